//! The 100 Hz cycle: requests, one inverse-model step, two set points, the frames
//! that carry them, and the reaction to every fault (docs/COMMANDS.md).
//!
//! Time is injected (`now_ms` on every call), so the schedule — NMT start, SYNC every
//! cycle, heartbeat and status every 100 ms, the drives' heartbeat timeouts — and every
//! reaction is tested on the host. The firmware's only job is to call
//! [`Controller::tick`] every 10 ms, feed received frames to [`Controller::on_frame`],
//! transmit what comes out, and report each cycle's cost and each failed transmission.

use heapless::{Deque, Vec};
use solver_core::Error;

use crate::canopen::{self, Incoming, NmtCommand, NmtState, CONTROLLER_NODE};
use crate::cia402::{controlword, DriveState, STATUS_FAULT};
use crate::commands::{status_frame, Answer, Reject, Request, Status};
use crate::drive::Drive;
use crate::feedforward::{Feedforward, FeedforwardStep, Replan};
use crate::frame::CanFrame;
use crate::planner::{MoveSearch, Planner, SAMPLES_PER_CYCLE};
use crate::setpoint::{DriveLimits, Setpoint, SetpointError, SetpointGate, UNITS_PER_M_PER_S};

/// Timing, limits and the thresholds of the fault reactions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// Drive limits enforced at the choke point and by the planner.
    pub limits: DriveLimits,
    /// Cycle time, ms (the solver's h).
    pub period_ms: u32,
    /// Period of the controller's heartbeat and status, ms.
    pub heartbeat_period_ms: u32,
    /// A drive whose heartbeat is older than this is lost, ms.
    pub heartbeat_timeout_ms: u32,
    /// Each drive's first heartbeat must arrive within this time after start, ms.
    pub boot_timeout_ms: u32,
    /// A cycle costing more than this (core cycles; QEMU instructions) missed its deadline:
    /// 10 ms at 400 MHz.
    pub cycle_budget: u64,
    /// A second deadline miss within this many cycles stops the crane.
    pub deadline_window: u32,
    /// This many cycles in a row with a failed RPDO: set points cannot be delivered.
    pub undeliverable_cycles: u32,
    /// Cycles of *fault reset* sent after a reset before a drive still in fault counts
    /// as a new fault.
    pub fault_reset_cycles: u8,
}

impl Config {
    /// 100 Hz on a 400 MHz Cortex-M7, heartbeats every 100 ms, drives lost after 300 ms.
    pub const DEFAULT: Self = Self {
        limits: DriveLimits::LAB,
        period_ms: 10,
        heartbeat_period_ms: 100,
        heartbeat_timeout_ms: 300,
        boot_timeout_ms: 1000,
        cycle_budget: 4_000_000,
        deadline_window: 100,
        undeliverable_cycles: 3,
        fault_reset_cycles: 10,
    };
}

/// Why the controller left *ready* (status byte 4, EMCY's first manufacturer byte).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Fault {
    /// The inverse model failed (Newton, singular matrix, non-finite values).
    Solver(Error),
    /// The choke point refused the model's set point.
    Setpoint(SetpointError),
    /// A drive reported a fault (statusword bit 3 or an EMCY).
    DriveFault(Drive),
    /// A drive's heartbeat stopped.
    HeartbeatLost(Drive),
    /// A second deadline miss within the window.
    Deadline,
    /// Set points could not be delivered for several cycles.
    Undeliverable,
    /// The model asked for motion of a drive that is not enabled.
    DriveNotReady(Drive),
    /// The controller was restarted by its watchdog: the 100 Hz task had stopped.
    Watchdog,
}

/// How a fault is met (docs/COMMANDS.md), mildest first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Reaction {
    Controlled,
    Quick,
    Halt,
}

impl Fault {
    /// The fault byte of the status frame and of the EMCY.
    #[must_use]
    pub fn code(&self) -> u8 {
        match self {
            Fault::Solver(_) => 1,
            Fault::Setpoint(_) => 2,
            Fault::DriveFault(_) => 3,
            Fault::HeartbeatLost(_) => 4,
            Fault::Deadline => 5,
            Fault::Undeliverable => 6,
            Fault::DriveNotReady(_) => 7,
            Fault::Watchdog => 8,
        }
    }

    /// The CiA 301 error code of the EMCY.
    #[must_use]
    pub fn emcy_code(&self) -> u16 {
        match self {
            Fault::Solver(_) => 0x6100,
            Fault::Setpoint(_) => 0xFF03,
            Fault::DriveFault(_) => 0xFF02,
            Fault::HeartbeatLost(_) => 0x8130,
            Fault::Deadline => 0xFF01,
            Fault::Undeliverable => 0x8140,
            Fault::DriveNotReady(_) => 0xFF04,
            Fault::Watchdog => 0x6010,
        }
    }

