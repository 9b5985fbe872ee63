//! Dense LU with partial pivoting for the small Newton matrices (7 … 24 rows), in place.
//!
//! Why not nalgebra's `LU`: measured on this project's steps, its generic
//! implementation spends several times the instructions of these plain loops on a
//! 7×7 or 21×21 matrix and copies whole matrices on the stack — 32 KiB of stack for
//! a Radau step, the firmware's whole budget. Here the factors overwrite the matrix
//! the Newton solver owns, the inverse (for Broyden) is formed in place as LAPACK's
//! `getri` does, and nothing larger than a vector lives on the stack. The tests
//! check both against nalgebra.
//!
//! Storage is nalgebra's column-major slice: element `(i, j)` is `d[j·M + i]`.

use nalgebra::{SMatrix, SVector};

use crate::scalar::{is_finite, Real};

/// Row interchanges of a factorisation: at step k, row k was swapped with `pivots[k]`.
pub(crate) type Pivots<const M: usize> = [usize; M];

fn column<T, const M: usize>(d: &[T], j: usize) -> &[T] {
    d.get(j * M..(j + 1) * M).unwrap_or(&[])
}

/// `A = Pᵀ L U` in place (unit lower L below the diagonal, U on and above).
/// `false` when a pivot is zero or not finite: the matrix is singular (to working precision).
pub(crate) fn factor<T: Real, const M: usize>(
    a: &mut SMatrix<T, M, M>,
    pivots: &mut Pivots<M>,
) -> bool {
    let d = a.as_mut_slice();
    for k in 0..M {
        // Pivot: the largest |a(i, k)|, i ≥ k.
        let col_k = column::<T, M>(d, k);
        let p = (k..M).fold(k, |best, i| {
            let (x, y) = (
                col_k.get(i).copied().unwrap_or_else(T::zero),
                col_k.get(best).copied().unwrap_or_else(T::zero),
            );
            if x.abs() > y.abs() {
                i
            } else {
                best
            }
        });
        if let Some(slot) = pivots.get_mut(k) {
            *slot = p;
        }
        if p != k {
            for j in 0..M {
                d.swap(j * M + k, j * M + p);
            }
        }
        let pivot = d.get(k * M + k).copied().unwrap_or_else(T::zero);
        if pivot == T::zero() || !is_finite(pivot) {
            return false;
        }
        let inv = T::one() / pivot;
        if let Some(below) = d.get_mut(k * M + k + 1..(k + 1) * M) {
            below.iter_mut().for_each(|x| *x *= inv);
        }
        // Rank-one update of the trailing columns.
        let (left, right) = d.split_at_mut((k + 1) * M);
        let Some(l) = left.get(k * M + k + 1..(k + 1) * M) else {
            continue;
        };
        for col in right.chunks_exact_mut(M) {
            let akj = col.get(k).copied().unwrap_or_else(T::zero);
            if akj != T::zero() {
                if let Some(rest) = col.get_mut(k + 1..) {
                    rest.iter_mut().zip(l).for_each(|(x, lik)| *x -= *lik * akj);
                }
            }
        }
    }
    true
}

/// Solves `A x = b` in place from the factors of [`factor`].
pub(crate) fn solve<T: Real, const M: usize>(
    lu: &SMatrix<T, M, M>,
    pivots: &Pivots<M>,
    b: &mut SVector<T, M>,
) {
    let d = lu.as_slice();
    let x = b.as_mut_slice();
    for (k, &p) in pivots.iter().enumerate() {
        if p != k && k < x.len() && p < x.len() {
            x.swap(k, p);
        }
    }
    // L y = P b (unit diagonal), by columns.
    for k in 0..M {
        let xk = x.get(k).copied().unwrap_or_else(T::zero);
        if let (Some(l), Some(rest)) = (d.get(k * M + k + 1..(k + 1) * M), x.get_mut(k + 1..)) {
            rest.iter_mut()
                .zip(l)
                .for_each(|(xi, lik)| *xi -= *lik * xk);
        }
    }
    // U x = y, by columns from the right.
    for k in (0..M).rev() {
        let ukk = d.get(k * M + k).copied().unwrap_or_else(T::one);
        let xk = x.get(k).copied().unwrap_or_else(T::zero) / ukk;
        if let Some(slot) = x.get_mut(k) {
            *slot = xk;
        }
        if let (Some(u), Some(above)) = (d.get(k * M..k * M + k), x.get_mut(..k)) {
            above
                .iter_mut()
                .zip(u)
                .for_each(|(xi, uik)| *xi -= *uik * xk);
        }
    }
}

