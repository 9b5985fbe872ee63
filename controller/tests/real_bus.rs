//! The cases found when the controller was tried against an independent CANopen stack
//! (python-canopen drives over SLCAN), each replayed on the virtual bus's stock CiA 402
//! drives: commissioning, supervision, requests, resets, and the controller as a node.

mod common;

use common::*;
use controller::canopen::{self, nmt, NmtCommand, NmtState};
use controller::cia402::pdo;
use controller::commands::{Request, STATUS_ID};
use controller::commissioning::{CommissioningError, Phase};
use controller::drive::{Drive, PLANAR};
use controller::node::Role;
use controller::{CanFrame, Config, Cycle, Fault, Mode};
use sim::{Action, Quirk, HEALTHY};

fn frames_with(cycles: &[Cycle], id: u16) -> Vec<Vec<u8>> {
    cycles
        .iter()
        .flat_map(|c| c.frames.iter())
        .filter(|f| f.id() == id)
        .map(|f| f.data().to_vec())
        .collect()
}

fn sdo_read(rig: &mut Rig, index: u16, sub: u8) -> [u8; 8] {
    let [i0, i1] = index.to_le_bytes();
    let req = CanFrame::new(0x610, &[0x40, i0, i1, sub, 0, 0, 0, 0]).unwrap();
    rig.c.on_frame(&req, u64::from(rig.now));
    let out = rig.cycle();
    let resp = out
        .frames
        .iter()
        .find(|f| f.id() == 0x590)
        .expect("the SDO server answers in the next cycle");
    resp.data().try_into().unwrap()
}

/// Commands the move to (16 m, 6 m) in 6 s as request 1: accepted, and the drives arrive.
fn move_and_arrive(rig: &mut Rig) {
    send(
        rig,
        Request::Move {
            id: 1,
            target: [16.0, 6.0],
            duration: Some(6.0),
        },
    );
    let moved = rig.run(700);
    assert_eq!(answers(&moved), [(1, 1, 0)]);
    assert!((rig.bus.drive(Drive::Trolley).unwrap().position() - 16.0).abs() < 1e-3);
    assert!((rig.bus.drive(Drive::Winch).unwrap().position() - 6.0).abs() < 1e-3);
}

#[test]
fn drives_powered_after_the_controller_are_commissioned_when_they_boot_and_nothing_moves() {
    let mut rig = Rig::new(HEALTHY, false);
    for d in PLANAR {
        rig.bus.inject(Action::PowerOff(d));
    }
    let waiting = rig.run(150);
    assert!(waiting.iter().all(|c| c.mode == Mode::Enabling));
    assert!(frames_with(&waiting, 0x201).is_empty() && frames_with(&waiting, 0x090).is_empty());
    // 1.5 s after the controller, the drives are powered: their boot-up starts it all.
    for d in PLANAR {
        rig.bus.inject(Action::PowerOn(d));
    }
    let booting = rig.until(120, |c| c.mode == Mode::Ready);
    assert_eq!(
        frames_with(&booting, 0x000),
        [[0x80, 1], [0x80, 2], [0x01, 1], [0x01, 2]],
        "each drive switched and started by its own addressed NMT command"
    );
    for d in PLANAR {
        assert_eq!(rig.bus.drive(d).unwrap().nmt(), NmtState::Operational);
        assert_eq!(rig.c.commissioning(d), Phase::Done);
    }
    // Ready, and nothing moves without a command.
    let idle = rig.run(300);
    assert!(idle.iter().all(|c| c.mode == Mode::Ready));
    assert!(idle
        .iter()
        .all(|c| c.setpoints.map(|s| s.units()) == [0, 0]));
    // A move on command is executed.
    move_and_arrive(&mut rig);
}

