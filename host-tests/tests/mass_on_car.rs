//! The mass-on-car's internal dynamics (Sec. 3.2): damping of the implicit Euler
//! against BDF4 and Radau IIA (Figs. 12–13), zero dynamics and Eq. 39.

use host_tests::run::{run, Scheme};
use host_tests::scenes::{mass_on_car_trajectory, MASS_ON_CAR_T_END};
use solver_core::models::mass_on_car::{self, MassOnCar, MassOnCarParams};
use solver_core::reference::dopri5::Dopri5Settings;
use solver_core::reference::mass_on_car::{
    breakaway_angle, zero_dynamics_eigenvalues, MassOnCarReference,
};
use solver_core::{JacobianMode, SolverSettings};

/// `(t, |Δu|)` of a run against the Eq. 37/38 reference.
fn delta_u(scheme: Scheme, mode: JacobianMode, h: f64) -> Vec<(f64, f64)> {
    let p = MassOnCarParams::PAPER;
    let z = mass_on_car_trajectory(4);
    let model = MassOnCar::new(p, z).unwrap();
    let settings = SolverSettings {
        h,
        ..SolverSettings::paper(mode)
    };
    let trace =
        run::<f64, _, _, _, { mass_on_car::S }>(&model, scheme, &settings, 0.0, MASS_ON_CAR_T_END)
            .unwrap();
    assert!(
        trace.failure.is_none(),
        "{scheme:?} h = {h}: {:?}",
        trace.failure
    );
    assert!((trace.t.last().unwrap() - MASS_ON_CAR_T_END).abs() < 1e-9);
    let mut reference = MassOnCarReference::new(p, z, 0.0, Dopri5Settings::default()).unwrap();
    trace
        .t
        .iter()
        .zip(&trace.u)
        .map(|(&t, u)| (t, (u[0] - reference.advance_to(t).unwrap().f).abs()))
        .collect()
}

/// Largest |Δu| within [a, b).
fn envelope(du: &[(f64, f64)], a: f64, b: f64) -> f64 {
    du.iter()
        .filter(|(t, _)| (a..b).contains(t))
        .map(|(_, d)| *d)
        .fold(0.0, f64::max)
}

/// Least-squares line through the 1-s envelopes from 7 s to 20 s: (slope, R²).
fn linear_fit(du: &[(f64, f64)]) -> (f64, f64) {
    let pts: Vec<(f64, f64)> = (7..20)
        .map(|k| (k as f64 + 0.5, envelope(du, k as f64, k as f64 + 1.0)))
        .collect();
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let syy: f64 = pts.iter().map(|p| (p.1 - my).powi(2)).sum();
    (sxy / sxx, sxy * sxy / (sxx * syy))
}

#[test]
fn implicit_euler_error_grows_linearly_with_time() {
    // h = 1 ms: IE's numerical damping (≈ ω²h/2 = 0.037/s) is slow, and Δu grows linearly (Fig. 13b).
    let du = delta_u(Scheme::Bdf(1), JacobianMode::FiniteDifference, 0.001);
    let (slope, r2) = linear_fit(&du);
    assert!(slope > 0.0 && r2 > 0.97, "slope {slope:.3e}/s, R² {r2:.3}");
    let (early, late) = (envelope(&du, 7.0, 8.0), envelope(&du, 19.0, 20.1));
    assert!(
        late > 3.0 * early,
        "Δu from {early:.3e} (7–8 s) to {late:.3e} (19–20 s)"
    );
}

