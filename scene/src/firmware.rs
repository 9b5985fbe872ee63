//! What the firmware's build scripts write of a scene's setup: its configuration and its
//! solver settings as Rust constant expressions. The setup itself — the crane, the first
//! plan, the planner of moves on command, the cycle's timing, or why the firmware refuses
//! the scene — is built beside the dispatch that makes the scene's crane a type
//! ([`crate::dispatch::firmware_scene`]), shared by the build script and the host's run of
//! the firmware's loop (`host_tests::firmware`), so both start from the same state.

use controller::commissioning::NodeSetup;
use controller::Config;

use crate::Scene;

// The firmware's setup of a scene lives beside the dispatch that makes its crane a
// type (`crate::dispatch`); it is named here too, where the code generation is.
pub use crate::dispatch::{commissioning_time, firmware_scene, FirmwareScene, WATCHDOG_MS};

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
/// planner's, [`Crane::LAB_LIMITS`].)
///
/// [`CommissioningFile::config_for`]: crate::commissioning::CommissioningFile::config_for
/// [`Crane::LAB_LIMITS`]: controller::crane::Crane::LAB_LIMITS
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
            "controller::commissioning::DriveSetup {{ node: {}, mode: controller::commissioning::OperationMode::{mode}, heartbeat_ms: {}, controller_timeout_ms: {}, quick_stop_option: {}, abort_connection_option: {}, quick_stop_deceleration: {}, max_velocity: {}, velocity_unit: {:?}, profile_ramp: {:?}, position_scale: {:?}, position_offset: {:?}, motion: controller::motion::MotionWindows {{ standstill: {:?}, standstill_delay_ms: {}, following: {:?}, following_drift: {:?}, velocity: {:?}, following_time_ms: {}, in_place: {:?} }} }}",
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
            d.position_offset,
            d.motion.standstill,
            d.motion.standstill_delay_ms,
            d.motion.following,
            d.motion.following_drift,
            d.motion.velocity,
            d.motion.following_time_ms,
            d.motion.in_place,
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
