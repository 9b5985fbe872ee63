//! Every bad input gets its typed error with context — never a panic, never a NaN.

use host_tests::run::{run, Scheme};
use host_tests::scenes::{crane_trajectory, mass_on_car_trajectory, CRANE_T_END};
use nalgebra::{SMatrix, SVector};
use solver_core::models::crane::{CraneParams, Workspace};
use solver_core::models::crane_proj::CraneProj;
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::models::mass_on_car::{MassOnCar, MassOnCarParams};
use solver_core::reference::dopri5::Dopri5Settings;
use solver_core::reference::mass_on_car::MassOnCarReference;
use solver_core::trajectory::PointToPoint;
use solver_core::{
    Bdf, DaeModel, Error, JacobianMode, NewtonSettings, Partials, Radau, SolverSettings,
};

type Subs = CraneSubs<f64, PointToPoint<f64, 2>>;

fn crane() -> Subs {
    CraneSubs::new(CraneParams::PAPER, crane_trajectory(4)).unwrap()
}

fn settings() -> SolverSettings {
    SolverSettings::paper(JacobianMode::Exact)
}

fn bdf_error(model: &Subs, s: SolverSettings, k: usize, t0: f64) -> Error {
    crane_subs::Bdf::<f64, _>::new(model, &s, k, t0).unwrap_err()
}

fn radau_error(model: &Subs, s: SolverSettings) -> Error {
    crane_subs::Radau::<f64, _>::new(model, &s, 0.0).unwrap_err()
}

fn move_to(start: [f64; 2], end: [f64; 2], duration: f64) -> PointToPoint<f64, 2> {
    PointToPoint::new(SVector::from(start), SVector::from(end), 1.0, duration, 4).unwrap()
}

#[test]
fn step_size_must_be_finite_and_positive() {
    let m = crane();
    for h in [0.0, -0.01, f64::NAN, f64::INFINITY] {
        let s = SolverSettings { h, ..settings() };
        assert!(
            matches!(bdf_error(&m, s, 4, 0.0), Error::InvalidStepSize { .. }),
            "BDF h = {h}"
        );
        assert!(
            matches!(radau_error(&m, s), Error::InvalidStepSize { .. }),
            "Radau h = {h}"
        );
    }
}

#[test]
fn unsupported_solver_settings_are_refused() {
    let m = crane();
    for k in [0, 7] {
        assert_eq!(
            bdf_error(&m, settings(), k, 0.0),
            Error::InvalidSetting {
                name: "bdf_k",
                value: k as f64
            }
        );
    }
    let s = SolverSettings {
        scaling_power: 4,
        ..settings()
    };
    assert_eq!(
        bdf_error(&m, s, 4, 0.0),
        Error::InvalidSetting {
            name: "scaling_power",
            value: 4.0
        }
    );
    let s = SolverSettings {
        newton: NewtonSettings {
            max_iterations: 0,
            ..NewtonSettings::default()
        },
        ..settings()
    };
    assert!(matches!(
        radau_error(&m, s),
        Error::InvalidSetting {
            name: "max_iterations",
            ..
        }
    ));
    let s = SolverSettings {
        newton: NewtonSettings {
            rtol: f64::NAN,
            ..NewtonSettings::default()
        },
        ..settings()
    };
    assert!(matches!(
        bdf_error(&m, s, 2, 0.0),
        Error::InvalidSetting { name: "rtol", .. }
    ));
    let s = SolverSettings::paper(JacobianMode::Broyden {
        reinit_every: Some(0),
    });
    assert!(matches!(
        bdf_error(&m, s, 4, 0.0),
        Error::InvalidSetting {
            name: "reinit_every",
            ..
        }
    ));
}

