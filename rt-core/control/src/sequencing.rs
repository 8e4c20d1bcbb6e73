//! One control cycle of the sequencer ([`Controller::sequence`]): the three cycles of
//! docs/domain.md section 5 with all their steps, rough and finishing passes, single mode,
//! feed hold, cycle stop, return to start; peripherals (coolant, X clamp, spindle); and the
//! fault reaction: retract X first with the gearbox engaged, then stop, then drop the PC-OK
//! relay (`seq_on_fault` starts it). The sequencer's own state is `Sequencer` (module
//! `sequencer`). `sequence` runs what every state shares, then one function per state, in
//! the order of the cycle: the approach, the work, out of the work, the end or stop, the
//! fault reaction; outside a cycle idle, jog (module `jog`) and referencing (module
//! `referencing`).

use super::Controller;
use super::command::State;
use super::egb::Coupling;
use super::events::EventKind;
use super::fault::{Axis, Fault};
use super::jog::{JogAxis, JogContext, JogCycle, JogMotion};
use super::profile::Profile;
use super::program::{CycleProgram, PassSetpoint};
use super::referencing::{HomingInputs, Progress};
use super::setup_math;
use hob_setup::job::CycleKind;

/// Feed ramp time in and out of the cut (feed hold, resume).
const FEED_RAMP_S: f64 = 0.2;
/// Time the stop sequence may take before the drives are disabled anyway.
const STOP_TIMEOUT_S: f64 = 15.0;
/// In the fault reaction X is out when its measured position is this close to the safe
/// position (the command there is not enough: the slide may not have followed).
const RETRACTED_WITHIN_MM: f64 = 0.02;
/// Time the slide may take to settle at the safe position after its command got there;
/// then the stop goes on anyway (a slide that cannot move is not waited for).
const RETRACT_SETTLE_TIMEOUT_S: f64 = 2.0;
/// Time the gearbox may take to synchronise before it is a fault.
const SYNC_TIMEOUT_S: f64 = 20.0;
/// Below this the spindle counts as stopped.
const SPINDLE_STOPPED_RPM: f64 = 1.0;
/// X rapids this far outside the blank before the radial plunge at feed.
const PLUNGE_CLEARANCE_MM: f64 = 1.0;
/// Fastest change of the spindle speed by its override with the tool in the work (rpm/s,
/// 60 deg/s^2 of spindle). The VFD's own ramp (80 Hz in 3 s: 83 rpm/s at the spindle)
/// jerks the spindle observer and the table by about 13 arcsec, above the cut's bound (a
/// quarter of ISO 1328-1 grade 5: 8.6 arcsec at z = 17, m = 5); the jerk's error scales
/// with the acceleration, so at 10 rpm/s it adds under 2 arcsec
/// (`bench/plant/tests/setup_ops.rs`).
const OVERRIDE_SPINDLE_RPM_S: f64 = 10.0;

impl Controller {
    /// One cycle of the sequencer: what every state shares (the state's time, a held
    /// spindle, the coolant, the gearbox's window with the tool in the work), then the
    /// state's step.
    pub(super) fn sequence(&mut self) {
        let dt = self.params.period_s;
        self.sequencer.state_time_s += dt;
        self.sequence_spindle_hold();
        let state = self.sequencer.state;
        self.sequencer.coolant = matches!(
            state,
            State::Infeed
                | State::Plunge
                | State::ExtraRev
                | State::Clamp
                | State::Cut
                | State::Unclamp
                | State::Retract
        ) && self.sequencer.spindle_set_rpm > 0.0;
        let status = self.gearbox.status();
        if state.tool_in_work()
            && self.gearbox.coupling() == Coupling::Synchronised
            && !status.in_coarse_window
        {
            self.raise(Fault::SyncLost {
                error_arcsec: status.error_deg * 3600.0,
            });
            return;
        }
        match state {
            State::Init | State::Idle | State::Faulted => self.sequence_idle(),
            State::Jog => self.sequence_jog(),
            State::Referencing => self.sequence_referencing(),
            State::Disengage => self.sequence_disengage(),
            State::SpindleDown => self.sequence_spindle_down(),
            State::FaultStop => self.sequence_fault_stop(),
            State::ToSafe
            | State::ToStart
            | State::SpindleUp
            | State::Engage
            | State::Infeed
            | State::Plunge
            | State::ExtraRev
            | State::Clamp
            | State::Cut
            | State::Unclamp
            | State::Retract
            | State::Return
            | State::Index
            | State::Home
            | State::FaultRetract => self.sequence_cycle(state),
        }
    }

