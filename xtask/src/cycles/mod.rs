//! `cargo xtask cycles`: Cortex-M7 cycles per 100 Hz step, estimated from QEMU's
//! execution trace.
//!
//! QEMU counts instructions; a Cortex-M7 spends between half a cycle (two issued at
//! once) and thirty (a double divide) on one. Debian's QEMU 7.2 is built without TCG
//! plugins, so the firmware runs with `-d in_asm,exec,nochain`: every translated
//! block's disassembly once, then every execution of a block in order. The log is
//! streamed through a FIFO (a run writes about 1 GB) into [`m7`]'s timing model,
//! which issues every executed instruction, in order, through three pipelines (lower
//! bound, point estimate, upper bound).
//!
//! A step's window is the firmware's own cost window: `Board::counter` (never inlined
//! on the QEMU board) is entered once before the tick and once after it, so the
//! instructions between two entries are the ones the firmware's `cost` line counts
//! from QEMU's virtual clock. The two counts are compared step by step and must agree
//! within [`WINDOW_SLACK`] instructions — the check that the trace and the windows
//! are read right.

pub mod m7;

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::rc::Rc;

use m7::{Class, Insn, Pipeline, Predictor, Setting};
use object::{Object, ObjectSymbol};
use sim::HEALTHY;

use crate::defmt_log;
use crate::firmware::{self, parse_cost, root, Board};
use crate::setup;

/// The core clock the µs are given for (the STM32H743's maximum).
pub const CLOCK_MHZ: f64 = 480.0;

/// How far a step's instructions in the trace may lie from the firmware's own count:
/// the counter's call and return are on different sides of the two readings, and the
/// virtual clock rounds to 3.2 timer ticks per instruction.
pub const WINDOW_SLACK: i64 = 16;

const SETTINGS: [Setting; 3] = [Setting::Lower, Setting::Point, Setting::Upper];

/// One step as the trace saw it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Step {
    /// QEMU instructions in the window.
    pub instructions: u64,
    /// Estimated cycles: lower bound, point estimate, upper bound.
    pub cycles: [u64; 3],
}

/// Everything the trace of one run gave.
#[derive(Debug, Default)]
pub struct Traced {
    /// Each step's window.
    pub steps: Vec<Step>,
    /// Instructions executed in the whole run.
    pub instructions: u64,
    /// Blocks executed that no disassembly was found for (their instructions are
    /// missing from the estimate; must be 0).
    pub unknown_blocks: u64,
    /// Blocks logged as executed that QEMU then stopped before their first
    /// instruction (not counted), or rewound to an I/O access inside them (counted up
    /// to it).
    pub stopped_blocks: u64,
}

/// The state carried through the trace.
struct Reader {
    counter: u32,
    by_host: HashMap<u64, Rc<[Insn]>>,
    by_pc: HashMap<u32, Rc<[Insn]>>,
    translating: Option<Vec<Insn>>,
    translated: Option<Rc<[Insn]>>,
    /// The block whose execution was logged last, with its host address: it counts
    /// once the next line shows that it was not stopped before it began.
    logged: Option<(u64, Rc<[Insn]>)>,
    previous: Option<Rc<[Insn]>>,
    pipelines: [Pipeline; 3],
    predictor: Predictor,
    open: Option<Step>,
    out: Traced,
}

impl Reader {
    fn new(counter: u32) -> Self {
        Self {
            counter,
            by_host: HashMap::new(),
            by_pc: HashMap::new(),
            translating: None,
            translated: None,
            logged: None,
            previous: None,
            pipelines: SETTINGS.map(Pipeline::new),
            predictor: Predictor::default(),
            open: None,
            out: Traced::default(),
        }
    }

    fn now(&self) -> Step {
        Step {
            instructions: self.out.instructions,
            cycles: [0, 1, 2].map(|i| self.pipelines[i].cycles()),
        }
    }

