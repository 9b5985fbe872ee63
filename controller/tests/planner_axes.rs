//! The planner over its number of axes: the 3D crane's moves are checked as the planar
//! crane's are, the planar crane is the 3D crane's special case (a move at a constant
//! trolley position y is planned exactly as the planar planner plans it, the planar
//! trolley's reasons becoming the bridge's), and each 3D axis names its own violation.

use controller::commands::Reject;
use controller::planner::Planner;
use controller::setpoint::{AxisLimits, DriveLimits};
use nalgebra::SVector;
use scene::cranes::planar::Planar;
use scene::cranes::spatial::Spatial;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::Crane3dParams;
use solver_core::plan::Plan;

const SMOOTHNESS: usize = 5;

fn planar() -> Planner<Planar, 2> {
    Planner::with_axes(Planar::PAPER, DriveLimits::LAB.axes())
}

/// The planar crane extruded across an 8 m span; the trolley across it gets `trolley`.
fn extruded(trolley: AxisLimits) -> Planner<Spatial, 3> {
    let lab = DriveLimits::LAB;
    Planner::with_axes(
        Spatial(Crane3dParams::extruded(&CraneParams::PAPER, 0.03, 0.0, 8.0)),
        [lab.trolley, trolley, lab.winch],
    )
}

fn planar_plan(at: [f64; 2]) -> Plan<f64, 2> {
    Plan::at_rest(SVector::from(at), SMOOTHNESS).unwrap()
}

fn plan_3d(at: [f64; 3]) -> Plan<f64, 3> {
    Plan::at_rest(SVector::from(at), SMOOTHNESS).unwrap()
}

/// The bridge's reasons where the planar crane names its trolley's.
fn as_bridge(reason: Reject) -> Reject {
    match reason {
        Reject::TrolleyWorkspace => Reject::BridgeWorkspace,
        Reject::TrolleyVelocity => Reject::BridgeVelocity,
        Reject::TrolleyAcceleration => Reject::BridgeAcceleration,
        other => other,
    }
}

#[test]
fn a_planar_move_is_the_3d_cranes_special_case() {
    let any_trolley = AxisLimits {
        max_velocity: 1.0,
        max_acceleration: 1.0,
    };
    // Each case with what the planar planner answers: accepted, or the reason.
    let cases = [
        ([12.0, 8.0], [20.0, 4.0], None, None),
        ([12.0, 8.0], [20.0, 4.0], Some(8.0), None),
        (
            [12.0, 8.0],
            [20.0, 4.0],
            Some(2.0),
            Some(Reject::TrolleyWorkspace),
        ),
        (
            [12.0, 8.0],
            [16.0, 8.0],
            Some(3.0),
            Some(Reject::TrolleyVelocity),
        ),
        ([15.0, 5.0], [11.0, 8.5], None, None),
        (
            [15.0, 5.0],
            [11.0, 8.5],
            Some(1.0),
            Some(Reject::TrolleyWorkspace),
        ),
        (
            [12.0, 8.0],
            [24.0, 4.0],
            None,
            Some(Reject::TrolleyWorkspace),
        ),
        ([12.0, 8.0], [14.0, 9.5], None, Some(Reject::RopeWorkspace)),
        ([12.0, 4.0], [12.0, 8.0], Some(0.6), Some(Reject::SlackRope)),
    ];
    for (from, to, duration, expected) in cases {
        let y = 3.5;
        let flat = planar().plan_move(&planar_plan(from), to, duration, 0.0);
        let spatial = extruded(any_trolley).plan_move(
            &plan_3d([from[0], y, from[1]]),
            [to[0], y, to[1]],
            duration,
            0.0,
        );
        assert_eq!(flat.err(), expected, "{from:?} → {to:?}, {duration:?}");
        match (flat, spatial) {
            (Ok(a), Ok(b)) => assert_eq!(
                (a.t_start(), a.duration()),
                (b.t_start(), b.duration()),
                "{from:?} → {to:?}"
            ),
            (Err(a), Err(b)) => assert_eq!(as_bridge(a), b, "{from:?} → {to:?}"),
            (a, b) => panic!("{from:?} → {to:?}: planar {a:?}, 3D {b:?}"),
        }
    }
}

