//! The speed/accuracy trade as a user makes it (issue 30): for each crane, every scheme ×
//! formulation × Jacobian mode × step size, its e_max (global and interior) against what
//! a step costs — host instructions (callgrind, measured by `cargo xtask trade`) and
//! estimated Cortex-M7 µs — with the Pareto front marked; and the Newton matrix's
//! condition number against h per formulation.
//!
//! This module holds what does not need valgrind: the grid of configurations, the rows
//! and their CSV, the estimate of Cortex-M7 µs from host instructions, the Pareto
//! fronts, the figures and tables, and the condition numbers. `cargo xtask trade` runs
//! the grid (xtask/src/trade.rs).

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{SMatrix, SVector};
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::{Crane3dExt, Crane3dParams, Crane3dSubs};
use solver_core::models::crane_ext::CraneExt;
use solver_core::models::crane_proj::CraneProj;
use solver_core::models::crane_subs::CraneSubs;
use solver_core::models::double_pendulum::DoublePendulumSubs;
use solver_core::models::double_pendulum_crane::DoublePendulumParams;
use solver_core::models::double_pendulum_ext::DoublePendulumExt;
use solver_core::reference::{double_pendulum, flat_crane, flat_crane3d};
use solver_core::trajectory::{PointToPoint, Trajectory};
use solver_core::DaeModel;

use crate::plot::{Chart, Legend, Scale, Series};

/// The step sizes of the trade, 50 ms down to 0.5 ms (as `sweep --vary h=…` writes them).
pub const STEP_SIZES: [&str; 7] = ["0.05", "0.02", "0.01", "0.005", "0.002", "0.001", "0.0005"];

/// A crane of the trade: its scene, its formulations and those with the firmware's
/// structured Newton.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Crane {
    /// Short name, used for the output files.
    pub name: &'static str,
    /// What the figures call it.
    pub title: &'static str,
    /// The scene (its move and crane); the grid varies its solver and formulation.
    pub scene: &'static str,
    /// Its formulations (`--vary formulation=` values).
    pub formulations: &'static [&'static str],
    /// The formulations with a structured elimination (the firmware's BDF and RADAU5).
    pub structured: &'static [&'static str],
}

/// The planar crane on the paper's move, the 3D crane on its diagonal move, and the
/// hook-and-load crane (a double pendulum) on the paper's move.
pub const CRANES: [Crane; 3] = [
    Crane {
        name: "planar",
        title: "the paper's crane (planar)",
        scene: "scenes/paper-crane.toml",
        formulations: &["subs", "proj", "ext"],
        structured: &["subs", "ext"],
    },
    Crane {
        name: "3d",
        title: "the 3D crane (diagonal move)",
        scene: "scenes/crane3d-diagonal.toml",
        formulations: &["subs", "ext"],
        structured: &["subs", "ext"],
    },
    Crane {
        name: "double-pendulum",
        title: "the hook-and-load crane (double pendulum)",
        scene: "scenes/hook-and-load.toml",
        formulations: &["subs", "ext"],
        structured: &["subs", "ext"],
    },
];

/// The crane of the trade called `name`.
pub fn crane(name: &str) -> Result<&'static Crane, String> {
    CRANES.iter().find(|c| c.name == name).ok_or_else(|| {
        let names: Vec<&str> = CRANES.iter().map(|c| c.name).collect();
        format!(
            "no crane `{name}` in the trade (one of {})",
            names.join(", ")
        )
    })
}

/// The paper's Jacobian modes and the exact one (`--vary jacobian=` values).
pub const MODES: [&str; 5] = ["j", "jt", "jt10", "jt50", "exact"];

/// One configuration: a formulation, a scheme, a Jacobian mode, and whether the Newton
/// systems are solved by the model's structured elimination (the firmware's strategies).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Config {
    /// `subs`, `proj` or `ext`.
    pub formulation: &'static str,
    /// `bdf1` … `bdf6` or `radau`.
    pub scheme: String,
    /// `j`, `jt`, `jt10`, `jt50`, `exact` or `transformed`.
    pub jacobian: &'static str,
    /// The firmware's structured Newton (BDF: exact; Radau: transformed).
    pub structured: bool,
}

