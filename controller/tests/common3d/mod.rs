//! The rig the 3D crane's controller tests share: the crane in three dimensions
//! (`Crane3dParams::EXAMPLE`) as the firmware's BDF4 inverse model with the structured
//! closed-form step at h = 10 ms, driven by a plan, and the commissioning of its three
//! CiA 402 drives (bridge 4, trolley 1, hoist 2).
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use controller::commissioning::{DriveSetup, NodeSetup};
use controller::drive::Drive;
use controller::{Config, Injectable, InverseModel};
use nalgebra::SVector;
use solver_core::models::crane3d::subs as crane3d;
use solver_core::models::crane3d::{Crane3dParams, Crane3dSubs};
use solver_core::plan::Plan;
use solver_core::{JacobianMode, SolverSettings};

pub type Model = Crane3dSubs<f64, Plan<f64, 3>>;
pub type Ff =
    Injectable<InverseModel<Model, crane3d::StructuredBdf<f64, Plan<f64, 3>>, f64, { crane3d::N }>>;

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
