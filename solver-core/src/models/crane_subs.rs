//! The crane in redundant coordinates with the servo-constraints substituted: *subs*.
//!
//! Eqs. 24–26 describe the crane in the redundant coordinates `[x, l, x_C, z_C]`
//! with one rope constraint (Eq. 26) and its multiplier λ. The servo-constraints
//! Eq. 28 prescribe `x_C = x_C,d(t)`, `z_C = z_C,d(t)`; substituting them (as in
//! Otto & Seifried 2018, ref. \[4\]) removes the load coordinates and leaves, with
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
use crate::model::{DaeModel, DifferenceFormula, Driven, Partials, StructuredJacobian};
use crate::models::crane::{check_trajectory, CraneParams};
use crate::scalar::{c, Real};
use crate::trajectory::{ensure_at_rest, Trajectory};

/// Number of unknowns of the *subs* formulation.
pub const N: usize = 7;
/// Number of inputs.
pub const NU: usize = 2;
schemes_of!(CraneSubs, structured);

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
    /// x, l, v_x, v_l; λ, u1, u2 have no derivative in F.
    const DIFFERENTIAL: usize = 4;
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
        // The order the step samples (`sample`), not `::<1>`: the value has the same
        // bits, and a firmware then links one evaluation of its plan, not two.
        let [[xc, zc], _, _] = self.trajectory.derivatives::<3>(t).map(<[T; 2]>::from);
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

/// The factors of the *subs* Newton matrix (see [`StructuredJacobian`] for `CraneSubs`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubsFactors<T> {
    /// `c = α₀/h`.
    c: T,
    /// `τ1 c + 1`, `τ2 c + 1`.
    actuator: [T; 2],
    /// `τ1`, `τ2` (the imaginary part of the actuator rows for a complex shift).
    tau: [T; 2],
    /// `1/S_i` of the four differential rows.
    inv_scale: [T; 4],
    /// Reciprocal pivots of the rows F6 (for λ), F5 (for x), F7 (for l).
    inv_pivot: [T; 3],
    /// `2 (x_C,d − x) S_5`, `2 (x_C,d − x) S_7`: the multipliers of F5 and F7.
    multiplier: [T; 2],
}

/// The Newton matrix of *subs* is triangular in the order λ, x, l, v_x, v_l, u1, u2:
///
/// ```text
/// F6: −2 z_C,d S6 · η_λ                              = r6
/// F5:  2 λ S5 · η_x − 2 (x_C,d − x) S5 · η_λ          = r5
/// F7: −2 l S7 · η_l − 2 (x_C,d − x) S7 · η_x          = r7
/// F1:  c S1 · η_x − S1 · η_vx                         = r1     (F2 likewise for l, v_l)
/// F3: (τ1 c + 1) S3 · η_vx − S3 · η_u1                = r3     (F4 likewise for v_l, u2)
/// ```
///
/// Its pivots are those of the algebraic block, whose determinant `−8 λ z_C l` vanishes
/// only for a slack rope (refused up front), at `z_C = 0` or `l = 0`: no pivot search is
/// needed, and the elimination costs 3 divisions and 20 multiply-adds instead of a
/// 7×7 LU.
impl<T: Real, Z: Trajectory<T, 2>> StructuredJacobian<T, N, 2> for CraneSubs<T, Z> {
    type Factors = SubsFactors<T>;

    const CLOSED_FORM: bool = true;

    fn factor(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
        alpha0_h: T,
        scale: &SVector<T, N>,
    ) -> Option<SubsFactors<T>> {
        let [xt, l, _, _, lambda, _, _]: [T; N] = (*x).into();
        let [s1, s2, s3, s4, s5, s6, s7]: [T; N] = (*scale).into();
        let [[xc, zc], _, _] = s.map(<[T; 2]>::from);
        let two = c::<T>(2.0);
        let dx = xc - xt;
        let one = T::one();
        let pivots = [-two * zc * s6, two * lambda * s5, -two * l * s7];
        let diagonal = [s1, s2, s3, s4];
        if pivots
            .iter()
            .chain(diagonal.iter())
            .any(|p| *p == T::zero() || !crate::scalar::is_finite(one / *p))
        {
            return None;
        }
        Some(SubsFactors {
            c: alpha0_h,
            actuator: [self.tau1 * alpha0_h + one, self.tau2 * alpha0_h + one],
            tau: [self.tau1, self.tau2],
            inv_scale: diagonal.map(|d| one / d),
            inv_pivot: pivots.map(|p| one / p),
            multiplier: [two * dx * s5, two * dx * s7],
        })
    }

