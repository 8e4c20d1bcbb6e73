//! # hob-config: the machine file and how every TOML file is checked
//!
//! The machine configuration (`config/machine.toml`, [`machine::MachineConfig`]) parsed
//! and validated completely, and what every TOML file of hob shares: problems named by key
//! and position ([`Problems`], [`LoadError`]). Pure: texts in, values or refusals out (the
//! files are read by `hob_store::files`). Apart from the set-up (`hob-setup`: programs and
//! the planner), so that a process that needs only the machine, the safety watchdog, links
//! no set-up code.
//!
//! Start-up code: it may allocate and fail. Every refusal names the file, the line and
//! column, the key, and the limit that was broken; all problems of a file are reported at
//! once so the machine builder or operator fixes them in one go.

pub mod machine;
pub mod source;

use serde::de::DeserializeOwned;
use source::{Position, locate_key, position_of};
use std::fmt;
use std::path::{Path, PathBuf};

/// One broken rule in a file: which key, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// Dotted key path, `[i]` for array elements, e.g. `strategy.rough_depths_mm[1]`.
    pub key: String,
    /// What is wrong and which limit applies.
    pub message: String,
    /// Where the key is written, when it is written at all.
    pub position: Option<Position>,
}

/// Collects the problems found while validating one file.
#[derive(Debug, Default)]
pub struct Problems {
    list: Vec<Problem>,
}

impl Problems {
    pub fn new() -> Self {
        Self::default()
    }

    /// Records a problem with `key`.
    pub fn push(&mut self, key: impl Into<String>, message: impl Into<String>) {
        self.list.push(Problem {
            key: key.into(),
            message: message.into(),
            position: None,
        });
    }

    /// Records a problem unless `ok`.
    pub fn require(&mut self, ok: bool, key: &str, message: impl FnOnce() -> String) {
        if !ok {
            self.push(key, message());
        }
    }

    /// Requires a finite value strictly above zero.
    pub fn positive(&mut self, key: &str, value: f64) {
        self.require(value.is_finite() && value > 0.0, key, || {
            format!("must be greater than 0 (is {value})")
        });
    }

    /// Requires a finite value at or above zero.
    pub fn non_negative(&mut self, key: &str, value: f64) {
        self.require(value.is_finite() && value >= 0.0, key, || {
            format!("must be 0 or more (is {value})")
        });
    }

    /// Requires `lo <= value <= hi`.
    pub fn within(&mut self, key: &str, value: f64, lo: f64, hi: f64, unit: &str) {
        self.require(value.is_finite() && (lo..=hi).contains(&value), key, || {
            format!("must be within {lo} .. {hi} {unit} (is {value})")
        });
    }

    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    pub fn as_slice(&self) -> &[Problem] {
        &self.list
    }

    /// `Ok(())` when nothing was found, else the problems located in `src`.
    pub fn into_result(self, file: &Path, src: &str) -> Result<(), LoadError> {
        if self.list.is_empty() {
            return Ok(());
        }
        let problems = self
            .list
            .into_iter()
            .map(|mut p| {
                p.position = locate_key(src, &p.key);
                p
            })
            .collect();
        Err(LoadError::Invalid {
            file: file.to_path_buf(),
            problems,
        })
    }
}

/// Why a file was refused.
#[derive(Debug)]
pub enum LoadError {
    /// The file could not be read.
    Io { file: PathBuf, error: std::io::Error },
    /// Not valid TOML, a value of the wrong type, a missing or an unknown key.
    Syntax {
        file: PathBuf,
        position: Option<Position>,
        message: String,
    },
    /// Well-formed, but values break the rules (limits, consistency, the machine).
    Invalid { file: PathBuf, problems: Vec<Problem> },
}

impl LoadError {
    /// The problems of an `Invalid` file (empty otherwise).
    pub fn problems(&self) -> &[Problem] {
        match self {
            LoadError::Invalid { problems, .. } => problems,
            _ => &[],
        }
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LoadError::Io { file, error } => write!(f, "{}: cannot read: {error}", file.display()),
            LoadError::Syntax {
                file,
                position,
                message,
            } => match position {
                Some(p) => write!(f, "{}:{p}: {message}", file.display()),
                None => write!(f, "{}: {message}", file.display()),
            },
            LoadError::Invalid { file, problems } => {
                let n = problems.len();
                write!(
                    f,
                    "{}: {n} problem{} found",
                    file.display(),
                    if n == 1 { "" } else { "s" }
                )?;
                for p in problems {
                    match p.position {
                        Some(pos) => write!(f, "\n  {}:{pos}: {}: {}", file.display(), p.key, p.message)?,
                        None => write!(f, "\n  {}: {}: {}", file.display(), p.key, p.message)?,
                    }
                }
                Ok(())
            }
        }
    }
}

impl std::error::Error for LoadError {}

/// Deserialises `src` (the contents of `file`, named in errors).
pub fn parse_toml<T: DeserializeOwned>(file: &Path, src: &str) -> Result<T, LoadError> {
    toml::from_str(src).map_err(|e| LoadError::Syntax {
        file: file.to_path_buf(),
        position: e.span().map(|s| position_of(src, s.start)),
        message: in_words(e.message().trim()),
    })
}

/// A value of the wrong type in the words of the person who typed it, not serde's
/// (`invalid type: string "1O", expected i64` is `"1O" is not a whole number`); any other
/// message as it is.
pub fn in_words(message: &str) -> String {
    let Some(rest) = message.strip_prefix("invalid type: ") else {
        return message.to_string();
    };
    let Some((found, expected)) = rest.rsplit_once(", expected ") else {
        return message.to_string();
    };
    let found = found
        .strip_prefix("string ")
        .or_else(|| found.strip_prefix("floating point "))
        .or_else(|| found.strip_prefix("integer "))
        .map_or(found, |v| v.trim_matches('`'));
    let wanted = match expected {
        "i8" | "i16" | "i32" | "i64" | "u8" | "u16" | "u32" | "u64" | "usize" | "isize" => "a whole number",
        "f32" | "f64" => "a number (digits with one decimal point or comma)",
        "a boolean" => "true or false",
        "a string" => "text in quotes",
        _ => return message.to_string(),
    };
    format!("{found} is not {wanted}")
}

#[cfg(test)]
mod words_tests {
    use super::*;

    /// A typo's message names the value and what was wanted in words (the HMI showed
    /// serde's `invalid type: string "94,94", expected f64`).
    #[test]
    fn a_value_of_the_wrong_type_is_said_in_words() {
        assert_eq!(
            in_words(r#"invalid type: string "1O", expected i64"#),
            r#""1O" is not a whole number"#
        );
        assert_eq!(
            in_words("invalid type: floating point `17.5`, expected u32"),
            "17.5 is not a whole number"
        );
        assert_eq!(
            in_words(r#"invalid type: string "9x", expected f64"#),
            r#""9x" is not a number (digits with one decimal point or comma)"#
        );
        assert_eq!(in_words("missing field `teeth`"), "missing field `teeth`");
        assert_eq!(
            in_words("invalid type: map, expected a sequence"),
            "invalid type: map, expected a sequence"
        );
        #[derive(Debug, serde::Deserialize)]
        #[allow(dead_code)]
        struct T {
            teeth: i64,
        }
        let e = parse_toml::<T>(Path::new("p.toml"), "teeth = \"1O\"\n").unwrap_err();
        assert!(e.to_string().ends_with(r#""1O" is not a whole number"#), "{e}");
    }
}
