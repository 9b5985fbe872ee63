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
//!   noisy, through its own first-order filter and one cycle late or more; the drives
//!   give positions only. A predictor-form observer on the error state (steady-state
//!   Kalman gain, scheduled like the LQR gains) corrects the estimate of the *previous*
//!   sample with the late measurement and predicts it to now with the set-point
//!   deviation actually sent: the swing rate is estimated from the model, not
//!   differentiated. The inclinometer's filter and delay line are states of the
//!   observer ([`SensorStates`]: the filter's output and up to [`MAX_DELAY_CYCLES`] of
//!   its past outputs, as commissioned, [`Config::inclinometer`]), designed with it as
//!   one Kalman filter for the angle's noise ([`Weights::angle_noise`]): the reading is
//!   compared with what the sensor reports of the estimate, at every frequency (issue
//!   33: the first-order model `φ − T φ̇` it replaces was right at the swing's
//!   frequency, not at the noise's, and the trolley chattered at 3.5 Hz on the noise
//!   after the move, worse the later the sensor).
//! * **The drive as it moves.** A drive under its own velocity loop is not the lag of
//!   Eq. 22: friction droops it (or stops it: a proportional loop does not move below
//!   its droop), its integral and the rope's pull push it. The observer's fifth state
//!   is that velocity offset `d` (the set point moves the trolley as `u + d`, `d` a
//!   random walk, [`Weights::drive_offset`]), estimated from the measured positions and
//!   not fed back. Without it the lag model's predictions disagreed with a trolley
//!   that did not move as asked, and the observer put the difference into the swing:
//!   during a move its swing rate was 0.2°/s off, which a sensor failure then left in
//!   the load, and a trolley stuck below a proportional loop's droop under a still
//!   load was read as swinging (issue 18).
//! * **Anti-windup.** `u_d + δu` is clamped to the velocity limit and to the change the
//!   acceleration limit allows from the last set point ([`clamp_to_limits`]), i.e.
//!   exactly what [`crate::setpoint::SetpointGate::admit`] accepts; the observer is
//!   fed the deviation actually sent, so its state never winds up on a saturated drive.
//! * **Start.** The observer starts from the first measurement with a plausible angle —
//!   positions and the swing the load already has — not from zero: cranes start moves
//!   with a swinging load, and a swing that was there before is no innovation.
//! * **A stuck angle.** A reading that has not changed for
//!   [`Config::max_frozen_cycles`] cycles while what the crane's own motion makes the
//!   angle do (the observer run on the drives' positions alone since the reading last
//!   changed) moved it by more than [`Config::frozen_motion`] is stuck — at rest too,
//!   where a swinging load or a trolley the feedback moves betray it. Until the reading
//!   changes again the trolley's correction may not grow beyond its value at the last
//!   change plus [`Config::held_allowance`]: an angle that does not move cannot make
//!   the feedback push harder, so a stuck one does little harm before it is caught.
//! * **An offset angle** (review finding 12). A pendulum's angle swings about zero;
//!   only a steady force holds it off — and a steady wind cannot be told from a biased
//!   sensor. The inclinometer's zero ([`crate::zero`]) is the difference between the
//!   angle read and the angle the load's measured acceleration requires: a DC
//!   component the pendulum cannot make. The feedback never acts on it. At the start a
//!   reading cannot yet be told from an offset, so the observer runs on the reading as
//!   it is and the feedback's estimate is the observer's less its response to the
//!   offset shown so far (superposition): all of the first reading at first, then
//!   only what the load's motion has not confirmed as a swing.
//!   Once the estimate is steady at rest the angle is trusted: the offset is fixed and
//!   taken out of every reading (within [`Config::offset_dead_band`], nothing is taken
//!   out: a healthy crane is read as before). A reading that leaves the prediction by
//!   more than [`Config::offset_step`] the same way in [`crate::zero::STEP_CYCLES`] readings in
//!   a row is a step of the zero (no pendulum jumps), taken out then; the readings
//!   before are held back and bridged, so a noise outlier is neither a swing nor a
//!   step. An offset beyond [`Config::max_offset`] for longer than a gust
//!   ([`Config::offset_cycles`]) is announced once the crane rests
//!   ([`Degraded::AngleOffset`], EMCY 0xFF20 reason 5) and the angle is no longer
//!   read; not during a move, which the angle, its offset taken out, finishes better
//!   than the positions alone (a gust after a fall-back mid-move is left to
//!   feedforward).
//! * **At rest.** With the whole reference still the trolley's gains are the rest's
//!   ([`GainPoint::k_rest`]): no path is left to follow, only the swing to damp, so
//!   their weights add the load's velocity over the rail — the swing the load keeps
//!   when the trolley stops, which the rest hold judges — and the slowest mode of the
//!   nominal loop decays at 1.04 /s over the whole rope range, where a move's falls
//!   from 0.98 /s at 3 m to 0.68 /s at 9 m. With the load within
//!   [`Config::rest_position`] of the reference and swinging less than
//!   [`Config::rest_swing`] for 0.1 s — the swing the load keeps once the trolley
//!   stands still, the angle trusted —, the feedback lets go: the set points are the
//!   inverse model's, exactly zero, and the drives hold. It takes hold again at
//!   [`Config::rest_hysteresis`] times either. Once the angle is trusted, the observer
//!   at rest is designed for a noisier angle ([`Weights::rest_angle_noise`],
//!   [`GainPoint::obs_rest`]): with the move's, the trolley hunted on a 0.05° noise
//!   at up to 190 mm/s after the move (issue 33).
//! * **The travel at rest while the hoist moves.** The trolley's rest is judged on the
//!   travel's part of the reference (`Still`) and on the load's horizontal place:
//!   while only the hoist moves the trolley has no path, only a swing to damp, as at
//!   rest — it is let go and held again by the same rule (the gains stay the move's,
//!   the observer is the rest's once the angle is trusted). The hoist is let go with
//!   it once it stands still with the rope within [`Config::rest_position`] (a
//!   hoist-only move's lag is made up first). Judged on the whole crane, a hoist-only
//!   demand kept the trolley acting on the angle's noise: up to 3.5 mm at 0.076 m/s
//!   with the angle trusted (`a_hoist_only_demand_leaves_the_trolley_where_it_stands`,
//!   operator_feedback, on 4a7f83f).
//! * **Let go before the trust.** Before the angle is trusted the estimate cannot yet
//!   tell the reading's noise from a swing. When the loop is closed at rest by a
//!   command that may move the hoist alone (manual mode's first demand, an automatic
//!   move's start: [`StateFeedback::let_go_at_rest`]), and when the hoist starts to
//!   move alone, the trolley is let go unless the estimate already shows a swing or a
//!   displacement beyond the hold thresholds ([`Config::hold_thresholds`]), and held
//!   again as a let-go crane is — a swing there as the load's motion confirms it. The
//!   hoist starts alone only after it stood still with the travel: a combined move's
//!   hoist going on after the travel stopped leaves the trolley holding the swing the
//!   move left (a hoist-only move the loop takes over before the trust is judged from the
//!   hoist's next start, once it stood still). Acting from the loop's closing on the
//!   young estimate, the angle's noise moved the trolley by up to 7.0 mm at 0.139 m/s
//!   while the operator only hoisted right after entering manual mode (the same test,
//!   on 4a7f83f).
//! * **Degraded mode.** [`degraded_rule`]: the angle missing or implausible for more
//!   than [`Config::max_bad_angle_cycles`] cycles, stuck, or offset →
//!   [`Mode::SwingEstimated`]: the angle is no longer read, the swing is estimated from the trolley's measured
//!   motion and damped until the crane rests; with nothing to estimate from (the
//!   observer never started, or started from the stuck reading itself), or the
//!   positions not finite → [`Mode::FeedforwardOnly`], the correction removed within
//!   the acceleration limit. Either is announced with its reason and latched until
//!   [`StateFeedback::reset`] (a new observer start needs the crane at rest). Stopping is left to the controller's existing reactions (a lost drive
//!   quick-stops both).
//!
//! The design — weights, configuration, the linearised model and the gains it gives —
//! is [`design`]'s, done once at start-up; this module is the loop that runs every cycle
//! ([`StateFeedback`]) and its rules. Everything is `no_std`, allocation-free and
//! panic-free: fixed-size nalgebra matrices, no indexing.

