//! The sequencer against the simulated machine: every cycle and mode, feed hold, stop,
//! the tooth phase kept across engagements, and every fault path (retract X first with
//! the gearbox engaged, then stop, then drop the PC-OK relay).
#![allow(clippy::unwrap_used)]

mod common;

use common::{Run, in_order, powered_up, run, run_cycle, short_spur};
use hob_control::Command;
use hob_control::egb::Coupling;
use hob_control::events::EventKind;
use hob_control::fault::{Axis, End, Fault, Refusal};
use hob_plant::plant::Injection;
use hob_plant::sim::RowState as State;

use State::*;

/// Starts the automatic cycle and runs until the cut has gone on for `cycles` cycles.
fn start_and_cut(sim: &mut hob_plant::sim::Simulation, cycles: u32) {
    sim.command(Command::Start { single: false }).unwrap();
    let mut cut_seen = 0;
    run(sim, 300.0, |r| {
        cut_seen += u32::from(r.state == Cut);
        cut_seen > cycles
    });
    assert_eq!(sim.controller.status().state, Cut);
}

fn cycle_done(r: &Run) -> bool {
    r.events.iter().any(|e| e.kind == EventKind::CycleDone)
}

#[test]
fn radial_axial_automatic_runs_every_step_in_order() {
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = powered_up(&job, &cycle, &plan);
    let r = run_cycle(&mut sim, false, 300.0);
    let states = r.states();
    assert!(cycle_done(&r), "{states:?}");
    let pass = [ToStart, SpindleUp, Engage, Infeed, Cut, Retract];
    let mut expected = vec![ToSafe];
    expected.extend(pass);
    expected.extend(pass);
    expected.extend([Home, Disengage, SpindleDown, Idle]);
    assert!(in_order(&states, &expected), "{states:?}");
    assert!(!states.contains(&Clamp), "crowning: X is never clamped");
    // Both passes cut, finishing deeper than roughing.
    let cut_x: Vec<f64> = r
        .rows
        .iter()
        .filter(|x| x.state == Cut)
        .map(|x| x.x_cmd_mm)
        .collect();
    assert!(cut_x.iter().any(|x| (x - plan.passes[1].x_mm).abs() < 0.03));
    // Back at the start position at the end.
    let last = r.rows.last().unwrap();
    assert!((last.y_cmd_mm - plan.passes[0].y_start_mm).abs() < 1e-9);
    assert!((last.x_cmd_mm - plan.x_safe_mm).abs() < 1e-9);
}

#[test]
fn without_a_shape_x_is_clamped_for_the_cut() {
    let (job, cycle, plan) = short_spur(&[("crowning = { height_mm = 0.02 }\n", "")]);
    let mut sim = powered_up(&job, &cycle, &plan);
    let r = run_cycle(&mut sim, false, 300.0);
    assert!(cycle_done(&r));
    assert!(
        in_order(&r.states(), &[Infeed, Clamp, Cut, Unclamp, Retract]),
        "{:?}",
        r.states()
    );
}

#[test]
fn single_mode_cuts_one_pass_at_its_depth() {
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = powered_up(&job, &cycle, &plan);
    let r = run_cycle(&mut sim, true, 300.0);
    assert!(cycle_done(&r));
    let passes: Vec<u32> = r.rows.iter().filter(|x| x.state == Cut).map(|x| x.pass).collect();
    assert!(passes.iter().all(|p| *p == 1));
    let single_x = cycle.single().unwrap().x_mm;
    let cut_x = r
        .rows
        .iter()
        .filter(|x| x.state == Cut)
        .map(|x| x.x_cmd_mm)
        .fold(f64::MAX, f64::min);
    assert!(
        (cut_x - (single_x - 0.02)).abs() < 1e-3,
        "crowned ends at single depth: {cut_x}"
    );
}

