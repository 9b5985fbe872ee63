//! The inverse model's desired output in a controller with manual mode: the plan of the
//! automatic moves, or — while manual mode runs — the operator's generator
//! (`solver_core::operator`), which turns the stick into a smooth load path.
//!
//! One trajectory type for both, so that the one inverse model (and its scheme's history)
//! carries on across the hand-over: manual mode is entered at rest, where the plan's
//! output is the constant rest position with every derivative zero and the generator
//! starts at rest at that very position, or from a running move, whose position and
//! first five derivatives the generator continues exactly ([`Source::take_over`]); it is
//! left only at rest, where the generator's output is again constant with every
//! derivative exactly 0.0, and the plan takes over at rest there. The model sees no step
//! in any derivative up to the fifth either way.

use nalgebra::SVector;
use solver_core::operator::{
    AxisSettings, Cycle, Demand, Generator3d, Handover, Headroom, PlanarGenerator, Room, Settings,
};
use solver_core::plan::{Plan, Segment};
use solver_core::trajectory::{PointToPoint, Trajectory};
use solver_core::{Error, Real};

use crate::setpoint::AxisLimits;

/// Share of a drive's limit a hand-over may use at all: what is left beside the
/// operator's own motion is its stop's ([`room`]).
pub const HANDOVER_LIMIT_SHARE: f64 = 0.95;

/// What a drive with `limit` leaves a hand-over's stop beside the operator's generator on
/// its `axis`: [`HANDOVER_LIMIT_SHARE`] of the limit less the manual speed, and less 1.5
/// times the manual acceleration (the drive's rate adds its lag times the load's jerk
/// to the load's acceleration). With these rooms no drive went past 0.894 of a limit over
/// 165 hand-overs (`cargo test --release -p host-tests --test operator_takeover`, which
/// calls this).
///
/// Where the operator alone may use more than that share (the difference below zero),
/// the room is zero, not negative: the stop may then add nothing to that drive. A stop
/// that adds nothing needs no room — the move does not move that axis, and the drive
/// sees the operator's motion only, as in manual mode at rest — while every stop that
/// moves it is refused, and the controller ends the move on its path instead. (A
/// negative room refused even the zero a purely horizontal move's stop adds to the
/// hoist.) The operator's share is kept whatever the stick asks at the take-over: the
/// stick is live throughout the stop, and may move any axis while it lasts. A limit
/// that is not a number leaves a room that is not one, which the take-over refuses.
#[must_use]
pub fn room(limit: &AxisLimits, axis: &AxisSettings) -> Room {
    // `<`, not `max`: `f64::max` would turn a NaN into a room of zero.
    let at_least_none = |left: f64| if left < 0.0 { 0.0 } else { left };
    Room {
        speed: at_least_none(HANDOVER_LIMIT_SHARE * limit.max_velocity - axis.speed),
        acceleration: at_least_none(
            HANDOVER_LIMIT_SHARE * limit.max_acceleration - 1.5 * axis.acceleration,
        ),
    }
}

/// The planar drives' room beside the operator (trolley `x`, hoist `z`): [`room`] per axis.
fn planar_room(settings: &Settings<1>, x: &AxisLimits, z: &AxisLimits) -> Headroom<1> {
    let [trolley] = settings.horizontal;
    Headroom {
        horizontal: [room(x, &trolley)],
        hoist: room(z, &settings.hoist),
    }
}

/// The 3D drives' room beside the operator (bridge `x`, trolley `y`, hoist `z`).
fn spatial_room(
    settings: &Settings<2>,
    x: &AxisLimits,
    y: &AxisLimits,
    z: &AxisLimits,
) -> Headroom<2> {
    let [bridge, trolley] = settings.horizontal;
    Headroom {
        horizontal: [room(x, &bridge), room(y, &trolley)],
        hoist: room(z, &settings.hoist),
    }
}

