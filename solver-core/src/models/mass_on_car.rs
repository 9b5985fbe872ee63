//! The mass-on-car system of Sec. 3.2 (Fig. 9): a non-flat output with internal dynamics.
//!
//! A car (mass m1, position x, pushed by the force F) carries a mass m2 that
//! slides on a plane inclined by α, tied to the car by a spring-damper (k, d);
//! `s` is its position along the plane. The output is the horizontal position of
//! m2 (Eq. 33). With `x = [x, s, ẋ, ṡ, F]`:
//!
//! ```text
//! F1 = ẋ − v_x                                          (31)
//! F2 = ṡ − v_s                                          (31)
//! F3 = (m1 + m2) v̇_x + m2 cos α v̇_s − F                 (32, row 1)
//! F4 = m2 cos α v̇_x + m2 v̇_s + k s + d v_s              (32, row 2)
//! F5 = x + s cos α − z_d(t)                             (34)   algebraic
//! ```
//!
//! For 0° < α < 90° the relative degree is 2 and the DAE has index 3; the
//! remaining internal dynamics (Eq. 38) oscillate undamped when d = 0.

use nalgebra::{SMatrix, SVector};

use crate::error::{check_positive, check_range, Error, Result};
use crate::model::{DaeModel, Driven, Partials};
use crate::scalar::{c, Real};
use crate::trajectory::{ensure_at_rest, Trajectory};

/// Number of unknowns.
pub const N: usize = 5;
/// Number of inputs.
pub const NU: usize = 1;
schemes_of!(MassOnCar);

/// Parameters of Tab. 4 plus the inclination α.
///
/// With feature `serde`, a mass-on-car scene's `[model]`, α in degrees as `alpha_deg` (a
/// key left out: [`MassOnCarParams::PAPER`]'s value).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields, default)
)]
pub struct MassOnCarParams {
    /// Car mass m1, kg.
    pub m1: f64,
    /// Sliding mass m2, kg.
    pub m2: f64,
    /// Spring stiffness k, N/m.
    pub k: f64,
    /// Damping d, Ns/m (Tab. 4: 0 or 1).
    pub d: f64,
    /// Inclination α of the plane, rad; must lie in (0°, 90°) for a non-flat output.
    #[cfg_attr(feature = "serde", serde(rename = "alpha_deg", with = "degrees"))]
    pub alpha: f64,
}

/// Tab. 4's: what a mass-on-car scene that sets no parameter gets.
impl Default for MassOnCarParams {
    fn default() -> Self {
        Self::PAPER
    }
}

/// A scene gives α in degrees (`alpha_deg`), the model takes radians.
#[cfg(feature = "serde")]
mod degrees {
    use serde::{Deserialize, Deserializer, Serializer};

    pub(super) fn serialize<S: Serializer>(alpha: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_f64(alpha.to_degrees())
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        f64::deserialize(d).map(f64::to_radians)
    }
}

impl MassOnCarParams {
    /// Tab. 4 with α = 15° and d = 0 (the configuration of Figs. 11–13).
    pub const PAPER: Self = Self {
        m1: 1.0,
        m2: 1.0,
        k: 5.0,
        d: 0.0,
        alpha: 15.0 * core::f64::consts::PI / 180.0,
    };

    /// Refuses non-finite or non-physical values (masses or k ≤ 0, d < 0, α ∉ (0°, 90°)).
    pub fn validate(&self) -> Result<()> {
        check_positive("m1", self.m1)?;
        check_positive("m2", self.m2)?;
        check_positive("k", self.k)?;
        check_range("d", self.d, 0.0, f64::MAX)?;
        check_range("alpha", self.alpha, 0.0, core::f64::consts::FRAC_PI_2)?;
        // The open interval: at 0° the output is flat, at 90° the car cannot move m2's output.
        if self.alpha == 0.0 || self.alpha == core::f64::consts::FRAC_PI_2 {
            return Err(Error::ParameterOutOfRange {
                name: "alpha",
                value: self.alpha,
                min: 0.0,
                max: core::f64::consts::FRAC_PI_2,
            });
        }
        Ok(())
    }
}

/// The mass-on-car inverse model, driven by an output trajectory `Z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassOnCar<T: Real, Z> {
    params: MassOnCarParams,
    m12: T,
    m2: T,
    m2_cos: T,
    cos: T,
    k: T,
    d: T,
    trajectory: Z,
}