/// Newton's settings are checked by the strategies that iterate; the closed-form
/// strategies the firmware links read none of them (and link no check), so they accept
/// any. The step's own settings are checked by every scheme.
#[test]
fn newton_settings_are_checked_where_newton_iterates() {
    use solver_core::schemes::bdf::StructuredOf;
    let m = crane();
    let bad = SolverSettings {
        newton: NewtonSettings {
            max_iterations: 0,
            rtol: f64::NAN,
            ..NewtonSettings::default()
        },
        ..settings()
    };
    let iterated = crane_subs::Bdf::<
        f64,
        PointToPoint<f64, 2>,
        StructuredOf<f64, Subs, { crane_subs::N }, { crane_subs::NU }>,
    >::new(&m, &bad, 4, 0.0);
    assert!(matches!(
        iterated.unwrap_err(),
        Error::InvalidSetting {
            name: "max_iterations",
            ..
        }
    ));
    assert!(crane_subs::StructuredBdf::<f64, _>::new(&m, &bad, 4, 0.0).is_ok());
    assert!(crane_subs::StructuredBdfUncorrected::<f64, _>::new(&m, &bad, 4, 0.0).is_ok());
    let radau5 = SolverSettings {
        jacobian: JacobianMode::Transformed,
        ..bad
    };
    assert!(crane_subs::StructuredRadau5::<f64, _>::new(&m, &radau5, 0.0).is_ok());
    assert!(crane_subs::Radau5::<f64, _>::new(&m, &radau5, 0.0).is_err());
    let h = SolverSettings { h: 0.0, ..bad };
    assert!(matches!(
        crane_subs::StructuredBdfUncorrected::<f64, _>::new(&m, &h, 4, 0.0).unwrap_err(),
        Error::InvalidStepSize { .. }
    ));
}

#[test]
fn non_physical_crane_parameters_are_refused() {
    let z = crane_trajectory(4);
    let p = CraneParams::PAPER;
    let cases = [
        (CraneParams { tau1: 0.0, ..p }, "tau1"),
        (CraneParams { tau2: -0.02, ..p }, "tau2"),
        (CraneParams { m: 0.0, ..p }, "m"),
        (CraneParams { g: f64::NAN, ..p }, "g"),
        (
            CraneParams {
                min_tension_fraction: 1.5,
                ..p
            },
            "min_tension_fraction",
        ),
        (
            CraneParams {
                workspace: Workspace {
                    l_min: 0.0,
                    ..Workspace::PAPER
                },
                ..p
            },
            "l_min",
        ),
        (
            CraneParams {
                workspace: Workspace {
                    x_max: 5.0,
                    ..Workspace::PAPER
                },
                ..p
            },
            "x_min",
        ),
    ];
    for (params, name) in cases {
        match CraneSubs::new(params, z) {
            Err(
                Error::ParameterOutOfRange { name: n, .. }
                | Error::NonFiniteParameter { name: n, .. },
            ) => {
                assert_eq!(n, name)
            }
            other => panic!("{name}: {other:?}"),
        }
        assert!(
            CraneProj::new(params, z).is_err(),
            "proj accepted bad {name}"
        );
    }
}

#[test]
fn non_physical_mass_on_car_parameters_are_refused() {
    let z = mass_on_car_trajectory(4);
    let p = MassOnCarParams::PAPER;
    let cases = [
        (MassOnCarParams { m1: 0.0, ..p }, "m1"),
        (MassOnCarParams { m2: -1.0, ..p }, "m2"),
        (MassOnCarParams { k: 0.0, ..p }, "k"),
        (MassOnCarParams { d: -1.0, ..p }, "d"),
        (MassOnCarParams { alpha: 0.0, ..p }, "alpha"),
        (
            MassOnCarParams {
                alpha: std::f64::consts::FRAC_PI_2,
                ..p
            },
            "alpha",
        ),
        (MassOnCarParams { alpha: 1.6, ..p }, "alpha"),
        (
            MassOnCarParams {
                alpha: f64::NAN,
                ..p
            },
            "alpha",
        ),
    ];
    for (params, name) in cases {
        match MassOnCar::new(params, z) {
            Err(
                Error::ParameterOutOfRange { name: n, .. }
                | Error::NonFiniteParameter { name: n, .. },
            ) => {
                assert_eq!(n, name)
            }
            other => panic!("{name}: {other:?}"),
        }
        assert!(MassOnCarReference::new(params, z, 0.0, Dopri5Settings::default()).is_err());
    }
}

