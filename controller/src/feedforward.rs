//! The inverse model as the controller sees it: one step per cycle, a velocity per
//! driven axis out (`A`: two for the planar crane, three for the 3D crane), and a plan
//! it can change while the model runs.

use solver_core::models::crane3d::{Crane3dExt, Crane3dSubs};
use solver_core::models::crane_ext::CraneExt;
use solver_core::models::crane_proj::CraneProj;
use solver_core::models::crane_subs::CraneSubs;
use solver_core::plan::Plan;
use solver_core::scalar::{c, to_f64};
use solver_core::trajectory::Trajectory;
use solver_core::{DaeModel, Driven, Error, Integrator, NewtonStats, Real};

use core::marker::PhantomData;

use crate::feedback::Reference;

/// The least smoothness `n` of the moves and stops the controller plans.
///
/// The inputs of the servo-constraint crane contain `z⁗`, so the drives' accelerations
/// `u̇` contain `z⁽⁵⁾`. With the paper's n = 4 the fifth derivative jumps at a move's
/// ends: the accelerations jump, and a multistep scheme answers the jump with a
/// transient that no margin on the exact inverse covers (BDF4 overshoots the planned
/// peak acceleration by 9.7 %, BDF6 by a factor of up to 3.3 —
/// `cargo test -p controller --test smoothness`). With n ≥ 5 the accelerations are
/// continuous and the computed ones stay within 0.5 % of the exact ones.
pub const MIN_COMMAND_SMOOTHNESS: usize = 5;

/// The plan of a crane with `A` driven axes that rests at `position` (the load's, in
/// the model's outputs), for a scene of smoothness `n`: moves and stops are planned
/// with `max(n, MIN_COMMAND_SMOOTHNESS)`.
pub fn command_plan<const A: usize>(position: [f64; A], n: usize) -> Result<Plan<f64, A>, Error> {
    Plan::at_rest(position.into(), n.max(MIN_COMMAND_SMOOTHNESS))
}

/// One step of the inverse model with `A` driven axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeedforwardStep<const A: usize = 2> {
    /// Model time of the new solution, s.
    pub t: f64,
    /// The velocity set points in the model's input order (planar: `[u1, u2]`,
    /// trolley and winch), m/s.
    pub u: [f64; A],
    /// What Newton did.
    pub stats: NewtonStats,
}

/// A crane with `A` driven axes, as a type: what its reference state is
/// ([`ReferenceOf`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Axes<const A: usize>;

/// The reference state of a crane with a given number of driven axes: the planar
/// crane's [`Reference`], the 3D crane's one per vertical plane (x–z, y–z).
pub trait ReferenceOf {
    /// The reference state.
    type Reference;
}

impl ReferenceOf for Axes<2> {
    type Reference = Reference;
}

impl ReferenceOf for Axes<3> {
    type Reference = [Reference; 2];
}

/// The reference state of a crane with `A` driven axes ([`ReferenceOf`]).
pub type ReferenceState<const A: usize> = <Axes<A> as ReferenceOf>::Reference;

/// Anything that advances a crane inverse model with `A` driven axes one step per cycle.
pub trait Feedforward<const A: usize = 2>
where
    Axes<A>: ReferenceOf,
{
    /// Advances one step. On error the model stays where it was.
    fn step(&mut self) -> Result<FeedforwardStep<A>, Error>;
    /// Model time of the newest solution, s.
    fn time(&self) -> f64;
    /// The reference state of the newest solution (positions, rope, angles and their
    /// rates) for the state feedback; asked only by a controller that corrects.
    fn reference(&self) -> ReferenceState<A>;
}

/// The reference state `y_d, v_d` (Eqs. 7–10) of a crane with `A` driven axes from a
/// solution of its inverse model: what the state feedback compares the measurements
/// with.
pub trait CraneReference<const A: usize = 2>
where
    Axes<A>: ReferenceOf,
{
    /// The reference at time `t` from the solution `y` (the scheme's unknowns).
    fn reference(&self, y: &[f64], t: f64) -> ReferenceState<A>;
}

/// *subs*: `y = [x, l, ẋ, l̇, λ, u1, u2]`; the angle and its rate from the desired
/// load position and velocity (Eqs. 27–28).
impl<T: Real> CraneReference<2> for CraneSubs<T, Plan<f64, 2>> {
    fn reference(&self, y: &[f64], t: f64) -> Reference {
        let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
        let [p, v] = self.trajectory().derivatives::<2>(t);
        Reference::from_subs([at(0), at(1), at(2), at(3)], p.into(), v.into())
    }
}

