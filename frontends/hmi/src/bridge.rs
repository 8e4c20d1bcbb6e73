//! The bridge between the loop's streams and the browsers: one thread owns the iceoryx2
//! subscriber (its ports are not thread-safe), drains every sample without ever making the
//! loop wait (iceoryx2 overwrites the oldest sample of a slow subscriber), reduces each
//! screen interval to one frame and hands frames, events and stats to the web server
//! through `tokio::sync::watch` channels (a browser reads the newest, never blocks the bridge).

use crate::protocol::{CycleClock, EventView, Frame, StateView, StatsView};
use crate::reduce::{EventLog, GapCounter, Interval, Since};
use hob_ipc::{EventSample, RecorderSample, StateSample, StatsSample};
use hob_setup::config::machine::IoMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use tokio::sync::watch;

/// Events the HMI keeps for reconnecting browsers and the alarm screen.
pub const EVENT_RING: usize = 4096;
/// How often the bridge drains the loop's streams.
pub const DRAIN_EVERY: Duration = Duration::from_millis(5);
/// How often a frame goes to the browsers (25 Hz); a change of what the status line shows
/// (the state, the alarm, feed hold) goes at once, at the next drain, between them.
pub const FRAME_EVERY: Duration = Duration::from_millis(40);

/// The events and what dates them.
#[derive(Debug)]
pub struct EventBook {
    pub log: EventLog,
    pub clock: Option<CycleClock>,
}

impl EventBook {
    /// The events after `seq` in words, and the numbers that are older than the ring.
    pub fn since(&self, seq: u64) -> (Vec<EventView>, Option<(u64, u64)>) {
        let (events, lost) = match self.log.since(seq) {
            Since::Events(e) => (e, None),
            Since::TooOld { from, to, events } => (events, Some((from, to))),
        };
        (
            events.iter().map(|e| EventView::of(e, self.clock)).collect(),
            lost,
        )
    }
}

/// What the web server reads: the newest frame, the events, the newest stats.
#[derive(Debug, Clone)]
pub struct Hub {
    pub frames: watch::Receiver<Arc<Frame>>,
    pub events_head: watch::Receiver<u64>,
    pub events: Arc<Mutex<EventBook>>,
    pub stats: watch::Receiver<Option<Arc<StatsView>>>,
}

impl Hub {
    pub fn book(&self) -> MutexGuard<'_, EventBook> {
        self.events
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

/// The writing side of the [`Hub`], owned by the bridge.
#[derive(Debug)]
pub struct Bridge {
    io: IoMap,
    silence: Duration,
    gaps: GapCounter,
    interval: Interval,
    newest: Option<(StateSample, Instant)>,
    period_ns: u64,
    frame_seq: u64,
    frames: watch::Sender<Arc<Frame>>,
    events_head: watch::Sender<u64>,
    events: Arc<Mutex<EventBook>>,
    stats: watch::Sender<Option<Arc<StatsView>>>,
    recorder: Option<RecorderSample>,
    /// A sample since the last frame changed what the status line shows.
    changed: bool,
    /// The newest sample of the previous frame (the speeds are over the frame's interval).
    previous: Option<StateSample>,
}

/// What the status line shows of a sample: a change of it is sent at once.
fn headline(s: &StateSample) -> (u32, u32, u8, u8) {
    (s.state, s.alarm.code, s.hold, s.program_loaded)
}

impl Bridge {
    /// A bridge and the hub that reads it; `silence`: after this long without a sample the
    /// frames say the loop is silent.
    pub fn new(io: IoMap, silence: Duration) -> (Self, Hub) {
        let empty = Frame {
            seq: 0,
            loop_age_ms: None,
            sample_utc_ms: None,
            silent_ms: None,
            samples_missed: 0,
            loop_restarts: 0,
            state: None,
            speeds: None,
            plot: None,
            events_head: 0,
            recorder: hob_ipc::codec::recorder_view(None, 0).into(),
        };
        let (frames, frames_rx) = watch::channel(Arc::new(empty));
        let (events_head, events_head_rx) = watch::channel(0);
        let (stats, stats_rx) = watch::channel(None);
        let events = Arc::new(Mutex::new(EventBook {
            log: EventLog::new(EVENT_RING),
            clock: None,
        }));
        let hub = Hub {
            frames: frames_rx,
            events_head: events_head_rx,
            events: events.clone(),
            stats: stats_rx,
        };
        let bridge = Self {
            io,
            silence,
            gaps: GapCounter::default(),
            interval: Interval::default(),
            newest: None,
            period_ns: 1_000_000,
            frame_seq: 0,
            frames,
            events_head,
            events,
            stats,
            recorder: None,
            changed: false,
            previous: None,
        };
        (bridge, hub)
    }

