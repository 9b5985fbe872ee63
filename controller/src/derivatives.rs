//! A signal's first two derivatives without differentiating it numerically: the
//! third-order low-pass `ω³/(s + ω)³` as a state-variable filter, whose states are the
//! filtered signal and its first two derivatives. The rope's length ([`crate::rope`])
//! and the inclinometer's offset ([`crate::zero`]) both solve the pendulum's equation
//! on signals filtered alike, so that the filter's lag is common to both sides of it.

/// `ω³/(s + ω)³` with corner `ω` (rad/s), advanced step by step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Derivatives {
    corner: f64,
    y: [f64; 3],
    started: bool,
}

impl Derivatives {
    /// A filter with corner `corner` (rad/s) that starts on its first input.
    pub(crate) const fn new(corner: f64) -> Self {
        Self {
            corner,
            y: [0.0; 3],
            started: false,
        }
    }

    /// Whether it has had its first input (or a [`Derivatives::start`]).
    pub(crate) fn started(&self) -> bool {
        self.started
    }

    /// Starts on a signal `u` with first two derivatives `du`, `ddu` as if it had been
    /// following it: its states are then the filtered signal and derivatives, which
    /// lag (`ω³/(s + ω)³ ≈ 1 − 3s/ω + 6s²/ω²`), so that no transient starts.
    pub(crate) fn start(&mut self, [u, du, ddu]: [f64; 3]) -> [f64; 3] {
        let w = self.corner;
        self.y = [
            u - 3.0 * du / w + 6.0 * ddu / (w * w),
            du - 3.0 * ddu / w,
            ddu,
        ];
        self.started = true;
        self.y
    }

    /// Advances by `h` with input `u` held: semi-implicit Euler in 4 sub-steps (the
    /// corners used keep ω h/4 ≤ 0.02 at 10 ms). The first input starts it at rest on it.
    pub(crate) fn push(&mut self, u: f64, h: f64) -> [f64; 3] {
        if !self.started {
            self.y = [u, 0.0, 0.0];
            self.started = true;
            return self.y;
        }
        const SUB: usize = 4;
        let dt = h / SUB as f64;
        let w = self.corner;
        let (w2, w3) = (w * w, w * w * w);
        let [mut p, mut v, mut a] = self.y;
        for _ in 0..SUB {
            a += dt * (w3 * (u - p) - 3.0 * w2 * v - 3.0 * w * a);
            v += dt * a;
            p += dt * v;
        }
        self.y = [p, v, a];
        self.y
    }
}

/// The same filter `ω³/(s + ω)³` discretised exactly for an input held over each period
/// `h` (its transition `e^{A h}` and input vector `∫₀ʰ e^{A t} B dt`, from their Taylor
/// series once, when built): its three states are then exactly the filtered signal and
/// its first two derivatives at every sample, for every signal alike. The rope's
/// calibration balances the pendulum's equation between states of different order
/// (`g φ` against `ẍ` and `L φ̈`), which the sub-stepped [`Derivatives`] offsets by a
/// fraction of a sub-step: that alone put the scaling 0.3 % off (issue 33).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ExactDerivatives {
    corner: f64,
    /// `e^{A h}`, row by row.
    transition: [[f64; 3]; 3],
    /// `∫₀ʰ e^{A t} B dt`.
    input: [f64; 3],
    y: [f64; 3],
    started: bool,
}

