//! The state feedback in the controller (Fig. 1), through the CAN frames, on the
//! virtual bus's plant that is not the model: drive lags 30 % slower, friction droop,
//! a rope 1 % longer than the drum says, a wind gust during the move, noisy quantised
//! sensors, all one cycle late — and the inclinometer (CiA 410, node 3) commissioned
//! over SDO, lost or stuck.
//!
//! The same scenario runs with feedforward only (the paper's controller) and with the
//! feedback, so that every claim is a comparison on identical disturbances.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

mod common;

use common::{feedforward, planner, Ff, HOME};
use controller::canopen::NmtState;
use controller::commands::{Answer, Request};
use controller::commissioning::{InclinometerSetup, NodeSetup};
use controller::drive::Drive;
use controller::feedback::{self, Correction, NoFeedback, StateFeedback};
use controller::setpoint::DriveLimits;
use controller::{Config, Controller, Cycle, Mode};
use scene::cranes::planar::Planar;
use sim::plant::{Gust, Mismatch};
use sim::{run_cycle, Action, Ending, Event, Scenario, SensorFault, VirtualBus};

/// The paper's move, asked at 1 s: (12, 8) → (20, 4) in 8 s.
const MOVE: Event = Event {
    at_ms: 1_000,
    action: Action::Request(Request::Move {
        id: 1,
        target: [20.0, 4.0],
        duration: Some(8.0),
    }),
};
/// The move ends at 9 s; 5 s later the load must be within ±50 mm and swing < 0.1°.
const MOVE_END_S: f64 = 9.0;
/// The demonstration's move (`run_from`'s, as the firmware scenes'): accepted at boot,
/// from 1.0 s.
const DEMONSTRATION_START_S: f64 = 1.0;

/// Everything the plant does differently from the model.
const MISMATCH: Mismatch = Mismatch {
    tau1: 0.3,
    tau2: -0.3,
    rope_offset: 0.08,
    drum_scale: 0.015,
    coulomb: [0.002, 0.002],
    viscous: [0.02, 0.02],
    gust: Gust {
        start: 4.0,
        duration: 1.5,
        amplitude: 8.0,
    },
    position_noise: Mismatch::SENSORS.0,
    angle_noise: Mismatch::SENSORS.1,
    noise_seed: 7,
    swing0: 0.0,
    ..Mismatch::NONE
};

const fn scenario(name: &'static str, events: &'static [Event]) -> Scenario {
    Scenario {
        name,
        expect: "",
        events,
        cycles: 0,
        random: None,
        ends: Ending::Ready,
        plant: Some(MISMATCH),
    }
}

const HEALTHY: Scenario = scenario("closed-loop", &[MOVE]);

fn config() -> Config {
    Config::DEFAULT.with_node(NodeSetup::Inclinometer(InclinometerSetup::STOCK))
}

fn feedback() -> StateFeedback {
    StateFeedback::new(feedback::Config::PAPER).unwrap()
}

/// What a run shows: every cycle's output, and the plant sampled after each cycle
/// (time s, load `[x_C, z_C]`, swing angle rad).
struct Run {
    cycles: Vec<Cycle>,
    load: Vec<(f64, [f64; 2], f64)>,
    /// The plant's trolley position after each cycle (time s, m).
    trolley: Vec<(f64, f64)>,
    bus: VirtualBus<Planar, 2>,
}

impl Run {
    /// The largest horizontal distance from the target and swing (°) over one swing
    /// period starting 5 s after the move ends.
    fn settled(&self) -> (f64, f64) {
        let from = MOVE_END_S + 5.0;
        let period = 2.0 * std::f64::consts::PI * (4.08_f64 / 9.81).sqrt();
        self.load
            .iter()
            .filter(|(t, ..)| *t >= from && *t <= from + period)
            .fold((0.0_f64, 0.0_f64), |(d, s), (_, p, phi)| {
                (d.max((p[0] - 20.0).abs()), s.max(phi.abs().to_degrees()))
            })
    }

    /// The cycle whose frames carry the first EMCY 0xFF20 (feedback off).
    fn feedback_off_at(&self) -> usize {
        self.cycles
            .iter()
            .position(|c| {
                c.frames
                    .iter()
                    .any(|f| f.id() == 0x090 && f.data()[..2] == [0x20, 0xFF])
            })
            .unwrap()
    }

    fn emcys(&self, code: u16) -> Vec<[u8; 8]> {
        common::emcy_frames(&self.cycles, Some(code))
    }
}

fn run<C: Correction>(correction: C, scenario: Scenario, seconds: f64) -> Run {
    run_from(correction, scenario, seconds, false)
}

