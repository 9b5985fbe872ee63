//! The hidden constraints of the single-rope cranes, planar and in three dimensions:
//! what their minimally extended formulations ([`crane_ext`](super::crane_ext),
//! [`crane3d::ext`](super::crane3d::ext)) share, one load equation at a time.
//!
//! ## The constraint chain
//!
//! With the servo-constraints substituted (*subs*, Eqs. 24–28 and their 3D counterparts)
//! the load's equations and the rope fix the crane's positions at every instant: per
//! horizontal axis `p` (the planar trolley's `x`; the 3D bridge's `x` and trolley's `y`),
//! with `d = p_C,d − p` the load's horizontal offset from its drive,
//!
//! ```text
//! X0 = p̈_C,d − 2 d λ                          (25, row 3)
//! V0 = z̈_C,d − g − 2 z_C,d λ                   (25, row 4)
//! R0 = Σ d² + z_C,d² − l²                       (26)
//! ```
//!
//! (one X0 per horizontal axis). These are the algebraic rows of *subs*; the solver
//! differentiates them twice through Eq. 24's `ṗ = v_p`, `l̇ = v_l` and the drives' rows
//! to reach the inputs: index 3. Their first and second time derivatives along the
//! motion — the hidden constraints — written with the velocities and accelerations in
//! place of `ṗ`, `l̇`, `p̈`, `l̈` (as a mechanical system's `G v = …` and `G v̇ + … = 0`),
//! with `μ = λ̇`, `ν = λ̈`, `dv = ṗ_C,d − v_p`, `da = p̈_C,d − a_p`:
//!
//! ```text
//! X1 = p⃛_C,d − 2 dv λ − 2 d μ                           (d/dt X0)
//! X2 = p⁗_C,d − 2 da λ − 4 dv μ − 2 d ν                  (d²/dt² X0)
//! V1 = z⃛_C,d − 2 ż_C,d λ − 2 z_C,d μ                      (d/dt V0)
//! V2 = z⁗_C,d − 2 z̈_C,d λ − 4 ż_C,d μ − 2 z_C,d ν           (d²/dt² V0)
//! R1 = Σ d dv + z_C,d ż_C,d − l v_l                        (½ d/dt R0)
//! R2 = Σ (dv² + d da) + ż_C,d² + z_C,d z̈_C,d − v_l² − l a_l  (½ d²/dt² R0)
//! ```
//!
//! The helpers here evaluate the rows, write their partials, solve them in the order
//! of their triangular Jacobian, and solve them in closed form; each model composes
//! them for its axes and adds its drives' rows.
//!
//! ## The triangular order
//!
//! The Jacobian of the chain is lower triangular in the order `λ, μ, ν` (rows V0, V1,
//! V2: pivots `−2 z_C,d`), then per horizontal axis `p, v_p, a_p` (rows X0, X1, X2:
//! pivots `2λ`), then `l, v_l, a_l` (rows R0, R1, R2: pivots `−2l`, `−l`, `−l`): each
//! row's unknown appears in no row before it. Its pivots vanish only for a slack rope
//! (λ = 0), `z_C,d = 0` or `l = 0`, which every crane's trajectory check refuses up
//! front, and none depends on a scheme's shift `c` (no row has an `ẋ`).

use crate::models::crane_subs::rope_increment;
use crate::scalar::{c, is_finite, Real};

/// One output coordinate's desired value and its first four derivatives,
/// `[p, ṗ, p̈, p⃛, p⁗]`.
pub(crate) type Derivatives<T> = [T; 5];

/// `[q, q̇, q̈]` of one chain unknown (a drive's position, velocity and acceleration; the
/// rope's; λ, μ, ν) or of an offset (`[d, dv, da]`).
pub(crate) type Levels<T> = [T; 3];

/// The vertical load equation V0–V2 at the depth `z` with `lambda = [λ, μ, ν]`.
pub(crate) fn vertical_rows<T: Real>(g: T, z: &Derivatives<T>, lambda: Levels<T>) -> Levels<T> {
    let [z0, z1, z2, z3, z4] = *z;
    let [l0, l1, l2] = lambda;
    let (two, four) = (c::<T>(2.0), c::<T>(4.0));
    [
        z2 - g - two * z0 * l0,
        z3 - two * z1 * l0 - two * z0 * l1,
        z4 - two * z2 * l0 - four * z1 * l1 - two * z0 * l2,
    ]
}

