//! The last few solution values of a multistep scheme.
//!
//! Hand-written rather than `heapless::HistoryBuf`: the firmware's link-time proof
//! that nothing panics (`cargo xtask panic-proof`) cannot see through that buffer's
//! indexing, and a ring of `K` values is a few lines whose every access is checked.

use nalgebra::SVector;

use crate::scalar::Real;

/// The newest `K` values, written in a ring.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct History<T: Real, const N: usize, const K: usize> {
    values: [SVector<T, N>; K],
    /// Index of the newest value.
    newest: usize,
}

impl<T: Real, const N: usize, const K: usize> History<T, N, K> {
    /// A history in which every value is `x` (a scheme started at rest).
    pub(crate) fn filled(x: SVector<T, N>) -> Self {
        Self {
            values: [x; K],
            newest: 0,
        }
    }

    /// The newest value (zeros for `K = 0`).
    pub(crate) fn newest(&self) -> SVector<T, N> {
        self.values
            .get(self.newest)
            .copied()
            .unwrap_or_else(SVector::zeros)
    }

    /// Appends `x`, forgetting the oldest value.
    pub(crate) fn push(&mut self, x: SVector<T, N>) {
        if K == 0 {
            return;
        }
        self.newest = if self.newest + 1 >= K {
            0
        } else {
            self.newest + 1
        };
        if let Some(slot) = self.values.get_mut(self.newest) {
            *slot = x;
        }
    }

    /// The value `i` steps before the newest (`i = 0`: the newest), if kept.
    pub(crate) fn back(&self, i: usize) -> Option<&SVector<T, N>> {
        if i >= K {
            return None;
        }
        // `newest + K − i` lies in [newest + 1, newest + K]: one conditional subtraction
        // instead of a remainder.
        let j = self.newest + K - i;
        self.values.get(if j >= K { j - K } else { j })
    }

    /// The values from the newest to the oldest.
    pub(crate) fn newest_first(&self) -> impl Iterator<Item = SVector<T, N>> + '_ {
        (0..K).filter_map(move |i| self.values.get((self.newest + K - i) % K).copied())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing)]
    use super::*;

    type V = SVector<f64, 1>;

    #[test]
    fn keeps_the_newest_k_newest_first() {
        let mut h: History<f64, 1, 3> = History::filled(V::new(0.0));
        for v in 1..=5 {
            h.push(V::new(f64::from(v)));
        }
        let mut order = h.newest_first().map(|v| v[0]);
        assert_eq!(
            [order.next(), order.next(), order.next(), order.next()],
            [Some(5.0), Some(4.0), Some(3.0), None]
        );
        assert_eq!(h.newest()[0], 5.0);
        let back: [Option<f64>; 4] = core::array::from_fn(|i| h.back(i).map(|v| v[0]));
        assert_eq!(back, [Some(5.0), Some(4.0), Some(3.0), None]);
    }
}