/// With `demonstration`, the paper's move is planned at boot, as the QEMU firmware
/// does with the scene's move, and counts as the main job's command.
fn run_from<C: Correction>(
    correction: C,
    scenario: Scenario,
    seconds: f64,
    demonstration: bool,
) -> Run {
    let first = demonstration.then_some(([20.0, 4.0], DEMONSTRATION_START_S, 8.0));
    let ff: Ff = feedforward(HOME, first);
    let mut c = Controller::with_correction(ff, correction, planner(), config());
    if demonstration {
        c.demonstration_commanded();
    }
    let mut bus = VirtualBus::new(scenario, HOME);
    let mut now = 0;
    let mut out = Run {
        cycles: Vec::new(),
        load: Vec::new(),
        trolley: Vec::new(),
        bus: bus.clone(),
    };
    while f64::from(now) < seconds * 1000.0 {
        let cycle = run_cycle(&mut c, &mut bus, now).expect("no hang");
        let plant = bus.plant().unwrap();
        out.load.push((plant.t, plant.load(), plant.y[2]));
        out.trolley.push((plant.t, plant.y[0]));
        out.cycles.push(cycle);
        now += 10;
    }
    out.bus = bus;
    out
}

/// The demonstration's move is accepted at boot and starts at 1.0 s: the feedback
/// observes until then, every set point exactly 0.0 with the drives enabled and the
/// inclinometer read (up to 3f6faa8 the trolley acted on the young estimate's noise, up
/// to 0.063 m/s).
fn assert_still_before_the_move(run: &Run) {
    let start = (DEMONSTRATION_START_S * 100.0) as usize;
    let before = &run.cycles[..start];
    let ready = before.iter().filter(|c| c.mode == Mode::Ready).count();
    assert!(ready > 20, "ready {ready} cycles before the move's start");
    for (k, c) in before.iter().enumerate() {
        for s in &c.setpoints {
            assert_eq!(s.units(), 0, "cycle {k}");
        }
    }
    assert!(
        run.cycles[start..start + 10]
            .iter()
            .any(|c| c.setpoints[0].units() != 0),
        "the move starts"
    );
}

/// Finite, within the velocity limit, and no step above the acceleration limit.
fn assert_within_limits(run: &Run) {
    let limits = DriveLimits::LAB;
    let mut last = [0i32; 2];
    for c in &run.cycles {
        for (i, axis) in limits.axes().into_iter().enumerate() {
            let v = c.setpoints[i].units();
            assert!(f64::from(v.abs()) <= axis.max_velocity * 1e6 + 1.0);
            let step = f64::from((v - last[i]).abs());
            assert!(step <= axis.max_acceleration * 0.01 * 1e6 + 1.0, "{step}");
            last[i] = v;
        }
    }
}

#[test]
fn the_inclinometer_is_commissioned_over_sdo_and_started() {
    let r = run(feedback(), HEALTHY, 1.0);
    let sensor = r.bus.inclinometer().unwrap();
    assert_eq!(sensor.nmt(), NmtState::Operational);
    assert_eq!(sensor.object(0x6000, 0), 10, "0.01° resolution");
    assert_eq!(sensor.object(0x1017, 0), 100, "heartbeat");
    assert_eq!(sensor.object(0x1A00, 1), 0x6010_0010, "slope long16 mapped");
    assert_eq!(sensor.object(0x1800, 2), 1, "synchronous");
    assert_eq!(r.cycles.last().unwrap().mode, Mode::Ready);
}

#[test]
fn feedback_brings_the_load_to_rest_at_the_target_where_feedforward_alone_does_not() {
    let open = run(NoFeedback, HEALTHY, 16.0);
    let closed = run(feedback(), HEALTHY, 16.0);
    let (d_open, s_open) = open.settled();
    let (d_closed, s_closed) = closed.settled();
    eprintln!(
        "5 s after the move: feedforward only {:.1} mm, {:.3}°; with feedback {:.1} mm, {:.3}°",
        d_open * 1e3,
        s_open,
        d_closed * 1e3,
        s_closed
    );
    assert!(d_closed < 0.05 && s_closed < 0.1, "the acceptance target");
    assert!(
        s_open > 5.0 * s_closed,
        "feedforward alone leaves the swing"
    );
    assert_within_limits(&closed);
    assert!(closed.emcys(0xFF20).is_empty(), "never fell back");
    // Settled on the target, the feedback lets go: the set points are exactly zero and
    // the drives hold (5 s after the move to the end of the run).
    let settled = &closed.cycles[(MOVE_END_S as usize + 5) * 100..];
    assert!(settled
        .iter()
        .all(|c| c.setpoints.iter().all(|s| s.units() == 0)));
    assert!(closed
        .cycles
        .iter()
        .all(|c| c.mode == Mode::Ready || c.mode == Mode::Enabling));
}

#[test]
fn no_correction_before_the_first_move() {
    // The gust swings the load at rest before anything is asked: the controller holds.
    const AT_REST: Scenario = Scenario {
        plant: Some(Mismatch {
            gust: Gust {
                start: 0.8,
                duration: 1.0,
                amplitude: 10.0,
            },
            ..MISMATCH
        }),
        ..scenario("gust-at-rest", &[])
    };
    let r = run(feedback(), AT_REST, 4.0);
    let swing = r
        .load
        .iter()
        .map(|(_, _, phi)| phi.abs())
        .fold(0.0, f64::max);
    assert!(swing.to_degrees() > 0.5, "the gust swings the load");
    assert!(r
        .cycles
        .iter()
        .all(|c| c.setpoints.iter().all(|s| s.units() == 0)));
}

