//! The inclinometer's zero, checked against the pendulum (issue 18, item 3; review
//! finding 12: a biased inclinometer was never caught).
//!
//! A load on a rope can hold a steady angle only under a steady horizontal force. Its
//! horizontal and vertical equations of motion (a point mass on a taut rope, the rope's
//! pull `T` along the measured angle's direction; `x_C = x + l sin φ`, `z_C = l cos φ`
//! below the rail) give the angle from the load's acceleration alone, whatever the
//! trolley, the winch or their lags do:
//!
//! `m ẍ_C = −T sin φ + F`, `m z̈_C = m g − T cos φ`  ⇒  `tan φ = −(ẍ_C − F/m)/(g − z̈_C)`.
//!
//! The load's acceleration is measured: the drives' positions and the inclinometer put
//! the load at `x + l sin φ_m`, and a constant offset `b` of the reading moves that
//! point by about `l b cos φ = b z_C`: constant while the rope is, and otherwise adding
//! only `b z̈_C` to the measured `ẍ_C`: the offset is then seen as `b g/(g − z̈_C)`, off
//! by `z̈_C/g` while the hoist accelerates (3 % at 0.3 m/s²). So the difference between
//! the angle read and the angle the load's measured acceleration requires,
//!
//! `b̂ = atan(tan φ_m) − atan(−ẍ_C/(g − z̈_C))`,
//!
//! is the reading's offset plus `F/(m g)`: a **DC component the pendulum's dynamics
//! cannot produce**. It is computed through the same state-variable filter
//! `ω³/(s + ω)³` on `tan φ_m`, `x_C` and `z_C` (their second derivatives are the
//! filter's states, nothing is differentiated numerically), the idea of
//! [`crate::rope`], which solves the same equation for the rope's length. This is the
//! mean of the angle over a swing period made exact: over any window, `g ∫φ dt` equals
//! minus the change of the load's horizontal velocity (linearised), so the mean of a
//! free swing over a period is zero — here the velocity term is not neglected, which is
//! what lets the test run during a move and with a swing left from it, not only over
//! whole periods of a still trolley.
//!
//! **A steady wind is a bias.** `F/(m g)` and an offset of the reading are the same
//! term: with a position-only trolley (no force or current measured) no test can tell
//! a steady wind from a biased sensor. Both are treated alike, as an offset: the
//! feedback does not act on a DC component that outlasts gusts. Under a steady wind
//! the load then hangs off by `l F/(m g)`, exactly as it does under feedforward alone
//! — never worse; under a bias, acting on it would drive the trolley about `l b` off
//! (146–485 mm for 3–10° on the lab crane, the review's measurement) and leave the
//! load worse than feedforward. A gust is a force too, and a passing one is countered
//! as before: the offset taken out of the readings is the one fixed at rest
//! ([`Zero::fix`]), not the estimate as it goes on; a DC that lasts longer than a gust
//! ([`OFFSET_CYCLES`]) is announced.
//!
//! **Before the angle is trusted.** The estimate starts, with the observer, from the
//! first reading as if it were all offset (the filters start at rest on it — the
//! observer starts at rest, a move being accepted at rest): a reading cannot yet be
//! told apart from a swing, and the swing is taken in as the load's acceleration
//! confirms it — within about 1.5 s ([`CORNER`]). Until the offset is fixed at rest,
//! the feedback's estimate is the observer's less its response to the offset shown
//! ([`Zero::shown`]; `crate::feedback`): so a wrong angle at the start cannot push the
//! trolley — what the feedback may act on is bounded by what the load's own motion
//! has shown. The estimate's own error (its noise, the filtering of products, the
//! rope's length) stays within the [`DEAD_BAND`], inside which nothing is taken out: a
//! healthy crane is read exactly as before.
//!
//! **A step of the zero.** A pendulum's angle is continuous; a reading that leaves the
//! observer's one-cycle prediction by more than [`MAX_STEP`] (12 σ of a 0.02° noise,
//! 5 σ of a 0.05° one, 1.8 times the most the prediction missed on the study's healthy
//! crane) is a
//! step of the zero (a knock on the sensor, a shifted mount) once [`STEP_CYCLES`]
//! readings in a row have left it the same way, and is then added to the offset
//! ([`Zero::off_prediction`]), so it never reaches the observer as a swing; the readings
//! before are held back, bridged like a missing one but not counted as one. A noise outlier does not persist
//! and is never taken for a step.

