//! The 3D crane in redundant coordinates with the servo-constraints substituted: *subs*.
//!
//! The planar *subs* model ([`crane_subs`](crate::models::crane_subs), Eqs. 24–28) with a
//! second horizontal axis. Redundant coordinates `[x, y, l, x_C, y_C, z_C]`, one rope
//! constraint (the 3D Eq. 26, see [the parent module](super)) and its multiplier λ; the
//! servo-constraints `x_C = x_C,d(t)`, `y_C = y_C,d(t)`, `z_C = z_C,d(t)` (the 3D
//! Eq. 28) substituted remove the load coordinates and leave, with
//! `x = [x, y, l, v_x, v_y, v_l, λ, u1, u2, u3]`,
//!
//! ```text
//! F1  = ẋ − v_x                                        (24)
//! F2  = ẏ − v_y                                        (24)
//! F3  = l̇ − v_l                                        (24)
//! F4  = τ1 v̇_x + v_x − u1                              (25, row 1: bridge)
//! F5  = τ2 v̇_y + v_y − u2                              (25, row 1: trolley)
//! F6  = τ3 v̇_l + v_l − u3                              (25, row 2: hoist)
//! F7  = ẍ_C,d − 2 (x_C,d − x) λ                         (25, row 3)        algebraic
//! F8  = ÿ_C,d − 2 (y_C,d − y) λ                         (25, row 3 in y)   algebraic
//! F9  = z̈_C,d − g − 2 z_C,d λ                           (25, row 4)        algebraic
//! F10 = (x_C,d − x)² + (y_C,d − y)² + z_C,d² − l²       (26)               algebraic
//! ```
//!
//! ordered as the planar model's rows: the differential ones first, then the
//! algebraic ones (which get the scaling ρ of Sec. 3.1.1), the load's three equations
//! before the constraint. F7–F10 fix `x`, `y`, `l`, `λ` at every instant; `u` needs two
//! more differentiations of `x`, `y`, `l` (through F1–F6), so the DAE has index 3, as
//! the planar one. The Jacobian of the algebraic block with respect to `(x, y, l, λ)`
//! has determinant `−16 λ² z_C l`: singular for a slack rope (λ → 0, `z̈_C,d → g`), which
//! [`check_trajectory`] refuses up front. With `y_C,d`
//! constant and the trolley at rest under the load, F2, F5 and F8 hold with
//! `y = y_C,d`, `v_y = u2 = 0`, and the other rows are the planar F1–F7 (bridge for
//! trolley, hoist for winch).

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::model::{DaeModel, DifferenceFormula, Driven, Partials, StructuredJacobian};
use crate::models::crane3d::{check_trajectory, Crane3dParams};
use crate::models::crane_subs::rope_increment;
use crate::scalar::{c, is_finite, Real};
use crate::trajectory::{ensure_at_rest, Trajectory};

/// Number of unknowns of the 3D *subs* formulation.
pub const N: usize = 10;
/// Number of inputs (bridge, trolley, hoist) and of outputs (`x_C`, `y_C`, `z_C`).
pub const NU: usize = 3;
schemes_of!(Crane3dSubs, structured);

/// The 3D crane *subs* inverse model, driven by a load trajectory `Z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crane3dSubs<T: Real, Z> {
    params: Crane3dParams,
    g: T,
    /// τ1, τ2, τ3.
    tau: [T; 3],
    trajectory: Z,
}

impl<T: Real, Z: Trajectory<T, NU>> Crane3dSubs<T, Z> {
    /// Builds the model after checking the parameters and the whole trajectory
    /// (smoothness, rope-slack margin, workspace).
    pub fn new(params: Crane3dParams, trajectory: Z) -> Result<Self> {
        params.validate()?;
        let required = <Self as DaeModel<T, N, NU>>::MIN_SMOOTHNESS;
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
            tau: [c(params.tau1), c(params.tau2), c(params.tau3)],
            trajectory,
        })
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &Crane3dParams {
        &self.params
    }
}

impl<T: Real, Z> Driven for Crane3dSubs<T, Z> {
    type Trajectory = Z;

    fn trajectory(&self) -> &Z {
        &self.trajectory
    }

    fn trajectory_mut(&mut self) -> &mut Z {
        &mut self.trajectory
    }
}

