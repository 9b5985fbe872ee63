//! What the fuzz targets share: the firmware of the default scene
//! (`scene::firmware::DEFAULT_SCENE`: the paper's crane on its minimally extended
//! formulation *ext*, BDF4 with the exact Jacobian at h = 10 ms; `fuzz/build.rs` writes its
//! types from the registry) behind the controller, and checks of what the controller sends.

use controller::canopen::cob;
use controller::commissioning::{InclinometerSetup, NodeSetup};
use controller::crane::command_plan;
use controller::drive::PLANAR;
use controller::feedback::{self, Correction, NoFeedback, StateFeedback};
use controller::planner::Planner;
use controller::setpoint::DriveLimits;
use controller::{CanFrame, Config, Controller, Injectable, InverseModel};
use nalgebra::SVector;
use sim::{run_cycle, Scenario, VirtualBus, CLOSED_LOOP, HEALTHY};
use solver_core::trajectory::PointToPoint;

/// The default scene's model, integrator and settings as the firmware links them
/// (`build.rs`, from `scene::dispatch`).
mod default_scene {
    #![allow(dead_code)]
    include!(concat!(env!("OUT_DIR"), "/default_scene.rs"));
}
pub use default_scene::{Crane, Integrator, Model, SETTINGS};

/// Model, integrator and the solver-failure injection.
pub type Feedforward =
    Injectable<InverseModel<Crane, Model, Integrator, f64, { default_scene::N }>>;

/// Where the crane rests at power-up: the paper's start (x_C, z_C), m.
pub const HOME: [f64; 2] = [12.0, 8.0];

/// The planner with the lab drives' limits.
pub const PLANNER: Planner<Crane, 2> =
    Planner::with_axes(default_scene::PARAMS, DriveLimits::LAB.axes());

/// The paper's move (12, 8) → (20, 4) from 1 s to 9 s, or rest at (12, 8).
pub fn feedforward(paper_move: bool) -> Feedforward {
    let home = HOME;
    let mut plan = command_plan::<Crane, 2>(home, 4).expect("valid plan");
    if paper_move {
        let m = PointToPoint::new(SVector::from(home), SVector::from([20.0, 4.0]), 1.0, 8.0, 4)
            .expect("the paper's move");
        plan.push(m).expect("fits the plan");
    }
    let model = Model::new(default_scene::PARAMS.0, plan).expect("the default scene's crane");
    let integrator = default_scene::integrator(&model).expect("the firmware's integrator");
    Injectable::new(InverseModel::new(model, integrator))
}

/// The controller and its bus, advanced together as the firmware does.
pub struct Rig<C = NoFeedback> {
    /// The controller.
    pub controller: Controller<Feedforward, C, Crane, 2>,
    /// The simulated drives.
    pub bus: VirtualBus<Crane, 2>,
    /// Cycles run.
    pub cycle: u32,
}

impl Rig<StateFeedback> {
    /// The controller with the state feedback (the inclinometer at node 3) and the paper's
    /// move planned as the main job's command, on the plant of `CLOSED_LOOP`, after
    /// `cycles` cycles.
    pub fn closed_loop(cycles: u32) -> Self {
        let feedback = StateFeedback::new(feedback::Config::PAPER).expect("the study's gains");
        let config = Config::DEFAULT.with_node(NodeSetup::Inclinometer(InclinometerSetup::STOCK));
        let mut controller =
            Controller::with_correction(feedforward(true), feedback, PLANNER, config);
        controller.demonstration_commanded();
        let mut rig = Self {
            controller,
            bus: VirtualBus::new(CLOSED_LOOP, HOME),
            cycle: 0,
        };
        for _ in 0..cycles {
            rig.step();
        }
        rig
    }
}

impl Rig {
    /// The controller with the paper's move planned, on `scenario`'s bus.
    pub fn new(scenario: Scenario) -> Self {
        Self {
            controller: Controller::new(feedforward(true), PLANNER, Config::DEFAULT),
            bus: VirtualBus::new(scenario, HOME),
            cycle: 0,
        }
    }

    /// The healthy rig after `cycles` cycles (from 75 cycles on the drives are commissioned
    /// and enabled; the paper's move runs from 100 to 900).
    pub fn after(cycles: u32) -> Self {
        let mut rig = Self::new(HEALTHY);
        for _ in 0..cycles {
            rig.step();
        }
        rig
    }
}

impl<C: Correction> Rig<C> {
    /// Time of the next cycle, ms.
    pub fn now_ms(&self) -> u32 {
        self.cycle * 10
    }

    /// One cycle; its set points, drive units.
    pub fn step(&mut self) -> controller::Cycle {
        let now = self.now_ms();
        let out = run_cycle(&mut self.controller, &mut self.bus, now)
            .expect("the fuzzed bus does not hang");
        self.cycle += 1;
        out
    }
}

/// Fuzzed traffic: each event runs its gap of cycles, then its frame (the id through
/// `target`, which points half of them at what a target studies) arrives; then 100
/// cycles more. Every cycle's set points must be admissible ([`assert_admissible`]).
pub fn under_traffic<C: Correction>(
    rig: &mut Rig<C>,
    events: &[(u8, u16, Vec<u8>)],
    target: impl Fn(u16) -> u16,
) {
    let mut last = [0i64; 2];
    for (gap, id, data) in events.iter().take(32) {
        for _ in 0..*gap {
            let out = rig.step();
            assert_admissible(&out.frames, &mut last);
        }
        if let Ok(frame) = CanFrame::new(target(*id), data) {
            rig.controller.on_frame(&frame, u64::from(rig.now_ms()));
        }
    }
    for _ in 0..100 {
        let out = rig.step();
        assert_admissible(&out.frames, &mut last);
    }
}

/// Panics unless every RPDO in `frames` is within the drive limits, and within the
/// acceleration limit against `last` (updated).
pub fn assert_admissible(frames: &[CanFrame], last: &mut [i64; 2]) {
    let limits = DriveLimits::LAB;
    for f in frames {
        for (i, d) in PLANAR.into_iter().enumerate() {
            if f.id() == cob::RPDO1 + u16::from(d.node()) {
                let b = f.data();
                assert_eq!(b.len(), 6, "RPDO length");
                let v = i64::from(i32::from_le_bytes([b[2], b[3], b[4], b[5]]));
                let l = limits.axes()[i];
                assert!(v.abs() as f64 <= l.max_velocity * 1e6, "{d:?} at {v}");
                let step = (v - last[i]).abs() as f64;
                assert!(
                    step <= l.max_acceleration * 0.01 * 1e6 + 1.0,
                    "{d:?} jumps by {step}"
                );
                last[i] = v;
            }
        }
    }
}
