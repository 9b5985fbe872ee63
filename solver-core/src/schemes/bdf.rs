//! BDF k = 1..6 (Eq. 16, Tab. 2); k = 1 is the implicit Euler.
//!
//! Each step solves `F(x_n, (1/h) Σ_{i=0..k} α_i x_{n−i}, t_n) = 0` for `x_n`.
//!
//! ## Start-up
//!
//! BDF needs the k values before the first step, consistent of order k + 1
//! (Brenan et al., ref. \[16\]). The inverse model starts at rest: the desired
//! output rests before its move, so the exact solution is the constant rest state
//! for all earlier times, and the history is filled with it — exact, hence
//! consistent of any order. A start time at which the trajectory moves is refused
//! ([`Error::NotAtRest`]) rather than started with a wrong history.
//!
//! ## How Newton is done: a type parameter
//!
//! [`Bdf`]'s last parameter is its Newton strategy ([`BdfNewton`]). The default,
//! [`Newton`], takes the Jacobian mode at run time (J, J̃, J̃ₙ, exact — the paper's
//! study) and factors a dense matrix. [`Structured`] takes the exact partials through
//! the model's own elimination of its fixed sparsity pattern
//! ([`StructuredJacobian`]) and keeps the factors across iterations and steps while
//! the iteration contracts fast. Being a type, the choice decides what is linked: a
//! firmware whose scene names `Structured` contains no finite differences, no Broyden
//! and no dense LU.

use core::marker::PhantomData;

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::model::{DaeModel, DifferenceFormula, Predicted, StepStart, StructuredJacobian};
use crate::newton::{
    max_abs, row_scaling, weighted_norm, JacobianMode, Newton, NewtonSettings, NewtonStats,
    StepSystem,
};
use crate::scalar::{c, to_f64, Real};
use crate::schemes::contraction::{Contraction, Verdict};
use crate::schemes::history::History;
use crate::schemes::{SolverSettings, StepReport};

/// Largest supported k (BDF is not zero-stable beyond 6).
pub const MAX_K: usize = 6;

/// `α_0 … α_k` of Tab. 2, one row per k.
#[rustfmt::skip]
pub const ALPHA: [[f64; MAX_K + 1]; MAX_K] = [
    [1.0,           -1.0, 0.0,        0.0,         0.0,        0.0,        0.0],
    [3.0 / 2.0,     -2.0, 1.0 / 2.0,  0.0,         0.0,        0.0,        0.0],
    [11.0 / 6.0,    -3.0, 3.0 / 2.0,  -1.0 / 3.0,  0.0,        0.0,        0.0],
    [25.0 / 12.0,   -4.0, 3.0,        -4.0 / 3.0,  1.0 / 4.0,  0.0,        0.0],
    [137.0 / 60.0,  -5.0, 5.0,        -10.0 / 3.0, 5.0 / 4.0,  -1.0 / 5.0, 0.0],
    [49.0 / 20.0,   -6.0, 15.0 / 2.0, -20.0 / 3.0, 15.0 / 4.0, -6.0 / 5.0, 1.0 / 6.0],
];

/// The k-step BDF integrator for a model `M` with `N` unknowns and `NU` inputs, its
/// Newton iteration done by `J` (see the module's documentation).
#[derive(Debug, Clone)]
pub struct Bdf<T: Real, M, const N: usize, const NU: usize, J = Newton<T, N>> {
    k: usize,
    h: T,
    t0: T,
    steps: u64,
    /// `α_0 … α_k` in T.
    alpha: [T; MAX_K + 1],
    /// Predictor: the polynomial through the last k values, extrapolated to `t_n`.
    predictor: [T; MAX_K],
    scale: SVector<T, N>,
    /// `x_{n−1}, x_{n−2}, …`.
    history: History<T, N, MAX_K>,
    newton: J,
    model: PhantomData<fn() -> M>,
}

