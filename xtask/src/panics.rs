//! `cargo xtask panic-proof`: the release firmware never panics.
//!
//! 1. **Proof at link time** for the portable logic: `panic-proof/` drives every entry
//!    point of the controller and every model and scheme of solver-core on opaque
//!    inputs, with `panic-never` as its panic handler. It links only if no panicking
//!    branch is left.
//! 2. **Per path** for the rest: the STM32H743 firmware is scanned for every branch
//!    into the panic machinery (Thumb-2 `b`/`bl`, conditional or not), each located by
//!    its debug information. Each must be listed, with the reason it cannot be taken,
//!    in docs/PANICS.md; none may be in our own crates.

use std::collections::BTreeMap;
use std::path::Path;

use object::{Object, ObjectSection, ObjectSymbol};

use crate::firmware::{self, root, Board};
use crate::{cargo, qemu, run, setup};

/// Our crates: a panicking branch here fails the check outright.
const OURS: [&str; 4] = [
    "solver-core/",
    "controller/",
    "firmware/src",
    "panic-proof/",
];

/// Symbols of the panic machinery (demangled prefixes).
const PANIC_FNS: [&str; 7] = [
    "core::panicking::",
    "core::slice::index::slice_",
    "core::option::unwrap_failed",
    "core::option::expect_failed",
    "core::result::unwrap_failed",
    "core::str::slice_error_fail",
    "core::cell::panic_",
];

/// Runs both steps and prints the remaining paths.
pub fn panic_proof() -> Result<(), String> {
    setup::ensure_target()?;
    run(cargo().current_dir(root()).args([
        "build",
        "--release",
        "--quiet",
        "--manifest-path",
        "panic-proof/Cargo.toml",
        "--target",
        setup::TARGET,
    ]))
    .map_err(|e| format!("{e}\nthe portable logic has a panicking branch: list them with `cargo xtask panic-proof --report`"))?;
    println!("solver-core and controller: no panicking branch (panic-never links, panic-proof/)");
    let documented = std::fs::read_to_string(root().join("docs/PANICS.md"))
        .map_err(|e| format!("docs/PANICS.md: {e}"))?;
    let mut failures = Vec::new();
    // The default scene, and the scenes with manual mode (their firmware links the
    // operator's generator and the model on `Steered`): the branches left in the
    // board's own build, which the proof above does not link (RTIC, defmt, the HAL).
    for scene in [
        host_tests::DEFAULT_SCENE,
        qemu::MANUAL_SCENE,
        qemu::CRANE3D_MANUAL_SCENE,
    ] {
        let elf = firmware::build(Board::Stm32h743, &root().join(scene))?;
        let sites = panic_sites(&elf)?;
        println!(
            "\nBranches into the panic machinery left in the STM32H743 firmware of {scene}, by source:"
        );
        check_sites(&sites, &documented, &mut failures);
    }
    failures.sort();
    failures.dedup();
    if failures.is_empty() {
        println!("every one is justified in docs/PANICS.md");
        Ok(())
    } else {
        Err(format!(
            "panicking branches without a justification in docs/PANICS.md (or in our own crates): {failures:?}"
        ))
    }
}

/// Lists `sites` and adds to `failures` each that is ours or not justified in
/// `documented` (docs/PANICS.md).
fn check_sites(sites: &BTreeMap<String, usize>, documented: &str, failures: &mut Vec<String>) {
    for (key, count) in sites {
        let listed = documented.contains(&format!("`{key}`"));
        let ours = OURS.iter().any(|o| key.starts_with(o));
        println!(
            "  {count:>2} × {key}{}",
            if listed {
                ""
            } else {
                "   <- not in docs/PANICS.md"
            }
        );
        if ours || !listed {
            failures.push(key.clone());
        }
    }
}

/// The portable logic's panicking branches, for fixing them (`--report`): the proof
/// binary linked with an ordinary panic handler, then scanned.
pub fn report() -> Result<(), String> {
    setup::ensure_target()?;
    let target_dir = root().join("target/panic-proof-report");
    run(cargo()
        .current_dir(root())
        .args([
            "build",
            "--release",
            "--quiet",
            "--manifest-path",
            "panic-proof/Cargo.toml",
        ])
        .args([
            "--no-default-features",
            "--features",
            "report",
            "--target",
            setup::TARGET,
            "--target-dir",
        ])
        .arg(&target_dir))?;
    let elf = target_dir.join(setup::TARGET).join("release/panic-proof");
    for (key, count) in panic_sites(&elf)? {
        println!("  {count:>2} × {key}");
    }
    Ok(())
}