/// Not a tuning but the filter's design, fixed by the pendulum (the swing's frequency
/// over the rope range, l = 3–9 m), like [`SETTLING_CYCLES`], [`SMOOTHING`] and
/// [`STEADY_CYCLES`], which follow from it: a commissioning engineer has nothing to
/// measure on the crane that would set them otherwise.
///
/// The filter's corner, rad/s: 3–6× the swing's 1.0–1.8 rad/s (l = 3–9 m). A swing
/// present at the start is told from an offset within about `9/ω` = 1.5 s (the
/// triple pole's transient `(ωt)² e^{−ωt}/2` is then under 1 %); its noise on the
/// study's sensors (0.2 mm, 0.02°: the load's position `l φ` is the noisy part, and
/// its second derivative's noise grows as `ω^{5/2}`) is about 0.04° (1σ).
pub const CORNER: f64 = 6.0;

/// Samples from the first reading before the estimate has settled: the triple pole's
/// transient `(ωt)² e^{−ωt}/2` from a reading taken all for offset is then under 1 %
/// (0.05° of a 5° swing, inside [`DEAD_BAND`]).
pub const SETTLING_CYCLES: u32 = 200;

/// The estimate is smoothed further with this time constant, s: the noise of the
/// load's acceleration (its position `l φ` differentiated twice) is a few hundredths
/// of a degree at the filter's corner, and what is judged is a DC component.
pub const SMOOTHING: f64 = 0.25;

/// … and the estimate's means over the last two blocks of this many cycles (1 s)
/// differ by less than the [`DEAD_BAND`]: not in the middle of a gust, whose push
/// would otherwise be taken for the offset (the means, not the samples: the
/// estimate's noise is a few hundredths of a degree, a second's mean's a tenth of it).
pub const STEADY_CYCLES: u32 = 100;

/// The default of [`crate::feedback::Config::offset_dead_band`] (a tuning: it depends
/// on the inclinometer's noise and on how closely the estimate can follow the load).
/// An offset within this is left in the reading, rad (0.1°): the estimate's own error
/// on a healthy crane is a few hundredths of a degree (its noise, the filtering of
/// `tan` and of a ratio), and a healthy crane is then read exactly as before; beyond
/// twice this, all of the offset is taken out, and in between a growing part
/// (continuously). What is left to the feedback, at most 0.1°, moves the
/// trolley by at most about `0.7 l` times it, 11 mm at 9 m.
pub const DEAD_BAND: f64 = 0.00175;

/// The default of [`crate::feedback::Config::offset_step`] (a tuning: a multiple of
/// the inclinometer's noise). A reading further than this from the observer's
/// prediction (and within
/// [`crate::feedback::Config::max_innovation`], beyond which it is implausible) is a
/// step of the zero once it persists ([`STEP_CYCLES`]), rad (0.25°: 12 σ of a 0.02°
/// noise, 5 σ of the noisiest sensor issue 33 names, 0.05° — enough, as a noise outlier
/// is not confirmed by the next two readings —, 1.8 times the
/// largest miss in the 400 healthy runs of `feedback_study --cases 200`, 0.14°, with
/// loads swinging up to 5° at the start and gusts of up to 10 N).
pub const MAX_STEP: f64 = 0.0044;

/// Readings in a row that must leave the observer's prediction by more than
/// [`MAX_STEP`], the same way, before the step of the zero is taken: a knock on the
/// sensor persists, a noise outlier does not. Taken at the first such reading, a
/// 5 σ outlier of a 0.05° noise (the noisiest sensor; a few in a run of the
/// paper's move) became a permanent 0.25° offset whenever the next reading missed by
/// a little less than the threshold on the way back: the feedback then held the load
/// where the reading less that offset put it, the trolley 21 mm past its target, and
/// never let go (issue 33, `interop/test_rope_calibration.py`). The readings held back
/// are bridged by the observer and not counted against
/// [`crate::feedback::Config::max_bad_angle_cycles`] (`AngleCheck::HeldBack`).
pub const STEP_CYCLES: u32 = 3;

