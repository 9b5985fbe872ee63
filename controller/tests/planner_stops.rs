//! The planner's stops on the registered cranes (`scene::cranes`): the search's budget
//! of path samples suffices, no stop is shorter than the shortest move, and every reason
//! a crane names is one the planner ranks.
#![allow(clippy::unwrap_used)]

use controller::crane::Crane;
use controller::planner::{Planner, STOP_SAMPLES, STOP_SHORTEST};
use controller::setpoint::DriveLimits;
use nalgebra::SVector;
use scene::cranes::planar::Planar;
use scene::cranes::spatial::Spatial;
use solver_core::plan::Plan;

/// A plan at rest at `from` with the quickest move to `to` the planner allows, and
/// the time that move ends.
fn the_quickest_move<K: Crane<A>, const A: usize>(
    planner: &Planner<K, A>,
    from: [f64; A],
    to: [f64; A],
) -> (Plan<f64, A>, f64) {
    a_move(planner, from, to, None)
}

/// A plan at rest at `from` with a move to `to` in `duration` s (`None`: the
/// quickest), and the time that move ends.
fn a_move<K: Crane<A>, const A: usize>(
    planner: &Planner<K, A>,
    from: [f64; A],
    to: [f64; A],
    duration: Option<f64>,
) -> (Plan<f64, A>, f64) {
    let mut plan = Plan::at_rest(SVector::from(from), 5).unwrap();
    plan.push(planner.plan_move(&plan, to, duration, 0.0).unwrap())
        .unwrap();
    let end = plan.end_time().unwrap();
    (plan, end)
}

/// [`STOP_SAMPLES`] suffices: the smallest budget with which the search finds what it
/// finds without one, over stops at every 0.25 s of moves from one place to many —
/// the quickest ones and the 8 s moves, whose longer spans the scan climbs
/// further — on the planar and the 3D crane, stays within it (printed: `cargo test -p controller
/// --release --lib stop_budget -- --nocapture`). A search that needs more ends with
/// the running move as the stop — safe, but not as short as the limits allow.
#[test]
fn the_stop_budget_suffices() {
    fn most_needed<K: Crane<A>, const A: usize>(
        planner: &Planner<K, A>,
        from: [f64; A],
        moves: &[([f64; A], Option<f64>)],
    ) -> (u32, usize) {
        let (mut most, mut stops) = (0, 0);
        for (to, duration) in moves {
            let (plan, end) = a_move(planner, from, *to, *duration);
            for i in 1..(end * 4.0) as usize {
                let t = i as f64 * 0.25;
                let unlimited = planner.stop_within(&plan, t, end, u32::MAX);
                // The search only ever stops early on its budget: bisect the least.
                let (mut lo, mut hi) = (0, 1 << 16);
                assert_eq!(planner.stop_within(&plan, t, end, hi), unlimited);
                while hi - lo > 1 {
                    let mid = (lo + hi) / 2;
                    if planner.stop_within(&plan, t, end, mid) == unlimited {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                most = most.max(hi);
                stops += 1;
            }
        }
        (most, stops)
    }
    let planar = Planner::with_axes(Planar::PAPER, DriveLimits::LAB.axes());
    let planar_moves = [
        ([20.0, 5.0], None),
        ([20.0, 5.0], Some(8.0)),
        ([20.0, 4.0], None),
        ([14.0, 7.0], None),
        ([19.0, 8.5], None),
        ([14.0, 7.0], Some(10.0)),
    ];
    let (planar_most, planar_stops) = most_needed(&planar, [12.0, 8.0], &planar_moves);
    let crane3d = Planner::with_axes(Spatial::EXAMPLE, DriveLimits::LAB_3D);
    let moves_3d = [
        ([14.0, 4.5, 6.5], None),
        ([14.0, 4.5, 6.5], Some(8.0)),
        ([16.0, 5.0, 6.0], None),
        ([20.0, 3.0, 4.0], None),
        ([16.0, 5.0, 6.0], Some(10.0)),
    ];
    let (most_3d, stops_3d) = most_needed(&crane3d, [12.0, 3.0, 8.0], &moves_3d);
    std::eprintln!(
        "path samples a stop's search needed at most: planar {planar_most} ({planar_stops} stops), 3D {most_3d} ({stops_3d} stops); the budget {STOP_SAMPLES}"
    );
    assert!(planar_most <= STOP_SAMPLES && most_3d <= STOP_SAMPLES);
}

/// No stop shorter than [`STOP_SHORTEST`], also in a move's last half second, where
/// the longest stop that fits is shorter: there the running segment is the rest.
#[test]
fn no_stop_is_shorter_than_the_shortest_move() {
    fn every_stop_long_enough<K: Crane<A>, const A: usize>(
        planner: &Planner<K, A>,
        from: [f64; A],
        to: [f64; A],
    ) {
        let (plan, end) = the_quickest_move(planner, from, to);
        for i in 0..=60 {
            let t = end - 0.6 + f64::from(i) * 0.01;
            if let Some(stop) = planner.plan_stop(&plan, t) {
                assert!(
                    stop.t_end() - t >= STOP_SHORTEST - 1e-9,
                    "a stop of {:.3} s at {t:.2} s of {end:.2}",
                    stop.t_end() - t
                );
            }
        }
    }
    every_stop_long_enough(
        &Planner::with_axes(Planar::PAPER, DriveLimits::LAB.axes()),
        [12.0, 8.0],
        [20.0, 4.0],
    );
    every_stop_long_enough(
        &Planner::with_axes(Spatial::EXAMPLE, DriveLimits::LAB_3D),
        [12.0, 3.0, 8.0],
        [16.0, 5.0, 6.0],
    );
}
