//! A library tool: the fields of a program's `[tool]` section (the same
//! [`hob_setup::job::Tool`], checked by the same [`Tool::check`]) and its usage.

use hob_setup::config::{LoadError, Problems, parse_toml};
use hob_setup::job::Tool;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The format this code reads and writes.
pub const FORMAT_VERSION: u32 = 1;

/// A tool file, `tools/<name>.toml`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ToolRecord {
    /// [`FORMAT_VERSION`].
    pub format_version: u32,
    /// Exactly what a program's `[tool]` holds.
    pub tool: Tool,
    /// What the tool has cut; zero for a new tool.
    #[serde(default)]
    pub usage: Usage,
}

/// What a tool has cut, for the operator's regrind and replacement decisions.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Usage {
    /// Passes cut (rough and finish).
    pub passes_cut: u64,
    /// Y travelled in the cut, metres.
    pub y_travel_in_cut_m: f64,
    /// When it last cut (`YYYY-MM-DDTHH:MM:SSZ`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_used_utc: Option<String>,
}

impl ToolRecord {
    /// Parses and validates a tool file's text (`origin` names it in errors).
    pub fn parse(origin: &Path, src: &str) -> Result<Self, LoadError> {
        let record: Self = parse_toml(origin, src)?;
        let mut p = Problems::new();
        record.validate(&mut p);
        p.into_result(origin, src)?;
        Ok(record)
    }

    /// Checks every value; problems are named by key (`tool.gashes`, `usage.passes_cut`).
    pub fn validate(&self, p: &mut Problems) {
        p.require(self.format_version == FORMAT_VERSION, "format_version", || {
            format!(
                "this hob reads format {FORMAT_VERSION} (is {})",
                self.format_version
            )
        });
        self.tool.check(p);
        p.non_negative("usage.y_travel_in_cut_m", self.usage.y_travel_in_cut_m);
        if let Some(t) = &self.usage.last_used_utc {
            p.require(crate::utc::is_timestamp(t), "usage.last_used_utc", || {
                format!("must be a UTC time as YYYY-MM-DDTHH:MM:SSZ (is {t:?})")
            });
        }
    }

    /// The file's text.
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_else(|e| format!("# not serialisable: {e}\n"))
    }
}
