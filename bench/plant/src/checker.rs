//! The simulated machine's gear checker: it measures the finished gear's pitch the way a
//! shop's checker does, at one height of the face, each flank with its own noise, and
//! writes the checker's file (`hob_gear_check`, docs/gear-measurement.md).
//!
//! What it measures is the plant's truth: where the table truly stood (`blank_err_arcsec`)
//! when each gap of the last pass passed the hob, read as
//! [`hob_logger::predicted`] reads it, in the face section nearest the middle of the face.
//! A gap cut with the table `e` ahead (its positive direction) has both its flanks `e` (um at
//! the pitch circle) ahead. The gaps are taken where the hob cut them
//! ([`GearChecker::at_hob`], `hob_logger::predicted::GapsAt::Hob`) or, with
//! [`GearChecker::new`], at the fixed table angles `k * 360 / z`. The teeth stand between
//! the gaps, counted in the table's positive direction from the gap the section's first
//! crossing was (`Section::table_order`): tooth 1 stands half a pitch after that gap, at
//! its table angle (`tooth_1_table_deg`, as an operator's mark on the table would give
//! it). Tooth k's right flank faces the gap after it (toward tooth k+1), its left flank
//! the gap before it.

use crate::rng::uniform;
use crate::sim::TraceRow;
use hob_control::State;
use hob_gear_check::{Counting, FlankPitch, Header, PitchMeasurement};
use hob_gearing::units::arcsec_to_um_at_radius;
use hob_logger::predicted::{GapsAt, Section, SectionBuilder, TrueSample};

/// The checker's repeatability, um (one sigma per flank and tooth; the 0.3-0.5).
pub const NOISE_UM: f64 = 0.4;

/// What the checker is told about the gear.
#[derive(Debug, Clone)]
pub struct GearUnderTest {
    /// The program's `workpiece.name` (or, without one, its file's name).
    pub gear: String,
    pub teeth: u32,
    pub normal_module_mm: f64,
    pub pitch_radius_mm: f64,
    /// The face's lowest Y (the datum face) and its width, mm.
    pub face_bottom_mm: f64,
    pub face_width_mm: f64,
}

impl GearUnderTest {
    /// The gear `gear` (its name for the checker) of a program as planned and built.
    pub fn of(
        gear: String,
        plan: &hob_setup::planner::Plan,
        cycle: &hob_control::program::CycleProgram,
    ) -> Self {
        Self {
            gear,
            teeth: plan.teeth,
            normal_module_mm: plan.normal_module_mm,
            pitch_radius_mm: plan.pitch_diameter_mm / 2.0,
            face_bottom_mm: cycle.face_bottom_mm,
            face_width_mm: plan.face_width_mm,
        }
    }
}

/// Collects the last pass's face sections from the trace rows of a cut.
#[derive(Debug, Clone)]
pub struct GearChecker {
    gear: GearUnderTest,
    at: GapsAt,
    pass: u32,
    sections: SectionBuilder,
}

impl GearChecker {
    /// The gaps at the fixed table angles `k * 360 / z`.
    pub fn new(gear: GearUnderTest) -> Self {
        Self::at(gear, GapsAt::Table { phase_deg: 0.0 })
    }

    /// The gaps where a hob of `starts` starts cut them (its phase 0: the simulated
    /// machine's hob has its reference thread at the spindle's zero).
    pub fn at_hob(gear: GearUnderTest, starts: u32) -> Self {
        Self::at(
            gear,
            GapsAt::Hob {
                starts,
                phase_deg: 0.0,
            },
        )
    }

    fn at(gear: GearUnderTest, at: GapsAt) -> Self {
        let teeth = gear.teeth;
        Self {
            gear,
            at,
            pass: 0,
            sections: SectionBuilder::at(teeth, at),
        }
    }

