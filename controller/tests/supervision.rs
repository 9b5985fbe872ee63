//! Nothing moves unseen (issue 32, item 1): each drive's motion against what the
//! controller commanded — a standstill window at rest, a following window while moving
//! (docs/COMMANDS.md, faults 20 and 21) —, another node producing what the controller
//! produces (fault 19: a second SYNC producer, a second master's RPDOs), and a move
//! refused when the drives are not where the controller last brought them (reason 15).
//! On the virtual bus's simulated drives, with injected time.

mod common;
mod common3d;

use common::*;
use controller::commands::Request;
use controller::drive::Drive;
use controller::fault::{FollowingError, Foreign};
use controller::{Fault, Mode};
use sim::{Action, Quirk, RawFrame, VirtualBus, HEALTHY};

/// The controller's EMCYs in the cycles: (code, register, fault, node, detail).
fn emcys_of<const A: usize>(cycles: &[controller::Cycle<A>]) -> Vec<(u16, u8, u8, u8, u8)> {
    common::emcy_frames(cycles, None)
        .into_iter()
        .map(|d| (u16::from_le_bytes([d[0], d[1]]), d[2], d[3], d[4], d[5]))
        .collect()
}

/// Another node's RPDO1 to `node`: controlword *enable operation*, target velocity
/// `units` µm/s (what a second master sends the drive).
fn foreign_rpdo(node: u8, units: i32) -> RawFrame {
    let [v0, v1, v2, v3] = units.to_le_bytes();
    RawFrame {
        id: 0x200 + u16::from(node),
        len: 6,
        data: [0x0F, 0, v0, v1, v2, v3, 0, 0],
    }
}

/// Another node's SYNC.
const FOREIGN_SYNC: RawFrame = RawFrame {
    id: 0x080,
    len: 0,
    data: [0; 8],
};

/// Ready, at rest, the standstill windows kept (0.5 s at zero).
fn resting_rig() -> Rig {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    rig.run(60);
    rig
}

/// Resets (retrying while refused, each with a new id from `id`) until one is taken;
/// then ready again.
fn reset(rig: &mut Rig, id: u8) {
    for id in id..id + 50 {
        send(rig, Request::Reset { id });
        if answers(&rig.run(2)).contains(&(id, 1, 0)) {
            rig.until(200, |c| c.mode == Mode::Ready);
            return;
        }
        rig.run(10);
    }
    panic!("no reset taken");
}

/// A move to `target` in `duration` s from rest, run to its end and 1 s beyond: accepted,
/// no fault, and both drives on the target within 1 mm (the move was planned from where
/// they are).
fn move_ends_on_target(rig: &mut Rig, id: u8, target: [f64; 2], duration: f64) {
    send(
        rig,
        Request::Move {
            id,
            target,
            duration: Some(duration),
        },
    );
    let out = rig.run((duration * 100.0) as usize + 100);
    assert_eq!(answers(&out)[0], (id, 1, 0), "the move is accepted");
    assert!(out.iter().all(|c| c.mode == Mode::Ready), "no fault");
    let at = [Drive::Trolley, Drive::Winch].map(|d| rig.bus.drive(d).unwrap().position());
    assert!(
        at.iter().zip(target).all(|(a, t)| (a - t).abs() < 1e-3),
        "at {at:?}, not {target:?}"
    );
}

/// The case: at rest, another node sends the trolley's RPDO (+0.2 m/s) and a
/// SYNC, 50 times. Before, the trolley crept 100 mm unseen and the next move put the
/// load down 100 mm off its target; now the first foreign RPDO is fault 19 naming the
/// trolley (a quick stop), and after the reset — which takes the drives' positions —
/// the next move ends on its target.
#[test]
fn a_second_master_moving_a_drive_at_rest_is_a_foreign_producer() {
    let mut rig = resting_rig();
    let mut out = Vec::new();
    for _ in 0..50 {
        rig.bus.inject(Action::Foreign(foreign_rpdo(1, 200_000)));
        rig.bus.inject(Action::Foreign(FOREIGN_SYNC));
        out.push(rig.cycle());
    }
    // At rest the quick stop is over at once: halted.
    assert_eq!(
        out[0].mode,
        Mode::Halted(Fault::ForeignProducer(Foreign::Rpdo(Drive::Trolley)))
    );
    assert_eq!(emcys_of(&out)[0], (0x8150, 0x11, 19, 1, 2));
    assert!(matches!(rig.c.mode(), Mode::Halted(_)));
    // The trolley, quick-stopped, moved only the foreign set point's first cycles.
    let x = rig.bus.drive(Drive::Trolley).unwrap().position();
    assert!(x - 12.0 < 0.01, "the trolley moved {} m", x - 12.0);
    reset(&mut rig, 10);
    move_ends_on_target(&mut rig, 30, [14.0, 7.0], 6.0);
}

