//! Faults and EMCYs: every emergency message with its node, CiA 301 error code and error
//! register; the controller's own decoded by the DBC (`EMCY_Controller`: the fault by
//! its value table, the node concerned, the detail, the object or the SDO abort code);
//! the reaction docs/COMMANDS.md documents for the fault (its fault table, read when the
//! report runs, so a new fault there needs no code edit here) and the reaction taken —
//! the modes the status frames showed after it.

use std::collections::BTreeMap;
use std::path::Path;

use controller::canopen::{emcy, sdo::abort};
use serde::Serialize;

use super::bus::{Cob, Crane};
use super::series::Capped;
use super::Seen;

/// An emergency error code's meaning: the exact codes a crane's nodes send (CiA 301's
/// Tab. 21; 0x2310, 0x3210, 0x3220, 0x4210, 0x5530 and 0x6010 as CiA 402 names them for
/// drives), then CiA 301's classes.
pub fn error_code_meaning(code: u16) -> &'static str {
    match code {
        0x0000 => "error reset or no error",
        0x1000 => "generic error",
        0x2310 => "continuous over current (output side)",
        0x3210 => "DC link over voltage",
        0x3220 => "DC link under voltage",
        0x4210 => "excess temperature device",
        0x5530 => "data storage (non-volatile memory)",
        0x6010 => "software reset (watchdog)",
        0x6100 => "internal software",
        0x6200 => "user software",
        0x6300 => "data set",
        0x8100 => "communication",
        0x8110 => "CAN overrun (objects lost)",
        0x8120 => "CAN in error passive mode",
        0x8130 => "life guard error or heartbeat error",
        0x8140 => "recovered from bus off",
        0x8150 => "CAN-ID collision",
        0x8210 => "PDO not processed due to length error",
        0x8220 => "PDO length exceeded",
        0x8230 => "DAM MPDO not processed, destination object not available",
        0x8240 => "unexpected SYNC data length",
        0x8250 => "RPDO timeout",
        c if c >> 12 == 0x2 => "current",
        c if c >> 12 == 0x3 => "voltage",
        c if c >> 12 == 0x4 => "temperature",
        c if c >> 12 == 0x5 => "device hardware",
        c if c >> 12 == 0x6 => "device software",
        c if c >> 12 == 0x7 => "additional modules",
        c if c >> 8 == 0x81 => "communication",
        c if c >> 8 == 0x82 => "protocol error",
        c if c >> 12 == 0x8 => "monitoring",
        c if c >> 12 == 0x9 => "external error",
        c if c >> 8 == 0xF0 => "additional functions",
        c if c >> 8 == 0xFF => "device specific",
        _ => "not a CiA 301 error code class",
    }
}

/// The bits of an error register (0x1001) that are set, by name (CiA 301 §7.5.2.2;
/// bit 6 is reserved).
pub fn register_bits(register: u8) -> Vec<&'static str> {
    [
        "generic",
        "current",
        "voltage",
        "temperature",
        "communication",
        "device profile specific",
        "reserved bit 6",
        "manufacturer specific",
    ]
    .into_iter()
    .enumerate()
    .filter(|(bit, _)| register & (1 << bit) != 0)
    .map(|(_, name)| name)
    .collect()
}

/// One EMCY.
#[derive(Debug, Clone, Serialize)]
pub struct Emcy {
    /// When, s.
    pub t: f64,
    /// The node that sent it.
    pub node: u8,
    /// Its name on this bus.
    pub from: String,
    /// Error code.
    pub code: u16,
    /// Error register (0x1001).
    pub register: u8,
    /// The error register's bits set, by name (CiA 301 §7.5.2.2).
    pub register_bits: Vec<&'static str>,
    /// The manufacturer-specific error field (bytes 3–7) as hex bytes: what a drive's
    /// manual explains; the controller's are decoded in `meaning`.
    pub manufacturer: String,
    /// What the code means (CiA 301), and for the controller's what its fault is.
    pub meaning: String,
    /// Fault (the controller's, the DBC's value table), if any.
    pub fault: Option<String>,
    /// The fault's number (status byte 4), if any.
    pub fault_code: Option<u8>,
    /// The reaction docs/COMMANDS.md documents for it.
    pub documented: Option<String>,
    /// The modes the status frames showed within 5 s after it (filled at the end).
    pub taken: String,
    /// A warning (the error register's generic bit clear) rather than an error.
    pub warning: bool,
}