impl ExactDerivatives {
    /// The filter with corner `corner` (rad/s) for the period `h` (s).
    pub(crate) fn new(corner: f64, h: f64) -> Self {
        let w = corner;
        let a = [
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [-w * w * w, -3.0 * w * w, -3.0 * w],
        ];
        let b = [0.0, 0.0, w * w * w];
        let mul = |m: &[[f64; 3]; 3], v: &[f64; 3]| -> [f64; 3] {
            let row = |r: &[f64; 3]| r.iter().zip(v).map(|(x, y)| x * y).sum::<f64>();
            [row(&m[0]), row(&m[1]), row(&m[2])]
        };
        // Σ (A h)^k / k! column by column, and Σ A^k h^(k+1)/(k+1)! B: 20 terms for ω h
        // up to 1 leave less than 1e-18.
        let mut transition = [[0.0; 3]; 3];
        for (j, col) in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
            .iter()
            .enumerate()
        {
            let (mut term, mut sum) = (*col, *col);
            for k in 1..20 {
                term = mul(&a, &term).map(|x| x * h / f64::from(k));
                for (s, t) in sum.iter_mut().zip(term) {
                    *s += t;
                }
            }
            for (row, s) in transition.iter_mut().zip(sum) {
                if let Some(cell) = row.get_mut(j) {
                    *cell = s;
                }
            }
        }
        let (mut term, mut input) = (b.map(|x| x * h), b.map(|x| x * h));
        for k in 2..21 {
            term = mul(&a, &term).map(|x| x * h / f64::from(k));
            for (s, t) in input.iter_mut().zip(term) {
                *s += t;
            }
        }
        Self {
            corner,
            transition,
            input,
            y: [0.0; 3],
            started: false,
        }
    }

    /// One period with input `u` held: the filtered signal and its first two
    /// derivatives. The first input starts it at rest on it.
    pub(crate) fn push(&mut self, u: f64) -> [f64; 3] {
        if !self.started {
            self.y = [u, 0.0, 0.0];
            self.started = true;
            return self.y;
        }
        let y = self.y;
        let row = |r: &[f64; 3], b: f64| r.iter().zip(&y).map(|(a, x)| a * x).sum::<f64>() + b * u;
        let [t0, t1, t2] = &self.transition;
        let [b0, b1, b2] = self.input;
        self.y = [row(t0, b0), row(t1, b1), row(t2, b2)];
        self.y
    }

    /// The third derivative of the filtered signal now, for the input `u` last pushed:
    /// the filter's equation `ω³ (u − y) − 3ω² ẏ − 3ω ÿ`.
    pub(crate) fn third(&self, u: f64) -> f64 {
        let w = self.corner;
        let [p, v, a] = self.y;
        w * w * w * (u - p) - 3.0 * w * w * v - 3.0 * w * a
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    #[test]
    fn the_exact_filter_s_states_are_the_signal_s_derivatives() {
        // What the rope relies on: the second derivative of a signal's filtered states
        // is the filtered second derivative, sampled alike. A swing of 1 rad/s: the
        // `ÿ` state of sin t and the `y` state of −sin t agree within 1e-4 of the
        // amplitude after the transient (the sub-stepped filter: 4e-3).
        let (w, h) = (2.0, 0.01);
        let (mut f, mut g) = (ExactDerivatives::new(w, h), ExactDerivatives::new(w, h));
        let (mut sub, mut sub_g) = (Derivatives::new(w), Derivatives::new(w));
        let (mut worst, mut worst_sub) = (0.0_f64, 0.0_f64);
        for k in 0..3000 {
            let t = f64::from(k) * h;
            let [_, _, a] = f.push(libm::sin(t));
            let [p, _, _] = g.push(-libm::sin(t));
            let [_, _, a_sub] = sub.push(libm::sin(t), h);
            let [p_sub, _, _] = sub_g.push(-libm::sin(t), h);
            if t > 10.0 {
                worst = worst.max((a - p).abs());
                worst_sub = worst_sub.max((a_sub - p_sub).abs());
            }
        }
        assert!(worst < 1e-4, "exact: {worst:e}");
        assert!(worst_sub > 10.0 * worst, "sub-stepped: {worst_sub:e}");
        // A constant stays where it started, its derivatives zero.
        let mut c = ExactDerivatives::new(w, h);
        for _ in 0..100 {
            assert_eq!(c.push(3.0), [3.0, 0.0, 0.0]);
        }
    }
}
