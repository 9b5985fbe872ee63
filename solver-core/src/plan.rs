//! Trajectories that change while the inverse model runs (moves on command, a stop).
//!
//! A [`Plan`] is the desired output over time: at rest, then a move, possibly another
//! move queued behind it, or a stop. It implements [`Trajectory`], so a model driven by
//! a plan needs nothing new. Replanning only ever changes the future: a move is
//! appended at or after the end of what is planned, a stop starts at a time that has not
//! been stepped yet and continues the current trajectory with all derivatives 0..=n.
//! BDF's history and Radau's last step therefore stay valid, and the inputs — which
//! contain `z_d⁗` — stay continuous across every change.
//!
//! The stop is a two-point Hermite polynomial of degree 2n+1 ([`Hermite`]): its value
//! and first n derivatives match the current trajectory at the start, and it ends at
//! rest. It is constructed in Bernstein form — the first and last n+1 Bernstein
//! coefficients follow from the end derivatives by triangular recursions — and
//! evaluated in Bernstein form too, as the moves' smooth step is
//! ([`crate::trajectory`]): each derivative from the differences of those coefficients,
//! summed over the Bernstein basis (all terms positive). Its monomial coefficients are
//! large and alternate (|c_k| summing to 2·10⁵ for an n = 8 stop, for values in
//! [0, 1]): Horner's rule on them lost digits towards the stop's rest — up to 6·10⁻¹⁰
//! in σ and 9·10⁻⁹ in σ̈ against de Casteljau's evaluation, as noise from one sample to
//! the next — which the hook-and-load crane's index-5 inverse model differences four
//! times into its set points: near the rest of its stops BDF4's trolley set points
//! alternated by up to ±0.02 m/s, over 3 m/s² from one cycle to the next (fault 2,
//! issue 29). The test `a_stop_is_smooth_to_rounding_up_to_its_rest` pins the noise.

use nalgebra::SVector;

use crate::error::{check_positive, Error, Result};
use crate::scalar::{c, to_f64, Real};
use crate::trajectory::{along, check_smoothness, PointToPoint, Trajectory, MAX_SMOOTHNESS};

const MAX_COEFFS: usize = 2 * MAX_SMOOTHNESS + 2;

/// A polynomial segment per output axis on `[t_start, t_start + duration]`, at rest after it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hermite<T: Real, const NZ: usize> {
    t_start: T,
    duration: T,
    /// `1/duration`: the chain rule's factor per order.
    inv_duration: T,
    n: usize,
    /// Bernstein coefficients in τ of the way still to go, per axis:
    /// `p(τ) − p(1) = Σ δ_k C(m,k) τ^k (1−τ)^(m−k)`, `m = 2n+1`; `δ_k = 0` for `k > n`
    /// (all derivatives vanish at the end), kept with one zero after `δ_n`.
    bernstein: [[T; MAX_SMOOTHNESS + 2]; NZ],
    end: SVector<T, NZ>,
    /// Every axis's Bernstein coefficients run monotonically from its start value to its
    /// end: then (convex hull, and a derivative whose Bernstein coefficients are the
    /// differences) each axis moves monotonically from start to end and never beyond.
    monotone: bool,
}

fn sign(k: usize) -> f64 {
    if k.is_multiple_of(2) {
        1.0
    } else {
        -1.0
    }
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k.min(n)).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

fn falling(m: usize, j: usize) -> f64 {
    (0..j).fold(1.0, |acc, i| acc * (m - i) as f64)
}

/// The first `n + 1` Bernstein coefficients of a polynomial of degree `m = 2n + 1` on
/// `τ ∈ [0, 1]` whose derivatives at τ = 0 are `d[j]`, `j = 0..=n` (the rest zero):
/// `p^(j)(0) = m!/(m−j)! Σ_i (−1)^(j−i) C(j,i) β_i`, solved for `β_j` in turn.
fn start_bernstein(d: &[f64; MAX_SMOOTHNESS + 1], n: usize) -> [f64; MAX_COEFFS] {
    let m = 2 * n + 1;
    let mut beta = [0.0; MAX_COEFFS];
    for (j, dj) in d.iter().enumerate().take(n + 1) {
        let lower: f64 = beta
            .iter()
            .take(j)
            .enumerate()
            .map(|(i, b)| sign(j - i) * binomial(j, i) * b)
            .sum();
        if let Some(b) = beta.get_mut(j) {
            *b = dj / falling(m, j) - lower;
        }
    }
    beta
}

/// The nearest end at which a two-point Hermite polynomial of smoothness `n` starting
/// with the τ-derivatives `d` (`d[j] = z^(j)·T^j`) provably rises monotonically (its
/// Bernstein coefficients non-decreasing): the last of its first n+1 Bernstein
/// coefficients, if those rise — `None` if they do not (then no end makes it monotone).
fn nearest_rising_end(d: &[f64; MAX_SMOOTHNESS + 1], n: usize) -> Option<f64> {
    let beta = start_bernstein(d, n);
    let rising = beta
        .iter()
        .take(n + 1)
        .zip(beta.iter().skip(1).take(n))
        .all(|(a, b)| b >= a);
    rising.then(|| beta.get(n).copied().unwrap_or(f64::NAN))
}