    pub fn state(&mut self, s: StateSample, now: Instant) {
        let gap = self.gaps.see(s.cycle);
        if let Some((prev, _)) = &self.newest
            && s.cycle == prev.cycle + 1
            && s.sync_time_ns > prev.sync_time_ns
        {
            // The loop's real period, for dating events.
            self.period_ns = s.sync_time_ns - prev.sync_time_ns;
        }
        self.interval.push(
            s.cycle,
            s.sync_error_arcsec,
            gap,
            s.state == hob_ipc::codec::State::Cut.code(),
        );
        self.changed |= self
            .newest
            .as_ref()
            .is_none_or(|(prev, _)| headline(prev) != headline(&s));
        self.newest = Some((s, now));
    }

    /// Whether a sample since the last frame changed the state, the alarm, feed hold or the
    /// loaded program: its frame goes at once instead of at the next 25 Hz tick.
    pub fn changed(&self) -> bool {
        self.changed
    }

    pub fn event(&mut self, e: EventSample) {
        let head = {
            let mut book = self
                .events
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            book.log.push(e);
            book.log.head()
        };
        self.events_head.send_replace(head);
    }

    pub fn stats(&mut self, s: &StatsSample) {
        if s.period_ns > 0 {
            self.period_ns = s.period_ns;
        }
        self.stats.send_replace(Some(Arc::new(StatsView::of(s))));
    }

    /// Closes the interval and publishes a frame; `mono_ns`: CLOCK_MONOTONIC now (the
    /// samples' SYNC times are on it), `utc_ms`: the wall clock now.
    /// The recorder's newest report.
    pub fn recorder(&mut self, r: RecorderSample) {
        self.recorder = Some(r);
    }

