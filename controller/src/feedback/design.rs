//! The feedback's design time: the weights and the configuration, the model linearised
//! about the hanging rest and discretised (Eqs. 21–22), and the gains that follow from
//! them by Riccati iteration at the [`GRID`] rope lengths — the LQR gains and the
//! observer's steady-state Kalman gains — computed once at start-up
//! ([`Gains::design`]). What runs every cycle is in the parent module.

use nalgebra::{
    Matrix2, Matrix2x1, Matrix4, Matrix4x1, Matrix4x2, Matrix5, RowVector2, RowVector4, SMatrix,
    Vector2, Vector4,
};

use super::{ObserverGain, SensorGain, SensorModel, AUGMENTED};
use crate::rope::InclinometerLag;
use crate::zero;

/// Number of rope lengths at which gains are designed.
pub const GRID_POINTS: usize = 7;
/// The rope lengths of the design grid, m: the workspace `l ∈ [3, 9] m` of Sec. 3.1.5.
pub const GRID: [f64; GRID_POINTS] = [3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0];

/// The LQR and Kalman weights (Bryson's rule: `1/(acceptable value)²`).
///
/// With feature `serde`, a scene's `[feedback]` keys of the same names (a key left out:
/// [`Weights::DEFAULT`]'s value; an unknown key refused by name).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Deserialize),
    serde(deny_unknown_fields, default = "default_weights")
)]
pub struct Weights {
    /// Acceptable horizontal load-position error `x + l φ`, m.
    pub load_position: f64,
    /// Acceptable trolley position error, m (keeps the trolley near its reference).
    pub trolley_position: f64,
    /// Acceptable swing-rate error `l φ̇` (load velocity relative to the trolley), m/s.
    pub swing_velocity: f64,
    /// Acceptable trolley set-point correction, m/s.
    pub trolley_correction: f64,
    /// Acceptable rope-length error, m.
    pub rope_position: f64,
    /// Acceptable winch set-point correction, m/s.
    pub winch_correction: f64,
    /// Process noise: unmodelled acceleration of trolley and rope (friction), m/s² (1σ).
    pub drive_disturbance: f64,
    /// Process noise: unmodelled angular acceleration of the load (wind), rad/s² (1σ).
    pub swing_disturbance: f64,
    /// Process noise: how fast the drive's velocity offset wanders (a random walk,
    /// m/s per √s, 1σ) — the trolley moving otherwise than the first-order lag of
    /// Eq. 22 says: its velocity loop's friction droop and integral, the rope's pull on
    /// it, the lag's error while it accelerates.
    pub drive_offset: f64,
    /// Position measurement noise, m (1σ).
    pub position_noise: f64,
    /// Angle measurement noise, rad (1σ, quantisation included).
    pub angle_noise: f64,
    /// At rest (the reference still, [`GainPoint::k_rest`]): acceptable horizontal
    /// load-position error `x + l φ`, m.
    pub rest_load_position: f64,
    /// At rest: acceptable trolley position error, m.
    pub rest_trolley_position: f64,
    /// At rest: acceptable swing-rate error `l φ̇` (load velocity relative to the
    /// trolley), m/s.
    pub rest_swing_velocity: f64,
    /// At rest: acceptable velocity of the load over the rail `ẋ + l φ̇`, m/s — the
    /// swing the load keeps when the trolley stops (`v/√(g l)` of amplitude), which is
    /// what the rest hold judges ([`Config::rest_swing`]).
    pub rest_load_velocity: f64,
    /// At rest, once the angle is trusted: the angle's noise the observer is designed
    /// for, rad (1σ; [`GainPoint::obs_rest`]). Above [`Self::angle_noise`]: with the
    /// move's observer the swing rate followed a reading's noise at 2.7 rad/s per rad
    /// (4 m), which the rest's gains turned into 50–85 mm/s of trolley set point per
    /// 0.05° sample, and the trolley hunted on the noise after the move (issue 33).
    pub rest_angle_noise: f64,
}

