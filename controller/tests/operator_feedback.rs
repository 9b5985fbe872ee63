//! Manual mode with the state feedback (issue 28, "Closed loop"), on the virtual bus's
//! plant that is not the model (`sim::MISMATCHED`: other drive lags, a longer rope,
//! friction, noisy quantised sensors) with the inclinometer (CiA 410, node 3): the loop
//! runs in manual mode too, and a lost inclinometer lets manual mode go on on
//! feedforward, its travel speed capped.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

mod common;

use common::manual::{ManualFf, HELD};
use common::{planner, settings, HOME};
use controller::canopen::CONTROLLER_NODE;
use controller::commands::{request_frame, Request};
use controller::commissioning::{InclinometerSetup, NodeSetup};
use controller::feedback::{self, StateFeedback};
use controller::operator::path::Steered;
use controller::operator::{
    operator_frame, OperatorFrame, FULL_SCALE, MANUAL_MODE_CODE, UNOBSERVED_SPEED_SHARE,
};
use controller::setpoint::{Setpoint, UNITS_PER_M_PER_S};
use controller::{Config, Controller, Cycle, Injectable, InverseModel, Mode};
use scene::cranes::planar::Planar;
use sim::plant::Mismatch;
use sim::{run_cycle, Action, Event, Scenario, SensorFault, VirtualBus, HEALTHY, MISMATCHED};
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::operator::Settings;
use solver_core::plan::Plan;
use solver_core::trajectory::PointToPoint;

/// The manual-mode controller with the state feedback, its bus and clock.
struct Rig {
    c: Controller<ManualFf, StateFeedback, Planar, 2>,
    bus: VirtualBus<Planar, 2>,
    now: u32,
    counter: u8,
}

impl Rig {
    /// Ready at rest at [`HOME`] on the plant that is not the model; `events` on the bus.
    fn new(events: &'static [Event]) -> Self {
        Self::at(HOME, MISMATCHED, events)
    }

    /// Ready at rest with the load at `home` on `plant`; `events` on the bus.
    fn at(home: [f64; 2], plant: Mismatch, events: &'static [Event]) -> Self {
        let plan = controller::crane::command_plan::<Planar, 2>(home, 4).unwrap();
        let mut rig = Self::on(plan, home, plant, events);
        rig.hold(200, [0; 3]);
        assert_eq!(rig.c.mode(), Mode::Ready);
        rig
    }

    /// Following `plan` from `home` on `plant`, `events` on the bus; not a cycle run yet.
    fn on(plan: Plan<f64, 2>, home: [f64; 2], plant: Mismatch, events: &'static [Event]) -> Self {
        let path = Steered::new(plan, Settings::lab(&CraneParams::PAPER));
        let model = CraneSubs::new(CraneParams::PAPER, path).unwrap();
        let integrator = crane_subs::Bdf::new(&model, &settings(), 4, 0.0).unwrap();
        let ff = Injectable::new(InverseModel::new(model, integrator));
        let feedback = StateFeedback::new(feedback::Config::PAPER).unwrap();
        let config = Config::DEFAULT.with_node(NodeSetup::Inclinometer(InclinometerSetup::STOCK));
        let scenario = Scenario {
            name: "manual-feedback",
            events,
            plant: Some(plant),
            ..HEALTHY
        };
        Self {
            c: Controller::with_correction(ff, feedback, planner(), config),
            bus: VirtualBus::new(scenario, home),
            now: 0,
            counter: 0,
        }
    }

    /// `cycles` cycles, the operator's frame every third (30 ms).
    fn hold(&mut self, cycles: usize, demand: [i16; 3]) -> Vec<Cycle> {
        (0..cycles)
            .map(|n| {
                if n % 3 == 0 {
                    self.counter = self.counter.wrapping_add(1);
                    let f = operator_frame(
                        CONTROLLER_NODE,
                        &OperatorFrame {
                            counter: self.counter,
                            flags: HELD,
                            demand,
                        },
                    );
                    self.c.on_frame(&f, self.now.into());
                }
                let out = run_cycle(&mut self.c, &mut self.bus, self.now).unwrap();
                self.now += 10;
                out
            })
            .collect()
    }

    /// `cycles` cycles without an operator frame.
    fn idle(&mut self, cycles: usize) -> Vec<Cycle> {
        (0..cycles)
            .map(|_| {
                let out = run_cycle(&mut self.c, &mut self.bus, self.now).unwrap();
                self.now += 10;
                out
            })
            .collect()
    }

