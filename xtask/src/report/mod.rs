//! `cargo xtask report LOG [--scene SCENE] [--out DIR] [--eds NODE=FILE …]`: a recorded
//! bus in, the crane's report out (docs/REPORT.md).
//!
//! The log (candump `-L` or Vector ASC, [`logs`]) is read once, frame by frame, with
//! bounded memory; each frame is decoded against `can/crane.dbc` (by the project's DBC
//! reader, `host_tests::dbc`, on can-dbc) for the crane the scene and its commissioning
//! file describe ([`bus`]), and handed to the analyses — the network ([`network`]),
//! requests and answers ([`requests`]), the drives ([`drives`]), the load
//! ([`load`]), faults and EMCYs ([`faults`]), timing ([`timing`]). The page
//! ([`html`]) and its figures ([`figures`]) are written to DIR with `summary.json`, the
//! report's numbers for tools and tests.
//!
//! Bad input is reported, not fatal: unreadable lines, ids the DBC does not know, frames
//! it cannot decode, a log without the controller, two controllers on one bus. Only a
//! file that cannot be read, or is in neither format, is an error.

pub mod bench;
pub mod browser;
mod bus;
mod drives;
mod faults;
mod figures;
mod html;
mod load;
mod logs;
mod network;
mod requests;
mod sdo;
mod series;
mod timing;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use host_tests::dbc::{Dbc, Decoded};
use serde::Serialize;

use crate::firmware::root;
use bus::{Cob, Crane, Role};
use logs::{Format, Frame, ReadStats};
use series::Capped;

/// The default scene: the virtual ECU's and the firmware's (one constant for all).
pub use host_tests::DEFAULT_SCENE;

/// What `cargo xtask report` is asked.
#[derive(Debug, Clone)]
pub struct Options {
    /// The log.
    pub log: PathBuf,
    /// The crane's scene (its commissioning file beside it).
    pub scene: PathBuf,
    /// Where the page, the figures and `summary.json` go.
    pub out: PathBuf,
    /// EDS files by node, over the defaults.
    pub eds: Vec<(u8, PathBuf)>,
}

/// One frame as the analyses see it.
pub struct Seen<'a> {
    /// Seconds from the log's first frame.
    pub t: f64,
    /// Nanoseconds from the log's first frame, exact: for the thresholds an interval
    /// of whole microseconds may sit on (1.5 cycles, a histogram bin's edge).
    pub ns: i64,
    /// The frame.
    pub frame: &'a Frame,
    /// Its meaning by the predefined connection set.
    pub cob: Cob,
    /// Decoded by the DBC, if it could be.
    pub decoded: Option<&'a Decoded>,
}

impl Seen<'_> {
    /// The DBC's name for a signal's value (`VAL_`), if it has one.
    pub fn label(&self, signal: &str) -> Option<String> {
        self.decoded?
            .signals
            .iter()
            .find(|s| s.name == signal)?
            .label
            .clone()
    }
}

/// What the DBC made of the frames.
#[derive(Debug, Default, Serialize)]
pub struct Decoding {
    /// Frames decoded.
    pub decoded: u64,
    /// Frames whose id the DBC does not have, by id.
    pub unknown_ids: BTreeMap<String, u64>,
    /// Frames of further unknown ids (beyond the 64 listed).
    pub unknown_other: u64,
    /// Frames the DBC has but cannot decode (their length), by message: (count, first reason).
    pub undecodable: BTreeMap<String, (u64, String)>,
    /// Remote frames (no data to decode).
    pub remote: u64,
    /// Extended-id frames (no CANopen frame).
    pub extended: u64,
}