pub use crate::reference::Reference;
use nalgebra::{SMatrix, SVector, Vector2, Vector4, Vector5};

use crate::rope::{RopeLength, MAX_DELAY_CYCLES};
use crate::setpoint::{AxisLimits, DriveLimits};
use crate::zero::Zero;

pub mod design;
pub use design::*;

/// The observer's state: the error `[x, ẋ, φ, φ̇]` and the drive's velocity offset `d`.
type Observed = Vector5<f64>;
/// The observer's gain (measured `x`, `φ`).
type ObserverGain = SMatrix<f64, 5, 2>;

/// The inclinometer's states in the observer (issue 33): its filter's output `y` and the
/// outputs it took in the last [`MAX_DELAY_CYCLES`] cycles and has yet to report,
/// newest first, `[y, y₋₁, …, y₋₅]` — what it will report, estimated. Entry `d` is the
/// reading of a sensor `d` cycles late. Absolute angles, rad (the reference's angle
/// included: the reading is of the load, not of the error).
pub type SensorStates = SVector<f64, SENSOR_STATES>;
/// The filter's output and the longest delay line.
pub const SENSOR_STATES: usize = 1 + MAX_DELAY_CYCLES as usize;
/// The observer's gain of the inclinometer's states (measured `x`, `φ`).
pub type SensorGain = SMatrix<f64, SENSOR_STATES, 2>;
/// The observer's design state: [`Observed`] and [`SensorStates`].
const AUGMENTED: usize = 5 + SENSOR_STATES;

/// The inclinometer's first-order filter over one cycle, `y' = a y + b₀ φ' + b₁ φ`: its
/// exact response to an angle linear between samples (the sensor filters continuously),
/// and the delay of the sample it reports, cycles ([`Config::inclinometer`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct SensorModel {
    a: f64,
    b0: f64,
    b1: f64,
    delay: usize,
}

impl SensorModel {
    fn of(cfg: &Config) -> Self {
        let (a, b0, b1) = crate::rope::first_order_hold(cfg.inclinometer.filter, cfg.h);
        Self {
            a,
            b0,
            b1,
            delay: usize::from(cfg.inclinometer.delay.min(MAX_DELAY_CYCLES)),
        }
    }

    /// The reading the sensor's states `s` make.
    fn reading(&self, s: &SensorStates) -> f64 {
        s.get(self.delay).copied().unwrap_or(0.0)
    }

    /// One cycle on: the filter takes the angle from `before` to `after`, its last
    /// output moves into the line.
    fn predict(&self, s: &SensorStates, before: f64, after: f64) -> SensorStates {
        SensorStates::from_fn(|i, _| match i {
            0 => self.a * s.x + self.b0 * after + self.b1 * before,
            i => s.get(i - 1).copied().unwrap_or(0.0),
        })
    }
}

/// The error part `[x, ẋ, φ, φ̇]` of the observer's state.
fn four(v: &Observed) -> Vector4<f64> {
    Vector4::new(v.x, v.y, v.z, v.w)
}

/// One cycle's prediction of the observer's state with the set-point correction `du`
/// sent: the drive moves as asked plus its offset `d`, which stays.
fn predict(model: &Discrete, v: &Observed, du: f64) -> Observed {
    let n = model.a * four(v) + model.b * (du + v.a);
    Vector5::new(n.x, n.y, n.z, n.w, v.a)
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

/// Why the angle is no longer read (the feedback estimates the swing or is off).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Degraded {
    /// No angle for more than the tolerated cycles.
    AngleLost,
    /// The angle out of range or too far from the prediction for more than the tolerated cycles.
    AngleImplausible,
    /// The angle stuck: unchanged while the crane's own motion moved it
    /// ([`Config::frozen_motion`]). A verdict, not a glitch: not bridged.
    AngleFrozen,
    /// A position is not finite.
    PositionsInvalid,
    /// The angle has a DC component the pendulum cannot make — a biased sensor or a
    /// steady wind, which no test can tell apart ([`crate::zero`]) — beyond
    /// [`Config::max_offset`] for [`Config::offset_cycles`]. The feedback never acted on
    /// it (the observer reads the angle less its offset), so the estimate it goes on
    /// with is the swing about the load's rest: nothing to undo.
    AngleOffset,
}

/// What the feedback is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Feedforward plus state feedback.
    Closed,
    /// The angle failed (lost, implausible or stuck) and is no longer read: the
    /// feedback goes on with the swing the model predicts from the drives' measured
    /// positions, from the estimate it had when the angle was last trusted, until the
    /// crane rests. Cutting the correction mid-swing instead leaves the load with the
    /// swing and the trolley offset the feedback was in the middle of removing — worse
    /// than feedforward alone in one case of eight (issue 18). Latched until
    /// [`StateFeedback::reset`].
    SwingEstimated(Degraded),
    /// Feedforward only, with the reason (latched until [`StateFeedback::reset`]): the
    /// positions themselves are not usable.
    FeedforwardOnly(Degraded),
}

