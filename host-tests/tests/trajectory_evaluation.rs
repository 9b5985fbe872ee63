//! A move's evaluation after issue 20 against the evaluation before it, bit for bit.
//!
//! Issue 20 made `PointToPoint::derivatives` cheaper (604 → 263 host instructions per
//! call at n = 4, D = 3) by keeping what depends only on the move (`1/T`, `end − start`,
//! the end time) and by forming only the powers the sums use, each once. The sums and
//! the order of their operations are the Bernstein/Leibniz ones of before (see
//! `solver_core::trajectory`'s documentation for why a cheaper factored form was not
//! taken): the error against the existing evaluation is zero, at every smoothness and
//! every order, which this test pins against a verbatim copy of the code before.

use nalgebra::SVector;
use solver_core::trajectory::{PointToPoint, Trajectory, MAX_SMOOTHNESS};

/// `PointToPoint::timing` as it was before issue 20 (commit c527c78): `SmoothStep::eval`
/// with its tables of every power up to the degree, then `1/T` per order.
mod before {
    const MAX_SMOOTHNESS: usize = 12;
    const MAX_DEGREE: usize = 2 * MAX_SMOOTHNESS + 1;
    const TABULATED_ORDERS: usize = 6;

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

    fn falling(n: usize, i: usize) -> f64 {
        (0..i).fold(1.0, |acc, j| acc * (n - j) as f64)
    }

    fn derivative_coefficient(n: usize, m: usize, i: usize) -> f64 {
        let j = m - i;
        if i > n || j > n {
            return 0.0;
        }
        let k = (2 * n + 1) as f64 * binomial(2 * n, n);
        let sign = if j.is_multiple_of(2) { 1.0 } else { -1.0 };
        k * sign * binomial(m, i) * falling(n, i) * falling(n, j)
    }

    pub fn eval<const D: usize>(n: usize, tau: f64) -> [f64; D] {
        let mut value = [0.0; MAX_SMOOTHNESS + 1];
        let degree = 2 * n + 1;
        for (j, v) in value.iter_mut().enumerate().take(n + 1) {
            *v = binomial(degree, n + 1 + j);
        }
        let mut derivative = [[0.0; TABULATED_ORDERS]; TABULATED_ORDERS];
        for (m, row) in derivative.iter_mut().enumerate() {
            for (i, c) in row.iter_mut().enumerate().take(m + 1) {
                *c = derivative_coefficient(n, m, i);
            }
        }
        let mut out = [0.0; D];
        if tau <= 0.0 {
            return out;
        }
        if tau >= 1.0 {
            out[0] = 1.0;
            return out;
        }
        let s = 1.0 - tau;
        let mut pt = [1.0; MAX_DEGREE + 1];
        let mut ps = [1.0; MAX_DEGREE + 1];
        let (mut a, mut b) = (1.0, 1.0);
        for (x, y) in pt.iter_mut().zip(ps.iter_mut()).take(degree + 1).skip(1) {
            a *= tau;
            b *= s;
            *x = a;
            *y = b;
        }
        for (order, slot) in out.iter_mut().enumerate() {
            *slot = if order == 0 {
                value
                    .iter()
                    .take(n + 1)
                    .enumerate()
                    .fold(0.0, |acc, (j, w)| {
                        let k = n + 1 + j;
                        acc + *w * pt[k] * ps[degree - k]
                    })
            } else {
                let m = order - 1;
                let row = derivative.get(m);
                (0..=m).fold(0.0, |acc, i| {
                    let j = m - i;
                    if i > n || j > n {
                        return acc;
                    }
                    let coeff = row
                        .and_then(|r| r.get(i))
                        .copied()
                        .unwrap_or_else(|| derivative_coefficient(n, m, i));
                    acc + coeff * pt[n - i] * ps[n - j]
                })
            };
        }
        out
    }

    pub fn timing<const D: usize>(n: usize, t_start: f64, duration: f64, t: f64) -> [f64; D] {
        let tau = (t - t_start) / duration;
        let mut s: [f64; D] = eval(n, tau);
        let inv_t = 1.0 / duration;
        let mut scale = 1.0;
        for sj in s.iter_mut().skip(1) {
            scale *= inv_t;
            *sj *= scale;
        }
        s
    }
}

/// Every smoothness, every order up to 13 (the stop's start derivatives), durations that
/// are and are not powers of two, 2,000 times across the move and at its ends: the same
/// bits as before, and the same points on the path.
#[test]
fn the_same_bits_as_before_issue_20() {
    const D: usize = MAX_SMOOTHNESS + 2;
    let (from, to) = (
        SVector::<f64, 2>::new(12.0, 8.0),
        SVector::<f64, 2>::new(20.0, 4.0),
    );
    for n in 1..=MAX_SMOOTHNESS {
        for (t_start, duration) in [(1.0, 8.0), (0.37, 2.9), (3.0, 0.3)] {
            let m = PointToPoint::new(from, to, t_start, duration, n).unwrap();
            let times = (0..=2000)
                .map(|i| t_start + duration * f64::from(i) / 2000.0)
                .chain([t_start - 1.0, t_start + duration + 1e-9, t_start + 1e-12]);
            for t in times {
                let now: [f64; D] = m.timing(t);
                let was: [f64; D] = before::timing(n, t_start, duration, t);
                assert_eq!(
                    now.map(f64::to_bits),
                    was.map(f64::to_bits),
                    "n = {n}, T = {duration}, t = {t}"
                );
                let z: [SVector<f64, 2>; 3] = m.derivatives(t);
                let delta = to - from;
                let path = [from + delta * was[0], delta * was[1], delta * was[2]];
                assert_eq!(z, path, "n = {n}, T = {duration}, t = {t}");
            }
        }
    }
}
