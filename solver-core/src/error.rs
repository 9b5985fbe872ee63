//! Typed errors with context. Nothing in this crate panics on bad input: every
//! refusal is one of these, carrying what a control engineer needs to act on it
//! (the time, the Newton iterations, the residual, the offending value).
//!
//! Context values are stored as `f64` whatever the solver's scalar, so an error
//! can be logged or compared without knowing how it was computed.

use core::fmt;

/// Everything that can go wrong, from a bad parameter to a Newton failure.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[must_use]
pub enum Error {
    /// The step size is not a finite positive number.
    InvalidStepSize {
        /// The offending step size in s.
        h: f64,
    },
    /// A model or solver parameter is NaN or infinite.
    NonFiniteParameter {
        /// Which parameter.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A parameter is outside the range in which the model is physical
    /// (a mass or time constant ≤ 0, an angle outside (0°, 90°), …).
    ParameterOutOfRange {
        /// Which parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Smallest admissible value.
        min: f64,
        /// Largest admissible value.
        max: f64,
    },
    /// A solver setting is outside what the scheme supports (BDF k ∉ 1..=6, ρ power > 3, …).
    InvalidSetting {
        /// Which setting.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// No stop of a hand-over from a running move keeps the drives' motion it adds within
    /// the headroom the caller leaves it, up to the longest stop allowed
    /// (`operator::Generator::take_over`).
    NoHandoverStop {
        /// The longest stop tried, s (`operator::Settings::entry_blend`).
        longest: f64,
    },
    /// The trajectory is not smooth enough for the model: its inputs would jump.
    TrajectoryTooRough {
        /// The trajectory's smoothness n (derivatives 1..n vanish at the ends).
        smoothness: usize,
        /// The smallest n the model accepts.
        required: usize,
    },
    /// The load's downward acceleration reaches (or comes too close to) g: the
    /// rope would go slack and the crane's inverse model is singular (λ → 0 in Eq. 25).
    RopeSlack {
        /// Time at which the margin is first violated, in s.
        t: f64,
        /// The desired vertical acceleration of the load, m/s² (positive downwards).
        vertical_acceleration: f64,
        /// The largest admissible vertical acceleration, m/s².
        limit: f64,
    },
    /// The inverse model needs a drive's axis or the rope outside the workspace.
    OutsideWorkspace {
        /// Time at which the workspace is first left, in s.
        t: f64,
        /// Which: `"x"` (the planar crane's trolley, the 3D crane's bridge), `"y"` (the
        /// 3D crane's trolley) or `"l"` (rope length).
        coordinate: &'static str,
        /// The required value, in m.
        value: f64,
        /// Workspace minimum, in m.
        min: f64,
        /// Workspace maximum, in m.
        max: f64,
    },
    /// BDF's start-up assumes the system at rest before `t0`, but the trajectory moves there.
    NotAtRest {
        /// The start time, in s.
        t: f64,
    },
    /// Newton did not meet its convergence test within the iteration cap.
    NewtonNotConverged {
        /// Time of the step, in s.
        t: f64,
        /// Iterations spent.
        iterations: u32,
        /// Max-norm of the (scaled) residual at the last iterate.
        residual: f64,
        /// Weighted max-norm of the last Newton increment (≤ 1 means converged).
        increment: f64,
    },
    /// The Newton matrix could not be factorised (or inverted, for Broyden).
    SingularJacobian {
        /// Time of the step, in s.
        t: f64,
        /// Iterations done before the failure.
        iterations: u32,
        /// Max-norm of the (scaled) residual at the iterate where it failed.
        residual: f64,
    },
    /// The adaptive reference integrator could not meet its tolerance (step size
    /// underflow or step budget exhausted).
    ReferenceFailed {
        /// Time reached, in s.
        t: f64,
        /// Last step size tried, in s.
        h: f64,
    },
    /// A residual, increment or solution component became NaN or infinite.
    NonFinite {
        /// Time of the step, in s.
        t: f64,
        /// Iterations done before the failure.
        iterations: u32,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::InvalidStepSize { h } => write!(f, "step size h = {h} s is not finite and positive"),
            Self::NonFiniteParameter { name, value } => write!(f, "parameter {name} = {value} is not finite"),
            // `check_positive`'s bounds said as what they mean, the open interval: its
            // `[MIN_POSITIVE, inf]` printed 300 digits of the smallest normal number.
            Self::ParameterOutOfRange { name, value, min, max } if min == f64::MIN_POSITIVE && max == f64::INFINITY => {
                write!(f, "parameter {name} = {} outside (0, inf)", Short(value))
            }
            Self::ParameterOutOfRange { name, value, min, max } => {
                write!(f, "parameter {name} = {} outside [{}, {}]", Short(value), Short(min), Short(max))
            }
            Self::InvalidSetting { name, value } => write!(f, "setting {name} = {value} is not supported"),
            Self::NoHandoverStop { longest } => write!(
                f,
                "no hand-over stop of at most {longest} s keeps the drives within the headroom left beside the operator"
            ),
            Self::TrajectoryTooRough { smoothness, required } => {
                write!(f, "trajectory smoothness n = {smoothness}, the model needs n >= {required}")
            }
            Self::RopeSlack { t, vertical_acceleration, limit } => write!(
                f,
                "t = {t} s: load acceleration {vertical_acceleration} m/s^2 downwards exceeds {limit} m/s^2 (rope would go slack)"
            ),
            Self::OutsideWorkspace { t, coordinate, value, min, max } => {
                write!(f, "t = {t} s: {coordinate} = {value} m outside the workspace [{min}, {max}] m")
            }
            Self::NotAtRest { t } => write!(f, "t = {t} s: trajectory not at rest at the start"),
            Self::NewtonNotConverged { t, iterations, residual, increment } => write!(
                f,
                "t = {t} s: Newton not converged after {iterations} iterations (residual {residual:e}, increment {increment:e})"
            ),
            Self::SingularJacobian { t, iterations, residual } => write!(
                f,
                "t = {t} s: singular Newton matrix at iteration {iterations} (residual {residual:e})"
            ),
            Self::ReferenceFailed { t, h } => write!(f, "t = {t} s: reference integration failed (h = {h:e} s)"),
            Self::NonFinite { t, iterations } => {
                write!(f, "t = {t} s: non-finite value at Newton iteration {iterations}")
            }
        }
    }
}

/// A number as short as its exact value allows: Rust's shortest round-trip digits (so a
/// refused value never prints equal to a bound it differs from), in exponent form where
/// the positional one is long (`f64::MAX` is 309 digits, `f64::MIN_POSITIVE` 310).
struct Short(f64);

impl fmt::Display for Short {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = libm::fabs(self.0);
        if a.is_finite() && (a >= 1e16 || (a != 0.0 && a < 1e-5)) {
            write!(f, "{:e}", self.0)
        } else {
            write!(f, "{}", self.0)
        }
    }
}