#[test]
fn plunge_cycle_feeds_in_and_turns_the_table_once_before_the_feed() {
    let (job, cycle, plan) = common::program(
        "spline-z12-m2-plunge.toml",
        &[
            ("face_width_mm = 35.0", "face_width_mm = 4.0"),
            ("feed_mm_per_rev = 1.5", "feed_mm_per_rev = 6.0"),
            ("feed_mm_per_rev = 0.8", "feed_mm_per_rev = 6.0"),
            ("plunge_feed_mm_min = 20.0", "plunge_feed_mm_min = 200.0"),
        ],
    );
    let mut sim = powered_up(&job, &cycle, &plan);
    let r = run_cycle(&mut sim, false, 600.0);
    assert!(cycle_done(&r), "{:?}", r.states());
    assert!(in_order(
        &r.states(),
        &[Engage, Infeed, Plunge, ExtraRev, Clamp, Cut, Unclamp, Retract]
    ));
    // One table revolution at depth before Y moves.
    let rev: Vec<_> = r
        .rows
        .iter()
        .filter(|x| x.state == ExtraRev && x.pass == 1)
        .collect();
    let turned = (rev.last().unwrap().table_deg - rev[0].table_deg).abs();
    assert!((359.0..=362.0).contains(&turned), "table turned {turned} deg");
    assert!(
        (rev.last().unwrap().y_cmd_mm - rev[0].y_cmd_mm).abs() < 1e-9,
        "Y waits"
    );
}

#[test]
fn tooth_by_tooth_indexes_every_tooth() {
    let (job, cycle, plan) = common::program(
        "tooth-by-tooth-z24-m8.toml",
        &[
            ("teeth = 24", "teeth = 6"),
            // A smaller gear than the cutter's profile was made for: not judged.
            ("grade = 7 ", "# grade = 7 "),
            ("face_width_mm = 60.0", "face_width_mm = 3.0"),
            ("outside_diameter_mm = 208.0", "outside_diameter_mm = 64.0"),
            ("total_depth_mm = 18.0", "total_depth_mm = 1.0"),
            ("finish_allowance_mm = 0.5", "finish_allowance_mm = 0.2"),
            ("rough_passes = 2", "rough_passes = 1"),
            ("feed_mm_per_rev = 1.0", "feed_mm_per_rev = 5.0"),
            ("feed_mm_per_rev = 0.5", "feed_mm_per_rev = 5.0"),
        ],
    );
    let mut sim = powered_up(&job, &cycle, &plan);
    let table0 = sim.plant.table_deg();
    let r = run_cycle(&mut sim, false, 900.0);
    assert!(cycle_done(&r), "{:?}", r.states());
    let indexes = r.states().iter().filter(|s| **s == Index).count();
    assert_eq!(indexes, 2 * 6, "one index per tooth per pass");
    let cuts = r.states().iter().filter(|s| **s == Cut).count();
    assert_eq!(cuts, 2 * 6);
    // Two full turns of indexing bring the table back to its start, modulo 360.
    let turned = sim.plant.table_deg() - table0;
    assert!((turned - 720.0).abs() < 0.01, "{turned}");
}

#[test]
fn feed_hold_stops_y_in_the_cut_with_the_gearbox_engaged_and_resume_finishes() {
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = powered_up(&job, &cycle, &plan);
    start_and_cut(&mut sim, 2000);
    sim.command(Command::FeedHold).unwrap();
    let held = run(&mut sim, 3.0, |_| false);
    let tail = &held.rows[held.rows.len() - 1000..];
    assert!(tail.iter().all(|r| r.hold && r.state == Cut));
    let y0 = tail[0].y_cmd_mm;
    assert!(
        tail.iter().all(|r| r.y_cmd_mm == y0),
        "Y stands still in feed hold"
    );
    assert!(
        tail.iter().all(|r| r.sync_err_arcsec.is_some()),
        "gearbox stays engaged"
    );
    let t0 = tail[0].table_deg;
    assert!(
        (tail.last().unwrap().table_deg - t0).abs() > 1.0,
        "the table keeps turning"
    );
    assert_eq!(tail.last().unwrap().state_word(), "hold");
    sim.command(Command::Resume).unwrap();
    let rest = run(&mut sim, 300.0, |r| r.state == Idle);
    assert!(cycle_done(&rest));
}