#[test]
fn a_lost_inclinometer_is_announced_and_the_move_goes_on_on_the_estimated_swing() {
    const LOST: Scenario = scenario(
        "inclinometer-lost",
        &[
            MOVE,
            Event {
                at_ms: 5_000,
                action: Action::Sensor(SensorFault::Lost),
            },
        ],
    );
    let r = run(feedback(), LOST, 11.0);
    let off = r.emcys(0xFF20);
    assert_eq!(off.len(), 1, "announced once");
    assert_eq!(off[0], [0x20, 0xFF, 0x80, 15, 3, 1, 0, 0], "angle lost");
    // Three cycles are bridged by the observer; the fourth without an angle switches.
    let at = r.feedback_off_at();
    assert!((500..=506).contains(&at), "switched at cycle {at}");
    assert_eq!(r.cycles.last().unwrap().mode, Mode::Ready, "no fault");
    assert_within_limits(&r);
}

#[test]
fn a_stuck_inclinometer_is_caught_by_the_crane_s_own_motion_and_the_swing_is_estimated() {
    const STUCK: Scenario = scenario(
        "inclinometer-stuck",
        &[
            MOVE,
            Event {
                at_ms: 3_000,
                action: Action::Sensor(SensorFault::Stuck),
            },
        ],
    );
    let r = run(feedback(), STUCK, 11.0);
    let off = r.emcys(0xFF20);
    assert_eq!(off.len(), 1);
    assert_eq!(off[0][5], 4, "stuck");
    // Caught within a few cycles: the move's acceleration swings the load, so an angle
    // that stays put is contradicted by the observer run on the drives' positions.
    let at = r.feedback_off_at();
    eprintln!("stuck at cycle 300, announced at cycle {at}");
    assert!((300..=320).contains(&at), "switched at cycle {at}");
    assert_eq!(r.cycles.last().unwrap().mode, Mode::Ready);
    assert_within_limits(&r);
}

#[test]
fn after_a_fault_the_model_restarts_where_the_drives_measure_the_crane() {
    // The trolley faults mid-move; with friction and the slower lag, where it stops is
    // not where the model was. The reset restarts the model at position actual.
    const FAULT: Scenario = scenario(
        "fault-mid-move",
        &[
            MOVE,
            Event {
                at_ms: 4_000,
                action: Action::DriveFault(Drive::Trolley),
            },
        ],
    );
    let ff: Ff = feedforward(HOME, None);
    let mut c = Controller::with_correction(ff, feedback(), planner(), config());
    let mut bus = VirtualBus::new(FAULT, HOME);
    let mut now = 0;
    let mut step = |c: &mut Controller<Ff, StateFeedback, Planar, 2>,
                    bus: &mut VirtualBus<Planar, 2>| {
        let out = run_cycle(c, bus, now).unwrap();
        now += 10;
        out
    };
    for _ in 0..1_000 {
        if matches!(c.mode(), Mode::Halted(_)) {
            break;
        }
        step(&mut c, &mut bus);
    }
    assert!(matches!(c.mode(), Mode::Halted(_)));
    for _ in 0..100 {
        step(&mut c, &mut bus);
    }
    bus.inject(Action::Request(Request::Reset { id: 2 }));
    step(&mut c, &mut bus);
    step(&mut c, &mut bus);
    assert_eq!(c.last_answer().0, 2);
    assert_eq!(c.last_answer().2, None, "the reset is accepted");
    let model = c.feedforward().inner.integrator.state();
    let plant = bus.plant().unwrap().y;
    assert!(
        (model[0] - plant[0]).abs() < 1e-3,
        "trolley {} vs {}",
        model[0],
        plant[0]
    );
    assert!(
        (model[1] - plant[1]).abs() < 1e-3,
        "rope {} vs {}",
        model[1],
        plant[1]
    );
    assert!((model[0] - 12.0).abs() > 0.5, "it did move");
}

#[test]
fn the_firmware_scenarios_of_the_feedback_scene() {
    use sim::{CLOSED_LOOP, FEEDBACK_SCENARIOS, GUST, INCLINOMETER_LOST, INCLINOMETER_STUCK};
    assert_eq!(
        FEEDBACK_SCENARIOS.map(|s| s.name),
        [
            "closed-loop",
            "gust",
            "inclinometer-lost",
            "inclinometer-stuck"
        ]
    );
    let closed = run_from(feedback(), CLOSED_LOOP, 16.0, true);
    assert_still_before_the_move(&closed);
    let (d, swing) = closed.settled();
    assert!(d < 0.05 && swing < 0.1, "{d} m, {swing}°");
    assert!(closed.emcys(0xFF20).is_empty());
    assert_within_limits(&closed);

    // The gust at rest (10.5 s): two swing periods after its end the swing is a tenth
    // of what feedforward alone leaves.
    let damped = run_from(feedback(), GUST, 16.0, true);
    assert_still_before_the_move(&damped);
    let open = run_from(NoFeedback, GUST, 16.0, true);
    let late = |r: &Run| {
        r.load
            .iter()
            .filter(|(t, ..)| *t > 15.0)
            .map(|(_, _, phi)| phi.abs())
            .fold(0.0, f64::max)
    };
    eprintln!(
        "gust at rest, swing after 15 s: feedforward only {:.3}°, feedback {:.3}°",
        late(&open).to_degrees(),
        late(&damped).to_degrees()
    );
    assert!(late(&damped) < 0.1 * late(&open));
    assert_within_limits(&damped);

    for (scenario, reason) in [(INCLINOMETER_LOST, 1), (INCLINOMETER_STUCK, 4)] {
        let r = run_from(feedback(), scenario, 16.0, true);
        assert_still_before_the_move(&r);
        let off = r.emcys(0xFF20);
        assert_eq!(off.len(), 1, "{}", scenario.name);
        assert_eq!(off[0][5], reason, "{}", scenario.name);
        assert_eq!(r.cycles.last().unwrap().mode, Mode::Ready);
        assert_within_limits(&r);
    }
}

