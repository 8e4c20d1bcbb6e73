//! The one small trait every CAN transport implements (the transports themselves, with I/O,
//! are in the crate `hob-can-transport`: SocketCAN, in memory, shared-memory virtual CAN).

use crate::frame::Frame;

/// What a CAN send or receive failed on (its words are the wire's).
pub use hob_wire::bus::BusError;

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
    /// it sleeps briefly (50 us) and the caller polls [`CanBus::try_recv`] again. The
    /// transports (with I/O, `hob-can-transport`) say how they wait.
    fn wait_for_frame(&mut self, timeout: std::time::Duration);
}

/// The time as start-up waits on it (an SDO answer, a boot-up, a drive changing modes):
/// the real one is the I/O edge's (`hob_can_transport::SystemClock`), a test's can be its
/// own. The protocol and the master read no wall clock themselves.
pub trait Clock {
    /// Time since some fixed origin of this clock (monotonic).
    fn now(&self) -> std::time::Duration;
    /// Lets `d` pass (the real clock sleeps; a test's may just advance).
    fn pause(&mut self, d: std::time::Duration);
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
