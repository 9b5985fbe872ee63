//! Starting from a moving load: the hand-over from a running automatic move.
//!
//! The generator's path is `K ∗ p₀`; a state it can continue exactly is one it could
//! have reached. The entry takes the one of *steady acceleration*: the rate limiter as
//! if it had accelerated at a constant `ā` (the move's acceleration, within the axis's
//! limit) for longer than the filters remember. Its ring is then full of that
//! acceleration's step, its running sums and B-spline coefficients hold their steady
//! values, and with `τ̄`, `μ₂` the mean and second moment of the kernel from `p₀` to the
//! virtual trolley `r` (the pendulum adds no lag: `ω²/(ω² + s²) = 1 − s²/ω² + …`):
//!
//! ```text
//! p₀(t − s) = p₀ − v₀ s + ā s²/2,   d = r − p₀ = −v₀ τ̄ + ā μ₂/2,   ḋ = −ā τ̄,
//! e = x_L − r = −ā/ω_g²,   ė = 0,    so   x_L = p₀ + d + e,  ẋ_L = v₀ − ā τ̄,  ẍ_L = ā.
//! ```
//!
//! (The hoist the same without `e`.) Given the move's load position, speed and
//! acceleration this fixes `v₀ = ẋ + ā τ̄` and the origin of `p₀`. What the steady
//! state cannot represent — the move's third to fifth derivatives, the acceleration
//! beyond the limit, the quanta's rounding — is added as a blend `E(t)` that starts with
//! exactly those differences in derivatives 0..=5 and ends with all of them zero after
//! [`Settings::entry_blend`]: the two-point Hermite basis of degree 11,
//! `H_j(τ) = τ^j/j! · (1 − τ)⁶ · Σ_{k=0}^{5−j} C(5+k, k) τ^k` (`H_j^{(i)}(0) = δ_ij`,
//! `H_j^{(i)}(1) = 0`, `i ≤ 5`). So the set points stay continuous with their
//! accelerations at the hand-over, and the path is the generator's own once the blend
//! has passed.
//!
//! Refused (the controller then lets the move stop on its path and hands over at rest):
//! a state whose steady past or whose full-deceleration stop leaves an axis's range, or
//! whose rope is longer than the virtual pendulum would be.

use crate::error::{Error, Result};
use crate::operator::limiter::{brake, round_i, MAX_STEP};
use crate::operator::piece::{binomial, factorial, Piece, COEFFS};
use crate::operator::settings::Quanta;
use crate::trajectory::Trajectory;

/// The derivatives that are continued: position to fifth.
pub const ORDERS: usize = 6;

/// A moving load's state: per output its position and first five derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Handover<const NH: usize> {
    /// The horizontal outputs, `[z, ż, z̈, z⃛, z⁗, z⁽⁵⁾]` each.
    pub horizontal: [[f64; ORDERS]; NH],
    /// The load's depth and its derivatives.
    pub hoist: [f64; ORDERS],
}

impl Handover<1> {
    /// The planar path `[x_C, z_C]` at `t`.
    #[must_use]
    pub fn of<Z: Trajectory<f64, 2>>(path: &Z, t: f64) -> Self {
        let d = path.derivatives::<ORDERS>(t).map(<[f64; 2]>::from);
        Self {
            horizontal: [d.map(|[x, _]| x)],
            hoist: d.map(|[_, z]| z),
        }
    }
}

impl Handover<2> {
    /// The 3D path `[x_C, y_C, z_C]` at `t`.
    #[must_use]
    pub fn of<Z: Trajectory<f64, 3>>(path: &Z, t: f64) -> Self {
        let d = path.derivatives::<ORDERS>(t).map(<[f64; 3]>::from);
        Self {
            horizontal: [d.map(|[x, _, _]| x), d.map(|[_, y, _]| y)],
            hoist: d.map(|[_, _, z]| z),
        }
    }
}

/// The blend `E(t)` on the current cycle: per axis its coefficients in
/// `θ = (t − t_n)/h`, moved on by one cycle after each (a Taylor shift by 1 in θ:
/// additions only), for the cycles it has left.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blend<const NH: usize> {
    horizontal: [[f64; COEFFS]; NH],
    hoist: [f64; COEFFS],
    /// Cycles left, this one included.
    left: u64,
}

/// The monomial coefficients of the Hermite basis `H_j(τ)`, `j = 0..=5` (module
/// documentation): `(1 − τ)⁶ Σ_{k ≤ 5−j} C(5+k, k) τ^k`, times `τ^j/j!`.
pub const HERMITE: [[f64; COEFFS]; ORDERS] = hermite();

