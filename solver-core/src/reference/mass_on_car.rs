//! The mass-on-car reference: internal dynamics (Eq. 38), input (Eq. 37), zero
//! dynamics and the breakaway angle (Eq. 39).
//!
//! In the coordinates `[z, s]` the output is prescribed and what remains is the
//! internal dynamics `m2 sin²α s̈ + d ṡ + k s = −z̈_d m2 cos α` (Eq. 38), driven by
//! the trajectory and invisible in the output. Integrated from rest by
//! [`Dopri5`] at tight tolerance it gives `s_d`, and Eq. 37 the exact input
//! `F_d = (a/sin²α) z̈_d + m1 cos α/(m2 sin²α) (k s_d + d ṡ_d)`, `a = m1 + m2 sin²α`.

use nalgebra::{Complex, SVector};

use crate::error::Result;
use crate::models::mass_on_car::MassOnCarParams;
use crate::reference::dopri5::{Dopri5, Dopri5Settings};
use crate::trajectory::{ensure_at_rest, Trajectory};

/// The reference at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassOnCarSample {
    /// Time, s.
    pub t: f64,
    /// Internal coordinate `s_d`, m.
    pub s: f64,
    /// Its rate `ṡ_d`, m/s.
    pub sdot: f64,
    /// The exact input `F_d` of Eq. 37, N.
    pub f: f64,
}

/// Eq. 38 integrated along a trajectory, sampled where the caller asks.
#[derive(Debug, Clone)]
pub struct MassOnCarReference<Z> {
    p: MassOnCarParams,
    sin2: f64,
    cos: f64,
    trajectory: Z,
    ode: Dopri5<2>,
}

impl<Z: Trajectory<f64, 1>> MassOnCarReference<Z> {
    /// Starts at rest (`s = ṡ = 0`) at `t0`, where the trajectory must rest.
    pub fn new(
        p: MassOnCarParams,
        trajectory: Z,
        t0: f64,
        settings: Dopri5Settings,
    ) -> Result<Self> {
        p.validate()?;
        ensure_at_rest(&trajectory, t0)?;
        let sin = libm::sin(p.alpha);
        Ok(Self {
            p,
            sin2: sin * sin,
            cos: libm::cos(p.alpha),
            trajectory,
            ode: Dopri5::new(t0, SVector::zeros(), 1e-3, settings),
        })
    }

    /// Integrates Eq. 38 on to `t` and evaluates Eq. 37 there.
    pub fn advance_to(&mut self, t: f64) -> Result<MassOnCarSample> {
        let (p, sin2, cos, z) = (self.p, self.sin2, self.cos, &self.trajectory);
        let mut rhs = |t: f64, y: &SVector<f64, 2>| {
            let [s, sdot]: [f64; 2] = (*y).into();
            let [_, _, [zdd]] = z.derivatives::<3>(t).map(<[f64; 1]>::from);
            SVector::<f64, 2>::new(
                sdot,
                -(p.d * sdot + p.k * s + zdd * p.m2 * cos) / (p.m2 * sin2),
            )
        };
        let [s, sdot]: [f64; 2] = self.ode.advance_to(t, &mut rhs)?.into();
        let [_, _, [zdd]] = self.trajectory.derivatives::<3>(t).map(<[f64; 1]>::from);
        let a = p.m1 + p.m2 * sin2;
        let f = a / sin2 * zdd + p.m1 * cos / (p.m2 * sin2) * (p.k * s + p.d * sdot);
        Ok(MassOnCarSample { t, s, sdot, f })
    }
}

/// Eigenvalues of the zero dynamics (Eq. 38 with `z_d ≡ 0`): the roots of
/// `m2 sin²α λ² + d λ + k = 0`. Purely imaginary for `d = 0` (Fig. 10).
#[must_use]
pub fn zero_dynamics_eigenvalues(p: &MassOnCarParams) -> [Complex<f64>; 2] {
    let sin = libm::sin(p.alpha);
    let a = p.m2 * sin * sin;
    let disc = p.d * p.d - 4.0 * a * p.k;
    let re = -p.d / (2.0 * a);
    if disc >= 0.0 {
        let r = libm::sqrt(disc) / (2.0 * a);
        [Complex::new(re + r, 0.0), Complex::new(re - r, 0.0)]
    } else {
        let im = libm::sqrt(-disc) / (2.0 * a);
        [Complex::new(re, im), Complex::new(re, -im)]
    }
}

/// The breakaway angle α̂ of Eq. 39, where the eigenvalues turn from real to complex;
/// `None` when `d ≥ 2√(k m2)` (they stay real for every α).
#[must_use]
pub fn breakaway_angle(p: &MassOnCarParams) -> Option<f64> {
    let ratio = p.d / (2.0 * libm::sqrt(p.k * p.m2));
    (0.0..=1.0).contains(&ratio).then(|| libm::asin(ratio))
}
