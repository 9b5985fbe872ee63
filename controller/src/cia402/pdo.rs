//! A drive's process data: which CiA 402 objects each PDO carries (the mapping the
//! commissioning writes) and their bytes. The CiA 301 layer ([`crate::canopen`]) only
//! knows a PDO by its COB-ID; what is inside is this profile's.
//!
//! | PDO | objects | bytes |
//! |---|---|---|
//! | RPDO1 (controller → drive) | controlword 0x6040, target velocity 0x60FF | u16, i32 |
//! | TPDO1 (drive → controller) | statusword 0x6041, velocity actual 0x606C | u16, i32 |
//! | TPDO2 (drive → controller) | position actual 0x6064, modes of operation display 0x6061 | i32, i8 |
//!
//! All values little endian (CiA 301), in the drive's units (1 µm/s, 1 µm by default;
//! see [`crate::setpoint`]).

use crate::canopen::od::device::{
    CONTROLWORD, MODES_DISPLAY, POSITION_ACTUAL, STATUSWORD, TARGET_VELOCITY, VELOCITY_ACTUAL,
};
use crate::canopen::{cob, DecodeError};
use crate::frame::CanFrame;
use crate::setpoint::Setpoint;

/// RPDO1's mapping entries (0x1600): controlword (0x6040, 16 bit), target velocity
/// (0x60FF, 32 bit).
pub const RPDO1_MAPPING: [u32; 2] = [CONTROLWORD.mapping(), TARGET_VELOCITY.mapping()];
/// TPDO1's mapping entries (0x1A00): statusword (0x6041, 16 bit), velocity actual
/// (0x606C, 32 bit).
pub const TPDO1_MAPPING: [u32; 2] = [STATUSWORD.mapping(), VELOCITY_ACTUAL.mapping()];
/// TPDO2's mapping entries (0x1A01): position actual (0x6064, 32 bit), modes of
/// operation display (0x6061, 8 bit).
pub const TPDO2_MAPPING: [u32; 2] = [POSITION_ACTUAL.mapping(), MODES_DISPLAY.mapping()];

/// RPDO1 to the drive at `node`: controlword (0x6040) and target velocity (0x60FF). The
/// velocity is a [`Setpoint`], so it has passed the choke point of [`crate::setpoint`].
#[must_use]
pub fn rpdo1(node: u8, controlword: u16, target_velocity: Setpoint) -> CanFrame {
    let [c0, c1] = controlword.to_le_bytes();
    let [v0, v1, v2, v3] = target_velocity.units().to_le_bytes();
    CanFrame::fixed(cob::RPDO1 + u16::from(node), &[c0, c1, v0, v1, v2, v3])
}

/// TPDO1 of a drive: statusword (0x6041) and velocity actual value (0x606C).
/// The controller only receives these; the encoder serves tests and the virtual bus.
#[must_use]
pub fn tpdo1(node: u8, statusword: u16, velocity: i32) -> CanFrame {
    let [s0, s1] = statusword.to_le_bytes();
    let [v0, v1, v2, v3] = velocity.to_le_bytes();
    CanFrame::fixed(cob::TPDO1 + u16::from(node), &[s0, s1, v0, v1, v2, v3])
}

/// TPDO2 of a drive: position actual value (0x6064) and modes of operation display (0x6061).
#[must_use]
pub fn tpdo2(node: u8, position: i32, mode: i8) -> CanFrame {
    let [p0, p1, p2, p3] = position.to_le_bytes();
    CanFrame::fixed(cob::TPDO2 + u16::from(node), &[p0, p1, p2, p3, mode as u8])
}

/// What a drive's TPDO reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Tpdo {
    /// TPDO1.
    Status {
        /// Statusword (0x6041).
        statusword: u16,
        /// Velocity actual value (0x606C), drive units.
        velocity: i32,
    },
    /// TPDO2.
    Position {
        /// Position actual value (0x6064), drive units.
        position: i32,
        /// Modes of operation display (0x6061).
        mode: i8,
    },
}

impl Tpdo {
    /// The contents of a drive's TPDO1 or TPDO2 as [`crate::canopen::decode`] handed it
    /// over (`Incoming::Tpdo`).
    pub fn decode(frame: &CanFrame) -> Result<Tpdo, DecodeError> {
        let id = frame.id();
        let wrong = |expected: u8| DecodeError::WrongLength {
            id,
            expected,
            got: frame.data().len() as u8,
        };
        match (id & cob::FUNCTION, frame.data()) {
            (cob::TPDO1, &[s0, s1, v0, v1, v2, v3]) => Ok(Tpdo::Status {
                statusword: u16::from_le_bytes([s0, s1]),
                velocity: i32::from_le_bytes([v0, v1, v2, v3]),
            }),
            (cob::TPDO1, _) => Err(wrong(6)),
            (cob::TPDO2, &[p0, p1, p2, p3, m]) => Ok(Tpdo::Position {
                position: i32::from_le_bytes([p0, p1, p2, p3]),
                mode: m as i8,
            }),
            (cob::TPDO2, _) => Err(wrong(5)),
            _ => Err(DecodeError::UnknownId(id)),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// The mappings CiA 402 drives are commissioned with, spelled out: index, sub-index,
    /// bits.
    #[test]
    fn mappings_are_the_profile_s_objects() {
        assert_eq!(RPDO1_MAPPING, [0x6040_0010, 0x60FF_0020]);
        assert_eq!(TPDO1_MAPPING, [0x6041_0010, 0x606C_0020]);
        assert_eq!(TPDO2_MAPPING, [0x6064_0020, 0x6061_0008]);
    }

    #[test]
    fn tpdos_round_trip() {
        for (velocity, statusword) in [(0, 0x0237), (-1_234_567, 0x0008), (i32::MAX, 0xFFFF)] {
            assert_eq!(
                Tpdo::decode(&tpdo1(2, statusword, velocity)),
                Ok(Tpdo::Status {
                    statusword,
                    velocity
                })
            );
        }
        assert_eq!(
            Tpdo::decode(&tpdo2(1, -12_000_000, 9)),
            Ok(Tpdo::Position {
                position: -12_000_000,
                mode: 9
            })
        );
    }

    #[test]
    fn malformed_tpdos_are_refused() {
        assert_eq!(
            Tpdo::decode(&CanFrame::new(0x181, &[1, 2, 3]).unwrap()),
            Err(DecodeError::WrongLength {
                id: 0x181,
                expected: 6,
                got: 3
            })
        );
        assert_eq!(
            Tpdo::decode(&CanFrame::new(0x282, &[0; 6]).unwrap()),
            Err(DecodeError::WrongLength {
                id: 0x282,
                expected: 5,
                got: 6
            })
        );
        assert_eq!(
            Tpdo::decode(&rpdo1(1, 0x0F, Setpoint::ZERO)),
            Err(DecodeError::UnknownId(0x201))
        );
    }
}