impl Weights {
    /// Every weight, in the order the struct declares them: what the gain design
    /// checks (each must be positive), and what a scene's test reads back.
    #[must_use]
    pub const fn all(&self) -> [f64; 16] {
        // Destructured, so that a weight added to the struct and not here does not compile.
        let Self {
            load_position,
            trolley_position,
            swing_velocity,
            trolley_correction,
            rope_position,
            winch_correction,
            drive_disturbance,
            swing_disturbance,
            drive_offset,
            position_noise,
            angle_noise,
            rest_load_position,
            rest_trolley_position,
            rest_swing_velocity,
            rest_load_velocity,
            rest_angle_noise,
        } = *self;
        [
            load_position,
            trolley_position,
            swing_velocity,
            trolley_correction,
            rope_position,
            winch_correction,
            drive_disturbance,
            swing_disturbance,
            drive_offset,
            position_noise,
            angle_noise,
            rest_load_position,
            rest_trolley_position,
            rest_swing_velocity,
            rest_load_velocity,
            rest_angle_noise,
        ]
    }

    /// The weights used in the study (`host-tests/src/feedback_study.rs`).
    pub const DEFAULT: Self = Self {
        load_position: 0.02,
        trolley_position: 0.5,
        swing_velocity: 0.05,
        trolley_correction: 0.15,
        rope_position: 0.005,
        winch_correction: 0.05,
        drive_disturbance: 0.5,
        swing_disturbance: 0.1,
        drive_offset: 0.3,
        position_noise: 5e-4,
        angle_noise: 5e-4,
        rest_load_position: 0.03,
        rest_trolley_position: 0.1,
        rest_swing_velocity: 0.1,
        rest_load_velocity: 0.03,
        rest_angle_noise: 3e-3,
    };
}

/// Everything the feedback needs besides the gains.
///
/// With feature `serde`, a scene's `[feedback]` keys of the same names (a key left out:
/// [`Config::PAPER`]'s value; an unknown key refused by name). What a scene does not set
/// here is skipped: the crane's g, τ1, τ2 and the cycle h are the scene's model's and
/// solver's, the inclinometer's lag its commissioning file's, and the weights — keys of
/// the same table in the file — are read as [`Weights`] beside it (serde's `flatten`
/// would lose the key a bad value stands at).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Deserialize),
    serde(deny_unknown_fields, default = "paper_config")
)]
pub struct Config {
    /// The weights the gains are designed from.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub weights: Weights,
    /// Gravity, m/s² (Tab. 3).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub g: f64,
    /// Trolley actuator time constant τ1 of the model, s (Tab. 3).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub tau1: f64,
    /// Winch actuator time constant τ2 of the model, s (Tab. 3).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub tau2: f64,
    /// Cycle period h, s.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub h: f64,
    /// A measured angle beyond this is implausible, rad.
    pub max_angle: f64,
    /// A measured angle further than this from the observer's prediction is implausible, rad.
    pub max_innovation: f64,
    /// Consecutive cycles with a missing or implausible angle tolerated before the
    /// angle is no longer read ([`super::Mode::SwingEstimated`]). A scene's
    /// `bridged_cycles`.
    #[cfg_attr(feature = "serde", serde(rename = "bridged_cycles"))]
    pub max_bad_angle_cycles: u32,
    /// A stuck sensor: the angle has not changed by a single quantum for this many
    /// cycles … (a scene's `frozen_cycles`)
    #[cfg_attr(feature = "serde", serde(rename = "frozen_cycles"))]
    pub max_frozen_cycles: u32,
    /// … while what the crane's own motion makes the angle do (the observer run on the
    /// drives' positions alone, from the moment the reading stopped changing) moved it
    /// by more than this, rad. A quiet load may legitimately read the same value at rest
    /// or at constant speed; an angle that stays put while the trolley accelerates under
    /// it cannot.
    pub frozen_motion: f64,
    /// While the reading has not changed since the last cycle (it may be stuck), the
    /// trolley's correction may grow by at most this beyond what it was when the reading
    /// last changed, m/s: a reading that does not move cannot make the feedback push
    /// harder, so a stuck angle can do little before it is caught.
    pub held_allowance: f64,
    /// At rest (the reference still; the travel's part of it for the trolley, which is
    /// let go while only the hoist moves too), the feedback lets go — set points exactly
    /// the inverse model's, zero — once the estimated load is within this of its
    /// reference horizontally (the trolley) and in rope length (the hoist, standing
    /// still), m, …
    pub rest_position: f64,
    /// … and the estimated swing amplitude is below this, rad (both for 0.1 s, ten
    /// samples at 100 Hz). It takes hold again when the load's place or the amplitude's square
    /// averaged over about a period exceeds [`Config::rest_hysteresis`] times either
    /// (so it does not chatter), or the reference moves.
    pub rest_swing: f64,
    /// How far beyond [`Config::rest_position`] or [`Config::rest_swing`] a crane let go
    /// must be disturbed for the feedback to take hold again (≥ 1).
    pub rest_hysteresis: f64,
    /// The inclinometer's offset check ([`crate::zero`]): an offset within this is left
    /// in the reading, rad ([`zero::DEAD_BAND`], the default).
    pub offset_dead_band: f64,
    /// A reading further than this from the observer's prediction (and within
    /// [`Config::max_innovation`]) in [`zero::STEP_CYCLES`] readings in a row, the same
    /// way, is a step of the zero, rad ([`zero::MAX_STEP`]).
    pub offset_step: f64,
    /// An offset beyond this, rad ([`zero::MAX_OFFSET`]) …
    pub max_offset: f64,
    /// … for this many cycles in a row is announced ([`zero::OFFSET_CYCLES`]).
    pub offset_cycles: u32,
    /// How late and how filtered the inclinometer reports the angle, as commissioned
    /// (the commissioning file's `[inclinometer]` `delay_cycles` and `filter_ms`): the
    /// rope calibration makes the positions as late before it pairs them with the
    /// angle ([`crate::rope`]); the observer has the filter and the delay line as states
    /// ([`super::SensorStates`]).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub inclinometer: InclinometerLag,
}

