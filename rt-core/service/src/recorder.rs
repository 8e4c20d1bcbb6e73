//! The flight recorder of `hob-rt` (issue 18): each cycle's mail, inputs and outputs in
//! fixed rings, with the control core's whole state before the first of them, so that a
//! fault, a stop or an operator's request can be replayed bit for bit afterwards (`hob
//! replay`, `hob_control::flight`).
//!
//! In the cycle nothing is allocated: two segments of [`SEGMENT_CYCLES`] records each,
//! preallocated, the newer filling while the older holds the seconds before it (between 8
//! and 16 s are kept at 1 kHz); when the newer is full the two swap and the newer starts
//! again with a copy of the controller (plain data: its copy allocates nothing,
//! `bench/plant/tests/no_alloc.rs`). A dump hands the whole pair to the writer thread
//! through a bounded channel (a pointer moves) and recording goes on at once in a spare pair;
//! the writer turns it into a [`FlightRecord`], writes the file (`hob_control::flight`'s
//! bytes, whole or not at all) and
//! gives the pair back as the next spare. A dump asked for while the writer still has the
//! spare is counted as missed, never waited for.

use hob_control::fault::Fault;
use hob_control::flight::{FlightRecord, Mail, Record};
use hob_control::program::CycleProgram;
use hob_control::{Controller, CycleInputs, CycleOutputs};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, SyncSender, TrySendError};

/// Records per segment: 8 s at 1 kHz (8 to 16 s are kept).
pub const SEGMENT_CYCLES: usize = 8000;
/// Programs a segment keeps (a load beyond them cannot be replayed past).
pub const PROGRAM_SLOTS: usize = 4;
/// After a fault the record waits this many cycles, so that it holds the reaction too.
pub const AFTER_FAULT_CYCLES: u64 = 2000;

/// Why a record is written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reason {
    Fault(Fault),
    Stop,
    Request,
}

/// One segment: the controller before its first record, and its records.
#[derive(Debug)]
struct Segment {
    start: Controller,
    records: Vec<Record>,
    programs: [Option<CycleProgram>; PROGRAM_SLOTS],
}

impl Segment {
    fn new(c: &Controller, cap: usize) -> Box<Self> {
        Box::new(Self {
            start: c.clone(),
            records: Vec::with_capacity(cap),
            programs: [None; PROGRAM_SLOTS],
        })
    }

    /// Starts the segment again at `c`'s state (allocation-free).
    fn restart(&mut self, c: &Controller) {
        self.start = c.clone();
        self.records.clear();
        self.programs = [None; PROGRAM_SLOTS];
    }
}

/// The older and the newer segment.
#[derive(Debug)]
pub struct Pair {
    older: Box<Segment>,
    newer: Box<Segment>,
}

impl Pair {
    fn new(c: &Controller, cap: usize) -> Box<Self> {
        Box::new(Self {
            older: Segment::new(c, cap),
            newer: Segment::new(c, cap),
        })
    }

    /// The record these segments hold, oldest first (allocates: off the loop).
    pub fn to_record(&self, reason: String, written_utc: String) -> FlightRecord {
        let (first, second) = if self.older.records.is_empty() {
            (&self.newer, None)
        } else {
            (&self.older, Some(&self.newer))
        };
        let mut programs: Vec<CycleProgram> = first.programs.iter().flatten().copied().collect();
        let mut records = first.records.clone();
        if let Some(s) = second {
            let offset = programs.len() as u16;
            programs.extend(s.programs.iter().flatten().copied());
            records.extend(s.records.iter().map(|r| match r.mail {
                Mail::Load(i) => Record {
                    mail: Mail::Load(i + offset),
                    ..*r
                },
                _ => *r,
            }));
        }
        FlightRecord {
            reason,
            written_utc,
            start: first.start.clone(),
            first_cycle: first.start.cycle(),
            records,
            programs,
        }
    }
}

/// The loop's side.
#[derive(Debug)]
pub struct Recorder {
    live: Box<Pair>,
    spare: Option<Box<Pair>>,
    cap: usize,
    to_writer: SyncSender<(Box<Pair>, Reason)>,
    from_writer: Receiver<Box<Pair>>,
    /// A dump asked for, and the cycle from which it is due.
    pending: Option<(u64, Reason)>,
    /// The mail of the cycle being recorded.
    mail: Mail,
    pub dumps: u64,
    pub missed: u64,
}

/// The writer thread's side: pairs to write, and the way back.
#[derive(Debug)]
pub struct Writer {
    from_loop: Receiver<(Box<Pair>, Reason)>,
    to_loop: SyncSender<Box<Pair>>,
}

