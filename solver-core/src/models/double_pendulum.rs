//! The planar crane with a hook block and the load on a sling below it: a double
//! pendulum, in redundant coordinates with the servo-constraints substituted (*subs*).
//!
//! The crane of Eqs. 24–28 (trolley `x` and rope `l` through first-order drives, τ1,
//! τ2) carries at the rope's end a hook block `H = [x_H, z_H]` of mass `m_h`, and below
//! it, on a sling of fixed length `l_s`, the load `C = [x_C, z_C]` of mass `m`; `z` points
//! down from the rail, gravity is `+g e_z`. Two constraints, as Eq. 26 for each rope:
//! `(x_H − x)² + z_H² = l²` and `|C − H|² = l_s²`, with multipliers λ1 (rope) and λ2
//! (sling) per unit load mass; `μ = m_h/m`. The servo-constraints Eq. 28 prescribe
//! `C = z_d(t)`; substituted, with
//! `x = [x, l, x_H, z_H, v_x, v_l, v_xH, v_zH, λ1, λ2, u1, u2]`:
//!
//! ```text
//! F1  = ẋ − v_x                                            (24)
//! F2  = l̇ − v_l                                            (24)
//! F3  = ẋ_H − v_xH                                         (24)
//! F4  = ż_H − v_zH                                         (24)
//! F5  = τ1 v̇_x + v_x − u1                                  (25, row 1)
//! F6  = τ2 v̇_l + v_l − u2                                  (25, row 2)
//! F7  = μ v̇_xH − 2 (x_H − x) λ1 + 2 (x_C,d − x_H) λ2        the hook, horizontal
//! F8  = μ v̇_zH − μ g − 2 z_H λ1 + 2 (z_C,d − z_H) λ2        the hook, vertical
//! F9  = ẍ_C,d − 2 (x_C,d − x_H) λ2                          (25, row 3)   algebraic
//! F10 = z̈_C,d − g − 2 (z_C,d − z_H) λ2                      (25, row 4)   algebraic
//! F11 = (x_C,d − x_H)² + (z_C,d − z_H)² − l_s²              (26), sling   algebraic
//! F12 = (x_H − x)² + z_H² − l²                              (26), rope    algebraic
//! ```
//!
//! **Differentiation index 5.** F9–F11 fix `x_H, z_H, λ2` on the trajectory alone
//! (position level, `z_d` to order 2). F7, F8 and F12 then fix `λ1, x, l` — but they
//! contain `v̇_H = ẍ_H`, which F3, F4 give only after two differentiations of F9–F11
//! (`z_d` to order 4). The inputs come from `u_i = τ_i q̈_i + q̇_i` (F1, F2, F5, F6) for
//! `q = (x, l)`: `u` needs F7, F8, F12 differentiated twice, and `u̇` — which an ODE for
//! every unknown needs — three times, i.e. F9–F11 five times (`z_d` to order 7). The
//! planar crane's *subs* (the hook's mass zero, F9–F11 giving `x, l, λ` directly) needs
//! three: index 3. So the inputs contain `z_d^(6)`: [`MIN_SMOOTHNESS`](DaeModel::MIN_SMOOTHNESS)
//! is 6, and the paper's C4 polynomial (n = 4) makes them jump at the move's ends — the
//! model refuses it ([`Error::TrajectoryTooRough`]).
//!
//! **Singular** where a rope or the sling goes slack (λ1 or λ2 → 0), the hook reaches the
//! rail (`z_H = 0`) or a rope has zero length: [`DoublePendulumSubs::new`] checks the whole
//! move up front against tension margins on both and the workspace (the exact flat
//! inverse, [`flat_state`](crate::models::double_pendulum_crane::flat_state), gives the
//! configuration). Where the hook's mass vanishes the rope and sling are collinear and
//! the model is the planar crane with a rope `l + l_s`
//! (`host-tests/tests/double_pendulum.rs` checks that limit).

use nalgebra::{SMatrix, SVector};

use crate::error::{Error, Result};
use crate::model::{DaeModel, DifferenceFormula, Driven, Partials, StructuredJacobian};
use crate::models::crane_subs::rope_increment;
use crate::scalar::{c, Real};
use crate::trajectory::{ensure_at_rest, Trajectory};