/// The default of [`crate::feedback::Config::max_offset`] (a tuning: how much steady
/// deflection the site accepts before it is announced). An offset beyond this, rad
/// (0.5°: the deflection a 1.6 N steady wind gives the lab crane's 18.9 kg load) …
pub const MAX_OFFSET: f64 = 0.0087;

/// … for this many cycles in a row (5 s: longer than the study's longest gust, 3 s,
/// plus the estimate's settling) is announced: the angle is no longer read
/// ([`crate::feedback::Degraded::AngleOffset`]). The default of
/// [`crate::feedback::Config::offset_cycles`] (a tuning: longer than the site's gusts).
pub const OFFSET_CYCLES: u32 = 500;

/// The offset check's thresholds, the tunings of the [`crate::feedback::Config`]
/// (scene `[feedback]`: `offset_dead_band`, `offset_step`, `max_offset`,
/// `offset_cycles`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Thresholds {
    /// An offset within this is left in the reading, rad ([`DEAD_BAND`]).
    pub dead_band: f64,
    /// A reading further than this from the prediction is a step of the zero, rad
    /// ([`MAX_STEP`]).
    pub max_step: f64,
    /// An offset beyond this … rad ([`MAX_OFFSET`]) …
    pub max_offset: f64,
    /// … for this many cycles is announced ([`OFFSET_CYCLES`]).
    pub offset_cycles: u32,
}

impl Thresholds {
    /// Today's values: [`DEAD_BAND`], [`MAX_STEP`], [`MAX_OFFSET`], [`OFFSET_CYCLES`].
    pub const DEFAULT: Self = Self {
        dead_band: DEAD_BAND,
        max_step: MAX_STEP,
        max_offset: MAX_OFFSET,
        offset_cycles: OFFSET_CYCLES,
    };

    /// An offset `o` as it is taken out: not within the dead band, all of it beyond
    /// twice that, and continuously in between (so that no offset is left to act on,
    /// and the estimate does not jump when the offset crosses the band).
    fn beyond_dead_band(&self, o: f64) -> f64 {
        let band = self.dead_band;
        let a = o.abs();
        if a <= band {
            0.0
        } else if a >= 2.0 * band {
            o
        } else {
            2.0 * (a - band) * o.signum()
        }
    }
}

use crate::derivatives::Derivatives;
use crate::reference::Reference;

/// The estimate of the reading's offset (see the module's documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Zero {
    g: f64,
    h: f64,
    limits: Thresholds,
    /// `tan` of the reading less the steps.
    tan: Derivatives,
    /// The load's horizontal position `x + l sin φ`, m.
    xc: Derivatives,
    /// Its depth below the rail `l cos φ`, m.
    zc: Derivatives,
    /// The steps of the zero seen so far, rad.
    steps: f64,
    /// The offset the load's acceleration shows beyond the steps, rad.
    drift: f64,
    /// Samples missing since the last one taken.
    missed: u32,
    /// Cycles in a row with the offset beyond [`MAX_OFFSET`].
    beyond: u32,
    /// Samples taken since the filters started.
    samples: u32,
    /// The sum of the drift over the current block of [`STEADY_CYCLES`], its samples
    /// and whether the crane stood still throughout; the means of the last two blocks
    /// and whether it stood still in each.
    block: (f64, u32, bool),
    means: [Option<f64>; 2],
    still_blocks: [bool; 2],
    /// The part of the drift taken out of the readings ([`Zero::fix`]), rad.
    taken: f64,
    /// The drift when the estimate settled, brought towards nought by two steady
    /// seconds closer to it, rad ([`Zero::shown`]).
    settled: Option<f64>,
    /// Readings in a row that left the prediction by more than the step threshold the
    /// same way, and the last one's miss, rad ([`Zero::off_prediction`]).
    pending: (u32, f64),
}

/// Missing samples in a row the filters bridge (longer, they start again from the
/// next reading, which is then all offset until the load's motion shows otherwise).
const MAX_BRIDGED: u32 = 3;

