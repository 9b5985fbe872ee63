//! Servo-constraints inverse models for underactuated machines, solved in real time.
//!
//! This crate implements Otto & Seifried, *Analysis of Servo-constraints Solution
//! Approaches for Underactuated Multibody Systems* (`shared/paper/`): the output
//! of an underactuated system (the load of an overhead crane) is forced onto a
//! desired trajectory by servo-constraints appended to its equations of motion.
//! The resulting index-3 DAE `F(x, ẋ, t) = 0` (Eq. 12) is integrated with a fixed
//! step, and its solution contains the input `u` that makes the output follow.
//!
//! * [`trajectory`] — smooth point-to-point moves of degree 2n+1 (the paper's C4 polynomial is n = 4).
//! * [`model`] — the [`DaeModel`] trait; [`models`] — crane *subs* and *proj*, mass-on-car.
//! * [`schemes`] — BDF k = 1..6 (Eq. 16) and Radau IIA (Eqs. 13–15) with [`newton`] (J, J̃, exact).
//! * [`operator`] — operator mode's generator: a master switch's demand turned into a smooth load path.
//! * [`reference`](mod@reference) — the exact answers that prove the schemes right: the crane's flat
//!   inverse, the mass-on-car's internal dynamics (Eqs. 37–38), forward simulations.
//!
//! `no_std`, no heap, no `unsafe`; every failure is an [`Error`] with context.

#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod error;
mod linalg;
pub mod model;
pub mod models;
pub mod newton;
pub mod operator;
pub mod plan;
pub mod reference;
pub mod scalar;
pub mod schemes;
pub mod trajectory;

pub use error::{Error, Result};
pub use model::{DaeModel, Driven, Partials, StructuredJacobian};
pub use newton::{JacobianMode, NewtonSettings, NewtonStats};
pub use scalar::Real;
pub use schemes::{Bdf, Integrator, Radau, Scheme, SolverSettings, StepReport};
