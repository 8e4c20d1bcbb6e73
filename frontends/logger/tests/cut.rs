//! One cut out of a recording, as a frontend asks for it: the report of a range of cycles
//! and the events of that range (its alarms among them), from a log the logger's writer
//! wrote, over restarts of the logger and of `hob-rt`.

#![allow(clippy::unwrap_used)]

use hob_ipc::codec::{self, Axis, Coupling, Fault, State};
use hob_ipc::{AlarmCode, EventSample, StateSample, event_kind, write_text};
use hob_logger::LogWriter;
use hob_logger::export::{LoggedEvent, events_in, read_events, report, report_cycles};
use hob_logger::format::{encode, header};
use std::path::{Path, PathBuf};

fn log_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hob-logger-cut-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn event(seq: u64, cycle: u64, kind: u32, a: u32) -> EventSample {
    EventSample {
        seq,
        cycle,
        kind,
        a,
        ..EventSample::default()
    }
}

fn alarm(seq: u64, cycle: u64) -> EventSample {
    EventSample {
        alarm: AlarmCode {
            code: Fault::DriveFault.code(),
            axis: Axis::Y.code(),
            ..AlarmCode::default()
        },
        ..event(seq, cycle, event_kind::ALARM, 0)
    }
}

fn sample(cycle: u64, pass: u32, sync_error_arcsec: f64) -> StateSample {
    StateSample {
        cycle,
        sync_time_ns: cycle * 1_000_000,
        state: State::Cut.code(),
        pass,
        coupling: Coupling::Synchronised.code(),
        sync_error_arcsec,
        pitch_radius_mm: 42.5,
        normal_module_mm: 5.0,
        feed_override_percent: 100.0,
        spindle_override_percent: 100.0,
        ..StateSample::default()
    }
}

fn write(dir: &Path, states: &[StateSample], events: &[EventSample]) {
    let mut w = LogWriter::open(dir, "t").unwrap();
    for s in states {
        w.push_state(s).unwrap();
    }
    for e in events {
        w.push_event(e).unwrap();
    }
    w.flush().unwrap();
}

fn seqs(events: &[LoggedEvent]) -> Vec<(u32, u64)> {
    events.iter().map(|e| (e.run, e.seq)).collect()
}

#[test]
fn the_events_of_a_cut_are_read_back_as_recorded_with_its_alarms() {
    let dir = log_dir("events");
    let events = [
        event(1, 5, event_kind::PROGRAM_LOADED, 0),
        event(2, 20, event_kind::PASS_STARTED, 1),
        alarm(3, 30),
        event(4, 31, event_kind::ALARM_CLEARED, 0),
        event(5, 40, event_kind::CYCLE_DONE, 0),
        event(6, 50, event_kind::PASS_STARTED, 1),
    ];
    write(&dir, &[sample(1, 1, 0.1)], &events);
    let all = read_events(&dir).unwrap();
    let cut = events_in(&dir, 20, 40).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(all.len(), events.len());
    for (l, e) in all.iter().zip(&events) {
        assert_eq!(
            (l.run, l.seq, l.cycle, l.kind, l.text.as_str()),
            (0, e.seq, e.cycle, e.kind, codec::event_text(e).as_str())
        );
    }
    assert_eq!(seqs(&cut), [(0, 2), (0, 3), (0, 4), (0, 5)]);
    let alarms: Vec<&LoggedEvent> = cut.iter().filter(|e| e.is_alarm()).collect();
    assert_eq!(alarms.len(), 1);
    assert_eq!(alarms[0].text, "ALARM drive fault Y");
}

