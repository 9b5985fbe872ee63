//! Manual mode's command interface on the virtual bus (issue 28): the operator's
//! speed-demand frame (RPDO3, 0x410) — malformed ones ignored and counted, never acted
//! upon, whatever their number.

mod common;

use common::manual::{moving, send_request, until_rest, Manual, HELD};
use common::*;
use controller::canopen::{NmtCommand, CONTROLLER_NODE};
use controller::operator::{operator_frame, Flags, OperatorFrame, FULL_SCALE, MANUAL_MODE_CODE};
use controller::setpoint::Setpoint;
use controller::{CanFrame, Mode, Replan};
use sim::HEALTHY;
use solver_core::models::crane::CraneParams;

fn stick(counter: u8, demand: [i16; 3]) -> CanFrame {
    operator_frame(
        CONTROLLER_NODE,
        &OperatorFrame {
            counter,
            flags: HELD,
            demand,
        },
    )
}

/// A flood of malformed operator frames, ten every cycle for four seconds: each one is
/// counted in *frames ignored* (status byte 5), none changes a set point or the mode.
#[test]
fn a_flood_of_malformed_operator_frames_is_counted_and_changes_nothing() {
    let mut flood = vec![
        CanFrame::new(0x410, &[1, 1, 0, 0]).unwrap(), // short
        CanFrame::new(0x410, &[]).unwrap(),           // empty
        CanFrame::new(0x410, &[2, 0x09, 0, 0, 0, 0, 0, 0]).unwrap(), // reserved flag bit 3
        CanFrame::new(0x410, &[3, 0x81, 0, 0, 0, 0, 0, 0]).unwrap(), // reserved flag bit 7
        CanFrame::new(0x410, &[4, 1, 0x00, 0x80, 0, 0, 0, 0]).unwrap(), // x = -32768
        CanFrame::new(0x410, &[5, 1, 0, 0, 0, 0, 0x00, 0x80]).unwrap(), // z = -32768
        stick(6, [0, FULL_SCALE, 0]),                 // along y: the planar crane has no y
    ];
    flood.extend((0..3).map(|k| stick(7 + k, [0, -1, 0])));
    assert_eq!(flood.len(), 10);
    let (mut clean, mut noisy) = (Rig::new(HEALTHY, true), Rig::new(HEALTHY, true));
    for i in 0..400 {
        for f in &flood {
            noisy.c.on_frame(f, noisy.now.into());
        }
        let (a, b) = (clean.cycle(), noisy.cycle());
        assert_eq!(a.setpoints, b.setpoints, "cycle {i}");
        assert_eq!(a.mode, b.mode, "cycle {i}");
    }
    assert_eq!(noisy.c.counters().frames_ignored, 400 * 10);
    assert_eq!(clean.c.counters().frames_ignored, 0);
    assert_eq!(noisy.c.counters().requests, 0, "none of them was answered");
    // The status frame's byte 5 is the count modulo 256.
    assert_eq!(noisy.c.status().bytes()[5], (4000 % 256) as u8);
}

/// A well-formed frame is received, not ignored; another node's RPDO3 is not the
/// controller's (a PLC's to its own devices); in pre-operational no PDO is taken, so a
/// well-formed operator frame is ignored and counted, as a command frame is.
#[test]
fn well_formed_frames_are_received_and_other_nodes_rpdo3_is_not_ours() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    let cases = [
        // (frame, received, ignored)
        (stick(1, [FULL_SCALE, 0, -FULL_SCALE]), 1, 0),
        (CanFrame::new(0x420, &[0; 3]).unwrap(), 1, 0),
        (
            CanFrame::new(0x411, &[1, 2, 3, 4, 5, 6, 7, 8]).unwrap(),
            1,
            0,
        ),
    ];
    for (frame, received, ignored) in cases {
        assert_eq!(rig.counted(&frame), (received, ignored), "{frame:?}");
    }
    assert_eq!(rig.c.mode(), Mode::Ready);
    rig.c.on_frame(
        &controller::canopen::nmt::command(NmtCommand::PreOperational, CONTROLLER_NODE),
        rig.now.into(),
    );
    let before = rig.c.counters().frames_ignored;
    rig.c.on_frame(&stick(2, [0; 3]), rig.now.into());
    assert_eq!(rig.c.counters().frames_ignored, before + 1);
}

// ---------------------------------------------------------------------------------------
// Manual mode: the operator's generator drives the planar crane's inverse model
// (`common::manual::Manual`).