#[test]
fn a_move_queued_behind_one_not_yet_started_does_not_close_the_loop_early() {
    // The demonstration's move waits for 1.0 s; a request at 0.8 s is queued behind it.
    // Accepted while a move is pending (the crane counted as moving), it must not close
    // the loop the first move's start will close: until then nothing moves.
    const BEHIND: Scenario = scenario(
        "queued-behind-the-demonstration",
        &[Event {
            at_ms: 800,
            action: Action::Request(Request::Move {
                id: 2,
                target: [15.0, 6.0],
                duration: Some(6.0),
            }),
        }],
    );
    let run = run_from(feedback(), BEHIND, 2.0, true);
    let start = (DEMONSTRATION_START_S * 100.0) as usize;
    let answered = run.cycles[..start]
        .iter()
        .filter_map(|c| common::status(&c.frames))
        .any(|s| s[0] == 2 && s[1] == Answer::Queued as u8);
    assert!(
        answered,
        "the request is queued before the first move starts"
    );
    assert_still_before_the_move(&run);
}

#[test]
fn after_falling_back_the_feedback_is_armed_again_by_a_move_accepted_at_rest() {
    use controller::feedback::{Degraded, Mode as FeedbackMode};
    // Lost at 5 s, repaired at 10 s; at 13 s, at rest (the swing estimated from the
    // positions was damped after the move and let go), a move back to (15, 6).
    const AGAIN: Scenario = scenario(
        "inclinometer-back",
        &[
            MOVE,
            Event {
                at_ms: 5_000,
                action: Action::Sensor(SensorFault::Lost),
            },
            Event {
                at_ms: 10_000,
                action: Action::Sensor(SensorFault::Back),
            },
            Event {
                at_ms: 13_000,
                action: Action::Request(Request::Move {
                    id: 2,
                    target: [15.0, 6.0],
                    duration: Some(6.0),
                }),
            },
        ],
    );
    let ff: Ff = feedforward(HOME, None);
    let mut c = Controller::with_correction(ff, feedback(), planner(), config());
    let mut bus = VirtualBus::new(AGAIN, HOME);
    let mut modes = Vec::new();
    for now in (0..14_000).step_by(10) {
        run_cycle(&mut c, &mut bus, now).unwrap();
        modes.push((now, c.feedback_mode()));
    }
    let at = |t: u32| modes.iter().find(|(now, _)| *now == t).unwrap().1;
    assert_eq!(at(4_990), Some(FeedbackMode::Closed));
    assert_eq!(
        at(9_000),
        Some(FeedbackMode::SwingEstimated(Degraded::AngleLost))
    );
    assert_eq!(
        at(12_900),
        Some(FeedbackMode::SwingEstimated(Degraded::AngleLost)),
        "latched while the sensor is back but no move was asked"
    );
    assert_eq!(
        at(13_990),
        Some(FeedbackMode::Closed),
        "armed again by move 2"
    );
    assert_eq!(c.last_answer().0, 2);
}

/// The speed of the trolley and the swing angle the plant had at `t` s.
fn swing_at(r: &Run, t: f64) -> f64 {
    r.load
        .iter()
        .find(|(tp, ..)| *tp >= t)
        .map(|(_, _, phi)| *phi)
        .unwrap()
}

#[test]
fn a_move_commanded_while_the_load_swings_keeps_the_feedback_and_ends_on_target() {
    // A gust swings the load before anything is asked; the move comes at 2.5 s, the
    // load swinging several degrees. The observer starts from the measured angle.
    const SWINGING: Scenario = Scenario {
        plant: Some(Mismatch {
            gust: Gust {
                start: 0.1,
                duration: 1.5,
                amplitude: 30.0,
            },
            ..MISMATCH
        }),
        ..scenario(
            "swinging-start",
            &[Event {
                at_ms: 2_500,
                action: Action::Request(Request::Move {
                    id: 1,
                    target: [20.0, 4.0],
                    duration: Some(6.5),
                }),
            }],
        )
    };
    let closed = run(feedback(), SWINGING, 16.0);
    let open = run(NoFeedback, SWINGING, 16.0);
    let at_command = closed
        .load
        .iter()
        .filter(|(t, ..)| (2.0..=2.5).contains(t))
        .map(|(_, _, phi)| phi.abs())
        .fold(0.0, f64::max);
    assert!(
        at_command.to_degrees() > 2.5,
        "{:.2}°",
        at_command.to_degrees()
    );
    assert!(
        closed.emcys(0xFF20).is_empty(),
        "the feedback stayed armed: {:?}",
        closed.emcys(0xFF20)
    );
    let (d, swing) = closed.settled();
    let (d_open, swing_open) = open.settled();
    eprintln!(
        "swinging start ({:.2}°), 5 s after the move: feedforward only {:.1} mm, {:.3}°; with feedback {:.1} mm, {:.3}°",
        at_command.to_degrees(),
        d_open * 1e3,
        swing_open,
        d * 1e3,
        swing
    );
    assert!(d < 0.05 && swing < 0.1, "{d} m, {swing}°");
    assert_within_limits(&closed);
}

