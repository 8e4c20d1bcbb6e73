//! Jogging by the operator: incremental (a distance) and continuous with a dead-man (the
//! axis runs only while its frontend renews the command; when the renewals stop, a touch
//! released, a frontend killed, a network lost, it stops within the dead-man time plus
//! the braking time). Until X and Y are referenced every X and Y jog is slow and only the
//! hardware limit switches protect the ends; from the reference on, a jog stops at the
//! soft limits.

use super::Controller;
pub use super::command::Direction;
use super::command::State;
use super::events::EventKind;
use super::fault::{Axis, Refusal};

/// The jog under way.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub(super) enum JogMotion {
    #[default]
    None,
    /// To a position (mm), or the table by a distance (its move is the gearbox's).
    To { axis: Axis, target: f64 },
    /// Continuous at a speed (units/s) until the renewals stop.
    Continuous {
        axis: Axis,
        direction: Direction,
        speed_per_s: f64,
        renewed_at_s: f64,
    },
    /// Braking to a stop.
    Stopping { axis: Axis },
}

impl Controller {
    fn now_s(&self) -> f64 {
        self.cycle as f64 * self.params.period_s
    }

    /// The jog speed of a linear axis: half its rapid, or the slow unreferenced speed.
    fn jog_speed_mm_s(&self, axis: Axis) -> f64 {
        let rapid = match axis {
            Axis::Y => self.params.y_limits.rapid_mm_s,
            _ => self.params.x_limits.rapid_mm_s,
        };
        if self.referencing.is_referenced(axis) {
            rapid / 2.0
        } else {
            (rapid / 2.0).min(self.params.unreferenced_jog_mm_s)
        }
    }

    /// The soft limits of a linear axis in the loop's (work) coordinates, or none before
    /// the reference.
    pub(super) fn work_limits(&self, axis: Axis) -> Option<(f64, f64)> {
        if !self.referencing.is_referenced(axis) {
            return None;
        }
        let (l, offset) = match axis {
            Axis::X => (self.params.x_limits, self.offsets.x_mm),
            Axis::Y => (self.params.y_limits, self.offsets.y_mm),
            Axis::B => return None,
        };
        Some((l.soft_min_mm + offset, l.soft_max_mm + offset))
    }

    /// Checks and starts (or renews) a continuous jog.
    pub(super) fn jog_continuous(
        &mut self,
        axis: Axis,
        direction: Direction,
        speed_per_min: f64,
    ) -> Result<(), Refusal> {
        if !(speed_per_min.is_finite() && speed_per_min > 0.0) {
            return Err(Refusal::BadValue);
        }
        let max_per_s = match axis {
            Axis::B => self.params.gearbox.phase_speed_deg_s,
            _ => self.jog_speed_mm_s(axis),
        };
        let speed_per_s = (speed_per_min / 60.0).min(max_per_s);
        let now = self.now_s();
        match (self.sequencer.state, self.sequencer.jog) {
            (
                State::Jog,
                JogMotion::Continuous {
                    axis: a,
                    direction: d,
                    ..
                },
            ) if a == axis && d == direction => {
                self.sequencer.jog = JogMotion::Continuous {
                    axis,
                    direction,
                    speed_per_s,
                    renewed_at_s: now,
                };
                Ok(())
            }
            (State::Jog, _) => Err(Refusal::JogActive),
            (State::Idle, _) => {
                if !self.drives_ready() {
                    return Err(Refusal::DrivesNotEnabled);
                }
                if let Some((lo, hi)) = self.work_limits(axis) {
                    let at = if axis == Axis::X {
                        self.x.position
                    } else {
                        self.y.position
                    };
                    let blocked = match direction {
                        Direction::Positive => at >= hi,
                        Direction::Negative => at <= lo,
                    };
                    if blocked {
                        return Err(Refusal::OutsideSoftLimits);
                    }
                }
                self.sequencer.jog = JogMotion::Continuous {
                    axis,
                    direction,
                    speed_per_s,
                    renewed_at_s: now,
                };
                self.enter(State::Jog);
                Ok(())
            }
            (State::Init, _) => Err(Refusal::NotReady),
            _ => Err(Refusal::CycleRunning),
        }
    }

    /// Checks and starts a jog by a distance (mm, or deg for the table).
    pub(super) fn jog_by(&mut self, axis: Axis, distance: f64) -> Result<(), Refusal> {
        match self.sequencer.state {
            State::Idle => {}
            State::Init => return Err(Refusal::NotReady),
            State::Jog => return Err(Refusal::JogActive),
            _ => return Err(Refusal::CycleRunning),
        }
        if !distance.is_finite() {
            return Err(Refusal::BadValue);
        }
        if !self.drives_ready() {
            return Err(Refusal::DrivesNotEnabled);
        }
        let target = match axis {
            Axis::X => self.x.position + distance,
            Axis::Y => self.y.position + distance,
            Axis::B => distance,
        };
        if let Some((lo, hi)) = self.work_limits(axis)
            && !(lo..=hi).contains(&target)
        {
            return Err(Refusal::OutsideSoftLimits);
        }
        if axis == Axis::B {
            self.gearbox.move_table_by(distance);
        }
        self.sequencer.jog = JogMotion::To { axis, target };
        self.enter(State::Jog);
        Ok(())
    }

