//! A robust pair that follows the rope, evaluated on the host before anyone builds it
//! into the generator (docs/OPERATOR.md, "The robust setting and what it costs").
//!
//! The generator's robust setting adds a zero-vibration pair `½(δ₀ + δ_{T_r/2})` tuned to
//! the load's depth when the horizontal motion starts; with the hoist moving during the
//! travel the pendulum's period moves away from it and the pair cancels little of a
//! ±10 % length error. The design studied here delays the *finished* plain path by half
//! the model's pendulum period at the load's depth *now*:
//!
//! ```text
//! x_r(t) = ½ (x_L(t) + x_L(t − D(t))),   D(t) = ½ (D₁(t) + D₁(t − D₁(t))),   D₁ = π √(z_C/g)
//! ```
//!
//! `x_L` the plain generator's load path, `z_C` its depth, `D` the mean of the half
//! periods at both ends of the delay ([`DelayRule::MeanOfBothEnds`]; the half period now
//! alone, [`DelayRule::HalfPeriodNow`], is the simpler rule). With `D` constant this is the
//! robust path the generator has (its filters are linear and time-invariant, so they
//! commute); it is as smooth as `D` is (`z_C` is C⁵) and rests exactly once `x_L` has
//! rested `D` earlier, where `x_L` does — no drift of the rest. The hoist's path is the
//! plain generator's.
//!
//! [`RopePair`] is that path as a [`Trajectory`]: it keeps a copy of the plain generator
//! per cycle (a prototype's liberty: about 3 KB a cycle) and evaluates `x_L(t − D(t))`
//! with its derivatives to the fifth by composing truncated Taylor series ([`Jet`]), so
//! that the exact flat inverse (`reference::flat_crane`, `flat_crane3d`) gives the drives'
//! set points. `cargo run --release -p host-tests --bin rope_pair_study` runs the open-loop
//! study's profiles with the hoist moving on it.

use nalgebra::SVector;
use solver_core::trajectory::Trajectory;

use crate::operator::{Crane, Gen};

/// Derivatives kept: 0..=5, what the flat inverse reads.
const ORDERS: usize = 6;

/// A truncated Taylor series about a point: `c[k] = f⁽ᵏ⁾/k!`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jet(pub [f64; ORDERS]);

/// `k!` for `k < ORDERS`.
const FACTORIAL: [f64; ORDERS] = [1.0, 1.0, 2.0, 6.0, 24.0, 120.0];

impl Jet {
    /// From the derivatives `f, f', f'', …`.
    #[must_use]
    pub fn from_derivatives(d: [f64; ORDERS]) -> Self {
        Self(core::array::from_fn(|k| d[k] / FACTORIAL[k]))
    }

    /// The derivatives `f, f', f'', …`.
    #[must_use]
    pub fn derivatives(&self) -> [f64; ORDERS] {
        core::array::from_fn(|k| self.0[k] * FACTORIAL[k])
    }

    /// The product, truncated.
    #[must_use]
    pub fn times(&self, o: &Self) -> Self {
        let mut c = [0.0; ORDERS];
        for (i, a) in self.0.iter().enumerate() {
            for (j, b) in o.0.iter().take(ORDERS - i).enumerate() {
                c[i + j] += a * b;
            }
        }
        Self(c)
    }

    /// `f(self)` for `f` given by its derivatives at `self`'s value: `Σ f⁽ᵏ⁾/k! δᵏ`,
    /// `δ = self − self(0)`.
    #[must_use]
    pub fn compose(&self, f: [f64; ORDERS]) -> Self {
        let mut delta = *self;
        delta.0[0] = 0.0;
        let mut power = Self([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let mut out = [0.0; ORDERS];
        for (k, fk) in f.iter().enumerate() {
            for (o, p) in out.iter_mut().zip(power.0) {
                *o += fk / FACTORIAL[k] * p;
            }
            power = power.times(&delta);
        }
        Self(out)
    }

    /// `√self`: the square root's derivatives at `self(0) > 0`, composed.
    #[must_use]
    pub fn sqrt(&self) -> Self {
        let x = self.0[0];
        // d^k/dx^k √x = √x · Π_{j<k} (½ − j) / x^k.
        let mut f = [0.0; ORDERS];
        let mut factor = x.sqrt();
        for (k, fk) in f.iter_mut().enumerate() {
            *fk = factor;
            factor *= (0.5 - k as f64) / x;
        }
        self.compose(f)
    }
}

/// How the pair's delay follows the rope.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DelayRule {
    /// `D = D₁(t)`: the half period at the load's depth now.
    HalfPeriodNow,
    /// `D = ½ (D₁(t) + D₁(t − D₁(t)))`: the mean of the half periods at both ends of the
    /// delay, so that the pendulum's phase turns by about π over `[t − D, t]` while the
    /// rope changes (to first order in the change).
    MeanOfBothEnds,
}

/// The path with the rope-following pair: the plain generator's copies, one per cycle.
#[derive(Debug, Clone)]
pub struct RopePair {
    /// How the delay follows the rope.
    rule: DelayRule,
    /// The plain generator after each cycle's `advance` (its cycle `[time, time + h]`).
    history: Vec<Gen>,
    /// Gravity, m/s².
    g: f64,
}

impl RopePair {
    /// An empty history for the crane, the delay following the rope by `rule`.
    #[must_use]
    pub fn new(crane: &Crane, rule: DelayRule) -> Self {
        Self {
            rule,
            history: Vec::new(),
            g: crane.g(),
        }
    }

