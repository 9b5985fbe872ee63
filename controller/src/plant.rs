//! A crane plant that is *not* the controller's model, for the closed-loop study.
//!
//! Eqs. 21–22 (minimal coordinates, state `[x, l, φ, ẋ, l̇, φ̇]`) with what the inverse
//! model leaves out:
//!
//! * the drives' velocity loops are first order with time constants `τ1 (1 + δ1)`,
//!   `τ2 (1 + δ2)`, `|δ| ≤ 30 %` (the model's τ of Tab. 3 are identified values);
//! * friction in both axes, as the velocity droop it causes in a velocity-controlled
//!   drive: Coulomb (`c · tanh(v / 1 mm/s)`) plus viscous (`b · v`), so the drive
//!   follows `τ v̇ + v = u − c tanh(v/ε) − b v`;
//! * the rope is not what the drum's measurement says: its scaling is off by up to ±2 %
//!   (rope diameter, layering) and it is longer by an offset of up to ±2 % of the initial
//!   length (hook block, rope stretch): the pendulum has length `(1 + s) l + Δl`;
//! * a wind gust: a horizontal force `F(t)` on the load (a sin² pulse);
//! * measurements sampled every cycle with noise and quantisation, delivered one
//!   cycle (10 ms) late.
//!
//! Integrated with classical RK4 at 1 ms under the zero-order-held 10 ms set points.
//!
//! `no_std` and `libm` only: the QEMU firmware's virtual bus runs the same plant as the
//! host (feature `sim`), so that QEMU and host compute the same frames.

/// A small deterministic generator (SplitMix64): the study's cases are fixed by a seed.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[a, b)`.
    pub fn uniform(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.unit()
    }

    /// Standard normal (Box–Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.unit().max(1e-300);
        let u2 = self.unit();
        libm::sqrt(-2.0 * libm::log(u1)) * libm::cos(2.0 * core::f64::consts::PI * u2)
    }
}

/// A wind gust: `F(t) = amplitude · sin²(π (t − start)/duration)` on `[start, start + duration]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gust {
    /// Start, s.
    pub start: f64,
    /// Duration, s.
    pub duration: f64,
    /// Peak horizontal force on the load, N.
    pub amplitude: f64,
}

impl Gust {
    /// No gust.
    pub const NONE: Self = Self {
        start: 0.0,
        duration: 1.0,
        amplitude: 0.0,
    };

    /// The force at `t`, N.
    pub fn force(&self, t: f64) -> f64 {
        let s = (t - self.start) / self.duration;
        if (0.0..=1.0).contains(&s) {
            let v = libm::sin(core::f64::consts::PI * s);
            self.amplitude * v * v
        } else {
            0.0
        }
    }
}

/// Everything in which the plant differs from the model, and the sensors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mismatch {
    /// Relative error of the trolley drive's time constant (plant τ1 = model τ1 · (1 + this)).
    pub tau1: f64,
    /// Relative error of the winch drive's time constant.
    pub tau2: f64,
    /// Rope longer than measured by this, m.
    pub rope_offset: f64,
    /// The drum's scaling error: the rope is `(1 + this)` times what the drum measures.
    pub drum_scale: f64,
    /// Coulomb droop of the trolley / winch velocity loop, m/s.
    pub coulomb: [f64; 2],
    /// Viscous droop of the trolley / winch, relative.
    pub viscous: [f64; 2],
    /// The wind gust.
    pub gust: Gust,
    /// Position noise (1σ) and quantum, m.
    pub position_noise: (f64, f64),
    /// Angle noise (1σ) and quantum, rad.
    pub angle_noise: (f64, f64),
    /// Seed of the sensor noise.
    pub noise_seed: u64,
    /// The swing the load already has when the run starts, rad (a gust before the
    /// command), at rest in the swing's turning point.
    pub swing0: f64,
}

impl Mismatch {
    /// The plant equal to the model: no friction, no offset, no gust, exact sensors.
    pub const NONE: Self = Self {
        tau1: 0.0,
        tau2: 0.0,
        rope_offset: 0.0,
        drum_scale: 0.0,
        coulomb: [0.0; 2],
        viscous: [0.0; 2],
        gust: Gust::NONE,
        position_noise: (0.0, 0.0),
        angle_noise: (0.0, 0.0),
        noise_seed: 0,
        swing0: 0.0,
    };

    /// The sensors of the study: positions 0.2 mm noise, 0.1 mm quantum; the inclinometer
    /// 0.02° noise, 0.01° quantum.
    pub const SENSORS: ((f64, f64), (f64, f64)) = ((2e-4, 1e-4), (3.5e-4, 1.75e-4));

    /// A random case: τ within ±30 %, rope offset within ±2 % of `l0`, drum scaling
    /// within ±2 %, Coulomb droop up
    /// to 3 mm/s on both axes, viscous up to 3 %, a gust of up to
    /// ±10 N (≈ 3° of static deflection on the 18.9 kg load) lasting 0.5–3 s starting in
    /// `gust_window`, and a load already swinging up to ±5° when the run starts.
    pub fn random(rng: &mut Rng, l0: f64, gust_window: (f64, f64)) -> Self {
        let duration = rng.uniform(0.5, 3.0);
        let (a, b) = gust_window;
        let start = rng.uniform(a, (b - duration).max(a));
        Self {
            tau1: rng.uniform(-0.3, 0.3),
            tau2: rng.uniform(-0.3, 0.3),
            rope_offset: rng.uniform(-0.02, 0.02) * l0,
            coulomb: [rng.uniform(0.0, 0.003), rng.uniform(0.0, 0.003)],
            viscous: [rng.uniform(0.0, 0.03), rng.uniform(0.0, 0.03)],
            gust: Gust {
                start,
                duration,
                amplitude: rng.uniform(-10.0, 10.0),
            },
            position_noise: Self::SENSORS.0,
            angle_noise: Self::SENSORS.1,
            noise_seed: rng.next_u64(),
            swing0: rng.uniform(-5.0, 5.0).to_radians(),
            drum_scale: rng.uniform(-0.02, 0.02),
        }
    }

