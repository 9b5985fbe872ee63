//! The controller over three driven axes: the 3D crane (bridge, trolley, hoist) as a
//! BDF4 inverse model behind the same controller as the planar crane, commissioning and
//! driving three CiA 402 drives on the virtual bus. The move command's `[x_C, z_C]`
//! moves the load in the vertical plane it hangs in (its y stays); a stop and a bridge
//! drive's fault are met as on the planar crane.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

mod common3d;

use common3d::{limits, Rig, BRIDGE_NODE, HOME};

use controller::canopen::emcy;
use controller::commands::{Answer, Request};
use controller::commissioning::Phase;
use controller::drive::{Drive, SPATIAL};
use controller::setpoint::UNITS_PER_M_PER_S;
use controller::{Cycle, Fault, Mode, Replan};
use sim::Action;
use solver_core::trajectory::Trajectory;

/// Every set point within its drive's limits, every RPDO to the drive it is for.
fn assert_within_limits(cycles: &[Cycle<3>], last: &mut [i32; 3]) {
    for out in cycles {
        for (i, axis) in limits().iter().enumerate() {
            let v = out.setpoints[i].units();
            assert!(f64::from(v.abs()) <= axis.max_velocity * UNITS_PER_M_PER_S);
            let dv = f64::from(v - last[i]);
            assert!(dv.abs() <= axis.max_acceleration * 0.01 * UNITS_PER_M_PER_S + 1.0);
            last[i] = v;
        }
        for f in &out.frames {
            if let Some(node) = f.id().checked_sub(0x200).filter(|n| *n < 0x80) {
                let i = SPATIAL.iter().position(|d| u16::from(d.node()) == node);
                let i = i.unwrap_or_else(|| panic!("RPDO to node {node}, not a drive"));
                let b = f.data();
                let v = i32::from_le_bytes([b[2], b[3], b[4], b[5]]);
                assert_eq!(v, out.setpoints[i].units());
            }
        }
    }
}

fn command(rig: &mut Rig, request: Request) {
    rig.bus.inject(Action::Request(request));
}

/// A move on the command frame: x_C to 20 m, z_C to 4 m, as fast as the limits allow.
const PLANAR_MOVE: Request = Request::Move {
    id: 1,
    target: [20.0, 4.0],
    duration: None,
};

/// The last cycle sent every drive standstill.
fn assert_at_rest(cycles: &[Cycle<3>]) {
    let last = cycles.last().expect("a cycle");
    assert!(last.setpoints.iter().all(|s| s.units() == 0), "{last:?}");
}

#[test]
fn three_drives_are_commissioned_and_a_move_in_the_x_z_plane_keeps_y() {
    let mut rig = Rig::new();
    rig.ready();
    for d in SPATIAL {
        assert_eq!(rig.c.commissioning(d), Phase::Done, "{d:?}");
        assert_eq!(rig.bus.drive(d).unwrap().mode(), 9, "{d:?} in CSV");
    }
    command(&mut rig, PLANAR_MOVE);
    let mut last = [0; 3];
    let out = rig.run(1200);
    assert_within_limits(&out, &mut last);
    assert_eq!(rig.c.last_answer(), (1, Answer::Accepted, None));
    assert_eq!(rig.c.mode(), Mode::Ready);
    let [x, y, l] = rig.positions();
    assert!((x - 20.0).abs() < 1e-3, "bridge at {x}");
    assert!((y - 3.0).abs() < 1e-6, "trolley moved to {y}");
    assert!((l - 4.0).abs() < 1e-3, "rope {l}");
    assert!(out.iter().all(|c| c.setpoints[1].units() == 0));
    assert!(out.iter().any(|c| c.setpoints[0].units() != 0));
    assert_at_rest(&out);
}

/// A stop mid-move: at rest before the move would have ended, every axis between where
/// the stop found it and its target — never past it, on the command frame's planar move
/// and on a diagonal 3D move alike.
fn stop_mid_move(request: Request, target: [f64; 3], moving_for: usize) {
    let mut rig = Rig::new();
    rig.ready();
    command(&mut rig, request);
    let mut last = [0; 3];
    let before = rig.run(moving_for);
    assert_within_limits(&before, &mut last);
    let planned_end = rig.c.feedforward().inner.plan().end_time().unwrap();
    let moving = rig.positions();
    assert!(moving[0] > HOME[0] + 0.01, "the bridge moves: {moving:?}");
    command(&mut rig, Request::Stop { id: 2 });
    let after = rig.run(1000);
    assert_within_limits(&after, &mut last);
    assert_eq!(rig.c.last_answer(), (2, Answer::Accepted, None));
    let rest = after
        .iter()
        .rposition(|c| c.setpoints.iter().any(|s| s.units() != 0))
        .unwrap();
    let rest_s = f64::from(rig.now) / 1000.0 - (after.len() - rest) as f64 * 0.01;
    assert!(
        rest_s < planned_end,
        "at rest at {rest_s} s, move to end at {planned_end} s"
    );
    let at_rest = rig.positions();
    for i in 0..3 {
        let (lo, hi) = (moving[i].min(target[i]), moving[i].max(target[i]));
        assert!(
            (lo - 1e-6..=hi + 1e-6).contains(&at_rest[i]),
            "axis {i} at rest at {}, stopped at {} on the way to {}",
            at_rest[i],
            moving[i],
            target[i]
        );
    }
    assert_at_rest(&after);
}

