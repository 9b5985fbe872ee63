//! Link-time proof that the firmware's portable logic cannot panic.
//!
//! `panic-never` is this binary's panic handler: it calls a symbol that does not exist,
//! so the link fails if any panicking branch survives optimisation. The binary drives
//! every entry point the firmware calls — `Controller::restarted_by_watchdog`,
//! `demonstration_commanded`, `on_frame`, `tick`, `record_cost`, `transmit_failed` — for
//! every model and scheme a scene can choose — the list comes from the firmware's one
//! registration of them (`scene::dispatch::FirmwareScheme::every`, through the build
//! script): the planar crane *subs* and *proj*, the 3D crane and the hook-and-load crane,
//! each *subs* also on its `Steered` path with the operator's generator (manual mode),
//! BDF with the run-time
//! modes and the structured exact Newton, Radau IIA, every Jacobian mode through the
//! settings — with and without the state feedback (its gain design included; the 3D
//! crane's per vertical plane with the two-axis inclinometer), with every input
//! (frames, times, costs, settings, parameters, the first move) hidden behind
//! `black_box`, so that nothing is proven for constants only.
//! Built with the firmware's release profile for the drive's target:
//! `cargo xtask panic-proof`. What it does not cover — the board, RTIC and defmt — is
//! listed path by path in docs/PANICS.md.
#![no_std]
#![no_main]

use core::hint::black_box;

use controller::commissioning::{DriveSetup, InclinometerSetup, NodeSetup};
use controller::correction::AxesCorrection;
use controller::crane::command_plan;
use controller::drive::Drive;
use controller::feedback::{self, NoFeedback, StateFeedback};
use controller::feedback3d::SpatialFeedback;
use controller::operator::path::{Source, Steered};
use controller::planner::{Crane, Planner};
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
use solver_core::models::crane3d::Crane3dParams;
use solver_core::models::double_pendulum_crane::DoublePendulumParams;
use solver_core::operator::{Generator3d, PlanarGenerator, Settings};
use solver_core::plan::Plan;
use solver_core::trajectory::PointToPoint;
use solver_core::{Error, JacobianMode, SolverSettings};

/// A crane the firmware drives, as the proof runs it: its parameters, its first plan
/// (rest, then a move) and its controller, all from opaque inputs.
trait Proven<const A: usize>: Crane<A> + Sized {
    /// The crane's parameters, opaque.
    fn params() -> Self;
    /// The first plan: rest, then a move, from opaque inputs.
    fn plan() -> Result<Plan<f64, A>, Error>;
    /// The controller on `feedforward` (with the state feedback where the crane has one,
    /// as the scene says), its entry points run on opaque inputs.
    fn run<F: Feedforward<A, Reference = Self::Reference> + Replan<A>>(feedforward: F) -> !;
}