impl<T: Real, Z: Trajectory<T, NU>> DaeModel<T, N, NU> for Crane3dSubs<T, Z> {
    const UNKNOWNS: [&'static str; N] =
        ["x", "y", "l", "vx", "vy", "vl", "lambda", "u1", "u2", "u3"];
    const ALGEBRAIC: [bool; N] = [
        false, false, false, false, false, false, true, true, true, true,
    ];
    /// x, y, l and their velocities; λ, u1, u2, u3 have no derivative in F.
    const DIFFERENTIAL: usize = 6;
    const INPUTS: [usize; NU] = [7, 8, 9];
    /// `u` contains `z_d⁗` (as the planar crane's); with n ≥ 4 it is continuous.
    const MIN_SMOOTHNESS: usize = 4;

    /// `[z_d, ż_d, z̈_d]`.
    type Sample = [SVector<T, NU>; 3];

    fn sample(&self, t: T) -> Self::Sample {
        self.trajectory.derivatives::<3>(t)
    }

    fn residual(&self, x: &SVector<T, N>, xdot: &SVector<T, N>, s: &Self::Sample) -> SVector<T, N> {
        let [xb, yt, l, vx, vy, vl, lambda, u1, u2, u3]: [T; N] = (*x).into();
        let [xb_dot, yt_dot, l_dot, vx_dot, vy_dot, vl_dot, _, _, _, _]: [T; N] = (*xdot).into();
        let [[xc, yc, zc], _, [xcdd, ycdd, zcdd]] = s.map(<[T; NU]>::from);
        let [tau1, tau2, tau3] = self.tau;
        let two = c::<T>(2.0);
        let (dx, dy) = (xc - xb, yc - yt);
        SVector::<T, N>::from([
            xb_dot - vx,
            yt_dot - vy,
            l_dot - vl,
            tau1 * vx_dot + vx - u1,
            tau2 * vy_dot + vy - u2,
            tau3 * vl_dot + vl - u3,
            xcdd - two * dx * lambda,
            ycdd - two * dy * lambda,
            zcdd - self.g - two * zc * lambda,
            dx * dx + dy * dy + zc * zc - l * l,
        ])
    }

    fn partials(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
    ) -> Partials<T, N> {
        let [xb, yt, l, _, _, _, lambda, _, _, _]: [T; N] = (*x).into();
        let [[xc, yc, zc], _, _] = s.map(<[T; NU]>::from);
        let [tau1, tau2, tau3] = self.tau;
        let (one, two) = (T::one(), c::<T>(2.0));
        let (dx, dy) = (xc - xb, yc - yt);
        let (o, m) = (T::zero(), -one);
        let (l2, dx2, dy2) = (two * lambda, -two * dx, -two * dy);
        #[rustfmt::skip]
        let dfdx = SMatrix::<T, N, N>::from_row_slice(&[
            // x    y    l          vx   vy   vl   lambda      u1   u2   u3
            o,      o,   o,         m,   o,   o,   o,          o,   o,   o,
            o,      o,   o,         o,   m,   o,   o,          o,   o,   o,
            o,      o,   o,         o,   o,   m,   o,          o,   o,   o,
            o,      o,   o,         one, o,   o,   o,          m,   o,   o,
            o,      o,   o,         o,   one, o,   o,          o,   m,   o,
            o,      o,   o,         o,   o,   one, o,          o,   o,   m,
            l2,     o,   o,         o,   o,   o,   dx2,        o,   o,   o,
            o,      l2,  o,         o,   o,   o,   dy2,        o,   o,   o,
            o,      o,   o,         o,   o,   o,   -two * zc,  o,   o,   o,
            dx2,    dy2, -two * l,  o,   o,   o,   o,          o,   o,   o,
        ]);
        let dfdxdot = SMatrix::<T, N, N>::from_diagonal(&SVector::<T, N>::from([
            one, one, one, tau1, tau2, tau3, o, o, o, o,
        ]));
        Partials {
            dx: dfdx,
            dxdot: dfdxdot,
        }
    }

    fn rest_state(&self, t: T) -> Result<SVector<T, N>> {
        ensure_at_rest(&self.trajectory, t)?;
        let [[xc, yc, zc]] = self.trajectory.derivatives::<1>(t).map(<[T; NU]>::from);
        // Hanging straight down: x = x_C, y = y_C, l = z_C, λ = −g/(2 z_C) from F9.
        let lambda = -self.g / (c::<T>(2.0) * zc);
        let o = T::zero();
        Ok(SVector::<T, N>::from([
            xc, yc, zc, o, o, o, lambda, o, o, o,
        ]))
    }

    /// The load position: the servo-constraints hold by construction, `z = z_d(t)`.
    fn output(&self, _x: &SVector<T, N>, s: &Self::Sample) -> SVector<T, NU> {
        let [z, _, _] = *s;
        z
    }
}

/// The factors of the 3D *subs* Newton matrix (see [`StructuredJacobian`] for
/// [`Crane3dSubs`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Subs3dFactors<T> {
    /// `c = α₀/h` (the real part of the shift).
    c: T,
    /// `τ_i c + 1` of the drives' rows F4–F6.
    actuator: [T; 3],
    /// `τ1`, `τ2`, `τ3` (the imaginary part of the drives' rows for a complex shift).
    tau: [T; 3],
    /// `1/S_i` of the six differential rows.
    inv_scale: [T; 6],
    /// Reciprocal pivots of the rows F9 (for λ), F7 (for x), F8 (for y), F10 (for l).
    inv_pivot: [T; 4],
    /// `2 (x_C,d − x) S7`, `2 (y_C,d − y) S8`, `2 (x_C,d − x) S10`, `2 (y_C,d − y) S10`:
    /// the multipliers of F7, F8 and F10.
    multiplier: [T; 4],
}

