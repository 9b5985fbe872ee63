//! The hook-and-load double pendulum's exact inverse and its forward plant.
//!
//! **Flat inverse.** The load's position `C = [x_C, z_C]` is a flat output
//! ([`DoublePendulumSubs`](crate::models::double_pendulum::DoublePendulumSubs) writes the
//! equations; `z` points down, gravity is `+g e_z`, everything per unit load mass, `μ` the
//! hook's mass over the load's):
//!
//! * the sling pulls the load along `a_C − g e_z` (F9–F10), so with `A = a_C − g e_z`
//!   the sling force per unit mass is `λ2 = −|A|/(2 l_s)` and the hook sits at
//!   `H = C + l_s A/|A|` (F11) — the load path's derivatives to order 2;
//! * the rope carries both masses (F7 + F9, F8 + F10): `B = μ(a_H − g e_z) + A = 2 λ1 (H − T)`
//!   with the trolley `T = [x, 0]`, so `λ1 = B_z/(2 z_H)` and `x = x_H − B_x z_H/B_z`, and
//!   F12 gives `l = √((x_H − x)² + z_H²)` — `a_H` needs the load path to order 4;
//! * the drives' rows (Eq. 25, rows 1–2) give `u_i = τ_i q̈_i + q̇_i` for `q = (x, l)` —
//!   order 6 — and their rates `u̇` order 7.
//!
//! The derivatives come from Taylor arithmetic ([`Taylor`]) on the trajectory's exact
//! derivatives, so the reference is exact to rounding.
//!
//! **Plant.** The same crane in minimal coordinates for the forward check of Sec. 2.3:
//! trolley `x` and rope `l` through their first-order drives, the rope's angle `φ1` and
//! the sling's `φ2` from the vertical, `H = [x + l sin φ1, l cos φ1]`,
//! `C = H + l_s [sin φ2, cos φ2]`; d'Alembert's principle along `φ1` and `φ2` gives two
//! linear equations for `φ̈1, φ̈2` ([`plant_rhs`]).

use nalgebra::SVector;

use crate::error::{Error, Result};
use crate::models::double_pendulum::DoublePendulumParams;
use crate::reference::emax::{self, Emax};
use crate::trajectory::Trajectory;

/// A truncated Taylor series: `L` normalised coefficients `f^(k)(t)/k!` of a function at
/// one instant. Sums, products, quotients and square roots by the usual recurrences;
/// coefficient `k` of a result depends on coefficients `≤ k` of its operands only, so a
/// series whose upper coefficients are unknown (zero) still gives the lower ones exactly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Taylor<const L: usize>(pub [f64; L]);

impl<const L: usize> Taylor<L> {
    /// From the derivatives `[f, ḟ, f̈, …]`.
    #[must_use]
    pub fn from_derivatives(d: [f64; L]) -> Self {
        let mut factorial = 1.0;
        Self(core::array::from_fn(|k| {
            if k > 0 {
                factorial *= k as f64;
            }
            d.get(k).copied().unwrap_or(0.0) / factorial
        }))
    }

    /// A constant.
    #[must_use]
    pub fn constant(v: f64) -> Self {
        Self(core::array::from_fn(|k| if k == 0 { v } else { 0.0 }))
    }

    /// The `k`-th derivative (0 beyond `L`).
    #[must_use]
    pub fn derivative(&self, k: usize) -> f64 {
        let factorial: f64 = (1..=k).map(|i| i as f64).product();
        self.0.get(k).copied().unwrap_or(0.0) * factorial
    }

    /// The value.
    #[must_use]
    pub fn value(&self) -> f64 {
        self.derivative(0)
    }

    /// The series of the time derivative; its last coefficient is unknown (zero).
    #[must_use]
    pub fn dt(&self) -> Self {
        Self(core::array::from_fn(|k| {
            self.0.get(k + 1).copied().unwrap_or(0.0) * (k + 1) as f64
        }))
    }

    fn coefficient(&self, k: usize) -> f64 {
        self.0.get(k).copied().unwrap_or(0.0)
    }

