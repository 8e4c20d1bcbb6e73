//! The one small trait every CAN transport implements (the transports themselves, with I/O,
//! are in the crate `hob-can-transport`: SocketCAN, in memory, shared-memory virtual CAN).

use crate::frame::Frame;

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
