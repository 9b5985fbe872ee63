//! The QEMU checks: golden output, the host's computation of the same scene on the
//! same virtual bus and scenario, committed baselines (instructions per step, flash,
//! RAM, stack), and the table.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use controller::canopen::cob;
use host_tests::dbc::Dbc;
use host_tests::firmware::controller_reference;
use object::{Object, ObjectSection};
use scene::commissioning::CommissioningFile;
use scene::dispatch::FirmwareModel;
use scene::Scene;
use sim::{Scenario, HEALTHY};

use crate::firmware::{self, parse_cost, parse_tx, readable_log, root, Board, StepCost};

/// The scenes the firmware is checked on, on the healthy bus: each registered crane's
/// `FirmwareCrane::QEMU_SCENES`, listed in its own file under `scene/src/cranes/`, crane
/// by crane in the order registered (`scene::dispatch::qemu_scenes`). First the default
/// scene ([`host_tests::DEFAULT_SCENE`], the planar crane's), on which the scenarios run.
/// `scene/tests/scenes.rs` checks that each is its crane's and the default scene comes
/// first.
#[must_use]
pub fn scenes() -> Vec<&'static str> {
    scene::dispatch::qemu_scenes()
}

/// The paper's scene (Tab. 3's move, *subs*, BDF4 with the exact Jacobian at 10 ms): the
/// planar crane's firmware whose model is visible by name in its symbols (the *ext*
/// model of the default scene is inlined whole), so the check that a firmware links its
/// own crane's model and not the other's is made on it.
pub const PAPER_SCENE: &str = "scenes/paper-crane.toml";

/// The 3D crane's default scene, on which its scenarios run (`sim::CRANE3D_SCENARIOS`).
pub const CRANE3D_SCENE: &str = "scenes/crane3d/crane3d.toml";

/// The 3D crane's scene with the state feedback per vertical plane: checked on its
/// scenarios (`sim::CRANE3D_FEEDBACK_SCENARIOS`: the 3D plant and the two-axis
/// inclinometer), measured by `qemu-bench` on the first.
pub const CRANE3D_FEEDBACK_SCENE: &str = "scenes/crane3d/crane3d-feedback.toml";

/// Scenes `qemu-bench` measures beside [`scenes`], with no golden log or baseline:
/// other solver configurations a user may choose for the MCU, among them the paper's
/// test-bench Radau (J̃10, Fig. 8e).
pub const BENCH_ONLY_SCENES: [&str; 2] = [
    "scenes/paper-crane-radau.toml",
    "scenes/paper-crane-radau-exact.toml",
];

/// The feedforward scenes `qemu-bench` measures on the healthy bus, in its table's
/// order: [`scenes`], then [`BENCH_ONLY_SCENES`].
pub fn feedforward_scenes() -> impl Iterator<Item = &'static str> {
    scenes().into_iter().chain(BENCH_ONLY_SCENES)
}

/// The scene with the state feedback (Fig. 1): checked on the feedback scenarios of the
/// virtual bus (`sim::FEEDBACK_SCENARIOS`, a plant that is not the
/// model and an inclinometer), measured by `qemu-bench` on the first of them.
pub const FEEDBACK_SCENE: &str = "scenes/paper-crane-feedback.toml";

/// The planar crane's scene with manual mode (`[operator]`): checked on its scenarios
/// (`sim::MANUAL_SCENARIOS`, the virtual bus playing the operator's master switch),
/// measured by `qemu-bench` on the first.
pub const MANUAL_SCENE: &str = "scenes/paper-crane-manual.toml";

/// The 3D crane's scene with manual mode: checked on `sim::MANUAL_3D_SCENARIOS`,
/// measured by `qemu-bench` on the first.
pub const CRANE3D_MANUAL_SCENE: &str = "scenes/crane3d/crane3d-manual.toml";

/// `<scene>` for the healthy bus, `<scene>--<scenario>` otherwise: the name of a run's
/// golden log and baseline (`--only` selects runs by it).
#[must_use]
pub fn stem(scene: &Path, scenario: &Scenario) -> String {
    let scene = scene
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scene");
    if scenario.name == HEALTHY.name {
        scene.to_string()
    } else {
        format!("{scene}--{}", scenario.name)
    }
}

/// Wall-clock limit for one QEMU run: 10 minutes, and a minute more per 100,000 cycles.
fn qemu_limit(scenario: &Scenario) -> Duration {
    Duration::from_secs(600 + u64::from(scenario.cycles) / 100_000 * 60)
}

/// The default scene, on which every scenario of the virtual bus runs.
pub const SCENARIO_SCENE: &str = host_tests::DEFAULT_SCENE;

