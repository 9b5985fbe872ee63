//! The continuous half of the filters: one cycle of the load path as a polynomial in
//! `θ = (t − t_n)/h ∈ [0, 1]`, built once per cycle and evaluated at any time inside it.
//!
//! Per axis the path is `x = p₀ + d + e` ([`Polynomial::build`]):
//!
//! * `p₀` — the rate limiter's path, quadratic on the cycle;
//! * `d = r − p₀` — what the windows and pairs take off it: `d̈ = r̈ − a₀`, where `r̈`, the
//!   filtered acceleration, is the cardinal B-spline of degree `q` whose coefficients
//!   the discrete filter gives ([`crate::operator::filter`]): on this cycle
//!   `r̈(θ) = Σ_{i=0}^{q} c[n−i] N_q(θ + i)`, a polynomial of degree `q` ([`BSPLINE2`],
//!   [`BSPLINE4`]). For the hoist `r` is the path (`e = 0`).
//! * `e = x_L − r` — the horizontal axes' virtual pendulum of length `l_g`,
//!   `ẍ_L = ω_g² (r − x_L)`, i.e. `ë = −ω_g² e − r̈`. Its Taylor coefficients in θ follow
//!   from `e`, `ė` at the cycle's start by the recursion
//!   `(j+1)(j+2) ε_{j+2} = −(ω_g h)² ε_j − h² ρ_j` (ρ_j those of `r̈`); twelve of them
//!   leave `(ω_g h)¹²/12! < 10⁻²⁰` of the swing ([`MAX_OMEGA_H`](super::settings::MAX_OMEGA_H)),
//!   so the piece is exact to rounding without a sine or cosine.
//!
//! The build also gives the states `d, ḋ, e, ė` at the cycle's end. The generator keeps
//! a cycle as what builds it (`ends.rs`): it works those end states out without the
//! polynomial, and builds the polynomial only for an evaluation inside the cycle.

use crate::operator::filter::i64_to_f64;

/// The piece's highest power of θ.
pub const DEGREE: usize = 11;

/// The piece's number of coefficients.
pub const COEFFS: usize = DEGREE + 1;

/// The hoist piece's number of coefficients (degree 6: `p₀` quadratic, `d` the quartic
/// spline integrated twice; no pendulum; a hand-over's blend is evaluated apart).
pub const HOIST_COEFFS: usize = 7;

/// `C(n, k)` as f64, in const context (the B-spline's and the Hermite basis' tables).
pub(crate) const fn binomial(n: usize, k: usize) -> f64 {
    let mut r = 1.0;
    let mut i = 0;
    while i < k {
        r = r * (n - i) as f64 / (i + 1) as f64;
        i += 1;
    }
    r
}

/// `n!` as f64, in const context.
pub(crate) const fn factorial(n: usize) -> f64 {
    let mut r = 1.0;
    let mut f = 2;
    while f <= n {
        r *= f as f64;
        f += 1;
    }
    r
}

/// The pieces of the cardinal B-spline of degree `q ≤ 4` (knots at the integers, support
/// `[0, q+1]`): row `i` holds the coefficients of `θ^j` of `N_q(θ + i)`, `θ ∈ [0, 1]`,
/// from `N_q(x) = (1/q!) Σ_m (−1)^m C(q+1, m) (x − m)₊^q`.
#[allow(clippy::indexing_slicing)] // evaluated at compile time: an index out of range fails the build
const fn bspline(q: usize) -> [[f64; 5]; 5] {
    let mut out = [[0.0; 5]; 5];
    let q_factorial = factorial(q);
    let mut i = 0;
    while i <= q {
        let mut m = 0;
        while m <= i {
            let sign = if m % 2 == 0 { 1.0 } else { -1.0 };
            let shift = (i - m) as f64;
            // (θ + shift)^q = Σ_j C(q, j) θ^j shift^(q−j).
            let mut j = 0;
            while j <= q {
                let mut power = 1.0;
                let mut p = 0;
                while p < q - j {
                    power *= shift;
                    p += 1;
                }
                out[i][j] += sign * binomial(q + 1, m) * binomial(q, j) * power / q_factorial;
                j += 1;
            }
            m += 1;
        }
        i += 1;
    }
    out
}

