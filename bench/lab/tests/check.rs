//! `hob-lab check` on a recording made in-process: the short two-start helical gear
//! (config/programs/demo-short-helical-z41-m2-2start.toml) cut on a plant whose worm wheel
//! is ISO 1328-1 grade 6 and whose hob runs out axially by 3 um, each trace row written as
//! the loop publishes its sample (`hob_logger::LogWriter`) and as hob-sim writes its truth
//! (`truth.csv`, the law's phase taken off: the join must find it 0). The binary's files
//! must be what `GearChecker` measures fed with the cut's rows directly; what it refuses it
//! refuses with nothing written. Then the loop of issue 34 on those files, as `hob
//! compensate` computes it: the second gear is three times better and within grade 5 (the
//! program's check before the multi-process test runs it over the bus).
#![allow(clippy::unwrap_used)]

use hob_control::pitch_comp::PitchCompensation;
use hob_control::program::CycleProgram;
use hob_ipc::codec::Coupling;
use hob_ipc::{AxisSample, StateSample};
use hob_logger::predicted::PredictedGear;
use hob_logger::trace::TraceRow;
use hob_logger::truth::{self, TruthRow};
use hob_plant::checker::{GearChecker, GearUnderTest};
use hob_plant::config::PlantConfig;
use hob_plant::disturbance::Disturbance;
use hob_plant::sim::{SimOptions, run_program};
use hob_setup::config::Problems;
use hob_setup::planner::{self, Plan};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;

const SEED: u64 = 11;
const PROGRAM: &str = "config/programs/demo-short-helical-z41-m2-2start.toml";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn program() -> PathBuf {
    root().join(PROGRAM)
}

fn lab(args: &[&str]) -> Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_hob-lab"))
        .args(args)
        .current_dir(root())
        .output()
        .unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn hidden_plant() -> PlantConfig {
    let mut plant =
        Disturbance::Nominal.apply(&PlantConfig::load(&root().join("config/plant.toml")).unwrap());
    plant.table.worm.wheel_grade = 6;
    plant.spindle.hob_axial_runout_um = 3.0;
    plant.simulation.seed = SEED;
    plant
}

/// The sample the loop would publish for a row.
fn sample(cycle: u64, r: &TraceRow, plan: &Plan) -> StateSample {
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
        pitch_radius_mm: plan.pitch_diameter_mm / 2.0,
        normal_module_mm: plan.normal_module_mm,
        feed_override_percent: 100.0,
        spindle_override_percent: 100.0,
        ..StateSample::default()
    }
}

/// What hob-sim would write at that SYNC: the drive's error is the controller's own
/// estimate here (the law's phase is 0), the blank's the plant's truth.
fn truth_row(cycle: u64, r: &TraceRow) -> TruthRow {
    TruthRow {
        sync_ns: cycle * 1_000_000 + 20_000,
        table_drive_deg: r.table_deg,
        y_mm: r.y_mm,
        drive_err_arcsec: r.sync_err_arcsec.unwrap_or(0.0),
        blank_err_arcsec: r.blank_err_arcsec.or(r.sync_err_arcsec).unwrap_or(0.0),
    }
}

struct Cut {
    gear: PredictedGear,
    tooth_phase_deg: Option<f64>,
    rows: Vec<TraceRow>,
    checker: GearChecker,
}

fn cut(compensation: Option<PitchCompensation>) -> Cut {
    let machine = hob_store::files::load_machine(&root().join("config/machine.toml")).unwrap();
    let (job, _) = hob_store::files::read_program(&program()).unwrap();
    let mut p = Problems::new();
    let cycle = CycleProgram::build(&job, &machine, &mut p).unwrap();
    let plan = planner::plan(&job, &machine, &mut p).unwrap();
    let mut checker = GearChecker::new(GearUnderTest::of(
        job.workpiece.name.clone().unwrap(),
        &plan,
        &cycle,
    ));
    let mut rows = Vec::new();
    let options = SimOptions {
        grade: 5,
        pitch_compensation: compensation,
        ..SimOptions::default()
    };
    let summary = run_program(
        &machine,
        &hidden_plant(),
        &cycle,
        &plan,
        &job,
        &options,
        &mut |row| {
            checker.add(row);
            rows.push(*row);
        },
    )
    .unwrap();
    assert!(summary.completed, "{:?}", summary.fault);
    Cut {
        gear: summary.passes.last().unwrap().predicted.clone().unwrap(),
        tooth_phase_deg: summary.tooth_phase_deg,
        rows,
        checker,
    }
}