/// A recorder whose segments start at `c`'s state, `cap` records each, and its writer.
pub fn recorder(c: &Controller, cap: usize) -> (Recorder, Writer) {
    let (to_writer, from_loop) = std::sync::mpsc::sync_channel(1);
    let (to_loop, from_writer) = std::sync::mpsc::sync_channel(1);
    (
        Recorder {
            live: Pair::new(c, cap),
            spare: Some(Pair::new(c, cap)),
            cap,
            to_writer,
            from_writer,
            pending: None,
            mail: Mail::None,
            dumps: 0,
            missed: 0,
        },
        Writer { from_loop, to_loop },
    )
}

impl Recorder {
    /// At the start of a cycle, before any mail: takes back a written pair, hands a due
    /// dump to the writer, starts a new segment when the newer one is full.
    pub fn begin_cycle(&mut self, c: &Controller) {
        self.mail = Mail::None;
        if self.spare.is_none()
            && let Ok(p) = self.from_writer.try_recv()
        {
            self.spare = Some(p);
        }
        let cycle = c.cycle();
        if let Some((due, reason)) = self.pending
            && cycle >= due
        {
            self.pending = None;
            match self.spare.take() {
                Some(mut next) => {
                    // An empty older segment is no segment: only the newer starts here.
                    next.older.records.clear();
                    next.newer.restart(c);
                    let full = std::mem::replace(&mut self.live, next);
                    match self.to_writer.try_send((full, reason)) {
                        Ok(()) => self.dumps += 1,
                        Err(TrySendError::Full((p, _)) | TrySendError::Disconnected((p, _))) => {
                            // The writer is busy or gone: keep the pair as the spare.
                            self.spare = Some(p);
                            self.missed += 1;
                        }
                    }
                }
                None => self.missed += 1,
            }
        }
        if self.live.newer.records.len() >= self.cap {
            let p = &mut *self.live;
            std::mem::swap(&mut p.older, &mut p.newer);
            p.newer.restart(c);
        }
    }

    /// A command applied this cycle.
    pub fn command(&mut self, cmd: hob_control::Command) {
        self.mail = Mail::Command(cmd);
    }

    /// A program loaded this cycle.
    pub fn load(&mut self, p: &CycleProgram) {
        let seg = &mut self.live.newer;
        self.mail = match seg.programs.iter().position(Option::is_none) {
            Some(i) => {
                seg.programs[i] = Some(*p);
                Mail::Load(i as u16)
            }
            None => Mail::LoadNotKept,
        };
    }

    /// The cycle's inputs and outputs, after the step.
    pub fn end_cycle(&mut self, inputs: &CycleInputs, outputs: &CycleOutputs) {
        let seg = &mut self.live.newer;
        if seg.records.len() < seg.records.capacity() {
            seg.records.push(Record {
                mail: self.mail,
                inputs: *inputs,
                outputs: *outputs,
            });
        }
    }

    /// Asks for a dump from cycle `due` on (a fault: later, to hold the reaction). A dump
    /// already asked for stays.
    pub fn request(&mut self, reason: Reason, due: u64) {
        if self.pending.is_none() {
            self.pending = Some((due, reason));
        }
    }

    /// The pair being recorded (the stop's dump, written by the caller after the loop).
    pub fn live(&self) -> &Pair {
        &self.live
    }
}

/// The file name of a record: `flight-<UTC>-<reason>.hobfr`.
pub fn file_name(utc: &str, reason: &Reason) -> String {
    let r = match reason {
        Reason::Fault(_) => "fault",
        Reason::Stop => "stop",
        Reason::Request => "request",
    };
    format!("flight-{}-{r}.hobfr", utc.replace(':', ""))
}

/// The reason in words.
pub fn reason_text(reason: &Reason) -> String {
    match reason {
        Reason::Fault(f) => format!(
            "fault: {}",
            hob_ipc::codec::alarm_text(&hob_control::fault::Fault::alarm(Some(*f)))
        ),
        Reason::Stop => "stop".into(),
        Reason::Request => "request".into(),
    }
}

/// Writes `pair` into `dir`; the file's path.
pub fn write(dir: &Path, pair: &Pair, reason: &Reason) -> Result<PathBuf, String> {
    let utc = hob_store::utc::now();
    let record = pair.to_record(reason_text(reason), utc.clone());
    let mut path = dir.join(file_name(&utc, reason));
    let mut n = 1;
    while path.exists() {
        n += 1;
        path = dir.join(file_name(&format!("{utc}-{n}"), reason));
    }
    let bytes = hob_control::flight::encode(&record)?;
    hob_store::atomic::write_new(&path, &bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path)
}

