//! `cargo xtask instructions`: host instructions per step under valgrind's callgrind —
//! a deterministic measure beside criterion's times (issue 11, "Measure it so that
//! anyone can repeat it").
//!
//! The release build of `host-tests`' `steps` program steps the paper's crane move
//! (`scenes/paper-crane.toml`, 10 s) from rest; callgrind collects only inside its
//! never-inlined `measured_step_*` functions (`--toggle-collect`), so the setup is not
//! counted and instructions per step = `Collected` / steps. These are x86-64
//! instructions of this host's default release build (LTO, no `target-cpu`), not
//! times and not Cortex-M7 cycles. The firmware's solvers are counted on the bare move
//! and on the firmware's trajectory type (`Plan`), which holds the same move; the 3D
//! crane's (issue 19) on its diagonal move (`scenes/crane3d-diagonal.toml`).

use std::path::PathBuf;
use std::process::Command;

use crate::firmware::root;
use crate::{cargo, run, setup};

/// The scene the planar configurations are measured on: the paper's crane move.
pub const SCENE: &str = "scenes/paper-crane.toml";

/// The scene the 3D crane's configurations are measured on: its diagonal move.
pub const SCENE_3D: &str = "scenes/crane3d-diagonal.toml";

/// The step sizes: the test bench's 10 ms, and 1 ms (where Radau is 30× more accurate).
pub const STEP_SIZES: [&str; 2] = ["0.01", "0.001"];

/// The solver configurations, as `(label, settings for `steps`)`: BDF4 with the exact
/// Jacobian on the dense LU (the paper's studies) and by the *subs* model's structured
/// elimination (the firmware's), Radau with the exact Jacobian, the paper's test-bench
/// Radau (J̃₁₀), and RADAU5's transformed simplified Newton on dense LUs (the studies')
/// and by the structured elimination (the firmware's). The firmware's two solvers are
/// measured twice: on the bare move (`PointToPoint`, as the studies drive the model) and
/// on the firmware's trajectory type, a `Plan` holding the same move — what the MCU
/// steps on (issue 20: the plan once cost 28 % more per step than the move it holds).
/// The *ext* rows are the minimally extended formulations (issue 30) with the firmware's
/// structured Newton, each step from the closed form.
pub const CONFIGURATIONS: [(&str, &str, &[&str]); 15] = [
    ("BDF4 exact", SCENE, &["scheme=bdf4", "jacobian=exact"]),
    (
        "BDF4 exact, structured",
        SCENE,
        &["scheme=bdf4", "newton=structured"],
    ),
    (
        "BDF4 exact, structured, Plan",
        SCENE,
        &["scheme=bdf4", "newton=structured", "trajectory=plan"],
    ),
    ("Radau exact", SCENE, &["scheme=radau", "jacobian=exact"]),
    ("Radau J̃₁₀", SCENE, &["scheme=radau", "jacobian=jt10"]),
    (
        "Radau transformed",
        SCENE,
        &["scheme=radau", "jacobian=transformed"],
    ),
    (
        "Radau transformed, structured",
        SCENE,
        &["scheme=radau", "jacobian=transformed", "newton=structured"],
    ),
    (
        "Radau transformed, structured, Plan",
        SCENE,
        &[
            "scheme=radau",
            "jacobian=transformed",
            "newton=structured",
            "trajectory=plan",
        ],
    ),
    (
        "3D BDF4 exact, structured",
        SCENE_3D,
        &["scheme=bdf4", "newton=structured"],
    ),
    (
        "3D Radau transformed, structured",
        SCENE_3D,
        &["scheme=radau", "jacobian=transformed", "newton=structured"],
    ),
    (
        "ext BDF4 exact, structured",
        SCENE,
        &["formulation=ext", "scheme=bdf4", "newton=structured"],
    ),
    (
        "ext BDF4 exact, structured, Plan",
        SCENE,
        &[
            "formulation=ext",
            "scheme=bdf4",
            "newton=structured",
            "trajectory=plan",
        ],
    ),
    (
        "ext Radau transformed, structured",
        SCENE,
        &[
            "formulation=ext",
            "scheme=radau",
            "jacobian=transformed",
            "newton=structured",
        ],
    ),
    (
        "3D ext BDF4 exact, structured",
        SCENE_3D,
        &["formulation=ext", "scheme=bdf4", "newton=structured"],
    ),
    (
        "3D ext Radau transformed, structured",
        SCENE_3D,
        &[
            "formulation=ext",
            "scheme=radau",
            "jacobian=transformed",
            "newton=structured",
        ],
    ),
];

/// One configuration at one step size, counted.
#[derive(Debug, Clone, PartialEq)]
pub struct Count {
    /// Instructions collected inside the steps.
    pub collected: u64,
    /// Steps taken.
    pub steps: u64,
    /// Newton iterations over all steps.
    pub iterations: u64,
}

impl Count {
    /// Instructions per step.
    pub fn per_step(&self) -> f64 {
        self.collected as f64 / self.steps as f64
    }
}

/// Checks for valgrind and builds `steps` (release): the program callgrind counts, for
/// this command and `cargo xtask trade`. Its path.
pub(crate) fn build_steps() -> Result<PathBuf, String> {
    setup::ensure_valgrind()?;
    run(cargo().current_dir(root()).args([
        "build",
        "--release",
        "--quiet",
        "-p",
        "host-tests",
        "--bin",
        "steps",
    ]))?;
    Ok(root().join("target/release/steps"))
}

