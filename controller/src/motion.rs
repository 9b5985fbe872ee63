//! Motion supervision: what each drive does against what the controller commanded, as a
//! CiA 402 drive's own position monitoring (following error window 0x6065 and time
//! 0x6066) and a safety PLC's standstill monitoring do it — here from outside the
//! drive, on its position actual 0x6064 and velocity actual 0x606C (docs/COMMANDS.md,
//! faults 20 and 21; docs/COMMISSIONING.md, "Motion supervision").
//!
//! In cyclic synchronous velocity the drive closes no position loop: where it ends up is
//! the integral of what it did, and only the controller knows what it was asked to do.
//! So the controller keeps, per drive, what the set points it sent should have done —
//! the drive as the model has it, a first-order lag `τ v̇ + v = u` (Eq. 24's drive
//! rows) — and judges position and velocity actual against it:
//!
//! * **following error** while the drive is commanded to move (and until it has settled):
//!   position actual within [`MotionWindows::following`] plus
//!   [`MotionWindows::following_drift`] of the distance between where it is commanded to
//!   be and where it last rested (a velocity loop's droop and scaling error accumulate with
//!   the signed travel, not with time: back and forth they cancel, so the window does
//!   not grow with a path's length either), velocity actual within [`MotionWindows::velocity`] plus the drift of the
//!   expected velocity, the latter for [`MotionWindows::following_time_ms`];
//! * **standstill** once the set points have been exactly zero for
//!   [`MotionWindows::standstill_delay_ms`]: the position where the drive came to rest is
//!   kept, and position actual must stay within [`MotionWindows::standstill`] of it — a
//!   slipping brake, a creeping axis, a drive that follows someone else's set point.
//!
//! The windows are the drive's row of the commissioning file; the lag τ is the model's.

/// A drive's motion supervision windows (its row of the commissioning file).
///
/// With feature `serde`, the row's keys (a window's name ends in `_window` there; a key
/// left out: [`MotionWindows::STOCK`]'s value).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Deserialize),
    serde(deny_unknown_fields, default = "stock_windows")
)]
pub struct MotionWindows {
    /// At rest, how far position actual may move from where the drive came to rest, m.
    #[cfg_attr(feature = "serde", serde(rename = "standstill_window"))]
    pub standstill: f64,
    /// Set points exactly zero this long before the drive counts as at rest and its
    /// position is kept (the drive's lag and its velocity loop settle meanwhile), ms.
    pub standstill_delay_ms: u16,
    /// While moving, how far position actual may be from where the set points sent put
    /// the drive through the model's lag, m …
    #[cfg_attr(feature = "serde", serde(rename = "following_window"))]
    pub following: f64,
    /// … plus this share of the distance commanded since it last rested (a velocity
    /// loop's droop, the drive's scaling error: relative, dimensionless).
    pub following_drift: f64,
    /// While moving, how far velocity actual may be from the lag's velocity, m/s (plus
    /// `following_drift` of it) …
    #[cfg_attr(feature = "serde", serde(rename = "velocity_window"))]
    pub velocity: f64,
    /// … for at most this long, ms.
    pub following_time_ms: u16,
    /// Before a move is accepted at rest, how far position actual may be from where the
    /// controller's model holds the crane, m: further, the move is refused (reason 15),
    /// and a reset takes the drives' positions as the model's.
    #[cfg_attr(feature = "serde", serde(rename = "in_place_window"))]
    pub in_place: f64,
}

impl MotionWindows {
    /// The stock windows (docs/COMMISSIONING.md): 20 mm at rest after 0.5 s at zero;
    /// 0.2 m plus 5 % of the distance from where the drive rested and 0.3 m/s (plus 5 %)
    /// for 50 ms while moving; 50 mm before a move.
    pub const STOCK: Self = Self {
        standstill: 0.02,
        standstill_delay_ms: 500,
        following: 0.2,
        following_drift: 0.05,
        velocity: 0.3,
        following_time_ms: 50,
        in_place: 0.05,
    };
}

