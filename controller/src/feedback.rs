//! State feedback around the inverse model's reference: the second degree of freedom
//! of the paper's Fig. 1.
//!
//! The inverse model (Eqs. 24–28, *subs*) gives the feedforward `u_d` and the reference
//! state `y_d, v_d`; the paper's experiments end with a residual swing of ≈ 0.3° and
//! note that "any errors can be further minimized by adding a state feedback
//! controller" (Sec. 3.1.5). This module is that controller:
//!
//! * **Model.** Eqs. 21–22 linearised about the hanging rest (`φ = 0`, `l̇ = 0`) at rope
//!   length `l`, *with* the actuator lags τ1, τ2. They split into the trolley–swing
//!   block, error state `e = [x, ẋ, φ, φ̇]`,
//!   `ẍ = (u1 − ẋ)/τ1`, `φ̈ = (−g φ − ẍ)/l` (rows 1 and 3 of Eq. 22), and the winch
//!   block `[l, l̇]`, `l̈ = (u2 − l̇)/τ2` (row 2). Both are discretised exactly for the
//!   zero-order-held set points of period `h`.
//! * **Why scheduled LQR, not a closed form.** The swing frequency `√(g/l)` varies by
//!   a factor 1.7 over `l ∈ [3, 9] m` (Sec. 3.1.5) and the 30 ms trolley lag is not
//!   negligible against the 10 ms cycle and the 10 ms late measurement: a closed-form
//!   pole placement for the 4th-order block with lag and delay is long and brittle,
//!   while a discrete LQR (and its dual, a steady-state Kalman filter) handles lag,
//!   delay and sampling exactly and is tuned by physically meaningful weights
//!   (Bryson's rule: one over the square of the acceptable error). The gains are
//!   designed from the [`Weights`] once, at start-up, by Riccati iteration at
//!   [`GRID`] rope lengths ([`Gains::design`], a few ms on the MCU) and interpolated
//!   linearly in `l` every cycle — weights are data (a scene or commissioning file can
//!   fill them), gains follow from them.
//! * **Angle rate, noise and delay.** The inclinometer gives the angle only, quantised,
//!   noisy and one cycle late; the drives give positions only. A predictor-form
//!   observer on the error state (steady-state Kalman gain, scheduled like the LQR
//!   gains) corrects the estimate of the *previous* sample with the late measurement
//!   and predicts it to now with the set-point deviation actually sent: the swing rate
//!   is estimated from the model, not differentiated.
//! * **Anti-windup.** `u_d + δu` is clamped to the velocity limit and to the change the
//!   acceleration limit allows from the last set point ([`clamp_to_limits`]), i.e.
//!   exactly what [`crate::setpoint::SetpointGate::admit`] accepts; the observer is
//!   fed the deviation actually sent, so its state never winds up on a saturated drive.
//! * **Degraded mode.** [`degraded_rule`]: the angle missing or implausible for more
//!   than [`Config::max_bad_angle_cycles`] cycles, or the positions not finite →
//!   feedforward only, announced by [`Mode::FeedforwardOnly`] with its reason, latched
//!   until [`StateFeedback::reset`] (a new observer start needs the crane at rest).
//!   Set points stay continuous: the correction is removed within the acceleration
//!   limit. Stopping is left to the controller's existing reactions (a lost drive
//!   quick-stops both).
//!
//! Everything is `no_std`, allocation-free and panic-free: fixed-size nalgebra
//! matrices, no indexing.

use nalgebra::{
    Matrix2, Matrix2x1, Matrix4, Matrix4x1, Matrix4x2, RowVector2, RowVector4, SMatrix, Vector2,
    Vector4,
};

use crate::setpoint::{AxisLimits, DriveLimits};

/// Number of rope lengths at which gains are designed.
pub const GRID_POINTS: usize = 7;
/// The rope lengths of the design grid, m: the workspace `l ∈ [3, 9] m` of Sec. 3.1.5.
pub const GRID: [f64; GRID_POINTS] = [3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0];

