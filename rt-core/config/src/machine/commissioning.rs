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
//!
//! ```toml
//! [commissioning.spindle_encoder]
//! utc = 2026-11-29T02:10:05Z     # when the spindle was run for it
//! error_arcsec = 15.2            # the encoder's error once per turn (its disc's eccentricity)
//! error_2_arcsec = 4.1           # ... twice and three times per turn (reported, not corrected)
//! error_3_arcsec = 1.6
//! swing_arcsec = 19.8            # the spindle's TRUE once-per-turn swing at reference_rpm
//! swing_phase_deg = 131.0        # its phase against the error's once-per-turn sine
//! swing_tau_s = 0.027            # J/D of the spindle against its drive: how the swing scales with speed
//! reference_rpm = 200.0
//! speeds_rpm = [60.0, 90.0, 130.0, 200.0]
//! misfit_arcsec = 0.5            # the once-per-turn model against the speeds, RMS
//! error_uncertainty_arcsec = 0.9 # how far error_arcsec may be off
//! ```
//!
//! ```toml
//! [commissioning.table_backlash]
//! utc = 2026-11-29T06:10:05Z     # when the table was reversed for it
//! lost_motion_arcsec = 25.3      # the table drive's travel that did not reach the table
//! uncertainty_arcsec = 0.2       # how far it may be off (the fit's standard error, and
//!                                # the two directions' disagreement on the gauge's scale)
//! speed_deg_min = 3.0            # how fast the table was turned
//! samples = 412                  # gauge readings the fit used
//! ```
//!
//! The backlash is recorded for the builder (the commissioning report, the machine's
//! papers); the loop does not use it: a hobbing cut turns the table one way only, and every
//! approach of the table (the tooth phase of an interrupted part) comes from the same side.
//!
//! ```toml
//! [commissioning.table_drive_gains]
//! utc = 2026-11-29T09:10:05Z               # when the table's frequency response was measured
//! velocity_kp_nm_s_per_rad = 1.91          # written to the drive (0x60F9:01) ...
//! velocity_integral_time_ms = 8.6          # ... (0x60F9:02, Ti = kp / ki) ...
//! position_kv_per_s = 100.5                # ... (0x60FB:01)
//! previous_velocity_kp_nm_s_per_rad = 7.5  # the drive's own values when measured: the old
//! previous_velocity_integral_time_ms = 1.6 # values kept, to go back to by hand
//! previous_position_kv_per_s = 377.0
//! velocity_gain_margin_db = 9.1            # the margins of the written gains on the fitted model
//! velocity_phase_margin_deg = 45.0
//! position_gain_margin_db = 8.9
//! position_phase_margin_deg = 41.0
//! mesh_antiresonance_hz = 50.3             # the mechanism as the measurement found it
//! mesh_resonance_hz = 137.0
//! table_drive_vendor_id = 0x00000B0B       # the drive it was measured on (0x1018), as drive_delay's
//! table_drive_product_code = 0x00020192
//! table_drive_serial = 0x00001002
//! ```
//!
//! `hob-rt`'s boot writes the three gains to the table drive (and reads them back) only when
//! the record names the table drive on the bus; a record of another drive is not written,
//! and hob-rt says so. A record of a proposal with less than [`MIN_GAIN_MARGIN_DB`] or
//! [`MIN_PHASE_MARGIN_DEG`] is refused: an unstable or barely stable tuning is never written.
//!
//! The loop identifies the once-per-turn part of the reading anew at each start (the counter
//! is incremental, so its phase is new), and cannot tell an error of the disc from a true
//! swing of the spindle at one speed. The record tells them apart: both are fixed to the
//! spindle, so their ratio holds across power cycles, and the loop corrects only the
//! encoder's share of what it identifies ([`SpindleEncoderRecord`]); the table follows the
//! true swing. Without the record the loop corrects all of it (a swing taken for an error).

use crate::Problems;
use serde::{Deserialize, Serialize};

/// The measurements of the machine's commissioning (each absent until it was made).
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Commissioning {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive_delay: Option<DriveDelayRecord>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spindle_encoder: Option<SpindleEncoderRecord>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub table_backlash: Option<TableBacklashRecord>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub table_drive_gains: Option<TableDriveGainsRecord>,
}

