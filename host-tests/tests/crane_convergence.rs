//! Convergence of the crane inverse model against the exact flat inverse (Eq. 29).
//!
//! Every order is estimated from two step sizes a factor 2 apart:
//! `p = log2(e_max(h) / e_max(h/2))`. "Interior" is t ∈ [2 s, 8 s] of the move
//! t ∈ [1 s, 9 s]; at the move's ends the C4 polynomial's 5th derivative jumps,
//! which limits every BDF to O(h) there.

use host_tests::run::{crane_input_errors, emax, run, Emax, Scheme};
use host_tests::scenes::{crane_trajectory, CRANE_T_END};
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::{JacobianMode, SolverSettings};

const INTERIOR: (f64, f64) = (2.0, 8.0);

fn subs_emax(n: usize, scheme: Scheme, mode: JacobianMode, h: f64) -> Emax {
    let p = CraneParams::PAPER;
    let z = crane_trajectory(n);
    let model = CraneSubs::new(p, z).unwrap();
    let settings = SolverSettings {
        h,
        ..SolverSettings::paper(mode)
    };
    let trace = run::<f64, _, _, _, { crane_subs::S }>(&model, scheme, &settings, 0.0, CRANE_T_END)
        .unwrap();
    assert!(
        trace.failure.is_none(),
        "{scheme:?} h = {h}: {:?}",
        trace.failure
    );
    emax(
        &trace.t,
        &crane_input_errors(&p, &z, &trace),
        INTERIOR.0,
        INTERIOR.1,
    )
}

/// Orders between consecutive step sizes (each half the previous).
fn orders(e: &[f64]) -> Vec<f64> {
    e.windows(2).map(|w| (w[0] / w[1]).log2()).collect()
}

fn assert_orders(label: &str, e: &[f64], lo: f64, hi: f64) {
    let p = orders(e);
    assert!(
        p.iter().all(|p| (lo..=hi).contains(p)),
        "{label}: e_max {e:?} gives orders {p:.2?}, expected [{lo}, {hi}]"
    );
}

#[test]
fn implicit_euler_converges_with_order_one() {
    let e: Vec<f64> = [0.02, 0.01, 0.005]
        .iter()
        .map(|&h| subs_emax(4, Scheme::Bdf(1), JacobianMode::Exact, h).global)
        .collect();
    assert_orders("implicit Euler, global", &e, 0.9, 1.1);
    // The paper's order of magnitude at the test-bench step (Fig. 6: k = 1 far above k > 2).
    assert!(e[1] > 1e-3 && e[1] < 1e-2, "{e:?}");
}

#[test]
fn bdf_k_shows_order_k_in_the_interior_and_order_one_at_the_ends() {
    for k in 2..=4 {
        let runs: Vec<Emax> = [0.04, 0.02, 0.01]
            .iter()
            .map(|&h| subs_emax(4, Scheme::Bdf(k), JacobianMode::Exact, h))
            .collect();
        let interior: Vec<f64> = runs.iter().map(|e| e.interior).collect();
        let global: Vec<f64> = runs.iter().map(|e| e.global).collect();
        assert_orders(
            &format!("BDF{k} interior"),
            &interior,
            k as f64 - 0.25,
            k as f64 + 0.25,
        );
        assert_orders(&format!("BDF{k} global (C4 ends)"), &global, 0.8, 1.3);
    }
}

#[test]
fn smoother_trajectory_moves_the_end_limit() {
    // n = 6: the 7th derivative jumps, BDF4's global order rises to 3; n = 8: to the full 4.
    for (n, lo, hi) in [(6, 2.8, 3.4), (8, 3.8, 4.2)] {
        let e: Vec<f64> = [0.04, 0.02, 0.01]
            .iter()
            .map(|&h| subs_emax(n, Scheme::Bdf(4), JacobianMode::Exact, h).global)
            .collect();
        assert_orders(&format!("BDF4 global, n = {n}"), &e, lo, hi);
    }
}

#[test]
fn radau_inputs_converge_with_order_two() {
    // Sec. 2.3: the algebraic variable of an s-stage scheme converges with order s − 1.
    for mode in [
        JacobianMode::FiniteDifference,
        JacobianMode::Broyden {
            reinit_every: Some(10),
        },
    ] {
        let e: Vec<f64> = [0.04, 0.02, 0.01, 0.005]
            .iter()
            .map(|&h| subs_emax(4, Scheme::Radau, mode, h).global)
            .collect();
        assert_orders(&format!("Radau {mode:?}"), &e, 1.85, 2.15);
    }
}

#[test]
fn bdf4_rounding_floor_shows_below_five_milliseconds() {
    // DESIGN.md: below h ≈ 5 ms the interior error of the index-3 scheme grows again.
    let e5 = subs_emax(4, Scheme::Bdf(4), JacobianMode::Exact, 0.005).interior;
    let e1 = subs_emax(4, Scheme::Bdf(4), JacobianMode::Exact, 0.001).interior;
    assert!(
        e1 > e5,
        "interior e_max at 1 ms ({e1:.2e}) should exceed the one at 5 ms ({e5:.2e})"
    );
}