/// The LQR and Kalman weights (Bryson's rule: `1/(acceptable value)²`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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
    /// Position measurement noise, m (1σ).
    pub position_noise: f64,
    /// Angle measurement noise, rad (1σ, quantisation included).
    pub angle_noise: f64,
}

impl Weights {
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
        position_noise: 5e-4,
        angle_noise: 5e-4,
    };
}

/// Everything the feedback needs besides the gains.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// The weights the gains are designed from.
    pub weights: Weights,
    /// Gravity, m/s² (Tab. 3).
    pub g: f64,
    /// Trolley actuator time constant τ1 of the model, s (Tab. 3).
    pub tau1: f64,
    /// Winch actuator time constant τ2 of the model, s (Tab. 3).
    pub tau2: f64,
    /// Cycle period h, s.
    pub h: f64,
    /// A measured angle beyond this is implausible, rad.
    pub max_angle: f64,
    /// A measured angle further than this from the observer's prediction is implausible, rad.
    pub max_innovation: f64,
    /// Consecutive cycles with a missing or implausible angle tolerated before the
    /// feedback is switched off.
    pub max_bad_angle_cycles: u32,
    /// A stuck sensor: the angle has not changed by a single quantum for this many
    /// cycles …
    pub max_frozen_cycles: u32,
    /// … while the reference angle moved by more than this, rad. (At rest a quiet
    /// sensor may legitimately read the same value; during a move it cannot.)
    pub frozen_motion: f64,
}