#[test]
fn a_stuck_inclinometer_at_rest_is_caught_and_leaves_the_load_no_worse_than_feedforward() {
    // After the move a gust swings the load at rest (10.5 s); the inclinometer sticks
    // at 12 s, mid-swing, and goes on talking.
    const PLANT: Mismatch = Mismatch {
        gust: Gust {
            start: 10.5,
            duration: 1.0,
            amplitude: 10.0,
        },
        ..MISMATCH
    };
    const STUCK_AT_REST: Scenario = Scenario {
        plant: Some(PLANT),
        ..scenario(
            "stuck-at-rest",
            &[
                MOVE,
                Event {
                    at_ms: 12_000,
                    action: Action::Sensor(SensorFault::Stuck),
                },
            ],
        )
    };
    let r = run(feedback(), STUCK_AT_REST, 20.0);
    let open = run(NoFeedback, STUCK_AT_REST, 20.0);
    assert!(
        swing_at(&r, 12.0).abs().to_degrees() > 0.2,
        "stuck mid-swing"
    );
    let off = r.emcys(0xFF20);
    assert_eq!(off.len(), 1);
    assert_eq!(off[0][5], 4, "stuck");
    let at = r.feedback_off_at();
    eprintln!("stuck at cycle 1200, announced at cycle {at}");
    // Where the load ends: over the last swing period, never further from the target
    // than with feedforward alone.
    let end = |r: &Run| {
        r.load
            .iter()
            .filter(|(t, ..)| *t >= 15.8)
            .map(|(_, p, _)| (p[0] - 20.0).abs())
            .fold(0.0, f64::max)
    };
    // The trolley under the load: x_C − (drum 4 m + the rope's 0.08 m) sin φ.
    let trolley = |r: &Run, t: f64| {
        let (_, p, phi) = r.load.iter().find(|(tp, ..)| *tp >= t).unwrap();
        p[0] - 4.08 * phi.sin()
    };
    eprintln!(
        "stuck at rest, farthest from the target over 15.8-20 s: feedforward only {:.1} mm, with feedback {:.1} mm; trolley moved {:.1} mm after the freeze",
        end(&open) * 1e3,
        end(&r) * 1e3,
        (trolley(&r, 19.9) - trolley(&r, 12.0)).abs() * 1e3
    );
    assert!(end(&r) <= end(&open));
    // The swing it was damping when the reading stuck goes on being damped, estimated
    // from the trolley's motion: the load ends within the target tolerance.
    assert!(end(&r) <= 0.05);
    assert_eq!(r.cycles.last().unwrap().mode, Mode::Ready);
    assert_within_limits(&r);
}