    /// The pendulum's length when the drum measures `l`, m.
    pub fn rope(&self, l: f64) -> f64 {
        (1.0 + self.drum_scale) * l + self.rope_offset
    }

    /// The same crane with the winch's scaling corrected by the rope calibration
    /// `(s, o)` ([`crate::rope`]): its reading becomes `(1 + s) l + o`, so the rope is
    /// `k (reading − o) + offset` with `k = (1 + drum_scale) / (1 + s)`.
    pub fn calibrated(&self, (s, o): (f64, f64)) -> Self {
        let k = (1.0 + self.drum_scale) / (1.0 + s);
        Self {
            drum_scale: k - 1.0,
            rope_offset: self.rope_offset - k * o,
            ..*self
        }
    }
}

/// The plant's true state, `[x, l_drum, φ, ẋ, l̇, φ̇]` (the pendulum length is `l_drum + offset`).
#[derive(Debug, Clone)]
pub struct Plant {
    /// State.
    pub y: [f64; 6],
    /// Time, s.
    pub t: f64,
    tau: [f64; 2],
    g: f64,
    m: f64,
    mismatch: Mismatch,
    noise: Rng,
}

/// Integration step of the plant, s.
pub const PLANT_STEP: f64 = 1e-3;

impl Plant {
    /// At rest at trolley `x`, drum rope length `l`, time `t`; model time constants `tau`.
    pub fn at_rest(x: f64, l: f64, t: f64, tau: [f64; 2], g: f64, m: f64, mm: Mismatch) -> Self {
        let [tau1, tau2] = tau;
        Self {
            y: [x, l, mm.swing0, 0.0, 0.0, 0.0],
            t,
            tau: [tau1 * (1.0 + mm.tau1), tau2 * (1.0 + mm.tau2)],
            g,
            m,
            mismatch: mm,
            noise: Rng::new(mm.noise_seed),
        }
    }

    fn rhs(&self, t: f64, y: &[f64; 6], u: [f64; 2]) -> [f64; 6] {
        let [_, l, phi, vx, vl, vphi] = *y;
        let mm = &self.mismatch;
        let [c1, c2] = mm.coulomb;
        let [b1, b2] = mm.viscous;
        let droop = |c: f64, b: f64, v: f64| c * libm::tanh(v / 1e-3) + b * v;
        let [u1, u2] = u;
        let [tau1, tau2] = self.tau;
        let ax = (u1 - vx - droop(c1, b1, vx)) / tau1;
        let al = (u2 - vl - droop(c2, b2, vl)) / tau2;
        let len = mm.rope(l);
        let vlen = (1.0 + mm.drum_scale) * vl;
        let (s, c) = (libm::sin(phi), libm::cos(phi));
        let f = mm.gust.force(t) / self.m;
        let aphi = (-self.g * s - 2.0 * vphi * vlen - c * ax + c * f) / len;
        [vx, vl, vphi, ax, al, aphi]
    }

    /// Integrates over `dt` (a multiple of [`PLANT_STEP`]) with `u` held.
    pub fn advance(&mut self, u: [f64; 2], dt: f64) {
        let n = libm::round(dt / PLANT_STEP).max(1.0) as usize;
        let h = dt / n as f64;
        for _ in 0..n {
            let y = self.y;
            let t = self.t;
            let add = |a: &[f64; 6], k: &[f64; 6], s: f64| -> [f64; 6] {
                core::array::from_fn(|i| a.get(i).zip(k.get(i)).map_or(0.0, |(a, k)| a + s * k))
            };
            let k1 = self.rhs(t, &y, u);
            let k2 = self.rhs(t + h / 2.0, &add(&y, &k1, h / 2.0), u);
            let k3 = self.rhs(t + h / 2.0, &add(&y, &k2, h / 2.0), u);
            let k4 = self.rhs(t + h, &add(&y, &k3, h), u);
            self.y = core::array::from_fn(|i| {
                let at = |v: &[f64; 6]| v.get(i).copied().unwrap_or(0.0);
                at(&y) + h / 6.0 * (at(&k1) + 2.0 * at(&k2) + 2.0 * at(&k3) + at(&k4))
            });
            self.t += h;
        }
    }

    /// The load position `[x_C, z_C]` (Eq. 27 with the true rope length).
    pub fn load(&self) -> [f64; 2] {
        let [x, l, phi, ..] = self.y;
        let len = self.mismatch.rope(l);
        [x + len * libm::sin(phi), len * libm::cos(phi)]
    }

    /// What the sensors read now: `[x, l_drum, φ]` with noise and quantisation.
    pub fn sense(&mut self) -> [f64; 3] {
        let [x, l, phi, ..] = self.y;
        let (pn, pq) = self.mismatch.position_noise;
        let (an, aq) = self.mismatch.angle_noise;
        let mut q = |v: f64, sigma: f64, quantum: f64| {
            let v = v + sigma * self.noise.normal();
            if quantum > 0.0 {
                libm::round(v / quantum) * quantum
            } else {
                v
            }
        };
        [q(x, pn, pq), q(l, pn, pq), q(phi, an, aq)]
    }
}
