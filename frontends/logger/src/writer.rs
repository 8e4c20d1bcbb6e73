//! Writing a log directory: rotating state files, the event lines, the gaps, the totals.

use crate::format::{encode, header, record_bytes, state_files};
use hob_ipc::{EventSample, StateSample};
use serde_json::json;
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Records per state file (5 min at 1 kHz) before the next file is started.
pub const ROTATE_RECORDS: u64 = 300_000;

/// What the logger has done so far.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LogStats {
    pub samples: u64,
    /// Samples the logger missed while running (gaps in the cycle counter): the target is 0.
    pub samples_lost: u64,
    /// Cycles between the end of an earlier log in this directory and this logger's first
    /// sample (the logger was not running): not counted as lost.
    pub samples_not_running: u64,
    pub events: u64,
    pub events_lost: u64,
    pub files: u64,
    /// `hob-rt` restarted (its cycle counter went back).
    pub service_restarts: u64,
}

#[derive(Debug)]
pub struct LogWriter {
    dir: PathBuf,
    instance: String,
    next_index: u64,
    in_file: u64,
    state: Option<BufWriter<File>>,
    events: BufWriter<File>,
    gaps: BufWriter<File>,
    last_cycle: Option<u64>,
    last_event: Option<u64>,
    buf: Vec<u8>,
    pub stats: LogStats,
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

fn append(p: &Path) -> std::io::Result<BufWriter<File>> {
    Ok(BufWriter::new(
        OpenOptions::new().create(true).append(true).open(p)?,
    ))
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
            events: append(&dir.join("events.log"))?,
            gaps: append(&dir.join("gaps.log"))?,
            last_cycle,
            last_event: None,
            buf: Vec::with_capacity(record_bytes()),
            stats: LogStats::default(),
        })
    }

    fn rotate(&mut self) -> std::io::Result<()> {
        if let Some(mut f) = self.state.take() {
            f.flush()?;
        }
        let p = self.dir.join(format!("state-{:06}.hoblog", self.next_index));
        self.next_index += 1;
        let mut f = BufWriter::with_capacity(1 << 20, File::create(p)?);
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        f.write_all(header(&self.instance, now).as_bytes())?;
        self.state = Some(f);
        self.in_file = 0;
        self.stats.files += 1;
        Ok(())
    }

    pub fn push_state(&mut self, s: &StateSample) -> std::io::Result<()> {
        match self.last_cycle {
            Some(last) if s.cycle <= last => {
                self.stats.service_restarts += 1;
                writeln!(self.gaps, "restart {last} {}", s.cycle)?;
            }
            Some(last) if s.cycle > last + 1 => {
                let missed = s.cycle - last - 1;
                if self.stats.samples == 0 {
                    self.stats.samples_not_running += missed;
                    writeln!(self.gaps, "not-running {} {} {missed}", last + 1, s.cycle - 1)?;
                } else {
                    self.stats.samples_lost += missed;
                    writeln!(self.gaps, "lost {} {} {missed}", last + 1, s.cycle - 1)?;
                }
            }
            _ => {}
        }
        self.last_cycle = Some(s.cycle);
        if self.state.is_none() || self.in_file >= ROTATE_RECORDS {
            self.rotate()?;
        }
        self.buf.clear();
        encode(s, &mut self.buf);
        if let Some(f) = self.state.as_mut() {
            f.write_all(&self.buf)?;
        }
        self.in_file += 1;
        self.stats.samples += 1;
        Ok(())
    }

    pub fn push_event(&mut self, e: &EventSample) -> std::io::Result<()> {
        if let Some(last) = self.last_event
            && e.seq > last + 1
        {
            self.stats.events_lost += e.seq - last - 1;
        }
        self.last_event = Some(e.seq);
        self.stats.events += 1;
        writeln!(self.events, "{}", crate::format::event_line(e))
    }

    /// Flushes everything and writes `logger.json`.
    pub fn flush(&mut self) -> std::io::Result<()> {
        if let Some(f) = self.state.as_mut() {
            f.flush()?;
        }
        self.events.flush()?;
        self.gaps.flush()?;
        let s = &self.stats;
        let j = json!({
            "samples": s.samples,
            "samples_lost": s.samples_lost,
            "samples_not_running": s.samples_not_running,
            "events": s.events,
            "events_lost": s.events_lost,
            "files": s.files,
            "service_restarts": s.service_restarts,
        });
        std::fs::write(self.dir.join("logger.json"), format!("{j:#}\n"))
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
}