#[test]
fn a_restarted_logger_writes_no_event_twice_and_fills_in_what_it_missed() {
    let dir = log_dir("logger-restart");
    // The first logger missed event 3; the second is handed 2 ..= 5 again, then 6.
    let first = [1, 2, 4, 5].map(|s| event(s, 10 * s, event_kind::PASS_STARTED, s as u32));
    let second = [2, 3, 4, 5, 6].map(|s| event(s, 10 * s, event_kind::PASS_STARTED, s as u32));
    write(&dir, &[sample(1, 1, 0.1)], &first);
    write(&dir, &[sample(2, 1, 0.1)], &second);
    let raw = std::fs::read_to_string(dir.join("events.log")).unwrap();
    let events = read_events(&dir).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(raw.lines().count(), 9, "the writer wrote the repeats: {raw}");
    assert_eq!(seqs(&events), [1, 2, 3, 4, 5, 6].map(|s| (0, s)));
    assert!(
        events
            .iter()
            .all(|e| e.cycle == 10 * e.seq && e.text == format!("pass {} started", e.seq)),
        "{events:?}"
    );
}

#[test]
fn a_restarted_loop_is_a_new_run_and_a_range_is_taken_from_the_newest() {
    let dir = log_dir("loop-restart");
    // hob-rt numbers its events and cycles again after a restart; its first event here is
    // the very line of the first run's first event.
    let start = event(1, 1, event_kind::MESSAGE, 0);
    let first = [start, event(2, 100, event_kind::PASS_STARTED, 1), alarm(3, 150)];
    let second = [start, event(2, 120, event_kind::PASS_STARTED, 1)];
    let run1: Vec<StateSample> = (100..=106).map(|c| sample(c, 1, 100.0)).collect();
    let run2: Vec<StateSample> = (100..=103).map(|c| sample(c, 2, 1.0)).collect();
    write(&dir, &run1, &first);
    write(&dir, &run2, &second);
    let events = read_events(&dir).unwrap();
    let cut = events_in(&dir, 0, 200).unwrap();
    let newest = report_cycles(&dir, 100, 110).unwrap();
    let whole = report(&dir).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(seqs(&events), [(0, 1), (0, 2), (0, 3), (1, 1), (1, 2)]);
    assert_eq!(
        seqs(&cut),
        [(1, 1), (1, 2)],
        "no alarm of the first run in this cut"
    );
    // The samples of the second run only: its pass, its error.
    assert_eq!(
        (newest.samples, newest.first_cycle, newest.last_cycle),
        (4, 100, 103)
    );
    let cut_passes: Vec<u32> = newest
        .passes
        .iter()
        .filter(|p| p.samples > 0)
        .map(|p| p.pass)
        .collect();
    assert_eq!(cut_passes, [2]);
    assert!(
        newest.passes.iter().all(|p| p.sync_err_max_arcsec <= 1.0),
        "{:?}",
        newest.passes
    );
    // The whole recording is reported as before: every sample of both runs.
    assert_eq!(whole.samples, 11);
}

#[test]
fn a_line_cut_short_is_left_out_and_a_foreign_line_is_refused_with_its_number() {
    let dir = log_dir("lines");
    write(
        &dir,
        &[sample(1, 1, 0.1)],
        &[event(1, 5, event_kind::CYCLE_DONE, 0)],
    );
    let path = dir.join("events.log");
    let mut text = std::fs::read_to_string(&path).unwrap();
    // A logger killed while it wrote a line.
    text.push_str("2 6 2 ALAR");
    std::fs::write(&path, &text).unwrap();
    let read = read_events(&dir).unwrap();
    std::fs::write(&path, format!("{text}M\nnot an event\n")).unwrap();
    let foreign = read_events(&dir).unwrap_err().to_string();
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(seqs(&read), [(0, 1)]);
    assert!(foreign.contains("events.log:3: not an event line"), "{foreign}");
}

#[test]
fn an_event_text_with_a_line_break_stays_one_line() {
    let dir = log_dir("line-break");
    let mut m = event(1, 5, event_kind::MESSAGE, 0);
    m.text_len = write_text(&mut m.text, "first\nsecond");
    write(
        &dir,
        &[sample(1, 1, 0.1)],
        &[m, event(2, 6, event_kind::CYCLE_DONE, 0)],
    );
    let events = read_events(&dir).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(seqs(&events), [(0, 1), (0, 2)]);
    assert_eq!(events[0].text, "first\\nsecond");
}

