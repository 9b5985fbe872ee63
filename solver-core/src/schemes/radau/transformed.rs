//! Radau IIA's stage system (Eq. 13) solved as Hairer's RADAU5 solves it: simplified
//! Newton on the system transformed by the eigenvectors of `A⁻¹` (Tab. 1).
//!
//! ## The transformation, for the residual form `F(x, ẋ, t) = 0` (Eq. 12)
//!
//! The unknowns are the stage increments `Z_i = X_i − x_{n−1}` (not the stage
//! derivatives the paper's modes iterate on). With `A` of Tab. 1, Eq. 13's
//! `X_i = x_{n−1} + h Σ_j a_ij X'_j` gives `X' = (hA)⁻¹ Z` (block-wise), so stage i is
//!
//! ```text
//! G_i(Z) = S · F(x_{n−1} + Z_i, Σ_j (A⁻¹)_ij Z_j / h, t_{n−1} + c_i h) = 0,
//! ```
//!
//! `S` the row scaling ρ of Sec. 3.1.1. Simplified Newton freezes `J_x = S ∂F/∂x`
//! and `J_ẋ = S ∂F/∂ẋ` at one point for all three stages; the 3N×3N matrix is then
//! `I ⊗ J_x + (A⁻¹/h) ⊗ J_ẋ`. With `A⁻¹ = T Λ T⁻¹`, `Λ = [γ 0 0; 0 α −β; 0 β α]`
//! (one real eigenvalue γ, the pair α ± iβ), and `Z = (T ⊗ I) V`:
//!
//! ```text
//! (T⁻¹ ⊗ I)(I ⊗ J_x + (A⁻¹/h) ⊗ J_ẋ)(T ⊗ I) = I ⊗ J_x + (Λ/h) ⊗ J_ẋ,
//! ```
//!
//! block-diagonal: one real N×N system `(J_x + γ/h J_ẋ) ΔV_1 = −R_1` and, with
//! `W = ΔV_2 + i ΔV_3`, one complex N×N system `(J_x + (α + iβ)/h J_ẋ) W = −(R_2 + i R_3)`,
//! where `R = (T⁻¹ ⊗ I) G(Z)`. For `M ẏ = f` (`F = M ẏ − f`) this is RADAU5's familiar
//! `γ/h M − ∂f/∂y`. The increment is `ΔZ = (T ⊗ I) ΔV`.
//!
//! ## When the matrices are recomputed
//!
//! A factorisation (the real and the complex system's: two LUs, or one structured
//! elimination whose factors serve both, see [`StageSystems`]) depends on `J` and h
//! only; h is fixed, so it is kept from step to step while the iteration contracts
//! fast. The rule, RADAU5's: the contraction rate `θ_k = ‖ΔZ_k‖ / ‖ΔZ_{k−1}‖` of the last step that
//! measured one decides — above [`THETA_REFRESH`] the next step starts with a fresh
//! `J` (exact partials at the predicted end of the step, stage 3, whose trajectory
//! sample the step has anyway). Within a step, an iteration that contracts by less
//! than `stall_ratio` on an old `J` refreshes it at the current iterate and continues.
//!
//! ## Stopping test with its floor known in advance
//!
//! With `η = θ/(1−θ)` the error left after iteration k is about `η ‖ΔZ_k‖`; the
//! iteration stops when `η ‖ΔZ_k‖ ≤ 1` in Newton's weighted norm (tolerance 1e-12,
//! κ = 1), or when `‖ΔZ_k‖ ≤ 1`. The first iteration has no θ of its own and uses the
//! last one measured, `η ← min(1, 4η)` per step (RADAU5's `FACCON`, which takes `η^0.8`), so a second
//! iteration is forced now and then to measure θ again. At rest the increment is pure
//! rounding, which the index-3 step amplifies by about `1/h²`: when a matrix is
//! factored, the increment that rounding alone produces is estimated in advance —
//! the real system solved with the residual's rounding level
//! `ε S_i Σ_j (|∂F_ij/∂x_j| |x_j| + |∂F_ij/∂ẋ_j| |ẋ_j|)` — and an increment within
//! [`FLOOR_FACTOR`] times it stops the iteration (flagged `at_rounding_floor`). As a
//! safeguard, a fresh matrix that fails to contract below `stall_limit` is also taken
//! as the floor, as in the paper's modes.
//!
//! The residual is not evaluated after the last increment (RADAU5 does not either):
//! `NewtonStats::residual_norm` is that of the iterate before it.
//!
//! ## Closed-form steps
//!
//! With [`StructuredStages`]`<…, Eliminated>` ([`EliminatedStagesOf`]) and a model that
//! solves its step in closed form ([`StructuredJacobian::solve_step`]: for the flat
//! cranes λ, the positions and the rope at each node from the trajectory alone, then
//! velocities and inputs through `X' = (hA)⁻¹ Z`), the stage increments are that
//! solution and no Newton iteration follows: no residual, no matrix (`NewtonStats`
//! report 0 iterations and norms of 0, not evaluated). BDF's closed-form start keeps
//! one correction; here a correction makes things worse: the unknowns are the
//! increments `Z` themselves, which the closed form gives to their own rounding, and a
//! correction adds the residual's rounding at the stage values `x_{n−1} + Z` (metres),
//! which Eq. 13 then differentiates twice. Measured on the paper's move, interior e_max
//! against the iteration from the extrapolated polynomial: closed form alone 0.90,
//! 0.92, 0.97 at 0.5, 1, 2 ms and 1.00 from 5 ms to 50 ms; followed by the iteration
//! (which stops after one correction, at the floor) 1.33, 1.37, 1.01, 1.00.
//!
//! [`Eliminated`]: crate::model::Eliminated

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::linalg::{self, Pivots};
use crate::model::{DaeModel, DifferenceFormula, Predicted, StepStart, StructuredJacobian};
use crate::newton::{max_abs, weighted_norm, JacobianMode, NewtonSettings, NewtonStats};
use crate::scalar::{c, is_finite, Real};
use crate::schemes::contraction::{Contraction, Verdict};
use crate::schemes::radau::step::{RadauNewton, RadauStep};
use crate::schemes::radau::tableau::{extrapolation, A};
use crate::schemes::SolverSettings;

