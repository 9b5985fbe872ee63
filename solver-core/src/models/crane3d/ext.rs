//! The 3D crane minimally extended to index 1: *ext*, as the planar crane's
//! ([`crane_ext`](crate::models::crane_ext)) with a second horizontal axis.
//!
//! *subs* ([`subs`](super::subs)) has index 3: its algebraic rows F7–F10 fix `x`, `y`,
//! `l` and λ, and the inputs follow from two differentiations through the scheme.
//! Minimal extension (Altmann, Betsch & Yang, the paper's ref. \[11\]) appends their
//! first and second time derivatives and, for each appended row, an algebraic unknown
//! in place of a derivative. The algebraic block of *subs* is invertible with respect to
//! `(x, y, l, λ)` along every admissible motion (determinant `−16 λ² z_C l`), so all three
//! positions are constrained: `ẋ`, `ẏ`, `l̇` become `x'`, `y'`, `l'`, the drives' `v̇`
//! become `a_x`, `a_y`, `a_l`, and λ's rates get `μ = λ̇`, `ν = λ̈`. With
//! `x = [x, y, l, v_x, v_y, v_l, λ, u1, u2, u3, x', y', l', μ, a_x, a_y, a_l, ν]`
//! (*subs*' unknowns first, in *subs*' order), for `p ∈ {x, y}`
//! `d_p = p_C,d − p`, `dv_p = ṗ_C,d − v_p`, `da_p = p̈_C,d − a_p`:
//!
//! ```text
//! F1–F3   = x' − v_x,  y' − v_y,  l' − v_l                       (24, q̇ → q')
//! F4–F6   = τ1 a_x + v_x − u1,  τ2 a_y + v_y − u2,  τ3 a_l + v_l − u3   (25, rows 1–2, v̇ → a)
//! F7, F8  = p̈_C,d − 2 d_p λ                                        (25, row 3; p = x, y)
//! F9      = z̈_C,d − g − 2 z_C,d λ                                   (25, row 4)
//! F10     = d_x² + d_y² + z_C,d² − l²                               (26, 3D)
//! F11, F12 = p⃛_C,d − 2 dv_p λ − 2 d_p μ                             (d/dt F7, F8)
//! F13     = z⃛_C,d − 2 ż_C,d λ − 2 z_C,d μ                            (d/dt F9)
//! F14     = d_x dv_x + d_y dv_y + z_C,d ż_C,d − l v_l                 (½ d/dt F10)
//! F15, F16 = p⁗_C,d − 2 da_p λ − 4 dv_p μ − 2 d_p ν                   (d²/dt² F7, F8)
//! F17     = z⁗_C,d − 2 z̈_C,d λ − 4 ż_C,d μ − 2 z_C,d ν                (d²/dt² F9)
//! F18     = Σ_p (dv_p² + d_p da_p) + ż_C,d² + z_C,d z̈_C,d − v_l² − l a_l   (½ d²/dt² F10)
//! ```
//!
//! (the rows of [`crane_hidden`](crate::models::crane_hidden), one X per horizontal axis).
//! No row has an `ẋ`: the system is algebraic with `∂F/∂x` invertible, index 1, and
//! every scheme's solution is the 3D flat inverse to rounding at every h
//! ([`flat_crane3d`](crate::reference::flat_crane3d)). With `y_C,d` constant and the
//! trolley under the load, F2, F5, F8, F12, F16 hold with `y = y_C,d` and every y rate
//! zero, and the other rows are the planar *ext*'s.

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::model::{DaeModel, DifferenceFormula, Driven, Partials, StructuredJacobian};
use crate::models::crane3d::{check_trajectory, Crane3dParams};
use crate::models::crane_hidden::{
    horizontal_rows, offsets, rope_rows, set, vertical_rows, ChainPoint, ClosedForm, Derivatives,
    Layout,
};
use crate::scalar::{c, is_finite, Real};
use crate::trajectory::{ensure_at_rest, Trajectory};

