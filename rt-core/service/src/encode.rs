//! The loop's side of the contract between processes: the control core's types to the
//! codes of `hob_ipc::codec` (and back where the loop needs it: a request's command).
//! Every encoder is an exhaustive `match`, so a new state, fault or refusal without a
//! code does not compile; none allocates (they run in the cycle).

use hob_canopen::bus::BusError;
use hob_control::egb::Coupling;
use hob_control::events::{Event, EventKind};
use hob_control::fault::{Axis, End, Fault, HomingFailure, Refusal};
use hob_control::{Command, Direction, HomeAxes, State, Status};
use hob_ipc::codec;
use hob_ipc::{AlarmCode, EventSample, StateSample, bus_event, command, direction, event_kind, send_error};
use hob_process_image::master::BusEvent;

/// The code of a sequencer state.
pub const fn state(s: State) -> codec::State {
    match s {
        State::Init => codec::State::Init,
        State::Idle => codec::State::Idle,
        State::Jog => codec::State::Jog,
        State::ToSafe => codec::State::ToSafe,
        State::ToStart => codec::State::ToStart,
        State::SpindleUp => codec::State::SpindleUp,
        State::Engage => codec::State::Engage,
        State::Infeed => codec::State::Infeed,
        State::Plunge => codec::State::Plunge,
        State::ExtraRev => codec::State::ExtraRev,
        State::Clamp => codec::State::Clamp,
        State::Cut => codec::State::Cut,
        State::Unclamp => codec::State::Unclamp,
        State::Retract => codec::State::Retract,
        State::Return => codec::State::Return,
        State::Index => codec::State::Index,
        State::Home => codec::State::Home,
        State::Disengage => codec::State::Disengage,
        State::SpindleDown => codec::State::SpindleDown,
        State::FaultRetract => codec::State::FaultRetract,
        State::FaultStop => codec::State::FaultStop,
        State::Faulted => codec::State::Faulted,
        State::Referencing => codec::State::Referencing,
    }
}

/// The sequencer state of a code.
pub const fn state_of(s: codec::State) -> State {
    match s {
        codec::State::Init => State::Init,
        codec::State::Idle => State::Idle,
        codec::State::Jog => State::Jog,
        codec::State::ToSafe => State::ToSafe,
        codec::State::ToStart => State::ToStart,
        codec::State::SpindleUp => State::SpindleUp,
        codec::State::Engage => State::Engage,
        codec::State::Infeed => State::Infeed,
        codec::State::Plunge => State::Plunge,
        codec::State::ExtraRev => State::ExtraRev,
        codec::State::Clamp => State::Clamp,
        codec::State::Cut => State::Cut,
        codec::State::Unclamp => State::Unclamp,
        codec::State::Retract => State::Retract,
        codec::State::Return => State::Return,
        codec::State::Index => State::Index,
        codec::State::Home => State::Home,
        codec::State::Disengage => State::Disengage,
        codec::State::SpindleDown => State::SpindleDown,
        codec::State::FaultRetract => State::FaultRetract,
        codec::State::FaultStop => State::FaultStop,
        codec::State::Faulted => State::Faulted,
        codec::State::Referencing => State::Referencing,
    }
}

/// The code of a refusal.
pub const fn refusal(r: Refusal) -> codec::Refusal {
    match r {
        Refusal::NoProgram => codec::Refusal::NoProgram,
        Refusal::CycleRunning => codec::Refusal::CycleRunning,
        Refusal::Faulted => codec::Refusal::Faulted,
        Refusal::NotReady => codec::Refusal::NotReady,
        Refusal::NothingToDo => codec::Refusal::NothingToDo,
        Refusal::OutsideSoftLimits => codec::Refusal::OutsideSoftLimits,
        Refusal::NoSingleDepth => codec::Refusal::NoSingleDepth,
        Refusal::NotReferenced => codec::Refusal::NotReferenced,
        Refusal::TablePositionLost => codec::Refusal::TablePositionLost,
        Refusal::JogActive => codec::Refusal::JogActive,
        Refusal::SpindleTurning => codec::Refusal::SpindleTurning,
        Refusal::FlanksCrossed => codec::Refusal::FlanksCrossed,
        Refusal::BadValue => codec::Refusal::BadValue,
        Refusal::SafetyChainOpen => codec::Refusal::SafetyChainOpen,
        Refusal::DrivesNotEnabled => codec::Refusal::DrivesNotEnabled,
    }
}