#[test]
fn drives_left_in_profile_position_mode_are_switched_to_csv_with_the_cycle_time() {
    let mut rig = Rig::new(HEALTHY, true);
    assert_eq!(
        rig.bus.drive(Drive::Trolley).unwrap().mode(),
        1,
        "profile position at boot"
    );
    rig.ready();
    for d in PLANAR {
        let sim = rig.bus.drive(d).unwrap();
        assert_eq!(sim.mode(), 9, "cyclic synchronous velocity");
        assert_eq!(sim.object(0x60C2, 1), 10, "interpolation period 10 (ms)");
        assert_eq!(sim.object(0x60C2, 2), 0xFD, "… × 10^-3 s");
        assert_eq!(sim.object(0x1A01, 1), 0x6064_0020, "position actual mapped");
        assert_eq!(sim.object(0x1800, 2), 1, "synchronous TPDO");
        assert_eq!(
            sim.object(0x1016, 1),
            0x0010_012C,
            "watches the controller: 300 ms"
        );
    }
    // The paper's move then reaches the drives as set points they follow.
    let cycles = rig.run(900);
    assert_within_limits(&cycles, &mut [0; 2]);
    assert!((rig.bus.drive(Drive::Trolley).unwrap().position() - 20.0).abs() < 1e-3);
    assert!((rig.bus.drive(Drive::Winch).unwrap().position() - 4.0).abs() < 1e-3);
}

#[test]
fn a_drive_that_does_not_confirm_csv_is_never_sent_a_set_point() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.bus
        .inject(Action::Quirk(Drive::Winch, Quirk::ReportsMode(1)));
    let cycles = rig.run(300);
    let fault = Fault::Commissioning(Drive::Winch, CommissioningError::Mode { found: 1 });
    assert_eq!(rig.c.mode(), Mode::Halted(fault));
    assert!(
        frames_with(&cycles, 0x202).is_empty(),
        "no PDO to the winch"
    );
    assert!(cycles
        .iter()
        .all(|c| c.setpoints.map(|s| s.units()) == [0, 0]));
    // EMCY 0xFF10: fault 12, node 2, object 0x6061:00; then EMCY 0xFF12: no SDO abort
    // (the drive answered, with the wrong mode).
    assert_eq!(
        frames_with(&cycles, 0x090),
        [
            [0x10, 0xFF, 0x81, 12, 2, 0x00, 0x61, 0x60],
            [0x12, 0xFF, 0x81, 16, 0, 0, 0, 0]
        ]
    );
    let last_status = cycles.iter().rev().find_map(|c| status(&c.frames)).unwrap();
    assert_eq!(last_status[3..5], [4, 12], "halted, commissioning");
    // A drive that switches mode at run time is caught by its mode display.
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(300);
    rig.bus
        .inject(Action::Quirk(Drive::Trolley, Quirk::ReportsMode(3)));
    rig.run(3);
    assert_eq!(
        rig.c.mode(),
        Mode::QuickStop(Fault::DriveMode(Drive::Trolley))
    );
}

#[test]
fn a_drive_that_refuses_csv_is_left_disabled_and_the_abort_code_is_readable() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.bus
        .inject(Action::Quirk(Drive::Trolley, Quirk::RefusesCsv));
    let cycles = rig.run(100);
    let Mode::Halted(Fault::Commissioning(Drive::Trolley, CommissioningError::Sdo(e))) =
        rig.c.mode()
    else {
        panic!("{:?}", rig.c.mode())
    };
    assert_eq!(
        (e.object().index, e.object().sub, e.code()),
        (0x6060, 0, 0x0609_0030)
    );
    // EMCY 0xFF10 names the drive and the object, EMCY 0xFF12 the abort code.
    assert_eq!(
        frames_with(&cycles, 0x090),
        [
            [0x10, 0xFF, 0x81, 12, 1, 0x00, 0x60, 0x60],
            [0x12, 0xFF, 0x81, 16, 0x30, 0x00, 0x09, 0x06]
        ]
    );
    assert!(frames_with(&cycles, 0x201).is_empty());
    // The controller's object dictionary names the failure with its abort code.
    assert_eq!(
        sdo_read(&mut rig, 0x2002, 1),
        [0x4F, 0x02, 0x20, 1, 1, 0, 0, 0]
    );
    assert_eq!(
        sdo_read(&mut rig, 0x2002, 2),
        [0x4B, 0x02, 0x20, 2, 0x60, 0x60, 0, 0]
    );
    assert_eq!(
        sdo_read(&mut rig, 0x2002, 4),
        [0x43, 0x02, 0x20, 4, 0x30, 0x00, 0x09, 0x06]
    );
    // The status frame shows halted by fault 12.
    let out = rig.run(10);
    let s = out.iter().find_map(|c| status(&c.frames)).unwrap();
    assert_eq!(s[3..5], [4, 12]);
}

