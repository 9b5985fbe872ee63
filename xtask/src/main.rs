//! `cargo xtask <command>`: everything that is not plain `cargo test`.
//!
//! * `run` — the main job: the firmware in QEMU on the default scene (and the Radau
//!   scene), its decoded CAN log, and instructions per step per scheme.
//! * `test` — the whole test suite: formatting, lints, host tests, the `no_std` build
//!   of solver-core, both firmware boards, and the QEMU checks.
//! * `qemu [--overwrite-expected]` — the QEMU checks alone: golden output, the host's
//!   computation of the same scene, committed baselines (±10 %).
//! * `qemu-bench` — instructions per step, flash, RAM and stack against the targets.
//! * `soak --minutes M` — the QEMU firmware through M simulated minutes of random
//!   requests, garbage and faults; every set point checked against the limits.
//! * `fuzz [--seconds N] [target …]` — cargo fuzz on the frame decoders, the command
//!   validator and the controller (N seconds per target, 30 by default).
//! * `panic-proof [--report]` — the link-time proof that the portable logic cannot
//!   panic, and the firmware's remaining panic paths against docs/PANICS.md.
//! * `decode ELF LOG` — a raw defmt log decoded with its ELF (debugging QEMU runs).
//! * `flash` — builds the STM32H743 firmware and runs it with `probe-rs run`.
//! * `study …` — the speed/accuracy studies (`run`, `sweep`, `paper`, `extremes`).
//! * `bench` — criterion benchmarks of one step and whole runs on the host.

use std::process::{Command, ExitCode};

mod defmt_log;
mod ecu;
mod firmware;
mod fuzz;
mod interop;
mod panics;
mod qemu;
mod setup;
mod soak;

use firmware::Board;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |f: &str| args.iter().any(|a| a == f);
    let result = match args.first().map(String::as_str) {
        Some("run") => main_job(),
        Some("test") => test(),
        Some("qemu") => qemu_checks(flag("--overwrite-expected")),
        Some("qemu-bench") => qemu_bench(),
        Some("soak") => match args
            .iter()
            .position(|a| a == "--minutes")
            .and_then(|i| args.get(i + 1))
        {
            Some(m) => m
                .parse()
                .map_err(|e| format!("--minutes {m}: {e}"))
                .and_then(soak::soak),
            None => Err("usage: cargo xtask soak --minutes M".into()),
        },
        Some("flash") => flash(),
        Some("ecu") => ecu::ecu(&args[1..]),
        Some("interop") => interop::interop(),
        Some("decode") if args.len() == 3 => decode_log(&args[1], &args[2]),
        Some("panic-proof") if flag("--report") => panics::report(),
        Some("panic-proof") => panics::panic_proof(),
        Some("fuzz") => {
            let seconds = args
                .iter()
                .position(|a| a == "--seconds")
                .and_then(|i| args.get(i + 1))
                .map_or(Ok(30), |s| {
                    s.parse().map_err(|e| format!("--seconds {s}: {e}"))
                });
            let targets: Vec<String> = args
                .iter()
                .skip(1)
                .filter(|a| !a.starts_with("--") && a.parse::<u64>().is_err())
                .cloned()
                .collect();
            seconds.and_then(|s| fuzz::fuzz(s, &targets))
        }
        Some("study") => run(cargo()
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
            .args(args.iter().skip(1))),
        Some("bench") => run(cargo()
            .args(["bench", "-p", "host-tests", "--bench", "step"])
            .args(args.iter().skip(1))),
        _ => {
            eprintln!(
                "usage: cargo xtask run | test | qemu [--overwrite-expected] | qemu-bench | soak --minutes M | ecu [--port N] [--role slave] [--seconds S] | interop | fuzz [--seconds N] [target …] | panic-proof [--report] | flash | study … | bench"
            );
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
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
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

/// The main job: the default scene's decoded log, then the cost table of both scenes.
fn main_job() -> Result<(), String> {
    let runs = qemu::SCENES
        .iter()
        .map(|s| qemu::measure(s))
        .collect::<Result<Vec<_>, _>>()?;
    let dbc = host_tests::dbc::Dbc::crane()?;
    if let Some(default) = runs.first() {
        println!("== {} (QEMU mps2-an500): decoded log", qemu::SCENES[0]);
        for line in firmware::readable_log(&default.lines, &dbc) {
            println!("{line}");
        }
    }
    print!("{}", qemu::table(&runs));
    all_succeeded(&runs)
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
fn decode_log(elf: &str, log: &str) -> Result<(), String> {
    let elf = std::fs::read(elf).map_err(|e| format!("{elf}: {e}"))?;
    let bytes = std::fs::read(log).map_err(|e| format!("{log}: {e}"))?;
    for line in defmt_log::decode(&elf, &bytes)? {
        println!("{line}");
    }
    Ok(())
}

/// Both scenes on the healthy bus, then the default scene through every scenario of
/// the virtual bus (docs/COMMANDS.md).
fn qemu_checks(overwrite: bool) -> Result<(), String> {
    for scene in qemu::SCENES {
        let m = qemu::measure(scene)?;
        qemu::check(&m, overwrite)?;
    }
    for scenario in controller::virtual_bus::SCENARIOS
        .into_iter()
        .filter(|s| s.name != controller::virtual_bus::HEALTHY.name)
    {
        let m = qemu::measure_scenario(qemu::SCENARIO_SCENE, scenario)?;
        qemu::check(&m, overwrite)?;
    }
    Ok(())
}

fn qemu_bench() -> Result<(), String> {
    let runs = qemu::SCENES
        .iter()
        .chain(&qemu::BENCH_ONLY_SCENES)
        .map(|s| qemu::measure(s))
        .collect::<Result<Vec<_>, _>>()?;
    print!("{}", qemu::table(&runs));
    print!("{}", qemu::worst_steps(&runs, 8));
    all_succeeded(&runs)
}

fn flash() -> Result<(), String> {
    let elf = firmware::build(Board::Stm32h743, &firmware::root().join(qemu::SCENES[0]))?;
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
    interop::interop()?;
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
    // The real drive controller: CI can build it, not run it.
    firmware::build(Board::Stm32h743, &firmware::root().join(qemu::SCENES[0]))?;
    qemu_checks(false)?;
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
