//! The inverse model as the controller sees it: one step per cycle, a velocity per
//! driven axis out (`A`: two for the planar crane, three for the 3D crane), and a plan
//! it can change while the model runs.

use solver_core::plan::Plan;
use solver_core::scalar::{c, to_f64};
use solver_core::{DaeModel, Driven, Error, Integrator, NewtonStats, Real};

use core::marker::PhantomData;

use crate::crane::Crane;
use crate::operator::path::Planned;

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

/// Anything that advances a crane inverse model with `A` driven axes one step per cycle.
pub trait Feedforward<const A: usize = 2> {
    /// The reference state its solutions give the feedback: its crane's
    /// ([`crate::crane::Crane::Reference`]).
    type Reference;
    /// Advances one step. On error the model stays where it was.
    fn step(&mut self) -> Result<FeedforwardStep<A>, Error>;
    /// Model time of the newest solution, s.
    fn time(&self) -> f64;
    /// The reference state of the newest solution (positions, rope, angles and their
    /// rates): for the state feedback every cycle, and for the range guard near a
    /// range's end ([`crate::range`]), in every controller.
    fn reference(&self) -> Self::Reference;
}

/// The reference state `y_d, v_d` (Eqs. 7–10) of crane `K` from a solution of one of its
/// inverse models: what the state feedback compares the measurements with. Keyed on the
/// crane, so that each crane's own file (`scene::cranes`) implements it for its models
/// beside everything else that crane is.
pub trait CraneReference<K: Crane<A>, const A: usize> {
    /// The reference at time `t` from the solution `y` (the scheme's unknowns).
    fn reference(&self, y: &[f64], t: f64) -> K::Reference;
}

/// An inverse model with `A` driven axes driven by a [`Plan`] that the controller may
/// change — and, in a controller with manual mode, by the operator's generator
/// ([`Planned`]: what the model follows, asked and changed through [`Replan::path`]).
pub trait Replan<const A: usize = 2> {
    /// What the model follows: the plan, and the generator while manual mode runs.
    fn path(&self) -> &dyn Planned<A>;
    /// The same, to change what has not been stepped yet.
    fn path_mut(&mut self) -> &mut dyn Planned<A>;
    /// The plan the model follows.
    fn plan(&self) -> &Plan<f64, A> {
        self.path().plan()
    }
    /// The plan, to change what has not been stepped yet (checked by the planner first).
    fn plan_mut(&mut self) -> &mut Plan<f64, A> {
        self.path_mut().plan_mut()
    }
    /// Starts again at rest with the load at `position` at time `t` (after a halt);
    /// manual mode, if it ran, is left.
    fn restart_at_rest(&mut self, position: [f64; A], t: f64) -> Result<(), Error>;
}

/// A model of crane `K` together with the integrator that advances it, in the
/// integrator's scalar `T` (f64 in the firmware) on the model's `N` unknowns: the inverse
/// model as the controller steps it, through solver-core's one scheme interface
/// ([`Integrator`]).
#[derive(Debug, Clone)]
pub struct InverseModel<K, M, I, T, const N: usize> {
    /// The DAE.
    pub model: M,
    /// The scheme and its state.
    pub integrator: I,
    crane_and_scalar: PhantomData<fn() -> (K, T)>,
}

impl<K, M, I, T, const N: usize> InverseModel<K, M, I, T, N> {
    /// `model` advanced by `integrator`.
    pub fn new(model: M, integrator: I) -> Self {
        Self {
            model,
            integrator,
            crane_and_scalar: PhantomData,
        }
    }
}

impl<
        K: Crane<A>,
        T: Real,
        M: CraneReference<K, A> + DaeModel<T, N, A>,
        I: Integrator<T, M, N, A>,
        const N: usize,
        const A: usize,
    > Feedforward<A> for InverseModel<K, M, I, T, N>
{
    type Reference = K::Reference;
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
    fn reference(&self) -> K::Reference {
        let y: [f64; N] = self.integrator.state().map(to_f64).into();
        self.model.reference(&y, self.time())
    }
}

impl<
        K,
        T: Real,
        M: Driven + DaeModel<T, N, A>,
        I: Integrator<T, M, N, A>,
        const N: usize,
        const A: usize,
    > Replan<A> for InverseModel<K, M, I, T, N>
where
    M::Trajectory: Planned<A>,
{
    fn path(&self) -> &dyn Planned<A> {
        self.model.trajectory()
    }
    fn path_mut(&mut self) -> &mut dyn Planned<A> {
        self.model.trajectory_mut()
    }
    fn restart_at_rest(&mut self, position: [f64; A], t: f64) -> Result<(), Error> {
        let n = self.plan().planned_smoothness();
        self.model.trajectory_mut().rest_at(position, n)?;
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
    ) -> Result<FeedforwardStep<A>, Error>;
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

impl<F: Feedforward<A>, W: AroundStep, const A: usize> Feedforward<A> for Wrapped<F, W> {
    type Reference = F::Reference;
    fn step(&mut self) -> Result<FeedforwardStep<A>, Error> {
        self.around.step(&mut self.inner)
    }
    fn time(&self) -> f64 {
        self.inner.time()
    }
    fn reference(&self) -> F::Reference {
        self.inner.reference()
    }
}

impl<F: Replan<A>, W, const A: usize> Replan<A> for Wrapped<F, W> {
    fn path(&self) -> &dyn Planned<A> {
        self.inner.path()
    }
    fn path_mut(&mut self) -> &mut dyn Planned<A> {
        self.inner.path_mut()
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
    ) -> Result<FeedforwardStep<A>, Error> {
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
