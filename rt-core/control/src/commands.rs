//! What a frontend asks of the loop, in one place: [`Controller::load`] and
//! [`Controller::command`]. A command is checked against the machine state (a refusal
//! changes nothing) and carried out by one small handler; [`Controller::command`]
//! dispatches by a short match, and every outcome is also an event. The handlers are
//! grouped as the match is: reset and the overrides (taken even in a fault), the cycle,
//! jog and referencing, the spindle, setting up the part (touch-off, flanks, new blank).

use super::Controller;
use super::align;
use super::command::{Command, Direction, HomeAxes, State};
use super::egb::GearboxParams;
use super::events::EventKind;
use super::fault::{Axis, Fault, Refusal};
use super::program::CycleProgram;
use super::setup_math;

/// Set-up commands and starts need the machine idle: the refusal for any other state.
fn idle(state: State) -> Result<(), Refusal> {
    match state {
        State::Idle => Ok(()),
        State::Init => Err(Refusal::NotReady),
        State::Jog => Err(Refusal::JogActive),
        _ => Err(Refusal::CycleRunning),
    }
}

impl Controller {
    /// Loads a program (built outside the loop). Refused during a cycle or a fault.
    pub fn load(&mut self, program: CycleProgram) -> Result<(), Refusal> {
        if self.sequencer.state.in_cycle() {
            return Err(Refusal::CycleRunning);
        }
        let params = GearboxParams {
            ratio_signed: program.ratio_signed,
            differential_signed_deg_per_mm: program.differential_signed_deg_per_mm,
            pitch_deg: program.pitch_deg(),
            ..self.params.gearbox
        };
        let same_law = self.program.is_some_and(|old| {
            old.ratio_signed == program.ratio_signed
                && old.differential_signed_deg_per_mm == program.differential_signed_deg_per_mm
                && old.teeth == program.teeth
        });
        if !same_law {
            // A different gear: the recorded phase belongs to another blank.
            self.gearbox.set_params(params);
            self.sequencer.flank_touch = [None; 2];
        }
        if self.program != Some(program) {
            // "Continue" belongs to the program it interrupted.
            self.sequencer.interrupted = None;
        }
        self.program = Some(program);
        self.event(EventKind::ProgramLoaded);
        Ok(())
    }

    /// Handles a command; every outcome is also an event.
    pub fn command(&mut self, cmd: Command) -> Result<(), Refusal> {
        let result = self.try_command(cmd);
        match result {
            Ok(()) => self.event(EventKind::Accepted(cmd)),
            Err(reason) => self.event(EventKind::Refused { command: cmd, reason }),
        }
        result
    }

    fn try_command(&mut self, cmd: Command) -> Result<(), Refusal> {
        match cmd {
            Command::Reset => self.reset(),
            // Overrides may change at any time, even in a fault (for the next start).
            Command::FeedOverride { percent } => self.set_feed_override(percent),
            Command::SpindleOverride { percent } => self.set_spindle_override(percent),
            _ if self.fault.is_some() => Err(Refusal::Faulted),
            Command::Start { single } => self.start(single),
            Command::Continue => self.continue_interrupted(),
            Command::FeedHold => self.feed_hold(),
            Command::Resume => self.resume(),
            Command::Stop => self.stop(),
            Command::Jog { axis, distance } => self.jog_by(axis, distance),
            Command::JogContinuous {
                axis,
                direction,
                speed_per_min,
            } => self.jog_continuous(axis, direction, speed_per_min),
            Command::JogRelease => self.jog_release(),
            Command::ExciteTable { frequency_hz, creep } => self.excite_table(frequency_hz, creep),
            Command::PitchCompensation { on } => self.switch_pitch_compensation(on),
            Command::Home { axes } => self.home(axes),
            Command::TouchOff {
                axis,
                value_mm,
                confirmed,
            } => self.touch_off(axis, value_mm, confirmed),
            Command::SpindleOn { rpm } => self.spindle_on(rpm),
            Command::SpindleHold { rpm } => self.spindle_hold(rpm),
            Command::SpindleOff => self.spindle_off(),
            Command::NewBlank => self.new_blank(),
            Command::TouchFlank { turned } => self.touch_flank(turned),
        }
    }

    // Reset and the overrides.

    /// Clears a fault whose cause is gone: the machine powers up again.
    fn reset(&mut self) -> Result<(), Refusal> {
        if self.fault.is_none() {
            return Err(Refusal::NothingToDo);
        }
        if self.sequencer.state != State::Faulted {
            return Err(Refusal::CycleRunning);
        }
        if self.fault == Some(Fault::LubeTimeout) {
            self.lube.request();
        }
        self.fault = None;
        // The drives' enable (and the fault reset) starts over, with its full time.
        self.enable_age_s = 0.0;
        self.event(EventKind::FaultCleared);
        self.enter(State::Init);
        Ok(())
    }

