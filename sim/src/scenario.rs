//! What a run on the virtual bus is made of: timed actions of a supervisor, of the bus
//! and of the drives (supervisor requests, garbage, a drive fault, a silenced drive, an
//! injected solver failure, a sensor fault), the plant that is not the model, and the
//! named scenarios the QEMU checks, the host tests and the soak run replay.

use controller::canopen::NmtCommand;
use controller::commands::Request;
use controller::controller::Mode;
use controller::drive::Drive;
use controller::frame::CanFrame;
use controller::operator::{Flags, FULL_SCALE};

use crate::plant::{Gust, Mismatch};

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
    /// The drive sends an EMCY warning (error register without the generic bit).
    DriveWarning(Drive),
    /// The drive loses power (silent, forgets everything).
    PowerOff(Drive),
    /// The drive is powered (again): it boots, sends its boot-up message, and waits
    /// pre-operational in its boot configuration.
    PowerOn(Drive),
    /// Someone else (a service tool) sends the drive this NMT command.
    Nmt(Drive, NmtCommand),
    /// The drive behaves unlike a stock one from now on.
    Quirk(Drive, Quirk),
    /// The inverse model's next step fails (the firmware's solver-fault injection).
    SolverFailure,
    /// The firmware hangs: its 100 Hz task stops (the watchdog's case).
    Hang,
    /// The controller's transmissions fail for `cycles` cycles (bus-off, then recovery).
    BusOff {
        /// How long, in cycles.
        cycles: u8,
    },
    /// The inclinometer (scenarios with a plant) fails so.
    Sensor(SensorFault),
    /// Another node transmits this frame: the drives take it as they take the
    /// controller's (a second master's RPDO moves a drive, a second SYNC producer's SYNC
    /// makes them apply their set points and answer), and the controller receives it.
    Foreign(RawFrame),
    /// The operator's master switch (a PLC) sends this from now on: an operator frame
    /// (RPDO3 0x410) every [`STICK_PERIOD_MS`], its alive counter changing every frame.
    /// A switch that was silent sends at once; one that sends keeps its period.
    Stick(Stick),
    /// The master switch falls silent (a cut cable, a PLC stopped): the dead-man's case.
    StickSilent,
}

/// What the operator's master switch sends: the flags and the demands along x, y and z
/// (`controller::operator::OperatorFrame`; the alive counter is the bus's).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stick {
    /// Enable (the dead-man switch held), manual mode requested, micro-speed.
    pub flags: Flags,
    /// x, y, z in 1/[`FULL_SCALE`] of each axis's manual speed; z > 0 lowers the load.
    pub demand: [i16; 3],
}

/// The master switch's frame period, ms: a PLC's cyclic 30 ms task, a third of the
/// dead-man's 90 ms deadline (`controller::operator::DEADLINE_MS`).
pub const STICK_PERIOD_MS: u32 = 30;

/// What can go wrong with it (the inclinometer) in a scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorFault {
    /// It falls silent (cable cut): no heartbeat, no TPDO.
    Lost,
    /// Its value freezes at the last one (a stuck pendulum), while it goes on talking.
    Stuck,
    /// It reads this many hundredths of a degree more than the angle (a mount knocked
    /// askew, a zero never commissioned): from power-up when the event is at 0 ms.
    Offset(i16),
    /// Repaired: it talks and measures again.
    Back,
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
    /// The crane the drives move: `None`, ideal drives that integrate their set points;
    /// `Some`, the paper's lab crane (Tab. 3) as a plant that is not the model, with
    /// this mismatch, and an inclinometer on the hook block (node 3).
    pub plant: Option<Mismatch>,
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

/// A way a simulated drive differs from a well-behaved stock drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quirk {
    /// It has no cyclic synchronous velocity mode: writing 0x6060 = 9 is aborted
    /// (0x0609_0030).
    RefusesCsv,
    /// Its mode display 0x6061 shows this whatever 0x6060 says.
    ReportsMode(i8),
    /// Its TPDO statusword is this many SYNCs old.
    StatusLag(u8),
    /// It never answers SDO requests.
    SdoMute,
    /// Its velocity actual reads this, whatever it does (a coasting axis, a bad encoder).
    ReportsVelocity(i32),
    /// Its axis moves this much faster than the drive drives it, drive units (µm/s), in
    /// every state while powered: a slipping brake, a load pulling a weak drive along.
    Creeps(i32),
    /// It stands whatever its set point, while its statusword says it follows (bit 12):
    /// a drive that ignores its set point (a wrong mapping, a local stop input).
    IgnoresSetpoint,
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

