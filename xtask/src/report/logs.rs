//! The log readers: candump `-L` lines and Vector ASC, the two formats python-can's
//! loggers write (`CanutilsLogWriter`, `ASCWriter`) and SocketCAN and Vector tools record.
//!
//! Streaming: one line at a time through a bounded buffer, so a 1 GB log costs no more
//! memory than a short one; a line longer than [`MAX_LINE`] (no CAN frame is) is read
//! past and counted unreadable instead of growing the buffer. A line that is not a frame
//! is counted with its number and text (the first few), never fatal: only a file that
//! cannot be opened or whose format is neither is an error.

use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use serde::Serialize;

/// The longest line read as a frame: a classic CAN frame in ASC with a comment is far
/// shorter; anything longer is not a frame.
pub const MAX_LINE: usize = 512;

/// How many unreadable lines are quoted in the report (all are counted).
const QUOTED: usize = 8;

/// One classic CAN frame from the log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Time stamp as the log has it, ns (candump: since the epoch; ASC: since the
    /// start), read exactly from its decimals ([`stamp_ns`]).
    pub t: i64,
    /// Identifier (11 or 29 bits).
    pub id: u32,
    /// A 29-bit identifier.
    pub extended: bool,
    /// A remote request (no data).
    pub remote: bool,
    /// Data length, 0..=8.
    pub len: u8,
    /// Data, `len` bytes used.
    pub data: [u8; 8],
}

impl Frame {
    /// The data bytes.
    pub fn bytes(&self) -> &[u8] {
        &self.data[..usize::from(self.len).min(8)]
    }
}

/// The two formats read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// `(1700000000.000000) can0 123#0102 [R|T]` — `candump -L`, python-can's `.log`.
    Candump,
    /// Vector ASC — python-can's `.asc`, CANoe/CANalyzer, PCAN-View's export.
    Asc,
}

impl Format {
    /// Its name in the report.
    pub fn name(self) -> &'static str {
        match self {
            Format::Candump => "candump -L",
            Format::Asc => "Vector ASC",
        }
    }
}

/// What reading the log found besides frames.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct ReadStats {
    /// Lines read.
    pub lines: u64,
    /// Classic CAN frames read.
    pub frames: u64,
    /// Lines that should have been frames but are not (truncated, bad hex, too long).
    pub unreadable: u64,
    /// The first of them: (line number, text).
    pub quoted: Vec<(u64, String)>,
    /// Error frames (not CAN traffic: counted, not analysed).
    pub error_frames: u64,
    /// CAN FD frames (not CANopen classic: counted, not analysed).
    pub fd_frames: u64,
    /// Lines that are neither frames nor errors (an ASC header, events; comments):
    /// skipped.
    pub other_lines: u64,
    /// Frames whose time stamp runs backwards (kept, counted).
    pub backwards: u64,
    /// Bytes read.
    pub bytes: u64,
}

/// How much of a log's beginning tells its format, bytes.
const HEAD: usize = 64 * 1024;

/// The format of the log at `path`, from its first lines; an error names what was
/// expected. An unreadable file is an error too.
pub fn detect(path: &Path) -> Result<Format, String> {
    let file = File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut head = Vec::new();
    file.take(HEAD as u64)
        .read_to_end(&mut head)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let text = String::from_utf8_lossy(&head);
    // All of it read, and nothing but blanks.
    if head.len() < HEAD && text.trim().is_empty() {
        return Err(format!(
            "{}: the log is empty: no line to read a frame from",
            path.display()
        ));
    }
    for line in text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .take(200)
    {
        if candump_line(line).is_some() {
            return Ok(Format::Candump);
        }
        let lower = line.to_ascii_lowercase();
        if lower.starts_with("date ")
            || lower.starts_with("base hex")
            || lower.starts_with("base dec")
            || lower.starts_with("begin triggerblock")
            || matches!(asc_line(line, false), AscLine::Frame(_))
        {
            return Ok(Format::Asc);
        }
    }
    Err(format!(
        "{}: unknown format: neither candump -L lines (`(1700000000.000000) can0 123#0102`) \
         nor Vector ASC (`date …`, `base hex …`, `   0.010000 1  123  Rx   d 2 01 02`) \
         in its first lines",
        path.display()
    ))
}

