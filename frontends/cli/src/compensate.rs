//! `hob compensate`: measure the first gear, correct the second (issue 34). The checker's
//! files of the first gear, matched to the cut's own record in its log, split into the
//! table's and the hob's repeatable errors (`hob_gear_check::decompose`), and the
//! compensation that takes them off stored for the table's worm set
//! (`hob_store::pitch_compensation`), validated as the loop will build it
//! (`hob_control::pitch_comp`). Nothing is written without `--yes`.
//!
//! Layers: [`run`] reads the files ([`load_gear`], [`read_measurement`], [`read_cut`]) and
//! hands the rest to [`compute`] and [`stored`], which take rows and measurements, so that
//! the same functions serve a log and an in-process cut.

use hob_control::pitch_comp::PitchCompensation;
use hob_control::program::CycleProgram;
use hob_gear_check::{Decomposition, GapRecord, Height, Identified, PitchMeasurement, decompose};
use hob_ipc::codec::State;
use hob_logger::gaps::{self, GapRecorder, GapSection};
use hob_logger::trace::TraceRow;
use hob_setup::config::Problems;
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::{Mode, Program};
use hob_setup::planner::{self, Plan};
use hob_store::pitch_compensation::{self as store, HobIdentified, StoredCompensation};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The largest scatter of the cut rows' tooth phase, arcsec of the table: beyond, the log
/// holds more than one gear (or a cut with a compensation on).
pub const MAX_PHASE_SCATTER_ARCSEC: f64 = 10.0;

/// What `hob compensate` was given.
#[derive(Debug, Clone)]
pub struct Options {
    pub machine: PathBuf,
    pub program: PathBuf,
    /// The log directory of the first cut.
    pub log: PathBuf,
    /// The checker's files, one per height.
    pub measurements: Vec<PathBuf>,
    /// The cut's cycles `FIRST..=LAST` in the log (`--cycles FIRST..LAST`, [`parse_cycles`]):
    /// one cut of a log that holds many; `None`: the newest run of hob-rt whole.
    pub cycles: Option<(u64, u64)>,
    pub svg: Option<PathBuf>,
    pub yes: bool,
}

/// Why nothing was stored.
#[derive(Debug, Clone, PartialEq)]
pub enum CompensateError {
    /// The files do not allow a compensation (exit 2), in words that name the file, line,
    /// key or field.
    Refused(String),
    /// Anything else (a write that failed; exit 1).
    Failed(String),
}

impl std::fmt::Display for CompensateError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CompensateError::Refused(t) | CompensateError::Failed(t) => f.write_str(t),
        }
    }
}

impl std::error::Error for CompensateError {}

fn refused(text: impl Into<String>) -> CompensateError {
    CompensateError::Refused(text.into())
}

/// The program as the loop cuts it: its name for the checker, its gearbox law and plan.
#[derive(Debug, Clone)]
pub struct Gear {
    /// `[workpiece] name`, or the program file's stem.
    pub name: String,
    pub job: Program,
    pub cycle: CycleProgram,
    pub plan: Plan,
}

impl Gear {
    /// From a program read already (`file` names it).
    pub fn new(
        file: &Path,
        job: Program,
        src: &str,
        machine: &MachineConfig,
    ) -> Result<Self, CompensateError> {
        let mut p = Problems::new();
        let built = CycleProgram::build(&job, machine, &mut p);
        let plan = built.and_then(|_| planner::plan(&job, machine, &mut p));
        let (Some(cycle), Some(plan)) = (built, plan) else {
            let e = p.into_result(file, src).err();
            return Err(refused(e.map_or_else(
                || format!("{}: the program does not plan", file.display()),
                |e| e.to_string(),
            )));
        };
        let name = job.workpiece.name.clone().unwrap_or_else(|| {
            file.file_stem()
                .map_or_else(String::new, |s| s.to_string_lossy().into_owned())
        });
        Ok(Self {
            name,
            job,
            cycle,
            plan,
        })
    }

    pub fn pitch_radius_mm(&self) -> f64 {
        self.plan.pitch_diameter_mm / 2.0
    }

