//! What the drives report is judged before it is believed (docs/COMMANDS.md, fault 17):
//! a position outside the workspace, a velocity beyond the drive's limit, a position that
//! jumps further than the drive can move — a named fault, never the basis of a restart;
//! and another node sending with the controller's node id (fault 18) — issue 17.

mod common;

use common::*;
use controller::canopen::{self, NmtState};
use controller::cia402::pdo;
use controller::commands::Request;
use controller::drive::Drive;
use controller::fault::Implausibility;
use controller::{CanFrame, Fault, Mode};
use sim::HEALTHY;

/// The trolley's TPDO2 with position actual `x` m (µm units, CSV).
fn trolley_at(x: f64) -> CanFrame {
    pdo::tpdo2(1, (x * 1e6).round() as i32, 9)
}

/// The controller's EMCY in the cycles: (code, register, fault, node, detail).
fn emcy_of(cycles: &[controller::Cycle]) -> Option<(u16, u8, u8, u8, u8)> {
    cycles.iter().find_map(|c| {
        c.frames.iter().find(|f| f.id() == 0x090).map(|f| {
            let d = f.data();
            (u16::from_le_bytes([d[0], d[1]]), d[2], d[3], d[4], d[5])
        })
    })
}

#[test]
fn a_position_outside_the_workspace_is_a_fault_and_no_basis_for_a_restart() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    // 30 m: the trolley's rail ends at 23 m (+ 0.5 m tolerance).
    rig.c.on_frame(&trolley_at(30.0), u64::from(rig.now));
    let out = rig.until(50, |c| matches!(c.mode, Mode::Halted(_)));
    // At rest the quick stop is over at once: halted.
    assert_eq!(
        out[0].mode,
        Mode::Halted(Fault::Implausible(Drive::Trolley, Implausibility::Position))
    );
    assert_eq!(emcy_of(&out), Some((0xFF05, 0x81, 17, 1, 1)));
    // While the drive says so, a reset is refused: the model would restart there. (A
    // cycle in which only that reading arrived: ticked without the bus.)
    rig.c.on_frame(&trolley_at(30.0), u64::from(rig.now));
    send(&mut rig, Request::Reset { id: 4 });
    let out = rig.c.tick(u64::from(rig.now));
    rig.now += 10;
    assert_eq!(answers(&[out]), [(4, 3, 2)]);
    // Its own TPDOs (the true position) make it plausible again: the reset is taken.
    rig.run(5);
    send(&mut rig, Request::Reset { id: 5 });
    assert_eq!(answers(&rig.run(2)), [(5, 1, 0)]);
    rig.until(100, |c| c.mode == Mode::Ready);
}

#[test]
fn a_position_jump_mid_move_is_a_fault() {
    let mut rig = Rig::new(HEALTHY, true);
    rig.run(400);
    let x = rig.bus.drive(Drive::Trolley).unwrap().position();
    // 0.5 m in 10 ms (50 m/s): no drive of 3 m/s moves so.
    rig.c.on_frame(&trolley_at(x + 0.5), u64::from(rig.now));
    let out = rig.run(2);
    assert_eq!(
        out[0].mode,
        Mode::QuickStop(Fault::Implausible(Drive::Trolley, Implausibility::Jump))
    );
    assert_eq!(emcy_of(&out), Some((0xFF05, 0x81, 17, 1, 3)));
    // Which reading is true is not known: the drive's position stays implausible, and a
    // reset is refused, until the drive is commissioned again (here: it reboots).
    rig.until(300, |c| matches!(c.mode, Mode::Halted(_)));
    rig.run(20);
    send(&mut rig, Request::Reset { id: 7 });
    assert_eq!(answers(&rig.run(2)), [(7, 3, 2)]);
    rig.bus.inject(sim::Action::PowerOn(Drive::Trolley));
    rig.until(150, rig_ready_to_reset);
    send(&mut rig, Request::Reset { id: 8 });
    assert_eq!(answers(&rig.run(2)), [(8, 1, 0)]);
}

/// A cycle after which a reset may be taken (the trolley commissioned again and its
/// TPDOs flowing): its RPDO is being sent again.
fn rig_ready_to_reset(c: &controller::Cycle) -> bool {
    c.frames.iter().any(|f| f.id() == 0x201)
}

#[test]
fn a_velocity_beyond_the_drives_limit_is_a_fault() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    // 4 m/s reported by the winch (limit 2 m/s), statusword operation enabled.
    rig.c
        .on_frame(&pdo::tpdo1(2, 0x1637, 4_000_000), u64::from(rig.now));
    let out = rig.run(2);
    assert_eq!(
        out[0].mode,
        Mode::Halted(Fault::Implausible(Drive::Winch, Implausibility::Velocity))
    );
}

#[test]
fn plausible_reports_of_a_whole_move_raise_nothing() {
    let mut rig = Rig::new(HEALTHY, true);
    let out = rig.run(1000);
    assert!(out.iter().all(|c| c.mode.fault().is_none()));
}

#[test]
fn another_node_with_the_controllers_id_is_detected_and_announced() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    // A second node 0x10 sends its heartbeat.
    let twin = canopen::heartbeat(0x10, NmtState::Operational);
    rig.c.on_frame(&twin, u64::from(rig.now));
    let out = rig.run(3);
    assert!(matches!(
        out[0].mode,
        Mode::Stopping(Fault::DuplicateNodeId) | Mode::Halted(Fault::DuplicateNodeId)
    ));
    assert_eq!(emcy_of(&out), Some((0x8150, 0x11, 18, 0, 0)));
    // Its status frame or SDO answers too.
    for id in [0x190, 0x590, 0x090] {
        let mut rig = Rig::new(HEALTHY, false);
        rig.ready();
        rig.c
            .on_frame(&CanFrame::new(id, &[0; 8]).unwrap(), u64::from(rig.now));
        assert_eq!(
            rig.cycle().mode.fault(),
            Some(Fault::DuplicateNodeId),
            "{id:x}"
        );
    }
}
