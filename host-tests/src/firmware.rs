//! The firmware's cycle, run on the host: the same controller, the same scene, the
//! same virtual bus and scenario. The QEMU run must send exactly these frames.

use controller::correction::AxesCorrection;
use controller::crane::command_plan;
use controller::setpoint::Setpoint;
use controller::{CanFrame, Config, Controller, Feedforward, Injectable, Mode, Replan};
use scene::commissioning::CommissioningFile;
use scene::dispatch::{firmware, FirmwareCrane, FirmwareCraneVisitor, FirmwareVisitor};
use scene::firmware::FirmwareScene;
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
    /// The set points, drive units, in the model's input order (planar `[trolley,
    /// winch]`, 3D `[bridge, trolley, winch]`).
    pub setpoints: Vec<Setpoint>,
    /// Supervisor state after the cycle.
    pub mode: Mode,
    /// The status frame's mode byte after the cycle (manual mode's
    /// `controller::operator::MANUAL_MODE_CODE` included), whether a status frame was
    /// sent in it or not: what a test judges a mode's change by, to the cycle.
    pub status_mode: u8,
}

/// Runs the firmware's loop for a crane scene on the virtual bus with `scenario`. A
/// scenario that hangs the firmware continues as the firmware does after its watchdog
/// restarted it: booted halted, without the scene's move, the hang not repeated.
pub fn controller_reference(
    scene: &Scene,
    commissioning: &CommissioningFile,
    scenario: &Scenario,
) -> Result<Vec<ReferenceCycle>, String> {
    firmware(
        scene,
        commissioning,
        RunScene {
            scene,
            scenario: *scenario,
        },
    )?
}

/// The host's run of the firmware on a scene, whatever its crane.
struct RunScene<'a> {
    scene: &'a Scene,
    scenario: Scenario,
}

impl FirmwareCraneVisitor for RunScene<'_> {
    type Output = Result<Vec<ReferenceCycle>, String>;

    fn visit<K: FirmwareCrane<A>, const A: usize>(self, f: FirmwareScene<K, A>) -> Self::Output {
        let (scene, scenario) = (self.scene, &self.scenario);
        let cycles = if scenario.cycles == 0 {
            f.cycles
        } else {
            scenario.cycles
        };
        // The simulated crane rests where the scene's move starts.
        let mut run = boot(scene, &f, f.plan, false, *scenario, cycles)?;
        if scenario.hang_at_ms().is_some() {
            let at_rest = command_plan::<K, A>(f.start(), scene.trajectory.smoothness)
                .map_err(|e| e.to_string())?;
            run.extend(boot(scene, &f, at_rest, true, *scenario, cycles)?);
        }
        Ok(run)
    }
}

/// The virtual bus the firmware's QEMU board builds for the scene: a stock drive for
/// each of the crane's drives, at rest where the scene's move starts; refused if the
/// scenario asks for a plant the bus does not simulate for this crane.
pub fn virtual_bus<K: FirmwareCrane<A>, const A: usize>(
    f: &FirmwareScene<K, A>,
    scenario: Scenario,
) -> Result<VirtualBus<K, A>, String> {
    let bus = VirtualBus::for_crane(scenario, &f.params, f.params.drives_at_rest(f.start()));
    if bus.simulates_scenario() {
        Ok(bus)
    } else {
        Err(format!(
            "scenario {}: it moves a plant, and this build has no plant (feature `plant`)",
            scenario.name
        ))
    }
}

/// What is done with the firmware's controller for a scene, whatever the types the
/// scene gives it (crane, model, scheme, Newton strategy, feedback).
pub trait WithController {
    /// What it gives.
    type Output;
    /// Does it with `controller`, the controller of crane `K` with `A` driven axes.
    fn with<F, C, K, const A: usize>(
        self,
        controller: Controller<Injectable<F>, C, K, A>,
        f: &FirmwareScene<K, A>,
    ) -> Self::Output
    where
        F: Feedforward<A, Reference = K::Reference> + Replan<A> + 'static,
        C: AxesCorrection<A, K::Reference> + 'static,
        K: FirmwareCrane<A>;
}

