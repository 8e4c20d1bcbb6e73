//! `hob-lab check`: the simulated machine's gear checker on a cut recorded over the bus
//! (issue 34). The recording's samples of its last cut, joined with `hob-sim`'s truth beside
//! it (`truth.csv`) by their SYNC times as `hob log report` joins them, give the cut's
//! trace rows with the blank's true error; [`hob_plant::checker::GearChecker`] measures the
//! finished gear from them at one or more heights and writes one checker's file per height
//! (docs/gear-measurement.md), the files `hob compensate` reads.
//!
//! The join: per pass, the law's phase (which only the controller knows) is the mean of the
//! truth's drive error less the controller's own estimate over the pass's synchronised cut,
//! taken modulo a tooth pitch; the blank's true error is the truth's less that phase. The
//! gaps are counted on the controller's own table scale (the log's table angle, the
//! operator's mark), as `hob compensate` counts them in its record of the same cut.

use hob_cli::compensate::{Gear, load_gear};
use hob_ipc::StateSample;
use hob_ipc::codec::State;
use hob_logger::export::{TruthNotOfThisCut, each_with_truth, truth_phases, whole_pitches_arcsec};
use hob_logger::trace::TraceRow;
use hob_logger::truth::{self, TruthRow};
use hob_plant::checker::{GearChecker, GearUnderTest};
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::Mode;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How far the truth less the controller's estimate may range over a pass before the truth
/// is taken to be of another cut: the report's own limit.
pub use hob_logger::export::TRUTH_AGREES_WITHIN_ARCSEC;

/// What `hob-lab check` was given.
#[derive(Debug, Clone)]
pub struct Args<'a> {
    pub log: &'a Path,
    pub program: &'a Path,
    pub out: &'a Path,
    pub heights: usize,
    pub seed: u64,
}

/// Why nothing was written: refused (exit 2) or failed (exit 1).
#[derive(Debug, Clone, PartialEq)]
pub enum CheckError {
    Refused(String),
    Failed(String),
}

fn refused(text: impl Into<String>) -> CheckError {
    CheckError::Refused(text.into())
}

/// The checker's files of the last cut in `a.log`, written into `a.out`; the text printed.
pub fn run(machine: &MachineConfig, a: &Args<'_>) -> Result<String, CheckError> {
    if a.heights == 0 {
        return Err(refused("--heights: at least 1"));
    }
    let gear = load_gear(a.program, machine).map_err(|e| refused(e.to_string()))?;
    let truth_path = a.log.join(truth::FILE);
    if !truth_path.is_file() {
        return Err(refused(format!(
            "{}: no {} beside the recording: the checker measures the simulated machine's truth \
             (hob-sim --truth LOG/{})",
            a.log.display(),
            truth::FILE,
            truth::FILE
        )));
    }
    let states = hob_logger::export::read_cycles(a.log, 0, u64::MAX)
        .map_err(|e| refused(format!("--log {}: {e}", a.log.display())))?;
    let (truth_gear, truth_rows) = truth::read(&truth_path).map_err(|e| refused(e.to_string()))?;
    let rows = truth_rows_of_last_cut(&states, &truth_rows, &gear, truth_gear, a.log)?;
    let mut checker = GearChecker::new(GearUnderTest::of(gear.name.clone(), &gear.plan, &gear.cycle));
    for r in &rows {
        checker.add(r);
    }
    let measured = checker.measure_heights(a.seed, &hob_store::utc::now(), a.heights);
    let last = rows.iter().map(|r| r.pass).max().unwrap_or(0);
    if measured.is_empty() {
        return Err(refused(format!(
            "{}: no complete face section of the last pass ({last}) with the blank's truth: every \
             gap must pass the hob",
            a.log.display()
        )));
    }
    if measured.len() < a.heights {
        return Err(refused(format!(
            "{}: the last pass ({last}) has {} complete face section(s) with the blank's truth; \
             --heights {} asks for more",
            a.log.display(),
            measured.len(),
            a.heights
        )));
    }
    std::fs::create_dir_all(a.out).map_err(|e| CheckError::Failed(format!("{}: {e}", a.out.display())))?;
    let mut text = String::new();
    let _ = writeln!(
        text,
        "{}: the last cut of {} ({} teeth, pass {last}), measured by the simulated checker \
         from hob-sim's truth ({} rows joined), seed {}:",
        a.log.display(),
        gear.name,
        gear.plan.teeth,
        rows.iter().filter(|r| r.blank_err_arcsec.is_some()).count(),
        a.seed
    );
    for (i, m) in measured.iter().enumerate() {
        let file = measurement_file(a.out, i + 1);
        std::fs::write(&file, m.to_file())
            .map_err(|e| CheckError::Failed(format!("{}: {e}", file.display())))?;
        let (fpt, fp) = m.figures_um();
        let _ = writeln!(
            text,
            "{}: height {:.3} mm above the face bottom, f_pt {fpt:.2} um, F_p {fp:.2} um",
            file.display(),
            m.header.face_position_mm
        );
    }
    Ok(text)
}