#[allow(clippy::indexing_slicing)] // evaluated at compile time: an index out of range fails the build
const fn hermite() -> [[f64; COEFFS]; ORDERS] {
    let mut out = [[0.0; COEFFS]; ORDERS];
    let mut j = 0;
    while j < ORDERS {
        let j_factorial = factorial(j);
        let mut k = 0;
        while k < ORDERS - j {
            let ck = binomial(5 + k, k);
            let mut i = 0;
            while i <= 6 {
                let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
                out[j][i + k + j] += ck * sign * binomial(6, i) / j_factorial;
                i += 1;
            }
            k += 1;
        }
        j += 1;
    }
    out
}

/// The blend of one axis as monomial coefficients in τ, from its τ-derivatives `e`.
fn blend_axis(e: &[f64; ORDERS]) -> [f64; COEFFS] {
    let mut out = [0.0; COEFFS];
    for (ej, basis) in e.iter().zip(HERMITE.iter()) {
        for (o, b) in out.iter_mut().zip(basis) {
            *o += ej * b;
        }
    }
    out
}

/// `p(θ + 1)` in place: the Taylor shift by one by repeated synthetic division
/// (Horner's scheme: `a_j += a_{j+1}` for every `j` from the top, once per coefficient —
/// `n(n−1)/2` additions).
fn shift_by_one(a: &mut [f64; COEFFS]) {
    for i in 0..COEFFS - 1 {
        for j in (i..COEFFS - 1).rev() {
            let next = a.get(j + 1).copied().unwrap_or(0.0);
            if let Some(slot) = a.get_mut(j) {
                *slot += next;
            }
        }
    }
}

/// `p(s θ)`: the coefficients of `p(τ)` scaled by `s^j`.
fn scaled(mut p: [f64; COEFFS], s: f64) -> [f64; COEFFS] {
    let mut s_j = 1.0;
    for c in p.iter_mut() {
        *c *= s_j;
        s_j *= s;
    }
    p
}

impl<const NH: usize> Blend<NH> {
    /// Adds the blend's share on the current cycle to the pieces and moves it on to the
    /// next; returns whether it goes on after this cycle.
    pub fn add(&mut self, horizontal: &mut [Piece; NH], hoist: &mut Piece) -> bool {
        if self.left == 0 {
            return false;
        }
        for (piece, e) in horizontal.iter_mut().zip(self.horizontal.iter_mut()) {
            for (c, b) in piece.coeffs.iter_mut().zip(e.iter()) {
                *c += b;
            }
            shift_by_one(e);
        }
        for (c, b) in hoist.coeffs.iter_mut().zip(self.hoist.iter()) {
            *c += b;
        }
        shift_by_one(&mut self.hoist);
        self.left -= 1;
        self.left > 0
    }
}

/// The moments of a filter's kernel: mean and variance, s and s².
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moments {
    /// Mean lag τ̄.
    pub mean: f64,
    /// Variance.
    pub variance: f64,
}

impl Moments {
    /// Of a moving average over `t` seconds.
    #[must_use]
    pub fn window(t: f64) -> Self {
        Self {
            mean: t * 0.5,
            variance: t * t / 12.0,
        }
    }

    /// Of a zero-vibration pair with delay `t`.
    #[must_use]
    pub fn pair(t: f64) -> Self {
        Self {
            mean: t * 0.5,
            variance: t * t * 0.25,
        }
    }

    /// Of a convolution: means and variances add.
    #[must_use]
    pub fn then(self, o: Self) -> Self {
        Self {
            mean: self.mean + o.mean,
            variance: self.variance + o.variance,
        }
    }

    /// The second moment about zero.
    #[must_use]
    pub fn second(&self) -> f64 {
        self.variance + self.mean * self.mean
    }
}

/// One axis's steady state: the rate limiter's step and speed, and `d`, `ḋ` (and, for a
/// pendulum, `e`) — from the path's position, speed and the steady acceleration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Steady {
    /// The acceleration step.
    pub k: i8,
    /// The speed in quanta, and the ideal speed's remainder.
    pub n_v: i64,
    /// The ideal speed's offset from `n_v`, quanta.
    pub carry: f64,
    /// `[d, ḋ]`.
    pub lag: [f64; 2],
    /// `[e, ė]`.
    pub swing: [f64; 2],
    /// `p₀`'s origin: the path's position minus `d + e`.
    pub origin: f64,
    /// The steady path's derivatives 0..=2 at the hand-over (3..=5 are zero).
    pub path: [f64; 3],
}