/// Serde's value of a window a commissioning file leaves out: the stock one.
#[cfg(feature = "serde")]
fn stock_windows() -> MotionWindows {
    MotionWindows::STOCK
}

/// Which window a drive left.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Breach {
    /// At rest, its position left the standstill window.
    Standstill = 1,
    /// Moving, its position left the following window.
    Position = 2,
    /// Moving, its velocity stayed outside its window for the following time.
    Velocity = 3,
}

/// The largest deviation a drive showed from what the controller commanded since it
/// started, against each window — what a commissioning engineer reads to judge the
/// windows (each well above what a healthy crane shows), and what the tests show healthy
/// runs use of them. 0 for a window never applied.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Deviations {
    /// At rest, from where the drive came to rest, m.
    pub standstill: f64,
    /// Moving, position actual from where the set points put it, m.
    pub position: f64,
    /// Moving, velocity actual from the lag's velocity, m/s.
    pub velocity: f64,
}

/// What a drive reported at the last SYNC, in metres and m/s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Actual {
    pub(crate) position: f64,
    pub(crate) velocity: f64,
}

/// One drive's supervision: what the set points sent should have done, and where it
/// came to rest.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct MotionWatch {
    /// Position and velocity the set points sent give through the lag, m and m/s
    /// (`None` until the drive is first measured).
    expected: Option<(f64, f64)>,
    /// Where the drive last rested or supervision took it up, m: the following window
    /// grows with the distance from there.
    origin: f64,
    /// How long the set points have been exactly zero, ms.
    zero_ms: u32,
    /// Where the drive came to rest, m: standstill is supervised while it is kept.
    rest: Option<f64>,
    /// How long velocity actual has been outside its window, ms.
    velocity_out_ms: u32,
    /// The largest deviation against each window so far.
    peaks: Deviations,
}

/// A drive as the model has it, over one cycle: its lag τ (Eq. 24's `τ v̇ + v = u`) and
/// the share `1 − e^(−h/τ)` of a set-point step its velocity takes in a cycle (1 without
/// lag), computed once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Lag {
    tau: f64,
    share: f64,
    period_s: f64,
    period_ms: u32,
}

impl Lag {
    /// A drive of lag `tau` (s), cycled every `period_ms`.
    #[must_use]
    pub(crate) fn new(tau: f64, period_ms: u32) -> Self {
        let period_s = f64::from(period_ms) / 1000.0;
        let lagging = tau > 0.0 && tau.is_finite();
        Self {
            tau: if lagging { tau } else { 0.0 },
            share: if lagging {
                1.0 - libm::exp(-period_s / tau)
            } else {
                1.0
            },
            period_s,
            period_ms,
        }
    }
}

impl Default for MotionWatch {
    fn default() -> Self {
        Self {
            expected: None,
            origin: 0.0,
            zero_ms: 0,
            rest: None,
            velocity_out_ms: 0,
            peaks: Deviations::default(),
        }
    }
}

impl MotionWatch {
    /// The largest deviation against each window so far.
    #[must_use]
    pub(crate) fn peaks(&self) -> Deviations {
        self.peaks
    }

    /// Whether `position` is outside the standstill window around where the drive came
    /// to rest (noting the deviation); `false` while it is not kept.
    pub(crate) fn left_standstill(&mut self, position: f64, windows: &MotionWindows) -> bool {
        let Some(rest) = self.rest else {
            return false;
        };
        let deviation = (position - rest).abs();
        self.peaks.standstill = self.peaks.standstill.max(deviation);
        deviation > windows.standstill
    }

    /// Where the drive came to rest, if it is supervised at standstill.
    #[cfg(test)]
    #[must_use]
    pub(crate) fn rest(&self) -> Option<f64> {
        self.rest
    }

    /// The drive is at `position`, at rest (the positions were read again: a reset):
    /// what it was commanded before counts no more.
    pub(crate) fn rebase(&mut self, position: f64) {
        self.expected = Some((position, 0.0));
        self.origin = position;
        self.rest = Some(position);
        self.velocity_out_ms = 0;
    }