/// The one construction of the firmware's controller on the host, for the host's run
/// of the firmware (the QEMU runs are compared with it) and the virtual ECU: the
/// scene's crane, model and scheme with the Newton strategy the firmware links
/// (`FirmwareScheme`), following `plan`, the state feedback with the inclinometer for
/// a scene with `[feedback]` (`f.config` then lists it), and `config` (the firmware's,
/// or it with another role). A scene the firmware cannot run is refused.
pub fn with_controller<K: FirmwareCrane<A>, V: WithController, const A: usize>(
    scene: &Scene,
    f: &FirmwareScene<K, A>,
    plan: Plan<f64, A>,
    config: Config,
    visit: V,
) -> Result<V::Output, String> {
    let build = Build { f, config, visit };
    f.inverse_model(plan, &scene.settings(), build)
        .map_err(|e| e.to_string())?
}

/// The inverse model built; the controller around it next.
struct Build<'a, K: FirmwareCrane<A>, V, const A: usize> {
    f: &'a FirmwareScene<K, A>,
    config: Config,
    visit: V,
}

impl<K: FirmwareCrane<A>, V: WithController, const A: usize> FirmwareVisitor<K, A>
    for Build<'_, K, V, A>
{
    type Output = Result<V::Output, String>;

    /// The firmware's controller around `feedforward`: with the crane's state feedback
    /// if the scene closes the loop.
    fn visit<F: Feedforward<A, Reference = K::Reference> + Replan<A> + 'static>(
        self,
        feedforward: F,
    ) -> Self::Output {
        let feedforward = Injectable::new(feedforward);
        let (f, planner, config) = (self.f, self.f.planner, self.config);
        Ok(match f.feedback {
            Some(feedback) => self.visit.with(
                Controller::with_correction(
                    feedforward,
                    f.params.feedback(feedback).map_err(|e| format!("{e:?}"))?,
                    planner,
                    config,
                ),
                f,
            ),
            None => self.visit.with(
                Controller::with_correction(
                    feedforward,
                    K::FeedforwardOnly::default(),
                    planner,
                    config,
                ),
                f,
            ),
        })
    }
}

/// One boot of the firmware with `plan`, until the cycles are done or it hangs: on a
/// fresh virtual bus, whose hangs are left out after a watchdog restart.
fn boot<K: FirmwareCrane<A>, const A: usize>(
    scene: &Scene,
    f: &FirmwareScene<K, A>,
    plan: Plan<f64, A>,
    restarted: bool,
    scenario: Scenario,
    cycles: u32,
) -> Result<Vec<ReferenceCycle>, String> {
    let run = Boot {
        restarted,
        scenario,
        cycles,
    };
    with_controller(scene, f, plan, f.config, run)?
}

/// The firmware's loop on the virtual bus.
struct Boot {
    restarted: bool,
    scenario: Scenario,
    cycles: u32,
}

impl WithController for Boot {
    type Output = Result<Vec<ReferenceCycle>, String>;

    fn with<F, C, K, const A: usize>(
        self,
        mut controller: Controller<Injectable<F>, C, K, A>,
        f: &FirmwareScene<K, A>,
    ) -> Self::Output
    where
        F: Feedforward<A, Reference = K::Reference> + Replan<A>,
        C: AxesCorrection<A, K::Reference>,
        K: FirmwareCrane<A>,
    {
        let mut bus = virtual_bus(f, self.scenario)?;
        if self.restarted {
            controller.restarted_by_watchdog();
            bus = bus.without_hangs();
        } else {
            // The scene's move, planned at boot, is the main job's command.
            controller.demonstration_commanded();
        }
        let period_ms = f.config.period_ms;
        let mut out = Vec::new();
        for cycle in 0..self.cycles {
            let now_ms = cycle * period_ms;
            let Some(c) = run_cycle(&mut controller, &mut bus, now_ms) else {
                break;
            };
            out.push(ReferenceCycle {
                now_ms,
                frames: c.frames.to_vec(),
                setpoints: c.setpoints.to_vec(),
                mode: c.mode,
                status_mode: controller.status().mode,
            });
        }
        Ok(out)
    }
}