/// The table drive's gains as `hob commission` proposed them from the table's frequency
/// response through the worm, and the operator confirmed: the values written to the drive
/// at boot, the drive's own values they replaced, the margins and the mechanism's modes.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TableDriveGainsRecord {
    pub utc: toml::value::Datetime,
    /// The velocity loop's proportional gain, N m s/rad at the motor.
    pub velocity_kp_nm_s_per_rad: f64,
    /// The velocity loop's integral time (kp / ki), ms.
    pub velocity_integral_time_ms: f64,
    /// The position loop's gain, 1/s.
    pub position_kv_per_s: f64,
    /// The drive's own gains when it was measured (the old values kept).
    pub previous_velocity_kp_nm_s_per_rad: f64,
    pub previous_velocity_integral_time_ms: f64,
    pub previous_position_kv_per_s: f64,
    /// The margins of the written gains on the fitted model of the mechanism.
    pub velocity_gain_margin_db: f64,
    pub velocity_phase_margin_deg: f64,
    pub position_gain_margin_db: f64,
    pub position_phase_margin_deg: f64,
    /// The worm mesh's antiresonance and resonance as the measurement found them, Hz.
    pub mesh_antiresonance_hz: f64,
    pub mesh_resonance_hz: f64,
    /// The table drive it was measured on (CiA 301 0x1018 sub 1, 2, 4).
    pub table_drive_vendor_id: u32,
    pub table_drive_product_code: u32,
    pub table_drive_serial: u32,
}

/// The least gain margin a record of gains may hold, dB.
pub const MIN_GAIN_MARGIN_DB: f64 = 3.0;
/// The least phase margin a record of gains may hold, deg.
pub const MIN_PHASE_MARGIN_DEG: f64 = 30.0;
/// The ranges a drive gain may take (a record's, and the drives' objects'): the velocity
/// loop's gain, N m s/rad ...
pub const VELOCITY_KP_RANGE_NM_S_PER_RAD: (f64, f64) = (1e-4, 1000.0);
/// ... its integral time, ms ...
pub const VELOCITY_INTEGRAL_TIME_RANGE_MS: (f64, f64) = (0.01, 10_000.0);
/// ... and the position loop's gain, 1/s.
pub const POSITION_KV_RANGE_PER_S: (f64, f64) = (0.001, 10_000.0);

impl TableDriveGainsRecord {
    /// Whether it was measured on the drive that names itself so.
    pub fn is_of(&self, vendor_id: u32, product_code: u32, serial: u32) -> bool {
        (
            self.table_drive_vendor_id,
            self.table_drive_product_code,
            self.table_drive_serial,
        ) == (vendor_id, product_code, serial)
    }

    fn validate(&self, p: &mut Problems) {
        const K: &str = "commissioning.table_drive_gains";
        utc_whole(&self.utc, &format!("{K}.utc"), p);
        let (kp, ti, kv) = (
            VELOCITY_KP_RANGE_NM_S_PER_RAD,
            VELOCITY_INTEGRAL_TIME_RANGE_MS,
            POSITION_KV_RANGE_PER_S,
        );
        for (key, v, (lo, hi), unit) in [
            (
                "velocity_kp_nm_s_per_rad",
                self.velocity_kp_nm_s_per_rad,
                kp,
                "N m s/rad",
            ),
            (
                "velocity_integral_time_ms",
                self.velocity_integral_time_ms,
                ti,
                "ms",
            ),
            ("position_kv_per_s", self.position_kv_per_s, kv, "1/s"),
            (
                "previous_velocity_kp_nm_s_per_rad",
                self.previous_velocity_kp_nm_s_per_rad,
                kp,
                "N m s/rad",
            ),
            (
                "previous_velocity_integral_time_ms",
                self.previous_velocity_integral_time_ms,
                ti,
                "ms",
            ),
            (
                "previous_position_kv_per_s",
                self.previous_position_kv_per_s,
                kv,
                "1/s",
            ),
            (
                "velocity_gain_margin_db",
                self.velocity_gain_margin_db,
                (MIN_GAIN_MARGIN_DB, 100.0),
                "dB",
            ),
            (
                "position_gain_margin_db",
                self.position_gain_margin_db,
                (MIN_GAIN_MARGIN_DB, 100.0),
                "dB",
            ),
            (
                "velocity_phase_margin_deg",
                self.velocity_phase_margin_deg,
                (MIN_PHASE_MARGIN_DEG, 180.0),
                "deg",
            ),
            (
                "position_phase_margin_deg",
                self.position_phase_margin_deg,
                (MIN_PHASE_MARGIN_DEG, 180.0),
                "deg",
            ),
            (
                "mesh_antiresonance_hz",
                self.mesh_antiresonance_hz,
                (0.1, 10_000.0),
                "Hz",
            ),
            ("mesh_resonance_hz", self.mesh_resonance_hz, (0.1, 10_000.0), "Hz"),
        ] {
            p.within(&format!("{K}.{key}"), v, lo, hi, unit);
        }
        p.require(
            // A value that is no number is refused by its range above, not here too.
            self.mesh_antiresonance_hz.is_nan()
                || self.mesh_resonance_hz.is_nan()
                || self.mesh_antiresonance_hz < self.mesh_resonance_hz,
            &format!("{K}.mesh_antiresonance_hz"),
            || {
                format!(
                    "must be below mesh_resonance_hz (is {} Hz against {} Hz): a motor driving \
                     a load through a spring sees the antiresonance first",
                    self.mesh_antiresonance_hz, self.mesh_resonance_hz
                )
            },
        );
    }
}