#[test]
fn a_second_sync_producer_is_a_foreign_producer() {
    let mut rig = resting_rig();
    rig.bus.inject(Action::Foreign(FOREIGN_SYNC));
    let out = rig.run(2);
    assert_eq!(
        out[0].mode.fault(),
        Some(Fault::ForeignProducer(Foreign::Sync))
    );
    assert_eq!(emcys_of(&out)[0], (0x8150, 0x11, 19, 0, 1));
}

/// Its own TPDO (the status frame, 0x190) from another node is fault 18, as its
/// heartbeat is: another node has its id.
#[test]
fn another_node_sending_the_controllers_status_frame_is_fault_18() {
    let mut rig = resting_rig();
    rig.bus.inject(Action::Foreign(RawFrame {
        id: 0x190,
        len: 8,
        data: [0; 8],
    }));
    let out = rig.run(2);
    assert_eq!(out[0].mode.fault(), Some(Fault::DuplicateNodeId));
}

/// The creep scenario (also a QEMU run): the trolley's axis creeps at 20 mm/s at rest
/// from 10 s; it leaves its 20 mm standstill window a second later: fault 20, EMCY
/// 0x8500 naming it, quick stop, halted. A reset is refused while it still creeps, taken
/// once it holds again; it takes the positions, and the next move ends on its target.
#[test]
fn a_creeping_drive_at_rest_leaves_its_standstill_window() {
    let mut rig = Rig::new(sim::CREEP, true);
    let out = rig.run(sim::CREEP.cycles as usize);
    let faulted = out
        .iter()
        .position(|c| c.mode.fault().is_some())
        .expect("a fault");
    assert_eq!(
        out[faulted].mode,
        Mode::Halted(Fault::Standstill(Drive::Trolley))
    );
    // 20 mm at 20 mm/s: one second after the creep began at 10 s.
    eprintln!(
        "creeping 20 mm/s from 10 s: fault 20 at {} ms",
        faulted * 10
    );
    assert!(
        (1095..=1105).contains(&faulted),
        "fault at {} ms",
        faulted * 10
    );
    assert_eq!(emcys_of(&out), [(0x8500, 0x81, 20, 1, 0)]);
    assert!(sim::CREEP.ends.admits(rig.c.mode()));
    // Still creeping: the reset is refused (a drive reports more than 1 mm/s).
    send(&mut rig, Request::Reset { id: 5 });
    assert_eq!(answers(&rig.run(2)), [(5, 3, 2)]);
    rig.bus
        .inject(Action::Quirk(Drive::Trolley, Quirk::Creeps(0)));
    rig.run(3);
    reset(&mut rig, 6);
    move_ends_on_target(&mut rig, 30, [18.0, 5.0], 4.0);
}

/// A creep too slow for the reset's 1 mm/s (a brake slipping 0.5 mm/s under the load's
/// weight) is caught by position: 20 mm after 40 s.
#[test]
fn a_slowly_slipping_winch_brake_is_caught_by_position() {
    let mut rig = resting_rig();
    rig.bus
        .inject(Action::Quirk(Drive::Winch, Quirk::Creeps(500)));
    let out = rig.until(4_500, |c| c.mode.fault().is_some());
    assert_eq!(
        out.last().unwrap().mode,
        Mode::Halted(Fault::Standstill(Drive::Winch))
    );
    let seconds = out.len() as f64 / 100.0;
    eprintln!("the winch slipping 0.5 mm/s at rest: fault 20 after {seconds} s");
    assert!((39.9..=40.2).contains(&seconds), "{seconds} s");
}

