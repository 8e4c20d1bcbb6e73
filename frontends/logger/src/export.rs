//! `hob log export|report`: a recorded directory as CSV, and its per-pass statistics.

use crate::error::Error;
use crate::format::FileClock;
use crate::header::{CutHeader, Span};
use crate::trace::{DURATIONS, PassSummary, SummaryBuilder, TRACE_HEADER, TraceRow};
use crate::truth;
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
        blank_err_arcsec: None,
        // NaN: a log written before the overrides were recorded.
        feed_override_percent: Some(s.feed_override_percent).filter(|v| v.is_finite()),
        spindle_override_percent: Some(s.spindle_override_percent).filter(|v| v.is_finite()),
        pitch_compensation: Some(s.pitch_compensation),
    }
}

/// Columns after the simulation's (`t_s` .. `sync_err_arcsec`).
const EXTRA: &str =
    "cycle,spindle_rpm,ccc_arcsec,coupling,alarm,digital_inputs,digital_outputs,wake_latency_us,compute_us";

/// The simulation trace's columns that end a log's CSV too, after [`EXTRA`].
pub(crate) const LAST: [&str; 2] = ["feed_override_percent", "spindle_override_percent"];

/// The CSV text of a log: the simulation trace's columns up to `sync_err_arcsec`, then
/// the recorded extras (the cycle counter among them), then the overrides (the last
/// columns of the simulation trace, empty in a log that did not record them).
pub fn export_csv(dir: &Path) -> Result<String, Error> {
    let states = crate::format::read_dir_states(dir)?;
    let sim_cols: Vec<&str> = TRACE_HEADER.split(',').collect();
    let upto = sim_cols
        .iter()
        .position(|c| *c == "sync_err_arcsec")
        .map_or(sim_cols.len(), |i| i + 1);
    let last = LAST.map(|name| sim_cols.iter().position(|c| *c == name));
    let [Some(feed_at), Some(spindle_at)] = last else {
        return Err(Error::NoTraceColumns {
            columns: LAST,
            header: TRACE_HEADER,
        });
    };
    let mut out = String::with_capacity(states.len() * 176);
    let _ = writeln!(out, "{},{EXTRA},{}", sim_cols[..upto].join(","), LAST.join(","));
    let t0 = states.first().map_or(0, |s| s.sync_time_ns);
    for s in &states {
        let row = trace_row(s, t0).csv();
        let cols: Vec<&str> = row.split(',').collect();
        let _ = writeln!(
            out,
            "{},{},{:.3},{:.3},{},{},0x{:06X},0x{:04X},{:.1},{:.1},{},{}",
            cols[..upto].join(","),
            s.cycle,
            s.spindle_rpm,
            s.ccc_arcsec,
            codec::coupling_name(s.coupling),
            codec::alarm_text(&s.alarm).replace(',', ";"),
            s.digital_inputs,
            s.digital_outputs,
            f64::from(s.wake_latency_ns) / 1e3,
            f64::from(s.compute_ns) / 1e3,
            cols[feed_at],
            cols[spindle_at]
        );
    }
    Ok(out)
}

/// Per-pass synchronisation error of a recorded cut, under its head.
#[derive(Debug, Clone)]
pub struct Report {
    /// The program, part, date, operator and alarms of the cut ([`crate::header`]).
    pub header: CutHeader,
    pub samples: usize,
    pub first_cycle: u64,
    pub last_cycle: u64,
    /// Gaps in the cycle counter inside the recording (samples the logger missed).
    pub missing: u64,
    pub pitch_radius_mm: f64,
    pub grade5_single_pitch_um: f64,
    /// Per pass, from the controller's own estimate of its error (what the loop recorded).
    pub passes: Vec<PassSummary>,
    /// The simulated machine's truth, where it wrote one beside the recording
    /// ([`crate::truth`]).
    pub truth: Option<TruthReport>,
    /// Why a truth file beside the recording was not used (it is of another gear).
    pub truth_refused: Option<String>,
}

/// A recording graded by the virtual machine's truth.
#[derive(Debug, Clone)]
pub struct TruthReport {
    pub gear: truth::Gear,
    /// Samples that found their truth row.
    pub joined: usize,
    /// Per pass, from the truth: the controller's share (the drive's motion through an
    /// ideal worm) as the error, and the predicted gear from the blank's truth
    /// (`PassSummary::predicted`) beside the controller's share of it.
    pub passes: Vec<PassSummary>,
    /// Per pass, the law's phase put back (arcsec): the mean of the truth less the
    /// controller's estimate over the pass's synchronised cut. A constant that moves no
    /// tooth against another.
    pub phase_arcsec: Vec<f64>,
}

/// The ISO 1328-1 grade the predicted gear of a recording is judged against.
pub const REPORT_GRADE: u8 = 5;

