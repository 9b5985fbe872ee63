//! The rate limiter: the stick's speed demand turned into an unfiltered path `p₀` whose
//! speed and acceleration stay within the axis's limits, whose stop ends at exactly zero
//! speed, and which never passes the axis's range (a braking curve).
//!
//! It works in integers. Each cycle every axis takes an acceleration `k δa` with
//! `k ∈ [−127, 127]` ([`MAX_STEP`]), held for the whole cycle; speed and position are
//! counted in quanta, `v₀ = n_v δv` and `p₀ = origin + n_p δp` with `δv = δa h` and
//! `δp = δv h/2`, so one cycle moves them exactly: `n_v += k`, `n_p += 2 n_v + k`
//! ([`crate::operator::settings::Quanta`]). Why integers: the filters behind it keep
//! the last few seconds of `k` (one byte each, the generator's largest RAM) and sum
//! them exactly, a stop reaches `v₀ = 0` exactly, and the braking curve is decided
//! without rounding.
//!
//! **Vector limiting.** The axes of a group (the 3D crane's bridge and trolley) change
//! their speed together along the straight line from the current speed to the demanded
//! one, each within its own limit: the step is scaled by `s = min(1, 127/|Δ_i|)` over
//! the axes, `Δ` the remaining change in quanta. An ideal speed `w = n_v + carry` keeps
//! the exact line; the integer speed follows it to within half a quantum (error
//! diffusion), so a diagonal demand gives a straight path from rest to within
//! `δv/2 · t` across it.
//!
//! **Braking curve.** After a cycle the axis must still be able to stop inside its range
//! at full deceleration: `n_p' + B(n_v') ≤ hi` (and `n_p' − B(−n_v') ≥ lo`), where
//! [`brake`] is the exact distance of that stop in position units. Braking at full
//! deceleration from a state that satisfies it gives one that does (`B(n) = 2n − 127 +
//! B(n − 127)`), so by induction the path never leaves the range, a demand held into a
//! limit ends there at rest, and a demand away from it is always granted.

use crate::operator::filter::i64_to_f64;

/// Largest acceleration step: `|k| ≤ 127`, so that a cycle's `k` is one `i8`.
pub const MAX_STEP: i32 = 127;

/// The braking distance from `n` velocity quanta per cycle (n ≥ 0) at full
/// deceleration, in position units: `j = n div 127` full cycles and one of `n mod 127`,
/// each moving `2 n_v + k` units, sum `2 j n − 127 j² + (n mod 127)`. Zero for `n ≤ 0`.
#[must_use]
pub fn brake(n: i64) -> i64 {
    if n <= 0 {
        return 0;
    }
    let step = i64::from(MAX_STEP);
    // The quotient in 32 bits where it fits (every speed a crane reaches): one hardware
    // divide on the Cortex-M7, which has none for 64 bits. The wide one out of line: inlined,
    // the compiler called the soft `__aeabi_uldivmod` on every call and chose between the
    // two quotients after (`cargo xtask cycles` found `__aeabi_uldivmod` in the 3D
    // generator's profile, called from `Axis::braked`).
    let j = match i32::try_from(n) {
        Ok(n32) => i64::from(n32 / MAX_STEP),
        Err(_) => wide_quotient(n),
    };
    let f = n - j * step;
    2 * j * n - step * j * j + f
}

/// `n / 127` for an `n` beyond 32 bits, in a call of its own (see [`brake`]).
#[cold]
#[inline(never)]
fn wide_quotient(n: i64) -> i64 {
    n / i64::from(MAX_STEP)
}

/// One axis of the rate limiter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axis {
    /// Speed in velocity quanta.
    pub n_v: i64,
    /// Position in position units from the axis's origin.
    pub n_p: i64,
    /// The ideal speed's offset from `n_v`, in quanta (error diffusion).
    pub carry: f64,
}

impl Axis {
    /// At rest at the origin.
    pub const REST: Self = Self {
        n_v: 0,
        n_p: 0,
        carry: 0.0,
    };

    /// The state after a cycle with acceleration step `k`.
    #[must_use]
    pub fn after(&self, k: i64) -> (i64, i64) {
        (self.n_v + k, self.n_p + 2 * self.n_v + k)
    }

    /// Whether an axis at speed `n_v` and position `n_p` is inside `[lo, hi]` and can
    /// stop there at full deceleration. One braking distance: moving up (or resting),
    /// only the upper bound needs it; the lower one is the position itself, and vice
    /// versa. The limiter's invariant ([`Axis::braked`]), and what a hand-over's stop
    /// shortened in place must leave (`Generator::stop_within`).
    #[inline(always)]
    #[must_use]
    pub fn stops_inside(n_v: i64, n_p: i64, (lo, hi): (i64, i64)) -> bool {
        if n_v >= 0 {
            n_p >= lo && n_p + brake(n_v) <= hi
        } else {
            n_p <= hi && n_p - brake(-n_v) >= lo
        }
    }

