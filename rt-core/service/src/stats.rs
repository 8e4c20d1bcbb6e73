//! The loop's timing: it records each cycle's wake-up latency and compute time into
//! preallocated HDR histograms; every half second it hands the filled pair to the stats
//! thread and takes an empty one back (no allocation, no lock: the pairs circulate through
//! two bounded mailboxes). The stats thread keeps the totals since start and publishes
//! them on the `stats` service; at shutdown the totals are written as `.hgrm` files.

use hdrhistogram::Histogram;
use hob_ipc::{Percentiles, StatsSample};
use std::fmt::Write as _;
use std::sync::mpsc::{Receiver, SyncSender};
use std::time::Duration;

/// Highest value a histogram holds, ns (larger values are recorded as this).
pub const HIGHEST_NS: u64 = 10_000_000_000;
/// Pairs in circulation: the loop's, one on its way, one being summed.
const PAIRS: usize = 3;

/// Wake-up latency and compute time of a stretch of cycles.
#[derive(Debug, Clone)]
pub struct Timing {
    pub wake_ns: Histogram<u64>,
    pub compute_ns: Histogram<u64>,
}

/// An empty latency histogram: 1 ns to [`HIGHEST_NS`], 3 significant digits.
pub fn histogram() -> Histogram<u64> {
    Histogram::new_with_bounds(1, HIGHEST_NS, 3).unwrap_or_else(|_| unreachable!("static bounds"))
}

/// Records a value, clamped into the range (allocation-free).
pub fn record(h: &mut Histogram<u64>, ns: u64) {
    h.saturating_record(ns.clamp(1, HIGHEST_NS));
}

impl Timing {
    pub fn new() -> Self {
        Self {
            wake_ns: histogram(),
            compute_ns: histogram(),
        }
    }

    /// Records one cycle (allocation-free: values are clamped into the range).
    pub fn record(&mut self, wake_ns: u64, compute_ns: u64) {
        record(&mut self.wake_ns, wake_ns);
        record(&mut self.compute_ns, compute_ns);
    }

    fn reset(&mut self) {
        self.wake_ns.reset();
        self.compute_ns.reset();
    }
}

impl Default for Timing {
    fn default() -> Self {
        Self::new()
    }
}

/// A distribution's summary.
pub fn percentiles(h: &Histogram<u64>) -> Percentiles {
    if h.is_empty() {
        return Percentiles::default();
    }
    Percentiles {
        count: h.len(),
        min_ns: h.min(),
        p50_ns: h.value_at_quantile(0.5),
        p90_ns: h.value_at_quantile(0.9),
        p99_ns: h.value_at_quantile(0.99),
        p999_ns: h.value_at_quantile(0.999),
        p9999_ns: h.value_at_quantile(0.9999),
        max_ns: h.max(),
    }
}

/// A distribution in powers of two (for a frontend's histogram; off the loop).
pub fn log2(h: &Histogram<u64>) -> hob_ipc::Log2Histogram {
    let mut out = hob_ipc::Log2Histogram::default();
    for v in h.iter_recorded() {
        out.add(v.value_iterated_to(), v.count_at_value());
    }
    out
}

/// HdrHistogram's percentile distribution text (`.hgrm`, as `HistogramLogProcessor` and
/// the plotters read it), values in microseconds.
pub fn hgrm(h: &Histogram<u64>) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:>12} {:>14} {:>10} {:>14}\n",
        "Value", "Percentile", "TotalCount", "1/(1-Percentile)"
    );
    for v in h.iter_quantiles(5) {
        let q = v.quantile_iterated_to();
        let inv = if q < 1.0 {
            format!("{:14.2}", 1.0 / (1.0 - q))
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "{:12.3} {:2.12} {:10} {inv}",
            v.value_iterated_to() as f64 / 1000.0,
            q,
            v.count_since_last_iteration()
        );
    }
    let p = percentiles(h);
    let mean = h.mean() / 1000.0;
    let sd = h.stdev() / 1000.0;
    let _ = writeln!(s, "#[Mean    = {mean:12.3}, StdDeviation   = {sd:12.3}]");
    let _ = writeln!(
        s,
        "#[Max     = {:12.3}, Total count    = {:12}]",
        p.max_ns as f64 / 1000.0,
        p.count
    );
    let _ = writeln!(
        s,
        "#[Buckets = {:12}, SubBuckets     = {:12}]",
        h.buckets(),
        h.distinct_values()
    );
    s
}

/// Every recorded value with its count, one `value_ns count` line each (lossless, unlike
/// the `.hgrm` text; the benchmarks read it back with [`from_counts_text`]).
pub fn counts_text(h: &Histogram<u64>) -> String {
    let mut s = String::from("# value_ns count\n");
    for v in h.iter_recorded() {
        let _ = writeln!(s, "{} {}", v.value_iterated_to(), v.count_at_value());
    }
    s
}

/// A histogram from [`counts_text`].
pub fn from_counts_text(text: &str) -> Result<Histogram<u64>, String> {
    let mut h = histogram();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut f = line.split_whitespace().map(str::parse::<u64>);
        match (f.next(), f.next(), f.next()) {
            (Some(Ok(v)), Some(Ok(c)), None) => h
                .record_n(v.clamp(1, HIGHEST_NS), c)
                .map_err(|e| format!("line {}: {e}", n + 1))?,
            _ => return Err(format!("line {}: expected `value_ns count`: {line}", n + 1)),
        }
    }
    Ok(h)
}

/// The loop's end of the circulation.
#[derive(Debug)]
pub struct LoopTiming {
    pub current: Timing,
    full: SyncSender<Timing>,
    empty: Receiver<Timing>,
    /// A pair that could not be handed over (the stats thread is gone): kept, never dropped
    /// in the loop.
    parked: Option<Timing>,
}

