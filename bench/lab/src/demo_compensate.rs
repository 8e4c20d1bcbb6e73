//! `hob demo --compensate [PROGRAM]`: issue 34's whole loop on the simulated machine, as an
//! operator does it (the recipe of the bus test
//! `measure_the_first_gear_correct_the_second_over_the_bus`): the first gear cut, measured
//! by the simulated gear checker from hob-sim's truth (`hob-lab check`, [`crate::check`]),
//! the compensation derived and stored by the code of `hob compensate --yes`
//! ([`hob_cli::compensate::run`]) in the demo's own state directory, X and Y jogged near
//! home, `hob-rt` restarted so that it loads it (switched off), `new-blank` and
//! `pitch-compensation on` sent as the CLI sends them, the second gear cut and measured; then
//! both gears side by side, by the checker and by the truth at every face section, and
//! where every file is.
//!
//! The demo's directory: its machine file (the machine state and the compensation kept in
//! the directory, never the machine PC's), `truth.csv` (hob-sim's, the whole session),
//! `pitch-compensation/WORM_SET.toml`, and a log directory per gear (`first-gear`,
//! `second-gear`: the recording, a copy of the truth, the checker's files, each process's
//! log; the first also `hob compensate`'s output and plot).

use crate::check;
use crate::demo::{self, DemoArgs, Prepared, SIBLINGS, say, wait_for};
use hob_cli::compensate::{self, CompensateError, Gear};
use hob_cli::service;
use hob_ipc::Ports;
use hob_ipc::codec::State;
use hob_logger::predicted::PredictedGear;
use hob_setup::config::machine::MachineConfig;
use hob_setup::job::CycleKind;
use hob_virtual_machine::procs::Processes;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The program `--compensate` cuts without one: the short two-start helical gear of the bus
/// test (one pass, 33 s planned; three heights one feed apart tell the hob's runout from
/// the table's error).
pub const PROGRAM: &str = "config/programs/demo-short-helical-z41-m2-2start.toml";

/// The checker's heights around mid-face, one feed apart (a two-start hob wants two or
/// more; the bus test measures three).
pub const HEIGHTS: usize = 3;

/// Each gear's log directory in the demo's.
pub const FIRST: &str = "first-gear";
pub const SECOND: &str = "second-gear";

/// The checker's noise draws: another for the second gear, as a second measurement.
const SEEDS: [u64; 2] = [1, 2];

/// Where X and Y are jogged before `hob-rt` restarts: this far below their home position,
/// so that referencing again takes seconds (from the cut's end it takes a minute).
const PARK_BELOW_HOME_MM: f64 = 2.0;

/// A gear cut and measured.
struct Measured {
    /// Its log directory.
    dir: PathBuf,
    /// The checker's files, lowest height first, with their height above the face bottom
    /// and their f_pt and F_p, um.
    files: Vec<(PathBuf, f64, f64, f64)>,
    /// The gear by the truth at every face section of its last pass (the report's).
    truth: Option<PredictedGear>,
}

impl Measured {
    /// The worst height's f_pt and F_p, um.
    fn checker_um(&self) -> (f64, f64) {
        self.files
            .iter()
            .fold((0.0, 0.0), |(a, b), f| (f64::max(a, f.2), f64::max(b, f.3)))
    }
}

/// The demo's processes: the simulated machine for the whole run, the service (logger,
/// loop, watchdog) once per gear.
struct Session<'a> {
    machine: &'a MachineConfig,
    a: &'a DemoArgs<'a>,
    p: Prepared,
    gear: Gear,
    sim: Processes,
    service: Processes,
    ports: Option<Ports>,
}

