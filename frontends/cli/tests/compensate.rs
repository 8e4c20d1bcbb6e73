//! `hob compensate` from files (issue 34): the held-out helical gear cut once on a plant
//! whose worm wheel is ISO 1328-1 grade 6 and whose hob runs out axially by 3 um, its trace
//! written into a log directory in the logger's format (`hob_logger::LogWriter`, each row
//! as the loop publishes its sample), the simulated checker's files written at three
//! heights; the command's function must store what the in-process flow
//! (bench/plant/tests/compensation.rs) computes, and refuse what does not fit. One cut,
//! shared by the tests.
#![allow(clippy::unwrap_used)]

use hob_cli::compensate::{self, CompensateError, Options};
use hob_control::pitch_comp::PitchCompensation;
use hob_control::program::CycleProgram;
use hob_gear_check::{FlankPitch, GapRecord, Height, PitchMeasurement, decompose};
use hob_ipc::codec::Coupling;
use hob_ipc::{AxisSample, StateSample};
use hob_logger::gaps::{GapRecorder, GapSection};
use hob_logger::trace::TraceRow;
use hob_plant::checker::{GearChecker, GearUnderTest};
use hob_plant::config::PlantConfig;
use hob_plant::disturbance::Disturbance;
use hob_plant::sim::{SimOptions, run_program};
use hob_setup::config::Problems;
use hob_setup::planner::{self, Plan};
use hob_store::pitch_compensation::load_for;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

const SEED: u64 = 11;
const WORM_SET: &str = "B-2019-07";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn program() -> PathBuf {
    root().join("config/programs/helical-z41-m2-2start.toml")
}

/// The first cut, as files: its log, the checker's files, and what the in-process flow
/// made of it.
struct First {
    dir: PathBuf,
    log: PathBuf,
    measurements: Vec<PathBuf>,
    expected: PitchCompensation,
    measured: Vec<PitchMeasurement>,
    /// The cut's rows as written into the log, cycle k+1 for row k.
    rows: Vec<TraceRow>,
    gear: (f64, f64),
}

fn first() -> &'static First {
    static FIRST: OnceLock<First> = OnceLock::new();
    FIRST.get_or_init(cut_first)
}

/// A copy of the shipped machine file with its own state file (`name`'s directory), with
/// `edits` made.
fn machine_file(name: &str, edits: &[(&str, &str)]) -> PathBuf {
    let dir = first().dir.join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut text = std::fs::read_to_string(root().join("config/machine.toml")).unwrap();
    let state = dir.join("state/machine-state.toml");
    let mut all = vec![(
        "file = \"/var/lib/hob/machine-state.toml\"".to_string(),
        format!("file = \"{}\"", state.display()),
    )];
    all.extend(edits.iter().map(|(a, b)| (a.to_string(), b.to_string())));
    for (from, to) in all {
        assert!(text.contains(&from), "machine.toml has no {from:?}");
        text = text.replace(&from, &to);
    }
    let file = dir.join("machine.toml");
    std::fs::write(&file, text).unwrap();
    file
}

fn state_of(machine: &Path) -> PathBuf {
    machine.parent().unwrap().join("state/machine-state.toml")
}

/// The sample the loop would publish for a row (the plant's controller-share error as the
/// controller's own, its table, spindle and Y as measured).
fn sample(cycle: u64, r: &TraceRow, pitch_radius_mm: f64, module_mm: f64) -> StateSample {
    let coupling = match r.sync_err_arcsec {
        Some(_) => Coupling::Synchronised,
        None => Coupling::Disengaged,
    };
    StateSample {
        cycle,
        sync_time_ns: cycle * 1_000_000,
        state: r.state.code(),
        hold: u8::from(r.hold),
        pass: r.pass,
        coupling: coupling.code(),
        table_deg: AxisSample {
            actual: r.table_deg,
            command: r.table_cmd_deg,
        },
        x_mm: AxisSample {
            actual: r.x_mm,
            command: r.x_cmd_mm,
        },
        y_mm: AxisSample {
            actual: r.y_mm,
            command: r.y_cmd_mm,
        },
        spindle_deg: r.spindle_deg,
        sync_error_arcsec: r.sync_err_arcsec.unwrap_or(0.0),
        pitch_radius_mm,
        normal_module_mm: module_mm,
        feed_override_percent: r.feed_override_percent.unwrap_or(100.0),
        spindle_override_percent: r.spindle_override_percent.unwrap_or(100.0),
        ..StateSample::default()
    }
}

