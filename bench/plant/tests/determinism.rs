//! The determinism a replay depends on (issue 18, flight recorder): the control core is a
//! pure function of its state, the commands it takes and the inputs latched at each SYNC.
//! A copy of the controller taken in the cut, stepped again over the recorded inputs with
//! the recorded commands at the same cycles (`hob_control::flight`'s replay, as `hob
//! replay` runs it), gives the recorded outputs bit for bit; one input changed by a single
//! count gives different outputs (the comparison can fail). The replay with the machine
//! answering (`replay_answered`, the "what if" of `hob replay`) is the recorded run with
//! the recorded controller, and keeps a much slower observer cutting where the open-loop
//! replay sees its error grow.
#![allow(clippy::unwrap_used)]

mod common;

use hob_control::flight::{FlightRecord, Mail, Record, same_bits};
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
    // The machine answering a replay: each drive's lag found in the record; with the
    // recorded controller the answered replay is the recorded run, to the bit.
    // A target sent after SYNC k applies at SYNC k+1 and the drive is there 1 ms
    // (`control.drive_delay_us`) later: the position latched at SYNC k+2 shows it. X does
    // not move in this stretch of the cut.
    let lags = record.follow_lags();
    assert_eq!(lags, [Some(2), None, Some(2)]);
    let lags = lags.map(|l| l.unwrap_or(2));
    let mut answered_parted = None;
    record.replay_answered(record.start.clone(), lags, |k, _, i, o| {
        if answered_parted.is_none()
            && (!same_bits(o, &record.records[k].outputs) || *i != record.records[k].inputs)
        {
            answered_parted = Some(k);
        }
    });
    assert_eq!(answered_parted, None);
    // A what-if with the observer at a fifth of its bandwidth: open loop the controller
    // soon faults on the following error it sees (the recorded table did not follow its
    // new targets); answered, the table follows and the cut goes on, with the controller's
    // estimate of its sync error larger than recorded.
    let mut slow = record.start.clone();
    slow.set_observer_bandwidth_hz(slow.params().observer_bandwidth_hz / 5.0);
    let sync_max = |states: &[(State, f64)]| {
        states
            .iter()
            .filter(|(s, _)| *s == State::Cut)
            .map(|(_, e)| e.abs())
            .fold(0.0f64, f64::max)
    };
    let mut open = Vec::new();
    record.replay_each(slow.clone(), |_, c, _| {
        let st = c.status();
        open.push((st.state, st.sync_error_arcsec));
    });
    let mut answered = Vec::new();
    let mut recorded = Vec::new();
    record.replay_answered(slow, lags, |_, c, _, _| {
        let st = c.status();
        answered.push((st.state, st.sync_error_arcsec));
    });
    record.replay_each(record.start.clone(), |_, c, _| {
        let st = c.status();
        recorded.push((st.state, st.sync_error_arcsec));
    });
    let (open_max, answered_max, recorded_max) = (sync_max(&open), sync_max(&answered), sync_max(&recorded));
    assert!(
        answered.iter().all(|(s, _)| *s == State::Cut),
        "answered, the slower observer still cuts"
    );
    assert!(
        open_max > 4.0 * answered_max && answered_max < 2.0 * recorded_max && answered_max > 0.1,
        "open loop {open_max:.2}, answered {answered_max:.2}, recorded {recorded_max:.2} arcsec"
    );
    // A command left out (the feed hold): the outputs part at once.
    let mut without_hold = record.clone();
    without_hold.records[1500].mail = Mail::None;
    let k = parted(&without_hold);
    assert!(k.is_some_and(|k| (1500..1600).contains(&k)), "{k:?}");
}
