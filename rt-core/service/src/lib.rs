//! # hob-service: `hob-rt`, the real-time service
//!
//! `hob-rt`, the real-time service: the control core and the CANopen master in a pinned
//! SCHED_FIFO loop at 1 kHz, publishing on the shared-memory services (`hob_ipc`).
//!
//! - [`cycle`]: the loop itself (no allocation, lock, blocking call or logging inside).
//! - [`commands`]: the command thread (request-response server; parses and checks
//!   programs) and its mailboxes to the loop.
//! - [`encode`]: the control core's types to the codes of `hob_ipc::codec` (exhaustive
//!   matches, no allocation), and a request back to a `hob_control::Command`.
//! - [`stats`]: the loop's timing histograms and their hand-over to the stats thread.
//! - [`lifecycle`]: configure -> activate -> run -> stop, in the order the types allow.
//!
//! Below it: `hob_rt_os` (memory lock, pinning, SCHED_FIFO, the clock, the allocation
//! guard), `hob_ipc` (the services and the wire codec), `hob_process_image` (the bus),
//! `hob_control` (the control core).

pub mod commands;
pub mod cycle;
pub mod encode;
pub mod lifecycle;
pub mod recorder;
pub mod stats;