    /// Y travel per table turn of the last pass, mm: a tooth gap meets the hob this far
    /// apart along the face.
    pub fn last_feed_mm(&self) -> f64 {
        let pass = match self.plan.mode {
            Mode::Single => self.cycle.single(),
            Mode::Automatic => self.cycle.passes().last().copied(),
        };
        pass.map_or(0.0, |p| self.cycle.feed_per_table_rev_mm(&p))
    }
}

/// Reads and plans the program file on `machine`.
pub fn load_gear(program: &Path, machine: &MachineConfig) -> Result<Gear, CompensateError> {
    let (job, src) = hob_store::files::read_program(program).map_err(|e| refused(e.to_string()))?;
    Gear::new(program, job, &src, machine)
}

/// Reads and parses a checker's file; a refusal names the file, the line and the field.
pub fn read_measurement(file: &Path) -> Result<PitchMeasurement, CompensateError> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| refused(format!("{}: cannot read: {e}", file.display())))?;
    hob_gear_check::parse(&text).map_err(|e| refused(format!("{}: {e}", file.display())))
}

/// `--cycles FIRST..LAST`: the cut's first and last cycle (the loop's cycle numbers, as the
/// HMI's cut report and `hob log export` give them), both counted; refused unless two whole
/// numbers with FIRST <= LAST.
pub fn parse_cycles(text: &str) -> Result<(u64, u64), CompensateError> {
    let bad = |why: &str| {
        refused(format!(
            "--cycles {text:?}: {why}; give the cut's first and last cycle as FIRST..LAST (e.g. 1200..98000)"
        ))
    };
    let Some((a, b)) = text.split_once("..") else {
        return Err(bad("no \"..\" between the first and the last cycle"));
    };
    let number = |s: &str, which: &str| {
        s.trim()
            .parse::<u64>()
            .map_err(|_| bad(&format!("the {which} cycle {:?} is not a whole number", s.trim())))
    };
    let (first, last) = (number(a, "first")?, number(b, "last")?);
    if first > last {
        return Err(bad(&format!("the first cycle {first} is after the last {last}")));
    }
    Ok((first, last))
}

/// The trace rows of a log directory: every sample of the newest run of `hob-rt` in it.
pub fn read_log(dir: &Path) -> Result<Vec<TraceRow>, CompensateError> {
    read_cut(dir, None)
}

/// The trace rows of one cut of a log directory: the samples of `cycles` (`FIRST..=LAST`) of
/// the newest run of `hob-rt` holding any, or every sample of its newest run (`None`); a
/// range without a sample is refused.
pub fn read_cut(dir: &Path, cycles: Option<(u64, u64)>) -> Result<Vec<TraceRow>, CompensateError> {
    let (first, last) = cycles.unwrap_or((0, u64::MAX));
    let samples = hob_logger::export::read_cycles(dir, first, last)
        .map_err(|e| refused(format!("--log {}: {e}", dir.display())))?;
    if samples.is_empty() && cycles.is_some() {
        let e = hob_logger::Error::NoSampleOfCycles {
            dir: dir.to_path_buf(),
            first,
            last,
        };
        return Err(refused(format!("--cycles {first}..{last}: {e}")));
    }
    let t0 = samples.first().map_or(0, |s| s.sync_time_ns);
    Ok(samples
        .iter()
        .map(|s| hob_logger::export::trace_row(s, t0))
        .collect())
}

/// A measurement refused unless it is of `gear`: its name and its teeth.
pub fn check_gear(file: &Path, m: &PitchMeasurement, gear: &Gear) -> Result<(), CompensateError> {
    if m.header.gear != gear.name {
        return Err(refused(format!(
            "{}: gear: the measurement is of {:?}, the program cuts {:?}",
            file.display(),
            m.header.gear,
            gear.name
        )));
    }
    if m.header.teeth != gear.plan.teeth {
        return Err(refused(format!(
            "{}: teeth: the measurement has {} teeth, the program's gear {}",
            file.display(),
            m.header.teeth,
            gear.plan.teeth
        )));
    }
    Ok(())
}

