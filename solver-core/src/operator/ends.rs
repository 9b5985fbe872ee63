//! A cycle of one axis's path kept as what builds it, and its end worked out directly.
//!
//! The path on a cycle is a polynomial in θ ([`Polynomial`], degree 11 with the virtual
//! pendulum), but the scheme the manual scenes run, BDF, evaluates it once a cycle, at
//! the cycle's end `t_{n+1}` (θ = 1 up to the last bits of the times), for the path, its
//! speed and its acceleration. All of these follow from the filter states at the end,
//! which are linear in the states at the start and in the filter output's backward
//! differences `∇^j S[n]` with coefficients fixed by `h` (the lag `d`) and by `ω_g h`
//! (the swing `e`):
//!
//! ```text
//! d(1) = d + ḋh − a₀h²/2 + Σ_m f_m            ḋ(1)h = ḋh − a₀h² + Σ_m (m+2) f_m
//! e(1) = Σ_j ε_j                               ė(1)h = Σ_j j ε_j
//! x(1) = p₀(1) + d(1) + e(1)    ẋ(1) = ṗ₀(1) + ḋ(1) + ė(1)    ẍ(1) = −ω_g² e(1)
//! ```
//!
//! (`f_m = h² ρ_m/((m+1)(m+2))`, `ρ = scale · D ∇S` the filtered acceleration's
//! coefficients, `ε_j` the pendulum's Taylor coefficients of [`Polynomial::build`]; for
//! the hoist `e = 0` and `z̈(1) = r̈(1) = Σ_m ρ_m`.) So a cycle keeps the states at its
//! start and end and the differences ([`Piece`]), works the end out from maps folded
//! once (the lag's at compile time, [`SwingMap`] when the filter is tuned), and builds
//! the polynomial only when something asks inside the cycle (Radau IIA's stage times, a
//! hand-over at an arbitrary instant) or for more than three derivatives. The end is the
//! polynomial at θ = 1 to rounding (the same quantities by other operations: they agree
//! to about 10⁻¹⁴ relative, `tests`); an evaluation within [`END_WINDOW`] of the end is
//! continued from it to first order.
//!
//! Why: the polynomial's build and its evaluation were most of the generator's cost
//! (`cargo xtask cycles`: over the 3D manual run's steps in which all three axes move,
//! 925 + 530 + 514 of 3,450 point cycles for the builds, the evaluation and the
//! splines), and BDF read three numbers of its twelve coefficients per axis.

use crate::operator::piece::{Inputs, Polynomial, DIFFERENCES2, DIFFERENCES4, INV_PAIR};

/// How far (in θ) from the cycle's end an evaluation is continued from the end states:
/// `2⁻²⁰`, about 10⁻⁶. The scheme's `t_{n+1}` differs from the generator's cycle end by
/// the times' rounding: after a day (t ≈ 86,400 s, its last bit 1.5·10⁻¹¹ s) θ − 1 is
/// about 10⁻⁹ with h = 10 ms, and the window holds for about 2²⁵ s (a year) of time
/// since the scheme's start. The first-order continuation leaves `(δh)²/2 · |x^{(k+2)}|`
/// ≤ 5·10⁻¹⁷ `|x^{(k+2)}|` (h = 10 ms), below the time argument's own resolution.
pub const END_WINDOW: f64 = 1.0 / 1_048_576.0;

/// `d, ḋ` and `e, ė` at an instant (m, m/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct States {
    /// `d = r − p₀` and `ḋ`.
    pub lag: [f64; 2],
    /// `e = x_L − r` and `ė` (zero for the hoist).
    pub swing: [f64; 2],
}

impl States {
    /// Every state zero: at rest.
    pub const REST: Self = Self {
        lag: [0.0; 2],
        swing: [0.0; 2],
    };
}

/// One axis's path on the current cycle, as what builds it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    /// The filter states at the cycle's start.
    pub start: States,
    /// At its end: the next cycle's start.
    pub end: States,
    /// The filter output's backward differences `∇^j S[n]` on this cycle (exact
    /// integers as f64; only the first `q + 1` used).
    pub nabla: [f64; 5],
}

impl Piece {
    /// At rest: every state and difference zero.
    pub const REST: Self = Self {
        start: States::REST,
        end: States::REST,
        nabla: [0.0; 5],
    };
}