#[test]
fn an_sdo_timeout_is_a_commissioning_failure_with_the_object_named() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.bus.inject(Action::Quirk(Drive::Winch, Quirk::SdoMute));
    let cycles = rig.run(50);
    let Mode::Halted(Fault::Commissioning(Drive::Winch, CommissioningError::Sdo(e))) = rig.c.mode()
    else {
        panic!("{:?}", rig.c.mode())
    };
    assert_eq!(
        (e.object().index, e.code()),
        (0x1000, 0x0504_0000),
        "timed out"
    );
    // The client told the server it gave up (abort 0x0504_0000 on 0x602).
    assert!(frames_with(&cycles, 0x602).contains(&vec![0x80, 0, 0x10, 0, 0, 0, 4, 5]));
}

#[test]
fn a_drive_that_reboots_mid_move_quick_stops_the_crane_and_moves_are_refused() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(400);
    rig.bus.inject(Action::PowerOn(Drive::Winch)); // a reboot: boot-up message
    let out = rig.run(2);
    assert_eq!(
        rig.c.mode(),
        Mode::QuickStop(Fault::DriveLeftOperational(Drive::Winch, NmtState::BootUp))
    );
    assert_eq!(
        frames_with(&out, 0x090),
        [[0x30, 0x81, 0x11, 9, 2, 0, 0, 0]],
        "EMCY 0x8130, fault 9, winch, boot-up"
    );
    send(
        &mut rig,
        Request::Move {
            id: 7,
            target: [14.0, 6.0],
            duration: Some(5.0),
        },
    );
    let out = rig.run(2);
    assert_eq!(answers(&out), [(7, 3, 2)], "not ready");
    // It is commissioned again meanwhile; after the halt a reset makes the crane ready.
    rig.until(300, |c| matches!(c.mode, Mode::Halted(_)));
    rig.run(100);
    assert_eq!(rig.c.commissioning(Drive::Winch), Phase::Done);
    send(&mut rig, Request::Reset { id: 8 });
    rig.until(100, |c| c.mode == Mode::Ready);
}

#[test]
fn a_drive_put_into_nmt_stopped_or_pre_operational_mid_move_is_noticed() {
    for command in [NmtCommand::Stop, NmtCommand::PreOperational] {
        let mut rig = Rig::new(HEALTHY, true);
        rig.run(400);
        rig.bus.inject(Action::Nmt(Drive::Trolley, command));
        rig.run(8);
        // Its TPDOs stop at once (PDOs flow only in operational) and its next heartbeat
        // says why: whichever comes first, a quick stop within 80 ms.
        let state = match command {
            NmtCommand::Stop => NmtState::Stopped,
            _ => NmtState::PreOperational,
        };
        let mode = rig.c.mode();
        assert!(
            mode == Mode::QuickStop(Fault::TpdoTimeout(Drive::Trolley))
                || mode == Mode::QuickStop(Fault::DriveLeftOperational(Drive::Trolley, state)),
            "{command:?}: {mode:?}"
        );
    }
}

