//! The stopping test of a simplified Newton iteration that keeps its matrix across
//! iterations and steps (BDF's structured Newton, RADAU5's transformed Newton): one copy
//! of the rule, Hairer & Wanner's (*Solving ODEs II*, Sec. IV.8).
//!
//! With the contraction rate `θ_k = ‖Δ_k‖ / ‖Δ_{k−1}‖` and `η = θ/(1−θ)`, the error left
//! after iteration k is about `η ‖Δ_k‖`; the iteration has converged when that, or the
//! increment itself, is ≤ 1 in Newton's weighted norm. The first iteration has no θ of
//! its own and takes the last η measured, drifting towards 1 (`η ← min(1, 4η)` per step;
//! RADAU5's `FACCON` takes `η^0.8`, a software `pow` the MCU would pay for), so that a
//! second iteration is forced now and then to measure θ again.
//!
//! An iteration that contracts by less than `stall_ratio` asks for a fresh matrix if the
//! one in use is old; with a fresh one it is rounding noise once the increment is below
//! `stall_limit` (as in the paper's modes), or below a floor the caller estimated in
//! advance (RADAU5 here).

use crate::newton::NewtonSettings;

/// What one iteration's increment says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Converged.
    Converged,
    /// Converged at the rounding floor: more iterations would only stir noise.
    AtRoundingFloor,
    /// Not contracting on an old matrix: form a fresh one at this iterate, go on.
    Refresh,
    /// Go on.
    Continue,
}

/// The iteration's contraction, carried through one step's iterations.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Contraction {
    eta: f64,
    previous: f64,
    theta: Option<f64>,
}

impl Contraction {
    /// The start of a step's iteration, with the η the last step ended with.
    pub(crate) fn start(carried_eta: f64) -> Self {
        Self {
            eta: (4.0 * carried_eta.max(1e-6)).min(1.0),
            previous: f64::INFINITY,
            theta: None,
        }
    }

    /// Judges iteration `it` (from 1) with increment `norm` (weighted); `floor`: the
    /// increment rounding alone makes (0 if not known). `fresh`: a refresh would not
    /// give a better matrix, so a stall is not met by another — for RADAU5 the matrix
    /// was formed during this step; for BDF it was formed at an iterate of this step's
    /// iteration (the factors every step forms at the prediction do not count).
    pub(crate) fn judge(
        &mut self,
        it: u32,
        norm: f64,
        fresh: bool,
        floor: f64,
        settings: &NewtonSettings,
    ) -> Verdict {
        let theta = norm / self.previous;
        self.previous = norm;
        if it >= 2 {
            self.theta = Some(theta);
            if theta < 1.0 {
                self.eta = theta / (1.0 - theta);
            }
        }
        let contracting = it == 1 || theta < 1.0;
        if norm <= 1.0 || (contracting && self.eta * norm <= 1.0) {
            Verdict::Converged
        } else if norm <= floor {
            Verdict::AtRoundingFloor
        } else if it >= 2 && theta >= settings.stall_ratio {
            if !fresh {
                // The error estimate of an old matrix means nothing for the new one.
                self.eta = 1.0;
                Verdict::Refresh
            } else if norm <= settings.stall_limit {
                Verdict::AtRoundingFloor
            } else {
                Verdict::Continue
            }
        } else {
            Verdict::Continue
        }
    }

    /// η now: carried into the next step's first iteration.
    pub(crate) fn eta(&self) -> f64 {
        self.eta
    }

    /// The contraction rate of the last iteration judged, once there are two.
    pub(crate) fn theta(&self) -> Option<f64> {
        self.theta
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> NewtonSettings {
        NewtonSettings::default()
    }

    #[test]
    fn a_small_increment_converges_at_once() {
        let mut c = Contraction::start(1.0);
        assert_eq!(c.judge(1, 0.5, true, 0.0, &settings()), Verdict::Converged);
    }

    #[test]
    fn fast_contraction_converges_by_the_error_estimate() {
        let mut c = Contraction::start(1.0);
        assert_eq!(c.judge(1, 1e4, true, 0.0, &settings()), Verdict::Continue);
        // θ = 0.005, η ≈ 0.005: η · 50 < 1 although the increment is 50.
        assert_eq!(c.judge(2, 50.0, true, 0.0, &settings()), Verdict::Converged);
        assert!((c.theta().unwrap_or(0.0) - 0.005).abs() < 1e-15);
        assert!(c.eta() < 0.006);
    }

    #[test]
    fn a_stall_refreshes_an_old_matrix_and_is_the_floor_with_a_fresh_one() {
        let mut c = Contraction::start(1.0);
        c.judge(1, 1e3, false, 0.0, &settings());
        assert_eq!(c.judge(2, 900.0, false, 0.0, &settings()), Verdict::Refresh);
        assert_eq!(c.eta(), 1.0);
        let mut c = Contraction::start(1.0);
        c.judge(1, 1e3, true, 0.0, &settings());
        assert_eq!(
            c.judge(2, 900.0, true, 0.0, &settings()),
            Verdict::AtRoundingFloor
        );
        let mut c = Contraction::start(1.0);
        c.judge(1, 1e8, true, 0.0, &settings());
        assert_eq!(c.judge(2, 9e7, true, 0.0, &settings()), Verdict::Continue);
    }

    #[test]
    fn an_increment_within_the_known_floor_stops() {
        let mut c = Contraction::start(1.0);
        assert_eq!(
            c.judge(1, 5.0, true, 10.0, &settings()),
            Verdict::AtRoundingFloor
        );
    }

    #[test]
    fn the_carried_eta_drifts_towards_one() {
        let c = Contraction::start(0.01);
        assert!((c.eta() - 0.04).abs() < 1e-15);
        assert_eq!(Contraction::start(0.5).eta(), 1.0);
        assert!((Contraction::start(0.0).eta() - 4e-6).abs() < 1e-18);
    }
}
