//! The rig the controller's tests share: the paper's crane (Tab. 3) as a BDF4 inverse
//! model with the exact Jacobian at h = 10 ms — the firmware's default scene — driven
//! by a plan, behind the controller, on the virtual bus with its simulated drives.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

pub mod manual;

use controller::drive::{Drive, PLANAR};
use controller::feedback::NoFeedback;
use controller::planner::Planner;
use controller::setpoint::{DriveLimits, UNITS_PER_M_PER_S};
use controller::{Config, Controller, Cycle, Injectable, InverseModel, Mode, Replan};
use nalgebra::SVector;
use scene::cranes::planar::Planar;
use sim::{run_cycle, Scenario, VirtualBus};
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::plan::Plan;
use solver_core::trajectory::{PointToPoint, Trajectory};
use solver_core::{JacobianMode, NewtonSettings, SolverSettings};

pub type Model = CraneSubs<f64, Plan<f64, 2>>;
pub type Ff = Injectable<
    InverseModel<Planar, Model, crane_subs::Bdf<f64, Plan<f64, 2>>, f64, { crane_subs::N }>,
>;

/// Where the crane rests when a test starts: the paper's start (x_C, z_C), m.
pub const HOME: [f64; 2] = [12.0, 8.0];

pub fn settings() -> SolverSettings {
    SolverSettings {
        h: 0.01,
        jacobian: JacobianMode::Exact,
        scaling_power: 2,
        newton: NewtonSettings::for_scalar::<f64>(),
    }
}

pub fn planner() -> Planner<Planar, 2> {
    Planner::with_axes(Planar::PAPER, DriveLimits::LAB.axes())
}

/// The inverse model at rest at `home` from t = 0, with `first` (end, start, duration) planned.
pub fn feedforward(home: [f64; 2], first: Option<([f64; 2], f64, f64)>) -> Ff {
    let mut plan = controller::crane::command_plan::<Planar, 2>(home, 4).unwrap();
    if let Some((end, t_start, duration)) = first {
        let m = PointToPoint::new(
            SVector::from(home),
            SVector::from(end),
            t_start,
            duration,
            4,
        )
        .unwrap();
        plan.push(m).unwrap();
    }
    let model = CraneSubs::new(CraneParams::PAPER, plan).unwrap();
    let integrator = crane_subs::Bdf::new(&model, &settings(), 4, 0.0).unwrap();
    Injectable::new(InverseModel::new(model, integrator))
}

/// The controller, the bus and the clock, advanced together as the firmware does.
pub struct Rig {
    pub c: Controller<Ff, NoFeedback, Planar, 2>,
    pub bus: VirtualBus<Planar, 2>,
    /// Time of the next cycle, ms.
    pub now: u32,
}

impl Rig {
    /// The paper's move planned from `HOME` (or nothing), on `scenario`.
    pub fn new(scenario: Scenario, paper_move: bool) -> Self {
        let first = paper_move.then_some(([20.0, 4.0], 1.0, 8.0));
        Self::with(feedforward(HOME, first), scenario)
    }

    pub fn with(ff: Ff, scenario: Scenario) -> Self {
        Self::configured(ff, scenario, Config::DEFAULT)
    }

    /// With another configuration (role, nodes, timeouts).
    pub fn configured(ff: Ff, scenario: Scenario, config: Config) -> Self {
        // The simulated drives stand where the model starts: the load at rest there.
        let [start]: [SVector<f64, 2>; 1] = ff.plan().derivatives(0.0);
        Self {
            c: Controller::new(ff, planner(), config),
            bus: VirtualBus::new(scenario, start.into()),
            now: 0,
        }
    }

    /// `frame` received now: how it was counted, `(received, ignored)` (each 0 or 1).
    pub fn counted(&mut self, frame: &controller::CanFrame) -> (u32, u32) {
        let before = self.c.counters();
        self.c.on_frame(frame, self.now.into());
        let after = self.c.counters();
        (
            after.frames_received - before.frames_received,
            after.frames_ignored - before.frames_ignored,
        )
    }

    /// One cycle.
    pub fn cycle(&mut self) -> Cycle {
        self.try_cycle().expect("only the hang scenario hangs")
    }

