//! The error measure of Eq. 29, `e_max = max_t max_i |u_d,i(t) − u_flat,i(t)|`, for any
//! number of inputs, accumulated sample by sample (no allocation).
//!
//! Each crane's flat reference supplies `u_flat(t)` (`flat_crane`, `flat_crane3d`); this
//! is what both then share: the per-sample error [`input_error`] and its maximum over a
//! run, globally and over an interior window ([`Emax`]), where a scheme's order is not
//! limited by the jump of the trajectory's `(n+1)`-th derivative at the move's ends.

use nalgebra::SVector;

/// `max_i |u_i − u_flat,i|` at one sample; NaN if any input is NaN (a failed run must not
/// look accurate: `f64::max` would drop the NaN).
#[must_use]
pub fn input_error<const NU: usize>(u: &SVector<f64, NU>, u_flat: &[f64; NU]) -> f64 {
    u.iter()
        .zip(u_flat)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, |acc, e| {
            if e.is_nan() || acc.is_nan() {
                f64::NAN
            } else {
                acc.max(e)
            }
        })
}

/// Eq. 29 over a run: the largest sample error overall and within `[a, b]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Emax {
    /// `max_t max_i |u_d,i − u_flat,i|` over every sample.
    pub global: f64,
    /// The same over samples with `t ∈ [a, b]`.
    pub interior: f64,
    /// The interior window `[a, b]`.
    window: (f64, f64),
}

impl Emax {
    /// Nothing seen yet; the interior is `[a, b]`.
    #[must_use]
    pub fn over(a: f64, b: f64) -> Self {
        Self {
            global: 0.0,
            interior: 0.0,
            window: (a, b),
        }
    }

    /// Takes one sample's error (from [`input_error`]) at time `t`; a NaN error makes
    /// the maximum NaN.
    pub fn add(&mut self, t: f64, error: f64) {
        let max = |m: f64| {
            if error.is_nan() || m.is_nan() {
                f64::NAN
            } else {
                m.max(error)
            }
        };
        self.global = max(self.global);
        let (a, b) = self.window;
        if (a..=b).contains(&t) {
            self.interior = max(self.interior);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maximum_over_inputs_and_samples_with_its_window() {
        assert_eq!(
            input_error(&SVector::from([1.0, -2.0, 3.0]), &[1.5, -2.0, 2.0]),
            1.0
        );
        assert!(input_error(&SVector::from([f64::NAN, 0.0]), &[0.0, 0.0]).is_nan());
        let mut e = Emax::over(1.0, 2.0);
        for (t, err) in [(0.5, 3.0), (1.0, 1.0), (1.5, 2.0), (2.5, 0.5)] {
            e.add(t, err);
        }
        assert_eq!((e.global, e.interior), (3.0, 2.0));
        e.add(3.0, f64::NAN);
        assert!(e.global.is_nan());
        assert_eq!(e.interior, 2.0);
    }
}
