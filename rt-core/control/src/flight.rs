//! A flight record: what the loop took in and gave out, cycle by cycle, over its last
//! seconds, and the control core's whole state before the first of them; and its replay.
//!
//! The control core is a pure function of its state, the commands it takes and the inputs
//! latched at each SYNC (`bench/plant/tests/determinism.rs`), so stepping a copy of the
//! state it had over the recorded commands and inputs gives the recorded outputs bit for
//! bit, or the first cycle where they part says that something else was at work. `hob-rt`
//! keeps the record in fixed rings (`hob_service::recorder`) and writes it to disk
//! ([`encode`]); `hob replay` reads it back ([`decode`]) and replays it.
//!
//! The file: one text line `hob-flight-record 2 <bytes> <fnv64 hex>\n`, then the record in
//! postcard's serde encoding (floats to the bit). A file cut short or changed is refused by
//! its length and checksum before anything is decoded; one of another format version is
//! refused by the line.

use crate::program::CycleProgram;
use crate::{Command, Controller, CycleInputs, CycleOutputs};

/// What reached the control core in a cycle besides its inputs.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Mail {
    None,
    Command(Command),
    /// A program loaded: the record's `programs[i]`.
    Load(u16),
    /// A program loaded that the record could not keep (more loads than it holds): the
    /// replay cannot go past it.
    LoadNotKept,
}

/// One cycle.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Record {
    /// Applied before the step, as the loop applies its mail.
    pub mail: Mail,
    pub inputs: CycleInputs,
    pub outputs: CycleOutputs,
}

/// Why a record was written.
pub const REASONS: [&str; 3] = ["fault", "stop", "request"];

/// A whole flight record.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct FlightRecord {
    /// `fault: <alarm>`, `stop`, `request`.
    pub reason: String,
    /// When it was written, UTC (`2026-11-26T11:00:00Z`).
    pub written_utc: String,
    /// The control core's state before the first record.
    pub start: Controller,
    /// The controller's cycle counter at the first record.
    pub first_cycle: u64,
    pub records: Vec<Record>,
    pub programs: Vec<CycleProgram>,
}

/// How a replay went.
#[derive(Debug, Clone, PartialEq)]
pub struct Replay {
    /// Cycles stepped.
    pub cycles: usize,
    /// The first record whose outputs differ from the replay's, with both.
    pub first_difference: Option<(usize, CycleOutputs, CycleOutputs)>,
    /// Where the replay had to stop early (a program not kept), if it did.
    pub stopped_at: Option<usize>,
    /// The outputs replayed, cycle by cycle.
    pub outputs: Vec<CycleOutputs>,
}

/// The outputs to the bit: every `f64` by its exact `Debug` form (the shortest text that
/// reads back to the same bits; -0.0 and NaN included).
pub fn same_bits(a: &CycleOutputs, b: &CycleOutputs) -> bool {
    format!("{a:?}") == format!("{b:?}")
}

impl FlightRecord {
    /// Hands a cycle's mail to `controller` as the loop did (a refusal is the controller's
    /// answer, as it was); false for a program the record did not keep.
    fn deliver(&self, controller: &mut Controller, mail: Mail) -> bool {
        match mail {
            Mail::None => {}
            Mail::Command(c) => {
                let _ = controller.command(c);
            }
            Mail::Load(i) => match self.programs.get(usize::from(i)) {
                Some(p) => {
                    let _ = controller.load(*p);
                }
                None => return false,
            },
            Mail::LoadNotKept => return false,
        }
        true
    }

    /// Steps `controller` (the record's start, or a copy changed for a "what if") over the
    /// record's mail and inputs, handing `each` the record's index, the controller after
    /// the step and its outputs; the index where it had to stop (a program not kept), if
    /// it did.
    pub fn replay_each(
        &self,
        mut controller: Controller,
        mut each: impl FnMut(usize, &Controller, &CycleOutputs),
    ) -> Option<usize> {
        for (k, rec) in self.records.iter().enumerate() {
            if !self.deliver(&mut controller, rec.mail) {
                return Some(k);
            }
            let out = controller.step(&rec.inputs);
            while controller.events().pop().is_some() {}
            each(k, &controller, &out);
        }
        None
    }

    /// The replay of the whole record, every output compared with the recorded one.
    pub fn replay(&self, controller: Controller) -> Replay {
        let mut outputs = Vec::with_capacity(self.records.len());
        let mut first_difference = None;
        let stopped_at = self.replay_each(controller, |k, _, out| {
            let recorded = self.records[k].outputs;
            if first_difference.is_none() && !same_bits(out, &recorded) {
                first_difference = Some((k, recorded, *out));
            }
            outputs.push(*out);
        });
        Replay {
            cycles: outputs.len(),
            first_difference,
            stopped_at,
            outputs,
        }
    }
}