/// Number of unknowns of the 3D *ext* formulation.
pub const N: usize = 18;
/// Number of inputs (bridge, trolley, hoist) and of outputs (`x_C`, `y_C`, `z_C`).
pub const NU: usize = 3;
schemes_of!(Crane3dExt, structured);

/// Where the constraint chain's rows and unknowns sit (see the module's equations).
const CHAIN: Layout<2> = Layout {
    horizontal_rows: [[6, 10, 14], [7, 11, 15]],
    vertical_rows: [8, 12, 16],
    rope_rows: [9, 13, 17],
    horizontal: [[0, 3, 14], [1, 4, 15]],
    rope: [2, 5, 16],
    lambda: [6, 13, 17],
};

/// The 3D crane *ext* inverse model, driven by a load trajectory `Z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crane3dExt<T: Real, Z> {
    params: Crane3dParams,
    g: T,
    /// τ1, τ2, τ3.
    tau: [T; 3],
    trajectory: Z,
}

impl<T: Real, Z: Trajectory<T, NU>> Crane3dExt<T, Z> {
    /// Builds the model after checking the parameters and the whole trajectory
    /// (smoothness, rope-slack margin, workspace), as *subs* does.
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

    /// The constraint chain's values at `x` and the sample `s`.
    fn chain_point(&self, x: &SVector<T, N>, s: &[SVector<T, NU>; 5]) -> ChainPoint<T, 2> {
        let [xb, yt, l, vx, vy, vl, lambda, _, _, _, _, _, _, mu, ax, ay, al, nu]: [T; N] =
            (*x).into();
        let ([xc, yc], [z0, z1, z2, _, _]) = path(s);
        ChainPoint {
            z: [z0, z1, z2],
            d: [offsets(&xc, [xb, vx, ax]), offsets(&yc, [yt, vy, ay])],
            rope: [l, vl, al],
            lambda: [lambda, mu, nu],
        }
    }
}

impl<T: Real, Z> Driven for Crane3dExt<T, Z> {
    type Trajectory = Z;

    fn trajectory(&self) -> &Z {
        &self.trajectory
    }

    fn trajectory_mut(&mut self) -> &mut Z {
        &mut self.trajectory
    }
}

/// The load path of a sample: `x_C,d` and `y_C,d`, and `z_C,d`, each with its
/// derivatives 0..=4.
fn path<T: Real>(s: &[SVector<T, NU>; 5]) -> ([Derivatives<T>; 2], Derivatives<T>) {
    let [[x0, y0, z0], [x1, y1, z1], [x2, y2, z2], [x3, y3, z3], [x4, y4, z4]] =
        s.map(<[T; NU]>::from);
    (
        [[x0, x1, x2, x3, x4], [y0, y1, y2, y3, y4]],
        [z0, z1, z2, z3, z4],
    )
}

impl<T: Real, Z: Trajectory<T, NU>> DaeModel<T, N, NU> for Crane3dExt<T, Z> {
    const UNKNOWNS: [&'static str; N] = [
        "x", "y", "l", "vx", "vy", "vl", "lambda", "u1", "u2", "u3", "x'", "y'", "l'", "mu", "ax",
        "ay", "al", "nu",
    ];
    /// Every row: none has an `ẋ` (index 1).
    const ALGEBRAIC: [bool; N] = [true; N];
    /// None: no unknown's derivative enters F.
    const DIFFERENTIAL: usize = 0;
    const INPUTS: [usize; NU] = [7, 8, 9];
    /// `u` contains `z_d⁗` (F15–F18); with n ≥ 4 it is continuous.
    const MIN_SMOOTHNESS: usize = 4;

    /// `[z_d, ż_d, z̈_d, z⃛_d, z⁗_d]`.
    type Sample = [SVector<T, NU>; 5];

    fn sample(&self, t: T) -> Self::Sample {
        self.trajectory.derivatives::<5>(t)
    }

