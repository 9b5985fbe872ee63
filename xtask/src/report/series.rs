//! Bounded memory for whole-log curves and lists: a curve keeps at most [`POINTS`]
//! points whatever the log's length (every second one is dropped and the stride doubled
//! when it fills: an even thinning over the whole log), and a list keeps its first
//! entries and counts the rest. Numbers the report states (maxima, counts) are taken
//! from every frame, never from the thinned curve.

use serde::Serialize;

/// Points kept per curve: more than a 900 px wide figure can show.
pub const POINTS: usize = 4000;

/// A time series thinned evenly to at most [`POINTS`] points.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    points: Vec<(f64, f64)>,
    stride: u64,
    seen: u64,
}

impl Series {
    /// An empty series.
    pub fn new() -> Self {
        Self {
            points: Vec::new(),
            stride: 1,
            seen: 0,
        }
    }

    /// Adds the point `(t, v)` (kept if it falls on the stride).
    pub fn push(&mut self, t: f64, v: f64) {
        if self.seen.is_multiple_of(self.stride.max(1)) {
            if self.points.len() >= POINTS {
                let mut keep = false;
                self.points.retain(|_| {
                    keep = !keep;
                    keep
                });
                self.stride = self.stride.max(1) * 2;
            }
            if self.seen.is_multiple_of(self.stride) {
                self.points.push((t, v));
            }
        }
        self.seen += 1;
    }

    /// The points kept.
    pub fn points(&self) -> &[(f64, f64)] {
        &self.points
    }
}

/// A list that keeps its first `cap` entries and counts the rest.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Capped<T> {
    /// The entries kept.
    pub items: Vec<T>,
    /// Entries beyond `cap`, counted only.
    pub dropped: u64,
    #[serde(skip)]
    cap: usize,
}

impl<T> Capped<T> {
    /// An empty list keeping `cap` entries.
    pub fn new(cap: usize) -> Self {
        Self {
            items: Vec::new(),
            dropped: 0,
            cap,
        }
    }

    /// Adds `item`, or counts it when full.
    pub fn push(&mut self, item: T) {
        if self.items.len() < self.cap {
            self.items.push(item);
        } else {
            self.dropped += 1;
        }
    }
}

/// Count, mean, spread and extremes of a stream of numbers. In summary.json a number
/// the stream did not give is `null` (no mean of nothing, no spread of one).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Stats {
    /// How many.
    pub count: u64,
    /// Mean.
    pub mean: f64,
    /// Standard deviation.
    pub std: f64,
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
    m2: f64,
}

impl Serialize for Stats {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Shown {
            count: u64,
            mean: Option<f64>,
            std: Option<f64>,
            min: Option<f64>,
            max: Option<f64>,
        }
        let any = |v: f64| (self.count > 0).then_some(v);
        Shown {
            count: self.count,
            mean: any(self.mean),
            std: (self.count > 1).then_some(self.std),
            min: any(self.min),
            max: any(self.max),
        }
        .serialize(serializer)
    }
}

impl Stats {
    /// `f` of the numbers, if there were any.
    pub fn get(&self, f: impl Fn(&Stats) -> f64) -> Option<f64> {
        (self.count > 0).then(|| f(self))
    }
}

impl Stats {
    /// Adds `x` (Welford's update).
    pub fn add(&mut self, x: f64) {
        if self.count == 0 {
            self.min = x;
            self.max = x;
        }
        self.count += 1;
        let delta = x - self.mean;
        self.mean += delta / self.count as f64;
        self.m2 += delta * (x - self.mean);
        self.std = if self.count > 1 {
            (self.m2 / (self.count - 1) as f64).sqrt()
        } else {
            0.0
        };
        self.min = self.min.min(x);
        self.max = self.max.max(x);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_series_is_thinned_evenly_and_bounded() {
        let mut s = Series::new();
        for i in 0..1_000_000u32 {
            s.push(f64::from(i), 0.0);
        }
        let p = s.points();
        assert!(p.len() <= POINTS && p.len() > POINTS / 2, "{}", p.len());
        let step = p[1].0 - p[0].0;
        assert!(p.windows(2).all(|w| w[1].0 - w[0].0 == step), "even");
        assert!(p.last().unwrap().0 > 1_000_000.0 - 2.0 * step);
    }

    #[test]
    fn stats_and_capped_lists() {
        let mut s = Stats::default();
        for x in [1.0, 2.0, 3.0, 4.0] {
            s.add(x);
        }
        assert_eq!((s.count, s.mean, s.min, s.max), (4, 2.5, 1.0, 4.0));
        assert!((s.std - 1.290_994_448_735_805_6).abs() < 1e-12);
        let mut c = Capped::new(2);
        (0..5).for_each(|i| c.push(i));
        assert_eq!((c.items.as_slice(), c.dropped), (&[0, 1][..], 3));
    }
}
