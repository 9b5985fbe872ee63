//! The 3-stage Radau IIA scheme of order 5 (Eqs. 13–15, Tab. 1).
//!
//! Each step solves, for the stage derivatives `X'_1, X'_2, X'_3`,
//! `F(x_{n−1} + h Σ_j a_ij X'_j, X'_i, t_{n−1} + c_i h) = 0` (i = 1, 2, 3) — a system of
//! size `S = 3N` — and sets `x_n = x_{n−1} + h Σ_i b_i X'_i` (Eq. 14). For index-3
//! problems the algebraic variables (here: the inputs) converge with order
//! `s − 1 = 2` (Hairer, Lubich & Roche, ref. \[17\]).
//!
//! The scheme is kept apart from its tableau and its Newton strategies, as diffsol keeps
//! a method apart from its tableau: [`tableau`] (Tab. 1), [`step`] (one step's stage
//! system and what a strategy is), [`full`] (the paper's modes on the 3N×3N system),
//! [`transformed`] (RADAU5's transformed simplified Newton).

pub mod full;
pub mod step;
pub mod tableau;
pub mod transformed;

use core::marker::PhantomData;

use nalgebra::SVector;

use crate::error::Result;
use crate::model::DaeModel;
use crate::newton::{row_scaling, JacobianMode, NewtonStats};
use crate::scalar::{c, to_f64, Real};
use crate::schemes::{SolverSettings, StepReport};

pub use full::FullNewton;
pub use step::{RadauNewton, RadauStep};
pub use tableau::{A, B, C};
pub use transformed::{StageSystems, Transformed};

/// The Radau IIA integrator for a model `M` with `N` unknowns and `NU` inputs; `S` must
/// be `3 * N` (checked at compile time). Its stage system is solved by `J`
/// ([`RadauNewton`]): the paper's modes on the 3N×3N system ([`FullNewton`]), RADAU5's
/// transformed simplified Newton ([`Transformed`]), or either, chosen at run time by the
/// settings' Jacobian mode ([`StageSolver`], the default, for the studies). Being a
/// type, the choice decides what is linked: a firmware whose scene names `Transformed`
/// contains no 3N×3N LU, no finite differences and no Broyden update.
#[derive(Debug, Clone)]
pub struct Radau<
    T: Real,
    M,
    const N: usize,
    const NU: usize,
    const S: usize,
    J = StageSolver<T, N, S>,
> {
    h: T,
    t0: T,
    steps: u64,
    x: SVector<T, N>,
    ha: [[T; 3]; 3],
    hb: [T; 3],
    scale: SVector<T, N>,
    newton: J,
    model: PhantomData<fn() -> M>,
}

/// The Newton strategy chosen at run time by the settings' Jacobian mode: RADAU5's for
/// `Transformed`, the paper's modes otherwise (the studies sweep them all).
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)] // one of them lives in each integrator, never moved
pub enum StageSolver<T: Real, const N: usize, const S: usize> {
    /// The paper's modes on the 3N×3N system.
    Full(FullNewton<T, S>),
    /// RADAU5's transformed simplified Newton.
    Transformed(Transformed<T, N>),
}

impl<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize, const S: usize>
    RadauNewton<T, M, N, NU, S> for StageSolver<T, N, S>
{
    fn new(settings: &SolverSettings, h: T) -> Result<Self> {
        Ok(if settings.jacobian == JacobianMode::Transformed {
            Self::Transformed(<Transformed<T, N> as RadauNewton<T, M, N, NU, S>>::new(
                settings, h,
            )?)
        } else {
            Self::Full(<FullNewton<T, S> as RadauNewton<T, M, N, NU, S>>::new(
                settings, h,
            )?)
        })
    }

    fn forget(&mut self) {
        match self {
            Self::Full(full) => RadauNewton::<T, M, N, NU, S>::forget(full),
            Self::Transformed(transformed) => RadauNewton::<T, M, N, NU, S>::forget(transformed),
        }
    }

    fn solve(&mut self, step: &RadauStep<'_, T, M, N, NU>) -> Result<(SVector<T, N>, NewtonStats)> {
        match self {
            Self::Full(full) => RadauNewton::<T, M, N, NU, S>::solve(full, step),
            Self::Transformed(transformed) => {
                RadauNewton::<T, M, N, NU, S>::solve(transformed, step)
            }
        }
    }
}

impl<
        T: Real,
        M: DaeModel<T, N, NU>,
        const N: usize,
        const NU: usize,
        const S: usize,
        J: RadauNewton<T, M, N, NU, S>,
    > Radau<T, M, N, NU, S, J>
{
    const STAGE_SYSTEM_IS_3N: () = assert!(S == 3 * N, "Radau IIA: S must equal 3 * N");

    /// A Radau IIA integrator starting at rest at `t0`.
    pub fn new(model: &M, settings: &SolverSettings, t0: T) -> Result<Self> {
        let () = Self::STAGE_SYSTEM_IS_3N;
        // Newton's settings: by the strategy (`J::new`), if it iterates.
        settings.validate_step()?;
        let h = c::<T>(settings.h);
        let x = model.rest_state(t0)?;
        Ok(Self {
            h,
            t0,
            steps: 0,
            x,
            ha: A.map(|row| row.map(|a| h * c::<T>(a))),
            hb: B.map(|b| h * c::<T>(b)),
            scale: row_scaling(&M::ALGEBRAIC, h, settings.scaling_power),
            newton: J::new(settings, h)?,
            model: PhantomData,
        })
    }

    /// Starts again at rest at `t0` (after a halt), with the same settings; the model's
    /// trajectory must rest at `t0`.
    pub fn restart(&mut self, model: &M, t0: T) -> Result<()> {
        self.x = model.rest_state(t0)?;
        self.t0 = t0;
        self.steps = 0;
        self.newton.forget();
        Ok(())
    }

    /// Time of the current solution value.
    #[must_use]
    pub fn time(&self) -> T {
        self.t0 + c::<T>(self.steps as f64) * self.h
    }

    /// The current solution value.
    #[must_use]
    pub fn state(&self) -> SVector<T, N> {
        self.x
    }

    /// Advances one step. On error the integrator stays where it was.
    pub fn step(&mut self, model: &M) -> Result<StepReport<T, N, NU>> {
        let t_prev = self.time();
        let samples = C.map(|ci| model.sample(t_prev + c::<T>(ci) * self.h));
        let t = self.t0 + c::<T>((self.steps + 1) as f64) * self.h;
        let step = RadauStep {
            model,
            samples,
            x0: self.x,
            ha: &self.ha,
            hb: &self.hb,
            scale: &self.scale,
            t: to_f64(t),
        };
        let (x, stats) = self.newton.solve(&step)?;
        self.x = x;
        self.steps += 1;
        Ok(StepReport {
            t,
            u: M::inputs(&x),
            x,
            stats,
        })
    }
}
