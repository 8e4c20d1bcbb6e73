//! Writing a log directory: rotating state files, the event lines, the gaps, the totals.
//!
//! A write that fails (the disk full, an I/O error) never stops the recorder: what could
//! not be written is counted (`samples_unwritten`, `events_unwritten`), the state file
//! that failed is closed (its last whole record is its end: readers take whole records),
//! and from then on every [`LogWriter::flush`] tries a new state file. When one can be
//! written the recording resumes there, and `gaps.log` gets one line for the run of
//! cycles that is missing: `unwritten FIRST LAST COUNT`. The gap lines themselves are
//! kept in memory until they can be written.

use crate::format::{encode, header, record_bytes, state_files};
use hob_ipc::{EventSample, StateSample};
use serde_json::json;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Records per state file (5 min at 1 kHz) before the next file is started.
pub const ROTATE_RECORDS: u64 = 300_000;

/// Bytes of state records kept before they are written (at most one flush interval's).
const STATE_CHUNK: usize = 1 << 20;

/// What the logger has done so far.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LogStats {
    pub samples: u64,
    /// Samples the logger missed while running (gaps in the cycle counter): the target is 0.
    pub samples_lost: u64,
    /// Cycles between the end of an earlier log in this directory and this logger's first
    /// sample (the logger was not running): not counted as lost.
    pub samples_not_running: u64,
    /// Samples received but not written (a write failed: the disk full, an I/O error).
    pub samples_unwritten: u64,
    pub events: u64,
    pub events_lost: u64,
    /// Events received but not written.
    pub events_unwritten: u64,
    pub files: u64,
    /// `hob-rt` restarted (its cycle counter went back).
    pub service_restarts: u64,
}

/// Writing has been failing since a sample of `first_cycle`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Failing {
    /// The first and last cycle received and not written, and how many.
    pub first_cycle: Option<u64>,
    pub last_cycle: u64,
    pub count: u64,
    /// The error of the write that failed first, and of the latest retry.
    pub error: String,
    pub errno: i32,
}

#[derive(Debug)]
pub struct LogWriter {
    dir: PathBuf,
    instance: String,
    next_index: u64,
    in_file: u64,
    state: Option<File>,
    /// State records not yet written (the last of them is `last_cycle`'s).
    pending: Vec<u8>,
    events: Option<File>,
    /// Event lines not yet written, and how many.
    events_pending: Vec<u8>,
    events_pending_count: u64,
    gaps: Option<File>,
    /// Gap lines not yet written (kept until they can be: they say what is missing).
    gaps_pending: Vec<u8>,
    last_cycle: Option<u64>,
    last_event: Option<u64>,
    failing: Option<Failing>,
    pub stats: LogStats,
    /// Test builds: every write fails as on a full disk.
    #[cfg(test)]
    pub(crate) disk_full: bool,
}

fn index_of(p: &Path) -> Option<u64> {
    p.file_name()?
        .to_str()?
        .strip_prefix("state-")?
        .strip_suffix(".hoblog")?
        .parse()
        .ok()
}

/// The last cycle recorded in a state file.
fn last_cycle_in(p: &Path) -> Option<u64> {
    let bytes = std::fs::read(p).ok()?;
    let nl = bytes.iter().position(|&b| b == b'\n')?;
    let body = &bytes[nl + 1..];
    let n = body.len() / record_bytes();
    let rec = body.get((n.checked_sub(1)?) * record_bytes()..n * record_bytes())?;
    crate::format::decode(rec).map(|s| s.cycle)
}

fn append(p: &Path) -> std::io::Result<File> {
    OpenOptions::new().create(true).append(true).open(p)
}

/// Writes as much of `bytes` as the file takes; the count written, and the error if not all.
fn write_some(f: &mut File, bytes: &[u8]) -> (usize, Option<std::io::Error>) {
    let mut done = 0;
    while done < bytes.len() {
        match f.write(&bytes[done..]) {
            Ok(0) => return (done, Some(std::io::ErrorKind::WriteZero.into())),
            Ok(n) => done += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return (done, Some(e)),
        }
    }
    (done, None)
}