impl Zero {
    /// Nothing read yet; judged with `limits`.
    #[must_use]
    pub fn new(g: f64, h: f64, limits: Thresholds) -> Self {
        Self {
            g,
            h,
            limits,
            tan: Derivatives::new(CORNER),
            xc: Derivatives::new(CORNER),
            zc: Derivatives::new(CORNER),
            steps: 0.0,
            drift: 0.0,
            missed: 0,
            beyond: 0,
            samples: 0,
            block: (0.0, 0, true),
            means: [None; 2],
            still_blocks: [false; 2],
            taken: 0.0,
            settled: None,
            pending: (0, 0.0),
        }
    }

    /// Whether the estimate has settled since its filters started on a reading
    /// ([`SETTLING_CYCLES`]) — from then on a swing that was there at the start is
    /// told from an offset — and is steady at rest ([`STEADY_CYCLES`]): the offset
    /// can be fixed ([`Zero::fix`]).
    #[must_use]
    pub fn steady_at_rest(&self) -> bool {
        self.samples >= SETTLING_CYCLES && self.steady_still().is_some()
    }

    /// The offset as far as it is shown before it is fixed, beyond the dead band,
    /// rad, the steps not counted: until the estimate has settled, the estimate (all
    /// of the first reading at first, then what the load's motion has not confirmed
    /// as a swing); then the estimate as it was when it settled, brought towards nought
    /// by two steady seconds closer to it, until the crane is at rest and it is
    /// fixed. Not the estimate as it goes on: during a move its small errors (the
    /// rope's length, filtered products) are larger than at rest, and a gust's push is
    /// a force the feedback counters; a gust blowing when the estimate settled fades
    /// from it as the gust drops, an offset does not.
    #[must_use]
    pub fn shown(&self) -> f64 {
        self.limits
            .beyond_dead_band(self.settled.unwrap_or(self.drift))
    }

    /// The steps of the zero seen so far, rad (always taken out of the readings).
    #[must_use]
    pub fn steps(&self) -> f64 {
        self.steps
    }

    /// The last block's mean, when it is within the [`DEAD_BAND`] of the one before.
    fn steady(&self) -> Option<f64> {
        match self.means {
            [Some(a), Some(b)] if (a - b).abs() < self.limits.dead_band => Some(b),
            _ => None,
        }
    }

    /// [`Zero::steady`], both blocks at rest.
    fn steady_still(&self) -> Option<f64> {
        match self.still_blocks {
            [true, true] => self.steady(),
            _ => None,
        }
    }

    /// From now on the offset estimated beyond the [`DEAD_BAND`] is taken out of the
    /// readings ([`Zero::removed`]), with every step that follows.
    pub fn fix(&mut self) {
        self.taken = self
            .limits
            .beyond_dead_band(self.steady_still().unwrap_or(self.drift));
    }

    /// What is taken out of the readings, rad: the steps, and the drift fixed by
    /// [`Zero::fix`]. Not the drift as it goes on: a gust's push is a force the
    /// feedback counters, and only an offset that outlasts gusts is judged
    /// ([`Zero::offset_persists`]).
    #[must_use]
    pub fn removed(&self) -> f64 {
        self.steps + self.taken
    }

    /// The reading's offset believed now, rad.
    #[must_use]
    pub fn offset(&self) -> f64 {
        self.steps + self.drift
    }

    /// The offset not taken out of the readings, beyond the [`DEAD_BAND`], rad.
    #[must_use]
    pub fn left(&self) -> f64 {
        self.limits.beyond_dead_band(self.offset() - self.removed())
    }

    /// This reading left the observer's prediction by `miss` (rad), more than
    /// [`Self::max_step`] and still plausible: `true` once [`STEP_CYCLES`] readings in
    /// a row have missed the same way — a step of the zero, taken now as this last
    /// reading's miss ([`Self::steps`]): a shifted mount reaches the reading through
    /// the sensor's own filter, so the latest miss is the most settled (a 10 ms filter
    /// at 10 ms shows 0.63, 0.86 and 0.95 of the step in three readings) —, `false`
    /// while it is not confirmed: the caller holds the reading back (neither a swing
    /// nor, yet, a step).
    pub fn off_prediction(&mut self, miss: f64) -> bool {
        if !miss.is_finite() {
            self.pending = (0, 0.0);
            return false;
        }
        let (n, last) = self.pending;
        let n = if n > 0 && (last > 0.0) == (miss > 0.0) {
            n + 1
        } else {
            1
        };
        if n < STEP_CYCLES {
            self.pending = (n, miss);
            return false;
        }
        self.steps += miss;
        self.pending = (0, 0.0);
        true
    }