/// The quadratic B-spline's pieces (two windows: the horizontal filter).
#[cfg(test)]
const BSPLINE2: [[f64; 5]; 5] = bspline(2);

/// The quartic B-spline's pieces (four windows: the hoist's filter).
#[cfg(test)]
const BSPLINE4: [[f64; 5]; 5] = bspline(4);

/// The pieces of degree `q` (2 or 4; any other is the quartic's, which no filter here has).
#[cfg(test)]
fn bspline_of(q: usize) -> &'static [[f64; 5]; 5] {
    if q == 2 {
        &BSPLINE2
    } else {
        &BSPLINE4
    }
}

/// `1/((j+1)(j+2))`: what integrating `θ^j` twice divides by.
pub(crate) const INV_PAIR: [f64; COEFFS] = inv_pair();

#[allow(clippy::indexing_slicing)] // evaluated at compile time
const fn inv_pair() -> [f64; COEFFS] {
    let mut out = [0.0; COEFFS];
    let mut j = 0;
    while j < COEFFS {
        out[j] = 1.0 / ((j + 1) * (j + 2)) as f64;
        j += 1;
    }
    out
}

/// `Σ_i N_q(θ + i) (−1)^j C(i, j)`: row `j` of the map from the filter output's
/// backward differences `∇^j S[n]` to the coefficients of θ^m of the B-spline on this
/// cycle, `Σ_i S[n−i] N_q(θ + i)` — the B-spline's pieces and the differences'
/// binomials in one table, entry `[m][j]`.
#[allow(clippy::indexing_slicing)] // evaluated at compile time: an index out of range fails the build
const fn spline_of_differences(q: usize) -> [[f64; 5]; 5] {
    let b = bspline(q);
    let mut out = [[0.0; 5]; 5];
    let mut m = 0;
    while m <= q {
        let mut j = 0;
        while j <= q {
            let mut i = j;
            while i <= q {
                let sign = if j % 2 == 0 { 1.0 } else { -1.0 };
                out[m][j] += b[i][m] * sign * binomial(i, j);
                i += 1;
            }
            j += 1;
        }
        m += 1;
    }
    out
}

/// [`spline_of_differences`] of the quadratic and the quartic B-spline.
pub(crate) const DIFFERENCES2: [[f64; 5]; 5] = spline_of_differences(2);
pub(crate) const DIFFERENCES4: [[f64; 5]; 5] = spline_of_differences(4);

/// The filtered acceleration on this cycle as a polynomial in θ, from the filter
/// output's backward differences `∇^j S[n]` (exact integers, as f64: [`differences`])
/// and `scale`, the factor that makes them m/s²: `Σ_i c[n−i] N_q(θ + i)` with
/// `c = scale · S`.
#[must_use]
pub fn spline(values: &[f64; 5], q: usize, scale: f64) -> [f64; 5] {
    // One unrolled product per degree (a group's degree never changes: the horizontal
    // filter's 2, the hoist's 4), rather than loops on `q` at run time.
    if q == 2 {
        spline_of::<3>(values, &DIFFERENCES2, scale)
    } else {
        spline_of::<5>(values, &DIFFERENCES4, scale)
    }
}

/// The backward differences as f64, each converted once (exact: they are far within
/// 2⁵³).
#[must_use]
pub fn differences(nabla: &[i64; 5]) -> [f64; 5] {
    nabla.map(i64_to_f64)
}

/// [`spline`] of degree `N − 1`: the first `N` differences through `table`.
fn spline_of<const N: usize>(values: &[f64; 5], table: &[[f64; 5]; 5], scale: f64) -> [f64; 5] {
    let mut rho = [0.0; 5];
    for (r, row) in rho.iter_mut().zip(table.iter()).take(N) {
        let mut acc = 0.0;
        for (n, m) in values.iter().zip(row.iter()).take(N) {
            // The table's zeros skipped (a third of the quadratic's): `acc` starts at +0.0
            // and a sum is −0.0 only of two −0.0, so adding a product `n·0 = ±0` (n an
            // integer's value, finite) never changes it. The same bits, fewer dependent
            // multiply-adds.
            if *m != 0.0 {
                acc += n * m;
            }
        }
        *r = acc * scale;
    }
    rho
}

