//! `steps`: a crane scene stepped from rest to `t_end`, nothing recorded — the program
//! that `cargo xtask instructions` runs under callgrind to count instructions per step.
//!
//! ```text
//! steps SCENE [key=value …]     keys as in `study sweep --vary` (h, scheme, jacobian, …),
//!                               and newton=structured, trajectory=plan|point-to-point
//! ```
//!
//! Each step goes through [`measured_step`], which is
//! never inlined, so that `valgrind --tool=callgrind --toggle-collect='*measured_step*'`
//! collects exactly the steps (with everything they call) and nothing of the setup:
//! instructions per step = callgrind's `Collected` / the steps printed. The scene goes
//! through the same `apply` as the study's sweeps, so the labels are the CSV's.
//!
//! `trajectory=plan` drives the model by the firmware's trajectory type, a
//! [`Plan`](solver_core::plan::Plan) holding the scene's move, instead of the bare
//! [`PointToPoint`](solver_core::trajectory::PointToPoint) the studies use: what a
//! step costs on the MCU includes what the plan costs per evaluation (issue 20).
//!
//! `newton=structured` BDF is the type the firmware links for the scene's h: from
//! `CORRECT_BELOW_H` (5 ms) on the closed form without its correction linked
//! (`StructuredBdfUncorrected`), below it with (`StructuredBdf`).

use std::process::ExitCode;

use host_tests::study::{jacobian_label, scheme_label, whole_steps};
use host_tests::sweep::apply;
use scene::{ModelSpec, ScalarSpec, Scene, SchemeSpec};
use solver_core::models::crane3d::{self, Crane3dSubs};
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::schemes::bdf::CORRECT_BELOW_H;
use solver_core::trajectory::Trajectory;
use solver_core::{DaeModel, Error, Integrator, SolverSettings};

/// One step of any scheme on any model, the unit callgrind collects (never inlined, so
/// that its monomorphisations carry its name).
#[inline(never)]
fn measured_step<
    M: DaeModel<f64, N, NU>,
    I: Integrator<f64, M, N, NU>,
    const N: usize,
    const NU: usize,
>(
    integrator: &mut I,
    model: &M,
) -> Result<u32, Error> {
    integrator.step(model).map(|r| r.stats.iterations)
}

/// Steps `integrator` `steps` times; the Newton iterations.
fn step_with<
    M: DaeModel<f64, N, NU>,
    I: Integrator<f64, M, N, NU>,
    const N: usize,
    const NU: usize,
>(
    integrator: Result<I, Error>,
    model: &M,
    steps: usize,
) -> Result<u64, String> {
    let mut integrator = integrator.map_err(|e| e.to_string())?;
    let mut iterations = 0_u64;
    for _ in 0..steps {
        iterations += u64::from(measured_step(&mut integrator, model).map_err(|e| e.to_string())?);
    }
    Ok(iterations)
}

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("steps: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The trajectory type the model is driven by (`trajectory=…`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Driven {
    /// The scene's move as a `PointToPoint` (the studies' and the paper's).
    PointToPoint,
    /// The same move pushed onto a `Plan` at rest at its start: the firmware's type.
    Plan,
}

