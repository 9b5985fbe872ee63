//! Starting from a moving load: the hand-over from a running automatic move.
//!
//! **Why not continue the move's steady state.** The first design let the generator
//! start in the steady state of the move's acceleration (its rate limiter as if it had
//! accelerated at the move's acceleration, within the axis's limit, for longer than the
//! filters remember) and blended what that state cannot represent — the acceleration
//! beyond the limit and the move's third to fifth derivatives — away over a fixed 4 s
//! with the Hermite basis below. Measured with the exact flat inverse
//! (`cargo run --release -p host-tests --example takeover_limits`, before this change):
//! up to 2.58 times the trolley's acceleration limit (3 m/s²) 20 % into a 6 s move,
//! 1.03 times at 10 %, where the move's acceleration is only 0.12 m/s². The drive past
//! its limit is the trolley, its rate `u̇ ≈ ẍ` (the drive lag is 30 ms), 0.4–0.6 s after
//! the take-over (−5.6 and −7.0 m/s² there), then a swing of the set point with a period
//! of about 2 s over the whole blend. The cause is the blend's fourth derivative: the
//! trolley is at `x = x_L + ẍ_L z_C/(g − z̈_C)`, so its acceleration carries
//! `x_L⁗ z_C/g` (0.8 s² on an 8 m rope), and the blend's share of `x_L⁗` is
//! `Σ_j e_j T^{j−4} H_j⁗(τ)` — for the move's jerk and snap (`e₃` = 1.77 m/s³,
//! `e₄` = 0.47 m/s⁴, `e₅` = −6.8 m/s⁵ at 20 % of the 6 s move) over `T` = 4 s several
//! m/s⁴. No fixed length fixes it: the terms above the second derivative grow with
//! `T^{j−2}`, those below shrink (1 s: 20 times the limit at 20 %; 16 s: 230 times at
//! 5 %, from `e₅ T⁵`), and the steady state itself keeps the move's speed, whose
//! continuation leaves the workspace (refused at 50 %).
//!
//! **The hand-over now: the move's stop and the stick, added.** The move ends with a stop
//! of its own — a path from the move's state (derivatives 0..=5 at the hand-over) to rest
//! on the move's path, at or before its target — and the generator starts *at rest at
//! that stop's end*, the stick live from the first cycle. The load path is the sum: the
//! generator's own path plus the stop's remainder `E(t) = S(t) − S_end`, which starts with
//! exactly the move's state minus the rest (so the set points continue with all their
//! derivatives) and ends with every derivative zero after the stop's duration `T`. On
//! `[0, T]`, `τ = t/T`, it is the two-point Hermite interpolant of degree 11,
//! `E(t) = Σ_j e_j T^j H_j(τ)`, `H_j(τ) = τ^j/j! · (1 − τ)⁶ · Σ_{k=0}^{5−j} C(5+k, k) τ^k`
//! (`H_j^{(i)}(0) = δ_ij`, `H_j^{(i)}(1) = 0`, `i ≤ 5`); for a straight point-to-point move
//! of degree 11 (the planner's) every `e_j` points along the move, so the stop stays on
//! its path, and `T` = the time the move has left with the end at the target *is* the
//! move.
//!
//! The stop's duration and end are chosen from the state: the shortest `T` (from 0.25 s
//! up by a fifth each time, and the move's own remaining time; at most
//! [`Settings::entry_blend`](crate::operator::Settings::entry_blend)) and then the end —
//! first the trolley's smoothest (least `∫ ẍ² dt`), then shares of the way left to the
//! target in eighths from the nearest — whose stop never turns back and keeps the drives' motion it adds within the caller's [`Headroom`] — the trolley's
//! speed and acceleration from the flat inverse with the rope held, `ẋ = Ė + c E⃛`,
//! `ẍ = Ë + c E⁗`, `c = l_g/g` (the generator pendulum for the deeper of the load's depth
//! and the move's target), the hoist's `Ė_z`, `Ë_z` — at 17 points of the stop. The
//! headroom is what the drives have left beside the operator's own motion, so that the
//! sum stays within the limits (the caller's choice: the tests take 95 % of each limit
//! less the manual speed and 1.5 times the manual acceleration). While the stop lasts,
//! the generator's ranges are narrowed by the stop's excursion (the load's and the
//! trolley's), and its pendulum is tuned for the stop's deepest load, braked downwards.
//!
//! A stop commanded while the hand-over's stop lasts plans that stop again from where it
//! is ([`Ends::Nearest`]): the same search, the shares of the travel's way left from the
//! nearest, the hoist to the end it had (`Generator::stop_within`).
//!
//! Refused ([`Error::NoHandoverStop`] when no stop keeps within the
//! headroom, [`Error::OutsideWorkspace`] when the stop leaves a range or the rope is
//! longer than the virtual pendulum may be): the controller then lets the move stop on
//! its path and hands over at rest.

