//! CANopen (CiA 301) as the drives and a PLC expect it: the controller is NMT manager
//! (or, under a PLC, a plain node) of CiA 402 drives in cyclic synchronous velocity
//! mode. The layout is documented for CAN tools in `can/crane.dbc` and, for
//! configuration tools, the controller's own objects in `can/crane-controller.eds`.
//!
//! | frame | COB-ID | bytes |
//! |---|---|---|
//! | NMT | 0x000 | command, node (0 = all) |
//! | SYNC | 0x080 | — |
//! | EMCY of node n | 0x080 + n | error code (u16), error register (u8), 5 bytes manufacturer |
//! | TPDO1, TPDO2 of node n | 0x180 + n, 0x280 + n | its device profile's |
//! | RPDO1 to node n | 0x200 + n | its device profile's |
//! | RPDO2 to node n | 0x300 + n | the controller's: the 3D move frame |
//! | RPDO3 to node n | 0x400 + n | the controller's: the operator's speed demand |
//! | SDO response of node n / request to node n | 0x580 + n / 0x600 + n | 8 bytes ([`sdo`]) |
//! | heartbeat of node n | 0x700 + n | NMT state |
//!
//! Frames name nodes, not drives: which node drives which axis is the commissioning
//! table's business, and what a PDO carries is its device profile's ([`crate::cia402::pdo`]
//! for the drives, [`crate::cia410`] for the inclinometer, [`crate::commands`] for the
//! controller's own). All multi-byte values are little endian (CiA 301).

use crate::frame::CanFrame;

/// The controller's node id by default (heartbeat 0x710, EMCY 0x090; the commissioning
/// file may choose another).
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
    /// Second transmit PDO, + node id.
    pub const TPDO2: u16 = 0x280;
    /// First receive PDO (controller → drive), + node id.
    pub const RPDO1: u16 = 0x200;
    /// Second receive PDO, + node id.
    pub const RPDO2: u16 = 0x300;
    /// Third receive PDO, + node id.
    pub const RPDO3: u16 = 0x400;
    /// Heartbeat (NMT error control), + node id.
    pub const HEARTBEAT: u16 = 0x700;
    /// SDO response (server → client), + node id.
    pub const SDO_RESPONSE: u16 = 0x580;
    /// SDO request (client → server), + node id.
    pub const SDO_REQUEST: u16 = 0x600;
    /// The function code's bits of an 11-bit COB-ID (the rest is the node id).
    pub const FUNCTION: u16 = 0x780;

    /// Whether `id` is a COB-ID only node `node` sends as the controller does — its
    /// heartbeat, EMCY, SDO response or first TPDO (the status frame): seen on the bus
    /// from elsewhere, another node has its node id (a CAN controller does not receive
    /// its own frames).
    #[must_use]
    pub fn produced_by(node: u8, id: u16) -> bool {
        id & !FUNCTION == u16::from(node)
            && [HEARTBEAT, EMCY, SDO_RESPONSE, TPDO1].contains(&(id & FUNCTION))
    }
}

pub mod emcy;
pub mod nmt;
pub mod od;
pub mod sdo;

pub use nmt::{NmtCommand, NmtState};