impl<T: Real, const NZ: usize> Hermite<T, NZ> {
    /// The segment that starts at `t_start` with the derivatives `start[j] = z^(j)`,
    /// `j = 0..=n`, and comes to rest at `end` (all derivatives zero) after `duration`.
    pub fn new(
        t_start: T,
        duration: T,
        start: &[SVector<T, NZ>],
        end: SVector<T, NZ>,
    ) -> Result<Self> {
        let n = start.len().saturating_sub(1);
        check_smoothness(n)?;
        check_positive("segment duration", to_f64(duration))?;
        let ts = to_f64(t_start);
        if !ts.is_finite() {
            return Err(Error::NonFiniteParameter {
                name: "segment t_start",
                value: ts,
            });
        }
        let m = 2 * n + 1;
        let big_t = to_f64(duration);
        let mut bernstein = [[T::zero(); MAX_SMOOTHNESS + 2]; NZ];
        let mut monotone = true;
        for (axis, out) in bernstein.iter_mut().enumerate() {
            // Derivatives with respect to τ: z^(j) · T^j.
            let mut d = [0.0; MAX_SMOOTHNESS + 1];
            let mut t_power = 1.0;
            for (j, dj) in d.iter_mut().enumerate().take(n + 1) {
                let v = start
                    .get(j)
                    .and_then(|s| s.get(axis))
                    .map_or(f64::NAN, |v| to_f64(*v));
                *dj = v * t_power;
                t_power *= big_t;
            }
            let e = end.get(axis).map_or(f64::NAN, |v| to_f64(*v));
            if d.iter()
                .take(n + 1)
                .chain([e].iter())
                .any(|v| !v.is_finite())
            {
                return Err(Error::NonFiniteParameter {
                    name: "segment boundary",
                    value: f64::NAN,
                });
            }
            // The first n+1 Bernstein coefficients follow from the start; at τ = 1 all
            // derivatives vanish, so the last n+1 equal the end value.
            let mut beta = start_bernstein(&d, n);
            for b in beta.iter_mut().take(m + 1).skip(n + 1) {
                *b = e;
            }
            let rising = beta.first().is_none_or(|b0| e >= *b0);
            monotone &= beta
                .iter()
                .take(m + 1)
                .zip(beta.iter().skip(1).take(m))
                .all(|(a, b)| if rising { b >= a } else { b <= a });
            // Evaluated from the end: the coefficients of `p − p(1)`, zero after the
            // first n + 1, from the recursion without the start value (which would
            // leave its rounding, ~2^j ε|p(0)|, in every difference the derivatives are
            // summed from) less the travel.
            let origin = d.first().copied().unwrap_or(0.0);
            if let Some(d0) = d.first_mut() {
                *d0 = 0.0;
            }
            let travel = start_bernstein(&d, n);
            for (o, b) in out.iter_mut().zip(travel.iter()).take(n + 1) {
                *o = c(*b - (e - origin));
            }
        }
        Ok(Self {
            t_start,
            duration,
            inv_duration: T::one() / duration,
            n,
            bernstein,
            end,
            monotone,
        })
    }

    /// Whether every axis provably moves monotonically from its start value to its end,
    /// never beyond either (a sufficient test on the Bernstein coefficients: exact, no
    /// sampling).
    #[must_use]
    pub fn is_monotone(&self) -> bool {
        self.monotone
    }

    /// Where the segment comes to rest.
    #[must_use]
    pub fn end(&self) -> SVector<T, NZ> {
        self.end
    }

    /// The time at which it comes to rest.
    #[must_use]
    pub fn t_end(&self) -> T {
        self.t_start + self.duration
    }
}

