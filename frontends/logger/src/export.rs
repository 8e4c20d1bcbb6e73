//! `hob log export|report`: a recorded directory as CSV, and its per-pass statistics.

use crate::trace::{PassSummary, SummaryBuilder, TRACE_HEADER, TraceRow};
use hob_ipc::StateSample;
use hob_ipc::codec::{self, Coupling, State};
use std::fmt::Write as _;
use std::path::Path;

/// The simulation trace's row for a recorded sample (`t0_ns`: the first sample's SYNC).
pub fn trace_row(s: &StateSample, t0_ns: u64) -> TraceRow {
    TraceRow {
        t_s: s.sync_time_ns.saturating_sub(t0_ns) as f64 * 1e-9,
        state: State::from_code(s.state).unwrap_or(State::Init),
        hold: s.hold != 0,
        pass: s.pass,
        spindle_deg: s.spindle_deg,
        table_deg: s.table_deg.actual,
        table_cmd_deg: s.table_deg.command,
        x_mm: s.x_mm.actual,
        x_cmd_mm: s.x_mm.command,
        y_mm: s.y_mm.actual,
        y_cmd_mm: s.y_mm.command,
        sync_err_arcsec: (s.coupling == Coupling::Synchronised.code()).then_some(s.sync_error_arcsec),
        work_twist_arcsec: 0.0,
    }
}

/// Columns after the simulation's (`t_s` .. `sync_err_arcsec`).
const EXTRA: &str =
    "cycle,spindle_rpm,ccc_arcsec,coupling,alarm,digital_inputs,digital_outputs,wake_latency_us,compute_us";

/// The CSV text of a log: the simulation trace's columns up to `sync_err_arcsec`, then
/// the recorded extras (the cycle counter among them).
pub fn export_csv(dir: &Path) -> Result<String, String> {
    let states = crate::read_dir_states(dir)?;
    let sim_cols: Vec<&str> = TRACE_HEADER.split(',').collect();
    let upto = sim_cols
        .iter()
        .position(|c| *c == "sync_err_arcsec")
        .map_or(sim_cols.len(), |i| i + 1);
    let mut out = String::with_capacity(states.len() * 160);
    let _ = writeln!(out, "{},{EXTRA}", sim_cols[..upto].join(","));
    let t0 = states.first().map_or(0, |s| s.sync_time_ns);
    for s in &states {
        let row = trace_row(s, t0).csv();
        let cut: Vec<&str> = row.split(',').take(upto).collect();
        let _ = writeln!(
            out,
            "{},{},{:.3},{:.3},{},{},0x{:06X},0x{:04X},{:.1},{:.1}",
            cut.join(","),
            s.cycle,
            s.spindle_rpm,
            s.ccc_arcsec,
            codec::coupling_name(s.coupling),
            codec::alarm_text(&s.alarm).replace(',', ";"),
            s.digital_inputs,
            s.digital_outputs,
            f64::from(s.wake_latency_ns) / 1e3,
            f64::from(s.compute_ns) / 1e3
        );
    }
    Ok(out)
}

/// Per-pass synchronisation error of a recorded cut.
#[derive(Debug, Clone)]
pub struct Report {
    pub samples: usize,
    pub first_cycle: u64,
    pub last_cycle: u64,
    /// Gaps in the cycle counter inside the recording (samples the logger missed).
    pub missing: u64,
    pub pitch_radius_mm: f64,
    pub grade5_single_pitch_um: f64,
    pub passes: Vec<PassSummary>,
}

/// The loop's cycle period as recorded: SYNC time over cycles from the first sample to the
/// last (a log holds no configuration; 1 ms when it holds a single sample).
fn cycle_period_s(states: &[StateSample]) -> f64 {
    match (states.first(), states.last()) {
        (Some(a), Some(b)) if b.cycle > a.cycle && b.sync_time_ns > a.sync_time_ns => {
            (b.sync_time_ns - a.sync_time_ns) as f64 * 1e-9 / (b.cycle - a.cycle) as f64
        }
        _ => 1e-3,
    }
}

pub fn report(dir: &Path) -> Result<Report, String> {
    let states = crate::read_dir_states(dir)?;
    let gear = states.iter().find(|s| s.pitch_radius_mm > 0.0).ok_or_else(|| {
        format!(
            "{}: no program was loaded while recording: nothing to report per pass",
            dir.display()
        )
    })?;
    let mut b = SummaryBuilder::for_gear(gear.pitch_radius_mm, gear.normal_module_mm);
    let t0 = states.first().map_or(0, |s| s.sync_time_ns);
    let period_s = cycle_period_s(&states);
    let mut missing = 0;
    let mut prev: Option<u64> = None;
    for s in &states {
        if let Some(p) = prev
            && s.cycle > p + 1
        {
            missing += s.cycle - p - 1;
        }
        prev = Some(s.cycle);
        b.add(&trace_row(s, t0), period_s);
    }
    let (passes, tol) = b.passes();
    Ok(Report {
        samples: states.len(),
        first_cycle: states.first().map_or(0, |s| s.cycle),
        last_cycle: states.last().map_or(0, |s| s.cycle),
        missing,
        pitch_radius_mm: gear.pitch_radius_mm,
        grade5_single_pitch_um: tol,
        passes,
    })
}

pub fn report_text(dir: &Path, r: &Report) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "{}: {} samples, cycles {} .. {}, {} missing; pitch radius {:.3} mm, ISO 1328-1 grade 5 single pitch tolerance {:.2} um (bound: a quarter, {:.2} um)",
        dir.display(),
        r.samples,
        r.first_cycle,
        r.last_cycle,
        r.missing,
        r.pitch_radius_mm,
        r.grade5_single_pitch_um,
        r.grade5_single_pitch_um / 4.0
    );
    let _ = writeln!(
        o,
        "pass  cut s  samples  sync error arcsec: rms    max   |  um at pitch circle: rms    max   of grade 5"
    );
    for p in &r.passes {
        let _ = writeln!(
            o,
            "{:>4} {:>6.1} {:>8} {:>24.3} {:>6.3} | {:>24.3} {:>6.3} {:>7.0} %",
            p.pass,
            p.cut_time_s,
            p.samples,
            p.sync_err_rms_arcsec,
            p.sync_err_max_arcsec,
            p.sync_err_rms_um,
            p.sync_err_max_um,
            100.0 * p.sync_err_max_um / r.grade5_single_pitch_um
        );
    }
    o
}
