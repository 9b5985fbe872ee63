//! Each model's analytic partials (the "exact" Jacobian mode) against central
//! differences of its residual, at random states and times inside the move.

use host_tests::scenes::{crane_trajectory, mass_on_car_trajectory};
use nalgebra::SVector;
use proptest::prelude::*;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::{Crane3dExt, Crane3dParams};
use solver_core::models::crane_ext::CraneExt;
use solver_core::models::crane_proj::CraneProj;
use solver_core::models::crane_subs::CraneSubs;
use solver_core::models::mass_on_car::{MassOnCar, MassOnCarParams};
use solver_core::models::mass_on_car_ext::MassOnCarExt;
use solver_core::trajectory::PointToPoint;
use solver_core::DaeModel;

/// Max relative difference between the analytic partials and central differences.
fn mismatch<M: DaeModel<f64, N, NU>, const N: usize, const NU: usize>(
    m: &M,
    x: SVector<f64, N>,
    xdot: SVector<f64, N>,
    t: f64,
) -> f64 {
    let s = m.sample(t);
    let p = m.partials(&x, &xdot, &s);
    let mut worst = 0.0_f64;
    for j in 0..N {
        let eps = 1e-6 * (1.0 + x[j].abs());
        let mut e = SVector::<f64, N>::zeros();
        e[j] = eps;
        let dfdx =
            (m.residual(&(x + e), &xdot, &s) - m.residual(&(x - e), &xdot, &s)) / (2.0 * eps);
        let dfdxdot =
            (m.residual(&x, &(xdot + e), &s) - m.residual(&x, &(xdot - e), &s)) / (2.0 * eps);
        for i in 0..N {
            worst = worst.max((dfdx[i] - p.dx[(i, j)]).abs() / (1.0 + p.dx[(i, j)].abs()));
            worst = worst.max((dfdxdot[i] - p.dxdot[(i, j)]).abs() / (1.0 + p.dxdot[(i, j)].abs()));
        }
    }
    worst
}

/// The 3D crane's diagonal move with hoisting (`scenes/crane3d-diagonal.toml`).
fn diagonal_3d() -> PointToPoint<f64, 3> {
    PointToPoint::new(
        SVector::from([12.0, 3.0, 8.0]),
        SVector::from([20.0, 6.0, 4.0]),
        1.0,
        7.0,
        4,
    )
    .unwrap()
}

fn vector<const N: usize>(values: Vec<f64>) -> SVector<f64, N> {
    SVector::from_iterator(values)
}

proptest! {
    #[test]
    fn crane_subs_partials_are_exact(x in prop::collection::vec(-2.0..2.0f64, 7), xd in prop::collection::vec(-2.0..2.0f64, 7), t in 1.0..9.0f64) {
        let m = CraneSubs::new(CraneParams::PAPER, crane_trajectory(4)).unwrap();
        let mut x = vector::<7>(x);
        x[0] += 15.0; // a trolley and rope inside the workspace
        x[1] += 6.0;
        prop_assert!(mismatch(&m, x, vector(xd), t) < 1e-7);
    }

    #[test]
    fn crane_ext_partials_are_exact(x in prop::collection::vec(-2.0..2.0f64, 13), xd in prop::collection::vec(-2.0..2.0f64, 13), t in 1.0..9.0f64) {
        let m = CraneExt::new(CraneParams::PAPER, crane_trajectory(4)).unwrap();
        let mut x = vector::<13>(x);
        x[0] += 15.0;
        x[1] += 6.0;
        prop_assert!(mismatch(&m, x, vector(xd), t) < 1e-7);
    }

    #[test]
    fn crane3d_ext_partials_are_exact(x in prop::collection::vec(-2.0..2.0f64, 18), xd in prop::collection::vec(-2.0..2.0f64, 18), t in 1.0..8.0f64) {
        let m = Crane3dExt::new(Crane3dParams::EXAMPLE, diagonal_3d()).unwrap();
        let mut x = vector::<18>(x);
        x[0] += 15.0;
        x[1] += 4.0;
        x[2] += 6.0;
        prop_assert!(mismatch(&m, x, vector(xd), t) < 1e-7);
    }

    #[test]
    fn mass_on_car_ext_partials_are_exact(x in prop::collection::vec(-2.0..2.0f64, 7), xd in prop::collection::vec(-2.0..2.0f64, 7), t in 0.0..20.0f64, alpha in 1.0..89.0f64, d in 0.0..1.0f64) {
        let p = MassOnCarParams { alpha: alpha.to_radians(), d, ..MassOnCarParams::PAPER };
        let m = MassOnCarExt::new(p, mass_on_car_trajectory(4)).unwrap();
        prop_assert!(mismatch(&m, vector(x), vector(xd), t) < 1e-7);
    }

    #[test]
    fn crane_proj_partials_are_exact(x in prop::collection::vec(-1.0..1.0f64, 8), xd in prop::collection::vec(-2.0..2.0f64, 8), t in 1.0..9.0f64) {
        let m = CraneProj::new(CraneParams::PAPER, crane_trajectory(4)).unwrap();
        let mut x = vector::<8>(x);
        x[0] += 15.0;
        x[1] += 6.0;
        prop_assert!(mismatch(&m, x, vector(xd), t) < 1e-7);
    }

    #[test]
    fn mass_on_car_partials_are_exact(x in prop::collection::vec(-2.0..2.0f64, 5), xd in prop::collection::vec(-2.0..2.0f64, 5), t in 0.0..20.0f64, alpha in 1.0..89.0f64, d in 0.0..1.0f64) {
        let p = MassOnCarParams { alpha: alpha.to_radians(), d, ..MassOnCarParams::PAPER };
        let m = MassOnCar::new(p, mass_on_car_trajectory(4)).unwrap();
        prop_assert!(mismatch(&m, vector(x), vector(xd), t) < 1e-7);
    }
}

