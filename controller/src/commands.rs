//! Requests from the supervisor (PLC/HMI) and the controller's status answer.
//! The layout is specified in docs/COMMANDS.md and documented for CAN tools in
//! `can/crane.dbc`.

use crate::canopen::{cob, CONTROLLER_NODE};
use crate::frame::CanFrame;

/// COB-ID of command frames: RPDO1 of the controller (0x200 + its node id; 0x210 by default).
pub const COMMAND_ID: u16 = command_id(CONTROLLER_NODE);
/// COB-ID of status frames: TPDO1 of the controller (0x180 + its node id; 0x190 by default).
pub const STATUS_ID: u16 = status_id(CONTROLLER_NODE);
/// COB-ID of 3D move frames: RPDO2 of the controller (0x300 + its node id; 0x310 by
/// default).
pub const MOVE3D_ID: u16 = move3d_id(CONTROLLER_NODE);

/// COB-ID of the command frames of the controller at `node`.
#[must_use]
pub const fn command_id(node: u8) -> u16 {
    cob::RPDO1 + node as u16
}

/// COB-ID of the status frames of the controller at `node`.
#[must_use]
pub const fn status_id(node: u8) -> u16 {
    cob::TPDO1 + node as u16
}

/// COB-ID of the 3D move frames of the controller at `node`.
#[must_use]
pub const fn move3d_id(node: u8) -> u16 {
    cob::RPDO2 + node as u16
}

/// A decoded request.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Request {
    /// Move the load to `target` (`[x_C, z_C]`, m) in `duration` seconds
    /// (`None`: as fast as the limits allow).
    Move {
        /// Request id.
        id: u8,
        /// Target load position, m.
        target: [f64; 2],
        /// Duration, s.
        duration: Option<f64>,
    },
    /// Move the load to `target` (`[x_C, y_C, z_C]`, m) in `duration` seconds (`None`:
    /// as fast as the limits allow): the 3D crane's move, on its own frame (RPDO2).
    Move3d {
        /// Request id.
        id: u8,
        /// Target load position, m.
        target: [f64; 3],
        /// Duration, s.
        duration: Option<f64>,
    },
    /// Bring the load to rest smoothly.
    Stop {
        /// Request id.
        id: u8,
    },
    /// Leave *halted*: fault reset, enable the drives again.
    Reset {
        /// Request id.
        id: u8,
    },
}

impl Request {
    /// The request id.
    #[must_use]
    pub fn id(&self) -> u8 {
        match *self {
            Request::Move { id, .. }
            | Request::Move3d { id, .. }
            | Request::Stop { id }
            | Request::Reset { id } => id,
        }
    }
}

/// Why a command frame is malformed (it is then ignored and counted).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommandError {
    /// Not 8 bytes.
    Length(u8),
    /// A command byte other than 1, 2, 3.
    UnknownCommand(u8),
    /// Non-zero bytes where *stop* and *reset* require zeros.
    TrailingBytes,
}

/// Decodes a 3D move frame's 8 bytes: request id, x_C, y_C, z_C (mm, u16 each) and the
/// duration in whole seconds (0: as fast as the limits allow). One frame for the whole
/// move — no state kept between two frames — which leaves one byte for the duration.
pub fn decode_move3d(data: &[u8]) -> Result<Request, CommandError> {
    let [id, x0, x1, y0, y1, z0, z1, seconds] = *data else {
        return Err(CommandError::Length(data.len() as u8));
    };
    let mm = |a, b| f64::from(u16::from_le_bytes([a, b])) / 1000.0;
    Ok(Request::Move3d {
        id,
        target: [mm(x0, x1), mm(y0, y1), mm(z0, z1)],
        duration: (seconds != 0).then_some(f64::from(seconds)),
    })
}

/// Ticks of a move's duration per second: the command frame carries durations in 10 ms
/// units — the wire's resolution (docs/COMMANDS.md), fixed whatever the scene's cycle h.
pub const DURATION_TICKS_PER_S: f64 = 100.0;

