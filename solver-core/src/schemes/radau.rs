//! The 3-stage Radau IIA scheme of order 5 (Eqs. 13–15, Tab. 1).
//!
//! Each step solves, for the stage derivatives `X'_1, X'_2, X'_3`,
//! `F(x_{n−1} + h Σ_j a_ij X'_j, X'_i, t_{n−1} + c_i h) = 0` (i = 1, 2, 3) — a system of
//! size `S = 3N` — and sets `x_n = x_{n−1} + h Σ_i b_i X'_i` (Eq. 14). For index-3
//! problems the algebraic variables (here: the inputs) converge with order
//! `s − 1 = 2` (Hairer, Lubich & Roche, ref. \[17\]).
//!
//! Tab. 1 as printed has `a_21 = (296 − 169√6)/1800`; the row sum must equal `c_2`,
//! which holds for `(296 + 169√6)/1800`, the value of Hairer & Wanner used here
//! (the test `simplifying_conditions_hold` checks it).

use core::marker::PhantomData;

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::model::DaeModel;
use crate::newton::{row_scaling, weighted_norm, JacobianMode, Newton, NewtonStats, StepSystem};
use crate::scalar::{c, to_f64, Real};
use crate::schemes::bdf::scale_rows;
use crate::schemes::radau5::{StageSystems, Transformed};
use crate::schemes::{SolverSettings, StepReport};

const SQRT6: f64 = 2.449_489_742_783_178;

/// Nodes `c_i` of Tab. 1.
pub const C: [f64; 3] = [(4.0 - SQRT6) / 10.0, (4.0 + SQRT6) / 10.0, 1.0];

/// Coefficients `a_ij` of Tab. 1 (with `a_21` corrected, see the module docs).
#[rustfmt::skip]
pub const A: [[f64; 3]; 3] = [
    [(88.0 - 7.0 * SQRT6) / 360.0,     (296.0 - 169.0 * SQRT6) / 1800.0, (-2.0 + 3.0 * SQRT6) / 225.0],
    [(296.0 + 169.0 * SQRT6) / 1800.0, (88.0 + 7.0 * SQRT6) / 360.0,     (-2.0 - 3.0 * SQRT6) / 225.0],
    [(16.0 - SQRT6) / 36.0,            (16.0 + SQRT6) / 36.0,            1.0 / 9.0],
];

/// Weights `b_i` (= the last row of A: the scheme is stiffly accurate).
pub const B: [f64; 3] = A[2];

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

/// How a Radau step's stage system (Eq. 13) is solved.
pub trait RadauNewton<
    T: Real,
    M: DaeModel<T, N, NU>,
    const N: usize,
    const NU: usize,
    const S: usize,
