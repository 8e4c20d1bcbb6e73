//! Every code of the contract between processes, as the number it is on the wire, and its
//! text: sequencer states, refusals, alarms (faults) with their axis and end, gearbox
//! couplings, commands, event kinds and bus events. Frontends decode with these and print
//! these texts, from the numbers alone, so a code reads the same everywhere. The states,
//! refusals, axes, ends, homing failures and couplings are the control core's own types
//! ([`crate::vocab`]); an alarm is the control core's fault as [`Fault`], its code here.
//!
//! The numbers are the wire format: never renumber one, only add new ones.

pub use crate::bus::nmt_state_name;
use crate::bus::{BusError, PowerState, emcy_text};
/// The alarm codes with their words, reaction and remedy (`vocab::FaultCode`).
pub use crate::vocab::FaultCode as Fault;
pub use crate::vocab::{Axis, Coupling, End, HomingFailure, Refusal, State};
use crate::{AlarmCode, EventSample, bus_event, bus_kind, command, event_kind, send_error};

/// The state's name, or `?<code>` for a code this build does not know.
pub fn state_name(c: u32) -> String {
    State::from_code(c).map_or_else(|| format!("?{c}"), |s| s.name().to_string())
}

/// The text of a refusal code (`?<code>` for one this build does not know).
pub fn refusal_text(c: u32) -> String {
    Refusal::from_code(c).map_or_else(|| format!("?{c}"), |r| r.text().to_string())
}

/// The recorder (`hob-logger`) as the operator is told of it: `hob status` and the HMI.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecorderView {
    /// Something recorded is being lost, or the recorder stopped reporting: shown as an
    /// alarm (the loop goes on: a record is not worth a part).
    pub alarm: bool,
    pub text: String,
}

/// A recorder report older than this is a recorder that stopped (it reports every 200 ms).
pub const RECORDER_SILENT_NS: u64 = 2_000_000_000;

/// What to tell of the recorder, given its newest report (if any) and the reader's
/// CLOCK_MONOTONIC.
pub fn recorder_view(r: Option<&crate::RecorderSample>, now_ns: u64) -> RecorderView {
    let Some(r) = r else {
        return RecorderView {
            alarm: false,
            text: "no recorder on the bus (hob-logger not running): nothing is recorded".into(),
        };
    };
    let age_ns = now_ns.saturating_sub(r.time_ns);
    if age_ns > RECORDER_SILENT_NS {
        return RecorderView {
            alarm: true,
            text: format!(
                "the recorder stopped reporting {:.1} s ago (hob-logger ended or hangs)",
                age_ns as f64 / 1e9
            ),
        };
    }
    if r.writing == 0 {
        let since = if r.failing_since_ns > 0 {
            format!(
                " for {:.1} s",
                now_ns.saturating_sub(r.failing_since_ns) as f64 / 1e9
            )
        } else {
            String::new()
        };
        return RecorderView {
            alarm: true,
            text: format!(
                "RECORDER ALARM: cannot write{since}: {}: {} samples and {} events not written (it resumes when space returns)",
                std::io::Error::from_raw_os_error(r.last_errno),
                r.samples_unwritten,
                r.events_unwritten
            ),
        };
    }
    let mut text = format!("writing: {} samples recorded", r.samples_written);
    if r.samples_unwritten > 0 || r.events_unwritten > 0 {
        text += &format!(
            ", {} samples and {} events not written earlier (gaps.log)",
            r.samples_unwritten, r.events_unwritten
        );
    }
    if r.samples_lost > 0 {
        text += &format!(", {} samples missed on the bus", r.samples_lost);
    }
    RecorderView { alarm: false, text }
}

/// An EMCY error code and its meaning; none for 0x0000 (no error, or its reset).
pub fn emcy_words(code: u16) -> Option<String> {
    (code != 0).then(|| format!("EMCY 0x{code:04X} {}", emcy_text(code)))
}

