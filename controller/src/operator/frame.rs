//! The operator's speed-demand frame: RPDO3 of the controller (0x400 + its node id; 0x410
//! by default), the master switch of a crane driven by hand (docs/COMMANDS.md).
//!
//! | byte | field | |
//! |---|---|---|
//! | 0 | alive counter (u8) | must change every frame (the dead-man, [`super::deadman`]) |
//! | 1 | flags (u8) | bit 0 enable (dead-man switch held), bit 1 manual mode requested, bit 2 micro-speed; bits 3–7 reserved, 0 |
//! | 2–3 | demand x (i16) | along x: the planar crane's trolley, the 3D crane's bridge |
//! | 4–5 | demand y (i16) | along y: the 3D crane's trolley; 0 for the planar crane |
//! | 6–7 | demand z (i16) | the hoist: positive lowers the load (its depth z_C grows) |
//!
//! Little endian (CiA 301). A demand is a fraction of that axis's configured manual
//! speed: ±[`FULL_SCALE`] is full stick either way; −32768 has no opposite and is refused.
//! The same fields are written over SDO into 0x2010 *Operator demand* (sub 1 the counter,
//! 2 the flags, 3–5 the demands), for a PLC without PDOs: writing the counter submits
//! them as one frame (`crate::node`).

use crate::canopen::{cob, CONTROLLER_NODE};
use crate::frame::CanFrame;

/// COB-ID of the operator's frames: RPDO3 of the controller (0x410 by default).
pub const OPERATOR_ID: u16 = operator_id(CONTROLLER_NODE);

/// COB-ID of the operator's frames of the controller at `node`.
#[must_use]
pub const fn operator_id(node: u8) -> u16 {
    cob::RPDO3 + node as u16
}

/// A demand of full stick: ±32767 is ± the axis's manual speed.
pub const FULL_SCALE: i16 = i16::MAX;

/// The fraction of the manual speed that full stick asks for with the micro-speed flag
/// set: fine positioning (a tenth, as pendants' second speed step usually is).
pub const MICRO_SPEED: f64 = 0.1;

/// Flag bits of byte 1.
const ENABLE: u8 = 1 << 0;
const MANUAL: u8 = 1 << 1;
const MICRO: u8 = 1 << 2;
const DEFINED: u8 = ENABLE | MANUAL | MICRO;

/// The frame's flags (byte 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Flags {
    /// Bit 0: the dead-man switch is held. Clear: the crane stops (a dead-man loss).
    pub enable: bool,
    /// Bit 1: the operator asks for manual mode (entered only at rest).
    pub manual: bool,
    /// Bit 2: micro-speed, full stick is [`MICRO_SPEED`] of the manual speed.
    pub micro: bool,
}

impl Flags {
    /// The flags' byte.
    #[must_use]
    pub fn byte(self) -> u8 {
        (if self.enable { ENABLE } else { 0 })
            | (if self.manual { MANUAL } else { 0 })
            | (if self.micro { MICRO } else { 0 })
    }
}

/// A decoded operator frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OperatorFrame {
    /// The alive counter (byte 0).
    pub counter: u8,
    /// The flags (byte 1).
    pub flags: Flags,
    /// The demands along x, y and z (bytes 2–7), in units of 1/[`FULL_SCALE`] of the
    /// manual speed, each within ±[`FULL_SCALE`].
    pub demand: [i16; 3],
}

/// Why an operator frame is malformed (it is then ignored and counted, as a malformed
/// command frame is).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OperatorError {
    /// Not 8 bytes.
    Length(u8),
    /// Reserved flag bits set (bits 3–7 of byte 1): a newer sender's meaning this
    /// controller does not know.
    ReservedFlags(u8),
    /// A demand of −32768 (axis 0 x, 1 y, 2 z): beyond full stick.
    OutOfRange(u8),
    /// A demand along y to a crane that has no such direction (the planar crane).
    NoSuchAxis,
}

