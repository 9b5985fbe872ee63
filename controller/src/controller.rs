//! The 100 Hz cycle: one inverse-model step, two set points, the frames that carry them.
//!
//! Time is injected (`now_ms` on every call), so the whole schedule — NMT start,
//! SYNC every cycle, the controller's heartbeat, the drives' heartbeat timeouts — is
//! tested on the host. The firmware's only job is to call [`Controller::tick`] every
//! 10 ms, feed received frames to [`Controller::on_frame`] and transmit what comes out.
//!
//! Seams: commands enter through [`Controller::enqueue`] and are taken at the start
//! of a cycle; the supervisor state ([`Mode`]) is consulted before any set point is
//! made. Any fault moves to [`Mode::Stopping`]: both drives ramp to standstill within
//! their acceleration limits, then get *quick stop* ([`Mode::Stopped`]).

use heapless::{Deque, Vec};
use solver_core::Error;

use crate::canopen::{self, Drive, Incoming, NmtCommand, NmtState, CONTROLLER_NODE};
use crate::cia402::{controlword, DriveState, STATUS_FAULT};
use crate::feedforward::{Feedforward, FeedforwardStep};
use crate::frame::CanFrame;
use crate::units::{DriveLimits, Setpoint, SetpointError, SetpointGate};

/// Timing and limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// Drive limits enforced at the choke point.
    pub limits: DriveLimits,
    /// Cycle time, ms (the solver's h).
    pub period_ms: u32,
    /// Period of the controller's own heartbeat, ms.
    pub heartbeat_period_ms: u32,
    /// A drive whose heartbeat is older than this is lost, ms.
    pub heartbeat_timeout_ms: u32,
    /// Each drive's first heartbeat must arrive within this time after start, ms.
    pub boot_timeout_ms: u32,
}

impl Config {
    /// 100 Hz, heartbeats every 100 ms, drives lost after 300 ms (1 s at boot).
    pub const DEFAULT: Self = Self {
        limits: DriveLimits::LAB,
        period_ms: 10,
        heartbeat_period_ms: 100,
        heartbeat_timeout_ms: 300,
        boot_timeout_ms: 1000,
    };
}

/// Why the controller stopped.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Fault {
    /// The inverse model failed (Newton, singular matrix, non-finite values).
    Solver(#[cfg_attr(feature = "defmt", defmt(Debug2Format))] Error),
    /// The choke point refused the model's set point.
    Setpoint(SetpointError),
    /// The model asked for motion of a drive that is not enabled.
    DriveNotReady(Drive),
    /// A drive reported a fault (statusword bit 3 or an EMCY).
    DriveFault(Drive),
    /// A drive's heartbeat stopped.
    HeartbeatLost(Drive),
    /// A stop was requested.
    StopRequested,
}

/// The supervisor state.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Mode {
    /// Following the inverse model.
    Running,
    /// Ramping both drives to standstill after a fault.
    Stopping(Fault),
    /// At standstill, drives held by quick stop.
    Stopped(Fault),
}

/// Requests from a supervisor (PLC/HMI); the next issue adds moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Command {
    /// Bring the load to rest and hold.
    Stop,
}

/// What the controller knows of one drive.
#[derive(Debug, Clone, Copy, PartialEq)]
struct DriveLink {
    state: DriveState,
    velocity: i32,
    nmt: Option<NmtState>,
    last_heartbeat_ms: Option<u32>,
}

/// Running totals for diagnostics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// Cycles run.
    pub cycles: u32,
    /// Frames received and understood.
    pub frames_received: u32,
    /// Frames received and ignored (unknown, malformed, out of range).
    pub frames_ignored: u32,
    /// Frames handed out for transmission.
    pub frames_sent: u32,
    /// Commands refused because the queue was full.
    pub commands_dropped: u32,
    /// Frames that did not fit a cycle's buffer (at most 6 of 8 are used: must stay 0).
    pub frames_lost: u32,
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
#[derive(Debug)]
pub struct Controller<F> {
    feedforward: F,
    config: Config,
    gate: SetpointGate,
    drives: [DriveLink; 2],
    mode: Mode,
    commands: Deque<Command, 4>,
    counters: Counters,
}

