//! The machine's vocabulary, written once: every code table the control core and the
//! wire share (sequencer states, refusals, axes and their ends, homing failures, gearbox
//! couplings) with the number each value is on the wire and its words, and the control
//! core's [`Fault`] with the alarm it travels as. The control core uses these types
//! themselves (`hob_control` re-exports them); the frontends read the same codes from the
//! wire with [`crate::codec`]. Adding a state or a refusal is one entry here; adding a
//! fault is a variant of [`Fault`] plus its alarm code ([`FaultCode`], with its words,
//! reaction and remedy) and the control core's handling.
//!
//! The numbers are the wire format: never renumber one, only add new ones
//! (`tests/reference.rs` holds every code as it was).

use crate::AlarmCode;

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

    /// The state in the operator's words (the HMI's status line; translated there through
    /// its message catalogue): [`Self::name`] is the short word of the trace and the CLI.
    pub const fn words(self) -> &'static str {
        match self {
            State::Init => "power-up",
            State::Idle => "idle",
            State::Jog => "jog",
            State::ToSafe => "to the safe position",
            State::ToStart => "to the start position",
            State::SpindleUp => "hob spindle starting",
            State::Engage => "gearbox engaging",
            State::Infeed => "infeed",
            State::Plunge => "plunging",
            State::ExtraRev => "extra revolution",
            State::Clamp => "clamping X",
            State::Cut => "cutting",
            State::Unclamp => "unclamping X",
            State::Retract => "retracting",
            State::Return => "returning",
            State::Index => "indexing",
            State::Home => "to the home position",
            State::Disengage => "gearbox disengaging",
            State::SpindleDown => "hob spindle stopping",
            State::FaultRetract => "FAULT: retracting X",
            State::FaultStop => "FAULT: stopping",
            State::Faulted => "FAULT",
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

    /// Where a fault in this state meets the machine ([`situation`]): in the work (the
    /// cut, or the infeed: the fault reaction retracts from there), elsewhere in a cycle,
    /// outside one.
    pub fn situation(self) -> u8 {
        if self.tool_in_work() || self == State::Infeed {
            situation::IN_WORK
        } else if self.in_cycle() {
            situation::IN_CYCLE
        } else {
            situation::OUTSIDE_CYCLE
        }
    }
}

/// The pitch compensation's state ([`crate::StateSample::pitch_compensation`]).
pub mod pitch_compensation {
    /// None loaded (none stored for the machine's worm set, or a recording from before).
    pub const NONE: u8 = 0;
    /// Loaded, switched off.
    pub const OFF: u8 = 1;
    /// Loaded and applied to the table.
    pub const ON: u8 = 2;

    /// The state's word (`none`, `off`, `on`; `?` for another code).
    pub fn name(code: u8) -> &'static str {
        match code {
            NONE => "none",
            OFF => "off",
            ON => "on",
            _ => "?",
        }
    }
}

/// Where a fault met the machine ([`crate::AlarmCode::situation`]): its reaction differs.
pub mod situation {
    /// Not recorded (an alarm of an older recording): the reaction of every case is told.
    pub const UNKNOWN: u8 = 0;
    pub const OUTSIDE_CYCLE: u8 = 1;
    pub const IN_CYCLE: u8 = 2;
    /// The cut or the infeed.
    pub const IN_WORK: u8 = 3;
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
    ProgramChanged = 16,
    OffsetNeedsConfirmation = 17,
    DelayNotCommissioned = 18,
    NoCompensation = 19,
}