/// A log opened for streaming.
pub struct LogReader<R> {
    input: R,
    format: Format,
    /// ASC: ids in decimal (`base dec`).
    decimal: bool,
    /// ASC: each time stamp relative to the one before (`timestamps relative`).
    relative: bool,
    clock: i64,
    last_t: Option<i64>,
    line: Vec<u8>,
    /// What was read so far.
    pub stats: ReadStats,
}

/// Opens `path` in `format`, and its size in bytes.
pub fn open(path: &Path, format: Format) -> Result<(LogReader<BufReader<File>>, u64), String> {
    let mut file = File::open(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let size = file
        .seek(SeekFrom::End(0))
        .and_then(|n| file.seek(SeekFrom::Start(0)).map(|_| n))
        .map_err(|e| format!("{}: {e}", path.display()))?;
    Ok((
        LogReader::new(BufReader::with_capacity(1 << 16, file), format),
        size,
    ))
}

impl<R: BufRead> LogReader<R> {
    /// A reader of `input` in `format`.
    pub fn new(input: R, format: Format) -> Self {
        Self {
            input,
            format,
            decimal: false,
            relative: false,
            clock: 0,
            last_t: None,
            line: Vec::with_capacity(MAX_LINE),
            stats: ReadStats::default(),
        }
    }

    /// The next frame, or `None` at the end; a read error (not a bad line) is an error.
    pub fn next_frame(&mut self) -> Result<Option<Frame>, String> {
        loop {
            let Some(too_long) = read_line(&mut self.input, &mut self.line, &mut self.stats.bytes)
                .map_err(|e| format!("reading the log: {e}"))?
            else {
                return Ok(None);
            };
            self.stats.lines += 1;
            let buf = std::mem::take(&mut self.line);
            let frame = self.classify(&buf, too_long);
            self.line = buf;
            if let Some(frame) = frame {
                if self.last_t.is_some_and(|t| frame.t < t) {
                    self.stats.backwards += 1;
                }
                self.last_t = Some(frame.t);
                self.stats.frames += 1;
                return Ok(Some(frame));
            }
        }
    }

    /// One line: the frame it is, or `None` (counted as what it is).
    fn classify(&mut self, bytes: &[u8], too_long: bool) -> Option<Frame> {
        let Ok(text) = std::str::from_utf8(bytes) else {
            self.unreadable(&String::from_utf8_lossy(bytes));
            return None;
        };
        let line = text.trim();
        if line.is_empty() {
            return None;
        }
        if too_long {
            self.unreadable(line);
            return None;
        }
        match self.format {
            // A note written into the log by hand or by a script: no frame, not garbled.
            Format::Candump if line.starts_with('#') || line.starts_with("//") => {
                self.stats.other_lines += 1;
                None
            }
            Format::Candump => match candump_line(line) {
                Some(Candump::Frame(f)) => Some(f),
                Some(Candump::Error) => {
                    self.stats.error_frames += 1;
                    None
                }
                Some(Candump::Fd) => {
                    self.stats.fd_frames += 1;
                    None
                }
                None => {
                    self.unreadable(line);
                    None
                }
            },
            Format::Asc => self.asc(line),
        }
    }

    fn asc(&mut self, line: &str) -> Option<Frame> {
        let lower = line.to_ascii_lowercase();
        if lower.starts_with("base ") {
            self.decimal = lower.contains("base dec");
            self.relative = lower.contains("timestamps relative");
            self.stats.other_lines += 1;
            return None;
        }
        // `timestamps relative`: each line's stamp is the time since the line before,
        // whatever that line is — an error frame, a CAN FD frame or an event moves the
        // clock as a frame does.
        if self.relative {
            if let Some(dt) = asc_stamp(line) {
                self.clock = self.clock.saturating_add(dt);
            }
        }
        match asc_line(line, self.decimal) {
            AscLine::Frame(mut f) => {
                if self.relative {
                    f.t = self.clock;
                }
                Some(f)
            }
            AscLine::Error => {
                self.stats.error_frames += 1;
                None
            }
            AscLine::Fd => {
                self.stats.fd_frames += 1;
                None
            }
            AscLine::Other => {
                self.stats.other_lines += 1;
                None
            }
            AscLine::Bad => {
                self.unreadable(line);
                None
            }
        }
    }

    fn unreadable(&mut self, line: &str) {
        self.stats.unreadable += 1;
        if self.stats.quoted.len() < QUOTED {
            let shown: String = line.chars().take(100).collect();
            self.stats.quoted.push((self.stats.lines, shown));
        }
    }
}

/// Reads one line into `buf` (without its end), keeping at most [`MAX_LINE`] bytes of
/// it: `Some(true)` when the line was longer (the rest is skipped), `None` at the end.
fn read_line<R: BufRead>(
    input: &mut R,
    buf: &mut Vec<u8>,
    bytes: &mut u64,
) -> io::Result<Option<bool>> {
    buf.clear();
    let mut too_long = false;
    let mut any = false;
    loop {
        let available = input.fill_buf()?;
        if available.is_empty() {
            return Ok(any.then_some(too_long));
        }
        any = true;
        let (chunk, used, end) = match available.iter().position(|&b| b == b'\n') {
            Some(i) => (&available[..i], i + 1, true),
            None => (available, available.len(), false),
        };
        let room = MAX_LINE.saturating_sub(buf.len());
        if chunk.len() > room {
            too_long = true;
        }
        buf.extend_from_slice(&chunk[..chunk.len().min(room)]);
        input.consume(used);
        *bytes += used as u64;
        if end {
            return Ok(Some(too_long));
        }
    }
}

/// A candump `-L` line, parsed.
enum Candump {
    Frame(Frame),
    Error,
    Fd,
}

/// `(time) interface id#data [R|T]`; `None` if the line is not one.
fn candump_line(line: &str) -> Option<Candump> {
    let mut words = line.split_ascii_whitespace();
    let stamp = words.next()?.strip_prefix('(')?.strip_suffix(')')?;
    let t = stamp_ns(stamp)?;
    let _interface = words.next()?;
    let frame = words.next()?;
    // python-can writes the direction (R received, T transmitted) after the frame.
    match words.next() {
        None | Some("R" | "T") => {}
        Some(_) => return None,
    }
    if words.next().is_some() {
        return None;
    }
    let (id_text, data) = frame.split_once('#')?;
    if id_text.is_empty() || id_text.len() > 8 || !id_text.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let id = u32::from_str_radix(id_text, 16).ok()?;
    let extended = id_text.len() == 8;
    if !extended && (id_text.len() > 3 || id > 0x7FF) {
        return None;
    }
    if extended && id & 0x2000_0000 != 0 {
        return Some(Candump::Error); // CAN_ERR_FLAG
    }
    if data.starts_with('#') {
        return Some(Candump::Fd);
    }
    let mut frame = Frame {
        t,
        id: id & 0x1FFF_FFFF,
        extended,
        remote: false,
        len: 0,
        data: [0; 8],
    };
    if let Some(rest) = data.strip_prefix('R') {
        frame.remote = true;
        frame.len = match rest {
            "" => 0,
            d => d.parse().ok().filter(|n| *n <= 8)?,
        };
        return Some(Candump::Frame(frame));
    }
    frame.len = hex_bytes(data, &mut frame.data)?;
    Some(Candump::Frame(frame))
}

/// `data` as hex pairs into `out`: the count, or `None` if odd, not hex or over 8 bytes.
fn hex_bytes(data: &str, out: &mut [u8; 8]) -> Option<u8> {
    let digits = data.as_bytes();
    if !digits.len().is_multiple_of(2) || digits.len() > 16 {
        return None;
    }
    for (slot, pair) in out.iter_mut().zip(digits.chunks(2)) {
        *slot = u8::from_str_radix(std::str::from_utf8(pair).ok()?, 16).ok()?;
    }
    u8::try_from(digits.len() / 2).ok()
}

/// An ASC line, classified.
enum AscLine {
    Frame(Frame),
    Error,
    Fd,
    /// A header, a comment or an event that is no frame.
    Other,
    /// It starts like a frame (time, channel, id, direction) but is not a whole one.
    Bad,
}

/// The time stamp an ASC line begins with, if it begins with one.
fn asc_stamp(line: &str) -> Option<i64> {
    stamp_ns(line.split_ascii_whitespace().next()?)
}

/// A time stamp in decimal seconds (`1795857436.319260`, `0.010000`) as integer
/// nanoseconds, exactly. Both formats write decimals — candump since the epoch, ASC
/// since the first frame — and the difference of two f64 seconds since the epoch is off
/// by up to a quarter of a microsecond: enough for one format to see an interval of
/// exactly 1.5 cycles as a missed cycle and the other not. Digits beyond the
/// nanosecond are dropped; anything but `digits[.digits]` is no stamp.
pub fn stamp_ns(text: &str) -> Option<i64> {
    let (whole, fraction) = text.split_once('.').unwrap_or((text, ""));
    let digits = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    if whole.is_empty() || !digits(whole) || !digits(fraction) {
        return None;
    }
    let fraction = &fraction[..fraction.len().min(9)];
    let scale = 10i64.pow(9 - u32::try_from(fraction.len()).ok()?);
    let ns = if fraction.is_empty() {
        0
    } else {
        fraction.parse::<i64>().ok()? * scale
    };
    whole
        .parse::<i64>()
        .ok()?
        .checked_mul(1_000_000_000)?
        .checked_add(ns)
}

/// A DLC or data byte of an ASC frame: hex digits, or in a `base dec` log up to
/// three decimal ones (Vector's tools and python-can's reader write ids, DLC and data in
/// the header's base).
fn number(word: &str, decimal: bool) -> Option<u8> {
    if decimal {
        (word.len() <= 3).then(|| word.parse().ok()).flatten()
    } else {
        (word.len() <= 2)
            .then(|| u8::from_str_radix(word, 16).ok())
            .flatten()
    }
}

/// `time channel id Rx|Tx d dlc bytes… [extra columns]`, ids, DLC and data in hex (`x`
/// after an extended id) unless `decimal`.
fn asc_line(line: &str, decimal: bool) -> AscLine {
    let mut words = line.split_ascii_whitespace();
    let Some(first) = words.next().filter(|w| w.parse::<f64>().is_ok()) else {
        return AscLine::Other; // a header, "Begin Triggerblock", a comment
    };
    let Some(t) = stamp_ns(first) else {
        return AscLine::Bad; // a number, but no time stamp (`inf`, `-1`, `1e3`)
    };
    let Some(channel) = words.next() else {
        return AscLine::Bad;
    };
    if channel.eq_ignore_ascii_case("CANFD") {
        return AscLine::Fd;
    }
    if !channel.bytes().all(|b| b.is_ascii_digit()) {
        return AscLine::Other; // "Start of measurement", statistics, triggers
    }
    let Some(id_text) = words.next() else {
        return AscLine::Bad;
    };
    if id_text.eq_ignore_ascii_case("ErrorFrame") {
        return AscLine::Error;
    }
    let (digits, extended) = match id_text.strip_suffix(['x', 'X']) {
        Some(d) => (d, true),
        None => (id_text, false),
    };
    let id = if decimal {
        digits.parse::<u32>().ok()
    } else {
        u32::from_str_radix(digits, 16).ok()
    };
    let Some(id) = id.filter(|&id| {
        if extended {
            id <= 0x1FFF_FFFF
        } else {
            id <= 0x7FF
        }
    }) else {
        // Statistics lines ("1 Statistic: …") and the like are not frames.
        return if id_text.bytes().all(|b| b.is_ascii_hexdigit()) {
            AscLine::Bad
        } else {
            AscLine::Other
        };
    };
    match words.next() {
        Some("Rx" | "Tx") => {}
        // A transmit request: the frame itself follows as `Tx` once it is on the bus.
        Some("TxRq") => return AscLine::Other,
        _ => return AscLine::Bad,
    }
    let mut frame = Frame {
        t,
        id,
        extended,
        remote: false,
        len: 0,
        data: [0; 8],
    };
    let kind = words.next();
    let dlc = words.next().map(|d| number(d, decimal));
    match (kind, dlc) {
        // A remote frame's DLC is optional: older Vector tools write `r` alone.
        (Some("r"), None) => {
            frame.remote = true;
            AscLine::Frame(frame)
        }
        (Some("r"), Some(Some(dlc))) => {
            frame.remote = true;
            frame.len = dlc.min(8);
            AscLine::Frame(frame)
        }
        (Some("d"), Some(Some(dlc))) if dlc <= 8 => {
            for slot in frame.data.iter_mut().take(usize::from(dlc)) {
                match words.next().and_then(|b| number(b, decimal)) {
                    Some(byte) => *slot = byte,
                    None => return AscLine::Bad,
                }
            }
            frame.len = dlc;
            AscLine::Frame(frame)
        }
        _ => AscLine::Bad,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    fn read(text: &str, format: Format) -> (Vec<Frame>, ReadStats) {
        let mut reader = LogReader::new(Cursor::new(text.as_bytes().to_vec()), format);
        let mut frames = Vec::new();
        while let Some(f) = reader.next_frame().unwrap() {
            frames.push(f);
        }
        (frames, reader.stats)
    }

    #[test]
    fn candump_lines_as_python_can_and_candump_write_them() {
        let (frames, stats) = read(
            "(1700000000.000100) vcan0 080# R\n\
             (1700000000.000200) can0 210#0101C8323C1E9001 T\n\
             (1700000000.000300) ecu 18FF0010#01\n\
             (1700000000.000400) can0 701#R\n\
             (1700000000.000500) can0 20000080#0000000000000000\n\
             (1700000000.000600) can0 123##1DEADBEEF\n",
            Format::Candump,
        );
        assert_eq!(frames.len(), 4, "{frames:?}");
        assert_eq!(
            (frames[0].id, frames[0].len, frames[0].remote),
            (0x080, 0, false)
        );
        assert_eq!(
            frames[1].bytes(),
            &[1, 1, 0xC8, 0x32, 0x3C, 0x1E, 0x90, 0x01]
        );
        assert!(frames[2].extended && frames[2].id == 0x18FF_0010);
        assert!(frames[3].remote);
        assert_eq!(
            (stats.error_frames, stats.fd_frames, stats.unreadable),
            (1, 1, 0)
        );
        assert_eq!(frames[1].t, 1_700_000_000_000_200_000);
    }

    #[test]
    fn asc_as_python_can_writes_it() {
        let text = "date Sat Nov 28 10:06:27.555 am 2026\n\
                    base hex  timestamps absolute\n\
                    internal events logged\n\
                    // version 9.0.0\n\
                    Begin Triggerblock Sat Nov 28 10:06:27.555 am 2026\n\
                    \x20  0.000000 Start of measurement\n\
                    \x20  0.001000 1  80              Rx   d 0 \n\
                    \x20  0.002000 1  191             Rx   d 6 01 02 03 04 05 06\n\
                    \x20  0.003000 1  18FF0010x       Tx   d 1 AA\n\
                    \x20  0.004000 1  ErrorFrame\n\
                    \x20  0.005000 1  701             Rx   r 1\n\
                    End TriggerBlock\n";
        let (frames, stats) = read(text, Format::Asc);
        assert_eq!(frames.len(), 4);
        assert_eq!(frames[1].bytes(), &[1, 2, 3, 4, 5, 6]);
        assert!(frames[2].extended && frames[2].id == 0x18FF_0010);
        assert!(frames[3].remote);
        assert_eq!((stats.error_frames, stats.unreadable), (1, 0));
    }

    #[test]
    fn asc_with_decimal_ids_and_relative_stamps() {
        let text = "base dec  timestamps relative\n\
                    0.010 1 128 Rx d 0\n\
                    0.010 1 401 Rx d 1 05\n";
        let (frames, _) = read(text, Format::Asc);
        assert_eq!(frames[0].id, 0x080);
        assert_eq!(frames[1].id, 0x191);
        assert_eq!(frames[1].t, 20_000_000);
    }

    #[test]
    fn relative_asc_stamps_count_from_every_event_not_only_frames() {
        // `timestamps relative`: each stamp is the time since the line before, whatever
        // that line was (an error frame, a CAN FD frame, a remote request).
        let text = "base hex  timestamps relative\n\
                    \x20  0.010000 1  80   Rx   d 0\n\
                    \x20  0.005000 1  ErrorFrame\n\
                    \x20  0.005000 1  80   Rx   d 0\n\
                    \x20  0.004000 CANFD   1 Rx  123  1 0 d 8 01 02 03 04 05 06 07 08\n\
                    \x20  0.006000 1  80   Rx   d 0\n";
        let (frames, stats) = read(text, Format::Asc);
        let t: Vec<i64> = frames.iter().map(|f| f.t).collect();
        assert_eq!(t, [10_000_000, 20_000_000, 30_000_000], "{frames:?}");
        assert_eq!((stats.error_frames, stats.fd_frames), (1, 1));
    }

    #[test]
    fn asc_in_base_dec_has_decimal_data_bytes_too() {
        // Vector (and python-can's reader) write ids, DLC and data in the base the header
        // names.
        let text = "base dec  timestamps absolute\n\
                    \x20  0.010000 1  400  Rx   d 3 10 128 255\n";
        let (frames, stats) = read(text, Format::Asc);
        assert_eq!(stats.unreadable, 0, "{stats:?}");
        assert_eq!(
            (frames[0].id, frames[0].bytes()),
            (0x190, &[10, 128, 255][..])
        );
    }

    #[test]
    fn asc_remote_frames_without_a_dlc_and_transmit_requests() {
        // `r` alone is a remote frame as older Vector tools write it; a `TxRq` line is
        // the request to send, not a frame on the bus (its frame follows as `Tx`).
        let text = "base hex  timestamps absolute\n\
                    \x20  0.010000 1  701  Rx   r\n\
                    \x20  0.020000 1  701  Rx   r 1\n\
                    \x20  0.030000 1  210  TxRq d 2 01 02\n\
                    \x20  0.030100 1  210  Tx   d 2 01 02\n";
        let (frames, stats) = read(text, Format::Asc);
        assert_eq!(stats.unreadable, 0, "{stats:?}");
        assert_eq!(frames.len(), 3, "{frames:?}");
        assert!(frames[0].remote && frames[1].remote && !frames[2].remote);
        assert_eq!(stats.other_lines, 2, "the header and the transmit request");
    }

    #[test]
    fn comment_lines_in_a_candump_log_are_no_unreadable_frames() {
        let (frames, stats) = read(
            "# recorded on the crane, can0\n(1.0) can0 080#\r\n// end\n",
            Format::Candump,
        );
        assert_eq!(frames.len(), 1);
        assert_eq!((stats.unreadable, stats.other_lines), (0, 2), "{stats:?}");
    }

    #[test]
    fn truncated_and_garbled_lines_are_counted_and_quoted_never_fatal() {
        let long = format!("(1.0) can0 123#{}\n", "0".repeat(4 * MAX_LINE));
        let text = format!(
            "(1.000000) can0 080#\n(1.01) can0 21\n(1.02) can0 181#0102030\n{long}\
             (1.03) can0 181#01020304050607080910\n(x) can0 080#\n(1.04) can0 080#\n"
        );
        let (frames, stats) = read(&text, Format::Candump);
        assert_eq!(frames.len(), 2);
        assert_eq!(stats.unreadable, 5);
        assert_eq!(stats.quoted[0], (2, "(1.01) can0 21".to_string()));
        let (frames, stats) = read(
            "   1.0 1 181 Rx d 8 01 02\n   1.1 1 181 Rx d 2 01 02\n",
            Format::Asc,
        );
        assert_eq!((frames.len(), stats.unreadable), (1, 1));
    }

    #[test]
    fn a_line_without_an_end_is_read() {
        let (frames, _) = read("(2.5) can0 080#", Format::Candump);
        assert_eq!(frames.len(), 1);
    }

    #[test]
    fn the_format_is_told_from_the_first_lines_and_an_unknown_one_refused() {
        let dir = std::env::temp_dir().join(format!("report-detect-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let write = |name: &str, text: &str| {
            let p = dir.join(name);
            std::fs::write(&p, text).unwrap();
            p
        };
        assert_eq!(
            detect(&write("a.log", "(1.0) can0 080#\n")).unwrap(),
            Format::Candump
        );
        assert_eq!(
            detect(&write("b.asc", "date Sat\nbase hex\n")).unwrap(),
            Format::Asc
        );
        let e = detect(&write("c.txt", "hello\nworld\n")).unwrap_err();
        assert!(e.contains("unknown format"), "{e}");
        let e = detect(&write("empty.log", "")).unwrap_err();
        assert!(e.contains("empty.log") && e.contains("empty"), "{e}");
        let e = detect(&write("blank.log", "\n \r\n")).unwrap_err();
        assert!(e.contains("empty"), "{e}");
        let e = detect(&dir.join("missing.log")).unwrap_err();
        assert!(e.contains("missing.log"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