/// The Newton matrix `S·(∂F/∂x + c·∂F/∂ẋ)` of the 3D *subs* model is triangular in the
/// order λ, x, y, l, v_x, v_y, v_l, u1, u2, u3 (`S_i` the row scaling, `r` the right side):
///
/// ```text
/// F9:  −2 z_C,d S9 · η_λ                                              = r9
/// F7:   2 λ S7 · η_x − 2 (x_C,d − x) S7 · η_λ                          = r7
/// F8:   2 λ S8 · η_y − 2 (y_C,d − y) S8 · η_λ                          = r8
/// F10: −2 l S10 · η_l − 2 (x_C,d − x) S10 · η_x − 2 (y_C,d − y) S10 · η_y = r10
/// F1:   c S1 · η_x − S1 · η_vx                                         = r1   (F2, F3 likewise for y, l)
/// F4:  (τ1 c + 1) S4 · η_vx − S4 · η_u1                                = r4   (F5, F6 likewise for τ2, τ3)
/// ```
///
/// Its pivots are those of the algebraic block (`−2 z_C S9`, `2 λ S7`, `2 λ S8`,
/// `−2 l S10`) and the differential rows' scalings, none of which depends on the
/// shift `c`: they vanish only for a slack rope (refused up front), at `z_C = 0` or at
/// `l = 0`. No pivot search, 4 reciprocals and about 30 multiply-adds instead of a
/// 10×10 LU; the same factors serve RADAU5's complex system.
impl<T: Real, Z: Trajectory<T, NU>> StructuredJacobian<T, N, NU> for Crane3dSubs<T, Z> {
    type Factors = Subs3dFactors<T>;

    const CLOSED_FORM: bool = true;

    fn factor(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
        alpha0_h: T,
        scale: &SVector<T, N>,
    ) -> Option<Subs3dFactors<T>> {
        let [xb, yt, l, _, _, _, lambda, _, _, _]: [T; N] = (*x).into();
        let [s1, s2, s3, s4, s5, s6, s7, s8, s9, s10]: [T; N] = (*scale).into();
        let [[xc, yc, zc], _, _] = s.map(<[T; NU]>::from);
        let two = c::<T>(2.0);
        let (dx, dy) = (xc - xb, yc - yt);
        let one = T::one();
        let pivots = [
            -two * zc * s9,
            two * lambda * s7,
            two * lambda * s8,
            -two * l * s10,
        ];
        let diagonal = [s1, s2, s3, s4, s5, s6];
        if pivots
            .iter()
            .chain(diagonal.iter())
            .any(|p| *p == T::zero() || !is_finite(one / *p))
        {
            return None;
        }
        let [tau1, tau2, tau3] = self.tau;
        Some(Subs3dFactors {
            c: alpha0_h,
            actuator: [
                tau1 * alpha0_h + one,
                tau2 * alpha0_h + one,
                tau3 * alpha0_h + one,
            ],
            tau: self.tau,
            inv_scale: diagonal.map(|d| one / d),
            inv_pivot: pivots.map(|p| one / p),
            multiplier: [two * dx * s7, two * dy * s8, two * dx * s10, two * dy * s10],
        })
    }

