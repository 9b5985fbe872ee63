//! `cargo xtask fig8`: the paper's Fig. 8(d, e) as a picture — the cost of every
//! 100 Hz cycle over the crane move under QEMU, BDF4 in (d), the Radau variants in (e).
//!
//! The paper plots computation time per step on its test bench. We have no board in
//! the loop, so we plot two things per cycle (the controller's whole tick with the
//! inverse-model step): what QEMU measures exactly, its instructions (`-icount`, the
//! firmware's `cost` lines, the same ones `qemu-bench` summarises), and what that
//! costs on the STM32H743 by estimate, µs at 480 MHz from [`cycles`]'s Cortex-M7
//! timing model (the point estimate; the CSV has the lower and upper bounds too).
//! The two come from two runs of the same deterministic firmware; every cycle's
//! instructions must agree between them within [`cycles::WINDOW_SLACK`].

use std::fmt::Write as _;
use std::path::Path;

use host_tests::plot::{figure, Chart, Legend, Scale, Series};
use host_tests::study::{jacobian_label, scheme_label};
use scene::dispatch::FirmwareModel;
use scene::SchemeSpec;

use crate::cycles::{self, CLOCK_MHZ};
use crate::firmware::StepCost;
use crate::qemu::{self, Measured};

/// The run of one scene as the figure needs it.
pub struct Trace<'a> {
    /// `BDF4 exact`, `Radau transformed`, … (the study's CSV labels), `3D …` for the
    /// crane in three dimensions.
    pub label: String,
    /// Whether the scheme is BDF (panel d) or Radau (panel e).
    pub bdf: bool,
    /// Step size, s: the time of cycle n is n·h.
    pub h: f64,
    /// When the load moves, s: `[t_start, t_start + duration)` of the trajectory.
    pub moving: (f64, f64),
    /// One entry per cycle, from the firmware's cost lines.
    pub steps: &'a [StepCost],
    /// The same cycles' estimated Cortex-M7 cycles, from the execution trace.
    pub estimated: &'a [cycles::Step],
}

