//! The trace of a cut, row by row, and its per-pass statistics: the format `hob log
//! export` writes from a recording and the simulated machine writes from a run, and what
//! `hob log report` and the demo judge the cut by.

use crate::predicted::{GapsAt, PHASES, PredictedGear, SectionBuilder, TrueSample};
use hob_gearing::iso1328::single_pitch_tolerance_um;
use hob_gearing::units::arcsec_to_um_at_radius;
use hob_ipc::codec::State;
use serde::Serialize;

/// Columns of `trace.csv`, in order.
///
/// `sync_err_arcsec` is the controller's share of the error: the table as the B motor
/// turned it through an ideal worm (its true angle over the ratio) against the gearbox law
/// for the true spindle angle and Y (empty unless the gearbox is synchronised; a
/// recording holds the controller's own estimate here); `work_twist_arcsec` is the work's
/// elastic twist on the table under the cut, which no encoder sees; `feed_override_percent`
/// (the axial feed Y) and `spindle_override_percent` are the overrides in force (empty where
/// a recording holds none); `blank_err_arcsec` is the truth, what the gear gets: the blank's
/// angle after the worm's errors, its play and deflection and the work's twist, against the
/// same law (empty where it is not known: a recording).
pub const TRACE_HEADER: &str = "t_s,state,pass,spindle_deg,table_deg,table_cmd_deg,x_mm,x_cmd_mm,y_mm,y_cmd_mm,sync_err_arcsec,work_twist_arcsec,feed_override_percent,spindle_override_percent,blank_err_arcsec";

/// One trace row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceRow {
    pub t_s: f64,
    /// The sequencer state, as its code in the contract between processes (the simulated
    /// machine writes the control core's state, the wire's own `State`).
    pub state: State,
    pub hold: bool,
    pub pass: u32,
    pub spindle_deg: f64,
    pub table_deg: f64,
    pub table_cmd_deg: f64,
    pub x_mm: f64,
    pub x_cmd_mm: f64,
    pub y_mm: f64,
    pub y_cmd_mm: f64,
    /// The controller's share of the synchronisation error while the gearbox is
    /// synchronised (the drive's motion through an ideal worm against the law).
    pub sync_err_arcsec: Option<f64>,
    pub work_twist_arcsec: f64,
    /// The blank's true error against the law while the gearbox is synchronised: the
    /// worm, its play and deflection and the work's twist included; none where not known.
    pub blank_err_arcsec: Option<f64>,
    /// Feed override (the axial feed Y) set, percent, as the controller's status gives it
    /// (the spindle's speed follows its override on a ramp); none where it was not
    /// recorded (a log written before the overrides were).
    pub feed_override_percent: Option<f64>,
    /// Spindle speed override in force, percent; none where it was not recorded.
    pub spindle_override_percent: Option<f64>,
    /// The pitch compensation's state (`hob_ipc::pitch_compensation`: none, off, on); none
    /// where not known. Not a column of the trace's CSV.
    pub pitch_compensation: Option<u8>,
}

impl TraceRow {
    /// The state word of the trace: `hold` overrides the state while feed hold is on.
    pub fn state_word(&self) -> &'static str {
        if self.hold { "hold" } else { self.state.name() }
    }

    /// The row as CSV (no newline).
    pub fn csv(&self) -> String {
        let err = self.sync_err_arcsec.map_or(String::new(), |e| format!("{e:.3}"));
        let blank = self.blank_err_arcsec.map_or(String::new(), |e| format!("{e:.3}"));
        let feed = self
            .feed_override_percent
            .map_or(String::new(), |v| format!("{v:.2}"));
        let spindle = self
            .spindle_override_percent
            .map_or(String::new(), |v| format!("{v:.2}"));
        format!(
            "{:.3},{},{},{:.6},{:.6},{:.6},{:.5},{:.5},{:.5},{:.5},{err},{:.3},{feed},{spindle},{blank}",
            self.t_s,
            self.state_word(),
            self.pass,
            self.spindle_deg,
            self.table_deg,
            self.table_cmd_deg,
            self.x_mm,
            self.x_cmd_mm,
            self.y_mm,
            self.y_cmd_mm,
            self.work_twist_arcsec,
        )
    }
}

