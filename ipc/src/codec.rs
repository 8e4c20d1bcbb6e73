//! The control core's types to and from the bus's plain numbers (`hob_ipc`), and the
//! operator's words for them. The loop uses only the `Copy` encoders (no allocation);
//! frontends use the decoders and the texts.

use crate::{AlarmCode, EventSample, StateSample, bus_event, bus_kind, command, event_kind, send_error};
use hob_canopen::bus::BusError;
use hob_canopen::emcy::emcy_text;
use hob_control::egb::Coupling;
use hob_control::events::{Event, EventKind};
use hob_control::fault::{Axis, End, Fault, Refusal};
use hob_control::{Command, State, Status};
use hob_process_image::master::BusEvent;

/// Every state, in code order (code = index).
pub const STATES: [State; 22] = [
    State::Init,
    State::Idle,
    State::Jog,
    State::ToSafe,
    State::ToStart,
    State::SpindleUp,
    State::Engage,
    State::Infeed,
    State::Plunge,
    State::ExtraRev,
    State::Clamp,
    State::Cut,
    State::Unclamp,
    State::Retract,
    State::Return,
    State::Index,
    State::Home,
    State::Disengage,
    State::SpindleDown,
    State::FaultRetract,
    State::FaultStop,
    State::Faulted,
];

pub fn state_code(s: State) -> u32 {
    STATES.iter().position(|&x| x == s).unwrap_or(0) as u32
}

pub fn state_from_code(c: u32) -> Option<State> {
    STATES.get(c as usize).copied()
}

/// The state's name, or `?<code>` for a code this build does not know.
pub fn state_name(c: u32) -> String {
    state_from_code(c).map_or_else(|| format!("?{c}"), |s| s.name().to_string())
}

pub const REFUSALS: [Refusal; 10] = [
    Refusal::NoProgram,
    Refusal::CycleRunning,
    Refusal::Faulted,
    Refusal::NotReady,
    Refusal::NothingToDo,
    Refusal::OutsideSoftLimits,
    Refusal::NoSingleDepth,
    Refusal::BadValue,
    Refusal::SafetyChainOpen,
    Refusal::DrivesNotEnabled,
];

/// Refusal codes start at 1 (0: the request itself was malformed or the program failed its check).
pub fn refusal_code(r: Refusal) -> u32 {
    REFUSALS.iter().position(|&x| x == r).map_or(0, |i| i as u32 + 1)
}

pub fn refusal_from_code(c: u32) -> Option<Refusal> {
    c.checked_sub(1).and_then(|i| REFUSALS.get(i as usize).copied())
}

/// What the operator reads for a refusal.
pub fn refusal_text(r: Refusal) -> &'static str {
    match r {
        Refusal::NoProgram => "no program loaded: load one first (hob load PROGRAM)",
        Refusal::CycleRunning => "a cycle is running: stop it first",
        Refusal::Faulted => "the machine is in fault: remove the cause, then reset",
        Refusal::NotReady => "power-up not finished (lubrication, safety chain, drives)",
        Refusal::NothingToDo => "nothing to do in this state",
        Refusal::OutsideSoftLimits => "the move would leave the soft limits",
        Refusal::NoSingleDepth => "the program has no single-mode depth",
        Refusal::BadValue => "the value is not a finite number in range",
        Refusal::SafetyChainOpen => "the safety chain is open: close it with the reset button first",
        Refusal::DrivesNotEnabled => "not every drive reports \"operation enabled\" yet",
    }
}

fn axis_code(a: Axis) -> u8 {
    match a {
        Axis::B => 1,
        Axis::X => 2,
        Axis::Y => 3,
    }
}

pub fn axis_from_code(c: u8) -> Option<Axis> {
    match c {
        1 => Some(Axis::B),
        2 => Some(Axis::X),
        3 => Some(Axis::Y),
        _ => None,
    }
}

