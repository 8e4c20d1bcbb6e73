//! # hob-virtual-machine: the virtual hobbing machine on a CAN bus
//!
//! Every node of the real machine, emulated around the physics of `hob-plant`: three
//! CiA 402 drives (NMT, SDO server with an object dictionary, PDO mapping writable by SDO,
//! the power state machine, CSP with interpolation between SYNCs, heartbeat, EMCY on
//! fault), the spindle (VFD, motor, encoder on the table drive's auxiliary input) and the
//! CiA 401 I/O coupler. Fault injection: frames dropped or delayed, drive faults, e-stop,
//! limit switches, lube pressure, a silent node, garbage frames.
//!
//! [`machine::VirtualMachine`] is transport-free (frames in, frames out); [`runner`] puts
//! it and the master on a bus, in one process (tests) or as the `hob-sim` process.

pub mod node;
pub mod od;
pub mod procs;
pub mod runner;
pub mod virtual_machine;
