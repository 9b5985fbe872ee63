//! The double pendulum's minimally extended formulation
//! (`solver_core::models::double_pendulum_ext`): its appended rows are the time
//! derivatives of the rows they extend, its partials are exact, the exact flat state
//! satisfies every row, and every scheme and Jacobian mode runs the move at the flat
//! inverse to rounding — where *subs* (index 5) has a rounding floor and Radau IIA does
//! not converge.
//!
//! The move is the paper's (load from (12, 8) m to (20, 4) m in 8 s from t = 1 s) with
//! smoothness n = 8, the parameters `DoublePendulumParams::EXAMPLE`, as in
//! `double_pendulum.rs`.

use host_tests::run::{run, run_with, Scheme, Trace};
use nalgebra::SVector;
use proptest::prelude::*;
use solver_core::models::double_pendulum::DoublePendulumParams;
use solver_core::models::double_pendulum_ext::{self, DoublePendulumExt, N, NU};
use solver_core::reference::double_pendulum::{e_max, extended_state};
use solver_core::reference::emax::Emax;
use solver_core::trajectory::{PointToPoint, Trajectory};
use solver_core::{DaeModel, Error, JacobianMode, SolverSettings};

type Z = PointToPoint<f64, 2>;
type Model = DoublePendulumExt<f64, Z>;

const T_END: f64 = 10.0;
const INTERIOR: (f64, f64) = (2.0, 8.0);

fn paper_move(n: usize) -> Z {
    PointToPoint::new(
        SVector::from([12.0, 8.0]),
        SVector::from([20.0, 4.0]),
        1.0,
        8.0,
        n,
    )
    .unwrap()
}

fn model() -> Model {
    DoublePendulumExt::new(DoublePendulumParams::EXAMPLE, paper_move(8)).unwrap()
}

/// The unknowns' rates as the module's documentation numbers them: `[q^(0), q^(1), …]`
/// for each chain, and the kinematic unknowns' slots (`x'`, `u`).
const CHAINS: [&[usize]; 6] = [
    &[2, 6, 18, 20, 22],  // x_H
    &[3, 7, 19, 21, 23],  // z_H
    &[9, 26, 27, 28, 29], // λ2
    &[0, 4, 16],          // x
    &[1, 5, 17],          // l
    &[8, 24, 25],         // λ1
];

/// An arbitrary (not solving) smooth motion of every chain, `q(t) = a + b sin(ω t + φ)`,
/// with its exact rates in the chain's slots.
fn motion(t: f64) -> SVector<f64, N> {
    let mut x = SVector::<f64, N>::zeros();
    let params = [
        (15.5, 0.7, 1.3, 0.2),
        (5.5, 0.4, 0.9, 1.1),
        (-5.0, 0.8, 1.7, 0.4),
        (15.0, 0.6, 1.1, 2.0),
        (5.0, 0.5, 0.7, 0.3),
        (-1.2, 0.2, 2.1, 0.9),
    ];
    for (slots, (a, b, w, phi)) in CHAINS.iter().zip(params) {
        for (j, slot) in slots.iter().enumerate() {
            let phase = w * t + phi + j as f64 * std::f64::consts::FRAC_PI_2;
            x[*slot] = if j == 0 { a } else { 0.0 } + b * w.powi(j as i32) * phase.sin();
        }
    }
    x
}

