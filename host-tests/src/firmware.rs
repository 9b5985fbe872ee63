//! The firmware's cycle, run on the host: the same controller, the same scene, the
//! same scripted bus. The QEMU run must send exactly these set points.

use controller::units::Setpoint;
use controller::virtual_bus::Script;
use controller::{CanFrame, Config, Controller, Feedforward, InverseModel, Mode};
use scene::{ModelSpec, ScalarSpec, Scene, SchemeSpec};
use solver_core::models::crane_proj::CraneProj;
use solver_core::models::crane_subs::CraneSubs;
use solver_core::trajectory::PointToPoint;
use solver_core::{Bdf, Radau, Real};

/// One cycle as the firmware runs it.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceCycle {
    /// Time of the cycle, ms.
    pub now_ms: u32,
    /// Frames sent.
    pub frames: Vec<CanFrame>,
    /// `[trolley, winch]` set points, drive units.
    pub setpoints: [Setpoint; 2],
    /// Supervisor state after the cycle.
    pub mode: Mode,
}

/// Runs the firmware's loop for a crane scene on `script`: every cycle the frames due
/// since the last one, then the tick.
pub fn controller_reference(scene: &Scene, script: &Script) -> Result<Vec<ReferenceCycle>, String> {
    match scene.solver.scalar {
        ScalarSpec::F64 => reference_in::<f64>(scene, script),
        ScalarSpec::F32 => reference_in::<f32>(scene, script),
    }
}

fn reference_in<T: Real>(scene: &Scene, script: &Script) -> Result<Vec<ReferenceCycle>, String> {
    let tr = scene.trajectory2().map_err(|e| e.to_string())?;
    let trajectory = PointToPoint::<T, 2>::new(
        tr.start().map(nalgebra::convert),
        tr.end().map(nalgebra::convert),
        nalgebra::convert(tr.t_start()),
        nalgebra::convert(tr.duration()),
        scene.trajectory.smoothness,
    )
    .map_err(|e| e.to_string())?;
    let settings = scene.settings();
    let err = |e: solver_core::Error| e.to_string();
    let t0 = T::zero();
    match (&scene.model, scene.solver.scheme) {
        (ModelSpec::CraneSubs(c), SchemeSpec::Bdf) => {
            let model = CraneSubs::new(c.params(), trajectory).map_err(err)?;
            let integrator =
                Bdf::<T, _, 7, 2>::new(&model, &settings, scene.solver.k, t0).map_err(err)?;
            Ok(cycles(InverseModel { model, integrator }, scene, script))
        }
        (ModelSpec::CraneSubs(c), SchemeSpec::Radau) => {
            let model = CraneSubs::new(c.params(), trajectory).map_err(err)?;
            let integrator = Radau::<T, _, 7, 2, 21>::new(&model, &settings, t0).map_err(err)?;
            Ok(cycles(InverseModel { model, integrator }, scene, script))
        }
        (ModelSpec::CraneProj(c), SchemeSpec::Bdf) => {
            let model = CraneProj::new(c.params(), trajectory).map_err(err)?;
            let integrator =
                Bdf::<T, _, 8, 2>::new(&model, &settings, scene.solver.k, t0).map_err(err)?;
            Ok(cycles(InverseModel { model, integrator }, scene, script))
        }
        (ModelSpec::CraneProj(c), SchemeSpec::Radau) => {
            let model = CraneProj::new(c.params(), trajectory).map_err(err)?;
            let integrator = Radau::<T, _, 8, 2, 24>::new(&model, &settings, t0).map_err(err)?;
            Ok(cycles(InverseModel { model, integrator }, scene, script))
        }
        (ModelSpec::MassOnCar(_), _) => {
            Err("the firmware drives a crane; this scene is the mass-on-car".into())
        }
    }
}

fn cycles<F: Feedforward>(feedforward: F, scene: &Scene, script: &Script) -> Vec<ReferenceCycle> {
    let period_ms = (scene.solver.h * 1000.0).round() as u32;
    let mut controller = Controller::new(
        feedforward,
        Config {
            period_ms,
            ..Config::DEFAULT
        },
    );
    let mut last = 0;
    (0..scene.steps() as u32)
        .map(|cycle| {
            let now_ms = cycle * period_ms;
            for frame in script.due(last, now_ms) {
                controller.on_frame(&frame, now_ms);
            }
            last = now_ms;
            let out = controller.tick(now_ms);
            ReferenceCycle {
                now_ms,
                frames: out.frames.to_vec(),
                setpoints: out.setpoints,
                mode: out.mode,
            }
        })
        .collect()
}
