//! The 100 Hz cycle: requests, one inverse-model step, two set points, the frames
//! that carry them, the drives' commissioning and supervision, and the reaction to
//! every fault (docs/COMMANDS.md, docs/COMMISSIONING.md).
//!
//! Time is injected (`now_ms` on every call), so the schedule — commissioning, SYNC every
//! cycle, heartbeat and status every 100 ms, the drives' heartbeat and TPDO timeouts —
//! and every reaction is tested on the host. The firmware's only job is to call
//! [`Controller::tick`] every cycle, feed received frames to [`Controller::on_frame`],
//! transmit what comes out, and report each cycle's cost and each failed transmission.

use heapless::{Deque, Vec};
use nalgebra::SVector;

use crate::canopen::emcy::{self, REGISTER_COMMUNICATION, REGISTER_GENERIC, REGISTER_MANUFACTURER};
use crate::canopen::sdo;
use crate::canopen::{self, nmt, Incoming, NmtCommand, NmtState};
use crate::cia402::pdo::{self, Tpdo};
use crate::cia402::{controlword, DriveState};
use crate::cia410;
use crate::commands::{self, Answer, Reject, Request, Status};
use crate::commissioning::{Commissioning, CommissioningError, Device, NodeSetup, Phase, Progress};
pub use crate::config::Config;
use crate::correction::{AxesCorrection, Measured};
use crate::drive::{self, Drive};
use crate::fault::Reaction;
pub use crate::fault::{Fault, FollowingError, Foreign, Implausibility};
use crate::feedback::{Mode as FeedbackMode, NoFeedback, Reference};
use crate::feedforward::{Feedforward, FeedforwardStep, Replan};
use crate::frame::CanFrame;
use crate::links::{self, DriveLink, Heartbeat, Link, Links, Silent};
use crate::motion::{Breach, Deviations, Lag};
use crate::node::{Dictionary, Node, Role, Snapshot, StagedOperator, StagedRequest};
use crate::operator::{self, Deadman, OperatorFrame, Refusal, State as Stick};
use crate::planner::{Crane, MoveSearch, Planner, SAMPLES_PER_CYCLE};
use crate::range;
use crate::requests::{PendingMove, Requests};
use crate::services;
use crate::services::nmt::NmtSlave;
use crate::services::status::StatusProducer;
use crate::setpoint::{Setpoint, SetpointGate, UNITS_PER_M_PER_S};
use solver_core::models::crane::CraneParams;
use solver_core::plan::Segment;

/// The supervisor state.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Commissioning the drives and walking them through the CiA 402 enable sequence;
    /// moves are refused, nothing moves.
    Enabling,
    /// Following the plan; moves are accepted.
    Ready,
    /// Controlled stop: ramping both drives to standstill.
    Stopping(Fault),
    /// Quick stop: both drives braking on their own ramps.
    QuickStop(Fault),
    /// At standstill, drives held by quick stop, waiting for a reset.
    Halted(Fault),
}

impl Mode {
    /// The mode byte of the status frame.
    #[must_use]
    pub fn code(&self) -> u8 {
        match self {
            Mode::Enabling => 0,
            Mode::Ready => 1,
            Mode::Stopping(_) => 2,
            Mode::QuickStop(_) => 3,
            Mode::Halted(_) => 4,
        }
    }

    /// The fault that left *ready*, if any.
    #[must_use]
    pub fn fault(&self) -> Option<Fault> {
        match *self {
            Mode::Stopping(f) | Mode::QuickStop(f) | Mode::Halted(f) => Some(f),
            _ => None,
        }
    }
}

/// Running totals, reported in the status frame and the logs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// Cycles run.
    pub cycles: u32,
    /// Frames received and understood.
    pub frames_received: u32,
    /// Frames ignored: malformed, unknown, out of range, of an unknown node, or a
    /// request beyond the queue's answers.
    pub frames_ignored: u32,
    /// Frames handed out for transmission.
    pub frames_sent: u32,
    /// Frames that did not fit a cycle's buffer (must stay 0).
    pub frames_lost: u32,
    /// Cycles that missed their deadline.
    pub deadline_misses: u32,
    /// Frames the board failed to transmit.
    pub tx_failures: u32,
    /// Requests answered.
    pub requests: u32,
    /// Repeats (the same request, id and bytes, while it waits or within
    /// [`REPEAT_WINDOW_MS`] of its answer): answered again, not acted on.
    pub repeated_requests: u32,
    /// Requests that found no place for an answer of their own in the [`ANSWER_QUEUE`] (a
    /// supervisor sending faster than [`STATUS_PER_CYCLE`] a cycle for long): answered by
    /// an overload answer ([`Answer::Overload`]) and not acted on — a stop among them is
    /// still obeyed.
    pub overloaded: u32,
    /// Requests that found no place even in an overload answer (more than a CAN bus
    /// carries between two cycles): not answered, counted as ignored (status byte 5) — a
    /// stop among them is still obeyed.
    pub unanswered: u32,
    /// Drive warnings: EMCYs classified as warnings, *internal limit active* (statusword
    /// bit 11) and statusword bit 7 rising.
    pub drive_warnings: u32,
    /// Drives commissioned (counting each boot).
    pub commissioned: u32,
}

/// The most frames one cycle hands out.
pub const MAX_FRAMES: usize = 16;

/// SDO answers waiting to be sent at most: every request to the controller's SDO server
/// gets exactly one (CiA 301's SDO is a confirmed service: a client waits for its answer
/// before the next request, so more wait only with several clients on the one channel).
/// A request that finds them all taken is not served, and is counted as ignored.
pub const SDO_ANSWERS: usize = 4;

/// SDO answers a cycle sends at most (the oldest first), so that they never crowd out
/// the cycle's EMCYs.
pub const SDO_PER_CYCLE: usize = 2;

/// What may be left of a plan's way, in every axis, for the crane to be at rest once its
/// set points round to zero, m: the drives' position resolution (1 µm).
pub const REST_TRAVEL_M: f64 = 1e-6;

/// Cycles in a row the model's own set points must be zero before manual mode is left:
/// BDF's history (up to six past steps) and the step itself, so that a set point that
/// crosses zero on the way to rest does not count as rest.
pub const MODEL_REST_CYCLES: u8 = 7;

/// EMCYs waiting to be sent at most. A commissioning failure takes two (0xFF10 and
/// 0xFF12), so every node of the list can fail in one cycle with room to spare.
pub const EMCY_QUEUE: usize = 10;

const _: () = assert!(EMCY_QUEUE >= 2 * crate::commissioning::MAX_NODES + 2);

