//! Operator mode's command interface (issue 28): the master switch's frame and the
//! dead-man that watches it.
//!
//! * [`frame`] — the speed-demand RPDO3 (0x410): alive counter, flags, one signed demand
//!   per direction of the load;
//! * [`deadman`] — when the stick may move the crane: the deadline, the frozen counter,
//!   the enable flag and the zero-position interlock.

pub mod deadman;
pub mod frame;

pub use deadman::{Deadman, Loss, State, CENTRED_FRAMES, MAX_DEADLINE_MS};
pub use frame::{
    decode_operator, operator_frame, operator_id, Flags, OperatorError, OperatorFrame, FULL_SCALE,
    MICRO_SPEED, OPERATOR_ID,
};
