//! The controller as a CANopen node (CiA 301): its NMT slave state machine, its object
//! dictionary and the values its SDO server answers with. Which objects exist, their
//! types and access are declared once in [`crate::canopen::od::CONTROLLER`], which the
//! server reads; `can/crane-controller.eds` describes the same objects for a PLC's
//! configuration tool, and a host test checks the two against each other. What they
//! hold:
//!
//! | index | name | access |
//! |---|---|---|
//! | 0x1000 | device type (0: no standard device profile) | ro |
//! | 0x1001 | error register | ro |
//! | 0x1005 | COB-ID SYNC (0x4000_0080: the controller produces SYNC) | ro |
//! | 0x1006 | communication cycle period, µs (the scene's h) | ro |
//! | 0x1016:1 | consumer heartbeat time: supervisor node << 16 \| ms (0: not watched) | rw |
//! | 0x1017 | producer heartbeat time, ms | rw |
//! | 0x1018:1..=4 | identity: vendor, product, revision, serial | ro |
//! | 0x1400:1..=2, 0x1600:1..=5 | RPDO1: the supervisor's command frame (0x210) | ro |
//! | 0x1401:1..=2, 0x1601:1..=5 | RPDO2: the supervisor's 3D move frame (0x310) | ro |
//! | 0x1402:1..=2, 0x1602:1..=5 | RPDO3: the operator's speed demand (0x410) | ro |
//! | 0x1800:1..=2, 0x1A00:1..=8 | TPDO1: the status frame (0x190) | ro |
//! | 0x2000:1..=7 | the command frames' fields (request id, command, x, z, duration in 10 ms; y and duration in s of the 3D move); writing the command submits a request (4: the 3D move) | wo |
//! | 0x2001:1..=8 | the status frame's fields (docs/COMMANDS.md) | ro |
//! | 0x2002:1..=5 | the last commissioning failure: node, index, sub, abort code, reason | ro |
//! | 0x2003:1..=2 | NMT role (0 manager, 1 slave); drives' commissioning phase (bit per drive: done) | ro |
//! | 0x2004:1..=6 | rope calibration learnt from the swing (`crate::rope`): drum scaling error, ppm (i32); rope offset, µm (i32); samples taken (u32); what was learnt (u8: 0 nothing yet, 1 the offset at one length, 2 scaling and offset — to be saved, 3 at a bound, 4 refused: too uncertain, 5 refused: the angle's delay not as commissioned); the length's uncertainty, µm (u32, three standard deviations over 3–9 m plus 3 mm, `crate::rope::SIGMAS`, `MODEL_FLOOR`; u32::MAX before anything is learnt); the angle's delay beyond the commissioned one, µs (i32) | ro |
//! | 0x2010:1..=5 | the operator frame's fields (alive counter, flags, demand x, y, z; `crate::operator::frame`); writing the counter submits them as one frame | wo |

use crate::canopen::od::{self, OPERATOR_FIELDS, REQUEST_FIELDS, STATUS_FIELDS};
use crate::canopen::sdo::{abort, Object, ObjectDictionary, Value};
use crate::canopen::{NmtCommand, NmtState};
use crate::commands::{
    command_id, decode_move3d, decode_request, move3d_id, status_id, CommandError, Request, Status,
};
use crate::commissioning::MAX_NODES;
use crate::operator::{decode_operator, operator_id, OperatorError, OperatorFrame};

/// Who starts the drives.
///
/// With feature `serde`, a commissioning file's `role = "manager"` or `"slave"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Deserialize),
    serde(rename_all = "kebab-case")
)]
pub enum Role {
    /// Standalone: the controller is NMT manager, commissions and starts the drives
    /// (addressed NMT) and starts itself.
    Manager,
    /// Under a PLC that is NMT master: the controller sends no NMT command, waits in
    /// pre-operational for the PLC's *start*, and still commissions the drives by SDO.
    Slave,
}

/// Identity (0x1018) of the controller.
pub const IDENTITY: [u32; 4] = [0, 0x0000_C4A1, 0x0001_0000, 0];

/// CiA 301 device type of the controller: no standard device profile.
pub const DEVICE_TYPE: u32 = 0;

/// Its COB-ID SYNC (0x1005): bit 30, the controller produces SYNC, on COB-ID 0x080.
pub const COB_ID_SYNC: u32 = 0x4000_0000 | crate::canopen::cob::SYNC as u32;

