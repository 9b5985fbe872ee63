//! QEMU `mps2-an500`: a Cortex-M7 with double-precision FPU, no CAN controller.
//!
//! * CAN: the virtual bus compiled into this build (the crate `sim`): two
//!   simulated CiA 402 drives that answer the controller, and the scenario named on
//!   QEMU's semihosting command line (default `healthy`). Frames go out through the
//!   same transmit path as on the STM32H743 — `controller::transmit::TxQueue` in front
//!   of 3 transmit buffers run as a FIFO — so the queue limit is exercised: the cycle
//!   hands its whole burst over (up to 3 frames into the buffers, the rest queued),
//!   then the bus takes the buffers' frames in order and each freed buffer is fed from
//!   the queue, as the FDCAN's transmit interrupt does. Every frame the bus takes is
//!   logged (decoded on the host against the DBC), and so is every loss.
//! * Cost: QEMU runs with `-icount shift=7`, so virtual time is driven by the
//!   instruction count (one instruction = 128 ns). The CMSDK APB timer 1 at
//!   0x4000_1000 counts down at 25 MHz: 3.2 ticks per instruction, identical on every
//!   run. These are **QEMU instructions, not Cortex-M7 cycles**.
//! * Watchdog: the MPS2's CMSDK APB watchdog (0x4000_8000, 25 MHz), fed only by the
//!   100 Hz task, as the STM32's IWDG. Its first timeout raises NMI, whose handler
//!   notes the cause in RAM that survives the reset; the second resets the MCU (QEMU
//!   reloads the image), and the next boot logs the cause. At 128 ns per instruction
//!   QEMU's virtual CPU is about 50 times slower than the 400 MHz STM32, so the
//!   IWDG's 100 ms become 1 s of virtual time (ten times the costliest cycle, a
//!   planning one), counted from the first completed cycle (building the scene's model
//!   takes most of a virtual second).
//! * Exit: semihosting `exit` with a real exit code (panic and HardFault fail).
//!
//! This module holds the board's `unsafe`: the device module RTIC needs (interrupt
//! numbers and the vector table), volatile access to the timer, and stack painting.
#![allow(unsafe_code)]

use controller::board::CanPort;
use controller::transmit::{FifoModel, Loss, Queued, TxQueue, BURST};
use controller::CanFrame;
use heapless::Deque;
pub use sim::Ending;
use sim::{Scenario, VirtualBus};

/// Core clock of the MPS2 board, Hz (SysTick and the APB timers run on it).
pub const SYSCLK_HZ: u32 = 25_000_000;

/// The minimal device module RTIC needs for mps2-an500 (CMSDK interrupt lines 0–3).
pub mod pac {
    /// Priority bits the NVIC implements (the top 3 are used).
    pub const NVIC_PRIO_BITS: u8 = 3;

    /// External interrupts: the CMSDK UART lines, unused by the firmware and so free
    /// for RTIC's software-task dispatchers. Line 3 (UART 1 TX) carries the name of the
    /// STM32H743's CAN receive interrupt, so that the application binds the same task on
    /// both boards; nothing raises it under QEMU.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    #[allow(non_camel_case_types, missing_docs, dead_code)]
    #[repr(u16)]
    pub enum Interrupt {
        UARTRX0 = 0,
        UARTTX0 = 1,
        UARTRX1 = 2,
        FDCAN1_IT0 = 3,
    }
    pub use Interrupt as interrupt;

    // SAFETY: `number` returns the interrupt's position in the vector table below,
    // which is what the NVIC expects.
    unsafe impl cortex_m::interrupt::InterruptNumber for Interrupt {
        fn number(self) -> u16 {
            self as u16
        }
    }

    /// The board's peripherals as RTIC hands them to `init` (none are modelled here).
    pub struct Peripherals {}

    impl Peripherals {
        /// RTIC takes the peripherals once, before `init`.
        ///
        /// # Safety
        /// Nothing is owned: there are no peripheral singletons to duplicate.
        pub unsafe fn steal() -> Self {
            Self {}
        }
    }

    extern "C" {
        fn UARTRX0();
        fn UARTTX0();
        fn UARTRX1();
        fn FDCAN1_IT0();
    }

