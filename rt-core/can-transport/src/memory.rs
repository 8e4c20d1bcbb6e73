//! An in-memory CAN bus for tests and simulation (a mutex: never the real machine's loop).

use hob_canopen::bus::{BusError, CanBus};
use hob_canopen::frame::{Frame, SYNC};
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

#[derive(Debug, Default)]
struct Hub {
    queues: Vec<VecDeque<Frame>>,
    /// Endpoints that hear their own SYNCs.
    echo_sync: Vec<bool>,
    log: Option<Vec<Frame>>,
    capacity: usize,
}

/// An in-memory CAN bus: every frame sent by one endpoint reaches every other endpoint
/// (as on a wire; no echo to the sender). Optionally logs every frame (a capture).
/// Uses a mutex: for tests and simulation, never the real machine's loop.
#[derive(Debug, Clone)]
pub struct MemoryBus {
    hub: Arc<Mutex<Hub>>,
    me: usize,
}

impl MemoryBus {
    /// A new bus with its first endpoint; each endpoint queues up to `capacity` frames.
    pub fn new(capacity: usize) -> Self {
        let hub = Hub {
            queues: vec![VecDeque::with_capacity(capacity)],
            echo_sync: vec![false],
            log: None,
            capacity,
        };
        Self {
            hub: Arc::new(Mutex::new(hub)),
            me: 0,
        }
    }

    /// Another endpoint on the same bus.
    pub fn endpoint(&self) -> Self {
        let mut hub = self.lock();
        let cap = hub.capacity;
        hub.queues.push(VecDeque::with_capacity(cap));
        hub.echo_sync.push(false);
        Self {
            hub: Arc::clone(&self.hub),
            me: hub.queues.len() - 1,
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Hub> {
        // A poisoned hub only means a test thread panicked; the data is still usable.
        self.hub.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Starts logging every frame on the bus.
    pub fn capture(&self) {
        self.lock().log = Some(Vec::new());
    }

    /// The frames logged since `capture`.
    pub fn captured(&self) -> Vec<Frame> {
        self.lock().log.clone().unwrap_or_default()
    }
}

impl CanBus for MemoryBus {
    fn send(&mut self, f: &Frame) -> Result<(), BusError> {
        let mut hub = self.lock();
        let cap = hub.capacity;
        let me = self.me;
        if hub
            .queues
            .iter()
            .enumerate()
            .any(|(i, q)| i != me && q.len() >= cap)
        {
            return Err(BusError::Full);
        }
        let echo = f.id == SYNC && hub.echo_sync[me];
        for (i, q) in hub.queues.iter_mut().enumerate() {
            if i != me || echo {
                q.push_back(*f);
            }
        }
        if let Some(log) = hub.log.as_mut() {
            log.push(*f);
        }
        Ok(())
    }

    fn try_recv(&mut self) -> Result<Option<Frame>, BusError> {
        let me = self.me;
        Ok(self.lock().queues[me].pop_front())
    }

    fn echo_own_sync(&mut self) -> bool {
        let me = self.me;
        self.lock().echo_sync[me] = true;
        true
    }

    fn wait_for_frame(&mut self, timeout: std::time::Duration) {
        // Nothing wakes a waiter here: a short sleep, then the caller polls again.
        std::thread::sleep(timeout.min(std::time::Duration::from_micros(50)));
    }
}

// Delivery, order, own SYNC and a full queue: the conformance suite
// (tests/conformance.rs). The capture is this bus's own.
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_capture_logs_every_frame_on_the_bus() {
        let mut a = MemoryBus::new(16);
        let mut c = a.endpoint();
        a.capture();
        a.send(&Frame::new(0x80, &[])).unwrap();
        c.send(&Frame::new(0x702, &[5])).unwrap();
        assert_eq!(a.captured(), vec![Frame::new(0x80, &[]), Frame::new(0x702, &[5])]);
    }
}
