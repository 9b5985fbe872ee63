//! The solver's own cost window inside the 100 Hz tick (issue 20).
//!
//! The firmware measures each cycle's tick between two readings of `Board::counter`;
//! what the inverse model's step costs within it was nowhere. [`Timed`] wraps the
//! feedforward the controller steps and reads the board's solver counter
//! (`board::solver_counter`, a function of its own, so that the tick's windows that
//! `cargo xtask cycles` cuts at `Board::counter` stay the tick's) before and after each
//! step; the firmware logs the sum, in the units of `Board::cost`, beside the tick's cost. Nothing else changes: the
//! controller, its frames and the plan see the inner feedforward.

use controller::feedback::Reference;
use controller::feedforward::FeedforwardStep;
use controller::{Feedforward, Replan};
use solver_core::plan::Plan;
use solver_core::Error;

use crate::board;

/// A feedforward whose steps are timed with the board's solver counter.
#[derive(Debug, Clone)]
pub struct Timed<F> {
    /// The feedforward the controller steps.
    pub inner: F,
    /// Counter ticks spent in [`Feedforward::step`] since the last [`Timed::take_ticks`].
    ticks: u32,
}

impl<F> Timed<F> {
    /// Wraps `inner`; nothing measured yet.
    pub fn new(inner: F) -> Self {
        Self { inner, ticks: 0 }
    }

    /// The counter ticks the steps took since the last call (0: no step), and starts
    /// again from zero. In the board's counter units: `Board::cost(0, ticks)` converts.
    pub fn take_ticks(&mut self) -> u32 {
        core::mem::take(&mut self.ticks)
    }
}

impl<F: Feedforward> Feedforward for Timed<F> {
    fn step(&mut self) -> Result<FeedforwardStep, Error> {
        let start = board::solver_counter();
        let out = self.inner.step();
        let spent = board::solver_elapsed(start, board::solver_counter());
        self.ticks = self.ticks.wrapping_add(spent);
        out
    }
    fn time(&self) -> f64 {
        self.inner.time()
    }
    fn reference(&self) -> Reference {
        self.inner.reference()
    }
}

impl<F: Replan> Replan for Timed<F> {
    fn plan(&self) -> &Plan<f64, 2> {
        self.inner.plan()
    }
    fn plan_mut(&mut self) -> &mut Plan<f64, 2> {
        self.inner.plan_mut()
    }
    fn restart_at_rest(&mut self, position: [f64; 2], t: f64) -> Result<(), Error> {
        self.inner.restart_at_rest(position, t)
    }
}
