//! Determinism of the control core: the same inputs through `Controller::step` give
//! bit-identical outputs. Two closed-loop runs of the same program against the simulated
//! machine record every cycle's `CycleInputs` and `CycleOutputs` and must agree bit for
//! bit (floats compared with `f64::to_bits`); the inputs of the first run, replayed into
//! a fresh controller in open loop, must reproduce its outputs bit for bit, every cycle.
#![allow(clippy::unwrap_used)]

mod common;

use hob_control::events::EventKind;
use hob_control::program::CycleProgram;
use hob_control::{Command, ControlParams, Controller, CycleInputs, CycleOutputs};
use hob_plant::sim::RowState as State;
use hob_plant::sim::Simulation;

/// Every cycle of one run, and where the commands were given.
struct Recording {
    inputs: Vec<CycleInputs>,
    outputs: Vec<CycleOutputs>,
    /// Cycles stepped before the program was loaded and started.
    started_at: usize,
    /// Cycles stepped before referencing was asked for (power-up asks once idle).
    homed_at: usize,
    cycle: CycleProgram,
    params: ControlParams,
}

/// The short spur job, whole, in the closed loop: power-up, load, start, until the cycle
/// is done (or faulted).
fn record() -> Recording {
    let (job, cycle, plan) = common::short_spur(&[]);
    let machine = common::machine();
    let mut sim = Simulation::for_program(&machine, &common::plant(), &cycle, &plan, &job);
    let mut inputs = Vec::new();
    let mut outputs = Vec::new();
    let mut step = |c: &mut Controller, i: &CycleInputs| {
        let o = c.step(i);
        inputs.push(*i);
        outputs.push(o);
        o
    };
    let mut started_at = 0;
    let mut homed_at = None;
    assert!(
        sim.power_up_with(
            120.0,
            &mut |row| {
                started_at += 1;
                // Power-up asks for referencing after the cycle whose row first says idle.
                if homed_at.is_none() && row.state == State::Idle {
                    homed_at = Some(started_at);
                }
            },
            &mut step
        ),
        "power-up"
    );
    let homed_at = homed_at.expect("idle before referencing");
    sim.controller.load(cycle).unwrap();
    sim.command(Command::Start { single: false }).unwrap();
    let done = sim.run_until_with(
        300.0,
        &mut |_| {},
        &mut |r, events| r.state == State::Faulted || events.iter().any(|e| e.kind == EventKind::CycleDone),
        &mut step,
    );
    assert!(done, "the cycle ends within 300 s");
    assert!(inputs.len() > started_at && outputs.len() == inputs.len());
    assert!(
        sim.events.iter().any(|e| e.kind == EventKind::CycleDone),
        "the whole cycle runs: {:?}",
        sim.controller.status().fault
    );
    Recording {
        inputs,
        outputs,
        started_at,
        homed_at,
        cycle,
        params: ControlParams::from_machine(&machine),
    }
}

/// Every field of the outputs, floats as their bits.
fn output_bits(o: &CycleOutputs) -> [u64; 9] {
    [
        o.table_target_counts as u32 as u64,
        o.x_target_counts as u32 as u64,
        o.y_target_counts as u32 as u64,
        o.table_velocity_counts_s.to_bits(),
        o.x_velocity_counts_s.to_bits(),
        o.y_velocity_counts_s.to_bits(),
        u64::from(o.drives_enabled),
        u64::from(o.digital_outputs),
        o.spindle_analog_v.to_bits(),
    ]
}

/// The first cycle whose outputs differ, with both.
fn first_divergence(a: &[CycleOutputs], b: &[CycleOutputs]) -> Option<(usize, String)> {
    if let Some(k) = (0..a.len().min(b.len())).find(|&k| output_bits(&a[k]) != output_bits(&b[k])) {
        return Some((k, format!("cycle {k}: {:?}\n  vs {:?}", a[k], b[k])));
    }
    (a.len() != b.len()).then(|| {
        let k = a.len().min(b.len());
        (
            k,
            format!("one run ends at cycle {k}: {} vs {} cycles", a.len(), b.len()),
        )
    })
}

/// The recorded inputs into a fresh controller, in open loop, with the same commands
/// before the same cycle; returns its outputs.
fn replay(r: &Recording, inputs: &[CycleInputs]) -> Vec<CycleOutputs> {
    let mut c = Controller::new(r.params);
    let mut out = Vec::with_capacity(inputs.len());
    for (k, i) in inputs.iter().enumerate() {
        if k == r.homed_at {
            c.command(Command::Home {
                axes: hob_control::HomeAxes::Both,
            })
            .unwrap();
        }
        if k == r.started_at {
            c.load(r.cycle).unwrap();
            c.command(Command::Start { single: false }).unwrap();
        }
        out.push(c.step(i));
        while c.events().pop().is_some() {}
    }
    out
}

#[test]
fn the_same_inputs_give_bit_identical_outputs_and_a_recorded_run_replays() {
    let one = record();
    let two = record();
    assert!(one.outputs.len() > 10_000, "{} cycles", one.outputs.len());
    assert_eq!(one.started_at, two.started_at, "power-up took as long");
    // The closed loop twice: the same inputs, cycle for cycle, and the same outputs.
    assert_eq!(one.inputs.len(), two.inputs.len(), "cycles of the two runs");
    if let Some(k) = (0..one.inputs.len()).find(|&k| one.inputs[k] != two.inputs[k]) {
        panic!(
            "inputs diverge at cycle {k}: {:?}\n  vs {:?}",
            one.inputs[k], two.inputs[k]
        );
    }
    if let Some((_, what)) = first_divergence(&one.outputs, &two.outputs) {
        panic!("closed loop, run 1 vs run 2: {what}");
    }
    // Run 1's inputs replayed in open loop reproduce run 1's outputs.
    let replayed = replay(&one, &one.inputs);
    if let Some((_, what)) = first_divergence(&one.outputs, &replayed) {
        panic!("replay vs run 1: {what}");
    }
    // The comparison can fail: one spindle count more (the smallest change the input
    // can carry) at a cycle in the cut shows up at that very cycle.
    let k = one.started_at + (one.inputs.len() - one.started_at) / 2;
    let mut perturbed = one.inputs.clone();
    perturbed[k].spindle_counts = perturbed[k].spindle_counts.wrapping_add(1);
    let diverged = first_divergence(&one.outputs, &replay(&one, &perturbed));
    assert_eq!(
        diverged.as_ref().map(|d| d.0),
        Some(k),
        "a perturbed input at cycle {k}: {diverged:?}"
    );
    println!(
        "{} cycles bit-identical twice and replayed; one count more at cycle {k}: {}",
        one.outputs.len(),
        diverged.unwrap().1
    );
}
