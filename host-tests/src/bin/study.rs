//! `study`: measure the speed/accuracy trade and map where each scheme breaks.
//!
//! ```text
//! study run SCENE [--csv FILE]                 one run: e_max, Newton statistics, time series
//! study sweep SCENE --vary h=…|…,rho=…  [--out FILE]   the cross product, one CSV row each
//! study paper [--out-dir DIR] [--quick]        the paper's Figs. 4–7 and 11–13 on our scenes
//! study extremes [--out-dir DIR] [--quick]     the stability map
//! ```
//!
//! Also `cargo xtask study …`. Results and their reading: docs/RESULTS.md.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use host_tests::study::{default_threshold, run_scene, RunResult};
use host_tests::sweep::{cross, csv_row, parse_vary, CSV_HEADER};
use host_tests::{extremes, paper};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use scene::Scene;

#[derive(Parser)]
#[command(about = "Measure the speed/accuracy trade of the servo-constraints solvers")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// One run of a scene: e_max (global and interior), Newton statistics, time series.
    Run {
        /// The scene file.
        scene: PathBuf,
        /// Where to write the time series (t, u, u_ref, error) as CSV.
        #[arg(long)]
        csv: Option<PathBuf>,
        /// e_max above which the run counts as inaccurate (default: 1e-3 crane, 1e-2 mass-on-car).
        #[arg(long)]
        threshold: Option<f64>,
    },
    /// The cross product of `--vary` axes, one CSV row per configuration.
    Sweep {
        /// The scene file.
        scene: PathBuf,
        /// Axes: `key=v1|v2,…` with keys h, rho, k, scheme, jacobian, formulation, scalar.
        #[arg(long, required = true)]
        vary: Vec<String>,
        /// CSV output (default: standard output).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Timed repeats per configuration (the median is reported).
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// e_max above which a run counts as inaccurate.
        #[arg(long)]
        threshold: Option<f64>,
    },
    /// The paper's studies (Figs. 4–7, 11–13) as SVG, CSV and a Markdown summary.
    Paper {
        /// Output directory.
        #[arg(long, default_value = "docs/figures")]
        out_dir: PathBuf,
        /// Fewer step sizes and one timing repeat (for tests).
        #[arg(long)]
        quick: bool,
    },
    /// The stability map over schemes, Jacobians, step sizes, scalings, scalars and hard scenes.
    Extremes {
        /// Output directory.
        #[arg(long, default_value = "docs/figures")]
        out_dir: PathBuf,
        /// A small map (for tests).
        #[arg(long)]
        quick: bool,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run {
            scene,
            csv,
            threshold,
        } => run(&scene, csv.as_deref(), threshold),
        Command::Sweep {
            scene,
            vary,
            out,
            repeats,
            threshold,
        } => sweep(&scene, &vary, out.as_deref(), repeats, threshold),
        Command::Paper { out_dir, quick } => paper::regenerate(&out_dir, quick, &progress),
        Command::Extremes { out_dir, quick } => extremes::map(&out_dir, quick, &progress),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("study: {e}");
            ExitCode::FAILURE
        }
    }
}

/// A progress bar that appears only once the work has taken more than a second.
fn progress(len: usize) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len as u64), ProgressDrawTarget::hidden());
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let shown = bar.clone();
    let start = Instant::now();
    std::thread::spawn(move || {
        std::thread::sleep(Duration::from_secs(1));
        if !shown.is_finished() && start.elapsed() >= Duration::from_secs(1) {
            shown.set_draw_target(ProgressDrawTarget::stderr());
        }
    });
    bar
}

fn load(path: &Path) -> Result<Scene, String> {
    Scene::load(path).map_err(|e| format!("{}: {e}", path.display()))
}

fn run(path: &Path, csv: Option<&Path>, threshold: Option<f64>) -> Result<(), String> {
    let scene = load(path)?;
    let threshold = threshold.unwrap_or_else(|| default_threshold(&scene));
    let r = run_scene(&scene, 5, threshold);
    print_summary(&scene, &r, threshold);
    if let Some(csv) = csv {
        write_series(csv, &r)?;
        println!("time series: {}", csv.display());
    }
    match r.outcome {
        host_tests::study::Outcome::Ok | host_tests::study::Outcome::Inaccurate => Ok(()),
        other => Err(format!(
            "the run ended as {}: {}",
            other.as_str(),
            r.failure.unwrap_or_default()
        )),
    }
}

fn print_summary(scene: &Scene, r: &RunResult, threshold: f64) {
    println!("scene {} ({})", scene.name, scene.description);
    println!(
        "outcome          {} (threshold {threshold:e})",
        r.outcome.as_str()
    );
    if let Some(f) = &r.failure {
        println!("failure          {f}");
    }
    let (a, b) = scene.interior();
    println!(
        "e_max            {:.4e} (global), {:.4e} (interior, t in [{a}, {b}] s)",
        r.e_global, r.e_interior
    );
    println!("steps            {}", r.steps);
    println!("Newton           {:.3} iterations per step (max {}), {:.2} residual evaluations per step, {} Jacobians, {} steps at the rounding floor", r.iterations_mean, r.iterations_max, r.residual_evals_per_step, r.jacobian_evals, r.floor_steps);
    println!(
        "host time        {:.1} ns per step (median of 5)",
        r.ns_per_step
    );
}

fn write_series(path: &Path, r: &RunResult) -> Result<(), String> {
    let nu = r.u.first().map_or(0, Vec::len);
    let mut text = String::from("t");
    for i in 1..=nu {
        text += &format!(",u{i},u{i}_ref");
    }
    text += ",error\n";
    for ((t, u), (u_ref, e)) in r.t.iter().zip(&r.u).zip(r.u_ref.iter().zip(&r.error)) {
        text += &format!("{t}");
        for (a, b) in u.iter().zip(u_ref) {
            text += &format!(",{a:.12e},{b:.12e}");
        }
        text += &format!(",{e:.6e}\n");
    }
    write(path, &text)
}

fn write(path: &Path, text: &str) -> Result<(), String> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

fn sweep(
    path: &Path,
    vary: &[String],
    out: Option<&Path>,
    repeats: usize,
    threshold: Option<f64>,
) -> Result<(), String> {
    let scene = load(path)?;
    let threshold = threshold.unwrap_or_else(|| default_threshold(&scene));
    let axes = vary
        .iter()
        .map(|v| parse_vary(v))
        .collect::<Result<Vec<_>, _>>()?
        .concat();
    let configs = cross(&scene, &axes)?;
    let bar = progress(configs.len());
    let mut text = format!("{CSV_HEADER}\n");
    for (_, s) in &configs {
        let r = run_scene(s, repeats, threshold);
        text += &csv_row(s, &r);
        text.push('\n');
        bar.inc(1);
    }
    bar.finish_and_clear();
    match out {
        Some(p) => write(p, &text),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}
