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

/// The status frame's mode byte while manual mode runs (the controller is *ready*,
/// the operator's generator drives the model): additive to 0–4.
pub const MANUAL_MODE_CODE: u8 = 5;

pub use deadman::{Deadman, Loss, State, CENTRED_FRAMES, MAX_DEADLINE_MS};
pub use frame::{
    decode_operator, operator_frame, operator_id, Flags, OperatorError, OperatorFrame, FULL_SCALE,
    MICRO_SPEED, OPERATOR_ID,
};