/// Runs the firmware's scenes and `qemu-bench`'s under QEMU, once measured and once
/// traced for the cycle estimate, and writes `fig8-cost.csv` and `.svg` into `out`;
/// prints `qemu-bench`'s table of the same runs.
pub fn fig8(out: &Path) -> Result<(), String> {
    let scenes: Vec<&str> = qemu::feedforward_scenes().collect();
    let runs = scenes
        .iter()
        .map(|s| qemu::measure(s))
        .collect::<Result<Vec<_>, _>>()?;
    for m in &runs {
        complete(m)?;
    }
    let estimates = scenes
        .iter()
        .map(|s| cycles::estimate(s, None))
        .collect::<Result<Vec<_>, _>>()?;
    let traces = runs
        .iter()
        .zip(&estimates)
        .map(|(m, e)| trace(m, e))
        .collect::<Result<Vec<_>, _>>()?;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let csv_path = out.join("fig8-cost.csv");
    std::fs::write(&csv_path, csv(&traces)).map_err(|e| format!("{}: {e}", csv_path.display()))?;
    let series = |bdf: bool, y: fn(&Trace<'_>) -> Vec<(f64, f64)>| -> Vec<Series> {
        traces
            .iter()
            .filter(|t| t.bdf == bdf)
            .map(|t| Series {
                name: t.label.clone(),
                points: y(t),
            })
            .collect()
    };
    let us_title = |panel: &str| {
        format!(
            "Fig. 8{panel}, estimated Cortex-M7 µs per 100 Hz cycle at {CLOCK_MHZ:.0} MHz (point estimate)"
        )
    };
    let (us_d, us_e) = (us_title("(d): BDF4"), us_title("(e): Radau IIA"));
    figure(
        &out.join("fig8-cost.svg"),
        &[
            (
                Chart {
                    title: "Fig. 8(d): BDF4, QEMU instructions per 100 Hz cycle",
                    x_label: "t [s]",
                    y_label: "QEMU instructions per cycle",
                    x_scale: Scale::Linear,
                    y_scale: Scale::Linear,
                    legend: Legend::BelowData,
                },
                series(true, instruction_points),
            ),
            (
                Chart {
                    title: "Fig. 8(e): Radau IIA, QEMU instructions per 100 Hz cycle",
                    x_label: "t [s]",
                    y_label: "QEMU instructions per cycle (log)",
                    x_scale: Scale::Linear,
                    y_scale: Scale::Log,
                    legend: Legend::BelowData,
                },
                series(false, instruction_points),
            ),
            (
                Chart {
                    title: &us_d,
                    x_label: "t [s]",
                    y_label: "estimated µs per cycle",
                    x_scale: Scale::Linear,
                    y_scale: Scale::Linear,
                    legend: Legend::BelowData,
                },
                series(true, microsecond_points),
            ),
            (
                Chart {
                    title: &us_e,
                    x_label: "t [s]",
                    y_label: "estimated µs per cycle (log)",
                    x_scale: Scale::Linear,
                    y_scale: Scale::Log,
                    legend: Legend::BelowData,
                },
                series(false, microsecond_points),
            ),
        ],
        true,
    )?;
    eprintln!("wrote {} and fig8-cost.svg", csv_path.display());
    print!("{}", summary(&traces));
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

/// The measured run and the traced one of a scene, cycle by cycle; refused where the
/// two runs did not execute the same cycles.
fn trace<'a>(m: &'a Measured, e: &'a cycles::Estimate) -> Result<Trace<'a>, String> {
    let measured: Vec<u64> = m.steps.iter().map(|s| s.instructions).collect();
    let worst = cycles::check_windows(&m.stem(), &e.steps, &measured)?;
    eprintln!(
        "{}: every cycle's instructions agree within {} between the traced run and its own \
         cost lines, within {worst} between it and the measured run",
        m.stem(),
        e.worst_mismatch
    );
    Ok(Trace {
        label: format!(
            "{}{} {}",
            // The other cranes beside the paper's (the first registered), by their name
            // ("3D crane" → "3D ").
            match FirmwareModel::of(&m.scene.model) {
                Ok(model)
                    if Some(model.crane())
                        != FirmwareModel::every().next().map(FirmwareModel::crane) =>
                {
                    format!("{} ", model.crane_name().trim_end_matches(" crane"))
                }
                _ => String::new(),
            },
            scheme_label(&m.scene),
            jacobian_label(&m.scene)
        ),
        bdf: m.scene.solver.scheme == SchemeSpec::Bdf,
        h: m.scene.solver.h,
        moving: (
            m.scene.trajectory.t_start,
            m.scene.trajectory.t_start + m.scene.trajectory.duration,
        ),
        steps: &m.steps,
        estimated: &e.steps,
    })
}

/// `(t, instructions)` per cycle.
fn instruction_points(t: &Trace<'_>) -> Vec<(f64, f64)> {
    t.steps
        .iter()
        .map(|s| (f64::from(s.cycle) * t.h, s.instructions as f64))
        .collect()
}

/// `(t, estimated µs)` per cycle: the point estimate at [`CLOCK_MHZ`].
fn microsecond_points(t: &Trace<'_>) -> Vec<(f64, f64)> {
    t.steps
        .iter()
        .zip(t.estimated)
        .map(|(s, e)| (f64::from(s.cycle) * t.h, microseconds(e.cycles[1])))
        .collect()
}

fn microseconds(cycles: u64) -> f64 {
    cycles as f64 / CLOCK_MHZ
}

/// Mean and maximum of the cycles while the load moves and while it rests: QEMU
/// instructions and estimated µs (point estimate), then the upper bound's maximum in µs
/// and the point estimate's cycles per instruction over the whole run.
pub fn summary(traces: &[Trace<'_>]) -> String {
    let mut out = format!(
        "\nPer 100 Hz cycle, mean / max, while the load moves and at rest (before and after \
         the move); µs: the Cortex-M7 point estimate at {CLOCK_MHZ:.0} MHz, then the upper \
         bound's maximum and the point estimate's cycles per instruction over the whole run:\n\n\
         | solver | instructions, moving | instructions, at rest | µs, moving | µs, at rest | µs upper bound, max | cycles per instruction |\n\
         |---|---:|---:|---:|---:|---:|---:|\n",
    );
    for t in traces {
        // (instructions, point-estimate cycles) of each cycle, moving or at rest. Cycle n
        // is the step that starts at t = n·h; it is moving if that start lies in
        // [t_start, t_start + duration), a tenth of a step of slack against the rounding
        // of n·h.
        let (mut moving, mut resting) = (Vec::new(), Vec::new());
        for (s, e) in t.steps.iter().zip(t.estimated) {
            let time = f64::from(s.cycle) * t.h;
            let inside = time >= t.moving.0 - 0.1 * t.h && time < t.moving.1 - 0.1 * t.h;
            let part = if inside { &mut moving } else { &mut resting };
            part.push((s.instructions, e.cycles[1]));
        }
        let instructions = |p: &[(u64, u64)]| mean_max_cell(p.iter().map(|c| c.0 as f64), 0);
        let us = |p: &[(u64, u64)]| mean_max_cell(p.iter().map(|c| microseconds(c.1)), 1);
        let upper = t.estimated.iter().map(|e| e.cycles[2]).max().unwrap_or(0);
        let all = moving.iter().chain(&resting);
        let per_instruction = all.clone().map(|c| c.1).sum::<u64>() as f64
            / all.map(|c| c.0).sum::<u64>().max(1) as f64;
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {:.1} | {per_instruction:.2} |",
            t.label,
            instructions(&moving),
            instructions(&resting),
            us(&moving),
            us(&resting),
            microseconds(upper)
        );
    }
    out
}

/// `mean / max` with `digits` decimals, `—` for no values.
fn mean_max_cell(values: impl Iterator<Item = f64>, digits: usize) -> String {
    let values: Vec<f64> = values.collect();
    if values.is_empty() {
        return "—".into();
    }
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    let max = values.iter().copied().fold(f64::MIN, f64::max);
    format!("{mean:.digits$} / {max:.digits$}")
}

/// One row per cycle and solver (t in ms resolution: `0.35`, not `0.35000000000000003`),
/// with the estimated Cortex-M7 cycles (lower bound, point estimate, upper bound) and
/// the point estimate in µs.
pub fn csv(traces: &[Trace<'_>]) -> String {
    let mut out = String::from(
        "solver,cycle,t,instructions,newton_iterations,jacobians,\
         m7_cycles_lower,m7_cycles_point,m7_cycles_upper,m7_us_point\n",
    );
    for t in traces {
        for (s, e) in t.steps.iter().zip(t.estimated) {
            let [lower, point, upper] = e.cycles;
            let _ = writeln!(
                out,
                "{},{},{:.3},{},{},{},{lower},{point},{upper},{:.2}",
                t.label,
                s.cycle,
                f64::from(s.cycle) * t.h,
                s.instructions,
                s.iterations,
                s.jacobians,
                microseconds(point)
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
                solver: 5000,
            },
            StepCost {
                cycle: 2,
                instructions: 8000,
                iterations: 2,
                jacobians: 2,
                solver: 5000,
            },
        ];
        let estimated = [
            cycles::Step {
                instructions: 7000,
                cycles: [5000, 9600, 14000],
            },
            cycles::Step {
                instructions: 8000,
                cycles: [6000, 12000, 16000],
            },
        ];
        let traces = [Trace {
            label: "BDF4 exact".into(),
            bdf: true,
            h: 0.01,
            moving: (0.02, 1.0),
            steps: &steps,
            estimated: &estimated,
        }];
        let text = csv(&traces);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3, "{text}");
        assert_eq!(
            lines[2],
            "BDF4 exact,2,0.020,8000,2,2,6000,12000,16000,25.00"
        );
        assert_eq!(
            instruction_points(&traces[0]),
            [(0.01, 7000.0), (0.02, 8000.0)]
        );
        assert_eq!(microsecond_points(&traces[0]), [(0.01, 20.0), (0.02, 25.0)]);
        // Cycle 1 (t = 0.01 s) is before the move, cycle 2 (t = 0.02 s) in it.
        let table = summary(&traces);
        assert!(
            table.contains("| BDF4 exact | 8000 / 8000 | 7000 / 7000 | 25.0 / 25.0 | 20.0 / 20.0 | 33.3 | 1.44 |"),
            "{table}"
        );
    }

    /// The move's end is open: the cycle that starts as the move ends is at rest; a part
    /// with no cycles says so rather than printing a number.
    #[test]
    fn the_summary_splits_at_the_moves_open_end_and_marks_an_empty_part() {
        let steps = [1, 2].map(|cycle| StepCost {
            cycle,
            instructions: 1000 * u64::from(cycle),
            iterations: 1,
            jacobians: 0,
            solver: 500,
        });
        let estimated = [1, 2].map(|c: u64| cycles::Step {
            instructions: 1000 * c,
            cycles: [0, 4800 * c, 0],
        });
        let trace = |moving| Trace {
            label: "Radau transformed".into(),
            bdf: false,
            h: 0.01,
            moving,
            steps: &steps,
            estimated: &estimated,
        };
        let table = summary(&[trace((0.01, 0.02))]);
        assert!(
            table.contains("| 1000 / 1000 | 2000 / 2000 | 10.0 / 10.0 | 20.0 / 20.0 |"),
            "{table}"
        );
        let table = summary(&[trace((5.0, 6.0))]);
        assert!(
            table.contains("| Radau transformed | — | 1500 / 2000 | — | 15.0 / 20.0 |"),
            "{table}"
        );
    }
}