    fn line(&mut self, line: &str) {
        if line.starts_with("IN:") {
            self.translating = Some(Vec::new());
        } else if line.starts_with("0x") {
            if let (Some(block), Some(insn)) = (self.translating.as_mut(), m7::decode(line)) {
                block.push(insn);
            }
        } else if line.is_empty() || line.starts_with("---") {
            if let Some(block) = self.translating.take().filter(|b| !b.is_empty()) {
                let block: Rc<[Insn]> = block.into();
                self.by_pc.insert(block[0].address, Rc::clone(&block));
                self.translated = Some(block);
            }
        } else if let Some(rest) = line.strip_prefix("Trace ") {
            if let Some((host, pc)) = parse_trace(rest) {
                self.logged_execution(host, pc);
            }
        } else if let Some(rest) =
            line.strip_prefix("cpu_io_recompile: rewound execution of TB to ")
        {
            // An I/O access inside the block under -icount: the instructions before it
            // ran, QEMU rewinds to the access and runs it as a block of its own.
            let pc = u32::from_str_radix(rest.trim().trim_start_matches("0x"), 16).ok();
            if let (Some(pc), Some((host, block))) = (pc, self.logged.take()) {
                match block.iter().position(|i| i.address == pc) {
                    Some(0) => self.out.stopped_blocks += 1,
                    Some(k) => {
                        self.out.stopped_blocks += 1;
                        self.logged = Some((host, block[..k].into()));
                    }
                    None => self.logged = Some((host, block)),
                }
            }
        } else if let Some(rest) = line.strip_prefix("Stopped execution of TB chain before ") {
            // The instruction budget (-icount) ran out before the block began: QEMU
            // logged its execution, but none of its instructions ran.
            let host = rest
                .split_whitespace()
                .next()
                .and_then(|h| u64::from_str_radix(h.strip_prefix("0x")?, 16).ok());
            if self.logged.as_ref().map(|(h, _)| Some(*h)) == Some(host) {
                self.logged = None;
                self.out.stopped_blocks += 1;
            }
        }
    }

    /// The end of the trace: the last block logged ran.
    fn finish(&mut self) {
        self.line("");
        if let Some((_, block)) = self.logged.take() {
            self.execute(block);
        }
    }

    fn logged_execution(&mut self, host: u64, pc: u32) {
        if let Some((_, block)) = self.logged.take() {
            self.execute(block);
        }
        // A block just translated runs at once: it is the one this host address names
        // from now on.
        if let Some(block) = self.translated.take() {
            if block[0].address == pc {
                self.by_host.insert(host, block);
            }
        }
        let block = self
            .by_host
            .get(&host)
            .filter(|b| b[0].address == pc)
            .or_else(|| self.by_pc.get(&pc))
            .cloned();
        match block {
            Some(block) => self.logged = Some((host, block)),
            None => {
                self.out.unknown_blocks += 1;
                self.previous = None;
            }
        }
    }

    /// A block that ran: the outcome of the last one's branch, a window's end or
    /// start, its instructions issued.
    fn execute(&mut self, block: Rc<[Insn]>) {
        let pc = block[0].address;
        if let Some(last) = self.previous.as_ref().and_then(|b| b.last()) {
            self.branch(*last, pc);
        }
        if pc == self.counter {
            match self.open.take() {
                None => self.open = Some(self.now()),
                Some(start) => {
                    let end = self.now();
                    self.out.steps.push(Step {
                        instructions: end.instructions - start.instructions,
                        cycles: [0, 1, 2].map(|i| end.cycles[i] - start.cycles[i]),
                    });
                }
            }
        }
        for insn in block.iter() {
            for p in &mut self.pipelines {
                p.issue(insn);
            }
        }
        self.out.instructions += block.len() as u64;
        self.previous = Some(block);
    }

    /// The outcome of the block's last instruction, a branch, seen from where
    /// execution went next; an exception entry in between is not an outcome.
    fn branch(&mut self, last: Insn, to: u32) {
        let Class::Branch {
            conditional,
            indirect,
        } = last.class
        else {
            return;
        };
        let fallthrough = last.address + last.size;
        let taken = to != fallthrough;
        if taken && !indirect && last.target != Some(to) {
            return;
        }
        if self
            .predictor
            .mispredicted(last.address, conditional, taken, to)
        {
            self.pipelines[1].mispredict();
        }
        if conditional || indirect {
            self.pipelines[2].mispredict();
        }
    }
}

/// `0: 0x7f317c000100 [00800408/00000050/00000110/ff020200] Reset` → (host, pc).
fn parse_trace(rest: &str) -> Option<(u64, u32)> {
    let mut words = rest.split_whitespace();
    words.next()?;
    let host = u64::from_str_radix(words.next()?.strip_prefix("0x")?, 16).ok()?;
    let fields = words.next()?.trim_start_matches('[');
    let pc = fields.split('/').nth(1)?;
    Some((host, u32::from_str_radix(pc, 16).ok()?))
}