    /// The plant's load `[x_C, z_C]` and swing angle, rad.
    fn plant(&self) -> ([f64; 2], f64) {
        let p = self.bus.plant().unwrap();
        (p.load(), p.y[2])
    }
}

fn trolley_speed(c: &Cycle) -> f64 {
    f64::from(c.setpoints[0].units()).abs() / UNITS_PER_M_PER_S
}

/// Full stick for 4 s and its release, with the state feedback, at every rope length of
/// the range and with the plant's pendulum about 10 % longer and 8 % shorter than the
/// model's (the drum's scale 9 % off either way, the hook block's 80 mm more,
/// `sim::MISMATCHED`'s drive lags, friction and sensors): after the set points rest, the plant's load stays within
/// ±50 mm of where it rests and swings less than 0.1° over the pendulum's period — the
/// issue's closed-loop target in manual mode — with no fault. Prints the table.
#[test]
fn the_feedback_brings_the_plant_to_rest_after_a_manual_travel() {
    println!("| rope, m | plant's pendulum | load within, mm | swing below, ° |");
    println!("|---:|---|---:|---:|");
    for rope in [3.0, 4.5, 6.0, 7.5, 8.9] {
        for (name, drum_scale) in [("rope +9 % +80 mm", 0.09), ("rope −9 % +80 mm", -0.09)] {
            let plant = Mismatch {
                drum_scale,
                ..MISMATCHED
            };
            let (dx, swing) = travel_and_rest(&mut Rig::at([12.0, rope], plant, &[]), rope);
            println!("| {rope} | {name} | {:.1} | {swing:.3} |", dx * 1000.0);
            assert!(dx <= 0.05, "rope {rope}, {name}: load moved {dx} m");
            assert!(swing <= 0.1, "rope {rope}, {name}: swing {swing}°");
        }
    }
}

/// Full stick for 4 s, the release, and the pendulum's period after the set points rest:
/// how far the plant's load moved from where it rested, m, and its largest swing, °.
fn travel_and_rest(rig: &mut Rig, rope: f64) -> (f64, f64) {
    rig.hold(9, [0; 3]);
    assert_eq!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
    let mut cycles = rig.hold(400, [FULL_SCALE, 0, 0]);
    let mut rested = false;
    for n in 0..1500 {
        cycles.extend(rig.hold(1, [0; 3]));
        let quiet = cycles
            .iter()
            .rev()
            .take(50)
            .all(|c| c.setpoints[0].units().abs() < 2_000);
        if quiet && n > 100 {
            rested = true;
            break;
        }
    }
    assert!(rested, "rope {rope}: the set points come to rest");
    let (rest, _) = rig.plant();
    let period = 2.0 * std::f64::consts::PI * (1.1 * rope / 9.81).sqrt();
    let (mut dx, mut swing) = (0.0_f64, 0.0_f64);
    for _ in 0..(period * 100.0) as usize {
        cycles.extend(rig.hold(1, [0; 3]));
        let (load, phi) = rig.plant();
        dx = dx.max((load[0] - rest[0]).abs());
        swing = swing.max(phi.abs().to_degrees());
    }
    assert!(
        cycles.iter().all(|c| c.mode == Mode::Ready),
        "rope {rope}: no fault"
    );
    (dx, swing)
}

/// Manual mode asked for at rest — the controller ready, the loop open (no move since
/// boot) — with the stick centred, then trembling inside its deadband, on the plant's
/// noisy, quantised sensors: from the request on every set point is exactly 0.0 and the
/// plant's trolley stays where it stood, for 5 s. The feedback observes from the entry
/// and sends its correction from the stick's first demand (acting from the entry, it
/// moved the trolley 4.3 mm at up to 95 mm/s on the sensors' noise before its observer
/// trusted the angle: `cargo run --release -p drive-view --example
/// manual_entry_at_rest` up to 785a611). That demand moves the crane at once, and its
/// travel and release end within the closed loop's targets
/// (`the_feedback_brings_the_plant_to_rest_after_a_manual_travel`'s).
#[test]
fn manual_mode_entered_at_rest_moves_nothing_until_the_stick_asks() {
    let plan = controller::crane::command_plan::<Planar, 2>(HOME, 4).unwrap();
    let mut rig = Rig::on(plan, HOME, MISMATCHED, &[]);
    rig.idle(200);
    assert_eq!(rig.c.mode(), Mode::Ready);
    assert_ne!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
    let stood = rig.bus.plant().unwrap().y[0];
    // Inside the 5 % deadband: 4 % of full stick, either way.
    let tremble = (0.04 * f64::from(FULL_SCALE)) as i16;
    let mut cycles = rig.hold(150, [0; 3]);
    assert_eq!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
    cycles.extend(rig.hold(150, [tremble, 0, 0]));
    cycles.extend(rig.hold(200, [-tremble, 0, 0]));
    nothing_moved_until_the_stick_asks(&mut rig, &cycles, stood);
}