/// Encodes a fault (`None`: code 0).
pub fn alarm(f: Option<Fault>) -> AlarmCode {
    let mut a = AlarmCode::default();
    let Some(f) = f else { return a };
    let (code, axis, end, va, vb) = match f {
        Fault::SafetyChainOpen => (1, None, 0, 0.0, 0.0),
        Fault::EmergencyStop => (2, None, 0, 0.0, 0.0),
        Fault::HardwareLimit { axis, end } => (3, Some(axis), if end == End::Min { 1 } else { 2 }, 0.0, 0.0),
        Fault::SoftLimit { axis, position } => (4, Some(axis), 0, position, 0.0),
        Fault::FollowingError { axis, error } => (5, Some(axis), 0, error, 0.0),
        Fault::DriveFault { axis } => (6, Some(axis), 0, 0.0, 0.0),
        Fault::VfdFault => (7, None, 0, 0.0, 0.0),
        Fault::SyncLost { error_arcsec } => (8, None, 0, error_arcsec, 0.0),
        Fault::SpindleSpeed { set_rpm, actual_rpm } => (9, None, 0, set_rpm, actual_rpm),
        Fault::LubeTimeout => (10, None, 0, 0.0, 0.0),
        Fault::ClampTimeout => (11, None, 0, 0.0, 0.0),
        Fault::FeedbackLost { axis } => (12, Some(axis), 0, 0.0, 0.0),
        Fault::IoLost => (13, None, 0, 0.0, 0.0),
        Fault::DriveNotEnabled { axis } => (14, Some(axis), 0, 0.0, 0.0),
    };
    a.code = code;
    a.axis = axis.map_or(0, axis_code);
    a.end = end;
    a.value_a = va;
    a.value_b = vb;
    a
}

/// Decodes an alarm (`None` for code 0 or an unknown code).
pub fn fault_from_alarm(a: &AlarmCode) -> Option<Fault> {
    let axis = axis_from_code(a.axis);
    Some(match a.code {
        1 => Fault::SafetyChainOpen,
        2 => Fault::EmergencyStop,
        3 => Fault::HardwareLimit {
            axis: axis?,
            end: if a.end == 1 { End::Min } else { End::Max },
        },
        4 => Fault::SoftLimit {
            axis: axis?,
            position: a.value_a,
        },
        5 => Fault::FollowingError {
            axis: axis?,
            error: a.value_a,
        },
        6 => Fault::DriveFault { axis: axis? },
        7 => Fault::VfdFault,
        8 => Fault::SyncLost {
            error_arcsec: a.value_a,
        },
        9 => Fault::SpindleSpeed {
            set_rpm: a.value_a,
            actual_rpm: a.value_b,
        },
        10 => Fault::LubeTimeout,
        11 => Fault::ClampTimeout,
        12 => Fault::FeedbackLost { axis: axis? },
        13 => Fault::IoLost,
        14 => Fault::DriveNotEnabled { axis: axis? },
        _ => return None,
    })
}

fn unit(a: Axis) -> &'static str {
    if a == Axis::B { "deg" } else { "mm" }
}

/// What the operator reads for a fault.
pub fn fault_text(f: Fault) -> String {
    match f {
        Fault::SafetyChainOpen => "safety chain open".into(),
        Fault::EmergencyStop => "emergency stop pressed".into(),
        Fault::HardwareLimit { axis, end } => format!(
            "hardware limit {} {}",
            axis.name(),
            if end == End::Min { "min" } else { "max" }
        ),
        Fault::SoftLimit { axis, position } => {
            format!("soft limit {}: {position:.3} {}", axis.name(), unit(axis))
        }
        Fault::FollowingError { axis, error } => {
            format!("following error {}: {error:.4} {}", axis.name(), unit(axis))
        }
        Fault::DriveFault { axis } => format!("drive fault {}", axis.name()),
        Fault::VfdFault => "spindle VFD fault".into(),
        Fault::SyncLost { error_arcsec } => {
            format!("synchronisation lost: {error_arcsec:.1} arcsec outside the coarse window")
        }
        Fault::SpindleSpeed { set_rpm, actual_rpm } => {
            format!("spindle did not reach {set_rpm:.1} rpm (is {actual_rpm:.1} rpm)")
        }
        Fault::LubeTimeout => "lubrication pressure not confirmed in time".into(),
        Fault::ClampTimeout => "X clamp did not report in time".into(),
        Fault::FeedbackLost { axis } => format!("feedback of drive {} lost (bus)", axis.name()),
        Fault::IoLost => "I/O coupler lost (bus)".into(),
        Fault::DriveNotEnabled { axis } => format!("drive {} not in \"operation enabled\"", axis.name()),
    }
}