    /// Forgets what the set points did (the controller stopped supervising: a quick stop,
    /// a halt); where the drive rests is kept until a reset reads it again.
    pub(crate) fn pause(&mut self) {
        self.expected = None;
        self.velocity_out_ms = 0;
    }

    /// One cycle: `sent` (m/s) is the set point the drive applied at the last SYNC,
    /// `actual` what it reported then (`None`: not fresh — the expectation still
    /// advances), `lag` the drive as the model has it. The window the drive left, if any.
    pub(crate) fn observe(
        &mut self,
        sent: f64,
        actual: Option<Actual>,
        windows: &MotionWindows,
        lag: &Lag,
    ) -> Option<Breach> {
        let period_ms = lag.period_ms;
        // What the set point did over the period: the lag's exact response to a held
        // input, x += h u − τ Δv.
        if let Some((x, v)) = self.expected {
            let next_v = v + (sent - v) * lag.share;
            let next_x = x + lag.period_s * sent - lag.tau * (next_v - v);
            self.expected = Some((next_x, next_v));
        } else if let Some(a) = actual {
            self.expected = Some((a.position, a.velocity));
            self.origin = a.position;
        }
        if sent == 0.0 {
            self.zero_ms = self.zero_ms.saturating_add(period_ms);
        } else {
            self.zero_ms = 0;
            self.rest = None;
        }
        let actual = actual?;
        if self.rest.is_none() && self.zero_ms >= u32::from(windows.standstill_delay_ms) {
            // At rest: where it rests is kept, and the next move starts from there.
            self.rebase(actual.position);
        }
        if self.rest.is_some() {
            return self
                .left_standstill(actual.position, windows)
                .then_some(Breach::Standstill);
        }
        let (x, v) = self.expected?;
        let (position, velocity) = ((actual.position - x).abs(), (actual.velocity - v).abs());
        self.peaks.position = self.peaks.position.max(position);
        self.peaks.velocity = self.peaks.velocity.max(velocity);
        if position > windows.following + windows.following_drift * (x - self.origin).abs() {
            return Some(Breach::Position);
        }
        if velocity > windows.velocity + windows.following_drift * v.abs() {
            self.velocity_out_ms = self.velocity_out_ms.saturating_add(period_ms);
        } else {
            self.velocity_out_ms = 0;
        }
        (self.velocity_out_ms >= u32::from(windows.following_time_ms).max(period_ms))
            .then_some(Breach::Velocity)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    const W: MotionWindows = MotionWindows::STOCK;
    const TAU: f64 = 0.03;

    fn lag() -> Lag {
        Lag::new(TAU, 10)
    }

    /// A drive that follows its set points through the model's lag (simulated finely),
    /// run through a move profile: never a breach; at rest it is latched.
    #[test]
    fn a_drive_like_the_model_stays_in_every_window() {
        let mut watch = MotionWatch::default();
        let (mut x, mut v) = (12.0, 0.0);
        // 1 s up to 3 m/s, 2 s at it, 1 s down, 1 s at rest.
        let u = |k: usize| match k {
            0..=99 => 0.03 * k as f64,
            100..=299 => 3.0,
            300..=399 => 3.0 - 0.03 * (k - 300) as f64,
            _ => 0.0,
        };
        for k in 0..600 {
            let sent = u(k);
            for _ in 0..100 {
                v += (sent - v) / TAU * 1e-4;
                x += v * 1e-4;
            }
            let actual = Actual {
                position: x,
                velocity: v,
            };
            assert_eq!(watch.observe(sent, Some(actual), &W, &lag()), None);
        }
        assert!(watch.rest().is_some_and(|r| (r - x).abs() < 1e-9));
    }

    /// Back and forth (8 m each way) without a rest, a drive that slips 2 % in one
    /// direction only: its error grows 0.16 m a round trip. The window grows with the
    /// distance from where the drive rested (at most 0.6 m here), not with the path's
    /// length (which would grow it by 0.8 m a round trip, five times as fast as the error:
    /// never caught), so the slip is caught within three round trips.
    #[test]
    fn a_one_way_slip_back_and_forth_is_caught_before_the_window_outgrows_it() {
        let mut watch = MotionWatch::default();
        let (mut x, mut v) = (12.0, 0.0);
        let mut breach = None;
        'trips: for trip in 0..10 {
            for k in 0..800 {
                let sent = if k < 400 { 2.0 } else { -2.0 };
                let applied = if sent > 0.0 { 0.98 * sent } else { sent };
                for _ in 0..100 {
                    v += (applied - v) / TAU * 1e-4;
                    x += v * 1e-4;
                }
                let actual = Actual {
                    position: x,
                    velocity: v,
                };
                if let Some(b) = watch.observe(sent, Some(actual), &W, &lag()) {
                    breach = Some((trip, b));
                    break 'trips;
                }
            }
        }
        assert!(breach.is_some(), "the slip was never caught");
        let (trip, kind) = breach.unwrap();
        assert_eq!(kind, Breach::Position);
        assert!(trip < 3, "caught only in round trip {trip}");
    }