fn cut_first() -> First {
    let t0 = std::time::Instant::now();
    // 400 MB of recording a test process: under the build's own scratch directory, and
    // those of processes gone (each test is one under nextest) removed first, so that the
    // runs do not fill the disk (they did: 79 left in /tmp, 32 GB).
    let base = Path::new(env!("CARGO_TARGET_TMPDIR"));
    for e in std::fs::read_dir(base).into_iter().flatten().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let pid = name
            .strip_prefix("hob-cli-compensate-")
            .and_then(|p| p.parse::<u32>().ok());
        if pid.is_some_and(|pid| !Path::new(&format!("/proc/{pid}")).exists()) {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
    let dir = base.join(format!("hob-cli-compensate-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let machine = hob_store::files::load_machine(&root().join("config/machine.toml")).unwrap();
    let (job, _) = hob_store::files::read_program(&program()).unwrap();
    let mut p = Problems::new();
    let cycle = CycleProgram::build(&job, &machine, &mut p).unwrap();
    let plan = planner::plan(&job, &machine, &mut p).unwrap();
    let mut plant =
        Disturbance::Nominal.apply(&PlantConfig::load(&root().join("config/plant.toml")).unwrap());
    plant.table.worm.wheel_grade = 6;
    plant.spindle.hob_axial_runout_um = 3.0;
    plant.simulation.seed = SEED;
    let r_mm = plan.pitch_diameter_mm / 2.0;
    let mut checker = GearChecker::new(GearUnderTest::of(
        job.workpiece.name.clone().unwrap(),
        &plan,
        &cycle,
    ));
    let mut recorder = GapRecorder::new(plan.teeth, r_mm);
    let log = dir.join("log");
    std::fs::create_dir_all(&log).unwrap();
    let mut writer = hob_logger::LogWriter::open(&log, "test").unwrap();
    let mut n = 0;
    let mut rows = Vec::new();
    let options = SimOptions {
        grade: 5,
        ..SimOptions::default()
    };
    let summary = run_program(&machine, &plant, &cycle, &plan, &job, &options, &mut |row| {
        checker.add(row);
        recorder.add(row);
        rows.push(*row);
        n += 1;
        writer
            .push_state(&sample(n, row, r_mm, plan.normal_module_mm))
            .unwrap();
    })
    .unwrap();
    writer.flush().unwrap();
    drop(writer);
    assert!(summary.completed, "{:?}", summary.fault);
    let measurements: Vec<PathBuf> = checker
        .measure_heights(SEED, "2026-11-29T12:00:00Z", 3)
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let f = dir.join(format!("height-{}.csv", i + 1));
            std::fs::write(&f, m.to_file()).unwrap();
            f
        })
        .collect();
    // The checker's numbers as its files give them (3 decimals, um).
    let measured: Vec<PitchMeasurement> = measurements
        .iter()
        .map(|f| hob_gear_check::parse(&std::fs::read_to_string(f).unwrap()).unwrap())
        .collect();
    let expected = in_process(
        &recorder.finish(),
        &measured,
        cycle.face_bottom_mm,
        &plan,
        summary.tooth_phase_deg.unwrap(),
    );
    eprintln!("the first cut: {n} rows, {:.1} s", t0.elapsed().as_secs_f64());
    First {
        dir,
        log,
        measurements,
        expected,
        measured,
        rows,
        gear: (r_mm, plan.normal_module_mm),
    }
}

/// The in-process flow of bench/plant/tests/compensation.rs: each measurement matched to
/// the record's section at its height, decomposed, and turned into the compensation.
fn in_process(
    record: &[GapSection],
    measured: &[PitchMeasurement],
    face_bottom_mm: f64,
    plan: &Plan,
    tooth_phase_deg: f64,
) -> PitchCompensation {
    let r_mm = plan.pitch_diameter_mm / 2.0;
    let records: Vec<Vec<GapRecord>> = measured
        .iter()
        .map(|m| {
            let y = face_bottom_mm + m.header.face_position_mm;
            hob_logger::gaps::nearest(record, y).unwrap().records()
        })
        .collect();
    let heights: Vec<Height> = measured
        .iter()
        .zip(&records)
        .map(|(m, g)| Height {
            measurement: m,
            gaps: g,
        })
        .collect();
    let d = decompose(&heights, plan.starts).unwrap();
    let deg = |um: f64| (um * 1e-3 / r_mm).to_degrees();
    let offsets: Vec<f64> = d.table_error_um.iter().map(|&e| -deg(e)).collect();
    PitchCompensation::new(
        d.gap_table_deg[0],
        &offsets,
        -deg(d.hob.a_um),
        -deg(d.hob.b_um),
        tooth_phase_deg,
    )
    .unwrap()
}

fn options(machine: PathBuf, measurements: Vec<PathBuf>, yes: bool) -> Options {
    Options {
        machine,
        program: program(),
        log: first().log.clone(),
        measurements,
        cycles: None,
        svg: None,
        yes,
    }
}

fn refused(o: &Options, needles: &[&str]) {
    match compensate::run(o) {
        Err(CompensateError::Refused(text)) => {
            for n in needles {
                assert!(text.contains(n), "{n:?} not in the refusal: {text}");
            }
        }
        other => panic!("not refused: {other:?}"),
    }
    let written = state_of(&o.machine).parent().unwrap().join("pitch-compensation");
    assert!(!written.exists(), "a refusal wrote {}", written.display());
}

#[test]
fn the_stored_compensation_is_the_one_computed_in_process() {
    let f = first();
    let machine = machine_file("stored", &[]);
    let state = state_of(&machine);
    let mut o = options(machine, f.measurements.clone(), false);
    o.svg = Some(f.dir.join("stored/plot.svg"));
    let shown = compensate::run(&o).unwrap();
    print!("{}", shown.text);
    assert!(!shown.written && shown.text.contains("(new)"), "{}", shown.text);
    assert!(shown.text.contains("not written"), "{}", shown.text);
    assert_eq!(load_for(&state, WORM_SET).unwrap(), None, "written without --yes");
    let svg = std::fs::read_to_string(o.svg.as_ref().unwrap()).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("polyline"), "{svg}");

    o.yes = true;
    let out = compensate::run(&o).unwrap();
    assert!(out.written && out.kept.is_none());
    let stored = load_for(&state, WORM_SET).unwrap().unwrap();
    assert_eq!(stored, out.stored);
    assert_eq!(stored.gear, "Helical z41 m2 beta 15 LH");
    assert_eq!(
        stored.measurements,
        ["height-1.csv", "height-2.csv", "height-3.csv"]
    );
    let from_file = compensate::to_control(&stored).unwrap();
    let e = &f.expected;
    let pitch = 360.0 / 41.0;
    let dp = (from_file.phase_deg() - e.phase_deg()).rem_euclid(pitch);
    assert!(dp.min(pitch - dp) < 1e-9, "tooth phase {dp} deg off");
    for k in 0..400 {
        let (table, spindle) = (k as f64 * 0.9137, k as f64 * 7.31);
        let (a, b) = (from_file.offset_deg(table, spindle), e.offset_deg(table, spindle));
        assert!((a - b).abs() < 1e-12, "at {table} deg: {a} vs {b}");
    }
    // What it removes is the gear's repeatable error: most of the measured one.
    let (fpt, _) = f.measured[0].figures_um();
    assert!(stored.removable_single_pitch_um > 0.5 * fpt, "{stored:?}");

    // Again: the diff against the stored one, the old one kept.
    let again = compensate::run(&o).unwrap();
    assert!(
        again.text.contains("changes against the current one"),
        "{}",
        again.text
    );
    let kept = again.kept.unwrap();
    assert_eq!(
        hob_store::pitch_compensation::StoredCompensation::parse(
            &kept,
            &std::fs::read_to_string(&kept).unwrap()
        )
        .unwrap(),
        stored
    );
}