impl Config {
    /// The settings `steps` takes (`key=value`), `h` excluded.
    #[must_use]
    pub fn settings(&self) -> Vec<String> {
        let mut s = vec![
            format!("formulation={}", self.formulation),
            format!("scheme={}", self.scheme),
            format!("jacobian={}", self.jacobian),
        ];
        if self.structured {
            s.push("newton=structured".into());
        }
        s
    }

    /// The label of the rows and legends: `ext BDF4 exact, structured`.
    #[must_use]
    pub fn label(&self) -> String {
        let scheme = match self.scheme.strip_prefix("bdf") {
            Some(k) => format!("BDF{k}"),
            None => "Radau".into(),
        };
        let jacobian = match self.jacobian {
            "j" => "J",
            "jt" => "J̃",
            "jt10" => "J̃₁₀",
            "jt50" => "J̃₅₀",
            other => other,
        };
        let structured = if self.structured { ", structured" } else { "" };
        format!("{} {scheme} {jacobian}{structured}", self.formulation)
    }

    /// The kind of step, for the estimate of Cortex-M7 cycles ([`Family`]).
    #[must_use]
    pub fn family(&self) -> Family {
        match (self.structured, self.scheme.as_str(), self.jacobian) {
            (true, "radau", _) => Family::StructuredRadau5,
            (true, _, _) => Family::StructuredBdf,
            (false, _, j) if j.starts_with("jt") => Family::Broyden,
            _ => Family::Dense,
        }
    }
}

/// Every configuration of a crane: each formulation with BDF 1–6 and Radau IIA in the
/// paper's modes and the exact one, Radau also with RADAU5's transformed Newton, and the
/// structured formulations with the firmware's BDF 1–6 and RADAU5.
#[must_use]
pub fn configurations(crane: &Crane) -> Vec<Config> {
    let schemes: Vec<String> = (1..=6)
        .map(|k| format!("bdf{k}"))
        .chain(["radau".to_string()])
        .collect();
    let mut out = Vec::new();
    for formulation in crane.formulations {
        for scheme in &schemes {
            let transformed = (scheme == "radau").then_some("transformed");
            for jacobian in MODES.into_iter().chain(transformed) {
                out.push(Config {
                    formulation,
                    scheme: scheme.clone(),
                    jacobian,
                    structured: false,
                });
            }
        }
    }
    for formulation in crane.structured {
        for scheme in &schemes {
            out.push(Config {
                formulation,
                scheme: scheme.clone(),
                jacobian: if scheme == "radau" {
                    "transformed"
                } else {
                    "exact"
                },
                structured: true,
            });
        }
    }
    out
}

/// The kind of step, as the Cortex-M7 estimate tells them apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Family {
    /// BDF by the model's structured elimination, from its closed-form step.
    StructuredBdf,
    /// RADAU5 by the structured elimination, its stages in closed form.
    StructuredRadau5,
    /// Newton on dense LUs with J, the exact Jacobian or RADAU5's transformed systems.
    Dense,
    /// Broyden's updates (J̃, J̃ₙ).
    Broyden,
}

impl Family {
    /// Estimated Cortex-M7 cycles per host instruction of a step of this kind: the point
    /// estimate's cycles per QEMU instruction of a firmware scene's tick (`cargo xtask
    /// cycles`) times its inverse-model step's QEMU instructions per host instruction
    /// (`qemu-bench`'s *solver only* mean over `cargo xtask instructions`), on the
    /// firmware scenes of the same kind (docs/RESULTS.md, *The trade*, lists each
    /// scene's two factors and the run they come from): structured BDF4, planar and 3D,
    /// 1.62 and 1.62; structured RADAU5 1.93 and 2.09; Radau with the exact Jacobian on
    /// the 3N×3N LU 1.97; J̃₁₀ 3.07. An estimate: a step of another configuration of the
    /// same kind may differ by the spread within a kind.
    #[must_use]
    pub const fn cycles_per_host_instruction(self) -> f64 {
        match self {
            Family::StructuredBdf => 1.62,
            Family::StructuredRadau5 => 2.01,
            Family::Dense => 1.97,
            Family::Broyden => 3.07,
        }
    }
}

/// The Cortex-M7's clock the µs are given for (the STM32H743's maximum), MHz.
pub const CLOCK_MHZ: f64 = 480.0;