    /// A step of the cycle under way (or of the fault reaction's retract), with the
    /// program and the pass it runs: one function per state, in the cycle's order.
    fn sequence_cycle(&mut self, state: State) {
        let (Some(program), Some(pass)) = (self.program, self.current_pass()) else {
            // A cycle state without a program cannot happen (loading is refused in a
            // cycle); stop safely if it ever does.
            self.sequencer.stopping = true;
            self.enter(State::Disengage);
            return;
        };
        self.ramp_spindle_override(state, &program, &pass);
        match state {
            // The approach.
            State::ToSafe => self.sequence_to_safe(&program),
            State::ToStart => self.sequence_to_start(&pass),
            State::SpindleUp => self.sequence_spindle_up(&program, &pass),
            State::Engage => self.sequence_engage(),
            // In the work.
            State::Infeed => self.sequence_infeed(&program, &pass),
            State::Plunge => self.sequence_plunge(&program, &pass),
            State::ExtraRev => self.sequence_extra_rev(&program),
            State::Clamp => self.sequence_clamp(),
            State::Cut => self.sequence_cut(&program, &pass),
            State::Unclamp => self.sequence_unclamp(),
            // Out of the work, tooth by tooth the next tooth, at the end Y back.
            State::Retract => self.sequence_retract(&program),
            State::Return => self.sequence_return(&program, &pass),
            State::Index => self.sequence_index(&program),
            State::Home => self.sequence_home(&program, &pass),
            // The fault reaction's retract.
            State::FaultRetract => self.sequence_fault_retract(&program),
            State::Init | State::Idle | State::Jog | State::Faulted | State::Referencing => {}
            State::Disengage | State::SpindleDown | State::FaultStop => {}
        }
    }

    /// The spindle override acts on a running spindle; the table follows the measured
    /// spindle and the feed its revolutions, so the law holds. With the tool in the
    /// work the change is ramped (OVERRIDE_SPINDLE_RPM_S): at the VFD's own ramp the
    /// jerk throws the table off the law by more than the cut's error bound.
    fn ramp_spindle_override(&mut self, state: State, program: &CycleProgram, pass: &PassSetpoint) {
        if self.sequencer.spindle_set_rpm > 0.0 && !matches!(state, State::ToSafe | State::FaultRetract) {
            let target = self.pass_spindle_rpm(program, pass);
            let set = self.sequencer.spindle_set_rpm;
            self.sequencer.spindle_set_rpm = if state.tool_in_work() {
                let step = OVERRIDE_SPINDLE_RPM_S * self.params.period_s;
                set + (target - set).clamp(-step, step)
            } else {
                target
            };
        }
    }

    // The approach.

    /// X out to the safe position at rapid.
    fn sequence_to_safe(&mut self, program: &CycleProgram) {
        let rapid_x = self.params.x_limits.rapid_mm_s;
        self.sequencer.clamp = false;
        if self.move_x(program.x_safe_mm, rapid_x) {
            self.enter(State::ToStart);
        }
    }

    /// Y to the pass's start.
    fn sequence_to_start(&mut self, pass: &PassSetpoint) {
        if self.move_y(pass.y_start_mm) {
            self.enter(State::SpindleUp);
        }
    }