/// The crane's parameters and realistic ranges, shared with *ext* and the reference
/// ([`double_pendulum_crane`](crate::models::double_pendulum_crane)); named here too,
/// where the studies and tests import them from.
pub use crate::models::double_pendulum_crane::{
    check_trajectory, DoublePendulumParams, HOOK_MASS_RATIO, SLING_LENGTH,
};

/// Number of unknowns.
pub const N: usize = 12;
/// Number of inputs.
pub const NU: usize = 2;
schemes_of!(DoublePendulumSubs, structured);

/// The double pendulum *subs* inverse model, driven by a load trajectory `Z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoublePendulumSubs<T: Real, Z> {
    params: DoublePendulumParams,
    g: T,
    tau1: T,
    tau2: T,
    mu: T,
    sling: T,
    trajectory: Z,
}

impl<T: Real, Z: Trajectory<T, 2>> DoublePendulumSubs<T, Z> {
    /// Builds the model after checking the parameters and the whole trajectory
    /// (smoothness, tension margins, workspace).
    pub fn new(params: DoublePendulumParams, trajectory: Z) -> Result<Self> {
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
            g: c(params.crane.g),
            tau1: c(params.crane.tau1),
            tau2: c(params.crane.tau2),
            mu: c(params.hook_mass / params.crane.m),
            sling: c(params.sling),
            trajectory,
        })
    }

    /// The parameters.
    #[must_use]
    pub fn params(&self) -> &DoublePendulumParams {
        &self.params
    }
}

impl<T: Real, Z> Driven for DoublePendulumSubs<T, Z> {
    type Trajectory = Z;

    fn trajectory(&self) -> &Z {
        &self.trajectory
    }

    fn trajectory_mut(&mut self) -> &mut Z {
        &mut self.trajectory
    }
}

impl<T: Real, Z: Trajectory<T, 2>> DaeModel<T, N, NU> for DoublePendulumSubs<T, Z> {
    const UNKNOWNS: [&'static str; N] = [
        "x", "l", "x_h", "z_h", "vx", "vl", "vx_h", "vz_h", "lambda1", "lambda2", "u1", "u2",
    ];
    const ALGEBRAIC: [bool; N] = [
        false, false, false, false, false, false, false, false, true, true, true, true,
    ];
    /// The positions and velocities; λ1, λ2, u1, u2 have no derivative in F.
    const DIFFERENTIAL: usize = 8;
    const INPUTS: [usize; NU] = [10, 11];
    /// `u` contains `z_d^(6)` (index 5, see the module's comment).
    const MIN_SMOOTHNESS: usize = 6;

    /// `[z_d, ż_d, z̈_d]`.
    type Sample = [SVector<T, 2>; 3];

    fn sample(&self, t: T) -> Self::Sample {
        self.trajectory.derivatives::<3>(t)
    }

    fn residual(&self, x: &SVector<T, N>, xdot: &SVector<T, N>, s: &Self::Sample) -> SVector<T, N> {
        let [xt, l, xh, zh, vx, vl, vxh, vzh, l1, l2, u1, u2]: [T; N] = (*x).into();
        let [dxt, dl, dxh, dzh, dvx, dvl, dvxh, dvzh, _, _, _, _]: [T; N] = (*xdot).into();
        let [[xc, zc], _, [xcdd, zcdd]] = s.map(<[T; 2]>::from);
        let two = c::<T>(2.0);
        let (sx, sz, rx) = (xc - xh, zc - zh, xh - xt);
        SVector::<T, N>::from([
            dxt - vx,
            dl - vl,
            dxh - vxh,
            dzh - vzh,
            self.tau1 * dvx + vx - u1,
            self.tau2 * dvl + vl - u2,
            self.mu * dvxh - two * rx * l1 + two * sx * l2,
            self.mu * (dvzh - self.g) - two * zh * l1 + two * sz * l2,
            xcdd - two * sx * l2,
            zcdd - self.g - two * sz * l2,
            sx * sx + sz * sz - self.sling * self.sling,
            rx * rx + zh * zh - l * l,
        ])
    }

