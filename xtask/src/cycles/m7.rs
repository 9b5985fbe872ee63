//! A timing model of the Cortex-M7, to turn QEMU's executed instructions into cycles.
//!
//! ARM publishes no instruction timings for the Cortex-M7. The model takes its numbers
//! from the scheduling model ARM contributed to LLVM (`llvm/lib/Target/ARM/
//! ARMScheduleM7.td`: issue width 2, in order; which instructions issue alone or only
//! in the first slot; the units they need; result latencies), and the measured
//! behaviour it states there (a double-precision chained `vmla` stalls the pipeline
//! behind it for 3 cycles, a fused `vfma` for 2; a mispredicted forward branch costs
//! 6 cycles). Every executed instruction goes through an in-order dual-issue
//! scoreboard ([`Pipeline`]) in one of three settings ([`Setting`]):
//!
//! * **lower** — issue-bound: the dual-issue rules, every result ready the next cycle,
//!   no stall, every branch predicted;
//! * **point** — the latencies and stalls above, a 2-bit predictor per branch with a
//!   target buffer ([`Predictor`]), a mispredict costing 6 cycles;
//! * **upper** — single issue, the slowest latency of each class (a byte load 3, an
//!   integer divide 12, a double divide or square root 30 with the FPU blocked), every
//!   conditional or indirect branch mispredicted.
//!
//! It ignores the memory system: code and data are taken to be in the TCMs or hitting
//! the caches with no wait state (on the STM32H743 the flash has wait states behind
//! the 16 KiB instruction cache; a miss costs more than any bound here), and the
//! interrupt entry's stacking beyond its instructions.

use std::collections::HashMap;

/// A register of the scoreboard: r0–r15 are 0–15, d0–d15 16–31 (s2k and s2k+1 are
/// halves of dk), the APSR flags 32, the FPSCR flags 33.
const FLAGS: usize = 32;
const FP_FLAGS: usize = 33;
const REGISTERS: usize = 34;

/// What an instruction is, for timing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Class {
    /// Integer data processing, moves, compares, shifts, IT.
    Alu,
    /// Integer multiply (-accumulate), 32 and 64 bit.
    Mul,
    /// Integer divide.
    Div,
    /// One load of a core or single-precision register.
    Load,
    /// One store.
    Store,
    /// Two words at once (LDRD, VLDR.64): issued alone.
    LoadPair,
    /// Two words at once (STRD, VSTR.64): issued alone.
    StorePair,
    /// Load or store multiple (LDM, POP, VLDM, …) of this many words: issued alone.
    Multiple(u8),
    /// A branch; `conditional` or `indirect` ones can be mispredicted.
    Branch {
        /// On a condition (`b<cc>`, `cbz`, `cbnz`).
        conditional: bool,
        /// To a register or loaded address (bx, blx r, pop {pc}, tbb).
        indirect: bool,
    },
    /// Double-precision add, subtract, absolute, negate, convert, compare, select.
    FpAlu,
    /// Double-precision multiply.
    FpMul,
    /// Double-precision chained multiply-accumulate (vmla, vmls, vnmla, vnmls).
    FpMac,
    /// Double-precision fused multiply-accumulate (vfma, vfms, vfnma, vfnms).
    FpFma,
    /// Double-precision divide or square root.
    FpDiv,
    /// Single-precision arithmetic.
    FpSingle,
    /// A move to, from or between FP registers.
    FpMove,
    /// Moves of two core registers to or from a double register: issued alone.
    FpMovePair,
    /// Barriers, system register access, hints, exceptions: issued alone.
    System,
}

/// One decoded instruction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Insn {
    /// Its address.
    pub address: u32,
    /// Its size in bytes (2 or 4).
    pub size: u32,
    /// Its timing class.
    pub class: Class,
    /// Registers read (a bit per scoreboard register).
    pub reads: u64,
    /// Registers read to form the address (needed a cycle earlier).
    pub address_reads: u64,
    /// Registers written.
    pub writes: u64,
    /// A direct branch's target.
    pub target: Option<u32>,
    /// A branch with link (`bl`, `blx`): a call, returning to the next instruction.
    pub links: bool,
}