    fn solve(f: &SubsFactors<T>, r: &mut SVector<T, N>) {
        let [r1, r2, r3, r4, r5, r6, r7]: [T; N] = (*r).into();
        let [i1, i2, i3, i4] = f.inv_scale;
        let [p_lambda, p_x, p_l] = f.inv_pivot;
        let [m5, m7] = f.multiplier;
        let [a1, a2] = f.actuator;
        let lambda = r6 * p_lambda;
        let x = (r5 + m5 * lambda) * p_x;
        let l = (r7 + m7 * x) * p_l;
        let vx = f.c * x - r1 * i1;
        let vl = f.c * l - r2 * i2;
        let u1 = a1 * vx - r3 * i3;
        let u2 = a2 * vl - r4 * i4;
        *r = SVector::<T, N>::from([x, l, vx, vl, lambda, u1, u2]);
    }

    /// The same elimination in complex arithmetic: the algebraic block's pivots do not
    /// depend on the shift (its rows are real), so λ, x, l are eliminated part by part;
    /// the shift `c + i b` enters F1–F4 through `c` and `τ c + 1`.
    fn solve_complex(f: &SubsFactors<T>, b: T, re: &mut SVector<T, N>, im: &mut SVector<T, N>) {
        let [i1, i2, i3, i4] = f.inv_scale;
        let [p_lambda, p_x, p_l] = f.inv_pivot;
        let [m5, m7] = f.multiplier;
        let [a1, a2] = f.actuator;
        let [tau1, tau2] = f.tau;
        let algebraic = |r: &SVector<T, N>| {
            let [_, _, _, _, r5, r6, r7]: [T; N] = (*r).into();
            let lambda = r6 * p_lambda;
            let x = (r5 + m5 * lambda) * p_x;
            let l = (r7 + m7 * x) * p_l;
            (lambda, x, l)
        };
        let (lambda_re, x_re, l_re) = algebraic(re);
        let (lambda_im, x_im, l_im) = algebraic(im);
        let [r1, r2, r3, r4, _, _, _]: [T; N] = (*re).into();
        let [q1, q2, q3, q4, _, _, _]: [T; N] = (*im).into();
        // v = (c + i b) η − r i_s; u = (τ (c + i b) + 1) v − r i_s.
        let vx_re = f.c * x_re - b * x_im - r1 * i1;
        let vx_im = f.c * x_im + b * x_re - q1 * i1;
        let vl_re = f.c * l_re - b * l_im - r2 * i2;
        let vl_im = f.c * l_im + b * l_re - q2 * i2;
        let (tb1, tb2) = (tau1 * b, tau2 * b);
        let u1_re = a1 * vx_re - tb1 * vx_im - r3 * i3;
        let u1_im = a1 * vx_im + tb1 * vx_re - q3 * i3;
        let u2_re = a2 * vl_re - tb2 * vl_im - r4 * i4;
        let u2_im = a2 * vl_im + tb2 * vl_re - q4 * i4;
        *re = SVector::<T, N>::from([x_re, l_re, vx_re, vl_re, lambda_re, u1_re, u2_re]);
        *im = SVector::<T, N>::from([x_im, l_im, vx_im, vl_im, lambda_im, u1_im, u2_im]);
    }