impl Steady {
    /// The steady state through a kernel of moments `m` (and a pendulum `ω_g`) at
    /// position `x`, speed `v`, acceleration `a` (already within the limit).
    #[must_use]
    pub fn new(x: f64, v: f64, a: f64, q: &Quanta, m: Moments, omega: Option<f64>) -> Self {
        let step = i64::from(MAX_STEP);
        let k = round_i(a / q.acceleration).clamp(-step, step);
        let a_q = k as f64 * q.acceleration;
        let v0 = v + a_q * m.mean;
        let ideal = v0 / q.velocity;
        let n_v = round_i(ideal);
        let v0_q = n_v as f64 * q.velocity;
        let lag = [-v0_q * m.mean + a_q * m.second() * 0.5, -a_q * m.mean];
        let swing = [omega.map_or(0.0, |w| -a_q / (w * w)), 0.0];
        let origin = x - lag[0] - swing[0];
        Self {
            k: k as i8,
            n_v,
            carry: ideal - n_v as f64,
            lag,
            swing,
            origin,
            path: [x, v0_q + lag[1], a_q],
        }
    }

    /// The steady past of `p₀` over `window` seconds, relative to the origin: its least and
    /// largest value, m.
    #[must_use]
    pub fn past_range(&self, q: &Quanta, window: f64) -> (f64, f64) {
        let (v, a) = (
            self.n_v as f64 * q.velocity,
            f64::from(self.k) * q.acceleration,
        );
        // p₀(−s) − p₀(0) = −v s + a s²/2 for s ∈ [0, window]: ends and vertex s = v/a.
        let at = |s: f64| -v * s + a * s * s * 0.5;
        let mut lo = 0.0_f64.min(at(window));
        let mut hi = 0.0_f64.max(at(window));
        if a != 0.0 {
            let s = v / a;
            if s > 0.0 && s < window {
                lo = lo.min(at(s));
                hi = hi.max(at(s));
            }
        }
        (lo, hi)
    }
}

/// The hoist's kernel moments: its four windows.
pub(crate) fn hoist_moments(windows: &[f64; 4]) -> Moments {
    windows.iter().fold(
        Moments {
            mean: 0.0,
            variance: 0.0,
        },
        |m, t| m.then(Moments::window(*t)),
    )
}

/// The horizontal kernel's moments from `p₀` to the virtual trolley: the two windows,
/// the generator pendulum's pair (`m_g h`) and the robust pair.
pub(crate) fn horizontal_moments(boxes: &[f64; 2], pair: f64, robust: Option<f64>) -> Moments {
    let mut m = Moments::window(boxes[0])
        .then(Moments::window(boxes[1]))
        .then(Moments::pair(pair));
    if let Some(r) = robust {
        m = m.then(Moments::pair(r));
    }
    m
}

/// The acceleration within the limits, keeping its direction: `a · min(1, A_i/|a_i|)`.
pub(crate) fn within<const W: usize>(a: [f64; W], limits: [f64; W]) -> [f64; W] {
    let scale = a.iter().zip(limits).fold(1.0_f64, |s, (ai, l)| {
        if libm::fabs(*ai) > l {
            s.min(l / libm::fabs(*ai))
        } else {
            s
        }
    });
    a.map(|ai| ai * scale)
}

/// Refuses an axis whose steady past or full stop leaves `[lo, hi]` (m, absolute).
pub(crate) fn check_axis(
    coordinate: &'static str,
    steady: &Steady,
    q: &Quanta,
    window: f64,
    (lo, hi): (f64, f64),
    t: f64,
) -> Result<()> {
    let (past_lo, past_hi) = steady.past_range(q, window);
    let p0 = steady.origin;
    let stop = brake(steady.n_v) as f64 * q.position;
    let back = brake(-steady.n_v) as f64 * q.position;
    for value in [p0 + past_lo, p0 + past_hi, p0 + stop, p0 - back] {
        check_inside(coordinate, value, (lo, hi), t)?;
    }
    Ok(())
}

/// Refuses a position that is not a number or outside `[lo, hi]`, naming the coordinate.
pub(crate) fn check_inside(
    coordinate: &'static str,
    value: f64,
    (lo, hi): (f64, f64),
    t: f64,
) -> Result<()> {
    if !(lo..=hi).contains(&value) {
        return Err(Error::OutsideWorkspace {
            t,
            coordinate,
            value,
            min: lo,
            max: hi,
        });
    }
    Ok(())
}