impl Config {
    /// The paper's crane (Tab. 3) at h = 10 ms with [`Weights::DEFAULT`]; the angle is
    /// implausible beyond 15° or 2° off the prediction; 3 cycles (30 ms) are bridged.
    pub const PAPER: Self = Self {
        weights: Weights::DEFAULT,
        g: 9.81,
        tau1: 0.03,
        tau2: 0.02,
        h: 0.01,
        max_angle: 0.26,
        max_innovation: 0.035,
        max_bad_angle_cycles: 3,
        max_frozen_cycles: 50,
        frozen_motion: 0.0087,
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

/// The gains at one rope length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GainPoint {
    /// Rope length, m.
    pub l: f64,
    /// Trolley state feedback `δu1 = −k · [x, ẋ, φ, φ̇]`.
    pub k: RowVector4<f64>,
    /// Winch state feedback `δu2 = −k_w · [l, l̇]`.
    pub kw: RowVector2<f64>,
    /// Observer gain of the trolley–swing block (measured `x`, `φ`).
    pub obs: Matrix4x2<f64>,
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
        let w = &cfg.weights;
        let all = [
            w.load_position,
            w.trolley_position,
            w.swing_velocity,
            w.trolley_correction,
            w.rope_position,
            w.winch_correction,
            w.drive_disturbance,
            w.swing_disturbance,
            w.position_noise,
            w.angle_noise,
            cfg.g,
            cfg.tau1,
            cfg.tau2,
            cfg.h,
        ];
        if !all.iter().all(|v| positive(*v)) {
            return Err(DesignError::BadParameter);
        }
        let mut points = [GainPoint {
            l: 0.0,
            k: RowVector4::zeros(),
            kw: RowVector2::zeros(),
            obs: Matrix4x2::zeros(),
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
        let qw = Matrix2::from_diagonal(&Vector2::new(sq(w.rope_position), 0.0));
        let kw = lqr(model.aw, model.bw, qw, sq(w.winch_correction))
            .ok_or(DesignError::NoConvergence { l })?;
        // Process noise enters as accelerations over one period.
        let (h, dd, ds) = (cfg.h, w.drive_disturbance, w.swing_disturbance);
        let g4 = Matrix4x2::new(0.5 * h * h, 0.0, h, 0.0, 0.0, 0.5 * h * h, 0.0, h);
        let noise = Matrix2::from_diagonal(&Vector2::new(dd * dd, ds * ds));
        let qn = g4 * noise * g4.transpose() + Matrix4::identity() * 1e-14;
        let rv = Matrix2::from_diagonal(&Vector2::new(
            w.position_noise * w.position_noise,
            w.angle_noise * w.angle_noise,
        ));
        // The trolley–swing block is measured in x and φ, the winch block in l.
        #[rustfmt::skip]
        let c = nalgebra::Matrix2x4::new(
            1.0, 0.0, 0.0, 0.0,
            0.0, 0.0, 1.0, 0.0,
        );
        let obs = kalman(model.a, c, qn, rv).ok_or(DesignError::NoConvergence { l })?;
        let g2 = Vector2::new(0.5 * h * h, h);
        let qn2 = g2 * g2.transpose() * (dd * dd) + Matrix2::identity() * 1e-14;
        let rv_w = SMatrix::<f64, 1, 1>::new(w.position_noise * w.position_noise);
        let obs_w = kalman(model.aw, RowVector2::new(1.0, 0.0), qn2, rv_w)
            .ok_or(DesignError::NoConvergence { l })?;
        Ok(GainPoint {
            l,
            k,
            kw,
            obs,
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
                kw: RowVector2::zeros(),
                obs: Matrix4x2::zeros(),
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
                    kw: p.kw.zip_map(&q.kw, mix),
                    obs: p.obs.zip_map(&q.obs, mix),
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

/// The reference state from the inverse model's solution, in the coordinates of Eq. 20.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reference {
    /// Trolley position x_d, m.
    pub x: f64,
    /// Rope length l_d, m.
    pub l: f64,
    /// Swing angle φ_d, rad.
    pub phi: f64,
    /// ẋ_d, m/s.
    pub vx: f64,
    /// l̇_d, m/s.
    pub vl: f64,
    /// φ̇_d, rad/s.
    pub vphi: f64,
}

impl Reference {
    /// From the *subs* solution `[x, l, ẋ, l̇]` (the first four unknowns of
    /// `solver_core::models::crane_subs`) and the desired load position and velocity
    /// `z_d, ż_d` (Eq. 28): `φ = atan2(x_C − x, z_C)` (Eq. 27), and its rate.
    #[must_use]
    pub fn from_subs(subs: [f64; 4], load: [f64; 2], load_rate: [f64; 2]) -> Self {
        let [x, l, vx, vl] = subs;
        let [xc, zc] = load;
        let [vxc, vzc] = load_rate;
        let dx = xc - x;
        let r2 = dx * dx + zc * zc;
        let vphi = if r2 > 0.0 {
            ((vxc - vx) * zc - dx * vzc) / r2
        } else {
            0.0
        };
        Self {
            x,
            l,
            phi: libm::atan2(dx, zc),
            vx,
            vl,
            vphi,
        }
    }
}

/// One sample of the measurements, taken one cycle before it is used (the drives' and
/// the inclinometer's TPDOs are sampled at SYNC and arrive within the next cycle).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Measurement {
    /// Trolley position (0x6064), m.
    pub x: f64,
    /// Rope length (winch 0x6064 through the drum scaling), m.
    pub l: f64,
    /// Swing angle from the inclinometer, rad; `None` when no fresh value arrived.
    pub phi: Option<f64>,
}

/// Why the feedback is off.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Degraded {
    /// No angle for more than the tolerated cycles.
    AngleLost,
    /// The angle out of range or too far from the prediction for more than the tolerated cycles.
    AngleImplausible,
    /// A position is not finite.
    PositionsInvalid,
}

/// What the feedback is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Feedforward plus state feedback.
    Closed,
    /// Feedforward only, with the reason (latched until [`StateFeedback::reset`]).
    FeedforwardOnly(Degraded),
}

/// How this cycle's angle looks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AngleCheck {
    /// Usable.
    Good,
    /// Missing.
    Missing,
    /// Out of range, non-finite, or too far from the prediction.
    Implausible,
}

/// Classifies a measured angle against the limits and the observer's prediction `predicted`.
#[must_use]
pub fn check_angle(cfg: &Config, phi: Option<f64>, predicted: f64) -> AngleCheck {
    match phi {
        None => AngleCheck::Missing,
        Some(p) if !p.is_finite() || p.abs() > cfg.max_angle => AngleCheck::Implausible,
        Some(p) if (p - predicted).abs() > cfg.max_innovation => AngleCheck::Implausible,
        Some(_) => AngleCheck::Good,
    }
}

/// The degraded-mode rule: from the current mode, this cycle's angle check, the number
/// of consecutive bad-angle cycles *including this one*, and whether the positions are
/// finite, the next mode. Feedforward only is latched; a bad angle is bridged by the
/// observer's prediction for up to `max_bad_angle_cycles` cycles.
#[must_use]
pub fn degraded_rule(
    cfg: &Config,
    mode: Mode,
    angle: AngleCheck,
    bad_cycles: u32,
    positions_finite: bool,
) -> Mode {
    match (mode, angle) {
        (Mode::FeedforwardOnly(_), _) => mode,
        _ if !positions_finite => Mode::FeedforwardOnly(Degraded::PositionsInvalid),
        (Mode::Closed, AngleCheck::Good) => Mode::Closed,
        (Mode::Closed, _) if bad_cycles <= cfg.max_bad_angle_cycles => Mode::Closed,
        (Mode::Closed, AngleCheck::Missing) => Mode::FeedforwardOnly(Degraded::AngleLost),
        (Mode::Closed, _) => Mode::FeedforwardOnly(Degraded::AngleImplausible),
    }
}

/// `u` clamped to what the set-point gate admits after `last`: within the velocity limit
/// and within `max_acceleration · h` of `last` (less a margin of two drive units for the
/// gate's rounding). A non-finite `u` becomes `last`.
#[must_use]
pub fn clamp_to_limits(u: f64, last: f64, limits: AxisLimits, h: f64) -> f64 {
    const MARGIN: f64 = 2e-6;
    if !u.is_finite() {
        return last;
    }
    let step = (limits.max_acceleration * h - MARGIN).max(0.0);
    let vmax = (limits.max_velocity - MARGIN).max(0.0);
    let lo = (last - step).max(-vmax);
    let hi = (last + step).min(vmax);
    if lo > hi {
        // `last` itself outside the velocity limit: move towards it as fast as allowed.
        return if last > 0.0 { lo } else { hi };
    }
    // Not `f64::clamp`, which panics on a NaN bound (the panic-proof link found it).
    u.max(lo).min(hi)
}

/// The output of one cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Output {
    /// The set points to hand to the gate, m/s: `u_d + δu`, clamped ([`clamp_to_limits`]).
    pub u: [f64; 2],
    /// The correction actually applied, `u − u_d`, m/s.
    pub correction: [f64; 2],
    /// The mode after this cycle.
    pub mode: Mode,
    /// The estimated error state now, `[x, ẋ, φ, φ̇, l, l̇]` (measured − reference).
    pub error: [f64; 6],
}

