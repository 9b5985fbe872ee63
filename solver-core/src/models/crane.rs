//! The planar overhead crane of Sec. 3.1 (Fig. 2b): what both formulations share.
//!
//! Trolley position `x` and rope length `l` are driven by velocity set points
//! `u1`, `u2` through first-order actuators (time constants τ1, τ2, Eq. 22); the
//! load hangs at `(x_C, z_C)` with `z` pointing **down** (gravity is `+g e_z`).
//! The output is the load position (Eq. 27).

use nalgebra::SVector;

use crate::error::{check_positive, check_range, Error, Result};
use crate::scalar::{c, to_f64, Real};
use crate::trajectory::Trajectory;

/// The crane's workspace (Sec. 3.1.5: `x ∈ [10, 23] m`, `l ∈ [3, 9] m`).
///
/// With feature `serde`, a scene's `[model.workspace]` (a key left out: the paper's,
/// [`Workspace::PAPER`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields, default)
)]
pub struct Workspace {
    /// Smallest trolley position, m.
    pub x_min: f64,
    /// Largest trolley position, m.
    pub x_max: f64,
    /// Shortest rope, m.
    pub l_min: f64,
    /// Longest rope, m.
    pub l_max: f64,
}

impl Workspace {
    /// The laboratory crane's workspace of Sec. 3.1.5.
    pub const PAPER: Self = Self {
        x_min: 10.0,
        x_max: 23.0,
        l_min: 3.0,
        l_max: 9.0,
    };
}

/// The paper's: what a scene that names no workspace gets.
impl Default for Workspace {
    fn default() -> Self {
        Self::PAPER
    }
}

/// Crane parameters (Tab. 3) and the limits within which the inverse model is regular.
///
/// With feature `serde`, a scene's `[model]` for the planar crane, the workspace a table
/// of its own (a key left out: [`CraneParams::PAPER`]'s value).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields, default)
)]
pub struct CraneParams {
    /// Load mass m, kg (scales the rope force only; the inverse model is per unit mass).
    pub m: f64,
    /// Gravity g, m/s².
    pub g: f64,
    /// Trolley actuator time constant τ1, s.
    pub tau1: f64,
    /// Winch actuator time constant τ2, s.
    pub tau2: f64,
    /// Where trolley and rope may go.
    pub workspace: Workspace,
    /// Smallest admissible rope tension as a fraction of the load's weight: the
    /// desired downward acceleration must stay below `(1 − fraction)·g`. At zero the
    /// rope goes slack and the inverse model is singular.
    pub min_tension_fraction: f64,
}

/// Tab. 3's: what a scene that sets no parameter gets.
impl Default for CraneParams {
    fn default() -> Self {
        Self::PAPER
    }
}

impl CraneParams {
    /// Tab. 3 with the workspace of Sec. 3.1.5 and a 5 % tension margin.
    pub const PAPER: Self = Self {
        m: 18.9,
        g: 9.81,
        tau1: 0.03,
        tau2: 0.02,
        workspace: Workspace::PAPER,
        min_tension_fraction: 0.05,
    };

    /// Refuses non-finite or non-physical values.
    pub fn validate(&self) -> Result<()> {
        check_positive("m", self.m)?;
        check_positive("g", self.g)?;
        check_positive("tau1", self.tau1)?;
        check_positive("tau2", self.tau2)?;
        let w = &self.workspace;
        check_range("x_min", w.x_min, f64::MIN, w.x_max)?;
        check_range("x_max", w.x_max, w.x_min, f64::MAX)?;
        check_positive("l_min", w.l_min)?;
        check_range("l_max", w.l_max, w.l_min, f64::MAX)?;
        check_range("min_tension_fraction", self.min_tension_fraction, 0.0, 1.0)?;
        Ok(())
    }
}

/// The crane configuration that puts the load at `z` with acceleration `z̈`.
///
/// The load's equations of motion (rows 3–4 of Eq. 25) with the servo-constraint
/// substituted give `λ = (z̈_C − g)/(2 z_C)` and `x = x_C − ẍ_C/(2λ)`; Eq. 26 then
/// gives the rope length. This is the position level of the flat inverse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlatConfiguration<T> {
    /// Trolley position x, m.
    pub x: T,
    /// Rope length l, m.
    pub l: T,
    /// Constraint force per unit mass λ of Eq. 25 (negative: rope under tension), 1/s².
    pub lambda: T,
    /// Swing angle φ, rad.
    pub phi: T,
}