/// The refusal of a code.
pub const fn refusal_of(r: codec::Refusal) -> Refusal {
    match r {
        codec::Refusal::NoProgram => Refusal::NoProgram,
        codec::Refusal::CycleRunning => Refusal::CycleRunning,
        codec::Refusal::Faulted => Refusal::Faulted,
        codec::Refusal::NotReady => Refusal::NotReady,
        codec::Refusal::NothingToDo => Refusal::NothingToDo,
        codec::Refusal::OutsideSoftLimits => Refusal::OutsideSoftLimits,
        codec::Refusal::NoSingleDepth => Refusal::NoSingleDepth,
        codec::Refusal::BadValue => Refusal::BadValue,
        codec::Refusal::SafetyChainOpen => Refusal::SafetyChainOpen,
        codec::Refusal::DrivesNotEnabled => Refusal::DrivesNotEnabled,
        codec::Refusal::NotReferenced => Refusal::NotReferenced,
        codec::Refusal::TablePositionLost => Refusal::TablePositionLost,
        codec::Refusal::JogActive => Refusal::JogActive,
        codec::Refusal::SpindleTurning => Refusal::SpindleTurning,
        codec::Refusal::FlanksCrossed => Refusal::FlanksCrossed,
    }
}

pub const fn axis(a: Axis) -> codec::Axis {
    match a {
        Axis::B => codec::Axis::B,
        Axis::X => codec::Axis::X,
        Axis::Y => codec::Axis::Y,
    }
}

pub const fn axis_of(a: codec::Axis) -> Axis {
    match a {
        codec::Axis::B => Axis::B,
        codec::Axis::X => Axis::X,
        codec::Axis::Y => Axis::Y,
    }
}

pub const fn end(e: End) -> codec::End {
    match e {
        End::Min => codec::End::Min,
        End::Max => codec::End::Max,
    }
}

/// Encodes a fault (`None`: code 0).
pub fn alarm(f: Option<Fault>) -> AlarmCode {
    let mut a = AlarmCode::default();
    let Some(f) = f else { return a };
    let (code, ax, en, va, vb) = match f {
        Fault::SafetyChainOpen => (codec::Fault::SafetyChainOpen, None, None, 0.0, 0.0),
        Fault::EmergencyStop => (codec::Fault::EmergencyStop, None, None, 0.0, 0.0),
        Fault::HardwareLimit { axis, end: e } => (codec::Fault::HardwareLimit, Some(axis), Some(e), 0.0, 0.0),
        Fault::SoftLimit { axis, position } => (codec::Fault::SoftLimit, Some(axis), None, position, 0.0),
        Fault::FollowingError { axis, error } => (codec::Fault::FollowingError, Some(axis), None, error, 0.0),
        Fault::DriveFault { axis } => (codec::Fault::DriveFault, Some(axis), None, 0.0, 0.0),
        Fault::VfdFault => (codec::Fault::VfdFault, None, None, 0.0, 0.0),
        Fault::SyncLost { error_arcsec } => (codec::Fault::SyncLost, None, None, error_arcsec, 0.0),
        Fault::SpindleSpeed { set_rpm, actual_rpm } => {
            (codec::Fault::SpindleSpeed, None, None, set_rpm, actual_rpm)
        }
        Fault::LubeTimeout => (codec::Fault::LubeTimeout, None, None, 0.0, 0.0),
        Fault::ClampTimeout => (codec::Fault::ClampTimeout, None, None, 0.0, 0.0),
        Fault::FeedbackLost { axis } => (codec::Fault::FeedbackLost, Some(axis), None, 0.0, 0.0),
        Fault::IoLost => (codec::Fault::IoLost, None, None, 0.0, 0.0),
        Fault::DriveNotEnabled { axis } => (codec::Fault::DriveNotEnabled, Some(axis), None, 0.0, 0.0),
        Fault::HomingFailed { axis, why } => {
            a.end = homing_failure(why).code();
            (codec::Fault::HomingFailed, Some(axis), None, 0.0, 0.0)
        }
        Fault::PositionLost { axis } => (codec::Fault::PositionLost, Some(axis), None, 0.0, 0.0),
    };
    a.code = code.code();
    a.axis = ax.map_or(0, |x| axis(x).code());
    if let Some(e) = en {
        a.end = end(e).code();
    }
    a.value_a = va;
    a.value_b = vb;
    a
}

