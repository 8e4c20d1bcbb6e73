//! The measured points read as the builder needs them: the mechanism fitted with the drive's
//! own gains, the mesh's two frequencies, the present tuning's stability and margins, the
//! gains proposed, their record for the machine file, and all of it in words.

use super::fit::{self, Fitted};
use super::frf::{self, Point};
use super::model::{self, DriveLoops, Stability};
use crate::Stop;
use hob_ipc::nodes::{DriveGains, DriveIdentity};
use hob_setup::config::machine::TableDriveModel;
use hob_store::machine_edit;

/// The deepest point must lie this far below the low-frequency response, dB: else the
/// mesh's mode did not show.
pub const DIP_DB: f64 = -2.0;
/// The fitted model may stray from the points this much, RMS of the complex response.
pub const MISFIT: f64 = 0.25;

/// What the measurement found.
#[derive(Debug, Clone, PartialEq)]
pub struct Analysis {
    /// Every point, lowest frequency first.
    pub points: Vec<Point>,
    pub fitted: Fitted,
    /// The mesh's anti-resonance and resonance on the fitted mechanism, Hz.
    pub modes_hz: (f64, f64),
    /// The drive's gains as it reported them, and its loops in the model's terms.
    pub gains: DriveGains,
    pub present: DriveLoops,
    pub present_stability: Stability,
    /// The gains proposed, with their margins on the fitted mechanism (its damping at most
    /// [`fit::CAUTIOUS_MODAL_DAMPING`] of critical).
    pub proposed: model::Proposal,
    /// The loop's period the points were read at, s.
    pub period_s: f64,
}

/// The drive's loops from the gains it reported and its data sheet's figures (velocity
/// feed-forward 1: cyclic synchronous position with the drive's own interpolation).
pub fn drive_loops(g: &DriveGains, d: &TableDriveModel) -> DriveLoops {
    DriveLoops {
        velocity_kp_nm_s_per_rad: g.velocity_kp_nm_s_per_rad,
        velocity_integral_time_s: g.velocity_integral_time_ms * 1e-3,
        position_kv_per_s: g.position_kv_per_s,
        velocity_feed_forward: 1.0,
        loop_period_s: f64::from(d.loop_us) * 1e-6,
        velocity_filter_hz: d.speed_filter_hz,
    }
}

/// The gains as the drive's objects carry them.
pub fn gains_of(d: &DriveLoops) -> DriveGains {
    DriveGains {
        velocity_kp_nm_s_per_rad: d.velocity_kp_nm_s_per_rad,
        velocity_integral_time_ms: d.velocity_integral_time_s * 1e3,
        position_kv_per_s: d.position_kv_per_s,
    }
}

/// Reads `points` (measured every `period_s` with the drive's `gains`).
pub fn analyse(
    points: Vec<Point>,
    gains: DriveGains,
    drive: &TableDriveModel,
    worm_ratio: f64,
    period_s: f64,
) -> Result<Analysis, Stop> {
    let deepest = frf::deepest(&points).map_or(f64::NAN, |i| points[i].magnitude_db());
    if deepest.is_nan() || deepest >= DIP_DB {
        return Err(Stop::Failed(format!(
            "the response has no dip (its deepest point {deepest:.1} dB): the mesh's mode did \
             not show in the band measured; widen it (--from, --to), or the table sits in the \
             worm's play (no friction to hold it on a flank); nothing written"
        )));
    }
    let present = drive_loops(&gains, drive);
    let fitted = fit::fit(
        &points,
        &present,
        period_s,
        worm_ratio,
        drive.motor_side_inertia_kg_m2,
    )
    .ok_or_else(|| Stop::Failed("no mechanism fits the response: nothing written".into()))?;
    if fitted.misfit > MISFIT {
        return Err(Stop::Failed(format!(
            "the model of the drive's loops does not fit the response (RMS {:.2} off, at most \
             {MISFIT}): check [table.drive_model] against the data sheets; nothing written",
            fitted.misfit
        )));
    }
    let cautious = fit::cautious(&fitted.mechanism);
    let proposed = model::propose(&cautious, present.loop_period_s, present.velocity_filter_hz, None)
        .ok_or_else(|| {
            Stop::Failed("no gains hold the margins on the fitted mechanism: nothing written".into())
        })?;
    Ok(Analysis {
        modes_hz: model::mesh_modes(&fitted.mechanism),
        present_stability: model::stability(&fitted.mechanism, &present),
        points,
        fitted,
        gains,
        present,
        proposed,
        period_s,
    })
}