#[test]
fn a_drive_that_reboots_at_rest_is_commissioned_and_enabled_again() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    rig.run(50);
    rig.bus.inject(Action::PowerOn(Drive::Trolley));
    let out = rig.until(150, |c| c.mode == Mode::Ready);
    assert_eq!(out[1].mode, Mode::Enabling);
    // Announced as a warning (error register without the generic bit), no fault.
    assert_eq!(
        frames_with(&out, 0x090),
        [[0x30, 0x81, 0x10, 9, 1, 0, 0, 0]]
    );
    assert!(out.iter().all(|c| c.mode.fault().is_none()));
    assert_eq!(rig.c.counters().commissioned, 3);
}

#[test]
fn nmt_commands_to_the_controller_are_obeyed_and_its_dictionary_is_served() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    let ignored = rig.c.counters().frames_ignored;
    rig.c
        .on_frame(&nmt::command(NmtCommand::Stop, 0x10), u64::from(rig.now));
    let out = rig.run(20);
    assert_eq!(rig.c.nmt_state(), NmtState::Stopped);
    assert!(frames_with(&out, 0x710).iter().all(|d| d == &[0x04]));
    assert!(
        frames_with(&out, STATUS_ID).is_empty(),
        "no PDO while stopped"
    );
    // A move while stopped is not processed (PDO).
    send(
        &mut rig,
        Request::Move {
            id: 3,
            target: [14.0, 6.0],
            duration: Some(5.0),
        },
    );
    // Broadcast start.
    rig.c
        .on_frame(&nmt::command(NmtCommand::Start, 0), u64::from(rig.now));
    let out = rig.run(20);
    assert_eq!(rig.c.nmt_state(), NmtState::Operational);
    assert!(frames_with(&out, 0x710).iter().all(|d| d == &[0x05]));
    assert!(
        answers(&out).is_empty(),
        "the move sent while stopped was not taken"
    );
    assert_eq!(
        rig.c.counters().frames_ignored,
        ignored + 1,
        "only that move"
    );
    // Its dictionary: identity, cycle period, heartbeat time (written and read back:
    // 150 ms, the most its drives' 300 ms consumers tolerate).
    assert_eq!(
        sdo_read(&mut rig, 0x1018, 0),
        [0x4F, 0x18, 0x10, 0, 4, 0, 0, 0]
    );
    assert_eq!(
        sdo_read(&mut rig, 0x1006, 0),
        [0x43, 0x06, 0x10, 0, 0x10, 0x27, 0, 0]
    );
    let write = CanFrame::new(0x610, &[0x2B, 0x17, 0x10, 0, 0x96, 0, 0, 0]).unwrap();
    rig.c.on_frame(&write, u64::from(rig.now));
    assert_eq!(
        frames_with(&[rig.cycle()], 0x590),
        [[0x60, 0x17, 0x10, 0, 0, 0, 0, 0]]
    );
    assert_eq!(
        sdo_read(&mut rig, 0x1017, 0),
        [0x4B, 0x17, 0x10, 0, 0x96, 0, 0, 0]
    );
    // A reset of communication: boot-up, the defaults again, operational (manager).
    rig.c.on_frame(
        &nmt::command(NmtCommand::ResetCommunication, 0x10),
        u64::from(rig.now),
    );
    let out = rig.run(2);
    assert_eq!(frames_with(&out, 0x710)[0], [0x00]);
    assert_eq!(rig.c.nmt_state(), NmtState::Operational);
    assert_eq!(sdo_read(&mut rig, 0x1017, 0)[4], 100);
    // NMT for another node is not for us.
    rig.c
        .on_frame(&nmt::command(NmtCommand::Stop, 0x11), u64::from(rig.now));
    assert_eq!(rig.c.nmt_state(), NmtState::Operational);
}

#[test]
fn stopped_by_its_nmt_master_during_a_move_the_controller_brings_the_load_to_rest() {
    let mut rig = Rig::new(HEALTHY, true);
    let before = rig.run(400);
    let mut last = before.last().unwrap().setpoints.map(|s| s.units());
    rig.c.on_frame(
        &nmt::command(NmtCommand::PreOperational, 0),
        u64::from(rig.now),
    );
    let out = rig.until(200, |c| matches!(c.mode, Mode::Halted(_)));
    assert!(matches!(out[0].mode, Mode::Stopping(Fault::NotOperational)));
    // The set points ramp down within the limits (RPDOs go on until standstill, a
    // deliberate exception to "no PDO outside operational": the drives must stop).
    assert_within_limits(&out, &mut last);
    assert_eq!(rig.c.nmt_state(), NmtState::PreOperational);
}