/// Serde's value of a `[feedback]` weight a scene leaves out: the study's.
#[cfg(feature = "serde")]
fn default_weights() -> Weights {
    Weights::DEFAULT
}

/// Serde's value of a [`Config`] field a scene leaves out (or cannot set): the paper's.
#[cfg(feature = "serde")]
fn paper_config() -> Config {
    Config::PAPER
}

impl Config {
    /// How far the load's place and its swing amplitude must be off for the estimate to
    /// hold a crane the feedback let go, (m, rad): [`Config::rest_hysteresis`] times
    /// [`Config::rest_position`] and [`Config::rest_swing`].
    #[must_use]
    pub fn hold_thresholds(&self) -> (f64, f64) {
        (
            self.rest_hysteresis * self.rest_position,
            self.rest_hysteresis * self.rest_swing,
        )
    }

    /// The offset check's thresholds.
    #[must_use]
    pub fn zero_thresholds(&self) -> zero::Thresholds {
        zero::Thresholds {
            dead_band: self.offset_dead_band,
            max_step: self.offset_step,
            max_offset: self.max_offset,
            offset_cycles: self.offset_cycles,
        }
    }
}

impl Config {
    /// The paper's crane (Tab. 3) at h = 10 ms with [`Weights::DEFAULT`]; the angle is
    /// implausible beyond 20° (the paper's move swings the load by up to 14° under the
    /// feedback, more with a swinging start) or 2° off the prediction; 3 cycles (30 ms) are bridged; a
    /// reading unchanged for 3 cycles while the crane's motion should have moved it by
    /// 0.1° is stuck; the feedback lets go at rest within 20 mm and 0.06° (held again
    /// at 33 mm or 0.0995°, the study's 0.1° target: a swing let go is not damped
    /// again, so the threshold is the target less the estimate's error at the moment it
    /// lets go, a few hundredths of a degree; at 0.08° 3 % of the study's cases were
    /// let go with a swing of 0.10–0.16° and held again, issue 18); the
    /// offset check at its defaults ([`zero::Thresholds::DEFAULT`]).
    pub const PAPER: Self = Self {
        weights: Weights::DEFAULT,
        g: 9.81,
        tau1: 0.03,
        tau2: 0.02,
        h: 0.01,
        max_angle: 0.35,
        max_innovation: 0.035,
        max_bad_angle_cycles: 3,
        max_frozen_cycles: 3,
        frozen_motion: 0.00175,
        held_allowance: 0.02,
        rest_position: 0.02,
        rest_swing: 0.00105,
        rest_hysteresis: 1.65,
        offset_dead_band: zero::DEAD_BAND,
        offset_step: zero::MAX_STEP,
        max_offset: zero::MAX_OFFSET,
        offset_cycles: zero::OFFSET_CYCLES,
        inclinometer: InclinometerLag::NONE,
    };
}

