//! Operator mode's command interface (issue 28): the master switch's frame and the
//! dead-man that watches it.
//!
//! * [`frame`] — the speed-demand RPDO3 (0x410): alive counter, flags, one signed demand
//!   per direction of the load;
//! * [`deadman`] — when the stick may move the crane: the deadline, the frozen counter,
//!   the enable flag and the zero-position interlock;
//! * [`path`] — the inverse model's desired output: the plan, or the operator's generator.

pub mod deadman;
pub mod frame;
pub mod path;

/// The dead-man's deadline, ms: three frames of a master switch sending every 30 ms. The
/// loss is latched in the controller's cycle 90 ms after the one that read the last
/// frame, so less than 100 ms after that frame arrived (it is read at the start of the
/// next cycle): the bound.
pub const DEADLINE_MS: u32 = 90;

/// The share of the stick's travel speed left while the state feedback does not read the
/// swing (a lost, frozen or implausible inclinometer: EMCY 0xFF20): the load's residual
/// swing on a crane that is not its model grows with its speed, and nothing corrects it
/// any more, so manual mode goes on at half the speed. The hoist is not capped (it makes
/// no swing).
pub const UNOBSERVED_SPEED_SHARE: f64 = 0.5;

/// The status frame's mode byte while manual mode runs (the controller is *ready*,
/// the operator's generator drives the model): additive to 0–4.
pub const MANUAL_MODE_CODE: u8 = 5;

/// Why an operator's request for manual mode was refused: announced once per request
/// (and again if the reason changes) by the warning EMCY 0xFF21, its detail byte the
/// code (docs/COMMANDS.md, "Manual mode"). A request during an automatic move is no
/// refusal: it waits for the move's rest, or for the stick (the hand-over).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Refusal {
    /// The scene's inverse model follows plans only: no `[operator]` section.
    Unsupported = 1,
    /// Not ready: a drive not enabled, the controller stopping, halted or not
    /// operational.
    NotReady = 2,
    /// The generator refused its settings or the load's state (a position outside its
    /// ranges).
    Generator = 3,
}

impl Refusal {
    /// The EMCY's detail byte.
    #[must_use]
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The refusal of a failed entry.
    #[must_use]
    pub const fn of(e: path::ManualError) -> Self {
        match e {
            path::ManualError::Unsupported => Self::Unsupported,
            // An entry is tried at rest only: "moving" is the plan that cannot rest.
            path::ManualError::Moving => Self::NotReady,
            path::ManualError::Generator(_) => Self::Generator,
        }
    }
}

pub use deadman::{Deadman, Loss, State, CENTRED_FRAMES, MAX_DEADLINE_MS};
pub use frame::{
    decode_operator, operator_frame, operator_id, Flags, OperatorError, OperatorFrame, FULL_SCALE,
    MICRO_SPEED, OPERATOR_ID,
};