    /// Keeps the plain generator's state after its `advance` of a new cycle.
    pub fn push(&mut self, gen: &Gen) {
        self.history.push(*gen);
    }

    /// The plain path's derivatives 0..=5 at `t`, slots `[x, y, z]`: from the copy whose
    /// cycle holds `t`; before the first cycle the path rests where it started.
    fn plain(&self, t: f64) -> [[f64; 3]; ORDERS] {
        let Some(first) = self.history.first() else {
            return [[0.0; 3]; ORDERS];
        };
        let n = self.history.partition_point(|g| g.time() <= t);
        match n.checked_sub(1).and_then(|k| self.history.get(k)) {
            Some(g) => g.load::<ORDERS>(t),
            None => {
                let mut rest = [[0.0; 3]; ORDERS];
                rest[0] = first.load::<1>(first.time())[0];
                rest
            }
        }
    }

    /// `π √(z_C/g)` at `t` composed with the time jet `at` (`t` itself: `[t, 1, 0, …]`).
    fn half_period(&self, at: &Jet) -> Jet {
        let z = self.plain(at.0[0]);
        let depth = at.compose(core::array::from_fn(|k| z[k][2] / self.g));
        let mut d = depth.sqrt();
        for c in &mut d.0 {
            *c *= core::f64::consts::PI;
        }
        d
    }

    /// The delay `D(t)` as a jet at `t`, as the rule says.
    #[must_use]
    pub fn delay(&self, t: f64) -> Jet {
        let now = self.half_period(&Jet([t, 1.0, 0.0, 0.0, 0.0, 0.0]));
        if self.rule == DelayRule::HalfPeriodNow {
            return now;
        }
        let mut w = Jet(now.0.map(|c| -c));
        w.0[0] += t;
        w.0[1] += 1.0;
        let then = self.half_period(&w);
        Jet(core::array::from_fn(|k| 0.5 * (now.0[k] + then.0[k])))
    }

    /// The path's derivatives 0..=5 at `t`, slots `[x, y, z]`: the horizontal slots
    /// `½(x_L(t) + x_L(t − D(t)))`, the hoist's the plain path's.
    #[must_use]
    pub fn path(&self, t: f64) -> [[f64; 3]; ORDERS] {
        let now = self.plain(t);
        let delay = self.delay(t);
        // w(t) = t − D(t) as a jet.
        let mut w = Jet(delay.0.map(|c| -c));
        w.0[0] += t;
        w.0[1] += 1.0;
        let past = self.plain(w.0[0]);
        let mut out = now;
        for slot in 0..2 {
            let delayed = w
                .compose(core::array::from_fn(|k| past[k][slot]))
                .derivatives();
            for k in 0..ORDERS {
                out[k][slot] = 0.5 * (now[k][slot] + delayed[k]);
            }
        }
        out
    }

    /// Whether the path rests at `t`: every derivative of every slot exactly 0.0.
    #[must_use]
    pub fn is_at_rest(&self, t: f64) -> bool {
        rests(&self.path(t))
    }
}

/// Whether a path's derivatives 0..=5 ([`RopePair::path`]) are those of a rest: every
/// derivative of every slot exactly 0.0.
#[must_use]
pub fn rests(path: &[[f64; 3]; ORDERS]) -> bool {
    path[1..].iter().all(|d| *d == [0.0; 3])
}

impl Trajectory<f64, 2> for RopePair {
    fn derivatives<const D: usize>(&self, t: f64) -> [SVector<f64, 2>; D] {
        let p = self.path(t);
        core::array::from_fn(|k| {
            let v = p.get(k).copied().unwrap_or([0.0; 3]);
            SVector::from([v[0], v[2]])
        })
    }

    fn active_span(&self) -> (f64, f64) {
        (f64::NEG_INFINITY, f64::INFINITY)
    }

    fn smoothness(&self) -> usize {
        5
    }
}

impl Trajectory<f64, 3> for RopePair {
    fn derivatives<const D: usize>(&self, t: f64) -> [SVector<f64, 3>; D] {
        let p = self.path(t);
        core::array::from_fn(|k| SVector::from(p.get(k).copied().unwrap_or([0.0; 3])))
    }

    fn active_span(&self) -> (f64, f64) {
        (f64::NEG_INFINITY, f64::INFINITY)
    }

