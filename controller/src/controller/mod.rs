//! The 100 Hz cycle: requests, one inverse-model step, two set points, the frames
//! that carry them, the drives' commissioning and supervision, and the reaction to
//! every fault (docs/COMMANDS.md, docs/COMMISSIONING.md).
//!
//! Time is injected (`now_ms` on every call), so the schedule — commissioning, SYNC every
//! cycle, heartbeat and status every 100 ms, the drives' heartbeat and TPDO timeouts —
//! and every reaction is tested on the host. The firmware's only job is to call
//! [`Controller::tick`] every cycle, feed received frames to [`Controller::on_frame`],
//! transmit what comes out, and report each cycle's cost and each failed transmission.

mod manual;
use manual::Manual;
mod moves;
mod receive;
mod setpoints;
mod supervision;

use heapless::{Deque, Vec};
use nalgebra::SVector;

use crate::canopen::emcy::{self, REGISTER_COMMUNICATION, REGISTER_GENERIC, REGISTER_MANUFACTURER};
use crate::canopen::sdo;
use crate::canopen::{self, Incoming, NmtCommand, NmtState};
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
use crate::feedback::{Mode as FeedbackMode, NoFeedback};
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

/// What the state feedback does with the drives' set points: no motion without a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Loop {
    /// Since the last boot, fault or reset nothing was commanded: the model's set points
    /// go out as they are, whatever the load does, and the feedback does not run.
    Open,
    /// Manual mode was entered at rest and nothing was commanded since, or a move
    /// accepted at rest has not started yet: the observer runs (it learns the angle's
    /// offset at rest) and is told that the model's set points went out, the correction
    /// is not sent. The stick's first demand that moves the generator, an accepted
    /// move's start or a take-over closes the loop (a stop request moves nothing and
    /// leaves it so; a fault or a reset opens it); it stays so after manual mode is left
    /// unused, and a second entry at rest keeps it so.
    Observing,
    /// A command began to move the crane (an automatic move's start, the stick's first
    /// demand, a take-over), or a move was accepted on a loop closed before: the
    /// corrected set points go out.
    Closed,
}

/// The crane controller: a CANopen node, manager (or slave) of the drives of crane `K`
/// (its `A` driven axes, [`Crane::DRIVES`]), with the inverse model `F` as feedforward
/// and `C` between it and the
/// drives (Fig. 1: [`NoFeedback`], or the state feedback with an inclinometer).
#[derive(Debug, Clone)]
pub struct Controller<F, C, K, const A: usize> {
    feedforward: F,
    correction: C,
    /// What the state feedback does with the set points: open until a command, see
    /// [`Loop`].
    feedback_loop: Loop,
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
    /// Manual mode's state: the operator's dead-man, the refusal announced, a stop
    /// request's hold, a hand-over under way, how long the model has rested.
    manual: Manual,
    /// Each drive's range guard's latches ([`range::Latches`]): a set point held back
    /// and not yet back to what is asked, the drive found ahead of the model's.
    range_latches: [range::Latches; A],
}

impl<F, K, const A: usize> Controller<F, NoFeedback, K, A>
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    NoFeedback: AxesCorrection<A, K::Reference>,
    K: Crane<A>,
{
    /// A controller that follows `feedforward` and checks moves with `planner`; it starts
    /// by commissioning the drives and holds them at standstill until a move is asked.
    pub fn new(feedforward: F, planner: Planner<K, A>, config: Config) -> Self {
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
            feedback_loop: Loop::Open,
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
                // A crane with one horizontal drive (the planar and the hook-and-load
                // crane: x and the hoist) has no y to demand.
                operator: StagedOperator {
                    planar: K::HORIZONTAL_AXES < 2,
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
            manual: Manual::new(deadband),
            range_latches: [range::Latches::default(); A],
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
        self.close_loop_as_the_move_starts();
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
        let wanted = step.as_ref().map(|s| {
            // Each drive's position actual and the model's reference, each read once for
            // the feedback and the range guard.
            let positions = self.positions();
            let (u, reference) = self.corrected(s, &positions);
            let guarded = self.within_ranges(u, s.u, &positions, reference.as_ref());
            if reference.is_some() && guarded != u {
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

    /// Queues an EMCY; with the queue full, the new one is dropped and counted.
    fn send_emcy(&mut self, frame: CanFrame) {
        if !self.emcy.send(frame) {
            self.ignore();
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
