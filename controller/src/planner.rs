//! Checks a requested move (or a stop) along its whole path before it is accepted
//! (docs/COMMANDS.md): the crane's workspace, the rope's tension, and the drives'
//! velocity and acceleration limits, evaluated with the exact flat inverse at
//! [`SAMPLES`] + 1 points of the path.

use nalgebra::SVector;
use solver_core::models::crane::CraneParams;
use solver_core::plan::{Hermite, Plan};
use solver_core::reference::flat_crane::flat_inverse;
use solver_core::trajectory::{PointToPoint, Trajectory};

use crate::commands::Reject;
use crate::units::DriveLimits;

/// Points per checked path segment (plus its end).
pub const SAMPLES: usize = 100;
/// Share of each drive limit a planned move may use (the computed inputs differ from
/// the flat inverse by the scheme's error).
pub const MARGIN: f64 = 0.95;
/// Largest downward acceleration of the load, as a share of g ("well below g").
pub const MAX_DOWN_ACCELERATION: f64 = 0.5;
/// Shortest and longest move, s.
pub const DURATION_RANGE: (f64, f64) = (0.5, 600.0);
/// Durations tried for a stop, s: steps of √2, shortest first.
pub const STOP_DURATIONS: [f64; 9] = [0.5, 0.7, 1.0, 1.4, 2.0, 2.8, 4.0, 5.6, 8.0];

/// The checks, in the order of precedence of their reasons.
const ORDER: [Reject; 7] = [
    Reject::TrolleyWorkspace,
    Reject::RopeWorkspace,
    Reject::SlackRope,
    Reject::TrolleyVelocity,
    Reject::WinchVelocity,
    Reject::TrolleyAcceleration,
    Reject::WinchAcceleration,
];

/// Plans and checks moves for one crane and its drives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Planner {
    params: CraneParams,
    limits: DriveLimits,
}

impl Planner {
    /// A planner for a crane with these parameters and drive limits.
    #[must_use]
    pub const fn new(params: CraneParams, limits: DriveLimits) -> Self {
        Self { params, limits }
    }

    /// Checks the desired output on `[t0, t1]`; the highest-precedence violation, if any.
    pub fn check<Z: Trajectory<f64, 2>>(&self, z: &Z, t0: f64, t1: f64) -> Result<(), Reject> {
        let p = &self.params;
        let w = &p.workspace;
        let mut violated = [false; ORDER.len()];
        let mut flag = |reason: Reject| {
            if let Some(i) = ORDER.iter().position(|r| *r == reason) {
                if let Some(v) = violated.get_mut(i) {
                    *v = true;
                }
            }
        };
        for i in 0..=SAMPLES {
            let t = t0 + (t1 - t0) * i as f64 / SAMPLES as f64;
            let [zd, _, zdd] = z.derivatives::<3>(t).map(<[f64; 2]>::from);
            let [_, zc] = zd;
            let [_, zcdd] = zdd;
            if zc.is_nan() || zc <= 0.0 {
                flag(Reject::RopeWorkspace);
                continue;
            }
            if zcdd.is_nan() || zcdd > MAX_DOWN_ACCELERATION * p.g {
                flag(Reject::SlackRope);
                continue;
            }
            let f = flat_inverse(p, z, t);
            if !(w.x_min..=w.x_max).contains(&f.x) {
                flag(Reject::TrolleyWorkspace);
            }
            if !(w.l_min..=w.l_max).contains(&f.l) {
                flag(Reject::RopeWorkspace);
            }
            let [u1, u2] = f.u;
            let [a1, a2] = f.u_dot;
            let (lt, lw) = (self.limits.trolley, self.limits.winch);
            for (value, limit, reason) in [
                (u1, lt.max_velocity, Reject::TrolleyVelocity),
                (u2, lw.max_velocity, Reject::WinchVelocity),
                (a1, lt.max_acceleration, Reject::TrolleyAcceleration),
                (a2, lw.max_acceleration, Reject::WinchAcceleration),
            ] {
                if value.is_nan() || value.abs() > MARGIN * limit {
                    flag(reason);
                }
            }
        }
        match ORDER.iter().zip(violated).find(|(_, v)| *v) {
            Some((reason, _)) => Err(*reason),
            None => Ok(()),
        }
    }

    /// A checked move from where `plan` ends to `target` (m), starting no earlier than
    /// `earliest`, taking `duration` seconds or, for `None`, the shortest duration (to
    /// 10 ms) that passes every check.
    pub fn plan_move(
        &self,
        plan: &Plan<f64, 2>,
        target: [f64; 2],
        duration: Option<f64>,
        earliest: f64,
    ) -> Result<PointToPoint<f64, 2>, Reject> {
        let (shortest, longest) = DURATION_RANGE;
        if target.iter().any(|v| !v.is_finite() || *v <= 0.0) {
            return Err(Reject::Invalid);
        }
        let target = SVector::from(target);
        let attempt = |d: f64| -> Result<PointToPoint<f64, 2>, Reject> {
            let m = plan
                .candidate(target, earliest, d)
                .map_err(|_| Reject::Invalid)?;
            let (t0, t1) = m.active_span();
            self.check(&m, t0, t1).map(|()| m)
        };
        match duration {
            Some(d) if !(shortest..=longest).contains(&d) => Err(Reject::Invalid),
            Some(d) => attempt(d),
            None => {
                // A move that fails at the longest duration fails for a reason slowness
                // cannot cure (the workspace, the target itself): report it.
                let slow = attempt(longest)?;
                if let Ok(m) = attempt(shortest) {
                    return Ok(m);
                }
                // Geometric bisection: lo fails, hi passes.
                let (mut lo, mut hi, mut best) = (shortest, longest, slow);
                while hi / lo > 1.02 {
                    let mid = libm::sqrt(lo * hi);
                    match attempt(mid) {
                        Ok(m) => (hi, best) = (mid, m),
                        Err(_) => lo = mid,
                    }
                }
                // Round up to the 10 ms grid; keep the checked candidate if rounding fails.
                Ok(attempt(libm::ceil(hi * 100.0) / 100.0).unwrap_or(best))
            }
        }
    }

    /// Trolley position and rope length `[x, l]` where `plan` stands at `t` (the flat
    /// inverse: exact for the plan, which the model follows to the scheme's error).
    #[must_use]
    pub fn drive_positions(&self, plan: &Plan<f64, 2>, t: f64) -> [f64; 2] {
        let f = flat_inverse(&self.params, plan, t);
        [f.x, f.l]
    }

    /// A checked smooth stop taking over at `t`: the shortest of [`STOP_DURATIONS`] that
    /// passes every check and comes to rest before the running segment would. `None`
    /// when no stop beats the plan itself — the running segment, checked when it was
    /// accepted, is then the quickest smooth way to rest.
    #[must_use]
    pub fn plan_stop(&self, plan: &Plan<f64, 2>, t: f64) -> Option<Hermite<f64, 2>> {
        let (_, running_until) = plan.active()?.span();
        STOP_DURATIONS
            .iter()
            .take_while(|&&d| t + d < running_until)
            .find_map(|&d| {
                let stop = plan.stop_candidate(t, d).ok()?;
                self.check(&stop, t, t + d).ok().map(|()| stop)
            })
    }
}
