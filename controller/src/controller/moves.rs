//! The supervisor's requests carried out: moves planned and started, stops on the
//! path, the loop closed, a reset to where the drives stand (docs/COMMANDS.md).

use super::*;

impl<F, C, K, const A: usize> Controller<F, C, K, A>
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: Crane<A>,
{
    /// Takes one move or reset (docs/COMMANDS.md): answers it, or starts planning a move.
    /// (Stops are obeyed before, by [`Controller::obey_stop`], and answered on arrival.)
    pub(super) fn handle(&mut self, request: Request) {
        let answer = match request {
            Request::Move {
                target: [x, z],
                duration,
                ..
            }
            | Request::Move3d {
                target: [x, _, z],
                duration,
                ..
            } => {
                let y = match request {
                    Request::Move3d { target, .. } => target.get(1).copied(),
                    _ => None,
                };
                let plan = self.feedforward.plan();
                // A request this crane cannot express (a y for the planar crane) is
                // invalid whatever the crane's state: checked first, so the answer does
                // not depend on when it was sent.
                match K::target(x, y, z, plan.final_position().into()) {
                    None => Err(Reject::Invalid),
                    // (Nor while the operator's stick takes the crane over.)
                    Some(_) if !self.may_move() || self.manual.handing_over => {
                        Err(Reject::NotReady)
                    }
                    Some(_) if !self.in_place() => Err(Reject::NotInPlace),
                    Some(_) if plan.has_queued() => Err(Reject::Busy),
                    Some(target) => match MoveSearch::new(plan, target, duration) {
                        Ok(search) => {
                            self.requests.plan(PendingMove {
                                request,
                                target,
                                search,
                            });
                            return;
                        }
                        Err(r) => Err(r),
                    },
                }
            }
            // Answered on arrival and obeyed by `obey_stop`; never queued.
            Request::Stop { .. } => Ok(Answer::Accepted),
            Request::Reset { .. } if self.nmt.node.state != NmtState::Operational => {
                Err(Reject::NotReady)
            }
            Request::Reset { .. } => match self.mode {
                Mode::Halted(_) => self.reset().map(|()| Answer::Accepted),
                Mode::Stopping(_) | Mode::QuickStop(_) => Err(Reject::NotReady),
                // None is taken while the crane moves (a move, or a stop still bringing
                // it to rest): it is refused until rest.
                Mode::Enabling | Mode::Ready if self.moving() => Err(Reject::Moving),
                // At rest a reset takes the drives' positions as where the crane is (after
                // a move refused as not in place).
                Mode::Enabling | Mode::Ready => self.read_positions().map(|()| Answer::Accepted),
            },
        };
        self.give_answer(request, answer);
    }

    /// The plan after `step`: what has ended by `step.t` retired. Once the plan rests —
    /// its last segment ended, or what is left of it can no longer be seen (set points
    /// that round to zero, and less than [`REST_TRAVEL_M`] to go for every drive) — the
    /// model starts again at rest where the plan ends, at `step.t`, and this step's set
    /// points are the exact inverse's at rest: zero. A multistep scheme answers a move's
    /// end with a few cycles of set points ringing around zero (±1–54 µm/s after the
    /// paper's moves with BDF4), and a stop's last few hundredths of a second send zeros
    /// while the plan still runs (a move sent then would wait for it): at rest, the set
    /// points are exactly zero and a move starts at once (docs/COMMANDS.md, "Rest").
    pub(super) fn settle(&mut self, mut step: FeedforwardStep<A>) -> FeedforwardStep<A> {
        let plan = self.feedforward.plan_mut();
        let had_motion = plan.active().is_some();
        plan.retire(step.t);
        let plan = self.feedforward.plan();
        let ended = had_motion && plan.active().is_none();
        let zero = step
            .u
            .iter()
            .all(|u| libm::round(u * UNITS_PER_M_PER_S) == 0.0);
        // (The drives' positions, not the load's: the trolley's last swing-cancelling
        // motion outlasts the load's by a tenth of a second.)
        let unseen = zero && plan.active().is_some() && !plan.has_queued() && {
            let here = SVector::from(self.planner.drive_positions(plan, step.t));
            let rest = SVector::from(self.planner.drives_at_rest(plan.final_position().into()));
            (rest - here).amax() < REST_TRAVEL_M
        };
        if ended || unseen {
            let rest = plan.final_position().into();
            // (A restart that fails leaves the model as it was: its steps go on.)
            if self.feedforward.restart_at_rest(rest, step.t).is_ok() {
                step.u = [0.0; A];
            }
        }
        self.manual.model_still = if zero || step.u == [0.0; A] {
            self.manual.model_still.saturating_add(1)
        } else {
            0
        };
        step
    }

    /// Obeys the stops that arrived since the last cycle (one or many: the same stop).
    /// The queued move is dropped, and a move that has not begun; the running one is
    /// re-timed to rest on its own path at or before its target if that is quicker
    /// within the limits, else it is the stop. At rest, and while already stopping or
    /// halted, there is nothing to stop.
    pub(super) fn obey_stop(&mut self) {
        let now = self.now_s();
        // Manual mode: the generator's sway-free stop, and the stick has to be centred
        // before it moves the crane again (the zero-position interlock); a hand-over
        // from an automatic move is called off (its move stops as any).
        self.manual.deadman.interlock();
        self.manual.handing_over = false;
        if self.mode == Mode::Ready {
            if let Some(path) = self.feedforward.path_mut().manual_mut() {
                path.stop(&self.planner.limits());
                self.manual.stop_held = true;
                return;
            }
        }
        if self.mode == Mode::Ready && self.feedforward.plan().is_moving(now) {
            self.stop_on_path(now);
        }
    }

    /// The plan re-timed at `now` to rest on its own path at or before its target if
    /// that is quicker within the limits, else the queued move and a move that has not
    /// begun are dropped (the running one then ends as planned).
    pub(super) fn stop_on_path(&mut self, now: f64) {
        let stop = self.planner.plan_stop(self.feedforward.plan(), now);
        let plan = self.feedforward.plan_mut();
        plan.cancel_from(now);
        if let Some(stop) = stop {
            plan.apply_stop(stop);
        }
    }

    /// Whether a move may be accepted: ready, every drive ready, and the controller
    /// operational (a move is process data, and a stop frame is one too).
    pub(super) fn may_move(&self) -> bool {
        self.mode == Mode::Ready
            && self.drives_ready()
            && self.nmt.node.state == NmtState::Operational
            && !self.feedforward.path().in_manual()
    }

    /// Advances the move being planned by this cycle's share of samples; places it in
    /// the plan and answers when its search is done. A fault meanwhile refuses it.
    pub(super) fn plan_pending(&mut self) {
        let Some(mut pending) = self.requests.take_pending() else {
            return;
        };
        if !self.may_move() {
            self.give_answer(pending.request, Err(Reject::NotReady));
            return;
        }
        let mut budget = SAMPLES_PER_CYCLE;
        let Some(result) = pending.search.advance(&self.planner, &mut budget) else {
            self.requests.plan(pending);
            return;
        };
        let now = self.now_s();
        let at_rest = !self.moving();
        let placed = result.and_then(|duration| {
            let plan = self.feedforward.plan_mut();
            let moving = plan.is_moving(now);
            // The search checked the path on [0, T]; it is placed now or after the
            // running move, which shifts it in time and changes nothing it checked.
            let m = plan
                .candidate(pending.target.into(), now, duration)
                .map_err(|_| Reject::Busy)?;
            plan.push(m).map_err(|_| Reject::Busy)?;
            let answer = if moving {
                Answer::Queued
            } else {
                Answer::Accepted
            };
            Ok((answer, m.t_start()))
        });
        if placed.is_ok() {
            self.close_loop(at_rest);
        }
        self.give_answer(pending.request, placed.map(|(answer, _)| answer));
        if let Ok((_, t_start)) = placed {
            self.requests.planned(pending.request, t_start);
        }
    }

    /// A move was accepted (`at_rest`: the crane was at rest when it was): the feedback
    /// acts on it ([`Loop::Closed`]). If it had stopped reading the angle and the crane
    /// was at rest, it starts again, its observer from the next good measurement (its
    /// degraded rule takes it off again if the angle is still bad).
    ///
    /// On an observer started now at rest, or one only observing, the loop closes as
    /// the plan's move starts ([`Self::close_loop_as_the_move_starts`]), as the stick's
    /// first demand closes it in manual mode — whatever else is accepted meanwhile (a
    /// move queued behind one that has not started is no start). A move placed to start
    /// later (the scene's demonstration move) left the travel acting on the young
    /// estimate's noise until then (0.063 m/s, `operator_feedback`, on 3f6faa8). A
    /// request's move on a crane at rest starts now: its loop closes in the cycle that
    /// accepts it.
    pub(super) fn close_loop(&mut self, at_rest: bool) {
        if C::ENABLED {
            let started = self.start_observer(at_rest);
            let observing = self.feedback_loop == Loop::Observing;
            self.feedback_loop = if observing || (at_rest && started) {
                Loop::Observing
            } else {
                Loop::Closed
            };
        }
    }

    /// An observing loop closes once the plan's move has started, the travel let go as
    /// the stick's first demand lets it go ([`Self::close_observed_loop`]). A move
    /// starting in this cycle counts (its path leaves rest from here); a stop given
    /// earlier in the cycle has already cancelled one that had not begun
    /// ([`crate::requests`]), and a stop segment is no move.
    pub(super) fn close_loop_as_the_move_starts(&mut self) {
        if self.feedback_loop != Loop::Observing {
            return;
        }
        let now = self.now_s();
        let started = match self.feedforward.plan().active() {
            Some(segment @ Segment::Move(_)) => {
                let (start, end) = segment.span();
                start <= now && now < end
            }
            _ => false,
        };
        if started {
            self.close_observed_loop();
        }
    }

    /// Manual mode entered at rest: the observer starts as [`Self::close_loop`] starts
    /// it, but its correction is held ([`Loop::Observing`]) until a command. A loop
    /// closed before by a move goes on as it was (its correction at rest follows that
    /// command), unless its observer starts again.
    pub(super) fn observe_at_rest(&mut self) {
        if C::ENABLED && (self.start_observer(true) || self.feedback_loop == Loop::Observing) {
            self.feedback_loop = Loop::Observing;
        }
    }

    /// The stick's first demand since manual mode was entered at rest is the command:
    /// the correction is sent from this cycle on, the trolley let go while the estimate
    /// shows nothing to hold it for (the demand may move the hoist alone:
    /// [`AxesCorrection::let_go_at_rest`]).
    pub(super) fn close_observed_loop(&mut self) {
        if self.feedback_loop == Loop::Observing {
            self.feedback_loop = Loop::Closed;
            self.correction.let_go_at_rest();
        }
    }

    /// Starts the observer afresh if the loop is open, or if the feedback stopped
    /// reading the angle and the crane is at rest. Returns whether it did.
    fn start_observer(&mut self, at_rest: bool) -> bool {
        let degraded = self
            .correction
            .mode()
            .and_then(FeedbackMode::degraded)
            .is_some();
        let starts = self.feedback_loop == Loop::Open || (degraded && at_rest);
        if starts {
            self.correction.restart();
            self.feedback_announced = None;
        }
        starts
    }

    /// The drives' position actual (0x6064) at standstill, in the model's input order
    /// (planar: trolley position and rope length). `None` if a drive's position is
    /// unknown or stale, or a drive still moves.
    pub(super) fn measured_rest(&self) -> Option<[f64; A]> {
        let mut position = [0.0; A];
        for (drive, slot) in K::DRIVES.into_iter().zip(position.iter_mut()) {
            let link = self.link(drive)?;
            let fresh = link.last_position_ms.is_some_and(|t| {
                self.now_ms.saturating_sub(t) <= u64::from(self.config.tpdo_timeout_ms)
            });
            if !fresh
                || link.implausible.is_some()
                || link.velocity.unsigned_abs() > self.config.standstill_units.unsigned_abs()
            {
                return None;
            }
            let setup = link.commissioning.setup();
            *slot = setup.metres(link.position?);
        }
        Some(position)
    }

    /// Leaves *halted*: the drives' measured position, the fault-reset sequence to a
    /// faulted drive, a failed commissioning started again, the model restarted at rest
    /// where the load hangs, the enable sequence, EMCY 0x0000. Refused while a drive
    /// still moves or its position is not known.
    pub(super) fn reset(&mut self) -> Result<(), Reject> {
        self.read_positions()?;
        for drive in K::DRIVES {
            if self
                .link(drive)
                .is_some_and(|l| matches!(l.commissioning.phase(), Phase::Failed(_)))
            {
                self.recommission(drive, self.now_ms);
            }
        }
        self.resetting = self.config.fault_reset_cycles;
        self.last_miss_cycle = None;
        self.failed_cycles = 0;
        self.mode = Mode::Enabling;
        self.send_emcy(canopen::emcy(self.nmt.node.id, emcy::NO_ERROR, 0, [0; 5]));
        Ok(())
    }

    /// Takes the drives' position actual as where the crane is: the model restarts at rest
    /// with the load where it hangs below them ([`Crane::load_at_rest`]), the motion
    /// supervision counts from them, and the feedback starts afresh. Refused while a drive
    /// still moves or its position is not known.
    pub(super) fn read_positions(&mut self) -> Result<(), Reject> {
        let position = self.measured_rest().ok_or(Reject::NotReady)?;
        self.feedforward
            .restart_at_rest(self.planner.load_at_rest(position), self.now_s())
            .map_err(|_| Reject::Invalid)?;
        for (drive, at) in K::DRIVES.into_iter().zip(position) {
            if let Some(link) = self.link_mut(drive) {
                link.motion.rebase(at);
            }
        }
        self.correction.restart();
        self.feedback_announced = None;
        // Its observer starts afresh, so the loop waits for a command, as after boot: a
        // feedback acting at rest from a new observer moved the trolley on the sensors'
        // noise before it trusted the angle.
        self.feedback_loop = Loop::Open;
        // The range guard's latches are the old model's.
        self.range_latches = [range::Latches::default(); A];
        // The model restarted (a reset, or the positions read again): centred frames
        // received while halted do not count, the stick has to be centred again before
        // it moves the crane (the zero-position interlock).
        self.manual.deadman.interlock();
        Ok(())
    }

    /// The fault-reset sequence: controlword bit 7 high for three cycles, then low for one
    /// (a rising edge every four cycles: the first against the halt's *quick stop*), so
    /// that a drive that missed an edge, or whose statusword lags a few SYNCs, is reset
    /// without a new fault.
    pub(super) fn fault_reset_command(&self) -> u16 {
        let elapsed = self
            .config
            .fault_reset_cycles
            .saturating_sub(self.resetting);
        if elapsed % 4 == 3 {
            controlword::DISABLE_VOLTAGE
        } else {
            controlword::FAULT_RESET
        }
    }
}
