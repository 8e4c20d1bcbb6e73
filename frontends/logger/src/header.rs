//! The head of a cut's report: the program and part loaded for it, when it ran, who
//! commanded it, and its alarms, from the recording alone: the loop's events
//! (`events.log`) and the state files' clocks.
//!
//! - The program and the part: the loop's PROGRAM_LOADED event names the program file and
//!   its workpiece's `name` ([`hob_ipc::codec::program_loaded_text`]); a `hob-rt` from
//!   before that names none, and a program loaded before the logger ran is not in the
//!   recording: the report says so.
//! - The date: the logger's wall clock at each state file's start
//!   ([`crate::format::FileClock`]) and the loop's SYNC time since, UTC, to about a second.
//! - The operator: not recorded. No command carries who gave it: the HMI and the CLI send
//!   the same request whoever stands at the machine, and `hob-gateway` writes the account a
//!   command came through (the HMI's own for everything done on the HMI) to its journal,
//!   not to the loop.
//! - The alarms: every alarm event of the cut with its time and words, and the events that
//!   dealt with them (alarm cleared, the accepted reset, stop and continue).

use crate::error::Error;
use crate::format::{FileClock, LoggedEvent};
use hob_ipc::{StateSample, codec, command, event_kind};
use serde::Serialize;

/// What the report covers: the whole recording, or the cycles `first ..= last` of the
/// newest run of `hob-rt` that holds any (one cut).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Span {
    Whole,
    Cycles(u64, u64),
}

/// The head of a cut's report.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CutHeader {
    /// The programs loaded for the cut, in order: the one loaded last before its first
    /// cycle and any loaded in it (a whole recording's). Empty: none in the recording.
    pub programs: Vec<LoadedProgram>,
    /// When the cut's first and last recorded cycles ran, UTC (`YYYY-MM-DDTHH:MM:SSZ`, to
    /// about a second); none where the state files give no clock.
    pub from_utc: Option<String>,
    pub to_utc: Option<String>,
    /// Who commanded the cut: nobody's name is recorded (none, always; see the module).
    pub operator: Option<String>,
    /// The alarms raised in the cut and what dealt with them, in order.
    pub alarms: Vec<CutEvent>,
    /// Why the events could not be read (then the programs and alarms are not known).
    pub events_unread: Option<String>,
}

/// A program loaded, as its PROGRAM_LOADED event names it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LoadedProgram {
    /// The program file's name; none where `hob-rt` did not name it.
    pub file: Option<String>,
    /// The workpiece's `name` of the program; none where it has none (or is not named).
    pub part: Option<String>,
    pub cycle: u64,
    pub utc: Option<String>,
}

/// An event of the cut's alarms: an alarm, its clearing, a reset, stop or continue.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CutEvent {
    pub cycle: u64,
    pub utc: Option<String>,
    /// An alarm raised (not what dealt with one).
    pub alarm: bool,
    /// The event's words as recorded.
    pub text: String,
}

/// The words of the operator line: nobody's name is in the recording.
pub const OPERATOR_NOT_RECORDED: &str = "not recorded (no command carries who gave it; hob-gateway's journal names the account each command came through, for the HMI the HMI's own)";

/// The commands that deal with an alarm or break a cut off, as their accepted event reads.
const DEALT_WITH: [u32; 3] = [command::RESET, command::STOP, command::CONTINUE];