#[test]
fn the_rope_is_learnt_from_the_swing_in_calm_air_and_read_from_0x2004() {
    // The commissioning step (controller::rope): the move in calm air, the load at rest
    // at the start; then 0x2004 read over SDO as a commissioning engineer would.
    const CALM: Scenario = Scenario {
        plant: Some(Mismatch {
            gust: Gust::NONE,
            ..MISMATCH
        }),
        ..scenario("rope-calibration", &[MOVE])
    };
    let ff: Ff = feedforward(HOME, None);
    let mut c = Controller::with_correction(ff, feedback(), planner(), config());
    let mut bus = VirtualBus::new(CALM, HOME);
    let mut now = 0;
    while now < 12_000 {
        run_cycle(&mut c, &mut bus, now).unwrap();
        now += 10;
    }
    let mut read = |sub: u8| -> i64 {
        let req = controller::CanFrame::new(0x610, &[0x40, 0x04, 0x20, sub, 0, 0, 0, 0]).unwrap();
        c.on_frame(&req, u64::from(now));
        let cycle = run_cycle(&mut c, &mut bus, now).unwrap();
        now += 10;
        let answer = cycle.frames.iter().find(|f| f.id() == 0x590).unwrap();
        let d = answer.data();
        // An expedited upload with its size: 4 bytes (0x43) or 1 (0x4F).
        assert!(
            [0x43, 0x4F].contains(&d[0]),
            "an expedited upload: {d:02x?}"
        );
        i64::from(i32::from_le_bytes(d[4..8].try_into().unwrap()))
    };
    let (scale, offset) = (read(1) as f64 * 1e-6, read(2) as f64 * 1e-6);
    let samples = read(3);
    // Scaling and offset learnt (the rope varied). One move is 6 of the 2 s blocks the
    // uncertainty is measured over, fewer than the 10 it is believed from
    // (`controller::rope::MIN_BLOCKS`): 0x2004:5 then says unknown (0xFFFFFFFF, an
    // UNSIGNED32) and the estimate is refused as uncertain (4) — the calibration is the
    // move and back three times (docs/COMMISSIONING.md) — while still close.
    let learnt = read(4);
    let uncertainty = match read(5) as u32 {
        u32::MAX => f64::INFINITY,
        um => f64::from(um) * 1e-6,
    };
    let delay = read(6) as f64 * 1e-6;
    assert!([2, 4].contains(&learnt), "learnt {learnt}");
    assert!(
        uncertainty.is_finite() || learnt == 4,
        "an unknown uncertainty is refused"
    );
    assert!(
        delay.abs() < 0.004,
        "delay beyond the commissioned {delay} s"
    );
    // The plant's rope: 1.5 % longer than the drum says, and 80 mm more.
    let truth = |l: f64| MISMATCH.rope(l);
    let length = |l: f64| (1.0 + scale) * l + offset;
    eprintln!(
        "rope learnt in calm air from {samples} samples (0x2004:4 = {learnt}, uncertainty {:.1} mm, delay {:.1} ms): scale {:+.4} (true {:+.4}), offset {:+.3} m (true {:+.3}); at 4 m off by {:.1} mm, at 8 m by {:.1} mm",
        uncertainty * 1e3,
        delay * 1e3,
        scale,
        MISMATCH.drum_scale,
        offset,
        MISMATCH.rope_offset,
        (length(4.0) - truth(4.0)) * 1e3,
        (length(8.0) - truth(8.0)) * 1e3
    );
    assert!(samples > 500);
    for l in [4.0, 6.0, 8.0] {
        assert!(
            (length(l) - truth(l)).abs() < 0.02 && (length(l) - truth(l)).abs() < uncertainty,
            "at {l} m: learnt {:.3}, true {:.3}",
            length(l),
            truth(l)
        );
    }
}

/// Where the trolley stands (the plant's, not the drive's reading) from `from` s to the
/// end: its farthest from `x`, m.
fn trolley_off(r: &Run, from: f64, x: f64) -> f64 {
    r.trolley
        .iter()
        .filter(|(t, _)| *t >= from)
        .map(|(_, p)| (p - x).abs())
        .fold(0.0, f64::max)
}

#[test]
fn an_inclinometer_offset_from_power_up_moves_no_trolley_and_is_announced_at_rest() {
    // The inclinometer reads 5° more than the angle from power-up (a zero never
    // commissioned). Read as a swing and a displaced load, it drove the trolley about
    // 0.7 l b = 250 mm off the target (review finding 12). The offset is not acted on:
    // the move ends on target as with a true reading, and once the crane rests the
    // offset is announced (EMCY 0xFF20 reason 5) and the angle no longer read.
    const OFFSET: Scenario = scenario(
        "offset-from-power-up",
        &[
            Event {
                at_ms: 0,
                action: Action::Sensor(SensorFault::Offset(500)),
            },
            MOVE,
        ],
    );
    let r = run(feedback(), OFFSET, 20.0);
    let open = run(NoFeedback, OFFSET, 20.0);
    let (d, swing) = r.settled();
    let (d_open, swing_open) = open.settled();
    let off = trolley_off(&r, MOVE_END_S + 5.0, 20.0);
    eprintln!(
        "5° offset from power-up, 5 s after the move: feedforward only {:.1} mm, {:.3}°; with feedback {:.1} mm, {:.3}°, the trolley {:.1} mm off",
        d_open * 1e3,
        swing_open,
        d * 1e3,
        swing,
        off * 1e3
    );
    assert!(d < 0.05 && swing < 0.1, "{d} m, {swing}°");
    assert!(off < 0.05, "the trolley {:.1} mm off", off * 1e3);
    assert!(
        d <= d_open && swing <= swing_open,
        "no worse than feedforward"
    );
    let emcy = r.emcys(0xFF20);
    assert_eq!(emcy, [[0x20, 0xFF, 0x80, 15, 3, 5, 0, 0]], "reason 5, once");
    let at = r.feedback_off_at();
    eprintln!("announced at cycle {at}");
    assert!(
        at > (MOVE_END_S * 100.0) as usize,
        "at rest, after the move"
    );
    assert_eq!(r.cycles.last().unwrap().mode, Mode::Ready, "no fault");
    assert_within_limits(&r);
}