/// The first cut's tooth phase, deg modulo the pitch, and the rows' scatter about it,
/// arcsec. The gearbox's phase (rt-core/control/src/egb.rs) is `table - coupled(spindle, Y)`
/// with `coupled = ratio_signed spindle + differential_signed_deg_per_mm Y` (the
/// CycleProgram's), and its synchronism error is `table - coupled - phase target`; so each
/// synchronised cut row gives the target as `table_deg - coupled(spindle_deg, y_mm) -
/// sync_err_arcsec / 3600` (the log's measured table, spindle and Y, and the controller's
/// own error). The target is the recorded phase plus whole pitches: a circular mean over
/// the rows modulo the pitch. A cut made with a compensation on has its offset in the
/// error as well, and scatters.
pub fn tooth_phase(rows: &[TraceRow], cycle: &CycleProgram) -> Result<(f64, f64, usize), CompensateError> {
    let pitch = 360.0 / f64::from(cycle.teeth.max(1));
    let phases: Vec<f64> = rows
        .iter()
        .filter(|r| r.state == State::Cut)
        .filter_map(|r| {
            let e = r.sync_err_arcsec?;
            let coupled = cycle.ratio_signed * r.spindle_deg + cycle.differential_signed_deg_per_mm * r.y_mm;
            Some((r.table_deg - coupled - e / 3600.0).rem_euclid(pitch))
        })
        .collect();
    if phases.is_empty() {
        return Err(refused("the log has no synchronised cut rows: no tooth phase"));
    }
    let turn = std::f64::consts::TAU / pitch;
    let (s, c) = phases.iter().fold((0.0, 0.0), |(s, c), p| {
        (s + (p * turn).sin(), c + (p * turn).cos())
    });
    let mean = (s.atan2(c) / turn).rem_euclid(pitch);
    let off = |p: f64| {
        let d = (p - mean).rem_euclid(pitch);
        d.min(pitch - d)
    };
    let scatter = phases.iter().fold(0.0_f64, |m, &p| m.max(off(p))) * 3600.0;
    if scatter > MAX_PHASE_SCATTER_ARCSEC {
        return Err(refused(format!(
            "the log's cut rows scatter by {scatter:.1} arcsec in tooth phase (at most \
             {MAX_PHASE_SCATTER_ARCSEC}): the log is not one gear's first cut"
        )));
    }
    Ok((mean, scatter, phases.len()))
}

/// What the measurements and the log say.
#[derive(Debug, Clone)]
pub struct Computed {
    pub decomposition: Decomposition,
    /// Per measurement: the Y measured at and the record's section's Y, mm.
    pub heights_mm: Vec<(f64, f64)>,
    pub tooth_phase_deg: f64,
    pub phase_scatter_arcsec: f64,
    pub phase_rows: usize,
}

/// The record's section nearest each measurement's height; refused when the log has no
/// complete section of the last pass, or the nearest is more than half a feed away.
pub fn sections_for(
    rows: &[TraceRow],
    gear: &Gear,
    measurements: &[PitchMeasurement],
) -> Result<Vec<(GapSection, f64)>, CompensateError> {
    let passes = gear.plan.passes.len() as u32;
    let last = rows.iter().map(|r| r.pass).max().unwrap_or(0);
    if gear.plan.mode == Mode::Automatic && last != passes {
        return Err(refused(format!(
            "the log's last pass is {last}, the program's {passes}: the log holds no finished cut"
        )));
    }
    let mut recorder = GapRecorder::new(gear.plan.teeth, gear.pitch_radius_mm());
    for r in rows {
        recorder.add(r);
    }
    let record = recorder.finish();
    if record.is_empty() {
        return Err(refused(format!(
            "the log has no complete face section of the last pass ({last}): every gap must pass the hob"
        )));
    }
    let half_feed = gear.last_feed_mm() / 2.0;
    measurements
        .iter()
        .map(|m| {
            let y = gear.cycle.face_bottom_mm + m.header.face_position_mm;
            let s = gaps::nearest(&record, y)
                .cloned()
                .unwrap_or_else(|| record[0].clone());
            if (s.y_mm - y).abs() > half_feed {
                return Err(refused(format!(
                    "face_position_mm {}: the log's nearest section of the last pass is at Y {:.3} mm, \
                     {:.3} mm from the measured Y {y:.3} mm (at most half a feed, {half_feed:.3} mm)",
                    m.header.face_position_mm,
                    s.y_mm,
                    (s.y_mm - y).abs()
                )));
            }
            Ok((s, y))
        })
        .collect()
}

