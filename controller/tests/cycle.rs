//! The 100 Hz cycle with injected time, frame by frame: the NMT/SYNC/heartbeat
//! schedule, the CiA 402 enable sequence, set points that carry the model's inputs
//! through the choke point, and the reaction to each fault that the scenarios
//! (tests/scenarios.rs) do not reach: deadline misses, a refused set point, a drive
//! that drops out of operation, drives that never boot, malformed commands.

mod common;

use common::*;
use controller::canopen::{self, NmtState};
use controller::cia402::controlword as cw;
use controller::cia402::pdo;
use controller::commands::{request_frame, Answer, Reject, Request};
use controller::commissioning::{CommissioningError, Phase};
use controller::drive::{Drive, PLANAR};
use controller::setpoint::{SetpointError, UNITS_PER_M_PER_S};
use controller::{CanFrame, Config, Fault, Mode, Replan};
use nalgebra::SVector;
use sim::{Action, HEALTHY};
use solver_core::trajectory::PointToPoint;

fn ids(frames: &[CanFrame]) -> Vec<u16> {
    frames.iter().map(CanFrame::id).collect()
}

/// The cycle in which the drives got their first RPDO (their commissioning ended).
fn linked(rig: &mut Rig) -> Vec<controller::Cycle> {
    rig.until(120, |c| c.frames.iter().any(|f| f.id() == 0x201))
}

#[test]
fn schedule_boot_up_commissioning_then_pdos_sync_and_a_heartbeat_with_status_every_100_ms() {
    let mut rig = Rig::new(HEALTHY, true);
    let first = rig.cycle();
    // Boot-up, then each drive's commissioning starts (its boot-up was heard): NMT
    // pre-operational to that drive, then 0x1000.
    assert_eq!(ids(&first.frames), vec![0x710, 0x000, 0x000, 0x080]);
    assert_eq!(first.frames[0].data(), &[0x00], "boot-up");
    assert_eq!(first.frames[1].data(), &[0x80, 1]);
    let second = rig.cycle();
    assert_eq!(ids(&second.frames), vec![0x601, 0x602, 0x080]);
    assert_eq!(second.frames[0].data(), &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0]);
    let before = linked(&mut rig);
    // No NMT broadcast ever: each drive is started by its own addressed NMT command.
    let nmt: Vec<&[u8]> = before
        .iter()
        .flat_map(|c| c.frames.iter())
        .filter(|f| f.id() == 0x000)
        .map(CanFrame::data)
        .collect();
    assert_eq!(nmt, [[0x01, 1], [0x01, 2]]);
    assert!(before
        .iter()
        .flat_map(|c| c.frames.iter())
        .all(|f| !matches!(f.id(), 0x201 | 0x202) || f.data()[2..] == [0; 4]));
    let start = rig.c.counters().cycles;
    for cycle in start..start + 30 {
        let out = rig.cycle();
        let mut expected = vec![0x201, 0x202, 0x080];
        if cycle % 10 == 0 {
            expected.extend([0x710, 0x190]);
        }
        assert_eq!(ids(&out.frames), expected, "cycle {cycle}");
    }
}

#[test]
fn drives_are_walked_to_operation_enabled() {
    let mut rig = Rig::new(HEALTHY, true);
    linked(&mut rig);
    let words: Vec<[u16; 2]> = rig
        .run(4)
        .iter()
        .map(|c| PLANAR.map(|d| rpdo(&c.frames, d).0))
        .collect();
    // The first RPDO knew no state yet and sent *shutdown*; the drives answer each SYNC,
    // and each following cycle takes the next step.
    let expected = [
        cw::SWITCH_ON,
        cw::ENABLE_OPERATION,
        cw::ENABLE_OPERATION,
        cw::ENABLE_OPERATION,
    ];
    assert_eq!(words, expected.map(|w| [w, w]).to_vec());
    rig.ready();
    for d in PLANAR {
        assert_eq!(
            rig.bus.drive(d).unwrap().mode(),
            9,
            "cyclic synchronous velocity"
        );
    }
}

#[test]
fn set_points_carry_the_model_inputs_in_drive_units() {
    let mut rig = Rig::new(HEALTHY, true);
    linked(&mut rig);
    let mut moving = 0;
    for out in rig.run(1000) {
        let step = out.step.expect("a step every cycle while ready");
        for (i, d) in PLANAR.into_iter().enumerate() {
            let (word, v) = rpdo(&out.frames, d);
            if out.mode == Mode::Ready {
                assert_eq!(word, cw::ENABLE_OPERATION);
            }
            assert_eq!(v, (step.u[i] * UNITS_PER_M_PER_S).round() as i32);
            moving += usize::from(v != 0);
        }
    }
    assert!(
        moving > 1000,
        "the paper's move: {moving} non-zero set points"
    );
}