/// Why the gains could not be designed.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DesignError {
    /// A weight, time constant or period is not finite and positive.
    BadParameter,
    /// The Riccati iteration did not converge at this rope length, m.
    NoConvergence {
        /// Rope length, m.
        l: f64,
    },
}

/// The discrete model of one rope length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Discrete {
    /// Trolley–swing transition, state `[x, ẋ, φ, φ̇]`.
    pub a: Matrix4<f64>,
    /// Trolley–swing input (δu1).
    pub b: Matrix4x1<f64>,
    /// Winch transition, state `[l, l̇]`.
    pub aw: Matrix2<f64>,
    /// Winch input (δu2).
    pub bw: Matrix2x1<f64>,
}

/// The continuous linearisation of Eqs. 21–22 at rest at rope length `l`:
/// `(A, B)` of the trolley–swing block and `(A_w, B_w)` of the winch.
#[must_use]
pub fn linearise(
    g: f64,
    tau1: f64,
    tau2: f64,
    l: f64,
) -> (Matrix4<f64>, Matrix4x1<f64>, Matrix2<f64>, Matrix2x1<f64>) {
    #[rustfmt::skip]
    let a = Matrix4::new(
        0.0, 1.0, 0.0, 0.0,
        0.0, -1.0 / tau1, 0.0, 0.0,
        0.0, 0.0, 0.0, 1.0,
        0.0, 1.0 / (tau1 * l), -g / l, 0.0,
    );
    let b = Matrix4x1::new(0.0, 1.0 / tau1, 0.0, -1.0 / (tau1 * l));
    let aw = Matrix2::new(0.0, 1.0, 0.0, -1.0 / tau2);
    let bw = Matrix2x1::new(0.0, 1.0 / tau2);
    (a, b, aw, bw)
}

/// `exp(A h)` and `∫₀ʰ exp(A s) ds · B` by their Taylor series (`‖A‖h < 1` here: 20 terms
/// reach rounding).
fn zoh<const N: usize>(
    a: SMatrix<f64, N, N>,
    b: SMatrix<f64, N, 1>,
    h: f64,
) -> (SMatrix<f64, N, N>, SMatrix<f64, N, 1>) {
    let mut phi = SMatrix::<f64, N, N>::identity();
    let mut int = SMatrix::<f64, N, N>::identity() * h;
    let mut term = SMatrix::<f64, N, N>::identity();
    for k in 1..25 {
        term = term * a * (h / f64::from(k));
        phi += term;
        int += term * (h / f64::from(k + 1));
    }
    (phi, int * b)
}

/// The zero-order-hold discretisation of [`linearise`] with period `h`.
#[must_use]
pub fn discretise(g: f64, tau1: f64, tau2: f64, l: f64, h: f64) -> Discrete {
    let (a, b, aw, bw) = linearise(g, tau1, tau2, l);
    let (a, b) = zoh(a, b, h);
    let (aw, bw) = zoh(aw, bw, h);
    Discrete { a, b, aw, bw }
}

const RICCATI_ITERATIONS: usize = 20_000;
const RICCATI_TOL: f64 = 1e-11;

/// LQR gain of a single-input system by iterating the discrete Riccati equation.
fn lqr<const N: usize>(
    a: SMatrix<f64, N, N>,
    b: SMatrix<f64, N, 1>,
    q: SMatrix<f64, N, N>,
    r: f64,
) -> Option<SMatrix<f64, 1, N>> {
    let mut s = q;
    for _ in 0..RICCATI_ITERATIONS {
        let bs = b.transpose() * s;
        let denom = r + (bs * b).x;
        if !(denom.is_finite() && denom > 0.0) {
            return None;
        }
        let k = (bs * a) / denom;
        let next = q + a.transpose() * s * (a - b * k);
        let next = (next + next.transpose()) * 0.5;
        let change = (next - s).abs().max();
        let size = next.abs().max();
        s = next;
        if !size.is_finite() {
            return None;
        }
        if change <= RICCATI_TOL * size {
            let bs = b.transpose() * s;
            return Some((bs * a) / (r + (bs * b).x));
        }
    }
    None
}

