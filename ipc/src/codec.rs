//! Every code of the contract between processes, as the number it is on the wire, and its
//! text: sequencer states, refusals, alarms (faults) with their axis and end, gearbox
//! couplings, commands, event kinds and bus events. Frontends decode with these and print
//! these texts, from the numbers alone, so a code reads the same everywhere; the loop's
//! side encodes its control core's types to them (`hob_service::encode`, exhaustive
//! matches: a new state without a code does not compile).
//!
//! The numbers are the wire format: never renumber one, only add new ones.

use crate::{AlarmCode, EventSample, bus_event, bus_kind, command, event_kind, send_error};
use hob_canopen::bus::BusError;
use hob_canopen::emcy::emcy_text;

/// A sequencer state ([`crate::StateSample::state`], [`event_kind::STATE_CHANGED`]'s `a` and `b`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum State {
    Init = 0,
    Idle = 1,
    Jog = 2,
    ToSafe = 3,
    ToStart = 4,
    SpindleUp = 5,
    Engage = 6,
    Infeed = 7,
    Plunge = 8,
    ExtraRev = 9,
    Clamp = 10,
    Cut = 11,
    Unclamp = 12,
    Retract = 13,
    Return = 14,
    Index = 15,
    Home = 16,
    Disengage = 17,
    SpindleDown = 18,
    FaultRetract = 19,
    FaultStop = 20,
    Faulted = 21,
    Referencing = 22,
}

impl State {
    /// Every state, in code order (`ALL[c].code() == c`).
    pub const ALL: [State; 23] = [
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
        State::Referencing,
    ];

    pub const fn code(self) -> u32 {
        self as u32
    }

    pub fn from_code(c: u32) -> Option<State> {
        Self::ALL.get(c as usize).copied()
    }

    /// The state's word (the trace's `state` column, `hob status`).
    pub const fn name(self) -> &'static str {
        match self {
            State::Init => "init",
            State::Idle => "idle",
            State::Jog => "jog",
            State::ToSafe => "safe",
            State::ToStart => "start",
            State::SpindleUp => "spin",
            State::Engage => "sync",
            State::Infeed => "infeed",
            State::Plunge => "plunge",
            State::ExtraRev => "rev",
            State::Clamp => "clamp",
            State::Cut => "cut",
            State::Unclamp => "unclamp",
            State::Retract => "retract",
            State::Return => "return",
            State::Index => "index",
            State::Home => "home",
            State::Disengage => "disengage",
            State::SpindleDown => "spindown",
            State::FaultRetract => "f_retract",
            State::FaultStop => "f_stop",
            State::Faulted => "fault",
            State::Referencing => "referencing",
        }
    }
}

/// The state's name, or `?<code>` for a code this build does not know.
pub fn state_name(c: u32) -> String {
    State::from_code(c).map_or_else(|| format!("?{c}"), |s| s.name().to_string())
}

/// Why the loop refused a command ([`crate::CommandResponse::refusal`], the `b` of
/// [`event_kind::REFUSED`]). Codes start at 1; 0: the request itself was malformed or the
/// program failed its check.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Refusal {
    NoProgram = 1,
    CycleRunning = 2,
    Faulted = 3,
    NotReady = 4,
    NothingToDo = 5,
    OutsideSoftLimits = 6,
    NoSingleDepth = 7,
    BadValue = 8,
    SafetyChainOpen = 9,
    DrivesNotEnabled = 10,
    NotReferenced = 11,
    TablePositionLost = 12,
    JogActive = 13,
}

impl Refusal {
    /// Every refusal, in code order (`ALL[i].code() == i + 1`).
    pub const ALL: [Refusal; 13] = [
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
        Refusal::NotReferenced,
        Refusal::TablePositionLost,
        Refusal::JogActive,
    ];

    pub const fn code(self) -> u32 {
        self as u32
    }

    pub fn from_code(c: u32) -> Option<Refusal> {
        c.checked_sub(1).and_then(|i| Self::ALL.get(i as usize).copied())
    }

