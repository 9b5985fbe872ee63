//! The controller's SDO server (issue 32, items 2 and 7): no write is confirmed that
//! later halts the crane — a heartbeat producer time 0x1017 the drives' consumers (the
//! 0x1016:1 the controller wrote into them) would not tolerate is aborted with the CiA 301
//! code that says why, and the status frame keeps its own period whatever 0x1017 says —;
//! every request gets exactly one answer, also two in one cycle; and an abort to a stray
//! segment names no object (its bytes are data).

mod common;

use common::*;
use controller::canopen::sdo::abort;
use controller::commissioning::{DriveSetup, NodeSetup};
use controller::drive::Drive;
use controller::{CanFrame, Config, Cycle, Mode};
use sim::HEALTHY;

/// A request to the controller's SDO server (0x610), received before the next cycle.
fn request(rig: &mut Rig, data: [u8; 8]) {
    rig.c
        .on_frame(&CanFrame::new(0x610, &data).unwrap(), u64::from(rig.now));
}

/// An expedited upload's request of `index:sub`.
fn upload(index: u16, sub: u8) -> [u8; 8] {
    let [i0, i1] = index.to_le_bytes();
    [0x40, i0, i1, sub, 0, 0, 0, 0]
}

/// The SDO server's answers (0x590) in `cycles`, in order.
fn answers_of(cycles: &[Cycle]) -> Vec<[u8; 8]> {
    cycles
        .iter()
        .flat_map(|c| c.frames.iter())
        .filter(|f| f.id() == 0x590)
        .map(|f| f.data().try_into().unwrap())
        .collect()
}

/// An answer's abort code (0 for a confirmation).
fn code(answer: &[u8; 8]) -> u32 {
    if answer[0] == 0x80 {
        u32::from_le_bytes(answer[4..8].try_into().unwrap())
    } else {
        0
    }
}

/// The cycles among `cycles` whose frames have `id`.
fn cycles_with(cycles: &[Cycle], id: u16) -> Vec<usize> {
    cycles
        .iter()
        .enumerate()
        .filter(|(_, c)| c.frames.iter().any(|f| f.id() == id))
        .map(|(i, _)| i)
        .collect()
}

/// Every `n` cycles, exactly.
fn every(at: &[usize], n: usize) -> bool {
    at.len() > 2 && at.windows(2).all(|w| w[1] - w[0] == n)
}

/// Item 7: two requests arriving between two cycles (before, the second's answer
/// replaced the first's) get two answers, in order, in the next cycle.
#[test]
fn two_requests_in_one_cycle_get_two_answers_in_order() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    request(&mut rig, upload(0x1017, 0));
    request(&mut rig, upload(0x1006, 0));
    let answers = answers_of(&[rig.cycle()]);
    assert_eq!(answers.len(), 2, "{answers:?}");
    assert_eq!(answers[0][..6], [0x4B, 0x17, 0x10, 0, 100, 0]);
    assert_eq!(
        answers[1][..8],
        [0x43, 0x06, 0x10, 0, 0x10, 0x27, 0, 0],
        "10,000 µs"
    );
}

/// Up to four wait for their answers (two leave a cycle); a fifth and sixth are not
/// served — the write is not made — and are counted as ignored, never answered out of
/// turn or acted on unanswered.
#[test]
fn requests_beyond_the_answers_waiting_are_not_served_and_are_counted() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    let ignored = rig.c.counters().frames_ignored;
    for ms in [20u16, 30, 40, 50, 60, 70] {
        request(&mut rig, download(0x1017, 0, &ms.to_le_bytes()));
    }
    let out = rig.run(3);
    assert_eq!(
        out.iter()
            .map(|c| answers_of(std::slice::from_ref(c)).len())
            .collect::<Vec<_>>(),
        [2, 2, 0]
    );
    assert!(answers_of(&out).iter().all(|a| a[0] == 0x60));
    assert_eq!(rig.c.counters().frames_ignored, ignored + 2);
    request(&mut rig, upload(0x1017, 0));
    assert_eq!(answers_of(&[rig.cycle()])[0][4..6], 50u16.to_le_bytes());
}