/// One horizontal axis's load equation X0–X2 at the desired coordinate `p` with the
/// offsets `d = [p_C,d − p, ṗ_C,d − v_p, p̈_C,d − a_p]`.
pub(crate) fn horizontal_rows<T: Real>(
    p: &Derivatives<T>,
    d: Levels<T>,
    lambda: Levels<T>,
) -> Levels<T> {
    let [_, _, p2, p3, p4] = *p;
    let [d0, d1, d2] = d;
    let [l0, l1, l2] = lambda;
    let (two, four) = (c::<T>(2.0), c::<T>(4.0));
    [
        p2 - two * d0 * l0,
        p3 - two * d1 * l0 - two * d0 * l1,
        p4 - two * d2 * l0 - four * d1 * l1 - two * d0 * l2,
    ]
}

/// The rope R0–R2 with each horizontal axis's offsets `d`, the depth `z` and
/// `rope = [l, v_l, a_l]`.
pub(crate) fn rope_rows<T: Real, const H: usize>(
    d: &[Levels<T>; H],
    z: &Derivatives<T>,
    rope: Levels<T>,
) -> Levels<T> {
    let [z0, z1, z2, _, _] = *z;
    let [l, vl, al] = rope;
    let [s0, s1, s2] = d.iter().fold(
        [z0 * z0, z0 * z1, z1 * z1 + z0 * z2],
        |[s0, s1, s2], [d0, d1, d2]| [s0 + *d0 * *d0, s1 + *d0 * *d1, s2 + *d1 * *d1 + *d0 * *d2],
    );
    [s0 - l * l, s1 - l * vl, s2 - vl * vl - l * al]
}

/// The offsets `[d, dv, da]` of a horizontal axis from its desired coordinate and the
/// drive's `[p, v_p, a_p]`.
pub(crate) fn offsets<T: Real>(p: &Derivatives<T>, q: Levels<T>) -> Levels<T> {
    let [p0, p1, p2, _, _] = *p;
    let [q0, q1, q2] = q;
    [p0 - q0, p1 - q1, p2 - q2]
}

/// Where the chain's rows and unknowns sit in a model's residual and state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Layout<const H: usize> {
    /// Rows X0, X1, X2 of each horizontal axis.
    pub(crate) horizontal_rows: [[usize; 3]; H],
    /// Rows V0, V1, V2.
    pub(crate) vertical_rows: [usize; 3],
    /// Rows R0, R1, R2.
    pub(crate) rope_rows: [usize; 3],
    /// Columns of each horizontal drive's `p, v_p, a_p`.
    pub(crate) horizontal: [[usize; 3]; H],
    /// Columns of `l, v_l, a_l`.
    pub(crate) rope: [usize; 3],
    /// Columns of `λ, μ, ν`.
    pub(crate) lambda: [usize; 3],
}

/// Writes `v` at `(i, j)` of `m` (checked: there is nothing to panic about).
pub(crate) fn set<T: Real, const N: usize>(
    m: &mut nalgebra::SMatrix<T, N, N>,
    i: usize,
    j: usize,
    v: T,
) {
    if let Some(e) = m.get_mut((i, j)) {
        *e = v;
    }
}

/// The chain's values at one point: what its partials and its elimination need.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ChainPoint<T, const H: usize> {
    /// `[z, ż, z̈]` of the depth.
    pub(crate) z: Levels<T>,
    /// Offsets `[d, dv, da]` of each horizontal axis.
    pub(crate) d: [Levels<T>; H],
    /// `[l, v_l, a_l]`.
    pub(crate) rope: Levels<T>,
    /// `[λ, μ, ν]`.
    pub(crate) lambda: Levels<T>,
}

