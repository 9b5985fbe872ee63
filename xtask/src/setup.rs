//! Installs what a fresh machine lacks: the Rust target (through rustup and the
//! pinned toolchain) and, for the QEMU runs, qemu-system-arm from Debian's packages.

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
