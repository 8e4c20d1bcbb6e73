//! The log format of `hob-logger`, its reader, and what is made of a recording: the CSV
//! export and the per-pass report (`hob log export|report`), in the trace format of
//! [`trace`] that the simulated machine writes too.
//!
//! A log is a directory:
//! - `state-NNNNNN.hoblog`: state samples. The first line is a header, one line of JSON
//!   ending in `\n`: `{"format":"hob-state-log","version":1,"record_bytes":N,
//!   "fields":[["cycle","u64"],...],"instance":..,"started_unix_s":..}`; then fixed-size
//!   records, little-endian, fields in the header's order. A new file is started every
//!   [`ROTATE_RECORDS`] records (and at every start of the logger).
//! - `events.log`: one line per event: `seq cycle kind text` ([`format::event_line`]). A
//!   restarted logger is handed the loop's recent events again and writes them again;
//!   [`export::read_events`] reads each event once, and tells the runs of `hob-rt` apart.
//! - `gaps.log`: one line per run of samples the logger missed: `first_cycle last_cycle count`.
//! - `logger.json`: written at exit and every 200 ms: samples recorded, samples lost,
//!   events recorded, events lost, files.

pub mod delay;
pub mod error;
pub mod export;
pub mod format;
pub mod gaps;
pub mod header;
pub mod predicted;
pub mod pump;
pub mod trace;
pub mod truth;
pub mod writer;

pub use error::{Error, TruthProblem};
pub use format::{FIELDS, decode, encode, read_dir_states, record_bytes};
pub use writer::{LogStats, LogWriter};
