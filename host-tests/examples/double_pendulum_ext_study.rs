//! The double pendulum's minimally extended formulation (*ext*, index 1) beside *subs*
//! (index 5), measured: e_max (Eq. 29) of every scheme against the exact flat inverse over
//! step sizes from 50 ms to 0.5 ms, the orders between them, f32 against f64, the
//! structured strategies, the realistic corners, and the condition number of BDF4's
//! Newton matrix against h.
//!
//! `cargo run -p host-tests --release --example double_pendulum_ext_study` prints the
//! tables that docs/MODELS.md, section 6 quotes ("The extended formulation, measured").
//!
//! The same move and parameters as `double_pendulum_study` (the paper's move with
//! smoothness n = 8, `DoublePendulumParams::EXAMPLE`), exact Jacobian, ρ = 1/h², Newton's
//! tolerances those of the scalar; e_max over the whole run and the interior
//! t ∈ [2, 8] s. "fails": the run stopped with an error, printed below the row.

use host_tests::run::{run, run_with, Scheme, Trace};
use host_tests::trade::bdf4_condition;
use nalgebra::SVector;
use solver_core::models::double_pendulum::{
    self, DoublePendulumParams, DoublePendulumSubs, HOOK_MASS_RATIO, SLING_LENGTH,
};
use solver_core::models::double_pendulum_ext::{self, DoublePendulumExt};
use solver_core::reference::double_pendulum::{e_max, extended_state, flat_inverse};
use solver_core::reference::emax::Emax;
use solver_core::trajectory::{PointToPoint, Trajectory};
use solver_core::{JacobianMode, NewtonSettings, Real, SolverSettings};

const T_END: f64 = 10.0;
const INTERIOR: (f64, f64) = (2.0, 8.0);
const STEP_SIZES: [f64; 7] = [0.05, 0.02, 0.01, 0.005, 0.002, 0.001, 0.0005];

fn trajectory<T: Real>() -> PointToPoint<T, 2> {
    let v = |a: f64, b: f64| {
        SVector::<T, 2>::from([solver_core::scalar::c(a), solver_core::scalar::c(b)])
    };
    PointToPoint::new(
        v(12.0, 8.0),
        v(20.0, 4.0),
        solver_core::scalar::c(1.0),
        solver_core::scalar::c(8.0),
        8,
    )
    .expect("the paper's move is valid")
}

/// The schemes measured: label, scheme, Jacobian mode.
const SCHEMES: [(&str, Scheme, JacobianMode); 8] = [
    ("BDF1", Scheme::Bdf(1), JacobianMode::Exact),
    ("BDF2", Scheme::Bdf(2), JacobianMode::Exact),
    ("BDF3", Scheme::Bdf(3), JacobianMode::Exact),
    ("BDF4", Scheme::Bdf(4), JacobianMode::Exact),
    ("BDF5", Scheme::Bdf(5), JacobianMode::Exact),
    ("BDF6", Scheme::Bdf(6), JacobianMode::Exact),
    ("Radau IIA", Scheme::Radau, JacobianMode::Exact),
    ("RADAU5", Scheme::Radau, JacobianMode::Transformed),
];

#[derive(Debug, Clone, Copy, PartialEq)]
enum Formulation {
    Subs,
    Ext,
}

fn settings<T: Real>(h: f64, mode: JacobianMode) -> SolverSettings {
    SolverSettings {
        h,
        jacobian: mode,
        scaling_power: 2,
        newton: NewtonSettings::for_scalar::<T>(),
    }
}

/// e_max of a trace's inputs against the flat inverse, or the failure that stopped it.
fn judged<const N: usize>(
    p: &DoublePendulumParams,
    trace: Result<Trace<N, 2>, solver_core::Error>,
) -> Result<Emax, String> {
    let trace = trace.map_err(|e| e.to_string())?;
    if let Some(e) = trace.failure {
        return Err(e.to_string());
    }
    Ok(e_max(
        p,
        &trajectory::<f64>(),
        trace.t.iter().copied().zip(trace.u.iter().copied()),
        INTERIOR,
    ))
}

