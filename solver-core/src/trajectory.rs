//! Desired output trajectories `z_d(t)` (the right-hand side of the servo-constraints, Eq. 10/28/34).
//!
//! The paper drives both examples with "a four times continuously differentiable
//! polynomial which smoothly merges into a constant final position". Here that is
//! the *smooth step* of degree `2n+1`: it goes from 0 to 1 with derivatives 1..n
//! vanishing at both ends, so the paper's polynomial is `n = 4` (degree 9). Before
//! the move and after it the output rests.
//!
//! Why `n` matters: an index-3 inverse model differentiates the output three
//! times, and the crane's input needs `z_d⁗`. At the ends of the move the
//! `(n+1)`-th derivative jumps, which limits every scheme to a low order there
//! (O(h) for n = 4). A smoother step moves that limit; it is a scene setting.
//!
//! Numerics: the value is summed in Bernstein form (all terms positive) and the
//! derivatives from `S'(τ) = K·τⁿ(1−τ)ⁿ` by Leibniz' rule. Both avoid the large
//! alternating monomial coefficients that cost digits at high n (the coefficients of
//! `S_n` in τ reach 540 at n = 4 and 3.3·10⁹ at n = 12, for values in [0, 1]).
//!
//! Cost (issue 20): the coefficients of both sums are computed once per smoothness
//! ([`SmoothStep::new`]), a move keeps what depends only on it (`1/T`, `end − start`,
//! its end time), and an evaluation forms only the powers `τ^k`, `(1−τ)^k` (k ≤ n) the
//! sums use, each once, continuing τ's powers into the value's terms. The operations of
//! the sums and their order are those they always had, so every value is bit for bit
//! what it was (`host-tests/tests/trajectory_evaluation.rs` pins it against the code
//! before): 604 → 263 host instructions per `PointToPoint::derivatives` call at n = 4
//! with the models' three orders (`solver-core/examples/trajectory_calls.rs`).
//!
//! A factored form was measured and not taken: the value as `τⁿ⁺¹ Σ_k C(n+k, k)(1−τ)ᵏ`
//! (all terms positive) by Horner in `1 − τ`, derivative `j` as `K·wⁿ⁺¹⁻ʲ·q_{j−1}(u)`
//! with `w = τ(1−τ)`, `u = 2τ − 1`, `q_0 = 1`, `q_{m+1} = −(n−m)·u·q_m + (1−u²)/2·q_m'`
//! (small coefficients, by Horner in `u²`). It is as accurate as this form — within
//! 2.1·10⁻¹⁵ of each order's peak against exact rational arithmetic for orders 0–2 at
//! n = 4 and n = 12, and within 1.9·10⁻¹⁵ for orders 3–5 where Bernstein/Leibniz reach
//! 1.9·10⁻¹⁴ at n = 12 — and cheaper (183 instructions per call). But any change of
//! `z_d` at rounding level moves the rounding floor of the index-3 schemes at h ≤ 5 ms:
//! BDF4's interior e_max at 2 ms went from 1.76·10⁻⁹ to 2.20·10⁻⁹ with it, RADAU5's at
//! 0.5 ms from 8.5·10⁻⁸ to 9.9·10⁻⁸, and even an exactly rounded `S_n` gives 2.09·10⁻⁹
//! at 2 ms — noise at the floor, but against the bar that no e_max grow at any step
//! size (`host-tests/tests/step_accuracy.rs`) only the same bits are sure to pass.

use nalgebra::SVector;

use crate::error::{check_positive, Error, Result};
use crate::scalar::{c, to_f64, Real};

/// Highest smoothness n supported (degree 2n+1 = 25).
pub const MAX_SMOOTHNESS: usize = 12;

/// A desired output trajectory with as many derivatives as the models and references need.
pub trait Trajectory<T: Real, const NZ: usize> {
    /// `z_d(t)` and its first `D − 1` time derivatives: element `j` is `d^j z_d / dt^j`.
    fn derivatives<const D: usize>(&self, t: T) -> [SVector<T, NZ>; D];

    /// The interval `[start, end]` outside of which the trajectory rests.
    fn active_span(&self) -> (T, T);