/// What one configuration at one step size measured.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// Steps of the run.
    pub steps: u64,
    /// Newton iterations per step (as the CSV writes them, to 3 decimals: a row read
    /// back from the CSV writes the same line).
    pub iterations_per_step: f64,
    /// Eq. 29 over the whole run.
    pub e_global: f64,
    /// Eq. 29 over the move's interior.
    pub e_interior: f64,
    /// Host instructions per step (callgrind); NaN while the row is not yet counted
    /// ([`UNCOUNTED`]).
    pub instructions: f64,
}

/// The outcome of a row whose e_max was measured but whose callgrind count was not
/// made: `cargo xtask trade` counts the rows fastest first, so a grid stopped for time
/// leaves its costliest rows so.
pub const UNCOUNTED: &str =
    "e_max only: its callgrind count not made (the grid counts its fastest runs first)";

impl Measured {
    /// A run's accuracy before its callgrind count.
    #[must_use]
    pub fn uncounted(steps: u64, iterations_per_step: f64, e_global: f64, e_interior: f64) -> Self {
        Self {
            steps,
            iterations_per_step,
            e_global,
            e_interior,
            instructions: f64::NAN,
        }
    }

    /// Whether its host instructions were counted.
    #[must_use]
    pub fn counted(&self) -> bool {
        self.instructions.is_finite()
    }

    /// Estimated Cortex-M7 µs per step at [`CLOCK_MHZ`].
    #[must_use]
    pub fn microseconds(&self, family: Family) -> f64 {
        self.instructions * family.cycles_per_host_instruction() / CLOCK_MHZ
    }
}

/// One row of a crane's trade: a configuration at a step size, and what it measured or
/// why it has no measurement (its run failed).
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The configuration.
    pub config: Config,
    /// The step size, s.
    pub h: f64,
    /// The measurement, or the failure.
    pub outcome: Result<Measured, String>,
}

/// The CSV columns of a trade (docs/RESULTS.md).
pub const CSV_HEADER: &str = "crane,formulation,scheme,jacobian,structured,h,steps,newton_iterations_per_step,e_max,e_max_interior,host_instructions_per_step,m7_cycles_per_host_instruction,m7_us_per_step,pareto_interior_instructions,outcome";

/// The rows as CSV, each marked if it is on the Pareto front of interior e_max against
/// host instructions.
#[must_use]
pub fn csv(crane: &Crane, rows: &[Row]) -> String {
    let front = pareto(rows, Error::Interior, Cost::Instructions);
    let mut out = format!("{CSV_HEADER}\n");
    for (i, r) in rows.iter().enumerate() {
        let c = &r.config;
        let k = c.family().cycles_per_host_instruction();
        let (fields, outcome) = match &r.outcome {
            Ok(m) if !m.counted() => (
                format!(
                    "{},{:.3},{:.4e},{:.4e},,{k},",
                    m.steps, m.iterations_per_step, m.e_global, m.e_interior
                ),
                UNCOUNTED.to_string(),
            ),
            Ok(m) => (
                format!(
                    "{},{:.3},{:.4e},{:.4e},{:.0},{k},{:.3}",
                    m.steps,
                    m.iterations_per_step,
                    m.e_global,
                    m.e_interior,
                    m.instructions,
                    m.microseconds(c.family())
                ),
                "ok".to_string(),
            ),
            Err(e) => (",,,,,,".to_string(), e.replace(['"', ','], ";")),
        };
        let _ = writeln!(
            out,
            "{},{},{},{},{},{},{fields},{},\"{outcome}\"",
            crane.name,
            c.formulation,
            c.scheme,
            c.jacobian,
            c.structured,
            r.h,
            front.contains(&i)
        );
    }
    out
}

