//! The table's worm drive: what a real worm gear puts between the B motor (whose encoder
//! the controller reads) and the table the blank sits on, none of which the motor encoder
//! sees:
//! - the worm wheel's pitch errors: a cumulative error once per table revolution (the
//!   wheel's eccentricity, range `F_p` of the wheel) and each wheel tooth's own position
//!   deviation (neighbouring teeth differ by up to the wheel's `f_pt`), passed on as the
//!   worm hands the table from tooth to tooth;
//! - the worm's axial runout, once per worm (motor) revolution;
//! - the table as a body of its own on the mesh: its inertia hangs on the drive's torsional
//!   stiffness (with a little damping), so the table follows the worm as a second-order
//!   system (about 50 Hz for the defaults) and lags it by the load over the stiffness;
//! - the backlash: inside the play the mesh carries no torque; the wheel rests on the
//!   worm's driving flank while the load resists the turning, and crosses the play where
//!   the torque changes sign (braking the table's inertia harder than its load).
//!
//! The motor's drive sees the table rigidly (its inertia and load reflected through the
//! ratio, [`crate::servo`]): valid below the mesh's resonance, where the drive's loops work.
//!
//! The angles here are the table's own (rad of the wheel, in the motor's sense of
//! rotation); [`crate::plant::Plant`] turns them into the machine's sign.

use crate::config::WormPlant;
use hob_gearing::iso1328;

/// Which flank of the worm the wheel rests on, or neither.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flank {
    /// The worm pushes the wheel forward (positive transmitted torque): the wheel lags the
    /// worm by half the backlash.
    Driving,
    /// The wheel is inside the play: the mesh carries no torque.
    Free,
    /// The wheel is pushed back against the worm (braking, or a load that drives the
    /// table): it leads by half the backlash.
    Braking,
}

/// The worm drive's state and its wheel's drawn pitch errors.
#[derive(Debug, Clone, PartialEq)]
pub struct WormDrive {
    /// Per wheel tooth: its position deviation, rad of the table.
    tooth_dev_rad: Vec<f64>,
    /// Half the wheel's cumulative pitch error (the eccentricity's amplitude), rad.
    eccentricity_rad: f64,
    eccentricity_phase_rad: f64,
    /// The worm's axial runout as table angle, rad.
    runout_rad: f64,
    runout_phase_rad: f64,
    half_backlash_rad: f64,
    stiffness_nm_rad: f64,
    damping_nm_s_rad: f64,
    table_inertia_kg_m2: f64,
    /// Worm revolutions per table revolution.
    ratio: f64,
    /// The table body's angle and speed, rad and rad/s of the table.
    pub table_rad: f64,
    pub table_rad_s: f64,
    pub flank: Flank,
    /// The torque the worm transmits to the table, Nm (positive: driving it forward).
    pub transmitted_nm: f64,
}

/// The wheel's tolerances in table angle: ISO 1328-1 `f_pt` and `F_p` of a wheel of
/// `pitch_diameter_mm`, `teeth` and `grade`, as arcsec at its pitch circle.
pub fn wheel_tolerances_arcsec(pitch_diameter_mm: f64, teeth: u32, grade: u8) -> (f64, f64) {
    let module_mm = pitch_diameter_mm / f64::from(teeth.max(1));
    let arcsec = |um: f64| um * 1e-3 / (pitch_diameter_mm / 2.0) * 180.0 / std::f64::consts::PI * 3600.0;
    (
        arcsec(iso1328::single_pitch_tolerance_um(
            pitch_diameter_mm,
            module_mm,
            grade,
        )),
        arcsec(iso1328::cumulative_pitch_tolerance_um(
            pitch_diameter_mm,
            module_mm,
            grade,
        )),
    )
}

