//! Forward simulations of the plants, driven by a computed input.
//!
//! The paper's check on an inverse model (Sec. 2.3): apply the input it computed to
//! the forward dynamics and see whether the output follows the desired trajectory.
//! The input samples `u_n` at `t_n = t0 + n h` are joined by piecewise-cubic
//! Lagrange interpolation (error `O(h⁴)`, far below a zero-order hold's `O(h)`), and
//! the plant is integrated sample interval by sample interval with [`Dopri5`].

use nalgebra::SVector;

use crate::error::Result;
use crate::models::crane::CraneParams;
use crate::models::mass_on_car::MassOnCarParams;
use crate::reference::dopri5::{Dopri5, Dopri5Settings};

/// Eqs. 21–22 solved for `ẏ, v̇`: state `[x, l, φ, ẋ, l̇, φ̇]`, input `[u1, u2]`.
#[must_use]
pub fn crane_rhs(p: &CraneParams, y: &SVector<f64, 6>, u: &SVector<f64, 2>) -> SVector<f64, 6> {
    let [_, l, phi, vx, vl, vphi]: [f64; 6] = (*y).into();
    let [u1, u2]: [f64; 2] = (*u).into();
    let ax = (u1 - vx) / p.tau1;
    let al = (u2 - vl) / p.tau2;
    let (sin, cos) = (libm::sin(phi), libm::cos(phi));
    let aphi = (-p.g * sin - 2.0 * vphi * vl - cos * ax) / l;
    SVector::from([vx, vl, vphi, ax, al, aphi])
}

/// Eq. 27: the load position `[x + l sin φ, l cos φ]`.
#[must_use]
pub fn crane_output(y: &SVector<f64, 6>) -> SVector<f64, 2> {
    let [x, l, phi, _, _, _]: [f64; 6] = (*y).into();
    SVector::from([x + l * libm::sin(phi), l * libm::cos(phi)])
}

/// Eqs. 31–32 solved for `ẏ, v̇`: state `[x, s, ẋ, ṡ]`, input `[F]`.
#[must_use]
pub fn mass_on_car_rhs(
    p: &MassOnCarParams,
    y: &SVector<f64, 4>,
    u: &SVector<f64, 1>,
) -> SVector<f64, 4> {
    let [_, s, vx, vs]: [f64; 4] = (*y).into();
    let [f]: [f64; 1] = (*u).into();
    let cos = libm::cos(p.alpha);
    // [[m1 + m2, m2 cos α], [m2 cos α, m2]] v̇ = [F, −(k s + d ṡ)], by Cramer's rule.
    let (a, b, d) = (p.m1 + p.m2, p.m2 * cos, p.m2);
    let (r1, r2) = (f, -(p.k * s + p.d * vs));
    let det = a * d - b * b;
    SVector::from([vx, vs, (r1 * d - b * r2) / det, (a * r2 - b * r1) / det])
}

/// Eq. 33: `z = x + s cos α`.
#[must_use]
pub fn mass_on_car_output(p: &MassOnCarParams, y: &SVector<f64, 4>) -> f64 {
    let [x, s, _, _]: [f64; 4] = (*y).into();
    x + s * libm::cos(p.alpha)
}

/// Input samples every `h` from `t0`, joined by piecewise-cubic interpolation.
#[derive(Debug, Clone, Copy)]
pub struct SampledInput<'a, const NU: usize> {
    t0: f64,
    h: f64,
    samples: &'a [SVector<f64, NU>],
}

impl<'a, const NU: usize> SampledInput<'a, NU> {
    /// `samples[n]` is the input at `t0 + n h`.
    #[must_use]
    pub fn new(t0: f64, h: f64, samples: &'a [SVector<f64, NU>]) -> Self {
        Self { t0, h, samples }
    }

    /// Time of the last sample.
    #[must_use]
    pub fn t_end(&self) -> f64 {
        self.t0 + self.h * self.samples.len().saturating_sub(1) as f64
    }

    /// The interpolated input at `t` (held constant outside the samples).
    #[must_use]
    pub fn at(&self, t: f64) -> SVector<f64, NU> {
        let n = self.samples.len();
        if n < 4 {
            return self.samples.first().copied().unwrap_or_else(SVector::zeros);
        }
        let pos = ((t - self.t0) / self.h).clamp(0.0, (n - 1) as f64);
        // The four samples around pos: i−1, i, i+1, i+2 (shifted inside at the ends).
        let i = (libm::floor(pos) as usize).clamp(1, n - 3);
        let s = pos - i as f64;
        let nodes = [-1.0, 0.0, 1.0, 2.0];
        let mut u = SVector::zeros();
        for (k, (node, sample)) in nodes
            .iter()
            .zip(self.samples.iter().skip(i - 1))
            .enumerate()
        {
            let w = nodes
                .iter()
                .enumerate()
                .filter(|&(m, _)| m != k)
                .fold(1.0, |acc, (_, nm)| acc * (s - nm) / (node - nm));
            u += sample * w;
        }
        u
    }
}

/// Integrates `ẏ = rhs(y, u(t))` from `y0` across every sample interval of `input`,
/// calling `each(n, t_n, y(t_n))` at each sample time.
pub fn simulate<const D: usize, const NU: usize>(
    rhs: impl Fn(&SVector<f64, D>, &SVector<f64, NU>) -> SVector<f64, D>,
    y0: SVector<f64, D>,
    input: &SampledInput<'_, NU>,
    mut each: impl FnMut(usize, f64, &SVector<f64, D>),
) -> Result<()> {
    let mut ode = Dopri5::new(
        input.t0,
        y0,
        input.h / 4.0,
        Dopri5Settings {
            rtol: 1e-11,
            atol: 1e-13,
            max_steps: 100_000,
        },
    );
    each(0, input.t0, &y0);
    let mut f = |t: f64, y: &SVector<f64, D>| rhs(y, &input.at(t));
    for n in 1..input.samples.len() {
        let t = input.t0 + input.h * n as f64;
        let y = ode.advance_to(t, &mut f)?;
        each(n, t, &y);
    }
    Ok(())
}