/// The transmission type of its PDOs (0x1400:2, 0x1401:2, 0x1800:2): event-driven,
/// manufacturer specific (CiA 301: 0xFE).
pub const EVENT_DRIVEN: u8 = 0xFE;

/// The command frame's mapping (0x1600): request id, command, x, z, duration.
pub const COMMAND_MAPPING: [u32; 5] = [
    REQUEST_FIELDS[0].mapping(),
    REQUEST_FIELDS[1].mapping(),
    REQUEST_FIELDS[2].mapping(),
    REQUEST_FIELDS[3].mapping(),
    REQUEST_FIELDS[4].mapping(),
];

/// The 3D move frame's mapping (0x1601): request id, x, y, z, duration in seconds.
pub const MOVE3D_MAPPING: [u32; 5] = [
    REQUEST_FIELDS[0].mapping(),
    REQUEST_FIELDS[2].mapping(),
    REQUEST_FIELDS[5].mapping(),
    REQUEST_FIELDS[3].mapping(),
    REQUEST_FIELDS[6].mapping(),
];

/// The operator frame's mapping (0x1602): alive counter, flags, demand x, y, z.
pub const OPERATOR_MAPPING: [u32; 5] = [
    OPERATOR_FIELDS[0].mapping(),
    OPERATOR_FIELDS[1].mapping(),
    OPERATOR_FIELDS[2].mapping(),
    OPERATOR_FIELDS[3].mapping(),
    OPERATOR_FIELDS[4].mapping(),
];

/// The command written over SDO (0x2000:2) that submits the 3D move of 0x2000:1, 3, 6,
/// 4 and 7; its frame (RPDO2) carries no command byte.
pub const MOVE3D_COMMAND: u8 = 4;

/// The status frame's mapping (0x1A00): eight bytes of 0x2001.
pub const STATUS_MAPPING: [u32; 8] = [
    STATUS_FIELDS[0].mapping(),
    STATUS_FIELDS[1].mapping(),
    STATUS_FIELDS[2].mapping(),
    STATUS_FIELDS[3].mapping(),
    STATUS_FIELDS[4].mapping(),
    STATUS_FIELDS[5].mapping(),
    STATUS_FIELDS[6].mapping(),
    STATUS_FIELDS[7].mapping(),
];

/// The controller's own NMT state and the parameters a master may change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Node {
    /// Node id.
    pub id: u8,
    /// NMT role.
    pub role: Role,
    /// NMT state.
    pub state: NmtState,
    /// Producer heartbeat time, ms (0x1017).
    pub heartbeat_ms: u16,
    /// Supervisor watched: node and heartbeat timeout, ms (0x1016:1; 0 = not watched).
    pub supervisor: u32,
    /// Cycle, µs (0x1006).
    pub cycle_us: u32,
    /// A request written field by field over SDO into 0x2000 (the command frame's
    /// bytes); writing the command (sub 2) submits it.
    pub request: StagedRequest,
    /// The operator frame written field by field over SDO into 0x2010; writing the
    /// alive counter (sub 1) submits it.
    pub operator: StagedOperator,
    /// The shortest heartbeat consumer time the controller writes into its drives
    /// (their 0x1016:1 for it), ms; 0 when none watches it. A producer time 0x1017 they
    /// would not tolerate is refused: confirmed, it would make them stop by themselves.
    pub drives_consumer_ms: u16,
    /// The nodes of the commissioning list (drives, inclinometer; 0 for a free place):
    /// their heartbeats are watched already, none can be the supervisor of 0x1016:1.
    pub listed: [u8; MAX_NODES],
}

/// A request written over SDO into 0x2000:1..=7, as the command frame's 8 bytes and the
/// 3D move's y and seconds, for a supervisor that commands through the dictionary
/// rather than the command PDOs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StagedRequest {
    /// The command frame's bytes as written so far.
    pub bytes: [u8; 8],
    /// The 3D move's y (mm, little-endian) and duration (s), 0x2000:6 and 7.
    pub y_and_duration: [u8; 3],
    /// The command (sub 2) was written: the controller takes it as a request.
    pub submitted: bool,
}

impl StagedRequest {
    /// The request written: the command frame's, or for command 4 the 3D move frame's
    /// fields.
    pub fn request(&self) -> Result<Request, CommandError> {
        let [id, command, x0, x1, z0, z1, ..] = self.bytes;
        let [y0, y1, seconds] = self.y_and_duration;
        if command == MOVE3D_COMMAND {
            decode_move3d(&[id, x0, x1, y0, y1, z0, z1, seconds])
        } else {
            decode_request(&self.bytes)
        }
    }
}