#[test]
fn one_deadline_miss_is_counted_a_second_within_the_window_stops() {
    let budget = Config::DEFAULT.cycle_budget();
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(300);
    rig.c.record_cost(budget + 1);
    rig.run(101); // beyond the 100-cycle window
    rig.c.record_cost(budget + 1);
    let out = rig.run(50);
    assert_eq!(
        rig.c.mode(),
        Mode::Ready,
        "two misses 101 cycles apart: counted only"
    );
    assert_eq!(status(&out[9].frames).unwrap()[6], 2, "reported");
    rig.c.record_cost(budget);
    rig.run(10);
    rig.c.record_cost(budget + 1);
    let out = rig.cycle();
    assert_eq!(out.mode, Mode::Stopping(Fault::Deadline));
    assert_eq!(emcy(&out.frames), Some((0xFF01, 0x81, 5, 0)));
    assert_eq!(rig.c.counters().deadline_misses, 3);
}

#[test]
fn a_set_point_beyond_the_limits_is_refused_at_the_choke_point() {
    // A move the planner would refuse (8 m in 2 s), pushed behind its back.
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    let plan = rig.c.feedforward_mut().plan_mut();
    let t0 = f64::from(rig.now) / 1000.0 + 0.5;
    let fast =
        PointToPoint::new(SVector::from(HOME), SVector::from([20.0, 8.0]), t0, 2.0, 4).unwrap();
    plan.push(fast).unwrap();
    let out = rig.until(200, |c| c.mode != Mode::Ready);
    let last = out.last().unwrap();
    // Refused at the move's first step: nothing had been sent yet, so there is nothing
    // to ramp down and the controlled stop is at standstill at once.
    let Mode::Halted(Fault::Setpoint(SetpointError::OverAcceleration {
        drive,
        value,
        limit,
    })) = last.mode
    else {
        panic!("{:?}", last.mode)
    };
    assert_eq!(drive, Drive::Trolley);
    assert!(value > limit);
    assert_eq!(emcy(&last.frames), Some((0xFF03, 0x81, 2, 1)));
    assert_eq!(emcy_detail(&last.frames), Some(3), "over acceleration");
    // The refused value never left: every set point sent was zero.
    assert!(out.iter().all(|c| c.setpoints.map(|s| s.units()) == [0, 0]));
    let (word, _) = rpdo(&last.frames, Drive::Trolley);
    assert_eq!(
        word,
        cw::ENABLE_OPERATION,
        "the halt's quick stop follows from the next cycle"
    );
    assert_eq!(
        rpdo(&rig.cycle().frames, Drive::Trolley),
        (cw::QUICK_STOP, 0)
    );
}

#[test]
fn a_drive_that_leaves_operation_while_moving_stops_the_crane() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(300);
    // The winch drops to *switch on disabled* (say, its safe torque off input) without a
    // fault in the middle of the move; the controller sees it in the next TPDO.
    rig.bus.inject(Action::DropOut(Drive::Winch));
    rig.cycle();
    let out = rig.cycle();
    assert_eq!(out.mode, Mode::Stopping(Fault::DriveNotReady(Drive::Winch)));
    assert_eq!(emcy(&out.frames), Some((0xFF04, 0x81, 7, 2)));
}

