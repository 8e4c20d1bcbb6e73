//! State records: the field list (names and types, written into every file's header) and
//! the encoder and decoder, which must follow it.

use crate::error::Error;
use hob_ipc::{AlarmCode, AxisSample, EventSample, StateSample};
use std::path::{Path, PathBuf};

/// Field names and types in record order.
///
/// The overrides took the first two of six reserved words: a file written before that
/// names them `reserved0` and `reserved1` (u64, always 0) and is read with its overrides
/// not recorded (see [`read_dir_states`]). The pitch compensation's state took the third
/// (`reserved2` before: read as none).
pub const FIELDS: [(&str, &str); 42] = [
    ("cycle", "u64"),
    ("sync_time_ns", "u64"),
    ("state", "u32"),
    ("hold", "u8"),
    ("program_loaded", "u8"),
    ("drives_enabled", "u8"),
    ("drives_silent", "u8"),
    ("pass", "u32"),
    ("passes_total", "u32"),
    ("tooth", "u32"),
    ("coupling", "u32"),
    ("table_deg", "f64"),
    ("table_cmd_deg", "f64"),
    ("x_mm", "f64"),
    ("x_cmd_mm", "f64"),
    ("y_mm", "f64"),
    ("y_cmd_mm", "f64"),
    ("spindle_deg", "f64"),
    ("spindle_rpm", "f64"),
    ("spindle_set_rpm", "f64"),
    ("sync_err_arcsec", "f64"),
    ("ccc_arcsec", "f64"),
    ("alarm_code", "u32"),
    ("alarm_axis", "u8"),
    ("alarm_end", "u8"),
    ("alarm_value_a", "f64"),
    ("alarm_value_b", "f64"),
    ("digital_inputs", "u32"),
    ("digital_outputs", "u32"),
    ("io_valid", "u8"),
    ("wake_latency_ns", "u32"),
    ("compute_ns", "u32"),
    ("overruns", "u64"),
    ("events_lost", "u64"),
    ("pitch_radius_mm", "f64"),
    ("normal_module_mm", "f64"),
    ("feed_override_percent", "f64"),
    ("spindle_override_percent", "f64"),
    ("pitch_compensation", "u64"),
    ("reserved3", "u64"),
    ("reserved4", "u64"),
    ("reserved5", "u64"),
];

/// Reserved words at the end of a record (written 0).
const RESERVED_WORDS: usize = 3;

/// Index in [`FIELDS`] of the pitch compensation's state (a word that was `reserved2`,
/// always 0 before: a file written before reads as "none", which it was).
const PITCH_COMPENSATION_AT: usize = 38;

/// Index in [`FIELDS`] of the feed override, the first of the two override words.
const OVERRIDES_AT: usize = 36;

fn width(t: &str) -> usize {
    match t {
        "u8" => 1,
        "u32" => 4,
        _ => 8,
    }
}

/// Bytes of one record.
pub fn record_bytes() -> usize {
    FIELDS.iter().map(|(_, t)| width(t)).sum()
}