/// The stats thread's end.
#[derive(Debug)]
pub struct StatsTiming {
    full: Receiver<Timing>,
    empty: SyncSender<Timing>,
    pub total: Timing,
}

/// Creates the circulation with its preallocated pairs.
pub fn circulation() -> (LoopTiming, StatsTiming) {
    let (full_tx, full_rx) = std::sync::mpsc::sync_channel(PAIRS + 1);
    let (empty_tx, empty_rx) = std::sync::mpsc::sync_channel(PAIRS + 1);
    for _ in 1..PAIRS {
        let _ = empty_tx.try_send(Timing::new());
    }
    (
        LoopTiming {
            current: Timing::new(),
            full: full_tx,
            empty: empty_rx,
            parked: None,
        },
        StatsTiming {
            full: full_rx,
            empty: empty_tx,
            total: Timing::new(),
        },
    )
}

impl LoopTiming {
    /// Hands the current pair over if an empty one is ready (allocation-free).
    pub fn hand_over(&mut self) {
        if self.parked.is_some() {
            return;
        }
        if let Ok(empty) = self.empty.try_recv() {
            let full = std::mem::replace(&mut self.current, empty);
            if let Err(e) = self.full.try_send(full) {
                let back = match e {
                    std::sync::mpsc::TrySendError::Full(t)
                    | std::sync::mpsc::TrySendError::Disconnected(t) => t,
                };
                // Keep recording into the full one; the empty one waits here.
                let empty = std::mem::replace(&mut self.current, back);
                self.parked = Some(empty);
            }
        }
    }
}

impl StatsTiming {
    /// Adds every pair handed over since the last call into the totals and returns the
    /// emptied pairs. Returns whether anything came.
    pub fn collect(&mut self) -> bool {
        let mut any = false;
        while let Ok(t) = self.full.try_recv() {
            self.absorb(t);
            any = true;
        }
        any
    }

    /// Adds a handed-over pair into the totals and returns it emptied.
    fn absorb(&mut self, mut t: Timing) {
        let _ = self.total.wake_ns.add(&t.wake_ns);
        let _ = self.total.compute_ns.add(&t.compute_ns);
        t.reset();
        let _ = self.empty.try_send(t);
    }

    /// Waits up to `d` for pairs (the stats thread's pace).
    pub fn wait(&mut self, d: Duration) -> bool {
        match self.full.recv_timeout(d) {
            Ok(t) => {
                self.absorb(t);
                self.collect();
                true
            }
            Err(_) => false,
        }
    }

    /// The totals as a stats sample (the loop's counters are filled by the caller).
    pub fn sample(&self) -> StatsSample {
        StatsSample {
            wake_latency: percentiles(&self.total.wake_ns),
            compute: percentiles(&self.total.compute_ns),
            wake_histogram: log2(&self.total.wake_ns),
            compute_histogram: log2(&self.total.compute_ns),
            ..StatsSample::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_circulate_and_the_totals_keep_everything() {
        let (mut lp, mut st) = circulation();
        for round in 0..10u64 {
            for i in 0..100 {
                lp.current.record(1000 + i, 50_000 + round);
            }
            lp.hand_over();
            st.collect();
        }
        assert_eq!(st.total.wake_ns.len(), 1000);
        assert_eq!(lp.current.wake_ns.len(), 0);
        let p = percentiles(&st.total.wake_ns);
        assert_eq!(p.min_ns, 1000);
        assert!((1098..=1100).contains(&p.max_ns), "{p:?}");
    }

    #[test]
    fn without_the_stats_thread_the_loop_keeps_recording() {
        let (mut lp, st) = circulation();
        drop(st);
        for _ in 0..5 {
            lp.current.record(10, 10);
            lp.hand_over();
        }
        assert_eq!(lp.current.wake_ns.len(), 5, "nothing recorded may be lost");
    }

    #[test]
    fn out_of_range_values_are_clamped_not_lost() {
        let mut t = Timing::new();
        t.record(0, u64::MAX);
        assert_eq!(t.wake_ns.len(), 1);
        assert!(t.compute_ns.max() >= HIGHEST_NS / 2);
    }

    #[test]
    fn the_log2_histogram_keeps_every_count_in_its_power_of_two() {
        let mut h = histogram();
        for ns in [0, 1, 3, 1000, 1023, 1024, 50_000, 50_000, 2_000_000] {
            record(&mut h, ns);
        }
        let l = log2(&h);
        assert_eq!(l.counts.iter().sum::<u64>(), 9);
        assert_eq!(l.counts[0], 2, "0 and 1 ns");
        assert_eq!(l.counts[1], 1, "3 ns");
        assert_eq!(l.counts[9], 2, "1000 and 1023 ns");
        assert_eq!(l.counts[10], 1, "1024 ns");
        assert_eq!(l.counts[15], 2, "50 us");
        assert_eq!(l.counts[20], 1, "2 ms");
    }

    #[test]
    fn counts_text_round_trips_exactly() {
        let mut t = Timing::new();
        for v in [1_000u64, 1_000, 25_000, 1_000_000, 64_000_000] {
            t.record(v, 5);
        }
        let back = from_counts_text(&counts_text(&t.wake_ns)).expect("parses");
        assert_eq!(back, t.wake_ns);
        assert!(from_counts_text("12 x").is_err());
        assert!(from_counts_text("12 1 2").is_err());
    }

    #[test]
    fn hgrm_has_the_header_and_the_totals() {
        let mut t = Timing::new();
        for v in 1..=1000 {
            t.record(v * 1000, 1);
        }
        let s = hgrm(&t.wake_ns);
        assert!(s.starts_with("       Value"), "{s}");
        assert!(s.contains("Total count    =         1000"), "{s}");
    }
}
