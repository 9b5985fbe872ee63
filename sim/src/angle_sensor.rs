//! What a real inclinometer does to the swing before it reports it (issue 33): it
//! filters (a MEMS sensor low-passes its own readings, often with a configurable corner)
//! and it reports late (the sample on its TPDO is one it took one or more SYNC periods
//! before, after its filter and its own processing). The drives' positions are sampled
//! at the SYNC itself, so the angle the controller pairs with them is older than they
//! are — by a few milliseconds to tens of them, which the rope calibration's balance of
//! the pendulum's equation is sensitive to (`controller::rope`).
//!
//! [`AngleSensor`] models it for the plants ([`crate::plant`], [`crate::plant3d`]), one
//! filter per axis: the true angle through a first-order low-pass of time constant
//! [`SensorLag::filter`], advanced at every step of the plant's integration; sampled once
//! a cycle with the sensor's noise and quantum; and reported [`SensorLag::delay`] cycles
//! after it was sampled. `no_std`, fixed-size, as the plants.

/// The longest delay modelled, in cycles (issue 33: 0–5).
pub const MAX_DELAY: usize = 5;

/// The inclinometer's own dynamics: how late and how filtered it reports the angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorLag {
    /// Cycles between the sample the sensor reports and the SYNC the drives' positions
    /// are sampled at (0: the same instant, as the positions), at most [`MAX_DELAY`].
    pub delay: u8,
    /// Time constant of its first-order low-pass, s (0: none).
    pub filter: f64,
}

impl SensorLag {
    /// An ideal sensor: no filter, sampled with the positions.
    pub const NONE: Self = Self {
        delay: 0,
        filter: 0.0,
    };

    /// The delay, cycles, within [`MAX_DELAY`].
    fn cycles(&self) -> usize {
        usize::from(self.delay).min(MAX_DELAY)
    }
}

/// An `N`-axis inclinometer's filter and delay line (see the module).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AngleSensor<const N: usize> {
    lag: SensorLag,
    /// The filter's output, rad.
    filtered: [f64; N],
    /// The samples taken, newest first: `line[k]` was taken `k` cycles ago (before the
    /// first ones, the angles it started on).
    line: [[f64; N]; MAX_DELAY + 1],
}

impl<const N: usize> AngleSensor<N> {
    /// A sensor with `lag`, settled on the angles `angles` (a load at rest in its
    /// turning point: the filter has long followed it).
    #[must_use]
    pub fn new(lag: SensorLag, angles: [f64; N]) -> Self {
        Self {
            lag,
            filtered: angles,
            line: [angles; MAX_DELAY + 1],
        }
    }

    /// Its dynamics.
    #[must_use]
    pub fn lag(&self) -> SensorLag {
        self.lag
    }

    /// The filter follows the true `angles` over `dt` s (one step of the plant's
    /// integration, the angles at its end): exact for angles held over the step.
    pub fn track(&mut self, angles: [f64; N], dt: f64) {
        let tau = self.lag.filter;
        let follow = if tau > 0.0 {
            1.0 - libm::exp(-dt / tau)
        } else {
            1.0
        };
        for (f, a) in self.filtered.iter_mut().zip(angles) {
            *f += follow * (a - *f);
        }
    }

    /// The filtered angles now, rad (before noise).
    #[must_use]
    pub fn filtered(&self) -> [f64; N] {
        self.filtered
    }

    /// Takes this cycle's sample — `read` turns each filtered angle into a reading (its
    /// noise and quantum) — and returns the one it reports now: the sample taken
    /// [`SensorLag::delay`] cycles ago (in the first cycles, the angles it started on,
    /// unrounded: what it had been reporting of the load at rest).
    pub fn sample(&mut self, mut read: impl FnMut(f64) -> f64) -> [f64; N] {
        let now = self.filtered.map(&mut read);
        self.line.rotate_right(1);
        if let Some(first) = self.line.first_mut() {
            *first = now;
        }
        self.line.get(self.lag.cycles()).copied().unwrap_or(now)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    #[test]
    fn an_ideal_sensor_reports_the_angle_of_this_cycle() {
        let mut s = AngleSensor::<1>::new(SensorLag::NONE, [0.0]);
        for k in 0..10 {
            s.track([f64::from(k)], 0.001);
            assert_eq!(s.sample(|v| v), [f64::from(k)]);
        }
    }

    #[test]
    fn a_delay_reports_the_sample_of_that_many_cycles_ago() {
        let lag = SensorLag {
            delay: 3,
            filter: 0.0,
        };
        let mut s = AngleSensor::<2>::new(lag, [0.0; 2]);
        let got: Vec<f64> = (1..=8)
            .map(|k| {
                s.track([f64::from(k), -f64::from(k)], 0.001);
                s.sample(|v| v)[0]
            })
            .collect();
        // Before the third sample is three cycles old, the angle it started on.
        assert_eq!(got, [0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
    }

    #[test]
    fn the_filter_is_a_first_order_lag() {
        // A step through τ = 20 ms: 63 % after τ, at 1 ms steps.
        let lag = SensorLag {
            delay: 0,
            filter: 0.02,
        };
        let mut s = AngleSensor::<1>::new(lag, [0.0]);
        for _ in 0..20 {
            s.track([1.0], 0.001);
        }
        assert!((s.filtered()[0] - (1.0 - (-1.0f64).exp())).abs() < 1e-12);
    }
}