/// What the drive an alarm names reported itself: its last EMCY
/// ([`crate::StateSample::last_emcy_code`]), by the drive's name; none when the alarm names
/// no drive or the drive sent none.
pub fn drive_reported(a: &AlarmCode, last_emcy_code: &[u16; 4]) -> Option<String> {
    let axis = Axis::from_code(a.axis)?;
    let code = last_emcy_code[usize::from(axis.code() - 1)];
    emcy_words(code).map(|w| format!("drive {} reported {w}", axis.name()))
}

/// The text of an alarm ("" for none, `alarm code <c>` for one this build cannot word).
pub fn alarm_text(a: &AlarmCode) -> String {
    if a.code == 0 {
        return String::new();
    }
    Fault::of(a)
        .and_then(|f| f.text(a))
        .unwrap_or_else(|| format!("alarm code {}", a.code))
}

/// The name of a coupling code (`?` for one this build does not know).
pub fn coupling_name(c: u32) -> &'static str {
    Coupling::from_code(c).map_or("?", Coupling::name)
}

/// Every [`command`] code, in code order (declared once, with its word, in [`command`]).
pub const COMMANDS: [u32; command::ALL.len()] = command::ALL;

/// The command's name as the CLI spells it (`?` for a code this build does not know).
pub fn command_name(code: u32) -> &'static str {
    command::name(code).unwrap_or("?")
}

/// Every [`event_kind`] code, in code order (declared once, with its word, in [`event_kind`]).
pub const EVENT_KINDS: [u32; event_kind::ALL.len()] = event_kind::ALL;

/// The name of an [`event_kind`] code (`None` for one this build does not know).
pub fn event_kind_name(k: u32) -> Option<&'static str> {
    event_kind::name(k)
}

/// How the words of a [`event_kind::PROGRAM_LOADED`] event that names its program begin.
const PROGRAM_LOADED_WORDS: &str = "program loaded: ";

/// Between the program's file name and its part in such an event's text.
const PART_WORDS: &str = "; part: ";

/// The text `hob-rt` gives a [`event_kind::PROGRAM_LOADED`] event: the program file's name
/// (as the command named it, without its folders) and the part, the workpiece's `name` of
/// the program (none: the program names none). [`loaded_program`] reads it back from the
/// event's words; cut short to [`crate::EVENT_TEXT_BYTES`] where it is longer.
pub fn program_loaded_text(file: &str, part: Option<&str>) -> String {
    let file = file.rsplit('/').next().unwrap_or(file);
    match part {
        Some(part) => format!("{file}{PART_WORDS}{part}"),
        None => file.to_string(),
    }
}

/// The program and part a [`event_kind::PROGRAM_LOADED`] event's words
/// ([`event_text`]) name, as [`program_loaded_text`] wrote them: `None` for words of
/// another event; the file `None` when `hob-rt` did not name the program (one that
/// recorded no name), the part `None` when the program names none.
pub fn loaded_program(words: &str) -> Option<(Option<String>, Option<String>)> {
    if words == "program loaded" {
        return Some((None, None));
    }
    let named = words.strip_prefix(PROGRAM_LOADED_WORDS)?;
    Some(match named.split_once(PART_WORDS) {
        Some((file, part)) => (Some(file.to_string()), Some(part.to_string())),
        None => (Some(named.to_string()), None),
    })
}

/// How serious an event is, for filtering the event log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    Alarm,
    Warning,
    Info,
}

impl Severity {
    pub const fn name(self) -> &'static str {
        match self {
            Severity::Alarm => "alarm",
            Severity::Warning => "warning",
            Severity::Info => "info",
        }
    }
}

/// What an event is about, for filtering the event log: its group (`alarm`, `operator`,
/// `bus`, `cycle`, `service`), its severity and the axis it concerns, where it names one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EventClass {
    pub group: &'static str,
    pub severity: Severity,
    pub axis: Option<Axis>,
}

