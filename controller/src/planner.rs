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
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::Crane3dParams;
use solver_core::plan::{Plan, Stop};
use solver_core::reference::{flat_crane, flat_crane3d};
use solver_core::trajectory::{PointToPoint, Trajectory};

use crate::commands::{Reject, DURATION_TICKS_PER_S};
use crate::drive::{self, Drive};
use crate::setpoint::{AxisLimits, DriveLimits};

/// Points per checked path segment (plus its end).
pub const SAMPLES: usize = 100;
/// Share of each drive limit a planned move may use (the computed inputs differ from
/// the flat inverse by the scheme's error).
pub const MARGIN: f64 = 0.95;
/// Largest downward acceleration of the load, as a share of g ("well below g").
pub const MAX_DOWN_ACCELERATION: f64 = 0.5;
/// Shortest and longest move, s.
pub const DURATION_RANGE: (f64, f64) = (0.5, 600.0);
/// Durations tried for a stop, s: 0.5 s to 8 s in steps of 2^(1/4) (19 % longer each),
/// shortest first.
pub const STOP_DURATIONS: [f64; 17] = [
    0.5, 0.59, 0.71, 0.84, 1.0, 1.19, 1.41, 1.68, 2.0, 2.38, 2.83, 3.36, 4.0, 4.76, 5.66, 6.73, 8.0,
];

/// Where a stop of a given duration may come to rest, tried in order: as near as its
/// motion allows (0), halfway from there to the target, at the target (1) — a farther
/// end decelerates more gently in the same time (`Plan::stop_candidate`).
pub const STOP_STRETCH: [f64; 3] = [0.0, 0.5, 1.0];

/// The checks, in the order of precedence of their reasons (a planar crane never
/// meets the bridge's).
const ORDER: [Reject; 10] = [
    Reject::BridgeWorkspace,
    Reject::TrolleyWorkspace,
    Reject::RopeWorkspace,
    Reject::SlackRope,
    Reject::BridgeVelocity,
    Reject::TrolleyVelocity,
    Reject::WinchVelocity,
    Reject::BridgeAcceleration,
    Reject::TrolleyAcceleration,
    Reject::WinchAcceleration,
];

/// The reasons naming one axis's violations.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisReasons {
    /// Its drive would leave its travel (the winch: the rope its length range).
    pub workspace: Reject,
    /// Its velocity above the limit.
    pub velocity: Reject,
    /// Its acceleration above the limit.
    pub acceleration: Reject,
}

const BRIDGE: AxisReasons = AxisReasons {
    workspace: Reject::BridgeWorkspace,
    velocity: Reject::BridgeVelocity,
    acceleration: Reject::BridgeAcceleration,
};
const TROLLEY: AxisReasons = AxisReasons {
    workspace: Reject::TrolleyWorkspace,
    velocity: Reject::TrolleyVelocity,
    acceleration: Reject::TrolleyAcceleration,
};
const WINCH: AxisReasons = AxisReasons {
    workspace: Reject::RopeWorkspace,
    velocity: Reject::WinchVelocity,
    acceleration: Reject::WinchAcceleration,
};

/// Where the drives stand and how they move when the load follows a path exactly (the
/// flat inverse), `A` driven axes in the model's input order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Flat<const A: usize> {
    /// Each drive's position, m (trolley or bridge position, rope length).
    pub position: [f64; A],
    /// Each input u, m/s.
    pub u: [f64; A],
    /// Each input's rate u̇, m/s².
    pub u_dot: [f64; A],
}

/// A crane the planner checks paths for: its flat inverse, the range of each drive's
/// position, and the reasons naming each axis. The last output is the load's depth
/// z_C below the rail (Eq. 24's convention, in 3D too).
pub trait Crane<const A: usize> {
    /// Its drives, in the model's input order: the order of every per-drive array.
    const DRIVES: [Drive; A];
    /// The reasons of each axis, in the model's input order.
    const REASONS: [AxisReasons; A];
    /// Gravity, m/s².
    fn g(&self) -> f64;
    /// Each drive position's range `(min, max)`, m.
    fn ranges(&self) -> [(f64, f64); A];
    /// The load's target for a move command to `x_C`, `z_C` and, from the 3D move
    /// frame, `y_C` (docs/COMMANDS.md), the plan ending with the load at `end`: what the
    /// command does not name stays. `None`: the crane has no such target (a y for the
    /// planar crane).
    fn target(x: f64, y: Option<f64>, z: f64, end: [f64; A]) -> Option<[f64; A]>;
    /// The flat inverse at `t` of the load's path `z`.
    fn flat<Z: Trajectory<f64, A>>(&self, z: &Z, t: f64) -> Flat<A>;
    /// Each drive's lag τ, s (Eq. 24's `τ v̇ + v = u`): what the controller expects of
    /// the set points it sends ([`crate::motion`]).
    fn lags(&self) -> [f64; A];
}