#[test]
fn another_gear_s_measurement_is_refused() {
    let f = first();
    let other = f.dir.join("other-gear.csv");
    let text = std::fs::read_to_string(&f.measurements[0])
        .unwrap()
        .replace("# gear: Helical z41 m2 beta 15 LH", "# gear: Spur z41");
    std::fs::write(&other, text).unwrap();
    let o = options(machine_file("other-gear", &[]), vec![other], true);
    refused(
        &o,
        &[
            "other-gear.csv",
            "gear",
            "\"Spur z41\"",
            "\"Helical z41 m2 beta 15 LH\"",
        ],
    );
}

#[test]
fn a_wrong_tooth_count_is_refused() {
    let f = first();
    let mut m = f.measured[0].clone();
    let positions = |fl: &FlankPitch| -> Vec<f64> { fl.cumulative_um[..40].to_vec() };
    m.left = FlankPitch::from_positions(&positions(&m.left));
    m.right = FlankPitch::from_positions(&positions(&m.right));
    m.header.teeth = 40;
    let file = f.dir.join("teeth-40.csv");
    std::fs::write(&file, m.to_file()).unwrap();
    let o = options(machine_file("teeth", &[]), vec![file], true);
    refused(&o, &["teeth-40.csv", "teeth", "40 teeth", "41"]);
}