fn register(name: &str) -> Option<usize> {
    let name = name.trim_matches(|c: char| !c.is_ascii_alphanumeric());
    let number = |p: &str| name.strip_prefix(p).and_then(|n| n.parse::<usize>().ok());
    match name {
        "sb" => return Some(9),
        "sl" => return Some(10),
        "fp" => return Some(11),
        "ip" => return Some(12),
        "sp" => return Some(13),
        "lr" => return Some(14),
        "pc" => return Some(15),
        _ => {}
    }
    if let Some(n) = number("r").filter(|&n| n < 16) {
        return Some(n);
    }
    if let Some(n) = number("d").filter(|&n| n < 16) {
        return Some(16 + n);
    }
    if let Some(n) = number("s").filter(|&n| n < 32) {
        return Some(16 + n / 2);
    }
    let lower = name.to_ascii_lowercase();
    if lower.starts_with("apsr") {
        return Some(FLAGS);
    }
    if lower == "fpscr" {
        return Some(FP_FLAGS);
    }
    None
}

/// The registers of an operand list, in order, expanding `{d8-d11}` ranges.
fn registers(operands: &str) -> Vec<usize> {
    let mut out = Vec::new();
    for word in operands.split([',', ' ', '[', ']', '{', '}', '!']) {
        if let Some((a, b)) = word.split_once('-') {
            if let (Some(a), Some(b)) = (register(a), register(b)) {
                out.extend(a..=b);
                continue;
            }
        }
        if let Some(r) = register(word) {
            out.push(r);
        }
    }
    out
}

fn mask(regs: &[usize]) -> u64 {
    regs.iter().fold(0, |m, &r| m | 1 << r)
}

const CONDITIONS: [&str; 16] = [
    "eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le",
];

/// `mnemonic` without a width qualifier (`.w`, `.n`) and its data type (`.f64`).
fn base(mnemonic: &str) -> (&str, &str) {
    let m = mnemonic
        .strip_suffix(".w")
        .or_else(|| mnemonic.strip_suffix(".n"))
        .unwrap_or(mnemonic);
    m.split_once('.').unwrap_or((m, ""))
}

/// `m` without a condition suffix (`moveq` → `mov`, `lslseq` → `lsls`), if it is
/// one of `bases` so suffixed or bare.
fn strip_condition<'a>(m: &'a str, bases: &[&str]) -> Option<&'a str> {
    bases.iter().find_map(|b| {
        let rest = m.strip_prefix(b)?;
        (rest.is_empty() || CONDITIONS.contains(&rest)).then_some(&m[..b.len()])
    })
}

fn is_conditional_branch(m: &str) -> bool {
    m.len() == 3 && m.starts_with('b') && CONDITIONS.contains(&&m[1..])
}

/// Decodes one line of QEMU's `in_asm` log: `0x0000a1b2:  f015 f86e  bl  #0x15130`.
pub fn decode(line: &str) -> Option<Insn> {
    let (address, rest) = line.split_once(':')?;
    let address = u32::from_str_radix(address.trim().strip_prefix("0x")?, 16).ok()?;
    let mut words = rest.split_whitespace();
    let first = u16::from_str_radix(words.next()?, 16).ok()?;
    // Thumb-2: a first halfword of 0b11101…, 0b11110… or 0b11111… starts 32 bits.
    let size = if first >> 11 >= 0b11101 {
        words.next()?;
        4
    } else {
        2
    };
    let mnemonic = words.next()?;
    let operands = rest
        .split_once(mnemonic)
        .map_or("", |(_, o)| o)
        .trim()
        .to_string();
    Some(classify(address, size, mnemonic, &operands))
}