/// The scene's move and nothing else: healthy drives.
pub const HEALTHY: Scenario = Scenario {
    name: "healthy",
    expect: "ready, at rest at the move's target",
    events: &[],
    cycles: 0,
    random: None,
    ends: Ending::Ready,
    plant: None,
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
    plant: None,
};

/// Every rejection reason once: a move while the drives are being commissioned (not
/// ready), one queued behind the paper's move and one more (busy), then, from (18, 5), one request
/// per remaining reason and a valid move as fast as the limits allow.
pub const REJECTIONS: Scenario = Scenario {
    name: "rejections",
    expect: "ready, at rest at (16, 6); reasons 2, 1, 3, 4, 5, 6, 7, 8, 9, 10 given once each",
    events: &[
        at(0, move_to(1, 14.0, 6.0, 4.0)), // 2 not ready: the drives are being enabled
        at(800, move_to(2, 18.0, 5.0, 4.0)), // queued behind the paper's move: 9 s to 13 s
        at(900, move_to(3, 14.0, 6.0, 4.0)), // 1 busy: a move is already queued
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
    plant: None,
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
    plant: None,
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
    plant: None,
};

/// The 3D crane's bridge drive faults in the middle of the move: quick stop, halted;
/// then a reset.
pub const BRIDGE_FAULT: Scenario = Scenario {
    name: "bridge-fault",
    expect: "ready, at rest; the bridge's fault at 5 s: quick stop, halted, reset at 8 s",
    events: &[
        at(5_000, Action::DriveFault(Drive::Bridge)),
        at(8_000, Action::Request(Request::Reset { id: 1 })),
    ],
    cycles: 1_000,
    random: None,
    ends: Ending::Ready,
    plant: None,
};

/// The inverse model fails in the middle of the move: controlled stop, halted.
pub const NEWTON_FAILURE: Scenario = Scenario {
    name: "newton-failure",
    expect: "halted after the solver's failure at 5 s and a controlled stop",
    events: &[at(5_000, Action::SolverFailure)],
    cycles: 0,
    random: None,
    ends: Ending::Halted,
    plant: None,
};

/// The trolley drive falls silent in the middle of the move: quick stop, halted.
pub const LOST_HEARTBEAT: Scenario = Scenario {
    name: "lost-heartbeat",
    expect: "halted after the trolley's heartbeat stopped at 4 s",
    events: &[at(4_000, Action::Silence(Drive::Trolley))],
    cycles: 0,
    random: None,
    ends: Ending::Halted,
    plant: None,
};

/// A stop request in the middle of the move: the load comes to rest smoothly, a
/// second before the move would have ended.
pub const STOP: Scenario = Scenario {
    name: "stop",
    expect: "ready, at rest on the path short of the target after a smooth stop from 4 s to 8 s",
    events: &[at(4_000, Action::Request(Request::Stop { id: 1 }))],
    cycles: 0,
    random: None,
    ends: Ending::Ready,
    plant: None,
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
    plant: None,
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
    plant: None,
};

/// The trolley's axis creeps at 20 mm/s from 10 s, a second after the paper's move has
/// ended (a slipping brake, a drive that does not hold): the controller commands zero,
/// the trolley leaves its 20 mm standstill window (fault 20), quick stop, halted.
pub const CREEP: Scenario = Scenario {
    name: "creep",
    expect: "halted after the trolley crept out of its standstill window from 10 s (fault 20)",
    events: &[at(
        10_000,
        Action::Quirk(Drive::Trolley, Quirk::Creeps(20_000)),
    )],
    cycles: 1_200,
    random: None,
    ends: Ending::Halted,
    plant: None,
};

/// The master switch held in manual mode with `demand`.
const fn stick(demand: [i16; 3]) -> Action {
    Action::Stick(Stick {
        flags: Flags {
            enable: true,
            manual: true,
            micro: false,
        },
        demand,
    })
}

/// The master switch held, manual mode no longer requested, the stick centred.
const AUTOMATIC: Action = Action::Stick(Stick {
    flags: Flags {
        enable: true,
        manual: false,
        micro: false,
    },
    demand: [0; 3],
});

/// Full stick, and half of it.
const FULL: i16 = FULL_SCALE;
const HALF: i16 = FULL_SCALE / 2;

/// Manual mode on the planar crane after the scene's move (at rest at (20, 4) from 9 s):
/// manual mode requested with the stick centred (entered at rest), full stick back along
/// x for 3 s, released (the load rests within 5.5 s: the rate limiter's 2 s stop and
/// the filters' window, 2.7 s at 4 m); again for 2 s, then reversed to full stick
/// forward while the hoist lowers at half stick, released; the request withdrawn at
/// rest (manual mode left), the switch held until the end.
pub const MANUAL_PROFILE: Scenario = Scenario {
    name: "manual-profile",
    expect:
        "ready (mode 1), manual mode left at rest; every set point 0.0 after each release's stop",
    events: &[
        at(10_000, stick([0, 0, 0])),
        at(10_500, stick([-FULL, 0, 0])),
        at(13_500, stick([0, 0, 0])),
        at(19_000, stick([-FULL, 0, 0])),
        at(21_000, stick([FULL, 0, HALF])),
        at(24_000, stick([0, 0, 0])),
        at(31_000, AUTOMATIC),
    ],
    cycles: 3_300,
    random: None,
    ends: Ending::Ready,
    plant: None,
};

/// [`MANUAL_PROFILE`] on the 3D crane: the first full stick diagonal (bridge and trolley
/// back, a straight load path) with the hoist lowering at half stick — bridge, trolley
/// and hoist start from rest in one cycle —, the hoist reversed to raising at half stick
/// halfway through the diagonal (the hoist moving, both ways, during horizontal travel:
/// every axis moving at once, the generator's costliest case, issue 28's cost target);
/// the reversal along the bridge with the hoist lowering.
pub const MANUAL_PROFILE_3D: Scenario = Scenario {
    name: "manual-profile-3d",
    events: &[
        at(10_000, stick([0, 0, 0])),
        at(10_500, stick([-FULL, -FULL, HALF])),
        at(12_000, stick([-FULL, -FULL, -HALF])),
        at(13_500, stick([0, 0, 0])),
        at(19_000, stick([-FULL, 0, 0])),
        at(21_000, stick([FULL, 0, HALF])),
        at(24_000, stick([0, 0, 0])),
        at(31_000, AUTOMATIC),
    ],
    ..MANUAL_PROFILE
};

/// The master switch falls silent mid-travel (full stick back along x for 2 s): the
/// dead-man's loss 90 ms after the last frame, the sway-free stop, manual mode left at
/// rest.
pub const MANUAL_DEADMAN: Scenario = Scenario {
    name: "manual-deadman",
    expect:
        "ready (mode 1): the dead-man's loss at 12.5 s, a sway-free stop, manual mode left at rest",
    events: &[
        at(10_000, stick([0, 0, 0])),
        at(10_500, stick([-FULL, 0, 0])),
        at(12_500, Action::StickSilent),
    ],
    cycles: 2_000,
    random: None,
    ends: Ending::Ready,
    plant: None,
};

/// The operator takes over the scene's automatic move (1–9 s) at 4 s: manual mode
/// requested with the stick centred at 3 s (two centred frames with the request arm the
/// take-over), half stick forward at 4 s — in the cycle that reads the frame manual mode
/// is entered (EMCY 0xFF22, *move taken over*, detail 0), the move ends with the
/// generator's own stop and the stick's half speed forward adds to it at once; released
/// at 9 s (the sway-free stop), the request withdrawn at rest at 15 s (manual mode
/// left).
pub const MANUAL_TAKEOVER: Scenario = Scenario {
    name: "manual-takeover",
    expect: "ready (mode 1): the move taken over at 4 s (EMCY 0xFF22), manual mode in the \
             same cycle with the stick live, released, left at rest",
    events: &[
        at(3_000, stick([0, 0, 0])),
        at(4_000, stick([HALF, 0, 0])),
        at(9_000, stick([0, 0, 0])),
        at(15_000, AUTOMATIC),
    ],
    cycles: 1_800,
    random: None,
    ends: Ending::Ready,
    plant: None,
};

/// [`MANUAL_TAKEOVER`] on the 3D crane: its scene's automatic move (1–9 s, bridge,
/// trolley and hoist together) taken over halfway, at 5 s, by a diagonal half stick —
/// the bridge on forward, the trolley back against the move — in the cycle that reads
/// the frame (EMCY 0xFF22, detail 0): the move ends with the generator's own stop and
/// the stick's vector adds to it at once; released at 9 s, the request withdrawn at rest
/// at 15 s (manual mode left).
pub const MANUAL_TAKEOVER_3D: Scenario = Scenario {
    name: "manual-takeover-3d",
    expect: "ready (mode 1): the move taken over at 5 s (EMCY 0xFF22, detail 0), manual mode \
             in the same cycle with the diagonal stick live, released, left at rest",
    events: &[
        at(3_000, stick([0, 0, 0])),
        at(5_000, stick([HALF, -HALF, 0])),
        at(9_000, stick([0, 0, 0])),
        at(15_000, AUTOMATIC),
    ],
    ..MANUAL_TAKEOVER
};

/// [`MANUAL_TAKEOVER_3D`] with a stop request (0x210) 100 ms after the take-over, while
/// the move's own stop (the hand-over's) still runs: the operator's stop is latched and
/// the hand-over's stop is planned again from where it is, shorter, within the same room
/// (`Generator::stop_within`); the stick, still deflected, moves nothing until centred;
/// released at 9 s, the request withdrawn at rest at 15 s (manual mode left). The only
/// QEMU run whose cycles include a re-planned hand-over's stop (its cost: `cargo xtask
/// decode` of the run's log; the baseline holds the run's largest step, the take-over's).
pub const MANUAL_TAKEOVER_STOP_3D: Scenario = Scenario {
    name: "manual-takeover-stop-3d",
    expect: "ready (mode 1): the move taken over at 5 s (EMCY 0xFF22, detail 0), stopped at \
             5.1 s (the hand-over's stop shortened), released, left at rest",
    events: &[
        at(3_000, stick([0, 0, 0])),
        at(5_000, stick([HALF, -HALF, 0])),
        at(5_100, Action::Request(Request::Stop { id: 1 })),
        at(9_000, stick([0, 0, 0])),
        at(15_000, AUTOMATIC),
    ],
    ..MANUAL_TAKEOVER
};

/// A hand-over refused: after the scene's move (at rest at (20, 4) from 9 s) a move back
/// and down to (15, 5) as fast as the limits allow (from 9.55 s; its trolley's set point
/// rising at up to 2.47 m/s² before 10.3 s, more than the 2.1 m/s² its drive leaves a
/// hand-over's stop beside the operator's manual acceleration, 0.95 · 3 − 1.5 · 0.5:
/// `controller::operator::path::room`; `cargo test -p host-tests --test manual_scenes
/// refused -- --nocapture` prints it); manual mode requested with
/// the stick centred at 10 s (the take-over armed), half stick forward at 10.3 s — no
/// stop of the generator's fits, so the move ends with the planner's on-path stop (EMCY
/// 0xFF22, detail 1: the stop a request on 0x210 would have started in that cycle), the
/// load rests on the move's path short of its target, and manual mode is entered at that
/// rest with the stick live (no re-centring): the load goes forward at half stick;
/// released at 17 s, the request withdrawn at rest at 23 s (manual mode left).
pub const MANUAL_HANDOVER_REFUSED: Scenario = Scenario {
    name: "manual-handover-refused",
    expect: "ready (mode 1): the hand-over refused at 10.3 s (EMCY 0xFF22, detail 1), the move \
             ended with its on-path stop, manual mode at its rest with the stick live, \
             released, left at rest",
    events: &[
        at(9_500, move_to(2, 15.0, 5.0, 0.0)),
        at(10_000, stick([0, 0, 0])),
        at(10_300, stick([HALF, 0, 0])),
        at(17_000, stick([0, 0, 0])),
        at(23_000, AUTOMATIC),
    ],
    cycles: 2_500,
    random: None,
    ends: Ending::Ready,
    plant: None,
};

/// The scenarios of the planar crane's scene with manual mode
/// (`scenes/paper-crane-manual.toml`).
pub const MANUAL_SCENARIOS: [Scenario; 4] = [
    MANUAL_PROFILE,
    MANUAL_DEADMAN,
    MANUAL_TAKEOVER,
    MANUAL_HANDOVER_REFUSED,
];

/// The scenarios of the 3D crane's scene with manual mode
/// (`scenes/crane3d/crane3d-manual.toml`).
pub const MANUAL_3D_SCENARIOS: [Scenario; 4] = [
    MANUAL_PROFILE_3D,
    MANUAL_DEADMAN,
    MANUAL_TAKEOVER_3D,
    MANUAL_TAKEOVER_STOP_3D,
];

/// Every scenario, by name.
pub const SCENARIOS: [Scenario; 11] = [
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
    CREEP,
];

/// The lab crane as a plant that is not the model, for the state feedback's scenarios:
/// the trolley's drive 30 % slower than τ1, the winch's 30 % faster than τ2, the rope
/// 1.5 % longer than the drum says and 80 mm more (the hook block), 2 mm/s Coulomb and 2 % viscous droop on both axes,
/// the study's sensors (docs/RESULTS.md); no gust.
pub const MISMATCHED: Mismatch = Mismatch {
    tau1: 0.3,
    tau2: -0.3,
    rope_offset: 0.08,
    drum_scale: 0.015,
    coulomb: [0.002, 0.002],
    viscous: [0.02, 0.02],
    gust: Gust::NONE,
    position_noise: Mismatch::SENSORS.0,
    angle_noise: Mismatch::SENSORS.1,
    noise_seed: 7,
    swing0: 0.0,
    ..Mismatch::NONE
};

/// The scene's move on [`MISMATCHED`] with an 8 N gust for 1.5 s in the middle of it.
pub const CLOSED_LOOP: Scenario = Scenario {
    name: "closed-loop",
    expect: "ready; the load within ±50 mm of the target and swinging < 0.1° from 14 s",
    events: &[],
    cycles: 0,
    random: None,
    ends: Ending::Ready,
    plant: Some(Mismatch {
        gust: Gust {
            start: 4.0,
            duration: 1.5,
            amplitude: 8.0,
        },
        ..MISMATCHED
    }),
};

/// The scene's move on [`MISMATCHED`], then a 10 N gust for 1 s on the load at rest.
pub const GUST: Scenario = Scenario {
    name: "gust",
    expect: "ready; the swing the gust excites at rest damped by the feedback",
    events: &[],
    cycles: 0,
    random: None,
    ends: Ending::Ready,
    plant: Some(Mismatch {
        gust: Gust {
            start: 10.5,
            duration: 1.0,
            amplitude: 10.0,
        },
        ..MISMATCHED
    }),
};

/// [`CLOSED_LOOP`] with the inclinometer falling silent at 5 s.
pub const INCLINOMETER_LOST: Scenario = Scenario {
    name: "inclinometer-lost",
    expect: "ready; the angle lost at 5 s (EMCY 0xFF20, reason 1), the swing then estimated from the drives' positions, no fault",
    events: &[at(5_000, Action::Sensor(SensorFault::Lost))],
    ..CLOSED_LOOP
};

/// [`CLOSED_LOOP`] with the inclinometer's value frozen from 3 s.
pub const INCLINOMETER_STUCK: Scenario = Scenario {
    name: "inclinometer-stuck",
    expect: "ready; the frozen angle caught (EMCY 0xFF20, reason 4 stuck), the swing then estimated from the drives' positions, no fault",
    events: &[at(3_000, Action::Sensor(SensorFault::Stuck))],
    ..CLOSED_LOOP
};

/// The scenarios of a scene with the state feedback (`scenes/paper-crane-feedback.toml`).
pub const FEEDBACK_SCENARIOS: [Scenario; 4] =
    [CLOSED_LOOP, GUST, INCLINOMETER_LOST, INCLINOMETER_STUCK];

/// The scenarios of the 3D crane's scene with the state feedback
/// (`scenes/crane3d/crane3d-feedback.toml`): the planar ones' plants, their gust and
/// swinging start blowing at 45° so that both vertical planes swing
/// (the 3D crane's `Simulated`, in `scene::cranes::spatial`).
pub const CRANE3D_FEEDBACK_SCENARIOS: [Scenario; 3] = [CLOSED_LOOP, GUST, INCLINOMETER_LOST];

/// The scenarios the 3D crane's scene is checked on besides its own move (healthy): a
/// stop, the bridge drive's fault, a drive's lost heartbeat (the trolley's, which the
/// 3D crane has too).
pub const CRANE3D_SCENARIOS: [Scenario; 3] = [STOP, BRIDGE_FAULT, LOST_HEARTBEAT];

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
    plant: None,
};

/// The scenario of this name (the checked ones and the soak run).
#[must_use]
pub fn scenario(name: &str) -> Option<Scenario> {
    SCENARIOS
        .into_iter()
        .chain(FEEDBACK_SCENARIOS)
        .chain(CRANE3D_SCENARIOS)
        .chain(MANUAL_SCENARIOS)
        .chain(MANUAL_3D_SCENARIOS)
        .chain([SOAK])
        .find(|s| s.name == name)
}
