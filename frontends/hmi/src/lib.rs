//! `hob-hmi`: the operator's touch HMI. A frontend like the CLI: it reads the loop's `state`,
//! `events` and `stats` streams and sends on its `command` service (all through `hob_ipc`),
//! edits the program and tool library through `hob_store`, and serves a web page to a kiosk
//! browser on the machine PC. It holds no control logic: every action is one loop command
//! that the loop checks and answers, every validation message comes from the Rust crates.

pub mod api;
pub mod app;
pub mod bridge;
pub mod commander;
pub mod commission;
pub mod compensate;
pub mod compensation;
pub mod definition;
pub mod error;
pub mod form;
pub mod jog;
pub mod protocol;
pub mod reduce;
pub mod sections;
pub mod web;
pub mod words;
pub mod ws;

pub use error::Error;
