//! The loop's side of the contract between processes: the control core's status, events,
//! commands and bus events to the wire's samples (and back where the loop needs it: a
//! request's command). The states, faults, refusals, axes and couplings need no encoding:
//! they are the wire's own vocabulary (`hob_wire::vocab`), their codes its. Every encoder
//! is an exhaustive `match`; none allocates (they run in the cycle).

use hob_canopen::bus::BusError;
use hob_control::events::{Event, EventKind};
use hob_control::fault::{Axis, Fault};
use hob_control::{Command, Direction, HomeAxes, Status};
use hob_ipc::{EventSample, StateSample, bus_event, command, direction, event_kind, send_error};
use hob_master::BusEvent;

fn bits(b: [bool; 3]) -> u8 {
    b.iter()
        .enumerate()
        .fold(0, |acc, (i, &on)| acc | (u8::from(on) << i))
}

/// Fills a state sample from the controller's status (allocation-free). Timing, I/O
/// image and counters are the loop's to fill.
pub fn fill_state(s: &mut StateSample, st: &Status, passes_total: u32, program_loaded: bool) {
    s.cycle = st.cycle;
    s.state = st.state.code();
    s.hold = u8::from(st.hold);
    s.program_loaded = u8::from(program_loaded);
    s.drives_enabled = bits(st.drives_enabled);
    s.drives_silent = bits(st.drives_silent);
    s.pass = st.pass;
    s.passes_total = passes_total;
    s.tooth = st.tooth;
    s.coupling = st.coupling.code();
    s.table_deg.actual = st.table_deg;
    s.table_deg.command = st.table_cmd_deg;
    s.x_mm.actual = st.x_mm;
    s.x_mm.command = st.x_cmd_mm;
    s.y_mm.actual = st.y_mm;
    s.y_mm.command = st.y_cmd_mm;
    s.spindle_deg = st.spindle_deg;
    s.spindle_reading_deg = st.spindle_reading_deg;
    s.table_gauge_counts = st.table_gauge_counts;
    s.spindle_rpm = st.spindle_rpm;
    s.spindle_set_rpm = st.spindle_set_rpm;
    s.sync_error_arcsec = st.sync_error_arcsec;
    s.ccc_arcsec = st.ccc_arcsec;
    s.alarm = Fault::alarm(st.fault);
    if st.fault.is_some() {
        s.alarm.situation = st.fault_met.situation();
    }
    s.referenced = bits([st.table_position_whole, st.referenced[0], st.referenced[1]]);
    s.moving_axis = st.moving_axis.map_or(0, Axis::code);
    s.continue_pass = st.continue_pass;
    s.continue_from_y_mm = st.continue_from_y_mm.unwrap_or(f64::NAN);
    s.feed_override_percent = st.feed_override_percent;
    s.spindle_override_percent = st.spindle_override_percent;
    s.x_offset_mm = st.offsets.x_mm;
    s.y_offset_mm = st.offsets.y_mm;
    s.pitch_compensation = st.pitch_compensation;
}

/// A command as it travels in a [`hob_ipc::CommandRequest`]: its code and arguments.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Args {
    pub code: u32,
    pub single: u8,
    pub axis: u8,
    pub direction: u8,
    /// TOUCH_OFF: 1 when confirmed.
    pub confirm: u8,
    pub value: f64,
}

impl Args {
    const fn of(code: u32) -> Self {
        Args {
            code,
            single: 0,
            axis: 0,
            direction: 0,
            confirm: 0,
            value: 0.0,
        }
    }

    const fn axis(self, a: Axis) -> Self {
        Args {
            axis: a.code(),
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
            confirm: r.confirm,
            value: r.value,
        }
    }

    /// Writes them into a request.
    pub fn to_request(self, r: &mut hob_ipc::CommandRequest) {
        r.command = self.code;
        r.single = self.single;
        r.axis = self.axis;
        r.direction = self.direction;
        r.confirm = self.confirm;
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
        Command::ExciteTable { frequency_hz, creep } => Args {
            direction: direction_code(creep),
            ..Args::of(command::EXCITE_TABLE).value(frequency_hz)
        },
        Command::PitchCompensation { on } => {
            Args::of(command::PITCH_COMPENSATION).value(if on { 1.0 } else { 0.0 })
        }
        Command::FeedOverride { percent } => Args::of(command::FEED_OVERRIDE).value(percent),
        Command::SpindleOverride { percent } => Args::of(command::SPINDLE_OVERRIDE).value(percent),
        Command::TouchOff {
            axis: a,
            value_mm,
            confirmed,
        } => Args {
            confirm: confirmed as u8,
            ..Args::of(command::TOUCH_OFF).axis(a).value(value_mm)
        },
        Command::Continue => Args::of(command::CONTINUE),
        Command::TouchFlank { turned } => Args {
            direction: direction_code(turned),
            ..Args::of(command::TOUCH_FLANK)
        },
    }
}

/// A command from its code and arguments (`None`: LOAD_PROGRAM, unknown code, bad axis
/// or direction, a pitch compensation's value other than 1 or 0).
pub fn command_from_code(a: &Args) -> Option<Command> {
    let ax = || Axis::from_code(a.axis);
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
        command::EXCITE_TABLE => Command::ExciteTable {
            frequency_hz: a.value,
            creep: direction_of(a.direction)?,
        },
        command::PITCH_COMPENSATION => Command::PitchCompensation {
            on: match a.value {
                1.0 => true,
                0.0 => false,
                _ => return None,
            },
        },
        command::FEED_OVERRIDE => Command::FeedOverride { percent: a.value },
        command::SPINDLE_OVERRIDE => Command::SpindleOverride { percent: a.value },
        command::TOUCH_OFF => Command::TouchOff {
            axis: ax()?,
            value_mm: a.value,
            confirmed: a.confirm != 0,
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
            s.a = from.code();
            s.b = to.code();
        }
        EventKind::Fault(f) => {
            s.kind = event_kind::ALARM;
            s.alarm = Fault::alarm(Some(f));
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
            s.b = u32::from(a.single)
                | (u32::from(a.axis) << 8)
                | (u32::from(a.direction) << 16)
                | (u32::from(a.confirm) << 24);
            s.value = a.value;
        }
        EventKind::Refused { command, reason } => {
            s.kind = event_kind::REFUSED;
            let a = command_code(command);
            s.a = a.code;
            s.b = reason.code();
            s.value = a.value;
        }
        EventKind::ProgramLoaded => s.kind = event_kind::PROGRAM_LOADED,
        EventKind::CycleDone => s.kind = event_kind::CYCLE_DONE,
        EventKind::Referenced { axis: a } => {
            s.kind = event_kind::REFERENCED;
            s.a = u32::from(a.code());
        }
        EventKind::DeadManStop { axis: a } => {
            s.kind = event_kind::DEAD_MAN_STOP;
            s.a = u32::from(a.code());
        }
        EventKind::SpindleDeadManStop => {
            // Axis 0: the hob spindle C (it has no axis code of its own).
            s.kind = event_kind::DEAD_MAN_STOP;
        }
        EventKind::OffsetChanged { axis: a, offset_mm } => {
            s.kind = event_kind::OFFSET_CHANGED;
            s.a = u32::from(a.code());
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
