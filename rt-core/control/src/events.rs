//! Events of the loop in a fixed ring: pushed in the cycle, drained by whoever publishes
//! them. When full, the oldest event is overwritten and counted as lost.

use super::command::{Command, Direction, State};
use super::fault::{Axis, Fault, Refusal};

/// Capacity of the ring.
pub const EVENT_CAPACITY: usize = 256;

/// What happened.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum EventKind {
    StateChanged {
        from: State,
        to: State,
    },
    Fault(Fault),
    FaultCleared,
    PassStarted {
        pass: u32,
    },
    /// First engagement on this blank: its tooth phase, deg.
    PhaseRecorded {
        phase_deg: f64,
    },
    /// A flank touched with the table turned in `turned`: the tooth phase there, deg.
    FlankTouched {
        turned: Direction,
        phase_deg: f64,
    },
    /// Both flanks touched: the part's tooth phase (their middle) and the play between
    /// them, deg.
    PhaseAligned {
        phase_deg: f64,
        play_deg: f64,
    },
    Accepted(Command),
    Refused {
        command: Command,
        reason: Refusal,
    },
    ProgramLoaded,
    CycleDone,
    /// An axis is referenced (its homing completed).
    Referenced {
        axis: Axis,
    },
    /// A continuous jog's renewals stopped: the axis was stopped.
    DeadManStop {
        axis: Axis,
    },
    /// A held hob spindle's renewals stopped: the spindle was stopped.
    SpindleDeadManStop,
    /// A touch-off set an axis' work offset (mm).
    OffsetChanged {
        axis: Axis,
        offset_mm: f64,
    },
}

/// An event and the cycle it happened in.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Event {
    pub cycle: u64,
    pub kind: EventKind,
}

/// Fixed-capacity event ring.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct EventRing {
    #[serde(with = "hob_gearing::serde_arrays")]
    buf: [Option<Event>; EVENT_CAPACITY],
    head: usize,
    len: usize,
    lost: u64,
}

/// The ring as a machine of the controller writes into it in one cycle: each event is
/// stamped with that cycle.
pub(crate) struct Stamped<'a> {
    ring: &'a mut EventRing,
    cycle: u64,
}

impl Stamped<'_> {
    pub fn push(&mut self, kind: EventKind) {
        self.ring.push(Event {
            cycle: self.cycle,
            kind,
        });
    }
}

impl Default for EventRing {
    fn default() -> Self {
        Self::new()
    }
}

impl EventRing {
    pub fn new() -> Self {
        Self {
            buf: [None; EVENT_CAPACITY],
            head: 0,
            len: 0,
            lost: 0,
        }
    }

    /// The ring for the machines of cycle `cycle`.
    pub(crate) fn stamped(&mut self, cycle: u64) -> Stamped<'_> {
        Stamped { ring: self, cycle }
    }

    pub fn push(&mut self, e: Event) {
        let idx = (self.head + self.len) % EVENT_CAPACITY;
        self.buf[idx] = Some(e);
        if self.len == EVENT_CAPACITY {
            self.head = (self.head + 1) % EVENT_CAPACITY;
            self.lost += 1;
        } else {
            self.len += 1;
        }
    }

    /// The oldest event, removed.
    pub fn pop(&mut self) -> Option<Event> {
        if self.len == 0 {
            return None;
        }
        let e = self.buf[self.head].take();
        self.head = (self.head + 1) % EVENT_CAPACITY;
        self.len -= 1;
        e
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Events overwritten before they were drained.
    pub fn lost(&self) -> u64 {
        self.lost
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_order_and_counts_overwrites() {
        let mut r = EventRing::new();
        for c in 0..(EVENT_CAPACITY as u64 + 3) {
            r.push(Event {
                cycle: c,
                kind: EventKind::CycleDone,
            });
        }
        assert_eq!(r.lost(), 3);
        assert_eq!(r.len(), EVENT_CAPACITY);
        assert_eq!(r.pop().map(|e| e.cycle), Some(3));
    }
}