/// The state feedback with its observer: one [`StateFeedback::cycle`] per 100 Hz cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateFeedback {
    cfg: Config,
    gains: Gains,
    /// Predicted error `ê(k|k−1)` of the trolley–swing block.
    e: Vector4<f64>,
    /// Predicted error of the winch block.
    ew: Vector2<f64>,
    /// The reference of the previous cycle (the measurement that arrives belongs to it).
    previous: Option<Reference>,
    /// The correction sent last cycle.
    applied: [f64; 2],
    mode: Mode,
    bad_angle_cycles: u32,
    /// The last angle received, the cycles it has stayed the same, and the reference
    /// angle when it started to (the stuck-sensor check).
    frozen: (Option<f64>, u32, f64),
}

impl StateFeedback {
    /// Designs the gains from `cfg` and starts in [`Mode::Closed`] with a zero error estimate.
    pub fn new(cfg: Config) -> Result<Self, DesignError> {
        let gains = Gains::design(&cfg)?;
        Ok(Self::with_gains(cfg, gains))
    }

    /// With gains designed elsewhere (the same for several controllers).
    #[must_use]
    pub fn with_gains(cfg: Config, gains: Gains) -> Self {
        Self {
            cfg,
            gains,
            e: Vector4::zeros(),
            ew: Vector2::zeros(),
            previous: None,
            applied: [0.0; 2],
            mode: Mode::Closed,
            bad_angle_cycles: 0,
            frozen: (None, 0, 0.0),
        }
    }