#[test]
fn an_inclinometer_offset_step_at_rest_moves_nothing_and_is_announced() {
    // The crane rests on its target, the feedback let go; at 15 s the reading steps by
    // 1.5° (a knock on the sensor). No pendulum jumps: it is the zero's step, not a
    // swing — read as one, it drove the trolley 50–90 mm off. The set points stay zero
    // and 5 s later the offset is announced.
    const STEP: Scenario = scenario(
        "offset-step-at-rest",
        &[
            MOVE,
            Event {
                at_ms: 15_000,
                action: Action::Sensor(SensorFault::Offset(150)),
            },
        ],
    );
    let r = run(feedback(), STEP, 22.0);
    let still = &r.cycles[1_450..];
    assert!(
        still
            .iter()
            .all(|c| c.setpoints.iter().all(|s| s.units() == 0)),
        "set points zero from 14.5 s on"
    );
    let at_step = r
        .trolley
        .iter()
        .find(|(t, _)| *t >= 15.0)
        .map(|(_, x)| *x)
        .unwrap();
    let moved = trolley_off(&r, 15.0, at_step);
    assert!(moved < 0.002, "the trolley moved {:.1} mm", moved * 1e3);
    let emcy = r.emcys(0xFF20);
    assert_eq!(emcy, [[0x20, 0xFF, 0x80, 15, 3, 5, 0, 0]], "reason 5, once");
    let at = r.feedback_off_at();
    eprintln!("1.5° step at cycle 1500, announced at cycle {at}");
    assert!((2_000..2_020).contains(&at), "announced at cycle {at}");
    assert_eq!(r.cycles.last().unwrap().mode, Mode::Ready);
}

/// The crane of [`MISMATCH`] with the study's strongest friction (a Coulomb droop of
/// 9.6 mm/s on the trolley, 3.7 mm/s on the winch) and a 9.4 N gust that blows until
/// just before the move ends (a case of the study's, `feedback_study`).
const FRICTION: Mismatch = Mismatch {
    tau1: -0.29,
    coulomb: [0.0096, 0.0037],
    gust: Gust {
        start: 5.8,
        duration: 2.35,
        amplitude: -9.35,
    },
    ..MISMATCH
};

/// The cycles from `from_s` to `to_s` whose set points are not both exactly zero.
fn holding(r: &Run, from_s: f64, to_s: f64) -> Vec<usize> {
    let (a, b) = ((from_s * 100.0) as usize, (to_s * 100.0) as usize);
    (a..b.min(r.cycles.len()))
        .filter(|&i| r.cycles[i].setpoints.iter().any(|s| s.units() != 0))
        .collect()
}

#[test]
fn with_friction_the_set_points_are_exactly_zero_from_5_s_after_the_move_and_a_push_takes_hold() {
    // Issue 18 item 5: against Coulomb friction the feedback damped the last tenths of
    // a degree slowly, and the old rest hold (the largest angle over the last half
    // period) let go only after the swing had gone for up to half a period: here
    // 5.65 s after the move (cycle 1465). Judged as the swing the load keeps once the
    // trolley stands still, it lets go 4.1 s after the move and the drives hold.
    const MOVE_WITH_FRICTION: Scenario = Scenario {
        plant: Some(FRICTION),
        ..scenario("closed-loop-friction", &[MOVE])
    };
    let r = run(feedback(), MOVE_WITH_FRICTION, 20.0);
    let (d, s) = r.settled();
    let held = holding(&r, MOVE_END_S + 5.0, 20.0);
    let last = holding(&r, 0.0, 20.0).last().copied();
    eprintln!(
        "friction: 5 s after the move {:.1} mm, {:.3}°; last set point not zero at cycle {last:?}",
        d * 1e3,
        s
    );
    assert!(d < 0.05 && s < 0.1, "the acceptance target");
    assert!(held.is_empty(), "held at cycles {:?}…", held.first());
    assert!(r.emcys(0xFF20).is_empty(), "never fell back");

    // A push at rest (a 10 N gust for 1 s, 11 s after the move): the feedback takes
    // hold again, damps it, and lets go once more.
    const PUSH: Mismatch = Mismatch {
        gust: Gust {
            start: 20.0,
            duration: 1.0,
            amplitude: 10.0,
        },
        ..FRICTION
    };
    const PUSHED: Scenario = Scenario {
        plant: Some(PUSH),
        ..scenario("closed-loop-friction-push", &[MOVE])
    };
    let r = run(feedback(), PUSHED, 40.0);
    assert!(holding(&r, 15.0, 20.0).is_empty(), "let go before the push");
    let taken = holding(&r, 20.0, 40.0);
    let (first, last) = (taken.first().copied(), taken.last().copied());
    eprintln!("push at cycle 2000: held from {first:?} to {last:?}");
    assert!(
        first.is_some_and(|k| k < 2000 + 100),
        "the push is answered within 1 s"
    );
    let peak = r.load[2000..2400]
        .iter()
        .map(|(_, _, phi)| phi.abs())
        .fold(0.0, f64::max);
    let end = r.load[3700..]
        .iter()
        .map(|(_, _, phi)| phi.abs())
        .fold(0.0, f64::max);
    eprintln!(
        "push: swing {:.3}° at its peak, {:.3}° at the end",
        peak.to_degrees(),
        end.to_degrees()
    );
    assert!(end < 0.1f64.to_radians() && end < 0.1 * peak, "damped");
    assert!(
        last.is_some_and(|k| k < 3700),
        "let go again, the set points exactly zero from cycle {last:?}"
    );
}

