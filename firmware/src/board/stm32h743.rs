//! The drive controller: STM32H743 (Cortex-M7 at 400 MHz, double-precision FPU).
//!
//! * CAN: FDCAN1 on PD0 (RX) / PD1 (TX), classic CAN at 1 Mbit/s (kernel clock 80 MHz
//!   from PLL1Q, prescaler 2, 40 tq per bit: 1 + 31 + 8, sample point 80 %), all
//!   standard frames into RX FIFO 0. The `fdcan` driver has no embedded-can
//!   implementation, so it sits behind the board's own `transmit`/`receive`.
//! * Bus-off: the FDCAN stops (CCCR.INIT) and is restarted at the next cycle; the
//!   controller rejoins after the 128 × 11 recessive bits ISO 11898-1 requires, which
//!   the FDCAN waits for itself. Meanwhile every transmission fails, and the controller
//!   halts after three cycles without set points (docs/COMMANDS.md).
//! * Watchdog: IWDG, 100 ms, fed only by the 100 Hz task after a completed cycle; the
//!   reset cause (RCC_RSR) is logged at boot.
//! * Cost: DWT CYCCNT, in core cycles (the QEMU board counts instructions instead).
//! * Logging: defmt over RTT (probe-rs).

use core::num::{NonZeroU16, NonZeroU8};

use controller::CanFrame;
use fdcan::config::NominalBitTiming;
use fdcan::filter::{StandardFilter, StandardFilterSlot};
use fdcan::frame::{FrameFormat, TxFrameHeader};
use fdcan::id::{Id, StandardId};
use fdcan::{FdCan, NormalOperationMode, ReceiveOverrun};
use stm32h7xx_hal::can::Can;
use stm32h7xx_hal::independent_watchdog::IndependentWatchdog;
use stm32h7xx_hal::pac::FDCAN1;
use stm32h7xx_hal::prelude::*;
use stm32h7xx_hal::rcc::rec;

pub use stm32h7xx_hal::pac;

/// Core clock, Hz.
pub const SYSCLK_HZ: u32 = 400_000_000;

/// The drive controller board.
pub struct Board {
    /// `None` only for the instant of a bus-off restart.
    can: Option<FdCan<Can<FDCAN1>, NormalOperationMode>>,
    /// Bus-off restarts since boot.
    pub bus_off_restarts: u32,
    watchdog: IndependentWatchdog,
    /// Received frames lost to a full RX FIFO (reported, never silently dropped).
    pub rx_overruns: u32,
}

/// Why a frame was not handed to the CAN controller.
#[derive(Debug, Clone, Copy, defmt::Format)]
pub enum TxError {
    /// All transmit buffers are busy (bus-off or a congested bus).
    QueueFull,
    /// A pending frame of lower priority was displaced to make room (that frame is
    /// lost; it is reported as this one, which errs on the side of a failure).
    Displaced,
    /// The FDCAN is off the bus (bus-off), waiting for its restart.
    BusOff,
}

impl Board {
    /// Clocks, FDCAN1 at 1 Mbit/s, the cycle counter and the watchdog.
    pub fn init(
        dp: pac::Peripherals,
        dcb: &mut cortex_m::peripheral::DCB,
        dwt: &mut cortex_m::peripheral::DWT,
    ) -> Self {
        let pwrcfg = dp.PWR.constrain().freeze();
        let mut rcc = dp.RCC.constrain();
        // Read and cleared once: a watchdog reset here means the firmware hung.
        let reason = rcc.get_reset_reason();
        defmt::info!("reset cause: {}", defmt::Display2Format(&reason));
        let ccdr = rcc
            .sys_ck(SYSCLK_HZ.Hz())
            .pll1_q_ck(80.MHz())
            .freeze(pwrcfg, &dp.SYSCFG);
        let prec = ccdr
            .peripheral
            .FDCAN
            .kernel_clk_mux(rec::FdcanClkSel::Pll1Q);
        let gpiod = dp.GPIOD.split(ccdr.peripheral.GPIOD);
        let rx = gpiod.pd0.into_alternate();
        let tx = gpiod.pd1.into_alternate();
        let mut can = dp.FDCAN1.fdcan(tx, rx, prec);
        can.set_protocol_exception_handling(false);
        can.set_nominal_bit_timing(BIT_TIMING);
        can.set_standard_filter(
            StandardFilterSlot::_0,
            StandardFilter::accept_all_into_fifo0(),
        );
        let can = can.into_normal();

        dcb.enable_trace();
        dwt.enable_cycle_counter();

        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        watchdog.start(100.millis());
        Self {
            can: Some(can),
            bus_off_restarts: 0,
            watchdog,
            rx_overruns: 0,
        }
    }