/// The operator frame written over SDO into 0x2010:1..=5, as its 8 bytes, for an
/// operator's PLC without PDOs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StagedOperator {
    /// The frame's bytes as written so far.
    pub bytes: [u8; 8],
    /// The counter (sub 1) was written: the controller takes the bytes as a frame.
    pub submitted: bool,
    /// The crane has no y direction (the planar crane): a frame with a y demand is
    /// refused when submitted. Set by the controller from its crane; kept by an NMT
    /// reset (a property of the crane, not a field written).
    pub planar: bool,
}

impl StagedOperator {
    /// The frame written.
    pub fn frame(&self) -> Result<OperatorFrame, OperatorError> {
        decode_operator(&self.bytes)
    }
}

impl Node {
    /// Obeys an NMT command addressed to it (CiA 301's NMT slave state machine). A reset
    /// of the node or its communication brings the communication parameters back to
    /// their defaults (`heartbeat_ms`: the producer time 0x1017 at boot; the supervisor
    /// no longer watched) and leaves it pre-operational; `true`: a boot-up message is due
    /// (a manager starts itself again after it).
    pub fn on_nmt(&mut self, command: NmtCommand, heartbeat_ms: u16) -> bool {
        let (state, reset) = match command {
            NmtCommand::Start => (NmtState::Operational, false),
            NmtCommand::Stop => (NmtState::Stopped, false),
            NmtCommand::PreOperational => (NmtState::PreOperational, false),
            NmtCommand::ResetNode | NmtCommand::ResetCommunication => {
                self.heartbeat_ms = heartbeat_ms;
                self.supervisor = 0;
                // The request fields of 0x2000 back to their power-on values (CiA 301: a
                // reset restores the dictionary): a 3D move submitted after it carries
                // only what was written since.
                self.request = StagedRequest::default();
                self.operator = StagedOperator {
                    planar: self.operator.planar,
                    ..StagedOperator::default()
                };
                (NmtState::PreOperational, true)
            }
        };
        self.state = state;
        reset
    }

    /// The cycle, ms (0x1006 in ms).
    #[must_use]
    pub fn cycle_ms(&self) -> u32 {
        self.cycle_us / 1000
    }

    /// Whether the node can take `ms` as its heartbeat producer time 0x1017, or the
    /// CiA 301 abort code that says why not:
    ///
    /// * 0 (off) while drives watch its heartbeat: 0x0604_0043, general parameter
    ///   incompatibility — they would stop by themselves (their consumer times out);
    /// * more than half the shortest consumer time its drives were given (the
    ///   commissioning file's rule, `controller_timeout_ms` at least twice the
    ///   heartbeat): 0x0609_0031, value too high — one late beat would trip them;
    /// * not a whole number of cycles (it is sent on a cycle): 0x0609_0030.
    pub fn heartbeat_producer_time(&self, ms: u16) -> Result<(), u32> {
        let consumer = u32::from(self.drives_consumer_ms);
        if ms == 0 {
            return if consumer == 0 {
                Ok(())
            } else {
                Err(abort::PARAMETER_INCOMPATIBLE)
            };
        }
        let cycle_ms = self.cycle_ms();
        if cycle_ms == 0 || u32::from(ms) % cycle_ms != 0 {
            return Err(abort::INVALID_VALUE);
        }
        if consumer != 0 && 2 * u32::from(ms) > consumer {
            return Err(abort::VALUE_TOO_HIGH);
        }
        Ok(())
    }
}

/// The values the object dictionary reads from the controller at the time of a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Snapshot {
    /// The status frame's contents.
    pub status: Status,
    /// Error register (0x1001).
    pub error_register: u8,
    /// Last commissioning failure: node, index, sub, abort code, reason.
    pub commissioning_failure: (u8, u16, u8, u32, u8),
    /// Bit per drive, in the crane's drive order (bit 0 the first of `DRIVES`: the
    /// planar crane's trolley, the 3D crane's bridge): commissioned.
    pub commissioned: u8,
    /// The rope calibration learnt so far: scaling error, ppm; offset, µm; samples;
    /// what was learnt (`crate::rope::Learnt`); the length's uncertainty, µm; the
    /// angle's delay beyond the commissioned one, µs.
    pub rope: (i32, i32, u32, u8, u32, i32),
}