/// The interop suite's rope-calibration case `delay-2-filter-10ms`
/// (interop/test_rope_calibration.py) on the virtual bus: the inclinometer two cycles
/// late behind a 10 ms filter with 0.05° of noise (0.01° quantum), the rope 1.5 %
/// shorter than the drum says and the hook block 80 mm shorter, drives that follow
/// their set points almost at once (3 and 10 ms against the model's 30 and 20 ms, as
/// drives.py's do at once), no friction, no gust.
const LATE_NOISY: Mismatch = Mismatch {
    rope_offset: -0.08,
    drum_scale: -0.015,
    angle_noise: (0.05 * std::f64::consts::PI / 180.0, 1.75e-4),
    noise_seed: 2,
    inclinometer: sim::angle_sensor::SensorLag {
        delay: 2,
        filter: 0.01,
    },
    tau1: -0.9,
    tau2: -0.5,
    position_noise: Mismatch::SENSORS.0,
    ..Mismatch::NONE
};

/// The paper's move and back, three times, 20 s apart (8 s each).
const ROUND_TRIPS: [Event; 6] = {
    const fn leg(k: u8) -> Event {
        Event {
            at_ms: 1_000 + 20_000 * k as u32,
            action: Action::Request(Request::Move {
                id: k + 1,
                target: if k.is_multiple_of(2) {
                    [20.0, 4.0]
                } else {
                    [12.0, 8.0]
                },
                duration: Some(8.0),
            }),
        }
    }
    [leg(0), leg(1), leg(2), leg(3), leg(4), leg(5)]
};

/// The swing the plant's load keeps if the trolley stops now, rad: `√(φ² + (ψ̇/ω)²)`
/// with `ψ̇ = φ̇ + ẋ/L` the load's velocity over the rail as an angle rate (what the
/// controller's rest hold judges), on the true rope `L`.
fn plant_amplitude(bus: &VirtualBus<Planar, 2>) -> f64 {
    let plant = bus.plant().unwrap();
    let [_, l, phi, vx, _, rate] = plant.y;
    let len = LATE_NOISY.rope(l).max(0.1);
    let omega = (9.81 / len).sqrt();
    let still = (rate + vx / len) / omega;
    (phi * phi + still * still).sqrt()
}

#[test]
fn after_each_move_a_late_noisy_inclinometer_leaves_the_crane_at_rest() {
    // Issue 33 (interop `delay-2-filter-10ms`, "no rest within 8 s"): after each move
    // the trolley's set point answered the inclinometer's noise at 100–300 mm/s for
    // seconds, and after the third move never came to rest. Here, before the rest's
    // observer (GainPoint::obs_rest): 99–191 mm/s once the swing was within 0.1°.
    const SCENE: Scenario = Scenario {
        plant: Some(LATE_NOISY),
        ..scenario("closed-loop-late-noisy", &ROUND_TRIPS)
    };
    let cfg = feedback::Config {
        inclinometer: controller::rope::InclinometerLag {
            delay: 2,
            filter: 0.01,
        },
        ..feedback::Config::PAPER
    };
    let ff: Ff = feedforward(HOME, None);
    let mut c =
        Controller::with_correction(ff, StateFeedback::new(cfg).unwrap(), planner(), config());
    let mut bus = VirtualBus::new(SCENE, HOME);
    // Per cycle: the trolley's set point (m/s), all set points zero, the plant's swing.
    let mut trace = Vec::new();
    for k in 0..12_100u32 {
        let cycle = run_cycle(&mut c, &mut bus, k * 10).expect("no hang");
        trace.push((
            f64::from(cycle.setpoints[0].units()) * 1e-6,
            cycle.setpoints.iter().all(|s| s.units() == 0),
            plant_amplitude(&bus),
        ));
    }
    let mut worst_rest = 0.0_f64;
    let mut worst_quiet = 0.0_f64;
    for (k, leg) in ROUND_TRIPS.iter().enumerate() {
        let end = (leg.at_ms / 10 + 800) as usize;
        let after = &trace[end..end + 1_200];
        // At rest for good: every set point zero from then to the next move.
        let rest = after
            .iter()
            .rposition(|(_, zero, _)| !zero)
            .map_or(0, |i| i + 1);
        // The trolley's set points once the swing is within the 0.1° target for good.
        let calm = after
            .iter()
            .rposition(|(_, _, a)| *a >= 0.1_f64.to_radians())
            .map_or(0, |i| i + 1);
        let quiet = after[calm..]
            .iter()
            .map(|(u, ..)| u.abs())
            .fold(0.0, f64::max);
        eprintln!(
            "move {}: at rest {:.2} s after its end, swing within 0.1° from {:.2} s, the trolley's set point since then ≤ {:.1} mm/s",
            k + 1,
            rest as f64 * 0.01,
            calm as f64 * 0.01,
            quiet * 1e3
        );
        worst_rest = worst_rest.max(rest as f64 * 0.01);
        // The first move ends before the angle is trusted (the zero's estimate settles
        // at the first rest): the move's observer is still the one at rest then.
        if k > 0 {
            worst_quiet = worst_quiet.max(quiet);
        }
    }
    assert!(worst_rest <= 3.0, "at rest {worst_rest:.2} s after a move");
    assert!(
        worst_quiet <= 0.08,
        "the trolley answered noise at {:.1} mm/s",
        worst_quiet * 1e3
    );
}
