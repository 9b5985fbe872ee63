//! The std side: runs of solver-core over whole trajectories and the measures the
//! paper uses on them (Eq. 29's `e_max`), shared by the tests and the study CLI.

/// The default scene: what the firmware, the virtual ECU (`ecu` without `--scene`), the
/// interop rig, `cargo xtask run`, the QEMU scenarios, the soak and the panic proof run
/// when none is named. The planar crane on the minimally extended formulation (*ext*,
/// index 1) with structured BDF4 at 10 ms, the configuration docs/RESULTS.md picks for it
/// ("Which configuration to pick"): the flat inverse to rounding where *subs* (index 3)
/// has a rounding floor. The paper's own scene (`scenes/paper-crane.toml`, *subs*) stays
/// what the paper's reproductions, the accuracy tests and the studies run.
pub const DEFAULT_SCENE: &str = "scenes/paper-crane-ext.toml";

pub mod crane3d_study;
pub mod dbc;
pub mod extremes;
pub mod feedback3d_study;
pub mod feedback_study;
pub mod firmware;
pub mod operator;
pub mod operator_study;
pub mod output;
pub mod paper;
/// The plant lives beside the virtual bus (the QEMU firmware runs it too).
pub use sim::plant;
/// The 3D crane's plant, beside the planar one.
pub use sim::plant3d;
pub mod plot;
pub mod root_locus;
pub mod run;
pub mod scenes;
pub mod study;
pub mod sweep;
pub mod trade;