    /// The node concerned (a drive) or 0.
    fn node(&self) -> u8 {
        match self {
            Fault::DriveFault(d) | Fault::HeartbeatLost(d) | Fault::DriveNotReady(d) => d.node(),
            Fault::Setpoint(
                SetpointError::NonFinite { drive }
                | SetpointError::OverSpeed { drive, .. }
                | SetpointError::OverAcceleration { drive, .. },
            ) => drive.node(),
            _ => 0,
        }
    }

    /// The EMCY's third manufacturer byte: for a refused set point, why (1 non-finite,
    /// 2 over speed, 3 over acceleration); for a solver failure, which (1 Newton did not
    /// converge, 2 singular matrix, 3 non-finite value, 4 other); otherwise 0.
    fn detail(&self) -> u8 {
        match self {
            Fault::Setpoint(SetpointError::NonFinite { .. }) => 1,
            Fault::Setpoint(SetpointError::OverSpeed { .. }) => 2,
            Fault::Setpoint(SetpointError::OverAcceleration { .. }) => 3,
            Fault::Solver(Error::NewtonNotConverged { .. }) => 1,
            Fault::Solver(Error::SingularJacobian { .. }) => 2,
            Fault::Solver(Error::NonFinite { .. }) => 3,
            Fault::Solver(_) => 4,
            _ => 0,
        }
    }

    fn reaction(&self) -> Reaction {
        match self {
            Fault::DriveFault(_) | Fault::HeartbeatLost(_) => Reaction::Quick,
            Fault::Undeliverable | Fault::Watchdog => Reaction::Halt,
            _ => Reaction::Controlled,
        }
    }
}

/// The supervisor state.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Walking the drives through the CiA 402 enable sequence; moves are refused.
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

/// What the controller knows of one drive.
#[derive(Debug, Clone, Copy, PartialEq)]
struct DriveLink {
    state: DriveState,
    velocity: i32,
    last_heartbeat_ms: Option<u64>,
}

/// Running totals, reported in the status frame and the logs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// Cycles run.
    pub cycles: u32,
    /// Frames received and understood.
    pub frames_received: u32,
    /// Frames ignored: malformed, unknown, out of range, or requests beyond the queue.
    pub frames_ignored: u32,
    /// Frames handed out for transmission.
    pub frames_sent: u32,
    /// Frames that did not fit a cycle's buffer (at most 7 of 8 are used: must stay 0).
    pub frames_lost: u32,
    /// Cycles that missed their deadline.
    pub deadline_misses: u32,
    /// Frames the board failed to transmit.
    pub tx_failures: u32,
    /// Requests answered.
    pub requests: u32,
}

/// A move request whose duration is being searched.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PendingMove {
    id: u8,
    target: [f64; 2],
    search: MoveSearch,
}

/// Everything one cycle produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Cycle {
    /// Frames to transmit, in order.
    pub frames: Vec<CanFrame, 8>,
    /// The set points sent, `[trolley, winch]`.
    pub setpoints: [Setpoint; 2],
    /// The inverse-model step of this cycle, if one was taken.
    pub step: Option<FeedforwardStep>,
    /// The supervisor state after the cycle.
    pub mode: Mode,
}

/// The crane controller: CANopen manager of the trolley and winch drives.
#[derive(Debug, Clone)]
pub struct Controller<F> {
    feedforward: F,
    config: Config,
    gate: SetpointGate,
    planner: Planner,
    drives: [DriveLink; 2],
    mode: Mode,
    requests: Deque<Request, 4>,
    /// The move being planned, a share of its search per cycle.
    pending: Option<PendingMove>,
    counters: Counters,
    /// The last answer: request id, answer, reason.
    answer: (u8, Answer, Option<Reject>),
    /// An answer was given this cycle: send the status at once.
    answered: bool,
    last_miss_cycle: Option<u32>,
    rpdo_failed: bool,
    failed_cycles: u32,
    emcy: Option<CanFrame>,
    /// Trolley position and rope length when the controller left *ready*, plus the
    /// travel the drives reported since: where the load hangs at the reset.
    drive_positions: [f64; 2],
    /// Cycles of *fault reset* still to send after a reset.
    resetting: u8,
    now_ms: u64,
    /// The first cycle has not run yet (NMT start and boot-up are due).
    starting: bool,
}

