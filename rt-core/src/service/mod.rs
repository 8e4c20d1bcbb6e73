//! `hob-rt`, the real-time service: the control core and the CANopen master in a pinned
//! SCHED_FIFO loop at 1 kHz, publishing on the shared-memory bus (`hob_ipc`).
//!
//! - [`cycle`]: the loop itself (no allocation, lock, blocking call or logging inside).
//! - [`commands`]: the command thread (request-response server; parses and checks
//!   programs) and its mailboxes to the loop.
//! - [`stats`]: the loop's timing histograms and their hand-over to the stats thread.
//! - [`rt`]: memory lock, stack pre-fault, core pinning, SCHED_FIFO, the absolute clock.
//! - [`wire`]: the control core's types to and from the bus's plain numbers.
//! - [`shm_can`]: the shared-memory virtual CAN bus (where the kernel has no CAN).
//! - [`alloc_guard`]: the counting allocator that proves the cycle allocates nothing.

pub mod alloc_guard;
pub mod commands;
pub mod cycle;
pub mod rt;
pub mod shm_can;
pub mod stats;
pub mod wire;