impl<T: Real, const H: usize> ChainPoint<T, H> {
    /// Writes the chain's partials `∂(X, V, R)/∂(p, v_p, a_p, l, v_l, a_l, λ, μ, ν)` into `m`.
    pub(crate) fn partials_into<const N: usize>(
        &self,
        at: &Layout<H>,
        m: &mut nalgebra::SMatrix<T, N, N>,
    ) {
        let (two, four) = (c::<T>(2.0), c::<T>(4.0));
        let [z0, z1, z2] = self.z;
        let [l0, l1, l2] = self.lambda;
        let [cl, cmu, cnu] = at.lambda;
        let [v0, v1, v2] = at.vertical_rows;
        set(m, v0, cl, -two * z0);
        set(m, v1, cl, -two * z1);
        set(m, v1, cmu, -two * z0);
        set(m, v2, cl, -two * z2);
        set(m, v2, cmu, -four * z1);
        set(m, v2, cnu, -two * z0);
        let [r0, r1, r2] = at.rope_rows;
        let [lq, lv, la] = at.rope;
        let [l, vl, al] = self.rope;
        for (([x0, x1, x2], [cp, cv, ca]), [d0, d1, d2]) in
            at.horizontal_rows.iter().zip(&at.horizontal).zip(&self.d)
        {
            let (x0, x1, x2, cp, cv, ca) = (*x0, *x1, *x2, *cp, *cv, *ca);
            let (d0, d1, d2) = (*d0, *d1, *d2);
            set(m, x0, cp, two * l0);
            set(m, x0, cl, -two * d0);
            set(m, x1, cv, two * l0);
            set(m, x1, cl, -two * d1);
            set(m, x1, cp, two * l1);
            set(m, x1, cmu, -two * d0);
            set(m, x2, ca, two * l0);
            set(m, x2, cl, -two * d2);
            set(m, x2, cv, four * l1);
            set(m, x2, cmu, -four * d1);
            set(m, x2, cp, two * l2);
            set(m, x2, cnu, -two * d0);
            set(m, r0, cp, -two * d0);
            set(m, r1, cp, -d1);
            set(m, r1, cv, -d0);
            set(m, r2, cv, -two * d1);
            set(m, r2, cp, -d2);
            set(m, r2, ca, -d0);
        }
        set(m, r0, lq, -two * l);
        set(m, r1, lq, -vl);
        set(m, r1, lv, -l);
        set(m, r2, lv, -two * vl);
        set(m, r2, lq, -al);
        set(m, r2, la, -l);
    }

    /// The reciprocal pivots `[1/(2 z), 1/(2 λ), 1/l]` of the triangular order; `None`
    /// where one is zero or not finite.
    pub(crate) fn inverse_pivots(&self) -> Option<[T; 3]> {
        let two = c::<T>(2.0);
        let [z0, _, _] = self.z;
        let [l0, _, _] = self.lambda;
        let [l, _, _] = self.rope;
        let pivots = [two * z0, two * l0, l];
        let inverse = pivots.map(|p| T::one() / p);
        (pivots.iter().all(|p| *p != T::zero()) && inverse.iter().all(|v| is_finite(*v)))
            .then_some(inverse)
    }

