//! The 3D crane's closed-loop study:
//! `cargo run --release -p host-tests --bin feedback3d_study -- [--cases N]`.
//!
//! Monte Carlo (fixed seeds) over the planar study's mismatch and disturbance ranges in
//! both planes (loads already swinging up to 5° in any direction at the start, gusts from
//! any direction) on the 3D scene's diagonal move and on random 3D moves, feedforward
//! only beside feedforward + the state feedback per vertical plane; the gust at rest
//! from eight directions. Prints the markdown tables of `docs/RESULTS.md`.

use clap::Parser;
use host_tests::feedback3d_study::{
    design, fault_study, gust_at_rest, monte_carlo, table_row, CaseResult3, FAULTS3, TABLE_HEADER,
};
use solver_core::models::crane3d::Crane3dParams;

#[derive(Parser)]
struct Args {
    /// Cases per set (diagonal move, random moves).
    #[arg(long, default_value_t = 1000)]
    cases: usize,
}

/// Seeds of the two sets and of the fault set.
const DIAGONAL_SEED: u64 = 3003;
const RANDOM_SEED: u64 = 1903;
const FAULT_SEED: u64 = 33;

fn main() -> Result<(), String> {
    let args = Args::parse();
    let gains = design(&Crane3dParams::EXAMPLE)?;
    println!("{TABLE_HEADER}");
    for (name, seed, random) in [
        ("diagonal move", DIAGONAL_SEED, false),
        ("random moves", RANDOM_SEED, true),
    ] {
        let mc = monte_carlo(seed, args.cases, random, &gains);
        let pick = |i: usize| -> Vec<CaseResult3> {
            mc.cases
                .iter()
                .map(|c| match i {
                    0 => c.1,
                    1 => c.2,
                    _ => c.3,
                })
                .collect()
        };
        println!(
            "{}",
            table_row(&format!("{name}, feedforward only"), &pick(0))
        );
        println!(
            "{}",
            table_row(&format!("{name}, feedforward + feedback"), &pick(1))
        );
        println!(
            "{}",
            table_row(
                &format!("{name}, feedforward + feedback, rope calibrated"),
                &pick(2)
            )
        );
    }
    println!();
    let directions = [0.0_f64, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0];
    println!(
        "| gust at rest (10 N, 1 s), from | {} |",
        directions
            .iter()
            .map(|d| format!("{d:.0}°"))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!("|---|{}", "---:|".repeat(directions.len()));
    for l in [3.0, 6.0, 9.0] {
        let ratios: Vec<(f64, f64)> = directions
            .iter()
            .map(|d| gust_at_rest(l, d.to_radians(), &gains))
            .collect();
        let row = |f: &dyn Fn(&(f64, f64)) -> f64| {
            ratios
                .iter()
                .map(|r| format!("{:.1} %", 100.0 * f(r)))
                .collect::<Vec<_>>()
                .join(" | ")
        };
        println!(
            "| l = {l} m: swing 2 periods after its peak / peak, feedforward only | {} |",
            row(&|r| r.1)
        );
        println!(
            "| l = {l} m: swing 2 periods after its peak / peak, with feedback | {} |",
            row(&|r| r.0)
        );
    }
    println!();
    let faults = fault_study(FAULT_SEED, args.cases, &gains);
    println!("| inclinometer (diagonal move, rope calibrated) | worse than feedforward alone on the same case | of them, the gust over when it failed | worst horizontal distance 5 s after, mm (median / max) | swing 5 s after (worse plane), ° (median / max) | within ±50 mm and < 0.1° |");
    println!("|---|---|---|---|---|---|");
    let worse = |fb: &CaseResult3, ff: &CaseResult3| {
        let d = |r: &CaseResult3| r.distance[0].max(r.distance[1]);
        let s = |r: &CaseResult3| r.swing_deg[0].max(r.swing_deg[1]);
        d(fb) > d(ff) || s(fb) > s(ff)
    };
    for (i, name) in FAULTS3.iter().enumerate() {
        let runs: Vec<_> = faults
            .iter()
            .filter_map(|(r, blowing)| r.get(i).map(|p| (p, *blowing)))
            .collect();
        let n_worse = runs.iter().filter(|((fb, ff), _)| worse(fb, ff)).count();
        let calm = runs.iter().filter(|(_, blowing)| !blowing).count();
        let calm_worse = runs
            .iter()
            .filter(|((fb, ff), blowing)| !blowing && worse(fb, ff))
            .count();
        let mut d: Vec<f64> = runs
            .iter()
            .map(|((fb, _), _)| fb.distance[0].max(fb.distance[1]) * 1e3)
            .collect();
        let mut sw: Vec<f64> = runs
            .iter()
            .map(|((fb, _), _)| fb.swing_deg[0].max(fb.swing_deg[1]))
            .collect();
        let ok = runs.iter().filter(|((fb, _), _)| fb.meets_target()).count();
        println!(
            "| {name} | {n_worse}/{} | {calm_worse}/{calm} | {:.1} / {:.1} | {:.3} / {:.3} | {ok}/{} |",
            runs.len(),
            host_tests::feedback_study::quantile(&mut d, 0.5),
            host_tests::feedback_study::quantile(&mut d, 1.0),
            host_tests::feedback_study::quantile(&mut sw, 0.5),
            host_tests::feedback_study::quantile(&mut sw, 1.0),
            runs.len()
        );
    }
    Ok(())
}