    /// A row of the cut's trace, in order. A later pass starts afresh: it recuts the gaps.
    pub fn add(&mut self, row: &TraceRow) {
        if row.pass == 0 {
            self.sections.interrupt();
            return;
        }
        if row.pass != self.pass {
            self.pass = row.pass;
            self.sections = SectionBuilder::at(self.gear.teeth, self.at);
        }
        match (row.state == State::Cut, row.blank_err_arcsec) {
            (true, Some(e)) => self.sections.add(TrueSample {
                table_deg: row.table_deg,
                spindle_deg: row.spindle_deg,
                y_mm: row.y_mm,
                error_um: arcsec_to_um_at_radius(e, self.gear.pitch_radius_mm),
            }),
            (true, None) => self.sections.skip(),
            (false, _) => self.sections.interrupt(),
        }
    }

    /// The measurement of the finished gear at mid-face, with the checker's noise drawn
    /// from `seed`; `measured_at` is written as given. None when the last pass left no
    /// complete section.
    pub fn measure(self, seed: u64, measured_at: &str) -> Option<PitchMeasurement> {
        self.measure_heights(seed, measured_at, 1).pop()
    }

    /// Measurements at `count` neighbouring heights, one feed (table turn) apart, around
    /// mid-face, lowest first, each with its own noise (as a checker measuring pitch at
    /// several heights). Fewer where the last pass has fewer complete sections.
    pub fn measure_heights(self, seed: u64, measured_at: &str, count: usize) -> Vec<PitchMeasurement> {
        let g = self.gear;
        let sections = self.sections.finish();
        let mid_y = g.face_bottom_mm + g.face_width_mm / 2.0;
        let Some(mid) = (0..sections.len()).min_by(|&a, &b| {
            (sections[a].y_mm - mid_y)
                .abs()
                .total_cmp(&(sections[b].y_mm - mid_y).abs())
        }) else {
            return Vec::new();
        };
        let first = mid
            .saturating_sub(count.saturating_sub(1) / 2)
            .min(sections.len().saturating_sub(count));
        let mut chosen: Vec<&Section> = sections.iter().skip(first).take(count).collect();
        chosen.sort_by(|a, b| a.y_mm.total_cmp(&b.y_mm));
        let z = g.teeth as usize;
        chosen
            .into_iter()
            .enumerate()
            .map(|(j, section)| {
                let draw = seed.wrapping_add(j as u64);
                let mut rng = draw.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
                let mut noisy = |um: f64| um + NOISE_UM * gaussian(&mut rng);
                // Tooth k (0-based) stands between gap k and gap k+1 in table order.
                let order = section.table_order();
                let gap = |k: usize| section.gap_um[order[k % z]];
                let right: Vec<f64> = (0..z).map(|k| noisy(gap(k + 1))).collect();
                let left: Vec<f64> = (0..z).map(|k| noisy(gap(k))).collect();
                let pitch_deg = 360.0 / g.teeth as f64;
                let tooth_1_table_deg = (section.table_deg[order[0]] + pitch_deg / 2.0).rem_euclid(360.0);
                PitchMeasurement {
                    header: Header {
                        gear: g.gear.clone(),
                        teeth: g.teeth,
                        normal_module_mm: g.normal_module_mm,
                        face_position_mm: section.y_mm - g.face_bottom_mm,
                        tooth_1_table_deg,
                        counting: Counting::TablePositive,
                        checker: format!("hob-plant checker, {NOISE_UM} um noise, seed {draw}"),
                        measured_at: measured_at.to_string(),
                    },
                    left: FlankPitch::from_positions(&left),
                    right: FlankPitch::from_positions(&right),
                }
            })
            .collect()
    }
}

/// A standard normal draw (Box-Muller).
fn gaussian(state: &mut u64) -> f64 {
    let u1 = uniform(state).max(f64::MIN_POSITIVE);
    let u2 = uniform(state);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_noise_is_standard_normal() {
        let mut s = 7u64.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let n = 20000;
        let draws: Vec<f64> = (0..n).map(|_| super::gaussian(&mut s)).collect();
        let mean = draws.iter().sum::<f64>() / n as f64;
        let sd = (draws.iter().map(|d| (d - mean) * (d - mean)).sum::<f64>() / n as f64).sqrt();
        println!("{mean} {sd}");
        assert!(mean.abs() < 0.03 && (sd - 1.0).abs() < 0.03, "{mean} {sd}");
    }
}