/// Steady-state Kalman gain (filter form, `x̂ += L (y − C x̂)`) of `x' = A x + w`,
/// `y = C x + v`, with process and measurement noise covariances `qw`, `rv`.
fn kalman<const N: usize, const M: usize>(
    a: SMatrix<f64, N, N>,
    c: SMatrix<f64, M, N>,
    qw: SMatrix<f64, N, N>,
    rv: SMatrix<f64, M, M>,
) -> Option<SMatrix<f64, N, M>> {
    let mut p = qw;
    for _ in 0..RICCATI_ITERATIONS {
        let sinv = (c * p * c.transpose() + rv).try_inverse()?;
        let gain = p * c.transpose() * sinv;
        let posterior = p - gain * c * p;
        let next = a * posterior * a.transpose() + qw;
        let next = (next + next.transpose()) * 0.5;
        let change = (next - p).abs().max();
        let size = next.abs().max();
        p = next;
        if !size.is_finite() {
            return None;
        }
        if change <= RICCATI_TOL * size {
            let sinv = (c * p * c.transpose() + rv).try_inverse()?;
            return Some(p * c.transpose() * sinv);
        }
    }
    None
}

/// The steady-state Kalman gain of the trolley–swing block `a5` (process noise `qn`,
/// measurement noise `rv` of `x` and the reading) with the inclinometer's states
/// appended ([`super::SensorStates`]): `y' = a y + b₀ φ' + b₁ φ` (so the swing's process noise
/// reaches the filter through `b₀`), the line shifting `y` in, the reading entry
/// [`SensorModel::delay`] of it. Split into the error's and the sensor's rows.
fn augmented_kalman(
    a5: &Matrix5<f64>,
    qn: &Matrix5<f64>,
    rv: &Matrix2<f64>,
    sensor: &SensorModel,
) -> Option<(ObserverGain, SensorGain)> {
    const PHI: usize = 2;
    let at5 = |m: &Matrix5<f64>, i: usize, j: usize| m.get((i, j)).copied().unwrap_or(0.0);
    let a = SMatrix::<f64, AUGMENTED, AUGMENTED>::from_fn(|i, j| match (i, j) {
        (i, j) if i < 5 && j < 5 => at5(a5, i, j),
        (i, _) if i < 5 => 0.0,
        // The filter: b₀ times the predicted angle, b₁ times the angle now.
        (5, j) if j < 5 => sensor.b0 * at5(a5, PHI, j) + if j == PHI { sensor.b1 } else { 0.0 },
        (5, 5) => sensor.a,
        (5, _) => 0.0,
        // The line: entry i takes entry i − 1.
        (i, j) => {
            if j + 1 == i {
                1.0
            } else {
                0.0
            }
        }
    });
    // The process noise enters the error, and the filter through the angle's.
    let t = SMatrix::<f64, AUGMENTED, 5>::from_fn(|i, j| match (i, j) {
        (i, j) if i == j => 1.0,
        (5, PHI) => sensor.b0,
        _ => 0.0,
    });
    let q = t * qn * t.transpose() + SMatrix::<f64, AUGMENTED, AUGMENTED>::identity() * 1e-14;
    let c = SMatrix::<f64, 2, AUGMENTED>::from_fn(|i, j| match (i, j) {
        (0, 0) => 1.0,
        (1, j) if j == 5 + sensor.delay => 1.0,
        _ => 0.0,
    });
    let gain = kalman(a, c, q, *rv)?;
    let at = |i: usize, j: usize| gain.get((i, j)).copied().unwrap_or(0.0);
    Some((
        ObserverGain::from_fn(&at),
        SensorGain::from_fn(|i, j| at(i + 5, j)),
    ))
}

