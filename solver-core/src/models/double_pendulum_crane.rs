//! The hook-and-load double pendulum crane: what its formulations and its reference
//! share — the parameters, the exact flat inverse at one instant, and the check of a
//! load path.
//!
//! The planar crane of Eqs. 24–28 (trolley `x` and rope `l` through first-order drives,
//! τ1, τ2) carries at the rope's end a hook block `H = [x_H, z_H]` of mass `m_h`, and
//! below it, on a sling of fixed length `l_s`, the load `C = [x_C, z_C]` of mass `m`; `z`
//! points down from the rail, gravity is `+g e_z`. Its formulations are *subs*
//! ([`double_pendulum`](super::double_pendulum), index 5) and *ext*
//! ([`double_pendulum_ext`](super::double_pendulum_ext), index 1); the reference
//! ([`reference::double_pendulum`](crate::reference::double_pendulum)) measures them
//! against the flat inverse below and simulates the plant forward.
//!
//! **Why the flat inverse is here.** Both formulations check a load path before they
//! run ([`check_trajectory`]), and the tension margins of the rope depend on the hook's
//! acceleration, which only the exact flat inverse gives; so the inverse sits below both
//! formulations and below the reference, and nothing here imports either of them.
//!
//! **Flat inverse.** The load's position `C = [x_C, z_C]` is a flat output
//! ([`DoublePendulumSubs`](super::double_pendulum::DoublePendulumSubs) writes the
//! equations; everything per unit load mass, `μ` the hook's mass over the load's):
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
//! derivatives, so the inverse is exact to rounding.

use nalgebra::SVector;

use crate::error::{check_positive, Error, Result};
use crate::models::crane::{CraneParams, Workspace, CHECK_SAMPLES};
use crate::scalar::{c, to_f64, Real};
use crate::trajectory::Trajectory;

/// The realistic range of the hook's mass as a fraction of the load's (10–100 %).
pub const HOOK_MASS_RATIO: (f64, f64) = (0.1, 1.0);
/// The realistic range of the sling's length, m.
pub const SLING_LENGTH: (f64, f64) = (0.5, 2.0);

/// The double pendulum's parameters: the planar crane's and the hook and sling.
///
/// With feature `serde`, a hook-and-load scene's `[model]`: `hook_mass`, `sling`, the crane
/// in `[model.crane]` and its workspace in `[model.crane.workspace]` (a key left out:
/// [`DoublePendulumParams::EXAMPLE`]'s value — the scene lays its keys over it, since the
/// nested types' own defaults are the paper crane's, whose rope is longer).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields, default)
)]
pub struct DoublePendulumParams {
    /// The crane: load mass, gravity, drive lags, workspace (its rope limits bound `l`,
    /// the rope to the hook), and the tension margin both ropes must keep.
    pub crane: CraneParams,
    /// The hook block's mass m_h, kg.
    pub hook_mass: f64,
    /// The sling's length l_s, m.
    pub sling: f64,
}

/// The example: what a hook-and-load scene that sets no parameter gets.
impl Default for DoublePendulumParams {
    fn default() -> Self {
        Self::EXAMPLE
    }
}

impl DoublePendulumParams {
    /// Tab. 3's crane with a hook block of 30 % of the load's mass on a 1 m sling; the
    /// rope's shortest length lowered from 3 m to 1.5 m, since the hook hangs `l_s` above
    /// the load (the paper's move ends with the load 4 m below the rail: a 2 m sling
    /// leaves a 2 m rope).
    pub const EXAMPLE: Self = Self {
        crane: CraneParams {
            workspace: Workspace {
                l_min: 1.5,
                ..Workspace::PAPER
            },
            ..CraneParams::PAPER
        },
        hook_mass: 0.3 * CraneParams::PAPER.m,
        sling: 1.0,
    };

    /// The example with another hook mass ratio `m_h/m` and sling length.
    #[must_use]
    pub fn with(self, hook_mass_ratio: f64, sling: f64) -> Self {
        Self {
            hook_mass: hook_mass_ratio * self.crane.m,
            sling,
            ..self
        }
    }

    /// Refuses non-finite or non-physical values (any positive hook mass and sling: the
    /// realistic ranges [`HOOK_MASS_RATIO`], [`SLING_LENGTH`] are what the studies sweep,
    /// and the light-hook limit is tested below them).
    pub fn validate(&self) -> Result<()> {
        self.crane.validate()?;
        check_positive("hook_mass", self.hook_mass)?;
        check_positive("sling", self.sling)
    }
}