/// The lag's end from the differences, per degree `q` of the spline (compile time):
/// rows `Σ_m c_m D[m][i]` for `c_m` = `1/((m+1)(m+2))` (the position's `Σ f_m/(s h²)`),
/// `1/(m+1)` (the rate's `Σ (m+2) f_m/(s h²)`), `1` (`r̈(1)/s`), `m` (`r⃛(1) h/s`).
#[derive(Debug, Clone, Copy)]
struct LagTables {
    position: [f64; 5],
    rate: [f64; 5],
    acceleration: [f64; 5],
    jerk: [f64; 5],
}

#[allow(clippy::indexing_slicing)] // evaluated at compile time: an index out of range fails the build
const fn lag_tables(d: &[[f64; 5]; 5]) -> LagTables {
    let mut t = LagTables {
        position: [0.0; 5],
        rate: [0.0; 5],
        acceleration: [0.0; 5],
        jerk: [0.0; 5],
    };
    let mut i = 0;
    while i < 5 {
        let mut m = 0;
        while m < 5 {
            t.position[i] += INV_PAIR[m] * d[m][i];
            t.rate[i] += d[m][i] / (m + 1) as f64;
            t.acceleration[i] += d[m][i];
            t.jerk[i] += m as f64 * d[m][i];
            m += 1;
        }
        i += 1;
    }
    t
}

const LAG2: LagTables = lag_tables(&DIFFERENCES2);
const LAG4: LagTables = lag_tables(&DIFFERENCES4);

/// The swing's end `[e(1), ė(1)h]` as a linear map of `e`, `ėh` and the differences
/// (times `scale h²`), for one `ω_g h`: the pendulum's recursion of
/// [`Polynomial::build`] run once per input with that input one, the rest zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwingMap {
    /// `ω_g h`, for a polynomial built inside the cycle.
    pub omega_h: f64,
    /// `ω_g²`, 1/s²: the load's acceleration is `−ω_g² e`.
    pub omega2: f64,
    /// `[e(1), ė(1)h]` per unit `e`.
    from_e: [f64; 2],
    /// Per unit `ė h`.
    from_rate: [f64; 2],
    /// Per unit `∇^i S` times `scale h²`, `i = 0..=2` (the horizontal filter's quadratic
    /// spline).
    from_nabla: [[f64; 3]; 2],
}

/// `Σ_j ε_j` and `Σ_j j ε_j` over the recursion `ε_{j+2} = k_j ε_j` (`j + 2 ≤ 11`) from
/// `ε_first = value`, the other terms zero.
fn chain(first: usize, value: f64, w: f64) -> [f64; 2] {
    let (mut sum, mut rate, mut eps) = (0.0, 0.0, value);
    let mut j = first;
    while j < INV_PAIR.len() {
        sum += eps;
        rate += j as f64 * eps;
        eps *= w * INV_PAIR.get(j).copied().unwrap_or(0.0);
        j += 2;
    }
    [sum, rate]
}

impl SwingMap {
    /// No pendulum (a group that has never been tuned): every end zero.
    pub const NONE: Self = Self {
        omega_h: 0.0,
        omega2: 0.0,
        from_e: [0.0; 2],
        from_rate: [0.0; 2],
        from_nabla: [[0.0; 3]; 2],
    };

    /// The map for `ω_g h` with the cycle `h`: worked out when the horizontal filter is
    /// installed (about 150 floating-point operations): while the horizontal axes rest,
    /// at the staging; in a start's own cycle when the start works the filter out (during
    /// a hand-over's blend, or with the robust pair after the rope changed).
    #[must_use]
    pub fn new(omega_h: f64, h: f64) -> Self {
        let w = -omega_h * omega_h;
        // f_m enters as ε_{m+2} −= f_m.
        let forced: [[f64; 2]; 3] = core::array::from_fn(|m| chain(m + 2, -1.0, w));
        let mut from_nabla = [[0.0; 3]; 2];
        for (out, k) in from_nabla.iter_mut().zip(0..2) {
            for (o, i) in out.iter_mut().zip(0..3) {
                let mut acc = 0.0;
                for (m, f) in forced.iter().enumerate() {
                    let d = DIFFERENCES2
                        .get(m)
                        .and_then(|row| row.get(i))
                        .copied()
                        .unwrap_or(0.0);
                    acc += f.get(k).copied().unwrap_or(0.0)
                        * INV_PAIR.get(m).copied().unwrap_or(0.0)
                        * d;
                }
                *o = acc;
            }
        }
        Self {
            omega_h,
            omega2: omega_h * omega_h / (h * h),
            from_e: chain(0, 1.0, w),
            from_rate: chain(1, 1.0, w),
            from_nabla,
        }
    }
}