/// The object dictionary at one moment: the node's parameters and a snapshot.
#[derive(Debug)]
pub struct Dictionary<'a> {
    /// The node, whose parameters a write changes.
    pub node: &'a mut Node,
    /// Read-only values.
    pub snapshot: Snapshot,
}

fn value(bytes: &[u8]) -> Value {
    crate::canopen::sdo::value(bytes)
}

impl Dictionary<'_> {
    /// The value of a readable object of the table ([`od::CONTROLLER`]) but a record's
    /// sub-index 0; `None` for one the table holds and this does not (a host test reads
    /// every entry of the table, so there is none).
    fn value_of(&self, object: Object) -> Option<Value> {
        let s = &self.snapshot;
        let (node, index, sub, code, reason) = s.commissioning_failure;
        let u32v = |v: u32| value(&v.to_le_bytes());
        let k = usize::from(object.sub).checked_sub(1);
        match (object.index, object.sub) {
            (od::DEVICE_TYPE, 0) => Some(u32v(DEVICE_TYPE)),
            (od::ERROR_REGISTER, 0) => Some(value(&[s.error_register])),
            (od::COB_ID_SYNC, 0) => Some(u32v(COB_ID_SYNC)),
            (od::CYCLE_PERIOD, 0) => Some(u32v(self.node.cycle_us)),
            (od::CONSUMER_HEARTBEAT, 1) => Some(u32v(self.node.supervisor)),
            (od::PRODUCER_HEARTBEAT, 0) => Some(value(&self.node.heartbeat_ms.to_le_bytes())),
            (od::IDENTITY, _) => k.and_then(|k| IDENTITY.get(k)).map(|v| u32v(*v)),
            (od::RPDO1_COMMUNICATION, 1) => Some(u32v(u32::from(command_id(self.node.id)))),
            (od::RPDO2_COMMUNICATION, 1) => Some(u32v(u32::from(move3d_id(self.node.id)))),
            (od::TPDO1_COMMUNICATION, 1) => Some(u32v(u32::from(status_id(self.node.id)))),
            (od::RPDO3_COMMUNICATION, 1) => Some(u32v(u32::from(operator_id(self.node.id)))),
            (
                od::RPDO1_COMMUNICATION
                | od::RPDO2_COMMUNICATION
                | od::RPDO3_COMMUNICATION
                | od::TPDO1_COMMUNICATION,
                2,
            ) => Some(value(&[EVENT_DRIVEN])),
            (od::RPDO1_MAPPING, _) => k.and_then(|k| COMMAND_MAPPING.get(k)).map(|v| u32v(*v)),
            (od::RPDO2_MAPPING, _) => k.and_then(|k| MOVE3D_MAPPING.get(k)).map(|v| u32v(*v)),
            (od::RPDO3_MAPPING, _) => k.and_then(|k| OPERATOR_MAPPING.get(k)).map(|v| u32v(*v)),
            (od::TPDO1_MAPPING, _) => k.and_then(|k| STATUS_MAPPING.get(k)).map(|v| u32v(*v)),
            (od::STATUS, _) => k
                .and_then(|k| s.status.bytes().get(k).copied())
                .map(|b| value(&[b])),
            (od::COMMISSIONING_FAILURE, 1) => Some(value(&[node])),
            (od::COMMISSIONING_FAILURE, 2) => Some(value(&index.to_le_bytes())),
            (od::COMMISSIONING_FAILURE, 3) => Some(value(&[sub])),
            (od::COMMISSIONING_FAILURE, 4) => Some(u32v(code)),
            (od::COMMISSIONING_FAILURE, 5) => Some(value(&[reason])),
            (od::NETWORK, 1) => Some(value(&[match self.node.role {
                Role::Manager => 0,
                Role::Slave => 1,
            }])),
            (od::NETWORK, 2) => Some(value(&[s.commissioned])),
            (od::ROPE_CALIBRATION, _) => {
                let (scale, offset, samples, learnt, uncertainty, delay) = s.rope;
                match object.sub {
                    1 => Some(value(&scale.to_le_bytes())),
                    2 => Some(value(&offset.to_le_bytes())),
                    3 => Some(u32v(samples)),
                    4 => Some(value(&[learnt])),
                    5 => Some(u32v(uncertainty)),
                    6 => Some(value(&delay.to_le_bytes())),
                    _ => None,
                }
            }
            _ => None,
        }
    }
}

