//! CANopen (CiA 301, 401, 402) as the machine's drives and I/O coupler speak it.
//!
//! Wire format and protocol state machines without I/O: frames in, frames out. The
//! transports (SocketCAN, in memory) sit at the edge in [`bus`].

pub mod bus;
pub mod busload;
pub mod capture;
pub mod cia402;
pub mod describe;
pub mod emcy;
pub mod frame;
pub mod master;
pub mod nmt;
pub mod pdo;
pub mod plan;
pub mod sdo;