/// e_max of one run in scalar `T`, or the error that stopped it.
fn measure<T: Real>(
    p: &DoublePendulumParams,
    formulation: Formulation,
    scheme: Scheme,
    mode: JacobianMode,
    h: f64,
) -> Result<Emax, String> {
    let s = settings::<T>(h, mode);
    match formulation {
        Formulation::Subs => {
            let m = DoublePendulumSubs::<T, _>::new(*p, trajectory::<T>())
                .map_err(|e| e.to_string())?;
            judged(
                p,
                run::<T, _, _, _, { double_pendulum::S }>(&m, scheme, &s, 0.0, T_END),
            )
        }
        Formulation::Ext => {
            let m =
                DoublePendulumExt::<T, _>::new(*p, trajectory::<T>()).map_err(|e| e.to_string())?;
            judged(
                p,
                run::<T, _, _, _, { double_pendulum_ext::S }>(&m, scheme, &s, 0.0, T_END),
            )
        }
    }
}

fn cell(e: &Result<Emax, String>, pick: fn(&Emax) -> f64) -> String {
    match e {
        Ok(e) => format!("{:.2e}", pick(e)),
        Err(_) => "fails".into(),
    }
}

fn order(
    a: &Result<Emax, String>,
    b: &Result<Emax, String>,
    ha: f64,
    hb: f64,
    pick: fn(&Emax) -> f64,
) -> String {
    match (a, b) {
        (Ok(a), Ok(b)) => format!("{:.2}", (pick(a) / pick(b)).ln() / (ha / hb).ln()),
        _ => "–".into(),
    }
}

fn header() -> String {
    STEP_SIZES
        .iter()
        .map(|h| format!("{} ms", h * 1e3))
        .collect::<Vec<_>>()
        .join(" | ")
}

fn convergence_table<T: Real>(p: &DoublePendulumParams, formulations: &[Formulation], title: &str) {
    println!("\n### {title}\n");
    println!("| scheme | formulation | | {} | smallest at |", header());
    println!("|---|---|---|{}---|", "---:|".repeat(STEP_SIZES.len()));
    for (label, scheme, mode) in SCHEMES {
        for &formulation in formulations {
            let runs: Vec<Result<Emax, String>> = STEP_SIZES
                .iter()
                .map(|&h| measure::<T>(p, formulation, scheme, mode, h))
                .collect();
            for (what, pick) in [
                ("e_max", (|e: &Emax| e.global) as fn(&Emax) -> f64),
                ("interior", |e: &Emax| e.interior),
            ] {
                let cells: Vec<String> = runs.iter().map(|e| cell(e, pick)).collect();
                let smallest = runs
                    .iter()
                    .zip(STEP_SIZES)
                    .filter_map(|(e, h)| e.as_ref().ok().map(|e| (pick(e), h)))
                    .min_by(|a, b| a.0.total_cmp(&b.0))
                    .map_or("–".into(), |(e, h)| format!("{} ms ({e:.1e})", h * 1e3));
                println!(
                    "| {label} | {formulation:?} | {what} | {} | {smallest} |",
                    cells.join(" | ")
                );
                let orders: Vec<String> = runs
                    .windows(2)
                    .zip(STEP_SIZES.windows(2))
                    .map(|(r, h)| order(&r[0], &r[1], h[0], h[1], pick))
                    .collect();
                println!("| | | order | – | {} | |", orders.join(" | "));
            }
            for (h, r) in STEP_SIZES.iter().zip(&runs) {
                if let Err(e) = r {
                    println!("| | {formulation:?} | h = {} ms | {e} | |", h * 1e3);
                }
            }
        }
    }
}

