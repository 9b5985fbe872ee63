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
//! * Transmission: the driver sets its 3 transmit buffers to *queue* mode (lowest
//!   identifier first; a full queue displaces a pending frame of higher identifier or
//!   refuses the new one), which reorders and loses a cycle's burst of up to 8 frames
//!   (`controller/tests/transmit.rs`). The board switches them to *FIFO* mode (TXBC.TFQM
//!   = 0, in configuration) and puts `controller::transmit::TxQueue` in front: the 100
//!   Hz task queues the burst and fills the free buffers; the rest is fed from the
//!   FDCAN1_IT0 interrupt when the FIFO has emptied (TFE) — from the interrupt, not the
//!   next cycle, because the burst must be on the bus before that cycle's SYNC is stale
//!   and the heartbeat must leave every 100 ms. Queue and buffers are shared by the two
//!   tasks under a short critical section. At the start of a cycle, frames of the last
//!   one still waiting (bus-off, a congested bus) are taken back — out of the queue and
//!   cancelled in the buffers (TXBCR) — and reported as themselves, so no stale set
//!   point or SYNC leaves after the bus returns.
//! * Bus-off: the FDCAN stops (CCCR.INIT); the interrupt restarts it at once and it
//!   rejoins after the 128 × 11 recessive bits ISO 11898-1 requires, which the FDCAN
//!   waits for itself. Meanwhile every transmission fails, and the controller halts
//!   after three cycles without set points (docs/COMMANDS.md).
//! * Watchdog: IWDG, 100 ms, fed only by the 100 Hz task after a completed cycle; the
//!   reset cause (RCC_RSR) is logged at boot.
//! * Cost: DWT CYCCNT, in core cycles (the QEMU board counts instructions instead).
//! * Logging: defmt over RTT (probe-rs).
//!
//! This module holds the board's `unsafe`: FDCAN1 register accesses the `fdcan` driver
//! does not offer — the restart after bus-off, the Tx FIFO mode, and reading which
//! buffer a frame goes to and cancelling pending ones.
#![allow(unsafe_code)]

use core::cell::RefCell;
use core::num::{NonZeroU16, NonZeroU8};
use core::sync::atomic::{AtomicU32, Ordering};

use controller::transmit::{Loss, Queued, TxFifo, TxQueue, BURST};
use controller::CanFrame;
use cortex_m::interrupt::Mutex;
use fdcan::config::NominalBitTiming;
use fdcan::filter::{StandardFilter, StandardFilterSlot};
use fdcan::frame::{FrameFormat, TxFrameHeader};
use fdcan::id::{Id, StandardId};
use fdcan::interrupt::{Interrupt, InterruptLine};
use fdcan::{FdCanControl, Fifo0, Fifo1, NormalOperationMode, ReceiveOverrun, Rx, Tx};
use heapless::spsc::{Consumer, Producer, Queue};
use heapless::Deque;
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

/// The FDCAN's transmit buffers (`fdcan` 0.2: `message_ram::TX_FIFO_MAX`).
const TX_BUFFERS: usize = 3;

/// Register polls to wait for one cancellation (inside a critical section): about the
/// 160 µs a frame already on the wire may take at 1 Mbit/s; one not confirmed by then
/// is tried again next cycle.
const CANCEL_POLLS: u32 = 10_000;

/// The transmit path: the queue and the buffers, shared by the 100 Hz task and the
/// FDCAN1_IT0 interrupt (`None` until `init`).
static TX_PATH: Mutex<RefCell<Option<TxPath>>> = Mutex::new(RefCell::new(None));

struct TxPath {
    queue: TxQueue<BURST>,
    buffers: Buffers,
}

/// Runs `f` on the transmit path in a critical section; `None` before `init`.
fn with_tx<R>(f: impl FnOnce(&mut TxPath) -> R) -> Option<R> {
    cortex_m::interrupt::free(|cs| {
        let mut path = TX_PATH.borrow(cs).try_borrow_mut().ok()?;
        path.as_mut().map(f)
    })
}

/// The FDCAN's 3 transmit buffers in FIFO mode, and which frame each holds (to report a
/// cancelled one as itself, oldest first).
struct Buffers {
    tx: Tx<Fdcan1, NormalOperationMode>,
    /// Per buffer: the order it was filled in, and its frame.
    held: [Option<(u32, Queued)>; TX_BUFFERS],
    filled: u32,
}

