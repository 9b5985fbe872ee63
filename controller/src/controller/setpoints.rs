//! Each drive's set point before the gate: the inverse model's `u_d`, the state
//! feedback's correction (Fig. 1) and the range guard ([`crate::range`]), from the
//! drives' positions actual read once per cycle.

use super::*;

/// A drive's last position actual (0x6064) as the range guard and the feedback read it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Position {
    /// Through the drive's commissioned scaling, m.
    pub(super) metres: f64,
    /// How much older than a cycle it is, ms (0: from the last SYNC, fresh). An integer:
    /// the MCU converts a 64-bit integer to f64 in software, and only a late position
    /// needs it as seconds.
    pub(super) late_ms: u32,
}

impl<F, C, K, const A: usize> Controller<F, C, K, A>
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: Crane<A>,
{
    /// What the drives and the inclinometer measured at the last SYNC (their TPDOs
    /// arrive between cycles): each drive's position (planar: trolley position and rope
    /// length) from `positions`, the angle if a fresh one came from a healthy
    /// inclinometer. `None` when a position is not fresh.
    pub(super) fn measurement(&mut self, positions: &[Option<Position>; A]) -> Option<Measured<A>> {
        let now_ms = self.now_ms;
        let swing = self.links.sensor_mut().and_then(|sensor| {
            let fresh = core::mem::take(&mut sensor.fresh);
            let healthy = sensor.healthy(now_ms, self.config.heartbeat_timeout_ms);
            sensor.swing.filter(|_| fresh && healthy)
        });
        let mut position = [0.0; A];
        for (slot, p) in position.iter_mut().zip(positions) {
            *slot = p.filter(|p| p.late_ms == 0)?.metres;
        }
        Some(Measured { position, swing })
    }

    /// Every drive's last position actual (0x6064), through its commissioned scaling,
    /// and how late it is; `None` for a drive that has sent none since it was linked.
    pub(super) fn positions(&self) -> [Option<Position>; A] {
        let period_ms = u64::from(self.config.period_ms);
        K::DRIVES.map(|drive| {
            let link = self.link(drive)?;
            let age_ms = self.now_ms.saturating_sub(link.last_position_ms?);
            Some(Position {
                metres: link.commissioning.setup().metres(link.position?),
                late_ms: u32::try_from(age_ms.saturating_sub(period_ms)).unwrap_or(u32::MAX),
            })
        })
    }

    /// `u` with each drive kept inside its range by its position actual
    /// ([`crate::range`]): the last word before the gate on what the feedback adds to the
    /// model's `u_d`, and on `u_d` itself for a drive ahead of the model's. A late
    /// position counts as far on as the drive can have gone since; a drive without any,
    /// `u` as it is. `reference`: the model's, if the feedback already asked for it this
    /// cycle.
    pub(super) fn within_ranges(
        &mut self,
        u: [f64; A],
        u_d: [f64; A],
        positions: &[Option<Position>; A],
        reference: Option<&K::Reference>,
    ) -> [f64; A] {
        let (ranges, limits, lags) = (
            self.planner.ranges(),
            self.planner.limits(),
            self.planner.lags(),
        );
        let (last, h) = (self.gate.last_velocities(), self.config.period_s());
        // The model's drives, asked for once and only near an end.
        let mut model: Option<[(f64, f64); A]> = None;
        let mut guarded = u;
        for (i, out) in guarded.iter_mut().enumerate() {
            let (Some(&u), Some(&u_d), Some(&last), Some(range), Some(limits), Some(&lag)) = (
                u.get(i),
                u_d.get(i),
                last.get(i),
                ranges.get(i),
                limits.get(i),
                lags.get(i),
            ) else {
                continue;
            };
            let Some(latches) = self.range_latches.get_mut(i) else {
                continue;
            };
            let at = positions.get(i).copied().flatten().map(|p| {
                let late_s = f64::from(p.late_ms) * 1e-3;
                range::late_position(p.metres, u, late_s, limits.max_velocity)
            });
            // The model's drive in this cycle's newest solution: as new as the position
            // from the last SYNC, which every set point sent so far has moved (the drive
            // applies one over the cycle before the SYNC).
            let feedforward = &self.feedforward;
            let model_at = || {
                let drives = *model.get_or_insert_with(|| match reference {
                    Some(r) => K::drive_states(r),
                    None => model_drives::<F, K, A>(feedforward),
                });
                drives.get(i).copied().unwrap_or((f64::NAN, f64::NAN))
            };
            *out = latches.apply(u, u_d, last, at, *range, *limits, lag, h, model_at);
        }
        guarded
    }

    /// This cycle's set points before the gate: the inverse model's `u_d`, corrected by
    /// the feedback while the loop is closed (Fig. 1); `u_d` while it only observes
    /// ([`Loop::Observing`]). A change of the feedback's mode is announced: the angle no
    /// longer used (the swing estimated from the positions, or feedforward only) by
    /// EMCY 0xFF20 with the reason (a warning: the move goes on), back to closed loop by
    /// nothing. Also the model's reference when the feedback ran (`None`: it did not;
    /// when it did, it is told what the drives were sent after the range guard, and the
    /// guard reads the model's drives from this reference).
    pub(super) fn corrected(
        &mut self,
        step: &FeedforwardStep<A>,
        positions: &[Option<Position>; A],
    ) -> ([f64; A], Option<K::Reference>) {
        if !C::ENABLED || self.feedback_loop == Loop::Open || self.mode != Mode::Ready {
            return (step.u, None);
        }
        let reference = self.feedforward.reference();
        let measured = self.measurement(positions);
        let last = self.gate.last_velocities();
        let (corrected, mode) =
            self.correction
                .correct(&reference, step.u, measured, last, &self.planner.limits());
        let u = if self.feedback_loop == Loop::Observing {
            // Nothing commanded yet: the observer learns that no correction was sent.
            self.correction.sent(step.u, step.u);
            step.u
        } else {
            corrected
        };
        if self.feedback_announced != Some(mode) {
            if let Some(reason) = mode.degraded() {
                let node = self
                    .links
                    .sensor()
                    .map_or(0, |s| s.commissioning.setup().node);
                self.send_emcy(canopen::emcy(
                    self.nmt.node.id,
                    emcy::FEEDBACK_OFF,
                    REGISTER_MANUFACTURER,
                    [15, node, reason.code(), 0, 0],
                ));
            }
            self.feedback_announced = Some(mode);
        }
        (u, Some(reference))
    }
}

/// Where the model's drives stand and how fast they move in its newest solution
/// ([`Crane::drive_states`]). Out of line: the range guard asks it only near an end, and
/// inlined its frame sat on the control task's stack in every cycle.
#[inline(never)]
fn model_drives<F, K, const A: usize>(feedforward: &F) -> [(f64, f64); A]
where
    F: Feedforward<A, Reference = K::Reference>,
    K: Crane<A>,
{
    K::drive_states(&feedforward.reference())
}