    fn partials(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
    ) -> Partials<T, N> {
        let [xt, l, xh, zh, _, _, _, _, l1, l2, _, _]: [T; N] = (*x).into();
        let [[xc, zc], _, _] = s.map(<[T; 2]>::from);
        let (o, one, two) = (T::zero(), T::one(), c::<T>(2.0));
        let (sx, sz, rx) = (xc - xh, zc - zh, xh - xt);
        let both = -two * (l1 + l2);
        #[rustfmt::skip]
        let dfdx = SMatrix::<T, N, N>::from_row_slice(&[
            // x         l          x_h        z_h        vx    vl    vx_h  vz_h  λ1          λ2          u1    u2
            o,           o,         o,         o,         -one, o,    o,    o,    o,          o,          o,    o,
            o,           o,         o,         o,         o,    -one, o,    o,    o,          o,          o,    o,
            o,           o,         o,         o,         o,    o,    -one, o,    o,          o,          o,    o,
            o,           o,         o,         o,         o,    o,    o,    -one, o,          o,          o,    o,
            o,           o,         o,         o,         one,  o,    o,    o,    o,          o,          -one, o,
            o,           o,         o,         o,         o,    one,  o,    o,    o,          o,          o,    -one,
            two * l1,    o,         both,      o,         o,    o,    o,    o,    -two * rx,  two * sx,   o,    o,
            o,           o,         o,         both,      o,    o,    o,    o,    -two * zh,  two * sz,   o,    o,
            o,           o,         two * l2,  o,         o,    o,    o,    o,    o,          -two * sx,  o,    o,
            o,           o,         o,         two * l2,  o,    o,    o,    o,    o,          -two * sz,  o,    o,
            o,           o,         -two * sx, -two * sz, o,    o,    o,    o,    o,          o,          o,    o,
            -two * rx,   -two * l,  two * rx,  two * zh,  o,    o,    o,    o,    o,          o,          o,    o,
        ]);
        let dfdxdot = SMatrix::<T, N, N>::from_diagonal(&SVector::<T, N>::from([
            one, one, one, one, self.tau1, self.tau2, self.mu, self.mu, o, o, o, o,
        ]));
        Partials {
            dx: dfdx,
            dxdot: dfdxdot,
        }
    }

    fn rest_state(&self, t: T) -> Result<SVector<T, N>> {
        ensure_at_rest(&self.trajectory, t)?;
        let [[xc, zc], _, _] = self.trajectory.derivatives::<3>(t).map(<[T; 2]>::from);
        // Hanging straight down: the hook l_s above the load, λ2 = −g/(2 l_s) from F10,
        // λ1 = −(1 + μ) g/(2 z_H) from F8.
        let two = c::<T>(2.0);
        let zh = zc - self.sling;
        let l2 = -self.g / (two * self.sling);
        let l1 = -(T::one() + self.mu) * self.g / (two * zh);
        let o = T::zero();
        Ok(SVector::<T, N>::from([
            xc, zh, xc, zh, o, o, o, o, l1, l2, o, o,
        ]))
    }

    /// The load position: the servo-constraint holds by construction, `z = z_d(t)`.
    fn output(&self, _x: &SVector<T, N>, s: &Self::Sample) -> SVector<T, 2> {
        let [z, _, _] = *s;
        z
    }
}

/// The factors of the Newton matrix (see [`StructuredJacobian`] for
/// [`DoublePendulumSubs`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoublePendulumFactors<T> {
    /// `c = α₀/h`.
    c: T,
    /// `τ1`, `τ2`.
    tau: [T; 2],
    /// `μ`.
    mu: T,
    /// `1/S_i` of every row.
    inv_scale: [T; N],
    /// The sling's `x_C,d − x_H`, `z_C,d − z_H`.
    sling: [T; 2],
    /// The rope's `x_H − x`, `z_H`.
    rope: [T; 2],
    /// `λ1 + λ2`, `λ2`.
    lambda: [T; 2],
    /// Reciprocal pivots: `1/(2 λ2)` (x_H, z_H from F9, F10), `1/(2 |C − H|²)` (λ2 from
    /// F11), `1/(−2 z_H)` (λ1 from F8), `1/(2 λ1)` (x from F7), `1/(−2 l)` (l from F12).
    inv_pivot: [T; 5],
}