use crate::error::{Error, Result};
use crate::operator::ends::END_WINDOW;
use crate::operator::filter::u64_to_f64;
use crate::operator::piece::{binomial, factorial, Polynomial, COEFFS};
use crate::trajectory::Trajectory;

/// The derivatives that are continued: position to fifth.
pub const ORDERS: usize = 6;

/// A moving load's state: per output its position and first five derivatives, and where
/// and when the move would have come to rest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Handover<const NH: usize> {
    /// The horizontal outputs, `[z, ż, z̈, z⃛, z⁗, z⁽⁵⁾]` each.
    pub horizontal: [[f64; ORDERS]; NH],
    /// The load's depth and its derivatives.
    pub hoist: [f64; ORDERS],
    /// The move's target, horizontal outputs: the stop ends at or before it.
    pub target: [f64; NH],
    /// The move's target depth.
    pub hoist_target: f64,
    /// The time the move has left until it rests at its target, s (one of the stop
    /// durations tried: with the end at the target, that stop is the move itself).
    pub rest_in: f64,
}

impl Handover<1> {
    /// The planar path `[x_C, z_C]` at `t`, its target where its active span ends.
    #[must_use]
    pub fn of<Z: Trajectory<f64, 2>>(path: &Z, t: f64) -> Self {
        let d = path.derivatives::<ORDERS>(t).map(<[f64; 2]>::from);
        let end = path.active_span().1;
        let [[x, z]] = path.derivatives::<1>(end).map(<[f64; 2]>::from);
        Self {
            horizontal: [d.map(|[x, _]| x)],
            hoist: d.map(|[_, z]| z),
            target: [x],
            hoist_target: z,
            rest_in: end - t,
        }
    }
}

impl Handover<2> {
    /// The 3D path `[x_C, y_C, z_C]` at `t`, its target where its active span ends.
    #[must_use]
    pub fn of<Z: Trajectory<f64, 3>>(path: &Z, t: f64) -> Self {
        let d = path.derivatives::<ORDERS>(t).map(<[f64; 3]>::from);
        let end = path.active_span().1;
        let [[x, y, z]] = path.derivatives::<1>(end).map(<[f64; 3]>::from);
        Self {
            horizontal: [d.map(|[x, _, _]| x), d.map(|[_, y, _]| y)],
            hoist: d.map(|[_, _, z]| z),
            target: [x, y],
            hoist_target: z,
            rest_in: end - t,
        }
    }
}

/// What a hand-over's stop may add to one drive's motion, beside the operator's own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Room {
    /// Speed, m/s.
    pub speed: f64,
    /// Acceleration, m/s².
    pub acceleration: f64,
}

/// What a hand-over's stop may add to each drive's motion: the drives' limits less what
/// the operator's generator may use of them at the same time (the caller knows both).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Headroom<const NH: usize> {
    /// The drives carrying the horizontal outputs (planar: trolley; 3D: bridge, trolley).
    pub horizontal: [Room; NH],
    /// The hoist.
    pub hoist: Room,
}

/// The blend `E(t)`, added to the path where the path is evaluated
/// ([`Blend::add_to`]): per axis its coefficients in `θ' = θ − 1` on the current cycle
/// (`θ = (t − t_n)/h`) — the share about the cycle's *end*, so that its value and first
/// derivatives there, what BDF asks every step, are its lowest coefficients — moved on
/// by one cycle at each cycle after the first (a Taylor shift by 1: additions only), for
/// the cycles it has left.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blend<const NH: usize> {
    horizontal: [[f64; COEFFS]; NH],
    hoist: [f64; COEFFS],
    /// Cycles with a share after the current one (before the first cycle: all of
    /// them); 0 on its last cycle, whose share holds until the next cycle begins.
    left: u64,
    /// Whether a cycle took the share yet (before the first the share is the first
    /// cycle's: it starts where the generator's first cycle does).
    started: bool,
    /// The hoist's share: its largest depth and downward acceleration, m and m/s² (≥ 0),
    /// for the virtual pendulum's length while it lasts.
    pub(crate) hoist_extent: [f64; 2],
}