impl CutHeader {
    /// The head of the report of `states` (the report's samples, in order; `clocks`: where
    /// each file's samples begin and its clock), from the recording's `events`.
    pub(crate) fn of(
        events: Result<Vec<LoggedEvent>, Error>,
        span: Span,
        states: &[StateSample],
        clocks: &[(usize, Option<FileClock>)],
        period_s: f64,
    ) -> CutHeader {
        let t = Timeline::new(states, clocks, period_s);
        let last = states.len().checked_sub(1);
        let mut h = CutHeader {
            from_utc: last.and_then(|_| t.unix_s_of(0)).and_then(utc),
            to_utc: last.and_then(|i| t.unix_s_of(i)).and_then(utc),
            ..CutHeader::default()
        };
        let events = match events {
            Ok(e) => e,
            Err(e) => {
                h.events_unread = Some(e.to_string());
                return h;
            }
        };
        // The events of the span.
        let chosen: Vec<&LoggedEvent> = match span {
            Span::Whole => events.iter().collect(),
            Span::Cycles(first, last) => {
                let run = events
                    .iter()
                    .filter(|e| (first..=last).contains(&e.cycle))
                    .map(|e| e.run)
                    .next_back();
                let in_run: Vec<&LoggedEvent> = events
                    .iter()
                    .filter(|e| Some(e.run) == run && e.cycle <= last)
                    .collect();
                // The program loaded last before the cut, then the cut's own events.
                let before = in_run
                    .iter()
                    .rposition(|e| e.cycle < first && codec::loaded_program(&e.text).is_some());
                in_run
                    .iter()
                    .enumerate()
                    .filter(|(i, e)| e.cycle >= first || Some(*i) == before)
                    .map(|(_, e)| *e)
                    .collect()
            }
        };
        // The run of the samples an event is in: the samples of one cut are one run.
        let run_of = |e: &LoggedEvent| if span == Span::Whole { e.run } else { 0 };
        let at = |e: &LoggedEvent| t.unix_s_at(run_of(e), e.cycle).and_then(utc);
        let dealt_with: Vec<String> = DEALT_WITH
            .iter()
            .map(|&c| format!("accepted: {}", codec::command_name(c)))
            .collect();
        for e in chosen {
            if let Some((file, part)) = codec::loaded_program(&e.text) {
                h.programs.push(LoadedProgram {
                    file,
                    part,
                    cycle: e.cycle,
                    utc: at(e),
                });
            } else if e.is_alarm() || e.kind == event_kind::ALARM_CLEARED || dealt_with.contains(&e.text) {
                h.alarms.push(CutEvent {
                    cycle: e.cycle,
                    utc: at(e),
                    alarm: e.is_alarm(),
                    text: e.text.clone(),
                });
            }
        }
        h
    }

    /// The head as the report prints it, line by line (`hob log report`; the HMI shows
    /// the same lines).
    pub fn lines(&self) -> Vec<String> {
        let mut o = Vec::new();
        let when = |utc: &Option<String>, cycle: u64| match utc {
            Some(u) => format!("{u}, cycle {cycle}"),
            None => format!("cycle {cycle}"),
        };
        let unknown = match &self.events_unread {
            Some(why) => format!("not known (the events were not read: {why})"),
            None => "not recorded (no program loaded in the events recorded before or in the cut: loaded before the logger ran)".to_string(),
        };
        let program = |p: &LoadedProgram| match &p.file {
            Some(f) => format!("{f} (loaded {})", when(&p.utc, p.cycle)),
            None => format!(
                "not named (loaded {}, by a hob-rt that did not name its programs)",
                when(&p.utc, p.cycle)
            ),
        };
        let part = |p: &LoadedProgram| match (&p.file, &p.part) {
            (_, Some(part)) => part.clone(),
            (Some(_), None) => "not named (the program's [workpiece] has no name)".to_string(),
            (None, None) => "not recorded".to_string(),
        };
        match self.programs.as_slice() {
            [] => {
                o.push(format!("program: {unknown}"));
                o.push("part: not recorded".to_string());
            }
            [p] => {
                o.push(format!("program: {}", program(p)));
                o.push(format!("part: {}", part(p)));
            }
            ps => {
                let list = |f: &dyn Fn(&LoadedProgram) -> String| {
                    ps.iter().map(f).collect::<Vec<_>>().join("; then ")
                };
                o.push(format!("programs: {}", list(&program)));
                o.push(format!("parts: {}", list(&part)));
            }
        }
        o.push(match (&self.from_utc, &self.to_utc) {
            (Some(a), Some(b)) => format!("date: {a} to {b} (UTC, the logger's clock, to about a second)"),
            _ => "date: not recorded (the state files' headers give no clock)".to_string(),
        });
        o.push(format!(
            "operator: {}",
            self.operator.as_deref().unwrap_or(OPERATOR_NOT_RECORDED)
        ));
        let raised = self.alarms.iter().filter(|a| a.alarm).count();
        if self.events_unread.is_some() {
            o.push("alarms: not known (the events were not read)".to_string());
        } else if self.alarms.is_empty() {
            o.push("alarms: none".to_string());
        } else {
            o.push(format!(
                "alarms: {raised} raised; the alarms, clearings, resets, stops and continues of the cut:"
            ));
            for a in &self.alarms {
                o.push(format!("  {}: {}", when(&a.utc, a.cycle), a.text));
            }
        }
        o
    }
}