    pub const fn name(self) -> &'static str {
        match self {
            Refusal::NoProgram => "no-program",
            Refusal::CycleRunning => "cycle-running",
            Refusal::Faulted => "faulted",
            Refusal::NotReady => "not-ready",
            Refusal::NothingToDo => "nothing-to-do",
            Refusal::OutsideSoftLimits => "outside-soft-limits",
            Refusal::NoSingleDepth => "no-single-depth",
            Refusal::BadValue => "bad-value",
            Refusal::SafetyChainOpen => "safety-chain-open",
            Refusal::DrivesNotEnabled => "drives-not-enabled",
            Refusal::NotReferenced => "not-referenced",
            Refusal::TablePositionLost => "table-position-lost",
            Refusal::JogActive => "jog-active",
        }
    }

    /// What the operator reads for a refusal.
    pub const fn text(self) -> &'static str {
        match self {
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
            Refusal::NotReferenced => {
                "X and Y are not referenced: only referencing (hob home) and slow jogs until they are"
            }
            Refusal::TablePositionLost => {
                "the table lost its position since the tooth phase was recorded: continuing would cut a new set of gaps into this part"
            }
            Refusal::JogActive => "a jog is running: release it (or stop) first",
        }
    }
}

/// The text of a refusal code (`?<code>` for one this build does not know).
pub fn refusal_text(c: u32) -> String {
    Refusal::from_code(c).map_or_else(|| format!("?{c}"), |r| r.text().to_string())
}

/// An axis ([`AlarmCode::axis`], [`crate::CommandRequest::axis`]; 0: none).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Axis {
    B = 1,
    X = 2,
    Y = 3,
}

impl Axis {
    pub const ALL: [Axis; 3] = [Axis::B, Axis::X, Axis::Y];

    pub const fn code(self) -> u8 {
        self as u8
    }

    pub fn from_code(c: u8) -> Option<Axis> {
        c.checked_sub(1).and_then(|i| Self::ALL.get(i as usize).copied())
    }

    pub const fn name(self) -> &'static str {
        match self {
            Axis::B => "B",
            Axis::X => "X",
            Axis::Y => "Y",
        }
    }

    /// The unit of the axis's positions and distances.
    pub const fn unit(self) -> &'static str {
        match self {
            Axis::B => "deg",
            Axis::X | Axis::Y => "mm",
        }
    }

    /// The axis of a name as an operator types it (`x`, `Y`, `b`).
    pub fn parse(name: &str) -> Option<Axis> {
        match name.to_ascii_lowercase().as_str() {
            "b" => Some(Axis::B),
            "x" => Some(Axis::X),
            "y" => Some(Axis::Y),
            _ => None,
        }
    }
}

/// Which end of an axis ([`AlarmCode::end`]; 0: none).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum End {
    Min = 1,
    Max = 2,
}

impl End {
    pub const ALL: [End; 2] = [End::Min, End::Max];

    pub const fn code(self) -> u8 {
        self as u8
    }

    pub fn from_code(c: u8) -> Option<End> {
        c.checked_sub(1).and_then(|i| Self::ALL.get(i as usize).copied())
    }

    pub const fn name(self) -> &'static str {
        match self {
            End::Min => "min",
            End::Max => "max",
        }
    }
}

/// What stopped the machine ([`AlarmCode::code`]; 0: no alarm). Which of the alarm's
/// `axis`, `end`, `value_a`, `value_b` it uses is in [`Fault::text`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Fault {
    SafetyChainOpen = 1,
    EmergencyStop = 2,
    /// `axis`, `end`.
    HardwareLimit = 3,
    /// `axis`, `value_a`: the commanded position.
    SoftLimit = 4,
    /// `axis`, `value_a`: the error.
    FollowingError = 5,
    /// `axis`.
    DriveFault = 6,
    VfdFault = 7,
    /// `value_a`: the error, arcsec.
    SyncLost = 8,
    /// `value_a`: set, `value_b`: actual, rpm.
    SpindleSpeed = 9,
    LubeTimeout = 10,
    ClampTimeout = 11,
    /// `axis`.
    FeedbackLost = 12,
    IoLost = 13,
    /// `axis`.
    DriveNotEnabled = 14,
    /// `axis`, `end`: a [`HomingFailure`] code.
    HomingFailed = 15,
    /// `axis`.
    PositionLost = 16,
}

/// Why referencing failed (the `end` byte of a [`Fault::HomingFailed`] alarm).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum HomingFailure {
    ModeNotConfirmed = 1,
    NotStarted = 2,
    DriveError = 3,
    Timeout = 4,
}

impl HomingFailure {
    pub const ALL: [HomingFailure; 4] = [
        HomingFailure::ModeNotConfirmed,
        HomingFailure::NotStarted,
        HomingFailure::DriveError,
        HomingFailure::Timeout,
    ];

