//! An object dictionary for the simulated nodes: typed entries, access rights, and the
//! CiA 301 rules for changing PDO parameters (only while the PDO is disabled).

use hob_canopen::sdo::{AbortCode, ObjectDictionary};
use std::collections::BTreeMap;

/// Access right of an entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    Ro,
    Rw,
}

#[derive(Debug, Clone, PartialEq, Eq)]
struct Entry {
    data: Vec<u8>,
    access: Access,
    /// Fixed size in bytes (`None`: any length, e.g. strings).
    size: Option<usize>,
    mappable: bool,
    /// The only values a write may bring (signed 8-bit entries such as 0x6060, 0x6098):
    /// any other is refused (by SDO: abort 0x0609_0030 value range exceeded).
    allowed: Option<Vec<i8>>,
    /// The least and greatest value an UNSIGNED32 entry may take (the gains 0x60F9,
    /// 0x60FB): any other is refused (by SDO: abort 0x0609_0030 value range exceeded).
    range: Option<(u32, u32)>,
}

/// A node's object dictionary.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Od {
    entries: BTreeMap<(u16, u8), Entry>,
}

impl Entry {
    fn accepts(&self, data: &[u8]) -> bool {
        let in_values = match &self.allowed {
            Some(values) => data.len() == 1 && values.contains(&(data[0] as i8)),
            None => true,
        };
        let in_range = match self.range {
            Some((lo, hi)) => {
                <[u8; 4]>::try_from(data).is_ok_and(|b| (lo..=hi).contains(&u32::from_le_bytes(b)))
            }
            None => true,
        };
        in_values && in_range
    }
}

impl Od {
    pub fn set(&mut self, index: u16, sub: u8, access: Access, data: &[u8]) -> &mut Self {
        self.entries.insert(
            (index, sub),
            Entry {
                data: data.to_vec(),
                access,
                size: Some(data.len()),
                mappable: index >= 0x2000,
                allowed: None,
                range: None,
            },
        );
        self
    }

    pub fn set_str(&mut self, index: u16, sub: u8, text: &str) -> &mut Self {
        self.entries.insert(
            (index, sub),
            Entry {
                data: text.as_bytes().to_vec(),
                access: Access::Ro,
                size: None,
                mappable: false,
                allowed: None,
                range: None,
            },
        );
        self
    }

    /// A writable string of any length (written by segmented SDO).
    pub fn set_rw_str(&mut self, index: u16, sub: u8, text: &str) -> &mut Self {
        self.entries.insert(
            (index, sub),
            Entry {
                data: text.as_bytes().to_vec(),
                access: Access::Rw,
                size: None,
                mappable: false,
                allowed: None,
                range: None,
            },
        );
        self
    }

    /// Restricts a 1-byte entry to `values` (see [`Self::accepts`]).
    pub fn allow_only(&mut self, index: u16, sub: u8, values: &[i8]) -> &mut Self {
        if let Some(e) = self.entries.get_mut(&(index, sub)) {
            e.allowed = Some(values.to_vec());
        }
        self
    }

    /// Restricts an UNSIGNED32 entry to `lo..=hi` (see [`Self::accepts`]).
    pub fn limit(&mut self, index: u16, sub: u8, lo: u32, hi: u32) -> &mut Self {
        if let Some(e) = self.entries.get_mut(&(index, sub)) {
            e.range = Some((lo, hi));
        }
        self
    }

    /// Whether `data` is a value the entry may take (always, unless restricted).
    pub fn accepts(&self, index: u16, sub: u8, data: &[u8]) -> bool {
        self.entries.get(&(index, sub)).is_none_or(|e| e.accepts(data))
    }

    pub fn u32(&self, index: u16, sub: u8) -> u32 {
        let d = self
            .entries
            .get(&(index, sub))
            .map(|e| e.data.as_slice())
            .unwrap_or(&[]);
        let mut b = [0u8; 4];
        let n = d.len().min(4);
        b[..n].copy_from_slice(&d[..n]);
        u32::from_le_bytes(b)
    }

