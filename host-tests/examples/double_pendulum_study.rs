//! The hook-and-load double pendulum's numerics, measured: e_max (Eq. 29) of every scheme
//! against the exact flat inverse over step sizes from 50 ms to 0.5 ms, the orders between
//! them, where the index-5 system's rounding floor stops each scheme converging, f32
//! against f64, and the realistic corners of the hook's mass and the sling's length.
//!
//! `cargo run -p host-tests --release --example double_pendulum_study` prints the tables
//! that docs/MODELS.md quotes ("The double pendulum, measured").
//!
//! The move is the paper's (load from (12, 8) m to (20, 4) m in 8 s from t = 1 s), as a
//! polynomial of smoothness n = 8 (the model needs n ≥ 6, the paper's n = 4 makes its
//! inputs jump); e_max over the whole run (t ∈ [0, 10] s) and over the interior
//! t ∈ [2, 8] s, where the jump of the trajectory's (n+1)-th derivative at the move's ends
//! does not limit the order. The parameters: Tab. 3's crane, a hook of 30 % of the load's
//! mass on a 1 m sling (`DoublePendulumParams::EXAMPLE`); exact Jacobian, ρ = 1/h²
//! (except in the scaling table), Newton's tolerances those of the scalar. "fails": the
//! run stopped with an error, printed below the row (Newton's increment does not fall
//! below its stall limit where the rounding, amplified by the index, exceeds it).

use host_tests::run::{run, run_with, Scheme, Trace};
use nalgebra::SVector;
use solver_core::models::double_pendulum::{
    self, DoublePendulumParams, DoublePendulumSubs, HOOK_MASS_RATIO, SLING_LENGTH,
};
use solver_core::reference::double_pendulum::e_max;
use solver_core::reference::emax::Emax;
use solver_core::trajectory::PointToPoint;
use solver_core::{JacobianMode, NewtonSettings, Real, SolverSettings};

const T_END: f64 = 10.0;
const INTERIOR: (f64, f64) = (2.0, 8.0);
const STEP_SIZES: [f64; 7] = [0.05, 0.02, 0.01, 0.005, 0.002, 0.001, 0.0005];