/// The class of an event from its codes alone.
pub fn event_class(e: &EventSample) -> EventClass {
    use event_kind as k;
    let axis_a = Axis::from_code(e.a.min(255) as u8);
    let (group, severity, axis) = match e.kind {
        k::ALARM => ("alarm", Severity::Alarm, Axis::from_code(e.alarm.axis)),
        k::ALARM_CLEARED => ("alarm", Severity::Info, Axis::from_code(e.alarm.axis)),
        // The command's axis is in `b`'s second byte.
        k::ACCEPTED => ("operator", Severity::Info, Axis::from_code((e.b >> 8) as u8)),
        k::REFUSED => ("operator", Severity::Warning, None),
        k::BUS => {
            let severity = match e.b {
                bus_event::EMCY | bus_event::HEARTBEAT_LOST | bus_event::SEND_FAILED => Severity::Warning,
                _ => Severity::Info,
            };
            ("bus", severity, None)
        }
        k::DEAD_MAN_STOP => ("operator", Severity::Warning, axis_a),
        k::REFERENCED | k::OFFSET_CHANGED => ("cycle", Severity::Info, axis_a),
        k::MESSAGE => ("service", Severity::Info, None),
        _ => ("cycle", Severity::Info, None),
    };
    EventClass {
        group,
        severity,
        axis,
    }
}

/// One line for an event (logger, `hob status --watch`, HMI).
pub fn event_text(e: &EventSample) -> String {
    match e.kind {
        event_kind::STATE_CHANGED => format!("state {} -> {}", state_name(e.a), state_name(e.b)),
        event_kind::ALARM => format!("ALARM {}", alarm_text(&e.alarm)),
        event_kind::ALARM_CLEARED => "alarm cleared".into(),
        event_kind::PASS_STARTED => format!("pass {} started", e.a),
        event_kind::PHASE_RECORDED => format!("tooth phase recorded: {:.4} deg", e.value),
        event_kind::ACCEPTED => format!("accepted: {}", command_name(e.a)),
        event_kind::REFUSED => format!(
            "refused: {}: {}",
            command_name(e.a),
            Refusal::from_code(e.b).map_or("?", Refusal::text)
        ),
        event_kind::PROGRAM_LOADED if e.text_len == 0 => "program loaded".into(),
        event_kind::PROGRAM_LOADED => format!("{PROGRAM_LOADED_WORDS}{}", e.text()),
        event_kind::CYCLE_DONE => "cycle done".into(),
        event_kind::BUS => bus_event_text(e),
        event_kind::MESSAGE => e.text(),
        event_kind::REFERENCED => format!("{} referenced", axis_name(e.a)),
        event_kind::DEAD_MAN_STOP if e.a == 0 => {
            "hob spindle C stopped: its renewals stopped (dead-man)".into()
        }
        event_kind::DEAD_MAN_STOP => {
            format!("jog {} stopped: its renewals stopped (dead-man)", axis_name(e.a))
        }
        event_kind::OFFSET_CHANGED => format!("touch-off: {} offset {:+.4} mm", axis_name(e.a), e.value),
        event_kind::FLANK_TOUCHED => format!(
            "flank touched, the table turned {}: tooth phase {:.4} deg; the part's phase is set when both flanks are touched",
            if e.a == u32::from(crate::direction::POSITIVE) {
                "positive"
            } else {
                "negative"
            },
            e.value
        ),
        event_kind::PHASE_ALIGNED => format!(
            "aligned to the cut gaps: tooth phase {:.4} deg, {:.4} deg of play between the flanks",
            e.value,
            f64::from(e.a) * 1e-6
        ),
        k => format!("event kind {k}"),
    }
}

fn axis_name(code: u32) -> &'static str {
    u8::try_from(code)
        .ok()
        .and_then(Axis::from_code)
        .map_or("?", Axis::name)
}

/// Every [`bus_event`] code, in code order (declared once, with its word, in [`bus_event`]).
pub const BUS_EVENTS: [u32; bus_event::ALL.len()] = bus_event::ALL;

/// The name of a [`bus_event`] code (`None` for one this build does not know).
pub fn bus_event_name(b: u32) -> Option<&'static str> {
    bus_event::name(b)
}