/// The rows of a crane's CSV as [`csv`] wrote them, so that a grid can be resumed (the
/// rows already measured kept, `cargo xtask trade`) and the tables written from a grid
/// measured earlier. Every row must be one of the crane's [`configurations`]; the
/// Pareto column is not read ([`csv`] marks the front anew). A row written by [`csv`]
/// and read back writes the same line: the values are read as written.
pub fn read_csv(crane: &Crane, text: &str) -> Result<Vec<Row>, String> {
    let configs = configurations(crane);
    let mut lines = text.lines();
    if lines.next() != Some(CSV_HEADER) {
        return Err(format!("{}: not a trade CSV (header)", crane.name));
    }
    lines
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, line)| {
            let at = |what: &str| format!("{}.csv line {}: {what}: {line}", crane.name, i + 2);
            let f: Vec<&str> = line.splitn(15, ',').collect();
            let [name, formulation, scheme, jacobian, structured, h, steps, ips, e_global, e_interior, instructions, _, _, _, outcome] =
                f.as_slice()
            else {
                return Err(at("expected 15 fields"));
            };
            if *name != crane.name {
                return Err(at("another crane's row"));
            }
            let config = configs
                .iter()
                .find(|c| {
                    c.formulation == *formulation
                        && c.scheme == *scheme
                        && c.jacobian == *jacobian
                        && c.structured.to_string() == *structured
                })
                .ok_or_else(|| at("not a configuration of the crane"))?
                .clone();
            let number = |v: &str| v.parse::<f64>().map_err(|_| at(&format!("`{v}`")));
            let outcome = outcome.trim_matches('"');
            let outcome = if outcome == "ok" || outcome == UNCOUNTED {
                Ok(Measured {
                    steps: steps.parse().map_err(|_| at("steps"))?,
                    iterations_per_step: number(ips)?,
                    e_global: number(e_global)?,
                    e_interior: number(e_interior)?,
                    instructions: if outcome == "ok" {
                        number(instructions)?
                    } else {
                        f64::NAN
                    },
                })
            } else {
                Err(outcome.to_string())
            };
            Ok(Row {
                config,
                h: number(h)?,
                outcome,
            })
        })
        .collect()
}

/// Which e_max.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// Over the whole run.
    Global,
    /// Over the move's interior.
    Interior,
}

/// Which cost.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cost {
    /// Host instructions per step.
    Instructions,
    /// Estimated Cortex-M7 µs per step.
    Microseconds,
}

/// A row's point `(cost, error)`, if it was measured.
#[must_use]
pub fn point(r: &Row, error: Error, cost: Cost) -> Option<(f64, f64)> {
    let m = r.outcome.as_ref().ok()?;
    let e = match error {
        Error::Global => m.e_global,
        Error::Interior => m.e_interior,
    };
    let c = match cost {
        Cost::Instructions => m.instructions,
        Cost::Microseconds => m.microseconds(r.config.family()),
    };
    (e.is_finite() && c.is_finite()).then_some((c, e))
}

/// The indices of the rows on the Pareto front: no other row is both cheaper (or as
/// cheap) and more accurate. Ordered by cost.
#[must_use]
pub fn pareto(rows: &[Row], error: Error, cost: Cost) -> Vec<usize> {
    let mut points: Vec<(usize, (f64, f64))> = rows
        .iter()
        .enumerate()
        .filter_map(|(i, r)| point(r, error, cost).map(|p| (i, p)))
        .collect();
    points.sort_by(|a, b| a.1 .0.total_cmp(&b.1 .0).then(a.1 .1.total_cmp(&b.1 .1)));
    let mut best = f64::INFINITY;
    let mut front = Vec::new();
    for (i, (_, e)) in points {
        if e < best {
            best = e;
            front.push(i);
        }
    }
    front
}

/// The four panels of a crane's figure: e_max global and interior against host
/// instructions and against estimated µs, each formulation's points and the front.
#[must_use]
pub fn panels<'a>(
    crane: &Crane,
    rows: &[Row],
    titles: &'a [String; 4],
) -> Vec<(Chart<'a>, Vec<Series>, Series)> {
    let grid = [
        (Error::Global, Cost::Instructions),
        (Error::Interior, Cost::Instructions),
        (Error::Global, Cost::Microseconds),
        (Error::Interior, Cost::Microseconds),
    ];
    grid.iter()
        .zip(titles)
        .map(|(&(error, cost), title)| {
            let clouds = crane
                .formulations
                .iter()
                .map(|f| Series {
                    name: (*f).to_string(),
                    points: rows
                        .iter()
                        .filter(|r| r.config.formulation == *f)
                        .filter_map(|r| point(r, error, cost))
                        .collect(),
                })
                .collect();
            let front = Series {
                name: "Pareto front".into(),
                points: pareto(rows, error, cost)
                    .iter()
                    .filter_map(|&i| rows.get(i).and_then(|r| point(r, error, cost)))
                    .collect(),
            };
            let chart = Chart {
                title,
                x_label: match cost {
                    Cost::Instructions => "host instructions per step",
                    Cost::Microseconds => "estimated Cortex-M7 µs per step (480 MHz)",
                },
                y_label: match error {
                    Error::Global => "e_max, whole run",
                    Error::Interior => "e_max, interior",
                },
                x_scale: Scale::Log,
                y_scale: Scale::Log,
                legend: Legend::OverData,
            };
            (chart, clouds, front)
        })
        .collect()
}

