//! A drive as the loop sees it (CiA 402): the feedback latched at SYNC, the homing bits of
//! its statusword, the mode of operation the loop asks for. A leaf: referencing and the
//! controller read it.

/// One drive's feedback, latched at SYNC.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct AxisFeedback {
    /// Actual position (0x6064), counts, wrapping.
    pub position_counts: i32,
    /// CiA 402 "operation enabled".
    pub enabled: bool,
    /// CiA 402 "fault".
    pub fault: bool,
    /// The feedback arrived for this cycle (false: the last value is held).
    pub fresh: bool,
    /// The mode the drive reports it is in (0x6061, the raw code: 8 cyclic synchronous
    /// position, 6 homing, anything else is neither).
    pub mode_display: i8,
    /// The statusword's bits 13, 12, 10 in homing mode (what they mean in another
    /// mode is not looked at).
    pub homing: HomingBits,
}

/// Homing progress reported by a drive in homing mode (statusword bits 13, 12, 10).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct HomingBits {
    /// Bit 12: homing attained.
    pub attained: bool,
    /// Bit 13: homing error.
    pub error: bool,
    /// Bit 10: target reached (the drive stands still).
    pub target_reached: bool,
}

/// A drive's mode of operation as the loop asks for it (0x6060).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum DriveMode {
    /// Cyclic synchronous position: the loop's targets every cycle (normal).
    #[default]
    CyclicPosition,
    /// Homing: the drive runs its homing method by itself.
    Homing,
}

impl DriveMode {
    /// The code of 0x6060/0x6061.
    pub fn code(self) -> i8 {
        match self {
            DriveMode::CyclicPosition => 8,
            DriveMode::Homing => 6,
        }
    }
}