/// FDCAN1's registers, for what the driver does not offer.
fn fdcan1() -> &'static pac::fdcan1::RegisterBlock {
    // SAFETY: a shared reference to the memory-mapped block; the accesses made through it
    // (TXFQS, TXBRP, TXBTO, TXBCF reads; TXBCR, TXBC and CCCR writes) are each explained
    // where they are made.
    unsafe { &*FDCAN1::ptr() }
}

impl Buffers {
    /// Forgets the frames of buffers no longer pending (they left).
    fn forget_sent(&mut self) {
        // Reading TXBRP has no side effect.
        let pending = fdcan1().txbrp.read().trp().bits();
        for (i, held) in self.held.iter_mut().enumerate() {
            if pending & (1 << i) == 0 {
                *held = None;
            }
        }
    }
}

impl TxFifo for Buffers {
    fn has_room(&mut self) -> bool {
        !self.tx.tx_queue_is_full()
    }

    fn push(&mut self, queued: Queued) -> Result<(), Queued> {
        self.forget_sent();
        // CanFrame's id has 11 bits, so this is always `Some`; were it not, the frame
        // would wait and expire, reported.
        let Some(id) = StandardId::new(queued.frame.id()) else {
            return Err(queued);
        };
        let header = TxFrameHeader {
            len: queued.frame.data().len() as u8,
            frame_format: FrameFormat::Standard,
            id: id.into(),
            bit_rate_switching: false,
            marker: None,
        };
        // The buffer the driver writes when the FIFO is not full: the put index
        // (fdcan 0.2.1 `Tx::transmit_preserve`). Reading TXFQS has no side effect.
        let slot = usize::from(fdcan1().txfqs.read().tfqpi().bits());
        // Not full (`has_room`, in the same critical section): the driver writes the
        // put index and displaces nothing, so `Ok` is always `Ok(None)`.
        match self.tx.transmit(header, queued.frame.data()) {
            Ok(_) => {
                if let Some(held) = self.held.get_mut(slot) {
                    *held = Some((self.filled, queued));
                }
                self.filled = self.filled.wrapping_add(1);
                Ok(())
            }
            Err(_) => Err(queued),
        }
    }

    /// One buffer at a time, oldest first: the oldest pending frame is the FIFO's head
    /// (TXFQS.TFGI), and cancelling the head is the case the M_CAN documents for the
    /// Tx FIFO — the get index moves on to the next pending buffer and the free level is
    /// recalculated; cancelling any other buffer leaves both unchanged.
    fn cancel_before(&mut self, now_ms: u64, lost: &mut dyn FnMut(Queued)) {
        self.forget_sent();
        let can = fdcan1();
        while let Some((i, (_, queued))) = self
            .held
            .iter()
            .enumerate()
            .filter_map(|(i, h)| h.map(|h| (i, h)))
            .filter(|(_, (_, q))| q.cycle_ms < now_ms)
            .min_by_key(|(_, (order, _))| *order)
        {
            let bit = 1u32 << i;
            // SAFETY: TXBCR requests the cancellation of one buffer this path filled; it
            // changes no configuration.
            can.txbcr.write(|w| unsafe { w.cr().bits(bit) });
            let mut polls = 0;
            while can.txbcf.read().cf().bits() & bit == 0 {
                polls += 1;
                if polls >= CANCEL_POLLS {
                    // Not confirmed (the FDCAN is not running): tried again next cycle.
                    return;
                }
            }
            if let Some(held) = self.held.get_mut(i) {
                *held = None;
            }
            // Finished: cancelled, unless it completed on the bus meanwhile (TXBTO).
            if can.txbto.read().to().bits() & bit == 0 {
                lost(queued);
            }
        }
    }
}

/// The drive controller board, as the 100 Hz task sees it.
pub struct Board {
    rx: Consumer<'static, CanFrame>,
    watchdog: IndependentWatchdog,
    /// Frames lost and not yet reported: at most the queue's and the buffers'.
    tx_lost: Deque<(CanFrame, Loss), { BURST + TX_BUFFERS }>,
}

