//! From the inverse model's inputs (m/s) to the drives' target velocity, through
//! the one choke point that every set point passes before it is transmitted.
//!
//! The drives' factor group is configured so that one velocity unit of 0x60FF is
//! 1 µm/s: `i32` covers ±2147 m/s with a resolution far below the solver's error.
//! [`SetpointGate::admit`] is the only way to make a [`Setpoint`], and
//! [`crate::cia402::pdo::rpdo1`] only takes a [`Setpoint`]: a non-finite value, one
//! beyond the drive's velocity limit, or one that changes faster than its
//! acceleration limit cannot reach the bus.

use crate::drive::{Drive, Order, PLANAR};

/// Drive velocity units (0x60FF, 0x606C) per m/s.
pub const UNITS_PER_M_PER_S: f64 = 1e6;

/// Limits of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisLimits {
    /// Largest |velocity|, m/s.
    pub max_velocity: f64,
    /// Largest |acceleration|, m/s².
    pub max_acceleration: f64,
}

/// Limits of the planar crane's two drives.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DriveLimits {
    /// Trolley (u1).
    pub trolley: AxisLimits,
    /// Winch (u2).
    pub winch: AxisLimits,
}

impl DriveLimits {
    /// The laboratory crane's drives as configured here: trolley 3 m/s and 3 m/s²,
    /// winch 2 m/s and 3 m/s².
    pub const LAB: Self = Self {
        trolley: AxisLimits {
            max_velocity: 3.0,
            max_acceleration: 3.0,
        },
        winch: AxisLimits {
            max_velocity: 2.0,
            max_acceleration: 3.0,
        },
    };

    /// The limits of the 3D crane's lab drives, in its input order
    /// ([`SPATIAL`](crate::drive::SPATIAL): bridge, trolley, hoist): the bridge, the
    /// heaviest axis, takes the planar trolley's drive, the hoist the planar winch's, and
    /// the trolley across the bridge a lighter one (2 m/s, 2 m/s²). Assumed, as the 3D
    /// crane's parameters are (`Crane3dParams::EXAMPLE`).
    pub const LAB_3D: [AxisLimits; 3] = [
        Self::LAB.trolley,
        AxisLimits {
            max_velocity: 2.0,
            max_acceleration: 2.0,
        },
        Self::LAB.winch,
    ];

    /// The limits in the planar crane's input order ([`PLANAR`]).
    #[must_use]
    pub const fn axes(&self) -> [AxisLimits; 2] {
        [self.trolley, self.winch]
    }

    /// The planar limits of `axes`, in [`PLANAR`] order.
    #[must_use]
    pub const fn from_axes(axes: [AxisLimits; 2]) -> Self {
        let [trolley, winch] = axes;
        Self { trolley, winch }
    }
}

/// A target velocity that passed the choke point, in drive units (µm/s).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Setpoint(i32);

impl Setpoint {
    /// Standstill.
    pub const ZERO: Setpoint = Setpoint(0);

    /// The value in drive units.
    #[must_use]
    pub fn units(self) -> i32 {
        self.0
    }

    /// The value in m/s.
    #[must_use]
    pub fn metres_per_second(self) -> f64 {
        f64::from(self.0) / UNITS_PER_M_PER_S
    }
}

/// Why a velocity was refused at the choke point.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SetpointError {
    /// NaN or infinite.
    NonFinite {
        /// Which drive.
        drive: Drive,
    },
    /// Beyond the velocity limit.
    OverSpeed {
        /// Which drive.
        drive: Drive,
        /// Requested velocity, m/s.
        value: f64,
        /// Limit, m/s.
        limit: f64,
    },
    /// Changes faster than the acceleration limit allows within one cycle.
    OverAcceleration {
        /// Which drive.
        drive: Drive,
        /// Implied acceleration, m/s².
        value: f64,
        /// Limit, m/s².
        limit: f64,
    },
    /// The crane has no such drive (the gate knows no limits for it).
    NoDrive {
        /// Which drive.
        drive: Drive,
    },
}

/// The choke point: remembers what was last sent to each of the crane's `A` drives and
/// admits only finite set points within the velocity and acceleration limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetpointGate<const A: usize = 2> {
    /// The drives, in the model's input order: the order of `limits` and `last`.
    drives: Order<A>,
    limits: [AxisLimits; A],
    /// Cycle time, s.
    period: f64,
    last: [Setpoint; A],
}

/// The largest set-point velocity limit a drive may be given, m/s: 0x60FF's i32 in µm/s
/// holds 2,147 m/s, and no crane drive comes near this (the commissioning file refuses a
/// larger `velocity_limit`).
pub const MAX_VELOCITY_LIMIT: f64 = 100.0;

/// Rounding slack on the acceleration check: one drive unit per cycle.
const ONE_UNIT: f64 = 1.0 / UNITS_PER_M_PER_S;

impl SetpointGate {
    /// A gate for the planar crane's drives with `limits`, transmitting every `period`
    /// seconds, both at standstill.
    #[must_use]
    pub fn new(limits: DriveLimits, period: f64) -> Self {
        Self::with_axes(PLANAR, limits.axes(), period)
    }
}

