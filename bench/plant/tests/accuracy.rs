//! The synchronisation error in the cut, measured on the simulated machine (default
//! plant): the whole program, with and without cross-coupling, with the predictor
//! replaced by the last measured angle. Bound: a quarter of the ISO 1328-1 grade-5
//! single pitch tolerance of the gear at its pitch circle; the finished gear's single and
//! cumulative pitch deviations, the controller's share, within a quarter of grade 4. And
//! the truth at the blank sees the worm's errors, which the controller's share does not.
#![allow(clippy::unwrap_used)]

mod common;

use hob_control::SpindleAngleSource;
use hob_plant::config::{PlantConfig, WormCoupling};
use hob_plant::sim::{SimOptions, Summary, run_program};

fn simulate_on(plant: &PlantConfig, name: &str, options: SimOptions) -> Summary {
    let (job, cycle, plan) = common::program(name, &[]);
    let s = run_program(
        &common::machine(),
        plant,
        &cycle,
        &plan,
        &job,
        &options,
        &mut |_| {},
    )
    .unwrap();
    assert!(s.completed, "{name}: {:?}", s.fault);
    assert_eq!(s.passes.len(), plan.passes.len());
    assert!(
        s.passes.iter().all(|p| p.samples > 1000),
        "{name}: every pass cut"
    );
    s
}

fn report(name: &str, label: &str, s: &Summary) {
    let passes: Vec<String> = s
        .passes
        .iter()
        .map(|p| format!("{:.2}/{:.2}", p.sync_err_max_um, p.sync_err_rms_um))
        .collect();
    println!(
        "{name} {label}: max/rms um per pass {} (bound {:.2} um)",
        passes.join(" "),
        s.bound_um
    );
}

/// The finished gear's (last pass's) deviations: the controller's share and the gear's own.
fn finished(
    s: &Summary,
) -> (
    hob_logger::predicted::PredictedGear,
    hob_logger::predicted::PredictedGear,
) {
    let last = s.passes.last().unwrap();
    (
        last.controller_share
            .clone()
            .expect("the last pass completed a face section"),
        last.predicted
            .clone()
            .expect("the truth is known in the simulation"),
    )
}

fn check(name: &str) {
    check_on(&common::plant(), name);
}

fn check_on(plant: &PlantConfig, name: &str) {
    let simulate = |name: &str, options: SimOptions| simulate_on(plant, name, options);
    let grade4 = SimOptions {
        grade: 4,
        ..SimOptions::default()
    };
    let full = simulate(name, grade4);
    let no_ccc = simulate(
        name,
        SimOptions {
            cross_coupling: false,
            ..SimOptions::default()
        },
    );
    let last = SimOptions {
        angle_source: SpindleAngleSource::LastMeasured,
        windows_off: true,
        ..grade4
    };
    let no_predictor = simulate(name, last);
    report(name, "full", &full);
    report(name, "no ccc", &no_ccc);
    report(name, "last measured angle", &no_predictor);
    assert!(
        full.max_sync_err_um <= full.bound_um,
        "{name}: {} um above {} um",
        full.max_sync_err_um,
        full.bound_um
    );
    // Cross-coupling takes out the table drive's following error; the shipped drives loop
    // on 20-bit motor feedback and leave little of it: it must do no harm here
    // (`cross_coupling_takes_out_a_coarse_drive_loops_error` shows it working).
    let rms = |s: &Summary| s.passes.iter().map(|p| p.sync_err_rms_um).fold(0.0, f64::max);
    assert!(
        rms(&full) <= 1.05 * rms(&no_ccc),
        "cross-coupling must do no harm: {} um RMS with, {} without",
        rms(&full),
        rms(&no_ccc)
    );
    assert!(
        no_predictor.max_sync_err_um > 10.0 * full.max_sync_err_um,
        "prediction must help"
    );
    // The gear: the controller's share of f_pt and F_p within a quarter of grade 4; the
    // last measured angle instead of the prediction makes it worse (a constant lag makes
    // no pitch error, its variation with the spindle's speed ripple does: with the table's
    // 2^20 position unit 0.77 against 0.70 um on spur-z17-m5; its lag is what the
    // predictor takes out, 50 times the peak above).
    let (mine, gear) = finished(&full);
    let (fpt, fp, _) = mine.shares();
    println!(
        "{name}: finished gear {}; controller's share {}",
        gear.text(),
        mine.text()
    );
    assert!(fpt <= 0.25 && fp <= 0.25, "{name}: {}", mine.text());
    let (late, _) = finished(&no_predictor);
    assert!(
        late.single_pitch_um > mine.single_pitch_um,
        "{name} without the predictor: {}",
        late.text()
    );
    // The gear itself carries the machine's errors on top of the controller's share.
    assert!(
        gear.cumulative_pitch_um > mine.cumulative_pitch_um,
        "{}",
        gear.text()
    );
}

