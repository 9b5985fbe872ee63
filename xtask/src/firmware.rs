//! Building the firmware for a scene, running it under QEMU, and reading its log.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use host_tests::dbc::Dbc;
use sim::Scenario;

use crate::{cargo, defmt_log, run, setup};

/// The boards the firmware builds for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Board {
    /// QEMU mps2-an500.
    Qemu,
    /// The STM32H743 drive controller.
    Stm32h743,
}

impl Board {
    fn feature(self) -> &'static str {
        match self {
            Board::Qemu => "qemu",
            Board::Stm32h743 => "stm32h743",
        }
    }
}

/// The repository root (xtask runs from anywhere inside it).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default()
}

/// `cargo <subcommand>` on the firmware for `board`, release, for the drive's target.
///
/// Every scene and both boards build in one target directory, `target/firmware/cargo`:
/// the dependencies and the build's host tools (proc macros, build scripts) are compiled
/// once. A directory per scene held them once per scene, 18 times over, some 9 GB: more
/// than a CI machine's disk may have to spare. The firmware crate itself is rebuilt when
/// the scene changes, so [`build`] copies each scene's ELF out to a place of its own.
fn firmware_cargo(subcommand: &str, board: Board) -> (Command, PathBuf) {
    let target_dir = root().join("target/firmware/cargo");
    let mut cmd = cargo();
    cmd.current_dir(root())
        .env("DEFMT_LOG", "info")
        .args([
            subcommand,
            "--release",
            "--quiet",
            "--manifest-path",
            "firmware/Cargo.toml",
            "--features",
            board.feature(),
        ])
        .args(["--target", setup::TARGET, "--target-dir"])
        .arg(&target_dir);
    (cmd, target_dir)
}

/// Runs the firmware build `cmd` for `scene` and copies its ELF to
/// `target/firmware/<board>-<name>/firmware`, where it stays while other scenes build (the
/// QEMU runs' logs are written beside it). Returns that path.
fn build_into(
    mut cmd: Command,
    target_dir: &Path,
    scene: &Path,
    own: &str,
) -> Result<PathBuf, String> {
    run(cmd.env("SCENE", scene))?;
    let built = target_dir.join(setup::TARGET).join("release/firmware");
    let dir = root().join("target/firmware").join(own);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let elf = dir.join("firmware");
    std::fs::copy(&built, &elf)
        .map_err(|e| format!("{} -> {}: {e}", built.display(), elf.display()))?;
    Ok(elf)
}

/// The file name's stem of `scene`, which names its build.
fn scene_name(scene: &Path) -> &str {
    scene
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("scene")
}

/// Builds the release firmware for `board` and `scene`; returns the ELF's path.
pub fn build(board: Board, scene: &Path) -> Result<PathBuf, String> {
    setup::ensure_target()?;
    let (mut cmd, target_dir) = firmware_cargo("build", board);
    if board == Board::Qemu && closes_loop(scene)? {
        cmd.args(["--features", "plant"]);
    }
    let own = format!("{}-{}", board.feature(), scene_name(scene));
    build_into(cmd, &target_dir, scene, &own)
}

/// Builds the QEMU firmware for `scene` with the inverse model stubbed out (feature
/// `stub-inverse-model`): the same firmware without model, integrator and Newton, whose
/// flash subtracted from the real build's is the solver's share. Returns the ELF's path.
pub fn build_without_inverse_model(scene: &Path) -> Result<PathBuf, String> {
    setup::ensure_target()?;
    let (mut cmd, target_dir) = firmware_cargo("build", Board::Qemu);
    if closes_loop(scene)? {
        cmd.args(["--features", "plant"]);
    }
    cmd.args(["--features", "stub-inverse-model"]);
    let own = format!("qemu-{}-stub-inverse-model", scene_name(scene));
    build_into(cmd, &target_dir, scene, &own)
}

/// Whether `scene` closes the loop: its QEMU scenarios run on the virtual bus's plant
/// and inclinometer (feature `plant`); other scenes do not link them.
fn closes_loop(scene: &Path) -> Result<bool, String> {
    Ok(scene::Scene::load(scene)
        .map_err(|e| format!("{}: {e}", scene.display()))?
        .feedback
        .is_some())
}

/// "Model only what a scene requires": the firmware built for `elf`'s scene links the
/// model module `own` (a path component of its symbols, e.g. `crane_subs`) and none of
/// `others` (every other crane's). Symbols of functions the optimiser inlined are gone,
/// so the check sees what stays out of line — a module linked at all leaves some (its
/// `rest_state` at least), which the positive half checks.
pub fn links_only(elf: &Path, own: &str, others: &[&str]) -> Result<(), String> {
    use object::{Object, ObjectSymbol};
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*bytes).map_err(|e| format!("{}: {e}", elf.display()))?;
    let names: Vec<String> = file
        .symbols()
        .filter_map(|s| s.name().ok().map(str::to_string))
        .collect();
    if !names.iter().any(|n| n.contains(own)) {
        return Err(format!(
            "{}: no symbol of {own}, the scene's model",
            elf.display()
        ));
    }
    for other in others {
        if let Some(n) = names.iter().find(|n| n.contains(other)) {
            return Err(format!(
                "{}: links {other}, which its scene does not use ({n})",
                elf.display()
            ));
        }
    }
    Ok(())
}

/// Clippy on the firmware for `board`.
pub fn clippy(board: Board) -> Result<(), String> {
    let (mut cmd, _) = firmware_cargo("clippy", board);
    if board == Board::Qemu {
        cmd.args(["--features", "plant"]);
    }
    run(cmd.args(["--", "-D", "warnings"]))
}

