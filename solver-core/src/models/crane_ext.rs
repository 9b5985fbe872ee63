//! The planar crane minimally extended to index 1: *ext* (Altmann, Betsch & Yang,
//! the paper's ref. \[11\]).
//!
//! ## Why
//!
//! *subs* ([`crane_subs`](super::crane_subs), Eqs. 24–28) has index 3: its algebraic
//! rows F5–F7 fix `x`, `l` and λ at every instant, and the solver reaches the inputs by
//! differentiating them twice through the scheme's difference formula — rounding is
//! amplified by about `1/h³`, and every scheme has a floor below a few ms (DESIGN,
//! *Conditioning*).
//!
//! ## The extension
//!
//! Minimal extension appends the hidden constraints — the first and second time
//! derivatives of F5–F7 — and, to keep the system square, one new algebraic unknown for
//! each appended row in place of a derivative. The constraint Jacobian of F5–F7 with
//! respect to the positions `(x, l)` and λ is invertible along every admissible motion
//! (determinant `−8 λ z_C l`, see *subs*), so every position is a constrained one: the
//! derivatives `ẋ`, `l̇` (Eq. 24) and `v̇_x`, `v̇_l` (Eq. 25, rows 1–2) are all replaced,
//! by `x'`, `l'`, `a_x`, `a_l`, and the rates of λ that the derivatives of F5–F6 bring in
//! get their own unknowns `μ = λ̇`, `ν = λ̈`. With
//! `x = [x, l, v_x, v_l, λ, u1, u2, x', l', μ, a_x, a_l, ν]` (*subs*' unknowns first,
//! in *subs*' order) and `d = x_C,d − x`, `dv = ẋ_C,d − v_x`, `da = ẍ_C,d − a_x`:
//!
//! ```text
//! F1  = x' − v_x                                  (24, ẋ → x')
//! F2  = l' − v_l                                  (24, l̇ → l')
//! F3  = τ1 a_x + v_x − u1                          (25, row 1, v̇_x → a_x)
//! F4  = τ2 a_l + v_l − u2                          (25, row 2, v̇_l → a_l)
//! F5  = ẍ_C,d − 2 d λ                              (25, row 3)
//! F6  = z̈_C,d − g − 2 z_C,d λ                       (25, row 4)
//! F7  = z_C,d² + d² − l²                            (26)
//! F8  = x⃛_C,d − 2 dv λ − 2 d μ                      (d/dt F5)
//! F9  = z⃛_C,d − 2 ż_C,d λ − 2 z_C,d μ                (d/dt F6)
//! F10 = d dv + z_C,d ż_C,d − l v_l                   (½ d/dt F7)
//! F11 = x⁗_C,d − 2 da λ − 4 dv μ − 2 d ν             (d²/dt² F5)
//! F12 = z⁗_C,d − 2 z̈_C,d λ − 4 ż_C,d μ − 2 z_C,d ν    (d²/dt² F6)
//! F13 = dv² + d da + ż_C,d² + z_C,d z̈_C,d − v_l² − l a_l   (½ d²/dt² F7)
//! ```
//!
//! F1–F7 are *subs*' rows with the derivatives replaced; F8–F13 are the hidden
//! constraints, written along the motion with the velocities and accelerations in place
//! of `ẋ`, `l̇`, `ẍ`, `l̈` (F1–F4 make them equal), as a mechanical system's velocity and
//! acceleration constraints are ([`crane_hidden`](super::crane_hidden) derives the rows
//! once for the planar and the 3D crane).
//!
//! ## What it is
//!
//! No row has an `ẋ` left: the system is algebraic, `∂F/∂x` invertible along the motion
//! (triangular, below), so it has index 1 — the crane is flat, it has no dynamics of its
//! own to integrate ([`crane`](super::crane)). Every scheme then solves the same
//! equations at its nodes, and its solution is the flat inverse to rounding whatever h:
//! no discretisation error, no `1/h³` amplification, and a Newton matrix whose condition
//! does not depend on h. What a scheme adds is only cost (Radau solves three nodes per
//! step). The inputs need the load path's 4th derivative, as *subs*' do
//! (`MIN_SMOOTHNESS` 4).
//!
//! *proj* ([`crane_proj`](super::crane_proj)) extended the same way fixes `x`, `l`, φ by
//! its rows F6–F8 and would become the same algebraic flat inverse in minimal coordinates,
//! with trigonometry and one unknown more: it is not built.

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::model::{DaeModel, DifferenceFormula, Driven, Partials, StructuredJacobian};
use crate::models::crane::{check_trajectory, CraneParams};
use crate::models::crane_hidden::{
    horizontal_rows, offsets, rope_rows, set, vertical_rows, ChainPoint, ClosedForm, Derivatives,
    Layout,
};
use crate::scalar::{c, is_finite, Real};
use crate::trajectory::{ensure_at_rest, Trajectory};