/// The gains at one rope length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GainPoint {
    /// Rope length, m.
    pub l: f64,
    /// Trolley state feedback `δu1 = −k · [x, ẋ, φ, φ̇]`.
    pub k: RowVector4<f64>,
    /// Trolley state feedback at rest (the reference still), designed from the rest's
    /// weights ([`Weights::rest_load_velocity`]): damping the swing fast is what is
    /// left to do, not following a path.
    pub k_rest: RowVector4<f64>,
    /// Winch state feedback `δu2 = −k_w · [l, l̇]`.
    pub kw: RowVector2<f64>,
    /// Observer gain of the trolley–swing block and the drive's velocity offset
    /// (measured `x`, `φ`).
    pub obs: ObserverGain,
    /// Observer gain of the inclinometer's filter and delay line (measured `x`, `φ`):
    /// designed with [`Self::obs`] as one Kalman filter (issue 33).
    pub obs_sensor: SensorGain,
    /// With the travel at rest (the hoist may move) and the angle trusted, [`Self::obs`] and
    /// [`Self::obs_sensor`] designed for the angle's noise at rest
    /// ([`Weights::rest_angle_noise`]): a swing to damp, no path to follow, so the
    /// reading's noise need not be followed as closely.
    pub obs_rest: ObserverGain,
    /// See [`Self::obs_rest`].
    pub obs_sensor_rest: SensorGain,
    /// Observer gain of the winch block (measured `l`).
    pub obs_w: Matrix2x1<f64>,
    /// The discrete model the gains were designed for.
    pub model: Discrete,
}

/// The gain table over [`GRID`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    /// One point per rope length of [`GRID`].
    pub points: [GainPoint; GRID_POINTS],
}