/// What the faults section reports.
#[derive(Debug)]
pub struct Faults {
    /// Every EMCY.
    pub emcys: Capped<Emcy>,
    /// Faults 18 (another node with the controller's id) the controller announced.
    pub duplicate_node: u64,
    reactions: BTreeMap<u8, (String, String)>,
    /// Where the reactions were read, or why not.
    pub reactions_source: String,
    /// The controller's EMCYs whose reaction is being watched (their 5 s are open):
    /// the reaction is followed as the log streams by, not read afterwards from the
    /// page's list of modes, which keeps only its first entries.
    watching: Vec<Watch>,
    /// The mode changes of the last [`BEFORE`] s.
    recent: Vec<(f64, String)>,
}

/// The fault table of docs/COMMANDS.md: fault number → (what, reaction). The warning
/// row (no number) is fault 15, as the DBC's value table has it.
pub fn documented_reactions(path: &Path) -> Result<BTreeMap<u8, (String, String)>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut table = BTreeMap::new();
    let mut in_faults = false;
    for line in text.lines() {
        if line.starts_with("## ") {
            in_faults = line.trim() == "## Faults";
            continue;
        }
        if !in_faults || !line.starts_with('|') {
            continue;
        }
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        let [what, reaction, ..] = cells[..] else {
            continue;
        };
        let number: String = what.chars().take_while(char::is_ascii_digit).collect();
        if let Ok(n) = number.parse::<u8>() {
            table.insert(
                n,
                (
                    what[number.len()..].trim().to_string(),
                    reaction.to_string(),
                ),
            );
        } else if what.starts_with('—') {
            table.insert(
                15,
                (
                    what.trim_start_matches('—').trim().to_string(),
                    reaction.to_string(),
                ),
            );
        }
    }
    if table.is_empty() {
        return Err(format!(
            "{}: no fault table under \"## Faults\"",
            path.display()
        ));
    }
    Ok(table)
}

impl Faults {
    /// With the reactions of the fault table at `commands` (docs/COMMANDS.md).
    pub fn new(commands: &Path) -> Self {
        let (reactions, reactions_source) = match documented_reactions(commands) {
            Ok(r) => (r, format!("the fault table of {}", super::shown(commands))),
            Err(e) => (BTreeMap::new(), format!("not read ({e})")),
        };
        Self {
            emcys: Capped::new(500),
            duplicate_node: 0,
            reactions,
            reactions_source,
            watching: Vec::new(),
            recent: Vec::new(),
        }
    }

    /// One frame.
    pub fn frame(&mut self, s: &Seen, crane: &Crane) {
        let Cob::Emcy(node) = s.cob else {
            return;
        };
        let data = s.frame.bytes();
        if data.len() < 3 {
            return; // counted as undecodable by the caller
        }
        let code = u16::from_le_bytes([data[0], data[1]]);
        let register = data[2];
        let manufacturer: Vec<String> = data[3..].iter().map(|b| format!("{b:02X}")).collect();
        let mut e = Emcy {
            t: s.t,
            node,
            from: crane.node_name(node),
            code,
            register,
            register_bits: register_bits(register),
            manufacturer: manufacturer.join(" "),
            meaning: error_code_meaning(code).to_string(),
            fault: None,
            fault_code: None,
            documented: None,
            taken: String::new(),
            warning: code != emcy::NO_ERROR && !emcy::is_fault(code, register),
        };
        if node == crane.controller {
            if let Some(d) = s.decoded {
                let fault = d.get("fault").map(|f| f as u8);
                let label = s.label("fault");
                e.fault_code = fault;
                e.fault = label.clone();
                let mut parts = vec![e.meaning.clone()];
                if let Some(label) = &label {
                    parts.push(format!("fault {} {label}", fault.unwrap_or(0)));
                }
                if let Some(n) = d.get("node").filter(|n| *n > 0.0) {
                    parts.push(format!("concerning {}", crane.node_name(n as u8)));
                }
                if let Some(detail) = d.get("detail").filter(|d| *d > 0.0) {
                    parts.push(format!("detail {detail}"));
                }
                if let Some(index) = d.get("object_index").filter(|i| *i > 0.0) {
                    parts.push(format!("object 0x{:04X}", index as u32));
                }
                if let Some(abort) = d.get("abort_code") {
                    let abort = abort as u32;
                    parts.push(format!(
                        "SDO abort 0x{abort:08X} ({})",
                        abort::describe(abort)
                    ));
                }
                e.meaning = parts.join("; ");
                if code == 0 {
                    e.meaning = "error reset: the controller was reset".into();
                }
                if let Some(f) = fault.filter(|_| code != 0 && code != 0xFF12) {
                    e.documented = self
                        .reactions
                        .get(&f)
                        .map(|(what, reaction)| format!("{reaction} ({what})"));
                    if label.as_deref() == Some("DuplicateNodeId") {
                        self.duplicate_node += 1;
                    }
                }
            }
        }
        let watch = e.fault_code.is_some();
        let t = e.t;
        self.emcys.push(e);
        let row = self.emcys.items.len() - 1;
        if watch && self.emcys.dropped == 0 {
            let mut w = Watch {
                emcy: row,
                changes: Vec::new(),
                more: 0,
            };
            for (_, change) in self.recent.iter().filter(|(when, _)| t - when <= BEFORE) {
                w.add(change);
            }
            self.watching.push(w);
        }
    }

