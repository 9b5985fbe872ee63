//! SDO transfers as a transcript a commissioning engineer reads, one line per transfer
//! however many frames it took: "read 0x1000:0 Device type → 0x00020192", "write
//! 0x6060:0 Modes of operation = 0x09 (9) → done", "read 0x1008:0 → \"Crane\" (5
//! bytes, segmented)", "… → abort 0x06090030 (invalid value for parameter)". Each
//! channel is followed frame by frame through CiA 301's expedited, segmented and block
//! transfers (§7.2.4.3): a block's segments carry a sequence number where other frames
//! carry a command, and are read as segments, never as commands; toggle bits are
//! checked. Objects are named from each node's EDS (rust-ini reads it), abort codes by
//! CiA 301's table as the controller names them (`controller::canopen::sdo::abort`).

use std::collections::HashMap;
use std::path::Path;

use controller::canopen::sdo::abort;

/// Object names from one EDS: `(index, sub) → name`, the sub-object's name prefixed with
/// its object's ("Identity object: Vendor-ID").
#[derive(Debug, Clone, Default)]
pub struct Eds {
    /// The file read (for the report).
    pub file: String,
    names: HashMap<(u16, u8), String>,
}

impl Eds {
    /// The object names of the EDS at `path`.
    pub fn load(path: &Path) -> Result<Eds, String> {
        let ini = ini::Ini::load_from_file_noescape(path)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        let mut names = HashMap::new();
        let mut objects = HashMap::new();
        for (section, props) in ini.iter() {
            let (Some(section), Some(name)) = (section, props.get("ParameterName")) else {
                continue;
            };
            let lower = section.to_ascii_lowercase();
            let (index, sub) = match lower.split_once("sub") {
                Some((i, s)) => (i.to_string(), Some(s.to_string())),
                None => (lower.clone(), None),
            };
            let Ok(index) = u16::from_str_radix(&index, 16) else {
                continue; // [FileInfo], [DeviceInfo], …
            };
            match sub.map(|s| u8::from_str_radix(&s, 16)) {
                None => {
                    objects.insert(index, name.to_string());
                }
                Some(Ok(sub)) => {
                    names.insert((index, sub), name.to_string());
                }
                Some(Err(_)) => {}
            }
        }
        for ((index, _), name) in names.iter_mut() {
            if let Some(object) = objects.get(index) {
                *name = format!("{object}: {name}");
            }
        }
        for (index, name) in objects {
            // A variable (no sub-objects) is sub-index 0.
            names.entry((index, 0)).or_insert(name);
        }
        Ok(Eds {
            file: super::shown(path),
            names,
        })
    }

    /// The name of `index:sub`, if the EDS has it.
    pub fn name(&self, index: u16, sub: u8) -> Option<&str> {
        self.names.get(&(index, sub)).map(String::as_str)
    }
}

/// One line of a node's SDO transcript: one transfer, however many frames it took.
#[derive(Debug, Clone, PartialEq)]
pub struct Exchange {
    /// When the transfer began (or the stray frame was seen), s from the log's start.
    pub t: f64,
    /// What was asked and answered.
    pub text: String,
    /// An abort (by either side).
    pub abort: bool,
    /// How many times in a row the same exchange was seen (presence checks, mode reads).
    pub repeated: u32,
}

/// What a transfer moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Op {
    /// An upload: the client reads the server's object.
    Read,
    /// A download: the client writes it.
    Write,
}

/// How (CiA 301 §7.2.4.3): the value in the initiate frames, in segments of 7 bytes
/// each answered, or in blocks of segments acknowledged together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Expedited,
    Segmented,
    Block,
}

impl Mode {
    fn name(self) -> &'static str {
        match self {
            Mode::Expedited => "expedited",
            Mode::Segmented => "segmented",
            Mode::Block => "block",
        }
    }
}

/// The frame a transfer waits for next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// The answer to the initiate request.
    Initiated,
    /// The client's next segment (download) or segment request (upload).
    ClientSegment,
    /// The server's answer to a segment (download) or the segment asked (upload).
    ServerSegment,
    /// Block upload: the client's start.
    Start,
    /// Block: a sub-block's segments (the client's in a download, the server's in an
    /// upload) and the acknowledgement that closes it. Every frame of the sending side
    /// is a segment here (sequence number and last-segment bit), not a command.
    SubBlock,
    /// Block: the end request and its answer.
    End,
}