/// The longest lag between a target and the position showing it that
/// [`FlightRecord::follow_lags`] looks for, cycles.
pub const MAX_FOLLOW_LAG: usize = 8;

fn targets(o: &CycleOutputs) -> [i32; 3] {
    [o.table_target_counts, o.x_target_counts, o.y_target_counts]
}

fn positions(i: &CycleInputs) -> [i32; 3] {
    [i.table.position_counts, i.x.position_counts, i.y.position_counts]
}

/// Whether the position of axis `a` (B, X, Y) arrived for this cycle.
fn fresh(i: &CycleInputs, a: usize) -> bool {
    [i.table, i.x, i.y][a].fresh
}

/// Whether the drive of axis `a` (B, X, Y) follows the targets of `o`.
fn follows(o: &CycleOutputs, a: usize) -> bool {
    o.drives_enabled && o.drive_modes[a] == crate::DriveMode::CyclicPosition
}

impl FlightRecord {
    /// For each axis (B, X, Y), the lag in cycles between a target sent and the drive's
    /// latched position showing it: the `d` in `1 ..= MAX_FOLLOW_LAG` (a target is computed after the inputs) for which the
    /// recorded positions differ least from the targets `d` cycles before them (the mean
    /// square of the difference over the cycles where the drive followed its targets and
    /// the axis moved, its position fresh); `None` for an axis that did not move.
    pub fn follow_lags(&self) -> [Option<usize>; 3] {
        let n = self.records.len();
        std::array::from_fn(|a| {
            let moved = self
                .records
                .windows(2)
                .any(|w| follows(&w[0].outputs, a) && targets(&w[0].outputs)[a] != targets(&w[1].outputs)[a]);
            if !moved {
                return None;
            }
            (1..=MAX_FOLLOW_LAG.min(n.saturating_sub(1)))
                .map(|d| {
                    let (mut sum, mut count) = (0.0f64, 0u32);
                    for k in d..n {
                        let sent = &self.records[k - d].outputs;
                        if follows(sent, a) && fresh(&self.records[k].inputs, a) {
                            let e = positions(&self.records[k].inputs)[a].wrapping_sub(targets(sent)[a]);
                            sum += f64::from(e) * f64::from(e);
                            count += 1;
                        }
                    }
                    (
                        d,
                        if count == 0 {
                            f64::INFINITY
                        } else {
                            sum / f64::from(count)
                        },
                    )
                })
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .map(|(d, _)| d)
        })
    }

    /// Like [`FlightRecord::replay_each`], but the machine answers the controller: each
    /// drive's position is the recorded one moved by how far the controller's target
    /// `lags[a]` cycles before moved from the recorded target (while the drive followed
    /// its targets; afterwards the last such shift stays). A drive that followed its
    /// targets with the recorded lag and the recorded deviation from them, whatever the
    /// targets: for a "what if" that changes the targets a little (a gain, a bandwidth),
    /// not one that changes what the machine does. The spindle (its own VFD) and the I/O
    /// are as recorded. With the recorded controller every shift is 0: the recorded run.
    /// `each` is also handed the inputs as answered.
    pub fn replay_answered(
        &self,
        mut controller: Controller,
        lags: [usize; 3],
        mut each: impl FnMut(usize, &Controller, &CycleInputs, &CycleOutputs),
    ) -> Option<usize> {
        let mut sent: Vec<CycleOutputs> = Vec::with_capacity(self.records.len());
        let mut shift = [0i32; 3];
        for (k, rec) in self.records.iter().enumerate() {
            for (a, lag) in lags.iter().enumerate() {
                // At least a cycle: a target is computed after the cycle's inputs.
                if let Some(j) = k.checked_sub((*lag).max(1))
                    && follows(&self.records[j].outputs, a)
                    && follows(&sent[j], a)
                {
                    shift[a] = targets(&sent[j])[a].wrapping_sub(targets(&self.records[j].outputs)[a]);
                }
            }
            let mut inputs = rec.inputs;
            for (fb, s) in [&mut inputs.table, &mut inputs.x, &mut inputs.y]
                .into_iter()
                .zip(shift)
            {
                fb.position_counts = fb.position_counts.wrapping_add(s);
            }
            if !self.deliver(&mut controller, rec.mail) {
                return Some(k);
            }
            let out = controller.step(&inputs);
            while controller.events().pop().is_some() {}
            each(k, &controller, &inputs, &out);
            sent.push(out);
        }
        None
    }
}

const MAGIC: &str = "hob-flight-record";
const VERSION: u32 = 2;

