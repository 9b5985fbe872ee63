//! The discrete half of the filters: moving averages and zero-vibration pairs applied to
//! the rate limiter's accelerations, exactly, at a cost independent of their length.
//!
//! The rate limiter's acceleration `a₀(t)` is constant over each cycle, `a₀ = k δa` on
//! `[t_n, t_n + h)`. A moving average over a window of `m` cycles, `B(mh)`, is the
//! discrete mean of the last `m` values followed by a box of one cycle
//! (`B(mh) = (1/m) Σ_{j<m} δ_{jh} ∗ B(h)`); a zero-vibration pair `½(δ₀ + δ_{mh})` is
//! discrete already. So the filtered acceleration is a cardinal B-spline of degree `q`
//! (the number of windows) whose coefficients are the discrete filter's output
//! ([`crate::operator::piece`] evaluates it):
//!
//! ```text
//! c[n] = D(z) k[n] · δa,     D(z) = Π_i (1 − z^{−m_i}) / (m_i (1 − z^{−1})) · Π_j (1 + z^{−m_j})/2.
//! ```
//!
//! `D` is computed as its numerator — a handful of taps into a ring of past `k`
//! ([`Taps`], [`Ring`]) — followed by `q` running sums. Everything is an integer: the
//! running sums are exact, so once the ring holds only zeros the output is exactly
//! zero (no drift, no creep), and the numerator never has more than 16 taps however
//! long the windows are.

/// `x as f64`, bit for bit (rounded to nearest, ties to even), from two 32-bit halves:
/// `hi·2³² + lo` is exact in the sum's operands and rounded once by the addition. The
/// Cortex-M7's FPU converts 32-bit integers only, so `as f64` on an `i64` is a call of
/// the soft `__aeabi_l2d` (about 20 instructions; 11 % of the 3D generator's estimated
/// cycles, `cargo xtask cycles scenes/crane3d/crane3d-manual.toml`); this is two
/// conversions, a multiply and an add. The rate limiter's and the filter's integers go
/// through it every cycle.
#[must_use]
#[inline]
pub fn i64_to_f64(x: i64) -> f64 {
    // Within 32 bits (every speed, step and filter value of a crane, most positions): one
    // hardware conversion, the same value.
    if let Ok(small) = i32::try_from(x) {
        return f64::from(small);
    }
    let hi = (x >> 32) as i32;
    let lo = x as u32;
    f64::from(hi) * 4_294_967_296.0 + f64::from(lo)
}

/// `x as f64`, the same value: in one hardware conversion where it fits 32 bits (every
/// filter's normalisation here), where `as f64` on a `u64` is the soft `__aeabi_ul2d` on
/// the Cortex-M7, which a motion's start called.
#[must_use]
#[inline]
pub fn u64_to_f64(x: u64) -> f64 {
    match u32::try_from(x) {
        Ok(small) => f64::from(small),
        Err(_) => wide_u64_to_f64(x),
    }
}

/// `x as f64` out of line (see [`u64_to_f64`]): inlined, the soft conversion could be
/// made unconditional, as `as i64` once was in the rate limiter.
#[cold]
#[inline(never)]
fn wide_u64_to_f64(x: u64) -> f64 {
    x as f64
}

/// Most taps of a filter's numerator: four factors, `2⁴` terms before merging.
pub const MAX_TAPS: usize = 16;

/// Most windows (running sums) of one filter: the hoist's four.
pub const MAX_WINDOWS: usize = 4;

/// One factor of the numerator (the zero-vibration pairs are added by
/// [`Taps::with_pairs`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Factor {
    /// A moving average over `m` cycles: `(1 − z^{−m})`, with one running sum and `1/m`.
    Window(usize),
}

/// The numerator `Σ w_i z^{−d_i}` of a filter: delays in cycles and integer weights.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Taps {
    delay: [u16; MAX_TAPS],
    /// At most 6 in size (the binomial coefficients of four windows).
    weight: [i8; MAX_TAPS],
    len: u8,
    /// How many factors are windows: the running sums after the taps.
    windows: u8,
    /// The terms of the windows alone: the first ones ([`Taps::with_pairs`] appends).
    unpaired: u8,
    /// How many pairs [`Taps::with_pairs`] multiplied in (each doubled `norm`).
    pairs: u8,
    /// `Π m_i · 2^pairs`: the factors' normalisation.
    norm: u64,
}