impl<F: Feedforward> Controller<F> {
    /// A controller that will follow `feedforward`, starting with the drives at standstill.
    pub fn new(feedforward: F, config: Config) -> Self {
        let link = DriveLink {
            state: DriveState::Unknown,
            velocity: 0,
            nmt: None,
            last_heartbeat_ms: None,
        };
        Self {
            feedforward,
            config,
            gate: SetpointGate::new(config.limits, f64::from(config.period_ms) / 1000.0),
            drives: [link; 2],
            mode: Mode::Running,
            commands: Deque::new(),
            counters: Counters::default(),
        }
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

    /// Queues a command for the next cycle; a full queue refuses it (and counts).
    pub fn enqueue(&mut self, command: Command) -> Result<(), Command> {
        self.commands
            .push_back(command)
            .inspect_err(|_| self.counters.commands_dropped += 1)
    }

    /// Takes one received frame. Frames it does not understand are ignored and counted:
    /// they never change a set point.
    pub fn on_frame(&mut self, frame: &CanFrame, now_ms: u32) {
        let Ok(incoming) = canopen::decode(frame) else {
            self.counters.frames_ignored += 1;
            return;
        };
        self.counters.frames_received += 1;
        match incoming {
            Incoming::Heartbeat { node, state } => {
                if let Some(link) = Drive::ALL
                    .into_iter()
                    .find(|d| d.node() == node)
                    .map(|d| self.link_mut(d))
                {
                    link.nmt = Some(state);
                    link.last_heartbeat_ms = Some(now_ms);
                }
            }
            Incoming::Status {
                drive,
                statusword,
                velocity,
            } => {
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
        }
    }

    /// One cycle at time `now_ms` (the start of the cycle).
    pub fn tick(&mut self, now_ms: u32) -> Cycle {
        let mut frames = Vec::new();
        let first = self.counters.cycles == 0;
        if first {
            push(
                &mut frames,
                &mut self.counters,
                canopen::nmt(NmtCommand::Start, 0),
            );
            push(
                &mut frames,
                &mut self.counters,
                canopen::heartbeat(CONTROLLER_NODE, NmtState::BootUp),
            );
        }
        if let Some(Command::Stop) = self.commands.pop_front() {
            self.fault(Fault::StopRequested);
        }
        self.supervise_heartbeats(now_ms);

        let step = if self.mode == Mode::Running {
            match self.feedforward.step() {
                Ok(step) => Some(step),
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
            if let Some(slot) = setpoints.get_mut(drive.index()) {
                *slot = setpoint;
            }
            push(
                &mut frames,
                &mut self.counters,
                canopen::rpdo1(drive, command, setpoint),
            );
        }
        if let Mode::Stopping(fault) = self.mode {
            if self.gate.at_standstill() {
                self.mode = Mode::Stopped(fault);
            }
        }
        push(&mut frames, &mut self.counters, canopen::sync());
        let heartbeat_cycles = (self.config.heartbeat_period_ms / self.config.period_ms).max(1);
        if !first && self.counters.cycles.is_multiple_of(heartbeat_cycles) {
            push(
                &mut frames,
                &mut self.counters,
                canopen::heartbeat(CONTROLLER_NODE, NmtState::Operational),
            );
        }
        self.counters.cycles = self.counters.cycles.wrapping_add(1);
        self.counters.frames_sent = self.counters.frames_sent.wrapping_add(frames.len() as u32);
        Cycle {
            frames,
            setpoints,
            step,
            mode: self.mode,
        }
    }

    /// Controlword and set point for one drive this cycle.
    fn command_for(&mut self, drive: Drive, step: Option<&FeedforwardStep>) -> (u16, Setpoint) {
        let state = self.link(drive).state;
        match self.mode {
            Mode::Running => {
                let Some(command) = state.enable_command() else {
                    self.fault(Fault::DriveFault(drive));
                    return (controlword::QUICK_STOP, self.gate.ramp_to_zero(drive));
                };
                let wanted = step
                    .and_then(|s| s.u.get(drive.index()).copied())
                    .unwrap_or(0.0);
                if state != DriveState::OperationEnabled {
                    if wanted != 0.0 {
                        self.fault(Fault::DriveNotReady(drive));
                    }
                    return (command, self.gate.ramp_to_zero(drive));
                }
                match self.gate.admit(drive, wanted) {
                    Ok(setpoint) => (command, setpoint),
                    Err(e) => {
                        self.fault(Fault::Setpoint(e));
                        (command, self.gate.ramp_to_zero(drive))
                    }
                }
            }
            Mode::Stopping(_) => (controlword::ENABLE_OPERATION, self.gate.ramp_to_zero(drive)),
            Mode::Stopped(_) => (controlword::QUICK_STOP, self.gate.ramp_to_zero(drive)),
        }
    }

    fn supervise_heartbeats(&mut self, now_ms: u32) {
        for drive in Drive::ALL {
            let lost = match self.link(drive).last_heartbeat_ms {
                None => now_ms > self.config.boot_timeout_ms,
                Some(t) => now_ms.wrapping_sub(t) > self.config.heartbeat_timeout_ms,
            };
            if lost {
                self.fault(Fault::HeartbeatLost(drive));
            }
        }
    }

    /// Enters the controlled stop; the first fault is the one remembered.
    fn fault(&mut self, fault: Fault) {
        if self.mode == Mode::Running {
            self.mode = Mode::Stopping(fault);
        }
    }

    fn link(&self, drive: Drive) -> &DriveLink {
        let [trolley, winch] = &self.drives;
        match drive {
            Drive::Trolley => trolley,
            Drive::Winch => winch,
        }
    }

    fn link_mut(&mut self, drive: Drive) -> &mut DriveLink {
        let [trolley, winch] = &mut self.drives;
        match drive {
            Drive::Trolley => trolley,
            Drive::Winch => winch,
        }
    }
}

/// Appends a frame; a cycle makes at most six (NMT, boot-up, 2 RPDOs, SYNC,
/// heartbeat), so eight always fit — a loss would show in [`Counters::frames_lost`].
fn push(frames: &mut Vec<CanFrame, 8>, counters: &mut Counters, frame: CanFrame) {
    if frames.push(frame).is_err() {
        counters.frames_lost += 1;
    }
}
