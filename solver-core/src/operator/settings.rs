//! What the operator-mode generator is told: the cycle, each axis's manual speed and
//! acceleration and where it may go, the filters' windows and the robust setting — and
//! what follows from them once ([`Tuning`]): the quanta of the integer rate limiter,
//! the window lengths in cycles, the bounds in quanta.

use crate::error::{check_positive, check_range, Error, Result};
use crate::operator::limiter::MAX_STEP;

/// One axis's manual-mode limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisSettings {
    /// The manual speed V: the speed of a full stick, m/s.
    pub speed: f64,
    /// The acceleration limit A of the unfiltered demand, m/s²: the load's acceleration
    /// never exceeds it (the filters average it with non-negative weights).
    pub acceleration: f64,
    /// Where the load — and, for bridge and trolley, the drive carrying it — may go,
    /// `(min, max)`, m. For the hoist: the load's depth `z_C` below the rope's exit
    /// ([`Settings::depth_range`] derives it from the rope's range).
    pub range: (f64, f64),
}

/// The generator's settings for a crane with `NH` horizontal axes (1: the planar crane's
/// trolley; 2: the 3D crane's bridge and trolley) and a hoist.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings<const NH: usize> {
    /// The cycle h, s: the generator's knots, and every window is a whole number of them.
    pub h: f64,
    /// Gravity, m/s².
    pub g: f64,
    /// The horizontal axes in the model's output order (planar: x; 3D: x, y).
    pub horizontal: [AxisSettings; NH],
    /// The hoist: speed and acceleration of the load's depth, and the depth's range.
    pub hoist: AxisSettings,
    /// The two moving-average windows of the horizontal filter, s (multiples of h).
    pub boxes: [f64; 2],
    /// The four moving-average windows of the hoist's filter, s (multiples of h).
    pub hoist_boxes: [f64; 4],
    /// How much deeper than where it would stop the hoist may lower the load while the
    /// horizontal axes move, m: the generator's pendulum is tuned for that depth when
    /// horizontal motion starts (a longer pendulum costs stopping distance).
    pub lowering_allowance: f64,
    /// The robust setting: one more zero-vibration pair tuned to the rope length at the
    /// start of each horizontal motion, against an error in the effective pendulum
    /// length (rope + rigging), at the cost of `v·T_r/4` more stopping distance.
    pub robust: bool,
    /// The stick's deadband, as a share of full stick: demands within it are zero, the
    /// rest is scaled so that full stick stays full speed.
    pub deadband: f64,
    /// The longest a hand-over's stop of the running move may last, s (a multiple of h):
    /// the generator takes the shortest that keeps within the drives' headroom
    /// (`Generator::take_over`), and refuses the hand-over if none this long does.
    pub entry_blend: f64,
}

/// Largest hoist acceleration as a share of g: the rope's tension never drops below
/// half the load's weight (the planner's "well below g").
pub const MAX_HOIST_ACCELERATION: f64 = 0.5;

/// Largest `ω_g h` the pendulum stage's Taylor series is summed for (its twelve terms
/// leave `(ω_g h)¹²/12! < 10⁻²⁰` of the swing's size): `l_g ≥ g (h/0.1)²`, 0.1 m at 10 ms.
pub const MAX_OMEGA_H: f64 = 0.1;

/// A window as a whole number of cycles, refusing one that is not (to 1 µs) or is shorter
/// than a cycle.
///
/// Fails closed: written as the negation of what passes, so that a cycle `h` that is not
/// a number (`window/h` NaN, every comparison with it false) is refused, not taken as
/// 0 cycles.
pub(crate) fn cycles(name: &'static str, window: f64, h: f64) -> Result<usize> {
    check_positive(name, window)?;
    let m = libm::round(window / h);
    if !((1.0..=f64::from(u16::MAX)).contains(&m) && libm::fabs(m * h - window) <= 1e-6) {
        return Err(Error::InvalidSetting {
            name,
            value: window,
        });
    }
    Ok(m as usize)
}

impl<const NH: usize> Settings<NH> {
    /// Refuses non-finite, non-physical or unsupported values.
    pub fn validate(&self) -> Result<()> {
        check_positive("h", self.h)?;
        check_positive("g", self.g)?;
        for axis in self.horizontal.iter() {
            check_axis(axis)?;
        }
        check_axis(&self.hoist)?;
        check_range(
            "hoist acceleration",
            self.hoist.acceleration,
            0.0,
            MAX_HOIST_ACCELERATION * self.g,
        )?;
        check_positive("hoist range min", self.hoist.range.0)?;
        for b in self.boxes {
            cycles("box", b, self.h)?;
        }
        for b in self.hoist_boxes {
            cycles("hoist box", b, self.h)?;
        }
        check_range("lowering_allowance", self.lowering_allowance, 0.0, f64::MAX)?;
        check_range("deadband", self.deadband, 0.0, 0.5)?;
        cycles("entry_blend", self.entry_blend, self.h)?;
        // The shortest generator pendulum: for the shallowest load.
        let omega_h = self.h * libm::sqrt(self.g / self.pendulum_for(self.hoist.range.0));
        check_omega_h(omega_h)
    }