/// Number of unknowns of the *ext* formulation.
pub const N: usize = 13;
/// Number of inputs.
pub const NU: usize = 2;
schemes_of!(CraneExt, structured);

/// Where the constraint chain's rows and unknowns sit (see the module's equations).
const CHAIN: Layout<1> = Layout {
    horizontal_rows: [[4, 7, 10]],
    vertical_rows: [5, 8, 11],
    rope_rows: [6, 9, 12],
    horizontal: [[0, 2, 10]],
    rope: [1, 3, 11],
    lambda: [4, 9, 12],
};

/// The crane *ext* inverse model, driven by a load trajectory `Z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CraneExt<T: Real, Z> {
    params: CraneParams,
    g: T,
    /// τ1, τ2.
    tau: [T; 2],
    trajectory: Z,
}

impl<T: Real, Z: Trajectory<T, 2>> CraneExt<T, Z> {
    /// Builds the model after checking the parameters and the whole trajectory
    /// (smoothness, rope-slack margin, workspace), as *subs* does.
    pub fn new(params: CraneParams, trajectory: Z) -> Result<Self> {
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
            tau: [c(params.tau1), c(params.tau2)],
            trajectory,
        })
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &CraneParams {
        &self.params
    }
}

impl<T: Real, Z> Driven for CraneExt<T, Z> {
    type Trajectory = Z;

    fn trajectory(&self) -> &Z {
        &self.trajectory
    }

    fn trajectory_mut(&mut self) -> &mut Z {
        &mut self.trajectory
    }
}

/// The load path of a sample: `x_C,d` and `z_C,d`, each with its derivatives 0..=4.
fn path<T: Real>(s: &[SVector<T, 2>; 5]) -> (Derivatives<T>, Derivatives<T>) {
    let [[x0, z0], [x1, z1], [x2, z2], [x3, z3], [x4, z4]] = s.map(<[T; 2]>::from);
    ([x0, x1, x2, x3, x4], [z0, z1, z2, z3, z4])
}

impl<T: Real, Z: Trajectory<T, 2>> DaeModel<T, N, NU> for CraneExt<T, Z> {
    const UNKNOWNS: [&'static str; N] = [
        "x", "l", "vx", "vl", "lambda", "u1", "u2", "x'", "l'", "mu", "ax", "al", "nu",
    ];
    /// Every row: none has an `ẋ` (index 1, see the module's documentation).
    const ALGEBRAIC: [bool; N] = [true; N];
    /// None: no unknown's derivative enters F.
    const DIFFERENTIAL: usize = 0;
    const INPUTS: [usize; NU] = [5, 6];
    /// `u` contains `z_d⁗` (F11, F13); with n ≥ 4 it is continuous.
    const MIN_SMOOTHNESS: usize = 4;

    /// `[z_d, ż_d, z̈_d, z⃛_d, z⁗_d]`.
    type Sample = [SVector<T, 2>; 5];

    fn sample(&self, t: T) -> Self::Sample {
        self.trajectory.derivatives::<5>(t)
    }