/// The first plan of a crane resting at `start`, moving to `end` with smoothness `n`
/// (opaque).
fn plan_of<K: Crane<A>, const A: usize>(
    start: [f64; A],
    end: [f64; A],
    n: usize,
) -> Result<Plan<f64, A>, Error> {
    let (start, end) = black_box((start, end));
    let [t0, d]: [f64; 2] = black_box([1.0, 8.0]);
    let n: usize = black_box(n);
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

impl Proven<2> for CraneParams {
    fn params() -> Self {
        black_box(CraneParams::PAPER)
    }
    fn plan() -> Result<Plan<f64, 2>, Error> {
        plan_of::<Self, 2>([12.0, 8.0], [20.0, 4.0], 4)
    }
    fn run<F: Feedforward<Reference = Self::Reference> + Replan>(feedforward: F) -> ! {
        let limits: DriveLimits = black_box(DriveLimits::LAB);
        let config: Config = black_box(Config::DEFAULT);
        let planner = Planner::new(Self::params(), limits);
        if black_box(true) {
            let Ok(feedback) = StateFeedback::new(black_box(feedback::Config::PAPER)) else {
                halt()
            };
            let config =
                config.with_node(NodeSetup::Inclinometer(black_box(InclinometerSetup::STOCK)));
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
}

/// The 3D crane, with and without its state feedback per vertical plane (the
/// two-axis inclinometer on node 5).
impl Proven<3> for Crane3dParams {
    fn params() -> Self {
        black_box(Crane3dParams::EXAMPLE)
    }
    fn plan() -> Result<Plan<f64, 3>, Error> {
        plan_of::<Self, 3>([12.0, 3.0, 8.0], [20.0, 6.0, 4.0], 4)
    }
    fn run<F: Feedforward<3, Reference = Self::Reference> + Replan<3>>(feedforward: F) -> ! {
        let limits = black_box(DriveLimits::LAB_3D);
        let bridge = DriveSetup {
            node: 4,
            ..DriveSetup::TROLLEY
        };
        let config: Config = black_box(
            Config::DEFAULT.with_node(NodeSetup::Drive(Drive::Bridge, black_box(bridge))),
        );
        let planner = Planner::with_axes(Self::params(), limits);
        if black_box(true) {
            let tau_trolley: f64 = black_box(Self::params().tau2);
            let Ok(feedback) =
                SpatialFeedback::new(black_box(feedback::Config::PAPER), tau_trolley)
            else {
                halt()
            };
            let config = config.with_node(NodeSetup::Inclinometer(black_box(
                InclinometerSetup::STOCK_TWO_AXES,
            )));
            drive(Controller::with_correction(
                feedforward,
                feedback,
                planner,
                config,
            ))
        } else {
            drive(Controller::with_correction(
                feedforward,
                NoFeedback,
                planner,
                config,
            ))
        }
    }
}

/// The hook-and-load crane: feedforward only (it has no loop), its move of smoothness 7
/// (its inputs contain the path's sixth derivative).
impl Proven<2> for DoublePendulumParams {
    fn params() -> Self {
        black_box(DoublePendulumParams::EXAMPLE)
    }
    fn plan() -> Result<Plan<f64, 2>, Error> {
        plan_of::<Self, 2>([12.0, 8.0], [20.0, 4.0], 7)
    }
    fn run<F: Feedforward<2, Reference = Self::Reference> + Replan<2>>(feedforward: F) -> ! {
        let limits = black_box(<Self as Crane<2>>::LAB_LIMITS);
        let config: Config = black_box(Config::DEFAULT);
        let planner = Planner::with_axes(Self::params(), limits);
        drive(Controller::with_correction(
            feedforward,
            NoFeedback,
            planner,
            config,
        ))
    }
}

/// A crane whose firmware may have manual mode: the operator generator's settings, opaque.
trait ProvenManual<const A: usize>: Proven<A> {
    /// The generator.
    type Generator: Source<A>;
    /// Its settings: the lab's, opaque.
    fn operator() -> <Self::Generator as Source<A>>::Settings;
}

impl ProvenManual<2> for CraneParams {
    type Generator = PlanarGenerator;
    fn operator() -> Settings<1> {
        black_box(Settings::lab(&Self::params()))
    }
}

impl ProvenManual<3> for Crane3dParams {
    type Generator = Generator3d;
    fn operator() -> Settings<2> {
        black_box(Settings::lab_3d(&Self::params()))
    }
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

/// Builds the crane `$crane`'s model `$model` on its first plan and the integrator
/// `$integrator` on it (`$new`, with the model as `$m` and `settings`, `k`, `t0` in
/// scope), then runs the controller on them.
macro_rules! prove {
    ($crane:ty, $axes:literal, $model:ty, $integrator:ty, |$m:ident| $new:expr) => {{
        type Integrator = $integrator;
        let Ok(plan) = <$crane as Proven<$axes>>::plan() else {
            halt()
        };
        let Ok($m) = <$model>::new(<$crane as Proven<$axes>>::params(), plan) else {
            halt()
        };
        let Ok(integrator) = ($new) else { halt() };
        <$crane as Proven<$axes>>::run(InverseModel::new($m, integrator))
    }};
}

/// [`prove!`] with the model on the crane's `Steered` path: the plan, or in manual mode
/// (entered by an operator frame, opaque as every frame) the operator's generator.
macro_rules! prove_steered {
    ($crane:ty, $axes:literal, $model:ty, $integrator:ty, |$m:ident| $new:expr) => {{
        type Integrator = $integrator;
        let Ok(plan) = <$crane as Proven<$axes>>::plan() else {
            halt()
        };
        let path = Steered::new(plan, <$crane as ProvenManual<$axes>>::operator());
        let Ok($m) = <$model>::new(<$crane as Proven<$axes>>::params(), path) else {
            halt()
        };
        let Ok(integrator) = ($new) else { halt() };
        <$crane as Proven<$axes>>::run(InverseModel::new($m, integrator))
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
