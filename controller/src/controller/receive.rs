//! Frames received between cycles: each dispatched on arrival to the service it
//! belongs to (SDO, NMT, heartbeats, the drives' TPDOs and EMCYs, the inclinometer's
//! frames, the supervisor's requests and the operator's frames).

use super::*;

impl<F, C, K, const A: usize> Controller<F, C, K, A>
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: Crane<A>,
{
    /// Takes one received frame. Frames it does not understand are ignored and counted:
    /// they never change a set point.
    pub fn on_frame(&mut self, frame: &CanFrame, now_ms: u64) {
        if canopen::cob::produced_by(self.nmt.node.id, frame.id()) {
            self.counters.frames_received = self.counters.frames_received.saturating_add(1);
            self.fault(Fault::DuplicateNodeId);
            return;
        }
        // `C::ENABLED` is a constant: without the feedback none of the inclinometer's
        // code is linked.
        if C::ENABLED && self.on_inclinometer_frame(frame, now_ms) {
            self.counters.frames_received = self.counters.frames_received.saturating_add(1);
            return;
        }
        let Ok(incoming) = canopen::decode(frame) else {
            self.ignore();
            return;
        };
        // A TPDO that reaches here is a drive's: its contents are CiA 402's.
        let tpdo = match incoming {
            Incoming::Tpdo { frame, .. } => match Tpdo::decode(&frame) {
                Ok(tpdo) => Some(tpdo),
                Err(_) => {
                    self.ignore();
                    return;
                }
            },
            _ => None,
        };
        self.counters.frames_received = self.counters.frames_received.saturating_add(1);
        match incoming {
            Incoming::Nmt { command, node } => {
                if node == 0 || node == self.nmt.node.id {
                    self.on_nmt(command);
                }
            }
            Incoming::Heartbeat { node, state } => {
                if let Some(drive) = self.drive_at(node) {
                    self.on_heartbeat(drive, state, now_ms);
                } else if self.supervisor_node() == Some(node) {
                    self.last_supervisor_heartbeat_ms = Some(now_ms);
                }
            }
            Incoming::Tpdo { node, .. } => match (self.drive_at(node), tpdo) {
                (
                    Some(drive),
                    Some(Tpdo::Status {
                        statusword,
                        velocity,
                    }),
                ) => {
                    // A drive being commissioned: its mapping is not confirmed yet.
                    if self.link(drive).is_some_and(DriveLink::linked) {
                        self.on_status(drive, statusword, velocity, now_ms);
                    }
                }
                (Some(drive), Some(Tpdo::Position { position, mode })) => {
                    if !self.link(drive).is_some_and(DriveLink::linked) {
                        return;
                    }
                    let judged = self.judge_position(drive, position, now_ms);
                    let Some(link) = self.link_mut(drive) else {
                        return;
                    };
                    // A jump stays implausible — which of the two readings is true is
                    // not known — until the drive is commissioned again (it reboots or
                    // is reset); a position outside the workspace is judged anew.
                    let implausible = match (judged, link.implausible) {
                        (None, Some(Implausibility::Jump)) => Some(Implausibility::Jump),
                        (judged, _) => judged,
                    };
                    link.implausible = implausible;
                    // A reading outside the workspace is no baseline for the next.
                    if judged != Some(Implausibility::Position) {
                        link.position = Some(position);
                    }
                    link.mode_display = Some(mode);
                    link.last_position_ms = Some(now_ms);
                    if let Some(what) = implausible {
                        self.fault(Fault::Implausible(drive, what));
                    } else if mode != link.commissioning.setup().mode.code() {
                        self.fault(Fault::DriveMode(drive));
                    }
                }
                _ => self.ignore(),
            },
            Incoming::Emergency {
                node,
                code,
                register,
            } => match self.drive_at(node) {
                Some(drive) => {
                    if emcy::is_fault(code, register) {
                        self.fault(Fault::DriveFault(drive));
                    } else if code != emcy::NO_ERROR {
                        self.warn();
                    }
                }
                None => self.ignore(),
            },
            Incoming::SdoResponse { node, data } => {
                let Some(drive) = self.drive_at(node) else {
                    self.ignore();
                    return;
                };
                match self
                    .link_mut(drive)
                    .and_then(|l| l.commissioning.on_response(&data, now_ms))
                {
                    // The next request goes out with the next cycle.
                    Some(progress) => {
                        let outbox = self.on_progress(drive, progress);
                        if let Some(link) = self.link_mut(drive) {
                            link.outbox = outbox;
                        }
                    }
                    None => self.ignore(),
                }
            }
            Incoming::SdoRequest { node, data } => {
                if node != self.nmt.node.id {
                    // Another server's traffic: not for us.
                    return;
                }
                // CiA 301: SDO is served in pre-operational and operational, not stopped.
                if self.nmt.node.state != NmtState::Stopped {
                    // Served only if its answer has a place: a request is never acted
                    // on unanswered (a client beyond SDO_ANSWERS waiting is counted).
                    if self.sdo_answers.is_full() {
                        self.ignore();
                        return;
                    }
                    let snapshot = self.snapshot();
                    let mut od = Dictionary {
                        node: &mut self.nmt.node,
                        snapshot,
                    };
                    if let Some(answer) = sdo::serve(&mut od, self.config.node, &data) {
                        // Not full: checked above.
                        let _ = self.sdo_answers.push_back(answer);
                    }
                    // A request written over SDO: taken as the command frame's.
                    if core::mem::take(&mut self.nmt.node.request.submitted) {
                        if let Ok(request) = self.nmt.node.request.request() {
                            self.on_request(request);
                        }
                    }
                    // An operator frame written over SDO (0x2010): taken as RPDO3's.
                    if core::mem::take(&mut self.nmt.node.operator.submitted) {
                        if let Ok(operator) = self.nmt.node.operator.frame() {
                            self.on_operator(operator, now_ms);
                        }
                    }
                }
            }
            // The supervisor's command frame: the controller's own RPDO1. (Another
            // node's RPDO1 — a PLC's to its own devices — is not ours.)
            Incoming::Rpdo1 { node, frame } if node == self.nmt.node.id => {
                match commands::decode_request(frame.data()) {
                    // PDOs are processed only in *operational* (CiA 301).
                    Ok(request) if self.nmt.node.state == NmtState::Operational => {
                        self.on_request(request);
                    }
                    _ => self.ignore(),
                }
            }
            // The supervisor's 3D move frame: the controller's own RPDO2.
            Incoming::Rpdo2 { node, frame } if node == self.nmt.node.id => {
                match commands::decode_move3d(frame.data()) {
                    Ok(request) if self.nmt.node.state == NmtState::Operational => {
                        self.on_request(request);
                    }
                    _ => self.ignore(),
                }
            }
            // The operator's speed demand: the controller's own RPDO3. A frame the crane
            // cannot follow (a demand along y to the planar crane) is malformed for it.
            Incoming::Rpdo3 { node, frame } if node == self.nmt.node.id => {
                match operator::decode_operator(frame.data()) {
                    Ok(operator) if self.nmt.node.state == NmtState::Operational => {
                        self.on_operator(operator, now_ms);
                    }
                    _ => self.ignore(),
                }
            }
            // Another node's RPDO3 (a PLC's to its own devices) is not ours.
            Incoming::Rpdo3 { .. } => {}
            // A commissioned drive's RPDO1 is the controller's to send: while it sends
            // it (operational), another node sending it is a second master moving the
            // drive.
            Incoming::Rpdo1 { node, .. } => {
                let Some(drive) = self.drive_at(node) else {
                    return;
                };
                if self.nmt.node.state == NmtState::Operational
                    && self.link(drive).is_some_and(DriveLink::linked)
                {
                    self.fault(Fault::ForeignProducer(Foreign::Rpdo(drive)));
                }
            }
            Incoming::Rpdo2 { .. } => {}
            // The controller is the SYNC producer (0x1005): while it sends SYNC another
            // producer's makes the drives apply set points and answer out of turn.
            Incoming::Sync => {
                if self.syncing {
                    self.fault(Fault::ForeignProducer(Foreign::Sync));
                }
            }
        }
    }

    /// A frame of the inclinometer (its TPDO1 *slope long16*, heartbeat, SDO response,
    /// EMCY): taken here, `true`. An EMCY that reports a fault makes its angles count
    /// as missing until it is commissioned again (the feedback's degraded rule decides).
    pub(super) fn on_inclinometer_frame(&mut self, frame: &CanFrame, now_ms: u64) -> bool {
        let Some(sensor) = self.links.sensor_mut() else {
            return false;
        };
        let setup = *sensor.commissioning.setup();
        let node = u16::from(setup.node);
        let id = frame.id();
        if id == canopen::cob::TPDO1 + node {
            match cia410::decode_tpdo1(frame, setup.two_axes()) {
                Ok(slopes) if sensor.commissioning.phase() == Phase::Done => {
                    sensor.swing = Some(setup.swing(slopes));
                    sensor.fresh = true;
                }
                Ok(_) => {}
                Err(_) => self.ignore(),
            }
            return true;
        }
        let Ok(incoming) = canopen::decode(frame) else {
            return false;
        };
        match incoming {
            Incoming::Heartbeat { node, state } if node == setup.node => {
                sensor.last_heartbeat_ms = Some(now_ms);
                sensor.nmt = Some(state);
                sensor.commissioning.heard_of();
                // As for a drive (`links::on_heartbeat`).
                let (action, left) = links::on_heartbeat(
                    state,
                    sensor.commissioning.phase(),
                    sensor.seen_operational,
                    self.nmt.node.role == Role::Manager,
                );
                if left {
                    sensor.swing = None;
                    sensor.seen_operational = false;
                }
                match action {
                    Heartbeat::Commission => {
                        sensor.swing = None;
                        sensor.seen_operational = false;
                        sensor.outbox = Some(sensor.commissioning.begin(now_ms));
                    }
                    Heartbeat::Start => {
                        if let Some(frame) = sensor.commissioning.start(now_ms) {
                            sensor.outbox = Some(frame);
                        }
                    }
                    Heartbeat::Resumed => sensor.seen_operational = true,
                    Heartbeat::Nothing => {}
                }
                true
            }
            Incoming::SdoResponse { node, data } if node == setup.node => {
                match sensor.commissioning.on_response(&data, now_ms) {
                    Some(Progress::Send(frame)) => sensor.outbox = Some(frame),
                    Some(Progress::Done) => {}
                    Some(Progress::Failed { error, abort }) => {
                        sensor.outbox = abort;
                        self.inclinometer_failed(error);
                    }
                    None => self.ignore(),
                }
                true
            }
            Incoming::Emergency {
                node,
                code,
                register,
            } if node == setup.node => {
                if emcy::is_fault(code, register) {
                    sensor.swing = None;
                    sensor.nmt = None;
                }
                true
            }
            _ => false,
        }
    }

    /// An NMT command for this node (or all): the node's NMT slave obeys it
    /// ([`Node::on_nmt`]); outside *operational*, what waits is refused and a move is a
    /// fault.
    pub(super) fn on_nmt(&mut self, command: NmtCommand) {
        self.nmt
            .on_command(command, self.config.heartbeat_period_ms);
        if self.nmt.node.state != NmtState::Operational {
            // Requests are process data: none taken in operational is acted on outside
            // it — each waiting one is refused (answered when the status may go out).
            self.refuse_waiting(true);
            if self.moving_for_supervision() {
                self.fault(Fault::NotOperational);
            }
        }
    }

    /// A drive's heartbeat or boot-up message (`links::on_heartbeat` decides). A drive
    /// that left *operational* is a fault during a move; at rest it is brought back: a
    /// stopped one (configuration intact) by NMT *start* from a manager or its master,
    /// any other by commissioning it again. Whatever it reported before counts no more.
    pub(super) fn on_heartbeat(&mut self, drive: Drive, state: NmtState, now_ms: u64) {
        let manager = self.nmt.node.role == Role::Manager;
        let Some(link) = self.link_mut(drive) else {
            return;
        };
        link.last_heartbeat_ms = Some(now_ms);
        link.nmt = Some(state);
        link.commissioning.heard_of();
        let phase = link.commissioning.phase();
        // Seen operational since it was commissioned (its TPDO clock runs).
        let was_operational = link.last_tpdo_ms.is_some();
        let (action, left) = links::on_heartbeat(state, phase, was_operational, manager);
        if left {
            link.forget_process_data();
            self.drive_left_operational(drive, state);
        }
        let Some(link) = self.link_mut(drive) else {
            return;
        };
        match action {
            Heartbeat::Commission => self.recommission(drive, now_ms),
            Heartbeat::Start => {
                if let Some(frame) = link.commissioning.start(now_ms) {
                    link.outbox = Some(frame);
                }
            }
            // The TPDOs' clocks start when the drive is (again) seen operational.
            Heartbeat::Resumed => link.restart_clocks(now_ms),
            Heartbeat::Nothing => {}
        }
    }

    pub(super) fn on_status(&mut self, drive: Drive, sw: u16, velocity: i32, now_ms: u64) {
        let max_velocity = self.gate.limits(drive).map_or(0.0, |l| l.max_velocity);
        let overspeed = self.config.overspeed * max_velocity * UNITS_PER_M_PER_S;
        if f64::from(velocity).abs() > overspeed {
            self.fault(Fault::Implausible(drive, Implausibility::Velocity));
        }
        let moving = self.moving();
        let asked = self.gate.last(drive) != Setpoint::ZERO;
        let not_following_limit = self.config.not_following_tpdos;
        let Some(link) = self.link_mut(drive) else {
            return;
        };
        let report = link.on_status(sw, velocity, now_ms, asked, not_following_limit);
        if report.warning {
            self.warn();
        }
        if report.fault {
            // During a reset's fault-reset sequence a fault statusword is expected (it
            // may lag a few SYNCs); one still there when the sequence ends is a fault.
            if self.resetting == 0 {
                self.fault(Fault::DriveFault(drive));
            }
        } else if report.not_following || (moving && report.remote_lost) {
            self.fault(Fault::DriveMode(drive));
        }
    }

    /// Whether a drive's position actual (`units`) is one it can have: inside its axis's
    /// range of the workspace (trolley x, rope length l) within
    /// [`Config::position_tolerance_m`], and no further from its last one than the drive
    /// can move in the time between at [`Config::overspeed`] times its velocity limit
    /// (at least a cycle's worth), plus the tolerance's tenth.
    pub(super) fn judge_position(
        &self,
        drive: Drive,
        units: i32,
        now_ms: u64,
    ) -> Option<Implausibility> {
        let link = self.link(drive)?;
        let setup = link.commissioning.setup();
        let (lo, hi) = *drive::of(&K::DRIVES, drive, &self.planner.ranges())?;
        let max_velocity = self.gate.limits(drive)?.max_velocity;
        let tolerance = self.config.position_tolerance_m;
        let at = setup.metres(units);
        if !(lo - tolerance..=hi + tolerance).contains(&at) {
            return Some(Implausibility::Position);
        }
        let (Some(last), Some(last_ms)) = (link.position, link.last_position_ms) else {
            return None;
        };
        let dt = now_ms
            .saturating_sub(last_ms)
            .max(u64::from(self.config.period_ms)) as f64
            / 1000.0;
        let reach = self.config.overspeed * max_velocity * dt + 0.1 * tolerance;
        ((at - setup.metres(last)).abs() > reach).then_some(Implausibility::Jump)
    }

    /// A request off the bus (docs/COMMANDS.md, "Requests"; [`Requests::take`]
    /// decides what it is). One that finds no place for its answer is ignored.
    pub(super) fn on_request(&mut self, request: Request) {
        if !self.requests.take(request, self.now_ms) {
            self.ignore();
        }
    }

    /// Answers `request` (once: its status frame is queued) and remembers it for repeats.
    pub(super) fn give_answer(&mut self, request: Request, answer: Result<Answer, Reject>) {
        if !self.requests.answer(request, answer, self.now_ms) {
            self.ignore();
        }
    }

    /// The move being planned and the moves waiting are refused
    /// ([`Requests::refuse_waiting`]).
    pub(super) fn refuse_waiting(&mut self, resets: bool) {
        let lost = self.requests.refuse_waiting(resets, self.now_ms);
        self.counters.frames_ignored = self.counters.frames_ignored.saturating_add(lost);
    }
}
