//! The trace of a cut, row by row, and its per-pass statistics: the format `hob log
//! export` writes from a recording and the simulated machine writes from a run, and what
//! `hob log report` and the demo judge the cut by.

use hob_gearing::iso1328::single_pitch_tolerance_um;
use hob_gearing::units::arcsec_to_um_at_radius;
use hob_ipc::codec::State;
use serde::Serialize;

/// Columns of `trace.csv`, in order.
///
/// `sync_err_arcsec` is the true table against the gearbox law for the true spindle angle
/// and Y (empty unless the gearbox is synchronised); `work_twist_arcsec` is the work's
/// elastic twist on the table under the cut, which no encoder sees (reported apart).
pub const TRACE_HEADER: &str = "t_s,state,pass,spindle_deg,table_deg,table_cmd_deg,x_mm,x_cmd_mm,y_mm,y_cmd_mm,sync_err_arcsec,work_twist_arcsec";

/// One trace row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceRow {
    pub t_s: f64,
    /// The sequencer state, as its code in the contract between processes (the simulated
    /// machine encodes the control core's state with `hob_service::encode::state`).
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
    /// True synchronisation error while the gearbox is synchronised.
    pub sync_err_arcsec: Option<f64>,
    pub work_twist_arcsec: f64,
}

impl TraceRow {
    /// The state word of the trace: `hold` overrides the state while feed hold is on.
    pub fn state_word(&self) -> &'static str {
        if self.hold { "hold" } else { self.state.name() }
    }

    /// The row as CSV (no newline).
    pub fn csv(&self) -> String {
        let err = self.sync_err_arcsec.map_or(String::new(), |e| format!("{e:.3}"));
        format!(
            "{:.3},{},{},{:.6},{:.6},{:.6},{:.5},{:.5},{:.5},{:.5},{err},{:.3}",
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

/// Synchronisation error statistics of one pass, in the cut.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct PassSummary {
    pub pass: u32,
    pub time_s: f64,
    pub cut_time_s: f64,
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
    #[serde(skip)]
    first_t: f64,
}

/// Collects the per-pass statistics of the cut from trace rows.
#[derive(Debug, Clone, Default)]
pub struct SummaryBuilder {
    passes: Vec<PassSummary>,
    pitch_radius_mm: f64,
    normal_module_mm: f64,
}

impl SummaryBuilder {
    /// For a gear known by its pitch radius and normal module (a recorded log).
    pub fn for_gear(pitch_radius_mm: f64, normal_module_mm: f64) -> Self {
        Self {
            passes: Vec::new(),
            pitch_radius_mm,
            normal_module_mm,
        }
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
        let tol = single_pitch_tolerance_um(2.0 * r, self.normal_module_mm, 5);
        (self.passes, tol)
    }

    pub fn add(&mut self, row: &TraceRow, period_s: f64) {
        if row.pass == 0 {
            return;
        }
        let idx = row.pass as usize - 1;
        while self.passes.len() <= idx {
            self.passes.push(PassSummary {
                pass: self.passes.len() as u32 + 1,
                first_t: row.t_s,
                min: f64::INFINITY,
                max: f64::NEG_INFINITY,
                ..PassSummary::default()
            });
        }
        let p = &mut self.passes[idx];
        p.time_s = row.t_s - p.first_t + period_s;
        if row.state == State::Cut && !row.hold {
            if let Some(y) = p.last_cut_y_mm {
                p.y_travel_in_cut_mm += (row.y_mm - y).abs();
            }
            p.last_cut_y_mm = Some(row.y_mm);
            p.cut_time_s += period_s;
            p.work_twist_max_arcsec = p.work_twist_max_arcsec.max(row.work_twist_arcsec.abs());
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
}
