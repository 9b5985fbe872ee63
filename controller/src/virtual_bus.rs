//! A virtual CAN bus: two simulated CiA 402 drives that answer the controller, plus a
//! scenario of timed actions (supervisor requests, garbage, a drive fault, a silenced
//! drive, an injected solver failure). Compiled into the QEMU build and replayed
//! identically by the host reference, so both see the same bus.
//!
//! The drives are deliberately simple: they walk the CiA 402 state machine on the
//! controlwords they receive, answer every SYNC with a TPDO (statusword and the target
//! velocity as actual velocity), and send a heartbeat every 100 ms from 5 ms on.

use heapless::Deque;

use crate::canopen::{self, cob, NmtState};
use crate::cia402::{controlword, DriveState};
use crate::commands::{request_frame, Request};
use crate::controller::{Controller, Cycle, Mode};
use crate::drive::Drive;
use crate::feedforward::{Feedforward, Injectable, Replan};
use crate::frame::CanFrame;
use crate::traffic::Traffic;

/// A frame as `const` data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawFrame {
    /// 11-bit identifier.
    pub id: u16,
    /// Number of data bytes.
    pub len: u8,
    /// Data.
    pub data: [u8; 8],
}

impl RawFrame {
    /// The frame (id masked to 11 bits, length capped at 8).
    #[must_use]
    pub fn frame(&self) -> CanFrame {
        CanFrame::fixed(
            self.id,
            self.data.get(..usize::from(self.len.min(8))).unwrap_or(&[]),
        )
    }
}

/// What happens at a scenario's event.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// The supervisor sends a request.
    Request(Request),
    /// A frame appears on the bus (garbage, malformed, foreign).
    Frame(RawFrame),
    /// `count` frames of garbage appear.
    Storm {
        /// How many.
        count: u8,
    },
    /// The drive goes to *fault* (statusword bit 3) and sends an EMCY.
    DriveFault(Drive),
    /// The drive falls silent (no heartbeat, no TPDO).
    Silence(Drive),
    /// The drive drops to *switch on disabled* without a fault (safe torque off).
    DropOut(Drive),
    /// A silent drive talks again.
    Revive(Drive),
    /// The inverse model's next step fails (the firmware's solver-fault injection).
    SolverFailure,
    /// The firmware hangs: its 100 Hz task stops (the watchdog's case).
    Hang,
    /// The controller's transmissions fail for `cycles` cycles (bus-off, then recovery).
    BusOff {
        /// How long, in cycles.
        cycles: u8,
    },
}

/// An action at a time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Event {
    /// Time, ms.
    pub at_ms: u32,
    /// What happens.
    pub action: Action,
}

/// A named scenario: its events and how long it runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scenario {
    /// Name (the QEMU command line selects it).
    pub name: &'static str,
    /// What the end state should be, for the logs.
    pub expect: &'static str,
    /// Events in time order.
    pub events: &'static [Event],
    /// Cycles to run; 0 runs the scene's own time.
    pub cycles: u32,
    /// Random traffic from this seed on top of the events (the soak run).
    pub random: Option<u32>,
    /// The mode the run must end in (the QEMU firmware's exit code says whether it did).
    pub ends: Ending,
}

/// The mode a scenario must end in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ending {
    /// Ready.
    Ready,
    /// Halted, by the fault the scenario injects.
    Halted,
    /// Either (random traffic).
    Either,
}

impl Ending {
    /// Whether `mode` is an admissible end.
    #[must_use]
    pub fn admits(self, mode: Mode) -> bool {
        match self {
            Ending::Ready => mode == Mode::Ready,
            Ending::Halted => matches!(mode, Mode::Halted(_)),
            Ending::Either => true,
        }
    }
}

impl Scenario {
    /// When the scenario makes the firmware hang, ms.
    #[must_use]
    pub fn hang_at_ms(&self) -> Option<u32> {
        self.events
            .iter()
            .find(|e| e.action == Action::Hang)
            .map(|e| e.at_ms)
    }
}

/// One simulated CiA 402 drive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveSim {
    drive: Drive,
    state: DriveState,
    velocity: i32,
    silent: bool,
}

impl DriveSim {
    /// A drive that has just booted (switch on disabled).
    #[must_use]
    pub fn new(drive: Drive) -> Self {
        Self {
            drive,
            state: DriveState::SwitchOnDisabled,
            velocity: 0,
            silent: false,
        }
    }

    /// Its CiA 402 state.
    #[must_use]
    pub fn state(&self) -> DriveState {
        self.state
    }