impl<
        T: Real,
        M: DaeModel<T, N, NU>,
        const N: usize,
        const NU: usize,
        J: BdfNewton<T, M, N, NU>,
    > Bdf<T, M, N, NU, J>
{
    /// A k-step BDF starting at rest at `t0`.
    pub fn new(model: &M, settings: &SolverSettings, k: usize, t0: T) -> Result<Self> {
        // Newton's settings: by the strategy (`J::new`), if it iterates.
        settings.validate_step()?;
        let row = k
            .checked_sub(1)
            .and_then(|r| ALPHA.get(r))
            .ok_or(Error::InvalidSetting {
                name: "bdf_k",
                value: k as f64,
            })?;
        let h = c::<T>(settings.h);
        let x0 = model.rest_state(t0)?;
        let mut predictor = [T::zero(); MAX_K];
        for (i, p) in predictor.iter_mut().take(k).enumerate() {
            // Extrapolation through k equidistant points: (−1)^(i) C(k, i+1).
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            *p = c(sign * binomial(k, i + 1));
        }
        Ok(Self {
            k,
            h,
            t0,
            steps: 0,
            alpha: row.map(c),
            predictor,
            scale: row_scaling(&M::ALGEBRAIC, h, settings.scaling_power),
            history: History::filled(x0),
            newton: J::new(settings)?,
            model: PhantomData,
        })
    }

    /// Starts again at rest at `t0` (after a halt), with the same settings; the model's
    /// trajectory must rest at `t0`.
    pub fn restart(&mut self, model: &M, t0: T) -> Result<()> {
        let x0 = model.rest_state(t0)?;
        self.history = History::filled(x0);
        self.t0 = t0;
        self.steps = 0;
        self.newton.forget();
        Ok(())
    }

    /// The number of steps k.
    #[must_use]
    pub fn k(&self) -> usize {
        self.k
    }

    /// Time of the newest solution value.
    #[must_use]
    pub fn time(&self) -> T {
        self.t0 + c::<T>(self.steps as f64) * self.h
    }

    /// The newest solution value.
    #[must_use]
    pub fn state(&self) -> SVector<T, N> {
        self.history.newest()
    }

    /// Advances one step. On error the integrator stays where it was.
    pub fn step(&mut self, model: &M) -> Result<StepReport<T, N, NU>> {
        let t = self.t0 + c::<T>((self.steps + 1) as f64) * self.h;
        // Eq. 16 in differences against the newest value x_{n−1} (Σ α_i = 0):
        // ẋ = (α_0 (ξ − x_{n−1}) + Σ_{i≥2} α_i (x_{n−i} − x_{n−1}))/h. Exact for a
        // resting history, and it spares the index-3 step the rounding of Σ α_i x_{n−i}.
        let anchor = self.state();
        let mut past = SVector::<T, N>::zeros();
        let mut guess = anchor;
        if J::PREDICTS {
            let newest_first = self.history.newest_first().take(self.k);
            for ((x, a), p) in newest_first
                .zip(self.alpha.iter().skip(1))
                .zip(self.predictor.iter())
            {
                let d = x - anchor;
                past += d * *a;
                guess += d * *p;
            }
        } else {
            // From the closed form: no predictor, and the sums of the model's differential
            // unknowns only (`DaeModel::DIFFERENTIAL`, the first ones; no row reads the
            // others' ẋ), from x_{n−2} on (x_{n−1}'s term α_1 (x_{n−1} − x_{n−1}) is +0, and
            // +0 + (−0) = +0): each sum the same bits as above. The others' `past` stays 0.
            let older = self.alpha.get(2..=self.k).unwrap_or_default();
            for (i, a) in older.iter().enumerate() {
                let Some(x) = self.history.back(i + 1) else {
                    break;
                };
                let unknowns = past.as_mut_slice().iter_mut().zip(x.as_slice());
                let unknowns = unknowns.zip(anchor.as_slice()).take(M::DIFFERENTIAL);
                for ((p, xj), aj) in unknowns {
                    *p += (*xj - *aj) * *a;
                }
            }
        }
        let system = BdfStep {
            model,
            sample: model.sample(t),
            anchor,
            past,
            alpha0: self.alpha.first().copied().unwrap_or_else(T::one),
            inv_h: T::one() / self.h,
            scale: &self.scale,
            t: to_f64(t),
        };
        let (x, stats) = self.newton.solve(&system, guess)?;
        self.history.push(x);
        self.steps += 1;
        Ok(StepReport {
            t,
            u: M::inputs(&x),
            x,
            stats,
        })
    }
}

/// One BDF step's system: `G(ξ) = S·F(ξ, (α_0 ξ + Σ α_i x_{n−i})/h, t_n)`, with the
/// derivative evaluated in the difference form of [`Bdf::step`].
#[derive(Debug)]
pub struct BdfStep<'a, T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize> {
    model: &'a M,
    sample: M::Sample,
    /// `x_{n−1}`.
    anchor: SVector<T, N>,
    /// `Σ_{i≥2} α_i (x_{n−i} − x_{n−1})` (0 for the algebraic unknowns where the
    /// strategy does not predict, [`BdfNewton::PREDICTS`]).
    past: SVector<T, N>,
    alpha0: T,
    inv_h: T,
    scale: &'a SVector<T, N>,
    t: f64,
}

