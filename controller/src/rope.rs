//! The rope's true length, learnt from the swing it makes (issue 18, item 4).
//!
//! The winch measures the rope through the drum: a scaling error of a per cent or two
//! (rope diameter, layering) and the hook block's length are invisible to the drum and
//! to the inclinometer, and put the load 0.1–0.2 m off vertically. The swing sees them:
//! a pendulum of length `L` obeys (Eq. 22, the rope force's direction)
//!
//! `L φ̈ + 2 L̇ φ̇ + g sin φ + ẍ cos φ = 0`,
//!
//! and since `L φ̈ + 2 L̇ φ̇ = (Lφ)¨ − L̈ φ`, with `L = (1 + s) l + o` (`l` the drum's
//! reading, `s` the scaling error, `o` the offset) `s` and `o` are the least-squares
//! solution of
//!
//! `s r₁ + o φ̈ = −g sin φ − ẍ cos φ − r₁`,  `r₁ = (lφ)¨ − l̈ φ`,
//!
//! over every sample of a good angle. The derivatives are those of the same
//! state-variable filter `ω³/(s + ω)³` applied to `x`, `φ`, `sin φ`, `l` and the product
//! `lφ` (a linear filter commutes with the equation's linear terms, so filtering `lφ`
//! before differentiating it leaves no lag between rope and swing while the rope
//! changes — the filtered `l` lags by 3/ω, 0.1 m at a 0.27 m/s hoist; only the small
//! `l̈ φ` and `ẍ cos φ` are products of filtered signals). Moves excite both unknowns
//! (the rope length changes while the load swings); at one rope length only
//! `(1 + s) l + o` is determined, and that is what the load needs there.
//!
//! It is a **commissioning step**, not an online adaptation: a gust is a force the
//! equation does not have, and at the small swing accelerations a move under feedback
//! makes (about 0.1 rad/s²), a gust of 2 N on the lab crane's load biases the length by
//! a decimetre — online, gust and rope error cannot be told apart (measured: the
//! 1000-case study with the estimate fed back left 60–140 mm in gusty cases). In calm
//! air, with feedforward only (the load swings freely after each move), a move down and
//! one up give the rope to a few millimetres; the controller shows the estimate in
//! 0x2003 and the commissioning engineer saves it as the winch's `position_scale` and
//! `position_offset` (docs/COMMISSIONING.md, "Rope calibration").

/// The largest scaling error believed, relative.
pub const MAX_SCALE: f64 = 0.05;
/// The largest offset believed, m.
pub const MAX_OFFSET: f64 = 0.5;
/// The filter's corner, rad/s: 5–7× the swing's 1.0–1.8 rad/s (l = 3–9 m).
const OMEGA: f64 = 8.0;
/// Information (Σ φ̈², rad²/s⁴) before the estimate is used: about a second of a
/// 0.1 rad/s² swing acceleration, a move's.
const MIN_INFORMATION: f64 = 1.0;

/// The sums of the regression: Σ r rᵀ (upper triangle), Σ r y, and the samples.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Sums {
    a: [f64; 3],
    b: [f64; 2],
    n: u32,
}

impl Sums {
    fn add(&mut self, r1: f64, r2: f64, y: f64) {
        self.a[0] += r1 * r1;
        self.a[1] += r1 * r2;
        self.a[2] += r2 * r2;
        self.b[0] += r1 * y;
        self.b[1] += r2 * y;
        self.n = self.n.saturating_add(1);
    }
}

/// `ω³/(s + ω)³` as a state-variable filter: its states are the filtered signal and
/// its first two derivatives.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Derivatives {
    y: [f64; 3],
    started: bool,
}

impl Derivatives {
    /// Advances by `h` with input `u` held: semi-implicit Euler in 4 sub-steps
    /// (ω h/4 = 0.02). Every signal goes through the same filter, so its error is
    /// common to both sides of the regression.
    fn push(&mut self, u: f64, h: f64) -> [f64; 3] {
        if !self.started {
            self.y = [u, 0.0, 0.0];
            self.started = true;
            return self.y;
        }
        const SUB: usize = 4;
        let dt = h / SUB as f64;
        let (w, w2, w3) = (OMEGA, OMEGA * OMEGA, OMEGA * OMEGA * OMEGA);
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

/// The least-squares estimate of the rope's scaling error and offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RopeLength {
    g: f64,
    h: f64,
    x: Derivatives,
    phi: Derivatives,
    sin_phi: Derivatives,
    l: Derivatives,
    l_phi: Derivatives,
    /// The regression's sums.
    taken: Sums,
    /// Cycles the filters have run without a gap.
    warm: u32,
}

impl RopeLength {
    /// No knowledge yet: the drum is believed.
    #[must_use]
    pub fn new(g: f64, h: f64) -> Self {
        Self {
            g,
            h,
            x: Derivatives::default(),
            phi: Derivatives::default(),
            sin_phi: Derivatives::default(),
            l: Derivatives::default(),
            l_phi: Derivatives::default(),
            taken: Sums::default(),
            warm: 0,
        }
    }