/// The titles of a crane's four panels.
#[must_use]
pub fn titles(crane: &Crane) -> [String; 4] {
    [
        format!("{}: e_max against host instructions", crane.title),
        format!("{}: interior e_max against host instructions", crane.title),
        format!("{}: e_max against Cortex-M7 µs (est.)", crane.title),
        format!(
            "{}: interior e_max against Cortex-M7 µs (est.)",
            crane.title
        ),
    ]
}

/// The accuracy levels of the pick table, m/s.
pub const LEVELS: [f64; 6] = [1e-3, 1e-5, 1e-7, 1e-9, 1e-11, 1e-13];

/// The cheapest configuration (host instructions) at step size `h` whose e_max over the
/// whole run is at most `level`, if any.
#[must_use]
pub fn cheapest(rows: &[Row], h: f64, level: f64) -> Option<&Row> {
    rows.iter()
        .filter(|r| r.h == h)
        .filter(|r| {
            r.outcome
                .as_ref()
                .is_ok_and(|m| m.counted() && m.e_global <= level)
        })
        .min_by(|a, b| {
            let cost = |r: &Row| r.outcome.as_ref().map_or(f64::INFINITY, |m| m.instructions);
            cost(a).total_cmp(&cost(b))
        })
}

/// A crane's Markdown: its Pareto front (interior e_max against host instructions, then
/// global e_max against µs) and the pick table — the cheapest configuration per step
/// size and accuracy.
#[must_use]
pub fn markdown(crane: &Crane, rows: &[Row]) -> String {
    let mut out = format!("## {}\n\n", crane.title);
    let measured = rows
        .iter()
        .filter(|r| r.outcome.as_ref().is_ok_and(Measured::counted))
        .count();
    let uncounted = rows
        .iter()
        .filter(|r| r.outcome.as_ref().is_ok_and(|m| !m.counted()))
        .count();
    let mut configs: Vec<&Config> = rows.iter().map(|r| &r.config).collect();
    configs.dedup();
    let mut steps: Vec<f64> = rows.iter().map(|r| r.h).collect();
    steps.sort_by(f64::total_cmp);
    steps.dedup();
    let _ = writeln!(
        out,
        "{} configurations × {} step sizes: {measured} of {} runs completed and counted, {uncounted} completed with e_max only (their callgrind count not made), {} failed (their failures are in the CSV).\n",
        configs.len(),
        steps.len(),
        rows.len(),
        rows.len() - measured - uncounted
    );
    for (error, cost, what) in [
        (
            Error::Interior,
            Cost::Instructions,
            "interior e_max against host instructions per step",
        ),
        (
            Error::Global,
            Cost::Microseconds,
            "e_max over the whole run against estimated Cortex-M7 µs per step",
        ),
    ] {
        let _ = writeln!(out, "Pareto front, {what}:\n");
        out += "| configuration | h, ms | e_max | interior e_max | host instructions / step | est. M7 µs / step |\n|---|---:|---:|---:|---:|---:|\n";
        for i in pareto(rows, error, cost) {
            let Some(r) = rows.get(i) else { continue };
            let Ok(m) = &r.outcome else { continue };
            let _ = writeln!(
                out,
                "| {} | {} | {:.1e} | {:.1e} | {:.0} | {:.2} |",
                r.config.label(),
                r.h * 1000.0,
                m.e_global,
                m.e_interior,
                m.instructions,
                m.microseconds(r.config.family())
            );
        }
        out.push('\n');
    }
    out += "The cheapest configuration (host instructions per step) at each step size whose e_max over the whole run is at most the level (— none):\n\n| e_max ≤ |";
    for h in STEP_SIZES {
        let _ = write!(
            out,
            " h = {} ms |",
            h.parse::<f64>().unwrap_or(f64::NAN) * 1000.0
        );
    }
    out += "\n|---|";
    out += &"---|".repeat(STEP_SIZES.len());
    out.push('\n');
    for level in LEVELS {
        let _ = write!(out, "| {level:.0e} |");
        for h in STEP_SIZES {
            let h: f64 = h.parse().unwrap_or(f64::NAN);
            match cheapest(rows, h, level) {
                Some(r) => {
                    let instructions = r.outcome.as_ref().map_or(f64::NAN, |m| m.instructions);
                    let _ = write!(out, " {} ({:.0}) |", r.config.label(), instructions);
                }
                None => out += " — |",
            }
        }
        out.push('\n');
    }
    out
}