>: Sized
{
    /// The strategy for `settings` at step size `h`; refuses a Jacobian mode it cannot do.
    fn new(settings: &SolverSettings, h: T) -> Result<Self>;
    /// Forgets what is carried from step to step (after a restart at rest).
    fn forget(&mut self);
    /// Solves one step, starting from the last step's collocation polynomial
    /// extrapolated to this step's nodes: the new value `x_n`.
    fn solve(&mut self, step: &RadauStep<'_, T, M, N, NU>) -> Result<(SVector<T, N>, NewtonStats)>;
}

/// `E[j][i] = L_i(1 + c_j)`: the Lagrange basis on the nodes `C`, at this step's nodes
/// seen from the last step — what extrapolates the last step's collocation polynomial.
pub(crate) fn extrapolation() -> [[f64; 3]; 3] {
    C.map(|cj| [0, 1, 2].map(|i| lagrange(i, 1.0 + cj)))
}

/// The paper's modes (J, J̃, J̃ₙ, exact) on the 3N×3N system of Eq. 13, unknowns the
/// stage derivatives, the guess the last step's derivatives extrapolated;
/// `Transformed` is refused ([`Newton::new`]).
#[derive(Debug, Clone)]
pub struct FullNewton<T: Real, const S: usize> {
    newton: Newton<T, S>,
    /// The last step's stage derivatives `X'_1, X'_2, X'_3`.
    derivatives: SVector<T, S>,
    /// [`extrapolation`].
    extrapolation: [[T; 3]; 3],
}

impl<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize, const S: usize>
    RadauNewton<T, M, N, NU, S> for FullNewton<T, S>
{
    fn new(settings: &SolverSettings, _h: T) -> Result<Self> {
        Ok(Self {
            newton: Newton::new(settings.jacobian, settings.newton)?,
            derivatives: SVector::zeros(),
            extrapolation: extrapolation().map(|row| row.map(c::<T>)),
        })
    }

    fn forget(&mut self) {
        self.newton.forget();
        self.derivatives = SVector::zeros();
    }

    fn solve(&mut self, step: &RadauStep<'_, T, M, N, NU>) -> Result<(SVector<T, N>, NewtonStats)> {
        let mut guess = SVector::<T, S>::zeros();
        for (j, weights) in self.extrapolation.iter().enumerate() {
            let mut g = SVector::<T, N>::zeros();
            for (i, w) in weights.iter().enumerate() {
                g += block::<T, N, S>(&self.derivatives, i) * *w;
            }
            for (r, v) in g.iter().enumerate() {
                if let Some(slot) = guess.get_mut(j * N + r) {
                    *slot = *v;
                }
            }
        }
        let (xi, stats) = self.newton.solve(step, guess)?;
        // Eq. 14.
        let mut x = step.x0;
        for (i, hb) in step.hb.iter().enumerate() {
            x += block::<T, N, S>(&xi, i) * *hb;
        }
        self.derivatives = xi;
        Ok((x, stats))
    }
}

/// RADAU5's transformed simplified Newton on N×N blocks, unknowns the stage increments;
/// the Jacobian mode must be `Transformed` (anything else is refused: the settings would
/// be silently ignored).
impl<
        T: Real,
        M: DaeModel<T, N, NU>,
        L: StageSystems<T, M, N, NU>,
        const N: usize,
        const NU: usize,
        const S: usize,
    > RadauNewton<T, M, N, NU, S> for Transformed<T, N, L>
{
    fn new(settings: &SolverSettings, h: T) -> Result<Self> {
        if settings.jacobian != JacobianMode::Transformed {
            return Err(Error::InvalidSetting {
                name: "jacobian (RADAU5's Newton is transformed only)",
                value: f64::NAN,
            });
        }
        Transformed::new::<M, NU>(settings.newton, h)
    }

    fn forget(&mut self) {
        Transformed::forget(self);
    }

    fn solve(&mut self, step: &RadauStep<'_, T, M, N, NU>) -> Result<(SVector<T, N>, NewtonStats)> {
        let (z, stats) = self.iterate(step)?;
        let [_, _, z3] = z;
        // Radau IIA is stiffly accurate: x_n is the last stage value (Eq. 14).
        Ok((step.x0 + z3, stats))
    }
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
        settings.validate()?;
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

/// The Lagrange basis polynomial `L_i` on the nodes `C`, at `tau`.
fn lagrange(i: usize, tau: f64) -> f64 {
    let ci = C.get(i).copied().unwrap_or(0.0);
    C.iter()
        .enumerate()
        .filter(|&(m, _)| m != i)
        .fold(1.0, |acc, (_, cm)| acc * (tau - cm) / (ci - cm))
}

/// One Radau step's data: the model, the trajectory at the three nodes `t_{n−1} + c_i h`,
/// the start value; as the paper's modes see it, the system of size 3N of Eq. 13 in the
/// stage derivatives.
pub struct RadauStep<'a, T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize> {
    pub(crate) model: &'a M,
    pub(crate) samples: [M::Sample; 3],
    /// `x_{n−1}`.
    pub(crate) x0: SVector<T, N>,
    /// `h a_ij` and `h b_i` of Tab. 1.
    pub(crate) ha: &'a [[T; 3]; 3],
    pub(crate) hb: &'a [T; 3],
    /// Row scaling ρ (Sec. 3.1.1).
    pub(crate) scale: &'a SVector<T, N>,
    /// Time of the step's end (for error context).
    pub(crate) t: f64,
}

impl<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize> RadauStep<'_, T, M, N, NU> {
    /// Stage value `X_i = x_{n−1} + h Σ_j a_ij X'_j` and derivative `X'_i`.
    fn stage<const S: usize>(
        &self,
        i: usize,
        xi: &SVector<T, S>,
    ) -> (SVector<T, N>, SVector<T, N>) {
        let mut x = self.x0;
        if let Some(row) = self.ha.get(i) {
            for (j, a) in row.iter().enumerate() {
                x += block::<T, N, S>(xi, j) * *a;
            }
        }
        (x, block::<T, N, S>(xi, i))
    }
}

