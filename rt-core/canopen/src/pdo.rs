//! CiA 301 process data objects: mapping entries, the SDO sequence that configures a PDO
//! (disable, map, enable), and packing values into and out of a PDO's bytes.

use super::frame::Frame;

/// Most entries in one PDO.
pub const MAX_ENTRIES: usize = 8;

/// One mapped object: `index:sub`, `bits` long (a multiple of 8 here).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MapEntry {
    pub index: u16,
    pub sub: u8,
    pub bits: u8,
}

impl MapEntry {
    pub const fn new(index: u16, sub: u8, bits: u8) -> Self {
        Self { index, sub, bits }
    }

    /// The 32-bit mapping value written to 0x16xx / 0x1Axx: index, sub-index, length.
    pub fn encode(&self) -> u32 {
        u32::from(self.index) << 16 | u32::from(self.sub) << 8 | u32::from(self.bits)
    }

    pub fn decode(v: u32) -> Self {
        Self {
            index: (v >> 16) as u16,
            sub: (v >> 8) as u8,
            bits: v as u8,
        }
    }
}

/// Direction of a PDO, seen from the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Node receives (master to node): 0x1400 / 0x1600.
    Rpdo,
    /// Node transmits (node to master): 0x1800 / 0x1A00.
    Tpdo,
}

/// A PDO's communication and mapping parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pdo {
    pub direction: Direction,
    /// PDO number 1..=4.
    pub number: u8,
    pub cob_id: u16,
    /// 1 = synchronous (every SYNC), 255 = event-driven (manufacturer / on change).
    pub transmission_type: u8,
    /// Minimum time between two transmissions, 100 us units (TPDO sub 3).
    pub inhibit_100us: u16,
    /// Event timer (TPDO sub 5), ms: an event-driven TPDO is sent again after this long
    /// even without a change, so a lost frame is recovered. 0 = off.
    pub event_timer_ms: u16,
    entries: [MapEntry; MAX_ENTRIES],
    count: usize,
}

/// One SDO write of a configuration sequence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SdoWrite {
    pub index: u16,
    pub sub: u8,
    pub value: u32,
    /// Size of the object in bytes.
    pub size: u8,
}

impl SdoWrite {
    pub const fn new(index: u16, sub: u8, value: u32, size: u8) -> Self {
        Self {
            index,
            sub,
            value,
            size,
        }
    }

    pub fn bytes(&self) -> [u8; 4] {
        self.value.to_le_bytes()
    }
}

impl Pdo {
    pub fn new(
        direction: Direction,
        number: u8,
        cob_id: u16,
        transmission_type: u8,
        entries: &[MapEntry],
    ) -> Self {
        let mut e = [MapEntry::default(); MAX_ENTRIES];
        let count = entries.len().min(MAX_ENTRIES);
        e[..count].copy_from_slice(&entries[..count]);
        Self {
            direction,
            number,
            cob_id,
            transmission_type,
            inhibit_100us: 0,
            event_timer_ms: 0,
            entries: e,
            count,
        }
    }

    pub fn with_inhibit_100us(mut self, inhibit: u16) -> Self {
        self.inhibit_100us = inhibit;
        self
    }

    pub fn with_event_timer_ms(mut self, ms: u16) -> Self {
        self.event_timer_ms = ms;
        self
    }

    pub fn entries(&self) -> &[MapEntry] {
        &self.entries[..self.count]
    }

    /// Payload length in bytes.
    pub fn len_bytes(&self) -> usize {
        self.entries().iter().map(|e| usize::from(e.bits) / 8).sum()
    }

    /// Communication parameter object (0x1400 + n - 1 or 0x1800 + n - 1).
    pub fn comm_index(&self) -> u16 {
        let base = match self.direction {
            Direction::Rpdo => 0x1400,
            Direction::Tpdo => 0x1800,
        };
        base + u16::from(self.number) - 1
    }

    /// Mapping parameter object (0x1600 + n - 1 or 0x1A00 + n - 1).
    pub fn map_index(&self) -> u16 {
        self.comm_index() + 0x200
    }

