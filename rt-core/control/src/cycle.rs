//! The cycle's steps, one control cycle each: the three cycles of docs/domain.md section 5
//! with all their steps, rough and finishing passes, single mode, feed hold, cycle stop,
//! return to start; and outside a cycle, power-up to idle. One function per state, in the
//! order of the cycle: the approach, the work, out of the work, the end or stop. They are
//! the sequencer's (module `sequencer`), and read and move only what it is given.

use super::command::State;
use super::egb::{Coupling, Gearbox};
use super::events::EventKind;
use super::fault::Fault;
use super::profile::Profile;
use super::program::{CycleProgram, PassSetpoint};
use super::sequencer::{Motion, SeqInputs, Sequencer};
use super::setup_math;
use hob_setup::job::CycleKind;

/// Feed ramp time in and out of the cut (feed hold, resume).
const FEED_RAMP_S: f64 = 0.2;
/// Time the gearbox may take to synchronise before it is a fault.
const SYNC_TIMEOUT_S: f64 = 20.0;
/// X rapids this far outside the blank before the radial plunge at feed.
const PLUNGE_CLEARANCE_MM: f64 = 1.0;
/// Fastest change of the spindle speed by its override with the tool in the work (rpm/s,
/// 60 deg/s^2 of spindle). The VFD's own ramp (80 Hz in 3 s: 83 rpm/s at the spindle)
/// jerks the spindle observer and the table by about 13 arcsec, above the cut's bound (a
/// quarter of ISO 1328-1 grade 5: 8.6 arcsec at z = 17, m = 5); the jerk's error scales
/// with the acceleration, so at 10 rpm/s it adds under 2 arcsec
/// (`bench/plant/tests/setup_ops.rs`).
const OVERRIDE_SPINDLE_RPM_S: f64 = 10.0;

impl Sequencer {
    /// A step of the cycle under way (or of the fault reaction's retract), with the
    /// program and the pass it runs: one function per state, in the cycle's order.
    pub(super) fn step_cycle(
        &mut self,
        state: State,
        i: &SeqInputs,
        program: Option<&CycleProgram>,
        m: &mut Motion,
    ) -> Option<Fault> {
        let Some((program, pass)) = program.and_then(|p| Some((p, self.current_pass(p)?))) else {
            // A cycle state without a program cannot happen (loading is refused in a
            // cycle); stop safely if it ever does.
            self.stopping = true;
            self.enter(State::Disengage, &mut m.events);
            return None;
        };
        self.ramp_spindle_override(state, i, program, &pass);
        match state {
            // The approach.
            State::ToSafe => self.step_to_safe(i, program, m),
            State::ToStart => self.step_to_start(i, &pass, m),
            State::SpindleUp => return self.step_spindle_up(i, program, &pass, m),
            State::Engage => return self.step_engage(m),
            // In the work.
            State::Infeed => self.step_infeed(i, program, &pass, m),
            State::Plunge => self.step_plunge(i, program, &pass, m),
            State::ExtraRev => self.step_extra_rev(i, program, m),
            State::Clamp => return self.step_clamp(i, m),
            State::Cut => self.step_cut(i, program, &pass, m),
            State::Unclamp => return self.step_unclamp(i, m),
            // Out of the work, tooth by tooth the next tooth, at the end Y back.
            State::Retract => self.step_retract(i, program, m),
            State::Return => self.step_return(i, program, &pass, m),
            State::Index => self.step_index(program, m),
            State::Home => self.step_home(i, program, &pass, m),
            // The fault reaction's retract (module `fault_reaction`).
            State::FaultRetract => self.step_fault_retract(i, program, m),
            State::Init | State::Idle | State::Jog | State::Faulted | State::Referencing => {}
            State::Disengage | State::SpindleDown | State::FaultStop => {}
        }
        None
    }

