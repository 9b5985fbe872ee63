//! Manual mode (docs/COMMANDS.md, "Manual mode"): the operator's frames, entering
//! and leaving the mode, the hand-over from an automatic move, the refusal's EMCY and
//! the status frame's mode byte.

use super::*;

/// Manual mode's state beside the generator (which the model's path owns): what the
/// controller keeps between cycles to enter, steer and leave the mode.
#[derive(Debug, Clone)]
pub(super) struct Manual {
    /// The operator's dead-man: whether the stick may move the crane.
    pub(super) deadman: Deadman,
    /// The refusal of the operator's request for manual mode last announced (EMCY
    /// 0xFF21), until the request is withdrawn or granted.
    pub(super) refused: Option<Refusal>,
    /// A stop request (0x210) latched the generator's stop: it holds until the load
    /// rests, whatever the stick does meanwhile.
    pub(super) stop_held: bool,
    /// The stick deflected during an automatic move: the move stops on its path, and
    /// manual mode is entered at its rest with the stick live.
    pub(super) handing_over: bool,
    /// Cycles in a row the model's own set points were zero in drive units: manual mode
    /// is left only when the model rests, its history too.
    pub(super) model_still: u8,
}

impl Manual {
    /// Nothing asked yet; the stick's `deadband` (the generator's) is the one the
    /// interlock checks.
    pub(super) fn new(deadband: f64) -> Self {
        Self {
            deadman: Deadman::new(operator::DEADLINE_MS, deadband),
            refused: None,
            stop_held: false,
            handing_over: false,
            model_still: 0,
        }
    }
}

