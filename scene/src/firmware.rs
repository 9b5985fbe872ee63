//! What the firmware's build scripts write of a scene's setup beyond single values (those
//! are [`crate::rust_source::ToRust`]'s): the controller's configuration, its fault
//! thresholds left at `Config::DEFAULT`. The setup itself — the crane, the first
//! plan, the planner of moves on command, the cycle's timing, or why the firmware refuses
//! the scene — is built beside the dispatch that makes the scene's crane a type
//! ([`crate::dispatch::firmware_scene`]), shared by the build script and the host's run of
//! the firmware's loop (`host_tests::firmware`), so both start from the same state.

use controller::Config;

use crate::cranes::FirmwareError;
use crate::rust_source::struct_literal;

// The firmware's setup of a scene lives beside the dispatch that makes its crane a
// type (`crate::dispatch`); it is named here too, where the code generation is.
pub use crate::dispatch::{commissioning_time, firmware_scene, FirmwareScene, WATCHDOG_MS};

/// The default scene: the planar crane's, named in its file (`crate::cranes::planar`),
/// the first of its `QEMU_SCENES`.
pub use crate::cranes::planar::DEFAULT_SCENE;

/// `config` as a Rust constant expression, for the firmware's generated scene module:
/// the same values the host's run of the firmware loop uses, built by the same
/// [`CommissioningFile::config_for`]. (The fault thresholds are [`Config::DEFAULT`]'s;
/// the check below refuses a config that differs there. The drives' limits are the
/// planner's, [`Crane::LAB_LIMITS`].)
///
/// [`CommissioningFile::config_for`]: crate::commissioning::CommissioningFile::config_for
/// [`Crane::LAB_LIMITS`]: controller::crane::Crane::LAB_LIMITS
pub fn config_source(config: &Config) -> Result<String, FirmwareError> {
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
        return Err(FirmwareError::ThresholdsNotDefault);
    }
    let Config {
        period_ms,
        node,
        role,
        heartbeat_period_ms,
        heartbeat_timeout_ms,
        tpdo_timeout_ms,
        sdo_timeout_ms,
        nodes,
        ..
    } = config;
    Ok(struct_literal(
        "controller::Config",
        &[
            ("period_ms", period_ms),
            ("node", node),
            ("role", role),
            ("heartbeat_period_ms", heartbeat_period_ms),
            ("heartbeat_timeout_ms", heartbeat_timeout_ms),
            ("tpdo_timeout_ms", tpdo_timeout_ms),
            ("sdo_timeout_ms", sdo_timeout_ms),
            ("nodes", nodes),
        ],
        Some("controller::Config::DEFAULT"),
    ))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// The default configuration is written on `Config::DEFAULT`; one whose fault
    /// thresholds differ is refused, typed, never written with the default's.
    #[test]
    fn only_the_default_fault_thresholds_are_written() {
        let source = config_source(&Config::DEFAULT).unwrap();
        assert!(source.starts_with("controller::Config {"), "{source}");
        assert!(
            source.ends_with("..controller::Config::DEFAULT }"),
            "{source}"
        );
        let other = Config {
            overspeed: Config::DEFAULT.overspeed * 2.0,
            ..Config::DEFAULT
        };
        assert_eq!(
            config_source(&other).unwrap_err(),
            FirmwareError::ThresholdsNotDefault
        );
    }
}