    /// Feed override in percent of the programmed feed.
    fn set_feed_override(&mut self, percent: f64) -> Result<(), Refusal> {
        self.feed_override = self.params.overrides.feed(percent).ok_or(Refusal::BadValue)?;
        Ok(())
    }

    /// Spindle speed override in percent of the programmed speed.
    fn set_spindle_override(&mut self, percent: f64) -> Result<(), Refusal> {
        self.spindle_override = self.params.overrides.spindle(percent).ok_or(Refusal::BadValue)?;
        Ok(())
    }

    // The cycle.

    /// Starts the loaded program from its first pass, on a new part.
    fn start(&mut self, single: bool) -> Result<(), Refusal> {
        let program = self.program.ok_or(Refusal::NoProgram)?;
        self.check_can_start(&program, single)?;
        self.sequencer.interrupted = None;
        self.sequencer.phase_lost = false;
        self.sequencer.flank_touch = [None; 2];
        self.begin_cycle(single, 0);
        Ok(())
    }

    /// Continues the interrupted program on the same part: the interrupted pass, its cut
    /// re-entered behind where it stopped (`Status::continue_from_y_mm`).
    fn continue_interrupted(&mut self) -> Result<(), Refusal> {
        let program = self.program.ok_or(Refusal::NoProgram)?;
        let Some(interrupted) = self.sequencer.interrupted else {
            return Err(Refusal::NothingToDo);
        };
        self.check_can_start(&program, interrupted.single)?;
        if self.sequencer.phase_lost {
            return Err(Refusal::TablePositionLost);
        }
        self.begin_cycle(interrupted.single, interrupted.pass_index);
        // The pass is under way again: "continue" is noted anew if it is broken off again.
        self.sequencer.interrupted = None;
        self.sequencer.resume_y_mm = interrupted.from_y_mm;
        Ok(())
    }

    /// Feed hold in a cycle.
    fn feed_hold(&mut self) -> Result<(), Refusal> {
        if !self.sequencer.state.in_cycle() || self.sequencer.hold {
            return Err(Refusal::NothingToDo);
        }
        self.sequencer.hold = true;
        Ok(())
    }

    /// Resumes after a feed hold.
    fn resume(&mut self) -> Result<(), Refusal> {
        if !self.sequencer.hold {
            return Err(Refusal::NothingToDo);
        }
        self.sequencer.hold = false;
        Ok(())
    }

    /// Cycle stop: out of the cut, gearbox out, spindle off; also stops a jog, a
    /// referencing run and a spindle turning on its own.
    fn stop(&mut self) -> Result<(), Refusal> {
        let state = self.sequencer.state;
        if !state.in_cycle()
            && !matches!(state, State::Jog | State::Referencing)
            && self.sequencer.spindle_set_rpm == 0.0
        {
            return Err(Refusal::NothingToDo);
        }
        self.sequencer.hold = false;
        if state.in_cycle() {
            self.note_interrupted();
        }
        match state {
            State::Idle => {
                self.sequencer.spindle_set_rpm = 0.0;
                self.sequencer.jog.spindle_hold_renewed_s = None;
            }
            State::Jog => {
                // Everything the operator set moving stops: the jog and the spindle.
                self.sequencer.spindle_set_rpm = 0.0;
                self.sequencer.jog.spindle_hold_renewed_s = None;
                self.jog_release()?;
            }
            State::Referencing => self.referencing.stop(),
            s if s.tool_in_work() || s == State::Infeed => {
                self.sequencer.stopping = true;
                self.leave_cut()
            }
            State::Home | State::Disengage | State::SpindleDown => self.sequencer.stopping = true,
            _ => {
                self.sequencer.stopping = true;
                self.enter(State::Disengage)
            }
        }
        Ok(())
    }

    /// What a start (or a continue) needs: idle, referenced, the chain closed, the
    /// drives enabled, the program's moves within the soft limits.
    fn check_can_start(&self, program: &CycleProgram, single: bool) -> Result<(), Refusal> {
        idle(self.sequencer.state)?;
        if !self.params.delay_commissioned {
            return Err(Refusal::DelayNotCommissioned);
        }
        if single && program.single().is_none() {
            return Err(Refusal::NoSingleDepth);
        }
        if !self.referencing.all_referenced() {
            return Err(Refusal::NotReferenced);
        }
        if !self.measured.inputs.safety_chain_closed {
            return Err(Refusal::SafetyChainOpen);
        }
        if !self.drives_ready() {
            return Err(Refusal::DrivesNotEnabled);
        }
        let (Some((x_lo, x_hi)), Some((y_lo, y_hi))) = (self.work_limits(Axis::X), self.work_limits(Axis::Y))
        else {
            return Err(Refusal::NotReferenced);
        };
        let (x_min, x_max, y_min, y_max) = program.extents_mm();
        if x_min < x_lo || x_max > x_hi || y_min < y_lo || y_max > y_hi {
            return Err(Refusal::OutsideSoftLimits);
        }
        Ok(())
    }

