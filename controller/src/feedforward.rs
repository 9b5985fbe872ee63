//! The inverse model as the controller sees it: one step per cycle, two velocities out.

use solver_core::scalar::to_f64;
use solver_core::{Bdf, DaeModel, Error, NewtonStats, Radau, Real};

/// One step of the inverse model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeedforwardStep {
    /// Model time of the new solution, s.
    pub t: f64,
    /// `[u1, u2]`: trolley and winch velocity set points, m/s.
    pub u: [f64; 2],
    /// What Newton did.
    pub stats: NewtonStats,
}

/// Anything that advances a crane inverse model one step per cycle.
pub trait Feedforward {
    /// Advances one step. On error the model stays where it was.
    fn step(&mut self) -> Result<FeedforwardStep, Error>;
}

/// A model together with the integrator that advances it.
#[derive(Debug, Clone)]
pub struct InverseModel<M, I> {
    /// The DAE.
    pub model: M,
    /// The scheme and its state.
    pub integrator: I,
}

fn report<T: Real>(t: T, u: nalgebra::SVector<T, 2>, stats: NewtonStats) -> FeedforwardStep {
    let [u1, u2]: [T; 2] = u.into();
    FeedforwardStep {
        t: to_f64(t),
        u: [to_f64(u1), to_f64(u2)],
        stats,
    }
}

impl<T: Real, M: DaeModel<T, N, 2>, const N: usize> Feedforward
    for InverseModel<M, Bdf<T, M, N, 2>>
{
    fn step(&mut self) -> Result<FeedforwardStep, Error> {
        self.integrator
            .step(&self.model)
            .map(|r| report(r.t, r.u, r.stats))
    }
}

impl<T: Real, M: DaeModel<T, N, 2>, const N: usize, const S: usize> Feedforward
    for InverseModel<M, Radau<T, M, N, 2, S>>
{
    fn step(&mut self) -> Result<FeedforwardStep, Error> {
        self.integrator
            .step(&self.model)
            .map(|r| report(r.t, r.u, r.stats))
    }
}