/// The monomial coefficients of the Hermite basis `H_j(τ)`, `j = 0..=5` (module
/// documentation): `(1 − τ)⁶ Σ_{k ≤ 5−j} C(5+k, k) τ^k`, times `τ^j/j!`.
pub const HERMITE: [[f64; COEFFS]; ORDERS] = hermite();

#[allow(clippy::indexing_slicing)] // evaluated at compile time: an index out of range fails the build
const fn hermite() -> [[f64; COEFFS]; ORDERS] {
    let mut out = [[0.0; COEFFS]; ORDERS];
    let mut j = 0;
    while j < ORDERS {
        let j_factorial = factorial(j);
        let mut k = 0;
        while k < ORDERS - j {
            let ck = binomial(5 + k, k);
            let mut i = 0;
            while i <= 6 {
                let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
                out[j][i + k + j] += ck * sign * binomial(6, i) / j_factorial;
                i += 1;
            }
            k += 1;
        }
        j += 1;
    }
    out
}

/// The blend of one axis as monomial coefficients in τ, from its τ-derivatives `e`.
fn blend_axis(e: &[f64; ORDERS]) -> [f64; COEFFS] {
    let mut out = [0.0; COEFFS];
    for (ej, basis) in e.iter().zip(HERMITE.iter()) {
        for (o, b) in out.iter_mut().zip(basis) {
            *o += ej * b;
        }
    }
    out
}

/// `p(θ + 1)` in place: the Taylor shift by one by repeated synthetic division
/// (Horner's scheme: `a_j += a_{j+1}` for every `j` from the top, once per coefficient —
/// `n(n−1)/2` additions).
fn shift_by_one(a: &mut [f64; COEFFS]) {
    for i in 0..COEFFS - 1 {
        for j in (i..COEFFS - 1).rev() {
            let next = a.get(j + 1).copied().unwrap_or(0.0);
            if let Some(slot) = a.get_mut(j) {
                *slot += next;
            }
        }
    }
}

/// [`shift_by_one`] of every horizontal share and the hoist's. (The axes' additions
/// side by side, three chains at a time, cost more, not less: 3D blend cycles 2,849 point
/// cycles where one axis after the other gives about 2,420, `cargo xtask cycles
/// --scenario manual-takeover-3d`.)
fn shift_each<const NH: usize>(horizontal: &mut [[f64; COEFFS]; NH], hoist: &mut [f64; COEFFS]) {
    for e in horizontal.iter_mut() {
        shift_by_one(e);
    }
    shift_by_one(hoist);
}

/// `p(s θ)`: the coefficients of `p(τ)` scaled by `s^j`.
fn scaled(mut p: [f64; COEFFS], s: f64) -> [f64; COEFFS] {
    let mut s_j = 1.0;
    for c in p.iter_mut() {
        *c *= s_j;
        s_j *= s;
    }
    p
}

impl<const NH: usize> Blend<NH> {
    /// Moves the share on to the cycle that begins (the first cycle keeps the first
    /// share); returns whether the blend lasts beyond this cycle.
    pub fn advance(&mut self) -> bool {
        if self.left == 0 {
            return false;
        }
        if self.started {
            shift_each(&mut self.horizontal, &mut self.hoist);
        }
        self.started = true;
        self.left -= 1;
        self.left > 0
    }

    /// The stop's state now — at the start of the cycle that begins next, where a stop
    /// commanded in between takes over — as a hand-over's state in the blend's own
    /// coordinates: `E` and its derivatives per axis, every target 0 (the stop's end),
    /// the rest in the cycles it has left.
    #[must_use]
    pub fn now(&self, h: f64) -> Handover<NH> {
        // Started: the current share's end (θ' = 0); before the first cycle, its start.
        let at = if self.started { 0.0 } else { -1.0 };
        let inv_h = 1.0 / h;
        Handover {
            horizontal: self.horizontal.map(|e| share::<ORDERS>(&e, at, inv_h)),
            hoist: share::<ORDERS>(&self.hoist, at, inv_h),
            target: [0.0; NH],
            hoist_target: 0.0,
            rest_in: u64_to_f64(self.left) * h,
        }
    }