impl LogWriter {
    /// Opens (or continues) the log in `dir`: a restarted logger starts a new state file
    /// after the existing ones.
    pub fn open(dir: &Path, instance: &str) -> std::io::Result<Self> {
        std::fs::create_dir_all(dir)?;
        let existing = state_files(dir)?;
        let next_index = existing
            .iter()
            .filter_map(|p| index_of(p))
            .max()
            .map_or(1, |i| i + 1);
        let last_cycle = existing.last().and_then(|p| last_cycle_in(p));
        Ok(Self {
            dir: dir.to_path_buf(),
            instance: instance.to_string(),
            next_index,
            in_file: 0,
            state: None,
            pending: Vec::with_capacity(STATE_CHUNK),
            events: Some(append(&dir.join("events.log"))?),
            events_pending: Vec::new(),
            events_pending_count: 0,
            gaps: Some(append(&dir.join("gaps.log"))?),
            gaps_pending: Vec::new(),
            last_cycle,
            last_event: None,
            failing: None,
            stats: LogStats::default(),
            #[cfg(test)]
            disk_full: false,
        })
    }

    /// Whether writing is failing, since which cycle and why.
    pub fn failing(&self) -> Option<&Failing> {
        self.failing.as_ref()
    }

    fn check_disk(&self) -> std::io::Result<()> {
        #[cfg(test)]
        if self.disk_full {
            return Err(std::io::Error::from_raw_os_error(28));
        }
        Ok(())
    }

    /// Starts the next state file with its header; a file that cannot take its header is
    /// removed (no reader meets half a header).
    fn rotate(&mut self) -> std::io::Result<()> {
        self.state = None;
        let p = self.dir.join(format!("state-{:06}.hoblog", self.next_index));
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let opened = self.check_disk().and_then(|()| File::create(&p));
        let mut f = opened?;
        let (_, e) = write_some(&mut f, header(&self.instance, now).as_bytes());
        if let Some(e) = e {
            drop(f);
            let _ = std::fs::remove_file(&p);
            return Err(e);
        }
        self.next_index += 1;
        self.state = Some(f);
        self.in_file = 0;
        self.stats.files += 1;
        Ok(())
    }

    fn gap_line(&mut self, line: std::fmt::Arguments<'_>) {
        let _ = self.gaps_pending.write_fmt(line);
        self.gaps_pending.push(b'\n');
    }

    pub fn push_state(&mut self, s: &StateSample) -> std::io::Result<()> {
        match self.last_cycle {
            Some(last) if s.cycle <= last => {
                self.stats.service_restarts += 1;
                self.gap_line(format_args!("restart {last} {}", s.cycle));
            }
            Some(last) if s.cycle > last + 1 => {
                let missed = s.cycle - last - 1;
                if self.stats.samples == 0 {
                    self.stats.samples_not_running += missed;
                    self.gap_line(format_args!("not-running {} {} {missed}", last + 1, s.cycle - 1));
                } else {
                    self.stats.samples_lost += missed;
                    self.gap_line(format_args!("lost {} {} {missed}", last + 1, s.cycle - 1));
                }
            }
            _ => {}
        }
        self.last_cycle = Some(s.cycle);
        self.stats.samples += 1;
        if let Some(f) = self.failing.as_mut() {
            f.first_cycle.get_or_insert(s.cycle);
            f.last_cycle = s.cycle;
            f.count += 1;
            self.stats.samples_unwritten += 1;
            return Ok(());
        }
        encode(s, &mut self.pending);
        if self.pending.len() >= STATE_CHUNK {
            self.write_states();
        }
        Ok(())
    }

    /// Writes the pending records into the state file (rotating where due); on failure the
    /// records not written whole are counted and the writer is failing.
    fn write_states(&mut self) {
        let rec = record_bytes();
        let mut done = 0;
        let mut error = None;
        while done < self.pending.len() {
            if (self.state.is_none() || self.in_file >= ROTATE_RECORDS)
                && let Err(e) = self.rotate()
            {
                error = Some(e);
                break;
            }
            let room = usize::try_from(ROTATE_RECORDS - self.in_file).unwrap_or(usize::MAX);
            let take = (self.pending.len() - done).min(room.saturating_mul(rec));
            let chunk = &self.pending[done..done + take];
            let (n, e) = match (self.check_disk(), self.state.as_mut()) {
                (Err(e), _) => (0, Some(e)),
                (Ok(()), Some(f)) => write_some(f, chunk),
                (Ok(()), None) => (0, Some(std::io::ErrorKind::NotFound.into())),
            };
            // Whole records only count as written: a torn last record is past the file's end
            // for every reader.
            let whole = n / rec;
            done += whole * rec;
            self.in_file += whole as u64;
            if let Some(e) = e {
                error = Some(e);
                break;
            }
            done += take - whole * rec;
        }
        if let Some(e) = error {
            let left = ((self.pending.len() - done) / rec) as u64;
            let last = self.last_cycle.unwrap_or(0);
            let first_unwritten = self
                .pending
                .get(done..done + rec)
                .and_then(crate::format::decode)
                .map(|s| s.cycle);
            self.stats.samples_unwritten += left;
            self.state = None;
            self.start_failing(&e, first_unwritten, last, left);
        }
        self.pending.clear();
    }