/// The loop's cycle period as recorded: SYNC time over cycles from the first sample to the
/// last (a log holds no configuration; 1 ms when it holds a single sample).
pub(crate) fn cycle_period_s(states: &[StateSample]) -> f64 {
    match (states.first(), states.last()) {
        (Some(a), Some(b)) if b.cycle > a.cycle && b.sync_time_ns > a.sync_time_ns => {
            (b.sync_time_ns - a.sync_time_ns) as f64 * 1e-9 / (b.cycle - a.cycle) as f64
        }
        _ => 1e-3,
    }
}

/// The samples of a report, and where each file's samples begin with its clock.
type Clocked = (Vec<StateSample>, Vec<(usize, Option<FileClock>)>);

/// Notes a sample's file clock where it changes (the first sample of each file).
fn note_clock(clocks: &mut Vec<(usize, Option<FileClock>)>, at: usize, clock: Option<FileClock>) {
    if clocks.last().is_none_or(|(_, c)| *c != clock) {
        clocks.push((at, clock));
    }
}

/// The report of a whole recording (every run of `hob-rt` in it).
pub fn report(dir: &Path) -> Result<Report, Error> {
    let (mut states, mut clocks): Clocked = (Vec::new(), Vec::new());
    crate::format::for_each_state_clocked(dir, |s, clock| {
        note_clock(&mut clocks, states.len(), clock);
        states.push(s);
    })?;
    if states.is_empty() {
        return Err(Error::NoSample {
            dir: dir.to_path_buf(),
        });
    }
    report_of(dir, &states, &clocks, Span::Whole)
}

/// The report of the cycles `first ..= last` of a recording: one cut (a frontend takes the
/// range from the loop's events: the accepted start, the cycle done). `hob-rt` counts its
/// cycles from its start, so a recording over a restart holds the same cycle twice: the
/// report is of the newest run holding any of the range ([`read_cycles`]).
pub fn report_cycles(dir: &Path, first: u64, last: u64) -> Result<Report, Error> {
    let (states, clocks) = read_cycles_clocked(dir, first, last)?;
    if states.is_empty() {
        return Err(Error::NoSampleOfCycles {
            dir: dir.to_path_buf(),
            first,
            last,
        });
    }
    report_of(dir, &states, &clocks, Span::Cycles(first, last))
}

/// The samples of cycles `first ..= last` of the newest run of `hob-rt` that holds any
/// (a run ends where the cycle counter goes back, as the logger's `gaps.log` says
/// `restart`); only those samples are held while reading.
pub fn read_cycles(dir: &Path, first: u64, last: u64) -> Result<Vec<StateSample>, Error> {
    read_cycles_clocked(dir, first, last).map(|(states, _)| states)
}

/// [`read_cycles`], with where each file's samples begin and its clock.
fn read_cycles_clocked(dir: &Path, first: u64, last: u64) -> Result<Clocked, Error> {
    let (mut out, mut clocks): Clocked = (Vec::new(), Vec::new());
    let mut runs = Runs::default();
    let mut out_run = None;
    crate::format::for_each_state_clocked(dir, |s, clock| {
        let run = runs.of(s.cycle);
        if (first..=last).contains(&s.cycle) {
            if out_run != Some(run) {
                out.clear();
                clocks.clear();
                out_run = Some(run);
            }
            note_clock(&mut clocks, out.len(), clock);
            out.push(s);
        }
    })?;
    Ok((out, clocks))
}

/// Counts the runs of `hob-rt` in a recording, in order: a cycle not after the one before
/// starts a new run.
#[derive(Debug, Default)]
struct Runs {
    run: u32,
    last_cycle: Option<u64>,
}

impl Runs {
    fn of(&mut self, cycle: u64) -> u32 {
        if self.last_cycle.is_some_and(|c| cycle <= c) {
            self.run += 1;
        }
        self.last_cycle = Some(cycle);
        self.run
    }
}