/// A finished QEMU run of one scene with everything measured about it.
pub struct Measured {
    /// The scene.
    pub scene: Scene,
    /// Its file.
    pub path: PathBuf,
    /// The virtual bus's scenario.
    pub scenario: Scenario,
    /// The decoded log.
    pub lines: Vec<String>,
    /// Whether the firmware exited with success.
    pub success: bool,
    /// Instructions per step, one per cycle.
    pub costs: Vec<u64>,
    /// Everything logged about each step's cost.
    pub steps: Vec<StepCost>,
    /// Flash and static RAM, bytes.
    pub sizes: Sizes,
    /// Stack high-water mark from stack painting since boot, bytes.
    pub stack: u64,
    /// The same since the control task started: its own frames (and the interrupts'),
    /// without the init-time frame that builds the RTIC resources.
    pub task_stack: u64,
    /// The solver's share of the flash, bytes: this firmware's flash minus that of the
    /// same firmware built with the inverse model stubbed out
    /// ([`firmware::build_without_inverse_model`]). Measured for the healthy bus only.
    pub solver_flash: Option<u64>,
}

/// Builds and runs `scene` on the QEMU board with the healthy bus, and measures the
/// solver's share of its flash.
pub fn measure(scene: &str) -> Result<Measured, String> {
    measure_with_solver_flash(scene, HEALTHY)
}

/// [`measure_scenario`], and the solver's share of the flash (the same firmware built
/// with the inverse model stubbed out).
pub fn measure_with_solver_flash(scene: &str, scenario: Scenario) -> Result<Measured, String> {
    let mut m = measure_scenario(scene, scenario)?;
    let stub = sizes(&firmware::build_without_inverse_model(&root().join(scene))?)?;
    m.solver_flash = Some(m.sizes.flash.saturating_sub(stub.flash));
    Ok(m)
}

/// Builds and runs `scene` on the QEMU board with `scenario` on the virtual bus.
pub fn measure_scenario(scene: &str, scenario: Scenario) -> Result<Measured, String> {
    let path = root().join(scene);
    let parsed = Scene::load(&path).map_err(|e| format!("{scene}: {e}"))?;
    let elf = firmware::build(Board::Qemu, &path)?;
    let run = firmware::run_qemu(&elf, &scenario, qemu_limit(&scenario))?;
    let steps: Vec<StepCost> = run.lines.iter().filter_map(|l| parse_cost(l)).collect();
    let costs = steps.iter().map(|c| c.instructions).collect();
    let reported = |label: &str| {
        run.lines.iter().find_map(|l| {
            l.split(label)
                .nth(1)
                .and_then(|r| r.split(' ').next())
                .and_then(|n| n.parse().ok())
        })
    };
    let missing = || format!("{scene}: no stack report in the log (did the run finish?)");
    let stack = reported(", stack ").ok_or_else(missing)?;
    let task_stack = reported("control task ").ok_or_else(missing)?;
    Ok(Measured {
        scene: parsed,
        path,
        scenario,
        lines: run.lines,
        success: run.success,
        costs,
        steps,
        sizes: sizes(&elf)?,
        stack,
        task_stack,
        solver_flash: None,
    })
}

/// Flash and static RAM of an ELF.
#[derive(Debug, Clone, Copy)]
pub struct Sizes {
    /// Code, constants, vector table and the initial values of `.data`.
    pub flash: u64,
    /// `.data`, `.bss` and `.uninit`.
    pub ram: u64,
}

/// Reads the section sizes of an ELF.
pub fn sizes(elf: &Path) -> Result<Sizes, String> {
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*bytes).map_err(|e| format!("{}: {e}", elf.display()))?;
    let (mut flash, mut ram) = (0, 0);
    for section in file.sections() {
        let size = section.size();
        match section.name().unwrap_or("") {
            ".vector_table" | ".text" | ".rodata" => flash += size,
            ".data" => {
                flash += size;
                ram += size;
            }
            ".bss" | ".uninit" => ram += size,
            _ => {}
        }
    }
    Ok(Sizes { flash, ram })
}

impl Measured {
    /// `<scene>` for the healthy bus, `<scene>--<scenario>` otherwise: the name of the
    /// golden log and the baseline.
    pub fn stem(&self) -> String {
        stem(&self.path, &self.scenario)
    }