/// The bytes of a value shown in a transcript (all are counted).
const SHOWN: usize = 32;

/// A transfer in progress on one channel.
#[derive(Debug, Clone)]
struct Transfer {
    t: f64,
    op: Op,
    mode: Mode,
    object: String,
    phase: Phase,
    /// The size the initiate frames indicated, bytes.
    size: Option<u32>,
    /// The first [`SHOWN`] bytes moved.
    data: Vec<u8>,
    /// Bytes moved.
    bytes: u64,
    /// The toggle bit the next segment must carry.
    toggle: u8,
    /// Segments seen.
    segments: u32,
    /// The segment marked last has been seen.
    last: bool,
    /// A protocol error seen on the bus (the first).
    note: Option<String>,
}

impl Transfer {
    fn new(t: f64, op: Op, mode: Mode, object: String) -> Self {
        Self {
            t,
            op,
            mode,
            object,
            phase: Phase::Initiated,
            size: None,
            data: Vec::new(),
            bytes: 0,
            toggle: 0,
            segments: 0,
            last: false,
            note: None,
        }
    }

    fn append(&mut self, bytes: &[u8]) {
        let room = SHOWN.saturating_sub(self.data.len());
        self.data.extend(bytes.iter().take(room));
        self.bytes += bytes.len() as u64;
    }

    /// The last block segment carried `unused` bytes of padding (told by the end frame).
    fn unpad(&mut self, unused: u8) {
        self.bytes = self.bytes.saturating_sub(u64::from(unused));
        self.data
            .truncate(usize::try_from(self.bytes).unwrap_or(usize::MAX));
    }

    /// A segment's toggle bit (segmented transfers alternate it from 0): a mismatch is
    /// noted once, naming the side and the segment.
    fn toggle(&mut self, cmd: u8, side: &str) {
        let bit = (cmd >> 4) & 1;
        if bit != self.toggle && self.note.is_none() {
            self.note = Some(format!(
                "the {side}'s toggle bit not alternated in segment {}",
                self.segments
            ));
        }
    }

    /// The transcript's line when the transfer completed.
    fn done(&self) -> String {
        let mut extra = Vec::new();
        if let Some(size) = self.size.filter(|s| u64::from(*s) != self.bytes) {
            extra.push(format!("size indicated {size}"));
        }
        extra.extend(self.note.clone());
        let extra = extra.iter().map(|e| format!("; {e}")).collect::<String>();
        let value = shown(&self.data, self.bytes);
        match (self.op, self.mode) {
            (Op::Write, Mode::Expedited) => format!("write {} = {value} → done", self.object),
            (Op::Read, Mode::Expedited) => format!("read {} → {value}", self.object),
            (Op::Write, mode) => format!(
                "write {} = {value} ({} bytes, {}{extra}) → done",
                self.object,
                self.bytes,
                mode.name()
            ),
            (Op::Read, mode) => format!(
                "read {} → {value} ({} bytes, {}{extra})",
                self.object,
                self.bytes,
                mode.name()
            ),
        }
    }

    /// The transcript's line when the transfer ended otherwise: `outcome` is the abort
    /// or the silence.
    fn failed(&self, outcome: &str) -> String {
        let verb = match self.op {
            Op::Read => "read",
            Op::Write => "write",
        };
        if self.mode == Mode::Expedited || self.phase == Phase::Initiated {
            return match (self.op, self.mode) {
                (Op::Write, Mode::Expedited) => format!(
                    "write {} = {} → {outcome}",
                    self.object,
                    shown(&self.data, self.bytes)
                ),
                (_, Mode::Expedited) => format!("{verb} {} → {outcome}", self.object),
                (_, mode) => format!("{verb} {} ({}) → {outcome}", self.object, mode.name()),
            };
        }
        let of = self.size.map_or(String::new(), |s| format!(" of {s}"));
        let note = self
            .note
            .as_ref()
            .map_or(String::new(), |n| format!("; {n}"));
        format!(
            "{verb} {} ({}, {}{of} bytes{note}) → {outcome}",
            self.object,
            self.mode.name(),
            self.bytes
        )
    }
}

