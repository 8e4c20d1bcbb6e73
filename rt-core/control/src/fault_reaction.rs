//! The fault reaction, the sequencer's part of a fault: retract X first with the gearbox
//! engaged, then stop, then the drives off (state `Faulted`, where the controller drops
//! the PC-OK relay). [`Sequencer::on_fault`] starts it from whatever state the fault met;
//! its two states' steps run a cycle each. Its own state is the sequencer's
//! `retract_commanded_s`; what it reads and moves is the sequencer's (module `sequencer`).

use super::command::State;
use super::egb::{Coupling, Gearbox};
use super::events::Stamped;
use super::fault::{Axis, Fault};
use super::jog::JogMotion;
use super::program::CycleProgram;
use super::sequencer::{Motion, SeqInputs, Sequencer};

/// Time the stop may take before the drives are disabled anyway.
const STOP_TIMEOUT_S: f64 = 15.0;
/// In the fault reaction X is out when its measured position is this close to the safe
/// position (the command there is not enough: the slide may not have followed).
const RETRACTED_WITHIN_MM: f64 = 0.02;
/// Time the slide may take to settle at the safe position after its command got there;
/// then the stop goes on anyway (a slide that cannot move is not waited for).
const RETRACT_SETTLE_TIMEOUT_S: f64 = 2.0;

impl Sequencer {
    /// Starts the fault reaction (the controller has noted a cycle under way for
    /// "continue"): a lost table position forgets the tooth phase, a jog stops; outside a cycle straight to
    /// `Faulted`; in the work X out first if it can move, else the stop. (X's and Y's lost
    /// references, and referencing broken off, are the controller's to tell the
    /// referencing.)
    pub fn on_fault(&mut self, f: Fault, gearbox: &mut Gearbox, events: &mut Stamped) {
        let state = self.state;
        self.fault_met = state;
        self.hold = false;
        if let Fault::FeedbackLost { axis: Axis::B } | Fault::PositionLost { axis: Axis::B } = f {
            self.table_position_lost(gearbox);
        }
        self.jog.motion = JogMotion::None;
        if matches!(
            state,
            State::Init | State::Idle | State::Jog | State::Faulted | State::Referencing
        ) {
            self.spindle_set_rpm = 0.0;
            self.enter(State::Faulted, events);
            return;
        }
        if !f.table_can_follow() {
            // The table cannot follow: stop the spindle at once, pull out if X can.
            self.spindle_set_rpm = 0.0;
            gearbox.disengage();
        }
        if (state.tool_in_work() || state == State::Infeed) && f.x_can_move() {
            self.enter(State::FaultRetract, events);
        } else {
            self.enter(State::FaultStop, events);
        }
    }

    /// The table's drive lost its position: the touches noted before are in the table's
    /// old frame, and the tooth phase recorded is lost.
    pub fn table_position_lost(&mut self, gearbox: &mut Gearbox) {
        self.flank_touch = [None; 2];
        if gearbox.recorded_phase_deg().is_some() {
            self.phase_lost = self.interrupted.is_some() || self.state.in_cycle();
            gearbox.new_blank();
        }
    }

    /// X out of the work with the gearbox engaged, Y braked.
    pub(super) fn step_fault_retract(&mut self, i: &SeqInputs, program: &CycleProgram, m: &mut Motion) {
        let dt = i.period_s;
        self.clamp = false;
        self.feed_scale = 0.0;
        m.y.step_stop(i.y_limits.accel_mm_s2, dt);
        let unclamped = !i.inputs.x_clamp_closed || self.state_time_s > i.clamp_timeout_s;
        // Out when the slide is at the safe position, not when its command is: the
        // gearbox stays engaged until the hob has left the work.
        if unclamped
            && m.x.step_towards(
                program.x_safe_mm,
                i.x_limits.rapid_mm_s,
                i.x_limits.accel_mm_s2,
                dt,
            )
        {
            let out = (i.x_mm - program.x_safe_mm).abs() <= RETRACTED_WITHIN_MM;
            let since = *self.retract_commanded_s.get_or_insert(self.state_time_s);
            if out || self.state_time_s - since > RETRACT_SETTLE_TIMEOUT_S {
                self.enter(State::FaultStop, &mut m.events);
            }
        }
    }

    /// X and Y braked, the gearbox out, the spindle down; then the drives off (state
    /// `Faulted`).
    pub(super) fn step_fault_stop(&mut self, i: &SeqInputs, m: &mut Motion) {
        let dt = i.period_s;
        self.clamp = false;
        self.spindle_set_rpm = 0.0;
        m.x.step_stop(i.x_limits.accel_mm_s2, dt);
        m.y.step_stop(i.y_limits.accel_mm_s2, dt);
        m.gearbox.disengage();
        let stopped = m.gearbox.coupling() == Coupling::Disengaged && i.spindle_stopped();
        if stopped || self.state_time_s > STOP_TIMEOUT_S {
            self.enter(State::Faulted, &mut m.events);
        }
    }
}