/// Appends one record.
pub fn encode(s: &StateSample, out: &mut Vec<u8>) {
    let u8s = |o: &mut Vec<u8>, v: u8| o.push(v);
    let u32s = |o: &mut Vec<u8>, v: u32| o.extend_from_slice(&v.to_le_bytes());
    let u64s = |o: &mut Vec<u8>, v: u64| o.extend_from_slice(&v.to_le_bytes());
    let f64s = |o: &mut Vec<u8>, v: f64| o.extend_from_slice(&v.to_le_bytes());
    u64s(out, s.cycle);
    u64s(out, s.sync_time_ns);
    u32s(out, s.state);
    u8s(out, s.hold);
    u8s(out, s.program_loaded);
    u8s(out, s.drives_enabled);
    u8s(out, s.drives_silent);
    u32s(out, s.pass);
    u32s(out, s.passes_total);
    u32s(out, s.tooth);
    u32s(out, s.coupling);
    for a in [s.table_deg, s.x_mm, s.y_mm] {
        f64s(out, a.actual);
        f64s(out, a.command);
    }
    f64s(out, s.spindle_deg);
    f64s(out, s.spindle_rpm);
    f64s(out, s.spindle_set_rpm);
    f64s(out, s.sync_error_arcsec);
    f64s(out, s.ccc_arcsec);
    u32s(out, s.alarm.code);
    u8s(out, s.alarm.axis);
    u8s(out, s.alarm.end);
    f64s(out, s.alarm.value_a);
    f64s(out, s.alarm.value_b);
    u32s(out, s.digital_inputs);
    u32s(out, s.digital_outputs);
    u8s(out, s.io_valid);
    u32s(out, s.wake_latency_ns);
    u32s(out, s.compute_ns);
    u64s(out, s.overruns);
    u64s(out, s.events_lost);
    f64s(out, s.pitch_radius_mm);
    f64s(out, s.normal_module_mm);
    f64s(out, s.feed_override_percent);
    f64s(out, s.spindle_override_percent);
    u64s(out, u64::from(s.pitch_compensation));
    for _ in 0..RESERVED_WORDS {
        u64s(out, 0);
    }
}

struct Cursor<'a> {
    b: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut a = [0u8; N];
        a.copy_from_slice(&self.b[self.at..self.at + N]);
        self.at += N;
        a
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    fn axis(&mut self) -> AxisSample {
        AxisSample {
            actual: self.f64(),
            command: self.f64(),
        }
    }
}

/// Decodes one record (`None` if `b` is shorter than a record).
pub fn decode(b: &[u8]) -> Option<StateSample> {
    if b.len() < record_bytes() {
        return None;
    }
    let mut c = Cursor { b, at: 0 };
    let mut s = StateSample {
        cycle: c.u64(),
        sync_time_ns: c.u64(),
        state: c.u32(),
        hold: c.u8(),
        program_loaded: c.u8(),
        drives_enabled: c.u8(),
        drives_silent: c.u8(),
        pass: c.u32(),
        passes_total: c.u32(),
        tooth: c.u32(),
        coupling: c.u32(),
        table_deg: c.axis(),
        x_mm: c.axis(),
        y_mm: c.axis(),
        spindle_deg: c.f64(),
        spindle_rpm: c.f64(),
        spindle_set_rpm: c.f64(),
        sync_error_arcsec: c.f64(),
        ccc_arcsec: c.f64(),
        ..StateSample::default()
    };
    s.alarm = AlarmCode {
        code: c.u32(),
        axis: c.u8(),
        end: c.u8(),
        // Not in the record: a recorded alarm tells its reaction in every case.
        situation: hob_ipc::situation::UNKNOWN,
        _pad: [0; 1],
        value_a: c.f64(),
        value_b: c.f64(),
    };
    s.digital_inputs = c.u32();
    s.digital_outputs = c.u32();
    s.io_valid = c.u8();
    s.wake_latency_ns = c.u32();
    s.compute_ns = c.u32();
    s.overruns = c.u64();
    s.events_lost = c.u64();
    s.pitch_radius_mm = c.f64();
    s.normal_module_mm = c.f64();
    s.feed_override_percent = c.f64();
    s.spindle_override_percent = c.f64();
    s.pitch_compensation = u8::try_from(c.u64()).unwrap_or(u8::MAX);
    Some(s)
}

/// A field list as a header holds it: `[["cycle","u64"],...]`.
fn fields_json(fields: &[(&str, &str)]) -> serde_json::Value {
    let fields: Vec<[&str; 2]> = fields.iter().map(|&(n, t)| [n, t]).collect();
    serde_json::json!(fields)
}

