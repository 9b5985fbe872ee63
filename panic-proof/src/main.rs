//! Link-time proof that the firmware's portable logic cannot panic.
//!
//! `panic-never` is this binary's panic handler: it calls a symbol that does not exist,
//! so the link fails if any panicking branch survives optimisation. The binary drives
//! every entry point the firmware calls — `Controller::restarted_by_watchdog`,
//! `demonstration_commanded`, `on_frame`, `tick`, `record_cost`, `transmit_failed` — for
//! every model and scheme a scene can choose (crane *subs* and *proj*, BDF — with the
//! run-time modes and the structured exact Newton — and Radau IIA, every Jacobian mode
//! through the settings), with and without the state feedback (its gain design
//! included), with every input (frames, times, costs, settings, parameters, the first
//! move) hidden behind `black_box`, so that nothing is proven for constants only.
//! Built with the firmware's release profile for the drive's target:
//! `cargo xtask panic-proof`. What it does not cover — the board, RTIC and defmt — is
//! listed path by path in docs/PANICS.md.
#![no_std]
#![no_main]

use core::hint::black_box;

use controller::commissioning::{InclinometerSetup, NodeSetup};
use controller::feedback::{self, Correction, StateFeedback};
use controller::feedforward::command_plan;
use controller::planner::Planner;
use controller::setpoint::DriveLimits;
use controller::{CanFrame, Config, Controller, Feedforward, InverseModel, Replan};
use cortex_m_rt::entry;
use nalgebra::SVector;
#[cfg(feature = "panic-never")]
use panic_never as _;

/// With `--no-default-features --features report`: a handler that links, so that the
/// panicking branches can be listed (`cargo xtask panic-proof` does).
#[cfg(not(feature = "panic-never"))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {
        black_box(());
    }
}
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_proj::{self, CraneProj};
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::plan::Plan;
use solver_core::trajectory::PointToPoint;
use solver_core::{Error, JacobianMode, SolverSettings};

/// The firmware's plan.
type P = Plan<f64, 2>;
type Subs = CraneSubs<f64, P>;
type Proj = CraneProj<f64, P>;

/// The first plan: rest, then a move, all from opaque inputs.
fn plan() -> Result<Plan<f64, 2>, Error> {
    let [x0, z0, x1, z1, t0, d]: [f64; 6] = black_box([12.0, 8.0, 20.0, 4.0, 1.0, 8.0]);
    let n: usize = black_box(4);
    let mut plan = command_plan([x0, z0], n)?;
    plan.push(PointToPoint::new(
        SVector::from([x0, z0]),
        SVector::from([x1, z1]),
        t0,
        d,
        n,
    )?)?;
    Ok(plan)
}

/// The controller on `feedforward`, with or without the state feedback (as the scene
/// says), its entry points run on opaque inputs.
fn run<F: Feedforward + Replan>(feedforward: F) -> ! {
    let params: CraneParams = black_box(CraneParams::PAPER);
    let limits: DriveLimits = black_box(DriveLimits::LAB);
    let config: Config = black_box(Config::DEFAULT);
    let planner = Planner::new(params, limits);
    if black_box(true) {
        let Ok(feedback) = StateFeedback::new(black_box(feedback::Config::PAPER)) else {
            halt()
        };
        let config = config.with_node(NodeSetup::Inclinometer(black_box(InclinometerSetup::STOCK)));
        drive(Controller::with_correction(
            feedforward,
            feedback,
            planner,
            config,
        ))
    } else {
        drive(Controller::new(feedforward, planner, config))
    }
}

/// Runs the controller's entry points on opaque inputs, forever.
fn drive<F: Feedforward + Replan, C: Correction>(mut controller: Controller<F, C>) -> ! {
    if black_box(false) {
        controller.restarted_by_watchdog();
    }
    if black_box(false) {
        controller.demonstration_commanded();
    }
    loop {
        let now: u64 = black_box(0);
        let (id, len, data): (u16, usize, [u8; 8]) = black_box((0, 0, [0; 8]));
        if let Ok(frame) = CanFrame::new(id, data.get(..len).unwrap_or(&[])) {
            controller.on_frame(&frame, now);
        }
        let out = controller.tick(now);
        controller.record_cost(black_box(0));
        for frame in &out.frames {
            if black_box(false) {
                controller.transmit_failed(frame);
            }
            black_box(frame);
        }
        black_box(&out);
    }
}

/// Where a refused setup ends.
fn halt() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

/// Builds the model on the first plan and the integrator `$integrator` on it, then runs
/// the controller on them.
macro_rules! prove {
    ($model:ty, |$m:ident| $new:expr) => {{
        let Ok(plan) = plan() else { halt() };
        let Ok(model) = <$model>::new(black_box(CraneParams::PAPER), plan) else {
            halt()
        };
        let $m = &model;
        let Ok(integrator) = ($new) else { halt() };
        run(InverseModel::new(model, integrator))
    }};
}

/// Every integrator the firmware links, one per row of `scene::dispatch::FirmwareScheme`
/// (the build script names them from there).
#[entry]
fn main() -> ! {
    let settings: SolverSettings = black_box(SolverSettings::paper(JacobianMode::Exact));
    let k: usize = black_box(4);
    let t0: f64 = black_box(0.0);
    match black_box(0_u8) {
        0 => prove!(Subs, |m| crane_subs::StructuredBdf::<f64, P>::new(
            m, &settings, k, t0
        )),
        1 => prove!(Subs, |m| {
            crane_subs::StructuredBdfUncorrected::<f64, P>::new(m, &settings, k, t0)
        }),
        2 => prove!(Subs, |m| crane_subs::Bdf::<f64, P>::new(
            m, &settings, k, t0
        )),
        3 => prove!(Subs, |m| crane_subs::StructuredRadau5::<f64, P>::new(
            m, &settings, t0
        )),
        4 => prove!(Subs, |m| crane_subs::RadauFull::<f64, P>::new(
            m, &settings, t0
        )),
        5 => prove!(Proj, |m| crane_proj::Bdf::<f64, P>::new(
            m, &settings, k, t0
        )),
        6 => prove!(Proj, |m| crane_proj::Radau5::<f64, P>::new(
            m, &settings, t0
        )),
        _ => prove!(Proj, |m| crane_proj::RadauFull::<f64, P>::new(
            m, &settings, t0
        )),
    }
}
