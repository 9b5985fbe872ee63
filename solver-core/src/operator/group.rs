//! A group of axes that share one filter: the horizontal axes (one rate limiter for the
//! vector, one ring, the virtual pendulum) or the hoist (its own limiter and windows).
//! Each cycle: the limiter's steps, the discrete filter, one piece per axis.

use crate::operator::filter::{i64_to_f64, u64_to_f64, Ring, Sums, Taps};
use crate::operator::limiter::{self, Axis};
use crate::operator::piece::{spline, Inputs, Piece};
use crate::operator::settings::Quanta;

/// One group of `W` axes with a ring of `R` cycles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Group<const W: usize, const R: usize> {
    /// The rate limiter's axes.
    pub axes: [Axis; W],
    /// Where each axis's position units count from, m.
    pub origin: [f64; W],
    /// Each axis's quanta (its acceleration limit with the cycle `h`), computed once at
    /// [`Group::reset`]: each is a double divide, about 30 Cortex-M7 cycles with the FPU
    /// blocked, which every cycle used to repeat.
    quanta: [Quanta; W],
    /// Each axis's range in position units from its origin.
    pub bounds: [(i64, i64); W],
    /// The last `R` cycles' steps.
    ring: Ring<W, R>,
    sums: Sums<W>,
    taps: Taps,
    /// `δa_i / norm`: a running sum's output in m/s².
    scale: [f64; W],
    /// The path on the current cycle.
    pieces: [Piece; W],
    /// Cycles in a row with every step zero, this one included.
    quiet: usize,
    /// Quiet cycles after which a group at zero speed is exactly at rest: the numerator's
    /// longest delay and one.
    window: usize,
    /// `ω_g h` of the virtual pendulum, if the group has one.
    omega_h: Option<f64>,
    /// Whether the current cycle's path is constant.
    at_rest: bool,
    /// Per axis: its piece is its rest position alone, as [`Piece::settle`] leaves it
    /// (every coefficient but the first +0.0, the filter states zero), and nothing was
    /// added to it since ([`Group::pieces_mut`] clears it). Such a piece is neither built
    /// nor evaluated term by term ([`Piece::eval_constant`]): an axis of a moving group
    /// that stands still (the 3D crane's trolley while the bridge travels) cost its
    /// spline, its build and thirty multiply-adds an evaluation, every cycle, for zeros.
    constant: [bool; W],
}

impl<const W: usize, const R: usize> Group<W, R> {
    /// A group that never moved and has no filter yet (every setting zero): the storage a
    /// generator is parked in until [`Group::reset`] starts it. Its cycles keep it at
    /// rest at 0. Always inlined, so that it is written straight into its destination
    /// (a call would build it in its own frame first).
    #[must_use]
    #[inline(always)]
    pub fn parked() -> Self {
        Self {
            axes: [Axis::REST; W],
            origin: [0.0; W],
            quanta: [Quanta {
                acceleration: 0.0,
                velocity: 0.0,
                position: 0.0,
            }; W],
            bounds: [(0, 0); W],
            ring: Ring::new(),
            sums: Sums::REST,
            taps: Taps::new(&[]),
            scale: [0.0; W],
            pieces: [Piece::rest(0.0); W],
            quiet: usize::MAX,
            window: 0,
            omega_h: None,
            at_rest: true,
            constant: [true; W],
        }
    }

    /// At rest at `origin` with these acceleration limits (cycle `h`), bounds and filter,
    /// in place: every field written, the ring forgotten rather than rebuilt, so that no
    /// second group (its ring is most of a generator's size) is ever on the stack. Inlined
    /// into its one caller, `Generator::reset` (flash: one function less per group).
    #[inline(always)]
    pub fn reset(
        &mut self,
        origin: [f64; W],
        accelerations: [f64; W],
        h: f64,
        bounds: [(i64, i64); W],
        taps: Taps,
        omega_h: Option<f64>,
    ) {
        self.axes = [Axis::REST; W];
        self.origin = origin;
        self.quanta = accelerations.map(|a| Quanta::new(a, h));
        self.bounds = bounds;
        self.pieces = origin.map(Piece::rest);
        self.constant = [true; W];
        self.quiet = usize::MAX;
        self.at_rest = true;
        // Forgets the ring and clears the sums.
        self.set_filter(taps, omega_h);
    }

    /// A new filter (only at rest: the history is then all zero); forgets the ring, whose
    /// older cycles the new taps may reach.
    pub fn set_filter(&mut self, taps: Taps, omega_h: Option<f64>) {
        self.taps = taps;
        self.omega_h = omega_h;
        self.window = taps.longest() + 1;
        let norm = u64_to_f64(taps.norm());
        let quanta = self.quanta();
        for (s, q) in self.scale.iter_mut().zip(quanta) {
            *s = q.acceleration / norm;
        }
        self.forget();
    }

    /// Forgets the ring and clears the running sums: the filter's history at rest, as
    /// [`Group::set_filter`] leaves it (a start with a filter installed while the group
    /// rested begins from the same state as one that installs it).
    pub fn forget(&mut self) {
        self.ring.forget();
        self.sums = Sums::REST;
    }

