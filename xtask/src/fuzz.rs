//! `cargo xtask fuzz [--seconds N] [target …]`: libFuzzer (cargo fuzz) on the frame
//! decoders, the command validator and the controller under garbage and traffic
//! (`fuzz/fuzz_targets/`). Runs on the pinned stable toolchain: without a sanitizer,
//! cargo fuzz needs no nightly features, and the crates fuzzed forbid `unsafe`, which
//! is what AddressSanitizer would watch. A panic or a failed assertion is a crash:
//! libFuzzer stops and leaves the input in `fuzz/artifacts/<target>/`.

use std::process::{Command, Stdio};
use std::time::Instant;

use crate::{cargo, firmware::root, setup};

/// Every fuzz target.
pub const TARGETS: [&str; 5] = [
    "frame_decoders",
    "command_validator",
    "garbage_changes_nothing",
    "controller_under_traffic",
    "closed_loop_under_traffic",
];

/// Fuzzes `targets` (all if empty) for `seconds` each; prints runs and coverage.
pub fn fuzz(seconds: u64, targets: &[String]) -> Result<(), String> {
    if seconds == 0 {
        // libFuzzer reads -max_total_time=0 as "no limit": the run would never end.
        return Err("--seconds must be at least 1".into());
    }
    setup::ensure_cargo_fuzz()?;
    let chosen: Vec<&str> = if targets.is_empty() {
        TARGETS.to_vec()
    } else {
        targets.iter().map(String::as_str).collect()
    };
    if let Some(t) = chosen.iter().find(|t| !TARGETS.contains(t)) {
        return Err(format!("no fuzz target {t}; the targets are {TARGETS:?}"));
    }
    let mut report = Vec::new();
    for target in chosen {
        let started = Instant::now();
        let out = cargo()
            .current_dir(root())
            .args([
                "fuzz",
                "run",
                "--sanitizer",
                "none",
                "--fuzz-dir",
                "fuzz",
                target,
                "--",
            ])
            .arg(format!("-max_total_time={seconds}"))
            .arg("-print_final_stats=1")
            .stdout(Stdio::inherit())
            .stderr(Stdio::piped())
            .output()
            .map_err(|e| format!("cannot start cargo fuzz: {e}"))?;
        let log = String::from_utf8_lossy(&out.stderr);
        let done = log
            .lines()
            .rev()
            .find(|l| l.contains("DONE"))
            .unwrap_or("")
            .to_string();
        if !out.status.success() {
            eprintln!("{log}");
            return Err(format!(
                "fuzz target {target} crashed (input in fuzz/artifacts/{target}/)"
            ));
        }
        let runs = stat(&log, "stat::number_of_executed_units:");
        report.push(format!(
            "| {target} | {} s | {runs} | {} | {} |",
            started.elapsed().as_secs(),
            field(&done, "cov:"),
            field(&done, "corp:")
        ));
    }
    println!(
        "\n| fuzz target | time | runs | coverage (edges) | corpus |\n|---|---:|---:|---:|---:|"
    );
    for line in report {
        println!("{line}");
    }
    println!("\nNo crash, no failed assertion (`cargo xtask fuzz --seconds {seconds}`).");
    Ok(())
}

fn stat(log: &str, key: &str) -> String {
    log.lines()
        .find_map(|l| l.strip_prefix(key))
        .map(|v| v.trim().to_string())
        .unwrap_or_default()
}

fn field(line: &str, key: &str) -> String {
    line.split_whitespace()
        .skip_while(|w| *w != key)
        .nth(1)
        .unwrap_or("")
        .to_string()
}

/// Formatting and lints of the fuzz crate (not in the host workspace).
pub fn lint() -> Result<(), String> {
    crate::run(cargo().current_dir(root()).args([
        "fmt",
        "--manifest-path",
        "fuzz/Cargo.toml",
        "--",
        "--check",
    ]))?;
    crate::run(
        Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
            .current_dir(root())
            .args([
                "clippy",
                "--manifest-path",
                "fuzz/Cargo.toml",
                "--bins",
                "--",
                "-D",
                "warnings",
            ]),
    )
}
