//! The study engine: one scene (with overrides) → one run, measured the way the
//! paper measures: e_max of Eq. 29 against the exact reference (the crane's flat
//! inverse; the mass-on-car's Eq. 37/38), Newton's statistics, and host time per step.
//!
//! Timing is taken on separate repeats that only step (no recording), and the median
//! is reported; it is a measurement for the results, never asserted by a test.

use std::time::Instant;

use nalgebra::SVector;
use scene::{JacobianSpec, ModelSpec, ScalarSpec, Scene, SceneError, SchemeSpec};
use solver_core::models::crane_proj::CraneProj;
use solver_core::models::crane_subs::CraneSubs;
use solver_core::models::mass_on_car::MassOnCar;
use solver_core::reference::dopri5::Dopri5Settings;
use solver_core::reference::flat_crane::flat_inverse;
use solver_core::reference::mass_on_car::MassOnCarReference;
use solver_core::scalar::c;
use solver_core::trajectory::PointToPoint;
use solver_core::{Bdf, DaeModel, Error, Radau, Real};

use crate::run::{run, Scheme, Trace};

/// How a configuration ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Ran to the end with e_max at or below the threshold.
    Ok,
    /// Ran to the end, e_max above the threshold.
    Inaccurate,
    /// Newton did not converge or its matrix was singular.
    NewtonFailure,
    /// A residual or solution became NaN or infinite (caught as a typed error).
    NonFinite,
    /// The scene was refused before running (invalid or physically impossible).
    Refused,
    /// The run panicked — a bug: solver-core promises typed errors. Tests assert none.
    Panic,
}

impl Outcome {
    /// The name used in CSV files and tables.
    pub fn as_str(self) -> &'static str {
        match self {
            Outcome::Ok => "ok",
            Outcome::Inaccurate => "inaccurate",
            Outcome::NewtonFailure => "newton-failure",
            Outcome::NonFinite => "non-finite",
            Outcome::Refused => "refused",
            Outcome::Panic => "panic",
        }
    }
}

/// Everything measured about one run.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// Sample times, s.
    pub t: Vec<f64>,
    /// Computed inputs per sample.
    pub u: Vec<Vec<f64>>,
    /// Reference inputs per sample.
    pub u_ref: Vec<Vec<f64>>,
    /// `max_i |u_i − u_ref,i|` per sample.
    pub error: Vec<f64>,
    /// Eq. 29 over the whole run.
    pub e_global: f64,
    /// Eq. 29 over the interior of the move ([`Scene::interior`]).
    pub e_interior: f64,
    /// Steps taken.
    pub steps: usize,
    /// Mean Newton iterations per step.
    pub iterations_mean: f64,
    /// Most Newton iterations in one step.
    pub iterations_max: u32,
    /// Residual evaluations per step.
    pub residual_evals_per_step: f64,
    /// Jacobians formed in the whole run.
    pub jacobian_evals: u64,
    /// Steps that converged at the rounding floor.
    pub floor_steps: usize,
    /// Median host time per step, ns (NaN when not timed).
    pub ns_per_step: f64,
    /// How the run ended.
    pub outcome: Outcome,
    /// The error that ended it early (or refused it).
    pub failure: Option<String>,
}

impl RunResult {
    fn refused(e: SceneError) -> Self {
        Self::not_run(e.to_string())
    }

    /// A configuration that was refused before running, with the reason.
    pub fn not_run(reason: impl Into<String>) -> Self {
        Self {
            t: vec![],
            u: vec![],
            u_ref: vec![],
            error: vec![],
            e_global: f64::NAN,
            e_interior: f64::NAN,
            steps: 0,
            iterations_mean: f64::NAN,
            iterations_max: 0,
            residual_evals_per_step: f64::NAN,
            jacobian_evals: 0,
            floor_steps: 0,
            ns_per_step: f64::NAN,
            outcome: Outcome::Refused,
            failure: Some(reason.into()),
        }
    }
}

/// The e_max above which a run counts as inaccurate, by model: 1 mm/s for the crane's
/// velocity set points, 0.01 N for the mass-on-car's force.
pub fn default_threshold(scene: &Scene) -> f64 {
    match scene.model {
        ModelSpec::MassOnCar(_) => 1e-2,
        _ => 1e-3,
    }
}

