//! `cargo xtask <command>`: everything that is not plain `cargo test`.
//!
//! * `run` — the main job: the firmware in QEMU on the default scene (and the Radau
//!   scene, RADAU5's transformed Newton), its decoded CAN log, instructions per step
//!   per scheme, and the default scene's estimated Cortex-M7 cycles per step.
//! * `test` — the whole test suite: formatting, lints, host tests, the `no_std` build
//!   of solver-core, both firmware boards, and the QEMU checks.
//! * `qemu [--overwrite-expected]` — the QEMU checks alone: golden output, the host's
//!   computation of the same scene, committed baselines (±10 %).
//! * `qemu-bench` — instructions per step, flash, RAM and stack against the targets.
//! * `cycles [SCENE …]` — estimated Cortex-M7 cycles (and µs at 480 MHz) per step,
//!   from QEMU's execution trace through a stated timing model (lower / point / upper).
//! * `fig8 [--out-dir DIR]` — the paper's Fig. 8(d, e) from the same QEMU runs:
//!   instructions and estimated Cortex-M7 µs per cycle over the move, BDF4 and Radau,
//!   as SVG and CSV.
//! * `soak --minutes M` — the QEMU firmware through M simulated minutes of random
//!   requests, garbage and faults; every set point checked against the limits.
//! * `fuzz [--seconds N] [target …]` — cargo fuzz on the frame decoders, the command
//!   validator and the controller (N seconds per target, 30 by default).
//! * `panic-proof [--report]` — the link-time proof that the portable logic cannot
//!   panic, and the firmware's remaining panic paths against docs/PANICS.md.
//! * `decode ELF LOG` — a raw defmt log decoded with its ELF (debugging QEMU runs).
//! * `flash` — builds the STM32H743 firmware and runs it with `probe-rs run`.
//! * `ecu [--port N] [--role manager|slave] [--seconds S] …` — the controller in real
//!   time, its CAN bus as SLCAN over TCP (docs/COMMISSIONING.md).
//! * `interop` — python-canopen drives and a supervisor against the virtual ECU.
//! * `drive [SCENE]` — manual mode from the keyboard: the real controller on the virtual
//!   bus with a plant that is not the model, in real time, in a terminal view
//!   (`drive-view/`, docs/OPERATOR.md "Try it from the keyboard").
//! * `report LOG [--scene SCENE] [--out DIR] [--eds NODE=FILE …]` — a recorded bus
//!   (candump `-L` or Vector ASC) in, the crane's report out: one HTML page with its
//!   figures, the figures as SVG, `summary.json` (docs/REPORT.md).
//! * `report-check` — the committed example report made again and compared, its page
//!   loaded in headless chromium (part of `test`).
//! * `report-bench [--frames N]` — the report's seconds per million frames (wall clock
//!   and CPU) and peak memory on a long log.
//! * `study …` — the speed/accuracy studies (`run`, `sweep`, `paper`, `extremes`).
//! * `bench` — criterion benchmarks of one step and whole runs on the host.
//! * `instructions` — host instructions per step under callgrind (deterministic),
//!   BDF4 and Radau on the paper's crane move at h = 10 ms and 1 ms.
//! * `trade [--quick] [--out-dir DIR] [--crane NAME …] [--tables-only]` — the speed/accuracy trade per crane: every
//!   scheme × formulation × Jacobian mode × h, e_max against host instructions and
//!   estimated Cortex-M7 µs per step, the Pareto front, and the Newton matrix's
//!   condition number against h.
//!
//! Arguments are parsed by clap: an unknown command or flag is refused, not
//! ignored. The commands that build the firmware for their own scenes refuse a
//! `SCENE` in the environment instead of silently running the default scene.

use std::path::PathBuf;
use std::process::{Command, ExitCode};

use clap::{Parser, Subcommand};