    fn statusword(&self) -> u16 {
        match self.state {
            DriveState::ReadyToSwitchOn => 0x0231,
            DriveState::SwitchedOn => 0x0233,
            DriveState::OperationEnabled => 0x0237,
            DriveState::QuickStopActive => 0x0217,
            DriveState::FaultReactionActive | DriveState::Fault => 0x0218,
            _ => 0x0250,
        }
    }

    /// Applies an RPDO addressed to this drive: the CiA 402 transitions (numbers of
    /// CiA 402 Fig. 3) for the controlwords the controller sends, anything else ignored.
    /// In *quick stop active* the drive brakes on its own ramp ([`QUICK_STOP_DECELERATION`]).
    fn command(&mut self, cw: u16, target: i32) {
        use controlword::*;
        use DriveState::*;
        self.state = match (self.state, cw) {
            (Fault, FAULT_RESET) => SwitchOnDisabled, // 15
            (Fault, _) => Fault,
            (OperationEnabled, QUICK_STOP) => QuickStopActive, // 11
            (QuickStopActive, QUICK_STOP) => QuickStopActive,
            (_, DISABLE_VOLTAGE | QUICK_STOP) => SwitchOnDisabled, // 7, 9, 10, 12
            (QuickStopActive, _) => QuickStopActive,
            (SwitchOnDisabled | SwitchedOn | OperationEnabled, SHUTDOWN) => ReadyToSwitchOn, // 2, 6, 8
            (ReadyToSwitchOn, SWITCH_ON) => SwitchedOn,                                      // 3
            (OperationEnabled, SWITCH_ON) => SwitchedOn,                                     // 5
            (SwitchedOn | OperationEnabled, ENABLE_OPERATION) => OperationEnabled,           // 4
            (state, _) => state,
        };
        self.velocity = match self.state {
            OperationEnabled => target,
            QuickStopActive => {
                let step = QUICK_STOP_DECELERATION_UNITS_PER_CYCLE;
                self.velocity - self.velocity.clamp(-step, step)
            }
            _ => 0,
        };
    }
}

/// The simulated drives' quick-stop deceleration, m/s² (twice the lab limit).
pub const QUICK_STOP_DECELERATION: f64 = 6.0;
/// The same per 10 ms cycle, in drive units.
const QUICK_STOP_DECELERATION_UNITS_PER_CYCLE: i32 = 60_000;

/// The bus: two drives, a scenario, and what is waiting to be received.
#[derive(Debug, Clone)]
pub struct VirtualBus {
    drives: [DriveSim; 2],
    scenario: Scenario,
    next_event: usize,
    inbox: Deque<CanFrame, 32>,
    injected: Deque<CanFrame, 32>,
    traffic: Option<Traffic>,
    solver_failure: bool,
    hang: bool,
    hangs: bool,
    bus_off_cycles: u8,
    noise: u32,
}

/// A frame the virtual bus refused (bus-off).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BusOff;

impl VirtualBus {
    /// Two freshly booted drives and the scenario.
    #[must_use]
    pub fn new(scenario: Scenario) -> Self {
        Self {
            drives: [DriveSim::new(Drive::Trolley), DriveSim::new(Drive::Winch)],
            scenario,
            next_event: 0,
            inbox: Deque::new(),
            injected: Deque::new(),
            traffic: scenario.random.map(Traffic::new),
            solver_failure: false,
            hang: false,
            hangs: true,
            bus_off_cycles: 0,
            noise: 0x9E37_79B9,
        }
    }

    /// The scenario.
    #[must_use]
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// A simulated drive.
    #[must_use]
    pub fn drive(&self, drive: Drive) -> &DriveSim {
        drive.of(&self.drives)
    }

    fn drive_mut(&mut self, drive: Drive) -> &mut DriveSim {
        drive.of_mut(&mut self.drives)
    }

    /// The same bus after the watchdog restarted the firmware: the scenario's hang is
    /// not repeated.
    #[must_use]
    pub fn without_hangs(mut self) -> Self {
        self.hangs = false;
        self
    }

    /// Whether the scenario makes the firmware hang now (asked once).
    pub fn take_hang(&mut self) -> bool {
        core::mem::take(&mut self.hang)
    }

    /// Whether the scenario asked for the next solver step to fail (asked once).
    pub fn take_solver_failure(&mut self) -> bool {
        core::mem::take(&mut self.solver_failure)
    }

    fn deliver(&mut self, frame: CanFrame) {
        // 32 frames per cycle are far more than any scenario sends; a loss would show as a
        // missing frame in the QEMU/host comparison.
        let _ = self.inbox.push_back(frame);
    }