/// The operator's words for a bus event ([`event_kind::BUS`]).
pub fn bus_event_text(e: &EventSample) -> String {
    let node = e.a;
    match e.b {
        bus_event::EMCY => {
            let code = e.value as u16;
            format!("EMCY node {node} 0x{code:04X}: {}", emcy_text(code))
        }
        bus_event::HEARTBEAT_LOST => format!("heartbeat of node {node} lost"),
        bus_event::TPDO_MISSING => {
            let cycles = e.value;
            format!(
                "TPDO of node {} late or lost in {cycles} cycle{} since its last report, at most {} in a row",
                node & 0xFF,
                if cycles == 1.0 { "" } else { "s" },
                node >> 8
            )
        }
        bus_event::SEND_FAILED => {
            let why = match e.a {
                send_error::QUEUE_FULL => BusError::Full.to_string(),
                send_error::INTERFACE_DOWN => BusError::Down.to_string(),
                _ => BusError::Os(e.value as i32).to_string(),
            };
            format!("CAN send failed: {why}")
        }
        b => format!("bus event {b} of node {node}"),
    }
}

/// A drive's CiA 402 power state, from its statusword ([`crate::StateSample::drive_statusword`]).
pub fn cia402_state_name(statusword: u16) -> &'static str {
    PowerState::from_statusword(statusword).name()
}

