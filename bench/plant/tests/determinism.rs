//! The determinism a replay depends on (issue 18, flight recorder): the control core is a
//! pure function of its state, the commands it takes and the inputs latched at each SYNC.
//! A copy of the controller taken in the cut, stepped again over the recorded inputs with
//! the recorded commands at the same cycles, gives the recorded outputs bit for bit; one
//! input changed by a single count gives different outputs (the comparison can fail).
#![allow(clippy::unwrap_used)]

mod common;

use hob_control::{Command, Controller, CycleInputs, CycleOutputs, State};

/// What a flight recorder keeps of one cycle.
#[derive(Debug, Clone, Copy)]
struct Record {
    command: Option<Command>,
    inputs: CycleInputs,
    outputs: CycleOutputs,
}

/// The outputs to the bit: every `f64` by its bits, through its exact `Debug` form
/// (shortest round-trip: equal text is equal bits, -0.0 and NaN included).
fn bits(o: &CycleOutputs) -> String {
    format!("{o:?}")
}

/// Steps `c` over the records' commands and inputs; the index of the first cycle whose
/// outputs differ from the record, if any.
fn replay(mut c: Controller, records: &[Record], change: impl Fn(usize, &mut CycleInputs)) -> Option<usize> {
    for (k, r) in records.iter().enumerate() {
        if let Some(cmd) = r.command {
            let _ = c.command(cmd);
        }
        let mut inputs = r.inputs;
        change(k, &mut inputs);
        let out = c.step(&inputs);
        while c.events().pop().is_some() {}
        if bits(&out) != bits(&r.outputs) {
            return Some(k);
        }
    }
    None
}

#[test]
fn a_copy_of_the_controller_replays_the_recorded_cycles_bit_for_bit() {
    let (job, cycle, plan) = common::short_spur(&[]);
    let mut sim = common::powered_up(&job, &cycle, &plan);
    sim.controller.command(Command::Start { single: false }).unwrap();
    for _ in 0..300_000 {
        sim.step();
        if sim.controller.status().state == State::Cut {
            break;
        }
    }
    assert_eq!(sim.controller.status().state, State::Cut);
    for _ in 0..500 {
        sim.step();
    }
    let snapshot = sim.controller.clone();
    // Five seconds of the cut with the operator's commands in it: feed override, feed
    // hold, resume, spindle override.
    let mut records = Vec::new();
    for k in 0..5000 {
        let command = match k {
            500 => Some(Command::FeedOverride { percent: 80.0 }),
            1500 => Some(Command::FeedHold),
            2500 => Some(Command::Resume),
            3500 => Some(Command::SpindleOverride { percent: 110.0 }),
            _ => None,
        };
        if let Some(c) = command {
            sim.controller.command(c).unwrap();
        }
        let mut seen = None;
        sim.step_with(&mut |c, i| {
            let o = c.step(i);
            seen = Some((*i, o));
            o
        });
        let (inputs, outputs) = seen.unwrap();
        records.push(Record {
            command,
            inputs,
            outputs,
        });
    }
    assert_eq!(
        sim.controller.status().state,
        State::Cut,
        "still cutting at the end"
    );
    // Replayed: every cycle's outputs to the bit, twice over.
    assert_eq!(replay(snapshot.clone(), &records, |_, _| {}), None);
    assert_eq!(replay(snapshot.clone(), &records, |_, _| {}), None);
    // One spindle count more at cycle 1000: the outputs part from there on.
    let parted = replay(snapshot.clone(), &records, |k, i| {
        if k == 1000 {
            i.spindle_counts = i.spindle_counts.wrapping_add(1);
        }
    });
    assert!(
        parted.is_some_and(|k| k >= 1000),
        "one count more changed nothing, or changed the past: {parted:?}"
    );
    // The spindle observer at half its bandwidth (a replay's "what if"): the table's
    // targets part.
    let mut slower = snapshot.clone();
    slower.set_observer_bandwidth_hz(slower.params().observer_bandwidth_hz / 2.0);
    let parted = replay(slower, &records, |_, _| {});
    assert!(parted.is_some(), "the observer's bandwidth changes nothing");
    // A command left out (the feed hold): the outputs part at once.
    let mut without_hold = records.clone();
    without_hold[1500].command = None;
    let parted = replay(snapshot, &without_hold, |_, _| {});
    assert!(parted.is_some_and(|k| (1500..1600).contains(&k)), "{parted:?}");
}