/// *proj*: `y = [x, l, φ, ẋ, l̇, φ̇, u1, u2]` holds the reference as it is.
impl<T: Real> CraneReference<2> for CraneProj<T, Plan<f64, 2>> {
    fn reference(&self, y: &[f64], _t: f64) -> Reference {
        let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
        Reference {
            x: at(0),
            l: at(1),
            phi: at(2),
            vx: at(3),
            vl: at(4),
            vphi: at(5),
        }
    }
}

/// The 3D crane (*subs*, `y = [x, y, l, ẋ, ẏ, l̇, λ, u1, u2, u3]`): the reference of
/// each vertical plane, x–z then y–z, as the planar crane's in that plane — the drive's
/// position, the rope, the rope's slope in the plane (what a two-axis inclinometer
/// reports, `solver_core::reference::flat_crane3d::FlatState3d::slope`) and the rates.
impl<T: Real> CraneReference<3> for Crane3dSubs<T, Plan<f64, 3>> {
    fn reference(&self, y: &[f64], t: f64) -> [Reference; 2] {
        let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
        let [p, v] = self.trajectory().derivatives::<2>(t);
        let [xc, yc, zc]: [f64; 3] = p.into();
        let [vxc, vyc, vzc]: [f64; 3] = v.into();
        let (l, vl) = (at(2), at(5));
        [
            Reference::from_subs([at(0), l, at(3), vl], [xc, zc], [vxc, vzc]),
            Reference::from_subs([at(1), l, at(4), vl], [yc, zc], [vyc, vzc]),
        ]
    }
}

/// *ext* (*subs* minimally extended to index 1): its first unknowns are *subs*'
/// `[x, l, ẋ, l̇, …]` in *subs*' order, so the reference is *subs*'.
impl<T: Real> CraneReference<2> for CraneExt<T, Plan<f64, 2>> {
    fn reference(&self, y: &[f64], t: f64) -> Reference {
        let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
        let [p, v] = self.trajectory().derivatives::<2>(t);
        Reference::from_subs([at(0), at(1), at(2), at(3)], p.into(), v.into())
    }
}

/// The 3D crane's *ext*: its first ten unknowns are the 3D *subs*' in its order, so the
/// reference of each vertical plane is *subs*'.
impl<T: Real> CraneReference<3> for Crane3dExt<T, Plan<f64, 3>> {
    fn reference(&self, y: &[f64], t: f64) -> [Reference; 2] {
        let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
        let [p, v] = self.trajectory().derivatives::<2>(t);
        let [xc, yc, zc]: [f64; 3] = p.into();
        let [vxc, vyc, vzc]: [f64; 3] = v.into();
        let (l, vl) = (at(2), at(5));
        [
            Reference::from_subs([at(0), l, at(3), vl], [xc, zc], [vxc, vzc]),
            Reference::from_subs([at(1), l, at(4), vl], [yc, zc], [vyc, vzc]),
        ]
    }
}

/// An inverse model with `A` driven axes driven by a [`Plan`] that the controller may
/// change.
pub trait Replan<const A: usize = 2> {
    /// The plan the model follows.
    fn plan(&self) -> &Plan<f64, A>;
    /// The plan, to change what has not been stepped yet (checked by the planner first).
    fn plan_mut(&mut self) -> &mut Plan<f64, A>;
    /// Starts again at rest with the load at `position` at time `t` (after a halt).
    fn restart_at_rest(&mut self, position: [f64; A], t: f64) -> Result<(), Error>;
}

/// A model together with the integrator that advances it, in the integrator's scalar
/// `T` (f64 in the firmware) on the model's `N` unknowns: the inverse model as the
/// controller steps it, through solver-core's one scheme interface ([`Integrator`]).
#[derive(Debug, Clone)]
pub struct InverseModel<M, I, T, const N: usize> {
    /// The DAE.
    pub model: M,
    /// The scheme and its state.
    pub integrator: I,
    scalar: PhantomData<fn() -> T>,
}

impl<M, I, T, const N: usize> InverseModel<M, I, T, N> {
    /// `model` advanced by `integrator`.
    pub fn new(model: M, integrator: I) -> Self {
        Self {
            model,
            integrator,
            scalar: PhantomData,
        }
    }
}

impl<
        T: Real,
        M: CraneReference<A> + DaeModel<T, N, A>,
        I: Integrator<T, M, N, A>,
        const N: usize,
        const A: usize,
    > Feedforward<A> for InverseModel<M, I, T, N>