/// Full stick for 4 s, then the stick released: manual mode is entered at rest (status
/// mode 5), the load travels, the stick's release brings it to rest (the generator's
/// sway-free stop), every set point on the way within the drives' limits, and after the
/// stop every set point is exactly zero; with the manual request withdrawn the
/// controller leaves manual mode at rest (status mode 1).
#[test]
fn a_full_stick_step_and_release_ends_at_rest_within_limits() {
    let mut rig = Manual::new();
    assert_eq!(rig.mode_byte(), 1);
    let mut cycles = rig.hold(9, HELD, [0; 3]);
    assert_eq!(rig.mode_byte(), MANUAL_MODE_CODE, "entered at rest");
    assert!(rig.c.feedforward().path().in_manual());
    let start = rig.load();
    cycles.extend(rig.hold(400, HELD, [FULL_SCALE, 0, 0]));
    let moved = rig.load()[0] - start[0];
    assert!(moved > 1.0, "the load travelled {moved} m");
    let mut rest = None;
    for n in 0..1000 {
        cycles.extend(rig.hold(3, HELD, [0; 3]));
        let last = cycles
            .iter()
            .rev()
            .take(30)
            .all(|c| c.setpoints == [Setpoint::ZERO; 2]);
        if last && n > 10 {
            rest = Some(rig.load());
            break;
        }
    }
    let rest = rest.expect("at rest after the release");
    let tail = rig.hold(300, HELD, [0; 3]);
    assert!(
        tail.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]),
        "exactly zero after the stop"
    );
    assert_eq!(rig.load(), rest, "no creep");
    cycles.extend(tail);
    let mut last = [0; 2];
    assert_within_limits(&cycles, &mut last);
    assert!(cycles.iter().all(|c| c.mode == Mode::Ready), "no fault");
    let off = Flags {
        manual: false,
        ..HELD
    };
    rig.hold(6, off, [0; 3]);
    assert_eq!(rig.mode_byte(), 1, "left at rest");
    assert!(!rig.c.feedforward().path().in_manual());
    println!(
        "travelled {moved:.3} m at full stick; rest at x = {:.4} m",
        rest[0]
    );
}

/// The operator's frames stop mid-travel (a cut cable): after the deadline the
/// generator's stop brings the load to rest within the limits, and manual mode is left
/// at rest; the held stick, when the frames come back, moves nothing (interlocked).
#[test]
fn a_dead_man_drop_stops_and_leaves_manual_mode_at_rest() {
    let mut rig = moving(300);
    let (cycles, rested) = until_rest(&mut rig, 2000, |_, _| {});
    assert!(
        cycles[0].setpoints[0].units() > 100_000,
        "travelling when the frames stop"
    );
    assert!(rested, "at rest after the frames stopped");
    let mut last = [
        cycles[0].setpoints[0].units(),
        cycles[0].setpoints[1].units(),
    ];
    assert_within_limits(&cycles[1..], &mut last);
    assert!(cycles.iter().all(|c| c.mode == Mode::Ready), "no fault");
    assert_eq!(rig.mode_byte(), 1, "manual mode left at rest");
    // The operator is back with the stick still deflected: nothing moves.
    let back = rig.hold(60, HELD, [FULL_SCALE, 0, 0]);
    assert!(back.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]));
}

/// The manual request withdrawn while travelling (the stick still held) is the same
/// stop: at rest, manual mode is left.
#[test]
fn withdrawing_the_manual_request_stops_and_leaves_manual_mode() {
    let off = Flags {
        manual: false,
        ..HELD
    };
    let mut rig = moving(300);
    let (cycles, rested) = until_rest(&mut rig, 2000, |r, n| {
        if n % 3 == 0 {
            r.send(off, [FULL_SCALE, 0, 0]);
        }
    });
    assert!(
        cycles[0].setpoints[0].units() > 100_000,
        "travelling when withdrawn"
    );
    assert!(rested, "at rest with the stick held");
    assert_eq!(rig.mode_byte(), 1, "manual mode left");
}