fn positive(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

impl Gains {
    /// Designs LQR and Kalman gains at every rope length of [`GRID`] for the crane of
    /// Eqs. 21–22 (with τ1, τ2) linearised at rest, discretised with period `h`.
    pub fn design(cfg: &Config) -> Result<Self, DesignError> {
        let crane = [cfg.g, cfg.tau1, cfg.tau2, cfg.h];
        if !cfg.weights.all().iter().chain(&crane).all(|v| positive(*v)) {
            return Err(DesignError::BadParameter);
        }
        let mut points = [GainPoint {
            l: 0.0,
            k: RowVector4::zeros(),
            k_rest: RowVector4::zeros(),
            kw: RowVector2::zeros(),
            obs: ObserverGain::zeros(),
            obs_sensor: SensorGain::zeros(),
            obs_rest: ObserverGain::zeros(),
            obs_sensor_rest: SensorGain::zeros(),
            obs_w: Matrix2x1::zeros(),
            model: discretise(cfg.g, cfg.tau1, cfg.tau2, 1.0, cfg.h),
        }; GRID_POINTS];
        for (point, &l) in points.iter_mut().zip(GRID.iter()) {
            *point = Self::design_at(cfg, l)?;
        }
        Ok(Self { points })
    }

    /// The gains at one rope length `l`.
    pub fn design_at(cfg: &Config, l: f64) -> Result<GainPoint, DesignError> {
        let w = &cfg.weights;
        let model = discretise(cfg.g, cfg.tau1, cfg.tau2, l, cfg.h);
        let sq = |v: f64| 1.0 / (v * v);
        // Load position x + lφ, trolley position x, load velocity relative to trolley lφ̇.
        let load = RowVector4::new(1.0, 0.0, l, 0.0);
        let q = load.transpose() * load * sq(w.load_position)
            + Matrix4::from_diagonal(&Vector4::new(
                sq(w.trolley_position),
                0.0,
                0.0,
                sq(w.swing_velocity) * l * l,
            ));
        let k = lqr(model.a, model.b, q, sq(w.trolley_correction))
            .ok_or(DesignError::NoConvergence { l })?;
        // At rest the same, with the rest's own weights and the load's velocity over
        // the rail ẋ + lφ̇: the swing the load keeps when the trolley stops.
        let over_rail = RowVector4::new(0.0, 1.0, 0.0, l);
        let q_rest = load.transpose() * load * sq(w.rest_load_position)
            + over_rail.transpose() * over_rail * sq(w.rest_load_velocity)
            + Matrix4::from_diagonal(&Vector4::new(
                sq(w.rest_trolley_position),
                0.0,
                0.0,
                sq(w.rest_swing_velocity) * l * l,
            ));
        let k_rest = lqr(model.a, model.b, q_rest, sq(w.trolley_correction))
            .ok_or(DesignError::NoConvergence { l })?;
        let qw = Matrix2::from_diagonal(&Vector2::new(sq(w.rope_position), 0.0));
        let kw = lqr(model.aw, model.bw, qw, sq(w.winch_correction))
            .ok_or(DesignError::NoConvergence { l })?;
        // Process noise enters as accelerations over one period.
        let (h, dd, ds) = (cfg.h, w.drive_disturbance, w.swing_disturbance);
        let g4 = Matrix4x2::new(0.5 * h * h, 0.0, h, 0.0, 0.0, 0.5 * h * h, 0.0, h);
        let noise = Matrix2::from_diagonal(&Vector2::new(dd * dd, ds * ds));
        let q4 = g4 * noise * g4.transpose();
        let sd = w.drive_offset;
        let qn = Matrix5::from_fn(|i, j| match (i, j) {
            (4, 4) => sd * sd * h,
            (i, j) if i < 4 && j < 4 => q4.get((i, j)).copied().unwrap_or(0.0),
            _ => 0.0,
        }) + Matrix5::identity() * 1e-14;
        // The drive's offset d enters as the set point does.
        let a5 = Matrix5::from_fn(|i, j| match (i, j) {
            (4, 4) => 1.0,
            (i, 4) => model.b.get(i).copied().unwrap_or(0.0),
            (i, j) if i < 4 && j < 4 => model.a.get((i, j)).copied().unwrap_or(0.0),
            _ => 0.0,
        });
        let rv = Matrix2::from_diagonal(&Vector2::new(
            w.position_noise * w.position_noise,
            w.angle_noise * w.angle_noise,
        ));
        // The trolley–swing block is measured in x and φ, the winch block in l; the
        // angle as the inclinometer reports it: through its filter and its delay line,
        // states of the observer ([`SensorStates`], issue 33). The first-order model
        // `φ − T φ̇` it replaces was right at the swing's frequency, not at the
        // noise's: the trolley chattered at 3.5 Hz on it after the move.
        let sensor = SensorModel::of(cfg);
        let (obs, obs_sensor) =
            augmented_kalman(&a5, &qn, &rv, &sensor).ok_or(DesignError::NoConvergence { l })?;
        let rv_rest = Matrix2::from_diagonal(&Vector2::new(
            w.position_noise * w.position_noise,
            w.rest_angle_noise * w.rest_angle_noise,
        ));
        let (obs_rest, obs_sensor_rest) = augmented_kalman(&a5, &qn, &rv_rest, &sensor)
            .ok_or(DesignError::NoConvergence { l })?;
        let g2 = Vector2::new(0.5 * h * h, h);
        let qn2 = g2 * g2.transpose() * (dd * dd) + Matrix2::identity() * 1e-14;
        let rv_w = SMatrix::<f64, 1, 1>::new(w.position_noise * w.position_noise);
        let obs_w = kalman(model.aw, RowVector2::new(1.0, 0.0), qn2, rv_w)
            .ok_or(DesignError::NoConvergence { l })?;
        Ok(GainPoint {
            l,
            k,
            k_rest,
            kw,
            obs,
            obs_sensor,
            obs_rest,
            obs_sensor_rest,
            obs_w,
            model,
        })
    }

    /// The gains at rope length `l`, interpolated linearly between the grid points
    /// (held constant outside [`GRID`]).
    #[must_use]
    pub fn at(&self, l: f64) -> GainPoint {
        let first = self.points.first().copied();
        let last = self.points.last().copied();
        let (Some(first), Some(last)) = (first, last) else {
            // Unreachable: GRID_POINTS > 0. Zero gains are the safe answer.
            return GainPoint {
                l,
                k: RowVector4::zeros(),
                k_rest: RowVector4::zeros(),
                kw: RowVector2::zeros(),
                obs: ObserverGain::zeros(),
                obs_sensor: SensorGain::zeros(),
                obs_rest: ObserverGain::zeros(),
                obs_sensor_rest: SensorGain::zeros(),
                obs_w: Matrix2x1::zeros(),
                model: discretise(9.81, 0.03, 0.02, l.max(1.0), 0.01),
            };
        };
        if l.is_nan() || l <= first.l {
            return first;
        }
        for (p, q) in self.points.iter().zip(self.points.iter().skip(1)) {
            if l <= q.l {
                let s = (l - p.l) / (q.l - p.l);
                let mix = |a: f64, b: f64| a + (b - a) * s;
                return GainPoint {
                    l,
                    k: p.k.zip_map(&q.k, mix),
                    k_rest: p.k_rest.zip_map(&q.k_rest, mix),
                    kw: p.kw.zip_map(&q.kw, mix),
                    obs: p.obs.zip_map(&q.obs, mix),
                    obs_sensor: p.obs_sensor.zip_map(&q.obs_sensor, mix),
                    obs_rest: p.obs_rest.zip_map(&q.obs_rest, mix),
                    obs_sensor_rest: p.obs_sensor_rest.zip_map(&q.obs_sensor_rest, mix),
                    obs_w: p.obs_w.zip_map(&q.obs_w, mix),
                    model: Discrete {
                        a: p.model.a.zip_map(&q.model.a, mix),
                        b: p.model.b.zip_map(&q.model.b, mix),
                        aw: p.model.aw.zip_map(&q.model.aw, mix),
                        bw: p.model.bw.zip_map(&q.model.bw, mix),
                    },
                };
            }
        }
        last
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use nalgebra::RowVector4;

    #[test]
    fn gains_interpolate_and_clamp() {
        let g = Gains::design(&Config::PAPER).unwrap();
        assert_eq!(g.at(2.0).k, g.points[0].k);
        assert_eq!(g.at(10.0).k, g.points[6].k);
        let mid = g.at(3.5).k;
        let expect = (g.points[0].k + g.points[1].k) * 0.5;
        assert!((mid - expect).abs().max() < 1e-12);
    }

    #[test]
    fn bad_weights_are_refused() {
        let mut cfg = Config::PAPER;
        cfg.weights.load_position = 0.0;
        assert_eq!(Gains::design(&cfg), Err(DesignError::BadParameter));
        cfg = Config::PAPER;
        cfg.h = f64::NAN;
        assert_eq!(Gains::design(&cfg), Err(DesignError::BadParameter));
        cfg = Config::PAPER;
        cfg.weights.drive_offset = f64::INFINITY;
        assert_eq!(Gains::design(&cfg), Err(DesignError::BadParameter));
        cfg = Config::PAPER;
        cfg.weights.rest_load_velocity = 0.0;
        assert_eq!(Gains::design(&cfg), Err(DesignError::BadParameter));
    }

    #[test]
    fn at_rest_the_swing_is_damped_faster_than_during_a_move() {
        // The slowest mode of the nominal closed loop (model and gains at the same rope
        // length): its decay rate, 1/s. During a move the load follows its path; at
        // rest damping the swing is all that is left, and the rest's weights (the
        // load's velocity over the rail among them) keep it at 1.04 /s over the whole
        // rope range, where the move's falls from 0.98 /s at 3 m to 0.68 /s at 9 m
        // (issue 18: that left the long ropes' swing after a late gust above the rest
        // hold's 0.06° 5 s after the move).
        let g = Gains::design(&Config::PAPER).unwrap();
        let rate = |p: &GainPoint, k: &RowVector4<f64>| {
            let m = p.model.a - p.model.b * k;
            let rho = m
                .complex_eigenvalues()
                .iter()
                .map(|z| z.re.hypot(z.im))
                .fold(0.0, f64::max);
            -libm::log(rho) / Config::PAPER.h
        };
        for p in &g.points {
            let (moving, rest) = (rate(p, &p.k), rate(p, &p.k_rest));
            std::eprintln!(
                "l = {} m: the slowest mode decays at {moving:.2} /s moving, {rest:.2} /s at rest",
                p.l
            );
            let faster = if p.l >= 6.0 { 1.3 } else { 1.0 };
            assert!(
                rest > faster * moving && rest > 1.0,
                "l = {}: {moving:.2} /s moving, {rest:.2} /s at rest",
                p.l
            );
        }
    }
}
