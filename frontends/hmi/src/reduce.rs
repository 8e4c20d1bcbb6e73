//! Pure reductions of the loop's streams for a screen: 1000 samples a second become one plot
//! point per frame that keeps the interval's minimum and maximum (a one-cycle spike is
//! never hidden), gaps in the cycle counter are counted, and the events are kept in a ring
//! that a reconnecting browser resynchronises from by number.

use hob_ipc::EventSample;
use serde::Serialize;
use std::collections::VecDeque;

/// One plot point: the synchronisation error over cycles `c0..=c1`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PlotPoint {
    pub c0: u64,
    pub c1: u64,
    pub min: f64,
    pub max: f64,
    pub last: f64,
    /// Samples reduced into this point.
    pub n: u32,
    /// Cycles missing inside or just before this interval (samples the HMI never got).
    pub gap: u64,
    /// A sample of the interval was in the cut (where the bound applies).
    pub cut: bool,
}

/// Reduces samples into one [`PlotPoint`] per interval.
#[derive(Debug, Default, Clone)]
pub struct Interval {
    open: Option<PlotPoint>,
}

impl Interval {
    /// Adds one sample; `gap`: the cycles missing before it; `cut`: the tool in the cut.
    pub fn push(&mut self, cycle: u64, value: f64, gap: u64, cut: bool) {
        if !value.is_finite() {
            return;
        }
        match &mut self.open {
            Some(p) => {
                p.c1 = cycle;
                p.min = p.min.min(value);
                p.max = p.max.max(value);
                p.last = value;
                p.n += 1;
                p.gap += gap;
                p.cut |= cut;
            }
            None => {
                self.open = Some(PlotPoint {
                    c0: cycle,
                    c1: cycle,
                    min: value,
                    max: value,
                    last: value,
                    n: 1,
                    gap,
                    cut,
                })
            }
        }
    }

    /// Closes the interval: its point, or none when no sample came.
    pub fn take(&mut self) -> Option<PlotPoint> {
        self.open.take()
    }
}

/// Merges consecutive points into one (a slower screen, a coarser plot): the extremes of
/// all, the last of the last.
pub fn merge(points: &[PlotPoint]) -> Option<PlotPoint> {
    let (first, rest) = points.split_first()?;
    Some(rest.iter().fold(*first, |a, p| PlotPoint {
        c0: a.c0,
        c1: p.c1,
        min: a.min.min(p.min),
        max: a.max.max(p.max),
        last: p.last,
        n: a.n + p.n,
        gap: a.gap + p.gap,
        cut: a.cut || p.cut,
    }))
}

/// Counts samples lost between the loop and the HMI from the loop's consecutive cycle
/// counter.
#[derive(Debug, Default, Clone)]
pub struct GapCounter {
    prev: Option<u64>,
    /// Cycles never received since the HMI started.
    pub missed: u64,
    /// Times the counter went back (the loop was restarted).
    pub restarts: u32,
}

impl GapCounter {
    /// The cycles missing just before `cycle` (0 for the first sample and after a restart).
    pub fn see(&mut self, cycle: u64) -> u64 {
        let gap = match self.prev {
            Some(p) if cycle > p => cycle - p - 1,
            Some(p) if cycle <= p => {
                self.restarts += 1;
                0
            }
            _ => 0,
        };
        self.prev = Some(cycle);
        self.missed += gap;
        gap
    }
}

/// The events a browser is sent after `seq`.
#[derive(Debug, Clone, PartialEq)]
pub enum Since {
    /// Every event after the one asked for.
    Events(Vec<EventSample>),
    /// Events `from..=to` are older than the ring; the rest follow.
    TooOld {
        from: u64,
        to: u64,
        events: Vec<EventSample>,
    },
}

/// The loop's events as the HMI saw them, newest last, a fixed number kept.
#[derive(Debug, Clone)]
pub struct EventLog {
    ring: VecDeque<EventSample>,
    capacity: usize,
    /// Event numbers the loop skipped or the HMI never received.
    pub missed: u64,
    /// Times the loop's numbering started over (a restarted loop): a page that saw the
    /// old numbers must start over too.
    pub generation: u64,
}