/// Each appended row is the time derivative of the row it extends, along an arbitrary
/// motion and the load's path (central differences, step 1e-4 s): F9–F11 to the 4th
/// derivative, F7, F8, F12 to the 2nd — the symbolic check of the module's equations.
#[test]
fn appended_rows_are_the_derivatives_of_the_rows_they_extend() {
    let m = model();
    // (row of order k, row of order k − 1): F9, F10, F11 then F7, F8, F12.
    let sling: [[usize; 3]; 5] = [
        [8, 9, 10],
        [12, 13, 14],
        [18, 19, 20],
        [24, 25, 26],
        [27, 28, 29],
    ];
    let rope: [[usize; 3]; 3] = [[6, 7, 11], [15, 16, 17], [21, 22, 23]];
    let pairs: Vec<(usize, usize)> = sling
        .windows(2)
        .chain(rope.windows(2))
        .flat_map(|w| w[1].into_iter().zip(w[0]))
        .collect();
    assert_eq!(pairs.len(), 18);
    let eps = 1e-4;
    let f = |t: f64| m.residual(&motion(t), &SVector::zeros(), &m.sample(t));
    let mut worst = 0.0_f64;
    for i in 0..60 {
        let t = 1.1 + 0.13 * f64::from(i);
        let (a, b, at) = (f(t - eps), f(t + eps), f(t));
        for &(row, lower) in &pairs {
            let numeric = (b[lower] - a[lower]) / (2.0 * eps);
            let relative = (numeric - at[row]).abs() / (1.0 + at[row].abs());
            worst = worst.max(relative);
            assert!(
                relative < 1e-6,
                "t = {t}: row {row} = {:e}, d/dt row {lower} = {numeric:e}",
                at[row]
            );
        }
    }
    println!("largest relative difference, row against d/dt of its lower row: {worst:.2e}");
}

/// Max relative difference between the analytic partials and central differences.
fn mismatch(m: &Model, x: SVector<f64, N>, t: f64) -> f64 {
    let s = m.sample(t);
    let xdot = SVector::zeros();
    let p = m.partials(&x, &xdot, &s);
    assert_eq!(p.dxdot, nalgebra::SMatrix::<f64, N, N>::zeros());
    let mut worst = 0.0_f64;
    for j in 0..N {
        let eps = 1e-6 * (1.0 + x[j].abs());
        let mut e = SVector::<f64, N>::zeros();
        e[j] = eps;
        let dfdx =
            (m.residual(&(x + e), &xdot, &s) - m.residual(&(x - e), &xdot, &s)) / (2.0 * eps);
        for i in 0..N {
            worst = worst.max((dfdx[i] - p.dx[(i, j)]).abs() / (1.0 + p.dx[(i, j)].abs()));
        }
    }
    worst
}

proptest! {
    /// The exact partials against central differences at random states around the
    /// motion's and random times inside the move.
    #[test]
    fn partials_are_exact(
        x in prop::collection::vec(-1.0..1.0f64, N),
        t in 1.0..9.0f64,
    ) {
        let m = model();
        let x = motion(t) + SVector::<f64, N>::from_iterator(x);
        prop_assert!(mismatch(&m, x, t) < 1e-7);
    }
}

/// The exact flat state with its rates (`extended_state`) satisfies every row at every
/// millisecond of the move and at rest around it, within 1e-12 of the size of the terms
/// a row subtracts (positions of ~20 m times forces and their rates of up to ~10 /s²).
#[test]
fn flat_state_satisfies_every_row() {
    let p = DoublePendulumParams::EXAMPLE;
    let (m, z) = (model(), paper_move(8));
    let mut worst = 0.0_f64;
    for i in 0..=10_000 {
        let t = f64::from(i) * 1e-3;
        let x = extended_state(&p, &z.derivatives::<8>(t), t).unwrap();
        let r = m.residual(&x, &SVector::zeros(), &m.sample(t));
        worst = worst.max(r.amax());
    }
    println!("largest residual row along the move: {worst:.2e}");
    assert!(worst < 1e-12 * 20.0 * 10.0, "{worst:e}");
}

fn settings(h: f64, mode: JacobianMode) -> SolverSettings {
    SolverSettings {
        h,
        ..SolverSettings::paper(mode)
    }
}

fn measured(trace: &Trace<N, NU>) -> Emax {
    assert!(trace.failure.is_none(), "{:?}", trace.failure);
    e_max(
        &DoublePendulumParams::EXAMPLE,
        &paper_move(8),
        trace.t.iter().copied().zip(trace.u.iter().copied()),
        INTERIOR,
    )
}