/// The whole report's numbers (`summary.json`).
#[derive(Debug, Serialize)]
pub struct Summary {
    /// The log file.
    pub log: String,
    /// Its format.
    pub format: &'static str,
    /// The crane: kind, scene.
    pub crane: String,
    /// The scene file.
    pub scene: String,
    /// Seconds from the first frame to the last.
    pub duration: f64,
    /// What reading found.
    pub read: ReadStats,
    /// What decoding found.
    pub decoding: Decoding,
    /// Whether the controller sent anything.
    pub controller_heard: bool,
    /// Signs of two controllers on one bus.
    pub two_controllers: Vec<String>,
    /// The nodes seen.
    pub nodes: BTreeMap<u8, network::Node>,
    /// NMT commands.
    pub nmt: Capped<network::NmtCommand>,
    /// SDO exchanges and aborts per server node.
    pub sdo: BTreeMap<u8, (u64, u64)>,
    /// Requests in order.
    pub requests: Capped<requests::Request>,
    /// Answers to no request in the log.
    pub unasked: Capped<(f64, u8, String, String)>,
    /// Modes (s, mode, fault).
    pub modes: Capped<(f64, String, String)>,
    /// Counter increases.
    pub counters: Capped<(f64, String, u64, u64)>,
    /// Last counters: ignored, deadline misses, transmit failures.
    pub last_counters: Option<[u64; 3]>,
    /// Status frames.
    pub statuses: u64,
    /// Manual-mode frames.
    pub manual_frames: u64,
    /// Drives.
    pub drives: Vec<drives::DriveRecord>,
    /// Inclinometer readings.
    pub inclinometer_readings: u64,
    /// Largest swing per plane, degrees (`None`: not read).
    pub max_swing: Vec<Option<f64>>,
    /// SYNCs with no fresh inclinometer reading after the first.
    pub stale_inclinometer_cycles: u64,
    /// Move verdicts.
    pub moves: Capped<load::Verdict>,
    /// EMCYs.
    pub emcys: Capped<faults::Emcy>,
    /// Timing.
    pub timing: timing::Timing,
    /// What the log cannot answer.
    pub cannot_answer: Vec<String>,
    /// Where the fault reactions were read.
    pub reactions_source: String,
}

/// The EDS of each node by default: the controller's own (`can/crane-controller.eds`),
/// the interop suite's generic CiA 402 drive and CiA 410 inclinometers — a crane's own
/// drives' EDS are given with `--eds NODE=FILE`.
fn default_eds(crane: &Crane) -> Vec<(u8, PathBuf)> {
    let mut eds = vec![(crane.controller, root().join("can/crane-controller.eds"))];
    eds.extend(
        crane
            .drives
            .iter()
            .map(|d| (d.node, root().join("interop/cia402-drive.eds"))),
    );
    let inclinometer = if crane.inclinometer.axes == 2 {
        "interop/cia410-inclinometer-2axis.eds"
    } else {
        "interop/cia410-inclinometer.eds"
    };
    eds.push((crane.inclinometer.node, root().join(inclinometer)));
    eds
}

/// The analyses over one log.
struct Analyses {
    crane: Crane,
    dbc: Dbc,
    known: Vec<bool>,
    decoding: Decoding,
    network: network::Network,
    requests: requests::Requests,
    drives: drives::Drives,
    load: load::Load,
    faults: faults::Faults,
    timing: timing::Timing,
    t0: Option<i64>,
    t_last: f64,
}

impl Analyses {
    fn new(crane: Crane, eds: Vec<(u8, PathBuf)>) -> Result<Self, String> {
        let dbc = Dbc::crane()?;
        let known = (0u16..0x800)
            .map(|id| dbc.signal_sizes(id).is_some())
            .collect();
        let mut names = BTreeMap::new();
        for (node, path) in eds {
            names.insert(node, sdo::Eds::load(&path)?);
        }
        Ok(Self {
            network: network::Network::new(&crane, names),
            requests: requests::Requests::new(crane.controller),
            drives: drives::Drives::new(&crane),
            load: load::Load::new(&crane),
            faults: faults::Faults::new(&root().join("docs/COMMANDS.md")),
            timing: timing::Timing::new(&crane),
            crane,
            dbc,
            known,
            decoding: Decoding::default(),
            t0: None,
            t_last: 0.0,
        })
    }