    /// The shortest generator pendulum `l_g` that is never shorter than the load's
    /// effective pendulum at depth `z` while the hoist accelerates it downwards by up to
    /// its limit `A_z`: `l_g = z g/(g − A_z)` (the flat inverse's `ω² = (g − z̈_C)/z_C`).
    #[must_use]
    pub fn pendulum_for(&self, z: f64) -> f64 {
        z * self.g / (self.g - self.hoist.acceleration)
    }

    /// The depth range that keeps the rope within `[l_min, l_max]`: `z_C ≤ l ≤ z_C √(1 + s²)`
    /// with the rope's slope `s = tan φ ≤ |a_h|/(g − A_z)`, `|a_h|` the largest horizontal
    /// acceleration of the load (the settings' accelerations as a vector).
    #[must_use]
    pub fn depth_range(&self, (l_min, l_max): (f64, f64)) -> (f64, f64) {
        let a2: f64 = self
            .horizontal
            .iter()
            .map(|a| a.acceleration * a.acceleration)
            .sum();
        let s = libm::sqrt(a2) / (self.g - self.hoist.acceleration);
        (l_min, l_max / libm::sqrt(1.0 + s * s))
    }

    /// The ring buffers' least lengths for these settings: the horizontal one (the
    /// filter numerator's longest delay — the generator pendulum's zero-vibration pair at
    /// the deepest load, the robust pair at the same rope, the two windows — and one), and
    /// the hoist's (its four windows and one).
    pub fn ring_lengths(&self) -> Result<(usize, usize)> {
        self.validate()?;
        let (_, z_max) = self.hoist.range;
        let mut longest = zv_cycles(self.pendulum_for(z_max), self.g, self.h, Rounding::Up);
        if self.robust {
            longest += zv_cycles(z_max, self.g, self.h, Rounding::Nearest);
        }
        for b in self.boxes {
            longest += cycles("box", b, self.h)?;
        }
        let mut hoist = 0;
        for b in self.hoist_boxes {
            hoist += cycles("hoist box", b, self.h)?;
        }
        Ok((longest + 1, hoist + 1))
    }
}

/// Refuses a `ω_g h` outside `[0, MAX_OMEGA_H]` — or not a number: written as the
/// negation of what passes (`NaN > MAX_OMEGA_H` is false, and let a NaN through).
fn check_omega_h(omega_h: f64) -> Result<()> {
    if !(0.0..=MAX_OMEGA_H).contains(&omega_h) {
        return Err(Error::ParameterOutOfRange {
            name: "omega_g h",
            value: omega_h,
            min: 0.0,
            max: MAX_OMEGA_H,
        });
    }
    Ok(())
}

fn check_axis(a: &AxisSettings) -> Result<()> {
    check_positive("speed", a.speed)?;
    check_positive("acceleration", a.acceleration)?;
    let (lo, hi) = a.range;
    check_range("range min", lo, f64::MIN, f64::MAX)?;
    check_range("range max", hi, lo, f64::MAX)?;
    Ok(())
}

/// How a half period is made a whole number of cycles.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Rounding {
    /// Up: the generator pendulum, which may only be longer than asked (never shorter
    /// than the rope).
    Up,
    /// To the nearest: the robust pair, tuned as close to the rope as the cycle allows.
    Nearest,
}

/// The half period `π √(l/g)` of a pendulum of length `l` in cycles of `h` (at least one).
pub(crate) fn zv_cycles(l: f64, g: f64, h: f64, rounding: Rounding) -> usize {
    let half = core::f64::consts::PI * libm::sqrt(l / g) / h;
    let m = match rounding {
        // 1e-9: a half period that is a whole number of cycles to rounding stays one.
        Rounding::Up => libm::ceil(half - 1e-9),
        Rounding::Nearest => libm::round(half),
    };
    (m as usize).max(1)
}