/// The decomposition of `measurements` against the cut's `rows`, and its tooth phase.
pub fn compute(
    rows: &[TraceRow],
    gear: &Gear,
    measurements: &[PitchMeasurement],
) -> Result<Computed, CompensateError> {
    let sections = sections_for(rows, gear, measurements)?;
    let (tooth_phase_deg, phase_scatter_arcsec, phase_rows) = tooth_phase(rows, &gear.cycle)?;
    let records: Vec<Vec<GapRecord>> = sections.iter().map(|(s, _)| s.records()).collect();
    let heights: Vec<Height> = measurements
        .iter()
        .zip(&records)
        .map(|(m, g)| Height {
            measurement: m,
            gaps: g,
        })
        .collect();
    let decomposition = decompose(&heights, gear.plan.starts).map_err(|e| refused(e.to_string()))?;
    Ok(Computed {
        decomposition,
        heights_mm: sections.iter().map(|(s, y)| (*y, s.y_mm)).collect(),
        tooth_phase_deg,
        phase_scatter_arcsec,
        phase_rows,
    })
}

/// What is stored for `worm_set` (`measurements`: the checker's files, by name).
pub fn stored(
    c: &Computed,
    gear: &Gear,
    worm_set: &str,
    measured: &[PitchMeasurement],
    measurements: &[PathBuf],
    log: &Path,
) -> StoredCompensation {
    let d = &c.decomposition;
    let arcsec = |um: f64| (um * 1e-3 / gear.pitch_radius_mm()).to_degrees() * 3600.0;
    let (removable_single_pitch_um, removable_cumulative_pitch_um) = d.removable_figures_um();
    let (residual_single_pitch_um, residual_cumulative_pitch_um) = d.residual_figures_um();
    StoredCompensation {
        format_version: store::FORMAT_VERSION,
        worm_set: worm_set.to_string(),
        gear: gear.name.clone(),
        teeth: gear.plan.teeth,
        measured_at: measured_at(measured),
        computed_at_utc: hob_store::utc::now(),
        measurements: measurements
            .iter()
            .map(|p| {
                p.file_name()
                    .unwrap_or(p.as_os_str())
                    .to_string_lossy()
                    .into_owned()
            })
            .collect(),
        log_dir: log.display().to_string(),
        first_table_deg: d.gap_table_deg.first().copied().unwrap_or(0.0),
        table_offsets_arcsec: d.table_error_um.iter().map(|&e| -arcsec(e)).collect(),
        hob_cos_arcsec: -arcsec(d.hob.a_um),
        hob_sin_arcsec: -arcsec(d.hob.b_um),
        hob_identified: match d.hob.identified {
            Identified::None => HobIdentified::None,
            Identified::Direction { .. } => HobIdentified::Direction,
            Identified::Full => HobIdentified::Full,
        },
        tooth_phase_deg: c.tooth_phase_deg,
        removable_single_pitch_um,
        removable_cumulative_pitch_um,
        residual_single_pitch_um,
        residual_cumulative_pitch_um,
    }
}

/// When the checker measured, each time once, in the files' order.
fn measured_at(measured: &[PitchMeasurement]) -> String {
    let mut at: Vec<&str> = Vec::new();
    for m in measured {
        if !at.contains(&m.header.measured_at.as_str()) {
            at.push(&m.header.measured_at);
        }
    }
    at.join(", ")
}

/// The compensation the loop builds from a stored one: the same constructor, the same
/// checks (3 to 512 points, finite, at most 0.02 deg).
pub fn to_control(s: &StoredCompensation) -> Result<PitchCompensation, CompensateError> {
    PitchCompensation::from_arcsec(
        s.first_table_deg,
        &s.table_offsets_arcsec,
        s.hob_cos_arcsec,
        s.hob_sin_arcsec,
        s.tooth_phase_deg,
    )
    .map_err(|e| {
        refused(format!(
            "the compensation would be refused by the loop: {}",
            e.text()
        ))
    })
}

/// What `hob compensate` did.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// What it found and what it would write (or wrote), as printed.
    pub text: String,
    pub stored: StoredCompensation,
    pub compensation: PitchCompensation,
    /// The worm set's file.
    pub file: PathBuf,
    /// Written (`--yes`), and the previous file kept, if there was one.
    pub written: bool,
    pub kept: Option<PathBuf>,
}

