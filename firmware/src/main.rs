//! The crane drive controller: every 10 ms one step of the inverse model, and the
//! trolley and winch velocity set points over CANopen; moves on command, and a
//! defined reaction to every fault (docs/COMMANDS.md).
//!
//! The RTIC application is the same on every board; `board` is the only part that
//! differs (QEMU for counting instructions, the STM32H743 drive controller). The
//! portable logic lives in the `controller` crate and is tested on the host.
#![no_std]
#![no_main]

mod board;
mod placed;
mod scene;
mod timed;

#[cfg(feature = "stm32h743")]
use defmt_rtt as _;
#[cfg(feature = "qemu")]
use defmt_semihosting as _;

/// What the controller steps: under QEMU with the scenarios' solver-failure
/// injection, on the drive controller the inverse model alone; on both boards with its
/// steps timed (the solver's share of the tick in each cost line).
#[cfg(feature = "qemu")]
type Feedforward = timed::Timed<controller::Injectable<scene::Feedforward>>;
#[cfg(feature = "stm32h743")]
type Feedforward = timed::Timed<scene::Feedforward>;

/// The controller of the scene's crane (its `AXES` drives), with the scene's correction;
/// its feedforward in a static of its own (`placed`).
type SceneController = controller::Controller<
    placed::Placed<Feedforward>,
    scene::Correction,
    scene::Crane,
    { scene::AXES },
>;

#[cfg_attr(feature = "qemu", rtic::app(device = crate::board::pac, dispatchers = [UARTRX0]))]
#[cfg_attr(feature = "stm32h743", rtic::app(device = crate::board::pac, dispatchers = [SPI1]))]
mod app {
    use core::mem::MaybeUninit;

    use controller::Controller;
    use rtic_monotonics::systick::prelude::*;

    use crate::board::{self, Board, CanPort};
    use crate::{scene, SceneController};

    rtic_monotonics::systick_monotonic!(Mono, 1_000);

    #[shared]
    struct Shared {}

    /// The 100 Hz task's resources. The controller and the board are built into statics
    /// of `init` and held by reference: returned by value, they would stay in `main`'s
    /// frame for good (`main` never returns), beneath every task's stack — 15–25 KiB of
    /// the stack before (`cargo xtask qemu-bench`, *stack (control task)*).
    #[local]
    struct Local {
        can_rx: board::CanRx,
        controller: &'static mut SceneController,
        board: &'static mut Board,
        /// Cycles to run: under QEMU the scenario's (or the scene's), on the board forever.
        cycles: Option<u32>,
        /// The mode the run must end in (QEMU's exit code).
        ending: board::Ending,
    }

    #[init(local = [
        feedforward_slot: MaybeUninit<crate::Feedforward> = MaybeUninit::uninit(),
        controller_slot: MaybeUninit<SceneController> = MaybeUninit::uninit(),
        board_slot: MaybeUninit<Board> = MaybeUninit::uninit(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        #[cfg(feature = "qemu")]
        let (board, can_rx, restarted, cycles, ending) = {
            let scenario = match board::scenario() {
                Ok(s) => s,
                Err(len) => {
                    defmt::error!("unknown scenario (name of {=usize} bytes)", len);
                    board::finish(false)
                }
            };
            defmt::info!("scenario {=str}: {=str}", scenario.name, scenario.expect);
            let cycles = if scenario.cycles == 0 {
                scene::CYCLES
            } else {
                scenario.cycles
            };
            Mono::start(cx.core.SYST, board::SYSCLK_HZ);
            let (board, restarted) = Board::init(scenario);
            (board, board::CanRx, restarted, Some(cycles), scenario.ends)
        };
        #[cfg(feature = "stm32h743")]
        let (board, can_rx, restarted, cycles, ending) = {
            let mut core = cx.core;
            // The code runs from flash, which has wait states at 480 MHz: through the
            // 16 KiB instruction cache (data and stack are in the DTCM, no cache).
            core.SCB.enable_icache();
            let (board, can_rx, restarted) = Board::init(cx.device, &mut core.DCB, &mut core.DWT);
            Mono::start(core.SYST, board::SYSCLK_HZ);
            let ending = board::Ending::Either;
            (board, can_rx, restarted, None, ending)
        };
        defmt::info!(
            "scene {=str}: {=str}, its move {=u32} cycles",
            scene::NAME,
            scene::SOLVER,
            scene::CYCLES
        );
        // No motion without a command: the scene's move is a demonstration that the QEMU
        // runs ask for, never the drive controller's default; after a watchdog reset
        // nothing moves on its own either, and the controller boots halted until a
        // supervisor's reset.
        #[cfg(feature = "qemu")]
        let demonstration = !restarted;
        #[cfg(feature = "stm32h743")]
        let demonstration = false;
        // The board into its static before the model is built: its by-value result
        // (4 KB) no longer shares `init`'s frame with the model's and the controller's.
        let board = cx.local.board_slot.write(board);
        let model = match scene::inverse_model(demonstration) {
            Ok(f) => f,
            Err(e) => {
                defmt::error!("scene refused: {}", e);
                board::finish(false)
            }
        };
        #[cfg(feature = "qemu")]
        let feedforward = cx
            .local
            .feedforward_slot
            .write(crate::timed::timed(controller::Injectable::new(model)));
        #[cfg(feature = "stm32h743")]
        let feedforward = cx.local.feedforward_slot.write(crate::timed::timed(model));
        let config = scene::CONFIG;
        if control::spawn().is_err() {
            defmt::error!("control task already running");
            board::finish(false)
        }
        let correction = match scene::correction() {
            Ok(c) => c,
            Err(e) => {
                defmt::error!("feedback refused: {}", e);
                board::finish(false)
            }
        };
        let controller = cx.local.controller_slot.write(Controller::with_correction(
            crate::placed::Placed(feedforward),
            correction,
            scene::PLANNER,
            config,
        ));
        if restarted {
            controller.restarted_by_watchdog();
        } else if demonstration {
            // The scene's move is the main job's command: a feedback acts on it.
            controller.demonstration_commanded();
        }
        (
            Shared {},
            Local {
                can_rx,
                controller,
                board,
                cycles,
                ending,
            },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            board::idle();
        }
    }