    /// The CiA 301 configuration sequence: disable (COB-ID bit 31), transmission type,
    /// inhibit time, clear the mapping, write the entries, set their number, enable.
    pub fn configuration(&self) -> Vec<SdoWrite> {
        let comm = self.comm_index();
        let map = self.map_index();
        let w = SdoWrite::new;
        let mut out = vec![
            w(comm, 1, 0x8000_0000 | u32::from(self.cob_id), 4),
            w(comm, 2, u32::from(self.transmission_type), 1),
        ];
        if self.direction == Direction::Tpdo {
            out.push(w(comm, 3, u32::from(self.inhibit_100us), 2));
            out.push(w(comm, 5, u32::from(self.event_timer_ms), 2));
        }
        out.push(w(map, 0, 0, 1));
        for (i, e) in self.entries().iter().enumerate() {
            out.push(w(map, i as u8 + 1, e.encode(), 4));
        }
        out.push(w(map, 0, self.count as u32, 1));
        out.push(w(comm, 1, u32::from(self.cob_id), 4));
        out
    }

    /// A frame carrying `values` (raw, little-endian, one per entry).
    pub fn pack(&self, values: &[u64]) -> Frame {
        let mut data = [0u8; 8];
        let mut pos = 0;
        for (e, v) in self.entries().iter().zip(values) {
            let n = usize::from(e.bits) / 8;
            data[pos..pos + n].copy_from_slice(&v.to_le_bytes()[..n]);
            pos += n;
        }
        Frame::new(self.cob_id, &data[..pos])
    }

    /// Raw values of the entries from a frame; `None` if the length does not match.
    pub fn unpack(&self, f: &Frame) -> Option<[u64; MAX_ENTRIES]> {
        if f.id != self.cob_id || usize::from(f.len) != self.len_bytes() {
            return None;
        }
        let mut out = [0u64; MAX_ENTRIES];
        let mut pos = 0;
        for (slot, e) in out.iter_mut().zip(self.entries()) {
            let n = usize::from(e.bits) / 8;
            let mut b = [0u8; 8];
            b[..n].copy_from_slice(&f.data[pos..pos + n]);
            *slot = u64::from_le_bytes(b);
            pos += n;
        }
        Some(out)
    }
}

/// A raw 32-bit PDO value as a signed position.
pub fn as_i32(v: u64) -> i32 {
    v as u32 as i32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cia402::object;

    #[test]
    fn mapping_value_layout() {
        // CiA 301 7.5.2.36: index (16) | sub-index (8) | length in bits (8).
        assert_eq!(
            MapEntry::new(object::TARGET_POSITION, 0, 32).encode(),
            0x607A_0020
        );
        assert_eq!(MapEntry::new(object::STATUSWORD, 0, 16).encode(), 0x6041_0010);
        assert_eq!(MapEntry::decode(0x6000_0108), MapEntry::new(0x6000, 1, 8));
    }

    #[test]
    fn configuration_sequence_disables_maps_and_enables() {
        let p = Pdo::new(
            Direction::Tpdo,
            1,
            0x182,
            1,
            &[MapEntry::new(0x6064, 0, 32), MapEntry::new(0x2112, 0, 32)],
        )
        .with_inhibit_100us(0);
        let seq: Vec<(u16, u8, u32)> = p
            .configuration()
            .iter()
            .map(|w| (w.index, w.sub, w.value))
            .collect();
        assert_eq!(
            seq,
            vec![
                (0x1800, 1, 0x8000_0182),
                (0x1800, 2, 1),
                (0x1800, 3, 0),
                (0x1800, 5, 0),
                (0x1A00, 0, 0),
                (0x1A00, 1, 0x6064_0020),
                (0x1A00, 2, 0x2112_0020),
                (0x1A00, 0, 2),
                (0x1800, 1, 0x0000_0182),
            ]
        );
        let r = Pdo::new(Direction::Rpdo, 2, 0x303, 255, &[MapEntry::new(0x6040, 0, 16)]);
        assert_eq!(r.comm_index(), 0x1401);
        assert_eq!(r.map_index(), 0x1601);
        assert!(
            r.configuration().iter().all(|w| w.index != 0x1401 || w.sub != 3),
            "no inhibit on an RPDO"
        );
    }

    #[test]
    fn pack_and_unpack_little_endian() {
        let p = Pdo::new(
            Direction::Tpdo,
            1,
            0x182,
            1,
            &[MapEntry::new(0x6064, 0, 32), MapEntry::new(0x6041, 0, 16)],
        );
        let f = p.pack(&[(-2i32) as u32 as u64, 0x0237]);
        assert_eq!(f.to_candump(), "182#FEFFFFFF3702");
        let v = p.unpack(&f).unwrap();
        assert_eq!(as_i32(v[0]), -2);
        assert_eq!(v[1], 0x0237);
        assert_eq!(p.unpack(&Frame::new(0x182, &[0; 4])), None, "length mismatch");
    }
}