#[test]
fn stop_in_the_cut_retracts_then_stops_and_a_restart_finds_the_same_tooth_gap() {
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = powered_up(&job, &cycle, &plan);
    start_and_cut(&mut sim, 3000);
    let recorded = sim.controller.gearbox().recorded_phase_deg().unwrap();
    sim.command(Command::Stop).unwrap();
    let stopped = run(&mut sim, 60.0, |r| r.state == Idle);
    assert!(
        in_order(&stopped.states(), &[Retract, Disengage, SpindleDown, Idle]),
        "{:?}",
        stopped.states()
    );
    let retracted = stopped.first(Disengage).unwrap();
    assert!(
        (stopped.rows[retracted].x_cmd_mm - plan.x_safe_mm).abs() < 1e-9,
        "out of the gear first"
    );
    assert!(!cycle_done(&stopped));
    // The table is turned by hand meanwhile; the restart must still find the same gap.
    sim.command(Command::Jog {
        axis: Axis::B,
        distance: 5.3,
    })
    .unwrap();
    run(&mut sim, 30.0, |r| r.state == Idle);
    sim.command(Command::Start { single: false }).unwrap();
    let again = run(&mut sim, 300.0, |r| r.state == Infeed);
    let g = sim.controller.gearbox();
    assert_eq!(g.recorded_phase_deg(), Some(recorded));
    let target = g.phase_target_deg().unwrap();
    let pitch = 360.0 / 17.0;
    let gaps = (target - recorded) / pitch;
    assert!(
        (gaps - gaps.round()).abs() < 1e-9,
        "same tooth gap: {gaps} pitches"
    );
    assert!(again.rows.last().unwrap().sync_err_arcsec.unwrap().abs() < 20.0);
}

#[test]
fn single_then_automatic_on_the_same_blank_keeps_the_phase_and_a_new_blank_clears_it() {
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = powered_up(&job, &cycle, &plan);
    assert!(cycle_done(&run_cycle(&mut sim, true, 300.0)));
    let recorded = sim.controller.gearbox().recorded_phase_deg().unwrap();
    assert!(cycle_done(&run_cycle(&mut sim, false, 300.0)));
    assert_eq!(sim.controller.gearbox().recorded_phase_deg(), Some(recorded));
    sim.command(Command::NewBlank).unwrap();
    assert_eq!(sim.controller.gearbox().recorded_phase_deg(), None);
}

#[test]
fn refused_commands_change_nothing() {
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = powered_up(&job, &cycle, &plan);
    assert_eq!(sim.command(Command::Resume), Err(Refusal::NothingToDo));
    assert_eq!(sim.command(Command::Reset), Err(Refusal::NothingToDo));
    assert_eq!(
        sim.command(Command::Jog {
            axis: Axis::X,
            distance: 1e4
        }),
        Err(Refusal::OutsideSoftLimits)
    );
    assert_eq!(
        sim.command(Command::SpindleOn { rpm: 500.0 }),
        Err(Refusal::BadValue)
    );
    assert_eq!(
        sim.command(Command::Jog {
            axis: Axis::Y,
            distance: f64::NAN
        }),
        Err(Refusal::BadValue)
    );
    assert_eq!(sim.controller.status().state, Idle);
    sim.command(Command::Start { single: false }).unwrap();
    run(&mut sim, 300.0, |r| r.state == Cut);
    assert_eq!(
        sim.command(Command::Jog {
            axis: Axis::X,
            distance: 1.0
        }),
        Err(Refusal::CycleRunning)
    );
    assert_eq!(
        sim.command(Command::Start { single: false }),
        Err(Refusal::CycleRunning)
    );
    assert_eq!(sim.command(Command::NewBlank), Err(Refusal::CycleRunning));
    assert_eq!(sim.controller.load(cycle), Err(Refusal::CycleRunning));
    assert_eq!(sim.controller.status().state, Cut);
    sim.step();
    let refused = sim
        .events
        .iter()
        .filter(|e| matches!(e.kind, EventKind::Refused { .. }))
        .count();
    assert_eq!(refused, 8, "every refusal is an event");
}

#[test]
fn start_without_a_program_is_refused() {
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = hob_plant::sim::Simulation::new(
        &common::machine(),
        &common::plant(),
        hob_plant::sim::start_for(&cycle),
        job.tool.gashes as u32,
    );
    let _ = plan;
    assert!(sim.power_up(120.0, &mut |_| {}));
    assert_eq!(
        sim.command(Command::Start { single: false }),
        Err(Refusal::NoProgram)
    );
}

/// Injects `fault` once the cut has run for a while; returns the rest of the run.
fn fault_in_cut(injection: Injection) -> (Run, f64) {
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = powered_up(&job, &cycle, &plan);
    start_and_cut(&mut sim, 3000);
    sim.inject(injection);
    let r = run(&mut sim, 60.0, |r| r.state == Faulted);
    (r, plan.x_safe_mm)
}