mod cycles;
mod defmt_log;
mod ecu;
mod fig8;
mod firmware;
mod fuzz;
mod instructions;
mod interop;
mod panics;
mod qemu;
mod report;
mod setup;
mod soak;
mod trade;

use firmware::Board;

/// The command line. clap refuses what it does not know (an unknown flag used to be
/// ignored: `panic-proof --bogus` ran the proof).
#[derive(Parser, Debug)]
#[command(
    name = "cargo xtask",
    bin_name = "cargo xtask",
    about = "The project's single entry point (README.md)"
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// The main job: the firmware in QEMU on the default scene and the Radau scene,
    /// the decoded CAN log and instructions per step.
    Run,
    /// The whole test suite (what CI runs).
    Test,
    /// The QEMU checks: golden output, the host's computation, baselines (±10 %).
    Qemu {
        /// Rewrite the golden logs and baselines instead of comparing with them.
        #[arg(long)]
        overwrite_expected: bool,
        /// Only the runs whose golden log's name (`<scene>` or `<scene>--<scenario>`)
        /// contains this (while developing; CI runs them all).
        #[arg(long)]
        only: Option<String>,
    },
    /// Instructions per step, flash, RAM and stack against the targets.
    QemuBench,
    /// Estimated Cortex-M7 cycles per step (lower / point / upper) and µs at 480 MHz,
    /// from QEMU's execution trace (xtask/src/cycles/m7.rs states the model).
    Cycles {
        /// Scene files (the scenes of `qemu-bench` when none is named; with `--scenario`,
        /// the QEMU checks' scenes that have that scenario).
        scenes: Vec<String>,
        /// Run each scene through this scenario of its QEMU checks (`cargo xtask qemu`;
        /// e.g. `manual-takeover-3d`) instead of its default one.
        #[arg(long)]
        scenario: Option<String>,
    },
    /// The paper's Fig. 8(d, e): QEMU instructions and estimated Cortex-M7 µs per cycle
    /// over the move, BDF4 and Radau, as SVG and CSV (the runs of `qemu-bench`).
    Fig8 {
        /// Output directory.
        #[arg(long, default_value = "docs/figures")]
        out_dir: PathBuf,
    },
    /// The QEMU firmware through M simulated minutes of random traffic and faults.
    Soak {
        /// Simulated minutes.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        minutes: u32,
    },
    /// cargo fuzz on the decoders, the command validator and the controller.
    Fuzz {
        /// Seconds per target (libFuzzer reads 0 as "forever", so it is refused).
        #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u64).range(1..))]
        seconds: u64,
        /// Targets (all when none is named).
        targets: Vec<String>,
    },
    /// The link-time proof that the portable logic cannot panic.
    PanicProof {
        /// Report the firmware's remaining panic paths against docs/PANICS.md.
        #[arg(long)]
        report: bool,
    },
    /// A raw defmt log decoded with its ELF (debugging QEMU runs).
    Decode {
        /// The firmware ELF.
        elf: PathBuf,
        /// The raw defmt log.
        log: PathBuf,
    },
    /// Builds the STM32H743 firmware and runs it with `probe-rs run`.
    Flash,
    /// The controller in real time with its CAN bus as SLCAN over TCP (`ecu --help`).
    #[command(disable_help_flag = true)]
    Ecu {
        /// Passed to the ECU, which checks them (--port, --role, --seconds, …).
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
    /// python-canopen drives and supervisor against the virtual ECU (in `test`).
    Interop,
    /// Manual mode from the keyboard: the real controller on the virtual bus with a
    /// plant that is not the model, in real time, in a terminal view.
    Drive {
        /// A scene with `[operator]` (manual mode); its commissioning file beside it.
        #[arg(default_value = DRIVE_SCENE)]
        scene: PathBuf,
    },
    /// A recorded bus in, the crane's report out: candump -L or Vector ASC (docs/REPORT.md).
    Report {
        /// The log (candump -L, `.log`; Vector ASC, `.asc`).
        log: PathBuf,
        /// The crane's scene; its commissioning file beside it says the node ids.
        #[arg(long, default_value = report::DEFAULT_SCENE)]
        scene: PathBuf,
        /// Where the page, its figures and summary.json go (default: target/report/<log's name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// A node's EDS (object names in its SDO transcript), NODE=FILE; repeatable.
        #[arg(long, value_parser = report::parse_eds)]
        eds: Vec<(u8, PathBuf)>,
    },
    /// The committed example report (docs/report-example) made again and compared, and
    /// its page loaded in headless chromium (in `test`).
    ReportCheck,
    /// The report's seconds per million frames and peak memory on a long log.
    ReportBench {
        /// Frames in the log.
        #[arg(long, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..))]
        frames: u64,
    },
    /// The speed/accuracy studies: `run`, `sweep`, `paper`, `extremes` (`study --help`).
    #[command(disable_help_flag = true)]
    Study {
        /// Passed to the study program, which checks them.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
    /// Host instructions per step under valgrind's callgrind (deterministic): BDF4 and
    /// Radau on the paper's crane move at h = 10 ms and 1 ms.
    Instructions,
    /// The speed/accuracy trade per crane: every scheme × formulation × Jacobian mode ×
    /// h, e_max against host instructions and estimated Cortex-M7 µs per step, the
    /// Pareto front, and the Newton matrix's condition number (about an hour).
    Trade {
        /// Output directory (default: docs/figures/trade; target/trade-quick with --quick).
        #[arg(long)]
        out_dir: Option<PathBuf>,
        /// BDF4 and RADAU5 at 10 ms only (for tests).
        #[arg(long)]
        quick: bool,
        /// Measure this crane only (planar, 3d, double-pendulum; repeatable): the
        /// others' CSV files are kept and their tables written from them.
        #[arg(long = "crane")]
        cranes: Vec<String>,
        /// Measure nothing: the selected cranes' figures and every table from the CSV
        /// files as they are.
        #[arg(long)]
        tables_only: bool,
    },
    /// Criterion benchmarks of one step and whole runs on the host.
    #[command(disable_help_flag = true)]
    Bench {
        /// Passed to criterion.
        #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
        args: Vec<String>,
    },
}

impl Cmd {
    /// Whether the command builds the firmware for its own fixed scenes (or, like
    /// `instructions`, measures its own fixed scene on the host), so that a `SCENE` in
    /// the environment would be silently ignored.
    fn builds_fixed_scenes(&self) -> bool {
        matches!(
            self,
            Cmd::Run
                | Cmd::Test
                | Cmd::Qemu { .. }
                | Cmd::QemuBench
                | Cmd::Fig8 { .. }
                | Cmd::Instructions
                | Cmd::Trade { .. }
                | Cmd::Soak { .. }
                | Cmd::Flash
        )
    }
}

/// `SCENE=… cargo xtask run` used to run the default scene anyway. The QEMU
/// commands are defined on the scenes the README names (their golden logs and
/// baselines are committed per scene), so a `SCENE` is refused, not ignored.
fn refuse_scene(cmd: &Cmd, scene: Option<String>) -> Result<(), String> {
    match scene {
        Some(s) if cmd.builds_fixed_scenes() => {
            let what = match cmd {
                Cmd::Instructions => format!("it measures {}", instructions::SCENE),
                Cmd::Trade { .. } => "it measures the cranes' own scenes".into(),
                _ => format!(
                    "it builds the firmware for {}",
                    qemu::scenes().join(" and ")
                ),
            };
            Err(format!(
                "SCENE={s} is not used by this command: {what} (README.md). \
                 Unset SCENE; to run another scene on the host use `cargo xtask study run {s}`."
            ))
        }
        _ => Ok(()),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result =
        refuse_scene(&cli.command, std::env::var("SCENE").ok()).and_then(|()| match cli.command {
            Cmd::Run => main_job(),
            Cmd::Test => test(),
            Cmd::Qemu {
                overwrite_expected,
                only,
            } => qemu_checks(overwrite_expected, only.as_deref()),
            Cmd::QemuBench => qemu_bench(),
            Cmd::Cycles { scenes, scenario } => cycles_of(scenes, scenario.as_deref()),
            Cmd::Fig8 { out_dir } => fig8::fig8(&firmware::root().join(out_dir)),
            Cmd::Soak { minutes } => soak::soak(minutes),
            Cmd::Fuzz { seconds, targets } => fuzz::fuzz(seconds, &targets),
            Cmd::PanicProof { report: true } => panics::report(),
            Cmd::PanicProof { report: false } => panics::panic_proof(),
            Cmd::Decode { elf, log } => decode_log(&elf, &log),
            Cmd::Flash => flash(),
            Cmd::Ecu { args } => ecu::ecu(&args),
            Cmd::Interop => interop::interop(),
            Cmd::Drive { scene } => drive(&scene),
            Cmd::Report {
                log,
                scene,
                out,
                eds,
            } => {
                let out = out.unwrap_or_else(|| {
                    let stem = log
                        .file_stem()
                        .map_or("log".into(), |s| s.to_string_lossy().into_owned());
                    ecu::target_dir().join("report").join(stem)
                });
                report::report(&report::Options {
                    log,
                    scene,
                    out,
                    eds,
                })
                .map(|_| ())
            }
            Cmd::ReportCheck => report::check_example(),
            Cmd::ReportBench { frames } => report::bench::bench(frames),
            Cmd::Study { args } => run(cargo()
                .args([
                    "run",
                    "--release",
                    "--quiet",
                    "-p",
                    "host-tests",
                    "--bin",
                    "study",
                    "--",
                ])
                .args(args)),
            Cmd::Instructions => instructions::instructions(),
            Cmd::Trade {
                out_dir,
                quick,
                cranes,
                tables_only,
            } => {
                let default = if quick {
                    "target/trade-quick"
                } else {
                    "docs/figures/trade"
                };
                let out = out_dir.unwrap_or_else(|| PathBuf::from(default));
                trade::trade(&firmware::root().join(out), quick, &cranes, tables_only)
            }
            Cmd::Bench { args } => run(cargo()
                .args(["bench", "-p", "host-tests", "--bench", "step"])
                .args(args)),
        });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The scene `cargo xtask drive` drives when none is named: manual mode with the state
/// feedback, as a commissioned crane runs it.
const DRIVE_SCENE: &str = "scenes/paper-crane-manual-feedback.toml";

/// `cargo xtask drive [SCENE]`: builds the keyboard view (the host's dev profile,
/// optimised) and runs it in this terminal.
fn drive(scene: &std::path::Path) -> Result<(), String> {
    run(cargo().args(["build", "--quiet", "-p", "drive-view", "--bin", "drive"]))?;
    // As given (from where xtask was called), else from the repository's root.
    let path = if scene.exists() {
        scene.to_path_buf()
    } else {
        firmware::root().join(scene)
    };
    run(Command::new(ecu::target_dir().join("debug").join("drive")).arg(path))
}

/// Runs a command, inheriting stdio; an error names it when it fails.
pub fn run(cmd: &mut Command) -> Result<(), String> {
    eprintln!("$ {}", describe(cmd));
    let status = cmd
        .status()
        .map_err(|e| format!("cannot start {}: {e}", describe(cmd)))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{}` failed ({status})", describe(cmd)))
    }
}

fn describe(cmd: &Command) -> String {
    std::iter::once(cmd.get_program().to_string_lossy().into_owned())
        .chain(cmd.get_args().map(|a| a.to_string_lossy().into_owned()))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The cargo that runs xtask.
pub fn cargo() -> Command {
    let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    // xtask's builds are whole runs, which an incremental cache does not speed up but
    // doubles on disk.
    cmd.env("CARGO_INCREMENTAL", "0");
    cmd
}

/// The main job: the default scene's decoded log, then the cost table of both scenes.
fn main_job() -> Result<(), String> {
    let runs = qemu::scenes()
        .into_iter()
        .map(qemu::measure)
        .chain([
            qemu::measure_scenario(qemu::FEEDBACK_SCENE, sim::CLOSED_LOOP),
            qemu::measure_scenario(qemu::CRANE3D_FEEDBACK_SCENE, sim::CLOSED_LOOP),
        ])
        .collect::<Result<Vec<_>, _>>()?;
    let dbc = host_tests::dbc::Dbc::crane()?;
    if let Some(default) = runs.first() {
        println!(
            "== {} (QEMU mps2-an500): decoded log",
            host_tests::DEFAULT_SCENE
        );
        for line in firmware::readable_log(&default.lines, &dbc) {
            println!("{line}");
        }
    }
    print!("{}", qemu::table(&runs));
    all_succeeded(&runs)?;
    // What the instructions of the default scene cost on a Cortex-M7 (estimated).
    cycles::cycles(&[(host_tests::DEFAULT_SCENE.to_string(), None)])
}

/// Fails naming the first run whose firmware did not end in the mode its scenario
/// expects: its instruction counts would describe a fault, not the scene.
fn all_succeeded(runs: &[qemu::Measured]) -> Result<(), String> {
    match runs.iter().find(|m| !m.success) {
        Some(m) => Err(format!(
            "{}: the firmware ended in a fault or panic (see its log)",
            m.scene.name
        )),
        None => Ok(()),
    }
}

/// Prints a raw defmt log (a QEMU run's `.defmt` file) decoded with its ELF.
fn decode_log(elf: &std::path::Path, log: &std::path::Path) -> Result<(), String> {
    let elf = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let bytes = std::fs::read(log).map_err(|e| format!("{}: {e}", log.display()))?;
    for line in defmt_log::decode(&elf, &bytes)? {
        println!("{line}");
    }
    Ok(())
}

/// Every scene on the healthy bus, then the default scene through every scenario of the
/// virtual bus (docs/COMMANDS.md), the feedback scene through its scenarios on the plant,
/// and the 3D crane's scene through its own.
fn qemu_checks(overwrite: bool, only: Option<&str>) -> Result<(), String> {
    let runs = qemu_runs()
        .into_iter()
        .filter(|(scene, scenario)| {
            only.is_none_or(|o| qemu::stem(std::path::Path::new(scene), scenario).contains(o))
        })
        .collect::<Vec<_>>();
    qemu_checks_of(runs, overwrite, only)
}

/// Every QEMU check's scene and scenario (see [`qemu_checks`]).
fn qemu_runs() -> Vec<(&'static str, sim::Scenario)> {
    qemu::scenes()
        .into_iter()
        .map(|scene| (scene, sim::HEALTHY))
        .chain(
            sim::SCENARIOS
                .into_iter()
                .filter(|s| s.name != sim::HEALTHY.name)
                .map(|s| (qemu::SCENARIO_SCENE, s)),
        )
        .chain(sim::FEEDBACK_SCENARIOS.map(|s| (qemu::FEEDBACK_SCENE, s)))
        .chain(sim::CRANE3D_SCENARIOS.map(|s| (qemu::CRANE3D_SCENE, s)))
        .chain(sim::CRANE3D_FEEDBACK_SCENARIOS.map(|s| (qemu::CRANE3D_FEEDBACK_SCENE, s)))
        .chain(sim::MANUAL_SCENARIOS.map(|s| (qemu::MANUAL_SCENE, s)))
        .chain(sim::MANUAL_3D_SCENARIOS.map(|s| (qemu::CRANE3D_MANUAL_SCENE, s)))
        .collect()
}

/// [`qemu_checks`] on the chosen runs.
fn qemu_checks_of(
    runs: Vec<(&'static str, sim::Scenario)>,
    overwrite: bool,
    only: Option<&str>,
) -> Result<(), String> {
    if runs.is_empty() {
        return Err(format!(
            "no QEMU run's name contains {:?}",
            only.unwrap_or("")
        ));
    }
    let measured = runs
        .into_iter()
        .map(|(scene, scenario)| qemu::measure_scenario(scene, scenario));
    // Every run is checked, and every failed check reported: one differing golden log
    // does not hide what the others would say. A run that cannot be made (a build, QEMU)
    // ends the checks: the next would fail the same way.
    let mut failures = Vec::new();
    for measured in measured {
        if let Err(e) = qemu::check(&measured?, overwrite) {
            failures.push(e);
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{} QEMU check(s) failed:\n{}",
            failures.len(),
            failures.join("\n")
        ))
    }
}

/// `cargo xtask cycles`: the named scenes, or those of `qemu-bench`; each on its
/// default scenario, or on the named one of its QEMU checks.
fn cycles_of(scenes: Vec<String>, scenario: Option<&str>) -> Result<(), String> {
    let Some(name) = scenario else {
        let scenes: Vec<String> = if scenes.is_empty() {
            qemu::feedforward_scenes()
                .chain([qemu::FEEDBACK_SCENE, qemu::CRANE3D_FEEDBACK_SCENE])
                .map(str::to_string)
                .collect()
        } else {
            scenes
        };
        let runs: Vec<_> = scenes.into_iter().map(|scene| (scene, None)).collect();
        return cycles::cycles(&runs);
    };
    let checks = qemu_runs();
    let with_it = |scene: &str| checks.iter().find(|(s, sc)| *s == scene && sc.name == name);
    let runs = if scenes.is_empty() {
        // Every QEMU check's scene that has the scenario, once.
        let mut runs: Vec<(String, Option<sim::Scenario>)> = Vec::new();
        for (scene, sc) in checks.iter().filter(|(_, sc)| sc.name == name) {
            if !runs.iter().any(|(s, _)| s == scene) {
                runs.push((scene.to_string(), Some(*sc)));
            }
        }
        if runs.is_empty() {
            return Err(format!("no QEMU check has the scenario {name:?}"));
        }
        runs
    } else {
        scenes
            .into_iter()
            .map(|scene| match with_it(&scene) {
                Some((_, sc)) => Ok((scene, Some(*sc))),
                None => {
                    let own: Vec<&str> = checks
                        .iter()
                        .filter(|(s, _)| *s == scene)
                        .map(|(_, sc)| sc.name)
                        .collect();
                    Err(if own.is_empty() {
                        let mut known: Vec<&str> = checks.iter().map(|(s, _)| *s).collect();
                        known.sort_unstable();
                        known.dedup();
                        format!(
                            "{scene} is not a QEMU check's scene (written as `cargo xtask qemu` \
                             names them: {})",
                            known.join(", ")
                        )
                    } else {
                        format!(
                            "{scene} has no QEMU scenario {name:?} (its scenarios: {})",
                            own.join(", ")
                        )
                    })
                }
            })
            .collect::<Result<Vec<_>, String>>()?
    };
    cycles::cycles(&runs)
}

fn qemu_bench() -> Result<(), String> {
    let runs = qemu::feedforward_scenes()
        .map(qemu::measure)
        // The state feedback's cost: its scenes on the plant they close the loop around.
        .chain([
            qemu::measure_with_solver_flash(qemu::FEEDBACK_SCENE, sim::CLOSED_LOOP),
            qemu::measure_with_solver_flash(qemu::CRANE3D_FEEDBACK_SCENE, sim::CLOSED_LOOP),
            // Manual mode's cost: its scenes with the operator's profile on the bus.
            qemu::measure_with_solver_flash(qemu::MANUAL_SCENE, sim::MANUAL_PROFILE),
            qemu::measure_with_solver_flash(qemu::CRANE3D_MANUAL_SCENE, sim::MANUAL_PROFILE_3D),
        ])
        .collect::<Result<Vec<_>, _>>()?;
    print!("{}", qemu::table(&runs));
    print!("{}", qemu::worst_steps(&runs, 8));
    all_succeeded(&runs)
}

fn flash() -> Result<(), String> {
    let elf = firmware::build(
        Board::Stm32h743,
        &firmware::root().join(host_tests::DEFAULT_SCENE),
    )?;
    run(Command::new("probe-rs")
        .args(["run", "--chip", "STM32H743ZITx"])
        .arg(&elf))
    .map_err(|e| {
        format!("{e}\n(probe-rs comes with `cargo install probe-rs-tools --locked`, see README.md)")
    })
}

fn test() -> Result<(), String> {
    setup::ensure_target()?;
    run(cargo().args(["fmt", "--all", "--", "--check"]))?;
    run(cargo().args([
        "fmt",
        "--manifest-path",
        "firmware/Cargo.toml",
        "--",
        "--check",
    ]))?;
    run(cargo().args([
        "clippy",
        "--workspace",
        "--all-targets",
        "--",
        "-D",
        "warnings",
    ]))?;
    run(cargo().args(["test", "--workspace"]))?;
    // The doc comments are the next engineer's guide: their links must resolve.
    run(cargo()
        .args(["doc", "--workspace", "--no-deps"])
        .env("RUSTDOCFLAGS", "-D warnings"))?;
    interop::interop()?;
    // The committed example report is what the report makes of its log, and its page
    // loads in a browser.
    report::check_example()?;
    // The numerics on the drive's target, as a `no_std` release build.
    run(cargo().args([
        "build",
        "--release",
        "-p",
        "solver-core",
        "--target",
        setup::TARGET,
    ]))?;
    for board in [Board::Qemu, Board::Stm32h743] {
        firmware::clippy(board)?;
    }
    // The build the main job (`cargo xtask run`, `qemu-bench`) measures the solver's flash
    // with, the inverse model stubbed out: it must build too (it once broke unseen when a
    // trait it implements grew, 56a9a33).
    firmware::build_without_inverse_model(&firmware::root().join(host_tests::DEFAULT_SCENE))?;
    // The real drive controller, for the planar and the 3D crane: CI can build it, not
    // run it. Each links its own crane's model and not the other's — the planar one shown
    // on the paper's scene, whose model keeps its name in the symbols (the default scene's
    // *ext* model is inlined whole; its STM32H743 firmware is built by the panic proof).
    let planar = firmware::build(Board::Stm32h743, &firmware::root().join(qemu::PAPER_SCENE))?;
    firmware::links_only(&planar, "crane_subs", &["crane3d"])?;
    let spatial = firmware::build(
        Board::Stm32h743,
        &firmware::root().join(qemu::CRANE3D_SCENE),
    )?;
    firmware::links_only(&spatial, "crane3d", &["crane_subs", "crane_proj"])?;
    qemu_checks(false, None)?;
    // The Cortex-M7 estimate on the default scene: its trace windows must match the
    // firmware's own instruction counts step by step.
    cycles::cycles(&[(host_tests::DEFAULT_SCENE.to_string(), None)])?;
    // A short soak: one simulated minute of random traffic, every set point checked.
    soak::soak(1)?;
    panics::lint()?;
    panics::panic_proof()?;
    // A short fuzz: 20 s per target.
    fuzz::lint()?;
    fuzz::fuzz(20, &[])?;
    eprintln!("xtask test: all checks passed");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Result<Cmd, clap::Error> {
        Cli::try_parse_from(std::iter::once("xtask").chain(args.iter().copied())).map(|c| c.command)
    }

    #[test]
    fn every_documented_command_parses() {
        for args in [
            &["run"][..],
            &["test"],
            &["qemu"],
            &["qemu", "--overwrite-expected"],
            &["qemu-bench"],
            &["fig8"],
            &["cycles"],
            &["cycles", "scenes/paper-crane.toml"],
            &[
                "cycles",
                "--scenario",
                "manual-takeover-3d",
                "scenes/crane3d/crane3d-manual.toml",
            ],
            &["fig8", "--out-dir", "/tmp/figures"],
            &["soak", "--minutes", "60"],
            &["fuzz"],
            &["fuzz", "--seconds", "600"],
            &[
                "fuzz",
                "--seconds",
                "20",
                "frame_decoders",
                "command_validator",
            ],
            &["panic-proof"],
            &["panic-proof", "--report"],
            &["decode", "a.elf", "a.defmt"],
            &["flash"],
            &["study", "run", "scenes/paper-crane.toml", "--csv", "x.csv"],
            &[
                "study",
                "sweep",
                "s.toml",
                "--vary",
                "h=0.01|0.02",
                "--repeats",
                "3",
            ],
            &["study", "--help"],
            &["bench"],
            &["bench", "--", "--quick"],
            &["instructions"],
            &["ecu"],
            &["ecu", "--port", "0", "--role", "slave", "--seconds", "5"],
            &["interop"],
            &["drive"],
            &["drive", "scenes/crane3d/crane3d-manual-feedback.toml"],
            &["report", "a.log"],
            &[
                "report",
                "a.asc",
                "--scene",
                "scenes/crane3d/crane3d.toml",
                "--out",
                "/tmp/r",
            ],
            &[
                "report",
                "a.log",
                "--eds",
                "1=drive.eds",
                "--eds",
                "0x10=c.eds",
            ],
            &["report-bench"],
            &["report-check"],
            &["report-bench", "--frames", "5000000"],
        ] {
            assert!(parse(args).is_ok(), "{args:?}: {:?}", parse(args).err());
        }
        assert!(matches!(
            parse(&["fuzz", "--seconds", "5", "frame_decoders"]).unwrap(),
            Cmd::Fuzz { seconds: 5, ref targets } if targets == &["frame_decoders"]
        ));
        assert!(matches!(
            parse(&["study", "sweep", "--out", "x"]).unwrap(),
            Cmd::Study { ref args } if args == &["sweep", "--out", "x"]
        ));
    }

    #[test]
    fn what_is_not_understood_is_refused() {
        for args in [
            &["panic-proof", "--bogus"][..],
            &["fuzz", "--seconds", "0"],
            &["fuzz", "--seconds", "ten"],
            &["soak"],
            &["soak", "--minutes", "0"],
            &["run", "--scene", "x.toml"],
            &["qemu", "--overwrite"],
            &["decode", "a.elf"],
            &["frobnicate"],
            &["instructions", "--quick"],
            &["report"],
            &["report", "a.log", "--eds", "200=x.eds"],
            &["report", "a.log", "--eds", "x.eds"],
            &["report-bench", "--frames", "0"],
            &[],
        ] {
            assert!(parse(args).is_err(), "{args:?} was accepted");
        }
    }

    #[test]
    fn a_scene_in_the_environment_is_refused_where_it_would_be_ignored() {
        let scene = Some("scenes/hard-crane.toml".to_string());
        let e = refuse_scene(&Cmd::Run, scene.clone()).unwrap_err();
        assert!(
            e.contains("SCENE=scenes/hard-crane.toml") && e.contains("Unset SCENE"),
            "{e}"
        );
        assert!(refuse_scene(&Cmd::QemuBench, scene.clone()).is_err());
        assert!(refuse_scene(
            &Cmd::Fig8 {
                out_dir: "x".into()
            },
            scene.clone()
        )
        .is_err());
        let e = refuse_scene(&Cmd::Instructions, scene.clone()).unwrap_err();
        assert!(e.contains("it measures scenes/paper-crane.toml"), "{e}");
        assert!(refuse_scene(&Cmd::Study { args: vec![] }, scene).is_ok());
        assert!(refuse_scene(&Cmd::Run, None).is_ok());
    }
}