where
    Axes<A>: ReferenceOf,
{
    fn step(&mut self) -> Result<FeedforwardStep<A>, Error> {
        let r = self.integrator.step(&self.model)?;
        let u: [T; A] = r.u.into();
        Ok(FeedforwardStep {
            t: to_f64(r.t),
            u: u.map(to_f64),
            stats: r.stats,
        })
    }
    fn time(&self) -> f64 {
        to_f64(self.integrator.time())
    }
    fn reference(&self) -> ReferenceState<A> {
        let y: [f64; N] = self.integrator.state().map(to_f64).into();
        self.model.reference(&y, self.time())
    }
}

impl<
        T: Real,
        M: Driven<Trajectory = Plan<f64, A>> + DaeModel<T, N, A>,
        I: Integrator<T, M, N, A>,
        const N: usize,
        const A: usize,
    > Replan<A> for InverseModel<M, I, T, N>
{
    fn plan(&self) -> &Plan<f64, A> {
        self.model.trajectory()
    }
    fn plan_mut(&mut self) -> &mut Plan<f64, A> {
        self.model.trajectory_mut()
    }
    fn restart_at_rest(&mut self, position: [f64; A], t: f64) -> Result<(), Error> {
        let n = self.model.trajectory().planned_smoothness();
        *self.model.trajectory_mut() = Plan::at_rest(position.into(), n)?;
        self.integrator.restart(&self.model, c(t))
    }
}

/// What a wrapper does around each step of the feedforward it wraps ([`Wrapped`]): the
/// fault injection of the QEMU build and the host tests ([`FailNext`]), the firmware's
/// timing of the solver.
pub trait AroundStep {
    /// Steps `inner` (or not), doing what the wrapper is for around it.
    fn step<F: Feedforward<A>, const A: usize>(
        &mut self,
        inner: &mut F,
    ) -> Result<FeedforwardStep<A>, Error>
    where
        Axes<A>: ReferenceOf;
}

/// A feedforward with something done around each of its steps ([`AroundStep`]);
/// everything else — its time, its reference, its plan — is the inner feedforward's, so
/// the controller, its frames and the plan see the inner one.
#[derive(Debug, Clone)]
pub struct Wrapped<F, W> {
    /// The real feedforward.
    pub inner: F,
    /// What is done around its steps.
    pub around: W,
}

impl<F: Feedforward<A>, W: AroundStep, const A: usize> Feedforward<A> for Wrapped<F, W>
where
    Axes<A>: ReferenceOf,
{
    fn step(&mut self) -> Result<FeedforwardStep<A>, Error> {
        self.around.step(&mut self.inner)
    }
    fn time(&self) -> f64 {
        self.inner.time()
    }
    fn reference(&self) -> ReferenceState<A> {
        self.inner.reference()
    }
}

impl<F: Replan<A>, W, const A: usize> Replan<A> for Wrapped<F, W> {
    fn plan(&self) -> &Plan<f64, A> {
        self.inner.plan()
    }
    fn plan_mut(&mut self) -> &mut Plan<f64, A> {
        self.inner.plan_mut()
    }
    fn restart_at_rest(&mut self, position: [f64; A], t: f64) -> Result<(), Error> {
        self.inner.restart_at_rest(position, t)
    }
}

/// A feedforward whose next step can be made to fail, for the fault-injection
/// scenarios (the QEMU build and the host tests; the drive controller's build does not
/// link it).
pub type Injectable<F> = Wrapped<F, FailNext>;

/// The next step fails when asked to ([`Injectable`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct FailNext {
    fail_next: bool,
}

impl<F> Wrapped<F, FailNext> {
    /// Wraps `inner`; nothing is injected until [`Wrapped::fail_next_step`].
    pub fn new(inner: F) -> Self {
        Self {
            inner,
            around: FailNext::default(),
        }
    }

    /// The next step reports what Newton reports when it runs out of iterations
    /// (the model stays where it was, as on a real failure).
    pub fn fail_next_step(&mut self) {
        self.around.fail_next = true;
    }
}

impl AroundStep for FailNext {
    fn step<F: Feedforward<A>, const A: usize>(
        &mut self,
        inner: &mut F,
    ) -> Result<FeedforwardStep<A>, Error>
    where
        Axes<A>: ReferenceOf,
    {
        if core::mem::take(&mut self.fail_next) {
            return Err(Error::NewtonNotConverged {
                t: inner.time(),
                iterations: 20,
                residual: f64::INFINITY,
                increment: f64::INFINITY,
            });
        }
        inner.step()
    }
}
