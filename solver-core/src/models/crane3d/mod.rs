//! The overhead crane in three dimensions: bridge, trolley and hoist.
//!
//! The planar crane of Sec. 3.1 (Fig. 2b) moves its trolley along one axis. An EOT
//! (electric overhead travelling) crane has two horizontal axes: the **bridge** runs
//! along the hall on its runway (position `x`), the **trolley** runs across on the
//! bridge (position `y`), and the **hoist** on the trolley sets the rope length `l`.
//! Each is driven by a velocity set point through a first-order lag (time constants
//! τ1, τ2, τ3), as the trolley and the winch of Eq. 22 are. The load hangs at
//! `(x_C, y_C, z_C)`, `z` pointing **down** from the rope's exit at the trolley
//! (gravity `+g e_z`) as in the planar crane. The output is the load position, the
//! 3D counterpart of Eq. 27; what this module holds is what every formulation of it
//! shares — parameters, workspace, the position-level flat inverse and the check of a
//! desired load path. The *subs* inverse model is [`subs`], its minimal extension to
//! index 1 [`ext`].
//!
//! ## The load's equations per unit mass (the 3D Eqs. 25–26)
//!
//! The rope from the trolley at `(x, y, 0)` to the load constrains
//!
//! ```text
//! c = (x_C − x)² + (y_C − y)² + z_C² − l² = 0                           (26, 3D)
//! ```
//!
//! and the load's Lagrangian per unit mass with the constraint appended is
//! `L = ½ (ẋ_C² + ẏ_C² + ż_C²) + g z_C + λ c` (`z` down: the potential is `−g z_C`).
//! Its Euler–Lagrange equations in `x_C, y_C, z_C` are the 3D rows 3–4 of Eq. 25:
//!
//! ```text
//! ẍ_C = 2 (x_C − x) λ,    ÿ_C = 2 (y_C − y) λ,    z̈_C = g + 2 z_C λ,
//! ```
//!
//! the rope force per unit mass `2 λ (x_C − x, y_C − y, z_C)`: along the rope, and
//! pulling the load towards the trolley for `λ < 0` (tension; `−2 λ l` per unit mass,
//! `λ = −g/(2 z_C)` at rest). The drives' rows have no λ, as rows 1–2 of Eq. 25 have
//! none: their velocity loops take the rope's reaction.
//!
//! ## Flatness
//!
//! With the load position as the flat output, the vertical equation gives
//! `λ = (z̈_C − g)/(2 z_C)`, the horizontal ones `x = x_C − ẍ_C/(2λ)` and
//! `y = y_C − ÿ_C/(2λ)`, the constraint `l` ([`flat_configuration`]), and the drives'
//! rows the inputs `u_i = τ_i q̈_i + q̇_i`
//! ([`flat_crane3d`](crate::reference::flat_crane3d)). With `y_C ≡ y ≡` const it is
//! the planar crane of Eqs. 24–26, the bridge in the planar trolley's place and the
//! hoist in the winch's ([`Crane3dParams::extruded`]).

use nalgebra::SVector;

use crate::error::{check_positive, check_range, Result};
use crate::models::crane::{check_load_path, CraneParams, Workspace};
use crate::scalar::{c, to_f64, Real};
use crate::trajectory::Trajectory;

pub mod ext;
pub mod subs;

pub use ext::{Crane3dExt, Ext3dFactors};
pub use subs::{Crane3dSubs, Subs3dFactors, N, NU};

/// Where bridge, trolley and rope may go.
///
/// With feature `serde`, a 3D scene's `[model.workspace]` (a key left out:
/// [`Workspace3d::EXAMPLE`]'s value).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields, default)
)]
pub struct Workspace3d {
    /// Smallest bridge position, m.
    pub x_min: f64,
    /// Largest bridge position, m.
    pub x_max: f64,
    /// Smallest trolley position, m.
    pub y_min: f64,
    /// Largest trolley position, m.
    pub y_max: f64,
    /// Shortest rope, m.
    pub l_min: f64,
    /// Longest rope, m.
    pub l_max: f64,
}

/// The assumed hall: what a 3D scene that names no workspace gets.
impl Default for Workspace3d {
    fn default() -> Self {
        Self::EXAMPLE
    }
}

impl Workspace3d {
    /// An assumed hall: the laboratory crane's trolley travel of Sec. 3.1.5
    /// (`[10, 23] m`) as the bridge's runway, an 8 m span for the trolley and the
    /// laboratory rope lengths `[3, 9] m`. Not from the paper, which is planar.
    pub const EXAMPLE: Self = Self::extruded(Workspace::PAPER, 0.0, 8.0);

    /// A planar workspace given a trolley axis across it: the planar trolley's range
    /// becomes the bridge's, its rope lengths stay.
    #[must_use]
    pub const fn extruded(planar: Workspace, y_min: f64, y_max: f64) -> Self {
        Self {
            x_min: planar.x_min,
            x_max: planar.x_max,
            y_min,
            y_max,
            l_min: planar.l_min,
            l_max: planar.l_max,
        }
    }
}

