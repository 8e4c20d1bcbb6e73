//! The cycle sequencer, a machine of its own: the state of the cycle (its pass, tooth,
//! hold, stop), the peripherals it sets (coolant, X clamp, spindle speed), the jog under
//! way, what "continue" needs, and what the loop asks of it (drives enabled, PC-OK relay).
//!
//! It takes what it reads as one copied value ([`SeqInputs`]) and moves what it commands
//! ([`Motion`]: X's and Y's commands, the gearbox, the events it writes); what it cannot
//! do itself it hands back ([`Next`]: a fault to raise, a cycle of jog or referencing,
//! which are machines of their own). [`Sequencer::step`] runs what every state shares,
//! then one function per state: the cycle's steps (module `cycle`) in the order of the
//! cycle, the fault reaction's (module `fault_reaction`). The controller composes it with
//! the other machines (module `sequencing`).

use super::command::State;
use super::egb::{Coupling, Gearbox};
use super::events::{EventKind, Stamped};
use super::fault::Fault;
use super::io::Inputs;
use super::jog::Jog;
use super::profile::{LinearLimits, Profile};
use super::program::{CycleProgram, PassSetpoint};
use super::setup_math;

/// Below this the spindle counts as stopped.
const SPINDLE_STOPPED_RPM: f64 = 1.0;

/// The sequencer's own state.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub(super) struct Sequencer {
    pub state: State,
    pub state_time_s: f64,
    pub hold: bool,
    pub stopping: bool,
    pub single: bool,
    pub pass_index: usize,
    pub tooth: u32,
    pub spindle_set_rpm: f64,
    pub coolant: bool,
    pub clamp: bool,
    pub feed_scale: f64,
    pub rev_start_deg: f64,
    /// The operator's jog under way and held spindle.
    pub jog: Jog,
    /// The pass a fault or a stop interrupted, for "continue".
    pub interrupted: Option<Interrupted>,
    /// The Y where this run of the pass enters its cut, when it re-enters an interrupted
    /// one ("continue"); none: at the pass's start.
    pub resume_y_mm: Option<f64>,
    /// The table lost its position after the tooth phase of an interrupted part was
    /// recorded: "continue" is refused until a new start or a new blank.
    pub phase_lost: bool,
    /// The tooth phase noted at each flank touch (table turned negative, positive).
    pub flank_touch: [Option<f64>; 2],
    /// Power-up conditions met (chain closed, lubricated, no fault): enable the drives.
    pub init_ready: bool,
    /// The state the latched fault met (what its reaction did follows from it).
    pub fault_met: State,
    /// In the fault reaction's retract: when X's command reached the safe position
    /// (state time, s); cleared on every change of state.
    pub retract_commanded_s: Option<f64>,
}

/// A pass a fault or a stop broke off: where "continue" takes it up.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub(super) struct Interrupted {
    pub pass_index: usize,
    pub single: bool,
    /// The Y where its cut is re-entered (module `setup_math`, `resume_y_mm`); none: at
    /// the pass's start (it was broken off before its cut, or it is tooth by tooth).
    pub from_y_mm: Option<f64>,
}

/// What the sequencer reads in one cycle, copied: the machine's settings it needs, the
/// overrides, and what was measured.
#[derive(Debug, Clone, Copy)]
pub(super) struct SeqInputs {
    pub period_s: f64,
    /// The loop's time, s.
    pub now_s: f64,
    pub deadman_s: f64,
    pub x_limits: LinearLimits,
    pub y_limits: LinearLimits,
    pub table_max_deg_s: f64,
    pub spindle_max_rpm: f64,
    pub spindle_start_timeout_s: f64,
    pub clamp_timeout_s: f64,
    /// Overrides as fractions (1.0 = 100 %).
    pub feed_override: f64,
    pub spindle_override: f64,
    pub spindle_deg: f64,
    pub spindle_speed_deg_s: f64,
    /// The angle the gearbox follows, this cycle and the last.
    pub spindle_for_gearbox_deg: f64,
    pub last_spindle_for_gearbox_deg: f64,
    /// The spindle has held its set speed long enough to engage.
    pub spindle_at_speed: bool,
    pub table_deg: f64,
    pub x_mm: f64,
    pub y_mm: f64,
    pub inputs: Inputs,
    /// The first lubrication since power-up is done.
    pub lubricated: bool,
    pub fault_latched: bool,
    /// Every drive reports "operation enabled".
    pub drives_ready: bool,
}