impl Mode {
    /// The reason the angle is not used, if it is not.
    #[must_use]
    pub fn degraded(self) -> Option<Degraded> {
        match self {
            Self::Closed => None,
            Self::SwingEstimated(d) | Self::FeedforwardOnly(d) => Some(d),
        }
    }
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
    /// Off the prediction by more than [`Config::offset_step`], not (yet) confirmed as
    /// a step of the zero ([`crate::zero::STEP_CYCLES`]): bridged like a missing reading, but
    /// not counted against [`Config::max_bad_angle_cycles`] — at most
    /// `STEP_CYCLES − 1` in a row, and a noise outlier is no fault of the sensor's.
    HeldBack,
    /// Stuck: unchanged while the crane's own motion moved it ([`Config::frozen_motion`]).
    Frozen,
    /// Offset: a DC component beyond [`Config::max_offset`] for longer than a gust
    /// ([`Config::offset_cycles`]).
    Offset,
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

/// The degraded-mode rule: from the current mode, this cycle's angle check (ignored
/// once the angle is no longer read), the number of consecutive bad-angle cycles
/// *including this one*, and whether the positions are finite, the next mode. Both
/// degraded modes are latched; non-finite positions end in feedforward only; a missing
/// or implausible angle is bridged by the observer's prediction for up to
/// `max_bad_angle_cycles` cycles, then the swing is estimated from the positions; a
/// stuck one is not bridged (it has already been watched for
/// [`Config::max_frozen_cycles`]).
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
        (Mode::SwingEstimated(_), _) => mode,
        (Mode::Closed, AngleCheck::Good) => Mode::Closed,
        (Mode::Closed, AngleCheck::Frozen) => Mode::SwingEstimated(Degraded::AngleFrozen),
        (Mode::Closed, AngleCheck::Offset) => Mode::SwingEstimated(Degraded::AngleOffset),
        (Mode::Closed, AngleCheck::HeldBack) => Mode::Closed,
        (Mode::Closed, _) if bad_cycles <= cfg.max_bad_angle_cycles => Mode::Closed,
        (Mode::Closed, AngleCheck::Missing) => Mode::SwingEstimated(Degraded::AngleLost),
        (Mode::Closed, _) => Mode::SwingEstimated(Degraded::AngleImplausible),
    }
}

/// The observer's gain for a trolley position alone, at rope length `l`: the trolley's
/// position and velocity and the drive's offset are corrected as the observer's gain
/// says, the load is not moved by it. The swing is not observable from the trolley's
/// position (the drive does not feel the rope), so the two-measurement gain's swing
/// rows would pull the swing estimate with every trolley residual; instead the load's
/// position `x + lφ` and velocity `ẋ + lφ̇` stay, and the swing follows from the
/// corrected trolley. The model's prediction then swings the load under the trolley's
/// measured motion (the load's own dynamics, `d²(x + lφ)/dt² = −gφ`, are driven by the
/// trolley's position).
fn position_only(obs: &ObserverGain, l: f64) -> Observed {
    let (gx, gv, gd) = (obs.m11, obs.m21, obs.m51);
    let l = l.max(0.1);
    Vector5::new(gx, gv, -gx / l, -gv / l, gd)
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

/// Below this a reference's speed or set point, m/s or rad/s, is still.
const STILL: f64 = 1e-6;

/// Which parts of the reference stand still this cycle: set points and rates below
/// [`STILL`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Still {
    /// The trolley's part — its set point `u_d1`, its speed and the swing's rate —
    /// whatever the winch does: while only the hoist moves the trolley has no path to
    /// follow, only a swing to damp, as at rest.
    travel: bool,
    /// The winch's: its set point `u_d2` and the rope's rate.
    hoist: bool,
}

impl Still {
    fn of(reference: &Reference, [ud1, ud2]: [f64; 2]) -> Self {
        Self {
            travel: ud1.abs() < STILL && reference.vx.abs() < STILL && reference.vphi.abs() < STILL,
            hoist: ud2.abs() < STILL && reference.vl.abs() < STILL,
        }
    }

    /// The whole reference stands still: the crane is at rest.
    fn all(self) -> bool {
        self.travel && self.hoist
    }
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
    /// The feedback has let go of a crane at rest on its target ([`Config::rest_position`]):
    /// the whole crane, trolley and hoist (the trolley alone may be let go while only
    /// the hoist moves, `StateFeedback::settle`).
    pub resting: bool,
    /// The swing's amplitude as the rest hold judges it, rad (nought while the
    /// travel's part of the reference moves, which the hoist's alone does not): see
    /// [`Config::rest_swing`].
    pub swing: f64,
    /// The estimated error state now, `[x, ẋ, φ, φ̇, l, l̇]` (measured − reference).
    pub error: [f64; 6],
    /// The inclinometer's offset believed now ([`crate::zero`]), rad: the observer
    /// reads the angle less the part of it judged when the angle was trusted.
    pub offset: f64,
    /// The angle is trusted: the zero's estimate has settled and is steady, and the
    /// offset it showed then is taken out of every reading. Until then the feedback's
    /// estimate is the observer's less the offset shown so far. Not set by an angle
    /// that fails before it was trusted.
    pub trusted: bool,
}

/// The stuck-sensor watch: since the angle read last changed, the observer run on the
/// drives' positions alone, i.e. what the crane's own motion makes the angle do.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Held {
    /// The angle read last cycle.
    last: Option<f64>,
    /// While it repeats: the position-only error estimate and the cycles it has repeated.
    run: Option<(Observed, u32)>,
    /// The trolley correction when the reading last changed, m/s.
    correction: f64,
    /// The angle the position-only estimate started from (the reference's plus the
    /// estimate the feedback acted on), rad: how far the crane's own motion has moved
    /// the angle since is measured from it, not from the repeated reading. Under a gust
    /// the observer's angle is a few hundredths of a degree off the reading (the wind is
    /// a force its model does not have); measured against the reading, that gap counted
    /// as motion and a healthy reading that repeated by chance for four cycles was
    /// judged stuck (issue 18: one paper's-move case in 1000, 105 mm / 1.5° off).
    start: f64,
    /// The offset shown but not yet taken out ([`StateFeedback::estimate`]) when it
    /// started to repeat, rad: a stuck reading under a moving load is no evidence of
    /// the offset.
    left: f64,
}