/// The table drive's lost motion at a reversal, as `hob commission backlash` found it
/// against a gauge on the table: the worm's backlash and the mesh's wind-up under the
/// table's friction (twice the friction torque over the mesh's stiffness).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TableBacklashRecord {
    pub utc: toml::value::Datetime,
    /// Arcsec of the table.
    pub lost_motion_arcsec: f64,
    pub uncertainty_arcsec: f64,
    pub speed_deg_min: f64,
    pub samples: u32,
}

/// The largest lost motion a record may hold, arcsec of the table: a tenth of a degree is
/// a worm drive worn out, not one to commission.
pub const MAX_BACKLASH_RECORD_ARCSEC: f64 = 360.0;

impl TableBacklashRecord {
    fn validate(&self, p: &mut Problems) {
        const K: &str = "commissioning.table_backlash";
        utc_whole(&self.utc, &format!("{K}.utc"), p);
        for (key, v) in [
            ("lost_motion_arcsec", self.lost_motion_arcsec),
            ("uncertainty_arcsec", self.uncertainty_arcsec),
        ] {
            p.within(
                &format!("{K}.{key}"),
                v,
                0.0,
                MAX_BACKLASH_RECORD_ARCSEC,
                "arcsec",
            );
        }
        p.within(
            &format!("{K}.speed_deg_min"),
            self.speed_deg_min,
            0.01,
            1200.0,
            "deg/min",
        );
        p.require(self.samples > 0, &format!("{K}.samples"), || {
            "must be at least 1".into()
        });
    }
}

