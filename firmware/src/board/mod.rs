//! One thin shell per board, selected by a cargo feature. Everything else is portable.

use controller::CanFrame;

/// What the 100 Hz task needs from a CAN controller: the board's own small trait,
/// because the STM32H743's `fdcan` driver has no embedded-can implementation and the
/// QEMU board has no CAN controller at all (its port is the virtual bus).
pub trait CanPort {
    /// Why a frame could not be handed to the controller.
    type TxError: defmt::Format;

    /// Queues a frame for transmission (`now_ms`: the cycle's time, for logs).
    fn transmit(&mut self, now_ms: u64, frame: &CanFrame) -> Result<(), Self::TxError>;

    /// The next frame received up to `now_ms`, if any.
    fn receive(&mut self, now_ms: u64) -> Option<CanFrame>;
}

#[cfg(feature = "qemu")]
mod qemu;
#[cfg(feature = "qemu")]
pub use qemu::*;

#[cfg(feature = "stm32h743")]
mod stm32h743;
#[cfg(feature = "stm32h743")]
pub use stm32h743::*;