/// A value and its rate at a cycle's start (`d, ḋ` or `e, ė`).
pub type State = [f64; 2];

/// One axis's path on the current cycle, and its filter states.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Polynomial {
    /// The path's coefficients in θ.
    pub coeffs: [f64; COEFFS],
    /// `d = r − p₀`, `ḋ` at the start of the next cycle to build (once built: at the
    /// current cycle's end).
    pub lag: State,
    /// `e = x_L − r`, `ė` likewise (zero for the hoist).
    pub swing: State,
}

/// What a cycle's piece is built from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inputs {
    /// The rate limiter's position at the cycle's start, m.
    pub p0: f64,
    /// Its speed, m/s.
    pub v0: f64,
    /// Its acceleration on the cycle, m/s².
    pub a0: f64,
    /// The filtered acceleration's coefficients in θ (degree `q`).
    pub rho: [f64; 5],
    /// The cycle, s.
    pub h: f64,
    /// `1/h`.
    pub inv_h: f64,
    /// `ω_g h` of the virtual pendulum; `None` for the hoist.
    pub omega_h: Option<f64>,
}

impl Polynomial {
    /// At rest at `position`.
    #[must_use]
    pub fn rest(position: f64) -> Self {
        let mut coeffs = [0.0; COEFFS];
        coeffs[0] = position;
        Self {
            coeffs,
            lag: [0.0; 2],
            swing: [0.0; 2],
        }
    }

    /// Builds the cycle from the states at its start (`self.lag`, `self.swing`), which
    /// it replaces by those at its end.
    ///
    /// Written out term by term with constant indices, each coefficient stored where it
    /// is made (no array of them kept and copied: the registers hold the recursion), and
    /// every sum of several terms added as a tree: on the Cortex-M7 a dependent double
    /// add waits 4 cycles and a multiply-add 11 (`cargo xtask cycles`' model), so the
    /// depth of the dependences, more than the count of operations, sets this function's
    /// cost.
    #[allow(clippy::indexing_slicing)] // constant indices below COEFFS: checked when compiled
    pub fn build(&mut self, x: &Inputs) {
        let (h, h2) = (x.h, x.h * x.h);
        let [d, d_dot] = self.lag;
        let [e, e_dot] = self.swing;
        let [r0, r1, r2, r3, r4] = x.rho;
        // r̈ integrated twice in θ: h² ρ_j θ^(j+2)/((j+1)(j+2)).
        let f0 = h2 * r0 * INV_PAIR[0];
        let f1 = h2 * r1 * INV_PAIR[1];
        let f2 = h2 * r2 * INV_PAIR[2];
        let f3 = h2 * r3 * INV_PAIR[3];
        let f4 = h2 * r4 * INV_PAIR[4];
        // d̈ = r̈ − a₀: d at the cycle's end and its rate (times h).
        let lag_curvature = -h2 * x.a0 * 0.5;
        let d_step = d_dot * h;
        let next_d = ((d + d_step) + (lag_curvature + f0)) + ((f1 + f2) + (f3 + f4));
        let next_d_rate = ((d_step + 2.0 * lag_curvature) + (2.0 * f0 + 3.0 * f1))
            + ((4.0 * f2 + 5.0 * f3) + 6.0 * f4);
        let c = &mut self.coeffs;
        // x = p₀ + d + e: from θ² on, p₀ + d is the filtered part alone.
        c[0] = x.p0 + d + e;
        c[1] = (x.v0 + d_dot + e_dot) * h;
        self.lag = [next_d, next_d_rate * x.inv_h];
        let Some(omega_h) = x.omega_h else {
            // The hoist: no pendulum, the path's top coefficients zero.
            c[2] = f0;
            c[3] = f1;
            c[4] = f2;
            c[5] = f3;
            c[6] = f4;
            for top in c.iter_mut().skip(HOIST_COEFFS) {
                *top = 0.0;
            }
            self.swing = [0.0; 2];
            return;
        };
        // The pendulum's Taylor coefficients ε_j: (j+1)(j+2) ε_{j+2} = −(ω_g h)² ε_j − h² ρ_j,
        // i.e. ε_{j+2} = k_j ε_j − f_j with k_j = −(ω_g h)²/((j+1)(j+2)), the factors
        // formed beside the recursion so that each of its steps is one multiply and one
        // subtract. The path's own coefficient is `k_j ε_j` (the load's acceleration
        // `ẍ_L = −ω_g² e`: `r`'s `f_j` cancels), free of that subtraction's rounding.
        let w = -omega_h * omega_h;
        let k = |j: usize| w * INV_PAIR[j];
        let e0 = e;
        let e1 = e_dot * h;
        let (p2, p3) = (e0 * k(0), e1 * k(1));
        c[2] = p2;
        c[3] = p3;
        let (e2, e3) = (p2 - f0, p3 - f1);
        let (p4, p5) = (e2 * k(2), e3 * k(3));
        c[4] = p4;
        c[5] = p5;
        let (e4, e5) = (p4 - f2, p5 - f3);
        let p6 = e4 * k(4);
        c[6] = p6;
        let e6 = p6 - f4;
        let e7 = e5 * k(5);
        let e8 = e6 * k(6);
        let e9 = e7 * k(7);
        let e10 = e8 * k(8);
        let e11 = e9 * k(9);
        c[7] = e7;
        c[8] = e8;
        c[9] = e9;
        c[10] = e10;
        c[11] = e11;
        // e and ė h at the cycle's end: Σ ε_j and Σ j ε_j, the early terms summed while
        // the recursion still runs.
        let sum = (((e0 + e1) + (e2 + e3)) + ((e4 + e5) + (e6 + e7))) + ((e8 + e9) + (e10 + e11));
        let rate = (((e1 + 2.0 * e2) + (3.0 * e3 + 4.0 * e4)) + ((5.0 * e5 + 6.0 * e6) + 7.0 * e7))
            + ((8.0 * e8 + 9.0 * e9) + (10.0 * e10 + 11.0 * e11));
        self.swing = [sum, rate * x.inv_h];
    }