    fn solve(f: &Subs3dFactors<T>, r: &mut SVector<T, N>) {
        let [r1, r2, r3, r4, r5, r6, r7, r8, r9, r10]: [T; N] = (*r).into();
        let [i1, i2, i3, i4, i5, i6] = f.inv_scale;
        let [a1, a2, a3] = f.actuator;
        let (lambda, x, y, l) = algebraic(f, r7, r8, r9, r10);
        let vx = f.c * x - r1 * i1;
        let vy = f.c * y - r2 * i2;
        let vl = f.c * l - r3 * i3;
        let u1 = a1 * vx - r4 * i4;
        let u2 = a2 * vy - r5 * i5;
        let u3 = a3 * vl - r6 * i6;
        *r = SVector::<T, N>::from([x, y, l, vx, vy, vl, lambda, u1, u2, u3]);
    }

    /// The same elimination in complex arithmetic: the algebraic block's rows are real
    /// (no `ẋ` in them), so λ, x, y, l are eliminated part by part with the real pivots;
    /// the shift `c + i b` enters F1–F6 through `c` and `τ_i c + 1`:
    /// `v = (c + i b) η − r/S`, `u = (τ (c + i b) + 1) v − r/S`.
    fn solve_complex(f: &Subs3dFactors<T>, b: T, re: &mut SVector<T, N>, im: &mut SVector<T, N>) {
        let [r1, r2, r3, r4, r5, r6, r7, r8, r9, r10]: [T; N] = (*re).into();
        let [q1, q2, q3, q4, q5, q6, q7, q8, q9, q10]: [T; N] = (*im).into();
        let (lambda_re, x_re, y_re, l_re) = algebraic(f, r7, r8, r9, r10);
        let (lambda_im, x_im, y_im, l_im) = algebraic(f, q7, q8, q9, q10);
        let [i1, i2, i3, i4, i5, i6] = f.inv_scale;
        let [a1, a2, a3] = f.actuator;
        let [tau1, tau2, tau3] = f.tau;
        // v = (c + i b) η − r i_s for each position η.
        let velocity = |p_re: T, p_im: T, r: T, q: T, i: T| {
            (f.c * p_re - b * p_im - r * i, f.c * p_im + b * p_re - q * i)
        };
        let (vx_re, vx_im) = velocity(x_re, x_im, r1, q1, i1);
        let (vy_re, vy_im) = velocity(y_re, y_im, r2, q2, i2);
        let (vl_re, vl_im) = velocity(l_re, l_im, r3, q3, i3);
        // u = (τ (c + i b) + 1) v − r i_s, `a = τ c + 1`.
        let input = |a: T, tau: T, v_re: T, v_im: T, r: T, q: T, i: T| {
            let tb = tau * b;
            (a * v_re - tb * v_im - r * i, a * v_im + tb * v_re - q * i)
        };
        let (u1_re, u1_im) = input(a1, tau1, vx_re, vx_im, r4, q4, i4);
        let (u2_re, u2_im) = input(a2, tau2, vy_re, vy_im, r5, q5, i5);
        let (u3_re, u3_im) = input(a3, tau3, vl_re, vl_im, r6, q6, i6);
        *re = SVector::<T, N>::from([
            x_re, y_re, l_re, vx_re, vy_re, vl_re, lambda_re, u1_re, u2_re, u3_re,
        ]);
        *im = SVector::<T, N>::from([
            x_im, y_im, l_im, vx_im, vy_im, vl_im, lambda_im, u1_im, u2_im, u3_im,
        ]);
    }