impl<F: Feedforward + Replan> Controller<F> {
    /// A controller that follows `feedforward` and checks moves with `planner`; it starts
    /// by enabling the drives.
    pub fn new(feedforward: F, planner: Planner, config: Config) -> Self {
        let link = DriveLink {
            state: DriveState::Unknown,
            velocity: 0,
            last_heartbeat_ms: None,
        };
        let position = feedforward.plan().final_position().into();
        let period = f64::from(config.period_ms) / 1000.0;
        Self {
            feedforward,
            config,
            gate: SetpointGate::new(config.limits, period),
            planner,
            drives: [link; 2],
            mode: Mode::Enabling,
            requests: Deque::new(),
            pending: None,
            counters: Counters::default(),
            answer: (0, Answer::None, None),
            answered: false,
            last_miss_cycle: None,
            rpdo_failed: false,
            failed_cycles: 0,
            emcy: None,
            drive_positions: position,
            resetting: 0,
            now_ms: 0,
            starting: true,
        }
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

    /// Diagnostics.
    #[must_use]
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// The state of a drive as last reported.
    #[must_use]
    pub fn drive_state(&self, drive: Drive) -> DriveState {
        self.link(drive).state
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

    /// The last answer given: request id, answer, reason.
    #[must_use]
    pub fn last_answer(&self) -> (u8, Answer, Option<Reject>) {
        self.answer
    }

    /// Takes one received frame. Frames it does not understand are ignored and counted:
    /// they never change a set point.
    pub fn on_frame(&mut self, frame: &CanFrame, now_ms: u64) {
        let Ok(incoming) = canopen::decode(frame) else {
            self.counters.frames_ignored = self.counters.frames_ignored.saturating_add(1);
            return;
        };
        self.counters.frames_received = self.counters.frames_received.saturating_add(1);
        match incoming {
            Incoming::Heartbeat { node, .. } => {
                if let Some(d) = Drive::ALL.into_iter().find(|d| d.node() == node) {
                    self.link_mut(d).last_heartbeat_ms = Some(now_ms);
                }
            }
            Incoming::Status {
                drive,
                statusword,
                velocity,
            } => {
                let period = f64::from(self.config.period_ms) / 1000.0;
                if self.mode.fault().is_some() {
                    // One TPDO per cycle, answering the SYNC: travel over one period.
                    *drive.of_mut(&mut self.drive_positions) +=
                        f64::from(velocity) / UNITS_PER_M_PER_S * period;
                }
                let link = self.link_mut(drive);
                link.state = DriveState::from_statusword(statusword);
                link.velocity = velocity;
                if statusword & STATUS_FAULT != 0 {
                    self.fault(Fault::DriveFault(drive));
                }
            }
            Incoming::Emergency { drive, code, .. } => {
                if code != 0 {
                    self.fault(Fault::DriveFault(drive));
                }
            }
            Incoming::Command(request) => {
                if self.requests.push_back(request).is_err() {
                    // More requests in one cycle than the queue holds: ignored and counted.
                    self.counters.frames_ignored = self.counters.frames_ignored.saturating_add(1);
                }
            }
        }
    }

    /// Reports what the last cycle cost (core cycles; QEMU instructions). A cycle over
    /// the budget missed its deadline; a second miss within the window stops the crane.
    pub fn record_cost(&mut self, cost: u64) {
        if cost <= self.config.cycle_budget {
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
    /// next cycle unless a newer one replaces it, so no fault goes unannounced.
    pub fn transmit_failed(&mut self, frame: &CanFrame) {
        self.counters.tx_failures = self.counters.tx_failures.saturating_add(1);
        let id = frame.id();
        if Drive::ALL
            .iter()
            .any(|d| id == canopen::cob::RPDO1 + u16::from(d.node()))
        {
            self.rpdo_failed = true;
        }
        if id == canopen::cob::EMCY + u16::from(CONTROLLER_NODE) && self.emcy.is_none() {
            self.emcy = Some(*frame);
        }
    }

    /// One cycle at time `now_ms` (the start of the cycle; the model has been stepped to it).
    pub fn tick(&mut self, now_ms: u64) -> Cycle {
        self.now_ms = now_ms;
        let mut frames = Vec::new();
        let first = core::mem::take(&mut self.starting);
        if first {
            self.push(&mut frames, canopen::nmt(NmtCommand::Start, 0));
            self.push(
                &mut frames,
                canopen::heartbeat(CONTROLLER_NODE, NmtState::BootUp),
            );
        }
        self.supervise_delivery();
        self.supervise_heartbeats(now_ms);
        // Requests are taken in order: the next one waits while a move is planned.
        if self.pending.is_none() {
            if let Some(request) = self.requests.pop_front() {
                self.handle(request);
            }
        }
        self.plan_pending();
        if self.mode == Mode::Enabling
            && self.resetting == 0
            && Drive::ALL
                .iter()
                .all(|d| self.link(*d).state == DriveState::OperationEnabled)
        {
            self.mode = Mode::Ready;
        }

        let step = if matches!(self.mode, Mode::Enabling | Mode::Ready) {
            match self.feedforward.step() {
                Ok(step) => {
                    self.feedforward.plan_mut().retire(step.t);
                    Some(step)
                }
                Err(e) => {
                    self.fault(Fault::Solver(e));
                    None
                }
            }
        } else {
            None
        };
        let mut setpoints = [Setpoint::ZERO; 2];
        for drive in Drive::ALL {
            let (command, setpoint) = self.command_for(drive, step.as_ref());
            *drive.of_mut(&mut setpoints) = setpoint;
            self.push(&mut frames, canopen::rpdo1(drive, command, setpoint));
        }
        self.resetting = self.resetting.saturating_sub(1);
        if let Mode::Stopping(f) | Mode::QuickStop(f) = self.mode {
            if self.gate.at_standstill() {
                self.mode = Mode::Halted(f);
            }
        }
        if let Some(emcy) = self.emcy.take() {
            self.push(&mut frames, emcy);
        }
        self.push(&mut frames, canopen::sync());
        let periodic = self
            .config
            .heartbeat_period_ms
            .checked_div(self.config.period_ms)
            .unwrap_or(1)
            .max(1);
        let beat = !first && self.counters.cycles.is_multiple_of(periodic);
        if beat {
            self.push(
                &mut frames,
                canopen::heartbeat(CONTROLLER_NODE, NmtState::Operational),
            );
        }
        if beat || self.answered {
            let status = self.status();
            self.push(&mut frames, status_frame(&status));
            self.answered = false;
        }
        self.counters.cycles = self.counters.cycles.wrapping_add(1);
        Cycle {
            frames,
            setpoints,
            step,
            mode: self.mode,
        }
    }

    /// The status frame's contents now.
    #[must_use]
    pub fn status(&self) -> Status {
        let (last_id, answer, reason) = self.answer;
        Status {
            last_id,
            answer,
            reason,
            mode: self.mode.code(),
            fault: self.mode.fault().map_or(0, |f| f.code()),
            ignored: self.counters.frames_ignored,
            deadline_misses: self.counters.deadline_misses,
            tx_failures: self.counters.tx_failures,
        }
    }

    fn now_s(&self) -> f64 {
        // Exact below 2^53 ms (285,000 years).
        self.now_ms as f64 / 1000.0
    }

    /// Takes one request (docs/COMMANDS.md): answers it, or starts planning a move.
    fn handle(&mut self, request: Request) {
        let now = self.now_s();
        let answer = match request {
            Request::Move {
                id,
                target,
                duration,
            } => {
                let plan = self.feedforward.plan();
                if self.mode != Mode::Ready {
                    Err(Reject::NotReady)
                } else if plan.has_queued() {
                    Err(Reject::Busy)
                } else {
                    match MoveSearch::new(plan, target, duration) {
                        Ok(search) => {
                            self.pending = Some(PendingMove { id, target, search });
                            return;
                        }
                        Err(r) => Err(r),
                    }
                }
            }
            Request::Stop { .. } => {
                // The queued move is dropped; the running one is replaced by a quicker
                // smooth stop if one fits the limits, else it is the stop.
                if self.mode == Mode::Ready && self.feedforward.plan().is_moving(now) {
                    let plan = self.feedforward.plan_mut();
                    plan.drop_queued();
                    if let Some(stop) = self.planner.plan_stop(plan, now) {
                        plan.apply_stop(stop);
                    }
                }
                Ok(Answer::Accepted)
            }
            Request::Reset { .. } => match self.mode {
                Mode::Halted(_) => self.reset().map(|()| Answer::Accepted),
                Mode::Stopping(_) | Mode::QuickStop(_) => Err(Reject::NotReady),
                Mode::Enabling | Mode::Ready => Ok(Answer::Accepted),
            },
        };
        self.give_answer(request.id(), answer);
    }

    /// Advances the move being planned by this cycle's share of samples; places it in
    /// the plan and answers when its search is done. A fault meanwhile refuses it.
    fn plan_pending(&mut self) {
        let Some(mut pending) = self.pending.take() else {
            return;
        };
        if self.mode != Mode::Ready {
            self.give_answer(pending.id, Err(Reject::NotReady));
            return;
        }
        let mut budget = SAMPLES_PER_CYCLE;
        let Some(result) = pending.search.advance(&self.planner, &mut budget) else {
            self.pending = Some(pending);
            return;
        };
        let now = self.now_s();
        let answer = result.and_then(|duration| {
            let plan = self.feedforward.plan_mut();
            let moving = plan.is_moving(now);
            // The search checked the path on [0, T]; it is placed now or after the
            // running move, which shifts it in time and changes nothing it checked.
            plan.candidate(pending.target.into(), now, duration)
                .and_then(|m| plan.push(m))
                .map_err(|_| Reject::Busy)?;
            Ok(if moving {
                Answer::Queued
            } else {
                Answer::Accepted
            })
        });
        self.give_answer(pending.id, answer);
    }

    fn give_answer(&mut self, id: u8, answer: Result<Answer, Reject>) {
        self.answer = match answer {
            Ok(a) => (id, a, None),
            Err(r) => (id, Answer::Rejected, Some(r)),
        };
        self.answered = true;
        self.counters.requests = self.counters.requests.saturating_add(1);
    }

    /// Leaves *halted*: fault reset to the drives, the model restarted at rest where the
    /// load hangs now (below the trolley, where the drives stopped), the enable sequence,
    /// EMCY 0x0000.
    fn reset(&mut self) -> Result<(), Reject> {
        self.feedforward
            .restart_at_rest(self.drive_positions, self.now_s())
            .map_err(|_| Reject::Invalid)?;
        self.resetting = self.config.fault_reset_cycles;
        self.last_miss_cycle = None;
        self.failed_cycles = 0;
        self.mode = Mode::Enabling;
        self.emcy = Some(canopen::emcy(CONTROLLER_NODE, 0x0000, 0, [0; 5]));
        Ok(())
    }

    /// Controlword and set point for one drive this cycle.
    fn command_for(&mut self, drive: Drive, step: Option<&FeedforwardStep>) -> (u16, Setpoint) {
        let state = self.link(drive).state;
        match self.mode {
            Mode::Enabling | Mode::Ready => {
                let wanted = step.map(|s| *drive.of(&s.u)).unwrap_or(0.0);
                let Some(command) = state.enable_command() else {
                    // A drive in fault: after a reset, send fault reset; otherwise it is a fault.
                    if self.resetting > 0 {
                        return (controlword::FAULT_RESET, self.gate.ramp_to_zero(drive));
                    }
                    self.fault(Fault::DriveFault(drive));
                    return (controlword::QUICK_STOP, self.gate.ramp_to_zero(drive));
                };
                if state != DriveState::OperationEnabled {
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

    fn supervise_heartbeats(&mut self, now_ms: u64) {
        for drive in Drive::ALL {
            let lost = match self.link(drive).last_heartbeat_ms {
                None => now_ms > u64::from(self.config.boot_timeout_ms),
                Some(t) => now_ms.saturating_sub(t) > u64::from(self.config.heartbeat_timeout_ms),
            };
            if lost {
                self.fault(Fault::HeartbeatLost(drive));
            }
        }
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
            return;
        }
        if current.is_none() {
            self.drive_positions = self
                .planner
                .drive_positions(self.feedforward.plan(), self.now_s());
        }
        self.mode = match reaction {
            Reaction::Controlled => Mode::Stopping(fault),
            Reaction::Quick => Mode::QuickStop(fault),
            Reaction::Halt => Mode::Halted(fault),
        };
        let register = 0x01
            | if matches!(fault, Fault::HeartbeatLost(_) | Fault::Undeliverable) {
                0x10
            } else {
                0x80
            };
        self.emcy = Some(canopen::emcy(
            CONTROLLER_NODE,
            fault.emcy_code(),
            register,
            [fault.code(), fault.node(), fault.detail(), 0, 0],
        ));
    }

    fn push(&mut self, frames: &mut Vec<CanFrame, 8>, frame: CanFrame) {
        if frames.push(frame).is_err() {
            self.counters.frames_lost = self.counters.frames_lost.saturating_add(1);
        } else {
            self.counters.frames_sent = self.counters.frames_sent.wrapping_add(1);
        }
    }

    fn link(&self, drive: Drive) -> &DriveLink {
        drive.of(&self.drives)
    }

    fn link_mut(&mut self, drive: Drive) -> &mut DriveLink {
        drive.of_mut(&mut self.drives)
    }
}
