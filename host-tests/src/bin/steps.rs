//! `steps`: a crane scene stepped from rest to `t_end`, nothing recorded — the program
//! that `cargo xtask instructions` runs under callgrind to count instructions per step.
//!
//! ```text
//! steps SCENE [key=value …]     keys as in `study sweep --vary` (h, scheme, jacobian, …),
//!                               and newton=structured, trajectory=plan|point-to-point,
//!                               emax=yes
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
//! `newton=structured` measures the integrator the firmware links for the scene
//! (`scene::dispatch::firmware_steps`, the firmware's build script's dispatch: BDF from
//! 5 ms on the closed form without its correction linked, below it with; RADAU5's stages
//! in closed form), on any crane the firmware drives; without it, the study's integrator
//! for the scene (`scene::dispatch::model`, the scheme with the settings' Jacobian mode
//! on dense LUs), on any model, bare move only.
//!
//! `emax=yes` also measures Eq. 29 against the scene's exact reference after every step
//! (outside [`measured_step`], from the integrator's state) and prints it: `cargo xtask
//! trade` runs each configuration once so for its accuracy and once under callgrind,
//! without it, for its cost.

use std::process::ExitCode;

use host_tests::study::{jacobian_label, scheme_label, whole_steps};
use host_tests::sweep::apply;
use scene::dispatch::{firmware_steps, scheme, DrivenBy, Exact, ModelVisitor, StepsVisitor};
use scene::{ScalarSpec, Scene, SchemeSpec};
use solver_core::reference::emax::{input_error, Emax};
use solver_core::scalar::to_f64;
use solver_core::schemes::Chosen;
use solver_core::{DaeModel, Error, Integrator};

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

/// Eq. 29 measured along a run: the scene's exact reference and the error so far.
struct Accuracy {
    exact: Exact,
    emax: Emax,
    reference: Vec<f64>,
}

impl Accuracy {
    /// The reference of `scene`, nothing measured yet.
    fn of(scene: &Scene) -> Result<Self, String> {
        let (a, b) = scene.interior();
        Ok(Self {
            exact: Exact::new(scene).map_err(|e| e.to_string())?,
            emax: Emax::over(a, b),
            reference: Vec::new(),
        })
    }

    /// Takes the inputs `u` at `t`.
    fn add<const NU: usize>(
        &mut self,
        t: f64,
        u: &nalgebra::SVector<f64, NU>,
    ) -> Result<(), String> {
        self.exact
            .at(t, &mut self.reference)
            .map_err(|e| e.to_string())?;
        let reference: [f64; NU] =
            core::array::from_fn(|i| self.reference.get(i).copied().unwrap_or(f64::NAN));
        self.emax.add(t, input_error(u, &reference));
        Ok(())
    }
}

/// Steps `integrator` `steps` times; the Newton iterations, and Eq. 29 over the run if
/// `accuracy` is given (from the rest state on, each step's state after it).
fn step_with<
    M: DaeModel<f64, N, NU>,
    I: Integrator<f64, M, N, NU>,
    const N: usize,
    const NU: usize,
>(
    mut integrator: I,
    model: &M,
    steps: usize,
    mut accuracy: Option<Accuracy>,
) -> Result<(u64, Option<Emax>), String> {
    let mut iterations = 0_u64;
    if let Some(a) = accuracy.as_mut() {
        a.add(to_f64(integrator.time()), &M::inputs(&integrator.state()))?;
    }
    for _ in 0..steps {
        iterations += u64::from(measured_step(&mut integrator, model).map_err(|e| e.to_string())?);
        if let Some(a) = accuracy.as_mut() {
            a.add(to_f64(integrator.time()), &M::inputs(&integrator.state()))?;
        }
    }
    Ok((iterations, accuracy.map(|a| a.emax)))
}

/// What a run gives: the Newton iterations, and e_max if it was measured.
type Stepped = Result<(u64, Option<Emax>), String>;

/// The firmware's integrator for the scene (`scene::dispatch::firmware_steps`), stepped.
struct Firmware {
    steps: usize,
    accuracy: Option<Accuracy>,
}

impl StepsVisitor for Firmware {
    type Output = Stepped;
    fn visit<
        M: DaeModel<f64, N, NU>,
        I: Integrator<f64, M, N, NU>,
        const N: usize,
        const NU: usize,
    >(
        self,
        model: M,
        integrator: I,
    ) -> Self::Output {
        step_with(integrator, &model, self.steps, self.accuracy)
    }
}

/// The study's integrator for the scene (`scene::dispatch::model`: the scheme the scene
/// names with the settings' Jacobian mode on dense LUs), stepped.
struct Study<'a> {
    scene: &'a Scene,
    accuracy: Option<Accuracy>,
}

impl ModelVisitor<f64> for Study<'_> {
    type Output = Stepped;
    fn visit<M: DaeModel<f64, N, NU>, const N: usize, const NU: usize, const S: usize>(
        self,
        model: M,
    ) -> Self::Output {
        let integrator = Chosen::<f64, M, N, NU, S>::new(
            &model,
            scheme(self.scene),
            &self.scene.settings(),
            0.0,
        )
        .map_err(|e| e.to_string())?;
        step_with(integrator, &model, self.scene.steps(), self.accuracy)
    }
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
    let mut driven = DrivenBy::PointToPoint;
    // `emax=yes`: Eq. 29 measured along the run.
    let mut measure = false;
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
            ("trajectory", "plan") => driven = DrivenBy::Plan,
            ("trajectory", "point-to-point") => driven = DrivenBy::PointToPoint,
            ("trajectory", v) => {
                return Err(format!("trajectory={v}: expected plan or point-to-point"))
            }
            ("emax", "yes") => measure = true,
            ("emax", v) => return Err(format!("emax={v}: expected yes")),
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
    let accuracy = measure.then(|| Accuracy::of(&scene)).transpose()?;
    let (iterations, emax) = if structured {
        // The firmware's integrator, through the one dispatch the firmware's build script
        // uses: it must be the structured one the flag asks for.
        let firmware = scene::dispatch::FirmwareScheme::of(&scene)?;
        if !firmware.structured() {
            return Err(format!(
                "newton=structured: the firmware links {firmware:?} for this scene"
            ));
        }
        firmware_steps(
            &scene,
            driven,
            Firmware {
                steps: scene.steps(),
                accuracy,
            },
        )??
    } else if driven == DrivenBy::PointToPoint {
        scene::dispatch::model::<f64, _>(
            &scene,
            Study {
                scene: &scene,
                accuracy,
            },
        )
        .map_err(|e| e.to_string())??
    } else {
        return Err(
            "trajectory=plan measures the firmware's integrator: add newton=structured".into(),
        );
    };
    report(&scene, structured, driven, iterations, emax)
}

/// The line `cargo xtask instructions` reads the steps and iterations from.
fn report(
    scene: &Scene,
    structured: bool,
    driven: DrivenBy,
    iterations: u64,
    emax: Option<Emax>,
) -> Result<(), String> {
    let accuracy = emax.map_or_else(String::new, |e| {
        format!(", e_max {:e}, interior {:e}", e.global, e.interior)
    });
    println!(
        "{} {}{}{} h = {}: steps {}, Newton iterations {iterations}{accuracy}",
        scheme_label(scene),
        jacobian_label(scene),
        if structured { " structured" } else { "" },
        if driven == DrivenBy::Plan {
            " plan"
        } else {
            ""
        },
        scene.solver.h,
        scene.steps()
    );
    Ok(())
}