#[test]
fn rest_states_are_consistent() {
    // F(x_rest, 0, t) = 0 exactly at rest, before and after the move.
    let zero7 = SVector::<f64, 7>::zeros();
    let subs = CraneSubs::new(CraneParams::PAPER, crane_trajectory(4)).unwrap();
    let proj = CraneProj::new(CraneParams::PAPER, crane_trajectory(4)).unwrap();
    let car = MassOnCar::new(MassOnCarParams::PAPER, mass_on_car_trajectory(4)).unwrap();
    for t in [0.0, 9.5] {
        assert!(
            subs.residual(&subs.rest_state(t).unwrap(), &zero7, &subs.sample(t))
                .amax()
                < 1e-14
        );
        assert!(
            proj.residual(
                &proj.rest_state(t).unwrap(),
                &SVector::zeros(),
                &proj.sample(t)
            )
            .amax()
                < 1e-14
        );
    }
    for t in [0.0, 7.0] {
        assert!(
            car.residual(
                &car.rest_state(t).unwrap(),
                &SVector::zeros(),
                &car.sample(t)
            )
            .amax()
                < 1e-14
        );
    }
}

#[test]
fn flat_inverse_rates_are_the_derivatives_of_its_inputs() {
    use solver_core::reference::flat_crane::flat_inverse;
    let (p, z) = (CraneParams::PAPER, crane_trajectory(4));
    let eps = 1e-5;
    // Inside the move: at its ends z's 5th derivative, hence u̇, jumps.
    for i in 0..80 {
        let t = 1.05 + 0.1 * f64::from(i);
        let (a, b, m) = (
            flat_inverse(&p, &z, t - eps),
            flat_inverse(&p, &z, t + eps),
            flat_inverse(&p, &z, t),
        );
        for k in 0..2 {
            let fd = (b.u[k] - a.u[k]) / (2.0 * eps);
            assert!(
                (fd - m.u_dot[k]).abs() < 1e-6 * (1.0 + fd.abs()),
                "t = {t}, input {k}: {fd} vs {}",
                m.u_dot[k]
            );
        }
    }
}