#[test]
fn thesis_worst_case_spur_is_within_a_quarter_of_grade_5() {
    check("spur-z17-m5.toml");
}

#[test]
fn helical_gear_is_within_a_quarter_of_grade_5() {
    check("helical-z31-m3.toml");
}

/// Cross-coupling where there is a following error to take out: the table drive's loops on
/// 13-bit motor feedback (the shipped 20 bits leave little), tuned at 400/60 Hz on the
/// one-way worm, where that feedback's noise makes the drive's error. Measured on the demo
/// gear at the nominal disturbance: 0.33 um RMS with, 1.02 um without. (On the two-way worm
/// with its 74/16 Hz tuning the same feedback leaves 0.50 um without and 0.39 with, short
/// of this test's 0.6: the slower loops amplify the quantisation less, 2026-11-27.)
#[test]
fn cross_coupling_takes_out_a_coarse_drive_loops_error() {
    let (job, cycle, plan) = common::program("demo-short-spur-z17-m5.toml", &[]);
    let mut plant = common::plant();
    plant.drives.feedback_bits = 13;
    plant.table.coupling = WormCoupling::OneWay;
    plant.table.velocity_loop_hz = 400.0;
    plant.table.position_loop_hz = 60.0;
    let run = |ccc: bool| {
        let s = run_program(
            &common::machine(),
            &plant,
            &cycle,
            &plan,
            &job,
            &SimOptions {
                cross_coupling: ccc,
                ..SimOptions::default()
            },
            &mut |_| {},
        )
        .unwrap();
        assert!(s.completed, "{:?}", s.fault);
        s.passes.iter().map(|p| p.sync_err_rms_um).fold(0.0, f64::max)
    };
    let (with, without) = (run(true), run(false));
    assert!(with < 0.6 * without, "{with} um RMS with, {without} without");
}

/// A gear nothing was tuned on: helical left hand, two-start hob, climb from the top. With
/// two starts the spindle encoder's once-per-turn error reaches alternate teeth: without
/// its identification the controller's f_pt is 32 % of grade 4 (nominal, seed 1).
#[test]
fn held_out_two_start_helical_is_within_a_quarter_of_grade_5() {
    check("helical-z41-m2-2start.toml");
}

/// The emulated PREEMPT_RT guest cannot hold 1 ms, so `ci/service/run` runs there on a
/// 2 ms cycle (`HOB_CYCLE_US=2000`: `control.cycle_period_us` and, CSP, the drive delay).
/// The control core holds its bound on that cycle too (measured with `hob simulate
/// --machine`: 1.32 / 1.63 um of 1.77; at 4 ms it does not: 2.27 um).
#[test]
fn the_demo_job_on_the_guests_2_ms_cycle_is_within_the_bound() {
    let mut m = common::machine();
    m.control.cycle_period_us = 2000;
    m.control.drive_delay_us = 2000;
    // Any problem with the program on this machine fails here (the planner refuses).
    let (job, cycle, plan) = common::program_on(&m, "demo-short-spur-z17-m5.toml", &[]);
    let s = run_program(
        &m,
        &common::plant(),
        &cycle,
        &plan,
        &job,
        &SimOptions::default(),
        &mut |_| {},
    )
    .unwrap();
    report("demo at 2 ms", "full", &s);
    assert!(s.completed, "{:?}", s.fault);
    assert!(
        s.max_sync_err_um <= s.bound_um,
        "{} um above {} um",
        s.max_sync_err_um,
        s.bound_um
    );
}

