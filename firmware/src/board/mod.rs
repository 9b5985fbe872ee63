//! One thin shell per board, selected by a cargo feature. Everything else is portable.

use controller::CanFrame;

/// What the 100 Hz task needs from a CAN controller: the board's own small trait,
/// because the STM32H743's `fdcan` driver has no embedded-can implementation and the
/// QEMU board has no CAN controller at all (its port is the virtual bus).
pub trait CanPort {
    /// Why a frame will never leave.
    type TxError: defmt::Format;

    /// Queues a frame of the cycle at `now_ms` behind those queued before it
    /// (`controller::transmit`: frames leave in this order). `Err`: this frame is
    /// refused and lost — report it.
    fn transmit(&mut self, now_ms: u64, frame: &CanFrame) -> Result<(), Self::TxError>;

    /// The next frame that was queued but will never leave, oldest first, with why:
    /// refused by the bus, or of a cycle before `now_ms` and still waiting (it is taken
    /// back rather than sent stale). Each lost frame is returned once — report it.
    fn lost(&mut self, now_ms: u64) -> Option<(CanFrame, Self::TxError)>;

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