    /// Cycles the run must log: the scenario's, or the scene's; a scenario that hangs
    /// the firmware logs the cycles before the hang, then a whole run after the
    /// watchdog's restart.
    fn cycles(&self) -> usize {
        let run = if self.scenario.cycles == 0 {
            self.scene.steps()
        } else {
            self.scenario.cycles as usize
        };
        let period_ms = (self.scene.solver.h * 1000.0).round() as usize;
        let before_hang = self
            .scenario
            .hang_at_ms()
            .map_or(0, |ms| (ms as usize).div_ceil(period_ms.max(1)));
        before_hang + run
    }

    /// (min, mean, max) instructions per step.
    pub fn cost_summary(&self) -> (u64, u64, u64) {
        let n = self.costs.len().max(1) as u64;
        let min = self.costs.iter().copied().min().unwrap_or(0);
        let max = self.costs.iter().copied().max().unwrap_or(0);
        (min, self.costs.iter().sum::<u64>() / n, max)
    }

    /// (mean, max) QEMU instructions of the inverse model's step alone, over the cycles
    /// that stepped it (`None` if none did).
    pub fn solver_summary(&self) -> Option<(u64, u64)> {
        let stepped: Vec<u64> = self
            .steps
            .iter()
            .map(|s| s.solver)
            .filter(|&s| s > 0)
            .collect();
        let n = stepped.len() as u64;
        let max = stepped.iter().copied().max()?;
        Some((stepped.iter().sum::<u64>() / n, max))
    }

    fn baseline_values(&self) -> BTreeMap<&'static str, u64> {
        let (_, mean, max) = self.cost_summary();
        let (solver_mean, solver_max) = self.solver_summary().unwrap_or((0, 0));
        BTreeMap::from([
            ("flash_bytes", self.sizes.flash),
            ("instructions_per_step_max", max),
            ("instructions_per_step_mean", mean),
            ("solver_instructions_per_step_max", solver_max),
            ("solver_instructions_per_step_mean", solver_mean),
            ("stack_bytes", self.stack),
            ("control_task_stack_bytes", self.task_stack),
            ("static_ram_bytes", self.sizes.ram),
        ])
    }
}

