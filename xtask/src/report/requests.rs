//! The supervisor's requests and the controller's answers, in order: the command frame
//! (0x200 + controller, `Command_Controller`), the 3D move frame (0x300 + controller,
//! `Move3d_Controller`), requests written into 0x2000 over SDO; each answer from the
//! status frame (0x180 + controller, `Status_Controller`) with the reason of a refusal by
//! the DBC's value table; the controller's mode and fault as the status shows them; its
//! counters (ignored frames, deadline misses, transmit failures); manual-mode frames
//! (0x400 + controller) counted.
//!
//! A status frame is sent after every answer and every 100 ms: the first status frame
//! after a request that carries its id (and an answer) is its answer; the periodic ones
//! repeat the last answer and are not counted again.

use std::collections::BTreeMap;

use serde::Serialize;

use super::bus::Cob;
use super::series::Capped;
use super::Seen;

/// What was asked.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum Kind {
    /// A move of the load to `target` (x, z; the 3D move x, y, z), m, in `duration` s
    /// (`None`: as fast as the limits allow).
    Move {
        /// Target, m.
        target: Vec<f64>,
        /// Duration, s.
        duration: Option<f64>,
    },
    /// A stop.
    Stop,
    /// A reset.
    Reset,
    /// Written into 0x2000 over SDO: the command code of 0x2000:2.
    BySdo(u8),
    /// A frame the DBC does not decode (the controller ignores and counts it).
    Malformed(String),
}

/// One request and its answers.
#[derive(Debug, Clone, Serialize)]
pub struct Request {
    /// When, s.
    pub t: f64,
    /// Request id.
    pub id: u8,
    /// What.
    pub kind: Kind,
    /// The answers: (s, answer, reason).
    pub answers: Vec<(f64, String, String)>,
}

/// A move the controller accepted (or queued): for the load's verdicts.
#[derive(Debug, Clone, PartialEq)]
pub struct Accepted {
    /// When it was answered, s.
    pub t: f64,
    /// Request id.
    pub id: u8,
    /// Target, m (x, z or x, y, z).
    pub target: Vec<f64>,
    /// Duration, s (`None`: as fast as the limits allow).
    pub duration: Option<f64>,
    /// Queued behind the running move.
    pub queued: bool,
}

/// What the requests section reports, and the events it hands on.
#[derive(Debug)]
pub struct Requests {
    /// Requests in order.
    pub requests: Capped<Request>,
    /// Status frames whose answer no request seen in the log asked for.
    pub unasked: Capped<(f64, u8, String, String)>,
    /// The mode and fault as the status frames show them, when they change: (s, mode, fault).
    pub modes: Capped<(f64, String, String)>,
    /// Counter increases: (s, counter, from, to).
    pub counters: Capped<(f64, String, u64, u64)>,
    /// The counters' last values: frames ignored, deadline misses, transmit failures.
    pub last_counters: Option<[u64; 3]>,
    /// Status frames seen.
    pub statuses: u64,
    /// Manual-mode frames (0x400 + controller).
    pub manual: u64,
    /// Changes of mode or fault the status frames showed, all counted.
    pub mode_changes: u64,
    pending: BTreeMap<u8, usize>,
    last_status: Option<(u8, u8, u8)>,
    last_mode: Option<(String, String)>,
    sdo_request: BTreeMap<u8, u32>,
    controller: u8,
}

impl Requests {
    /// For the controller at node `controller`.
    pub fn new(controller: u8) -> Self {
        Self {
            requests: Capped::new(2000),
            unasked: Capped::new(100),
            modes: Capped::new(500),
            counters: Capped::new(200),
            last_counters: None,
            statuses: 0,
            manual: 0,
            mode_changes: 0,
            pending: BTreeMap::new(),
            last_status: None,
            last_mode: None,
            sdo_request: BTreeMap::new(),
            controller,
        }
    }

    /// One frame; a move accepted or queued is returned, and a stop accepted as
    /// `Some(Err(t))`.
    pub fn frame(&mut self, s: &Seen) -> Option<Result<Accepted, f64>> {
        match s.cob {
            Cob::Rpdo(1 | 2, n) if n == self.controller => {
                self.request(s);
                None
            }
            Cob::Rpdo(3, n) if n == self.controller => {
                self.manual += 1;
                None
            }
            Cob::SdoRequest(n) if n == self.controller => {
                self.sdo_write(s);
                None
            }
            Cob::Tpdo(1, n) if n == self.controller => self.status(s),
            _ => None,
        }
    }