    pub const fn code(self) -> u8 {
        self as u8
    }

    pub fn from_code(c: u8) -> Option<HomingFailure> {
        c.checked_sub(1).and_then(|i| Self::ALL.get(i as usize).copied())
    }

    pub const fn text(self) -> &'static str {
        match self {
            HomingFailure::ModeNotConfirmed => "the drive did not confirm the mode of operation (0x6061)",
            HomingFailure::NotStarted => "the drive did not start homing",
            HomingFailure::DriveError => {
                "the drive reported a homing error (home switch not found before a limit?)"
            }
            HomingFailure::Timeout => "homing took longer than homing.timeout_s",
        }
    }
}

impl Fault {
    /// Every fault, in code order (`ALL[i].code() == i + 1`).
    pub const ALL: [Fault; 16] = [
        Fault::SafetyChainOpen,
        Fault::EmergencyStop,
        Fault::HardwareLimit,
        Fault::SoftLimit,
        Fault::FollowingError,
        Fault::DriveFault,
        Fault::VfdFault,
        Fault::SyncLost,
        Fault::SpindleSpeed,
        Fault::LubeTimeout,
        Fault::ClampTimeout,
        Fault::FeedbackLost,
        Fault::IoLost,
        Fault::DriveNotEnabled,
        Fault::HomingFailed,
        Fault::PositionLost,
    ];

    pub const fn code(self) -> u32 {
        self as u32
    }

    pub fn from_code(c: u32) -> Option<Fault> {
        c.checked_sub(1).and_then(|i| Self::ALL.get(i as usize).copied())
    }