/// A drive that ignores its set point (it stands, its statusword says it follows): the
/// move's first tenths of a metre per second leave the velocity window — fault 21,
/// EMCY 0x8611 detail 2 — before the model has the trolley 0.1 m along.
#[test]
fn a_drive_that_ignores_its_set_point_is_a_following_error() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.bus
        .inject(Action::Quirk(Drive::Trolley, Quirk::IgnoresSetpoint));
    let out = rig.until(1_000, |c| c.mode.fault().is_some());
    assert_eq!(
        out.last().unwrap().mode,
        Mode::QuickStop(Fault::FollowingError(
            Drive::Trolley,
            FollowingError::Velocity
        ))
    );
    assert_eq!(emcys_of(&out), [(0x8611, 0x81, 21, 1, 2)]);
    let model = rig.drives()[0];
    eprintln!(
        "a trolley ignoring its set point from the start: fault 21 at {} ms, the model had it {:.1} mm along",
        out.len() * 10,
        (model - 12.0) * 1e3
    );
    assert!(model - 12.0 < 0.1, "the model had the trolley at {model} m");
    assert!((rig.bus.drive(Drive::Trolley).unwrap().position() - 12.0).abs() < 1e-9);
}

/// One that stops following at full speed, mid-move, is caught within 60 ms.
#[test]
fn a_drive_that_stops_following_mid_move_is_caught_at_once() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(500);
    rig.bus
        .inject(Action::Quirk(Drive::Trolley, Quirk::IgnoresSetpoint));
    let out = rig.until(10, |c| c.mode.fault().is_some());
    assert!(matches!(
        out.last().unwrap().mode,
        Mode::QuickStop(Fault::FollowingError(Drive::Trolley, _))
    ));
    eprintln!(
        "a trolley that stops following at 5 s, mid-move: fault 21 {} cycles later",
        out.len()
    );
    assert!(out.len() <= 6, "{} cycles", out.len());
}

/// A drive that was moved while it did not report (it rebooted at rest, and its axis
/// was pushed 50 mm while it was being commissioned again) is caught by its standstill
/// window when it reports again.
#[test]
fn a_drive_moved_while_it_was_silent_is_caught_when_it_reports_again() {
    let mut rig = resting_rig();
    rig.bus.inject(Action::PowerOn(Drive::Trolley));
    rig.run(1);
    // Pushed while pre-operational (it sends no TPDO), for 0.2 s.
    rig.bus
        .inject(Action::Quirk(Drive::Trolley, Quirk::Creeps(2_000_000)));
    let silent = rig.run(20);
    rig.bus
        .inject(Action::Quirk(Drive::Trolley, Quirk::Creeps(0)));
    assert!(silent.iter().all(|c| c.mode.fault().is_none()));
    let x = rig.bus.drive(Drive::Trolley).unwrap().position();
    assert!(x - 12.0 > 0.04, "it was moved: {x}");
    // The controller commissions and starts it again; its first TPDOs show where it is.
    let out = rig.until(200, |c| c.mode.fault().is_some());
    assert_eq!(
        out.last().unwrap().mode.fault(),
        Some(Fault::Standstill(Drive::Trolley))
    );
}

/// At power-up the model rests where the scene starts; drives elsewhere (the crane was
/// moved while the controller was off) are not where it last brought them: a move is
/// refused, reason 15, and nothing moves. A reset takes their positions; the move then
/// ends on its target.
#[test]
fn a_move_is_refused_while_the_drives_are_not_where_the_controller_left_them() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.bus = VirtualBus::new(HEALTHY, [12.3, 8.0]);
    rig.ready();
    rig.run(60);
    send(
        &mut rig,
        Request::Move {
            id: 1,
            target: [14.0, 7.0],
            duration: Some(6.0),
        },
    );
    let out = rig.run(50);
    assert_eq!(answers(&out), [(1, 3, 15)]);
    assert!(out
        .iter()
        .all(|c| c.setpoints.iter().all(|s| s.units() == 0)));
    assert!(out.iter().all(|c| c.mode == Mode::Ready), "no fault");
    reset(&mut rig, 2);
    move_ends_on_target(&mut rig, 3, [14.0, 7.0], 6.0);
}