    /// A drive without lag (a stiff velocity loop) runs τ·v ahead: within the window.
    #[test]
    fn a_drive_without_the_models_lag_is_within_the_window() {
        let mut watch = MotionWatch::default();
        let mut x = 12.0;
        for k in 0..500 {
            // Up to 3 m/s at 3 m/s², 3 s at it, down again.
            let sent = (0.03 * f64::from(k.min(500 - k))).min(3.0);
            x += sent * 0.01;
            let actual = Actual {
                position: x,
                velocity: sent,
            };
            assert_eq!(watch.observe(sent, Some(actual), &W, &lag()), None, "{k}");
        }
    }

    #[test]
    fn a_drive_that_ignores_its_set_point_leaves_the_following_window() {
        let mut watch = MotionWatch::default();
        let still = Actual {
            position: 12.0,
            velocity: 0.0,
        };
        let mut found = None;
        for k in 0..200 {
            let sent = (0.03 * f64::from(k)).min(3.0);
            if let Some(b) = watch.observe(sent, Some(still), &W, &lag()) {
                found = Some((k, b));
                break;
            }
        }
        // The velocity window (0.3 m/s) is left at 0.32 m/s, 50 ms later a breach.
        let (k, breach) = found.unwrap();
        assert_eq!(breach, Breach::Velocity);
        assert!((10..=20).contains(&k), "{k}");
    }

    #[test]
    fn a_creeping_drive_at_rest_leaves_the_standstill_window() {
        let mut watch = MotionWatch::default();
        let mut x = 12.0;
        let mut found = None;
        for k in 0..200 {
            // At rest for 0.5 s (latched), then creeping at 0.3 m/s.
            let velocity = if k < 60 { 0.0 } else { 0.3 };
            x += velocity * 0.01;
            let actual = Actual {
                position: x,
                velocity,
            };
            if let Some(b) = watch.observe(0.0, Some(actual), &W, &lag()) {
                found = Some((k, b));
                break;
            }
        }
        // 20 mm at 3 mm a cycle: the 7th cycle of creep.
        assert_eq!(found, Some((66, Breach::Standstill)));
    }

    #[test]
    fn a_reset_rebases_the_standstill_window() {
        let mut watch = MotionWatch::default();
        let at = |p: f64| {
            Some(Actual {
                position: p,
                velocity: 0.0,
            })
        };
        for _ in 0..60 {
            watch.observe(0.0, at(12.0), &W, &lag());
        }
        assert_eq!(
            watch.observe(0.0, at(12.1), &W, &lag()),
            Some(Breach::Standstill)
        );
        watch.pause();
        watch.rebase(12.1);
        assert_eq!(watch.observe(0.0, at(12.1), &W, &lag()), None);
    }
}