/// Every set point of `cycles` exactly 0.0 and the plant's trolley where it `stood`;
/// then the stick's travel: the feedback acts, the load ends within ±50 mm and 0.1°.
fn nothing_moved_until_the_stick_asks(rig: &mut Rig, cycles: &[Cycle], stood: f64) {
    assert!(
        cycles.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]),
        "a set point other than 0.0 without a command"
    );
    let moved = (rig.bus.plant().unwrap().y[0] - stood).abs();
    assert!(moved == 0.0, "the trolley moved {moved} m");
    let (dx, swing) = travel_and_rest(rig, HOME[1]);
    println!(
        "then the stick's travel: load within {:.1} mm, swing below {swing:.3}°",
        dx * 1000.0
    );
    assert!(dx <= 0.05 && swing <= 0.1, "{dx} m, {swing}°");
}

/// Manual mode entered at rest, left unused (the operator's frames stop) and entered
/// again: the second entry is no command either. The observer has run since the first
/// entry, the correction stays held: every set point exactly 0.0 until the stick asks.
#[test]
fn manual_mode_left_unused_and_entered_again_moves_nothing() {
    let plan = controller::crane::command_plan::<Planar, 2>(HOME, 4).unwrap();
    let mut rig = Rig::on(plan, HOME, MISMATCHED, &[]);
    rig.idle(200);
    let stood = rig.bus.plant().unwrap().y[0];
    let tremble = (0.04 * f64::from(FULL_SCALE)) as i16;
    // Left and entered again within half a second: the observer is young, its
    // correction would still act on the sensors' noise.
    let mut cycles = rig.hold(12, [tremble, 0, 0]);
    assert_eq!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
    cycles.extend(rig.idle(25));
    assert_ne!(rig.c.status().bytes()[3], MANUAL_MODE_CODE, "left at rest");
    cycles.extend(rig.hold(300, [-tremble, 0, 0]));
    assert_eq!(rig.c.status().bytes()[3], MANUAL_MODE_CODE, "entered again");
    nothing_moved_until_the_stick_asks(&mut rig, &cycles, stood);
}

/// A reset at rest (the drives' positions taken again) restarts the observer and opens
/// the loop, as at boot: after a move with the feedback on the noisy plant and its
/// rest, the reset, and 5 s in which every set point is exactly 0.0 and the trolley
/// stays where it stood.
#[test]
fn a_reset_at_rest_opens_the_loop_until_the_next_command() {
    let mut rig = Rig::new(&[]);
    let (_, _) = travel_and_rest(&mut rig, HOME[1]);
    // Manual mode left: the request withdrawn, the load at rest.
    rig.idle(300);
    assert_ne!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
    let reset = request_frame(&Request::Reset { id: 9 });
    rig.c.on_frame(&reset, rig.now.into());
    let after = rig.idle(500);
    assert!(
        after.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]),
        "a set point other than 0.0 after the reset"
    );
}