#[test]
fn a_move_that_slackens_the_rope_is_refused_with_its_time() {
    // Lowering the load 6 m in 1.2 s asks for more than g downwards early in the move.
    let z = move_to([15.0, 3.0], [15.0, 9.0], 1.2);
    match CraneSubs::new(CraneParams::PAPER, z) {
        Err(Error::RopeSlack {
            t,
            vertical_acceleration,
            limit,
        }) => {
            assert!(t > 1.0 && t < 2.2, "t = {t}");
            assert!(vertical_acceleration > limit && (limit - 0.95 * 9.81).abs() < 1e-12);
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        CraneProj::new(CraneParams::PAPER, z),
        Err(Error::RopeSlack { .. })
    ));
}

#[test]
fn a_move_outside_the_workspace_is_refused_naming_the_coordinate() {
    let p = CraneParams::PAPER;
    // Raising the load above the trolley: with the paper's l_min the rope is too short
    // first, so let the rope go (almost) to zero to reach z_C ≤ 0.
    let short_rope = CraneParams {
        workspace: Workspace {
            l_min: 1e-3,
            ..Workspace::PAPER
        },
        ..p
    };
    let cases = [
        (p, move_to([12.0, 10.0], [20.0, 4.0], 8.0), "l", 1.0),
        (p, move_to([12.0, 8.0], [24.0, 4.0], 8.0), "x", 9.0),
        (p, move_to([12.0, 8.0], [20.0, -1.0], 8.0), "l", 9.0),
        (
            short_rope,
            move_to([12.0, 8.0], [12.0, -1.0], 8.0),
            "z_C",
            9.0,
        ),
    ];
    for (p, z, coordinate, when) in cases {
        match CraneSubs::new(p, z) {
            Err(Error::OutsideWorkspace {
                coordinate: c, t, ..
            }) => {
                assert_eq!(c, coordinate);
                assert!(t <= when, "{coordinate} first outside at {t}");
            }
            other => panic!("{coordinate}: {other:?}"),
        }
    }
}

#[test]
fn a_trajectory_too_rough_for_the_model_is_refused() {
    assert_eq!(
        CraneSubs::new(CraneParams::PAPER, crane_trajectory(3)).unwrap_err(),
        Error::TrajectoryTooRough {
            smoothness: 3,
            required: 4
        }
    );
    assert_eq!(
        MassOnCar::new(MassOnCarParams::PAPER, mass_on_car_trajectory(1)).unwrap_err(),
        Error::TrajectoryTooRough {
            smoothness: 1,
            required: 2
        }
    );
}

#[test]
fn starting_in_the_middle_of_a_move_is_refused() {
    let m = crane();
    assert_eq!(
        bdf_error(&m, settings(), 4, 5.0),
        Error::NotAtRest { t: 5.0 }
    );
    assert!(matches!(
        crane_subs::Radau::<f64, _>::new(&m, &settings(), 5.0),
        Err(Error::NotAtRest { .. })
    ));
}

#[test]
fn newton_over_its_iteration_cap_reports_time_iterations_and_residual() {
    let m = crane();
    let s = SolverSettings {
        newton: NewtonSettings {
            max_iterations: 1,
            ..NewtonSettings::default()
        },
        ..settings()
    };
    let trace =
        run::<f64, _, _, _, { crane_subs::S }>(&m, Scheme::Bdf(4), &s, 0.0, CRANE_T_END).unwrap();
    match trace.failure {
        Some(Error::NewtonNotConverged {
            t,
            iterations,
            residual,
            increment,
        }) => {
            // At rest the predictor is exact; the first moving step needs more than one iteration.
            assert!(t > 1.0 && t < 1.1, "t = {t}");
            assert_eq!(iterations, 1);
            assert!(residual.is_finite() && increment > 1.0);
        }
        other => panic!("{other:?}"),
    }
    // What was computed before the failure is finite and kept.
    assert!(trace.u.iter().all(|u| u.iter().all(|v| v.is_finite())));
}

/// A model whose residual does not depend on x: every Newton matrix is zero.
struct Degenerate;