    /// A sample with a good angle: trolley `x`, swing `phi` and the drum's rope `l`.
    pub fn sample(&mut self, x: f64, phi: f64, l: f64) {
        if !(x.is_finite() && phi.is_finite() && l.is_finite()) {
            self.gap();
            return;
        }
        let [_, _, xa] = self.x.push(x, self.h);
        let [pf, _, pa] = self.phi.push(phi, self.h);
        let [sf, _, _] = self.sin_phi.push(libm::sin(phi), self.h);
        let [_, _, la] = self.l.push(l, self.h);
        let [_, _, lpa] = self.l_phi.push(l * phi, self.h);
        self.warm = self.warm.saturating_add(1);
        // The filters forget their start within a few time constants (3/ω ≈ 0.4 s).
        if f64::from(self.warm) * self.h < 6.0 / OMEGA {
            return;
        }
        let r1 = lpa - la * pf;
        let r2 = pa;
        let y = -self.g * sf - xa * libm::cos(pf) - r1;
        self.taken.add(r1, r2, y);
    }

    /// No good sample this cycle: the filters start again at the next one.
    pub fn gap(&mut self) {
        self.x = Derivatives::default();
        self.phi = Derivatives::default();
        self.sin_phi = Derivatives::default();
        self.l = Derivatives::default();
        self.l_phi = Derivatives::default();
        self.warm = 0;
    }

    /// The scaling error and offset believed, `(s, o)`: none until the swing has
    /// shown enough; the offset alone while the rope length has not varied enough to
    /// tell them apart.
    #[must_use]
    pub fn estimate(&self) -> (f64, f64) {
        let [a11, a12, a22] = self.taken.a;
        let [b1, b2] = self.taken.b;
        if a22 < MIN_INFORMATION {
            return (0.0, 0.0);
        }
        let det = a11 * a22 - a12 * a12;
        // Both unknowns when the regressors are far from collinear (the rope length
        // varied over the samples), else the length at this rope, as an offset.
        let (s, o) = if det > 1e-3 * a11 * a22 {
            ((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det)
        } else {
            (0.0, b2 / a22)
        };
        if !(s.is_finite() && o.is_finite()) {
            return (0.0, 0.0);
        }
        (
            s.clamp(-MAX_SCALE, MAX_SCALE),
            o.clamp(-MAX_OFFSET, MAX_OFFSET),
        )
    }

    /// The rope's length for the drum's reading `l` under [`Self::estimate`], m.
    #[must_use]
    pub fn length(&self, l: f64) -> f64 {
        let (s, o) = self.estimate();
        (1.0 + s) * l + o
    }

    /// The samples taken.
    #[must_use]
    pub fn samples(&self) -> u32 {
        self.taken.n
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    /// A pendulum of length `(1 + s) l + o` under a trolley moving back and forth
    /// while the drum hoists from 8 to 4 m, sampled at 100 Hz with an angle quantum.
    fn learn(s: f64, o: f64, quantum: f64) -> RopeLength {
        let (g, h) = (9.81, 0.01);
        let mut est = RopeLength::new(g, h);
        let (mut phi, mut vphi) = (0.0, 0.0);
        let sub = 10;
        let dt = h / sub as f64;
        for k in 0..1500 {
            for j in 0..sub {
                let t = (k * sub + j) as f64 * dt;
                let l = 8.0 - 4.0 * (t / 15.0).min(1.0);
                let vl = if t < 15.0 { -4.0 / 15.0 } else { 0.0 };
                let len = (1.0 + s) * l + o;
                let acc = 0.5 * libm::sin(1.3 * t) + 0.3 * libm::sin(0.4 * t);
                let aphi =
                    (-g * libm::sin(phi) - libm::cos(phi) * acc - 2.0 * (1.0 + s) * vl * vphi)
                        / len;
                vphi += dt * aphi;
                phi += dt * vphi;
            }
            let t = (k * sub) as f64 * dt;
            let x = -0.5 / (1.3 * 1.3) * libm::sin(1.3 * t) - 0.3 / 0.16 * libm::sin(0.4 * t)
                + 0.5 / 1.3 * t
                + 0.3 / 0.4 * t;
            let l = 8.0 - 4.0 * (t / 15.0).min(1.0);
            let read = if quantum > 0.0 {
                libm::round(phi / quantum) * quantum
            } else {
                phi
            };
            est.sample(x, read, l);
        }
        est
    }

    #[test]
    fn the_scaling_error_and_the_offset_are_learnt_from_the_swing() {
        for (s, o) in [(0.02, 0.0), (-0.02, 0.1), (0.0, -0.15), (0.015, 0.08)] {
            let (es, eo) = learn(s, o, 1.75e-4).estimate();
            // What matters: the length at the end of the move, 4 m.
            let err = ((1.0 + s) * 4.0 + o) - ((1.0 + es) * 4.0 + eo);
            assert!(
                err.abs() < 0.02,
                "s {s}, o {o}: learnt {es:.4}, {eo:.3}, length off {:.1} mm",
                err * 1e3
            );
        }
    }

    #[test]
    fn without_a_swing_nothing_is_believed() {
        let mut est = RopeLength::new(9.81, 0.01);
        for _ in 0..500 {
            est.sample(10.0, 0.0, 6.0);
        }
        assert_eq!(est.estimate(), (0.0, 0.0));
        assert_eq!(est.length(6.0), 6.0);
        est.sample(f64::NAN, 0.0, 4.0);
        assert_eq!(est.length(4.0), 4.0);
    }
}