impl WormDrive {
    /// The drive of a table of `table_inertia_kg_m2` turned by a single-start worm through
    /// `ratio` (the wheel has `ratio` teeth), its errors drawn from `seed`, the table at
    /// rest where the worm at `wheel_rad` (the motor over the ratio) puts it.
    /// `modal_inertia_kg_m2`: the inertia of the mesh's mode, at the table, that
    /// `damping_ratio` is a share of critical of (the table's alone when the motor holds the
    /// worm rigidly; with the motor free on the other side, the two in series).
    pub fn new(
        p: &WormPlant,
        ratio: f64,
        table_inertia_kg_m2: f64,
        modal_inertia_kg_m2: f64,
        seed: u64,
        wheel_rad: f64,
    ) -> Self {
        let teeth = ratio.round().max(1.0) as u32;
        let rad = |arcsec: f64| arcsec / 3600.0 * std::f64::consts::PI / 180.0;
        let (fpt_arcsec, fp_arcsec) = if p.wheel_grade == 0 {
            (0.0, 0.0)
        } else {
            wheel_tolerances_arcsec(p.wheel_pitch_diameter_mm, teeth, p.wheel_grade)
        };
        let mut rng = seed.wrapping_mul(0xD1B5_4A32_D192_ED03) | 1;
        let mut uniform = || crate::rng::uniform(&mut rng);
        // Each tooth within +-f_pt/2 of its place: neighbours differ by at most f_pt.
        let tooth_dev_rad = (0..teeth).map(|_| (uniform() - 0.5) * rad(fpt_arcsec)).collect();
        let tau = std::f64::consts::TAU;
        let r_um = p.wheel_pitch_diameter_mm * 1e3 / 2.0;
        let mut w = Self {
            tooth_dev_rad,
            eccentricity_rad: rad(fp_arcsec) / 2.0,
            eccentricity_phase_rad: uniform() * tau,
            runout_rad: p.worm_axial_runout_um / r_um,
            runout_phase_rad: uniform() * tau,
            half_backlash_rad: rad(p.backlash_arcsec) / 2.0,
            stiffness_nm_rad: p.stiffness_nm_rad,
            damping_nm_s_rad: 2.0 * p.damping_ratio * (p.stiffness_nm_rad * modal_inertia_kg_m2).sqrt(),
            table_inertia_kg_m2,
            ratio,
            table_rad: 0.0,
            table_rad_s: 0.0,
            flank: Flank::Free,
            transmitted_nm: 0.0,
        };
        w.table_rad = w.worm_contact_rad(wheel_rad);
        w
    }

    /// The worm's pitch errors at the wheel angle `wheel_rad` (the motor's angle over the
    /// ratio): eccentricity, the teeth in mesh, the worm's runout; rad of the table.
    pub fn kinematic_error_rad(&self, wheel_rad: f64) -> f64 {
        let z = self.tooth_dev_rad.len();
        let u = wheel_rad / std::f64::consts::TAU * z as f64;
        let k = u.floor();
        let f = u - k;
        let i = (k as i64).rem_euclid(z as i64) as usize;
        let teeth = self.tooth_dev_rad[i] * (1.0 - f) + self.tooth_dev_rad[(i + 1) % z] * f;
        let ecc = self.eccentricity_rad * (wheel_rad + self.eccentricity_phase_rad).sin();
        let runout = self.runout_rad * (wheel_rad * self.ratio + self.runout_phase_rad).sin();
        ecc + teeth + runout
    }

    /// Where a rigid, play-free mesh would put the table for the worm at `wheel_rad`: the
    /// nominal angle plus the pitch errors.
    pub fn worm_contact_rad(&self, wheel_rad: f64) -> f64 {
        wheel_rad + self.kinematic_error_rad(wheel_rad)
    }