#[test]
fn a_malformed_file_is_refused_with_its_line_and_field() {
    let f = first();
    let text = std::fs::read_to_string(&f.measurements[1]).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let row = lines.iter().position(|l| l.starts_with("5,")).unwrap();
    let mut fields: Vec<&str> = lines[row].split(',').collect();
    fields[2] = "0.4x";
    let bad_row = fields.join(",");
    let mut out: Vec<&str> = lines.clone();
    out[row] = &bad_row;
    let file = f.dir.join("malformed.csv");
    std::fs::write(&file, out.join("\n") + "\n").unwrap();
    let o = options(
        machine_file("malformed", &[]),
        vec![f.measurements[0].clone(), file],
        true,
    );
    refused(
        &o,
        &["malformed.csv", &format!("line {}", row + 1), "right_fp_um"],
    );
}

#[test]
fn a_measurement_away_from_the_cut_s_sections_is_refused() {
    let f = first();
    let text = std::fs::read_to_string(&f.measurements[0]).unwrap();
    let line = text
        .lines()
        .find(|l| l.starts_with("# face_position_mm:"))
        .unwrap();
    let file = f.dir.join("off-face.csv");
    std::fs::write(&file, text.replace(line, "# face_position_mm: 80.000")).unwrap();
    let o = options(machine_file("off-face", &[]), vec![file], true);
    refused(&o, &["face_position_mm 80", "half a feed"]);
}

#[test]
fn a_machine_file_without_a_worm_set_is_refused() {
    let f = first();
    let m = machine_file("no-worm-set", &[("worm_set = \"B-2019-07\"\n", "")]);
    let o = options(m, f.measurements.clone(), true);
    refused(&o, &["table.worm_set", "is not set"]);
}

#[test]
fn a_stored_file_of_another_worm_set_is_refused() {
    let f = first();
    let m = machine_file("other-set", &[]);
    let state = state_of(&m);
    let mut o = options(m, f.measurements.clone(), false);
    // The set's file, copied from another machine whose set it was.
    let mut s = compensate::run(&o).unwrap().stored;
    s.worm_set = "C-2021-03".into();
    s.save(&state).unwrap();
    let file = hob_store::pitch_compensation::path_for(&state, "C-2021-03");
    let mine = hob_store::pitch_compensation::path_for(&state, WORM_SET);
    std::fs::rename(&file, &mine).unwrap();
    let before = std::fs::read(&mine).unwrap();
    o.yes = true;
    match compensate::run(&o) {
        Err(CompensateError::Refused(t)) => {
            assert!(t.contains("\"C-2021-03\"") && t.contains("\"B-2019-07\""), "{t}");
        }
        other => panic!("not refused: {other:?}"),
    }
    assert_eq!(
        std::fs::read(&mine).unwrap(),
        before,
        "the other set's file was changed"
    );
}