    /// Smoothness n: derivatives 1..=n are continuous everywhere (they vanish at the ends).
    fn smoothness(&self) -> usize;
}

/// Refuses a time at which the trajectory moves: consistent initial values "at
/// rest" (and BDF's rest history) only hold where the output rests.
pub fn ensure_at_rest<T: Real, const NZ: usize, Z: Trajectory<T, NZ>>(z: &Z, t: T) -> Result<()> {
    let (start, end) = z.active_span();
    if t <= start || t >= end {
        Ok(())
    } else {
        Err(Error::NotAtRest { t: to_f64(t) })
    }
}

/// Derivative orders whose coefficients are tabulated (the models need 2, the flat
/// reference 4); higher orders are computed on the fly.
const TABULATED_ORDERS: usize = 6;

/// The unit smooth step `S_n(τ)` of degree `2n+1` on `τ ∈ [0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothStep {
    n: usize,
    /// `C(2n+1, k)` for `k = n+1..=2n+1`: the Bernstein weights of the value.
    value: [f64; MAX_SMOOTHNESS + 1],
    /// Row `m`: the coefficients of `d^m/dτ^m [K τⁿ(1−τ)ⁿ]` (order `m + 1` of `S`),
    /// term `i` multiplying `τ^(n−i) (1−τ)^(n−m+i)`.
    derivative: [[f64; TABULATED_ORDERS]; TABULATED_ORDERS],
}

impl SmoothStep {
    /// A step whose derivatives 1..=n vanish at both ends (`n = 4`: the paper's C4 polynomial).
    pub fn new(n: usize) -> Result<Self> {
        check_smoothness(n)?;
        let degree = 2 * n + 1;
        let mut value = [0.0; MAX_SMOOTHNESS + 1];
        for (j, v) in value.iter_mut().enumerate().take(n + 1) {
            *v = binomial(degree, n + 1 + j);
        }
        let mut derivative = [[0.0; TABULATED_ORDERS]; TABULATED_ORDERS];
        for (m, row) in derivative.iter_mut().enumerate() {
            for (i, c) in row.iter_mut().enumerate().take(m + 1) {
                *c = derivative_coefficient(n, m, i);
            }
        }
        Ok(Self {
            n,
            value,
            derivative,
        })
    }

    /// Smoothness n.
    #[must_use]
    pub fn n(&self) -> usize {
        self.n
    }

    /// Polynomial degree `2n + 1`.
    #[must_use]
    pub fn degree(&self) -> usize {
        2 * self.n + 1
    }

    /// `S_n(τ)` and its first `D − 1` derivatives with respect to τ.
    /// Before the step (τ ≤ 0) it is 0 at rest, after it (τ ≥ 1) 1 at rest.
    ///
    /// The powers `τ^k` and `(1−τ)^k` are formed each from the last, `k = 1..`, and the
    /// sums run in increasing index: the operations of the Bernstein and Leibniz sums
    /// as they always were, without the tables of every power up to the degree.
    #[must_use]
    pub fn eval<T: Real, const D: usize>(&self, tau: T) -> [T; D] {
        let mut out = [T::zero(); D];
        if tau <= T::zero() {
            return out;
        }
        if tau >= T::one() {
            if let Some(v) = out.first_mut() {
                *v = T::one();
            }
            return out;
        }
        let n = self.n;
        // τ^k and (1−τ)^k for k = 0..=n: every power a derivative asks for.
        let s = T::one() - tau;
        let mut pt = [T::one(); MAX_SMOOTHNESS + 1];
        let mut ps = [T::one(); MAX_SMOOTHNESS + 1];
        let (mut a, mut b) = (T::one(), T::one());
        if let (Some(pt), Some(ps)) = (pt.get_mut(1..=n), ps.get_mut(1..=n)) {
            for (x, y) in pt.iter_mut().zip(ps.iter_mut()) {
                a *= tau;
                b *= s;
                *x = a;
                *y = b;
            }
        }
        if let (Some(v), Some(weights), Some(ps)) =
            (out.first_mut(), self.value.get(..=n), ps.get(..=n))
        {
            // Bernstein form: P(Binomial(2n+1, τ) ≥ n+1), the term of τ^(n+1+j) with
            // (1−τ)^(n−j), τ's powers continued from τⁿ.
            let mut sum = T::zero();
            for (w, sp) in weights.iter().zip(ps.iter().rev()) {
                a *= tau;
                sum += c::<T>(*w) * a * *sp;
            }
            *v = sum;
        }
        for (order, slot) in out.iter_mut().enumerate().skip(1) {
            *slot = self.derivative_at(order - 1, &pt, &ps);
        }
        out
    }