    /// The spindle override acts on a running spindle; the table follows the measured
    /// spindle and the feed its revolutions, so the law holds. With the tool in the
    /// work the change is ramped (OVERRIDE_SPINDLE_RPM_S): at the VFD's own ramp the
    /// jerk throws the table off the law by more than the cut's error bound.
    fn ramp_spindle_override(
        &mut self,
        state: State,
        i: &SeqInputs,
        program: &CycleProgram,
        pass: &PassSetpoint,
    ) {
        if self.spindle_set_rpm > 0.0 && !matches!(state, State::ToSafe | State::FaultRetract) {
            let target = Self::pass_spindle_rpm(i, program, pass);
            let set = self.spindle_set_rpm;
            self.spindle_set_rpm = if state.tool_in_work() {
                let step = OVERRIDE_SPINDLE_RPM_S * i.period_s;
                set + (target - set).clamp(-step, step)
            } else {
                target
            };
        }
    }

    // The approach.

    /// X out to the safe position at rapid.
    fn step_to_safe(&mut self, i: &SeqInputs, program: &CycleProgram, m: &mut Motion) {
        self.clamp = false;
        if self.move_x(program.x_safe_mm, i.x_limits.rapid_mm_s, i, m) {
            self.enter(State::ToStart, &mut m.events);
        }
    }

    /// Y to the pass's start, or to where "continue" re-enters its cut.
    fn step_to_start(&mut self, i: &SeqInputs, pass: &PassSetpoint, m: &mut Motion) {
        if self.move_y(self.resume_y_mm.unwrap_or(pass.y_start_mm), i, m) {
            self.enter(State::SpindleUp, &mut m.events);
        }
    }

    /// The spindle up to the pass's speed (not while held).
    fn step_spindle_up(
        &mut self,
        i: &SeqInputs,
        program: &CycleProgram,
        pass: &PassSetpoint,
        m: &mut Motion,
    ) -> Option<Fault> {
        if self.hold {
            return None;
        }
        self.spindle_set_rpm = Self::pass_spindle_rpm(i, program, pass);
        if i.spindle_at_speed {
            m.events.push(EventKind::PassStarted {
                pass: self.pass_index as u32 + 1,
            });
            self.enter(State::Engage, &mut m.events);
        } else if self.state_time_s > i.spindle_start_timeout_s {
            let actual_rpm = i.spindle_speed_deg_s.abs() / 6.0;
            return Some(Fault::SpindleSpeed {
                set_rpm: pass.spindle_rpm,
                actual_rpm,
            });
        }
        None
    }

    /// The gearbox in: synchronised within its window (the first time on a blank, its
    /// tooth phase is recorded).
    fn step_engage(&mut self, m: &mut Motion) -> Option<Fault> {
        let recorded_before = m.gearbox.recorded_phase_deg();
        m.gearbox.engage();
        if recorded_before.is_none()
            && let Some(phase_deg) = m.gearbox.recorded_phase_deg()
        {
            m.events.push(EventKind::PhaseRecorded { phase_deg });
        }
        if m.gearbox.ready_to_cut() && !self.hold {
            self.enter(State::Infeed, &mut m.events);
        } else if self.state_time_s > SYNC_TIMEOUT_S {
            let error_arcsec = m.gearbox.status().error_deg * 3600.0;
            return Some(Fault::SyncLost { error_arcsec });
        }
        None
    }

    // In the work.

    /// X in to the pass's depth at rapid (radial plunge: to just outside the blank;
    /// re-entering an interrupted cut: to just outside the pass's depth).
    fn step_infeed(&mut self, i: &SeqInputs, program: &CycleProgram, pass: &PassSetpoint, m: &mut Motion) {
        let plunge = program.cycle == CycleKind::RadialPlunge;
        let re_entry = self.resume_y_mm.is_some();
        let target = if plunge {
            program.x_surface_mm + PLUNGE_CLEARANCE_MM
        } else if re_entry {
            Self::x_in_cut(program, pass, m.y.position) + setup_math::RE_ENTRY_CLEARANCE_MM
        } else {
            Self::x_in_cut(program, pass, m.y.position)
        };
        if self.move_x(target, i.x_limits.rapid_mm_s, i, m) {
            self.rev_start_deg = i.spindle_deg;
            if plunge || re_entry {
                self.enter(State::Plunge, &mut m.events);
            } else {
                self.enter_cut_or_clamp(program, &mut m.events);
            }
        }
    }