/// Replaces `a` by its inverse (LU factorisation, then LAPACK's `getri` in place).
/// `false` when `a` is singular; `a` is then left partly overwritten.
pub(crate) fn invert<T: Real, const M: usize>(a: &mut SMatrix<T, M, M>) -> bool {
    let mut pivots = [0; M];
    if !factor(a, &mut pivots) {
        return false;
    }
    let d = a.as_mut_slice();
    // inv(U) in place, column by column: column j = −inv(U_jj) · inv(U[..j, ..j]) · U[..j, j].
    // The product is accumulated column-wise (contiguous axpys over the already
    // inverted columns k < j, whose entries live in rows ..=k).
    let mut work = [T::zero(); M];
    for j in 0..M {
        let Some(ujj) = d.get_mut(j * M + j) else {
            return false;
        };
        *ujj = T::one() / *ujj;
        let ajj = -*ujj;
        let (left, right) = d.split_at_mut(j * M);
        let Some(x) = right.get_mut(..j) else {
            return false;
        };
        let Some(w) = work.get_mut(..j) else {
            return false;
        };
        w.copy_from_slice(x);
        x.iter_mut().for_each(|v| *v = T::zero());
        for (k, wk) in w.iter().enumerate() {
            if let Some(col) = left.get(k * M..k * M + k + 1) {
                x.iter_mut()
                    .zip(col)
                    .for_each(|(xi, uik)| *xi += *uik * *wk);
            }
        }
        x.iter_mut().for_each(|v| *v *= ajj);
    }
    // inv(A) · L = inv(U): from the last column to the first.
    for j in (0..M.saturating_sub(1)).rev() {
        for i in j + 1..M {
            if let (Some(w), Some(x)) = (work.get_mut(i), d.get_mut(j * M + i)) {
                *w = *x;
                *x = T::zero();
            }
        }
        for k in j + 1..M {
            let wk = work.get(k).copied().unwrap_or_else(T::zero);
            if wk == T::zero() {
                continue;
            }
            let (left, right) = d.split_at_mut(k * M);
            if let (Some(cj), Some(ck)) = (left.get_mut(j * M..(j + 1) * M), right.get(..M)) {
                cj.iter_mut().zip(ck).for_each(|(x, y)| *x -= *y * wk);
            }
        }
    }
    // Undo the row interchanges as column interchanges, last first.
    for j in (0..M).rev() {
        let p = pivots.get(j).copied().unwrap_or(j);
        if p != j {
            for i in 0..M {
                let (a, b) = (j * M + i, p * M + i);
                if a < d.len() && b < d.len() {
                    d.swap(a, b);
                }
            }
        }
    }
    d.iter().all(|x| is_finite(*x))
}

/// `A = Pᵀ L U` in place for a complex matrix `A = re + i·im`, in real arithmetic
/// (RADAU5's `decc`): the transformed Radau step's one complex N×N system (α + iβ).
///
/// Why not the equivalent 2N×2N real system: its LU costs `(2N)³/3 = 8N³/3`
/// multiply-adds; the complex LU `N³/3` complex multiply-adds of four real ones, and
/// the pivot search runs over N rows instead of 2N. Measured on the whole crane run
/// (host callgrind, `docs/RESULTS.md`): 9,166 against 10,972 instructions per step at
/// h = 10 ms. Pivoting by `|re| + |im|`, which needs no square root.
/// `false` when a pivot is zero or not finite.
/// `s.swap(a, b)` when both are in bounds (always, for the callers' indices); the
/// check lets the compiler drop the slice's panicking bounds check.
fn swap_checked<T>(s: &mut [T], a: usize, b: usize) {
    if a < s.len() && b < s.len() {
        s.swap(a, b);
    }
}

