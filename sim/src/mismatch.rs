//! How a simulated crane differs from the controller's model — its drives' lags and
//! loops, friction, the rope's calibration, the load's mass, a gust, its sensors' noise
//! and lag ([`Mismatch`]) — and the seeded generator the studies draw random cases from.
//! Shared by every plant: the virtual bus builds each crane's plant from one `Mismatch`
//! (`crate::simulated::Simulated`), the 3D crane's by [`crate::plant3d::Mismatch3d::from_planar`].

use crate::angle_sensor::SensorLag;

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
    /// Relative error of the load's mass (plant m = model m (1 + this)).
    pub load_mass: f64,
    /// The inclinometer's filter and its delay beyond the positions'.
    pub inclinometer: SensorLag,
    /// The velocity loops of these axes (trolley, winch) have no integral action: P
    /// only, their integral frozen at its start (zero for the trolley, the commissioned
    /// load's weight for the winch).
    pub proportional_only: [bool; 2],
    /// The loops' gains (and a P-only winch's hold) are tuned for the model's load mass,
    /// as commissioned, not for the plant's (module documentation).
    pub loops_for_model_load: bool,
    /// Which of the 3D crane's travel drives take the trolley's errors above when the
    /// virtual bus builds the 3D plant from this mismatch
    /// ([`crate::plant3d::Mismatch3d::from_planar`]); the planar crane has one travel
    /// drive and ignores it.
    pub travel_3d: Travel3d,
}

/// The 3D crane's travel drives that take the planar trolley's errors — its lag
/// ([`Mismatch::tau1`]), friction ([`Mismatch::coulomb`], [`Mismatch::viscous`]) and a
/// loop without integral action ([`Mismatch::proportional_only`]) — so that a study can
/// put them on the 3D crane's trolley as well as on its bridge. The others are exact.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Travel3d {
    /// The bridge (x) alone: the planar crane's trolley becomes the bridge, the 3D
    /// trolley is exact (the planar special case the 3D studies compare).
    Bridge,
    /// The trolley (y) alone.
    Trolley,
    /// Bridge and trolley alike.
    Both,
}

impl Travel3d {
    /// Whether the bridge and the trolley take the errors.
    pub const fn drives(self) -> [bool; 2] {
        match self {
            Self::Bridge => [true, false],
            Self::Trolley => [false, true],
            Self::Both => [true, true],
        }
    }
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
        load_mass: 0.0,
        inclinometer: SensorLag::NONE,
        proportional_only: [false; 2],
        loops_for_model_load: false,
        travel_3d: Travel3d::Bridge,
    };

    /// The sensors of the study: positions 0.2 mm noise, 0.1 mm quantum; the inclinometer
    /// 0.02° noise, 0.01° quantum.
    pub const SENSORS: ((f64, f64), (f64, f64)) = ((2e-4, 1e-4), (3.5e-4, 1.75e-4));

    /// A random case: τ within ±30 %, rope offset within ±2 % of `l0`, drum scaling
    /// within ±2 %, Coulomb friction up to a droop of 10 mm/s on the trolley and 5 mm/s
    /// on the winch, viscous up to 3 %, a gust of up to
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
            coulomb: [rng.uniform(0.0, 0.01), rng.uniform(0.0, 0.005)],
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
            load_mass: 0.0,
            inclinometer: SensorLag::NONE,
            proportional_only: [false; 2],
            loops_for_model_load: false,
            travel_3d: Travel3d::Bridge,
        }
    }

    /// The pendulum's length when the drum measures `l`, m.
    pub fn rope(&self, l: f64) -> f64 {
        rope(self.drum_scale, self.rope_offset, l)
    }

    /// The same crane with the winch's scaling corrected by the rope calibration
    /// `(s, o)` ([`controller::rope`]; [`calibrated`]).
    pub fn calibrated(&self, calibration: (f64, f64)) -> Self {
        let (drum_scale, rope_offset) =
            calibrated((self.drum_scale, self.rope_offset), calibration);
        Self {
            drum_scale,
            rope_offset,
            ..*self
        }
    }
}

/// The pendulum's length when the drum measures `l`, m, for a drum whose scaling is
/// `drum_scale` off and a rope `rope_offset` longer than the drum counts (the planar
/// winch's and the 3D hoist's mismatch alike).
pub fn rope(drum_scale: f64, rope_offset: f64, l: f64) -> f64 {
    (1.0 + drum_scale) * l + rope_offset
}

/// The hoist's `(drum_scale, rope_offset)` once the rope calibration `(s, o)`
/// ([`controller::rope`]) corrects its reading: the reading becomes `(1 + s) l + o`, so
/// the rope is `k (reading − o) + rope_offset` with `k = (1 + drum_scale) / (1 + s)`.
pub fn calibrated((drum_scale, rope_offset): (f64, f64), (s, o): (f64, f64)) -> (f64, f64) {
    let k = (1.0 + drum_scale) / (1.0 + s);
    (k - 1.0, rope_offset - k * o)
}