/// What a QEMU run printed.
pub struct QemuRun {
    /// The decoded log, one line per message.
    pub lines: Vec<String>,
    /// Whether the firmware exited with success.
    pub success: bool,
}

/// QEMU's command line: mps2-an500 (Cortex-M7, DP FPU), semihosting for the log, the
/// exit code and the virtual bus's scenario (the command line's words after the
/// program's: its name and, if not 0, its cycles), and `-icount shift=7` so that
/// virtual time follows the instruction count.
pub fn qemu_command(elf: &Path, scenario: &Scenario) -> Command {
    let cycles = if scenario.cycles == 0 {
        String::new()
    } else {
        format!(",arg={}", scenario.cycles)
    };
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args([
        "-M",
        "mps2-an500",
        "-nographic",
        "-monitor",
        "none",
        "-serial",
        "none",
    ])
    .arg("-semihosting-config")
    .arg(format!(
        "enable=on,target=native,arg=firmware,arg={}{cycles}",
        scenario.name
    ))
    .args(["-icount", "shift=7,align=off,sleep=off"])
    .arg("-kernel")
    .arg(elf);
    cmd
}

/// Runs the firmware under QEMU on `scenario` (killed after `limit`) and decodes its log.
pub fn run_qemu(elf: &Path, scenario: &Scenario, limit: Duration) -> Result<QemuRun, String> {
    setup::ensure_qemu()?;
    let elf_bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let out_path = elf.with_extension(format!("{}.defmt", scenario.name));
    let out =
        std::fs::File::create(&out_path).map_err(|e| format!("{}: {e}", out_path.display()))?;
    let mut child = qemu_command(elf, scenario)
        .stdout(out)
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break status;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!("QEMU did not finish within {} s", limit.as_secs()));
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let bytes = std::fs::read(&out_path).map_err(|e| e.to_string())?;
    let lines = defmt_log::decode(&elf_bytes, &bytes)?;
    Ok(QemuRun {
        lines,
        success: status.success(),
    })
}

/// A transmitted frame from the log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Tx {
    /// Time of the cycle, ms.
    pub now_ms: u32,
    /// COB-ID.
    pub id: u16,
    /// Data.
    pub data: Vec<u8>,
}

/// Parses `tx <ms> <id> [bytes]` lines.
pub fn parse_tx(line: &str) -> Option<Tx> {
    let rest = line.strip_prefix("tx ")?;
    let (ms, rest) = rest.split_once(' ')?;
    let (id, rest) = rest.split_once(' ')?;
    let bytes = rest.trim().trim_start_matches('[').trim_end_matches(']');
    let data = if bytes.is_empty() {
        Vec::new()
    } else {
        bytes
            .split(',')
            .map(|b| u8::from_str_radix(b.trim().trim_start_matches("0x"), 16).ok())
            .collect::<Option<Vec<u8>>>()?
    };
    Some(Tx {
        now_ms: ms.parse().ok()?,
        id: u16::from_str_radix(id.trim_start_matches("0x"), 16).ok()?,
        data,
    })
}

/// One step's cost from a `cost <cycle> <instructions> <iterations> <jacobians> <solver>`
/// line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepCost {
    /// Cycle number.
    pub cycle: u32,
    /// QEMU instructions of the whole 100 Hz step (the controller's tick).
    pub instructions: u64,
    /// Newton iterations.
    pub iterations: u32,
    /// Jacobians formed (Broyden: re-initialisations).
    pub jacobians: u32,
    /// QEMU instructions of the inverse model's step alone, inside the tick (0: the
    /// cycle did not step it).
    pub solver: u64,
}

/// Parses a cost line.
pub fn parse_cost(line: &str) -> Option<StepCost> {
    let mut it = line.strip_prefix("cost ")?.split(' ');
    Some(StepCost {
        cycle: it.next()?.parse().ok()?,
        instructions: it.next()?.parse().ok()?,
        iterations: it.next()?.parse().ok()?,
        jacobians: it.next()?.parse().ok()?,
        solver: it.next()?.parse().ok()?,
    })
}

/// The log for people and for the golden file: frames decoded against the DBC,
/// everything else as printed, without the per-step cost lines (those are baselines).
pub fn readable_log(lines: &[String], dbc: &Dbc) -> Vec<String> {
    lines
        .iter()
        .filter(|l| !l.starts_with("cost ") && !l.starts_with("done: "))
        .map(|l| match parse_tx(l) {
            Some(tx) => match dbc.decode(tx.id, &tx.data) {
                Ok(d) => format!("{:>6} ms  {d}", tx.now_ms),
                Err(e) => format!("{:>6} ms  undecodable frame {:#05x}: {e}", tx.now_ms, tx.id),
            },
            None => l.clone(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_lines_parse() {
        assert_eq!(
            parse_tx("tx 1230 0x201 [0f, 00, 40, 42, 0f, 00]"),
            Some(Tx {
                now_ms: 1230,
                id: 0x201,
                data: vec![0x0f, 0, 0x40, 0x42, 0x0f, 0]
            })
        );
        assert_eq!(
            parse_tx("tx 0 0x080 []"),
            Some(Tx {
                now_ms: 0,
                id: 0x80,
                data: vec![]
            })
        );
        assert_eq!(
            parse_cost("cost 12 4567 2 1 2890"),
            Some(StepCost {
                cycle: 12,
                instructions: 4567,
                iterations: 2,
                jacobians: 1,
                solver: 2890
            })
        );
        // A line without the solver's window is not this firmware's.
        assert_eq!(parse_cost("cost 12 4567 2 1"), None);
        assert_eq!(parse_tx("cost 1 2 3"), None);
    }
}
