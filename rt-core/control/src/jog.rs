//! Jogging by the operator: incremental (a distance) and continuous with a dead-man (the
//! axis runs only while its frontend renews the command; when the renewals stop, a touch
//! released, a frontend killed, a network lost, it stops within the dead-man time plus
//! the braking time). Until X and Y are referenced every X and Y jog is slow and only the
//! hardware limit switches protect the ends; from the reference on, a jog stops at the
//! soft limits. The hob spindle held while the operator holds it has the same dead-man.
//!
//! [`Jog`] owns the jog under way and the held spindle. Its commands take the machine's
//! state ([`JogContext`]); a cycle of it takes the axes' limits and speeds
//! ([`JogCycle`]) and the X and Y commands it moves; what the table (the gearbox's) and
//! the machine's state are to do is the controller's ([`JogStep`]).

pub use super::command::Direction;
use super::command::State;
use super::fault::{Axis, Refusal};
use super::profile::Profile;
pub use hob_wire::vocab::excitation::{
    CREEP_DEG_S as EXCITE_CREEP_DEG_S, FADE_S as EXCITE_FADE_S, MAX_DEG as EXCITE_MAX_DEG,
    MIN_HZ as EXCITE_MIN_HZ,
};

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
    /// A held sine on the table's target (commissioning's frequency response): faded in,
    /// renewed like a continuous jog, faded out on release or when the renewals stop.
    Excite(Excitation),
}

/// The table's target swung about where it stands: `envelope x amplitude x sin(phase)`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(super) struct Excitation {
    pub frequency_hz: f64,
    /// The way the table creeps meanwhile (at [`EXCITE_CREEP_DEG_S`]).
    pub direction: Direction,
    pub amplitude_deg: f64,
    pub phase_rad: f64,
    /// 0 to 1: faded in over [`EXCITE_FADE_S`], out the same.
    pub envelope: f64,
    pub renewed_at_s: f64,
    pub fading_out: bool,
}

impl Excitation {
    /// The swing at `frequency_hz` for a table whose acceleration is limited to
    /// `accel_deg_s2`, the loop running every `period_s`: the amplitude is the smaller of
    /// [`EXCITE_MAX_DEG`] and what the acceleration allows (`a / (2 pi f)^2`); refused
    /// below [`EXCITE_MIN_HZ`] and above a quarter of the loop's rate.
    pub fn new(
        frequency_hz: f64,
        direction: Direction,
        accel_deg_s2: f64,
        period_s: f64,
        now_s: f64,
    ) -> Result<Self, Refusal> {
        let highest_hz = 0.25 / period_s;
        if !(frequency_hz.is_finite() && (EXCITE_MIN_HZ..=highest_hz).contains(&frequency_hz)) {
            return Err(Refusal::BadValue);
        }
        let w = std::f64::consts::TAU * frequency_hz;
        Ok(Self {
            frequency_hz,
            direction,
            amplitude_deg: EXCITE_MAX_DEG.min(accel_deg_s2 / (w * w)),
            phase_rad: 0.0,
            envelope: 0.0,
            renewed_at_s: now_s,
            fading_out: false,
        })
    }

    /// One cycle: the table's offset from where it stood, deg, and whether the swing is
    /// over (faded out: the offset is exactly 0).
    fn step(&mut self, dt_s: f64) -> (f64, bool) {
        let towards = if self.fading_out { -1.0 } else { 1.0 };
        self.envelope = (self.envelope + towards * dt_s / EXCITE_FADE_S).clamp(0.0, 1.0);
        if self.fading_out && self.envelope == 0.0 {
            return (0.0, true);
        }
        self.phase_rad =
            (self.phase_rad + std::f64::consts::TAU * self.frequency_hz * dt_s) % std::f64::consts::TAU;
        let e = self.envelope;
        let smooth = e * e * (3.0 - 2.0 * e);
        (smooth * self.amplitude_deg * self.phase_rad.sin(), false)
    }
}

/// The operator's jogs: an axis' jog under way and a held hob spindle.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub(super) struct Jog {
    pub motion: JogMotion,
    /// A held spindle (`SpindleHold`): when it was last renewed, s.
    pub spindle_hold_renewed_s: Option<f64>,
}

/// One axis as a jog sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct JogAxis {
    /// The soft limits in the loop's (work) coordinates; none before the reference, and
    /// none for the table.
    pub limits: Option<(f64, f64)>,
    /// The fastest jog (units/s): X and Y half their rapid, or the slow unreferenced
    /// speed; the table its phase speed.
    pub max_speed_per_s: f64,
    /// Acceleration of a linear axis, mm/s^2.
    pub accel: f64,
}

/// The machine as a jog command sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct JogContext {
    pub state: State,
    /// Every drive reports "operation enabled".
    pub drives_ready: bool,
    pub now_s: f64,
    /// The commanded positions of X and Y, mm.
    pub x_mm: f64,
    pub y_mm: f64,
    /// The axis the command jogs.
    pub axis: JogAxis,
}

