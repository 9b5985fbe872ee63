//! Installs what a fresh machine lacks: the Rust target (through rustup and the
//! pinned toolchain), qemu-system-arm, valgrind and chromium from Debian's packages.

use std::process::Command;

use crate::run;

/// The drive MCU's target (Cortex-M7 with double-precision FPU).
pub const TARGET: &str = "thumbv7em-none-eabihf";

/// `rustup target add` for the pinned toolchain, if the target is missing.
pub fn ensure_target() -> Result<(), String> {
    let installed = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map_err(|e| format!("rustup not found: {e}"))?;
    if String::from_utf8_lossy(&installed.stdout)
        .lines()
        .any(|l| l.trim() == TARGET)
    {
        return Ok(());
    }
    run(Command::new("rustup").args(["target", "add", TARGET]))
}

/// qemu-system-arm from Debian's packages, if it is not on the PATH.
pub fn ensure_qemu() -> Result<(), String> {
    ensure_debian_package("qemu-system-arm", "qemu-system-arm")
}

/// valgrind (callgrind counts `cargo xtask instructions`) from Debian's packages, if
/// it is not on the PATH.
pub fn ensure_valgrind() -> Result<(), String> {
    ensure_debian_package("valgrind", "valgrind")
}

/// The headless browser the report's page is checked in (Debian's package `chromium`).
pub const CHROMIUM: &str = "chromium";

/// chromium from Debian's packages, if it is not on the PATH (the report's page check).
pub fn ensure_chromium() -> Result<(), String> {
    ensure_debian_package(CHROMIUM, "chromium")
}

/// `apt-get install package` (as root, or through sudo), if `program --version` does
/// not run; `apt-get update` first only when the install fails without it.
fn ensure_debian_package(program: &str, package: &str) -> Result<(), String> {
    if Command::new(program)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        return Ok(());
    }
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    let apt = |args: &[&str]| {
        let mut cmd = if root {
            Command::new("apt-get")
        } else {
            Command::new("sudo")
        };
        if !root {
            cmd.arg("apt-get");
        }
        cmd.env("DEBIAN_FRONTEND", "noninteractive").args(args);
        run(&mut cmd)
    };
    let install = ["install", "-y", "--no-install-recommends", package];
    if apt(&install).is_err() {
        apt(&["update"])?;
        apt(&install)?;
    }
    Ok(())
}

/// The cargo-fuzz version `cargo xtask fuzz` installs from crates.io.
const CARGO_FUZZ: &str = "0.13.2";

/// `cargo install cargo-fuzz` from crates.io, if `cargo fuzz` is missing.
pub fn ensure_cargo_fuzz() -> Result<(), String> {
    if crate::cargo()
        .args(["fuzz", "--version"])
        .output()
        .is_ok_and(|o| o.status.success())
    {
        return Ok(());
    }
    run(crate::cargo().args(["install", "cargo-fuzz", "--locked", "--version", CARGO_FUZZ]))
}