    /// X in to the pass's depth at feed: the radial plunge's (then one more turn of the
    /// table), or re-entering an interrupted cut the pass's own feed (then the cut).
    fn step_plunge(&mut self, i: &SeqInputs, program: &CycleProgram, pass: &PassSetpoint, m: &mut Motion) {
        let target = Self::x_in_cut(program, pass, m.y.position);
        let plunge = program.cycle == CycleKind::RadialPlunge;
        let feed_mm_s = if plunge {
            program.plunge_feed_mm_min / 60.0 * i.feed_override
        } else {
            pass.axial_feed_mm_s() * i.feed_override
        };
        if self.move_x(target, feed_mm_s, i, m) {
            self.rev_start_deg = i.spindle_deg;
            if plunge {
                self.enter(State::ExtraRev, &mut m.events);
            } else {
                self.enter_cut_or_clamp(program, &mut m.events);
            }
        }
    }

    /// Radial plunge: one more turn of the table at depth before the feed.
    fn step_extra_rev(&mut self, i: &SeqInputs, program: &CycleProgram, m: &mut Motion) {
        let table_turn = (program.ratio_signed * (i.spindle_deg - self.rev_start_deg)).abs();
        if table_turn >= 360.0 {
            self.enter_cut_or_clamp(program, &mut m.events);
        }
    }

    /// X clamped before the cut.
    fn step_clamp(&mut self, i: &SeqInputs, m: &mut Motion) -> Option<Fault> {
        self.clamp = true;
        if i.inputs.x_clamp_closed {
            self.feed_scale = 0.0;
            self.enter(State::Cut, &mut m.events);
        } else if self.state_time_s > i.clamp_timeout_s {
            return Some(Fault::ClampTimeout);
        }
        None
    }

    /// The cut: Y fed with the spindle's turning (ramped in and out by feed hold), X
    /// following the shape; at the pass's end out of the cut.
    fn step_cut(&mut self, i: &SeqInputs, program: &CycleProgram, pass: &PassSetpoint, m: &mut Motion) {
        let dt = i.period_s;
        let want = if self.hold { 0.0 } else { i.feed_override };
        let ramp = dt / FEED_RAMP_S;
        self.feed_scale += (want - self.feed_scale).clamp(-ramp, ramp);
        // Y is tied to the spindle: it advances with the spindle's turning, never with time.
        let spindle_delta =
            program.spindle_sign * (i.spindle_for_gearbox_deg - i.last_spindle_for_gearbox_deg);
        let dy = program.feed_sign * pass.feed_mm_per_spindle_deg * spindle_delta.max(0.0) * self.feed_scale;
        let before = m.y.position;
        let mut y = before + dy;
        let done = (pass.y_end_mm - y) * program.feed_sign <= 0.0;
        if done {
            y = pass.y_end_mm;
        }
        m.y.position = y;
        m.y.velocity = (y - before) / dt;
        let x = Self::x_in_cut(program, pass, m.y.position);
        m.x.velocity = (x - m.x.position) / dt;
        m.x.position = x;
        if done {
            m.y.velocity = 0.0;
            m.x.velocity = 0.0;
            self.leave_cut(Some(program), &mut m.events);
        }
    }

    /// X unclamped after the cut.
    fn step_unclamp(&mut self, i: &SeqInputs, m: &mut Motion) -> Option<Fault> {
        self.clamp = false;
        if !i.inputs.x_clamp_closed {
            self.enter(State::Retract, &mut m.events);
        } else if self.state_time_s > i.clamp_timeout_s {
            return Some(Fault::ClampTimeout);
        }
        None
    }

    // Out of the work.