impl<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize> BdfStep<'_, T, M, N, NU> {
    /// `ẋ` at `ξ` by Eq. 16.
    fn derivative(&self, xi: &SVector<T, N>) -> SVector<T, N> {
        ((xi - self.anchor) * self.alpha0 + self.past) * self.inv_h
    }
}

/// Eq. 16 for one unknown in the difference form of [`Bdf::step`]:
/// `ẋ_j = (α_0 (ξ_j − x_{n−1,j}) + Σ_{i≥2} α_i (x_{n−i,j} − x_{n−1,j})) / h` — the
/// operations of the residual's `ẋ` (`BdfStep::derivative`), so that the closed-form step and the residual
/// differentiate alike.
impl<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize> DifferenceFormula<T, 1>
    for BdfStep<'_, T, M, N, NU>
{
    fn anchor(&self, j: usize) -> T {
        self.anchor.get(j).copied().unwrap_or_else(T::zero)
    }

    fn derivative(&self, j: usize, [increment]: [T; 1]) -> [T; 1] {
        let past = self.past.get(j).copied().unwrap_or_else(T::zero);
        [(increment * self.alpha0 + past) * self.inv_h]
    }
}

impl<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize> StepSystem<T, N>
    for BdfStep<'_, T, M, N, NU>
{
    fn residual(&self, xi: &SVector<T, N>) -> SVector<T, N> {
        let xdot = self.derivative(xi);
        self.model
            .residual(xi, &xdot, &self.sample)
            .component_mul(self.scale)
    }

    fn jacobian_into(&self, xi: &SVector<T, N>, out: &mut SMatrix<T, N, N>) {
        let xdot = self.derivative(xi);
        let p = self.model.partials(xi, &xdot, &self.sample);
        *out = p.dx + p.dxdot * (self.alpha0 * self.inv_h);
        scale_rows(out, self.scale);
    }

    fn time(&self) -> f64 {
        self.t
    }
}

/// How a BDF step solves its nonlinear system (see the module's documentation).
pub trait BdfNewton<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize>:
    Sized
{
    /// The strategy for `settings`; refuses a Jacobian mode it cannot do, and Newton's
    /// settings if it iterates ([`Bdf::new`] does not check them).
    fn new(settings: &SolverSettings) -> Result<Self>;
    /// Whether the strategy starts from the predictor: [`Bdf::step`] forms it with Eq.
    /// 16's history sum only then (otherwise `xi` is `x_{n−1}`, and the history sum is
    /// formed for the model's differential unknowns only, [`DaeModel::DIFFERENTIAL`]:
    /// the step's `ẋ` of the others is then not Eq. 16's, which only a strategy that
    /// reads it through the model's `F` may accept).
    const PREDICTS: bool = true;
    /// Forgets what is carried from step to step (after a restart).
    fn forget(&mut self);
    /// Solves one step's system from the predictor `xi` (or wherever the strategy
    /// starts).
    fn solve(
        &mut self,
        step: &BdfStep<'_, T, M, N, NU>,
        xi: SVector<T, N>,
    ) -> Result<(SVector<T, N>, NewtonStats)>;
}

/// The paper's modes, chosen at run time; a dense LU.
impl<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize> BdfNewton<T, M, N, NU>
    for Newton<T, N>
{
    fn new(settings: &SolverSettings) -> Result<Self> {
        Newton::new(settings.jacobian, settings.newton)
    }

    fn forget(&mut self) {
        Newton::forget(self);
    }

    fn solve(
        &mut self,
        step: &BdfStep<'_, T, M, N, NU>,
        xi: SVector<T, N>,
    ) -> Result<(SVector<T, N>, NewtonStats)> {
        Newton::solve(self, step, xi)
    }
}

