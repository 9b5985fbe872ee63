//! The firmware's cycle, run on the host: the same controller, the same scene, the
//! same virtual bus and scenario. The QEMU run must send exactly these frames.

use controller::feedback::{Correction, StateFeedback};
use controller::feedforward::command_plan;
use controller::setpoint::Setpoint;
use controller::virtual_bus::{run_cycle, Scenario, VirtualBus};
use controller::{CanFrame, Controller, Feedforward, Injectable, InverseModel, Mode, Replan};
use scene::commissioning::CommissioningFile;
use scene::firmware::{firmware_scene, structured_newton, FirmwareScene};
use scene::{ModelSpec, Scene, SchemeSpec};
use solver_core::models::crane_proj::CraneProj;
use solver_core::models::crane_subs::CraneSubs;
use solver_core::plan::Plan;
use solver_core::schemes::bdf::StructuredOf;
use solver_core::schemes::radau5::{StructuredStagesOf, Transformed};

/// The firmware's *subs* model, driven by a plan that changes on command.
type Subs = CraneSubs<f64, Plan<f64, 2>>;
use solver_core::{Bdf, Radau};

/// One cycle as the firmware runs it.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceCycle {
    /// Time of the cycle, ms.
    pub now_ms: u32,
    /// Frames sent (including those the bus refused).
    pub frames: Vec<CanFrame>,
    /// `[trolley, winch]` set points, drive units.
    pub setpoints: [Setpoint; 2],
    /// Supervisor state after the cycle.
    pub mode: Mode,
}

/// Runs the firmware's loop for a crane scene on the virtual bus with `scenario`. A
/// scenario that hangs the firmware continues as the firmware does after its watchdog
/// restarted it: booted halted, without the scene's move, the hang not repeated.
pub fn controller_reference(
    scene: &Scene,
    commissioning: &CommissioningFile,
    scenario: &Scenario,
) -> Result<Vec<ReferenceCycle>, String> {
    let f = firmware_scene(scene, commissioning)?;
    let cycles = if scenario.cycles == 0 {
        f.cycles
    } else {
        scenario.cycles
    };
    // The simulated crane rests where the scene's move starts.
    let start: [f64; 2] = f.first_move.start().into();
    let mut run = boot(
        scene,
        &f,
        f.plan,
        false,
        VirtualBus::new(*scenario, start),
        cycles,
    )?;
    if scenario.hang_at_ms().is_some() {
        let at_rest = command_plan(f.first_move.start().into(), scene.trajectory.smoothness)
            .map_err(|e| e.to_string())?;
        let bus = VirtualBus::new(*scenario, start).without_hangs();
        run.extend(boot(scene, &f, at_rest, true, bus, cycles)?);
    }
    Ok(run)
}

/// One boot of the firmware with `plan`, until the cycles are done or it hangs.
fn boot(
    scene: &Scene,
    f: &FirmwareScene,
    plan: Plan<f64, 2>,
    restarted: bool,
    bus: VirtualBus,
    cycles: u32,
) -> Result<Vec<ReferenceCycle>, String> {
    let settings = scene.settings();
    let err = |e: solver_core::Error| e.to_string();
    let k = scene.solver.k;
    match (&scene.model, scene.solver.scheme) {
        (ModelSpec::CraneSubs(_), SchemeSpec::Bdf) if structured_newton(scene) => {
            let model = CraneSubs::new(f.params, plan).map_err(err)?;
            let integrator = Bdf::<f64, Subs, 7, 2, StructuredOf<f64, Subs, 7, 2>>::new(
                &model, &settings, k, 0.0,
            )
            .map_err(err)?;
            run(
                InverseModel { model, integrator },
                f,
                restarted,
                bus,
                cycles,
            )
        }
        (ModelSpec::CraneSubs(_), SchemeSpec::Bdf) => {
            let model = CraneSubs::new(f.params, plan).map_err(err)?;
            let integrator = Bdf::<f64, _, 7, 2>::new(&model, &settings, k, 0.0).map_err(err)?;
            run(
                InverseModel { model, integrator },
                f,
                restarted,
                bus,
                cycles,
            )
        }
        (ModelSpec::CraneSubs(_), SchemeSpec::Radau) if structured_newton(scene) => {
            let model = CraneSubs::new(f.params, plan).map_err(err)?;
            let integrator = Radau::<
                f64,
                Subs,
                7,
                2,
                21,
                Transformed<f64, 7, StructuredStagesOf<f64, Subs, 7, 2>>,
            >::new(&model, &settings, 0.0)
            .map_err(err)?;
            run(
                InverseModel { model, integrator },
                f,
                restarted,
                bus,
                cycles,
            )
        }
        (ModelSpec::CraneSubs(_), SchemeSpec::Radau) => {
            let model = CraneSubs::new(f.params, plan).map_err(err)?;
            let integrator = Radau::<f64, _, 7, 2, 21>::new(&model, &settings, 0.0).map_err(err)?;
            run(
                InverseModel { model, integrator },
                f,
                restarted,
                bus,
                cycles,
            )
        }
        (ModelSpec::CraneProj(_), SchemeSpec::Bdf) => {
            let model = CraneProj::new(f.params, plan).map_err(err)?;
            let integrator = Bdf::<f64, _, 8, 2>::new(&model, &settings, k, 0.0).map_err(err)?;
            run(
                InverseModel { model, integrator },
                f,
                restarted,
                bus,
                cycles,
            )
        }
        (ModelSpec::CraneProj(_), SchemeSpec::Radau) => {
            let model = CraneProj::new(f.params, plan).map_err(err)?;
            let integrator = Radau::<f64, _, 8, 2, 24>::new(&model, &settings, 0.0).map_err(err)?;
            run(
                InverseModel { model, integrator },
                f,
                restarted,
                bus,
                cycles,
            )
        }
        (ModelSpec::MassOnCar(_), _) => Err("the firmware drives a crane".into()),
    }
}

/// The firmware's controller for the scene: the state feedback if it closes the loop.
fn run<F: Feedforward + Replan>(
    feedforward: F,
    f: &FirmwareScene,
    restarted: bool,
    bus: VirtualBus,
    cycles: u32,
) -> Result<Vec<ReferenceCycle>, String> {
    let feedforward = Injectable::new(feedforward);
    Ok(match f.feedback {
        Some(config) => {
            let feedback = StateFeedback::new(config).map_err(|e| format!("{e:?}"))?;
            let controller =
                Controller::with_correction(feedforward, feedback, f.planner, f.config);
            run_with(controller, f, restarted, bus, cycles)
        }
        None => {
            let controller = Controller::new(feedforward, f.planner, f.config);
            run_with(controller, f, restarted, bus, cycles)
        }
    })
}

fn run_with<F: Feedforward + Replan, C: Correction>(
    mut controller: Controller<Injectable<F>, C>,
    f: &FirmwareScene,
    restarted: bool,
    mut bus: VirtualBus,
    cycles: u32,
) -> Vec<ReferenceCycle> {
    if restarted {
        controller.restarted_by_watchdog();
    } else {
        // The scene's move, planned at boot, is the main job's command.
        controller.demonstration_commanded();
    }
    let period_ms = f.config.period_ms;
    let mut out = Vec::new();
    for cycle in 0..cycles {
        let now_ms = cycle * period_ms;
        let Some(c) = run_cycle(&mut controller, &mut bus, now_ms) else {
            break;
        };
        out.push(ReferenceCycle {
            now_ms,
            frames: c.frames.to_vec(),
            setpoints: c.setpoints,
            mode: c.mode,
        });
    }
    out
}
