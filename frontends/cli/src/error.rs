//! Why a `hob` command could not do its work: the facts (the file, the argument, the node,
//! the report so far), worded as `hob` prints them. The binary chooses the exit status and
//! the prefix (`hob: refused:`, `hob: error:`); a report written before the refusal is part
//! of the message (it is printed whole).

use std::fmt;
use std::num::ParseIntError;
use std::path::PathBuf;

/// An error of the `hob` commands' library.
#[derive(Debug)]
pub enum Error {
    /// A file that could not be read or written.
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    /// `hob bus-load`: the report, and the load above the limit (fractions).
    BusOverloaded {
        report: String,
        load: f64,
        limit: f64,
    },
    /// The CAN interface could not be opened.
    CanOpen(std::io::Error),
    /// `hob can dump` without a place to read frames from.
    NoIfaceOrFile,
    /// A number of `hob can sdo` (as given) that does not read.
    Number {
        text: String,
        error: ParseIntError,
    },
    /// An object index or sub-index (as given) beyond 16 bits.
    IndexRange {
        text: String,
    },
    /// A value to write (as given) beyond its type's range (`ty`: the
    /// [`crate::can::SdoType`] as its name is written).
    ValueRange {
        value: String,
        lo: i64,
        hi: i64,
        ty: String,
    },
    /// A hex value (as given) with an odd number of digits.
    HexOdd {
        value: String,
    },
    HexDigit(ParseIntError),
    /// An SDO transfer with a node that failed.
    Sdo {
        node: u8,
        error: hob_canopen::sdo::SdoError,
    },
    /// A program that does not load or check.
    Program(hob_setup::config::LoadError),
    /// A program that does not check, without the reasons.
    ProgramRefused,
    /// `hob can check-capture`: the report, and the capture off the bus schedule.
    OffSchedule {
        report: String,
    },
    /// `hob can check-capture`: the report, and the table targets off the gearbox law.
    OffGearboxLaw {
        report: String,
    },
    /// `hob cutter design --grade` beyond ISO 1328-1's grades.
    Grade(u8),
    Design(hob_cutters::design::DesignError),
    /// The designed profile does not validate (a bug).
    DesignInvalid(hob_cutters::profile::ProfileError),
    ProfileToml(toml::ser::Error),
    /// A cutter's figure out of its range: the argument (`--name`).
    OutOfRange(hob_cutters::dynamics::OutOfRange),
    /// The speeds within the limit could not be searched.
    SpeedRanges(hob_cutters::dynamics::OutOfRange),
    /// `--limit-um` that is not a positive number.
    LimitUm(f64),
    /// A profile file that is not `[[profile]]` primitives.
    ProfileFile {
        path: PathBuf,
        error: toml::de::Error,
    },
    /// A profile file whose primitives are not a valid profile for the cutter.
    ProfileInvalid {
        path: PathBuf,
        error: hob_cutters::profile::ProfileError,
    },
    /// `--feed-mm-min` that is not positive.
    FeedMmMin(f64),
    /// A grinding set-up the path cannot be made for: the argument (`--name`) or the reason.
    Grind(hob_cutters::grind::GrindError),
    /// A flight record that does not decode (`hob_control::flight`'s words).
    FlightRecord(String),
    /// `hob replay`: the report, ending in where the outputs part.
    NotReproduced {
        report: String,
    },
    /// `hob replay --observer-bandwidth-hz` beyond what the cycle allows: the report so far.
    ObserverBandwidth {
        report: String,
        hz: f64,
    },
    /// No state from the loop (the bus instance it was looked for on).
    NoState {
        instance: String,
    },
}

/// A cutter library's refusal as the argument it names: `--name-with-dashes ...`.
fn as_argument(f: &mut fmt::Formatter<'_>, e: &dyn fmt::Display) -> fmt::Result {
    write!(f, "--{}", e.to_string().replace('_', "-"))
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Io { path, error } => write!(f, "{}: {error}", path.display()),
            Error::BusOverloaded { report, load, limit } => write!(
                f,
                "{report}bus load {:.1} % is above can.bus_load_limit = {:.0} %: lengthen inhibit times or take 0x60B1 out of the RPDO",
                load * 100.0,
                limit * 100.0
            ),
            Error::CanOpen(e) => write!(f, "{e}"),
            Error::NoIfaceOrFile => f.write_str("give --iface or --file"),
            Error::Number { text, error } => write!(f, "{text:?}: {error}"),
            Error::IndexRange { text } => write!(f, "{text}: out of range 0 .. 0xFFFF"),
            Error::ValueRange { value, lo, hi, ty } => {
                write!(f, "{value} is out of range {lo} .. {hi} for {ty}")
            }
            Error::HexOdd { value } => write!(f, "{value:?}: hex needs an even number of digits"),
            Error::HexDigit(e) => write!(f, "{e}"),
            Error::Sdo { node, error } => write!(f, "node {node}: {error}"),
            Error::Program(e) => write!(f, "{e}"),
            Error::ProgramRefused => f.write_str("refused"),
            Error::OffSchedule { report } => {
                write!(f, "{report}the capture does not keep to the schedule")
            }
            Error::OffGearboxLaw { report } => write!(
                f,
                "{report}the table targets do not follow the gearbox law closely enough (bound 1e-4, at least 5 stretches)"
            ),
            Error::Grade(g) => write!(f, "--grade: an ISO 1328-1 grade is 1 to 11 (is {g})"),
            Error::Design(e) => write!(f, "{e}"),
            Error::DesignInvalid(e) => write!(f, "the designed profile is invalid (a bug): {e}"),
            Error::ProfileToml(e) => write!(f, "{e}"),
            Error::OutOfRange(e) => as_argument(f, e),
            Error::SpeedRanges(e) => write!(f, "{e}"),
            Error::LimitUm(limit) => write!(f, "--limit-um: must be a positive number of um (is {limit})"),
            Error::ProfileFile { path, error } => write!(f, "{}: {error}", path.display()),
            Error::ProfileInvalid { path, error } => write!(f, "{}: {error}", path.display()),
            Error::FeedMmMin(feed) => write!(f, "--feed-mm-min: must be positive (is {feed})"),
            Error::Grind(e) => as_argument(f, e),
            Error::FlightRecord(e) => f.write_str(e),
            Error::NotReproduced { report } => f.write_str(report),
            Error::ObserverBandwidth { report, hz } => write!(
                f,
                "{report}--observer-bandwidth-hz {hz}: must be above 0 and below half the cycle rate"
            ),
            Error::NoState { instance } => write!(
                f,
                "no state from hob-rt within 2 s (is it running? HOB_INSTANCE={instance})"
            ),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { error, .. } | Error::CanOpen(error) => Some(error),
            Error::Number { error, .. } | Error::HexDigit(error) => Some(error),
            Error::Sdo { error, .. } => Some(error),
            Error::Program(e) => Some(e),
            Error::ProfileToml(e) => Some(e),
            Error::ProfileFile { error, .. } => Some(error),
            _ => None,
        }
    }
}
