//! The vocabulary of the loop's commands: what a frontend may ask ([`Command`]) and the
//! words it is said in (the sequencer's [`State`], a jog's [`Direction`], the axes a
//! "home" references). A leaf: it knows nothing of the machines that carry the commands
//! out, so that every module may speak it (events, the sequencer, jog, referencing).

use super::fault::Axis;

/// Sequencer states (the wire's vocabulary): `name` is the short word of traces and status.
pub use hob_wire::vocab::State;

/// A request from a frontend (HMI, CLI, buttons). Checked against the machine state;
/// a refusal changes nothing.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Command {
    /// Start the loaded program: all passes, or the single-mode pass.
    Start {
        single: bool,
    },
    FeedHold,
    Resume,
    /// Cycle stop: out of the cut, gearbox out, spindle off.
    Stop,
    /// Clear a fault whose cause is gone.
    Reset,
    /// Move an axis by a distance (mm, or deg for B), only when idle.
    Jog {
        axis: Axis,
        distance: f64,
    },
    /// Jog an axis while the command is renewed (the dead-man); the same command again
    /// renews it. Speed in mm/min (deg/min for B), limited by the machine.
    JogContinuous {
        axis: Axis,
        direction: Direction,
        speed_per_min: f64,
    },
    /// Let go of a jog: brake it to a stop (an excitation fades out).
    JogRelease,
    /// Swing the table's target, a sine at `frequency_hz` with the amplitude the table's
    /// acceleration allows (at most [`crate::jog::EXCITE_MAX_DEG`]), the table creeping
    /// slowly `creep`, while the command is renewed (commissioning's frequency response),
    /// only when idle.
    ExciteTable {
        frequency_hz: f64,
        /// The way the table creeps meanwhile (its friction holds the worm on one flank).
        creep: Direction,
    },
    /// Apply the loaded pitch compensation to the table (`on`) or not, only outside a
    /// cycle with the gearbox out; refused when none is loaded.
    PitchCompensation {
        on: bool,
    },
    /// Reference X and/or Y (CiA 402 homing).
    Home {
        axes: HomeAxes,
    },
    /// Feed override in percent of the programmed feed.
    FeedOverride {
        percent: f64,
    },
    /// Spindle speed override in percent of the programmed speed.
    SpindleOverride {
        percent: f64,
    },
    /// Touch-off: the hob's tip touches a gauge; X: its diameter, Y: its top face's
    /// height above the table face (mm). Sets that axis' work offset, unless it does not
    /// fit the loaded blank, the previous offset or where the axes stand
    /// (`setup_math::check_touch_off`): then only `confirmed` by the operator.
    TouchOff {
        axis: Axis,
        value_mm: f64,
        confirmed: bool,
    },
    /// Continue the interrupted program from the interrupted pass on the same part.
    Continue,
    /// Spindle at a speed, only when idle (e.g. to centre the blank).
    SpindleOn {
        rpm: f64,
    },
    SpindleOff,
    /// The hob spindle at a speed while the operator holds it (renewed like a continuous
    /// jog, stopped by its dead-man when the renewals stop), only when idle.
    SpindleHold {
        rpm: f64,
    },
    /// A new blank is on the table: forget the recorded tooth phase.
    NewBlank,
    /// Aligning to a part whose gaps are already cut (the table lost its position, or a
    /// pre-cut part to finish): the hob and the spindle stand still in a gap and the table
    /// was turned in `turned` until a flank of the gap touched the hob's tooth. The loop
    /// notes the tooth phase there; once both flanks are touched the part's phase is their
    /// middle (module `align`).
    TouchFlank {
        turned: Direction,
    },
}

/// Which way a continuous jog runs, in the axis' own frame (docs/domain.md section 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Direction {
    Positive,
    Negative,
}

impl Direction {
    pub fn sign(self) -> f64 {
        match self {
            Direction::Positive => 1.0,
            Direction::Negative => -1.0,
        }
    }
}

/// Which axes a "home" command references.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum HomeAxes {
    X,
    Y,
    /// X, then Y.
    Both,
}
