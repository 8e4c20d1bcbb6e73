//! `[commissioning]`: what `hob commission` measured on this machine, written by it into
//! the machine file beside the value it set, so that the file says where its figure came
//! from and a hand edit that parts from the measurement is refused.
//!
//! ```toml
//! [commissioning.drive_delay]
//! utc = 2026-11-28T23:10:05Z     # when the table was jogged for it
//! found_us = 1128.6              # the delay the jogs showed
//! residual_arcsec = 0.4          # the table's angle against the shifted command, RMS
//! samples = 3998                 # cycles of steady jog the fit used
//! table_drive_vendor_id = 0x00000B0B     # the drive it was measured on (its 0x1018)
//! table_drive_product_code = 0x00020192
//! table_drive_serial = 0x00001002
//! ```
//!
//! `hob-rt` compares the table drive on the bus with the one the record names at boot: a
//! record of another drive (a file copied from another machine, a drive replaced) is no
//! commissioning, and START is refused until `hob commission delay` has run.

use crate::Problems;
use serde::{Deserialize, Serialize};

/// The measurements of the machine's commissioning (each absent until it was made).
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Commissioning {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive_delay: Option<DriveDelayRecord>,
}

/// The table drive's delay as `hob commission delay` found it.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct DriveDelayRecord {
    /// When it was measured (a TOML date-time in UTC).
    pub utc: toml::value::Datetime,
    /// The delay found, us (`control.drive_delay_us` is this, rounded).
    pub found_us: f64,
    /// RMS of the table's angle against the command shifted by the found delay, arcsec.
    pub residual_arcsec: f64,
    /// Cycles of steady jog the fit used.
    pub samples: u32,
    /// The table drive it was measured on, as it names itself (CiA 301 0x1018 sub 1, 2, 4).
    pub table_drive_vendor_id: u32,
    pub table_drive_product_code: u32,
    pub table_drive_serial: u32,
}

impl DriveDelayRecord {
    /// Whether it was measured on the drive that names itself so.
    pub fn is_of(&self, vendor_id: u32, product_code: u32, serial: u32) -> bool {
        (
            self.table_drive_vendor_id,
            self.table_drive_product_code,
            self.table_drive_serial,
        ) == (vendor_id, product_code, serial)
    }
}

/// A drive's identity as the record writes it.
pub fn identity_text(vendor_id: u32, product_code: u32, serial: u32) -> String {
    format!("vendor 0x{vendor_id:08X}, product 0x{product_code:08X}, serial 0x{serial:08X}")
}

/// How far `control.drive_delay_us` may stand from the measured delay: the measurement's
/// own uncertainty (the issue's +-20 us) and the rounding to a whole us.
pub const DELAY_AGREEMENT_US: f64 = 20.0;

impl Commissioning {
    /// Checks the records, and that `drive_delay_us` (the value in use) is the measured one.
    pub fn validate(&self, drive_delay_us: u32, max_delay_us: u32, p: &mut Problems) {
        let Some(d) = &self.drive_delay else {
            return;
        };
        let whole_utc = d.utc.date.is_some()
            && d.utc.time.is_some()
            && matches!(d.utc.offset, Some(toml::value::Offset::Z));
        p.require(whole_utc, "commissioning.drive_delay.utc", || {
            format!(
                "must be a date and time in UTC, as 2026-11-28T23:10:05Z (is {})",
                d.utc
            )
        });
        p.within(
            "commissioning.drive_delay.found_us",
            d.found_us,
            0.0,
            f64::from(max_delay_us),
            "us",
        );
        p.within(
            "commissioning.drive_delay.residual_arcsec",
            d.residual_arcsec,
            0.0,
            3600.0,
            "arcsec",
        );
        p.require(d.samples > 0, "commissioning.drive_delay.samples", || {
            "must be at least 1".into()
        });
        if d.found_us.is_finite() {
            p.require(
                (f64::from(drive_delay_us) - d.found_us).abs() <= DELAY_AGREEMENT_US,
                "control.drive_delay_us",
                || {
                    format!(
                        "is {drive_delay_us} us, but the commissioning measured {:.1} us \
                         (commissioning.drive_delay.found_us, {}): run `hob commission delay` \
                         again, or remove [commissioning.drive_delay] to use a value by hand",
                        d.found_us, d.utc
                    )
                },
            );
        }
    }
}