fn classify(address: u32, size: u32, mnemonic: &str, operands: &str) -> Insn {
    let (m, data_type) = base(mnemonic);
    let regs = registers(operands);
    let all = mask(&regs);
    let first = regs.first().map_or(0, |&r| 1 << r);
    let first_two = mask(&regs[..regs.len().min(2)]);
    // The sources of an instruction whose first operand is its destination (it may
    // be a source too: `adds r0, r0, r1`), and of one with two destinations.
    let sources = mask(regs.get(1..).unwrap_or(&[]));
    let sources_after_two = mask(regs.get(2..).unwrap_or(&[]));
    let double = data_type.contains("64") || names_a_double_register(operands);
    let (address_reads, written_base) = address_registers(operands);
    let target = operands
        .strip_prefix('#')
        .and_then(|t| u32::from_str_radix(t.trim_start_matches("0x"), 16).ok());
    let insn = |class, reads, writes| Insn {
        address,
        size,
        class,
        reads,
        address_reads,
        writes: writes | written_base,
        target,
        links: m == "bl" || strip_condition(m, &["blx"]).is_some(),
    };
    let branch = |conditional, indirect| Class::Branch {
        conditional,
        indirect,
    };
    let pc = 1 << 15;
    // Branches.
    if m == "b" || m == "bl" {
        return insn(branch(false, false), 0, 0);
    }
    if is_conditional_branch(m) {
        return insn(branch(true, false), 1 << FLAGS, 0);
    }
    if m == "cbz" || m == "cbnz" {
        return insn(branch(true, false), all, 0);
    }
    if let Some(b) = strip_condition(m, &["blx", "bx"]) {
        let conditional = b.len() != m.len();
        return insn(branch(conditional, target.is_none()), all, 0);
    }
    if m == "tbb" || m == "tbh" {
        return insn(branch(false, true), all, 0);
    }
    if m.len() <= 5 && m.starts_with("it") && m[2..].chars().all(|c| c == 't' || c == 'e') {
        return insn(Class::Alu, 1 << FLAGS, 0);
    }
    // Floating point.
    if let Some(v) = m.strip_prefix('v') {
        let arith = |class| {
            let class = if double { class } else { Class::FpSingle };
            insn(
                class,
                sources | if accumulates(v) { first } else { 0 },
                first,
            )
        };
        let v_base = strip_condition(
            v,
            &[
                "ldr", "str", "ldmia", "ldmdb", "stmia", "stmdb", "push", "pop", "mov", "mrs",
                "msr", "add", "sub", "mul", "nmul", "mla", "mls", "nmla", "nmls", "fma", "fms",
                "fnma", "fnms", "div", "sqrt", "abs", "neg", "cvt", "cmp", "cmpe", "maxnm",
                "minnm", "seleq", "selge", "selgt", "selvs", "rintz", "rintm", "rintp", "rinta",
                "rintn", "rintx", "rintr",
            ],
        )
        .unwrap_or(v);
        return match v_base {
            "ldr" if double => insn(Class::LoadPair, sources, first),
            "ldr" => insn(Class::Load, sources, first),
            "str" if double => insn(Class::StorePair, all, 0),
            "str" => insn(Class::Store, all, 0),
            "ldmia" | "ldmdb" | "pop" => insn(
                Class::Multiple(words(&regs, double)),
                address_reads,
                all & !address_reads,
            ),
            "stmia" | "stmdb" | "push" => insn(Class::Multiple(words(&regs, double)), all, 0),
            "mov" if regs.len() == 3 => {
                if regs[0] < 16 {
                    insn(Class::FpMovePair, sources_after_two, first_two)
                } else {
                    insn(Class::FpMovePair, sources, first)
                }
            }
            "mov" => insn(Class::FpMove, sources, first),
            "mrs" => insn(Class::System, 1 << FP_FLAGS, first),
            "msr" => insn(Class::System, all, 1 << FP_FLAGS),
            "cmp" | "cmpe" => insn(
                if double {
                    Class::FpAlu
                } else {
                    Class::FpSingle
                },
                all,
                1 << FP_FLAGS,
            ),
            "add" | "sub" | "abs" | "neg" | "cvt" | "maxnm" | "minnm" | "rintz" | "rintm"
            | "rintp" | "rinta" | "rintn" | "rintx" | "rintr" => arith(Class::FpAlu),
            s if s.starts_with("sel") => arith(Class::FpAlu),
            "mul" | "nmul" => arith(Class::FpMul),
            "mla" | "mls" | "nmla" | "nmls" => arith(Class::FpMac),
            "fma" | "fms" | "fnma" | "fnms" => arith(Class::FpFma),
            "div" | "sqrt" => {
                if double {
                    arith(Class::FpDiv)
                } else {
                    arith(Class::FpSingle)
                }
            }
            _ => insn(Class::System, all, all),
        };
    }
    // Loads and stores.
    if let Some(l) = strip_condition(
        m,
        &[
            "ldrd", "ldrexb", "ldrexh", "ldrex", "ldrsb", "ldrsh", "ldrb", "ldrh", "ldr",
        ],
    ) {
        let (class, writes, reads) = if l == "ldrd" {
            (Class::LoadPair, first_two, sources_after_two)
        } else {
            (Class::Load, first, sources)
        };
        let class = if writes & pc != 0 {
            branch(false, true)
        } else {
            class
        };
        return insn(class, reads, writes);
    }
    if let Some(s) = strip_condition(
        m,
        &["strd", "strexb", "strexh", "strex", "strb", "strh", "str"],
    ) {
        let class = if s == "strd" {
            Class::StorePair
        } else {
            Class::Store
        };
        // strex's first operand is its status result; its sources follow.
        let (writes, reads) = if s.starts_with("strex") {
            (first, sources)
        } else {
            (0, all)
        };
        return insn(class, reads, writes);
    }
    if let Some(b) = strip_condition(m, &["ldmia", "ldmdb", "ldm", "pop"]) {
        let pop = b == "pop";
        let list = all & !address_reads;
        let words = words(&regs, false).saturating_sub(u8::from(!pop));
        let class = if list & pc != 0 {
            branch(b.len() != m.len(), true)
        } else {
            Class::Multiple(words)
        };
        return insn(class, address_reads, list);
    }
    if let Some(b) = strip_condition(m, &["stmia", "stmdb", "stm", "push"]) {
        let words = words(&regs, false).saturating_sub(u8::from(b != "push"));
        return insn(Class::Multiple(words), all, 0);
    }
    // Multiply and divide.
    if let Some(x) = strip_condition(
        m,
        &[
            "umull", "umlal", "smull", "smlal", "muls", "mul", "mla", "mls", "smmul", "smmla",
            "smulbb", "smlabb",
        ],
    ) {
        let long = x.ends_with("ll") || x.ends_with("al");
        let writes = if long { first_two } else { first };
        let reads = match (long, x.ends_with("al")) {
            (true, true) => all,
            (true, false) => sources_after_two,
            (false, _) => sources,
        };
        return insn(Class::Mul, reads, writes);
    }
    if strip_condition(m, &["udiv", "sdiv"]).is_some() {
        return insn(Class::Div, sources, first);
    }
    if strip_condition(
        m,
        &[
            "dmb", "dsb", "isb", "mrs", "msr", "cpsid", "cpsie", "wfi", "wfe", "bkpt", "svc",
            "nop", "udf", "sev", "yield", "clrex",
        ],
    )
    .is_some()
    {
        return insn(Class::System, all, 0);
    }
    // Integer data processing.
    let compare = strip_condition(m, &["cmp", "cmn", "tst", "teq"]).is_some();
    if compare {
        return insn(Class::Alu, all, 1 << FLAGS);
    }
    let (op, sets_flags, conditional) = split_integer(m);
    let writes = first | if sets_flags { 1 << FLAGS } else { 0 };
    let mut reads = sources;
    if conditional || ["adc", "sbc", "rrx"].contains(&op) {
        reads |= 1 << FLAGS;
    }
    // Read-modify-write of the destination: bfi, movt, and an IT-conditional write.
    if ["bfi", "bfc", "movt"].contains(&op) || conditional {
        reads |= first;
    }
    let class = if writes & pc != 0 {
        branch(conditional, true)
    } else {
        Class::Alu
    };
    insn(class, reads, writes)
}

