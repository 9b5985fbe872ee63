//! The crane's exact inverse: it is differentially flat in the load position.
//!
//! Given `z_d = [x_C, z_C]` and its derivatives up to order 4 (5 for `u̇`), the load's
//! equations of motion fix the rope force per unit mass `λ = (z̈_C − g)/(2 z_C)`
//! and the trolley `x = x_C − ẍ_C z_C/(z̈_C − g)` (rows 3–4 of Eq. 25), the rope
//! constraint Eq. 26 fixes `l`, and the actuator rows of Eq. 25 give the inputs
//! `u1 = τ1 ẍ + ẋ`, `u2 = τ2 l̈ + l̇`. The derivatives of `x` and `l` come from
//! [`Jet`] arithmetic on the trajectory's exact derivatives, so `u_flat` is exact
//! to rounding: the reference of Eq. 29.

use nalgebra::SVector;

use crate::models::crane::CraneParams;
use crate::reference::jet::Jet;
use crate::trajectory::Trajectory;

/// The exact crane state and inputs that keep the load on the trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlatState {
    /// Trolley position x, m.
    pub x: f64,
    /// Rope length l, m.
    pub l: f64,
    /// Trolley velocity ẋ, m/s.
    pub vx: f64,
    /// Rope velocity l̇, m/s.
    pub vl: f64,
    /// Rope force per unit mass λ of Eq. 25, 1/s².
    pub lambda: f64,
    /// Swing angle φ, rad.
    pub phi: f64,
    /// Swing rate φ̇, rad/s.
    pub vphi: f64,
    /// `u_flat = [u1, u2]`: trolley and winch velocity set points, m/s.
    pub u: [f64; 2],
    /// `u̇_flat`: the set points' rates, m/s² (what the drives' acceleration limits bound).
    pub u_dot: [f64; 2],
}

impl FlatState {
    /// The state in the *subs* unknowns `[x, l, ẋ, l̇, λ, u1, u2]`.
    #[must_use]
    pub fn subs(&self) -> SVector<f64, 7> {
        let [u1, u2] = self.u;
        SVector::from([self.x, self.l, self.vx, self.vl, self.lambda, u1, u2])
    }

    /// The state in the *proj* unknowns `[x, l, φ, ẋ, l̇, φ̇, u1, u2]`.
    #[must_use]
    pub fn proj(&self) -> SVector<f64, 8> {
        let [u1, u2] = self.u;
        SVector::from([
            self.x, self.l, self.phi, self.vx, self.vl, self.vphi, u1, u2,
        ])
    }
}

/// `u_flat(t)` and the state that goes with it.
#[must_use]
pub fn flat_inverse<Z: Trajectory<f64, 2>>(p: &CraneParams, z: &Z, t: f64) -> FlatState {
    let [[xc, zc], [xc1, zc1], [xc2, zc2], [xc3, zc3], [xc4, zc4], [xc5, zc5]] =
        z.derivatives::<6>(t).map(<[f64; 2]>::from);
    let (xc, zc) = (Jet::new(xc, xc1, xc2, xc3), Jet::new(zc, zc1, zc2, zc3));
    let (xcdd, zcdd) = (Jet::new(xc2, xc3, xc4, xc5), Jet::new(zc2, zc3, zc4, zc5));
    let g = Jet::constant(p.g);
    let x = xc - xcdd * zc / (zcdd - g);
    let dx = xc - x;
    let l = (zc * zc + dx * dx).sqrt();
    let r2 = dx.v * dx.v + zc.v * zc.v;
    FlatState {
        x: x.v,
        l: l.v,
        vx: x.d1,
        vl: l.d1,
        lambda: (zcdd.v - p.g) / (2.0 * zc.v),
        phi: libm::atan2(dx.v, zc.v),
        vphi: (dx.d1 * zc.v - dx.v * zc.d1) / r2,
        u: [p.tau1 * x.d2 + x.d1, p.tau2 * l.d2 + l.d1],
        u_dot: [p.tau1 * x.d3 + x.d2, p.tau2 * l.d3 + l.d2],
    }
}

/// The exact solution in the *ext* unknowns
/// (`[x, l, v_x, v_l, λ, u1, u2, x', l', μ, a_x, a_l, ν]`,
/// [`CraneExt`](crate::models::crane_ext::CraneExt)): [`flat_inverse`]'s state with the
/// dummies of the minimal extension, `x' = ẋ`, `l' = l̇`, `μ = λ̇`, `a_x = ẍ`, `a_l = l̈`,
/// `ν = λ̈`, by the same [`Jet`] arithmetic (`λ` as a jet of its own). What the
/// extended residual vanishes on along the move.
#[must_use]
pub fn extended_state<Z: Trajectory<f64, 2>>(p: &CraneParams, z: &Z, t: f64) -> SVector<f64, 13> {
    let [[xc, zc], [xc1, zc1], [xc2, zc2], [xc3, zc3], [xc4, zc4], [xc5, zc5]] =
        z.derivatives::<6>(t).map(<[f64; 2]>::from);
    let (xc, zc) = (Jet::new(xc, xc1, xc2, xc3), Jet::new(zc, zc1, zc2, zc3));
    let (xcdd, zcdd) = (Jet::new(xc2, xc3, xc4, xc5), Jet::new(zc2, zc3, zc4, zc5));
    let g = Jet::constant(p.g);
    let x = xc - xcdd * zc / (zcdd - g);
    let dx = xc - x;
    let l = (zc * zc + dx * dx).sqrt();
    let lambda = (zcdd - g) / (Jet::constant(2.0) * zc);
    SVector::from([
        x.v,
        l.v,
        x.d1,
        l.d1,
        lambda.v,
        p.tau1 * x.d2 + x.d1,
        p.tau2 * l.d2 + l.d1,
        x.d1,
        l.d1,
        lambda.d1,
        x.d2,
        l.d2,
        lambda.d2,
    ])
}
