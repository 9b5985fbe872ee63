//! Newton's method for the nonlinear system of one step (Eq. 13 or Eq. 16).
//!
//! Three ways to get the Newton matrix (Sec. 2.3, "Numerical Improvements"):
//!
//! * **J** — forward differences, recomputed in every iteration (`m + 1` residual
//!   evaluations per iteration for a system of size `m`). The paper's reference.
//! * **J̃, J̃₁₀, J̃₅₀** — Broyden's method (Eqs. 17–19): one residual evaluation per
//!   iteration; the approximation is carried from step to step and re-initialised
//!   by finite differences every N steps (or never).
//! * **exact** — the model's analytic partial derivatives (the paper had no such option).
//!
//! Broyden's update (Eq. 19) is applied to `J̃⁻¹` through the Sherman–Morrison
//! formula. That is the same update, algebraically, but an iteration costs `O(m²)`
//! instead of a new `O(m³)` factorisation — what makes Radau (m = 3N) cheap on the MCU.
//!
//! ## Convergence test
//!
//! An index-3 step amplifies every error left in a differential state by about
//! `1/h²` on its way into the inputs (a trolley position off by δ moves `u1` by
//! `τ1 α0² δ/h²` at the next step). Newton must therefore converge to what
//! rounding allows, not to a loose tolerance. But the Newton matrix is
//! ill-conditioned (cond ≈ 2e5 at h = 10 ms, growing like h⁻³), so that floor
//! rises as h falls. The test (weighted max-norm `‖η‖ = max_i |η_i|/(atol + rtol·|ξ_i|)`,
//! with tight default tolerances of 1e-12):
//!
//! 1. **tolerance**: `‖η_i‖ ≤ 1`, or the contraction estimate of the remaining
//!    error `θ/(1−θ)·‖η_i‖ ≤ 1` with `θ = ‖η_i‖/‖η_{i−1}‖ < 1`;
//! 2. **rounding floor**: an iteration made with a *current* Newton matrix (J, exact,
//!    or the first after a Broyden (re)start) fails to contract (`θ ≥ stall_ratio`)
//!    while `‖η_i‖ ≤ stall_limit`: more iterations only stir rounding noise.
//!
//! Broyden iterations often fail to contract for a while before converging
//! superlinearly, so a Broyden stall is not taken as the floor: after two in a
//! row the matrix is recomputed by finite differences and the step continues as
//! simplified Newton on it (unless `broyden_refresh` is off, as in the paper).
//! Anything else within `max_iterations` is an [`Error::NewtonNotConverged`].

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::linalg::{self, Pivots};
use crate::scalar::{to_f64, Real};

/// How the Newton matrix is obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JacobianMode {
    /// **J**: forward differences in every Newton iteration.
    FiniteDifference,
    /// **J̃**: Broyden updates from a finite-difference start, re-initialised every
    /// `reinit_every` steps (`Some(10)`: J̃₁₀, `Some(50)`: J̃₅₀) or never (`None`: J̃).
    Broyden {
        /// Steps between re-initialisations; `None` for continuous updating.
        reinit_every: Option<u32>,
    },
    /// The model's exact partial derivatives in every Newton iteration.
    Exact,
    /// Radau IIA only: RADAU5's simplified Newton on the transformed stage system —
    /// one real and one complex N×N matrix from the model's exact partials, kept across
    /// steps while the iteration contracts fast (`schemes::radau5`). Not one of the
    /// paper's modes; BDF refuses it.
    Transformed,
}

/// Newton's stopping rules and limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonSettings {
    /// Iteration cap per step (the paper's test bench: 20).
    pub max_iterations: u32,
    /// Relative tolerance on the increment.
    pub rtol: f64,
    /// Absolute tolerance on the increment.
    pub atol: f64,
    /// An increment that shrinks by less than this factor has stalled.
    pub stall_ratio: f64,
    /// A stalled increment is accepted as converged below this weighted norm.
    pub stall_limit: f64,
    /// Return the last iterate (flagged `converged = false`) instead of an error when
    /// the cap is reached. Off by default; the paper's studies ran this way.
    pub accept_unconverged: bool,
    /// Broyden: recompute `J̃` by finite differences when its iterations stagnate
    /// (two non-contracting iterations in a row), and once more, from the start of
    /// the step, when the step fails. Off reproduces the paper's pure J̃.
    pub broyden_refresh: bool,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        Self::for_scalar::<f64>()
    }
}