    /// Cycles with a share from the cycle that begins next (the first included before
    /// it started).
    #[must_use]
    pub fn cycles_left(&self) -> u64 {
        self.left
    }

    /// Whether cycles with a share remain after the current one.
    #[must_use]
    pub fn lasts(&self) -> bool {
        self.left > 0
    }

    /// The hoist's share at the current cycle's start (θ = 0), m.
    #[must_use]
    pub fn hoist_at_start(&self) -> f64 {
        let [x] = share::<1>(&self.hoist, -1.0, 1.0);
        x
    }

    /// Adds the share on the current cycle at `θ` (its first `D − 1` derivatives too) to
    /// the path's values: within [`END_WINDOW`] of the cycle's end (`D ≤ 3`) from its
    /// lowest coefficients, continued to first order as the pieces' ends are; elsewhere by
    /// synthetic division at `θ − 1`.
    pub fn add_to<const D: usize>(
        &self,
        horizontal: &mut [[f64; D]; NH],
        hoist: &mut [f64; D],
        theta: f64,
        inv_h: f64,
    ) {
        let delta = theta - 1.0;
        let at_end = D <= 3 && libm::fabs(delta) <= END_WINDOW;
        let value = |e: &[f64; COEFFS]| {
            if at_end {
                share_at_end::<D>(e, delta, inv_h)
            } else {
                share::<D>(e, delta, inv_h)
            }
        };
        for (out, e) in horizontal.iter_mut().zip(self.horizontal.iter()) {
            for (o, s) in out.iter_mut().zip(value(e)) {
                *o += s;
            }
        }
        for (o, s) in hoist.iter_mut().zip(value(&self.hoist)) {
            *o += s;
        }
    }
}

/// One axis's share and its first two derivatives at `θ' = δ` near 0 (the cycle's end):
/// `c₀ + c₁δ`, `(c₁ + 2c₂δ)/h`, `(2c₂ + 6c₃δ)/h²`.
#[allow(clippy::indexing_slicing)] // constant indices below COEFFS: checked when compiled
fn share_at_end<const D: usize>(c: &[f64; COEFFS], delta: f64, inv_h: f64) -> [f64; D] {
    let values = [
        c[0] + c[1] * delta,
        (c[1] + 2.0 * c[2] * delta) * inv_h,
        (2.0 * c[2] + 6.0 * c[3] * delta) * (inv_h * inv_h),
    ];
    let mut out = [0.0; D];
    for (o, v) in out.iter_mut().zip(values) {
        *o = v;
    }
    out
}

/// One axis's share at `θ'` (`θ − 1`). Never inlined: the polynomial it evaluates is a
/// local of its own frame, not one per axis in the evaluation's.
#[inline(never)]
fn share<const D: usize>(coeffs: &[f64; COEFFS], theta: f64, inv_h: f64) -> [f64; D] {
    let mut p = Polynomial::rest(0.0);
    p.coeffs = *coeffs;
    p.eval::<D>(theta, inv_h)
}

/// `∫₀¹ H₀^{(a)} H_j^{(b)} dτ` for `j = 0..=5`: the Gram row the least-squares end of a
/// stop is built from (evaluated at compile time).
#[allow(clippy::indexing_slicing)] // evaluated at compile time: an index out of range fails the build
const fn gram_row(a: usize, b: usize) -> [f64; ORDERS] {
    let mut out = [0.0; ORDERS];
    let mut j = 0;
    while j < ORDERS {
        let mut p = a;
        while p < COEFFS {
            let mut q = b;
            while q < COEFFS {
                let dp = HERMITE[0][p] * falling(p, a);
                let dq = HERMITE[j][q] * falling(q, b);
                out[j] += dp * dq / ((p - a + q - b + 1) as f64);
                q += 1;
            }
            p += 1;
        }
        j += 1;
    }
    out
}

/// `p!/(p − k)!`.
const fn falling(p: usize, k: usize) -> f64 {
    factorial(p) / factorial(p - k)
}

/// The Gram rows of `Ë` with itself, with `E⁗` (both orders), and of `E⁗` with itself.
const GRAM_22: [f64; ORDERS] = gram_row(2, 2);
const GRAM_24: [f64; ORDERS] = gram_row(2, 4);
const GRAM_42: [f64; ORDERS] = gram_row(4, 2);
const GRAM_44: [f64; ORDERS] = gram_row(4, 4);

