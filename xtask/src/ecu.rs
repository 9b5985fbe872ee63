//! `cargo xtask ecu [--port N] [--role manager|slave] [--seconds S] [--demo] [--log FILE]
//! [--scene FILE]` — the virtual ECU (`host-tests/src/bin/ecu.rs`): the firmware's
//! controller on the default scene in real time, its CAN bus as SLCAN (Lawicel ASCII)
//! over TCP on 127.0.0.1:N (28800 by default) for python-can, python-canopen and, through
//! `slcand`, SocketCAN tools. It stops by itself after S seconds (300 by default); every
//! frame, both directions, is logged to FILE (`target/ecu/frames.log` by default) in
//! candump's `-l` layout. The arguments are the binary's own (`--help` lists them).

use std::path::PathBuf;
use std::process::Command;

use crate::firmware::root;
use crate::{cargo, run};

/// Where cargo puts the host builds.
pub fn target_dir() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from) {
        Some(dir) if dir.is_absolute() => dir,
        Some(dir) => root().join(dir),
        None => root().join("target"),
    }
}

/// Builds the ECU (the host's dev profile, optimised) and returns its path.
pub fn build() -> Result<PathBuf, String> {
    run(cargo().args(["build", "--quiet", "-p", "host-tests", "--bin", "ecu"]))?;
    Ok(target_dir().join("debug").join("ecu"))
}

/// Runs the ECU with `args`, logging to `target/ecu/frames.log` unless `--log` is given.
pub fn ecu(args: &[String]) -> Result<(), String> {
    let bin = build()?;
    let mut cmd = Command::new(bin);
    cmd.current_dir(root()).args(args);
    if !args.iter().any(|a| a == "--log") {
        let log = target_dir().join("ecu").join("frames.log");
        eprintln!("xtask ecu: frames logged to {}", log.display());
        cmd.arg("--log").arg(log);
    }
    run(&mut cmd)
}
