//! What a model is: the residual `F(x, ẋ, t) = 0` of Eq. 12 and a little metadata.
//!
//! A new model is one small implementation of [`DaeModel`]: the residual, its two
//! partial derivatives (the exact Jacobian), which rows are algebraic (they get the
//! scaling ρ of Sec. 3.1.1), where the inputs `u` sit in `x`, the consistent state
//! at rest, and the output `z`. The schemes never look inside a model.

use nalgebra::{SMatrix, SVector};

use crate::error::Result;
use crate::scalar::Real;

/// The partial derivatives `∂F/∂x` and `∂F/∂ẋ` of a model's residual.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Partials<T: Real, const N: usize> {
    /// `∂F/∂x`.
    pub dx: SMatrix<T, N, N>,
    /// `∂F/∂ẋ` (singular for a DAE).
    pub dxdot: SMatrix<T, N, N>,
}

/// A model driven by a desired output `Z` (the servo-constraints' right-hand side).
pub trait Driven {
    /// The desired output's type.
    type Trajectory;

    /// The desired output.
    fn trajectory(&self) -> &Self::Trajectory;

    /// The desired output, to change in place (a move appended, a stop) while the
    /// model runs. The caller is responsible for what it changes: it must check a new
    /// segment (the controller checks it against the workspace, the rope tension and
    /// the drive limits), and only change what has not been stepped yet.
    fn trajectory_mut(&mut self) -> &mut Self::Trajectory;
}

/// A DAE `F(x, ẋ, t) = 0` (Eq. 12) with `N` unknowns, `NU` of them inputs.
///
/// `x` holds every unknown: positions, velocities, reaction forces and the inputs.
pub trait DaeModel<T: Real, const N: usize, const NU: usize> {
    /// Names of the unknowns, in order (for reports and CSV headers).
    const UNKNOWNS: [&'static str; N];
    /// `true` for the algebraic rows of `F` (no `ẋ` in them): scaled by `ρ = h^-p`.
    const ALGEBRAIC: [bool; N];
    /// How many unknowns, from the first, are differential: their derivative `ẋ_j` enters
    /// `F` (nonzero columns of `∂F/∂ẋ`). The ones after them (λ, the inputs) are
    /// algebraic unknowns, whose `ẋ_j` no row reads, so a scheme may leave those
    /// derivatives unformed where only `F` reads them (BDF's closed-form start skips
    /// their share of Eq. 16's history sum). Default: every unknown.
    const DIFFERENTIAL: usize = N;
    /// Position in `x` of each input `u_i`.
    const INPUTS: [usize; NU];
    /// Smallest trajectory smoothness n for which the inputs are continuous.
    const MIN_SMOOTHNESS: usize;

    /// Everything the residual needs that depends on `t` only (the desired output
    /// and its derivatives). Computed once per stage, reused by every Newton iteration.
    type Sample: Copy;

    /// Evaluates the time-dependent part at `t`.
    fn sample(&self, t: T) -> Self::Sample;

    /// The residual `F(x, ẋ, t)`.
    fn residual(&self, x: &SVector<T, N>, xdot: &SVector<T, N>, s: &Self::Sample) -> SVector<T, N>;

    /// The exact partial derivatives of the residual.
    fn partials(&self, x: &SVector<T, N>, xdot: &SVector<T, N>, s: &Self::Sample)
        -> Partials<T, N>;

    /// The consistent state at rest at time `t` (`ẋ = 0`), where the trajectory rests.
    fn rest_state(&self, t: T) -> Result<SVector<T, N>>;

    /// The system output `z` (Eq. 3) for state `x`.
    fn output(&self, x: &SVector<T, N>, s: &Self::Sample) -> SVector<T, NU>;

    /// The inputs `u` picked out of `x`.
    fn inputs(x: &SVector<T, N>) -> SVector<T, NU> {
        SVector::<T, NU>::from_fn(|i, _| {
            Self::INPUTS
                .get(i)
                .and_then(|&j| x.get(j))
                .copied()
                .unwrap_or_else(T::zero)
        })
    }
}

/// A model whose BDF Newton matrix `A = S·(∂F/∂x + c·∂F/∂ẋ)` (`c = α₀/h`, `S` the row
/// scaling ρ of Sec. 3.1.1) has a fixed sparsity pattern that it eliminates by hand:
/// a static pivot order, no pivot search, no fill-in, only the entries that change
/// computed. Used by [`Structured`](crate::schemes::bdf::Structured), the BDF Newton
/// strategy the firmware links, and by RADAU5's
/// [`StructuredStages`](crate::schemes::radau::transformed::StructuredStages) for its real and complex
/// stage systems; models without it keep the dense LUs.
///
/// The factors must solve the same system as the dense LU of `S·(∂F/∂x + c·∂F/∂ẋ)`
/// built from [`DaeModel::partials`] (each implementation's tests check it).
pub trait StructuredJacobian<T: Real, const N: usize, const NU: usize>: DaeModel<T, N, NU> {
    /// What the elimination keeps of `A`: reciprocal pivots and multipliers.
    type Factors: Copy + core::fmt::Debug;

    /// Factors `A` at `(x, ẋ)` and the sample `s`; `None` when a pivot is zero or
    /// not finite (`A` singular).
    fn factor(
        &self,
        x: &SVector<T, N>,
        xdot: &SVector<T, N>,
        s: &Self::Sample,
        c: T,
        scale: &SVector<T, N>,
    ) -> Option<Self::Factors>;

