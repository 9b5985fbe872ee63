//! Checks a requested move (or a stop) along its whole path before it is accepted
//! (docs/COMMANDS.md): the crane's workspace, the rope's tension, and the drives'
//! velocity and acceleration limits, evaluated with the exact flat inverse at
//! [`SAMPLES`] + 1 points of the path.
//!
//! The planner is generic over the crane ([`Crane`]) and its number of driven axes `A`:
//! the planar crane of the paper (`A = 2`: trolley, winch) and the 3D crane (`A = 3`:
//! bridge, trolley, winch) differ only in their flat inverse, their workspace and which
//! reason names each axis's violation.
//!
//! A move's search for its duration costs up to a dozen such checks; the controller
//! runs it as a [`MoveSearch`], at most [`SAMPLES_PER_CYCLE`] samples per cycle, so that
//! planning never takes a cycle past its deadline.

use nalgebra::SVector;
use solver_core::plan::{Plan, Stop, StopStart};
use solver_core::trajectory::{PointToPoint, Trajectory};

use crate::commands::{Reject, DURATION_TICKS_PER_S};
use crate::setpoint::AxisLimits;

pub use crate::crane::{AxisReasons, Crane, Flat};

/// Points per checked path segment (plus its end).
pub const SAMPLES: usize = 100;
/// Share of each drive limit a planned move may use (the computed inputs differ from
/// the flat inverse by the scheme's error).
pub const MARGIN: f64 = 0.95;
/// Largest downward acceleration of the load, as a share of g ("well below g").
pub const MAX_DOWN_ACCELERATION: f64 = 0.5;
/// Shortest and longest move, s.
pub const DURATION_RANGE: (f64, f64) = (0.5, 600.0);
/// The checks, in the order of precedence of their reasons (a planar crane never
/// meets the bridge's).
pub const ORDER: [Reject; 11] = [
    Reject::BridgeWorkspace,
    Reject::TrolleyWorkspace,
    Reject::HookAtRail,
    Reject::RopeWorkspace,
    Reject::SlackRope,
    Reject::BridgeVelocity,
    Reject::TrolleyVelocity,
    Reject::WinchVelocity,
    Reject::BridgeAcceleration,
    Reject::TrolleyAcceleration,
    Reject::WinchAcceleration,
];

/// Plans and checks moves for one crane `K` and its `A` drives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Planner<K, const A: usize> {
    crane: K,
    limits: [AxisLimits; A],
}

impl<K: Crane<A>, const A: usize> Planner<K, A> {
    /// A planner for `crane` whose drives have `limits`, in the model's input order.
    #[must_use]
    pub const fn with_axes(crane: K, limits: [AxisLimits; A]) -> Self {
        Self { crane, limits }
    }

    /// Each drive position's range `(min, max)`, m, in the model's input order.
    #[must_use]
    pub fn ranges(&self) -> [(f64, f64); A] {
        self.crane.ranges()
    }

    /// Each drive's lag τ, s, in the model's input order ([`Crane::lags`]).
    #[must_use]
    pub fn lags(&self) -> [f64; A] {
        self.crane.lags()
    }

    /// Each drive's limits, in the model's input order: the ones the set-point gate
    /// enforces too.
    #[must_use]
    pub fn limits(&self) -> [AxisLimits; A] {
        self.limits
    }

    /// The rules the desired output breaks at `t`: bit `i` set for `ORDER[i]`.
    fn violations_at<Z: Trajectory<f64, A>>(&self, z: &Z, t: f64) -> u16 {
        let bit = |reason: Reject| {
            ORDER
                .iter()
                .position(|r| *r == reason)
                .map_or(0, |i| 1u16 << i)
        };
        let [zd, _, zdd] = z.derivatives::<3>(t);
        let (zc, zcdd) = match (zd.as_slice().last(), zdd.as_slice().last()) {
            (Some(zc), Some(zcdd)) => (*zc, *zcdd),
            // No output at all: no load to hang.
            _ => return bit(Reject::RopeWorkspace),
        };
        if zc.is_nan() || zc <= 0.0 {
            return bit(Reject::RopeWorkspace);
        }
        let max_down_acceleration = MAX_DOWN_ACCELERATION * self.crane.g();
        if zcdd.is_nan() || zcdd > max_down_acceleration {
            return bit(Reject::SlackRope);
        }
        let f = match self.crane.taut_flat(z, t, zcdd, max_down_acceleration) {
            Ok(f) => f,
            Err(reason) => return bit(reason),
        };
        let mut found = 0;
        let axes = K::REASONS
            .iter()
            .zip(self.crane.ranges())
            .zip(f.position)
            .map(|((reasons, range), at)| (reasons, range, at));
        for (reasons, (lo, hi), at) in axes {
            if !(lo..=hi).contains(&at) {
                found |= bit(reasons.workspace);
            }
        }
        let rates = K::REASONS
            .iter()
            .zip(self.limits)
            .zip(f.u.iter().zip(f.u_dot));
        for ((reasons, limit), (u, u_dot)) in rates {
            if u.is_nan() || u.abs() > MARGIN * limit.max_velocity {
                found |= bit(reasons.velocity);
            }
            if u_dot.is_nan() || u_dot.abs() > MARGIN * limit.max_acceleration {
                found |= bit(reasons.acceleration);
            }
        }
        found
    }