impl Held {
    const NEW: Self = Self {
        last: None,
        run: None,
        correction: 0.0,
        start: 0.0,
        left: 0.0,
    };
}

/// How long load and swing must stay within [`Config::rest_position`] and
/// [`Config::rest_swing`] before the crane is let go, s: ten samples, so that one
/// sample's dip of the estimate does not let go of a swinging load. Not a tuning: the
/// swing judged already accounts for what stopping the trolley does to it.
const DWELL: f64 = 0.1;

/// The swing of a crane at rest, as [`StateFeedback::settle`] judges it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Swing {
    /// The estimated angle, low-passed, rad.
    angle: f64,
    /// The estimated angle's rate, low-passed alike, rad/s.
    rate: f64,
    /// The amplitude judged this cycle, rad.
    amplitude: f64,
    /// Its square averaged over about a period (from the moment the crane is let go),
    /// rad²: what a crane let go is held again on.
    energy: f64,
    /// Cycles in a row the load has been within the thresholds.
    within: u32,
    /// Cycles the reference has been still.
    cycles: u32,
    /// The load's horizontal distance from its reference judged this cycle, m.
    load: f64,
    /// Last cycle the hoist moved, or may have: true from the travel's last motion
    /// ([`Self::NEW`]) until the hoist has been seen still, so that a combined move's
    /// hoist going on after the travel stopped is no hoist starting alone.
    hoist_moving: bool,
    /// Cycles in a row the hoist has stood still with the rope within
    /// [`Config::rest_position`] of its reference.
    rope_within: u32,
}

impl Swing {
    /// Within the hold thresholds: a let-go crane would not be held again.
    fn holds_nothing(&self, load: f64, position: f64, swing: f64) -> bool {
        load <= position && self.amplitude <= swing
    }

    const NEW: Self = Self {
        angle: 0.0,
        rate: 0.0,
        amplitude: 0.0,
        energy: 0.0,
        within: 0,
        cycles: 0,
        load: 0.0,
        hoist_moving: true,
        rope_within: 0,
    };
}

/// The observer's response to a unit offset of the reading (see [`StateFeedback`]'s
/// `unit`): of the error and of the inclinometer's states.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Unit {
    e: Observed,
    sensor: SensorStates,
}

/// The state feedback with its observer: one [`StateFeedback::cycle`] per 100 Hz cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateFeedback {
    cfg: Config,
    gains: Gains,
    /// The inclinometer's filter and delay as commissioned ([`Config::inclinometer`]).
    sensor_model: SensorModel,
    /// Predicted error `ê(k|k−1)` of the trolley–swing block, and the drive's velocity
    /// offset.
    e: Observed,
    /// The inclinometer's states predicted alike, `[y, y₋₁, …]` ([`SensorStates`]): what
    /// it reports of the angle less its offset.
    sensor: SensorStates,
    /// Predicted error of the winch block.
    ew: Vector2<f64>,
    /// The reference of the previous cycle (the measurement that arrives belongs to it).
    previous: Option<Reference>,
    /// The observer was started from a measurement with a good angle (a load may
    /// already swing when the first move is commanded).
    started: bool,
    /// The angle read has changed since the observer started: the swing it started
    /// from was seen, not only assumed from one reading (which may be a stuck one).
    seen_change: bool,
    /// The correction sent last cycle.
    applied: [f64; 2],
    mode: Mode,
    bad_angle_cycles: u32,
    held: Held,
    /// The trolley let go with the travel at rest, the hoist moving or not (see
    /// [`Config::rest_position`], [`StateFeedback::settle`]).
    resting: bool,
    /// … and the hoist let go too, the whole crane at rest.
    hoist_resting: bool,
    /// The swing judged at rest (see [`StateFeedback::settle`]).
    swing: Swing,
    /// The rope's length learnt from the swing, for the commissioning step (kept
    /// through a reset: the rope does not change with the feedback's mode).
    rope: RopeLength,
    /// The inclinometer's offset ([`crate::zero`]), started with the observer: not
    /// kept through a reset (a steady wind that has dropped would become a wrong zero;
    /// a real offset is commissioned away, `InclinometerSetup::offset_deg`).
    zero: Zero,
    /// Until the angle is trusted (the zero's estimate settled and steady,
    /// [`zero::SETTLING_CYCLES`], [`zero::STEADY_CYCLES`]): the observer's response to
    /// a unit offset of the reading since it started, to take the offset out of the
    /// estimate by superposition: as far as it is known yet for the feedback
    /// ([`Self::estimate`]), and for good when it is trusted ([`Self::trust`]).
    unit: Option<Unit>,
    /// The angle has been trusted since the observer started ([`Self::trust`]); not
    /// `unit.is_none()`, which an angle failing before the trust sets too.
    trusted: bool,
}

impl StateFeedback {
    /// Designs the gains from `cfg` and starts in [`Mode::Closed`]; the observer starts
    /// from the first measurement.
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
            sensor_model: SensorModel::of(&cfg),
            e: Observed::zeros(),
            sensor: SensorStates::zeros(),
            ew: Vector2::zeros(),
            previous: None,
            started: false,
            seen_change: false,
            applied: [0.0; 2],
            mode: Mode::Closed,
            bad_angle_cycles: 0,
            held: Held::NEW,
            resting: false,
            hoist_resting: false,
            swing: Swing::NEW,
            rope: RopeLength::new(cfg.g, cfg.h, cfg.inclinometer),
            zero: Zero::new(cfg.g, cfg.h, cfg.zero_thresholds()),
            unit: None,
            trusted: false,
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

    /// Back to [`Mode::Closed`], the observer to be started from the next measurement
    /// (call with the inverse model restarted at the measured position).
    ///
    /// Field by field, as [`Self::with_gains`] starts them, the gains and the rope's
    /// calibration left in place: a new value built with them copied in and copied
    /// back put both (~5 KB) on the control task's stack twice (review finding C1).
    /// The pattern lists every field, so a field added fails to compile here.
    pub fn reset(&mut self) {
        let Self {
            cfg,
            gains: _,
            sensor_model: _,
            e,
            sensor,
            ew,
            previous,
            started,
            seen_change,
            applied,
            mode,
            bad_angle_cycles,
            held,
            resting,
            hoist_resting,
            swing,
            rope: _,
            zero,
            unit,
            trusted,
        } = self;
        *e = Observed::zeros();
        *sensor = SensorStates::zeros();
        *ew = Vector2::zeros();
        *previous = None;
        *started = false;
        *seen_change = false;
        *applied = [0.0; 2];
        *mode = Mode::Closed;
        *bad_angle_cycles = 0;
        *held = Held::NEW;
        *resting = false;
        *hoist_resting = false;
        *swing = Swing::NEW;
        *zero = Zero::new(cfg.g, cfg.h, cfg.zero_thresholds());
        *unit = None;
        *trusted = false;
    }

