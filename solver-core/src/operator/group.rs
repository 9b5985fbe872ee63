//! A group of axes that share one filter: the horizontal axes (one rate limiter for the
//! vector, one ring, the virtual pendulum) or the hoist (its own limiter and windows).
//! Each cycle: the limiter's steps, the discrete filter, one piece per axis.

use crate::operator::ends::{EndInputs, Piece, SwingMap, END_WINDOW};
use crate::operator::filter::{i64_to_f64, u64_to_f64, Ring, Sums, Taps};
use crate::operator::limiter::{self, Axis};
use crate::operator::piece::{differences, spline, Inputs, Polynomial, HOIST_COEFFS};
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
    /// Whether the current cycle's path is constant.
    at_rest: bool,
    /// Per axis: its piece is its rest position alone (the filter states and differences
    /// zero, [`Piece::REST`]). Such a piece is neither worked out nor evaluated term by
    /// term ([`Polynomial::eval_constant`]): an axis of a moving group that stands still
    /// (the 3D crane's trolley while the bridge travels) cost its spline, its build and
    /// thirty multiply-adds an evaluation, every cycle, for zeros.
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
            pieces: [Piece::REST; W],
            quiet: usize::MAX,
            window: 0,
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
    ) {
        self.axes = [Axis::REST; W];
        self.origin = origin;
        self.quanta = accelerations.map(|a| Quanta::new(a, h));
        self.bounds = bounds;
        self.pieces = [Piece::REST; W];
        self.constant = [true; W];
        self.quiet = usize::MAX;
        self.at_rest = true;
        // Forgets the ring and clears the sums.
        self.set_filter(taps);
    }

    /// A new filter (only at rest: the history is then all zero); forgets the ring, whose
    /// older cycles the new taps may reach.
    pub fn set_filter(&mut self, taps: Taps) {
        self.taps = taps;
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
    /// quanta) within `bounds`, the filter, the pieces' ends. `h`, `inv_h`: the cycle;
    /// `swing`: the virtual pendulum's map, if the group has one.
    pub fn cycle(
        &mut self,
        targets: [f64; W],
        bounds: [(i64, i64); W],
        h: f64,
        inv_h: f64,
        swing: Option<&SwingMap>,
    ) {
        if self.at_rest && targets.iter().all(|t| *t == 0.0) {
            // Nothing moves: the steps would be zero, the ring's window is zero already
            // and the running sums stay zero; the pieces are the rest positions again.
            self.quiet = self.quiet.saturating_add(1);
            for (piece, constant) in self.pieces.iter_mut().zip(self.constant.iter_mut()) {
                settle(piece, constant);
            }
            return;
        }
        let quanta = self.quanta();
        let resting = self.axes.iter().all(|a| a.n_v == 0);
        let k = limiter::step(&mut self.axes, targets, bounds);
        let still = self.axes.map(|a| a.n_v == 0);
        self.ring.push(k);
        // The filter output's backward differences: the B-spline on this cycle.
        let nabla = self.sums.advance(&self.ring, &self.taps);
        self.quiet = if k.iter().all(|k| *k == 0) {
            self.quiet.saturating_add(1)
        } else {
            0
        };
        self.at_rest = resting && self.quiet >= self.window;
        let h2 = h * h;
        for (i, (piece, constant)) in self
            .pieces
            .iter_mut()
            .zip(self.constant.iter_mut())
            .enumerate()
        {
            let (Some(ki), Some(n), Some(qa), Some(scale), Some(still)) = (
                k.get(i),
                nabla.get(i),
                quanta.get(i),
                self.scale.get(i),
                still.get(i),
            ) else {
                continue;
            };
            // An axis that stood still and still does while the group moves: no step, no
            // speed, the filter's output and its differences zero, the piece settled (its
            // states zero). Worked out, its end would be the same zeros.
            let idle = *constant && *ki == 0 && *still && n.iter().all(|n| *n == 0);
            if self.at_rest || idle {
                settle(piece, constant);
            } else {
                *constant = false;
                let cycle = EndInputs {
                    a0: f64::from(*ki) * qa.acceleration,
                    scale_h2: scale * h2,
                    h,
                    inv_h,
                };
                if swing.is_some() {
                    piece.advance::<3>(differences(n), &cycle, swing);
                } else {
                    piece.advance::<5>(differences(n), &cycle, None);
                }
            }
        }
    }

    /// Axis `i`'s rate-limiter position (m) and speed (m/s) at the current cycle's end.
    fn limiter_end(&self, i: usize) -> (f64, f64) {
        match (self.axes.get(i), self.quanta.get(i), self.origin.get(i)) {
            (Some(a), Some(q), Some(o)) => (
                o + i64_to_f64(a.n_p) * q.position,
                i64_to_f64(a.n_v) * q.velocity,
            ),
            _ => (0.0, 0.0),
        }
    }

    /// Axis `i`'s rate limiter at the current cycle's start, what it stepped from (the
    /// ring's newest step `k` undone: `n_v − k`, `n_p − 2(n_v − k) − k`): position (m),
    /// speed (m/s) and the cycle's acceleration (m/s²).
    fn limiter_start(&self, i: usize) -> (f64, f64, f64) {
        let k = i64::from(self.ring.get(0).get(i).copied().unwrap_or(0));
        match (self.axes.get(i), self.quanta.get(i), self.origin.get(i)) {
            (Some(a), Some(q), Some(o)) => {
                let n_v = a.n_v - k;
                let n_p = a.n_p - 2 * n_v - k;
                (
                    o + i64_to_f64(n_p) * q.position,
                    i64_to_f64(n_v) * q.velocity,
                    i64_to_f64(k) * q.acceleration,
                )
            }
            _ => (0.0, 0.0, 0.0),
        }
    }

    /// Axis `i`'s path at the current cycle's start, m (the hoist's: the rope then).
    #[must_use]
    pub fn start_position(&self, i: usize) -> f64 {
        match (self.pieces.get(i), self.constant.get(i)) {
            (Some(piece), Some(false)) => {
                let (p0, _, _) = self.limiter_start(i);
                (p0 + piece.start.lag[0]) + piece.start.swing[0]
            }
            _ => self.limiter_end(i).0,
        }
    }

    /// Axis `i`'s path and its first `D − 1` derivatives at `θ`: from the end states at
    /// the cycle's end (`D ≤ 3`, `|θ − 1| ≤` [`END_WINDOW`]), else from the cycle's
    /// polynomial; the rest position itself for a piece at rest.
    #[must_use]
    pub fn eval<const D: usize>(
        &self,
        i: usize,
        theta: f64,
        h: f64,
        inv_h: f64,
        swing: Option<&SwingMap>,
    ) -> [f64; D] {
        let (Some(piece), Some(constant)) = (self.pieces.get(i), self.constant.get(i)) else {
            return [0.0; D];
        };
        if *constant {
            return Polynomial::rest(self.limiter_end(i).0).eval_constant(theta);
        }
        let delta = theta - 1.0;
        if D <= 3 && libm::fabs(delta) <= END_WINDOW {
            let scale = self.scale.get(i).copied().unwrap_or(0.0);
            return piece.at_end(self.limiter_end(i), delta * h, scale, inv_h, swing);
        }
        self.inside(i, theta, h, inv_h, swing)
    }

    /// [`Group::eval`] from the cycle's polynomial, built for the call. Never inlined: the
    /// polynomial and its build's temporaries are its own frame's, not carried by the
    /// evaluation at the cycle's end (BDF's, every step) for each axis.
    #[inline(never)]
    fn inside<const D: usize>(
        &self,
        i: usize,
        theta: f64,
        h: f64,
        inv_h: f64,
        swing: Option<&SwingMap>,
    ) -> [f64; D] {
        let Some(piece) = self.pieces.get(i) else {
            return [0.0; D];
        };
        let (p0, v0, a0) = self.limiter_start(i);
        let scale = self.scale.get(i).copied().unwrap_or(0.0);
        let p = piece.polynomial(&Inputs {
            p0,
            v0,
            a0,
            rho: spline(&piece.nabla, self.taps.windows(), scale),
            h,
            inv_h,
            omega_h: swing.map(|m| m.omega_h),
        });
        if swing.is_some() {
            p.eval(theta, inv_h)
        } else {
            p.eval_below::<D, HOIST_COEFFS>(theta, inv_h)
        }
    }
}

/// The piece at rest, `constant` then: nothing written when it was constant already (no
/// longer the whole piece cleared every cycle a group rests, `__aeabi_memclr8`).
fn settle(piece: &mut Piece, constant: &mut bool) {
    if !*constant {
        *piece = Piece::REST;
        *constant = true;
    }
}