/// A stability in words.
pub fn stability_text(s: &Stability) -> String {
    match s {
        Stability::Stable { velocity, cascade } => format!(
            "stable: velocity loop GM {:.1} dB at {:.0} Hz, PM {:.1} deg at {:.0} Hz; cascade GM \
             {:.1} dB, PM {:.1} deg at {:.0} Hz",
            velocity.gain_margin_db,
            velocity.phase_crossover_hz,
            velocity.phase_margin_deg,
            velocity.gain_crossover_hz,
            cascade.gain_margin_db,
            cascade.phase_margin_deg,
            cascade.gain_crossover_hz
        ),
        Stability::Unstable {
            largest_pole_radius,
            near_hz,
        } => format!(
            "UNSTABLE: a pole at |z| = {largest_pole_radius:.2} near {near_hz:.0} Hz (the drive \
             would oscillate)"
        ),
    }
}

/// The measurement and its reading in words.
pub fn report(a: &Analysis) -> String {
    let m = &a.fitted.mechanism;
    let dip = frf::deepest(&a.points).map(|i| &a.points[i]);
    let g = gains_of(&a.proposed.loops);
    format!(
        "table frequency response: {} points from {:.1} to {:.1} Hz, the deepest {:.1} dB at {:.1} Hz\n\
         fitted mechanism: table {:.2} kg m2, mesh {:.3e} Nm/rad (equivalent, at this swing), \
         damping {:.0} Nm s/rad ({:.1} % of critical), delay {:.2} ms; model off by {:.3} RMS\n\
         mesh anti-resonance {:.1} Hz, resonance {:.1} Hz (motor side {:.2e} kg m2 from \
         [table.drive_model])\n\
         the drive's present gains (kp {:.3} Nm s/rad, Ti {:.2} ms, kv {:.1} 1/s): {}\n\
         proposed (for the fitted mechanism at no more than {:.0} % damping): kp {:.3} Nm s/rad, \
         Ti {:.2} ms, kv {:.1} 1/s: velocity loop GM {:.1} dB, PM {:.1} deg; cascade GM {:.1} \
         dB, PM {:.1} deg\n",
        a.points.len(),
        a.points.first().map_or(0.0, |p| p.frequency_hz),
        a.points.last().map_or(0.0, |p| p.frequency_hz),
        dip.map_or(f64::NAN, Point::magnitude_db),
        dip.map_or(0.0, |p| p.frequency_hz),
        m.table_inertia_kg_m2,
        m.mesh_stiffness_nm_per_rad,
        m.mesh_damping_nm_s_per_rad,
        100.0 * m.modal_damping_ratio(),
        a.fitted.delay_s * 1e3,
        a.fitted.misfit,
        a.modes_hz.0,
        a.modes_hz.1,
        m.motor_inertia_kg_m2,
        a.gains.velocity_kp_nm_s_per_rad,
        a.gains.velocity_integral_time_ms,
        a.gains.position_kv_per_s,
        stability_text(&a.present_stability),
        100.0 * fit::CAUTIOUS_MODAL_DAMPING,
        g.velocity_kp_nm_s_per_rad,
        g.velocity_integral_time_ms,
        g.position_kv_per_s,
        a.proposed.velocity.gain_margin_db,
        a.proposed.velocity.phase_margin_deg,
        a.proposed.cascade.gain_margin_db,
        a.proposed.cascade.phase_margin_deg,
    )
}

/// The machine file's text with the record of the proposed gains (the drive's present ones
/// kept in it), measured on the drive `identity`.
pub fn proposal(text: &str, a: &Analysis, identity: DriveIdentity, utc: &str) -> String {
    let g = gains_of(&a.proposed.loops);
    let block = format!(
        "[commissioning.table_drive_gains]\n\
         # Written by `hob commission response` (the file before it kept beside it as .bak).\n\
         # hob-rt's boot writes these to the table drive (0x60F9, 0x60FB) and reads them back.\n\
         utc = {utc}\n\
         velocity_kp_nm_s_per_rad = {:.4}\n\
         velocity_integral_time_ms = {:.3}\n\
         position_kv_per_s = {:.2}\n\
         previous_velocity_kp_nm_s_per_rad = {:.4}\n\
         previous_velocity_integral_time_ms = {:.3}\n\
         previous_position_kv_per_s = {:.2}\n\
         velocity_gain_margin_db = {:.2}\n\
         velocity_phase_margin_deg = {:.2}\n\
         position_gain_margin_db = {:.2}\n\
         position_phase_margin_deg = {:.2}\n\
         mesh_antiresonance_hz = {:.2}\n\
         mesh_resonance_hz = {:.2}\n\
         {}",
        g.velocity_kp_nm_s_per_rad,
        g.velocity_integral_time_ms,
        g.position_kv_per_s,
        a.gains.velocity_kp_nm_s_per_rad,
        a.gains.velocity_integral_time_ms,
        a.gains.position_kv_per_s,
        a.proposed.velocity.gain_margin_db,
        a.proposed.velocity.phase_margin_deg,
        a.proposed.cascade.gain_margin_db,
        a.proposed.cascade.phase_margin_deg,
        a.modes_hz.0,
        a.modes_hz.1,
        crate::link::identity_lines(identity),
    );
    machine_edit::replace_table(text, "commissioning.table_drive_gains", &block)
}