/// Builds `steps`, counts every configuration at every step size and prints the table.
pub fn instructions() -> Result<(), String> {
    let program = build_steps()?;
    let mut rows = Vec::new();
    for (label, scene, settings) in CONFIGURATIONS {
        let counts = STEP_SIZES
            .iter()
            .map(|h| count(&program, scene, settings, h))
            .collect::<Result<Vec<_>, _>>()?;
        rows.push((label, counts));
    }
    print!("{}", table(&rows));
    Ok(())
}

/// Runs `steps` under callgrind for one configuration and step size.
pub(crate) fn count(
    program: &PathBuf,
    scene: &str,
    settings: &[&str],
    h: &str,
) -> Result<Count, String> {
    // callgrind's profile is not used (the totals are on standard error); it is
    // written to the temporary directory, not into the work tree.
    let profile = std::env::temp_dir().join(format!("callgrind.steps.{}", std::process::id()));
    let mut cmd = Command::new("valgrind");
    cmd.current_dir(root())
        .args(["--tool=callgrind", "--toggle-collect=*measured_step*"])
        .arg(format!("--callgrind-out-file={}", profile.display()))
        .arg(program)
        .arg(scene)
        .args(settings)
        .arg(format!("h={h}"));
    eprintln!("$ valgrind … steps {scene} {} h={h}", settings.join(" "));
    let output = cmd
        .output()
        .map_err(|e| format!("cannot start valgrind: {e}"))?;
    let _ = std::fs::remove_file(&profile);
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    if !output.status.success() {
        return Err(format!(
            "steps {} h={h} failed under callgrind ({}):\n{stdout}{stderr}",
            settings.join(" "),
            output.status
        ));
    }
    parse(&stdout, &stderr)
}

/// Reads the steps and Newton iterations `steps` printed and callgrind's `Collected`.
/// Refuses a run that counted nothing or stepped zero times: a per-step figure from
/// either would be meaningless (the toggle pattern no longer matching, say, after a
/// rename, gives `Collected : 0`).
pub fn parse(stdout: &str, stderr: &str) -> Result<Count, String> {
    let after = |text: &str, key: &str| -> Option<u64> {
        text.split(key)
            .nth(1)?
            .trim_start_matches([' ', ':'])
            .split(|c: char| !c.is_ascii_digit())
            .next()?
            .parse()
            .ok()
    };
    let collected = stderr
        .lines()
        .find_map(|l| l.contains("Collected").then(|| after(l, "Collected"))?)
        .ok_or_else(|| format!("no `Collected` count in callgrind's output:\n{stderr}"))?;
    let steps = after(stdout, "steps ")
        .ok_or_else(|| format!("no step count in the program's output: {stdout}"))?;
    let iterations = after(stdout, "Newton iterations ").unwrap_or(0);
    if collected == 0 || steps == 0 {
        return Err(format!(
            "callgrind collected {collected} instructions in {steps} steps: the toggle \
             pattern `*measured_step*` matched no function, or nothing was stepped"
        ));
    }
    Ok(Count {
        collected,
        steps,
        iterations,
    })
}

/// The Markdown table: instructions per step and Newton iterations per step.
pub fn table(rows: &[(&str, Vec<Count>)]) -> String {
    let mut out = String::from(
        "\nHost instructions per step (valgrind callgrind, x86-64 release build; not time, not Cortex-M7 cycles),\n\
         the paper's crane move (scenes/paper-crane.toml, 10 s from rest), setup excluded; *Plan*: the model\n\
         driven by the firmware's trajectory type holding the same move, not the bare move; *3D*: the crane in\n\
         three dimensions on its diagonal move (scenes/crane3d-diagonal.toml, 9 s from rest); *ext*: the minimally\n\
         extended formulation (index 1):\n\n\
         | instructions per step | h = 10 ms | Newton iterations / step | h = 1 ms | Newton iterations / step |\n\
         |---|---:|---:|---:|---:|\n",
    );
    for (label, counts) in rows {
        out += &format!("| {label} |");
        for c in counts {
            out += &format!(
                " {} | {:.2} |",
                thousands(c.per_step().round() as u64),
                c.iterations as f64 / c.steps as f64
            );
        }
        out.push('\n');
    }
    out
}

/// `12345` → `12,345`.
fn thousands(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, ch) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const STDERR: &str = "==4242== Callgrind, a call-graph generating cache profiler\n\
                          ==4242== Events    : Ir\n\
                          ==4242== Collected : 8624000\n\
                          ==4242== \n\
                          ==4242== I   refs:      10,108,467\n";

    #[test]
    fn callgrind_totals_are_read() {
        let c = parse(
            "Radau transformed h = 0.01: steps 1000, Newton iterations 2440\n",
            STDERR,
        )
        .unwrap();
        assert_eq!(
            c,
            Count {
                collected: 8_624_000,
                steps: 1000,
                iterations: 2440
            }
        );
        assert_eq!(c.per_step(), 8624.0);
    }

    #[test]
    fn nothing_collected_is_refused_not_reported_as_zero() {
        let e = parse(
            "BDF4 exact h = 0.01: steps 1000, Newton iterations 2000\n",
            &STDERR.replace("8624000", "0"),
        )
        .unwrap_err();
        assert!(e.contains("matched no function"), "{e}");
        assert!(parse("", STDERR).is_err());
        assert!(parse("steps 10", "no totals").is_err());
    }

    #[test]
    fn the_table_has_a_row_per_configuration() {
        let c = Count {
            collected: 4_325_000,
            steps: 1000,
            iterations: 2000,
        };
        let t = table(&[("BDF4 exact", vec![c.clone(), c])]);
        assert!(
            t.contains("| BDF4 exact | 4,325 | 2.00 | 4,325 | 2.00 |"),
            "{t}"
        );
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1_000), "1,000");
    }
}
