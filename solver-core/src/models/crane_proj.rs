//! The crane in minimal coordinates, projected after Blajer: *proj*.
//!
//! ## Derivation
//!
//! Start from Eqs. 21–22 in the minimal coordinates `y = [x, l, φ]`,
//! `v = [ẋ, l̇, φ̇]`. Eq. 22 has three rows. Rows 1–2 are the actuated directions
//! (the inputs `B u` act there and nowhere else). Row 3 has no input: it is the
//! load's Newton equation `a_C = g e_z + (S/m) e_r` (rope force `S` along the rope
//! direction `e_r = [sin φ, cos φ]`) projected onto the direction the rope force
//! cannot act in, `e_t = [cos φ, −sin φ]`:
//!
//! ```text
//! e_t · a_C = cos φ ẍ + l φ̈ + 2 l̇ φ̇        (the left side of row 3)
//! e_t · g e_z = −g sin φ                    (the right side of row 3)
//! ```
//!
//! (expand `a_C = d²/dt² [x + l sin φ, l cos φ]` to check the first line).
//! Projecting the dynamics onto the constrained and unconstrained directions of
//! the servo-constraints (Blajer & Kołodziejczyk, ref. \[3\]) means: in the
//! directions the servo-constraint fixes, the load's acceleration is not a
//! dynamic unknown but prescribed, `a_C = z̈_d(t)`. Evaluated along the
//! constrained motion, row 3 therefore becomes an algebraic relation between the
//! swing angle and time,
//!
//! ```text
//! e_t(φ) · (z̈_d(t) − g e_z) = cos φ ẍ_C,d − sin φ (z̈_C,d − g) = 0,
//! ```
//!
//! which is the step that lowers the index from 5 (Eqs. 21–22 with Eq. 28
//! appended as they stand) to 3. With `x = [x, l, φ, ẋ, l̇, φ̇, u1, u2]`:
//!
//! ```text
//! F1..3 = ẏ − v                                   (21)
//! F4    = τ1 v̇_x + v_x − u1                       (22, row 1)
//! F5    = τ2 v̇_l + v_l − u2                       (22, row 2)
//! F6    = cos φ ẍ_C,d − sin φ (z̈_C,d − g)         (22, row 3 projected)  algebraic
//! F7    = x + l sin φ − x_C,d                     (28, with Eq. 27)     algebraic
//! F8    = l cos φ − z_C,d                         (28, with Eq. 27)     algebraic
//! ```
//!
//! F6–F8 fix `x, l, φ` at every instant, `u` follows from two differentiations
//! through F1–F5: index 3, like *subs*, but with one unknown more (8 against 7)
//! and trigonometric terms — the paper's Fig. 7 finds it slower for that reason.

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::model::{DaeModel, Driven, Partials};
use crate::models::crane::{check_trajectory, CraneParams};
use crate::scalar::{c, Real};
use crate::trajectory::{ensure_at_rest, Trajectory};

/// Number of unknowns of the *proj* formulation.
pub const N: usize = 8;
/// Number of inputs.
pub const NU: usize = 2;
schemes_of!(CraneProj);

/// The crane *proj* inverse model, driven by a load trajectory `Z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CraneProj<T: Real, Z> {
    params: CraneParams,
    g: T,
    tau1: T,
    tau2: T,
    trajectory: Z,
}

impl<T: Real, Z: Trajectory<T, 2>> CraneProj<T, Z> {
    /// Builds the model after checking the parameters and the whole trajectory.
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

impl<T: Real, Z> Driven for CraneProj<T, Z> {
    type Trajectory = Z;

    fn trajectory(&self) -> &Z {
        &self.trajectory
    }

    fn trajectory_mut(&mut self) -> &mut Z {
        &mut self.trajectory
    }
}

impl<T: Real, Z: Trajectory<T, 2>> DaeModel<T, N, 2> for CraneProj<T, Z> {
    const UNKNOWNS: [&'static str; N] = ["x", "l", "phi", "vx", "vl", "vphi", "u1", "u2"];
    const ALGEBRAIC: [bool; N] = [false, false, false, false, false, true, true, true];
    const INPUTS: [usize; 2] = [6, 7];
    const MIN_SMOOTHNESS: usize = 4;

    /// `[z_d, ż_d, z̈_d]`.
    type Sample = [SVector<T, 2>; 3];

    fn sample(&self, t: T) -> Self::Sample {
        self.trajectory.derivatives::<3>(t)
    }

    fn residual(&self, x: &SVector<T, N>, xdot: &SVector<T, N>, s: &Self::Sample) -> SVector<T, N> {
        let [xt, l, phi, vx, vl, vphi, u1, u2]: [T; N] = (*x).into();
        let [xt_dot, l_dot, phi_dot, vx_dot, vl_dot, _, _, _]: [T; N] = (*xdot).into();
        let [[xc, zc], _, [xcdd, zcdd]] = s.map(<[T; 2]>::from);
        let (sin, cos) = phi.sin_cos();
        SVector::<T, N>::from([
            xt_dot - vx,
            l_dot - vl,
            phi_dot - vphi,
            self.tau1 * vx_dot + vx - u1,
            self.tau2 * vl_dot + vl - u2,
            cos * xcdd - sin * (zcdd - self.g),
            xt + l * sin - xc,
            l * cos - zc,
        ])
    }

    fn partials(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
    ) -> Partials<T, N> {
        let [_, l, phi, _, _, _, _, _]: [T; N] = (*x).into();
        let [_, _, [xcdd, zcdd]] = s.map(<[T; 2]>::from);
        let (sin, cos) = phi.sin_cos();
        let (one, o) = (T::one(), T::zero());
        let d6_dphi = -sin * xcdd - cos * (zcdd - self.g);
        #[rustfmt::skip]
        let dfdx = SMatrix::<T, N, N>::from_row_slice(&[
            // x    l     phi          vx    vl    vphi  u1    u2
            o,      o,    o,           -one, o,    o,    o,    o,
            o,      o,    o,           o,    -one, o,    o,    o,
            o,      o,    o,           o,    o,    -one, o,    o,
            o,      o,    o,           one,  o,    o,    -one, o,
            o,      o,    o,           o,    one,  o,    o,    -one,
            o,      o,    d6_dphi,     o,    o,    o,    o,    o,
            one,    sin,  l * cos,     o,    o,    o,    o,    o,
            o,      cos,  -l * sin,    o,    o,    o,    o,    o,
        ]);
        let diagonal = SVector::<T, N>::from([one, one, one, self.tau1, self.tau2, o, o, o]);
        Partials {
            dx: dfdx,
            dxdot: SMatrix::<T, N, N>::from_diagonal(&diagonal),
        }
    }

    fn rest_state(&self, t: T) -> Result<SVector<T, N>> {
        ensure_at_rest(&self.trajectory, t)?;
        let [[xc, zc]] = self.trajectory.derivatives::<1>(t).map(<[T; 2]>::from);
        let o = T::zero();
        Ok(SVector::<T, N>::from([xc, zc, o, o, o, o, o, o]))
    }

    /// Eq. 27: `z = [x + l sin φ, l cos φ]`.
    fn output(&self, x: &SVector<T, N>, _s: &Self::Sample) -> SVector<T, 2> {
        let [xt, l, phi, _, _, _, _, _]: [T; N] = (*x).into();
        let (sin, cos) = phi.sin_cos();
        SVector::<T, 2>::new(xt + l * sin, l * cos)
    }
}
