//! Referencing X and Y at power-up by CiA 402 homing (docs/domain.md section 2: the
//! encoders are incremental, so until this ran nothing knows where X and Y are).
//!
//! The drive does the motion by itself (its home switch and index pulse, the method and
//! speeds the master wrote at boot); the loop switches the drive's mode of operation to
//! homing and back, starts it with controlword bit 4, and relies on a mode only once the
//! drive's mode display (0x6061) confirms it. While the drive moves by itself the loop's
//! command follows the measured position, so that the return to cyclic synchronous
//! position never jumps. Axes are referenced one after the other, X first: X's home is
//! at its outer end, away from the work.
//!
//! [`Referencing`] owns the run's state and takes, each cycle, only the drives' feedback
//! and its timeouts ([`HomingInputs`]); what came of the cycle ([`Progress`]) is the
//! controller's to act on (its command follows the drive; the event, the fault, idle).

pub use super::command::HomeAxes;
use super::drive::{AxisFeedback, DriveMode};
use super::fault::{Axis, HomingFailure};

/// Time a drive may take to confirm a mode change (0x6061) or to start homing.
pub const MODE_CHANGE_TIMEOUT_S: f64 = 1.0;

/// Where the referencing of one axis stands.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum HomingStep {
    /// Asked for homing mode; waiting for the mode display to confirm it.
    #[default]
    ToHomingMode,
    /// Controlword bit 4 set; waiting for the drive to report homing in progress.
    Start,
    /// The drive is homing; waiting for "homing attained" and "target reached".
    Running,
    /// Done (or stopped): asked for cyclic synchronous position again; waiting for the
    /// mode display.
    ToCyclicMode,
}

/// What a cycle of referencing needs.
#[derive(Debug, Clone, Copy)]
pub(super) struct HomingInputs {
    pub period_s: f64,
    /// The drives' feedback (B, X, Y) as latched this cycle.
    pub feedback: [AxisFeedback; 3],
    /// Referencing X (Y) that takes longer is a fault.
    pub x_timeout_s: f64,
    pub y_timeout_s: f64,
}

/// What came of a cycle of referencing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Progress {
    /// Nothing (left) to reference: the run is over, every drive in cyclic synchronous
    /// position.
    Finished,
    /// The axis under way (its drive moves by itself).
    Running(Axis),
    /// The axis under way was stopped and its drive is back in cyclic synchronous
    /// position: the run is over, the axis not referenced.
    Stopped(Axis),
    /// The axis is referenced; the next one (if any) follows.
    Referenced(Axis),
    /// The axis' homing failed.
    Failed(Axis, HomingFailure),
}

impl Progress {
    /// The axis under way this cycle (its drive moved by itself: the loop's command
    /// follows it).
    pub fn axis(self) -> Option<Axis> {
        match self {
            Progress::Finished => None,
            Progress::Running(axis)
            | Progress::Stopped(axis)
            | Progress::Referenced(axis)
            | Progress::Failed(axis, _) => Some(axis),
        }
    }
}

/// The referencing state of the linear axes.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub(super) struct Referencing {
    /// X, Y referenced.
    pub referenced: [bool; 2],
    queue: [Option<Axis>; 2],
    current: usize,
    pub step: HomingStep,
    step_time_s: f64,
    /// The run was stopped: the axis under way is not referenced.
    aborted: bool,
    /// Mode requested of each drive (B, X, Y) and controlword bit 4.
    pub modes: [DriveMode; 3],
    pub start_bit: [bool; 3],
}

fn slot(axis: Axis) -> usize {
    match axis {
        Axis::B => 0,
        Axis::X => 1,
        Axis::Y => 2,
    }
}

impl Referencing {
    pub fn is_referenced(&self, axis: Axis) -> bool {
        match axis {
            // The table needs no reference for hobbing (its phase comes from the first
            // engagement).
            Axis::B => true,
            Axis::X => self.referenced[0],
            Axis::Y => self.referenced[1],
        }
    }

    pub fn all_referenced(&self) -> bool {
        self.referenced == [true, true]
    }

    /// The reference of `axis` is gone (its drive lost its position).
    pub fn lose(&mut self, axis: Axis) {
        match axis {
            Axis::X => self.referenced[0] = false,
            Axis::Y => self.referenced[1] = false,
            Axis::B => {}
        }
    }

    /// The axis whose drive is (or is being asked to be) out of cyclic synchronous
    /// position: its measured position may jump and it follows no command of the loop.
    pub fn drive_on_its_own(&self, axis: Axis) -> bool {
        self.modes[slot(axis)] != DriveMode::CyclicPosition
    }