    fn residual(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
    ) -> SVector<T, N> {
        let [xt, l, vx, vl, lambda, u1, u2, xd, ld, mu, ax, al, nu]: [T; N] = (*x).into();
        let (xc, z) = path(s);
        let chain = [lambda, mu, nu];
        let d = offsets(&xc, [xt, vx, ax]);
        let [f5, f8, f11] = horizontal_rows(&xc, d, chain);
        let [f6, f9, f12] = vertical_rows(self.g, &z, chain);
        let [f7, f10, f13] = rope_rows(&[d], &z, [l, vl, al]);
        let [tau1, tau2] = self.tau;
        SVector::<T, N>::from([
            xd - vx,
            ld - vl,
            tau1 * ax + vx - u1,
            tau2 * al + vl - u2,
            f5,
            f6,
            f7,
            f8,
            f9,
            f10,
            f11,
            f12,
            f13,
        ])
    }

    fn partials(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
    ) -> Partials<T, N> {
        let one = T::one();
        let [tau1, tau2] = self.tau;
        let mut dx = SMatrix::<T, N, N>::zeros();
        // F1, F2: x' − v_x, l' − v_l; F3, F4: τ a + v − u.
        for (row, col, v) in [
            (0, 7, one),
            (0, 2, -one),
            (1, 8, one),
            (1, 3, -one),
            (2, 10, tau1),
            (2, 2, one),
            (2, 5, -one),
            (3, 11, tau2),
            (3, 3, one),
            (3, 6, -one),
        ] {
            set(&mut dx, row, col, v);
        }
        self.chain_point(x, s).partials_into(&CHAIN, &mut dx);
        Partials {
            dx,
            dxdot: SMatrix::zeros(),
        }
    }

    fn rest_state(&self, t: T) -> Result<SVector<T, N>> {
        ensure_at_rest(&self.trajectory, t)?;
        // The order the step samples (`sample`): the same bits as `::<1>`, one evaluation linked.
        let [[xc, zc], ..] = self.trajectory.derivatives::<5>(t).map(<[T; 2]>::from);
        // Hanging straight down: x = x_C, l = z_C, λ = −g/(2 z_C) (F6); every rate zero.
        let lambda = -self.g / (c::<T>(2.0) * zc);
        let mut x = SVector::<T, N>::zeros();
        for (j, v) in [(0, xc), (1, zc), (4, lambda)] {
            if let Some(e) = x.get_mut(j) {
                *e = v;
            }
        }
        Ok(x)
    }

    /// The load position: the servo-constraints hold by construction, `z = z_d(t)`.
    fn output(&self, _x: &SVector<T, N>, s: &Self::Sample) -> SVector<T, NU> {
        let [z, ..] = *s;
        z
    }
}

impl<T: Real, Z> CraneExt<T, Z> {
    /// The constraint chain's values at `x` and the sample `s`.
    fn chain_point(&self, x: &SVector<T, N>, s: &[SVector<T, 2>; 5]) -> ChainPoint<T, 1> {
        let [xt, l, vx, vl, lambda, _, _, _, _, mu, ax, al, nu]: [T; N] = (*x).into();
        let (xc, [z0, z1, z2, _, _]) = path(s);
        ChainPoint {
            z: [z0, z1, z2],
            d: [offsets(&xc, [xt, vx, ax])],
            rope: [l, vl, al],
            lambda: [lambda, mu, nu],
        }
    }
}

/// The factors of the *ext* Newton matrix (see [`StructuredJacobian`] for [`CraneExt`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtFactors<T> {
    /// The chain's values where the matrix was formed.
    point: ChainPoint<T, 1>,
    /// `[1/(2 z_C,d), 1/(2λ), 1/l]`.
    inv_pivot: [T; 3],
    /// τ1, τ2.
    tau: [T; 2],
    /// `1/S_i` of every row.
    inv_scale: [T; N],
}

