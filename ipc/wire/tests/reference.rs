//! Every code of the wire as it is today, written out by hand: the reference a change of
//! the vocabulary is checked against. A code is never renumbered and a word never changes
//! meaning; a new value is added at the end (and here). The documents that state how many
//! codes a table has are checked against the tables too.
#![allow(clippy::unwrap_used)]

use hob_wire::codec::{self, Axis, Coupling, End, Fault, HomingFailure, Refusal, State};
use hob_wire::{bus_event, bus_kind, command, direction, event_kind, send_error};

const STATES: &[(u32, &str)] = &[
    (0, "init"),
    (1, "idle"),
    (2, "jog"),
    (3, "safe"),
    (4, "start"),
    (5, "spin"),
    (6, "sync"),
    (7, "infeed"),
    (8, "plunge"),
    (9, "rev"),
    (10, "clamp"),
    (11, "cut"),
    (12, "unclamp"),
    (13, "retract"),
    (14, "return"),
    (15, "index"),
    (16, "home"),
    (17, "disengage"),
    (18, "spindown"),
    (19, "f_retract"),
    (20, "f_stop"),
    (21, "fault"),
    (22, "referencing"),
];

const REFUSALS: &[(u32, &str)] = &[
    (1, "no-program"),
    (2, "cycle-running"),
    (3, "faulted"),
    (4, "not-ready"),
    (5, "nothing-to-do"),
    (6, "outside-soft-limits"),
    (7, "no-single-depth"),
    (8, "bad-value"),
    (9, "safety-chain-open"),
    (10, "drives-not-enabled"),
    (11, "not-referenced"),
    (12, "table-position-lost"),
    (13, "jog-active"),
    (14, "spindle-turning"),
    (15, "flanks-crossed"),
    (16, "program-changed"),
    (17, "offset-needs-confirmation"),
    (18, "delay-not-commissioned"),
    (19, "no-compensation"),
];

const FAULTS: &[(u32, &str)] = &[
    (1, "safety-chain-open"),
    (2, "emergency-stop"),
    (3, "hardware-limit"),
    (4, "soft-limit"),
    (5, "following-error"),
    (6, "drive-fault"),
    (7, "vfd-fault"),
    (8, "sync-lost"),
    (9, "spindle-speed"),
    (10, "lube-timeout"),
    (11, "clamp-timeout"),
    (12, "feedback-lost"),
    (13, "io-lost"),
    (14, "drive-not-enabled"),
    (15, "homing-failed"),
    (16, "position-lost"),
];

const COUPLINGS: &[(u32, &str)] = &[
    (0, "disengaged"),
    (1, "engaging"),
    (2, "phasing"),
    (3, "synchronised"),
    (4, "disengaging"),
];

const EVENT_KINDS: &[(u32, &str)] = &[
    (1, "state-changed"),
    (2, "alarm"),
    (3, "alarm-cleared"),
    (4, "pass-started"),
    (5, "phase-recorded"),
    (6, "accepted"),
    (7, "refused"),
    (8, "program-loaded"),
    (9, "cycle-done"),
    (10, "message"),
    (11, "bus"),
    (12, "referenced"),
    (13, "dead-man-stop"),
    (14, "offset-changed"),
    (15, "flank-touched"),
    (16, "phase-aligned"),
];

const BUS_EVENTS: &[(u32, &str)] = &[
    (1, "emcy"),
    (2, "heartbeat-lost"),
    (3, "tpdo-missing"),
    (4, "send-failed"),
];

const COMMANDS: &[(u32, &str)] = &[
    (1, "load"),
    (2, "start"),
    (3, "hold"),
    (4, "resume"),
    (5, "stop"),
    (6, "reset"),
    (7, "jog"),
    (8, "spindle on"),
    (9, "spindle off"),
    (10, "new blank"),
    (11, "home"),
    (12, "jog continuous"),
    (13, "jog release"),
    (14, "feed override"),
    (15, "spindle override"),
    (16, "touch-off"),
    (17, "continue"),
    (18, "spindle hold"),
    (19, "record"),
    (20, "touch flank"),
    (21, "nodes"),
    (22, "excite table"),
    (23, "pitch compensation"),
];

#[test]
fn every_state_keeps_its_code_and_word() {
    assert_eq!(State::ALL.len(), STATES.len(), "a state added: add it here too");
    for &(code, word) in STATES {
        let s = State::from_code(code).unwrap();
        assert_eq!((s.code(), s.name()), (code, word));
        assert_eq!(codec::state_name(code), word);
    }
    assert_eq!(State::from_code(STATES.len() as u32), None);
}

#[test]
fn every_refusal_keeps_its_code_and_word() {
    assert_eq!(
        Refusal::ALL.len(),
        REFUSALS.len(),
        "a refusal added: add it here too"
    );
    for &(code, word) in REFUSALS {
        let r = Refusal::from_code(code).unwrap();
        assert_eq!((r.code(), r.name()), (code, word));
    }
    assert_eq!(Refusal::from_code(0), None);
}

#[test]
fn a_touch_off_to_confirm_is_said_in_the_operators_words() {
    // The HMI shows it beside a CONFIRM button, the CLI beside its own hint: no command
    // line in it, and it says that nothing changed.
    let t = Refusal::OffsetNeedsConfirmation.text();
    assert!(!t.contains("hob touch") && !t.contains("--confirm"), "{t}");
    assert!(t.contains("confirm") && t.contains("nothing was changed"), "{t}");
    assert_eq!(codec::refusal_text(17), t);
}