/// Runs a scene, measures it against its reference, and times `repeats` further runs.
/// A panic (which solver-core promises never to do) is caught and reported as
/// [`Outcome::Panic`] instead of ending the study.
pub fn run_scene(scene: &Scene, repeats: usize, threshold: f64) -> RunResult {
    std::panic::catch_unwind(|| run_scene_unguarded(scene, repeats, threshold)).unwrap_or_else(
        |_| {
            let mut r = RunResult::refused(SceneError {
                field: String::new(),
                reason: "panicked".into(),
            });
            r.outcome = Outcome::Panic;
            r
        },
    )
}

fn run_scene_unguarded(scene: &Scene, repeats: usize, threshold: f64) -> RunResult {
    if let Err(e) = scene.validate() {
        return RunResult::refused(e);
    }
    let result = match scene.solver.scalar {
        ScalarSpec::F64 => dispatch::<f64>(scene, repeats),
        ScalarSpec::F32 => dispatch::<f32>(scene, repeats),
    };
    match result {
        Ok(mut r) => {
            if r.outcome == Outcome::Ok && (r.e_global.is_nan() || r.e_global > threshold) {
                r.outcome = Outcome::Inaccurate;
            }
            r
        }
        Err(e) => RunResult::refused(e),
    }
}

fn dispatch<T: Real>(scene: &Scene, repeats: usize) -> Result<RunResult, SceneError> {
    let err = |e: Error| scene.field_of(e);
    match &scene.model {
        ModelSpec::CraneSubs(c) => {
            let model = CraneSubs::new(c.params(), trajectory::<T, 2>(scene)?).map_err(err)?;
            measure::<T, _, 7, 2, 21>(&model, scene, repeats)
        }
        ModelSpec::CraneProj(c) => {
            let model = CraneProj::new(c.params(), trajectory::<T, 2>(scene)?).map_err(err)?;
            measure::<T, _, 8, 2, 24>(&model, scene, repeats)
        }
        ModelSpec::MassOnCar(m) => {
            let model = MassOnCar::new(m.params(), trajectory::<T, 1>(scene)?).map_err(err)?;
            measure::<T, _, 5, 1, 15>(&model, scene, repeats)
        }
    }
}

/// The scene's trajectory in the scalar `T`.
fn trajectory<T: Real, const NZ: usize>(scene: &Scene) -> Result<PointToPoint<T, NZ>, SceneError> {
    let t = &scene.trajectory;
    for (field, v) in [("trajectory.start", &t.start), ("trajectory.end", &t.end)] {
        if v.len() != NZ {
            return Err(SceneError {
                field: field.into(),
                reason: format!("needs {NZ} values, has {}", v.len()),
            });
        }
    }
    PointToPoint::new(
        SVector::<T, NZ>::from_iterator(t.start.iter().map(|v| c::<T>(*v))),
        SVector::<T, NZ>::from_iterator(t.end.iter().map(|v| c::<T>(*v))),
        c(t.t_start),
        c(t.duration),
        t.smoothness,
    )
    .map_err(|e| scene.field_of(e))
}

fn scheme(scene: &Scene) -> Scheme {
    match scene.solver.scheme {
        SchemeSpec::Bdf => Scheme::Bdf(scene.solver.k),
        SchemeSpec::Radau => Scheme::Radau,
    }
}

fn measure<T, M, const N: usize, const NU: usize, const S: usize>(
    model: &M,
    scene: &Scene,
    repeats: usize,
) -> Result<RunResult, SceneError>
where
    T: Real,
    M: DaeModel<T, N, NU>,
{
    let settings = scene.settings();
    let t_end = scene.trajectory.t_end;
    let trace = run::<T, M, N, NU, S>(model, scheme(scene), &settings, 0.0, t_end)
        .map_err(|e| scene.field_of(e))?;
    let u_ref = reference_inputs(scene, &trace.t)?;
    let mut result = summarise(scene, &trace, u_ref);
    if repeats > 0 && trace.failure.is_none() {
        result.ns_per_step = time_per_step::<T, M, N, NU, S>(model, scene, trace.steps(), repeats);
    }
    Ok(result)
}

/// The exact inputs at the sample times, in f64.
fn reference_inputs(scene: &Scene, t: &[f64]) -> Result<Vec<Vec<f64>>, SceneError> {
    match &scene.model {
        ModelSpec::CraneSubs(c) | ModelSpec::CraneProj(c) => {
            let (p, z) = (c.params(), scene.trajectory2()?);
            Ok(t.iter()
                .map(|&t| flat_inverse(&p, &z, t).u.to_vec())
                .collect())
        }
        ModelSpec::MassOnCar(m) => {
            let mut r = MassOnCarReference::new(
                m.params(),
                scene.trajectory1()?,
                0.0,
                Dopri5Settings::default(),
            )
            .map_err(|e| scene.field_of(e))?;
            t.iter()
                .map(|&t| {
                    r.advance_to(t)
                        .map(|s| vec![s.f])
                        .map_err(|e| scene.field_of(e))
                })
                .collect()
        }
    }
}