    /// A vector table entry.
    pub union Vector {
        handler: unsafe extern "C" fn(),
        _reserved: usize,
    }

    /// The device-specific part of the vector table (cortex-m-rt's `device` feature
    /// expects it); handlers default to `DefaultHandler` through `qemu/device.x`.
    #[link_section = ".vector_table.interrupts"]
    #[no_mangle]
    pub static __INTERRUPTS: [Vector; 4] = [
        Vector { handler: UARTRX0 },
        Vector { handler: UARTTX0 },
        Vector { handler: UARTRX1 },
        Vector {
            handler: FDCAN1_IT0,
        },
    ];
}

const WATCHDOG: usize = 0x4000_8000;
const WDOG_LOAD: usize = 0x0;
const WDOG_CONTROL: usize = 0x8;
const WDOG_INTCLR: usize = 0xC;
/// 1 s of the 25 MHz watchdog clock (see the module's notes).
const WATCHDOG_TICKS: u32 = 25_000_000;

/// Written by the NMI handler at the watchdog's first timeout, read at the next boot.
const WATCHDOG_FIRED: u32 = 0x57D0_6F1D;

/// Why the MCU last reset: `WATCHDOG_FIRED`, or anything else for a power-on. In
/// `.uninit`, which neither the startup code nor QEMU's reset clears.
#[link_section = ".uninit.reset_cause"]
static mut RESET_CAUSE: core::mem::MaybeUninit<u32> = core::mem::MaybeUninit::uninit();

const TIMER1: usize = 0x4000_1000;
const CTRL: usize = 0x0;
const VALUE: usize = 0x4;
const RELOAD: usize = 0x8;

/// Pattern written over the unused stack at boot.
const PAINT: u32 = 0xCCCC_CCCC;

extern "C" {
    static mut _stack_end: u32;
    static mut _stack_start: u32;
}

/// The receive interrupt's side of the board: nothing under QEMU, where the virtual
/// bus hands frames to the 100 Hz task directly.
pub struct CanRx;

impl CanRx {
    /// Nothing to drain.
    pub fn drain(&mut self) {}
}

/// Transmit buffers, as the STM32H743's FDCAN has them (`fdcan` 0.2: 3).
pub const TX_BUFFERS: usize = 3;

/// The QEMU board.
pub struct Board {
    bus: VirtualBus<crate::scene::Crane, { crate::scene::AXES }>,
    watchdog_started: bool,
    /// Frames waiting for a transmit buffer, in order.
    tx_queue: TxQueue<BURST>,
    /// The transmit buffers, a FIFO.
    tx_buffers: FifoModel<TX_BUFFERS>,
    /// Frames lost and not yet reported: at most a burst and the buffers' frames.
    tx_lost: Deque<(CanFrame, Loss), { BURST + TX_BUFFERS }>,
    /// The stack's high-water mark when the control task started (boot and `init`).
    init_stack: u32,
    /// The stack pointer when the control task started: below it, the task's own frames.
    task_base: usize,
}

/// The scenario named on the semihosting command line
/// (`… arg=firmware,arg=<name>[,arg=<cycles>]`): `healthy` without one, its cycles
/// replaced if a number follows; `Err` with the name's length for an unknown one.
pub fn scenario() -> Result<Scenario, usize> {
    let mut buffer = [0u8; 96];
    let mut block = [buffer.as_mut_ptr() as usize, buffer.len()];
    // SAFETY: SYS_GET_CMDLINE writes at most `block[1]` bytes into `buffer` and the
    // length into `block[1]`; both outlive the call.
    let status = unsafe {
        cortex_m_semihosting::syscall1(
            cortex_m_semihosting::nr::GET_CMDLINE,
            block.as_mut_ptr() as usize,
        )
    };
    if status != 0 {
        return Ok(sim::HEALTHY);
    }
    let line = buffer.get(..block[1].min(buffer.len())).unwrap_or(&[]);
    let line = core::str::from_utf8(line).unwrap_or("");
    let mut words = line.split_ascii_whitespace().skip(1);
    let mut scenario = match words.next() {
        None => return Ok(sim::HEALTHY),
        Some(name) => sim::scenario(name).ok_or(name.len())?,
    };
    if let Some(cycles) = words.next().and_then(|w| w.parse().ok()) {
        scenario.cycles = cycles;
    }
    Ok(scenario)
}