#[test]
fn a_range_without_samples_and_an_empty_log_are_refused_in_words() {
    let dir = log_dir("empty");
    write(&dir, &[], &[]);
    // The logger opens a state file only for its first sample.
    let no_file = report(&dir).unwrap_err().to_string();
    // A logger killed before its first record reached the file.
    std::fs::write(dir.join("state-000001.hoblog"), header("t", 0)).unwrap();
    let empty = report(&dir).unwrap_err().to_string();
    write(&dir, &[sample(7, 1, 0.1)], &[]);
    let none = report_cycles(&dir, 100, 200).unwrap_err().to_string();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(no_file.contains("not a hob log"), "{no_file}");
    assert!(empty.ends_with(": no sample recorded"), "{empty}");
    assert!(none.contains("no sample of cycles 100 .. 200 recorded"), "{none}");
}

/// A program loaded, as `hob-rt` names it in its event.
fn loaded(seq: u64, cycle: u64, file: &str, part: Option<&str>) -> EventSample {
    let mut e = event(seq, cycle, event_kind::PROGRAM_LOADED, 0);
    e.text_len = write_text(&mut e.text, &codec::program_loaded_text(file, part));
    e
}

/// A cut broken off by a fault and continued, one cycle a second (to read the times in
/// whole seconds): cycles 1 ..= 85 in a state file the logger started at
/// 2026-11-27T15:31:46Z with cycle 1. Another program loaded at 2 and an alarm at 3, before
/// the cut; spur-z17-m5 loaded at 5, START at 10; pass 1 at 11 ..= 33 (to the start 11 ..=
/// 15, the cut 16 ..= 30, the fault's retract 31 ..= 33: the alarm at 31); stood in the fault
/// 34 ..= 60 (cleared and reset at 40, CONTINUE at 60); pass 1 again at 61 ..= 80 (the
/// cut 66 ..= 75); the cycle done at 81.
fn continued_cut(dir: &Path) {
    let events = [
        loaded(1, 2, "other.toml", None),
        alarm(2, 3),
        event(3, 4, event_kind::ALARM_CLEARED, 0),
        loaded(
            4,
            5,
            "config/programs/spur-z17-m5.toml",
            Some("Thesis worst case, spur z17 m5, 42CrMo4"),
        ),
        event(5, 10, event_kind::ACCEPTED, hob_ipc::command::START),
        event(6, 11, event_kind::PASS_STARTED, 1),
        alarm(7, 31),
        event(8, 40, event_kind::ALARM_CLEARED, 0),
        event(9, 40, event_kind::ACCEPTED, hob_ipc::command::RESET),
        event(10, 60, event_kind::ACCEPTED, hob_ipc::command::CONTINUE),
        event(11, 61, event_kind::PASS_STARTED, 1),
        event(12, 81, event_kind::CYCLE_DONE, 0),
    ];
    write(dir, &[], &events);
    let state = |cycle: u64| match cycle {
        11..=15 | 61..=65 => (State::ToStart, 1),
        16..=30 | 66..=75 => (State::Cut, 1),
        31..=33 => (State::FaultRetract, 1),
        34..=39 => (State::Faulted, 0),
        76..=80 => (State::Retract, 1),
        _ => (State::Idle, 0),
    };
    let mut file = header("t", 1_795_793_506).into_bytes();
    for cycle in 1..=85 {
        let (st, pass) = state(cycle);
        encode(
            &StateSample {
                sync_time_ns: cycle * 1_000_000_000,
                state: st.code(),
                ..sample(cycle, pass, 0.5)
            },
            &mut file,
        );
    }
    std::fs::write(dir.join("state-000001.hoblog"), file).unwrap();
}