/// Frames a cycle sends after its EMCYs at most: SYNC, heartbeat and two status frames.
/// EMCYs beyond what leaves room for them wait for the next cycle.
const AFTER_EMCY: usize = 4;

/// Everything one cycle of a crane with `A` driven axes produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Cycle<const A: usize = 2> {
    /// Frames to transmit, in order: commissioning and SDO answers, RPDOs, EMCY,
    /// SYNC, heartbeat, status.
    pub frames: Vec<CanFrame, MAX_FRAMES>,
    /// The set points sent, in the model's input order ([`Crane::DRIVES`]; planar
    /// `[trolley, winch]`), zero to a drive that is not linked.
    pub setpoints: [Setpoint; A],
    /// The inverse-model step of this cycle, if one was taken.
    pub step: Option<FeedforwardStep<A>>,
    /// The supervisor state after the cycle.
    pub mode: Mode,
}

pub use crate::requests::{
    ANSWER_QUEUE, OVERLOAD_ANSWERS, REPEAT_WINDOW_MS, STATUS_PER_CYCLE, STOP_ANSWERS,
};

/// A drive's last position actual (0x6064) as the range guard and the feedback read it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Position {
    /// Through the drive's commissioned scaling, m.
    metres: f64,
    /// How much older than a cycle it is, s (0: from the last SYNC, fresh).
    late_s: f64,
}

/// The crane controller: a CANopen node, manager (or slave) of the drives of crane `K`
/// (its `A` driven axes, [`Crane::DRIVES`]: the planar crane's trolley and winch by
/// default), with the inverse model `F` as feedforward and `C` between it and the
/// drives (Fig. 1: [`NoFeedback`], or the state feedback with an inclinometer).
#[derive(Debug, Clone)]
pub struct Controller<F, C = NoFeedback, K = CraneParams, const A: usize = 2> {
    feedforward: F,
    correction: C,
    /// The loop is closed: a move was accepted since the last boot or fault. Before,
    /// the controller holds zero set points whatever the load does (no motion without a
    /// command).
    closed_loop: bool,
    /// The feedback mode last announced (EMCY 0xFF20 when it stops reading the angle).
    feedback_announced: Option<FeedbackMode>,
    config: Config,
    /// The NMT slave: the controller's own node, its boot-up and heartbeat.
    nmt: NmtSlave,
    /// The status frames: one per answer, and every period.
    status_producer: StatusProducer,
    /// The choke point, with the planner's drive limits.
    gate: SetpointGate<A>,
    planner: Planner<K, A>,
    /// The nodes on the bus, from `config.nodes`.
    links: Links<A>,
    /// Each drive as the model has it over a cycle (its lag), in the model's input
    /// order: what the motion supervision expects ([`crate::motion`]).
    lags: [Lag; A],
    mode: Mode,
    /// The supervisor's requests, from arrival to answer.
    requests: Requests<A>,
    counters: Counters,
    last_miss_cycle: Option<u32>,
    rpdo_failed: bool,
    failed_cycles: u32,
    /// The EMCY producer: what is to be sent and what the last cycle sent.
    emcy: emcy::Producer<EMCY_QUEUE>,
    /// The SDO server's answers to the requests received since the last cycle, in
    /// order (each request is served on arrival).
    sdo_answers: Deque<CanFrame, SDO_ANSWERS>,
    /// The last commissioning failure (0x2002): node, index, sub, abort code, reason.
    commissioning_failure: (u8, u16, u8, u32, u8),
    /// Cycles of the fault-reset sequence still to send after a reset.
    resetting: u8,
    last_supervisor_heartbeat_ms: Option<u64>,
    now_ms: u64,
    /// SYNC was sent in the last cycle (the drives' TPDOs are due).
    syncing: bool,
    /// The operator's dead-man: whether the stick may move the crane (manual mode).
    deadman: Deadman,
    /// The refusal of the operator's request for manual mode last announced (EMCY
    /// 0xFF21), until the request is withdrawn or granted.
    manual_refused: Option<Refusal>,
    /// A stop request (0x210) latched the generator's stop: it holds until the load
    /// rests, whatever the stick does meanwhile.
    manual_stop_held: bool,
    /// The stick deflected during an automatic move: the move stops on its path, and
    /// manual mode is entered at its rest with the stick live.
    handing_over: bool,
    /// Each drive's set point held back by its range's guard (`crate::range`) and not
    /// yet back to what is asked.
    range_held: [bool; A],
    /// Each drive found ahead of the model's drive near an end: the model's set point no
    /// longer passes the guard until it stops heading for that end (`crate::range`).
    range_ahead: [bool; A],
    /// Cycles in a row the model's own set points were zero in drive units: manual mode
    /// is left only when the model rests, its history too.
    model_still: u8,
}

impl<F: Feedforward<Reference = Reference> + Replan> Controller<F> {
    /// A controller that follows `feedforward` and checks moves with `planner`; it starts
    /// by commissioning the drives and holds them at standstill until a move is asked.
    pub fn new(feedforward: F, planner: Planner, config: Config) -> Self {
        Self::with_correction(feedforward, NoFeedback, planner, config)
    }
}