    fn frame(&mut self, frame: &Frame) {
        let t0 = *self.t0.get_or_insert(frame.t);
        let ns = frame.t.saturating_sub(t0);
        let t = ns as f64 / 1e9;
        self.t_last = self.t_last.max(t);
        if frame.extended {
            self.decoding.extended += 1;
        }
        if frame.remote {
            self.decoding.remote += 1;
            return;
        }
        let cob = Cob::of(frame.id, frame.extended);
        let decoded = if frame.extended {
            None
        } else {
            let id = self.crane.dbc_id(frame.id);
            if self.known.get(id as usize).copied().unwrap_or(false) {
                match self.dbc.decode(id as u16, frame.bytes()) {
                    Ok(d) => {
                        self.decoding.decoded += 1;
                        Some(d)
                    }
                    Err(e) => {
                        let key = format!("0x{:03X}", frame.id);
                        self.decoding.undecodable.entry(key).or_insert((0, e)).0 += 1;
                        None
                    }
                }
            } else {
                let key = format!("0x{:03X}", frame.id);
                let ids = &mut self.decoding.unknown_ids;
                if let Some(n) = ids.get_mut(&key) {
                    *n += 1;
                } else if ids.len() < 64 {
                    ids.insert(key, 1);
                } else {
                    self.decoding.unknown_other += 1;
                }
                None
            }
        };
        let seen = Seen {
            t,
            ns,
            frame,
            cob,
            decoded: decoded.as_ref(),
        };
        let drive = cob.node().and_then(|n| self.crane.drive_of(n));
        self.network.frame(&seen);
        self.faults.frame(&seen, &self.crane);
        self.timing.frame(&seen, drive);
        self.drives.frame(&seen, drive);
        let changes = self.requests.mode_changes;
        match self.requests.frame(&seen) {
            Some(Ok(a)) => self
                .load
                .accepted(a.t, a.id, a.target, a.duration, a.queued),
            Some(Err(t)) => self.load.stop(t),
            None => {}
        }
        if self.requests.mode_changes != changes {
            if let Some((mode, fault)) = self.requests.mode_now() {
                self.faults.mode(t, mode, fault);
            }
        }
        match cob {
            Cob::Tpdo(1, n) if n == self.crane.controller => {
                if let Some(d) = &decoded {
                    let fault = d.get("fault").filter(|f| *f != 0.0);
                    let label = seen.label("fault");
                    self.load
                        .fault(t, fault.map(|_| label.as_deref().unwrap_or("?")));
                }
            }
            Cob::Tpdo(1, n) if self.crane.role(n) == Role::Inclinometer => {
                if let Some(d) = &decoded {
                    self.load
                        .inclinometer(t, d.get("slope_long16"), d.get("slope_lateral16"));
                }
            }
            Cob::Sync => {
                let positions: Vec<Option<f64>> =
                    self.drives.drives.iter().map(|d| d.position_now).collect();
                let setpoints: Vec<Option<f64>> = self.drives.last_setpoints().collect();
                self.load.cycle(t, &positions, &setpoints);
            }
            _ => {}
        }
    }

    fn finish(mut self, log: &Path, format: Format, read: ReadStats) -> (Summary, Extras) {
        self.network.finish();
        self.load.finish(self.t_last);
        self.faults.finish(self.t_last);
        let mut two = Vec::new();
        // A loaded host's recorder (or a late cycle caught up at once) brings a few SYNCs
        // close together; a second producer brings every other one.
        if self.timing.doubled_syncs > 10 && self.timing.doubled_syncs * 10 > self.timing.syncs {
            two.push(format!(
                "{} SYNCs came less than half a cycle after the one before (two SYNC producers?)",
                self.timing.doubled_syncs
            ));
        }
        let beats = self
            .network
            .nodes
            .get(&self.crane.controller)
            .map_or(0, |n| n.heartbeats);
        if self.network.early_controller_heartbeats > 3
            && self.network.early_controller_heartbeats * 10 > beats
        {
            two.push(format!(
                "{} heartbeats of node {} came less than half its period after the one before (two nodes with the controller's id?)",
                self.network.early_controller_heartbeats, self.crane.controller
            ));
        }
        if self.faults.duplicate_node > 0 {
            two.push(format!(
                "the controller announced another node with its id (fault 18, DuplicateNodeId) {} time(s)",
                self.faults.duplicate_node
            ));
        }
        let heard = self.network.controller_heard();
        let mut cannot = Vec::new();
        if !heard {
            cannot.push(format!(
                "no controller traffic in this log: nothing from node {} (heartbeat 0x{:03X}, status 0x{:03X}, EMCY 0x{:03X}) — requests, answers, modes and the controller's faults cannot be read",
                self.crane.controller,
                0x700 + u32::from(self.crane.controller),
                0x180 + u32::from(self.crane.controller),
                0x80 + u32::from(self.crane.controller)
            ));
        }
        if self.load.readings == 0 {
            cannot.push(format!(
                "no inclinometer on the bus (no TPDO1 0x{:03X} from node {}): the swing is not measured; the load's position is taken hanging still below the trolley",
                0x180 + u32::from(self.crane.inclinometer.node),
                self.crane.inclinometer.node
            ));
        }
        if self.timing.syncs == 0 {
            cannot.push("no SYNC in this log: the cycle's timing cannot be read".into());
        }
        for d in &self.drives.drives {
            if d.positions.is_none() {
                cannot.push(format!(
                    "no position actual (TPDO2 0x{:03X}) from the {} drive: its position and the load's cannot be read",
                    0x280 + u32::from(d.node),
                    d.name
                ));
            }
        }
        if self.requests.manual == 0 {
            cannot.push(format!(
                "no manual-mode frames (0x{:03X}) in this log",
                0x400 + u32::from(self.crane.controller)
            ));
        }
        cannot.push("the recorder's time stamps are the host's: the jitter shown includes the recorder's own".into());
        let sdo = self
            .network
            .sdo
            .iter()
            .map(|(n, c)| (*n, (c.exchanges, c.aborts)))
            .collect();
        let summary = Summary {
            log: shown(log),
            format: format.name(),
            crane: self.crane.kind.to_string(),
            scene: shown(&self.crane.scene),
            duration: self.t_last,
            read,
            decoding: self.decoding,
            controller_heard: heard,
            two_controllers: two,
            nodes: self.network.nodes.clone(),
            nmt: self.network.nmt.clone(),
            sdo,
            requests: self.requests.requests,
            unasked: self.requests.unasked,
            modes: self.requests.modes,
            counters: self.requests.counters,
            last_counters: self.requests.last_counters,
            statuses: self.requests.statuses,
            manual_frames: self.requests.manual,
            drives: self.drives.drives.clone(),
            inclinometer_readings: self.load.readings,
            max_swing: self.load.max_swing[..self.load.planes()].to_vec(),
            stale_inclinometer_cycles: self.load.stale_cycles,
            moves: self.load.verdicts.clone(),
            emcys: self.faults.emcys,
            timing: self.timing,
            cannot_answer: cannot,
            reactions_source: self.faults.reactions_source,
        };
        let extras = Extras {
            crane: self.crane,
            network: self.network,
            drives: self.drives,
            load: self.load,
        };
        (summary, extras)
    }
}