/// Decodes a command frame's 8 bytes.
pub fn decode_request(data: &[u8]) -> Result<Request, CommandError> {
    let [id, command, x0, x1, z0, z1, d0, d1] = *data else {
        return Err(CommandError::Length(data.len() as u8));
    };
    match command {
        1 => {
            let mm = |a, b| f64::from(u16::from_le_bytes([a, b])) / 1000.0;
            let ticks = u16::from_le_bytes([d0, d1]);
            let duration = (ticks != 0).then(|| f64::from(ticks) / DURATION_TICKS_PER_S);
            Ok(Request::Move {
                id,
                target: [mm(x0, x1), mm(z0, z1)],
                duration,
            })
        }
        2 | 3 if [x0, x1, z0, z1, d0, d1] != [0; 6] => Err(CommandError::TrailingBytes),
        2 => Ok(Request::Stop { id }),
        3 => Ok(Request::Reset { id }),
        other => Err(CommandError::UnknownCommand(other)),
    }
}

/// A command frame, or a 3D move frame (for the supervisor's side, the tests and the
/// virtual bus). Targets are rounded to millimetres and clamped to the field's range; a
/// 3D move's duration to whole seconds, 1..=255.
#[must_use]
pub fn request_frame(request: &Request) -> CanFrame {
    let mm =
        |m: f64| (libm::round(m * 1000.0).clamp(0.0, f64::from(u16::MAX)) as u16).to_le_bytes();
    let (cob, data) = match *request {
        Request::Move3d {
            id,
            target: [x, y, z],
            duration,
        } => {
            let ([x0, x1], [y0, y1], [z0, z1]) = (mm(x), mm(y), mm(z));
            let seconds = duration.map_or(0, |d| libm::round(d).clamp(1.0, 255.0) as u8);
            (MOVE3D_ID, [id, x0, x1, y0, y1, z0, z1, seconds])
        }
        Request::Move {
            id,
            target: [x, z],
            duration,
        } => {
            let [x0, x1] = mm(x);
            let [z0, z1] = mm(z);
            let ticks: u16 = duration.map_or(0, |d| {
                libm::round(d * DURATION_TICKS_PER_S).clamp(1.0, f64::from(u16::MAX)) as u16
            });
            let [d0, d1] = ticks.to_le_bytes();
            (COMMAND_ID, [id, 1, x0, x1, z0, z1, d0, d1])
        }
        Request::Stop { id } => (COMMAND_ID, [id, 2, 0, 0, 0, 0, 0, 0]),
        Request::Reset { id } => (COMMAND_ID, [id, 3, 0, 0, 0, 0, 0, 0]),
    };
    CanFrame::fixed(cob, &data)
}

/// The answer to a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Answer {
    /// No request answered yet.
    None = 0,
    /// Accepted; starts now.
    Accepted = 1,
    /// Accepted; starts after the running move.
    Queued = 2,
    /// Rejected; see the reason.
    Rejected = 3,
    /// Requests that found no place for an answer of their own (a supervisor sending
    /// faster than the status frames can answer): not acted on. The status frame names
    /// the last of them (byte 0) and how many they are (byte 2); a stop among them is
    /// obeyed all the same.
    Overload = 4,
}

/// Why a request was rejected (docs/COMMANDS.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Reject {
    /// A move is already queued.
    Busy = 1,
    /// Drives not enabled, or stopping/halted.
    NotReady = 2,
    /// Zero or non-finite target, a duration out of range, or a y for the planar crane.
    Invalid = 3,
    /// The trolley would leave its workspace.
    TrolleyWorkspace = 4,
    /// The rope would leave its length range (or the load rise above the rail).
    RopeWorkspace = 5,
    /// The load's downward acceleration would exceed half of g.
    SlackRope = 6,
    /// Trolley velocity above its limit.
    TrolleyVelocity = 7,
    /// Winch velocity above its limit.
    WinchVelocity = 8,
    /// Trolley acceleration above its limit.
    TrolleyAcceleration = 9,
    /// Winch acceleration above its limit.
    WinchAcceleration = 10,
    /// The bridge would leave its runway (3D crane).
    BridgeWorkspace = 11,
    /// Bridge velocity above its limit (3D crane).
    BridgeVelocity = 12,
    /// Bridge acceleration above its limit (3D crane).
    BridgeAcceleration = 13,
    /// A reset while the crane still moves (a move, or a stop bringing it to rest):
    /// taken only at rest.
    Moving = 14,
    /// A drive is not where the controller last brought it (position actual further
    /// than its `in_place` window from where the model holds the crane), or its position
    /// is not known: a move from the wrong start would end off its target. A reset takes
    /// the drives' positions as the crane's.
    NotInPlace = 15,
    /// The hook-and-load crane's hook block would reach the rail (the flat inverse has no
    /// hook below it): not the trolley's end stop nor the rope's range, which a PLC would
    /// look for elsewhere.
    HookAtRail = 16,
}

