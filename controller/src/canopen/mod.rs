//! CANopen (CiA 301) as the drives expect it, with the controller as manager of two
//! CiA 402 drives in profile-velocity mode. The layout is documented for CAN tools
//! in `firmware/can/crane.dbc`; `controller/tests/dbc.rs` checks this encoder against it.
//!
//! | frame | COB-ID | bytes |
//! |---|---|---|
//! | NMT | 0x000 | command, node (0 = all) |
//! | SYNC | 0x080 | — |
//! | EMCY of node n | 0x080 + n | error code (u16), error register (u8), 5 bytes manufacturer |
//! | TPDO1 of drive n (statusword, 0x6041; velocity actual, 0x606C) | 0x180 + n | u16, i32 |
//! | RPDO1 to drive n (controlword, 0x6040; target velocity, 0x60FF) | 0x200 + n | u16, i32 |
//! | heartbeat of node n | 0x700 + n | NMT state |
//!
//! All multi-byte values are little endian (CiA 301). Velocities are in the drives'
//! units of 1 µm/s (see [`crate::units`]).

use crate::commands::{self, CommandError, Request};
use crate::drive::Drive;
use crate::frame::CanFrame;
use crate::setpoint::Setpoint;

/// The controller's own node id (heartbeat 0x710, EMCY 0x090).
pub const CONTROLLER_NODE: u8 = 0x10;

/// COB-ID bases (CiA 301 predefined connection set).
pub mod cob {
    /// Network management.
    pub const NMT: u16 = 0x000;
    /// Synchronisation: drives apply their RPDOs on it.
    pub const SYNC: u16 = 0x080;
    /// Emergency, + node id.
    pub const EMCY: u16 = 0x080;
    /// First transmit PDO (drive → controller), + node id.
    pub const TPDO1: u16 = 0x180;
    /// First receive PDO (controller → drive), + node id.
    pub const RPDO1: u16 = 0x200;
    /// Heartbeat (NMT error control), + node id.
    pub const HEARTBEAT: u16 = 0x700;
}

pub mod emcy;
pub mod nmt;
pub mod sdo;

pub use nmt::{NmtCommand, NmtState};

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::fixed(id, data)
}

/// NMT command to one node (or all: node 0).
#[must_use]
pub fn nmt(command: NmtCommand, node: u8) -> CanFrame {
    frame(cob::NMT, &[command as u8, node])
}

/// SYNC, without counter.
#[must_use]
pub fn sync() -> CanFrame {
    frame(cob::SYNC, &[])
}

/// Heartbeat of `node` in `state`.
#[must_use]
pub fn heartbeat(node: u8, state: NmtState) -> CanFrame {
    frame(cob::HEARTBEAT + u16::from(node), &[state as u8])
}

/// RPDO1 to a drive: controlword (0x6040) and target velocity (0x60FF). The velocity
/// is a [`Setpoint`], so it has passed the choke point of [`crate::units`].
#[must_use]
pub fn rpdo1(drive: Drive, controlword: u16, target_velocity: Setpoint) -> CanFrame {
    let [c0, c1] = controlword.to_le_bytes();
    let [v0, v1, v2, v3] = target_velocity.units().to_le_bytes();
    frame(
        cob::RPDO1 + u16::from(drive.node()),
        &[c0, c1, v0, v1, v2, v3],
    )
}

/// TPDO1 of a drive: statusword (0x6041) and velocity actual value (0x606C).
/// The controller only receives these; the encoder serves tests and the virtual bus.
#[must_use]
pub fn tpdo1(drive: Drive, statusword: u16, velocity: i32) -> CanFrame {
    let [s0, s1] = statusword.to_le_bytes();
    let [v0, v1, v2, v3] = velocity.to_le_bytes();
    frame(
        cob::TPDO1 + u16::from(drive.node()),
        &[s0, s1, v0, v1, v2, v3],
    )
}

/// EMCY of `node`: error code, error register (1001h) and 5 manufacturer bytes.
#[must_use]
pub fn emcy(node: u8, code: u16, register: u8, info: [u8; 5]) -> CanFrame {
    let [e0, e1] = code.to_le_bytes();
    let [i0, i1, i2, i3, i4] = info;
    frame(
        cob::EMCY + u16::from(node),
        &[e0, e1, register, i0, i1, i2, i3, i4],
    )
}