    /// Whether after a cycle with step `k` the axis can still stop at or below `hi`
    /// (position units); monotone: true for every step up to some largest one.
    #[must_use]
    pub fn stops_below(&self, k: i64, hi: i64) -> bool {
        let (n_v, n_p) = self.after(k);
        n_p + brake(n_v) <= hi
    }

    /// Whether after a cycle with step `k` the axis can still stop at or above `lo`;
    /// monotone: true for every step from some smallest one on.
    #[must_use]
    pub fn stops_above(&self, k: i64, lo: i64) -> bool {
        let (n_v, n_p) = self.after(k);
        n_p - brake(-n_v) >= lo
    }

    /// The step nearest `k` after which the axis can still stop within `[lo, hi]`; where
    /// no step can (only from a state that could not stop there already, which no cycle
    /// of this limiter produces from a state inside), the step that stops it soonest.
    #[must_use]
    pub fn braked(&self, k: i64, (lo, hi): (i64, i64)) -> i64 {
        let step = i64::from(MAX_STEP);
        // The common case first: the step asked for keeps the axis inside.
        let (n_v, n_p) = self.after(k);
        if Self::stops_inside(n_v, n_p, (lo, hi)) {
            return k;
        }
        let below = |k| self.stops_below(k, hi);
        let above = |k| self.stops_above(k, lo);
        // The feasible steps are an interval: search its end nearest k.
        let nearest = if !below(k) {
            // The largest step in [−127, k) that stops below hi.
            search(-step, k, below)
        } else {
            // The smallest step in (k, 127] that stops above lo.
            search(step, k, above)
        };
        match nearest {
            Some(k) if below(k) && above(k) => k,
            _ => (-self.n_v).clamp(-step, step),
        }
    }
}

/// The step between `good_end` (inclusive) and `bad` (exclusive) nearest `bad` for
/// which `ok` holds, `ok` being monotone (true from `good_end` up to some point);
/// `None` when it fails at `good_end`.
fn search(good_end: i64, bad: i64, ok: impl Fn(i64) -> bool) -> Option<i64> {
    if !ok(good_end) {
        return None;
    }
    let (mut good, mut bad) = (good_end, bad);
    while (bad - good).abs() > 1 {
        let mid = good + (bad - good) / 2;
        if ok(mid) {
            good = mid;
        } else {
            bad = mid;
        }
    }
    Some(good)
}

/// Rounds to the nearest integer (halves away from zero); `as` saturates and maps NaN
/// to 0, so no value panics.
#[must_use]
pub fn round_i(x: f64) -> i64 {
    truncate(if x >= 0.0 { x + 0.5 } else { x - 0.5 })
}

/// `y as i64`: towards zero, saturating, NaN to 0.
#[must_use]
pub fn truncate(y: f64) -> i64 {
    // Within ±2³¹ (every step of the rate limiter, the lowering allowance in position
    // units) `as i32` truncates as `as i64` does, in one hardware conversion where
    // `as i64` is the soft `__aeabi_d2lz` on the Cortex-M7.
    if libm::fabs(y) < 2_147_483_648.0 {
        i64::from(y as i32)
    } else {
        truncate_wide(y)
    }
}

/// `libm::ceil(y) as i64`, without `ceil`'s bit manipulations: the truncation, plus one
/// where it lies below `y` (saturating, NaN to 0, as `as` does).
#[must_use]
pub fn ceil_i(y: f64) -> i64 {
    let t = truncate(y);
    if i64_to_f64(t) < y {
        t.saturating_add(1)
    } else {
        t
    }
}