/// What the page needs besides the summary: the curves and the transcripts.
pub struct Extras {
    crane: Crane,
    network: network::Network,
    drives: drives::Drives,
    load: load::Load,
}

/// Reads the log and writes the report; returns the summary and the frames per second.
pub fn report(options: &Options) -> Result<Summary, String> {
    let format = logs::detect(&options.log)?;
    let crane = Crane::load(&options.scene)?;
    let mut eds = default_eds(&crane);
    eds.extend(options.eds.iter().cloned());
    let mut analyses = Analyses::new(crane, eds)?;
    let (mut reader, size) = logs::open(&options.log, format)?;
    let progress = (size > 32 << 20).then(|| {
        let bar = indicatif::ProgressBar::new(size);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{msg} [{bar:40}] {bytes}/{total_bytes} ({eta})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        bar.set_message("reading the log");
        bar
    });
    let began = Instant::now();
    let cpu_began = cpu_seconds();
    while let Some(frame) = reader.next_frame()? {
        analyses.frame(&frame);
        if let Some(bar) = &progress {
            if reader.stats.frames % 65_536 == 0 {
                bar.set_position(reader.stats.bytes);
            }
        }
    }
    if let Some(bar) = progress {
        bar.finish_and_clear();
    }
    let read_seconds = began.elapsed().as_secs_f64();
    let cpu = cpu_seconds().zip(cpu_began).map(|(end, start)| end - start);
    let frames = reader.stats.frames;
    let (summary, extras) = analyses.finish(&options.log, format, reader.stats);
    std::fs::create_dir_all(&options.out).map_err(|e| format!("{}: {e}", options.out.display()))?;
    html::write(&options.out, &summary, &extras)?;
    let json = serde_json::to_string_pretty(&summary).map_err(|e| e.to_string())?;
    let path = options.out.join("summary.json");
    std::fs::write(&path, json).map_err(|e| format!("{}: {e}", path.display()))?;
    // Wall-clock time depends on what else the machine runs; the CPU time this process
    // spent reading is the cost of the report itself.
    let per_million = |seconds: f64| {
        (frames > 0).then(|| {
            format!(
                ", {:.2} s per million frames",
                seconds * 1e6 / frames as f64
            )
        })
    };
    eprintln!(
        "report: {frames} frames read in {read_seconds:.2} s{} (CPU {}), peak memory {} — {}",
        per_million(read_seconds).unwrap_or_default(),
        cpu.map_or("unknown".into(), |c| format!(
            "{c:.2} s{}",
            per_million(c).unwrap_or_default()
        )),
        peak_memory().map_or("unknown".into(), |kib| format!(
            "{:.1} MiB",
            kib as f64 / 1024.0
        )),
        options.out.join("index.html").display()
    );
    Ok(summary)
}

