//! The inclinometer's process data (CiA 410, device profile for inclinometers): the
//! objects the controller reads and the TPDO that carries them. How an angle becomes
//! the swing φ of Eq. 20 is the commissioning file's business
//! ([`crate::commissioning::InclinometerSetup::angle`]).
//!
//! | PDO | objects | bytes |
//! |---|---|---|
//! | TPDO1 (inclinometer → controller) | slope long16 0x6010 | i16 |

use crate::canopen::{cob, DecodeError};
use crate::frame::CanFrame;

/// 0x6000 *resolution* of the 16-bit slopes, in 0.001°.
pub const RESOLUTION: u16 = 0x6000;
/// 0x6010 *slope long16*: the angle about the lateral axis, in resolution units.
pub const SLOPE_LONG16: u16 = 0x6010;

/// TPDO1's mapping entry (0x1A00): slope long16 (0x6010, 16 bit), as CiA 301 writes an
/// entry: index, sub-index 0, length in bits.
pub const TPDO1_MAPPING: [u32; 1] = [(SLOPE_LONG16 as u32) << 16 | 16];

/// TPDO1 of the inclinometer at `node`: *slope long16*. The controller only receives
/// it; the encoder serves tests and the virtual bus.
#[must_use]
pub fn tpdo1(node: u8, slope_long: i16) -> CanFrame {
    CanFrame::fixed(cob::TPDO1 + u16::from(node), &slope_long.to_le_bytes())
}

/// The *slope long16* in the inclinometer's TPDO1.
pub fn decode_tpdo1(frame: &CanFrame) -> Result<i16, DecodeError> {
    match *frame.data() {
        [a, b] => Ok(i16::from_le_bytes([a, b])),
        _ => Err(DecodeError::WrongLength {
            id: frame.id(),
            expected: 2,
            got: frame.data().len() as u8,
        }),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn the_mapping_entry_is_slope_long16_in_16_bits() {
        assert_eq!(TPDO1_MAPPING, [0x6010_0010]);
    }

    #[test]
    fn slope_round_trips_and_a_wrong_length_is_refused() {
        for slope in [0, -1, 123, i16::MIN, i16::MAX] {
            assert_eq!(decode_tpdo1(&tpdo1(3, slope)), Ok(slope));
        }
        assert_eq!(
            decode_tpdo1(&CanFrame::new(0x183, &[1, 2, 3]).unwrap()),
            Err(DecodeError::WrongLength {
                id: 0x183,
                expected: 2,
                got: 3
            })
        );
    }
}