/// The real eigenvalue γ of `A⁻¹` (Tab. 1): `3 + 3^(2/3) − 3^(1/3)`.
pub const GAMMA: f64 = 3.637_834_252_744_496;
/// Real part α of the complex pair of `A⁻¹`: `3 − (3^(2/3) − 3^(1/3))/2`.
pub const ALPHA: f64 = 2.681_082_873_627_752_3;
/// Imaginary part β of the complex pair of `A⁻¹`: `(3^(5/6) + 3^(7/6))/2`.
pub const BETA: f64 = 3.050_430_199_247_411;

/// `T`: columns the eigenvector of `A⁻¹` for γ and the real and imaginary parts of the
/// one for `α − iβ`, so that `A⁻¹ T = T Λ` (checked by a test).
#[rustfmt::skip]
pub const T_MAT: [[f64; 3]; 3] = [
    [0.094_438_762_488_975_29, -0.141_255_295_020_954_27, -0.030_029_194_105_147_407],
    [0.250_213_122_965_333_4,  0.204_129_352_293_799_97,  0.382_942_112_757_261_9],
    [1.0,                      1.0,                       0.0],
];

/// `T⁻¹` (checked by a test).
#[rustfmt::skip]
pub const T_INV: [[f64; 3]; 3] = [
    [4.178_718_591_551_902_5,  0.327_682_820_761_062_03,  0.523_376_445_499_449_6],
    [-4.178_718_591_551_902_5, -0.327_682_820_761_062_03, 0.476_623_554_500_550_33],
    [-0.502_872_634_945_786_9, 2.571_926_949_855_605,     -0.596_039_204_828_225],
];

/// `A⁻¹` of Tab. 1 (checked by a test): stage derivatives from stage increments.
#[rustfmt::skip]
pub const A_INV: [[f64; 3]; 3] = [
    [3.224_744_871_391_589,  1.167_840_084_690_405_8,  -0.253_197_264_742_180_9],
    [-3.567_840_084_690_405_7, 0.775_255_128_608_411_2, 1.053_197_264_742_181],
    [5.531_972_647_421_811,  -7.531_972_647_421_811,   5.0],
];

/// Above this contraction rate the next step starts with a fresh Jacobian. RADAU5's
/// `THET` is 0.001; measured here 0.01 is cheaper at unchanged accuracy (0.5–50 ms,
/// `host-tests/tests/radau5.rs`): at 1 ms, where θ is measured on increments near the
/// rounding floor, 0.001 refreshed J in 79 % of the steps (10,750 host instructions per
/// step), 0.01 in 36 % (8,524); at 10 ms QEMU's mean per cycle fell from 11,943 to 11,675.
pub const THETA_REFRESH: f64 = 0.01;