impl<T: Real, Z: Trajectory<T, 1>> MassOnCar<T, Z> {
    /// Builds the model after checking the parameters and the trajectory's smoothness.
    pub fn new(params: MassOnCarParams, trajectory: Z) -> Result<Self> {
        params.validate()?;
        let required = <Self as DaeModel<T, N, 1>>::MIN_SMOOTHNESS;
        if trajectory.smoothness() < required {
            return Err(Error::TrajectoryTooRough {
                smoothness: trajectory.smoothness(),
                required,
            });
        }
        let cos = c::<T>(params.alpha).cos();
        let m2 = c::<T>(params.m2);
        Ok(Self {
            params,
            m12: c(params.m1 + params.m2),
            m2,
            m2_cos: m2 * cos,
            cos,
            k: c(params.k),
            d: c(params.d),
            trajectory,
        })
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &MassOnCarParams {
        &self.params
    }
}

impl<T: Real, Z> Driven for MassOnCar<T, Z> {
    type Trajectory = Z;

    fn trajectory(&self) -> &Z {
        &self.trajectory
    }

    fn trajectory_mut(&mut self) -> &mut Z {
        &mut self.trajectory
    }
}

impl<T: Real, Z: Trajectory<T, 1>> DaeModel<T, N, 1> for MassOnCar<T, Z> {
    const UNKNOWNS: [&'static str; N] = ["x", "s", "vx", "vs", "F"];
    const ALGEBRAIC: [bool; N] = [false, false, false, false, true];
    const INPUTS: [usize; 1] = [4];
    /// `F` contains `z̈_d` (Eq. 37): continuous for n ≥ 2.
    const MIN_SMOOTHNESS: usize = 2;

    /// `z_d(t)`.
    type Sample = T;

    fn sample(&self, t: T) -> Self::Sample {
        let [[z]] = self.trajectory.derivatives::<1>(t).map(<[T; 1]>::from);
        z
    }

    fn residual(
        &self,
        x: &SVector<T, N>,
        xdot: &SVector<T, N>,
        zd: &Self::Sample,
    ) -> SVector<T, N> {
        let [xc, s, vx, vs, f]: [T; N] = (*x).into();
        let [xc_dot, s_dot, vx_dot, vs_dot, _]: [T; N] = (*xdot).into();
        SVector::<T, N>::from([
            xc_dot - vx,
            s_dot - vs,
            self.m12 * vx_dot + self.m2_cos * vs_dot - f,
            self.m2_cos * vx_dot + self.m2 * vs_dot + self.k * s + self.d * vs,
            xc + s * self.cos - *zd,
        ])
    }

    fn partials(
        &self,
        _x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        _zd: &Self::Sample,
    ) -> Partials<T, N> {
        let (one, o) = (T::one(), T::zero());
        #[rustfmt::skip]
        let dfdx = SMatrix::<T, N, N>::from_row_slice(&[
            // x    s          vx    vs      F
            o,      o,         -one, o,      o,
            o,      o,         o,    -one,   o,
            o,      o,         o,    o,      -one,
            o,      self.k,    o,    self.d, o,
            one,    self.cos,  o,    o,      o,
        ]);
        #[rustfmt::skip]
        let dfdxdot = SMatrix::<T, N, N>::from_row_slice(&[
            one, o,   o,           o,           o,
            o,   one, o,           o,           o,
            o,   o,   self.m12,    self.m2_cos, o,
            o,   o,   self.m2_cos, self.m2,     o,
            o,   o,   o,           o,           o,
        ]);
        Partials {
            dx: dfdx,
            dxdot: dfdxdot,
        }
    }

    fn rest_state(&self, t: T) -> Result<SVector<T, N>> {
        ensure_at_rest(&self.trajectory, t)?;
        let o = T::zero();
        Ok(SVector::<T, N>::from([self.sample(t), o, o, o, o]))
    }

    /// Eq. 33: `z = x + s cos α`.
    fn output(&self, x: &SVector<T, N>, _zd: &Self::Sample) -> SVector<T, 1> {
        let [xc, s, _, _, _]: [T; N] = (*x).into();
        SVector::<T, 1>::new(xc + s * self.cos)
    }
}