    fn begin_cycle(&mut self, single: bool, pass_index: usize) {
        self.sequencer.single = single;
        self.sequencer.pass_index = pass_index;
        self.sequencer.tooth = 0;
        self.sequencer.stopping = false;
        self.sequencer.hold = false;
        self.sequencer.resume_y_mm = None;
        self.enter(State::ToSafe);
    }

    // Jog and referencing.

    /// Starts referencing X and/or Y.
    fn home(&mut self, axes: HomeAxes) -> Result<(), Refusal> {
        idle(self.sequencer.state)?;
        if !self.drives_ready() {
            return Err(Refusal::DrivesNotEnabled);
        }
        self.referencing.begin(axes);
        self.enter(State::Referencing);
        Ok(())
    }

    /// Jogs an axis by a distance, only when idle (module `jog`).
    fn jog_by(&mut self, axis: Axis, distance: f64) -> Result<(), Refusal> {
        let m = self.jog_context(axis);
        self.sequencer.jog.by(&m, axis, distance)?;
        if axis == Axis::B {
            self.gearbox.move_table_by(distance);
        }
        self.enter(State::Jog);
        Ok(())
    }

    /// Starts (or renews) a continuous jog (module `jog`).
    fn jog_continuous(
        &mut self,
        axis: Axis,
        direction: Direction,
        speed_per_min: f64,
    ) -> Result<(), Refusal> {
        let m = self.jog_context(axis);
        if self
            .sequencer
            .jog
            .continuous(&m, axis, direction, speed_per_min)?
        {
            self.enter(State::Jog);
        }
        Ok(())
    }

    /// Starts (or renews) a held sine on the table's target (module `jog`).
    fn excite_table(&mut self, frequency_hz: f64, creep: Direction) -> Result<(), Refusal> {
        let m = self.jog_context(Axis::B);
        if self.sequencer.state == State::Idle && self.gearbox.table_moving() {
            return Err(Refusal::JogActive);
        }
        if self
            .sequencer
            .jog
            .excite(&m, frequency_hz, creep, self.params.period_s)?
        {
            self.enter(State::Jog);
        }
        Ok(())
    }

    /// The operator let go of a jog: it brakes to a stop.
    fn jog_release(&mut self) -> Result<(), Refusal> {
        self.sequencer.jog.release(self.sequencer.state)
    }

    // The spindle.

    /// The spindle at a speed, latched, only when idle.
    fn spindle_on(&mut self, rpm: f64) -> Result<(), Refusal> {
        let state = self.sequencer.state;
        if state != State::Idle {
            return Err(if state == State::Init {
                Refusal::NotReady
            } else {
                Refusal::CycleRunning
            });
        }
        if !(rpm.is_finite() && rpm > 0.0 && rpm <= self.params.spindle_max_rpm) {
            return Err(Refusal::BadValue);
        }
        self.sequencer.spindle_set_rpm = rpm;
        self.sequencer.jog.spindle_hold_renewed_s = None;
        Ok(())
    }

    /// The hob spindle at a speed while the operator holds it (module `jog`).
    fn spindle_hold(&mut self, rpm: f64) -> Result<(), Refusal> {
        let now_s = self.now_s();
        let (state, max_rpm, set_rpm) = (
            self.sequencer.state,
            self.params.spindle_max_rpm,
            self.sequencer.spindle_set_rpm,
        );
        self.sequencer
            .jog
            .hold_spindle(state, rpm, max_rpm, set_rpm, now_s)?;
        self.sequencer.spindle_set_rpm = rpm;
        Ok(())
    }

    /// The spindle off, outside a cycle.
    fn spindle_off(&mut self) -> Result<(), Refusal> {
        if self.sequencer.state.in_cycle() {
            return Err(Refusal::CycleRunning);
        }
        self.sequencer.spindle_set_rpm = 0.0;
        self.sequencer.jog.spindle_hold_renewed_s = None;
        Ok(())
    }

    // Setting up the part.