/// An increment within this factor of the estimated rounding floor stops the iteration.
pub const FLOOR_FACTOR: f64 = 10.0;

/// The stage increments `Z_1, Z_2, Z_3`.
pub(crate) type Stages<T, const N: usize> = [SVector<T, N>; 3];

/// The two transformed N×N systems of a step, `J_x + γ/h J_ẋ` (real) and
/// `J_x + (α + iβ)/h J_ẋ` (complex): factored when the Jacobian is refreshed, solved in
/// every iteration. A type, like BDF's Newton strategy, so that a firmware links one way.
pub trait StageSystems<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize>:
    Sized
{
    /// Nothing factored yet.
    fn empty() -> Self;
    /// Factors both at `at`, `shifts` = `[γ/h, α/h, β/h]`; `false` if either is singular.
    fn factor(&mut self, at: &FactorPoint<'_, T, M, N, NU>, shifts: [T; 3]) -> bool;
    /// Solves the real system in place.
    fn solve_real(&self, r: &mut SVector<T, N>);
    /// Solves the complex system in place, real and imaginary parts.
    fn solve_complex(&self, re: &mut SVector<T, N>, im: &mut SVector<T, N>);

    /// Whether the stages are taken from [`StageSystems::closed_form`] alone: then a step
    /// it refuses is refused ([`Error::SingularJacobian`], 0 iterations) — the iteration
    /// is not a fall-back, so that a firmware taking the closed form does not link it.
    /// The flat cranes' closed form refuses only a slack rope (the elimination's pivots
    /// vanish: the iteration's factors would be singular too) or the rope moving by more
    /// than 15 % of its length in one step, trajectories the models' checks and the
    /// planner's limits refuse up front.
    const CLOSED_FORM: bool = false;

    /// The step's stage increments in closed form, where this way of solving takes them
    /// from the model ([`StructuredJacobian::solve_step`]); `None` (the default): the
    /// iteration from the extrapolated collocation polynomial.
    fn closed_form<D: DifferenceFormula<T, 3>>(
        model: &M,
        samples: &[M::Sample; 3],
        d: &D,
    ) -> Option<Stages<T, N>> {
        let _ = (model, samples, d);
        None
    }
}

/// Where the systems are formed: the model at stage 3's values `x`, `ẋ` and trajectory
/// sample, with the row scaling S and the row-scaled partials `S ∂F/∂x`, `S ∂F/∂ẋ` there.
pub struct FactorPoint<'a, T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize> {
    model: &'a M,
    x: SVector<T, N>,
    xdot: SVector<T, N>,
    sample: &'a M::Sample,
    scale: &'a SVector<T, N>,
    jx: SMatrix<T, N, N>,
    jxd: SMatrix<T, N, N>,
}

/// Dense LUs of the two systems (any model): a real one and a complex one in real
/// arithmetic (`linalg::factor_complex`).
#[derive(Debug, Clone)]
pub struct DenseStages<T: Real, const N: usize> {
    /// LU of `J_x + γ/h J_ẋ`.
    real: SMatrix<T, N, N>,
    real_pivots: Pivots<N>,
    /// LU of `J_x + (α + iβ)/h J_ẋ`, real and imaginary parts.
    complex_re: SMatrix<T, N, N>,
    complex_im: SMatrix<T, N, N>,
    complex_pivots: Pivots<N>,
}

impl<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize> StageSystems<T, M, N, NU>
    for DenseStages<T, N>
{
    fn empty() -> Self {
        Self {
            real: SMatrix::zeros(),
            real_pivots: [0; N],
            complex_re: SMatrix::zeros(),
            complex_im: SMatrix::zeros(),
            complex_pivots: [0; N],
        }
    }

    fn factor(
        &mut self,
        at: &FactorPoint<'_, T, M, N, NU>,
        [gamma_h, alpha_h, beta_h]: [T; 3],
    ) -> bool {
        self.real = at.jx + at.jxd * gamma_h;
        self.complex_re = at.jx + at.jxd * alpha_h;
        self.complex_im = at.jxd * beta_h;
        linalg::factor(&mut self.real, &mut self.real_pivots)
            && linalg::factor_complex(
                &mut self.complex_re,
                &mut self.complex_im,
                &mut self.complex_pivots,
            )
    }

    fn solve_real(&self, r: &mut SVector<T, N>) {
        linalg::solve(&self.real, &self.real_pivots, r);
    }

    fn solve_complex(&self, re: &mut SVector<T, N>, im: &mut SVector<T, N>) {
        linalg::solve_complex(
            &self.complex_re,
            &self.complex_im,
            &self.complex_pivots,
            re,
            im,
        );
    }
}