/// Simplified Newton on the model's structured elimination of the exact Newton matrix
/// ([`StructuredJacobian`]), for the exact Jacobian mode only (anything else is refused).
///
/// Each step factors the matrix once, at its predicted `ξ`, and keeps the factors for
/// its iterations; an iteration that contracts by less than `stall_ratio` refactors at
/// the current iterate once, and if fresh factors still do not contract below
/// `stall_limit` the increment is rounding noise (the floor, as in the paper's modes).
/// The stopping test is RADAU5's: `θ/(1−θ)·‖η‖ ≤ 1` or `‖η‖ ≤ 1` (Newton's weighted
/// norm, tolerance 1e-12), with `θ = ‖η_k‖/‖η_{k−1}‖`; the first iteration of a step
/// uses the last `θ/(1−θ)` measured, growing by 4× per step while it is not measured
/// again, so that a second iteration is forced now and then. The residual is not
/// evaluated after the last increment: `NewtonStats::residual_norm` is that of the
/// iterate before it.
///
/// Why the factors are not kept across steps (as RADAU5 keeps its LUs while θ ≤ 0.01):
/// the elimination costs less than one iteration (3 divisions), and old factors cost
/// iterations. Measured on the paper's move at h = 10 ms (host callgrind,
/// `examples/bdf_steps.rs`): refactoring when the last θ exceeded 0.01 took 2,601
/// iterations and 1,610 instructions per step, when it exceeded 0.1 2,605 iterations,
/// refactoring every step 1,410 and 1,387.
///
/// ## Where a step starts: `S`
///
/// [`Predicted`] (the default): from the predictor, as above. [`Eliminated`]: from the
/// model's closed-form step ([`StructuredJacobian::solve_step`]) where it has one, which
/// already solves Eq. 16 to rounding. Below [`CORRECT_BELOW_H`] (5 ms) exactly one
/// simplified-Newton correction follows, at factors formed there, with no stopping test:
/// its work is to make positions, velocities and inputs agree as the residual rounds
/// them, which the index-3 step then differentiates twice — without it the interior error
/// of the paper's move at 2 ms was 5 % above Newton's (1.84e-9 against 1.76e-9), with it
/// 0.997–1.000 of Newton's from 0.5 to 2 ms. From 5 ms on the closed form is the step (no
/// iteration, no matrix); a model without differential unknowns (`DaeModel::DIFFERENTIAL`
/// 0: the extended cranes, algebraic, their closed form exact at every node) is never
/// corrected. A model without a closed form keeps the predictor and the
/// iteration above. A step the closed form refuses (a slack rope, which the models'
/// trajectory checks refuse up front, or the rope moving by more than 15 % of its length
/// in one step) is refused ([`Error::SingularJacobian`], 0 iterations): the iteration is
/// not a fall-back, so that a firmware starting from the closed form does not link it.
/// [`EliminatedUncorrected`]: the same from 5 ms on, and smaller steps refused, so that
/// the correction is not linked either (a firmware's scene fixes h at build time; 1.3 KiB
/// of the default scene's flash).
///
/// [`Eliminated`]: crate::model::Eliminated
/// [`EliminatedUncorrected`]: crate::model::EliminatedUncorrected
#[derive(Debug, Clone)]
pub struct Structured<T: Real, F, S = Predicted> {
    settings: NewtonSettings,
    factors: Option<F>,
    /// `θ/(1−θ)` carried into the first iteration of the next step.
    eta: f64,
    /// Whether a closed-form start is corrected (`h` below [`CORRECT_BELOW_H`]).
    correct: bool,
    scalar: PhantomData<fn() -> (T, S)>,
}

/// Below this step size (s) a closed-form start gets its Newton correction; from it on
/// the closed form is the step. Below 5 ms the interior error of the index-3 step is
/// rounding amplified by the index (DESIGN, *Conditioning*), and the correction keeps it
/// at Newton's: on the paper's move the closed form alone had 0.94, 1.00, 1.05 of the
/// predictor's interior e_max at 0.5, 1, 2 ms, corrected 0.997, 0.999, 0.9997. From 5 ms
/// the discretisation error is all there is: the closed form alone is within 1e-4 of
/// the predictor's interior e_max and 1e-11 of its e_max (e_max 4e-16 below it at 5 ms,
/// the corrected one 4e-16 above), and the correction would cost 40 % of the step (697
/// against 423 host instructions).
pub const CORRECT_BELOW_H: f64 = 0.005;

/// Refuses a step value with a NaN or an infinity in it (after `iterations`).
fn ensure_finite<T: Real, const N: usize>(
    xi: &SVector<T, N>,
    t: f64,
    iterations: u32,
) -> Result<()> {
    // A NaN or infinity anywhere makes the sum one (one test instead of N).
    if crate::scalar::is_finite(xi.iter().fold(T::zero(), |acc, v| acc + *v)) {
        Ok(())
    } else {
        Err(Error::NonFinite { t, iterations })
    }
}

