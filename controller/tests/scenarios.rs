//! The virtual bus's scenarios, run on the host exactly as the QEMU firmware runs them
//! (`sim::run_cycle`): each ends in the state docs/COMMANDS.md documents, with
//! the answers, modes and EMCYs it documents, and every set point within the limits.

mod common;

use common::*;
use controller::cia402::controlword as cw;
use controller::drive::{Drive, PLANAR};
use controller::{Fault, Mode, Replan};
use sim::Scenario;
use solver_core::Error;

/// Runs a scenario with the paper's move planned, as the firmware does; checks the limits.
fn play(scenario: Scenario) -> (Rig, Vec<controller::Cycle>) {
    let mut rig = Rig::new(scenario, true);
    let n = if scenario.cycles == 0 {
        1000
    } else {
        scenario.cycles as usize
    };
    let cycles = rig.run(n);
    assert_within_limits(&cycles, &mut [0; 2]);
    assert!(
        scenario.ends.admits(rig.c.mode()),
        "{} ends {:?}",
        scenario.name,
        rig.c.mode()
    );
    assert_eq!(
        rig.c.counters().frames_lost,
        0,
        "a cycle's frames never overflow"
    );
    (rig, cycles)
}

/// The crane is at rest at `at` (the model's trolley and rope, the plan, the set points).
fn assert_at_rest(rig: &Rig, cycles: &[controller::Cycle], at: [f64; 2]) {
    let plan = rig.c.feedforward().plan().final_position();
    let drives = rig.drives();
    for i in 0..2 {
        assert!(
            (plan[i] - at[i]).abs() < 1e-9,
            "plan ends at {plan:?}, not {at:?}"
        );
        assert!(
            (drives[i] - at[i]).abs() < 1e-4,
            "trolley and rope at {drives:?}, not {at:?}"
        );
    }
    let last = cycles.last().unwrap();
    assert_eq!(last.setpoints.map(|s| s.units()), [0, 0], "standstill");
}

const READY: (u32, Mode) = (750, Mode::Ready);

#[test]
fn healthy_follows_the_paper_move_and_rests_at_the_target() {
    let (rig, cycles) = play(sim::HEALTHY);
    assert_eq!(modes(&cycles), vec![(0, Mode::Enabling), READY]);
    assert_at_rest(&rig, &cycles, [20.0, 4.0]);
    assert!(emcys(&cycles).is_empty());
    assert!(answers(&cycles).is_empty());
}

#[test]
fn two_moves_back_to_back_the_second_queued() {
    let (rig, cycles) = play(sim::TWO_MOVES);
    assert_eq!(
        answers(&cycles),
        vec![(1, 1, 0), (2, 2, 0)],
        "accepted, then queued"
    );
    assert_eq!(modes(&cycles), vec![(0, Mode::Enabling), READY]);
    assert_at_rest(&rig, &cycles, [15.0, 6.0]);
}

#[test]
fn rejections_give_every_reason_and_change_nothing() {
    let (rig, cycles) = play(sim::REJECTIONS);
    let expected = vec![
        (1, 3, 2),   // not ready
        (2, 2, 0),   // queued
        (3, 3, 1),   // busy
        (4, 3, 3),   // invalid
        (5, 3, 4),   // trolley workspace
        (6, 3, 5),   // rope workspace
        (7, 3, 6),   // slack rope
        (8, 3, 7),   // trolley velocity
        (9, 3, 8),   // winch velocity
        (10, 3, 9),  // trolley acceleration
        (11, 3, 10), // winch acceleration
        (12, 1, 0),  // accepted
    ];
    assert_eq!(answers(&cycles), expected);
    assert_eq!(modes(&cycles), vec![(0, Mode::Enabling), READY]);
    assert_at_rest(&rig, &cycles, [16.0, 6.0]);
    // The answer goes out in the cycle that handles the request.
    let at = |ms: usize| status(&cycles[ms / 10].frames).unwrap();
    assert_eq!(at(13_100)[..3], [4, 3, 3]);
    assert_eq!(at(13_200)[..3], [5, 3, 4]);
}

#[test]
fn a_storm_of_garbage_is_counted_and_changes_no_set_point() {
    let (rig, noisy) = play(sim::STORM);
    let (_, clean) = play(sim::HEALTHY);
    assert_eq!(rig.c.counters().frames_ignored, 100);
    for (i, (a, b)) in clean.iter().zip(&noisy).enumerate() {
        assert_eq!(a.setpoints, b.setpoints, "cycle {i}");
        assert_eq!(a.mode, b.mode, "cycle {i}");
    }
    let last = status(&noisy[990].frames).unwrap();
    assert_eq!(last[5], 100, "reported in the status frame");
    assert_at_rest(&rig, &noisy, [20.0, 4.0]);
}

