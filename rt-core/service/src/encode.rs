//! The loop's side of the contract between processes: the control core's types to the
//! codes of `hob_ipc::codec` (and back where the loop needs it: a request's command).
//! Every encoder is an exhaustive `match`, so a new state, fault or refusal without a
//! code does not compile; none allocates (they run in the cycle).

use hob_canopen::bus::BusError;
use hob_control::egb::Coupling;
use hob_control::events::{Event, EventKind};
use hob_control::fault::{Axis, End, Fault, Refusal};
use hob_control::{Command, State, Status};
use hob_ipc::codec;
use hob_ipc::{AlarmCode, EventSample, StateSample, bus_event, command, event_kind, send_error};
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
    };
    a.code = code.code();
    a.axis = ax.map_or(0, |x| axis(x).code());
    a.end = en.map_or(0, |e| end(e).code());
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
    })
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
}

/// A command's code and arguments: (code, single, axis, value).
pub fn command_code(c: Command) -> (u32, u8, u8, f64) {
    match c {
        Command::Start { single } => (command::START, u8::from(single), 0, 0.0),
        Command::FeedHold => (command::FEED_HOLD, 0, 0, 0.0),
        Command::Resume => (command::RESUME, 0, 0, 0.0),
        Command::Stop => (command::STOP, 0, 0, 0.0),
        Command::Reset => (command::RESET, 0, 0, 0.0),
        Command::Jog { axis: a, distance } => (command::JOG, 0, axis(a).code(), distance),
        Command::SpindleOn { rpm } => (command::SPINDLE_ON, 0, 0, rpm),
        Command::SpindleOff => (command::SPINDLE_OFF, 0, 0, 0.0),
        Command::NewBlank => (command::NEW_BLANK, 0, 0, 0.0),
    }
}

/// A command from its code and arguments (`None`: LOAD_PROGRAM, unknown code, bad axis).
pub fn command_from_code(code: u32, single: u8, axis: u8, value: f64) -> Option<Command> {
    Some(match code {
        command::START => Command::Start { single: single != 0 },
        command::FEED_HOLD => Command::FeedHold,
        command::RESUME => Command::Resume,
        command::STOP => Command::Stop,
        command::RESET => Command::Reset,
        command::JOG => Command::Jog {
            axis: axis_of(codec::Axis::from_code(axis)?),
            distance: value,
        },
        command::SPINDLE_ON => Command::SpindleOn { rpm: value },
        command::SPINDLE_OFF => Command::SpindleOff,
        command::NEW_BLANK => Command::NewBlank,
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
        EventKind::Accepted(c) => {
            s.kind = event_kind::ACCEPTED;
            let (code, single, axis, value) = command_code(c);
            s.a = code;
            s.b = u32::from(single) | (u32::from(axis) << 8);
            s.value = value;
        }
        EventKind::Refused { command, reason } => {
            s.kind = event_kind::REFUSED;
            let (code, _, _, value) = command_code(command);
            s.a = code;
            s.b = refusal(reason).code();
            s.value = value;
        }
        EventKind::ProgramLoaded => s.kind = event_kind::PROGRAM_LOADED,
        EventKind::CycleDone => s.kind = event_kind::CYCLE_DONE,
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
        BusEvent::TpdoMissing { node, in_a_row } => {
            e.a = u32::from(node);
            e.b = bus_event::TPDO_MISSING;
            e.value = f64::from(in_a_row);
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