/// A released dead-man switch (enable = 0) and a frozen counter are the same stop.
#[test]
fn a_released_switch_or_a_frozen_counter_stops() {
    let released = Flags {
        enable: false,
        ..HELD
    };
    let mut rig = moving(300);
    let (_, rested) = until_rest(&mut rig, 2000, |r, n| {
        if n % 3 == 0 {
            r.send(released, [FULL_SCALE, 0, 0]);
        }
    });
    assert!(rested, "released: at rest");
    assert_eq!(rig.mode_byte(), 1, "released: manual mode left");
    let mut rig = moving(300);
    let (_, rested) = until_rest(&mut rig, 2000, |r, n| {
        if n % 3 == 0 {
            // The same counter again and again: a stale sender.
            let f = operator_frame(
                CONTROLLER_NODE,
                &OperatorFrame {
                    counter: r.counter,
                    flags: HELD,
                    demand: [FULL_SCALE, 0, 0],
                },
            );
            r.c.on_frame(&f, r.now.into());
        }
    });
    assert!(rested, "frozen: at rest");
    assert_eq!(rig.mode_byte(), 1, "frozen: manual mode left");
}

/// The zero-position interlock: a stick held deflected when manual mode is entered
/// moves nothing until it was centred for two frames; one centred frame is not enough.
#[test]
fn the_interlock_refuses_motion_until_the_stick_was_centred_two_frames() {
    let mut rig = Manual::new();
    let held = rig.hold(150, HELD, [FULL_SCALE, 0, 0]);
    assert_eq!(
        rig.mode_byte(),
        MANUAL_MODE_CODE,
        "entered: the crane rests"
    );
    assert!(
        held.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]),
        "interlocked"
    );
    // One centred frame, then the stick again: still interlocked.
    rig.send(HELD, [0; 3]);
    rig.cycle();
    let again = rig.hold(150, HELD, [FULL_SCALE, 0, 0]);
    assert!(
        again.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]),
        "one frame is not enough"
    );
    // Two centred frames: the stick moves the crane.
    rig.hold(6, HELD, [0; 3]);
    let live = rig.hold(150, HELD, [FULL_SCALE, 0, 0]);
    assert!(live.iter().any(|c| c.setpoints[0].units() > 0), "live");
}

/// A stop request (0x210) in manual mode is obeyed as in automatic: the load comes to
/// rest although the stick is held, and only a centred stick moves it again.
#[test]
fn a_stop_request_is_obeyed_in_manual_mode() {
    let mut rig = moving(300);
    send_request(&mut rig, controller::commands::Request::Stop { id: 5 });
    let (cycles, rested) = until_rest(&mut rig, 2000, |r, n| {
        if n % 3 == 0 {
            r.send(HELD, [FULL_SCALE, 0, 0]);
        }
    });
    assert!(
        cycles[0].setpoints[0].units() > 100_000,
        "travelling when stopped"
    );
    assert!(rested, "at rest with the stick held");
    let mut last = [
        cycles[0].setpoints[0].units(),
        cycles[0].setpoints[1].units(),
    ];
    assert_within_limits(&cycles[1..], &mut last);
    assert_eq!(rig.c.last_answer().0, 5);
    assert_eq!(
        rig.mode_byte(),
        MANUAL_MODE_CODE,
        "still manual: the operator is there"
    );
    rig.hold(6, HELD, [0; 3]);
    let live = rig.hold(150, HELD, [FULL_SCALE, 0, 0]);
    assert!(
        live.iter().any(|c| c.setpoints[0].units() > 0),
        "centred, then live"
    );
}

/// A move request in manual mode is refused (not ready): the stick has the crane.
#[test]
fn a_move_request_in_manual_mode_is_refused() {
    let mut rig = moving(30);
    send_request(
        &mut rig,
        controller::commands::Request::Move {
            id: 6,
            target: [20.0, 4.0],
            duration: None,
        },
    );
    rig.hold(3, HELD, [FULL_SCALE, 0, 0]);
    assert_eq!(
        rig.c.last_answer(),
        (
            6,
            controller::commands::Answer::Rejected,
            Some(controller::commands::Reject::NotReady)
        )
    );
}

