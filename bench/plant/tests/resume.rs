//! "Continue" after a fault in the cut re-enters the interrupted pass where it stopped
//! (repositioning), not at its start: closed loop on the simulated machine, the gear
//! judged by the machine's truth (the blank's true error where each gap met the hob), as
//! the ISO 1328 report judges it.
#![allow(clippy::unwrap_used)]

mod common;
use common::{powered_up, repair_and_reset, run, run_cycle, short_spur};
use hob_control::Command;
use hob_control::events::EventKind;
use hob_control::fault::Axis;
use hob_control::program::CycleProgram;
use hob_control::setup_math::resume_y_mm;
use hob_plant::plant::Injection;
use hob_plant::sim::{RowState as State, TraceRow, summary_builder};
use hob_setup::job::Program;
use hob_setup::planner::Plan;

/// The thesis gear over its whole 40 mm face, shallow (one rough pass and a finishing
/// pass, 2 mm in all: `short_spur` with its face back) so that a pass takes about a minute.
fn shallow_spur() -> (Program, CycleProgram, Plan) {
    short_spur(&[("face_width_mm = 4.0", "face_width_mm = 40.0")])
}

/// What ISO 1328-1 would measure on the gear the last pass left, from the truth of
/// `rows` (single pitch, cumulative pitch, um), and the grade-5 single pitch tolerance.
fn last_pass_gear(plan: &Plan, rows: &[TraceRow], period_s: f64) -> (f64, f64, f64) {
    let mut b = summary_builder(plan, 5);
    for r in rows {
        b.add(r, period_s);
    }
    let (passes, tol) = b.passes();
    let g = passes
        .last()
        .unwrap()
        .predicted
        .clone()
        .expect("the last pass's gear");
    (g.single_pitch_um, g.cumulative_pitch_um, tol)
}

#[test]
fn continue_re_enters_the_cut_behind_where_it_stopped_and_the_gear_is_as_good() {
    let (job, cycle, plan) = shallow_spur();
    assert_eq!(cycle.passes().len(), 2, "a rough and a finishing pass");
    let pass = cycle.passes()[1];
    let sign = cycle.feed_sign;
    let length_mm = (pass.y_end_mm - pass.y_start_mm).abs();

    // The gear cut without a stop.
    let mut sim = powered_up(&job, &cycle, &plan);
    let period_s = sim.controller.params().period_s;
    let whole = run_cycle(&mut sim, false, 900.0);
    assert!(whole.events.iter().any(|e| e.kind == EventKind::CycleDone));
    let (whole_fpt, whole_fp, tol) = last_pass_gear(&plan, &whole.rows, period_s);

    // The same gear, the Y drive faulting 3/4 of the way through the finishing pass.
    let mut sim = powered_up(&job, &cycle, &plan);
    sim.command(Command::Start { single: false }).unwrap();
    let stop_at = pass.y_start_mm + sign * 0.75 * length_mm;
    let mut rows = run(&mut sim, 900.0, |r| {
        r.state == State::Cut && r.pass == 2 && sign * (r.y_cmd_mm - stop_at) >= 0.0
    })
    .rows;
    let stopped_y = rows.last().unwrap().y_cmd_mm;
    sim.inject(Injection::DriveFault(Axis::Y));
    rows.extend(run(&mut sim, 60.0, |r| r.state == State::Faulted).rows);
    let s = sim.controller.status();
    assert_eq!(s.continue_pass, 2);
    // The alarm will say what happened in the cut only (`hob_wire`'s reaction by situation).
    assert_eq!(s.fault_met, hob_control::State::Cut);
    let from_y = s.continue_from_y_mm.expect("a point to re-enter the cut");
    let expected = resume_y_mm(
        stopped_y,
        pass.y_start_mm,
        cycle.feed_per_table_rev_mm(&pass),
        sign,
        sim.controller.params().resume_overlap_mm,
    )
    .unwrap();
    // The fault is seen a cycle or two after the injection, Y a um further on.
    assert!(
        (from_y - expected).abs() < 0.01,
        "re-entry {from_y} mm, expected {expected} mm (stopped at {stopped_y} mm)"
    );

    repair_and_reset(&mut sim);
    sim.command(Command::Continue).unwrap();
    assert_eq!(
        sim.controller.status().continue_pass,
        0,
        "continue is no longer offered"
    );
    let rest = run(&mut sim, 900.0, |r| {
        matches!(r.state, State::Idle | State::Faulted)
    });
    assert!(
        rest.events.iter().any(|e| e.kind == EventKind::CycleDone),
        "{:?}",
        rest.states()
    );
    // The cut resumed where it re-entered, in pass 2; no row of the cut before it.
    let first_cut = rest.rows.iter().find(|r| r.state == State::Cut).unwrap();
    assert_eq!(first_cut.pass, 2);
    assert!(
        (first_cut.y_cmd_mm - from_y).abs() < 1e-6,
        "the cut resumed at {} mm, not at {from_y} mm",
        first_cut.y_cmd_mm
    );
    let cut_again_mm = (pass.y_end_mm - from_y).abs();
    println!(
        "pass 2 from {:.2} to {:.2} mm, stopped at {stopped_y:.2} mm, re-entered at \
         {from_y:.2} mm: {cut_again_mm:.2} mm cut again of {length_mm:.2}",
        pass.y_start_mm, pass.y_end_mm
    );
    assert!(cut_again_mm < 0.5 * length_mm);
    rows.extend(rest.rows);

    // The gear: no worse than the one cut without a stop, within a tenth of the
    // tolerance (the samples of the re-cut stretch are taken twice).
    let (fpt, fp, _) = last_pass_gear(&plan, &rows, period_s);
    println!(
        "gear: single pitch {fpt:.2} um (uninterrupted {whole_fpt:.2}), cumulative \
         {fp:.2} um (uninterrupted {whole_fp:.2}); grade-5 f_pt {tol:.2} um"
    );
    assert!(
        fpt <= whole_fpt + 0.1 * tol,
        "single pitch {fpt} um vs {whole_fpt} um"
    );
    assert!(
        fp <= whole_fp + 0.1 * tol,
        "cumulative pitch {fp} um vs {whole_fp} um"
    );
}