impl EventLog {
    pub fn new(capacity: usize) -> Self {
        Self {
            ring: VecDeque::with_capacity(capacity),
            capacity: capacity.max(1),
            missed: 0,
            generation: 0,
        }
    }

    /// Adds an event; an event at or below the newest number (a history replayed to a new
    /// subscriber, or a restarted loop) is kept only when it is new to the log.
    pub fn push(&mut self, e: EventSample) {
        if let Some(last) = self.ring.back() {
            if e.seq <= last.seq {
                if self.ring.iter().any(|x| x.seq == e.seq && x.cycle == e.cycle) {
                    return;
                }
                // A restarted loop numbers from 1 again: start over.
                self.ring.clear();
                self.generation += 1;
            } else {
                self.missed += e.seq - last.seq - 1;
            }
        }
        if self.ring.len() == self.capacity {
            self.ring.pop_front();
        }
        self.ring.push_back(e);
    }

    /// The newest event's number (0: none yet).
    pub fn head(&self) -> u64 {
        self.ring.back().map_or(0, |e| e.seq)
    }

    /// The events after `seq`, for a browser that has seen up to `seq`.
    pub fn since(&self, seq: u64) -> Since {
        let events: Vec<EventSample> = self.ring.iter().filter(|e| e.seq > seq).copied().collect();
        match self.ring.front() {
            Some(first) if seq + 1 < first.seq && seq > 0 => Since::TooOld {
                from: seq + 1,
                to: first.seq - 1,
                events,
            },
            _ => Since::Events(events),
        }
    }

    /// The cycles of the newest finished cycle: from the loop's acceptance of its START to
    /// its CYCLE_DONE (the cut report's range).
    pub fn last_cycle_run(&self) -> Option<(u64, u64)> {
        use hob_ipc::{command, event_kind};
        let done = self.ring.iter().rposition(|e| e.kind == event_kind::CYCLE_DONE)?;
        let last = self.ring[done].cycle;
        let first = self
            .ring
            .iter()
            .take(done)
            .rev()
            .find(|e| e.kind == event_kind::ACCEPTED && e.a == command::START)?
            .cycle;
        Some((first, last))
    }

    /// Every finished cycle the ring holds, newest first: from the loop's acceptance of its
    /// START to its CYCLE_DONE (the cuts the COMPENSATE screen offers).
    pub fn cycle_runs(&self) -> Vec<(u64, u64)> {
        use hob_ipc::{command, event_kind};
        let mut runs = Vec::new();
        let mut started = None;
        for e in &self.ring {
            if e.kind == event_kind::ACCEPTED && e.a == command::START {
                started = Some(e.cycle);
            } else if e.kind == event_kind::CYCLE_DONE
                && let Some(first) = started.take()
            {
                runs.push((first, e.cycle));
            }
        }
        runs.reverse();
        runs
    }