/// Points `τ = i/SAMPLES` at which a stop's drive motion is checked.
const SAMPLES: usize = 16;

/// The shortest stop tried, s; each next one a fifth longer.
const SHORTEST_STOP: f64 = 0.25;

/// The ends tried, as a share of the way left to the target: the nearest first.
const SHARES: [f64; 9] = [0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0];

/// One axis's stop: its blend's time derivatives at the start (`e₀` = where it is less
/// where it ends), and what it adds, relative to its end: the least and largest of the
/// load's and the trolley's position, m, and the load's largest downward acceleration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct AxisStop {
    /// `[e₀, …, e₅]`.
    pub e: [f64; ORDERS],
    /// Least excursion, m (≤ 0).
    pub low: f64,
    /// Largest excursion, m (≥ 0).
    pub high: f64,
    /// Largest `Ë` (positive: downwards for the hoist), m/s².
    pub down: f64,
}

/// A hand-over's stop on every axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Stop<const NH: usize> {
    /// Its duration in cycles.
    pub cycles: u64,
    /// The horizontal axes.
    pub horizontal: [AxisStop; NH],
    /// The hoist.
    pub hoist: AxisStop,
}

impl<const NH: usize> Stop<NH> {
    /// Its blend (cycle `h`), starting at the stop's start, with the hoist's extent.
    pub(crate) fn blend(&self, h: f64) -> Blend<NH> {
        let mut blend = new_blend(self.cycles, h, &self.horizontal.map(|a| a.e), &self.hoist.e);
        blend.hoist_extent = [self.hoist.high, self.hoist.down.max(0.0)];
        blend
    }
}

/// The coefficients of `P^{(k)}` from those of `P`.
fn derivative(p: &[f64; COEFFS]) -> [f64; COEFFS] {
    let mut out = [0.0; COEFFS];
    for (i, (o, c)) in out.iter_mut().zip(p.iter().skip(1)).enumerate() {
        *o = c * (i + 1) as f64;
    }
    out
}

/// Horner's sum of `p` at `x`.
fn horner(p: &[f64; COEFFS], x: f64) -> f64 {
    p.iter().rev().fold(0.0, |acc, c| acc * x + c)
}

/// The stop of one axis in state `d` over `duration` s to `distance` from where it is,
/// if it keeps within `room` (trolley: `ẋ = Ė + c E⃛`, `ẍ = Ë + c E⁗`; `c = 0` for the
/// hoist) and never moves against `forward` (the way to the target's sign, 0: either).
///
/// Every check fails closed: a comparison with NaN is false, so each is written as the
/// negation of what may pass (`!(|v| ≤ room)`), and a stop from values that are not
/// finite, or over no time, is refused before it is sampled.
fn axis_stop(
    d: &[f64; ORDERS],
    distance: f64,
    duration: f64,
    c: f64,
    room: &Room,
    forward: f64,
) -> Option<AxisStop> {
    let inputs = d.iter().chain([&distance, &duration, &c, &forward]);
    if !(inputs.into_iter().all(|v| v.is_finite()) && duration > 0.0) {
        return None;
    }
    let mut tau = *d;
    let mut scale = 1.0;
    for t in tau.iter_mut() {
        *t *= scale;
        scale *= duration;
    }
    if let Some(e0) = tau.first_mut() {
        *e0 = -distance;
    }
    let p = blend_axis(&tau);
    if !p.iter().all(|coefficient| coefficient.is_finite()) {
        return None;
    }
    let p1 = derivative(&p);
    let p2 = derivative(&p1);
    let p3 = derivative(&p2);
    let p4 = derivative(&p3);
    let (inv, inv2) = (1.0 / duration, 1.0 / (duration * duration));
    let mut stop = AxisStop {
        e: *d,
        low: 0.0,
        high: 0.0,
        down: f64::NEG_INFINITY,
    };
    if let Some(e0) = stop.e.first_mut() {
        *e0 = -distance;
    }
    for i in 0..=SAMPLES {
        let x = i as f64 / SAMPLES as f64;
        let (pos, v, a) = (horner(&p, x), horner(&p1, x) * inv, horner(&p2, x) * inv2);
        let trolley_v = v + c * horner(&p3, x) * inv * inv2;
        let trolley_a = a + c * horner(&p4, x) * inv2 * inv2;
        if !(libm::fabs(trolley_v) <= room.speed
            && libm::fabs(trolley_a) <= room.acceleration
            && v * forward >= -1e-9
            && pos.is_finite())
        {
            return None;
        }
        let trolley = pos + c * a;
        stop.low = stop.low.min(pos).min(trolley);
        stop.high = stop.high.max(pos).max(trolley);
        stop.down = stop.down.max(a);
    }
    Some(stop)
}