fn trajectory<T: Real>(n: usize) -> PointToPoint<T, 2> {
    let v = |a: f64, b: f64| {
        SVector::<T, 2>::from([solver_core::scalar::c(a), solver_core::scalar::c(b)])
    };
    PointToPoint::new(
        v(12.0, 8.0),
        v(20.0, 4.0),
        solver_core::scalar::c(1.0),
        solver_core::scalar::c(8.0),
        n,
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

/// e_max of one run in scalar `T`, or the error that stopped it.
fn measure<T: Real>(
    p: &DoublePendulumParams,
    n: usize,
    scheme: Scheme,
    mode: JacobianMode,
    h: f64,
) -> Result<Emax, String> {
    measure_scaled::<T>(p, n, scheme, mode, h, 2)
}

/// [`measure`] with the algebraic rows scaled by `ρ = h^-power`; Newton's tolerances
/// those of the scalar (`NewtonSettings::for_scalar`).
fn measure_scaled<T: Real>(
    p: &DoublePendulumParams,
    n: usize,
    scheme: Scheme,
    mode: JacobianMode,
    h: f64,
    power: u32,
) -> Result<Emax, String> {
    let model =
        DoublePendulumSubs::<T, _>::new(*p, trajectory::<T>(n)).map_err(|e| e.to_string())?;
    let settings = SolverSettings {
        h,
        jacobian: mode,
        scaling_power: power,
        newton: NewtonSettings::for_scalar::<T>(),
    };
    let trace: Trace<{ double_pendulum::N }, { double_pendulum::NU }> =
        run::<T, _, _, _, { double_pendulum::S }>(&model, scheme, &settings, 0.0, T_END)
            .map_err(|e| e.to_string())?;
    if let Some(e) = trace.failure {
        return Err(e.to_string());
    }
    let z = trajectory::<f64>(n);
    Ok(e_max(
        p,
        &z,
        trace.t.iter().copied().zip(trace.u.iter().copied()),
        INTERIOR,
    ))
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

fn convergence_table<T: Real>(p: &DoublePendulumParams, n: usize, title: &str) {
    println!("\n### {title}\n");
    let header: Vec<String> = STEP_SIZES
        .iter()
        .map(|h| format!("{} ms", h * 1e3))
        .collect();
    println!("| scheme | | {} | floor at |", header.join(" | "));
    println!("|---|---|{}---|", "---:|".repeat(STEP_SIZES.len()));
    for (label, scheme, mode) in SCHEMES {
        let runs: Vec<Result<Emax, String>> = STEP_SIZES
            .iter()
            .map(|&h| measure::<T>(p, n, scheme, mode, h))
            .collect();
        for (what, pick) in [
            ("e_max", (|e: &Emax| e.global) as fn(&Emax) -> f64),
            ("interior", |e: &Emax| e.interior),
        ] {
            let cells: Vec<String> = runs.iter().map(|e| cell(e, pick)).collect();
            // Where the error stops falling: the step size of the smallest error.
            let floor = runs
                .iter()
                .zip(STEP_SIZES)
                .filter_map(|(e, h)| e.as_ref().ok().map(|e| (pick(e), h)))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .map_or("–".into(), |(e, h)| format!("{} ms ({e:.1e})", h * 1e3));
            println!("| {label} | {what} | {} | {floor} |", cells.join(" | "));
            let orders: Vec<String> = runs
                .windows(2)
                .zip(STEP_SIZES.windows(2))
                .map(|(r, h)| order(&r[0], &r[1], h[0], h[1], pick))
                .collect();
            println!("| | order | – | {} | |", orders.join(" | "));
        }
        for (h, r) in STEP_SIZES.iter().zip(&runs) {
            if let Err(e) = r {
                println!("| | h = {} ms | {e} | |", h * 1e3);
            }
        }
    }
}

fn corners() {
    println!("\n### The realistic corners (n = 8, h = 10 ms): e_max / interior\n");
    println!("| hook m_h/m | sling l_s | BDF4 | Radau IIA | RADAU5 |");
    println!("|---:|---:|---:|---:|---:|");
    for ratio in [HOOK_MASS_RATIO.0, HOOK_MASS_RATIO.1] {
        for sling in [SLING_LENGTH.0, SLING_LENGTH.1] {
            let p = DoublePendulumParams::EXAMPLE.with(ratio, sling);
            let cells: Vec<String> = [
                (Scheme::Bdf(4), JacobianMode::Exact),
                (Scheme::Radau, JacobianMode::Exact),
                (Scheme::Radau, JacobianMode::Transformed),
            ]
            .iter()
            .map(|&(s, m)| match measure::<f64>(&p, 8, s, m, 0.01) {
                Ok(e) => format!("{:.2e} / {:.2e}", e.global, e.interior),
                Err(e) => format!("fails: {e}"),
            })
            .collect();
            println!("| {ratio} | {sling} m | {} |", cells.join(" | "));
        }
    }
}

/// The firmware's strategies: each step from the closed-form step
/// (`StructuredJacobian::solve_step`), BDF4 corrected by Newton below 5 ms, RADAU5 not.
fn closed_form() {
    println!("\n### From the closed-form step (n = 8, f64): e_max / interior\n");
    let header: Vec<String> = STEP_SIZES
        .iter()
        .map(|h| format!("{} ms", h * 1e3))
        .collect();
    println!("| strategy | {} |", header.join(" | "));
    println!("|---|{}", "---:|".repeat(STEP_SIZES.len()));
    let p = DoublePendulumParams::EXAMPLE;
    let model =
        DoublePendulumSubs::<f64, _>::new(p, trajectory::<f64>(8)).expect("the move is valid");
    let z = trajectory::<f64>(8);
    let show = |trace: Result<
        Trace<{ double_pendulum::N }, { double_pendulum::NU }>,
        solver_core::Error,
    >| {
        match trace {
            Ok(t) if t.failure.is_none() => {
                let e = e_max(
                    &p,
                    &z,
                    t.t.iter().copied().zip(t.u.iter().copied()),
                    INTERIOR,
                );
                format!("{:.2e} / {:.2e}", e.global, e.interior)
            }
            Ok(t) => format!(
                "fails ({})",
                t.failure.map_or(String::new(), |e| e.to_string())
            ),
            Err(e) => format!("refused ({e})"),
        }
    };
    let cells: Vec<String> = STEP_SIZES
        .iter()
        .map(|&h| {
            let s = SolverSettings {
                h,
                ..SolverSettings::paper(JacobianMode::Exact)
            };
            show(
                double_pendulum::StructuredBdf::<f64, _>::new(&model, &s, 4, 0.0)
                    .and_then(|i| run_with(&model, i, &s, T_END)),
            )
        })
        .collect();
    println!("| BDF4 structured | {} |", cells.join(" | "));
    let cells: Vec<String> = STEP_SIZES
        .iter()
        .map(|&h| {
            let s = SolverSettings {
                h,
                ..SolverSettings::paper(JacobianMode::Transformed)
            };
            show(
                double_pendulum::StructuredRadau5::<f64, _>::new(&model, &s, 0.0)
                    .and_then(|i| run_with(&model, i, &s, T_END)),
            )
        })
        .collect();
    println!("| RADAU5 structured | {} |", cells.join(" | "));
}

fn scaling() {
    println!("\n### The row scaling ρ = h^-p of Sec. 3.1.1 (n = 8, f64): e_max\n");
    let hs = [0.02, 0.01, 0.005, 0.002];
    let header: Vec<String> = hs.iter().map(|h| format!("{} ms", h * 1e3)).collect();
    println!("| scheme | p | {} |", header.join(" | "));
    println!("|---|---:|{}", "---:|".repeat(hs.len()));
    let p = DoublePendulumParams::EXAMPLE;
    for (label, scheme, mode) in [SCHEMES[3], SCHEMES[6], SCHEMES[7]] {
        for power in 0..=3 {
            let cells: Vec<String> = hs
                .iter()
                .map(|&h| {
                    cell(&measure_scaled::<f64>(&p, 8, scheme, mode, h, power), |e| {
                        e.global
                    })
                })
                .collect();
            println!("| {label} | {power} | {} |", cells.join(" | "));
        }
    }
}

fn main() {
    let p = DoublePendulumParams::EXAMPLE;
    println!("## The double pendulum against its flat inverse (e_max of Eq. 29, m/s)");
    convergence_table::<f64>(&p, 8, "f64, n = 8");
    convergence_table::<f64>(&p, 6, "f64, n = 6 (the least smoothness the model accepts)");
    convergence_table::<f32>(&p, 8, "f32, n = 8");
    closed_form();
    scaling();
    corners();
}