/// Decodes an alarm (`None` for code 0, an unknown code, or a missing axis).
pub fn fault_of(a: &AlarmCode) -> Option<Fault> {
    let f = codec::Fault::of(a)?;
    let ax = codec::Axis::from_code(a.axis).map(axis_of);
    Some(match f {
        codec::Fault::SafetyChainOpen => Fault::SafetyChainOpen,
        codec::Fault::EmergencyStop => Fault::EmergencyStop,
        codec::Fault::HardwareLimit => Fault::HardwareLimit {
            axis: ax?,
            end: if codec::End::from_code(a.end) == Some(codec::End::Min) {
                End::Min
            } else {
                End::Max
            },
        },
        codec::Fault::SoftLimit => Fault::SoftLimit {
            axis: ax?,
            position: a.value_a,
        },
        codec::Fault::FollowingError => Fault::FollowingError {
            axis: ax?,
            error: a.value_a,
        },
        codec::Fault::DriveFault => Fault::DriveFault { axis: ax? },
        codec::Fault::VfdFault => Fault::VfdFault,
        codec::Fault::SyncLost => Fault::SyncLost {
            error_arcsec: a.value_a,
        },
        codec::Fault::SpindleSpeed => Fault::SpindleSpeed {
            set_rpm: a.value_a,
            actual_rpm: a.value_b,
        },
        codec::Fault::LubeTimeout => Fault::LubeTimeout,
        codec::Fault::ClampTimeout => Fault::ClampTimeout,
        codec::Fault::FeedbackLost => Fault::FeedbackLost { axis: ax? },
        codec::Fault::IoLost => Fault::IoLost,
        codec::Fault::DriveNotEnabled => Fault::DriveNotEnabled { axis: ax? },
        codec::Fault::HomingFailed => Fault::HomingFailed {
            axis: ax?,
            why: homing_failure_of(codec::HomingFailure::from_code(a.end)?),
        },
        codec::Fault::PositionLost => Fault::PositionLost { axis: ax? },
    })
}

/// The code of a homing failure.
pub const fn homing_failure(h: HomingFailure) -> codec::HomingFailure {
    match h {
        HomingFailure::ModeNotConfirmed => codec::HomingFailure::ModeNotConfirmed,
        HomingFailure::NotStarted => codec::HomingFailure::NotStarted,
        HomingFailure::DriveError => codec::HomingFailure::DriveError,
        HomingFailure::Timeout => codec::HomingFailure::Timeout,
    }
}

const fn homing_failure_of(h: codec::HomingFailure) -> HomingFailure {
    match h {
        codec::HomingFailure::ModeNotConfirmed => HomingFailure::ModeNotConfirmed,
        codec::HomingFailure::NotStarted => HomingFailure::NotStarted,
        codec::HomingFailure::DriveError => HomingFailure::DriveError,
        codec::HomingFailure::Timeout => HomingFailure::Timeout,
    }
}

/// The code of a coupling state.
pub const fn coupling(c: Coupling) -> codec::Coupling {
    match c {
        Coupling::Disengaged => codec::Coupling::Disengaged,
        Coupling::Engaging => codec::Coupling::Engaging,
        Coupling::Phasing => codec::Coupling::Phasing,
        Coupling::Synchronised => codec::Coupling::Synchronised,
        Coupling::Disengaging => codec::Coupling::Disengaging,
    }
}

