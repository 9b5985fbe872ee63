//! Fixed-step integrators for `F(x, ẋ, t) = 0`: BDF k = 1..6 and 3-stage Radau IIA.
//!
//! Both advance one step of size `h` per call to `step`, return the inputs `u`, the
//! full state and the Newton statistics, and take the model by reference at every
//! step (so a caller may swap in a new trajectory between steps). [`Integrator`] is
//! that interface, the one every caller steps through (the controller's inverse
//! model, the studies, the runs); [`Scheme`] names a scheme as a value, and
//! [`Chosen`] is the integrator picked by it at run time (the studies sweep schemes;
//! the firmware names its scheme as a type and links only that one).

pub mod bdf;
mod contraction;
mod history;
pub mod radau;

use nalgebra::SVector;

use crate::error::{Error, Result};
use crate::newton::{JacobianMode, NewtonSettings, NewtonStats};
use crate::scalar::Real;

pub use bdf::Bdf;
pub use radau::Radau;

use crate::model::DaeModel;
use bdf::BdfNewton;
use radau::{RadauNewton, StageSolver};

/// What every scheme does, whatever its Newton strategy: one step at a time on a model
/// with `N` unknowns and `NU` inputs (the sizes are the model's own). Modelled on
/// diffsol's one-trait-per-method interface.
pub trait Integrator<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize> {
    /// Advances one step. On error the integrator stays where it was.
    fn step(&mut self, model: &M) -> Result<StepReport<T, N, NU>>;
    /// Time of the newest solution value.
    fn time(&self) -> T;
    /// The newest solution value.
    fn state(&self) -> SVector<T, N>;
    /// Starts again at rest at `t0` (after a halt), with the same settings; the model's
    /// trajectory must rest at `t0`.
    fn restart(&mut self, model: &M, t0: T) -> Result<()>;
}

impl<
        T: Real,
        M: DaeModel<T, N, NU>,
        const N: usize,
        const NU: usize,
        J: BdfNewton<T, M, N, NU>,
    > Integrator<T, M, N, NU> for Bdf<T, M, N, NU, J>
{
    fn step(&mut self, model: &M) -> Result<StepReport<T, N, NU>> {
        Bdf::step(self, model)
    }
    fn time(&self) -> T {
        Bdf::time(self)
    }
    fn state(&self) -> SVector<T, N> {
        Bdf::state(self)
    }
    fn restart(&mut self, model: &M, t0: T) -> Result<()> {
        Bdf::restart(self, model, t0)
    }
}

impl<
        T: Real,
        M: DaeModel<T, N, NU>,
        const N: usize,
        const NU: usize,
        const S: usize,
        J: RadauNewton<T, M, N, NU, S>,
    > Integrator<T, M, N, NU> for Radau<T, M, N, NU, S, J>
{
    fn step(&mut self, model: &M) -> Result<StepReport<T, N, NU>> {
        Radau::step(self, model)
    }
    fn time(&self) -> T {
        Radau::time(self)
    }
    fn state(&self) -> SVector<T, N> {
        Radau::state(self)
    }
    fn restart(&mut self, model: &M, t0: T) -> Result<()> {
        Radau::restart(self, model, t0)
    }
}

/// A scheme named as a value (a scene's `[solver]`, a study's sweep).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheme {
    /// BDF with k steps (k = 1: implicit Euler).
    Bdf(usize),
    /// 3-stage Radau IIA.
    Radau,
}

/// The integrator [`Scheme`] names, chosen at run time, each with the Newton strategy
/// the settings' Jacobian mode names (dense LUs; RADAU5's transformed Newton for
/// [`JacobianMode::Transformed`]). `S` is Radau's stage-system size, `3 * N`.
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)] // one lives in each run, never moved
pub enum Chosen<T: Real, M, const N: usize, const NU: usize, const S: usize> {
    /// BDF.
    Bdf(Bdf<T, M, N, NU>),
    /// Radau IIA.
    Radau(Radau<T, M, N, NU, S, StageSolver<T, N, S>>),
}

impl<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize, const S: usize>
    Chosen<T, M, N, NU, S>
{
    /// `scheme` starting at rest at `t0`.
    pub fn new(model: &M, scheme: Scheme, settings: &SolverSettings, t0: T) -> Result<Self> {
        Ok(match scheme {
            Scheme::Bdf(k) => Self::Bdf(Bdf::new(model, settings, k, t0)?),
            Scheme::Radau => Self::Radau(Radau::new(model, settings, t0)?),
        })
    }
}

impl<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize, const S: usize>
    Integrator<T, M, N, NU> for Chosen<T, M, N, NU, S>
{
    fn step(&mut self, model: &M) -> Result<StepReport<T, N, NU>> {
        match self {
            Self::Bdf(i) => i.step(model),
            Self::Radau(i) => i.step(model),
        }
    }
    fn time(&self) -> T {
        match self {
            Self::Bdf(i) => i.time(),
            Self::Radau(i) => i.time(),
        }
    }
    fn state(&self) -> SVector<T, N> {
        match self {
            Self::Bdf(i) => i.state(),
            Self::Radau(i) => i.state(),
        }
    }
    fn restart(&mut self, model: &M, t0: T) -> Result<()> {
        match self {
            Self::Bdf(i) => i.restart(model, t0),
            Self::Radau(i) => i.restart(model, t0),
        }
    }
}

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
        self.validate_step()?;
        self.newton.validate()
    }

    /// [`SolverSettings::validate`] without Newton's settings, which the Newton strategies
    /// that iterate validate themselves ([`NewtonSettings::validate`]): a strategy that
    /// takes the model's closed-form step reads none of them, and a firmware linking
    /// only it does not link their check either.
    pub(crate) fn validate_step(&self) -> Result<()> {
        if !(self.h.is_finite() && self.h > 0.0) {
            return Err(Error::InvalidStepSize { h: self.h });
        }
        if self.scaling_power > 3 {
            return Err(Error::InvalidSetting {
                name: "scaling_power",
                value: f64::from(self.scaling_power),
            });
        }
        Ok(())
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