impl DaeModel<f64, 1, 1> for Degenerate {
    const UNKNOWNS: [&'static str; 1] = ["u"];
    const ALGEBRAIC: [bool; 1] = [true];
    const INPUTS: [usize; 1] = [0];
    const MIN_SMOOTHNESS: usize = 0;
    type Sample = f64;
    fn sample(&self, t: f64) -> f64 {
        t
    }
    fn residual(&self, _: &SVector<f64, 1>, _: &SVector<f64, 1>, t: &f64) -> SVector<f64, 1> {
        SVector::from([1.0 + t])
    }
    fn partials(&self, _: &SVector<f64, 1>, _: &SVector<f64, 1>, _: &f64) -> Partials<f64, 1> {
        Partials {
            dx: SMatrix::zeros(),
            dxdot: SMatrix::zeros(),
        }
    }
    fn rest_state(&self, _: f64) -> solver_core::Result<SVector<f64, 1>> {
        Ok(SVector::zeros())
    }
    fn output(&self, x: &SVector<f64, 1>, _: &f64) -> SVector<f64, 1> {
        *x
    }
}

#[test]
fn a_singular_newton_matrix_is_a_typed_error_in_every_mode() {
    for mode in [
        JacobianMode::Exact,
        JacobianMode::FiniteDifference,
        JacobianMode::Broyden {
            reinit_every: Some(10),
        },
    ] {
        let s = SolverSettings::paper(mode);
        let mut bdf = Bdf::<f64, Degenerate, 1, 1>::new(&Degenerate, &s, 2, 0.0).unwrap();
        assert!(
            matches!(bdf.step(&Degenerate), Err(Error::SingularJacobian { t, .. }) if (t - 0.01).abs() < 1e-12),
            "{mode:?}"
        );
        let mut radau = Radau::<f64, Degenerate, 1, 1, 3>::new(&Degenerate, &s, 0.0).unwrap();
        assert!(
            matches!(radau.step(&Degenerate), Err(Error::SingularJacobian { .. })),
            "{mode:?}"
        );
        // The failed step left the integrator where it was.
        assert_eq!(bdf.time(), 0.0);
        assert_eq!(radau.time(), 0.0);
    }
}

/// `F = x − ln(1 − t)`: fine before t = 1, NaN after.
struct Blowup;

impl DaeModel<f64, 1, 1> for Blowup {
    const UNKNOWNS: [&'static str; 1] = ["u"];
    const ALGEBRAIC: [bool; 1] = [true];
    const INPUTS: [usize; 1] = [0];
    const MIN_SMOOTHNESS: usize = 0;
    type Sample = f64;
    fn sample(&self, t: f64) -> f64 {
        (1.0 - t).ln()
    }
    fn residual(&self, x: &SVector<f64, 1>, _: &SVector<f64, 1>, s: &f64) -> SVector<f64, 1> {
        SVector::from([x[0] - s])
    }
    fn partials(&self, _: &SVector<f64, 1>, _: &SVector<f64, 1>, _: &f64) -> Partials<f64, 1> {
        Partials {
            dx: SMatrix::identity(),
            dxdot: SMatrix::zeros(),
        }
    }
    fn rest_state(&self, _: f64) -> solver_core::Result<SVector<f64, 1>> {
        Ok(SVector::zeros())
    }
    fn output(&self, x: &SVector<f64, 1>, _: &f64) -> SVector<f64, 1> {
        *x
    }
}

#[test]
fn a_non_finite_residual_is_a_typed_error_never_a_nan_output() {
    let s = SolverSettings {
        h: 0.25,
        ..SolverSettings::paper(JacobianMode::Exact)
    };
    let mut bdf = Bdf::<f64, Blowup, 1, 1>::new(&Blowup, &s, 1, 0.0).unwrap();
    let mut last = None;
    let err = loop {
        match bdf.step(&Blowup) {
            Ok(r) => last = Some(r.u[0]),
            Err(e) => break e,
        }
    };
    assert!(
        matches!(err, Error::NonFinite { t, .. } if t == 1.0),
        "{err:?}"
    );
    assert!(last.unwrap().is_finite());
}

#[test]
fn a_reference_integration_out_of_budget_is_a_typed_error() {
    let settings = Dopri5Settings {
        max_steps: 3,
        ..Dopri5Settings::default()
    };
    let mut r = MassOnCarReference::new(
        MassOnCarParams::PAPER,
        mass_on_car_trajectory(4),
        0.0,
        settings,
    )
    .unwrap();
    assert!(matches!(
        r.advance_to(20.0),
        Err(Error::ReferenceFailed { .. })
    ));
}
