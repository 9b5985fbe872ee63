//! The paper's check of an inverse model (Sec. 2.3): apply the computed input to
//! the forward dynamics and compare the simulated output with the desired one.
//!
//! Tolerances (h = 10 ms, the whole run): the crane's load stays within 1 µm of its
//! trajectory with BDF4 and within 10 µm with Radau J̃₁₀, and ends at rest (swing rate
//! below 1e-8 rad/s with BDF4, 1e-6 rad/s with Radau); the mass-on-car's output stays within 10 µm with BDF4. The
//! implicit Euler misses by more than a millimetre — the check can fail.

use host_tests::run::{run, Scheme, Trace};
use host_tests::scenes::{
    crane_trajectory, mass_on_car_trajectory, CRANE_START, CRANE_T_END, MASS_ON_CAR_T_END,
};
use nalgebra::SVector;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::models::mass_on_car::{self, MassOnCar, MassOnCarParams};
use solver_core::reference::plant::{
    crane_output, crane_rhs, mass_on_car_output, mass_on_car_rhs, simulate, SampledInput,
};
use solver_core::trajectory::Trajectory;
use solver_core::{JacobianMode, SolverSettings};

const H: f64 = 0.01;

/// (max |z − z_d| in m, final |φ̇| in rad/s) when the crane is driven by `trace.u`.
fn crane_tracking(trace: &Trace<{ crane_subs::N }, { crane_subs::NU }>) -> (f64, f64) {
    let (p, z) = (CraneParams::PAPER, crane_trajectory(4));
    assert!(trace.failure.is_none(), "{:?}", trace.failure);
    let input = SampledInput::new(0.0, H, &trace.u);
    let rest = SVector::<f64, 6>::from([CRANE_START[0], CRANE_START[1], 0.0, 0.0, 0.0, 0.0]);
    let (mut worst, mut swing) = (0.0_f64, f64::NAN);
    simulate(
        |y, u| crane_rhs(&p, y, u),
        rest,
        &input,
        |_, t, y| {
            let [zd] = z.derivatives::<1>(t);
            worst = worst.max((crane_output(y) - zd).abs().max());
            swing = y[5].abs();
        },
    )
    .unwrap();
    (worst, swing)
}

fn crane_run(scheme: Scheme, mode: JacobianMode) -> Trace<{ crane_subs::N }, { crane_subs::NU }> {
    let model = CraneSubs::new(CraneParams::PAPER, crane_trajectory(4)).unwrap();
    let settings = SolverSettings {
        h: H,
        ..SolverSettings::paper(mode)
    };
    run::<f64, _, _, _, { crane_subs::S }>(&model, scheme, &settings, 0.0, CRANE_T_END).unwrap()
}

#[test]
fn crane_load_follows_its_trajectory_with_the_computed_inputs() {
    for (scheme, mode, position, swing_rate) in [
        (Scheme::Bdf(4), JacobianMode::Exact, 1e-6, 1e-8),
        (Scheme::Bdf(4), JacobianMode::FiniteDifference, 1e-6, 1e-8),
        (
            Scheme::Radau,
            JacobianMode::Broyden {
                reinit_every: Some(10),
            },
            1e-5,
            1e-6,
        ),
    ] {
        let (worst, swing) = crane_tracking(&crane_run(scheme, mode));
        assert!(
            worst < position,
            "{scheme:?} {mode:?}: load off its trajectory by {worst:.3e} m"
        );
        assert!(
            swing < swing_rate,
            "{scheme:?} {mode:?}: load still swinging at {swing:.3e} rad/s"
        );
    }
}

#[test]
fn implicit_euler_inputs_do_not_keep_the_load_on_track() {
    let (worst, _) = crane_tracking(&crane_run(Scheme::Bdf(1), JacobianMode::Exact));
    assert!(
        worst > 1e-3,
        "the implicit Euler tracked within {worst:.3e} m"
    );
}

#[test]
fn mass_on_car_output_follows_with_the_computed_force() {
    let (p, z) = (MassOnCarParams::PAPER, mass_on_car_trajectory(4));
    let model = MassOnCar::new(p, z).unwrap();
    let settings = SolverSettings {
        h: H,
        ..SolverSettings::paper(JacobianMode::FiniteDifference)
    };
    let trace = run::<f64, _, _, _, { mass_on_car::S }>(
        &model,
        Scheme::Bdf(4),
        &settings,
        0.0,
        MASS_ON_CAR_T_END,
    )
    .unwrap();
    assert!(trace.failure.is_none());
    let input = SampledInput::new(0.0, H, &trace.u);
    let mut worst = 0.0_f64;
    simulate(
        |y, u| mass_on_car_rhs(&p, y, u),
        SVector::zeros(),
        &input,
        |_, t, y| {
            let [zd] = z.derivatives::<1>(t);
            worst = worst.max((mass_on_car_output(&p, y) - zd[0]).abs());
        },
    )
    .unwrap();
    assert!(worst < 1e-5, "output off by {worst:.3e} m");
}