/// Reads a trace.
pub fn read_trace(input: impl BufRead, counter: u32) -> Result<Traced, String> {
    let mut reader = Reader::new(counter);
    for line in input.split(b'\n') {
        let line = line.map_err(|e| format!("reading the trace: {e}"))?;
        reader.line(String::from_utf8_lossy(&line).trim_end());
    }
    reader.finish();
    Ok(reader.out)
}

/// The address of `firmware::board::qemu::Board::counter` in `elf`.
fn counter_address(elf: &Path) -> Result<u32, String> {
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*bytes).map_err(|e| e.to_string())?;
    let mut found = file.symbols().filter(|s| {
        s.name().is_ok_and(|n| {
            format!("{:#}", rustc_demangle::demangle(n)) == "firmware::board::qemu::Board::counter"
        })
    });
    match (found.next(), found.next()) {
        (Some(s), None) => Ok((s.address() & !1) as u32),
        (None, _) => Err(format!(
            "{}: no symbol firmware::board::qemu::Board::counter (inlined?)",
            elf.display()
        )),
        (Some(_), Some(_)) => Err("Board::counter is in the ELF twice".to_string()),
    }
}

/// The estimate for one scene, checked against the firmware's own instruction counts.
pub struct Estimate {
    /// The scene file, relative to the repository.
    pub scene: String,
    /// Each step.
    pub steps: Vec<Step>,
    /// The largest difference between a step's instructions in the trace and in the
    /// firmware's cost line.
    pub worst_mismatch: i64,
}

/// Runs `scene`'s QEMU firmware with the execution trace and estimates every step's
/// cycles: on the healthy bus, the feedback scene on the plant it closes the loop
/// around (as `qemu-bench` measures them).
pub fn estimate(scene: &str) -> Result<Estimate, String> {
    let scenario = if scene == crate::qemu::FEEDBACK_SCENE {
        sim::CLOSED_LOOP
    } else {
        HEALTHY
    };
    setup::ensure_qemu()?;
    let path = root().join(scene);
    let elf = firmware::build(Board::Qemu, &path)?;
    let counter = counter_address(&elf)?;
    let dir = elf.with_extension("cycles");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let fifo = dir.join("trace.fifo");
    let _ = std::fs::remove_file(&fifo);
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .map_err(|e| format!("mkfifo: {e}"))?;
    if !made.success() {
        return Err(format!("mkfifo {} failed", fifo.display()));
    }
    let log_path = dir.join("run.defmt");
    let log = File::create(&log_path).map_err(|e| format!("{}: {e}", log_path.display()))?;
    let mut child = firmware::qemu_command(&elf, &scenario)
        .args(["-d", "in_asm,exec,nochain", "-D"])
        .arg(&fifo)
        .stdout(log)
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    let input = File::open(&fifo).map_err(|e| format!("{}: {e}", fifo.display()));
    let traced = input.and_then(|f| read_trace(BufReader::with_capacity(1 << 20, f), counter));
    let status = child.wait().map_err(|e| e.to_string())?;
    let _ = std::fs::remove_file(&fifo);
    let traced = traced?;
    if !status.success() {
        return Err(format!("{scene}: QEMU exited with {status}"));
    }
    if traced.unknown_blocks != 0 {
        return Err(format!(
            "{scene}: {} executed blocks without a disassembly in the trace",
            traced.unknown_blocks
        ));
    }
    let elf_bytes = std::fs::read(&elf).map_err(|e| e.to_string())?;
    let raw = std::fs::read(&log_path).map_err(|e| e.to_string())?;
    let lines = defmt_log::decode(&elf_bytes, &raw)?;
    let costs: Vec<u64> = lines
        .iter()
        .filter_map(|l| parse_cost(l))
        .map(|c| c.instructions)
        .collect();
    check_windows(scene, &traced.steps, &costs).map(|worst_mismatch| Estimate {
        scene: scene.to_string(),
        steps: traced.steps,
        worst_mismatch,
    })
}