/// Checks a run against the golden log, the host's set points and the baselines;
/// `overwrite` refreshes the committed files instead.
pub fn check(m: &Measured, overwrite: bool) -> Result<(), String> {
    if !m.success {
        return Err(format!(
            "{}: the firmware did not exit with success",
            m.stem()
        ));
    }
    if m.costs.len() != m.cycles() {
        return Err(format!(
            "{}: {} cycles logged, the run has {}",
            m.stem(),
            m.costs.len(),
            m.cycles()
        ));
    }
    compare_with_host(m)?;
    let dbc = Dbc::crane()?;
    let log = readable_log(&m.lines, &dbc).join("\n") + "\n";
    let golden = root()
        .join("firmware/expected")
        .join(format!("{}.run", m.stem()));
    let baseline = root()
        .join("firmware/baselines")
        .join(format!("{}.qemu", m.stem()));
    if overwrite {
        write(&golden, &log)?;
        write(&baseline, &baseline_text(&m.baseline_values()))?;
        eprintln!("refreshed {} and {}", golden.display(), baseline.display());
        return Ok(());
    }
    let expected = std::fs::read_to_string(&golden).map_err(|e| {
        format!(
            "{}: {e} (create it with `cargo xtask qemu --overwrite-expected`)",
            golden.display()
        )
    })?;
    if expected != log {
        let first = expected
            .lines()
            .zip(log.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(expected.lines().count().min(log.lines().count()));
        return Err(format!(
            "{}: QEMU output differs from {} at line {}:\n  expected: {}\n  got:      {}\n(refresh deliberately with `cargo xtask qemu --overwrite-expected`)",
            m.stem(),
            golden.display(),
            first + 1,
            expected.lines().nth(first).unwrap_or("<end>"),
            log.lines().nth(first).unwrap_or("<end>")
        ));
    }
    check_baseline(&baseline, &m.baseline_values())
}

/// The firmware computes what the tests proved: every frame equals the host's run of
/// the same scene on the same virtual bus and scenario; set points may differ by one
/// drive unit (1 µm/s).
pub fn compare_with_host(m: &Measured) -> Result<(), String> {
    let commissioning = CommissioningFile::for_scene(&m.path).map_err(|e| e.to_string())?;
    let reference = controller_reference(&m.scene, &commissioning, &m.scenario)?;
    let expected: Vec<(u32, u16, Vec<u8>)> = reference
        .iter()
        .flat_map(|c| {
            c.frames
                .iter()
                .map(move |f| (c.now_ms, f.id(), f.data().to_vec()))
        })
        .collect();
    let got: Vec<(u32, u16, Vec<u8>)> = m
        .lines
        .iter()
        .filter_map(|l| parse_tx(l))
        .map(|t| (t.now_ms, t.id, t.data))
        .collect();
    if expected.len() != got.len() {
        return Err(format!(
            "{}: QEMU sent {} frames, the host computes {}",
            m.stem(),
            got.len(),
            expected.len()
        ));
    }
    let mut worst = 0i64;
    for ((t0, id0, d0), (t1, id1, d1)) in expected.iter().zip(&got) {
        // A drive's set point (RPDO1 of a drive node: 6 bytes, controlword and 0x60FF).
        let rpdo = (cob::RPDO1 + 1..=cob::RPDO1 + 0x7F).contains(id0) && d0.len() == 6;
        let same_frame = t0 == t1 && id0 == id1 && d0.len() == d1.len();
        if rpdo && same_frame && d0.get(..2) == d1.get(..2) {
            let v = |d: &[u8]| i64::from(i32::from_le_bytes([d[2], d[3], d[4], d[5]]));
            let diff = (v(d0) - v(d1)).abs();
            worst = worst.max(diff);
            if diff <= 1 {
                continue;
            }
        }
        if !(same_frame && d0 == d1) {
            return Err(format!(
                "{}: at {t1} ms QEMU sent {id1:#05x} {d1:02x?}, the host computes {id0:#05x} {d0:02x?} at {t0} ms",
                m.stem()
            ));
        }
    }
    eprintln!(
        "{}: {} frames equal to the host's computation (set points within {worst} µm/s)",
        m.stem(),
        got.len()
    );
    Ok(())
}

fn baseline_text(values: &BTreeMap<&str, u64>) -> String {
    let mut text = String::from(
        "# QEMU mps2-an500, -icount shift=7: instructions are QEMU instructions, not Cortex-M7 cycles.\n\
         # A regression of more than 10 % fails `cargo xtask test`; refresh with `cargo xtask qemu --overwrite-expected`.\n",
    );
    for (k, v) in values {
        text += &format!("{k} = {v}\n");
    }
    text
}

fn check_baseline(path: &Path, values: &BTreeMap<&str, u64>) -> Result<(), String> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        format!(
            "{}: {e} (create it with `cargo xtask qemu --overwrite-expected`)",
            path.display()
        )
    })?;
    let committed: BTreeMap<String, u64> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| {
            l.split_once('=')
                .and_then(|(k, v)| Some((k.trim().to_string(), v.trim().parse().ok()?)))
        })
        .collect();
    let mut failures = Vec::new();
    for (key, &now) in values {
        let Some(&base) = committed.get(*key) else {
            failures.push(format!("{key}: no baseline"));
            continue;
        };
        let limit = base + base / 10;
        if now > limit {
            failures.push(format!(
                "{key}: {now} exceeds the baseline {base} by more than 10 %"
            ));
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(format!("{}:\n  {}", path.display(), failures.join("\n  ")))
    }
}

fn write(path: &Path, text: &str) -> Result<(), String> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| e.to_string())?;
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