/// The [`Structured`] strategy of a model `M` starting from the predictor (the
/// firmware's before issue 20; the studies' and tests' iterating reference).
pub type StructuredOf<T, M, const N: usize, const NU: usize> =
    Structured<T, <M as StructuredJacobian<T, N, NU>>::Factors>;

/// The [`Structured`] strategy of a model `M` starting from the model's closed-form step
/// (`StructuredBdf` of a model's scheme aliases; the firmware's for h below
/// [`CORRECT_BELOW_H`], [`EliminatedUncorrectedOf`] from there on). Against the predictor's
/// iteration its e_max and interior e_max on the paper's move stay within that
/// iteration's rounding floor at every h from 0.5 to 50 ms (`host-tests/tests/
/// step_accuracy.rs`, `ALLOWANCE`).
pub type EliminatedOf<T, M, const N: usize, const NU: usize> =
    Structured<T, <M as StructuredJacobian<T, N, NU>>::Factors, crate::model::Eliminated>;

/// [`EliminatedOf`] for `h ≥` [`CORRECT_BELOW_H`], without the correction linked
/// ([`EliminatedUncorrected`](crate::model::EliminatedUncorrected); the firmware's for
/// such a step size: `StructuredBdfUncorrected` of a model's scheme aliases).
pub type EliminatedUncorrectedOf<T, M, const N: usize, const NU: usize> = Structured<
    T,
    <M as StructuredJacobian<T, N, NU>>::Factors,
    crate::model::EliminatedUncorrected,
>;

impl<T: Real, F, S> Structured<T, F, S> {
    fn refresh<M, const N: usize, const NU: usize>(
        &mut self,
        step: &BdfStep<'_, T, M, N, NU>,
        xi: &SVector<T, N>,
        stats: &mut NewtonStats,
    ) -> Result<()>
    where
        M: StructuredJacobian<T, N, NU, Factors = F>,
    {
        stats.jacobian_evals += 1;
        stats.factorizations += 1;
        self.factors = step.model.factor(
            xi,
            &step.derivative(xi),
            &step.sample,
            step.alpha0 * step.inv_h,
            step.scale,
        );
        if self.factors.is_none() {
            return Err(Error::SingularJacobian {
                t: step.t,
                iterations: stats.iterations,
                residual: stats.residual_norm,
            });
        }
        Ok(())
    }

    /// One simplified-Newton correction of the closed-form step `xi`, at factors formed
    /// there (see the type's documentation). `NewtonStats` report one iteration and no
    /// norms (0: not measured — the correction is the rounding floor, which at small h is
    /// far above Newton's tolerance, and its two norms cost a seventh of the step on the
    /// host); a non-finite result is refused.
    fn correct<M, const N: usize, const NU: usize>(
        &mut self,
        step: &BdfStep<'_, T, M, N, NU>,
        mut xi: SVector<T, N>,
    ) -> Result<(SVector<T, N>, NewtonStats)>
    where
        M: StructuredJacobian<T, N, NU, Factors = F>,
    {
        let mut stats = NewtonStats::default();
        self.refresh(step, &xi, &mut stats)?;
        stats.residual_evals = 1;
        let mut d = -step.residual(&xi);
        if let Some(f) = &self.factors {
            M::solve(f, &mut d);
        }
        xi += d;
        ensure_finite(&xi, step.t, 1)?;
        stats.iterations = 1;
        stats.converged = true;
        Ok((xi, stats))
    }
}

impl<T: Real, M, S: StepStart, const N: usize, const NU: usize> BdfNewton<T, M, N, NU>
    for Structured<T, M::Factors, S>
