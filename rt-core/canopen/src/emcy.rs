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

pub use hob_wire::bus::emcy_text;

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
