//! # hob-setup: what is done before the loop starts
//!
//! Start-up code: it may allocate, block and fail, and refuses everything it cannot accept
//! with errors that name the key and its position. Pure: texts in, plans or refusals out
//! (the files are read by `hob_store::files`).
//!
//! - [`config`]: the machine configuration (`config/machine.toml`) and the problems of a
//!   TOML file (crate `hob-config`, re-exported here);
//! - [`job`]: the operator's program (job) file and its machine-independent checks;
//! - [`form`]: a program's sections as the HMI's definition form shows them, each
//!   checked and planned;
//! - [`planner`]: turns a job on a machine into passes, positions, speeds and times, and
//!   refuses a job the machine cannot cut.

pub use hob_config as config;
pub mod form;
pub mod job;
pub mod planner;
