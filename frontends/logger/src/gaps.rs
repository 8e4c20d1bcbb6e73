//! The cut's own record at each tooth gap (issue 34): for every face section of the last
//! pass, where the hob's spindle stood and how far the controller itself was off when each
//! gap passed the hob. A compensation takes the controller's share out of a measured gear
//! with it (so that it is not compensated twice) and tells the hob's errors from the
//! table's by the hob's phase.
//!
//! The gaps are those of [`crate::predicted`]: where the hob cut them
//! ([`GapRecorder::at_hob`], `GapsAt::Hob`), or at the fixed table angles `i * 360 / z`
//! ([`GapRecorder::new`]), crossed in whichever direction the table turns; a section is
//! complete when every gap has passed once, and its gaps are given in table order
//! (`Section::table_order`) with the table angle each passed at. Every quantity is
//! interpolated at the crossing. The record and the checker's measurement must take the
//! same gaps: `hob_gear_check::decompose` matches them by table angle.

use crate::predicted::{GapsAt, Section, SectionBuilder, TrueSample};
use crate::trace::TraceRow;
use hob_gear_check::decompose::GapRecord;
use hob_gearing::units::arcsec_to_um_at_radius;
use hob_ipc::codec::State;

/// One face section of the record: gap `i` in table order.
#[derive(Debug, Clone, PartialEq)]
pub struct GapSection {
    /// The section's mean Y, mm.
    pub y_mm: f64,
    /// The table angle each gap passed the hob at, deg, modulo 360, ascending from the
    /// section's gap 0.
    pub table_deg: Vec<f64>,
    /// The spindle's angle when it passed, deg (unwrapped).
    pub hob_phase_deg: Vec<f64>,
    /// The controller's own synchronism error then, um at the pitch circle.
    pub controller_um: Vec<f64>,
}

impl GapSection {
    /// Each gap's record as the decomposition takes it, in table order.
    pub fn records(&self) -> Vec<GapRecord> {
        (0..self.table_deg.len())
            .map(|i| GapRecord {
                table_deg: self.table_deg[i],
                hob_phase_deg: self.hob_phase_deg[i],
                controller_um: self.controller_um[i],
            })
            .collect()
    }
}

/// The section nearest the height `y_mm` (the hob's Y when it was cut); none without any.
pub fn nearest(sections: &[GapSection], y_mm: f64) -> Option<&GapSection> {
    sections
        .iter()
        .min_by(|a, b| (a.y_mm - y_mm).abs().total_cmp(&(b.y_mm - y_mm).abs()))
}

/// Collects the last pass's gap sections from a cut's trace rows.
#[derive(Debug, Clone)]
pub struct GapRecorder {
    teeth: u32,
    at: GapsAt,
    pitch_radius_mm: f64,
    pass: u32,
    /// The controller's error at each crossing; the section gives the table's and the
    /// spindle's angle there too.
    controller: SectionBuilder,
}

impl GapRecorder {
    /// Gaps at fixed table angles `i * 360 / z` ([`GapsAt::Table`]).
    pub fn new(teeth: u32, pitch_radius_mm: f64) -> Self {
        Self::at(teeth, GapsAt::Table { phase_deg: 0.0 }, pitch_radius_mm)
    }

    /// The gaps where a hob of `starts` starts cut them ([`GapsAt::Hob`], its phase 0: as
    /// the simulated checker measures them).
    pub fn at_hob(teeth: u32, starts: u32, pitch_radius_mm: f64) -> Self {
        Self::at(
            teeth,
            GapsAt::Hob {
                starts,
                phase_deg: 0.0,
            },
            pitch_radius_mm,
        )
    }

    fn at(teeth: u32, at: GapsAt, pitch_radius_mm: f64) -> Self {
        Self {
            teeth,
            at,
            pitch_radius_mm,
            pass: 0,
            controller: SectionBuilder::at(teeth, at),
        }
    }

    /// The next row of the cut. A later pass starts afresh: it recuts the gaps.
    pub fn add(&mut self, row: &TraceRow) {
        if row.pass == 0 {
            self.controller.interrupt();
            return;
        }
        if row.pass != self.pass {
            self.pass = row.pass;
            self.controller = SectionBuilder::at(self.teeth, self.at);
        }
        match (row.state == State::Cut, row.sync_err_arcsec) {
            (true, Some(e)) => self.controller.add(TrueSample {
                table_deg: row.table_deg,
                spindle_deg: row.spindle_deg,
                y_mm: row.y_mm,
                error_um: arcsec_to_um_at_radius(e, self.pitch_radius_mm),
            }),
            (true, None) => self.controller.skip(),
            (false, _) => self.controller.interrupt(),
        }
    }