/// The machine's worm set and its state file: a machine file without `table.worm_set`
/// is refused.
pub fn worm_set_of(machine: &MachineConfig, file: &Path) -> Result<(String, PathBuf), CompensateError> {
    let Some(w) = machine.table.worm_set.clone() else {
        return Err(refused(format!(
            "{}: table.worm_set is not set: a compensation is kept per worm set of the table; \
             name the set (e.g. worm_set = \"B-2019-07\" under [table])",
            file.display()
        )));
    };
    Ok((w, PathBuf::from(&machine.state.file)))
}

/// `hob compensate`: reads, computes, shows, and writes on `yes`.
pub fn run(o: &Options) -> Result<Outcome, CompensateError> {
    let machine = hob_store::files::load_machine(&o.machine).map_err(|e| refused(e.to_string()))?;
    let (worm_set, state_file) = worm_set_of(&machine, &o.machine)?;
    let gear = load_gear(&o.program, &machine)?;
    if o.measurements.is_empty() {
        return Err(refused("--measurement: give the checker's file (one per height)"));
    }
    let mut measured = Vec::new();
    for file in &o.measurements {
        let m = read_measurement(file)?;
        check_gear(file, &m, &gear)?;
        measured.push(m);
    }
    let current = store::load_for(&state_file, &worm_set).map_err(|e| refused(e.to_string()))?;
    let rows = read_cut(&o.log, o.cycles)?;
    let c = compute(&rows, &gear, &measured)?;
    let new = stored(&c, &gear, &worm_set, &measured, &o.measurements, &o.log);
    let compensation = to_control(&new)?;
    let file = new.path(&state_file);
    let mut text = findings(&c, &gear, &new, &o.measurements);
    if let Some((first, last)) = o.cycles {
        let _ = writeln!(text, "  the cut: cycles {first} .. {last} of {}", o.log.display());
    }
    if let Some(svg) = &o.svg {
        std::fs::write(svg, plot(&c.decomposition, &gear.name))
            .map_err(|e| CompensateError::Failed(format!("{}: {e}", svg.display())))?;
        let _ = writeln!(text, "the plot: {}", svg.display());
    }
    match &current {
        None => {
            let _ = writeln!(text, "\n{} (new):\n{}", file.display(), new.to_toml());
        }
        Some(old) => {
            let diff = hob_store::machine_edit::diff(&old.to_toml(), &new.to_toml());
            let _ = writeln!(
                text,
                "\n{} (changes against the current one):\n{diff}",
                file.display()
            );
        }
    }
    let (written, kept) = if o.yes {
        let kept = new
            .save(&state_file)
            .map_err(|e| CompensateError::Failed(e.to_string()))?;
        let _ = match &kept {
            Some(k) => writeln!(
                text,
                "written: {} (the old one kept as {})",
                file.display(),
                k.display()
            ),
            None => writeln!(text, "written: {}", file.display()),
        };
        let _ = writeln!(text, "restart hob-rt for the loop to load it");
        (true, kept)
    } else {
        let _ = writeln!(text, "not written (run again with --yes to write it)");
        (false, None)
    };
    Ok(Outcome {
        text,
        stored: new,
        compensation,
        file,
        written,
        kept,
    })
}