    /// The spindle up to the pass's speed (not while held).
    fn sequence_spindle_up(&mut self, program: &CycleProgram, pass: &PassSetpoint) {
        if self.sequencer.hold {
            return;
        }
        self.sequencer.spindle_set_rpm = self.pass_spindle_rpm(program, pass);
        if self.spindle_at_speed() {
            self.event(EventKind::PassStarted {
                pass: self.sequencer.pass_index as u32 + 1,
            });
            self.enter(State::Engage);
        } else if self.sequencer.state_time_s > self.params.spindle_start_timeout_s {
            let actual_rpm = self.measured.spindle_speed_deg_s.abs() / 6.0;
            self.raise(Fault::SpindleSpeed {
                set_rpm: pass.spindle_rpm,
                actual_rpm,
            });
        }
    }

    /// The gearbox in: synchronised within its window (the first time on a blank, its
    /// tooth phase is recorded).
    fn sequence_engage(&mut self) {
        let recorded_before = self.gearbox.recorded_phase_deg();
        self.gearbox.engage();
        if recorded_before.is_none()
            && let Some(phase_deg) = self.gearbox.recorded_phase_deg()
        {
            self.event(EventKind::PhaseRecorded { phase_deg });
        }
        if self.gearbox.ready_to_cut() && !self.sequencer.hold {
            self.enter(State::Infeed);
        } else if self.sequencer.state_time_s > SYNC_TIMEOUT_S {
            let error_arcsec = self.gearbox.status().error_deg * 3600.0;
            self.raise(Fault::SyncLost { error_arcsec });
        }
    }

    // In the work.

    /// X in to the pass's depth at rapid (radial plunge: to just outside the blank).
    fn sequence_infeed(&mut self, program: &CycleProgram, pass: &PassSetpoint) {
        let rapid_x = self.params.x_limits.rapid_mm_s;
        let target = if program.cycle == CycleKind::RadialPlunge {
            program.x_surface_mm + PLUNGE_CLEARANCE_MM
        } else {
            self.x_in_cut(program, pass)
        };
        if self.move_x(target, rapid_x) {
            self.sequencer.rev_start_deg = self.measured.spindle_deg;
            if program.cycle == CycleKind::RadialPlunge {
                self.enter(State::Plunge);
            } else {
                self.enter_cut_or_clamp(program);
            }
        }
    }

    /// Radial plunge: X in to the pass's depth at the plunge feed.
    fn sequence_plunge(&mut self, program: &CycleProgram, pass: &PassSetpoint) {
        let target = self.x_in_cut(program, pass);
        let feed_mm_s = program.plunge_feed_mm_min / 60.0 * self.feed_override;
        if self.move_x(target, feed_mm_s) {
            self.sequencer.rev_start_deg = self.measured.spindle_deg;
            self.enter(State::ExtraRev);
        }
    }

    /// Radial plunge: one more turn of the table at depth before the feed.
    fn sequence_extra_rev(&mut self, program: &CycleProgram) {
        let table_turn =
            (program.ratio_signed * (self.measured.spindle_deg - self.sequencer.rev_start_deg)).abs();
        if table_turn >= 360.0 {
            self.enter_cut_or_clamp(program);
        }
    }

    /// X clamped before the cut.
    fn sequence_clamp(&mut self) {
        self.sequencer.clamp = true;
        if self.measured.inputs.x_clamp_closed {
            self.sequencer.feed_scale = 0.0;
            self.enter(State::Cut);
        } else if self.sequencer.state_time_s > self.params.clamp_timeout_s {
            self.raise(Fault::ClampTimeout);
        }
    }

