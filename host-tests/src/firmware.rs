//! The firmware's cycle, run on the host: the same controller, the same scene, the
//! same virtual bus and scenario. The QEMU run must send exactly these frames.

use controller::units::Setpoint;
use controller::virtual_bus::{run_cycle, Scenario, VirtualBus};
use controller::{CanFrame, Controller, Feedforward, Injectable, InverseModel, Mode, Replan};
use scene::firmware::{firmware_scene, FirmwareScene};
use scene::{ModelSpec, Scene, SchemeSpec};
use solver_core::models::crane_proj::CraneProj;
use solver_core::models::crane_subs::CraneSubs;
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

/// Runs the firmware's loop for a crane scene on the virtual bus with `scenario`.
pub fn controller_reference(
    scene: &Scene,
    scenario: &Scenario,
) -> Result<Vec<ReferenceCycle>, String> {
    let f = firmware_scene(scene)?;
    let settings = scene.settings();
    let err = |e: solver_core::Error| e.to_string();
    let cycles = if scenario.cycles == 0 {
        f.cycles
    } else {
        scenario.cycles
    };
    match (&scene.model, scene.solver.scheme) {
        (ModelSpec::CraneSubs(_), SchemeSpec::Bdf) => {
            let model = CraneSubs::new(f.params, f.plan).map_err(err)?;
            let integrator =
                Bdf::<f64, _, 7, 2>::new(&model, &settings, scene.solver.k, 0.0).map_err(err)?;
            Ok(run(
                Injectable::new(InverseModel { model, integrator }),
                &f,
                scenario,
                cycles,
            ))
        }
        (ModelSpec::CraneSubs(_), SchemeSpec::Radau) => {
            let model = CraneSubs::new(f.params, f.plan).map_err(err)?;
            let integrator = Radau::<f64, _, 7, 2, 21>::new(&model, &settings, 0.0).map_err(err)?;
            Ok(run(
                Injectable::new(InverseModel { model, integrator }),
                &f,
                scenario,
                cycles,
            ))
        }
        (ModelSpec::CraneProj(_), SchemeSpec::Bdf) => {
            let model = CraneProj::new(f.params, f.plan).map_err(err)?;
            let integrator =
                Bdf::<f64, _, 8, 2>::new(&model, &settings, scene.solver.k, 0.0).map_err(err)?;
            Ok(run(
                Injectable::new(InverseModel { model, integrator }),
                &f,
                scenario,
                cycles,
            ))
        }
        (ModelSpec::CraneProj(_), SchemeSpec::Radau) => {
            let model = CraneProj::new(f.params, f.plan).map_err(err)?;
            let integrator = Radau::<f64, _, 8, 2, 24>::new(&model, &settings, 0.0).map_err(err)?;
            Ok(run(
                Injectable::new(InverseModel { model, integrator }),
                &f,
                scenario,
                cycles,
            ))
        }
        (ModelSpec::MassOnCar(_), _) => Err("the firmware drives a crane".into()),
    }
}

fn run<F: Feedforward + Replan>(
    feedforward: Injectable<F>,
    f: &FirmwareScene,
    scenario: &Scenario,
    cycles: u32,
) -> Vec<ReferenceCycle> {
    let mut controller = Controller::new(feedforward, f.planner, f.config);
    let mut bus = VirtualBus::new(*scenario);
    let period_ms = f.config.period_ms;
    let mut after = 0;
    (0..cycles)
        .map(|cycle| {
            let now_ms = cycle * period_ms;
            let out = run_cycle(&mut controller, &mut bus, after, now_ms);
            after = now_ms;
            ReferenceCycle {
                now_ms,
                frames: out.frames.to_vec(),
                setpoints: out.setpoints,
                mode: out.mode,
            }
        })
        .collect()
}