    fn residual(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
    ) -> SVector<T, N> {
        let [xb, yt, l, vx, vy, vl, lambda, u1, u2, u3, xd, yd, ld, mu, ax, ay, al, nu]: [T; N] =
            (*x).into();
        let ([xc, yc], z) = path(s);
        let chain = [lambda, mu, nu];
        let (dx, dy) = (offsets(&xc, [xb, vx, ax]), offsets(&yc, [yt, vy, ay]));
        let [f7, f11, f15] = horizontal_rows(&xc, dx, chain);
        let [f8, f12, f16] = horizontal_rows(&yc, dy, chain);
        let [f9, f13, f17] = vertical_rows(self.g, &z, chain);
        let [f10, f14, f18] = rope_rows(&[dx, dy], &z, [l, vl, al]);
        let [tau1, tau2, tau3] = self.tau;
        SVector::<T, N>::from([
            xd - vx,
            yd - vy,
            ld - vl,
            tau1 * ax + vx - u1,
            tau2 * ay + vy - u2,
            tau3 * al + vl - u3,
            f7,
            f8,
            f9,
            f10,
            f11,
            f12,
            f13,
            f14,
            f15,
            f16,
            f17,
            f18,
        ])
    }

    fn partials(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
    ) -> Partials<T, N> {
        let one = T::one();
        let [tau1, tau2, tau3] = self.tau;
        let mut dx = SMatrix::<T, N, N>::zeros();
        // F1–F3: q' − v; F4–F6: τ a + v − u.
        for (row, col, v) in [
            (0, 10, one),
            (0, 3, -one),
            (1, 11, one),
            (1, 4, -one),
            (2, 12, one),
            (2, 5, -one),
            (3, 14, tau1),
            (3, 3, one),
            (3, 7, -one),
            (4, 15, tau2),
            (4, 4, one),
            (4, 8, -one),
            (5, 16, tau3),
            (5, 5, one),
            (5, 9, -one),
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
        let [[xc, yc, zc], ..] = self.trajectory.derivatives::<5>(t).map(<[T; NU]>::from);
        // Hanging straight down: x = x_C, y = y_C, l = z_C, λ = −g/(2 z_C) (F9).
        let lambda = -self.g / (c::<T>(2.0) * zc);
        let mut x = SVector::<T, N>::zeros();
        for (j, v) in [(0, xc), (1, yc), (2, zc), (6, lambda)] {
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

/// The factors of the 3D *ext* Newton matrix (see [`StructuredJacobian`] for
/// [`Crane3dExt`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ext3dFactors<T> {
    /// The chain's values where the matrix was formed.
    point: ChainPoint<T, 2>,
    /// `[1/(2 z_C,d), 1/(2λ), 1/l]`.
    inv_pivot: [T; 3],
    /// τ1, τ2, τ3.
    tau: [T; 3],
    /// `1/S_i` of every row.
    inv_scale: [T; N],
}

/// The Newton matrix `S·∂F/∂x` of the 3D *ext* model (`∂F/∂ẋ = 0`) is triangular in the
/// chain's order — λ, μ, ν (F9, F13, F17), x, v_x, a_x (F7, F11, F15), y, v_y, a_y (F8,
/// F12, F16), l, v_l, a_l (F10, F14, F18) — then x', y', l' (F1–F3) and u1, u2, u3
/// (F4–F6). Pivots `−2 z_C,d`, `2λ`, `−2l`, `−l`, `1`, `−1`: they vanish only for a
/// slack rope, `z_C,d = 0` or `l = 0`. RADAU5's complex system is the real one per part.
impl<T: Real, Z: Trajectory<T, NU>> StructuredJacobian<T, N, NU> for Crane3dExt<T, Z> {
    type Factors = Ext3dFactors<T>;

    const CLOSED_FORM: bool = true;

    fn factor(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
        _c: T,
        scale: &SVector<T, N>,
    ) -> Option<Ext3dFactors<T>> {
        let point = self.chain_point(x, s);
        let inv_pivot = point.inverse_pivots()?;
        let inv_scale: [T; N] = scale.map(|s| T::one() / s).into();
        if !inv_scale.iter().all(|v| is_finite(*v)) {
            return None;
        }
        Some(Ext3dFactors {
            point,
            inv_pivot,
            tau: self.tau,
            inv_scale,
        })
    }

    fn solve(f: &Ext3dFactors<T>, r: &mut SVector<T, N>) {
        let unscaled: [T; N] = core::array::from_fn(|i| {
            let (ri, si) = (r.get(i), f.inv_scale.get(i));
            ri.zip(si).map_or_else(T::zero, |(r, s)| *r * *s)
        });
        let [r1, r2, r3, r4, r5, r6, r7, r8, r9, r10, r11, r12, r13, r14, r15, r16, r17, r18] =
            unscaled;
        let ([lambda, mu, nu], [[x, vx, ax], [y, vy, ay]], [l, vl, al]) = f.point.solve(
            &f.inv_pivot,
            [r9, r13, r17],
            [[r7, r11, r15], [r8, r12, r16]],
            [r10, r14, r18],
        );
        let [tau1, tau2, tau3] = f.tau;
        // F1: η_x' − η_vx = r; F4: τ1 η_ax + η_vx − η_u1 = r (likewise for y and l).
        *r = SVector::<T, N>::from([
            x,
            y,
            l,
            vx,
            vy,
            vl,
            lambda,
            tau1 * ax + vx - r4,
            tau2 * ay + vy - r5,
            tau3 * al + vl - r6,
            r1 + vx,
            r2 + vy,
            r3 + vl,
            mu,
            ax,
            ay,
            al,
            nu,
        ]);
    }

    /// `∂F/∂ẋ = 0`: the complex system is the real one for each part.
    fn solve_complex(f: &Ext3dFactors<T>, _b: T, re: &mut SVector<T, N>, im: &mut SVector<T, N>) {
        Self::solve(f, re);
        Self::solve(f, im);
    }

    /// The step node by node in the matrix's order (`crane_hidden::ClosedForm`): λ, μ, ν, then each
    /// horizontal axis's offset and rates, the rope and its rates, `q' = v` and
    /// `u_i = τ_i a + v`; positions as increments against the anchor `x_{n−1}`, the rope
    /// by Heron steps. `None` for a slack rope, `z_C,d = 0` or an unresolved rope
    /// increment.
    fn solve_step<const K: usize, D: DifferenceFormula<T, K>>(
        &self,
        samples: &[Self::Sample; K],
        d: &D,
    ) -> Option<[SVector<T, N>; K]> {
        let anchor: [T; N] = core::array::from_fn(|j| d.anchor(j));
        let [x0, y0, l0, ..] = anchor;
        let [tau1, tau2, tau3] = self.tau;
        let mut out = [SVector::<T, N>::zeros(); K];
        for (o, s) in out.iter_mut().zip(samples) {
            let (horizontal, z) = path(s);
            let cf = ClosedForm::solve(self.g, &horizontal, &z, l0)?;
            let [[xc0, xc1, xc2, _, _], [yc0, yc1, yc2, _, _]] = horizontal;
            let [[dx0, dx1, dx2], [dy0, dy1, dy2]] = cf.d;
            let [dl, vl, al] = cf.rope;
            let [lambda, mu, nu] = cf.lambda;
            let (vx, ax, vy, ay) = (xc1 - dx1, xc2 - dx2, yc1 - dy1, yc2 - dy2);
            let value = [
                T::zero(),
                T::zero(),
                T::zero(),
                vx,
                vy,
                vl,
                lambda,
                tau1 * ax + vx,
                tau2 * ay + vy,
                tau3 * al + vl,
                vx,
                vy,
                vl,
                mu,
                ax,
                ay,
                al,
                nu,
            ];
            let mut increment = SVector::<T, N>::from_fn(|j, _| {
                let v = value.get(j).copied().unwrap_or_else(T::zero);
                v - anchor.get(j).copied().unwrap_or_else(T::zero)
            });
            // Positions as increments: (p_C,d − p_{n−1}) − d keeps the motion's digits.
            for (j, v) in [(0, (xc0 - x0) - dx0), (1, (yc0 - y0) - dy0), (2, dl)] {
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
    use crate::models::crane::CraneParams;
    use crate::models::crane_ext::CraneExt;
    use crate::trajectory::PointToPoint;

    type Model = Crane3dExt<f64, PointToPoint<f64, 3>>;

    /// The diagonal move with hoisting: (12, 3, 8) → (20, 6, 4) m from t = 1 s to 8 s.
    fn model() -> Model {
        let z = PointToPoint::new(
            SVector::from([12.0, 3.0, 8.0]),
            SVector::from([20.0, 6.0, 4.0]),
            1.0,
            7.0,
            4,
        )
        .unwrap();
        Crane3dExt::new(Crane3dParams::EXAMPLE, z).unwrap()
    }

    /// A state off the solution near the move's.
    fn state(k: f64, i: usize) -> f64 {
        let base = [
            15.0, 4.0, 6.0, 0.5, 0.2, -0.3, -0.8, 0.4, 0.1, -0.2, 0.45, 0.15, -0.25, 0.1, 0.3, 0.1,
            -0.2, 0.05,
        ][i];
        base * (1.0 + 0.2 * (k * 0.37 + i as f64).sin()) + 0.01 * (k + i as f64).cos()
    }

    /// No derivative enters F (`DIFFERENTIAL` 0).
    #[test]
    fn no_unknown_is_differential() {
        let m = model();
        let x = SVector::<f64, N>::from_fn(|i, _| state(2.0, i));
        let xdot = SVector::<f64, N>::from_fn(|i, _| 0.1 * i as f64 - 0.7);
        crate::models::test_support::assert_differential_first(&m, &x, &xdot, &m.sample(4.2));
    }

    /// The structured elimination solves the dense system built from the partials, with
    /// every row scaling of Sec. 3.1.1, and its complex solve is the real one per part.
    #[test]
    fn structured_elimination_solves_the_dense_newton_system() {
        let m = model();
        for case in 0..200 {
            let k = case as f64;
            let s = m.sample(0.045 * k);
            let x = SVector::<f64, N>::from_fn(|i, _| state(k, i));
            let h: f64 = [0.0005, 0.01, 0.05][case % 3];
            let rho = 1.0 / h.powi((case % 4) as i32);
            let scale = SVector::<f64, N>::repeat(rho);
            let a = m.partials(&x, &x, &s).dx * rho;
            let r = SVector::<f64, N>::from_fn(|i, _| (k - 1.5 * i as f64).sin());
            let f = m.factor(&x, &x, &s, 25.0 / 12.0 / h, &scale).unwrap();
            let mut eta = r;
            Model::solve(&f, &mut eta);
            let size = a.abs().column_sum().max() * eta.amax() + r.amax();
            assert!(
                (a * eta - r).amax() <= 1e-13 * size,
                "case {case}: A η − r = {:e}",
                (a * eta - r).amax()
            );
            let (mut re, mut im) = (r, r * 0.25);
            Model::solve_complex(&f, 3.0 / h, &mut re, &mut im);
            let mut quarter = r * 0.25;
            Model::solve(&f, &mut quarter);
            assert_eq!((re, im), (eta, quarter), "case {case}");
        }
    }

    /// A slack rope (λ = 0) has no factors and no closed form.
    #[test]
    fn slack_rope_has_no_factors_and_no_closed_form() {
        let m = model();
        let mut s = m.sample(3.0);
        let mut x = m.rest_state(0.0).unwrap();
        x[6] = 0.0;
        let scale = SVector::<f64, N>::repeat(1.0);
        assert!(m.factor(&x, &x, &s, 200.0, &scale).is_none());
        s[2][2] = 9.81;
        let f = crate::models::test_support::Formula::<N, 1> {
            anchor: m.rest_state(0.0).unwrap(),
            weights: [[2500.0]],
            past: SVector::zeros(),
        };
        assert!(m.solve_step(&[s], &f).is_none());
    }

    /// A move with `y_C` constant through the 3D *ext* model gives the planar *ext*
    /// model's closed-form step (bridge ≙ planar trolley, hoist ≙ winch) to a few ε, the
    /// trolley at rest, at every node of BDF4's and Radau IIA's formulas.
    #[test]
    fn planar_move_gives_the_planar_closed_form() {
        use crate::schemes::radau::transformed::A_INV;
        use crate::schemes::radau::C;
        let planar = CraneParams::PAPER;
        let p = Crane3dParams::extruded(&planar, 0.025, 0.0, 8.0);
        let z3 = PointToPoint::new(
            SVector::from([12.0, 4.0, 8.0]),
            SVector::from([20.0, 4.0, 4.0]),
            1.0,
            8.0,
            4,
        )
        .unwrap();
        let z2 = PointToPoint::new(
            SVector::from([12.0, 8.0]),
            SVector::from([20.0, 4.0]),
            1.0,
            8.0,
            4,
        )
        .unwrap();
        let (m3, m2) = (
            Crane3dExt::new(p, z3).unwrap(),
            CraneExt::new(planar, z2).unwrap(),
        );
        // Planar unknown j sits at 3D index MAP[j]; the trolley's (y, v_y, u2, y', a_y) rest.
        const MAP: [usize; 13] = [0, 2, 3, 5, 6, 7, 9, 10, 12, 13, 14, 16, 17];
        for i in 0..200 {
            let t = 0.9 + 0.04 * f64::from(i);
            let h = 0.01;
            let mut anchor2 = SVector::<f64, 13>::from_fn(|j, _| 0.01 * j as f64);
            let [[xc, zc], ..] = m2.sample(t - h).map(<[f64; 2]>::from);
            (anchor2[0], anchor2[1]) = (xc - 0.1, zc * 1.01);
            let mut anchor3 = SVector::<f64, N>::zeros();
            for (j, k) in MAP.iter().enumerate() {
                anchor3[*k] = anchor2[j];
            }
            anchor3[1] = 4.0;
            let (f2, f3) = (
                crate::models::test_support::Formula::<13, 3> {
                    anchor: anchor2,
                    weights: A_INV.map(|row| row.map(|a| a / h)),
                    past: SVector::zeros(),
                },
                crate::models::test_support::Formula::<N, 3> {
                    anchor: anchor3,
                    weights: A_INV.map(|row| row.map(|a| a / h)),
                    past: SVector::zeros(),
                },
            );
            let times = C.map(|c| t - h + c * h);
            let inc2 = m2.solve_step(&times.map(|t| m2.sample(t)), &f2).unwrap();
            let inc3 = m3.solve_step(&times.map(|t| m3.sample(t)), &f3).unwrap();
            for (a, b) in inc2.iter().zip(&inc3) {
                let (x2, x3) = (anchor2 + a, anchor3 + b);
                for (j, k) in MAP.iter().enumerate() {
                    assert!(
                        (x2[j] - x3[*k]).abs() <= 4.0 * f64::EPSILON * (1.0 + x2[j].abs()),
                        "t = {t}, {}: {} against {}",
                        Model::UNKNOWNS[*k],
                        x2[j],
                        x3[*k]
                    );
                }
                for k in [1, 4, 8, 11, 15] {
                    assert!((x3[k] - anchor3[k] * f64::from(u8::from(k == 1))).abs() <= 1e-15);
                }
            }
        }
    }
}
