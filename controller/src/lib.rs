//! The firmware's portable logic, tested on the host.
//!
//! * [`board`] — the 100 Hz cycle every board runs, behind the one trait a board implements;
//! * [`drive`] — the driven axes (bridge, trolley, winch) and each crane's order of them;
//! * [`canopen`] — CiA 301 by specification: frames, NMT, EMCY codes;
//! * [`setpoint`] — m/s to drive units through the one set-point choke point;
//! * [`cia402`] — the drive state machine (enable sequence, quick stop, fault) and its PDOs;
//! * [`cia410`] — the inclinometer's PDO;
//! * [`feedforward`] — the inverse model behind a one-step-per-cycle trait, with its plan;
//! * [`commands`] — move, stop and reset requests, and the status answer;
//! * [`operator`] — the operator's speed-demand frame and its dead-man (manual mode);
//! * [`crane`] — what a crane is (drives, limits, reference, flat inverse), one file per crane;
//! * [`planner`] — the checks a move or a stop passes before it is accepted;
//! * `requests` — the supervisor's requests from arrival to answer (each answered once);
//! * [`correction`] — what stands between the inverse model and the drives, per crane;
//! * [`feedback`] — the state feedback around the inverse model (Fig. 1);
//! * [`crate::reference`] — the reference state of a vertical plane, from the inverse model;
//! * [`rope`] — the rope's true length learnt from the swing, a commissioning step;
//! * [`zero`] — the inclinometer's offset: the angle's DC that the pendulum cannot make;
//! * [`transmit`] — the transmit queue that keeps a cycle's frames in order and names every loss;
//! * [`controller`] — the 100 Hz cycle and the reaction to every fault, with injected time.
//!
//! The boards (QEMU, STM32H743) only move frames and call [`Controller::tick`]. The
//! simulation the QEMU board, the host tests and the fuzzer run it against (virtual bus,
//! scenarios, traffic, plant) is the crate `sim`.

#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

pub mod board;
pub mod canopen;
pub mod cia402;
pub mod cia410;
pub mod commands;
pub mod commissioning;
pub mod config;
pub mod controller;
pub mod correction;
pub mod crane;
mod derivatives;
pub mod drive;
pub mod fault;
pub mod feedback;
pub mod feedback3d;
pub mod feedforward;
pub mod frame;
mod links;
pub mod motion;
pub mod node;
pub mod operator;
pub mod planner;
pub mod range;
pub mod reference;
mod requests;
pub mod rope;
mod services;
pub mod setpoint;
pub mod transmit;
pub mod zero;

pub use controller::{Config, Controller, Counters, Cycle, Fault, Mode};
pub use feedforward::{Feedforward, FeedforwardStep, Injectable, InverseModel, Replan};
pub use frame::CanFrame;