#[test]
fn a_stop_brings_the_3d_crane_to_rest_sooner_and_never_past_its_target() {
    stop_mid_move(PLANAR_MOVE, [20.0, HOME[1], 4.0], 80);
}

#[test]
fn a_stop_on_a_diagonal_3d_move_leaves_every_axis_short_of_its_target() {
    stop_mid_move(
        Request::Move3d {
            id: 1,
            target: [16.0, 5.0, 6.0],
            duration: Some(10.0),
        },
        [16.0, 5.0, 6.0],
        300,
    );
}

#[test]
fn a_bridge_drive_fault_stops_the_crane_and_names_the_bridge_node() {
    let mut rig = Rig::new();
    rig.ready();
    command(&mut rig, PLANAR_MOVE);
    let mut last = [0; 3];
    assert_within_limits(&rig.run(100), &mut last);
    rig.bus.inject(Action::DriveFault(Drive::Bridge));
    let after = rig.run(300);
    assert_within_limits(&after, &mut last);
    assert!(
        matches!(rig.c.mode(), Mode::Halted(Fault::DriveFault(Drive::Bridge))),
        "{:?}",
        rig.c.mode()
    );
    let announced = after.iter().flat_map(|c| &c.frames).any(|f| {
        f.id() == 0x090
            && u16::from_le_bytes([f.data()[0], f.data()[1]]) == emcy::DRIVE_FAULT
            && f.data()[4] == BRIDGE_NODE
    });
    assert!(
        announced,
        "EMCY 0x{:04X} naming node {BRIDGE_NODE}",
        emcy::DRIVE_FAULT
    );
    assert_at_rest(&after);
}

#[test]
fn a_3d_move_frame_moves_the_load_in_all_three_directions() {
    let mut rig = Rig::new();
    rig.ready();
    command(
        &mut rig,
        Request::Move3d {
            id: 3,
            target: [16.0, 5.0, 6.0],
            duration: Some(10.0),
        },
    );
    let mut last = [0; 3];
    let out = rig.run(1100);
    assert_within_limits(&out, &mut last);
    assert_eq!(rig.c.last_answer(), (3, Answer::Accepted, None));
    let [x, y, l] = rig.positions();
    assert!((x - 16.0).abs() < 1e-3, "bridge at {x}");
    assert!((y - 5.0).abs() < 1e-3, "trolley at {y}");
    assert!((l - 6.0).abs() < 1e-3, "rope {l}");
    // Every drive moved, and all three rest.
    for i in 0..3 {
        assert!(out.iter().any(|c| c.setpoints[i].units() != 0), "drive {i}");
    }
    assert_at_rest(&out);
}

/// A PLC without PDOs writes the 3D move into 0x2000 (id, x, y, z, seconds) and submits
/// it with command 4.
#[test]
fn a_3d_move_written_over_sdo_is_taken_as_its_frame() {
    let mut rig = Rig::new();
    rig.ready();
    let mut write = |sub: u8, value: &[u8]| {
        let command = 0x23 | ((4 - value.len() as u8) << 2);
        let mut data = [command, 0x00, 0x20, sub, 0, 0, 0, 0];
        data[4..4 + value.len()].copy_from_slice(value);
        rig.c
            .on_frame(&controller::CanFrame::new(0x610, &data).unwrap(), 0);
        let out = rig.cycle();
        let answer = out.frames.iter().find(|f| f.id() == 0x590).unwrap();
        answer.data()[0]
    };
    assert_eq!(write(1, &[9]), 0x60);
    assert_eq!(write(3, &15_000u16.to_le_bytes()), 0x60);
    assert_eq!(write(6, &1_500u16.to_le_bytes()), 0x60);
    assert_eq!(write(4, &6_000u16.to_le_bytes()), 0x60);
    assert_eq!(write(7, &[8]), 0x60);
    assert_eq!(write(2, &[4]), 0x60);
    rig.run(3);
    assert_eq!(rig.c.last_answer(), (9, Answer::Accepted, None));
    let end = rig.c.feedforward().inner.plan().final_position();
    assert_eq!([end[0], end[1], end[2]], [15.0, 1.5, 6.0]);
}

