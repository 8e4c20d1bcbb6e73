//! The loop's two signs of life, each with the same deadline: the `state` stream it
//! publishes on shared memory (one sample per cycle) and the SYNC frames it sends on the
//! CAN bus (one per cycle: the loop's real output, which the watchdog hears on a socket of
//! its own). Either going silent past the deadline trips the watchdog: a loop that keeps
//! publishing but no longer drives the bus is as dead to the machine as one that stopped.
//!
//! Pure bookkeeping over a monotonic clock in ns: unit-tested here, used by `main`.

/// Which sign of life went silent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// The loop's `state` samples on shared memory.
    State,
    /// The SYNC frames on the CAN bus.
    Sync,
}

impl Channel {
    pub fn name(self) -> &'static str {
        match self {
            Channel::State => "state",
            Channel::Sync => "sync",
        }
    }
}

/// A silence past the deadline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Silence {
    pub channel: Channel,
    /// Time since the channel's last sign of life when it was noticed, ms.
    pub silence_ms: f64,
    /// Whether the other channel was still alive then (within the deadline).
    pub other_alive: bool,
}

/// One channel: armed by its first sign of life, never before (a loop still booting its bus
/// sends no SYNC yet).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Seen {
    last_ns: Option<u64>,
}

impl Seen {
    fn silent_for(self, now_ns: u64) -> Option<u64> {
        self.last_ns.map(|t| now_ns.saturating_sub(t))
    }
}

/// Both channels and the deadline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Liveness {
    deadline_ns: u64,
    state: Seen,
    sync: Seen,
}

impl Liveness {
    pub fn new(deadline_ns: u64) -> Self {
        Self {
            deadline_ns,
            state: Seen::default(),
            sync: Seen::default(),
        }
    }

    /// A state sample arrived at `now_ns`.
    pub fn state_seen(&mut self, now_ns: u64) {
        self.state.last_ns = Some(now_ns);
    }

    /// A SYNC frame arrived at `now_ns`.
    pub fn sync_seen(&mut self, now_ns: u64) {
        self.sync.last_ns = Some(now_ns);
    }

    /// Whether the channel has shown a sign of life since the start or the last re-arm.
    pub fn armed(&self, channel: Channel) -> bool {
        self.seen(channel).last_ns.is_some()
    }

    fn seen(&self, channel: Channel) -> Seen {
        match channel {
            Channel::State => self.state,
            Channel::Sync => self.sync,
        }
    }

    /// Forgets both channels (a new loop started): each re-arms on its next sign of life.
    pub fn rearm(&mut self) {
        self.state = Seen::default();
        self.sync = Seen::default();
    }

    /// The first armed channel silent for longer than the deadline at `now_ns` (the longer
    /// silence when both are).
    pub fn check(&self, now_ns: u64) -> Option<Silence> {
        let late = |c: Channel| {
            self.seen(c)
                .silent_for(now_ns)
                .filter(|&s| s > self.deadline_ns)
                .map(|s| (c, s))
        };
        let (channel, silent_ns) = match (late(Channel::State), late(Channel::Sync)) {
            (Some(a), Some(b)) => {
                if b.1 > a.1 {
                    b
                } else {
                    a
                }
            }
            (Some(a), None) | (None, Some(a)) => a,
            (None, None) => return None,
        };
        let other = match channel {
            Channel::State => Channel::Sync,
            Channel::Sync => Channel::State,
        };
        let other_alive = self
            .seen(other)
            .silent_for(now_ns)
            .is_some_and(|s| s <= self.deadline_ns);
        Some(Silence {
            channel,
            silence_ms: silent_ns as f64 / 1e6,
            other_alive,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const MS: u64 = 1_000_000;

    #[test]
    fn nothing_trips_before_a_channel_has_shown_life() {
        let l = Liveness::new(10 * MS);
        assert_eq!(l.check(1_000 * MS), None);
        assert!(!l.armed(Channel::State) && !l.armed(Channel::Sync));
    }

    #[test]
    fn a_loop_that_publishes_but_sends_no_sync_trips_on_the_sync() {
        let mut l = Liveness::new(10 * MS);
        for t in 0..=100 {
            l.state_seen(t * MS);
            if t <= 50 {
                l.sync_seen(t * MS);
            }
        }
        // 50 ms of SYNC silence with the state stream live.
        assert_eq!(l.check(60 * MS + 1).map(|s| s.channel), Some(Channel::Sync));
        assert_eq!(
            l.check(100 * MS),
            Some(Silence {
                channel: Channel::Sync,
                silence_ms: 50.0,
                other_alive: true
            })
        );
        // At exactly the deadline it has not passed yet.
        assert_eq!(l.check(60 * MS), None);
    }

    #[test]
    fn a_loop_that_sends_sync_but_no_longer_publishes_trips_on_the_state() {
        let mut l = Liveness::new(10 * MS);
        for t in 0..=100 {
            l.sync_seen(t * MS);
            if t <= 20 {
                l.state_seen(t * MS);
            }
        }
        let s = l.check(100 * MS).unwrap();
        assert_eq!(
            (s.channel, s.silence_ms, s.other_alive),
            (Channel::State, 80.0, true)
        );
    }

    #[test]
    fn both_silent_names_the_longer_silence_and_rearm_forgets_both() {
        let mut l = Liveness::new(10 * MS);
        l.sync_seen(5 * MS);
        l.state_seen(7 * MS);
        let s = l.check(40 * MS).unwrap();
        assert_eq!((s.channel, s.other_alive), (Channel::Sync, false));
        l.rearm();
        assert_eq!(l.check(1_000 * MS), None);
    }

    proptest! {
        /// It trips exactly when a channel that has shown life has been silent longer than
        /// the deadline, and the silence it reports is that channel's.
        #[test]
        fn trips_exactly_past_the_deadline(
            deadline_ms in 2u64..200,
            state_at in proptest::option::of(0u64..1_000_000_000),
            sync_at in proptest::option::of(0u64..1_000_000_000),
            now in 0u64..2_000_000_000,
        ) {
            let mut l = Liveness::new(deadline_ms * MS);
            if let Some(t) = state_at { l.state_seen(t); }
            if let Some(t) = sync_at { l.sync_seen(t); }
            let late = |at: Option<u64>| at.is_some_and(|t| now.saturating_sub(t) > deadline_ms * MS);
            let r = l.check(now);
            prop_assert_eq!(r.is_some(), late(state_at) || late(sync_at));
            if let Some(s) = r {
                let at = match s.channel { Channel::State => state_at, Channel::Sync => sync_at };
                let at = at.unwrap();
                prop_assert!((s.silence_ms - now.saturating_sub(at) as f64 / 1e6).abs() < 1e-9);
            }
        }
    }
}