/// A value as the transcript shows it: up to 4 bytes as the number they encode (CiA 301
/// little endian), printable text quoted, anything else as hex bytes.
fn shown(data: &[u8], total: u64) -> String {
    let cut = if total > data.len() as u64 {
        " …"
    } else {
        ""
    };
    if data.is_empty() {
        "(no data)".into()
    } else if total <= 4 {
        value(data)
    } else if data.iter().all(|b| (0x20..=0x7E).contains(b)) {
        format!("\"{}\"{cut}", String::from_utf8_lossy(data))
    } else {
        let hex: Vec<String> = data.iter().map(|b| format!("{b:02X}")).collect();
        format!("{}{cut}", hex.join(" "))
    }
}

/// One server's SDO channel (requests 0x600 + node, answers 0x580 + node) followed
/// frame by frame through CiA 301's expedited, segmented and block transfers, its
/// transcript kept to [`TRANSCRIPT_LINES`] lines (all are counted).
#[derive(Debug, Clone, Default)]
pub struct Channel {
    transfer: Option<Transfer>,
    /// The transcript.
    pub lines: Vec<Exchange>,
    /// Exchanges seen.
    pub exchanges: u64,
    /// Aborts seen.
    pub aborts: u64,
    /// Exchanges beyond the kept lines.
    pub dropped: u64,
}

/// The most lines of a transcript kept (a long log polls the same objects for hours).
pub const TRANSCRIPT_LINES: usize = 300;

fn object(eds: Option<&Eds>, index: u16, sub: u8) -> String {
    match eds.and_then(|e| e.name(index, sub)) {
        Some(name) => format!("0x{index:04X}:{sub} {name}"),
        None => format!("0x{index:04X}:{sub}"),
    }
}

/// The object an initiate or abort frame addresses (bytes 1–3).
fn multiplexer(data: &[u8; 8]) -> (u16, u8) {
    (u16::from_le_bytes([data[1], data[2]]), data[3])
}

/// The u32 in bytes 4–7: an indicated size or an abort code.
fn word(data: &[u8; 8]) -> u32 {
    u32::from_le_bytes([data[4], data[5], data[6], data[7]])
}

/// The data of an expedited transfer: bytes 4.. less the unused ones the command byte
/// names when it indicates the size (CiA 301 §7.2.4.3.3).
fn expedited(data: &[u8; 8]) -> &[u8] {
    let unused = if data[0] & 0x01 != 0 {
        usize::from((data[0] >> 2) & 3)
    } else {
        0
    };
    &data[4..8 - unused]
}

/// The data of a segment: bytes 1.. less the `n` unused ones of bits 1–3.
fn segment(data: &[u8; 8]) -> &[u8] {
    &data[1..8 - usize::from((data[0] >> 1) & 7)]
}

fn value(data: &[u8]) -> String {
    let mut word = [0u8; 4];
    word.iter_mut().zip(data).for_each(|(w, d)| *w = *d);
    let v = u32::from_le_bytes(word);
    format!("0x{v:0width$X} ({v})", width = data.len() * 2)
}

/// The abort frame's text.
fn abort_text(data: &[u8; 8]) -> String {
    let code = word(data);
    format!("abort 0x{code:08X} ({})", abort::describe(code))
}

/// An SDO abort: command byte 0x80 exactly (its other bits are reserved), unlike a
/// block segment's sequence number with the last-segment bit.
const ABORT: u8 = 0x80;