pub(crate) fn factor_complex<T: Real, const M: usize>(
    re: &mut SMatrix<T, M, M>,
    im: &mut SMatrix<T, M, M>,
    pivots: &mut Pivots<M>,
) -> bool {
    let (dr, di) = (re.as_mut_slice(), im.as_mut_slice());
    for k in 0..M {
        let size = |i: usize| {
            dr.get(k * M + i).map_or_else(T::zero, |x| x.abs())
                + di.get(k * M + i).map_or_else(T::zero, |x| x.abs())
        };
        let p = (k + 1..M).fold(k, |best, i| if size(i) > size(best) { i } else { best });
        if let Some(slot) = pivots.get_mut(k) {
            *slot = p;
        }
        if p != k {
            for j in 0..M {
                swap_checked(dr, j * M + k, j * M + p);
                swap_checked(di, j * M + k, j * M + p);
            }
        }
        let (pr, pi) = (
            dr.get(k * M + k).copied().unwrap_or_else(T::zero),
            di.get(k * M + k).copied().unwrap_or_else(T::zero),
        );
        let norm2 = pr * pr + pi * pi;
        if norm2 == T::zero() || !is_finite(norm2) {
            return false;
        }
        // 1/(pr + i·pi) = (pr − i·pi)/|p|².
        let (ir, ii) = (pr / norm2, -pi / norm2);
        if let (Some(br), Some(bi)) = (
            dr.get_mut(k * M + k + 1..(k + 1) * M),
            di.get_mut(k * M + k + 1..(k + 1) * M),
        ) {
            for (xr, xi) in br.iter_mut().zip(bi.iter_mut()) {
                let (a, b) = (*xr, *xi);
                *xr = a * ir - b * ii;
                *xi = a * ii + b * ir;
            }
        }
        let (left_r, right_r) = dr.split_at_mut((k + 1) * M);
        let (left_i, right_i) = di.split_at_mut((k + 1) * M);
        let (Some(lr), Some(li)) = (
            left_r.get(k * M + k + 1..(k + 1) * M),
            left_i.get(k * M + k + 1..(k + 1) * M),
        ) else {
            continue;
        };
        for (cr, ci) in right_r.chunks_exact_mut(M).zip(right_i.chunks_exact_mut(M)) {
            let (ar, ai) = (
                cr.get(k).copied().unwrap_or_else(T::zero),
                ci.get(k).copied().unwrap_or_else(T::zero),
            );
            if ar == T::zero() && ai == T::zero() {
                continue;
            }
            if let (Some(rr), Some(ri)) = (cr.get_mut(k + 1..), ci.get_mut(k + 1..)) {
                for (((xr, xi), l_r), l_i) in rr.iter_mut().zip(ri.iter_mut()).zip(lr).zip(li) {
                    *xr -= *l_r * ar - *l_i * ai;
                    *xi -= *l_r * ai + *l_i * ar;
                }
            }
        }
    }
    true
}

