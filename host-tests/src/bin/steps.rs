//! `steps`: a crane scene stepped from rest to `t_end`, nothing recorded — the program
//! that `cargo xtask instructions` runs under callgrind to count instructions per step.
//!
//! ```text
//! steps SCENE [key=value …]     keys as in `study sweep --vary` (h, scheme, jacobian, …),
//!                               and newton=structured, trajectory=plan|point-to-point
//! ```
//!
//! Each step goes through [`measured_step_bdf`] or [`measured_step_radau`], which are
//! never inlined, so that `valgrind --tool=callgrind --toggle-collect='*measured_step*'`
//! collects exactly the steps (with everything they call) and nothing of the setup:
//! instructions per step = callgrind's `Collected` / the steps printed. The scene goes
//! through the same `apply` as the study's sweeps, so the labels are the CSV's.
//!
//! `trajectory=plan` drives the model by the firmware's trajectory type, a
//! [`Plan`](solver_core::plan::Plan) holding the scene's move, instead of the bare
//! [`PointToPoint`](solver_core::trajectory::PointToPoint) the studies use: what a
//! step costs on the MCU includes what the plan costs per evaluation (issue 20).

use std::process::ExitCode;

use host_tests::study::{jacobian_label, scheme_label, whole_steps};
use host_tests::sweep::apply;
use scene::{ModelSpec, ScalarSpec, Scene, SchemeSpec};
use solver_core::models::crane_subs::{self, CraneSubs, N, NU};
use solver_core::trajectory::Trajectory;
use solver_core::{Error, StepReport};

/// The crane *subs* model of the paper (Eqs. 24–28) driven by the trajectory `Z`.
type Crane<Z> = CraneSubs<f64, Z>;

/// One BDF step, the unit callgrind collects.
#[inline(never)]
fn measured_step_bdf<Z: Trajectory<f64, 2>>(
    bdf: &mut crane_subs::Bdf<f64, Z>,
    model: &Crane<Z>,
) -> Result<u32, Error> {
    bdf.step(model)
        .map(|r: StepReport<f64, N, NU>| r.stats.iterations)
}

/// BDF with the *subs* model's structured elimination: the firmware's default scene.
#[inline(never)]
fn measured_step_bdf_structured<Z: Trajectory<f64, 2>>(
    bdf: &mut crane_subs::StructuredBdf<f64, Z>,
    model: &Crane<Z>,
) -> Result<u32, Error> {
    bdf.step(model)
        .map(|r: StepReport<f64, N, NU>| r.stats.iterations)
}

/// RADAU5 with the *subs* model's structured elimination: the firmware's Radau scene.
#[inline(never)]
fn measured_step_radau_structured<Z: Trajectory<f64, 2>>(
    radau: &mut crane_subs::StructuredRadau5<f64, Z>,
    model: &Crane<Z>,
) -> Result<u32, Error> {
    radau
        .step(model)
        .map(|r: StepReport<f64, N, NU>| r.stats.iterations)
}

#[inline(never)]
fn measured_step_radau<Z: Trajectory<f64, 2>>(
    radau: &mut crane_subs::Radau<f64, Z>,
    model: &Crane<Z>,
) -> Result<u32, Error> {
    radau
        .step(model)
        .map(|r: StepReport<f64, N, NU>| r.stats.iterations)
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
    let (ModelSpec::CraneSubs(crane), ScalarSpec::F64) = (&scene.model, scene.solver.scalar) else {
        return Err("only the crane *subs* model in f64 is measured".into());
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
    println!(
        "{} {}{}{} h = {}: steps {}, Newton iterations {iterations}",
        scheme_label(&scene),
        jacobian_label(&scene),
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
    model: &Crane<Z>,
    structured: bool,
) -> Result<u64, String> {
    let settings = scene.settings();
    let steps = scene.steps();
    let mut iterations = 0_u64;
    match scene.solver.scheme {
        SchemeSpec::Bdf if structured => {
            let mut bdf =
                crane_subs::StructuredBdf::<f64, Z>::new(model, &settings, scene.solver.k, 0.0)
                    .map_err(|e| e.to_string())?;
            for _ in 0..steps {
                iterations += u64::from(
                    measured_step_bdf_structured(&mut bdf, model).map_err(|e| e.to_string())?,
                );
            }
        }
        SchemeSpec::Bdf => {
            let mut bdf = crane_subs::Bdf::<f64, Z>::new(model, &settings, scene.solver.k, 0.0)
                .map_err(|e| e.to_string())?;
            for _ in 0..steps {
                iterations +=
                    u64::from(measured_step_bdf(&mut bdf, model).map_err(|e| e.to_string())?);
            }
        }
        SchemeSpec::Radau if structured => {
            let mut radau = crane_subs::StructuredRadau5::<f64, Z>::new(model, &settings, 0.0)
                .map_err(|e| e.to_string())?;
            for _ in 0..steps {
                iterations += u64::from(
                    measured_step_radau_structured(&mut radau, model).map_err(|e| e.to_string())?,
                );
            }
        }
        SchemeSpec::Radau => {
            let mut radau = crane_subs::Radau::<f64, Z>::new(model, &settings, 0.0)
                .map_err(|e| e.to_string())?;
            for _ in 0..steps {
                iterations +=
                    u64::from(measured_step_radau(&mut radau, model).map_err(|e| e.to_string())?);
            }
        }
    }
    Ok(iterations)
}