/// The truth at the blank carries the worm wheel's pitch errors, the controller's share does
/// not: the same job on the shipped plant and with a perfect wheel. The wheel's cumulative
/// error (grade 4 at d 300 mm: 17.6 um = 24.2 arcsec) is 4.99 um at the demo gear's pitch
/// circle (r 42.5 mm).
#[test]
fn the_gear_carries_the_worm_wheels_pitch_error_and_the_controllers_share_does_not() {
    let (job, cycle, plan) = common::program("demo-short-spur-z17-m5.toml", &[]);
    let run = |p: &hob_plant::config::PlantConfig| {
        let s = run_program(
            &common::machine(),
            p,
            &cycle,
            &plan,
            &job,
            &SimOptions {
                grade: 4,
                ..SimOptions::default()
            },
            &mut |_| {},
        )
        .unwrap();
        assert!(s.completed, "{:?}", s.fault);
        finished(&s)
    };
    // The wheel alone: the spindle encoder's and the hob's once-per-turn errors off.
    let mut shipped = common::plant();
    shipped.spindle.encoder_error_arcsec = 0.0;
    shipped.spindle.hob_axial_runout_um = 0.0;
    let mut perfect = shipped.clone();
    perfect.table.worm.wheel_grade = 0;
    let ((mine_w, gear_w), (mine_p, gear_p)) = (run(&shipped), run(&perfect));
    println!(
        "wheel of grade 4: {}\nperfect wheel: {}",
        gear_w.text(),
        gear_p.text()
    );
    let wheel_fp_um = 24.24 / 206_264.8 * 42.5e3;
    assert!(
        gear_w.cumulative_pitch_um - gear_p.cumulative_pitch_um > 0.6 * wheel_fp_um,
        "{} against {}",
        gear_w.cumulative_pitch_um,
        gear_p.cumulative_pitch_um
    );
    assert!(
        (mine_w.cumulative_pitch_um - mine_p.cumulative_pitch_um).abs() < 0.2 * mine_p.cumulative_pitch_um,
        "the controller's share must not see the wheel: {} against {}",
        mine_w.cumulative_pitch_um,
        mine_p.cumulative_pitch_um
    );
}

/// Frames that miss their SYNC (none in the shipped plant file). A late position TPDO leaves
/// the controller without a reading for a cycle: its observer coasts, and the demo gear
/// holds its bound with 1 in 100 late (measured: 1.06 um against 1.12 um with none). A late
/// target RPDO leaves the table drive on its last target for a period (CiA 402 cyclic
/// synchronous position does not extrapolate): the table stalls and catches up, which the
/// controller cannot prevent, only see: 1 in 1000 late takes the demo's peak from 1.12 to
/// 2.13 um, over the bound. Drives that extrapolate a missing target, or a bus on which
/// no target is late, are what the bound needs.
#[test]
fn late_readings_are_coasted_over_and_late_targets_show_in_the_table() {
    let (job, cycle, plan) = common::program("demo-short-spur-z17-m5.toml", &[]);
    let run = |tpdo: f64, rpdo: f64| {
        let mut p = common::plant();
        p.simulation.tpdo_late_rate = tpdo;
        p.simulation.rpdo_late_rate = rpdo;
        let s = run_program(
            &common::machine(),
            &p,
            &cycle,
            &plan,
            &job,
            &SimOptions {
                grade: 4,
                ..SimOptions::default()
            },
            &mut |_| {},
        )
        .unwrap();
        report("demo", &format!("late TPDOs {tpdo}, RPDOs {rpdo}"), &s);
        assert!(s.completed, "late TPDOs {tpdo}, RPDOs {rpdo}: {:?}", s.fault);
        s
    };
    let on_time = run(0.0, 0.0);
    assert_eq!(on_time.late_frames, [0, 0]);
    let late_readings = run(0.01, 0.0);
    // Three drives over some 135 000 cycles at 1 %.
    assert!(
        late_readings.late_frames[0] > 3000,
        "{:?}",
        late_readings.late_frames
    );
    assert!(
        late_readings.max_sync_err_um <= late_readings.bound_um,
        "{} um above {} um",
        late_readings.max_sync_err_um,
        late_readings.bound_um
    );
    let (fpt, fp, _) = finished(&late_readings).0.shares();
    assert!(fpt <= 0.25 && fp <= 0.25, "{fpt} {fp}");
    let late_targets = run(0.0, 0.001);
    assert!(
        late_targets.late_frames[1] > 300,
        "{:?}",
        late_targets.late_frames
    );
    assert!(
        late_targets.max_sync_err_um > 1.5 * on_time.max_sync_err_um,
        "a stalled table must show: {} um against {} um on time",
        late_targets.max_sync_err_um,
        on_time.max_sync_err_um
    );
}