/// The Newton matrix `S·∂F/∂x` of *ext* (`∂F/∂ẋ = 0`: the shift `c` does not enter) is
/// triangular in the order λ, μ, ν (F6, F9, F12), x, v_x, a_x (F5, F8, F11), l, v_l, a_l
/// (F7, F10, F13), x', l' (F1, F2), u1, u2 (F3, F4) — the chain's order
/// ([`crane_hidden`](super::crane_hidden)), then the drives' rows. Its pivots `−2 z_C,d`,
/// `2λ`, `−2l`, `−l`, `1`, `−1` vanish only for a slack rope (refused up front),
/// `z_C,d = 0` or `l = 0`: no pivot search, 3 reciprocals and about 60 multiply-adds
/// instead of a 13×13 LU. RADAU5's complex system is the real one for each part (its
/// `∂F/∂ẋ` term is zero), solved with the same factors.
impl<T: Real, Z: Trajectory<T, 2>> StructuredJacobian<T, N, NU> for CraneExt<T, Z> {
    type Factors = ExtFactors<T>;

    const CLOSED_FORM: bool = true;

    fn factor(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
        _c: T,
        scale: &SVector<T, N>,
    ) -> Option<ExtFactors<T>> {
        let point = self.chain_point(x, s);
        let inv_pivot = point.inverse_pivots()?;
        let inv_scale: [T; N] = scale.map(|s| T::one() / s).into();
        if !inv_scale.iter().all(|v| is_finite(*v)) {
            return None;
        }
        Some(ExtFactors {
            point,
            inv_pivot,
            tau: self.tau,
            inv_scale,
        })
    }

    fn solve(f: &ExtFactors<T>, r: &mut SVector<T, N>) {
        let unscaled: [T; N] = core::array::from_fn(|i| {
            let (ri, si) = (r.get(i), f.inv_scale.get(i));
            ri.zip(si).map_or_else(T::zero, |(r, s)| *r * *s)
        });
        let [r1, r2, r3, r4, r5, r6, r7, r8, r9, r10, r11, r12, r13] = unscaled;
        let ([lambda, mu, nu], [[x, vx, ax]], [l, vl, al]) =
            f.point
                .solve(&f.inv_pivot, [r6, r9, r12], [[r5, r8, r11]], [r7, r10, r13]);
        let [tau1, tau2] = f.tau;
        // F1: η_x' − η_vx = r; F3: τ1 η_ax + η_vx − η_u1 = r (F2, F4 likewise).
        *r = SVector::<T, N>::from([
            x,
            l,
            vx,
            vl,
            lambda,
            tau1 * ax + vx - r3,
            tau2 * al + vl - r4,
            r1 + vx,
            r2 + vl,
            mu,
            ax,
            al,
            nu,
        ]);
    }

    /// `∂F/∂ẋ = 0`: the complex system is the real one for the real and the imaginary
    /// part alike.
    fn solve_complex(f: &ExtFactors<T>, _b: T, re: &mut SVector<T, N>, im: &mut SVector<T, N>) {
        Self::solve(f, re);
        Self::solve(f, im);
    }