#[test]
fn each_3d_axis_names_its_own_violation() {
    let trolley = AxisLimits {
        max_velocity: 0.5,
        max_acceleration: 0.5,
    };
    let planner = extruded(trolley);
    let start = plan_3d([12.0, 2.0, 8.0]);
    // Across the span in 4 s the trolley is too fast; a weaker one, 1 m in 4 s, cannot
    // accelerate enough.
    assert_eq!(
        planner.plan_move(&start, [12.0, 7.0, 8.0], Some(4.0), 0.0),
        Err(Reject::TrolleyVelocity)
    );
    let weak = extruded(AxisLimits {
        max_velocity: 2.0,
        max_acceleration: 0.3,
    });
    assert_eq!(
        weak.plan_move(&start, [12.0, 3.0, 8.0], Some(4.0), 0.0),
        Err(Reject::TrolleyAcceleration)
    );
    // Off the span, off the runway, below the shortest rope.
    assert_eq!(
        planner.plan_move(&start, [12.0, 9.0, 8.0], None, 0.0),
        Err(Reject::TrolleyWorkspace)
    );
    assert_eq!(
        planner.plan_move(&start, [24.0, 2.0, 8.0], None, 0.0),
        Err(Reject::BridgeWorkspace)
    );
    assert_eq!(
        planner.plan_move(&start, [12.0, 2.0, 2.0], None, 0.0),
        Err(Reject::RopeWorkspace)
    );
    // The bridge too fast.
    assert_eq!(
        planner.plan_move(&start, [16.0, 2.0, 8.0], Some(3.0), 0.0),
        Err(Reject::BridgeVelocity)
    );
    // Bridge and trolley both too fast: the bridge's reason first (12 before 7). The
    // trolley's part alone is too fast too (its flat inverse does not depend on x).
    assert_eq!(
        planner.plan_move(&plan_3d([12.0, 2.0, 5.0]), [12.0, 3.0, 5.0], Some(3.0), 0.0),
        Err(Reject::TrolleyVelocity)
    );
    assert_eq!(
        planner.plan_move(&plan_3d([12.0, 2.0, 5.0]), [16.0, 3.0, 5.0], Some(3.0), 0.0),
        Err(Reject::BridgeVelocity)
    );
    // A diagonal move, as fast as the limits allow: every axis within its limits along
    // the whole path (checked again at every sample), the trolley's the binding one.
    let m = planner
        .plan_move(&start, [20.0, 6.0, 4.0], None, 0.0)
        .unwrap();
    let (t0, t1) = (m.t_start(), m.t_start() + m.duration());
    assert!(planner.check(&m, t0, t1).is_ok());
    let quicker = planner.plan_move(&start, [20.0, 6.0, 4.0], Some(0.9 * (t1 - t0)), 0.0);
    assert!(
        matches!(
            quicker,
            Err(Reject::TrolleyVelocity | Reject::TrolleyAcceleration)
        ),
        "{quicker:?}"
    );
}

#[test]
fn a_3d_stop_comes_to_rest_on_the_path() {
    let planner = extruded(AxisLimits {
        max_velocity: 1.0,
        max_acceleration: 1.0,
    });
    let mut plan = plan_3d([12.0, 2.0, 8.0]);
    let m = planner
        .plan_move(&plan, [20.0, 6.0, 4.0], Some(10.0), 0.0)
        .unwrap();
    plan.push(m).unwrap();
    let stop = planner
        .plan_stop(&plan, 4.0)
        .expect("a stop quicker than the move");
    assert!(stop.stays_on_path());
    assert!(stop.t_end() < 10.0);
    let rest = planner.drive_positions(&plan, 10.0);
    let stopped = {
        let mut p = plan;
        p.cancel_from(4.0);
        p.apply_stop(stop);
        planner.drive_positions(&p, stop.t_end() + 1.0)
    };
    // At rest short of the target along the path: every axis between start and target.
    for (k, (now, target)) in stopped.iter().zip(rest).enumerate() {
        let start = [12.0, 2.0, 8.0][k];
        let (lo, hi) = if start < target {
            (start, target)
        } else {
            (target, start)
        };
        assert!(
            (lo - 1e-9..=hi + 1e-9).contains(now),
            "axis {k}: {now} not in [{lo}, {hi}]"
        );
    }
}