/// Decodes an operator frame's 8 bytes (the layout in the module's documentation).
pub fn decode_operator(data: &[u8]) -> Result<OperatorFrame, OperatorError> {
    let [counter, flags, x0, x1, y0, y1, z0, z1] = *data else {
        return Err(OperatorError::Length(data.len() as u8));
    };
    if flags & !DEFINED != 0 {
        return Err(OperatorError::ReservedFlags(flags));
    }
    let demand = [
        i16::from_le_bytes([x0, x1]),
        i16::from_le_bytes([y0, y1]),
        i16::from_le_bytes([z0, z1]),
    ];
    if let Some(axis) = demand.iter().position(|d| *d == i16::MIN) {
        return Err(OperatorError::OutOfRange(axis as u8));
    }
    Ok(OperatorFrame {
        counter,
        flags: Flags {
            enable: flags & ENABLE != 0,
            manual: flags & MANUAL != 0,
            micro: flags & MICRO != 0,
        },
        demand,
    })
}

impl OperatorFrame {
    /// The frame's 8 bytes.
    #[must_use]
    pub fn bytes(&self) -> [u8; 8] {
        let [x, y, z] = self.demand;
        let ([x0, x1], [y0, y1], [z0, z1]) = (x.to_le_bytes(), y.to_le_bytes(), z.to_le_bytes());
        [self.counter, self.flags.byte(), x0, x1, y0, y1, z0, z1]
    }

    /// Whether a crane with `horizontal` horizontal directions (planar 1, 3D 2) can
    /// follow the frame: no demand along a direction it does not have.
    pub fn fits(&self, horizontal: usize) -> Result<(), OperatorError> {
        let [_, y, _] = self.demand;
        if horizontal < 2 && y != 0 {
            return Err(OperatorError::NoSuchAxis);
        }
        Ok(())
    }

    /// The stick's position for a crane with `NH` horizontal directions (planar 1: x;
    /// 3D 2: x, y) as fractions of full stick in `[−1, 1]`: the horizontal demands and
    /// the hoist's, micro-speed not applied (see [`OperatorFrame::demand`]). A demand
    /// along y to the planar crane is refused ([`OperatorError::NoSuchAxis`]): the
    /// operator pushes a stick the crane cannot follow, which is a wiring or
    /// configuration error, not a demand to drop silently.
    pub fn stick<const NH: usize>(&self) -> Result<([f64; NH], f64), OperatorError> {
        self.fits(NH)?;
        let [x, y, z] = self.demand;
        let fraction = |d: i16| f64::from(d) / f64::from(FULL_SCALE);
        let mut horizontal = [0.0; NH];
        for (slot, d) in horizontal.iter_mut().zip([x, y]) {
            *slot = fraction(d);
        }
        Ok((horizontal, fraction(z)))
    }

    /// The stick as the generator takes it, whose own `deadband` (a share of full
    /// stick) zeroes a demand inside it and maps `deadband..1` onto `0..1` of the manual
    /// speed. With the micro-speed flag the speed past the deadband is
    /// [`MICRO_SPEED`] of the manual one: the deadband applies to the stick's position
    /// (a micro stick moves past the same deadband as a plain one), and a position `p`
    /// past it is handed over as `deadband + MICRO_SPEED (p − deadband)` (with `p`'s
    /// sign), which the generator's deadband maps to `MICRO_SPEED` times what `p` asks
    /// for. Scaling before the deadband would give `(0.1 − 0.05)/0.95` = 5.3 % at full
    /// stick and nothing below half stick.
    pub fn demand<const NH: usize>(
        &self,
        deadband: f64,
    ) -> Result<([f64; NH], f64), OperatorError> {
        let (horizontal, hoist) = self.stick::<NH>()?;
        if !self.flags.micro {
            return Ok((horizontal, hoist));
        }
        let micro = |p: f64| {
            let a = p.abs();
            if a <= deadband {
                p
            } else {
                (deadband + MICRO_SPEED * (a - deadband)).copysign(p)
            }
        };
        Ok((horizontal.map(micro), micro(hoist)))
    }
}