    pub fn frame(&mut self, now: Instant, mono_ns: u64, utc_ms: u64) -> Arc<Frame> {
        self.frame_seq += 1;
        self.changed = false;
        let silent_for = self
            .newest
            .as_ref()
            .map_or(Duration::MAX, |(_, at)| now.duration_since(*at));
        let silent_ms =
            (silent_for >= self.silence).then(|| silent_for.as_millis().min(u128::from(u64::MAX)) as u64);
        if let Some((s, _)) = &self.newest {
            let mut book = self
                .events
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            book.clock = Some(CycleClock {
                cycle: s.cycle,
                utc_ms: utc_ms.saturating_sub(silent_for.as_millis() as u64),
                period_ns: self.period_ns,
            });
        }
        let loop_age_ms = self
            .newest
            .as_ref()
            .map(|(s, _)| mono_ns.saturating_sub(s.sync_time_ns) as f64 / 1e6);
        let newest = self.newest.as_ref().map(|(s, _)| *s);
        let speeds = match (&self.previous, &newest) {
            (Some(a), Some(b)) => crate::protocol::Speeds::between(a, b),
            _ => None,
        };
        if newest.is_some() {
            self.previous = newest;
        }
        let frame = Arc::new(Frame {
            seq: self.frame_seq,
            loop_age_ms,
            sample_utc_ms: loop_age_ms.map(|age| utc_ms as f64 - age),
            silent_ms,
            samples_missed: self.gaps.missed,
            loop_restarts: self.gaps.restarts,
            state: self
                .newest
                .as_ref()
                .map(|(s, _)| StateView::of(s, &self.io, self.period_ns)),
            speeds,
            plot: self.interval.take(),
            events_head: *self.events_head.borrow(),
            recorder: hob_ipc::codec::recorder_view(self.recorder.as_ref(), mono_ns).into(),
        });
        self.frames.send_replace(frame.clone());
        frame
    }
}

/// Wall-clock milliseconds since the epoch.
pub fn utc_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

/// The bridge thread: subscribes as `hob-hmi-PID` (or follows through `hob-gateway` when
/// `HOB_GATEWAY` names it), drains every [`DRAIN_EVERY`], publishes
/// a frame every [`FRAME_EVERY`] and one at once when the status line's values changed
/// ([`Bridge::changed`]), until `stop`.
pub fn run(mut bridge: Bridge, stop: &AtomicBool) {
    // The bus or the gateway may not be there yet (the HMI started first, the gateway
    // restarting): the frames say the loop is silent meanwhile, and this tries again.
    let name = format!("hob-hmi-{}", std::process::id());
    let mut said = false;
    let mut ports = loop {
        match hob_ipc::follow(&name) {
            Ok(p) => break p,
            Err(e) => {
                if !said {
                    eprintln!("hob-hmi: {e}; trying again every second");
                    said = true;
                }
                if stop.load(Ordering::Relaxed) {
                    return;
                }
                let now = Instant::now();
                bridge.frame(now, hob_rt_os::now_ns(), utc_ms());
                std::thread::sleep(Duration::from_secs(1));
            }
        }
    };
    let mut next_frame = Instant::now() + FRAME_EVERY;
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        while let Some(s) = ports.next_state() {
            bridge.state(s, now);
        }
        while let Some(e) = ports.next_event() {
            bridge.event(e);
        }
        if let Some(s) = ports.latest_stats() {
            bridge.stats(&s);
        }
        if let Some(r) = ports.latest_recorder() {
            bridge.recorder(r);
        }
        if now >= next_frame {
            bridge.frame(now, hob_rt_os::now_ns(), utc_ms());
            next_frame += FRAME_EVERY;
            if next_frame < now {
                next_frame = now + FRAME_EVERY;
            }
        } else if bridge.changed() {
            // Between the ticks, which keep their pace.
            bridge.frame(now, hob_rt_os::now_ns(), utc_ms());
        }
        std::thread::sleep(DRAIN_EVERY);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn io() -> IoMap {
        hob_store::files::load_machine(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/machine.toml"
        )))
        .expect("the shipped machine file")
        .io
    }

    fn sample(cycle: u64, err: f64) -> StateSample {
        StateSample {
            cycle,
            sync_time_ns: cycle * 1_000_000,
            sync_error_arcsec: err,
            ..Default::default()
        }
    }

    #[test]
    fn a_frame_carries_the_interval_the_age_and_the_gaps() {
        let (mut b, hub) = Bridge::new(io(), Duration::from_millis(100));
        let t0 = Instant::now();
        for c in (1..=40).filter(|c| *c != 20 && *c != 21) {
            b.state(sample(c, if c == 30 { -7.5 } else { 0.5 }), t0);
        }
        let f = b.frame(
            t0 + Duration::from_millis(3),
            40 * 1_000_000 + 2_500_000,
            1_000_000,
        );
        let p = f.plot.expect("a plot point");
        assert_eq!((p.min, p.max, p.n, p.gap), (-7.5, 0.5, 38, 2));
        assert_eq!(f.samples_missed, 2);
        assert_eq!(f.loop_age_ms, Some(2.5));
        assert_eq!(f.silent_ms, None);
        assert_eq!(f.state.as_ref().map(|s| s.cycle), Some(40));
        assert_eq!(hub.frames.borrow().seq, 1);
        // Nothing new: no plot point, and after the silence limit the frame says so.
        let f = b.frame(t0 + Duration::from_millis(150), 0, 1_000_150);
        assert!(f.plot.is_none());
        assert_eq!(f.silent_ms, Some(150));
        assert!(f.state.is_some(), "the old values stay, marked silent");
    }

    /// A change of the state (or the alarm, feed hold, the loaded program) asks for a frame
    /// at once; a sample that only moves the axes waits for the 25 Hz tick.
    #[test]
    fn a_change_of_the_status_line_asks_for_a_frame_at_once() {
        let (mut b, _hub) = Bridge::new(io(), Duration::from_millis(100));
        let t0 = Instant::now();
        b.state(sample(1, 0.0), t0);
        assert!(b.changed(), "the first sample");
        b.frame(t0, 0, 0);
        assert!(!b.changed());
        b.state(sample(2, 3.0), t0);
        assert!(!b.changed(), "the sync error alone is not the status line");
        for (i, edit) in [
            (|s: &mut StateSample| s.state = hob_ipc::codec::State::Cut.code()) as fn(&mut StateSample),
            |s| s.alarm.code = 3,
            |s| s.hold = 1,
            |s| s.program_loaded = 1,
        ]
        .into_iter()
        .enumerate()
        {
            let mut s = sample(3 + i as u64, 0.0);
            edit(&mut s);
            b.state(s, t0);
            assert!(b.changed(), "change {i}");
            b.frame(t0, 0, 0);
            b.state(sample(10 + i as u64, 0.0), t0);
            b.frame(t0, 0, 0);
        }
    }

    /// AUTOMATIC's actual feed and table speed: over the frame's interval, from the samples'
    /// positions and SYNC times; the table's angle across its turn counts the short way.
    #[test]
    fn the_speeds_are_over_the_frames_interval() {
        let (mut b, _hub) = Bridge::new(io(), Duration::from_millis(100));
        let t0 = Instant::now();
        let at = |cycle: u64, y: f64, table: f64| {
            let mut s = sample(cycle, 0.0);
            s.y_mm.actual = y;
            s.table_deg.actual = table;
            s
        };
        b.state(at(1000, 10.0, 359.0), t0);
        assert!(b.frame(t0, 0, 0).speeds.is_none(), "one frame: no interval yet");
        b.state(at(1040, 10.1, 359.5), t0);
        b.state(at(1080, 10.2, 0.2), t0);
        let v = b.frame(t0, 0, 0).speeds.expect("speeds");
        // 0.2 mm in 80 ms: 150 mm/min; 1.2 deg in 80 ms: 2.5 rpm.
        assert!((v.y_feed_mm_min - 150.0).abs() < 1e-9, "{v:?}");
        assert!((v.table_rpm - 2.5).abs() < 1e-9, "{v:?}");
        assert_eq!(v.x_feed_mm_min, 0.0);
    }

    #[test]
    fn events_are_kept_and_dated_from_the_newest_cycle() {
        let (mut b, hub) = Bridge::new(io(), Duration::from_millis(100));
        let t0 = Instant::now();
        b.state(sample(1000, 0.0), t0);
        b.state(sample(1001, 0.0), t0);
        b.event(EventSample {
            seq: 1,
            cycle: 501,
            kind: hob_ipc::event_kind::CYCLE_DONE,
            ..Default::default()
        });
        assert_eq!(*hub.events_head.borrow(), 1);
        b.frame(t0, 0, 10_000_000);
        let (ev, lost) = hub.book().since(0);
        assert_eq!(lost, None);
        assert_eq!(ev.len(), 1);
        assert_eq!(ev[0].text, "cycle done");
        assert_eq!(ev[0].utc_ms, Some(10_000_000 - 500));
    }
}