/// The 3D crane's parameters and the limits within which the inverse model is regular.
///
/// With feature `serde`, a 3D scene's `[model]`, the workspace a table of its own (a key
/// left out: [`Crane3dParams::EXAMPLE`]'s value).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields, default)
)]
pub struct Crane3dParams {
    /// Load mass m, kg (scales the rope force only; the inverse model is per unit mass).
    pub m: f64,
    /// Gravity g, m/s².
    pub g: f64,
    /// Bridge drive time constant τ1, s.
    pub tau1: f64,
    /// Trolley drive time constant τ2, s.
    pub tau2: f64,
    /// Hoist drive time constant τ3, s.
    pub tau3: f64,
    /// Where bridge, trolley and rope may go.
    pub workspace: Workspace3d,
    /// Smallest admissible rope tension as a fraction of the load's weight: the
    /// desired downward acceleration must stay below `(1 − fraction)·g`. At zero the
    /// rope goes slack and the inverse model is singular.
    pub min_tension_fraction: f64,
}

/// The assumed EOT crane: what a 3D scene that sets no parameter gets.
impl Default for Crane3dParams {
    fn default() -> Self {
        Self::EXAMPLE
    }
}

impl Crane3dParams {
    /// An assumed EOT crane, not measured: the load, gravity, trolley and hoist of
    /// Tab. 3 (the planar trolley's τ = 0.03 s for the trolley, the winch's 0.02 s for
    /// the hoist) and a bridge that is the heaviest, slowest axis, τ1 = 0.05 s; the
    /// [`Workspace3d::EXAMPLE`] hall and a 5 % tension margin.
    pub const EXAMPLE: Self = Self {
        m: 18.9,
        g: 9.81,
        tau1: 0.05,
        tau2: 0.03,
        tau3: 0.02,
        workspace: Workspace3d::EXAMPLE,
        min_tension_fraction: 0.05,
    };

    /// The planar crane `planar` given a trolley axis across it (time constant
    /// `tau_trolley`, travel `[y_min, y_max]`): its trolley becomes the bridge (τ1),
    /// its winch the hoist (τ3 = the planar τ2). A move with `y_C` constant then
    /// needs exactly the planar inputs on bridge and hoist, and none on the trolley.
    #[must_use]
    pub const fn extruded(planar: &CraneParams, tau_trolley: f64, y_min: f64, y_max: f64) -> Self {
        Self {
            m: planar.m,
            g: planar.g,
            tau1: planar.tau1,
            tau2: tau_trolley,
            tau3: planar.tau2,
            workspace: Workspace3d::extruded(planar.workspace, y_min, y_max),
            min_tension_fraction: planar.min_tension_fraction,
        }
    }

    /// Refuses non-finite or non-physical values.
    pub fn validate(&self) -> Result<()> {
        check_positive("m", self.m)?;
        check_positive("g", self.g)?;
        check_positive("tau1", self.tau1)?;
        check_positive("tau2", self.tau2)?;
        check_positive("tau3", self.tau3)?;
        let w = &self.workspace;
        check_range("x_min", w.x_min, f64::MIN, w.x_max)?;
        check_range("x_max", w.x_max, w.x_min, f64::MAX)?;
        check_range("y_min", w.y_min, f64::MIN, w.y_max)?;
        check_range("y_max", w.y_max, w.y_min, f64::MAX)?;
        check_positive("l_min", w.l_min)?;
        check_range("l_max", w.l_max, w.l_min, f64::MAX)?;
        check_range("min_tension_fraction", self.min_tension_fraction, 0.0, 1.0)?;
        Ok(())
    }
}

/// The crane configuration that puts the load at `z` with acceleration `z̈`.
///
/// The load's equations (module documentation) with the servo-constraints substituted
/// give `λ = (z̈_C − g)/(2 z_C)`, `x = x_C − ẍ_C/(2λ)`, `y = y_C − ÿ_C/(2λ)`; the 3D
/// Eq. 26 then gives the rope length. The position level of the flat inverse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlatConfiguration3d<T> {
    /// Bridge position x, m.
    pub x: T,
    /// Trolley position y, m.
    pub y: T,
    /// Rope length l, m.
    pub l: T,
    /// Constraint force per unit mass λ (negative: rope under tension), 1/s².
    pub lambda: T,
    /// The rope's slope in the x–z plane, `atan2(x_C − x, z_C)`, and in the y–z plane,
    /// `atan2(y_C − y, z_C)`, rad: what a two-axis inclinometer on the rope reports
    /// (CiA 410 slope long, slope lateral).
    pub slope: [T; 2],
}

