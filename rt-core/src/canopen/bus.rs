//! Transports behind one small trait: SocketCAN (raw `CAN_RAW`, non-blocking, usable
//! from the real-time thread) and an in-memory bus for tests and simulation. The same
//! scenarios run on both: `bench/vm/tests/bus_loop.rs` on the memory bus, `ci/vcan/run`
//! on vcan in the PREEMPT_RT guest.

use super::frame::Frame;
use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

/// Why a bus operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BusError {
    /// The transmit queue is full (try again next cycle).
    Full,
    /// The interface is down or gone.
    Down,
    /// Another OS error (errno).
    Os(i32),
}

impl std::fmt::Display for BusError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BusError::Full => write!(f, "transmit queue full"),
            BusError::Down => write!(f, "interface down"),
            BusError::Os(e) => write!(f, "OS error {e}"),
        }
    }
}

impl std::error::Error for BusError {}

/// A CAN bus endpoint. Neither call blocks.
pub trait CanBus {
    fn send(&mut self, f: &Frame) -> Result<(), BusError>;
    /// The next received frame, if one is waiting.
    fn try_recv(&mut self) -> Result<Option<Frame>, BusError>;
    /// From now on, also deliver this endpoint's own SYNC frames, in bus order among the
    /// frames received (start-up only). Then a TPDO is known to answer the SYNC heard
    /// before it. Returns false where the transport cannot keep that order.
    fn echo_own_sync(&mut self) -> bool {
        false
    }
    /// Waits until a frame may be waiting, at most `timeout`: for a process that serves the
    /// bus (the virtual machine), never the loop. Where the transport cannot wake a waiter
    /// it sleeps briefly (50 us) and the caller polls [`CanBus::try_recv`] again.
    fn wait_for_frame(&mut self, timeout: std::time::Duration) {
        std::thread::sleep(timeout.min(std::time::Duration::from_micros(50)));
    }
}

impl<B: CanBus + ?Sized> CanBus for Box<B> {
    fn send(&mut self, f: &Frame) -> Result<(), BusError> {
        (**self).send(f)
    }

    fn try_recv(&mut self) -> Result<Option<Frame>, BusError> {
        (**self).try_recv()
    }

    fn echo_own_sync(&mut self) -> bool {
        (**self).echo_own_sync()
    }

    fn wait_for_frame(&mut self, timeout: std::time::Duration) {
        (**self).wait_for_frame(timeout);
    }
}

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
        let echo = f.id == super::frame::SYNC && hub.echo_sync[me];
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
}

#[cfg(feature = "socketcan")]
pub use socket::SocketCan;

#[cfg(feature = "socketcan")]
mod socket {
    use super::{BusError, CanBus, Frame};
    use socketcan::{
        CanDataFrame, CanFilter, CanFrame, CanSocket, EmbeddedFrame, Id, Socket, SocketOptions, StandardId,
    };
    use std::io::ErrorKind;
    use std::os::fd::AsRawFd;

    const ENETDOWN: i32 = 100;

    /// A raw SocketCAN socket in non-blocking mode.
    #[derive(Debug)]
    pub struct SocketCan {
        socket: CanSocket,
        iface: String,
    }

    impl SocketCan {
        /// Opens `iface` (e.g. `can0`, `vcan0`); start-up only.
        pub fn open(iface: &str) -> std::io::Result<Self> {
            let socket = CanSocket::open(iface).map_err(|e| {
                std::io::Error::new(
                    e.kind(),
                    format!("{iface}: {e} (does the interface exist and is it up?)"),
                )
            })?;
            socket.set_nonblocking(true)?;
            Ok(Self {
                socket,
                iface: iface.to_string(),
            })
        }

        pub fn iface(&self) -> &str {
            &self.iface
        }

        /// Waits up to `timeout` for a frame (start-up tools only: blocks).
        pub fn recv_timeout(&mut self, timeout: std::time::Duration) -> Result<Option<Frame>, BusError> {
            let deadline = std::time::Instant::now() + timeout;
            loop {
                if let Some(f) = self.try_recv()? {
                    return Ok(Some(f));
                }
                if std::time::Instant::now() >= deadline {
                    return Ok(None);
                }
                std::thread::sleep(std::time::Duration::from_micros(200));
            }
        }
    }