/// A reset at rest and ready takes the drives' positions (and is refused while one is
/// not known or still moves): the remedy for reason 15.
#[test]
fn a_reset_at_rest_takes_the_drives_positions() {
    let mut rig = resting_rig();
    rig.bus
        .inject(Action::Quirk(Drive::Winch, Quirk::Creeps(5_000)));
    rig.run(2);
    send(&mut rig, Request::Reset { id: 1 });
    assert_eq!(answers(&rig.run(2)), [(1, 3, 2)], "the winch still moves");
    rig.bus
        .inject(Action::Quirk(Drive::Winch, Quirk::Creeps(0)));
    rig.run(2);
    let l = rig.bus.drive(Drive::Winch).unwrap().position();
    send(&mut rig, Request::Reset { id: 2 });
    assert_eq!(answers(&rig.run(2)), [(2, 1, 0)]);
    assert!((rig.drives()[1] - l).abs() < 1e-6, "the model took {l} m");
}

/// The 3D crane's three drives are supervised alike: a creeping bridge at rest (fault
/// 20 naming node 4), a second master's RPDO to it (fault 19), a hoist that ignores its
/// set point in a 3D move (fault 21), and drives that are not where the model rests
/// (reason 15 until a reset).
mod crane3d {
    use super::*;
    use crate::common3d::{Rig, HOME};
    use scene::cranes::spatial::Spatial;
    use sim::VirtualBus;

    fn resting() -> Rig {
        let mut rig = Rig::new();
        rig.ready();
        rig.run(60);
        rig
    }

    fn until_fault(rig: &mut Rig, max: usize) -> Vec<controller::Cycle<3>> {
        let mut out = Vec::new();
        for _ in 0..max {
            let c = rig.cycle();
            let done = c.mode.fault().is_some();
            out.push(c);
            if done {
                return out;
            }
        }
        panic!("no fault within {max} cycles");
    }

    #[test]
    fn a_creeping_bridge_at_rest_is_a_standstill_fault_naming_node_4() {
        let mut rig = resting();
        rig.bus
            .inject(Action::Quirk(Drive::Bridge, Quirk::Creeps(50_000)));
        let out = until_fault(&mut rig, 100);
        assert_eq!(
            out.last().unwrap().mode,
            Mode::Halted(Fault::Standstill(Drive::Bridge))
        );
        assert_eq!(emcys_of(&out), [(0x8500, 0x81, 20, 4, 0)]);
    }

    #[test]
    fn a_second_master_on_the_bridge_is_a_foreign_producer() {
        let mut rig = resting();
        rig.bus.inject(Action::Foreign(foreign_rpdo(4, 200_000)));
        let out = until_fault(&mut rig, 2);
        assert_eq!(
            out.last().unwrap().mode.fault(),
            Some(Fault::ForeignProducer(Foreign::Rpdo(Drive::Bridge)))
        );
        assert_eq!(emcys_of(&out), [(0x8150, 0x11, 19, 4, 2)]);
    }

    #[test]
    fn a_hoist_that_ignores_its_set_point_is_a_following_error() {
        let mut rig = resting();
        rig.bus
            .inject(Action::Quirk(Drive::Winch, Quirk::IgnoresSetpoint));
        rig.bus.inject(Action::Request(Request::Move3d {
            id: 1,
            target: [16.0, 5.0, 6.0],
            duration: Some(10.0),
        }));
        let out = until_fault(&mut rig, 500);
        assert!(matches!(
            out.last().unwrap().mode.fault(),
            Some(Fault::FollowingError(Drive::Winch, _))
        ));
        assert_eq!(emcys_of(&out)[0].3, 2, "the hoist's node");
    }