where
    M: StructuredJacobian<T, N, NU>,
{
    const PREDICTS: bool = !(S::ELIMINATE && M::CLOSED_FORM);

    fn new(settings: &SolverSettings) -> Result<Self> {
        // The closed form (and its correction) reads none of Newton's settings.
        if !(S::ELIMINATE && M::CLOSED_FORM) {
            settings.newton.validate()?;
        }
        if settings.jacobian != JacobianMode::Exact {
            return Err(Error::InvalidSetting {
                name: "jacobian (structured Newton is exact only)",
                value: f64::NAN,
            });
        }
        // The correction makes the positions, velocities and inputs agree as the residual
        // rounds them before the index-3 step differentiates them; a model with no
        // differential unknown (the minimally extended cranes, whose closed form is their
        // exact solution at every node) has nothing to differentiate.
        let correct = settings.h < CORRECT_BELOW_H && M::DIFFERENTIAL > 0;
        if correct && S::ELIMINATE && M::CLOSED_FORM && !S::CORRECT {
            return Err(Error::InvalidSetting {
                name: "h (below CORRECT_BELOW_H the closed form is corrected: start Eliminated)",
                value: settings.h,
            });
        }
        Ok(Self {
            settings: settings.newton,
            factors: None,
            eta: 1.0,
            correct,
            scalar: PhantomData,
        })
    }

    fn forget(&mut self) {
        self.factors = None;
        self.eta = 1.0;
    }

    fn solve(
        &mut self,
        step: &BdfStep<'_, T, M, N, NU>,
        mut xi: SVector<T, N>,
    ) -> Result<(SVector<T, N>, NewtonStats)> {
        if S::ELIMINATE && M::CLOSED_FORM {
            // No iteration to fall back on (so none is linked): the closed form refuses
            // only where the elimination's pivots vanish (a slack rope: the iteration's
            // factors would be singular too) or where the rope would move by more than
            // 15 % of its length in one step — trajectories the models' checks and the
            // planner's limits refuse up front.
            let Some([increment]) = step.model.solve_step(&[step.sample], step) else {
                return Err(Error::SingularJacobian {
                    t: step.t,
                    iterations: 0,
                    residual: 0.0,
                });
            };
            let xi = step.anchor + increment;
            if S::CORRECT && self.correct {
                return self.correct(step, xi);
            }
            ensure_finite(&xi, step.t, 0)?;
            let stats = NewtonStats {
                converged: true,
                ..NewtonStats::default()
            };
            return Ok((xi, stats));
        }
        let mut stats = NewtonStats::default();
        self.refresh(step, &xi, &mut stats)?;
        // Whether the factors were formed at an iterate of this step's iteration (not
        // only at the prediction).
        let mut refactored = false;
        let mut contraction = Contraction::start(self.eta);
        let (rtol, atol) = (self.settings.rtol, self.settings.atol);
        for it in 1..=self.settings.max_iterations {
            stats.residual_evals += 1;
            let mut d = -step.residual(&xi);
            stats.residual_norm = max_abs(&d);
            if !stats.residual_norm.is_finite() {
                return Err(Error::NonFinite {
                    t: step.t,
                    iterations: stats.iterations,
                });
            }
            if let Some(f) = &self.factors {
                M::solve(f, &mut d);
            }
            xi += d;
            let norm = weighted_norm(&d, &xi, rtol, atol);
            stats.iterations = it;
            stats.increment_norm = norm;
            if !norm.is_finite() {
                return Err(Error::NonFinite {
                    t: step.t,
                    iterations: it,
                });
            }
            match contraction.judge(it, norm, refactored, 0.0, &self.settings) {
                Verdict::Converged => stats.converged = true,
                Verdict::AtRoundingFloor => {
                    stats.converged = true;
                    stats.at_rounding_floor = true;
                }
                Verdict::Refresh => {
                    // Factors from the prediction that do not contract: refactor here.
                    self.refresh(step, &xi, &mut stats)?;
                    refactored = true;
                }
                Verdict::Continue => {}
            }
            if stats.converged {
                self.eta = contraction.eta();
                return Ok((xi, stats));
            }
        }
        Err(Error::NewtonNotConverged {
            t: step.t,
            iterations: stats.iterations,
            residual: stats.residual_norm,
            increment: stats.increment_norm,
        })
    }
}

/// Multiplies row i of `m` by `scale[i]`.
pub(crate) fn scale_rows<T: Real, const R: usize, const C: usize>(
    m: &mut SMatrix<T, R, C>,
    scale: &SVector<T, R>,
) {
    for (mut row, s) in m.row_iter_mut().zip(scale.iter()) {
        row *= *s;
    }
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Consistency: Σ α_i = 0 and Σ α_i·(−i) = 1 (exact for constants and lines).
    #[test]
    fn coefficients_are_consistent() {
        for row in ALPHA {
            let sum: f64 = row.iter().sum();
            let first: f64 = row.iter().enumerate().map(|(i, a)| -(i as f64) * a).sum();
            assert!(sum.abs() < 1e-14 && (first - 1.0).abs() < 1e-14, "{row:?}");
        }
    }
}