impl<const A: usize> SetpointGate<A> {
    /// A gate for `drives` with `limits` (in the same order), transmitting every `period`
    /// seconds, all at standstill. A velocity limit above [`MAX_VELOCITY_LIMIT`] (or not
    /// a number) is taken as that: every admitted set point then fits 0x60FF's i32,
    /// checked here once rather than on every set point. (The commissioning file
    /// refuses such a limit with an error; this is the backstop for a gate built in
    /// code.)
    #[must_use]
    pub fn with_axes(drives: [Drive; A], limits: [AxisLimits; A], period: f64) -> Self {
        Self {
            drives: Order::new(drives),
            limits: limits.map(|l| AxisLimits {
                max_velocity: l.max_velocity.min(MAX_VELOCITY_LIMIT),
                ..l
            }),
            period,
            last: [Setpoint::ZERO; A],
        }
    }

    /// The limits of `drive` (`None`: the crane has no such drive).
    #[must_use]
    pub fn limits(&self, drive: Drive) -> Option<AxisLimits> {
        self.drives.of(drive, &self.limits).copied()
    }

    /// The set point last admitted for `drive` (standstill for a drive the crane lacks).
    #[must_use]
    pub fn last(&self, drive: Drive) -> Setpoint {
        self.drives
            .of(drive, &self.last)
            .map_or(Setpoint::ZERO, |s| *s)
    }

    /// Every drive's last set point, m/s, in the model's input order.
    #[must_use]
    pub fn last_velocities(&self) -> [f64; A] {
        self.last.map(Setpoint::metres_per_second)
    }

    /// Admits `velocity` (m/s) for `drive`, or says why not. Nothing changes on refusal.
    pub fn admit(&mut self, drive: Drive, velocity: f64) -> Result<Setpoint, SetpointError> {
        if !velocity.is_finite() {
            return Err(SetpointError::NonFinite { drive });
        }
        let limits = self.limits(drive).ok_or(SetpointError::NoDrive { drive })?;
        if velocity.abs() > limits.max_velocity {
            return Err(SetpointError::OverSpeed {
                drive,
                value: velocity,
                limit: limits.max_velocity,
            });
        }
        let units = libm::round(velocity * UNITS_PER_M_PER_S);
        let change = (units - f64::from(self.last(drive).units())) / UNITS_PER_M_PER_S;
        if change.abs() > limits.max_acceleration * self.period + ONE_UNIT {
            return Err(SetpointError::OverAcceleration {
                drive,
                value: change / self.period,
                limit: limits.max_acceleration,
            });
        }
        // |units| ≤ max_velocity·1e6 ≤ 1e8 (`with_axes` caps the limit at
        // `MAX_VELOCITY_LIMIT`): a whole number within i32's range, so the conversion is
        // exact, never saturated into a set point other than the one checked.
        let setpoint = Setpoint(units as i32);
        if let Some(last) = self.drives.of_mut(drive, &mut self.last) {
            *last = setpoint;
        }
        Ok(setpoint)
    }

    /// The next set point of a ramp to standstill at the acceleration limit: always admissible.
    pub fn ramp_to_zero(&mut self, drive: Drive) -> Setpoint {
        let Some(limits) = self.limits(drive) else {
            return Setpoint::ZERO;
        };
        let step = limits.max_acceleration * self.period;
        let last = self.last(drive).metres_per_second();
        let next = if last.abs() <= step {
            0.0
        } else {
            last - step.copysign(last)
        };
        // Admissible by construction: |next| < |last| and |next − last| ≤ the step.
        self.admit(drive, next).unwrap_or(self.last(drive))
    }

    /// Whether every drive was last sent standstill.
    #[must_use]
    pub fn at_standstill(&self) -> bool {
        self.last.iter().all(|s| *s == Setpoint::ZERO)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A set point outside 0x60FF's i32 is refused, never saturated into another one —
    /// even where a (wrong) limit would admit it: the gate caps the limit at
    /// [`MAX_VELOCITY_LIMIT`], and a limit that is not a number too.
    #[test]
    fn a_set_point_outside_the_drive_units_range_is_refused() {
        for wrong in [5_000.0, f64::INFINITY, f64::NAN] {
            let limits = AxisLimits {
                max_velocity: wrong,
                max_acceleration: 1e9,
            };
            let mut gate = SetpointGate::with_axes(PLANAR, [limits; 2], 0.01);
            for refused in [2_500.0, 100.001] {
                assert_eq!(
                    gate.admit(Drive::Trolley, refused),
                    Err(SetpointError::OverSpeed {
                        drive: Drive::Trolley,
                        value: refused,
                        limit: MAX_VELOCITY_LIMIT
                    }),
                    "limit {wrong}"
                );
            }
            assert_eq!(gate.last(Drive::Trolley), Setpoint::ZERO);
            assert_eq!(
                gate.admit(Drive::Trolley, -MAX_VELOCITY_LIMIT)
                    .map(Setpoint::units),
                Ok(-100_000_000)
            );
        }
    }

    /// A drive the crane does not have is refused by name.
    #[test]
    fn a_drive_the_crane_lacks_is_refused() {
        let mut gate = SetpointGate::new(DriveLimits::LAB, 0.01);
        assert_eq!(
            gate.admit(Drive::Bridge, 0.1),
            Err(SetpointError::NoDrive {
                drive: Drive::Bridge
            })
        );
        assert_eq!(gate.ramp_to_zero(Drive::Bridge), Setpoint::ZERO);
    }
}
