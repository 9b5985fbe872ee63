//! What can go wrong, as the controller reports it (the status frame's fault byte, the
//! EMCY's error code and manufacturer bytes) and how each is met (`Reaction`):
//! docs/COMMANDS.md.

use solver_core::Error;

use crate::canopen::emcy;
use crate::canopen::NmtState;
use crate::commissioning::CommissioningError;
use crate::drive::Drive;
use crate::setpoint::SetpointError;

/// Why the controller left *ready* (status byte 4, EMCY's first manufacturer byte).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Fault {
    /// The inverse model failed (Newton, singular matrix, non-finite values).
    Solver(Error),
    /// The choke point refused the model's set point.
    Setpoint(SetpointError),
    /// A drive reported a fault (statusword bit 3 or an EMCY classified as a fault).
    DriveFault(Drive),
    /// A drive's heartbeat stopped.
    HeartbeatLost(Drive),
    /// A second deadline miss within the window.
    Deadline,
    /// Set points could not be delivered for several cycles.
    Undeliverable,
    /// The model asked for motion of a drive that is not enabled.
    DriveNotReady(Drive),
    /// The controller was restarted by its watchdog: the 100 Hz task had stopped.
    Watchdog,
    /// A drive that should be operational reported boot-up, pre-operational or stopped
    /// during a move (it rebooted or was switched by someone else).
    DriveLeftOperational(Drive, NmtState),
    /// A started drive's TPDOs stopped arriving.
    TpdoTimeout(Drive),
    /// A drive reports another mode of operation than the commissioned one, or does
    /// not follow its set points.
    DriveMode(Drive),
    /// Commissioning a drive failed.
    Commissioning(Drive, CommissioningError),
    /// The controller was switched out of *operational* by its NMT master during a move.
    NotOperational,
    /// The supervisor's heartbeat stopped during a move (0x1016 of the controller).
    SupervisorLost,
    /// A drive reports a position or velocity it cannot have: never the basis of a
    /// restart.
    Implausible(Drive, Implausibility),
    /// Another node sends with the controller's own node id.
    DuplicateNodeId,
    /// Another node produces what the controller produces: a SYNC, or a drive's set
    /// points (a second master).
    ForeignProducer(Foreign),
    /// A drive at rest and commanded to stand still moved out of its standstill window
    /// (a slipping brake, a creeping axis, someone else's set point).
    Standstill(Drive),
    /// A drive commanded to move does not do what it was commanded: its position or its
    /// velocity left its following window.
    FollowingError(Drive, FollowingError),
}

/// What another node produced that only the controller may (the EMCY's detail byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Foreign {
    /// A SYNC (0x080) while the controller is the SYNC producer.
    Sync,
    /// A drive's RPDO1 (0x200 + its node), which the controller sends it.
    Rpdo(Drive),
}

/// Which of a moving drive's windows it left (the EMCY's detail byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum FollowingError {
    /// Position actual (0x6064) against where the set points sent put the drive.
    Position = 1,
    /// Velocity actual (0x606C) against the velocity they give it.
    Velocity = 2,
}

/// What is implausible about what a drive reports (the EMCY's detail byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Implausibility {
    /// Position actual (0x6064) outside the workspace by more than
    /// [`Config::position_tolerance_m`](crate::config::Config::position_tolerance_m).
    Position = 1,
    /// Velocity actual (0x606C) beyond the drive's limit by more than
    /// [`Config::overspeed`](crate::config::Config::overspeed).
    Velocity = 2,
    /// Position actual jumped further than the drive can move between two TPDOs.
    Jump = 3,
}

/// How a fault is met (docs/COMMANDS.md), mildest first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Reaction {
    /// A controlled stop: the set points ramp the drives to standstill (mode *stopping*).
    Controlled,
    /// A quick stop: the drives brake on their own ramps (mode *quick stop*).
    Quick,
    /// At standstill, the drives held by quick stop until a reset (mode *halted*).
    Halt,
}

/// What is known of one kind of fault, whatever it carries: a row of [`Fault::facts`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Facts {
    /// The fault byte of the status frame and of the EMCY, 1 to [`Fault::MAX_CODE`].
    pub code: u8,
    /// Its name in `can/crane.dbc`'s value tables of the fault byte (status and EMCY),
    /// which is also the variant's.
    pub name: &'static str,
    /// The CiA 301 error code of its EMCY.
    pub emcy_code: u16,
    /// The error register's class bit (0x1001) the EMCY sets beside the generic one:
    /// [`emcy::REGISTER_COMMUNICATION`] or [`emcy::REGISTER_MANUFACTURER`].
    pub register: u8,
    /// How it is met.
    pub reaction: Reaction,
}

impl Fault {
    /// The largest fault byte. `can/crane.dbc` multiplexes the EMCY's manufacturer
    /// bytes on it: 0–15 and 17–21 a fault (15 the feedback warning), 16 the abort code
    /// that follows a commissioning failure (`emcy::ABORT_CODE_FOLLOWS`).
    pub const MAX_CODE: u8 = 21;