#[test]
fn a_stop_is_never_dropped_behind_a_full_queue_and_every_request_is_answered_once() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(200);
    for id in 1..=4 {
        send(
            &mut rig,
            Request::Move {
                id,
                target: [15.0, 6.0],
                duration: Some(6.0),
            },
        );
    }
    send(&mut rig, Request::Stop { id: 5 });
    send(
        &mut rig,
        Request::Move {
            id: 6,
            target: [15.0, 6.0],
            duration: Some(6.0),
        },
    );
    // The supervisor did not see an answer and repeats move 2: not a new request.
    send(
        &mut rig,
        Request::Move {
            id: 2,
            target: [15.0, 6.0],
            duration: Some(6.0),
        },
    );
    let out = rig.run(30);
    // (The periodic status repeats the last answer: consecutive repeats are one answer.)
    let mut given = every_answer(&out);
    given.dedup();
    // Answers one frame each: 6 busy at once (the queue is full), then, when the stop is
    // obeyed (first thing in the next cycle, never queued), the moves that were waiting,
    // rejected (the crane is stopping), and last the stop itself: the status frame that
    // stays shows the stop accepted.
    let ids: Vec<u8> = given.iter().map(|a| a.0).collect();
    assert_eq!(given[0], (6, 3, 1), "busy");
    assert!(
        given[1..5].iter().all(|a| a.1 == 3 && a.2 == 2),
        "{given:?}"
    );
    assert_eq!(given[5], (5, 1, 0), "stop accepted, last");
    let mut sorted = ids.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted, [1, 2, 3, 4, 5, 6], "{given:?}");
    assert_eq!(ids.len(), 6, "each exactly once: {given:?}");
    assert_eq!(rig.c.counters().repeated_requests, 1);
    // Asked again after its answer: the same answer again, nothing done.
    let before = rig.c.counters().requests;
    send(
        &mut rig,
        Request::Move {
            id: 4,
            target: [15.0, 6.0],
            duration: Some(6.0),
        },
    );
    let again = every_answer(&rig.run(2));
    assert_eq!(again.first().map(|a| a.0), Some(4));
    assert_eq!(rig.c.counters().requests, before);
}

#[test]
fn a_move_while_a_drive_is_not_operation_enabled_is_rejected_with_reason_2() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    rig.run(10);
    rig.bus.inject(Action::DropOut(Drive::Winch));
    rig.run(2);
    assert_eq!(rig.c.mode(), Mode::Ready, "at rest: re-enabled, no fault");
    send(
        &mut rig,
        Request::Move {
            id: 9,
            target: [14.0, 6.0],
            duration: Some(5.0),
        },
    );
    let out = rig.run(1);
    assert_eq!(answers(&out), [(9, 3, 2)]);
}

#[test]
fn a_fault_reset_works_on_a_drive_whose_statusword_lags_two_syncs() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.bus
        .inject(Action::Quirk(Drive::Winch, Quirk::StatusLag(2)));
    rig.run(500);
    rig.bus.inject(Action::DriveFault(Drive::Winch));
    rig.until(300, |c| matches!(c.mode, Mode::Halted(_)));
    send(&mut rig, Request::Reset { id: 4 });
    let out = rig.until(40, |c| c.mode == Mode::Ready);
    assert_eq!(answers(&out)[0], (4, 1, 0));
    assert!(out
        .iter()
        .all(|c| c.mode == Mode::Enabling || c.mode == Mode::Ready));
}

