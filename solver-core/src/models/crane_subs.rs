//! The crane in redundant coordinates with the servo-constraints substituted: *subs*.
//!
//! Eqs. 24–26 describe the crane in the redundant coordinates `[x, l, x_C, z_C]`
//! with one rope constraint (Eq. 26) and its multiplier λ. The servo-constraints
//! Eq. 28 prescribe `x_C = x_C,d(t)`, `z_C = z_C,d(t)`; substituting them (as in
//! Otto & Seifried 2018, ref. [4]) removes the load coordinates and leaves, with
//! `x = [x, l, ẋ, l̇, λ, u1, u2]`,
//!
//! ```text
//! F1 = ẋ − v_x                                 (24)
//! F2 = l̇ − v_l                                 (24)
//! F3 = τ1 v̇_x + v_x − u1                       (25, row 1)
//! F4 = τ2 v̇_l + v_l − u2                       (25, row 2)
//! F5 = ẍ_C,d − 2 (x_C,d − x) λ                  (25, row 3)   algebraic
//! F6 = z̈_C,d − g − 2 z_C,d λ                    (25, row 4)   algebraic
//! F7 = z_C,d² + (x_C,d − x)² − l²               (26)          algebraic
//! ```
//!
//! F5–F7 fix `x`, `l`, `λ` at every instant; `u` needs two more differentiations
//! of `x` and `l` (through F1–F4), so the DAE has index 3. The Newton matrix of
//! the algebraic block has determinant `−8 λ z_C l`: it is singular when the rope
//! goes slack (λ → 0, i.e. `z̈_C,d → g`), which [`check_trajectory`] refuses up front.

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::model::{DaeModel, Driven, Partials};
use crate::models::crane::{check_trajectory, CraneParams};
use crate::scalar::{c, Real};
use crate::trajectory::{ensure_at_rest, Trajectory};

/// Number of unknowns of the *subs* formulation.
pub const N: usize = 7;

/// The crane *subs* inverse model, driven by a load trajectory `Z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CraneSubs<T: Real, Z> {
    params: CraneParams,
    g: T,
    tau1: T,
    tau2: T,
    trajectory: Z,
}

impl<T: Real, Z: Trajectory<T, 2>> CraneSubs<T, Z> {
    /// Builds the model after checking the parameters and the whole trajectory
    /// (smoothness, rope-slack margin, workspace).
    pub fn new(params: CraneParams, trajectory: Z) -> Result<Self> {
        params.validate()?;
        let required = <Self as DaeModel<T, N, 2>>::MIN_SMOOTHNESS;
        if trajectory.smoothness() < required {
            return Err(Error::TrajectoryTooRough {
                smoothness: trajectory.smoothness(),
                required,
            });
        }
        check_trajectory(&params, &trajectory)?;
        Ok(Self {
            params,
            g: c(params.g),
            tau1: c(params.tau1),
            tau2: c(params.tau2),
            trajectory,
        })
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &CraneParams {
        &self.params
    }
}

impl<T: Real, Z> Driven for CraneSubs<T, Z> {
    type Trajectory = Z;

    fn trajectory(&self) -> &Z {
        &self.trajectory
    }

    fn trajectory_mut(&mut self) -> &mut Z {
        &mut self.trajectory
    }
}

impl<T: Real, Z: Trajectory<T, 2>> DaeModel<T, N, 2> for CraneSubs<T, Z> {
    const UNKNOWNS: [&'static str; N] = ["x", "l", "vx", "vl", "lambda", "u1", "u2"];
    const ALGEBRAIC: [bool; N] = [false, false, false, false, true, true, true];
    const INPUTS: [usize; 2] = [5, 6];
    /// `u` contains `z_d⁗`; with n ≥ 4 it is continuous (the paper's choice).
    const MIN_SMOOTHNESS: usize = 4;

    /// `[z_d, ż_d, z̈_d]`.
    type Sample = [SVector<T, 2>; 3];

    fn sample(&self, t: T) -> Self::Sample {
        self.trajectory.derivatives::<3>(t)
    }

    fn residual(&self, x: &SVector<T, N>, xdot: &SVector<T, N>, s: &Self::Sample) -> SVector<T, N> {
        let [xt, l, vx, vl, lambda, u1, u2]: [T; N] = (*x).into();
        let [xt_dot, l_dot, vx_dot, vl_dot, _, _, _]: [T; N] = (*xdot).into();
        let [[xc, zc], _, [xcdd, zcdd]] = s.map(<[T; 2]>::from);
        let two = c::<T>(2.0);
        let dx = xc - xt;
        SVector::<T, N>::from([
            xt_dot - vx,
            l_dot - vl,
            self.tau1 * vx_dot + vx - u1,
            self.tau2 * vl_dot + vl - u2,
            xcdd - two * dx * lambda,
            zcdd - self.g - two * zc * lambda,
            zc * zc + dx * dx - l * l,
        ])
    }

    fn partials(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
    ) -> Partials<T, N> {
        let [xt, l, _, _, lambda, _, _]: [T; N] = (*x).into();
        let [[xc, zc], _, _] = s.map(<[T; 2]>::from);
        let (one, two) = (T::one(), c::<T>(2.0));
        let dx = xc - xt;
        let o = T::zero();
        #[rustfmt::skip]
        let dfdx = SMatrix::<T, N, N>::from_row_slice(&[
            // x          l          vx    vl    lambda        u1    u2
            o,            o,         -one, o,    o,            o,    o,
            o,            o,         o,    -one, o,            o,    o,
            o,            o,         one,  o,    o,            -one, o,
            o,            o,         o,    one,  o,            o,    -one,
            two * lambda, o,         o,    o,    -two * dx,    o,    o,
            o,            o,         o,    o,    -two * zc,    o,    o,
            -two * dx,    -two * l,  o,    o,    o,            o,    o,
        ]);
        let dfdxdot = SMatrix::<T, N, N>::from_diagonal(&SVector::<T, N>::from([
            one, one, self.tau1, self.tau2, o, o, o,
        ]));
        Partials {
            dx: dfdx,
            dxdot: dfdxdot,
        }
    }

    fn rest_state(&self, t: T) -> Result<SVector<T, N>> {
        ensure_at_rest(&self.trajectory, t)?;
        let [[xc, zc]] = self.trajectory.derivatives::<1>(t).map(<[T; 2]>::from);
        // Hanging straight down: x = x_C, l = z_C, λ = −g/(2 z_C) from F6.
        let lambda = -self.g / (c::<T>(2.0) * zc);
        let o = T::zero();
        Ok(SVector::<T, N>::from([xc, zc, o, o, lambda, o, o]))
    }

    /// The load position: here the servo-constraint holds by construction, `z = z_d(t)`.
    fn output(&self, _x: &SVector<T, N>, s: &Self::Sample) -> SVector<T, 2> {
        let [z, _, _] = *s;
        z
    }
}