#[test]
fn drives_that_never_answer_are_looked_for_then_a_named_commissioning_failure() {
    // No bus at all: the controller alone, ticked, nothing asked of it.
    let mut c = Rig::new(HEALTHY, false).c;
    let boot_time = c.config().boot_time_ms;
    let mut presence = Vec::new();
    let mut emcys = Vec::new();
    for i in 0..=1200u64 {
        let out = c.tick(i * 10);
        let expected = if i * 10 < u64::from(boot_time) {
            Mode::Enabling
        } else {
            Mode::Halted(Fault::Commissioning(
                Drive::Trolley,
                CommissioningError::NeverAppeared {
                    waited_ms: boot_time,
                },
            ))
        };
        assert_eq!(out.mode, expected, "at {} ms", i * 10);
        assert!(
            out.frames.iter().all(|f| !matches!(f.id(), 0x201 | 0x202)),
            "no set point to a drive that is not commissioned"
        );
        if out.frames.iter().any(|f| f.id() == 0x601) {
            presence.push(i * 10);
        }
        emcys.extend(
            out.frames
                .iter()
                .filter(|f| f.id() == 0x090)
                .map(|f| (i * 10, f.data().to_vec())),
        );
    }
    // 0x1000 is read once a second (presence check, CiA 302) for the boot time (10 s),
    // then the drive that never answered is a commissioning failure naming it, the object
    // looked for, reason 7, and the SDO timeout — for both drives.
    assert_eq!(
        presence,
        [0, 1000, 2000, 3000, 4000, 5000, 6000, 7000, 8000, 9000]
    );
    assert!(matches!(
        c.commissioning(Drive::Trolley),
        Phase::Failed(CommissioningError::NeverAppeared { .. })
    ));
    let at = u64::from(boot_time);
    assert_eq!(
        emcys,
        [
            (at, vec![0x10, 0xFF, 0x81, 12, 1, 0, 0x00, 0x10]),
            (at, vec![0x12, 0xFF, 0x81, 16, 0x00, 0x00, 0x04, 0x05]),
            (at, vec![0x10, 0xFF, 0x81, 12, 2, 0, 0x00, 0x10]),
            (at, vec![0x12, 0xFF, 0x81, 16, 0x00, 0x00, 0x04, 0x05]),
        ]
    );

    // A demonstration move planned for 1 s (the QEMU main job's) with no drive there:
    // the documented reaction, not motion: halted, and still no set point.
    let mut c = Rig::new(HEALTHY, true).c;
    for i in 0..=150 {
        let out = c.tick(i * 10);
        assert!(out.frames.iter().all(|f| !matches!(f.id(), 0x201 | 0x202)));
    }
    assert_eq!(c.mode(), Mode::Halted(Fault::DriveNotReady(Drive::Trolley)));
}

#[test]
fn malformed_commands_are_ignored_counted_and_change_nothing() {
    let garbage = [
        CanFrame::new(0x210, &[1, 1, 0x20, 0x4E]).unwrap(), // short move
        CanFrame::new(0x210, &[2, 9, 0, 0, 0, 0, 0, 0]).unwrap(), // unknown command
        CanFrame::new(0x210, &[3, 2, 0, 0, 0, 0, 1, 0]).unwrap(), // stop with a duration
        CanFrame::new(0x210, &[4, 3, 0xFF, 0, 0, 0, 0, 0]).unwrap(), // reset with a target
        CanFrame::new(0x181, &[0x37, 0x02]).unwrap(),       // short TPDO
        CanFrame::new(0x555, &[0; 8]).unwrap(),             // unknown id
    ];
    let (mut clean, mut noisy) = (Rig::new(HEALTHY, true), Rig::new(HEALTHY, true));
    for i in 0..400 {
        if i % 40 == 7 {
            for g in &garbage {
                noisy.c.on_frame(g, noisy.now.into());
            }
        }
        let (a, b) = (clean.cycle(), noisy.cycle());
        assert_eq!(a.setpoints, b.setpoints, "cycle {i}");
        assert_eq!(a.mode, b.mode, "cycle {i}");
    }
    assert_eq!(noisy.c.counters().frames_ignored, 10 * 6);
    assert_eq!(noisy.c.counters().requests, 0, "none of them was answered");
}

/// Each TPDO counts once: received if the CiA 301 layer and the drive profile
/// (CiA 402) understand it, ignored if either refuses it or no drive is at its node; a
/// drive still being commissioned has its TPDO received and not acted on.
#[test]
fn tpdos_are_counted_received_or_ignored() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.cycle();
    assert_ne!(rig.c.commissioning(Drive::Trolley), Phase::Done);
    let cases = [
        // (frame, received, ignored)
        (pdo::tpdo1(1, 0x0250, 0), 1, 0),    // drive not linked yet
        (pdo::tpdo2(2, 8_000_000, 9), 1, 0), // drive not linked yet
        (CanFrame::new(0x181, &[0x37, 0x02]).unwrap(), 0, 1), // TPDO1 too short
        (CanFrame::new(0x282, &[0; 6]).unwrap(), 0, 1), // TPDO2 too long
        (pdo::tpdo1(5, 0x0237, 0), 1, 1),    // no drive at node 5
        (pdo::tpdo2(9, 0, 9), 1, 1),         // no drive at node 9
    ];
    for (frame, received, ignored) in cases {
        assert_eq!(rig.counted(&frame), (received, ignored), "{frame:?}");
    }
    assert_eq!(rig.c.mode(), Mode::Enabling, "none of them is a fault");
}