/// Whether a header's field list records the overrides: `Some(true)` for this writer's
/// list, `Some(false)` for the list written before the overrides were recorded (the same
/// record with those two words reserved), `None` for any other list.
///
/// The list written before the pitch compensation was recorded names its word `reserved2`
/// (always 0): read the same, its samples say "none".
fn overrides_recorded(fields: &serde_json::Value) -> Option<bool> {
    let mut before_compensation = FIELDS;
    before_compensation[PITCH_COMPENSATION_AT] = ("reserved2", "u64");
    let mut before = before_compensation;
    before[OVERRIDES_AT] = ("reserved0", "u64");
    before[OVERRIDES_AT + 1] = ("reserved1", "u64");
    if *fields == fields_json(&FIELDS) || *fields == fields_json(&before_compensation) {
        Some(true)
    } else if *fields == fields_json(&before) {
        Some(false)
    } else {
        None
    }
}

/// The header line of a state file.
pub fn header(instance: &str, started_unix_s: u64) -> String {
    let h = serde_json::json!({
        "format": "hob-state-log",
        "version": 1,
        "record_bytes": record_bytes(),
        "fields": fields_json(&FIELDS),
        "instance": instance,
        "started_unix_s": started_unix_s,
    });
    format!("{h}\n")
}

/// The state files of a log directory, in order.
pub fn state_files(dir: &Path) -> std::io::Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("state-") && n.ends_with(".hoblog"))
        })
        .collect();
    files.sort();
    Ok(files)
}

/// Every state sample of a log directory, in order. Refuses files whose header does not
/// describe this reader's records. A file written before the overrides were recorded
/// (its header names their words `reserved0` and `reserved1`) gives its samples NaN
/// overrides: not recorded, never 0 %.
pub fn read_dir_states(dir: &Path) -> Result<Vec<StateSample>, Error> {
    let mut out = Vec::new();
    for_each_state(dir, |s| out.push(s))?;
    Ok(out)
}

/// Every state sample of a log directory, in order, handed to `f` one by one (a reader of
/// a part of a long log holds only that part), read as [`read_dir_states`] reads them.
pub fn for_each_state(dir: &Path, mut f: impl FnMut(StateSample)) -> Result<(), Error> {
    for_each_state_clocked(dir, |s, _| f(s))
}

/// The wall clock of a state file: the logger's clock when it started the file
/// (`started_unix_s` of its header, whole seconds) and the SYNC time of the file's first
/// record. The logger starts a file when it writes its first records, at most a flush
/// (200 ms) after it received them: a sample's time from it is good to about a second.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FileClock {
    pub started_unix_s: u64,
    pub first_sync_ns: u64,
}

impl FileClock {
    /// The wall-clock time (seconds since 1970-01-01 UTC) of a sample of this file with SYNC
    /// time `sync_ns` (the loop's monotonic clock).
    pub fn unix_s(&self, sync_ns: u64) -> f64 {
        self.started_unix_s as f64 + (sync_ns as f64 - self.first_sync_ns as f64) * 1e-9
    }
}

/// [`for_each_state`], each sample with its file's clock (none where the header has no
/// `started_unix_s`).
pub fn for_each_state_clocked(
    dir: &Path,
    mut f: impl FnMut(StateSample, Option<FileClock>),
) -> Result<(), Error> {
    let files = state_files(dir).map_err(|error| Error::Io {
        path: dir.to_path_buf(),
        error,
    })?;
    if files.is_empty() {
        return Err(Error::NotALog {
            dir: dir.to_path_buf(),
        });
    }
    for path in files {
        let bytes = std::fs::read(&path).map_err(|error| Error::Io {
            path: path.clone(),
            error,
        })?;
        let started_unix_s = header_json(&bytes).and_then(|h| h["started_unix_s"].as_u64());
        let mut clock = None;
        read_states(&bytes, &path.display().to_string(), &mut |s: StateSample| {
            if clock.is_none() {
                clock = started_unix_s.map(|started_unix_s| FileClock {
                    started_unix_s,
                    first_sync_ns: s.sync_time_ns,
                });
            }
            f(s, clock);
        })?;
    }
    Ok(())
}

/// A state file's header, as JSON (none when it is not: [`read_states`] says why).
fn header_json(bytes: &[u8]) -> Option<serde_json::Value> {
    let nl = bytes.iter().position(|&b| b == b'\n')?;
    serde_json::from_slice(&bytes[..nl]).ok()
}