fn bits(b: [bool; 3]) -> u8 {
    b.iter()
        .enumerate()
        .fold(0, |acc, (i, &on)| acc | (u8::from(on) << i))
}

/// Fills a state sample from the controller's status (allocation-free). Timing, I/O
/// image and counters are the loop's to fill.
pub fn fill_state(s: &mut StateSample, st: &Status, passes_total: u32, program_loaded: bool) {
    s.cycle = st.cycle;
    s.state = state(st.state).code();
    s.hold = u8::from(st.hold);
    s.program_loaded = u8::from(program_loaded);
    s.drives_enabled = bits(st.drives_enabled);
    s.drives_silent = bits(st.drives_silent);
    s.pass = st.pass;
    s.passes_total = passes_total;
    s.tooth = st.tooth;
    s.coupling = coupling(st.coupling).code();
    s.table_deg.actual = st.table_deg;
    s.table_deg.command = st.table_cmd_deg;
    s.x_mm.actual = st.x_mm;
    s.x_mm.command = st.x_cmd_mm;
    s.y_mm.actual = st.y_mm;
    s.y_mm.command = st.y_cmd_mm;
    s.spindle_deg = st.spindle_deg;
    s.spindle_rpm = st.spindle_rpm;
    s.spindle_set_rpm = st.spindle_set_rpm;
    s.sync_error_arcsec = st.sync_error_arcsec;
    s.ccc_arcsec = st.ccc_arcsec;
    s.alarm = alarm(st.fault);
    s.referenced = bits([st.table_position_whole, st.referenced[0], st.referenced[1]]);
    s.moving_axis = st.moving_axis.map_or(0, |a| axis(a).code());
    s.continue_pass = st.continue_pass;
    s.feed_override_percent = st.feed_override_percent;
    s.spindle_override_percent = st.spindle_override_percent;
    s.x_offset_mm = st.offsets.x_mm;
    s.y_offset_mm = st.offsets.y_mm;
}

/// A command as it travels in a [`hob_ipc::CommandRequest`]: its code and arguments.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Args {
    pub code: u32,
    pub single: u8,
    pub axis: u8,
    pub direction: u8,
    pub value: f64,
}

impl Args {
    const fn of(code: u32) -> Self {
        Args {
            code,
            single: 0,
            axis: 0,
            direction: 0,
            value: 0.0,
        }
    }

    const fn axis(self, a: Axis) -> Self {
        Args {
            axis: axis(a).code(),
            ..self
        }
    }

    const fn value(self, value: f64) -> Self {
        Args { value, ..self }
    }

    /// The arguments of a request.
    pub fn from_request(r: &hob_ipc::CommandRequest) -> Self {
        Args {
            code: r.command,
            single: r.single,
            axis: r.axis,
            direction: r.direction,
            value: r.value,
        }
    }

    /// Writes them into a request.
    pub fn to_request(self, r: &mut hob_ipc::CommandRequest) {
        r.command = self.code;
        r.single = self.single;
        r.axis = self.axis;
        r.direction = self.direction;
        r.value = self.value;
    }
}

const fn direction_code(d: Direction) -> u8 {
    match d {
        Direction::Positive => direction::POSITIVE,
        Direction::Negative => direction::NEGATIVE,
    }
}

fn direction_of(code: u8) -> Option<Direction> {
    match code {
        direction::POSITIVE => Some(Direction::Positive),
        direction::NEGATIVE => Some(Direction::Negative),
        _ => None,
    }
}