    /// Solves the chain's rows of `J η = r` (unscaled `J`: `r` already divided by the
    /// row scaling) by forward substitution in the triangular order; `inv` from
    /// [`ChainPoint::inverse_pivots`]. Returns `η` of `[λ, μ, ν]`, of each horizontal
    /// drive's `[p, v_p, a_p]` and of `[l, v_l, a_l]`, from the rows' right sides
    /// `vertical`, `horizontal` and `rope`.
    pub(crate) fn solve(
        &self,
        inv: &[T; 3],
        vertical: Levels<T>,
        horizontal: [Levels<T>; H],
        rope: Levels<T>,
    ) -> (Levels<T>, [Levels<T>; H], Levels<T>) {
        let (two, four) = (c::<T>(2.0), c::<T>(4.0));
        let [inv_2z, inv_2lambda, inv_l] = *inv;
        let [_, z1, z2] = self.z;
        let [_, l1, l2] = self.lambda;
        // V0–V2: −2z η_λ = r, −2ż η_λ − 2z η_μ = r, −2z̈ η_λ − 4ż η_μ − 2z η_ν = r.
        let [rv0, rv1, rv2] = vertical;
        let e_l = -rv0 * inv_2z;
        let e_mu = -(rv1 + two * z1 * e_l) * inv_2z;
        let e_nu = -(rv2 + two * z2 * e_l + four * z1 * e_mu) * inv_2z;
        let mut axes = horizontal;
        for (e, [d0, d1, d2]) in axes.iter_mut().zip(&self.d) {
            let [rx0, rx1, rx2] = *e;
            // X0: 2λ η_p − 2d η_λ = r; X1: 2λ η_v + 2μ η_p − 2dv η_λ − 2d η_μ = r;
            // X2: 2λ η_a + 4μ η_v + 2ν η_p − 2da η_λ − 4dv η_μ − 2d η_ν = r.
            let e_p = (rx0 + two * *d0 * e_l) * inv_2lambda;
            let e_v = (rx1 + two * *d1 * e_l + two * *d0 * e_mu - two * l1 * e_p) * inv_2lambda;
            let e_a = (rx2 + two * *d2 * e_l + four * *d1 * e_mu + two * *d0 * e_nu
                - four * l1 * e_v
                - two * l2 * e_p)
                * inv_2lambda;
            *e = [e_p, e_v, e_a];
        }
        // R0: −2l η_l − Σ 2d η_p = r; R1: −l η_vl − v_l η_l − Σ (dv η_p + d η_v) = r;
        // R2: −l η_al − 2v_l η_vl − a_l η_l − Σ (2dv η_v + da η_p + d η_a) = r.
        let [rr0, rr1, rr2] = rope;
        let [_, vl, al] = self.rope;
        let [s0, s1, s2] = self.d.iter().zip(&axes).fold(
            [rr0, rr1, rr2],
            |[s0, s1, s2], ([d0, d1, d2], [e_p, e_v, e_a])| {
                [
                    s0 + two * *d0 * *e_p,
                    s1 + *d1 * *e_p + *d0 * *e_v,
                    s2 + two * *d1 * *e_v + *d2 * *e_p + *d0 * *e_a,
                ]
            },
        );
        let e_rope = -s0 * inv_l / two;
        let e_vl = -(s1 + vl * e_rope) * inv_l;
        let e_al = -(s2 + two * vl * e_vl + al * e_rope) * inv_l;
        ([e_l, e_mu, e_nu], axes, [e_rope, e_vl, e_al])
    }
}

/// The chain solved in closed form at one instant, in the triangular order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ClosedForm<T, const H: usize> {
    /// `[λ, μ, ν]`.
    pub(crate) lambda: Levels<T>,
    /// Each horizontal axis's offsets `[d, dv, da]` (the drive at `p_C,d − d`, …).
    pub(crate) d: [Levels<T>; H],
    /// The rope's increment `l − l_{n−1}`, its rate `v_l` and `a_l`.
    pub(crate) rope: Levels<T>,
}

