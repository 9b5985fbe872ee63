//! Supervision of the drives and of delivery, and the reaction to every fault
//! (docs/COMMANDS.md, faults; docs/COMMISSIONING.md, "Motion supervision").

use super::*;

impl<F, C, K, const A: usize> Controller<F, C, K, A>
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: Crane<A>,
{
    pub(super) fn recommission(&mut self, drive: Drive, now_ms: u64) {
        let Some(link) = self.link_mut(drive) else {
            return;
        };
        link.forget_process_data();
        let frame = link.commissioning.begin(now_ms);
        link.outbox = Some(frame);
    }

    /// A linked drive reported boot-up, pre-operational or stopped: a fault during a
    /// move; at rest it is enabled again once it is back, announced by an EMCY warning —
    /// unless the controller itself is not operational (the network is being stopped or
    /// configured by its master: nothing to warn of).
    pub(super) fn drive_left_operational(&mut self, drive: Drive, state: NmtState) {
        if self.moving_for_supervision() {
            self.fault(Fault::DriveLeftOperational(drive, state));
            return;
        }
        if self.mode == Mode::Ready {
            self.mode = Mode::Enabling;
        }
        if self.nmt.node.state != NmtState::Operational {
            return;
        }
        let node = self.node_of(drive);
        // A warning: the fault's byte, but the error register without the generic bit
        // (see emcy::is_fault).
        let code = Fault::DriveLeftOperational(drive, state).code();
        self.send_emcy(canopen::emcy(
            self.nmt.node.id,
            emcy::HEARTBEAT,
            REGISTER_COMMUNICATION,
            [code, node, state as u8, 0, 0],
        ));
    }

    /// Suspends every commissioning that is running (`Commissioning::suspend`), with
    /// the frame it had waiting.
    pub(super) fn suspend_commissioning(&mut self) {
        for i in 0..self.links.len() {
            let (commissioning_suspended, outbox) = match self.links.get_mut(i) {
                Some(Link::Drive(_, link)) => (link.commissioning.suspend(), &mut link.outbox),
                Some(Link::Inclinometer(sensor)) => {
                    (sensor.commissioning.suspend(), &mut sensor.outbox)
                }
                None => continue,
            };
            if commissioning_suspended {
                *outbox = None;
            }
        }
    }

    /// The TPDO clocks of the drives seen operational start again now; what they
    /// reported before the gap is no baseline for the next reading (they may have been
    /// moved meanwhile).
    pub(super) fn restart_tpdo_clocks(&mut self, now_ms: u64) {
        for drive in K::DRIVES {
            if let Some(link) = self.link_mut(drive).filter(|l| l.last_tpdo_ms.is_some()) {
                link.restart_clocks(now_ms);
            }
        }
    }

    /// Heartbeats of linked drives, their TPDOs' age, and the supervisor's heartbeat.
    pub(super) fn supervise_drives(&mut self, now_ms: u64) {
        let late = |t: Option<u64>, limit: u32| {
            t.is_some_and(|t| now_ms.saturating_sub(t) > u64::from(limit))
        };
        for drive in K::DRIVES {
            let silent = self.link(drive).and_then(|l| {
                l.silent(
                    now_ms,
                    self.syncing,
                    self.config.heartbeat_timeout_ms,
                    self.config.tpdo_timeout_ms,
                )
            });
            match silent {
                Some(Silent::Heartbeat) => self.fault(Fault::HeartbeatLost(drive)),
                Some(Silent::Tpdo) => self.fault(Fault::TpdoTimeout(drive)),
                None => {}
            }
        }
        // The supervisor, if watched (0x1016:1): lost during a move → controlled stop.
        if self.supervisor_node().is_some()
            && late(
                self.last_supervisor_heartbeat_ms,
                self.nmt.node.supervisor & 0xFFFF,
            )
            && self.moving_for_supervision()
        {
            self.fault(Fault::SupervisorLost);
        }
    }

    /// Each drive against what the controller commanded ([`crate::motion`]): while the
    /// controller commands the drives — enabling, ready, a controlled stop. An enabled
    /// drive is held to its following windows while it moves and to its standstill
    /// window once it has rested; a drive not enabled (being enabled, dropped out) only to
    /// its standstill window, if it rested before. In a quick stop the drives brake on
    /// their own ramps, and halted nothing moves until a reset reads their positions again
    /// ([`Controller::reset`]): not supervised.
    ///
    /// Never inlined: inlined into the tick it cost the 3D crane's worst cycle 1,200 more
    /// QEMU instructions (6,010 against 4,810) and its control task 1.1 KiB more stack
    /// (`cargo xtask qemu`'s baselines, both ways).
    #[inline(never)]
    pub(super) fn supervise_motion(&mut self, now_ms: u64) {
        let supervised = matches!(self.mode, Mode::Enabling | Mode::Ready | Mode::Stopping(_));
        let period_ms = self.config.period_ms;
        for (drive, lag) in K::DRIVES.into_iter().zip(self.lags) {
            // The set point the drive applied at the last SYNC (this cycle's is not sent).
            let sent = self.gate.last(drive).metres_per_second();
            let Some(link) = self.links.drive_mut(drive) else {
                continue;
            };
            let windows = &link.commissioning.setup().motion;
            let actual = link.actual(now_ms, period_ms);
            let breach = if supervised && link.ready() {
                link.motion.observe(sent, actual, windows, &lag)
            } else {
                link.motion.pause();
                actual
                    .filter(|_| supervised)
                    .filter(|a| link.motion.left_standstill(a.position, windows))
                    .map(|_| Breach::Standstill)
            };
            match breach {
                Some(Breach::Standstill) => self.fault(Fault::Standstill(drive)),
                Some(Breach::Position) => {
                    self.fault(Fault::FollowingError(drive, FollowingError::Position));
                }
                Some(Breach::Velocity) => {
                    self.fault(Fault::FollowingError(drive, FollowingError::Velocity));
                }
                None => {}
            }
        }
    }

    /// Whether every drive is where the controller last brought it, for a move at rest:
    /// position actual within its `in_place` window of where the model holds the crane
    /// (where the drives stand while the load rests: [`Crane::drives_at_rest`]). A
    /// position not known is not in place. While the controller itself moves the crane
    /// (a move, the feedback holding the load) the following windows vouch for the
    /// drives instead. Never inlined (asked only with a move request).
    #[inline(never)]
    pub(super) fn in_place(&self) -> bool {
        let plan = self.feedforward.plan();
        if plan.is_moving(self.now_s()) || !self.gate.at_standstill() {
            return true;
        }
        let rest = self.planner.drives_at_rest(plan.final_position().into());
        K::DRIVES.into_iter().zip(rest).all(|(drive, at)| {
            self.link(drive).is_some_and(|l| {
                l.actual(self.now_ms, self.config.tpdo_timeout_ms)
                    .is_some_and(|a| {
                        (a.position - at).abs() <= l.commissioning.setup().motion.in_place
                    })
            })
        })
    }

    /// Three cycles in a row with a failed RPDO: the set points are not getting through.
    pub(super) fn supervise_delivery(&mut self) {
        self.failed_cycles = if self.rpdo_failed {
            self.failed_cycles + 1
        } else {
            0
        };
        self.rpdo_failed = false;
        if self.failed_cycles >= self.config.undeliverable_cycles {
            self.fault(Fault::Undeliverable);
        }
    }

    /// Meets a fault: the first one leaves *ready*; a later, more severe one escalates.
    pub(super) fn fault(&mut self, fault: Fault) {
        let current = match self.mode {
            Mode::Enabling | Mode::Ready => None,
            Mode::Stopping(_) => Some(Reaction::Controlled),
            Mode::QuickStop(_) => Some(Reaction::Quick),
            Mode::Halted(_) => Some(Reaction::Halt),
        };
        let reaction = fault.reaction();
        if current.is_some_and(|c| c >= reaction) {
            // Already met as severely; a commissioning failure is still announced.
            if let Fault::Commissioning(..) = fault {
                self.announce(fault);
            }
            return;
        }
        self.feedback_loop = Loop::Open;
        // After the fault the stick has to be centred before it moves the crane again.
        self.manual.deadman.interlock();
        // The plan is given up: an accepted move that has not begun will not run.
        let lost = self.requests.cancel_planned(self.now_s(), self.now_ms);
        self.counters.frames_ignored = self.counters.frames_ignored.saturating_add(lost);
        self.mode = match reaction {
            Reaction::Controlled => Mode::Stopping(fault),
            Reaction::Quick => Mode::QuickStop(fault),
            Reaction::Halt => Mode::Halted(fault),
        };
        self.announce(fault);
    }

    /// The EMCYs announcing `fault` ([`services::emcy::announcement`]).
    pub(super) fn announce(&mut self, fault: Fault) {
        let drive_node = fault.drive().map_or(0, |d| self.node_of(d));
        let (emcy, abort) = services::emcy::announcement(self.nmt.node.id, fault, drive_node);
        self.send_emcy(emcy);
        if let Some(abort) = abort {
            self.send_emcy(abort);
        }
    }
}