#[test]
fn every_alarm_keeps_its_code_and_word() {
    assert_eq!(Fault::ALL.len(), FAULTS.len(), "a fault added: add it here too");
    for &(code, word) in FAULTS {
        let f = Fault::from_code(code).unwrap();
        assert_eq!((f.code(), f.name()), (code, word));
    }
    assert_eq!(Fault::from_code(0), None);
}

#[test]
fn axes_ends_homing_failures_and_couplings_keep_their_codes() {
    let axes: Vec<(u8, &str)> = Axis::ALL.iter().map(|a| (a.code(), a.name())).collect();
    assert_eq!(axes, [(1, "B"), (2, "X"), (3, "Y")]);
    let ends: Vec<(u8, &str)> = End::ALL.iter().map(|e| (e.code(), e.name())).collect();
    assert_eq!(ends, [(1, "min"), (2, "max")]);
    let h: Vec<u8> = HomingFailure::ALL.iter().map(|h| h.code()).collect();
    assert_eq!(h, [1, 2, 3, 4]);
    assert_eq!(HomingFailure::from_code(4), Some(HomingFailure::Timeout));
    assert_eq!(Coupling::ALL.len(), COUPLINGS.len());
    for &(code, word) in COUPLINGS {
        assert_eq!(Coupling::from_code(code).unwrap().name(), word);
        assert_eq!(codec::coupling_name(code), word);
    }
}

#[test]
fn events_bus_events_and_commands_keep_their_codes_and_words() {
    for (table, all, name) in [
        (
            EVENT_KINDS,
            &event_kind::ALL[..],
            event_kind::name as fn(u32) -> Option<&'static str>,
        ),
        (BUS_EVENTS, &bus_event::ALL[..], bus_event::name),
        (COMMANDS, &command::ALL[..], command::name),
    ] {
        let codes: Vec<u32> = table.iter().map(|(c, _)| *c).collect();
        assert_eq!(all, &codes[..]);
        for &(code, word) in table {
            assert_eq!(name(code), Some(word));
        }
        assert_eq!(name(0), None);
    }
    assert_eq!((event_kind::STATE_CHANGED, event_kind::PHASE_ALIGNED), (1, 16));
    assert_eq!((bus_event::EMCY, bus_event::SEND_FAILED), (1, 4));
    assert_eq!((command::LOAD_PROGRAM, command::PITCH_COMPENSATION), (1, 23));
    assert_eq!(
        (send_error::QUEUE_FULL, send_error::INTERFACE_DOWN, send_error::OS),
        (1, 2, 3)
    );
    assert_eq!((bus_kind::SOCKETCAN, bus_kind::SHARED_MEMORY), (0, 1));
    assert_eq!((direction::POSITIVE, direction::NEGATIVE), (1, 2));
}

/// Every `` `Name` (a..=b `` a document states for a code table, e.g. "`State` (0..=22)".
fn ranges_stated(text: &str) -> Vec<(String, u32, u32)> {
    let mut out = Vec::new();
    for (i, _) in text.match_indices("..=") {
        let before = &text[..i];
        let Some(open) = before.rfind('(') else { continue };
        let Ok(lo) = before[open + 1..].trim().parse::<u32>() else {
            continue;
        };
        let digits: String = text[i + 3..].chars().take_while(char::is_ascii_digit).collect();
        let Ok(hi) = digits.parse::<u32>() else { continue };
        let head = &before[..open];
        let Some(end) = head.rfind('`') else { continue };
        let Some(start) = head[..end].rfind('`') else {
            continue;
        };
        out.push((head[start + 1..end].to_string(), lo, hi));
    }
    out
}

fn range_of(name: &str) -> Option<(u32, u32)> {
    let t = match name {
        "State" => STATES,
        "Refusal" => REFUSALS,
        "Fault" | "FaultCode" => FAULTS,
        "Coupling" => COUPLINGS,
        "event_kind" => EVENT_KINDS,
        "bus_event" => BUS_EVENTS,
        "command" => COMMANDS,
        _ => return None,
    };
    Some((t[0].0, t[t.len() - 1].0))
}

#[test]
fn the_documents_state_the_tables_as_they_are() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut checked = 0;
    for doc in ["ARCHITECTURE.md", "ipc/README.md"] {
        let text = std::fs::read_to_string(root.join(doc)).unwrap();
        for (name, lo, hi) in ranges_stated(&text) {
            let Some(range) = range_of(&name) else { continue };
            assert_eq!((lo, hi), range, "{doc} says `{name}` ({lo}..={hi})");
            checked += 1;
        }
    }
    assert!(
        checked >= 3,
        "the documents state {checked} code ranges: the check found none to check"
    );
}

#[test]
fn a_stale_count_in_a_document_is_found() {
    let stale = "codes: `State` (0..=21), `Refusal` (1..=10), `Fault` (the alarm codes 1..=14)";
    let got = ranges_stated(stale);
    assert_eq!(got.len(), 2, "{got:?}");
    for (name, lo, hi) in got {
        assert_ne!(
            Some((lo, hi)),
            range_of(&name),
            "{name} ({lo}..={hi}) passed as current"
        );
    }
}