/// The per-pass report of recorded samples (not empty, in order; `clocks`: where each
/// file's samples begin, with its clock), under the head of `span`.
fn report_of(
    dir: &Path,
    states: &[StateSample],
    clocks: &[(usize, Option<FileClock>)],
    span: Span,
) -> Result<Report, Error> {
    let gear = states
        .iter()
        .find(|s| s.pitch_radius_mm > 0.0)
        .ok_or_else(|| Error::NoProgramLoaded {
            dir: dir.to_path_buf(),
        })?;
    let mut b = SummaryBuilder::for_gear(gear.pitch_radius_mm, gear.normal_module_mm);
    let t0 = states.first().map_or(0, |s| s.sync_time_ns);
    let period_s = cycle_period_s(states);
    let mut missing = 0;
    let mut prev: Option<u64> = None;
    for s in states {
        if let Some(p) = prev
            && s.cycle > p + 1
        {
            missing += s.cycle - p - 1;
        }
        prev = Some(s.cycle);
        b.add(&trace_row(s, t0), period_s);
    }
    let (passes, tol) = b.passes();
    let truth_path = dir.join(truth::FILE);
    let (mut truth, mut truth_refused) = (None, None);
    if truth_path.exists() {
        let (g, rows) = truth::read(&truth_path)?;
        if g.is_of(gear.pitch_radius_mm, gear.normal_module_mm) {
            match graded_by_truth(
                states,
                g,
                &rows,
                gear.pitch_radius_mm,
                gear.normal_module_mm,
                period_s,
            ) {
                Ok(t) => truth = Some(t),
                Err(why) => truth_refused = Some(why.to_string()),
            }
        } else {
            truth_refused = Some(format!(
                "{} is of another gear (pitch radius {:.3} mm, normal module {} mm; the recording's {:.3} mm, {} mm): its gearbox law is not the cut's, not used",
                truth::FILE,
                g.pitch_radius_mm,
                g.normal_module_mm,
                gear.pitch_radius_mm,
                gear.normal_module_mm
            ));
        }
    }
    let header = CutHeader::of(read_events(dir), span, states, clocks, period_s);
    Ok(Report {
        header,
        samples: states.len(),
        first_cycle: states.first().map_or(0, |s| s.cycle),
        last_cycle: states.last().map_or(0, |s| s.cycle),
        missing,
        pitch_radius_mm: gear.pitch_radius_mm,
        grade5_single_pitch_um: tol,
        passes,
        truth,
        truth_refused,
    })
}

/// Whether a recorded sample is in the cut with the gearbox synchronised (where the
/// controller's estimate of its error is recorded).
pub(crate) fn synchronised_cut(s: &StateSample) -> bool {
    s.pass > 0 && s.state == State::Cut.code() && s.coupling == Coupling::Synchronised.code()
}

/// Each sample with the truth row of its SYNC (none where the truth has none), in order.
pub fn each_with_truth(
    states: &[StateSample],
    rows: &[truth::TruthRow],
    f: &mut dyn FnMut(&StateSample, Option<truth::TruthRow>),
) {
    let mut from = 0;
    for (i, s) in states.iter().enumerate() {
        let next = states.get(i + 1).map(|n| n.sync_time_ns);
        f(s, truth::row_for(rows, &mut from, s.sync_time_ns, next));
    }
}

/// `d` less the whole tooth pitches (arcsec, of a gear of `teeth`) it lies from `from`: the
/// law's phase counts modulo a pitch ("continue" puts the table back on the same gaps, which
/// the truth's law may call a whole number of pitches further on).
pub fn whole_pitches_arcsec(d: f64, from: f64, teeth: u32) -> f64 {
    let pitch_arcsec = 360.0 * 3600.0 / f64::from(teeth.max(1));
    pitch_arcsec * ((d - from) / pitch_arcsec).round()
}

/// A truth of another cut: the pass (1-based) and the range (arcsec) of the truth less the
/// controller's estimate over it.
pub type TruthNotOfThisCut = (usize, f64, f64);

/// Each pass's law phase (arcsec, none for a pass without a synchronised cut sample the
/// truth has) and the samples the truth has.
pub type TruthPhases = (Vec<Option<f64>>, usize);

/// Each pass's law phase of a recording joined with its truth (arcsec; none for a pass
/// without a synchronised cut sample the truth has): the truth's drive error less the
/// controller's estimate, averaged over the pass, and the samples the truth has. `Err((pass,
/// lo, hi))` (1-based) where that difference ranges over more than
/// [`TRUTH_AGREES_WITHIN_ARCSEC`] in a pass: the truth is of another cut.
pub fn truth_phases(
    states: &[StateSample],
    rows: &[truth::TruthRow],
    teeth: u32,
) -> Result<TruthPhases, TruthNotOfThisCut> {
    // Per pass: the sum, count and range of the truth less the estimate, each taken to
    // within half a pitch of the pass's first.
    let mut sums: Vec<(f64, u64, f64, f64, f64)> = Vec::new();
    let mut joined = 0;
    each_with_truth(states, rows, &mut |s, t| {
        joined += usize::from(t.is_some());
        if let Some(t) = t.filter(|_| synchronised_cut(s)) {
            let i = s.pass as usize - 1;
            if sums.len() <= i {
                sums.resize(i + 1, (0.0, 0, f64::INFINITY, f64::NEG_INFINITY, 0.0));
            }
            let e = &mut sums[i];
            let raw = t.drive_err_arcsec - s.sync_error_arcsec;
            if e.1 == 0 {
                e.4 = raw;
            }
            let d = raw - whole_pitches_arcsec(raw, e.4, teeth);
            (e.0, e.1, e.2, e.3) = (e.0 + d, e.1 + 1, e.2.min(d), e.3.max(d));
        }
    });
    // The truth and the estimate differ by the law's phase and the estimate's own error
    // (arcsec): a truth whose difference wanders by degrees is of another program (the
    // simulator's law is its own program's), not of this cut.
    if let Some((pass, e)) = sums
        .iter()
        .enumerate()
        .find(|(_, e)| e.1 > 0 && e.3 - e.2 > TRUTH_AGREES_WITHIN_ARCSEC)
    {
        return Err((pass + 1, e.2, e.3));
    }
    let phases = sums
        .iter()
        .map(|(sum, n, ..)| (*n > 0).then(|| sum / *n as f64))
        .collect();
    Ok((phases, joined))
}

