//! A stop obeyed at any instant of any move (docs/COMMANDS.md, "Stop"), as a property:
//! random moves accepted from random places, stopped at a random instant — a third of
//! them around the move's peak velocity, where the rule before this one carried the load
//! more than a metre past its target — and run to rest on the controller with the real
//! inverse model (BDF4, exact Jacobian, h = 10 ms) and the virtual bus's drives:
//!
//! * the stop is answered *accepted* in the cycle it arrives, and nothing faults;
//! * the plan comes to rest no later than the move would have, on the move's straight
//!   path, at or before the target in every axis;
//! * the crane driven by the set points actually sent (a forward simulation of
//!   Eqs. 21-22) keeps its load at or before the target in every axis at every instant,
//!   and brings it to rest there;
//! * every set point is finite and within the limits;
//! * as short as the limits allow (issue 32): no stop that
//!   rests at half the distance from where the load was — any duration from 0.5 s to
//!   the move's end, in steps of 5 % — keeps the rules (`Planner::stop_passes`; the
//!   search's stops are nearer the family's nearest than that, the study
//!   `stop_search_against_a_fine_search` says how near); and the load
//!   comes to rest within the published stopping distance (docs/COMMANDS.md, "Stopping
//!   distance"): while the load decelerates, [`DECELERATING_S`] times its speed when the
//!   stop arrives; in every case no farther than the rest of the move's path.
//!
//! 2,000 cases (`PROPTEST_CASES` overrides). It prints the stopping distance by the
//! load's speed, the table of docs/COMMANDS.md.

mod common;

use common::*;
use controller::commands::{request_frame, Request};
use controller::{Mode, Replan};
use nalgebra::SVector;
use proptest::prelude::*;
use proptest::test_runner::TestRunner;
use sim::HEALTHY;
use solver_core::reference::plant::crane_output;
use solver_core::trajectory::Trajectory;
use std::cell::RefCell;

/// How far the simulated load may pass the target in an axis: the scheme's error on
/// the set points and their rounding to µm/s.
const PAST_TARGET_M: f64 = 2e-3;

/// The stopping distance of a stop that arrives while the load decelerates, as a time
/// at the load's speed then: the load rests within this many seconds' travel at that
/// speed (docs/COMMANDS.md, "Stopping distance"; 2.1 s the most seen in 10,000 stops).
const DECELERATING_S: f64 = 2.5;

/// The speed bands of the stopping-distance table, m/s.
const BANDS: [f64; 9] = [0.0, 0.1, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0];

/// The share of the stop's distance at which a nearer stop is tried: none may keep the
/// rules.
const NEARER: f64 = 0.5;

/// The stop instant as a fraction of the move's duration: anywhere, around the peak
/// velocity, or while the crane still accelerates.
fn stop_at() -> impl Strategy<Value = f64> {
    prop_oneof![
        1 => 0.01..0.99f64,
        1 => 0.4..0.6f64,
        1 => 0.15..0.45f64,
    ]
}

#[derive(Default)]
struct Tally {
    stopped: u32,
    short_of_target: u32,
    rejected_moves: u32,
    /// Σ (time to rest after the stop) / (time the move had left).
    time_share: f64,
    /// Stops the search found none for (the move ran on) where one resting at half the
    /// distance keeps the rules.
    missed: u32,
    /// Per speed band and phase (decelerating, accelerating): stops, the longest
    /// stopping distance, m, and the longest as a time at the load's speed, s.
    bands: [[(u32, f64, f64); 2]; BANDS.len()],
}

