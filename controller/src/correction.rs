//! What the controller asks of whatever stands between the inverse model and the drives
//! (Fig. 1), for a crane with `A` driven axes: nothing ([`crate::feedback::NoFeedback`]:
//! the planar crane's through the blanket impl below, every other crane's through a
//! `feedforward_only!` line for its reference — the 3D crane's below, the hook-and-load
//! crane's in its crane file), or the planar state feedback ([`Correction`], the paper's
//! crane).
//!
//! The controller speaks in per-drive arrays in the model's input order; a correction
//! sees the measurements as its own crane's type. The planar feedback's interface
//! ([`Correction`]) keeps its own types (`Measurement`, `DriveLimits`), so each
//! planar correction is an `AxesCorrection<2, Reference>` through the one blanket impl here.

use crate::commissioning::Swing;
use crate::feedback::{Correction, Measurement, Mode, Reference};
use crate::rope::RopeLength;
use crate::setpoint::{AxisLimits, DriveLimits};

/// What the drives and the inclinometer measured at the last SYNC.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measured<const A: usize> {
    /// Each drive's position actual, m, in the model's input order.
    pub position: [f64; A],
    /// The swing angles, rad, if fresh ones came from a healthy inclinometer: the planar
    /// crane's φ (Eq. 20) is the long one, the 3D crane's swing in the x–z and y–z
    /// planes the long and the lateral one.
    pub swing: Option<Swing>,
}

/// The correction of a crane with `A` driven axes and the reference state `R` (its
/// [`Crane::Reference`](crate::crane::Crane::Reference)) between the inverse model and
/// the set-point gate. Keyed on the reference, not only on the axes: a second crane
/// with two axes has its own reference, so the planar loop is refused for it at
/// compile time.
pub trait AxesCorrection<const A: usize, R> {
    /// `false`: the controller never asks for a reference or measurements, and links
    /// none of the inclinometer's code.
    const ENABLED: bool;
    /// One cycle: the set points to hand to the gate, and the mode after it.
    fn correct(
        &mut self,
        reference: &R,
        u_d: [f64; A],
        measured: Option<Measured<A>>,
        last: [f64; A],
        limits: &[AxisLimits; A],
    ) -> ([f64; A], Mode);
    /// What the drives were sent after [`Self::correct`] when something after it (the
    /// range guard, [`crate::range`]) changed its set points: the observer learns the
    /// correction `u − u_d` the drives got, not the one it asked for (anti-windup).
    /// Required, not defaulted: a wrapper that forgot to forward it would leave its
    /// observer learning what was never sent.
    fn sent(&mut self, u_d: [f64; A], u: [f64; A]);
    /// Back to closed loop, the observer to start from the next good measurement.
    fn restart(&mut self);
    /// The loop is closed at rest on a command that may move the hoist alone (manual
    /// mode's first demand after an entry at rest, the start of an automatic move
    /// accepted at rest): the travel's correction is let go
    /// unless the estimate already shows a swing or a displacement beyond the rest's
    /// hold thresholds ([`crate::feedback::StateFeedback::let_go_at_rest`]).
    /// Required, not defaulted: a wrapper that forgot to forward it would keep the
    /// trolley acting on the young estimate's noise while the operator only hoists.
    fn let_go_at_rest(&mut self);
    /// What it is doing (`None`: there is no feedback).
    fn mode(&self) -> Option<Mode>;
    /// The rope calibration learnt from the swing (`None`: no inclinometer).
    fn rope(&self) -> Option<&RopeLength>;
}

/// The planar crane's corrections: trolley x and rope length l.
impl<C: Correction> AxesCorrection<2, Reference> for C {
    const ENABLED: bool = C::ENABLED;
    fn correct(
        &mut self,
        reference: &Reference,
        u_d: [f64; 2],
        measured: Option<Measured<2>>,
        last: [f64; 2],
        limits: &[AxisLimits; 2],
    ) -> ([f64; 2], Mode) {
        let measured = measured.map(|m| {
            let [x, l] = m.position;
            Measurement {
                x,
                l,
                phi: m.swing.map(|s| s.long),
            }
        });
        let out = Correction::correct(
            self,
            reference,
            u_d,
            measured,
            last,
            &DriveLimits::from_axes(*limits),
        );
        (out.u, out.mode)
    }
    fn sent(&mut self, [ud1, ud2]: [f64; 2], [u1, u2]: [f64; 2]) {
        Correction::sent(self, [u1 - ud1, u2 - ud2]);
    }
    fn restart(&mut self) {
        Correction::restart(self);
    }
    fn let_go_at_rest(&mut self) {
        Correction::let_go_at_rest(self);
    }
    fn mode(&self) -> Option<Mode> {
        Correction::mode(self)
    }
    fn rope(&self) -> Option<&RopeLength> {
        Correction::rope(self)
    }
}

/// [`crate::feedback::NoFeedback`] as the correction of a crane with `$axes` axes and reference `$reference`
/// (one the planar blanket impl does not cover): the inverse model's set points as
/// they are.
#[macro_export]
macro_rules! feedforward_only {
    ($axes:literal, $reference:ty) => {
        impl $crate::correction::AxesCorrection<$axes, $reference>
            for $crate::feedback::NoFeedback
        {
            const ENABLED: bool = false;
            fn correct(
                &mut self,
                _reference: &$reference,
                u_d: [f64; $axes],
                _measured: Option<$crate::correction::Measured<$axes>>,
                _last: [f64; $axes],
                _limits: &[$crate::setpoint::AxisLimits; $axes],
            ) -> ([f64; $axes], $crate::feedback::Mode) {
                let degraded = $crate::feedback::Degraded::AngleLost;
                (u_d, $crate::feedback::Mode::FeedforwardOnly(degraded))
            }
            fn sent(&mut self, _u_d: [f64; $axes], _u: [f64; $axes]) {}
            fn restart(&mut self) {}
            fn let_go_at_rest(&mut self) {}
            fn mode(&self) -> Option<$crate::feedback::Mode> {
                None
            }
            fn rope(&self) -> Option<&$crate::rope::RopeLength> {
                None
            }
        }
    };
}

// The 3D crane without the feedback.
feedforward_only!(3, [Reference; 2]);
