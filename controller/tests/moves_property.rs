//! Random move requests, inside and outside the envelope, sent as CAN frames to the
//! controller running the real inverse model (BDF4, exact Jacobian, h = 10 ms):
//!
//! * every accepted move is executed with finite, in-limit set points, without a
//!   fault, and the load ends at rest at the target — in the model, and in a forward
//!   simulation of the crane (Eqs. 21-22) driven by the set points actually sent;
//!   a move "as fast as the limits allow" is the shortest to 2 % and the 10 ms grid;
//! * every rejected one names the right reason: an invalid request is recognised from
//!   the request alone; any other reason is a violation that an independent evaluation
//!   of docs/COMMANDS.md's rules finds on the path, and no reason of higher precedence
//!   is violated at the planner's sample points.
//!
//! 10,000 cases (`PROPTEST_CASES` overrides).

mod common;

use common::*;
use controller::commands::{decode_request, request_frame, Reject, Request};
use controller::planner::{DURATION_RANGE, MARGIN, MAX_DOWN_ACCELERATION, SAMPLES};
use controller::setpoint::DriveLimits;
use controller::{Mode, Replan};
use nalgebra::SVector;
use proptest::prelude::*;
use proptest::test_runner::TestRunner;
use sim::HEALTHY;
use solver_core::models::crane::CraneParams;
use solver_core::reference::flat_crane::flat_inverse;
use solver_core::reference::plant::crane_output;
use solver_core::trajectory::{PointToPoint, Trajectory};
use std::cell::RefCell;

/// The rules of docs/COMMANDS.md, evaluated at `samples + 1` points of `[t0, t1]`:
/// which reasons (4 to 10) the path violates.
fn violations(z: &PointToPoint<f64, 2>, t0: f64, t1: f64, samples: usize) -> Vec<u8> {
    let p = CraneParams::PAPER;
    let lim = DriveLimits::LAB;
    let mut found = [false; 11];
    for i in 0..=samples {
        let t = t0 + (t1 - t0) * i as f64 / samples as f64;
        let [zd, _, zdd]: [SVector<f64, 2>; 3] = z.derivatives(t);
        if zd[1] <= 0.0 {
            found[5] = true;
            continue;
        }
        if zdd[1] > MAX_DOWN_ACCELERATION * p.g {
            found[6] = true;
            continue;
        }
        let f = flat_inverse(&p, z, t);
        found[4] |= f.x < 10.0 || f.x > 23.0;
        found[5] |= f.l < 3.0 || f.l > 9.0;
        found[7] |= f.u[0].abs() > MARGIN * lim.trolley.max_velocity;
        found[8] |= f.u[1].abs() > MARGIN * lim.winch.max_velocity;
        found[9] |= f.u_dot[0].abs() > MARGIN * lim.trolley.max_acceleration;
        found[10] |= f.u_dot[1].abs() > MARGIN * lim.winch.max_acceleration;
    }
    (4..=10).filter(|&r| found[r as usize]).collect()
}

fn duration() -> impl Strategy<Value = Option<f64>> {
    prop_oneof![
        4 => Just(None),
        // Log-uniform: as many short, limit-bound moves as long, easy ones.
        5 => (0.5f64.ln()..20.0f64.ln()).prop_map(|l| Some(l.exp())),
        1 => (0.01..0.5f64).prop_map(Some),
        1 => (600.01..655.0f64).prop_map(Some),
    ]
}

fn coordinate(range: std::ops::Range<f64>) -> impl Strategy<Value = f64> {
    prop_oneof![30 => range, 1 => Just(0.0)]
}

/// A target anywhere around the workspace, or a short hop from home (the hops are
/// where the acceleration limits bind).
fn target() -> impl Strategy<Value = Target> {
    prop_oneof![
        (coordinate(8.0..25.0), coordinate(1.0..10.5)).prop_map(|(x, z)| Target::Absolute([x, z])),
        (-1.5..1.5f64, -1.5..1.5f64).prop_map(|(dx, dz)| Target::Hop([dx, dz])),
        (-1.5..1.5f64).prop_map(|dz| Target::Hop([0.0, dz])),
    ]
}

#[derive(Debug, Clone, Copy)]
enum Target {
    Absolute([f64; 2]),
    Hop([f64; 2]),
}

impl Target {
    fn from(self, home: [f64; 2]) -> [f64; 2] {
        match self {
            Target::Absolute(t) => t,
            Target::Hop([dx, dz]) => [home[0] + dx, home[1] + dz],
        }
    }
}

/// The longest a move's answer may take, cycles.
const ANSWER_CYCLES: usize = 15;