/// The receive side, owned by the FDCAN1_IT0 interrupt.
pub struct CanRx {
    control: FdCanControl<Fdcan1, NormalOperationMode>,
    fifo0: Rx<Fdcan1, NormalOperationMode, Fifo0>,
    fifo1: Rx<Fdcan1, NormalOperationMode, Fifo1>,
    queue: Producer<'static, CanFrame>,
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
        // The driver put the transmit buffers into queue mode (lowest id first); in
        // FIFO mode they leave in the order written.
        // TXBC is writable in configuration mode (CCCR.INIT and CCE set), where `can`
        // is; only TFQM changes, the buffers' address and count stay the HAL's.
        fdcan1().txbc.modify(|_, w| w.tfqm().clear_bit());
        for interrupt in [
            Interrupt::RxFifo0NewMsg,
            Interrupt::RxFifo1NewMsg,
            Interrupt::BusOff,
            Interrupt::TxEmpty,
        ] {
            can.enable_interrupt(interrupt);
        }
        can.enable_interrupt_line(InterruptLine::_0, true);
        let (control, tx, fifo0, fifo1) = can.into_normal().split();
        cortex_m::interrupt::free(|cs| {
            // Nothing else holds it yet: `init` runs before any task.
            if let Ok(mut path) = TX_PATH.borrow(cs).try_borrow_mut() {
                *path = Some(TxPath {
                    queue: TxQueue::new(),
                    buffers: Buffers {
                        tx,
                        held: [None; TX_BUFFERS],
                        filled: 0,
                    },
                });
            }
        });
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
                rx: consumer,
                watchdog,
                tx_lost: Deque::new(),
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
    pub fn restart_stack_watermark(&mut self) {}

    /// Stack painting is measured under QEMU (see there): nothing here.
    pub fn stack_use(&self) -> (u32, u32) {
        (0, 0)
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
    /// Moves every received frame into the queue, feeds the transmit FIFO from the
    /// transmit queue once it has emptied, and restarts the FDCAN after a bus-off. Runs
    /// in the FDCAN1_IT0 interrupt.
    pub fn drain(&mut self) {
        if self.control.has_interrupt(Interrupt::TxEmpty) {
            self.control.clear_interrupt(Interrupt::TxEmpty);
            with_tx(|path| path.queue.feed(&mut path.buffers));
        }
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
    // FDCAN1's CCCR is written by no one else after `init` (the driver's halves do not
    // touch it in normal operation); clearing INIT is the documented way out of bus-off
    // and changes no configuration.
    fdcan1().cccr.modify(|_, w| w.init().clear_bit());
}

impl controller::board::CanPort for Board {
    type TxError = Loss;

    /// Next received frame, if any, from the interrupt's queue.
    fn receive(&mut self, _now_ms: u64) -> Option<CanFrame> {
        self.rx.dequeue()
    }

    /// Queues a frame behind those of this cycle and fills the free transmit buffers;
    /// the FDCAN1_IT0 interrupt feeds the rest as the FIFO empties.
    fn transmit(&mut self, now_ms: u64, frame: &CanFrame) -> Result<(), Loss> {
        with_tx(|path| {
            path.queue.submit(*frame, now_ms).map_err(|l| l.loss)?;
            path.queue.feed(&mut path.buffers);
            Ok(())
        })
        .unwrap_or(Err(Loss::QueueFull))
    }

    /// Frames of cycles before `now_ms` that have not left are taken back (out of the
    /// queue, cancelled in the buffers) and returned one by one, oldest first.
    fn lost(&mut self, now_ms: u64) -> Option<(CanFrame, Loss)> {
        if self.tx_lost.is_empty() {
            let pending = &mut self.tx_lost;
            with_tx(|path| {
                path.queue.expire(&mut path.buffers, now_ms, |lost| {
                    // Room for everything the queue and the buffers hold.
                    let _ = pending.push_back((lost.queued.frame, lost.loss));
                })
            });
        }
        self.tx_lost.pop_front()
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

/// The mode a run must end in: the drive controller runs forever, so any.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ending {
    /// Whatever the mode.
    Either,
}

impl Ending {
    /// Always: the drive controller's run has no expected end.
    #[must_use]
    pub fn admits(self, _mode: controller::Mode) -> bool {
        true
    }
}

/// The cycle counter read around the inverse model's steps (`crate::timed`): the same
/// DWT CYCCNT as [`Board::counter`].
pub fn solver_counter() -> u32 {
    cortex_m::peripheral::DWT::cycle_count()
}

/// Core cycles between two readings of [`solver_counter`], across a wrap; the same units
/// as [`Board::cost`]'s.
pub fn solver_elapsed(start: u32, end: u32) -> u32 {
    end.wrapping_sub(start)
}