/// Item 2: the drives watch the controller's heartbeat with the 300 ms the controller
/// wrote into their 0x1016:1. 0 (off) would leave them without it, 310 ms — and a
/// configuration tool's usual 500 or 1000 ms — would let them time out between two
/// beats: each is refused with its reason, nothing changes, the crane keeps running; up
/// to half their time (150 ms) is taken and produced.
#[test]
fn a_heartbeat_the_drives_would_not_tolerate_is_refused() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    for (ms, why) in [
        (0u16, abort::PARAMETER_INCOMPATIBLE),
        (310, abort::VALUE_TOO_HIGH),
        (500, abort::VALUE_TOO_HIGH),
        (1000, abort::VALUE_TOO_HIGH),
        (160, abort::VALUE_TOO_HIGH),
    ] {
        request(&mut rig, download(0x1017, 0, &ms.to_le_bytes()));
        let answer = answers_of(&[rig.cycle()]);
        assert_eq!(code(&answer[0]), why, "{ms} ms");
    }
    let out = rig.run(100);
    assert!(every(&cycles_with(&out, 0x710), 10), "still every 100 ms");
    assert!(out.iter().all(|c| c.mode == Mode::Ready));
    request(&mut rig, download(0x1017, 0, &150u16.to_le_bytes()));
    assert_eq!(code(&answers_of(&[rig.cycle()])[0]), 0);
    let out = rig.run(150);
    assert!(every(&cycles_with(&out, 0x710), 15), "every 150 ms");
    assert!(
        every(&cycles_with(&out, 0x190), 10),
        "the status every 100 ms"
    );
}

/// The status frame has its own period: with no drive watching the controller (their
/// consumer time 0), 0x1017 = 0 is taken and the heartbeat stops — before, the status
/// stopped with it —, and at 50 ms the heartbeat doubles while the status stays at its
/// 100 ms.
#[test]
fn the_status_keeps_its_period_whatever_the_heartbeat() {
    let unwatched = DriveSetup {
        controller_timeout_ms: 0,
        ..DriveSetup::TROLLEY
    };
    let config = Config {
        nodes: [
            Some(NodeSetup::Drive(Drive::Trolley, unwatched)),
            Some(NodeSetup::Drive(
                Drive::Winch,
                DriveSetup {
                    controller_timeout_ms: 0,
                    ..DriveSetup::WINCH
                },
            )),
            None,
            None,
        ],
        ..Config::DEFAULT
    };
    let mut rig = Rig::configured(feedforward(HOME, None), HEALTHY, config);
    rig.ready();
    request(&mut rig, download(0x1017, 0, &0u16.to_le_bytes()));
    assert_eq!(code(&answers_of(&[rig.cycle()])[0]), 0);
    let out = rig.run(100);
    assert!(cycles_with(&out, 0x710).is_empty(), "no heartbeat");
    assert!(
        every(&cycles_with(&out, 0x190), 10),
        "the status every 100 ms"
    );
    request(&mut rig, download(0x1017, 0, &50u16.to_le_bytes()));
    rig.cycle();
    let out = rig.run(100);
    assert!(
        every(&cycles_with(&out, 0x710), 5),
        "the heartbeat every 50 ms"
    );
    assert!(
        every(&cycles_with(&out, 0x190), 10),
        "the status every 100 ms"
    );
}

/// Item 7: a download segment with no transfer running (the server answers expedited
/// transfers only) is aborted, 0x0504_0001, naming no object — before, its data bytes
/// came back as index and sub-index.
#[test]
fn a_stray_download_segment_is_aborted_naming_no_object() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    request(&mut rig, [0x00, 0x17, 0x10, 0x00, 0x64, 0, 0, 0]);
    let answers = answers_of(&[rig.cycle()]);
    assert_eq!(answers, [[0x80, 0, 0, 0, 0x01, 0x00, 0x04, 0x05]]);
    request(&mut rig, upload(0x1017, 0));
    assert_eq!(answers_of(&[rig.cycle()])[0][4], 100, "nothing written");
}

/// 0x1016:1 naming a node of the controller's own list (a drive, whose heartbeat the
/// list watches already) would be confirmed and never honoured: refused, 0x0604_0043.
#[test]
fn a_node_of_the_list_cannot_be_the_supervisor() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    let value = ((2u32 << 16) | 300).to_le_bytes();
    request(&mut rig, download(0x1016, 1, &value));
    assert_eq!(
        code(&answers_of(&[rig.cycle()])[0]),
        abort::PARAMETER_INCOMPATIBLE
    );
}