/// Checks a load path against both ropes' tension margins, the hook below the rail and
/// the workspace, at [`CHECK_SAMPLES`]` + 1` points of its active span, with the exact
/// flat inverse: the sling stays taut while the load's downward acceleration is below
/// `(1 − f) g` ([`Error::RopeSlack`] with it), the rope while the two masses' mean
/// downward acceleration `(z̈_C + μ z̈_H)/(1 + μ)` is ([`Error::RopeSlack`] with that mean);
/// `z_C`, `z_H` must be positive and `x`, `l` within the workspace
/// ([`Error::OutsideWorkspace`] naming `z_C`, `z_H`, `x` or `l`).
pub fn check_trajectory<T: Real, Z: Trajectory<T, 2>>(
    p: &DoublePendulumParams,
    z: &Z,
) -> Result<()> {
    let (t0, t1) = z.active_span();
    let limit = p.crane.g * (1.0 - p.crane.min_tension_fraction);
    let mu = p.hook_mass / p.crane.m;
    let w = &p.crane.workspace;
    for i in 0..=CHECK_SAMPLES {
        let t = t0 + (t1 - t0) * c::<T>(i as f64 / CHECK_SAMPLES as f64);
        let tf = to_f64(t);
        let d = z.derivatives::<8>(t).map(|v| v.map(to_f64));
        let [[_, zc], _, [_, zcdd], ..] = d.map(<[f64; 2]>::from);
        let slack = |acc: f64| {
            (acc.is_nan() || acc > limit).then_some(Error::RopeSlack {
                t: tf,
                vertical_acceleration: acc,
                limit,
            })
        };
        if let Some(e) = slack(zcdd) {
            return Err(e);
        }
        let flat = flat_state(p, &d, tf)?;
        let [_, zh] = flat.hook;
        let [_, zhdd] = flat.a_hook;
        if let Some(e) = slack((zcdd + mu * zhdd) / (1.0 + mu)) {
            return Err(e);
        }
        for (coordinate, value, min, max) in [
            ("z_C", zc, f64::MIN_POSITIVE, f64::INFINITY),
            ("z_H", zh, f64::MIN_POSITIVE, f64::INFINITY),
            ("x", flat.x, w.x_min, w.x_max),
            ("l", flat.l, w.l_min, w.l_max),
        ] {
            if !(min..=max).contains(&value) {
                return Err(Error::OutsideWorkspace {
                    t: tf,
                    coordinate,
                    value,
                    min,
                    max,
                });
            }
        }
    }
    Ok(())
}

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

    /// The plant's state `[x, l, φ1, φ2, ẋ, l̇, φ̇1, φ̇2]`
    /// ([`plant_rhs`](crate::reference::double_pendulum::plant_rhs)).
    #[must_use]
    pub fn plant_state(&self) -> SVector<f64, 8> {
        let ([vx, vl], [p1, p2], [w1, w2]) = (self.v, self.angle, self.angle_rate);
        SVector::from([self.x, self.l, p1, p2, vx, vl, w1, w2])
    }
}

/// The flat inverse's Taylor series at one instant: the load, the hook, both forces, the
/// trolley and the rope (see the module's comment).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FlatSeries {
    pub(crate) xc: Taylor<L>,
    pub(crate) zc: Taylor<L>,
    pub(crate) azc: Taylor<L>,
    pub(crate) xh: Taylor<L>,
    pub(crate) zh: Taylor<L>,
    pub(crate) azh: Taylor<L>,
    pub(crate) lambda1: Taylor<L>,
    pub(crate) lambda2: Taylor<L>,
    pub(crate) x: Taylor<L>,
    pub(crate) dx: Taylor<L>,
    pub(crate) l: Taylor<L>,
}

/// The series of [`FlatSeries`] from the load path's derivatives `[z, ż, …, z^(7)]`.
pub(crate) fn flat_series(p: &DoublePendulumParams, d: &[SVector<f64, 2>; 8]) -> FlatSeries {
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
/// parameter or path, [`Error::NonFinite`]). The formulations' check
/// ([`check_trajectory`]) keeps margins to these.
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