    /// What the checks bound at `t` of the path `z` ([`Quantities`]).
    fn quantities<Z: Trajectory<f64, A>>(&self, z: &Z, t: f64) -> Quantities<A> {
        let [zd, _, zdd] = z.derivatives::<3>(t);
        let last = |v: &SVector<f64, A>| v.as_slice().last().copied().unwrap_or(f64::NAN);
        Quantities {
            depth: last(&zd),
            depth_acceleration: last(&zdd),
            flat: self.crane.flat(z, t),
        }
    }

    /// Checks the desired output at [`SAMPLES`] + 1 points of `[t0, t1]`; the
    /// highest-precedence violation, if any.
    pub fn check<Z: Trajectory<f64, A>>(&self, z: &Z, t0: f64, t1: f64) -> Result<(), Reject> {
        let found = (0..=SAMPLES).fold(0, |acc, i| {
            acc | self.violations_at(z, sample_time(t0, t1, i))
        });
        first_reason(found)
    }

    /// Whether the desired output passes every check at the same points as
    /// [`Planner::check`], visited in a spread order and left at the first violation.
    pub fn passes<Z: Trajectory<f64, A>>(&self, z: &Z, t0: f64, t1: f64) -> bool {
        (0..=SAMPLES).all(|k| self.violations_at(z, sample_time(t0, t1, spread(k))) == 0)
    }

    /// A checked move from where `plan` ends to `target` (m), starting no earlier than
    /// `earliest`, taking `duration` seconds or, for `None`, the shortest duration that
    /// passes every check — planned at once (the controller spreads the same search over
    /// cycles with [`MoveSearch`]).
    pub fn plan_move(
        &self,
        plan: &Plan<f64, A>,
        target: [f64; A],
        duration: Option<f64>,
        earliest: f64,
    ) -> Result<PointToPoint<f64, A>, Reject> {
        let mut search = MoveSearch::new(plan, target, duration)?;
        let mut budget = u32::MAX;
        loop {
            if let Some(result) = search.advance(self, &mut budget) {
                let d = result?;
                return plan
                    .candidate(SVector::from(target), earliest, d)
                    .map_err(|_| Reject::Invalid);
            }
        }
    }

    /// Where the drives stand while the load rests at `load` ([`Crane::drives_at_rest`]).
    #[must_use]
    pub fn drives_at_rest(&self, load: [f64; A]) -> [f64; A] {
        self.crane.drives_at_rest(load)
    }

    /// Where the load rests while the drives stand at `drives` ([`Crane::load_at_rest`]).
    #[must_use]
    pub fn load_at_rest(&self, drives: [f64; A]) -> [f64; A] {
        self.crane.load_at_rest(drives)
    }

    /// Each drive's position (planar: trolley x and rope length l) where `plan` stands
    /// at `t` (the flat inverse: exact for the plan, which the model follows to the
    /// scheme's error).
    #[must_use]
    pub fn drive_positions(&self, plan: &Plan<f64, A>, t: f64) -> [f64; A] {
        self.crane.flat(plan, t).position
    }

    /// The shortest smooth stop taking over at `t` on the running segment's path
    /// ([`Stop`]) that the limits allow, its rest chosen on the path continuously — `None`
    /// when no stop beats the running segment itself (checked when it was accepted: it
    /// then goes on to its end, at the target) or when the search would take more than
    /// [`STOP_SAMPLES`] samples.
    ///
    /// A stop of duration `d` continues the segment's timing σ with all its derivatives
    /// up to order n and rests at σ_end; it provably stays on the path at or before the
    /// target when its Bernstein coefficients rise ([`Stop::stays_on_path`]), i.e. when
    /// `σ_rise(d) ≤ σ_end ≤ 1`, `σ_rise(d)` the *nearest end* its start allows
    /// ([`StopStart::nearest_end`]), which grows with `d` (more time at the start's
    /// speed). A stop passes when it passes every check of a move — workspace, rope
    /// tension, the drives' velocity and acceleration (the limits, not the move's own
    /// speeds: a slow move may stop with its drives briefly faster than it ran, which is
    /// what makes its stop short) — and ends no later than the running segment,
    /// `d ≤ end − t`.
    ///
    /// Where the stops of the shortest durations pass, the nearest rest is near the
    /// shortest of them (a longer one may rest nearer only within its narrow first
    /// ends; a still longer one cannot rest nearer than its `σ_rise`). So the search
    /// scans the durations up from [`STOP_SHORTEST`] in steps of 25 % for the first whose
    /// stops pass a coarse check (which ends pass, estimated at `COARSE_POINTS`
    /// instants), bisects below it to 5 %, and gives the nearest end found the full check
    /// at every one of [`Planner::check`]'s points — else the middle of the ends, else a
    /// little longer. On the cases it rests within a few per cent of the nearest
    /// rest a fine search of durations and ends finds (the study
    /// `stop_search_against_a_fine_search`).
    ///
    /// Never inlined (nor [`MoveSearch::advance`]): the flat inverse's jets at each
    /// sample stay in a frame of their own instead of the cycle's. Inlined into the tick
    /// they took the control task's stack from 2.7 to 3.7 KiB (`cargo xtask qemu-bench`).
    #[must_use]
    #[inline(never)]
    pub fn plan_stop(&self, plan: &Plan<f64, A>, t: f64) -> Option<Stop<f64, A>> {
        let (_, running_until) = plan.segment_at(t)?.span();
        self.stop_ending_by(plan, t, running_until)
    }