    /// The controller transmits `frame`: the drives react (and answer a SYNC). While the
    /// bus is off nothing is delivered; the SYNC, always a cycle's last frame but for
    /// the heartbeat and status, counts the bus-off cycles down.
    pub fn transmit(&mut self, frame: &CanFrame) -> Result<(), BusOff> {
        let id = frame.id();
        if self.bus_off_cycles > 0 {
            if id == cob::SYNC {
                self.bus_off_cycles -= 1;
            }
            return Err(BusOff);
        }
        for drive in Drive::ALL {
            if id == cob::RPDO1 + u16::from(drive.node()) {
                if let [c0, c1, v0, v1, v2, v3] = *frame.data() {
                    self.drive_mut(drive).command(
                        u16::from_le_bytes([c0, c1]),
                        i32::from_le_bytes([v0, v1, v2, v3]),
                    );
                }
            }
        }
        if id == cob::SYNC {
            for drive in Drive::ALL {
                let d = *self.drive(drive);
                if !d.silent {
                    self.deliver(canopen::tpdo1(drive, d.statusword(), d.velocity));
                }
            }
        }
        Ok(())
    }

    /// Everything that appears on the bus in `(after_ms, up_to_ms]`: the scenario's
    /// events and the drives' heartbeats, then the TPDOs answering the last SYNC.
    pub fn receive_until(
        &mut self,
        after_ms: u32,
        up_to_ms: u32,
    ) -> impl Iterator<Item = CanFrame> + '_ {
        let mut fresh: Deque<CanFrame, 32> = Deque::new();
        while let Some(e) = self.scenario.events.get(self.next_event).copied() {
            if e.at_ms > up_to_ms {
                break;
            }
            self.next_event += 1;
            self.apply(e.action, &mut fresh);
        }
        while let Some(f) = self.injected.pop_front() {
            let _ = fresh.push_back(f);
        }
        if let Some(mut traffic) = self.traffic.take() {
            traffic.cycle(up_to_ms, |a| self.apply(a, &mut fresh));
            self.traffic = Some(traffic);
        }
        // Heartbeats every 100 ms from 5 ms on.
        let beats = |t: u32| if t < 5 { 0 } else { (t - 5) / 100 + 1 };
        let due = beats(up_to_ms).saturating_sub(beats(after_ms));
        for _ in 0..due.min(1) {
            for drive in Drive::ALL {
                if !self.drive(drive).silent {
                    let _ =
                        fresh.push_back(canopen::heartbeat(drive.node(), NmtState::Operational));
                }
            }
        }
        while let Some(f) = self.inbox.pop_front() {
            let _ = fresh.push_back(f);
        }
        core::iter::from_fn(move || fresh.pop_front())
    }

    /// Makes `action` happen now (tests and the soak run); frames it puts on the bus
    /// are received in the next cycle, after the scenario's.
    pub fn inject(&mut self, action: Action) {
        let mut frames = Deque::new();
        self.apply(action, &mut frames);
        while let Some(f) = frames.pop_front() {
            let _ = self.injected.push_back(f);
        }
    }

    fn apply(&mut self, action: Action, fresh: &mut Deque<CanFrame, 32>) {
        match action {
            Action::Request(r) => {
                let _ = fresh.push_back(request_frame(&r));
            }
            Action::Frame(raw) => {
                let _ = fresh.push_back(raw.frame());
            }
            Action::Storm { count } => {
                for _ in 0..count {
                    let f = self.garbage();
                    let _ = fresh.push_back(f);
                }
            }
            Action::DriveFault(drive) => {
                self.drive_mut(drive).state = DriveState::Fault;
                let _ = fresh.push_back(canopen::emcy(drive.node(), 0x2310, 0x03, [0; 5]));
            }
            Action::Silence(drive) => self.drive_mut(drive).silent = true,
            Action::DropOut(drive) => self.drive_mut(drive).state = DriveState::SwitchOnDisabled,
            Action::Revive(drive) => self.drive_mut(drive).silent = false,
            Action::SolverFailure => self.solver_failure = true,
            Action::Hang => self.hang = self.hangs,
            Action::BusOff { cycles } => self.bus_off_cycles = cycles,
        }
    }

    /// A pseudo-random frame: unknown ids, wrong lengths, malformed commands, foreign TPDOs.
    fn garbage(&mut self) -> CanFrame {
        self.noise ^= self.noise << 13;
        self.noise ^= self.noise >> 17;
        self.noise ^= self.noise << 5;
        let n = self.noise;
        let bytes = n.to_le_bytes();
        let kind = n % 5;
        let data = [
            bytes[0], bytes[1], bytes[2], bytes[3], bytes[1], bytes[0], bytes[3], bytes[2],
        ];
        let len = ((n >> 8) % 9) as usize;
        let id = match kind {
            0 => 0x210,                                 // a command, mostly malformed
            1 => (0x181 + (n >> 12) % 2) as u16,        // a drive TPDO of a wrong length
            2 => 0x555,                                 // unknown
            3 => (0x700 + 0x40 + (n >> 12) % 8) as u16, // a foreign node's heartbeat
            _ => 0x7FF,                                 // unknown
        };
        let len = if kind == 0 && len == 8 {
            7
        } else if kind == 1 && len == 6 {
            5
        } else {
            len
        };
        CanFrame::fixed(id, data.get(..len).unwrap_or(&[]))
    }
}