/// The recording's samples joined with the truth rows by their SYNC times: each pass's
/// law phase first ([`truth_phases`]), then the per-pass statistics of the truth with it.
fn graded_by_truth(
    states: &[StateSample],
    g: truth::Gear,
    rows: &[truth::TruthRow],
    pitch_radius_mm: f64,
    normal_module_mm: f64,
    period_s: f64,
) -> Result<TruthReport, Error> {
    let (phases, joined) =
        truth_phases(states, rows, g.teeth).map_err(|(pass, lo, hi)| Error::TruthNotOfThisCut {
            file: truth::FILE,
            pass,
            lo,
            hi,
            within_arcsec: TRUTH_AGREES_WITHIN_ARCSEC,
        })?;
    let phase_arcsec: Vec<f64> = phases.iter().map(|p| p.unwrap_or(0.0)).collect();
    let mut b = SummaryBuilder::for_gear(pitch_radius_mm, normal_module_mm).predicting(
        g.teeth,
        g.starts,
        g.face_width_mm,
        REPORT_GRADE,
    );
    let t0 = states.first().map_or(0, |s| s.sync_time_ns);
    each_with_truth(states, rows, &mut |s, t| {
        let mut row = trace_row(s, t0);
        let phase = (s.pass as usize)
            .checked_sub(1)
            .and_then(|i| phase_arcsec.get(i))
            .copied();
        match (t, phase) {
            (Some(t), Some(phase)) if row.sync_err_arcsec.is_some() => {
                let k = whole_pitches_arcsec(t.drive_err_arcsec, phase, g.teeth);
                row.table_deg = t.table_drive_deg;
                row.y_mm = t.y_mm;
                row.sync_err_arcsec = Some(t.drive_err_arcsec - phase - k);
                row.blank_err_arcsec = Some(t.blank_err_arcsec - phase - k);
            }
            // No truth for this sample: a gap in the truth, never the estimate in its place.
            _ => {
                row.sync_err_arcsec = None;
                row.blank_err_arcsec = None;
            }
        }
        b.add(&row, period_s);
    });
    Ok(TruthReport {
        gear: g,
        joined,
        passes: without_compensated_shares(b.passes().0),
        phase_arcsec,
    })
}

/// The passes graded by the truth, the controller's share left out where the pitch
/// compensation was on: the truth's drive error holds the compensation's deliberate offset
/// there, so the controller's share cannot be told from it (the gear itself, from the
/// blank's error, can).
fn without_compensated_shares(mut passes: Vec<PassSummary>) -> Vec<PassSummary> {
    for p in &mut passes {
        if p.pitch_compensation == Some("on") {
            p.controller_share = None;
        }
    }
    passes
}

/// How far the truth less the controller's estimate may range over a pass before the
/// truth is taken to be of another program: far above what the estimate's own error can
/// be (the coarse window is 200 arcsec), far below a wrong law's drift.
pub const TRUTH_AGREES_WITHIN_ARCSEC: f64 = 1000.0;

/// An event as the logger recorded it (declared with the file formats).
pub use crate::format::LoggedEvent;

/// Every event of a log directory's `events.log`, in order, each once. A restarted logger
/// is handed the loop's recent events again and writes them a second time: such a block
/// (rising numbers up to the last one recorded, each the same as the one recorded under its
/// number) is left out, and an event of it that the first logger missed is put in its place.
/// Anything else numbered again is a restarted `hob-rt` (it numbers its events from 1): a new
/// run. A last line without its line end (a logger killed while writing it) is left out; any
/// other line that is not `seq cycle kind text` is refused with its line number.
pub fn read_events(dir: &Path) -> Result<Vec<LoggedEvent>, Error> {
    let path = dir.join("events.log");
    let text = std::fs::read_to_string(&path).map_err(|error| Error::Io {
        path: path.clone(),
        error,
    })?;
    let whole = text.rsplit_once('\n').map_or("", |(lines, _partial)| lines);
    let lines = whole
        .lines()
        .enumerate()
        .map(|(i, line)| {
            let l = crate::format::parse_event_line(line).ok_or_else(|| Error::NotAnEventLine {
                path: path.clone(),
                line: i + 1,
                text: line.to_string(),
            })?;
            Ok(LoggedEvent {
                run: 0,
                seq: l.seq,
                cycle: l.cycle,
                kind: l.kind,
                text: l.text,
                alarm: l.alarm,
                args: l.args.unwrap_or_default(),
            })
        })
        .collect::<Result<Vec<_>, Error>>()?;
    let mut out: Vec<LoggedEvent> = Vec::with_capacity(lines.len());
    let (mut run, mut run_start) = (0u32, 0usize);
    let mut i = 0;
    while i < lines.len() {
        let seq = lines[i].seq;
        if let Some(last) = out.last().map(|l| l.seq)
            && seq <= last
        {
            let mut end = i + 1;
            while end < lines.len() && lines[end].seq > lines[end - 1].seq && lines[end].seq <= last {
                end += 1;
            }
            let block = &lines[i..end];
            let this_run = &out[run_start..];
            let recorded = |e: &LoggedEvent| this_run.binary_search_by_key(&e.seq, |l| l.seq);
            let same = |e: &LoggedEvent, k: usize| {
                let l = &this_run[k];
                (l.cycle, l.kind, &l.text) == (e.cycle, e.kind, &e.text)
            };
            let repeat = block.iter().all(|e| recorded(e).map_or(true, |k| same(e, k)))
                && block.iter().any(|e| recorded(e).is_ok());
            if repeat {
                // What the first logger missed goes into its place.
                let missed: Vec<LoggedEvent> = block
                    .iter()
                    .filter(|e| recorded(e).is_err())
                    .map(|e| LoggedEvent { run, ..e.clone() })
                    .collect();
                for e in missed {
                    let at = run_start + out[run_start..].partition_point(|l| l.seq < e.seq);
                    out.insert(at, e);
                }
                i = end;
                continue;
            }
            run += 1;
            run_start = out.len();
        }
        out.push(LoggedEvent {
            run,
            ..lines[i].clone()
        });
        i += 1;
    }
    Ok(out)
}