/// The operator frame of the controller at `node` (for the operator's side, the tests
/// and the virtual bus).
#[must_use]
pub fn operator_frame(node: u8, frame: &OperatorFrame) -> CanFrame {
    CanFrame::fixed(operator_id(node), &frame.bytes())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    fn frame(counter: u8, flags: Flags, demand: [i16; 3]) -> OperatorFrame {
        OperatorFrame {
            counter,
            flags,
            demand,
        }
    }

    const HELD: Flags = Flags {
        enable: true,
        manual: true,
        micro: false,
    };

    #[test]
    fn the_layout_is_the_documented_one() {
        let f = frame(0x2A, HELD, [FULL_SCALE, -1, -FULL_SCALE]);
        let c = operator_frame(CONTROLLER_NODE, &f);
        assert_eq!(c.id(), 0x410);
        assert_eq!(c.data(), [0x2A, 0b011, 0xFF, 0x7F, 0xFF, 0xFF, 0x01, 0x80]);
        assert_eq!(decode_operator(c.data()), Ok(f));
        assert_eq!(operator_id(0x20), 0x420);
    }

    #[test]
    fn every_flag_is_its_bit() {
        for bits in 0..8u8 {
            let data = [0, bits, 0, 0, 0, 0, 0, 0];
            let f = decode_operator(&data).unwrap();
            assert_eq!(f.flags.enable, bits & 1 != 0);
            assert_eq!(f.flags.manual, bits & 2 != 0);
            assert_eq!(f.flags.micro, bits & 4 != 0);
            assert_eq!(f.bytes(), data);
        }
    }

    #[test]
    fn malformed_frames_are_refused() {
        assert_eq!(decode_operator(&[]), Err(OperatorError::Length(0)));
        assert_eq!(decode_operator(&[1; 7]), Err(OperatorError::Length(7)));
        assert_eq!(decode_operator(&[1, 1]), Err(OperatorError::Length(2)));
        for bit in 3..8 {
            let flags = (1u8 << bit) | 1;
            assert_eq!(
                decode_operator(&[0, flags, 0, 0, 0, 0, 0, 0]),
                Err(OperatorError::ReservedFlags(flags))
            );
        }
        for axis in 0..3u8 {
            let mut data = [0u8; 8];
            data[2 + 2 * usize::from(axis)..4 + 2 * usize::from(axis)]
                .copy_from_slice(&i16::MIN.to_le_bytes());
            assert_eq!(decode_operator(&data), Err(OperatorError::OutOfRange(axis)));
        }
    }

    #[test]
    fn the_stick_is_a_fraction_of_the_manual_speed() {
        let f = frame(0, HELD, [FULL_SCALE, 0, -FULL_SCALE / 2]);
        let (h, z) = f.stick::<1>().unwrap();
        assert_eq!(h, [1.0]);
        assert!((z + 0.5).abs() < 1e-4, "{z}");
        let micro = Flags {
            micro: true,
            ..HELD
        };
        let f = frame(0, micro, [-FULL_SCALE, FULL_SCALE, FULL_SCALE / 2]);
        let (h, z) = f.stick::<2>().unwrap();
        assert_eq!(h, [-1.0, 1.0], "the stick's position");
        assert!((z - 0.5).abs() < 1e-4, "{z}");
        // Past the deadband (5 %), micro-speed is a tenth of what the position asks:
        // the generator maps (d - 0.05)/0.95 to the manual speed.
        let (h, z) = f.demand::<2>(0.05).unwrap();
        let speed = |d: f64| (d.abs() - 0.05) / 0.95 * d.signum();
        assert!((speed(h[0]) + 0.1).abs() < 1e-12, "{h:?}");
        assert!((speed(h[1]) - 0.1).abs() < 1e-12, "{h:?}");
        assert!((speed(z) - 0.1 * speed(0.5)).abs() < 1e-4, "{z}");
        // Inside the deadband nothing moves, micro or not; a plain frame is the stick.
        let (h, _) = frame(0, micro, [1000, 0, 0]).demand::<1>(0.05).unwrap();
        assert!(h[0].abs() <= 0.05);
        assert_eq!(
            frame(0, HELD, [FULL_SCALE, 0, 0]).demand::<1>(0.05),
            frame(0, HELD, [FULL_SCALE, 0, 0]).stick::<1>()
        );
    }

    #[test]
    fn the_planar_crane_refuses_a_demand_along_y() {
        let f = frame(0, HELD, [0, 1, 0]);
        assert_eq!(f.stick::<1>(), Err(OperatorError::NoSuchAxis));
        assert!(f.stick::<2>().is_ok());
    }
}