    /// Core clock cycles (DWT CYCCNT), widened.
    pub fn instructions(&self) -> u64 {
        u64::from(cortex_m::peripheral::DWT::cycle_count())
    }

    /// Feeds the IWDG: only the 100 Hz task calls this, after a completed cycle.
    pub fn feed_watchdog(&mut self) {
        self.watchdog.feed();
    }

    /// Stack painting is measured under QEMU; on the board the linker guards the stack.
    pub fn stack_high_water(&self) -> u32 {
        0
    }
}

impl super::CanPort for Board {
    type TxError = TxError;

    /// Next received frame, if any (extended and remote frames are not CANopen's and are skipped).
    fn receive(&mut self, _now_ms: u64) -> Option<CanFrame> {
        let mut buffer = [0u8; 8];
        let can = self.can.as_mut()?;
        loop {
            let info = match can.receive0(&mut buffer) {
                Ok(ReceiveOverrun::NoOverrun(info)) => info,
                Ok(ReceiveOverrun::Overrun(info)) => {
                    self.rx_overruns = self.rx_overruns.wrapping_add(1);
                    info
                }
                Err(_) => return None,
            };
            if let (Id::Standard(id), false) = (info.id, info.rtr) {
                let len = usize::from(info.len.min(8));
                if let Ok(frame) = CanFrame::new(id.as_raw(), buffer.get(..len).unwrap_or(&[])) {
                    return Some(frame);
                }
            }
        }
    }

    /// Hands a frame to the CAN controller.
    fn transmit(&mut self, _now_ms: u64, frame: &CanFrame) -> Result<(), TxError> {
        let Some(can) = self.can.as_mut() else {
            return Err(TxError::BusOff);
        };
        if can.get_protocol_status().bus_off_status {
            return Err(TxError::BusOff);
        }
        let Some(id) = StandardId::new(frame.id()) else {
            return Err(TxError::QueueFull);
        };
        let header = TxFrameHeader {
            len: frame.data().len() as u8,
            frame_format: FrameFormat::Standard,
            id: id.into(),
            bit_rate_switching: false,
            marker: None,
        };
        match can.transmit(header, frame.data()) {
            Ok(None) => Ok(()),
            Ok(Some(())) => Err(TxError::Displaced),
            Err(_) => Err(TxError::QueueFull),
        }
    }

    /// Restarts the FDCAN after a bus-off: leaving the initialisation state starts the
    /// recovery sequence (RM0433, FDCAN bus-off recovery).
    fn service(&mut self) {
        let off = self
            .can
            .as_ref()
            .is_some_and(|c| c.get_protocol_status().bus_off_status);
        if off {
            if let Some(can) = self.can.take() {
                self.can = Some(can.into_config_mode().into_normal());
                self.bus_off_restarts = self.bus_off_restarts.wrapping_add(1);
                defmt::warn!("CAN bus-off: restart {=u32}", self.bus_off_restarts);
            }
        }
    }
}

/// 1 Mbit/s from the 80 MHz kernel clock.
const BIT_TIMING: NominalBitTiming = NominalBitTiming {
    prescaler: match NonZeroU16::new(2) {
        Some(v) => v,
        None => NonZeroU16::MIN,
    },
    seg1: match NonZeroU8::new(31) {
        Some(v) => v,
        None => NonZeroU8::MIN,
    },
    seg2: match NonZeroU8::new(8) {
        Some(v) => v,
        None => NonZeroU8::MIN,
    },
    sync_jump_width: match NonZeroU8::new(8) {
        Some(v) => v,
        None => NonZeroU8::MIN,
    },
};

/// On the board the control loop never ends; `finish` is reached only when the
/// firmware cannot start (a scene it refuses). It stops transmitting — the drives
/// lose the controller's heartbeat and brake on their own — and waits for the watchdog.
pub fn finish(_success: bool) -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

/// Idle: sleep until the next interrupt.
pub fn idle() {
    cortex_m::asm::wfi();
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    // Stop transmitting: the drives see the controller's heartbeat stop and brake on
    // their own; the watchdog resets the controller.
    loop {
        cortex_m::asm::wfi();
    }
}
