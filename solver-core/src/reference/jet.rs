//! Third-order Taylor jets: a value with its first three time derivatives.
//!
//! The crane's flat inverse needs `ẍ` and `l̈` (for the inputs) and `x⃛`, `l⃛` (for the
//! inputs' rates) of expressions such as `x = x_C − ẍ_C z_C / (z̈_C − g)`; carrying
//! `(f, ḟ, f̈, f⃛)` through `+ − · / √` by Leibniz' rule gives them exactly, without
//! differentiating by hand.

use core::ops::{Add, Div, Mul, Neg, Sub};

/// `(f, ḟ, f̈, f⃛)` at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jet {
    /// f
    pub v: f64,
    /// ḟ
    pub d1: f64,
    /// f̈
    pub d2: f64,
    /// f⃛
    pub d3: f64,
}

impl Jet {
    /// A jet from its four parts.
    #[must_use]
    pub const fn new(v: f64, d1: f64, d2: f64, d3: f64) -> Self {
        Self { v, d1, d2, d3 }
    }

    /// A constant.
    #[must_use]
    pub const fn constant(v: f64) -> Self {
        Self::new(v, 0.0, 0.0, 0.0)
    }

    /// `r = √f`, from `r² = f`: `r' = f'/(2r)`, `r'' = (f'' − 2r'²)/(2r)`,
    /// `r''' = (f''' − 6 r' r'')/(2r)`.
    #[must_use]
    pub fn sqrt(self) -> Self {
        let r = libm::sqrt(self.v);
        let d1 = self.d1 / (2.0 * r);
        let d2 = (self.d2 - 2.0 * d1 * d1) / (2.0 * r);
        Self::new(r, d1, d2, (self.d3 - 6.0 * d1 * d2) / (2.0 * r))
    }
}

impl Add for Jet {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self::new(self.v + o.v, self.d1 + o.d1, self.d2 + o.d2, self.d3 + o.d3)
    }
}

impl Sub for Jet {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self::new(self.v - o.v, self.d1 - o.d1, self.d2 - o.d2, self.d3 - o.d3)
    }
}

impl Neg for Jet {
    type Output = Self;
    fn neg(self) -> Self {
        Self::new(-self.v, -self.d1, -self.d2, -self.d3)
    }
}

impl Mul for Jet {
    type Output = Self;
    /// Leibniz: `(ab)''' = a'''b + 3a''b' + 3a'b'' + ab'''`.
    fn mul(self, o: Self) -> Self {
        Self::new(
            self.v * o.v,
            self.d1 * o.v + self.v * o.d1,
            self.d2 * o.v + 2.0 * self.d1 * o.d1 + self.v * o.d2,
            self.d3 * o.v + 3.0 * self.d2 * o.d1 + 3.0 * self.d1 * o.d2 + self.v * o.d3,
        )
    }
}

impl Div for Jet {
    type Output = Self;
    /// `q = a/b`, from `q b = a`: `q' = (a' − q b')/b`, `q'' = (a'' − 2q'b' − q b'')/b`,
    /// `q''' = (a''' − 3q''b' − 3q'b'' − q b''')/b`.
    fn div(self, o: Self) -> Self {
        let q = self.v / o.v;
        let d1 = (self.d1 - q * o.d1) / o.v;
        let d2 = (self.d2 - 2.0 * d1 * o.d1 - q * o.d2) / o.v;
        let d3 = (self.d3 - 3.0 * d2 * o.d1 - 3.0 * d1 * o.d2 - q * o.d3) / o.v;
        Self::new(q, d1, d2, d3)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f(t) = √(1 + t²)/(2 + t) at t = 0.7 against finite differences of f.
    #[test]
    fn chain_of_operations_matches_finite_differences() {
        let t = 0.7;
        let tj = Jet::new(t, 1.0, 0.0, 0.0);
        let f = (Jet::constant(1.0) + tj * tj).sqrt() / (Jet::constant(2.0) + tj);
        let g = |t: f64| libm::sqrt(1.0 + t * t) / (2.0 + t);
        let eps = 1e-4;
        let fd1 = (g(t + eps) - g(t - eps)) / (2.0 * eps);
        let fd2 = (g(t + eps) - 2.0 * g(t) + g(t - eps)) / (eps * eps);
        let h = 1e-3;
        let fd3 =
            (g(t + 2.0 * h) - 2.0 * g(t + h) + 2.0 * g(t - h) - g(t - 2.0 * h)) / (2.0 * h * h * h);
        assert!((f.v - g(t)).abs() < 1e-15);
        assert!((f.d1 - fd1).abs() < 1e-8, "{} vs {fd1}", f.d1);
        assert!((f.d2 - fd2).abs() < 1e-6, "{} vs {fd2}", f.d2);
        assert!((f.d3 - fd3).abs() < 1e-5, "{} vs {fd3}", f.d3);
    }
}
