//! What the firmware makes of a scene: the crane, the first plan, the planner of moves
//! on command and the cycle's timing — or why it refuses the scene. Shared by the
//! firmware's build script (which turns it into Rust) and the host's run of the
//! firmware's loop (`host_tests::firmware`), so both start from the same state.

use controller::feedforward::command_plan;
use controller::planner::Planner;
use controller::setpoint::DriveLimits;
use controller::Config;
use solver_core::models::crane::CraneParams;
use solver_core::plan::Plan;
use solver_core::trajectory::{PointToPoint, Trajectory};

use crate::{ModelSpec, ScalarSpec, Scene};

/// The firmware's setup of a crane scene.
#[derive(Debug, Clone, Copy)]
pub struct FirmwareScene {
    /// Crane parameters.
    pub params: CraneParams,
    /// The scene's move.
    pub first_move: PointToPoint<f64, 2>,
    /// The plan at t = 0: at rest at the move's start, the move planned. Moves on
    /// command have the smoothness `max(n, 5)` (`controller::feedforward::command_plan`).
    pub plan: Plan<f64, 2>,
    /// The planner of moves on command, with the lab drives' limits.
    pub planner: Planner,
    /// Timing and limits of the controller.
    pub config: Config,
    /// Cycles the scene runs (to its `t_end`).
    pub cycles: u32,
}

/// The firmware's setup of `scene`, or why the firmware cannot run it: not a crane, not
/// f64, or a move that breaks the planner's rules (docs/COMMANDS.md) — a scene's move
/// must pass the checks every commanded move passes.
pub fn firmware_scene(scene: &Scene) -> Result<FirmwareScene, String> {
    let crane = match &scene.model {
        ModelSpec::CraneSubs(c) | ModelSpec::CraneProj(c) => c,
        ModelSpec::MassOnCar(_) => {
            return Err("the firmware drives a crane; this scene is the mass-on-car".into())
        }
    };
    if scene.solver.scalar != ScalarSpec::F64 {
        return Err("the firmware plans moves in f64; this scene computes in f32".into());
    }
    let params = crane.params();
    let first_move = scene.trajectory2().map_err(|e| e.to_string())?;
    let mut plan = command_plan(first_move.start().into(), scene.trajectory.smoothness)
        .map_err(|e| e.to_string())?;
    plan.push(first_move).map_err(|e| e.to_string())?;
    let planner = Planner::new(params, DriveLimits::LAB);
    let (t0, t1) = first_move.active_span();
    planner.check(&first_move, t0, t1).map_err(|r| {
        format!("the scene's move breaks the planner's rule {r:?} (docs/COMMANDS.md)")
    })?;
    let period_ms = (scene.solver.h * 1000.0).round() as u32;
    if (f64::from(period_ms) / 1000.0 - scene.solver.h).abs() > 1e-12 {
        return Err(format!(
            "the firmware's cycle is a whole number of ms; h = {} s",
            scene.solver.h
        ));
    }
    Ok(FirmwareScene {
        params,
        first_move,
        plan,
        planner,
        config: Config {
            period_ms,
            ..Config::DEFAULT
        },
        cycles: scene.steps() as u32,
    })
}