/// The 1-norm condition number `‖A‖₁ ‖A⁻¹‖₁` (LAPACK's κ₁); infinite for a singular `A`.
#[must_use]
pub fn condition<const N: usize>(a: &SMatrix<f64, N, N>) -> f64 {
    let norm = |m: &SMatrix<f64, N, N>| m.abs().row_sum().max();
    a.try_inverse()
        .map_or(f64::INFINITY, |inv| norm(a) * norm(&inv))
}

/// BDF4's Newton matrix `S·(∂F/∂x + α₀/h ∂F/∂ẋ)` of `model` at `x` and `t`, the
/// algebraic rows scaled by `ρ = h^-power` (Sec. 3.1.1), and its κ₁.
#[must_use]
pub fn bdf4_condition<M: DaeModel<f64, N, NU>, const N: usize, const NU: usize>(
    model: &M,
    x: &SVector<f64, N>,
    t: f64,
    h: f64,
    power: i32,
) -> f64 {
    let p = model.partials(x, &SVector::zeros(), &model.sample(t));
    let mut a = p.dx + p.dxdot * (25.0 / 12.0 / h);
    for (mut row, algebraic) in a.row_iter_mut().zip(M::ALGEBRAIC) {
        if algebraic {
            row /= h.powi(power);
        }
    }
    condition(&a)
}

/// κ₁ of BDF4's Newton matrix at the middle of each crane's move (the planar, the 3D and
/// the hook-and-load crane), on the exact solution, with the scenes' ρ = 1/h², per
/// formulation and step size: `(name, [κ₁ per h of STEP_SIZES])`.
pub fn conditions() -> Result<Vec<(&'static str, Vec<f64>)>, String> {
    let e = |e: solver_core::Error| e.to_string();
    let steps: Vec<f64> = STEP_SIZES.iter().filter_map(|h| h.parse().ok()).collect();
    let p = CraneParams::PAPER;
    let z = PointToPoint::new(
        SVector::from([12.0, 8.0]),
        SVector::from([20.0, 4.0]),
        1.0,
        8.0,
        4,
    )
    .map_err(e)?;
    let (t, t3) = (5.0, 4.5);
    let flat = flat_crane::flat_inverse(&p, &z, t);
    let p3 = Crane3dParams::EXAMPLE;
    let z3 = PointToPoint::new(
        SVector::from([12.0, 3.0, 8.0]),
        SVector::from([20.0, 6.0, 4.0]),
        1.0,
        7.0,
        4,
    )
    .map_err(e)?;
    let (subs, proj, ext) = (
        CraneSubs::new(p, z).map_err(e)?,
        CraneProj::new(p, z).map_err(e)?,
        CraneExt::new(p, z).map_err(e)?,
    );
    let (subs3, ext3) = (
        Crane3dSubs::new(p3, z3).map_err(e)?,
        Crane3dExt::new(p3, z3).map_err(e)?,
    );
    let x_ext = flat_crane::extended_state(&p, &z, t);
    let x3 = flat_crane3d::flat_inverse(&p3, &z3, t3).subs();
    let x_ext3 = flat_crane3d::extended_state(&p3, &z3, t3);
    // The hook-and-load crane on the paper's move (its scene's smoothness, 7).
    let pd = DoublePendulumParams::EXAMPLE;
    let zd = PointToPoint::new(
        SVector::from([12.0, 8.0]),
        SVector::from([20.0, 4.0]),
        1.0,
        8.0,
        7,
    )
    .map_err(e)?;
    let (subs_d, ext_d) = (
        DoublePendulumSubs::new(pd, zd).map_err(e)?,
        DoublePendulumExt::new(pd, zd).map_err(e)?,
    );
    let dd = zd.derivatives::<8>(t);
    let x_d = double_pendulum::flat_state(&pd, &dd, t).map_err(e)?.subs();
    let x_ext_d = double_pendulum::extended_state(&pd, &dd, t).map_err(e)?;
    let row = |f: &dyn Fn(f64) -> f64| steps.iter().map(|h| f(*h)).collect::<Vec<f64>>();
    Ok(vec![
        (
            "planar subs",
            row(&|h| bdf4_condition(&subs, &flat.subs(), t, h, 2)),
        ),
        (
            "planar proj",
            row(&|h| bdf4_condition(&proj, &flat.proj(), t, h, 2)),
        ),
        (
            "planar ext",
            row(&|h| bdf4_condition(&ext, &x_ext, t, h, 2)),
        ),
        ("3D subs", row(&|h| bdf4_condition(&subs3, &x3, t3, h, 2))),
        ("3D ext", row(&|h| bdf4_condition(&ext3, &x_ext3, t3, h, 2))),
        (
            "double pendulum subs",
            row(&|h| bdf4_condition(&subs_d, &x_d, t, h, 2)),
        ),
        (
            "double pendulum ext",
            row(&|h| bdf4_condition(&ext_d, &x_ext_d, t, h, 2)),
        ),
    ])
}