/// The zero-position interlock after a fault and a reset (review finding 1): a fault in
/// manual mode halts; the operator centres the stick while halted and then holds it
/// deflected; the supervisor's reset brings the controller back to ready — and the held
/// stick moves nothing until it was centred for two frames *after* the reset.
#[test]
fn after_a_fault_and_a_reset_a_held_stick_moves_nothing_until_centred_twice() {
    let mut rig = moving(100);
    rig.c.feedforward_mut().fail_next_step();
    let mut halted = false;
    for _ in 0..2000 {
        rig.send(HELD, [0; 3]);
        if matches!(rig.cycle().mode, Mode::Halted(_)) {
            halted = true;
            break;
        }
    }
    assert!(halted, "the fault halts");
    // Centred twice while halted, then held deflected.
    rig.hold(6, HELD, [0; 3]);
    rig.hold(6, HELD, [FULL_SCALE, 0, 0]);
    send_request(&mut rig, controller::commands::Request::Reset { id: 7 });
    let after = rig.hold(300, HELD, [FULL_SCALE, 0, 0]);
    assert!(after.iter().any(|c| c.mode == Mode::Ready), "reset: ready");
    assert!(
        after.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]),
        "the stick held through the reset moves nothing"
    );
    rig.hold(6, HELD, [0; 3]);
    let live = rig.hold(150, HELD, [FULL_SCALE, 0, 0]);
    assert!(
        live.iter().any(|c| c.setpoints[0].units() > 0),
        "centred twice after the reset: live"
    );
}

/// The interlock lifted in automatic (manual = 0, the stick centred), then manual mode
/// asked for with the stick deflected (review finding 1): entering manual mode
/// interlocks the stick, so nothing moves until it was centred twice.
#[test]
fn entering_manual_mode_with_a_deflected_stick_moves_nothing_until_centred_twice() {
    let auto = Flags {
        manual: false,
        ..HELD
    };
    let mut rig = Manual::new();
    rig.hold(9, auto, [0; 3]);
    assert_eq!(rig.mode_byte(), 1, "automatic");
    let held = rig.hold(150, HELD, [FULL_SCALE, 0, 0]);
    assert_eq!(rig.mode_byte(), MANUAL_MODE_CODE, "entered at rest");
    assert!(
        held.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]),
        "interlocked on entry"
    );
    rig.hold(6, HELD, [0; 3]);
    let live = rig.hold(150, HELD, [FULL_SCALE, 0, 0]);
    assert!(live.iter().any(|c| c.setpoints[0].units() > 0), "live");
}

/// The generator and the inverse model in step (review finding 2): the generator is
/// advanced on every cycle the model steps, the entry cycle included, so that after
/// each cycle the generator's time (the start of the piece it built) is one cycle
/// (10 ms) before the model's time: the model evaluates each piece within [0, 1] of its own cycle, never
/// extrapolates it. (An equivalent of comparing with host-tests' `inverse_model_run`,
/// which advances before every step: controller tests do not depend on host-tests.)
#[test]
fn the_generator_is_advanced_on_every_cycle_the_model_steps() {
    use controller::{Feedforward, Replan};
    let mut rig = Manual::new();
    let mut checked = 0;
    let stick = |n: usize| match n {
        0..=8 => [0; 3],
        9..=308 => [FULL_SCALE, 0, FULL_SCALE / 2],
        _ => [0; 3],
    };
    for n in 0..700 {
        if n % 3 == 0 {
            rig.send(HELD, stick(n));
        }
        rig.cycle();
        let ff = rig.c.feedforward_mut();
        let model = ff.time();
        if let Some(path) = ff.path_mut().manual_mut() {
            let generator = path.time();
            assert!(
                (model - generator - 0.01).abs() < 1e-9,
                "cycle {n}: the generator's piece starts at {generator} s, the model is at {model} s"
            );
            checked += 1;
        }
    }
    assert!(checked > 600, "{checked} cycles in manual mode");
}

/// The dead-man's deadline in the controller's cycles (review finding 4): the last
/// frame read in the cycle at T, none after it — the sway-free stop is latched in the
/// cycle at T + 90 ms (the documented deadline), not before and not a cycle later.
#[test]
fn the_dead_man_stop_is_latched_in_the_cycle_ninety_ms_after_the_last_frame() {
    use controller::Replan;
    let mut rig = moving(300);
    rig.send(HELD, [FULL_SCALE, 0, 0]);
    let last = rig.now;
    rig.cycle();
    let mut latched = None;
    while rig.now <= last + 120 {
        let at = rig.now;
        rig.cycle();
        let stopping = rig
            .c
            .feedforward_mut()
            .path_mut()
            .manual_mut()
            .is_some_and(|p| p.is_stopping());
        if stopping && latched.is_none() {
            latched = Some(at - last);
        }
    }
    assert_eq!(
        latched,
        Some(controller::operator::DEADLINE_MS),
        "ms after the last frame"
    );
}