/// Every step's window against the firmware's own count of its instructions (its cost
/// lines, from the traced run or from another run of the same firmware); the largest
/// difference.
pub(crate) fn check_windows(scene: &str, steps: &[Step], costs: &[u64]) -> Result<i64, String> {
    if steps.len() != costs.len() || steps.is_empty() {
        return Err(format!(
            "{scene}: {} windows in the trace, {} steps counted by the firmware",
            steps.len(),
            costs.len()
        ));
    }
    let mut worst = 0_i64;
    for (i, (s, &c)) in steps.iter().zip(costs).enumerate() {
        let d = s.instructions as i64 - c as i64;
        if d.abs() > WINDOW_SLACK {
            return Err(format!(
                "{scene}: step {i} has {} instructions in the trace, {c} in the firmware's count",
                s.instructions
            ));
        }
        worst = worst.max(d.abs());
    }
    Ok(worst)
}

/// Mean and maximum of a column.
fn mean_max(steps: &[Step], f: impl Fn(&Step) -> u64) -> (f64, u64) {
    let sum: u64 = steps.iter().map(&f).sum();
    let max = steps.iter().map(&f).max().unwrap_or(0);
    (sum as f64 / steps.len().max(1) as f64, max)
}

/// The table row of one estimate.
fn row(e: &Estimate) -> String {
    let (imean, imax) = mean_max(&e.steps, |s| s.instructions);
    let c = |k: usize| mean_max(&e.steps, move |s| s.cycles[k]);
    let ((lm, lx), (pm, px), (um, ux)) = (c(0), c(1), c(2));
    format!(
        "| {} | {imean:.0} / {imax} | {lm:.0} / {pm:.0} / {um:.0} | {lx} / {px} / {ux} | {:.1} / {:.1} (≤ {:.1}) |",
        e.scene,
        pm / CLOCK_MHZ,
        px as f64 / CLOCK_MHZ,
        ux as f64 / CLOCK_MHZ,
    )
}

/// `cargo xtask cycles`: the estimate for each scene, a table, and per-step CSVs in
/// `target/cycles/`.
pub fn cycles(scenes: &[String]) -> Result<(), String> {
    let out_dir = root().join("target/cycles");
    std::fs::create_dir_all(&out_dir).map_err(|e| e.to_string())?;
    let mut rows = Vec::new();
    for scene in scenes {
        let e = estimate(scene)?;
        let csv = out_dir.join(csv_name(scene));
        write_csv(&csv, &e.steps)?;
        eprintln!(
            "{scene}: {} steps, trace and firmware counts within {} instructions; {}",
            e.steps.len(),
            e.worst_mismatch,
            csv.display()
        );
        rows.push(row(&e));
    }
    println!(
        "\nEstimated Cortex-M7 cycles per 100 Hz step (the controller's whole tick), from QEMU's \
         execution trace through the timing model of xtask/src/cycles/m7.rs — lower bound / \
         point estimate / upper bound; caches, TCM and flash wait states ignored:\n"
    );
    println!(
        "| scene | QEMU instructions mean / max | cycles mean: lower / point / upper | cycles max: lower / point / upper | µs at {CLOCK_MHZ:.0} MHz: point mean / max (upper max) |"
    );
    println!("|---|---:|---:|---:|---:|");
    for r in rows {
        println!("{r}");
    }
    Ok(())
}

fn csv_name(scene: &str) -> PathBuf {
    let stem = Path::new(scene)
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    PathBuf::from(format!("{stem}.csv"))
}

