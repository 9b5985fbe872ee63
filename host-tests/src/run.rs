//! Whole-trajectory runs of a scheme on a model, and the errors the paper measures.

use nalgebra::SVector;
use solver_core::models::crane::CraneParams;
use solver_core::reference::flat_crane::flat_inverse;
use solver_core::scalar::{c, to_f64};
use solver_core::schemes::Chosen;
use solver_core::trajectory::Trajectory;
use solver_core::{DaeModel, Error, Integrator, JacobianMode, NewtonStats, Real, SolverSettings};

/// The paper's Jacobian modes (J, J̃, J̃₁₀, J̃₅₀) and the exact one, with short labels.
pub const JACOBIAN_MODES: [(&str, JacobianMode); 5] = [
    ("J", JacobianMode::FiniteDifference),
    ("Jt", JacobianMode::Broyden { reinit_every: None }),
    (
        "Jt10",
        JacobianMode::Broyden {
            reinit_every: Some(10),
        },
    ),
    (
        "Jt50",
        JacobianMode::Broyden {
            reinit_every: Some(50),
        },
    ),
    ("exact", JacobianMode::Exact),
];

pub use solver_core::Scheme;

/// Everything a run produced, in f64, starting with the rest state at `t0`.
#[derive(Debug, Clone)]
pub struct Trace<const N: usize, const NU: usize> {
    /// Sample times.
    pub t: Vec<f64>,
    /// States.
    pub x: Vec<SVector<f64, N>>,
    /// Inputs.
    pub u: Vec<SVector<f64, NU>>,
    /// Newton statistics per step (the rest state at `t0` has none: default).
    pub stats: Vec<NewtonStats>,
    /// The error that ended the run early, if any.
    pub failure: Option<Error>,
}

impl<const N: usize, const NU: usize> Trace<N, NU> {
    /// Steps taken (samples after the initial one).
    pub fn steps(&self) -> usize {
        self.t.len().saturating_sub(1)
    }

    /// Total residual evaluations of all steps.
    pub fn residual_evals(&self) -> u64 {
        self.stats.iter().map(|s| u64::from(s.residual_evals)).sum()
    }

    /// Total Newton iterations of all steps.
    pub fn iterations(&self) -> u64 {
        self.stats.iter().map(|s| u64::from(s.iterations)).sum()
    }
}

/// Integrates `model` from rest at `t0` to `t_end` with fixed steps; stops at the first error.
/// `S` is Radau's stage-system size, `3 * N`; the Newton strategy is the one the
/// settings' Jacobian mode names ([`Chosen`]).
pub fn run<T, M, const N: usize, const NU: usize, const S: usize>(
    model: &M,
    scheme: Scheme,
    settings: &SolverSettings,
    t0: f64,
    t_end: f64,
) -> Result<Trace<N, NU>, Error>
where
    T: Real,
    M: DaeModel<T, N, NU>,
{
    let integrator = Chosen::<T, M, N, NU, S>::new(model, scheme, settings, c(t0))?;
    run_with(model, integrator, settings, t_end)
}

/// [`run`] with `integrator` (any scheme and Newton strategy: the firmware's structured
/// one, say), from where it stands to `t_end`.
pub fn run_with<T, M, I, const N: usize, const NU: usize>(
    model: &M,
    mut integrator: I,
    settings: &SolverSettings,
    t_end: f64,
) -> Result<Trace<N, NU>, Error>
where
    T: Real,
    M: DaeModel<T, N, NU>,
    I: Integrator<T, M, N, NU>,
{
    let t0 = to_f64(integrator.time());
    let steps = ((t_end - t0) / settings.h).round() as usize;
    let x0 = integrator.state();
    let mut trace = Trace {
        t: vec![t0],
        x: vec![x0.map(to_f64)],
        u: vec![M::inputs(&x0).map(to_f64)],
        stats: vec![NewtonStats::default()],
        failure: None,
    };
    for _ in 0..steps {
        match integrator.step(model) {
            Ok(r) => {
                trace.t.push(to_f64(r.t));
                trace.x.push(r.x.map(to_f64));
                trace.u.push(r.u.map(to_f64));
                trace.stats.push(r.stats);
            }
            Err(e) => {
                trace.failure = Some(e);
                break;
            }
        }
    }
    Ok(trace)
}

/// Eq. 29 over the whole run and over an interior window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Emax {
    /// `max_t max_i |u_d,i − u_flat,i|` over every sample.
    pub global: f64,
    /// The same over samples with `t ∈ [a, b]`.
    pub interior: f64,
}

/// Per-sample input error `max_i |u_i − u_flat,i(t)|` of a crane run.
pub fn crane_input_errors<Z: Trajectory<f64, 2>, const N: usize>(
    p: &CraneParams,
    z: &Z,
    trace: &Trace<N, 2>,
) -> Vec<f64> {
    trace
        .t
        .iter()
        .zip(&trace.u)
        .map(|(&t, u)| {
            let flat = flat_inverse(p, z, t);
            (u - SVector::from(flat.u)).abs().max()
        })
        .collect()
}

/// Eq. 29 globally and over `[a, b]`.
pub fn emax(t: &[f64], errors: &[f64], a: f64, b: f64) -> Emax {
    let pick = |inside: bool| {
        t.iter()
            .zip(errors)
            .filter(|(&t, _)| !inside || (a..=b).contains(&t))
            .map(|(_, e)| *e)
            .fold(0.0, f64::max)
    };
    Emax {
        global: pick(false),
        interior: pick(true),
    }
}
