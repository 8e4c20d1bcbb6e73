//! # hob-can-transport: the CAN transports
//!
//! Every transport implements [`hob_canopen::bus::CanBus`], and one conformance suite
//! (`tests/conformance.rs`) runs against each of them:
//! - [`SocketCan`]: raw SocketCAN (`CAN_RAW`, non-blocking), `can0` or `vcan0`;
//! - [`MemoryBus`]: in memory, for tests and in-process simulation (a mutex: never the
//!   real machine's loop);
//! - [`ShmCan`]: the shared-memory virtual CAN bus (iceoryx2), where the kernel has no CAN.

pub mod clock;
pub mod memory;
pub mod shm;
pub mod socketcan;

pub use clock::SystemClock;
pub use memory::MemoryBus;
pub use shm::{ShmCan, default_iface, open_bus};
pub use socketcan::SocketCan;
