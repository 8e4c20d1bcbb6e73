//! The drives' loop gains as CiA 402 objects, in the units of hob's virtual drive
//! (`hob-sim`), and of a real drive that uses the same (CiA 402 leaves them to the
//! manufacturer):
//!
//! | object | name | type | unit | range |
//! |---|---|---|---|---|
//! | 0x60F9:01 | velocity control parameter set: gain | UNSIGNED32 | 1e-4 N m s/rad at the motor | 1 ..= 10 000 000 |
//! | 0x60F9:02 | velocity control parameter set: integration time constant (Ti = kp / ki) | UNSIGNED32 | us | 10 ..= 10 000 000 |
//! | 0x60FB:01 | position control parameter set: gain | UNSIGNED32 | 1e-3 1/s | 1 ..= 10 000 000 |
//!
//! The ranges are the machine file's (`commissioning::VELOCITY_KP_RANGE_NM_S_PER_RAD` and
//! the others) in these units: every record the file accepts can be written, and a drive
//! refuses a value outside them (SDO abort 0x0609_0030, value range exceeded). All three
//! are read and written by expedited SDO.
//!
//! `hob-master`'s boot reads them from the table drive after its identity (a drive that
//! aborts the upload has none, and they stay unknown), and writes a commissioned set first
//! when the machine file's `[commissioning.table_drive_gains]` names that drive.

use hob_canopen::cia402::object;
use hob_canopen::pdo::SdoWrite;
use hob_config::machine::commissioning::{
    POSITION_KV_RANGE_PER_S, TableDriveGainsRecord, VELOCITY_INTEGRAL_TIME_RANGE_MS,
    VELOCITY_KP_RANGE_NM_S_PER_RAD,
};

/// The three objects, in the order [`DriveGains::values`] holds them, with their names.
pub const OBJECTS: [(u16, u8, &str); 3] = [
    (object::VELOCITY_CONTROL_PARAMETERS, 1, "velocity control gain"),
    (
        object::VELOCITY_CONTROL_PARAMETERS,
        2,
        "velocity control integration time",
    ),
    (object::POSITION_CONTROL_PARAMETERS, 1, "position control gain"),
];

/// The objects' units in SI (N m s/rad, s, 1/s) per count.
const SI_PER_COUNT: [f64; 3] = [1e-4, 1e-6, 1e-3];

/// The values each object accepts, counts ([`OBJECTS`]' order).
pub fn ranges() -> [(u32, u32); 3] {
    let si = [
        VELOCITY_KP_RANGE_NM_S_PER_RAD,
        (
            VELOCITY_INTEGRAL_TIME_RANGE_MS.0 * 1e-3,
            VELOCITY_INTEGRAL_TIME_RANGE_MS.1 * 1e-3,
        ),
        POSITION_KV_RANGE_PER_S,
    ];
    std::array::from_fn(|i| {
        let c = |v: f64| (v / SI_PER_COUNT[i]).round() as u32;
        (c(si[i].0), c(si[i].1))
    })
}

/// A drive's three gains as its objects hold them, counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DriveGains {
    /// 0x60F9:01, 0x60F9:02, 0x60FB:01.
    pub values: [u32; 3],
}

impl DriveGains {
    /// The gains in SI (velocity gain N m s/rad, integral time s, position gain 1/s), in
    /// counts: None when one is outside its object's range.
    pub fn from_si(
        velocity_kp_nm_s_per_rad: f64,
        velocity_integral_time_s: f64,
        position_kv_per_s: f64,
    ) -> Option<Self> {
        let si = [
            velocity_kp_nm_s_per_rad,
            velocity_integral_time_s,
            position_kv_per_s,
        ];
        let ranges = ranges();
        let mut values = [0u32; 3];
        for i in 0..3 {
            let c = (si[i] / SI_PER_COUNT[i]).round();
            if c.is_nan() || c < f64::from(ranges[i].0) || c > f64::from(ranges[i].1) {
                return None;
            }
            values[i] = c as u32;
        }
        Some(Self { values })
    }

    /// Whether every value is one its object accepts.
    pub fn in_range(&self) -> bool {
        let r = ranges();
        (0..3).all(|i| (r[i].0..=r[i].1).contains(&self.values[i]))
    }

    pub fn velocity_kp_nm_s_per_rad(&self) -> f64 {
        f64::from(self.values[0]) * SI_PER_COUNT[0]
    }

    pub fn velocity_integral_time_s(&self) -> f64 {
        f64::from(self.values[1]) * SI_PER_COUNT[1]
    }

    pub fn velocity_integral_time_ms(&self) -> f64 {
        self.velocity_integral_time_s() * 1e3
    }

    pub fn position_kv_per_s(&self) -> f64 {
        f64::from(self.values[2]) * SI_PER_COUNT[2]
    }

    /// The SDO writes that set them.
    pub fn writes(&self) -> [SdoWrite; 3] {
        std::array::from_fn(|i| SdoWrite::new(OBJECTS[i].0, OBJECTS[i].1, self.values[i], 4))
    }
}

/// A commissioned set of gains for the table drive, and the drive it was measured on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CommissionedGains {
    pub gains: DriveGains,
    pub vendor_id: u32,
    pub product_code: u32,
    pub serial: u32,
}

impl CommissionedGains {
    /// The record's gains (None if one is outside its object's range, which a validated
    /// record never is).
    pub fn from_record(r: &TableDriveGainsRecord) -> Option<Self> {
        Some(Self {
            gains: DriveGains::from_si(
                r.velocity_kp_nm_s_per_rad,
                r.velocity_integral_time_ms * 1e-3,
                r.position_kv_per_s,
            )?,
            vendor_id: r.table_drive_vendor_id,
            product_code: r.table_drive_product_code,
            serial: r.table_drive_serial,
        })
    }

    /// Whether they were measured on the drive that names itself so (0x1018 sub 1, 2, 4).
    pub fn is_of(&self, vendor_id: u32, product_code: u32, serial: u32) -> bool {
        (self.vendor_id, self.product_code, self.serial) == (vendor_id, product_code, serial)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_units_are_the_documented_ones() {
        let g = DriveGains::from_si(1.91, 8.6e-3, 100.5).unwrap_or_else(|| panic!("in range"));
        assert_eq!(g.values, [19_100, 8_600, 100_500]);
        assert!((g.velocity_kp_nm_s_per_rad() - 1.91).abs() < 1e-12);
        assert!((g.velocity_integral_time_ms() - 8.6).abs() < 1e-12);
        assert!((g.position_kv_per_s() - 100.5).abs() < 1e-12);
        assert_eq!(ranges(), [(1, 10_000_000), (10, 10_000_000), (1, 10_000_000)]);
        assert_eq!(DriveGains::from_si(0.0, 8.6e-3, 100.5), None);
        assert_eq!(DriveGains::from_si(1.91, f64::NAN, 100.5), None);
        assert_eq!(DriveGains::from_si(1.91, 8.6e-3, 1e9), None);
        assert_eq!(g.writes()[1], SdoWrite::new(0x60F9, 2, 8_600, 4));
    }
}
