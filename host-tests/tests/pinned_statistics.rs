//! Solver statistics of one reference scene per scheme and Jacobian mode, pinned as
//! a snapshot: any change of behaviour (an extra iteration, a different error)
//! fails here and shows as a diff. Refresh deliberately with
//! `INSTA_UPDATE=always cargo test -p host-tests --test pinned_statistics` and review the diff.

use std::fmt::Write;

use host_tests::run::{crane_input_errors, emax, run, Scheme, Trace, JACOBIAN_MODES};
use host_tests::scenes::{
    crane_trajectory, mass_on_car_trajectory, CRANE_T_END, MASS_ON_CAR_T_END,
};
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::models::mass_on_car::{self, MassOnCar, MassOnCarParams};
use solver_core::reference::dopri5::Dopri5Settings;
use solver_core::reference::mass_on_car::MassOnCarReference;
use solver_core::{JacobianMode, SolverSettings};

const MODES: [(&str, JacobianMode); 5] = JACOBIAN_MODES;

fn row<const N: usize, const NU: usize>(
    out: &mut String,
    label: &str,
    trace: &Trace<N, NU>,
    e_global: f64,
    e_interior: f64,
) {
    let sum = |f: fn(&solver_core::NewtonStats) -> u32| {
        trace.stats.iter().map(|s| u64::from(f(s))).sum::<u64>()
    };
    writeln!(
        out,
        "{label:<22} steps {:5} | iter {:5} max {:2} | res {:6} | jac {:5} | lu {:5} | floor {:4} | skip {:3} | e_max {:.3e} interior {:.3e} | {}",
        trace.steps(),
        sum(|s| s.iterations),
        trace.stats.iter().map(|s| s.iterations).max().unwrap_or(0),
        sum(|s| s.residual_evals),
        sum(|s| s.jacobian_evals),
        sum(|s| s.factorizations),
        trace.stats.iter().filter(|s| s.at_rounding_floor).count(),
        sum(|s| s.broyden_skipped),
        e_global,
        e_interior,
        trace.failure.map_or("ok".to_string(), |e| e.to_string()),
    )
    .unwrap();
}

#[test]
fn crane_subs_at_ten_milliseconds() {
    let (p, z) = (CraneParams::PAPER, crane_trajectory(4));
    let model = CraneSubs::new(p, z).unwrap();
    let mut out = String::new();
    let mut schemes: Vec<(String, Scheme, JacobianMode)> = (1..=6)
        .map(|k| {
            (
                format!("BDF{k} J"),
                Scheme::Bdf(k),
                JacobianMode::FiniteDifference,
            )
        })
        .collect();
    schemes.extend(
        MODES
            .iter()
            .skip(1)
            .map(|(n, m)| (format!("BDF4 {n}"), Scheme::Bdf(4), *m)),
    );
    schemes.extend(
        MODES
            .iter()
            .map(|(n, m)| (format!("Radau {n}"), Scheme::Radau, *m)),
    );
    for (label, scheme, mode) in schemes {
        let trace = run::<f64, _, _, _, { crane_subs::S }>(
            &model,
            scheme,
            &SolverSettings::paper(mode),
            0.0,
            CRANE_T_END,
        )
        .unwrap();
        let e = emax(&trace.t, &crane_input_errors(&p, &z, &trace), 2.0, 8.0);
        row(&mut out, &label, &trace, e.global, e.interior);
    }
    insta::assert_snapshot!(out);
}

#[test]
fn mass_on_car_at_ten_milliseconds() {
    let (p, z) = (MassOnCarParams::PAPER, mass_on_car_trajectory(4));
    let model = MassOnCar::new(p, z).unwrap();
    let mut out = String::new();
    for (label, scheme, mode) in [
        ("IE J", Scheme::Bdf(1), JacobianMode::FiniteDifference),
        ("BDF4 J", Scheme::Bdf(4), JacobianMode::FiniteDifference),
        (
            "Radau Jt10",
            Scheme::Radau,
            JacobianMode::Broyden {
                reinit_every: Some(10),
            },
        ),
    ] {
        let trace = run::<f64, _, _, _, { mass_on_car::S }>(
            &model,
            scheme,
            &SolverSettings::paper(mode),
            0.0,
            MASS_ON_CAR_T_END,
        )
        .unwrap();
        let mut reference = MassOnCarReference::new(p, z, 0.0, Dopri5Settings::default()).unwrap();
        let du: Vec<f64> = trace
            .t
            .iter()
            .zip(&trace.u)
            .map(|(&t, u)| (u[0] - reference.advance_to(t).unwrap().f).abs())
            .collect();
        let e = emax(&trace.t, &du, 7.0, 20.0);
        row(&mut out, label, &trace, e.global, e.interior);
    }
    insta::assert_snapshot!(out);
}

/// RADAU5's transformed simplified Newton (not one of the paper's modes, so not in
/// `JACOBIAN_MODES`): steps, iterations, Jacobians and factorisations pinned on the
/// paper's crane at the test bench's 10 ms and at 1 ms, and on the mass-on-car.
#[test]
fn radau_transformed_newton() {
    let (p, z) = (CraneParams::PAPER, crane_trajectory(4));
    let model = CraneSubs::new(p, z).unwrap();
    let mut out = String::new();
    for h in [0.01, 0.001] {
        let settings = SolverSettings {
            h,
            ..SolverSettings::paper(JacobianMode::Transformed)
        };
        let trace = run::<f64, _, _, _, { crane_subs::S }>(
            &model,
            Scheme::Radau,
            &settings,
            0.0,
            CRANE_T_END,
        )
        .unwrap();
        let e = emax(&trace.t, &crane_input_errors(&p, &z, &trace), 2.0, 8.0);
        row(
            &mut out,
            &format!("crane h={h}"),
            &trace,
            e.global,
            e.interior,
        );
    }
    let (p, z) = (MassOnCarParams::PAPER, mass_on_car_trajectory(4));
    let model = MassOnCar::new(p, z).unwrap();
    let trace = run::<f64, _, _, _, { mass_on_car::S }>(
        &model,
        Scheme::Radau,
        &SolverSettings::paper(JacobianMode::Transformed),
        0.0,
        MASS_ON_CAR_T_END,
    )
    .unwrap();
    let mut reference = MassOnCarReference::new(p, z, 0.0, Dopri5Settings::default()).unwrap();
    let du: Vec<f64> = trace
        .t
        .iter()
        .zip(&trace.u)
        .map(|(&t, u)| (u[0] - reference.advance_to(t).unwrap().f).abs())
        .collect();
    let e = emax(&trace.t, &du, 7.0, 20.0);
    row(&mut out, "mass-on-car h=0.01", &trace, e.global, e.interior);
    insta::assert_snapshot!(out);
}
