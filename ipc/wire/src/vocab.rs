//! The machine's vocabulary, written once: every code table the control core and the
//! wire share (sequencer states, refusals, axes and their ends, homing failures, gearbox
//! couplings) with the number each value is on the wire and its words, and the control
//! core's [`Fault`] with the alarm it travels as. The control core uses these types
//! themselves (`hob_control` re-exports them); the frontends read the same codes from the
//! wire with [`crate::codec`]. Adding a state or a refusal is one entry here; adding a
//! fault is a variant of [`Fault`] plus its alarm code ([`codec::Fault`], with its words,
//! reaction and remedy) and the control core's handling.
//!
//! The numbers are the wire format: never renumber one, only add new ones
//! (`tests/reference.rs` holds every code as it was).

use crate::AlarmCode;
use crate::codec;

/// A sequencer state ([`crate::StateSample::state`], [`crate::event_kind::STATE_CHANGED`]'s `a` and `b`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize)]
#[repr(u32)]
pub enum State {
    /// Power-up: waiting for the safety chain and the first lubrication.
    #[default]
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

    /// Whether the tool may be in (or touching) the work.
    pub fn tool_in_work(self) -> bool {
        matches!(
            self,
            State::Plunge | State::ExtraRev | State::Clamp | State::Cut | State::Unclamp | State::Retract
        )
    }

    /// Whether a cycle is running.
    pub fn in_cycle(self) -> bool {
        !matches!(
            self,
            State::Init | State::Idle | State::Jog | State::Faulted | State::Referencing
        )
    }
}

/// Why the loop refused a command ([`crate::CommandResponse::refusal`], the `b` of
/// [`crate::event_kind::REFUSED`]). Codes start at 1; 0: the request itself was malformed or the
/// program failed its check.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
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
    SpindleTurning = 14,
    FlanksCrossed = 15,
}

impl Refusal {
    /// Every refusal, in code order (`ALL[i].code() == i + 1`).
    pub const ALL: [Refusal; 15] = [
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
        Refusal::SpindleTurning,
        Refusal::FlanksCrossed,
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
            Refusal::SpindleTurning => "spindle-turning",
            Refusal::FlanksCrossed => "flanks-crossed",
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
                "the table lost its position since the tooth phase was recorded: continuing would cut a new set of gaps into this part (touch both flanks of a cut gap to align to it: hob touch-flank)"
            }
            Refusal::JogActive => "a jog is running: release it (or stop) first",
            Refusal::SpindleTurning => {
                "the spindle turns: a flank touch needs the hob standing still (spindle off)"
            }
            Refusal::FlanksCrossed => {
                "this flank lies on the wrong side of the other one: the table is turned positive to touch one flank of the gap and negative to touch the other"
            }
        }
    }
}

/// An axis ([`crate::AlarmCode::axis`], [`crate::CommandRequest::axis`]; 0: none).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
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

/// Which end of an axis ([`crate::AlarmCode::end`]; 0: none).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
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

/// Why referencing failed (the `end` byte of a [`Fault::HomingFailed`] alarm).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
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

/// Where the gearbox is ([`crate::StateSample::coupling`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
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

/// Something that stops the machine.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Fault {
    /// The safety relay opened the chain (e-stop, hardware limit, VFD fault relay).
    SafetyChainOpen,
    /// E-stop button pressed.
    EmergencyStop,
    /// A hardware limit switch.
    HardwareLimit { axis: Axis, end: End },
    /// A commanded position outside the soft limits.
    SoftLimit { axis: Axis, position: f64 },
    /// Actual position too far from the command (mm, or deg for B).
    FollowingError { axis: Axis, error: f64 },
    /// The drive reports a fault.
    DriveFault { axis: Axis },
    /// The VFD's fault relay.
    VfdFault,
    /// Synchronisation error left the coarse window in the cut (arcsec).
    SyncLost { error_arcsec: f64 },
    /// The spindle did not reach its speed in time.
    SpindleSpeed { set_rpm: f64, actual_rpm: f64 },
    /// The lube pressure switch did not confirm in time.
    LubeTimeout,
    /// The X clamp did not report in time.
    ClampTimeout,
    /// A drive's feedback did not arrive (bus).
    FeedbackLost { axis: Axis },
    /// The I/O coupler's inputs are not current (its heartbeat is lost).
    IoLost,
    /// A drive did not reach, or left, "operation enabled" while it should be enabled.
    DriveNotEnabled { axis: Axis },
    /// Referencing an axis failed.
    HomingFailed { axis: Axis, why: HomingFailure },
    /// A drive's position jumped (a reboot of the drive, an encoder fault): its
    /// reference (X, Y) or the table's tooth phase (B) is gone.
    PositionLost { axis: Axis },
}

