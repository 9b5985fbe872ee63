//! From the inverse model's inputs (m/s) to the drives' target velocity, through
//! the one choke point that every set point passes before it is transmitted.
//!
//! The drives' factor group is configured so that one velocity unit of 0x60FF is
//! 1 µm/s: `i32` covers ±2147 m/s with a resolution far below the solver's error.
//! [`SetpointGate::admit`] is the only way to make a [`Setpoint`], and
//! [`crate::cia402::pdo::rpdo1`] only takes a [`Setpoint`]: a non-finite value, one
//! beyond the drive's velocity limit, or one that changes faster than its
//! acceleration limit cannot reach the bus.

use crate::drive::Drive;

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

/// Limits of both drives.
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

    /// The limits of one drive.
    #[must_use]
    pub fn of(&self, drive: Drive) -> AxisLimits {
        match drive {
            Drive::Trolley => self.trolley,
            Drive::Winch => self.winch,
        }
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
}

/// The choke point: remembers what was last sent to each drive and admits only
/// finite set points within the velocity and acceleration limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SetpointGate {
    limits: DriveLimits,
    /// Cycle time, s.
    period: f64,
    last: [Setpoint; 2],
}

/// Rounding slack on the acceleration check: one drive unit per cycle.
const ONE_UNIT: f64 = 1.0 / UNITS_PER_M_PER_S;

impl SetpointGate {
    /// A gate for drives with `limits`, transmitting every `period` seconds, both at standstill.
    #[must_use]
    pub fn new(limits: DriveLimits, period: f64) -> Self {
        Self {
            limits,
            period,
            last: [Setpoint::ZERO; 2],
        }
    }

    /// The limits enforced.
    #[must_use]
    pub fn limits(&self) -> DriveLimits {
        self.limits
    }

    /// The set point last admitted for `drive`.
    #[must_use]
    pub fn last(&self, drive: Drive) -> Setpoint {
        *drive.of(&self.last)
    }

    /// Admits `velocity` (m/s) for `drive`, or says why not. Nothing changes on refusal.
    pub fn admit(&mut self, drive: Drive, velocity: f64) -> Result<Setpoint, SetpointError> {
        if !velocity.is_finite() {
            return Err(SetpointError::NonFinite { drive });
        }
        let limits = self.limits.of(drive);
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
        // |units| ≤ max_velocity·1e6, far inside i32 for any plausible limit (< 2147 m/s).
        let setpoint = Setpoint(units as i32);
        *drive.of_mut(&mut self.last) = setpoint;
        Ok(setpoint)
    }

    /// The next set point of a ramp to standstill at the acceleration limit: always admissible.
    pub fn ramp_to_zero(&mut self, drive: Drive) -> Setpoint {
        let step = self.limits.of(drive).max_acceleration * self.period;
        let last = self.last(drive).metres_per_second();
        let next = if last.abs() <= step {
            0.0
        } else {
            last - step.copysign(last)
        };
        // Admissible by construction: |next| < |last| and |next − last| ≤ the step.
        self.admit(drive, next).unwrap_or(self.last(drive))
    }

    /// Whether both drives were last sent standstill.
    #[must_use]
    pub fn at_standstill(&self) -> bool {
        self.last.iter().all(|s| *s == Setpoint::ZERO)
    }
}