    /// The gains.
    #[must_use]
    pub fn gains(&self) -> &Gains {
        &self.gains
    }

    /// The mode.
    #[must_use]
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Back to [`Mode::Closed`] with a zero error estimate (call with the crane at rest
    /// and the inverse model restarted at the measured position).
    pub fn reset(&mut self) {
        *self = Self::with_gains(self.cfg, self.gains);
    }

    /// Whether the sensor looks stuck: `phi` identical for [`Config::max_frozen_cycles`]
    /// cycles while the reference angle (`reference_phi`, the previous cycle's) moved by
    /// more than [`Config::frozen_motion`].
    fn frozen(&mut self, phi: Option<f64>, reference_phi: f64) -> bool {
        let (last, cycles, since) = self.frozen;
        self.frozen = if phi.is_some() && phi == last {
            (last, cycles.saturating_add(1), since)
        } else {
            (phi, 0, reference_phi)
        };
        let (_, cycles, since) = self.frozen;
        cycles >= self.cfg.max_frozen_cycles
            && (reference_phi - since).abs() > self.cfg.frozen_motion
    }

    /// One cycle. `reference` and `u_d` are this cycle's inverse-model solution,
    /// `measured` is the sample of the previous cycle (`None` in the very first cycle or
    /// when no position arrived), `last` the set points last admitted by the gate.
    pub fn cycle(
        &mut self,
        reference: &Reference,
        u_d: [f64; 2],
        measured: Option<Measurement>,
        last: [f64; 2],
        limits: &DriveLimits,
    ) -> Output {
        let [ud1, ud2] = u_d;
        let [last1, last2] = last;
        let [app1, app2] = self.applied;
        let point = self.gains.at(reference.l);
        if let (Some(m), Some(prev), Mode::Closed) = (measured, self.previous, self.mode) {
            let positions_finite = m.x.is_finite() && m.l.is_finite();
            let predicted_phi = prev.phi + self.e.z;
            let check = match check_angle(&self.cfg, m.phi, predicted_phi) {
                AngleCheck::Good if self.frozen(m.phi, prev.phi) => AngleCheck::Implausible,
                check => check,
            };
            self.bad_angle_cycles = match check {
                AngleCheck::Good => 0,
                _ => self.bad_angle_cycles.saturating_add(1),
            };
            self.mode = degraded_rule(
                &self.cfg,
                self.mode,
                check,
                self.bad_angle_cycles,
                positions_finite,
            );
            if self.mode == Mode::Closed {
                // Correct the estimate of the previous sample with its measurement.
                let ex = m.x - prev.x;
                let residual_x = ex - self.e.x;
                let residual_phi = match (check, m.phi) {
                    (AngleCheck::Good, Some(p)) => p - prev.phi - self.e.z,
                    _ => 0.0,
                };
                // Without a good angle, correct with the position only.
                let gain = match check {
                    AngleCheck::Good => point.obs,
                    _ => {
                        let mut g = point.obs;
                        g.set_column(1, &Vector4::zeros());
                        g
                    }
                };
                self.e += gain * Vector2::new(residual_x, residual_phi);
                let el = m.l - prev.l;
                self.ew += point.obs_w * (el - self.ew.x);
            }
        }
        // Predict to now with the correction actually sent.
        self.e = point.model.a * self.e + point.model.b * app1;
        self.ew = point.model.aw * self.ew + point.model.bw * app2;
        let (d1, d2) = match self.mode {
            Mode::Closed if self.previous.is_some() => {
                ((-(point.k * self.e)).x, (-(point.kw * self.ew)).x)
            }
            _ => (0.0, 0.0),
        };
        let u1 = clamp_to_limits(ud1 + d1, last1, limits.trolley, self.cfg.h);
        let u2 = clamp_to_limits(ud2 + d2, last2, limits.winch, self.cfg.h);
        let correction = [u1 - ud1, u2 - ud2];
        // Anti-windup: the observer learns what was sent, not what was wished.
        self.applied = match self.mode {
            Mode::Closed => correction,
            Mode::FeedforwardOnly(_) => [0.0; 2],
        };
        if let Mode::FeedforwardOnly(_) = self.mode {
            self.e = Vector4::zeros();
            self.ew = Vector2::zeros();
        }
        self.previous = Some(*reference);
        let [e0, e1, e2, e3]: [f64; 4] = self.e.into();
        let [w0, w1]: [f64; 2] = self.ew.into();
        Output {
            u: [u1, u2],
            correction,
            mode: self.mode,
            error: [e0, e1, e2, e3, w0, w1],
        }
    }
}

/// What the controller puts between the inverse model's `u_d` and the set-point gate:
/// nothing ([`NoFeedback`], the paper's feedforward alone) or the state feedback
/// ([`StateFeedback`]). A type parameter of the controller, so that a scene without
/// feedback does not link the gain design, the observer or the inclinometer's use
/// (model only what a scene requires).
pub trait Correction {
    /// `false`: the controller never asks for a reference or measurements.
    const ENABLED: bool;
    /// One cycle: the set points to hand to the gate (see [`StateFeedback::cycle`]).
    fn correct(
        &mut self,
        reference: &Reference,
        u_d: [f64; 2],
        measured: Option<Measurement>,
        last: [f64; 2],
        limits: &DriveLimits,
    ) -> Output;
    /// Back to closed loop with a zero error estimate (the crane at rest).
    fn restart(&mut self);
    /// What it is doing (`None`: there is no feedback).
    fn mode(&self) -> Option<Mode>;
}

/// Feedforward only: the set points are the inverse model's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NoFeedback;

impl Correction for NoFeedback {
    const ENABLED: bool = false;
    fn correct(
        &mut self,
        _reference: &Reference,
        u_d: [f64; 2],
        _measured: Option<Measurement>,
        _last: [f64; 2],
        _limits: &DriveLimits,
    ) -> Output {
        Output {
            u: u_d,
            correction: [0.0; 2],
            mode: Mode::FeedforwardOnly(Degraded::AngleLost),
            error: [0.0; 6],
        }
    }
    fn restart(&mut self) {}
    fn mode(&self) -> Option<Mode> {
        None
    }
}

impl Correction for StateFeedback {
    const ENABLED: bool = true;
    fn correct(
        &mut self,
        reference: &Reference,
        u_d: [f64; 2],
        measured: Option<Measurement>,
        last: [f64; 2],
        limits: &DriveLimits,
    ) -> Output {
        self.cycle(reference, u_d, measured, last, limits)
    }
    fn restart(&mut self) {
        self.reset();
    }
    fn mode(&self) -> Option<Mode> {
        Some(self.mode)
    }
}

impl Degraded {
    /// The reason byte of the EMCY announcing feedforward only (docs/COMMANDS.md).
    #[must_use]
    pub fn code(self) -> u8 {
        match self {
            Self::AngleLost => 1,
            Self::AngleImplausible => 2,
            Self::PositionsInvalid => 3,
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    fn at_rest(x: f64, l: f64) -> Reference {
        Reference {
            x,
            l,
            ..Reference::default()
        }
    }

    #[test]
    fn zero_when_measurement_equals_reference() {
        let mut fb = StateFeedback::new(Config::PAPER).unwrap();
        let mut last = [0.1, -0.05];
        let mut prev: Option<Reference> = None;
        for k in 0..300 {
            let t = f64::from(k) * 0.01;
            let r = Reference {
                x: 12.0 + 0.1 * t,
                l: 6.0 - 0.05 * t,
                phi: 0.01 * libm::sin(t),
                vx: 0.1,
                vl: -0.05,
                vphi: 0.01 * libm::cos(t),
            };
            let ud = [0.1, -0.05];
            let m = prev.map(|p| Measurement {
                x: p.x,
                l: p.l,
                phi: Some(p.phi),
            });
            let out = fb.cycle(&r, ud, m, last, &DriveLimits::LAB);
            assert_eq!(out.correction, [0.0, 0.0]);
            assert_eq!(out.mode, Mode::Closed);
            last = out.u;
            prev = Some(r);
        }
    }

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
    }

    #[test]
    fn degraded_rule_table() {
        let c = Config::PAPER;
        let n = c.max_bad_angle_cycles;
        use AngleCheck::*;
        use Mode::*;
        assert_eq!(degraded_rule(&c, Closed, Good, 0, true), Closed);
        assert_eq!(degraded_rule(&c, Closed, Missing, n, true), Closed);
        assert_eq!(
            degraded_rule(&c, Closed, Missing, n + 1, true),
            FeedforwardOnly(Degraded::AngleLost)
        );
        assert_eq!(
            degraded_rule(&c, Closed, Implausible, n + 1, true),
            FeedforwardOnly(Degraded::AngleImplausible)
        );
        assert_eq!(
            degraded_rule(&c, Closed, Good, 0, false),
            FeedforwardOnly(Degraded::PositionsInvalid)
        );
        // Latched.
        let off = FeedforwardOnly(Degraded::AngleLost);
        assert_eq!(degraded_rule(&c, off, Good, 0, true), off);
        assert_eq!(check_angle(&c, None, 0.0), Missing);
        assert_eq!(check_angle(&c, Some(f64::NAN), 0.0), Implausible);
        assert_eq!(check_angle(&c, Some(0.5), 0.5), Implausible);
        assert_eq!(check_angle(&c, Some(0.1), 0.0), Implausible);
        assert_eq!(check_angle(&c, Some(0.01), 0.0), Good);
    }

    #[test]
    fn angle_lost_switches_to_feedforward_and_announces_it() {
        let mut fb = StateFeedback::new(Config::PAPER).unwrap();
        let r = at_rest(15.0, 5.0);
        let mut last = [0.0; 2];
        for k in 0..10 {
            let m = Measurement {
                x: 15.01,
                l: 5.0,
                phi: if k < 3 { Some(0.0) } else { None },
            };
            let out = fb.cycle(&r, [0.0; 2], Some(m), last, &DriveLimits::LAB);
            last = out.u;
            if k >= 3 + 4 {
                assert_eq!(out.mode, Mode::FeedforwardOnly(Degraded::AngleLost));
            }
        }
        // The correction is ramped out within the acceleration limit, then zero.
        for _ in 0..100 {
            let out = fb.cycle(&r, [0.0; 2], None, last, &DriveLimits::LAB);
            assert!((out.u[0] - last[0]).abs() <= 3.0 * 0.01 + 1e-12);
            last = out.u;
        }
        assert_eq!(last, [0.0, 0.0]);
        fb.reset();
        assert_eq!(fb.mode(), Mode::Closed);
    }

    #[test]
    fn clamp_respects_both_limits() {
        let lim = AxisLimits {
            max_velocity: 3.0,
            max_acceleration: 3.0,
        };
        assert!((clamp_to_limits(10.0, 2.99, lim, 0.01) - (3.0 - 2e-6)).abs() < 1e-12);
        assert!((clamp_to_limits(1.0, 0.0, lim, 0.01) - (0.03 - 2e-6)).abs() < 1e-12);
        assert_eq!(clamp_to_limits(f64::NAN, 0.5, lim, 0.01), 0.5);
        assert_eq!(clamp_to_limits(0.01, 0.0, lim, 0.01), 0.01);
    }
}