/// The model's structured elimination of both systems ([`StructuredJacobian`]; for the
/// crane *subs* model 3 divisions and a few dozen multiply-adds instead of two LUs).
///
/// With `S` = [`Eliminated`](crate::model::Eliminated), the stage system itself is
/// solved by the model's closed-form step where it has one, and no Newton iteration
/// follows (see [`Transformed`]'s *Closed-form steps*); [`Predicted`], the default,
/// iterates from the extrapolated collocation polynomial.
#[derive(Debug, Clone)]
pub struct StructuredStages<T: Real, F, S = Predicted> {
    /// Factors for the shift γ/h.
    real: Option<F>,
    /// Factors for the real part α/h of the complex shift.
    complex: Option<F>,
    /// Its imaginary part β/h.
    beta_h: T,
    start: core::marker::PhantomData<fn() -> S>,
}

/// The [`StructuredStages`] of a model `M` iterating from the extrapolated collocation
/// polynomial (the firmware's before issue 20).
pub type StructuredStagesOf<T, M, const N: usize, const NU: usize> =
    StructuredStages<T, <M as StructuredJacobian<T, N, NU>>::Factors>;

/// The [`StructuredStages`] of a model `M` taking the stages from its closed-form step (the
/// firmware's: `StructuredRadau5` of a model's scheme aliases; within the iteration's
/// rounding floor, `host-tests/tests/step_accuracy.rs`).
pub type EliminatedStagesOf<T, M, const N: usize, const NU: usize> =
    StructuredStages<T, <M as StructuredJacobian<T, N, NU>>::Factors, crate::model::Eliminated>;

impl<T: Real, M, S: StepStart, const N: usize, const NU: usize> StageSystems<T, M, N, NU>
    for StructuredStages<T, M::Factors, S>
where
    M: StructuredJacobian<T, N, NU>,
{
    const CLOSED_FORM: bool = S::ELIMINATE && M::CLOSED_FORM;

    fn empty() -> Self {
        Self {
            real: None,
            complex: None,
            beta_h: T::zero(),
            start: core::marker::PhantomData,
        }
    }

    fn factor(
        &mut self,
        at: &FactorPoint<'_, T, M, N, NU>,
        [gamma_h, alpha_h, beta_h]: [T; 3],
    ) -> bool {
        let factor = |shift| at.model.factor(&at.x, &at.xdot, at.sample, shift, at.scale);
        self.real = factor(gamma_h);
        self.complex = factor(alpha_h);
        self.beta_h = beta_h;
        self.real.is_some() && self.complex.is_some()
    }

    fn solve_real(&self, r: &mut SVector<T, N>) {
        if let Some(f) = &self.real {
            M::solve(f, r);
        }
    }

    fn solve_complex(&self, re: &mut SVector<T, N>, im: &mut SVector<T, N>) {
        if let Some(f) = &self.complex {
            M::solve_complex(f, self.beta_h, re, im);
        }
    }

    fn closed_form<D: DifferenceFormula<T, 3>>(
        model: &M,
        samples: &[M::Sample; 3],
        d: &D,
    ) -> Option<Stages<T, N>> {
        if S::ELIMINATE {
            model.solve_step(samples, d)
        } else {
            None
        }
    }
}

