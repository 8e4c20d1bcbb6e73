//! Why the HMI server could not do what the page asked, before or instead of the loop's
//! answer: the facts (the library's refusal, the key, the file), worded as the page shows
//! them (its browser tests compare the texts).

use std::fmt;
use std::path::PathBuf;

/// An error of the HMI server.
#[derive(Debug)]
pub enum Error {
    /// The program and tool library refused (its own words, as the CLI's).
    Library(hob_store::library::Refusal),
    /// A library program that does not check on this machine.
    Program(hob_setup::config::LoadError),
    /// A loop command its builder refused (`hob_ipc::request`, in its words).
    Request(hob_ipc::Error),
    /// A program's load asked of the command path: the server reads it from the library.
    LoadFromLibrary {
        program: String,
    },
    /// The command thread is gone: no request can reach the loop.
    CommandThreadStopped,
    /// The loop did not answer within `within` ([`crate::commander::ANSWER`]).
    NoAnswer {
        error: hob_ipc::IpcError,
        within: std::time::Duration,
    },
    /// The loop's command service could not be reached.
    Unreachable,
    /// A spindle hold asked to turn the hob the other way (`dir`).
    SpindleOneWay {
        dir: String,
    },
    /// A front-end library file missing from the npm install.
    VendorMissing {
        path: PathBuf,
        error: std::io::Error,
    },
    /// The view token is `chars` long, shorter than `min`
    /// ([`crate::web::VIEW_TOKEN_MIN_CHARS`]).
    ViewTokenShort {
        chars: usize,
        min: usize,
    },
    /// The view token holds a character other than printable ASCII (or `;` `=` `&`).
    ViewTokenCharacters,
    /// A form field's key that is not a key path of a program.
    KeyPath {
        key: String,
    },
    /// A form field's key outside the program's tables.
    OutsideTables {
        key: String,
    },
    NotATable,
    NotAnArray,
    /// A program's text that is not TOML (the parser's message).
    Toml(toml::de::Error),
    /// A library tool that is not a TOML table.
    ToolNotATable {
        name: String,
    },
    /// A library tool that cannot be written as TOML.
    ToolToml {
        name: String,
        error: toml::ser::Error,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Library(r) => write!(f, "{r}"),
            Error::Program(e) => write!(f, "{e}"),
            Error::Request(e) => write!(f, "{e}"),
            Error::LoadFromLibrary { program } => {
                write!(f, "load {program}: read from the library by the server")
            }
            Error::CommandThreadStopped => f.write_str("the HMI's command thread has stopped"),
            Error::NoAnswer { error, within } => write!(
                f,
                "no answer from the loop (hob-rt) within {} s: {error}",
                within.as_secs()
            ),
            Error::Unreachable => f.write_str("cannot reach the loop's command service (is hob-rt running?)"),
            Error::SpindleOneWay { dir } => {
                write!(f, "spindle hold: the hob spindle turns one way only, not {dir}")
            }
            Error::VendorMissing { path, error } => write!(
                f,
                "the HMI's front-end libraries are missing: {}: {error}. Install them with \
                 `npm ci --omit=dev --prefix frontends/hmi` (README, Deploying) or give --vendor DIR",
                path.display()
            ),
            Error::ViewTokenShort { chars, min } => write!(
                f,
                "the view token is {chars} characters, at least {min} are needed \
                 (e.g. `head -c 24 /dev/urandom | base64 > FILE`)"
            ),
            Error::ViewTokenCharacters => {
                f.write_str("the view token holds a character other than printable ASCII (or ; = &)")
            }
            Error::KeyPath { key } => write!(f, "{key}: not a key path of a program"),
            Error::OutsideTables { key } => write!(
                f,
                "{key}: a program's fields live in its tables ([workpiece] ...)"
            ),
            Error::NotATable => f.write_str("not a table"),
            Error::NotAnArray => f.write_str("not an array"),
            Error::Toml(e) => f.write_str(e.message()),
            Error::ToolNotATable { name } => write!(f, "the library tool {name:?} is not a table"),
            Error::ToolToml { name, error } => write!(f, "the library tool {name:?}: {error}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Library(e) => Some(e),
            Error::Program(e) => Some(e),
            Error::NoAnswer { error, .. } => Some(error),
            Error::VendorMissing { error, .. } => Some(error),
            Error::Toml(e) => Some(e),
            Error::ToolToml { error, .. } => Some(error),
            _ => None,
        }
    }
}