/// The report's samples on the wall clock: their runs of `hob-rt` and their files' clocks.
struct Timeline<'a> {
    states: &'a [StateSample],
    clocks: &'a [(usize, Option<FileClock>)],
    /// Where each run of `hob-rt` begins (its cycle counter starts again).
    run_starts: Vec<usize>,
    period_s: f64,
}

impl<'a> Timeline<'a> {
    fn new(states: &'a [StateSample], clocks: &'a [(usize, Option<FileClock>)], period_s: f64) -> Self {
        let mut run_starts = vec![0];
        run_starts.extend((1..states.len()).filter(|&i| states[i].cycle <= states[i - 1].cycle));
        Self {
            states,
            clocks,
            run_starts,
            period_s,
        }
    }

    /// The wall clock of sample `i`, seconds since 1970 UTC.
    fn unix_s_of(&self, i: usize) -> Option<f64> {
        let k = self.clocks.partition_point(|(at, _)| *at <= i);
        let (_, clock) = self.clocks.get(k.checked_sub(1)?)?;
        Some(clock.as_ref()?.unix_s(self.states.get(i)?.sync_time_ns))
    }

    /// The wall clock of cycle `cycle` of run `run`: from its sample, else from the sample
    /// nearest before it (the first when it is before them all) and the cycle period.
    fn unix_s_at(&self, run: u32, cycle: u64) -> Option<f64> {
        let run = usize::try_from(run).ok()?;
        let from = *self.run_starts.get(run)?;
        let to = self.run_starts.get(run + 1).copied().unwrap_or(self.states.len());
        let k = self.states[from..to].partition_point(|s| s.cycle <= cycle);
        let i = from + k.saturating_sub(1);
        let base = self.unix_s_of(i)?;
        Some(base + (cycle as f64 - self.states[i].cycle as f64) * self.period_s)
    }
}

/// Seconds since 1970 UTC as `YYYY-MM-DDTHH:MM:SSZ` (whole seconds; none before 1970).
fn utc(unix_s: f64) -> Option<String> {
    if !(unix_s >= 0.0 && unix_s.is_finite()) {
        return None;
    }
    let s = unix_s.floor() as u64;
    let (y, m, d) = civil_from_days(s / 86_400);
    let rem = s % 86_400;
    Some(format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    ))
}

/// Days since 1970-01-01 to (year, month, day), proleptic Gregorian (H. Hinnant's
/// algorithm, as `hob_store::utc`, which the logger may not link: it brings the set-up).
fn civil_from_days(days: u64) -> (u64, u64, u64) {
    let z = days + 719_468;
    let era = z / 146_097;
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + u64::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_times_read_as_the_calendar_has_them() {
        assert_eq!(utc(0.0).as_deref(), Some("1970-01-01T00:00:00Z"));
        // 2000-02-29 (a leap day of a century divisible by 400) and 2026-11-27 15:31:46.
        assert_eq!(utc(951_782_400.0).as_deref(), Some("2000-02-29T00:00:00Z"));
        assert_eq!(utc(1_795_793_506.9).as_deref(), Some("2026-11-27T15:31:46Z"));
        assert_eq!(utc(-1.0), None);
        assert_eq!(utc(f64::NAN), None);
    }
}
