//! The hook-and-load crane: the planar crane (trolley x and rope l) with a hook block
//! at the rope's end and the load on a sling below it, a double pendulum
//! (`solver_core::models::double_pendulum`). Everything the controller knows of it: the
//! [`Crane`] impl, its own reference state ([`HookReference`]) and the reference of
//! each of its inverse models (*subs*, *ext*).
//!
//! It has no state feedback yet: which sensor a loop would read (the rope's angle at
//! the hook block, the sling's, or both) is open, so its only correction is
//! [`crate::feedback::NoFeedback`], and the planar loop — keyed on the planar [`crate::feedback::Reference`]
//! — is refused for it at compile time.

use solver_core::models::double_pendulum::DoublePendulumSubs;
use solver_core::models::double_pendulum_crane::DoublePendulumParams;
use solver_core::models::double_pendulum_ext::DoublePendulumExt;
use solver_core::plan::Plan;
use solver_core::reference::double_pendulum::{self, FlatDoublePendulum};
use solver_core::trajectory::Trajectory;
use solver_core::Real;

use super::{AxisReasons, Crane, Flat};
use crate::commands::Reject;
use crate::drive::{self, Drive};
use crate::feedforward::CraneReference;
use crate::setpoint::{AxisLimits, DriveLimits};

/// The hook-and-load crane's reference state: the drives and the hook block, with their
/// rates (the load follows its path; the hook is where the flat inverse puts it).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct HookReference {
    /// Trolley position x, m.
    pub x: f64,
    /// Rope length l (rail to hook block), m.
    pub l: f64,
    /// The hook block `[x_H, z_H]`, m.
    pub hook: [f64; 2],
    /// Trolley velocity, m/s.
    pub vx: f64,
    /// Rope rate, m/s.
    pub vl: f64,
    /// The hook block's velocity, m/s.
    pub v_hook: [f64; 2],
}

impl HookReference {
    /// From the first unknowns of *subs* (and *ext*, which keeps *subs*' order):
    /// `[x, l, x_H, z_H, v_x, v_l, v_xH, v_zH, …]`.
    fn from_subs_unknowns(y: &[f64]) -> Self {
        let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
        Self {
            x: at(0),
            l: at(1),
            hook: [at(2), at(3)],
            vx: at(4),
            vl: at(5),
            v_hook: [at(6), at(7)],
        }
    }
}