    #[test]
    fn a_move_is_refused_while_the_drives_are_not_where_the_model_rests() {
        let mut rig = Rig::new();
        rig.bus = VirtualBus::for_crane(
            HEALTHY,
            &Spatial::EXAMPLE,
            [HOME[0] + 0.2, HOME[1], HOME[2]],
        );
        rig.ready();
        rig.run(60);
        let to = |id| Request::Move3d {
            id,
            target: [16.0, 5.0, 6.0],
            duration: Some(10.0),
        };
        rig.bus.inject(Action::Request(to(1)));
        let out = rig.run(20);
        assert!(out
            .iter()
            .all(|c| c.setpoints.iter().all(|s| s.units() == 0)));
        assert_eq!(
            rig.c.last_answer().2,
            Some(controller::commands::Reject::NotInPlace)
        );
        rig.bus.inject(Action::Request(Request::Reset { id: 2 }));
        rig.run(2);
        assert_eq!(
            rig.c.last_answer(),
            (2, controller::commands::Answer::Accepted, None)
        );
        rig.bus.inject(Action::Request(to(3)));
        rig.run(1_100);
        assert_eq!(rig.c.mode(), Mode::Ready);
        let [x, y, l] = rig.positions();
        assert!((x - 16.0).abs() < 1e-3 && (y - 5.0).abs() < 1e-3 && (l - 6.0).abs() < 1e-3);
    }
}