    /// A reading within [`Self::max_step`] of the prediction: the misses before it, if
    /// any, were noise. (A missing or implausible reading neither counts towards a
    /// step nor ends the row.)
    pub fn on_prediction(&mut self) {
        self.pending = (0, 0.0);
    }

    /// A good reading `phi` (rad, as read) with the trolley at `x` and the drum's rope
    /// `l` (m) of the same sample, whose reference was `reference`; `still`: it stands
    /// still (only then is the estimate judged steady: during a move, the equation's
    /// small errors — the rope's length, filtered products — are larger than at rest).
    ///
    /// The first sample starts the filters with the derivatives the reference has: a
    /// start in the middle of a move (the feedback closed on a move already under
    /// way) takes the reading's departure from the reference's angle for an offset,
    /// not the swing the move itself gives the load. At rest that is all of the
    /// reading.
    pub fn sample(&mut self, x: f64, phi: f64, l: f64, reference: &Reference, still: bool) {
        let q = phi - self.steps;
        if !(x.is_finite() && q.is_finite() && l.is_finite()) {
            self.gap();
            return;
        }
        let dt = self.h * f64::from(self.missed.saturating_add(1));
        self.missed = 0;
        self.samples = self.samples.saturating_add(1);
        let (t, ax, az) = if self.tan.started() {
            let [t, _, _] = self.tan.push(libm::tan(q), dt);
            let [_, _, ax] = self.xc.push(x + l * libm::sin(q), dt);
            let [_, _, az] = self.zc.push(l * libm::cos(q), dt);
            (t, ax, az)
        } else {
            let r = reference;
            let (s, c) = (libm::sin(r.phi), libm::cos(r.phi));
            let tan_d = libm::tan(r.phi);
            let rate = (1.0 + tan_d * tan_d) * r.vphi;
            let [t, _, _] = self.tan.start([libm::tan(q), rate, 0.0]);
            // The load's acceleration along the reference: its angle's, as filtered (the
            // filter lags by 3/ω; the winch's acceleration is not known, and is small
            // beside g).
            let lagged = tan_d - 3.0 * rate / CORNER;
            let vx = r.vx + r.vl * s + r.l * c * r.vphi;
            let [_, _, ax] = self.xc.start([x + l * libm::sin(q), vx, -self.g * lagged]);
            let vz = r.vl * c - r.l * s * r.vphi;
            let [_, _, az] = self.zc.start([l * libm::cos(q), vz, 0.0]);
            (t, ax, az)
        };
        // The angle the load's acceleration requires; a load falling freely (the rope
        // slack) tells nothing, and the estimate is held.
        let lift = self.g - az;
        if lift > 0.5 * self.g {
            let raw = libm::atan(t) + libm::atan(ax / lift);
            self.drift = if self.samples <= 1 {
                raw
            } else {
                self.drift + (raw - self.drift) * (1.0 - libm::exp(-dt / SMOOTHING))
            };
        }
        let d = self.drift;
        if self.samples >= SETTLING_CYCLES && self.settled.is_none() {
            self.settled = Some(d);
        }
        let (sum, n, all_still) = self.block;
        let n = n.saturating_add(1);
        self.block = (sum + d, n, all_still && still);
        if n >= STEADY_CYCLES {
            let [_, last] = self.means;
            let [_, last_still] = self.still_blocks;
            self.means = [last, Some((sum + d) / f64::from(n))];
            self.still_blocks = [last_still, all_still && still];
            self.block = (0.0, 0, true);
            // Two steady seconds closer to nought than the estimate when it settled (a
            // gust blowing then has dropped) bring it there; a gust now, a transient,
            // seldom gives two equal means.
            if let (Some(m), Some(s)) = (self.steady(), self.settled) {
                if s * m <= 0.0 {
                    self.settled = Some(0.0);
                } else if m.abs() < s.abs() {
                    self.settled = Some(m);
                }
            }
        }
        let o = self.offset();
        // An offset, or one that has gone since it was fixed (a steady wind dropped).
        self.beyond = if o.abs().max((o - self.removed()).abs()) > self.limits.max_offset {
            self.beyond.saturating_add(1)
        } else {
            0
        };
    }