    /// Where a stop taking over at `t` on `plan` starts, as smooth as this crane's stops
    /// are ([`Crane::STOP_SMOOTHNESS_ABOVE_MOVES`] orders above its moves): the start of
    /// every stop [`Planner::plan_stop`] tries.
    #[must_use]
    pub fn stop_start(&self, plan: &Plan<f64, A>, t: f64) -> Option<StopStart<f64, A>> {
        plan.stop_start(t, K::STOP_SMOOTHNESS_ABOVE_MOVES)
    }

    /// Whether `stop`, taking over at `t` on `plan`'s running segment, keeps every rule
    /// [`Planner::plan_stop`] keeps: on the path at or before the target, at rest no later
    /// than the segment, every check of a move at [`Planner::check`]'s points. What the
    /// search finds passes; a test uses it to ask whether a nearer stop would have
    /// (`tests/stop_property.rs`).
    #[must_use]
    pub fn stop_passes(&self, plan: &Plan<f64, A>, t: f64, stop: &Stop<f64, A>) -> bool {
        let (Some(segment), Some(start)) = (plan.segment_at(t), self.stop_start(plan, t)) else {
            return false;
        };
        let span = segment.span();
        if stop.path() != start.path() || stop.t_end() > span.1 || !stop.stays_on_path() {
            return false;
        }
        (0..=SAMPLES).all(|i| self.violations_at(stop, sample_time(t, stop.t_end(), i)) == 0)
    }

    /// [`Planner::plan_stop`] with the stop's end allowed up to `latest` instead of the
    /// running segment's end (the rule's cost is a study: `stop_rule_distance_against_time`).
    fn stop_ending_by(&self, plan: &Plan<f64, A>, t: f64, latest: f64) -> Option<Stop<f64, A>> {
        self.stop_within(plan, t, latest, STOP_SAMPLES)
    }

    /// The shortest stop at `t` on the path, at or before the target, ending by `latest`,
    /// found within `budget` path samples: the search [`Planner::plan_stop`] runs with
    /// [`STOP_SAMPLES`] and the running segment's end, public so that a test can show
    /// that budget suffices on each crane (`controller/tests/planner_stops.rs`).
    pub fn stop_within(
        &self,
        plan: &Plan<f64, A>,
        t: f64,
        latest: f64,
        budget: u32,
    ) -> Option<Stop<f64, A>> {
        let start = self.stop_start(plan, t)?;
        let longest = longest_stop(&start, latest - t)?;
        // No stop shorter than the shortest move: its set points would leave the checks'
        // margin. Where none that long fits, the running segment is the quickest rest.
        if longest < STOP_SHORTEST {
            return None;
        }
        let mut search = StopCheck {
            planner: self,
            start,
            budget,
        };
        // The shortest duration whose stops pass the coarse check: up from the shortest
        // in steps of STOP_SCAN until one passes, then a geometric bisection below it.
        let mut d = STOP_SHORTEST;
        let mut below = None;
        loop {
            let (mut hi, mut ends) = loop {
                if let Some(found) = search.ends(d)? {
                    break (d, found);
                }
                if d >= longest {
                    return None;
                }
                below = Some(d);
                d = (d * STOP_SCAN).min(longest);
            };
            if let Some(mut lo) = below {
                while hi / lo > STOP_RESOLUTION {
                    let mid = libm::sqrt(lo * hi);
                    match search.ends(mid)? {
                        Some(found) => (hi, ends) = (mid, found),
                        None => lo = mid,
                    }
                }
            }
            // The full check of the nearest end, else of the middle of the ends (the
            // coarse estimate is linear in the end, and sees only its points); else a
            // little longer.
            for longer in STOP_LONGER {
                d = (hi * longer).min(longest);
                if longer > 1.0 {
                    match search.ends(d)? {
                        Some(found) => ends = found,
                        None => continue,
                    }
                }
                let (near, far) = ends;
                for end in [near, near + 0.5 * (far - near)] {
                    if let Some(stop) = search.clears(d, end)? {
                        return Some(search.nearer(stop, d, longest));
                    }
                }
            }
            // The coarse check was too kind here: on up from the last duration tried.
            if d >= longest {
                return None;
            }
            below = None;
            d = (d * STOP_SCAN).min(longest);
        }
    }
}

/// Time of sample `i` of `[t0, t1]`.
fn sample_time(t0: f64, t1: f64, i: usize) -> f64 {
    t0 + (t1 - t0) * i as f64 / SAMPLES as f64
}

/// The `k`-th sample of a spread visiting order: 37 and 101 are coprime, so this is a
/// permutation of `0..=100` whose consecutive samples lie far apart (a violation
/// anywhere on the path is met early).
fn spread(k: usize) -> usize {
    (k * 37) % (SAMPLES + 1)
}

/// The highest-precedence reason among the violated rules.
fn first_reason(found: u16) -> Result<(), Reject> {
    match ORDER
        .iter()
        .enumerate()
        .find(|(i, _)| found & (1 << i) != 0)
    {
        Some((_, reason)) => Err(*reason),
        None => Ok(()),
    }
}