/// The inclinometer lost during manual travel: the feedback announces it (EMCY 0xFF20,
/// reason 1) and manual mode goes on on feedforward with the travel speed capped at
/// [`UNOBSERVED_SPEED_SHARE`] of the manual speed; released, the load rests, no fault.
#[test]
fn a_lost_inclinometer_caps_the_manual_speed() {
    const LOST: &[Event] = &[Event {
        at_ms: 9_000,
        action: Action::Sensor(SensorFault::Lost),
    }];
    let mut rig = Rig::new(LOST);
    rig.hold(9, [0; 3]);
    assert_eq!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
    let before = rig.hold((9_000 - rig.now as usize) / 10, [FULL_SCALE, 0, 0]);
    let full = before.iter().map(trolley_speed).fold(0.0, f64::max);
    let after = rig.hold(800, [FULL_SCALE, 0, 0]);
    let off: Vec<_> = after
        .iter()
        .flat_map(|c| c.frames.iter())
        .filter(|f| f.id() == 0x090 && f.data()[..2] == [0x20, 0xFF])
        .collect();
    assert_eq!(off.len(), 1, "announced once");
    let capped = after[after.len() - 200..]
        .iter()
        .map(trolley_speed)
        .fold(0.0, f64::max);
    println!("trolley at full stick: {full:.3} m/s with the angle, {capped:.3} m/s without");
    assert!(full > 0.95, "full speed with the angle: {full}");
    assert!(
        (capped - UNOBSERVED_SPEED_SHARE).abs() < 0.02,
        "capped: {capped}"
    );
    let rest = rig.hold(1500, [0; 3]);
    assert!(rest[rest.len() - 100..]
        .iter()
        .all(|c| c.setpoints == [Setpoint::ZERO; 2]));
    assert!(before
        .iter()
        .chain(&after)
        .chain(&rest)
        .all(|c| c.mode == Mode::Ready));
}

/// The EMCYs of `cycles` announcing the feedback's angle lost (0xFF20).
fn angle_lost(cycles: &[Cycle]) -> usize {
    cycles
        .iter()
        .flat_map(|c| c.frames.iter())
        .filter(|f| f.id() == 0x090 && f.data()[..2] == [0x20, 0xFF])
        .count()
}

/// A take-over closes the loop at once, as the stick's first demand after an entry at rest
/// does (`close_loop`; review s14: the
/// take-over did not call it): a move planned at boot and never commanded runs without
/// the feedback (it acts on commands: `demonstration_commanded` not called here); the
/// stick takes it over halfway (EMCY 0xFF22, detail 0), and the feedback then runs in
/// manual mode — the inclinometer lost 2 s later is announced (EMCY 0xFF20, once) and the
/// stick's travel capped at [`UNOBSERVED_SPEED_SHARE`] of the manual speed once the
/// move's stop is over, as after an entry at rest
/// (`a_lost_inclinometer_caps_the_manual_speed`); no fault. (A feedback already degraded
/// at a take-over is not restarted there: its observer starts from a crane at rest,
/// `Correction::restart`, as for a move accepted while the crane moves.)
#[test]
fn a_take_over_closes_the_loop_at_once() {
    const LOST: &[Event] = &[Event {
        at_ms: 8_000,
        action: Action::Sensor(SensorFault::Lost),
    }];
    let mut plan = controller::crane::command_plan::<Planar, 2>(HOME, 4).unwrap();
    let boot = PointToPoint::new(HOME.into(), [18.0, 6.0].into(), 3.0, 6.0, 4).unwrap();
    plan.push(boot).unwrap();
    let mut rig = Rig::on(plan, HOME, MISMATCHED, LOST);
    rig.idle(450);
    assert_eq!(rig.c.mode(), Mode::Ready);
    assert_eq!(rig.c.status().bytes()[3], 1, "automatic: the move runs");
    // The request with the stick centred (two frames arm the take-over), then backwards.
    let mut cycles = rig.hold(150, [0; 3]);
    let taken = rig.hold(1, [-FULL_SCALE, 0, 0]);
    let over: Vec<_> = taken
        .iter()
        .flat_map(|c| c.frames.iter())
        .filter(|f| f.id() == 0x090 && f.data()[..2] == [0x22, 0xFF])
        .collect();
    assert_eq!(over.len(), 1, "taken over in the frame's cycle");
    assert_eq!(over[0].data()[5], 0, "at once");
    assert_eq!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
    cycles.extend(taken);
    // To 8 s, the inclinometer lost, to 16 s: the stop (at most 8 s) over by 14 s.
    cycles.extend(rig.hold(800, [-FULL_SCALE, 0, 0]));
    let late = rig.hold(200, [-FULL_SCALE, 0, 0]);
    let capped = late.iter().map(trolley_speed).fold(0.0, f64::max);
    cycles.extend(late);
    println!("after the take-over, the angle lost: trolley at {capped:.3} m/s at full stick");
    assert_eq!(
        angle_lost(&cycles),
        1,
        "the feedback runs: the loss announced once"
    );
    assert!(
        (capped - UNOBSERVED_SPEED_SHARE).abs() < 0.02,
        "capped: {capped}"
    );
    assert!(cycles.iter().all(|c| c.mode == Mode::Ready), "no fault");
}