impl NewtonSettings {
    /// Defaults scaled to the scalar's precision (f32 cannot resolve 1e-12).
    #[must_use]
    pub fn for_scalar<T: Real>() -> Self {
        let eps = to_f64(T::default_epsilon());
        let tol = (100.0 * eps).max(1e-12);
        Self {
            max_iterations: 20,
            rtol: tol,
            atol: tol,
            stall_ratio: 0.5,
            stall_limit: 1e6,
            accept_unconverged: false,
            broyden_refresh: true,
        }
    }

    /// Refuses settings Newton cannot work with.
    pub fn validate(&self) -> Result<()> {
        if self.max_iterations == 0 {
            return Err(Error::InvalidSetting {
                name: "max_iterations",
                value: 0.0,
            });
        }
        for (name, value) in [
            ("rtol", self.rtol),
            ("atol", self.atol),
            ("stall_ratio", self.stall_ratio),
            ("stall_limit", self.stall_limit),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(Error::InvalidSetting { name, value });
            }
        }
        Ok(())
    }
}

/// What one step's Newton solve cost and how it ended.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NewtonStats {
    /// Newton iterations (linear solves).
    pub iterations: u32,
    /// Evaluations of the step's nonlinear system (one Radau evaluation = 3 model residuals).
    pub residual_evals: u32,
    /// Jacobians formed (by finite differences or exactly).
    pub jacobian_evals: u32,
    /// LU factorisations (Broyden: inversions at re-initialisation).
    pub factorizations: u32,
    /// Max-norm of the scaled residual at the returned iterate.
    pub residual_norm: f64,
    /// Weighted norm of the last increment (≤ 1 passes the tolerance test).
    pub increment_norm: f64,
    /// Whether the convergence test passed.
    pub converged: bool,
    /// Whether it passed at the rounding floor (test 2) rather than the tolerance.
    pub at_rounding_floor: bool,
    /// Broyden updates skipped because they would have made `J̃` singular.
    pub broyden_skipped: u32,
}

/// The nonlinear system `G(ξ) = 0` of one step.
pub(crate) trait StepSystem<T: Real, const M: usize> {
    /// `G(ξ)`.
    fn residual(&self, xi: &SVector<T, M>) -> SVector<T, M>;
    /// Writes `∂G/∂ξ` from the model's exact partials into `out`.
    fn jacobian_into(&self, xi: &SVector<T, M>, out: &mut SMatrix<T, M, M>);
    /// Time of the step (for error context).
    fn time(&self) -> f64;
    /// The weighted max-norm `max_i |δ_i| / (atol + rtol·|v_i|)` of the change `δ`
    /// that the increment `eta` makes to the step's solution values `v` (for BDF
    /// `δ = eta`, `v = ξ`; Radau measures the change of its stage values).
    fn increment_norm(&self, eta: &SVector<T, M>, xi: &SVector<T, M>, rtol: f64, atol: f64) -> f64 {
        weighted_norm(eta, xi, rtol, atol)
    }
}

/// `max_i |δ_i| / (atol + rtol·|v_i|)`.
pub(crate) fn weighted_norm<T: Real, const M: usize>(
    delta: &SVector<T, M>,
    v: &SVector<T, M>,
    rtol: f64,
    atol: f64,
) -> f64 {
    delta
        .iter()
        .zip(v.iter())
        .map(|(d, x)| to_f64(d.abs()) / (atol + rtol * to_f64(x.abs())))
        .fold(0.0, f64::max)
}

/// Newton's method with a Jacobian mode and, for Broyden, the approximation it carries.
#[derive(Debug, Clone)]
pub struct Newton<T: Real, const M: usize> {
    mode: JacobianMode,
    settings: NewtonSettings,
    /// The one matrix Newton owns: J and then its LU factors (J, exact), or `J̃⁻¹`
    /// carried from step to step (Broyden). Kept here, not on the stack.
    matrix: SMatrix<T, M, M>,
    pivots: Pivots<M>,
    has_inverse: bool,
    steps_since_init: u32,
}