/// Refused before anything is written or started (exit 2): a machine file without a worm
/// set (the compensation is kept per worm set), a program that does not plan, or one the
/// checker cannot measure along the face (a radial-axial hob cut only). A one-start hob is
/// accepted: its hob term is invisible and harmless, the table's error is compensated.
pub fn refusal(machine: &MachineConfig, a: &DemoArgs<'_>) -> Result<Gear, (u8, String)> {
    let text = |e: CompensateError| (2, format!("--compensate: {e}"));
    compensate::worm_set_of(machine, a.machine_file).map_err(text)?;
    let gear = compensate::load_gear(a.program, machine).map_err(text)?;
    let cycle = match gear.plan.cycle {
        CycleKind::RadialAxial => return Ok(gear),
        CycleKind::RadialPlunge => "radial-plunge",
        CycleKind::ToothByTooth => "tooth-by-tooth",
    };
    Err((
        2,
        format!(
            "--compensate: {}: a {cycle} cycle; the checker measures a hobbed gear at heights \
             along its face, which only a radial-axial cycle cuts (e.g. {PROGRAM})",
            a.program.display()
        ),
    ))
}

pub fn run(machine: &MachineConfig, a: &DemoArgs<'_>) -> Result<String, (u8, String)> {
    let gear = refusal(machine, a)?;
    if gear.plan.starts == 1 {
        say(
            a.quiet,
            "a one-start hob: every gap meets the hob at the same phase of its turn, so its \
             once-per-turn term is invisible (and harmless); the table's error is compensated",
        );
    }
    let p = demo::prepare(machine, a, "hob demo --compensate", &SIBLINGS, true)?;
    let began = Instant::now();
    let mut s = Session {
        machine,
        a,
        p,
        gear,
        sim: Processes::default(),
        service: Processes::default(),
        ports: None,
    };
    let truth = s.p.dir.join(hob_logger::truth::FILE);
    demo::spawn_sim(&s.p, a, &truth, &mut s.sim)?;
    say(a.quiet, "the first gear: compensation off");
    s.cut_gear(FIRST, false)?;
    s.park_near_home()?;
    demo::stop_in_order(&mut s.service);
    let first = s.measure(FIRST, SEEDS[0])?;
    let comp = s.compensate(&first)?;
    say(
        a.quiet,
        "hob-rt restarted to load the compensation; the second gear: compensation on",
    );
    s.service = Processes::default();
    s.cut_gear(SECOND, true)?;
    std::thread::sleep(Duration::from_millis(600));
    let stats = s.ports.as_ref().and_then(Ports::latest_stats);
    s.ports = None;
    demo::stop_in_order(&mut s.service);
    demo::stop_in_order(&mut s.sim);
    let second = s.measure(SECOND, SEEDS[1])?;
    let mut o = comp.found;
    o.push_str(&side_by_side(&s.gear, &first, &second));
    o.push_str(&files(&first, &second, &comp.file));
    let _ = writeln!(o, "the second gear's recording and loop:");
    o.push_str(&demo::recorded_and_loop(&second.dir, stats.as_ref(), &s.p.iface));
    let _ = writeln!(o, "the whole loop took {:.0} s", began.elapsed().as_secs_f64());
    let _ = writeln!(o, "log: {}", s.p.dir.display());
    Ok(o)
}

/// What `hob compensate` found (as it printed it) and the file it wrote.
struct Compensation {
    found: String,
    file: PathBuf,
}

