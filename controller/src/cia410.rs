//! The inclinometer's process data (CiA 410, device profile for inclinometers): the
//! objects the controller reads and the TPDO that carries them. How an angle becomes
//! the swing φ of Eq. 20 is the commissioning file's business
//! ([`crate::commissioning::InclinometerSetup::angle`]).
//!
//! | PDO | objects | bytes |
//! |---|---|---|
//! | TPDO1 (inclinometer → controller), one axis | slope long16 0x6010 | i16 |
//! | TPDO1, two axes (the 3D crane's) | slope long16 0x6010, slope lateral16 0x6020 | i16, i16 |

use crate::canopen::od::device::{SLOPE_LATERAL16, SLOPE_LONG16};
use crate::canopen::{cob, DecodeError};
use crate::frame::CanFrame;

/// TPDO1's mapping (0x1A00) of a one-axis inclinometer: slope long16.
pub const TPDO1_MAPPING: [u32; 1] = [SLOPE_LONG16.mapping()];

/// TPDO1's mapping of a two-axis inclinometer: slope long16, then slope lateral16.
pub const TPDO1_MAPPING_TWO_AXES: [u32; 2] = [SLOPE_LONG16.mapping(), SLOPE_LATERAL16.mapping()];

/// The slopes an inclinometer's TPDO1 carries, in resolution units: slope long16, and
/// slope lateral16 where two axes are mapped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Slopes {
    /// 0x6010 *slope long16*.
    pub long: i16,
    /// 0x6020 *slope lateral16* (two axes mapped).
    pub lateral: Option<i16>,
}

/// TPDO1 of the inclinometer at `node`: *slope long16*, and *slope lateral16* if it has
/// one (2 or 4 bytes). The controller only receives it; the encoder serves tests and the
/// virtual bus.
#[must_use]
pub fn tpdo1(node: u8, slopes: Slopes) -> CanFrame {
    let [a, b] = slopes.long.to_le_bytes();
    let id = cob::TPDO1 + u16::from(node);
    match slopes.lateral {
        None => CanFrame::fixed(id, &[a, b]),
        Some(lateral) => {
            let [c, d] = lateral.to_le_bytes();
            CanFrame::fixed(id, &[a, b, c, d])
        }
    }
}

/// The slopes in the inclinometer's TPDO1, as the mapping the controller commissioned
/// says (`two_axes`: slope long16 and slope lateral16, 4 bytes; otherwise 2).
pub fn decode_tpdo1(frame: &CanFrame, two_axes: bool) -> Result<Slopes, DecodeError> {
    match (frame.data(), two_axes) {
        (&[a, b], false) => Ok(Slopes {
            long: i16::from_le_bytes([a, b]),
            lateral: None,
        }),
        (&[a, b, c, d], true) => Ok(Slopes {
            long: i16::from_le_bytes([a, b]),
            lateral: Some(i16::from_le_bytes([c, d])),
        }),
        _ => Err(DecodeError::WrongLength {
            id: frame.id(),
            expected: if two_axes { 4 } else { 2 },
            got: frame.data().len() as u8,
        }),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn the_mapping_entries_are_the_slopes_in_16_bits() {
        assert_eq!(TPDO1_MAPPING, [0x6010_0010]);
        assert_eq!(TPDO1_MAPPING_TWO_AXES, [0x6010_0010, 0x6020_0010]);
    }

    #[test]
    fn slopes_round_trip_and_a_wrong_length_is_refused() {
        for long in [0, -1, 123, i16::MIN, i16::MAX] {
            for lateral in [None, Some(-7), Some(i16::MAX)] {
                let slopes = Slopes { long, lateral };
                let frame = tpdo1(3, slopes);
                assert_eq!(decode_tpdo1(&frame, lateral.is_some()), Ok(slopes));
                // A frame of the other mapping is not read as this one.
                assert!(decode_tpdo1(&frame, lateral.is_none()).is_err());
            }
        }
        assert_eq!(
            decode_tpdo1(&CanFrame::new(0x183, &[1, 2, 3]).unwrap(), false),
            Err(DecodeError::WrongLength {
                id: 0x183,
                expected: 2,
                got: 3
            })
        );
        assert_eq!(
            decode_tpdo1(&CanFrame::new(0x183, &[1, 2]).unwrap(), true),
            Err(DecodeError::WrongLength {
                id: 0x183,
                expected: 4,
                got: 2
            })
        );
    }
}