impl ObjectDictionary for Dictionary<'_> {
    /// The table ([`od::CONTROLLER`]) says whether the object exists and may be read;
    /// a record's sub-index 0 is its highest sub-index there.
    fn read(&self, object: Object) -> Result<Value, u32> {
        let entry = od::controller_entry(object)?;
        if !entry.access.readable() {
            return Err(abort::WRITE_ONLY);
        }
        if object.sub == 0 {
            if let Some(highest) = od::highest_sub(object.index) {
                return Ok(value(&[highest]));
            }
        }
        self.value_of(object).ok_or(abort::NO_OBJECT)
    }

    /// The table ([`od::CONTROLLER`]) says whether the object exists, may be written,
    /// and how long its value is.
    fn write(&mut self, object: Object, data: &[u8]) -> Result<(), u32> {
        let entry = od::controller_entry(object)?;
        if !entry.access.writable() {
            return Err(abort::READ_ONLY);
        }
        if data.len() != usize::from(entry.size()) {
            return Err(abort::LENGTH);
        }
        match (object.index, object.sub) {
            (od::PRODUCER_HEARTBEAT, 0) => match *data {
                [a, b] => {
                    let ms = u16::from_le_bytes([a, b]);
                    self.node.heartbeat_producer_time(ms)?;
                    self.node.heartbeat_ms = ms;
                    Ok(())
                }
                _ => Err(abort::LENGTH),
            },
            (od::CONSUMER_HEARTBEAT, 1) => match *data {
                [a, b, c, d] => {
                    let v = u32::from_le_bytes([a, b, c, d]);
                    // Bits 31..24 are reserved; a node id above 127 is invalid; the
                    // heartbeat is checked once a cycle, so a time shorter than a cycle
                    // cannot be watched; the controller does not consume its own.
                    let (node, ms) = ((v >> 16) & 0xFF, v & 0xFFFF);
                    if v >> 24 != 0
                        || node > 127
                        || (node != 0 && ms != 0 && ms < self.node.cycle_ms())
                    {
                        return Err(abort::INVALID_VALUE);
                    }
                    // Neither itself nor a node of its list (whose heartbeat the list's
                    // timeout watches already: confirmed, it would never be honoured).
                    let listed = self
                        .node
                        .listed
                        .iter()
                        .any(|n| *n != 0 && u32::from(*n) == node);
                    if node != 0 && (node == u32::from(self.node.id) || listed) {
                        return Err(abort::PARAMETER_INCOMPATIBLE);
                    }
                    self.node.supervisor = v;
                    Ok(())
                }
                _ => Err(abort::LENGTH),
            },
            // The command frame's fields, as mapped into RPDO1 (0x1600): bytes 0, 1,
            // 2–3, 4–5, 6–7. The command (sub 2) submits what was written, checked as
            // a command frame is; only in operational, as the command PDO.
            (od::REQUEST, sub @ 1..=5) => {
                let (at, size) = match sub {
                    1 => (0, 1),
                    2 => (1, 1),
                    k => (2 * usize::from(k) - 4, 2),
                };
                if data.len() != size {
                    return Err(abort::LENGTH);
                }
                let mut bytes = self.node.request.bytes;
                if let Some(field) = bytes.get_mut(at..at + size) {
                    field.copy_from_slice(data);
                }
                if sub == 2 {
                    // Stop and reset carry nothing else: fields left from a move are not
                    // theirs.
                    if matches!(data, [2 | 3]) {
                        if let Some(rest) = bytes.get_mut(2..) {
                            rest.fill(0);
                        }
                    }
                    if self.node.state != NmtState::Operational {
                        return Err(abort::DEVICE_STATE);
                    }
                    let staged = StagedRequest {
                        bytes,
                        ..self.node.request
                    };
                    if staged.request().is_err() {
                        return Err(abort::INVALID_VALUE);
                    }
                    self.node.request.submitted = true;
                }
                self.node.request.bytes = bytes;
                Ok(())
            }
            // The 3D move's y (as mapped into RPDO2, 0x1601) and its duration in s.
            (od::REQUEST, 6) => match *data {
                [y0, y1] => {
                    let [_, _, seconds] = self.node.request.y_and_duration;
                    self.node.request.y_and_duration = [y0, y1, seconds];
                    Ok(())
                }
                _ => Err(abort::LENGTH),
            },
            (od::REQUEST, 7) => match *data {
                [seconds] => {
                    let [y0, y1, _] = self.node.request.y_and_duration;
                    self.node.request.y_and_duration = [y0, y1, seconds];
                    Ok(())
                }
                _ => Err(abort::LENGTH),
            },
            // The operator frame's fields, as mapped into RPDO3 (0x1602): bytes 0, 1,
            // 2–3, 4–5, 6–7. The counter (sub 1) submits what was written, checked as an
            // operator frame is; only in operational, as the PDO.
            (od::OPERATOR, sub @ 1..=5) => {
                let at = match sub {
                    1 => 0,
                    2 => 1,
                    k => 2 * usize::from(k) - 4,
                };
                let mut bytes = self.node.operator.bytes;
                if let Some(field) = bytes.get_mut(at..at + data.len()) {
                    field.copy_from_slice(data);
                }
                if sub == 1 {
                    if self.node.state != NmtState::Operational {
                        return Err(abort::DEVICE_STATE);
                    }
                    // Malformed, or a demand along y to the planar crane (one it cannot
                    // follow: refused here, where the PLC hears of it).
                    let horizontal = if self.node.operator.planar { 1 } else { 2 };
                    if decode_operator(&bytes)
                        .and_then(|f| f.fits(horizontal))
                        .is_err()
                    {
                        return Err(abort::INVALID_VALUE);
                    }
                    self.node.operator.submitted = true;
                }
                self.node.operator.bytes = bytes;
                Ok(())
            }
            // A writable entry of the table this does not take (a host test writes every
            // one, so there is none).
            _ => Err(abort::READ_ONLY),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::commands::Answer;

    fn node() -> Node {
        Node {
            id: 0x10,
            role: Role::Manager,
            state: NmtState::Operational,
            heartbeat_ms: 100,
            supervisor: 0,
            cycle_us: 10_000,
            request: StagedRequest::default(),
            operator: StagedOperator::default(),
            drives_consumer_ms: 300,
            listed: [1, 2, 0, 0],
        }
    }

    #[test]
    fn nmt_commands_move_the_state_and_a_reset_restores_the_defaults() {
        let mut n = node();
        n.heartbeat_ms = 250;
        n.supervisor = (0x20 << 16) | 300;
        assert!(!n.on_nmt(NmtCommand::Stop, 100));
        assert_eq!(n.state, NmtState::Stopped);
        assert!(!n.on_nmt(NmtCommand::Start, 100));
        assert_eq!(n.state, NmtState::Operational);
        assert!(!n.on_nmt(NmtCommand::PreOperational, 100));
        assert_eq!((n.state, n.heartbeat_ms), (NmtState::PreOperational, 250));
        for reset in [NmtCommand::ResetCommunication, NmtCommand::ResetNode] {
            n.heartbeat_ms = 250;
            n.supervisor = 1;
            n.request.y_and_duration = [0x10, 0x27, 5];
            n.request.bytes[1] = MOVE3D_COMMAND;
            assert!(n.on_nmt(reset, 100), "a boot-up message is due");
            assert_eq!(
                (n.state, n.heartbeat_ms, n.supervisor),
                (NmtState::PreOperational, 100, 0)
            );
            assert_eq!(n.request, StagedRequest::default(), "0x2000 is cleared");
        }
    }

    /// 0x2010 takes the operator frame's fields; writing the counter submits them as one
    /// frame, checked as RPDO3's, only in operational; RPDO3's parameters name 0x410 and
    /// the fields in the frame's order.
    #[test]
    fn the_operator_frame_is_written_field_by_field() {
        use crate::operator::{Flags, OperatorFrame};
        let mut n = node();
        let mut od = Dictionary {
            node: &mut n,
            snapshot: snapshot(),
        };
        let o = |sub| Object::new(0x2010, sub);
        assert_eq!(od.write(o(2), &[0b011]), Ok(()));
        assert_eq!(od.write(o(3), &1000i16.to_le_bytes()), Ok(()));
        assert_eq!(od.write(o(5), &(-2000i16).to_le_bytes()), Ok(()));
        assert!(!od.node.operator.submitted, "only the counter submits");
        assert_eq!(od.write(o(1), &[9]), Ok(()));
        assert!(od.node.operator.submitted);
        assert_eq!(
            od.node.operator.frame(),
            Ok(OperatorFrame {
                counter: 9,
                flags: Flags {
                    enable: true,
                    manual: true,
                    micro: false
                },
                demand: [1000, 0, -2000],
            })
        );
        assert_eq!(od.read(o(1)), Err(abort::WRITE_ONLY));
        assert_eq!(od.write(o(3), &[1]), Err(abort::LENGTH));
        // A malformed frame is refused when submitted, and not taken.
        od.node.operator.submitted = false;
        assert_eq!(od.write(o(2), &[0x80]), Ok(()));
        assert_eq!(od.write(o(1), &[10]), Err(abort::INVALID_VALUE));
        assert!(!od.node.operator.submitted);
        assert_eq!(od.write(o(2), &[1]), Ok(()));
        od.node.state = NmtState::PreOperational;
        assert_eq!(od.write(o(1), &[11]), Err(abort::DEVICE_STATE));
        assert!(!od.node.operator.submitted);
        assert_eq!(
            od.read(Object::new(0x1402, 1)).unwrap(),
            value(&0x410u32.to_le_bytes())
        );
        assert_eq!(od.read(Object::new(0x1402, 2)).unwrap(), value(&[0xFE]));
        assert_eq!(
            od.read(Object::new(0x1602, 3)).unwrap(),
            value(&0x2010_0310u32.to_le_bytes())
        );
        assert!(od.node.on_nmt(NmtCommand::ResetCommunication, 100));
        assert_eq!(
            od.node.operator,
            StagedOperator::default(),
            "0x2010 is cleared"
        );
    }

    /// A demand along y written to the planar crane's 0x2010 is refused when the counter
    /// submits it (0x06090030), not taken; the 3D crane takes it. The crane's kind
    /// survives an NMT reset.
    #[test]
    fn the_planar_crane_refuses_a_y_demand_over_sdo() {
        let mut n = node();
        n.operator.planar = true;
        let mut od = Dictionary {
            node: &mut n,
            snapshot: snapshot(),
        };
        let o = |sub| Object::new(0x2010, sub);
        assert_eq!(od.write(o(2), &[0b011]), Ok(()));
        assert_eq!(od.write(o(4), &1000i16.to_le_bytes()), Ok(()));
        assert_eq!(od.write(o(1), &[1]), Err(abort::INVALID_VALUE));
        assert!(!od.node.operator.submitted, "not taken");
        assert_eq!(od.write(o(4), &0i16.to_le_bytes()), Ok(()));
        assert_eq!(od.write(o(1), &[2]), Ok(()), "without y it is taken");
        assert!(od.node.operator.submitted);
        assert!(od.node.on_nmt(NmtCommand::ResetCommunication, 100));
        assert!(od.node.operator.planar, "still the planar crane");
        let mut n = node();
        let mut od = Dictionary {
            node: &mut n,
            snapshot: snapshot(),
        };
        assert_eq!(od.write(o(2), &[0b011]), Ok(()));
        assert_eq!(od.write(o(4), &1000i16.to_le_bytes()), Ok(()));
        assert_eq!(od.write(o(1), &[1]), Ok(()), "the 3D crane has a y");
    }

    fn snapshot() -> Snapshot {
        Snapshot {
            status: Status {
                last_id: 7,
                answer: Answer::Accepted,
                reason: None,
                overload: 0,
                mode: 1,
                fault: 0,
                ignored: 300,
                deadline_misses: 0,
                tx_failures: 2,
            },
            error_register: 0,
            commissioning_failure: (2, 0x6060, 0, 0x0609_0030, 1),
            commissioned: 0b01,
            rope: (-15_000, 80_000, 1234, 2, 4_200, -300),
        }
    }

    #[test]
    fn reads_and_writes() {
        let mut n = node();
        let mut od = Dictionary {
            node: &mut n,
            snapshot: snapshot(),
        };
        assert_eq!(
            od.read(Object::new(0x1006, 0)).unwrap(),
            value(&10_000u32.to_le_bytes())
        );
        assert_eq!(od.read(Object::new(0x1018, 0)).unwrap(), value(&[4]));
        assert_eq!(od.read(Object::new(0x2001, 1)).unwrap(), value(&[7]));
        // The frames-ignored counter (300) modulo 256, as the status frame has it.
        assert_eq!(od.read(Object::new(0x2001, 6)).unwrap(), value(&[44]));
        assert_eq!(
            od.read(Object::new(0x2004, 1)).unwrap(),
            value(&(-15_000i32).to_le_bytes())
        );
        assert_eq!(
            od.read(Object::new(0x2004, 3)).unwrap(),
            value(&1234u32.to_le_bytes())
        );
        assert_eq!(od.read(Object::new(0x2004, 4)).unwrap(), value(&[2]));
        assert_eq!(
            od.read(Object::new(0x2004, 5)).unwrap(),
            value(&4_200u32.to_le_bytes())
        );
        assert_eq!(
            od.read(Object::new(0x2004, 6)).unwrap(),
            value(&(-300i32).to_le_bytes())
        );
        assert_eq!(
            od.read(Object::new(0x2002, 4)).unwrap(),
            value(&0x0609_0030u32.to_le_bytes())
        );
        assert_eq!(od.read(Object::new(0x2001, 9)), Err(abort::NO_SUB));
        assert_eq!(od.read(Object::new(0x3000, 0)), Err(abort::NO_OBJECT));
        assert_eq!(
            od.write(Object::new(0x1000, 0), &[0; 4]),
            Err(abort::READ_ONLY)
        );
        assert_eq!(od.write(Object::new(0x1017, 0), &[0x96, 0x00]), Ok(()));
        assert_eq!(od.write(Object::new(0x1017, 0), &[1]), Err(abort::LENGTH));
        assert_eq!(
            od.write(Object::new(0x1016, 1), &0x0080_0064u32.to_le_bytes()),
            Err(abort::INVALID_VALUE)
        );
        assert_eq!(
            od.write(Object::new(0x1016, 1), &0x0020_01F4u32.to_le_bytes()),
            Ok(())
        );
        assert_eq!(n.heartbeat_ms, 150);
        assert_eq!(n.supervisor, 0x0020_01F4);
    }

    /// A value the node cannot produce is refused (0x06090030), not confirmed and then
    /// produced otherwise or not at all (issue 17, case 4).
    #[test]
    fn writes_the_node_cannot_honour_are_refused() {
        let mut n = node();
        let mut od = Dictionary {
            node: &mut n,
            snapshot: snapshot(),
        };
        let heartbeat = |ms: u16| ms.to_le_bytes();
        for ms in [5, 15, 1, 9, 105] {
            assert_eq!(
                od.write(Object::new(0x1017, 0), &heartbeat(ms)),
                Err(abort::INVALID_VALUE),
                "{ms} ms"
            );
        }
        for ms in [10, 20, 100, 150] {
            assert_eq!(od.write(Object::new(0x1017, 0), &heartbeat(ms)), Ok(()));
        }
        assert_eq!(od.node.heartbeat_ms, 150);
        let consumer = |node: u32, ms: u32| (node << 16 | ms).to_le_bytes();
        assert_eq!(
            od.write(Object::new(0x1016, 1), &consumer(0x20, 5)),
            Err(abort::INVALID_VALUE),
            "shorter than a cycle"
        );
        assert_eq!(
            od.write(Object::new(0x1016, 1), &consumer(0x10, 300)),
            Err(abort::PARAMETER_INCOMPATIBLE),
            "its own node id"
        );
        assert_eq!(
            od.write(Object::new(0x1016, 1), &consumer(0x20, 10)),
            Ok(())
        );
        assert_eq!(od.write(Object::new(0x1016, 1), &consumer(0, 0)), Ok(()));
        // A node of its own list is watched by the list already.
        assert_eq!(
            od.write(Object::new(0x1016, 1), &consumer(2, 300)),
            Err(abort::PARAMETER_INCOMPATIBLE),
            "the winch's node"
        );
    }

    /// Issue 32, item 2: a heartbeat producer time the drives' consumers (300 ms, written
    /// by the controller) do not tolerate is refused with the reason, never confirmed and
    /// then tripping them — 0 (off), 310 ms, a configuration tool's usual 500 or 1000 ms;
    /// up to half their time is taken. Without consumers any whole number of cycles is.
    #[test]
    fn a_heartbeat_the_drives_would_not_tolerate_is_refused() {
        let mut n = node();
        let mut od = Dictionary {
            node: &mut n,
            snapshot: snapshot(),
        };
        let write =
            |od: &mut Dictionary, ms: u16| od.write(Object::new(0x1017, 0), &ms.to_le_bytes());
        assert_eq!(write(&mut od, 0), Err(abort::PARAMETER_INCOMPATIBLE));
        for ms in [160, 310, 500, 1000, 65_530] {
            assert_eq!(write(&mut od, ms), Err(abort::VALUE_TOO_HIGH), "{ms} ms");
        }
        assert_eq!(od.node.heartbeat_ms, 100, "nothing changed");
        assert_eq!(write(&mut od, 150), Ok(()));
        od.node.drives_consumer_ms = 0;
        for ms in [0, 310, 65_530] {
            assert_eq!(write(&mut od, ms), Ok(()), "{ms} ms");
        }
    }
}