impl Session<'_> {
    fn dead(&mut self) -> Option<String> {
        self.sim.dead().or_else(|| self.service.dead())
    }

    /// The service started recording into `name`; power-up, referencing, the program
    /// loaded, with `on` a new blank and the compensation switched on; the cut.
    fn cut_gear(&mut self, name: &str, on: bool) -> Result<(), (u8, String)> {
        let fail = |e: String| (1, e);
        let quiet = self.a.quiet;
        let recording = self.p.dir.join(name);
        std::fs::create_dir_all(&recording).map_err(|e| fail(format!("{}: {e}", recording.display())))?;
        demo::spawn_service(&self.p, &recording, &mut self.service)?;
        let ports = Ports::subscribe(&format!("hob-demo-{}-{name}", std::process::id()))
            .map_err(|e| fail(e.to_string()))?;
        let (sim, service) = (&mut self.sim, &mut self.service);
        let mut dead = || sim.dead().or_else(|| service.dead());
        demo::power_up_and_reference(&ports, &mut dead, quiet)?;
        demo::load_from_library(self.machine, self.a.program, &self.p.dir, quiet)?;
        if on {
            switch_on(&ports, &mut dead, &recording, quiet)?;
        }
        let period_s = f64::from(self.machine.control.cycle_period_us) * 1e-6;
        let fault = demo::cut(&ports, &mut dead, &self.gear.plan, period_s, quiet)?;
        self.ports = Some(ports);
        match fault {
            None => Ok(()),
            Some(f) => Err((
                3,
                format!(
                    "FAULT in the cut of the {}: {f} (the machine retracted and stopped; see \
                     {}/events.log)\nlog: {}",
                    name.replace('-', " "),
                    recording.display(),
                    self.p.dir.display()
                ),
            )),
        }
    }

    /// X and Y jogged to just below their home positions, as an operator does before
    /// restarting the loop: it references them again.
    fn park_near_home(&mut self) -> Result<(), (u8, String)> {
        let Some(ports) = self.ports.take() else {
            return Ok(());
        };
        let m = self.machine;
        say(
            self.a.quiet,
            "X and Y jogged near home (referencing again takes seconds from there)",
        );
        for (axis, home) in [
            ("x", m.x.homing.home_position_mm),
            ("y", m.y.homing.home_position_mm),
        ] {
            let to = home - PARK_BELOW_HOME_MM;
            let at = |x: &hob_ipc::StateSample| if axis == "x" { x.x_mm.actual } else { x.y_mm.actual };
            let mut dead = || self.dead();
            let now = wait_for(&ports, &mut dead, Duration::from_secs(30), "idle", |s, _| {
                s == State::Idle
            })
            .map_err(|e| (1, e))?;
            let jog = service::jog(axis, to - at(&now)).and_then(|r| service::request(&r));
            jog.map_err(|e| (e.exit_code(), format!("jog {axis}: {e}")))?;
            wait_for(
                &ports,
                &mut dead,
                Duration::from_secs(300),
                &format!("{axis} at {to} mm"),
                |s, x| s == State::Idle && (at(x) - to).abs() < 0.1,
            )
            .map_err(|e| (1, e))?;
        }
        Ok(())
    }

    /// The checker on the gear in `name`: hob-sim's truth copied beside the recording,
    /// `hob-lab check`'s files written there; with the report's truth of the same cut.
    fn measure(&self, name: &str, seed: u64) -> Result<Measured, (u8, String)> {
        let dir = self.p.dir.join(name);
        let truth = hob_logger::truth::FILE;
        std::fs::copy(self.p.dir.join(truth), dir.join(truth))
            .map_err(|e| (1, format!("{}: {e}", dir.join(truth).display())))?;
        let args = check::Args {
            log: &dir,
            program: self.a.program,
            out: &dir,
            heights: HEIGHTS,
            seed,
        };
        let gear = name.replace('-', " ");
        let text = check::run(self.machine, &args).map_err(|e| match e {
            check::CheckError::Refused(e) => (2, format!("the checker on the {gear}: {e}")),
            check::CheckError::Failed(e) => (1, format!("the checker on the {gear}: {e}")),
        })?;
        say(self.a.quiet, text.trim_end());
        let mut files = Vec::new();
        for i in 1..=HEIGHTS {
            let f = check::measurement_file(&dir, i);
            let m = compensate::read_measurement(&f).map_err(|e| (1, e.to_string()))?;
            let (fpt, fp) = m.figures_um();
            files.push((f, m.header.face_position_mm, fpt, fp));
        }
        let report = hob_logger::export::report(&dir).map_err(|e| (1, format!("{}: {e}", dir.display())))?;
        let truth = report
            .truth
            .and_then(|t| t.passes.last().and_then(|p| p.predicted.clone()));
        Ok(Measured { dir, files, truth })
    }

    /// `hob compensate --yes` on the first gear (its files, its log, the demo's machine
    /// file): its whole output and its plot beside the first gear's log.
    fn compensate(&self, first: &Measured) -> Result<Compensation, (u8, String)> {
        let o = compensate::Options {
            machine: self.p.machine_file.clone(),
            program: self.a.program.to_path_buf(),
            log: first.dir.clone(),
            // The first gear's log holds its one cut.
            cycles: None,
            measurements: first.files.iter().map(|f| f.0.clone()).collect(),
            svg: Some(first.dir.join("compensation.svg")),
            yes: true,
        };
        let out = compensate::run(&o).map_err(|e| match e {
            CompensateError::Refused(t) => (2, format!("hob compensate: {t}")),
            CompensateError::Failed(t) => (1, format!("hob compensate: {t}")),
        })?;
        let saved = first.dir.join("compensate.txt");
        std::fs::write(&saved, &out.text).map_err(|e| (1, format!("{}: {e}", saved.display())))?;
        // What it found: the lines before the plot and the file it wrote.
        let found: String = out
            .text
            .lines()
            .take_while(|l| !l.is_empty() && !l.starts_with("the plot:"))
            .map(|l| format!("{l}\n"))
            .collect();
        say(self.a.quiet, found.trim_end());
        Ok(Compensation {
            found,
            file: out.file,
        })
    }
}

