//! Why a recording could not be read or reported: the facts (the file, the line, the
//! cycles), worded as `hob log export|report`, the HMI's report and `hob lib tools
//! record-usage` print them.

use std::fmt;
use std::path::PathBuf;

/// An error of the logger's readers.
#[derive(Debug)]
pub enum Error {
    /// A file or directory of the recording could not be read.
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// A directory without state files.
    NotALog {
        dir: PathBuf,
    },
    /// A state file (`file`: its name in the message) without its header line.
    NoHeaderLine {
        file: String,
    },
    HeaderNotJson {
        file: String,
        error: serde_json::Error,
    },
    /// A state file's header describes other records than this reader's.
    OtherFormat {
        file: String,
        format: serde_json::Value,
        version: serde_json::Value,
        record_bytes: serde_json::Value,
    },
    /// A state file's header names other fields than this reader's.
    OtherFields {
        file: String,
        fields: serde_json::Value,
    },
    /// The simulation trace lacks the override columns a log's CSV ends with (a bug).
    NoTraceColumns,
    NoSample {
        dir: PathBuf,
    },
    NoSampleOfCycles {
        dir: PathBuf,
        first: u64,
        last: u64,
    },
    NoProgramLoaded {
        dir: PathBuf,
    },
    /// The truth beside a recording differs from the controller's estimate by more than a
    /// truth of the same program can (arcsec, in `pass`).
    TruthNotOfThisCut {
        pass: usize,
        lo: f64,
        hi: f64,
    },
    /// A line of `events.log` (numbered from 1) that is not an event.
    NotAnEventLine {
        path: PathBuf,
        line: usize,
        text: String,
    },
    /// A line of a truth file (numbered from 1) that could not be read.
    Truth {
        path: PathBuf,
        line: usize,
        problem: TruthProblem,
    },
}

/// What is wrong with a truth file's line.
#[derive(Debug)]
pub enum TruthProblem {
    Io(std::io::Error),
    /// The first line does not name the gear.
    NotATruthFile,
    /// The second line is not [`crate::truth::HEADER`].
    Header,
    /// A row (not the last) that is not a truth row.
    NotARow(String),
}

impl fmt::Display for TruthProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TruthProblem::Io(e) => write!(f, "{e}"),
            TruthProblem::NotATruthFile => {
                f.write_str("not a hob-sim truth file (its first line names the gear)")
            }
            TruthProblem::Header => write!(f, "the header must be {}", crate::truth::HEADER),
            TruthProblem::NotARow(line) => write!(f, "not a truth row: {line}"),
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Io { path, error } => write!(f, "{}: {error}", path.display()),
            Error::NotALog { dir } => {
                write!(f, "{}: no state-*.hoblog files: not a hob log", dir.display())
            }
            Error::NoHeaderLine { file } => write!(f, "{file}: no header line"),
            Error::HeaderNotJson { file, error } => write!(f, "{file}: header is not JSON: {error}"),
            Error::OtherFormat {
                file,
                format,
                version,
                record_bytes,
            } => write!(
                f,
                "{file}: header says {format} version {version} with {record_bytes} bytes per record; this reader knows hob-state-log version 1 with {}",
                crate::format::record_bytes()
            ),
            Error::OtherFields { file, fields } => write!(
                f,
                "{file}: header's fields are not those of hob-state-log version 1 this reader knows: {fields}"
            ),
            Error::NoTraceColumns => write!(
                f,
                "the trace has no {:?} columns: {}",
                crate::export::LAST,
                crate::trace::TRACE_HEADER
            ),
            Error::NoSample { dir } => write!(f, "{}: no sample recorded", dir.display()),
            Error::NoSampleOfCycles { dir, first, last } => write!(
                f,
                "{}: no sample of cycles {first} .. {last} recorded",
                dir.display()
            ),
            Error::NoProgramLoaded { dir } => write!(
                f,
                "{}: no program was loaded while recording: nothing to report per pass",
                dir.display()
            ),
            Error::TruthNotOfThisCut { pass, lo, hi } => write!(
                f,
                "{} is not of this cut: in pass {pass} it differs from the controller's estimate by {lo:.0} to {hi:.0} arcsec, more than the {} arcsec a truth of the same program can; not used",
                crate::truth::FILE,
                crate::export::TRUTH_AGREES_WITHIN_ARCSEC
            ),
            Error::NotAnEventLine { path, line, text } => write!(
                f,
                "{}:{line}: not an event line (seq cycle kind text): {text:?}",
                path.display()
            ),
            Error::Truth { path, line, problem } => write!(f, "{}:{line}: {problem}", path.display()),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { error, .. }
            | Error::Truth {
                problem: TruthProblem::Io(error),
                ..
            } => Some(error),
            Error::HeaderNotJson { error, .. } => Some(error),
            _ => None,
        }
    }
}