    pub const fn name(self) -> &'static str {
        match self {
            Fault::SafetyChainOpen => "safety-chain-open",
            Fault::EmergencyStop => "emergency-stop",
            Fault::HardwareLimit => "hardware-limit",
            Fault::SoftLimit => "soft-limit",
            Fault::FollowingError => "following-error",
            Fault::DriveFault => "drive-fault",
            Fault::VfdFault => "vfd-fault",
            Fault::SyncLost => "sync-lost",
            Fault::SpindleSpeed => "spindle-speed",
            Fault::LubeTimeout => "lube-timeout",
            Fault::ClampTimeout => "clamp-timeout",
            Fault::FeedbackLost => "feedback-lost",
            Fault::IoLost => "io-lost",
            Fault::DriveNotEnabled => "drive-not-enabled",
            Fault::HomingFailed => "homing-failed",
            Fault::PositionLost => "position-lost",
        }
    }

    /// Whether the fault names an axis (its alarm is incomplete without one).
    pub const fn has_axis(self) -> bool {
        matches!(
            self,
            Fault::HardwareLimit
                | Fault::SoftLimit
                | Fault::FollowingError
                | Fault::DriveFault
                | Fault::FeedbackLost
                | Fault::DriveNotEnabled
                | Fault::HomingFailed
                | Fault::PositionLost
        )
    }

    /// The fault of an alarm: `None` for code 0, an unknown code, or a fault that names an
    /// axis without a valid one.
    pub fn of(a: &AlarmCode) -> Option<Fault> {
        let f = Fault::from_code(a.code)?;
        (!f.has_axis() || Axis::from_code(a.axis).is_some()).then_some(f)
    }

    /// Whether X can still move under this fault on `axis` (else the machine stops where
    /// it is instead of retracting): the control core's `Fault::x_can_move`, read from the
    /// wire (hob-service's tests check the two agree for every fault).
    pub fn x_can_move(self, a: &AlarmCode) -> bool {
        let x = Axis::from_code(a.axis) == Some(Axis::X);
        !match self {
            Fault::DriveFault
            | Fault::DriveNotEnabled
            | Fault::FollowingError
            | Fault::FeedbackLost
            | Fault::SoftLimit
            | Fault::PositionLost
            | Fault::HomingFailed => x,
            Fault::HardwareLimit => x && End::from_code(a.end) != Some(End::Min),
            _ => false,
        }
    }

    /// Whether the table can still follow the spindle under this fault (else the spindle
    /// stops and the gearbox disengages at once): the control core's
    /// `Fault::table_can_follow`, read from the wire.
    pub fn table_can_follow(self, a: &AlarmCode) -> bool {
        let b = Axis::from_code(a.axis) == Some(Axis::B);
        !match self {
            Fault::DriveFault
            | Fault::DriveNotEnabled
            | Fault::FollowingError
            | Fault::FeedbackLost
            | Fault::PositionLost => b,
            Fault::SyncLost => true,
            _ => false,
        }
    }

    /// What the machine did on this fault, in the operator's words (docs: README, "What a
    /// fault does").
    pub fn reaction(self, a: &AlarmCode) -> &'static str {
        if !self.x_can_move(a) {
            "in a cycle X cannot move: the machine stopped where it is (gearbox out, spindle and \
             axes to rest), then PC-OK dropped and the safety chain opened; outside a cycle the \
             spindle stopped and PC-OK dropped at once"
        } else if !self.table_can_follow(a) {
            "in the cut the table could no longer follow: the spindle stopped and the gearbox \
             disengaged at once, X pulled the hob out of the work, then PC-OK dropped; outside a \
             cycle the spindle stopped and PC-OK dropped at once"
        } else {
            "in the cut X retracted with the gearbox still engaged (the hob left its tooth gap), \
             then the machine stopped (gearbox out, spindle and axes to rest), then PC-OK \
             dropped; outside a cycle the spindle stopped and PC-OK dropped at once"
        }
    }

    /// What the operator checks or repairs before RESET.
    pub const fn remedy(self) -> &'static str {
        match self {
            Fault::SafetyChainOpen => {
                "find what opened the chain (e-stop, limit switch, VFD fault relay, PC-OK): \
                 POWER-UP shows each condition of its reset; then press the reset button"
            }
            Fault::EmergencyStop => {
                "release the e-stop button once the danger is gone, then the reset button"
            }
            Fault::HardwareLimit => {
                "the axis is on its limit switch: find why it got there (offsets, program, a \
                 lost reference); move it off the switch in the other direction by jog after RESET"
            }
            Fault::SoftLimit => {
                "check the program's positions and the work offsets (touch-off) against the axis's travel"
            }
            Fault::FollowingError => {
                "the axis could not follow its command: look for an obstruction, a collision, \
                 a seized slide, a brake not released or a drive at its current limit"
            }
            Fault::DriveFault => {
                "read the drive's EMCY in DIAGNOSTICS (over-current, over-temperature, encoder), \
                 repair the cause at the drive"
            }
            Fault::VfdFault => "read the fault code on the spindle VFD's display and repair its cause",
            Fault::SyncLost => {
                "the table left the coarse window: check the spindle encoder and its coupling, \
                 the table drive's tuning and the cutting load (speeds, feed, worn hob)"
            }
            Fault::SpindleSpeed => {
                "the spindle did not reach its speed: check the VFD (enable, its own fault), the \
                 belt and the spindle encoder"
            }
            Fault::LubeTimeout => "check the lubricant level, the pump, the filter and the pressure switch",
            Fault::ClampTimeout => "check the X clamp's magnet, its supply and its feedback switch",
            Fault::FeedbackLost => {
                "the drive's position frames stopped: check its CAN cable and connector, its \
                 supply, the bus termination; DIAGNOSTICS lists the heartbeats and EMCYs"
            }
            Fault::IoLost => "the I/O coupler stopped answering: check its CAN cable, supply and node id",
            Fault::DriveNotEnabled => {
                "the drive did not reach \"operation enabled\": check its enable input (safety \
                 chain), its supply and its own fault"
            }
            Fault::HomingFailed => {
                "check the home switch and its cable, the homing speeds and the axis's travel \
                 ([x.homing], [y.homing] in the machine file)"
            }
            Fault::PositionLost => {
                "the drive restarted or its encoder jumped: check its supply and encoder cable; \
                 its reference (or the part's tooth phase on the table) is gone"
            }
        }
    }

    /// How work goes on after the remedy.
    pub const fn how_to_continue(self) -> &'static str {
        match self {
            Fault::PositionLost | Fault::HomingFailed => {
                "RESET, reference X and Y again (HOME); a part on the table has lost its tooth \
                 phase if B lost its position: NEW BLANK, CONTINUE is refused"
            }
            Fault::FeedbackLost => {
                "RESET; if the drive kept its position, CONTINUE re-enters the interrupted pass; \
                 if it restarted, reference again (HOME), and for B: NEW BLANK"
            }
            Fault::SafetyChainOpen | Fault::EmergencyStop => {
                "reset button on the panel, then RESET; CONTINUE re-enters the interrupted pass \
                 on the same tooth gaps"
            }
            _ => {
                "RESET, then CONTINUE re-enters the interrupted pass on the same tooth gaps (or START a new cycle)"
            }
        }
    }

    /// What the operator reads for an alarm of this fault (its axis, end and values
    /// from `a`); `None` if the fault names an axis and `a` has none.
    pub fn text(self, a: &AlarmCode) -> Option<String> {
        let axis = Axis::from_code(a.axis);
        let (va, vb) = (a.value_a, a.value_b);
        Some(match self {
            Fault::SafetyChainOpen => "safety chain open".into(),
            Fault::EmergencyStop => "emergency stop pressed".into(),
            Fault::HardwareLimit => {
                // End 1 is min; anything else reads as max (as it always has).
                let end = if End::from_code(a.end) == Some(End::Min) {
                    End::Min
                } else {
                    End::Max
                };
                format!("hardware limit {} {}", axis?.name(), end.name())
            }
            Fault::SoftLimit => {
                let axis = axis?;
                format!("soft limit {}: {va:.3} {}", axis.name(), axis.unit())
            }
            Fault::FollowingError => {
                let axis = axis?;
                format!("following error {}: {va:.4} {}", axis.name(), axis.unit())
            }
            Fault::DriveFault => format!("drive fault {}", axis?.name()),
            Fault::VfdFault => "spindle VFD fault".into(),
            Fault::SyncLost => format!("synchronisation lost: {va:.1} arcsec outside the coarse window"),
            Fault::SpindleSpeed => format!("spindle did not reach {va:.1} rpm (is {vb:.1} rpm)"),
            Fault::LubeTimeout => "lubrication pressure not confirmed in time".into(),
            Fault::ClampTimeout => "X clamp did not report in time".into(),
            Fault::FeedbackLost => format!("feedback of drive {} lost (bus)", axis?.name()),
            Fault::IoLost => "I/O coupler lost (bus)".into(),
            Fault::DriveNotEnabled => format!("drive {} not in \"operation enabled\"", axis?.name()),
            Fault::HomingFailed => format!(
                "referencing {} failed: {}",
                axis?.name(),
                HomingFailure::from_code(a.end).map_or("?", HomingFailure::text)
            ),
            Fault::PositionLost => {
                let axis = axis?;
                let what = if axis == Axis::B {
                    "the tooth phase of the part on the table is gone"
                } else {
                    "reference it again (hob home)"
                };
                format!(
                    "drive {} lost its position (reboot or encoder): {what}",
                    axis.name()
                )
            }
        })
    }
}

