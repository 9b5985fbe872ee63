//! The interop test: the virtual ECU against an independent CANopen stack —
//! python-canopen drives and supervisor over python-can's SLCAN interface, every frame
//! decoded with cantools against `can/crane.dbc` (`interop/`, its README-level docs in
//! `interop/test_interop.py`). The Python side is pinned in `interop/requirements.txt`
//! and installed from PyPI into its own virtual environment, `target/interop-venv`
//! (again whenever the requirements change); nothing is installed globally.

use std::fs;
use std::path::PathBuf;
use std::process::Command;

use crate::ecu::{self, target_dir};
use crate::firmware::root;
use crate::run;

const REQUIREMENTS: &str = "interop/requirements.txt";

/// Builds the ECU, makes the virtual environment and runs the scenarios with pytest
/// (their logs in `target/interop/pytest`).
pub fn interop() -> Result<(), String> {
    let ecu = ecu::build()?;
    let python = venv()?;
    let runs = target_dir().join("interop");
    fs::create_dir_all(&runs).map_err(|e| format!("{}: {e}", runs.display()))?;
    run(Command::new(python)
        .current_dir(root())
        .env("ECU_BIN", ecu)
        // `cargo xtask report`, run on the logs python-can records (test_report.py).
        .env(
            "REPORT_BIN",
            std::env::current_exe().map_err(|e| format!("xtask's own path: {e}"))?,
        )
        .args(["-m", "pytest", "-p", "no:cacheprovider", "-q", "-rxX"])
        .arg("--basetemp")
        .arg(runs.join("pytest"))
        .arg("interop"))
}

/// The virtual environment's python, with the pinned requirements installed.
fn venv() -> Result<PathBuf, String> {
    let dir = target_dir().join("interop-venv");
    let python = dir.join("bin").join("python");
    let wanted = fs::read_to_string(root().join(REQUIREMENTS))
        .map_err(|e| format!("{REQUIREMENTS}: {e}"))?;
    // What was installed last, so that a changed pin installs again.
    let stamp = dir.join("installed-requirements.txt");
    if fs::read_to_string(&stamp).is_ok_and(|s| s == wanted) && python.exists() {
        return Ok(python);
    }
    if !python.exists() {
        run(Command::new("python3").arg("-m").arg("venv").arg(&dir)).map_err(|e| {
            format!("{e}\n(the interop test needs python3 with venv: apt-get install python3-venv)")
        })?;
    }
    run(Command::new(&python)
        .args([
            "-m",
            "pip",
            "install",
            "--quiet",
            "--disable-pip-version-check",
            "-r",
        ])
        .arg(root().join(REQUIREMENTS)))?;
    fs::write(&stamp, wanted).map_err(|e| format!("{}: {e}", stamp.display()))?;
    Ok(python)
}
