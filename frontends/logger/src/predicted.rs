//! What ISO 1328-1 would measure on the gear a cut made, from the table's true error along
//! the cut: the gear is judged by its single pitch deviation `f_pt` (adjacent teeth), its
//! cumulative pitch deviation `F_p` and its helix, not by the peak of the error.
//!
//! In hobbing every tooth gap is generated anew at each revolution of the table while Y
//! feeds across the face: a face section (one table revolution, `feed` mm of Y) holds each
//! gap once, and gap `k`'s flanks in that section sit where the table was when gap `k`
//! passed the hob. So the table's error (at the pitch circle, um) at the moment each gap
//! passed is that gap's position deviation in that section. Per section: `f_pt` is the
//! largest difference between neighbouring gaps (around the whole gear), `F_p` the range
//! of the positions (a common offset of all gaps moves the teeth, not their spacing). Along
//! the face: a gap's position from section to section is the controller's share of the
//! helix deviation. The gear's figures are the worst section's; the finished gear is the
//! last pass's sections.
//!
//! Where a gap is cut ([`GapsAt`]): a hob of `starts` starts passes a tooth gap through its
//! axial plane once every `360 / starts` deg of the spindle, so the part's real gaps are
//! where the spindle was at `phase + j * 360 / starts` (`GapsAt::Hob`): on a helical gear
//! they follow the helix along the face, and the gearbox's own phase puts them where the
//! program's law does. The phase is the hob's thread against the spindle's zero, which the
//! controller does not know (the simulated machine's hob has its reference thread at the
//! spindle's zero, phase 0): the summary gives phase 0 and the worst over the phase
//! ([`PHASES`]). `GapsAt::Table` takes virtual gaps at fixed table angles
//! `phase + k * 360 / z` instead: what a compensation's record and the simulated checker
//! sample at, the same table angles for both (`crate::gaps`), and the summary's
//! `predicted` and `controller_share` still (the gate's and the goals' figures,
//! docs/accuracy.md, "The gaps where the hob cuts them").

use hob_gearing::iso1328;
use serde::Serialize;

/// The table's true error at one instant of the cut.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrueSample {
    /// The table's true angle, deg (unwrapped, either direction).
    pub table_deg: f64,
    /// The spindle's (hob's) angle, deg (unwrapped).
    pub spindle_deg: f64,
    pub y_mm: f64,
    /// The table's error against the gearbox law, at the pitch circle, um.
    pub error_um: f64,
}

/// One face section: each gap's position deviation (um), by gap number.
#[derive(Debug, Clone, PartialEq)]
pub struct Section {
    pub y_mm: f64,
    pub gap_um: Vec<f64>,
    /// The table's angle (deg, unwrapped) where each gap passed the hob.
    pub table_deg: Vec<f64>,
    /// The spindle's angle (deg, unwrapped) then.
    pub spindle_deg: Vec<f64>,
}

impl Section {
    /// The gaps in the table's positive direction, gap 0 first: gap `k` is the `k`-th gap
    /// at or after gap 0's table angle. Gap 0 is the same gap in every section of a cut (at
    /// the hob's gaps it follows the helix), so the order is the same in all of them.
    pub fn table_order(&self) -> Vec<usize> {
        let first = self.table_deg.first().copied().unwrap_or(0.0);
        let mut order: Vec<usize> = (0..self.table_deg.len()).collect();
        order.sort_by(|&a, &b| {
            let at = |k: usize| (self.table_deg[k] - first).rem_euclid(360.0);
            at(a).total_cmp(&at(b))
        });
        order
    }

    /// The largest difference between neighbouring gaps, around the whole gear, um.
    pub fn single_pitch_um(&self) -> f64 {
        let z = self.gap_um.len();
        (0..z)
            .map(|k| (self.gap_um[k] - self.gap_um[(k + z - 1) % z]).abs())
            .fold(0.0, f64::max)
    }

    /// The range of the gaps' positions, um.
    pub fn cumulative_pitch_um(&self) -> f64 {
        let max = self.gap_um.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let min = self.gap_um.iter().copied().fold(f64::INFINITY, f64::min);
        max - min
    }
}