/// A command's code and arguments.
pub const fn command_code(c: Command) -> Args {
    match c {
        Command::Start { single } => Args {
            single: single as u8,
            ..Args::of(command::START)
        },
        Command::FeedHold => Args::of(command::FEED_HOLD),
        Command::Resume => Args::of(command::RESUME),
        Command::Stop => Args::of(command::STOP),
        Command::Reset => Args::of(command::RESET),
        Command::Jog { axis: a, distance } => Args::of(command::JOG).axis(a).value(distance),
        Command::SpindleOn { rpm } => Args::of(command::SPINDLE_ON).value(rpm),
        Command::SpindleOff => Args::of(command::SPINDLE_OFF),
        Command::SpindleHold { rpm } => Args::of(command::SPINDLE_HOLD).value(rpm),
        Command::NewBlank => Args::of(command::NEW_BLANK),
        Command::Home { axes } => match axes {
            HomeAxes::X => Args::of(command::HOME).axis(Axis::X),
            HomeAxes::Y => Args::of(command::HOME).axis(Axis::Y),
            HomeAxes::Both => Args::of(command::HOME),
        },
        Command::JogContinuous {
            axis: a,
            direction: d,
            speed_per_min,
        } => Args {
            direction: direction_code(d),
            ..Args::of(command::JOG_CONTINUOUS).axis(a).value(speed_per_min)
        },
        Command::JogRelease => Args::of(command::JOG_RELEASE),
        Command::FeedOverride { percent } => Args::of(command::FEED_OVERRIDE).value(percent),
        Command::SpindleOverride { percent } => Args::of(command::SPINDLE_OVERRIDE).value(percent),
        Command::TouchOff { axis: a, value_mm } => Args::of(command::TOUCH_OFF).axis(a).value(value_mm),
        Command::Continue => Args::of(command::CONTINUE),
        Command::TouchFlank { turned } => Args {
            direction: direction_code(turned),
            ..Args::of(command::TOUCH_FLANK)
        },
    }
}

/// A command from its code and arguments (`None`: LOAD_PROGRAM, unknown code, bad axis
/// or direction).
pub fn command_from_code(a: &Args) -> Option<Command> {
    let ax = || codec::Axis::from_code(a.axis).map(axis_of);
    Some(match a.code {
        command::START => Command::Start {
            single: a.single != 0,
        },
        command::FEED_HOLD => Command::FeedHold,
        command::RESUME => Command::Resume,
        command::STOP => Command::Stop,
        command::RESET => Command::Reset,
        command::JOG => Command::Jog {
            axis: ax()?,
            distance: a.value,
        },
        command::SPINDLE_ON => Command::SpindleOn { rpm: a.value },
        command::SPINDLE_OFF => Command::SpindleOff,
        command::SPINDLE_HOLD => Command::SpindleHold { rpm: a.value },
        command::NEW_BLANK => Command::NewBlank,
        command::HOME => Command::Home {
            axes: match a.axis {
                0 => HomeAxes::Both,
                _ => match ax()? {
                    Axis::X => HomeAxes::X,
                    Axis::Y => HomeAxes::Y,
                    Axis::B => return None,
                },
            },
        },
        command::JOG_CONTINUOUS => Command::JogContinuous {
            axis: ax()?,
            direction: direction_of(a.direction)?,
            speed_per_min: a.value,
        },
        command::TOUCH_FLANK => Command::TouchFlank {
            turned: direction_of(a.direction)?,
        },
        command::JOG_RELEASE => Command::JogRelease,
        command::FEED_OVERRIDE => Command::FeedOverride { percent: a.value },
        command::SPINDLE_OVERRIDE => Command::SpindleOverride { percent: a.value },
        command::TOUCH_OFF => Command::TouchOff {
            axis: ax()?,
            value_mm: a.value,
        },
        command::CONTINUE => Command::Continue,
        _ => return None,
    })
}