    /// A change of the controller's mode or fault, as its status frame showed it: part
    /// of the reaction to each EMCY of the last 5 s (and of one that follows within 20
    /// ms: the recorder may log the status before the EMCY).
    pub fn mode(&mut self, t: f64, mode: &str, fault: &str) {
        let change = (t, format!("{mode} (fault {fault}) at {t:.2} s"));
        let emcys = &mut self.emcys.items;
        self.watching.retain(|w| {
            let open = emcys.get(w.emcy).is_some_and(|e| t <= e.t + AFTER);
            if !open {
                if let Some(e) = emcys.get_mut(w.emcy) {
                    e.taken = w.taken(AFTER);
                }
            }
            open
        });
        for w in &mut self.watching {
            w.add(&change.1);
        }
        self.recent.retain(|(when, _)| t - when <= BEFORE);
        if self.recent.len() < RECENT {
            self.recent.push(change);
        }
    }

    /// The end of the log at `end`: the reactions still watched are what the log shows.
    pub fn finish(&mut self, end: f64) {
        for w in std::mem::take(&mut self.watching) {
            if let Some(e) = self.emcys.items.get_mut(w.emcy) {
                e.taken = w.taken((end - e.t).min(AFTER));
            }
        }
    }
}

/// How long after an EMCY the status frames show the reaction to it, s.
const AFTER: f64 = 5.0;
/// How long before it a status frame may show it, s (the recorder's order).
const BEFORE: f64 = 0.02;
/// Mode changes kept from the last [`BEFORE`] s.
const RECENT: usize = 16;
/// Mode changes listed per reaction.
const CHANGES: usize = 20;

/// The reaction to one of the controller's EMCYs, watched while its window is open.
#[derive(Debug)]
struct Watch {
    /// Its row in [`Faults::emcys`].
    emcy: usize,
    /// The mode changes seen, the first [`CHANGES`].
    changes: Vec<String>,
    /// Changes beyond those.
    more: u64,
}

impl Watch {
    fn add(&mut self, change: &str) {
        if self.changes.len() < CHANGES {
            self.changes.push(change.to_string());
        } else {
            self.more += 1;
        }
    }

    /// The reaction as the page says it, over a window of `window` s.
    fn taken(&self, window: f64) -> String {
        if self.changes.is_empty() {
            return if window < AFTER {
                format!(
                    "no change of mode in the status frames in the {window:.1} s until the log ends"
                )
            } else {
                format!("no change of mode in the status frames within {AFTER:.0} s")
            };
        }
        let mut text = self.changes.join(" → ");
        if self.more > 0 {
            text.push_str(&format!(" → … and {} more", self.more));
        }
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::firmware::root;

    #[test]
    fn the_reactions_are_read_from_the_fault_table() {
        let table = documented_reactions(&root().join("docs/COMMANDS.md")).unwrap();
        assert_eq!(table.get(&3).unwrap().1, "quick stop");
        assert_eq!(table.get(&1).unwrap().1, "controlled stop");
        assert!(table.get(&15).unwrap().1.starts_with("none"));
        assert!(documented_reactions(&root().join("README.md")).is_err());
    }

    #[test]
    fn error_codes() {
        assert_eq!(
            error_code_meaning(0x8130),
            "life guard error or heartbeat error"
        );
        assert_eq!(error_code_meaning(0x2311), "current");
        assert_eq!(error_code_meaning(0xFF02), "device specific");
    }
}