/// `Σ_i table[i] v[i]` over the first `N`, as a tree of two halves.
#[allow(clippy::indexing_slicing)] // N ≤ 5: constant indices, checked when compiled
fn dot<const N: usize>(table: &[f64; 5], v: &[f64; 5]) -> f64 {
    if N == 3 {
        (table[0] * v[0] + table[1] * v[1]) + table[2] * v[2]
    } else {
        ((table[0] * v[0] + table[1] * v[1]) + (table[2] * v[2] + table[3] * v[3]))
            + table[4] * v[4]
    }
}

/// What a cycle's end is worked out from besides the piece.
#[derive(Debug, Clone, Copy)]
pub struct EndInputs {
    /// The rate limiter's acceleration on the cycle, m/s².
    pub a0: f64,
    /// `scale h²`: the differences to the integrated spline's m.
    pub scale_h2: f64,
    /// The cycle, s.
    pub h: f64,
    /// `1/h`.
    pub inv_h: f64,
}

impl Piece {
    /// Moves on to the next cycle with the differences `nabla` (`q + 1 = N` of them: 3
    /// with the pendulum `swing`, 5 for the hoist): the old end is the new start, the
    /// new end is worked out.
    #[allow(clippy::indexing_slicing)] // constant indices below 5
    pub fn advance<const N: usize>(
        &mut self,
        nabla: [f64; 5],
        c: &EndInputs,
        swing: Option<&SwingMap>,
    ) {
        self.start = self.end;
        self.nabla = nabla;
        let lag = if N == 3 { &LAG2 } else { &LAG4 };
        let [d, d_dot] = self.start.lag;
        let d_step = d_dot * c.h;
        let curvature = -c.h * c.h * c.a0 * 0.5;
        let position = c.scale_h2 * dot::<N>(&lag.position, &nabla);
        let rate = c.scale_h2 * dot::<N>(&lag.rate, &nabla);
        let next_d = ((d + d_step) + curvature) + position;
        let next_rate = (d_step + 2.0 * curvature) + rate;
        self.end.lag = [next_d, next_rate * c.inv_h];
        self.end.swing = match swing {
            Some(map) => {
                let [e, e_dot] = self.start.swing;
                let e_step = e_dot * c.h;
                let mut out = [0.0; 2];
                for (o, ((a, b), n)) in out.iter_mut().zip(
                    map.from_e
                        .iter()
                        .zip(map.from_rate.iter())
                        .zip(map.from_nabla.iter()),
                ) {
                    let forced = (n[0] * nabla[0] + n[1] * nabla[1]) + n[2] * nabla[2];
                    *o = (a * e + b * e_step) + c.scale_h2 * forced;
                }
                [out[0], out[1] * c.inv_h]
            }
            None => [0.0; 2],
        };
    }

    /// The path, its speed and its acceleration (the first `D ≤ 3`) at `θ = 1 + δ`,
    /// `|δ| ≤` [`END_WINDOW`], from the end states: `p`, `v` the rate limiter's position
    /// and speed at the end, `scale` the differences' m/s².
    #[must_use]
    pub fn at_end<const D: usize>(
        &self,
        (p, v): (f64, f64),
        delta_t: f64,
        scale: f64,
        inv_h: f64,
        swing: Option<&SwingMap>,
    ) -> [f64; D] {
        let [d, d_dot] = self.end.lag;
        let [e, e_dot] = self.end.swing;
        let (x, speed) = ((p + d) + e, (v + d_dot) + e_dot);
        let (acceleration, jerk) = match swing {
            Some(map) => (-map.omega2 * e, -map.omega2 * e_dot),
            None => (
                scale * dot::<5>(&LAG4.acceleration, &self.nabla),
                scale * inv_h * dot::<5>(&LAG4.jerk, &self.nabla),
            ),
        };
        let values = [
            x + delta_t * speed,
            speed + delta_t * acceleration,
            acceleration + delta_t * jerk,
        ];
        let mut out = [0.0; D];
        for (o, value) in out.iter_mut().zip(values) {
            *o = value;
        }
        out
    }