    /// Forgets a run under way: every drive back to cyclic synchronous position.
    pub fn abandon(&mut self) {
        self.queue = [None; 2];
        self.current = 0;
        self.step = HomingStep::ToHomingMode;
        self.modes = [DriveMode::CyclicPosition; 3];
        self.start_bit = [false; 3];
    }

    /// Starts a run (command "home", checked by its handler): the axes lose their
    /// reference until it is found again.
    pub fn begin(&mut self, axes: HomeAxes) {
        self.queue = match axes {
            HomeAxes::X => [Some(Axis::X), None],
            HomeAxes::Y => [Some(Axis::Y), None],
            HomeAxes::Both => [Some(Axis::X), Some(Axis::Y)],
        };
        for a in self.queue.into_iter().flatten() {
            self.lose(a);
        }
        self.current = 0;
        self.step = HomingStep::ToHomingMode;
        self.step_time_s = 0.0;
        self.aborted = false;
    }

    pub fn current_axis(&self) -> Option<Axis> {
        self.queue.get(self.current).copied().flatten()
    }

    fn go(&mut self, step: HomingStep) {
        self.step = step;
        self.step_time_s = 0.0;
    }

    /// Stops a run: the axis under way stays unreferenced.
    pub fn stop(&mut self) {
        self.aborted = true;
        if self.step != HomingStep::ToCyclicMode {
            self.go(HomingStep::ToCyclicMode);
        }
    }

    /// One cycle of referencing.
    pub fn step(&mut self, input: &HomingInputs) -> Progress {
        self.step_time_s += input.period_s;
        let Some(axis) = self.current_axis() else {
            self.abandon();
            return Progress::Finished;
        };
        let k = slot(axis);
        let feedback = input.feedback[k];
        let t = self.step_time_s;
        let timeout_s = match axis {
            Axis::Y => input.y_timeout_s,
            _ => input.x_timeout_s,
        };
        match self.step {
            HomingStep::ToHomingMode => {
                self.modes[k] = DriveMode::Homing;
                self.start_bit[k] = false;
                if feedback.mode_display == DriveMode::Homing.code() {
                    self.go(HomingStep::Start);
                } else if t > MODE_CHANGE_TIMEOUT_S {
                    return Progress::Failed(axis, HomingFailure::ModeNotConfirmed);
                }
            }
            HomingStep::Start => {
                self.start_bit[k] = true;
                let h = feedback.homing;
                if h.error {
                    return Progress::Failed(axis, HomingFailure::DriveError);
                } else if !h.target_reached && feedback.mode_display == DriveMode::Homing.code() {
                    // Bits 13, 12, 10 all clear: in progress (a previous run's "completed"
                    // is not taken for this one's).
                    self.go(HomingStep::Running);
                } else if t > MODE_CHANGE_TIMEOUT_S {
                    return Progress::Failed(axis, HomingFailure::NotStarted);
                }
            }
            HomingStep::Running => {
                let h = feedback.homing;
                if feedback.mode_display != DriveMode::Homing.code() {
                    return Progress::Failed(axis, HomingFailure::ModeNotConfirmed);
                } else if h.error {
                    return Progress::Failed(axis, HomingFailure::DriveError);
                } else if h.attained && h.target_reached {
                    self.go(HomingStep::ToCyclicMode);
                } else if t > timeout_s {
                    return Progress::Failed(axis, HomingFailure::Timeout);
                }
            }
            HomingStep::ToCyclicMode => return self.back_to_cyclic_mode(axis, feedback),
        }
        Progress::Running(axis)
    }

    /// The axis under way is done (or stopped): once its drive is back in cyclic
    /// synchronous position it is referenced (or the stopped run is over).
    fn back_to_cyclic_mode(&mut self, axis: Axis, feedback: AxisFeedback) -> Progress {
        let k = slot(axis);
        self.start_bit[k] = false;
        self.modes[k] = DriveMode::CyclicPosition;
        if feedback.mode_display == DriveMode::CyclicPosition.code() {
            if self.aborted {
                self.abandon();
                return Progress::Stopped(axis);
            }
            match axis {
                Axis::X => self.referenced[0] = true,
                Axis::Y => self.referenced[1] = true,
                Axis::B => {}
            }
            self.current += 1;
            self.go(HomingStep::ToHomingMode);
            Progress::Referenced(axis)
        } else if self.step_time_s > MODE_CHANGE_TIMEOUT_S {
            Progress::Failed(axis, HomingFailure::ModeNotConfirmed)
        } else {
            Progress::Running(axis)
        }
    }
}