/// The status frame's contents.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    /// Id of the last request answered.
    pub last_id: u8,
    /// Its answer.
    pub answer: Answer,
    /// The reason, if rejected.
    pub reason: Option<Reject>,
    /// For [`Answer::Overload`]: how many requests it answers, 1–255 (status byte 2).
    pub overload: u8,
    /// The mode code (docs/COMMANDS.md).
    pub mode: u8,
    /// The fault code, 0 for none.
    pub fault: u8,
    /// Frames ignored.
    pub ignored: u32,
    /// Deadline misses.
    pub deadline_misses: u32,
    /// Transmit failures.
    pub tx_failures: u32,
}

impl Status {
    /// The status frame's 8 bytes (docs/COMMANDS.md; the controller's 0x2001:1..=8). The
    /// counters go modulo 256: they roll over rather than stick at 255, so that the
    /// difference between two status frames is what happened between them (fewer than
    /// 256 events apart: the status goes out every 100 ms at least).
    #[must_use]
    pub fn bytes(&self) -> [u8; 8] {
        let detail = match self.answer {
            Answer::Overload => self.overload,
            _ => self.reason.map_or(0, |r| r as u8),
        };
        let roll = |v: u32| (v % 256) as u8;
        [
            self.last_id,
            self.answer as u8,
            detail,
            self.mode,
            self.fault,
            roll(self.ignored),
            roll(self.deadline_misses),
            roll(self.tx_failures),
        ]
    }
}

/// The status frame of the controller at `node`.
#[must_use]
pub fn status_frame(node: u8, s: &Status) -> CanFrame {
    CanFrame::fixed(status_id(node), &s.bytes())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn requests_round_trip() {
        let requests = [
            Request::Move {
                id: 7,
                target: [20.0, 4.0],
                duration: Some(8.0),
            },
            Request::Move {
                id: 8,
                target: [12.345, 8.765],
                duration: None,
            },
            Request::Stop { id: 9 },
            Request::Reset { id: 10 },
        ];
        for r in requests {
            let f = request_frame(&r);
            assert_eq!(f.id(), 0x210);
            assert_eq!(decode_request(f.data()), Ok(r));
        }
    }

    #[test]
    fn move3d_frames_round_trip() {
        for r in [
            Request::Move3d {
                id: 7,
                target: [20.0, 6.5, 4.0],
                duration: Some(9.0),
            },
            Request::Move3d {
                id: 8,
                target: [12.345, 0.001, 8.765],
                duration: None,
            },
        ] {
            let f = request_frame(&r);
            assert_eq!(f.id(), 0x310);
            assert_eq!(decode_move3d(f.data()), Ok(r));
        }
        assert_eq!(
            request_frame(&Request::Move3d {
                id: 1,
                target: [1.0, 2.0, 3.0],
                duration: Some(0.2)
            })
            .data(),
            [1, 0xE8, 0x03, 0xD0, 0x07, 0xB8, 0x0B, 1]
        );
        assert_eq!(decode_move3d(&[1; 7]), Err(CommandError::Length(7)));
    }

    #[test]
    fn malformed_commands_are_refused() {
        assert_eq!(decode_request(&[1, 1, 0]), Err(CommandError::Length(3)));
        assert_eq!(
            decode_request(&[1, 9, 0, 0, 0, 0, 0, 0]),
            Err(CommandError::UnknownCommand(9))
        );
        assert_eq!(
            decode_request(&[1, 2, 0, 0, 0, 0, 1, 0]),
            Err(CommandError::TrailingBytes)
        );
        assert_eq!(
            decode_request(&[1, 3, 5, 0, 0, 0, 0, 0]),
            Err(CommandError::TrailingBytes)
        );
    }
}
