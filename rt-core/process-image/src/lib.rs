//! # hob-process-image: this machine on CANopen
//!
//! The layer above both the pure CANopen protocol (`hob-canopen`) and the control core
//! (`hob-control`): which PDOs this machine's drives and I/O coupler carry, how the bus is
//! brought up, and how frames become the control core's inputs and its outputs frames.
//!
//! - [`plan`]: the bus schedule from `config/machine.toml` (PDOs, their SDO configuration,
//!   worst-case load);
//! - [`master`]: [`master::boot`] (start-up, blocks) returns a [`master::Booted`] bus, the
//!   only way to get the cyclic exchange ([`master::Cyclic`], no allocation);
//! - [`describe`]: this machine's frames in words;
//! - [`capture`]: candump captures checked against the plan.

pub mod capture;
pub mod describe;
pub mod master;
pub mod plan;
