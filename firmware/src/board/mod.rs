//! One thin shell per board, selected by a cargo feature. Everything else is portable.

/// What the 100 Hz task needs from a CAN controller: the portable cycle's trait
/// (`controller::board`), which the host's run on the virtual bus implements too.
pub use controller::board::CanPort;

#[cfg(feature = "qemu")]
mod qemu;
#[cfg(feature = "qemu")]
pub use qemu::*;

#[cfg(feature = "stm32h743")]
mod stm32h743;
#[cfg(feature = "stm32h743")]
pub use stm32h743::*;