fn frame(id: u16, data: &[u8]) -> CanFrame {
    CanFrame::fixed(id, data)
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
    /// A SYNC (with or without its counter): the controller produces it, so another
    /// node's is a second producer.
    Sync,
    /// An NMT command for `node` (0: all nodes).
    Nmt {
        /// The command.
        command: NmtCommand,
        /// Addressee.
        node: u8,
    },
    /// A heartbeat (or, with state *boot-up*, a boot-up message).
    Heartbeat {
        /// Sender.
        node: u8,
        /// Its NMT state.
        state: NmtState,
    },
    /// A TPDO1 or TPDO2 of `node` (its contents are its device profile's).
    Tpdo {
        /// Sender.
        node: u8,
        /// The frame as received (its length is the profile's to check).
        frame: CanFrame,
    },
    /// An SDO response from `node` (to the controller's client).
    SdoResponse {
        /// Server.
        node: u8,
        /// The 8 data bytes.
        data: [u8; 8],
    },
    /// An SDO request to `node` (the controller's server, if it is its node).
    SdoRequest {
        /// Server addressed.
        node: u8,
        /// The 8 data bytes.
        data: [u8; 8],
    },
    /// An RPDO1 for `node` (the supervisor's command frame, if it is the controller's).
    Rpdo1 {
        /// Addressee.
        node: u8,
        /// The frame as received (its length is the receiver's to check).
        frame: CanFrame,
    },
    /// An RPDO2 for `node` (the supervisor's 3D move frame, if it is the controller's).
    Rpdo2 {
        /// Addressee.
        node: u8,
        /// The frame as received (its length is the receiver's to check).
        frame: CanFrame,
    },
    /// An RPDO3 for `node` (the operator's speed demand, if it is the controller's).
    Rpdo3 {
        /// Addressee.
        node: u8,
        /// The frame as received (its length is the receiver's to check).
        frame: CanFrame,
    },
    /// An emergency message.
    Emergency {
        /// Sender.
        node: u8,
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
    /// An NMT command CiA 301 does not define.
    BadNmtCommand(u8),
}

/// Decodes a received frame.
pub fn decode(frame: &CanFrame) -> Result<Incoming, DecodeError> {
    let id = frame.id();
    let data = frame.data();
    let node = (id & 0x7F) as u8;
    let wrong = |expected: u8| DecodeError::WrongLength {
        id,
        expected,
        got: data.len() as u8,
    };
    if id == cob::NMT {
        let &[command, node] = data else {
            return Err(wrong(2));
        };
        return NmtCommand::from_byte(command)
            .map(|command| Incoming::Nmt { command, node })
            .ok_or(DecodeError::BadNmtCommand(command));
    }
    if id == cob::SYNC {
        // CiA 301: no data, or the 1-byte counter.
        return if data.len() <= 1 {
            Ok(Incoming::Sync)
        } else {
            Err(wrong(1))
        };
    }
    if node == 0 {
        return Err(DecodeError::UnknownId(id));
    }
    let eight = || -> Result<[u8; 8], DecodeError> { data.try_into().map_err(|_| wrong(8)) };
    match id & 0x780 {
        cob::HEARTBEAT => {
            let &[b] = data else {
                return Err(wrong(1));
            };
            NmtState::from_byte(b)
                .map(|state| Incoming::Heartbeat { node, state })
                .ok_or(DecodeError::BadState(b))
        }
        cob::TPDO1 | cob::TPDO2 => Ok(Incoming::Tpdo {
            node,
            frame: *frame,
        }),
        cob::RPDO1 => Ok(Incoming::Rpdo1 {
            node,
            frame: *frame,
        }),
        cob::RPDO2 => Ok(Incoming::Rpdo2 {
            node,
            frame: *frame,
        }),
        cob::RPDO3 => Ok(Incoming::Rpdo3 {
            node,
            frame: *frame,
        }),
        cob::EMCY => match *data {
            [e0, e1, register, ..] if data.len() == 8 => Ok(Incoming::Emergency {
                node,
                code: u16::from_le_bytes([e0, e1]),
                register,
            }),
            _ => Err(wrong(8)),
        },
        sdo::RESPONSE => Ok(Incoming::SdoResponse {
            node,
            data: eight()?,
        }),
        sdo::REQUEST => Ok(Incoming::SdoRequest {
            node,
            data: eight()?,
        }),
        _ => Err(DecodeError::UnknownId(id)),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn received_frames_round_trip() {
        let pdo = CanFrame::new(0x282, &[1, 2, 3]).unwrap();
        assert_eq!(
            decode(&pdo),
            Ok(Incoming::Tpdo {
                node: 2,
                frame: pdo
            })
        );
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
                node: 2,
                code: 0x8611,
                register: 0x81
            })
        );
        assert_eq!(
            decode(&nmt::command(NmtCommand::Start, 0x10)),
            Ok(Incoming::Nmt {
                command: NmtCommand::Start,
                node: 0x10
            })
        );
        let d = [0x43, 0, 0x10, 0, 0x92, 1, 2, 0];
        assert_eq!(
            decode(&CanFrame::new(0x581, &d).unwrap()),
            Ok(Incoming::SdoResponse { node: 1, data: d })
        );
        assert_eq!(
            decode(&CanFrame::new(0x610, &d).unwrap()),
            Ok(Incoming::SdoRequest {
                node: 0x10,
                data: d
            })
        );
    }

    #[test]
    fn malformed_frames_are_refused() {
        assert_eq!(
            decode(&CanFrame::new(0x701, &[0x42]).unwrap()),
            Err(DecodeError::BadState(0x42))
        );
        assert_eq!(
            decode(&CanFrame::new(0x000, &[0x42, 1]).unwrap()),
            Err(DecodeError::BadNmtCommand(0x42))
        );
        assert_eq!(
            decode(&CanFrame::new(0x581, &[0x60]).unwrap()),
            Err(DecodeError::WrongLength {
                id: 0x581,
                expected: 8,
                got: 1
            })
        );
        assert_eq!(
            decode(&CanFrame::new(0x123, &[]).unwrap()),
            Err(DecodeError::UnknownId(0x123))
        );
        assert_eq!(
            decode(&CanFrame::new(0x180, &[0; 6]).unwrap()),
            Err(DecodeError::UnknownId(0x180))
        );
        assert!(CanFrame::new(0x800, &[]).is_err());
        assert!(CanFrame::new(1, &[0; 9]).is_err());
    }
}