/// `re + i·im`, for the elimination written once for the real and the complex systems.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Lane<T> {
    re: T,
    im: T,
}

impl<T: Real> Lane<T> {
    fn add(self, o: Self) -> Self {
        Self {
            re: self.re + o.re,
            im: self.im + o.im,
        }
    }
    fn sub(self, o: Self) -> Self {
        Self {
            re: self.re - o.re,
            im: self.im - o.im,
        }
    }
    fn scale(self, a: T) -> Self {
        Self {
            re: self.re * a,
            im: self.im * a,
        }
    }
    /// `(c + i b) · self`.
    fn shift(self, c: T, b: T) -> Self {
        Self {
            re: c * self.re - b * self.im,
            im: c * self.im + b * self.re,
        }
    }
}

/// The Newton matrix is block triangular in the order (x_H, z_H, λ2), v_xH, v_zH, λ1, x,
/// l, v_x, v_l, u1, u2 (rows scaled by `S`, `c` the shift, `a = x_C,d − x_H`,
/// `b = z_C,d − z_H`, `d = x_H − x`):
///
/// ```text
/// F9:   2 λ2 η_xH − 2 a η_λ2                                         = r9    ┐ the sling's
/// F10:  2 λ2 η_zH − 2 b η_λ2                                         = r10   │ 3×3 block,
/// F11: −2 a η_xH − 2 b η_zH                                          = r11   ┘ det −8 λ2 l_s²
/// F3:   c η_xH − η_vxH                                               = r3    (F4 for z_H)
/// F8:   μ c η_vzH − 2 (λ1 + λ2) η_zH − 2 z_H η_λ1 + 2 b η_λ2          = r8
/// F7:   μ c η_vxH − 2 (λ1 + λ2) η_xH + 2 λ1 η_x − 2 d η_λ1 + 2 a η_λ2 = r7
/// F12:  2 d η_xH − 2 d η_x + 2 z_H η_zH − 2 l η_l                     = r12
/// F1:   c η_x − η_vx                                                 = r1    (F2 for l)
/// F5:  (τ1 c + 1) η_vx − η_u1                                        = r5    (F6 for l)
/// ```
///
/// The sling's block is eliminated with the pivot `2 λ2` for x_H and z_H and its Schur
/// complement `−2 (a² + b²)/λ2` for λ2; then λ1, x, l each have one pivot (`−2 z_H`,
/// `2 λ1`, `−2 l`). None depends on the shift, so the real factors serve RADAU5's complex
/// system too; they vanish only for a slack sling or rope, the hook at the load or at the
/// rail, or a rope of zero length, all refused up front. Five pivots known in advance
/// instead of a 12×12 LU with its pivot search (its cost not measured yet: the model is
/// not in a firmware).
impl<T: Real, Z: Trajectory<T, 2>> StructuredJacobian<T, N, NU> for DoublePendulumSubs<T, Z> {
    type Factors = DoublePendulumFactors<T>;

    fn factor(
        &self,
        x: &SVector<T, N>,
        _xdot: &SVector<T, N>,
        s: &Self::Sample,
        alpha0_h: T,
        scale: &SVector<T, N>,
    ) -> Option<DoublePendulumFactors<T>> {
        let [xt, l, xh, zh, _, _, _, _, l1, l2, _, _]: [T; N] = (*x).into();
        let [[xc, zc], _, _] = s.map(<[T; 2]>::from);
        let (one, two) = (T::one(), c::<T>(2.0));
        let (a, b) = (xc - xh, zc - zh);
        let pivots = [
            two * l2,
            two * (a * a + b * b),
            -two * zh,
            two * l1,
            -two * l,
        ];
        let finite_reciprocal = |p: &T| *p != T::zero() && crate::scalar::is_finite(one / *p);
        if !pivots.iter().chain(scale.iter()).all(finite_reciprocal) {
            return None;
        }
        Some(DoublePendulumFactors {
            c: alpha0_h,
            tau: [self.tau1, self.tau2],
            mu: self.mu,
            inv_scale: scale.map(|s| one / s).into(),
            sling: [a, b],
            rope: [xh - xt, zh],
            lambda: [l1 + l2, l2],
            inv_pivot: pivots.map(|p| one / p),
        })
    }

