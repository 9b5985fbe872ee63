//! What the firmware makes of a scene: the crane, the first plan, the planner of moves
//! on command and the cycle's timing — or why it refuses the scene. Shared by the
//! firmware's build script (which turns it into Rust) and the host's run of the
//! firmware's loop (`host_tests::firmware`), so both start from the same state.

use controller::commissioning::NodeSetup;
use controller::feedforward::{command_plan, Axes, ReferenceOf};
use controller::planner::Planner;
use controller::Config;
use solver_core::plan::Plan;
use solver_core::trajectory::{PointToPoint, Trajectory};

use crate::commissioning::CommissioningFile;
use crate::dispatch::{trajectory, FirmwareCrane, FirmwareScheme};
use crate::Scene;

/// The firmware's watchdog period, ms: a cycle must be shorter.
pub const WATCHDOG_MS: u32 = 100;

/// How long commissioning both drives takes, s, at `period_ms` per cycle: one SDO
/// exchange per cycle for every write and its read-back and the reads around them, the
/// drives' first heartbeat after their start, and the CiA 402 enable sequence. A scene's
/// move that starts earlier would ask for motion from drives not yet enabled.
#[must_use]
pub fn commissioning_time(config: &Config) -> f64 {
    let drives = || {
        config.nodes.iter().flatten().filter_map(|n| match n {
            NodeSetup::Drive(_, d) => Some(d),
            NodeSetup::Inclinometer(_) => None,
        })
    };
    let writes = drives()
        .map(|d| controller::commissioning::configuration(d, config.node, 10).len())
        .max()
        .unwrap_or(0);
    let exchanges = 2 * writes + 10;
    let heartbeat = drives()
        .map(|d| f64::from(d.heartbeat_ms))
        .fold(0.0, f64::max);
    (exchanges as f64 * f64::from(config.period_ms) + heartbeat) / 1000.0
}

/// The firmware's setup of a crane scene: crane `K` with `A` driven axes.
#[derive(Debug, Clone, Copy)]
pub struct FirmwareScene<K, const A: usize> {
    /// Crane parameters.
    pub params: K,
    /// The scene's move.
    pub first_move: PointToPoint<f64, A>,
    /// The plan at t = 0: at rest at the move's start, the move planned. Moves on
    /// command have the smoothness `max(n, 5)` (`controller::feedforward::command_plan`).
    pub plan: Plan<f64, A>,
    /// The planner of moves on command, with each drive's set-point limits (the
    /// commissioning file's, [`FirmwareCrane::LIMITS`] where it names none).
    pub planner: Planner<K, A>,
    /// Timing and the nodes of the controller.
    pub config: Config,
    /// Cycles the scene runs (to its `t_end`).
    pub cycles: u32,
    /// The state feedback, if the scene closes the loop (its inclinometer is then in
    /// `config`).
    pub feedback: Option<controller::feedback::Config>,
    /// The integrator the firmware links.
    pub scheme: FirmwareScheme,
}

impl<K, const A: usize> FirmwareScene<K, A> {
    /// Where the load rests at power-up: where the scene's move starts (`[x_C, z_C]`,
    /// the 3D crane's `[x_C, y_C, z_C]`). At rest the drives stand there too (trolley
    /// and bridge under the load, the rope as long as the load is deep).
    #[must_use]
    pub fn start(&self) -> [f64; A] {
        self.first_move.start().into()
    }
}

