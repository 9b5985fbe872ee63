//! The cranes the virtual bus can simulate, keyed on the crane type as the controller is
//! ([`controller::crane::Crane`]): which plant a scenario with a plant runs on, built
//! from the crane's own parameters, and how the plant's sensed state reaches the drives'
//! position actual and the inclinometer. The bus never decides by its drive list which
//! crane it carries.
//!
//! The traits live here, and the plants' physics beside them (`plant.rs`, `plant3d.rs`,
//! `plant_dp.rs`); which plant a crane runs on is its [`Simulated`] impl, in the crane's
//! own file (`scene::cranes`), with everything else that crane is.

use controller::crane::Crane;

use crate::mismatch::Mismatch;

/// What a plant's sensors read at the end of a cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensed<const A: usize> {
    /// Each drive's position and velocity, m and m/s, in the model's input order: its
    /// drive's position and velocity actual.
    pub motion: [(f64, f64); A],
    /// The inclinometer's slopes, degrees: long (x–z plane) and lateral (y–z plane; 0
    /// for a one-axis inclinometer).
    pub slope_deg: [f64; 2],
}

/// A plant's true state, without its sensors' noise, filter or delay: what a view draws
/// and a test judges the crane by. Each in the slots `[x, y, z]` of the operator frame
/// (a planar crane's y is 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrueState {
    /// Where the drives stand: bridge (planar: trolley) x, trolley y, the drum's rope
    /// length, m.
    pub drives: [f64; 3],
    /// The load `[x_C, y_C, z_C]`, m, `z_C` its depth below the rope's exit.
    pub load: [f64; 3],
    /// The rope's slopes in the x–z and y–z planes, rad (the swing; the hook-and-load
    /// crane's: the hoist rope's, where its inclinometer sits).
    pub swing: [f64; 2],
}

/// A simulated crane that the drives move.
pub trait CranePlant<const A: usize> {
    /// Advances `dt` with each drive's velocity command `u` (m/s), the drives in
    /// `braked` held by their brakes.
    fn advance_braked(&mut self, u: [f64; A], dt: f64, braked: [bool; A]);
    /// What its sensors read now, with their noise, filter and delay.
    fn sense(&mut self) -> Sensed<A>;
    /// Its true state now.
    fn true_state(&self) -> TrueState;
}

/// A crane the virtual bus simulates in scenarios with a plant.
pub trait Simulated<const A: usize>: Crane<A> + Copy + core::fmt::Debug {
    /// Its plant.
    type Plant: CranePlant<A> + Clone + core::fmt::Debug;
    /// The plant of this crane with the scenario's `mismatch`, at rest with the drives
    /// at `start` (model input order).
    fn plant(&self, mismatch: Mismatch, start: [f64; A]) -> Self::Plant;
}