    /// The rope as the swing has shown it so far ([`crate::rope`]).
    #[must_use]
    pub fn rope(&self) -> &RopeLength {
        &self.rope
    }

    /// The offset taken from the reading: the steps of the zero; once the angle is
    /// trusted, the offset fixed then too (until then the observer reads the rest as
    /// it is, and the offset shown so far is taken out of its estimate,
    /// [`Self::estimate`]).
    fn read_offset(&self) -> f64 {
        match (self.started, self.unit) {
            (true, None) => self.zero.removed(),
            (true, Some(_)) => self.zero.steps(),
            (false, _) => 0.0,
        }
    }

    /// The reading's offset known now: what is taken out of the reading, and until the
    /// angle is trusted the offset shown so far.
    fn known_offset(&self) -> f64 {
        match self.unit {
            Some(_) => self.read_offset() + self.shown(),
            None => self.read_offset(),
        }
    }

    /// The angle the inclinometer reports for the previous sample's estimate: its
    /// states' entry of the commissioned delay ([`SensorStates`]; issue 33: the
    /// observer designed for a reading as old as the positions took the older one for
    /// them, and at 2 cycles and 19 ms more under a lighter load the loop swung up
    /// during a move; the first-order model `φ − T φ̇` that followed fed the angle's
    /// noise into the trolley at 3.5 Hz).
    fn reading(&self) -> f64 {
        self.sensor_model.reading(&self.sensor)
    }

    /// The corrections actually sent, `[trolley, winch]`, when they differ from this
    /// feedback's own: the range guard cut them ([`crate::range`]), or another feedback
    /// drives the hoist (the 3D crane's y–z plane, [`crate::feedback3d`]). The observer
    /// learns them in place of its own, which were never sent (anti-windup's rule, the
    /// observer learns what was sent). Call after [`Self::cycle`].
    pub(crate) fn sent(&mut self, correction: [f64; 2]) {
        if !matches!(self.mode, Mode::FeedforwardOnly(_)) {
            self.applied = correction;
        }
    }

    /// The trolley–swing estimate the feedback acts on: until the angle is trusted, the
    /// observer's (run on the reading as it is) less its response to the offset the
    /// zero's estimate shows now beyond its dead band — all of the first reading, at
    /// the start, then what the load's motion has not confirmed as a swing. So the
    /// feedback's estimate holds from the start only what the pendulum's physics has
    /// confirmed, never an offset; once trusted, the observer's.
    fn estimate(&self) -> Observed {
        match self.unit {
            Some(u) => self.e - u.e * self.shown(),
            None => self.e,
        }
    }

    /// The offset shown but not yet taken out of the readings ([`Zero::shown`]), or
    /// while the reading repeats (it may be stuck), the one from before.
    fn shown(&self) -> f64 {
        match self.held.run {
            Some(_) => self.held.left,
            None => self.zero.shown(),
        }
    }

    /// Once the zero's estimate is steady at rest, the angle is trusted: its offset is
    /// fixed ([`Zero::fix`]) and taken out of the estimate — by superposition, the
    /// observer's response to it since the start ([`Self::unit`]) times the offset —
    /// and from then on out of every reading. Under a swing at the start the offset
    /// is nought and nothing changes; under an offset the estimate is the one the
    /// observer would have made from the true angle.
    fn trust(&mut self) {
        if let (Some(u), true, Mode::Closed) = (self.unit, self.zero.steady_at_rest(), self.mode) {
            self.zero.fix();
            let c = self.zero.removed() - self.zero.steps();
            self.e -= u.e * c;
            self.sensor -= u.sensor * c;
            // A repeating reading is watched again from the next repeat, on the
            // estimate now read.
            self.held.run = None;
            self.unit = None;
            self.trusted = true;
        }
    }

    /// The stuck-sensor watch for this cycle's reading `phi` of the sample whose
    /// reference was `prev`, `ex` its measured trolley error: [`AngleCheck::Frozen`]
    /// when the reading has repeated for [`Config::max_frozen_cycles`] cycles while the
    /// position-only observer moved the angle by more than [`Config::frozen_motion`].
    fn watch_frozen(
        &mut self,
        phi: Option<f64>,
        prev: &Reference,
        ex: f64,
        obs: &ObserverGain,
    ) -> bool {
        let repeated = phi.is_some() && phi == self.held.last;
        if phi.is_some() && self.held.last.is_some() && !repeated {
            self.seen_change = true;
        }
        self.held.last = phi;
        if !repeated {
            self.held.run = None;
            self.held.correction = self.applied[0];
            return false;
        }
        let Some((run, cycles)) = self.held.run.as_mut() else {
            // First repeat: watch from the estimate of this sample the feedback acts on
            // (the offset shown so far taken out).
            self.held.left = match self.unit {
                Some(_) => self.zero.shown(),
                None => 0.0,
            };
            let estimate = self.estimate();
            self.held.run = Some((estimate, 0));
            self.held.start = prev.phi + estimate.z;
            return false;
        };
        *run += position_only(obs, prev.l) * (ex - run.x);
        *cycles = cycles.saturating_add(1);
        *cycles >= self.cfg.max_frozen_cycles
            && (prev.phi + run.z - self.held.start).abs() > self.cfg.frozen_motion
    }