/// Micro-speed (review finding 3): the deadband applies to the stick's position and the
/// micro factor after it, so full stick with micro-speed drives the trolley at a tenth of
/// full stick's speed (not (0.1 − 0.05)/0.95 = 5.3 %), and a micro stick at 30 % moves
/// the crane (scaled before the deadband it did nothing below half stick).
#[test]
fn micro_speed_is_a_tenth_of_the_manual_speed_past_the_deadband() {
    let micro = Flags {
        micro: true,
        ..HELD
    };
    let speed = |flags: Flags, x: i16| {
        let mut rig = Manual::new();
        rig.hold(9, HELD, [0; 3]);
        let out = rig.hold(800, flags, [x, 0, 0]);
        out.last().unwrap().setpoints[0].units()
    };
    let full = speed(HELD, FULL_SCALE);
    let tenth = speed(micro, FULL_SCALE);
    let ratio = f64::from(tenth) / f64::from(full);
    println!("full stick {full}, micro {tenth}: {ratio:.4}");
    assert!(full > 100_000, "{full}");
    assert!(
        (ratio - 0.1).abs() < 0.002,
        "micro-speed {ratio} of full stick"
    );
    let third = speed(micro, FULL_SCALE / 10 * 3);
    assert!(third > 0, "a micro stick at 30 % moves the crane: {third}");
}

/// Manual mode parked at rest is not motion for supervision (review finding 5): an NMT
/// *enter pre-operational* with the stick centred and the crane at rest in manual mode
/// is no fault (manual mode is then left, its frames no longer taken); the same command
/// while the stick moves the load is the fault NotOperational, as in automatic.
#[test]
fn an_nmt_change_in_manual_mode_at_rest_is_no_fault_while_travelling_it_is() {
    let pre_op = controller::canopen::nmt::command(NmtCommand::PreOperational, CONTROLLER_NODE);
    let mut rig = Manual::new();
    rig.hold(30, HELD, [0; 3]);
    assert_eq!(rig.mode_byte(), MANUAL_MODE_CODE, "parked in manual mode");
    rig.c.on_frame(&pre_op, rig.now.into());
    let after = rig.hold(60, HELD, [0; 3]);
    assert!(
        after.iter().all(|c| c.mode == Mode::Ready),
        "no fault at rest: {:?}",
        after.iter().map(|c| c.mode).find(|m| *m != Mode::Ready)
    );
    assert!(
        after.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]),
        "nothing moves"
    );
    assert!(!rig.c.feedforward().path().in_manual(), "manual mode left");
    let mut rig = moving(300);
    rig.c.on_frame(&pre_op, rig.now.into());
    let out = rig.cycle();
    assert!(
        matches!(out.mode, Mode::Stopping(controller::Fault::NotOperational)),
        "{:?}",
        out.mode
    );
}

/// A drive that reboots (its boot-up message) while manual mode is parked at rest (review finding
/// 5): no fault; the controller enables it again (the model steps meanwhile and the
/// generator with it, its stop latched), manual mode goes on, and the stick moves the
/// crane once the drives are ready and it was centred twice.
#[test]
fn a_drive_leaving_operational_in_manual_mode_at_rest_is_no_fault() {
    use controller::{Feedforward, Replan};
    let mut rig = Manual::new();
    rig.hold(30, HELD, [0; 3]);
    assert_eq!(rig.mode_byte(), MANUAL_MODE_CODE, "parked in manual mode");
    // The winch's boot-up message (a reboot, as the controller hears it).
    let boot_up = CanFrame::new(0x702, &[0x00]).unwrap();
    rig.c.on_frame(&boot_up, rig.now.into());
    let mut enabling = false;
    let mut back = false;
    for n in 0..600 {
        if n % 3 == 0 {
            rig.send(HELD, [0; 3]);
        }
        let out = rig.cycle();
        assert!(
            matches!(out.mode, Mode::Ready | Mode::Enabling),
            "cycle {n}: {:?}",
            out.mode
        );
        assert_eq!(out.setpoints, [Setpoint::ZERO; 2], "cycle {n}");
        enabling |= out.mode == Mode::Enabling;
        let ff = rig.c.feedforward_mut();
        let model = ff.time();
        let path = ff.path_mut().manual_mut().expect("manual mode goes on");
        assert!((model - path.time() - 0.01).abs() < 1e-9, "cycle {n}");
        if enabling && out.mode == Mode::Ready {
            back = true;
            break;
        }
    }
    assert!(enabling && back, "enabling, then ready again");
    rig.hold(6, HELD, [0; 3]);
    let live = rig.hold(150, HELD, [FULL_SCALE, 0, 0]);
    assert!(live.iter().any(|c| c.setpoints[0].units() > 0), "live");
}