/// Encodes a control-core event (allocation-free).
pub fn event_sample(seq: u64, e: &Event) -> EventSample {
    let mut s = EventSample {
        seq,
        cycle: e.cycle,
        ..EventSample::default()
    };
    match e.kind {
        EventKind::StateChanged { from, to } => {
            s.kind = event_kind::STATE_CHANGED;
            s.a = state(from).code();
            s.b = state(to).code();
        }
        EventKind::Fault(f) => {
            s.kind = event_kind::ALARM;
            s.alarm = alarm(Some(f));
        }
        EventKind::FaultCleared => s.kind = event_kind::ALARM_CLEARED,
        EventKind::PassStarted { pass } => {
            s.kind = event_kind::PASS_STARTED;
            s.a = pass;
        }
        EventKind::PhaseRecorded { phase_deg } => {
            s.kind = event_kind::PHASE_RECORDED;
            s.value = phase_deg;
        }
        EventKind::FlankTouched { turned, phase_deg } => {
            s.kind = event_kind::FLANK_TOUCHED;
            s.a = u32::from(direction_code(turned));
            s.value = phase_deg;
        }
        EventKind::PhaseAligned { phase_deg, play_deg } => {
            s.kind = event_kind::PHASE_ALIGNED;
            // Micro-degrees (the play is less than half a pitch, well below 4 294 deg).
            s.a = (play_deg * 1e6).round().clamp(0.0, f64::from(u32::MAX)) as u32;
            s.value = phase_deg;
        }
        EventKind::Accepted(c) => {
            s.kind = event_kind::ACCEPTED;
            let a = command_code(c);
            s.a = a.code;
            s.b = u32::from(a.single) | (u32::from(a.axis) << 8) | (u32::from(a.direction) << 16);
            s.value = a.value;
        }
        EventKind::Refused { command, reason } => {
            s.kind = event_kind::REFUSED;
            let a = command_code(command);
            s.a = a.code;
            s.b = refusal(reason).code();
            s.value = a.value;
        }
        EventKind::ProgramLoaded => s.kind = event_kind::PROGRAM_LOADED,
        EventKind::CycleDone => s.kind = event_kind::CYCLE_DONE,
        EventKind::Referenced { axis: a } => {
            s.kind = event_kind::REFERENCED;
            s.a = u32::from(axis(a).code());
        }
        EventKind::DeadManStop { axis: a } => {
            s.kind = event_kind::DEAD_MAN_STOP;
            s.a = u32::from(axis(a).code());
        }
        EventKind::SpindleDeadManStop => {
            // Axis 0: the hob spindle C (it has no axis code of its own).
            s.kind = event_kind::DEAD_MAN_STOP;
        }
        EventKind::OffsetChanged { axis: a, offset_mm } => {
            s.kind = event_kind::OFFSET_CHANGED;
            s.a = u32::from(axis(a).code());
            s.value = offset_mm;
        }
    }
    s
}

/// A bus event of the loop's CANopen master as an event sample (in the cycle: numbers
/// only, nothing formatted; `hob_ipc::codec::event_text` words it).
pub fn bus_event_sample(cycle: u64, be: &BusEvent) -> EventSample {
    let mut e = EventSample {
        kind: event_kind::BUS,
        cycle,
        ..EventSample::default()
    };
    match *be {
        BusEvent::Emcy(m) => {
            e.a = u32::from(m.node);
            e.b = bus_event::EMCY;
            e.value = f64::from(m.code);
        }
        BusEvent::HeartbeatLost { node } => {
            e.a = u32::from(node);
            e.b = bus_event::HEARTBEAT_LOST;
        }
        BusEvent::TpdoMissing {
            node,
            missed,
            longest_in_a_row,
        } => {
            // The node in the low byte, the longest run above it (`hob_ipc::codec`).
            e.a = u32::from(node) | longest_in_a_row.min(0x00FF_FFFF) << 8;
            e.b = bus_event::TPDO_MISSING;
            e.value = f64::from(missed);
        }
        BusEvent::SendFailed(err) => {
            e.b = bus_event::SEND_FAILED;
            (e.a, e.value) = match err {
                BusError::Full => (send_error::QUEUE_FULL, 0.0),
                BusError::Down => (send_error::INTERFACE_DOWN, 0.0),
                BusError::Os(errno) => (send_error::OS, f64::from(errno)),
            };
        }
    }
    e
}

#[cfg(test)]
mod tests;