impl Refusal {
    /// Every refusal, in code order (`ALL[i].code() == i + 1`).
    pub const ALL: [Refusal; 19] = [
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
        Refusal::ProgramChanged,
        Refusal::OffsetNeedsConfirmation,
        Refusal::DelayNotCommissioned,
        Refusal::NoCompensation,
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
            Refusal::ProgramChanged => "program-changed",
            Refusal::OffsetNeedsConfirmation => "offset-needs-confirmation",
            Refusal::DelayNotCommissioned => "delay-not-commissioned",
            Refusal::NoCompensation => "no-compensation",
        }
    }

    /// What the operator reads for a refusal.
    pub const fn text(self) -> &'static str {
        match self {
            Refusal::NoProgram => "no program loaded: load one first",
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
                "X and Y are not referenced: only referencing (HOME) and slow jogs until they are"
            }
            Refusal::TablePositionLost => {
                "the table lost its position since the tooth phase was recorded: continuing would cut a new set of gaps into this part (touch both flanks of a cut gap to align to it)"
            }
            Refusal::JogActive => "a jog is running: release it (or stop) first",
            Refusal::SpindleTurning => {
                "the spindle turns: a flank touch needs the hob standing still (spindle off)"
            }
            Refusal::FlanksCrossed => {
                "this flank lies on the wrong side of the other one: the table is turned positive to touch one flank of the gap and negative to touch the other"
            }
            Refusal::ProgramChanged => {
                "the program was changed since it was loaded: load it again to cut the changed program"
            }
            Refusal::OffsetNeedsConfirmation => {
                "this touch-off does not fit what the machine knows (the loaded blank, the previous offset, where the hob stands): check the gauge's value and the hob's position, and confirm the new offset only if both are right; nothing was changed"
            }
            Refusal::DelayNotCommissioned => {
                "the table drive's delay was not measured on this machine's table drive: run hob commission delay, then restart hob-rt (a wrong delay faults the cut at engagement)"
            }
            Refusal::NoCompensation => {
                "no pitch compensation was loaded for this machine's worm set: measure a gear, run hob compensate, then restart hob-rt"
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

    /// The alarm code of this fault ([`FaultCode`]: its words, reaction and remedy).
    pub const fn code(&self) -> FaultCode {
        match self {
            Fault::SafetyChainOpen => FaultCode::SafetyChainOpen,
            Fault::EmergencyStop => FaultCode::EmergencyStop,
            Fault::HardwareLimit { .. } => FaultCode::HardwareLimit,
            Fault::SoftLimit { .. } => FaultCode::SoftLimit,
            Fault::FollowingError { .. } => FaultCode::FollowingError,
            Fault::DriveFault { .. } => FaultCode::DriveFault,
            Fault::VfdFault => FaultCode::VfdFault,
            Fault::SyncLost { .. } => FaultCode::SyncLost,
            Fault::SpindleSpeed { .. } => FaultCode::SpindleSpeed,
            Fault::LubeTimeout => FaultCode::LubeTimeout,
            Fault::ClampTimeout => FaultCode::ClampTimeout,
            Fault::FeedbackLost { .. } => FaultCode::FeedbackLost,
            Fault::IoLost => FaultCode::IoLost,
            Fault::DriveNotEnabled { .. } => FaultCode::DriveNotEnabled,
            Fault::HomingFailed { .. } => FaultCode::HomingFailed,
            Fault::PositionLost { .. } => FaultCode::PositionLost,
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
        let f = FaultCode::of(a)?;
        let ax = Axis::from_code(a.axis);
        Some(match f {
            FaultCode::SafetyChainOpen => Fault::SafetyChainOpen,
            FaultCode::EmergencyStop => Fault::EmergencyStop,
            FaultCode::HardwareLimit => Fault::HardwareLimit {
                axis: ax?,
                end: if End::from_code(a.end) == Some(End::Min) {
                    End::Min
                } else {
                    End::Max
                },
            },
            FaultCode::SoftLimit => Fault::SoftLimit {
                axis: ax?,
                position: a.value_a,
            },
            FaultCode::FollowingError => Fault::FollowingError {
                axis: ax?,
                error: a.value_a,
            },
            FaultCode::DriveFault => Fault::DriveFault { axis: ax? },
            FaultCode::VfdFault => Fault::VfdFault,
            FaultCode::SyncLost => Fault::SyncLost {
                error_arcsec: a.value_a,
            },
            FaultCode::SpindleSpeed => Fault::SpindleSpeed {
                set_rpm: a.value_a,
                actual_rpm: a.value_b,
            },
            FaultCode::LubeTimeout => Fault::LubeTimeout,
            FaultCode::ClampTimeout => Fault::ClampTimeout,
            FaultCode::FeedbackLost => Fault::FeedbackLost { axis: ax? },
            FaultCode::IoLost => Fault::IoLost,
            FaultCode::DriveNotEnabled => Fault::DriveNotEnabled { axis: ax? },
            FaultCode::HomingFailed => Fault::HomingFailed {
                axis: ax?,
                why: HomingFailure::from_code(a.end)?,
            },
            FaultCode::PositionLost => Fault::PositionLost { axis: ax? },
        })
    }
}

/// What stopped the machine ([`AlarmCode::code`]; 0: no alarm). Which of the alarm's
/// `axis`, `end`, `value_a`, `value_b` it uses is in [`FaultCode::text`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum FaultCode {
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

// The pieces of the fault texts (literals, so that each text is one `&'static str`).

/// A fault in a cycle when X and the table can both still move (`seq_on_fault`:
/// `FaultRetract` from the cut or the infeed, else `FaultStop`).
macro_rules! reaction_retract {
    () => {
        "in the cut (or the infeed) X retracted to its safe position with the gearbox still \
         engaged, so the hob left its tooth gap (Y stopped, the X clamp opened); then the machine \
         stopped (gearbox out, spindle and axes to rest, 15 s at most) and PC-OK dropped, which \
         opens the safety chain; elsewhere in a cycle it stopped where it was, then PC-OK dropped"
    };
}

/// A fault in a cycle that the table cannot follow.
macro_rules! reaction_table_lost {
    () => {
        "in the cut the table could no longer follow: the spindle stopped and the gearbox \
         disengaged at once, X pulled the hob out of the work (Y stopped), then the machine came \
         to rest and PC-OK dropped, which opens the safety chain; elsewhere in a cycle the \
         spindle stopped and the gearbox disengaged at once, the machine stopped where it was, \
         then PC-OK dropped"
    };
}

/// A fault in a cycle under which X cannot move.
macro_rules! reaction_x_stuck {
    () => {
        "in a cycle X could not move: the machine stopped where it was, the hob in the work if \
         it was there (gearbox out, spindle and axes to rest, 15 s at most), then PC-OK dropped, \
         which opens the safety chain"
    };
}

macro_rules! reaction_outside {
    () => {
        "; outside a cycle (idle, jogging, referencing) the spindle stopped and PC-OK dropped at once"
    };
}

// Each case alone (an alarm whose situation is recorded tells only what happened).

macro_rules! work_retract {
    () => {
        "X retracted to its safe position with the gearbox still engaged, so the hob left its \
         tooth gap (Y stopped, the X clamp opened); then the machine stopped (gearbox out, \
         spindle and axes to rest, 15 s at most) and PC-OK dropped, which opens the safety chain"
    };
}

macro_rules! work_table_lost {
    () => {
        "the table could no longer follow: the spindle stopped and the gearbox disengaged at \
         once, X pulled the hob out of the work (Y stopped), then the machine came to rest and \
         PC-OK dropped, which opens the safety chain"
    };
}

macro_rules! work_x_stuck {
    () => {
        "X could not move: the machine stopped where it was with the hob in the work (gearbox \
         out, spindle and axes to rest, 15 s at most), then PC-OK dropped, which opens the \
         safety chain"
    };
}

macro_rules! cycle_stop {
    () => {
        "the hob was out of the work: the machine stopped where it was (gearbox out, spindle and \
         axes to rest, 15 s at most), then PC-OK dropped, which opens the safety chain"
    };
}

macro_rules! cycle_table_lost {
    () => {
        "the hob was out of the work: the spindle stopped and the gearbox disengaged at once, \
         the machine stopped where it was, then PC-OK dropped, which opens the safety chain"
    };
}

macro_rules! outside_stop {
    () => {
        "no cycle ran: the spindle stopped and PC-OK dropped at once, which opens the safety chain"
    };
}

/// The watchdog's reaction to a loop faulted with a node lost (`hob-watchdog`).
macro_rules! reaction_watchdog {
    () => {
        "; with the loop faulted, the watchdog switched every output of the I/O coupler off by \
         SDO (spindle reference 0 V) and quick-stopped every drive"
    };
}

/// PC-OK dropped on every fault: the chain closes again only once it is back.
macro_rules! continue_reset {
    () => {
        "RESET (PC-OK comes back), then the reset button on the panel closes the safety chain \
         and the machine powers up to idle"
    };
}

macro_rules! continue_pass {
    () => {
        "CONTINUE re-enters the interrupted pass on the same tooth gaps (if a cycle was \
         interrupted and the same program is loaded), or START"
    };
}

/// What comes `before` the reset, the reset, what comes `between` it and the pass.
macro_rules! continue_after {
    ($before:literal, $between:literal) => {
        concat!($before, continue_reset!(), $between, continue_pass!())
    };
}

/// The table lost its position after the part's tooth phase was recorded.
macro_rules! continue_phase_lost {
    () => {
        "the part on the table has lost its tooth phase and cannot be finished on the same \
         gaps: CONTINUE is refused; NEW BLANK with a new part, then START"
    };
}

impl FaultCode {
    /// Every fault, in code order (`ALL[i].code() == i + 1`).
    pub const ALL: [FaultCode; 16] = [
        FaultCode::SafetyChainOpen,
        FaultCode::EmergencyStop,
        FaultCode::HardwareLimit,
        FaultCode::SoftLimit,
        FaultCode::FollowingError,
        FaultCode::DriveFault,
        FaultCode::VfdFault,
        FaultCode::SyncLost,
        FaultCode::SpindleSpeed,
        FaultCode::LubeTimeout,
        FaultCode::ClampTimeout,
        FaultCode::FeedbackLost,
        FaultCode::IoLost,
        FaultCode::DriveNotEnabled,
        FaultCode::HomingFailed,
        FaultCode::PositionLost,
    ];

    pub const fn code(self) -> u32 {
        self as u32
    }

    pub fn from_code(c: u32) -> Option<FaultCode> {
        c.checked_sub(1).and_then(|i| Self::ALL.get(i as usize).copied())
    }

    pub const fn name(self) -> &'static str {
        match self {
            FaultCode::SafetyChainOpen => "safety-chain-open",
            FaultCode::EmergencyStop => "emergency-stop",
            FaultCode::HardwareLimit => "hardware-limit",
            FaultCode::SoftLimit => "soft-limit",
            FaultCode::FollowingError => "following-error",
            FaultCode::DriveFault => "drive-fault",
            FaultCode::VfdFault => "vfd-fault",
            FaultCode::SyncLost => "sync-lost",
            FaultCode::SpindleSpeed => "spindle-speed",
            FaultCode::LubeTimeout => "lube-timeout",
            FaultCode::ClampTimeout => "clamp-timeout",
            FaultCode::FeedbackLost => "feedback-lost",
            FaultCode::IoLost => "io-lost",
            FaultCode::DriveNotEnabled => "drive-not-enabled",
            FaultCode::HomingFailed => "homing-failed",
            FaultCode::PositionLost => "position-lost",
        }
    }

    /// Whether the fault names an axis (its alarm is incomplete without one).
    pub const fn has_axis(self) -> bool {
        matches!(
            self,
            FaultCode::HardwareLimit
                | FaultCode::SoftLimit
                | FaultCode::FollowingError
                | FaultCode::DriveFault
                | FaultCode::FeedbackLost
                | FaultCode::DriveNotEnabled
                | FaultCode::HomingFailed
                | FaultCode::PositionLost
        )
    }

    /// The fault of an alarm: `None` for code 0, an unknown code, or a fault that names an
    /// axis without a valid one.
    pub fn of(a: &AlarmCode) -> Option<FaultCode> {
        let f = FaultCode::from_code(a.code)?;
        (!f.has_axis() || Axis::from_code(a.axis).is_some()).then_some(f)
    }

    /// Whether X can still move under this fault on `axis` (else the machine stops where
    /// it is instead of retracting): the control core's `FaultCode::x_can_move`, read from the
    /// wire (hob-service's tests check the two agree for every fault).
    pub fn x_can_move(self, a: &AlarmCode) -> bool {
        let x = Axis::from_code(a.axis) == Some(Axis::X);
        !match self {
            FaultCode::DriveFault
            | FaultCode::DriveNotEnabled
            | FaultCode::FollowingError
            | FaultCode::FeedbackLost
            | FaultCode::SoftLimit
            | FaultCode::PositionLost
            | FaultCode::HomingFailed => x,
            FaultCode::HardwareLimit => x && End::from_code(a.end) != Some(End::Min),
            _ => false,
        }
    }

    /// Whether the table can still follow the spindle under this fault (else the spindle
    /// stops and the gearbox disengages at once): the control core's
    /// `FaultCode::table_can_follow`, read from the wire.
    pub fn table_can_follow(self, a: &AlarmCode) -> bool {
        let b = Axis::from_code(a.axis) == Some(Axis::B);
        !match self {
            FaultCode::DriveFault
            | FaultCode::DriveNotEnabled
            | FaultCode::FollowingError
            | FaultCode::FeedbackLost
            | FaultCode::PositionLost => b,
            FaultCode::SyncLost => true,
            _ => false,
        }
    }

    /// What the machine did on this fault, in the operator's words (docs: README, "What a
    /// fault does"): the control core's fault reaction (`seq_on_fault`) for the alarm's
    /// axis, in the cut, elsewhere in a cycle and outside one; for a lost node also what
    /// the watchdog did once the loop stood faulted.
    pub fn reaction(self, a: &AlarmCode) -> &'static str {
        let watchdog = matches!(self, FaultCode::FeedbackLost | FaultCode::IoLost);
        if a.situation != situation::UNKNOWN {
            return self.reaction_in(a, watchdog);
        }
        match (self.x_can_move(a), self.table_can_follow(a), watchdog) {
            (false, _, false) => concat!(reaction_x_stuck!(), reaction_outside!()),
            (false, _, true) => concat!(reaction_x_stuck!(), reaction_outside!(), reaction_watchdog!()),
            (true, false, false) => concat!(reaction_table_lost!(), reaction_outside!()),
            (true, false, true) => {
                concat!(reaction_table_lost!(), reaction_outside!(), reaction_watchdog!())
            }
            (true, true, false) => concat!(reaction_retract!(), reaction_outside!()),
            (true, true, true) => concat!(reaction_retract!(), reaction_outside!(), reaction_watchdog!()),
        }
    }

    /// [`Self::reaction`] for an alarm whose situation is recorded: what happened only.
    fn reaction_in(self, a: &AlarmCode, watchdog: bool) -> &'static str {
        let (x, table) = (self.x_can_move(a), self.table_can_follow(a));
        match (a.situation, x, table, watchdog) {
            (situation::IN_WORK, false, _, false) => work_x_stuck!(),
            (situation::IN_WORK, false, _, true) => concat!(work_x_stuck!(), reaction_watchdog!()),
            (situation::IN_WORK, true, false, false) => work_table_lost!(),
            (situation::IN_WORK, true, false, true) => concat!(work_table_lost!(), reaction_watchdog!()),
            (situation::IN_WORK, true, true, false) => work_retract!(),
            (situation::IN_WORK, true, true, true) => concat!(work_retract!(), reaction_watchdog!()),
            (situation::IN_CYCLE, _, false, false) => cycle_table_lost!(),
            (situation::IN_CYCLE, _, false, true) => concat!(cycle_table_lost!(), reaction_watchdog!()),
            (situation::IN_CYCLE, _, true, false) => cycle_stop!(),
            (situation::IN_CYCLE, _, true, true) => concat!(cycle_stop!(), reaction_watchdog!()),
            (_, _, _, false) => outside_stop!(),
            (_, _, _, true) => concat!(outside_stop!(), reaction_watchdog!()),
        }
    }

    /// What the operator checks or repairs before RESET.
    pub const fn remedy(self) -> &'static str {
        match self {
            FaultCode::SafetyChainOpen => {
                "find what opened the chain: an e-stop button, a hardware limit switch, the VFD's \
                 fault relay or PC-OK; POWER-UP shows what the chain's reset needs (VFD ready, PC \
                 reset relay, lube and coolant pumps off, e-stop released, the reset button)"
            }
            FaultCode::EmergencyStop => {
                "find why the e-stop was pressed and make the machine safe, then release the e-stop \
                 button: while it is pressed the alarm comes back at once after RESET"
            }
            FaultCode::HardwareLimit => {
                "the slide stands on its limit switch, which keeps the safety chain open (no drive \
                 enable, so no jog) and the alarm back after RESET: move it off the switch by hand; \
                 then find why it got there (soft limits guard only a referenced axis, the work \
                 offsets, the program)"
            }
            FaultCode::SoftLimit => {
                "a command went outside the soft limits (soft_limit_min_mm, soft_limit_max_mm of \
                 [x] or [y] in the machine file): check the work offsets (touch-off) and the \
                 program's positions against the axis's travel"
            }
            FaultCode::FollowingError => {
                "the axis could not follow its command (max_following_error_mm of the axis, or of \
                 the table): look for an obstruction, a collision, a seized slide, a brake not \
                 released or a drive at its current limit"
            }
            FaultCode::DriveFault => {
                "read the drive's EMCY in DIAGNOSTICS (over-current, over-temperature, encoder) and \
                 repair the cause at the drive; RESET sends the drive a fault reset, and a fault \
                 still there after the drives' 2 s enable time is this alarm again"
            }
            FaultCode::VfdFault => {
                "read the fault code on the spindle VFD's display, repair its cause and reset the \
                 VFD: until then its fault relay keeps the safety chain open and the alarm comes back \
                 after RESET"
            }
            FaultCode::SyncLost => {
                "the table left the coarse window: check the spindle encoder and its coupling, \
                 the table drive's tuning and the cutting load (speeds, feed, worn hob)"
            }
            FaultCode::SpindleSpeed => {
                "the spindle did not reach its speed: check the VFD (enable, its own fault), the \
                 belt and the spindle encoder"
            }
            FaultCode::LubeTimeout => {
                "the pressure switch did not confirm: check the lubricant level, the pump and its \
                 fuse, the filter, the lines and the switch"
            }
            FaultCode::ClampTimeout => "check the X clamp's magnet, its supply and its feedback switch",
            FaultCode::FeedbackLost => {
                "the drive's position frames stopped: check its CAN cable and connectors, the bus \
                 termination and the drive's supply (did it restart?); DIAGNOSTICS lists the \
                 heartbeats and EMCYs"
            }
            FaultCode::IoLost => {
                "the I/O coupler stopped answering: check its CAN cable, its supply, the bus \
                 termination and its node id"
            }
            FaultCode::DriveNotEnabled => {
                "the drive did not reach \"operation enabled\": check its enable input (safety \
                 chain), its supply and its own fault"
            }
            FaultCode::HomingFailed => {
                "the alarm says why (mode not confirmed, homing not started, the drive's homing \
                 error, timeout): check the home switch and its cable, the homing method, speeds \
                 and timeout ([x.homing], [y.homing] in the machine file) and the axis's travel"
            }
            FaultCode::PositionLost => {
                "the drive restarted or its encoder jumped: check its supply and encoder cable; \
                 its reference (or the part's tooth phase on the table) is gone"
            }
        }
    }

    /// How work goes on after the remedy (what the control core asks of `CONTINUE`: the
    /// interrupted pass kept, X and Y referenced, the table's position kept since the
    /// part's tooth phase was recorded).
    pub const fn how_to_continue(self) -> &'static str {
        match self {
            FaultCode::EmergencyStop => continue_after!("with the e-stop released: ", "; then "),
            FaultCode::HardwareLimit => continue_after!(
                "with the slide off the switch: ",
                "; HOME the axis if its reference is in doubt; then "
            ),
            FaultCode::VfdFault => continue_after!("with the VFD reset: ", "; then "),
            FaultCode::LubeTimeout => continue_after!(
                "",
                " (RESET runs the lubrication again and the machine waits for its pressure); then "
            ),
            FaultCode::SoftLimit => concat!(
                continue_reset!(),
                "; START and CONTINUE check the program against the soft limits again: correct \
                 the work offsets or load a corrected program (a changed program cannot be \
                 continued: START it)"
            ),
            FaultCode::HomingFailed => concat!(
                continue_reset!(),
                "; HOME again: the axis that failed is not referenced (homing drops its reference \
                 first), START and CONTINUE are refused until it is; a pass interrupted before is \
                 still there for CONTINUE"
            ),
            FaultCode::PositionLost => concat!(
                continue_reset!(),
                "; X or Y: HOME it (its reference is gone), then CONTINUE re-enters the \
                 interrupted pass; B: ",
                continue_phase_lost!()
            ),
            FaultCode::FeedbackLost | FaultCode::IoLost => {
                "once the node answers again, restart hob-rt: the watchdog acted and re-arms only \
                 for a new loop, and a node that restarted is configured only by hob-rt's start-up; \
                 the new loop has no reference, no interrupted pass and no tooth phase: the reset \
                 button on the panel, HOME X and Y, then START; a part interrupted on the table \
                 cannot be finished on the same gaps: NEW BLANK with a new part"
            }
            FaultCode::SafetyChainOpen
            | FaultCode::FollowingError
            | FaultCode::DriveFault
            | FaultCode::SyncLost
            | FaultCode::SpindleSpeed
            | FaultCode::ClampTimeout
            | FaultCode::DriveNotEnabled => continue_after!("", "; then "),
        }
    }

    /// What the operator reads for an alarm of this fault (its axis, end and values
    /// from `a`); `None` if the fault names an axis and `a` has none.
    pub fn text(self, a: &AlarmCode) -> Option<String> {
        let axis = Axis::from_code(a.axis);
        let (va, vb) = (a.value_a, a.value_b);
        Some(match self {
            FaultCode::SafetyChainOpen => "safety chain open".into(),
            FaultCode::EmergencyStop => "emergency stop pressed".into(),
            FaultCode::HardwareLimit => {
                // End 1 is min; anything else reads as max (as it always has).
                let end = if End::from_code(a.end) == Some(End::Min) {
                    End::Min
                } else {
                    End::Max
                };
                format!("hardware limit {} {}", axis?.name(), end.name())
            }
            FaultCode::SoftLimit => {
                let axis = axis?;
                format!("soft limit {}: {va:.3} {}", axis.name(), axis.unit())
            }
            FaultCode::FollowingError => {
                let axis = axis?;
                format!("following error {}: {va:.4} {}", axis.name(), axis.unit())
            }
            FaultCode::DriveFault => format!("drive fault {}", axis?.name()),
            FaultCode::VfdFault => "spindle VFD fault".into(),
            FaultCode::SyncLost => format!("synchronisation lost: {va:.1} arcsec outside the coarse window"),
            FaultCode::SpindleSpeed => format!("spindle did not reach {va:.1} rpm (is {vb:.1} rpm)"),
            FaultCode::LubeTimeout => "lubrication pressure not confirmed in time".into(),
            FaultCode::ClampTimeout => "X clamp did not report in time".into(),
            FaultCode::FeedbackLost => format!("feedback of drive {} lost (bus)", axis?.name()),
            FaultCode::IoLost => "I/O coupler lost (bus)".into(),
            FaultCode::DriveNotEnabled => format!("drive {} not in \"operation enabled\"", axis?.name()),
            FaultCode::HomingFailed => format!(
                "referencing {} failed: {}",
                axis?.name(),
                HomingFailure::from_code(a.end).map_or("?", HomingFailure::text)
            ),
            FaultCode::PositionLost => {
                let axis = axis?;
                let what = if axis == Axis::B {
                    "the tooth phase of the part on the table is gone"
                } else {
                    "reference it again (HOME)"
                };
                format!(
                    "drive {} lost its position (reboot or encoder): {what}",
                    axis.name()
                )
            }
        })
    }
}

/// The table's swing of `EXCITE_TABLE` (commissioning's frequency response), as the loop
/// makes it and the procedure reads it.
pub mod excitation {
    /// The largest swing of the table's target, deg (about an arcsec). Small: the mesh's
    /// torque must stay below the table's friction, which holds the wheel on the worm's
    /// driving flank while the table creeps; a larger swing lifts the wheel into the play,
    /// and the motor then feels only itself (on the simulated machine 0.02 deg showed no
    /// mesh at all).
    pub const MAX_DEG: f64 = 0.0003;
    /// The table creeps one way while its target swings, deg/s (36 deg/min): fast enough
    /// for its bearing's friction to reach its sliding value, which keeps the worm on one
    /// flank as the cutting torque does in the cut (at 3 deg/min the simulated table's
    /// friction is a tenth of it, and the mesh's mode did not show).
    pub const CREEP_DEG_S: f64 = 0.6;
    /// The lowest frequency, Hz (a period within the dead-man's renewals).
    pub const MIN_HZ: f64 = 0.5;
    /// The swing fades in and out over this long, s.
    pub const FADE_S: f64 = 0.25;
}
