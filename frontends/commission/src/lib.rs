//! # hob-commission: measuring on the machine what the controller must know
//!
//! The procedures of commissioning, written once for every frontend that offers them (the
//! CLI's `hob commission`, the touch HMI's DIAGNOSTICS page). Each moves the machine only
//! by the loop's own commands, which the loop checks as it checks an operator's (a jog is
//! refused while a cycle runs, in fault, before power-up; a continuous jog stops by its
//! dead-man when its sender stops renewing it), reads the loop's state stream, and changes
//! the machine file only through [`hob_store::machine_edit`]: the change shown as a diff,
//! written on the builder's confirmation, whole or not at all, the old file kept.
//!
//! - [`delay`]: the table drive's delay (`control.drive_delay_us`), from constant-speed
//!   jogs of the table one way and back.
//! - [`encoder`]: the spindle encoder's error (once, twice, three times per turn) told apart
//!   from a true once-per-turn swing of the spindle, from the spindle held at several
//!   speeds (`[commissioning.spindle_encoder]`).
//! - [`backlash`]: the table drive's lost motion at a reversal, against a gauge on the
//!   table (`[commissioning.table_backlash]`).
//! - [`report`]: the commissioning report of the machine file's records (text, and the
//!   encoder's record over the spindle's speeds as SVG).

pub mod backlash;
pub mod delay;
pub mod encoder;
mod link;
pub mod report;
pub mod response;

/// What a whole measurement proposes for the machine file: the procedure's own figures
/// (`measured`), the fit in words, the change as a line diff; written only by
/// [`Proposal::write`], on the builder's confirmation, and only into the file as it was
/// read.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Proposal<M> {
    pub file: std::path::PathBuf,
    #[serde(skip)]
    pub measured: M,
    /// The measurement and its fit in words.
    pub report: String,
    /// The lines that change (`-`/`+` with their line numbers).
    pub diff: String,
    pub utc: String,
    #[serde(skip)]
    edit: link::Edit,
}

impl<M> Proposal<M> {
    /// The proposal of `new_text` for `file`, read as `read_text`.
    pub(crate) fn new(
        file: &std::path::Path,
        measured: M,
        report: String,
        read_text: String,
        new_text: String,
        utc: String,
    ) -> Self {
        Self {
            file: file.to_path_buf(),
            measured,
            report,
            diff: hob_store::machine_edit::diff(&read_text, &new_text),
            utc,
            edit: link::Edit { read_text, new_text },
        }
    }

    /// Writes the proposal (the file must still be as it was read), the old file kept;
    /// returns the kept file.
    pub fn write(&self) -> Result<std::path::PathBuf, Stop> {
        self.edit.commit(&self.file, &self.utc)
    }

    /// The proposal and the diff as the CLI prints them.
    pub fn text(&self) -> String {
        format!(
            "{}changes to {}:\n{}",
            self.report,
            self.file.display(),
            self.diff
        )
    }
}

/// Why a procedure stopped without a result (nothing was written).
#[derive(Debug, Clone, PartialEq)]
pub enum Stop {
    /// Refused before anything moved, or by the loop (its words): exit status 2.
    Refused(String),
    /// Stopped on the way (an alarm, the enable let go, a measurement that does not hold,
    /// the loop unreachable): exit status 1.
    Failed(String),
}

impl std::fmt::Display for Stop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Stop::Refused(t) | Stop::Failed(t) => f.write_str(t),
        }
    }
}

impl std::error::Error for Stop {}
