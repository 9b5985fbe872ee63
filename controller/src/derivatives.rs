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