    /// The polynomial of this cycle (for an evaluation inside it): built from the start
    /// states as [`Polynomial::build`] builds it, from the rate limiter at the cycle's
    /// start and this cycle's spline in `inputs`.
    #[must_use]
    pub fn polynomial(&self, inputs: &Inputs) -> Polynomial {
        let mut p = Polynomial::rest(0.0);
        p.lag = self.start.lag;
        p.swing = self.start.swing;
        p.build(inputs);
        p
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing, clippy::unwrap_used)]
    use super::*;

    /// A pseudo-random sequence in `[−1, 1)`.
    fn sequence(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            ((seed >> 11) as f64 / (1_u64 << 53) as f64 - 0.5) * 2.0
        }
    }

    /// `|a − b| ≤ tol (1 + |b|)` for every entry.
    fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
        a.iter()
            .zip(b)
            .all(|(a, b)| (a - b).abs() <= tol * (1.0 + b.abs()))
    }

    /// The end worked out from the maps is the polynomial's: its end states, and the path,
    /// speed and acceleration at θ = 1, to rounding — with the pendulum (`ω_g h` across
    /// its range) and without (the hoist's quartic spline), over random states, steps
    /// and differences. Near the end (θ = 1 ± 10⁻⁷, inside [`END_WINDOW`]) the continued
    /// end is the polynomial there.
    #[test]
    fn the_end_is_the_polynomial_at_the_cycle_end() {
        let mut next = sequence(17);
        let h = 0.01;
        for n in 0..4_000 {
            let pendulum = n % 2 == 0;
            let omega_h = 0.002 + 0.098 * next().abs();
            let map = SwingMap::new(omega_h, h);
            let swing = pendulum.then_some(&map);
            let start = States {
                lag: [next() * 0.8, next() * 0.5],
                swing: if pendulum {
                    [next() * 0.2, next() * 0.3]
                } else {
                    [0.0; 2]
                },
            };
            let count = if pendulum { 3 } else { 5 };
            let mut nabla = [0.0; 5];
            for (i, d) in nabla.iter_mut().enumerate().take(count) {
                *d = libm::round(next() * 1e5 / (1 + 10 * i) as f64);
            }
            let scale = 1e-5 * (1.0 + next().abs());
            let (p0, v0, a0) = (10.0 * next(), next(), 0.5 * next());
            let mut piece = Piece {
                end: start,
                ..Piece::REST
            };
            let inputs = EndInputs {
                a0,
                scale_h2: scale * h * h,
                h,
                inv_h: 1.0 / h,
            };
            if pendulum {
                piece.advance::<3>(nabla, &inputs, swing);
            } else {
                piece.advance::<5>(nabla, &inputs, swing);
            }
            assert_eq!(piece.start, start);
            let polynomial = piece.polynomial(&Inputs {
                p0,
                v0,
                a0,
                rho: crate::operator::piece::spline(&nabla, count - 1, scale),
                h,
                inv_h: 1.0 / h,
                omega_h: swing.map(|m| m.omega_h),
            });
            let ends = [piece.end.lag, piece.end.swing].concat();
            let built = [polynomial.lag, polynomial.swing].concat();
            assert!(close(&ends, &built, 1e-13), "{n}: {ends:?} vs {built:?}");
            let limiter_end = (p0 + v0 * h + 0.5 * a0 * h * h, v0 + a0 * h);
            for delta in [0.0, 1e-7, -1e-7] {
                let fast: [f64; 3] = piece.at_end(limiter_end, delta * h, scale, 1.0 / h, swing);
                let slow: [f64; 3] = polynomial.eval(1.0 + delta, 1.0 / h);
                assert!(
                    close(&fast, &slow, 1e-12),
                    "{n} δ {delta}: {fast:?} vs {slow:?}"
                );
            }
        }
    }

    /// Without a pendulum (`ω_g h` = 0) the swing drifts at its rate: `e(1) = e + ė h`,
    /// `ė(1) = ė`.
    #[test]
    fn without_a_pendulum_the_swing_drifts_at_its_rate() {
        let map = SwingMap::new(0.0, 0.01);
        assert_eq!(map.from_e, [1.0, 0.0]);
        assert_eq!(map.from_rate, [1.0, 1.0]);
        assert_eq!(map.omega2, 0.0);
    }
}
