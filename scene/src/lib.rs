//! Scene files. A scene is one model with its parameters, one desired trajectory
//! and the solver settings — everything a run (on the host or in the firmware) needs.
//!
//! ```toml
//! name = "paper-crane-bdf4"
//! description = "…"
//!
//! [model]
//! kind = "crane-subs"        # crane-subs | crane-proj | crane-ext | mass-on-car |
//!                            # mass-on-car-ext | crane3d-subs | crane3d-ext
//! tau1 = 0.03                # optional parameters (below); the model's defaults
//!
//! [model.workspace]          # optional: where the crane may go (the 3D crane's too)
//! l_max = 9.0
//!
//! [trajectory]
//! start = [12.0, 8.0]        # one value per output axis: [x_C, z_C] m, [x_C, y_C, z_C] m, or [z] m
//! end = [20.0, 4.0]
//! t_start = 1.0              # s
//! duration = 8.0             # s
//! smoothness = 4             # n: degree 2n + 1, derivatives 1..n vanish at the ends
//! t_end = 10.0               # s, total simulated time
//!
//! [solver]
//! scheme = "bdf"             # bdf | radau
//! k = 4                      # bdf only, 1..6
//! h = 0.01                   # s
//! jacobian = "exact"         # fd | broyden | exact
//! reinit_every = 10          # broyden only; omit for continuous updating (J̃)
//! newton = "full"            # full | transformed (radau with exact only: RADAU5's
//!                            # transformed simplified Newton)
//! rho_power = 2              # algebraic rows scaled by h^-p, p in 0..3
//! max_iterations = 20
//! scalar = "f64"             # f64 | f32
//! ```
//!
//! The model's parameters are solver-core's own types, read by their derives (its feature
//! `serde`); a key left out keeps the model's default, at every depth ([`Params`]):
//! - the planar crane, `crane-*` (`CraneParams::PAPER`: Tab. 3): `m`, `g`, `tau1`, `tau2`,
//!   `min_tension_fraction`; in `[model.workspace]` `x_min`, `x_max`, `l_min`, `l_max`;
//! - the 3D crane, `crane3d-*` (`Crane3dParams::EXAMPLE`): `m`, `g`, `tau1`, `tau2`, `tau3`,
//!   `min_tension_fraction`; in `[model.workspace]` `x_min`, `x_max`, `y_min`, `y_max`,
//!   `l_min`, `l_max`;
//! - the hook-and-load crane, `double-pendulum-*` (`DoublePendulumParams::EXAMPLE`):
//!   `hook_mass`, `sling`; the planar crane's keys in `[model.crane]`, its workspace in
//!   `[model.crane.workspace]`;
//! - the mass-on-car, `mass-on-car*` (`MassOnCarParams::PAPER`: Tab. 4, α = 15°): `m1`,
//!   `m2`, `k`, `d`, `alpha_deg` (degrees).
//!
//! A malformed or physically impossible scene is refused with a [`SceneError`]
//! that names the field and the reason (the checks of a whole scene: `check.rs`).
//!
//! The crate is also the registry of the cranes ([`cranes`]: one file each, everything a
//! crane is). Its default feature `host` is everything above; without it the crate is
//! `#![no_std]` and builds only the crane types and their `no_std` impls, which is what
//! the firmware, the panic proof and the fuzzer link of it.

#![cfg_attr(not(feature = "host"), no_std)]

#[cfg(feature = "host")]
mod check;
#[cfg(feature = "host")]
pub mod commissioning;
pub mod cranes;
#[cfg(feature = "host")]
pub mod dispatch;
#[cfg(feature = "host")]
pub mod family;
#[cfg(feature = "host")]
pub mod feedback;
#[cfg(feature = "host")]
pub mod firmware;
#[cfg(feature = "host")]
mod mass_on_car;
#[cfg(feature = "host")]
pub mod operator;
#[cfg(feature = "host")]
mod params;
#[cfg(feature = "host")]
pub mod rust_source;
#[cfg(feature = "host")]
mod scene_file;
#[cfg(feature = "host")]
mod side_by_side;

#[cfg(feature = "host")]
pub use scene_file::*;