/// Position-level flat inverse (see [`FlatConfiguration3d`]). Singular when `z̈_C = g`.
#[must_use]
pub fn flat_configuration<T: Real>(
    g: T,
    z: &SVector<T, 3>,
    zdd: &SVector<T, 3>,
) -> FlatConfiguration3d<T> {
    let [xc, yc, zc]: [T; 3] = (*z).into();
    let [xcdd, ycdd, zcdd]: [T; 3] = (*zdd).into();
    let two = c::<T>(2.0);
    let lambda = (zcdd - g) / (two * zc);
    let x = xc - xcdd / (two * lambda);
    let y = yc - ycdd / (two * lambda);
    let (dx, dy) = (xc - x, yc - y);
    FlatConfiguration3d {
        x,
        y,
        l: (dx * dx + dy * dy + zc * zc).sqrt(),
        lambda,
        slope: [dx.atan2(zc), dy.atan2(zc)],
    }
}

/// Checks a desired load trajectory against the rope-slack margin and the workspace:
/// the planar crane's checks ([`crate::models::crane::check_trajectory`]: `z_C > 0`,
/// `z̈_C ≤ (1 − min_tension_fraction) g`, sampled at
/// [`CHECK_SAMPLES`](crate::models::crane::CHECK_SAMPLES)` + 1` points of the active
/// span) with bridge `x`, trolley `y` and rope `l` of [`flat_configuration`] within
/// the workspace. A refusal names the coordinate: `"z_C"`, `"x"`, `"y"` or `"l"`.
pub fn check_trajectory<T: Real, Z: Trajectory<T, 3>>(p: &Crane3dParams, z: &Z) -> Result<()> {
    let g = c::<T>(p.g);
    let w = &p.workspace;
    check_load_path(p.g, p.min_tension_fraction, z, |zd, zdd| {
        let conf = flat_configuration(g, zd, zdd);
        [
            ("x", to_f64(conf.x), w.x_min, w.x_max),
            ("y", to_f64(conf.y), w.y_min, w.y_max),
            ("l", to_f64(conf.l), w.l_min, w.l_max),
        ]
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::error::Error;
    use crate::trajectory::PointToPoint;

    fn path(start: [f64; 3], end: [f64; 3], duration: f64) -> PointToPoint<f64, 3> {
        PointToPoint::new(start.into(), end.into(), 1.0, duration, 4).unwrap()
    }

    #[test]
    fn example_parameters_are_valid_and_bad_ones_refused() {
        Crane3dParams::EXAMPLE.validate().unwrap();
        let mut p = Crane3dParams::EXAMPLE;
        p.tau3 = 0.0;
        assert!(matches!(
            p.validate(),
            Err(Error::ParameterOutOfRange { name: "tau3", .. })
        ));
        let mut p = Crane3dParams::EXAMPLE;
        p.workspace.y_max = -1.0;
        assert!(p.validate().is_err());
        let mut p = Crane3dParams::EXAMPLE;
        p.tau2 = f64::NAN;
        assert!(matches!(
            p.validate(),
            Err(Error::NonFiniteParameter { name: "tau2", .. })
        ));
    }

    /// The diagonal move with hoisting of the tests passes; a trolley beyond its span,
    /// a load above the rope's exit and a drop faster than the margin are refused by name.
    #[test]
    fn check_refuses_what_the_crane_cannot_do() {
        let p = Crane3dParams::EXAMPLE;
        check_trajectory(&p, &path([12.0, 3.0, 8.0], [20.0, 6.0, 4.0], 7.0)).unwrap();
        let across = check_trajectory(&p, &path([12.0, 3.0, 8.0], [20.0, 9.0, 4.0], 7.0));
        assert!(
            matches!(
                across,
                Err(Error::OutsideWorkspace {
                    coordinate: "y",
                    ..
                })
            ),
            "{across:?}"
        );
        let above = check_trajectory(&p, &path([12.0, 3.0, -1.0], [20.0, 6.0, 4.0], 7.0));
        assert!(matches!(
            above,
            Err(Error::OutsideWorkspace {
                coordinate: "z_C",
                ..
            })
        ));
        let drop = check_trajectory(&p, &path([12.0, 3.0, 4.0], [12.0, 3.0, 8.9], 0.6));
        assert!(matches!(drop, Err(Error::RopeSlack { .. })), "{drop:?}");
    }

    /// With `y_C = y` the configuration is the planar one in the x–z plane.
    #[test]
    fn planar_configuration_is_the_special_case() {
        let g = 9.81_f64;
        let z = SVector::from([15.0, 2.5, 6.0]);
        let zdd = SVector::from([0.3, 0.0, -0.2]);
        let conf = flat_configuration(g, &z, &zdd);
        let planar = crate::models::crane::flat_configuration(
            g,
            &SVector::from([15.0, 6.0]),
            &SVector::from([0.3, -0.2]),
        );
        assert_eq!(conf.x, planar.x);
        assert_eq!(conf.y, 2.5);
        assert_eq!(conf.lambda, planar.lambda);
        assert!((conf.l - planar.l).abs() <= 1e-15 * planar.l);
        assert_eq!(conf.slope, [planar.phi, 0.0]);
    }
}