impl<T: Real, const NZ: usize> Trajectory<T, NZ> for Hermite<T, NZ> {
    fn derivatives<const D: usize>(&self, t: T) -> [SVector<T, NZ>; D] {
        let mut out = [SVector::<T, NZ>::zeros(); D];
        let tau = (t - self.t_start) / self.duration;
        if tau >= T::one() {
            if let Some(v) = out.first_mut() {
                *v = self.end;
            }
            return out;
        }
        // Before its start a segment is only ever asked at its start (τ = 0).
        let tau = tau.max(T::zero());
        let m = 2 * self.n + 1;
        let s = T::one() - tau;
        let n = self.n;
        for (axis, delta) in self.bernstein.iter().enumerate() {
            // The j-th derivative is m!/(m−j)!/T^j Σ_i Δ^j δ_i B_{i,m−j}(τ), the value the
            // end plus that sum at j = 0. δ_i vanishes for i > n, so every Δ^j δ_i with
            // i > n does too: each order sums the first n + 1 terms at most. `diff` holds
            // Δ^j δ_0..=n, differenced in place from one order to the next (Δ^j δ_{n+1}
            // is 0).
            let mut diff = *delta;
            let mut scale = T::one();
            for (j, slot) in out.iter_mut().enumerate() {
                let Some(k) = m.checked_sub(j) else {
                    break;
                };
                let last = n.min(k);
                // Σ_{i ≤ last} Δ^j δ_i C(k, i) τ^i (1−τ)^(last−i) by Horner's rule in 1−τ
                // from i = 0 up, τ^i and C(k, i) carried along (the basis' weights all
                // positive, no table of powers), then times (1−τ)^(k−last). C(k, i) is
                // exact in integers (C(25, 12)·13 < 2³²; `checked_*` only so that no
                // panic is linked).
                let mut acc = T::zero();
                let mut tau_power = T::one();
                let mut binom: u32 = 1;
                let k32 = u32::try_from(k).unwrap_or(0);
                for (i, d) in (0u32..).zip(diff.iter().take(last + 1)) {
                    acc = acc * s + *d * c::<T>(f64::from(binom)) * tau_power;
                    tau_power *= tau;
                    // C(k, i + 1) = C(k, i) · (k − i) / (i + 1).
                    binom = binom
                        .checked_mul(k32.saturating_sub(i))
                        .and_then(|v| v.checked_div(i.saturating_add(1)))
                        .unwrap_or(0);
                }
                for _ in last..k {
                    acc *= s;
                }
                if let Some(v) = slot.get_mut(axis) {
                    *v = if j == 0 {
                        self.end.get(axis).copied().unwrap_or_else(T::zero) + acc
                    } else {
                        acc * scale
                    };
                }
                for i in 0..=last {
                    let next = diff.get(i + 1).copied().unwrap_or_else(T::zero);
                    if let Some(d) = diff.get_mut(i) {
                        *d = next - *d;
                    }
                }
                scale *= c::<T>(k as f64) * self.inv_duration;
            }
        }
        out
    }

    fn active_span(&self) -> (T, T) {
        (self.t_start, self.t_end())
    }

    fn smoothness(&self) -> usize {
        self.n
    }
}

/// A stop on a move's path: the move's timing law `σ(t)` (the fraction of the way from
/// its start to its target, [`PointToPoint::timing`]) re-timed from the stop's start
/// on, so that the load decelerates *along the same straight segment* and comes to
/// rest at `σ_end ≤ 1` — at or before the target in every axis, never past it.
///
/// The new timing is a two-point Hermite polynomial in σ ([`Hermite`] with one axis):
/// σ and its first n derivatives continue the move's, so the inputs (which contain
/// `z_d⁗`) stay continuous; it is accepted only if its Bernstein coefficients rise
/// monotonically ([`Stop::stays_on_path`]), which proves that σ never decreases and
/// never exceeds `σ_end` — no sampling involved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stop<T: Real, const NZ: usize> {
    from: SVector<T, NZ>,
    to: SVector<T, NZ>,
    /// `to − from`.
    delta: SVector<T, NZ>,
    timing: Hermite<T, 1>,
}

impl<T: Real, const NZ: usize> Stop<T, NZ> {
    /// Where the stop comes to rest.
    #[must_use]
    pub fn end(&self) -> SVector<T, NZ> {
        self.from + (self.to - self.from) * self.fraction()
    }

    /// The fraction of the stopped move's path at which it comes to rest (≤ 1).
    #[must_use]
    pub fn fraction(&self) -> T {
        self.timing.end().get(0).copied().unwrap_or_else(T::zero)
    }

    /// The time at which it comes to rest.
    #[must_use]
    pub fn t_end(&self) -> T {
        self.timing.t_end()
    }

    /// Whether the load provably stays on the stopped move's path between where it is
    /// at the stop's start and the stop's end (which is at or before the target): σ
    /// never decreases and never exceeds `σ_end ≤ 1`.
    #[must_use]
    pub fn stays_on_path(&self) -> bool {
        self.timing.is_monotone() && self.fraction() <= T::one()
    }

    /// The path's start and target (the stopped move's).
    #[must_use]
    pub fn path(&self) -> (SVector<T, NZ>, SVector<T, NZ>) {
        (self.from, self.to)
    }

    /// σ and its first `D − 1` derivatives at `t`.
    #[must_use]
    pub fn timing<const D: usize>(&self, t: T) -> [T; D] {
        let s: [SVector<T, 1>; D] = self.timing.derivatives(t);
        s.map(|v| v.get(0).copied().unwrap_or_else(T::zero))
    }
}

impl<T: Real, const NZ: usize> Trajectory<T, NZ> for Stop<T, NZ> {
    fn derivatives<const D: usize>(&self, t: T) -> [SVector<T, NZ>; D] {
        along(self.from, self.delta, &self.timing(t))
    }

    fn active_span(&self) -> (T, T) {
        self.timing.active_span()
    }

    fn smoothness(&self) -> usize {
        self.timing.smoothness()
    }
}

/// Where a stop takes over ([`Plan::stop_start`]): the instant, the straight path of the
/// segment running then, and its timing σ with its first n derivatives — everything a
/// stop of any duration and end is built from, computed once for a stop's search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StopStart<T: Real, const NZ: usize> {
    t: T,
    path: (SVector<T, NZ>, SVector<T, NZ>),
    sigma: [T; MAX_SMOOTHNESS + 1],
    /// The stop's smoothness: the moves' and [`Plan::stop_start`]'s `above`.
    n: usize,
}