/// The largest e_max (m/s) any scheme and mode may reach at any step size: the flat
/// inverse to rounding (the inputs are ~1 m/s, their terms up to ~20 m times ~10 /s²).
const BOUND: f64 = 1e-10;

/// Every scheme and Jacobian mode of the planar crane runs the move at 10 ms (where on
/// *subs* Radau IIA's full Newton fails and RADAU5 misses by 9e-2 m/s) and at 0.5 ms
/// (where on *subs* every dense scheme fails) and meets the flat inverse within
/// [`BOUND`]; the structured eliminations give the dense LUs' results.
#[test]
fn every_scheme_and_jacobian_mode_meets_the_flat_inverse() {
    let m = model();
    let modes = [
        JacobianMode::FiniteDifference,
        JacobianMode::Broyden { reinit_every: None },
        JacobianMode::Broyden {
            reinit_every: Some(10),
        },
        JacobianMode::Broyden {
            reinit_every: Some(50),
        },
        JacobianMode::Exact,
    ];
    let mut rows = Vec::new();
    for h in [0.01, 0.0005] {
        for k in 1..=6 {
            for mode in modes {
                let trace = run::<f64, _, _, _, { double_pendulum_ext::S }>(
                    &m,
                    Scheme::Bdf(k),
                    &settings(h, mode),
                    0.0,
                    T_END,
                )
                .unwrap();
                rows.push((format!("{h} s BDF{k} {mode:?}"), measured(&trace)));
            }
        }
        for mode in modes.into_iter().chain([JacobianMode::Transformed]) {
            let trace = run::<f64, _, _, _, { double_pendulum_ext::S }>(
                &m,
                Scheme::Radau,
                &settings(h, mode),
                0.0,
                T_END,
            )
            .unwrap();
            rows.push((format!("{h} s Radau {mode:?}"), measured(&trace)));
        }
        let s = settings(h, JacobianMode::Exact);
        let structured_bdf = run_with(
            &m,
            double_pendulum_ext::StructuredBdf::<f64, Z>::new(&m, &s, 4, 0.0).unwrap(),
            &s,
            T_END,
        )
        .unwrap();
        rows.push((format!("{h} s BDF4 structured"), measured(&structured_bdf)));
        let s5 = settings(h, JacobianMode::Transformed);
        let structured_radau = run_with(
            &m,
            double_pendulum_ext::StructuredRadau5::<f64, Z>::new(&m, &s5, 0.0).unwrap(),
            &s5,
            T_END,
        )
        .unwrap();
        rows.push((
            format!("{h} s RADAU5 structured"),
            measured(&structured_radau),
        ));
    }
    for (label, e) in &rows {
        println!(
            "{label}: e_max {:.2e}, interior {:.2e}",
            e.global, e.interior
        );
    }
    for (label, e) in &rows {
        assert!(e.global < BOUND, "{label}: {e:?}");
    }
}

/// The model refuses what *subs* refuses: the paper's C4 move (its inputs need the
/// path's 6th derivative) and a path whose sling would go slack.
#[test]
fn rough_and_slack_moves_are_refused() {
    let p = DoublePendulumParams::EXAMPLE;
    assert!(matches!(
        DoublePendulumExt::<f64, Z>::new(p, paper_move(4)),
        Err(Error::TrajectoryTooRough {
            smoothness: 4,
            required: 6
        })
    ));
    // Down by 4 m in 0.5 s: the load falls faster than the sling's margin allows.
    let fast = PointToPoint::new(
        SVector::from([12.0, 4.0]),
        SVector::from([12.0, 8.0]),
        1.0,
        0.5,
        8,
    )
    .unwrap();
    assert!(matches!(
        DoublePendulumExt::<f64, Z>::new(p, fast),
        Err(Error::RopeSlack { .. })
    ));
}