    pub fn raw(&self, index: u16, sub: u8) -> Option<&[u8]> {
        self.entries.get(&(index, sub)).map(|e| e.data.as_slice())
    }

    /// Writes a value from the device side (ignores access rights).
    pub fn put(&mut self, index: u16, sub: u8, value: u64) {
        if let Some(e) = self.entries.get_mut(&(index, sub)) {
            let n = e.data.len().min(8);
            e.data[..n].copy_from_slice(&value.to_le_bytes()[..n]);
        }
    }

    pub fn exists(&self, index: u16, sub: u8) -> bool {
        self.entries.contains_key(&(index, sub))
    }

    pub fn size_bits(&self, index: u16, sub: u8) -> Option<usize> {
        self.entries.get(&(index, sub)).map(|e| e.data.len() * 8)
    }

    pub fn mappable(&self, index: u16, sub: u8) -> bool {
        self.entries.get(&(index, sub)).is_some_and(|e| e.mappable)
    }

    /// Whether the PDO whose communication object is `comm` is disabled (COB-ID bit 31).
    fn pdo_disabled(&self, comm: u16) -> bool {
        self.u32(comm, 1) & 0x8000_0000 != 0
    }
}

impl ObjectDictionary for Od {
    fn read(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
        match self.entries.get(&(index, sub)) {
            Some(e) => Ok(e.data.clone()),
            None if self.entries.keys().any(|(i, _)| *i == index) => Err(AbortCode::NO_SUBINDEX),
            None => Err(AbortCode::NO_OBJECT),
        }
    }

    fn write(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
        let comm = match index {
            0x1600..=0x1603 | 0x1A00..=0x1A03 => Some(index - 0x200),
            _ => None,
        };
        if let Some(comm) = comm {
            // CiA 301: the mapping may change only while the PDO is disabled, and the
            // number of entries only while it is 0 beforehand or set to 0.
            if !self.pdo_disabled(comm) {
                return Err(AbortCode::DEVICE_STATE);
            }
            if sub > 0 {
                let v = u32::from_le_bytes(
                    data.get(..4)
                        .and_then(|b| b.try_into().ok())
                        .ok_or(AbortCode::LENGTH_MISMATCH)?,
                );
                let (oi, os, bits) = ((v >> 16) as u16, (v >> 8) as u8, (v & 0xFF) as usize);
                if !self.mappable(oi, os) || self.size_bits(oi, os) != Some(bits) {
                    return Err(AbortCode::NOT_MAPPABLE);
                }
            } else {
                let n = usize::from(*data.first().ok_or(AbortCode::LENGTH_MISMATCH)?);
                let total: usize = (1..=n as u8).map(|s| (self.u32(index, s) & 0xFF) as usize).sum();
                if n > 8 || total > 64 {
                    return Err(AbortCode::PDO_TOO_LONG);
                }
            }
        }
        if !self.entries.contains_key(&(index, sub)) {
            let object_exists = self.entries.keys().any(|(i, _)| *i == index);
            return Err(if object_exists {
                AbortCode::NO_SUBINDEX
            } else {
                AbortCode::NO_OBJECT
            });
        }
        let Some(e) = self.entries.get_mut(&(index, sub)) else {
            return Err(AbortCode::NO_OBJECT);
        };
        if e.access == Access::Ro {
            return Err(AbortCode::READ_ONLY);
        }
        if let Some(size) = e.size
            && data.len() != size
        {
            return Err(if data.len() > size {
                AbortCode(0x0607_0012)
            } else {
                AbortCode(0x0607_0013)
            });
        }
        if !e.accepts(data) {
            return Err(AbortCode::INVALID_VALUE);
        }
        e.data = data.to_vec();
        Ok(())
    }
}