/// What healthy runs use of the stock windows — the numbers docs/RESULTS.md ("Motion
/// supervision") quotes: every scenario that moves the crane, on the virtual bus's
/// drives without lag (they run τ·v ahead of the model's expectation) and on the plants
/// that are not the model (drive lags 30 % off, friction, noisy sensors a cycle late,
/// gusts), feedforward only and with the feedback, planar and 3D. Each run ends without
/// a fault, and its largest deviations stay below half of each window without its drift
/// allowance; they are printed (`-- --nocapture`).
#[test]
fn healthy_runs_use_less_than_half_of_every_window() {
    use controller::commissioning::{InclinometerSetup, NodeSetup};
    use controller::correction::AxesCorrection;
    use controller::feedback::{self, NoFeedback, StateFeedback};
    use controller::feedforward::{Feedforward, Replan};
    use controller::motion::{Deviations, MotionWindows};
    use controller::planner::Planner;
    use controller::{Config, Controller, Injectable};
    use sim::{run_cycle, Event, Scenario, VirtualBus};

    fn run<F, C, K, const A: usize>(
        mut c: Controller<Injectable<F>, C, K, A>,
        mut bus: VirtualBus<K, A>,
        cycles: u32,
    ) -> [Deviations; A]
    where
        F: Feedforward<A, Reference = K::Reference> + Replan<A>,
        C: AxesCorrection<A, K::Reference>,
        K: sim::simulated::Simulated<A>,
    {
        for now in (0..cycles).map(|k| k * 10) {
            let out = run_cycle(&mut c, &mut bus, now).expect("no hang");
            assert_eq!(out.mode.fault(), None, "at {now} ms");
        }
        c.motion_deviations()
    }
    // The planar crane with the paper's move planned at boot, as the firmware runs it.
    fn planar<C: AxesCorrection<2, feedback::Reference>>(
        correction: C,
        scenario: Scenario,
        cycles: u32,
    ) -> [Deviations; 2] {
        let ff = feedforward(HOME, Some(([20.0, 4.0], 1.0, 8.0)));
        let config = Config::DEFAULT.with_node(NodeSetup::Inclinometer(InclinometerSetup::STOCK));
        let mut c = Controller::with_correction(ff, correction, planner(), config);
        c.demonstration_commanded();
        run(c, VirtualBus::new(scenario, HOME), cycles)
    }
    // The 3D crane, `scenario`'s events with a 3D move (12, 3, 8) → (20, 6, 4) in 9 s
    // asked at 1 s among them.
    fn spatial<C: AxesCorrection<3, [feedback::Reference; 2]>>(
        correction: C,
        scenario: Scenario,
    ) -> [Deviations; 3] {
        use scene::cranes::spatial::Spatial;
        let planner = Planner::with_axes(Spatial::EXAMPLE, crate::common3d::limits());
        let config = crate::common3d::config()
            .with_node(NodeSetup::Inclinometer(InclinometerSetup::STOCK_TWO_AXES));
        let c = Controller::with_correction(
            crate::common3d::feedforward(),
            correction,
            planner,
            config,
        );
        run(
            c,
            VirtualBus::for_crane(scenario, &Spatial::EXAMPLE, crate::common3d::HOME),
            1_600,
        )
    }
    let planar_feedback = || StateFeedback::new(feedback::Config::PAPER).unwrap();
    let spatial_feedback = || {
        let c = solver_core::models::crane3d::Crane3dParams::EXAMPLE;
        let config = feedback::Config {
            tau1: c.tau1,
            tau2: c.tau3,
            ..feedback::Config::PAPER
        };
        controller::feedback3d::SpatialFeedback::new(config, c.tau2).unwrap()
    };
    const MOVE_3D: Event = Event {
        at_ms: 1_000,
        action: Action::Request(Request::Move3d {
            id: 1,
            target: [20.0, 6.0, 4.0],
            duration: Some(9.0),
        }),
    };
    const LOST_3D: [Event; 2] = [
        MOVE_3D,
        Event {
            at_ms: 5_000,
            action: Action::Sensor(sim::SensorFault::Lost),
        },
    ];
    let with_move = |s: Scenario| Scenario {
        events: if s.name == sim::INCLINOMETER_LOST.name {
            &LOST_3D
        } else {
            &[MOVE_3D]
        },
        ..s
    };
    let mut rows: Vec<(String, Vec<Deviations>)> = Vec::new();
    // Planar, the virtual bus's drives: every scenario that moves and ends ready.
    for s in [
        sim::HEALTHY,
        sim::TWO_MOVES,
        sim::REJECTIONS,
        sim::STORM,
        sim::STOP,
    ] {
        let cycles = if s.cycles == 0 { 1_200 } else { s.cycles };
        rows.push((
            format!("planar {}", s.name),
            planar(NoFeedback, s, cycles).to_vec(),
        ));
    }
    // Planar, the plant: feedforward alone and with the feedback.
    for s in sim::FEEDBACK_SCENARIOS {
        rows.push((
            format!("planar {} feedforward", s.name),
            planar(NoFeedback, s, 1_600).to_vec(),
        ));
        rows.push((
            format!("planar {} feedback", s.name),
            planar(planar_feedback(), s, 1_600).to_vec(),
        ));
    }
    // 3D, its drives and its plant.
    rows.push((
        "3d move".into(),
        spatial(NoFeedback, with_move(sim::HEALTHY)).to_vec(),
    ));
    for s in sim::CRANE3D_FEEDBACK_SCENARIOS.map(with_move) {
        rows.push((
            format!("3d {} feedforward", s.name),
            spatial(NoFeedback, s).to_vec(),
        ));
        rows.push((
            format!("3d {} feedback", s.name),
            spatial(spatial_feedback(), s).to_vec(),
        ));
    }
    let w = MotionWindows::STOCK;
    eprintln!(
        "largest deviation per drive (model's order): standstill mm (window {} mm) / position mm (window {} mm + {} of the travel) / velocity mm/s (window {} mm/s + {} of it)",
        w.standstill * 1e3,
        w.following * 1e3,
        w.following_drift,
        w.velocity * 1e3,
        w.following_drift
    );
    let mut most = Deviations::default();
    for (name, deviations) in &rows {
        let cells: Vec<String> = deviations
            .iter()
            .map(|d| {
                format!(
                    "{:5.1} / {:5.1} / {:5.1}",
                    d.standstill * 1e3,
                    d.position * 1e3,
                    d.velocity * 1e3
                )
            })
            .collect();
        eprintln!("{name:40} {}", cells.join("   "));
        for d in deviations {
            most.standstill = most.standstill.max(d.standstill);
            most.position = most.position.max(d.position);
            most.velocity = most.velocity.max(d.velocity);
        }
    }
    eprintln!(
        "most of all: standstill {:.1} mm, position {:.1} mm, velocity {:.1} mm/s",
        most.standstill * 1e3,
        most.position * 1e3,
        most.velocity * 1e3
    );
    assert!(most.standstill < 0.5 * w.standstill, "{most:?}");
    assert!(most.position < 0.5 * w.following, "{most:?}");
    assert!(most.velocity < 0.5 * w.velocity, "{most:?}");
}
