//! The rig the 3D crane's controller tests share: the crane in three dimensions
//! (`Crane3dParams::EXAMPLE`) as the firmware's BDF4 inverse model with the structured
//! closed-form step at h = 10 ms, driven by a plan, the commissioning of its three
//! CiA 402 drives (bridge 4, trolley 1, hoist 2), and the controller on the virtual bus
//! with them.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use controller::commissioning::{DriveSetup, NodeSetup};
use controller::drive::{Drive, SPATIAL};
use controller::feedback::NoFeedback;
use controller::planner::Planner;
use controller::setpoint::{AxisLimits, DriveLimits};
use controller::{Config, Controller, Cycle, Injectable, InverseModel, Mode};
use nalgebra::SVector;
use scene::cranes::spatial::Spatial;
use sim::{run_cycle, VirtualBus, HEALTHY};
use solver_core::models::crane3d::subs as crane3d;
use solver_core::models::crane3d::{Crane3dParams, Crane3dSubs};
use solver_core::plan::Plan;
use solver_core::{JacobianMode, SolverSettings};

pub type Model = Crane3dSubs<f64, Plan<f64, 3>>;
pub type Ff = Injectable<
    InverseModel<Spatial, Model, crane3d::StructuredBdf<f64, Plan<f64, 3>>, f64, { crane3d::N }>,
>;

/// Where the load rests at the start: bridge x, trolley y, rope length l, m.
pub const HOME: [f64; 3] = [12.0, 3.0, 8.0];
/// The bridge's stock node.
pub const BRIDGE_NODE: u8 = 4;

/// The commissioning file of a 3D crane: bridge, trolley and winch drives.
pub fn config() -> Config {
    let bridge = DriveSetup {
        node: BRIDGE_NODE,
        ..DriveSetup::TROLLEY
    };
    let trolley = DriveSetup {
        max_velocity: 2_200_000,
        ..DriveSetup::TROLLEY
    };
    Config {
        nodes: [
            Some(NodeSetup::Drive(Drive::Bridge, bridge)),
            Some(NodeSetup::Drive(Drive::Trolley, trolley)),
            Some(NodeSetup::Drive(Drive::Winch, DriveSetup::WINCH)),
            None,
        ],
        ..Config::DEFAULT
    }
}

/// The inverse model at rest at [`HOME`] at t = 0.
pub fn feedforward() -> Ff {
    let plan = Plan::at_rest(SVector::from(HOME), 5).unwrap();
    let model = Crane3dSubs::new(Crane3dParams::EXAMPLE, plan).unwrap();
    let settings = SolverSettings {
        h: 0.01,
        ..SolverSettings::paper(JacobianMode::Exact)
    };
    let integrator = crane3d::StructuredBdf::new(&model, &settings, 4, 0.0).unwrap();
    Injectable::new(InverseModel::new(model, integrator))
}

pub type Crane3dController = Controller<Ff, NoFeedback, Spatial, 3>;

/// The 3D crane's lab drives' limits (bridge, trolley, hoist).
pub fn limits() -> [AxisLimits; 3] {
    DriveLimits::LAB_3D
}

/// The controller, the bus with the three drives at [`HOME`], and the clock.
pub struct Rig {
    pub c: Crane3dController,
    pub bus: VirtualBus<Spatial, 3>,
    /// Time of the next cycle, ms.
    pub now: u32,
}

impl Rig {
    pub fn new() -> Self {
        let ff = feedforward();
        let planner = Planner::with_axes(Spatial::EXAMPLE, limits());
        Self {
            c: Controller::with_correction(ff, NoFeedback, planner, config()),
            bus: VirtualBus::for_crane(HEALTHY, &Spatial::EXAMPLE, HOME),
            now: 0,
        }
    }

    pub fn cycle(&mut self) -> Cycle<3> {
        let out = run_cycle(&mut self.c, &mut self.bus, self.now).unwrap();
        self.now += 10;
        out
    }

    pub fn run(&mut self, n: usize) -> Vec<Cycle<3>> {
        (0..n).map(|_| self.cycle()).collect()
    }

    pub fn ready(&mut self) {
        for _ in 0..200 {
            if self.cycle().mode == Mode::Ready {
                return;
            }
        }
        panic!("not ready: {:?}", self.c.mode());
    }

    /// The drives' positions (bridge, trolley, rope), m.
    pub fn positions(&self) -> [f64; 3] {
        SPATIAL.map(|d| self.bus.drive(d).unwrap().position())
    }
}