    /// The cut: Y fed with the spindle's turning (ramped in and out by feed hold), X
    /// following the shape; at the pass's end out of the cut.
    fn sequence_cut(&mut self, program: &CycleProgram, pass: &PassSetpoint) {
        let dt = self.params.period_s;
        let want = if self.sequencer.hold {
            0.0
        } else {
            self.feed_override
        };
        let ramp = dt / FEED_RAMP_S;
        self.sequencer.feed_scale += (want - self.sequencer.feed_scale).clamp(-ramp, ramp);
        // Y is tied to the spindle: it advances with the spindle's turning, never with time.
        let spindle_delta = program.spindle_sign
            * (self.measured.spindle_for_gearbox_deg - self.last_spindle_for_gearbox_deg);
        let dy = program.feed_sign
            * pass.feed_mm_per_spindle_deg
            * spindle_delta.max(0.0)
            * self.sequencer.feed_scale;
        let before = self.y.position;
        let mut y = before + dy;
        let done = (pass.y_end_mm - y) * program.feed_sign <= 0.0;
        if done {
            y = pass.y_end_mm;
        }
        self.y.position = y;
        self.y.velocity = (y - before) / dt;
        let x = self.x_in_cut(program, pass);
        self.x.velocity = (x - self.x.position) / dt;
        self.x.position = x;
        if done {
            self.y.velocity = 0.0;
            self.x.velocity = 0.0;
            self.leave_cut();
        }
    }

    /// X unclamped after the cut.
    fn sequence_unclamp(&mut self) {
        self.sequencer.clamp = false;
        if !self.measured.inputs.x_clamp_closed {
            self.enter(State::Retract);
        } else if self.sequencer.state_time_s > self.params.clamp_timeout_s {
            self.raise(Fault::ClampTimeout);
        }
    }

    // Out of the work.

    /// X out to the safe position; then the next pass, the next tooth or the stop.
    fn sequence_retract(&mut self, program: &CycleProgram) {
        let rapid_x = self.params.x_limits.rapid_mm_s;
        if self.move_x(program.x_safe_mm, rapid_x) {
            if self.sequencer.stopping {
                self.enter(State::Disengage);
            } else if program.cycle == CycleKind::ToothByTooth {
                self.enter(State::Return);
            } else {
                self.next_pass();
            }
        }
    }

    /// Tooth by tooth: Y back to the start, then the table on by a pitch.
    fn sequence_return(&mut self, program: &CycleProgram, pass: &PassSetpoint) {
        if self.move_y(pass.y_start_mm) {
            self.gearbox.move_table_by(program.pitch_deg());
            self.enter(State::Index);
        }
    }

    /// Tooth by tooth: the table's index to the next tooth.
    fn sequence_index(&mut self, program: &CycleProgram) {
        if !self.gearbox.table_moving() {
            self.sequencer.tooth += 1;
            if self.sequencer.tooth < program.teeth {
                self.enter(State::Infeed);
            } else {
                self.sequencer.tooth = 0;
                self.next_pass();
            }
        }
    }

    /// At the end: Y back to the start of the program (single mode: of its pass).
    fn sequence_home(&mut self, program: &CycleProgram, pass: &PassSetpoint) {
        let start = if self.sequencer.single {
            pass.y_start_mm
        } else {
            program.passes()[0].y_start_mm
        };
        if self.move_y(start) {
            self.enter(State::Disengage);
        }
    }

    // The end of the cycle, or its stop.

    /// X and Y braked, the gearbox out.
    fn sequence_disengage(&mut self) {
        let dt = self.params.period_s;
        self.sequencer.clamp = false;
        self.x.step_stop(self.params.x_limits.accel_mm_s2, dt);
        self.y.step_stop(self.params.y_limits.accel_mm_s2, dt);
        self.gearbox.disengage();
        if self.gearbox.coupling() == Coupling::Disengaged && !self.gearbox.table_moving() {
            self.enter(State::SpindleDown);
        }
    }

    /// The spindle down; then idle (the cycle done, unless it was stopped).
    fn sequence_spindle_down(&mut self) {
        self.sequencer.spindle_set_rpm = 0.0;
        if self.spindle_stopped() {
            if !self.sequencer.stopping {
                self.sequencer.interrupted = None;
                self.event(EventKind::CycleDone);
            }
            self.sequencer.stopping = false;
            self.enter(State::Idle);
        }
    }

    // The fault reaction.