/// The checker's file of the `n`th height (from 1, the lowest) in `out`.
pub fn measurement_file(out: &Path, n: usize) -> PathBuf {
    out.join(format!("measurement-{n}.csv"))
}

/// The trace rows of the recording's last cut (its newest run of `hob-rt`, from the last
/// idle before its last pass), each with the blank's true error where the truth has the
/// sample and the gearbox is synchronised. Refused: a recording of another gear than the
/// program's, a truth of another gear or of another cut, a cut that did not reach the
/// program's last pass.
pub fn truth_rows_of_last_cut(
    states: &[StateSample],
    truth_rows: &[TruthRow],
    gear: &Gear,
    truth_gear: truth::Gear,
    log: &Path,
) -> Result<Vec<TraceRow>, CheckError> {
    let r_mm = gear.pitch_radius_mm();
    let m_n = gear.plan.normal_module_mm;
    let Some(recorded) = states.iter().find(|s| s.pitch_radius_mm > 0.0) else {
        return Err(refused(format!(
            "{}: the recording holds no loaded program",
            log.display()
        )));
    };
    if (recorded.pitch_radius_mm - r_mm).abs() > 1e-6 || (recorded.normal_module_mm - m_n).abs() > 1e-9 {
        return Err(refused(format!(
            "{}: the recording is of another gear (pitch radius {:.3} mm, normal module {} mm) than \
             the program's {} ({r_mm:.3} mm, {m_n} mm)",
            log.display(),
            recorded.pitch_radius_mm,
            recorded.normal_module_mm,
            gear.name
        )));
    }
    if !truth_gear.is_of(r_mm, m_n) || truth_gear.teeth != gear.plan.teeth {
        return Err(refused(format!(
            "{}: {} is of another gear ({} teeth, pitch radius {:.3} mm, normal module {} mm) than \
             the program's {} ({} teeth, {r_mm:.3} mm, {m_n} mm)",
            log.display(),
            truth::FILE,
            truth_gear.teeth,
            truth_gear.pitch_radius_mm,
            truth_gear.normal_module_mm,
            gear.name,
            gear.plan.teeth
        )));
    }
    let Some(end) = states.iter().rposition(|s| s.pass > 0) else {
        return Err(refused(format!("{}: the recording holds no cut", log.display())));
    };
    let start = states[..end]
        .iter()
        .rposition(|s| s.state == State::Idle.code())
        .map_or(0, |i| i + 1);
    let cut = &states[start..=end];
    let passes = gear.plan.passes.len() as u32;
    let last = cut.iter().map(|s| s.pass).max().unwrap_or(0);
    if gear.plan.mode == Mode::Automatic && last != passes {
        return Err(refused(format!(
            "{}: the recording's last cut ends in pass {last}, the program has {passes}: no finished gear",
            log.display()
        )));
    }
    join(cut, truth_rows, gear.plan.teeth).map_err(|(pass, lo, hi)| {
        refused(format!(
            "{}: {} is not of this cut: in pass {pass} the truth less the controller's estimate \
             ranges {lo:.0} .. {hi:.0} arcsec (within {TRUTH_AGREES_WITHIN_ARCSEC} for one cut)",
            log.display(),
            truth::FILE
        ))
    })
}

/// The samples joined with the truth as the report joins them (`hob_logger::export`'s
/// [`truth_phases`] and [`each_with_truth`]): the trace rows with the blank's true error less
/// each pass's law phase where both are known, keeping the log's own table angle (as `hob
/// compensate` counts its record of the same cut). Err((pass, lo, hi)) where the truth less
/// the estimate wanders over a pass (a truth of another cut).
fn join(states: &[StateSample], rows: &[TruthRow], teeth: u32) -> Result<Vec<TraceRow>, TruthNotOfThisCut> {
    let (phase, _) = truth_phases(states, rows, teeth)?;
    let t0 = states.first().map_or(0, |s| s.sync_time_ns);
    let mut out = Vec::with_capacity(states.len());
    each_with_truth(states, rows, &mut |s, t| {
        let mut row = hob_logger::export::trace_row(s, t0);
        let p = (s.pass as usize)
            .checked_sub(1)
            .and_then(|i| phase.get(i).copied().flatten());
        row.blank_err_arcsec = match (t, p) {
            (Some(t), Some(p)) if row.sync_err_arcsec.is_some() => {
                Some(t.blank_err_arcsec - p - whole_pitches_arcsec(t.drive_err_arcsec, p, teeth))
            }
            _ => None,
        };
        out.push(row);
    });
    Ok(out)
}