    /// Touch-off: sets an axis' work offset from a gauge touched with the hob's tip, once
    /// it is judged plausible against the loaded blank, the previous offset and where the
    /// axes stand, or the operator confirmed the offset the loop showed
    /// (`setup_math::check_touch_off`, `TouchOffs::decide`). An absurd one is refused even
    /// confirmed. [`Controller::last_touch_off`] keeps the figures for the answer.
    fn touch_off(&mut self, axis: Axis, value_mm: f64, confirmed: bool) -> Result<(), Refusal> {
        self.touch_offs.last = None;
        idle(self.sequencer.state)?;
        if !self.referencing.is_referenced(axis) || axis == Axis::B {
            return Err(if axis == Axis::B {
                Refusal::BadValue
            } else {
                Refusal::NotReferenced
            });
        }
        let program = self.program.ok_or(Refusal::NoProgram)?;
        let (work_mm, old_offset_mm, other) = match axis {
            Axis::X => (
                self.measured.x_mm,
                self.offsets.x_mm,
                (Axis::Y, self.measured.y_mm),
            ),
            _ => (
                self.measured.y_mm,
                self.offsets.y_mm,
                (Axis::X, self.measured.x_mm),
            ),
        };
        let judged = setup_math::check_touch_off(&setup_math::TouchOffInput {
            axis,
            gauge_mm: value_mm,
            machine_mm: work_mm - old_offset_mm,
            old_offset_mm,
            other_work_mm: self.referencing.is_referenced(other.0).then_some(other.1),
            tool_tip_diameter_mm: program.tool_tip_diameter_mm,
            blank: program.blank(),
            confirm_mm: self.params.touch_off_confirm_mm,
        })
        .ok_or(Refusal::BadValue)?;
        let applied = self
            .touch_offs
            .decide(judged, confirmed)
            .ok_or(Refusal::OffsetNeedsConfirmation)?;
        let offset = applied.new_offset_mm;
        let mut offsets = self.offsets;
        match axis {
            Axis::X => offsets.x_mm = offset,
            _ => offsets.y_mm = offset,
        }
        self.apply_offsets(offsets);
        self.event(EventKind::OffsetChanged {
            axis,
            offset_mm: offset,
        });
        Ok(())
    }

    /// The loaded pitch compensation on or off: outside a cycle, with the gearbox out (the
    /// switch would step the table); on refused without one loaded.
    fn switch_pitch_compensation(&mut self, on: bool) -> Result<(), Refusal> {
        if self.sequencer.state.in_cycle() || self.gearbox.coupling() != crate::egb::Coupling::Disengaged {
            return Err(Refusal::CycleRunning);
        }
        if on && self.pitch_compensation.is_none() {
            return Err(Refusal::NoCompensation);
        }
        self.pitch_compensation_on = on;
        Ok(())
    }

    /// A new blank is on the table: forget the recorded tooth phase.
    fn new_blank(&mut self) -> Result<(), Refusal> {
        if self.sequencer.state.in_cycle() {
            return Err(Refusal::CycleRunning);
        }
        self.gearbox.new_blank();
        self.sequencer.interrupted = None;
        self.sequencer.phase_lost = false;
        self.sequencer.flank_touch = [None; 2];
        Ok(())
    }

    /// A flank of a gap touched with the table turned in `turned` (module `align`), in
    /// idle with a program loaded (the gearbox's law comes with it).
    fn touch_flank(&mut self, turned: Direction) -> Result<(), Refusal> {
        idle(self.sequencer.state)?;
        // The gearbox's law comes with the program.
        self.program.ok_or(Refusal::NoProgram)?;
        if self.measured.spindle_speed_deg_s.abs() > align::STANDSTILL_DEG_S
            || self.sequencer.spindle_set_rpm != 0.0
        {
            return Err(Refusal::SpindleTurning);
        }
        let law = *self.gearbox.params();
        let phase_deg =
            self.measured.table_deg - law.coupled_deg(self.measured.spindle_for_gearbox_deg, self.y.position);
        let mut touches = self.sequencer.flank_touch;
        touches[match turned {
            Direction::Negative => 0,
            Direction::Positive => 1,
        }] = Some(phase_deg);
        let centre = match touches {
            [Some(neg), Some(pos)] => {
                Some(align::gap_centre_deg(neg, pos, law.pitch_deg).ok_or(Refusal::FlanksCrossed)?)
            }
            _ => None,
        };
        self.event(EventKind::FlankTouched { turned, phase_deg });
        match centre {
            Some((phase_deg, play_deg)) => {
                self.gearbox.restore_recorded_phase(phase_deg);
                self.sequencer.phase_lost = false;
                self.sequencer.flank_touch = [None; 2];
                self.event(EventKind::PhaseAligned { phase_deg, play_deg });
            }
            None => self.sequencer.flank_touch = touches,
        }
        Ok(())
    }
}