    /// Starts the fault reaction.
    pub(super) fn seq_on_fault(&mut self, f: Fault) {
        let state = self.sequencer.state;
        self.sequencer.hold = false;
        if state.in_cycle() {
            self.note_interrupted();
        }
        match f {
            Fault::FeedbackLost { axis } | Fault::PositionLost { axis } => self.position_lost(axis),
            _ => {}
        }
        if state == State::Referencing {
            self.referencing.abandon();
        }
        self.sequencer.jog.motion = JogMotion::None;
        if matches!(
            state,
            State::Init | State::Idle | State::Jog | State::Faulted | State::Referencing
        ) {
            self.sequencer.spindle_set_rpm = 0.0;
            self.enter(State::Faulted);
            return;
        }
        if !f.table_can_follow() {
            // The table cannot follow: stop the spindle at once, pull out if X can.
            self.sequencer.spindle_set_rpm = 0.0;
            self.gearbox.disengage();
        }
        if (state.tool_in_work() || state == State::Infeed) && f.x_can_move() {
            self.enter(State::FaultRetract);
        } else {
            self.enter(State::FaultStop);
        }
    }

    /// A cycle is being broken off: remember the pass for "continue".
    pub(super) fn note_interrupted(&mut self) {
        if self.program.is_some() {
            self.sequencer.interrupted = Some((self.sequencer.pass_index, self.sequencer.single));
        }
    }

    /// A drive lost its position: X or Y its reference; the table the tooth phase.
    pub(super) fn position_lost(&mut self, axis: Axis) {
        if axis == Axis::B {
            // Touches noted before are in the table's old frame.
            self.sequencer.flank_touch = [None; 2];
            if self.gearbox.recorded_phase_deg().is_some() {
                self.sequencer.phase_lost =
                    self.sequencer.interrupted.is_some() || self.sequencer.state.in_cycle();
                self.gearbox.new_blank();
            }
        } else {
            self.referencing.lose(axis);
        }
    }

    /// X out of the work with the gearbox engaged, Y braked.
    fn sequence_fault_retract(&mut self, program: &CycleProgram) {
        let dt = self.params.period_s;
        let rapid_x = self.params.x_limits.rapid_mm_s;
        self.sequencer.clamp = false;
        self.sequencer.feed_scale = 0.0;
        self.y.step_stop(self.params.y_limits.accel_mm_s2, dt);
        let unclamped =
            !self.measured.inputs.x_clamp_closed || self.sequencer.state_time_s > self.params.clamp_timeout_s;
        // Out when the slide is at the safe position, not when its command is: the
        // gearbox stays engaged until the hob has left the work.
        if unclamped
            && self
                .x
                .step_towards(program.x_safe_mm, rapid_x, self.params.x_limits.accel_mm_s2, dt)
        {
            let out = (self.measured.x_mm - program.x_safe_mm).abs() <= RETRACTED_WITHIN_MM;
            let since = *self
                .sequencer
                .retract_commanded_s
                .get_or_insert(self.sequencer.state_time_s);
            if out || self.sequencer.state_time_s - since > RETRACT_SETTLE_TIMEOUT_S {
                self.enter(State::FaultStop);
            }
        }
    }

    /// X and Y braked, the gearbox out, the spindle down; then the drives off (state
    /// `Faulted`).
    fn sequence_fault_stop(&mut self) {
        let dt = self.params.period_s;
        self.sequencer.clamp = false;
        self.sequencer.spindle_set_rpm = 0.0;
        self.x.step_stop(self.params.x_limits.accel_mm_s2, dt);
        self.y.step_stop(self.params.y_limits.accel_mm_s2, dt);
        self.gearbox.disengage();
        let stopped = self.gearbox.coupling() == Coupling::Disengaged && self.spindle_stopped();
        if stopped || self.sequencer.state_time_s > STOP_TIMEOUT_S {
            self.enter(State::Faulted);
        }
    }

    // Outside a cycle.