/// Where the gaps pass the hob: the instants a face section's gaps are taken at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GapsAt {
    /// At the table angles `phase_deg + k * 360 / z` (virtual gaps at fixed table angles).
    Table { phase_deg: f64 },
    /// Where the hob cuts them: at the spindle angles `phase_deg + j * 360 / starts`;
    /// consecutive passes are neighbouring gaps, `z` of them one table revolution.
    Hob { starts: u32, phase_deg: f64 },
}

/// The phases of the hob's thread [`crate::trace::SummaryBuilder`] takes the worst over:
/// `i / PHASES` of `360 / starts` deg of the spindle, `i` in `0..PHASES`.
pub const PHASES: usize = 8;

/// The face sections of a stretch of the cut: gap `k` passes the hob when the table is at
/// `phase_deg + k * 360 / teeth` (mod 360); a section is complete when every gap has passed
/// once. The error is interpolated at the crossing; an incomplete last revolution is left
/// out.
pub fn sections(samples: &[TrueSample], teeth: u32, phase_deg: f64) -> Vec<Section> {
    sections_at(samples, teeth, GapsAt::Table { phase_deg })
}

/// [`sections`] with the gaps where `at` says.
pub fn sections_at(samples: &[TrueSample], teeth: u32, at: GapsAt) -> Vec<Section> {
    let mut b = SectionBuilder::at(teeth, at);
    for s in samples {
        b.add(*s);
    }
    b.finish()
}

/// Rows of the cut without a true sample that [`SectionBuilder::skip`] bridges by
/// interpolating between the samples either side (10 ms at a 1 ms cycle): the simulated
/// machine writes no truth for a SYNC it could not answer in time, one or a few at a time
/// in an emulated guest. A longer run ends the stretch.
pub const MAX_BRIDGED_ROWS: u32 = 10;

/// [`sections`] one sample at a time, for a recording too long to hold: the memory is one
/// section's gaps and the sections completed.
#[derive(Debug, Clone)]
pub struct SectionBuilder {
    /// The crossing's unit, deg (of the table or of the spindle), and its phase.
    pitch_deg: f64,
    phase_deg: f64,
    /// Whether the spindle's angle, not the table's, counts the gaps.
    by_spindle: bool,
    prev: Option<TrueSample>,
    /// Rows skipped since `prev`.
    skipped: u32,
    gap_um: Vec<f64>,
    table_deg: Vec<f64>,
    spindle_deg: Vec<f64>,
    filled: usize,
    y_sum: f64,
    out: Vec<Section>,
}

impl SectionBuilder {
    /// Gaps at fixed table angles ([`GapsAt::Table`]).
    pub fn new(teeth: u32, phase_deg: f64) -> Self {
        Self::at(teeth, GapsAt::Table { phase_deg })
    }

    pub fn at(teeth: u32, at: GapsAt) -> Self {
        let z = teeth.max(1) as usize;
        let (pitch_deg, phase_deg, by_spindle) = match at {
            GapsAt::Table { phase_deg } => (360.0 / z as f64, phase_deg, false),
            GapsAt::Hob { starts, phase_deg } => (360.0 / f64::from(starts.max(1)), phase_deg, true),
        };
        Self {
            pitch_deg,
            phase_deg,
            by_spindle,
            prev: None,
            skipped: 0,
            gap_um: vec![f64::NAN; z],
            table_deg: vec![f64::NAN; z],
            spindle_deg: vec![f64::NAN; z],
            filled: 0,
            y_sum: 0.0,
            out: Vec::new(),
        }
    }