impl<T: Real, const NZ: usize> StopStart<T, NZ> {
    /// The instant the stop takes over.
    #[must_use]
    pub fn t(&self) -> T {
        self.t
    }

    /// σ there: the fraction of the path already travelled.
    #[must_use]
    pub fn fraction(&self) -> T {
        self.sigma.first().copied().unwrap_or_else(T::zero)
    }

    /// σ̇ there, 1/s.
    #[must_use]
    pub fn rate(&self) -> T {
        self.sigma.get(1).copied().unwrap_or_else(T::zero)
    }

    /// The path's start and target.
    #[must_use]
    pub fn path(&self) -> (SVector<T, NZ>, SVector<T, NZ>) {
        self.path
    }

    /// The nearest end σ_rise at which a stop of `duration` provably never turns back
    /// (its first n+1 Bernstein coefficients, fixed by the start, rise; the end must be
    /// at least the last of them): `None` if no end makes a stop of that duration
    /// monotone.
    #[must_use]
    pub fn nearest_end(&self, duration: f64) -> Option<f64> {
        nearest_rising_end(&self.scaled(duration), self.n)
    }

    /// The stop of `duration` that comes to rest at the fraction `end` of the path.
    /// Check [`Stop::stays_on_path`] before using it.
    pub fn stop(&self, duration: T, end: T) -> Result<Stop<T, NZ>> {
        let start: [SVector<T, 1>; MAX_SMOOTHNESS + 1] = self.sigma.map(|v| SVector::from([v]));
        let (from, to) = self.path;
        Hermite::new(
            self.t,
            duration,
            start.get(..=self.n).unwrap_or(&start),
            SVector::from([end]),
        )
        .map(|timing| Stop {
            from,
            to,
            delta: to - from,
            timing,
        })
    }

    /// The τ-derivatives of σ for a stop of `duration`: `σ^(j) · duration^j`.
    fn scaled(&self, duration: f64) -> [f64; MAX_SMOOTHNESS + 1] {
        let mut d = [0.0; MAX_SMOOTHNESS + 1];
        let mut t_power = 1.0;
        for (dj, sj) in d.iter_mut().zip(self.sigma.iter()).take(self.n + 1) {
            *dj = to_f64(*sj) * t_power;
            t_power *= duration;
        }
        d
    }
}

/// One piece of a plan.
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub enum Segment<T: Real, const NZ: usize> {
    /// A rest-to-rest move.
    Move(PointToPoint<T, NZ>),
    /// A stop from motion, on the path of the move it stopped.
    Stop(Stop<T, NZ>),
}

impl<T: Real, const NZ: usize> Segment<T, NZ> {
    /// Start and end time of the segment's motion.
    pub fn span(&self) -> (T, T) {
        match self {
            Segment::Move(m) => m.active_span(),
            Segment::Stop(s) => s.active_span(),
        }
    }

    fn end(&self) -> SVector<T, NZ> {
        match self {
            Segment::Move(m) => m.end(),
            Segment::Stop(s) => s.end(),
        }
    }

    fn derivatives<const D: usize>(&self, t: T) -> [SVector<T, NZ>; D] {
        match self {
            Segment::Move(m) => m.derivatives(t),
            Segment::Stop(s) => s.derivatives(t),
        }
    }

    /// The straight path the segment moves along (start, target), and its timing law σ
    /// with its first `D − 1` derivatives at `t`.
    fn path_timing<const D: usize>(&self, t: T) -> ((SVector<T, NZ>, SVector<T, NZ>), [T; D]) {
        match self {
            Segment::Move(m) => ((m.start(), m.end()), m.timing(t)),
            Segment::Stop(s) => (s.path(), s.timing(t)),
        }
    }
}

/// The desired output over time: rest, the active segment, and one move queued behind it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plan<T: Real, const NZ: usize> {
    rest: SVector<T, NZ>,
    smoothness: usize,
    active: Option<Segment<T, NZ>>,
    queued: Option<PointToPoint<T, NZ>>,
}

impl<T: Real, const NZ: usize> Plan<T, NZ> {
    /// At rest at `position`; moves will have smoothness `n`.
    pub fn at_rest(position: SVector<T, NZ>, smoothness: usize) -> Result<Self> {
        check_smoothness(smoothness)?;
        if position.iter().any(|v| !to_f64(*v).is_finite()) {
            return Err(Error::NonFiniteParameter {
                name: "rest position",
                value: f64::NAN,
            });
        }
        Ok(Self {
            rest: position,
            smoothness,
            active: None,
            queued: None,
        })
    }

    /// The smoothness `n` of the moves and stops this plan builds.
    #[must_use]
    pub fn planned_smoothness(&self) -> usize {
        self.smoothness
    }

    /// Where the plan ends at rest (after everything planned).
    #[must_use]
    pub fn final_position(&self) -> SVector<T, NZ> {
        self.queued
            .as_ref()
            .map(PointToPoint::end)
            .or_else(|| self.active.as_ref().map(Segment::end))
            .unwrap_or(self.rest)
    }