/// Writes `rows` as a log directory (and its truth beside it, `with_truth`).
fn write_log(dir: &Path, rows: &[TraceRow], with_truth: bool) {
    let machine = hob_store::files::load_machine(&root().join("config/machine.toml")).unwrap();
    let (job, _) = hob_store::files::read_program(&program()).unwrap();
    let plan = planner::plan(&job, &machine, &mut Problems::new()).unwrap();
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir).unwrap();
    let mut writer = hob_logger::LogWriter::open(dir, "test").unwrap();
    for (i, r) in rows.iter().enumerate() {
        writer.push_state(&sample(i as u64 + 1, r, &plan)).unwrap();
    }
    writer.flush().unwrap();
    drop(writer);
    if with_truth {
        let mut t = Vec::new();
        truth::write_head(
            &mut t,
            truth::Gear {
                teeth: plan.teeth,
                face_width_mm: plan.face_width_mm,
                pitch_radius_mm: plan.pitch_diameter_mm / 2.0,
                normal_module_mm: plan.normal_module_mm,
                starts: plan.starts,
            },
        )
        .unwrap();
        for (i, r) in rows.iter().enumerate() {
            writeln!(t, "{}", truth_row(i as u64 + 1, r).csv()).unwrap();
        }
        std::fs::write(dir.join(truth::FILE), t).unwrap();
    }
}

struct First {
    dir: PathBuf,
    log: PathBuf,
    cut: Cut,
}