#[test]
fn the_report_of_a_cut_continued_after_a_fault_names_its_program_part_date_and_alarms() {
    let dir = log_dir("continued");
    continued_cut(&dir);
    // The cut as the HMI asks for it: from the accepted START to the cycle done.
    let r = report_cycles(&dir, 10, 81).unwrap();
    let text = hob_logger::export::report_text(&dir, &r);
    let whole = report(&dir).unwrap();
    let whole_text = hob_logger::export::report_text(&dir, &whole);
    let _ = std::fs::remove_dir_all(&dir);
    let lines: Vec<&str> = text.lines().collect();
    let has = |l: &str| assert!(lines.contains(&l), "no line {l:?} in:\n{text}");
    has("program: spur-z17-m5.toml (loaded 2026-11-27T15:31:50Z, cycle 5)");
    has("part: Thesis worst case, spur z17 m5, 42CrMo4");
    has("date: 2026-11-27T15:31:55Z to 2026-11-27T15:33:06Z (UTC, the logger's clock, to about a second)");
    assert!(
        text.contains("\noperator: not recorded (no command carries who gave it"),
        "{text}"
    );
    // The cut's alarm and what followed, in order; not the alarm before the cut.
    let from = lines.iter().position(|l| l.starts_with("alarms: ")).unwrap();
    assert_eq!(
        lines[from..from + 5],
        [
            "alarms: 1 raised; the alarms, clearings, resets, stops and continues of the cut:",
            "  2026-11-27T15:32:16Z, cycle 31: ALARM drive fault Y",
            "  2026-11-27T15:32:25Z, cycle 40: alarm cleared",
            "  2026-11-27T15:32:25Z, cycle 40: accepted: reset",
            "  2026-11-27T15:32:45Z, cycle 60: accepted: continue",
        ],
        "{text}"
    );
    assert!(lines[from + 5].starts_with("durations: cut s: "), "{text}");
    // The pass: 25 s at feed, 43 s of its own cycles; the 27 s stood in the fault counted
    // apart, in neither.
    let p = &r.passes[0];
    assert_eq!(
        (p.cut_time_s, p.pass_time_s, p.stood_s),
        (25.0, 43.0, 27.0),
        "{p:?}"
    );
    let pass_line = lines
        .iter()
        .find(|l| l.starts_with("   1 "))
        .unwrap_or_else(|| panic!("{text}"));
    let f: Vec<&str> = pass_line.split_whitespace().collect();
    assert_eq!(f[..4], ["1", "25.0", "43.0", "27.0"], "{text}");
    // The whole recording: both programs, both alarms.
    assert!(
        whole_text.contains("\nprograms: other.toml (loaded 2026-11-27T15:31:47Z, cycle 2); then spur-z17-m5.toml (loaded 2026-11-27T15:31:50Z, cycle 5)\n"),
        "{whole_text}"
    );
    assert!(
        whole_text.contains("\nparts: not named (the program's [workpiece] has no name); then Thesis worst case, spur z17 m5, 42CrMo4\n"),
        "{whole_text}"
    );
    assert!(whole_text.contains("\nalarms: 2 raised;"), "{whole_text}");
    assert!(
        whole_text.contains("\ndate: 2026-11-27T15:31:46Z to 2026-11-27T15:33:10Z"),
        "{whole_text}"
    );
}

#[test]
fn a_recording_that_names_no_program_says_so() {
    let dir = log_dir("unnamed");
    // A hob-rt that did not name its program; no events at all in a second log.
    write(
        &dir,
        &[sample(1, 1, 0.1), sample(2, 1, 0.1)],
        &[event(1, 1, event_kind::PROGRAM_LOADED, 0)],
    );
    let unnamed = hob_logger::export::report_text(&dir, &report(&dir).unwrap());
    std::fs::write(dir.join("events.log"), "").unwrap();
    let none = hob_logger::export::report_text(&dir, &report(&dir).unwrap());
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        unnamed.contains("\nprogram: not named (loaded ")
            && unnamed.contains("by a hob-rt that did not name its programs)\npart: not recorded\n"),
        "{unnamed}"
    );
    assert!(
        none.contains(
            "\nprogram: not recorded (no program loaded in the events recorded before or in the cut"
        ),
        "{none}"
    );
    assert!(none.contains("\nalarms: none\n"), "{none}");
}