    /// `S^(m+1)` from the powers `pt[k] = τ^k`, `ps[k] = (1−τ)^k`, `k ≤ n`: Leibniz'
    /// terms `i` with `i ≤ n` and `j = m − i ≤ n`, in increasing `i`.
    fn derivative_at<T: Real>(
        &self,
        m: usize,
        pt: &[T; MAX_SMOOTHNESS + 1],
        ps: &[T; MAX_SMOOTHNESS + 1],
    ) -> T {
        let n = self.n;
        // Orders up to n + 1 (all that the models ask for): every term i = 0..=m.
        let terms = (
            self.derivative.get(m).and_then(|r| r.get(..=m)),
            n.checked_sub(m).and_then(|lo| pt.get(lo..=n)),
            n.checked_sub(m).and_then(|lo| ps.get(lo..=n)),
        );
        let (Some(row), Some(pt_m), Some(ps_m)) = terms else {
            // Beyond n + 1 (asked when a stop is planned).
            return beyond(n, m, self.derivative.get(m), pt, ps);
        };
        let mut acc = T::zero();
        for ((coeff, x), y) in row.iter().zip(pt_m.iter().rev()).zip(ps_m.iter()) {
            acc += c::<T>(*coeff) * *x * *y;
        }
        acc
    }
}

/// [`SmoothStep::derivative_at`] for an order beyond n + 1, where some terms of
/// Leibniz' rule do not exist: the tabulated coefficients while there are, then each
/// computed by [`derivative_coefficient`].
#[cold]
fn beyond<T: Real>(
    n: usize,
    m: usize,
    row: Option<&[f64; TABULATED_ORDERS]>,
    pt: &[T; MAX_SMOOTHNESS + 1],
    ps: &[T; MAX_SMOOTHNESS + 1],
) -> T {
    let pow = |p: &[T; MAX_SMOOTHNESS + 1], i: usize| p.get(i).copied().unwrap_or_else(T::one);
    // i ≤ n and j = m − i ≤ n: Leibniz' terms that exist.
    (m.saturating_sub(n)..=m.min(n)).fold(T::zero(), |acc, i| {
        let coeff = row
            .and_then(|r| r.get(i))
            .copied()
            .unwrap_or_else(|| derivative_coefficient(n, m, i));
        acc + c::<T>(coeff) * pow(pt, n - i) * pow(ps, n - (m - i))
    })
}

/// `S^(m+1) = K · d^m/dτ^m [τⁿ (1−τ)ⁿ]` with `K = (2n+1)·C(2n, n)`, by Leibniz' rule:
/// the coefficient of `τ^(n−i) (1−τ)^(n−j)`, `j = m − i`.
fn derivative_coefficient(n: usize, m: usize, i: usize) -> f64 {
    let j = m - i;
    if i > n || j > n {
        return 0.0;
    }
    let k = (2 * n + 1) as f64 * binomial(2 * n, n);
    let sign = if j.is_multiple_of(2) { 1.0 } else { -1.0 };
    k * sign * binomial(m, i) * falling(n, i) * falling(n, j)
}

/// Refuses a smoothness outside `1..=MAX_SMOOTHNESS`.
pub(crate) fn check_smoothness(n: usize) -> Result<()> {
    if n == 0 || n > MAX_SMOOTHNESS {
        return Err(Error::ParameterOutOfRange {
            name: "smoothness",
            value: n as f64,
            min: 1.0,
            max: MAX_SMOOTHNESS as f64,
        });
    }
    Ok(())
}