/// The spindle encoder's error told apart from the spindle's true swing, as `hob commission
/// encoder` found them over several speeds.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SpindleEncoderRecord {
    pub utc: toml::value::Datetime,
    /// The encoder's error once, twice, three times per turn, amplitude arcsec of spindle.
    pub error_arcsec: f64,
    pub error_2_arcsec: f64,
    pub error_3_arcsec: f64,
    /// The spindle's true once-per-turn swing at `reference_rpm`, arcsec of spindle ...
    pub swing_arcsec: f64,
    /// ... its phase against the error's once-per-turn sine, deg ...
    pub swing_phase_deg: f64,
    /// ... and how it scales with speed: the swing of a torque against the drive's slip
    /// (D) and the spindle's inertia (J) goes as 1 / (W (1 + i W tau)), tau = J / D, s.
    pub swing_tau_s: f64,
    pub reference_rpm: f64,
    /// The speeds it was measured at.
    pub speeds_rpm: Vec<f64>,
    /// RMS misfit of the once-per-turn model over those speeds, arcsec.
    pub misfit_arcsec: f64,
    /// How far `error_arcsec` may be from the truth, arcsec (its standard error, and its
    /// spread over the swing's dynamics the speeds could not tell apart).
    pub error_uncertainty_arcsec: f64,
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
    pub fn validate(&self, drive_delay_us: u32, max_delay_us: u32, max_spindle_rpm: f64, p: &mut Problems) {
        if let Some(e) = &self.spindle_encoder {
            e.validate(max_spindle_rpm, p);
        }
        if let Some(b) = &self.table_backlash {
            b.validate(p);
        }
        if let Some(g) = &self.table_drive_gains {
            g.validate(p);
        }
        let Some(d) = &self.drive_delay else {
            return;
        };
        utc_whole(&d.utc, "commissioning.drive_delay.utc", p);
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

fn utc_whole(utc: &toml::value::Datetime, key: &str, p: &mut Problems) {
    let whole =
        utc.date.is_some() && utc.time.is_some() && matches!(utc.offset, Some(toml::value::Offset::Z));
    p.require(whole, key, || {
        format!("must be a date and time in UTC, as 2026-11-28T23:10:05Z (is {utc})")
    });
}

/// A held spindle (the loop's SPINDLE HOLD, what `hob commission encoder` measures with)
/// keeps its speed trim once it has been at speed this long, s: four of the trim's time
/// constants; the VFD's reference then stands still, so the spindle turns as its drive and
/// its inertia make it, not as the loop's reaction to the reading's once-per-turn error
/// (through a coupler that updates the reference every 50 ms) would. The loop
/// (`hob_control`) and the procedure (`hob_commission::encoder`, which reads no earlier)
/// both take it from here.
pub const HELD_SPINDLE_TRIM_FREEZE_S: f64 = 8.0;

/// The largest once-per-turn figure a record may hold, arcsec: a tenth of a degree, the
/// loop's largest correction (`hob_control::eccentricity::MAX_CORRECTION_DEG`); more is a
/// broken encoder or a spindle that is not fit to cut.
pub const MAX_ENCODER_RECORD_ARCSEC: f64 = 360.0;

impl SpindleEncoderRecord {
    fn validate(&self, max_spindle_rpm: f64, p: &mut Problems) {
        const K: &str = "commissioning.spindle_encoder";
        utc_whole(&self.utc, &format!("{K}.utc"), p);
        for (key, v) in [
            ("error_arcsec", self.error_arcsec),
            ("error_2_arcsec", self.error_2_arcsec),
            ("error_3_arcsec", self.error_3_arcsec),
            ("swing_arcsec", self.swing_arcsec),
        ] {
            p.within(&format!("{K}.{key}"), v, 0.0, MAX_ENCODER_RECORD_ARCSEC, "arcsec");
        }
        p.within(
            &format!("{K}.swing_phase_deg"),
            self.swing_phase_deg,
            -180.0,
            180.0,
            "deg",
        );
        p.within(&format!("{K}.swing_tau_s"), self.swing_tau_s, 0.0, 100.0, "s");
        p.within(
            &format!("{K}.reference_rpm"),
            self.reference_rpm,
            1.0,
            max_spindle_rpm,
            "rpm",
        );
        p.within(
            &format!("{K}.misfit_arcsec"),
            self.misfit_arcsec,
            0.0,
            3600.0,
            "arcsec",
        );
        p.within(
            &format!("{K}.error_uncertainty_arcsec"),
            self.error_uncertainty_arcsec,
            0.0,
            MAX_ENCODER_RECORD_ARCSEC,
            "arcsec",
        );
        p.require(self.speeds_rpm.len() >= 3, &format!("{K}.speeds_rpm"), || {
            format!("must name at least 3 speeds (names {})", self.speeds_rpm.len())
        });
        for (n, v) in self.speeds_rpm.iter().enumerate() {
            p.within(&format!("{K}.speeds_rpm[{n}]"), *v, 1.0, max_spindle_rpm, "rpm");
        }
    }

    /// What the loop needs of it.
    pub fn swing(&self) -> SpindleSwing {
        let (s, c) = self.swing_phase_deg.to_radians().sin_cos();
        SpindleSwing {
            error_arcsec: self.error_arcsec,
            swing_sin_arcsec: self.swing_arcsec * c,
            swing_cos_arcsec: self.swing_arcsec * s,
            tau_s: self.swing_tau_s,
            reference_rpm: self.reference_rpm,
        }
    }
}

/// How a true once-per-turn swing at `rpm` stands to the same torque's swing at
/// `reference_rpm`, complex (re, im): a torque once per turn against the spindle's inertia J
/// and the drive's slip D moves it by `T / (i W D (1 + i W tau))` (W the turn's angular
/// frequency, signed with the direction: a reversed spindle sees the conjugate; tau = J / D).
/// The loop's slow trim of the VFD's reference does not act on it: while the loop identifies
/// the once-per-turn sine, it takes it out of the speed the trim sees. Written once, for the
/// commissioning's fit over the speeds and the loop's share of what it identifies.
pub fn swing_scale(rpm: f64, reference_rpm: f64, tau_s: f64) -> (f64, f64) {
    let w = |rpm: f64| rpm * std::f64::consts::TAU / 60.0;
    // i w (1 + i w tau) = -tau w^2 + i w, at the reference over the same at rpm.
    let d = |rpm: f64| (-tau_s * w(rpm) * w(rpm), w(rpm));
    let ((nr, ni), (dr, di)) = (d(reference_rpm), d(rpm));
    let d2 = dr * dr + di * di;
    ((nr * dr + ni * di) / d2, (ni * dr - nr * di) / d2)
}

/// The spindle's true once-per-turn swing beside its encoder's error, in the error's own
/// phase: what lets the loop keep only the encoder's share of a once-per-turn sine it
/// identified at one speed.
///
/// Complex numbers here are a once-per-turn sine `S sin(theta) + C cos(theta)` written
/// `S + iC` (`amplitude e^(i phase)` for `amplitude sin(theta + phase)`): the response of a
/// linear system to it is the product, and moving the counter's zero turns every such
/// number by the same angle, so their ratios hold across power cycles.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpindleSwing {
    /// The encoder's error once per turn, arcsec (real: the phase reference).
    pub error_arcsec: f64,
    /// The swing at `reference_rpm`, its sine and cosine parts in the error's phase, arcsec.
    pub swing_sin_arcsec: f64,
    pub swing_cos_arcsec: f64,
    pub tau_s: f64,
    pub reference_rpm: f64,
}