/// FNV-1a, 64 bits: a checksum against a file cut short or damaged (not against intent).
fn fnv64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The file's bytes.
pub fn encode(r: &FlightRecord) -> Result<Vec<u8>, String> {
    let body = postcard::to_allocvec(r).map_err(|e| format!("flight record: {e}"))?;
    let mut out = format!("{MAGIC} {VERSION} {} {:016x}\n", body.len(), fnv64(&body)).into_bytes();
    out.extend_from_slice(&body);
    Ok(out)
}

/// A record from a file's bytes; `name` for the messages.
pub fn decode(bytes: &[u8], name: &str) -> Result<FlightRecord, String> {
    let nl = bytes
        .iter()
        .take(128)
        .position(|&b| b == b'\n')
        .ok_or_else(|| format!("{name}: not a flight record (no header line)"))?;
    let head = std::str::from_utf8(&bytes[..nl]).map_err(|_| format!("{name}: not a flight record"))?;
    let f: Vec<&str> = head.split(' ').collect();
    if f.len() != 4 || f[0] != MAGIC {
        return Err(format!("{name}: not a flight record (header {head:?})"));
    }
    if f[1] != VERSION.to_string() {
        return Err(format!(
            "{name}: flight record format {}, this build reads format {VERSION}",
            f[1]
        ));
    }
    let len: usize = f[2]
        .parse()
        .map_err(|_| format!("{name}: bad length in the header"))?;
    let sum = u64::from_str_radix(f[3], 16).map_err(|_| format!("{name}: bad checksum in the header"))?;
    let body = &bytes[nl + 1..];
    if body.len() != len {
        return Err(format!(
            "{name}: {} bytes after the header, the header says {len}: cut short or extended",
            body.len()
        ));
    }
    if fnv64(body) != sum {
        return Err(format!("{name}: checksum mismatch: the file is damaged"));
    }
    postcard::from_bytes(body).map_err(|e| {
        format!("{name}: does not decode as this build's flight record ({e}): written by another version of hob-rt?")
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ControlParams, Controller, CycleInputs};

    fn record() -> FlightRecord {
        let mut c = Controller::new(ControlParams::from_machine(
            &hob_setup::config::machine::shipped_for_tests(),
        ));
        let start = c.clone();
        let records = (0..50)
            .map(|k| {
                let inputs = CycleInputs {
                    spindle_counts: k * 11,
                    ..CycleInputs::default()
                };
                Record {
                    mail: Mail::None,
                    inputs,
                    outputs: c.step(&inputs),
                }
            })
            .collect();
        FlightRecord {
            reason: "request".into(),
            written_utc: "2026-11-26T12:00:00Z".into(),
            start,
            first_cycle: 0,
            records,
            programs: Vec::new(),
        }
    }

    #[test]
    fn a_record_reads_back_and_replays_bit_for_bit() {
        let r = record();
        let back = decode(&encode(&r).unwrap(), "f").unwrap();
        assert_eq!(back.records, r.records);
        let rep = back.replay(back.start.clone());
        assert_eq!((rep.cycles, rep.first_difference), (50, None));
    }

    #[test]
    fn the_follow_lag_is_the_delay_that_explains_the_positions() {
        let mut r = record();
        let target = |k: usize| (k * k) as i32 * 37;
        for (k, rec) in r.records.iter_mut().enumerate() {
            rec.outputs.drives_enabled = true;
            rec.outputs.table_target_counts = target(k);
            rec.outputs.y_target_counts = -target(k);
            rec.inputs.table.fresh = true;
            rec.inputs.table.position_counts = target(k.saturating_sub(3)) + 5;
            rec.inputs.y.fresh = true;
            rec.inputs.y.position_counts = -target(k.saturating_sub(1));
        }
        assert_eq!(r.follow_lags(), [Some(3), None, Some(1)]);
        // Positions that did not arrive are not evidence.
        for rec in &mut r.records[10..] {
            rec.inputs.table.fresh = false;
            rec.inputs.table.position_counts = 0;
        }
        assert_eq!(r.follow_lags()[0], Some(3));
    }

    #[test]
    fn a_file_cut_short_damaged_or_of_another_format_is_refused_with_the_reason() {
        let bytes = encode(&record()).unwrap();
        let e = decode(&bytes[..bytes.len() - 10], "f").unwrap_err();
        assert!(e.contains("cut short"), "{e}");
        let mut damaged = bytes.clone();
        let last = damaged.len() - 1;
        damaged[last] ^= 1;
        assert!(decode(&damaged, "f").unwrap_err().contains("checksum"));
        let other =
            String::from_utf8_lossy(&bytes).replacen("hob-flight-record 2 ", "hob-flight-record 3 ", 1);
        assert!(decode(other.as_bytes(), "f").unwrap_err().contains("format 3"));
        assert!(
            decode(b"hello\n", "f")
                .unwrap_err()
                .contains("not a flight record")
        );
        assert!(decode(b"", "f").unwrap_err().contains("not a flight record"));
    }
}