/// The text of an alarm ("" for none, `alarm code <c>` for one this build cannot word).
pub fn alarm_text(a: &AlarmCode) -> String {
    if a.code == 0 {
        return String::new();
    }
    Fault::of(a)
        .and_then(|f| f.text(a))
        .unwrap_or_else(|| format!("alarm code {}", a.code))
}

/// Where the gearbox is ([`crate::StateSample::coupling`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum Coupling {
    Disengaged = 0,
    Engaging = 1,
    Phasing = 2,
    Synchronised = 3,
    Disengaging = 4,
}

impl Coupling {
    /// Every coupling, in code order (`ALL[c].code() == c`).
    pub const ALL: [Coupling; 5] = [
        Coupling::Disengaged,
        Coupling::Engaging,
        Coupling::Phasing,
        Coupling::Synchronised,
        Coupling::Disengaging,
    ];

    pub const fn code(self) -> u32 {
        self as u32
    }

    pub fn from_code(c: u32) -> Option<Coupling> {
        Self::ALL.get(c as usize).copied()
    }

    pub const fn name(self) -> &'static str {
        match self {
            Coupling::Disengaged => "disengaged",
            Coupling::Engaging => "engaging",
            Coupling::Phasing => "phasing",
            Coupling::Synchronised => "synchronised",
            Coupling::Disengaging => "disengaging",
        }
    }
}

/// The name of a coupling code (`?` for one this build does not know).
pub fn coupling_name(c: u32) -> &'static str {
    Coupling::from_code(c).map_or("?", Coupling::name)
}