fn check_stop(
    home: [f64; 2],
    target: [f64; 2],
    duration: Option<f64>,
    fraction: f64,
    tally: &RefCell<Tally>,
) -> Result<(), TestCaseError> {
    let mut rig = Rig::with(feedforward(home, None), HEALTHY);
    rig.ready();
    let request = Request::Move {
        id: 1,
        target,
        duration,
    };
    rig.c.on_frame(&request_frame(&request), rig.now.into());
    let mut outs = Vec::new();
    let accepted = loop {
        let out = rig.cycle();
        let s = status(&out.frames).filter(|s| s[0] == 1 && s[1] != 0);
        outs.push(out);
        if let Some(s) = s {
            break s[1] == 1;
        }
        prop_assert!(outs.len() < 20, "no answer to the move");
    };
    if !accepted {
        tally.borrow_mut().rejected_moves += 1;
        return Ok(());
    }
    let plan = *rig.c.feedforward().plan();
    let (start, end) = plan.active_span();
    let from: [f64; 2] = plan.derivatives::<1>(start)[0].into();
    let to: [f64; 2] = plan.final_position().into();
    let t_stop = start + fraction * (end - start);
    while f64::from(rig.now) / 1000.0 < t_stop {
        outs.push(rig.cycle());
    }
    // A fresh id, as an operator's stop button sends; obeyed in the next cycle.
    rig.c
        .on_frame(&request_frame(&Request::Stop { id: 2 }), rig.now.into());
    let t_obeyed = f64::from(rig.now) / 1000.0;
    let out = rig.cycle();
    prop_assert_eq!(
        status(&out.frames).map(|s| [s[0], s[1], s[2]]),
        Some([2, 1, 0]),
        "the stop is accepted in the cycle it arrives"
    );
    outs.push(out);
    let stopped = *rig.c.feedforward().plan();
    let rest_at = stopped.end_time().unwrap_or(t_stop);
    prop_assert!(
        rest_at <= end + 1e-9,
        "rests at {rest_at} s, the move would have at {end} s"
    );
    // On the path, at or before the target in every axis.
    let rest: [f64; 2] = stopped.final_position().into();
    let dir = [to[0] - from[0], to[1] - from[1]];
    let len2 = dir[0] * dir[0] + dir[1] * dir[1];
    // (A move to where the crane already is has no path: it rests where it is.)
    let sigma = if len2 > 0.0 {
        ((rest[0] - from[0]) * dir[0] + (rest[1] - from[1]) * dir[1]) / len2
    } else {
        0.0
    };
    prop_assert!(sigma <= 1.0 + 1e-12, "rests at σ = {sigma}");
    for i in 0..2 {
        let on = from[i] + sigma * dir[i];
        prop_assert!((rest[i] - on).abs() < 1e-9, "off the path: {rest:?}");
    }
    let cycles = ((rest_at - f64::from(rig.now) / 1000.0) / 0.01)
        .ceil()
        .max(0.0) as usize
        + 10;
    outs.extend(rig.run(cycles));
    prop_assert!(
        outs.iter().all(|c| c.mode == Mode::Ready),
        "left ready: {:?}",
        rig.c.mode()
    );
    assert_within_limits(&outs, &mut [0, 0]);
    prop_assert_eq!(outs.last().unwrap().setpoints.map(|s| s.units()), [0, 0]);
    let drives = rig.drives();
    for i in 0..2 {
        prop_assert!(
            (drives[i] - rest[i]).abs() < 1e-4,
            "the model rests at {drives:?}, the plan at {rest:?}"
        );
    }
    // The crane driven by the set points sent.
    let t_first = f64::from(rig.now) / 1000.0 - 0.01 * outs.len() as f64;
    let mut past = 0.0f64;
    let mut last = SVector::<f64, 2>::zeros();
    simulate_sent(&outs, t_first, home, |_, y| {
        let load = crane_output(y);
        for i in 0..2 {
            // How far the load is beyond the target in the direction of travel.
            let beyond = (load[i] - to[i]) * dir[i].signum();
            past = past.max(beyond);
        }
        last = load;
    })
    .map_err(TestCaseError::fail)?;
    prop_assert!(
        past <= PAST_TARGET_M,
        "the crane's load passed the target by {past:.4} m"
    );
    let off = ((last[0] - rest[0]).powi(2) + (last[1] - rest[1]).powi(2)).sqrt();
    prop_assert!(off < 1e-3, "the load rests {off:.2e} m from the stop's end");
    // As short as the limits allow.
    // No stop resting at half the distance keeps the rules — asserted of every stop
    // the search found; where it found none and the move runs on to its target, counted
    // (the search's coarse check can miss a narrow region of stops that pass).
    let planner = planner();
    let start_of_stop = planner.stop_start(&plan, t_obeyed).expect("moving");
    let s0 = start_of_stop.fraction();
    let nearer = s0 + NEARER * (sigma.min(1.0) - s0);
    let mut d = controller::planner::STOP_SHORTEST;
    let mut missed = false;
    while t_obeyed + d <= end && !missed {
        if let Ok(stop) = start_of_stop.stop(d, nearer) {
            missed = planner.stop_passes(&plan, t_obeyed, &stop);
            prop_assert!(
                !missed || sigma >= 1.0 - 1e-9,
                "a stop of {d:.2} s resting at σ = {nearer:.4} (found: {sigma:.4}) keeps the rules"
            );
        }
        d *= 1.05;
    }
    // The stopping distance, by the load's speed when the stop arrived.
    let [here, velocity, acceleration]: [SVector<f64, 2>; 3] = plan.derivatives(t_obeyed);
    let speed = velocity.norm();
    let distance = (SVector::from(rest) - here).norm();
    let decelerating = acceleration.dot(&velocity) < 0.0;
    let remaining = (SVector::from(to) - here).norm();
    prop_assert!(
        distance <= remaining + 1e-9,
        "{distance} m, {remaining} m left"
    );
    if decelerating {
        prop_assert!(
            distance <= DECELERATING_S * speed,
            "decelerating at {speed:.3} m/s: at rest {distance:.3} m on"
        );
    }
    let mut t = tally.borrow_mut();
    t.missed += u32::from(missed);
    let band = BANDS.iter().rposition(|v| speed >= *v).unwrap_or(0);
    let cell = &mut t.bands[band][usize::from(!decelerating)];
    cell.0 += 1;
    cell.1 = cell.1.max(distance);
    cell.2 = cell.2.max(distance / speed.max(1e-12));
    t.stopped += 1;
    if sigma < 1.0 - 1e-9 {
        t.short_of_target += 1;
    }
    t.time_share += (rest_at - t_stop) / (end - t_stop);
    Ok(())
}

