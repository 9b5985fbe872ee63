//! The study engine: one scene (with overrides) → one run, measured the way the
//! paper measures: e_max of Eq. 29 against the exact reference (the crane's flat
//! inverse; the mass-on-car's Eq. 37/38), Newton's statistics, and host time per step.
//!
//! Timing is taken on separate repeats that only step (no recording), and the median
//! is reported; it is a measurement for the results, never asserted by a test.

use std::time::Instant;

use scene::dispatch::{scheme, Exact, ModelVisitor};
use scene::{JacobianSpec, NewtonSpec, ScalarSpec, Scene, SceneError, SchemeSpec};
use solver_core::scalar::to_f64;
use solver_core::schemes::Chosen;
use solver_core::{DaeModel, Error, Integrator, Real};

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

/// Everything measured about one run. Nothing here grows with the run's length: the
/// samples go to an [`Observer`] as they are computed (a run at h = 1e-9 has 10¹⁰).
#[derive(Debug, Clone)]
pub struct RunResult {
    /// Eq. 29 over the whole run; NaN (an empty cell) unless the run reached `t_end`:
    /// the error of the part that ran is not the run's e_max.
    pub e_global: f64,
    /// Eq. 29 over the interior of the move ([`Scene::interior`]); NaN unless completed.
    pub e_interior: f64,
    /// Eq. 29 over the samples that were computed (equals `e_global` when completed).
    pub e_partial: f64,
    /// Time of the last computed sample, s.
    pub t_reached: f64,
    /// Where the run should have ended, s.
    pub t_end: f64,
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
        Self::not_run(readable_numbers(&e.to_string()))
    }

    /// A configuration that was refused before running, with the reason.
    pub fn not_run(reason: impl Into<String>) -> Self {
        Self {
            e_global: f64::NAN,
            e_interior: f64::NAN,
            e_partial: f64::NAN,
            t_reached: f64::NAN,
            t_end: f64::NAN,
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

    /// Whether the run stopped after some steps but before `t_end`.
    pub fn is_partial(&self) -> bool {
        self.steps > 0 && self.e_global.is_nan() && self.outcome != Outcome::Refused
    }

    /// The failure, and for a run that stopped part-way how far it got and the error
    /// of that part — never presented as the run's e_max.
    pub fn failure_text(&self) -> String {
        let failure = self.failure.clone().unwrap_or_default();
        if self.is_partial() {
            format!(
                "{failure} (partial run: stopped at t = {} s of {} s after {} steps; e_max over that part {:.4e})",
                self.t_reached, self.t_end, self.steps, self.e_partial
            )
        } else {
            failure
        }
    }
}

/// One computed sample, handed to an [`Observer`] as the run goes.
#[derive(Debug, Clone, Copy)]
pub struct Sample<'a> {
    /// Time, s.
    pub t: f64,
    /// Computed inputs.
    pub u: &'a [f64],
    /// Reference inputs.
    pub u_ref: &'a [f64],
    /// `max_i |u_i − u_ref,i|`.
    pub error: f64,
}

/// What a run does with its samples and its progress; by default nothing, so a run
/// keeps no memory proportional to its length.
pub trait Observer {
    /// One sample (the rest state at t = 0 first). An error stops the run.
    fn sample(&mut self, _sample: &Sample<'_>) -> Result<(), String> {
        Ok(())
    }
    /// `done` of `total` steps taken.
    fn progress(&mut self, _done: usize, _total: usize) {}
}

/// Keeps nothing.
impl Observer for () {}

/// The whole time series in memory: for the paper's figures of short runs.
#[derive(Debug, Clone, Default)]
pub struct TimeSeries {
    /// Sample times, s.
    pub t: Vec<f64>,
    /// Computed inputs per sample.
    pub u: Vec<Vec<f64>>,
    /// Reference inputs per sample.
    pub u_ref: Vec<Vec<f64>>,
    /// `max_i |u_i − u_ref,i|` per sample.
    pub error: Vec<f64>,
}

impl Observer for TimeSeries {
    fn sample(&mut self, s: &Sample<'_>) -> Result<(), String> {
        self.t.push(s.t);
        self.u.push(s.u.to_vec());
        self.u_ref.push(s.u_ref.to_vec());
        self.error.push(s.error);
        Ok(())
    }
}

/// The e_max above which a run counts as inaccurate, by model
/// ([`scene::dispatch::accuracy_threshold`]).
pub fn default_threshold(scene: &Scene) -> f64 {
    scene::dispatch::accuracy_threshold(&scene.model)
}

/// Runs a scene, measures it against its reference, and times `repeats` further runs.
/// A panic (which solver-core promises never to do) is caught and reported as
/// [`Outcome::Panic`] instead of ending the study.
pub fn run_scene(scene: &Scene, repeats: usize, threshold: f64) -> RunResult {
    run_scene_observed(scene, repeats, threshold, &mut ()).unwrap_or_else(RunResult::not_run)
}