impl Taps {
    /// The product of the windows `factors` (at most four; further ones are ignored, and
    /// the generator never passes more): equal delays merged, zero weights dropped.
    #[must_use]
    pub fn new(factors: &[Factor]) -> Self {
        let mut delay = [0_u16; MAX_TAPS];
        let mut weight = [0_i8; MAX_TAPS];
        if let Some(w) = weight.first_mut() {
            *w = 1;
        }
        let mut len = 1;
        let mut windows = 0;
        let mut norm: u64 = 1;
        for f in factors.iter().take(MAX_WINDOWS) {
            let Factor::Window(m) = *f;
            let sign = -1;
            windows += 1;
            norm = norm.saturating_mul(m as u64);
            // Each existing term once as it is and once delayed by m with the sign (the
            // existing terms as they were before this factor).
            let (old_delay, old_weight, old) = (delay, weight, len);
            for (&d, &w) in old_delay.iter().zip(old_weight.iter()).take(old) {
                let shifted = d.saturating_add(u16::try_from(m).unwrap_or(u16::MAX));
                len = add_term(&mut delay, &mut weight, len, shifted, sign * w);
            }
        }
        Self {
            delay,
            weight,
            len: len as u8,
            windows,
            unpaired: len as u8,
            pairs: 0,
            norm,
        }
    }

    /// These taps without the pairs [`Taps::with_pairs`] multiplied in: the windows'
    /// taps as [`Taps::new`] made them, without merging them again. What a motion's start
    /// retunes the horizontal filter from (its `Taps::new` was about a quarter of the
    /// start's retuning, `cargo xtask cycles`' profile). `norm` halved per pair: exact
    /// while it did not saturate (two windows of at most `u16::MAX` cycles and two pairs
    /// stay below 2³⁴).
    #[must_use]
    pub fn without_pairs(&self) -> Self {
        let mut out = *self;
        let len = usize::from(self.unpaired);
        for (d, w) in out.delay.iter_mut().zip(out.weight.iter_mut()).skip(len) {
            *d = 0;
            *w = 0;
        }
        out.len = self.unpaired;
        out.norm = self.norm.checked_shr(u32::from(self.pairs)).unwrap_or(0);
        out.pairs = 0;
        out
    }

    /// These taps times zero-vibration pairs with the delays `pairs` (as many as fit
    /// [`MAX_TAPS`]), without merging equal delays: a tap twice at one delay sums the
    /// same. The cheap way to the horizontal filter when a motion starts (the windows'
    /// taps merged once, the pairs' delays new each time).
    #[must_use]
    pub fn with_pairs(&self, pairs: &[usize]) -> Self {
        let mut out = *self;
        for m in pairs {
            let len = usize::from(out.len);
            if 2 * len > MAX_TAPS {
                break;
            }
            let shift = u16::try_from(*m).unwrap_or(u16::MAX);
            // Indexed, in place: term `i` is copied to `len + i` (the terms read are never
            // the ones written). Written with iterators over copies of both arrays, it was
            // compiled to those copies and a loop of bounds checks, once per motion's
            // start.
            for i in 0..len {
                let (Some(&d), Some(&w)) = (out.delay.get(i), out.weight.get(i)) else {
                    break;
                };
                if let (Some(sd), Some(sw)) =
                    (out.delay.get_mut(len + i), out.weight.get_mut(len + i))
                {
                    *sd = d.saturating_add(shift);
                    *sw = w;
                }
            }
            out.len = (2 * len) as u8;
            out.norm = out.norm.saturating_mul(2);
            out.pairs = out.pairs.saturating_add(1);
        }
        out
    }

    /// The longest delay, in cycles.
    #[must_use]
    pub fn longest(&self) -> usize {
        self.terms().map(|(d, _)| d).max().unwrap_or(0)
    }