/// What a cycle of jogging needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct JogCycle {
    pub period_s: f64,
    pub now_s: f64,
    pub deadman_s: f64,
    /// The table still moves (its jog is a move of the gearbox's).
    pub table_moving: bool,
    pub x: JogAxis,
    pub y: JogAxis,
}

/// What came of a cycle of jogging.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct JogStep {
    /// The renewals of the continuous jog of this axis stopped: the dead-man let go.
    pub dead_man: Option<Axis>,
    /// The table is to move on by this much (deg): a continuous jog of B.
    pub table_by: Option<f64>,
    /// The table's target swung this far from the gearbox's (deg): an excitation.
    pub table_offset_deg: f64,
    /// The jog is over: the machine is idle again.
    pub done: bool,
}

impl Jog {
    /// The axis of the jog under way.
    pub fn axis(&self) -> Option<Axis> {
        match self.motion {
            JogMotion::None => None,
            JogMotion::To { axis, .. }
            | JogMotion::Continuous { axis, .. }
            | JogMotion::Stopping { axis } => Some(axis),
            JogMotion::Excite(_) => Some(Axis::B),
        }
    }

    /// Checks and starts (or renews) a held sine on the table's target, only when idle
    /// with every drive enabled; the same frequency again renews it, another is refused
    /// until the one under way has faded out. True for a new one (the machine is to enter
    /// `Jog`).
    pub fn excite(
        &mut self,
        m: &JogContext,
        frequency_hz: f64,
        direction: Direction,
        period_s: f64,
    ) -> Result<bool, Refusal> {
        let new = Excitation::new(frequency_hz, direction, m.axis.accel, period_s, m.now_s)?;
        match (m.state, &mut self.motion) {
            (State::Jog, JogMotion::Excite(e))
                if e.frequency_hz == frequency_hz && e.direction == direction && !e.fading_out =>
            {
                e.renewed_at_s = m.now_s;
                Ok(false)
            }
            (State::Jog, _) => Err(Refusal::JogActive),
            (State::Idle, _) => {
                if !m.drives_ready {
                    return Err(Refusal::DrivesNotEnabled);
                }
                self.motion = JogMotion::Excite(new);
                Ok(true)
            }
            (State::Init, _) => Err(Refusal::NotReady),
            _ => Err(Refusal::CycleRunning),
        }
    }

    /// Checks and starts (or renews) a continuous jog; true for a new jog (the machine
    /// is to enter `Jog`).
    pub fn continuous(
        &mut self,
        m: &JogContext,
        axis: Axis,
        direction: Direction,
        speed_per_min: f64,
    ) -> Result<bool, Refusal> {
        if !(speed_per_min.is_finite() && speed_per_min > 0.0) {
            return Err(Refusal::BadValue);
        }
        let speed_per_s = (speed_per_min / 60.0).min(m.axis.max_speed_per_s);
        let now = m.now_s;
        match (m.state, self.motion) {
            (
                State::Jog,
                JogMotion::Continuous {
                    axis: a,
                    direction: d,
                    ..
                },
            ) if a == axis && d == direction => {
                self.motion = JogMotion::Continuous {
                    axis,
                    direction,
                    speed_per_s,
                    renewed_at_s: now,
                };
                Ok(false)
            }
            (State::Jog, _) => Err(Refusal::JogActive),
            (State::Idle, _) => {
                if !m.drives_ready {
                    return Err(Refusal::DrivesNotEnabled);
                }
                if let Some((lo, hi)) = m.axis.limits {
                    let at = if axis == Axis::X { m.x_mm } else { m.y_mm };
                    let blocked = match direction {
                        Direction::Positive => at >= hi,
                        Direction::Negative => at <= lo,
                    };
                    if blocked {
                        return Err(Refusal::OutsideSoftLimits);
                    }
                }
                self.motion = JogMotion::Continuous {
                    axis,
                    direction,
                    speed_per_s,
                    renewed_at_s: now,
                };
                Ok(true)
            }
            (State::Init, _) => Err(Refusal::NotReady),
            _ => Err(Refusal::CycleRunning),
        }
    }

    /// Checks and starts a jog by a distance (mm, or deg for the table: its move is the
    /// caller's to start on the gearbox). The machine is to enter `Jog`.
    pub fn by(&mut self, m: &JogContext, axis: Axis, distance: f64) -> Result<(), Refusal> {
        match m.state {
            State::Idle => {}
            State::Init => return Err(Refusal::NotReady),
            State::Jog => return Err(Refusal::JogActive),
            _ => return Err(Refusal::CycleRunning),
        }
        if !distance.is_finite() {
            return Err(Refusal::BadValue);
        }
        if !m.drives_ready {
            return Err(Refusal::DrivesNotEnabled);
        }
        let target = match axis {
            Axis::X => m.x_mm + distance,
            Axis::Y => m.y_mm + distance,
            Axis::B => distance,
        };
        if let Some((lo, hi)) = m.axis.limits
            && !(lo..=hi).contains(&target)
        {
            return Err(Refusal::OutsideSoftLimits);
        }
        self.motion = JogMotion::To { axis, target };
        Ok(())
    }

