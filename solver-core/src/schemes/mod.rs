//! Fixed-step integrators for `F(x, ẋ, t) = 0`: BDF k = 1..6 and 3-stage Radau IIA.
//!
//! Both advance one step of size `h` per call to `step`, return the inputs `u`, the
//! full state and the Newton statistics, and take the model by reference at every
//! step (so a caller may swap in a new trajectory between steps).

pub mod bdf;
mod contraction;
mod history;
pub mod radau;
pub mod radau5;

use nalgebra::SVector;

use crate::error::{Error, Result};
use crate::newton::{JacobianMode, NewtonSettings, NewtonStats};
use crate::scalar::Real;

pub use bdf::Bdf;
pub use radau::Radau;

/// Settings shared by every scheme.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverSettings {
    /// Step size h, s.
    pub h: f64,
    /// How Newton gets its matrix.
    pub jacobian: JacobianMode,
    /// Scaling of the algebraic rows by `ρ = h^-p`, `p ∈ {0, 1, 2, 3}` (Sec. 3.1.1).
    pub scaling_power: u32,
    /// Newton's limits and tolerances.
    pub newton: NewtonSettings,
}

impl SolverSettings {
    /// The paper's test-bench choice: h = 10 ms, ρ = 1/h², 20 Newton iterations.
    #[must_use]
    pub fn paper(jacobian: JacobianMode) -> Self {
        Self {
            h: 0.01,
            jacobian,
            scaling_power: 2,
            newton: NewtonSettings::default(),
        }
    }

    /// Refuses a non-finite or non-positive step and unsupported settings.
    pub fn validate(&self) -> Result<()> {
        if !(self.h.is_finite() && self.h > 0.0) {
            return Err(Error::InvalidStepSize { h: self.h });
        }
        if self.scaling_power > 3 {
            return Err(Error::InvalidSetting {
                name: "scaling_power",
                value: f64::from(self.scaling_power),
            });
        }
        self.newton.validate()
    }
}

/// One step's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport<T: Real, const N: usize, const NU: usize> {
    /// Time at the end of the step, s.
    pub t: T,
    /// The inputs `u(t)`: what the drives are sent.
    pub u: SVector<T, NU>,
    /// The full state `x(t)`.
    pub x: SVector<T, N>,
    /// What Newton did.
    pub stats: NewtonStats,
}
