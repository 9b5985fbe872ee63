//! CiA 301 emergency error codes (Tab. 21) the controller sends or classifies, by name.
//! Codes 0xFF00..=0xFFFF are device specific; their meaning is in docs/COMMANDS.md.

/// Error reset or no error: a fault has been cleared.
pub const NO_ERROR: u16 = 0x0000;
/// Software reset (the watchdog restarted the controller).
pub const SOFTWARE_RESET: u16 = 0x6010;
/// Internal software: the inverse model failed.
pub const INTERNAL_SOFTWARE: u16 = 0x6100;
/// Communication, generic: set points could not be delivered.
pub const COMMUNICATION: u16 = 0x8100;
/// Life guard or heartbeat error: a drive's heartbeat stopped or reported a state other
/// than operational.
pub const HEARTBEAT: u16 = 0x8130;
/// Recovered from bus off (CiA 301) — not sent by this controller; named so that it is
/// not used for anything else.
pub const RECOVERED_FROM_BUS_OFF: u16 = 0x8140;
/// CAN-ID collision: another node sends with the controller's own node id.
pub const CAN_ID_COLLISION: u16 = 0x8150;
/// RPDO timeout: a drive's TPDO (the controller's receive PDO) stopped arriving.
pub const RPDO_TIMEOUT: u16 = 0x8250;
/// Device specific: a second deadline miss.
pub const DEADLINE: u16 = 0xFF01;
/// Device specific: a drive reported a fault.
pub const DRIVE_FAULT: u16 = 0xFF02;
/// Device specific: the set-point choke point refused the model's value.
pub const SETPOINT_REFUSED: u16 = 0xFF03;
/// Device specific: the model asked for motion of a drive that is not enabled.
pub const DRIVE_NOT_READY: u16 = 0xFF04;
/// Device specific: a drive reports a position or velocity it cannot have (outside the
/// workspace, beyond its limits, a jump it cannot make in a cycle).
pub const DRIVE_IMPLAUSIBLE: u16 = 0xFF05;
/// Device specific: commissioning a drive failed (drive, object and reason in the
/// manufacturer bytes).
pub const COMMISSIONING: u16 = 0xFF10;
/// Device specific: the SDO abort code of the commissioning failure announced by the
/// [`COMMISSIONING`] EMCY just before it — drive, object and abort code do not fit one
/// EMCY's five manufacturer bytes (manufacturer bytes: [`ABORT_CODE_FOLLOWS`], the abort
/// code as u32 little-endian; 0 when the failure was no SDO abort, e.g. a wrong device
/// type: the reason is in 0x2002:5).
///
/// Fault codes never take the values of the manufacturer bytes' other meanings: 15 (the
/// feedback warning, [`FEEDBACK_OFF`]) and 16 ([`ABORT_CODE_FOLLOWS`]).
pub const COMMISSIONING_ABORT: u16 = 0xFF12;
/// The first manufacturer byte of [`COMMISSIONING_ABORT`] (where other EMCYs of the
/// controller have their fault code): 16, not a fault of its own.
pub const ABORT_CODE_FOLLOWS: u8 = 16;
/// Device specific: a drive reports a mode of operation (0x6061) other than the
/// commissioned one.
pub const DRIVE_MODE: u16 = 0xFF11;
/// Device specific: the state feedback fell back to feedforward only — a warning
/// (manufacturer bytes: 15, inclinometer node, reason; docs/COMMANDS.md).
pub const FEEDBACK_OFF: u16 = 0xFF20;

/// Error register (0x1001) bit 0: generic error. CiA 301 requires it whenever any error
/// is present, so an EMCY without it is a warning (see [`is_fault`]).
pub const REGISTER_GENERIC: u8 = 0x01;
/// Error register bit 4: communication error.
pub const REGISTER_COMMUNICATION: u8 = 0x10;
/// Error register bit 7: manufacturer specific.
pub const REGISTER_MANUFACTURER: u8 = 0x80;

/// The rule by which a drive's EMCY is classified: a **fault** when its error code is not
/// *error reset* and its error register has the generic bit set (CiA 301 7.5.2.2: the
/// bit is set while any error is present); otherwise a **warning** (logged and counted,
/// no reaction). A drive's own fault is in any case seen in its statusword (bit 3).
#[must_use]
pub fn is_fault(code: u16, register: u8) -> bool {
    code != NO_ERROR && register & REGISTER_GENERIC != 0
}
