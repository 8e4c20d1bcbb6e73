//! # hob-wire: the contract between hob's processes, pure
//!
//! What every process agrees on, with no I/O (no file, socket, clock or shared memory
//! here: those are `hob-ipc`'s):
//! - [`vocab`]: the machine's vocabulary, written once: sequencer states, refusals, axes,
//!   ends, homing failures, couplings and the control core's faults, each with the number
//!   it is on the wire and its words. The control core uses these types themselves.
//! - the messages ([`StateSample`], [`EventSample`], [`StatsSample`], [`RecorderSample`],
//!   [`CommandRequest`] and [`CommandResponse`], [`CanFrameSample`]): `#[repr(C)]`,
//!   fixed-size, the same layout in every process built from this crate;
//! - [`codec`]: every code's words from its number alone (alarms with their reaction,
//!   remedy and how to continue, commands, events, bus events), so a code reads the same
//!   in every frontend; [`bus`]: the CAN bus's words (EMCY codes, NMT and CiA 402 states);
//! - [`request`]: the operator's words to a request, for the CLI and the HMI; [`number`]:
//!   a number as an operator types it (a decimal point or comma);
//! - [`frame`]: the gateway's frames (length-prefixed postcard).
//!
//! The numbers are the wire format: never renumber one, only add new ones
//! (`tests/reference.rs` holds every code as it was).

pub mod bus;
pub mod codec;
mod error;
pub mod frame;
pub mod nodes;
pub mod number;
pub mod request;
mod types;
pub mod vocab;

pub use error::Error;
pub use types::*;
pub use vocab::{pitch_compensation, situation};