/// Path samples a stop's search may take (a stop is planned in the cycle it arrives):
/// two per instant of each coarse check (`COARSE_POINTS` instants; one that fails is
/// left at its first failing instant) and 101 per full check. A search that would take
/// more ends with the running segment as the stop (it was checked when it was accepted). Its cost: docs/RESULTS.md.
pub const STOP_SAMPLES: u32 = 6 * SAMPLES_PER_CYCLE;

/// Instants of a stop at which its coarse check evaluates the path, each at two ends
/// ([`StopCheck::ends`]).
const COARSE_POINTS: usize = 20;

/// The share of each bound the coarse check allows, so that what it finds passes the
/// full check, which it does not see between its points.
const COARSE_SHARE: f64 = 0.98;

/// The durations tried for a nearer stop once one passed, as shares of its duration
/// ([`StopCheck::nearer`]).
const STOP_NEARER: [f64; 7] = [0.94, 0.97, 1.0, 1.03, 1.06, 1.1, 1.15];

/// The durations whose ends get the full check, as shares of the one the bisection
/// found: the next if neither end of the last passed it.
const STOP_LONGER: [f64; 5] = [1.0, 1.03, 1.07, 1.15, 1.3];

/// The shortest stop tried, s: the shortest move ([`DURATION_RANGE`]). A stop of a few
/// cycles would leave the scheme's error in the computed set points beyond the checks'
/// margin (a 0.1 s stop's accelerations came out 6 % above the flat inverse's).
pub const STOP_SHORTEST: f64 = DURATION_RANGE.0;

/// The step of the stop's scan of durations, as a ratio…
const STOP_SCAN: f64 = 1.25;

/// …and the resolution of the bisection that follows it (three halvings).
const STOP_RESOLUTION: f64 = 1.05;

/// A stop's checks from one start, within a budget of samples.
struct StopCheck<'a, K, const A: usize> {
    planner: &'a Planner<K, A>,
    start: StopStart<f64, A>,
    budget: u32,
}

impl<K: Crane<A>, const A: usize> StopCheck<'_, K, A> {
    /// The ends `[near, far]` (fractions of the path) at which a stop of duration `d`
    /// passes every check, as the coarse check estimates them: `None` if there are none
    /// (`None` outer: the budget ran out).
    ///
    /// For a given duration the stop's timing is affine in its end (`σ = H₀ + σ_end·S`,
    /// the Hermite polynomial that rests at 0 plus the smooth step), so each quantity the
    /// checks bound is nearly affine in it too (exactly so for the planar crane's trolley
    /// at a constant rope length): evaluated at two ends, the nearest end the start allows
    /// (`σ_rise`) and halfway from it to the target, at `COARSE_POINTS` instants, each
    /// bound gives an interval of ends, and the ends that pass are their intersection
    /// with `[σ_rise, 1]`. The bounds are [`COARSE_SHARE`] of the checks' own, so that
    /// the full check ([`StopCheck::clears`]) of what this finds passes.
    fn ends(&mut self, d: f64) -> Option<Option<(f64, f64)>> {
        let Some(near) = self.start.nearest_end(d).filter(|e| *e <= 1.0) else {
            return Some(None);
        };
        let other = near + 0.5 * (1.0 - near);
        let (a, b) = match (self.start.stop(d, near), self.start.stop(d, other)) {
            (Ok(a), Ok(b)) if a.stays_on_path() => (a, b),
            _ => return Some(None),
        };
        let planner = self.planner;
        let limits = planner.limits.map(|l| {
            (
                COARSE_SHARE * MARGIN * l.max_velocity,
                COARSE_SHARE * MARGIN * l.max_acceleration,
            )
        });
        let mut ends = Ends {
            at: (near, other),
            range: (near, 1.0),
        };
        let t = self.start.t();
        for i in 0..COARSE_POINTS {
            self.budget = self.budget.checked_sub(2)?;
            let at = t + d * (2 * i + 1) as f64 / (2 * COARSE_POINTS) as f64;
            let (qa, qb) = (planner.quantities(&a, at), planner.quantities(&b, at));
            ends.bound((qa.depth, qb.depth), (0.0, f64::INFINITY));
            let slack = MAX_DOWN_ACCELERATION * planner.crane.g();
            ends.bound(
                (qa.depth_acceleration, qb.depth_acceleration),
                (f64::NEG_INFINITY, slack),
            );
            let axes = planner.crane.ranges().into_iter().zip(limits).enumerate();
            for (k, (range, (speed, acceleration))) in axes {
                let of = |q: &Quantities<A>| {
                    let f = &q.flat;
                    (
                        f.position.get(k).copied().unwrap_or(f64::NAN),
                        f.u.get(k).copied().unwrap_or(f64::NAN),
                        f.u_dot.get(k).copied().unwrap_or(f64::NAN),
                    )
                };
                let ((pa, ua, ra), (pb, ub, rb)) = (of(&qa), of(&qb));
                ends.bound((pa, pb), range);
                ends.bound((ua, ub), (-speed, speed));
                ends.bound((ra, rb), (-acceleration, acceleration));
            }
            if ends.range.0 > ends.range.1 {
                return Some(None);
            }
        }
        Some(Some(ends.range))
    }

    /// `stop` (of duration `d`), or a nearer one: the coarse check is stricter than the
    /// full one, and its estimate of the nearest end linear, so a stop a little shorter
    /// or longer resting at its own nearest end (`σ_rise`, the nearest any stop of that
    /// duration can rest) may pass the full check; the shortest of [`STOP_NEARER`] that
    /// does, within the budget.
    fn nearer(&mut self, stop: Stop<f64, A>, d: f64, longest: f64) -> Stop<f64, A> {
        for longer in STOP_NEARER {
            // max/min, not clamp: clamp panics on bounds it cannot order (a NaN).
            let d = (d * longer).max(STOP_SHORTEST).min(longest);
            let Some(end) = self.start.nearest_end(d) else {
                continue;
            };
            if end >= stop.fraction() {
                // σ_rise grows with the duration: no longer one rests nearer.
                break;
            }
            match self.clears(d, end) {
                Some(Some(nearer)) => return nearer,
                Some(None) => {}
                None => break,
            }
        }
        stop
    }

    /// The stop of duration `d` that rests at the fraction `end` of the path, if it stays
    /// on the path at or before the target and passes every check at every one of
    /// [`Planner::check`]'s points (visited in the spread order, left
    /// at the first violation); `None` (outer) when the budget runs out.
    fn clears(&mut self, d: f64, end: f64) -> Option<Option<Stop<f64, A>>> {
        let stop = match self.start.stop(d, end) {
            Ok(stop) if stop.stays_on_path() => stop,
            _ => return Some(None),
        };
        let t = self.start.t();
        for i in (0..=SAMPLES).map(spread) {
            self.budget = self.budget.checked_sub(1)?;
            if self.planner.violations_at(&stop, sample_time(t, t + d, i)) != 0 {
                return Some(None);
            }
        }
        Some(Some(stop))
    }
}

