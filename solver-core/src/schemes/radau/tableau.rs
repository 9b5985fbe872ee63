//! Radau IIA's Butcher tableau (Tab. 1) and the collocation polynomial's extrapolation.
//!
//! Tab. 1 as printed has `a_21 = (296 − 169√6)/1800`; the row sum must equal `c_2`,
//! which holds for `(296 + 169√6)/1800`, the value of Hairer & Wanner used here
//! (the test `simplifying_conditions_hold` checks it).

const SQRT6: f64 = 2.449_489_742_783_178;

/// Nodes `c_i` of Tab. 1.
pub const C: [f64; 3] = [(4.0 - SQRT6) / 10.0, (4.0 + SQRT6) / 10.0, 1.0];

/// Coefficients `a_ij` of Tab. 1 (with `a_21` corrected, see the module docs).
#[rustfmt::skip]
pub const A: [[f64; 3]; 3] = [
    [(88.0 - 7.0 * SQRT6) / 360.0,     (296.0 - 169.0 * SQRT6) / 1800.0, (-2.0 + 3.0 * SQRT6) / 225.0],
    [(296.0 + 169.0 * SQRT6) / 1800.0, (88.0 + 7.0 * SQRT6) / 360.0,     (-2.0 - 3.0 * SQRT6) / 225.0],
    [(16.0 - SQRT6) / 36.0,            (16.0 + SQRT6) / 36.0,            1.0 / 9.0],
];

/// Weights `b_i` (= the last row of A: the scheme is stiffly accurate).
pub const B: [f64; 3] = A[2];

/// `E[j][i] = L_i(1 + c_j)`: the Lagrange basis on the nodes `C`, at this step's nodes
/// seen from the last step — what extrapolates the last step's collocation polynomial.
pub(crate) fn extrapolation() -> [[f64; 3]; 3] {
    C.map(|cj| [0, 1, 2].map(|i| lagrange(i, 1.0 + cj)))
}

/// The Lagrange basis polynomial `L_i` on the nodes `C`, at `tau`.
fn lagrange(i: usize, tau: f64) -> f64 {
    let ci = C.get(i).copied().unwrap_or(0.0);
    C.iter()
        .enumerate()
        .filter(|&(m, _)| m != i)
        .fold(1.0, |acc, (_, cm)| acc * (tau - cm) / (ci - cm))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// C(3): Σ_j a_ij c_j^(q−1) = c_i^q / q for q = 1, 2, 3; B(5): Σ b_i c_i^(q−1) = 1/q.
    #[test]
    fn simplifying_conditions_hold() {
        for (row, ci) in A.iter().zip(C) {
            for q in 1..=3 {
                let lhs: f64 = row.iter().zip(C).map(|(a, cj)| a * cj.powi(q - 1)).sum();
                assert!(
                    (lhs - ci.powi(q) / f64::from(q)).abs() < 1e-14,
                    "C({q}) row {row:?}"
                );
            }
        }
        for q in 1..=5 {
            let lhs: f64 = B.iter().zip(C).map(|(b, ci)| b * ci.powi(q - 1)).sum();
            assert!((lhs - 1.0 / f64::from(q)).abs() < 1e-14, "B({q})");
        }
    }
}
