//! The crane drive controller: every 10 ms one step of the inverse model, and the
//! trolley and winch velocity set points over CANopen.
//!
//! The RTIC application is the same on every board; `board` is the only part that
//! differs (QEMU for counting instructions, the STM32H743 drive controller). The
//! portable logic lives in the `controller` crate and is tested on the host.
#![no_std]
#![no_main]

mod board;
mod scene;

#[cfg(feature = "stm32h743")]
use defmt_rtt as _;
#[cfg(feature = "qemu")]
use defmt_semihosting as _;

#[cfg_attr(feature = "qemu", rtic::app(device = crate::board::pac, dispatchers = [UARTRX0]))]
#[cfg_attr(feature = "stm32h743", rtic::app(device = crate::board::pac, dispatchers = [SPI1]))]
mod app {
    #[cfg(feature = "qemu")]
    use controller::virtual_bus::HEALTHY;
    use controller::{Config, Controller, Mode};
    use rtic_monotonics::systick::prelude::*;

    use crate::board::{self, Board, CanPort};
    use crate::scene;

    rtic_monotonics::systick_monotonic!(Mono, 1_000);

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        controller: Controller<scene::Feedforward>,
        board: Board,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        #[cfg(feature = "qemu")]
        let board = Board::init(HEALTHY);
        #[cfg(feature = "stm32h743")]
        let board = {
            let mut core = cx.core;
            let board = Board::init(cx.device, &mut core.DCB, &mut core.DWT);
            Mono::start(core.SYST, board::SYSCLK_HZ);
            board
        };
        #[cfg(feature = "qemu")]
        Mono::start(cx.core.SYST, board::SYSCLK_HZ);
        defmt::info!(
            "scene {=str}: {=str}, {=u32} cycles",
            scene::NAME,
            scene::SOLVER,
            scene::CYCLES
        );
        let feedforward = match scene::inverse_model() {
            Ok(f) => f,
            Err(e) => {
                defmt::error!("scene refused: {}", defmt::Debug2Format(&e));
                board::finish(false)
            }
        };
        let config = Config {
            period_ms: scene::PERIOD_MS,
            ..Config::DEFAULT
        };
        if control::spawn().is_err() {
            defmt::error!("control task already running");
            board::finish(false)
        }
        (
            Shared {},
            Local {
                controller: Controller::new(feedforward, config),
                board,
            },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            board::idle();
        }
    }

    /// The 100 Hz cycle: received frames, one inverse-model step, transmit.
    #[task(priority = 1, local = [controller, board])]
    async fn control(cx: control::Context) {
        let (controller, board) = (cx.local.controller, cx.local.board);
        let mut next = Mono::now();
        let (mut min, mut max, mut sum) = (u64::MAX, 0, 0);
        for cycle in 0..scene::CYCLES {
            let now_ms = cycle * scene::PERIOD_MS;
            while let Some(frame) = board.receive(now_ms) {
                controller.on_frame(&frame, now_ms);
            }
            let start = board.instructions();
            let out = controller.tick(now_ms);
            let cost = board.instructions() - start;
            for frame in &out.frames {
                if let Err(e) = board.transmit(now_ms, frame) {
                    defmt::warn!("transmit failed: {}", e);
                }
            }
            let (iterations, jacobians) = out
                .step
                .map_or((0, 0), |s| (s.stats.iterations, s.stats.jacobian_evals));
            defmt::info!(
                "cost {=u32} {=u64} {=u32} {=u32}",
                cycle,
                cost,
                iterations,
                jacobians
            );
            (min, max, sum) = (min.min(cost), max.max(cost), sum + cost);
            board.feed_watchdog();
            next += scene::PERIOD_MS.millis();
            Mono::delay_until(next).await;
        }
        let counters = controller.counters();
        defmt::info!(
            "done: {=u32} cycles, instructions per step min {=u64} mean {=u64} max {=u64}, stack {=u32} bytes, {}",
            scene::CYCLES,
            min,
            sum / u64::from(scene::CYCLES.max(1)),
            max,
            board.stack_high_water(),
            counters
        );
        let mode = controller.mode();
        defmt::info!("mode {}", mode);
        board::finish(mode == Mode::Running)
    }
}