/// Integer data-processing mnemonics, each possibly followed by `s` (sets the flags)
/// and a condition (inside an IT block).
const INTEGER_OPS: [&str; 42] = [
    "mov", "mvn", "add", "adc", "sub", "sbc", "rsb", "and", "orr", "orn", "eor", "bic", "lsl",
    "lsr", "asr", "ror", "rrx", "movw", "movt", "ubfx", "sbfx", "bfi", "bfc", "uxtb", "uxth",
    "sxtb", "sxth", "uxtab", "uxtah", "uxtb16", "clz", "rbit", "rev", "rev16", "addw", "subw",
    "uqadd8", "uqsub8", "usat", "ssat", "sel", "pkhbt",
];

/// `(operation, sets flags, conditional)` of an integer mnemonic: `lslseq` is `lsl`,
/// flag-setting, conditional; the longest operation that parses wins.
fn split_integer(m: &str) -> (&str, bool, bool) {
    INTEGER_OPS
        .iter()
        .filter_map(|op| {
            let rest = m.strip_prefix(op)?;
            let (s, cond) = match rest.strip_prefix('s') {
                Some(c) if c.is_empty() || CONDITIONS.contains(&c) => (true, c),
                _ => (false, rest),
            };
            (cond.is_empty() || CONDITIONS.contains(&cond)).then_some((*op, s, !cond.is_empty()))
        })
        .max_by_key(|(op, ..)| op.len())
        .unwrap_or((m, m.ends_with('s'), false))
}

