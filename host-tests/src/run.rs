//! Whole-trajectory runs of a scheme on a model, and the errors the paper measures.

use nalgebra::SVector;
use solver_core::models::crane::CraneParams;
use solver_core::newton::Newton;
use solver_core::reference::flat_crane::flat_inverse;
use solver_core::scalar::{c, to_f64};
use solver_core::schemes::bdf::BdfNewton;
use solver_core::schemes::radau::{RadauNewton, StageSolver};
use solver_core::trajectory::Trajectory;
use solver_core::{Bdf, DaeModel, Error, JacobianMode, NewtonStats, Radau, Real, SolverSettings};

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

/// Which integrator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheme {
    /// BDF with k steps (k = 1: implicit Euler).
    Bdf(usize),
    /// 3-stage Radau IIA.
    Radau,
}

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
/// `S` is Radau's stage-system size, `3 * N`.
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
    match scheme {
        Scheme::Bdf(k) => run_bdf::<T, M, N, NU, Newton<T, N>>(model, k, settings, t0, t_end),
        Scheme::Radau => {
            run_radau::<T, M, N, NU, S, StageSolver<T, N, S>>(model, settings, t0, t_end)
        }
    }
}

/// [`run`] with BDF k and the Newton strategy `J` (the firmware's structured one, say).
pub fn run_bdf<T, M, const N: usize, const NU: usize, J>(
    model: &M,
    k: usize,
    settings: &SolverSettings,
    t0: f64,
    t_end: f64,
) -> Result<Trace<N, NU>, Error>
where
    T: Real,
    M: DaeModel<T, N, NU>,
    J: BdfNewton<T, M, N, NU>,
{
    let (mut trace, steps) = start(model, settings, t0, t_end)?;
    let mut bdf = Bdf::<T, M, N, NU, J>::new(model, settings, k, c(t0))?;
    for _ in 0..steps {
        if !record(&mut trace, bdf.step(model)) {
            break;
        }
    }
    Ok(trace)
}

/// The trace of the rest state at `t0`, and the number of steps to `t_end`.
fn start<T: Real, M: DaeModel<T, N, NU>, const N: usize, const NU: usize>(
    model: &M,
    settings: &SolverSettings,
    t0: f64,
    t_end: f64,
) -> Result<(Trace<N, NU>, usize), Error> {
    let steps = ((t_end - t0) / settings.h).round() as usize;
    let x0 = model.rest_state(c(t0))?;
    Ok((
        Trace {
            t: vec![t0],
            x: vec![x0.map(to_f64)],
            u: vec![M::inputs(&x0).map(to_f64)],
            stats: vec![NewtonStats::default()],
            failure: None,
        },
        steps,
    ))
}

/// Appends a step's result to the trace, or its error; `false` on error.
fn record<T: Real, const N: usize, const NU: usize>(
    trace: &mut Trace<N, NU>,
    result: Result<solver_core::StepReport<T, N, NU>, Error>,
) -> bool {
    match result {
        Ok(r) => {
            trace.t.push(to_f64(r.t));
            trace.x.push(r.x.map(to_f64));
            trace.u.push(r.u.map(to_f64));
            trace.stats.push(r.stats);
            true
        }
        Err(e) => {
            trace.failure = Some(e);
            false
        }
    }
}

/// [`run`] with Radau IIA and the Newton strategy `J` (the firmware's structured RADAU5,
/// say; [`run`] takes the one the settings' Jacobian mode names).
pub fn run_radau<T, M, const N: usize, const NU: usize, const S: usize, J>(
    model: &M,
    settings: &SolverSettings,
    t0: f64,
    t_end: f64,
) -> Result<Trace<N, NU>, Error>
where
    T: Real,
    M: DaeModel<T, N, NU>,
    J: RadauNewton<T, M, N, NU, S>,
{
    let (mut trace, steps) = start(model, settings, t0, t_end)?;
    let mut radau = Radau::<T, M, N, NU, S, J>::new(model, settings, c(t0))?;
    for _ in 0..steps {
        if !record(&mut trace, radau.step(model)) {
            break;
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