/// Solves `A x = b` in place from the factors of [`factor_complex`]; `b = br + i·bi`.
pub(crate) fn solve_complex<T: Real, const M: usize>(
    re: &SMatrix<T, M, M>,
    im: &SMatrix<T, M, M>,
    pivots: &Pivots<M>,
    br: &mut SVector<T, M>,
    bi: &mut SVector<T, M>,
) {
    let (dr, di) = (re.as_slice(), im.as_slice());
    let (xr, xi) = (br.as_mut_slice(), bi.as_mut_slice());
    for (k, &p) in pivots.iter().enumerate() {
        if p != k && k < M && p < M {
            xr.swap(k, p);
            xi.swap(k, p);
        }
    }
    for k in 0..M {
        let (ar, ai) = (
            xr.get(k).copied().unwrap_or_else(T::zero),
            xi.get(k).copied().unwrap_or_else(T::zero),
        );
        if let (Some(lr), Some(li), Some(rr), Some(ri)) = (
            dr.get(k * M + k + 1..(k + 1) * M),
            di.get(k * M + k + 1..(k + 1) * M),
            xr.get_mut(k + 1..),
            xi.get_mut(k + 1..),
        ) {
            for (((yr, yi), l_r), l_i) in rr.iter_mut().zip(ri.iter_mut()).zip(lr).zip(li) {
                *yr -= *l_r * ar - *l_i * ai;
                *yi -= *l_r * ai + *l_i * ar;
            }
        }
    }
    for k in (0..M).rev() {
        let (ur, ui) = (
            dr.get(k * M + k).copied().unwrap_or_else(T::one),
            di.get(k * M + k).copied().unwrap_or_else(T::zero),
        );
        let (ar, ai) = (
            xr.get(k).copied().unwrap_or_else(T::zero),
            xi.get(k).copied().unwrap_or_else(T::zero),
        );
        let norm2 = ur * ur + ui * ui;
        let (qr, qi) = ((ar * ur + ai * ui) / norm2, (ai * ur - ar * ui) / norm2);
        if let (Some(sr), Some(si)) = (xr.get_mut(k), xi.get_mut(k)) {
            *sr = qr;
            *si = qi;
        }
        if let (Some(cr), Some(ci), Some(rr), Some(ri)) = (
            dr.get(k * M..k * M + k),
            di.get(k * M..k * M + k),
            xr.get_mut(..k),
            xi.get_mut(..k),
        ) {
            for (((yr, yi), u_r), u_i) in rr.iter_mut().zip(ri.iter_mut()).zip(cr).zip(ci) {
                *yr -= *u_r * qr - *u_i * qi;
                *yi -= *u_r * qi + *u_i * qr;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    /// A deterministic, badly scaled test matrix (with a zero on the diagonal, so pivoting matters).
    fn matrix<const M: usize>(seed: u64) -> SMatrix<f64, M, M> {
        let mut state = seed;
        SMatrix::from_fn(|i, j| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let r = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            if i == j && i == 0 {
                0.0
            } else {
                r * 10f64.powi((i % 3) as i32 * 2)
            }
        })
    }

    fn check<const M: usize>(seed: u64) {
        let a = matrix::<M>(seed);
        let b = SVector::<f64, M>::from_fn(|i, _| 1.0 + i as f64);
        let expected = a.try_inverse().unwrap() * b;
        let mut lu = a;
        let mut p = [0; M];
        assert!(factor(&mut lu, &mut p));
        let mut x = b;
        solve(&lu, &p, &mut x);
        assert!(
            (x - expected).amax() <= 1e-9 * expected.amax(),
            "solve, seed {seed}"
        );
        let mut inv = a;
        assert!(invert(&mut inv));
        let reference = a.try_inverse().unwrap();
        assert!(
            (inv - reference).amax() <= 1e-9 * reference.amax(),
            "inverse, seed {seed}"
        );
        let scale = a.amax() * inv.amax() * M as f64;
        assert!(
            (a * inv - SMatrix::<f64, M, M>::identity()).amax() < 1e-13 * scale,
            "A·inv(A), seed {seed}"
        );
    }

    #[test]
    fn agrees_with_nalgebra() {
        for seed in 1..20 {
            check::<7>(seed);
            check::<8>(seed);
            check::<21>(seed);
            check::<24>(seed);
        }
    }

    /// The complex LU against nalgebra's on the same complex matrix.
    #[test]
    fn complex_agrees_with_nalgebra() {
        use nalgebra::Complex;
        for seed in 1..20 {
            let (re, im) = (matrix::<7>(seed), matrix::<7>(seed + 100));
            let a =
                SMatrix::<Complex<f64>, 7, 7>::from_fn(|i, j| Complex::new(re[(i, j)], im[(i, j)]));
            let b = SVector::<Complex<f64>, 7>::from_fn(|i, _| {
                Complex::new(1.0 + i as f64, -(i as f64))
            });
            let expected = a.try_inverse().unwrap() * b;
            let (mut lr, mut li, mut p) = (re, im, [0; 7]);
            assert!(factor_complex(&mut lr, &mut li, &mut p));
            let mut xr = b.map(|z| z.re);
            let mut xi = b.map(|z| z.im);
            solve_complex(&lr, &li, &p, &mut xr, &mut xi);
            let size = |z: Complex<f64>| z.re.abs() + z.im.abs();
            let scale = expected.iter().map(|z| size(*z)).fold(0.0, f64::max);
            for i in 0..7 {
                let d = Complex::new(xr[i], xi[i]) - expected[i];
                assert!(size(d) <= 1e-9 * scale, "seed {seed}, row {i}");
            }
        }
        let (mut z, mut w) = (SMatrix::<f64, 3, 3>::zeros(), SMatrix::<f64, 3, 3>::zeros());
        assert!(!factor_complex(&mut z, &mut w, &mut [0; 3]));
    }

    #[test]
    fn singular_matrices_are_reported() {
        let mut a = SMatrix::<f64, 3, 3>::new(1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 1.0, 1.0);
        assert!(!factor(&mut a, &mut [0; 3]));
        let mut z = SMatrix::<f64, 4, 4>::zeros();
        assert!(!invert(&mut z));
        let mut nan = SMatrix::<f64, 2, 2>::new(f64::NAN, 1.0, 1.0, 1.0);
        assert!(!invert(&mut nan));
    }
}
