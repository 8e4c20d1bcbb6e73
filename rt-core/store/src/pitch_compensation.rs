//! A gear's pitch compensation as `hob compensate` stores it (issue 34): one TOML file per
//! worm set of the table (`[table] worm_set` of the machine file), beside `hob-rt`'s machine
//! state file: `<dir of [state] file>/pitch-compensation/<worm_set>.toml`. It says what was
//! measured (the gear, the checker's files and time, the log of the cut), what the table and
//! the hob did wrong (minus the errors: the offsets the table's target gets, arcsec of the
//! table), the first cut's tooth phase, and which part of the gear's error it removes.
//!
//! Saved with [`crate::atomic::write_atomic`], the previous file kept as
//! `<worm_set>.<stamp>.toml`; read back for one worm set only ([`load_for`]): a file of
//! another set is refused, never applied. Validated as the control core will take it
//! (`hob_control::pitch_comp`: 3 to 512 points, finite, at most 72 arcsec), each problem
//! named by its key.

use crate::atomic::{write_atomic, write_new};
use hob_setup::config::{LoadError as FileError, Problems, parse_toml};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The format this code reads and writes.
pub const FORMAT_VERSION: u32 = 1;
/// The fewest and the most table points (a gear's teeth): `hob_control::pitch_comp::
/// MAX_POINTS` is 512 too (repeated here, hob-store does not link the control core; the
/// control core's check runs again when `hob-rt` builds it).
pub const POINTS: (usize, usize) = (3, 512);
/// The largest offset, arcsec of the table: `hob_control::pitch_comp::MAX_OFFSET_DEG`
/// (0.02 deg), repeated for the same reason.
pub const MAX_OFFSET_ARCSEC: f64 = 72.0;
/// The directory beside the state file that holds the compensations.
pub const DIR: &str = "pitch-compensation";

/// How much of the hob's once-per-turn error the measurement identified
/// (`hob_gear_check::Identified`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum HobIdentified {
    /// One start, or one hob phase: the hob's term is zero.
    None,
    /// Two hob phases 180 deg apart: one direction of it.
    Direction,
    Full,
}

/// A stored pitch compensation.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StoredCompensation {
    /// [`FORMAT_VERSION`].
    pub format_version: u32,
    /// The worm set it was measured on (`[table] worm_set`).
    pub worm_set: String,
    /// The gear as the program names it.
    pub gear: String,
    pub teeth: u32,
    /// When the checker measured it, as the checker wrote it.
    pub measured_at: String,
    /// When `hob compensate` computed it ([`crate::utc`]).
    pub computed_at_utc: String,
    /// The checker's files it was computed from (their names).
    pub measurements: Vec<String>,
    /// The log directory of the first cut.
    pub log_dir: String,
    /// The table angle of the first offset, deg; offset i is `360 i / n` further.
    pub first_table_deg: f64,
    /// What the table's target gets at each gap (minus the table's error), arcsec of the
    /// table, in gap order.
    pub table_offsets_arcsec: Vec<f64>,
    /// The hob's term the table's target gets: `cos cos(spindle) + sin sin(spindle)`,
    /// arcsec of the table (minus the hob's error).
    pub hob_cos_arcsec: f64,
    pub hob_sin_arcsec: f64,
    pub hob_identified: HobIdentified,
    /// The first cut's tooth phase (gearbox phase, modulo the pitch), deg.
    pub tooth_phase_deg: f64,
    /// The gear's f_pt and F_p a compensation removes (the table's and the hob's
    /// repeatable errors), um.
    pub removable_single_pitch_um: f64,
    pub removable_cumulative_pitch_um: f64,
    /// What stays: the residual's f_pt and F_p, um.
    pub residual_single_pitch_um: f64,
    pub residual_cumulative_pitch_um: f64,
}

/// Why a compensation was not read ([`load_for`]).
#[derive(Debug)]
pub enum LoadError {
    /// The file does not read or validate (the problems name the keys).
    Invalid(FileError),
    /// The file is another worm set's.
    OtherWormSet {
        file: PathBuf,
        asked: String,
        found: String,
    },
}

impl std::fmt::Display for LoadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LoadError::Invalid(e) => write!(f, "{e}"),
            LoadError::OtherWormSet { file, asked, found } => write!(
                f,
                "{}: worm_set is {found:?}, but the machine's table.worm_set is {asked:?}: \
                 another worm set's compensation is never applied",
                file.display()
            ),
        }
    }
}