    /// One cycle, or `None` where the scenario hangs the firmware.
    pub fn try_cycle(&mut self) -> Option<Cycle> {
        let out = run_cycle(&mut self.c, &mut self.bus, self.now)?;
        self.now += 10;
        Some(out)
    }

    /// Cycles until `stop` holds for a cycle's output (at most `max`); all outputs.
    pub fn until(&mut self, max: usize, mut stop: impl FnMut(&Cycle) -> bool) -> Vec<Cycle> {
        let mut outs = Vec::new();
        for _ in 0..max {
            let out = self.cycle();
            let done = stop(&out);
            outs.push(out);
            if done {
                return outs;
            }
        }
        panic!(
            "condition not reached within {max} cycles; mode {:?}",
            self.c.mode()
        );
    }

    /// Runs `n` cycles.
    pub fn run(&mut self, n: usize) -> Vec<Cycle> {
        (0..n).map(|_| self.cycle()).collect()
    }

    /// Cycles until the drives are enabled and the controller is ready.
    pub fn ready(&mut self) -> Vec<Cycle> {
        self.until(120, |c| c.mode == Mode::Ready)
    }

    /// Trolley position and rope length in the model, m (the load's position at rest).
    pub fn drives(&self) -> [f64; 2] {
        let x = self.c.feedforward().inner.integrator.state();
        [x[0], x[1]]
    }
}

/// Every set point of `cycles` is finite and within the limits, and no consecutive pair
/// changes faster than the acceleration limit allows (one drive unit of rounding).
pub fn assert_within_limits(cycles: &[Cycle], last: &mut [i32; 2]) {
    let limits = DriveLimits::LAB;
    for (n, out) in cycles.iter().enumerate() {
        for (i, d) in PLANAR.into_iter().enumerate() {
            let v = out.setpoints[i].units();
            let l = limits.axes()[i];
            assert!(
                f64::from(v.abs()) <= l.max_velocity * UNITS_PER_M_PER_S,
                "cycle {n}: {d:?} at {v} units"
            );
            let dv = f64::from(v - last[i]);
            assert!(
                dv.abs() <= l.max_acceleration * 0.01 * UNITS_PER_M_PER_S + 1.0,
                "cycle {n}: {d:?} jumps by {dv} units"
            );
            last[i] = v;
        }
    }
}

/// `(controlword, target velocity)` of a drive's RPDO in `frames`.
pub fn rpdo(frames: &[controller::CanFrame], drive: Drive) -> (u16, i32) {
    let id = controller::canopen::cob::RPDO1 + u16::from(drive.node());
    let f = frames
        .iter()
        .find(|f| f.id() == id)
        .expect("an RPDO per drive every cycle");
    let d = f.data();
    (
        u16::from_le_bytes([d[0], d[1]]),
        i32::from_le_bytes([d[2], d[3], d[4], d[5]]),
    )
}

/// The controller's status frame in `frames`, if sent.
pub fn status(frames: &[controller::CanFrame]) -> Option<[u8; 8]> {
    frames
        .iter()
        .find(|f| f.id() == controller::commands::STATUS_ID)
        .map(|f| f.data().try_into().unwrap())
}

/// The controller's EMCY in `frames`: (error code, register, fault byte, node byte).
pub fn emcy(frames: &[controller::CanFrame]) -> Option<(u16, u8, u8, u8)> {
    frames.iter().find(|f| f.id() == 0x090).map(|f| {
        let d = f.data();
        (u16::from_le_bytes([d[0], d[1]]), d[2], d[3], d[4])
    })
}

/// The detail byte of the controller's EMCY in `frames` (why a set point was refused,
/// which solver failure).
pub fn emcy_detail(frames: &[controller::CanFrame]) -> Option<u8> {
    frames.iter().find(|f| f.id() == 0x090).map(|f| f.data()[5])
}

/// The answers given, in order: (request id, answer, reason), from the status frames.
pub fn answers(cycles: &[Cycle]) -> Vec<(u8, u8, u8)> {
    let mut out: Vec<(u8, u8, u8)> = Vec::new();
    for s in cycles.iter().filter_map(|c| status(&c.frames)) {
        let a = (s[0], s[1], s[2]);
        if a.1 != 0 && out.last() != Some(&a) {
            out.push(a);
        }
    }
    out
}