/// Only the hoist on the stick, lowering and raising at 0.6 of full scale for 3 s, then
/// centred for 3 s, after manual mode was entered at rest (0.09 s or 4 s before): the
/// trolley has no path, and its correction is exactly 0.0 — let go when the hoist's
/// demand closes the loop (`StateFeedback::let_go_at_rest`), or when the hoist starts
/// alone, and the load within the hold thresholds while the hoist moves —, and the plant's
/// trolley stays where it stood. Acting on the young estimate, the angle's noise moved
/// the trolley by up to 7.0 mm at 0.139 m/s; with the angle trusted but the loop held
/// while hoisting, 3.5 mm at 0.076 m/s (both on 4a7f83f).
#[test]
fn a_hoist_only_demand_leaves_the_trolley_where_it_stands() {
    let lever = (0.6 * f64::from(FULL_SCALE)) as i16;
    for (observed, hoist) in [(9, lever), (9, -lever), (400, lever), (400, -lever)] {
        let plan = controller::crane::command_plan::<Planar, 2>(HOME, 4).unwrap();
        let mut rig = Rig::on(plan, HOME, MISMATCHED, &[]);
        rig.idle(200);
        rig.hold(observed, [0; 3]);
        assert_eq!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
        let (stood, rope) = (rig.bus.plant().unwrap().y[0], rig.plant().0[1]);
        let (mut speed, mut moved) = (0.0_f64, 0.0_f64);
        for demand in [[0, 0, hoist], [0; 3]] {
            for _ in 0..100 {
                for c in rig.hold(3, demand) {
                    speed = speed.max(trolley_speed(&c));
                }
                moved = moved.max((rig.bus.plant().unwrap().y[0] - stood).abs());
            }
        }
        let hoisted = (rig.plant().0[1] - rope).abs();
        println!(
            "observed {observed} cycles, hoist {hoist}: the load hoisted {hoisted:.2} m, \
             trolley set point up to {speed:.3} m/s, trolley up to {:.2} mm",
            moved * 1000.0
        );
        assert!(hoisted > 0.5, "the hoist moved {hoisted} m");
        assert!(speed == 0.0 && moved == 0.0, "{speed} m/s, {moved} m");
    }
}

/// The plant's largest swing over the next `cycles` cycles of `demand`, °.
fn largest_swing(rig: &mut Rig, cycles: usize, demand: [i16; 3]) -> f64 {
    (0..cycles)
        .map(|_| {
            rig.hold(1, demand);
            rig.plant().1.abs().to_degrees()
        })
        .fold(0.0, f64::max)
}

/// A load already swinging 1° when manual mode is entered at rest, and only the hoist
/// on the stick (0.6 of full scale, lowering and raising, for 3 s): the trolley is let
/// go when the demand closes the loop (the swing not yet confirmed by the load's
/// motion 0.09 s after the entry), takes hold as soon as the load's motion shows it, and
/// damps it while the hoist moves — over the hoist's last second less than 0.6 of the
/// swing at the entry —, and less than 0.1° is left over the 3 s that follow 3 s of rest
/// after the hoist. (With the trolley waiting for a trust that the hoist's motion
/// postponed, the swing went undamped for as long as the hoist moved: review s23,
/// finding 1.)
#[test]
fn a_swinging_load_is_damped_while_only_the_hoist_moves() {
    let lever = (0.6 * f64::from(FULL_SCALE)) as i16;
    let swinging = Mismatch {
        swing0: 1f64.to_radians(),
        ..MISMATCHED
    };
    for hoist in [lever, -lever] {
        let plan = controller::crane::command_plan::<Planar, 2>(HOME, 4).unwrap();
        let mut rig = Rig::on(plan, HOME, swinging, &[]);
        let before = (0..200)
            .map(|_| {
                rig.idle(1);
                rig.plant().1.abs().to_degrees()
            })
            .fold(0.0, f64::max);
        rig.hold(9, [0; 3]);
        assert_eq!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
        let hoisting = largest_swing(&mut rig, 200, [0, 0, hoist]);
        let hoist_end = largest_swing(&mut rig, 100, [0, 0, hoist]);
        let rest = largest_swing(&mut rig, 300, [0; 3]);
        let after = largest_swing(&mut rig, 300, [0; 3]);
        println!(
            "hoist {hoist}: swing at the entry {before:.3}°, in the hoist's first 2 s \
             {hoisting:.3}°, its last second {hoist_end:.3}°, in the 3 s after {rest:.3}°, \
             in the next 3 s {after:.3}°"
        );
        assert!(before > 0.9, "{before}°: the load swings at the entry");
        assert!(
            hoist_end < 0.6 * before,
            "hoist {hoist}: {hoist_end}° in the hoist's last second: not damped while hoisting"
        );
        assert!(after < 0.1, "hoist {hoist}: {after}° left");
    }
}

