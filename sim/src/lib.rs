//! The simulation beside the product, as embassy keeps its mock time driver apart: what
//! the QEMU firmware, the host tests, the virtual ECU and the fuzzer run the controller
//! against. The drive controller's own build (STM32H743) does not link it.
//!
//! * [`scenario`](mod@scenario) — the vocabulary of a run (timed supervisor requests, garbage, drive
//!   and sensor faults) and the named scenarios the QEMU checks replay;
//! * [`virtual_bus`] — simulated stock CiA 402 drives (and, with the feature `plant`, a
//!   CiA 410 inclinometer over a plant) that answer the controller frame by frame;
//! * [`traffic`] — random traffic for the soak run, deterministic for a seed;
//! * [`mismatch`] — how a plant differs from the model (lags, friction, rope offset,
//!   gusts, noisy late sensors), shared by every plant;
//! * [`plant`] — the planar crane that is not the model, for the closed-loop runs;
//! * [`angle_sensor`] — what a real inclinometer does to the swing it reports: a
//!   filter and a delay of its own;
//! * [`plant3d`] — the same for the 3D crane: bridge, trolley, hoist and a load
//!   swinging in both planes, read by a two-axis inclinometer;
//! * [`plant_dp`] — the hook-and-load crane: a double pendulum under trolley and winch,
//!   its inclinometer on the hook block;
//! * [`simulated`] — what a crane the bus simulates provides (its plant, built from its
//!   parameters, and what the plant's sensors read); each plant's file implements it.

#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod angle_sensor;
pub mod mismatch;
pub mod plant;
pub mod plant3d;
pub mod plant_dp;
pub mod scenario;
pub mod simulated;
pub mod traffic;
pub mod virtual_bus;

pub use scenario::{
    scenario, Action, Ending, Event, Quirk, RawFrame, Scenario, SensorFault, Stick, BRIDGE_FAULT,
    BUS_OFF, CLOSED_LOOP, CRANE3D_FEEDBACK_SCENARIOS, CRANE3D_SCENARIOS, CREEP, DRIVE_FAULT,
    FEEDBACK_SCENARIOS, GUST, HANG, HEALTHY, INCLINOMETER_LOST, INCLINOMETER_STUCK, LOST_HEARTBEAT,
    MANUAL_3D_SCENARIOS, MANUAL_DEADMAN, MANUAL_PROFILE, MANUAL_PROFILE_3D, MANUAL_SCENARIOS,
    MANUAL_TAKEOVER, MISMATCHED, NEWTON_FAILURE, REJECTIONS, SCENARIOS, SOAK, STICK_PERIOD_MS,
    STOP, STORM, TWO_MOVES,
};
#[cfg(feature = "plant")]
pub use virtual_bus::InclinometerSim;
pub use virtual_bus::{run_cycle, BusOff, DriveSim, VirtualBus};