fn summarise<const N: usize, const NU: usize>(
    scene: &Scene,
    trace: &Trace<N, NU>,
    u_ref: Vec<Vec<f64>>,
) -> RunResult {
    let u: Vec<Vec<f64>> = trace
        .u
        .iter()
        .map(|u| u.iter().copied().collect())
        .collect();
    let error: Vec<f64> = u
        .iter()
        .zip(&u_ref)
        .map(|(a, b)| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        })
        .collect();
    let (a, b) = scene.interior();
    let pick = |inside: bool| {
        trace
            .t
            .iter()
            .zip(&error)
            .filter(|(t, _)| !inside || (a..=b).contains(*t))
            .map(|(_, e)| *e)
            .fold(0.0, f64::max)
    };
    let steps = trace.steps();
    let stats = trace.stats.get(1..).unwrap_or(&[]);
    let n = stats.len().max(1) as f64;
    let outcome = match trace.failure {
        None => Outcome::Ok,
        Some(Error::NonFinite { .. }) => Outcome::NonFinite,
        Some(_) => Outcome::NewtonFailure,
    };
    // A non-finite value in what was returned would be a bug; make it visible.
    let outcome = if u.iter().flatten().any(|v| !v.is_finite()) {
        Outcome::NonFinite
    } else {
        outcome
    };
    RunResult {
        e_global: pick(false),
        e_interior: pick(true),
        steps,
        iterations_mean: stats.iter().map(|s| f64::from(s.iterations)).sum::<f64>() / n,
        iterations_max: stats.iter().map(|s| s.iterations).max().unwrap_or(0),
        residual_evals_per_step: stats
            .iter()
            .map(|s| f64::from(s.residual_evals))
            .sum::<f64>()
            / n,
        jacobian_evals: stats.iter().map(|s| u64::from(s.jacobian_evals)).sum(),
        floor_steps: stats.iter().filter(|s| s.at_rounding_floor).count(),
        ns_per_step: f64::NAN,
        outcome,
        failure: trace.failure.map(|e| e.to_string()),
        t: trace.t.clone(),
        u,
        u_ref,
        error,
    }
}

/// Median over `repeats` runs of the host time per step (stepping only, nothing recorded).
fn time_per_step<T, M, const N: usize, const NU: usize, const S: usize>(
    model: &M,
    scene: &Scene,
    steps: usize,
    repeats: usize,
) -> f64
where
    T: Real,
    M: DaeModel<T, N, NU>,
{
    let settings = scene.settings();
    let mut samples: Vec<f64> = (0..repeats)
        .filter_map(|_| {
            let start = Instant::now();
            let ok = match scheme(scene) {
                Scheme::Bdf(k) => Bdf::<T, M, N, NU>::new(model, &settings, k, T::zero())
                    .is_ok_and(|mut b| {
                        (0..steps).all(|_| std::hint::black_box(b.step(model)).is_ok())
                    }),
                Scheme::Radau => Radau::<T, M, N, NU, S>::new(model, &settings, T::zero())
                    .is_ok_and(|mut r| {
                        (0..steps).all(|_| std::hint::black_box(r.step(model)).is_ok())
                    }),
            };
            ok.then(|| start.elapsed().as_nanos() as f64 / steps.max(1) as f64)
        })
        .collect();
    samples.sort_by(f64::total_cmp);
    samples.get(samples.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Whether the scene's Jacobian mode is Broyden with this re-initialisation period.
pub fn jacobian_label(scene: &Scene) -> String {
    match (scene.solver.jacobian, scene.solver.reinit_every) {
        (JacobianSpec::Fd, _) => "J".into(),
        (JacobianSpec::Exact, _) => "exact".into(),
        (JacobianSpec::Broyden, None) => "Jt".into(),
        (JacobianSpec::Broyden, Some(n)) => format!("Jt{n}"),
    }
}

/// `BDF4`, `Radau`, …
pub fn scheme_label(scene: &Scene) -> String {
    match scene.solver.scheme {
        SchemeSpec::Bdf => format!("BDF{}", scene.solver.k),
        SchemeSpec::Radau => "Radau".into(),
    }
}