    /// `√f`: `r_k = (f_k − Σ_{i=1}^{k−1} r_i r_{k−i}) / (2 r_0)`.
    #[must_use]
    pub fn sqrt(&self) -> Self {
        let mut r = [0.0; L];
        for k in 0..L {
            let rk = if k == 0 {
                libm::sqrt(self.coefficient(0))
            } else {
                let cross: f64 = (1..k)
                    .map(|i| {
                        r.get(i).copied().unwrap_or(0.0) * r.get(k - i).copied().unwrap_or(0.0)
                    })
                    .sum();
                (self.coefficient(k) - cross) / (2.0 * r.first().copied().unwrap_or(0.0))
            };
            if let Some(slot) = r.get_mut(k) {
                *slot = rk;
            }
        }
        Self(r)
    }

    /// `f · a` for a number `a`.
    #[must_use]
    pub fn scale(&self, a: f64) -> Self {
        Self(self.0.map(|v| v * a))
    }
}

impl<const L: usize> core::ops::Add for Taylor<L> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self(core::array::from_fn(|k| {
            self.coefficient(k) + o.coefficient(k)
        }))
    }
}

impl<const L: usize> core::ops::Sub for Taylor<L> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self(core::array::from_fn(|k| {
            self.coefficient(k) - o.coefficient(k)
        }))
    }
}

impl<const L: usize> core::ops::Mul for Taylor<L> {
    type Output = Self;
    /// The Cauchy product `(fg)_k = Σ_i f_i g_{k−i}`.
    fn mul(self, o: Self) -> Self {
        Self(core::array::from_fn(|k| {
            (0..=k)
                .map(|i| self.coefficient(i) * o.coefficient(k - i))
                .sum()
        }))
    }
}

impl<const L: usize> core::ops::Div for Taylor<L> {
    type Output = Self;
    /// `q = f/g` from `q g = f`: `q_k = (f_k − Σ_{i=1}^{k} g_i q_{k−i}) / g_0`.
    fn div(self, o: Self) -> Self {
        let mut q = [0.0; L];
        for k in 0..L {
            let known: f64 = (1..=k)
                .map(|i| o.coefficient(i) * q.get(k - i).copied().unwrap_or(0.0))
                .sum();
            if let Some(slot) = q.get_mut(k) {
                *slot = (self.coefficient(k) - known) / o.coefficient(0);
            }
        }
        Self(q)
    }
}

/// Coefficients carried: the load path to order 7 in two series of 6 (`z` … `z^(5)` and
/// `z̈` … `z^(7)`), which leaves `x` and `l` with 4 exact coefficients (`u̇` needs `q⃛`).
const L: usize = 6;

/// The exact double-pendulum state and inputs that keep the load on its path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlatDoublePendulum {
    /// Trolley position x, m.
    pub x: f64,
    /// Rope length l, m.
    pub l: f64,
    /// The hook block `[x_H, z_H]`, m.
    pub hook: [f64; 2],
    /// Trolley and rope velocities `[ẋ, l̇]`, m/s.
    pub v: [f64; 2],
    /// The hook's velocity `[ẋ_H, ż_H]`, m/s.
    pub v_hook: [f64; 2],
    /// Trolley and rope accelerations `[ẍ, l̈]`, m/s².
    pub a: [f64; 2],
    /// The hook's acceleration `[ẍ_H, z̈_H]`, m/s².
    pub a_hook: [f64; 2],
    /// Rope and sling forces per unit load mass `[λ1, λ2]` (negative: tension), 1/s².
    pub lambda: [f64; 2],
    /// Their rates, 1/s³.
    pub lambda_dot: [f64; 2],
    /// The rope's and the sling's angles from the vertical `[φ1, φ2]`, rad.
    pub angle: [f64; 2],
    /// Their rates, rad/s.
    pub angle_rate: [f64; 2],
    /// `u_flat = [u1, u2]`: trolley and winch velocity set points, m/s.
    pub u: [f64; 2],
    /// `u̇_flat`, m/s².
    pub u_dot: [f64; 2],
}

