//! A classic CAN 2.0A data frame (11-bit identifier, up to 8 bytes), `Copy`, no I/O.

/// One CAN frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct Frame {
    /// 11-bit identifier (COB-ID).
    pub id: u16,
    pub len: u8,
    pub data: [u8; 8],
}

impl Frame {
    /// A frame with `data` (at most 8 bytes; longer data is cut, which callers never do).
    pub fn new(id: u16, data: &[u8]) -> Self {
        let len = data.len().min(8);
        let mut d = [0u8; 8];
        d[..len].copy_from_slice(&data[..len]);
        Self {
            id: id & 0x7FF,
            len: len as u8,
            data: d,
        }
    }

    pub fn payload(&self) -> &[u8] {
        &self.data[..usize::from(self.len.min(8))]
    }

    /// `candump`-style text: `080#` or `181#11223344`.
    pub fn to_candump(&self) -> String {
        let mut s = format!("{:03X}#", self.id);
        for b in self.payload() {
            s.push_str(&format!("{b:02X}"));
        }
        s
    }

    /// Parses `candump -L` / `cansend` text `ID#HEX` (the part after the interface).
    pub fn from_candump(text: &str) -> Option<Self> {
        let (id, data) = text.trim().split_once('#')?;
        let id = u16::from_str_radix(id, 16).ok()?;
        if id > 0x7FF || data.len() % 2 != 0 || data.len() > 16 {
            return None;
        }
        let mut bytes = [0u8; 8];
        for (i, b) in bytes.iter_mut().enumerate().take(data.len() / 2) {
            *b = u8::from_str_radix(data.get(2 * i..2 * i + 2)?, 16).ok()?;
        }
        Some(Self::new(id, &bytes[..data.len() / 2]))
    }
}

/// CiA 301 predefined connection set: what a COB-ID is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cob {
    Nmt,
    Sync,
    Emcy(u8),
    Time,
    /// TPDO 1..=4 of a node (node to master).
    Tpdo(u8, u8),
    /// RPDO 1..=4 of a node (master to node).
    Rpdo(u8, u8),
    /// SDO server to client (response).
    SdoTx(u8),
    /// SDO client to server (request).
    SdoRx(u8),
    /// Heartbeat / boot-up of a node.
    Heartbeat(u8),
    Other,
}

pub const NMT: u16 = 0x000;
pub const SYNC: u16 = 0x080;

pub fn tpdo_id(n: u8, node: u8) -> u16 {
    0x080 + 0x100 * u16::from(n) + u16::from(node)
}
pub fn rpdo_id(n: u8, node: u8) -> u16 {
    0x100 + 0x100 * u16::from(n) + u16::from(node)
}
pub fn sdo_tx_id(node: u8) -> u16 {
    0x580 + u16::from(node)
}
pub fn sdo_rx_id(node: u8) -> u16 {
    0x600 + u16::from(node)
}
pub fn heartbeat_id(node: u8) -> u16 {
    0x700 + u16::from(node)
}
pub fn emcy_id(node: u8) -> u16 {
    0x080 + u16::from(node)
}

impl Cob {
    pub fn of(id: u16) -> Self {
        let node = (id & 0x7F) as u8;
        match (id & 0x780, node) {
            (0x000, 0) => Cob::Nmt,
            (0x080, 0) => Cob::Sync,
            (0x080, n) => Cob::Emcy(n),
            (0x100, 0) => Cob::Time,
            (0x180, n) => Cob::Tpdo(1, n),
            (0x200, n) => Cob::Rpdo(1, n),
            (0x280, n) => Cob::Tpdo(2, n),
            (0x300, n) => Cob::Rpdo(2, n),
            (0x380, n) => Cob::Tpdo(3, n),
            (0x400, n) => Cob::Rpdo(3, n),
            (0x480, n) => Cob::Tpdo(4, n),
            (0x500, n) => Cob::Rpdo(4, n),
            (0x580, n) => Cob::SdoTx(n),
            (0x600, n) => Cob::SdoRx(n),
            (0x700, n) => Cob::Heartbeat(n),
            _ => Cob::Other,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn predefined_connection_set() {
        assert_eq!(Cob::of(0x000), Cob::Nmt);
        assert_eq!(Cob::of(0x080), Cob::Sync);
        assert_eq!(Cob::of(0x082), Cob::Emcy(2));
        assert_eq!(Cob::of(0x182), Cob::Tpdo(1, 2));
        assert_eq!(Cob::of(0x203), Cob::Rpdo(1, 3));
        assert_eq!(Cob::of(0x284), Cob::Tpdo(2, 4));
        assert_eq!(Cob::of(0x305), Cob::Rpdo(2, 5));
        assert_eq!(Cob::of(0x585), Cob::SdoTx(5));
        assert_eq!(Cob::of(0x605), Cob::SdoRx(5));
        assert_eq!(Cob::of(0x705), Cob::Heartbeat(5));
        assert_eq!(tpdo_id(1, 2), 0x182);
        assert_eq!(rpdo_id(2, 3), 0x303);
        assert_eq!(sdo_rx_id(4), 0x604);
    }

    #[test]
    fn candump_text_round_trips() {
        let f = Frame::new(0x181, &[0x11, 0x22, 0x33, 0x44]);
        assert_eq!(f.to_candump(), "181#11223344");
        assert_eq!(Frame::from_candump("181#11223344"), Some(f));
        assert_eq!(Frame::from_candump("080#"), Some(Frame::new(0x080, &[])));
        assert_eq!(Frame::from_candump("800#00"), None);
        assert_eq!(Frame::from_candump("181#123"), None);
    }
}
