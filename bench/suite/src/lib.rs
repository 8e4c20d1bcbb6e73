//! # hob-bench: the benchmarks and the release gate
//!
//! One command each (`hob-bench loop|bus|step|accuracy|bus-load`), JSON out plus, for
//! the loop, a picture; `hob-bench all --quick|--release` runs them all into one
//! directory and `hob-bench gate` checks that directory against `ci/gates.toml`.
//! `ci/gate` and `ci/release` are the entry points.

pub mod accuracy;
pub mod bus;
pub mod busload;
pub mod flood;
pub mod gate;
pub mod hist;
pub mod hmi_load;
pub mod latency;
pub mod plot;
pub mod step;
pub mod system;

use std::path::Path;

/// Pretty JSON with a final newline.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), String> {
    let text = serde_json::to_string_pretty(value).map_err(|e| e.to_string())?;
    std::fs::write(path, text + "\n").map_err(|e| format!("{}: {e}", path.display()))
}