/// The text of an encoded alarm ("" for none).
pub fn alarm_text(a: &AlarmCode) -> String {
    match (a.code, fault_from_alarm(a)) {
        (0, _) => String::new(),
        (_, Some(f)) => fault_text(f),
        (c, None) => format!("alarm code {c}"),
    }
}

/// The code of a coupling state (`StateSample::coupling`).
pub fn coupling_code(c: Coupling) -> u32 {
    match c {
        Coupling::Disengaged => 0,
        Coupling::Engaging => 1,
        Coupling::Phasing => 2,
        Coupling::Synchronised => 3,
        Coupling::Disengaging => 4,
    }
}

pub fn coupling_name(c: u32) -> &'static str {
    ["disengaged", "engaging", "phasing", "synchronised", "disengaging"]
        .get(c as usize)
        .copied()
        .unwrap_or("?")
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
    s.state = state_code(st.state);
    s.hold = u8::from(st.hold);
    s.program_loaded = u8::from(program_loaded);
    s.drives_enabled = bits(st.drives_enabled);
    s.drives_silent = bits(st.drives_silent);
    s.pass = st.pass;
    s.passes_total = passes_total;
    s.tooth = st.tooth;
    s.coupling = coupling_code(st.coupling);
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
        Command::Jog { axis, distance } => (command::JOG, 0, axis_code(axis), distance),
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
            axis: axis_from_code(axis)?,
            distance: value,
        },
        command::SPINDLE_ON => Command::SpindleOn { rpm: value },
        command::SPINDLE_OFF => Command::SpindleOff,
        command::NEW_BLANK => Command::NewBlank,
        _ => return None,
    })
}

/// The command's name as the CLI spells it.
pub fn command_name(code: u32) -> &'static str {
    match code {
        command::LOAD_PROGRAM => "load",
        command::START => "start",
        command::FEED_HOLD => "hold",
        command::RESUME => "resume",
        command::STOP => "stop",
        command::RESET => "reset",
        command::JOG => "jog",
        command::SPINDLE_ON => "spindle on",
        command::SPINDLE_OFF => "spindle off",
        command::NEW_BLANK => "new blank",
        _ => "?",
    }
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
            s.a = state_code(from);
            s.b = state_code(to);
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
            s.b = refusal_code(reason);
            s.value = value;
        }
        EventKind::ProgramLoaded => s.kind = event_kind::PROGRAM_LOADED,
        EventKind::CycleDone => s.kind = event_kind::CYCLE_DONE,
    }
    s
}

/// One line for an event (logger, `hob status --watch`, HMI).
pub fn event_text(e: &EventSample) -> String {
    match e.kind {
        event_kind::STATE_CHANGED => format!("state {} -> {}", state_name(e.a), state_name(e.b)),
        event_kind::ALARM => format!("ALARM {}", alarm_text(&e.alarm)),
        event_kind::ALARM_CLEARED => "alarm cleared".into(),
        event_kind::PASS_STARTED => format!("pass {} started", e.a),
        event_kind::PHASE_RECORDED => format!("tooth phase recorded: {:.4} deg", e.value),
        event_kind::ACCEPTED => format!("accepted: {}", command_name(e.a)),
        event_kind::REFUSED => format!(
            "refused: {}: {}",
            command_name(e.a),
            refusal_from_code(e.b).map_or("?", refusal_text)
        ),
        event_kind::PROGRAM_LOADED => "program loaded".into(),
        event_kind::CYCLE_DONE => "cycle done".into(),
        event_kind::BUS => bus_event_text(e),
        event_kind::MESSAGE => e.text(),
        k => format!("event kind {k}"),
    }
}

/// A bus event of the loop's CANopen master as an event sample (in the cycle: numbers
/// only, nothing formatted; [`event_text`] words it).
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