/// Every [`command`] code, in code order.
pub const COMMANDS: [u32; 17] = [
    command::LOAD_PROGRAM,
    command::START,
    command::FEED_HOLD,
    command::RESUME,
    command::STOP,
    command::RESET,
    command::JOG,
    command::SPINDLE_ON,
    command::SPINDLE_OFF,
    command::NEW_BLANK,
    command::HOME,
    command::JOG_CONTINUOUS,
    command::JOG_RELEASE,
    command::FEED_OVERRIDE,
    command::SPINDLE_OVERRIDE,
    command::TOUCH_OFF,
    command::CONTINUE,
];

/// The command's name as the CLI spells it (`?` for a code this build does not know).
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
        command::HOME => "home",
        command::JOG_CONTINUOUS => "jog continuous",
        command::JOG_RELEASE => "jog release",
        command::FEED_OVERRIDE => "feed override",
        command::SPINDLE_OVERRIDE => "spindle override",
        command::TOUCH_OFF => "touch-off",
        command::CONTINUE => "continue",
        _ => "?",
    }
}

/// Every [`event_kind`] code, in code order.
pub const EVENT_KINDS: [u32; 14] = [
    event_kind::STATE_CHANGED,
    event_kind::ALARM,
    event_kind::ALARM_CLEARED,
    event_kind::PASS_STARTED,
    event_kind::PHASE_RECORDED,
    event_kind::ACCEPTED,
    event_kind::REFUSED,
    event_kind::PROGRAM_LOADED,
    event_kind::CYCLE_DONE,
    event_kind::MESSAGE,
    event_kind::BUS,
    event_kind::REFERENCED,
    event_kind::DEAD_MAN_STOP,
    event_kind::OFFSET_CHANGED,
];

/// The name of an [`event_kind`] code (`None` for one this build does not know).
pub fn event_kind_name(k: u32) -> Option<&'static str> {
    Some(match k {
        event_kind::STATE_CHANGED => "state-changed",
        event_kind::ALARM => "alarm",
        event_kind::ALARM_CLEARED => "alarm-cleared",
        event_kind::PASS_STARTED => "pass-started",
        event_kind::PHASE_RECORDED => "phase-recorded",
        event_kind::ACCEPTED => "accepted",
        event_kind::REFUSED => "refused",
        event_kind::PROGRAM_LOADED => "program-loaded",
        event_kind::CYCLE_DONE => "cycle-done",
        event_kind::MESSAGE => "message",
        event_kind::BUS => "bus",
        event_kind::REFERENCED => "referenced",
        event_kind::DEAD_MAN_STOP => "dead-man-stop",
        event_kind::OFFSET_CHANGED => "offset-changed",
        _ => return None,
    })
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
            Refusal::from_code(e.b).map_or("?", Refusal::text)
        ),
        event_kind::PROGRAM_LOADED => "program loaded".into(),
        event_kind::CYCLE_DONE => "cycle done".into(),
        event_kind::BUS => bus_event_text(e),
        event_kind::MESSAGE => e.text(),
        event_kind::REFERENCED => format!("{} referenced", axis_name(e.a)),
        event_kind::DEAD_MAN_STOP => {
            format!("jog {} stopped: its renewals stopped (dead-man)", axis_name(e.a))
        }
        event_kind::OFFSET_CHANGED => format!("touch-off: {} offset {:+.4} mm", axis_name(e.a), e.value),
        k => format!("event kind {k}"),
    }
}

fn axis_name(code: u32) -> &'static str {
    u8::try_from(code)
        .ok()
        .and_then(Axis::from_code)
        .map_or("?", Axis::name)
}

/// Every [`bus_event`] code, in code order.
pub const BUS_EVENTS: [u32; 4] = [
    bus_event::EMCY,
    bus_event::HEARTBEAT_LOST,
    bus_event::TPDO_MISSING,
    bus_event::SEND_FAILED,
];

/// The name of a [`bus_event`] code (`None` for one this build does not know).
pub fn bus_event_name(b: u32) -> Option<&'static str> {
    Some(match b {
        bus_event::EMCY => "emcy",
        bus_event::HEARTBEAT_LOST => "heartbeat-lost",
        bus_event::TPDO_MISSING => "tpdo-missing",
        bus_event::SEND_FAILED => "send-failed",
        _ => return None,
    })
}