/// The structured eliminations (the firmware's strategies) on *ext*: BDF4 from the
/// predictor with the block-triangular solve, RADAU5 with both stage systems by it.
fn structured() {
    println!("\n### Structured strategies on ext (f64): e_max / interior\n");
    println!("| strategy | {} |", header());
    println!("|---|{}", "---:|".repeat(STEP_SIZES.len()));
    let p = DoublePendulumParams::EXAMPLE;
    let m = DoublePendulumExt::<f64, _>::new(p, trajectory::<f64>()).expect("the move is valid");
    let show = |e: Result<Emax, String>| match e {
        Ok(e) => format!("{:.2e} / {:.2e}", e.global, e.interior),
        Err(e) => format!("fails ({e})"),
    };
    let bdf: Vec<String> = STEP_SIZES
        .iter()
        .map(|&h| {
            let s = settings::<f64>(h, JacobianMode::Exact);
            show(judged(
                &p,
                double_pendulum_ext::StructuredBdf::<f64, _>::new(&m, &s, 4, 0.0)
                    .and_then(|i| run_with(&m, i, &s, T_END)),
            ))
        })
        .collect();
    println!("| BDF4 structured | {} |", bdf.join(" | "));
    let radau: Vec<String> = STEP_SIZES
        .iter()
        .map(|&h| {
            let s = settings::<f64>(h, JacobianMode::Transformed);
            show(judged(
                &p,
                double_pendulum_ext::StructuredRadau5::<f64, _>::new(&m, &s, 0.0)
                    .and_then(|i| run_with(&m, i, &s, T_END)),
            ))
        })
        .collect();
    println!("| RADAU5 structured | {} |", radau.join(" | "));
}

/// κ₁ of BDF4's Newton matrix `S·(∂F/∂x + α₀/h ∂F/∂ẋ)` on the exact state at t = 5 s
/// (mid-move), ρ = 1/h² on the algebraic rows (`host_tests::trade::bdf4_condition`).
fn conditions() {
    println!("\n### Condition number κ₁ of BDF4's Newton matrix at t = 5 s, ρ = 1/h²\n");
    println!("| formulation | {} | growth 50 → 0.5 ms |", header());
    println!("|---|{}---:|", "---:|".repeat(STEP_SIZES.len()));
    let p = DoublePendulumParams::EXAMPLE;
    let z = trajectory::<f64>();
    let t = 5.0;
    let subs = DoublePendulumSubs::<f64, _>::new(p, z).expect("the move is valid");
    let ext = DoublePendulumExt::<f64, _>::new(p, z).expect("the move is valid");
    let x_subs = flat_inverse(&p, &z, t).expect("inside the move").subs();
    let x_ext = extended_state(&p, &z.derivatives::<8>(t), t).expect("inside the move");
    for (label, kappa) in [
        (
            "subs",
            STEP_SIZES
                .map(|h| bdf4_condition(&subs, &x_subs, t, h, 2))
                .to_vec(),
        ),
        (
            "ext",
            STEP_SIZES
                .map(|h| bdf4_condition(&ext, &x_ext, t, h, 2))
                .to_vec(),
        ),
    ] {
        let cells: Vec<String> = kappa.iter().map(|k| format!("{k:.2e}")).collect();
        let growth = kappa.last().copied().unwrap_or(f64::NAN) / kappa[0];
        println!("| {label} | {} | {growth:.2e} |", cells.join(" | "));
    }
}

fn corners() {
    println!("\n### The realistic corners on ext (h = 10 ms): e_max / interior\n");
    println!("| hook m_h/m | sling l_s | BDF4 | Radau IIA | RADAU5 |");
    println!("|---:|---:|---:|---:|---:|");
    for ratio in [HOOK_MASS_RATIO.0, HOOK_MASS_RATIO.1] {
        for sling in [SLING_LENGTH.0, SLING_LENGTH.1] {
            let p = DoublePendulumParams::EXAMPLE.with(ratio, sling);
            let cells: Vec<String> = [SCHEMES[3], SCHEMES[6], SCHEMES[7]]
                .iter()
                .map(
                    |&(_, s, m)| match measure::<f64>(&p, Formulation::Ext, s, m, 0.01) {
                        Ok(e) => format!("{:.2e} / {:.2e}", e.global, e.interior),
                        Err(e) => format!("fails: {e}"),
                    },
                )
                .collect();
            println!("| {ratio} | {sling} m | {} |", cells.join(" | "));
        }
    }
}

fn main() {
    let p = DoublePendulumParams::EXAMPLE;
    println!("## The double pendulum, subs (index 5) beside ext (index 1): e_max of Eq. 29, m/s");
    convergence_table::<f64>(&p, &[Formulation::Subs, Formulation::Ext], "f64");
    convergence_table::<f32>(&p, &[Formulation::Ext], "f32, ext");
    structured();
    conditions();
    corners();
}