/// `new-blank` and `pitch-compensation on` as the CLI sends them, once the restarted loop
/// says it loaded the compensation (switched off); `Err` when it did not.
fn switch_on(
    ports: &Ports,
    dead: &mut dyn FnMut() -> Option<String>,
    recording: &Path,
    quiet: bool,
) -> Result<(), (u8, String)> {
    let loaded = wait_for(ports, dead, Duration::from_secs(10), "idle", |s, _| {
        s == State::Idle
    })
    .map_err(|e| (1, e))?;
    if loaded.pitch_compensation == hob_ipc::pitch_compensation::NONE {
        return Err((
            1,
            format!(
                "hob-rt loaded no pitch compensation after the restart: see {}",
                recording.join("hob-rt.log").display()
            ),
        ));
    }
    let log = std::fs::read_to_string(recording.join("hob-rt.log")).unwrap_or_default();
    if let Some(line) = log
        .lines()
        .find(|l| l.contains("pitch compensation for worm set"))
    {
        say(quiet, line);
    }
    for (what, req) in [
        ("new-blank", Ok(service::simple(hob_ipc::command::NEW_BLANK))),
        ("pitch-compensation on", service::pitch_compensation("on")),
    ] {
        let answer = req.and_then(|r| service::request(&r));
        say(
            quiet,
            &answer.map_err(|e| (e.exit_code(), format!("{what}: {e}")))?,
        );
    }
    wait_for(
        ports,
        dead,
        Duration::from_secs(10),
        "pitch compensation on",
        |s, x| s == State::Idle && x.pitch_compensation == hob_ipc::pitch_compensation::ON,
    )
    .map(|_| ())
    .map_err(|e| (1, e))
}

/// The ISO 1328-1 grade `um` meets, from the tolerance `tol_um` of grade `grade` (each
/// grade sqrt(2) coarser than the one before, `hob_gearing::iso1328::grade_factor`):
/// "grade 4", or "over grade 11".
fn grade_of(um: f64, tol_um: f64, grade: u8) -> String {
    let tol = |g: u8| tol_um * std::f64::consts::SQRT_2.powi(i32::from(g) - i32::from(grade));
    (1..=11u8)
        .find(|&g| um <= tol(g))
        .map_or_else(|| "over grade 11".to_string(), |g| format!("grade {g}"))
}

/// One figure against its tolerance: ` 13.30 um  133 % (grade 6)`.
fn figure(um: f64, tol_um: f64, grade: u8) -> String {
    format!(
        "{um:6.2} um {:4.0} % ({})",
        100.0 * um / tol_um,
        grade_of(um, tol_um, grade)
    )
}

