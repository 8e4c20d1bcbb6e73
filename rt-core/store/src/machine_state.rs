//! `hob-rt`'s machine state file (`[state] file` of the machine file): the work offsets
//! found by touch-off, with when and with which gauge they were set. TOML, with a format
//! version; a missing file means the machine has not been calibrated yet, which is a state
//! to report, not an error. Saved with [`crate::atomic::write_atomic`]: a crash while
//! saving leaves the previous calibration.

use crate::atomic::write_atomic;
use hob_setup::config::{LoadError, Problems, parse_toml};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The format this code reads and writes.
pub const FORMAT_VERSION: u32 = 1;

/// The largest work offset accepted on X and Y: a touch-off further off than this is a
/// wrong gauge or a wrong reference, not a calibration.
pub const MAX_OFFSET_MM: f64 = 50.0;

/// The largest gauge (diameter or height) accepted.
pub const MAX_GAUGE_MM: f64 = 1000.0;

/// The machine state file.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MachineState {
    /// [`FORMAT_VERSION`].
    pub format_version: u32,
    /// Work offset of X (centre distance) from touch-off.
    pub x_offset_mm: f64,
    /// Work offset of Y (height) from touch-off.
    pub y_offset_mm: f64,
    /// When the offsets were set (`YYYY-MM-DDTHH:MM:SSZ`, [`crate::utc`]).
    pub set_at_utc: String,
    /// Diameter of the gauge (setting mandrel) touched off on X; none before X's first
    /// touch-off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gauge_diameter_mm: Option<f64>,
    /// Height of the gauge touched off on Y (0: the table face itself); none before Y's
    /// first touch-off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gauge_height_mm: Option<f64>,
    /// Free text for the operator (who, which machine state).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// What [`load`] found.
#[derive(Debug, Clone, PartialEq)]
pub enum Loaded {
    /// No state file: the machine has not been touched off yet.
    NotCalibrated,
    Calibrated(MachineState),
}

/// Why a state was not saved.
#[derive(Debug)]
pub enum SaveError {
    /// A value breaks the rules (named by key); nothing was written.
    Invalid(LoadError),
    Io {
        file: std::path::PathBuf,
        error: std::io::Error,
    },
}

impl std::fmt::Display for SaveError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SaveError::Invalid(e) => write!(f, "{e}"),
            SaveError::Io { file, error } => write!(f, "{}: cannot write: {error}", file.display()),
        }
    }
}

impl std::error::Error for SaveError {}

/// Reads and validates the state file at `path`; a missing file is
/// [`Loaded::NotCalibrated`].
pub fn load(path: &Path) -> Result<Loaded, LoadError> {
    let src = match std::fs::read_to_string(path) {
        Ok(s) => s,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Loaded::NotCalibrated),
        Err(error) => {
            return Err(LoadError::Io {
                file: path.to_path_buf(),
                error,
            });
        }
    };
    MachineState::parse(path, &src).map(Loaded::Calibrated)
}

impl MachineState {
    /// A state set now.
    pub fn new(
        x_offset_mm: f64,
        y_offset_mm: f64,
        gauge_diameter_mm: Option<f64>,
        gauge_height_mm: Option<f64>,
    ) -> Self {
        Self {
            format_version: FORMAT_VERSION,
            x_offset_mm,
            y_offset_mm,
            set_at_utc: crate::utc::now(),
            gauge_diameter_mm,
            gauge_height_mm,
            note: None,
        }
    }

    /// Parses and validates a state file's text (`origin` names it in errors).
    pub fn parse(origin: &Path, src: &str) -> Result<Self, LoadError> {
        let state: Self = parse_toml(origin, src)?;
        let mut p = Problems::new();
        state.validate(&mut p);
        p.into_result(origin, src)?;
        Ok(state)
    }

    /// Checks every value; problems are named by key.
    pub fn validate(&self, p: &mut Problems) {
        p.require(self.format_version == FORMAT_VERSION, "format_version", || {
            format!(
                "this hob reads format {FORMAT_VERSION} (is {})",
                self.format_version
            )
        });
        for (key, v) in [
            ("x_offset_mm", self.x_offset_mm),
            ("y_offset_mm", self.y_offset_mm),
        ] {
            p.within(key, v, -MAX_OFFSET_MM, MAX_OFFSET_MM, "mm");
        }
        if let Some(v) = self.gauge_diameter_mm {
            p.positive("gauge_diameter_mm", v);
        }
        if let Some(v) = self.gauge_height_mm {
            p.require(v.is_finite() && v >= 0.0, "gauge_height_mm", || {
                format!("must be 0 (the table face) or more (is {v})")
            });
        }
        for (key, v) in [
            ("gauge_diameter_mm", self.gauge_diameter_mm),
            ("gauge_height_mm", self.gauge_height_mm),
        ] {
            if let Some(v) = v {
                p.require(v.is_nan() || v <= MAX_GAUGE_MM, key, || {
                    format!("must be at most {MAX_GAUGE_MM} mm (is {v})")
                });
            }
        }
        p.require(crate::utc::is_timestamp(&self.set_at_utc), "set_at_utc", || {
            format!(
                "must be a UTC time as YYYY-MM-DDTHH:MM:SSZ (is {:?})",
                self.set_at_utc
            )
        });
    }

    /// The file's text.
    pub fn to_toml(&self) -> String {
        let body = toml::to_string(self).unwrap_or_else(|e| format!("# not serialisable: {e}\n"));
        format!(
            "# hob-rt machine state: work offsets from touch-off. Written by hob; edit with care.\n{body}"
        )
    }

    /// Validates, then replaces the file at `path` atomically; nothing is written when a
    /// value is invalid.
    pub fn save(&self, path: &Path) -> Result<(), SaveError> {
        let text = self.to_toml();
        let mut p = Problems::new();
        self.validate(&mut p);
        p.into_result(path, &text).map_err(SaveError::Invalid)?;
        write_atomic(path, text.as_bytes()).map_err(|error| SaveError::Io {
            file: path.to_path_buf(),
            error,
        })
    }
}

#[cfg(test)]
mod tests;