/// What the durations of a pass ([`PassSummary`]) count, in the words every report
/// prints them with (`hob log report`, the HMI's cut report, `summary.json`'s fields).
pub const DURATIONS: &str = "cut s: the time at feed in the cut (state cut, feed hold not counted); pass s: the pass's own cycles, from its start to its end (the rapids, the feed holds and a fault's retract counted), not the time stood between them (in a fault, stopped, jogging or referencing before a continue); stood s: that time stood";

/// Synchronisation error statistics of one pass, in the cut.
///
/// The durations ([`DURATIONS`]) count the cycles recorded (rows) times the cycle period: a
/// sample the logger missed counts in none of them.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct PassSummary {
    pub pass: u32,
    /// The time at feed in the cut: rows in state cut without feed hold.
    pub cut_time_s: f64,
    /// The pass's own time: every row of this pass (the cycle running it, from its start to
    /// its end), the rapids, feed holds and a fault's retract included; the time stood
    /// between (`stood_s`) not.
    pub pass_time_s: f64,
    /// The time the pass stood between its own rows: rows out of a cycle (in a fault,
    /// stopped, jogging or referencing) before the pass went on (a continue).
    pub stood_s: f64,
    pub samples: u64,
    pub sync_err_rms_arcsec: f64,
    pub sync_err_max_arcsec: f64,
    pub sync_err_rms_um: f64,
    pub sync_err_max_um: f64,
    /// Mean error (a constant phase offset within the pass: no pitch error).
    pub sync_err_mean_arcsec: f64,
    /// Largest deviation from the pass mean.
    pub sync_err_max_dev_arcsec: f64,
    pub sync_err_max_dev_um: f64,
    /// Largest elastic twist of the work on the table in the cut (machine, not control).
    pub work_twist_max_arcsec: f64,
    pub work_twist_max_um: f64,
    /// Y travelled in the cut (feed hold excluded): what the pass wore the tool by.
    pub y_travel_in_cut_mm: f64,
    /// The lowest and highest feed override (the axial feed Y) in the cut, percent, over
    /// the rows in state cut without feed hold, as Y travel: the rapids, the retract and
    /// a hold feed nothing. None (JSON null) when the pass has no such row with the
    /// override recorded: never a made-up 100 %.
    pub feed_override_min_percent: Option<f64>,
    pub feed_override_max_percent: Option<f64>,
    /// The lowest and highest spindle speed override in the cut, percent, over the same
    /// rows; none likewise.
    pub spindle_override_min_percent: Option<f64>,
    pub spindle_override_max_percent: Option<f64>,
    /// The pitch compensation in the cut (`none`, `off`, `on`, the first cut row's: it
    /// cannot be switched in a cycle); none where not recorded or the pass has no cut row.
    pub pitch_compensation: Option<&'static str>,
    /// What ISO 1328-1 would measure on the gear this pass left, from the blank's true
    /// error (`blank_err_arcsec`) where each tooth gap passed the hob
    /// ([`crate::predicted`]): the worm, its play and deflection and the work's twist
    /// included. None where the truth or the gear's teeth are not known (a recorded log) or
    /// the pass did not complete a table revolution in the cut.
    pub predicted: Option<PredictedGear>,
    /// The controller's share of the same deviations: from `sync_err_arcsec`, the drive's
    /// motion through an ideal worm. None likewise.
    pub controller_share: Option<PredictedGear>,
    /// `predicted` and `controller_share` take the gaps at fixed table angles `k * 360 /
    /// z` (as the compensation's checker and record do, `crate::gaps`); these take them
    /// where the hob cut them ([`crate::predicted::GapsAt::Hob`]): at the hob's phase 0
    /// (the simulated machine's hob has its reference thread at the spindle's zero) ...
    pub predicted_at_hob: Option<PredictedGear>,
    pub controller_share_at_hob: Option<PredictedGear>,
    /// ... and each deviation's worst over the hob's phase ([`crate::predicted::PHASES`]
    /// phases of its thread against the spindle's zero, which the controller does not
    /// know; phase 0 among them).
    pub predicted_worst_phase: Option<PredictedGear>,
    pub controller_share_worst_phase: Option<PredictedGear>,
    /// Largest blank error in the cut (the truth), arcsec; none where not known.
    pub blank_err_max_arcsec: Option<f64>,
    /// Y of the previous row in the cut of this pass (none after a row out of the cut).
    #[serde(skip)]
    last_cut_y_mm: Option<f64>,
    #[serde(skip)]
    sum: f64,
    #[serde(skip)]
    sum_sq: f64,
    #[serde(skip)]
    min: f64,
    #[serde(skip)]
    max: f64,
}