/// The blend's length in cycles of `h`.
pub(crate) fn blend_cycles(settings_blend: f64, h: f64) -> u64 {
    libm::round(settings_blend / h).max(1.0) as u64
}

/// A blend over `cycles` cycles of `h` from the next cycle on, with the differences
/// `e[j]` in the j-th time derivative at its start: `E(τ) = Σ_j e_j T_b^j H_j(τ)`, as
/// coefficients in θ (`τ = θ/cycles`).
pub(crate) fn new_blend<const NH: usize>(
    cycles: u64,
    h: f64,
    horizontal: &[[f64; ORDERS]; NH],
    hoist: &[f64; ORDERS],
) -> Blend<NH> {
    let duration = cycles as f64 * h;
    // d^j/dτ^j = T_b^j d^j/dt^j, then E in θ.
    let in_theta = |e: &[f64; ORDERS]| {
        let mut tau = *e;
        let mut scale = 1.0;
        for o in tau.iter_mut() {
            *o *= scale;
            scale *= duration;
        }
        scaled(blend_axis(&tau), 1.0 / cycles as f64)
    };
    Blend {
        horizontal: horizontal.map(|e| in_theta(&e)),
        hoist: in_theta(hoist),
        left: cycles,
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing, clippy::unwrap_used)]
    use super::*;

    fn derivative_at(p: &[f64; COEFFS], tau: f64, j: usize) -> f64 {
        (j..COEFFS).fold(0.0, |acc, k| {
            let falling = ((k - j + 1)..=k).fold(1.0, |a, i| a * i as f64);
            acc + p[k] * falling * tau.powi((k - j) as i32)
        })
    }

    #[test]
    fn hermite_basis_has_its_end_conditions() {
        for (j, b) in HERMITE.iter().enumerate() {
            for i in 0..ORDERS {
                let at0 = derivative_at(b, 0.0, i);
                let at1 = derivative_at(b, 1.0, i);
                assert!(
                    (at0 - if i == j { 1.0 } else { 0.0 }).abs() < 1e-9,
                    "H_{j}^({i})(0) = {at0}"
                );
                assert!(at1.abs() < 1e-7, "H_{j}^({i})(1) = {at1}");
            }
        }
    }

    /// A blend moved on cycle by cycle is the polynomial at the later argument: its
    /// derivatives 0..=5 within 1e-9 of the largest each reaches over the blend (measured:
    /// 1.6e-12 for the value, at most 1.4e-10 for the fourth derivative — the rounding of
    /// the monomial form, whose coefficients reach ~10⁴ for values ≤ 1, in the reference
    /// as in the blend, and of 400 cycles of additions).
    #[test]
    fn taylor_shift_is_the_polynomial_at_the_shifted_argument() {
        let p = blend_axis(&[0.1, -0.3, 0.5, 0.2, -1.0, 0.7]);
        let cycles = 400.0;
        let s = 1.0 / cycles;
        let mut largest = [0.0_f64; ORDERS];
        let mut error = [0.0_f64; ORDERS];
        let mut q = scaled(p, s);
        for n in 0..=400 {
            let tau0 = n as f64 * s;
            for theta in [0.0, 0.3, 1.0] {
                for j in 0..ORDERS {
                    let a = derivative_at(&p, tau0 + theta * s, j);
                    let b = derivative_at(&q, theta, j) / s.powi(j as i32);
                    largest[j] = largest[j].max(a.abs());
                    error[j] = error[j].max((a - b).abs());
                }
            }
            shift_by_one(&mut q);
        }
        for j in 0..ORDERS {
            assert!(
                error[j] <= 1e-9 * largest[j],
                "order {j}: {} of {}",
                error[j],
                largest[j]
            );
        }
    }

    #[test]
    fn moments_of_the_steady_state_reproduce_the_path() {
        // A window of 0.2 s: the mean of p₀(t − s) = p₀ − v s + a s²/2 over it.
        let m = Moments::window(0.2);
        let q = Quanta::new(0.5, 0.01);
        let st = Steady::new(5.0, 0.8, 0.3, &q, m, None);
        let (v, a) = (st.n_v as f64 * q.velocity, f64::from(st.k) * q.acceleration);
        let p0 = st.origin;
        let n = 2000;
        let mean: f64 = (0..n)
            .map(|i| {
                let s = 0.2 * (i as f64 + 0.5) / n as f64;
                p0 - v * s + 0.5 * a * s * s
            })
            .sum::<f64>()
            / n as f64;
        assert!((mean - 5.0).abs() < 1e-9, "{mean}");
    }
}
