//! The drive controller: STM32H743 (Cortex-M7 at 400 MHz, double-precision FPU).
//!
//! * CAN: FDCAN1 on PD0 (RX) / PD1 (TX), classic CAN at 1 Mbit/s (kernel clock 80 MHz
//!   from PLL1Q, prescaler 2, 40 tq per bit: 1 + 31 + 8, sample point 80 %), all
//!   standard frames into RX FIFO 0. The message RAM layout of the HAL gives each
//!   FIFO only 3 elements — fewer than the frames of one 10 ms cycle at a heartbeat
//!   (two TPDOs, two heartbeats) — so reception is interrupt-driven: [`CanRx::drain`]
//!   (the FDCAN1_IT0 task, above the 100 Hz task) moves every frame into a 64-frame
//!   queue that the 100 Hz task empties. The `fdcan` driver has no embedded-can
//!   implementation, so it sits behind the board's own `transmit`/`receive`.
//! * Bus-off: the FDCAN stops (CCCR.INIT); the interrupt restarts it at once and it
//!   rejoins after the 128 × 11 recessive bits ISO 11898-1 requires, which the FDCAN
//!   waits for itself. Meanwhile every transmission fails, and the controller halts
//!   after three cycles without set points (docs/COMMANDS.md).
//! * Watchdog: IWDG, 100 ms, fed only by the 100 Hz task after a completed cycle; the
//!   reset cause (RCC_RSR) is logged at boot.
//! * Cost: DWT CYCCNT, in core cycles (the QEMU board counts instructions instead).
//! * Logging: defmt over RTT (probe-rs).
//!
//! This module holds the board's one `unsafe`: the restart after bus-off, a register
//! write the `fdcan` driver offers only together with reconfiguration.
#![allow(unsafe_code)]

use core::num::{NonZeroU16, NonZeroU8};
use core::sync::atomic::{AtomicU32, Ordering};

use controller::CanFrame;
use fdcan::config::NominalBitTiming;
use fdcan::filter::{StandardFilter, StandardFilterSlot};
use fdcan::frame::{FrameFormat, TxFrameHeader};
use fdcan::id::{Id, StandardId};
use fdcan::interrupt::{Interrupt, InterruptLine};
use fdcan::{FdCanControl, Fifo0, Fifo1, NormalOperationMode, ReceiveOverrun, Rx, Tx};
use heapless::spsc::{Consumer, Producer, Queue};
use stm32h7xx_hal::can::Can;
use stm32h7xx_hal::independent_watchdog::IndependentWatchdog;
use stm32h7xx_hal::pac::FDCAN1;
use stm32h7xx_hal::prelude::*;
use stm32h7xx_hal::rcc::rec;

pub use stm32h7xx_hal::pac;

/// Core clock, Hz.
pub const SYSCLK_HZ: u32 = 400_000_000;

/// Frames the receive queue holds between two cycles (a storm of garbage included).
pub const RX_QUEUE: usize = 64;

/// The queue between the receive interrupt and the 100 Hz task.
pub type RxQueue = Queue<CanFrame, RX_QUEUE>;

type Fdcan1 = Can<FDCAN1>;

/// Frames lost: the FDCAN's FIFO overran, or the queue was full (reported, never
/// silently dropped).
static RX_LOST: AtomicU32 = AtomicU32::new(0);
/// Bus-off restarts since boot.
static BUS_OFF_RESTARTS: AtomicU32 = AtomicU32::new(0);

/// The drive controller board, as the 100 Hz task sees it.
pub struct Board {
    tx: Tx<Fdcan1, NormalOperationMode>,
    rx: Consumer<'static, CanFrame>,
    watchdog: IndependentWatchdog,
}

/// The receive side, owned by the FDCAN1_IT0 interrupt.
pub struct CanRx {
    control: FdCanControl<Fdcan1, NormalOperationMode>,
    fifo0: Rx<Fdcan1, NormalOperationMode, Fifo0>,
    fifo1: Rx<Fdcan1, NormalOperationMode, Fifo1>,
    queue: Producer<'static, CanFrame>,
}

/// Why a frame was not handed to the CAN controller.
#[derive(Debug, Clone, Copy, defmt::Format)]
pub enum TxError {
    /// All transmit buffers are busy (bus-off or a congested bus).
    QueueFull,
    /// A pending frame of lower priority was displaced to make room (that frame is
    /// lost; it is reported as this one, which errs on the side of a failure).
    Displaced,
}