/// The condition numbers as CSV (`formulation,h,kappa1`) and as a figure (κ₁ against h,
/// log–log) in `out`.
pub fn write_conditions(out: &Path) -> Result<Vec<(&'static str, Vec<f64>)>, String> {
    let rows = conditions()?;
    let steps: Vec<f64> = STEP_SIZES.iter().filter_map(|h| h.parse().ok()).collect();
    let mut csv = String::from("formulation,h,kappa1\n");
    for (name, values) in &rows {
        for (h, k) in steps.iter().zip(values) {
            let _ = writeln!(csv, "{name},{h},{k:.6e}");
        }
    }
    let path = out.join("condition.csv");
    std::fs::write(&path, csv).map_err(|e| format!("{}: {e}", path.display()))?;
    let series = rows
        .iter()
        .map(|(name, values)| Series {
            name: (*name).to_string(),
            points: steps.iter().copied().zip(values.iter().copied()).collect(),
        })
        .collect();
    let chart = Chart {
        title: "κ₁ of BDF4's Newton matrix at mid-move (ρ = 1/h²)",
        x_label: "h, s",
        y_label: "condition number κ₁",
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        legend: Legend::OverData,
    };
    crate::plot::figure(&out.join("condition.svg"), &[(chart, series)], false)?;
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(formulation: &'static str, instructions: f64, e: f64) -> Row {
        Row {
            config: Config {
                formulation,
                scheme: "bdf4".into(),
                jacobian: "exact",
                structured: false,
            },
            h: 0.01,
            outcome: Ok(Measured {
                steps: 1000,
                iterations_per_step: 2.0,
                e_global: e,
                e_interior: e / 10.0,
                instructions,
            }),
        }
    }

    /// The front keeps a row only if nothing cheaper is as accurate: ordered by cost,
    /// each more accurate than the one before; failed rows are not on it.
    #[test]
    fn the_pareto_front_is_the_non_dominated_rows() {
        let mut rows = vec![
            row("subs", 400.0, 1e-3),
            row("ext", 500.0, 1e-15),
            row("proj", 450.0, 1e-2),
            row("subs", 300.0, 1e-1),
            row("subs", 5000.0, 1e-16),
            row("ext", 600.0, 1e-14),
        ];
        rows.push(Row {
            outcome: Err("Newton failed".into()),
            ..row("subs", 1.0, 0.0)
        });
        assert_eq!(
            pareto(&rows, Error::Global, Cost::Instructions),
            [3, 0, 1, 4]
        );
        let csv = csv(&CRANES[0], &rows);
        assert_eq!(csv.lines().count(), 1 + rows.len());
        assert!(csv
            .lines()
            .last()
            .is_some_and(|l| l.contains("Newton failed")));
        assert_eq!(
            cheapest(&rows, 0.01, 1e-12).map(|r| r.config.formulation),
            Some("ext")
        );
        assert!(cheapest(&rows, 0.01, 1e-17).is_none());
    }

    /// A CSV read back writes the same values: the committed planar grid (so tables
    /// written from it say what it measured) — every field as committed, but the µs and
    /// the Pareto marks, which the committed grid computed from the unrounded counts
    /// (within half an instruction's worth; a mark differs only at a tie of rounded
    /// counts); a CSV written from rows read back is the same text; and
    /// a CSV that is not the crane's or names no configuration of it is refused.
    #[test]
    fn a_trade_csv_read_back_writes_the_same_values() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../docs/figures/trade/planar.csv"
        );
        let committed = std::fs::read_to_string(path).unwrap();
        let rows = read_csv(&CRANES[0], &committed).unwrap();
        assert_eq!(rows.len(), 854);
        let written = csv(&CRANES[0], &rows);
        assert_eq!(written.lines().count(), committed.lines().count());
        for (w, c) in written.lines().zip(committed.lines()).skip(1) {
            let (w, c): (Vec<&str>, Vec<&str>) = (w.split(',').collect(), c.split(',').collect());
            for (i, (a, b)) in w.iter().zip(&c).enumerate() {
                if i == 13 && a != b {
                    // The committed marks came from the unrounded counts: a mark differs
                    // only where the row's rounded count ties with another row's.
                    let ties = committed
                        .lines()
                        .filter(|l| l.split(',').nth(10) == Some(c[10]))
                        .count();
                    assert!(ties > 1, "{w:?} {c:?}");
                } else if i == 12 && a != b {
                    // Half an instruction's worth, and the third decimal's rounding.
                    let (a, b): (f64, f64) = (a.parse().unwrap(), b.parse().unwrap());
                    let k: f64 = c[11].parse().unwrap();
                    assert!((a - b).abs() <= 0.5 * k / CLOCK_MHZ + 1e-3, "{w:?} {c:?}");
                } else {
                    assert_eq!(a, b, "{w:?} {c:?}");
                }
            }
        }
        assert_eq!(
            csv(&CRANES[0], &read_csv(&CRANES[0], &written).unwrap()),
            written
        );
        assert!(read_csv(&CRANES[1], &committed).is_err());
        let broken = committed.replacen(
            "planar,subs,bdf1,j,false,0.05,200",
            "planar,subs,bdf7,j,false,0.05,200",
            1,
        );
        assert!(read_csv(&CRANES[0], &broken).is_err());
    }

    /// A row measured for its e_max but not counted writes and reads back as such, is on
    /// no front and is nobody's cheapest.
    #[test]
    fn an_uncounted_row_is_kept_but_not_costed() {
        let mut rows = vec![row("ext", 500.0, 1e-15)];
        rows.push(Row {
            outcome: Ok(Measured::uncounted(1000, 1.5, 1e-16, 1e-16)),
            ..row("subs", 0.0, 0.0)
        });
        let text = csv(&CRANES[0], &rows);
        assert!(text.contains(UNCOUNTED));
        assert_eq!(
            read_csv(&CRANES[0], &text).map(|r| csv(&CRANES[0], &r)),
            Ok(text)
        );
        assert_eq!(pareto(&rows, Error::Global, Cost::Instructions), [0]);
        assert_eq!(
            cheapest(&rows, 0.01, 1e-15).map(|r| r.config.formulation),
            Some("ext")
        );
    }

    /// The grid: each formulation × (BDF 1–6 × 5 modes + Radau × 6), and the structured
    /// formulations × (BDF 1–6 + RADAU5).
    #[test]
    fn the_grid_has_every_scheme_mode_and_formulation() {
        let planar = configurations(&CRANES[0]);
        assert_eq!(planar.len(), 3 * (6 * 5 + 6) + 2 * 7);
        assert_eq!(configurations(&CRANES[1]).len(), 2 * (6 * 5 + 6) + 2 * 7);
        assert_eq!(configurations(&CRANES[2]).len(), 2 * (6 * 5 + 6) + 2 * 7);
        assert_eq!(
            crane("double-pendulum").map(|c| c.scene),
            Ok("scenes/hook-and-load.toml")
        );
        assert!(crane("dp").is_err());
        assert!(planar
            .iter()
            .any(|c| c.label() == "ext Radau transformed, structured"));
        assert_eq!(
            planar
                .iter()
                .find(|c| c.jacobian == "jt10")
                .map(Config::family),
            Some(Family::Broyden)
        );
    }

    /// The condition numbers: the extended cranes' do not depend on h, *subs*' grow.
    #[test]
    fn the_extended_cranes_condition_does_not_depend_on_h() {
        let rows = conditions().unwrap();
        for (name, values) in &rows {
            let growth = values.last().unwrap() / values.first().unwrap();
            if name.ends_with("ext") {
                assert!((growth - 1.0).abs() < 1e-9, "{name}: {values:?}");
            } else {
                assert!(growth > 1e4, "{name}: {values:?}");
            }
        }
    }
}