fn first() -> &'static First {
    static FIRST: OnceLock<First> = OnceLock::new();
    FIRST.get_or_init(|| {
        let t0 = std::time::Instant::now();
        let dir = std::env::temp_dir().join(format!("hob-lab-check-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let cut = cut(None);
        let log = dir.join("log");
        write_log(&log, &cut.rows, true);
        eprintln!(
            "the first cut: {} rows, {:.1} s",
            cut.rows.len(),
            t0.elapsed().as_secs_f64()
        );
        First { dir, log, cut }
    })
}

fn check(log: &Path, out: &Path, extra: &[&str]) -> Output {
    let (log, out, program) = (log.to_str().unwrap(), out.to_str().unwrap(), program());
    let mut args = vec![
        "check",
        "--log",
        log,
        "--program",
        program.to_str().unwrap(),
        "--out",
        out,
    ];
    args.extend(extra);
    lab(&args)
}

fn parse(file: &Path) -> hob_gear_check::PitchMeasurement {
    hob_gear_check::parse(&std::fs::read_to_string(file).unwrap()).unwrap()
}

#[test]
fn the_files_are_the_checker_s_measurement_of_the_cut_and_compensate_makes_the_second_gear_3x_better() {
    let f = first();
    let out = f.dir.join("measured");
    let o = check(&f.log, &out, &["--heights", "3", "--seed", &SEED.to_string()]);
    let shown = text(&o);
    println!("{shown}");
    assert_eq!(o.status.code(), Some(0), "{shown}");
    let files: Vec<PathBuf> = (1..=3)
        .map(|i| out.join(format!("measurement-{i}.csv")))
        .collect();
    let measured: Vec<_> = files.iter().map(|f| parse(f)).collect();
    assert!(!out.join("measurement-4.csv").exists());
    let direct = f.cut.checker.clone().measure_heights(SEED, "now", 3);
    assert_eq!(direct.len(), 3);
    for ((m, d), file) in measured.iter().zip(&direct).zip(&files) {
        assert!(
            shown.contains(&format!(
                "{}: height {:.3} mm above the face bottom",
                file.display(),
                m.header.face_position_mm
            )),
            "{shown}"
        );
        assert_eq!(m.header.gear, "short helical z41 m2 2-start for bus tests");
        assert_eq!(m.header.teeth, 41);
        assert!((m.header.face_position_mm - d.header.face_position_mm).abs() < 1e-3);
        assert!(
            (0.0..=21.0).contains(&m.header.face_position_mm),
            "{} mm: outside the face",
            m.header.face_position_mm
        );
        for (a, b) in [(&m.left, &d.left), (&m.right, &d.right)] {
            for (x, y) in a.cumulative_um.iter().zip(&b.cumulative_um) {
                assert!((x - y).abs() < 2e-3, "{x} vs {y} um");
            }
        }
    }

    // The loop, as `hob compensate` computes it from the log and the files.
    let machine = hob_store::files::load_machine(&root().join("config/machine.toml")).unwrap();
    let gear = hob_cli::compensate::load_gear(&program(), &machine).unwrap();
    let rows = hob_cli::compensate::read_log(&f.log).unwrap();
    let c = hob_cli::compensate::compute(&rows, &gear, &measured).unwrap();
    let stored = hob_cli::compensate::stored(&c, &gear, "B-2019-07", &measured, &files, &f.log);
    println!("hob identified: {:?}", stored.hob_identified);
    let compensation = hob_cli::compensate::to_control(&stored).unwrap();
    let second = cut(Some(compensation));
    assert!(second.tooth_phase_deg.is_some());
    println!("first gear:  {}", f.cut.gear.text());
    println!("second gear: {}", second.gear.text());
    let (f1, p1, _) = f.cut.gear.shares();
    let (f2, p2, _) = second.gear.shares();
    assert!(
        f1 >= 3.0 * f2 && p1 >= 3.0 * p2,
        "f_pt {f1:.2} -> {f2:.2}, F_p {p1:.2} -> {p2:.2} of grade 5"
    );
    assert!(f2 <= 1.0 && p2 <= 1.0, "{}", second.gear.text());
}

/// Refused, exit 2, with the words `needles`, and nothing written.
fn refused(log: &Path, extra: &[&str], needles: &[&str]) {
    let out = first()
        .dir
        .join(format!("refused-{}", needles[0].replace([' ', '/'], "-")));
    let o = check(log, &out, extra);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    for n in needles {
        assert!(t.contains(n), "{n:?} not in: {t}");
    }
    assert!(!out.exists(), "a refusal wrote {}", out.display());
}

#[test]
fn a_log_without_truth_of_another_gear_or_without_a_finished_section_is_refused() {
    let f = first();
    // No truth beside the log.
    let bare = f.dir.join("no-truth");
    write_log(&bare, &f.cut.rows, false);
    refused(&bare, &[], &["no truth.csv", "hob-sim --truth"]);
    // A truth of another gear.
    let other = f.dir.join("other-truth");
    write_log(&other, &f.cut.rows, true);
    let t = std::fs::read_to_string(other.join(truth::FILE)).unwrap();
    let first_line = t.lines().next().unwrap().to_string();
    std::fs::write(
        other.join(truth::FILE),
        t.replacen(
            &first_line,
            &first_line
                .replace("teeth 41", "teeth 17")
                .replace("normal_module_mm 2", "normal_module_mm 5"),
            1,
        ),
    )
    .unwrap();
    refused(&other, &[], &["truth.csv is of another gear", "17 teeth"]);
    // A recording of another gear than the program's.
    let spur = root().join("config/programs/demo-short-spur-z17-m5.toml");
    let out = f.dir.join("refused-spur");
    let o = lab(&[
        "check",
        "--log",
        f.log.to_str().unwrap(),
        "--program",
        spur.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("the recording is of another gear"),
        "{}",
        text(&o)
    );
    assert!(!out.exists());
    // The cut stopped before a table turn of its pass: no complete face section.
    let cut_rows = &f.cut.rows;
    let into = cut_rows
        .iter()
        .position(|r| r.state == hob_ipc::codec::State::Cut && r.blank_err_arcsec.is_some())
        .unwrap();
    let short = f.dir.join("short");
    write_log(&short, &cut_rows[..into + 2000], true);
    refused(&short, &[], &["no complete face section of the last pass"]);
    // More heights than the pass has sections.
    refused(&f.log, &["--heights", "40"], &["--heights 40 asks for more"]);
}