    /// When everything planned has finished.
    #[must_use]
    pub fn end_time(&self) -> Option<T> {
        self.queued
            .as_ref()
            .map(|q| q.active_span().1)
            .or_else(|| self.active.as_ref().map(|a| a.span().1))
    }

    /// Whether a move is active at `t` (or a stop is running).
    #[must_use]
    pub fn is_moving(&self, t: T) -> bool {
        self.active.as_ref().is_some_and(|a| t < a.span().1) || self.queued.is_some()
    }

    /// Whether a move is queued behind the active one.
    #[must_use]
    pub fn has_queued(&self) -> bool {
        self.queued.is_some()
    }

    /// The active segment, if any.
    #[must_use]
    pub fn active(&self) -> Option<&Segment<T, NZ>> {
        self.active.as_ref()
    }

    /// Forgets segments that have finished by `t` (the queued move becomes active).
    pub fn retire(&mut self, t: T) {
        if let Some(a) = &self.active {
            if t >= a.span().1 {
                self.rest = a.end();
                self.active = self.queued.take().map(Segment::Move);
                if let Some(next) = &self.active {
                    if t >= next.span().1 {
                        self.rest = next.end();
                        self.active = None;
                    }
                }
            }
        }
    }

    /// A candidate move from where the plan ends to `target`, starting no earlier than
    /// `earliest` and after everything planned; not yet part of the plan.
    pub fn candidate(
        &self,
        target: SVector<T, NZ>,
        earliest: T,
        duration: T,
    ) -> Result<PointToPoint<T, NZ>> {
        let start = self
            .end_time()
            .map_or(earliest, |e| if e > earliest { e } else { earliest });
        PointToPoint::new(
            self.final_position(),
            target,
            start,
            duration,
            self.smoothness,
        )
    }

    /// Appends a move built by [`Plan::candidate`]: active if nothing is, else queued.
    /// Refuses a second queued move, or one that does not start where and after the plan ends.
    pub fn push(&mut self, next: PointToPoint<T, NZ>) -> Result<()> {
        let fits = next.start() == self.final_position()
            && self.end_time().is_none_or(|e| next.t_start() >= e);
        if !fits || self.queued.is_some() {
            return Err(Error::InvalidSetting {
                name: "plan",
                value: to_f64(next.t_start()),
            });
        }
        if self.active.is_some() {
            self.queued = Some(next);
        } else {
            self.active = Some(Segment::Move(next));
        }
        Ok(())
    }

    /// The segment the plan follows at `t`, if it moves then or later: the active one,
    /// or the queued move once the active one has ended.
    #[must_use]
    pub fn segment_at(&self, t: T) -> Option<Segment<T, NZ>> {
        let active = self.active?;
        match self.queued {
            Some(q) if t > active.span().1 => Some(Segment::Move(q)),
            _ => Some(active),
        }
    }

    /// Where a stop taking over at `t` (not yet stepped) starts: the path of the segment
    /// running at `t` and its timing σ with its derivatives there ([`StopStart`]), from
    /// which stops of any duration and end are built, `above` orders smoother than the
    /// moves (at most [`MAX_SMOOTHNESS`]). `None` when nothing moves at or after `t`.
    ///
    /// The derivative of the path that jumps where a stop of smoothness `n + above` takes
    /// over is the (n + above + 1)-th. With `above = 1` it is one beyond what the planar
    /// crane's drive accelerations contain, so a multistep scheme meets no jump in them
    /// (a jump in the (n+1)-th made BDF4's accelerations overshoot the checked ones by up
    /// to 8 %); the controller takes `above` per crane
    /// (`controller::crane::Crane::STOP_SMOOTHNESS_ABOVE_MOVES`).
    #[must_use]
    pub fn stop_start(&self, t: T, above: usize) -> Option<StopStart<T, NZ>> {
        let segment = self.segment_at(t)?;
        let (path, sigma) = segment.path_timing::<{ MAX_SMOOTHNESS + 1 }>(t);
        let n = self.smoothness.saturating_add(above).min(MAX_SMOOTHNESS);
        Some(StopStart { t, path, sigma, n })
    }

    /// Whether the segment running at `t` has not begun by then (a stop then simply
    /// drops it: the load is still at rest).
    #[must_use]
    pub fn not_started_at(&self, t: T) -> bool {
        self.segment_at(t).is_some_and(|s| t <= s.span().0)
    }

    /// Drops everything planned that has not begun by `t` — the queued move, and the
    /// active one too if it starts later — so that the plan rests where it is at `t`.
    pub fn cancel_from(&mut self, t: T) {
        // A queued move that has begun by `t` is running: it becomes the active one.
        self.retire(t);
        self.queued = None;
        if self.active.as_ref().is_some_and(|a| t <= a.span().0) {
            self.active = None;
        }
    }

    /// Drops the queued move, if any.
    pub fn drop_queued(&mut self) {
        self.queued = None;
    }