impl Board {
    /// Clocks, FDCAN1 at 1 Mbit/s with its receive interrupt, the cycle counter and
    /// the watchdog; the receive side goes to the interrupt task.
    pub fn init(
        dp: pac::Peripherals,
        dcb: &mut cortex_m::peripheral::DCB,
        dwt: &mut cortex_m::peripheral::DWT,
    ) -> (Self, CanRx, bool) {
        let pwrcfg = dp.PWR.constrain().freeze();
        let mut rcc = dp.RCC.constrain();
        // Read and cleared once: a watchdog reset here means the firmware hung.
        let reason = rcc.get_reset_reason();
        defmt::info!("reset cause: {}", defmt::Display2Format(&reason));
        let restarted = matches!(
            reason,
            stm32h7xx_hal::rcc::ResetReason::IndependentWatchdogReset
                | stm32h7xx_hal::rcc::ResetReason::GenericWatchdogReset
        );
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
        for interrupt in [
            Interrupt::RxFifo0NewMsg,
            Interrupt::RxFifo1NewMsg,
            Interrupt::BusOff,
        ] {
            can.enable_interrupt(interrupt);
        }
        can.enable_interrupt_line(InterruptLine::_0, true);
        let (control, tx, fifo0, fifo1) = can.into_normal().split();
        // `init` runs once: the queue is created here and lives for the program.
        let queue = cortex_m::singleton!(: RxQueue = RxQueue::new());
        let Some(queue) = queue else {
            defmt::error!("receive queue taken twice");
            finish(false)
        };
        let (producer, consumer) = queue.split();

        dcb.enable_trace();
        dwt.enable_cycle_counter();

        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        watchdog.start(100.millis());
        (
            Self {
                tx,
                rx: consumer,
                watchdog,
            },
            CanRx {
                control,
                fifo0,
                fifo1,
                queue: producer,
            },
            restarted,
        )
    }

    /// The free-running cost counter: core clock cycles (DWT CYCCNT, wraps every
    /// 10.7 s at 400 MHz).
    pub fn counter(&self) -> u32 {
        cortex_m::peripheral::DWT::cycle_count()
    }

    /// Core cycles between two readings of [`Board::counter`], across a wrap.
    pub fn cost(&self, from: u32, to: u32) -> u64 {
        u64::from(to.wrapping_sub(from))
    }

    /// Feeds the IWDG: only the 100 Hz task calls this, after a completed cycle.
    pub fn feed_watchdog(&mut self) {
        self.watchdog.feed();
    }

    /// Stack painting is measured under QEMU; on the board the linker guards the stack.
    pub fn stack_high_water(&self) -> u32 {
        0
    }

    /// Frames lost on reception and bus-off restarts since boot.
    pub fn link_losses(&self) -> (u32, u32) {
        (
            RX_LOST.load(Ordering::Relaxed),
            BUS_OFF_RESTARTS.load(Ordering::Relaxed),
        )
    }
}

impl CanRx {
    /// Moves every received frame into the queue, and restarts the FDCAN after a
    /// bus-off. Runs in the FDCAN1_IT0 interrupt.
    pub fn drain(&mut self) {
        // A classic CAN frame has at most 8 bytes, but the driver copies as many bytes
        // as the frame's DLC says (up to 64): the buffer is a CAN FD frame's.
        let mut buffer = [0u8; 64];
        loop {
            let received = match self.fifo0.receive(&mut buffer) {
                Ok(r) => r,
                Err(_) => match self.fifo1.receive(&mut buffer) {
                    Ok(r) => r,
                    Err(_) => break,
                },
            };
            let info = match received {
                ReceiveOverrun::NoOverrun(info) => info,
                ReceiveOverrun::Overrun(info) => {
                    RX_LOST.fetch_add(1, Ordering::Relaxed);
                    info
                }
            };
            // Extended and remote frames are not CANopen's; a length above 8 is refused
            // by CanFrame (and counted by the controller as an ignored frame would be,
            // were it delivered: here it never is).
            if let (Id::Standard(id), false) = (info.id, info.rtr) {
                let len = usize::from(info.len).min(buffer.len());
                if let Ok(frame) = CanFrame::new(id.as_raw(), buffer.get(..len).unwrap_or(&[])) {
                    if self.queue.enqueue(frame).is_err() {
                        RX_LOST.fetch_add(1, Ordering::Relaxed);
                    }
                }
            }
        }
        self.control.clear_interrupt(Interrupt::RxFifo0NewMsg);
        self.control.clear_interrupt(Interrupt::RxFifo1NewMsg);
        if self.control.has_interrupt(Interrupt::BusOff) {
            self.control.clear_interrupt(Interrupt::BusOff);
            restart_after_bus_off();
            BUS_OFF_RESTARTS.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// Leaves the initialisation state the FDCAN entered at bus-off: the recovery sequence
/// starts (RM0433, FDCAN "Bus-off recovery").
fn restart_after_bus_off() {
    // SAFETY: FDCAN1's CCCR is written by no one else after `init` (the driver's halves
    // do not touch it in normal operation); clearing INIT is the documented way out of
    // bus-off and changes no configuration.
    let can = unsafe { &*FDCAN1::ptr() };
    can.cccr.modify(|_, w| w.init().clear_bit());
}

impl super::CanPort for Board {
    type TxError = TxError;

    /// Next received frame, if any, from the interrupt's queue.
    fn receive(&mut self, _now_ms: u64) -> Option<CanFrame> {
        self.rx.dequeue()
    }

    /// Hands a frame to the CAN controller.
    fn transmit(&mut self, _now_ms: u64, frame: &CanFrame) -> Result<(), TxError> {
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
        match self.tx.transmit(header, frame.data()) {
            Ok(None) => Ok(()),
            Ok(Some(())) => Err(TxError::Displaced),
            Err(_) => Err(TxError::QueueFull),
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