impl FlatDoublePendulum {
    /// The state in the *subs* unknowns
    /// `[x, l, x_H, z_H, v_x, v_l, v_xH, v_zH, λ1, λ2, u1, u2]`.
    #[must_use]
    pub fn subs(&self) -> SVector<f64, 12> {
        let ([vx, vl], [vxh, vzh], [l1, l2], [u1, u2]) = (self.v, self.v_hook, self.lambda, self.u);
        let [xh, zh] = self.hook;
        SVector::from([self.x, self.l, xh, zh, vx, vl, vxh, vzh, l1, l2, u1, u2])
    }

    /// Its time derivative, with which the *subs* residual vanishes along the path.
    #[must_use]
    pub fn subs_dot(&self) -> SVector<f64, 12> {
        let ([vx, vl], [vxh, vzh], [ax, al], [axh, azh]) =
            (self.v, self.v_hook, self.a, self.a_hook);
        let ([l1, l2], [u1, u2]) = (self.lambda_dot, self.u_dot);
        SVector::from([vx, vl, vxh, vzh, ax, al, axh, azh, l1, l2, u1, u2])
    }

    /// The plant's state `[x, l, φ1, φ2, ẋ, l̇, φ̇1, φ̇2]` ([`plant_rhs`]).
    #[must_use]
    pub fn plant_state(&self) -> SVector<f64, 8> {
        let ([vx, vl], [p1, p2], [w1, w2]) = (self.v, self.angle, self.angle_rate);
        SVector::from([self.x, self.l, p1, p2, vx, vl, w1, w2])
    }
}

/// The flat inverse's Taylor series at one instant: the load, the hook, both forces, the
/// trolley and the rope (see the module's comment).
#[derive(Debug, Clone, Copy, PartialEq)]
struct FlatSeries {
    xc: Taylor<L>,
    zc: Taylor<L>,
    azc: Taylor<L>,
    xh: Taylor<L>,
    zh: Taylor<L>,
    azh: Taylor<L>,
    lambda1: Taylor<L>,
    lambda2: Taylor<L>,
    x: Taylor<L>,
    dx: Taylor<L>,
    l: Taylor<L>,
}

/// The series of [`FlatSeries`] from the load path's derivatives `[z, ż, …, z^(7)]`.
fn flat_series(p: &DoublePendulumParams, d: &[SVector<f64, 2>; 8]) -> FlatSeries {
    let series = |axis: usize, from: usize| {
        Taylor::<L>::from_derivatives(core::array::from_fn(|k| {
            d.get(from + k)
                .and_then(|v| v.get(axis))
                .copied()
                .unwrap_or(0.0)
        }))
    };
    let (xc, zc) = (series(0, 0), series(1, 0));
    let (axc, azc) = (series(0, 2), series(1, 2));
    let g = Taylor::constant(p.crane.g);
    let mu = p.hook_mass / p.crane.m;
    // The sling along A = a_C − g e_z.
    let (ax, az) = (axc, azc - g);
    let norm = (ax * ax + az * az).sqrt();
    let xh = xc + (ax / norm).scale(p.sling);
    let zh = zc + (az / norm).scale(p.sling);
    let lambda2 = norm.scale(-0.5 / p.sling);
    // The rope along B = μ (a_H − g e_z) + A.
    let (axh, azh) = (xh.dt().dt(), zh.dt().dt());
    let bx = axh.scale(mu) + ax;
    let bz = (azh - g).scale(mu) + az;
    let lambda1 = bz / zh.scale(2.0);
    let x = xh - bx * zh / bz;
    let dx = xh - x;
    let l = (dx * dx + zh * zh).sqrt();
    FlatSeries {
        xc,
        zc,
        azc,
        xh,
        zh,
        azh,
        lambda1,
        lambda2,
        x,
        dx,
        l,
    }
}