    /// Replaces everything planned from the stop's start on by the stop.
    pub fn apply_stop(&mut self, stop: Stop<T, NZ>) {
        self.queued = None;
        self.active = Some(Segment::Stop(stop));
    }
}

impl<T: Real, const NZ: usize> Trajectory<T, NZ> for Plan<T, NZ> {
    /// The segment running at `t`, evaluated where it lies: before the active segment
    /// the rest, then the active one until its end, then the queued move (or the active
    /// one at rest at its end). Issue 20: the plan copied both segments by value on
    /// every call (about 900 bytes: some 450 Cortex-M7 instructions, +28 % on a BDF4
    /// step); now a comparison or two select the segment and nothing is copied.
    fn derivatives<const D: usize>(&self, t: T) -> [SVector<T, NZ>; D] {
        let rest = || {
            let mut rest = [SVector::<T, NZ>::zeros(); D];
            if let Some(v) = rest.first_mut() {
                *v = self.rest;
            }
            rest
        };
        let Some(a) = &self.active else {
            return rest();
        };
        let (start, end) = a.span();
        if t < start {
            rest()
        } else {
            match &self.queued {
                Some(q) if t > end => q.derivatives(t),
                _ => a.derivatives(t),
            }
        }
    }

    fn active_span(&self) -> (T, T) {
        match (&self.active, self.end_time()) {
            (Some(a), Some(end)) => (a.span().0, end),
            _ => (T::zero(), T::zero()),
        }
    }