impl Fault {
    /// Whether X can still be retracted after this fault.
    pub fn x_can_move(&self) -> bool {
        !matches!(
            self,
            Fault::DriveFault { axis: Axis::X }
                | Fault::DriveNotEnabled { axis: Axis::X }
                | Fault::FollowingError { axis: Axis::X, .. }
                | Fault::FeedbackLost { axis: Axis::X }
                | Fault::HardwareLimit {
                    axis: Axis::X,
                    end: End::Max
                }
                | Fault::SoftLimit { axis: Axis::X, .. }
                | Fault::PositionLost { axis: Axis::X }
                | Fault::HomingFailed { axis: Axis::X, .. }
        )
    }

    /// Whether the table can still follow the spindle during the retract.
    pub fn table_can_follow(&self) -> bool {
        !matches!(
            self,
            Fault::DriveFault { axis: Axis::B }
                | Fault::DriveNotEnabled { axis: Axis::B }
                | Fault::FollowingError { axis: Axis::B, .. }
                | Fault::FeedbackLost { axis: Axis::B }
                | Fault::PositionLost { axis: Axis::B }
                | Fault::SyncLost { .. }
        )
    }

    /// The alarm code of this fault ([`codec::Fault`]: its words, reaction and remedy).
    pub const fn code(&self) -> codec::Fault {
        match self {
            Fault::SafetyChainOpen => codec::Fault::SafetyChainOpen,
            Fault::EmergencyStop => codec::Fault::EmergencyStop,
            Fault::HardwareLimit { .. } => codec::Fault::HardwareLimit,
            Fault::SoftLimit { .. } => codec::Fault::SoftLimit,
            Fault::FollowingError { .. } => codec::Fault::FollowingError,
            Fault::DriveFault { .. } => codec::Fault::DriveFault,
            Fault::VfdFault => codec::Fault::VfdFault,
            Fault::SyncLost { .. } => codec::Fault::SyncLost,
            Fault::SpindleSpeed { .. } => codec::Fault::SpindleSpeed,
            Fault::LubeTimeout => codec::Fault::LubeTimeout,
            Fault::ClampTimeout => codec::Fault::ClampTimeout,
            Fault::FeedbackLost { .. } => codec::Fault::FeedbackLost,
            Fault::IoLost => codec::Fault::IoLost,
            Fault::DriveNotEnabled { .. } => codec::Fault::DriveNotEnabled,
            Fault::HomingFailed { .. } => codec::Fault::HomingFailed,
            Fault::PositionLost { .. } => codec::Fault::PositionLost,
        }
    }

    /// The fault as an alarm on the wire (allocation-free: it runs in the cycle). `None`
    /// is code 0, no alarm.
    pub fn alarm(f: Option<Fault>) -> AlarmCode {
        let mut a = AlarmCode::default();
        let Some(f) = f else { return a };
        let (axis, end, va, vb) = match f {
            Fault::HardwareLimit { axis, end } => (Some(axis), end.code(), 0.0, 0.0),
            Fault::SoftLimit { axis, position } => (Some(axis), 0, position, 0.0),
            Fault::FollowingError { axis, error } => (Some(axis), 0, error, 0.0),
            Fault::SyncLost { error_arcsec } => (None, 0, error_arcsec, 0.0),
            Fault::SpindleSpeed { set_rpm, actual_rpm } => (None, 0, set_rpm, actual_rpm),
            Fault::HomingFailed { axis, why } => (Some(axis), why.code(), 0.0, 0.0),
            Fault::DriveFault { axis }
            | Fault::FeedbackLost { axis }
            | Fault::DriveNotEnabled { axis }
            | Fault::PositionLost { axis } => (Some(axis), 0, 0.0, 0.0),
            Fault::SafetyChainOpen
            | Fault::EmergencyStop
            | Fault::VfdFault
            | Fault::LubeTimeout
            | Fault::ClampTimeout
            | Fault::IoLost => (None, 0, 0.0, 0.0),
        };
        a.code = f.code().code();
        a.axis = axis.map_or(0, Axis::code);
        a.end = end;
        a.value_a = va;
        a.value_b = vb;
        a
    }

    /// The fault of an alarm (`None` for code 0, an unknown code, a missing axis or an
    /// unknown homing failure). A hardware limit whose end is not "min" reads as "max".
    pub fn of_alarm(a: &AlarmCode) -> Option<Fault> {
        let f = codec::Fault::of(a)?;
        let ax = Axis::from_code(a.axis);
        Some(match f {
            codec::Fault::SafetyChainOpen => Fault::SafetyChainOpen,
            codec::Fault::EmergencyStop => Fault::EmergencyStop,
            codec::Fault::HardwareLimit => Fault::HardwareLimit {
                axis: ax?,
                end: if End::from_code(a.end) == Some(End::Min) {
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
                why: HomingFailure::from_code(a.end)?,
            },
            codec::Fault::PositionLost => Fault::PositionLost { axis: ax? },
        })
    }
}