/// The firmware's setup of `scene` for crane `K` with the drives of `commissioning`, or
/// why the firmware cannot run it: not this crane, not f64 ([`FirmwareScheme::of`]), a
/// cycle the watchdog or the ms timer cannot keep, a run that is not a whole number of
/// cycles, a bad commissioning file (a drive of the crane missing, a drive it does not
/// have), a `[feedback]` the crane cannot honour, a move that starts before the drives
/// can be enabled, or one that breaks the planner's rules (docs/COMMANDS.md) — a scene's
/// move must pass the checks every commanded move passes. [`crate::dispatch::firmware`]
/// picks `K` from the scene.
pub fn firmware_scene<K: FirmwareCrane<A>, const A: usize>(
    scene: &Scene,
    commissioning: &CommissioningFile,
) -> Result<FirmwareScene<K, A>, String>
where
    Axes<A>: ReferenceOf,
{
    let scheme = FirmwareScheme::of(scene)?;
    let params = K::of(&scene.model).ok_or("the scene's model is not this crane's")?;
    let first_move = trajectory::<f64, A>(scene).map_err(|e| e.to_string())?;
    let mut plan = command_plan(first_move.start().into(), scene.trajectory.smoothness)
        .map_err(|e| e.to_string())?;
    plan.push(first_move).map_err(|e| e.to_string())?;
    // Each drive's set-point limits: its commissioning row's, the crane's lab drive's
    // where the row names none — the planner's and the gate's.
    let limits = commissioning
        .limits_for(K::DRIVES, K::LIMITS)
        .map_err(|e| format!("commissioning file: {e}"))?;
    let planner = Planner::with_axes(params, limits);
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
    if period_ms >= WATCHDOG_MS {
        return Err(format!(
            "h = {} s is not shorter than the watchdog's {WATCHDOG_MS} ms: every cycle would reset the controller",
            scene.solver.h
        ));
    }
    let cycles = scene.trajectory.t_end / scene.solver.h;
    if (cycles - cycles.round()).abs() > 1e-9 * cycles.max(1.0) {
        return Err(format!(
            "h = {} s does not divide t_end = {} s: the run would stop short",
            scene.solver.h, scene.trajectory.t_end
        ));
    }
    let config = commissioning
        .config_for(K::DRIVES, limits, period_ms)
        .map_err(|e| format!("commissioning file: {e}"))?;
    let feedback = scene
        .feedback
        .map(|f| K::feedback_config(&f, &params, scene.solver.h))
        .transpose()?;
    let config = if feedback.is_some() {
        commissioning
            .with_inclinometer_of(config, K::SWING_AXES)
            .map_err(|e| format!("commissioning file: {e}"))?
    } else {
        config
    };
    let ready = commissioning_time(&config);
    if scene.trajectory.t_start < ready {
        return Err(format!(
            "the move starts at {} s, before the drives can be commissioned and enabled ({ready:.2} s at h = {} s)",
            scene.trajectory.t_start, scene.solver.h
        ));
    }
    Ok(FirmwareScene {
        params,
        first_move,
        plan,
        planner,
        config,
        cycles: scene.steps() as u32,
        feedback,
        scheme,
    })
}

/// The scene's solver settings as a Rust constant expression (what the firmware's build
/// script writes, and the fuzzer's: `scene.settings()` spelled out).
#[must_use]
pub fn settings_source(scene: &Scene) -> String {
    let settings = scene.settings();
    let nw = settings.newton;
    let jacobian = match settings.jacobian {
        solver_core::JacobianMode::Transformed => {
            "solver_core::JacobianMode::Transformed".to_string()
        }
        solver_core::JacobianMode::FiniteDifference => {
            "solver_core::JacobianMode::FiniteDifference".to_string()
        }
        solver_core::JacobianMode::Exact => "solver_core::JacobianMode::Exact".to_string(),
        solver_core::JacobianMode::Broyden { reinit_every } => {
            format!("solver_core::JacobianMode::Broyden {{ reinit_every: {reinit_every:?} }}")
        }
    };
    format!(
        "solver_core::SolverSettings {{ h: {:?}, jacobian: {jacobian}, scaling_power: {}, newton: solver_core::NewtonSettings {{ max_iterations: {}, rtol: {:?}, atol: {:?}, stall_ratio: {:?}, stall_limit: {:?}, accept_unconverged: {:?}, broyden_refresh: {:?} }} }}",
        settings.h, settings.scaling_power, nw.max_iterations, nw.rtol, nw.atol, nw.stall_ratio, nw.stall_limit, nw.accept_unconverged, nw.broyden_refresh
    )
}