impl Channel {
    /// A frame from a client to this server (0x600 + node).
    pub fn request(&mut self, t: f64, data: &[u8], eds: Option<&Eds>) {
        let Some(data) = self.eight(t, data, "request") else {
            return;
        };
        let cmd = data[0];
        if let Some(x) = self.transfer.as_mut() {
            // A block download's segments come from the client.
            if x.op == Op::Write && x.phase == Phase::SubBlock && cmd != ABORT {
                x.segments += 1;
                x.last = cmd & 0x80 != 0;
                x.append(&data[1..]);
                return;
            }
        }
        let (index, sub) = multiplexer(&data);
        let name = object(eds, index, sub);
        match cmd >> 5 {
            // Initiate download.
            1 => {
                self.interrupted();
                let mode = if cmd & 0x02 != 0 {
                    Mode::Expedited
                } else {
                    Mode::Segmented
                };
                let mut x = Transfer::new(t, Op::Write, mode, name);
                if mode == Mode::Expedited {
                    x.append(expedited(&data));
                } else if cmd & 0x01 != 0 {
                    x.size = Some(word(&data));
                }
                self.transfer = Some(x);
            }
            // Initiate upload: expedited unless the server's answer says segmented.
            2 => {
                self.interrupted();
                self.transfer = Some(Transfer::new(t, Op::Read, Mode::Expedited, name));
            }
            // Download segment.
            0 => match self.transfer.as_mut() {
                Some(x)
                    if x.op == Op::Write
                        && x.mode == Mode::Segmented
                        && x.phase == Phase::ClientSegment =>
                {
                    x.segments += 1;
                    x.toggle(cmd, "client");
                    x.last = cmd & 0x01 != 0;
                    x.append(segment(&data));
                    x.phase = Phase::ServerSegment;
                }
                _ => self.stray(t, "a download segment with no segmented write under way"),
            },
            // Upload segment request.
            3 => match self.transfer.as_mut() {
                Some(x)
                    if x.op == Op::Read
                        && x.mode == Mode::Segmented
                        && x.phase == Phase::ClientSegment =>
                {
                    x.segments += 1;
                    x.toggle(cmd, "client");
                    x.phase = Phase::ServerSegment;
                }
                _ => self.stray(
                    t,
                    "an upload segment request with no segmented read under way",
                ),
            },
            // Abort by the client.
            4 => {
                let text = format!("the client aborts: {}", abort_text(&data));
                match self.transfer.take() {
                    Some(x) => self.push(x.t, x.failed(&text), true),
                    None => self.push(t, format!("{name}: {text}"), true),
                }
            }
            // Block upload: initiate (cs 0), end response (1), acknowledgement (2),
            // start (3).
            5 => match (cmd & 0x03, self.transfer.as_mut()) {
                (0, _) => {
                    self.interrupted();
                    self.transfer = Some(Transfer::new(t, Op::Read, Mode::Block, name));
                }
                (3, Some(x)) if x.mode == Mode::Block && x.phase == Phase::Start => {
                    x.phase = Phase::SubBlock;
                }
                (2, Some(x)) if x.mode == Mode::Block && x.phase == Phase::SubBlock => {
                    if x.last {
                        x.phase = Phase::End;
                    }
                }
                (1, Some(x)) if x.mode == Mode::Block && x.phase == Phase::End => {
                    if let Some(x) = self.transfer.take() {
                        self.push(x.t, x.done(), false);
                    }
                }
                _ => self.stray(
                    t,
                    &format!("a block upload command 0x{cmd:02X} out of turn"),
                ),
            },
            // Block download: initiate (cs 0), end with the unused bytes (1).
            6 => match (cmd & 0x01, self.transfer.as_mut()) {
                (0, _) => {
                    self.interrupted();
                    let mut x = Transfer::new(t, Op::Write, Mode::Block, name);
                    if cmd & 0x02 != 0 {
                        x.size = Some(word(&data));
                    }
                    self.transfer = Some(x);
                }
                (_, Some(x)) if x.mode == Mode::Block && x.phase == Phase::End => {
                    x.unpad((cmd >> 2) & 7);
                }
                _ => self.stray(
                    t,
                    &format!("a block download command 0x{cmd:02X} out of turn"),
                ),
            },
            _ => self.stray(t, &format!("unknown client command specifier 0x{cmd:02X}")),
        }
    }