/// RADAU5's transformed simplified Newton for a model of `N` unknowns, its two systems
/// solved by `L` ([`DenseStages`] or the model's [`StructuredStages`]): the factors and
/// what the iteration carries between steps (a Radau Newton strategy,
/// [`RadauNewton`]).
#[derive(Debug, Clone)]
pub struct Transformed<T: Real, const N: usize, L = DenseStages<T, N>> {
    settings: NewtonSettings,
    /// The two systems, factored.
    systems: L,
    /// Whether the factors above are valid.
    factored: bool,
    /// The last contraction rate measured (decides the refresh at the next step).
    theta: f64,
    /// `η = θ/(1−θ)` carried into the first iteration of the next step.
    eta: f64,
    /// The increment (weighted norm) that rounding alone produces with these factors.
    floor: f64,
    gamma_h: T,
    alpha_h: T,
    beta_h: T,
    t_mat: [[T; 3]; 3],
    t_inv: [[T; 3]; 3],
    /// `A⁻¹/h`.
    a_inv_h: [[T; 3]; 3],
    /// The last step's stage increments.
    last: Stages<T, N>,
    /// `A E A⁻¹`: the last step's collocation polynomial extrapolated to this step's
    /// nodes, in stage increments (`E` of [`extrapolation`] acts on derivatives:
    /// `Z = hA X'`, `X' = (hA)⁻¹ Z`; h cancels). Zero where the stages come in closed
    /// form (never read).
    continuation: [[T; 3]; 3],
}

impl<T: Real, const N: usize, L> Transformed<T, N, L> {
    /// The solver for step size `h`.
    pub(crate) fn new<M, const NU: usize>(settings: NewtonSettings, h: T) -> Result<Self>
    where
        M: DaeModel<T, N, NU>,
        L: StageSystems<T, M, N, NU>,
    {
        // Stages in closed form: no iteration, so no settings to check and no
        // continuation to start it from (neither is linked).
        if !L::CLOSED_FORM {
            settings.validate()?;
        }
        let conv = |m: [[f64; 3]; 3]| m.map(|row| row.map(c::<T>));
        Ok(Self {
            settings,
            systems: L::empty(),
            factored: false,
            theta: 0.0,
            eta: 1.0,
            floor: 0.0,
            gamma_h: c::<T>(GAMMA) / h,
            alpha_h: c::<T>(ALPHA) / h,
            beta_h: c::<T>(BETA) / h,
            t_mat: conv(T_MAT),
            t_inv: conv(T_INV),
            a_inv_h: A_INV.map(|row| row.map(|a| c::<T>(a) / h)),
            last: [SVector::zeros(); 3],
            continuation: if L::CLOSED_FORM {
                [[T::zero(); 3]; 3]
            } else {
                conv(mul3(&A, &mul3(&extrapolation(), &A_INV)))
            },
        })
    }

    /// Forgets the factors (after a restart).
    pub(crate) fn forget(&mut self) {
        self.last = [SVector::zeros(); 3];
        self.factored = false;
        self.theta = 0.0;
        self.eta = 1.0;
    }

    /// Stage derivatives `X' = (A⁻¹/h) Z`.
    pub(crate) fn derivatives(&self, z: &Stages<T, N>) -> Stages<T, N> {
        self.a_inv_h.map(|row| {
            row.iter()
                .zip(z)
                .fold(SVector::zeros(), |acc, (a, zj)| acc + zj * *a)
        })
    }

    /// Exact partials at stage 3 of `z`, the two matrices factored, the floor estimated.
    fn refresh<M, const NU: usize>(
        &mut self,
        data: &RadauStep<'_, T, M, N, NU>,
        z: &Stages<T, N>,
        stats: &mut NewtonStats,
    ) -> Result<()>
    where
        M: DaeModel<T, N, NU>,
        L: StageSystems<T, M, N, NU>,
    {
        let [_, _, z3] = z;
        let x = data.x0 + z3;
        let [_, _, xdot] = self.derivatives(z);
        let [_, _, sample] = &data.samples;
        let p = data.model.partials(&x, &xdot, sample);
        stats.jacobian_evals += 1;
        stats.factorizations += 1;
        self.factored = false;
        // Rows scaled by S (Sec. 3.1.1) — the same row scaling as the residual.
        let mut jx = p.dx;
        let mut jxd = p.dxdot;
        for (i, s) in data.scale.iter().enumerate() {
            jx.row_mut(i).scale_mut(*s);
            jxd.row_mut(i).scale_mut(*s);
        }
        // The residual's rounding level, row by row.
        let eps = T::default_epsilon();
        let noise = SVector::<T, N>::from_fn(|i, _| {
            let terms = jx
                .row(i)
                .iter()
                .zip(x.iter())
                .chain(jxd.row(i).iter().zip(xdot.iter()))
                .fold(T::zero(), |acc, (j, v)| acc + (*j * *v).abs());
            eps * terms
        });
        let at = FactorPoint {
            model: data.model,
            x,
            xdot,
            sample,
            scale: data.scale,
            jx,
            jxd,
        };
        if !self
            .systems
            .factor(&at, [self.gamma_h, self.alpha_h, self.beta_h])
        {
            return Err(Error::SingularJacobian {
                t: data.t,
                iterations: stats.iterations,
                residual: stats.residual_norm,
            });
        }
        let mut d = noise;
        self.systems.solve_real(&mut d);
        let floor = weighted_norm(&d, &x, self.settings.rtol, self.settings.atol);
        self.floor = if floor.is_finite() {
            FLOOR_FACTOR * floor
        } else {
            0.0
        };
        self.factored = true;
        self.theta = 0.0;
        Ok(())
    }