/// An SDO download of `value` (1–4 bytes) into `index:sub` of the controller; its
/// answer's abort code (0: confirmed).
fn sdo_write(rig: &mut Rig, index: u16, sub: u8, value: &[u8]) -> u32 {
    let data = download(index, sub, value);
    rig.c
        .on_frame(&CanFrame::new(0x610, &data).unwrap(), rig.now.into());
    let out = rig.cycle();
    let answer: [u8; 8] = out
        .frames
        .iter()
        .find(|f| f.id() == 0x590)
        .map(|f| f.data().try_into().unwrap())
        .expect("an answer");
    if answer[0] == 0x80 {
        u32::from_le_bytes(answer[4..8].try_into().unwrap())
    } else {
        0
    }
}

/// A demand along y written over SDO (0x2010) to the planar crane is aborted when the
/// counter submits it, 0x06090030 (review finding 8): the PLC hears that the crane
/// cannot follow it, and nothing is counted as ignored; without y it is confirmed.
#[test]
fn the_planar_crane_aborts_a_y_demand_written_over_sdo() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    assert_eq!(sdo_write(&mut rig, 0x2010, 2, &[0b011]), 0);
    assert_eq!(sdo_write(&mut rig, 0x2010, 4, &1000i16.to_le_bytes()), 0);
    let ignored = rig.c.counters().frames_ignored;
    assert_eq!(sdo_write(&mut rig, 0x2010, 1, &[1]), 0x0609_0030);
    assert_eq!(rig.c.counters().frames_ignored, ignored, "not taken");
    assert_eq!(sdo_write(&mut rig, 0x2010, 4, &0i16.to_le_bytes()), 0);
    assert_eq!(sdo_write(&mut rig, 0x2010, 1, &[2]), 0, "without y");
}

/// A stick held into the workspace's end (issue 28, "Limits"): full stick towards the
/// trolley's end x = 23 m brings the load to a sway-free rest short of it, every set point
/// within the drives' limits and no fault (the gate never refuses one), exactly zero once
/// at rest although the stick is still held; the stick pulled the other way moves the
/// load away at once (no interlock: nothing stopped it but the limit).
#[test]
fn a_stick_held_into_a_limit_rests_at_it_and_drives_away() {
    let mut rig = Manual::new();
    rig.hold(9, HELD, [0; 3]);
    let mut cycles = Vec::new();
    let mut rested = None;
    for _ in 0..800 {
        cycles.extend(rig.hold(3, HELD, [FULL_SCALE, 0, 0]));
        let quiet = cycles.len() > 300
            && cycles
                .iter()
                .rev()
                .take(100)
                .all(|c| c.setpoints == [Setpoint::ZERO; 2]);
        if quiet {
            rested = Some(rig.load());
            break;
        }
    }
    let [x, _] = rested.expect("at rest at the end with the stick held");
    let x_max = CraneParams::PAPER.workspace.x_max;
    println!("rested at x = {x:.4} m, the end at {x_max} m");
    assert!(x <= x_max, "inside the workspace");
    assert!(x_max - x < 1e-3, "at the end, not short of it: {x}");
    let trolley = rig
        .bus
        .drive(controller::drive::Drive::Trolley)
        .unwrap()
        .position();
    println!("the trolley's drive at {trolley:.4} m");
    assert!(trolley <= x_max + 1e-3, "the drive inside too: {trolley}");
    let mut last = [0; 2];
    assert_within_limits(&cycles, &mut last);
    assert!(cycles.iter().all(|c| c.mode == Mode::Ready), "no fault");
    let away = rig.hold(60, HELD, [-FULL_SCALE, 0, 0]);
    assert!(
        away.iter().any(|c| c.setpoints[0].units() < 0),
        "the stick drives away"
    );
}

/// The changed set point in the next cycle after the frame (issue 28, "Proof"): from
/// rest in manual mode, the cycle that reads the first deflected frame already sends a
/// trolley set point other than zero.
#[test]
fn a_deflection_changes_the_set_point_in_the_next_cycle() {
    let mut rig = Manual::new();
    let centred = rig.hold(30, HELD, [0; 3]);
    assert!(centred.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]));
    rig.send(HELD, [FULL_SCALE, 0, 0]);
    let next = rig.cycle();
    assert!(
        next.setpoints[0].units() > 0,
        "{:?}",
        next.setpoints[0].units()
    );
}