/// The ends of a stop of one duration that pass the bounds met so far, each bound taken
/// as affine in the end between the two ends it was evaluated at.
struct Ends {
    /// The two ends evaluated.
    at: (f64, f64),
    /// What passes so far: `near > far` when nothing does.
    range: (f64, f64),
}

impl Ends {
    /// Narrows the range to the ends whose value — `values` at the two ends evaluated,
    /// affine between and beyond them — lies within `bounds`. A value that is not a
    /// number passes no end.
    fn bound(&mut self, (va, vb): (f64, f64), (min, max): (f64, f64)) {
        let (ea, eb) = self.at;
        let slope = (vb - va) / (eb - ea);
        let (from, to) = if slope > 0.0 {
            (ea + (min - va) / slope, ea + (max - va) / slope)
        } else if slope < 0.0 {
            (ea + (max - va) / slope, ea + (min - va) / slope)
        } else if (min..=max).contains(&va) {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            // Flat outside the bounds, or not a number.
            (f64::INFINITY, f64::NEG_INFINITY)
        };
        let (near, far) = self.range;
        self.range = (near.max(from), far.min(to));
        if from.is_nan() || to.is_nan() {
            self.range = (f64::INFINITY, f64::NEG_INFINITY);
        }
    }
}

/// What the checks bound at one instant of a path: the load's depth and its downward
/// acceleration, and the flat inverse (the drives' positions, speeds and accelerations).
struct Quantities<const A: usize> {
    depth: f64,
    depth_acceleration: f64,
    flat: Flat<A>,
}

/// The longest stop duration, at most `window` (when the running segment would come to
/// rest), whose nearest end lies on the path at or before the target (the start's
/// Bernstein coefficients rise and end at σ ≤ 1): `window` itself, or the edge found by
/// bisection (arithmetic only, no path sample). `None` if there is none.
fn longest_stop<const A: usize>(start: &StopStart<f64, A>, window: f64) -> Option<f64> {
    let fits = |d: f64| start.nearest_end(d).is_some_and(|e| e <= 1.0);
    // (A window that is not a positive number has no stop.)
    if window.is_nan() || window <= 0.0 {
        return None;
    }
    if fits(window) {
        return Some(window);
    }
    let (mut lo, mut hi) = (0.0, window);
    for _ in 0..48 {
        let mid = 0.5 * (lo + hi);
        if fits(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (lo > 0.0).then_some(lo)
}

/// Path samples the controller evaluates per cycle at most while it plans a move
/// (about 0.4 M instructions: a plan never costs a cycle its deadline).
pub const SAMPLES_PER_CYCLE: u32 = 128;

/// Where a move search stands.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// A given duration: every sample, every reason.
    Given(f64),
    /// As fast as possible: first the shortest duration.
    Shortest,
    /// Geometric bisection: `lo` fails, `hi` passes (or is the longest, untested).
    Bisect { lo: f64, hi: f64, tested: bool },
    /// `hi` rounded up to the command frame's duration unit (10 ms, whatever h), so the
    /// duration found is one a supervisor can ask for.
    Round { hi: f64 },
    /// Nothing passed: the reasons at the longest duration.
    Reason,
}

/// One candidate path under check, resumable between cycles.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Check {
    duration: f64,
    next: usize,
    found: u16,
    /// Every sample and every reason (for the answer), or pass/fail only.
    full: bool,
}

impl Check {
    fn new(duration: f64, full: bool) -> Self {
        Self {
            duration,
            next: 0,
            found: 0,
            full,
        }
    }
}