    fn start_failing(&mut self, e: &std::io::Error, first_cycle: Option<u64>, last_cycle: u64, count: u64) {
        match self.failing.as_mut() {
            Some(f) => {
                if f.first_cycle.is_none() {
                    f.first_cycle = first_cycle;
                }
                f.count += count;
                f.last_cycle = f.last_cycle.max(last_cycle);
                f.errno = e.raw_os_error().unwrap_or(0);
                f.error = e.to_string();
            }
            None => {
                self.failing = Some(Failing {
                    first_cycle,
                    last_cycle,
                    count,
                    error: e.to_string(),
                    errno: e.raw_os_error().unwrap_or(0),
                })
            }
        }
    }

    pub fn push_event(&mut self, e: &EventSample) -> std::io::Result<()> {
        if let Some(last) = self.last_event
            && e.seq > last + 1
        {
            self.stats.events_lost += e.seq - last - 1;
        }
        self.last_event = Some(e.seq);
        self.stats.events += 1;
        if self.failing.is_some() {
            self.stats.events_unwritten += 1;
            return Ok(());
        }
        writeln!(self.events_pending, "{}", crate::format::event_line(e))?;
        self.events_pending_count += 1;
        Ok(())
    }

    /// While failing: tries a new state file; when it takes its header the recording
    /// resumes and the missing run goes to `gaps.log`.
    fn try_resume(&mut self) {
        let Some(f) = self.failing.clone() else {
            return;
        };
        match self.rotate().and_then(|()| self.end_torn_event_line()) {
            Ok(()) => {
                if let Some(first) = f.first_cycle {
                    self.gap_line(format_args!("unwritten {first} {} {}", f.last_cycle, f.count));
                }
                self.failing = None;
            }
            Err(e) => self.start_failing(&e, None, f.last_cycle, 0),
        }
    }

    /// A failed write may have left `events.log` ending mid-line: the next line must not
    /// continue it.
    fn end_torn_event_line(&mut self) -> std::io::Result<()> {
        let p = self.dir.join("events.log");
        let bytes = std::fs::read(&p)?;
        if bytes.last().is_some_and(|&b| b != b'\n')
            && let Some(f) = self.events.as_mut()
        {
            f.write_all(b"\n")?;
        }
        Ok(())
    }

    /// Writes everything pending and `logger.json` (atomically). Never fails: what cannot be
    /// written is counted, and [`LogWriter::failing`] says since when and why; the
    /// returned error is the latest write's, for the operator.
    pub fn flush(&mut self) -> std::io::Result<()> {
        if self.failing.is_some() {
            self.try_resume();
        }
        if self.failing.is_none() {
            self.write_states();
        }
        self.flush_lines();
        let s = &self.stats;
        let j = json!({
            "samples": s.samples,
            "samples_lost": s.samples_lost,
            "samples_not_running": s.samples_not_running,
            "samples_unwritten": s.samples_unwritten,
            "events": s.events,
            "events_lost": s.events_lost,
            "events_unwritten": s.events_unwritten,
            "files": s.files,
            "service_restarts": s.service_restarts,
            "writing": self.failing.is_none(),
        });
        let written = self.check_disk().and_then(|()| {
            hob_rt_os::durable::write_atomic(&self.dir.join("logger.json"), format!("{j:#}\n").as_bytes())
        });
        match (&self.failing, written) {
            (Some(f), _) => Err(std::io::Error::other(f.error.clone())),
            (None, r) => r,
        }
    }

