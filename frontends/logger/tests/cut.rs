//! One cut out of a recording, as a frontend asks for it: the report of a range of cycles
//! and the events of that range (its alarms among them), from a log the logger's writer
//! wrote, over restarts of the logger and of `hob-rt`.

#![allow(clippy::unwrap_used)]

use hob_ipc::codec::{self, Axis, Coupling, Fault, State};
use hob_ipc::{AlarmCode, EventSample, StateSample, event_kind, write_text};
use hob_logger::LogWriter;
use hob_logger::export::{LoggedEvent, events_in, read_events, report, report_cycles};
use hob_logger::format::header;
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
