//! The exact answers that prove the schemes right.
//!
//! * [`flat_crane`] — the crane is differentially flat: `u_flat(t)` is exact (Eq. 29 measures against it).
//! * [`flat_crane3d`] — the same for the crane in three dimensions (bridge, trolley, hoist).
//! * [`emax`] — Eq. 29 for any number of inputs, without allocating.
//! * [`mass_on_car`] — `F_d` of Eq. 37 with `s_d` from the internal dynamics Eq. 38, integrated by
//!   [`dopri5`] at tight tolerance; the zero-dynamics eigenvalues and the breakaway angle (Eq. 39).
//! * [`plant`] — forward simulations of each plant (Eqs. 21–22, 31–32) driven by a computed input:
//!   the check the paper recommends ("applying the calculated control input in a forward-time integration").
//!
//! References run in `f64` whatever scalar the solver under test uses.

pub mod dopri5;
pub mod double_pendulum;
pub mod emax;
pub mod flat_crane;
pub mod flat_crane3d;
pub mod jet;
pub mod mass_on_car;
pub mod plant;