    /// The last pass's complete sections, in the order cut, each's gaps in table order
    /// ([`Section::table_order`]) at the table angles they passed the hob at (modulo 360).
    pub fn finish(self) -> Vec<GapSection> {
        self.controller
            .finish()
            .into_iter()
            .map(|c: Section| {
                let order = c.table_order();
                let pick = |v: &[f64]| order.iter().map(|&k| v[k]).collect::<Vec<f64>>();
                GapSection {
                    y_mm: c.y_mm,
                    table_deg: pick(&c.table_deg).iter().map(|d| d.rem_euclid(360.0)).collect(),
                    hob_phase_deg: pick(&c.spindle_deg),
                    controller_um: pick(&c.gap_um),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t: f64, table_deg: f64, spindle_deg: f64, err_arcsec: f64) -> TraceRow {
        TraceRow {
            t_s: t,
            state: State::Cut,
            hold: false,
            pass: 1,
            spindle_deg,
            table_deg,
            table_cmd_deg: table_deg,
            x_mm: 0.0,
            x_cmd_mm: 0.0,
            y_mm: 10.0,
            y_cmd_mm: 10.0,
            sync_err_arcsec: Some(err_arcsec),
            work_twist_arcsec: 0.0,
            blank_err_arcsec: None,
            feed_override_percent: None,
            spindle_override_percent: None,
            pitch_compensation: None,
        }
    }

    #[test]
    fn each_gap_gets_the_spindle_and_the_error_where_it_passed() {
        // 4 teeth, a table turning 1 deg a row, the spindle 4 times as fast, the error
        // equal to the table angle in arcsec.
        let mut r = GapRecorder::new(4, 100.0);
        for k in 0..=1100 {
            let t = k as f64 - 5.5;
            r.add(&row(k as f64, t, 4.0 * t, t));
        }
        let s = r.finish();
        assert_eq!(s.len(), 3, "{s:?}");
        let first = &s[0];
        assert_eq!(first.table_deg, vec![0.0, 90.0, 180.0, 270.0]);
        // Gap 0 crossed at table 0 deg (turn 0), gap 1 at 90 deg, ...
        assert_eq!(first.hob_phase_deg, vec![0.0, 360.0, 720.0, 1080.0]);
        let um = arcsec_to_um_at_radius(90.0, 100.0);
        assert!((first.controller_um[1] - um).abs() < 1e-9, "{first:?}");
        assert_eq!(s[1].hob_phase_deg[0], 1440.0);
        assert_eq!(nearest(&s, 10.2).map(|n| n.hob_phase_deg[0]), Some(0.0));
        let r = first.records();
        assert_eq!((r[2].table_deg, r[2].hob_phase_deg), (180.0, 720.0));
        assert!((r[1].controller_um - um).abs() < 1e-9);
    }

    #[test]
    fn at_the_hobs_gaps_the_record_is_in_table_order_at_the_angles_they_passed() {
        // 4 teeth, a two-start hob, the table turning backwards 1 deg a row from 0.3 deg,
        // the spindle twice as fast (table = starts / z * spindle): a gap every 180 deg of
        // the spindle (0, -180, -360, ...), every 90 deg of the table (0, -90, -180, ...);
        // 1100 deg of the table: three whole sections.
        let mut r = GapRecorder::at_hob(4, 2, 100.0);
        for k in 0..=1100 {
            let t = 0.3 - k as f64;
            r.add(&row(k as f64, t, 2.0 * t, 10.0));
        }
        let s = r.finish();
        assert_eq!(s.len(), 3, "{s:?}");
        for section in &s {
            // Ascending in the table's positive direction, a pitch apart, modulo 360.
            for w in section.table_deg.windows(2) {
                assert!(
                    ((w[1] - w[0]).rem_euclid(360.0) - 90.0).abs() < 1e-9,
                    "{section:?}"
                );
            }
            let off = |d: f64, step: f64| d.rem_euclid(step).min(step - d.rem_euclid(step));
            assert!(
                section.table_deg.iter().all(|&d| off(d, 90.0) < 1e-9),
                "{section:?}"
            );
            // Every gap passed with the spindle at a multiple of 180 deg.
            assert!(
                section.hob_phase_deg.iter().all(|&p| off(p, 180.0) < 1e-9),
                "{section:?}"
            );
        }
        // The same gap first in both sections.
        assert!((s[0].table_deg[0] - s[1].table_deg[0]).abs() < 1e-9, "{s:?}");
    }
}
