//! # hob-canopen: CANopen (CiA 301, 401, 402) as the machine's drives and I/O coupler speak it
//!
//! Wire format and protocol state machines without I/O: frames in, frames out. No
//! dependency on an operating system's CAN, and none on hob's control core. The
//! [`bus::CanBus`] trait is what the transports (crate `hob-can-transport`) implement.

pub mod bus;
pub mod busload;
pub mod cia402;
pub mod emcy;
pub mod frame;
pub mod nmt;
pub mod pdo;
pub mod sdo;