impl core::error::Error for Error {}

/// Result with this crate's [`Error`].
pub type Result<T> = core::result::Result<T, Error>;

/// Checks that a parameter is finite and within `[min, max]`.
pub(crate) fn check_range(name: &'static str, value: f64, min: f64, max: f64) -> Result<()> {
    if !value.is_finite() {
        return Err(Error::NonFiniteParameter { name, value });
    }
    if value < min || value > max {
        return Err(Error::ParameterOutOfRange {
            name,
            value,
            min,
            max,
        });
    }
    Ok(())
}

/// Checks that a parameter is finite and strictly positive.
pub(crate) fn check_positive(name: &'static str, value: f64) -> Result<()> {
    if !value.is_finite() {
        return Err(Error::NonFiniteParameter { name, value });
    }
    if value <= 0.0 {
        return Err(Error::ParameterOutOfRange {
            name,
            value,
            min: f64::MIN_POSITIVE,
            max: f64::INFINITY,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    extern crate std;
    use std::string::ToString;

    use super::*;

    /// A refusal's text is short and exact: `check_positive`'s bounds said as "(0, inf)" (they
    /// printed `f64::MIN_POSITIVE`'s 310 characters), `f64::MAX` and tiny values in
    /// exponent form, and a value just past its bound printed with the digits that tell
    /// it from the bound.
    #[test]
    fn a_refusal_reads_short_and_outside_its_bound() {
        let text = |r: Result<()>| r.unwrap_err().to_string();
        assert_eq!(
            text(check_positive("h", -0.01)),
            "parameter h = -0.01 outside (0, inf)"
        );
        assert_eq!(
            text(check_positive("h", 0.0)),
            "parameter h = 0 outside (0, inf)"
        );
        assert_eq!(
            text(check_range("lowering_allowance", -1.0, 0.0, f64::MAX)),
            "parameter lowering_allowance = -1 outside [0, 1.7976931348623157e308]"
        );
        assert_eq!(
            text(check_range("range min", -1e-300, 1e-300, 2.0)),
            "parameter range min = -1e-300 outside [1e-300, 2]"
        );
        let past = 0.5 + f64::EPSILON;
        assert_eq!(
            text(check_range("deadband", past, 0.0, 0.5)),
            "parameter deadband = 0.5000000000000002 outside [0, 0.5]"
        );
    }
}