/// What was found, in words.
fn findings(c: &Computed, gear: &Gear, s: &StoredCompensation, files: &[PathBuf]) -> String {
    let d = &c.decomposition;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "hob compensate: {}, {} teeth, {}-start hob; worm set {}",
        gear.name, gear.plan.teeth, gear.plan.starts, s.worm_set
    );
    for (f, (y, ys)) in files.iter().zip(&c.heights_mm) {
        let _ = writeln!(
            t,
            "  {}: measured at Y {y:.3} mm, the cut's section at Y {ys:.3} mm",
            f.display()
        );
    }
    let _ = writeln!(
        t,
        "  the first cut's tooth phase: {:.6} deg ({} cut rows, scatter {:.3} arcsec)",
        c.tooth_phase_deg, c.phase_rows, c.phase_scatter_arcsec
    );
    let n = d.table_error_um.len().max(1) as f64;
    let rms = (d.table_error_um.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
    let (lo, hi) = d
        .table_error_um
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &e| {
            (l.min(e), h.max(e))
        });
    let _ = writeln!(t, "  the table's error: {rms:.2} um rms, range {:.2} um", hi - lo);
    let identified = match d.hob.identified {
        Identified::None => "not identified (one hob phase per gap: invisible on this gear)".to_string(),
        Identified::Direction { phase_deg } => {
            format!("identified in its direction only, along {phase_deg:.1} deg")
        }
        Identified::Full => "identified fully".to_string(),
    };
    let _ = writeln!(
        t,
        "  the hob's once-per-turn term: {:.2} um at {:.1} deg, {identified}",
        d.hob.a_um.hypot(d.hob.b_um),
        d.hob.b_um.atan2(d.hob.a_um).to_degrees().rem_euclid(360.0)
    );
    let _ = writeln!(t, "  the residual: {:.2} um rms", d.residual_rms_um);
    let _ = writeln!(
        t,
        "  the controller's share removed: {:.2} um rms",
        d.controller_rms_um
    );
    let _ = writeln!(
        t,
        "  the checker's noise seen (the flanks disagree): {:.2} um rms",
        d.flank_disagreement_rms_um
    );
    let _ = writeln!(
        t,
        "  a compensation removes f_pt {:.2} um, F_p {:.2} um; it leaves the residual's f_pt {:.2} um, F_p {:.2} um",
        s.removable_single_pitch_um,
        s.removable_cumulative_pitch_um,
        s.residual_single_pitch_um,
        s.residual_cumulative_pitch_um
    );
    t
}

const W: f64 = 760.0;
const H: f64 = 360.0;
const LEFT: f64 = 70.0;
const PLOT_W: f64 = 640.0;
const TOP: f64 = 50.0;
const PLOT_H: f64 = 250.0;

/// The plot: the table's error per gap and each height's residual, um, over the gaps in
/// table order (the style of `hob commission response`'s Bode plot).
pub fn plot(d: &Decomposition, gear: &str) -> String {
    let n = d.table_error_um.len().max(2);
    let all = d.table_error_um.iter().chain(d.residual_um.iter().flatten());
    let top = all.fold(1.0_f64, |m, v| m.max(v.abs())).ceil();
    let x = |i: usize| LEFT + i as f64 / (n - 1) as f64 * PLOT_W;
    let y = |v: f64| TOP + PLOT_H / 2.0 - v / top * PLOT_H / 2.0;
    let line = |vs: &[f64]| {
        vs.iter()
            .enumerate()
            .map(|(i, v)| format!("{:.1},{:.1}", x(i), y(*v)))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let mut o = String::new();
    let _ = writeln!(
        o,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}" font-family="sans-serif" font-size="13">"#
    );
    let _ = writeln!(o, r#"<rect width="{W}" height="{H}" fill="white"/>"#);
    let _ = writeln!(
        o,
        r##"<text x="{LEFT}" y="30">{}: the table's error per gap (line) and the residual at each height (grey), um</text>"##,
        escape(gear)
    );
    let _ = writeln!(
        o,
        r##"<rect x="{LEFT}" y="{TOP}" width="{PLOT_W}" height="{PLOT_H}" fill="none" stroke="#444"/>"##
    );
    for v in [-top, -top / 2.0, 0.0, top / 2.0, top] {
        let py = y(v);
        let _ = writeln!(
            o,
            r##"<line x1="{LEFT}" x2="{}" y1="{py:.1}" y2="{py:.1}" stroke="#ddd"/><text x="{}" y="{:.1}" text-anchor="end">{v:.1} um</text>"##,
            LEFT + PLOT_W,
            LEFT - 6.0,
            py + 4.0
        );
    }
    for r in &d.residual_um {
        let _ = writeln!(
            o,
            r##"<polyline points="{}" fill="none" stroke="#999" stroke-width="1"/>"##,
            line(r)
        );
    }
    let _ = writeln!(
        o,
        r##"<polyline points="{}" fill="none" stroke="#1f5fbf" stroke-width="2"/>"##,
        line(&d.table_error_um)
    );
    let _ = writeln!(
        o,
        r#"<text x="{LEFT}" y="{}">gap 1 .. {} in table order</text></svg>"#,
        TOP + PLOT_H + 30.0,
        d.table_error_um.len()
    );
    o
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