/// The modes the controller went through, with the time each began, ms.
pub fn modes(cycles: &[Cycle]) -> Vec<(u32, Mode)> {
    let mut out: Vec<(u32, Mode)> = Vec::new();
    for (i, c) in cycles.iter().enumerate() {
        if out.last().map(|(_, m)| *m) != Some(c.mode) {
            out.push((i as u32 * 10, c.mode));
        }
    }
    out
}

/// Every EMCY the controller sent, with its time, ms.
pub fn emcys(cycles: &[Cycle]) -> Vec<(u32, (u16, u8, u8, u8))> {
    cycles
        .iter()
        .enumerate()
        .filter_map(|(i, c)| emcy(&c.frames).map(|e| (i as u32 * 10, e)))
        .collect()
}

/// The controller's EMCYs (0x090) among `cycles`' frames, in order, each as its 8
/// bytes; with `code`, only those with that error code.
pub fn emcy_frames<const A: usize>(cycles: &[Cycle<A>], code: Option<u16>) -> Vec<[u8; 8]> {
    cycles
        .iter()
        .flat_map(|c| c.frames.iter())
        .filter(|f| f.id() == 0x090)
        .filter(|f| code.is_none_or(|code| f.data()[..2] == code.to_le_bytes()))
        .map(|f| f.data().try_into().unwrap())
        .collect()
}

/// Sends `request` to the controller (received before the next cycle).
pub fn send(rig: &mut Rig, request: controller::commands::Request) {
    rig.c.on_frame(
        &controller::commands::request_frame(&request),
        u64::from(rig.now),
    );
}

/// Every status frame's answer, in order (the periodic ones repeat the last answer).
pub fn every_answer(cycles: &[Cycle]) -> Vec<(u8, u8, u8)> {
    cycles
        .iter()
        .flat_map(|c| c.frames.iter())
        .filter(|f| f.id() == controller::commands::STATUS_ID)
        .map(|f| (f.data()[0], f.data()[1], f.data()[2]))
        .collect()
}

/// A property test's settings: `default` cases unless `PROPTEST_CASES` says otherwise,
/// no persisted failures (a failure prints its minimal input).
pub fn property_config(default: u32) -> proptest::test_runner::Config {
    let cases = std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|c| c.parse().ok())
        .unwrap_or(default);
    proptest::test_runner::Config {
        cases,
        failure_persistence: None,
        ..proptest::test_runner::Config::default()
    }
}

/// The crane (Eqs. 21-22, the paper's parameters) driven by the set points `cycles`
/// sent, from rest with the load at `home`, the first cycle at `t_first` s (sample n + 1
/// is the set point sent in cycle n, the model's input at the end of that step), then
/// 2 s at zero so that any swing left shows: `each(t, state)` at every output time.
pub fn simulate_sent(
    cycles: &[Cycle],
    t_first: f64,
    home: [f64; 2],
    each: impl FnMut(f64, &SVector<f64, 6>),
) -> Result<(), String> {
    use solver_core::reference::plant::{crane_rhs, simulate, SampledInput};
    let mut u: Vec<SVector<f64, 2>> = vec![SVector::zeros()];
    u.extend(cycles.iter().map(|c| {
        SVector::from(
            c.setpoints
                .map(|s| f64::from(s.units()) / UNITS_PER_M_PER_S),
        )
    }));
    u.extend(std::iter::repeat_n(SVector::zeros(), 200));
    let p = CraneParams::PAPER;
    let y0 = SVector::from([home[0], home[1], 0.0, 0.0, 0.0, 0.0]);
    let mut each = each;
    simulate(
        |y, u| crane_rhs(&p, y, u),
        y0,
        &SampledInput::new(t_first, 0.01, &u),
        |_, t, y| each(t, y),
    )
    .map_err(|e| e.to_string())
}

/// An expedited SDO download's request: `value` (1–4 bytes) into `index:sub`.
pub fn download(index: u16, sub: u8, value: &[u8]) -> [u8; 8] {
    let [i0, i1] = index.to_le_bytes();
    let mut data = [
        0x23 | ((4 - value.len() as u8) << 2),
        i0,
        i1,
        sub,
        0,
        0,
        0,
        0,
    ];
    data[4..4 + value.len()].copy_from_slice(value);
    data
}
