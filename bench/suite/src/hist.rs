//! Latency distributions: HDR histograms in ns, their summary, and readers for the
//! histograms `hob-rt --hgrm` and `cyclictest --json` write.

use hdrhistogram::Histogram;
use hob_service::stats::{self, HIGHEST_NS};
use serde::{Deserialize, Serialize};

/// A distribution's summary, microseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub count: u64,
    pub min_us: f64,
    pub p50_us: f64,
    pub p99_us: f64,
    pub p999_us: f64,
    pub p9999_us: f64,
    pub max_us: f64,
    pub mean_us: f64,
}

pub fn new() -> Histogram<u64> {
    stats::histogram()
}

pub fn record(h: &mut Histogram<u64>, ns: u64) {
    stats::record(h, ns);
}

/// [`stats::percentiles`] in microseconds, with the mean.
pub fn summary(h: &Histogram<u64>) -> Summary {
    let p = stats::percentiles(h);
    let us = |ns: u64| ns as f64 / 1e3;
    Summary {
        count: p.count,
        min_us: us(p.min_ns),
        p50_us: us(p.p50_ns),
        p99_us: us(p.p99_ns),
        p999_us: us(p.p999_ns),
        p9999_us: us(p.p9999_ns),
        max_us: us(p.max_ns),
        mean_us: if h.is_empty() { 0.0 } else { h.mean() / 1e3 },
    }
}

/// Wake-ups that came a whole period or more late, and the periods they cost (a wake-up
/// `k` periods late skipped `k` deadlines), from a wake-up latency histogram.
pub fn late_wakeups(h: &Histogram<u64>, period_ns: u64) -> (u64, u64) {
    let mut wakeups = 0;
    let mut periods = 0;
    for v in h.iter_recorded() {
        let value = v.value_iterated_to();
        if value >= period_ns {
            wakeups += v.count_at_value();
            periods += v.count_at_value() * (value / period_ns);
        }
    }
    (wakeups, periods)
}

/// cyclictest's result (`--json`, with `-h`): the first thread's histogram (1 us buckets,
/// recorded at the bucket's value) plus the samples beyond its range at the maximum.
pub fn from_cyclictest_json(text: &str) -> Result<(Histogram<u64>, serde_json::Value), String> {
    let j: serde_json::Value = serde_json::from_str(text).map_err(|e| format!("cyclictest json: {e}"))?;
    let t = &j["thread"]["0"];
    let buckets = t["histogram"]
        .as_object()
        .ok_or("cyclictest json: no histogram in thread 0 (run with -h)")?;
    let mut h = new();
    let mut n = 0;
    for (k, v) in buckets {
        let us: u64 = k.parse().map_err(|_| format!("cyclictest json: bucket {k}"))?;
        let c = v
            .as_u64()
            .ok_or_else(|| format!("cyclictest json: count of bucket {k}"))?;
        h.saturating_record_n((us * 1000).clamp(1, HIGHEST_NS), c);
        n += c;
    }
    let cycles = t["cycles"].as_u64().ok_or("cyclictest json: no cycle count")?;
    let max_us = t["max"].as_u64().ok_or("cyclictest json: no max")?;
    if cycles > n {
        h.saturating_record_n((max_us * 1000).clamp(1, HIGHEST_NS), cycles - n);
    }
    Ok((h, j))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn late_wakeups_count_the_periods_skipped() {
        let mut h = new();
        for v in [20_000, 999_000, 1_000_000, 2_500_000, 64_000_000] {
            record(&mut h, v);
        }
        let (w, p) = late_wakeups(&h, 1_000_000);
        assert_eq!(w, 3);
        // 1 + 2 + 64 (within the histogram's 0.1 % precision).
        assert!((66..=67).contains(&p), "{p}");
    }

    #[test]
    fn cyclictest_histogram_with_overflows() {
        let text =
            r#"{"thread": {"0": {"histogram": {"12": 3, "20": 1}, "cycles": 5, "min": 12, "max": 340}}}"#;
        let (h, _) = from_cyclictest_json(text).expect("parses");
        assert_eq!(h.len(), 5);
        let s = summary(&h);
        assert!((s.min_us - 12.0).abs() < 0.1);
        assert!((s.max_us - 340.0).abs() < 1.0, "{s:?}");
        assert!(from_cyclictest_json(r#"{"thread": {"0": {}}}"#).is_err());
    }

    #[test]
    fn summary_of_an_empty_histogram_is_zero() {
        assert_eq!(summary(&new()).count, 0);
    }
}