/// Whether an operand is a double register (`d0`–`d15`).
fn names_a_double_register(operands: &str) -> bool {
    operands
        .split([',', ' ', '[', ']', '{', '}', '!', '-'])
        .any(|w| {
            w.strip_prefix('d')
                .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
        })
}

/// Words a register list moves.
fn words(regs: &[usize], double: bool) -> u8 {
    let n = regs.len() as u8;
    if double {
        2 * n
    } else {
        n
    }
}

fn accumulates(v: &str) -> bool {
    ["mla", "mls", "nmla", "nmls", "fma", "fms", "fnma", "fnms"]
        .iter()
        .any(|a| v.starts_with(a))
}

/// The registers that form a memory operand's address (`[r0, r1]`), and the base
/// register if it is written back (`[r0], #4` or `[r0, #4]!`, `ldm r0!`).
fn address_registers(operands: &str) -> (u64, u64) {
    let Some(open) = operands.find('[') else {
        // ldm/stm: the base is the first operand, before the list, written back with
        // `!`; push and pop (a list alone) address by sp, which nothing here waits for.
        let Some((base, _)) = operands.split_once('{') else {
            return (0, 0);
        };
        return match register(base.trim().trim_end_matches(',')) {
            Some(r) if base.contains('!') => (1 << r, 1 << r),
            Some(r) => (1 << r, 0),
            None => (0, 0),
        };
    };
    let close = operands[open..]
        .find(']')
        .map_or(operands.len(), |c| open + c);
    let inside = &operands[open + 1..close];
    let regs = registers(inside);
    let base = regs.first().map_or(0, |&r| 1 << r);
    let after = &operands[close..];
    let written = if after.starts_with("]!") || after.starts_with("], ") {
        base
    } else {
        0
    };
    (mask(&regs), written)
}

/// The three settings of the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// Issue-bound.
    Lower,
    /// The stated latencies and a branch predictor.
    Point,
    /// Single issue, the slowest latencies, every branch that can be mispredicted is.
    Upper,
}