/// The events of cycles `first ..= last` (one cut: its alarms among them), of the newest run
/// of `hob-rt` that holds any, as [`report_cycles`] takes its samples.
pub fn events_in(dir: &Path, first: u64, last: u64) -> Result<Vec<LoggedEvent>, Error> {
    let mut events = read_events(dir)?;
    events.retain(|e| (first..=last).contains(&e.cycle));
    if let Some(newest) = events.last().map(|e| e.run) {
        events.retain(|e| e.run == newest);
    }
    Ok(events)
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
    let graded = match &r.truth {
        Some(t) => {
            let _ = writeln!(
                o,
                "graded by the simulated machine's truth ({}: {} of {} samples joined): the error is the drive's true motion against the gearbox law; the controller's own estimate follows",
                truth::FILE,
                t.joined,
                r.samples
            );
            &t.passes
        }
        None => {
            match &r.truth_refused {
                Some(why) => {
                    let _ = writeln!(
                        o,
                        "no truth used: {why}; the error is the controller's own estimate from its encoders"
                    );
                }
                None => {
                    let _ = writeln!(
                        o,
                        "no truth recorded beside the log: the error is the controller's own estimate from its encoders"
                    );
                }
            }
            &r.passes
        }
    };
    for l in r.header.lines() {
        let _ = writeln!(o, "{l}");
    }
    let _ = writeln!(o, "durations: {DURATIONS}");
    let _ = writeln!(
        o,
        "pass  cut s  pass s  stood s  samples  sync error arcsec: rms    max   |  um at pitch circle: rms    max   of grade 5 | overrides in the cut, pitch compensation"
    );
    for p in graded {
        let _ = writeln!(
            o,
            "{:>4} {:>6.1} {:>7.1} {:>8.1} {:>8} {:>24.3} {:>6.3} | {:>24.3} {:>6.3} {:>7.0} % | feed {}, spindle {}, pitch compensation {}",
            p.pass,
            p.cut_time_s,
            p.pass_time_s,
            p.stood_s,
            p.samples,
            p.sync_err_rms_arcsec,
            p.sync_err_max_arcsec,
            p.sync_err_rms_um,
            p.sync_err_max_um,
            100.0 * p.sync_err_max_um / r.grade5_single_pitch_um,
            percent_range(p.feed_override_min_percent, p.feed_override_max_percent),
            percent_range(p.spindle_override_min_percent, p.spindle_override_max_percent),
            p.pitch_compensation.unwrap_or("-")
        );
    }
    if let Some(t) = &r.truth {
        for p in &r.passes {
            let _ = writeln!(
                o,
                "  the controller's estimate, pass {}: rms {:.3} max {:.3} um",
                p.pass, p.sync_err_rms_um, p.sync_err_max_um
            );
        }
        for p in &t.passes {
            let compensated = p.pitch_compensation == Some("on");
            let _ = writeln!(
                o,
                "{}{}",
                crate::predicted::pass_line(p.pass, p.predicted.as_ref(), p.controller_share.as_ref()),
                if compensated {
                    " (the pitch compensation was on: the drive's true motion holds its offset, so \
                     the controller's share is not told apart)"
                } else {
                    ""
                }
            );
        }
    }
    o
}

