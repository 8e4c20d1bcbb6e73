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
    /// A state file's `header` describes other records than this reader's (of
    /// `known_record_bytes`, [`crate::format::record_bytes`]).
    OtherFormat {
        file: String,
        header: serde_json::Value,
        known_record_bytes: usize,
    },
    /// A state file's header names other fields than this reader's.
    OtherFields {
        file: String,
        fields: serde_json::Value,
    },
    /// The simulation trace (its `header`, [`crate::trace::TRACE_HEADER`]) lacks the override
    /// `columns` a log's CSV ends with (a bug).
    NoTraceColumns {
        columns: [&'static str; 2],
        header: &'static str,
    },
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
    /// The truth beside a recording (`file`, [`crate::truth::FILE`]) differs from the
    /// controller's estimate by more than a truth of the same program can (`within_arcsec`,
    /// [`crate::export`]): by `lo` to `hi` arcsec in `pass`.
    TruthNotOfThisCut {
        file: &'static str,
        pass: usize,
        lo: f64,
        hi: f64,
        within_arcsec: f64,
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
    /// The second line is not the `expected` header ([`crate::truth::HEADER`]).
    Header {
        expected: &'static str,
    },
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
            TruthProblem::Header { expected } => write!(f, "the header must be {expected}"),
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
                header,
                known_record_bytes,
            } => write!(
                f,
                "{file}: header says {} version {} with {} bytes per record; this reader knows hob-state-log version 1 with {known_record_bytes}",
                header["format"], header["version"], header["record_bytes"]
            ),
            Error::OtherFields { file, fields } => write!(
                f,
                "{file}: header's fields are not those of hob-state-log version 1 this reader knows: {fields}"
            ),
            Error::NoTraceColumns { columns, header } => {
                write!(f, "the trace has no {columns:?} columns: {header}")
            }
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
            Error::TruthNotOfThisCut {
                file,
                pass,
                lo,
                hi,
                within_arcsec,
            } => write!(
                f,
                "{file} is not of this cut: in pass {pass} it differs from the controller's estimate by {lo:.0} to {hi:.0} arcsec, more than the {within_arcsec} arcsec a truth of the same program can; not used"
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