    fn os(e: std::io::Error) -> BusError {
        match e.kind() {
            ErrorKind::WouldBlock => BusError::Full,
            ErrorKind::NotFound | ErrorKind::BrokenPipe => BusError::Down,
            _ => match e.raw_os_error() {
                // ENETDOWN: the interface was taken down.
                Some(ENETDOWN) => BusError::Down,
                Some(n) => BusError::Os(n),
                None => BusError::Os(0),
            },
        }
    }

    impl CanBus for SocketCan {
        fn send(&mut self, f: &Frame) -> Result<(), BusError> {
            let id = StandardId::new(f.id).ok_or(BusError::Os(22))?;
            let frame = CanDataFrame::new(id, f.payload()).ok_or(BusError::Os(22))?;
            self.socket.write_frame(&frame).map_err(os)
        }

        fn try_recv(&mut self) -> Result<Option<Frame>, BusError> {
            loop {
                match self.socket.read_frame() {
                    Ok(CanFrame::Data(d)) => {
                        if let Id::Standard(id) = d.id() {
                            return Ok(Some(Frame::new(id.as_raw(), d.data())));
                        }
                        // 29-bit identifiers are not CANopen's: skip.
                    }
                    Ok(_) => {} // remote and error frames: skip
                    Err(e) if e.kind() == ErrorKind::WouldBlock => return Ok(None),
                    Err(e) => return Err(os(e)),
                }
            }
        }

        /// The kernel delivers a socket's own frames (`CAN_RAW_RECV_OWN_MSGS`) when they
        /// are on the bus: on vcan at once, on a controller with echo when transmitted, in
        /// order with the frames received. Filters keep out the other frames this master
        /// sends (NMT, RPDOs, SDO requests): what passes is SYNC and EMCY, TPDO 1-4, SDO
        /// responses and heartbeats, from any node.
        fn echo_own_sync(&mut self) -> bool {
            let node_to_master = [0x080, 0x180, 0x280, 0x380, 0x480, 0x580, 0x700];
            let filters: Vec<CanFilter> = node_to_master
                .iter()
                .map(|&id| CanFilter::new(id, 0x780))
                .collect();
            self.socket.set_filters(&filters).is_ok() && self.socket.set_recv_own_msgs(true).is_ok()
        }

        /// Blocks in `poll(2)` until the socket is readable: the process wakes when a frame
        /// arrives, as a node reacts to reception.
        #[allow(unsafe_code)]
        fn wait_for_frame(&mut self, timeout: std::time::Duration) {
            let mut fd = libc::pollfd {
                fd: self.socket.as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            };
            let ms = libc::c_int::try_from(timeout.as_millis().max(1)).unwrap_or(libc::c_int::MAX);
            // SAFETY: one valid pollfd for the duration of the call; the result only tells
            // whether to read, which the caller does with `try_recv` in any case.
            unsafe { libc::poll(&mut fd, 1, ms) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_bus_delivers_to_every_other_endpoint_in_order() {
        let mut a = MemoryBus::new(16);
        let mut b = a.endpoint();
        let mut c = a.endpoint();
        a.capture();
        a.send(&Frame::new(0x80, &[])).unwrap();
        a.send(&Frame::new(0x181, &[1])).unwrap();
        assert_eq!(a.try_recv().unwrap(), None, "no echo");
        assert_eq!(b.try_recv().unwrap(), Some(Frame::new(0x80, &[])));
        assert_eq!(b.try_recv().unwrap(), Some(Frame::new(0x181, &[1])));
        assert_eq!(c.try_recv().unwrap(), Some(Frame::new(0x80, &[])));
        c.send(&Frame::new(0x702, &[5])).unwrap();
        assert_eq!(a.try_recv().unwrap(), Some(Frame::new(0x702, &[5])));
        assert_eq!(a.captured().len(), 3);
    }

    #[test]
    fn a_full_queue_refuses_without_blocking() {
        let mut a = MemoryBus::new(2);
        let _b = a.endpoint();
        a.send(&Frame::new(1, &[])).unwrap();
        a.send(&Frame::new(2, &[])).unwrap();
        assert_eq!(a.send(&Frame::new(3, &[])), Err(BusError::Full));
    }
}
