//! The firmware's cycle, run on the host: the same controller, the same scene, the
//! same virtual bus and scenario. The QEMU run must send exactly these frames.

use controller::feedback::{Correction, StateFeedback};
use controller::feedforward::command_plan;
use controller::setpoint::Setpoint;
use controller::{CanFrame, Config, Controller, Feedforward, Injectable, Mode, Replan};
use scene::commissioning::CommissioningFile;
use scene::dispatch::FirmwareVisitor;
use scene::firmware::{firmware_scene, FirmwareScene};
use scene::Scene;
use sim::{run_cycle, Scenario, VirtualBus};
use solver_core::plan::Plan;

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

/// What is done with the firmware's controller for a scene, whatever the types the
/// scene gives it (model, scheme, Newton strategy, feedback).
pub trait WithController {
    /// What it gives.
    type Output;
    /// Does it with `controller`.
    fn with<F: Feedforward + Replan, C: Correction>(
        self,
        controller: Controller<Injectable<F>, C>,
    ) -> Self::Output;
}

/// The one construction of the firmware's controller on the host, for the host's run
/// of the firmware (the QEMU runs are compared with it) and the virtual ECU: the
/// scene's model and scheme with the Newton strategy the firmware links
/// (`FirmwareScheme`), following `plan`, the state feedback with the inclinometer for
/// a scene with `[feedback]` (`f.config` then lists it), and `config` (the firmware's,
/// or it with another role). A scene the firmware cannot run is refused.
pub fn with_controller<V: WithController>(
    scene: &Scene,
    f: &FirmwareScene,
    plan: Plan<f64, 2>,
    config: Config,
    visit: V,
) -> Result<V::Output, String> {
    let build = Build { f, config, visit };
    f.scheme
        .visit(f.params, plan, &scene.settings(), build)
        .map_err(|e| e.to_string())?
}

/// The inverse model built; the controller around it next.
struct Build<'a, V> {
    f: &'a FirmwareScene,
    config: Config,
    visit: V,
}

impl<V: WithController> FirmwareVisitor for Build<'_, V> {
    type Output = Result<V::Output, String>;

    /// The firmware's controller around `feedforward`: with the state feedback if the
    /// scene closes the loop.
    fn visit<F: Feedforward + Replan>(self, feedforward: F) -> Self::Output {
        let feedforward = Injectable::new(feedforward);
        let (planner, config) = (self.f.planner, self.config);
        Ok(match self.f.feedback {
            Some(feedback) => {
                let feedback = StateFeedback::new(feedback).map_err(|e| format!("{e:?}"))?;
                self.visit.with(Controller::with_correction(
                    feedforward,
                    feedback,
                    planner,
                    config,
                ))
            }
            None => self
                .visit
                .with(Controller::new(feedforward, planner, config)),
        })
    }
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
    let run = Boot {
        f,
        restarted,
        bus,
        cycles,
    };
    with_controller(scene, f, plan, f.config, run)
}

/// The firmware's loop on the virtual bus.
struct Boot<'a> {
    f: &'a FirmwareScene,
    restarted: bool,
    bus: VirtualBus,
    cycles: u32,
}

impl WithController for Boot<'_> {
    type Output = Vec<ReferenceCycle>;

    fn with<F: Feedforward + Replan, C: Correction>(
        self,
        controller: Controller<Injectable<F>, C>,
    ) -> Self::Output {
        run_with(controller, self.f, self.restarted, self.bus, self.cycles)
    }
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