impl<T: Real, const M: usize> Newton<T, M> {
    /// A solver for systems of size `M`.
    pub fn new(mode: JacobianMode, settings: NewtonSettings) -> Result<Self> {
        settings.validate()?;
        if let JacobianMode::Broyden {
            reinit_every: Some(0),
        } = mode
        {
            return Err(Error::InvalidSetting {
                name: "reinit_every",
                value: 0.0,
            });
        }
        if mode == JacobianMode::Transformed {
            // Only Radau IIA's stage system has the structure the transformation needs.
            return Err(Error::InvalidSetting {
                name: "jacobian_transformed",
                value: 1.0,
            });
        }
        Ok(Self {
            mode,
            settings,
            matrix: SMatrix::zeros(),
            pivots: [0; M],
            has_inverse: false,
            steps_since_init: 0,
        })
    }

    /// Forgets Broyden's carried approximation (the next step re-initialises it).
    pub fn forget(&mut self) {
        self.has_inverse = false;
        self.steps_since_init = 0;
    }

    /// The Jacobian mode.
    #[must_use]
    pub fn mode(&self) -> JacobianMode {
        self.mode
    }

    /// Solves one step's system from the initial guess `xi`.
    pub(crate) fn solve<S: StepSystem<T, M>>(
        &mut self,
        sys: &S,
        xi: SVector<T, M>,
    ) -> Result<(SVector<T, M>, NewtonStats)> {
        let mut stats = NewtonStats::default();
        let g = evaluate(sys, &xi, &mut stats)?;
        let JacobianMode::Broyden { reinit_every } = self.mode else {
            return self
                .iterate(sys, xi, g, &mut stats, true)
                .map(|x| (x, stats));
        };
        let due = !self.has_inverse || reinit_every.is_some_and(|n| self.steps_since_init >= n);
        if due {
            self.reinitialise(sys, &xi, &g, &mut stats)?;
        }
        self.steps_since_init = self.steps_since_init.saturating_add(1);
        match self.iterate(sys, xi, g, &mut stats, due) {
            Err(_) if self.settings.broyden_refresh && !due => {
                // The carried approximation was too far off: start the step afresh once.
                self.reinitialise(sys, &xi, &g, &mut stats)?;
                self.steps_since_init = 1;
                self.iterate(sys, xi, g, &mut stats, true)
                    .map(|x| (x, stats))
            }
            other => other.map(|x| (x, stats)),
        }
    }

    /// Broyden's (re)start: a finite-difference Jacobian at `xi`, inverted.
    fn reinitialise<S: StepSystem<T, M>>(
        &mut self,
        sys: &S,
        xi: &SVector<T, M>,
        g: &SVector<T, M>,
        stats: &mut NewtonStats,
    ) -> Result<()> {
        finite_difference_jacobian(sys, xi, g, stats, &mut self.matrix);
        stats.factorizations += 1;
        self.has_inverse = false;
        if !linalg::invert(&mut self.matrix) {
            return Err(Error::SingularJacobian {
                t: sys.time(),
                iterations: stats.iterations,
                residual: max_abs(g),
            });
        }
        self.has_inverse = true;
        self.steps_since_init = 0;
        Ok(())
    }