fn write_csv(path: &Path, steps: &[Step]) -> Result<(), String> {
    let mut f = File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut text = String::from("step,instructions,cycles_lower,cycles_point,cycles_upper\n");
    for (i, s) in steps.iter().enumerate() {
        text.push_str(&format!(
            "{i},{},{},{},{}\n",
            s.instructions, s.cycles[0], s.cycles[1], s.cycles[2]
        ));
    }
    f.write_all(text.as_bytes())
        .map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-written trace in QEMU's format: a loop of two blocks run three times,
    /// with the counter's block entered before and after.
    const TRACE: &str = "\
----------------
IN: counter
0x00000100:  4770       bx       lr

Trace 0: 0x7f0000000100 [00800408/00000100/00000110/ff020200] counter
----------------
IN: work
0x00000200:  ee20 0b01  vmul.f64 d0, d0, d1
0x00000204:  3801       subs     r0, #1
0x00000206:  d1fb       bne      #0x200

Trace 0: 0x7f0000000200 [00800408/00000200/00000110/ff020200] work
Trace 0: 0x7f0000000200 [00800408/00000200/00000110/ff020200] work
Trace 0: 0x7f0000000200 [00800408/00000200/00000110/ff020200] work
----------------
IN: after
0x00000208:  4770       bx       lr

Trace 0: 0x7f0000000300 [00800408/00000208/00000110/ff020200] after
Trace 0: 0x7f0000000100 [00800408/00000100/00000110/ff020200] counter
";

    #[test]
    fn a_window_is_what_runs_between_two_counter_entries() {
        let t = read_trace(TRACE.as_bytes(), 0x100).unwrap();
        assert_eq!(t.unknown_blocks, 0);
        assert_eq!(t.instructions, 1 + 9 + 1 + 1);
        assert_eq!(t.steps.len(), 1);
        let s = t.steps[0];
        assert_eq!(
            s.instructions,
            1 + 9 + 1,
            "counter's own block, loop, after"
        );
        let [lower, point, upper] = s.cycles;
        assert!(lower <= point && point <= upper, "{:?}", s.cycles);
        // Each vmul.f64 depends on the last through d0 (7 cycles) in the point
        // estimate; the lower bound sees only issue.
        assert!(point >= 3 * 7, "{point}");
        assert!(lower <= 8, "{lower}");
        assert!(s.instructions / 2 <= lower);
    }

    #[test]
    fn a_block_stopped_before_it_began_is_not_counted() {
        let stopped = TRACE.replacen(
            "Trace 0: 0x7f0000000300 [00800408/00000208/00000110/ff020200] after\n",
            "Trace 0: 0x7f0000000300 [00800408/00000208/00000110/ff020200] after\n\
             Stopped execution of TB chain before 0x7f0000000300 [00000208] after\n\
             Trace 0: 0x7f0000000300 [00800408/00000208/00000110/ff020200] after\n",
            1,
        );
        let t = read_trace(stopped.as_bytes(), 0x100).unwrap();
        assert_eq!(t.stopped_blocks, 1);
        assert_eq!(t.steps[0].instructions, 1 + 9 + 1);
    }

    #[test]
    fn a_block_rewound_for_an_io_access_counts_once() {
        let rewound = TRACE.replacen(
            "Trace 0: 0x7f0000000300 [00800408/00000208/00000110/ff020200] after\n",
            "Trace 0: 0x7f0000000300 [00800408/00000208/00000110/ff020200] after\n\
             cpu_io_recompile: rewound execution of TB to 00000208\n\
             Trace 0: 0x7f0000000300 [00800408/00000208/00000110/ff020200] after\n",
            1,
        );
        let t = read_trace(rewound.as_bytes(), 0x100).unwrap();
        assert_eq!(t.stopped_blocks, 1);
        assert_eq!(t.steps[0].instructions, 1 + 9 + 1);
        // Rewound to its third instruction: the first two ran.
        let mid = TRACE.replacen(
            "Trace 0: 0x7f0000000200 [00800408/00000200/00000110/ff020200] work\n",
            "Trace 0: 0x7f0000000200 [00800408/00000200/00000110/ff020200] work\n\
             cpu_io_recompile: rewound execution of TB to 00000206\n",
            1,
        );
        let t = read_trace(mid.as_bytes(), 0x100).unwrap();
        assert_eq!(t.steps[0].instructions, 1 + 2 + 6 + 1);
    }

    #[test]
    fn a_block_without_disassembly_is_counted_not_guessed() {
        let t = read_trace(
            "Trace 0: 0x7f0000000900 [00800408/00000900/00000110/ff020200] x\n".as_bytes(),
            0x100,
        )
        .unwrap();
        assert_eq!((t.unknown_blocks, t.instructions), (1, 0));
    }

    #[test]
    fn windows_that_disagree_with_the_firmware_are_refused() {
        let steps = [Step {
            instructions: 1000,
            cycles: [500, 900, 2000],
        }];
        assert_eq!(check_windows("s", &steps, &[995]), Ok(5));
        assert!(check_windows("s", &steps, &[900]).is_err());
        assert!(check_windows("s", &steps, &[1000, 1000]).is_err());
        assert!(check_windows("s", &[], &[]).is_err());
    }
}
