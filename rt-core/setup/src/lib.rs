//! # hob-setup: what is done before the loop starts
//!
//! Start-up code: it may allocate, block and fail, and refuses everything it cannot accept
//! with errors that name the key and its position. No I/O dependency: files are read
//! with `std::fs` at start-up only, never by the loop.
//!
//! - [`config`]: the machine configuration (`config/machine.toml`), loaded with serde and
//!   validated completely;
//! - [`job`]: the operator's program (job) file and its machine-independent checks;
//! - [`planner`]: turns a job on a machine into passes, positions, speeds and times, and
//!   refuses a job the machine cannot cut.

pub mod config;
pub mod job;
pub mod planner;