#[test]
fn a_reset_is_refused_while_stopping_and_accepted_when_halted() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(500);
    rig.c.feedforward_mut().fail_next_step();
    rig.cycle();
    rig.c
        .on_frame(&request_frame(&Request::Reset { id: 5 }), rig.now.into());
    let out = rig.cycle();
    assert!(matches!(out.mode, Mode::Stopping(_)));
    assert_eq!(
        status(&out.frames).unwrap()[..3],
        [5, 3, 2],
        "rejected: not ready"
    );
    rig.until(200, |c| matches!(c.mode, Mode::Halted(_)));
    rig.c
        .on_frame(&request_frame(&Request::Reset { id: 6 }), rig.now.into());
    let out = rig.cycle();
    assert_eq!(out.mode, Mode::Enabling);
    assert_eq!(status(&out.frames).unwrap()[..3], [6, 1, 0]);
    assert_eq!(emcy(&out.frames), Some((0, 0, 0, 0)), "error reset");
    rig.until(20, |c| c.mode == Mode::Ready);
}

#[test]
fn a_stop_drops_the_queued_move() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(200);
    let next = Request::Move {
        id: 1,
        target: [15.0, 6.0],
        duration: Some(6.0),
    };
    rig.c.on_frame(&request_frame(&next), rig.now.into());
    let out = rig.cycle();
    assert_eq!(status(&out.frames).unwrap()[..3], [1, 2, 0], "queued");
    rig.run(100);
    rig.c
        .on_frame(&request_frame(&Request::Stop { id: 2 }), rig.now.into());
    let out = rig.cycle();
    // The queued move answered again, refused (it will not run), then the stop.
    assert_eq!(
        every_answer(std::slice::from_ref(&out)),
        [(1, 3, 2), (2, 1, 0)]
    );
    let rest = rig.run(1500);
    assert!(rest.iter().all(|c| c.mode == Mode::Ready));
    // The scene's move runs (12, 8) → (20, 4); the queued target (15, 6) is off that
    // path. The stop ends on it, short of its target.
    let end = rig.c.feedforward().plan().final_position();
    let sigma = (end[0] - 12.0) / 8.0;
    assert!(
        sigma > 0.0 && sigma < 1.0 && (end[1] - (8.0 - 4.0 * sigma)).abs() < 1e-9,
        "stopped on the running move's path, short of its target: {end:?}"
    );
    assert_within_limits(&rest, &mut out.setpoints.map(|s| s.units()));
}

#[test]
fn a_stop_at_rest_is_accepted_and_changes_nothing() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    rig.c
        .on_frame(&request_frame(&Request::Stop { id: 9 }), rig.now.into());
    let out = rig.cycle();
    assert_eq!(status(&out.frames).unwrap()[..3], [9, 1, 0]);
    assert_eq!(
        rig.c.feedforward().plan().final_position(),
        SVector::from(HOME)
    );
    assert_eq!(out.setpoints.map(|s| s.units()), [0, 0]);
}

#[test]
fn a_drive_heartbeat_alone_keeps_it_alive() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.ready();
    for d in PLANAR {
        rig.c.on_frame(
            &canopen::heartbeat(d.node(), NmtState::Operational),
            rig.now.into(),
        );
    }
    assert_eq!(rig.cycle().mode, Mode::Ready);
}

/// The 3D move frame (RPDO2, 0x310) names a y the planar crane does not have: answered
/// *rejected*, reason 3 (invalid), and nothing moves.
#[test]
fn the_planar_crane_rejects_a_3d_move() {
    let mut rig = Rig::new(HEALTHY, false);
    // Invalid before the drives are ready too: the answer does not depend on when the
    // request came (not "not ready" now and "invalid" later).
    rig.bus.inject(Action::Request(Request::Move3d {
        id: 4,
        target: [20.0, 1.0, 4.0],
        duration: None,
    }));
    rig.run(5);
    assert_eq!(
        rig.c.last_answer(),
        (4, Answer::Rejected, Some(Reject::Invalid))
    );
    rig.ready();
    rig.bus.inject(Action::Request(Request::Move3d {
        id: 5,
        target: [20.0, 1.0, 4.0],
        duration: None,
    }));
    let out = rig.run(50);
    assert_eq!(
        rig.c.last_answer(),
        (5, Answer::Rejected, Some(Reject::Invalid))
    );
    assert!(out
        .iter()
        .all(|c| c.setpoints.iter().all(|s| s.units() == 0)));
    assert!(!rig
        .c
        .feedforward()
        .plan()
        .is_moving(f64::from(rig.now) / 1000.0));
}