/// What the controller asks of an operator generator for a crane whose model has `A`
/// outputs (planar `[x_C, z_C]`, 3D `[x_C, y_C, z_C]`), whatever its number of
/// horizontal axes.
pub trait Source<const A: usize>: Trajectory<f64, A> + Sized {
    /// Its settings (each axis's manual speed and acceleration, its windows).
    type Settings: Copy;
    /// Storage for a generator not started yet (at rest, deaf to the stick).
    fn parked(settings: Self::Settings) -> Self;
    /// The generator at rest with the load at `position` at time `t`, written in place
    /// (no generator is built on the stack); on an error `self` is unchanged.
    fn reset(&mut self, settings: Self::Settings, t: f64, position: [f64; A]) -> Result<(), Error>;
    /// One cycle of the stick: `horizontal` (x, and y for the 3D crane; a planar crane
    /// takes x only) and `hoist`, each a fraction of full stick.
    fn advance(&mut self, horizontal: [f64; 2], hoist: f64) -> Cycle;
    /// Takes over the running automatic `move_` at `t` in place (the drives' `limits` in
    /// the model's output order): the move ends with a stop of its own within the
    /// headroom the operator leaves, and the generator rests at its end with the stick
    /// live (`Generator::reset_taking_over`). On an error the generator is not used.
    fn take_over(
        &mut self,
        settings: Self::Settings,
        t: f64,
        move_: &PointToPoint<f64, A>,
        limits: &[AxisLimits; A],
    ) -> Result<(), Error>;
    /// Latches the sway-free stop: every demand is taken as zero from the next cycle on,
    /// and a hand-over's stop that lasts is shortened within the room the drives'
    /// `limits` (the model's output order) leave beside the operator, as at the
    /// take-over (`Generator::stop_within`).
    fn stop(&mut self, limits: &[AxisLimits; A]);
    /// Lifts a latched stop.
    fn resume(&mut self);
    /// Whether the path rests this cycle (every derivative exactly 0.0).
    fn is_at_rest(&self) -> bool;
    /// Whether a stop is latched.
    fn is_stopping(&self) -> bool;
    /// The generator's time (the start of the last cycle built), s.
    fn time(&self) -> f64;
    /// The stick's deadband of `settings`, a share of full stick.
    fn deadband(settings: &Self::Settings) -> f64;
}

impl Source<2> for PlanarGenerator {
    type Settings = Settings<1>;
    #[inline(always)]
    fn parked(settings: Settings<1>) -> Self {
        PlanarGenerator::parked(settings)
    }
    fn reset(&mut self, settings: Settings<1>, t: f64, [x, z]: [f64; 2]) -> Result<(), Error> {
        PlanarGenerator::reset(self, settings, t, [x], z)
    }
    fn advance(&mut self, [x, _]: [f64; 2], hoist: f64) -> Cycle {
        PlanarGenerator::advance(
            self,
            &Demand {
                horizontal: [x],
                hoist,
            },
        )
    }
    fn take_over(
        &mut self,
        settings: Settings<1>,
        t: f64,
        move_: &PointToPoint<f64, 2>,
        [x, z]: &[AxisLimits; 2],
    ) -> Result<(), Error> {
        let room = planar_room(&settings, x, z);
        self.reset_taking_over(settings, t, &Handover::<1>::of(move_, t), &room)
    }
    fn stop(&mut self, [x, z]: &[AxisLimits; 2]) {
        let room = planar_room(self.settings(), x, z);
        self.stop_within(&room);
    }
    fn resume(&mut self) {
        PlanarGenerator::resume(self);
    }
    fn is_at_rest(&self) -> bool {
        PlanarGenerator::is_at_rest(self)
    }
    fn is_stopping(&self) -> bool {
        PlanarGenerator::is_stopping(self)
    }
    fn time(&self) -> f64 {
        PlanarGenerator::time(self)
    }
    fn deadband(settings: &Settings<1>) -> f64 {
        settings.deadband
    }
}

impl Source<3> for Generator3d {
    type Settings = Settings<2>;
    #[inline(always)]
    fn parked(settings: Settings<2>) -> Self {
        Generator3d::parked(settings)
    }
    fn reset(&mut self, settings: Settings<2>, t: f64, [x, y, z]: [f64; 3]) -> Result<(), Error> {
        Generator3d::reset(self, settings, t, [x, y], z)
    }
    fn advance(&mut self, horizontal: [f64; 2], hoist: f64) -> Cycle {
        Generator3d::advance(self, &Demand { horizontal, hoist })
    }
    fn take_over(
        &mut self,
        settings: Settings<2>,
        t: f64,
        move_: &PointToPoint<f64, 3>,
        [x, y, z]: &[AxisLimits; 3],
    ) -> Result<(), Error> {
        let room = spatial_room(&settings, x, y, z);
        self.reset_taking_over(settings, t, &Handover::<2>::of(move_, t), &room)
    }
    fn stop(&mut self, [x, y, z]: &[AxisLimits; 3]) {
        let room = spatial_room(self.settings(), x, y, z);
        self.stop_within(&room);
    }
    fn resume(&mut self) {
        Generator3d::resume(self);
    }
    fn is_at_rest(&self) -> bool {
        Generator3d::is_at_rest(self)
    }
    fn is_stopping(&self) -> bool {
        Generator3d::is_stopping(self)
    }
    fn time(&self) -> f64 {
        Generator3d::time(self)
    }
    fn deadband(settings: &Settings<2>) -> f64 {
        settings.deadband
    }
}