    /// The path and its first `D − 1` time derivatives at `θ`, `inv_h = 1/h`.
    #[must_use]
    pub fn eval<const D: usize>(&self, theta: f64, inv_h: f64) -> [f64; D] {
        self.eval_below::<D, COEFFS>(theta, inv_h)
    }

    /// [`Polynomial::eval`] of a piece at rest as [`Polynomial::rest`] makes it (every coefficient
    /// but the first +0.0), bit for bit, without its steps: those sums add +0.0 to
    /// `(+0.0)·θ` at every step and stay +0.0 (NaN for a θ that is not finite), all but
    /// the path's last, `(+0.0)·θ + c₀`; the derivatives are such sums scaled by
    /// factorials and powers of `1/h`, which leave them as they are.
    #[must_use]
    pub fn eval_constant<const D: usize>(&self, theta: f64) -> [f64; D] {
        let zero = 0.0 * theta + 0.0;
        let mut out = [zero; D];
        if let Some(x) = out.first_mut() {
            *x = 0.0 * theta + self.coeffs[0];
        }
        out
    }

    /// [`Polynomial::eval`] of a piece whose coefficients from `θ^N` on are zero (the hoist's:
    /// degree 6, no pendulum), `N ≤ COEFFS`: the same
    /// values bit for bit — the steps over the zero coefficients leave every sum at zero
    /// — without those steps.
    ///
    /// By repeated synthetic division (Horner's scheme for the polynomial and its
    /// quotients): `b_0 ← b_0 θ + c_k`, `b_j ← b_j θ + b_{j−1}` from the top coefficient
    /// down leave `b_j = p^(j)(θ)/j!`. One multiply-add per coefficient and derivative
    /// and no other multiply: the sums of the derivatives' coefficients `c_k k!/(k−j)!`
    /// had a product of their own in every step, and the compiler fused that product,
    /// not the one on the sum's chain, into the `vmla` (each step a `vmul` and a `vmla`
    /// one after the other: 18 Cortex-M7 cycles in `cargo xtask cycles`' model, against
    /// 11).
    #[must_use]
    pub fn eval_below<const D: usize, const N: usize>(&self, theta: f64, inv_h: f64) -> [f64; D] {
        let mut out = [0.0; D];
        if D <= 3 {
            // What the inverse models ask (position, speed, acceleration).
            let [x, v, a] = self.three_below::<N>(theta);
            for (o, value) in out.iter_mut().zip([x, v * inv_h, a * (inv_h * inv_h)]) {
                *o = value;
            }
            return out;
        }
        // The same steps as `three_below`'s, for any number of derivatives: in step `i`
        // (from the top) the sums `b_j`, `j ≤ i`, that hold something (the first time,
        // `0·θ + b_{j−1}` is `b_{j−1}`).
        let mut b = [0.0; D];
        for (i, c) in self.coeffs.iter().take(N).rev().enumerate() {
            for j in (1..D.min(i + 1)).rev() {
                let Some(&lower) = b.get(j - 1) else {
                    continue;
                };
                if let Some(slot) = b.get_mut(j) {
                    *slot = if j == i { lower } else { *slot * theta + lower };
                }
            }
            if let Some(b0) = b.first_mut() {
                *b0 = if i == 0 { *c } else { *b0 * theta + c };
            }
        }
        // p^(j) = j! b_j, per h^j.
        let (mut scale, mut factorial) = (1.0, 1.0);
        for (j, (slot, bj)) in out.iter_mut().zip(b).enumerate() {
            if j > 0 {
                factorial *= j as f64;
            }
            *slot = bj * factorial * scale;
            scale *= inv_h;
        }
        out
    }