    /// Advances the table body by `dt_s`: the worm at `wheel_rad` turning at
    /// `wheel_rad_s` (the motor over the ratio), against `load_nm` at the table (positive:
    /// resisting forward turning). Semi-implicit Euler.
    pub fn advance(&mut self, wheel_rad: f64, wheel_rad_s: f64, load_nm: f64, dt_s: f64) {
        let d = self.worm_contact_rad(wheel_rad) - self.table_rad;
        let h = self.half_backlash_rad;
        let (contact_rad, flank) = if d > h {
            (d - h, Flank::Driving)
        } else if d < -h {
            (d + h, Flank::Braking)
        } else {
            (0.0, Flank::Free)
        };
        let torque = if flank == Flank::Free {
            0.0
        } else {
            self.stiffness_nm_rad * contact_rad + self.damping_nm_s_rad * (wheel_rad_s - self.table_rad_s)
        };
        self.flank = flank;
        self.transmitted_nm = torque;
        self.table_rad_s += (torque - load_nm) / self.table_inertia_kg_m2 * dt_s;
        self.table_rad += self.table_rad_s * dt_s;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    fn plant(grade: u8, runout_um: f64, backlash_arcsec: f64) -> WormPlant {
        WormPlant {
            wheel_pitch_diameter_mm: 300.0,
            wheel_grade: grade,
            worm_axial_runout_um: runout_um,
            backlash_arcsec,
            stiffness_nm_rad: 2.0e6,
            damping_ratio: 0.05,
        }
    }

    fn arcsec(rad: f64) -> f64 {
        rad.to_degrees() * 3600.0
    }

    #[test]
    fn the_wheels_tolerances_come_from_iso_1328_at_its_pitch_circle() {
        // d = 300 mm, z = 75, m = 4 mm, grade 4: f_pt = (0.3 + 1.6 + 5) / sqrt 2 = 4.879 um,
        // F_p = (0.6 + 0.55 sqrt 300 + 2.8 + 12) / sqrt 2 = 17.63 um; at r = 150 mm
        // 1 um is 1.375 arcsec.
        let (fpt, fp) = wheel_tolerances_arcsec(300.0, 75, 4);
        assert!((fpt - 4.879 * 1.375_099).abs() < 0.01, "{fpt}");
        assert!((fp - 17.628 * 1.375_099).abs() < 0.02, "{fp}");
    }

    #[test]
    fn a_wheel_of_its_grade_has_its_tolerances_and_no_more() {
        let w = WormDrive::new(&plant(4, 0.0, 0.0), 75.0, 20.0, 20.0, 7, 0.0);
        let (fpt, fp) = wheel_tolerances_arcsec(300.0, 75, 4);
        // Sample the error at each tooth's place around one revolution.
        let at: Vec<f64> = (0..75)
            .map(|k| arcsec(w.kinematic_error_rad(TAU * f64::from(k) / 75.0)))
            .collect();
        let range = at.iter().copied().fold(f64::MIN, f64::max) - at.iter().copied().fold(f64::MAX, f64::min);
        let single = (0..75)
            .map(|k| (at[k] - at[(k + 74) % 75]).abs())
            .fold(0.0, f64::max);
        // The cumulative error is the eccentricity's range plus the teeth's own spread.
        assert!(
            range <= fp + fpt + 1e-9 && range > 0.8 * fp,
            "range {range} of F_p {fp}"
        );
        // Neighbours: the teeth's difference plus the eccentricity's step over one pitch.
        let ecc_step = fp * (std::f64::consts::PI / 75.0).sin();
        assert!(
            single <= fpt + ecc_step + 1e-9 && single > 0.3 * fpt,
            "{single} of f_pt {fpt}"
        );
        // Grade 0: a perfect wheel.
        let perfect = WormDrive::new(&plant(0, 0.0, 0.0), 75.0, 20.0, 20.0, 7, 0.0);
        assert_eq!(perfect.kinematic_error_rad(1.234), 0.0);
    }

    #[test]
    fn the_worms_runout_repeats_every_worm_revolution() {
        let w = WormDrive::new(&plant(0, 2.0, 0.0), 75.0, 20.0, 20.0, 3, 0.0);
        let worm_rev = TAU / 75.0;
        let (a, b) = (w.kinematic_error_rad(0.3), w.kinematic_error_rad(0.3 + worm_rev));
        assert!((a - b).abs() < 1e-15);
        let peak = (0..1000)
            .map(|i| w.kinematic_error_rad(worm_rev * f64::from(i) / 1000.0).abs())
            .fold(0.0, f64::max);
        // 2 um at r = 150 mm.
        assert!((peak - 2.0 / 150e3).abs() < 1e-8, "{peak}");
    }

    /// Turns the worm at `rate` (rad/s of the table) from `at` for `seconds` against
    /// `load_nm`; returns where the worm ends.
    fn turn(w: &mut WormDrive, at: f64, rate: f64, load_nm: f64, seconds: f64) -> f64 {
        let dt = 1e-4;
        let mut a = at;
        for _ in 0..(seconds / dt) as usize {
            // Both sides at the start of the step, as the plant calls it.
            w.advance(a, rate, load_nm, dt);
            a += rate * dt;
        }
        a
    }

    #[test]
    fn the_table_lags_by_half_the_play_and_the_deflection_and_crosses_the_play_when_the_load_turns() {
        let mut w = WormDrive::new(&plant(0, 0.0, 10.0), 75.0, 20.0, 20.0, 1, 0.0);
        // Turning against 200 Nm at 1 rpm of the table: settled on the driving flank, 5 arcsec
        // of play plus 200 / 2e6 rad behind the worm.
        let rate = std::f64::consts::TAU / 60.0;
        let at = turn(&mut w, 0.0, rate, 200.0, 2.0);
        assert_eq!(w.flank, Flank::Driving);
        let lag = arcsec(w.table_rad - at);
        assert!((lag - (-5.0 - arcsec(1e-4))).abs() < 0.01, "{lag}");
        assert!((w.transmitted_nm - 200.0).abs() < 0.5, "{}", w.transmitted_nm);
        // A load that drives the table (-200 Nm): it crosses the play onto the braking flank
        // and leads the worm by the same amount.
        let at = turn(&mut w, at, rate, -200.0, 2.0);
        assert_eq!(w.flank, Flank::Braking);
        let lead = arcsec(w.table_rad - at);
        assert!((lead - (5.0 + arcsec(1e-4))).abs() < 0.01, "{lead}");
    }

    #[test]
    fn the_table_rings_at_the_meshs_resonance_and_settles() {
        // sqrt(2e6 / 20) = 316 rad/s = 50.3 Hz; a step of the worm, no play, no load.
        let mut w = WormDrive::new(&plant(0, 0.0, 0.0), 75.0, 20.0, 20.0, 1, 0.0);
        let step = 1e-5;
        let (dt, mut crossings, mut above) = (1e-4, 0, false);
        for i in 0..10_000 {
            w.advance(step, 0.0, 0.0, dt);
            // Crossings of the final value while the ringing is still 1 % of the step.
            let now = w.table_rad > step;
            if i > 0 && now != above && (w.table_rad_s * dt).abs() > 1e-4 * step {
                crossings += 1;
            }
            above = now;
        }
        // Damped at 5 %, the swing (speed x step, 0.0316 of the amplitude) stays above
        // 1e-4 of the step until the amplitude falls to 0.32 %: ln(316) / (zeta omega) =
        // 0.364 s of a 50.3 Hz ringing, crossing twice per cycle: 36.6.
        assert!((33..=40).contains(&crossings), "{crossings}");
        assert!((w.table_rad - step).abs() < 1e-9, "settled at {}", w.table_rad);
        let mut w2 = WormDrive::new(&plant(0, 0.0, 0.0), 75.0, 20.0, 20.0, 1, 0.0);
        let mut first_peak = 0.0f64;
        for _ in 0..200 {
            w2.advance(step, 0.0, 0.0, dt);
            first_peak = first_peak.max(w2.table_rad);
        }
        // The first overshoot of a 5 %-damped second-order step: exp(-pi zeta / sqrt(1 - zeta^2)) = 85 %.
        assert!((first_peak / step - 1.85).abs() < 0.03, "{}", first_peak / step);
    }
}
