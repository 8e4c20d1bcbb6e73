//! Receiving apart from writing. One thread drains the subscribers into a bounded queue
//! every few milliseconds and never touches the disk; another writes. A write that blocks
//! (a slow disk, `fsync`, the kernel throttling a writer with many dirty pages, a network
//! or 9p file system) then delays only the writing: the subscriber's buffer on the bus
//! (2 s of the loop's samples) is still emptied on time. What the queue cannot take (the
//! writer blocked for longer than [`QUEUE_BATCHES`] batches) is dropped whole and shows as
//! lost samples, a gap in the cycle counter, like anything else the logger missed.

use crate::writer::LogWriter;
use hob_ipc::{EventSample, StateSample};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender, TrySendError, sync_channel};
use std::time::{Duration, Instant};

/// Batches the queue holds: at one batch per 10 ms drain, a minute of the loop's output.
pub const QUEUE_BATCHES: usize = 6000;

/// One received sample of either stream, in the order it was drained.
#[derive(Debug, Clone, Copy)]
pub enum Item {
    State(StateSample),
    Event(EventSample),
}

/// What the writing side does with the items (the log writer; a test's stand-in).
pub trait Sink {
    fn push(&mut self, item: &Item);
    /// Writes what is pending; called every flush interval and at the end.
    fn flush(&mut self) -> std::io::Result<()>;
}

impl Sink for LogWriter {
    fn push(&mut self, item: &Item) {
        // The writer counts what it cannot write; nothing to do with the error here.
        let _ = match item {
            Item::State(s) => self.push_state(s),
            Item::Event(e) => self.push_event(e),
        };
    }

    fn flush(&mut self) -> std::io::Result<()> {
        LogWriter::flush(self)
    }
}

/// The receiving side's end of the queue.
#[derive(Debug)]
pub struct Forwarder {
    tx: SyncSender<Vec<Item>>,
    /// Items dropped because the queue was full.
    pub dropped_items: u64,
}

/// The writing side's end of the queue.
#[derive(Debug)]
pub struct Queue {
    rx: Receiver<Vec<Item>>,
}

/// A queue of at most `batches` batches.
pub fn queue(batches: usize) -> (Forwarder, Queue) {
    let (tx, rx) = sync_channel(batches);
    (Forwarder { tx, dropped_items: 0 }, Queue { rx })
}

impl Forwarder {
    /// Hands a batch to the writer without waiting; false when the queue is full (the
    /// batch is dropped and counted) or the writer has ended.
    pub fn forward(&mut self, batch: Vec<Item>) -> bool {
        if batch.is_empty() {
            return true;
        }
        match self.tx.try_send(batch) {
            Ok(()) => true,
            Err(TrySendError::Full(b) | TrySendError::Disconnected(b)) => {
                self.dropped_items += b.len() as u64;
                false
            }
        }
    }
}

impl Queue {
    /// Writes every batch into `sink` until the forwarder is dropped and the queue is
    /// empty; flushes every `every` (and at the end) and hands each flush's result to
    /// `after_flush` (alarms, the recorder's health on the bus).
    pub fn write_until_closed<S: Sink>(
        self,
        sink: &mut S,
        every: Duration,
        mut after_flush: impl FnMut(&mut S, std::io::Result<()>),
    ) {
        let mut last_flush = Instant::now();
        loop {
            let wait = every.saturating_sub(last_flush.elapsed());
            let closed = match self.rx.recv_timeout(wait) {
                Ok(batch) => {
                    for item in &batch {
                        sink.push(item);
                    }
                    false
                }
                Err(RecvTimeoutError::Timeout) => false,
                Err(RecvTimeoutError::Disconnected) => true,
            };
            if closed || last_flush.elapsed() >= every {
                let r = sink.flush();
                last_flush = Instant::now();
                after_flush(sink, r);
            }
            if closed {
                return;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc::channel;

    fn state(cycle: u64) -> Item {
        Item::State(StateSample {
            cycle,
            ..StateSample::default()
        })
    }

    /// Records the cycles it is given; its first flush blocks until released (a disk that
    /// stalls).
    struct Stalling {
        cycles: Vec<u64>,
        release: Option<Receiver<()>>,
        flushes: usize,
    }

    impl Sink for Stalling {
        fn push(&mut self, item: &Item) {
            if let Item::State(s) = item {
                self.cycles.push(s.cycle);
            }
        }
        fn flush(&mut self) -> std::io::Result<()> {
            if let Some(r) = self.release.take() {
                let _ = r.recv();
            }
            self.flushes += 1;
            Ok(())
        }
    }

    #[test]
    fn a_stalled_writer_does_not_stop_the_receiving_and_nothing_is_lost() {
        let (mut fwd, q) = queue(QUEUE_BATCHES);
        let (release_tx, release_rx) = channel();
        let writer = std::thread::spawn(move || {
            let mut sink = Stalling {
                cycles: Vec::new(),
                release: Some(release_rx),
                flushes: 0,
            };
            q.write_until_closed(&mut sink, Duration::from_millis(1), |_, _| {});
            sink
        });
        // 30 s of a 1 kHz loop in 10-sample batches while the writer is stuck in its flush:
        // every batch is taken at once.
        for b in 0..3000u64 {
            assert!(
                fwd.forward((0..10).map(|i| state(1 + b * 10 + i)).collect()),
                "batch {b} refused"
            );
        }
        release_tx.send(()).unwrap();
        drop(fwd);
        let sink = writer.join().unwrap();
        assert_eq!(sink.cycles.len(), 30_000);
        assert!(
            sink.cycles.windows(2).all(|w| w[1] == w[0] + 1),
            "in order, no gap"
        );
        assert!(sink.flushes >= 2, "flushed while running and at the end");
    }

    #[test]
    fn a_full_queue_drops_whole_batches_and_the_log_counts_them_lost() {
        let dir = std::env::temp_dir().join(format!("hob-pump-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let (mut fwd, q) = queue(2);
        // Nobody writes yet: the third batch finds the queue full.
        assert!(fwd.forward(vec![state(1), state(2)]));
        assert!(fwd.forward(vec![state(3)]));
        assert!(!fwd.forward(vec![state(4), state(5)]));
        assert_eq!(fwd.dropped_items, 2);
        assert!(fwd.forward(vec![]), "an empty batch is not a drop");
        let mut w = LogWriter::open(&dir, "test").unwrap();
        let writer = std::thread::spawn(move || {
            q.write_until_closed(&mut w, Duration::from_secs(60), |_, r| r.unwrap());
            w
        });
        // Space again once the writer takes the first two.
        while !fwd.forward(vec![state(6)]) {
            std::thread::yield_now();
        }
        drop(fwd);
        let w = writer.join().unwrap();
        assert_eq!(w.stats.samples, 4);
        assert_eq!(w.stats.samples_lost, 2, "cycles 4 and 5");
        let states = crate::format::read_dir_states(&dir).unwrap();
        assert_eq!(
            states.iter().map(|s| s.cycle).collect::<Vec<_>>(),
            vec![1, 2, 3, 6]
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
