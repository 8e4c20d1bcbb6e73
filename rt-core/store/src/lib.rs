//! # hob-store: files on disk
//!
//! The I/O edge for what the controller keeps between runs, used by the CLI `hob` (later
//! the touch HMI) and by the loop process `hob-rt` for its state file; never by the 1 kHz
//! loop itself.
//!
//! - [`atomic`]: [`atomic::write_atomic`], a file replaced whole or not at all (temporary
//!   file, `fsync`, rename, `fsync` of the directory; `hob_rt_os::durable`, where the
//!   logger finds it too); every write of this crate goes through it.
//! - [`machine_state`]: `hob-rt`'s machine state file (work offsets from touch-off).
//! - [`machine_edit`]: the machine file changed by a tool (`hob commission`): only the
//!   changed keys' lines, checked as `hob-rt` loads it, shown as a diff, the old file kept.
//! - [`pitch_compensation`]: a gear's pitch compensation per worm set of the table
//!   (`hob compensate`), beside the state file, the previous one kept.
//! - [`library`]: the operator's program and tool library (`programs/`, `tools/`), the
//!   names it accepts, and [`library::Library::resolve`], which fills a program's library
//!   tool in.
//! - [`files`]: the machine file and programs read from disk (`hob-setup` parses and
//!   checks their texts; it reads no file itself).
//! - [`utc`]: UTC timestamps as text (`2025-01-31T12:00:00Z`), without a clock crate.

pub use hob_rt_os::durable as atomic;
pub mod files;
pub mod library;
pub mod machine_edit;
pub mod machine_state;
pub mod pitch_compensation;
pub mod utc;

/// A fresh, empty directory for one test (removed and made again).
#[cfg(test)]
pub(crate) fn test_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("hob-store-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("test dir");
    dir
}