impl Writer {
    /// Writes every pair the loop hands over into `dir` and gives it back, until the loop
    /// is gone.
    pub fn serve(self, dir: &Path) {
        while let Ok((pair, reason)) = self.from_loop.recv() {
            match write(dir, &pair, &reason) {
                Ok(p) => eprintln!(
                    "hob-rt: flight record ({}) written: {}",
                    reason_text(&reason),
                    p.display()
                ),
                Err(e) => eprintln!(
                    "hob-rt: flight record ({}) NOT written: {e}",
                    reason_text(&reason)
                ),
            }
            if self.to_loop.send(pair).is_err() {
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hob_control::{Command, ControlParams, CycleInputs};

    fn controller() -> Controller {
        Controller::new(ControlParams::from_machine(
            &hob_setup::config::machine::shipped_for_tests(),
        ))
    }

    /// Steps `c` for `n` cycles through the recorder as the loop does, a command at cycle
    /// `command_at`.
    fn run(c: &mut Controller, rec: &mut Recorder, n: u64, command_at: Option<u64>) {
        for k in 0..n {
            rec.begin_cycle(c);
            if command_at == Some(k) {
                let cmd = Command::FeedOverride { percent: 90.0 };
                rec.command(cmd);
                let _ = c.command(cmd);
            }
            let inputs = CycleInputs {
                spindle_counts: (k * 7) as i32,
                ..CycleInputs::default()
            };
            let out = c.step(&inputs);
            while c.events().pop().is_some() {}
            rec.end_cycle(&inputs, &out);
        }
    }

    #[test]
    fn the_last_segments_are_kept_and_a_dump_replays_bit_for_bit() {
        let mut c = controller();
        let (mut rec, writer) = recorder(&c, 100);
        run(&mut c, &mut rec, 350, Some(320));
        // Two segments: cycles 200..300 and 300..350.
        let r = rec.live().to_record("request".into(), "now".into());
        assert_eq!(r.first_cycle, 200);
        assert_eq!(r.records.len(), 150);
        assert_eq!(
            r.records[120].mail,
            Mail::Command(Command::FeedOverride { percent: 90.0 })
        );
        let rep = r.replay(r.start.clone());
        assert_eq!(
            (rep.cycles, rep.first_difference, rep.stopped_at),
            (150, None, None)
        );
        // A dump hands the pair to the writer and recording goes on in the spare.
        let now = c.status().cycle;
        rec.request(Reason::Request, now);
        run(&mut c, &mut rec, 5, None);
        assert_eq!((rec.dumps, rec.missed), (1, 0));
        let (pair, reason) = writer.from_loop.try_recv().unwrap();
        assert_eq!(reason, Reason::Request);
        let dumped = pair.to_record("request".into(), "now".into());
        assert_eq!(dumped.records.len(), 150);
        assert_eq!(
            rec.live().to_record(String::new(), String::new()).records.len(),
            5
        );
        // While the writer holds the spare, a second dump is missed, never waited for.
        rec.request(Reason::Stop, now + 5);
        run(&mut c, &mut rec, 2, None);
        assert_eq!((rec.dumps, rec.missed), (1, 1));
        // Given back, the next one goes.
        writer.to_loop.send(pair).unwrap();
        rec.request(Reason::Stop, now + 7);
        run(&mut c, &mut rec, 2, None);
        assert_eq!((rec.dumps, rec.missed), (2, 1));
    }

    #[test]
    fn programs_loaded_are_kept_and_one_too_many_is_marked() {
        let c = controller();
        let (mut rec, _writer) = recorder(&c, 100);
        let machine = hob_setup::config::machine::shipped_for_tests();
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../config/programs/demo-short-spur-z17-m5.toml"),
        )
        .unwrap();
        let p = crate::commands::build_program("demo", &text, &machine).unwrap();
        for k in 0..=PROGRAM_SLOTS {
            rec.begin_cycle(&c);
            rec.load(&p);
            rec.end_cycle(&CycleInputs::default(), &CycleOutputs::default());
            let expected = if k < PROGRAM_SLOTS {
                Mail::Load(k as u16)
            } else {
                Mail::LoadNotKept
            };
            assert_eq!(rec.live.newer.records[k].mail, expected);
        }
        let r = rec.live().to_record(String::new(), String::new());
        assert_eq!(r.programs.len(), PROGRAM_SLOTS);
        assert_eq!(r.replay(r.start.clone()).stopped_at, Some(PROGRAM_SLOTS));
    }
}
