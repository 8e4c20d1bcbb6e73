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

use super::Controller;
use super::DriveMode;
pub use super::command::HomeAxes;
use super::command::State;
use super::events::EventKind;
use super::fault::{Axis, Fault, HomingFailure};
use super::profile::Profile;

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

    fn begin(&mut self, axes: HomeAxes) {
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
}

impl Controller {
    /// Starts referencing (command "home"); checked by the sequencer's command handler.
    pub(super) fn begin_referencing(&mut self, axes: HomeAxes) {
        self.referencing.begin(axes);
        self.enter(State::Referencing);
    }

    /// Stops a referencing run: the axis under way stays unreferenced.
    pub(super) fn stop_referencing(&mut self) {
        self.referencing.aborted = true;
        if self.referencing.step != HomingStep::ToCyclicMode {
            self.referencing.go(HomingStep::ToCyclicMode);
        }
    }

    /// One cycle of referencing.
    pub(super) fn sequence_referencing(&mut self) {
        let dt = self.params.period_s;
        self.referencing.step_time_s += dt;
        let Some(axis) = self.referencing.current_axis() else {
            self.referencing.abandon();
            self.enter(State::Idle);
            return;
        };
        let k = slot(axis);
        let feedback = self.measured.feedback[k];
        // The drive moves by itself: the command follows it.
        self.follow_measured(axis);
        let t = self.referencing.step_time_s;
        let timeout_s = match axis {
            Axis::Y => self.params.y_homing_timeout_s,
            _ => self.params.x_homing_timeout_s,
        };
        match self.referencing.step {
            HomingStep::ToHomingMode => {
                self.referencing.modes[k] = DriveMode::Homing;
                self.referencing.start_bit[k] = false;
                if feedback.mode_display == DriveMode::Homing.code() {
                    self.referencing.go(HomingStep::Start);
                } else if t > MODE_CHANGE_TIMEOUT_S {
                    self.homing_failed(axis, HomingFailure::ModeNotConfirmed);
                }
            }
            HomingStep::Start => {
                self.referencing.start_bit[k] = true;
                let h = feedback.homing;
                if h.error {
                    self.homing_failed(axis, HomingFailure::DriveError);
                } else if !h.target_reached && feedback.mode_display == DriveMode::Homing.code() {
                    // Bits 13, 12, 10 all clear: in progress (a previous run's "completed"
                    // is not taken for this one's).
                    self.referencing.go(HomingStep::Running);
                } else if t > MODE_CHANGE_TIMEOUT_S {
                    self.homing_failed(axis, HomingFailure::NotStarted);
                }
            }
            HomingStep::Running => {
                let h = feedback.homing;
                if feedback.mode_display != DriveMode::Homing.code() {
                    self.homing_failed(axis, HomingFailure::ModeNotConfirmed);
                } else if h.error {
                    self.homing_failed(axis, HomingFailure::DriveError);
                } else if h.attained && h.target_reached {
                    self.referencing.go(HomingStep::ToCyclicMode);
                } else if t > timeout_s {
                    self.homing_failed(axis, HomingFailure::Timeout);
                }
            }
            HomingStep::ToCyclicMode => {
                self.referencing.start_bit[k] = false;
                self.referencing.modes[k] = DriveMode::CyclicPosition;
                if feedback.mode_display == DriveMode::CyclicPosition.code() {
                    if self.referencing.aborted {
                        self.referencing.abandon();
                        self.enter(State::Idle);
                        return;
                    }
                    match axis {
                        Axis::X => self.referencing.referenced[0] = true,
                        Axis::Y => self.referencing.referenced[1] = true,
                        Axis::B => {}
                    }
                    self.event(EventKind::Referenced { axis });
                    self.referencing.current += 1;
                    self.referencing.go(HomingStep::ToHomingMode);
                } else if t > MODE_CHANGE_TIMEOUT_S {
                    self.homing_failed(axis, HomingFailure::ModeNotConfirmed);
                }
            }
        }
    }

    fn homing_failed(&mut self, axis: Axis, why: HomingFailure) {
        self.raise(Fault::HomingFailed { axis, why });
    }

    /// The command of `axis` is where the axis is, at rest (and so are the last two
    /// targets, against which the following error is measured).
    fn follow_measured(&mut self, axis: Axis) {
        let (k, at) = match axis {
            Axis::X => (1, self.measured.x_mm),
            Axis::Y => (2, self.measured.y_mm),
            Axis::B => return,
        };
        match axis {
            Axis::X => self.x = Profile::at(at),
            _ => self.y = Profile::at(at),
        }
        self.history[0][k] = at;
        self.history[1][k] = at;
    }
}
