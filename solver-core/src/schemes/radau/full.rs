//! The paper's Newton modes (J, J̃, J̃ₙ, exact) on Radau IIA's 3N×3N stage system.

use nalgebra::SVector;

use crate::error::Result;
use crate::model::DaeModel;
use crate::newton::{Newton, NewtonStats};
use crate::scalar::{c, Real};
use crate::schemes::radau::step::{block, RadauNewton, RadauStep};
use crate::schemes::radau::tableau::extrapolation;
use crate::schemes::SolverSettings;

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