/// Collects the per-pass statistics of the cut from trace rows.
#[derive(Debug, Clone, Default)]
pub struct SummaryBuilder {
    passes: Vec<PassSummary>,
    pitch_radius_mm: f64,
    normal_module_mm: f64,
    /// The gear's teeth, the hob's starts, the face width and the grade its predicted
    /// deviations are judged at, when known ([`Self::predicting`]).
    gear: Option<(u32, u32, f64, u8)>,
    /// Per pass: the controller's share's sections and the blank's, at the table's fixed
    /// angles first, then per phase of the hob ([`PHASES`], phase 0 first).
    sections: Vec<Vec<[SectionBuilder; 2]>>,
    /// The index of the pass of the last row in a pass, and the time out of any pass since
    /// (counted as stood by that pass if it goes on).
    last_pass: Option<usize>,
    out_of_pass_s: f64,
}

impl SummaryBuilder {
    /// For a gear known by its pitch radius and normal module (a recorded log).
    pub fn for_gear(pitch_radius_mm: f64, normal_module_mm: f64) -> Self {
        Self {
            passes: Vec::new(),
            pitch_radius_mm,
            normal_module_mm,
            gear: None,
            sections: Vec::new(),
            last_pass: None,
            out_of_pass_s: 0.0,
        }
    }

    /// Also predicts the gear each pass leaves (`PassSummary::predicted`): `teeth` gaps cut
    /// by a hob of `starts` starts (the gaps where it cut them, [`GapsAt::Hob`]), the face
    /// width, judged against ISO 1328-1 grade `grade`.
    pub fn predicting(mut self, teeth: u32, starts: u32, face_width_mm: f64, grade: u8) -> Self {
        self.gear = Some((teeth, starts.max(1), face_width_mm, grade));
        self
    }

