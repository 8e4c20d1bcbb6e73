//! # hob-process-image: this machine on CANopen
//!
//! Above the pure CANopen protocol (`hob-canopen`) and the machine file (`hob-setup`),
//! below the control core: which PDOs this machine's drives and I/O coupler carry and how
//! they are configured, in counts and objects (the units' scaling is `hob-gearing`'s).
//! The master that brings the bus up and exchanges it with the control core every cycle
//! is `hob-master`; the safety watchdog needs only this plan.
//!
//! - [`plan`]: the bus schedule from `config/machine.toml` (PDOs, their SDO configuration,
//!   worst-case load);
//! - [`describe`]: this machine's frames in words;
//! - [`gains`]: the drives' loop gains as CiA 402 objects (0x60F9, 0x60FB) and their units;
//! - [`capture`]: candump captures checked against the plan.

pub mod capture;
pub mod describe;
pub mod gains;
pub mod plan;