/// [`read_states`] with its error as text: the form the fuzz harness
/// (`bench/fuzz-harness`) checks the reasons in.
pub fn states_in_file(bytes: &[u8], name: &str, f: &mut impl FnMut(StateSample)) -> Result<(), String> {
    read_states(bytes, name, f).map_err(|e| e.to_string())
}

/// The state samples of one state file's bytes (`name` for the messages), handed to `f`:
/// refused when its header does not describe this reader's records; a partial last record
/// (a file cut short) is dropped.
pub fn read_states(bytes: &[u8], name: &str, f: &mut impl FnMut(StateSample)) -> Result<(), Error> {
    let file = || name.to_string();
    let nl = bytes
        .iter()
        .position(|&b| b == b'\n')
        .ok_or_else(|| Error::NoHeaderLine { file: file() })?;
    let h: serde_json::Value =
        serde_json::from_slice(&bytes[..nl]).map_err(|error| Error::HeaderNotJson { file: file(), error })?;
    if h["format"] != "hob-state-log" || h["version"] != 1 || h["record_bytes"] != record_bytes() {
        return Err(Error::OtherFormat {
            file: file(),
            header: h,
            known_record_bytes: record_bytes(),
        });
    }
    let recorded = overrides_recorded(&h["fields"]).ok_or_else(|| Error::OtherFields {
        file: file(),
        fields: h["fields"].clone(),
    })?;
    // A file cut short by a killed logger ends in a partial record: dropped.
    for rec in bytes[nl + 1..].chunks_exact(record_bytes()) {
        if let Some(mut s) = decode(rec) {
            if !recorded {
                s.feed_override_percent = f64::NAN;
                s.spindle_override_percent = f64::NAN;
            }
            f(s);
        }
    }
    Ok(())
}

/// An event's line in `events.log`: `seq cycle kind text`, the text as
/// [`hob_ipc::codec::event_text`] words it (a line break in it written as `\n`, so that
/// every event is one line).
pub fn event_line(e: &EventSample) -> String {
    let text = hob_ipc::codec::event_text(e).replace('\n', "\\n");
    if e.kind == hob_ipc::event_kind::ALARM {
        // The alarm's code and arguments after the kind (`kind@code/axis/end/a/b`): a frontend
        // reading the log back gives the same reaction, remedy and way to continue as for
        // an alarm it saw live. f64's Display reads back to the same value.
        let a = &e.alarm;
        format!(
            "{} {} {}@{}/{}/{}/{}/{} {text}",
            e.seq, e.cycle, e.kind, a.code, a.axis, a.end, a.value_a, a.value_b
        )
    } else if e.a != 0 || e.b != 0 {
        // The event's arguments after the kind (`kind#a/b`: an axis, a command's code):
        // the event log's filters read its axis from them.
        format!("{} {} {}#{}/{} {text}", e.seq, e.cycle, e.kind, e.a, e.b)
    } else {
        format!("{} {} {} {text}", e.seq, e.cycle, e.kind)
    }
}

/// An `events.log` line read back.
#[derive(Debug, Clone, PartialEq)]
pub struct EventLine {
    pub seq: u64,
    pub cycle: u64,
    pub kind: u32,
    /// The alarm's code and arguments, on an alarm's line (none on a line written before
    /// they were recorded).
    pub alarm: Option<AlarmCode>,
    /// Another event's arguments `a` and `b` (none when both were 0, or on a line written
    /// before they were recorded).
    pub args: Option<(u32, u32)>,
    pub text: String,
}