impl SeqInputs {
    pub fn spindle_stopped(&self) -> bool {
        (self.spindle_speed_deg_s / 6.0).abs() < SPINDLE_STOPPED_RPM
    }
}

/// What the sequencer moves: X's and Y's commands, the gearbox, and the events it writes.
pub(super) struct Motion<'a> {
    pub x: &'a mut Profile,
    pub y: &'a mut Profile,
    pub gearbox: &'a mut Gearbox,
    pub events: Stamped<'a>,
}

/// What a cycle of the sequencer leaves to the controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Next {
    Done,
    /// Raise this fault (its reaction is [`Sequencer::on_fault`]).
    Fault(Fault),
    /// Run a cycle of the jog under way (module `jog`).
    Jog,
    /// Run a cycle of referencing (module `referencing`).
    Referencing,
}

impl From<Option<Fault>> for Next {
    fn from(f: Option<Fault>) -> Self {
        f.map_or(Next::Done, Next::Fault)
    }
}

impl Sequencer {
    pub fn pass_number(&self) -> u32 {
        if self.state.in_cycle() {
            self.pass_index as u32 + 1
        } else {
            0
        }
    }

    /// Drives are asked to be enabled once power-up is through (safety chain closed,
    /// first lubrication done) and until the fault reaction has stopped the machine.
    pub fn drives_should_be_enabled(&self) -> bool {
        match self.state {
            State::Faulted => false,
            State::Init => self.init_ready,
            _ => true,
        }
    }

    /// The fault reaction (retract, stop) runs: a stop of category 1 (IEC 60204-1), the
    /// drives keep following while they have power, even with the safety chain open.
    pub fn in_fault_reaction(&self) -> bool {
        matches!(self.state, State::FaultRetract | State::FaultStop)
    }

    pub fn pc_ok(&self, fault: Option<Fault>) -> bool {
        // Dropped once the fault reaction has stopped the machine.
        !(fault.is_some() && self.state == State::Faulted)
    }

    /// One cycle: what every state shares (the state's time, a held spindle, the coolant,
    /// the gearbox's window with the tool in the work), then the state's step.
    pub fn step(&mut self, i: &SeqInputs, program: Option<&CycleProgram>, m: &mut Motion) -> Next {
        self.state_time_s += i.period_s;
        if self.jog.spindle_dead_man(self.state, i.now_s, i.deadman_s) {
            self.spindle_set_rpm = 0.0;
            m.events.push(EventKind::SpindleDeadManStop);
        }
        let state = self.state;
        self.coolant = matches!(
            state,
            State::Infeed
                | State::Plunge
                | State::ExtraRev
                | State::Clamp
                | State::Cut
                | State::Unclamp
                | State::Retract
        ) && self.spindle_set_rpm > 0.0;
        let status = m.gearbox.status();
        if state.tool_in_work() && m.gearbox.coupling() == Coupling::Synchronised && !status.in_coarse_window
        {
            return Next::Fault(Fault::SyncLost {
                error_arcsec: status.error_deg * 3600.0,
            });
        }
        match state {
            State::Init | State::Idle | State::Faulted => {
                self.step_idle(i, m);
                Next::Done
            }
            State::Jog => Next::Jog,
            State::Referencing => Next::Referencing,
            State::Disengage => {
                self.step_disengage(i, m);
                Next::Done
            }
            State::SpindleDown => {
                self.step_spindle_down(i, m);
                Next::Done
            }
            State::FaultStop => {
                self.step_fault_stop(i, m);
                Next::Done
            }
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
            | State::FaultRetract => self.step_cycle(state, i, program, m).into(),
        }
    }