/// An override range as the report prints it: `80-100 %`, `100 %` when the override
/// stayed put, `-` when there is none (no row in the cut, or a log that did not record
/// the overrides).
pub fn percent_range(min: Option<f64>, max: Option<f64>) -> String {
    let pct = |v: f64| {
        let s = format!("{v:.1}");
        s.strip_suffix(".0").map_or_else(|| s.clone(), str::to_string)
    };
    match (min, max) {
        (Some(lo), Some(hi)) if pct(lo) == pct(hi) => format!("{} %", pct(lo)),
        (Some(lo), Some(hi)) => format!("{}-{} %", pct(lo), pct(hi)),
        _ => "-".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::writer::LogWriter;

    /// A recorded cut: pass 1 with the feed turned down to 80 % in the cut, a hold at
    /// 0 %, the retract at 120 %; pass 2 at 100 % throughout.
    fn recorded(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("hob-export-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut w = LogWriter::open(&dir, "t").unwrap();
        let rows = [
            (State::ToStart, 0, 1, 50.0, 100.0),
            (State::Cut, 0, 1, 100.0, 100.0),
            (State::Cut, 0, 1, 80.0, 100.0),
            (State::Cut, 1, 1, 0.0, 100.0),
            (State::Retract, 0, 1, 120.0, 100.0),
            (State::Cut, 0, 2, 100.0, 100.0),
        ];
        for (i, (state, hold, pass, feed, spindle)) in rows.into_iter().enumerate() {
            let cycle = i as u64 + 1;
            w.push_state(&StateSample {
                cycle,
                sync_time_ns: cycle * 1_000_000,
                state: state.code(),
                hold,
                pass,
                coupling: Coupling::Synchronised.code(),
                sync_error_arcsec: 0.5 * cycle as f64,
                pitch_radius_mm: 42.5,
                normal_module_mm: 5.0,
                feed_override_percent: feed,
                spindle_override_percent: spindle,
                ..StateSample::default()
            })
            .unwrap();
        }
        w.flush().unwrap();
        dir
    }

    #[test]
    fn the_csv_ends_with_the_overrides() {
        let dir = recorded("csv");
        let csv = export_csv(&dir).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let sim: Vec<&str> = TRACE_HEADER.split(',').collect();
        let upto = sim.iter().position(|c| *c == "sync_err_arcsec").unwrap() + 1;
        assert_eq!(header[..upto], sim[..upto]);
        assert_eq!(header[upto], "cycle");
        assert_eq!(
            header[header.len() - 2..],
            ["feed_override_percent", "spindle_override_percent"]
        );
        let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
        assert_eq!(rows.len(), 6);
        assert!(rows.iter().all(|r| r.len() == header.len()), "{rows:?}");
        let feed: Vec<&str> = rows.iter().map(|r| r[r.len() - 2]).collect();
        assert_eq!(feed, ["50.00", "100.00", "80.00", "0.00", "120.00", "100.00"]);
        assert!(rows.iter().all(|r| r[r.len() - 1] == "100.00"), "{rows:?}");
    }

    #[test]
    fn the_report_gives_the_override_ranges_in_the_cut_after_the_columns_it_had() {
        let dir = recorded("report");
        let r = report(&dir).unwrap();
        let text = report_text(&dir, &r);
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(r.passes[0].feed_override_min_percent, Some(80.0));
        assert_eq!(r.passes[0].feed_override_max_percent, Some(100.0));
        // The pass lines as `Report::parse` of the system tests reads them: a leading
        // space, the pass number first, the max um the second field after the first `|`.
        let lines: Vec<&str> = text
            .lines()
            .skip(1)
            .filter(|l| {
                l.starts_with(' ')
                    && l.split_whitespace()
                        .next()
                        .is_some_and(|p| p.parse::<u32>().is_ok())
            })
            .collect();
        assert_eq!(lines.len(), 2, "{text}");
        for (l, p) in lines.iter().zip(&r.passes) {
            let f: Vec<&str> = l.split_whitespace().collect();
            let bar = f.iter().position(|f| *f == "|").unwrap();
            let max_um: f64 = f[bar + 2].parse().unwrap();
            assert!((max_um - p.sync_err_max_um).abs() < 5e-4, "{l}");
        }
        // The recording's samples carry no compensation: "none", as a log from before says.
        assert!(
            lines[0].ends_with("| feed 80-100 %, spindle 100 %, pitch compensation none"),
            "{text}"
        );
        assert!(
            lines[1].ends_with("| feed 100 %, spindle 100 %, pitch compensation none"),
            "{text}"
        );
    }

    #[test]
    fn a_compensated_pass_graded_by_the_truth_has_no_controller_s_share() {
        let share = crate::predicted::PredictedGear {
            sections: 1,
            single_pitch_um: 1.0,
            cumulative_pitch_um: 1.0,
            helix_um: 1.0,
            grade: 5,
            single_pitch_tolerance_um: 5.0,
            cumulative_pitch_tolerance_um: 15.0,
            helix_tolerance_um: 9.0,
        };
        let pass = |pc: Option<&'static str>| {
            let mut p = PassSummary::default();
            p.pitch_compensation = pc;
            p.controller_share = Some(share.clone());
            p
        };
        let passes = without_compensated_shares(vec![pass(Some("off")), pass(Some("on")), pass(None)]);
        let kept: Vec<bool> = passes.iter().map(|p| p.controller_share.is_some()).collect();
        assert_eq!(kept, [true, false, true]);
    }

    #[test]
    fn a_range_of_cycles_reports_only_that_cut() {
        let dir = recorded("range");
        // Cycles 6 ..= 6: pass 2 only; the whole recording has both passes.
        let r = report_cycles(&dir, 6, 6).unwrap();
        let all = report(&dir).unwrap();
        let none = report_cycles(&dir, 100, 200);
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!((r.samples, r.first_cycle, r.last_cycle), (1, 6, 6));
        assert_eq!(
            r.passes.iter().filter(|p| p.samples > 0).count(),
            1,
            "{:?}",
            r.passes
        );
        assert_eq!(r.passes.last().map(|p| p.pass), Some(2));
        assert_eq!((all.samples, all.passes.len()), (6, 2));
        assert!(
            none.unwrap_err()
                .to_string()
                .contains("no sample of cycles 100 .. 200")
        );
    }

    #[test]
    fn percent_ranges_read_as_the_operator_set_them() {
        assert_eq!(percent_range(Some(80.0), Some(100.0)), "80-100 %");
        assert_eq!(percent_range(Some(100.0), Some(100.0)), "100 %");
        assert_eq!(percent_range(Some(85.5), Some(100.000_000_000_01)), "85.5-100 %");
        assert_eq!(percent_range(None, None), "-");
    }

    /// The gear of the recorded cut ([`recorded`]).
    fn truth_gear() -> truth::Gear {
        truth::Gear {
            teeth: 17,
            face_width_mm: 40.0,
            pitch_radius_mm: 42.5,
            normal_module_mm: 5.0,
            starts: 1,
        }
    }

    /// A truth file of `gear` with a row per cycle of `cycles` (its errors from the cycle).
    fn truth_file(gear: truth::Gear, cycles: &[u64], errors: impl Fn(u64) -> (f64, f64)) -> Vec<u8> {
        let mut text = Vec::new();
        truth::write_head(&mut text, gear).unwrap();
        for &cycle in cycles {
            let (drive_err_arcsec, blank_err_arcsec) = errors(cycle);
            let r = truth::TruthRow {
                sync_ns: cycle * 1_000_000 + 30_000,
                table_drive_deg: cycle as f64,
                y_mm: 0.0,
                drive_err_arcsec,
                blank_err_arcsec,
            };
            text.extend_from_slice(format!("{}\n", r.csv()).as_bytes());
        }
        text
    }

    /// The estimate is 0.5 arcsec x cycle; the truth: a phase of 3600.25 arcsec, the
    /// estimate plus 2 arcsec in pass 1 (cycles 2..=4 in the cut), read 30 us after each
    /// SYNC; cycle 3's row is missing.
    fn agreeing_truth() -> Vec<u8> {
        truth_file(truth_gear(), &[1, 2, 4, 5, 6], |cycle| {
            let est = 0.5 * cycle as f64;
            let extra = if (2..=4).contains(&cycle) {
                2.0 + 0.1 * cycle as f64
            } else {
                0.0
            };
            (3600.25 + est + extra, 3600.25 + est + extra + 1.0)
        })
    }

    /// The report grades the cut by the truth (the phase put back per pass from the
    /// estimate), leaves a sample without its truth row out rather than using the estimate,
    /// and says so.
    fn graded_by_the_truth(dir: &Path) {
        std::fs::write(dir.join(truth::FILE), agreeing_truth()).unwrap();
        let r = report(dir).unwrap();
        let t = r.truth.as_ref().expect("graded by the truth");
        assert_eq!(t.joined, 5);
        // Pass 1's synchronised cut with truth: cycles 2 and 4 (extra 2.2 and 2.4): phase
        // 3600.25 + 2.3. The statistics count the cut without hold, cycle 2 only: its truth
        // less the phase is 1.0 + 2.2 - 2.3 = 0.9 arcsec (the estimate there: 1.0).
        assert!((t.phase_arcsec[0] - 3602.55).abs() < 1e-6, "{:?}", t.phase_arcsec);
        let p1 = &t.passes[0];
        assert_eq!(p1.samples, 1);
        assert!((p1.sync_err_max_arcsec - 0.9).abs() < 1e-6, "{p1:?}");
        // The estimate's own figures are kept beside: 0.5 x cycle, cycles 2 and 3 in the cut
        // without hold (cycle 3 has no truth but its estimate).
        assert!((r.passes[0].sync_err_max_arcsec - 1.5).abs() < 1e-9);
        assert!((p1.blank_err_max_arcsec.unwrap() - 1.9).abs() < 1e-6, "{p1:?}");
        let text = report_text(dir, &r);
        assert!(
            text.lines()
                .nth(1)
                .is_some_and(|l| l.starts_with("graded by the simulated machine's truth (truth.csv: 5 of 6")),
            "{text}"
        );
        assert!(text.contains("the controller's estimate, pass 1: rms"), "{text}");
    }

    /// After "continue" the table is on the same gaps, which the truth's law may count a
    /// whole number of pitches on (the operator's trial: 16 pitches): graded the same.
    fn the_same_gaps_a_whole_number_of_pitches_on_are_graded_the_same(dir: &Path) {
        let pitch_arcsec = 360.0 * 3600.0 / 17.0;
        let plain = {
            std::fs::write(dir.join(truth::FILE), agreeing_truth()).unwrap();
            report(dir).unwrap().truth.unwrap()
        };
        let shifted = truth_file(truth_gear(), &[1, 2, 4, 5, 6], |cycle| {
            let est = 0.5 * cycle as f64;
            let extra = if (2..=4).contains(&cycle) {
                2.0 + 0.1 * cycle as f64
            } else {
                0.0
            };
            let on = if cycle >= 4 { 16.0 * pitch_arcsec } else { 0.0 };
            (3600.25 + est + extra + on, 3600.25 + est + extra + 1.0 + on)
        });
        std::fs::write(dir.join(truth::FILE), &shifted).unwrap();
        let r = report(dir).unwrap();
        let t = r
            .truth
            .as_ref()
            .unwrap_or_else(|| panic!("{:?}", r.truth_refused));
        assert!(
            // Floats of a million arcsec: equal to 1e-4 arcsec.
            (t.phase_arcsec[0] - plain.phase_arcsec[0]).abs() < 1e-4,
            "{:?}",
            t.phase_arcsec
        );
        assert_eq!(t.passes[0].samples, plain.passes[0].samples);
        assert!((t.passes[0].sync_err_max_arcsec - plain.passes[0].sync_err_max_arcsec).abs() < 1e-4);
        assert!(
            (t.passes[0].blank_err_max_arcsec.unwrap() - plain.passes[0].blank_err_max_arcsec.unwrap()).abs()
                < 1e-4
        );
    }

    /// The truth of another gear is not used, and the report says why.
    fn another_gears_truth_is_not_used(dir: &Path) {
        let truth_text = agreeing_truth();
        let mut other = Vec::new();
        truth::write_head(
            &mut other,
            truth::Gear {
                pitch_radius_mm: 49.485,
                normal_module_mm: 3.0,
                ..truth_gear()
            },
        )
        .unwrap();
        // The same rows after the other gear's two head lines.
        let rows_at = truth_text
            .iter()
            .enumerate()
            .filter(|(_, c)| **c == b'\n')
            .nth(1)
            .map(|(i, _)| i + 1)
            .unwrap();
        other.extend_from_slice(&truth_text[rows_at..]);
        std::fs::write(dir.join(truth::FILE), &other).unwrap();
        let r2 = report(dir).unwrap();
        assert!(r2.truth.is_none());
        let t2 = report_text(dir, &r2);
        assert!(
            t2.contains("truth.csv is of another gear (pitch radius 49.485 mm"),
            "{t2}"
        );
    }

    /// A truth whose law is another program's drifts against the estimate: not used.
    fn a_drifting_truth_is_not_used(dir: &Path) {
        let drifting = truth_file(truth_gear(), &[1, 2, 3, 4, 5, 6], |cycle| {
            (5000.0 * cycle as f64, 5000.0 * cycle as f64)
        });
        std::fs::write(dir.join(truth::FILE), &drifting).unwrap();
        let r3 = report(dir).unwrap();
        assert!(r3.truth.is_none());
        let t3 = report_text(dir, &r3);
        assert!(t3.contains("truth.csv is not of this cut: in pass 1"), "{t3}");
    }

    /// Without the file: the estimate, said so; a broken truth file is refused with its
    /// name, not silently ignored.
    fn a_missing_truth_is_said_and_a_broken_one_refused(dir: &Path) {
        std::fs::remove_file(dir.join(truth::FILE)).unwrap();
        let r = report(dir).unwrap();
        assert!(r.truth.is_none());
        assert!(report_text(dir, &r).contains("no truth recorded beside the log"));
        std::fs::write(dir.join(truth::FILE), "garbage\n").unwrap();
        assert!(report(dir).unwrap_err().to_string().contains("truth.csv:1"));
    }

    /// A recorded cut with the simulated machine's truth beside it, of this cut, of another
    /// gear, of another program, none, and a broken one.
    #[test]
    fn a_recording_with_the_truth_beside_it_is_graded_by_the_truth() {
        let dir = recorded("truth");
        graded_by_the_truth(&dir);
        the_same_gaps_a_whole_number_of_pitches_on_are_graded_the_same(&dir);
        another_gears_truth_is_not_used(&dir);
        a_drifting_truth_is_not_used(&dir);
        a_missing_truth_is_said_and_a_broken_one_refused(&dir);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