/// The numbers and text of an `events.log` line (without its line end); `None` when it is
/// not `seq cycle kind[@code/axis/end/a/b|#a/b] text`.
pub fn parse_event_line(line: &str) -> Option<EventLine> {
    let mut parts = line.splitn(4, ' ');
    let seq = parts.next()?.parse().ok()?;
    let cycle = parts.next()?.parse().ok()?;
    let kind_field = parts.next()?;
    let (kind_field, args) = match kind_field.split_once('#') {
        None => (kind_field, None),
        Some((kind, args)) => {
            let (a, b) = args.split_once('/')?;
            (kind, Some((a.parse().ok()?, b.parse().ok()?)))
        }
    };
    let (kind, alarm) = match kind_field.split_once('@') {
        None => (kind_field.parse().ok()?, None),
        Some((kind, alarm)) => {
            let mut f = alarm.split('/');
            let code = AlarmCode {
                code: f.next()?.parse().ok()?,
                axis: f.next()?.parse().ok()?,
                end: f.next()?.parse().ok()?,
                value_a: f.next()?.parse().ok()?,
                value_b: f.next()?.parse().ok()?,
                ..AlarmCode::default()
            };
            if f.next().is_some() {
                return None;
            }
            (kind.parse().ok()?, Some(code))
        }
    };
    Some(EventLine {
        seq,
        cycle,
        kind,
        alarm,
        args,
        text: parts.next().unwrap_or("").to_string(),
    })
}

/// An event as the logger recorded it (`events.log`).
#[derive(Debug, Clone, PartialEq)]
pub struct LoggedEvent {
    /// Which run of `hob-rt` in the file, from 0 (its event numbers and cycles start again
    /// at every start).
    pub run: u32,
    pub seq: u64,
    pub cycle: u64,
    /// The event's kind (`hob_ipc::event_kind`).
    pub kind: u32,
    /// The event in words, as `hob_ipc::codec::event_text` gave it when it was recorded.
    pub text: String,
    /// An alarm's code and arguments (none on another event, or on an alarm's line written
    /// before they were recorded): the reaction, remedy and way to continue follow from it
    /// (`hob_ipc::codec::Fault`).
    pub alarm: Option<hob_ipc::AlarmCode>,
    /// Another event's arguments `a` and `b` (an axis, a command's code; 0 when not
    /// recorded).
    pub args: (u32, u32),
}

