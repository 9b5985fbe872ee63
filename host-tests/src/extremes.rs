//! `study extremes`: where each configuration stops being accurate, stops
//! converging, or produces non-finite values, on the paper's scenes and the hard
//! ones in `scenes/extremes/`. Every run's outcome is recorded (a typed error, never
//! a panic or a NaN in the output — a panic would be recorded as such and is asserted
//! absent by the tests).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use indicatif::ProgressBar;
use scene::Scene;

use crate::paper::{root, shipped};
use crate::plot::{heat_map, Facet};
use crate::study::{
    default_threshold, jacobian_label, run_scene, scheme_label, Outcome, RunResult,
};
use crate::sweep::{apply, csv_row, CSV_HEADER};

/// Step sizes of the map, 0.5 ms to 100 ms.
pub const STEPS: [f64; 8] = [0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1];

/// Outcome and e_max of each configuration row, by step size in µs.
type Grid = BTreeMap<Row, BTreeMap<u64, (Outcome, f64)>>;

/// One configuration of the map (without its step size).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Row {
    scheme: String,
    jacobian: String,
    rho: u32,
    scalar: &'static str,
}

impl Row {
    /// The row's label inside its scheme's panel.
    fn label(&self) -> String {
        format!("{} p={} {}", self.jacobian, self.rho, self.scalar)
    }
}

/// Schemes in the order of the panels: BDF1 … BDF6, then Radau.
fn facets(rows: &BTreeMap<Row, BTreeMap<u64, (Outcome, f64)>>, keys: &[u64]) -> Vec<Facet> {
    let mut facets: Vec<Facet> = Vec::new();
    for (row, hs) in rows {
        let cells = keys.iter().map(|k| hs.get(k).map(|c| c.0)).collect();
        match facets.iter_mut().find(|f| f.title == row.scheme) {
            Some(f) => {
                f.rows.push(row.label());
                f.cells.push(cells);
            }
            None => facets.push(Facet {
                title: row.scheme.clone(),
                rows: vec![row.label()],
                cells: vec![cells],
            }),
        }
    }
    facets
}