#[test]
fn a_stop_at_any_instant_rests_on_the_path_at_or_before_the_target() {
    let config = property_config(2_000);
    let cases = config.cases;
    let tally = RefCell::new(Tally::default());
    let strategy = (
        (10.5..22.5f64, 3.2..8.8f64),
        (10.5..22.5f64, 3.2..8.8f64),
        prop_oneof![1 => Just(None), 2 => (1.0..12.0f64).prop_map(Some)],
        stop_at(),
    );
    let result = TestRunner::new(config).run(&strategy, |(home, target, duration, at)| {
        check_stop([home.0, home.1], [target.0, target.1], duration, at, &tally)
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let t = tally.into_inner();
    println!(
        "stopped {} moves ({} short of the target, the rest on the move itself); {} moves \
         rejected; at rest after {:.0} % of the time the move had left, on average",
        t.stopped,
        t.short_of_target,
        t.rejected_moves,
        100.0 * t.time_share / f64::from(t.stopped.max(1)),
    );
    println!(
        "the move ran on where a stop at half the distance keeps the rules: {} of {}",
        t.missed, t.stopped
    );
    println!(
        "stopping distance by the load's speed when the stop arrived (most, m; most / speed, s):"
    );
    println!("| speed, m/s | decelerating: stops | m | s | accelerating: stops | m | s |");
    for (i, [dec, acc]) in t.bands.iter().enumerate() {
        let upper = BANDS.get(i + 1).map_or("…".into(), |v| format!("{v}"));
        println!(
            "| {}–{upper} | {} | {:.2} | {:.2} | {} | {:.2} | {:.2} |",
            BANDS[i], dec.0, dec.1, dec.2, acc.0, acc.1, acc.2
        );
    }
    if cases >= 1_000 {
        assert!(
            t.stopped as usize >= cases as usize / 2,
            "too few moves accepted"
        );
        assert!(
            t.short_of_target >= t.stopped / 3,
            "most stops must come to rest short of the target"
        );
        // The search misses a stop at half the distance for at most 1 % of the stops.
        assert!(
            t.missed * 100 <= t.stopped,
            "{} of {} stops ran on where one at half the distance keeps the rules",
            t.missed,
            t.stopped
        );
    }
}