/// The end of least `∫ (Ë + c E⁗)² dt` over a stop of `duration` (the smoothest for the
/// trolley), as a share of `remaining` (the way left to the target): what the Gram rows
/// give for `e₀`.
fn smoothest_share(d: &[f64; ORDERS], remaining: f64, duration: f64, c: f64) -> Option<f64> {
    let gamma = c / (duration * duration);
    let row = |j: usize| {
        let g = |r: &[f64; ORDERS]| r.get(j).copied().unwrap_or(0.0);
        g(&GRAM_22) + gamma * (g(&GRAM_24) + g(&GRAM_42)) + gamma * gamma * g(&GRAM_44)
    };
    let mut scale = duration;
    let mut rest = 0.0;
    for (j, dj) in d.iter().enumerate().skip(1) {
        rest += dj * scale * row(j);
        scale *= duration;
    }
    let share = rest / row(0) / remaining;
    (remaining != 0.0 && share.is_finite()).then_some(share.clamp(0.0, 1.0))
}

/// Which end of a stop is tried first at each duration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Ends {
    /// A hand-over: the trolley's smoothest end first, then the shares from the nearest;
    /// the hoist takes the same share of its way, so the stop stays on the move's path.
    Smoothest,
    /// A stop commanded during a hand-over's stop
    /// ([`Generator::stop_within`](crate::operator::Generator::stop_within)): the
    /// horizontal shares from the nearest; the hoist keeps the end it was stopping at (its
    /// origin is the generator's, which the shortened stop does not move).
    Nearest,
}

/// The stop of a hand-over (module documentation): the shortest duration, then the
/// nearest end (`ends`), that keeps within `room`; `c = l_g/g`, `h` the cycle, `longest`
/// the longest duration, s. `None`: no stop does.
// Always inlined: with two callers (the take-over, a stop during its stop) the compiler
// kept it out of line, and its ~700 B frame went below the take-over's on the control
// task's stack (QEMU `manual-takeover-3d`: 8,440 B; 8,280 B inlined, against 7,672 B
// before the second caller). Each caller is a function of its own, called only in the
// cycle that searches.
#[inline(always)]
pub(crate) fn plan_stop<const NH: usize>(
    state: &Handover<NH>,
    room: &Headroom<NH>,
    c: f64,
    h: f64,
    longest: f64,
    ends: Ends,
) -> Option<Stop<NH>> {
    let last = libm::round(longest / h).max(1.0) as u64;
    let own = libm::round(state.rest_in / h);
    let own = (own >= 1.0 && own <= last as f64).then_some(own as u64);
    // `max` and `min`, not `clamp`: the compiler cannot see that `last ≥ 1` (a float
    // cast), and `clamp`'s check of its bounds is a panicking branch (the panic proof).
    let mut cycles = (libm::round(SHORTEST_STOP / h) as u64).max(1).min(last);
    loop {
        // The move's own remaining time, where it falls before the next duration.
        let next = ((cycles as f64 * 1.2) as u64).max(cycles + 1);
        for n in [
            Some(cycles),
            own.filter(|o| *o > cycles && *o < next.min(last + 1)),
        ]
        .into_iter()
        .flatten()
        {
            if let Some(stop) = stop_over(state, room, c, n, h, ends) {
                return Some(stop);
            }
        }
        if cycles >= last {
            return None;
        }
        cycles = next.min(last);
    }
}