/// `u_flat(t)` and the state that goes with it, from the load path's derivatives
/// `[z, ż, …, z^(7)]` at the instant `t` (see the module's comment).
///
/// Refused where the inverse does not exist: the load's downward acceleration at or
/// above `g` (the sling would push, [`Error::RopeSlack`] with it), the two masses' mean
/// downward acceleration `(z̈_C + μ z̈_H)/(1 + μ)` at or above `g` (the rope would,
/// [`Error::RopeSlack`] with the mean), the hook at or above the rail
/// ([`Error::OutsideWorkspace`] naming `z_H`), and anything not finite (a non-finite
/// parameter or path, [`Error::NonFinite`]). The model's checks
/// ([`check_trajectory`](crate::models::double_pendulum::check_trajectory)) keep margins
/// to these.
pub fn flat_state(
    p: &DoublePendulumParams,
    d: &[SVector<f64, 2>; 8],
    t: f64,
) -> Result<FlatDoublePendulum> {
    let FlatSeries {
        xc,
        zc,
        azc,
        xh,
        zh,
        azh,
        lambda1,
        lambda2,
        x,
        dx,
        l,
    } = flat_series(p, d);
    let mu = p.hook_mass / p.crane.m;
    // d/dt atan2(p, q) = (ṗ q − p q̇)/(p² + q²).
    let rate = |p: &Taylor<L>, q: &Taylor<L>| {
        (p.derivative(1) * q.value() - p.value() * q.derivative(1))
            / (p.value() * p.value() + q.value() * q.value())
    };
    let (sx, sz) = (xc - xh, zc - zh);
    let (tau1, tau2) = (p.crane.tau1, p.crane.tau2);
    let input = |q: &Taylor<L>, tau: f64, k: usize| tau * q.derivative(k + 2) + q.derivative(k + 1);
    let g = p.crane.g;
    let slack = |acc: f64| {
        (acc >= g).then_some(Error::RopeSlack {
            t,
            vertical_acceleration: acc,
            limit: g,
        })
    };
    let mean = (azc.value() + mu * azh.value()) / (1.0 + mu);
    if let Some(e) = slack(azc.value()).or_else(|| slack(mean)) {
        return Err(e);
    }
    if zh.value() <= 0.0 {
        return Err(Error::OutsideWorkspace {
            t,
            coordinate: "z_H",
            value: zh.value(),
            min: 0.0,
            max: f64::INFINITY,
        });
    }
    let flat = FlatDoublePendulum {
        x: x.value(),
        l: l.value(),
        hook: [xh.value(), zh.value()],
        v: [x.derivative(1), l.derivative(1)],
        v_hook: [xh.derivative(1), zh.derivative(1)],
        a: [x.derivative(2), l.derivative(2)],
        a_hook: [xh.derivative(2), zh.derivative(2)],
        lambda: [lambda1.value(), lambda2.value()],
        lambda_dot: [lambda1.derivative(1), lambda2.derivative(1)],
        angle: [
            libm::atan2(dx.value(), zh.value()),
            libm::atan2(sx.value(), sz.value()),
        ],
        angle_rate: [rate(&dx, &zh), rate(&sx, &sz)],
        u: [input(&x, tau1, 0), input(&l, tau2, 0)],
        u_dot: [input(&x, tau1, 1), input(&l, tau2, 1)],
    };
    if flat
        .subs()
        .iter()
        .chain(flat.u_dot.iter())
        .all(|v| v.is_finite())
    {
        Ok(flat)
    } else {
        Err(Error::NonFinite { t, iterations: 0 })
    }
}

/// `u_flat(t)` and the state that goes with it, on the trajectory `z` at `t`; refused as
/// [`flat_state`] refuses.
pub fn flat_inverse<Z: Trajectory<f64, 2>>(
    p: &DoublePendulumParams,
    z: &Z,
    t: f64,
) -> Result<FlatDoublePendulum> {
    flat_state(p, &z.derivatives::<8>(t), t)
}

