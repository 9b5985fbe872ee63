//! The solver's own cost window inside the 100 Hz tick (issue 20).
//!
//! The firmware measures each cycle's tick between two readings of `Board::counter`;
//! what the inverse model's step costs within it was nowhere. [`Timed`] wraps the
//! feedforward the controller steps and reads the board's solver counter
//! (`board::solver_counter`, a function of its own, so that the tick's windows that
//! `cargo xtask cycles` cuts at `Board::counter` stay the tick's) before and after each
//! step; the firmware logs the sum, in the units of `Board::cost`, beside the tick's cost. Nothing else changes: the
//! controller, its frames and the plan see the inner feedforward.

use controller::feedforward::{AroundStep, FeedforwardStep, Wrapped};
use controller::Feedforward;
use solver_core::Error;

use crate::board;

/// A feedforward whose steps are timed with the board's solver counter.
pub type Timed<F> = Wrapped<F, SolverTimer>;

/// Counter ticks spent in [`Feedforward::step`] since the last [`SolverTimer::take_ticks`].
#[derive(Debug, Clone, Copy, Default)]
pub struct SolverTimer {
    ticks: u32,
}

impl SolverTimer {
    /// The counter ticks the steps took since the last call (0: no step), and starts
    /// again from zero. In the board's counter units: `Board::cost(0, ticks)` converts.
    pub fn take_ticks(&mut self) -> u32 {
        core::mem::take(&mut self.ticks)
    }
}

/// Wraps `inner`; nothing measured yet.
pub fn timed<F>(inner: F) -> Timed<F> {
    Wrapped {
        inner,
        around: SolverTimer::default(),
    }
}

impl AroundStep for SolverTimer {
    fn step<F: Feedforward<A>, const A: usize>(
        &mut self,
        inner: &mut F,
    ) -> Result<FeedforwardStep<A>, Error> {
        let start = board::solver_counter();
        let out = inner.step();
        let spent = board::solver_elapsed(start, board::solver_counter());
        self.ticks = self.ticks.wrapping_add(spent);
        out
    }
}
