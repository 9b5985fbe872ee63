//! `cargo xtask fig8`: the paper's Fig. 8(d, e) as a picture — the cost of every
//! 100 Hz cycle over the crane move under QEMU, BDF4 in (d), the Radau variants in (e).
//!
//! The paper plots computation time per step on its test bench; we plot what the QEMU
//! run measures: QEMU instructions per cycle (`-icount`, the controller's whole tick
//! with the inverse-model step), not Cortex-M7 cycles and not time. The counts come
//! from the firmware's `cost` lines, the same ones `qemu-bench` summarises.

use std::fmt::Write as _;
use std::path::Path;

use host_tests::plot::{figure, Chart, Scale, Series};
use host_tests::study::{jacobian_label, scheme_label};
use scene::SchemeSpec;

use crate::firmware::StepCost;
use crate::qemu::{self, Measured};

/// The run of one scene as the figure needs it.
pub struct Trace<'a> {
    /// `BDF4 exact`, `Radau transformed`, … (the study's CSV labels).
    pub label: String,
    /// Whether the scheme is BDF (panel d) or Radau (panel e).
    pub bdf: bool,
    /// Step size, s: the time of cycle n is n·h.
    pub h: f64,
    /// One entry per cycle.
    pub steps: &'a [StepCost],
}

/// Runs the firmware's scenes and `qemu-bench`'s under QEMU and writes
/// `fig8-instructions.csv` and `.svg` into `out`; prints `qemu-bench`'s table of the
/// same runs.
pub fn fig8(out: &Path) -> Result<(), String> {
    let runs = qemu::SCENES
        .iter()
        .chain(&qemu::BENCH_ONLY_SCENES)
        .map(|s| qemu::measure(s))
        .collect::<Result<Vec<_>, _>>()?;
    for m in &runs {
        complete(m)?;
    }
    let traces: Vec<Trace<'_>> = runs.iter().map(trace).collect();
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let csv_path = out.join("fig8-instructions.csv");
    std::fs::write(&csv_path, csv(&traces)).map_err(|e| format!("{}: {e}", csv_path.display()))?;
    let series = |bdf: bool| -> Vec<Series> {
        traces
            .iter()
            .filter(|t| t.bdf == bdf)
            .map(|t| Series {
                name: t.label.clone(),
                points: points(t),
            })
            .collect()
    };
    figure(
        &out.join("fig8-instructions.svg"),
        &[
            (
                Chart {
                    title: "Fig. 8(d): BDF4, QEMU instructions per 100 Hz cycle",
                    x_label: "t [s]",
                    y_label: "QEMU instructions per cycle",
                    x_scale: Scale::Linear,
                    y_scale: Scale::Linear,
                },
                series(true),
            ),
            (
                Chart {
                    title: "Fig. 8(e): Radau IIA, QEMU instructions per 100 Hz cycle",
                    x_label: "t [s]",
                    y_label: "QEMU instructions per cycle (log)",
                    x_scale: Scale::Linear,
                    y_scale: Scale::Log,
                },
                series(false),
            ),
        ],
        true,
    )?;
    eprintln!("wrote {} and fig8-instructions.svg", csv_path.display());
    print!("{}", qemu::table(&runs));
    Ok(())
}

/// A run that faulted or stopped early would draw a different move than the scene's.
fn complete(m: &Measured) -> Result<(), String> {
    if !m.success {
        return Err(format!(
            "{}: the firmware did not exit with success",
            m.stem()
        ));
    }
    if m.steps.len() != m.scene.steps() {
        return Err(format!(
            "{}: {} cycles logged, the scene has {}",
            m.stem(),
            m.steps.len(),
            m.scene.steps()
        ));
    }
    Ok(())
}

fn trace(m: &Measured) -> Trace<'_> {
    Trace {
        label: format!("{} {}", scheme_label(&m.scene), jacobian_label(&m.scene)),
        bdf: m.scene.solver.scheme == SchemeSpec::Bdf,
        h: m.scene.solver.h,
        steps: &m.steps,
    }
}

/// `(t, instructions)` per cycle.
fn points(t: &Trace<'_>) -> Vec<(f64, f64)> {
    t.steps
        .iter()
        .map(|s| (f64::from(s.cycle) * t.h, s.instructions as f64))
        .collect()
}

/// One row per cycle and solver (t in ms resolution: `0.35`, not `0.35000000000000003`).
pub fn csv(traces: &[Trace<'_>]) -> String {
    let mut out = String::from("solver,cycle,t,instructions,newton_iterations,jacobians\n");
    for t in traces {
        for s in t.steps {
            let _ = writeln!(
                out,
                "{},{},{:.3},{},{},{}",
                t.label,
                s.cycle,
                f64::from(s.cycle) * t.h,
                s.instructions,
                s.iterations,
                s.jacobians
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_row_per_cycle_and_solver_with_its_time() {
        let steps = [
            StepCost {
                cycle: 1,
                instructions: 7000,
                iterations: 2,
                jacobians: 2,
            },
            StepCost {
                cycle: 2,
                instructions: 8000,
                iterations: 2,
                jacobians: 2,
            },
        ];
        let traces = [Trace {
            label: "BDF4 exact".into(),
            bdf: true,
            h: 0.01,
            steps: &steps,
        }];
        let text = csv(&traces);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3, "{text}");
        assert_eq!(lines[2], "BDF4 exact,2,0.020,8000,2,2");
        assert_eq!(points(&traces[0]), [(0.01, 7000.0), (0.02, 8000.0)]);
    }
}