/// The paper's planar crane: trolley x and rope length l (Eq. 24).
impl Crane<2> for CraneParams {
    const DRIVES: [Drive; 2] = drive::PLANAR;
    const REASONS: [AxisReasons; 2] = [TROLLEY, WINCH];
    fn g(&self) -> f64 {
        self.g
    }
    fn ranges(&self) -> [(f64, f64); 2] {
        let w = &self.workspace;
        [(w.x_min, w.x_max), (w.l_min, w.l_max)]
    }
    fn target(x: f64, y: Option<f64>, z: f64, _end: [f64; 2]) -> Option<[f64; 2]> {
        y.is_none().then_some([x, z])
    }
    fn flat<Z: Trajectory<f64, 2>>(&self, z: &Z, t: f64) -> Flat<2> {
        let f = flat_crane::flat_inverse(self, z, t);
        Flat {
            position: [f.x, f.l],
            u: f.u,
            u_dot: f.u_dot,
        }
    }
    fn lags(&self) -> [f64; 2] {
        [self.tau1, self.tau2]
    }
}

/// The 3D crane: bridge x, trolley y and rope length l.
impl Crane<3> for Crane3dParams {
    const DRIVES: [Drive; 3] = drive::SPATIAL;
    const REASONS: [AxisReasons; 3] = [BRIDGE, TROLLEY, WINCH];
    fn g(&self) -> f64 {
        self.g
    }
    fn ranges(&self) -> [(f64, f64); 3] {
        let w = &self.workspace;
        [(w.x_min, w.x_max), (w.y_min, w.y_max), (w.l_min, w.l_max)]
    }
    /// A planar command moves the load in the x–z plane it hangs in: y stays.
    fn target(x: f64, y: Option<f64>, z: f64, [_, y_end, _]: [f64; 3]) -> Option<[f64; 3]> {
        Some([x, y.unwrap_or(y_end), z])
    }
    fn flat<Z: Trajectory<f64, 3>>(&self, z: &Z, t: f64) -> Flat<3> {
        let f = flat_crane3d::flat_inverse(self, z, t);
        Flat {
            position: [f.x, f.y, f.l],
            u: f.u,
            u_dot: f.u_dot,
        }
    }
    fn lags(&self) -> [f64; 3] {
        [self.tau1, self.tau2, self.tau3]
    }
}

/// Plans and checks moves for one crane `K` and its `A` drives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Planner<K = CraneParams, const A: usize = 2> {
    crane: K,
    limits: [AxisLimits; A],
}

impl Planner {
    /// A planner for the planar crane with these parameters and drive limits.
    #[must_use]
    pub const fn new(params: CraneParams, limits: DriveLimits) -> Self {
        Self::with_axes(params, [limits.trolley, limits.winch])
    }
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
        if zcdd.is_nan() || zcdd > MAX_DOWN_ACCELERATION * self.crane.g() {
            return bit(Reject::SlackRope);
        }
        let f = self.crane.flat(z, t);
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

    /// Each drive's position (planar: trolley x and rope length l) where `plan` stands
    /// at `t` (the flat inverse: exact for the plan, which the model follows to the
    /// scheme's error).
    #[must_use]
    pub fn drive_positions(&self, plan: &Plan<f64, A>, t: f64) -> [f64; A] {
        self.crane.flat(plan, t).position
    }