    /// `G(Z)` (Eq. 13 in stage increments) and the stage values.
    fn residual<M, const NU: usize>(
        &self,
        data: &RadauStep<'_, T, M, N, NU>,
        z: &Stages<T, N>,
        stats: &mut NewtonStats,
    ) -> Result<Stages<T, N>>
    where
        M: DaeModel<T, N, NU>,
    {
        stats.residual_evals += 1;
        let xdot = self.derivatives(z);
        let mut g = [SVector::<T, N>::zeros(); 3];
        for (((gi, zi), xdi), sample) in g.iter_mut().zip(z).zip(&xdot).zip(&data.samples) {
            *gi = data
                .model
                .residual(&(data.x0 + zi), xdi, sample)
                .component_mul(data.scale);
            if !gi.iter().all(|v| is_finite(*v)) {
                return Err(Error::NonFinite {
                    t: data.t,
                    iterations: stats.iterations,
                });
            }
        }
        Ok(g)
    }

    /// Solves one step's stage system, from the last step's collocation polynomial
    /// extrapolated (or, where `L` takes them from the model, in closed form); the stage
    /// increments.
    pub(crate) fn iterate<M, const NU: usize>(
        &mut self,
        data: &RadauStep<'_, T, M, N, NU>,
    ) -> Result<(Stages<T, N>, NewtonStats)>
    where
        M: DaeModel<T, N, NU>,
        L: StageSystems<T, M, N, NU>,
    {
        let formula = StageFormula {
            a_inv_h: &self.a_inv_h,
            x0: &data.x0,
        };
        if L::CLOSED_FORM {
            // No iteration to fall back on (so none is linked): see
            // `StageSystems::CLOSED_FORM`.
            let z = L::closed_form(data.model, &data.samples, &formula).ok_or(
                Error::SingularJacobian {
                    t: data.t,
                    iterations: 0,
                    residual: 0.0,
                },
            )?;
            self.last = z;
            let stats = NewtonStats {
                converged: true,
                ..NewtonStats::default()
            };
            return Ok((z, stats));
        }
        let mut z = self.continuation.map(|row| {
            row.iter()
                .zip(&self.last)
                .fold(SVector::<T, N>::zeros(), |acc, (w, zi)| acc + zi * *w)
        });
        let mut stats = NewtonStats::default();
        let mut fresh = false;
        if !self.factored || self.theta > THETA_REFRESH {
            self.refresh(data, &z, &mut stats)?;
            fresh = true;
        }
        let mut contraction = Contraction::start(self.eta);
        let (rtol, atol) = (self.settings.rtol, self.settings.atol);
        for it in 1..=self.settings.max_iterations {
            let g = self.residual(data, &z, &mut stats)?;
            stats.residual_norm = g.iter().map(max_abs).fold(0.0, f64::max);
            let dz = self.increment::<M, NU>(&g);
            let mut norm = 0.0_f64;
            for (zi, dzi) in z.iter_mut().zip(&dz) {
                *zi += dzi;
                norm = norm.max(weighted_norm(dzi, &(data.x0 + *zi), rtol, atol));
            }
            stats.iterations = it;
            stats.increment_norm = norm;
            if !norm.is_finite() {
                return Err(Error::NonFinite {
                    t: data.t,
                    iterations: it,
                });
            }
            let verdict = contraction.judge(it, norm, fresh, self.floor, &self.settings);
            if let Some(theta) = contraction.theta() {
                self.theta = theta;
            }
            match verdict {
                Verdict::Converged => stats.converged = true,
                Verdict::AtRoundingFloor => {
                    stats.converged = true;
                    stats.at_rounding_floor = true;
                }
                Verdict::Refresh => {
                    // An old matrix that no longer contracts: refresh it here.
                    self.refresh(data, &z, &mut stats)?;
                    fresh = true;
                }
                Verdict::Continue => {}
            }
            if stats.converged {
                self.eta = contraction.eta();
                self.last = z;
                return Ok((z, stats));
            }
        }
        Err(Error::NewtonNotConverged {
            t: data.t,
            iterations: stats.iterations,
            residual: stats.residual_norm,
            increment: stats.increment_norm,
        })
    }