impl Board {
    /// Paints the stack, starts the instruction counter and the virtual bus; whether
    /// the watchdog caused this boot (then the scenario's hang is not repeated).
    pub fn init(scenario: Scenario) -> (Self, bool) {
        paint_stack();
        let cause = core::ptr::addr_of_mut!(RESET_CAUSE).cast::<u32>();
        // SAFETY: `RESET_CAUSE` is a word in RAM written only here and by the NMI
        // handler, which cannot run before the watchdog is started (first feed).
        let restarted = unsafe { core::ptr::read_volatile(cause) } == WATCHDOG_FIRED;
        // SAFETY: as above.
        unsafe { core::ptr::write_volatile(cause, 0) };
        defmt::info!(
            "reset cause: {=str}",
            if restarted { "watchdog" } else { "power-on" }
        );
        // SAFETY: TIMER1 is the CMSDK APB timer of the MPS2 memory map, owned by this
        // board only; word writes to its RELOAD, VALUE and CTRL registers.
        unsafe {
            core::ptr::write_volatile((TIMER1 + RELOAD) as *mut u32, u32::MAX);
            core::ptr::write_volatile((TIMER1 + VALUE) as *mut u32, u32::MAX);
            core::ptr::write_volatile((TIMER1 + CTRL) as *mut u32, 1);
        }
        // A stock drive for each of the crane's drives, resting where the scene's move
        // starts (the host's run builds the same: `host_tests::firmware::virtual_bus`).
        let bus = VirtualBus::for_crane(scenario, &crate::scene::PARAMS, crate::scene::START);
        if !bus.simulates_scenario() {
            defmt::error!(
                "scenario {=str} moves a plant: only a build with [feedback] (feature `plant`) has one",
                scenario.name
            );
            finish(false)
        }
        let bus = if restarted { bus.without_hangs() } else { bus };
        (
            Self {
                bus,
                watchdog_started: false,
                init_stack: 0,
                task_base: 0,
                tx_queue: TxQueue::new(),
                tx_buffers: FifoModel::new(),
                tx_lost: Deque::new(),
            },
            restarted,
        )
    }

    /// Whether the scenario makes the firmware hang now.
    pub fn take_hang(&mut self) -> bool {
        self.bus.take_hang()
    }

    /// Whether the scenario makes the inverse model's next step fail.
    pub fn take_solver_failure(&mut self) -> bool {
        self.bus.take_solver_failure()
    }

    /// The free-running cost counter: timer ticks counting up (the timer counts down
    /// and wraps every 172 s of virtual time). Never inlined: its timer read marks the
    /// two ends of each step's cost window in QEMU's execution trace, where `cargo
    /// xtask cycles` estimates the Cortex-M7's cycles (at the read, not the function's
    /// entry: an interrupt between the two belongs where the timer puts it).
    #[inline(never)]
    pub fn counter(&self) -> u32 {
        // SAFETY: a volatile word read of the timer's VALUE register (see `init`).
        u32::MAX - unsafe { core::ptr::read_volatile((TIMER1 + VALUE) as *const u32) }
    }

    /// QEMU instructions between two readings of [`Board::counter`], across a wrap:
    /// 25 MHz timer, 128 ns per instruction, 3.2 ticks per instruction.
    pub fn cost(&self, from: u32, to: u32) -> u64 {
        u64::from(to.wrapping_sub(from)) * 10 / 32
    }