/// Binomial coefficient as f64 (exact for the sizes used here, ≤ C(25, 12)).
fn binomial(n: usize, k: usize) -> f64 {
    if k > n {
        return 0.0;
    }
    let k = k.min(n - k);
    let mut r: u64 = 1;
    for i in 0..k as u64 {
        r = r * (n as u64 - i) / (i + 1);
    }
    r as f64
}

/// Falling factorial n·(n−1)·…·(n−i+1).
fn falling(n: usize, i: usize) -> f64 {
    (0..i).fold(1.0, |acc, j| acc * (n - j) as f64)
}

/// A rest-to-rest move of every output axis along the same smooth step:
/// `z_d(t) = start + (end − start)·S_n((t − t_start)/duration)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointToPoint<T: Real, const NZ: usize> {
    start: SVector<T, NZ>,
    end: SVector<T, NZ>,
    /// `end − start`.
    delta: SVector<T, NZ>,
    t_start: T,
    duration: T,
    /// `t_start + duration`.
    t_end: T,
    /// `1/duration`: the chain rule's factor per order.
    inv_duration: T,
    step: SmoothStep,
}

impl<T: Real, const NZ: usize> PointToPoint<T, NZ> {
    /// A move from `start` to `end` that begins at `t_start` and lasts `duration` seconds.
    pub fn new(
        start: SVector<T, NZ>,
        end: SVector<T, NZ>,
        t_start: T,
        duration: T,
        smoothness: usize,
    ) -> Result<Self> {
        for (value, name) in start
            .iter()
            .map(|v| (v, "trajectory start"))
            .chain(end.iter().map(|v| (v, "trajectory end")))
        {
            let v = to_f64(*value);
            if !v.is_finite() {
                return Err(Error::NonFiniteParameter { name, value: v });
            }
        }
        let ts = to_f64(t_start);
        if !ts.is_finite() {
            return Err(Error::NonFiniteParameter {
                name: "trajectory t_start",
                value: ts,
            });
        }
        check_positive("trajectory duration", to_f64(duration))?;
        Ok(Self {
            start,
            end,
            delta: end - start,
            t_start,
            duration,
            t_end: t_start + duration,
            inv_duration: T::one() / duration,
            step: SmoothStep::new(smoothness)?,
        })
    }

    /// Start position.
    #[must_use]
    pub fn start(&self) -> SVector<T, NZ> {
        self.start
    }

    /// End position.
    #[must_use]
    pub fn end(&self) -> SVector<T, NZ> {
        self.end
    }

    /// Time at which the move begins.
    #[must_use]
    pub fn t_start(&self) -> T {
        self.t_start
    }

    /// Duration of the move.
    #[must_use]
    pub fn duration(&self) -> T {
        self.duration
    }
}

impl<T: Real, const NZ: usize> PointToPoint<T, NZ> {
    /// The move's timing law: the fraction `σ(t) = S_n((t − t_start)/duration)` of the
    /// way from start to end, and its first `D − 1` derivatives with respect to t. Every
    /// axis follows it, so the load's path is the straight segment from start to end;
    /// a stop re-times σ and stays on that segment ([`crate::plan::Stop`]).
    #[must_use]
    pub fn timing<const D: usize>(&self, t: T) -> [T; D] {
        let tau = (t - self.t_start) / self.duration;
        let mut s: [T; D] = self.step.eval(tau);
        let mut scale = T::one();
        for sj in s.iter_mut().skip(1) {
            scale *= self.inv_duration;
            *sj *= scale;
        }
        s
    }
}

/// The point at the fraction `s[0]` of the straight segment from `from` by `delta`,
/// and its derivatives from those of the fraction, `s[j]` (every axis moves along the
/// segment).
pub(crate) fn along<T: Real, const NZ: usize, const D: usize>(
    from: SVector<T, NZ>,
    delta: SVector<T, NZ>,
    s: &[T; D],
) -> [SVector<T, NZ>; D] {
    let mut out = [SVector::<T, NZ>::zeros(); D];
    for (order, (slot, sj)) in out.iter_mut().zip(s.iter()).enumerate() {
        *slot = if order == 0 {
            from + delta * *sj
        } else {
            delta * *sj
        };
    }
    out
}

