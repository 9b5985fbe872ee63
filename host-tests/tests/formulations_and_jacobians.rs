//! *subs* against *proj* (Fig. 7) and Broyden against full Newton (Fig. 5), by the
//! numbers the paper compares: e_max of Eq. 29 and the residual evaluations paid for it.

use host_tests::run::{crane_input_errors, emax, run, Scheme, Trace};
use host_tests::scenes::{crane_trajectory, CRANE_T_END};
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_proj::{self, CraneProj};
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::{JacobianMode, SolverSettings};

const JT10: JacobianMode = JacobianMode::Broyden {
    reinit_every: Some(10),
};

fn settings(mode: JacobianMode, h: f64) -> SolverSettings {
    SolverSettings {
        h,
        ..SolverSettings::paper(mode)
    }
}

fn subs(
    scheme: Scheme,
    mode: JacobianMode,
    h: f64,
) -> Trace<{ crane_subs::N }, { crane_subs::NU }> {
    let model = CraneSubs::new(CraneParams::PAPER, crane_trajectory(4)).unwrap();
    let trace = run::<f64, _, _, _, { crane_subs::S }>(
        &model,
        scheme,
        &settings(mode, h),
        0.0,
        CRANE_T_END,
    )
    .unwrap();
    assert!(
        trace.failure.is_none(),
        "subs {scheme:?} {mode:?} h = {h}: {:?}",
        trace.failure
    );
    trace
}

fn proj(
    scheme: Scheme,
    mode: JacobianMode,
    h: f64,
) -> Trace<{ crane_proj::N }, { crane_proj::NU }> {
    let model = CraneProj::new(CraneParams::PAPER, crane_trajectory(4)).unwrap();
    let trace = run::<f64, _, _, _, { crane_proj::S }>(
        &model,
        scheme,
        &settings(mode, h),
        0.0,
        CRANE_T_END,
    )
    .unwrap();
    assert!(
        trace.failure.is_none(),
        "proj {scheme:?} {mode:?} h = {h}: {:?}",
        trace.failure
    );
    trace
}

fn global_emax<const N: usize>(trace: &Trace<N, 2>) -> f64 {
    let errors = crane_input_errors(&CraneParams::PAPER, &crane_trajectory(4), trace);
    emax(&trace.t, &errors, 2.0, 8.0).global
}

fn interior_emax<const N: usize>(trace: &Trace<N, 2>) -> f64 {
    let errors = crane_input_errors(&CraneParams::PAPER, &crane_trajectory(4), trace);
    emax(&trace.t, &errors, 2.0, 8.0).interior
}

fn evals_per_step<const N: usize>(trace: &Trace<N, 2>) -> f64 {
    trace.residual_evals() as f64 / trace.steps() as f64
}

#[test]
fn proj_converges_like_subs() {
    // BDF4 with J (as in Fig. 7): interior order 4 for both formulations.
    for (scheme, lo, hi) in [(Scheme::Bdf(4), 3.75, 4.25), (Scheme::Radau, 1.85, 2.15)] {
        let e: Vec<f64> = [0.04, 0.02, 0.01]
            .iter()
            .map(|&h| {
                if scheme == Scheme::Radau {
                    global_emax(&proj(scheme, JT10, h))
                } else {
                    interior_emax(&proj(scheme, JacobianMode::FiniteDifference, h))
                }
            })
            .collect();
        for w in e.windows(2) {
            let p = (w[0] / w[1]).log2();
            assert!(
                (lo..=hi).contains(&p),
                "proj {scheme:?}: e_max {e:?}, order {p:.2}"
            );
        }
    }
}

#[test]
fn subs_needs_fewer_residual_evaluations_than_proj() {
    // One unknown fewer (7 against 8): every finite-difference Jacobian costs one evaluation less.
    for (scheme, mode) in [
        (Scheme::Bdf(4), JacobianMode::FiniteDifference),
        (Scheme::Radau, JT10),
        (Scheme::Radau, JacobianMode::FiniteDifference),
    ] {
        let (s, p) = (subs(scheme, mode, 0.01), proj(scheme, mode, 0.01));
        let (es, ep) = (evals_per_step(&s), evals_per_step(&p));
        assert!(
            es < ep,
            "{scheme:?} {mode:?}: subs {es:.2} vs proj {ep:.2} residual evaluations per step"
        );
        // ... at the same accuracy (within 10 %).
        let (a, b) = (global_emax(&s), global_emax(&p));
        assert!(
            (a / b - 1.0).abs() < 0.1,
            "{scheme:?} {mode:?}: subs e_max {a:.3e}, proj {b:.3e}"
        );
    }
}

#[test]
fn radau_with_broyden_j10_matches_full_newton_at_ten_milliseconds_for_far_less() {
    let full = subs(Scheme::Radau, JacobianMode::FiniteDifference, 0.01);
    let broyden = subs(Scheme::Radau, JT10, 0.01);
    let (ej, eb) = (global_emax(&full), global_emax(&broyden));
    assert!(
        eb <= 2.0 * ej && eb >= 0.5 * ej,
        "e_max with J {ej:.3e}, with J̃10 {eb:.3e}"
    );
    let (nj, nb) = (full.residual_evals(), broyden.residual_evals());
    // J costs 3N + 1 = 22 evaluations per iteration; J̃10 one per iteration plus 22 every 10 steps.
    assert!(nb * 5 <= nj, "residual evaluations: J {nj}, J̃10 {nb}");
    let (fj, fb) = (
        full.stats.iter().map(|s| s.factorizations).sum::<u32>(),
        broyden.stats.iter().map(|s| s.factorizations).sum::<u32>(),
    );
    assert!(fb * 5 <= fj, "factorisations: J {fj}, J̃10 {fb}");
}

#[test]
fn every_jacobian_mode_reaches_the_same_accuracy_at_ten_milliseconds() {
    let reference = interior_emax(&subs(Scheme::Bdf(4), JacobianMode::FiniteDifference, 0.01));
    for mode in [
        JacobianMode::Exact,
        JT10,
        JacobianMode::Broyden {
            reinit_every: Some(50),
        },
        JacobianMode::Broyden { reinit_every: None },
    ] {
        let e = interior_emax(&subs(Scheme::Bdf(4), mode, 0.01));
        assert!(
            e <= 2.0 * reference && e >= 0.5 * reference,
            "BDF4 {mode:?}: interior e_max {e:.3e} against J's {reference:.3e}"
        );
    }
}

#[test]
fn exact_jacobian_needs_the_fewest_residual_evaluations() {
    for scheme in [Scheme::Bdf(4), Scheme::Radau] {
        let exact = evals_per_step(&subs(scheme, JacobianMode::Exact, 0.01));
        for mode in [JacobianMode::FiniteDifference, JT10] {
            let other = evals_per_step(&subs(scheme, mode, 0.01));
            assert!(
                exact < other,
                "{scheme:?}: exact {exact:.2} vs {mode:?} {other:.2}"
            );
        }
    }
}
