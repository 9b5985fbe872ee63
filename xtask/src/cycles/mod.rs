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
//! on the QEMU board) reads the timer once before the tick and once after it, so the
//! instructions from one execution of that read to the next are the ones the
//! firmware's `cost` line counts from QEMU's virtual clock. The windows are cut at the
//! read itself, not at the function's entry: an interrupt taken between the entry and
//! the read is inside the firmware's window when the read closes it and outside when
//! the read opens it (cut at the entries, the feedback scene's step 499 lost the 30
//! instructions of a SysTick handler to the next window). The read is the counter's
//! one load that does not take a constant from the literal pool, found in the trace's
//! disassembly of the counter's code (the symbol's address and size). The two counts
//! are compared step by step and must agree within [`WINDOW_SLACK`] instructions — the
//! check that the trace and the windows are read right.
//!
//! **The operator's generator** (issue 28; a scene with `[operator]`, run on its manual
//! profile): its share of each step is the code that runs between a call of
//! `Generator::advance` or `Generator::evaluate` (solver-core, never inlined for this) and
//! the return to the instruction after the call (after the call of the function that
//! tail-calls it, for a `b` straight to its entry) — the cycle's advance and every
//! evaluation the scheme makes at its stage times, with everything they call. A
//! generator window must open and close inside one step's window (checked); the steps
//! in which it ran are the manual-mode cycles the estimate is given for.

pub mod m7;

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufRead, BufReader, Write};
use std::ops::Range;
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
/// the virtual clock rounds to 3.2 timer ticks per instruction, so with the windows cut
/// at the timer read every step of every scene agrees within 1 (the slack is the one
/// set when the windows were cut at the counter's entry).
pub const WINDOW_SLACK: i64 = 16;

/// The deepest call chain kept for the generator's tail calls (deeper: the oldest
/// forgotten).
const MAX_CALL_DEPTH: usize = 64;

const SETTINGS: [Setting; 3] = [Setting::Lower, Setting::Point, Setting::Upper];

/// One step as the trace saw it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Step {
    /// QEMU instructions in the window.
    pub instructions: u64,
    /// Estimated cycles: lower bound, point estimate, upper bound.
    pub cycles: [u64; 3],
}

/// The generator's share of one step: its windows' sum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Share {
    /// QEMU instructions and estimated cycles in the generator's windows.
    pub cost: Step,
    /// How many windows (calls of the generator's functions) the step had.
    pub calls: u32,
}

/// Everything the trace of one run gave.
#[derive(Debug, Default)]
pub struct Traced {
    /// Each step's window.
    pub steps: Vec<Step>,
    /// Each step's share spent in the generator (all zero without one).
    pub generator: Vec<Share>,
    /// Instructions and point-estimate cycles inside the generator's windows, by the
    /// function (symbol) the instruction belongs to.
    pub generator_profile: HashMap<String, (u64, u64)>,
    /// Entries of a generator function neither straight after a call instruction nor by
    /// a tail call's direct branch (an interrupt taken between the call and the entry):
    /// windows not counted.
    pub unlinked_entries: u64,
    /// Instructions executed in the whole run.
    pub instructions: u64,
    /// Blocks executed that no disassembly was found for (their instructions are
    /// missing from the estimate; must be 0).
    pub unknown_blocks: u64,
    /// Blocks logged as executed that QEMU then stopped before their first
    /// instruction (not counted), or rewound to an I/O access inside them (counted up
    /// to it).
    pub stopped_blocks: u64,
    /// The address of `Board::counter`'s timer read (`None`: no disassembly of the
    /// counter's code showed one).
    pub read: Option<u32>,
    /// Generator windows still open when a step's window was cut (must be 0: a window
    /// that never found its return; dropped).
    pub generator_across_cuts: u64,
}

/// The functions whose windows are the generator's: their entry addresses, and every
/// function symbol of the ELF (sorted by address) to profile them by.
#[derive(Debug, Default, Clone)]
pub struct Probe {
    /// Entry addresses of `Generator::advance` and `Generator::evaluate`.
    pub entries: Vec<u32>,
    /// `(start, end, name)` of every function, sorted by start.
    pub functions: Vec<(u32, u32, Rc<str>)>,
}

