//! `study`: measure the speed/accuracy trade and map where each scheme breaks.
//!
//! ```text
//! study run SCENE [--csv FILE]                 one run: e_max, Newton statistics, time series
//! study sweep SCENE --vary h=…|…,rho=…  [--out FILE]   the cross product, one CSV row each
//! study paper [--out-dir DIR] [--quick]        the paper's Figs. 4–7 and 11–13 on our scenes
//! study extremes [--out-dir DIR] [--quick]     the stability map
//! study crane3d [--out-dir DIR] [--quick]      the 3D crane: convergence, orders, f32/f64, stability map
//! study root-locus [--out-dir DIR]             Fig. 10: the internal dynamics' eigenvalues over α
//! study condition [--out-dir DIR]              κ₁ of BDF4's Newton matrix against h per formulation
//! ```
//!
//! Also `cargo xtask study …`. Results and their reading: docs/RESULTS.md.

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use host_tests::study::{
    default_threshold, readable_numbers, run_scene, run_scene_observed, Observer, Outcome,
    RunResult, Sample,
};
use host_tests::sweep::{cross, csv_row, parse_vary, CSV_HEADER};
use host_tests::{crane3d_study, extremes, paper, root_locus, trade};
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
        #[arg(long, value_parser = threshold)]
        threshold: Option<f64>,
    },
    /// The cross product of `--vary` axes, one CSV row per configuration.
    Sweep {
        /// The scene file.
        scene: PathBuf,
        /// Axes: `key=v1|v2,…` with keys h, rho, k, scheme, jacobian (j, jt, jtN, exact,
        /// transformed), formulation (subs, proj, ext; the mass-on-car: direct, ext), scalar.
        #[arg(long, required = true)]
        vary: Vec<String>,
        /// CSV output (default: standard output).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Timed repeats per configuration (the median is reported; 0: not timed,
        /// the ns_per_step column stays empty).
        #[arg(long, default_value_t = 5)]
        repeats: usize,
        /// e_max above which a run counts as inaccurate.
        #[arg(long, value_parser = threshold)]
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
    /// The crane in three dimensions: convergence of BDF 1–6 and Radau IIA against the 3D
    /// flat reference on four moves, observed orders, f32 against f64, the stability map.
    Crane3d {
        /// Output directory.
        #[arg(long, default_value = "docs/figures/crane3d")]
        out_dir: PathBuf,
        /// Two step sizes, BDF4 only, one move in the map (for tests).
        #[arg(long)]
        quick: bool,
    },
    /// Fig. 10: the root locus of the mass-on-car's internal dynamics over α, with α̂
    /// of Eq. 39 marked, as SVG and CSV.
    RootLocus {
        /// Output directory.
        #[arg(long, default_value = "docs/figures")]
        out_dir: PathBuf,
    },
    /// The condition number κ₁ of BDF4's Newton matrix at mid-move against h, per crane
    /// and formulation (subs, proj, ext), as CSV, SVG and a table on standard output.
    Condition {
        /// Output directory.
        #[arg(long, default_value = "docs/figures/trade")]
        out_dir: PathBuf,
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
        Command::Crane3d { out_dir, quick } => {
            crane3d_study::regenerate(&out_dir, quick, &progress)
        }
        Command::Condition { out_dir } => condition(&out_dir),
        Command::RootLocus { out_dir } => root_locus::write(&out_dir).map(|alpha_hat| {
            eprintln!(
                "wrote {}: alpha^ = {alpha_hat:.3} deg (Eq. 39, d = 1 Ns/m)",
                out_dir.join("fig10-root-locus.{csv,svg}").display()
            );
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("study: {}", readable_numbers(&e));
            ExitCode::FAILURE
        }
    }
}

/// `study condition`: κ₁ per formulation and h, written to `out` and printed.
fn condition(out: &Path) -> Result<(), String> {
    fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let rows = trade::write_conditions(out)?;
    let mut text =
        String::from("kappa1 of BDF4's Newton matrix at mid-move, rho = 1/h^2\nformulation");
    for h in trade::STEP_SIZES {
        text += &format!(" | h = {h} s");
    }
    text.push('\n');
    for (name, values) in rows {
        text += name;
        for v in values {
            text += &format!(" | {v:.3e}");
        }
        text.push('\n');
    }
    emit(&text)?;
    eprintln!("wrote {}", out.join("condition.{csv,svg}").display());
    Ok(())
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

/// A threshold is a positive number: `nan` would make every comparison false and
/// every run "ok".
fn threshold(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{text}` is not a finite number > 0")),
    }
}

/// Writes to standard output. A closed pipe (`study … | head`) ends the program
/// quietly, as it ends other Unix tools, instead of panicking in `println!`.
fn emit(text: &str) -> Result<(), String> {
    let mut out = io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => std::process::exit(0),
        Err(e) => Err(format!("standard output: {e}")),
    }
}

/// Creates a file for writing (and its directory), so that a path that cannot be
/// written is refused before the work, not after it.
fn create(path: &Path) -> Result<BufWriter<fs::File>, String> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    fs::File::create(path)
        .map(BufWriter::new)
        .map_err(|e| format!("{}: {e}", path.display()))
}

fn load(path: &Path) -> Result<Scene, String> {
    Scene::load(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// A single run: its samples go to the CSV file as they come (memory stays bounded
/// however small h is) and its progress to a bar.
struct RunOutput {
    csv: Option<(PathBuf, BufWriter<fs::File>)>,
    header: bool,
    bar: ProgressBar,
}

impl Observer for RunOutput {
    fn sample(&mut self, s: &Sample<'_>) -> Result<(), String> {
        let Some((path, file)) = &mut self.csv else {
            return Ok(());
        };
        let mut line = String::new();
        if !self.header {
            line += "t";
            for i in 1..=s.u.len() {
                line += &format!(",u{i},u{i}_ref");
            }
            line += ",error\n";
            self.header = true;
        }
        line += &format!("{}", s.t);
        for (a, b) in s.u.iter().zip(s.u_ref) {
            line += &format!(",{a:.12e},{b:.12e}");
        }
        line += &format!(",{:.6e}\n", s.error);
        file.write_all(line.as_bytes())
            .map_err(|e| format!("{}: {e}", path.display()))
    }

    fn progress(&mut self, done: usize, total: usize) {
        self.bar.set_length(total as u64);
        self.bar.set_position(done as u64);
    }
}

fn run(path: &Path, csv: Option<&Path>, threshold: Option<f64>) -> Result<(), String> {
    let scene = load(path)?;
    let threshold = threshold.unwrap_or_else(|| default_threshold(&scene));
    let file = match csv {
        Some(p) => Some((p.to_path_buf(), create(p)?)),
        None => None,
    };
    let mut output = RunOutput {
        csv: file,
        header: false,
        bar: progress(scene.steps()),
    };
    let r = run_scene_observed(&scene, 5, threshold, &mut output)?;
    output.bar.finish_and_clear();
    if let Some((p, mut file)) = output.csv.take() {
        file.flush().map_err(|e| format!("{}: {e}", p.display()))?;
    }
    emit(&summary(&scene, &r, threshold))?;
    if let Some(csv) = csv {
        emit(&format!("time series: {}\n", csv.display()))?;
    }
    match r.outcome {
        Outcome::Ok | Outcome::Inaccurate => Ok(()),
        other => Err(format!(
            "the run ended as {}: {}",
            other.as_str(),
            readable_numbers(&r.failure_text())
        )),
    }
}

fn summary(scene: &Scene, r: &RunResult, threshold: f64) -> String {
    let mut text = format!("scene {} ({})\n", scene.name, scene.description);
    text += &format!(
        "outcome          {} (threshold {threshold:e})\n",
        r.outcome.as_str()
    );
    if let Some(f) = &r.failure {
        text += &format!("failure          {}\n", readable_numbers(f));
    }
    let (a, b) = scene.interior();
    if r.is_partial() {
        text += &format!(
            "e_max            none: the run stopped at t = {} s of {} s (over the part that ran: {:.4e})\n",
            r.t_reached, r.t_end, r.e_partial
        );
    } else if r.e_global.is_finite() {
        text += &format!(
            "e_max            {:.4e} (global), {:.4e} (interior, t in [{a}, {b}] s)\n",
            r.e_global, r.e_interior
        );
    } else {
        text += "e_max            none: the run did not start\n";
    }
    text += &format!("steps            {}\n", r.steps);
    if r.steps == 0 {
        return text;
    }
    text += &format!("Newton           {:.3} iterations per step (max {}), {:.2} residual evaluations per step, {} Jacobians, {} steps at the rounding floor\n", r.iterations_mean, r.iterations_max, r.residual_evals_per_step, r.jacobian_evals, r.floor_steps);
    if r.ns_per_step.is_finite() {
        text += &format!(
            "host time        {:.1} ns per step (median of 5)\n",
            r.ns_per_step
        );
    } else {
        text += "host time        not timed (only complete runs are)\n";
    }
    text
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
    // Opened before the first run: an unwritable path fails now, not after the sweep.
    let mut file = out.map(|p| create(p).map(|f| (p, f))).transpose()?;
    let mut write_row = |line: &str| match &mut file {
        Some((p, f)) => f
            .write_all(line.as_bytes())
            .and_then(|()| f.flush())
            .map_err(|e| format!("{}: {e}", p.display())),
        None => emit(line),
    };
    write_row(&format!("{CSV_HEADER}\n"))?;
    let bar = progress(configs.len());
    for (_, s) in &configs {
        let r = run_scene(s, repeats, threshold);
        write_row(&format!("{}\n", csv_row(s, &r)))?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(())
}
