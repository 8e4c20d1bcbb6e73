//! What the wire refuses: an operator's word that is not one of a command's, a program too
//! long for a request, a gateway frame too long or that does not decode. Each reads as the
//! operator or the peer is told it.

use std::fmt;

/// A refusal of the wire.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// `command`: the word is not an axis the command takes (`x`, `y`, `b`).
    NotAnAxis { command: &'static str, word: String },
    /// `home`: the word is not `x`, `y` or `all`.
    NotHomeAxes { word: String },
    /// `command`: the word is not a direction (`+`, `-`).
    NotADirection { command: &'static str, word: String },
    /// `override`: the word is not `feed` or `spindle`.
    NotAnOverride { word: String },
    /// `pitch-compensation`: the word is not `on` or `off`.
    NotOnOff { command: &'static str, word: String },
    /// `touch-off` without the gauge's diameter for X or its height for Y.
    TouchOffGauge,
    /// `touch-off` of an axis that takes none (only X and Y do).
    NotATouchOffAxis { word: String },
    /// A program's text longer than a request carries.
    ProgramTooLong { name: String, bytes: usize, max: usize },
    /// A gateway frame longer than the limit.
    FrameTooLong { bytes: usize, max: usize },
    /// A typed number that is not one (`number`): the field's name and the text.
    NotANumber { field: String, text: String },
    /// A message postcard could not encode.
    Encode(String),
    /// Bytes that do not decode to a message.
    Decode(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::NotAnAxis { command, word } => write!(f, "{command}: axis {word} is not x, y or b"),
            Error::NotHomeAxes { word } => write!(
                f,
                "home: {word} is not x, y or all (the table needs no reference for hobbing)"
            ),
            Error::NotADirection { command, word } => {
                write!(f, "{command}: direction {word} is not + or -")
            }
            Error::NotAnOverride { word } => write!(f, "override: {word} is not feed or spindle"),
            Error::NotOnOff { command, word } => write!(f, "{command}: {word} is not on or off"),
            Error::TouchOffGauge => write!(
                f,
                "touch-off: give x --diameter MM (the gauge's diameter) or y --height MM (its top face above the table face)"
            ),
            Error::NotATouchOffAxis { word } => write!(f, "touch-off: axis {word} is not x or y"),
            Error::ProgramTooLong { name, bytes, max } => {
                write!(f, "{name}: {bytes} bytes, a program file may have at most {max}")
            }
            Error::FrameTooLong { bytes, max } => write!(f, "a frame of {bytes} bytes (at most {max})"),
            Error::NotANumber { field, text } => write!(
                f,
                "{field}: \"{text}\" is not a number (digits with one decimal point or comma: 94.94 or 94,94)"
            ),
            Error::Encode(e) => write!(f, "encode: {e}"),
            Error::Decode(e) => write!(f, "a frame that does not decode: {e}"),
        }
    }
}

impl std::error::Error for Error {}