/// The exact state in the unknowns of the minimally extended formulation
/// ([`double_pendulum_ext`](crate::models::double_pendulum_ext), its order): the *subs*
/// state of [`flat_state`], then the rates the extension adds — `x', l', x_H', z_H'`, the
/// trolley's, rope's and hook's accelerations, the hook's jerk and snap, `λ1', λ1''` and
/// `λ2'` … `λ2''''` — from the same Taylor series (the hook and λ2 keep 6 exact
/// coefficients, the trolley, the rope and λ1 4). Refused as [`flat_state`] refuses.
pub fn extended_state(
    p: &DoublePendulumParams,
    d: &[SVector<f64, 2>; 8],
    t: f64,
) -> Result<SVector<f64, { crate::models::double_pendulum_ext::N }>> {
    let flat = flat_state(p, d, t)?;
    let FlatSeries {
        xh,
        zh,
        lambda1,
        lambda2,
        x,
        l,
        ..
    } = flat_series(p, d);
    let added = [
        x.derivative(1),
        l.derivative(1),
        xh.derivative(1),
        zh.derivative(1),
        x.derivative(2),
        l.derivative(2),
        xh.derivative(2),
        zh.derivative(2),
        xh.derivative(3),
        zh.derivative(3),
        xh.derivative(4),
        zh.derivative(4),
        lambda1.derivative(1),
        lambda1.derivative(2),
        lambda2.derivative(1),
        lambda2.derivative(2),
        lambda2.derivative(3),
        lambda2.derivative(4),
    ];
    Ok(SVector::from_iterator(
        flat.subs().iter().copied().chain(added),
    ))
}

/// One sample's error of Eq. 29, `max_i |u_i − u_flat,i(t)|` (NaN if `u` is, or where
/// the reference is refused: a failed comparison must not look accurate).
#[must_use]
pub fn input_error<Z: Trajectory<f64, 2>>(
    p: &DoublePendulumParams,
    z: &Z,
    t: f64,
    u: &SVector<f64, 2>,
) -> f64 {
    flat_inverse(p, z, t).map_or(f64::NAN, |flat| emax::input_error(u, &flat.u))
}

/// Eq. 29 over a run's samples `(t, u(t))`, globally and over the interior `[a, b]`.
pub fn e_max<Z, I>(p: &DoublePendulumParams, z: &Z, samples: I, (a, b): (f64, f64)) -> Emax
where
    Z: Trajectory<f64, 2>,
    I: IntoIterator<Item = (f64, SVector<f64, 2>)>,
{
    let mut e = Emax::over(a, b);
    for (t, u) in samples {
        e.add(t, input_error(p, z, t, &u));
    }
    e
}

/// The plant in minimal coordinates, state `y = [x, l, φ1, φ2, ẋ, l̇, φ̇1, φ̇2]`, input
/// `[u1, u2]`: `ẏ`.
///
/// The drives: `ẍ = (u1 − ẋ)/τ1`, `l̈ = (u2 − l̇)/τ2` (Eq. 22). With `e_i = [cos φ_i, −sin φ_i]`
/// the hook's acceleration is `a_H = a_0 + l φ̈1 e1`, `a_0` everything but `φ̈1`
/// (`ẍ + l̈ sin φ1 + 2 l̇ φ̇1 cos φ1 − l φ̇1² sin φ1`, `l̈ cos φ1 − 2 l̇ φ̇1 sin φ1 − l φ̇1² cos φ1`),
/// the load's `a_C = a_H + l_s φ̈2 e2 − l_s φ̇2² n2`, `n2 = [sin φ2, cos φ2]`. D'Alembert per unit
/// load mass along `φ1` (both masses move by `l e1`) and `φ2` (the load by `l_s e2`):
///
/// ```text
/// (1 + μ) l φ̈1 + l_s cos(φ1 − φ2) φ̈2 = −(1 + μ)(a_0 − g e_z)·e1 + l_s φ̇2² sin(φ2 − φ1)
/// l cos(φ1 − φ2) φ̈1 + l_s φ̈2         = −(a_0 − g e_z)·e2
/// ```
///
/// solved by Cramer's rule (the determinant `l l_s (1 + μ − cos²(φ1 − φ2))` is at least
/// `μ l l_s`).
#[must_use]
pub fn plant_rhs(
    p: &DoublePendulumParams,
    y: &SVector<f64, 8>,
    u: &SVector<f64, 2>,
) -> SVector<f64, 8> {
    let [_, l, p1, p2, vx, vl, w1, w2]: [f64; 8] = (*y).into();
    let [u1, u2]: [f64; 2] = (*u).into();
    let (mu, ls, g) = (p.hook_mass / p.crane.m, p.sling, p.crane.g);
    let ax = (u1 - vx) / p.crane.tau1;
    let al = (u2 - vl) / p.crane.tau2;
    let (s1, c1) = (libm::sin(p1), libm::cos(p1));
    let (s2, c2) = (libm::sin(p2), libm::cos(p2));
    // a_0 − g e_z.
    let a0x = ax + al * s1 + 2.0 * vl * w1 * c1 - l * w1 * w1 * s1;
    let a0z = al * c1 - 2.0 * vl * w1 * s1 - l * w1 * w1 * c1 - g;
    let dot = |e: (f64, f64)| a0x * e.0 + a0z * e.1;
    let (e1, e2) = ((c1, -s1), (c2, -s2));
    let cos12 = c1 * c2 + s1 * s2;
    let sin21 = s2 * c1 - c2 * s1;
    let (m11, m12) = ((1.0 + mu) * l, ls * cos12);
    let (m21, m22) = (l * cos12, ls);
    let r1 = -(1.0 + mu) * dot(e1) + ls * w2 * w2 * sin21;
    let r2 = -dot(e2);
    let det = m11 * m22 - m12 * m21;
    let acc1 = (r1 * m22 - m12 * r2) / det;
    let acc2 = (m11 * r2 - m21 * r1) / det;
    SVector::from([vx, vl, w1, w2, ax, al, acc1, acc2])
}