impl<T: Real, const H: usize> ClosedForm<T, H> {
    /// Solves V0–V2, X0–X2 and R0–R2 for the load at `horizontal`, `depth`, the rope
    /// starting from `l0`:
    ///
    /// ```text
    /// λ = (z̈ − g)/(2z),   μ = (z⃛ − 2ż λ)/(2z),   ν = (z⁗ − 2z̈ λ − 4ż μ)/(2z)
    /// d = p̈/(2λ),   dv = (p⃛ − 2d μ)/(2λ),   da = (p⁗ − 4dv μ − 2d ν)/(2λ)
    /// l² = Σ d² + z²,   v_l = (Σ d dv + z ż)/l,   a_l = (Σ (dv² + d da) + ż² + z z̈ − v_l²)/l
    /// ```
    ///
    /// the rope as an increment by Heron steps (`crane_subs::rope_increment`). `None`
    /// for a zero or non-finite λ (a slack rope) or `z`, or an unresolved rope increment.
    pub(crate) fn solve(
        g: T,
        horizontal: &[Derivatives<T>; H],
        depth: &Derivatives<T>,
        l0: T,
    ) -> Option<Self> {
        let (two, four) = (c::<T>(2.0), c::<T>(4.0));
        let [z0, z1, z2, z3, z4] = *depth;
        let inv_2z = T::one() / (two * z0);
        let lambda = (z2 - g) * inv_2z;
        let inv_2lambda = T::one() / (two * lambda);
        // A zero λ (a slack rope) or depth makes its reciprocal infinite.
        if !is_finite(inv_2z) || !is_finite(inv_2lambda) {
            return None;
        }
        let mu = (z3 - two * z1 * lambda) * inv_2z;
        let nu = (z4 - two * z2 * lambda - four * z1 * mu) * inv_2z;
        let d = horizontal.map(|[_, _, p2, p3, p4]| {
            let d0 = p2 * inv_2lambda;
            let d1 = (p3 - two * d0 * mu) * inv_2lambda;
            let d2 = (p4 - four * d1 * mu - two * d0 * nu) * inv_2lambda;
            [d0, d1, d2]
        });
        // l² − l_{n−1}² by R0; z − l_{n−1} is exact (Sterbenz: l ≥ z ≥ l/2).
        let q = d
            .iter()
            .fold((z0 - l0) * (z0 + l0), |acc, [d0, _, _]| acc + *d0 * *d0);
        let dl = rope_increment(l0, q)?;
        let l = l0 + dl;
        let inv_l = T::one() / l;
        let [s1, s2] = d
            .iter()
            .fold([z0 * z1, z1 * z1 + z0 * z2], |[s1, s2], [d0, d1, d2]| {
                [s1 + *d0 * *d1, s2 + *d1 * *d1 + *d0 * *d2]
            });
        let vl = s1 * inv_l;
        let al = (s2 - vl * vl) * inv_l;
        let out = Self {
            lambda: [lambda, mu, nu],
            d,
            rope: [dl, vl, al],
        };
        is_finite(al + nu + vl + mu).then_some(out)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    /// `a + b sin(ω t + φ)` and its first four derivatives at `t`.
    fn wave(a: f64, b: f64, w: f64, phi: f64, t: f64) -> Derivatives<f64> {
        core::array::from_fn(|k| {
            let phase = w * t + phi + k as f64 * core::f64::consts::FRAC_PI_2;
            let value = b * w.powi(k as i32) * libm::sin(phase);
            if k == 0 {
                a + value
            } else {
                value
            }
        })
    }

    /// An arbitrary motion, not a solution: two horizontal axes' desired coordinates and
    /// drives, the depth, the rope and λ, each with its derivatives.
    struct Motion {
        path: [Derivatives<f64>; 2],
        depth: Derivatives<f64>,
        drives: [Derivatives<f64>; 2],
        rope: Derivatives<f64>,
        lambda: Derivatives<f64>,
    }

    fn motion(t: f64) -> Motion {
        Motion {
            path: [wave(15.0, 2.0, 0.7, 0.3, t), wave(4.0, 1.0, 1.1, 2.2, t)],
            depth: wave(6.0, 1.5, 0.9, 1.1, t),
            drives: [wave(14.0, 1.0, 1.3, 0.2, t), wave(3.5, 0.6, 0.8, 1.7, t)],
            rope: wave(6.5, 0.8, 0.5, 2.0, t),
            lambda: wave(-1.2, 0.3, 1.7, 0.4, t),
        }
    }

    fn levels(d: &Derivatives<f64>) -> Levels<f64> {
        [d[0], d[1], d[2]]
    }

    /// Every row of the chain along `motion` at `t`: X (two axes), V, R, each at levels 0–2.
    fn rows(t: f64) -> [Levels<f64>; 4] {
        let m = motion(t);
        let lambda = levels(&m.lambda);
        let d = [0, 1].map(|i| offsets(&m.path[i], levels(&m.drives[i])));
        [
            horizontal_rows(&m.path[0], d[0], lambda),
            horizontal_rows(&m.path[1], d[1], lambda),
            vertical_rows(9.81, &m.depth, lambda),
            rope_rows(&d, &m.depth, levels(&m.rope)),
        ]
    }

    /// The hidden constraints are the derivatives of the constraints, along any motion
    /// (not only the solution): X1 = d/dt X0, X2 = d/dt X1, V likewise, R1 = ½ d/dt R0,
    /// R2 = d/dt R1 — each against a central difference of the row below it, with every
    /// unknown moving as an arbitrary smooth function of time and its derivatives the
    /// rates the rows are written with (`v = ṗ`, `a = p̈`, `μ = λ̇`, `ν = λ̈`).
    #[test]
    fn hidden_constraints_are_the_derivatives_of_the_constraints() {
        let e = 1e-4;
        for i in 0..40 {
            let t = 0.37 * f64::from(i);
            let (lo, mid, hi) = (rows(t - e), rows(t), rows(t + e));
            for (row, name) in ["X (x)", "X (y)", "V", "R"].iter().enumerate() {
                let half = if *name == "R" { [0.5, 1.0] } else { [1.0, 1.0] };
                for level in 0..2 {
                    let fd = half[level] * (hi[row][level] - lo[row][level]) / (2.0 * e);
                    let exact = mid[row][level + 1];
                    assert!(
                        (fd - exact).abs() <= 1e-6 * (1.0 + exact.abs()),
                        "t = {t}, {name}{}: central difference {fd} against {exact}",
                        level + 1
                    );
                }
            }
        }
    }

    /// The closed form solves the chain: its rows vanish to rounding at a point of a
    /// move (two axes, the rope from a nearby length), and the elimination solves
    /// `J η = r` with the partials written by `partials_into`.
    #[test]
    fn closed_form_and_elimination_solve_the_chain() {
        let g = 9.81;
        for i in 0..40 {
            let t = 0.37 * f64::from(i);
            let m = motion(t);
            // A depth below the rope's exit with an acceleration far from g.
            let cf = ClosedForm::solve(g, &m.path, &m.depth, m.depth[0] + 0.3).unwrap();
            let l = m.depth[0] + 0.3 + cf.rope[0];
            let rope = [l, cf.rope[1], cf.rope[2]];
            let d = cf.d;
            let r = [
                horizontal_rows(&m.path[0], d[0], cf.lambda),
                horizontal_rows(&m.path[1], d[1], cf.lambda),
                vertical_rows(g, &m.depth, cf.lambda),
                rope_rows(&d, &m.depth, rope),
            ];
            for row in r {
                for v in row {
                    assert!(v.abs() <= 1e-12 * (1.0 + l * l), "t = {t}: rows {r:?}");
                }
            }
            // The elimination against the dense matrix of the chain's 15 rows.
            let layout = Layout {
                horizontal_rows: [[0, 1, 2], [3, 4, 5]],
                vertical_rows: [6, 7, 8],
                rope_rows: [9, 10, 11],
                horizontal: [[0, 1, 2], [3, 4, 5]],
                rope: [9, 10, 11],
                lambda: [6, 7, 8],
            };
            let point = ChainPoint {
                z: levels(&m.depth),
                d,
                rope,
                lambda: cf.lambda,
            };
            let mut j = nalgebra::SMatrix::<f64, 12, 12>::zeros();
            point.partials_into(&layout, &mut j);
            let rhs = nalgebra::SVector::<f64, 12>::from_fn(|k, _| (t + k as f64).cos());
            let inv = point.inverse_pivots().unwrap();
            let (el, axes, er) = point.solve(
                &inv,
                [rhs[6], rhs[7], rhs[8]],
                [[rhs[0], rhs[1], rhs[2]], [rhs[3], rhs[4], rhs[5]]],
                [rhs[9], rhs[10], rhs[11]],
            );
            let [[a0, a1, a2], [b0, b1, b2]] = axes;
            let eta = nalgebra::SVector::<f64, 12>::from([
                a0, a1, a2, b0, b1, b2, el[0], el[1], el[2], er[0], er[1], er[2],
            ]);
            let back = j * eta - rhs;
            let size = j.abs().column_sum().max() * eta.amax() + 1.0;
            assert!(back.amax() <= 1e-14 * size, "t = {t}: J η − r = {back}");
        }
    }
}
