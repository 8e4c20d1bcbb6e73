//! # hob-cli: the operator's `hob` commands
//!
//! The product's command line: it talks to the running `hob-rt` through the shared-memory
//! services (`hob_ipc`) and reads the machine and program files with the same validation
//! the loop uses (`hob_setup`). It links neither the simulated machine nor the virtual
//! machine on the bus: `hob demo`, `hob simulate` and `hob can run` are the sibling binary
//! `hob-lab` (crate `bench/lab`), which `hob` runs for them ([`lab`]).

pub mod can;
pub mod commission;
pub mod compensate;
pub mod cutter;
pub mod doctor;
pub mod error;
pub mod lab;
pub mod library;
pub mod render;
pub mod replay;
pub mod service;
pub mod util;

pub use error::Error;