/// One cycle of the firmware's loop on the virtual bus — what `firmware/src/main.rs`
/// does with the QEMU board, but for counting instructions: the frames that appeared
/// since `after_ms`, the scenario's hang or solver failure if one is due, the tick,
/// and the transmission (a refused frame is reported to the controller). `None`: the
/// firmware hangs here, and its watchdog takes over.
pub fn run_cycle<F: Feedforward + Replan>(
    controller: &mut Controller<Injectable<F>>,
    bus: &mut VirtualBus,
    after_ms: u32,
    now_ms: u32,
) -> Option<Cycle> {
    for frame in bus.receive_until(after_ms, now_ms) {
        controller.on_frame(&frame, u64::from(now_ms));
    }
    if bus.take_hang() {
        return None;
    }
    if bus.take_solver_failure() {
        controller.feedforward_mut().fail_next_step();
    }
    let out = controller.tick(u64::from(now_ms));
    for frame in &out.frames {
        if bus.transmit(frame).is_err() {
            controller.transmit_failed(frame);
        }
    }
    Some(out)
}

const fn move_to(id: u8, x: f64, z: f64, duration: f64) -> Action {
    Action::Request(Request::Move {
        id,
        target: [x, z],
        duration: if duration > 0.0 { Some(duration) } else { None },
    })
}

const fn at(at_ms: u32, action: Action) -> Event {
    Event { at_ms, action }
}

/// The paper's move and nothing else: healthy drives.
pub const HEALTHY: Scenario = Scenario {
    name: "healthy",
    expect: "ready, at rest at (20, 4)",
    events: &[],
    cycles: 0,
    random: None,
    ends: Ending::Ready,
};

/// Two moves requested back to back after the paper's move: the first starts at once,
/// the second (as fast as the limits allow) is queued behind it.
pub const TWO_MOVES: Scenario = Scenario {
    name: "two-moves",
    expect: "ready, at rest at (15, 6); answers: 1 accepted, 2 queued",
    events: &[
        at(9_500, move_to(1, 16.0, 5.0, 6.0)),
        at(9_600, move_to(2, 15.0, 6.0, 0.0)),
    ],
    cycles: 2_000,
    random: None,
    ends: Ending::Ready,
};

/// Every rejection reason once: a move before the drives are enabled (not ready), one
/// queued behind the paper's move and one more (busy), then, from (18, 5), one request
/// per remaining reason and a valid move as fast as the limits allow.
pub const REJECTIONS: Scenario = Scenario {
    name: "rejections",
    expect: "ready, at rest at (16, 6); reasons 2, 1, 3, 4, 5, 6, 7, 8, 9, 10 given once each",
    events: &[
        at(0, move_to(1, 14.0, 6.0, 4.0)), // 2 not ready: the drives are being enabled
        at(500, move_to(2, 18.0, 5.0, 4.0)), // queued behind the paper's move: 9 s to 13 s
        at(600, move_to(3, 14.0, 6.0, 4.0)), // 1 busy: a move is already queued
        at(13_100, move_to(4, 0.0, 5.0, 8.0)), // 3 invalid: x = 0
        at(13_200, move_to(5, 24.0, 5.0, 8.0)), // 4 trolley workspace
        at(13_300, move_to(6, 18.0, 10.0, 8.0)), // 5 rope workspace
        at(13_400, move_to(7, 18.0, 6.5, 1.0)), // 6 slack rope
        at(13_500, move_to(8, 17.0, 5.0, 1.5)), // 7 trolley velocity
        at(13_600, move_to(9, 18.0, 7.0, 2.5)), // 8 winch velocity
        at(13_700, move_to(10, 18.5, 5.0, 2.5)), // 9 trolley acceleration
        at(13_800, move_to(11, 18.0, 5.4, 1.0)), // 10 winch acceleration
        at(13_900, move_to(12, 16.0, 6.0, 0.0)), // accepted, as fast as the limits allow
    ],
    cycles: 1_900,
    random: None,
    ends: Ending::Ready,
};