impl Crane<2> for DoublePendulumParams {
    const NAME: &'static str = "hook-and-load crane";
    const DRIVES: [Drive; 2] = drive::PLANAR;
    const REASONS: [AxisReasons; 2] = [AxisReasons::TROLLEY, AxisReasons::WINCH];
    const LAB_LIMITS: [AxisLimits; 2] = DriveLimits::LAB.axes();
    /// Provisional: no feedback reads it yet; the stock one-axis inclinometer (on the
    /// hook block it would read the rope's angle; the sling's is not measured).
    const SWING_AXES: u8 = 1;
    /// The inputs contain `z⁽⁶⁾` (the sling's constraints differentiated four times give
    /// `u`, five times `u̇`: index 5, `solver_core::models::double_pendulum`), so the
    /// drives' accelerations `u̇` contain `z⁽⁷⁾`: moves are planned with n ≥ 7, as the
    /// planar crane's with n ≥ 5 for its `z⁗`.
    const MIN_COMMAND_SMOOTHNESS: usize = 7;
    /// Two: its stops have n = 9, the path's 10th derivative jumps where one takes over.
    /// With one (n = 8, the 9th jumping) BDF4's set points answered the takeover with a
    /// transient alternating cycle to cycle, up to 9.0e-3 m/s from the exact inverse's in
    /// a stop's first 15 cycles (3.6e-3 with two; 7.4e-4 and 7.1e-4 after them: `cargo
    /// test -p controller --test double_pendulum_crane stop_takeover -- --ignored
    /// --nocapture`, stops every 0.1 s of (12, 8) → (16, 6) in 8 s), and the stop sent
    /// 0.4 s into that move — 0.58 s long — sent a trolley set point 3.66 m/s² from the
    /// last where the exact inverse's acceleration was 1.6–1.9 m/s²: fault 2. With two
    /// every stop of the sweep every 0.1 s rests ready, its set points within 0.950 of the
    /// acceleration limits (`cargo test -p controller --test double_pendulum_crane a_stop
    /// -- --nocapture`; three: 0.948).
    const STOP_SMOOTHNESS_ABOVE_MOVES: usize = 2;
    type Reference = HookReference;
    fn drive_states(r: &HookReference) -> [(f64, f64); 2] {
        [(r.x, r.vx), (r.l, r.vl)]
    }
    fn g(&self) -> f64 {
        self.crane.g
    }
    fn ranges(&self) -> [(f64, f64); 2] {
        let w = &self.crane.workspace;
        [(w.x_min, w.x_max), (w.l_min, w.l_max)]
    }
    fn target(x: f64, y: Option<f64>, z: f64, _end: [f64; 2]) -> Option<[f64; 2]> {
        y.is_none().then_some([x, z])
    }
    /// The exact flat inverse; where it has none (a rope or the sling slack, the hook at
    /// the rail) every value is NaN, which the planner refuses as a violation.
    fn flat<Z: Trajectory<f64, 2>>(&self, z: &Z, t: f64) -> Flat<2> {
        double_pendulum::flat_inverse(self, z, t).map_or(Flat::UNDEFINED, |f| drives(&f))
    }
    /// The hook hangs a sling above the load: the rope is that much shorter.
    fn drives_at_rest(&self, [x, z]: [f64; 2]) -> [f64; 2] {
        [x, z - self.sling]
    }
    fn load_at_rest(&self, [x, l]: [f64; 2]) -> [f64; 2] {
        [x, l + self.sling]
    }
    /// The rope carries hook and load: it stays taut while their mean downward
    /// acceleration `(z̈_C + μ z̈_H)/(1 + μ)` (μ = m_h/m) stays below g, and keeps the
    /// planner's margin below `max_down_acceleration`; the sling is the load's own rope,
    /// which the planner checks for every crane. Where the flat inverse refuses a slack
    /// rope or sling, slack; where it refuses the hook at the rail
    /// (`solver_core::Error::OutsideWorkspace` naming `z_H`), [`Reject::HookAtRail`];
    /// anything else it refuses (a non-finite path), the undefined flat, whose NaN the
    /// planner refuses as each axis's violation. One flat inverse serves both the rope
    /// check and the drives' checks.
    fn taut_flat<Z: Trajectory<f64, 2>>(
        &self,
        z: &Z,
        t: f64,
        load_down_acceleration: f64,
        max_down_acceleration: f64,
    ) -> Result<Flat<2>, Reject> {
        match double_pendulum::flat_inverse(self, z, t) {
            Ok(f) => {
                let [_, a_hook] = f.a_hook;
                let mu = self.hook_mass / self.crane.m;
                let mean = (load_down_acceleration + mu * a_hook) / (1.0 + mu);
                if mean.is_nan() || mean > max_down_acceleration {
                    Err(Reject::SlackRope)
                } else {
                    Ok(drives(&f))
                }
            }
            Err(solver_core::Error::RopeSlack { .. }) => Err(Reject::SlackRope),
            Err(solver_core::Error::OutsideWorkspace {
                coordinate: "z_H", ..
            }) => Err(Reject::HookAtRail),
            Err(_) => Ok(Flat::UNDEFINED),
        }
    }
    fn lags(&self) -> [f64; 2] {
        [self.crane.tau1, self.crane.tau2]
    }
}

/// The drives' part of the exact double-pendulum state: trolley and rope, their inputs
/// and the inputs' rates.
fn drives(f: &FlatDoublePendulum) -> Flat<2> {
    Flat {
        position: [f.x, f.l],
        u: f.u,
        u_dot: f.u_dot,
    }
}

/// *subs*: `y = [x, l, x_H, z_H, v_x, v_l, v_xH, v_zH, λ1, λ2, u1, u2]`.
impl<T: Real> CraneReference for DoublePendulumSubs<T, Plan<f64, 2>> {
    type Reference = HookReference;
    fn reference(&self, y: &[f64], _t: f64) -> HookReference {
        HookReference::from_subs_unknowns(y)
    }
}

/// *ext*: its first unknowns are *subs*' in *subs*' order.
impl<T: Real> CraneReference for DoublePendulumExt<T, Plan<f64, 2>> {
    type Reference = HookReference;
    fn reference(&self, y: &[f64], _t: f64) -> HookReference {
        HookReference::from_subs_unknowns(y)
    }
}

// The hook-and-load crane without feedback: the inverse model's set points as they are.
crate::correction::feedforward_only!(2, HookReference);
