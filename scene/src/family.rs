//! What the formulations of one model share, whatever the formulation: the facts the
//! studies need of a model besides its type (its name, its exact reference, when a run
//! of it counts as inaccurate), one impl per parameter type, in the model's own file
//! here (each crane's under `cranes/`, the mass-on-car's in `mass_on_car.rs`).
//!
//! `model_specs!` (`lib.rs`) names each parameter type with its number of outputs and
//! builds the study's [`ModelVisitor`] dispatch, the scene's reference and the accuracy
//! threshold from this trait: a parameter type listed there without its impl does not
//! compile.

use core::fmt;

use solver_core::trajectory::PointToPoint;
use solver_core::{DaeModel, Error, Real};

/// What is done with a scene's model, whatever model it is (the studies).
pub trait ModelVisitor<T: Real> {
    /// What it gives.
    type Output;
    /// Does it with `model` (`N` unknowns, `NU` inputs, `S = 3N` for Radau's stage
    /// system), driven by the scene's move in `T`.
    fn visit<M: DaeModel<T, N, NU>, const N: usize, const NU: usize, const S: usize>(
        self,
        model: M,
    ) -> Self::Output;
}

/// The facts every formulation of a model with these parameters shares; `NZ` outputs
/// (the move's axes: `[x_C, z_C]`, `[x_C, y_C, z_C]`, `[z]`).
pub trait ModelFamily<const NZ: usize>: Copy {
    /// How refusals name it ("the planar crane").
    const NAME: &'static str;
    /// The e_max of Eq. 29 above which a run counts as inaccurate, in its inputs' unit.
    const ACCURACY_THRESHOLD: f64;
    /// The table a scene writes its crane's keys in (`m`, `tau1`, its workspace):
    /// `model`, or for a model that nests a crane's parameters the nested table
    /// (`model.crane`), so that a refusal names the key as the file spells it.
    const CRANE_KEYS_UNDER: &'static str = "model";
    /// Its exact inputs along a move: what Eq. 29 measures every formulation against.
    type Exact: ExactInputs + 'static;
    /// Its exact inputs along `z`, or why there are none (a refused parameter).
    fn exact(self, z: PointToPoint<f64, NZ>) -> Result<Self::Exact, Error>;
}

/// A model's exact inputs along a move, sample by sample, in f64.
pub trait ExactInputs: fmt::Debug {
    /// The exact inputs at `t`, appended to `out` (`t` never decreases between calls).
    fn at(&mut self, t: f64, out: &mut Vec<f64>) -> Result<(), Error>;
}

/// A flat model's exact inputs: its closed-form flat inverse of the move `z` (Eq. 29's
/// reference where the model is flat: the cranes').
#[derive(Debug, Clone, Copy)]
pub struct Flat<P, const NZ: usize> {
    /// The model's parameters.
    pub params: P,
    /// The move.
    pub z: PointToPoint<f64, NZ>,
}