impl SpindleSwing {
    /// How the swing at `rpm` stands to the swing at `reference_rpm` ([`swing_scale`]).
    pub fn scale(&self, rpm: f64) -> (f64, f64) {
        swing_scale(rpm, self.reference_rpm, self.tau_s)
    }

    /// The factor (complex, re and im) that leaves the encoder's share of a once-per-turn
    /// sine identified at `rpm` (which is the error plus the swing at that speed), for a
    /// reading that counts up (one that counts down sees the conjugate of every
    /// once-per-turn sine, and of this factor): `a /
    /// (a + b g(rpm))`. None where the two all but cancel at that speed (what is left is
    /// under a tenth of the larger): the identified sine then says nothing of either, and
    /// the caller learns nothing from it.
    pub fn encoder_share(&self, rpm: f64) -> Option<(f64, f64)> {
        if !(rpm.is_finite() && rpm > 0.0) {
            return None;
        }
        let (gr, gi) = self.scale(rpm);
        let (bs, bc) = (self.swing_sin_arcsec, self.swing_cos_arcsec);
        let (sr, si) = (bs * gr - bc * gi, bs * gi + bc * gr);
        let (tr, ti) = (self.error_arcsec + sr, si);
        let total = tr.hypot(ti);
        if total.is_nan() || total < 0.1 * self.error_arcsec.max(sr.hypot(si)) || total == 0.0 {
            return None;
        }
        let t2 = total * total;
        Some((self.error_arcsec * tr / t2, -self.error_arcsec * ti / t2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record() -> SpindleEncoderRecord {
        SpindleEncoderRecord {
            utc: "2026-11-29T02:10:05Z".parse().unwrap_or_else(|e| panic!("{e}")),
            error_arcsec: 15.2,
            error_2_arcsec: 4.1,
            error_3_arcsec: 1.6,
            swing_arcsec: 19.8,
            swing_phase_deg: 131.0,
            swing_tau_s: 0.027,
            reference_rpm: 200.0,
            speeds_rpm: vec![60.0, 90.0, 130.0, 200.0],
            misfit_arcsec: 0.5,
            error_uncertainty_arcsec: 0.9,
        }
    }

    fn problems(r: &SpindleEncoderRecord) -> Vec<String> {
        let mut p = Problems::default();
        r.validate(212.2, &mut p);
        p.as_slice()
            .iter()
            .map(|m| format!("{}: {}", m.key, m.message))
            .collect()
    }

    /// (re, im) products, for the checks.
    fn mul(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
        (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
    }

    proptest::proptest! {
        #[test]
        fn the_share_of_error_plus_swing_is_the_error(
            error in 0.5f64..200.0,
            swing in 0.0f64..200.0,
            phase in -180.0f64..180.0,
            tau in 0.0f64..1.0,
            reference in 20.0f64..212.0,
            rpm in 20.0f64..212.0,
            turn in 0.0f64..6.3,
        ) {
            let r = SpindleEncoderRecord {
                error_arcsec: error,
                swing_arcsec: swing,
                swing_phase_deg: phase,
                swing_tau_s: tau,
                reference_rpm: reference,
                ..record()
            };
            let sw = r.swing();
            // What the loop identifies at rpm, in a counter frame turned by `turn`: the
            // error plus the swing's response at that speed, independently written as
            // T / (i w D (1 + i w tau)) normalised at the reference.
            let resp = |rpm: f64| {
                let w = rpm * std::f64::consts::TAU / 60.0;
                let (re, im) = (-w * w * tau, w); // i w (1 + i w tau)
                let n = re * re + im * im;
                (re / n, -im / n)
            };
            let (g1, g0) = (resp(rpm), resp(reference));
            let n0 = g0.0 * g0.0 + g0.1 * g0.1;
            let g = mul(g1, (g0.0 / n0, -g0.1 / n0));
            let b = (swing * phase.to_radians().cos(), swing * phase.to_radians().sin());
            let seen_ref = (error + mul(b, g).0, mul(b, g).1);
            let rot = (turn.cos(), turn.sin());
            let seen = mul(seen_ref, rot);
            if let Some(f) = sw.encoder_share(rpm) {
                let a = mul(seen, f);
                let want = mul((error, 0.0), rot);
                proptest::prop_assert!((a.0 - want.0).hypot(a.1 - want.1) < 1e-9 * (1.0 + error + swing * 10.0));
            } else {
                proptest::prop_assert!(seen.0.hypot(seen.1) < 0.1 * error.max(mul(b, g).0.hypot(mul(b, g).1)) + 1e-12);
            }
        }
    }

    #[test]
    fn without_a_swing_all_of_it_is_the_error() {
        let r = SpindleEncoderRecord {
            swing_arcsec: 0.0,
            ..record()
        };
        for rpm in [30.0, 100.0, 212.0] {
            let f = r.swing().encoder_share(rpm).unwrap_or((f64::NAN, f64::NAN));
            assert!((f.0 - 1.0).abs() < 1e-12 && f.1.abs() < 1e-12, "{f:?}");
        }
    }

    #[test]
    fn a_measured_record_passes() {
        assert!(problems(&record()).is_empty(), "{:?}", problems(&record()));
    }

    #[test]
    fn each_bad_value_is_refused_naming_its_key() {
        type Edit = fn(&mut SpindleEncoderRecord);
        let cases: [(&str, Edit); 7] = [
            ("commissioning.spindle_encoder.error_arcsec", |r| {
                r.error_arcsec = -1.0
            }),
            ("commissioning.spindle_encoder.error_3_arcsec", |r| {
                r.error_3_arcsec = f64::NAN
            }),
            ("commissioning.spindle_encoder.swing_arcsec", |r| {
                r.swing_arcsec = 400.0
            }),
            ("commissioning.spindle_encoder.swing_phase_deg", |r| {
                r.swing_phase_deg = 200.0
            }),
            ("commissioning.spindle_encoder.reference_rpm", |r| {
                r.reference_rpm = 300.0
            }),
            ("commissioning.spindle_encoder.speeds_rpm", |r| {
                r.speeds_rpm.truncate(2)
            }),
            ("commissioning.spindle_encoder.utc", |r| {
                r.utc = "2026-11-29T02:10:05".parse().unwrap_or_else(|e| panic!("{e}"))
            }),
        ];
        for (key, edit) in cases {
            let mut r = record();
            edit(&mut r);
            let found = problems(&r);
            assert!(found.iter().any(|m| m.contains(key)), "{key}: {found:?}");
        }
    }
}
