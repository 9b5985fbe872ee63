//! The scalar the numerics run in.
//!
//! Everything is generic over [`Real`] so that an `f32` build can be measured
//! against `f64` (a speed/accuracy trade the study reports). `f64` is the
//! default everywhere: the index-3 DAEs amplify rounding by about `1/h³`.

use nalgebra::RealField;

/// A real scalar: `f64` or `f32` (anything nalgebra calls a `RealField` and is `Copy`).
pub trait Real: RealField + Copy {}

impl<T: RealField + Copy> Real for T {}

/// An `f64` literal in the scalar type `T` (exact for `f64`, rounded for `f32`).
#[inline(always)]
#[must_use]
pub fn c<T: Real>(value: f64) -> T {
    nalgebra::convert(value)
}

/// A scalar as `f64`, for error context and reports. `NaN` if it cannot be represented.
#[inline]
#[must_use]
pub fn to_f64<T: Real>(value: T) -> f64 {
    value.to_subset().unwrap_or(f64::NAN)
}

/// `true` when the value is neither infinite nor NaN.
#[inline]
#[must_use]
pub fn is_finite<T: Real>(value: T) -> bool {
    to_f64(value).is_finite()
}
