//! The controller's feedforward over its number of axes: the 3D crane's inverse model
//! steps through the same `Feedforward`/`Replan` interface as the planar crane's, with
//! three set points out, a plan the controller can change, and the reference state of
//! each vertical plane for the state feedback.

use controller::crane::command_plan;
use controller::feedforward::{Feedforward, InverseModel, Replan};
use controller::planner::Planner;
use controller::setpoint::{AxisLimits, DriveLimits};
use nalgebra::SVector;
use scene::cranes::planar::Planar;
use scene::cranes::spatial::Spatial;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::subs as crane3d;
use solver_core::models::crane3d::{Crane3dParams, Crane3dSubs};
use solver_core::plan::Plan;
use solver_core::reference::flat_crane3d;
use solver_core::{JacobianMode, SolverSettings};

type Model = Crane3dSubs<f64, Plan<f64, 3>>;
type Model3d =
    InverseModel<Spatial, Model, crane3d::StructuredBdf<f64, Plan<f64, 3>>, f64, { crane3d::N }>;

const START: [f64; 3] = [12.0, 3.0, 8.0];
const TARGET: [f64; 3] = [20.0, 6.0, 4.0];

fn planner() -> Planner<Spatial, 3> {
    let lab = DriveLimits::LAB;
    let trolley = AxisLimits {
        max_velocity: 2.0,
        max_acceleration: 2.0,
    };
    Planner::with_axes(Spatial::EXAMPLE, [lab.trolley, trolley, lab.winch])
}

/// The 3D crane at rest at `START`, a diagonal move planned (as fast as the limits
/// allow, from t = 1 s) and BDF4 with the exact Jacobian at 10 ms.
fn inverse_model() -> (Model3d, f64) {
    let mut plan = Plan::at_rest(SVector::from(START), 5).unwrap();
    let m = planner().plan_move(&plan, TARGET, None, 1.0).unwrap();
    let end = m.t_start() + m.duration();
    plan.push(m).unwrap();
    let model = Crane3dSubs::new(Crane3dParams::EXAMPLE, plan).unwrap();
    let settings = SolverSettings {
        h: 0.01,
        ..SolverSettings::paper(JacobianMode::Exact)
    };
    let integrator = crane3d::StructuredBdf::new(&model, &settings, 4, 0.0).unwrap();
    (InverseModel::new(model, integrator), end)
}

#[test]
fn the_3d_crane_steps_through_the_controllers_feedforward() {
    let (mut ff, end) = inverse_model();
    let params = Crane3dParams::EXAMPLE;
    let (mut worst_u, mut worst_slope) = (0.0_f64, 0.0_f64);
    let (mut worst_rate, mut worst_slope_rate) = (0.0_f64, 0.0_f64);
    while ff.time() < end + 2.0 {
        let step = Feedforward::<3>::step(&mut ff).unwrap();
        let exact = flat_crane3d::flat_inverse(&params, ff.plan(), step.t);
        for (u, e) in step.u.iter().zip(exact.u) {
            worst_u = worst_u.max((u - e).abs());
        }
        // Each plane's reference: the drive's position and rate, the rope and its slope
        // there, and their rates.
        let [xz, yz] = Feedforward::<3>::reference(&ff);
        let planes = [
            (xz, exact.x, exact.vx, exact.slope[0], exact.slope_rate[0]),
            (yz, exact.y, exact.vy, exact.slope[1], exact.slope_rate[1]),
        ];
        for (plane, position, rate, slope, slope_rate) in planes {
            assert!((plane.x - position).abs() < 1e-3, "{plane:?} vs {position}");
            assert!(
                (plane.l - exact.l).abs() < 1e-3,
                "{plane:?} vs l {}",
                exact.l
            );
            worst_slope = worst_slope.max((plane.phi - slope).abs());
            worst_rate = worst_rate
                .max((plane.vx - rate).abs())
                .max((plane.vl - exact.vl).abs());
            worst_slope_rate = worst_slope_rate.max((plane.vphi - slope_rate).abs());
        }
    }
    // BDF4 at 10 ms on a move of this size (measured: set points 6e-5 m/s off the exact
    // inverse): the set points within 0.1 mm/s, the drives' rates within 1 mm/s, the
    // slopes within 0.01° and their rates within 0.1°/s.
    assert!(worst_u < 1e-4, "worst |u − u_flat| = {worst_u}");
    assert!(worst_rate < 1e-3, "worst drive rate error {worst_rate}");
    assert!(
        worst_slope < 1e-2_f64.to_radians(),
        "worst slope error {worst_slope}"
    );
    assert!(
        worst_slope_rate < 1e-1_f64.to_radians(),
        "worst slope rate error {worst_slope_rate}"
    );
    assert!(!ff.plan().is_moving(ff.time()));
}

#[test]
fn the_3d_plan_can_be_changed_and_restarted_at_rest() {
    let (mut ff, _) = inverse_model();
    for _ in 0..200 {
        Feedforward::<3>::step(&mut ff).unwrap();
    }
    // A stop 1 s into the move, as the controller plans it. (Later in this move, which
    // runs at the limits, no stop beats the move itself without speeding a drive up.)
    let now = ff.time();
    let stop = planner()
        .plan_stop(ff.plan(), now)
        .expect("a stop short of the target");
    assert!(stop.fraction() < 0.9, "{}", stop.fraction());
    let plan = ff.plan_mut();
    plan.cancel_from(now);
    plan.apply_stop(stop);
    while ff.time() < stop.t_end() + 1.0 {
        Feedforward::<3>::step(&mut ff).unwrap();
    }
    let at_rest = Feedforward::<3>::step(&mut ff).unwrap();
    assert!(at_rest.u.iter().all(|u| u.abs() < 1e-9), "{:?}", at_rest.u);
    // After a halt: restarted at rest where the load hangs.
    let here = [15.0, 4.0, 6.5];
    ff.restart_at_rest(here, ff.time()).unwrap();
    let step = Feedforward::<3>::step(&mut ff).unwrap();
    assert_eq!(step.u, [0.0; 3]);
    let [xz, yz] = Feedforward::<3>::reference(&ff);
    assert!((xz.x - 15.0).abs() < 1e-12 && (yz.x - 4.0).abs() < 1e-12);
    assert!((xz.l - 6.5).abs() < 1e-12 && xz.phi.abs() < 1e-12 && yz.phi.abs() < 1e-12);
}

#[test]
fn the_planar_crane_keeps_its_two_axes() {
    // The planar feedforward is the default: two set points, the planar reference.
    let plan = command_plan::<Planar, 2>([12.0, 8.0], 4).unwrap();
    let model = solver_core::models::crane_subs::CraneSubs::new(CraneParams::PAPER, plan).unwrap();
    let settings = SolverSettings {
        h: 0.01,
        ..SolverSettings::paper(JacobianMode::Exact)
    };
    let integrator = solver_core::models::crane_subs::StructuredBdf::<f64, Plan<f64, 2>>::new(
        &model, &settings, 4, 0.0,
    )
    .unwrap();
    let mut ff = InverseModel::new(model, integrator);
    let step: controller::FeedforwardStep = ff.step().unwrap();
    assert_eq!(step.u, [0.0, 0.0]);
    let r = ff.reference();
    assert_eq!((r.x, r.l, r.phi), (12.0, 8.0, 0.0));
}