/// Why manual mode could not be entered or left.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ManualError {
    /// This controller's inverse model follows plans only.
    Unsupported,
    /// Not at rest: the plan still moves (entry), the generator still moves (leaving);
    /// or no move runs that could be taken over (a stop does).
    Moving,
    /// The generator refused its settings or the start (its error).
    Generator(Error),
}

/// What the inverse model's desired output is: a plan (automatic moves), or a plan and
/// an operator generator (manual mode as well). The controller changes it through
/// [`crate::Replan`].
pub trait Planned<const A: usize> {
    /// The plan.
    fn plan(&self) -> &Plan<f64, A>;
    /// The plan, to change what has not been stepped yet.
    fn plan_mut(&mut self) -> &mut Plan<f64, A>;
    /// Everything at rest at `position`: the plan at rest there (smoothness `n`), manual
    /// mode left.
    fn rest_at(&mut self, position: [f64; A], n: usize) -> Result<(), Error> {
        *self.plan_mut() = Plan::at_rest(position.into(), n)?;
        Ok(())
    }
    /// Manual mode: the generator takes over at rest at time `t`, where the plan rests.
    fn enter_manual(&mut self, _t: f64) -> Result<(), ManualError> {
        Err(ManualError::Unsupported)
    }
    /// Manual mode entered at the model's time `t` from the running automatic move: the
    /// generator takes the move over in place ([`Source::take_over`], the drives'
    /// `limits`), the plan rests where the load is at `t` (it is not followed while
    /// manual mode runs). Only a move (not a stop) is taken over; its own end is the
    /// stop's bound, whatever is queued behind it.
    fn take_over(&mut self, _t: f64, _limits: &[AxisLimits; A]) -> Result<(), ManualError> {
        Err(ManualError::Unsupported)
    }
    /// Manual mode left at rest: the plan takes over where the generator rests.
    fn leave_manual(&mut self) -> Result<(), ManualError> {
        Err(ManualError::Unsupported)
    }
    /// The generator, while manual mode runs.
    fn manual_mut(&mut self) -> Option<&mut dyn ManualPath<A>> {
        None
    }
    /// Whether manual mode runs (the generator drives the model).
    fn in_manual(&self) -> bool {
        false
    }
    /// The generator's stick deadband (`Settings::deadband`), a share of full stick;
    /// `None` for a model that follows plans only.
    fn stick_deadband(&self) -> Option<f64> {
        None
    }
    /// Whether manual mode runs and its generator does not rest this cycle.
    fn manual_moving(&self) -> bool {
        false
    }
}

/// The generator as the controller drives it each cycle (object safe: the controller
/// does not name the generator's type), for a model of `A` outputs.
pub trait ManualPath<const A: usize> {
    /// One cycle of the stick (see [`Source::advance`]).
    fn advance(&mut self, horizontal: [f64; 2], hoist: f64) -> Cycle;
    /// Latches the sway-free stop (see [`Source::stop`]).
    fn stop(&mut self, limits: &[AxisLimits; A]);
    /// Lifts a latched stop.
    fn resume(&mut self);
    /// Whether the path rests this cycle.
    fn is_at_rest(&self) -> bool;
    /// Whether a stop is latched.
    fn is_stopping(&self) -> bool;
    /// The generator's time (the start of the last cycle built), s: after each of the
    /// model's steps, one cycle before the model's time, as the generator is advanced on
    /// every cycle the model steps.
    fn time(&self) -> f64;
}

impl<G: Source<A>, const A: usize> ManualPath<A> for G {
    fn advance(&mut self, horizontal: [f64; 2], hoist: f64) -> Cycle {
        Source::advance(self, horizontal, hoist)
    }
    fn stop(&mut self, limits: &[AxisLimits; A]) {
        Source::stop(self, limits);
    }
    fn resume(&mut self) {
        Source::resume(self);
    }
    fn is_at_rest(&self) -> bool {
        Source::is_at_rest(self)
    }
    fn is_stopping(&self) -> bool {
        Source::is_stopping(self)
    }
    fn time(&self) -> f64 {
        Source::time(self)
    }
}

impl<const A: usize> Planned<A> for Plan<f64, A> {
    fn plan(&self) -> &Plan<f64, A> {
        self
    }
    fn plan_mut(&mut self) -> &mut Plan<f64, A> {
        self
    }
}

/// The plan, and the operator's generator `G` while manual mode runs.
#[derive(Debug, Clone)]
pub struct Steered<G: Source<A>, const A: usize> {
    plan: Plan<f64, A>,
    settings: G::Settings,
    /// The generator: parked until manual mode is first entered, then reset in place on
    /// each entry. Always here rather than an `Option` built on entry: a generator built
    /// by value and moved into place is one or two copies of it (3D: ~3 KB each) on the
    /// control task's stack.
    generator: G,
    /// Whether manual mode runs (the generator drives the model).
    manual: bool,
}