#[test]
fn the_restart_position_is_the_drives_position_actual_whatever_the_tpdos_said() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(500);
    // A duplicated TPDO1 and a spoofed one with an absurd velocity: once integrated
    // velocities moved the restart position; position actual does not care.
    let now = u64::from(rig.now);
    rig.c.on_frame(&pdo::tpdo1(1, 0x1237, 1_500_000), now);
    rig.c.on_frame(&pdo::tpdo1(1, 0x1237, 1_500_000), now);
    rig.c.on_frame(&pdo::tpdo1(2, 0x1237, 2_000_000_000), now);
    rig.bus.inject(Action::Silence(Drive::Trolley));
    rig.until(300, |c| matches!(c.mode, Mode::Halted(_)));
    // Silent: its position is unknown now — a reset is refused.
    send(&mut rig, Request::Reset { id: 1 });
    assert_eq!(answers(&rig.run(1)), [(1, 3, 2)]);
    rig.bus.inject(Action::Revive(Drive::Trolley));
    rig.run(5);
    send(&mut rig, Request::Reset { id: 2 });
    assert_eq!(answers(&rig.run(1)), [(2, 1, 0)]);
    let restart = rig.drives();
    for (i, d) in PLANAR.into_iter().enumerate() {
        let actual = rig.bus.drive(d).unwrap().position();
        assert!(
            (restart[i] - actual).abs() < 2e-6,
            "{d:?}: restarted at {} m, the drive is at {actual} m",
            restart[i]
        );
    }
}

#[test]
fn a_reset_is_refused_while_a_drive_still_reports_motion() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(500);
    rig.c.feedforward_mut().fail_next_step();
    rig.until(300, |c| matches!(c.mode, Mode::Halted(_)));
    // The trolley still reports 1 m/s (coasting, or a slow brake).
    rig.bus.inject(Action::Quirk(
        Drive::Trolley,
        Quirk::ReportsVelocity(1_000_000),
    ));
    rig.run(2);
    send(&mut rig, Request::Reset { id: 3 });
    assert_eq!(answers(&rig.run(1)), [(3, 3, 2)]);
    rig.bus
        .inject(Action::Quirk(Drive::Trolley, Quirk::ReportsVelocity(0)));
    rig.run(2);
    send(&mut rig, Request::Reset { id: 4 });
    assert_eq!(answers(&rig.run(1)), [(4, 1, 0)], "at standstill again");
}

#[test]
fn a_drive_emcy_warning_is_counted_and_changes_nothing() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(300);
    rig.bus.inject(Action::DriveWarning(Drive::Trolley));
    let out = rig.run(100);
    assert!(out.iter().all(|c| c.mode == Mode::Ready));
    assert!(frames_with(&out, 0x090).is_empty());
    assert_eq!(rig.c.counters().drive_warnings, 1);
}

#[test]
fn under_a_plc_as_nmt_master_the_controller_sends_no_nmt_and_waits_for_its_start() {
    let config = Config {
        role: Role::Slave,
        ..Config::DEFAULT
    };
    let mut rig = Rig::configured(feedforward(HOME, None), HEALTHY, config);
    let out = rig.run(100);
    assert!(frames_with(&out, 0x000).is_empty(), "no NMT command, ever");
    assert_eq!(rig.c.nmt_state(), NmtState::PreOperational);
    assert!(frames_with(&out, 0x710)
        .iter()
        .skip(1)
        .all(|d| d == &[0x7F]));
    assert!(
        frames_with(&out, STATUS_ID).is_empty(),
        "no PDO before the master's start"
    );
    // Commissioned by SDO all the same, and left pre-operational for the master.
    for d in PLANAR {
        assert_eq!(rig.c.commissioning(d), Phase::Done);
        assert_eq!(rig.bus.drive(d).unwrap().mode(), 9);
        assert_eq!(rig.bus.drive(d).unwrap().nmt(), NmtState::PreOperational);
    }
    // The PLC starts the network (broadcast): drives and controller go operational.
    let start = nmt::command(NmtCommand::Start, 0);
    rig.bus.transmit(&start).unwrap();
    rig.c.on_frame(&start, u64::from(rig.now));
    let out = rig.until(50, |c| c.mode == Mode::Ready);
    assert!(frames_with(&out, 0x000).is_empty());
    assert_eq!(rig.c.nmt_state(), NmtState::Operational);
    send(
        &mut rig,
        Request::Move {
            id: 1,
            target: [16.0, 6.0],
            duration: Some(6.0),
        },
    );
    assert_eq!(answers(&rig.run(2)), [(1, 1, 0)]);
}