/// The two gears side by side: by the checker (its files: the worst height) and by the
/// truth at every face section of the pass, f_pt and F_p against the grade's tolerances.
fn side_by_side(gear: &Gear, first: &Measured, second: &Measured) -> String {
    let mut o = String::new();
    let (Some(t1), Some(t2)) = (&first.truth, &second.truth) else {
        let _ = writeln!(o, "no truth beside the recordings: the gears are not graded");
        return o;
    };
    let (tf, tp, g) = (
        t1.single_pitch_tolerance_um,
        t1.cumulative_pitch_tolerance_um,
        t1.grade,
    );
    let _ = writeln!(
        o,
        "\n{}, {} teeth, {}-start hob:\n{:<30}{:<34}second gear (compensation on)",
        gear.name, gear.plan.teeth, gear.plan.starts, "", "first gear (compensation off)",
    );
    let row = |o: &mut String, what: &str, a: f64, b: f64, tol: f64| {
        let _ = writeln!(o, "  {what:<28}{:<34}{}", figure(a, tol, g), figure(b, tol, g));
    };
    let (c1, c2) = (first.checker_um(), second.checker_um());
    let _ = writeln!(
        o,
        "by the checker's files ({} heights around mid-face, the worst; 0.4 um noise a flank):",
        first.files.len()
    );
    row(&mut o, "f_pt, single pitch", c1.0, c2.0, tf);
    row(&mut o, "F_p, cumulative pitch", c1.1, c2.1, tp);
    let _ = writeln!(
        o,
        "by the truth (the simulated machine's, every face section of the pass: {} and {}):",
        t1.sections, t2.sections
    );
    row(
        &mut o,
        "f_pt, single pitch",
        t1.single_pitch_um,
        t2.single_pitch_um,
        tf,
    );
    row(
        &mut o,
        "F_p, cumulative pitch",
        t1.cumulative_pitch_um,
        t2.cumulative_pitch_um,
        tp,
    );
    let _ = writeln!(
        o,
        "%: of ISO 1328-1 grade {g}'s tolerance for this gear (f_pt {tf:.2} um, F_p {tp:.2} um); \
         (grade N): the finest grade the figure meets\n\
         the compensation made f_pt {:.1} times and F_p {:.1} times smaller (by the truth)",
        t1.single_pitch_um / t2.single_pitch_um,
        t1.cumulative_pitch_um / t2.cumulative_pitch_um
    );
    o
}

/// Where the files are.
fn files(first: &Measured, second: &Measured, stored: &Path) -> String {
    let mut o = String::from("\nthe files:\n");
    let names = |m: &Measured| {
        m.files
            .iter()
            .map(|f| f.0.file_name().unwrap_or_default().to_string_lossy().into_owned())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(
        o,
        "  the first gear's log (hob log report DIR): {}\n    the checker's files: {}\n    \
         hob compensate's output and plot: compensate.txt, compensation.svg",
        first.dir.display(),
        names(first)
    );
    let _ = writeln!(
        o,
        "  the compensation: {} (the demo's own; hob-rt loads it at start, switched off)",
        stored.display()
    );
    let _ = writeln!(
        o,
        "  the second gear's log: {}\n    the checker's files: {}",
        second.dir.display(),
        names(second)
    );
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_figure_is_graded_by_the_finest_grade_whose_tolerance_holds_it() {
        // Grade 5's tolerance 10 um: grade 6's 14.14, grade 4's 7.07, grade 1's 2.5.
        assert_eq!(grade_of(10.0, 10.0, 5), "grade 5");
        assert_eq!(grade_of(10.1, 10.0, 5), "grade 6");
        assert_eq!(grade_of(7.0, 10.0, 5), "grade 4");
        assert_eq!(grade_of(0.1, 10.0, 5), "grade 1");
        assert_eq!(grade_of(500.0, 10.0, 5), "over grade 11");
        assert_eq!(figure(13.3, 10.0, 5), " 13.30 um  133 % (grade 6)");
    }
}