    /// `ΔZ = −(T ⊗ I) blockdiag(real, complex)⁻¹ (T⁻¹ ⊗ I) G`.
    fn increment<M, const NU: usize>(&self, g: &Stages<T, N>) -> Stages<T, N>
    where
        M: DaeModel<T, N, NU>,
        L: StageSystems<T, M, N, NU>,
    {
        let [r1, mut r2, mut r3] = self.t_inv.map(|row| {
            row.iter()
                .zip(g)
                .fold(SVector::<T, N>::zeros(), |acc, (t, gi)| acc - gi * *t)
        });
        let mut v1 = r1;
        self.systems.solve_real(&mut v1);
        self.systems.solve_complex(&mut r2, &mut r3);
        let v = [v1, r2, r3];
        self.t_mat.map(|row| {
            row.iter()
                .zip(&v)
                .fold(SVector::<T, N>::zeros(), |acc, (t, vk)| acc + vk * *t)
        })
    }
}

/// Eq. 13 solved for the stage derivatives, one unknown at a time:
/// `X'_i = Σ_k (A⁻¹/h)_ik Z_k`, `Z_k = X_k − x_{n−1}` — the operations of
/// [`Transformed::derivatives`].
struct StageFormula<'a, T: Real, const N: usize> {
    a_inv_h: &'a [[T; 3]; 3],
    x0: &'a SVector<T, N>,
}

impl<T: Real, const N: usize> DifferenceFormula<T, 3> for StageFormula<'_, T, N> {
    fn anchor(&self, j: usize) -> T {
        self.x0.get(j).copied().unwrap_or_else(T::zero)
    }

    fn derivative(&self, _j: usize, z: [T; 3]) -> [T; 3] {
        self.a_inv_h.map(|row| {
            row.iter()
                .zip(&z)
                .fold(T::zero(), |acc, (a, zk)| acc + *zk * *a)
        })
    }
}

/// The product of two 3×3 matrices.
fn mul3(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    a.map(|row| {
        [0, 1, 2].map(|j| {
            row.iter().zip(b).fold(0.0, |acc, (aik, brow)| {
                acc + aik * brow.get(j).copied().unwrap_or(0.0)
            })
        })
    })
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

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing)]
    use super::*;

    fn mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
        let mut out = [[0.0; 3]; 3];
        for (i, row) in out.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        out
    }

    fn assert_identity(m: &[[f64; 3]; 3], what: &str) {
        for (i, row) in m.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                let e = if i == j { 1.0 } else { 0.0 };
                assert!((v - e).abs() < 1e-14, "{what}: ({i}, {j}) = {v}");
            }
        }
    }

    /// `A A⁻¹ = I`, `T T⁻¹ = I`, and `A⁻¹ T = T Λ` with Λ's real 2×2 block for α ± iβ.
    #[test]
    fn transformation_diagonalises_a_inverse() {
        assert_identity(&mul(&A, &A_INV), "A A⁻¹");
        assert_identity(&mul(&T_MAT, &T_INV), "T T⁻¹");
        let lambda = [[GAMMA, 0.0, 0.0], [0.0, ALPHA, -BETA], [0.0, BETA, ALPHA]];
        let (lhs, rhs) = (mul(&A_INV, &T_MAT), mul(&T_MAT, &lambda));
        for i in 0..3 {
            for j in 0..3 {
                assert!(
                    (lhs[i][j] - rhs[i][j]).abs() < 1e-13,
                    "A⁻¹T ≠ TΛ at ({i}, {j})"
                );
            }
        }
        let cbrt3 = 3f64.cbrt();
        assert!((GAMMA - (3.0 + cbrt3 * cbrt3 - cbrt3)).abs() < 1e-14);
        assert!((ALPHA - (3.0 - (cbrt3 * cbrt3 - cbrt3) / 2.0)).abs() < 1e-14);
        assert!((BETA - (3f64.powf(5.0 / 6.0) + 3f64.powf(7.0 / 6.0)) / 2.0).abs() < 1e-14);
    }
}
