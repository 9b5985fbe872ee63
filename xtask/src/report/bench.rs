//! `cargo xtask report-bench [--frames N]`: seconds per million frames (wall clock, and
//! the CPU time the report spent: the wall clock also counts whatever else the machine
//! runs) and peak memory of `cargo xtask report` on a long log — the committed example
//! log's frames repeated, each copy shifted by the example's length, into
//! `target/report-bench/bench.log`, then the report run on it in a process of its own
//! (its peak resident memory, VmHWM, is its own, not this one's).

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::process::Command;

use crate::ecu::target_dir;
use crate::firmware::root;

/// Writes a log of at least `frames` frames and runs the report on it.
pub fn bench(frames: u64) -> Result<(), String> {
    // The committed example's log, whose frames are repeated.
    let source = root().join(super::EXAMPLE_DIR).join(super::EXAMPLE_LOG);
    let lines: Vec<(f64, String)> =
        BufReader::new(File::open(&source).map_err(|e| format!("{}: {e}", source.display()))?)
            .lines()
            .map_while(Result::ok)
            .filter_map(|l| {
                let (stamp, rest) = l.split_once(' ')?;
                let t: f64 = stamp
                    .trim_start_matches('(')
                    .trim_end_matches(')')
                    .parse()
                    .ok()?;
                Some((t, rest.to_string()))
            })
            .collect();
    let (first, last) = match (lines.first(), lines.last()) {
        (Some(a), Some(b)) => (a.0, b.0),
        _ => return Err(format!("{}: no frames", source.display())),
    };
    let span = last - first + 0.01;
    let dir = target_dir().join("report-bench");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let log = dir.join("bench.log");
    let mut out =
        BufWriter::new(File::create(&log).map_err(|e| format!("{}: {e}", log.display()))?);
    let mut written = 0u64;
    let mut copy = 0u64;
    while written < frames {
        let shift = copy as f64 * span;
        for (t, rest) in &lines {
            writeln!(out, "({:.6}) {rest}", t + shift).map_err(|e| e.to_string())?;
            written += 1;
        }
        copy += 1;
    }
    out.flush().map_err(|e| e.to_string())?;
    let size = std::fs::metadata(&log).map_err(|e| e.to_string())?.len();
    eprintln!(
        "report-bench: {written} frames, {:.1} MB, in {}",
        size as f64 / 1e6,
        log.display()
    );
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let run = Command::new(exe)
        .arg("report")
        .arg(&log)
        .arg("--out")
        .arg(dir.join("out"))
        .current_dir(root())
        .output()
        .map_err(|e| format!("cannot run the report: {e}"))?;
    let stderr = String::from_utf8_lossy(&run.stderr);
    if !run.status.success() {
        return Err(format!("the report failed:\n{stderr}"));
    }
    let line = stderr
        .lines()
        .find(|l| l.starts_with("report: ") && l.contains("per million frames"))
        .ok_or_else(|| format!("the report printed no timing:\n{stderr}"))?;
    println!("{line}");
    println!(
        "log: {written} frames, {:.1} MB (candump -L)",
        size as f64 / 1e6
    );
    Ok(())
}
