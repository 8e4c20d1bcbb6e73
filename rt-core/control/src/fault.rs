//! Faults and refusals on the real-time path: `Copy` enums with fields, no strings.

/// A machine axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Axis {
    B,
    X,
    Y,
}

impl Axis {
    pub fn name(self) -> &'static str {
        match self {
            Axis::B => "B",
            Axis::X => "X",
            Axis::Y => "Y",
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

/// Which end of an axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum End {
    Min,
    Max,
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

/// Why referencing an axis failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum HomingFailure {
    /// The drive's mode display did not confirm the mode asked for.
    ModeNotConfirmed,
    /// The drive did not start homing.
    NotStarted,
    /// The drive reported a homing error (statusword bit 13).
    DriveError,
    /// Homing took longer than `homing.timeout_s`.
    Timeout,
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
}

/// Why a command was refused. Nothing changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Refusal {
    NoProgram,
    /// A cycle is running; stop it first.
    CycleRunning,
    /// The machine is in fault; reset first.
    Faulted,
    /// Power-up (lubrication, safety chain) not finished.
    NotReady,
    /// Nothing to hold, resume, stop or reset.
    NothingToDo,
    /// The move would leave the soft limits.
    OutsideSoftLimits,
    /// The program has no single-mode depth.
    NoSingleDepth,
    /// The value is not a finite number in range.
    BadValue,
    /// The safety chain is open: close it (reset button) first.
    SafetyChainOpen,
    /// Not every drive reports "operation enabled" yet.
    DrivesNotEnabled,
    /// X and Y are not referenced: only referencing and slow jogs until they are.
    NotReferenced,
    /// The table lost its position since the tooth phase was recorded: continuing would
    /// cut a new set of gaps into the part.
    TablePositionLost,
    /// A jog is running: release it first.
    JogActive,
    /// The spindle turns: a flank touch needs the hob standing still.
    SpindleTurning,
    /// The flank touched with the table turned positive lies below the one touched turned
    /// negative: not the two flanks of one gap.
    FlanksCrossed,
}