/// A path as the report shows it: relative to the repository when inside it, so that
/// the committed example's report is the same on every machine.
pub fn shown(path: &Path) -> String {
    let root = root();
    let absolute = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .map(|d| d.join(path))
            .unwrap_or_else(|_| path.to_path_buf())
    };
    absolute
        .strip_prefix(&root)
        .map(|p| p.display().to_string())
        .unwrap_or_else(|_| path.display().to_string())
}

/// The committed example (`docs/report-example/`): its report made again into
/// `target/report-example` must equal the committed one file for file (else it is out of
/// date: `cargo xtask report docs/report-example/healthy.log --scene
/// scenes/paper-crane-feedback.toml --out docs/report-example`), and the page must load
/// in headless chromium.
pub fn check_example() -> Result<(), String> {
    let committed = root().join(EXAMPLE_DIR);
    let out = crate::ecu::target_dir().join("report-example");
    let _ = std::fs::remove_dir_all(&out);
    report(&Options {
        log: committed.join(EXAMPLE_LOG),
        scene: root().join(EXAMPLE_SCENE),
        out: out.clone(),
        eds: Vec::new(),
    })?;
    same_files(&out, &committed, EXAMPLE_LOG).map_err(|what| {
        format!(
            "{what}: regenerate the example with `cargo xtask report docs/report-example/{EXAMPLE_LOG} \
             --scene {EXAMPLE_SCENE} --out docs/report-example`"
        )
    })?;
    browser::check(&out.join("index.html"))
}

/// Where the committed example is.
const EXAMPLE_DIR: &str = "docs/report-example";
/// The committed example's log (in [`EXAMPLE_DIR`]).
const EXAMPLE_LOG: &str = "healthy.log";

/// Whether the directory `committed` holds exactly the files the report `made`, byte
/// for byte, besides its log `keep`: a file the report no longer makes (a figure renamed
/// or dropped) is as stale as one it makes otherwise. The error names the file.
fn same_files(made: &Path, committed: &Path, keep: &str) -> Result<(), String> {
    let names = |dir: &Path| -> Result<Vec<std::ffi::OsString>, String> {
        let mut names: Vec<_> = std::fs::read_dir(dir)
            .map_err(|e| format!("{}: {e}", dir.display()))?
            .filter_map(Result::ok)
            .map(|e| e.file_name())
            .filter(|n| n != keep)
            .collect();
        names.sort();
        Ok(names)
    };
    let (made_names, kept_names) = (names(made)?, names(committed)?);
    for name in &made_names {
        let new = std::fs::read(made.join(name)).map_err(|e| e.to_string())?;
        if std::fs::read(committed.join(name)).ok() != Some(new) {
            return Err(format!(
                "{} is not what the report makes now",
                committed.join(name).display()
            ));
        }
    }
    if let Some(stale) = kept_names.iter().find(|n| !made_names.contains(n)) {
        return Err(format!(
            "{} is not made by the report any more",
            committed.join(stale).display()
        ));
    }
    Ok(())
}

/// The scene of the committed example (the state feedback, with the inclinometer).
pub const EXAMPLE_SCENE: &str = "scenes/paper-crane-feedback.toml";

/// The CPU time this thread has run, s (the first field of `/proc/self/schedstat`,
/// nanoseconds) — Linux.
pub fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/schedstat").ok()?;
    let ns: u64 = stat.split_whitespace().next()?.parse().ok()?;
    Some(ns as f64 / 1e9)
}

/// The process's peak resident memory (VmHWM), KiB — Linux.
pub fn peak_memory() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// `NODE=FILE` of `--eds`.
pub fn parse_eds(arg: &str) -> Result<(u8, PathBuf), String> {
    let (node, file) = arg
        .split_once('=')
        .ok_or_else(|| format!("--eds {arg}: NODE=FILE"))?;
    let node = match node.strip_prefix("0x") {
        Some(hex) => u8::from_str_radix(hex, 16),
        None => node.parse(),
    }
    .ok()
    .filter(|n| (1..=127).contains(n))
    .ok_or_else(|| format!("--eds {arg}: a node id 1..=127"))?;
    Ok((node, PathBuf::from(file)))
}

#[cfg(test)]
mod tests;
