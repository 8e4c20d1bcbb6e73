//! CiA 402 drive profile: the power state machine (statusword 0x6041, controlword 0x6040),
//! the modes of operation, and the objects the controller uses.

/// Objects of the drive profile.
pub mod object {
    pub const CONTROLWORD: u16 = 0x6040;
    pub const STATUSWORD: u16 = 0x6041;
    pub const MODES_OF_OPERATION: u16 = 0x6060;
    pub const MODES_DISPLAY: u16 = 0x6061;
    pub const POSITION_ACTUAL: u16 = 0x6064;
    pub const TARGET_POSITION: u16 = 0x607A;
    pub const VELOCITY_OFFSET: u16 = 0x60B1;
    pub const INTERPOLATION_PERIOD: u16 = 0x60C2;
    pub const SUPPORTED_MODES: u16 = 0x6502;
    /// Homing (CiA 402-2 section 12): the position actual value at the home position.
    pub const HOME_OFFSET: u16 = 0x607C;
    /// Homing method (i8): 3 and 4 positive home switch, 5 and 6 negative home switch,
    /// each with the index pulse.
    pub const HOMING_METHOD: u16 = 0x6098;
    /// Homing speeds (u32, counts/s): sub 1 while searching the switch, sub 2 while
    /// searching the index pulse (zero).
    pub const HOMING_SPEEDS: u16 = 0x6099;
    /// Homing acceleration (u32, counts/s^2).
    pub const HOMING_ACCELERATION: u16 = 0x609A;
    /// Velocity control parameter set: sub 1 the gain, sub 2 the integration time
    /// constant (units the manufacturer's; hob's virtual drive's are in
    /// `hob_process_image::gains`).
    pub const VELOCITY_CONTROL_PARAMETERS: u16 = 0x60F9;
    /// Position control parameter set: sub 1 the gain (units the manufacturer's).
    pub const POSITION_CONTROL_PARAMETERS: u16 = 0x60FB;
}

/// Mode of operation: homing.
pub const MODE_HOMING: i8 = 6;

/// Controlword bit 4 in homing mode: a rising edge starts the homing operation.
pub const CW_HOMING_START: u16 = 1 << 4;
/// Statusword bit 10: target reached (in homing mode: the drive stands still at the end).
pub const SW_TARGET_REACHED: u16 = 1 << 10;
/// Statusword bit 12 in homing mode: homing attained.
pub const SW_HOMING_ATTAINED: u16 = 1 << 12;
/// Statusword bit 13 in homing mode: homing error.
pub const SW_HOMING_ERROR: u16 = 1 << 13;

/// The homing methods with a home switch and the index pulse (CiA 402-2 figures 34 to
/// 37): 3, 4 (switch active on the positive side of its edge), 5, 6 (negative side).
pub const HOMING_METHODS_SWITCH_AND_INDEX: [i8; 4] = [3, 4, 5, 6];

/// Homing progress as the statusword's mode-specific bits 13, 12, 10 report it
/// (CiA 402-2 table 62).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HomingProgress {
    /// 0 0 0: homing in progress.
    InProgress,
    /// 0 0 1: interrupted or not started.
    NotStarted,
    /// 0 1 0: homing attained, target not reached (still moving).
    AttainedMoving,
    /// 0 1 1: homing completed.
    Completed,
    /// 1 x x: homing error (bit 10 says whether the axis stands still).
    Error,
}

impl HomingProgress {
    pub fn from_statusword(sw: u16) -> Self {
        let (e, a, t) = (
            sw & SW_HOMING_ERROR != 0,
            sw & SW_HOMING_ATTAINED != 0,
            sw & SW_TARGET_REACHED != 0,
        );
        match (e, a, t) {
            (true, _, _) => HomingProgress::Error,
            (false, false, false) => HomingProgress::InProgress,
            (false, false, true) => HomingProgress::NotStarted,
            (false, true, false) => HomingProgress::AttainedMoving,
            (false, true, true) => HomingProgress::Completed,
        }
    }

    /// The statusword bits 13, 12, 10 of this progress.
    pub fn bits(self) -> u16 {
        match self {
            HomingProgress::InProgress => 0,
            HomingProgress::NotStarted => SW_TARGET_REACHED,
            HomingProgress::AttainedMoving => SW_HOMING_ATTAINED,
            HomingProgress::Completed => SW_HOMING_ATTAINED | SW_TARGET_REACHED,
            HomingProgress::Error => SW_HOMING_ERROR | SW_TARGET_REACHED,
        }
    }
}

/// Mode of operation: cyclic synchronous position.
pub const MODE_CSP: i8 = 8;
/// Mode of operation: interpolated position.
pub const MODE_IP: i8 = 7;

/// Whether 0x6502 announces a mode (bit `mode - 1`).
pub fn supports_mode(supported: u32, mode: i8) -> bool {
    mode >= 1 && supported & (1 << (mode - 1)) != 0
}

/// States of the power state machine (CiA 402 figure 5): the words of the wire.
pub use hob_wire::bus::PowerState;

/// Controlword commands.
pub mod command {
    pub const SHUTDOWN: u16 = 0x0006;
    pub const SWITCH_ON: u16 = 0x0007;
    pub const ENABLE_OPERATION: u16 = 0x000F;
    pub const DISABLE_VOLTAGE: u16 = 0x0000;
    pub const QUICK_STOP: u16 = 0x0002;
    pub const DISABLE_OPERATION: u16 = 0x0007;
    pub const FAULT_RESET: u16 = 0x0080;
}

