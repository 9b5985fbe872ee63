//! The 3D crane's exact inverse: it is differentially flat in the load position, as the
//! planar crane is ([`flat_crane`](super::flat_crane)).
//!
//! Given `z_d = [x_C, y_C, z_C]` and its derivatives up to order 4 (5 for `u̇`), the
//! load's equations (rows F7–F9 of [`Crane3dSubs`](crate::models::crane3d::Crane3dSubs))
//! fix the rope force per unit mass `λ = (z̈_C − g)/(2 z_C)`, the bridge
//! `x = x_C − ẍ_C/(2λ) = x_C − ẍ_C z_C/(z̈_C − g)` and the trolley
//! `y = y_C − ÿ_C z_C/(z̈_C − g)`; the rope constraint F10 fixes `l`, and the drives'
//! rows F4–F6 give the inputs `u_i = τ_i q̈_i + q̇_i` for `q = (x, y, l)`. The
//! derivatives of `x`, `y` and `l` come from [`Jet`] arithmetic on the trajectory's
//! exact derivatives, so `u_flat` is exact to rounding: the reference of Eq. 29
//! ([`e_max`]).

use nalgebra::SVector;

use crate::models::crane3d::Crane3dParams;
use crate::reference::emax::{self, Emax};
use crate::reference::jet::Jet;
use crate::trajectory::Trajectory;

/// The exact 3D crane state and inputs that keep the load on the trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlatState3d {
    /// Bridge position x, m.
    pub x: f64,
    /// Trolley position y, m.
    pub y: f64,
    /// Rope length l, m.
    pub l: f64,
    /// Bridge velocity ẋ, m/s.
    pub vx: f64,
    /// Trolley velocity ẏ, m/s.
    pub vy: f64,
    /// Rope velocity l̇, m/s.
    pub vl: f64,
    /// Accelerations `[ẍ, ÿ, l̈]`, m/s² (the drives' rows' `v̇`).
    pub a: [f64; 3],
    /// Rope force per unit mass λ, 1/s² (negative: tension).
    pub lambda: f64,
    /// Its rate λ̇, 1/s³.
    pub lambda_dot: f64,
    /// The rope's slopes `[atan2(x_C − x, z_C), atan2(y_C − y, z_C)]` in the x–z and
    /// y–z planes, rad (what a two-axis inclinometer on the rope reports).
    pub slope: [f64; 2],
    /// The slopes' rates, rad/s.
    pub slope_rate: [f64; 2],
    /// `u_flat = [u1, u2, u3]`: bridge, trolley and hoist velocity set points, m/s.
    pub u: [f64; 3],
    /// `u̇_flat`: the set points' rates, m/s² (what the drives' acceleration limits bound).
    pub u_dot: [f64; 3],
}

impl FlatState3d {
    /// The state in the *subs* unknowns `[x, y, l, v_x, v_y, v_l, λ, u1, u2, u3]`.
    #[must_use]
    pub fn subs(&self) -> SVector<f64, 10> {
        let [u1, u2, u3] = self.u;
        SVector::from([
            self.x,
            self.y,
            self.l,
            self.vx,
            self.vy,
            self.vl,
            self.lambda,
            u1,
            u2,
            u3,
        ])
    }

    /// Its time derivative: `ẋ` in the *subs* unknowns, with which the residual of
    /// [`Crane3dSubs`](crate::models::crane3d::Crane3dSubs) vanishes along the move.
    #[must_use]
    pub fn subs_dot(&self) -> SVector<f64, 10> {
        let [ax, ay, al] = self.a;
        let [u1, u2, u3] = self.u_dot;
        SVector::from([
            self.vx,
            self.vy,
            self.vl,
            ax,
            ay,
            al,
            self.lambda_dot,
            u1,
            u2,
            u3,
        ])
    }
}

/// `u_flat(t)` and the state that goes with it.
#[must_use]
pub fn flat_inverse<Z: Trajectory<f64, 3>>(p: &Crane3dParams, z: &Z, t: f64) -> FlatState3d {
    let [[xc, yc, zc], [xc1, yc1, zc1], [xc2, yc2, zc2], [xc3, yc3, zc3], [xc4, yc4, zc4], [xc5, yc5, zc5]] =
        z.derivatives::<6>(t).map(<[f64; 3]>::from);
    let (xc, yc, zc) = (
        Jet::new(xc, xc1, xc2, xc3),
        Jet::new(yc, yc1, yc2, yc3),
        Jet::new(zc, zc1, zc2, zc3),
    );
    let (xcdd, ycdd, zcdd) = (
        Jet::new(xc2, xc3, xc4, xc5),
        Jet::new(yc2, yc3, yc4, yc5),
        Jet::new(zc2, zc3, zc4, zc5),
    );
    let g = Jet::constant(p.g);
    // 1/(2λ) = z_C/(z̈_C − g); the operations of the planar reference, in its order.
    let x = xc - xcdd * zc / (zcdd - g);
    let y = yc - ycdd * zc / (zcdd - g);
    let (dx, dy) = (xc - x, yc - y);
    let l = (dx * dx + dy * dy + zc * zc).sqrt();
    let lambda = (zcdd - g) / (Jet::constant(2.0) * zc);
    // d/dt atan2(d, z_C) = (ḋ z_C − d ż_C)/(d² + z_C²).
    let rate = |d: Jet| (d.d1 * zc.v - d.v * zc.d1) / (d.v * d.v + zc.v * zc.v);
    FlatState3d {
        x: x.v,
        y: y.v,
        l: l.v,
        vx: x.d1,
        vy: y.d1,
        vl: l.d1,
        a: [x.d2, y.d2, l.d2],
        lambda: lambda.v,
        lambda_dot: lambda.d1,
        slope: [libm::atan2(dx.v, zc.v), libm::atan2(dy.v, zc.v)],
        slope_rate: [rate(dx), rate(dy)],
        u: [
            p.tau1 * x.d2 + x.d1,
            p.tau2 * y.d2 + y.d1,
            p.tau3 * l.d2 + l.d1,
        ],
        u_dot: [
            p.tau1 * x.d3 + x.d2,
            p.tau2 * y.d3 + y.d2,
            p.tau3 * l.d3 + l.d2,
        ],
    }
}