/// Cycles lost to a mispredicted branch (LLVM's Cortex-M7 model: 6 for a forward
/// branch).
pub const MISPREDICT: u64 = 6;

impl Setting {
    /// Result latency of `class`, cycles from issue until a dependent may issue.
    fn latency(self, class: Class) -> u64 {
        if self == Setting::Lower {
            return 1;
        }
        let upper = self == Setting::Upper;
        match class {
            Class::Alu | Class::Branch { .. } | Class::System => 1,
            Class::Mul => 2,
            Class::Div => {
                if upper {
                    12
                } else {
                    7
                }
            }
            Class::Load | Class::Multiple(_) => {
                if upper {
                    3
                } else {
                    2
                }
            }
            Class::LoadPair | Class::Store | Class::StorePair => 2,
            Class::FpMove | Class::FpMovePair | Class::FpSingle => 3,
            Class::FpAlu => 4,
            Class::FpMul => 7,
            Class::FpMac | Class::FpFma => 11,
            Class::FpDiv => 30,
        }
    }

    /// Cycles the instruction holds the issue stage (1, or more for a stall behind it).
    fn occupancy(self, class: Class) -> u64 {
        match (self, class) {
            (Setting::Lower, Class::Multiple(w)) => u64::from(w).div_ceil(2).max(1),
            (Setting::Lower, _) => 1,
            (_, Class::Multiple(w)) => u64::from(w).max(1),
            (_, Class::FpMac) => 4,
            (_, Class::FpFma) => 3,
            (Setting::Upper, Class::Div) => 12,
            (Setting::Upper, Class::FpDiv) => 30,
            _ => 1,
        }
    }
}

/// How an instruction may pair.
fn issues_alone(class: Class) -> bool {
    matches!(
        class,
        Class::LoadPair
            | Class::StorePair
            | Class::Multiple(_)
            | Class::FpMovePair
            | Class::Div
            | Class::System
    )
}

/// Only in the first slot of a pair.
fn first_slot_only(class: Class) -> bool {
    matches!(
        class,
        Class::FpAlu | Class::FpMul | Class::FpMac | Class::FpFma | Class::FpDiv
    )
}

/// The unit an instruction needs that a pair cannot share (the two ALUs and two load
/// units can be shared).
fn unit(class: Class) -> Option<u8> {
    match class {
        Class::Alu | Class::Load => None,
        Class::Store | Class::StorePair => Some(0),
        Class::Mul | Class::Div => Some(1),
        Class::Branch { .. } => Some(2),
        _ => Some(3), // the FPU
    }
}

/// An in-order, dual-issue scoreboard.
#[derive(Debug, Clone)]
pub struct Pipeline {
    setting: Setting,
    /// The cycle the next instruction can issue in, at the earliest.
    cycle: u64,
    /// What issued in `cycle` so far: nothing, or the first of a pair (its unit).
    first: Option<Option<u8>>,
    ready: [u64; REGISTERS],
    /// The FPU is busy (a divide) until then.
    fpu_free: u64,
}

impl Pipeline {
    /// A pipeline at cycle 0.
    pub fn new(setting: Setting) -> Self {
        Self {
            setting,
            cycle: 0,
            first: None,
            ready: [0; REGISTERS],
            fpu_free: 0,
        }
    }

    /// Cycles so far: the issue of everything given, and the stalls behind it.
    pub fn cycles(&self) -> u64 {
        self.cycle + u64::from(self.first.is_some())
    }

