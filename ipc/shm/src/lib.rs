//! # hob-ipc: the edge between hob's processes
//!
//! The shared-memory services (iceoryx2) that `hob-rt` and every frontend (HMI, CLI,
//! logger, safety watchdog) open with the same settings, and the gateway's client for
//! frontends of another user. What travels is `hob-wire`'s (re-exported here, so a
//! frontend names one crate): the messages, the vocabulary and the codec.
//!
//! Services (all under `hob/<instance>/`, instance from `HOB_INSTANCE`, default `main`):
//!
//! | service   | pattern           | payload                           | who writes          |
//! |-----------|-------------------|-----------------------------------|---------------------|
//! | `state`   | publish-subscribe | [`StateSample`], one per cycle    | the 1 kHz loop      |
//! | `events`  | publish-subscribe | [`EventSample`], history kept     | the 1 kHz loop      |
//! | `stats`   | publish-subscribe | [`StatsSample`], twice a second   | `hob-rt`'s stats thread |
//! | `command` | request-response  | [`CommandRequest`] → [`CommandResponse`] | frontends → `hob-rt` |
//! | `can`     | publish-subscribe | [`CanFrameSample`]                | the shared-memory virtual CAN bus |
//!
//! Frontends of another user than the bus's (the HMI, an operator's shell) reach these
//! through `hob-gateway` ([`gateway`]; `HOB_GATEWAY`): [`follow`] and [`commands`] pick the way.
//!
//! The liveness signal is the `state` stream itself: a new sample every millisecond. The
//! watchdog waits on it with its own deadline, so the loop never calls `notify()` (a
//! syscall per cycle) for anybody.

pub mod gateway;
mod ports;

pub use gateway::{Commands, Feed, commands, follow};
pub use hob_wire::*;
pub use ports::{
    CAN_BUFFER, CanError, CanPort, Client, EVENT_BUFFER, EVENT_HISTORY, IpcError, Ports, PubSub,
    STATE_BUFFER, Svc, command_server, instance, node, open_can, open_can_port, open_command, open_events,
    open_recorder, open_state, open_stats, publisher, service_name, use_instance,
};

/// The exact iceoryx2 every process must use (re-exported so nobody depends on another).
pub use iceoryx2;