    /// Feeds the watchdog (clears its interrupt and reloads it): only the 100 Hz task
    /// calls this, after a completed cycle.
    pub fn feed_watchdog(&mut self) {
        // SAFETY: the CMSDK watchdog of the MPS2 memory map, owned by this board only;
        // word writes to LOAD and CONTROL (interrupt and reset enabled) once, then to
        // INTCLR, which clears the interrupt and reloads the counter.
        unsafe {
            if !self.watchdog_started {
                core::ptr::write_volatile((WATCHDOG + WDOG_LOAD) as *mut u32, WATCHDOG_TICKS);
                core::ptr::write_volatile((WATCHDOG + WDOG_CONTROL) as *mut u32, 0b11);
                self.watchdog_started = true;
            }
            core::ptr::write_volatile((WATCHDOG + WDOG_INTCLR) as *mut u32, 1);
        }
    }

    /// Starts measuring the control task's own stack: records the high-water mark of
    /// boot and `init` (which builds the RTIC resources on the stack), then paints the
    /// stack below the task's frame again, with interrupts off so that no handler's
    /// frame is painted over while in use. Called once, as the task starts.
    pub fn restart_stack_watermark(&mut self) {
        self.init_stack = self.stack_high_water();
        self.task_base = cortex_m::register::msp::read() as usize;
        cortex_m::interrupt::free(|_| paint_stack());
    }

    /// Stack use, bytes: the deepest since boot, and the control task's own from the
    /// first time `idle` ran — how far below `idle`'s stack pointer (the context it
    /// interrupts) it reached: its
    /// exception frame, its dispatcher's and its own frames and the interrupts on top
    /// of it, whatever the optimiser inlines into which. (Measured from the task's
    /// stack pointer when it starts, the frame its entry allocated went uncounted, and
    /// the figure moved with inlining.) The difference is what stays live above the
    /// task: `main`'s frame, which holds the resources `init` returned by value.
    pub fn stack_use(&self) -> (u32, u32) {
        let since = self.stack_high_water();
        let (_, top) = stack_bounds();
        let base = match IDLE_SP.load(core::sync::atomic::Ordering::Relaxed) {
            0 => self.task_base,
            idle => idle,
        };
        let task = base.saturating_sub(top.saturating_sub(since as usize));
        (self.init_stack.max(since), task as u32)
    }

    /// Deepest stack use since the last painting, bytes.
    fn stack_high_water(&self) -> u32 {
        let (bottom, top) = stack_bounds();
        let mut p = bottom;
        // SAFETY: reads of the stack region between the linker's _stack_end and
        // _stack_start, word-aligned, below the current stack pointer or used stack.
        while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
            p += 4;
        }
        (top - p) as u32
    }
}

impl CanPort for Board {
    type TxError = Loss;

    /// Next frame received by `now_ms`: the virtual bus's own port (the host's run
    /// receives through the same code).
    fn receive(&mut self, now_ms: u64) -> Option<CanFrame> {
        CanPort::receive(&mut self.bus, now_ms)
    }

    /// Queues a frame: into a free transmit buffer, or behind the frames waiting for one.
    fn transmit(&mut self, now_ms: u64, frame: &CanFrame) -> Result<(), Loss> {
        self.tx_queue.submit(*frame, now_ms).map_err(|l| l.loss)?;
        self.tx_queue.feed(&mut self.tx_buffers);
        Ok(())
    }

    /// The bus takes what the buffers hold, in order, each freed buffer fed from the
    /// queue (the CPU hands a whole burst over in less time than one frame takes on the
    /// bus); each frame is logged for the host to decode, and a refused one (bus-off)
    /// is lost. Then the frames of cycles before `now_ms` still waiting expire (none
    /// do: the virtual bus takes or refuses everything at once).
    fn lost(&mut self, now_ms: u64) -> Option<(CanFrame, Loss)> {
        while let Some(Queued { frame, cycle_ms }) = self.tx_buffers.take_next() {
            defmt::info!(
                "tx {=u64} {=u16:#05x} {=[u8]:02x}",
                cycle_ms,
                frame.id(),
                frame.data()
            );
            if self.bus.transmit(&frame).is_err()
                && self.tx_lost.push_back((frame, Loss::BusOff)).is_err()
            {
                defmt::error!("tx {=u16:#05x} lost and not reported", frame.id());
            }
            self.tx_queue.feed(&mut self.tx_buffers);
        }
        if self.tx_lost.is_empty() {
            let pending = &mut self.tx_lost;
            self.tx_queue.expire(&mut self.tx_buffers, now_ms, |lost| {
                if pending.push_back((lost.queued.frame, lost.loss)).is_err() {
                    defmt::error!(
                        "tx {=u16:#05x} lost and not reported",
                        lost.queued.frame.id()
                    );
                }
            });
        }
        self.tx_lost.pop_front()
    }
}