/// The operator's words for a bus event ([`event_kind::BUS`]).
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
    use std::collections::BTreeSet;

    fn distinct<'a>(names: impl IntoIterator<Item = &'a str>) -> bool {
        let names: Vec<&str> = names.into_iter().collect();
        names.iter().collect::<BTreeSet<_>>().len() == names.len() && names.iter().all(|n| !n.is_empty())
    }

    #[test]
    fn every_code_is_its_position_and_round_trips() {
        for (i, s) in State::ALL.into_iter().enumerate() {
            assert_eq!(s.code(), i as u32);
            assert_eq!(State::from_code(s.code()), Some(s));
        }
        for (i, r) in Refusal::ALL.into_iter().enumerate() {
            assert_eq!(r.code(), i as u32 + 1);
            assert_eq!(Refusal::from_code(r.code()), Some(r));
        }
        for (i, f) in Fault::ALL.into_iter().enumerate() {
            assert_eq!(f.code(), i as u32 + 1);
            assert_eq!(Fault::from_code(f.code()), Some(f));
        }
        for (i, c) in Coupling::ALL.into_iter().enumerate() {
            assert_eq!(c.code(), i as u32);
            assert_eq!(Coupling::from_code(c.code()), Some(c));
        }
        for (i, a) in Axis::ALL.into_iter().enumerate() {
            assert_eq!(a.code(), i as u8 + 1);
            assert_eq!(Axis::from_code(a.code()), Some(a));
            assert_eq!(Axis::parse(&a.name().to_lowercase()), Some(a));
        }
        for (i, e) in End::ALL.into_iter().enumerate() {
            assert_eq!(e.code(), i as u8 + 1);
            assert_eq!(End::from_code(e.code()), Some(e));
        }
        for (i, c) in COMMANDS.into_iter().enumerate() {
            assert_eq!(c, i as u32 + 1);
        }
        for (i, k) in EVENT_KINDS.into_iter().enumerate() {
            assert_eq!(k, i as u32 + 1);
        }
        for (i, b) in BUS_EVENTS.into_iter().enumerate() {
            assert_eq!(b, i as u32 + 1);
        }
    }

    #[test]
    fn every_code_has_a_distinct_name() {
        assert!(distinct(State::ALL.map(State::name)));
        assert!(distinct(Refusal::ALL.map(Refusal::name)));
        assert!(distinct(Refusal::ALL.map(Refusal::text)));
        assert!(distinct(Fault::ALL.map(Fault::name)));
        assert!(distinct(Coupling::ALL.map(Coupling::name)));
        assert!(distinct(Axis::ALL.map(Axis::name)));
        assert!(distinct(End::ALL.map(End::name)));
        assert!(distinct(COMMANDS.map(command_name)));
        assert!(distinct(EVENT_KINDS.map(|k| event_kind_name(k).unwrap())));
        assert!(distinct(BUS_EVENTS.map(|b| bus_event_name(b).unwrap())));
        // Every alarm reads differently, given an axis and values.
        let texts: Vec<String> = Fault::ALL
            .iter()
            .map(|f| {
                let a = AlarmCode {
                    code: f.code(),
                    axis: Axis::X.code(),
                    end: End::Min.code(),
                    value_a: 1.0,
                    value_b: 2.0,
                    ..AlarmCode::default()
                };
                alarm_text(&a)
            })
            .collect();
        assert!(distinct(texts.iter().map(String::as_str)), "{texts:?}");
    }

    #[test]
    fn unknown_codes_decode_to_none() {
        assert_eq!(State::from_code(State::ALL.len() as u32), None);
        assert_eq!(state_name(99), "?99");
        assert_eq!(Refusal::from_code(0), None);
        assert_eq!(Refusal::from_code(Refusal::ALL.len() as u32 + 1), None);
        assert_eq!(refusal_text(42), "?42");
        assert_eq!(Fault::from_code(0), None);
        assert_eq!(Fault::from_code(Fault::ALL.len() as u32 + 1), None);
        assert_eq!(Coupling::from_code(5), None);
        assert_eq!(coupling_name(5), "?");
        assert_eq!(Axis::from_code(0), None);
        assert_eq!(Axis::from_code(4), None);
        assert_eq!(Axis::parse("z"), None);
        assert_eq!(End::from_code(0), None);
        assert_eq!(End::from_code(3), None);
        assert_eq!(command_name(0), "?");
        assert_eq!(command_name(COMMANDS.len() as u32 + 1), "?");
        assert_eq!(event_kind_name(0), None);
        assert_eq!(event_kind_name(EVENT_KINDS.len() as u32 + 1), None);
        assert_eq!(bus_event_name(5), None);
        let e = EventSample {
            kind: 99,
            ..EventSample::default()
        };
        assert_eq!(event_text(&e), "event kind 99");
    }

    #[test]
    fn alarms_are_worded_from_their_numbers() {
        assert_eq!(alarm_text(&AlarmCode::default()), "");
        let a = |code: u32, axis: u8, end: u8, va: f64, vb: f64| AlarmCode {
            code,
            axis,
            end,
            value_a: va,
            value_b: vb,
            ..AlarmCode::default()
        };
        assert_eq!(alarm_text(&a(3, 3, 1, 0.0, 0.0)), "hardware limit Y min");
        assert_eq!(alarm_text(&a(3, 1, 2, 0.0, 0.0)), "hardware limit B max");
        assert_eq!(alarm_text(&a(4, 1, 0, 12.5, 0.0)), "soft limit B: 12.500 deg");
        assert_eq!(alarm_text(&a(5, 2, 0, 0.25, 0.0)), "following error X: 0.2500 mm");
        assert_eq!(
            alarm_text(&a(9, 0, 0, 119.0, 80.0)),
            "spindle did not reach 119.0 rpm (is 80.0 rpm)"
        );
        // A fault that names an axis, without one; an unknown code.
        assert_eq!(alarm_text(&a(12, 0, 0, 0.0, 0.0)), "alarm code 12");
        assert_eq!(Fault::of(&a(12, 0, 0, 0.0, 0.0)), None);
        assert_eq!(Fault::of(&a(13, 0, 0, 0.0, 0.0)), Some(Fault::IoLost));
        assert_eq!(alarm_text(&a(77, 0, 0, 0.0, 0.0)), "alarm code 77");
    }

    #[test]
    fn events_are_worded_from_their_numbers() {
        let e = |kind: u32, a: u32, b: u32| EventSample {
            kind,
            a,
            b,
            ..EventSample::default()
        };
        assert_eq!(
            event_text(&e(
                event_kind::STATE_CHANGED,
                State::Idle.code(),
                State::Cut.code()
            )),
            "state idle -> cut"
        );
        assert_eq!(
            event_text(&e(event_kind::STATE_CHANGED, 1, 40)),
            "state idle -> ?40"
        );
        assert_eq!(
            event_text(&e(event_kind::REFUSED, command::START, Refusal::NoProgram.code())),
            "refused: start: no program loaded: load one first (hob load PROGRAM)"
        );
        assert_eq!(
            event_text(&e(event_kind::REFUSED, command::START, 0)),
            "refused: start: ?"
        );
        assert_eq!(
            event_text(&e(event_kind::ACCEPTED, command::JOG, 0)),
            "accepted: jog"
        );
        let mut bus = e(event_kind::BUS, 5, bus_event::HEARTBEAT_LOST);
        assert_eq!(event_text(&bus), "heartbeat of node 5 lost");
        bus.b = 9;
        assert_eq!(event_text(&bus), "bus event 9 of node 5");
    }

    #[test]
    fn every_fault_says_what_the_machine_did_what_to_repair_and_how_to_go_on() {
        for f in Fault::ALL {
            for axis in [0u8, 1, 2, 3] {
                let a = AlarmCode {
                    code: f.code(),
                    axis,
                    end: 2,
                    ..AlarmCode::default()
                };
                assert!(f.reaction(&a).len() > 40, "{f:?} axis {axis}");
            }
            assert!(f.remedy().len() > 30, "{f:?}: {}", f.remedy());
            assert!(
                f.how_to_continue().starts_with("RESET") || f.how_to_continue().starts_with("reset"),
                "{f:?}"
            );
        }
        // The three reactions are told apart by the axis.
        let b = AlarmCode {
            code: Fault::DriveFault.code(),
            axis: Axis::B.code(),
            ..AlarmCode::default()
        };
        let x = AlarmCode {
            axis: Axis::X.code(),
            ..b
        };
        let y = AlarmCode {
            axis: Axis::Y.code(),
            ..b
        };
        let texts = [
            Fault::DriveFault.reaction(&b),
            Fault::DriveFault.reaction(&x),
            Fault::DriveFault.reaction(&y),
        ];
        assert!(texts[0].contains("disengaged at once") && texts[1].contains("stopped where it is"));
        assert!(texts[2].contains("retracted with the gearbox still engaged"));
    }
}