    /// The filter's numerator.
    #[must_use]
    pub fn taps(&self) -> &Taps {
        &self.taps
    }

    /// Each axis's quanta.
    #[must_use]
    pub fn quanta(&self) -> [Quanta; W] {
        self.quanta
    }

    /// The path on the current cycle, per axis.
    #[must_use]
    pub fn pieces(&self) -> &[Piece; W] {
        &self.pieces
    }

    /// The pieces to write to (a hand-over's path, its blend): none counts as constant
    /// until a cycle settles it again.
    pub fn pieces_mut(&mut self) -> &mut [Piece; W] {
        self.constant = [false; W];
        &mut self.pieces
    }

    /// Per axis, whether its piece is its rest position alone (see the field).
    #[must_use]
    pub fn constant(&self) -> [bool; W] {
        self.constant
    }

    /// Whether the current cycle's path is constant (exactly: every derivative 0.0).
    #[must_use]
    pub fn is_at_rest(&self) -> bool {
        self.at_rest
    }

    /// Each axis's rate-limiter speed, m/s.
    #[must_use]
    pub fn speeds(&self) -> [f64; W] {
        let mut out = [0.0; W];
        for (o, (a, q)) in out.iter_mut().zip(self.axes.iter().zip(self.quanta())) {
            *o = i64_to_f64(a.n_v) * q.velocity;
        }
        out
    }

    /// One cycle from the states at its start: the limiter towards `targets` (velocity
    /// quanta) within `bounds`, the filter, the pieces. `h`, `inv_h`: the cycle.
    pub fn cycle(&mut self, targets: [f64; W], bounds: [(i64, i64); W], h: f64, inv_h: f64) {
        if self.at_rest && targets.iter().all(|t| *t == 0.0) {
            // Nothing moves: the steps would be zero, the ring's window is zero already
            // and the running sums stay zero; the pieces are the rest positions again (a
            // hand-over's blend may have been added to the last ones).
            self.quiet = self.quiet.saturating_add(1);
            for (((piece, constant), o), (a, q)) in self
                .pieces
                .iter_mut()
                .zip(self.constant.iter_mut())
                .zip(self.origin)
                .zip(self.axes.iter().zip(self.quanta))
            {
                settle(piece, constant, o + i64_to_f64(a.n_p) * q.position);
            }
            return;
        }
        let quanta = self.quanta();
        let mut p0 = self.origin;
        let mut v0 = [0.0; W];
        for ((p, v), (a, q)) in p0
            .iter_mut()
            .zip(v0.iter_mut())
            .zip(self.axes.iter().zip(quanta))
        {
            *p += i64_to_f64(a.n_p) * q.position;
            *v = i64_to_f64(a.n_v) * q.velocity;
        }
        let resting = self.axes.iter().all(|a| a.n_v == 0);
        let k = limiter::step(&mut self.axes, targets, bounds);
        self.ring.push(k);
        // The filter output's backward differences: the B-spline on this cycle.
        let nabla = self.sums.advance(&self.ring, &self.taps);
        self.quiet = if k.iter().all(|k| *k == 0) {
            self.quiet.saturating_add(1)
        } else {
            0
        };
        self.at_rest = resting && self.quiet >= self.window;
        let q = self.taps.windows();
        for (i, (piece, constant)) in self
            .pieces
            .iter_mut()
            .zip(self.constant.iter_mut())
            .enumerate()
        {
            let (Some(p), Some(v), Some(ki), Some(n), Some(qa), Some(scale), Some(axis)) = (
                p0.get(i),
                v0.get(i),
                k.get(i),
                nabla.get(i),
                quanta.get(i),
                self.scale.get(i),
                self.axes.get(i),
            ) else {
                continue;
            };
            // An axis that stood still and still does while the group moves: no step, no
            // speed, the filter's output and its differences zero, the piece settled (its
            // states zero). Its build would make the same path (`Piece::build` of zero
            // inputs: the rest position, the other coefficients and states ±0.0, which the
            // evaluation's sums turn into +0.0 again).
            let idle = *constant && *ki == 0 && axis.n_v == 0 && n.iter().all(|n| *n == 0);
            if self.at_rest || idle {
                settle(piece, constant, *p);
            } else {
                *constant = false;
                piece.build(&Inputs {
                    p0: *p,
                    v0: *v,
                    a0: f64::from(*ki) * qa.acceleration,
                    rho: spline(n, q, *scale),
                    h,
                    inv_h,
                    omega_h: self.omega_h,
                });
            }
        }
    }
}

/// The piece at rest at `position`, `constant` then: only the position written when it was
/// constant already (the rest of it is zero), no longer the whole piece cleared every
/// cycle a group rests (`__aeabi_memclr8`).
fn settle(piece: &mut Piece, constant: &mut bool, position: f64) {
    if let (true, Some(c0)) = (*constant, piece.coeffs.first_mut()) {
        *c0 = position;
    } else {
        piece.settle(position);
        *constant = true;
    }
}
