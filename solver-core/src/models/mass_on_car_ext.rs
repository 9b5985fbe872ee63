//! The mass-on-car of Sec. 3.2 minimally extended to index 1: *ext* (Altmann, Betsch &
//! Yang, the paper's ref. \[11\]).
//!
//! The direct formulation ([`mass_on_car`](super::mass_on_car), Eqs. 31–34) has index 3:
//! the servo-constraint Eq. 34 `g = x + s cos α − z_d = 0` fixes one combination of the
//! positions, and the input `F` follows from two differentiations through the scheme.
//! Minimal extension appends its hidden constraints `ġ = 0`, `g̈ = 0` and, for each, one
//! new algebraic unknown in place of a derivative, chosen where the constraint Jacobian
//! `G = ∂g/∂(x, s) = [1, cos α]` has an invertible block: the car's `x` (block 1, for
//! every α; the block `cos α` of `s` would vanish at 90°). So `ẋ` (Eq. 31) becomes `x'`
//! and `v̇_x` (Eq. 32) `a_x`, and `s`, `v_s` — the internal dynamics' coordinates, Eq.
//! 38 — stay differential. With `x = [x, s, v_x, v_s, F, x', a_x]` (the direct
//! formulation's unknowns first, in its order):
//!
//! ```text
//! F1 = x' − v_x                                  (31, ẋ → x')             algebraic
//! F2 = ṡ − v_s                                   (31)
//! F3 = (m1 + m2) a_x + m2 cos α v̇_s − F          (32, row 1, v̇_x → a_x)
//! F4 = m2 cos α a_x + m2 v̇_s + k s + d v_s        (32, row 2)
//! F5 = x + s cos α − z_d(t)                      (34)                     algebraic
//! F6 = v_x + v_s cos α − ż_d(t)                  (d/dt 34)                algebraic
//! F7 = a_x + cos α v̇_s − z̈_d(t)                  (d²/dt² 34)
//! ```
//!
//! (the hidden constraints written along the motion, velocities and accelerations in
//! place of `ẋ`, `ẍ`, as a mechanical system's `G v = …`, `G v̇ + … = 0`).
//!
//! ## Index 1
//!
//! Given `s`, `v_s` and t, F5, F6, F1 give `x`, `v_x`, `x'`; F2 gives `ṡ`; F4 and F7 are
//! linear in `(a_x, v̇_s)` with determinant `m2 cos² α − m2 = −m2 sin² α`, nonzero for
//! 0° < α < 90° (what [`MassOnCarParams::validate`] admits); F3 gives `F`. Every unknown
//! and every derivative is determined without differentiating: index 1. Eliminating
//! `a_x` from F4 with F7 leaves `m2 sin² α v̇_s + d v_s + k s = −m2 cos α z̈_d`, the internal
//! dynamics of Eq. 38 — which here stay an ODE the scheme integrates with its own order,
//! in every unknown (for an index-1 DAE BDF k converges with order k, Radau IIA with
//! order 5).
//!
//! No structured elimination: the firmware drives cranes, and the model is linear
//! (Newton converges in one iteration on the dense 7×7 LU).

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::model::{DaeModel, Driven, Partials};
use crate::models::mass_on_car::MassOnCarParams;
use crate::scalar::{c, Real};
use crate::trajectory::{ensure_at_rest, Trajectory};

/// Number of unknowns.
pub const N: usize = 7;
/// Number of inputs.
pub const NU: usize = 1;
schemes_of!(MassOnCarExt);

/// The mass-on-car *ext* inverse model, driven by an output trajectory `Z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassOnCarExt<T: Real, Z> {
    params: MassOnCarParams,
    m12: T,
    m2: T,
    m2_cos: T,
    cos: T,
    k: T,
    d: T,
    trajectory: Z,
}