/// [`run_scene`], handing every sample and the progress to `observer`. `Err` only when
/// the observer failed (a file could not be written): the run was not finished.
pub fn run_scene_observed(
    scene: &Scene,
    repeats: usize,
    threshold: f64,
    observer: &mut dyn Observer,
) -> Result<RunResult, String> {
    let observer = std::panic::AssertUnwindSafe(observer);
    std::panic::catch_unwind(move || {
        let observer = observer;
        run_scene_unguarded(scene, repeats, threshold, observer.0)
    })
    .unwrap_or_else(|_| {
        let mut r = RunResult::not_run("panicked");
        r.outcome = Outcome::Panic;
        Ok(r)
    })
}

fn run_scene_unguarded(
    scene: &Scene,
    repeats: usize,
    threshold: f64,
    observer: &mut dyn Observer,
) -> Result<RunResult, String> {
    if let Err(e) = scene.validate().and_then(|()| whole_steps(scene)) {
        return Ok(RunResult::refused(e));
    }
    let result = match scene.solver.scalar {
        ScalarSpec::F64 => dispatch::<f64>(scene, repeats, observer),
        ScalarSpec::F32 => dispatch::<f32>(scene, repeats, observer),
    }?;
    Ok(match result {
        Ok(mut r) => {
            // NaN is never accurate.
            if r.outcome == Outcome::Ok && (r.e_global.is_nan() || r.e_global > threshold) {
                r.outcome = Outcome::Inaccurate;
            }
            r
        }
        Err(e) => RunResult::refused(e),
    })
}

/// Refuses a step size that does not divide the run: h = 0.03 s over 10 s would end
/// at 9.99 s (or 10.02 s), and e_max would describe a different run than asked for.
pub fn whole_steps(scene: &Scene) -> Result<(), SceneError> {
    let (t_end, h) = (scene.trajectory.t_end, scene.solver.h);
    let n = t_end / h;
    if (n - n.round()).abs() > 1e-6 * n.round().max(1.0) {
        return Err(SceneError {
            field: "solver.h".into(),
            reason: format!(
                "h = {h} s does not divide trajectory.t_end = {t_end} s ({n:.3} steps): the run would end at {} s",
                n.round() * h
            ),
        });
    }
    Ok(())
}

/// `Ok(Err(_))`: the scene was refused; `Err(_)`: the observer failed.
type Measured = Result<Result<RunResult, SceneError>, String>;

fn dispatch<T: Real>(scene: &Scene, repeats: usize, observer: &mut dyn Observer) -> Measured {
    match scene::dispatch::model::<T, _>(
        scene,
        Measure {
            scene,
            repeats,
            observer,
        },
    ) {
        Ok(measured) => measured,
        Err(e) => Ok(Err(e)),
    }
}

/// [`measure`] as the visitor of a scene's model.
struct Measure<'a> {
    scene: &'a Scene,
    repeats: usize,
    observer: &'a mut dyn Observer,
}

impl<T: Real> ModelVisitor<T> for Measure<'_> {
    type Output = Measured;
    fn visit<M: DaeModel<T, N, NU>, const N: usize, const NU: usize, const S: usize>(
        self,
        model: M,
    ) -> Measured {
        measure::<T, M, N, NU, S>(&model, self.scene, self.repeats, self.observer)
    }
}