    fn solve(f: &DoublePendulumFactors<T>, r: &mut SVector<T, N>) {
        let lanes = eliminate(f, T::zero(), r.map(|re| Lane { re, im: T::zero() }).into());
        *r = SVector::<T, N>::from(lanes.map(|v| v.re));
    }

    /// The same elimination in complex arithmetic (`eliminate`): the shift `c + i b`
    /// enters through F1–F8 only.
    fn solve_complex(
        f: &DoublePendulumFactors<T>,
        b: T,
        re: &mut SVector<T, N>,
        im: &mut SVector<T, N>,
    ) {
        let r: [Lane<T>; N] = core::array::from_fn(|i| Lane {
            re: re.get(i).copied().unwrap_or_else(T::zero),
            im: im.get(i).copied().unwrap_or_else(T::zero),
        });
        let lanes = eliminate(f, b, r);
        *re = SVector::<T, N>::from(lanes.map(|v| v.re));
        *im = SVector::<T, N>::from(lanes.map(|v| v.im));
    }

    const CLOSED_FORM: bool = true;

    /// The step by forward substitution in the matrix's order — the flat inverse
    /// ([`flat_state`](crate::models::double_pendulum_crane::flat_state)) with the
    /// scheme's difference formula in place of each time derivative:
    ///
    /// ```text
    /// F9–F11 (node by node):  A = [ẍ_C,d, z̈_C,d − g],  λ2 = −|A|/(2 l_s),  H = C_d + l_s A/|A|
    /// F3, F4:                 v_H = d(H),  v̇_H = d(v_H)
    /// F8:                     λ1 = (μ (v̇_zH − g) + z̈_C,d − g) / (2 z_H)
    /// F7:                     x_H − x = (μ v̇_xH + ẍ_C,d) / (2 λ1)
    /// F12:                    l² = (x_H − x)² + z_H²
    /// F1, F2, F5, F6:         v = d(q),  u = τ d(v) + v   for q = x, l
    /// ```
    ///
    /// as increments against `x_{n−1}` ([`StructuredJacobian::solve_step`]), the rope's
    /// by the planar crane's Heron steps. `None` where a pivot vanishes (a slack sling or
    /// rope, the hook at the rail) or the rope's increment is not resolved.
    fn solve_step<const K: usize, D: DifferenceFormula<T, K>>(
        &self,
        samples: &[Self::Sample; K],
        d: &D,
    ) -> Option<[SVector<T, N>; K]> {
        let two = c::<T>(2.0);
        let anchor: [T; N] = core::array::from_fn(|j| d.anchor(j));
        let [x0, l0, xh0, zh0, vx0, vl0, vxh0, vzh0, l10, l20, u10, u20] = anchor;
        let usable = |v: T| v != T::zero() && crate::scalar::is_finite(v);
        let mut refused = false;
        // F9–F11: the hook and the sling's force at each node.
        let sling = samples.map(|s| {
            let [[xc, zc], _, [xcdd, zcdd]] = s.map(<[T; 2]>::from);
            let az = zcdd - self.g;
            let norm = (xcdd * xcdd + az * az).sqrt();
            refused |= !usable(norm);
            let (ox, oz) = (self.sling * xcdd / norm, self.sling * az / norm);
            [(xc - xh0) + ox, (zc - zh0) + oz, -norm / (two * self.sling)]
        });
        let dxh = sling.map(|[v, _, _]| v);
        let dzh = sling.map(|[_, v, _]| v);
        let vxh = d.derivative(2, dxh);
        let vzh = d.derivative(3, dzh);
        let axh = d.derivative(6, vxh.map(|v| v - vxh0));
        let azh = d.derivative(7, vzh.map(|v| v - vzh0));
        // F8, F7, F12: the rope's force, the trolley and the rope at each node.
        let mut rope = [[T::zero(); 3]; K];
        for (k, (r, s)) in rope.iter_mut().zip(samples).enumerate() {
            let at = |a: &[T; K]| a.get(k).copied().unwrap_or_else(T::zero);
            let [_, _, [xcdd, zcdd]] = s.map(<[T; 2]>::from);
            let zh = zh0 + at(&dzh);
            let l1 = (self.mu * (at(&azh) - self.g) + zcdd - self.g) / (two * zh);
            refused |= !usable(l1);
            let offset = (self.mu * at(&axh) + xcdd) / (two * l1);
            // l² − l_{n−1}², with z_H − l_{n−1} formed first (both near the rope's length).
            let q = (zh - l0) * (zh + l0) + offset * offset;
            let dl = rope_increment(l0, q);
            refused |= dl.is_none();
            *r = [
                (xh0 - x0) + at(&dxh) - offset,
                dl.unwrap_or_else(T::zero),
                l1,
            ];
        }
        if refused {
            return None;
        }
        let dx = rope.map(|[v, _, _]| v);
        let dl = rope.map(|[_, v, _]| v);
        let vx = d.derivative(0, dx);
        let vl = d.derivative(1, dl);
        let dvx = vx.map(|v| v - vx0);
        let dvl = vl.map(|v| v - vl0);
        let ax = d.derivative(4, dvx);
        let al = d.derivative(5, dvl);
        let mut out = [SVector::<T, N>::zeros(); K];
        for (k, o) in out.iter_mut().enumerate() {
            let at = |a: &[T; K]| a.get(k).copied().unwrap_or_else(T::zero);
            let [_, _, l2] = sling.get(k).copied()?;
            let [_, _, l1] = rope.get(k).copied()?;
            *o = SVector::<T, N>::from([
                at(&dx),
                at(&dl),
                at(&dxh),
                at(&dzh),
                at(&dvx),
                at(&dvl),
                at(&vxh) - vxh0,
                at(&vzh) - vzh0,
                l1 - l10,
                l2 - l20,
                self.tau1 * at(&ax) + at(&vx) - u10,
                self.tau2 * at(&al) + at(&vl) - u20,
            ]);
        }
        Some(out)
    }
}