    /// The step by forward substitution in the matrix's order, node by node for the
    /// algebraic rows, which hold at each node on the trajectory alone:
    ///
    /// ```text
    /// F6 (Eq. 25, row 4):  λ = (z̈_C,d − g) / (2 z_C,d)
    /// F5 (Eq. 25, row 3):  x = x_C,d − ẍ_C,d / (2 λ)           (the offset ẍ_C,d/(2λ))
    /// F7 (Eq. 26):         l² = z_C,d² + (x_C,d − x)²
    /// ```
    ///
    /// then the differential rows through the scheme's difference formula, which is
    /// linear: `v_x = ẋ`, `v_l = l̇` (F1, F2, Eq. 24) and `u_i = τ_i v̇ + v` (F3, F4,
    /// Eq. 25 rows 1–2). Everything is formed as an increment against `x_{n−1}` (see
    /// [`StructuredJacobian::solve_step`]); the rope's by Heron steps, without a square
    /// root (`rope_increment`). `None` for a zero or non-finite λ (a slack rope,
    /// `z_C,d = 0`: the pivots [`factor`](StructuredJacobian::factor) refuses too) and
    /// for a rope increment the Heron steps do not resolve.
    fn solve_step<const K: usize, D: DifferenceFormula<T, K>>(
        &self,
        samples: &[Self::Sample; K],
        d: &D,
    ) -> Option<[SVector<T, N>; K]> {
        let two = c::<T>(2.0);
        let [x0, l0, vx0, vl0, lambda0, u10, u20] = core::array::from_fn(|j| d.anchor(j));
        let mut refused = false;
        let positions = samples.map(|s| {
            let [[xc, zc], _, [xcdd, zcdd]] = s.map(<[T; 2]>::from);
            let lambda = (zcdd - self.g) / (two * zc);
            refused |= lambda == T::zero() || !crate::scalar::is_finite(lambda);
            let offset = xcdd / (two * lambda);
            // l² − l_{n−1}² by F7; z_C,d − l_{n−1} is exact (Sterbenz: l ≥ z_C ≥ l/2).
            let q = (zc - l0) * (zc + l0) + offset * offset;
            let dl = rope_increment(l0, q);
            refused |= dl.is_none();
            let dl = dl.unwrap_or_else(T::zero);
            [(xc - x0) - offset, dl, lambda - lambda0]
        });
        if refused {
            return None;
        }
        let vx = d.derivative(0, positions.map(|[dx, _, _]| dx));
        let vl = d.derivative(1, positions.map(|[_, dl, _]| dl));
        let dvx = vx.map(|v| v - vx0);
        let dvl = vl.map(|v| v - vl0);
        let ax = d.derivative(2, dvx);
        let al = d.derivative(3, dvl);
        let mut out = [SVector::<T, N>::zeros(); K];
        for (k, o) in out.iter_mut().enumerate() {
            let at = |a: &[T; K]| a.get(k).copied().unwrap_or_else(T::zero);
            let [dx, dl, dlambda] = positions.get(k).copied()?;
            *o = SVector::<T, N>::from([
                dx,
                dl,
                at(&dvx),
                at(&dvl),
                dlambda,
                self.tau1 * at(&ax) + at(&vx) - u10,
                self.tau2 * at(&al) + at(&vl) - u20,
            ]);
        }
        Some(out)
    }
}