    /// Outside a cycle: follow the actual positions when the drives are off, run jogs.
    fn sequence_idle(&mut self) {
        match self.sequencer.state {
            State::Init | State::Faulted => {
                self.sequencer.clamp = false;
                self.sequencer.spindle_set_rpm = 0.0;
                if !self.sequencer.drives_should_be_enabled() {
                    // Drives are off: the commands follow the machine, so enabling never
                    // jumps. Once they are being enabled the commands hold still.
                    self.x = Profile::at(self.measured.x_mm);
                    self.y = Profile::at(self.measured.y_mm);
                    let table = self.measured.table_deg;
                    let g = *self.gearbox.params();
                    let recorded = self.gearbox.recorded_phase_deg();
                    self.gearbox = super::egb::Gearbox::new(g, table);
                    if let Some(r) = recorded {
                        self.gearbox.restore_recorded_phase(r);
                    }
                }
                self.sequencer.init_ready = self.sequencer.state == State::Init
                    && self.measured.inputs.safety_chain_closed
                    && self.lube.cycles_done() > 0
                    && self.fault.is_none();
                if self.sequencer.init_ready && self.drives_ready() {
                    self.enter(State::Idle);
                }
            }
            _ => {}
        }
    }

    /// One cycle of the jog under way (module `jog`).
    fn sequence_jog(&mut self) {
        let cycle = JogCycle {
            period_s: self.params.period_s,
            now_s: self.now_s(),
            deadman_s: self.params.deadman_s,
            table_moving: self.gearbox.table_moving(),
            x: self.jog_axis(Axis::X),
            y: self.jog_axis(Axis::Y),
        };
        let step = self.sequencer.jog.step(&cycle, &mut self.x, &mut self.y);
        if let Some(axis) = step.dead_man {
            self.event(EventKind::DeadManStop { axis });
        }
        if let Some(deg) = step.table_by {
            self.gearbox.move_table_by(deg);
        }
        if step.done {
            self.enter(State::Idle);
        }
    }

    /// One cycle of a held spindle (module `jog`): stopped by its dead-man.
    fn sequence_spindle_hold(&mut self) {
        let now_s = self.now_s();
        if self
            .sequencer
            .jog
            .spindle_dead_man(self.sequencer.state, now_s, self.params.deadman_s)
        {
            self.sequencer.spindle_set_rpm = 0.0;
            self.event(EventKind::SpindleDeadManStop);
        }
    }