    /// Issues `insn`.
    pub fn issue(&mut self, insn: &Insn) {
        let s = self.setting;
        let wait = |mask: u64, ready: &[u64; REGISTERS]| {
            (0..REGISTERS)
                .filter(|r| mask & 1 << r != 0)
                .map(|r| ready[r])
                .max()
                .unwrap_or(0)
        };
        let mut t = self.cycle.max(wait(insn.reads, &self.ready));
        if s != Setting::Lower && insn.address_reads != 0 {
            // Address operands are read in EX1, a cycle before data operands.
            t = t.max(wait(insn.address_reads, &self.ready) + 1);
        }
        if unit(insn.class) == Some(3) && s != Setting::Lower {
            t = t.max(self.fpu_free);
        }
        let pairs = s != Setting::Upper
            && !issues_alone(insn.class)
            && !first_slot_only(insn.class)
            && match self.first {
                Some(None) => true,
                Some(Some(u)) => unit(insn.class) != Some(u),
                None => false,
            };
        if t == self.cycle && self.first.is_some() && !pairs {
            t += 1;
        }
        let second = t == self.cycle && self.first.is_some();
        let occupancy = s.occupancy(insn.class);
        for r in 0..REGISTERS {
            if insn.writes & 1 << r != 0 {
                self.ready[r] = t + s.latency(insn.class);
            }
        }
        if insn.class == Class::FpDiv && s != Setting::Lower {
            self.fpu_free = t + s.latency(insn.class) - 1;
        }
        if second || issues_alone(insn.class) || s == Setting::Upper || occupancy > 1 {
            self.cycle = t + occupancy;
            self.first = None;
        } else {
            self.cycle = t;
            self.first = Some(unit(insn.class));
        }
    }

    /// A branch mispredicted: the pipeline refills.
    pub fn mispredict(&mut self) {
        self.cycle = self.cycles() + MISPREDICT;
        self.first = None;
    }
}

/// A 2-bit counter per conditional branch for its direction and a target buffer for
/// every branch, as a stand-in for the Cortex-M7's branch prediction (not published).
#[derive(Debug, Default)]
pub struct Predictor {
    counters: HashMap<u32, u8>,
    targets: HashMap<u32, u32>,
}