    /// The next sample of a continuous stretch of the cut.
    pub fn add(&mut self, b: TrueSample) {
        self.skipped = 0;
        let Some(a) = self.prev.replace(b) else {
            return;
        };
        let z = self.gap_um.len();
        let angle = |s: &TrueSample| {
            if self.by_spindle {
                s.spindle_deg
            } else {
                s.table_deg
            }
        };
        let ua = (angle(&a) - self.phase_deg) / self.pitch_deg;
        let ub = (angle(&b) - self.phase_deg) / self.pitch_deg;
        if ua == ub || !ua.is_finite() || !ub.is_finite() {
            return;
        }
        let (lo, hi) = (ua.min(ub), ua.max(ub));
        // Every gap position crossed in (lo, hi], in the order the table met them.
        let first = lo.floor() as i64 + 1;
        let last = hi.floor() as i64;
        let count = (last - first + 1).max(0);
        for i in 0..count {
            let n = if ub > ua { first + i } else { last - i };
            let f = (n as f64 - ua) / (ub - ua);
            let k = n.rem_euclid(z as i64) as usize;
            if self.gap_um[k].is_nan() {
                self.filled += 1;
            }
            self.gap_um[k] = a.error_um + f * (b.error_um - a.error_um);
            self.table_deg[k] = a.table_deg + f * (b.table_deg - a.table_deg);
            self.spindle_deg[k] = a.spindle_deg + f * (b.spindle_deg - a.spindle_deg);
            self.y_sum += a.y_mm + f * (b.y_mm - a.y_mm);
            if self.filled == z {
                self.out.push(Section {
                    y_mm: self.y_sum / z as f64,
                    gap_um: std::mem::replace(&mut self.gap_um, vec![f64::NAN; z]),
                    table_deg: std::mem::replace(&mut self.table_deg, vec![f64::NAN; z]),
                    spindle_deg: std::mem::replace(&mut self.spindle_deg, vec![f64::NAN; z]),
                });
                self.filled = 0;
                self.y_sum = 0.0;
            }
        }
    }

    /// The stretch ends (the cut left, a sample missing): the next sample starts a new
    /// one; the gaps already crossed in the open section stay.
    pub fn interrupt(&mut self) {
        self.prev = None;
        self.skipped = 0;
    }

    /// A row of the cut without a true sample: bridged up to [`MAX_BRIDGED_ROWS`] in a row
    /// (the next sample is interpolated from the last), beyond that the stretch ends.
    pub fn skip(&mut self) {
        self.skipped += 1;
        if self.skipped > MAX_BRIDGED_ROWS {
            self.interrupt();
        }
    }

    /// The sections completed.
    pub fn finish(self) -> Vec<Section> {
        self.out
    }
}

/// The controller's share of the gear's deviations, with the tolerances of a grade.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PredictedGear {
    pub sections: usize,
    /// Worst section's single pitch deviation, um.
    pub single_pitch_um: f64,
    /// Worst section's cumulative pitch deviation, um.
    pub cumulative_pitch_um: f64,
    /// The largest range of one gap's position over the face sections, um.
    pub helix_um: f64,
    pub grade: u8,
    pub single_pitch_tolerance_um: f64,
    pub cumulative_pitch_tolerance_um: f64,
    pub helix_tolerance_um: f64,
}