/// A move being planned: the search for its duration, spread over cycles.
///
/// The path is a rest-to-rest smooth step from where the plan ends, so its checks do
/// not depend on when it starts: the search runs on `[0, T]` and the move is placed
/// when the search is done.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveSearch<const A: usize = 2> {
    start: SVector<f64, A>,
    target: SVector<f64, A>,
    smoothness: usize,
    phase: Phase,
    check: Check,
}

impl<const A: usize> MoveSearch<A> {
    /// Starts planning a move from where `plan` ends to `target`; refuses an invalid
    /// request at once.
    pub fn new(
        plan: &Plan<f64, A>,
        target: [f64; A],
        duration: Option<f64>,
    ) -> Result<Self, Reject> {
        let (shortest, longest) = DURATION_RANGE;
        if target.iter().any(|v| !v.is_finite() || *v <= 0.0) {
            return Err(Reject::Invalid);
        }
        let phase = match duration {
            Some(d) if !(shortest..=longest).contains(&d) => return Err(Reject::Invalid),
            Some(d) => Phase::Given(d),
            None => Phase::Shortest,
        };
        let check = match phase {
            Phase::Given(d) => Check::new(d, true),
            _ => Check::new(shortest, false),
        };
        Ok(Self {
            start: plan.final_position(),
            target: SVector::from(target),
            smoothness: plan.planned_smoothness(),
            phase,
            check,
        })
    }

    /// Evaluates at most `budget` samples (and lowers it by as many); the chosen
    /// duration or the reason once the search is done.
    /// Never inlined, as [`Planner::plan_stop`] is not: the search's frames are not
    /// the cycle's.
    #[inline(never)]
    pub fn advance<K: Crane<A>>(
        &mut self,
        planner: &Planner<K, A>,
        budget: &mut u32,
    ) -> Option<Result<f64, Reject>> {
        loop {
            let passed = self.run_check(planner, budget)?;
            if let Some(done) = self.next_phase(passed) {
                return Some(done);
            }
        }
    }

    /// Runs the current check within the budget: `None` if it is unfinished.
    fn run_check<K: Crane<A>>(
        &mut self,
        planner: &Planner<K, A>,
        budget: &mut u32,
    ) -> Option<Result<(), Reject>> {
        let c = &mut self.check;
        let Ok(path) = PointToPoint::new(self.start, self.target, 0.0, c.duration, self.smoothness)
        else {
            return Some(Err(Reject::Invalid));
        };
        while c.next <= SAMPLES {
            if *budget == 0 {
                return None;
            }
            *budget -= 1;
            let i = if c.full { c.next } else { spread(c.next) };
            c.found |= planner.violations_at(&path, sample_time(0.0, c.duration, i));
            c.next += 1;
            if !c.full && c.found != 0 {
                break;
            }
        }
        Some(first_reason(c.found))
    }

