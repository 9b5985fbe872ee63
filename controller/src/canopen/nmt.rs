//! CiA 301 network management: the commands a manager sends and the states a
//! heartbeat reports.

use crate::frame::CanFrame;

/// COB-ID of NMT commands.
pub const COB_ID: u16 = 0x000;

/// NMT command to one node (or to all: node 0).
#[must_use]
pub fn command(command: NmtCommand, node: u8) -> CanFrame {
    CanFrame::fixed(COB_ID, &[command as u8, node])
}

/// NMT commands (CiA 301).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum NmtCommand {
    /// Enter operational.
    Start = 0x01,
    /// Enter stopped.
    Stop = 0x02,
    /// Enter pre-operational.
    PreOperational = 0x80,
    /// Reset the application.
    ResetNode = 0x81,
    /// Reset communication.
    ResetCommunication = 0x82,
}

impl NmtCommand {
    /// The command a byte names, if CiA 301 defines it.
    #[must_use]
    pub fn from_byte(b: u8) -> Option<Self> {
        [
            Self::Start,
            Self::Stop,
            Self::PreOperational,
            Self::ResetNode,
            Self::ResetCommunication,
        ]
        .into_iter()
        .find(|c| *c as u8 == b)
    }
}

/// NMT states as reported in heartbeats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum NmtState {
    /// Just booted.
    BootUp = 0x00,
    /// Stopped.
    Stopped = 0x04,
    /// Operational: PDOs flow.
    Operational = 0x05,
    /// Pre-operational.
    PreOperational = 0x7F,
}

impl NmtState {
    /// The state a heartbeat byte names, if CiA 301 defines it.
    #[must_use]
    pub fn from_byte(b: u8) -> Option<Self> {
        [
            Self::BootUp,
            Self::Stopped,
            Self::Operational,
            Self::PreOperational,
        ]
        .into_iter()
        .find(|s| *s as u8 == b)
    }
}

/// The communication services CiA 301 lets a node use in an NMT state (CiA 301 7.3.2.2,
/// "NMT states and communication object relation"): NMT and the heartbeat in every
/// state; SDO, SYNC and EMCY in pre-operational and operational; PDOs in operational
/// only.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Services {
    /// PDOs (the drives' RPDOs, the status frame; the command frame is taken).
    pub pdo: bool,
    /// SDO, as client (commissioning) and as server.
    pub sdo: bool,
    /// SYNC production.
    pub sync: bool,
    /// EMCY production.
    pub emcy: bool,
}

impl NmtState {
    /// What a node in this state may send.
    #[must_use]
    pub fn services(self) -> Services {
        let configured = matches!(self, Self::PreOperational | Self::Operational);
        Services {
            pdo: self == Self::Operational,
            sdo: configured,
            sync: configured,
            emcy: configured,
        }
    }
}