#[test]
fn a_lost_nmt_start_is_sent_again() {
    let mut rig = Rig::new(HEALTHY, false);
    let start = [0x01, 0x01];
    rig.until(120, |c| {
        c.frames
            .iter()
            .any(|f| f.id() == 0x000 && f.data() == start)
    });
    // The trolley missed it (say, it was still busy): it stays pre-operational.
    rig.bus
        .inject(Action::Nmt(Drive::Trolley, NmtCommand::PreOperational));
    let out = rig.until(60, |c| c.mode == Mode::Ready);
    assert_eq!(
        frames_with(&out, 0x000),
        [start],
        "sent again, to that node"
    );
    assert!(out.iter().all(|c| c.mode.fault().is_none()));
}

#[test]
fn a_drive_commissioned_again_mid_move_never_sees_its_set_point_jump() {
    // Found by the fuzzer: a boot-up message of the winch (spoofed, or a real reboot)
    // mid-move. The winch is commissioned again; meanwhile it still gets the rest of its
    // ramp to standstill, so the RPDO stream never jumps.
    let mut rig = Rig::new(HEALTHY, true);
    let before = rig.run(400);
    let mut last = before.last().unwrap().setpoints.map(|s| s.units());
    let boot_up = CanFrame::new(0x702, &[0x00]).unwrap();
    rig.c.on_frame(&boot_up, u64::from(rig.now));
    let after = rig.run(300);
    assert_within_limits(&after, &mut last);
    let winch: Vec<i32> = after
        .iter()
        .flat_map(|c| c.frames.iter())
        .filter(|f| f.id() == 0x202)
        .map(|f| i32::from_le_bytes(f.data()[2..6].try_into().unwrap()))
        .collect();
    let mut previous = before.last().unwrap().setpoints[1].units();
    for v in winch {
        assert!((v - previous).abs() <= 30_001, "{previous} → {v}");
        previous = v;
    }
    assert_eq!(previous, 0);
}

#[test]
fn a_drive_stopped_by_someone_else_is_switched_back_commissioned_and_the_crane_recovers() {
    // Found with the independent stack: a stopped drive answers no SDO, so commissioning
    // must begin with NMT pre-operational.
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(400);
    rig.bus
        .inject(Action::Nmt(Drive::Trolley, NmtCommand::Stop));
    rig.until(300, |c| matches!(c.mode, Mode::Halted(_)));
    for _ in 0..150 {
        rig.cycle();
        if rig.bus.drive(Drive::Trolley).unwrap().nmt() == NmtState::Operational {
            break;
        }
    }
    assert_eq!(
        rig.bus.drive(Drive::Trolley).unwrap().nmt(),
        NmtState::Operational
    );
    rig.run(20);
    send(&mut rig, Request::Reset { id: 5 });
    let out = rig.until(60, |c| c.mode == Mode::Ready);
    assert_eq!(answers(&out)[0], (5, 1, 0));
    assert_eq!(rig.c.commissioning(Drive::Trolley), Phase::Done);
    assert_eq!(
        rig.bus.drive(Drive::Trolley).unwrap().nmt(),
        NmtState::Operational
    );
}