    /// The event and gap lines: events not written are counted; gap lines are kept.
    fn flush_lines(&mut self) {
        if !self.events_pending.is_empty() {
            let (n, e) = match (self.check_disk(), self.events.as_mut()) {
                (Err(e), _) => (0, Some(e)),
                (Ok(()), Some(f)) => write_some(f, &self.events_pending),
                (Ok(()), None) => (0, Some(std::io::ErrorKind::NotFound.into())),
            };
            if let Some(e) = e {
                // Lines not written whole: each ends after byte n (a torn line included).
                let unwritten = self.events_pending[n..]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count()
                    .min(self.events_pending_count as usize);
                self.stats.events_unwritten += unwritten as u64;
                let last = self.last_cycle.unwrap_or(0);
                self.start_failing(&e, None, last, 0);
            }
            self.events_pending.clear();
            self.events_pending_count = 0;
        }
        if !self.gaps_pending.is_empty()
            && self.failing.is_none()
            && self.check_disk().is_ok()
            && let Some(f) = self.gaps.as_mut()
        {
            let (n, _) = write_some(f, &self.gaps_pending);
            self.gaps_pending.drain(..n);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(cycle: u64) -> StateSample {
        StateSample {
            cycle,
            ..StateSample::default()
        }
    }

    #[test]
    fn gaps_are_counted_and_a_restarted_logger_continues_in_a_new_file() {
        let dir = std::env::temp_dir().join(format!("hob-log-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut w = LogWriter::open(&dir, "t").unwrap();
        for c in [1, 2, 3, 7, 8] {
            w.push_state(&sample(c)).unwrap();
        }
        w.flush().unwrap();
        assert_eq!(w.stats.samples_lost, 3);
        drop(w);
        let mut w = LogWriter::open(&dir, "t").unwrap();
        for c in [20, 21] {
            w.push_state(&sample(c)).unwrap();
        }
        w.flush().unwrap();
        assert_eq!(w.stats.samples_lost, 0);
        assert_eq!(w.stats.samples_not_running, 11);
        let all = crate::format::read_dir_states(&dir).unwrap();
        let cycles: Vec<u64> = all.iter().map(|s| s.cycle).collect();
        assert_eq!(cycles, [1, 2, 3, 7, 8, 20, 21]);
        assert_eq!(state_files(&dir).unwrap().len(), 2);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_full_disk_is_counted_and_the_recording_resumes_in_a_new_file() {
        let dir = std::env::temp_dir().join(format!("hob-log-full-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut w = LogWriter::open(&dir, "t").unwrap();
        let event = |seq| EventSample {
            seq,
            ..EventSample::default()
        };
        for c in 1..=100 {
            w.push_state(&sample(c)).unwrap();
        }
        w.push_event(&event(1)).unwrap();
        w.flush().unwrap();
        w.disk_full = true;
        for c in 101..=150 {
            w.push_state(&sample(c)).unwrap();
        }
        w.push_event(&event(2)).unwrap();
        let e = w.flush().unwrap_err();
        assert!(e.to_string().contains("No space left"), "{e}");
        let f = w.failing().unwrap().clone();
        assert_eq!(
            (f.first_cycle, f.last_cycle, f.count, f.errno),
            (Some(101), 150, 50, 28)
        );
        // Still failing: counted, not kept.
        for c in 151..=170 {
            w.push_state(&sample(c)).unwrap();
        }
        w.push_event(&event(3)).unwrap();
        assert!(w.flush().is_err());
        assert_eq!(w.stats.samples_unwritten, 70);
        assert_eq!(w.stats.events_unwritten, 2);
        // Space again: the next flush resumes in a new file, and the gap goes to gaps.log.
        w.disk_full = false;
        w.flush().unwrap();
        for c in 171..=180 {
            w.push_state(&sample(c)).unwrap();
        }
        w.flush().unwrap();
        assert!(w.failing().is_none());
        assert_eq!(w.stats.samples, 180);
        assert_eq!(w.stats.samples_lost, 0, "nothing was missed on the bus");
        let cycles: Vec<u64> = crate::format::read_dir_states(&dir)
            .unwrap()
            .iter()
            .map(|s| s.cycle)
            .collect();
        let expected: Vec<u64> = (1..=100).chain(171..=180).collect();
        assert_eq!(cycles, expected);
        let gaps = std::fs::read_to_string(dir.join("gaps.log")).unwrap();
        assert_eq!(gaps, "unwritten 101 170 70\n");
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("logger.json")).unwrap()).unwrap();
        assert_eq!(j["samples_unwritten"], 70);
        assert_eq!(j["events_unwritten"], 2);
        assert_eq!(j["writing"], true);
        assert_eq!(
            std::fs::read_to_string(dir.join("events.log"))
                .unwrap()
                .lines()
                .count(),
            1
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