    /// The operator let go: brake the jog to a stop.
    pub fn release(&mut self, state: State) -> Result<(), Refusal> {
        match (state, self.motion) {
            (State::Jog, JogMotion::To { axis, .. } | JogMotion::Continuous { axis, .. }) => {
                self.motion = JogMotion::Stopping { axis };
                Ok(())
            }
            (State::Jog, JogMotion::Excite(mut e)) if !e.fading_out => {
                e.fading_out = true;
                self.motion = JogMotion::Excite(e);
                Ok(())
            }
            _ => Err(Refusal::NothingToDo),
        }
    }

    /// One cycle of the jog under way: X or Y moved in `x`, `y`.
    pub fn step(&mut self, c: &JogCycle, x: &mut Profile, y: &mut Profile) -> JogStep {
        let dt = c.period_s;
        let mut out = JogStep::default();
        let done = match self.motion {
            JogMotion::None => true,
            JogMotion::To { axis: Axis::B, .. } => !c.table_moving,
            JogMotion::To { axis, target } => {
                let (p, a) = linear(axis, c, x, y);
                p.step_towards(target, a.max_speed_per_s, a.accel, dt)
            }
            JogMotion::Continuous {
                axis,
                direction,
                speed_per_s,
                renewed_at_s,
            } => {
                if c.now_s - renewed_at_s > c.deadman_s {
                    // The renewals stopped: the dead-man lets go.
                    self.motion = JogMotion::Stopping { axis };
                    return JogStep {
                        dead_man: Some(axis),
                        ..self.step(c, x, y)
                    };
                }
                if axis == Axis::B {
                    out.table_by = Some(direction.sign() * speed_per_s * dt);
                } else {
                    let (p, a) = linear(axis, c, x, y);
                    let target = match (a.limits, direction) {
                        (Some((_, hi)), Direction::Positive) => hi,
                        (Some((lo, _)), Direction::Negative) => lo,
                        // Before the reference: far ahead, re-aimed every cycle.
                        (None, d) => p.position + d.sign() * 1000.0,
                    };
                    p.step_towards(target, speed_per_s, a.accel, dt);
                }
                false
            }
            JogMotion::Excite(mut e) => {
                if !e.fading_out && c.now_s - e.renewed_at_s > c.deadman_s {
                    // The renewals stopped: the swing fades out.
                    e.fading_out = true;
                    out.dead_man = Some(Axis::B);
                }
                let (offset, over) = e.step(dt);
                self.motion = JogMotion::Excite(e);
                out.table_offset_deg = offset;
                if !e.fading_out {
                    out.table_by = Some(e.direction.sign() * EXCITE_CREEP_DEG_S * dt);
                }
                over
            }
            JogMotion::Stopping { axis: Axis::B } => !c.table_moving,
            JogMotion::Stopping { axis } => {
                let (p, a) = linear(axis, c, x, y);
                p.step_stop(a.accel, dt)
            }
        };
        if done {
            self.motion = JogMotion::None;
        }
        out.done = done;
        out
    }

    /// Checks and starts (or renews) a held hob spindle at `rpm` (the caller sets the
    /// speed): only when idle (also while an axis jogs), at most the machine's spindle
    /// speed, and not a spindle latched on (`set_rpm` without a hold).
    pub fn hold_spindle(
        &mut self,
        state: State,
        rpm: f64,
        max_rpm: f64,
        set_rpm: f64,
        now_s: f64,
    ) -> Result<(), Refusal> {
        match state {
            State::Idle | State::Jog => {}
            State::Init => return Err(Refusal::NotReady),
            _ => return Err(Refusal::CycleRunning),
        }
        if !(rpm.is_finite() && rpm > 0.0 && rpm <= max_rpm) {
            return Err(Refusal::BadValue);
        }
        if set_rpm > 0.0 && self.spindle_hold_renewed_s.is_none() {
            // Latched by SPINDLE ON: holding it would make it stop on release.
            return Err(Refusal::NothingToDo);
        }
        self.spindle_hold_renewed_s = Some(now_s);
        Ok(())
    }

    /// One cycle of a held spindle: it is let go when the machine leaves idle and jog (a
    /// cycle or a fault owns the spindle); true when its renewals stopped (the dead-man:
    /// the spindle is to stop).
    pub fn spindle_dead_man(&mut self, state: State, now_s: f64, deadman_s: f64) -> bool {
        let Some(renewed_at_s) = self.spindle_hold_renewed_s else {
            return false;
        };
        if !matches!(state, State::Idle | State::Jog) {
            self.spindle_hold_renewed_s = None;
            return false;
        }
        if now_s - renewed_at_s > deadman_s {
            self.spindle_hold_renewed_s = None;
            return true;
        }
        false
    }
}

/// The command and the limits of a linear axis (X for any but Y).
fn linear<'a>(
    axis: Axis,
    c: &'a JogCycle,
    x: &'a mut Profile,
    y: &'a mut Profile,
) -> (&'a mut Profile, &'a JogAxis) {
    match axis {
        Axis::Y => (y, &c.y),
        _ => (x, &c.x),
    }
}