    /// How many running sums follow the taps (the spline's degree).
    #[must_use]
    pub fn windows(&self) -> usize {
        usize::from(self.windows)
    }

    /// `Π m_i · 2^pairs`.
    #[must_use]
    pub fn norm(&self) -> u64 {
        self.norm
    }

    /// The terms `(delay, weight)`.
    pub fn terms(&self) -> impl Iterator<Item = (usize, i64)> + '_ {
        self.delay
            .iter()
            .zip(self.weight.iter())
            .take(usize::from(self.len))
            .map(|(d, w)| (usize::from(*d), i64::from(*w)))
    }
}

/// Adds `w z^{−d}` to the sparse polynomial of `len` terms; returns the new length.
fn add_term(
    delay: &mut [u16; MAX_TAPS],
    weight: &mut [i8; MAX_TAPS],
    len: usize,
    d: u16,
    w: i8,
) -> usize {
    if let Some(i) = delay.iter().take(len).position(|x| *x == d) {
        if let Some(slot) = weight.get_mut(i) {
            *slot += w;
        }
        return len;
    }
    match (delay.get_mut(len), weight.get_mut(len)) {
        (Some(ds), Some(ws)) => {
            *ds = d;
            *ws = w;
            len + 1
        }
        _ => len,
    }
}

/// The last `R` cycles' acceleration steps of a group of `W` axes, one byte each.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ring<const W: usize, const R: usize> {
    cells: [[i8; W]; R],
    /// Where the newest cycle is.
    head: usize,
    /// How many of the newest cycles hold what was pushed since the ring was last
    /// forgotten (up to `R`): older cells read as zero, so forgetting the history needs
    /// no clearing (the start of a motion, the generator's most expensive cycle, would
    /// otherwise write every cell).
    valid: usize,
}

impl<const W: usize, const R: usize> Ring<W, R> {
    /// All zero: a history at rest.
    #[must_use]
    #[inline(always)]
    pub fn new() -> Self {
        Self {
            cells: [[0; W]; R],
            head: 0,
            valid: 0,
        }
    }

    /// Appends a cycle, forgetting the oldest.
    pub fn push(&mut self, k: [i8; W]) {
        self.head = if self.head + 1 >= R { 0 } else { self.head + 1 };
        if let Some(cell) = self.cells.get_mut(self.head) {
            *cell = k;
        }
        if self.valid < R {
            self.valid += 1;
        }
    }

    /// The cycle `delay` cycles before the newest (zero beyond what was pushed since the
    /// ring was last forgotten).
    #[must_use]
    pub fn get(&self, delay: usize) -> [i8; W] {
        if delay >= self.valid {
            return [0; W];
        }
        let i = if delay <= self.head {
            self.head - delay
        } else {
            self.head + R - delay
        };
        self.cells.get(i).copied().unwrap_or([0; W])
    }

    /// Forgets every cycle: from now on the history reads as all zero (a history at rest).
    pub fn forget(&mut self) {
        self.valid = 0;
    }
}

impl<const W: usize, const R: usize> Default for Ring<W, R> {
    fn default() -> Self {
        Self::new()
    }
}

/// `(−1)^j C(i, j)` (zero for `j > i`): row `i` turns backward differences `∇^j S[n]`
/// into `S[n − i]` (the tests' reading of the differences; the pieces fold it into their
/// B-spline table).
#[cfg(test)]
pub const BACKWARD: [[i64; MAX_WINDOWS + 1]; MAX_WINDOWS + 1] = [
    [1, 0, 0, 0, 0],
    [1, -1, 0, 0, 0],
    [1, -2, 1, 0, 0],
    [1, -3, 3, -1, 0],
    [1, -4, 6, -4, 1],
];

/// The last `q + 1` outputs `S[n − i]`, newest first, from the backward differences
/// `∇^j S[n]`: `S[n − i] = Σ_j (−1)^j C(i, j) ∇^j S[n]`.
#[cfg(test)]
#[must_use]
pub fn values(nabla: &[i64; MAX_WINDOWS + 1], q: usize) -> [i64; MAX_WINDOWS + 1] {
    let mut out = [0_i64; MAX_WINDOWS + 1];
    for (oi, row) in out.iter_mut().zip(BACKWARD.iter()).take(q + 1) {
        *oi = nabla
            .iter()
            .zip(row)
            .fold(0_i64, |acc, (n, b)| acc.wrapping_add(b.wrapping_mul(*n)));
    }
    out
}