/// Solves `(∂F/∂x + (c + i b) ∂F/∂ẋ) η = r` (rows scaled) by forward substitution in the
/// order of the [`StructuredJacobian`] impl's comment; `b = 0` is the real system.
fn eliminate<T: Real>(f: &DoublePendulumFactors<T>, b: T, r: [Lane<T>; N]) -> [Lane<T>; N] {
    let two = c::<T>(2.0);
    // The rows without their scaling.
    let [r1, r2, r3, r4, r5, r6, r7, r8, r9, r10, r11, r12]: [Lane<T>; N] =
        core::array::from_fn(|i| {
            let v = r.get(i).copied().unwrap_or(Lane {
                re: T::zero(),
                im: T::zero(),
            });
            v.scale(f.inv_scale.get(i).copied().unwrap_or_else(T::one))
        });
    let [p_hook, p_schur, p_lambda1, p_x, p_l] = f.inv_pivot;
    let [a, sb] = f.sling;
    let [d, zh] = f.rope;
    let [sum, l2] = f.lambda;
    let [tau1, tau2] = f.tau;
    let shift = |v: Lane<T>| v.shift(f.c, b);
    // The sling's block: η_λ2 = −(λ2 r11 + a r9 + b r10) / (2 (a² + b²)).
    let eta_l2 = r11
        .scale(l2)
        .add(r9.scale(a))
        .add(r10.scale(sb))
        .scale(-p_schur);
    let eta_xh = r9.add(eta_l2.scale(two * a)).scale(p_hook);
    let eta_zh = r10.add(eta_l2.scale(two * sb)).scale(p_hook);
    let eta_vxh = shift(eta_xh).sub(r3);
    let eta_vzh = shift(eta_zh).sub(r4);
    let eta_l1 = r8
        .sub(shift(eta_vzh).scale(f.mu))
        .add(eta_zh.scale(two * sum))
        .sub(eta_l2.scale(two * sb))
        .scale(p_lambda1);
    let eta_x = r7
        .sub(shift(eta_vxh).scale(f.mu))
        .add(eta_xh.scale(two * sum))
        .add(eta_l1.scale(two * d))
        .sub(eta_l2.scale(two * a))
        .scale(p_x);
    let eta_l = r12
        .sub(eta_xh.scale(two * d))
        .add(eta_x.scale(two * d))
        .sub(eta_zh.scale(two * zh))
        .scale(p_l);
    let eta_vx = shift(eta_x).sub(r1);
    let eta_vl = shift(eta_l).sub(r2);
    // u = (τ (c + i b) + 1) v − r.
    let eta_u1 = shift(eta_vx).scale(tau1).add(eta_vx).sub(r5);
    let eta_u2 = shift(eta_vl).scale(tau2).add(eta_vl).sub(r6);
    [
        eta_x, eta_l, eta_xh, eta_zh, eta_vx, eta_vl, eta_vxh, eta_vzh, eta_l1, eta_l2, eta_u1,
        eta_u2,
    ]
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use crate::models::double_pendulum_crane::flat_state;
    use crate::trajectory::PointToPoint;

    type Model = DoublePendulumSubs<f64, PointToPoint<f64, 2>>;

    fn model() -> Model {
        let z = PointToPoint::new(
            SVector::from([12.0, 8.0]),
            SVector::from([20.0, 4.0]),
            1.0,
            8.0,
            6,
        )
        .unwrap();
        DoublePendulumSubs::new(DoublePendulumParams::EXAMPLE, z).unwrap()
    }

    /// A state off the solution, near the move's configuration.
    fn state(k: f64) -> SVector<f64, N> {
        let base = [
            15.0, 5.0, 15.5, 5.2, 0.5, -0.3, 0.4, -0.2, -1.2, -4.9, 0.4, -0.2,
        ];
        SVector::from_fn(|i, _| base[i] * (1.0 + 0.2 * (k * 0.37 + i as f64).sin()))
    }

    /// The positions and velocities are the differential unknowns.
    #[test]
    fn the_first_eight_unknowns_are_the_differential_ones() {
        let m = model();
        let s = m.sample(3.8);
        crate::models::test_support::assert_differential_first(&m, &state(1.0), &state(2.0), &s);
    }

    /// The rest state is consistent: the residual vanishes with ẋ = 0.
    #[test]
    fn rest_state_is_consistent() {
        let m = model();
        for t in [0.0, 9.5] {
            let x = m.rest_state(t).unwrap();
            let r = m.residual(&x, &SVector::zeros(), &m.sample(t));
            assert!(r.amax() < 1e-14, "t = {t}: {r:?}");
        }
    }

    /// The structured elimination solves the dense system built from the partials (its
    /// product with the matrix gives back the right-hand side, and the dense LU agrees),
    /// at states off the solution, for BDF4's and RADAU5's real shift and every row
    /// scaling of Sec. 3.1.1.
    #[test]
    fn structured_elimination_solves_the_dense_newton_system() {
        let m = model();
        for case in 0..200 {
            let k = case as f64;
            let s = m.sample(0.05 * k);
            let x = state(k);
            let h: f64 = [0.0005, 0.01, 0.05][case % 3];
            let c = 25.0 / 12.0 / h;
            let rho = 1.0 / h.powi((case % 4) as i32);
            let scale = SVector::<f64, N>::from_fn(|i, _| if i >= 8 { rho } else { 1.0 });
            let p = m.partials(&x, &x, &s);
            let mut a = p.dx + p.dxdot * c;
            for (mut row, si) in a.row_iter_mut().zip(scale.iter()) {
                row *= *si;
            }
            let r = SVector::<f64, N>::from_fn(|i, _| (k + 2.0 * i as f64).cos());
            let f = m.factor(&x, &x, &s, c, &scale).unwrap();
            let mut eta = r;
            Model::solve(&f, &mut eta);
            let size = a.abs().column_sum().max() * eta.amax() + r.amax();
            let back = (a * eta - r).amax();
            assert!(back <= 1e-13 * size, "case {case}: A η − r = {back:e}");
            let mut lu = a;
            let mut piv = [0; N];
            assert!(crate::linalg::factor(&mut lu, &mut piv));
            let mut dense = r;
            crate::linalg::solve(&lu, &piv, &mut dense);
            assert!(
                (dense - eta).amax() <= 1e-8 * dense.amax(),
                "case {case}: {:e}",
                (dense - eta).amax()
            );
        }
    }

    /// The complex elimination solves RADAU5's complex system (rows scaled), checked by
    /// multiplying back in real arithmetic.
    #[test]
    fn structured_elimination_solves_the_complex_system() {
        use crate::schemes::radau::transformed::{ALPHA, BETA};
        let m = model();
        for case in 0..120 {
            let k = case as f64;
            let s = m.sample(0.08 * k);
            let x = state(k);
            let h: f64 = [0.0005, 0.01, 0.05][case % 3];
            let (c, b) = (ALPHA / h, BETA / h);
            let rho = 1.0 / h.powi((case % 4) as i32);
            let scale = SVector::<f64, N>::from_fn(|i, _| if i >= 8 { rho } else { 1.0 });
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
        }
    }

    /// A difference formula around an anchor, for this model's `N` unknowns.
    type Formula<const K: usize> = crate::models::test_support::Formula<N, K>;

    /// The closed-form step solves the scheme's equations at every node: each row of
    /// `F(x_{n−1} + Δ_k, Ẋ_k, t_k)` vanishes to within a few roundings of its terms, for
    /// BDF4's formula (one node) and Radau IIA's (three), anchors off the solution and h
    /// from 0.5 ms to 50 ms.
    #[test]
    fn closed_form_step_solves_the_step() {
        use crate::schemes::radau::transformed::A_INV;
        use crate::schemes::radau::C;
        let m = model();
        fn check<const K: usize>(m: &Model, f: &Formula<K>, times: [f64; K], case: usize) {
            let samples = times.map(|t| m.sample(t));
            let inc = m.solve_step(&samples, f);
            assert!(inc.is_some(), "case {case}, K = {K}: refused");
            let inc = inc.unwrap();
            for (k, s) in samples.iter().enumerate() {
                let x = f.anchor + inc[k];
                let xd = SVector::<f64, N>::from_fn(|j, _| f.derivative(j, inc.map(|d| d[j]))[k]);
                let r = m.residual(&x, &xd, s);
                // Each row's terms, bounded by the sizes of what it adds.
                let size = x.amax() * (1.0 + x.amax()) + xd.amax() + 10.0 + s[2].amax();
                for (i, ri) in r.iter().enumerate() {
                    assert!(
                        ri.abs() <= 64.0 * f64::EPSILON * size,
                        "case {case}, node {k}, row {i}: {ri:e} against {size:e}"
                    );
                }
            }
        }
        for case in 0..300 {
            let t = 0.9 + 0.027 * case as f64;
            let h = [0.0005, 0.001, 0.01, 0.05][case % 4];
            let k = (case as f64 * 0.7).sin();
            // Anchors near the exact solution at t − h, off it by 1e-10: a step's trolley and
            // rope hang on the hook's acceleration from the difference formula, which turns
            // an anchor's offset δ into about δ/h² (Radau's A⁻¹ has entries near 10): at
            // 1 ms an offset of 1e-6 m gives the hook 10 m/s² and slackens the rope.
            let exact =
                |t: f64| flat_state(m.params(), &m.trajectory().derivatives::<8>(t), t).unwrap();
            let anchor = exact(t - h).subs()
                + SVector::<f64, N>::from_fn(|j, _| 1e-10 * k * (j as f64 - 5.0));
            let w = 25.0 / 12.0 / h;
            let bdf = Formula {
                anchor,
                weights: [[w]],
                past: exact(t).subs_dot() - (exact(t).subs() - anchor) * w,
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

    /// A slack sling (λ2 = 0) or rope (λ1 = 0) makes the matrix singular: no factors.
    #[test]
    fn singular_matrix_has_no_factors() {
        let m = model();
        let s = m.sample(0.0);
        let scale = SVector::<f64, N>::repeat(1.0);
        for slack in [8, 9] {
            let mut x = m.rest_state(0.0).unwrap();
            x[slack] = 0.0;
            assert!(m.factor(&x, &x, &s, 200.0, &scale).is_none(), "{slack}");
        }
    }
}
