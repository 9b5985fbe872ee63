//! The CiA 402 drive state machine, as far as the controller drives it.
//!
//! The statusword (0x6041) tells the state; the controlword (0x6040) asks for the
//! next transition. Enabling walks *switch on disabled → ready to switch on →
//! switched on → operation enabled* with the commands *shutdown*, *switch on* and
//! *enable operation*. A fault is left only through an explicit fault reset.

pub mod pdo;

/// Drive states decoded from the statusword (CiA 402, Tab. 30).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DriveState {
    /// `xxxx xxxx x0xx 0000`
    NotReadyToSwitchOn,
    /// `xxxx xxxx x1xx 0000`
    SwitchOnDisabled,
    /// `xxxx xxxx x01x 0001`
    ReadyToSwitchOn,
    /// `xxxx xxxx x01x 0011`
    SwitchedOn,
    /// `xxxx xxxx x01x 0111`
    OperationEnabled,
    /// `xxxx xxxx x00x 0111`
    QuickStopActive,
    /// `xxxx xxxx x0xx 1111`
    FaultReactionActive,
    /// `xxxx xxxx x0xx 1000`
    Fault,
    /// No statusword received yet, or a combination CiA 402 does not define.
    Unknown,
}

/// Statusword (0x6041) bits the controller reads besides the state (CiA 402 Tab. 30;
/// bit 12 in cyclic synchronous modes).
pub mod statusword {
    /// Bit 3: fault.
    pub const FAULT: u16 = 1 << 3;
    /// Bit 7: warning.
    pub const WARNING: u16 = 1 << 7;
    /// Bit 9: remote — the controlword is processed (not under local control).
    pub const REMOTE: u16 = 1 << 9;
    /// Bit 11: internal limit active (the drive limits torque, speed or position).
    pub const INTERNAL_LIMIT: u16 = 1 << 11;
    /// Bit 12 in CSV: drive follows the command value (clear: the target is ignored).
    pub const FOLLOWING: u16 = 1 << 12;
}

/// Controlword commands (CiA 402, Tab. 28).
pub mod controlword {
    /// Shutdown: → ready to switch on.
    pub const SHUTDOWN: u16 = 0x0006;
    /// Switch on: → switched on.
    pub const SWITCH_ON: u16 = 0x0007;
    /// Enable operation: → operation enabled (and stay there).
    pub const ENABLE_OPERATION: u16 = 0x000F;
    /// Disable voltage: → switch on disabled.
    pub const DISABLE_VOLTAGE: u16 = 0x0000;
    /// Quick stop: the drive brakes on its quick-stop ramp.
    pub const QUICK_STOP: u16 = 0x0002;
    /// Fault reset (acts on the rising edge of bit 7).
    pub const FAULT_RESET: u16 = 0x0080;
}

impl DriveState {
    /// Decodes a statusword.
    #[must_use]
    pub fn from_statusword(sw: u16) -> Self {
        match (sw & 0x4F, sw & 0x6F) {
            (0x00, _) => Self::NotReadyToSwitchOn,
            (0x40, _) => Self::SwitchOnDisabled,
            (_, 0x21) => Self::ReadyToSwitchOn,
            (_, 0x23) => Self::SwitchedOn,
            (_, 0x27) => Self::OperationEnabled,
            (_, 0x07) => Self::QuickStopActive,
            (0x0F, _) => Self::FaultReactionActive,
            (0x08, _) => Self::Fault,
            _ => Self::Unknown,
        }
    }

    /// The controlword that moves a healthy drive one step towards *operation enabled*
    /// (and keeps it there); `None` in a fault, which needs a deliberate reset.
    /// *Quick stop active* is left by *disable voltage* (transition 12), the way back to
    /// *switch on disabled*.
    #[must_use]
    pub fn enable_command(self) -> Option<u16> {
        match self {
            Self::QuickStopActive => Some(controlword::DISABLE_VOLTAGE),
            Self::NotReadyToSwitchOn | Self::SwitchOnDisabled | Self::Unknown => {
                Some(controlword::SHUTDOWN)
            }
            Self::ReadyToSwitchOn => Some(controlword::SWITCH_ON),
            Self::SwitchedOn | Self::OperationEnabled => Some(controlword::ENABLE_OPERATION),
            Self::FaultReactionActive | Self::Fault => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuswords_of_the_enable_sequence() {
        let sequence = [
            (0x0250, DriveState::SwitchOnDisabled),
            (0x0231, DriveState::ReadyToSwitchOn),
            (0x0233, DriveState::SwitchedOn),
            (0x0237, DriveState::OperationEnabled),
        ];
        for (sw, state) in sequence {
            assert_eq!(DriveState::from_statusword(sw), state, "{sw:#06x}");
        }
        assert_eq!(DriveState::from_statusword(0x0218), DriveState::Fault);
        assert_eq!(
            DriveState::from_statusword(0x021F),
            DriveState::FaultReactionActive
        );
        assert_eq!(
            DriveState::from_statusword(0x0217),
            DriveState::QuickStopActive
        );
        assert_eq!(
            DriveState::from_statusword(0x0000),
            DriveState::NotReadyToSwitchOn
        );
    }

    #[test]
    fn enabling_walks_the_state_machine() {
        assert_eq!(
            DriveState::SwitchOnDisabled.enable_command(),
            Some(controlword::SHUTDOWN)
        );
        assert_eq!(
            DriveState::ReadyToSwitchOn.enable_command(),
            Some(controlword::SWITCH_ON)
        );
        assert_eq!(
            DriveState::SwitchedOn.enable_command(),
            Some(controlword::ENABLE_OPERATION)
        );
        assert_eq!(
            DriveState::OperationEnabled.enable_command(),
            Some(controlword::ENABLE_OPERATION)
        );
        assert_eq!(
            DriveState::QuickStopActive.enable_command(),
            Some(controlword::DISABLE_VOLTAGE)
        );
        assert_eq!(DriveState::Fault.enable_command(), None);
    }
}