impl PredictedGear {
    /// From the sections of a pass (none: `None`), against `grade` for a gear of reference
    /// diameter `d`, normal module `m_n` and face width `b`.
    pub fn of(
        sections: &[Section],
        grade: u8,
        reference_diameter_mm: f64,
        normal_module_mm: f64,
        face_width_mm: f64,
    ) -> Option<Self> {
        let first = sections.first()?;
        let z = first.gap_um.len();
        let helix_um = (0..z)
            .map(|k| {
                let (lo, hi) = sections
                    .iter()
                    .map(|s| s.gap_um[k])
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                        (lo.min(v), hi.max(v))
                    });
                hi - lo
            })
            .fold(0.0, f64::max);
        Some(Self {
            sections: sections.len(),
            single_pitch_um: sections.iter().map(Section::single_pitch_um).fold(0.0, f64::max),
            cumulative_pitch_um: sections
                .iter()
                .map(Section::cumulative_pitch_um)
                .fold(0.0, f64::max),
            helix_um,
            grade,
            single_pitch_tolerance_um: iso1328::single_pitch_tolerance_um(
                reference_diameter_mm,
                normal_module_mm,
                grade,
            ),
            cumulative_pitch_tolerance_um: iso1328::cumulative_pitch_tolerance_um(
                reference_diameter_mm,
                normal_module_mm,
                grade,
            ),
            helix_tolerance_um: iso1328::helix_total_tolerance_um(
                reference_diameter_mm,
                face_width_mm,
                grade,
            ),
        })
    }

    /// Each deviation the larger of the two (the worst over the hob's phase: the figures
    /// may come from different phases); the sections the fewer.
    pub fn worst(&self, other: &Self) -> Self {
        Self {
            sections: self.sections.min(other.sections),
            single_pitch_um: self.single_pitch_um.max(other.single_pitch_um),
            cumulative_pitch_um: self.cumulative_pitch_um.max(other.cumulative_pitch_um),
            helix_um: self.helix_um.max(other.helix_um),
            ..self.clone()
        }
    }

    /// The shares of the tolerances: single pitch, cumulative pitch, helix.
    pub fn shares(&self) -> (f64, f64, f64) {
        (
            self.single_pitch_um / self.single_pitch_tolerance_um,
            self.cumulative_pitch_um / self.cumulative_pitch_tolerance_um,
            self.helix_um / self.helix_tolerance_um,
        )
    }

    /// "f_pt 1.23 um (25 % of grade 5 5.02 um), F_p ..., helix ...": the deviations against
    /// their tolerances, as the cut reports print them.
    pub fn text(&self) -> String {
        let (fpt, fp, helix) = self.shares();
        format!(
            "f_pt {:.2} um ({:.0} % of grade {} {:.2} um), F_p {:.2} um ({:.0} % of {:.2} um), helix {:.2} um ({:.0} % of F_beta {:.2} um)",
            self.single_pitch_um,
            100.0 * fpt,
            self.grade,
            self.single_pitch_tolerance_um,
            self.cumulative_pitch_um,
            100.0 * fp,
            self.cumulative_pitch_tolerance_um,
            self.helix_um,
            100.0 * helix,
            self.helix_tolerance_um,
        )
    }
}