    /// A frame from this server (0x580 + node).
    pub fn response(&mut self, t: f64, data: &[u8], eds: Option<&Eds>) {
        let Some(data) = self.eight(t, data, "answer") else {
            return;
        };
        let cmd = data[0];
        let block_segments = self.transfer.as_ref().is_some_and(|x| {
            x.op == Op::Read && x.mode == Mode::Block && x.phase == Phase::SubBlock
        });
        if cmd == ABORT || (cmd >> 5 == 4 && !block_segments) {
            let text = abort_text(&data);
            match self.transfer.take() {
                Some(x) => self.push(x.t, x.failed(&text), true),
                None => {
                    let (index, sub) = multiplexer(&data);
                    let name = object(eds, index, sub);
                    self.push(
                        t,
                        format!("answer without a request: {name} → {text}"),
                        true,
                    );
                }
            }
            return;
        }
        let Some(x) = self.transfer.as_mut() else {
            // The log began in the middle of a transfer, or a frame was lost.
            let (index, sub) = multiplexer(&data);
            let answer = match cmd >> 5 {
                2 if cmd & 0x02 != 0 => value(expedited(&data)),
                3 => "done".into(),
                _ => format!("server command 0x{cmd:02X}"),
            };
            self.push(
                t,
                format!(
                    "answer without a request: {} → {answer}",
                    object(eds, index, sub)
                ),
                false,
            );
            return;
        };
        match (x.op, x.mode, x.phase, cmd >> 5) {
            // A block upload's segments come from the server.
            (Op::Read, Mode::Block, Phase::SubBlock, _) => {
                x.segments += 1;
                x.last = cmd & 0x80 != 0;
                x.append(&data[1..]);
            }
            // Initiate download answered.
            (Op::Write, Mode::Expedited, Phase::Initiated, 3) => {
                let text = x.done();
                self.finish_transfer(text);
            }
            (Op::Write, Mode::Segmented, Phase::Initiated, 3) => x.phase = Phase::ClientSegment,
            // A download segment answered.
            (Op::Write, Mode::Segmented, Phase::ServerSegment, 1) => {
                x.toggle(cmd, "server");
                x.toggle ^= 1;
                if x.last {
                    let text = x.done();
                    self.finish_transfer(text);
                } else {
                    x.phase = Phase::ClientSegment;
                }
            }
            // Initiate upload answered: the value, or the segments to come.
            (Op::Read, _, Phase::Initiated, 2) => {
                if cmd & 0x02 != 0 {
                    x.append(expedited(&data));
                    let text = x.done();
                    self.finish_transfer(text);
                } else {
                    x.mode = Mode::Segmented;
                    x.size = (cmd & 0x01 != 0).then(|| word(&data));
                    x.phase = Phase::ClientSegment;
                }
            }
            // An upload segment.
            (Op::Read, Mode::Segmented, Phase::ServerSegment, 0) => {
                x.toggle(cmd, "server");
                x.toggle ^= 1;
                x.append(segment(&data));
                if cmd & 0x01 != 0 {
                    let text = x.done();
                    self.finish_transfer(text);
                } else {
                    x.phase = Phase::ClientSegment;
                }
            }
            // Block download: initiate answered (ss 0), a sub-block acknowledged (2),
            // the end answered (1).
            (Op::Write, Mode::Block, Phase::Initiated, 5) if cmd & 0x03 == 0 => {
                x.phase = Phase::SubBlock;
            }
            (Op::Write, Mode::Block, Phase::SubBlock, 5) if cmd & 0x03 == 2 => {
                if x.last {
                    x.phase = Phase::End;
                }
            }
            (Op::Write, Mode::Block, Phase::End, 5) if cmd & 0x03 == 1 => {
                let text = x.done();
                self.finish_transfer(text);
            }
            // Block upload: initiate answered (ss 0), the end with the unused bytes (1).
            (Op::Read, Mode::Block, Phase::Initiated, 6) if cmd & 0x01 == 0 => {
                x.size = (cmd & 0x02 != 0).then(|| word(&data));
                x.phase = Phase::Start;
            }
            (Op::Read, Mode::Block, Phase::End, 6) if cmd & 0x01 == 1 => {
                x.unpad((cmd >> 2) & 7);
            }
            _ => {
                let text = x.failed(&format!("server command 0x{cmd:02X} out of turn"));
                let began = x.t;
                self.transfer = None;
                self.push(began, text, false);
            }
        }
    }

    /// An SDO frame has 8 bytes (CiA 301); another length is noted as `what` of that
    /// many bytes.
    fn eight(&mut self, t: f64, data: &[u8], what: &str) -> Option<[u8; 8]> {
        let frame = <[u8; 8]>::try_from(data).ok();
        if frame.is_none() {
            self.push(
                t,
                format!("{what} of {} bytes (not an SDO)", data.len()),
                false,
            );
        }
        frame
    }

    /// The end of the log: a transfer still open is unanswered.
    pub fn finish(&mut self) {
        if let Some(x) = self.transfer.take() {
            self.push(x.t, x.failed("no answer before the log ends"), false);
        }
    }

    /// A new transfer begins: the one under way got no (further) answer.
    fn interrupted(&mut self) {
        if let Some(x) = self.transfer.take() {
            self.push(x.t, x.failed("no answer"), false);
        }
    }