/// Block `j` of the stage vector, entries `j·N .. (j+1)·N` (checked access: there is
/// nothing to panic about, for the firmware's link-time proof).
fn block<T: Real, const N: usize, const S: usize>(xi: &SVector<T, S>, j: usize) -> SVector<T, N> {
    SVector::from_fn(|r, _| xi.get(j * N + r).copied().unwrap_or_else(T::zero))
}

impl<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize, const S: usize>
    StepSystem<T, S> for RadauStep<'_, T, M, N, NU>
{
    fn residual(&self, xi: &SVector<T, S>) -> SVector<T, S> {
        let mut g = SVector::<T, S>::zeros();
        for (i, sample) in self.samples.iter().enumerate() {
            let (x, xdot) = self.stage(i, xi);
            let f = self
                .model
                .residual(&x, &xdot, sample)
                .component_mul(self.scale);
            g.fixed_rows_mut::<N>(i * N).copy_from(&f);
        }
        g
    }

    /// `∂G_i/∂X'_j = S (h a_ij ∂F/∂x + δ_ij ∂F/∂ẋ)` at stage i.
    fn jacobian_into(&self, xi: &SVector<T, S>, jac: &mut SMatrix<T, S, S>) {
        for (i, (sample, row)) in self.samples.iter().zip(self.ha.iter()).enumerate() {
            let (x, xdot) = self.stage(i, xi);
            let p = self.model.partials(&x, &xdot, sample);
            for (j, a) in row.iter().enumerate() {
                let mut block = p.dx * *a;
                if i == j {
                    block += p.dxdot;
                }
                scale_rows(&mut block, self.scale);
                jac.fixed_view_mut::<N, N>(i * N, j * N).copy_from(&block);
            }
        }
    }

    fn time(&self) -> f64 {
        self.t
    }

    /// Measured on the stage values: `δX_i = h Σ_j a_ij η_j`, relative to `X_i`.
    /// (The unknowns are derivatives, whose rounding floor is 1/h larger.)
    fn increment_norm(&self, eta: &SVector<T, S>, xi: &SVector<T, S>, rtol: f64, atol: f64) -> f64 {
        (0..3)
            .map(|i| {
                let (x, _) = self.stage(i, xi);
                let mut delta = SVector::<T, N>::zeros();
                if let Some(row) = self.ha.get(i) {
                    for (j, a) in row.iter().enumerate() {
                        delta += block::<T, N, S>(eta, j) * *a;
                    }
                }
                weighted_norm(&delta, &x, rtol, atol)
            })
            .fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// C(3): Σ_j a_ij c_j^(q−1) = c_i^q / q for q = 1, 2, 3; B(5): Σ b_i c_i^(q−1) = 1/q.
    #[test]
    fn simplifying_conditions_hold() {
        for (row, ci) in A.iter().zip(C) {
            for q in 1..=3 {
                let lhs: f64 = row.iter().zip(C).map(|(a, cj)| a * cj.powi(q - 1)).sum();
                assert!(
                    (lhs - ci.powi(q) / f64::from(q)).abs() < 1e-14,
                    "C({q}) row {row:?}"
                );
            }
        }
        for q in 1..=5 {
            let lhs: f64 = B.iter().zip(C).map(|(b, ci)| b * ci.powi(q - 1)).sum();
            assert!((lhs - 1.0 / f64::from(q)).abs() < 1e-14, "B({q})");
        }
    }
}
