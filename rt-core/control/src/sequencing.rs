//! How the controller composes its machines each cycle ([`Controller::sequence`]): the
//! cycle sequencer (module `sequencer`, its steps in `cycle` and `fault_reaction`) gets
//! what it reads as one copied value and moves X, Y and the gearbox; what it hands back,
//! a fault, a cycle of jog (module `jog`) or of referencing (module `referencing`), the
//! controller runs here. A fault is raised here too ([`Controller::raise`]): latched, an
//! event, and the reaction of each machine it concerns.

use super::Controller;
use super::command::State;
use super::events::EventKind;
use super::fault::{Axis, Fault};
use super::jog::{JogAxis, JogContext, JogCycle};
use super::profile::Profile;
use super::referencing::{HomingInputs, Progress};
use super::sequencer::{Interrupted, Motion, Next, SeqInputs};
use super::setup_math;
use hob_setup::job::CycleKind;

impl Controller {
    /// One cycle of the sequencer, and of the machine it hands on to.
    pub(super) fn sequence(&mut self) {
        let inputs = self.seq_inputs();
        let mut motion = Motion {
            x: &mut self.x,
            y: &mut self.y,
            gearbox: &mut self.gearbox,
            events: self.events.stamped(self.cycle),
        };
        match self.sequencer.step(&inputs, self.program.as_ref(), &mut motion) {
            Next::Done => {}
            Next::Fault(f) => self.raise(f),
            Next::Jog => self.sequence_jog(),
            Next::Referencing => self.sequence_referencing(),
        }
    }

    /// What the sequencer reads this cycle.
    fn seq_inputs(&self) -> SeqInputs {
        let p = &self.params;
        let m = &self.measured;
        SeqInputs {
            period_s: p.period_s,
            now_s: self.now_s(),
            deadman_s: p.deadman_s,
            x_limits: p.x_limits,
            y_limits: p.y_limits,
            table_max_deg_s: p.table_max_deg_s,
            spindle_max_rpm: p.spindle_max_rpm,
            spindle_start_timeout_s: p.spindle_start_timeout_s,
            clamp_timeout_s: p.clamp_timeout_s,
            feed_override: self.feed_override,
            spindle_override: self.spindle_override,
            spindle_deg: m.spindle_deg,
            spindle_speed_deg_s: m.spindle_speed_deg_s,
            spindle_for_gearbox_deg: m.spindle_for_gearbox_deg,
            last_spindle_for_gearbox_deg: self.last_spindle_for_gearbox_deg,
            spindle_at_speed: self.spindle_at_speed_s >= super::SPINDLE_SETTLE_S,
            table_deg: m.table_deg,
            x_mm: m.x_mm,
            y_mm: m.y_mm,
            inputs: m.inputs,
            lubricated: self.lube.cycles_done() > 0,
            fault_latched: self.fault.is_some(),
            drives_ready: self.drives_ready(),
        }
    }

    /// Latches a fault (the first one wins), and starts the reaction: the referencing's
    /// (a lost reference, referencing broken off), the sequencer's (module
    /// `fault_reaction`).
    pub(super) fn raise(&mut self, f: Fault) {
        if self.fault.is_some() {
            return;
        }
        self.fault = Some(f);
        self.event(EventKind::Fault(f));
        if self.sequencer.state.in_cycle() {
            self.note_interrupted();
        }
        if let Fault::FeedbackLost { axis } | Fault::PositionLost { axis } = f
            && axis != Axis::B
        {
            self.referencing.lose(axis);
        }
        if self.sequencer.state == State::Referencing {
            self.referencing.abandon();
        }
        let mut events = self.events.stamped(self.cycle);
        self.sequencer.on_fault(f, &mut self.gearbox, &mut events);
    }

    /// A drive lost its position: X or Y its reference; the table the tooth phase.
    pub(super) fn position_lost(&mut self, axis: Axis) {
        if axis == Axis::B {
            self.sequencer.table_position_lost(&mut self.gearbox);
        } else {
            self.referencing.lose(axis);
        }
    }

    /// The sequencer enters `to` (a command's doing).
    pub(super) fn enter(&mut self, to: State) {
        let mut events = self.events.stamped(self.cycle);
        self.sequencer.enter(to, &mut events);
    }

    /// Out of the cut (a cycle stop's doing).
    pub(super) fn leave_cut(&mut self) {
        let mut events = self.events.stamped(self.cycle);
        self.sequencer.leave_cut(self.program.as_ref(), &mut events);
    }

    /// A cycle is being broken off (by a fault or a stop): remember the pass for
    /// "continue", and where its cut is to be re-entered. Broken off in its cut (or once
    /// it was cut), a feed and the overlap behind where Y stands
    /// (`setup_math::resume_y_mm`); before its cut, where this run was to enter it. Tooth by tooth every tooth is a pass of Y of its own, and
    /// the pass is cut again from its first tooth.
    pub(super) fn note_interrupted(&mut self) {
        let Some(program) = self.program else {
            return;
        };
        let s = &self.sequencer;
        let cut_begun = matches!(s.state, State::Cut | State::Unclamp | State::Retract)
            && program.cycle != CycleKind::ToothByTooth;
        let behind_y = s.current_pass(&program).filter(|_| cut_begun).and_then(|pass| {
            setup_math::resume_y_mm(
                self.y.position,
                pass.y_start_mm,
                program.feed_per_table_rev_mm(&pass),
                program.feed_sign,
                self.params.resume_overlap_mm,
            )
        });
        // A re-entry this run had is still good (the gaps there were cut to depth before),
        // and so is the one further along.
        let from_y_mm = match (s.resume_y_mm, behind_y) {
            (Some(a), Some(b)) => Some(if program.feed_sign * (b - a) > 0.0 { b } else { a }),
            (a, b) => a.or(b),
        };
        self.sequencer.interrupted = Some(Interrupted {
            pass_index: s.pass_index,
            single: s.single,
            from_y_mm,
        });
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
        self.table_excitation_deg = step.table_offset_deg;
        if step.done {
            self.enter(State::Idle);
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

    // What jog sees of the machine.

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