#[test]
fn a_malformed_cycle_range_is_refused() {
    assert_eq!(compensate::parse_cycles("1200..98000"), Ok((1200, 98000)));
    assert_eq!(compensate::parse_cycles("7..7"), Ok((7, 7)));
    for (text, why) in [
        ("1200-98000", "no \"..\""),
        ("..98000", "the first cycle \"\" is not a whole number"),
        ("1200..", "the last cycle \"\" is not a whole number"),
        ("12x..40", "the first cycle \"12x\" is not a whole number"),
        ("-5..40", "the first cycle \"-5\" is not a whole number"),
        ("40..12", "the first cycle 40 is after the last 12"),
    ] {
        match compensate::parse_cycles(text) {
            Err(CompensateError::Refused(t)) => {
                assert!(t.starts_with(&format!("--cycles {text:?}: ")), "{t}");
                assert!(t.contains(why) && t.contains("FIRST..LAST"), "{why:?} not in {t}");
            }
            other => panic!("{text:?} not refused: {other:?}"),
        }
    }
    // The command refuses it, exit 2, before it reads anything (the files need not exist).
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hob"))
        .args(["compensate", "--machine", "/nonexistent/machine.toml"])
        .args(["--program", "/nonexistent/p.toml", "--log", "/nonexistent/log"])
        .args([
            "--measurement",
            "/nonexistent/m.csv",
            "--cycles",
            "40..12",
            "--yes",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(
        said.starts_with("hob: refused: --cycles \"40..12\": the first cycle 40 is after the last 12"),
        "{said}"
    );
}

/// A log with two cuts of the gear, the second at another tooth phase (a third of a pitch
/// on): the log whole is refused, each cut by its cycles gives its own compensation.
#[test]
fn one_cut_of_a_log_that_holds_two_is_chosen_by_its_cycles() {
    let f = first();
    let log = f.dir.join("two-cuts-log");
    let _ = std::fs::remove_dir_all(&log);
    std::fs::create_dir_all(&log).unwrap();
    let mut writer = hob_logger::LogWriter::open(&log, "test").unwrap();
    let n = f.rows.len() as u64;
    let third = 360.0 / 41.0 / 3.0;
    for (k, r) in f.rows.iter().enumerate() {
        writer
            .push_state(&sample(k as u64 + 1, r, f.gear.0, f.gear.1))
            .unwrap();
    }
    for (k, r) in f.rows.iter().enumerate() {
        let mut r = *r;
        r.table_deg += third;
        r.table_cmd_deg += third;
        writer
            .push_state(&sample(n + k as u64 + 1, &r, f.gear.0, f.gear.1))
            .unwrap();
    }
    writer.flush().unwrap();
    drop(writer);
    let machine = machine_file("two-cuts", &[]);
    let mut o = options(machine, f.measurements.clone(), false);
    o.log = log;
    match compensate::run(&o) {
        Err(CompensateError::Refused(t)) => assert!(t.contains("scatter"), "{t}"),
        other => panic!("the log of two cuts whole is not refused: {other:?}"),
    }
    o.cycles = Some((1, n));
    let one = compensate::run(&o).unwrap();
    assert!(
        one.text.contains(&format!("the cut: cycles 1 .. {n} of ")),
        "{}",
        one.text
    );
    let alone = compensate::run(&options(o.machine.clone(), f.measurements.clone(), false)).unwrap();
    assert_eq!(one.stored.table_offsets_arcsec, alone.stored.table_offsets_arcsec);
    assert_eq!(one.stored.tooth_phase_deg, alone.stored.tooth_phase_deg);
    o.cycles = Some((n + 1, 2 * n));
    let two = compensate::run(&o).unwrap();
    let pitch = 360.0 / 41.0;
    let d = (two.stored.tooth_phase_deg - one.stored.tooth_phase_deg - third).rem_euclid(pitch);
    assert!(
        d.min(pitch - d) < 1e-6,
        "the second cut's tooth phase is {d} deg off"
    );
    // The first cut until its last pass begins: no finished cut; cycles the log does not
    // hold: no sample.
    let last = f.rows.iter().map(|r| r.pass).max().unwrap();
    let before_last = f.rows.iter().position(|r| r.pass == last).unwrap() as u64;
    assert!(last > 1 && before_last > 0, "the program has one pass");
    o.cycles = Some((1, before_last));
    refused(&o, &["no finished cut"]);
    o.cycles = Some((3 * n, 4 * n));
    refused(
        &o,
        &[&format!("--cycles {}..{}", 3 * n, 4 * n), "no sample of cycles"],
    );
}