#[test]
fn a_watched_supervisor_that_falls_silent_during_a_move_stops_the_crane() {
    // The PLC asks the controller to watch its heartbeat (0x1016:1 = node 0x20, 300 ms).
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(50);
    let write = CanFrame::new(0x610, &[0x23, 0x16, 0x10, 1, 0x2C, 0x01, 0x20, 0]).unwrap();
    rig.c.on_frame(&write, u64::from(rig.now));
    assert_eq!(
        frames_with(&[rig.cycle()], 0x590),
        [[0x60, 0x16, 0x10, 1, 0, 0, 0, 0]]
    );
    // Its heartbeat every 100 ms until 2 s: at rest and into the move, nothing happens.
    while rig.now < 2_000 {
        if rig.now.is_multiple_of(100) {
            let beat = canopen::heartbeat(0x20, NmtState::Operational);
            rig.c.on_frame(&beat, u64::from(rig.now));
        }
        let out = rig.cycle();
        assert!(!matches!(out.mode, Mode::Stopping(_)), "at {} ms", rig.now);
    }
    let mut last = rig.cycle().setpoints.map(|s| s.units());
    // Then silence: more than 300 ms after its last heartbeat (1.9 s) a controlled stop
    // (fault 14), announced; `now` is the next cycle's time.
    let out = rig.until(60, |c| matches!(c.mode, Mode::Stopping(_)));
    assert!(
        (2_210..=2_230).contains(&rig.now),
        "stopped at {} ms",
        rig.now
    );
    assert!(matches!(
        out.last().unwrap().mode,
        Mode::Stopping(Fault::SupervisorLost)
    ));
    let emcy = frames_with(&out, 0x090);
    assert_eq!(emcy.len(), 1);
    assert_eq!(emcy[0][..4], [0x30, 0x81, 0x11, 14], "0x8130, fault 14");
    let rest = rig.until(300, |c| matches!(c.mode, Mode::Halted(_)));
    assert_within_limits(&out, &mut last);
    assert_within_limits(&rest, &mut last);
}

/// The nodes are a list (the commissioning file's rows): listed winch first, the winch is
/// commissioned first and the crane works the same.
#[test]
fn the_nodes_are_commissioned_in_the_order_of_the_list() {
    let [trolley, winch, ..] = Config::DEFAULT.nodes;
    let config = Config {
        nodes: [winch, trolley, None, None],
        ..Config::DEFAULT
    };
    let mut rig = Rig::configured(feedforward(HOME, None), HEALTHY, config);
    let out = rig.until(200, |c| c.mode == Mode::Ready);
    assert_eq!(out.last().map(|c| c.mode), Some(Mode::Ready));
    let first_sdo = out
        .iter()
        .flat_map(|c| c.frames.iter())
        .find(|f| (0x601..=0x602).contains(&f.id()))
        .map(|f| f.id());
    assert_eq!(
        first_sdo,
        Some(0x602),
        "the winch, listed first, is asked first"
    );
    move_and_arrive(&mut rig);
}

/// An axis without a drive in the list is never ready: no PDO to anybody's winch node,
/// every move refused with reason 2, nothing moves.
#[test]
fn an_axis_without_a_drive_in_the_list_is_never_ready_and_nothing_moves() {
    let [trolley, ..] = Config::DEFAULT.nodes;
    let config = Config {
        nodes: [trolley, None, None, None],
        ..Config::DEFAULT
    };
    let mut rig = Rig::configured(feedforward(HOME, None), HEALTHY, config);
    let out = rig.run(200);
    assert!(out.iter().all(|c| c.mode == Mode::Enabling));
    assert!(frames_with(&out, 0x202).is_empty() && frames_with(&out, 0x602).is_empty());
    assert_eq!(rig.c.commissioning(Drive::Winch), Phase::Absent);
    assert_eq!(rig.c.commissioning(Drive::Trolley), Phase::Done);
    send(
        &mut rig,
        Request::Move {
            id: 1,
            target: [16.0, 6.0],
            duration: Some(6.0),
        },
    );
    let refused = rig.run(50);
    assert_eq!(
        answers(&refused),
        [(1, 3, 2)],
        "rejected, reason 2: not ready"
    );
    assert!(refused
        .iter()
        .all(|c| c.setpoints.map(|s| s.units()) == [0, 0]));
}