/// Whether `got` is `expected`: the same kind on the same axis (and end); a measured
/// value in the fault (following error, sync error, speed, position) is not compared.
fn same_fault(got: &Fault, expected: &Fault) -> bool {
    match (got, expected) {
        (Fault::FollowingError { axis: a, .. }, Fault::FollowingError { axis: b, .. })
        | (Fault::SoftLimit { axis: a, .. }, Fault::SoftLimit { axis: b, .. }) => a == b,
        (Fault::SyncLost { .. }, Fault::SyncLost { .. })
        | (Fault::SpindleSpeed { .. }, Fault::SpindleSpeed { .. }) => true,
        _ => got == expected,
    }
}

/// The first fault raised in `r` is `expected` (kind and axis).
fn assert_first_fault(r: &Run, expected: Fault) {
    let faults = r.faults();
    assert!(
        faults.first().is_some_and(|f| same_fault(f, &expected)),
        "expected {expected:?} first, raised {faults:?}"
    );
}

/// The fault reaction in the cut: X retracts while the gearbox is still synchronised,
/// then the gearbox disengages and the spindle stops, then PC-OK drops, drives off.
fn assert_retract_first(r: &Run, x_safe_mm: f64, expected: Fault) {
    let states = r.states();
    assert!(
        in_order(&states, &[FaultRetract, FaultStop, Faulted]),
        "{states:?}"
    );
    assert_first_fault(r, expected);
    let stop = r.first(FaultStop).unwrap();
    assert!(
        (r.rows[stop].x_cmd_mm - x_safe_mm).abs() < 1e-9,
        "X out before the stop"
    );
    // X really left the work: the slide's true position, not only its command.
    assert_x_out(r, stop, x_safe_mm);
    let retract: Vec<_> = r.rows.iter().filter(|x| x.state == FaultRetract).collect();
    // The gearbox engaged while X retracts, by its true error: the table kept following
    // the spindle within the synchronism window the cut itself needs.
    let worst = retract
        .iter()
        .map(|x| x.sync_err_arcsec.map_or(f64::INFINITY, f64::abs))
        .fold(0.0, f64::max);
    let window = common::machine().gearbox.fine_window_arcsec;
    println!("{expected:?}: worst true sync error while X retracts {worst:.2} arcsec");
    assert!(
        worst <= window,
        "gearbox not kept while X retracts: {worst} arcsec (window {window})"
    );
    let y0 = retract[0].y_cmd_mm;
    assert!(
        retract.iter().all(|x| (x.y_cmd_mm - y0).abs() < 0.01),
        "feed stopped"
    );
}

/// At row `stop` the slide stands at `x_safe_mm` (true position, within 0.05 mm), after a
/// retract of the whole way from where it cut.
fn assert_x_out(r: &Run, stop: usize, x_safe_mm: f64) {
    let x = r.rows[stop].x_mm;
    let from = r
        .rows
        .iter()
        .find(|x| x.state == FaultRetract)
        .map_or(x, |row| row.x_mm);
    println!("X retracted {from:.3} -> {x:.3} mm (safe {x_safe_mm:.3} mm)");
    assert!(
        (x - x_safe_mm).abs() < 0.05,
        "X stands at {x} mm at the stop, not at the safe {x_safe_mm} mm"
    );
    assert!(
        (x - from).abs() > 1.0,
        "X moved only {} mm in the retract",
        (x - from).abs()
    );
}

fn assert_stopped_safely(sim_rows: &Run) {
    let last = sim_rows.rows.last().unwrap();
    assert_eq!(last.state, Faulted);
}

#[test]
fn safety_chain_open_in_the_cut_retracts_first() {
    let (r, x_safe) = fault_in_cut(Injection::OpenSafetyChain);
    assert_retract_first(&r, x_safe, Fault::SafetyChainOpen);
    assert_stopped_safely(&r);
}

#[test]
fn hardware_limit_in_the_cut_retracts_first() {
    let (r, x_safe) = fault_in_cut(Injection::HardwareLimit(Axis::Y, End::Min));
    assert_retract_first(
        &r,
        x_safe,
        Fault::HardwareLimit {
            axis: Axis::Y,
            end: End::Min,
        },
    );
}