impl std::error::Error for LoadError {}

/// Why a compensation was not saved.
#[derive(Debug)]
pub enum SaveError {
    /// A value breaks the rules (named by key); nothing was written.
    Invalid(FileError),
    Io {
        file: PathBuf,
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

/// The worm set's name as a file name: ASCII letters, digits, `-`, `_` and `.` kept, any
/// other character (a `/`, a space) and a leading `.` made `_`. Two names that map to one
/// file are told apart by the file's `worm_set` ([`load_for`] refuses the other's).
pub fn file_stem(worm_set: &str) -> String {
    worm_set
        .chars()
        .enumerate()
        .map(|(i, c)| match c {
            '.' if i == 0 => '_',
            c if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') => c,
            _ => '_',
        })
        .collect()
}

/// The directory of the compensations: beside the state file.
pub fn dir_for(state_file: &Path) -> PathBuf {
    state_file.parent().unwrap_or_else(|| Path::new(".")).join(DIR)
}

/// The file of `worm_set`'s compensation.
pub fn path_for(state_file: &Path, worm_set: &str) -> PathBuf {
    dir_for(state_file).join(format!("{}.toml", file_stem(worm_set)))
}

/// The compensation stored for `worm_set`; none when there is no file. Refused when the
/// file does not validate or is another worm set's.
pub fn load_for(state_file: &Path, worm_set: &str) -> Result<Option<StoredCompensation>, LoadError> {
    let path = path_for(state_file, worm_set);
    let src = match std::fs::read_to_string(&path) {
        Ok(s) => s,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(error) => return Err(LoadError::Invalid(FileError::Io { file: path, error })),
    };
    let stored = StoredCompensation::parse(&path, &src).map_err(LoadError::Invalid)?;
    if stored.worm_set != worm_set {
        return Err(LoadError::OtherWormSet {
            file: path,
            asked: worm_set.to_string(),
            found: stored.worm_set,
        });
    }
    Ok(Some(stored))
}

impl StoredCompensation {
    /// Parses and validates a compensation file's text (`origin` names it in errors).
    pub fn parse(origin: &Path, src: &str) -> Result<Self, FileError> {
        let stored: Self = parse_toml(origin, src)?;
        let mut p = Problems::new();
        stored.validate(&mut p);
        p.into_result(origin, src)?;
        Ok(stored)
    }

    /// Checks every value; problems are named by key.
    pub fn validate(&self, p: &mut Problems) {
        p.require(self.format_version == FORMAT_VERSION, "format_version", || {
            format!(
                "this hob reads format {FORMAT_VERSION} (is {})",
                self.format_version
            )
        });
        p.require(
            hob_setup::config::machine::is_worm_set_name(&self.worm_set),
            "worm_set",
            || {
                format!(
                    "must name a worm set as table.worm_set does (is {:?})",
                    self.worm_set
                )
            },
        );
        for (key, text) in [
            ("gear", &self.gear),
            ("measured_at", &self.measured_at),
            ("log_dir", &self.log_dir),
        ] {
            p.require(!text.trim().is_empty(), key, || "must not be empty".into());
        }
        p.require(
            !self.measurements.is_empty() && self.measurements.iter().all(|m| !m.trim().is_empty()),
            "measurements",
            || "must name the checker's files, none empty".into(),
        );
        p.require(
            crate::utc::is_timestamp(&self.computed_at_utc),
            "computed_at_utc",
            || {
                format!(
                    "must be a UTC time as YYYY-MM-DDTHH:MM:SSZ (is {:?})",
                    self.computed_at_utc
                )
            },
        );
        let n = self.table_offsets_arcsec.len();
        p.require(
            (POINTS.0..=POINTS.1).contains(&(self.teeth as usize)),
            "teeth",
            || format!("must be {} to {} (is {})", POINTS.0, POINTS.1, self.teeth),
        );
        p.require(n == self.teeth as usize, "table_offsets_arcsec", || {
            format!("must have one offset per tooth, {} (has {n})", self.teeth)
        });
        if let Some((i, v)) = self
            .table_offsets_arcsec
            .iter()
            .enumerate()
            .find(|(_, v)| !v.is_finite() || v.abs() > MAX_OFFSET_ARCSEC)
        {
            p.push(
                "table_offsets_arcsec",
                format!("offset {i} must be a finite number within +-{MAX_OFFSET_ARCSEC} arcsec (is {v})"),
            );
        }
        let hob = self.hob_cos_arcsec.hypot(self.hob_sin_arcsec);
        for key in ["hob_cos_arcsec", "hob_sin_arcsec"] {
            let v = if key == "hob_cos_arcsec" {
                self.hob_cos_arcsec
            } else {
                self.hob_sin_arcsec
            };
            p.require(v.is_finite(), key, || format!("must be a finite number (is {v})"));
        }
        p.require(
            !hob.is_finite() || hob <= MAX_OFFSET_ARCSEC,
            "hob_cos_arcsec",
            || format!("the hob's term's amplitude must be at most {MAX_OFFSET_ARCSEC} arcsec (is {hob})"),
        );
        p.require(
            self.hob_identified != HobIdentified::None
                || (self.hob_cos_arcsec == 0.0 && self.hob_sin_arcsec == 0.0),
            "hob_identified",
            || "is \"none\", but the hob's term is not zero".into(),
        );
        p.within("first_table_deg", self.first_table_deg, -360.0, 360.0, "deg");
        let pitch = 360.0 / f64::from(self.teeth.max(1));
        p.within(
            "tooth_phase_deg",
            self.tooth_phase_deg,
            0.0,
            pitch,
            "deg (modulo the pitch)",
        );
        for (key, v) in [
            ("removable_single_pitch_um", self.removable_single_pitch_um),
            (
                "removable_cumulative_pitch_um",
                self.removable_cumulative_pitch_um,
            ),
            ("residual_single_pitch_um", self.residual_single_pitch_um),
            ("residual_cumulative_pitch_um", self.residual_cumulative_pitch_um),
        ] {
            p.non_negative(key, v);
        }
    }

    /// The file's text.
    pub fn to_toml(&self) -> String {
        let body = toml::to_string(self).unwrap_or_else(|e| format!("# not serialisable: {e}\n"));
        format!(
            "# hob: a gear's pitch compensation for one worm set of the table (hob compensate). \
             Written by hob; edit with care.\n{body}"
        )
    }

    /// The file it is saved to.
    pub fn path(&self, state_file: &Path) -> PathBuf {
        path_for(state_file, &self.worm_set)
    }

    /// Validates, then replaces this worm set's file atomically, the previous one kept as
    /// `<worm_set>.<stamp>.toml` (`stamp`: [`crate::machine_edit::file_stamp`] of now; a
    /// `-2`, `-3` ... added when that name is taken). Returns the kept file, none when
    /// there was no previous one. Nothing is written when a value is invalid.
    pub fn save(&self, state_file: &Path) -> Result<Option<PathBuf>, SaveError> {
        let path = self.path(state_file);
        let text = self.to_toml();
        let mut p = Problems::new();
        self.validate(&mut p);
        p.into_result(&path, &text).map_err(SaveError::Invalid)?;
        let io = |file: &Path| {
            let file = file.to_path_buf();
            move |error| SaveError::Io { file, error }
        };
        let dir = dir_for(state_file);
        std::fs::create_dir_all(&dir).map_err(io(&dir))?;
        let kept = match std::fs::read(&path) {
            Ok(old) => Some(keep(&path, &old)?),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(error) => return Err(SaveError::Io { file: path, error }),
        };
        write_atomic(&path, text.as_bytes()).map_err(io(&path))?;
        Ok(kept)
    }
}

/// Keeps `old` (the text of `path`) as `<stem>.<stamp>.toml` beside it.
fn keep(path: &Path, old: &[u8]) -> Result<PathBuf, SaveError> {
    let stem = path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let stamp = crate::machine_edit::file_stamp(&crate::utc::now());
    for k in 1..1000 {
        let name = match k {
            1 => format!("{stem}.{stamp}.toml"),
            k => format!("{stem}.{stamp}-{k}.toml"),
        };
        let kept = path.with_file_name(name);
        match write_new(&kept, old) {
            Ok(()) => return Ok(kept),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(error) => return Err(SaveError::Io { file: kept, error }),
        }
    }
    Err(SaveError::Io {
        file: path.to_path_buf(),
        error: std::io::Error::other("no free name to keep the previous file"),
    })
}

#[cfg(test)]
mod tests;
