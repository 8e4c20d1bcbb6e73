//! The real clock start-up waits on (`hob_canopen::bus::Clock`): the monotonic clock and
//! a sleep. The protocol and the master read no clock themselves; whoever brings a bus up
//! hands them this one.

use hob_canopen::bus::Clock;
use std::time::{Duration, Instant};

/// The monotonic clock from its creation, and the thread's sleep.
#[derive(Debug, Clone, Copy)]
pub struct SystemClock {
    origin: Instant,
}

impl SystemClock {
    pub fn new() -> Self {
        Self {
            origin: Instant::now(),
        }
    }
}

impl Default for SystemClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for SystemClock {
    fn now(&self) -> Duration {
        self.origin.elapsed()
    }

    fn pause(&mut self, d: Duration) {
        std::thread::sleep(d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clock_moves_on_by_at_least_each_pause() {
        let mut c = SystemClock::new();
        let t0 = c.now();
        c.pause(Duration::from_millis(2));
        assert!(c.now() >= t0 + Duration::from_millis(2));
    }
}