/// The inclinometer lost 0.5 s after manual mode was entered at rest (before the angle
/// could be trusted), then only the hoist on the stick for 3 s: the feedback goes on
/// on the drives' positions, and the trolley, let go when the hoist's demand closed the
/// loop, stays let go — every trolley set point exactly 0.0. (An angle lost before the trust must not
/// hand the trolley to the young estimate: review s23, finding 2.)
#[test]
fn an_angle_lost_before_it_is_trusted_moves_no_trolley_while_only_the_hoist_moves() {
    const LOST: &[Event] = &[Event {
        at_ms: 2_500,
        action: Action::Sensor(SensorFault::Lost),
    }];
    let lever = (0.6 * f64::from(FULL_SCALE)) as i16;
    let plan = controller::crane::command_plan::<Planar, 2>(HOME, 4).unwrap();
    let mut rig = Rig::on(plan, HOME, MISMATCHED, LOST);
    rig.idle(200);
    let mut cycles = rig.hold(60, [0; 3]);
    assert_eq!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
    let stood = rig.bus.plant().unwrap().y[0];
    cycles.extend(rig.hold(300, [0, 0, lever]));
    cycles.extend(rig.hold(300, [0; 3]));
    assert_eq!(angle_lost(&cycles), 1, "the loss announced once");
    let speed = cycles.iter().map(trolley_speed).fold(0.0, f64::max);
    let moved = (rig.bus.plant().unwrap().y[0] - stood).abs();
    println!("angle lost before trust: trolley set point up to {speed:.3} m/s, moved {moved} m");
    assert!(speed == 0.0 && moved == 0.0, "{speed} m/s, {moved} m");
    assert!(cycles.iter().all(|c| c.mode == Mode::Ready), "no fault");
}

/// A nudge of the trolley's lever (0.3 of full scale for 0.3 s) right after manual mode
/// was entered at rest, then only the hoist for 3 s (review s23, finding 4):
/// - once the nudge's set points rest (the trolley let go, the angle trusted): every
///   trolley set point exactly 0.0 while hoisting;
/// - as soon as the nudge's path rests, before the angle is trusted: the trolley, still
///   damping the nudge (0.073 m/s printed, 1.6 mm moved), is let go when the hoist
///   starts alone — the model's hoist set point leaving 1e-6 m/s, 4 cycles after the
///   stick — and every set point from the damping's ramp-out on is exactly 0.0 (on
///   4a7f83f, where the trolley was never let go while the hoist moved, the first case
///   printed 0.105 m/s and 2.9 mm).
#[test]
fn a_trolley_nudge_before_the_hoist_leaves_the_trolley_where_it_stopped() {
    let lever = (0.6 * f64::from(FULL_SCALE)) as i16;
    let nudge = (0.3 * f64::from(FULL_SCALE)) as i16;
    for wait_for_rest in [true, false] {
        let plan = controller::crane::command_plan::<Planar, 2>(HOME, 4).unwrap();
        let mut rig = Rig::on(plan, HOME, MISMATCHED, &[]);
        rig.idle(200);
        rig.hold(9, [0; 3]);
        assert_eq!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
        rig.hold(30, [nudge, 0, 0]);
        if wait_for_rest {
            let mut rested = 0;
            while rested < 10 {
                let c = rig.hold(1, [0; 3]);
                rested = if trolley_speed(&c[0]) == 0.0 {
                    rested + 1
                } else {
                    0
                };
                assert!(rig.now < 30_000, "the nudge's set points rest");
            }
        } else {
            // The model's trolley set point at rest: the path has stopped.
            let mut rested = 0;
            while rested < 10 {
                let c = rig.hold(1, [0; 3]);
                rested = match c[0].step {
                    Some(step) if step.u[0] == 0.0 => rested + 1,
                    _ => 0,
                };
                assert!(rig.now < 30_000, "the nudge's path rests");
            }
        }
        let stood = rig.bus.plant().unwrap().y[0];
        let hoisting = rig.hold(300, [0, 0, lever]);
        let speed = hoisting.iter().map(trolley_speed).fold(0.0, f64::max);
        let moved = (rig.bus.plant().unwrap().y[0] - stood).abs();
        println!(
            "a nudge, {}, then hoisting: trolley set point up to {speed:.3} m/s, moved {:.2} mm",
            if wait_for_rest {
                "the trolley let go"
            } else {
                "its path at rest"
            },
            moved * 1000.0
        );
        if wait_for_rest {
            assert!(speed == 0.0, "{speed} m/s");
        } else {
            // The hoist starts alone when the model's hoist set point leaves the
            // feedback's stillness (1e-6 m/s); the trolley's damping is ramped out
            // within the acceleration limit (3 cycles) and let go from then on.
            let start = hoisting
                .iter()
                .position(|c| c.step.is_some_and(|s| s.u[1].abs() >= 1e-6))
                .expect("the hoist starts");
            for (k, c) in hoisting.iter().enumerate().skip(start + 3) {
                assert_eq!(trolley_speed(c), 0.0, "cycle {k} of hoisting");
            }
            assert!(speed < 0.09 && moved < 0.003, "{speed} m/s, {moved} m");
        }
    }
}