/// The controlword that moves a drive in `state` one step towards "operation enabled"
/// (`enable`) or towards "switch on disabled" (not `enable`).
pub fn next_controlword(state: PowerState, enable: bool) -> u16 {
    use command::*;
    if !enable {
        return DISABLE_VOLTAGE;
    }
    match state {
        PowerState::Fault => FAULT_RESET,
        PowerState::SwitchOnDisabled | PowerState::NotReadyToSwitchOn => SHUTDOWN,
        PowerState::ReadyToSwitchOn => SWITCH_ON,
        PowerState::SwitchedOn | PowerState::OperationEnabled => ENABLE_OPERATION,
        PowerState::QuickStopActive => DISABLE_VOLTAGE,
        PowerState::FaultReactionActive => DISABLE_VOLTAGE,
    }
}

/// The drive side: the state a drive moves to on a controlword (CiA 402 transitions
/// 2-12, 15, 16; a fault is entered by the drive itself).
pub fn drive_transition(state: PowerState, cw: u16) -> PowerState {
    use PowerState::*;
    let fault_reset = cw & 0x0080 != 0;
    let bits = cw & 0x000F;
    // Disable voltage (bit 1 = 0) and quick stop (bits 1 = 1, 2 = 0).
    let disable_voltage = bits & 0x0002 == 0;
    let quick_stop = bits & 0x0006 == 0x0002;
    match state {
        Fault if fault_reset => SwitchOnDisabled,
        Fault | FaultReactionActive | NotReadyToSwitchOn => state,
        _ if disable_voltage => SwitchOnDisabled,
        OperationEnabled if quick_stop => QuickStopActive,
        QuickStopActive => state,
        _ if quick_stop => SwitchOnDisabled,
        SwitchOnDisabled if bits & 0x7 == 0x6 => ReadyToSwitchOn,
        ReadyToSwitchOn if bits == 0x7 => SwitchedOn,
        ReadyToSwitchOn if bits == 0xF => OperationEnabled,
        SwitchedOn if bits == 0xF => OperationEnabled,
        SwitchedOn if bits & 0x7 == 0x6 => ReadyToSwitchOn,
        OperationEnabled if bits == 0x7 => SwitchedOn,
        OperationEnabled if bits & 0x7 == 0x6 => ReadyToSwitchOn,
        s => s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuswords_decode() {
        assert_eq!(PowerState::from_statusword(0x0250), PowerState::SwitchOnDisabled);
        assert_eq!(PowerState::from_statusword(0x0231), PowerState::ReadyToSwitchOn);
        assert_eq!(PowerState::from_statusword(0x0233), PowerState::SwitchedOn);
        assert_eq!(PowerState::from_statusword(0x0237), PowerState::OperationEnabled);
        assert_eq!(PowerState::from_statusword(0x0217), PowerState::QuickStopActive);
        assert_eq!(PowerState::from_statusword(0x0218), PowerState::Fault);
        for s in [
            PowerState::SwitchOnDisabled,
            PowerState::ReadyToSwitchOn,
            PowerState::SwitchedOn,
            PowerState::OperationEnabled,
            PowerState::QuickStopActive,
            PowerState::FaultReactionActive,
            PowerState::Fault,
        ] {
            assert_eq!(PowerState::from_statusword(s.statusword()), s);
        }
    }

    #[test]
    fn the_master_walks_a_drive_to_operation_enabled() {
        let mut s = PowerState::Fault;
        let mut steps = Vec::new();
        for _ in 0..6 {
            let cw = next_controlword(s, true);
            steps.push(cw);
            s = drive_transition(s, cw);
        }
        assert_eq!(s, PowerState::OperationEnabled);
        assert_eq!(&steps[..4], &[0x0080, 0x0006, 0x0007, 0x000F]);
    }

    #[test]
    fn quick_stop_and_disable() {
        let s = drive_transition(PowerState::OperationEnabled, command::QUICK_STOP);
        assert_eq!(s, PowerState::QuickStopActive);
        assert_eq!(
            drive_transition(s, command::DISABLE_VOLTAGE),
            PowerState::SwitchOnDisabled
        );
        assert_eq!(
            drive_transition(PowerState::OperationEnabled, command::DISABLE_VOLTAGE),
            PowerState::SwitchOnDisabled
        );
    }

    #[test]
    fn csp_support_bit() {
        // 0x6502 bit 7 = mode 8 (CSP), bit 6 = mode 7 (IP).
        assert!(supports_mode(0x0000_0080, MODE_CSP));
        assert!(!supports_mode(0x0000_0040, MODE_CSP));
        assert!(supports_mode(0x0000_0040, MODE_IP));
    }

    #[test]
    fn homing_progress_round_trips_through_the_statusword_bits() {
        for p in [
            HomingProgress::InProgress,
            HomingProgress::NotStarted,
            HomingProgress::AttainedMoving,
            HomingProgress::Completed,
            HomingProgress::Error,
        ] {
            // The power-state bits and the others do not change the reading.
            let sw = PowerState::OperationEnabled.statusword() | p.bits();
            assert_eq!(HomingProgress::from_statusword(sw), p);
        }
        // Bit 13 with or without bit 10: an error either way (moving or standing).
        assert_eq!(
            HomingProgress::from_statusword(SW_HOMING_ERROR),
            HomingProgress::Error
        );
        assert!(supports_mode(0x0000_00A0, MODE_HOMING));
        assert!(!supports_mode(0x0000_0080, MODE_HOMING));
    }
}