fn stack_bounds() -> (usize, usize) {
    // Only the addresses of the linker symbols are taken.
    (
        core::ptr::addr_of!(_stack_end) as usize,
        core::ptr::addr_of!(_stack_start) as usize,
    )
}

/// Fills the unused stack (below the current stack pointer, with a margin) with `PAINT`.
fn paint_stack() {
    let (bottom, _) = stack_bounds();
    let sp = cortex_m::register::msp::read() as usize - 64;
    let mut p = bottom;
    while p < sp {
        // SAFETY: word writes to the unused part of the stack, below the live frames.
        unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
}

/// Ends the QEMU run with an exit code.
pub fn finish(success: bool) -> ! {
    use cortex_m_semihosting::debug;
    debug::exit(if success {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    #[allow(clippy::empty_loop)]
    loop {}
}

/// Idle: `wfi`. With `-icount … sleep=off` QEMU then skips the idle time at once,
/// about 30× faster than a busy loop. The SysTick monotonic runs slow under `wfi` and
/// `-icount` (DESIGN.md), which changes nothing here: the cycle's time comes from its
/// own counter, and each step's cost is counted inside the step.
///
/// The first time it runs, it notes its stack pointer and paints the stack below it
/// (interrupts off): no task is running, so nothing below is live, and from here on the
/// high-water mark is the tasks' own, measured from the context they interrupt.
pub fn idle() {
    use core::sync::atomic::Ordering::Relaxed;
    if IDLE_SP.load(Relaxed) == 0 {
        cortex_m::interrupt::free(|_| {
            IDLE_SP.store(cortex_m::register::msp::read() as usize, Relaxed);
            paint_stack();
        });
    }
    cortex_m::asm::wfi();
}

/// The stack pointer of `idle`, the context every task interrupts: the base of the
/// control task's stack, above its dispatcher's exception frame and its own frame (0
/// until `idle` first ran).
static IDLE_SP: core::sync::atomic::AtomicUsize = core::sync::atomic::AtomicUsize::new(0);

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    finish(false)
}

/// The watchdog's first timeout: the 100 Hz task stopped checking in. Note it for the
/// next boot (no logging here: an NMI may interrupt a log); the watchdog's second
/// timeout resets the MCU.
#[cortex_m_rt::exception]
unsafe fn NonMaskableInt() {
    // SAFETY: a word write to `RESET_CAUSE` (see `Board::init`).
    unsafe {
        core::ptr::write_volatile(
            core::ptr::addr_of_mut!(RESET_CAUSE).cast::<u32>(),
            WATCHDOG_FIRED,
        )
    };
}

#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::error!("HardFault at pc {=u32:#010x}", frame.pc());
    finish(false)
}

/// The timer that [`Board::counter`] reads, read around the inverse model's steps
/// (`crate::timed`) as it counts — down: [`solver_elapsed`] turns two readings into
/// ticks. A function of its own, never inlined: `cargo xtask cycles` cuts the tick's
/// windows at every timer read of `Board::counter`, so the solver's window inside the
/// tick must not call it. Its body must differ from `Board::counter`'s too (the raw value,
/// not `u32::MAX −` it): identical functions are folded into one symbol by the
/// optimiser, and `Board::counter`'s name would vanish from the ELF.
#[inline(never)]
pub fn solver_counter() -> u32 {
    // SAFETY: a volatile word read of the timer's VALUE register (see `Board::init`).
    unsafe { core::ptr::read_volatile((TIMER1 + VALUE) as *const u32) }
}

/// Timer ticks between two readings of [`solver_counter`] (it counts down), across a
/// wrap; `Board::cost(0, ticks)` converts them into QEMU instructions.
pub fn solver_elapsed(start: u32, end: u32) -> u32 {
    start.wrapping_sub(end)
}
