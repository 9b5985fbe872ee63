//! Adaptive Dormand–Prince 5(4), the scheme behind Matlab's `ode45` that the paper
//! uses for its mass-on-car reference (Sec. 3.2).
//!
//! Fifth-order solution, fourth-order embedded error estimate, FSAL, and the
//! step-size control of Hairer, Nørsett & Wanner (II.4): `h ← h·min(5, max(0.2,
//! 0.9·err^(−1/5)))`, with `err` the RMS of the error scaled by
//! `atol + rtol·max(|y|, |y_new|)`. Each call integrates to an exact end time, so a
//! caller can sample the solution on a fixed grid without interpolation.

use nalgebra::SVector;

use crate::error::{Error, Result};

#[rustfmt::skip]
const A: [[f64; 6]; 6] = [
    [1.0 / 5.0,             0.0,               0.0,              0.0,            0.0,               0.0],
    [3.0 / 40.0,            9.0 / 40.0,        0.0,              0.0,            0.0,               0.0],
    [44.0 / 45.0,           -56.0 / 15.0,      32.0 / 9.0,       0.0,            0.0,               0.0],
    [19372.0 / 6561.0,      -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0, 0.0,               0.0],
    [9017.0 / 3168.0,       -355.0 / 33.0,     46732.0 / 5247.0, 49.0 / 176.0,   -5103.0 / 18656.0, 0.0],
    [35.0 / 384.0,          0.0,               500.0 / 1113.0,   125.0 / 192.0,  -2187.0 / 6784.0,  11.0 / 84.0],
];
const C: [f64; 6] = [1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
/// Fifth-order solution minus the embedded fourth-order one.
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339_200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// Tolerances and budget.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dopri5Settings {
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance.
    pub atol: f64,
    /// Most steps (accepted or rejected) one call may take.
    pub max_steps: u32,
}

impl Default for Dopri5Settings {
    /// Tight: the reference must be far more accurate than any scheme it judges.
    fn default() -> Self {
        Self {
            rtol: 1e-12,
            atol: 1e-14,
            max_steps: 1_000_000,
        }
    }
}

/// An integration in progress: the state, and the step size to try next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dopri5<const D: usize> {
    /// Current time.
    pub t: f64,
    /// Current state.
    pub y: SVector<f64, D>,
    h: f64,
    settings: Dopri5Settings,
    /// Accepted steps so far.
    pub accepted: u32,
    /// Rejected steps so far.
    pub rejected: u32,
}

impl<const D: usize> Dopri5<D> {
    /// Starts at `(t, y)` with a first trial step `h`.
    #[must_use]
    pub fn new(t: f64, y: SVector<f64, D>, h: f64, settings: Dopri5Settings) -> Self {
        Self {
            t,
            y,
            h,
            settings,
            accepted: 0,
            rejected: 0,
        }
    }

    /// Integrates `ẏ = f(t, y)` up to exactly `t_end`.
    pub fn advance_to<F>(&mut self, t_end: f64, f: &mut F) -> Result<SVector<f64, D>>
    where
        F: FnMut(f64, &SVector<f64, D>) -> SVector<f64, D>,
    {
        let mut budget = self.settings.max_steps;
        let mut k0 = f(self.t, &self.y);
        while self.t < t_end {
            if budget == 0 || self.h.is_nan() || self.h <= 1e-14 * self.t.abs().max(1.0) {
                return Err(Error::ReferenceFailed {
                    t: self.t,
                    h: self.h,
                });
            }
            budget -= 1;
            let h = self.h.min(t_end - self.t);
            let mut k = [k0; 7];
            for (i, (row, ci)) in A.iter().zip(C).enumerate() {
                let mut y = self.y;
                for (a, kj) in row.iter().zip(k.iter()).take(i + 1) {
                    y += kj * (h * a);
                }
                if let Some(slot) = k.get_mut(i + 1) {
                    *slot = f(self.t + ci * h, &y);
                }
            }
            // The last stage is evaluated at the fifth-order solution (FSAL).
            let mut y_new = self.y;
            if let Some(row) = A.last() {
                for (a, kj) in row.iter().zip(k.iter()) {
                    y_new += kj * (h * a);
                }
            }
            let mut err_sq = 0.0;
            for i in 0..D {
                let e: f64 = E
                    .iter()
                    .zip(k.iter())
                    .map(|(e, kj)| e * kj.get(i).copied().unwrap_or(0.0))
                    .sum::<f64>()
                    * h;
                let (a, b) = (
                    self.y.get(i).copied().unwrap_or(0.0),
                    y_new.get(i).copied().unwrap_or(0.0),
                );
                let scale = self.settings.atol + self.settings.rtol * a.abs().max(b.abs());
                err_sq += (e / scale) * (e / scale);
            }
            let err = libm::sqrt(err_sq / D as f64);
            if !err.is_finite() {
                return Err(Error::NonFinite {
                    t: self.t,
                    iterations: self.accepted,
                });
            }
            let factor = if err == 0.0 {
                5.0
            } else {
                (0.9 * libm::pow(err, -0.2)).clamp(0.2, 5.0)
            };
            if err <= 1.0 {
                self.t = if h == t_end - self.t {
                    t_end
                } else {
                    self.t + h
                };
                self.y = y_new;
                k0 = k.last().copied().unwrap_or(k0);
                self.accepted += 1;
                // Do not let the shortened last step shrink the next trial.
                self.h = (h * factor).max(if h < self.h { self.h } else { 0.0 });
            } else {
                self.rejected += 1;
                self.h = h * factor.min(1.0);
            }
        }
        Ok(self.y)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    /// ÿ = −ω² y: y(t) = cos ωt, to 1e-10 over ten periods.
    #[test]
    fn harmonic_oscillator_to_tolerance() {
        let omega = 3.0;
        let mut f =
            |_t: f64, y: &SVector<f64, 2>| SVector::<f64, 2>::new(y[1], -omega * omega * y[0]);
        let mut ode = Dopri5::new(
            0.0,
            SVector::<f64, 2>::new(1.0, 0.0),
            1e-3,
            Dopri5Settings::default(),
        );
        for i in 1..=100 {
            let t = 0.2 * f64::from(i);
            let y = ode.advance_to(t, &mut f).unwrap();
            assert!(
                (y[0] - libm::cos(omega * t)).abs() < 1e-10,
                "t = {t}: {}",
                y[0]
            );
        }
    }
}