/// The name of a [`bus_kind`] code.
pub fn bus_kind_name(k: u8) -> &'static str {
    match k {
        bus_kind::SHARED_MEMORY => "shm",
        _ => "socketcan",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every event kind has a class; the event log's filters (kind, axis, severity) use it.
    #[test]
    fn every_event_has_a_group_a_severity_and_where_it_names_one_an_axis() {
        let ev = |kind: u32, a: u32, b: u32| EventSample {
            kind,
            a,
            b,
            ..Default::default()
        };
        let mut alarm = ev(event_kind::ALARM, 0, 0);
        alarm.alarm.axis = Axis::Y.code();
        let c = event_class(&alarm);
        assert_eq!(
            (c.group, c.severity, c.axis),
            ("alarm", Severity::Alarm, Some(Axis::Y))
        );
        let jog_x = ev(event_kind::ACCEPTED, command::JOG, u32::from(Axis::X.code()) << 8);
        assert_eq!(event_class(&jog_x).axis, Some(Axis::X));
        assert_eq!(
            event_class(&ev(event_kind::REFUSED, command::JOG, 1)).severity,
            Severity::Warning
        );
        assert_eq!(
            event_class(&ev(event_kind::BUS, 4, bus_event::EMCY)).severity,
            Severity::Warning
        );
        assert_eq!(
            event_class(&ev(event_kind::BUS, 4, bus_event::TPDO_MISSING)).severity,
            Severity::Info
        );
        let referenced = event_class(&ev(event_kind::REFERENCED, u32::from(Axis::Y.code()), 0));
        assert_eq!((referenced.group, referenced.axis), ("cycle", Some(Axis::Y)));
        for kind in 1..=16 {
            let c = event_class(&ev(kind, 0, 0));
            assert!(
                ["alarm", "operator", "bus", "cycle", "service"].contains(&c.group),
                "{kind}"
            );
        }
    }

    #[test]
    fn the_recorder_is_an_alarm_when_it_cannot_write_or_stops_reporting() {
        let ok = crate::RecorderSample {
            time_ns: 10_000_000_000,
            samples_written: 5000,
            writing: 1,
            ..Default::default()
        };
        let v = recorder_view(Some(&ok), 10_100_000_000);
        assert!(!v.alarm && v.text == "writing: 5000 samples recorded", "{v:?}");
        let full = crate::RecorderSample {
            writing: 0,
            failing_since_ns: 7_000_000_000,
            last_errno: 28,
            samples_unwritten: 3000,
            events_unwritten: 2,
            ..ok
        };
        let v = recorder_view(Some(&full), 10_100_000_000);
        assert!(v.alarm, "{v:?}");
        assert!(
            v.text.contains("for 3.1 s")
                && v.text.contains("No space left on device")
                && v.text.contains("3000 samples and 2 events not written"),
            "{v:?}"
        );
        let v = recorder_view(Some(&ok), 13_000_000_000);
        assert!(v.alarm && v.text.contains("stopped reporting 3.0 s ago"), "{v:?}");
        let resumed = crate::RecorderSample {
            samples_unwritten: 3000,
            ..ok
        };
        let v = recorder_view(Some(&resumed), 10_000_000_000);
        assert!(
            !v.alarm && v.text.contains("3000 samples and 0 events not written earlier"),
            "{v:?}"
        );
        assert!(!recorder_view(None, 0).alarm);
    }
    use std::collections::BTreeSet;

    fn distinct<'a>(names: impl IntoIterator<Item = &'a str>) -> bool {
        let names: Vec<&str> = names.into_iter().collect();
        names.iter().collect::<BTreeSet<_>>().len() == names.len() && names.iter().all(|n| !n.is_empty())
    }

    #[test]
    fn every_code_is_its_position_and_round_trips() {
        for (i, s) in State::ALL.into_iter().enumerate() {
            assert_eq!(s.code(), i as u32);
            assert_eq!(State::from_code(s.code()), Some(s));
        }
        for (i, r) in Refusal::ALL.into_iter().enumerate() {
            assert_eq!(r.code(), i as u32 + 1);
            assert_eq!(Refusal::from_code(r.code()), Some(r));
        }
        for (i, f) in Fault::ALL.into_iter().enumerate() {
            assert_eq!(f.code(), i as u32 + 1);
            assert_eq!(Fault::from_code(f.code()), Some(f));
        }
        for (i, c) in Coupling::ALL.into_iter().enumerate() {
            assert_eq!(c.code(), i as u32);
            assert_eq!(Coupling::from_code(c.code()), Some(c));
        }
        for (i, a) in Axis::ALL.into_iter().enumerate() {
            assert_eq!(a.code(), i as u8 + 1);
            assert_eq!(Axis::from_code(a.code()), Some(a));
            assert_eq!(Axis::parse(&a.name().to_lowercase()), Some(a));
        }
        for (i, e) in End::ALL.into_iter().enumerate() {
            assert_eq!(e.code(), i as u8 + 1);
            assert_eq!(End::from_code(e.code()), Some(e));
        }
        for (i, c) in COMMANDS.into_iter().enumerate() {
            assert_eq!(c, i as u32 + 1);
        }
        for (i, k) in EVENT_KINDS.into_iter().enumerate() {
            assert_eq!(k, i as u32 + 1);
        }
        for (i, b) in BUS_EVENTS.into_iter().enumerate() {
            assert_eq!(b, i as u32 + 1);
        }
    }

    #[test]
    fn every_code_has_a_distinct_name() {
        assert!(distinct(State::ALL.map(State::name)));
        assert!(distinct(Refusal::ALL.map(Refusal::name)));
        assert!(distinct(Refusal::ALL.map(Refusal::text)));
        assert!(distinct(Fault::ALL.map(Fault::name)));
        assert!(distinct(Coupling::ALL.map(Coupling::name)));
        assert!(distinct(Axis::ALL.map(Axis::name)));
        assert!(distinct(End::ALL.map(End::name)));
        assert!(distinct(COMMANDS.map(command_name)));
        assert!(distinct(EVENT_KINDS.map(|k| event_kind_name(k).unwrap())));
        assert!(distinct(BUS_EVENTS.map(|b| bus_event_name(b).unwrap())));
        // Every alarm reads differently, given an axis and values.
        let texts: Vec<String> = Fault::ALL
            .iter()
            .map(|f| {
                let a = AlarmCode {
                    code: f.code(),
                    axis: Axis::X.code(),
                    end: End::Min.code(),
                    value_a: 1.0,
                    value_b: 2.0,
                    ..AlarmCode::default()
                };
                alarm_text(&a)
            })
            .collect();
        assert!(distinct(texts.iter().map(String::as_str)), "{texts:?}");
    }

    #[test]
    fn unknown_codes_decode_to_none() {
        assert_eq!(State::from_code(State::ALL.len() as u32), None);
        assert_eq!(state_name(99), "?99");
        assert_eq!(Refusal::from_code(0), None);
        assert_eq!(Refusal::from_code(Refusal::ALL.len() as u32 + 1), None);
        assert_eq!(refusal_text(42), "?42");
        assert_eq!(Fault::from_code(0), None);
        assert_eq!(Fault::from_code(Fault::ALL.len() as u32 + 1), None);
        assert_eq!(Coupling::from_code(5), None);
        assert_eq!(coupling_name(5), "?");
        assert_eq!(Axis::from_code(0), None);
        assert_eq!(Axis::from_code(4), None);
        assert_eq!(Axis::parse("z"), None);
        assert_eq!(End::from_code(0), None);
        assert_eq!(End::from_code(3), None);
        assert_eq!(command_name(0), "?");
        assert_eq!(command_name(COMMANDS.len() as u32 + 1), "?");
        assert_eq!(event_kind_name(0), None);
        assert_eq!(event_kind_name(EVENT_KINDS.len() as u32 + 1), None);
        assert_eq!(bus_event_name(5), None);
        let e = EventSample {
            kind: 99,
            ..EventSample::default()
        };
        assert_eq!(event_text(&e), "event kind 99");
    }

    #[test]
    fn alarms_are_worded_from_their_numbers() {
        assert_eq!(alarm_text(&AlarmCode::default()), "");
        let a = |code: u32, axis: u8, end: u8, va: f64, vb: f64| AlarmCode {
            code,
            axis,
            end,
            value_a: va,
            value_b: vb,
            ..AlarmCode::default()
        };
        assert_eq!(alarm_text(&a(3, 3, 1, 0.0, 0.0)), "hardware limit Y min");
        assert_eq!(alarm_text(&a(3, 1, 2, 0.0, 0.0)), "hardware limit B max");
        assert_eq!(alarm_text(&a(4, 1, 0, 12.5, 0.0)), "soft limit B: 12.500 deg");
        assert_eq!(alarm_text(&a(5, 2, 0, 0.25, 0.0)), "following error X: 0.2500 mm");
        assert_eq!(
            alarm_text(&a(9, 0, 0, 119.0, 80.0)),
            "spindle did not reach 119.0 rpm (is 80.0 rpm)"
        );
        // A fault that names an axis, without one; an unknown code.
        assert_eq!(alarm_text(&a(12, 0, 0, 0.0, 0.0)), "alarm code 12");
        assert_eq!(Fault::of(&a(12, 0, 0, 0.0, 0.0)), None);
        assert_eq!(Fault::of(&a(13, 0, 0, 0.0, 0.0)), Some(Fault::IoLost));
        assert_eq!(alarm_text(&a(77, 0, 0, 0.0, 0.0)), "alarm code 77");
    }

    #[test]
    fn events_are_worded_from_their_numbers() {
        let e = |kind: u32, a: u32, b: u32| EventSample {
            kind,
            a,
            b,
            ..EventSample::default()
        };
        assert_eq!(
            event_text(&e(
                event_kind::STATE_CHANGED,
                State::Idle.code(),
                State::Cut.code()
            )),
            "state idle -> cut"
        );
        assert_eq!(
            event_text(&e(event_kind::STATE_CHANGED, 1, 40)),
            "state idle -> ?40"
        );
        assert_eq!(
            event_text(&e(event_kind::REFUSED, command::START, Refusal::NoProgram.code())),
            "refused: start: no program loaded: load one first"
        );
        assert_eq!(
            event_text(&e(event_kind::REFUSED, command::START, 0)),
            "refused: start: ?"
        );
        assert_eq!(
            event_text(&e(event_kind::ACCEPTED, command::JOG, 0)),
            "accepted: jog"
        );
        let mut bus = e(event_kind::BUS, 5, bus_event::HEARTBEAT_LOST);
        assert_eq!(event_text(&bus), "heartbeat of node 5 lost");
        bus.b = 9;
        assert_eq!(event_text(&bus), "bus event 9 of node 5");
    }

    #[test]
    fn a_loaded_program_is_named_in_its_event_and_read_back_from_its_words() {
        let named = |text: &str| {
            let mut e = EventSample {
                kind: event_kind::PROGRAM_LOADED,
                ..EventSample::default()
            };
            e.text_len = crate::write_text(&mut e.text, text);
            event_text(&e)
        };
        let text = program_loaded_text(
            "config/programs/spur-z17-m5.toml",
            Some("Thesis worst case, spur z17 m5, 42CrMo4"),
        );
        let words = named(&text);
        assert_eq!(
            words,
            "program loaded: spur-z17-m5.toml; part: Thesis worst case, spur z17 m5, 42CrMo4"
        );
        assert_eq!(
            loaded_program(&words),
            Some((
                Some("spur-z17-m5.toml".to_string()),
                Some("Thesis worst case, spur z17 m5, 42CrMo4".to_string())
            ))
        );
        let words = named(&program_loaded_text("library program hmi-gear", None));
        assert_eq!(words, "program loaded: library program hmi-gear");
        assert_eq!(
            loaded_program(&words),
            Some((Some("library program hmi-gear".to_string()), None))
        );
        // A hob-rt that did not name its program; another event.
        assert_eq!(named(""), "program loaded");
        assert_eq!(loaded_program("program loaded"), Some((None, None)));
        assert_eq!(loaded_program("cycle done"), None);
    }

    #[test]
    fn every_fault_says_what_the_machine_did_what_to_repair_and_how_to_go_on() {
        // Every code the wire can carry, with every axis and end byte an alarm can hold.
        let faults: Vec<Fault> = (0..=u32::from(u8::MAX)).filter_map(Fault::from_code).collect();
        assert_eq!(faults, Fault::ALL);
        for f in faults {
            for axis in [0u8, 1, 2, 3] {
                for end in [0u8, 1, 2] {
                    let a = AlarmCode {
                        code: f.code(),
                        axis,
                        end,
                        ..AlarmCode::default()
                    };
                    let r = f.reaction(&a);
                    assert!(
                        r.len() > 40 && r.contains("PC-OK dropped"),
                        "{f:?} axis {axis}: {r}"
                    );
                    // Outside a cycle every fault stops the spindle and drops PC-OK at once.
                    assert!(r.contains("outside a cycle"), "{f:?}: {r}");
                }
            }
            assert!(f.remedy().len() > 30, "{f:?}: {}", f.remedy());
            let c = f.how_to_continue();
            // PC-OK dropped on every fault and opened the chain: its reset button is part
            // of going on, whatever the fault.
            assert!(c.contains("reset button"), "{f:?}: {c}");
            assert!(c.contains("START"), "{f:?}: {c}");
        }
        // The three reactions are told apart by the axis.
        let b = AlarmCode {
            code: Fault::DriveFault.code(),
            axis: Axis::B.code(),
            ..AlarmCode::default()
        };
        let x = AlarmCode {
            axis: Axis::X.code(),
            ..b
        };
        let y = AlarmCode {
            axis: Axis::Y.code(),
            ..b
        };
        let texts = [
            Fault::DriveFault.reaction(&b),
            Fault::DriveFault.reaction(&x),
            Fault::DriveFault.reaction(&y),
        ];
        assert!(texts[0].contains("disengaged at once") && texts[1].contains("stopped where it was"));
        assert!(texts[2].contains("retracted to its safe position with the gearbox still engaged"));
        assert!(texts.iter().all(|t| !t.contains("watchdog")));
        // A lost node: the watchdog acts too, and only a restarted hob-rt re-arms it.
        let lost = AlarmCode {
            code: Fault::FeedbackLost.code(),
            ..y
        };
        assert!(Fault::FeedbackLost.reaction(&lost).contains("watchdog"));
        assert!(Fault::IoLost.reaction(&AlarmCode::default()).contains("watchdog"));
        for f in [Fault::FeedbackLost, Fault::IoLost] {
            assert!(f.how_to_continue().contains("restart hob-rt"), "{f:?}");
        }
    }

    #[test]
    fn an_alarm_whose_situation_is_recorded_tells_only_what_happened() {
        use crate::vocab::situation;
        let y = |sit: u8| AlarmCode {
            code: Fault::DriveFault.code(),
            axis: Axis::Y.code(),
            situation: sit,
            ..AlarmCode::default()
        };
        let work = Fault::DriveFault.reaction(&y(situation::IN_WORK));
        assert!(work.starts_with("X retracted to its safe position"), "{work}");
        let cycle = Fault::DriveFault.reaction(&y(situation::IN_CYCLE));
        assert!(cycle.starts_with("the hob was out of the work"), "{cycle}");
        let outside = Fault::DriveFault.reaction(&y(situation::OUTSIDE_CYCLE));
        assert!(outside.starts_with("no cycle ran"), "{outside}");
        for t in [work, cycle, outside] {
            assert!(!t.contains("elsewhere") && !t.contains("outside a cycle"), "{t}");
        }
        // Not recorded: every case, as before.
        let unknown = Fault::DriveFault.reaction(&y(situation::UNKNOWN));
        assert!(unknown.contains("elsewhere") && unknown.contains("outside a cycle"));
        // The table's drive in the work: the spindle stops at once, X pulls out.
        let b = AlarmCode {
            axis: Axis::B.code(),
            ..y(situation::IN_WORK)
        };
        assert!(
            Fault::DriveFault
                .reaction(&b)
                .starts_with("the table could no longer follow")
        );
        // A lost node still tells the watchdog's part.
        let lost = AlarmCode {
            code: Fault::FeedbackLost.code(),
            ..y(situation::IN_WORK)
        };
        assert!(Fault::FeedbackLost.reaction(&lost).contains("watchdog"));
        assert_eq!(State::Cut.situation(), situation::IN_WORK);
        assert_eq!(State::Infeed.situation(), situation::IN_WORK);
        assert_eq!(State::ToStart.situation(), situation::IN_CYCLE);
        assert_eq!(State::Jog.situation(), situation::OUTSIDE_CYCLE);
    }

    #[test]
    fn the_drive_an_alarm_names_says_what_it_reported() {
        let y = AlarmCode {
            code: Fault::DriveFault.code(),
            axis: Axis::Y.code(),
            ..AlarmCode::default()
        };
        assert_eq!(
            drive_reported(&y, &[0, 0, 0x2310, 0]).as_deref(),
            Some("drive Y reported EMCY 0x2310 continuous over-current")
        );
        // Another drive's EMCY is not this alarm's; none sent, or reset: nothing.
        assert_eq!(drive_reported(&y, &[0x2310, 0x2310, 0, 0]), None);
        assert_eq!(drive_reported(&AlarmCode::default(), &[0x2310; 4]), None);
    }

    #[test]
    fn continue_is_offered_only_where_the_loop_accepts_it() {
        // CONTINUE needs the interrupted pass, X and Y referenced and the table's position
        // kept (`Command::Continue` in the control core).
        let continues = |f: Fault| f.how_to_continue().contains("CONTINUE re-enters");
        for f in [
            Fault::SafetyChainOpen,
            Fault::EmergencyStop,
            Fault::FollowingError,
            Fault::DriveFault,
            Fault::SyncLost,
            Fault::LubeTimeout,
            Fault::PositionLost,
        ] {
            assert!(continues(f), "{f:?}: {}", f.how_to_continue());
        }
        // After a restart of hob-rt nothing is left to continue.
        assert!(!continues(Fault::FeedbackLost) && !continues(Fault::IoLost));
        // A table that lost its position refuses CONTINUE; an axis that lost its reference
        // needs HOME first.
        let p = Fault::PositionLost.how_to_continue();
        assert!(p.contains("CONTINUE is refused") && p.contains("NEW BLANK") && p.contains("HOME"));
        assert!(Fault::HomingFailed.how_to_continue().contains("HOME again"));
    }
}