#[test]
fn y_following_error_in_the_cut_retracts_first() {
    let (r, x_safe) = fault_in_cut(Injection::Obstruct(Axis::Y));
    assert_retract_first(
        &r,
        x_safe,
        Fault::FollowingError {
            axis: Axis::Y,
            error: 0.0,
        },
    );
    // The error it reports is Y's, beyond Y's limit.
    let limit = common::machine().y.max_following_error_mm;
    let Some(Fault::FollowingError { error, .. }) = r.faults().first().copied() else {
        unreachable!("checked above")
    };
    assert!(error.abs() > limit, "{error} mm within the {limit} mm limit");
}

#[test]
fn y_drive_fault_in_the_cut_retracts_first() {
    let (r, x_safe) = fault_in_cut(Injection::DriveFault(Axis::Y));
    assert_retract_first(&r, x_safe, Fault::DriveFault { axis: Axis::Y });
}

#[test]
fn vfd_fault_in_the_cut_retracts_while_the_table_follows_the_coasting_spindle() {
    let (r, x_safe) = fault_in_cut(Injection::VfdFault);
    assert_retract_first(&r, x_safe, Fault::VfdFault);
}

#[test]
fn x_drive_fault_cannot_retract_and_stops_at_once() {
    let (r, _) = fault_in_cut(Injection::DriveFault(Axis::X));
    assert_first_fault(&r, Fault::DriveFault { axis: Axis::X });
    let states = r.states();
    assert!(!states.contains(&FaultRetract), "{states:?}");
    assert!(in_order(&states, &[FaultStop, Faulted]), "{states:?}");
}

#[test]
fn table_drive_fault_stops_the_spindle_and_retracts() {
    let (r, x_safe) = fault_in_cut(Injection::DriveFault(Axis::B));
    assert_first_fault(&r, Fault::DriveFault { axis: Axis::B });
    let states = r.states();
    assert!(
        in_order(&states, &[FaultRetract, FaultStop, Faulted]),
        "{states:?}"
    );
    let stop = r.first(FaultStop).unwrap();
    assert!((r.rows[stop].x_cmd_mm - x_safe).abs() < 1e-9);
    assert_x_out(&r, stop, x_safe);
}

#[test]
fn after_the_fault_reaction_pc_ok_drops_and_the_drives_are_off_until_reset() {
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = powered_up(&job, &cycle, &plan);
    sim.command(Command::Start { single: false }).unwrap();
    run(&mut sim, 300.0, |r| r.state == Cut);
    sim.inject(Injection::DriveFault(Axis::Y));
    let faulted = run(&mut sim, 60.0, |r| r.state == Faulted);
    assert_first_fault(&faulted, Fault::DriveFault { axis: Axis::Y });
    run(&mut sim, 1.0, |_| false);
    let s = sim.controller.status();
    assert_eq!(s.fault, Some(Fault::DriveFault { axis: Axis::Y }));
    assert!(!s.outputs.pc_ok_relay && s.outputs.fault_lamp);
    assert!(!s.outputs.spindle_run_forward && !s.outputs.spindle_run_reverse && !s.outputs.coolant_pump);
    assert!(!sim.plant.safety_chain_closed(), "PC-OK dropped opens the chain");
    assert_eq!(sim.controller.gearbox().coupling(), Coupling::Disengaged);
    assert_eq!(
        sim.command(Command::Start { single: false }),
        Err(Refusal::Faulted)
    );
    // The drive's fault is cleared; reset brings the machine back.
    sim.plant.y.fault = false;
    sim.command(Command::Reset).unwrap();
    let back = run(&mut sim, 30.0, |r| r.state == Idle);
    let faults: Vec<_> = back
        .events
        .iter()
        .filter(|e| matches!(e.kind, EventKind::Fault(_)))
        .collect();
    assert!(faults.is_empty(), "{faults:?}");
    assert_eq!(back.rows.last().unwrap().state, Idle);
}