    fn smoothness(&self) -> usize {
        5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(got: [f64; ORDERS], want: [f64; ORDERS]) {
        for k in 0..ORDERS {
            assert!(
                (got[k] - want[k]).abs() <= 1e-12 * (1.0 + want[k].abs()),
                "order {k}: {got:?} against {want:?}"
            );
        }
    }

    /// Composition against closed forms: `exp(0.3 + 2t)` (derivatives `2ᵏ e^0.3`) and
    /// `w²` with `w = 0.3 + 2t + t²` (the polynomial `0.09 + 1.2 t + 4.6 t² + 4 t³ + t⁴`).
    #[test]
    fn jets_compose_as_the_chain_rule_says() {
        let e = 0.3_f64.exp();
        let line = Jet([0.3, 2.0, 0.0, 0.0, 0.0, 0.0]);
        close(
            line.compose([e; ORDERS]).derivatives(),
            core::array::from_fn(|k| 2.0_f64.powi(k as i32) * e),
        );
        let w = Jet([0.3, 2.0, 1.0, 0.0, 0.0, 0.0]);
        close(
            w.compose([0.09, 0.6, 2.0, 0.0, 0.0, 0.0]).derivatives(),
            [0.09, 1.2, 9.2, 24.0, 24.0, 0.0],
        );
    }

    /// Runs the plain generator and the pair on a stick: full stick on x for `hold` s with
    /// the hoist's lever at `hoist`, released; the pair and the last generator.
    fn pair_run(hoist: f64, hold: usize, rule: DelayRule) -> (RopePair, Gen) {
        let crane = Crane::PLANAR;
        let mut g = crane.start(false, [12.0, 0.0, 6.0]).unwrap();
        let mut pair = RopePair::new(&crane, rule);
        for n in 0..hold + 1500 {
            let s = if n < hold {
                [1.0, 0.0, hoist]
            } else {
                [0.0; 3]
            };
            let _ = g.advance(s);
            pair.push(&g);
        }
        (pair, g)
    }

    /// Hoisting during the travel (raising and lowering, both rules): the pair's path
    /// rests, every derivative exactly 0.0, where the plain path rests — the delay's
    /// changes move no rest.
    #[test]
    fn the_pair_rests_where_the_plain_path_rests_while_hoisting() {
        for rule in [DelayRule::HalfPeriodNow, DelayRule::MeanOfBothEnds] {
            for hoist in [-0.6, 0.6] {
                let (pair, g) = pair_run(hoist, 400, rule);
                let t = g.time();
                assert!(g.is_at_rest() && pair.is_at_rest(t), "{rule:?} {hoist}");
                let (a, b) = (pair.path(t)[0], g.load::<1>(t)[0]);
                assert!(
                    (a[0] - b[0]).abs() < 1e-12 && a[2] == b[2],
                    "{rule:?} {hoist}: {a:?} against {b:?}"
                );
                let d = pair.delay(t).derivatives();
                assert!(d[0] > 1.5 && d[1..].iter().all(|v| *v == 0.0), "{d:?}");
            }
        }
    }

    /// The hoist idle: the pair's path is the generator's robust path but for the robust
    /// pair's delay, which the generator rounds to whole cycles — at most half a cycle
    /// off, so the two paths differ by at most a quarter cycle of the load's speed.
    #[test]
    fn with_the_hoist_idle_the_pair_is_the_robust_path() {
        let crane = Crane::PLANAR;
        let (pair, _) = pair_run(0.0, 400, DelayRule::MeanOfBothEnds);
        let mut robust = crane.start(true, [12.0, 0.0, 6.0]).unwrap();
        let mut worst = 0.0_f64;
        for n in 0..1900 {
            let s = if n < 400 { [1.0, 0.0, 0.0] } else { [0.0; 3] };
            let _ = robust.advance(s);
            let t = robust.time();
            worst = worst.max((pair.path(t)[0][0] - robust.load::<1>(t)[0][0]).abs());
        }
        // 1 m/s at most, h/4 = 2.5 ms.
        assert!(worst <= 0.0025 && worst > 0.0, "{worst}");
    }

    /// The square root: `√(4 + t)`'s derivatives `Π_{j<k}(½ − j) 4^{½−k}`, and a root
    /// squared is the jet again.
    #[test]
    fn a_jet_s_square_root_squares_back() {
        let j = Jet([4.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
        let mut want = [0.0; ORDERS];
        let mut factor = 2.0;
        for (k, w) in want.iter_mut().enumerate() {
            *w = factor;
            factor *= (0.5 - k as f64) / 4.0;
        }
        close(j.sqrt().derivatives(), want);
        let curved = Jet([4.0, 1.0, -0.5, 0.2, 0.1, -0.3]);
        let root = curved.sqrt();
        close(root.times(&root).0, curved.0);
    }
}