/// The operator's words for a bus event.
pub fn bus_event_text(e: &EventSample) -> String {
    let node = e.a;
    match e.b {
        bus_event::EMCY => {
            let code = e.value as u16;
            format!("EMCY node {node} 0x{code:04X}: {}", emcy_text(code))
        }
        bus_event::HEARTBEAT_LOST => format!("heartbeat of node {node} lost"),
        bus_event::TPDO_MISSING => format!("TPDO of node {node} missing {} cycles in a row", e.value),
        bus_event::SEND_FAILED => {
            let why = match e.a {
                send_error::QUEUE_FULL => BusError::Full.to_string(),
                send_error::INTERFACE_DOWN => BusError::Down.to_string(),
                _ => BusError::Os(e.value as i32).to_string(),
            };
            format!("CAN send failed: {why}")
        }
        b => format!("bus event {b} of node {node}"),
    }
}

/// The name of a [`bus_kind`] code.
pub fn bus_kind_name(k: u8) -> &'static str {
    match k {
        bus_kind::SHARED_MEMORY => "shm",
        _ => "socketcan",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bus_event_is_worded_from_its_numbers() {
        use hob_canopen::emcy::Emcy;
        let cases = [
            (
                BusEvent::Emcy(Emcy {
                    node: 3,
                    code: 0x8611,
                    register: 0,
                    vendor: [0; 5],
                }),
                format!("EMCY node 3 0x8611: {}", emcy_text(0x8611)),
            ),
            (
                BusEvent::HeartbeatLost { node: 5 },
                "heartbeat of node 5 lost".into(),
            ),
            (
                BusEvent::TpdoMissing { node: 2, in_a_row: 4 },
                "TPDO of node 2 missing 4 cycles in a row".into(),
            ),
            (
                BusEvent::SendFailed(BusError::Full),
                "CAN send failed: transmit queue full".into(),
            ),
            (
                BusEvent::SendFailed(BusError::Os(105)),
                "CAN send failed: OS error 105".into(),
            ),
        ];
        for (be, text) in cases {
            let e = bus_event_sample(7, &be);
            assert_eq!((e.kind, e.cycle, e.text_len), (event_kind::BUS, 7, 0), "{be:?}");
            assert_eq!(event_text(&e), text);
        }
    }

    #[test]
    fn every_state_round_trips() {
        for s in STATES {
            assert_eq!(state_from_code(state_code(s)), Some(s));
        }
        assert_eq!(state_from_code(99), None);
    }

    #[test]
    fn every_refusal_round_trips_and_0_is_none() {
        for r in REFUSALS {
            assert_eq!(refusal_from_code(refusal_code(r)), Some(r));
        }
        assert_eq!(refusal_from_code(0), None);
    }

    #[test]
    fn faults_round_trip() {
        let faults = [
            Fault::SafetyChainOpen,
            Fault::HardwareLimit {
                axis: Axis::Y,
                end: End::Min,
            },
            Fault::FollowingError {
                axis: Axis::X,
                error: 0.25,
            },
            Fault::SpindleSpeed {
                set_rpm: 119.0,
                actual_rpm: 80.0,
            },
            Fault::DriveNotEnabled { axis: Axis::B },
            Fault::IoLost,
        ];
        for f in faults {
            assert_eq!(fault_from_alarm(&alarm(Some(f))), Some(f));
        }
        assert_eq!(fault_from_alarm(&alarm(None)), None);
        assert_eq!(alarm_text(&alarm(None)), "");
    }

    #[test]
    fn commands_round_trip() {
        let cmds = [
            Command::Start { single: true },
            Command::Jog {
                axis: Axis::B,
                distance: -12.5,
            },
            Command::SpindleOn { rpm: 100.0 },
            Command::NewBlank,
        ];
        for c in cmds {
            let (code, single, axis, value) = command_code(c);
            assert_eq!(command_from_code(code, single, axis, value), Some(c));
        }
        assert_eq!(command_from_code(command::JOG, 0, 9, 1.0), None);
        assert_eq!(command_from_code(command::LOAD_PROGRAM, 0, 0, 0.0), None);
    }
}