    /// X out to the safe position; then the next pass, the next tooth or the stop.
    fn step_retract(&mut self, i: &SeqInputs, program: &CycleProgram, m: &mut Motion) {
        if self.move_x(program.x_safe_mm, i.x_limits.rapid_mm_s, i, m) {
            if self.stopping {
                self.enter(State::Disengage, &mut m.events);
            } else if program.cycle == CycleKind::ToothByTooth {
                self.enter(State::Return, &mut m.events);
            } else {
                self.next_pass(program, &mut m.events);
            }
        }
    }

    /// Tooth by tooth: Y back to the start, then the table on by a pitch.
    fn step_return(&mut self, i: &SeqInputs, program: &CycleProgram, pass: &PassSetpoint, m: &mut Motion) {
        if self.move_y(pass.y_start_mm, i, m) {
            m.gearbox.move_table_by(program.pitch_deg());
            self.enter(State::Index, &mut m.events);
        }
    }

    /// Tooth by tooth: the table's index to the next tooth.
    fn step_index(&mut self, program: &CycleProgram, m: &mut Motion) {
        if !m.gearbox.table_moving() {
            self.tooth += 1;
            if self.tooth < program.teeth {
                self.enter(State::Infeed, &mut m.events);
            } else {
                self.tooth = 0;
                self.next_pass(program, &mut m.events);
            }
        }
    }

    /// At the end: Y back to the start of the program (single mode: of its pass).
    fn step_home(&mut self, i: &SeqInputs, program: &CycleProgram, pass: &PassSetpoint, m: &mut Motion) {
        let start = if self.single {
            pass.y_start_mm
        } else {
            program.passes()[0].y_start_mm
        };
        if self.move_y(start, i, m) {
            self.enter(State::Disengage, &mut m.events);
        }
    }

    // The end of the cycle, or its stop.

    /// X and Y braked, the gearbox out.
    pub(super) fn step_disengage(&mut self, i: &SeqInputs, m: &mut Motion) {
        self.clamp = false;
        m.x.step_stop(i.x_limits.accel_mm_s2, i.period_s);
        m.y.step_stop(i.y_limits.accel_mm_s2, i.period_s);
        m.gearbox.disengage();
        if m.gearbox.coupling() == Coupling::Disengaged && !m.gearbox.table_moving() {
            self.enter(State::SpindleDown, &mut m.events);
        }
    }

    /// The spindle down; then idle (the cycle done, unless it was stopped).
    pub(super) fn step_spindle_down(&mut self, i: &SeqInputs, m: &mut Motion) {
        self.spindle_set_rpm = 0.0;
        if i.spindle_stopped() {
            if !self.stopping {
                self.interrupted = None;
                m.events.push(EventKind::CycleDone);
            }
            self.stopping = false;
            self.enter(State::Idle, &mut m.events);
        }
    }

    // Outside a cycle.

    /// Power-up, idle and after a fault: the commands follow the actual positions while
    /// the drives are off; power-up ends in idle once the conditions are met and the
    /// drives are enabled.
    pub(super) fn step_idle(&mut self, i: &SeqInputs, m: &mut Motion) {
        if !matches!(self.state, State::Init | State::Faulted) {
            return;
        }
        self.clamp = false;
        self.spindle_set_rpm = 0.0;
        if !self.drives_should_be_enabled() {
            // Drives are off: the commands follow the machine, so enabling never jumps.
            // Once they are being enabled the commands hold still.
            *m.x = Profile::at(i.x_mm);
            *m.y = Profile::at(i.y_mm);
            let g = *m.gearbox.params();
            let recorded = m.gearbox.recorded_phase_deg();
            *m.gearbox = Gearbox::new(g, i.table_deg);
            if let Some(r) = recorded {
                m.gearbox.restore_recorded_phase(r);
            }
        }
        self.init_ready =
            self.state == State::Init && i.inputs.safety_chain_closed && i.lubricated && !i.fault_latched;
        if self.init_ready && i.drives_ready {
            self.enter(State::Idle, &mut m.events);
        }
    }
}
