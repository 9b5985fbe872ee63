//! The std side: runs of solver-core over whole trajectories and the measures the
//! paper uses on them (Eq. 29's `e_max`), shared by the tests and the study CLI.

/// The default scene ([`scene::firmware::DEFAULT_SCENE`]: the firmware's build script
/// reads it from there).
pub use scene::firmware::DEFAULT_SCENE;

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
pub mod rope_pair;
pub mod run;
pub mod scenes;
pub mod study;
pub mod sweep;
pub mod trade;