/// An automatic hoist-only move, 1 m up from 1.0 s in 4 s, accepted at rest before the
/// angle is trusted (`demonstration_commanded`, as the QEMU main job asks for its
/// move): the loop closes as the move starts, so until then every trolley set point is
/// exactly 0.0 — the correction acted on the young estimate's noise from the command
/// until 3f6faa8 (0.063 m/s) —, and it closes with the trolley let go: every trolley set
/// point to the move's end exactly 0.0, and the plant's trolley stays where it stood
/// (0.00 mm printed). Closed without the let-go, the trolley acted from the move's start
/// until the hoist's set point left 0 and the hoist's alone start let it go (0.012 m/s,
/// 0.10 mm: `let_go_at_rest` removed from `close_observed_loop`); on 3f6faa8, the loop
/// closed at the acceptance and the hoist's alone start not let go (`hoist_starts`
/// disabled in `StateFeedback::settle`), 0.077 m/s and 3.1 mm during the move.
#[test]
fn an_automatic_hoist_only_move_before_the_trust_leaves_the_trolley_where_it_stands() {
    let mut plan = controller::crane::command_plan::<Planar, 2>(HOME, 4).unwrap();
    let up = [HOME[0], HOME[1] - 1.0];
    plan.push(PointToPoint::new(HOME.into(), up.into(), 1.0, 4.0, 4).unwrap())
        .unwrap();
    let mut rig = Rig::on(plan, HOME, MISMATCHED, &[]);
    rig.c.demonstration_commanded();
    // Until the model's hoist set point leaves the feedback's stillness (1e-6 m/s).
    let mut before = 0.0_f64;
    loop {
        let c = rig.idle(1).remove(0);
        before = before.max(trolley_speed(&c));
        if c.step.is_some_and(|s| s.u[1].abs() >= 1e-6) {
            break;
        }
        assert!(rig.now < 2_000, "the hoist starts at 1.0 s");
    }
    let (stood, load) = (rig.bus.plant().unwrap().y[0], rig.plant().0[1]);
    // The move to its end: the loop closed at its start let the trolley go at once.
    let moving = rig.idle(403);
    let after = moving.iter().map(trolley_speed).fold(0.0, f64::max);
    let moved = (rig.bus.plant().unwrap().y[0] - stood).abs();
    let hoisted = (rig.plant().0[1] - load).abs();
    println!(
        "an automatic hoist-only move before the trust: trolley set point up to \
         {before:.3} m/s before the hoist starts, {after:.3} m/s after, trolley moved \
         {:.2} mm while the load rose {hoisted:.2} m",
        moved * 1000.0
    );
    // Observed, not acted on, until the move starts; let go from its start.
    assert_eq!(
        before, 0.0,
        "the trolley acted before the hoist's set point left 0"
    );
    for (k, c) in moving.iter().enumerate() {
        assert_eq!(trolley_speed(c), 0.0, "cycle {k} of the move");
        assert_eq!(c.mode, Mode::Ready);
    }
    assert!(hoisted > 0.7, "{hoisted} m");
    assert!(moved < 0.001, "{moved} m");
}