#[test]
fn drive_fault_quick_stops_halts_and_recovers_after_a_reset() {
    let (rig, cycles) = play(sim::DRIVE_FAULT);
    let fault = Fault::DriveFault(Drive::Winch);
    let m = modes(&cycles);
    assert_eq!(
        m[..3],
        [(0, Mode::Enabling), READY, (5_000, Mode::QuickStop(fault))]
    );
    assert!(matches!(m[3], (_, Mode::Halted(f)) if f == fault), "{m:?}");
    assert_eq!(m[4], (8_000, Mode::Enabling), "the reset");
    assert!(matches!(m[5], (_, Mode::Ready)), "{m:?}");
    assert_eq!(m.len(), 6);
    assert_eq!(
        emcys(&cycles),
        vec![(5_000, (0xFF02, 0x81, 3, 2)), (8_000, (0x0000, 0, 0, 0))],
        "drive fault naming the winch, then the reset"
    );
    // Both drives get quick stop from the fault on.
    let quick = &cycles[500];
    assert_eq!(rpdo(&quick.frames, Drive::Trolley).0, cw::QUICK_STOP);
    assert_eq!(rpdo(&quick.frames, Drive::Winch).0, cw::QUICK_STOP);
    // The re-enable sequence after the reset, controlword by controlword.
    let words = |d| {
        let mut w: Vec<u16> = cycles[800..].iter().map(|c| rpdo(&c.frames, d).0).collect();
        w.dedup();
        w
    };
    assert_eq!(
        words(Drive::Winch),
        vec![
            cw::FAULT_RESET,
            cw::SHUTDOWN,
            cw::SWITCH_ON,
            cw::ENABLE_OPERATION
        ]
    );
    assert_eq!(
        words(Drive::Trolley),
        vec![
            cw::DISABLE_VOLTAGE,
            cw::SHUTDOWN,
            cw::SWITCH_ON,
            cw::ENABLE_OPERATION
        ]
    );
    // Restarted where the drives stopped: the rope where the winch faulted, the trolley
    // beyond where it was, by its quick-stop travel.
    let home = rig.c.feedforward().plan().final_position();
    assert_at_rest(&rig, &cycles, [home[0], home[1]]);
}

#[test]
fn newton_failure_ramps_down_then_halts() {
    let (_, cycles) = play(sim::NEWTON_FAILURE);
    let fault = Fault::Solver(Error::NewtonNotConverged {
        t: 5.0,
        iterations: 20,
        residual: f64::INFINITY,
        increment: f64::INFINITY,
    });
    let m = modes(&cycles);
    assert_eq!(
        m[..3],
        [(0, Mode::Enabling), READY, (5_000, Mode::Stopping(fault))]
    );
    assert!(matches!(m[3], (_, Mode::Halted(f)) if f == fault), "{m:?}");
    assert_eq!(m.len(), 4);
    assert_eq!(emcys(&cycles), vec![(5_000, (0x6100, 0x81, 1, 0))]);
    assert_eq!(
        emcy_detail(&cycles[500].frames),
        Some(1),
        "Newton did not converge"
    );
    assert_controlled_stop(&cycles, 500);
}

#[test]
fn lost_heartbeat_quick_stops_and_halts() {
    let (_, cycles) = play(sim::LOST_HEARTBEAT);
    // The silent drive's TPDOs stop with its heartbeat: the last arrived at 4.00 s
    // (answering the SYNC of 3.99 s), and they are lost when more than 50 ms old — long
    // before its heartbeat (300 ms).
    let fault = Fault::TpdoTimeout(Drive::Trolley);
    let m = modes(&cycles);
    assert_eq!(
        m[..3],
        [(0, Mode::Enabling), READY, (4_060, Mode::QuickStop(fault))]
    );
    assert!(matches!(m[3], (_, Mode::Halted(f)) if f == fault), "{m:?}");
    assert_eq!(emcys(&cycles), vec![(4_060, (0x8250, 0x11, 10, 1))]);
}

#[test]
fn stop_request_brings_the_load_to_rest_smoothly() {
    let (rig, cycles) = play(sim::STOP);
    assert_eq!(answers(&cycles), vec![(1, 1, 0)]);
    assert_eq!(
        modes(&cycles),
        vec![(0, Mode::Enabling), READY],
        "no fault, no ramp: a planned stop"
    );
    let end = rig.c.feedforward().plan().final_position();
    assert!(end[0] < 20.0, "short of the target: {end:?}");
    assert_at_rest(&rig, &cycles, [end[0], end[1]]);
    // The stop (4 s to 8 s) really cut the move short of its 9 s end.
    let last_motion = |cycles: &[controller::Cycle]| {
        cycles
            .iter()
            .rposition(|c| c.setpoints.iter().any(|s| s.units() != 0))
            .unwrap()
    };
    let (_, healthy) = play(sim::HEALTHY);
    assert!(
        last_motion(&cycles) + 95 < last_motion(&healthy),
        "{} vs {} cycles",
        last_motion(&cycles),
        last_motion(&healthy)
    );
}