#[test]
fn lube_pressure_never_coming_is_a_fault_at_power_up() {
    let (job, cycle, _) = short_spur(&[]);
    let mut sim = hob_plant::sim::Simulation::new(
        &common::machine(),
        &common::plant(),
        hob_plant::sim::start_for(&cycle),
        job.tool.gashes as u32,
    );
    sim.inject(Injection::NoLubePressure);
    let r = run(&mut sim, 30.0, |r| r.state == Faulted);
    assert_eq!(r.rows.last().unwrap().state, Faulted);
    assert!(
        r.events
            .iter()
            .any(|e| e.kind == EventKind::Fault(Fault::LubeTimeout))
    );
    assert!(
        (r.rows.last().unwrap().t_s - 10.0).abs() < 0.1,
        "after the 10 s pressure timeout"
    );
}

#[test]
fn lube_runs_again_after_5_m_of_travel() {
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = powered_up(&job, &cycle, &plan);
    assert_eq!(sim.controller.lube_cycles(), 1);
    // Referenced, Y stands at its home near the top: down and up again.
    for _ in 0..14 {
        sim.command(Command::Jog {
            axis: Axis::Y,
            distance: -200.0,
        })
        .unwrap();
        run(&mut sim, 30.0, |r| r.state == Idle);
        sim.command(Command::Jog {
            axis: Axis::Y,
            distance: 200.0,
        })
        .unwrap();
        run(&mut sim, 30.0, |r| r.state == Idle);
    }
    run(&mut sim, 10.0, |_| false);
    assert_eq!(sim.controller.lube_cycles(), 2, "5.6 m of Y");
}

#[test]
fn leaving_the_coarse_window_in_the_cut_is_a_fault_with_retract_first() {
    // Without prediction the table lags the spindle by ~2 ms: ~300 arcsec at 119 rpm,
    // beyond the 200 arcsec coarse window once the cross-coupling's bound is used up.
    // The predictor is switched off in the cut: switched off from the start, the error
    // leaves the window while engaging, before the cut.
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = powered_up(&job, &cycle, &plan);
    start_and_cut(&mut sim, 1000);
    sim.controller
        .set_angle_source(hob_control::SpindleAngleSource::LastMeasured);
    let r = run(&mut sim, 60.0, |r| r.state == Faulted);
    let faults = r.faults();
    let coarse = common::machine().gearbox.coarse_window_arcsec;
    assert!(
        matches!(faults.first(), Some(Fault::SyncLost { error_arcsec }) if error_arcsec.abs() > coarse),
        "sync lost beyond {coarse} arcsec first: {faults:?}"
    );
    assert_eq!(r.rows.last().unwrap().state, Faulted);
    // The fault comes in the cut: the retract-first reaction.
    let states = r.states();
    assert_eq!(states.first(), Some(&Cut), "{states:?}");
    assert!(
        in_order(&states, &[Cut, FaultRetract, FaultStop, Faulted]),
        "{states:?}"
    );
    // The table no longer follows (README, "What a fault does"): the gearbox is out at
    // once, and X still pulls out before the stop.
    assert!(
        r.rows
            .iter()
            .filter(|x| x.state == FaultRetract)
            .all(|x| x.sync_err_arcsec.is_none()),
        "gearbox out while X retracts"
    );
    let stop = r.first(FaultStop).unwrap();
    assert!(
        (r.rows[stop].x_cmd_mm - plan.x_safe_mm).abs() < 1e-9,
        "X out before the stop: {}",
        r.rows[stop].x_cmd_mm
    );
}

#[test]
fn coolant_runs_only_while_cutting() {
    let (job, cycle, plan) = short_spur(&[]);
    let mut sim = powered_up(&job, &cycle, &plan);
    sim.command(Command::Start { single: false }).unwrap();
    let (mut cut_cycles, mut coolant_in_cut, mut coolant_elsewhere) = (0, true, false);
    for _ in 0..300_000 {
        let row = sim.step();
        let on = sim.controller.status().outputs.coolant_pump;
        match row.state {
            Cut => {
                cut_cycles += 1;
                coolant_in_cut &= on;
            }
            ToSafe | ToStart | SpindleUp | Engage | Home | Disengage | SpindleDown => coolant_elsewhere |= on,
            _ => {}
        }
        if row.state == Idle {
            break;
        }
    }
    assert!(cut_cycles > 1000);
    assert!(coolant_in_cut, "coolant on in every cut cycle");
    assert!(!coolant_elsewhere, "coolant off out of the cut");
    assert!(!sim.controller.status().outputs.coolant_pump);
}
