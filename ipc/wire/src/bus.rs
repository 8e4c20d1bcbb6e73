//! The CAN bus's words as the operator reads them, wherever a bus event or a drive's
//! state is shown: CANopen emergency codes (CiA 301 table 21 and CiA 402's), NMT states,
//! the CiA 402 power states and the transports' send errors. `hob-canopen` uses these
//! (re-exported there); the wire's codec words bus events with them.

/// Meaning of an emergency error code.
pub fn emcy_text(code: u16) -> &'static str {
    match code {
        0x0000 => "error reset or no error",
        0x1000 => "generic error",
        0x2310 => "continuous over-current",
        0x2320 => "short circuit at outputs",
        0x3210 => "DC link over-voltage",
        0x3220 => "DC link under-voltage",
        0x4210 => "excess temperature device",
        0x5441 => "input stage: STO / enable input",
        0x6010 => "software reset (watchdog)",
        0x7303 => "resolver / encoder 1 fault",
        0x7305 => "incremental sensor 1 fault",
        0x8110 => "CAN overrun (objects lost)",
        0x8120 => "CAN in error passive mode",
        0x8130 => "life guard or heartbeat error",
        0x8140 => "recovered from bus off",
        0x8210 => "PDO not processed due to length error",
        0x8611 => "following error",
        0xFF00..=0xFFFF => "device specific",
        c => match c >> 12 {
            0x1 => "generic error",
            0x2 => "current",
            0x3 => "voltage",
            0x4 => "temperature",
            0x5 => "device hardware",
            0x6 => "device software",
            0x7 => "additional modules",
            0x8 => "monitoring / communication",
            0x9 => "external error",
            0xF => "additional functions",
            _ => "unknown",
        },
    }
}

/// States of the power state machine (CiA 402 figure 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PowerState {
    NotReadyToSwitchOn,
    SwitchOnDisabled,
    ReadyToSwitchOn,
    SwitchedOn,
    OperationEnabled,
    QuickStopActive,
    FaultReactionActive,
    Fault,
}

impl PowerState {
    /// Decodes the statusword (bits 0-3, 5, 6).
    pub fn from_statusword(sw: u16) -> Self {
        match sw & 0x006F {
            0x0000 | 0x0020 => PowerState::NotReadyToSwitchOn,
            0x0040 | 0x0060 => PowerState::SwitchOnDisabled,
            0x0021 => PowerState::ReadyToSwitchOn,
            0x0023 => PowerState::SwitchedOn,
            0x0027 => PowerState::OperationEnabled,
            0x0007 => PowerState::QuickStopActive,
            0x000F | 0x002F => PowerState::FaultReactionActive,
            0x0008 | 0x0028 => PowerState::Fault,
            _ => match sw & 0x004F {
                0x0040 => PowerState::SwitchOnDisabled,
                0x0008 => PowerState::Fault,
                _ => PowerState::NotReadyToSwitchOn,
            },
        }
    }

    /// The statusword a drive reports in this state (voltage enabled bit 4 set when
    /// powered, remote bit 9 set).
    pub fn statusword(self) -> u16 {
        let base = match self {
            PowerState::NotReadyToSwitchOn => 0x0000,
            PowerState::SwitchOnDisabled => 0x0040,
            PowerState::ReadyToSwitchOn => 0x0021,
            PowerState::SwitchedOn => 0x0023,
            PowerState::OperationEnabled => 0x0027,
            PowerState::QuickStopActive => 0x0007,
            PowerState::FaultReactionActive => 0x000F,
            PowerState::Fault => 0x0008,
        };
        base | 0x0200 | 0x0010
    }

    pub fn name(self) -> &'static str {
        match self {
            PowerState::NotReadyToSwitchOn => "not ready to switch on",
            PowerState::SwitchOnDisabled => "switch on disabled",
            PowerState::ReadyToSwitchOn => "ready to switch on",
            PowerState::SwitchedOn => "switched on",
            PowerState::OperationEnabled => "operation enabled",
            PowerState::QuickStopActive => "quick stop active",
            PowerState::FaultReactionActive => "fault reaction active",
            PowerState::Fault => "fault",
        }
    }
}

/// Why a bus operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BusError {
    /// The transmit queue is full (try again next cycle).
    Full,
    /// The interface is down or gone.
    Down,
    /// Another OS error (errno).
    Os(i32),
}

impl std::fmt::Display for BusError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BusError::Full => write!(f, "transmit queue full"),
            BusError::Down => write!(f, "interface down"),
            BusError::Os(e) => write!(f, "OS error {e}"),
        }
    }
}

impl std::error::Error for BusError {}

/// A node's NMT state from its heartbeat code ([`crate::StateSample::nmt_state`];
/// [`crate::NMT_NOT_HEARD`]: no heartbeat yet).
pub fn nmt_state_name(code: u8) -> &'static str {
    match code {
        crate::NMT_NOT_HEARD => "not heard",
        0x00 => "boot-up",
        0x04 => "stopped",
        0x05 => "operational",
        0x7F => "pre-operational",
        _ => "unknown",
    }
}