#[test]
fn bus_off_is_counted_then_halts_when_set_points_cannot_be_delivered() {
    let (rig, cycles) = play(sim::BUS_OFF);
    let m = modes(&cycles);
    assert_eq!(m[..2], [(0, Mode::Enabling), READY]);
    // 3.00–3.01 s off: two failed cycles, no fault. 6.00–6.04 s off: the third failed
    // cycle in a row halts.
    assert_eq!(m[2], (6_030, Mode::Halted(Fault::Undeliverable)));
    let e = emcys(&cycles);
    assert!(e.iter().all(|(_, x)| *x == (0x8100, 0x11, 6, 0)), "{e:?}");
    assert_eq!(e.first().map(|x| x.0), Some(6_030));
    assert_eq!(
        e.last().map(|x| x.0),
        Some(6_050),
        "sent again until the bus is back"
    );
    // Every frame sent from the cycle the bus goes off up to the SYNC of its last cycle:
    // 3.00 s: 2 RPDOs, SYNC, heartbeat, status; 3.01 s: 2 RPDOs, SYNC; 6.00 s as 3.00 s;
    // 6.01, 6.02 s as 3.01 s; 6.03, 6.04 s: 2 RPDOs, EMCY, SYNC.
    let failures = rig.c.counters().tx_failures;
    assert_eq!(failures, 5 + 3 + 5 + 3 + 3 + 4 + 4);
    assert_eq!(
        status(&cycles[990].frames).unwrap()[7],
        failures.min(255) as u8
    );
}

/// From cycle `from` on: *enable operation* while the set points ramp down at the
/// acceleration limit, then *quick stop* at zero.
fn assert_controlled_stop(cycles: &[controller::Cycle], from: usize) {
    let mut at_zero = false;
    for c in &cycles[from..] {
        for d in PLANAR {
            let (word, v) = rpdo(&c.frames, d);
            if at_zero {
                assert_eq!((word, v), (cw::QUICK_STOP, 0));
            } else {
                assert_eq!(word, cw::ENABLE_OPERATION);
            }
        }
        at_zero = at_zero || matches!(c.mode, Mode::Halted(_));
    }
    assert!(at_zero, "never reached standstill");
}

#[test]
fn a_hang_restarts_the_controller_halted_until_a_reset() {
    // First boot: the paper's move until the hang at 5 s stops the cycle.
    let mut rig = Rig::new(sim::HANG, true);
    let mut ran = 0;
    while rig.try_cycle().is_some() {
        ran += 1;
    }
    assert_eq!(ran, 500, "the 100 Hz task stopped at 5 s");
    // Second boot, as the firmware comes up after the watchdog's reset: no scene move,
    // halted, the hang not repeated.
    let mut rig = Rig::with(feedforward(HOME, None), sim::HANG);
    rig.bus = rig.bus.clone().without_hangs();
    rig.c.restarted_by_watchdog();
    let cycles = rig.run(sim::HANG.cycles as usize);
    assert_within_limits(&cycles, &mut [0; 2]);
    let m = modes(&cycles);
    assert_eq!(
        m[..2],
        [(0, Mode::Halted(Fault::Watchdog)), (1_000, Mode::Enabling)],
        "{m:?}"
    );
    assert!(matches!(m[2], (_, Mode::Ready)), "{m:?}");
    assert_eq!(
        emcys(&cycles),
        vec![(0, (0x6010, 0x81, 8, 0)), (1_000, (0, 0, 0, 0))],
        "software reset (watchdog), then the reset"
    );
    // Commissioned again (the drives are found by their boot-up), and held.
    let quick_stops = cycles[..100]
        .iter()
        .flat_map(|c| c.frames.iter())
        .filter(|f| matches!(f.id(), 0x201 | 0x202))
        .inspect(|f| {
            assert_eq!(
                f.data(),
                &[0x02, 0, 0, 0, 0, 0],
                "nothing moves after a crash"
            )
        })
        .count();
    assert!(quick_stops > 2 * 20, "{quick_stops} RPDOs");
    assert_eq!(answers(&cycles), vec![(1, 1, 0)]);
    assert_at_rest(&rig, &cycles, HOME);
    assert!(sim::HANG.ends.admits(rig.c.mode()));
}

/// The trolley creeps at rest: fault 20 one second later, halted (more in
/// `tests/supervision.rs`).
#[test]
fn a_creeping_trolley_halts_the_crane() {
    let (rig, cycles) = play(sim::CREEP);
    assert_eq!(
        rig.c.mode(),
        Mode::Halted(Fault::Standstill(Drive::Trolley))
    );
    let emcys = emcys(&cycles);
    assert_eq!(emcys.len(), 1);
    assert_eq!(emcys[0].1, (0x8500, 0x81, 20, 1));
    assert!((11_000..=11_050).contains(&emcys[0].0), "{:?}", emcys[0]);
}

#[test]
fn every_scenario_is_tested_here() {
    let names: Vec<_> = sim::SCENARIOS.iter().map(|s| s.name).collect();
    assert_eq!(
        names,
        [
            "healthy",
            "two-moves",
            "rejections",
            "storm",
            "drive-fault",
            "newton-failure",
            "lost-heartbeat",
            "stop",
            "bus-off",
            "hang",
            "creep"
        ]
    );
}