    /// The per-pass statistics, and the ISO 1328-1 grade-5 single pitch tolerance (um).
    pub fn passes(mut self) -> (Vec<PassSummary>, f64) {
        let r = self.pitch_radius_mm;
        for p in &mut self.passes {
            if p.samples == 0 {
                continue;
            }
            let n = p.samples as f64;
            let mean = p.sum / n;
            p.sync_err_rms_arcsec = (p.sum_sq / n).sqrt();
            p.sync_err_max_arcsec = p.max.abs().max(p.min.abs());
            p.sync_err_mean_arcsec = mean;
            p.sync_err_max_dev_arcsec = (p.max - mean).abs().max((p.min - mean).abs());
            p.sync_err_rms_um = arcsec_to_um_at_radius(p.sync_err_rms_arcsec, r);
            p.sync_err_max_um = arcsec_to_um_at_radius(p.sync_err_max_arcsec, r);
            p.sync_err_max_dev_um = arcsec_to_um_at_radius(p.sync_err_max_dev_arcsec, r);
            p.work_twist_max_um = arcsec_to_um_at_radius(p.work_twist_max_arcsec, r);
        }
        if let Some((_, _, face_width_mm, grade)) = self.gear {
            let of = |b: SectionBuilder| {
                PredictedGear::of(&b.finish(), grade, 2.0 * r, self.normal_module_mm, face_width_mm)
            };
            let worst = |w: Option<PredictedGear>, g: &Option<PredictedGear>| match (w, g) {
                (Some(w), Some(g)) => Some(w.worst(g)),
                (w, g) => w.or_else(|| g.clone()),
            };
            for (p, phases) in self.passes.iter_mut().zip(self.sections) {
                for (i, [controller, blank]) in phases.into_iter().enumerate() {
                    let (c, b) = (of(controller), of(blank));
                    if i == 0 {
                        (p.controller_share, p.predicted) = (c, b);
                        continue;
                    }
                    p.controller_share_worst_phase = worst(p.controller_share_worst_phase.take(), &c);
                    p.predicted_worst_phase = worst(p.predicted_worst_phase.take(), &b);
                    if i == 1 {
                        (p.controller_share_at_hob, p.predicted_at_hob) = (c, b);
                    }
                }
            }
        }
        let tol = single_pitch_tolerance_um(2.0 * r, self.normal_module_mm, 5);
        (self.passes, tol)
    }

    pub fn add(&mut self, row: &TraceRow, period_s: f64) {
        if row.pass == 0 {
            // Out of a cycle: stood, if the pass before goes on.
            if self.last_pass.is_some() {
                self.out_of_pass_s += period_s;
            }
            return;
        }
        let idx = row.pass as usize - 1;
        while self.passes.len() <= idx {
            self.passes.push(PassSummary {
                pass: self.passes.len() as u32 + 1,
                min: f64::INFINITY,
                max: f64::NEG_INFINITY,
                ..PassSummary::default()
            });
        }
        if let Some((teeth, starts, _, _)) = self.gear {
            while self.sections.len() <= idx {
                self.sections.push(hob_phases(teeth, starts));
            }
            // The gaps are generated while the hob is in the cut, a feed hold included (the
            // table turns on, Y stands): every synchronised row in the cut.
            let in_cut = row.state == State::Cut;
            for b in self.sections[idx].iter_mut() {
                for (b, err) in b.iter_mut().zip([row.sync_err_arcsec, row.blank_err_arcsec]) {
                    match (in_cut, err) {
                        (true, Some(e)) => b.add(TrueSample {
                            table_deg: row.table_deg,
                            spindle_deg: row.spindle_deg,
                            y_mm: row.y_mm,
                            error_um: arcsec_to_um_at_radius(e, self.pitch_radius_mm),
                        }),
                        // In the cut without a true sample (a recording's truth has none
                        // for a SYNC the simulated machine did not answer): bridged when
                        // short.
                        (true, None) => b.skip(),
                        (false, _) => b.interrupt(),
                    }
                }
            }
        }
        let stood_s = std::mem::take(&mut self.out_of_pass_s);
        let goes_on = self.last_pass.replace(idx) == Some(idx);
        let p = &mut self.passes[idx];
        if goes_on {
            p.stood_s += stood_s;
        }
        p.pass_time_s += period_s;
        if row.state == State::Cut && !row.hold {
            if let Some(y) = p.last_cut_y_mm {
                p.y_travel_in_cut_mm += (row.y_mm - y).abs();
            }
            p.last_cut_y_mm = Some(row.y_mm);
            p.cut_time_s += period_s;
            p.work_twist_max_arcsec = p.work_twist_max_arcsec.max(row.work_twist_arcsec.abs());
            widen(
                &mut p.feed_override_min_percent,
                &mut p.feed_override_max_percent,
                row.feed_override_percent,
            );
            widen(
                &mut p.spindle_override_min_percent,
                &mut p.spindle_override_max_percent,
                row.spindle_override_percent,
            );
            if let Some(e) = row.blank_err_arcsec {
                p.blank_err_max_arcsec = Some(p.blank_err_max_arcsec.unwrap_or(0.0).max(e.abs()));
            }
            if p.pitch_compensation.is_none() {
                p.pitch_compensation = row.pitch_compensation.map(hob_ipc::pitch_compensation::name);
            }
            if let Some(e) = row.sync_err_arcsec {
                p.samples += 1;
                p.sum += e;
                p.sum_sq += e * e;
                p.min = p.min.min(e);
                p.max = p.max.max(e);
            }
        } else {
            p.last_cut_y_mm = None;
        }
    }
}