/// The table of the paper's Fig. 8(d)/(e): instructions per 100 Hz step per scheme.
pub fn table(runs: &[Measured]) -> String {
    let mut out = String::from(
        "\nInstructions per 100 Hz step under QEMU mps2-an500 (-icount shift=7): QEMU instructions, not Cortex-M7 cycles.\n\n\
         | scene | solver | min | mean | max | target (max) | solver only: mean / max | its target | flash | solver's flash | static RAM | stack (control task) | RAM + stack |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for m in runs {
        let (min, mean, max) = m.cost_summary();
        let solver = m
            .lines
            .iter()
            .filter(|l| l.starts_with("scene "))
            .find_map(|l| {
                l.split(": ")
                    .nth(1)
                    .map(|s| s.split(',').next().unwrap_or(s).to_string())
            })
            .unwrap_or_default();
        // The targets: BDF4, Radau with J̃10, and RADAU5's transformed Newton
        // (worst case including the controller's tick); other configurations have none.
        // The feedback scene has none: its QEMU build also links the simulated plant and
        // inclinometer, and the targets were set for the feedforward controller.
        // The targets were set per crane: the planar crane's by issues 8 and 20, the 3D
        // crane's by issue 19; the hook-and-load crane has none.
        let settings = &m.scene.solver;
        let crane = FirmwareModel::of(&m.scene.model).ok();
        let spatial = matches!(crane, Some(FirmwareModel::Spatial(_)));
        let planar = matches!(crane, Some(FirmwareModel::Planar(_)));
        let target = match settings.scheme {
            _ if m.scene.feedback.is_some() => "— (feedback)",
            _ if !planar && !spatial => "—",
            // Issue 19's for the 3D crane's whole tick.
            scene::SchemeSpec::Radau
                if spatial && settings.newton == scene::NewtonSpec::Transformed =>
            {
                "20,000"
            }
            scene::SchemeSpec::Bdf if spatial && settings.k == 4 => "6,000",
            _ if spatial => "—",
            scene::SchemeSpec::Radau if settings.newton == scene::NewtonSpec::Transformed => {
                "25,000 (mean 12,000)"
            }
            scene::SchemeSpec::Radau
                if settings.jacobian == scene::JacobianSpec::Broyden
                    && settings.reinit_every == Some(10) =>
            {
                "60,000"
            }
            scene::SchemeSpec::Radau => "—",
            scene::SchemeSpec::Bdf => "5,000",
        };
        // Issue 20's targets for the inverse model's step alone (with the firmware's
        // `Plan`), BDF4 and RADAU5.
        let solver_target = match settings.scheme {
            _ if m.scene.feedback.is_some() || !planar => "—",
            scene::SchemeSpec::Radau if settings.newton == scene::NewtonSpec::Transformed => {
                "1,600 / 2,500"
            }
            scene::SchemeSpec::Bdf if settings.k == 4 => "600 / 900",
            _ => "—",
        };
        let solver_only = m
            .solver_summary()
            .map_or("—".to_string(), |(mean, max)| format!("{mean} / {max}"));
        let solver_flash = m.solver_flash.map_or("—".to_string(), |b| {
            format!("{:.1} KiB", b as f64 / 1024.0)
        });
        out += &format!(
            "| {} | {solver} | {min} | {mean} | {max} | {target} | {solver_only} | {solver_target} | {:.1} KiB | {solver_flash} | {:.1} KiB | {:.1} KiB ({:.1} KiB) | {:.1} KiB |\n",
            m.stem(),
            m.sizes.flash as f64 / 1024.0,
            m.sizes.ram as f64 / 1024.0,
            m.stack as f64 / 1024.0,
            m.task_stack as f64 / 1024.0,
            (m.sizes.ram + m.stack) as f64 / 1024.0
        );
    }
    out + "\nTargets: flash ≤ 128 KiB, static RAM + stack ≤ 32 KiB; the solver's flash (the firmware's minus \
           that of the same firmware built with the inverse model stubbed out, feature `stub-inverse-model`) \
           ≤ 16 KiB for BDF4. The feedback scene's row (no target) includes the virtual bus's simulated plant \
           and inclinometer, which its QEMU build links (feature `plant`). *stack*: the high-water mark since boot; \
           in brackets since the control task started (its own frames and the interrupts'; the rest is `init`'s). \
           *solver only*: the inverse model's step alone (the firmware's `timed` window inside the tick, the model \
           driven by its `Plan`), over the cycles that stepped it.\n"
}

/// What dominates the worst case: steps split by the Jacobians they formed, and the
/// most expensive steps of each run.
pub fn worst_steps(runs: &[Measured], count: usize) -> String {
    let mut out = String::new();
    for m in runs {
        let h_ms = m.scene.solver.h * 1000.0;
        out += &format!(
            "\n{}: steps by Jacobians formed (QEMU instructions)\n",
            m.stem()
        );
        let most = m.steps.iter().map(|s| s.jacobians).max().unwrap_or(0);
        for j in 0..=most {
            let group: Vec<&StepCost> = m.steps.iter().filter(|s| s.jacobians == j).collect();
            if group.is_empty() {
                continue;
            }
            let n = group.len() as u64;
            let mean = group.iter().map(|s| s.instructions).sum::<u64>() / n;
            let max = group.iter().map(|s| s.instructions).max().unwrap_or(0);
            let iterations =
                group.iter().map(|s| u64::from(s.iterations)).sum::<u64>() as f64 / n as f64;
            out += &format!("  {j} Jacobians: {n:>4} steps, mean {mean:>7}, max {max:>7}, {iterations:.1} Newton iterations on average\n");
        }
        let mut order: Vec<&StepCost> = m.steps.iter().collect();
        order.sort_by_key(|s| std::cmp::Reverse(s.instructions));
        out += &format!("{}: the {count} most expensive steps\n", m.stem());
        for s in order.iter().take(count) {
            out += &format!(
                "  t = {:>7.0} ms: {:>7} instructions, {:>2} Newton iterations, {} Jacobians\n",
                f64::from(s.cycle) * h_ms,
                s.instructions,
                s.iterations,
                s.jacobians
            );
        }
    }
    out
}