impl<T: Real, const NZ: usize> Trajectory<T, NZ> for PointToPoint<T, NZ> {
    fn derivatives<const D: usize>(&self, t: T) -> [SVector<T, NZ>; D] {
        along(self.start, self.delta, &self.timing(t))
    }

    fn active_span(&self) -> (T, T) {
        (self.t_start, self.t_end)
    }

    fn smoothness(&self) -> usize {
        self.step.n()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing, clippy::unwrap_used)]
    use super::*;

    #[test]
    fn paper_polynomial_is_degree_nine_with_four_vanishing_derivatives() {
        let s = SmoothStep::new(4).unwrap();
        assert_eq!(s.degree(), 9);
        for tau in [1e-12_f64, 1.0 - 1e-12] {
            let d: [f64; 6] = s.eval(tau);
            for (j, v) in d.iter().enumerate().skip(1).take(4) {
                assert!(v.abs() < 1e-6, "derivative {j} at {tau} = {v}");
            }
        }
        let mid: [f64; 1] = s.eval(0.5);
        assert!((mid[0] - 0.5).abs() < 1e-15);
    }

    #[test]
    fn derivatives_match_finite_differences() {
        for n in [1, 4, 8, 12] {
            let s = SmoothStep::new(n).unwrap();
            for &tau in &[0.13_f64, 0.5, 0.77] {
                let eps = 1e-6;
                let a: [f64; 6] = s.eval(tau - eps);
                let b: [f64; 6] = s.eval(tau + eps);
                let m: [f64; 6] = s.eval(tau);
                for j in 0..5 {
                    let fd = (b[j] - a[j]) / (2.0 * eps);
                    let scale = 1.0 + m[j + 1].abs();
                    assert!(
                        (fd - m[j + 1]).abs() < 1e-5 * scale,
                        "n={n} τ={tau} order {j}: {fd} vs {}",
                        m[j + 1]
                    );
                }
            }
        }
    }

    /// A move's time derivatives — the tabulated orders and the first beyond them —
    /// against central differences of the order below; at rest before and after.
    #[test]
    fn move_derivatives_match_finite_differences() {
        let a = SVector::<f64, 2>::new(12.0, 8.0);
        let b = SVector::<f64, 2>::new(20.0, 4.0);
        for n in [1, 4, 5, 6, 12] {
            let m = PointToPoint::new(a, b, 1.3, 2.5, n).unwrap();
            for t in [1.5, 2.2, 2.55, 3.1, 3.7] {
                let eps = 1e-6;
                let lo: [SVector<f64, 2>; 8] = m.derivatives(t - eps);
                let hi: [SVector<f64, 2>; 8] = m.derivatives(t + eps);
                let mid: [SVector<f64, 2>; 8] = m.derivatives(t);
                for j in 0..7 {
                    let fd = (hi[j] - lo[j]) / (2.0 * eps);
                    let scale = 1.0 + mid[j + 1].norm() + mid[j].norm();
                    assert!(
                        (fd - mid[j + 1]).norm() < 1e-5 * scale,
                        "n={n} t={t} order {}: {fd} vs {}",
                        j + 1,
                        mid[j + 1]
                    );
                }
            }
            let before: [SVector<f64, 2>; 3] = m.derivatives(1.0);
            let after: [SVector<f64, 2>; 3] = m.derivatives(4.0);
            let zero = SVector::<f64, 2>::zeros();
            assert_eq!(before, [a, zero, zero]);
            assert_eq!(after, [b, zero, zero]);
        }
    }

    #[test]
    fn rejects_bad_smoothness_and_duration() {
        assert!(SmoothStep::new(0).is_err());
        assert!(SmoothStep::new(MAX_SMOOTHNESS + 1).is_err());
        let a = SVector::<f64, 1>::new(0.0);
        assert!(PointToPoint::new(a, a, 0.0, 0.0, 4).is_err());
        assert!(PointToPoint::new(a, a, 0.0, f64::NAN, 4).is_err());
        assert!(PointToPoint::new(SVector::<f64, 1>::new(f64::INFINITY), a, 0.0, 1.0, 4).is_err());
    }
}