impl Predictor {
    /// Whether the branch at `address` that went to `to` (`taken` or not) was
    /// mispredicted; learns the outcome.
    pub fn mispredicted(&mut self, address: u32, conditional: bool, taken: bool, to: u32) -> bool {
        let mut wrong = false;
        if conditional {
            let c = self.counters.entry(address).or_insert(1);
            wrong = (*c >= 2) != taken;
            *c = if taken {
                (*c + 1).min(3)
            } else {
                c.saturating_sub(1)
            };
        }
        if taken {
            let known = self.targets.insert(address, to);
            wrong |= known != Some(to);
        }
        wrong
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(setting: Setting, lines: &[&str]) -> u64 {
        let mut p = Pipeline::new(setting);
        for l in lines {
            p.issue(&decode(l).unwrap());
        }
        p.cycles()
    }

    #[test]
    fn decodes_qemu_lines() {
        let bl = decode("0x00000050:  f015 f86e  bl       #0x15130").unwrap();
        assert_eq!((bl.size, bl.target), (4, Some(0x15130)));
        let push = decode("0x00015130:  b580       push     {r7, lr}").unwrap();
        assert_eq!((push.size, push.class), (2, Class::Multiple(2)));
        let vmla = decode("0x00001000:  ee00 0b01  vmla.f64 d0, d0, d1").unwrap();
        assert_eq!(vmla.class, Class::FpMac);
        assert_eq!(vmla.writes, 1 << 16);
        assert_eq!(vmla.reads, 1 << 16 | 1 << 17, "the accumulator is read");
        let ldr = decode("0x00001004:  f853 2b04  ldr      r2, [r3], #4").unwrap();
        assert_eq!(ldr.class, Class::Load);
        assert_eq!(
            ldr.writes,
            1 << 2 | 1 << 3,
            "post-indexed: the base is written"
        );
        assert_eq!(ldr.address_reads, 1 << 3);
        let beq = decode("0x00001008:  d001       beq      #0x100e").unwrap();
        assert_eq!(
            beq.class,
            Class::Branch {
                conditional: true,
                indirect: false
            }
        );
        let ret = decode("0x0000100a:  bd80       pop      {r7, pc}").unwrap();
        assert!(matches!(ret.class, Class::Branch { indirect: true, .. }));
        let moveq = decode("0x0000100c:  bf08       moveq    r0, r1").unwrap();
        assert_eq!(
            moveq.reads & 1 << FLAGS,
            1 << FLAGS,
            "conditional: reads flags"
        );
        let vldr = decode("0x0000100e:  ed93 0b00  vldr     d0, [r3]").unwrap();
        assert_eq!(vldr.class, Class::LoadPair);
        let vmov = decode("0x00001012:  ec51 0b10  vmov     r0, r1, d0").unwrap();
        assert_eq!(
            (vmov.class, vmov.writes),
            (Class::FpMovePair, 0b11),
            "two core registers written"
        );
    }

    #[test]
    fn independent_integer_instructions_pair() {
        let code = [
            "0x00000000:  2000       movs     r0, #0",
            "0x00000002:  2101       movs     r1, #1",
            "0x00000004:  2202       movs     r2, #2",
            "0x00000006:  2303       movs     r3, #3",
        ];
        assert_eq!(run(Setting::Lower, &code), 2);
        assert_eq!(run(Setting::Point, &code), 2);
        assert_eq!(run(Setting::Upper, &code), 4);
    }

    #[test]
    fn a_dependent_double_multiply_waits_for_its_operand() {
        let code = [
            "0x00000000:  ee20 0b01  vmul.f64 d0, d0, d1",
            "0x00000004:  ee20 0b02  vmul.f64 d0, d0, d2",
        ];
        // Point: the second issues 7 cycles after the first.
        assert_eq!(run(Setting::Point, &code), 8);
        assert_eq!(run(Setting::Lower, &code), 2);
        let independent = [
            "0x00000000:  ee20 0b01  vmul.f64 d0, d0, d1",
            "0x00000004:  ee21 1b02  vmul.f64 d1, d1, d2",
        ];
        assert_eq!(run(Setting::Point, &independent), 2, "first slot only");
    }

    #[test]
    fn a_double_divide_blocks_the_fpu_but_not_the_integer_pipeline() {
        let code = [
            "0x00000000:  ee80 0b01  vdiv.f64 d0, d0, d1",
            "0x00000004:  2000       movs     r0, #0",
            "0x00000006:  ee31 1b02  vadd.f64 d1, d1, d2",
        ];
        let point = run(Setting::Point, &code);
        assert!((29..=31).contains(&point), "{point}");
        assert_eq!(run(Setting::Upper, &code), 32);
    }

    #[test]
    fn the_three_settings_are_ordered_on_mixed_code() {
        let code = [
            "0x00000000:  e9d3 2300  ldrd     r2, r3, [r3]",
            "0x00000004:  18d0       adds     r0, r2, r3",
            "0x00000006:  ed93 0b00  vldr     d0, [r3]",
            "0x0000000a:  ee00 0b01  vmla.f64 d0, d0, d1",
            "0x0000000e:  ed83 0b00  vstr     d0, [r3]",
            "0x00000012:  b4f0       push     {r4, r5, r6, r7}",
            "0x00000014:  fbb0 f0f1  udiv     r0, r0, r1",
        ];
        let (l, p, u) = (
            run(Setting::Lower, &code),
            run(Setting::Point, &code),
            run(Setting::Upper, &code),
        );
        assert!(l < p && p < u, "{l} {p} {u}");
    }

    #[test]
    fn the_predictor_learns_a_loop_branch() {
        let mut p = Predictor::default();
        let wrong: usize = (0..100)
            .map(|i| usize::from(p.mispredicted(0x100, true, i % 10 != 9, 0x80)))
            .sum();
        // The first taken (target unknown), then once per exit and once after it.
        assert!((10..=21).contains(&wrong), "{wrong}");
    }
}
