//! What a crane is to the controller, as one trait ([`Crane`]): its drives, what names
//! each axis's violations, its lab drives' limits, the reference state its feedback
//! compares with, how smooth its commanded moves must be, and its flat inverse. Generic
//! code is keyed on the crane type `K`, never on the number of axes or the drive list,
//! so that a second crane with the same axes gets its own reference and its own loop
//! (or none) instead of the first one's.
//!
//! Each crane is one file of the registry (`scene::cranes`: the paper's planar crane,
//! Eq. 24; the 3D crane; the hook-and-load crane), which holds its `Crane` impl beside its
//! plant and its registration.

use solver_core::plan::Plan;
use solver_core::trajectory::Trajectory;
use solver_core::Error;

use crate::commands::Reject;
use crate::drive::Drive;
use crate::setpoint::AxisLimits;

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

impl AxisReasons {
    /// The bridge's (the 3D crane's x axis).
    pub const BRIDGE: Self = Self {
        workspace: Reject::BridgeWorkspace,
        velocity: Reject::BridgeVelocity,
        acceleration: Reject::BridgeAcceleration,
    };
    /// The trolley's.
    pub const TROLLEY: Self = Self {
        workspace: Reject::TrolleyWorkspace,
        velocity: Reject::TrolleyVelocity,
        acceleration: Reject::TrolleyAcceleration,
    };
    /// The winch's: its workspace is the rope's length range.
    pub const WINCH: Self = Self {
        workspace: Reject::RopeWorkspace,
        velocity: Reject::WinchVelocity,
        acceleration: Reject::WinchAcceleration,
    };
}

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

impl<const A: usize> Flat<A> {
    /// Where a crane has no flat inverse: every value NaN, which the planner refuses as
    /// a violation of each axis.
    pub const UNDEFINED: Self = Self {
        position: [f64::NAN; A],
        u: [f64::NAN; A],
        u_dot: [f64::NAN; A],
    };
}

/// A crane with `A` driven axes: everything the controller, the planner and the
/// registry ask of it. The last output is the load's depth z_C below the rail (Eq. 24's
/// convention, in 3D too).
pub trait Crane<const A: usize> {
    /// How errors and reports name it ("planar crane").
    const NAME: &'static str;
    /// Its drives, in the model's input order: the order of every per-drive array.
    const DRIVES: [Drive; A];
    /// The reasons of each axis, in the model's input order.
    const REASONS: [AxisReasons; A];
    /// The lab drives' limits, in the model's input order: what the planner checks and
    /// the gate enforces where the commissioning file names none.
    const LAB_LIMITS: [AxisLimits; A];
    /// How many slopes its swing has, as its feedback reads them (the planar crane's φ:
    /// 1; the 3D crane's swing in both vertical planes: 2): its inclinometer must have as
    /// many axes ([`crate::commissioning::InclinometerSetup::stock`]).
    const SWING_AXES: u8;
    /// How many of its drives move the load horizontally (the planar and the
    /// hook-and-load crane's trolley: 1; the 3D crane's bridge and trolley: 2): the
    /// horizontal directions its operator's stick demands, so that a y demand to a crane
    /// with one is refused ([`crate::operator`]).
    const HORIZONTAL_AXES: u8;
    /// The least smoothness `n` of the moves and stops the controller plans for it
    /// ([`command_plan`]). Its inputs contain the load path's derivatives up to some
    /// order `k`, so the drives' accelerations contain order `k + 1`: a plan of
    /// smoothness `n ≤ k` makes them jump at a move's ends, and a multistep scheme
    /// answers the jump with a transient that no margin on the exact inverse covers
    /// (`cargo test -p controller --test smoothness`).
    const MIN_COMMAND_SMOOTHNESS: usize;
    /// How many orders smoother than its moves a stop is (`solver_core::plan::
    /// Plan::stop_start`): the path's derivative that jumps where a stop takes over must
    /// lie far enough beyond what its inverse model differences into the set points that
    /// the scheme's transient there stays inside the checks' margin. One for the planar
    /// and 3D cranes (index 3); cranes whose inverse is of higher index may need more
    /// (`cargo test -p controller --test double_pendulum_crane a_stop`).
    const STOP_SMOOTHNESS_ABOVE_MOVES: usize = 1;
    /// The reference state its feedback compares the measurements with, from a solution
    /// of its inverse model ([`crate::feedforward::CraneReference`]).
    type Reference: Copy + Default + PartialEq + core::fmt::Debug;
    /// Where the model's drives stand in `reference` and how fast they move, in the
    /// model's input order (trolley or bridge position, rope length), `(m, m/s)`: what
    /// the range guard compares a drive's position actual with near an end
    /// ([`crate::range`]).
    fn drive_states(reference: &Self::Reference) -> [(f64, f64); A];
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
    /// Where the drives stand while the load rests at `load` (its outputs): the inverse
    /// at rest. The planar and 3D crane's drives stand where the load hangs (trolley and
    /// bridge above it, the rope as long as it is deep); the hook-and-load crane's rope
    /// is a sling shorter. What the controller expects its drives' positions actual to
    /// read at rest, and where the virtual bus powers them up.
    fn drives_at_rest(&self, load: [f64; A]) -> [f64; A];
    /// Where the load rests while the drives stand at `drives`: the inverse of
    /// [`Crane::drives_at_rest`]. Where the controller restarts its model from the
    /// drives' positions actual (a reset).
    fn load_at_rest(&self, drives: [f64; A]) -> [f64; A];
    /// The flat inverse at `t` of `z` where every rope other than the load's own stays
    /// taut with the planner's margin and the crane's own geometry allows it; otherwise
    /// the reason the planner gives for that sample alone: [`Reject::SlackRope`] where a
    /// rope goes slack or keeps less tension than that margin, [`Reject::HookAtRail`]
    /// where the hook-and-load crane's hook block would reach the rail.
    /// `load_down_acceleration` is the load's own `z̈_C` at `t` (m/s²), which the planner
    /// has already checked against `max_down_acceleration` for every crane. The planner
    /// asks this once per sample instead of [`Crane::flat`], so that a crane whose rope
    /// check needs its flat inverse (the hook-and-load crane's hook) computes that
    /// inverse once. The planar and 3D crane's one rope carries the load alone: always
    /// their flat.
    ///
    /// # Errors
    ///
    /// The reason of this sample, as above.
    fn taut_flat<Z: Trajectory<f64, A>>(
        &self,
        z: &Z,
        t: f64,
        load_down_acceleration: f64,
        max_down_acceleration: f64,
    ) -> Result<Flat<A>, Reject> {
        let _ = (load_down_acceleration, max_down_acceleration);
        Ok(self.flat(z, t))
    }
    /// Each drive's lag τ, s (Eq. 24's `τ v̇ + v = u`): what the controller expects of
    /// the set points it sends ([`crate::motion`]).
    fn lags(&self) -> [f64; A];
}

/// The plan of crane `K` that rests at `position` (the load's, in the model's outputs),
/// for a scene of smoothness `n`: moves and stops are planned with
/// `max(n, K::MIN_COMMAND_SMOOTHNESS)`.
pub fn command_plan<K: Crane<A>, const A: usize>(
    position: [f64; A],
    n: usize,
) -> Result<Plan<f64, A>, Error> {
    Plan::at_rest(position.into(), n.max(K::MIN_COMMAND_SMOOTHNESS))
}
