//! The std side: runs of solver-core over whole trajectories and the measures the
//! paper uses on them (Eq. 29's `e_max`), shared by the tests and the study CLI.

pub mod dbc;
pub mod extremes;
pub mod firmware;
pub mod paper;
pub mod plot;
pub mod root_locus;
pub mod run;
pub mod scenes;
pub mod study;
pub mod sweep;