    /// Every received frame into the queue the 100 Hz task empties (the FDCAN's FIFOs
    /// hold 3 frames each), and the restart after a bus-off. (Under QEMU nothing raises
    /// it: the virtual bus feeds the 100 Hz task directly.)
    #[task(binds = FDCAN1_IT0, priority = 2, local = [can_rx])]
    fn can_rx(cx: can_rx::Context) {
        cx.local.can_rx.drain();
    }

    /// The 100 Hz cycle: received frames, one inverse-model step, transmit. The
    /// watchdog is fed only here, after a completed cycle.
    #[task(priority = 1, local = [controller, board, cycles, ending])]
    async fn control(cx: control::Context) {
        let (controller, board) = (&mut **cx.local.controller, &mut **cx.local.board);
        // From here on the stack's high-water mark is this task's (under QEMU).
        board.restart_stack_watermark();
        let cycles = *cx.local.cycles;
        let mut next = Mono::now();
        let (mut min, mut max, mut sum) = (u64::MAX, 0u64, 0u64);
        let mut cycle: u64 = 0;
        let mut commissioned = 0;
        #[cfg(feature = "stm32h743")]
        let mut link_losses = (0, 0);
        while cycles.is_none_or(|n| cycle < u64::from(n)) {
            let now_ms = cycle * u64::from(scene::PERIOD_MS);
            // The cycle every board runs (controller::board): the frames of the last cycle
            // that did not leave (bus-off, a slow bus) reported, each as itself, before
            // the tick; the burst queued in order (controller::transmit), a refused frame
            // reported at once, a frame the bus refuses as soon as it does.
            let (mut cost, mut solver) = (0, 0);
            let tick = |controller: &mut SceneController, board: &mut Board| {
                #[cfg(feature = "qemu")]
                if board.take_hang() {
                    defmt::warn!(
                        "hang at {=u64} ms: the 100 Hz task stops checking in",
                        now_ms
                    );
                    #[allow(clippy::empty_loop)]
                    loop {}
                }
                #[cfg(feature = "qemu")]
                if board.take_solver_failure() {
                    controller.feedforward_mut().inner.fail_next_step();
                }
                let start = board.counter();
                let out = controller.tick(now_ms);
                cost = board.cost(start, board.counter());
                // The inverse model's steps within it (`timed`): a linear count, so the
                // ticks convert as a window from 0.
                solver = board.cost(0, controller.feedforward_mut().around.take_ticks());
                controller.record_cost(cost);
                Some(out)
            };
            let log_lost = |frame: &controller::CanFrame, e: &<Board as CanPort>::TxError| {
                defmt::warn!("tx failed {=u16:#05x}: {}", frame.id(), e);
            };
            let Some(out) = controller::board::cycle(controller, board, now_ms, tick, log_lost)
            else {
                // The tick above never declines (a hang loops inside it).
                defmt::error!("the cycle declined its tick");
                board::finish(false)
            };
            if controller.counters().commissioned != commissioned {
                commissioned = controller.counters().commissioned;
                log_identities(controller);
            }
            let (iterations, jacobians) = out
                .step
                .map_or((0, 0), |s| (s.stats.iterations, s.stats.jacobian_evals));
            // cycle, the whole tick, Newton iterations, Jacobians, the solver's steps alone.
            defmt::info!(
                "cost {=u64} {=u64} {=u32} {=u32} {=u64}",
                cycle,
                cost,
                iterations,
                jacobians,
                solver
            );
            (min, max, sum) = (min.min(cost), max.max(cost), sum.wrapping_add(cost));
            #[cfg(feature = "stm32h743")]
            {
                let losses = board.link_losses();
                if losses != link_losses {
                    defmt::warn!(
                        "CAN: {=u32} frames lost on reception, {=u32} bus-off restarts",
                        losses.0,
                        losses.1
                    );
                    link_losses = losses;
                }
            }
            board.feed_watchdog();
            cycle += 1;
            next += scene::PERIOD_MS.millis();
            Mono::delay_until(next).await;
        }
        let counters = controller.counters();
        defmt::info!(
            "done: {=u64} cycles, instructions per step min {=u64} mean {=u64} max {=u64}, stack {=u32} bytes, control task {=u32} bytes, {}",
            cycle,
            min,
            sum / cycle.max(1),
            max,
            board.stack_use().0,
            board.stack_use().1,
            counters
        );
        let mode = controller.mode();
        defmt::info!("mode {}", mode);
        board::finish(cx.local.ending.admits(mode))
    }

    /// The identity (0x1018:1..=4) of every commissioned drive: which drive, by vendor,
    /// product, revision and serial number, is on the crane (a commissioning record).
    fn log_identities(controller: &SceneController) {
        for drive in controller.drives() {
            if controller.commissioning(drive) == controller::commissioning::Phase::Done {
                let [vendor, product, revision, serial] = controller.identity(drive);
                defmt::info!(
                    "{} commissioned: vendor {=u32:#010x} product {=u32:#010x} revision {=u32:#010x} serial {=u32}",
                    drive,
                    vendor,
                    product,
                    revision,
                    serial
                );
            }
        }
    }
}