/// What the controller understands off the bus.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Incoming {
    /// A heartbeat.
    Heartbeat {
        /// Sender.
        node: u8,
        /// Its NMT state.
        state: NmtState,
    },
    /// A drive's TPDO1.
    Status {
        /// Which drive.
        drive: Drive,
        /// Statusword (0x6041).
        statusword: u16,
        /// Velocity actual value (0x606C), µm/s.
        velocity: i32,
    },
    /// A request from the supervisor.
    Command(Request),
    /// A drive's emergency message.
    Emergency {
        /// Which drive.
        drive: Drive,
        /// CiA 301 error code (0 = error reset / no error).
        code: u16,
        /// Error register.
        register: u8,
    },
}

/// Why a received frame was not understood. Such frames are ignored and counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DecodeError {
    /// Not a frame this controller consumes.
    UnknownId(u16),
    /// A known id with the wrong number of bytes.
    WrongLength {
        /// COB-ID.
        id: u16,
        /// Bytes expected.
        expected: u8,
        /// Bytes received.
        got: u8,
    },
    /// A heartbeat with a state byte CiA 301 does not define.
    BadState(u8),
    /// A malformed command frame.
    Command(CommandError),
}

/// Decodes a received frame.
pub fn decode(frame: &CanFrame) -> Result<Incoming, DecodeError> {
    let id = frame.id();
    let data = frame.data();
    let node = (id & 0x7F) as u8;
    let length = |expected: u8| {
        if data.len() == usize::from(expected) {
            Ok(())
        } else {
            Err(DecodeError::WrongLength {
                id,
                expected,
                got: data.len() as u8,
            })
        }
    };
    if id == commands::COMMAND_ID {
        return commands::decode_request(data)
            .map(Incoming::Command)
            .map_err(DecodeError::Command);
    }
    match (id & 0x780, Drive::from_node(node)) {
        (cob::HEARTBEAT, _) if node != 0 => {
            length(1)?;
            let b = data.first().copied().unwrap_or(0xFF);
            NmtState::from_byte(b)
                .map(|state| Incoming::Heartbeat { node, state })
                .ok_or(DecodeError::BadState(b))
        }
        (cob::TPDO1, Some(drive)) => {
            length(6)?;
            match *data {
                [s0, s1, v0, v1, v2, v3] => Ok(Incoming::Status {
                    drive,
                    statusword: u16::from_le_bytes([s0, s1]),
                    velocity: i32::from_le_bytes([v0, v1, v2, v3]),
                }),
                _ => Err(DecodeError::WrongLength {
                    id,
                    expected: 6,
                    got: data.len() as u8,
                }),
            }
        }
        (cob::EMCY, Some(drive)) => {
            length(8)?;
            match *data {
                [e0, e1, register, ..] => Ok(Incoming::Emergency {
                    drive,
                    code: u16::from_le_bytes([e0, e1]),
                    register,
                }),
                _ => Err(DecodeError::WrongLength {
                    id,
                    expected: 8,
                    got: data.len() as u8,
                }),
            }
        }
        _ => Err(DecodeError::UnknownId(id)),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn received_frames_round_trip() {
        for (velocity, statusword) in [(0, 0x0237), (-1_234_567, 0x0008), (i32::MAX, 0xFFFF)] {
            let f = tpdo1(Drive::Winch, statusword, velocity);
            assert_eq!(
                decode(&f),
                Ok(Incoming::Status {
                    drive: Drive::Winch,
                    statusword,
                    velocity
                })
            );
        }
        assert_eq!(
            decode(&heartbeat(1, NmtState::Operational)),
            Ok(Incoming::Heartbeat {
                node: 1,
                state: NmtState::Operational
            })
        );
        let e = emcy(2, 0x8611, 0x81, [0; 5]);
        assert_eq!(
            decode(&e),
            Ok(Incoming::Emergency {
                drive: Drive::Winch,
                code: 0x8611,
                register: 0x81
            })
        );
    }

    #[test]
    fn malformed_frames_are_refused() {
        assert_eq!(
            decode(&CanFrame::new(0x181, &[1, 2, 3]).unwrap()),
            Err(DecodeError::WrongLength {
                id: 0x181,
                expected: 6,
                got: 3
            })
        );
        assert_eq!(
            decode(&CanFrame::new(0x701, &[0x42]).unwrap()),
            Err(DecodeError::BadState(0x42))
        );
        assert_eq!(
            decode(&CanFrame::new(0x185, &[0; 6]).unwrap()),
            Err(DecodeError::UnknownId(0x185))
        );
        assert_eq!(
            decode(&CanFrame::new(0x123, &[]).unwrap()),
            Err(DecodeError::UnknownId(0x123))
        );
        assert!(CanFrame::new(0x800, &[]).is_err());
        assert!(CanFrame::new(1, &[0; 9]).is_err());
    }
}
