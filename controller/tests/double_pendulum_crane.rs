//! The hook-and-load crane (a double pendulum) to the controller: its flat inverse
//! reduces to the planar crane's for a light hook on a short sling, its moves are
//! planned with its own smoothness and checks, each axis names its own violation, and
//! its inverse models give its own reference state.

use controller::commands::Reject;
use controller::crane::double_pendulum::HookReference;
use controller::crane::{command_plan, Crane};
use controller::feedforward::CraneReference;
use controller::planner::Planner;
use solver_core::models::crane::CraneParams;
use solver_core::models::double_pendulum::DoublePendulumSubs;
use solver_core::models::double_pendulum_crane::DoublePendulumParams;
use solver_core::models::double_pendulum_ext::DoublePendulumExt;
use solver_core::plan::Plan;
use solver_core::reference::double_pendulum;
use solver_core::trajectory::Trajectory;

type HookAndLoad = DoublePendulumParams;

fn planner(p: HookAndLoad) -> Planner<HookAndLoad, 2> {
    Planner::with_axes(p, <HookAndLoad as Crane<2>>::LAB_LIMITS)
}

/// The load at rest at `at`, planned as the controller plans this crane's moves.
fn at_rest(at: [f64; 2]) -> Plan<f64, 2> {
    command_plan::<HookAndLoad, 2>(at, 4).unwrap()
}

/// With a hook of a millionth of the load's mass on a 0.5 m sling, rope and sling hang
/// in one line: the trolley and its set points are the planar crane's with a rope as
/// long as both, along a whole move (the limit `host-tests/tests/double_pendulum.rs`
/// checks on the solver's side, here through the `Crane` impls the planner uses).
#[test]
fn a_light_hook_on_a_short_sling_is_the_planar_crane() {
    let sling = 0.5;
    let dp = HookAndLoad::EXAMPLE.with(1e-6, sling);
    let planar = CraneParams {
        workspace: dp.crane.workspace,
        ..dp.crane
    };
    let mut plan = at_rest([12.0, 8.0]);
    let step = planner(dp)
        .plan_move(&plan, [20.0, 5.0], None, 0.0)
        .unwrap();
    plan.push(step).unwrap();
    let (t0, t1) = step.active_span();
    let mut worst = [0.0f64; 3];
    for i in 0..=200 {
        let t = t0 + (t1 - t0) * f64::from(i) / 200.0;
        let (a, b) = (dp.flat(&plan, t), planar.flat(&plan, t));
        worst[0] = worst[0].max((a.position[0] - b.position[0]).abs());
        worst[1] = worst[1].max((a.position[1] + sling - b.position[1]).abs());
        let du = (0..2).map(|k| (a.u[k] - b.u[k]).abs()).fold(0.0, f64::max);
        worst[2] = worst[2].max(du);
    }
    eprintln!("light hook against the planar crane: trolley, rope, u {worst:?}");
    assert!(
        worst.iter().all(|w| *w < 1e-5),
        "trolley, rope, u: {worst:?}"
    );
}

/// Its moves are planned with n ≥ 7 (its inputs contain the path's sixth derivative),
/// and each axis names its own violation, as the planar crane's does.
#[test]
fn its_moves_are_planned_with_its_own_smoothness_and_checks() {
    assert_eq!(<HookAndLoad as Crane<2>>::MIN_COMMAND_SMOOTHNESS, 7);
    assert_eq!(at_rest([12.0, 8.0]).smoothness(), 7);
    let p = planner(HookAndLoad::EXAMPLE);
    let from = at_rest([12.0, 8.0]);
    // As fast as the limits allow: accepted, and within the lab drives' limits.
    let fastest = p.plan_move(&from, [20.0, 5.0], None, 0.0).unwrap();
    let (t0, t1) = fastest.active_span();
    assert!(p.check(&fastest, t0, t1).is_ok());
    // Each violation named by its axis.
    let cases = [
        ([16.0, 8.0], Some(3.0), Reject::TrolleyVelocity),
        ([12.0, 10.5], None, Reject::RopeWorkspace),
        ([24.0, 8.0], None, Reject::TrolleyWorkspace),
    ];
    for (to, duration, expected) in cases {
        assert_eq!(
            p.plan_move(&from, to, duration, 0.0).err(),
            Some(expected),
            "{to:?} in {duration:?} s"
        );
    }
}

/// *subs* and *ext* give the crane's own reference state from their unknowns: the
/// trolley, the rope, the hook block and their rates, where the exact flat inverse puts
/// them.
#[test]
fn its_inverse_models_give_its_own_reference() {
    let p = HookAndLoad::EXAMPLE;
    let mut plan = at_rest([12.0, 8.0]);
    let step = planner(p).plan_move(&plan, [20.0, 5.0], None, 0.0).unwrap();
    plan.push(step).unwrap();
    let t = step.t_start() + 0.4 * step.duration();
    let f = double_pendulum::flat_inverse(&p, &plan, t).unwrap();
    let expected = HookReference {
        x: f.x,
        l: f.l,
        hook: f.hook,
        vx: f.v[0],
        vl: f.v[1],
        v_hook: f.v_hook,
    };
    let subs = DoublePendulumSubs::<f64, _>::new(p, plan).unwrap();
    assert_eq!(subs.reference(f.subs().as_slice(), t), expected);
    let ext = DoublePendulumExt::<f64, _>::new(p, plan).unwrap();
    let y = double_pendulum::extended_state(&p, &plan.derivatives::<8>(t), t).unwrap();
    assert_eq!(ext.reference(y.as_slice(), t), expected);
    // The hook block hangs the sling's length above the load.
    let load = plan.derivatives::<1>(t)[0];
    let sling = ((load[0] - f.hook[0]).powi(2) + (load[1] - f.hook[1]).powi(2)).sqrt();
    assert!((sling - p.sling).abs() < 1e-9, "{sling}");
}