    /// Newton iterations from `xi` with `g = G(xi)`; `fresh` tells whether the
    /// Broyden matrix has just been (re)computed.
    fn iterate<S: StepSystem<T, M>>(
        &mut self,
        sys: &S,
        mut xi: SVector<T, M>,
        mut g: SVector<T, M>,
        stats: &mut NewtonStats,
        mut fresh: bool,
    ) -> Result<SVector<T, M>> {
        let t = sys.time();
        let broyden = matches!(self.mode, JacobianMode::Broyden { .. });
        let mut previous = f64::INFINITY;
        let mut stalled = 0;
        // Set once Broyden had to refresh within this step: from then on the fresh
        // matrix is kept (simplified Newton), so its stalls are evidence of the floor.
        let mut simplified = false;
        let first = stats.iterations;
        for it in 1..=self.settings.max_iterations {
            let eta = match self.mode {
                JacobianMode::Broyden { .. } => -(self.matrix * g),
                JacobianMode::FiniteDifference => {
                    finite_difference_jacobian(sys, &xi, &g, stats, &mut self.matrix);
                    self.solve_linear(&g, stats, t)?
                }
                JacobianMode::Exact | JacobianMode::Transformed => {
                    stats.jacobian_evals += 1;
                    sys.jacobian_into(&xi, &mut self.matrix);
                    self.solve_linear(&g, stats, t)?
                }
            };
            // J and the exact Jacobian are recomputed every iteration.
            let fresh_matrix = fresh || simplified || !broyden;
            xi += eta;
            stats.iterations = first + it;
            let increment = sys.increment_norm(&eta, &xi, self.settings.rtol, self.settings.atol);
            if !increment.is_finite() {
                return Err(Error::NonFinite {
                    t,
                    iterations: stats.iterations,
                });
            }
            let g_new = evaluate(sys, &xi, stats)?;
            stats.residual_norm = max_abs(&g_new);
            stats.increment_norm = increment;
            if increment <= 1.0 {
                stats.converged = true;
                return Ok(xi);
            }
            if it >= 2 {
                let theta = increment / previous;
                // Contracting with rate θ, the remaining error is about θ/(1−θ)·‖η‖.
                if theta < 1.0 && theta / (1.0 - theta) * increment <= 1.0 {
                    stats.converged = true;
                    return Ok(xi);
                }
                stalled = if theta >= self.settings.stall_ratio {
                    stalled + 1
                } else {
                    0
                };
            }
            if stalled >= 1 && fresh_matrix && increment <= self.settings.stall_limit {
                // A current Newton matrix and still no contraction: rounding noise.
                stats.converged = true;
                stats.at_rounding_floor = true;
                return Ok(xi);
            }
            if broyden && !simplified {
                if stalled >= 2 && self.settings.broyden_refresh {
                    self.reinitialise(sys, &xi, &g_new, stats)?;
                    simplified = true;
                    stalled = 0;
                } else {
                    // Eq. 19 — only when another iteration follows: an update built
                    // from a converged step is rounding noise over a tiny ‖η‖².
                    self.broyden_update(&g_new, &eta, stats);
                    fresh = false;
                }
            }
            g = g_new;
            previous = increment;
        }
        if self.settings.accept_unconverged {
            return Ok(xi);
        }
        Err(Error::NewtonNotConverged {
            t,
            iterations: stats.iterations,
            residual: stats.residual_norm,
            increment: stats.increment_norm,
        })
    }

    /// Solves `J η = −g` with the LU factors of `self.matrix` (which holds J).
    fn solve_linear(
        &mut self,
        g: &SVector<T, M>,
        stats: &mut NewtonStats,
        t: f64,
    ) -> Result<SVector<T, M>> {
        stats.factorizations += 1;
        if !linalg::factor(&mut self.matrix, &mut self.pivots) {
            return Err(Error::SingularJacobian {
                t,
                iterations: stats.iterations,
                residual: max_abs(g),
            });
        }
        let mut eta = -g;
        linalg::solve(&self.matrix, &self.pivots, &mut eta);
        Ok(eta)
    }

    /// Eq. 19, `J̃₊ = J̃ + G(ξ₊) ηᵀ / ‖η‖²`, applied to `J̃⁻¹` by Sherman–Morrison:
    /// `H₊ = H − (H G₊)(ηᵀ H) / (‖η‖² + ηᵀ H G₊)`.
    ///
    /// The update multiplies `det J̃` by `r = (‖η‖² + ηᵀ H G₊)/‖η‖²`. Near the rounding
    /// floor the increments bounce back and forth and `r` goes to zero: the update
    /// would make `J̃` (nearly) singular. As in Powell's safeguard, such an update
    /// (`|r| < 0.1`) is skipped and `J̃` kept; the skip is counted.
    fn broyden_update(
        &mut self,
        g_new: &SVector<T, M>,
        eta: &SVector<T, M>,
        stats: &mut NewtonStats,
    ) {
        let hg = self.matrix * g_new;
        let eta2 = eta.norm_squared();
        let denom = eta2 + eta.dot(&hg);
        let ratio = to_f64(denom) / to_f64(eta2);
        if ratio.is_nan() || ratio.abs() < 0.1 {
            stats.broyden_skipped += 1;
            return;
        }
        // (ηᵀ H)ᵀ = Hᵀ η as a column; the update in place, one multiply-add per element.
        let h_t_eta = self.matrix.tr_mul(eta);
        self.matrix.ger(-T::one() / denom, &hg, &h_t_eta, T::one());
    }
}

/// Evaluates `G(ξ)`, counts it, and refuses non-finite values.
fn evaluate<T: Real, const M: usize, S: StepSystem<T, M>>(
    sys: &S,
    xi: &SVector<T, M>,
    stats: &mut NewtonStats,
) -> Result<SVector<T, M>> {
    stats.residual_evals += 1;
    let g = sys.residual(xi);
    if g.iter().all(|v| to_f64(*v).is_finite()) {
        Ok(g)
    } else {
        Err(Error::NonFinite {
            t: sys.time(),
            iterations: stats.iterations,
        })
    }
}