    /// The path and its first two θ-derivatives at `θ` from the coefficients below `θ^N`
    /// ([`Polynomial::eval_below`]'s synthetic division; the second derivative `2 b_2`),
    /// written out step by step with constant indices (the compiler kept a loop over `k`
    /// rolled, with its branches, however it was written). Each step of a sum waits for
    /// its last (a multiply-accumulate: 11 Cortex-M7 cycles in `cargo xtask cycles`'
    /// model); the three sums side by side fill those cycles. The operations are those of
    /// the loop in [`Polynomial::eval_below`], in the same order: its values bit for bit.
    #[allow(clippy::indexing_slicing)] // constant indices below COEFFS: checked when compiled
    fn three_below<const N: usize>(&self, theta: f64) -> [f64; 3] {
        let c = &self.coeffs;
        let (mut x, mut v, mut a) = (0.0, 0.0, 0.0);
        macro_rules! step {
            ($k:literal) => {
                if $k < N {
                    // The step's index from the top.
                    let i = N - 1 - $k;
                    if i >= 3 {
                        a = a * theta + v;
                    } else if i == 2 {
                        a = v;
                    }
                    if i >= 2 {
                        v = v * theta + x;
                    } else if i == 1 {
                        v = x;
                    }
                    x = if i >= 1 { x * theta + c[$k] } else { c[$k] };
                }
            };
        }
        step!(11);
        step!(10);
        step!(9);
        step!(8);
        step!(7);
        step!(6);
        step!(5);
        step!(4);
        step!(3);
        step!(2);
        step!(1);
        step!(0);
        [x, v, a * 2.0]
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing, clippy::unwrap_used)]
    use super::*;

    /// Cox–de Boor's recursion at a point, for the tables' check.
    fn cox_de_boor(q: usize, x: f64) -> f64 {
        if q == 0 {
            return if (0.0..1.0).contains(&x) { 1.0 } else { 0.0 };
        }
        let qf = q as f64;
        (x * cox_de_boor(q - 1, x) + (qf + 1.0 - x) * cox_de_boor(q - 1, x - 1.0)) / qf
    }

    #[test]
    fn bspline_tables_are_the_b_splines() {
        for q in [2, 4] {
            let t = bspline_of(q);
            for (i, row) in t.iter().enumerate().take(q + 1) {
                for s in 0..10 {
                    let theta = f64::from(s) / 10.0;
                    let poly: f64 = (0..=q).map(|j| row[j] * theta.powi(j as i32)).sum();
                    let want = cox_de_boor(q, theta + i as f64);
                    assert!((poly - want).abs() < 1e-14, "q {q} piece {i} θ {theta}");
                }
            }
            // Partition of unity: the pieces' sum is 1 at every θ.
            for j in 0..=q {
                let s: f64 = t.iter().take(q + 1).map(|row| row[j]).sum();
                assert!((s - if j == 0 { 1.0 } else { 0.0 }).abs() < 1e-14);
            }
        }
    }

    /// The spline from the differences is the B-spline of the values they stand for.
    #[test]
    fn spline_from_differences_is_the_spline_of_the_values() {
        use crate::operator::filter::values;
        for q in [2, 4] {
            let nabla = [123_456, -2_345, 678, -90, 12];
            let s = values(&nabla, q);
            let rho = spline(&differences(&nabla), q, 0.25);
            let table = bspline_of(q);
            for (m, r) in rho.iter().enumerate().take(q + 1) {
                let want: f64 = (0..=q).map(|i| s[i] as f64 * 0.25 * table[i][m]).sum();
                assert!(
                    (r - want).abs() < 1e-9 * (1.0 + want.abs()),
                    "q {q} θ^{m}: {r} vs {want}"
                );
            }
        }
    }

    /// The pendulum piece satisfies `ẍ_L = ω² (r − x_L)` inside the cycle, and the end
    /// states continue it: the difference to a fine RK4 integration of the same
    /// equations is at rounding level.
    #[test]
    fn pendulum_piece_solves_its_equation() {
        let h = 0.01;
        let omega: f64 = 1.7;
        let x = Inputs {
            p0: 12.0,
            v0: 0.4,
            a0: 0.3,
            rho: [0.2, -0.05, 0.01, 0.0, 0.0],
            h,
            inv_h: 1.0 / h,
            omega_h: Some(omega * h),
        };
        let mut p = Polynomial::rest(0.0);
        p.lag = [-0.6, 0.02];
        p.swing = [0.03, -0.01];
        p.build(&x);
        // r = p₀ + d, with d̈ = r̈ − a₀, integrated by RK4 beside e.
        let rdd = |th: f64| x.rho[0] + x.rho[1] * th + x.rho[2] * th * th;
        let f = |th: f64, y: [f64; 4]| -> [f64; 4] {
            // y = [d, ḋ, e, ė]
            [y[1], rdd(th) - x.a0, y[3], -omega * omega * y[2] - rdd(th)]
        };
        let mut y = [-0.6, 0.02, 0.03, -0.01];
        let n = 1000;
        let dt = h / n as f64;
        for i in 0..n {
            let th = |s: f64| (i as f64 * dt + s) / h;
            let k1 = f(th(0.0), y);
            let k2 = f(
                th(0.5 * dt),
                core::array::from_fn(|j| y[j] + 0.5 * dt * k1[j]),
            );
            let k3 = f(
                th(0.5 * dt),
                core::array::from_fn(|j| y[j] + 0.5 * dt * k2[j]),
            );
            let k4 = f(th(dt), core::array::from_fn(|j| y[j] + dt * k3[j]));
            for j in 0..4 {
                y[j] += dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
            }
        }
        assert!((p.lag[0] - y[0]).abs() < 1e-15 && (p.lag[1] - y[1]).abs() < 1e-14);
        assert!((p.swing[0] - y[2]).abs() < 1e-15 && (p.swing[1] - y[3]).abs() < 1e-14);
        // The path at the end: p₀(h) + d + e.
        let p0_end = x.p0 + x.v0 * h + 0.5 * x.a0 * h * h;
        let [v, _]: [f64; 2] = p.eval(1.0, 1.0 / h);
        assert!((v - (p0_end + y[0] + y[2])).abs() < 1e-14);
    }

    /// The unrolled evaluation of three derivatives is the loop's bit for bit (the loop
    /// runs for more than three), and a piece with a zero top evaluated below it is the
    /// whole piece evaluated, bit for bit: random pieces, θ inside and beyond the cycle.
    #[test]
    fn the_unrolled_evaluations_are_the_loops_bit_for_bit() {
        let mut seed = 3_u64;
        let mut next = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            ((seed >> 11) as f64 / (1_u64 << 53) as f64 - 0.5) * 4.0
        };
        for n in 0..2_000 {
            let mut p = Polynomial::rest(0.0);
            for c in &mut p.coeffs {
                *c = next() * 10.0_f64.powi((n % 7) - 3);
            }
            let theta = if n % 5 == 0 { 1.0 } else { next() * 0.6 + 0.5 };
            let inv_h = 100.0 + next();
            let three: [f64; 3] = p.eval(theta, inv_h);
            let loop7: [f64; 7] = p.eval(theta, inv_h);
            assert_eq!(
                three.map(f64::to_bits),
                [0, 1, 2].map(|j| loop7[j].to_bits())
            );
            let two: [f64; 2] = p.eval(theta, inv_h);
            assert_eq!(two.map(f64::to_bits), [0, 1].map(|j| loop7[j].to_bits()));
            for c in p.coeffs.iter_mut().skip(HOIST_COEFFS) {
                *c = 0.0;
            }
            let whole: [f64; 3] = p.eval(theta, inv_h);
            let below = p.eval_below::<3, HOIST_COEFFS>(theta, inv_h);
            assert_eq!(
                whole.map(f64::to_bits),
                below.map(f64::to_bits),
                "piece {n}"
            );
            let whole7: [f64; 7] = p.eval(theta, inv_h);
            let below7 = p.eval_below::<7, HOIST_COEFFS>(theta, inv_h);
            assert_eq!(
                whole7.map(f64::to_bits),
                below7.map(f64::to_bits),
                "piece {n}"
            );
        }
    }

    /// A piece settled, and one built from zero inputs at its position (what an axis
    /// standing still in a moving group would build), evaluate as the constant shortcut
    /// does, bit for bit, for θ over the cycle and beyond, three and seven derivatives.
    #[test]
    fn a_resting_piece_evaluates_as_its_constant() {
        let mut seed = 9_u64;
        let mut next = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            ((seed >> 11) as f64 / (1_u64 << 53) as f64 - 0.5) * 40.0
        };
        for n in 0..2_000 {
            let position = if n % 7 == 0 { 0.0 } else { next() };
            let settled = Polynomial::rest(position);
            let mut built = Polynomial::rest(position);
            built.build(&Inputs {
                p0: position,
                v0: 0.0,
                a0: 0.0,
                rho: spline(&[0.0; 5], 2, 0.25),
                h: 0.01,
                inv_h: 100.0,
                omega_h: Some(0.02 + next().abs() * 1e-3),
            });
            assert_eq!(built.lag, [0.0; 2]);
            assert_eq!(built.swing, [0.0; 2]);
            let theta = if n % 5 == 0 { 1.0 } else { next().abs() / 20.0 };
            let inv_h = 100.0 + next();
            let shortcut3: [f64; 3] = settled.eval_constant(theta);
            let shortcut7: [f64; 7] = settled.eval_constant(theta);
            for piece in [settled, built] {
                let three: [f64; 3] = piece.eval(theta, inv_h);
                let seven: [f64; 7] = piece.eval(theta, inv_h);
                assert_eq!(three.map(f64::to_bits), shortcut3.map(f64::to_bits), "{n}");
                assert_eq!(seven.map(f64::to_bits), shortcut7.map(f64::to_bits), "{n}");
                let below = piece.eval_below::<3, HOIST_COEFFS>(theta, inv_h);
                assert_eq!(below.map(f64::to_bits), shortcut3.map(f64::to_bits), "{n}");
            }
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let h = 0.01;
        let mut p = Polynomial::rest(0.0);
        p.lag = [-0.6, 0.02];
        p.swing = [0.03, -0.01];
        p.build(&Inputs {
            p0: 3.0,
            v0: -0.2,
            a0: 0.1,
            rho: [0.2, -0.05, 0.01, 0.003, -0.001],
            h,
            inv_h: 1.0 / h,
            omega_h: Some(0.02),
        });
        let th = 0.37;
        let e = 1e-4;
        let lo: [f64; 7] = p.eval(th - e, 1.0 / h);
        let hi: [f64; 7] = p.eval(th + e, 1.0 / h);
        let mid: [f64; 7] = p.eval(th, 1.0 / h);
        for j in 0..6 {
            let fd = (hi[j] - lo[j]) / (2.0 * e * h);
            assert!(
                (fd - mid[j + 1]).abs() < 1e-5 * (1.0 + mid[j + 1].abs()),
                "order {}: {fd} vs {}",
                j + 1,
                mid[j + 1]
            );
        }
    }
}