impl<F, C, K, const A: usize> Controller<F, C, K, A>
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: Crane<A>,
{
    /// An operator frame (RPDO3, or 0x2010 written over SDO), well-formed. One the crane
    /// cannot follow is ignored and counted, as a malformed one.
    pub(super) fn on_operator(&mut self, frame: OperatorFrame, now_ms: u64) {
        if frame.fits(A.saturating_sub(1)).is_err() {
            self.ignore();
            return;
        }
        self.manual.deadman.on_frame(&frame, now_ms);
    }

    /// Manual mode, once a cycle before the model's step (docs/COMMANDS.md, "Manual
    /// mode"): entered when a live operator asks for it — at rest, the stick interlocked,
    /// or during an automatic move when the stick is deflected (the hand-over); a request
    /// the controller cannot grant is announced once (EMCY 0xFF21). The stick's demand
    /// (zero while interlocked) advances the generator on every cycle the model steps in
    /// manual mode, the entry cycle included, so that the model evaluates each of the
    /// generator's pieces on its own cycle; a dead-man loss or the request withdrawn
    /// latches its sway-free stop and interlocks the stick; a stop request's stop holds
    /// until the load rests; manual mode is left at rest once the operator is lost or no
    /// longer asks for it.
    // Kept out of line: inlined into the cycle it changed the firmware's inlining
    // (QEMU: the RADAU5 scene's control-task stack grew by 1,200 bytes).
    #[inline(never)]
    pub(super) fn steer_manual(&mut self) {
        let frame = self.manual.deadman.frame();
        let lost = matches!(self.manual.deadman.state(self.now_ms), Stick::Lost(_));
        let asked = !lost && frame.is_some_and(|f| f.flags.manual);
        if !self.feedforward.path().in_manual() {
            self.manual.stop_held = false;
            if !asked {
                // (A hand-over's stop goes on to rest: the move was ended by the stick.)
                self.manual.refused = None;
                self.manual.handing_over = false;
                return;
            }
            match self.enter_manual(frame) {
                // An automatic move runs: manual mode waits for its rest, or the stick.
                None => return,
                Some(Err(refusal)) => {
                    self.refuse_manual(refusal);
                    return;
                }
                // On to advance the generator in this very cycle: the model steps over
                // [t, t + h] right after, and the generator's piece is for that cycle.
                Some(Ok(())) => self.manual.refused = None,
            }
        } else if !matches!(self.mode, Mode::Enabling | Mode::Ready) {
            // The model does not step (a stop's ramp, halted): nor does the generator.
            return;
        } else if !asked
            && self
                .feedforward
                .path_mut()
                .manual_mut()
                .is_some_and(|path| path.is_at_rest())
            && self.manual.model_still >= MODEL_REST_CYCLES
            && self.feedforward.path_mut().leave_manual().is_ok()
        {
            // Left at rest: the path resting and the model's set points zero for
            // `MODEL_REST_CYCLES` (they reach it a few cycles after the path rests, and
            // may cross zero on the way: BDF's history). The feedback's corrections do
            // not count: they go on in either mode. (Refused only while it moves, or if
            // the plan cannot rest there: then the generator goes on resting, advanced
            // below.)
            return;
        }
        let Some(path) = self.feedforward.path_mut().manual_mut() else {
            return;
        };
        if self.manual.stop_held && path.is_at_rest() {
            // The stop request's stop is over: the stick moves the load again once it
            // is centred after it (centring during the stop does not count).
            self.manual.stop_held = false;
            self.manual.deadman.interlock();
        }
        // The state again: an entry or the end of a stop just now interlocked the stick.
        let state = self.manual.deadman.state(self.now_ms);
        // Enabling (a drive came back after leaving operational at rest): the model
        // steps, so the generator is advanced, its stop latched: the drives are not
        // ready for the stick.
        let ready = self.mode == Mode::Ready;
        let stick = match (state, frame) {
            (Stick::Live, Some(f)) if asked && ready => {
                f.demand::<2>(self.manual.deadman.deadband()).ok()
            }
            _ => None,
        };
        if !asked || !ready {
            // A dead-man loss, the request withdrawn, or the drives not ready: the
            // sway-free stop, and the stick centred before it moves the crane again.
            path.stop(&self.planner.limits());
            self.manual.deadman.interlock();
        } else if state == Stick::Live && path.is_stopping() && !self.manual.stop_held {
            path.resume();
        }
        let ([x, y], z) = stick.unwrap_or(([0.0; 2], 0.0));
        // The state feedback no longer reads the angle (EMCY 0xFF20 said so): manual
        // mode goes on on feedforward, the travel speed capped.
        let cap = match self.feedback_announced.and_then(|m| m.degraded()) {
            Some(_) if C::ENABLED => operator::UNOBSERVED_SPEED_SHARE,
            _ => 1.0,
        };
        let moved = !path.advance([x * cap, y * cap], z).at_rest;
        if moved {
            // The stick's first demand since the entry at rest (past the generator's own
            // deadband) is the command: the feedback's correction is sent from this
            // cycle on, its observer started at the entry.
            self.close_observed_loop();
        }
    }

    /// Manual mode entered for a live operator who asks for it, if it can be now: at
    /// rest, the stick interlocked (centred frames counted before do not lift it). During
    /// an automatic move a deflected stick — live, centred since the request — takes the
    /// crane over in the same cycle: what waited for the move is refused, the generator
    /// takes the move over at the model's time (`Generator::reset_taking_over`: the move
    /// ends with a stop of its own, within what the drives' limits leave beside the
    /// operator's motion, [`operator::path::room`]) and the stick is live at once. When
    /// no such stop fits, the move ends with its on-path stop instead and manual mode is
    /// entered at its rest, the stick live. The supervisor hears which (EMCY 0xFF22).
    /// `None`: not now, manual mode waits (the move, or the on-path stop, runs).
    pub(super) fn enter_manual(
        &mut self,
        frame: Option<OperatorFrame>,
    ) -> Option<Result<(), Refusal>> {
        // A model that follows plans only: the stick neither enters nor takes anything
        // over (its frames cannot stop a move).
        if self.feedforward.path().stick_deadband().is_none() {
            return Some(Err(Refusal::Unsupported));
        }
        if !self.may_move() {
            self.manual.handing_over = false;
            return Some(Err(Refusal::NotReady));
        }
        if !self.moving() {
            let t = self.feedforward.time();
            // A hand-over's stick is live: the operator deflected it to take over.
            let handed_over = core::mem::take(&mut self.manual.handing_over);
            let entered = self.feedforward.path_mut().enter_manual(t);
            if entered.is_ok() {
                if !handed_over {
                    self.manual.deadman.interlock();
                }
                // The observer starts now, at rest, and learns the angle's offset there;
                // the correction is held until the stick's first demand: a crane at
                // rest with the stick centred is not commanded to move, and a feedback
                // acting from the entry moved it on the sensors' noise (up to 95 mm/s,
                // 4.3 mm within 0.3 s on the noisy plant) before its observer trusted
                // the angle. (A loop closed before, by a move, goes on as it was: its
                // correction at rest follows that command.)
                self.observe_at_rest();
            }
            return Some(entered.map_err(Refusal::of));
        }
        let deflected = frame.is_some_and(|f| !self.manual.deadman.centred(&f));
        let on_its_way = matches!(self.feedforward.plan().active(), Some(Segment::Move(_)));
        if self.manual.handing_over
            || !(deflected && on_its_way && self.manual.deadman.state(self.now_ms) == Stick::Live)
        {
            return None;
        }
        // The stick takes the crane over: what waited for the move is refused (reason
        // 2), as after a stop, a move sent again is a new request, and the supervisor
        // hears that its move will not reach its target.
        let (now, now_ms) = (self.now_s(), self.now_ms);
        self.requests.forget_answered();
        let lost =
            self.requests.cancel_planned(now, now_ms) + self.requests.refuse_waiting(false, now_ms);
        self.counters.frames_ignored = self.counters.frames_ignored.saturating_add(lost);
        let limits = self.planner.limits();
        let t = self.feedforward.time();
        let at_once = self.feedforward.path_mut().take_over(t, &limits).is_ok();
        let how = if at_once {
            // Manual mode from this cycle, the loop closed: the deflected stick is the
            // command (the feedback acts in manual mode, also after a move it did not act on: one
            // planned at boot and never commanded). Not at rest: a feedback that no longer
            // reads the angle is not restarted here — its observer starts from a crane at
            // rest (`Correction::restart`) — as for a move accepted while the crane moves.
            self.close_loop(false);
            emcy::TAKEN_OVER_AT_ONCE
        } else {
            self.stop_on_path(now);
            self.manual.handing_over = true;
            emcy::TAKEN_OVER_AT_REST
        };
        self.send_emcy(canopen::emcy(
            self.nmt.node.id,
            emcy::MOVE_TAKEN_OVER,
            REGISTER_MANUFACTURER,
            [emcy::MOVE_TAKEN_OVER_BYTE, 0, how, 0, 0],
        ));
        at_once.then_some(Ok(()))
    }

    /// Announces a refused request for manual mode (EMCY 0xFF21, a warning), once per
    /// request and reason.
    pub(super) fn refuse_manual(&mut self, refusal: Refusal) {
        if self.manual.refused == Some(refusal) {
            return;
        }
        self.manual.refused = Some(refusal);
        self.send_emcy(canopen::emcy(
            self.nmt.node.id,
            emcy::MANUAL_REFUSED,
            REGISTER_MANUFACTURER,
            [emcy::MANUAL_REFUSED_BYTE, 0, refusal.code(), 0, 0],
        ));
    }

    /// The status frame's mode byte: the supervisor state's, or
    /// [`operator::MANUAL_MODE_CODE`] while manual mode runs.
    pub(super) fn mode_code(&self) -> u8 {
        if self.mode == Mode::Ready && self.feedforward.path().in_manual() {
            operator::MANUAL_MODE_CODE
        } else {
            self.mode.code()
        }
    }
}