    fn request(&mut self, s: &Seen) {
        let Some(d) = s.decoded else {
            let hex: String = s.frame.bytes().iter().map(|b| format!("{b:02X}")).collect();
            self.push(
                s.t,
                s.frame.bytes().first().copied().unwrap_or(0),
                Kind::Malformed(format!("0x{:03X} [{}] {hex}", s.frame.id, s.frame.len)),
            );
            return;
        };
        let id = d.get("request_id").unwrap_or(0.0) as u8;
        let duration = d.get("duration").filter(|&v| v > 0.0);
        let kind = match d.message.as_str() {
            "Move3d_Controller" => Kind::Move {
                target: ["target_x", "target_y", "target_z"]
                    .iter()
                    .map(|n| d.get(n).unwrap_or(f64::NAN))
                    .collect(),
                duration,
            },
            _ => match s.label("command").as_deref() {
                Some("Move") => Kind::Move {
                    target: ["target_x", "target_z"]
                        .iter()
                        .map(|n| d.get(n).unwrap_or(f64::NAN))
                        .collect(),
                    duration,
                },
                Some("Stop") => Kind::Stop,
                Some("Reset") => Kind::Reset,
                other => Kind::Malformed(format!("command {}", other.unwrap_or("?"))),
            },
        };
        self.push(s.t, id, kind);
    }

    /// A write into 0x2000 (a PLC without PDOs): sub 1 the id, sub 2 the command that
    /// submits it.
    fn sdo_write(&mut self, s: &Seen) {
        let data = s.frame.bytes();
        if data.len() != 8 || data[0] >> 5 != 1 || u16::from_le_bytes([data[1], data[2]]) != 0x2000
        {
            return;
        }
        let value = u32::from_le_bytes([data[4], data[5], data[6], data[7]]);
        self.sdo_request.insert(data[3], value);
        if data[3] == 2 {
            let id = self.sdo_request.get(&1).copied().unwrap_or(0) as u8;
            self.push(s.t, id, Kind::BySdo(data[4]));
        }
    }

    fn push(&mut self, t: f64, id: u8, kind: Kind) {
        if matches!(kind, Kind::Malformed(_)) {
            self.requests.push(Request {
                t,
                id,
                kind,
                answers: Vec::new(),
            });
            return;
        }
        let index = self.requests.items.len();
        self.requests.push(Request {
            t,
            id,
            kind,
            answers: Vec::new(),
        });
        if index < self.requests.items.len() {
            self.pending.insert(id, index);
        }
    }

    /// The controller's mode and fault as its last status frame showed them.
    pub fn mode_now(&self) -> Option<(&str, &str)> {
        self.last_mode
            .as_ref()
            .map(|(mode, fault)| (mode.as_str(), fault.as_str()))
    }

    fn status(&mut self, s: &Seen) -> Option<Result<Accepted, f64>> {
        let d = s.decoded?;
        self.statuses += 1;
        let get = |n: &str| d.get(n).unwrap_or(0.0);
        let (id, answer, reason) = (
            get("last_id") as u8,
            get("answer") as u8,
            get("reason") as u8,
        );
        let answer_name = s.label("answer").unwrap_or_else(|| answer.to_string());
        let reason_name = s.label("reason").unwrap_or_else(|| reason.to_string());
        let mode = (
            s.label("mode").unwrap_or_else(|| get("mode").to_string()),
            s.label("fault").unwrap_or_else(|| get("fault").to_string()),
        );
        if self.last_mode.as_ref() != Some(&mode) {
            self.modes.push((s.t, mode.0.clone(), mode.1.clone()));
            self.mode_changes += 1;
            self.last_mode = Some(mode);
        }
        let counters = [
            get("ignored") as u64,
            get("deadline_misses") as u64,
            get("tx_failures") as u64,
        ];
        if let Some(last) = self.last_counters {
            for (i, name) in ["frames ignored", "deadline misses", "transmit failures"]
                .iter()
                .enumerate()
            {
                if counters[i] != last[i] {
                    self.counters
                        .push((s.t, name.to_string(), last[i], counters[i]));
                }
            }
        }
        self.last_counters = Some(counters);
        let status = (id, answer, reason);
        let repeated = self.last_status == Some(status);
        self.last_status = Some(status);
        if answer == 0 {
            return None;
        }
        let Some(index) = self.pending.remove(&id) else {
            if !repeated {
                self.unasked.push((s.t, id, answer_name, reason_name));
            }
            return None;
        };
        let request = self.requests.items.get_mut(index)?;
        request
            .answers
            .push((s.t, answer_name.clone(), reason_name));
        match (&request.kind, answer_name.as_str()) {
            (Kind::Move { target, duration }, "Accepted" | "Queued") => Some(Ok(Accepted {
                t: s.t,
                id,
                target: target.clone(),
                duration: *duration,
                queued: answer_name == "Queued",
            })),
            (Kind::Stop, "Accepted") => Some(Err(s.t)),
            _ => None,
        }
    }
}