/// Runs one request from rest at `home` and checks its answer; counts the answers by
/// reason (0: accepted).
fn check_request(
    home: [f64; 2],
    request: Request,
    tally: &RefCell<[u32; 11]>,
) -> Result<(), TestCaseError> {
    let mut rig = Rig::with(feedforward(home, None), HEALTHY);
    rig.ready();
    let frame = request_frame(&request);
    // What the controller will see: millimetres and 10 ms ticks.
    let Ok(Request::Move {
        target, duration, ..
    }) = decode_request(frame.data())
    else {
        return Err(TestCaseError::fail("the request frame must decode"));
    };
    rig.c.on_frame(&frame, rig.now.into());
    let t0 = f64::from(rig.now) / 1000.0;
    // A move's search is spread over cycles: the answer comes within ANSWER_CYCLES.
    let id = request.id();
    let mut first = Vec::new();
    let s = loop {
        let out = rig.cycle();
        let s = status(&out.frames).filter(|s| s[0] == id && s[1] != 0);
        first.push(out);
        if let Some(s) = s {
            break s;
        }
        prop_assert!(
            first.len() < ANSWER_CYCLES,
            "no answer within {ANSWER_CYCLES} cycles"
        );
    };
    let invalid = target.iter().any(|v| *v <= 0.0)
        || duration.is_some_and(|d| !(DURATION_RANGE.0..=DURATION_RANGE.1).contains(&d));
    tally.borrow_mut()[usize::from(s[2])] += 1;
    match (s[1], s[2]) {
        (1, 0) => {
            prop_assert!(!invalid, "accepted an invalid request {request:?}");
            execute(&mut rig, home, target, duration, t0, first)
        }
        (3, r) if r == Reject::Invalid as u8 => {
            prop_assert!(invalid, "{request:?} called invalid");
            Ok(())
        }
        (3, r) => {
            prop_assert!(!invalid, "{request:?} is invalid, rejected with reason {r}");
            let d = duration.unwrap_or(DURATION_RANGE.1);
            let n = rig.c.feedforward().plan().planned_smoothness();
            let path =
                PointToPoint::new(SVector::from(home), SVector::from(target), t0, d, n).unwrap();
            let dense = violations(&path, t0, t0 + d, 20 * SAMPLES);
            prop_assert!(
                dense.contains(&r),
                "{request:?}: reason {r}, but the path violates {dense:?}"
            );
            let coarse = violations(&path, t0, t0 + d, SAMPLES);
            prop_assert!(
                coarse.iter().all(|&c| c >= r),
                "{request:?}: reason {r}, but {coarse:?} at the sample points"
            );
            prop_assert_eq!(
                rig.c.feedforward().plan().final_position(),
                SVector::from(home)
            );
            Ok(())
        }
        other => Err(TestCaseError::fail(format!(
            "answer {other:?} to {request:?}"
        ))),
    }
}

/// Runs an accepted move to its end and checks it.
fn execute(
    rig: &mut Rig,
    home: [f64; 2],
    target: [f64; 2],
    duration: Option<f64>,
    t0: f64,
    first: Vec<controller::Cycle>,
) -> Result<(), TestCaseError> {
    let plan = *rig.c.feedforward().plan();
    let (start, end) = plan.active_span();
    let answered = t0 + 0.01 * (first.len() - 1) as f64;
    prop_assert!(
        start >= t0 - 1e-9 && start <= answered + 1e-9,
        "starts at {start}, asked at {t0}"
    );
    if let Some(d) = duration {
        prop_assert!((end - start - d).abs() < 1e-9);
    } else {
        // The shortest, to the bisection's 2 % and the 10 ms grid: a little faster
        // than that breaks a rule.
        let faster = (end - start - 0.01) / 1.021;
        if faster >= DURATION_RANGE.0 {
            let n = plan.planned_smoothness();
            let m = PointToPoint::new(SVector::from(home), SVector::from(target), t0, faster, n)
                .unwrap();
            prop_assert!(
                planner().check(&m, t0, t0 + faster).is_err(),
                "{} s is not the shortest",
                end - start
            );
        }
    }
    let cycles = ((end - t0) / 0.01).ceil() as usize + 10;
    let mut outs = first;
    outs.extend(rig.run(cycles));
    prop_assert!(
        outs.iter().all(|c| c.mode == Mode::Ready),
        "left ready: {:?}",
        rig.c.mode()
    );
    assert_within_limits(&outs, &mut [0, 0]);
    // The model at rest at the target.
    let drives = rig.drives();
    for i in 0..2 {
        prop_assert!(
            (drives[i] - target[i]).abs() < 1e-4,
            "trolley and rope at {drives:?}, target {target:?}"
        );
    }
    prop_assert_eq!(outs.last().unwrap().setpoints.map(|s| s.units()), [0, 0]);
    // The crane driven by the set points sent; the swing shows for 2 s more.
    let t_first = f64::from(rig.now) / 1000.0 - 0.01 * outs.len() as f64;
    let mut worst = (0.0f64, 0.0f64);
    let settle = t_first + 0.01 * (outs.len() as f64);
    simulate_sent(&outs, t_first, home, |t, y| {
        if t >= settle {
            let load = crane_output(y);
            let off = ((load[0] - target[0]).powi(2) + (load[1] - target[1]).powi(2)).sqrt();
            // The load's velocity: trolley plus swing.
            let speed = (y[3] + y[4] * y[2].sin() + y[1] * y[5] * y[2].cos()).abs();
            worst = (worst.0.max(off), worst.1.max(speed));
        }
    })
    .map_err(TestCaseError::fail)?;
    prop_assert!(
        worst.0 < 1e-3 && worst.1 < 1e-3,
        "the crane's load: {:.2e} m off, {:.2e} m/s",
        worst.0,
        worst.1
    );
    Ok(())
}

#[test]
fn random_move_requests() {
    let config = property_config(10_000);
    let cases = config.cases;
    let tally = RefCell::new([0u32; 11]);
    let strategy = (
        (10.5..22.5f64, 3.2..8.8f64),
        target(),
        duration(),
        any::<u8>(),
    );
    let result = TestRunner::new(config).run(&strategy, |((hx, hz), target, duration, id)| {
        let home = [hx, hz];
        check_request(
            home,
            Request::Move {
                id,
                target: target.from(home),
                duration,
            },
            &tally,
        )
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let tally = tally.into_inner();
    println!("answers by reason (0 accepted): {tally:?}");
    if cases >= 10_000 {
        // Every reason a single request can earn, and plenty of executed moves.
        assert!(tally[0] >= 2_000, "{tally:?}");
        assert!(tally[3..].iter().all(|&n| n > 0), "{tally:?}");
    }
}
