//! The synchronisation error in the cut, measured on the simulated machine (default
//! plant): the whole program, with and without cross-coupling, with the predictor
//! replaced by the last measured angle. Bound: a quarter of the ISO 1328-1 grade-5
//! single pitch tolerance of the gear at its pitch circle.
#![allow(clippy::unwrap_used)]

mod common;

use hob_control::SpindleAngleSource;
use hob_plant::sim::{SimOptions, Summary, run_program};

fn simulate(name: &str, options: SimOptions) -> Summary {
    let (job, cycle, plan) = common::program(name, &[]);
    let s = run_program(
        &common::machine(),
        &common::plant(),
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

fn check(name: &str) {
    let full = simulate(name, SimOptions::default());
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
        ..SimOptions::default()
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
    assert!(
        no_ccc.max_sync_err_um > full.max_sync_err_um,
        "cross-coupling must help"
    );
    assert!(
        no_predictor.max_sync_err_um > 10.0 * full.max_sync_err_um,
        "prediction must help"
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