    /// The step by forward substitution in the matrix's order, as the planar model's
    /// ([`CraneSubs`](crate::models::crane_subs::CraneSubs)): at each node
    ///
    /// ```text
    /// F9  (Eq. 25, row 4):   λ = (z̈_C,d − g) / (2 z_C,d)
    /// F7, F8 (Eq. 25, row 3): x = x_C,d − ẍ_C,d / (2 λ),  y = y_C,d − ÿ_C,d / (2 λ)
    /// F10 (Eq. 26, 3D):      l² = (x_C,d − x)² + (y_C,d − y)² + z_C,d²
    /// ```
    ///
    /// then `v = q̇` (F1–F3, Eq. 24) and `u_i = τ_i v̇ + v` (F4–F6) through the scheme's
    /// difference formula; increments against `x_{n−1}`, the rope by Heron steps.
    /// `None` for a zero or non-finite λ and an unresolved rope increment.
    fn solve_step<const K: usize, D: DifferenceFormula<T, K>>(
        &self,
        samples: &[Self::Sample; K],
        d: &D,
    ) -> Option<[SVector<T, N>; K]> {
        let two = c::<T>(2.0);
        let a: [T; N] = core::array::from_fn(|j| d.anchor(j));
        let [x0, y0, l0, vx0, vy0, vl0, lambda0, u10, u20, u30] = a;
        let mut refused = false;
        let positions = samples.map(|s| {
            let [[xc, yc, zc], _, [xcdd, ycdd, zcdd]] = s.map(<[T; NU]>::from);
            let lambda = (zcdd - self.g) / (two * zc);
            refused |= lambda == T::zero() || !is_finite(lambda);
            let (ox, oy) = (xcdd / (two * lambda), ycdd / (two * lambda));
            // l² − l_{n−1}² by F10; z_C,d − l_{n−1} is exact (l ≥ z_C ≥ l/2).
            let q = (zc - l0) * (zc + l0) + ox * ox + oy * oy;
            let dl = rope_increment(l0, q);
            refused |= dl.is_none();
            [
                (xc - x0) - ox,
                (yc - y0) - oy,
                dl.unwrap_or_else(T::zero),
                lambda - lambda0,
            ]
        });
        if refused {
            return None;
        }
        let v = [0, 1, 2].map(|j| {
            d.derivative(
                j,
                positions.map(|p| p.get(j).copied().unwrap_or_else(T::zero)),
            )
        });
        let [vx, vy, vl] = v;
        let dv = [(vx, vx0), (vy, vy0), (vl, vl0)].map(|(v, v0)| v.map(|vk| vk - v0));
        let [dvx, dvy, dvl] = dv;
        let [ax, ay, al] = [(3, dvx), (4, dvy), (5, dvl)].map(|(j, dv)| d.derivative(j, dv));
        let [tau1, tau2, tau3] = self.tau;
        let mut out = [SVector::<T, N>::zeros(); K];
        for (k, o) in out.iter_mut().enumerate() {
            let at = |a: &[T; K]| a.get(k).copied().unwrap_or_else(T::zero);
            let [dx, dy, dl, dlambda] = positions.get(k).copied()?;
            *o = SVector::<T, N>::from([
                dx,
                dy,
                dl,
                at(&dvx),
                at(&dvy),
                at(&dvl),
                dlambda,
                tau1 * at(&ax) + at(&vx) - u10,
                tau2 * at(&ay) + at(&vy) - u20,
                tau3 * at(&al) + at(&vl) - u30,
            ]);
        }
        Some(out)
    }
}