    /// Up to `count` events before `seq` (0: the newest), newest first: the alarm screen's pages.
    pub fn page_before(&self, seq: u64, count: usize) -> Vec<EventSample> {
        self.ring
            .iter()
            .rev()
            .filter(|e| seq == 0 || e.seq < seq)
            .take(count)
            .copied()
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ev(seq: u64) -> EventSample {
        EventSample {
            seq,
            cycle: seq * 10,
            ..EventSample::default()
        }
    }

    #[test]
    fn a_one_cycle_spike_survives_the_reduction() {
        let mut i = Interval::default();
        for c in 0..40u64 {
            i.push(c, if c == 17 { 500.0 } else { 1.0 }, 0, c == 39);
        }
        let p = i.take().expect("a point");
        assert_eq!(
            (p.min, p.max, p.last, p.n, p.c0, p.c1),
            (1.0, 500.0, 1.0, 40, 0, 39)
        );
        assert!(i.take().is_none(), "the interval starts empty again");
    }

    #[test]
    fn gaps_in_the_cycle_counter_are_counted_and_a_restart_is_not_a_gap() {
        let mut g = GapCounter::default();
        let gaps: Vec<u64> = [1, 2, 5, 6, 3, 4].iter().map(|&c| g.see(c)).collect();
        assert_eq!(gaps, vec![0, 0, 2, 0, 0, 0]);
        assert_eq!((g.missed, g.restarts), (2, 1));
    }

    #[test]
    fn a_browser_resynchronises_by_event_number() {
        let mut log = EventLog::new(4);
        for s in 1..=6 {
            log.push(ev(s));
        }
        assert_eq!(log.head(), 6);
        assert_eq!(log.since(4), Since::Events(vec![ev(5), ev(6)]));
        assert_eq!(log.since(6), Since::Events(vec![]));
        // Seen up to 1: 2 fell out of the ring (3..=6 kept).
        assert_eq!(
            log.since(1),
            Since::TooOld {
                from: 2,
                to: 2,
                events: vec![ev(3), ev(4), ev(5), ev(6)]
            }
        );
        // A first load (0) gets what there is, nothing called lost.
        assert!(matches!(log.since(0), Since::Events(v) if v.len() == 4));
        assert_eq!(log.page_before(5, 2), vec![ev(4), ev(3)]);
    }

    #[test]
    fn skipped_event_numbers_are_counted_and_a_replayed_history_is_not_doubled() {
        let mut log = EventLog::new(16);
        for s in [1, 2, 5] {
            log.push(ev(s));
        }
        assert_eq!(log.missed, 2);
        log.push(ev(2));
        assert_eq!(log.since(0), Since::Events(vec![ev(1), ev(2), ev(5)]));
        // A restarted loop numbers from 1 again.
        let mut restarted = ev(1);
        restarted.cycle = 99;
        assert_eq!(log.generation, 0);
        log.push(restarted);
        assert_eq!(log.since(0), Since::Events(vec![restarted]));
        assert_eq!(log.generation, 1);
    }

    #[test]
    fn the_last_cycle_run_goes_from_its_start_to_its_cycle_done() {
        use hob_ipc::{command, event_kind};
        let at = |seq: u64, cycle: u64, kind: u32, a: u32| EventSample {
            seq,
            cycle,
            kind,
            a,
            ..EventSample::default()
        };
        let mut log = EventLog::new(64);
        assert_eq!(log.last_cycle_run(), None);
        log.push(at(1, 100, event_kind::ACCEPTED, command::START));
        log.push(at(2, 900, event_kind::CYCLE_DONE, 0));
        log.push(at(3, 1000, event_kind::ACCEPTED, command::START));
        log.push(at(4, 1100, event_kind::ACCEPTED, command::FEED_HOLD));
        assert_eq!(
            log.last_cycle_run(),
            Some((100, 900)),
            "the running one is not done"
        );
        assert_eq!(log.cycle_runs(), [(100, 900)]);
        log.push(at(5, 2000, event_kind::CYCLE_DONE, 0));
        assert_eq!(log.last_cycle_run(), Some((1000, 2000)));
        // Every finished one, newest first, each the same range the report takes.
        assert_eq!(log.cycle_runs(), [(1000, 2000), (100, 900)]);
        log.push(at(6, 2100, event_kind::CYCLE_DONE, 0));
        assert_eq!(
            log.cycle_runs(),
            [(1000, 2000), (100, 900)],
            "a done without a start"
        );
    }

    proptest! {
        #[test]
        fn the_points_keep_the_extremes_of_the_series(
            values in prop::collection::vec(-1e4f64..1e4, 1..400),
            width in 1usize..60,
        ) {
            let mut i = Interval::default();
            let mut points = Vec::new();
            for (c, v) in values.iter().enumerate() {
                i.push(c as u64, *v, 0, false);
                if (c + 1) % width == 0 {
                    points.extend(i.take());
                }
            }
            points.extend(i.take());
            let min = values.iter().copied().fold(f64::INFINITY, f64::min);
            let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let all = merge(&points).expect("points");
            prop_assert_eq!((all.min, all.max, all.n as usize), (min, max, values.len()));
            prop_assert_eq!(all.last, *values.last().expect("a value"));
            // Merging the points equals reducing the whole series at once.
            let mut whole = Interval::default();
            for (c, v) in values.iter().enumerate() {
                whole.push(c as u64, *v, 0, false);
            }
            prop_assert_eq!(whole.take(), Some(all));
        }
    }
}