/// One pass's section builders, the controller's share's and the blank's: at the table's
/// fixed angles, then per phase of the hob's thread ([`PHASES`] of `360 / starts` deg,
/// phase 0 first).
fn hob_phases(teeth: u32, starts: u32) -> Vec<[SectionBuilder; 2]> {
    let hob = (0..PHASES).map(|i| GapsAt::Hob {
        starts,
        phase_deg: i as f64 / PHASES as f64 * 360.0 / f64::from(starts),
    });
    std::iter::once(GapsAt::Table { phase_deg: 0.0 })
        .chain(hob)
        .map(|at| [SectionBuilder::at(teeth, at), SectionBuilder::at(teeth, at)])
        .collect()
}

/// Widens a range `[min, max]` (none: empty) to hold `v` (none or not finite: nothing).
fn widen(min: &mut Option<f64>, max: &mut Option<f64>, v: Option<f64>) {
    if let Some(v) = v.filter(|v| v.is_finite()) {
        *min = Some(min.map_or(v, |m| m.min(v)));
        *max = Some(max.map_or(v, |m| m.max(v)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t_s: f64, state: State, hold: bool, pass: u32, y_mm: f64) -> TraceRow {
        TraceRow {
            t_s,
            state,
            hold,
            pass,
            spindle_deg: 0.0,
            table_deg: 0.0,
            table_cmd_deg: 0.0,
            x_mm: 0.0,
            x_cmd_mm: 0.0,
            y_mm,
            y_cmd_mm: y_mm,
            sync_err_arcsec: None,
            work_twist_arcsec: 0.0,
            blank_err_arcsec: None,
            feed_override_percent: Some(100.0),
            spindle_override_percent: Some(100.0),
            pitch_compensation: None,
        }
    }

    #[test]
    fn y_travel_counts_only_the_cut_without_hold() {
        let mut b = SummaryBuilder::for_gear(42.5, 5.0);
        let rows = [
            (State::ToStart, false, 1, 100.0), // the rapid to the start: not cut
            (State::Cut, false, 1, 90.0),
            (State::Cut, false, 1, 80.0),
            (State::Cut, true, 1, 80.0),  // feed hold
            (State::Cut, false, 1, 78.0), // resumed
            (State::Retract, false, 1, 150.0),
            (State::Cut, false, 2, 90.0),
            (State::Cut, false, 2, 89.5),
        ];
        for (i, (state, hold, pass, y)) in rows.into_iter().enumerate() {
            b.add(&row(i as f64 * 1e-3, state, hold, pass, y), 1e-3);
        }
        let (passes, _) = b.passes();
        assert_eq!(passes.len(), 2);
        assert!(
            (passes[0].y_travel_in_cut_mm - 10.0).abs() < 1e-12,
            "{:?}",
            passes[0]
        );
        assert!(
            (passes[1].y_travel_in_cut_mm - 0.5).abs() < 1e-12,
            "{:?}",
            passes[1]
        );
    }

    /// The durations of a pass broken off by a fault and continued: the time stood in the
    /// fault (rows out of a cycle, pass 0) counts in neither its pass time nor its cut time.
    #[test]
    fn a_pass_continued_after_a_fault_counts_not_the_time_stood_in_it() {
        let mut b = SummaryBuilder::for_gear(42.5, 5.0);
        let mut t = 0.0;
        let mut rows = |b: &mut SummaryBuilder, n: usize, state: State, hold: bool, pass: u32| {
            for _ in 0..n {
                b.add(&row(t, state, hold, pass, 0.0), 0.1);
                t += 0.1;
            }
        };
        rows(&mut b, 20, State::Idle, false, 0); // before the start: not the pass's
        rows(&mut b, 30, State::ToStart, false, 1); // 3 s to the start
        rows(&mut b, 100, State::Cut, false, 1); // 10 s at feed
        rows(&mut b, 10, State::Cut, true, 1); // 1 s feed hold
        rows(&mut b, 20, State::FaultRetract, false, 1); // 2 s: the fault's retract
        rows(&mut b, 870, State::Faulted, false, 0); // 87 s stood in the fault
        rows(&mut b, 50, State::Idle, false, 0); // 5 s reset, before the continue
        rows(&mut b, 40, State::ToStart, false, 1); // continued: 4 s back in
        rows(&mut b, 150, State::Cut, false, 1); // 15 s at feed
        rows(&mut b, 20, State::Retract, false, 1); // 2 s out
        rows(&mut b, 30, State::Idle, false, 0); // after the cycle: not stood
        let (passes, _) = b.passes();
        assert_eq!(passes.len(), 1);
        let p = &passes[0];
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert!(close(p.cut_time_s, 25.0), "{p:?}");
        assert!(
            close(p.pass_time_s, 3.0 + 10.0 + 1.0 + 2.0 + 4.0 + 15.0 + 2.0),
            "{p:?}"
        );
        assert!(close(p.stood_s, 87.0 + 5.0), "{p:?}");
        let json = serde_json::to_value(p).unwrap();
        assert!(
            json.get("time_s").is_none(),
            "no field of another meaning under the old name: {json}"
        );
        assert!(json["pass_time_s"].as_f64().is_some() && json["stood_s"].as_f64().is_some());
    }

    /// A pass that starts after another ended stood for none of the time between them.
    #[test]
    fn the_time_between_two_passes_is_stood_by_neither() {
        let mut b = SummaryBuilder::for_gear(42.5, 5.0);
        let states = [
            (State::Cut, 1),
            (State::Idle, 0),
            (State::Idle, 0),
            (State::Cut, 2),
            (State::Idle, 0),
        ];
        for (i, (state, pass)) in states.into_iter().enumerate() {
            b.add(&row(i as f64, state, false, pass, 0.0), 1.0);
        }
        let (passes, _) = b.passes();
        assert_eq!(passes.iter().map(|p| p.stood_s).collect::<Vec<_>>(), [0.0, 0.0]);
        assert_eq!(
            passes.iter().map(|p| p.pass_time_s).collect::<Vec<_>>(),
            [1.0, 1.0]
        );
    }

    /// A row of the override tests: state, hold, pass, feed %, spindle %.
    type OverrideRow = (State, bool, u32, Option<f64>, Option<f64>);

    /// The per-pass statistics of rows.
    fn ranges_of(rows: &[OverrideRow]) -> Vec<PassSummary> {
        let mut b = SummaryBuilder::for_gear(42.5, 5.0);
        for (i, &(state, hold, pass, feed, spindle)) in rows.iter().enumerate() {
            let r = TraceRow {
                feed_override_percent: feed,
                spindle_override_percent: spindle,
                ..row(i as f64 * 1e-3, state, hold, pass, 0.0)
            };
            b.add(&r, 1e-3);
        }
        b.passes().0
    }

    #[test]
    fn override_ranges_count_only_the_cut_without_hold() {
        let passes = ranges_of(&[
            // The rapid to the start at 20 %: not the cut.
            (State::ToStart, false, 1, Some(20.0), Some(50.0)),
            (State::Cut, false, 1, Some(100.0), Some(100.0)),
            (State::Cut, false, 1, Some(80.0), Some(100.0)), // turned down in the cut
            (State::Cut, true, 1, Some(0.0), Some(60.0)),    // feed hold: excluded
            (State::Cut, false, 1, Some(90.0), Some(110.0)), // resumed, spindle up
            (State::Retract, false, 1, Some(120.0), Some(120.0)),
            (State::Cut, false, 2, Some(100.0), Some(95.0)),
        ]);
        assert_eq!(passes.len(), 2);
        let p = &passes[0];
        assert_eq!(p.feed_override_min_percent, Some(80.0), "{p:?}");
        assert_eq!(p.feed_override_max_percent, Some(100.0), "{p:?}");
        assert_eq!(p.spindle_override_min_percent, Some(100.0), "{p:?}");
        assert_eq!(p.spindle_override_max_percent, Some(110.0), "{p:?}");
        let p = &passes[1];
        assert_eq!(p.feed_override_min_percent, Some(100.0), "{p:?}");
        assert_eq!(p.feed_override_max_percent, Some(100.0), "{p:?}");
        assert_eq!(p.spindle_override_min_percent, Some(95.0), "{p:?}");
        assert_eq!(p.spindle_override_max_percent, Some(95.0), "{p:?}");
    }

    #[test]
    fn override_ranges_are_none_without_a_recorded_row_in_the_cut() {
        let passes = ranges_of(&[
            // Pass 1 never cut: held all along, and rows out of the cut.
            (State::ToStart, false, 1, Some(70.0), Some(70.0)),
            (State::Cut, true, 1, Some(70.0), Some(70.0)),
            (State::Retract, false, 1, Some(70.0), Some(70.0)),
            // Pass 2 cut in a log that did not record the overrides (read as NaN).
            (State::Cut, false, 2, None, None),
            (State::Cut, false, 2, Some(f64::NAN), Some(f64::NAN)),
        ]);
        assert_eq!(passes.len(), 2);
        for p in &passes {
            assert_eq!(p.feed_override_min_percent, None, "{p:?}");
            assert_eq!(p.feed_override_max_percent, None, "{p:?}");
            assert_eq!(p.spindle_override_min_percent, None, "{p:?}");
            assert_eq!(p.spindle_override_max_percent, None, "{p:?}");
        }
        assert!(passes[1].cut_time_s > 0.0);
        let json = serde_json::to_value(&passes[0]).unwrap();
        assert!(json["feed_override_min_percent"].is_null(), "{json}");
    }

    #[test]
    fn the_csv_row_has_a_column_per_header_column_with_the_overrides_then_the_truth_last() {
        let mut r = row(0.0, State::Cut, false, 1, 5.0);
        r.feed_override_percent = Some(85.0);
        r.spindle_override_percent = Some(110.5);
        r.blank_err_arcsec = Some(-2.25);
        let cols: Vec<String> = r.csv().split(',').map(str::to_string).collect();
        let header: Vec<&str> = TRACE_HEADER.split(',').collect();
        assert_eq!(cols.len(), header.len(), "{cols:?}");
        assert_eq!(
            header[header.len() - 3..],
            [
                "feed_override_percent",
                "spindle_override_percent",
                "blank_err_arcsec"
            ]
        );
        assert_eq!(cols[cols.len() - 3..], ["85.00", "110.50", "-2.250"]);
        r.feed_override_percent = None;
        r.spindle_override_percent = None;
        r.blank_err_arcsec = None;
        let cols: Vec<String> = r.csv().split(',').map(str::to_string).collect();
        assert_eq!(cols.len(), header.len(), "{cols:?}");
        assert_eq!(cols[cols.len() - 3..], ["", "", ""]);
    }
}