    /// This cycle's angle `m.phi` against the limits, the observer's prediction (once
    /// started: until then the load may be swinging, only the range is checked), the
    /// stuck-sensor watch ([`Self::watch_frozen`]) and the inclinometer's zero
    /// ([`crate::zero`]): a reading that leaves the prediction by more than
    /// [`Config::offset_step`] (but not by an implausible [`Config::max_innovation`]) is
    /// held back ([`AngleCheck::HeldBack`], bridged) until [`crate::zero::STEP_CYCLES`] in a
    /// row confirm a step of the zero, never a swing; a good reading feeds the zero's estimate, whose
    /// offset lasting beyond [`Config::max_offset`] for [`Config::offset_cycles`] is
    /// [`AngleCheck::Offset`].
    fn judge_angle(
        &mut self,
        m: &Measurement,
        prev: &Reference,
        ex: f64,
        obs: &ObserverGain,
        still: Still,
    ) -> AngleCheck {
        let phi = m.phi;
        // The prediction of the reading: of the angle, plus the offset believed.
        let predicted = if self.started {
            self.reading() + self.read_offset()
        } else {
            phi.unwrap_or(0.0)
        };
        if let (Some(p), true) = (phi, self.started) {
            let miss = p - predicted;
            let plausible = miss.abs() <= self.cfg.max_innovation
                && (p - self.known_offset()).abs() <= self.cfg.max_angle;
            if miss.abs() <= self.zero.max_step() {
                self.zero.on_prediction();
            } else if plausible && !self.zero.off_prediction(miss) {
                // A step of the zero once it persists (zero::STEP_CYCLES); until then
                // the reading is held back and bridged, neither swing nor step. An
                // implausible reading neither counts towards a step nor ends the row.
                self.zero.gap();
                return AngleCheck::HeldBack;
            }
        }
        // Judged as the angle it reads, the offset known taken out: a 10° offset does
        // not make a 12° swing implausible.
        let known = if self.started {
            self.known_offset()
        } else {
            0.0
        };
        let predicted = if self.started {
            self.reading() + self.read_offset()
        } else {
            predicted
        };
        let check = match check_angle(&self.cfg, phi.map(|p| p - known), predicted - known) {
            AngleCheck::Good if self.started && self.watch_frozen(phi, prev, ex, obs) => {
                AngleCheck::Frozen
            }
            check => check,
        };
        match (check, phi) {
            (AngleCheck::Good, Some(p)) => {
                self.zero.sample(m.x, p, m.l, prev, still.all());
                if self.zero.offset_persists() && still.all() && self.hoist_resting {
                    return AngleCheck::Offset;
                }
            }
            _ => self.zero.gap(),
        }
        check
    }

    /// The loop is closed at rest on a command that may move the hoist alone (manual
    /// mode's first demand after an entry at rest, an automatic move's start): the
    /// trolley is let go — its set point the model's, exactly — unless the estimate
    /// already shows a swing or a displacement beyond the hold thresholds
    /// ([`Config::hold_thresholds`]), and held again as a let-go crane is
    /// (`Self::settle`); a travel demand holds it as the path starts. Before the trust
    /// the estimate cannot yet tell the reading's noise from a swing: acting on it from
    /// the loop's closing, the angle's noise moved the trolley by up to 7.0 mm at
    /// 0.139 m/s while the operator only hoisted right after entering manual mode
    /// (`a_hoist_only_demand_leaves_the_trolley_where_it_stands`, operator_feedback, on
    /// 4a7f83f). The same when the hoist starts to move alone before the trust.
    pub fn let_go_at_rest(&mut self) {
        let (position, swing) = self.cfg.hold_thresholds();
        let sw = &mut self.swing;
        if self.started
            && !self.resting
            && sw.cycles > 0
            && sw.holds_nothing(sw.load, position, swing)
        {
            self.resting = true;
            sw.energy = sw.amplitude * sw.amplitude;
        }
    }