    fn finish_transfer(&mut self, text: String) {
        if let Some(x) = self.transfer.take() {
            self.push(x.t, text, false);
        }
    }

    /// A frame that belongs to no transfer under way.
    fn stray(&mut self, t: f64, what: &str) {
        self.push(t, what.to_string(), false);
    }

    fn push(&mut self, t: f64, text: String, abort: bool) {
        self.exchanges += 1;
        if abort {
            self.aborts += 1;
        }
        if let Some(last) = self.lines.last_mut().filter(|l| l.text == text) {
            last.repeated += 1;
            return;
        }
        if self.lines.len() >= TRANSCRIPT_LINES {
            self.dropped += 1;
            return;
        }
        self.lines.push(Exchange {
            t,
            text,
            abort,
            repeated: 1,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::firmware::root;

    #[test]
    fn objects_named_from_the_eds() {
        let eds = Eds::load(&root().join("can/crane-controller.eds")).unwrap();
        assert_eq!(eds.name(0x1018, 1), Some("Identity object: Vendor-ID"));
        assert_eq!(eds.name(0x1000, 0), Some("Device type"));
        assert!(Eds::load(&root().join("no/such.eds")).is_err());
    }

    #[test]
    fn a_transcript_of_reads_writes_aborts_and_silence() {
        let eds = Eds::load(&root().join("interop/cia402-drive.eds")).unwrap();
        let mut c = Channel::default();
        c.request(0.0, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0], Some(&eds));
        c.response(
            0.01,
            &[0x43, 0x00, 0x10, 0, 0x92, 0x01, 0x02, 0x00],
            Some(&eds),
        );
        c.request(0.02, &[0x2F, 0x60, 0x60, 0, 9, 0, 0, 0], Some(&eds));
        c.response(0.03, &[0x60, 0x60, 0x60, 0, 0, 0, 0, 0], Some(&eds));
        c.request(0.04, &[0x2F, 0x60, 0x60, 0, 9, 0, 0, 0], Some(&eds));
        c.response(
            0.05,
            &[0x80, 0x60, 0x60, 0, 0x30, 0, 0x09, 0x06],
            Some(&eds),
        );
        c.request(0.06, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0], Some(&eds));
        c.request(0.07, &[0x40, 0x00, 0x10, 0, 0, 0, 0, 0], Some(&eds));
        c.finish();
        let texts: Vec<_> = c
            .lines
            .iter()
            .map(|l| (l.text.as_str(), l.repeated))
            .collect();
        assert_eq!(
            texts[0].0,
            "read 0x1000:0 Device type → 0x00020192 (131474)"
        );
        assert!(texts[1]
            .0
            .starts_with("write 0x6060:0 Modes of operation = 0x09 (9) → done"));
        assert!(texts[2]
            .0
            .ends_with("abort 0x06090030 (invalid value for parameter)"));
        assert_eq!(texts[3], ("read 0x1000:0 Device type → no answer", 1));
        assert_eq!(c.aborts, 1);
        assert_eq!(c.exchanges, 5);
    }

    /// Frames as (client's request?, bytes) through one channel without an EDS; the
    /// transcript's lines.
    fn transcript(frames: &[(bool, [u8; 8])]) -> Channel {
        let mut c = Channel::default();
        for (k, (request, data)) in frames.iter().enumerate() {
            let t = k as f64 * 0.001;
            if *request {
                c.request(t, data, None);
            } else {
                c.response(t, data, None);
            }
        }
        c.finish();
        c
    }

    fn texts(c: &Channel) -> Vec<&str> {
        c.lines.iter().map(|l| l.text.as_str()).collect()
    }

    /// A segment's 7 bytes from `data`, zero-padded.
    fn seg(cmd: u8, data: &[u8]) -> [u8; 8] {
        let mut f = [cmd, 0, 0, 0, 0, 0, 0, 0];
        f[1..1 + data.len()].copy_from_slice(data);
        f
    }

    #[test]
    fn a_segmented_download_is_one_line_with_its_value() {
        let c = transcript(&[
            (true, [0x21, 0x08, 0x10, 0, 7, 0, 0, 0]),
            (false, [0x60, 0x08, 0x10, 0, 0, 0, 0, 0]),
            (true, seg(0x01, b"Crane-1")),
            (false, [0x20, 0, 0, 0, 0, 0, 0, 0]),
        ]);
        assert_eq!(
            texts(&c),
            ["write 0x1008:0 = \"Crane-1\" (7 bytes, segmented) → done"]
        );
        assert_eq!((c.exchanges, c.aborts), (1, 0));
    }

    #[test]
    fn a_segmented_upload_is_one_line_with_its_value() {
        let c = transcript(&[
            (true, [0x40, 0x08, 0x10, 0, 0, 0, 0, 0]),
            (false, [0x41, 0x08, 0x10, 0, 10, 0, 0, 0]),
            (true, [0x60, 0, 0, 0, 0, 0, 0, 0]),
            (false, seg(0x00, b"0123456")),
            (true, [0x70, 0, 0, 0, 0, 0, 0, 0]),
            // Toggle 1, 4 bytes unused, the last segment.
            (false, seg(0x10 | (4 << 1) | 1, b"789")),
        ]);
        assert_eq!(
            texts(&c),
            ["read 0x1008:0 → \"0123456789\" (10 bytes, segmented)"]
        );
        assert_eq!(c.exchanges, 1);
    }

    #[test]
    fn a_toggle_bit_not_alternated_and_the_abort_that_follows() {
        let c = transcript(&[
            (true, [0x40, 0x08, 0x10, 0, 0, 0, 0, 0]),
            (false, [0x41, 0x08, 0x10, 0, 10, 0, 0, 0]),
            (true, [0x60, 0, 0, 0, 0, 0, 0, 0]),
            (false, seg(0x00, b"0123456")),
            (true, [0x60, 0, 0, 0, 0, 0, 0, 0]), // toggle 0 again
            (false, [0x80, 0x08, 0x10, 0, 0x00, 0x00, 0x03, 0x05]),
        ]);
        let lines = texts(&c);
        assert_eq!(lines.len(), 1, "{lines:?}");
        assert!(
            lines[0].starts_with("read 0x1008:0 (segmented, 7 of 10 bytes; the client's toggle bit not alternated in segment 2) → abort 0x05030000"),
            "{lines:?}"
        );
        assert_eq!((c.exchanges, c.aborts), (1, 1));
    }

    #[test]
    fn a_block_download_is_one_line_its_segments_no_commands() {
        let data: Vec<u8> = (0..20).collect();
        let c = transcript(&[
            (true, [0xC2, 0x00, 0x20, 1, 20, 0, 0, 0]),
            (false, [0xA0, 0x00, 0x20, 1, 127, 0, 0, 0]),
            (true, seg(0x01, &data[0..7])),
            (true, seg(0x02, &data[7..14])),
            (true, seg(0x83, &data[14..20])),
            (false, [0xA2, 3, 127, 0, 0, 0, 0, 0]),
            // End: 1 byte of the last segment unused.
            (true, [0xC5, 0x12, 0x34, 0, 0, 0, 0, 0]),
            (false, [0xA1, 0, 0, 0, 0, 0, 0, 0]),
        ]);
        assert_eq!(
            texts(&c),
            ["write 0x2000:1 = 00 01 02 03 04 05 06 07 08 09 0A 0B 0C 0D 0E 0F 10 11 12 13 (20 bytes, block) → done"]
        );
        assert_eq!((c.exchanges, c.aborts), (1, 0));
    }

    #[test]
    fn a_block_upload_is_one_line_with_its_value() {
        let c = transcript(&[
            (true, [0xA0, 0x08, 0x10, 0, 127, 0, 0, 0]),
            (false, [0xC2, 0x08, 0x10, 0, 10, 0, 0, 0]),
            (true, [0xA3, 0, 0, 0, 0, 0, 0, 0]),
            (false, seg(0x01, b"ABCDEFG")),
            (false, seg(0x82, b"HIJ")),
            (true, [0xA2, 2, 127, 0, 0, 0, 0, 0]),
            // End: 4 bytes of the last segment unused.
            (false, [0xC0 | (4 << 2) | 1, 0x12, 0x34, 0, 0, 0, 0, 0]),
            (true, [0xA1, 0, 0, 0, 0, 0, 0, 0]),
        ]);
        assert_eq!(
            texts(&c),
            ["read 0x1008:0 → \"ABCDEFGHIJ\" (10 bytes, block)"]
        );
        assert_eq!(c.exchanges, 1);
    }
}
