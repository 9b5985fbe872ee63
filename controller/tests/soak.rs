//! The soak traffic on the host: ten simulated minutes of random valid and invalid
//! requests, garbage, drive faults, silent drives, failed solver steps and bus-offs
//! after the paper's move. Whatever comes, every set point is within the limits, the
//! choke point never has to refuse the model, and the crane comes back after resets.
//! (`cargo xtask soak --minutes M` runs the same traffic on the QEMU firmware.)

mod common;

use common::*;
use controller::{Fault, Mode};
use sim::{Scenario, SOAK};

#[test]
fn ten_minutes_of_random_traffic_keep_every_set_point_within_the_limits() {
    let scenario = Scenario {
        cycles: 60_000,
        ..SOAK
    };
    let mut rig = Rig::new(scenario, true);
    let mut last = [0; 2];
    let mut answers = [0u32; 4];
    let mut faults = [0u32; 8];
    let mut ready_cycles = 0u32;
    let mut previous = Mode::Enabling;
    let mut last_answer = None;
    for _ in 0..scenario.cycles {
        let out = rig.cycle();
        assert_within_limits(std::slice::from_ref(&out), &mut last);
        assert!(
            !matches!(out.mode.fault(), Some(Fault::Setpoint(_))),
            "the model needed the choke point: {:?}",
            out.mode
        );
        if out.mode != previous {
            if let Some(f) = out.mode.fault() {
                if previous.fault().is_none() {
                    faults[usize::from(f.code())] += 1;
                }
            }
            previous = out.mode;
        }
        ready_cycles += u32::from(out.mode == Mode::Ready);
        if let Some(s) = status(&out.frames) {
            if s[1] != 0 && last_answer != Some(s[0]) {
                answers[usize::from(s[1])] += 1;
                last_answer = Some(s[0]);
            }
        }
    }
    println!("answers (none, accepted, queued, rejected): {answers:?}; faults by code: {faults:?}; ready {ready_cycles} of {} cycles; {:?}", scenario.cycles, rig.c.counters());
    assert!(
        answers[1] > 50 && answers[2] > 5 && answers[3] > 100,
        "{answers:?}"
    );
    assert!(
        faults[1] + faults[3] + faults[4] + faults[6] > 3,
        "faults met: {faults:?}"
    );
    assert!(
        ready_cycles > scenario.cycles / 2,
        "the crane came back after its faults"
    );
    assert_eq!(rig.c.counters().frames_lost, 0);
}