#[test]
fn implicit_euler_at_ten_ms_damps_the_internal_oscillation_away() {
    // h = 10 ms: the damping (≈ 0.37/s) wins within seconds; from its O(h) error at the
    // end of the move, Δu grows until it equals the whole reference oscillation, i.e.
    // IE's own oscillation has been damped out (Fig. 12).
    let du = delta_u(Scheme::Bdf(1), JacobianMode::FiniteDifference, 0.01);
    let (early, late) = (envelope(&du, 6.5, 7.5), envelope(&du, 18.0, 20.1));
    assert!(late > 1.5 * early, "Δu from {early:.3e} to {late:.3e}");
    let p = MassOnCarParams::PAPER;
    let mut reference =
        MassOnCarReference::new(p, mass_on_car_trajectory(4), 0.0, Dopri5Settings::default())
            .unwrap();
    let amplitude = (1800..=2000)
        .map(|i| reference.advance_to(f64::from(i) * 0.01).unwrap().f.abs())
        .fold(0.0, f64::max);
    assert!(
        (late / amplitude - 1.0).abs() < 0.05,
        "Δu {late:.3e} against the oscillation amplitude {amplitude:.3e}"
    );
}

#[test]
fn bdf4_and_radau_stay_two_orders_below_implicit_euler() {
    let ie = delta_u(Scheme::Bdf(1), JacobianMode::FiniteDifference, 0.01);
    let ie_growth = envelope(&ie, 18.0, 20.1) - envelope(&ie, 6.5, 7.5);
    for (name, du) in [
        (
            "BDF4",
            delta_u(Scheme::Bdf(4), JacobianMode::FiniteDifference, 0.01),
        ),
        (
            "Radau J̃10",
            delta_u(
                Scheme::Radau,
                JacobianMode::Broyden {
                    reinit_every: Some(10),
                },
                0.01,
            ),
        ),
    ] {
        // ≥ 100× below the implicit Euler at every second after the move...
        for k in 7..20 {
            let (a, b) = (k as f64, k as f64 + 1.0);
            let (mine, theirs) = (envelope(&du, a, b), envelope(&ie, a, b));
            assert!(
                100.0 * mine <= theirs,
                "{name} in [{a}, {b}): {mine:.3e} vs IE {theirs:.3e}"
            );
        }
        // ...and whatever they gain over the 13 s (BDF4 has an O((ωh)⁴) phase drift) is
        // under 1 % of what the implicit Euler gains.
        let growth = envelope(&du, 18.0, 20.1) - envelope(&du, 6.5, 7.5);
        assert!(
            growth < 0.01 * ie_growth,
            "{name}: grows {growth:.3e}, IE {ie_growth:.3e}"
        );
    }
}

#[test]
fn zero_dynamics_oscillate_undamped_for_d_zero() {
    let [l1, l2] = zero_dynamics_eigenvalues(&MassOnCarParams::PAPER);
    // k/(m2 sin²15°) = 74.6: λ = ±8.64 i.
    assert_eq!(l1.re, 0.0);
    assert!((l1.im - (5.0_f64 / 15f64.to_radians().sin().powi(2)).sqrt()).abs() < 1e-12);
    assert_eq!(l2, l1.conj());
}

#[test]
fn breakaway_angle_of_eq_39() {
    let damped = MassOnCarParams {
        d: 1.0,
        ..MassOnCarParams::PAPER
    };
    let alpha_hat = breakaway_angle(&damped).unwrap().to_degrees();
    // The paper: α̂ ≈ 12.9° for d = 1 Ns/m.
    assert!((alpha_hat - 12.92).abs() < 0.01, "{alpha_hat}");
    // Complex above α̂, real below (Fig. 10).
    let above = zero_dynamics_eigenvalues(&MassOnCarParams {
        alpha: (alpha_hat + 1.0).to_radians(),
        ..damped
    });
    let below = zero_dynamics_eigenvalues(&MassOnCarParams {
        alpha: (alpha_hat - 1.0).to_radians(),
        ..damped
    });
    assert!(above[0].im != 0.0 && above[0].re < 0.0);
    assert!(below.iter().all(|l| l.im == 0.0 && l.re < 0.0));
    // Overdamped for every angle: no breakaway.
    assert!(breakaway_angle(&MassOnCarParams {
        d: 10.0,
        ..MassOnCarParams::PAPER
    })
    .is_none());
}
