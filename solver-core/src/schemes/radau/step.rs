//! One Radau IIA step as its Newton strategies see it: the step's data ([`RadauStep`]),
//! the stage system of Eq. 13 in the stage derivatives, and what a strategy is
//! ([`RadauNewton`]).

use nalgebra::{SMatrix, SVector};

use crate::error::Result;
use crate::model::DaeModel;
use crate::newton::{weighted_norm, NewtonStats, StepSystem};
use crate::scalar::Real;
use crate::schemes::bdf::scale_rows;
use crate::schemes::SolverSettings;

/// How a Radau step's stage system (Eq. 13) is solved.
pub trait RadauNewton<
    T: Real,
    M: DaeModel<T, N, NU>,
    const N: usize,
    const NU: usize,
    const S: usize,
>: Sized
{
    /// The strategy for `settings` at step size `h`; refuses a Jacobian mode it cannot do,
    /// and Newton's settings if it iterates ([`Radau::new`](super::Radau::new) does not
    /// check them).
    fn new(settings: &SolverSettings, h: T) -> Result<Self>;
    /// Forgets what is carried from step to step (after a restart at rest).
    fn forget(&mut self);
    /// Solves one step, starting from the last step's collocation polynomial
    /// extrapolated to this step's nodes: the new value `x_n`.
    fn solve(&mut self, step: &RadauStep<'_, T, M, N, NU>) -> Result<(SVector<T, N>, NewtonStats)>;
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
pub(crate) fn block<T: Real, const N: usize, const S: usize>(
    xi: &SVector<T, S>,
    j: usize,
) -> SVector<T, N> {
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