/// The exact solution in the 3D *ext* unknowns
/// (`[x, y, l, v_x, v_y, v_l, λ, u1, u2, u3, x', y', l', μ, a_x, a_y, a_l, ν]`,
/// [`Crane3dExt`](crate::models::crane3d::Crane3dExt)): [`flat_inverse`]'s state with the
/// dummies of the minimal extension, `q' = q̇`, `μ = λ̇`, `a = q̈`, `ν = λ̈`, by the same
/// [`Jet`] arithmetic. What the extended residual vanishes on along the move.
#[must_use]
pub fn extended_state<Z: Trajectory<f64, 3>>(p: &Crane3dParams, z: &Z, t: f64) -> SVector<f64, 18> {
    let [[xc, yc, zc], [xc1, yc1, zc1], [xc2, yc2, zc2], [xc3, yc3, zc3], [xc4, yc4, zc4], [xc5, yc5, zc5]] =
        z.derivatives::<6>(t).map(<[f64; 3]>::from);
    let jet = |v, d1, d2, d3| Jet::new(v, d1, d2, d3);
    let (xc, yc, zc) = (
        jet(xc, xc1, xc2, xc3),
        jet(yc, yc1, yc2, yc3),
        jet(zc, zc1, zc2, zc3),
    );
    let (xcdd, ycdd, zcdd) = (
        jet(xc2, xc3, xc4, xc5),
        jet(yc2, yc3, yc4, yc5),
        jet(zc2, zc3, zc4, zc5),
    );
    let g = Jet::constant(p.g);
    let x = xc - xcdd * zc / (zcdd - g);
    let y = yc - ycdd * zc / (zcdd - g);
    let (dx, dy) = (xc - x, yc - y);
    let l = (dx * dx + dy * dy + zc * zc).sqrt();
    let lambda = (zcdd - g) / (Jet::constant(2.0) * zc);
    SVector::from([
        x.v,
        y.v,
        l.v,
        x.d1,
        y.d1,
        l.d1,
        lambda.v,
        p.tau1 * x.d2 + x.d1,
        p.tau2 * y.d2 + y.d1,
        p.tau3 * l.d2 + l.d1,
        x.d1,
        y.d1,
        l.d1,
        lambda.d1,
        x.d2,
        y.d2,
        l.d2,
        lambda.d2,
    ])
}

/// One sample's error of Eq. 29, `max_i |u_i − u_flat,i(t)|` (NaN if `u` is).
#[must_use]
pub fn input_error<Z: Trajectory<f64, 3>>(
    p: &Crane3dParams,
    z: &Z,
    t: f64,
    u: &SVector<f64, 3>,
) -> f64 {
    emax::input_error(u, &flat_inverse(p, z, t).u)
}