impl<G: Source<A>, const A: usize> Steered<G, A> {
    /// Follows `plan`; manual mode, when entered, with the generator's `settings`.
    pub fn new(plan: Plan<f64, A>, settings: G::Settings) -> Self {
        Self {
            plan,
            settings,
            generator: G::parked(settings),
            manual: false,
        }
    }
}

impl<G: Source<A>, const A: usize> Planned<A> for Steered<G, A> {
    fn plan(&self) -> &Plan<f64, A> {
        &self.plan
    }
    fn plan_mut(&mut self) -> &mut Plan<f64, A> {
        &mut self.plan
    }
    fn rest_at(&mut self, position: [f64; A], n: usize) -> Result<(), Error> {
        self.plan = Plan::at_rest(position.into(), n)?;
        self.manual = false;
        Ok(())
    }
    fn enter_manual(&mut self, t: f64) -> Result<(), ManualError> {
        if self.plan.is_moving(t) || self.plan.active().is_some() {
            return Err(ManualError::Moving);
        }
        let position = self.plan.final_position().into();
        self.generator
            .reset(self.settings, t, position)
            .map_err(ManualError::Generator)?;
        self.manual = true;
        Ok(())
    }
    fn take_over(&mut self, t: f64, limits: &[AxisLimits; A]) -> Result<(), ManualError> {
        let Some(Segment::Move(move_)) = self.plan.active().copied() else {
            return Err(ManualError::Moving);
        };
        self.generator
            .take_over(self.settings, t, &move_, limits)
            .map_err(ManualError::Generator)?;
        let [here]: [SVector<f64, A>; 1] = move_.derivatives(t);
        let n = self.plan.planned_smoothness();
        self.plan = Plan::at_rest(here, n).map_err(ManualError::Generator)?;
        self.manual = true;
        Ok(())
    }
    fn leave_manual(&mut self) -> Result<(), ManualError> {
        if !self.manual {
            return Ok(());
        }
        let g = &self.generator;
        if !g.is_at_rest() {
            return Err(ManualError::Moving);
        }
        let [position]: [SVector<f64, A>; 1] = g.derivatives(g.time());
        let n = self.plan.planned_smoothness();
        self.plan = Plan::at_rest(position, n).map_err(ManualError::Generator)?;
        self.manual = false;
        Ok(())
    }
    fn manual_mut(&mut self) -> Option<&mut dyn ManualPath<A>> {
        if self.manual {
            Some(&mut self.generator as &mut dyn ManualPath<A>)
        } else {
            None
        }
    }
    fn in_manual(&self) -> bool {
        self.manual
    }
    fn stick_deadband(&self) -> Option<f64> {
        Some(G::deadband(&self.settings))
    }
    fn manual_moving(&self) -> bool {
        self.manual && !self.generator.is_at_rest()
    }
}

impl<T: Real, G: Source<A>, const A: usize> Trajectory<T, A> for Steered<G, A>
where
    G: Trajectory<T, A>,
    Plan<f64, A>: Trajectory<T, A>,
{
    fn derivatives<const D: usize>(&self, t: T) -> [SVector<T, A>; D] {
        if self.manual {
            self.generator.derivatives(t)
        } else {
            self.plan.derivatives(t)
        }
    }
    fn active_span(&self) -> (T, T) {
        if self.manual {
            self.generator.active_span()
        } else {
            self.plan.active_span()
        }
    }
    fn smoothness(&self) -> usize {
        if self.manual {
            Trajectory::<T, A>::smoothness(&self.generator)
        } else {
            Trajectory::<T, A>::smoothness(&self.plan)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drive the operator alone may take past [`HANDOVER_LIMIT_SHARE`] leaves a room of
    /// zero, not a negative one; a limit that is not a number leaves a room that is not
    /// one (the take-over refuses it), not zero.
    #[test]
    fn a_room_is_zero_at_least_and_not_a_number_stays_so() {
        let axis = AxisSettings {
            speed: 0.5,
            acceleration: 1.95,
            range: (0.0, 1.0),
        };
        let limit = AxisLimits {
            max_velocity: 2.0,
            max_acceleration: 3.0,
        };
        let r = room(&limit, &axis);
        assert!((r.speed - 1.4).abs() < 1e-12, "{r:?}");
        assert_eq!(r.acceleration, 0.0, "0.95 · 3 − 1.5 · 1.95 < 0");
        let nan = room(
            &AxisLimits {
                max_velocity: f64::NAN,
                ..limit
            },
            &axis,
        );
        assert!(nan.speed.is_nan(), "{nan:?}");
    }
}