/// Position-level flat inverse (see [`FlatConfiguration`]). Singular when `z̈_C = g`.
#[must_use]
pub fn flat_configuration<T: Real>(
    g: T,
    z: &SVector<T, 2>,
    zdd: &SVector<T, 2>,
) -> FlatConfiguration<T> {
    let [xc, zc]: [T; 2] = (*z).into();
    let [xcdd, zcdd]: [T; 2] = (*zdd).into();
    let two = c::<T>(2.0);
    let lambda = (zcdd - g) / (two * zc);
    let x = xc - xcdd / (two * lambda);
    let dx = xc - x;
    let l = (zc * zc + dx * dx).sqrt();
    FlatConfiguration {
        x,
        l,
        lambda,
        phi: dx.atan2(zc),
    }
}

/// Samples taken along a move when checking it against the crane's limits.
pub const CHECK_SAMPLES: usize = 2000;

/// Checks a desired load trajectory against the rope-slack margin and the workspace.
///
/// The move is sampled at [`CHECK_SAMPLES`]` + 1` points of its active span (the
/// trajectory rests outside it, so its end points cover the rest of time).
pub fn check_trajectory<T: Real, Z: Trajectory<T, 2>>(p: &CraneParams, z: &Z) -> Result<()> {
    let g = c::<T>(p.g);
    let w = &p.workspace;
    check_load_path(p.g, p.min_tension_fraction, z, |zd, zdd| {
        let conf = flat_configuration(g, zd, zdd);
        [
            ("x", to_f64(conf.x), w.x_min, w.x_max),
            ("l", to_f64(conf.l), w.l_min, w.l_max),
        ]
    })
}

/// The checks every crane's load path must pass, sample by sample: the load below the
/// rope's exit (`z_C > 0`, the vertical output last in `z`), its downward acceleration
/// within the rope-slack margin, and then the crane coordinates that the position-level
/// flat inverse needs at `(z_d, z̈_d)` — `coordinates` returns them as
/// `(name, value, min, max)` — within their ranges. Shared by the planar crane and the
/// 3D one ([`crane3d`](crate::models::crane3d)): only the flat inverse and the workspace
/// differ between them.
pub(crate) fn check_load_path<T, const NZ: usize, const K: usize, Z>(
    g: f64,
    min_tension_fraction: f64,
    z: &Z,
    coordinates: impl Fn(&SVector<T, NZ>, &SVector<T, NZ>) -> [(&'static str, f64, f64, f64); K],
) -> Result<()>
where
    T: Real,
    Z: Trajectory<T, NZ>,
{
    let (t0, t1) = z.active_span();
    let limit = g * (1.0 - min_tension_fraction);
    let vertical = |v: &SVector<T, NZ>| v.iter().last().copied().map_or(f64::NAN, to_f64);
    for i in 0..=CHECK_SAMPLES {
        let t = t0 + (t1 - t0) * c::<T>(i as f64 / CHECK_SAMPLES as f64);
        let [zd, _, zdd] = z.derivatives::<3>(t);
        let tf = to_f64(t);
        let (zc, acc) = (vertical(&zd), vertical(&zdd));
        if zc.is_nan() || zc <= 0.0 {
            return Err(Error::OutsideWorkspace {
                t: tf,
                coordinate: "z_C",
                value: zc,
                min: 0.0,
                max: f64::INFINITY,
            });
        }
        if acc.is_nan() || acc > limit {
            return Err(Error::RopeSlack {
                t: tf,
                vertical_acceleration: acc,
                limit,
            });
        }
        for (coordinate, value, min, max) in coordinates(&zd, &zdd) {
            if !(min..=max).contains(&value) {
                return Err(Error::OutsideWorkspace {
                    t: tf,
                    coordinate,
                    value,
                    min,
                    max,
                });
            }
        }
    }
    Ok(())
}