/// The algebraic block's forward substitution, rows F9, F7, F8, F10 for λ, x, y, l.
fn algebraic<T: Real>(f: &Subs3dFactors<T>, r7: T, r8: T, r9: T, r10: T) -> (T, T, T, T) {
    let [p_lambda, p_x, p_y, p_l] = f.inv_pivot;
    let [m7, m8, m10x, m10y] = f.multiplier;
    let lambda = r9 * p_lambda;
    let x = (r7 + m7 * lambda) * p_x;
    let y = (r8 + m8 * lambda) * p_y;
    let l = (r10 + m10x * x + m10y * y) * p_l;
    (lambda, x, y, l)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use crate::trajectory::PointToPoint;

    type Model = Crane3dSubs<f64, PointToPoint<f64, 3>>;

    /// The diagonal move with hoisting: (12, 3, 8) → (20, 6, 4) m from t = 1 s to 8 s,
    /// of smoothness `n`.
    fn diagonal(n: usize) -> PointToPoint<f64, 3> {
        PointToPoint::new(
            SVector::from([12.0, 3.0, 8.0]),
            SVector::from([20.0, 6.0, 4.0]),
            1.0,
            7.0,
            n,
        )
        .unwrap()
    }

    /// The model on the diagonal move of the paper's smoothness.
    fn model() -> Model {
        Crane3dSubs::new(Crane3dParams::EXAMPLE, diagonal(4)).unwrap()
    }

    /// A state off the solution near `(x_C, y_C, z_C)`, with every unknown non-zero.
    fn state(s: &<Model as DaeModel<f64, N, NU>>::Sample, k: f64) -> SVector<f64, N> {
        let [[xc, yc, zc], _, _] = s.map(<[f64; 3]>::from);
        let base = [
            xc - 0.3,
            yc + 0.2,
            zc + 0.1,
            0.5,
            -0.3,
            0.2,
            -0.8,
            0.4,
            -0.2,
            0.3,
        ];
        SVector::<f64, N>::from_fn(|i, _| base[i] * (1.0 + 0.2 * (k * 0.37 + i as f64).sin()))
    }

    /// Row scalings: 1 for the differential rows, `ρ = h^-p` for the algebraic ones.
    fn scaling(h: f64, p: i32) -> SVector<f64, N> {
        let rho = 1.0 / h.powi(p);
        SVector::<f64, N>::from_fn(|i, _| if Model::ALGEBRAIC[i] { rho } else { 1.0 })
    }

    /// The positions and velocities are the differential unknowns (`DIFFERENTIAL`),
    /// mid-move, off the solution.
    #[test]
    fn the_first_six_unknowns_are_the_differential_ones() {
        let m = model();
        let s = m.sample(3.8);
        let (x, xdot) = (state(&s, 1.0), state(&s, 2.0));
        crate::models::test_support::assert_differential_first(&m, &x, &xdot, &s);
    }

    /// The exact partials against central differences of the residual, mid-way through
    /// the diagonal move while hoisting (t = 3.8 s: velocity and acceleration non-zero on
    /// every axis), off the solution. The residual is at
    /// most quadratic in `x` and linear in `ẋ`, so central differences are exact up to
    /// rounding: the bound is rounding of the residual's terms (~20 m², ε/δ with δ = 1e-6).
    #[test]
    fn partials_match_central_differences() {
        let m = model();
        let s = m.sample(3.8);
        let [_, zd1, zd2] = s;
        assert!(zd1.iter().all(|v| v.abs() > 0.1) && zd2.iter().all(|v| v.abs() > 1e-3));
        let x = state(&s, 1.0);
        let xdot = SVector::<f64, N>::from_fn(|i, _| 0.1 * (i as f64 + 1.0).cos());
        let p = m.partials(&x, &xdot, &s);
        let delta = 1e-6;
        for j in 0..N {
            let e = SVector::<f64, N>::from_fn(|i, _| if i == j { delta } else { 0.0 });
            let dx =
                (m.residual(&(x + e), &xdot, &s) - m.residual(&(x - e), &xdot, &s)) / (2.0 * delta);
            let dxdot =
                (m.residual(&x, &(xdot + e), &s) - m.residual(&x, &(xdot - e), &s)) / (2.0 * delta);
            for i in 0..N {
                assert!(
                    (dx[i] - p.dx[(i, j)]).abs() <= 1e-7,
                    "∂F{}/∂{}: {} against {}",
                    i + 1,
                    Model::UNKNOWNS[j],
                    dx[i],
                    p.dx[(i, j)]
                );
                assert!(
                    (dxdot[i] - p.dxdot[(i, j)]).abs() <= 1e-7,
                    "∂F{}/∂{}': {} against {}",
                    i + 1,
                    Model::UNKNOWNS[j],
                    dxdot[i],
                    p.dxdot[(i, j)]
                );
            }
        }
    }

    /// At rest the load hangs under the trolley: residual zero with `ẋ = 0`, before the
    /// move and after it; no rest state while the load moves.
    #[test]
    fn rest_state_is_consistent() {
        let m = model();
        for t in [0.0, 1.0, 8.0, 9.0] {
            let x = m.rest_state(t).unwrap();
            let r = m.residual(&x, &SVector::zeros(), &m.sample(t));
            assert!(r.amax() <= 1e-14, "t = {t}: {r}");
            assert!(x[6] < 0.0, "rope in tension");
        }
        assert!(matches!(m.rest_state(4.0), Err(Error::NotAtRest { .. })));
    }

    /// The structured elimination solves the dense system built from the partials, and
    /// agrees with the dense LU of it, at states off the solution and with every row
    /// scaling of Sec. 3.1.1, at BDF4's shift for step sizes 1–50 ms.
    #[test]
    fn structured_elimination_solves_the_dense_newton_system() {
        let m = model();
        for case in 0..200 {
            let k = case as f64;
            let t = 0.045 * k;
            let s = m.sample(t);
            let x = state(&s, k);
            let xdot = SVector::<f64, N>::from_fn(|i, _| (k * 0.71 + 1.3 * i as f64).cos());
            let h: f64 = [0.001, 0.01, 0.05][case % 3];
            let c = 25.0 / 12.0 / h;
            let scale = scaling(h, (case % 4) as i32);
            let p = m.partials(&x, &xdot, &s);
            let mut a = p.dx + p.dxdot * c;
            for (mut row, si) in a.row_iter_mut().zip(scale.iter()) {
                row *= *si;
            }
            let r = SVector::<f64, N>::from_fn(|i, _| (k * 1.7 - 0.9 * i as f64).sin());
            let f = m.factor(&x, &xdot, &s, c, &scale).unwrap();
            let mut eta = r;
            Model::solve(&f, &mut eta);
            let back = a * eta;
            let size = a.abs().column_sum().max() * eta.amax() + r.amax();
            assert!(
                (back - r).amax() <= 1e-13 * size,
                "case {case}: A η − r = {:e}",
                (back - r).amax()
            );
            let mut lu = a;
            let mut piv = [0; N];
            assert!(crate::linalg::factor(&mut lu, &mut piv));
            let mut dense = r;
            crate::linalg::solve(&lu, &piv, &mut dense);
            assert!(
                (dense - eta).amax() <= 1e-9 * dense.amax(),
                "case {case}: dense LU differs by {:e}",
                (dense - eta).amax()
            );
        }
    }

    /// The complex elimination solves RADAU5's complex system
    /// `S (∂F/∂x + (c + i b) ∂F/∂ẋ) w = r`, checked by multiplying back in real
    /// arithmetic: at RADAU5's shift `(α + iβ)/h` and at other shifts `c + i b`.
    #[test]
    fn structured_elimination_solves_the_complex_system() {
        use crate::schemes::radau::transformed::{ALPHA, BETA};
        let m = model();
        for case in 0..160 {
            let k = case as f64;
            let t = 0.06 * k;
            let s = m.sample(t);
            let x = state(&s, k);
            let h: f64 = [0.0005, 0.01, 0.05][case % 3];
            let (c, b) = match case % 4 {
                0 | 1 => (ALPHA / h, BETA / h),
                2 => (3.0 / h, -0.5 / h),
                _ => (0.2 / h, 7.0 / h),
            };
            let scale = scaling(h, ((case / 4) % 4) as i32);
            let p = m.partials(&x, &x, &s);
            let mut a_re = p.dx + p.dxdot * c;
            let mut a_im = p.dxdot * b;
            for ((mut re, mut im), si) in a_re
                .row_iter_mut()
                .zip(a_im.row_iter_mut())
                .zip(scale.iter())
            {
                re *= *si;
                im *= *si;
            }
            let r_re = SVector::<f64, N>::from_fn(|i, _| (k + 2.0 * i as f64).cos());
            let r_im = SVector::<f64, N>::from_fn(|i, _| (k * 1.3 - i as f64).sin());
            let f = m.factor(&x, &x, &s, c, &scale).unwrap();
            let (mut w_re, mut w_im) = (r_re, r_im);
            Model::solve_complex(&f, b, &mut w_re, &mut w_im);
            let back_re = a_re * w_re - a_im * w_im;
            let back_im = a_re * w_im + a_im * w_re;
            let size = (a_re.abs().column_sum().max() + a_im.abs().column_sum().max())
                * w_re.amax().max(w_im.amax())
                + r_re.amax().max(r_im.amax());
            let residual = (back_re - r_re).amax().max((back_im - r_im).amax());
            assert!(
                residual <= 1e-13 * size,
                "case {case}: residual {residual:e}"
            );
            // With b = 0 it is the real elimination.
            let (mut z_re, mut z_im) = (r_re, SVector::<f64, N>::zeros());
            Model::solve_complex(&f, 0.0, &mut z_re, &mut z_im);
            let mut real = r_re;
            Model::solve(&f, &mut real);
            assert_eq!(z_re, real);
            assert_eq!(z_im, SVector::<f64, N>::zeros());
        }
    }

    /// A slack rope (λ = 0) makes the matrix singular: no factors.
    #[test]
    fn singular_matrix_has_no_factors() {
        let m = model();
        let s = m.sample(0.0);
        let mut x = m.rest_state(0.0).unwrap();
        x[6] = 0.0;
        let scale = SVector::<f64, N>::repeat(1.0);
        assert!(m.factor(&x, &x, &s, 200.0, &scale).is_none());
    }

    /// A trajectory that is too rough (n = 3: `u` would jump) is refused.
    #[test]
    fn rough_trajectory_is_refused() {
        let z = diagonal(3);
        assert!(matches!(
            Crane3dSubs::<f64, _>::new(Crane3dParams::EXAMPLE, z),
            Err(Error::TrajectoryTooRough {
                smoothness: 3,
                required: 4
            })
        ));
    }

    /// A difference formula around an anchor, for this model's `N` unknowns.
    type Formula<const K: usize> = crate::models::test_support::Formula<N, K>;

    /// The closed-form step solves the scheme's equations at every node: each row of
    /// `F(x_{n−1} + Δ_k, Ẋ_k, t_k)` vanishes to within a few roundings of its terms, for
    /// BDF4's formula and Radau IIA's, anchors off the solution, h from 0.5 to 50 ms.
    #[test]
    fn closed_form_step_solves_the_step() {
        use crate::schemes::radau::transformed::A_INV;
        use crate::schemes::radau::C;
        fn check<const K: usize>(m: &Model, f: &Formula<K>, times: [f64; K], case: usize) {
            let samples = times.map(|t| m.sample(t));
            let inc = m.solve_step(&samples, f).unwrap();
            let p = Crane3dParams::EXAMPLE;
            let [tau1, tau2, tau3] = [p.tau1, p.tau2, p.tau3];
            for (k, s) in samples.iter().enumerate() {
                let x = f.anchor + inc[k];
                let xd = SVector::<f64, N>::from_fn(|j, _| f.derivative(j, inc.map(|d| d[j]))[k]);
                let r = m.residual(&x, &xd, s);
                let [[xc, yc, zc], _, [xcdd, ycdd, zcdd]] = s.map(<[f64; 3]>::from);
                let (dx, dy, l, lambda) = (xc - x[0], yc - x[1], x[2], x[6]);
                let terms = [
                    xd[0].abs() + x[3].abs(),
                    xd[1].abs() + x[4].abs(),
                    xd[2].abs() + x[5].abs(),
                    tau1 * xd[3].abs() + x[3].abs() + x[7].abs(),
                    tau2 * xd[4].abs() + x[4].abs() + x[8].abs(),
                    tau3 * xd[5].abs() + x[5].abs() + x[9].abs(),
                    xcdd.abs() + 2.0 * (xc.abs() + x[0].abs()) * lambda.abs(),
                    ycdd.abs() + 2.0 * (yc.abs() + x[1].abs()) * lambda.abs(),
                    zcdd.abs() + 9.81 + 2.0 * zc * lambda.abs(),
                    dx * dx + dy * dy + zc * zc + l * l,
                ];
                for (i, (ri, ti)) in r.iter().zip(terms).enumerate() {
                    assert!(
                        ri.abs() <= 8.0 * f64::EPSILON * ti,
                        "case {case}, node {k}, row {i}: {ri:e} against terms {ti:e}"
                    );
                }
            }
        }
        let m = model();
        for case in 0..300 {
            let t = 0.9 + 0.025 * case as f64;
            let h = [0.0005, 0.001, 0.01, 0.05][case % 4];
            let k = (case as f64 * 0.7).sin();
            let before = m.sample(t - h);
            let mut anchor = state(&before, case as f64);
            anchor[2] = before[0][2] * (1.0 + 0.01 * k);
            let past = SVector::<f64, N>::from_fn(|j, _| 1e-3 * (j as f64 - 4.0) * k);
            let bdf = Formula {
                anchor,
                weights: [[25.0 / 12.0 / h]],
                past: past / h,
            };
            check(&m, &bdf, [t], case);
            let radau = Formula {
                anchor,
                weights: A_INV.map(|row| row.map(|a| a / h)),
                past: SVector::zeros(),
            };
            check(&m, &radau, C.map(|c| t - h + c * h), case);
        }
    }

    /// A slack rope (z̈_C,d = g: λ = 0) has no closed-form step.
    #[test]
    fn slack_rope_has_no_closed_form_step() {
        let m = model();
        let mut s = m.sample(3.0);
        s[2][2] = Crane3dParams::EXAMPLE.g;
        let f = Formula {
            anchor: m.rest_state(0.0).unwrap(),
            weights: [[2500.0]],
            past: SVector::zeros(),
        };
        assert!(m.solve_step(&[s], &f).is_none());
    }
}