impl<T: Real, Z: Trajectory<T, 1>> MassOnCarExt<T, Z> {
    /// Builds the model after checking the parameters and the trajectory's smoothness.
    pub fn new(params: MassOnCarParams, trajectory: Z) -> Result<Self> {
        params.validate()?;
        let required = <Self as DaeModel<T, N, NU>>::MIN_SMOOTHNESS;
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

impl<T: Real, Z> Driven for MassOnCarExt<T, Z> {
    type Trajectory = Z;

    fn trajectory(&self) -> &Z {
        &self.trajectory
    }

    fn trajectory_mut(&mut self) -> &mut Z {
        &mut self.trajectory
    }
}

impl<T: Real, Z: Trajectory<T, 1>> DaeModel<T, N, NU> for MassOnCarExt<T, Z> {
    const UNKNOWNS: [&'static str; N] = ["x", "s", "vx", "vs", "F", "x'", "ax"];
    /// F1, F5, F6; F7 has `v̇_s`.
    const ALGEBRAIC: [bool; N] = [true, false, false, false, true, true, false];
    const INPUTS: [usize; NU] = [4];
    /// `F` contains `z̈_d` (F7, F3): continuous for n ≥ 2.
    const MIN_SMOOTHNESS: usize = 2;

    /// `[z_d, ż_d, z̈_d]`.
    type Sample = [T; 3];

    fn sample(&self, t: T) -> Self::Sample {
        self.trajectory.derivatives::<3>(t).map(|z| z.x)
    }

    fn residual(&self, x: &SVector<T, N>, xdot: &SVector<T, N>, s: &Self::Sample) -> SVector<T, N> {
        let [xc, sp, vx, vs, f, xd, ax]: [T; N] = (*x).into();
        let [_, s_dot, _, vs_dot, _, _, _]: [T; N] = (*xdot).into();
        let [z, z1, z2] = *s;
        SVector::<T, N>::from([
            xd - vx,
            s_dot - vs,
            self.m12 * ax + self.m2_cos * vs_dot - f,
            self.m2_cos * ax + self.m2 * vs_dot + self.k * sp + self.d * vs,
            xc + sp * self.cos - z,
            vx + vs * self.cos - z1,
            ax + self.cos * vs_dot - z2,
        ])
    }

    fn partials(
        &self,
        _x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        _s: &Self::Sample,
    ) -> Partials<T, N> {
        let (one, o) = (T::one(), T::zero());
        let (m12, m2, m2c, cos) = (self.m12, self.m2, self.m2_cos, self.cos);
        #[rustfmt::skip]
        let dfdx = SMatrix::<T, N, N>::from_row_slice(&[
            // x    s       vx    vs      F     x'    ax
            o,      o,      -one, o,      o,    one,  o,
            o,      o,      o,    -one,   o,    o,    o,
            o,      o,      o,    o,      -one, o,    m12,
            o,      self.k, o,    self.d, o,    o,    m2c,
            one,    cos,    o,    o,      o,    o,    o,
            o,      o,      one,  cos,    o,    o,    o,
            o,      o,      o,    o,      o,    o,    one,
        ]);
        #[rustfmt::skip]
        let dfdxdot = SMatrix::<T, N, N>::from_row_slice(&[
            o, o,   o, o,   o, o, o,
            o, one, o, o,   o, o, o,
            o, o,   o, m2c, o, o, o,
            o, o,   o, m2,  o, o, o,
            o, o,   o, o,   o, o, o,
            o, o,   o, o,   o, o, o,
            o, o,   o, cos, o, o, o,
        ]);
        Partials {
            dx: dfdx,
            dxdot: dfdxdot,
        }
    }

    fn rest_state(&self, t: T) -> Result<SVector<T, N>> {
        ensure_at_rest(&self.trajectory, t)?;
        let [z, _, _] = self.sample(t);
        let o = T::zero();
        Ok(SVector::<T, N>::from([z, o, o, o, o, o, o]))
    }

    /// Eq. 33: `z = x + s cos α`.
    fn output(&self, x: &SVector<T, N>, _s: &Self::Sample) -> SVector<T, NU> {
        let [xc, sp, ..]: [T; N] = (*x).into();
        SVector::<T, NU>::new(xc + sp * self.cos)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use crate::trajectory::PointToPoint;

    /// Index 1: at any `(s, v_s)` and t the rows determine every other unknown and both
    /// derivatives — the matrix `[∂F/∂(x, v_x, F, x', a_x) | ∂F/∂(ṡ, v̇_s)]` is invertible
    /// for α in (0°, 90°), its determinant `±m2 sin² α`.
    #[test]
    fn the_extended_system_has_index_one() {
        for alpha in [1.0_f64, 15.0, 45.0, 89.0] {
            let p = MassOnCarParams {
                alpha: alpha.to_radians(),
                ..MassOnCarParams::PAPER
            };
            let z =
                PointToPoint::new(SVector::from([0.0]), SVector::from([1.0]), 3.0, 3.0, 4).unwrap();
            let m = MassOnCarExt::new(p, z).unwrap();
            let x = SVector::<f64, N>::from([0.3, 0.1, 0.2, -0.4, 1.0, 0.2, 0.5]);
            let s = m.sample(4.0);
            let pt = m.partials(&x, &x, &s);
            // Columns: the algebraic unknowns from ∂F/∂x, the two derivatives from ∂F/∂ẋ.
            let a = SMatrix::<f64, N, N>::from_fn(|i, j| match j {
                0 => pt.dx[(i, 0)],
                1 => pt.dx[(i, 2)],
                2 => pt.dx[(i, 4)],
                3 => pt.dx[(i, 5)],
                4 => pt.dx[(i, 6)],
                5 => pt.dxdot[(i, 1)],
                _ => pt.dxdot[(i, 3)],
            });
            let sin2 = alpha.to_radians().sin().powi(2);
            assert!(
                (a.determinant().abs() - p.m2 * sin2).abs() <= 1e-12,
                "α = {alpha}: det {}",
                a.determinant()
            );
        }
    }

    /// At rest the residual vanishes.
    #[test]
    fn rest_state_is_consistent() {
        let z = PointToPoint::new(SVector::from([0.0]), SVector::from([1.0]), 3.0, 3.0, 4).unwrap();
        let m = MassOnCarExt::new(MassOnCarParams::PAPER, z).unwrap();
        for t in [0.0, 2.0, 6.0, 9.0] {
            let r = m.residual(&m.rest_state(t).unwrap(), &SVector::zeros(), &m.sample(t));
            assert!(r.amax() < 1e-15, "t = {t}: {r}");
        }
    }
}