/// Forward differences into `j`, one column per unknown (`M` residual evaluations).
fn finite_difference_jacobian<T: Real, const M: usize, S: StepSystem<T, M>>(
    sys: &S,
    xi: &SVector<T, M>,
    g: &SVector<T, M>,
    stats: &mut NewtonStats,
    j: &mut SMatrix<T, M, M>,
) {
    let sqrt_eps = T::default_epsilon().sqrt();
    let mut probe = *xi;
    for (col, mut column) in j.column_iter_mut().enumerate() {
        let Some(&x0) = xi.get(col) else { continue };
        let delta = sqrt_eps * x0.abs().max(T::one());
        if let Some(p) = probe.get_mut(col) {
            *p = x0 + delta;
        }
        // The step actually taken, after rounding of x0 + delta.
        let taken = probe.get(col).map_or(delta, |p| *p - x0);
        column.copy_from(&((sys.residual(&probe) - g) / taken));
        if let Some(p) = probe.get_mut(col) {
            *p = x0;
        }
    }
    stats.residual_evals += M as u32;
    stats.jacobian_evals += 1;
}

/// Max-norm as f64.
pub(crate) fn max_abs<T: Real, const M: usize>(v: &SVector<T, M>) -> f64 {
    v.iter().map(|x| to_f64(x.abs())).fold(0.0, f64::max)
}

/// Scales the algebraic rows by `ρ = h^-p` (Sec. 3.1.1) and leaves the rest at 1.
pub(crate) fn row_scaling<T: Real, const N: usize>(
    algebraic: &[bool; N],
    h: T,
    power: u32,
) -> SVector<T, N> {
    let rho = T::one() / h.powi(power as i32);
    SVector::<T, N>::from_fn(|i, _| {
        if algebraic.get(i).copied().unwrap_or(false) {
            rho
        } else {
            T::one()
        }
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    /// G(ξ) = [ξ0² − 2, ξ0 ξ1 − 3]: root (√2, 3/√2).
    struct Toy;
    impl StepSystem<f64, 2> for Toy {
        fn residual(&self, xi: &SVector<f64, 2>) -> SVector<f64, 2> {
            SVector::<f64, 2>::new(xi[0] * xi[0] - 2.0, xi[0] * xi[1] - 3.0)
        }
        fn jacobian_into(&self, xi: &SVector<f64, 2>, out: &mut SMatrix<f64, 2, 2>) {
            *out = SMatrix::<f64, 2, 2>::new(2.0 * xi[0], 0.0, xi[1], xi[0]);
        }
        fn time(&self) -> f64 {
            0.0
        }
    }

    #[test]
    fn every_mode_finds_the_root() {
        for mode in [
            JacobianMode::Exact,
            JacobianMode::FiniteDifference,
            JacobianMode::Broyden { reinit_every: None },
        ] {
            let mut newton = Newton::<f64, 2>::new(mode, NewtonSettings::default()).unwrap();
            let (xi, stats) = newton
                .solve(&Toy, SVector::<f64, 2>::new(1.0, 1.0))
                .unwrap();
            assert!((xi[0] - 2f64.sqrt()).abs() < 1e-9, "{mode:?}: {xi}");
            assert!((xi[1] - 3.0 / 2f64.sqrt()).abs() < 1e-9, "{mode:?}: {xi}");
            assert!(stats.converged);
        }
    }

    #[test]
    fn iteration_cap_is_a_typed_error() {
        let settings = NewtonSettings {
            max_iterations: 2,
            ..NewtonSettings::default()
        };
        let mut newton = Newton::<f64, 2>::new(JacobianMode::Exact, settings).unwrap();
        let err = newton
            .solve(&Toy, SVector::<f64, 2>::new(10.0, 10.0))
            .unwrap_err();
        assert!(
            matches!(err, Error::NewtonNotConverged { iterations: 2, .. }),
            "{err:?}"
        );
    }

    #[test]
    fn singular_matrix_is_a_typed_error() {
        let mut newton =
            Newton::<f64, 2>::new(JacobianMode::Exact, NewtonSettings::default()).unwrap();
        // At ξ0 = 0 the exact Jacobian has a zero column.
        let err = newton
            .solve(&Toy, SVector::<f64, 2>::new(0.0, 1.0))
            .unwrap_err();
        assert!(matches!(err, Error::SingularJacobian { .. }), "{err:?}");
    }
}
