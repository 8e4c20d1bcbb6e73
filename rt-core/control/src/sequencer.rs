//! The sequencer's own state: the state of the cycle (its pass, tooth, hold, stop), the
//! peripherals it sets (coolant, X clamp, spindle speed), the jog under way, what
//! "continue" needs, and what the loop asks of it (drives enabled, PC-OK relay). Its
//! steps, one control cycle each, are `Controller::sequence` (module `sequencing`).

use super::command::State;
use super::fault::Fault;
use super::jog::Jog;

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
    /// The pass a fault or a stop interrupted (index, single mode), for "continue".
    pub interrupted: Option<(usize, bool)>,
    /// The table lost its position after the tooth phase of an interrupted part was
    /// recorded: "continue" is refused until a new start or a new blank.
    pub phase_lost: bool,
    /// The tooth phase noted at each flank touch (table turned negative, positive).
    pub flank_touch: [Option<f64>; 2],
    /// Power-up conditions met (chain closed, lubricated, no fault): enable the drives.
    pub init_ready: bool,
    /// In the fault reaction's retract: when X's command reached the safe position
    /// (state time, s); cleared on every change of state.
    pub retract_commanded_s: Option<f64>,
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
}