/// The running sums after the taps, per axis: the discrete filter's state besides the
/// ring.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sums<const W: usize> {
    sums: [[i64; MAX_WINDOWS]; W],
}

impl<const W: usize> Sums<W> {
    /// At rest.
    pub const REST: Self = Self {
        sums: [[0; MAX_WINDOWS]; W],
    };

    /// One cycle: the taps on the ring (whose newest cycle is this one's), then the
    /// `q` running sums. Returns per axis the backward differences of the filter's
    /// output `S = D(z) k` times the normalisation ([`Taps::norm`]), exact integers:
    /// the running sums hold them — `∇^j S[n]` is the `(q−j)`-th sum, `∇^q S[n]` the
    /// taps' output — so the B-spline's coefficients need no history of their own
    /// ([`values`] turns them into `S[n − i]`). Wrapping arithmetic: the true values are
    /// bounded (127 · norm and their differences), so the results are exact whatever the
    /// intermediate sums.
    pub fn advance<const R: usize>(
        &mut self,
        ring: &Ring<W, R>,
        taps: &Taps,
    ) -> [[i64; MAX_WINDOWS + 1]; W] {
        let q = taps.windows();
        // The taps' sum in 32 bits: at most 16 taps, each an i8 weight times an i8 step
        // (|w k| ≤ 128², the sum within ±2¹⁸), so it is the 64-bit sum exactly, in
        // fewer Cortex-M7 instructions.
        let mut x = [0_i32; W];
        for (&d, &w) in taps
            .delay
            .iter()
            .zip(taps.weight.iter())
            .take(usize::from(taps.len))
        {
            for (xi, ki) in x.iter_mut().zip(ring.get(usize::from(d))) {
                *xi = xi.wrapping_add(i32::from(w).wrapping_mul(i32::from(ki)));
            }
        }
        let mut out = [[0_i64; MAX_WINDOWS + 1]; W];
        for ((s, xi), nabla) in self
            .sums
            .iter_mut()
            .zip(x.map(i64::from))
            .zip(out.iter_mut())
        {
            let mut carry = xi;
            for sum in s.iter_mut().take(q) {
                *sum = sum.wrapping_add(carry);
                carry = *sum;
            }
            for (j, n) in nabla.iter_mut().enumerate().take(q + 1) {
                *n = match q.checked_sub(j + 1) {
                    Some(i) => s.get(i).copied().unwrap_or(0),
                    None => xi,
                };
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing, clippy::unwrap_used)]
    use super::*;

    /// The taps and sums against the filter applied directly: moving means and pairs on a
    /// random integer sequence, in f64 from the definition.
    #[test]
    fn taps_and_sums_are_the_cascade_of_means_and_pairs() {
        let taps = Taps::new(&[Factor::Window(7), Factor::Window(3)]).with_pairs(&[11, 5]);
        assert_eq!(taps.windows(), 2);
        assert_eq!(taps.norm(), 7 * 3 * 4);
        assert_eq!(taps.longest(), 7 + 3 + 11 + 5);
        let mut ring = Ring::<1, 64>::new();
        let mut sums = Sums::<1>::REST;
        let mut seed = 7_u64;
        let mut input = [0.0_f64; 500];
        let mut outputs = [0_i64; 500];
        for n in 0..500_usize {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            let k = if n < 400 {
                ((seed >> 33) % 255) as i64 - 127
            } else {
                0
            };
            input[n] = k as f64;
            ring.push([k as i8]);
            let all = values(&sums.advance(&ring, &taps)[0], taps.windows());
            let out = all[0] as f64 / taps.norm() as f64;
            // The earlier outputs, read off the sums, are the earlier cycles' own.
            for (i, earlier) in all.iter().enumerate().take(3).skip(1) {
                if n >= i {
                    assert_eq!(*earlier, outputs[n - i], "n {n}: S[n − {i}]");
                }
            }
            outputs[n] = all[0];
            // Direct: mean over 7, then mean over 3, then the pairs.
            let x = |i: isize| -> f64 {
                if i < 0 {
                    0.0
                } else {
                    input[i as usize]
                }
            };
            let mean7 = |i: isize| (0..7).map(|j| x(i - j)).sum::<f64>() / 7.0;
            let mean3 = |i: isize| (0..3).map(|j| mean7(i - j)).sum::<f64>() / 3.0;
            let pair11 = |i: isize| 0.5 * (mean3(i) + mean3(i - 11));
            let n = n as isize;
            let direct = 0.5 * (pair11(n) + pair11(n - 5));
            assert!((out - direct).abs() < 1e-12, "n {n}: {out} vs {direct}");
            if n > 400 + 30 {
                assert_eq!(out, 0.0, "exactly zero once the ring has passed");
            }
        }
    }

    /// The split conversion is `as f64` for every i64: the edges, powers of two and their
    /// neighbours (ties at 2⁵³ and above), and a million random values of every size.
    #[test]
    fn the_split_conversion_is_as_f64() {
        let check = |x: i64| assert_eq!(i64_to_f64(x).to_bits(), (x as f64).to_bits(), "{x}");
        for x in [0, 1, -1, i64::MAX, i64::MIN, i64::MIN + 1, i64::MAX - 1] {
            check(x);
        }
        for b in 0..63 {
            for d in -3..=3 {
                check((1_i64 << b).wrapping_add(d));
                check((-(1_i64 << b)).wrapping_add(d));
            }
        }
        let mut seed = 11_u64;
        for _ in 0..1_000_000 {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let shift = (seed % 64) as u32;
            check((seed as i64) >> shift);
        }
    }

    /// The windows' taps taken back from a filter with pairs are the windows' own, field
    /// for field, whatever the pairs.
    #[test]
    fn the_windows_come_back_without_their_pairs() {
        for (b1, b2) in [(20, 20), (7, 3), (1, 65_535)] {
            let windows = Taps::new(&[Factor::Window(b1), Factor::Window(b2)]);
            for pairs in [&[][..], &[31], &[31, 17], &[5, 5]] {
                let paired = windows.with_pairs(pairs);
                assert_eq!(paired.without_pairs(), windows, "{b1}, {b2}: {pairs:?}");
            }
        }
    }

    /// The 32-bit conversion is `as f64` for every u64 size.
    #[test]
    fn the_unsigned_conversion_is_as_f64() {
        let check = |x: u64| assert_eq!(u64_to_f64(x).to_bits(), (x as f64).to_bits(), "{x}");
        for b in 0..64 {
            for d in [0, 1, 2, 3] {
                check((1_u64 << b).wrapping_add(d));
                check((1_u64 << b).wrapping_sub(d));
            }
        }
        check(u64::MAX);
    }

    #[test]
    fn equal_windows_merge_into_binomial_taps() {
        let taps = Taps::new(&[Factor::Window(10); 4]);
        let mut terms = [(0, 0); 5];
        for (slot, t) in terms.iter_mut().zip(taps.terms()) {
            *slot = t;
        }
        assert_eq!(taps.terms().count(), 5);
        assert_eq!(terms, [(0, 1), (10, -4), (20, 6), (30, -4), (40, 1)]);
    }

    #[test]
    fn ring_reads_back_what_was_pushed() {
        let mut ring = Ring::<1, 5>::new();
        for k in 1..=12 {
            ring.push([k]);
        }
        let back: [i8; 6] = core::array::from_fn(|d| ring.get(d)[0]);
        assert_eq!(back, [12, 11, 10, 9, 8, 0]);
        // Forgotten: zero everywhere, then only what came since.
        ring.forget();
        assert!((0..6).all(|d| ring.get(d) == [0]));
        ring.push([7]);
        ring.push([8]);
        let back: [i8; 4] = core::array::from_fn(|d| ring.get(d)[0]);
        assert_eq!(back, [8, 7, 0, 0]);
    }
}