/// Heron steps on F7 (Eq. 26) in increments — Newton's method on `l² = l₀² + q`,
/// `i ← (i² + q) / (2 (l₀ + i))` from `i = 0`, the first step being the linearisation
/// `q / (2 l₀)` — instead of a square root: `libm`'s is a software routine on the
/// Cortex-M7 (about 90 instructions, DESIGN), a step here one division. The error after
/// step k is about the square of the one before over `2 l`, from `i² / (2 l₀)` after the
/// first: four steps reach the increment's rounding while `|i| ≤ 0.15 l₀` (the paper's
/// move changes its rope by at most 1.2 m/s, 0.2 % of its length in a 10 ms step, 1 %
/// in 50 ms). What is left is about `δ² / (2 l)`, `δ` the last update: more than the
/// increment's rounding is refused (`None`), and the strategies keep their predictors.
pub(crate) fn rope_increment<T: Real>(l0: T, q: T) -> Option<T> {
    const STEPS: usize = 4;
    let two = c::<T>(2.0);
    let (mut i, mut update) = (T::zero(), T::zero());
    for _ in 0..STEPS {
        let next = (i * i + q) / (two * (l0 + i));
        update = next - i;
        i = next;
    }
    (update * update <= T::default_epsilon() * two * (l0 + i) * i.abs()).then_some(i)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use crate::models::crane::CraneParams;
    use crate::trajectory::PointToPoint;

    fn model() -> CraneSubs<f64, PointToPoint<f64, 2>> {
        let z = PointToPoint::new(
            SVector::from([12.0, 8.0]),
            SVector::from([20.0, 4.0]),
            1.0,
            8.0,
            4,
        )
        .unwrap();
        CraneSubs::new(CraneParams::PAPER, z).unwrap()
    }

    /// x, l, v_x, v_l are the differential unknowns (`DIFFERENTIAL`), mid-move, off the
    /// solution.
    #[test]
    fn the_first_four_unknowns_are_the_differential_ones() {
        let m = model();
        let s = m.sample(3.8);
        let x = SVector::from([15.0, 6.5, 0.4, -0.3, -0.6, 0.5, -0.2]);
        let xdot = SVector::from([0.3, -0.2, 0.1, 0.05, 0.7, -0.4, 0.9]);
        crate::models::test_support::assert_differential_first(&m, &x, &xdot, &s);
    }

    /// The structured elimination solves the dense system built from the partials, at
    /// states off the solution and with every row scaling of Sec. 3.1.1.
    #[test]
    fn structured_elimination_solves_the_dense_newton_system() {
        let m = model();
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut rand = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for case in 0..200 {
            let t = 0.05 * case as f64;
            let s = m.sample(t);
            let x = SVector::<f64, N>::from_fn(|i, _| {
                let base = [15.0, 6.0, 0.5, -0.3, -0.8, 0.4, -0.2][i];
                base * (1.0 + 0.3 * rand())
            });
            let xdot = SVector::<f64, N>::from_fn(|_, _| rand());
            let h: f64 = [0.001, 0.01, 0.05][case % 3];
            let c = 25.0 / 12.0 / h;
            let rho = 1.0 / h.powi((case % 4) as i32);
            let scale = SVector::<f64, N>::from_fn(|i, _| if i >= 4 { rho } else { 1.0 });
            let p = m.partials(&x, &xdot, &s);
            let mut a = p.dx + p.dxdot * c;
            for (mut row, si) in a.row_iter_mut().zip(scale.iter()) {
                row *= *si;
            }
            let r = SVector::<f64, N>::from_fn(|_, _| rand());
            let f = m.factor(&x, &xdot, &s, c, &scale).unwrap();
            let mut eta = r;
            CraneSubs::<f64, PointToPoint<f64, 2>>::solve(&f, &mut eta);
            let back = a * eta;
            let size = a.abs().column_sum().max() * eta.amax() + r.amax();
            assert!(
                (back - r).amax() <= 1e-13 * size,
                "case {case}: A η − r = {:e}",
                (back - r).amax()
            );
            // The dense LU agrees.
            let mut lu = a;
            let mut piv = [0; N];
            assert!(crate::linalg::factor(&mut lu, &mut piv));
            let mut dense = r;
            crate::linalg::solve(&lu, &piv, &mut dense);
            assert!((dense - eta).amax() <= 1e-9 * dense.amax(), "case {case}");
        }
    }

    /// The complex elimination solves RADAU5's complex system `(J_x + (α+iβ)/h J_ẋ) w = r`
    /// (rows scaled), checked by multiplying back in real arithmetic.
    #[test]
    fn structured_elimination_solves_the_complex_system() {
        use crate::schemes::radau::transformed::{ALPHA, BETA};
        let m = model();
        for case in 0..120 {
            let t = 0.08 * case as f64;
            let s = m.sample(t);
            let k = case as f64;
            let x = SVector::<f64, N>::from_fn(|i, _| {
                let base = [15.0, 6.0, 0.5, -0.3, -0.8, 0.4, -0.2][i];
                base * (1.0 + 0.2 * (k * 0.37 + i as f64).sin())
            });
            let h: f64 = [0.0005, 0.01, 0.05][case % 3];
            let (c, b) = (ALPHA / h, BETA / h);
            let rho = 1.0 / h.powi((case % 4) as i32);
            let scale = SVector::<f64, N>::from_fn(|i, _| if i >= 4 { rho } else { 1.0 });
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
            CraneSubs::<f64, PointToPoint<f64, 2>>::solve_complex(&f, b, &mut w_re, &mut w_im);
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
        }
    }

    /// A slack rope (λ = 0) makes the matrix singular: no factors.
    #[test]
    fn singular_matrix_has_no_factors() {
        let m = model();
        let s = m.sample(0.0);
        let mut x = m.rest_state(0.0).unwrap();
        x[4] = 0.0;
        let scale = SVector::<f64, N>::repeat(1.0);
        assert!(m.factor(&x, &x, &s, 200.0, &scale).is_none());
    }

    /// A difference formula around an anchor, for this model's `N` unknowns.
    type Formula<const K: usize> = crate::models::test_support::Formula<N, K>;

    /// The closed-form step solves the scheme's equations at every node: each row of
    /// `F(x_{n−1} + Δ_k, Ẋ_k, t_k)` vanishes to within a few roundings of its terms, for
    /// one node (BDF4's formula) and three (Radau IIA's), anchors off the solution and
    /// h from 0.5 ms to 50 ms.
    #[test]
    fn closed_form_step_solves_the_step() {
        use crate::schemes::radau::transformed::A_INV;
        use crate::schemes::radau::C;
        let m = model();
        fn check<const K: usize>(
            m: &CraneSubs<f64, PointToPoint<f64, 2>>,
            f: &Formula<K>,
            times: [f64; K],
            case: usize,
        ) {
            let samples = times.map(|t| m.sample(t));
            let inc = m.solve_step(&samples, f).unwrap();
            let xdot =
                |k: usize| SVector::<f64, N>::from_fn(|j, _| f.derivative(j, inc.map(|d| d[j]))[k]);
            for (k, s) in samples.iter().enumerate() {
                let x = f.anchor + inc[k];
                let xd = xdot(k);
                let r = m.residual(&x, &xd, s);
                let [[xc, zc], _, [xcdd, zcdd]] = s.map(<[f64; 2]>::from);
                let (dx, l, lambda) = (xc - x[0], x[1], x[4]);
                let terms = [
                    xd[0].abs() + x[2].abs(),
                    xd[1].abs() + x[3].abs(),
                    0.03 * xd[2].abs() + x[2].abs() + x[5].abs(),
                    0.02 * xd[3].abs() + x[3].abs() + x[6].abs(),
                    xcdd.abs() + 2.0 * (xc.abs() + x[0].abs()) * lambda.abs(),
                    zcdd.abs() + 9.81 + 2.0 * zc * lambda.abs(),
                    zc * zc + dx * dx + l * l,
                ];
                for (i, (ri, ti)) in r.iter().zip(terms).enumerate() {
                    assert!(
                        ri.abs() <= 8.0 * f64::EPSILON * ti,
                        "case {case}, node {k}, row {i}: {ri:e} against terms {ti:e}"
                    );
                }
            }
        }
        for case in 0..300 {
            let t = 0.9 + 0.027 * case as f64;
            let h = [0.0005, 0.001, 0.01, 0.05][case % 4];
            let k = (case as f64 * 0.7).sin();
            let mut anchor = m.rest_state(0.0).unwrap();
            anchor[0] = m.sample(t - h)[0][0] - 0.3 * k;
            anchor[1] = m.sample(t - h)[0][1] * (1.0 + 0.01 * k);
            anchor[2] = 0.4 * k;
            anchor[3] = -0.2 * k;
            anchor[5] = 0.6 * k;
            anchor[6] = -0.1 * k;
            let past = SVector::<f64, N>::from_fn(|j, _| 1e-3 * (j as f64 - 3.0) * k);
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

    /// The rope's increment without a square root agrees with one to rounding wherever
    /// the step changes the rope by up to 15 % of its length, and is refused beyond.
    #[test]
    fn rope_increment_is_the_square_root_to_rounding() {
        for l0 in [3.0_f64, 4.0, 8.0, 9.0] {
            for r in [
                0.0, 1e-12, 1e-6, 1e-3, 4e-3, 0.01, 0.05, 0.1, 0.15, -1e-9, -0.01, -0.1, -0.15,
            ] {
                let l = l0 * (1.0 + r);
                let q = (l - l0) * (l + l0);
                let exact = libm::sqrt(l0 * l0 + q) - l0;
                let i = rope_increment(l0, q).unwrap();
                assert!(
                    (i - exact).abs() <= 4.0 * f64::EPSILON * l0,
                    "l0 = {l0}, r = {r}: {i:e} against {exact:e}"
                );
            }
            assert!(rope_increment(l0, (0.8 * l0) * (2.8 * l0)).is_none());
        }
    }

    /// A slack rope (z̈_C,d = g: λ = 0) has no closed-form step.
    #[test]
    fn slack_rope_has_no_closed_form_step() {
        let m = model();
        let mut s = m.sample(3.0);
        s[2][1] = 9.81;
        let f = Formula {
            anchor: m.rest_state(0.0).unwrap(),
            weights: [[2500.0]],
            past: SVector::zeros(),
        };
        assert!(m.solve_step(&[s], &f).is_none());
    }
}
