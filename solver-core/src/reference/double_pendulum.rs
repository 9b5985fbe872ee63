//! The hook-and-load double pendulum's exact inverse along a load path, Eq. 29 against
//! it, and its forward plant.
//!
//! **Flat inverse.** The load's position is a flat output; the inverse at one instant,
//! from the load path's derivatives, is [`flat_state`]
//! ([`double_pendulum_crane`](crate::models::double_pendulum_crane) derives it, since the
//! formulations' checks need it too). Here it is taken along a trajectory
//! ([`flat_inverse`]), in the unknowns of the minimally extended formulation
//! ([`extended_state`]), and as the reference of Eq. 29 ([`input_error`], [`e_max`]).
//!
//! **Plant.** The same crane in minimal coordinates for the forward check of Sec. 2.3:
//! trolley `x` and rope `l` through their first-order drives, the rope's angle `φ1` and
//! the sling's `φ2` from the vertical, `H = [x + l sin φ1, l cos φ1]`,
//! `C = H + l_s [sin φ2, cos φ2]`; d'Alembert's principle along `φ1` and `φ2` gives two
//! linear equations for `φ̈1, φ̈2` ([`plant_rhs`]).

use nalgebra::SVector;

use crate::error::Result;
use crate::models::double_pendulum_crane::{flat_series, DoublePendulumParams, FlatSeries};
use crate::reference::emax::{self, Emax};
use crate::trajectory::Trajectory;

pub use crate::models::double_pendulum_crane::{flat_state, FlatDoublePendulum, Taylor};

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
