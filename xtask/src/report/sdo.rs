//! SDO transfers as a transcript a commissioning engineer reads: "read 0x1000:0 Device
//! type → 0x00020192", "write 0x6060:0 Modes of operation = 9 → done", "abort
//! 0x06090030 (value range of parameter exceeded)" — objects named from each node's EDS
//! (rust-ini reads it), abort codes by CiA 301's table (§7.2.4.3.17).

use std::collections::HashMap;
use std::path::Path;

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

/// CiA 301's SDO abort codes.
pub fn abort_meaning(code: u32) -> &'static str {
    match code {
        0x0503_0000 => "toggle bit not alternated",
        0x0504_0000 => "SDO protocol timed out",
        0x0504_0001 => "client/server command specifier not valid or unknown",
        0x0504_0002 => "invalid block size",
        0x0504_0003 => "invalid sequence number",
        0x0504_0004 => "CRC error",
        0x0504_0005 => "out of memory",
        0x0601_0000 => "unsupported access to an object",
        0x0601_0001 => "attempt to read a write only object",
        0x0601_0002 => "attempt to write a read only object",
        0x0602_0000 => "object does not exist in the object dictionary",
        0x0604_0041 => "object cannot be mapped to the PDO",
        0x0604_0042 => "the number and length of the objects to be mapped would exceed PDO length",
        0x0604_0043 => "general parameter incompatibility",
        0x0604_0047 => "general internal incompatibility in the device",
        0x0606_0000 => "access failed due to a hardware error",
        0x0607_0010 => "data type does not match, length of service parameter does not match",
        0x0607_0012 => "data type does not match, length of service parameter too high",
        0x0607_0013 => "data type does not match, length of service parameter too low",
        0x0609_0011 => "sub-index does not exist",
        0x0609_0030 => "invalid value for parameter (download only)",
        0x0609_0031 => "value of parameter written too high (download only)",
        0x0609_0032 => "value of parameter written too low (download only)",
        0x0609_0036 => "maximum value is less than minimum value",
        0x060A_0023 => "resource not available: SDO connection",
        0x0800_0000 => "general error",
        0x0800_0020 => "data cannot be transferred or stored to the application",
        0x0800_0021 => "data cannot be transferred or stored because of local control",
        0x0800_0022 => "data cannot be transferred or stored because of the present device state",
        0x0800_0023 => {
            "object dictionary dynamic generation fails or no object dictionary is present"
        }
        0x0800_0024 => "no data available",
        _ => "not a CiA 301 abort code",
    }
}

/// One line of a node's SDO transcript.
#[derive(Debug, Clone, PartialEq)]
pub struct Exchange {
    /// When the request (or the unsolicited answer) was seen, s from the log's start.
    pub t: f64,
    /// What was asked and answered.
    pub text: String,
    /// An abort (by either side).
    pub abort: bool,
    /// How many times in a row the same exchange was seen (presence checks, mode reads).
    pub repeated: u32,
}

/// The pending request of one SDO channel.
#[derive(Debug, Clone)]
struct Pending {
    t: f64,
    text: String,
}

/// One server's SDO channel (requests 0x600 + node, answers 0x580 + node), its
/// transcript kept to `cap` lines (all are counted).
#[derive(Debug, Clone, Default)]
pub struct Channel {
    pending: Option<Pending>,
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

/// The data of an expedited transfer (8-byte frame): bytes 4.. less the unused ones the
/// command byte names when it indicates the size (CiA 301 §7.2.4.3.3).
fn expedited(data: &[u8]) -> &[u8] {
    let unused = if data[0] & 0x01 != 0 {
        usize::from((data[0] >> 2) & 3)
    } else {
        0
    };
    data.get(4..8 - unused).unwrap_or_default()
}

fn value(data: &[u8]) -> String {
    let mut word = [0u8; 4];
    word.iter_mut().zip(data).for_each(|(w, d)| *w = *d);
    let v = u32::from_le_bytes(word);
    format!("0x{v:0width$X} ({v})", width = data.len() * 2)
}

impl Channel {
    /// A request from a client to this server.
    pub fn request(&mut self, t: f64, data: &[u8], eds: Option<&Eds>) {
        let Some((index, sub)) = self.addressed(t, data, "request") else {
            return;
        };
        let name = object(eds, index, sub);
        let ccs = data[0] >> 5;
        let text = match ccs {
            2 => format!("read {name}"),
            1 => {
                if data[0] & 0x02 != 0 {
                    format!("write {name} = {}", value(expedited(data)))
                } else {
                    format!("write {name} (segmented)")
                }
            }
            4 => {
                let code = u32::from_le_bytes([data[4], data[5], data[6], data[7]]);
                self.flush_pending(t, "no answer");
                self.push(
                    t,
                    format!(
                        "the client aborts {name}: 0x{code:08X} ({})",
                        abort_meaning(code)
                    ),
                    true,
                );
                return;
            }
            0 | 3 => "segment".to_string(),
            5 | 6 => format!("block transfer {name}"),
            _ => format!("unknown command specifier 0x{:02X}", data[0]),
        };
        self.flush_pending(t, "no answer");
        self.pending = Some(Pending { t, text });
    }

    /// An answer from this server.
    pub fn response(&mut self, t: f64, data: &[u8], eds: Option<&Eds>) {
        let Some((index, sub)) = self.addressed(t, data, "answer") else {
            return;
        };
        let scs = data[0] >> 5;
        let (answer, abort) = match scs {
            2 if data[0] & 0x02 != 0 => (value(expedited(data)), false),
            2 => ("segmented answer".to_string(), false),
            3 => ("done".to_string(), false),
            4 => {
                let code = u32::from_le_bytes([data[4], data[5], data[6], data[7]]);
                (
                    format!("abort 0x{code:08X} ({})", abort_meaning(code)),
                    true,
                )
            }
            0 | 1 => ("segment".to_string(), false),
            _ => (format!("server command specifier 0x{:02X}", data[0]), false),
        };
        match self.pending.take() {
            Some(p) => self.push(p.t, format!("{} → {answer}", p.text), abort),
            None => self.push(
                t,
                format!(
                    "answer without a request: {} → {answer}",
                    object(eds, index, sub)
                ),
                abort,
            ),
        }
    }

    /// The object an 8-byte SDO frame addresses; a frame of another length is noted in
    /// the transcript as `what` of that many bytes.
    fn addressed(&mut self, t: f64, data: &[u8], what: &str) -> Option<(u16, u8)> {
        if data.len() != 8 {
            let text = format!("{what} of {} bytes (not an SDO)", data.len());
            self.push(t, text, false);
            return None;
        }
        Some((u16::from_le_bytes([data[1], data[2]]), data[3]))
    }

    /// The end of the log: a request still open is unanswered.
    pub fn finish(&mut self) {
        if let Some(p) = self.pending.take() {
            self.push(
                p.t,
                format!("{} → no answer before the log ends", p.text),
                false,
            );
        }
    }

    fn flush_pending(&mut self, _t: f64, what: &str) {
        if let Some(p) = self.pending.take() {
            self.push(p.t, format!("{} → {what}", p.text), false);
        }
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
            .ends_with("abort 0x06090030 (invalid value for parameter (download only))"));
        assert_eq!(texts[3], ("read 0x1000:0 Device type → no answer", 1));
        assert_eq!(c.aborts, 1);
        assert_eq!(c.exchanges, 5);
    }
}