/// `config` as a Rust constant expression, for the firmware's generated scene module:
/// the same values the host's run of the firmware loop uses, built by the same
/// [`CommissioningFile::config_for`]. (The fault thresholds are [`Config::DEFAULT`]'s;
/// the check below refuses a config that differs there. The drives' limits are the
/// planner's, [`FirmwareCrane::LIMITS`].)
pub fn config_source(config: &Config) -> Result<String, String> {
    let defaults = Config {
        period_ms: config.period_ms,
        node: config.node,
        role: config.role,
        heartbeat_period_ms: config.heartbeat_period_ms,
        heartbeat_timeout_ms: config.heartbeat_timeout_ms,
        tpdo_timeout_ms: config.tpdo_timeout_ms,
        sdo_timeout_ms: config.sdo_timeout_ms,
        nodes: config.nodes,
        ..Config::DEFAULT
    };
    if defaults != *config {
        return Err("the firmware takes its fault thresholds from Config::DEFAULT".into());
    }
    let drive = |d: &controller::commissioning::DriveSetup| {
        let mode = match d.mode {
            controller::commissioning::OperationMode::CyclicSynchronousVelocity => {
                "CyclicSynchronousVelocity"
            }
            controller::commissioning::OperationMode::ProfileVelocity => "ProfileVelocity",
        };
        format!(
            "controller::commissioning::DriveSetup {{ node: {}, mode: controller::commissioning::OperationMode::{mode}, heartbeat_ms: {}, controller_timeout_ms: {}, quick_stop_option: {}, abort_connection_option: {}, quick_stop_deceleration: {}, max_velocity: {}, velocity_unit: {:?}, profile_ramp: {:?}, position_scale: {:?}, position_offset: {:?} }}",
            d.node,
            d.heartbeat_ms,
            d.controller_timeout_ms,
            d.quick_stop_option,
            d.abort_connection_option,
            d.quick_stop_deceleration,
            d.max_velocity,
            d.velocity_unit,
            d.profile_ramp,
            d.position_scale,
            d.position_offset
        )
    };
    let role = match config.role {
        controller::node::Role::Manager => "Manager",
        controller::node::Role::Slave => "Slave",
    };
    let node = |n: &Option<NodeSetup>| {
        match n {
        None => "None".to_string(),
        Some(NodeSetup::Drive(axis, d)) => {
            format!("Some(controller::commissioning::NodeSetup::Drive(controller::drive::Drive::{axis:?}, {}))", drive(d))
        }
        Some(NodeSetup::Inclinometer(i)) => format!(
            "Some(controller::commissioning::NodeSetup::Inclinometer(controller::commissioning::InclinometerSetup {{ node: {}, resolution: {}, heartbeat_ms: {}, sign: {:?}, offset_deg: {:?}, lateral: {} }}))",
            i.node, i.resolution, i.heartbeat_ms, i.sign, i.offset_deg,
            match i.lateral {
                None => "None".to_string(),
                Some(l) => format!("Some(controller::commissioning::LateralAxis {{ sign: {:?}, offset_deg: {:?} }})", l.sign, l.offset_deg),
            }
        ),
    }
    };
    let nodes = config.nodes.iter().map(node).collect::<Vec<_>>().join(", ");
    Ok(format!(
        "controller::Config {{ period_ms: {}, node: {}, role: controller::node::Role::{role}, heartbeat_period_ms: {}, heartbeat_timeout_ms: {}, tpdo_timeout_ms: {}, sdo_timeout_ms: {}, nodes: [{nodes}], ..controller::Config::DEFAULT }}",
        config.period_ms,
        config.node,
        config.heartbeat_period_ms,
        config.heartbeat_timeout_ms,
        config.tpdo_timeout_ms,
        config.sdo_timeout_ms,
    ))
}
