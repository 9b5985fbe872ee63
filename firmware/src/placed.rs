//! The inverse model in a static of its own, the controller holding it by reference.
//!
//! `init` built the controller by value — the inverse model inside it, 10.6 and 12.1 KB
//! for the manual scenes — and then wrote it into its static: `init`'s frame held the
//! controller once more, and its stack since boot (19.3 and 21.5 KB) was the firmware's
//! high-water mark, putting static RAM + stack over 32 KiB (docs/COMMISSIONING.md,
//! "Manual mode"). The controller's constructor takes its feedforward by value, so the
//! model is written into a static of its own first and the controller gets [`Placed`],
//! a reference to it: the controller's by-value copy is a few KB smaller by the model.

use controller::feedforward::FeedforwardStep;
use controller::operator::path::Planned;
use controller::{Feedforward, Replan};
use solver_core::Error;

/// A feedforward in a static, stepped and replanned through this reference.
#[derive(Debug)]
pub struct Placed<F: 'static>(pub &'static mut F);

impl<F> core::ops::Deref for Placed<F> {
    type Target = F;
    fn deref(&self) -> &F {
        self.0
    }
}

impl<F> core::ops::DerefMut for Placed<F> {
    fn deref_mut(&mut self) -> &mut F {
        self.0
    }
}

impl<F: Feedforward<A>, const A: usize> Feedforward<A> for Placed<F> {
    type Reference = F::Reference;
    fn step(&mut self) -> Result<FeedforwardStep<A>, Error> {
        self.0.step()
    }
    fn time(&self) -> f64 {
        self.0.time()
    }
    fn reference(&self) -> F::Reference {
        self.0.reference()
    }
}

impl<F: Replan<A>, const A: usize> Replan<A> for Placed<F> {
    fn path(&self) -> &dyn Planned<A> {
        self.0.path()
    }
    fn path_mut(&mut self) -> &mut dyn Planned<A> {
        self.0.path_mut()
    }
    fn restart_at_rest(&mut self, position: [f64; A], t: f64) -> Result<(), Error> {
        self.0.restart_at_rest(position, t)
    }
}