    /// Solves `A η = r` in place with the factors of [`StructuredJacobian::factor`].
    fn solve(f: &Self::Factors, r: &mut SVector<T, N>);

    /// Solves the complex system `(∂F/∂x + (c + i b) ∂F/∂ẋ)(η_re + i η_im) = r_re + i r_im`
    /// in place (rows scaled as in `factor`), `f` the factors for the real part `c` of
    /// the shift and `b` its imaginary part — RADAU5's complex stage system
    /// (`schemes::radau5`). Required: a model implements this trait only where its
    /// elimination's pivots do not depend on the shift, so that the real factors serve
    /// the complex system too (checked by multiplying the system back in its tests).
    fn solve_complex(f: &Self::Factors, b: T, re: &mut SVector<T, N>, im: &mut SVector<T, N>);

    /// The discrete step itself, solved in closed form where the model can: the
    /// increments `X_k − x_{n−1}` of every unknown at a step's `K` nodes such that
    /// `F(X_k, Ẋ_k, t_k) = 0` (Eq. 12) at every node, `Ẋ` given by the scheme's
    /// difference formula `d` (BDF's Eq. 16, Radau IIA's Eq. 13) and `samples` the
    /// trajectory at the nodes; `None` by default (the strategies then keep their
    /// predictors), and wherever the model cannot (a zero pivot, a slack rope: a
    /// strategy starting from the closed form then refuses the step,
    /// [`Error::SingularJacobian`](crate::Error::SingularJacobian)).
    ///
    /// Why here: a Newton matrix triangular in a static order (this trait's premise) is
    /// the Jacobian of a system that is itself triangular in that order. Where each
    /// diagonal equation can be solved for its unknown in closed form, the whole step is
    /// forward substitution: for the flat cranes the algebraic rows give λ, the
    /// horizontal positions and the rope length at every node from the trajectory alone,
    /// and the differential rows, linear through `d`, then give velocities and inputs.
    ///
    /// Why increments: the positions are metres (an ulp of 1.8e-15 at 15 m) while the
    /// first steps of a move change them by far less; formed as differences against
    /// `x_{n−1}` (`(x_C,d − x_{n−1}) − offset`) those motions keep their relative
    /// precision, and the index-3 step does not amplify an absolute rounding of the
    /// position into the inputs (measured on the paper's move, BDF4's closed form without
    /// correction: absolute values raised e_max at 0.5 ms by 1.8e-5 relative and the
    /// interior error at 2 ms by 9 %, 2.00e-9 against 1.84e-9).
    fn solve_step<const K: usize, D: DifferenceFormula<T, K>>(
        &self,
        samples: &[Self::Sample; K],
        d: &D,
    ) -> Option<[SVector<T, N>; K]> {
        let _ = (samples, d);
        None
    }

    /// `true` where [`StructuredJacobian::solve_step`] is implemented: a strategy that
    /// starts from it then does not form the scheme's predictor at all (for BDF4 on the
    /// host about 80 instructions of a step).
    const CLOSED_FORM: bool = false;
}

/// A scheme's difference formula as a closed-form step
/// ([`StructuredJacobian::solve_step`]) needs it: the derivative of one unknown at the
/// step's `K` nodes from its increments there, everything else (the history, h) held by
/// the scheme. Linear: BDF's Eq. 16 (`K = 1`), Radau IIA's Eq. 13 solved for the stage
/// derivatives, `X' = (hA)⁻¹ Z` (`K = 3`).
pub trait DifferenceFormula<T: Real, const K: usize> {
    /// The value of unknown `j` the step starts from, `x_{n−1, j}`.
    fn anchor(&self, j: usize) -> T;
    /// `Ẋ_j` at the `K` nodes from the increments `X_j − x_{n−1, j}` there.
    fn derivative(&self, j: usize, increments: [T; K]) -> [T; K];
}

/// Where a structured Newton strategy starts a step: a type, so that a firmware links
/// one way.
pub trait StepStart {
    /// `true`: from the model's closed-form step ([`StructuredJacobian::solve_step`])
    /// where it has one, the scheme's predictor otherwise.
    const ELIMINATE: bool;
    /// Whether BDF may follow a closed-form start with its correction (below
    /// [`CORRECT_BELOW_H`](crate::schemes::bdf::CORRECT_BELOW_H)); RADAU5 never corrects.
    const CORRECT: bool;
}

/// Start from the scheme's predictor (BDF's extrapolation of its history, RADAU5's of
/// the last collocation polynomial).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Predicted;

impl StepStart for Predicted {
    const ELIMINATE: bool = false;
    const CORRECT: bool = false;
}

/// Start from the model's closed-form step where it has one; BDF corrects it below
/// [`CORRECT_BELOW_H`](crate::schemes::bdf::CORRECT_BELOW_H).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Eliminated;

impl StepStart for Eliminated {
    const ELIMINATE: bool = true;
    const CORRECT: bool = true;
}

/// [`Eliminated`] for step sizes from
/// [`CORRECT_BELOW_H`](crate::schemes::bdf::CORRECT_BELOW_H) on, where it is not
/// corrected either: the same steps, bit for bit, and BDF's correction is not linked (a
/// firmware's scene names its step size at build time). Where the model has a closed
/// form, BDF refuses a smaller `h` ([`Error::InvalidSetting`](crate::Error::InvalidSetting))
/// rather than step it uncorrected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EliminatedUncorrected;

impl StepStart for EliminatedUncorrected {
    const ELIMINATE: bool = true;
    const CORRECT: bool = false;
}