/// Runs the scene once, step by step: each sample is compared with the reference,
/// folded into the statistics and handed to the observer, then dropped.
fn measure<T, M, const N: usize, const NU: usize, const S: usize>(
    model: &M,
    scene: &Scene,
    repeats: usize,
    observer: &mut dyn Observer,
) -> Measured
where
    T: Real,
    M: DaeModel<T, N, NU>,
{
    let settings = scene.settings();
    let total = scene.steps();
    let t_end = scene.trajectory.t_end;
    let (a, b) = scene.interior();
    let mut reference = match Exact::new(scene) {
        Ok(r) => r,
        Err(e) => return Ok(Err(e)),
    };
    let made = Chosen::<T, M, N, NU, S>::new(model, scheme(scene), &settings, T::zero());
    let x0 = model.rest_state(T::zero());
    let (mut stepper, x0) = match made.and_then(|s| Ok((s, x0?))) {
        Ok(v) => v,
        Err(e) => return Ok(Err(scene.field_of(e))),
    };

    let mut r = RunResult::not_run("");
    r.failure = None;
    r.outcome = Outcome::Ok;
    r.t_end = t_end;
    let (mut e_all, mut e_inside) = (0.0_f64, 0.0_f64);
    let (mut iterations, mut residual_evals) = (0_u64, 0_u64);
    let mut u_ref = Vec::with_capacity(NU);
    let mut u = Vec::with_capacity(NU);
    let mut t = 0.0;
    let mut u_now = M::inputs(&x0);
    for step in 0..=total {
        if step > 0 {
            match stepper.step(model) {
                Ok(rep) => {
                    t = to_f64(rep.t);
                    u_now = rep.u;
                    let st = rep.stats;
                    r.steps = step;
                    iterations += u64::from(st.iterations);
                    residual_evals += u64::from(st.residual_evals);
                    r.iterations_max = r.iterations_max.max(st.iterations);
                    r.jacobian_evals += u64::from(st.jacobian_evals);
                    r.floor_steps += usize::from(st.at_rounding_floor);
                }
                Err(e) => {
                    r.outcome = match e {
                        Error::NonFinite { .. } => Outcome::NonFinite,
                        _ => Outcome::NewtonFailure,
                    };
                    r.failure = Some(e.to_string());
                    break;
                }
            }
        }
        u.clear();
        u.extend(u_now.iter().map(|v| to_f64(*v)));
        // A non-finite value returned as a success would be a bug; make it visible.
        if u.iter().any(|v| !v.is_finite()) {
            r.outcome = Outcome::NonFinite;
            r.failure = Some(format!("t = {t} s: non-finite input returned"));
            break;
        }
        if let Err(e) = reference.at(t, &mut u_ref) {
            return Ok(Err(scene.field_of(e)));
        }
        let error = u
            .iter()
            .zip(&u_ref)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        e_all = e_all.max(error);
        if (a..=b).contains(&t) {
            e_inside = e_inside.max(error);
        }
        r.t_reached = t;
        observer.sample(&Sample {
            t,
            u: &u,
            u_ref: &u_ref,
            error,
        })?;
        if step % 1024 == 0 || step == total {
            observer.progress(step, total);
        }
    }
    let n = r.steps.max(1) as f64;
    r.iterations_mean = iterations as f64 / n;
    r.residual_evals_per_step = residual_evals as f64 / n;
    r.e_partial = e_all;
    if r.outcome == Outcome::Ok {
        r.e_global = e_all;
        r.e_interior = e_inside;
        if repeats > 0 {
            r.ns_per_step = time_per_step::<T, M, N, NU, S>(model, scene, r.steps, repeats);
        }
    }
    Ok(Ok(r))
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
            let ok = Chosen::<T, M, N, NU, S>::new(model, scheme(scene), &settings, T::zero())
                .is_ok_and(|mut i| (0..steps).all(|_| std::hint::black_box(i.step(model)).is_ok()));
            ok.then(|| start.elapsed().as_nanos() as f64 / steps.max(1) as f64)
        })
        .collect();
    samples.sort_by(f64::total_cmp);
    samples.get(samples.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Rewrites numbers of more than 17 digits in a message in the shortest exponent form,
/// `1.7976931348623157e308`. solver-core prints a range's bounds short, but a value
/// printed with `{}` (a step size, a parameter) can still be hundreds of digits long.
pub fn readable_numbers(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find(|ch: char| ch.is_ascii_digit()) {
        let (before, from) = rest.split_at(start);
        out.push_str(before);
        let len = from
            .find(|ch: char| !(ch.is_ascii_digit() || ch == '.'))
            .unwrap_or(from.len());
        let (number, after) = from.split_at(len);
        let digits = number.chars().filter(char::is_ascii_digit).count();
        match number.parse::<f64>() {
            Ok(v) if digits > 17 => out.push_str(&format!("{v:e}")),
            _ => out.push_str(number),
        }
        rest = after;
    }
    out.push_str(rest);
    out
}

/// The Jacobian column of the CSV: `J`, `Jt`, `JtN`, `exact`, or `transformed` for
/// RADAU5's simplified Newton (exact partials too, but a different iteration: it
/// must not be reported as the paper's exact-Jacobian full Newton).
pub fn jacobian_label(scene: &Scene) -> String {
    match (scene.solver.jacobian, scene.solver.reinit_every) {
        (JacobianSpec::Fd, _) => "J".into(),
        (JacobianSpec::Exact, _) if scene.solver.newton == NewtonSpec::Transformed => {
            "transformed".into()
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Counts what a run hands over, keeping nothing else.
    #[derive(Default)]
    struct Count {
        samples: usize,
        last_progress: (usize, usize),
    }

    impl Observer for Count {
        fn sample(&mut self, _: &Sample<'_>) -> Result<(), String> {
            self.samples += 1;
            Ok(())
        }
        fn progress(&mut self, done: usize, total: usize) {
            assert!(done >= self.last_progress.0, "progress went back");
            self.last_progress = (done, total);
        }
    }

    #[test]
    fn a_run_streams_its_samples_and_reports_its_progress() {
        let scene = Scene::load(&crate::paper::root().join("scenes/paper-crane.toml")).unwrap();
        let mut count = Count::default();
        let r = run_scene_observed(&scene, 0, 1e-3, &mut count).unwrap();
        assert_eq!(r.outcome, Outcome::Ok);
        assert_eq!(count.samples, 1 + 1000);
        assert_eq!(count.last_progress, (1000, 1000));
    }

    #[test]
    fn long_numbers_are_shortened() {
        let text = format!("outside [{}, {}]", f64::MIN_POSITIVE, f64::MAX);
        assert_eq!(
            readable_numbers(&text),
            "outside [2.2250738585072014e-308, 1.7976931348623157e308]"
        );
        assert_eq!(readable_numbers("t = 7.602 s, 40 it"), "t = 7.602 s, 40 it");
    }
}