impl LoggedEvent {
    pub fn is_alarm(&self) -> bool {
        self.kind == hob_ipc::event_kind::ALARM
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_round_trip_and_match_the_header() {
        let mut s = StateSample {
            cycle: 42,
            sync_time_ns: 7,
            state: 11,
            hold: 1,
            pass: 2,
            sync_error_arcsec: -1.25,
            wake_latency_ns: 33,
            pitch_radius_mm: 44.5,
            feed_override_percent: 80.0,
            spindle_override_percent: 110.0,
            ..StateSample::default()
        };
        s.alarm.code = 5;
        s.alarm.axis = 2;
        s.alarm.value_a = 0.3;
        s.y_mm.command = 12.5;
        let mut b = Vec::new();
        encode(&s, &mut b);
        assert_eq!(b.len(), record_bytes());
        assert_eq!(decode(&b), Some(s));
        assert_eq!(decode(&b[1..]), None);
    }

    /// A directory holding one state file: `header` then the records of `samples`.
    fn log_dir(name: &str, header: &str, samples: &[StateSample]) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("hob-format-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let mut b = header.as_bytes().to_vec();
        for s in samples {
            encode(s, &mut b);
        }
        std::fs::write(dir.join("state-000001.hoblog"), b).unwrap();
        dir
    }

    #[test]
    fn overrides_are_recorded_and_older_files_read_them_as_not_recorded() {
        let s = StateSample {
            cycle: 1,
            feed_override_percent: 85.0,
            spindle_override_percent: 120.0,
            pitch_compensation: hob_ipc::pitch_compensation::ON,
            ..StateSample::default()
        };
        let now = header("t", 0);
        let dir = log_dir("now", &now, &[s]);
        let read = read_dir_states(&dir).unwrap();
        assert_eq!(read[0].feed_override_percent, 85.0);
        assert_eq!(read[0].spindle_override_percent, 120.0);
        assert_eq!(read[0].pitch_compensation, hob_ipc::pitch_compensation::ON);
        let _ = std::fs::remove_dir_all(&dir);

        // Written before the pitch compensation was: its word reserved (0), read as none.
        let before_compensation = now.replace(r#"["pitch_compensation","u64"]"#, r#"["reserved2","u64"]"#);
        assert_ne!(before_compensation, now);
        let uncompensated = StateSample {
            pitch_compensation: 0,
            ..s
        };
        let dir = log_dir("before-compensation", &before_compensation, &[uncompensated]);
        let read = read_dir_states(&dir).unwrap();
        assert_eq!(read[0].feed_override_percent, 85.0);
        assert_eq!(read[0].pitch_compensation, hob_ipc::pitch_compensation::NONE);
        let _ = std::fs::remove_dir_all(&dir);

        // Written before the overrides were: the same record, those words reserved (0).
        let before = before_compensation
            .replace(r#"["feed_override_percent","f64"]"#, r#"["reserved0","u64"]"#)
            .replace(r#"["spindle_override_percent","f64"]"#, r#"["reserved1","u64"]"#);
        assert_ne!(before, now);
        let old = StateSample {
            feed_override_percent: 0.0,
            spindle_override_percent: 0.0,
            pitch_compensation: 0,
            ..s
        };
        let dir = log_dir("before", &before, &[old]);
        let read = read_dir_states(&dir).unwrap();
        assert_eq!(read[0].cycle, 1);
        assert!(read[0].feed_override_percent.is_nan(), "{:?}", read[0]);
        assert!(read[0].spindle_override_percent.is_nan(), "{:?}", read[0]);
        let _ = std::fs::remove_dir_all(&dir);

        // Any other field list is refused.
        let other = now.replace(r#"["spindle_override_percent","f64"]"#, r#"["reserved1","u64"]"#);
        let dir = log_dir("other", &other, &[s]);
        let e = read_dir_states(&dir).unwrap_err().to_string();
        assert!(e.contains("fields"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn an_alarm_line_carries_its_code_back_and_an_old_line_still_reads() {
        use hob_ipc::codec::Fault;
        let e = EventSample {
            seq: 17,
            cycle: 123_456,
            kind: hob_ipc::event_kind::ALARM,
            alarm: AlarmCode {
                code: Fault::FollowingError.code(),
                axis: 3,
                end: 0,
                value_a: 0.1 + 0.2,
                value_b: -1.0e-7,
                ..AlarmCode::default()
            },
            ..EventSample::default()
        };
        let line = event_line(&e);
        let read = parse_event_line(&line).expect(&line);
        assert_eq!((read.seq, read.cycle, read.kind), (17, 123_456, e.kind), "{line}");
        assert_eq!(read.alarm, Some(e.alarm), "{line}: every bit of the values back");
        assert_eq!(read.text, hob_ipc::codec::event_text(&e).replace('\n', "\\n"));
        // Another event: no code on the line.
        let other = EventSample {
            kind: hob_ipc::event_kind::STATE_CHANGED,
            ..e
        };
        assert_eq!(parse_event_line(&event_line(&other)).unwrap().alarm, None);
        // Another event's arguments: its axis for the event log's filters.
        let referenced = EventSample {
            kind: hob_ipc::event_kind::REFERENCED,
            a: 2,
            b: 7,
            ..e
        };
        let read = parse_event_line(&event_line(&referenced)).unwrap();
        assert_eq!(
            (read.kind, read.alarm, read.args),
            (referenced.kind, None, Some((2, 7)))
        );
        assert_eq!(read.text, hob_ipc::codec::event_text(&referenced));
        // A line written before the codes were: the same text, no code.
        let old = format!("17 123456 {} following error", e.kind);
        let read = parse_event_line(&old).unwrap();
        assert_eq!((read.alarm, read.text.as_str()), (None, "following error"));
        // A code cut short or with a field too many is no event line.
        for bad in [
            "1 2 3@4/3/0/0.5 text",
            "1 2 3@4/3/0/0.5/0/9 text",
            "1 2 3@x/3/0/0/0 text",
            "1 2 3@ text",
            "1 2 3#4 text",
            "1 2 3#4/x text",
        ] {
            assert_eq!(parse_event_line(bad), None, "{bad}");
        }
    }
}