    /// The least smoothness of anything planned: a move pushed with a smaller `n` than
    /// the plan's own (the scene's first move) lowers it while it is planned.
    fn smoothness(&self) -> usize {
        let active = self.active.as_ref().map_or(self.smoothness, |a| match a {
            Segment::Move(m) => m.smoothness(),
            Segment::Stop(s) => s.smoothness(),
        });
        let queued = self
            .queued
            .as_ref()
            .map_or(self.smoothness, PointToPoint::smoothness);
        self.smoothness.min(active).min(queued)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    type V = SVector<f64, 1>;

    /// The stop taking over at `t` after `duration` at the rule of the stops before
    /// issue 32: as far as a uniform deceleration carries the load, no nearer than the
    /// nearest end, never past the target.
    fn uniform_stop<const NZ: usize>(
        plan: &Plan<f64, NZ>,
        t: f64,
        duration: f64,
    ) -> Option<Result<Stop<f64, NZ>>> {
        let start = plan.stop_start(t, 1)?;
        let reach = start.fraction() + start.rate() * duration * 0.5;
        let end = start
            .nearest_end(duration)
            .unwrap_or(reach)
            .max(reach)
            .min(1.0);
        Some(start.stop(duration, end))
    }

    #[test]
    fn hermite_matches_its_boundary_conditions() {
        let start = [
            V::new(1.0),
            V::new(0.7),
            V::new(-0.3),
            V::new(0.2),
            V::new(-0.1),
        ];
        let h = Hermite::new(2.0, 3.0, &start, V::new(2.5)).unwrap();
        let d0: [V; 6] = h.derivatives(2.0);
        for j in 0..5 {
            assert!(
                (d0[j][0] - start[j][0]).abs() < 1e-12,
                "order {j} at the start: {}",
                d0[j][0]
            );
        }
        let d1: [V; 6] = h.derivatives(5.0 - 1e-12);
        assert!((d1[0][0] - 2.5).abs() < 1e-9);
        for (j, d) in d1.iter().enumerate().skip(1).take(4) {
            assert!(d[0].abs() < 1e-6, "order {j} at the end: {}", d[0]);
        }
        let after: [V; 3] = h.derivatives(9.0);
        assert_eq!((after[0][0], after[1][0]), (2.5, 0.0));
    }

    #[test]
    fn hermite_from_rest_to_rest_is_the_smooth_step() {
        let p = PointToPoint::new(V::new(0.0), V::new(1.0), 0.0, 2.0, 4).unwrap();
        let h = Hermite::new(0.0, 2.0, &[V::new(0.0); 5], V::new(1.0)).unwrap();
        for t in [0.1, 0.7, 1.0, 1.5, 1.9] {
            let (a, b): ([V; 5], [V; 5]) = (p.derivatives(t), h.derivatives(t));
            for j in 0..5 {
                assert!(
                    (a[j][0] - b[j][0]).abs() < 1e-10 * (1.0 + a[j][0].abs()),
                    "t {t} order {j}"
                );
            }
        }
    }

    #[test]
    fn plan_queues_one_move_and_stops_smoothly() {
        let mut plan = Plan::at_rest(V::new(0.0), 4).unwrap();
        let a = plan.candidate(V::new(1.0), 1.0, 2.0).unwrap();
        plan.push(a).unwrap();
        let b = plan.candidate(V::new(3.0), 0.0, 2.0).unwrap();
        assert_eq!(b.t_start(), 3.0, "queued behind the active move");
        plan.push(b).unwrap();
        assert!(
            plan.push(plan.candidate(V::new(4.0), 0.0, 1.0).unwrap())
                .is_err(),
            "one queued move at most"
        );
        let z: [V; 1] = plan.derivatives(4.0);
        assert!(z[0][0] > 1.0 && z[0][0] < 3.0, "in the second move");
        // Stop at 3.5 s, inside the second move: continuous to order 4.
        let before: [V; 5] = plan.derivatives(3.5);
        let stop = uniform_stop(&plan, 3.5, 1.0).unwrap().unwrap();
        plan.apply_stop(stop);
        let after: [V; 5] = plan.derivatives(3.5);
        for j in 0..5 {
            assert!(
                (before[j][0] - after[j][0]).abs() < 1e-9 * (1.0 + before[j][0].abs()),
                "order {j}"
            );
        }
        plan.retire(10.0);
        assert!(!plan.is_moving(10.0));
        assert!((plan.final_position()[0] - stop.end()[0]).abs() < 1e-15);
    }

    /// The plan answers exactly what the segment running at `t` answers — the rest
    /// before it, the active one up to and at its end, the queued move after it, the
    /// stop once applied — bit for bit (it selects, it does not copy or recompute).
    #[test]
    fn plan_evaluates_the_segment_it_runs() {
        type V2 = SVector<f64, 2>;
        let mut plan = Plan::at_rest(V2::new(12.0, 8.0), 5).unwrap();
        let a = plan.candidate(V2::new(20.0, 4.0), 1.0, 8.0).unwrap();
        plan.push(a).unwrap();
        let b = plan.candidate(V2::new(14.0, 6.0), 0.0, 5.0).unwrap();
        plan.push(b).unwrap();
        let rest: [V2; 3] = [V2::new(12.0, 8.0), V2::zeros(), V2::zeros()];
        for t in [0.0, 0.5, 1.0, 3.3, 9.0, 9.0 + 1e-12, 11.7, 14.0, 20.0] {
            let z: [V2; 3] = plan.derivatives(t);
            let want: [V2; 3] = if t < 1.0 {
                rest
            } else if t <= 9.0 {
                a.derivatives(t)
            } else {
                b.derivatives(t)
            };
            assert_eq!(z, want, "t = {t}");
        }
        let stop = uniform_stop(&plan, 4.0, 2.0).unwrap().unwrap();
        plan.apply_stop(stop);
        for t in [4.0, 4.7, 6.0, 12.0] {
            let (z, want): ([V2; 3], [V2; 3]) = (plan.derivatives(t), stop.derivatives(t));
            assert_eq!(z, want, "t = {t}");
        }
    }

    /// A stop that rests at its nearest end ([`StopStart::nearest_end`]) provably stays on
    /// the path; one that rests a little nearer does not (it would have to turn back).
    #[test]
    fn the_nearest_end_is_the_nearest_a_stop_stays_on_the_path() {
        type V2 = SVector<f64, 2>;
        let mut plan = Plan::at_rest(V2::new(12.0, 8.0), 5).unwrap();
        plan.push(plan.candidate(V2::new(20.0, 4.0), 1.0, 8.0).unwrap())
            .unwrap();
        let mut checked = 0;
        for k in 1..40 {
            let t = 1.0 + 8.0 * f64::from(k) / 40.0;
            let start = plan.stop_start(t, 1).unwrap();
            for d in [0.5, 1.0, 2.0, 4.0] {
                let Some(near) = start.nearest_end(d) else {
                    continue;
                };
                assert!(near >= start.fraction(), "t {t} d {d}: behind the load");
                let at_near = start.stop(d, near).unwrap();
                if near > 1.0 {
                    // Past the target: no stop of that duration rests on the path.
                    assert!(!at_near.stays_on_path(), "t {t} d {d}");
                    continue;
                }
                assert!(at_near.stays_on_path(), "t {t} d {d}");
                let nearer = near - 1e-6 * (1.0 + near.abs());
                assert!(
                    !start.stop(d, nearer).unwrap().stays_on_path(),
                    "t {t} d {d}"
                );
                checked += 1;
            }
        }
        assert!(checked > 100, "{checked}");
    }

    /// A stop at any instant of a move, for any duration, ends on the move's straight
    /// path at or before its target; a stop whose Bernstein test passes never leaves the
    /// segment between where it started and where it ends (checked densely here).
    #[test]
    fn a_stop_never_passes_the_target() {
        type V2 = SVector<f64, 2>;
        let mut accepted = 0;
        for n in [4, 5, 6] {
            let from = V2::new(12.0, 8.0);
            let to = V2::new(20.0, 4.0);
            let mut plan = Plan::at_rest(from, n).unwrap();
            plan.push(plan.candidate(to, 1.0, 8.0).unwrap()).unwrap();
            for k in 0..=80 {
                let t = 1.0 + 8.0 * f64::from(k) / 80.0;
                for d in [0.3, 0.5, 1.0, 2.0, 4.0, 8.0] {
                    let Some(stop) = uniform_stop(&plan, t, d) else {
                        continue;
                    };
                    let stop = stop.unwrap();
                    let sigma = stop.fraction();
                    assert!(sigma <= 1.0, "n {n} t {t} d {d}: ends at σ = {sigma}");
                    let end = stop.end();
                    for axis in 0..2 {
                        let (lo, hi) = (from[axis].min(to[axis]), from[axis].max(to[axis]));
                        assert!(end[axis] >= lo - 1e-12 && end[axis] <= hi + 1e-12);
                    }
                    if !stop.stays_on_path() {
                        continue;
                    }
                    accepted += 1;
                    // The Bernstein test proves it of the exact polynomial; evaluated
                    // (degree up to 15) it carries rounding.
                    let s0: [f64; 1] = stop.timing(t);
                    let mut last = s0[0];
                    for i in 0..=400 {
                        let [s, v]: [f64; 2] = stop.timing(t + d * f64::from(i) / 400.0);
                        assert!(
                            s >= last - 1e-8 && s <= sigma + 1e-8 && v >= -1e-7,
                            "n {n} t {t} d {d} i {i}: σ {s} last {last} σ_end {sigma} v {v}"
                        );
                        last = s;
                    }
                    // Continuous with the move to order n at the stop's start: to
                    // rounding up to the 4th derivative (what the models and the flat
                    // inverse use); the higher ones lose digits to the τ-scaling (d^j).
                    let a: [V2; 7] = plan.derivatives(t);
                    let b: [V2; 7] = stop.derivatives(t);
                    for j in 0..=n {
                        let tol = if j <= 4 { 1e-8 } else { 1e-4 };
                        assert!(
                            (a[j] - b[j]).norm() < tol * (1.0 + a[j].norm()),
                            "n {n} t {t} d {d} order {j}: {} vs {}",
                            a[j],
                            b[j]
                        );
                    }
                }
            }
        }
        assert!(accepted > 100, "only {accepted} stops passed");
    }

    /// The stop's σ and its derivatives of `order` at τ by de Casteljau's algorithm on
    /// the Bernstein coefficients `beta` of degree `m` (differenced `order` times first),
    /// for a stop of `duration`: the textbook evaluation, stable, and slow.
    fn de_casteljau(
        beta: &[f64; MAX_COEFFS],
        m: usize,
        tau: f64,
        order: usize,
        duration: f64,
    ) -> f64 {
        let mut b = *beta;
        for _ in 0..order {
            for k in 0..m {
                b[k] = b[k + 1] - b[k];
            }
        }
        let degree = m - order;
        for r in 1..=degree {
            for k in 0..=(degree - r) {
                b[k] += tau * (b[k + 1] - b[k]);
            }
        }
        b[0] * falling(m, order) / duration.powi(order as i32)
    }

    /// A stop's timing is smooth to rounding from its start to its rest: at the
    /// controller's 10 ms, the fourth difference of its σ, σ̇ and σ̈ (what an index-5
    /// inverse model differences into its set points) against that of de Casteljau's
    /// evaluation stays within 1e-13 at every sample. Evaluated by Horner's rule on the
    /// stop's monomial coefficients (before issue 29's fix) it grew towards the stop's
    /// rest to 6.5e-11, 1.1e-10 and 5.7e-10 (the Bernstein sums: 1.1e-14, 6.0e-15,
    /// 3.4e-15), noise that the hook-and-load crane's BDF4 set points carried as an
    /// alternation of up to ±0.02 m/s near the stop's rest, and fault 2.
    #[test]
    fn a_stop_is_smooth_to_rounding_up_to_its_rest() {
        type V2 = SVector<f64, 2>;
        let h = 0.01;
        let mut worst = [0.0f64; 3];
        // Moves of n = 4, 5, 7: the paper's, the planar crane's, the hook-and-load's.
        for n in [4, 5, 7] {
            let mut plan = Plan::at_rest(V2::new(12.0, 8.0), n).unwrap();
            plan.push(plan.candidate(V2::new(16.0, 6.0), 2.0, 8.0).unwrap())
                .unwrap();
            for (t0, d) in [(3.5, 1.0), (5.0, 3.25), (7.0, 2.0), (4.0, 6.0)] {
                let start = plan.stop_start(t0, 1).unwrap();
                let stop = uniform_stop(&plan, t0, d).unwrap().unwrap();
                let m = 2 * start.n + 1;
                let mut beta = start_bernstein(&start.scaled(d), start.n);
                for b in beta.iter_mut().take(m + 1).skip(start.n + 1) {
                    *b = stop.fraction();
                }
                let steps = (d / h).round() as usize;
                let error = |k: usize, order: usize| {
                    let t = t0 + h * k as f64;
                    let s: [f64; 3] = stop.timing(t);
                    s[order] - de_casteljau(&beta, m, (t - t0) / d, order, d)
                };
                for k in 0..steps.saturating_sub(4) {
                    for (order, w) in worst.iter_mut().enumerate() {
                        let e = [0, 1, 2, 3, 4].map(|i| error(k + i, order));
                        let fourth = e[0] - 4.0 * e[1] + 6.0 * e[2] - 4.0 * e[3] + e[4];
                        *w = w.max(fourth.abs());
                    }
                }
            }
        }
        assert!(worst.iter().all(|w| *w < 1e-13), "σ, σ̇, σ̈: {worst:?}");
    }
}