fn run() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let path = args.next().ok_or(
        "usage: steps SCENE [key=value …] (keys as in `study sweep --vary`, and \
         newton=structured, trajectory=plan|point-to-point)",
    )?;
    let mut scene = Scene::load(path.as_ref()).map_err(|e| format!("{path}: {e}"))?;
    // `newton=structured` (BDF with the exact Jacobian, or Radau with `transformed`): the
    // firmware's Newton by the model's structured elimination, not a study axis.
    let mut structured = false;
    // `trajectory=plan`: the firmware's trajectory type, not a study axis either.
    let mut driven = Driven::PointToPoint;
    for setting in args {
        let (key, value) = setting
            .split_once('=')
            .ok_or_else(|| format!("`{setting}`: expected key=value"))?;
        match (key, value) {
            ("newton", "structured") => {
                structured = true;
                if scene.solver.newton != scene::NewtonSpec::Transformed {
                    scene = apply(&scene, "jacobian", "exact")?;
                }
            }
            ("trajectory", "plan") => driven = Driven::Plan,
            ("trajectory", "point-to-point") => driven = Driven::PointToPoint,
            ("trajectory", v) => {
                return Err(format!("trajectory={v}: expected plan or point-to-point"))
            }
            _ => scene = apply(&scene, key, value)?,
        }
    }
    let transformed = scene.solver.newton == scene::NewtonSpec::Transformed;
    if structured && scene.solver.scheme == SchemeSpec::Radau && !transformed {
        return Err("newton=structured is BDF's (exact) or RADAU5's (jacobian=transformed)".into());
    }
    // `apply` does not validate; a refused combination (BDF with `transformed`) must
    // not be measured as something else.
    scene
        .validate()
        .and_then(|()| whole_steps(&scene))
        .map_err(|e| e.to_string())?;
    if scene.solver.scalar != ScalarSpec::F64 {
        return Err("only f64 is measured".into());
    }
    let crane = match &scene.model {
        ModelSpec::CraneSubs(crane) => crane,
        ModelSpec::Crane3dSubs(crane) if driven == Driven::PointToPoint => {
            let iterations = step_all_3d(&scene, crane.params(), structured)?;
            return report(&scene, structured, driven, iterations);
        }
        _ => {
            return Err(
                "only the crane *subs* models are measured (the 3D one on its bare move)".into(),
            )
        }
    };
    let trajectory = scene.trajectory2().map_err(|e| e.to_string())?;
    let iterations = match driven {
        Driven::PointToPoint => {
            let model = CraneSubs::new(crane.params(), trajectory).map_err(|e| e.to_string())?;
            step_all(&scene, &model, structured)?
        }
        Driven::Plan => {
            // As the firmware builds it (`inverse_model` of firmware/build.rs): at rest at
            // the move's start, the scene's move pushed as the running one.
            let mut plan = controller::feedforward::command_plan(
                trajectory.start().into(),
                scene.trajectory.smoothness,
            )
            .map_err(|e| e.to_string())?;
            plan.push(trajectory).map_err(|e| e.to_string())?;
            let model = CraneSubs::new(crane.params(), plan).map_err(|e| e.to_string())?;
            step_all(&scene, &model, structured)?
        }
    };
    report(&scene, structured, driven, iterations)
}

/// The line `cargo xtask instructions` reads the steps and iterations from.
fn report(scene: &Scene, structured: bool, driven: Driven, iterations: u64) -> Result<(), String> {
    println!(
        "{} {}{}{} h = {}: steps {}, Newton iterations {iterations}",
        scheme_label(scene),
        jacobian_label(scene),
        if structured { " structured" } else { "" },
        if driven == Driven::Plan { " plan" } else { "" },
        scene.solver.h,
        scene.steps()
    );
    Ok(())
}

/// Steps the scene from rest to its end with the scheme it names; the Newton iterations.
fn step_all<Z: Trajectory<f64, 2>>(
    scene: &Scene,
    model: &CraneSubs<f64, Z>,
    structured: bool,
) -> Result<u64, String> {
    let (s, k, n) = (&scene.settings(), scene.solver.k, scene.steps());
    match scene.solver.scheme {
        SchemeSpec::Bdf if structured && s.h >= CORRECT_BELOW_H => step_with(
            crane_subs::StructuredBdfUncorrected::new(model, s, k, 0.0),
            model,
            n,
        ),
        SchemeSpec::Bdf if structured => {
            step_with(crane_subs::StructuredBdf::new(model, s, k, 0.0), model, n)
        }
        SchemeSpec::Bdf => step_with(crane_subs::Bdf::<f64, Z>::new(model, s, k, 0.0), model, n),
        SchemeSpec::Radau if structured => {
            step_with(crane_subs::StructuredRadau5::new(model, s, 0.0), model, n)
        }
        SchemeSpec::Radau => step_with(crane_subs::Radau::<f64, Z>::new(model, s, 0.0), model, n),
    }
}

/// [`step_all`] for the 3D crane on the scene's bare move.
fn step_all_3d(
    scene: &Scene,
    params: crane3d::Crane3dParams,
    structured: bool,
) -> Result<u64, String> {
    let model = Crane3dSubs::new(params, scene.trajectory3().map_err(|e| e.to_string())?)
        .map_err(|e| e.to_string())?;
    let (s, k, n): (&SolverSettings, usize, usize) =
        (&scene.settings(), scene.solver.k, scene.steps());
    type Z = solver_core::trajectory::PointToPoint<f64, 3>;
    use crane3d::subs;
    match scene.solver.scheme {
        SchemeSpec::Bdf if structured && s.h >= CORRECT_BELOW_H => step_with(
            subs::StructuredBdfUncorrected::new(&model, s, k, 0.0),
            &model,
            n,
        ),
        SchemeSpec::Bdf if structured => {
            step_with(subs::StructuredBdf::new(&model, s, k, 0.0), &model, n)
        }
        SchemeSpec::Bdf => step_with(subs::Bdf::<f64, Z>::new(&model, s, k, 0.0), &model, n),
        SchemeSpec::Radau if structured => {
            step_with(subs::StructuredRadau5::new(&model, s, 0.0), &model, n)
        }
        SchemeSpec::Radau => step_with(subs::Radau::<f64, Z>::new(&model, s, 0.0), &model, n),
    }
}
