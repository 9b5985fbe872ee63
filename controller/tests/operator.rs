//! Manual mode's command interface on the virtual bus (issue 28): the operator's
//! speed-demand frame (RPDO3, 0x410) — malformed ones ignored and counted, never acted
//! upon, whatever their number.

mod common;

use common::*;
use controller::canopen::{NmtCommand, CONTROLLER_NODE};
use controller::operator::{operator_frame, Flags, OperatorFrame, FULL_SCALE};
use controller::{CanFrame, Mode};
use sim::HEALTHY;

const HELD: Flags = Flags {
    enable: true,
    manual: true,
    micro: false,
};

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
        let before = rig.c.counters();
        rig.c.on_frame(&frame, rig.now.into());
        let after = rig.c.counters();
        assert_eq!(
            (
                after.frames_received - before.frames_received,
                after.frames_ignored - before.frames_ignored
            ),
            (received, ignored),
            "{frame:?}"
        );
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