    /// The step by forward substitution in the matrix's order, node by node
    /// (`crane_hidden::ClosedForm`): λ, μ, ν from F6, F9, F12, the trolley's offset and its two rates
    /// from F5, F8, F11, the rope and its rates from F7, F10, F13, then `x' = v_x`,
    /// `l' = v_l` and `u_i = τ_i a + v`. The scheme's difference formula is not needed
    /// (only its anchor `x_{n−1}`: positions as increments against it, the rope by Heron
    /// steps, as *subs* forms them); every node is the flat inverse to rounding. `None`
    /// for a zero or non-finite λ or `z_C,d` (a slack rope) and an unresolved rope
    /// increment.
    fn solve_step<const K: usize, D: DifferenceFormula<T, K>>(
        &self,
        samples: &[Self::Sample; K],
        d: &D,
    ) -> Option<[SVector<T, N>; K]> {
        let anchor: [T; N] = core::array::from_fn(|j| d.anchor(j));
        let [x0, l0, ..] = anchor;
        let [tau1, tau2] = self.tau;
        let mut out = [SVector::<T, N>::zeros(); K];
        for (o, s) in out.iter_mut().zip(samples) {
            let (xc, z) = path(s);
            let cf = ClosedForm::solve(self.g, &[xc], &z, l0)?;
            let [[d0, d1, d2]] = cf.d;
            let [dl, vl, al] = cf.rope;
            let [lambda, mu, nu] = cf.lambda;
            let [xc0, xc1, xc2, _, _] = xc;
            let (vx, ax) = (xc1 - d1, xc2 - d2);
            let value = [
                T::zero(),
                T::zero(),
                vx,
                vl,
                lambda,
                tau1 * ax + vx,
                tau2 * al + vl,
                vx,
                vl,
                mu,
                ax,
                al,
                nu,
            ];
            let mut increment = SVector::<T, N>::from_fn(|j, _| {
                let v = value.get(j).copied().unwrap_or_else(T::zero);
                v - anchor.get(j).copied().unwrap_or_else(T::zero)
            });
            // Positions as increments: (x_C,d − x_{n−1}) − d keeps the motion's digits.
            for (j, v) in [(0, (xc0 - x0) - d0), (1, dl)] {
                if let Some(e) = increment.get_mut(j) {
                    *e = v;
                }
            }
            *o = increment;
        }
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use crate::trajectory::PointToPoint;

    type Model = CraneExt<f64, PointToPoint<f64, 2>>;

    fn model() -> Model {
        let z = PointToPoint::new(
            SVector::from([12.0, 8.0]),
            SVector::from([20.0, 4.0]),
            1.0,
            8.0,
            4,
        )
        .unwrap();
        CraneExt::new(CraneParams::PAPER, z).unwrap()
    }

    /// A state off the solution, near the move's: trolley and rope in the workspace,
    /// λ in tension.
    fn state(k: f64, i: usize) -> f64 {
        let base = [
            15.0, 6.0, 0.5, -0.3, -0.8, 0.4, -0.2, 0.45, -0.25, 0.1, 0.3, -0.2, 0.05,
        ][i];
        base * (1.0 + 0.2 * (k * 0.37 + i as f64).sin()) + 0.01 * (k + i as f64).cos()
    }

    /// No derivative enters F (`DIFFERENTIAL` 0): every unknown's `ẋ` changes no bit.
    #[test]
    fn no_unknown_is_differential() {
        let m = model();
        let s = m.sample(3.8);
        let x = SVector::<f64, N>::from_fn(|i, _| state(1.0, i));
        let xdot = SVector::<f64, N>::from_fn(|i, _| 0.1 * i as f64 - 0.4);
        crate::models::test_support::assert_differential_first(&m, &x, &xdot, &s);
    }

    /// The structured elimination solves the dense system built from the partials, at
    /// states off the solution and with every row scaling of Sec. 3.1.1; its complex
    /// solve is the real one per part.
    #[test]
    fn structured_elimination_solves_the_dense_newton_system() {
        let m = model();
        for case in 0..200 {
            let k = case as f64;
            let s = m.sample(0.05 * k);
            let x = SVector::<f64, N>::from_fn(|i, _| state(k, i));
            let h: f64 = [0.0005, 0.01, 0.05][case % 3];
            let rho = 1.0 / h.powi((case % 4) as i32);
            let scale = SVector::<f64, N>::repeat(rho);
            let p = m.partials(&x, &x, &s);
            let a = p.dx * rho;
            let r = SVector::<f64, N>::from_fn(|i, _| (k + 2.0 * i as f64).cos());
            let f = m.factor(&x, &x, &s, 25.0 / 12.0 / h, &scale).unwrap();
            let mut eta = r;
            Model::solve(&f, &mut eta);
            let size = a.abs().column_sum().max() * eta.amax() + r.amax();
            assert!(
                (a * eta - r).amax() <= 1e-13 * size,
                "case {case}: A η − r = {:e}",
                (a * eta - r).amax()
            );
            let mut lu = a;
            let mut piv = [0; N];
            assert!(crate::linalg::factor(&mut lu, &mut piv));
            let mut dense = r;
            crate::linalg::solve(&lu, &piv, &mut dense);
            assert!((dense - eta).amax() <= 1e-9 * dense.amax(), "case {case}");
            let (mut re, mut im) = (r, r * 0.5);
            Model::solve_complex(&f, 3.0 / h, &mut re, &mut im);
            let mut half = r * 0.5;
            Model::solve(&f, &mut half);
            assert_eq!((re, im), (eta, half), "case {case}");
        }
    }

    /// A slack rope (λ = 0) makes the matrix singular: no factors, and no closed form.
    #[test]
    fn slack_rope_has_no_factors_and_no_closed_form() {
        let m = model();
        let mut s = m.sample(3.0);
        let mut x = m.rest_state(0.0).unwrap();
        x[4] = 0.0;
        let scale = SVector::<f64, N>::repeat(1.0);
        assert!(m.factor(&x, &x, &s, 200.0, &scale).is_none());
        s[2][1] = 9.81;
        let f = Formula {
            anchor: m.rest_state(0.0).unwrap(),
            weights: [[2500.0]],
            past: SVector::zeros(),
        };
        assert!(m.solve_step(&[s], &f).is_none());
    }

    /// A difference formula around an anchor, for this model's `N` unknowns.
    type Formula<const K: usize> = crate::models::test_support::Formula<N, K>;

    /// The closed-form step solves the step's equations at every node: each row of
    /// `F(x_{n−1} + Δ_k, t_k)` vanishes to within a few roundings of its terms, for one
    /// node (BDF4's formula) and three (Radau IIA's), anchors off the solution and h from
    /// 0.5 ms to 50 ms.
    #[test]
    fn closed_form_step_solves_the_step() {
        use crate::schemes::radau::transformed::A_INV;
        use crate::schemes::radau::C;
        let m = model();
        fn check<const K: usize>(m: &Model, f: &Formula<K>, times: [f64; K], case: usize) {
            let samples = times.map(|t| m.sample(t));
            let inc = m.solve_step(&samples, f).unwrap();
            for (k, s) in samples.iter().enumerate() {
                let x = f.anchor + inc[k];
                let r = m.residual(&x, &SVector::zeros(), s);
                // The size of each row's terms: |∂F_i/∂x_j| |x_j| and the path's own.
                let p = m.partials(&x, &x, s);
                let [[_, zc], [_, zc1], [xc2, zc2], [xc3, zc3], [xc4, zc4]] =
                    s.map(<[f64; 2]>::from);
                let path = [
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    xc2.abs(),
                    zc2.abs() + 9.81,
                    zc * zc,
                    xc3.abs(),
                    zc3.abs(),
                    (zc * zc1).abs(),
                    xc4.abs(),
                    zc4.abs(),
                    zc1 * zc1 + (zc * zc2).abs(),
                ];
                for i in 0..N {
                    // x_{n−1} + Δ rounds to the anchor's ulp: count the anchor too.
                    let terms = (0..N)
                        .map(|j| p.dx[(i, j)].abs() * (x[j].abs() + f.anchor[j].abs()))
                        .sum::<f64>()
                        + path[i];
                    assert!(
                        r[i].abs() <= 16.0 * f64::EPSILON * terms,
                        "case {case}, node {k}, row {i}: {:e} against terms {terms:e}",
                        r[i]
                    );
                }
            }
        }
        for case in 0..300 {
            let t = 0.9 + 0.027 * case as f64;
            let h = [0.0005, 0.001, 0.01, 0.05][case % 4];
            let k = (case as f64 * 0.7).sin();
            let mut anchor = SVector::<f64, N>::from_fn(|i, _| 0.1 * k * (i as f64 - 6.0));
            anchor[0] = m.sample(t - h)[0][0] - 0.3 * k;
            anchor[1] = m.sample(t - h)[0][1] * (1.0 + 0.01 * k);
            anchor[4] = -1.2;
            let bdf = Formula {
                anchor,
                weights: [[25.0 / 12.0 / h]],
                past: SVector::zeros(),
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

    /// The rest state is consistent: `F(x_rest, ·, t) = 0` before and after the move.
    #[test]
    fn rest_state_is_consistent() {
        let m = model();
        for t in [0.0, 0.5, 9.0, 9.5] {
            let r = m.residual(&m.rest_state(t).unwrap(), &SVector::zeros(), &m.sample(t));
            assert!(r.amax() < 1e-14, "t = {t}: {r}");
        }
    }
}