/// `libm::floor(y) as i64`, as [`ceil_i`].
#[must_use]
pub fn floor_i(y: f64) -> i64 {
    let t = truncate(y);
    if i64_to_f64(t) > y {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// `y as i64` (the soft `__aeabi_d2lz`), in a call of its own: inlined, the compiler
/// made it unconditional in [`step`] (both conversions, then a choice), and every cycle
/// paid for the soft one.
#[cold]
#[inline(never)]
fn truncate_wide(y: f64) -> i64 {
    y as i64
}

/// One cycle of a group of `W` axes: each towards its target speed `targets[i]` (in its
/// velocity quanta) along the straight line in speed, each step within ±127 and within
/// the braking curve of `bounds[i]`. Returns the steps `k` and leaves the axes after
/// the cycle.
pub fn step<const W: usize>(
    axes: &mut [Axis; W],
    targets: [f64; W],
    bounds: [(i64, i64); W],
) -> [i8; W] {
    let step = f64::from(MAX_STEP);
    // The remaining change of the ideal speed and the common scale that keeps every
    // axis within ±127 quanta per cycle. Each speed converted once.
    let mut largest = 0.0_f64;
    let mut speed = [0.0; W];
    let mut delta = [0.0; W];
    for (((d, s), a), t) in delta
        .iter_mut()
        .zip(speed.iter_mut())
        .zip(axes.iter())
        .zip(targets)
    {
        *s = i64_to_f64(a.n_v);
        *d = t - (*s + a.carry);
        largest = largest.max(libm::fabs(*d));
    }
    // The ideal speed after the cycle; exactly the target once it is reached. The scale's
    // divide only where it is needed: written as a choice of two values, it was computed
    // every cycle (a double divide holds the Cortex-M7's FPU for about 30 cycles).
    let mut ideal = targets;
    if largest > step {
        let scale = step / largest;
        if scale < 1.0 {
            for (((i, s), a), d) in ideal.iter_mut().zip(speed).zip(axes.iter()).zip(delta) {
                *i = s + a.carry + scale * d;
            }
        }
    }
    let mut ks = [0_i8; W];
    for (((a, k_out), (ideal, s)), b) in axes
        .iter_mut()
        .zip(ks.iter_mut())
        .zip(ideal.into_iter().zip(speed))
        .zip(bounds)
    {
        let wanted = round_i(ideal - s).clamp(-i64::from(MAX_STEP), i64::from(MAX_STEP));
        let k = a.braked(wanted, b);
        a.carry = if k == wanted {
            ideal - i64_to_f64(a.n_v + k)
        } else {
            0.0
        };
        let (n_v, n_p) = a.after(k);
        a.n_v = n_v;
        a.n_p = n_p;
        *k_out = k as i8;
    }
    ks
}

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing, clippy::unwrap_used)]
    extern crate std;
    use std::vec;

    use super::*;

    /// `ceil_i` and `floor_i` are `libm::ceil(y) as i64` and `libm::floor(y) as i64`:
    /// random values over many magnitudes, integers and their neighbours, the ends of
    /// `i64`, infinities and NaN.
    #[test]
    fn integer_ceil_and_floor_are_the_casts() {
        let mut seed = 5_u64;
        let mut values = vec![
            0.0,
            -0.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            9.3e18,
            -9.3e18,
            9.223_372_036_854_775e18,
            -9.223_372_036_854_776e18,
            2_147_483_647.5,
            -2_147_483_648.5,
        ];
        for _ in 0..100_000 {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            let unit = (seed >> 11) as f64 / (1_u64 << 53) as f64 - 0.5;
            let y = unit * 10f64.powi(((seed >> 3) % 22) as i32 - 3);
            let whole = libm::round(y);
            values.extend([
                y,
                whole,
                libm::nextafter(whole, f64::INFINITY),
                libm::nextafter(whole, f64::NEG_INFINITY),
            ]);
        }
        for y in values {
            assert_eq!(ceil_i(y), libm::ceil(y) as i64, "ceil {y:e}");
            assert_eq!(floor_i(y), libm::floor(y) as i64, "floor {y:e}");
        }
    }

    /// The closed form against the cycles of a full-deceleration stop, summed.
    #[test]
    fn brake_is_the_sum_of_the_stopping_cycles() {
        for n0 in 0..2000_i64 {
            let mut a = Axis {
                n_v: n0,
                ..Axis::REST
            };
            while a.n_v > 0 {
                let k = -a.n_v.min(127);
                (a.n_v, a.n_p) = a.after(k);
            }
            assert_eq!(a.n_p, brake(n0), "n = {n0}");
        }
    }

    /// The continuous bound the docs publish holds: `B(n) δp ≤ v²/(2A) + v h/2`, i.e.
    /// in units `B(n) ≤ n²/127 + n`.
    #[test]
    fn brake_within_the_published_bound() {
        for n in 0..100_000_i64 {
            assert!(brake(n) * 127 <= n * n + 127 * n, "n = {n}");
        }
    }

    /// Held at full demand into a limit: ends at rest exactly at or inside it, having
    /// never passed it; the opposite demand is then granted at once.
    #[test]
    fn a_demand_held_into_a_limit_ends_at_rest_inside() {
        for hi in [0_i64, 1, 5, 127, 1000, 54_321, 1_000_000] {
            for target in [3.0, 127.0, 500.0, 20_000.0] {
                let mut axes = [Axis::REST];
                let mut last = i64::MIN;
                let cycles = 20_000 + (2 * hi) as usize / target as usize;
                for _ in 0..cycles {
                    step(&mut axes, [target], [(-10, hi)]);
                    assert!(axes[0].n_p + brake(axes[0].n_v) <= hi);
                    assert!(axes[0].n_p <= hi);
                    last = axes[0].n_p;
                }
                assert_eq!(axes[0].n_v, 0, "hi {hi} target {target}");
                assert!(
                    hi - last < 2 * 127 + 2,
                    "stopped {} short of {hi}",
                    hi - last
                );
                let k = step(&mut axes, [-target], [(-1_000_000, hi)]);
                assert!(k[0] < 0, "driving away is granted");
            }
        }
    }

    /// A diagonal demand: the speeds stay on the straight line within half a quantum
    /// (plus one while a step is clamped), and the stop ends at exactly zero.
    #[test]
    fn a_vector_demand_keeps_its_direction_and_stops_exactly() {
        let far = (-i64::MAX / 4, i64::MAX / 4);
        let mut axes = [Axis::REST; 2];
        let target = [20_000.3, -7_100.7];
        for _ in 0..400 {
            step(&mut axes, target, [far; 2]);
            let (x, y) = (axes[0].n_v as f64, axes[1].n_v as f64);
            // Distance of (x, y) from the line through 0 and the target.
            let n = (target[0] * target[0] + target[1] * target[1]).sqrt();
            let across = (x * target[1] - y * target[0]).abs() / n;
            assert!(across <= 1.0, "{x}, {y}: {across} quanta off the line");
        }
        assert_eq!((axes[0].n_v, axes[1].n_v), (20_000, -7_101));
        for _ in 0..400 {
            step(&mut axes, [0.0, 0.0], [far; 2]);
        }
        assert_eq!((axes[0].n_v, axes[1].n_v), (0, 0));
        assert_eq!((axes[0].carry, axes[1].carry), (0.0, 0.0));
    }

    #[test]
    fn steps_stay_within_the_limit() {
        let far = (-i64::MAX / 4, i64::MAX / 4);
        let mut axes = [Axis::REST; 3];
        let mut seed = 12_345_u64;
        for _ in 0..10_000 {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            let t = [
                ((seed >> 11) % 40_001) as f64 - 20_000.0,
                ((seed >> 23) % 401) as f64 - 200.0,
                0.5,
            ];
            let k = step(&mut axes, t, [far; 3]);
            assert!(k.iter().all(|k| i32::from(*k).abs() <= MAX_STEP));
        }
    }

    /// The 32-bit path of the rounding is the 64-bit conversion's: around ±2³¹, halves,
    /// and random values of every size.
    #[test]
    fn rounding_in_32_bits_is_the_64_bit_rounding() {
        let reference = |x: f64| {
            if x >= 0.0 {
                (x + 0.5) as i64
            } else {
                (x - 0.5) as i64
            }
        };
        let edge = 2_147_483_648.0_f64;
        for x in [0.0, -0.0, 0.5, -0.5, 1.5, -1.5, 126.5, -127.49] {
            assert_eq!(round_i(x), reference(x), "{x}");
        }
        for d in [-1.5, -1.0, -0.5, -0.25, 0.0, 0.25, 0.5, 1.0] {
            for x in [edge + d, -edge + d, edge - 0.5 + d, -edge + 0.5 + d] {
                assert_eq!(round_i(x), reference(x), "{x}");
            }
        }
        let mut seed = 5_u64;
        for _ in 0..100_000 {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            let scale = 2.0_f64.powi((seed % 70) as i32 - 5);
            let x = ((seed >> 11) as f64 / (1_u64 << 53) as f64 - 0.5) * scale;
            assert_eq!(round_i(x), reference(x), "{x}");
        }
    }

    /// The 32-bit truncation is `as i64` around ±2³¹, at the edges and for random values.
    #[test]
    fn truncating_in_32_bits_is_as_i64() {
        let check = |x: f64| assert_eq!(truncate(x), x as i64, "{x}");
        let edge = 2_147_483_648.0_f64;
        for x in [
            0.0,
            -0.0,
            0.99,
            -0.99,
            f64::NAN,
            f64::INFINITY,
            -f64::INFINITY,
        ] {
            check(x);
        }
        for d in [-1.5, -1.0, -0.5, 0.0, 0.5, 1.0] {
            check(edge + d);
            check(-edge + d);
        }
        let mut seed = 17_u64;
        for _ in 0..100_000 {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            let scale = 2.0_f64.powi((seed % 70) as i32 - 5);
            check(((seed >> 11) as f64 / (1_u64 << 53) as f64 - 0.5) * scale);
        }
    }

    #[test]
    fn rounding_is_defined_for_every_value() {
        assert_eq!(round_i(2.5), 3);
        assert_eq!(round_i(-2.5), -3);
        assert_eq!(round_i(f64::NAN), 0);
        assert_eq!(round_i(f64::INFINITY), i64::MAX);
    }
}