/// A stop at every 0.25 s of the 8 s 3D move and of the quickest move to the
/// same target keeps every set point within the drives' limits (speed and the step a
/// cycle may make) and rests at or before the target in every axis: the stop search
/// bounds only the flat inverse, within the 5 % margin, so the scheme's set points are
/// checked here at every instant, not only at the three.
#[test]
fn every_stop_of_a_3d_move_keeps_the_limits_and_rests_short() {
    let target = [14.0, 4.5, 6.5];
    for duration in [Some(8.0), None] {
        let the_move = Request::Move3d {
            id: 1,
            target,
            duration,
        };
        let mut alone = Rig::new();
        alone.ready();
        command(&mut alone, the_move);
        // (The quickest move's duration is searched over a few cycles.)
        let mut waited = 0;
        while alone.c.feedforward().inner.plan().end_time().is_none() {
            assert!(waited < 30, "{duration:?}: the move not accepted");
            alone.cycle();
            waited += 1;
        }
        let plan = *alone.c.feedforward().inner.plan();
        let end = plan.end_time().unwrap();
        let start = plan.active_span().0;
        let mut stop_after = 0.25;
        let mut stops = 0;
        while start + stop_after < end {
            stops += 1;
            let mut rig = Rig::new();
            rig.ready();
            command(&mut rig, the_move);
            let mut outs = rig.run(2);
            while f64::from(rig.now) / 1000.0 < start + stop_after {
                outs.push(rig.cycle());
            }
            command(&mut rig, Request::Stop { id: 2 });
            outs.extend(rig.run(1100));
            let what = format!("{duration:?} stopped {stop_after} s in");
            assert_eq!(rig.c.mode(), Mode::Ready, "{what}");
            assert_within_limits(&outs, &mut [0; 3]);
            let rest = rig.c.feedforward().inner.plan().final_position();
            for i in 0..3 {
                let way = target[i] - HOME[i];
                assert!(
                    (target[i] - rest[i]) * way.signum() >= -1e-9,
                    "{what}: axis {i} rests at {} past {}",
                    rest[i],
                    target[i]
                );
            }
            assert_at_rest(&outs);
            stop_after += 0.25;
        }
        eprintln!("{duration:?}: {stops} stops from {start} s to {end} s");
        assert!(
            stops >= 12,
            "{duration:?}: {stops} stops from {start} to {end}"
        );
    }
}

/// Issue 32, cases 5–7 on the 3D crane: the 3D move (12, 3, 8) → (14, 4.5, 6.5) in 8 s
/// stopped 3.9–6.5 s in came to rest at the target. Now it rests short of the target in
/// every axis (0.1 mm at least; the later the stop, the nearer), every set point within
/// the drives' limits; a reset while the stop moves the crane is refused (reason
/// 14); from its first all-zero cycle every set point is exactly zero; a move sent then
/// is accepted.
#[test]
fn a_stop_of_a_3d_move_rests_short_of_the_target_then_exactly_zero() {
    let target = [14.0, 4.5, 6.5];
    let the_move = Request::Move3d {
        id: 1,
        target,
        duration: Some(8.0),
    };
    for stop_after in [3.9, 5.0, 6.5] {
        let mut rig = Rig::new();
        rig.ready();
        command(&mut rig, the_move);
        let mut outs = rig.run(2);
        let start = rig.c.feedforward().inner.plan().end_time().unwrap() - 8.0;
        while f64::from(rig.now) / 1000.0 < start + stop_after {
            outs.push(rig.cycle());
        }
        command(&mut rig, Request::Stop { id: 2 });
        outs.extend(rig.run(3));
        command(&mut rig, Request::Reset { id: 3 });
        outs.extend(rig.run(2));
        assert_eq!(
            rig.c.last_answer(),
            (
                3,
                Answer::Rejected,
                Some(controller::commands::Reject::Moving)
            )
        );
        let mut moving = true;
        while moving {
            let out = rig.cycle();
            moving = out.setpoints.iter().any(|s| s.units() != 0);
            outs.push(out);
        }
        let what = format!("stopped {stop_after} s in");
        let rest = rig.c.feedforward().inner.plan().final_position();
        for i in 0..3 {
            assert!(
                (rest[i] - target[i]).abs() > 1e-4 && (rest[i] - target[i]).abs() < 2.0,
                "{what}: axis {i} at rest at {} (target {})",
                rest[i],
                target[i]
            );
        }
        assert_within_limits(&outs, &mut [0; 3]);
        let after = rig.run(200);
        assert!(
            after
                .iter()
                .all(|c| c.setpoints.iter().all(|s| s.units() == 0)),
            "{what}: a set point after the first all-zero cycle"
        );
        command(&mut rig, PLANAR_MOVE);
        for _ in 0..20 {
            if rig.c.last_answer().0 == 1 {
                break;
            }
            rig.cycle();
        }
        assert_eq!(rig.c.last_answer(), (1, Answer::Accepted, None), "{what}");
    }
}