impl<F, C, K, const A: usize> Controller<F, C, K, A>
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: Crane<A>,
{
    /// A controller whose set points are `feedforward`'s corrected by `correction`
    /// (the state feedback measures the angle with the inclinometer of `config.nodes`),
    /// its moves checked and its set points limited by `planner`.
    pub fn with_correction(
        feedforward: F,
        correction: C,
        planner: Planner<K, A>,
        config: Config,
    ) -> Self {
        let manager = config.role == Role::Manager;
        // Without the feedback the inclinometer is not linked (`C::ENABLED` is a
        // constant: none of its code is).
        let links = Links::new(&config, K::DRIVES, C::ENABLED);
        let deadband = feedforward.path().stick_deadband().unwrap_or(0.0);
        Self {
            feedforward,
            correction,
            closed_loop: false,
            feedback_announced: None,
            config,
            nmt: NmtSlave::new(Node {
                id: config.node,
                role: config.role,
                // A manager starts itself (CiA 302); a slave waits for its master.
                state: if manager {
                    NmtState::Operational
                } else {
                    NmtState::PreOperational
                },
                heartbeat_ms: config.heartbeat_period_ms,
                supervisor: 0,
                cycle_us: config.period_ms.saturating_mul(1000),
                request: StagedRequest::default(),
                // The planar crane (two outputs: x, z) has no y to demand.
                operator: StagedOperator {
                    planar: A < 3,
                    ..StagedOperator::default()
                },
                drives_consumer_ms: config
                    .nodes
                    .iter()
                    .flatten()
                    .filter_map(|n| match n {
                        NodeSetup::Drive(_, d) if d.controller_timeout_ms != 0 => {
                            Some(d.controller_timeout_ms)
                        }
                        _ => None,
                    })
                    .min()
                    .unwrap_or(0),
                listed: config.nodes.map(|n| n.map_or(0, |n| n.node())),
            }),
            status_producer: StatusProducer::new(config.heartbeat_period_ms),
            gate: SetpointGate::with_axes(K::DRIVES, planner.limits(), config.period_s()),
            lags: planner.lags().map(|tau| Lag::new(tau, config.period_ms)),
            planner,
            links,
            mode: Mode::Enabling,
            requests: Requests::default(),
            counters: Counters::default(),
            last_miss_cycle: None,
            rpdo_failed: false,
            failed_cycles: 0,
            emcy: emcy::Producer::default(),
            sdo_answers: Deque::new(),
            commissioning_failure: (0, 0, 0, 0, 0),
            resetting: 0,
            last_supervisor_heartbeat_ms: None,
            now_ms: 0,
            syncing: false,
            // The generator's deadband, the one the interlock checks; a model that
            // follows plans only never enters manual mode: a centred stick is 0 there.
            deadman: Deadman::new(operator::DEADLINE_MS, deadband),
            manual_refused: None,
            manual_stop_held: false,
            range_held: [false; A],
            range_ahead: [false; A],
            model_still: 0,
            handing_over: false,
        }
    }

    /// The scene's own move was planned at boot (the QEMU main job's demonstration, which
    /// it asks for explicitly): it counts as a command, so a state feedback acts on it.
    pub fn demonstration_commanded(&mut self) {
        let at_rest = !self.moving();
        self.close_loop(at_rest);
    }

    /// What the state feedback is doing (`None`: the controller has none).
    #[must_use]
    pub fn feedback_mode(&self) -> Option<FeedbackMode> {
        self.correction.mode()
    }

    /// After a restart by the watchdog: halted, announced by an EMCY (CiA 301 0x6010,
    /// software reset), until a supervisor's reset walks the drives through fault reset
    /// and the enable sequence. Nothing moves on its own after a crash.
    pub fn restarted_by_watchdog(&mut self) {
        self.fault(Fault::Watchdog);
    }

    /// The supervisor state.
    #[must_use]
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The controller's own NMT state.
    #[must_use]
    pub fn nmt_state(&self) -> NmtState {
        self.nmt.node.state
    }

    /// Diagnostics.
    #[must_use]
    pub fn counters(&self) -> Counters {
        let tally = self.requests.tally();
        Counters {
            requests: tally.answered,
            repeated_requests: tally.repeated,
            overloaded: tally.overloaded,
            unanswered: tally.unanswered,
            ..self.counters
        }
    }

    /// The crane's drives, in the model's input order ([`Crane::DRIVES`]).
    #[must_use]
    pub fn drives(&self) -> [Drive; A] {
        K::DRIVES
    }

    /// The CiA 402 state of a drive as last reported.
    #[must_use]
    pub fn drive_state(&self, drive: Drive) -> DriveState {
        self.link(drive).map_or(DriveState::Unknown, |l| l.state)
    }

    /// Where a drive's commissioning stands.
    #[must_use]
    pub fn commissioning(&self, drive: Drive) -> Phase {
        self.link(drive)
            .map_or(Phase::Absent, |l| l.commissioning.phase())
    }

    /// A drive's identity (0x1018:1..=4) as read when it was commissioned.
    #[must_use]
    pub fn identity(&self, drive: Drive) -> [u32; 4] {
        self.link(drive)
            .map_or([0; 4], |l| l.commissioning.identity())
    }

    /// The largest deviation each drive showed from what the controller commanded since
    /// it started, against each motion supervision window ([`crate::motion`]), in the
    /// model's input order.
    #[must_use]
    pub fn motion_deviations(&self) -> [Deviations; A] {
        K::DRIVES.map(|d| {
            self.link(d)
                .map_or_else(Deviations::default, |l| l.motion.peaks())
        })
    }

    /// The inverse model (and its plan).
    #[must_use]
    pub fn feedforward(&self) -> &F {
        &self.feedforward
    }

    /// The inverse model, to inject a fault (tests, the QEMU scenarios).
    pub fn feedforward_mut(&mut self) -> &mut F {
        &mut self.feedforward
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The last answer given: request id, answer, reason.
    #[must_use]
    pub fn last_answer(&self) -> (u8, Answer, Option<Reject>) {
        let last = self.requests.last();
        (last.id, last.answer, last.reason)
    }

    fn ignore(&mut self) {
        self.counters.frames_ignored = self.counters.frames_ignored.saturating_add(1);
    }

    fn drive_at(&self, node: u8) -> Option<Drive> {
        self.links.axis_at(node)
    }

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

    /// An operator frame (RPDO3, or 0x2010 written over SDO), well-formed. One the crane
    /// cannot follow is ignored and counted, as a malformed one.
    fn on_operator(&mut self, frame: OperatorFrame, now_ms: u64) {
        if frame.fits(A.saturating_sub(1)).is_err() {
            self.ignore();
            return;
        }
        self.deadman.on_frame(&frame, now_ms);
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
    fn steer_manual(&mut self) {
        let frame = self.deadman.frame();
        let lost = matches!(self.deadman.state(self.now_ms), Stick::Lost(_));
        let asked = !lost && frame.is_some_and(|f| f.flags.manual);
        if !self.feedforward.path().in_manual() {
            self.manual_stop_held = false;
            if !asked {
                // (A hand-over's stop goes on to rest: the move was ended by the stick.)
                self.manual_refused = None;
                self.handing_over = false;
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
                Some(Ok(())) => self.manual_refused = None,
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
            && self.model_still >= MODEL_REST_CYCLES
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
        if self.manual_stop_held && path.is_at_rest() {
            // The stop request's stop is over: the stick moves the load again once it
            // is centred after it (centring during the stop does not count).
            self.manual_stop_held = false;
            self.deadman.interlock();
        }
        // The state again: an entry or the end of a stop just now interlocked the stick.
        let state = self.deadman.state(self.now_ms);
        // Enabling (a drive came back after leaving operational at rest): the model
        // steps, so the generator is advanced, its stop latched: the drives are not
        // ready for the stick.
        let ready = self.mode == Mode::Ready;
        let stick = match (state, frame) {
            (Stick::Live, Some(f)) if asked && ready => f.demand::<2>(self.deadman.deadband()).ok(),
            _ => None,
        };
        if !asked || !ready {
            // A dead-man loss, the request withdrawn, or the drives not ready: the
            // sway-free stop, and the stick centred before it moves the crane again.
            path.stop();
            self.deadman.interlock();
        } else if state == Stick::Live && path.is_stopping() && !self.manual_stop_held {
            path.resume();
        }
        let ([x, y], z) = stick.unwrap_or(([0.0; 2], 0.0));
        // The state feedback no longer reads the angle (EMCY 0xFF20 said so): manual
        // mode goes on on feedforward, the travel speed capped.
        let cap = match self.feedback_announced.and_then(|m| m.degraded()) {
            Some(_) if C::ENABLED => operator::UNOBSERVED_SPEED_SHARE,
            _ => 1.0,
        };
        let _ = path.advance([x * cap, y * cap], z);
    }

    /// Manual mode entered for a live operator who asks for it, if it can be now: at
    /// rest, the stick interlocked (centred frames counted before do not lift it). During
    /// an automatic move a deflected stick — live, centred since the request — takes the
    /// crane over: the move ends at once with its on-path stop (what waited for it is
    /// refused), and at the stop's rest manual mode is entered with the stick live.
    /// `None`: not now, manual mode waits (the move, or the hand-over's stop, runs).
    ///
    /// (`Generator::take_over` continues a moving load's state, but tried here in motion
    /// its blend put the drives past their limits — up to 2.6 times the trolley's
    /// acceleration limit at 20 % into a 6 s move (`cargo run --release -p host-tests
    /// --example takeover_limits`) — so the generator starts from the stop's rest.)
    fn enter_manual(&mut self, frame: Option<OperatorFrame>) -> Option<Result<(), Refusal>> {
        // A model that follows plans only: the stick neither enters nor takes anything
        // over (its frames cannot stop a move).
        if self.feedforward.path().stick_deadband().is_none() {
            return Some(Err(Refusal::Unsupported));
        }
        if !self.may_move() {
            self.handing_over = false;
            return Some(Err(Refusal::NotReady));
        }
        if !self.moving() {
            let t = self.feedforward.time();
            // A hand-over's stick is live: the operator deflected it to take over.
            let handed_over = core::mem::take(&mut self.handing_over);
            let entered = self.feedforward.path_mut().enter_manual(t);
            if entered.is_ok() {
                if !handed_over {
                    self.deadman.interlock();
                }
                self.close_loop(true);
            }
            return Some(entered.map_err(Refusal::of));
        }
        let deflected = frame.is_some_and(|f| !self.deadman.centred(&f));
        let on_its_way = matches!(self.feedforward.plan().active(), Some(Segment::Move(_)));
        if self.handing_over
            || !(deflected && on_its_way && self.deadman.state(self.now_ms) == Stick::Live)
        {
            return None;
        }
        // The stick takes the crane over: what waited for the move is refused (reason
        // 2), as after a stop, a move sent again is a new request, the move ends on its
        // path, and the supervisor hears that it will not reach its target.
        let (now, now_ms) = (self.now_s(), self.now_ms);
        self.requests.forget_answered();
        let lost =
            self.requests.cancel_planned(now, now_ms) + self.requests.refuse_waiting(false, now_ms);
        self.counters.frames_ignored = self.counters.frames_ignored.saturating_add(lost);
        self.stop_on_path(now);
        self.handing_over = true;
        self.send_emcy(canopen::emcy(
            self.nmt.node.id,
            emcy::MOVE_TAKEN_OVER,
            REGISTER_MANUFACTURER,
            [emcy::MOVE_TAKEN_OVER_BYTE, 0, 0, 0, 0],
        ));
        None
    }

    /// Announces a refused request for manual mode (EMCY 0xFF21, a warning), once per
    /// request and reason.
    fn refuse_manual(&mut self, refusal: Refusal) {
        if self.manual_refused == Some(refusal) {
            return;
        }
        self.manual_refused = Some(refusal);
        self.send_emcy(canopen::emcy(
            self.nmt.node.id,
            emcy::MANUAL_REFUSED,
            REGISTER_MANUFACTURER,
            [emcy::MANUAL_REFUSED_BYTE, 0, refusal.code(), 0, 0],
        ));
    }

    /// The status frame's mode byte: the supervisor state's, or
    /// [`operator::MANUAL_MODE_CODE`] while manual mode runs.
    fn mode_code(&self) -> u8 {
        if self.mode == Mode::Ready && self.feedforward.path().in_manual() {
            operator::MANUAL_MODE_CODE
        } else {
            self.mode.code()
        }
    }

    /// A frame of the inclinometer (its TPDO1 *slope long16*, heartbeat, SDO response,
    /// EMCY): taken here, `true`. An EMCY that reports a fault makes its angles count
    /// as missing until it is commissioned again (the feedback's degraded rule decides).
    fn on_inclinometer_frame(&mut self, frame: &CanFrame, now_ms: u64) -> bool {
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
                        sensor.outbox = Some(nmt::command(NmtCommand::Start, setup.node));
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

    /// The inclinometer's commissioning failed: no fault (the crane can run on
    /// feedforward alone), but the failure is recorded in 0x2002 like a drive's, and
    /// the feedback's degraded rule announces the missing angle.
    fn inclinometer_failed(&mut self, error: CommissioningError) {
        let node = self
            .links
            .sensor()
            .map_or(0, |s| s.commissioning.setup().node);
        self.record_commissioning_failure(node, error);
    }

    /// What 0x2002 shows: the last commissioning failure of any device.
    fn record_commissioning_failure(&mut self, node: u8, error: CommissioningError) {
        let object = error.object();
        self.commissioning_failure = (
            node,
            object.index,
            object.sub,
            error.abort_code(),
            error.reason(),
        );
    }

    fn supervisor_node(&self) -> Option<u8> {
        let node = ((self.nmt.node.supervisor >> 16) & 0x7F) as u8;
        (node != 0 && self.nmt.node.supervisor & 0xFFFF != 0).then_some(node)
    }

    fn warn(&mut self) {
        self.counters.drive_warnings = self.counters.drive_warnings.saturating_add(1);
    }

    /// An NMT command for this node (or all): the node's NMT slave obeys it
    /// ([`Node::on_nmt`]); outside *operational*, what waits is refused and a move is a
    /// fault.
    fn on_nmt(&mut self, command: NmtCommand) {
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
    fn on_heartbeat(&mut self, drive: Drive, state: NmtState, now_ms: u64) {
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
                link.outbox = Some(nmt::command(
                    NmtCommand::Start,
                    link.commissioning.setup().node,
                ));
            }
            // The TPDOs' clocks start when the drive is (again) seen operational.
            Heartbeat::Resumed => link.restart_clocks(now_ms),
            Heartbeat::Nothing => {}
        }
    }

    fn recommission(&mut self, drive: Drive, now_ms: u64) {
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
    fn drive_left_operational(&mut self, drive: Drive, state: NmtState) {
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

    /// Whether a drive's position actual (`units`) is one it can have: inside its axis's
    /// range of the workspace (trolley x, rope length l) within
    /// [`Config::position_tolerance_m`], and no further from its last one than the drive
    /// can move in the time between at [`Config::overspeed`] times its velocity limit
    /// (at least a cycle's worth), plus the tolerance's tenth.
    fn judge_position(&self, drive: Drive, units: i32, now_ms: u64) -> Option<Implausibility> {
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

    fn on_status(&mut self, drive: Drive, sw: u16, velocity: i32, now_ms: u64) {
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

    /// A request off the bus (docs/COMMANDS.md, "Requests"; [`Requests::take`]
    /// decides what it is). One that finds no place for its answer is ignored.
    fn on_request(&mut self, request: Request) {
        if !self.requests.take(request, self.now_ms) {
            self.ignore();
        }
    }

    /// Answers `request` (once: its status frame is queued) and remembers it for repeats.
    fn give_answer(&mut self, request: Request, answer: Result<Answer, Reject>) {
        if !self.requests.answer(request, answer, self.now_ms) {
            self.ignore();
        }
    }

    /// The move being planned and the moves waiting are refused
    /// ([`Requests::refuse_waiting`]).
    fn refuse_waiting(&mut self, resets: bool) {
        let lost = self.requests.refuse_waiting(resets, self.now_ms);
        self.counters.frames_ignored = self.counters.frames_ignored.saturating_add(lost);
    }

    /// Reports what the last cycle cost (core cycles; QEMU instructions). A cycle over
    /// the budget missed its deadline; a second miss within the window stops the crane.
    pub fn record_cost(&mut self, cost: u64) {
        if cost <= self.config.cycle_budget() {
            return;
        }
        let cycle = self.counters.cycles;
        self.counters.deadline_misses = self.counters.deadline_misses.saturating_add(1);
        if self
            .last_miss_cycle
            .is_some_and(|last| cycle.wrapping_sub(last) <= self.config.deadline_window)
        {
            self.fault(Fault::Deadline);
        }
        self.last_miss_cycle = Some(cycle);
    }

    /// Reports a frame the board could not transmit (bus-off, full transmit queue). Set
    /// points are not repeated (the next cycle sends fresh ones); an EMCY is sent again
    /// next cycle, so no fault goes unannounced; a lost SDO request is left to the
    /// transfer's timeout.
    pub fn transmit_failed(&mut self, frame: &CanFrame) {
        self.counters.tx_failures = self.counters.tx_failures.saturating_add(1);
        let id = frame.id();
        if self
            .links
            .drives()
            .any(|(_, d)| id == canopen::cob::RPDO1 + u16::from(d.commissioning.setup().node))
        {
            self.rpdo_failed = true;
        }
        if id == canopen::cob::EMCY + u16::from(self.nmt.node.id) && !self.emcy.lost(frame) {
            self.ignore();
        }
    }

    /// Whether the load is being moved (or the drives were last sent motion). Manual
    /// mode counts as moving until it is left (at rest): the stick may move the crane
    /// at any cycle, so nothing that needs rest (a reset, a move) is taken meanwhile.
    fn moving(&self) -> bool {
        (self.mode == Mode::Ready
            && (self.feedforward.plan().is_moving(self.now_s())
                || self.feedforward.path().in_manual()))
            || !self.gate.at_standstill()
    }

    /// Whether the load is being moved, for supervision (an NMT state change, a drive
    /// leaving *operational*, a lost supervisor): as [`Self::moving`], except that manual
    /// mode parked at rest (the generator resting, the stick centred) is not motion. A
    /// fault there would halt a crane that stands still; the stick cannot move it without
    /// a live operator, operational PDOs, and the supervision that then counts it moving.
    fn moving_for_supervision(&self) -> bool {
        (self.mode == Mode::Ready
            && (self.feedforward.plan().is_moving(self.now_s())
                || self.feedforward.path().manual_moving()))
            || !self.gate.at_standstill()
    }

    /// One cycle at time `now_ms` (the start of the cycle; the model has been stepped to it).
    pub fn tick(&mut self, now_ms: u64) -> Cycle<A> {
        self.now_ms = now_ms;
        // The frames are queued in the cycle that returns them: built whole at the end,
        // the 196-byte list was copied into it every cycle (and, with this function
        // inlined into the firmware's task, by the generic `memcpy`: issue 29, C1/C2).
        let mut cycle = Cycle {
            frames: Vec::new(),
            setpoints: [Setpoint::ZERO; A],
            step: None,
            mode: self.mode,
        };
        let frames = &mut cycle.frames;
        if let Some(boot_up) = self.nmt.begin_cycle() {
            self.push(frames, boot_up);
        }
        // (An answer to a request served before an NMT stop waits: no SDO in stopped.)
        for _ in 0..SDO_PER_CYCLE {
            if !self.nmt.node.state.services().sdo {
                break;
            }
            let Some(answer) = self.sdo_answers.pop_front() else {
                break;
            };
            self.push(frames, answer);
        }
        // What the controller's own NMT state lets it send (CiA 301); bringing a moving
        // load to rest is the one exception, for the RPDOs and the SYNC that apply them.
        let allowed = self.nmt.node.state.services();
        let finishing = self.moving();
        let pdo = allowed.pdo || finishing;
        let sync = allowed.sync || finishing;
        self.supervise_delivery();
        self.supervise_drives(now_ms);
        self.supervise_motion(now_ms);
        // A manager commissions and starts its nodes only while operational itself; a
        // slave commissions them by SDO in pre-operational too (its master starts them).
        if allowed.sdo && (self.nmt.node.role == Role::Slave || allowed.pdo) {
            self.commission(now_ms, frames);
        } else {
            self.suspend_commissioning();
        }
        // Ready once every drive is: a reset's answer still shows *enabling*.
        if self.mode == Mode::Enabling && self.drives_ready() {
            self.mode = Mode::Ready;
        }
        // A stop goes first; then requests in order: the next one waits while a move
        // is planned.
        self.requests.begun_by(self.now_s());
        if self.requests.stop_due() {
            self.obey_stop();
            let lost = self.requests.after_stop(now_ms, self.now_s());
            self.counters.frames_ignored = self.counters.frames_ignored.saturating_add(lost);
        } else if let Some(request) = self.requests.next() {
            self.handle(request);
        }
        self.plan_pending();
        self.steer_manual();

        let step = if matches!(self.mode, Mode::Enabling | Mode::Ready) {
            match self.feedforward.step() {
                Ok(step) => Some(self.settle(step)),
                Err(e) => {
                    self.fault(Fault::Solver(e));
                    None
                }
            }
        } else {
            None
        };
        // Each drive's position actual, read once for the feedback and the range guard.
        let positions = self.positions();
        let wanted = step.as_ref().map(|s| {
            let (u, corrected) = self.corrected(s, &positions);
            let guarded = self.within_ranges(u, s.u, &positions);
            if corrected && guarded != u {
                // The observer learns what the drives were sent (anti-windup).
                self.correction.sent(s.u, guarded);
            }
            guarded
        });
        // An angle counts for the cycle after it arrived only, whether the loop used it
        // or not: one that waited through enabling or a halt is stale.
        if let Some(sensor) = self.links.sensor_mut() {
            sensor.fresh = false;
        }
        let mut setpoints = [Setpoint::ZERO; A];
        for (i, drive) in K::DRIVES.into_iter().enumerate().filter(|_| pdo) {
            let wanted = wanted.and_then(|u| u.get(i).copied());
            let (command, setpoint) = self.command_for(drive, wanted);
            // Only a commissioned drive gets PDOs: its mapping is known. A drive that
            // is being commissioned again (it rebooted, or said so) still gets the rest
            // of its ramp to standstill, so that no drive ever sees its set point jump;
            // in pre-operational it ignores them.
            // An axis without a drive gets nothing (and is never ready).
            let Some((linked, node)) = self
                .link(drive)
                .map(|l| (l.linked(), l.commissioning.setup().node))
            else {
                continue;
            };
            if linked || self.gate.last(drive) != Setpoint::ZERO {
                if let Some(slot) = setpoints.get_mut(i) {
                    *slot = setpoint;
                }
                self.push(frames, pdo::rpdo1(node, command, setpoint));
            }
        }
        self.resetting = self.resetting.saturating_sub(1);
        if let Mode::Stopping(f) | Mode::QuickStop(f) = self.mode {
            if self.gate.at_standstill() {
                self.mode = Mode::Halted(f);
            }
        }
        let dropped = self.emcy.requeue_lost();
        self.counters.frames_ignored = self.counters.frames_ignored.saturating_add(dropped);
        // EMCYs wait while the controller is stopped.
        while allowed.emcy && frames.len() + AFTER_EMCY < MAX_FRAMES {
            let Some(emcy) = self.emcy.hand_out() else {
                break;
            };
            self.push(frames, emcy);
        }
        if sync {
            if !self.syncing {
                // SYNC resumes: the drives' TPDOs follow from now on.
                self.restart_tpdo_clocks(now_ms);
            }
            self.push(frames, canopen::sync());
        }
        self.syncing = sync;
        let clock = self.nmt.clock(self.counters.cycles, self.config.period_ms);
        if let Some(heartbeat) = self.nmt.heartbeat(clock) {
            self.push(frames, heartbeat);
        }
        if self.nmt.node.state == NmtState::Operational {
            // One status frame per answer (room permitting), and every period.
            let (node, status) = (self.nmt.node.id, self.status());
            while frames.len() < MAX_FRAMES {
                let next_unsent = || self.requests.next_unsent();
                let Some(frame) = self.status_producer.answer(node, &status, next_unsent) else {
                    break;
                };
                self.push(frames, frame);
            }
            if let Some(frame) = self.status_producer.end_cycle(node, &status, clock) {
                self.push(frames, frame);
            }
        }
        self.counters.cycles = self.counters.cycles.wrapping_add(1);
        cycle.setpoints = setpoints;
        cycle.step = step;
        cycle.mode = self.mode;
        cycle
    }

    /// Commissioning of each node, in the list's order: the frame answering a response
    /// received between cycles, a due step, a timeout or a presence check — at most one
    /// frame per node.
    fn commission(&mut self, now_ms: u64, frames: &mut Vec<CanFrame, MAX_FRAMES>) {
        for i in 0..self.links.len() {
            // What the node's commissioning asks, then (the link no longer borrowed) its
            // consequence.
            let (drive, step) = match self.links.get_mut(i) {
                Some(Link::Drive(drive, link)) => (
                    Some(*drive),
                    next_step(&mut link.outbox, &mut link.commissioning, now_ms),
                ),
                // `C::ENABLED` is a constant: without the feedback none of this is linked.
                Some(Link::Inclinometer(sensor)) if C::ENABLED => (
                    None,
                    next_step(&mut sensor.outbox, &mut sensor.commissioning, now_ms),
                ),
                _ => continue,
            };
            let frame = match (drive, step) {
                (_, Step::Frame(frame)) => Some(frame),
                (_, Step::Idle) => None,
                (Some(drive), Step::Progress(progress)) => self.on_progress(drive, progress),
                (None, Step::Progress(Progress::Send(frame))) => Some(frame),
                (None, Step::Progress(Progress::Done)) => None,
                (None, Step::Progress(Progress::Failed { error, abort })) => {
                    self.inclinometer_failed(error);
                    abort
                }
            };
            if let Some(frame) = frame {
                self.push(frames, frame);
            }
        }
    }

    /// What the drives and the inclinometer measured at the last SYNC (their TPDOs
    /// arrive between cycles): each drive's position (planar: trolley position and rope
    /// length) from `positions`, the angle if a fresh one came from a healthy
    /// inclinometer. `None` when a position is not fresh.
    fn measurement(&mut self, positions: &[Option<Position>; A]) -> Option<Measured<A>> {
        let now_ms = self.now_ms;
        let swing = self.links.sensor_mut().and_then(|sensor| {
            let fresh = core::mem::take(&mut sensor.fresh);
            let healthy = sensor.healthy(now_ms, self.config.heartbeat_timeout_ms);
            sensor.swing.filter(|_| fresh && healthy)
        });
        let mut position = [0.0; A];
        for (slot, p) in position.iter_mut().zip(positions) {
            *slot = p.filter(|p| p.late_s <= 0.0)?.metres;
        }
        Some(Measured { position, swing })
    }

    /// Every drive's last position actual (0x6064), through its commissioned scaling,
    /// and how late it is; `None` for a drive that has sent none since it was linked.
    fn positions(&self) -> [Option<Position>; A] {
        let period_ms = u64::from(self.config.period_ms);
        K::DRIVES.map(|drive| {
            let link = self.link(drive)?;
            let age_ms = self.now_ms.saturating_sub(link.last_position_ms?);
            Some(Position {
                metres: link.commissioning.setup().metres(link.position?),
                late_s: age_ms.saturating_sub(period_ms) as f64 * 1e-3,
            })
        })
    }

    /// `u` with each drive kept inside its range by its position actual
    /// ([`crate::range`]): the last word before the gate on what the feedback adds to the
    /// model's `u_d`, and on `u_d` itself for a drive ahead of the model's. A late
    /// position counts as far on as the drive can have gone since; a drive without any,
    /// `u` as it is.
    fn within_ranges(
        &mut self,
        u: [f64; A],
        u_d: [f64; A],
        positions: &[Option<Position>; A],
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
            if let Some(Some(p)) = positions.get(i) {
                let at = range::late_position(p.metres, u, p.late_s, limits.max_velocity);
                let feedforward = &self.feedforward;
                let model_at = || {
                    let drives =
                        *model.get_or_insert_with(|| K::drive_states(&feedforward.reference()));
                    drives.get(i).copied().unwrap_or((f64::NAN, f64::NAN))
                };
                let ahead = self.range_ahead.get_mut(i);
                let mut spare = false;
                let ahead = ahead.unwrap_or(&mut spare);
                *out = range::guard(u, u_d, last, at, *range, *limits, lag, h, model_at, ahead);
            }
            // Held back (now or before): back to what is asked at the gate's step only,
            // whether the drive is inside again or its position is late.
            let Some(held) = self.range_held.get_mut(i) else {
                continue;
            };
            *held |= *out != u && out.is_finite();
            if *held {
                *out = range::toward(*out, last, limits.max_acceleration, h);
                *held = *out != u;
            }
        }
        guarded
    }

    /// This cycle's set points before the gate: the inverse model's `u_d`, corrected by
    /// the feedback while the loop is closed (Fig. 1). A change of the feedback's mode
    /// is announced: the angle no longer used (the swing estimated from the positions,
    /// or feedforward only) by EMCY 0xFF20 with the reason (a warning: the move goes
    /// on), back to closed loop by nothing. Also whether the feedback ran (it is then
    /// told what the drives were sent after the range guard).
    fn corrected(
        &mut self,
        step: &FeedforwardStep<A>,
        positions: &[Option<Position>; A],
    ) -> ([f64; A], bool) {
        if !C::ENABLED || !self.closed_loop || self.mode != Mode::Ready {
            return (step.u, false);
        }
        let reference = self.feedforward.reference();
        let measured = self.measurement(positions);
        let last = self.gate.last_velocities();
        let (u, mode) =
            self.correction
                .correct(&reference, step.u, measured, last, &self.planner.limits());
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
        (u, true)
    }

    /// What a commissioning step asks: the frame to send, if any, and the end of the
    /// sequence (counted) or its failure (a fault).
    fn on_progress(&mut self, drive: Drive, progress: Progress) -> Option<CanFrame> {
        match progress {
            Progress::Send(frame) => Some(frame),
            Progress::Done => {
                self.counters.commissioned = self.counters.commissioned.saturating_add(1);
                None
            }
            Progress::Failed { error, abort } => {
                let node = self.node_of(drive);
                self.record_commissioning_failure(node, error);
                self.fault(Fault::Commissioning(drive, error));
                abort
            }
        }
    }

    /// The status frame's contents now.
    #[must_use]
    pub fn status(&self) -> Status {
        let answer = self.requests.last();
        Status {
            last_id: answer.id,
            answer: answer.answer,
            reason: answer.reason,
            overload: answer.overload,
            mode: self.mode_code(),
            fault: self.mode.fault().map_or(0, |f| f.code()),
            ignored: self.counters.frames_ignored,
            deadline_misses: self.counters.deadline_misses,
            tx_failures: self.counters.tx_failures,
        }
    }

    fn snapshot(&self) -> Snapshot {
        let commissioned = K::DRIVES
            .iter()
            .enumerate()
            .filter(|(_, d)| self.link(**d).is_some_and(DriveLink::linked))
            .fold(0u8, |bits, (i, _)| bits | (1 << i));
        Snapshot {
            status: self.status(),
            error_register: if self.mode.fault().is_some() {
                REGISTER_GENERIC
            } else {
                0
            },
            commissioning_failure: self.commissioning_failure,
            commissioned,
            rope: self
                .correction
                .rope()
                .map_or((0, 0, 0, 0, u32::MAX, 0), |r| {
                    // One solve for all of it (review finding C1).
                    let s = r.solution();
                    (
                        libm::round(s.scale * 1e6) as i32,
                        libm::round(s.offset * 1e6) as i32,
                        r.samples(),
                        s.learnt as u8,
                        // Saturating casts: an infinite uncertainty is u32::MAX.
                        libm::round(s.uncertainty * 1e6) as u32,
                        libm::round(s.delay * 1e6) as i32,
                    )
                }),
        }
    }

    fn now_s(&self) -> f64 {
        // Exact below 2^53 ms (285,000 years).
        self.now_ms as f64 / 1000.0
    }

    /// Whether every drive may be asked to move.
    fn drives_ready(&self) -> bool {
        K::DRIVES
            .iter()
            .all(|d| self.link(*d).is_some_and(DriveLink::ready))
    }

    /// Takes one move or reset (docs/COMMANDS.md): answers it, or starts planning a move.
    /// (Stops are obeyed before, by [`Controller::obey_stop`], and answered on arrival.)
    fn handle(&mut self, request: Request) {
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
                    Some(_) if !self.may_move() || self.handing_over => Err(Reject::NotReady),
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
    fn settle(&mut self, mut step: FeedforwardStep<A>) -> FeedforwardStep<A> {
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
        self.model_still = if zero || step.u == [0.0; A] {
            self.model_still.saturating_add(1)
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
    fn obey_stop(&mut self) {
        let now = self.now_s();
        // Manual mode: the generator's sway-free stop, and the stick has to be centred
        // before it moves the crane again (the zero-position interlock); a hand-over
        // from an automatic move is called off (its move stops as any).
        self.deadman.interlock();
        self.handing_over = false;
        if self.mode == Mode::Ready {
            if let Some(path) = self.feedforward.path_mut().manual_mut() {
                path.stop();
                self.manual_stop_held = true;
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
    fn stop_on_path(&mut self, now: f64) {
        let stop = self.planner.plan_stop(self.feedforward.plan(), now);
        let plan = self.feedforward.plan_mut();
        plan.cancel_from(now);
        if let Some(stop) = stop {
            plan.apply_stop(stop);
        }
    }

    /// Whether a move may be accepted: ready, every drive ready, and the controller
    /// operational (a move is process data, and a stop frame is one too).
    fn may_move(&self) -> bool {
        self.mode == Mode::Ready
            && self.drives_ready()
            && self.nmt.node.state == NmtState::Operational
            && !self.feedforward.path().in_manual()
    }

    /// Advances the move being planned by this cycle's share of samples; places it in
    /// the plan and answers when its search is done. A fault meanwhile refuses it.
    fn plan_pending(&mut self) {
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
    /// acts from now on. If it had stopped reading the angle and the crane was at rest,
    /// it starts again, its observer from the next good measurement (its degraded rule
    /// takes it off again if the angle is still bad).
    fn close_loop(&mut self, at_rest: bool) {
        if !C::ENABLED {
            return;
        }
        let degraded = self
            .correction
            .mode()
            .and_then(FeedbackMode::degraded)
            .is_some();
        if !self.closed_loop || (degraded && at_rest) {
            self.correction.restart();
            self.feedback_announced = None;
        }
        self.closed_loop = true;
    }

    /// The drives' position actual (0x6064) at standstill, in the model's input order
    /// (planar: trolley position and rope length). `None` if a drive's position is
    /// unknown or stale, or a drive still moves.
    fn measured_rest(&self) -> Option<[f64; A]> {
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
    fn reset(&mut self) -> Result<(), Reject> {
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
    fn read_positions(&mut self) -> Result<(), Reject> {
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
        // The model restarted (a reset, or the positions read again): centred frames
        // received while halted do not count, the stick has to be centred again before
        // it moves the crane (the zero-position interlock).
        self.deadman.interlock();
        Ok(())
    }

    /// The fault-reset sequence: controlword bit 7 high for three cycles, then low for one
    /// (a rising edge every four cycles: the first against the halt's *quick stop*), so
    /// that a drive that missed an edge, or whose statusword lags a few SYNCs, is reset
    /// without a new fault.
    fn fault_reset_command(&self) -> u16 {
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

    /// Controlword and set point for one drive this cycle.
    /// `wanted`: the drive's velocity after the correction, if a step was taken.
    fn command_for(&mut self, drive: Drive, wanted: Option<f64>) -> (u16, Setpoint) {
        let ready = self.link(drive).is_some_and(DriveLink::ready);
        let state = self.drive_state(drive);
        match self.mode {
            Mode::Enabling | Mode::Ready => {
                let wanted = wanted.unwrap_or(0.0);
                let Some(command) = state.enable_command() else {
                    // A drive in fault: after a reset, the fault-reset sequence; otherwise
                    // it is a fault.
                    if self.resetting > 0 {
                        return (self.fault_reset_command(), self.gate.ramp_to_zero(drive));
                    }
                    self.fault(Fault::DriveFault(drive));
                    return (controlword::QUICK_STOP, self.gate.ramp_to_zero(drive));
                };
                if !ready {
                    if libm::round(wanted * UNITS_PER_M_PER_S) != 0.0 {
                        self.fault(Fault::DriveNotReady(drive));
                    }
                    return (command, self.gate.ramp_to_zero(drive));
                }
                match self.gate.admit(drive, wanted) {
                    Ok(setpoint) => (command, setpoint),
                    Err(e) => {
                        self.fault(Fault::Setpoint(e));
                        (controlword::ENABLE_OPERATION, self.gate.ramp_to_zero(drive))
                    }
                }
            }
            Mode::Stopping(_) => (controlword::ENABLE_OPERATION, self.gate.ramp_to_zero(drive)),
            Mode::QuickStop(_) | Mode::Halted(_) => {
                (controlword::QUICK_STOP, self.gate.ramp_to_zero(drive))
            }
        }
    }

    /// Suspends every commissioning that is running (`Commissioning::suspend`), with
    /// the frame it had waiting.
    fn suspend_commissioning(&mut self) {
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
    fn restart_tpdo_clocks(&mut self, now_ms: u64) {
        for drive in K::DRIVES {
            if let Some(link) = self.link_mut(drive).filter(|l| l.last_tpdo_ms.is_some()) {
                link.restart_clocks(now_ms);
            }
        }
    }

    /// Heartbeats of linked drives, their TPDOs' age, and the supervisor's heartbeat.
    fn supervise_drives(&mut self, now_ms: u64) {
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
    fn supervise_motion(&mut self, now_ms: u64) {
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
    fn in_place(&self) -> bool {
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
    fn supervise_delivery(&mut self) {
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

    /// Queues an EMCY; with the queue full, the new one is dropped and counted.
    fn send_emcy(&mut self, frame: CanFrame) {
        if !self.emcy.send(frame) {
            self.ignore();
        }
    }

    /// Meets a fault: the first one leaves *ready*; a later, more severe one escalates.
    fn fault(&mut self, fault: Fault) {
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
        self.closed_loop = false;
        // After the fault the stick has to be centred before it moves the crane again.
        self.deadman.interlock();
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
    fn announce(&mut self, fault: Fault) {
        let drive_node = fault.drive().map_or(0, |d| self.node_of(d));
        let (emcy, abort) = services::emcy::announcement(self.nmt.node.id, fault, drive_node);
        self.send_emcy(emcy);
        if let Some(abort) = abort {
            self.send_emcy(abort);
        }
    }

    fn push(&mut self, frames: &mut Vec<CanFrame, MAX_FRAMES>, frame: CanFrame) {
        if frames.push(frame).is_err() {
            self.counters.frames_lost = self.counters.frames_lost.saturating_add(1);
        } else {
            self.counters.frames_sent = self.counters.frames_sent.wrapping_add(1);
        }
    }

    /// The drive of `drive`'s axis, if the nodes have one.
    fn link(&self, drive: Drive) -> Option<&DriveLink> {
        self.links.drive(drive)
    }

    fn link_mut(&mut self, drive: Drive) -> Option<&mut DriveLink> {
        self.links.drive_mut(drive)
    }

    /// The node id of `drive`'s axis (0 without a drive).
    fn node_of(&self, drive: Drive) -> u8 {
        self.link(drive).map_or(0, |l| l.commissioning.setup().node)
    }
}

/// What a node's commissioning asks this cycle.
enum Step {
    /// A frame answering a response received between cycles.
    Frame(CanFrame),
    /// A step, a timeout or a presence check came due.
    Progress(Progress),
    /// Nothing.
    Idle,
}

/// The answer waiting in `outbox`, else what `commissioning` asks at `now_ms`.
fn next_step<D: Device>(
    outbox: &mut Option<CanFrame>,
    commissioning: &mut Commissioning<D>,
    now_ms: u64,
) -> Step {
    match outbox.take() {
        Some(frame) => Step::Frame(frame),
        None => commissioning
            .poll(now_ms)
            .map_or(Step::Idle, Step::Progress),
    }
}