/// The nearest stop over `cycles` cycles that keeps within `room`, if any: first the
/// trolley's smoothest end (where it is on the way, [`Ends::Smoothest`]), then the shares
/// from the nearest.
fn stop_over<const NH: usize>(
    state: &Handover<NH>,
    room: &Headroom<NH>,
    c: f64,
    cycles: u64,
    h: f64,
    ends: Ends,
) -> Option<Stop<NH>> {
    let duration = cycles as f64 * h;
    // The way left per axis, and the horizontal axis that has the most of it.
    let mut remaining = [0.0; NH];
    for ((r, d), target) in remaining
        .iter_mut()
        .zip(&state.horizontal)
        .zip(state.target)
    {
        *r = target - d[0];
    }
    let hoist_remaining = state.hoist_target - state.hoist[0];
    let widest = remaining
        .iter()
        .zip(&state.horizontal)
        .fold((0.0_f64, None), |(w, best), (r, d)| {
            if libm::fabs(*r) > w {
                (libm::fabs(*r), Some((d, *r)))
            } else {
                (w, best)
            }
        })
        .1;
    let smoothest = widest
        .filter(|_| ends == Ends::Smoothest)
        .and_then(|(d, r)| smoothest_share(d, r, duration, c));
    let forward = sign(hoist_remaining);
    // The nearest ends keep the hoist's: its stop over this duration is one for every
    // share, worked out (or refused) once.
    let kept_hoist = match ends {
        Ends::Smoothest => None,
        Ends::Nearest => Some(axis_stop(
            &state.hoist,
            hoist_remaining,
            duration,
            0.0,
            &room.hoist,
            forward,
        )?),
    };
    for share in smoothest.into_iter().chain(SHARES) {
        let mut horizontal = [AxisStop {
            e: [0.0; ORDERS],
            low: 0.0,
            high: 0.0,
            down: 0.0,
        }; NH];
        let mut all = true;
        for (((out, d), r), axis_room) in horizontal
            .iter_mut()
            .zip(&state.horizontal)
            .zip(remaining)
            .zip(&room.horizontal)
        {
            match axis_stop(d, share * r, duration, c, axis_room, sign(r)) {
                Some(s) => *out = s,
                None => {
                    all = false;
                    break;
                }
            }
        }
        if !all {
            continue;
        }
        let hoist = match kept_hoist {
            Some(hoist) => Some(hoist),
            None => axis_stop(
                &state.hoist,
                share * hoist_remaining,
                duration,
                0.0,
                &room.hoist,
                forward,
            ),
        };
        if let Some(hoist) = hoist {
            return Some(Stop {
                cycles,
                horizontal,
                hoist,
            });
        }
    }
    None
}

/// `1`, `−1` or `0` (for 0); NaN for NaN, which [`axis_stop`] refuses (0 would let the
/// stop move either way).
fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else if x == 0.0 {
        0.0
    } else {
        f64::NAN
    }
}

/// Refuses a position that is not a number or outside `[lo, hi]`, naming the coordinate.
pub(crate) fn check_inside(
    coordinate: &'static str,
    value: f64,
    (lo, hi): (f64, f64),
    t: f64,
) -> Result<()> {
    if !(lo..=hi).contains(&value) {
        return Err(Error::OutsideWorkspace {
            t,
            coordinate,
            value,
            min: lo,
            max: hi,
        });
    }
    Ok(())
}