    /// This fault's facts: the one table of every kind of fault (docs/COMMANDS.md,
    /// "Faults"), one row each, so that a new kind is one row here.
    #[must_use]
    pub const fn facts(&self) -> Facts {
        use emcy::{REGISTER_COMMUNICATION as COMM, REGISTER_MANUFACTURER as MANUF, *};
        use Fault::*;
        use Reaction::{Controlled, Halt, Quick};
        #[rustfmt::skip]
        let (code, name, emcy_code, register, reaction) = match self {
            //                          code name (can/crane.dbc)     EMCY code          0x1001 reaction
            Solver(_) =>                (1,  "Solver",               INTERNAL_SOFTWARE, MANUF, Controlled),
            Setpoint(_) =>              (2,  "Setpoint",             SETPOINT_REFUSED,  MANUF, Controlled),
            DriveFault(_) =>            (3,  "DriveFault",           DRIVE_FAULT,       MANUF, Quick),
            HeartbeatLost(_) =>         (4,  "HeartbeatLost",        HEARTBEAT,         COMM,  Quick),
            Deadline =>                 (5,  "Deadline",             DEADLINE,          MANUF, Controlled),
            Undeliverable =>            (6,  "Undeliverable",        COMMUNICATION,     COMM,  Halt),
            DriveNotReady(_) =>         (7,  "DriveNotReady",        DRIVE_NOT_READY,   MANUF, Controlled),
            Watchdog =>                 (8,  "Watchdog",             SOFTWARE_RESET,    MANUF, Halt),
            DriveLeftOperational(..) => (9,  "DriveLeftOperational", HEARTBEAT,         COMM,  Quick),
            TpdoTimeout(_) =>           (10, "TpdoTimeout",          RPDO_TIMEOUT,      COMM,  Quick),
            DriveMode(_) =>             (11, "DriveMode",            DRIVE_MODE,        MANUF, Quick),
            Commissioning(..) =>        (12, "Commissioning",        COMMISSIONING,     MANUF, Halt),
            NotOperational =>           (13, "NotOperational",       COMMUNICATION,     COMM,  Controlled),
            SupervisorLost =>           (14, "SupervisorLost",       HEARTBEAT,         COMM,  Controlled),
            // 15 and 16 are taken (emcy::FEEDBACK_OFF, emcy::ABORT_CODE_FOLLOWS).
            Implausible(..) =>          (17, "Implausible",          DRIVE_IMPLAUSIBLE, MANUF, Quick),
            DuplicateNodeId =>          (18, "DuplicateNodeId",      CAN_ID_COLLISION,  COMM,  Controlled),
            ForeignProducer(_) =>       (19, "ForeignProducer",      CAN_ID_COLLISION,  COMM,  Quick),
            Standstill(_) =>            (20, "Standstill",           STANDSTILL,        MANUF, Quick),
            FollowingError(..) =>       (21, "FollowingError",       FOLLOWING_ERROR,   MANUF, Quick),
        };
        Facts {
            code,
            name,
            emcy_code,
            register,
            reaction,
        }
    }

    /// The fault byte of the status frame and of the EMCY, 1 to [`Fault::MAX_CODE`].
    #[must_use]
    pub const fn code(&self) -> u8 {
        self.facts().code
    }

    /// The CiA 301 error code of the EMCY.
    #[must_use]
    pub const fn emcy_code(&self) -> u16 {
        self.facts().emcy_code
    }

    /// The drive concerned, if any.
    #[must_use]
    pub fn drive(&self) -> Option<Drive> {
        match *self {
            Fault::DriveFault(d)
            | Fault::HeartbeatLost(d)
            | Fault::DriveNotReady(d)
            | Fault::DriveLeftOperational(d, _)
            | Fault::TpdoTimeout(d)
            | Fault::DriveMode(d)
            | Fault::Implausible(d, _)
            | Fault::Standstill(d)
            | Fault::FollowingError(d, _)
            | Fault::ForeignProducer(Foreign::Rpdo(d))
            | Fault::Commissioning(d, _) => Some(d),
            Fault::Setpoint(
                SetpointError::NonFinite { drive }
                | SetpointError::OverSpeed { drive, .. }
                | SetpointError::OverAcceleration { drive, .. }
                | SetpointError::NoDrive { drive },
            ) => Some(drive),
            _ => None,
        }
    }

    /// The EMCY's third manufacturer byte: for a refused set point, why (1 non-finite,
    /// 2 over speed, 3 over acceleration, 4 no such drive); for a solver failure, which
    /// (1 Newton did not converge, 2 singular matrix, 3 non-finite value, 4 other); for
    /// a drive that left *operational*, the NMT state it reported; for implausible
    /// feedback what was implausible; for a foreign producer 1 SYNC, 2 a drive's RPDO;
    /// for a following error 1 position, 2 velocity; otherwise 0.
    pub(crate) fn detail(&self) -> u8 {
        match self {
            Fault::Setpoint(SetpointError::NonFinite { .. }) => 1,
            Fault::Setpoint(SetpointError::OverSpeed { .. }) => 2,
            Fault::Setpoint(SetpointError::OverAcceleration { .. }) => 3,
            Fault::Setpoint(SetpointError::NoDrive { .. }) => 4,
            Fault::Solver(Error::NewtonNotConverged { .. }) => 1,
            Fault::Solver(Error::SingularJacobian { .. }) => 2,
            Fault::Solver(Error::NonFinite { .. }) => 3,
            Fault::Solver(_) => 4,
            Fault::DriveLeftOperational(_, state) => *state as u8,
            Fault::Implausible(_, what) => *what as u8,
            Fault::ForeignProducer(Foreign::Sync) => 1,
            Fault::ForeignProducer(Foreign::Rpdo(_)) => 2,
            Fault::FollowingError(_, which) => *which as u8,
            _ => 0,
        }
    }

    /// How it is met (docs/COMMANDS.md).
    #[must_use]
    pub const fn reaction(&self) -> Reaction {
        self.facts().reaction
    }
}