/// Every branch into a panic function, keyed by the innermost source location outside
/// `core` (for a shared panic block, the branches into the block).
fn panic_sites(elf: &Path) -> Result<BTreeMap<String, usize>, String> {
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*bytes).map_err(|e| e.to_string())?;
    let text = file.section_by_name(".text").ok_or("no .text")?;
    let (base, code) = (text.address(), text.data().map_err(|e| e.to_string())?);
    let mut functions: Vec<(u64, u64, String)> = file
        .symbols()
        .filter(|s| s.kind() == object::SymbolKind::Text && s.size() > 0)
        .filter_map(|s| {
            let name = s.name().ok()?;
            Some((
                s.address() & !1,
                s.size(),
                format!("{:#}", rustc_demangle::demangle(name)),
            ))
        })
        .collect();
    functions.sort();
    let in_panic_fn = |addr: u64| {
        functions.iter().any(|(a, size, name)| {
            (*a..a + size).contains(&addr) && PANIC_FNS.iter().any(|p| name.starts_with(p))
        })
    };
    let targets: Vec<u64> = functions
        .iter()
        .filter(|(_, _, name)| PANIC_FNS.iter().any(|p| name.starts_with(p)))
        .map(|(a, _, _)| *a)
        .collect();
    let branches = decode_branches(base, code);
    let loader = addr2line::Loader::new(elf).map_err(|e| e.to_string())?;
    let mut sites = BTreeMap::new();
    for &(at, _, _) in branches
        .iter()
        .filter(|(at, t, _)| targets.contains(t) && !in_panic_fn(*at))
    {
        // A panic block reached by jumps (often shared): the jumps into the few
        // instructions before the call are the paths.
        let mut sources: Vec<u64> = branches
            .iter()
            .filter(|(_, t, jump)| *jump && (at.saturating_sub(24)..=at).contains(t))
            .map(|(a, _, _)| *a)
            .collect();
        if sources.is_empty() {
            sources.push(at);
        }
        for source in sources {
            if let Some(key) = innermost(&loader, source) {
                *sites.entry(key).or_insert(0) += 1;
            }
        }
    }
    Ok(sites)
}

/// The innermost frame outside the standard library (line 0: no source line).
fn innermost(loader: &addr2line::Loader, addr: u64) -> Option<String> {
    let mut frames = loader.find_frames(addr).ok()?;
    while let Ok(Some(frame)) = frames.next() {
        let Some(loc) = frame.location else { continue };
        let (Some(file), Some(line)) = (loc.file, loc.line) else {
            continue;
        };
        if line == 0 || file.contains("/library/") || file.contains("/rustc/") {
            continue;
        }
        let file = file
            .split("/index.crates.io-")
            .nth(1)
            .and_then(|f| f.split_once('/').map(|(_, f)| f))
            .or_else(|| file.strip_prefix(&format!("{}/", root().display())))
            .unwrap_or(file);
        return Some(format!("{file}:{line}"));
    }
    None
}

/// Every Thumb-2 branch in `code` (at `base`): `(address, target, jump)`, `jump` for a
/// branch that is not a call (`b`, `b<c>`, `cbz`). Every halfword is tried, so data in
/// the code may add spurious branches: the list errs on the side of more paths.
fn decode_branches(base: u64, code: &[u8]) -> Vec<(u64, u64, bool)> {
    let half = |i: usize| {
        code.get(i..i + 2)
            .map(|b| u32::from(u16::from_le_bytes([b[0], b[1]])))
    };
    let sign = |v: u32, bits: u32| -> i64 {
        let v = i64::from(v);
        if v & (1 << (bits - 1)) != 0 {
            v - (1 << bits)
        } else {
            v
        }
    };
    let mut out = Vec::new();
    let mut i = 0;
    while let Some(h1) = half(i) {
        let at = base + i as u64;
        let pc = at as i64 + 4;
        if h1 >> 11 == 0b11110 {
            if let Some(h2) = half(i + 2) {
                let s = (h1 >> 10) & 1;
                let (j1, j2) = ((h2 >> 13) & 1, (h2 >> 11) & 1);
                if h2 & 0x9000 == 0x9000 {
                    // BL, or B.W (T4).
                    let (i1, i2) = (1 - (j1 ^ s), 1 - (j2 ^ s));
                    let off = (s << 24)
                        | (i1 << 23)
                        | (i2 << 22)
                        | ((h1 & 0x3ff) << 12)
                        | ((h2 & 0x7ff) << 1);
                    let call = h2 >> 14 & 1 == 1;
                    out.push((at, (pc + sign(off, 25)) as u64, !call));
                } else if h2 >> 14 == 0b10 && h2 >> 12 & 1 == 0 && (h1 >> 6) & 0xf < 14 {
                    // B<c>.W (T3).
                    let off = (s << 20)
                        | (j2 << 19)
                        | (j1 << 18)
                        | ((h1 & 0x3f) << 12)
                        | ((h2 & 0x7ff) << 1);
                    out.push((at, (pc + sign(off, 21)) as u64, true));
                }
            }
        } else if h1 >> 11 == 0b11100 {
            out.push((at, (pc + sign((h1 & 0x7ff) << 1, 12)) as u64, true));
        } else if h1 >> 12 == 0b1101 && (h1 >> 8) & 0xf < 14 {
            out.push((at, (pc + sign((h1 & 0xff) << 1, 9)) as u64, true));
        } else if h1 & 0xf500 == 0xb100 {
            // CBZ/CBNZ.
            let off = (((h1 >> 9) & 1) << 6) | (((h1 >> 3) & 0x1f) << 1);
            out.push((at, (pc + i64::from(off)) as u64, true));
        }
        i += 2;
    }
    out
}

/// Formatting and lints of the proof crate (not in the host workspace).
pub fn lint() -> Result<(), String> {
    run(cargo().current_dir(root()).args([
        "fmt",
        "--manifest-path",
        "panic-proof/Cargo.toml",
        "--",
        "--check",
    ]))?;
    run(cargo().current_dir(root()).args([
        "clippy",
        "--release",
        "--manifest-path",
        "panic-proof/Cargo.toml",
        "--target",
        setup::TARGET,
        "--",
        "-D",
        "warnings",
    ]))
}
