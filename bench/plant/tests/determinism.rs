//! The determinism a replay depends on (issue 18, flight recorder): the control core is a
//! pure function of its state, the commands it takes and the inputs latched at each SYNC.
//! A copy of the controller taken in the cut, stepped again over the recorded inputs with
//! the recorded commands at the same cycles (`hob_control::flight`'s replay, as `hob
//! replay` runs it), gives the recorded outputs bit for bit; one input changed by a single
//! count gives different outputs (the comparison can fail).
#![allow(clippy::unwrap_used)]

mod common;

use hob_control::flight::{FlightRecord, Mail, Record};
use hob_control::{Command, State};

/// The index of the first record whose outputs the replay of `r` does not reproduce.
fn parted(r: &FlightRecord) -> Option<usize> {
    r.replay(r.start.clone()).first_difference.map(|(k, ..)| k)
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
            mail: command.map_or(Mail::None, Mail::Command),
            inputs,
            outputs,
        });
    }
    let record = FlightRecord {
        reason: "test".into(),
        written_utc: String::new(),
        start: snapshot,
        first_cycle: 0,
        records,
        programs: Vec::new(),
    };
    assert_eq!(
        sim.controller.status().state,
        State::Cut,
        "still cutting at the end"
    );
    // Replayed: every cycle's outputs to the bit, twice over.
    assert_eq!(parted(&record), None);
    assert_eq!(parted(&record), None);
    // One spindle count more at cycle 1000: the outputs part from there on.
    let mut one_more = record.clone();
    let i = &mut one_more.records[1000].inputs;
    i.spindle_counts = i.spindle_counts.wrapping_add(1);
    let k = parted(&one_more);
    assert!(
        k.is_some_and(|k| k >= 1000),
        "one count more changed nothing, or changed the past: {k:?}"
    );
    // The spindle observer at half its bandwidth (a replay's "what if"): the table's
    // targets part.
    let mut slower = record.start.clone();
    slower.set_observer_bandwidth_hz(slower.params().observer_bandwidth_hz / 2.0);
    assert!(
        record.replay(slower).first_difference.is_some(),
        "the observer's bandwidth changes nothing"
    );
    // A command left out (the feed hold): the outputs part at once.
    let mut without_hold = record.clone();
    without_hold.records[1500].mail = Mail::None;
    let k = parted(&without_hold);
    assert!(k.is_some_and(|k| (1500..1600).contains(&k)), "{k:?}");
}
