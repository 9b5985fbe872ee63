//! Link-time proof that the firmware's portable logic cannot panic.
//!
//! `panic-never` is this binary's panic handler: it calls a symbol that does not exist,
//! so the link fails if any panicking branch survives optimisation. The binary drives
//! every entry point the firmware calls — `Controller::restarted_by_watchdog`,
//! `demonstration_commanded`, `on_frame`, `tick`, `record_cost`, `transmit_failed` — for
//! every model and scheme a scene can choose — the list comes from the firmware's one
//! registration of them (`scene::dispatch::FirmwareScheme::every`, through the build
//! script): every registered crane's formulations, each that runs manual mode also on
//! its crane's `Steered` path with the operator's generator, with every integrator and
//! Newton strategy the firmware links and every Jacobian mode through the settings —
//! each with and without its crane's state feedback where the crane has one (its gain
//! design included), with every input (frames, times, costs, settings, parameters,
//! limits, the configuration, the first move) hidden behind
//! `black_box`, so that nothing is proven for constants only.
//! Built with the firmware's release profile for the drive's target:
//! `cargo xtask panic-proof`. What it does not cover — the board, RTIC and defmt — is
//! listed path by path in docs/PANICS.md.
#![no_std]
#![no_main]

use core::hint::black_box;

use controller::commissioning::{InclinometerSetup, NodeSetup};
use controller::correction::AxesCorrection;
use controller::crane::command_plan;
use controller::feedback::{self, DesignError};
use controller::operator::path::Steered;
use controller::planner::{Crane, Planner};
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
use solver_core::plan::Plan;
use solver_core::trajectory::PointToPoint;
use solver_core::{Error, JacobianMode, SolverSettings};

/// The first plan of `crane`: rest, then a move, the load carried from where it hangs
/// with its drives a third into each range to where it hangs with them two thirds in, at
/// the crane's least command smoothness — every value opaque, so that the proof holds for
/// whatever plan the firmware's scene gives.
fn first_plan<K: Crane<A>, const A: usize>(crane: &K) -> Result<Plan<f64, A>, Error> {
    let ranges = crane.ranges();
    let start = crane.load_at_rest(ranges.map(|(lo, hi)| lo + (hi - lo) / 3.0));
    let end = crane.load_at_rest(ranges.map(|(lo, hi)| hi - (hi - lo) / 3.0));
    let (start, end) = black_box((start, end));
    let [t0, d]: [f64; 2] = black_box([1.0, 8.0]);
    let n: usize = black_box(K::MIN_COMMAND_SMOOTHNESS);
    let mut plan = command_plan::<K, A>(start, n)?;
    plan.push(PointToPoint::new(
        SVector::from(start),
        SVector::from(end),
        t0,
        d,
        n,
    )?)?;
    Ok(plan)
}

/// The controller of `crane` on `feedforward`, its drives at the crane's lab limits: in
/// one opaque branch with the correction `C` that `correction` designs from `crane` and
/// `feedback` (its state feedback, the stock inclinometer of as many axes as its swing),
/// in the other with `N`, the crane's correction of a scene without feedback (none).
/// Every value is opaque.
fn run_with_correction<K, F, C, N, const A: usize>(
    crane: K,
    feedback: feedback::Config,
    feedforward: F,
    correction: impl FnOnce(K, feedback::Config) -> Result<C, DesignError>,
) -> !
where
    K: Crane<A> + Copy,
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    N: AxesCorrection<A, K::Reference> + Default,
{
    if black_box(true) {
        let planner = Planner::with_axes(black_box(crane), black_box(K::LAB_LIMITS));
        let Ok(correction) = correction(black_box(crane), black_box(feedback)) else {
            halt()
        };
        let inclinometer = black_box(InclinometerSetup::stock(K::SWING_AXES));
        let config = black_box(Config::DEFAULT).with_node(NodeSetup::Inclinometer(inclinometer));
        drive(Controller::with_correction(
            feedforward,
            correction,
            planner,
            config,
        ))
    } else {
        run_feedforward::<K, F, N, A>(crane, feedforward)
    }
}

/// The controller of `crane` on `feedforward` with `N`, the crane's correction of a scene
/// without feedback (none), its drives at the crane's lab limits; every value opaque.
fn run_feedforward<K, F, N, const A: usize>(crane: K, feedforward: F) -> !
where
    K: Crane<A>,
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    N: AxesCorrection<A, K::Reference> + Default,
{
    let planner = Planner::with_axes(black_box(crane), black_box(K::LAB_LIMITS));
    let config: Config = black_box(Config::DEFAULT);
    drive(Controller::with_correction(
        feedforward,
        N::default(),
        planner,
        config,
    ))
}

/// Runs the controller's entry points on opaque inputs, forever.
fn drive<F, C, K, const A: usize>(mut controller: Controller<F, C, K, A>) -> !
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: Crane<A>,
{
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

/// Builds the model `$model` of the crane the generated module `$crane` describes on its
/// first plan and the integrator `$integrator` on it (`$new`, with the model as `$m` and
/// `settings`, `k`, `t0` in scope), then runs that crane's controller on them.
macro_rules! prove {
    ($crane:ident, $model:ty, $integrator:ty, |$m:ident| $new:expr) => {{
        type Integrator = $integrator;
        let params = black_box($crane::EXAMPLE);
        let Ok(plan) = first_plan(&params) else {
            halt()
        };
        let Ok($m) = <$model>::new(params.0, plan) else {
            halt()
        };
        let Ok(integrator) = ($new) else { halt() };
        $crane::run(InverseModel::new($m, integrator))
    }};
}

/// [`prove!`] with the model on the crane's `Steered` path: the plan, or in manual mode
/// (entered by an operator frame, opaque as every frame) the operator's generator with
/// the crane's settings (`$crane::OPERATOR`, opaque).
macro_rules! prove_steered {
    ($crane:ident, $model:ty, $integrator:ty, |$m:ident| $new:expr) => {{
        type Integrator = $integrator;
        let params = black_box($crane::EXAMPLE);
        let Ok(plan) = first_plan(&params) else {
            halt()
        };
        let path = Steered::new(plan, black_box($crane::OPERATOR));
        let Ok($m) = <$model>::new(params.0, path) else {
            halt()
        };
        let Ok(integrator) = ($new) else { halt() };
        $crane::run(InverseModel::new($m, integrator))
    }};
}

include!(concat!(env!("OUT_DIR"), "/proofs.rs"));

/// Every integrator the firmware can link (`scene::dispatch::FirmwareScheme::every`, the
/// build script's list), for the crane it drives.
#[entry]
fn main() -> ! {
    let settings: SolverSettings = black_box(SolverSettings::paper(JacobianMode::Exact));
    let k: usize = black_box(4);
    let t0: f64 = black_box(0.0);
    prove_every(black_box(0), settings, k, t0)
}