    /// Whether a crane at rest on its target may be let go, or must be held again
    /// ([`Config::rest_position`], [`Config::rest_swing`], [`Config::rest_hysteresis`]):
    /// the trolley's, judged while the travel is still, the hoist moving or not, on the
    /// load's horizontal place and swing; the hoist's with it, once the hoist stands
    /// still with the rope within the same position threshold ([`Output::resting`]).
    ///
    /// The swing's amplitude is the pendulum's energy, `√(φ² + (φ̇/ω)²)`, of the
    /// estimated angle and rate, both low-passed at twice the swing frequency `ω`
    /// (the estimate's noise, its rate's more, is of the order of the few hundredths of
    /// a degree to be judged) and divided by the low-pass's gain at `ω`: constant over
    /// a free swing, so it follows a swing being damped within the low-pass's lag
    /// (`1/(2ω)`, 0.2–0.5 s), not half a period late as the largest angle over the last
    /// half period did (issue 18: that held the feedback on, 1–3 s after the swing had
    /// gone, in most of the cases not let go 5 s after the move). The crane is let go
    /// once load and swing have stayed within the thresholds for [`DWELL`] (so a
    /// momentary dip of the estimate does not let go of a swinging load), and held
    /// again on the amplitude's square averaged over about a period.
    fn settle(&mut self, reference: &Reference, still: Still) {
        // The offset is no longer in the estimate: trusted, or the angle no longer read
        // (not `self.trusted`, which an angle failing before the trust leaves false).
        let offset_out = self.unit.is_none();
        if !still.travel || !self.started || matches!(self.mode, Mode::FeedforwardOnly(_)) {
            self.resting = false;
            self.hoist_resting = false;
            self.swing = Swing::NEW;
            return;
        }
        let l = reference.l.max(0.1);
        let omega = libm::sqrt(self.cfg.g / l);
        let smoothing = 1.0 - libm::exp(-2.0 * omega * self.cfg.h);
        let e = self.estimate();
        let phi = reference.phi + e.z;
        // The load's velocity relative to the rail, as an angle rate: what the swing's
        // rate becomes once the trolley stands still.
        let rate = reference.vphi + e.w + (reference.vx + e.y) / l;
        let sw = &mut self.swing;
        (sw.angle, sw.rate) = if sw.cycles == 0 {
            (phi, rate)
        } else {
            (
                sw.angle + smoothing * (phi - sw.angle),
                sw.rate + smoothing * (rate - sw.rate),
            )
        };
        sw.cycles = sw.cycles.saturating_add(1);
        // The low-pass's gain at the swing frequency (0.89 for the corner at 2ω).
        let r = 1.0 - smoothing;
        let gain = smoothing / libm::sqrt(1.0 - 2.0 * r * libm::cos(omega * self.cfg.h) + r * r);
        let (a, v) = (sw.angle, sw.rate / omega);
        sw.amplitude = libm::sqrt(a * a + v * v) / gain.max(0.1);
        // The load's horizontal place: the trolley's rest; the rope's is the hoist's.
        let load = (e.x + l * e.z).abs();
        sw.load = load;
        let rope = self.ew.x.abs();
        let (pos, swing) = (self.cfg.rest_position, self.cfg.rest_swing);
        sw.within = if load <= pos && sw.amplitude <= swing {
            sw.within.saturating_add(1)
        } else {
            0
        };
        let hold = self.cfg.rest_hysteresis;
        let period = 2.0 * core::f64::consts::PI / omega;
        let a2 = sw.amplitude * sw.amplitude;
        // The hoist starts moving alone, the angle not yet trusted: it stood still with
        // the travel last cycle (not a combined move's hoist going on at its tail).
        let hoist_starts = !still.hoist && !sw.hoist_moving && !offset_out;
        sw.hoist_moving = !still.hoist;
        self.resting = if self.resting {
            sw.energy += (a2 - sw.energy) * (1.0 - libm::exp(-2.0 * self.cfg.h / period));
            load <= hold * pos && sw.energy <= hold * hold * swing * swing
        } else if hoist_starts {
            // Before the trust the estimate cannot yet tell the reading's noise from a
            // swing, and the trolley has no path: it is let go unless it would be held
            // again at once, and held again as a let-go crane is
            // ([`Self::let_go_at_rest`]).
            sw.energy = a2;
            let (hold_position, hold_swing) = self.cfg.hold_thresholds();
            sw.holds_nothing(load, hold_position, hold_swing)
        } else {
            sw.energy = a2;
            // Not on an estimate the angle's offset check has not confirmed yet (until
            // then all of a swing may still be read as offset): once trusted.
            offset_out && f64::from(sw.within) * self.cfg.h >= DWELL
        };
        // The hoist is let go with the trolley, the hoist still and the rope within
        // the same position threshold for the same dwell, and held again beyond
        // `rest_hysteresis` times it (or with the trolley): a hoist-only move's lag is
        // made up before it is let go.
        sw.rope_within = if still.hoist && rope <= pos {
            sw.rope_within.saturating_add(1)
        } else {
            0
        };
        self.hoist_resting = self.resting
            && still.hoist
            && if self.hoist_resting {
                rope <= hold * pos
            } else {
                f64::from(sw.rope_within) * self.cfg.h >= DWELL
            };
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
        let still = Still::of(reference, u_d);
        let mut point = self.gains.at(reference.l);
        // With the travel still (at rest, or only the hoist moving), once the angle is
        // trusted, the observer designed for the rest (GainPoint::obs_rest): the
        // reading's noise is not turned into the trolley's set points. Not before: the
        // offset shown at power-up is taken out by the observer's response to it
        // (Self::unit), which the zero's estimate is judged steady on with the move's
        // observer (with the rest's, a 5° offset from power-up put the trolley 340 mm
        // off, closed_loop.rs).
        if still.travel && self.started && self.unit.is_none() {
            point.obs = point.obs_rest;
            point.obs_sensor = point.obs_sensor_rest;
        }
        let reads_positions = !matches!(self.mode, Mode::FeedforwardOnly(_));
        // The offset shown so far, as the feedback acted on it last cycle: a missing
        // angle resets the zero's estimate once it is no longer bridged (in this
        // cycle's judgement), and the swing must go on from what the feedback acted on.
        let shown = self.shown();
        if let (Some(m), Some(prev), true) = (measured, self.previous, reads_positions) {
            let positions_finite = m.x.is_finite() && m.l.is_finite();
            let ex = m.x - prev.x;
            let check = match self.mode {
                Mode::Closed => self.judge_angle(&m, &prev, ex, &point.obs, still),
                // The angle is no longer read.
                _ => AngleCheck::Missing,
            };
            self.bad_angle_cycles = match check {
                AngleCheck::Good => 0,
                AngleCheck::HeldBack => self.bad_angle_cycles,
                _ => self.bad_angle_cycles.saturating_add(1),
            };
            let was = self.mode;
            self.mode = degraded_rule(
                &self.cfg,
                self.mode,
                check,
                self.bad_angle_cycles,
                positions_finite,
            );
            // Nothing to estimate the swing from: the observer never started (no good
            // angle since the restart), or the one reading it started from is the stuck
            // one — going on would put that "swing" into a still load.
            if let (Mode::Closed, Mode::SwingEstimated(reason)) = (was, self.mode) {
                if !self.started || (reason == Degraded::AngleFrozen && !self.seen_change) {
                    self.mode = Mode::FeedforwardOnly(reason);
                }
            }
            let read = match (self.mode, check, m.phi) {
                (Mode::Closed, AngleCheck::Good, Some(p)) => Some(p),
                _ => None,
            };
            match read {
                // The reading as it is: its offset is the regression's constant term
                // (crate::rope); taking out the zero's estimate instead was tried and
                // is not steady enough during the calibration move (issue 18).
                Some(p) => self.rope.sample(m.x, p, m.l, &prev),
                None => self.rope.gap(),
            }
            // What the observer reads: the angle less its offset — a DC component the
            // pendulum cannot make is never taken for a swing or a displaced load.
            let angle = read.map(|p| p - self.read_offset());
            if let (Mode::Closed, Mode::SwingEstimated(_), Some(u)) = (was, self.mode, self.unit) {
                // The angle failed before it was trusted: the swing goes on from the
                // estimate the feedback acted on, the offset shown so far taken out
                // (as shown before this cycle: a lost angle went on from the raw
                // estimate, a stuck one from this one — with a gust's push read as
                // offset before trust, more than 0.25° or 50 mm apart 5 s after the
                // move in 35 of 1000 mid-move failures, issue 18).
                self.e -= u.e * shown;
                self.sensor -= u.sensor * shown;
                self.unit = None;
            } else if let (Mode::Closed, Mode::SwingEstimated(Degraded::AngleOffset)) =
                (was, self.mode)
            {
                // The offset not yet taken out of the readings (it grew after the angle
                // was trusted) is taken out of the estimate the swing goes on from: the
                // trolley is brought back from where it chased it.
                self.e.z -= self.zero.left();
            }
            match (was, self.mode, self.held.run) {
                (_, Mode::FeedforwardOnly(_), _) => {}
                (Mode::Closed, Mode::SwingEstimated(Degraded::AngleFrozen), Some((run, _))) => {
                    // Stuck since the reading last changed: the estimate from the
                    // positions alone since then (corrected with this sample) is the
                    // one to go on with, not the one the stuck readings pulled along.
                    self.e = run;
                }
                _ if !self.started => {
                    if let (Some(p), Some(raw)) = (angle, read) {
                        // Start from what is measured: positions, and the swing the load
                        // already has (its rate follows from the next samples) — or the
                        // reading's offset: which, the zero's estimate tells once
                        // settled ([`Self::trust`]); until then the estimate holds what
                        // the load's motion has confirmed ([`Self::estimate`]).
                        self.e = Vector5::new(ex, 0.0, p - prev.phi, 0.0, 0.0);
                        self.ew = Vector2::new(m.l - prev.l, 0.0);
                        // The sensor has long reported this angle.
                        self.sensor = SensorStates::repeat(p);
                        self.started = true;
                        self.held.last = Some(raw);
                        self.unit = Some(Unit {
                            e: Vector5::new(0.0, 0.0, 1.0, 0.0, 0.0),
                            sensor: SensorStates::repeat(1.0),
                        });
                    }
                }
                _ => {
                    // Correct the estimate of the previous sample with its measurement;
                    // without a good angle, with the position only.
                    let residual_x = ex - self.e.x;
                    match angle {
                        Some(p) => {
                            let residual = Vector2::new(residual_x, p - self.reading());
                            self.e += point.obs * residual;
                            self.sensor += point.obs_sensor * residual;
                        }
                        None => self.e += position_only(&point.obs, prev.l) * residual_x,
                    }
                    // The same correction of the response to a unit offset (a reading
                    // one higher, the positions the same).
                    if let Some(u) = self.unit.as_mut() {
                        match angle {
                            Some(_) => {
                                let read = self.sensor_model.reading(&u.sensor);
                                let residual = Vector2::new(-u.e.x, 1.0 - read);
                                u.e += point.obs * residual;
                                u.sensor += point.obs_sensor * residual;
                            }
                            None => u.e += position_only(&point.obs, prev.l) * -u.e.x,
                        }
                    }
                    self.ew += point.obs_w * (m.l - prev.l - self.ew.x);
                }
            }
            if self.mode != Mode::Closed {
                self.held = Held::NEW;
            }
        }
        // Predict to now with the correction actually sent; the sensor's filter takes
        // the angle from the previous sample's to this one's.
        let before = self.previous.map_or(reference.phi, |p| p.phi) + self.e.z;
        self.e = predict(&point.model, &self.e, app1);
        self.sensor = self
            .sensor_model
            .predict(&self.sensor, before, reference.phi + self.e.z);
        if let Some(u) = self.unit.as_mut() {
            let before = u.e.z;
            u.e = predict(&point.model, &u.e, 0.0);
            u.sensor = self.sensor_model.predict(&u.sensor, before, u.e.z);
        }
        self.trust();
        self.ew = point.model.aw * self.ew + point.model.bw * app2;
        if let Some((run, _)) = self.held.run.as_mut() {
            *run = predict(&point.model, run, app1);
        }
        self.settle(reference, still);
        let acts = self.started && matches!(self.mode, Mode::Closed | Mode::SwingEstimated(_));
        let mut d1 = if !acts || self.resting {
            // Let go: with the travel still, also while the hoist moves.
            0.0
        } else {
            // At rest the rest's gains (GainPoint::k_rest): the swing damped faster,
            // the long ropes' 1.5 times as fast.
            let k = if still.all() { point.k_rest } else { point.k };
            (-(k * four(&self.estimate()))).x
        };
        let d2 = if !acts || self.hoist_resting {
            0.0
        } else {
            (-(point.kw * self.ew)).x
        };
        if self.held.run.is_some() {
            // The reading has not changed: it may be stuck, so it may not push harder.
            let cap = self.held.correction.abs() + self.cfg.held_allowance;
            d1 = d1.max(-cap).min(cap);
        }
        let u1 = clamp_to_limits(ud1 + d1, last1, limits.trolley, self.cfg.h);
        let u2 = clamp_to_limits(ud2 + d2, last2, limits.winch, self.cfg.h);
        let correction = [u1 - ud1, u2 - ud2];
        // Anti-windup: the observer learns what was sent, not what was wished.
        self.applied = match self.mode {
            Mode::Closed | Mode::SwingEstimated(_) => correction,
            Mode::FeedforwardOnly(_) => [0.0; 2],
        };
        if let Mode::FeedforwardOnly(_) = self.mode {
            self.e = Observed::zeros();
            self.ew = Vector2::zeros();
            self.held = Held::NEW;
        }
        self.previous = Some(*reference);
        let [e0, e1, e2, e3]: [f64; 4] = four(&self.e).into();
        let [w0, w1]: [f64; 2] = self.ew.into();
        Output {
            u: [u1, u2],
            correction,
            mode: self.mode,
            resting: self.hoist_resting,
            swing: self.swing.amplitude,
            error: [e0, e1, e2, e3, w0, w1],
            offset: self.zero.offset(),
            trusted: self.trusted,
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
    /// The correction `u − u_d` the drives were sent after [`Self::correct`], when the
    /// range guard ([`crate::range`]) changed it: the observer learns it.
    /// Required, not defaulted: a wrapper that forgot to forward it would leave its
    /// observer learning what was never sent.
    fn sent(&mut self, correction: [f64; 2]);
    /// Back to closed loop, the observer to start from the next good measurement (the
    /// crane at rest).
    fn restart(&mut self);
    /// See [`crate::correction::AxesCorrection::let_go_at_rest`] (required for the
    /// same reason as [`Self::sent`]).
    fn let_go_at_rest(&mut self);
    /// What it is doing (`None`: there is no feedback).
    fn mode(&self) -> Option<Mode>;
    /// The rope calibration learnt from the swing (`None`: there is no feedback, so no
    /// inclinometer).
    fn rope(&self) -> Option<&RopeLength>;
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
            resting: false,
            swing: 0.0,
            error: [0.0; 6],
            offset: 0.0,
            trusted: false,
        }
    }
    fn sent(&mut self, _correction: [f64; 2]) {}
    fn restart(&mut self) {}
    fn let_go_at_rest(&mut self) {}
    fn mode(&self) -> Option<Mode> {
        None
    }
    fn rope(&self) -> Option<&RopeLength> {
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
    fn sent(&mut self, correction: [f64; 2]) {
        StateFeedback::sent(self, correction);
    }
    fn restart(&mut self) {
        self.reset();
    }
    fn let_go_at_rest(&mut self) {
        StateFeedback::let_go_at_rest(self);
    }
    fn mode(&self) -> Option<Mode> {
        Some(self.mode)
    }
    fn rope(&self) -> Option<&RopeLength> {
        Some(&self.rope)
    }
}

impl Degraded {
    /// The reason byte of the EMCY 0xFF20 announcing the degraded mode (docs/COMMANDS.md).
    #[must_use]
    pub fn code(self) -> u8 {
        match self {
            Self::AngleLost => 1,
            Self::AngleImplausible => 2,
            Self::PositionsInvalid => 3,
            Self::AngleFrozen => 4,
            Self::AngleOffset => 5,
        }
    }
}

#[cfg(test)]
mod tests;