/// A storm of malformed and unknown frames during the move: ignored, counted, no effect.
pub const STORM: Scenario = Scenario {
    name: "storm",
    expect: "ready, at rest at (20, 4); 100 frames ignored, set points as in healthy",
    events: &[
        at(2_000, Action::Storm { count: 20 }),
        at(3_000, Action::Storm { count: 20 }),
        at(4_000, Action::Storm { count: 20 }),
        at(5_000, Action::Storm { count: 20 }),
        at(6_000, Action::Storm { count: 20 }),
    ],
    cycles: 0,
    random: None,
    ends: Ending::Ready,
};

/// The winch drive faults in the middle of the move: quick stop, halted; then a reset.
pub const DRIVE_FAULT: Scenario = Scenario {
    name: "drive-fault",
    expect: "ready, at rest; the winch's fault at 5 s: quick stop, halted, reset at 8 s",
    events: &[
        at(5_000, Action::DriveFault(Drive::Winch)),
        at(8_000, Action::Request(Request::Reset { id: 1 })),
    ],
    cycles: 1_000,
    random: None,
    ends: Ending::Ready,
};

/// The inverse model fails in the middle of the move: controlled stop, halted.
pub const NEWTON_FAILURE: Scenario = Scenario {
    name: "newton-failure",
    expect: "halted after the solver's failure at 5 s and a controlled stop",
    events: &[at(5_000, Action::SolverFailure)],
    cycles: 0,
    random: None,
    ends: Ending::Halted,
};

/// The trolley drive falls silent in the middle of the move: quick stop, halted.
pub const LOST_HEARTBEAT: Scenario = Scenario {
    name: "lost-heartbeat",
    expect: "halted after the trolley's heartbeat stopped at 4 s",
    events: &[at(4_000, Action::Silence(Drive::Trolley))],
    cycles: 0,
    random: None,
    ends: Ending::Halted,
};

/// A stop request in the middle of the move: the load comes to rest smoothly, a
/// second before the move would have ended.
pub const STOP: Scenario = Scenario {
    name: "stop",
    expect: "ready, at rest short of (20, 4) after a smooth stop from 4 s to 8 s",
    events: &[at(4_000, Action::Request(Request::Stop { id: 1 }))],
    cycles: 0,
    random: None,
    ends: Ending::Ready,
};

/// The bus goes off twice in the middle of the move: for 2 cycles (counted, the move
/// goes on), then for 5 (the set points cannot be delivered: halted).
pub const BUS_OFF: Scenario = Scenario {
    name: "bus-off",
    expect: "halted after the second bus-off at 6 s; 2 + 3 cycles of failed transmissions",
    events: &[
        at(3_000, Action::BusOff { cycles: 2 }),
        at(6_000, Action::BusOff { cycles: 5 }),
    ],
    cycles: 0,
    random: None,
    ends: Ending::Halted,
};

/// The firmware hangs in the middle of the move: the watchdog restarts it, it boots
/// halted (reset cause logged, EMCY 0x6010) and a supervisor's reset enables it again.
pub const HANG: Scenario = Scenario {
    name: "hang",
    expect:
        "restarted by the watchdog after the hang at 5 s; halted, then ready after the reset at 1 s",
    events: &[
        at(1_000, Action::Request(Request::Reset { id: 1 })),
        at(5_000, Action::Hang),
    ],
    cycles: 800,
    random: None,
    ends: Ending::Ready,
};

/// Every scenario, by name.
pub const SCENARIOS: [Scenario; 10] = [
    HEALTHY,
    TWO_MOVES,
    REJECTIONS,
    STORM,
    DRIVE_FAULT,
    NEWTON_FAILURE,
    LOST_HEARTBEAT,
    STOP,
    BUS_OFF,
    HANG,
];

/// The soak run: random valid and invalid requests, garbage and faults after the
/// paper's move, for as many cycles as asked (`cargo xtask soak --minutes M`; one
/// simulated minute by default).
pub const SOAK: Scenario = Scenario {
    name: "soak",
    expect: "every set point finite and within the limits, whatever the traffic",
    events: &[],
    cycles: 6_000,
    random: Some(0x5EED_C0DE),
    ends: Ending::Either,
};

/// The scenario of this name (the checked ones and the soak run).
#[must_use]
pub fn scenario(name: &str) -> Option<Scenario> {
    SCENARIOS.into_iter().chain([SOAK]).find(|s| s.name == name)
}