    /// A checked smooth stop taking over at `t`, on the running move's path
    /// ([`Stop`]): the shortest of [`STOP_DURATIONS`] whose re-timing provably stays on
    /// the path at or before the target ([`Stop::stays_on_path`]), passes every check and
    /// comes to rest before the running segment would. `None` when no stop beats the
    /// plan itself — the running segment, checked when it was accepted, is then the
    /// quickest smooth way to rest, and it ends at the target — or when the search would
    /// take more than [`STOP_SAMPLES`] samples (the running segment again: a stop is
    /// answered in the cycle it arrives, within the cycle's budget).
    ///
    /// Never inlined (nor [`MoveSearch::advance`]): the flat inverse's jets at each
    /// sample stay in a frame of their own instead of the cycle's. Inlined into the tick
    /// they took the control task's stack from 2.7 to 3.7 KiB (`cargo xtask qemu-bench`).
    #[must_use]
    #[inline(never)]
    pub fn plan_stop(&self, plan: &Plan<f64, A>, t: f64) -> Option<Stop<f64, A>> {
        let (_, running_until) = plan.segment_at(t)?.span();
        let mut budget = STOP_SAMPLES;
        for d in STOP_DURATIONS
            .iter()
            .copied()
            .take_while(|&d| t + d < running_until)
        {
            for stretch in STOP_STRETCH {
                let Ok(stop) = plan.stop_candidate(t, d, stretch)? else {
                    continue;
                };
                if !stop.stays_on_path() {
                    continue;
                }
                let mut found = 0;
                for k in 0..=SAMPLES {
                    budget = budget.checked_sub(1)?;
                    found |= self.violations_at(&stop, sample_time(t, t + d, spread(k)));
                    if found != 0 {
                        break;
                    }
                }
                if found == 0 {
                    return Some(stop);
                }
            }
        }
        None
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

/// Path samples a stop's search may take (a stop is planned in the cycle it arrives).
pub const STOP_SAMPLES: u32 = 2 * SAMPLES_PER_CYCLE;

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

    /// Every reason a crane names is one the planner ranks: a reason outside [`ORDER`]
    /// would have no bit, and its violation would pass unseen.
    fn ranked<const A: usize, K: Crane<A>>() -> bool {
        K::REASONS.iter().all(|r| {
            [r.workspace, r.velocity, r.acceleration]
                .iter()
                .all(|reason| ORDER.contains(reason))
        })
    }

    #[test]
    fn every_crane_reason_is_ranked() {
        assert!(ranked::<2, CraneParams>());
        assert!(ranked::<3, Crane3dParams>());
    }

    /// What the rule "never later than the move would have ended" (issue 17) costs in
    /// stopping distance: at instants 0.1 s apart on three moves as fast as the limits
    /// allow, the stop [`Planner::plan_stop`] finds beside the first candidate that rests
    /// short of the target if it may end later. A study, not a check of the firmware
    /// (`cargo test -p controller --release --lib stop_rule -- --ignored --nocapture`).
    #[test]
    #[ignore = "a study: prints what the stop rule costs in distance"]
    fn stop_rule_distance_against_time() {
        fn first_short_of_target<K: Crane<A>, const A: usize>(
            planner: &Planner<K, A>,
            plan: &Plan<f64, A>,
            t: f64,
        ) -> Option<Stop<f64, A>> {
            STOP_DURATIONS.iter().find_map(|&d| {
                STOP_STRETCH.iter().find_map(|&stretch| {
                    let stop = plan.stop_candidate(t, d, stretch)?.ok()?;
                    let clear = stop.stays_on_path()
                        && stop.fraction() < 1.0
                        && (0..=SAMPLES)
                            .all(|k| planner.violations_at(&stop, sample_time(t, t + d, k)) == 0);
                    clear.then_some(stop)
                })
            })
        }
        fn study<K: Crane<A>, const A: usize>(
            planner: &Planner<K, A>,
            from: [f64; A],
            to: [f64; A],
        ) {
            let mut plan = Plan::at_rest(SVector::from(from), 5).unwrap();
            plan.push(planner.plan_move(&plan, to, None, 0.0).unwrap())
                .unwrap();
            let end = plan.end_time().unwrap();
            let length = (SVector::from(to) - SVector::from(from)).norm();
            let (mut runs_on, mut could_stop, mut shorter, mut later) = (0, 0, 0.0_f64, 0.0_f64);
            for i in 1..(end * 10.0) as usize {
                let t = i as f64 * 0.1;
                let stop = planner.plan_stop(&plan, t);
                assert!(stop.is_none_or(|s| s.t_end() <= end && s.fraction() <= 1.0));
                if stop.is_some() {
                    continue;
                }
                runs_on += 1;
                if let Some(alt) = first_short_of_target(planner, &plan, t) {
                    could_stop += 1;
                    shorter = shorter.max((1.0 - alt.fraction()) * length);
                    later = later.max(alt.t_end() - end);
                }
            }
            std::eprintln!(
                "{from:?} -> {to:?} in {end:.2} s: the move runs on to its target at {runs_on} of {} instants; a stop allowed to end later would rest short of it at {could_stop}, up to {shorter:.2} m shorter, ending up to {later:.2} s after the move",
                (end * 10.0) as usize - 1
            );
        }
        let crane3d = Planner::with_axes(Crane3dParams::EXAMPLE, DriveLimits::LAB_3D);
        study(&crane3d, [12.0, 3.0, 8.0], [16.0, 5.0, 6.0]);
        study(&crane3d, [12.0, 3.0, 8.0], [20.0, 3.0, 4.0]);
        study(
            &Planner::new(CraneParams::PAPER, DriveLimits::LAB),
            [12.0, 8.0],
            [20.0, 4.0],
        );
    }
}
