//! CiA 301 emergency messages, with the error code's meaning for the operator.

use super::frame::{Frame, emcy_id};

/// One EMCY message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Emcy {
    pub node: u8,
    /// Emergency error code (CiA 301 table 21, CiA 402 additions).
    pub code: u16,
    /// Error register (0x1001).
    pub register: u8,
    pub vendor: [u8; 5],
}

impl Emcy {
    pub fn frame(&self) -> Frame {
        let c = self.code.to_le_bytes();
        let v = self.vendor;
        Frame::new(
            emcy_id(self.node),
            &[c[0], c[1], self.register, v[0], v[1], v[2], v[3], v[4]],
        )
    }

    pub fn parse(f: &Frame) -> Option<Self> {
        if !(0x081..=0x0FF).contains(&f.id) || f.len != 8 {
            return None;
        }
        let d = f.data;
        Some(Self {
            node: (f.id - 0x080) as u8,
            code: u16::from_le_bytes([d[0], d[1]]),
            register: d[2],
            vendor: [d[3], d[4], d[5], d[6], d[7]],
        })
    }

    /// The error code in words (by its class when not listed).
    pub fn text(&self) -> &'static str {
        emcy_text(self.code)
    }
}

/// Meaning of an emergency error code.
pub fn emcy_text(code: u16) -> &'static str {
    match code {
        0x0000 => "error reset or no error",
        0x1000 => "generic error",
        0x2310 => "continuous over-current",
        0x2320 => "short circuit at outputs",
        0x3210 => "DC link over-voltage",
        0x3220 => "DC link under-voltage",
        0x4210 => "excess temperature device",
        0x5441 => "input stage: STO / enable input",
        0x6010 => "software reset (watchdog)",
        0x7303 => "resolver / encoder 1 fault",
        0x7305 => "incremental sensor 1 fault",
        0x8110 => "CAN overrun (objects lost)",
        0x8120 => "CAN in error passive mode",
        0x8130 => "life guard or heartbeat error",
        0x8140 => "recovered from bus off",
        0x8210 => "PDO not processed due to length error",
        0x8611 => "following error",
        0xFF00..=0xFFFF => "device specific",
        c => match c >> 12 {
            0x1 => "generic error",
            0x2 => "current",
            0x3 => "voltage",
            0x4 => "temperature",
            0x5 => "device hardware",
            0x6 => "device software",
            0x7 => "additional modules",
            0x8 => "monitoring / communication",
            0x9 => "external error",
            0xF => "additional functions",
            _ => "unknown",
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn emcy_layout() {
        // CiA 301 7.2.7.3.1: code (2, LE), error register (1), vendor (5).
        let e = Emcy {
            node: 3,
            code: 0x8611,
            register: 0x20,
            vendor: [0; 5],
        };
        assert_eq!(e.frame().to_candump(), "083#1186200000000000");
        assert_eq!(Emcy::parse(&e.frame()), Some(e));
        assert_eq!(e.text(), "following error");
        assert_eq!(emcy_text(0x2311), "current");
        assert_eq!(
            Emcy::parse(&Frame::new(0x080, &[0; 8])),
            None,
            "SYNC is not an EMCY"
        );
    }
}