    /// No good reading this cycle.
    pub fn gap(&mut self) {
        self.missed = self.missed.saturating_add(1);
        if self.missed > MAX_BRIDGED {
            *self = Self {
                steps: self.steps,
                taken: self.taken,
                ..Self::new(self.g, self.h, self.limits)
            };
        }
    }

    /// The offset has stayed beyond [`MAX_OFFSET`] for [`OFFSET_CYCLES`]: longer than a
    /// gust, so a biased sensor or a steady wind.
    #[must_use]
    pub fn offset_persists(&self) -> bool {
        self.beyond >= self.limits.offset_cycles
    }

    /// A reading further than this from the prediction is a step of the zero, rad.
    #[must_use]
    pub fn max_step(&self) -> f64 {
        self.limits.max_step
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    const G: f64 = 9.81;
    const H: f64 = 0.01;
    const REST: Reference = Reference {
        x: 15.0,
        l: 6.0,
        phi: 0.0,
        vx: 0.0,
        vl: 0.0,
        vphi: 0.0,
    };

    /// A free pendulum of length `l` under a trolley that moves as `x(t)`, exact
    /// (RK4 at 1 ms), read every 10 ms with offset `bias(t)`; the offsets estimated.
    fn estimates(
        l: f64,
        phi0: f64,
        x: impl Fn(f64) -> f64,
        bias: impl Fn(f64) -> f64,
        seconds: f64,
    ) -> Vec<f64> {
        let mut zero = Zero::new(G, H, Thresholds::DEFAULT);
        // State φ, φ̇; the trolley's acceleration by central differences of x(t).
        let acc = |t: f64| (x(t + 1e-4) - 2.0 * x(t) + x(t - 1e-4)) / 1e-8;
        let f = |t: f64, s: [f64; 2]| [s[1], (-G * s[0].sin() - acc(t) * s[0].cos()) / l];
        let mut s = [phi0, 0.0];
        let mut out = Vec::new();
        let steps = (seconds / H) as usize;
        for k in 0..steps {
            let t = k as f64 * H;
            zero.sample(x(t), s[0] + bias(t), l, &REST, true);
            out.push(zero.offset());
            let dt = 1e-3;
            for i in 0..10 {
                let t = t + f64::from(i) * dt;
                let k1 = f(t, s);
                let k2 = f(
                    t + dt / 2.0,
                    [s[0] + dt / 2.0 * k1[0], s[1] + dt / 2.0 * k1[1]],
                );
                let k3 = f(
                    t + dt / 2.0,
                    [s[0] + dt / 2.0 * k2[0], s[1] + dt / 2.0 * k2[1]],
                );
                let k4 = f(t + dt, [s[0] + dt * k3[0], s[1] + dt * k3[1]]);
                s = [
                    s[0] + dt / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
                    s[1] + dt / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
                ];
            }
        }
        out
    }

    #[test]
    fn a_free_swing_has_no_offset_once_the_load_has_shown_it() {
        // 5° of swing at 6 m: the first reading is all offset, then the swing is
        // taken in as the load's acceleration shows it.
        let est = estimates(6.0, 5f64.to_radians(), |_| 15.0, |_| 0.0, 20.0);
        assert!((est[0] - 5f64.to_radians()).abs() < 1e-12);
        let settled = SETTLING_CYCLES as usize;
        let late = est[settled..].iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!(late < DEAD_BAND, "{:.3}°", late.to_degrees());
        assert!(!{
            let mut z = Zero::new(G, H, Thresholds::DEFAULT);
            z.beyond = OFFSET_CYCLES - 1;
            z.offset_persists()
        });
    }

    #[test]
    fn a_swing_under_a_moving_trolley_has_no_offset() {
        // The trolley swings the load: 2 m back and forth with a 7 s period (the
        // pendulum's is 4 s). What is left is the filtering of a ratio and of `tan`
        // (products of filtered signals), a tenth of a degree at most.
        let x = |t: f64| 15.0 + 1.0 - (2.0 * std::f64::consts::PI * t / 7.0).cos();
        let est = estimates(4.0, 0.0, x, |_| 0.0, 20.0);
        let worst = est.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!(worst < 0.15f64.to_radians(), "{:.3}°", worst.to_degrees());
    }

    #[test]
    fn a_steady_offset_is_seen_from_the_start_and_through_a_move() {
        // Within 0.1° and 3 %: the load's position is computed with the offset reading,
        // whose curvature is about `cos b` times the true one (1.5 % at 10°).
        for bias in [3f64, -10.0] {
            let b = bias.to_radians();
            let x = |t: f64| 15.0 + 1.0 - (2.0 * std::f64::consts::PI * t / 7.0).cos();
            let est = estimates(4.0, 1f64.to_radians(), x, |_| b, 10.0);
            for (k, e) in est.iter().enumerate().skip(SETTLING_CYCLES as usize) {
                assert!(
                    (e - b).abs() < 0.1f64.to_radians() + 0.03 * b.abs(),
                    "{bias}° at cycle {k}: {:.3}°",
                    e.to_degrees()
                );
            }
        }
    }

    #[test]
    fn a_slow_drift_is_followed() {
        // 1° per 10 s, the load swinging 2°.
        let est = estimates(
            6.0,
            2f64.to_radians(),
            |_| 15.0,
            |t| 0.1f64.to_radians() * t,
            30.0,
        );
        for (k, e) in est.iter().enumerate().skip(200) {
            let b = 0.1f64.to_radians() * k as f64 * H;
            assert!((e - b).abs() < 0.1f64.to_radians(), "cycle {k}");
        }
    }

    #[test]
    fn steps_and_gaps() {
        let mut z = Zero::new(G, H, Thresholds::DEFAULT);
        z.sample(15.0, 0.02, 6.0, &REST, true);
        for _ in 0..STEP_CYCLES {
            z.off_prediction(0.01);
        }
        z.sample(15.0, 0.03, 6.0, &REST, true);
        assert!((z.offset() - 0.03).abs() < 1e-9);
        for _ in 0..=MAX_BRIDGED {
            z.gap();
        }
        // Restarted, the steps kept: the next reading is all offset.
        z.sample(15.0, 0.05, 6.0, &REST, true);
        assert!((z.offset() - 0.05).abs() < 1e-12);
        z.sample(f64::NAN, 0.05, 6.0, &REST, true);
        assert_eq!(z.missed, 1);
    }

    #[test]
    fn a_step_is_taken_once_it_persists_an_outlier_never() {
        let mut z = Zero::new(G, H, Thresholds::DEFAULT);
        // A knock: three readings in a row 1.5° off the prediction, the same way.
        // Seen through the sensor's filter: the last, most settled miss is the step.
        let knock = 1.5f64.to_radians();
        assert!(!z.off_prediction(0.9 * knock));
        assert!(!z.off_prediction(0.97 * knock));
        assert_eq!(z.steps(), 0.0, "not before it is confirmed");
        assert!(z.off_prediction(knock));
        assert!((z.steps() - knock).abs() < 1e-12, "the last miss");
        // Outliers: one off, then back on the prediction; two off opposite ways.
        let spike = MAX_STEP * 1.05;
        for _ in 0..10 {
            assert!(!z.off_prediction(spike));
            z.on_prediction();
            assert!(!z.off_prediction(spike));
            assert!(!z.off_prediction(-spike));
            assert!(!z.off_prediction(spike));
            z.on_prediction();
        }
        assert!(
            (z.steps() - knock).abs() < 1e-12,
            "no outlier taken for a step"
        );
        // A non-finite miss ends a row.
        assert!(!z.off_prediction(spike));
        assert_eq!(z.pending.0, 1);
        assert!(!z.off_prediction(f64::NAN));
        assert_eq!(z.pending, (0, 0.0));
    }
}