/// One axis's quanta: the integer rate limiter moves in whole steps of these, so that a
/// stop ends at exactly zero speed and the filters' history is exact integers
/// (`operator::limiter`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quanta {
    /// Acceleration quantum `δa = A/127`, m/s².
    pub acceleration: f64,
    /// Velocity quantum `δv = δa h`, m/s.
    pub velocity: f64,
    /// Position unit `δp = δv h/2`, m: one step moves the position by `(2 n_v + k) δp`.
    pub position: f64,
}

impl Quanta {
    /// The quanta of an axis with acceleration limit `a` at cycle `h`.
    #[must_use]
    pub fn new(a: f64, h: f64) -> Self {
        let acceleration = a / f64::from(MAX_STEP);
        let velocity = acceleration * h;
        Self {
            acceleration,
            velocity,
            position: velocity * h * 0.5,
        }
    }
}

/// The manual-mode settings the lab cranes are studied with (`docs/OPERATOR.md`): 100 Hz,
/// windows of 0.2 s, a lowering allowance of 1 m, a 5 % deadband, hand-over stops
/// of at most 4 s; the rope's range from the crane's workspace.
const LAB_BOXES: [f64; 2] = [0.2, 0.2];
const LAB_HOIST_BOXES: [f64; 4] = [0.2; 4];

impl Settings<1> {
    /// The planar lab crane (`CraneParams::PAPER`'s workspace) driven by hand: the
    /// trolley at up to 1 m/s and 0.5 m/s², the hoist at up to 0.5 m/s and 0.5 m/s².
    #[must_use]
    pub fn lab(params: &crate::models::crane::CraneParams) -> Self {
        let w = params.workspace;
        let mut s = Self {
            h: 0.01,
            g: params.g,
            horizontal: [AxisSettings {
                speed: 1.0,
                acceleration: 0.5,
                range: (w.x_min, w.x_max),
            }],
            hoist: AxisSettings {
                speed: 0.5,
                acceleration: 0.5,
                range: (w.l_min, w.l_max),
            },
            boxes: LAB_BOXES,
            hoist_boxes: LAB_HOIST_BOXES,
            lowering_allowance: 1.0,
            robust: false,
            deadband: 0.05,
            entry_blend: 8.0,
        };
        s.hoist.range = s.depth_range((w.l_min, w.l_max));
        s
    }
}

impl Settings<2> {
    /// The 3D lab crane (`Crane3dParams::EXAMPLE`'s workspace) driven by hand: the bridge
    /// at up to 1 m/s and 0.5 m/s², the trolley at up to 0.8 m/s and 0.5 m/s², the hoist
    /// at up to 0.5 m/s and 0.5 m/s².
    #[must_use]
    pub fn lab_3d(params: &crate::models::crane3d::Crane3dParams) -> Self {
        let w = params.workspace;
        let mut s = Self {
            h: 0.01,
            g: params.g,
            horizontal: [
                AxisSettings {
                    speed: 1.0,
                    acceleration: 0.5,
                    range: (w.x_min, w.x_max),
                },
                AxisSettings {
                    speed: 0.8,
                    acceleration: 0.5,
                    range: (w.y_min, w.y_max),
                },
            ],
            hoist: AxisSettings {
                speed: 0.5,
                acceleration: 0.5,
                range: (w.l_min, w.l_max),
            },
            boxes: LAB_BOXES,
            hoist_boxes: LAB_HOIST_BOXES,
            lowering_allowance: 1.0,
            robust: false,
            deadband: 0.05,
            entry_blend: 8.0,
        };
        s.hoist.range = s.depth_range((w.l_min, w.l_max));
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A window over a cycle that is not a number is refused, not taken as 0 cycles:
    /// `window/h` is NaN then, and every `<`/`>` with NaN is false.
    #[test]
    fn a_window_over_a_cycle_that_is_not_a_number_is_refused() {
        assert_eq!(cycles("box", 0.2, 0.01), Ok(20));
        assert_eq!(
            cycles("box", 0.2, f64::NAN),
            Err(Error::InvalidSetting {
                name: "box",
                value: 0.2
            })
        );
    }

    /// A `ω_g h` that is not a number is refused, as one above the bound is.
    #[test]
    fn an_omega_h_that_is_not_a_number_is_refused() {
        assert_eq!(check_omega_h(MAX_OMEGA_H), Ok(()));
        for bad in [
            f64::NAN,
            MAX_OMEGA_H * (1.0 + f64::EPSILON),
            f64::INFINITY,
            -0.01,
        ] {
            assert!(
                matches!(
                    check_omega_h(bad),
                    Err(Error::ParameterOutOfRange {
                        name: "omega_g h",
                        ..
                    })
                ),
                "{bad}"
            );
        }
    }
}