/// Eq. 29 over a run's samples `(t, u(t))`, globally and over the interior `[a, b]`.
pub fn e_max<Z, I>(p: &Crane3dParams, z: &Z, samples: I, (a, b): (f64, f64)) -> Emax
where
    Z: Trajectory<f64, 3>,
    I: IntoIterator<Item = (f64, SVector<f64, 3>)>,
{
    let mut e = Emax::over(a, b);
    for (t, u) in samples {
        e.add(t, input_error(p, z, t, &u));
    }
    e
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::model::DaeModel;
    use crate::models::crane::CraneParams;
    use crate::models::crane3d::Crane3dSubs;
    use crate::reference::flat_crane;
    use crate::trajectory::PointToPoint;

    fn diagonal_move() -> PointToPoint<f64, 3> {
        PointToPoint::new(
            SVector::from([12.0, 3.0, 8.0]),
            SVector::from([20.0, 6.0, 4.0]),
            1.0,
            7.0,
            4,
        )
        .unwrap()
    }

    /// The flat state and its derivative satisfy the *subs* residual to rounding at every
    /// millisecond of the diagonal move with hoisting (and at rest around it): each row
    /// within 1e-12 (a few ε of the Jet chain) of the size of what it subtracts — for
    /// F7 and F8 that includes `2|λ|(|x_C| + |x|)`, since `x_C − x` is a difference of
    /// two ~15 m numbers.
    #[test]
    fn flat_state_satisfies_the_residual_along_a_3d_move() {
        let p = Crane3dParams::EXAMPLE;
        let z = diagonal_move();
        let model = Crane3dSubs::<f64, _>::new(p, z).unwrap();
        for i in 0..=9000 {
            let t = f64::from(i) * 1e-3;
            let flat = flat_inverse(&p, &z, t);
            let (x, xdot) = (flat.subs(), flat.subs_dot());
            let s = model.sample(t);
            let r = model.residual(&x, &xdot, &s);
            // The size of each row's terms.
            let [[xc, yc, zc], _, [xcdd, ycdd, zcdd]] = s.map(<[f64; 3]>::from);
            let (dx, dy) = (xc - flat.x, yc - flat.y);
            let size = [
                flat.vx.abs(),
                flat.vy.abs(),
                flat.vl.abs(),
                flat.u[0].abs() + flat.vx.abs(),
                flat.u[1].abs() + flat.vy.abs(),
                flat.u[2].abs() + flat.vl.abs(),
                xcdd.abs() + (2.0 * flat.lambda).abs() * (xc.abs() + flat.x.abs()),
                ycdd.abs() + (2.0 * flat.lambda).abs() * (yc.abs() + flat.y.abs()),
                zcdd.abs() + p.g + (2.0 * zc * flat.lambda).abs(),
                dx * dx + dy * dy + zc * zc + flat.l * flat.l,
            ];
            for (ri, si) in r.iter().zip(size) {
                assert!(ri.abs() <= 1e-12 * si, "t = {t}: residual {r}");
            }
        }
    }

    /// λ̇ and the slopes' rates against central differences of λ and the slopes.
    #[test]
    fn rates_match_finite_differences() {
        let (p, z) = (Crane3dParams::EXAMPLE, diagonal_move());
        for t in [2.0, 3.8, 5.5, 7.2] {
            let e = 1e-5;
            let (lo, mid, hi) = (
                flat_inverse(&p, &z, t - e),
                flat_inverse(&p, &z, t),
                flat_inverse(&p, &z, t + e),
            );
            let fd = |a: f64, b: f64| (b - a) / (2.0 * e);
            assert!((fd(lo.lambda, hi.lambda) - mid.lambda_dot).abs() < 1e-8);
            for k in 0..2 {
                let (a, b) = (lo.slope.get(k).unwrap(), hi.slope.get(k).unwrap());
                let rate = mid.slope_rate.get(k).unwrap();
                assert!((fd(*a, *b) - rate).abs() < 1e-8, "t = {t}, slope {k}");
            }
            for k in 0..3 {
                let (a, b) = (lo.u.get(k).unwrap(), hi.u.get(k).unwrap());
                let rate = mid.u_dot.get(k).unwrap();
                assert!((fd(*a, *b) - rate).abs() < 1e-7, "t = {t}, u̇{}", k + 1);
            }
        }
    }

    /// With `y_C` constant the 3D reference is the planar one: bridge ≙ planar trolley
    /// (τ1), hoist ≙ planar winch (planar τ2 = τ3 here), no trolley motion. Same
    /// operations on the same numbers except the extra `+ dy² = + 0` in `l`, so equal to
    /// a few ε.
    #[test]
    fn planar_move_gives_the_planar_reference() {
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
        for i in 0..=1000 {
            let t = f64::from(i) * 0.01;
            let (a, b) = (
                flat_inverse(&p, &z3, t),
                flat_crane::flat_inverse(&planar, &z2, t),
            );
            assert_eq!((a.x, a.y, a.vy), (b.x, 4.0, 0.0));
            assert_eq!(a.lambda, b.lambda);
            let [u1, u2, u3] = a.u;
            let [v1, v2] = b.u;
            assert_eq!(u2, 0.0);
            assert!(
                (u1 - v1).abs() <= 1e-15 && (u3 - v2).abs() <= 1e-15,
                "t = {t}"
            );
            assert!((a.l - b.l).abs() <= 1e-14);
        }
    }

    #[test]
    fn e_max_of_the_reference_itself_is_zero() {
        let (p, z) = (Crane3dParams::EXAMPLE, diagonal_move());
        let samples = (0..=90).map(|i| {
            let t = f64::from(i) * 0.1;
            (t, SVector::from(flat_inverse(&p, &z, t).u))
        });
        let e = e_max(&p, &z, samples, (2.0, 7.0));
        assert_eq!((e.global, e.interior), (0.0, 0.0));
        let off = e_max(
            &p,
            &z,
            [(
                4.0,
                SVector::from(flat_inverse(&p, &z, 4.0).u) + SVector::from([0.0, 1e-3, 0.0]),
            )],
            (2.0, 7.0),
        );
        assert!((off.interior - 1e-3).abs() < 1e-15);
    }
}