/// The scenes of the map: the paper's and the hard ones.
fn scenes(quick: bool) -> Result<Vec<Scene>, String> {
    if quick {
        return Ok(vec![
            shipped("paper-crane.toml")?,
            shipped("extremes/mass-on-car-alpha89.toml")?,
        ]);
    }
    let mut list = vec![
        shipped("paper-crane.toml")?,
        shipped("hard-crane.toml")?,
        shipped("mass-on-car.toml")?,
    ];
    let dir = root().join("scenes/extremes");
    let mut names: Vec<String> = fs::read_dir(&dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    names.sort();
    for n in names {
        list.push(shipped(&format!("extremes/{n}"))?);
    }
    Ok(list)
}

/// The configuration axes: schemes × Jacobians × ρ powers × scalars (× step sizes).
fn configurations(quick: bool) -> Vec<Vec<(&'static str, String)>> {
    let schemes: &[&str] = if quick {
        &["bdf4", "radau"]
    } else {
        &["bdf1", "bdf2", "bdf3", "bdf4", "bdf5", "bdf6", "radau"]
    };
    let jacobians: &[&str] = if quick {
        &["exact"]
    } else {
        &["j", "jt", "jt10", "jt50", "exact"]
    };
    let rhos: &[&str] = if quick { &["2"] } else { &["0", "1", "2", "3"] };
    let mut out = Vec::new();
    for s in schemes {
        for j in jacobians {
            for r in rhos {
                for x in ["f64", "f32"] {
                    out.push(vec![
                        ("scheme", s.to_string()),
                        ("jacobian", j.to_string()),
                        ("rho", r.to_string()),
                        ("scalar", x.to_string()),
                    ]);
                }
            }
        }
    }
    out
}

/// Runs the map and writes `extremes.csv`, `extremes.md` and one heat map per scene.
pub fn map(out: &Path, quick: bool, progress: &dyn Fn(usize) -> ProgressBar) -> Result<(), String> {
    fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let steps: &[f64] = if quick { &[0.01, 0.002] } else { &STEPS };
    let mut jobs = Vec::new();
    for scene in scenes(quick)? {
        for config in configurations(quick) {
            for &h in steps {
                let mut s = scene.clone();
                for (k, v) in &config {
                    s = apply(&s, k, v)?;
                }
                jobs.push(apply(&s, "h", &h.to_string())?);
            }
        }
    }
    let bar = progress(jobs.len());
    let results = run_all(&jobs, &bar);
    bar.finish_and_clear();

    let mut csv = format!("{CSV_HEADER}\n");
    for (s, r) in jobs.iter().zip(&results) {
        csv += &csv_row(s, r);
        csv.push('\n');
    }
    fs::write(out.join("extremes.csv"), csv).map_err(|e| e.to_string())?;

    // Per scene: a grid of outcomes (rows: configurations, columns: step sizes).
    let mut by_scene: BTreeMap<String, Grid> = BTreeMap::new();
    for (s, r) in jobs.iter().zip(&results) {
        let row = Row {
            scheme: scheme_label(s),
            jacobian: jacobian_label(s),
            rho: s.solver.rho_power,
            scalar: match s.solver.scalar {
                scene::ScalarSpec::F64 => "f64",
                scene::ScalarSpec::F32 => "f32",
            },
        };
        let key = (s.solver.h * 1e6).round() as u64;
        by_scene
            .entry(s.name.clone())
            .or_default()
            .entry(row)
            .or_default()
            .insert(key, (r.outcome, r.e_global));
    }
    let columns: Vec<String> = steps.iter().map(|h| format!("{}", h * 1000.0)).collect();
    let keys: Vec<u64> = steps.iter().map(|h| (h * 1e6).round() as u64).collect();
    let mut md = String::from(
        "# Stability map\n\nRegenerated by `cargo xtask study extremes`. Outcome of every configuration: `ok` (e_max at or\n\
         below the threshold: 1e-3 m/s for the crane, 1e-2 N for the mass-on-car), `inaccurate` (above it),\n\
         `newton-failure` (no convergence within 20 iterations, or a singular matrix), `non-finite` (a NaN or\n\
         infinity, caught as a typed error), `refused` (the scene was refused before running). The heat maps\n\
         `extremes-<scene>.svg` have one panel per scheme (rows: Jacobian, ρ power p, scalar; columns: h in ms);\n\
         the tables below are for ρ = h^-2 (p = 2).\n",
    );
    let mut totals: BTreeMap<&'static str, usize> = BTreeMap::new();
    for r in &results {
        *totals.entry(r.outcome.as_str()).or_default() += 1;
    }
    let _ = writeln!(
        md,
        "\nAll {} runs: {}.",
        results.len(),
        totals
            .iter()
            .map(|(k, v)| format!("{v} {k}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for (name, rows) in &by_scene {
        heat_map(
            &out.join(format!("extremes-{name}.svg")),
            &format!("Stability map: {name} (one panel per scheme; columns: h in ms)"),
            &columns,
            &facets(rows, &keys),
            4,
        )?;
        let _ = writeln!(md, "\n## {name}\n\n`extremes-{name}.svg`\n\n| scheme | Jacobian | scalar | accurate for h in | smaller h | larger h |\n|---|---|---|---|---|---|");
        for (row, hs) in rows.iter().filter(|(r, _)| r.rho == 2) {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} |",
                row.scheme,
                row.jacobian,
                row.scalar,
                describe(&keys, hs)
            );
        }
    }
    fs::write(out.join("extremes.md"), md).map_err(|e| e.to_string())
}

/// `accurate range | what happens below it | what happens above it` for one row.
fn describe(keys: &[u64], hs: &BTreeMap<u64, (Outcome, f64)>) -> String {
    let ok: Vec<u64> = keys
        .iter()
        .copied()
        .filter(|k| hs.get(k).is_some_and(|c| c.0 == Outcome::Ok))
        .collect();
    let ms = |k: u64| format!("{} ms", k as f64 / 1000.0);
    let outcomes = |ks: Vec<u64>| -> String {
        let mut names: Vec<&str> = ks
            .iter()
            .filter_map(|k| hs.get(k))
            .map(|c| c.0.as_str())
            .collect();
        names.dedup();
        if names.is_empty() {
            "—".into()
        } else {
            names.join(", ")
        }
    };
    match (ok.first(), ok.last()) {
        (Some(&lo), Some(&hi)) => format!(
            "{} … {} | {} | {}",
            ms(lo),
            ms(hi),
            outcomes(keys.iter().copied().filter(|k| *k < lo).collect()),
            outcomes(keys.iter().copied().filter(|k| *k > hi).collect())
        ),
        _ => format!("never (all h: {}) | — | —", outcomes(keys.to_vec())),
    }
}

/// Runs the jobs on every core, keeping their order.
pub fn run_all(jobs: &[Scene], bar: &ProgressBar) -> Vec<RunResult> {
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<RunResult>>> = Mutex::new(vec![None; jobs.len()]);
    let workers = std::thread::available_parallelism().map_or(1, usize::from);
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(scene) = jobs.get(i) else { break };
                let r = run_scene(scene, 0, default_threshold(scene));
                if let Ok(mut all) = results.lock() {
                    if let Some(slot) = all.get_mut(i) {
                        *slot = Some(r);
                    }
                }
                bar.inc(1);
            });
        }
    });
    results
        .into_inner()
        .unwrap_or_default()
        .into_iter()
        .map(|r| r.unwrap_or_else(|| RunResult::not_run("a worker stopped before this run")))
        .collect()
}