/// The load's position `C = [x + l sin φ1 + l_s sin φ2, l cos φ1 + l_s cos φ2]`.
#[must_use]
pub fn plant_output(p: &DoublePendulumParams, y: &SVector<f64, 8>) -> SVector<f64, 2> {
    let [x, l, p1, p2, _, _, _, _]: [f64; 8] = (*y).into();
    SVector::from([
        x + l * libm::sin(p1) + p.sling * libm::sin(p2),
        l * libm::cos(p1) + p.sling * libm::cos(p2),
    ])
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    /// f(t) = √(1 + t²)/(2 + t) at t = 0.7: the series' first four derivatives against
    /// the closed forms' central differences, and a product of the identity with itself.
    #[test]
    fn taylor_series_match_finite_differences() {
        let t = 0.7;
        let tj = Taylor::<6>::from_derivatives([t, 1.0, 0.0, 0.0, 0.0, 0.0]);
        let f = (Taylor::constant(1.0) + tj * tj).sqrt() / (Taylor::constant(2.0) + tj);
        let g = |t: f64| libm::sqrt(1.0 + t * t) / (2.0 + t);
        let h = 1e-2;
        let at = |k: f64| g(t + k * h);
        let fd1 = (at(1.0) - at(-1.0)) / (2.0 * h);
        let fd2 = (at(1.0) - 2.0 * at(0.0) + at(-1.0)) / (h * h);
        let fd3 = (at(2.0) - 2.0 * at(1.0) + 2.0 * at(-1.0) - at(-2.0)) / (2.0 * h.powi(3));
        let fd4 = (at(2.0) - 4.0 * at(1.0) + 6.0 * at(0.0) - 4.0 * at(-1.0) + at(-2.0)) / h.powi(4);
        assert!((f.value() - g(t)).abs() < 1e-15);
        for (k, fd, tol) in [
            (1, fd1, 1e-4),
            (2, fd2, 1e-4),
            (3, fd3, 1e-3),
            (4, fd4, 1e-2),
        ] {
            assert!(
                (f.derivative(k) - fd).abs() < tol * fd.abs().max(1.0),
                "order {k}: {} against {fd}",
                f.derivative(k)
            );
        }
        let square = tj * tj;
        assert_eq!(square.derivative(2), 2.0);
        assert_eq!(square.derivative(3), 0.0);
        assert_eq!(tj.dt().value(), 1.0);
    }
}