    // Helpers of the steps: the state's change, the pass, the moves.

    pub fn enter(&mut self, to: State, events: &mut Stamped) {
        let from = self.state;
        if from != to {
            self.state = to;
            self.state_time_s = 0.0;
            self.retract_commanded_s = None;
            events.push(EventKind::StateChanged { from, to });
        }
    }

    /// Out of the cut: unclamp X first if it was clamped.
    pub fn leave_cut(&mut self, program: Option<&CycleProgram>, events: &mut Stamped) {
        let moves_x = program.is_some_and(|p| p.shape.moves_x());
        self.enter(if moves_x { State::Retract } else { State::Unclamp }, events);
    }

    /// Into the cut: X clamped first unless it moves in the cut (crowning, contour).
    pub(super) fn enter_cut_or_clamp(&mut self, program: &CycleProgram, events: &mut Stamped) {
        self.feed_scale = 0.0;
        self.enter(
            if program.shape.moves_x() {
                State::Cut
            } else {
                State::Clamp
            },
            events,
        );
    }

    pub(super) fn next_pass(&mut self, program: &CycleProgram, events: &mut Stamped) {
        if self.pass_index + 1 < self.pass_count(program) && !self.stopping {
            self.pass_index += 1;
            self.resume_y_mm = None;
            self.enter(State::ToStart, events);
        } else {
            self.enter(State::Home, events);
        }
    }

    pub(super) fn current_pass(&self, program: &CycleProgram) -> Option<PassSetpoint> {
        if self.single {
            program.single()
        } else {
            program.passes().get(self.pass_index).copied()
        }
    }

    fn pass_count(&self, program: &CycleProgram) -> usize {
        if self.single { 1 } else { program.passes().len() }
    }

    /// The spindle speed of a pass under the spindle override, within the machine.
    pub(super) fn pass_spindle_rpm(i: &SeqInputs, program: &CycleProgram, pass: &PassSetpoint) -> f64 {
        setup_math::overridden_spindle_rpm(
            pass.spindle_rpm,
            i.spindle_override,
            i.spindle_max_rpm,
            program.ratio_signed,
            i.table_max_deg_s,
        )
    }

    /// X for Y at `y_mm` in the cut: pass depth plus crowning/contour.
    pub(super) fn x_in_cut(program: &CycleProgram, pass: &PassSetpoint, y_mm: f64) -> f64 {
        pass.x_mm + program.shape.x_offset_mm(y_mm - program.face_bottom_mm)
    }

    /// Steps X towards `target` at `speed_mm_s`, pausing on feed hold.
    pub(super) fn move_x(&self, target: f64, speed_mm_s: f64, i: &SeqInputs, m: &mut Motion) -> bool {
        let l = i.x_limits;
        if self.hold {
            m.x.step_stop(l.accel_mm_s2, i.period_s);
            return false;
        }
        m.x.step_towards(target, speed_mm_s, l.accel_mm_s2, i.period_s)
    }

    /// Steps Y towards `target` at rapid, slower while the gearbox couples the table to
    /// Y (the differential must not drive the table beyond its speed).
    pub(super) fn move_y(&self, target: f64, i: &SeqInputs, m: &mut Motion) -> bool {
        let l = i.y_limits;
        if self.hold {
            m.y.step_stop(l.accel_mm_s2, i.period_s);
            return false;
        }
        let g = m.gearbox.params();
        let mut speed = l.rapid_mm_s;
        let d = g.differential_signed_deg_per_mm.abs();
        if d > 0.0 && m.gearbox.coupling() != Coupling::Disengaged {
            let base = (g.ratio_signed * i.spindle_speed_deg_s).abs();
            let spare = (0.9 * i.table_max_deg_s - base).max(0.0);
            speed = speed.min(spare / d).max(0.1);
        }
        m.y.step_towards(target, speed, l.accel_mm_s2, i.period_s)
    }
}