    /// One cycle of referencing (module `referencing`): the command of the axis under way
    /// follows its drive, and what came of the cycle is acted on.
    fn sequence_referencing(&mut self) {
        let input = HomingInputs {
            period_s: self.params.period_s,
            feedback: self.measured.feedback,
            x_timeout_s: self.params.x_homing_timeout_s,
            y_timeout_s: self.params.y_homing_timeout_s,
        };
        let progress = self.referencing.step(&input);
        if let Some(axis) = progress.axis() {
            // The drive moves by itself: the command follows it.
            self.follow_measured(axis);
        }
        match progress {
            Progress::Finished | Progress::Stopped(_) => self.enter(State::Idle),
            Progress::Running(_) => {}
            Progress::Referenced(axis) => self.event(EventKind::Referenced { axis }),
            Progress::Failed(axis, why) => self.raise(Fault::HomingFailed { axis, why }),
        }
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

    // Helpers: the state's change, the pass, the moves, the spindle, the jog's view.

    pub(super) fn enter(&mut self, to: State) {
        let from = self.sequencer.state;
        if from != to {
            self.sequencer.state = to;
            self.sequencer.state_time_s = 0.0;
            self.sequencer.retract_commanded_s = None;
            self.event(EventKind::StateChanged { from, to });
        }
    }

    /// Out of the cut: unclamp X first if it was clamped.
    pub(super) fn leave_cut(&mut self) {
        let moves_x = self.program.is_some_and(|p| p.shape.moves_x());
        self.enter(if moves_x { State::Retract } else { State::Unclamp });
    }

    /// Into the cut: X clamped first unless it moves in the cut (crowning, contour).
    fn enter_cut_or_clamp(&mut self, program: &CycleProgram) {
        self.sequencer.feed_scale = 0.0;
        self.enter(if program.shape.moves_x() {
            State::Cut
        } else {
            State::Clamp
        });
    }

    fn next_pass(&mut self) {
        if self.sequencer.pass_index + 1 < self.pass_count() && !self.sequencer.stopping {
            self.sequencer.pass_index += 1;
            self.enter(State::ToStart);
        } else {
            self.enter(State::Home);
        }
    }

    fn current_pass(&self) -> Option<PassSetpoint> {
        let program = self.program?;
        if self.sequencer.single {
            program.single()
        } else {
            program.passes().get(self.sequencer.pass_index).copied()
        }
    }

    fn pass_count(&self) -> usize {
        match self.program {
            Some(_) if self.sequencer.single => 1,
            Some(p) => p.passes().len(),
            None => 0,
        }
    }

    /// The spindle speed of a pass under the spindle override, within the machine.
    fn pass_spindle_rpm(&self, program: &CycleProgram, pass: &PassSetpoint) -> f64 {
        setup_math::overridden_spindle_rpm(
            pass.spindle_rpm,
            self.spindle_override,
            self.params.spindle_max_rpm,
            program.ratio_signed,
            self.params.table_max_deg_s,
        )
    }

    /// X for the current Y in the cut: pass depth plus crowning/contour.
    fn x_in_cut(&self, program: &CycleProgram, pass: &PassSetpoint) -> f64 {
        pass.x_mm
            + program
                .shape
                .x_offset_mm(self.y.position - program.face_bottom_mm)
    }

    /// Steps X towards `target` at rapid (or `speed`), pausing on feed hold.
    fn move_x(&mut self, target: f64, speed_mm_s: f64) -> bool {
        let l = self.params.x_limits;
        if self.sequencer.hold {
            self.x.step_stop(l.accel_mm_s2, self.params.period_s);
            return false;
        }
        self.x
            .step_towards(target, speed_mm_s, l.accel_mm_s2, self.params.period_s)
    }

    /// Steps Y towards `target` at rapid, slower while the gearbox couples the table to
    /// Y (the differential must not drive the table beyond its speed).
    fn move_y(&mut self, target: f64) -> bool {
        let l = self.params.y_limits;
        if self.sequencer.hold {
            self.y.step_stop(l.accel_mm_s2, self.params.period_s);
            return false;
        }
        let g = self.gearbox.params();
        let mut speed = l.rapid_mm_s;
        let d = g.differential_signed_deg_per_mm.abs();
        if d > 0.0 && self.gearbox.coupling() != Coupling::Disengaged {
            let base = (g.ratio_signed * self.measured.spindle_speed_deg_s).abs();
            let spare = (0.9 * self.params.table_max_deg_s - base).max(0.0);
            speed = speed.min(spare / d).max(0.1);
        }
        self.y
            .step_towards(target, speed, l.accel_mm_s2, self.params.period_s)
    }

    fn spindle_at_speed(&self) -> bool {
        self.spindle_at_speed_s >= super::SPINDLE_SETTLE_S
    }

    fn spindle_stopped(&self) -> bool {
        (self.measured.spindle_speed_deg_s / 6.0).abs() < SPINDLE_STOPPED_RPM
    }

    /// The loop's time, s.
    pub(super) fn now_s(&self) -> f64 {
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

    /// An axis as a jog sees it (module `jog`).
    fn jog_axis(&self, axis: Axis) -> JogAxis {
        JogAxis {
            limits: self.work_limits(axis),
            max_speed_per_s: match axis {
                Axis::B => self.params.gearbox.phase_speed_deg_s,
                _ => self.jog_speed_mm_s(axis),
            },
            accel: match axis {
                Axis::X => self.params.x_limits.accel_mm_s2,
                Axis::Y => self.params.y_limits.accel_mm_s2,
                Axis::B => self.params.table_accel_deg_s2,
            },
        }
    }

    /// The machine as a jog command for `axis` sees it (module `jog`).
    pub(super) fn jog_context(&self, axis: Axis) -> JogContext {
        JogContext {
            state: self.sequencer.state,
            drives_ready: self.drives_ready(),
            now_s: self.now_s(),
            x_mm: self.x.position,
            y_mm: self.y.position,
            axis: self.jog_axis(axis),
        }
    }
}