    /// The operator let go: brake the jog to a stop.
    pub(super) fn jog_release(&mut self) -> Result<(), Refusal> {
        match (self.sequencer.state, self.sequencer.jog) {
            (State::Jog, JogMotion::To { axis, .. } | JogMotion::Continuous { axis, .. }) => {
                self.sequencer.jog = JogMotion::Stopping { axis };
                Ok(())
            }
            _ => Err(Refusal::NothingToDo),
        }
    }

    /// One cycle of the jog under way.
    pub(super) fn sequence_jog(&mut self) {
        let dt = self.params.period_s;
        let now = self.now_s();
        let deadman_s = self.params.deadman_s;
        let done = match self.sequencer.jog {
            JogMotion::None => true,
            JogMotion::To { axis: Axis::B, .. } => !self.gearbox.table_moving(),
            JogMotion::To { axis, target } => {
                let speed = self.jog_speed_mm_s(axis);
                let (p, accel) = self.linear(axis);
                p.step_towards(target, speed, accel, dt)
            }
            JogMotion::Continuous {
                axis,
                direction,
                speed_per_s,
                renewed_at_s,
            } => {
                if now - renewed_at_s > deadman_s {
                    // The renewals stopped: the dead-man lets go.
                    self.event(EventKind::DeadManStop { axis });
                    self.sequencer.jog = JogMotion::Stopping { axis };
                    return self.sequence_jog();
                }
                if axis == Axis::B {
                    self.gearbox.move_table_by(direction.sign() * speed_per_s * dt);
                } else {
                    let target = match (self.work_limits(axis), direction) {
                        (Some((_, hi)), Direction::Positive) => hi,
                        (Some((lo, _)), Direction::Negative) => lo,
                        // Before the reference: far ahead, re-aimed every cycle.
                        (None, d) => {
                            let at = if axis == Axis::X {
                                self.x.position
                            } else {
                                self.y.position
                            };
                            at + d.sign() * 1000.0
                        }
                    };
                    let (p, accel) = self.linear(axis);
                    p.step_towards(target, speed_per_s, accel, dt);
                }
                false
            }
            JogMotion::Stopping { axis: Axis::B } => !self.gearbox.table_moving(),
            JogMotion::Stopping { axis } => {
                let (p, accel) = self.linear(axis);
                p.step_stop(accel, dt)
            }
        };
        if done {
            self.sequencer.jog = JogMotion::None;
            self.enter(State::Idle);
        }
    }

    /// Checks and starts (or renews) a held hob spindle: only when idle (also while an axis
    /// jogs), at most the machine's spindle speed.
    pub(super) fn spindle_hold(&mut self, rpm: f64) -> Result<(), Refusal> {
        match self.sequencer.state {
            State::Idle | State::Jog => {}
            State::Init => return Err(Refusal::NotReady),
            _ => return Err(Refusal::CycleRunning),
        }
        if !(rpm.is_finite() && rpm > 0.0 && rpm <= self.params.spindle_max_rpm) {
            return Err(Refusal::BadValue);
        }
        if self.sequencer.spindle_set_rpm > 0.0 && self.sequencer.spindle_hold_renewed_s.is_none() {
            // Latched by SPINDLE ON: holding it would make it stop on release.
            return Err(Refusal::NothingToDo);
        }
        self.sequencer.spindle_set_rpm = rpm;
        self.sequencer.spindle_hold_renewed_s = Some(self.now_s());
        Ok(())
    }

    /// One cycle of a held spindle: it stops when the renewals stop (the dead-man) and is
    /// let go when the machine leaves idle and jog (a cycle or a fault owns the spindle).
    pub(super) fn sequence_spindle_hold(&mut self) {
        let Some(renewed_at_s) = self.sequencer.spindle_hold_renewed_s else {
            return;
        };
        if !matches!(self.sequencer.state, State::Idle | State::Jog) {
            self.sequencer.spindle_hold_renewed_s = None;
            return;
        }
        if self.now_s() - renewed_at_s > self.params.deadman_s {
            self.sequencer.spindle_hold_renewed_s = None;
            self.sequencer.spindle_set_rpm = 0.0;
            self.event(EventKind::SpindleDeadManStop);
        }
    }

    fn linear(&mut self, axis: Axis) -> (&mut super::profile::Profile, f64) {
        match axis {
            Axis::Y => (&mut self.y, self.params.y_limits.accel_mm_s2),
            _ => (&mut self.x, self.params.x_limits.accel_mm_s2),
        }
    }
}