impl Probe {
    fn function(&self, address: u32) -> Option<&Rc<str>> {
        let i = self.functions.partition_point(|(s, _, _)| *s <= address);
        let (start, end, name) = self.functions.get(i.checked_sub(1)?)?;
        (*start <= address && address < *end).then_some(name)
    }
}

/// The state carried through the trace.
struct Reader {
    /// The code of `Board::counter`.
    counter: Range<u32>,
    probe: Probe,
    /// The open generator window: where it returns to, the state at its start.
    generator_open: Option<(u32, Step)>,
    /// The current step's generator share so far.
    share: Share,
    /// The last instruction executed.
    last: Option<Insn>,
    /// Where the calls executed (`bl`, `blx`) and not yet returned from return to,
    /// innermost last (kept only with a generator to probe): a call or tail call of the
    /// generator returns to the innermost. An interrupt's calls return before it does,
    /// so they leave it as it was; a return seen deeper in it drops what lies above.
    returns: Vec<u32>,
    /// Instructions and point cycles by function inside the generator's windows.
    profile: HashMap<Rc<str>, (u64, u64)>,
    /// The address of its timer read, once its disassembly was seen.
    read: Option<u32>,
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
    fn new(counter: Range<u32>, probe: Probe) -> Self {
        Self {
            counter,
            probe,
            generator_open: None,
            share: Share::default(),
            last: None,
            returns: Vec::new(),
            profile: HashMap::new(),
            read: None,
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
                if self.read.is_none() {
                    self.read = block
                        .iter()
                        .find(|i| self.counter.contains(&i.address) && reads_memory(i))
                        .map(|i| i.address);
                }
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

    /// A block that ran: the outcome of the last one's branch, its instructions
    /// issued, a window's end and the next one's start at the counter's timer read.
    fn execute(&mut self, block: Rc<[Insn]>) {
        let pc = block[0].address;
        if let Some(last) = self.previous.as_ref().and_then(|b| b.last()) {
            self.branch(*last, pc);
        }
        let probing = !self.probe.entries.is_empty();
        if probing {
            // Returns land at a block's start.
            if let Some(i) = self.returns.iter().rposition(|r| *r == pc) {
                self.returns.truncate(i);
            }
        }
        for insn in block.iter() {
            if let Some((ret, start)) = self.generator_open {
                if insn.address == ret {
                    self.generator_open = None;
                    let end = self.now();
                    let s = &mut self.share;
                    s.calls += 1;
                    s.cost.instructions += end.instructions - start.instructions;
                    for (c, (e, b)) in s
                        .cost
                        .cycles
                        .iter_mut()
                        .zip(end.cycles.iter().zip(start.cycles))
                    {
                        *c += e - b;
                    }
                }
            }
            if self.generator_open.is_none() && self.probe.entries.contains(&insn.address) {
                // Called, or tail-called (`b` straight to it from a function that was
                // called last: it returns where that call does).
                let ret = match self.last {
                    Some(call) if call.links => Some(call.address + call.size),
                    Some(jump) if jump.target == Some(insn.address) => self.returns.last().copied(),
                    _ => None,
                };
                match ret {
                    Some(ret) => self.generator_open = Some((ret, self.now())),
                    None => self.out.unlinked_entries += 1,
                }
            }
            if Some(insn.address) == self.read {
                self.cut();
            }
            let before = self.pipelines[1].cycles();
            for p in &mut self.pipelines {
                p.issue(insn);
            }
            if self.generator_open.is_some() {
                if let Some(name) = self.probe.function(insn.address) {
                    let spent = self.pipelines[1].cycles() - before;
                    let e = self.profile.entry(Rc::clone(name)).or_default();
                    e.0 += 1;
                    e.1 += spent;
                }
            }
            self.out.instructions += 1;
            self.last = Some(*insn);
            if probing && insn.links {
                if self.returns.len() >= MAX_CALL_DEPTH {
                    self.returns.remove(0);
                }
                self.returns.push(insn.address + insn.size);
            }
        }
        self.previous = Some(block);
    }

    /// The timer read is about to run: a window closes, or one opens.
    fn cut(&mut self) {
        if self.generator_open.take().is_some() {
            self.out.generator_across_cuts += 1;
        }
        match self.open.take() {
            None => {
                self.open = Some(self.now());
                self.share = Share::default();
            }
            Some(start) => {
                let end = self.now();
                self.out.steps.push(Step {
                    instructions: end.instructions - start.instructions,
                    cycles: [0, 1, 2].map(|i| end.cycles[i] - start.cycles[i]),
                });
                self.out.generator.push(core::mem::take(&mut self.share));
            }
        }
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

/// Whether `insn` reads memory other than a constant in the literal pool (`ldr r0,
/// [pc, #8]`): in `Board::counter`, the timer read (its `pop` is a load multiple).
fn reads_memory(insn: &Insn) -> bool {
    matches!(insn.class, Class::Load | Class::LoadPair) && insn.address_reads & 1 << 15 == 0
}

/// Reads a trace; `counter` is the code of `Board::counter`, whose timer read cuts the
/// windows (no generator probed: the tests' reading).
#[cfg(test)]
pub fn read_trace(input: impl BufRead, counter: Range<u32>) -> Result<Traced, String> {
    read_trace_probed(input, counter, Probe::default())
}

/// Reads a trace as the tests' `read_trace` does, and the generator's share of each step by
/// `probe`.
pub fn read_trace_probed(
    input: impl BufRead,
    counter: Range<u32>,
    probe: Probe,
) -> Result<Traced, String> {
    let mut reader = Reader::new(counter, probe);
    for line in input.split(b'\n') {
        let line = line.map_err(|e| format!("reading the trace: {e}"))?;
        reader.line(String::from_utf8_lossy(&line).trim_end());
    }
    reader.finish();
    reader.out.read = reader.read;
    reader.out.generator_profile = reader
        .profile
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
    Ok(reader.out)
}

/// The code of `firmware::board::qemu::Board::counter` in `elf`: its address and size.
fn counter_code(elf: &Path) -> Result<Range<u32>, String> {
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*bytes).map_err(|e| e.to_string())?;
    let mut found = file.symbols().filter(|s| {
        s.name().is_ok_and(|n| {
            format!("{:#}", rustc_demangle::demangle(n)) == "firmware::board::qemu::Board::counter"
        })
    });
    match (found.next(), found.next()) {
        (Some(s), None) if s.size() > 0 => {
            let start = (s.address() & !1) as u32;
            Ok(start..start + s.size() as u32)
        }
        (Some(_), None) => Err(format!(
            "{}: Board::counter has no size in the symbol table",
            elf.display()
        )),
        (None, _) => Err(format!(
            "{}: no symbol firmware::board::qemu::Board::counter (inlined?)",
            elf.display()
        )),
        (Some(_), Some(_)) => Err("Board::counter is in the ELF twice".to_string()),
    }
}

/// The generator's functions in `elf` ([`Probe`]): the entries of every
/// `solver_core::operator::generator::Generator<…>::advance` and `::evaluate`
/// instance, and all function symbols. No entry: the scene has no manual mode.
fn generator_probe(elf: &Path) -> Result<Probe, String> {
    let bytes = std::fs::read(elf).map_err(|e| format!("{}: {e}", elf.display()))?;
    let file = object::File::parse(&*bytes).map_err(|e| e.to_string())?;
    let mut probe = Probe::default();
    for s in file.symbols() {
        if s.kind() != object::SymbolKind::Text || s.size() == 0 {
            continue;
        }
        let Ok(raw) = s.name() else { continue };
        let name = format!("{:#}", rustc_demangle::demangle(raw));
        let start = (s.address() & !1) as u32;
        if name.contains("operator::generator::Generator<")
            && (name.ends_with("::advance") || name.contains("::evaluate"))
        {
            probe.entries.push(start);
        }
        probe
            .functions
            .push((start, start + s.size() as u32, name.into()));
    }
    probe.functions.sort_by_key(|(s, _, _)| *s);
    probe.entries.sort_unstable();
    probe.entries.dedup();
    Ok(probe)
}

/// The estimate for one scene, checked against the firmware's own instruction counts.
pub struct Estimate {
    /// The scene file, relative to the repository (and the scenario, when one was given).
    pub scene: String,
    /// Each step.
    pub steps: Vec<Step>,
    /// The largest difference between a step's instructions in the trace and in the
    /// firmware's cost line.
    pub worst_mismatch: i64,
    /// Each step's share spent in the operator's generator (a scene with manual mode).
    pub generator: Vec<Share>,
    /// Instructions and point cycles in the generator's windows by function.
    pub generator_profile: HashMap<String, (u64, u64)>,
    /// Generator entries not straight after a call (not counted).
    pub unlinked_entries: u64,
}

/// Runs `scene`'s QEMU firmware with the execution trace and estimates every step's
/// cycles: on the healthy bus, the feedback scenes (planar and 3D) on the plant they
/// close the loop around, with their inclinometer (as `qemu-bench` measures them), the
/// manual scenes on their operator's profile (the master switch on the bus; the
/// generator's share of each step too) — or on `scenario`, when one is given.
pub fn estimate(scene: &str, scenario: Option<sim::Scenario>) -> Result<Estimate, String> {
    let feedback = [
        crate::qemu::FEEDBACK_SCENE,
        crate::qemu::CRANE3D_FEEDBACK_SCENE,
    ];
    // A scenario given is named beside the scene in the tables.
    let label = match scenario {
        Some(chosen) => format!("{scene} (`{}`)", chosen.name),
        None => scene.to_string(),
    };
    let scenario = if let Some(chosen) = scenario {
        chosen
    } else if feedback.contains(&scene) {
        sim::CLOSED_LOOP
    } else if scene == crate::qemu::MANUAL_SCENE {
        sim::MANUAL_PROFILE
    } else if scene == crate::qemu::CRANE3D_MANUAL_SCENE {
        sim::MANUAL_PROFILE_3D
    } else {
        HEALTHY
    };
    setup::ensure_qemu()?;
    let path = root().join(scene);
    let elf = firmware::build(Board::Qemu, &path)?;
    let counter = counter_code(&elf)?;
    let probe = generator_probe(&elf)?;
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
    let traced = input.and_then(|f| {
        read_trace_probed(BufReader::with_capacity(1 << 20, f), counter.clone(), probe)
    });
    let status = child.wait().map_err(|e| e.to_string())?;
    let _ = std::fs::remove_file(&fifo);
    let traced = traced?;
    if !status.success() {
        return Err(format!("{scene}: QEMU exited with {status}"));
    }
    if traced.read.is_none() {
        return Err(format!(
            "{scene}: no timer read in the trace's disassembly of Board::counter ({counter:#x?})"
        ));
    }
    if traced.generator_across_cuts != 0 {
        return Err(format!(
            "{scene}: {} generator windows still open at a step's end (their return not found)",
            traced.generator_across_cuts
        ));
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
        scene: label,
        steps: traced.steps,
        worst_mismatch,
        generator: traced.generator,
        generator_profile: traced.generator_profile,
        unlinked_entries: traced.unlinked_entries,
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

/// The generator's row of one estimate, over the steps it ran in (`None`: it never ran).
fn generator_row(e: &Estimate) -> Option<String> {
    let ran: Vec<Step> = e
        .generator
        .iter()
        .filter(|s| s.calls > 0)
        .map(|s| s.cost)
        .collect();
    if ran.is_empty() {
        return None;
    }
    let calls = e.generator.iter().map(|s| u64::from(s.calls)).sum::<u64>() as f64;
    let (imean, imax) = mean_max(&ran, |s| s.instructions);
    let c = |k: usize| mean_max(&ran, move |s| s.cycles[k]);
    let ((lm, lx), (pm, px), (um, ux)) = (c(0), c(1), c(2));
    Some(format!(
        "| {} | {} | {:.1} | {imean:.0} / {imax} | {lm:.0} / {pm:.0} / {um:.0} | {lx} / {px} / {ux} | {} |",
        e.scene,
        ran.len(),
        calls / ran.len() as f64,
        e.unlinked_entries,
    ))
}

/// The functions the generator's point-estimate cycles went to, most first.
fn generator_profile(e: &Estimate, count: usize) -> String {
    let total: u64 = e.generator_profile.values().map(|(_, c)| c).sum();
    let mut by: Vec<(&String, &(u64, u64))> = e.generator_profile.iter().collect();
    by.sort_by_key(|(n, (_, c))| (std::cmp::Reverse(*c), (*n).clone()));
    let mut out = format!(
        "\n{}: the generator's point-estimate cycles by function\n",
        e.scene
    );
    for (name, (i, c)) in by.into_iter().take(count) {
        out += &format!(
            "  {:>5.1} %  {c:>11} cycles  {i:>11} instructions  {name}\n",
            100.0 * *c as f64 / total.max(1) as f64
        );
    }
    out
}

/// `cargo xtask cycles`: the estimate for each scene (on its default scenario, or the one
/// given), a table, and per-step CSVs in `target/cycles/` (`SCENE.csv`, or
/// `SCENE--SCENARIO.csv` for a scenario given).
pub fn cycles(runs: &[(String, Option<sim::Scenario>)]) -> Result<(), String> {
    let out_dir = root().join("target/cycles");
    std::fs::create_dir_all(&out_dir).map_err(|e| e.to_string())?;
    let mut rows = Vec::new();
    let mut generator_rows = Vec::new();
    let mut profiles = String::new();
    for (scene, scenario) in runs {
        let e = estimate(scene, *scenario)?;
        if let Some(r) = generator_row(&e) {
            generator_rows.push(r);
            profiles += &generator_profile(&e, 15);
        }
        let csv = out_dir.join(csv_name(scene, scenario.map(|s| s.name)));
        write_csv(&csv, &e.steps, &e.generator)?;
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
    if !generator_rows.is_empty() {
        println!(
            "\nThe operator's generator per manual-mode step (issue 28's target: ≤ 3,000 cycles): \
             `Generator::advance` and every `Generator::evaluate`, from the call to the return, \
             summed per step, over the steps it ran in:\n"
        );
        println!(
            "| scene | steps | calls per step | QEMU instructions mean / max | cycles mean: lower / point / upper | cycles max: lower / point / upper | entries not counted |"
        );
        println!("|---|---:|---:|---:|---:|---:|---:|");
        for r in generator_rows {
            println!("{r}");
        }
        print!("{profiles}");
    }
    Ok(())
}

fn csv_name(scene: &str, scenario: Option<&str>) -> PathBuf {
    let stem = Path::new(scene)
        .file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned());
    match scenario {
        Some(name) => PathBuf::from(format!("{stem}--{name}.csv")),
        None => PathBuf::from(format!("{stem}.csv")),
    }
}

/// Each step's row; with the generator's share (`generator_*`, zero where it did not
/// run) when the scene has one.
fn write_csv(path: &Path, steps: &[Step], generator: &[Share]) -> Result<(), String> {
    let mut f = File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let probed = generator.iter().any(|g| g.calls > 0);
    let mut text = String::from("step,instructions,cycles_lower,cycles_point,cycles_upper");
    if probed {
        text.push_str(",generator_calls,generator_instructions,generator_cycles_lower,generator_cycles_point,generator_cycles_upper");
    }
    text.push('\n');
    for (i, s) in steps.iter().enumerate() {
        text.push_str(&format!(
            "{i},{},{},{},{}",
            s.instructions, s.cycles[0], s.cycles[1], s.cycles[2]
        ));
        if let (true, Some(g)) = (probed, generator.get(i)) {
            let c = g.cost.cycles;
            text.push_str(&format!(
                ",{},{},{},{},{}",
                g.calls, g.cost.instructions, c[0], c[1], c[2]
            ));
        }
        text.push('\n');
    }
    f.write_all(text.as_bytes())
        .map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-written trace in QEMU's format: a loop of two blocks run three times,
    /// with the counter called before and after (its timer read at 0x104).
    const TRACE: &str = "\
----------------
IN: counter
0x00000100:  f241 0004  movw     r0, #0x1004
0x00000104:  6800       ldr      r0, [r0]
0x00000106:  4770       bx       lr

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

    /// The code of the counter in [`TRACE`].
    const COUNTER: Range<u32> = 0x100..0x108;

    /// From the first read to the second: the read and the return, the loop, `after`,
    /// the second call up to its read.
    const WINDOW: u64 = 2 + 9 + 1 + 1;

    #[test]
    fn a_window_is_what_runs_between_two_timer_reads() {
        let t = read_trace(TRACE.as_bytes(), COUNTER).unwrap();
        assert_eq!(t.unknown_blocks, 0);
        assert_eq!(t.read, Some(0x104));
        assert_eq!(t.instructions, 3 + 9 + 1 + 3);
        assert_eq!(t.steps.len(), 1);
        let s = t.steps[0];
        assert_eq!(s.instructions, WINDOW);
        let [lower, point, upper] = s.cycles;
        assert!(lower <= point && point <= upper, "{:?}", s.cycles);
        // Each vmul.f64 depends on the last through d0 (7 cycles) in the point
        // estimate; the lower bound sees only issue.
        assert!(point >= 3 * 7, "{point}");
        assert!(lower <= 8, "{lower}");
        assert!(s.instructions / 2 <= lower);
    }

    /// An interrupt taken inside the counter before its read (QEMU's instruction
    /// budget ran out there: the block is stopped, its first instruction run as a block
    /// of its own, then the handler): the firmware's clock counts the handler in the
    /// window the read closes, not in the one it opens.
    #[test]
    fn an_interrupt_before_the_read_counts_in_the_window_the_read_closes() {
        let interrupted = "\
Trace 0: 0x7f0000000100 [00800408/00000100/00000110/ff020200] counter
Stopped execution of TB chain before 0x7f0000000100 [00000100] counter
----------------
IN: counter
0x00000100:  f241 0004  movw     r0, #0x1004

Trace 0: 0x7f0000000500 [00800408/00000100/00000110/ff020203] counter
----------------
IN: SysTick
0x00000600:  2000       movs     r0, #0
0x00000602:  4770       bx       lr

Trace 0: 0x7f0000000600 [0080040d/00000600/00000110/ff020200] SysTick
----------------
IN: counter
0x00000104:  6800       ldr      r0, [r0]
0x00000106:  4770       bx       lr

Trace 0: 0x7f0000000700 [00800408/00000104/00000110/ff020200] counter
";
        let (first, rest) = TRACE.split_at(TRACE.find("Trace 0: 0x7f0000000100").unwrap());
        let (rest, _) = rest.split_at(rest.rfind("Trace 0: 0x7f0000000100").unwrap());
        let closing = format!("{first}{rest}{interrupted}");
        let t = read_trace(closing.as_bytes(), COUNTER).unwrap();
        assert_eq!(t.stopped_blocks, 1);
        assert_eq!(t.steps.len(), 1);
        assert_eq!(t.steps[0].instructions, WINDOW + 2, "the handler is in");
        // The same interrupt in the call that opens the window: the handler runs before
        // the clock is read.
        let opening = format!(
            "{}{interrupted}{}",
            &TRACE[..TRACE.find("Trace 0").unwrap()],
            &TRACE[TRACE.find("----------------\nIN: work").unwrap()..]
        );
        let t = read_trace(opening.as_bytes(), COUNTER).unwrap();
        assert_eq!(t.steps.len(), 1);
        assert_eq!(t.steps[0].instructions, WINDOW, "the handler is out");
    }

    #[test]
    fn a_constant_from_the_literal_pool_is_not_the_timer_read() {
        let literal = TRACE.replace(
            "0x00000100:  f241 0004  movw     r0, #0x1004",
            "0x00000100:  4801       ldr      r0, [pc, #4]\n0x00000102:  bf00       nop",
        );
        let t = read_trace(literal.as_bytes(), 0x100..0x10c).unwrap();
        assert_eq!(t.read, Some(0x104));
        assert_eq!(t.steps[0].instructions, WINDOW + 1);
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
        let t = read_trace(stopped.as_bytes(), COUNTER).unwrap();
        assert_eq!(t.stopped_blocks, 1);
        assert_eq!(t.steps[0].instructions, WINDOW);
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
        let t = read_trace(rewound.as_bytes(), COUNTER).unwrap();
        assert_eq!(t.stopped_blocks, 1);
        assert_eq!(t.steps[0].instructions, WINDOW);
        // Rewound to its third instruction: the first two ran.
        let mid = TRACE.replacen(
            "Trace 0: 0x7f0000000200 [00800408/00000200/00000110/ff020200] work\n",
            "Trace 0: 0x7f0000000200 [00800408/00000200/00000110/ff020200] work\n\
             cpu_io_recompile: rewound execution of TB to 00000206\n",
            1,
        );
        let t = read_trace(mid.as_bytes(), COUNTER).unwrap();
        assert_eq!(t.steps[0].instructions, 2 + 2 + 6 + 1 + 1);
        // The timer read itself, as QEMU runs it under -icount: the counter's block
        // rewound to it, then the read alone as a block of its own. The window is cut
        // where the read ran, once.
        let io = TRACE.replace(
            "Trace 0: 0x7f0000000100 [00800408/00000100/00000110/ff020200] counter\n",
            "Trace 0: 0x7f0000000100 [00800408/00000100/00000110/ff020200] counter\n\
             cpu_io_recompile: rewound execution of TB to 00000104\n\
             ----------------\n\
             IN: counter\n\
             0x00000104:  6800       ldr      r0, [r0]\n\
             \n\
             Trace 0: 0x7f0000000400 [00800408/00000104/00000110/ff038201] counter\n\
             ----------------\n\
             IN: counter\n\
             0x00000106:  4770       bx       lr\n\
             \n\
             Trace 0: 0x7f0000000480 [00800408/00000106/00000110/ff020200] counter\n",
        );
        let t = read_trace(io.as_bytes(), COUNTER).unwrap();
        assert_eq!((t.stopped_blocks, t.steps.len()), (2, 1));
        assert_eq!(t.steps[0].instructions, WINDOW);
    }

    /// A step in which a caller calls the generator's function (at 0x200) with `bl`,
    /// then a wrapper (0x400) that tail-calls it with `b`, then reaches it by an indirect
    /// branch that is no call.
    const CALLED: &str = "\
----------------
IN: counter
0x00000100:  f241 0004  movw     r0, #0x1004
0x00000104:  6800       ldr      r0, [r0]
0x00000106:  4770       bx       lr

Trace 0: 0x7f0000000100 [00800408/00000100/00000110/ff020200] counter
----------------
IN: caller
0x00000300:  2001       movs     r0, #1
0x00000302:  f000 f800  bl       #0x200

Trace 0: 0x7f0000000300 [00800408/00000300/00000110/ff020200] caller
----------------
IN: gen
0x00000200:  ee20 0b01  vmul.f64 d0, d0, d1
0x00000204:  ee20 0b01  vmul.f64 d0, d0, d1
0x00000208:  4770       bx       lr

Trace 0: 0x7f0000000200 [00800408/00000200/00000110/ff020200] gen
----------------
IN: back
0x00000306:  f000 f800  bl       #0x400

Trace 0: 0x7f0000000306 [00800408/00000306/00000110/ff020200] back
----------------
IN: wrapper
0x00000400:  e7fe       b        #0x200

Trace 0: 0x7f0000000400 [00800408/00000400/00000110/ff020200] wrapper
Trace 0: 0x7f0000000200 [00800408/00000200/00000110/ff020200] gen
----------------
IN: back2
0x0000030a:  4718       bx       r3

Trace 0: 0x7f000000030a [00800408/0000030a/00000110/ff020200] back2
Trace 0: 0x7f0000000200 [00800408/00000200/00000110/ff020200] gen
Trace 0: 0x7f0000000100 [00800408/00000100/00000110/ff020200] counter
";

    #[test]
    fn the_generator_window_runs_from_its_call_to_the_return() {
        let probe = Probe {
            entries: vec![0x200],
            functions: vec![
                (0x200, 0x20a, "gen".into()),
                (0x300, 0x30c, "caller".into()),
                (0x400, 0x402, "wrapper".into()),
            ],
        };
        let t = read_trace_probed(CALLED.as_bytes(), COUNTER, probe).unwrap();
        assert_eq!((t.unknown_blocks, t.generator_across_cuts), (0, 0));
        assert_eq!(t.steps.len(), 1);
        assert_eq!(t.generator.len(), 1);
        // The called and the tail-called windows: the two multiplies and the return,
        // twice; the entry by an indirect branch is no call (no return address to close
        // it): counted apart, not measured.
        let share = t.generator[0];
        assert_eq!((share.calls, share.cost.instructions), (2, 6));
        assert_eq!(t.unlinked_entries, 1);
        let [lower, point, upper] = share.cost.cycles;
        assert!(
            lower <= point && point <= upper && point >= 14,
            "{:?}",
            share.cost.cycles
        );
        assert_eq!(t.generator_profile.get("gen").map(|p| p.0), Some(6));
        assert_eq!(t.generator_profile.get("caller"), None);
        assert_eq!(t.generator_profile.get("wrapper"), None);
        assert!(share.cost.instructions < t.steps[0].instructions);
    }

    #[test]
    fn a_block_without_disassembly_is_counted_not_guessed() {
        let t = read_trace(
            "Trace 0: 0x7f0000000900 [00800408/00000900/00000110/ff020200] x\n".as_bytes(),
            COUNTER,
        )
        .unwrap();
        assert_eq!((t.unknown_blocks, t.instructions, t.read), (1, 0, None));
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