/// The minimal extension checked against the original system's solution: along the
/// paper's move (and at rest around it, every millisecond) the flat inverse with the
/// extension's dummies (`flat_crane::extended_state`: `x' = ẋ`, `μ = λ̇`, `a_x = ẍ`, …)
/// makes every row of *ext* vanish to a few roundings of its terms, and its first seven
/// unknowns are the state on which *subs*' residual vanishes.
#[test]
fn flat_reference_satisfies_the_extended_residual() {
    use solver_core::reference::flat_crane::{extended_state, flat_inverse};
    let (p, z) = (CraneParams::PAPER, crane_trajectory(4));
    let ext = CraneExt::new(p, z).unwrap();
    let mut worst = 0.0_f64;
    for i in 0..=10_000 {
        let t = f64::from(i) * 1e-3;
        let x = extended_state(&p, &z, t);
        let s = ext.sample(t);
        let r = ext.residual(&x, &SVector::zeros(), &s);
        let j = ext.partials(&x, &x, &s).dx;
        for row in 0..13 {
            // |∂F/∂x_j x_j| counts every term with an unknown; the path's own terms
            // (z's derivatives, g) are below 25 on this move.
            let terms: f64 = (0..13).map(|c| (j[(row, c)] * x[c]).abs()).sum::<f64>() + 25.0;
            worst = worst.max(r[row].abs() / terms);
        }
        let flat = flat_inverse(&p, &z, t);
        assert_eq!(x.fixed_rows::<7>(0).into_owned(), flat.subs(), "t = {t}");
    }
    assert!(worst <= 8.0 * f64::EPSILON, "worst relative row {worst:e}");
}

/// The same for the 3D *ext* model along the diagonal move with hoisting: the 3D flat
/// inverse with the extension's dummies (`flat_crane3d::extended_state`) makes every row
/// vanish to a few roundings of its terms; its first ten unknowns are *subs*' state.
#[test]
fn flat_reference_satisfies_the_extended_3d_residual() {
    use solver_core::reference::flat_crane3d::{extended_state, flat_inverse};
    let (p, z) = (Crane3dParams::EXAMPLE, diagonal_3d());
    let ext = Crane3dExt::new(p, z).unwrap();
    let mut worst = 0.0_f64;
    for i in 0..=9_000 {
        let t = f64::from(i) * 1e-3;
        let x = extended_state(&p, &z, t);
        let s = ext.sample(t);
        let r = ext.residual(&x, &SVector::zeros(), &s);
        let j = ext.partials(&x, &x, &s).dx;
        for row in 0..18 {
            let terms: f64 = (0..18).map(|c| (j[(row, c)] * x[c]).abs()).sum::<f64>() + 25.0;
            worst = worst.max(r[row].abs() / terms);
        }
        assert_eq!(
            x.fixed_rows::<10>(0).into_owned(),
            flat_inverse(&p, &z, t).subs(),
            "t = {t}"
        );
    }
    assert!(worst <= 8.0 * f64::EPSILON, "worst relative row {worst:e}");
}

/// The mass-on-car's *ext* residual along the reference (Eqs. 37–38 integrated at tight
/// tolerance): with `x = z_d − s cos α`, `v_x = ż_d − ṡ cos α`, `x' = v_x`,
/// `a_x = z̈_d − s̈ cos α` and `s̈` from Eq. 38, every row vanishes to rounding (Eq. 37's
/// `F` and Eq. 38's `s̈` are the rows solved for them), every 10 ms of the 20 s scene.
#[test]
fn internal_dynamics_reference_satisfies_the_extended_residual() {
    use solver_core::reference::dopri5::Dopri5Settings;
    use solver_core::reference::mass_on_car::MassOnCarReference;
    use solver_core::trajectory::Trajectory;
    let p = MassOnCarParams::PAPER;
    let z = mass_on_car_trajectory(4);
    let m = MassOnCarExt::new(p, z).unwrap();
    let mut reference = MassOnCarReference::new(p, z, 0.0, Dopri5Settings::default()).unwrap();
    let (sin, cos) = p.alpha.sin_cos();
    let mut worst = 0.0_f64;
    for i in 0..=2000 {
        let t = f64::from(i) * 0.01;
        let r = reference.advance_to(t).unwrap();
        let [[z0], [z1], [z2]] = z.derivatives::<3>(t).map(<[f64; 1]>::from);
        let sdd = -(p.d * r.sdot + p.k * r.s + z2 * p.m2 * cos) / (p.m2 * sin * sin);
        let vx = z1 - r.sdot * cos;
        let x = SVector::<f64, 7>::from([z0 - r.s * cos, r.s, vx, r.sdot, r.f, vx, z2 - sdd * cos]);
        let xdot = SVector::<f64, 7>::from([vx, r.sdot, z2 - sdd * cos, sdd, 0.0, 0.0, 0.0]);
        worst = worst.max(m.residual(&x, &xdot, &m.sample(t)).amax());
    }
    assert!(worst <= 1e-14, "worst row {worst:e}");
}