/// A blend over `cycles` cycles of `h` from the next cycle on, with the differences
/// `e[j]` in the j-th time derivative at its start: `E(τ) = Σ_j e_j T_b^j H_j(τ)`, as
/// coefficients in `θ' = θ − 1` about the first cycle's end (`τ = θ/cycles`; [`Blend`]).
fn new_blend<const NH: usize>(
    cycles: u64,
    h: f64,
    horizontal: &[[f64; ORDERS]; NH],
    hoist: &[f64; ORDERS],
) -> Blend<NH> {
    let duration = cycles as f64 * h;
    // d^j/dτ^j = T_b^j d^j/dt^j, then E in θ.
    let in_theta = |e: &[f64; ORDERS]| {
        let mut tau = *e;
        let mut scale = 1.0;
        for o in tau.iter_mut() {
            *o *= scale;
            scale *= duration;
        }
        scaled(blend_axis(&tau), 1.0 / cycles as f64)
    };
    let mut blend = Blend {
        horizontal: horizontal.map(|e| in_theta(&e)),
        hoist: in_theta(hoist),
        left: cycles,
        started: false,
        hoist_extent: [0.0; 2],
    };
    // About the first cycle's end.
    shift_each(&mut blend.horizontal, &mut blend.hoist);
    blend
}

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing, clippy::unwrap_used)]
    use super::*;

    fn derivative_at(p: &[f64; COEFFS], tau: f64, j: usize) -> f64 {
        (j..COEFFS).fold(0.0, |acc, k| {
            let falling = ((k - j + 1)..=k).fold(1.0, |a, i| a * i as f64);
            acc + p[k] * falling * tau.powi((k - j) as i32)
        })
    }

    /// A stop whose drive motion is not a number at a sample is refused, not let through:
    /// a comparison with NaN is false, so a limit check written `|v| > room` passed it.
    /// Reaches the check itself (`take_over` refuses a non-finite state before planning),
    /// with a NaN or infinite derivative of the state, distance, duration, pendulum or room.
    #[test]
    fn a_stop_that_is_not_a_number_is_refused() {
        let room = Room {
            speed: 1.0,
            acceleration: 1.0,
        };
        let moving = [0.0, 0.2, 0.0, 0.0, 0.0, 0.0];
        // The finite stop passes: the refusals below are the non-finite value's.
        assert!(axis_stop(&moving, 0.2, 2.0, 0.5, &room, 1.0).is_some());
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for j in 0..ORDERS {
                let mut d = moving;
                d[j] = bad;
                assert_eq!(
                    axis_stop(&d, 0.2, 2.0, 0.5, &room, 1.0),
                    None,
                    "d[{j}] = {bad}"
                );
            }
            assert_eq!(
                axis_stop(&moving, bad, 2.0, 0.5, &room, 1.0),
                None,
                "distance {bad}"
            );
            assert_eq!(
                axis_stop(&moving, 0.2, bad, 0.5, &room, 1.0),
                None,
                "duration {bad}"
            );
            assert_eq!(
                axis_stop(&moving, 0.2, 2.0, bad, &room, 1.0),
                None,
                "c {bad}"
            );
            assert_eq!(
                axis_stop(&moving, 0.2, 2.0, 0.5, &room, bad),
                None,
                "forward {bad}"
            );
        }
        for nan_room in [
            Room {
                speed: f64::NAN,
                ..room
            },
            Room {
                acceleration: f64::NAN,
                ..room
            },
        ] {
            assert_eq!(
                axis_stop(&moving, 0.2, 2.0, 0.5, &nan_room, 1.0),
                None,
                "{nan_room:?}"
            );
        }
        // A duration of zero divides by zero.
        assert_eq!(axis_stop(&moving, 0.2, 0.0, 0.5, &room, 1.0), None);
        // The way to the target that is not a number has no direction (0 would allow both).
        assert!(sign(f64::NAN).is_nan());
    }

    #[test]
    fn hermite_basis_has_its_end_conditions() {
        for (j, b) in HERMITE.iter().enumerate() {
            for i in 0..ORDERS {
                let at0 = derivative_at(b, 0.0, i);
                let at1 = derivative_at(b, 1.0, i);
                assert!(
                    (at0 - if i == j { 1.0 } else { 0.0 }).abs() < 1e-9,
                    "H_{j}^({i})(0) = {at0}"
                );
                assert!(at1.abs() < 1e-7, "H_{j}^({i})(1) = {at1}");
            }
        }
    }

    /// A blend moved on cycle by cycle is the polynomial at the later argument: its
    /// derivatives 0..=5 within 1e-9 of the largest each reaches over the blend (measured:
    /// 1.6e-12 for the value, at most 1.4e-10 for the fourth derivative — the rounding of
    /// the monomial form, whose coefficients reach ~10⁴ for values ≤ 1, in the reference
    /// as in the blend, and of 400 cycles of additions).
    #[test]
    fn taylor_shift_is_the_polynomial_at_the_shifted_argument() {
        let p = blend_axis(&[0.1, -0.3, 0.5, 0.2, -1.0, 0.7]);
        let cycles = 400.0;
        let s = 1.0 / cycles;
        let mut largest = [0.0_f64; ORDERS];
        let mut error = [0.0_f64; ORDERS];
        let mut q = scaled(p, s);
        for n in 0..=400 {
            let tau0 = n as f64 * s;
            for theta in [0.0, 0.3, 1.0] {
                for j in 0..ORDERS {
                    let a = derivative_at(&p, tau0 + theta * s, j);
                    let b = derivative_at(&q, theta, j) / s.powi(j as i32);
                    largest[j] = largest[j].max(a.abs());
                    error[j] = error[j].max((a - b).abs());
                }
            }
            shift_by_one(&mut q);
        }
        for j in 0..ORDERS {
            assert!(
                error[j] <= 1e-9 * largest[j],
                "order {j}: {} of {}",
                error[j],
                largest[j]
            );
        }
    }
}