/// One pass's predicted gear as a report line (no newline): the gear (the truth at the
/// blank) and the controller's share, either missing said so.
pub fn pass_line(pass: u32, gear: Option<&PredictedGear>, controller: Option<&PredictedGear>) -> String {
    let part = |g: Option<&PredictedGear>| g.map_or_else(|| "not known".to_string(), PredictedGear::text);
    match gear.or(controller) {
        None => format!(
            "  pass {pass}: no predicted gear (no whole table revolution in the cut, or no truth recorded)"
        ),
        Some(g) => format!(
            "  pass {pass}: predicted gear ({} face sections): {}; controller's share: {}",
            g.sections,
            part(gear),
            part(controller)
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// `revs` table revolutions in `steps` samples per revolution, the error a function of
    /// the table angle (deg) and Y; Y feeds 2 mm per revolution.
    fn cut(revs: f64, steps: usize, backwards: bool, e: impl Fn(f64, f64) -> f64) -> Vec<TrueSample> {
        let n = (revs * steps as f64) as usize;
        (0..=n)
            .map(|i| {
                let turn = i as f64 / steps as f64;
                let deg = if backwards { -360.0 * turn } else { 360.0 * turn } + 0.3;
                let y = 2.0 * turn;
                TrueSample {
                    table_deg: deg,
                    spindle_deg: 0.0,
                    y_mm: y,
                    error_um: e(deg, y),
                }
            })
            .collect()
    }

    #[test]
    fn short_runs_without_truth_are_bridged_and_a_long_one_ends_the_stretch() {
        // An error linear in the table angle: interpolation across a missing run is exact.
        let samples = cut(3.0, 1000, false, |deg, _| 0.01 * deg);
        let full = sections(&samples, 17, 0.0);
        assert_eq!(full.len(), 3);
        // Every 7th..(7+k)th sample of each 20 missing, k up to the bridge: the same gear.
        let with_gaps = |missing: usize| {
            let mut b = SectionBuilder::new(17, 0.0);
            for (i, s) in samples.iter().enumerate() {
                if i % 40 >= 7 && i % 40 < 7 + missing {
                    b.skip();
                } else {
                    b.add(*s);
                }
            }
            b.finish()
        };
        let bridged = with_gaps(MAX_BRIDGED_ROWS as usize);
        assert_eq!(bridged.len(), full.len());
        for (a, b) in bridged.iter().zip(&full) {
            for (x, y) in a.gap_um.iter().zip(&b.gap_um) {
                assert!((x - y).abs() < 1e-9, "{x} vs {y}");
            }
        }
        // One row more than the bridge every 40: each such run ends the stretch, the gaps
        // crossed in it stay open, and fewer sections complete.
        assert!(with_gaps(MAX_BRIDGED_ROWS as usize + 1).len() < full.len());
    }

    #[test]
    fn no_error_and_a_common_offset_make_no_pitch_deviation() {
        for e in [0.0, 3.7] {
            let s = sections(&cut(5.0, 1000, false, |_, _| e), 17, 0.0);
            // Gap positions every 360/17 deg from 21.2 to 1800 deg: 85 crossings, 5 sections.
            assert_eq!(s.len(), 5);
            let g = PredictedGear::of(&s, 5, 85.0, 5.0, 40.0).unwrap();
            assert!(
                g.single_pitch_um < 1e-12 && g.cumulative_pitch_um < 1e-12 && g.helix_um < 1e-12,
                "{g:?}"
            );
            assert!(s.iter().all(|x| x.gap_um.iter().all(|v| (v - e).abs() < 1e-12)));
        }
    }

    #[test]
    fn a_once_per_revolution_error_is_cumulative_pitch_twice_its_amplitude() {
        // Eccentricity: e = A sin(table). Gaps sample it at 360/z apart: F_p = 2A (to the
        // sampling of the sine), f_pt = 2 A sin(pi / z).
        let (a, z) = (1.5, 17u32);
        for backwards in [false, true] {
            let s = sections(
                &cut(4.0, 3600, backwards, |deg, _| a * deg.to_radians().sin()),
                z,
                0.0,
            );
            let g = PredictedGear::of(&s, 5, 85.0, 5.0, 40.0).unwrap();
            let fpt = 2.0 * a * (PI / f64::from(z)).sin();
            assert!(
                (g.single_pitch_um - fpt).abs() < 1e-3,
                "{backwards}: {g:?} vs {fpt}"
            );
            // z samples of a sine: the largest is at least cos(pi / z) of its peak.
            let fp_min = 2.0 * a * (PI / f64::from(z)).cos();
            assert!(
                g.cumulative_pitch_um <= 2.0 * a + 1e-9 && g.cumulative_pitch_um >= fp_min - 1e-3,
                "{backwards}: {g:?}"
            );
            assert!(g.helix_um < 1e-3, "the same error every revolution: no helix");
        }
    }

    #[test]
    fn one_gap_cut_late_shows_in_both_of_its_neighbouring_pitches() {
        // 2 um at gap 5 only (the table late while it passed): f_pt = 2, F_p = 2.
        let z = 20u32;
        let pitch = 360.0 / f64::from(z);
        let s = sections(
            &cut(3.0, 7200, false, |deg, _| {
                let at = (deg / pitch - 5.0).rem_euclid(f64::from(z));
                if !(0.05..=z as f64 - 0.05).contains(&at) {
                    2.0
                } else {
                    0.0
                }
            }),
            z,
            0.0,
        );
        let g = PredictedGear::of(&s, 5, 85.0, 5.0, 40.0).unwrap();
        assert!(
            (g.single_pitch_um - 2.0).abs() < 1e-9 && (g.cumulative_pitch_um - 2.0).abs() < 1e-9,
            "{g:?}"
        );
        assert!(s.iter().all(|x| (x.gap_um[5] - 2.0).abs() < 1e-9));
    }

    #[test]
    fn a_drift_along_the_face_is_helix_not_pitch() {
        // 0.5 um more per mm of Y, 2 mm per section: each gap moves 1 um per section, the
        // pitch only by the drift within one revolution between neighbours.
        let s = sections(&cut(5.0, 3600, false, |_, y| 0.5 * y), 17, 0.0);
        let g = PredictedGear::of(&s, 5, 85.0, 5.0, 40.0).unwrap();
        assert!((g.helix_um - 1.0 * (s.len() - 1) as f64).abs() < 1e-6, "{g:?}");
        // Neighbours 1/17 revolution apart: 2/17 mm of Y, except across the section's start
        // and end (a whole revolution less one pitch).
        assert!(g.single_pitch_um <= 0.5 * 2.0 + 1e-9, "{g:?}");
        let (fpt, fp, fh) = g.shares();
        assert!(fpt > 0.0 && fp > 0.0 && fh > 0.0);
    }

    /// A helical cut by a `starts`-start hob on `z` teeth: the table follows the gearbox
    /// law `table = starts / z * spindle + diff * Y` (Y feeding 2 mm per table revolution),
    /// the error a function of the table angle, Y and the spindle.
    fn helical(z: u32, starts: u32, revs: f64, e: impl Fn(f64, f64, f64) -> f64) -> Vec<TrueSample> {
        let diff_deg_per_mm = 7.3;
        let ratio = f64::from(starts) / f64::from(z);
        let steps = 20_000;
        let n = (revs * steps as f64) as usize;
        (0..=n)
            .map(|i| {
                let spindle = i as f64 / steps as f64 * 360.0 / ratio + 1.1;
                let y = 2.0 * ratio * spindle / 360.0;
                let table = ratio * spindle + diff_deg_per_mm * y;
                TrueSample {
                    table_deg: table,
                    spindle_deg: spindle,
                    y_mm: y,
                    error_um: e(table, y, spindle),
                }
            })
            .collect()
    }

    #[test]
    fn the_hobs_gaps_follow_the_helix_where_fixed_table_angles_do_not() {
        // An error of the gaps themselves: a once-per-revolution eccentricity of the gear
        // along its helix (the table angle less the law's Y term), which the gaps carry
        // unchanged from face section to section.
        let on_the_gear = |table: f64, y: f64, _| 2.0 * ((table - 7.3 * y).to_radians()).sin();
        let cut = helical(17, 2, 6.0, on_the_gear);
        let hob = sections_at(
            &cut,
            17,
            GapsAt::Hob {
                starts: 2,
                phase_deg: 0.0,
            },
        );
        let table = sections_at(&cut, 17, GapsAt::Table { phase_deg: 0.0 });
        assert!(
            hob.len() >= 5 && table.len() >= 5,
            "{} {}",
            hob.len(),
            table.len()
        );
        let of = |s: &[Section]| PredictedGear::of(s, 5, 85.0, 5.0, 30.0).unwrap();
        let (at_hob, at_table) = (of(&hob), of(&table));
        // Each gap keeps its position along the face at the hob's gaps: no helix; at fixed
        // table angles the gaps slide under the sampling and the eccentricity shows as helix.
        assert!(at_hob.helix_um < 1e-3, "{at_hob:?}");
        assert!(at_table.helix_um > 0.5, "{at_table:?}");
        // Either way a section holds a whole revolution of it: F_p is twice the amplitude.
        for g in [&at_hob, &at_table] {
            assert!((g.cumulative_pitch_um - 4.0).abs() < 0.05, "{g:?}");
        }
    }

    #[test]
    fn the_hobs_phase_moves_where_a_spindle_error_is_sampled_and_worst_takes_the_largest() {
        // A once-per-hob-turn error of a two-start hob: the gaps cut at spindle 0 and 180
        // deg alternate by twice its cosine, at 90 and 270 deg they see nothing.
        let runout = |_, _, spindle: f64| 1.5 * spindle.to_radians().cos();
        let cut = helical(17, 2, 4.0, runout);
        let at = |phase_deg| {
            let s = sections_at(&cut, 17, GapsAt::Hob { starts: 2, phase_deg });
            PredictedGear::of(&s, 5, 85.0, 5.0, 30.0).unwrap()
        };
        let (zero, quarter) = (at(0.0), at(90.0));
        // 17 gaps: around the gear the alternation meets itself once (a step of 0).
        assert!((zero.single_pitch_um - 3.0).abs() < 1e-3, "{zero:?}");
        assert!(quarter.single_pitch_um < 1e-3, "{quarter:?}");
        let w = quarter.worst(&zero);
        assert_eq!(w.single_pitch_um, zero.single_pitch_um);
        assert_eq!(w.cumulative_pitch_um, zero.cumulative_pitch_um);
        assert_eq!(w.sections, zero.sections.min(quarter.sections));
    }
}