    /// The search's next step after a finished check: `Some` when the search is done.
    fn next_phase(&mut self, passed: Result<(), Reject>) -> Option<Result<f64, Reject>> {
        let (shortest, longest) = DURATION_RANGE;
        let d = self.check.duration;
        let (phase, next) = match (self.phase, passed) {
            (Phase::Given(_), result) => return Some(result.map(|()| d)),
            (Phase::Reason, result) => return Some(result.map(|()| d)),
            (Phase::Shortest, Ok(())) => return Some(Ok(d)),
            (Phase::Round { .. }, Ok(())) => return Some(Ok(d)),
            (Phase::Round { hi }, Err(_)) => return Some(Ok(hi)),
            (Phase::Shortest, Err(_)) => (
                Phase::Bisect {
                    lo: shortest,
                    hi: longest,
                    tested: false,
                },
                None,
            ),
            (Phase::Bisect { lo, hi, tested }, result) => {
                let mid = d;
                match result {
                    Ok(()) => (
                        Phase::Bisect {
                            lo,
                            hi: mid,
                            tested: true,
                        },
                        None,
                    ),
                    Err(_) if mid >= longest => (Phase::Reason, Some(Check::new(longest, true))),
                    Err(_) => (
                        Phase::Bisect {
                            lo: mid,
                            hi,
                            tested,
                        },
                        None,
                    ),
                }
            }
        };
        self.phase = phase;
        if let Some(check) = next {
            self.check = check;
            return None;
        }
        self.check = match self.phase {
            Phase::Bisect { lo, hi, .. } if hi / lo > 1.02 => {
                Check::new(libm::sqrt(lo * hi), false)
            }
            // Not yet known to pass: the longest itself.
            Phase::Bisect {
                hi, tested: false, ..
            } => Check::new(hi, false),
            Phase::Bisect { hi, .. } => {
                self.phase = Phase::Round { hi };
                Check::new(
                    (libm::ceil(hi * DURATION_TICKS_PER_S) / DURATION_TICKS_PER_S).min(longest),
                    false,
                )
            }
            _ => return Some(Err(Reject::Invalid)),
        };
        None
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::crane::{AxisReasons, Flat};
    use crate::drive::{self, Drive};
    use crate::feedback::Reference;
    use crate::setpoint::DriveLimits;
    use solver_core::models::crane::CraneParams;
    use solver_core::models::crane3d::Crane3dParams;
    use solver_core::reference::{flat_crane, flat_crane3d};

    /// The planar and the 3D crane as far as the planner asks: their drives' limits,
    /// ranges and flat inverses, for the two studies below, which read the stop search's
    /// internals. The cranes themselves are the registry's (`scene::cranes`), whose
    /// `Crane` impls are of the library build of this crate, not of its unit-test build;
    /// the checks of the search run on them (`controller/tests/planner_stops.rs`).
    #[derive(Debug, Clone, Copy)]
    struct Lab<P>(P);

    impl Crane<2> for Lab<CraneParams> {
        const NAME: &'static str = "planar crane (test double)";
        const DRIVES: [Drive; 2] = drive::PLANAR;
        const REASONS: [AxisReasons; 2] = [AxisReasons::TROLLEY, AxisReasons::WINCH];
        const LAB_LIMITS: [AxisLimits; 2] = DriveLimits::LAB.axes();
        const SWING_AXES: u8 = 1;
        const HORIZONTAL_AXES: u8 = 1;
        const MIN_COMMAND_SMOOTHNESS: usize = 5;
        type Reference = Reference;
        fn drive_states(r: &Reference) -> [(f64, f64); 2] {
            [(r.x, r.vx), (r.l, r.vl)]
        }
        fn g(&self) -> f64 {
            self.0.g
        }
        fn ranges(&self) -> [(f64, f64); 2] {
            let w = &self.0.workspace;
            [(w.x_min, w.x_max), (w.l_min, w.l_max)]
        }
        fn target(x: f64, y: Option<f64>, z: f64, _end: [f64; 2]) -> Option<[f64; 2]> {
            y.is_none().then_some([x, z])
        }
        fn flat<Z: Trajectory<f64, 2>>(&self, z: &Z, t: f64) -> Flat<2> {
            let f = flat_crane::flat_inverse(&self.0, z, t);
            Flat {
                position: [f.x, f.l],
                u: f.u,
                u_dot: f.u_dot,
            }
        }
        fn drives_at_rest(&self, load: [f64; 2]) -> [f64; 2] {
            load
        }
        fn load_at_rest(&self, drives: [f64; 2]) -> [f64; 2] {
            drives
        }
        fn lags(&self) -> [f64; 2] {
            [self.0.tau1, self.0.tau2]
        }
    }

    impl Crane<3> for Lab<Crane3dParams> {
        const NAME: &'static str = "3D crane (test double)";
        const DRIVES: [Drive; 3] = drive::SPATIAL;
        const REASONS: [AxisReasons; 3] = [
            AxisReasons::BRIDGE,
            AxisReasons::TROLLEY,
            AxisReasons::WINCH,
        ];
        const LAB_LIMITS: [AxisLimits; 3] = DriveLimits::LAB_3D;
        const SWING_AXES: u8 = 2;
        const HORIZONTAL_AXES: u8 = 2;
        const MIN_COMMAND_SMOOTHNESS: usize = 5;
        type Reference = [Reference; 2];
        fn drive_states([xz, yz]: &[Reference; 2]) -> [(f64, f64); 3] {
            [(xz.x, xz.vx), (yz.x, yz.vx), (xz.l, xz.vl)]
        }
        fn g(&self) -> f64 {
            self.0.g
        }
        fn ranges(&self) -> [(f64, f64); 3] {
            let w = &self.0.workspace;
            [(w.x_min, w.x_max), (w.y_min, w.y_max), (w.l_min, w.l_max)]
        }
        fn target(x: f64, y: Option<f64>, z: f64, [_, y_end, _]: [f64; 3]) -> Option<[f64; 3]> {
            Some([x, y.unwrap_or(y_end), z])
        }
        fn flat<Z: Trajectory<f64, 3>>(&self, z: &Z, t: f64) -> Flat<3> {
            let f = flat_crane3d::flat_inverse(&self.0, z, t);
            Flat {
                position: [f.x, f.y, f.l],
                u: f.u,
                u_dot: f.u_dot,
            }
        }
        fn drives_at_rest(&self, load: [f64; 3]) -> [f64; 3] {
            load
        }
        fn load_at_rest(&self, drives: [f64; 3]) -> [f64; 3] {
            drives
        }
        fn lags(&self) -> [f64; 3] {
            [self.0.tau1, self.0.tau2, self.0.tau3]
        }
    }

    const PLANAR: Lab<CraneParams> = Lab(CraneParams::PAPER);
    const SPATIAL: Lab<Crane3dParams> = Lab(Crane3dParams::EXAMPLE);

    /// A plan at rest at `from` with the quickest move to `to` the planner allows, and
    /// the time that move ends.
    fn the_quickest_move<K: Crane<A>, const A: usize>(
        planner: &Planner<K, A>,
        from: [f64; A],
        to: [f64; A],
    ) -> (Plan<f64, A>, f64) {
        a_move(planner, from, to, None)
    }

    /// A plan at rest at `from` with a move to `to` in `duration` s (`None`: the
    /// quickest), and the time that move ends.
    fn a_move<K: Crane<A>, const A: usize>(
        planner: &Planner<K, A>,
        from: [f64; A],
        to: [f64; A],
        duration: Option<f64>,
    ) -> (Plan<f64, A>, f64) {
        let mut plan = Plan::at_rest(SVector::from(from), 5).unwrap();
        plan.push(planner.plan_move(&plan, to, duration, 0.0).unwrap())
            .unwrap();
        let end = plan.end_time().unwrap();
        (plan, end)
    }

    /// What the rule "never later than the move would have ended" (issue 17) costs in
    /// stopping distance: at instants 0.1 s apart on three moves as fast as the limits
    /// allow, the stop [`Planner::plan_stop`] finds beside the one it would find if it
    /// might end up to 10 s later. A study, not a check of the firmware (`cargo test -p
    /// controller --release --lib stop_rule -- --ignored --nocapture`).
    #[test]
    #[ignore = "a study: prints what the stop rule costs in distance"]
    fn stop_rule_distance_against_time() {
        fn study<K: Crane<A>, const A: usize>(
            planner: &Planner<K, A>,
            from: [f64; A],
            to: [f64; A],
        ) {
            let (plan, end) = the_quickest_move(planner, from, to);
            let length = (SVector::from(to) - SVector::from(from)).norm();
            let (mut runs_on, mut shorter_later, mut shorter, mut later) = (0, 0, 0.0_f64, 0.0_f64);
            for i in 1..(end * 10.0) as usize {
                let t = i as f64 * 0.1;
                let stop = planner.plan_stop(&plan, t);
                assert!(stop.is_none_or(|s| s.t_end() <= end && s.fraction() <= 1.0));
                runs_on += usize::from(stop.is_none());
                let rest = stop.map_or(1.0, |s| s.fraction());
                if let Some(alt) = planner.stop_ending_by(&plan, t, end + 10.0) {
                    if alt.fraction() < rest - 1e-9 {
                        shorter_later += 1;
                        shorter = shorter.max((rest - alt.fraction()) * length);
                        later = later.max(alt.t_end() - end);
                    }
                }
            }
            std::eprintln!(
                "{from:?} -> {to:?} in {end:.2} s: the move runs on to its target at {runs_on} of {} instants; a stop allowed to end later would rest shorter at {shorter_later}, up to {shorter:.2} m shorter, ending up to {later:.2} s after the move",
                (end * 10.0) as usize - 1
            );
        }
        let crane3d = Planner::with_axes(SPATIAL, DriveLimits::LAB_3D);
        study(&crane3d, [12.0, 3.0, 8.0], [16.0, 5.0, 6.0]);
        study(&crane3d, [12.0, 3.0, 8.0], [20.0, 3.0, 4.0]);
        study(
            &Planner::with_axes(PLANAR, DriveLimits::LAB.axes()),
            [12.0, 8.0],
            [20.0, 4.0],
        );
    }

    /// How near the stop [`Planner::plan_stop`] rests to the nearest rest of its family
    /// under the same rules (on the path at or before the target, every check, no later
    /// than the move): a fine search — durations 20 ms
    /// apart, for each the nearest end 0.001 of the path apart that passes the full check
    /// — at instants of the moves. A study, not a check of the firmware (`cargo
    /// test -p controller --release --lib stop_search -- --ignored --nocapture`, about a
    /// minute).
    #[test]
    #[ignore = "a study: prints the search's stops beside a fine search's"]
    fn stop_search_against_a_fine_search() {
        fn study<K: Crane<A>, const A: usize>(
            planner: &Planner<K, A>,
            from: [f64; A],
            to: [f64; A],
            duration: f64,
            instants: &[f64],
        ) {
            let mut plan = Plan::at_rest(SVector::from(from), 5).unwrap();
            plan.push(plan.candidate(SVector::from(to), 0.0, duration).unwrap())
                .unwrap();
            let length = (SVector::from(to) - SVector::from(from)).norm();
            for &t in instants {
                let span = plan.segment_at(t).unwrap().span();
                let start = planner.stop_start(&plan, t).unwrap();
                let mut fine = StopCheck {
                    planner,
                    start,
                    budget: u32::MAX,
                };
                let mut best: Option<(f64, f64)> = None;
                let mut d = STOP_SHORTEST;
                while t + d <= span.1 {
                    let mut end = start.nearest_end(d).unwrap_or(2.0);
                    while end <= 1.0 && best.is_none_or(|(e, _)| end < e) {
                        if fine.clears(d, end).flatten().is_some() {
                            best = Some((end, d));
                            break;
                        }
                        end += 0.001;
                    }
                    d += 0.02;
                }
                let s0 = start.fraction();
                let metres = |end: f64| (end - s0) * length;
                let found = planner.plan_stop(&plan, t);
                std::eprintln!(
                    "{from:?} -> {to:?} in {duration} s, stopped at {t} s (σ = {s0:.3}): search {}, fine search {}",
                    found.map_or("none: the move runs on".into(), |s| format!(
                        "{:.3} m in {:.2} s",
                        metres(s.fraction()),
                        s.t_end() - t
                    )),
                    best.map_or("none".into(), |(e, d)| format!("{:.3} m in {d:.2} s", metres(e))),
                );
            }
        }
        let planar = Planner::with_axes(PLANAR, DriveLimits::LAB.axes());
        let instants = [1.0, 2.0, 3.0, 3.9, 4.0, 4.05, 5.0, 6.0, 7.0];
        study(&planar, [12.0, 8.0], [20.0, 5.0], 8.0, &instants);
        let crane3d = Planner::with_axes(SPATIAL, DriveLimits::LAB_3D);
        let instants = [1.0, 2.5, 3.9, 5.0, 6.5];
        study(&crane3d, [12.0, 3.0, 8.0], [14.0, 4.5, 6.5], 8.0, &instants);
    }
}
