//! Manual mode on the 3D crane (issue 28): the operator's generator drives the 3D
//! crane's inverse model (bridge, trolley, hoist) on the virtual bus — the same
//! controller code as the planar crane's, generic over the crane.

mod common;
mod common3d;

use common3d::{config, limits, HOME};
use controller::canopen::{emcy, CONTROLLER_NODE};
use controller::commands::{request_frame, Answer, Request};
use controller::feedback::NoFeedback;
use controller::operator::path::Steered;
use controller::operator::{operator_frame, Flags, OperatorFrame, FULL_SCALE, MANUAL_MODE_CODE};
use controller::planner::Planner;
use controller::setpoint::{Setpoint, UNITS_PER_M_PER_S};
use controller::{Controller, Cycle, Injectable, InverseModel, Mode, Replan};
use nalgebra::SVector;
use scene::cranes::spatial::Spatial;
use sim::{run_cycle, VirtualBus, HEALTHY};
use solver_core::models::crane3d::subs as crane3d;
use solver_core::models::crane3d::{Crane3dParams, Crane3dSubs};
use solver_core::operator::{Generator3d, Settings};
use solver_core::plan::Plan;
use solver_core::{JacobianMode, SolverSettings};

type Path = Steered<Generator3d, 3>;
type Ff = Injectable<
    InverseModel<
        Spatial,
        Crane3dSubs<f64, Path>,
        crane3d::StructuredBdf<f64, Path>,
        f64,
        { crane3d::N },
    >,
>;

const HELD: Flags = Flags {
    enable: true,
    manual: true,
    micro: false,
};

struct Manual {
    c: Controller<Ff, NoFeedback, Spatial, 3>,
    bus: VirtualBus<Spatial, 3>,
    now: u32,
    counter: u8,
}

impl Manual {
    fn new() -> Self {
        let plan = Plan::at_rest(SVector::from(HOME), 5).unwrap();
        let path = Steered::new(plan, Settings::lab_3d(&Crane3dParams::EXAMPLE));
        let model = Crane3dSubs::new(Crane3dParams::EXAMPLE, path).unwrap();
        let settings = SolverSettings {
            h: 0.01,
            ..SolverSettings::paper(JacobianMode::Exact)
        };
        let integrator = crane3d::StructuredBdf::new(&model, &settings, 4, 0.0).unwrap();
        let ff = Injectable::new(InverseModel::new(model, integrator));
        let planner = Planner::with_axes(Spatial::EXAMPLE, limits());
        let mut rig = Self {
            c: Controller::with_correction(ff, NoFeedback, planner, config()),
            bus: VirtualBus::for_crane(HEALTHY, &Spatial::EXAMPLE, HOME),
            now: 0,
            counter: 0,
        };
        for _ in 0..200 {
            if rig.cycle().mode == Mode::Ready {
                return rig;
            }
        }
        panic!("not ready");
    }

    fn cycle(&mut self) -> Cycle<3> {
        let out = run_cycle(&mut self.c, &mut self.bus, self.now).unwrap();
        self.now += 10;
        out
    }

    /// `cycles` cycles with a frame every third (30 ms).
    fn hold(&mut self, cycles: usize, flags: Flags, demand: [i16; 3]) -> Vec<Cycle<3>> {
        (0..cycles)
            .map(|n| {
                if n % 3 == 0 {
                    self.counter = self.counter.wrapping_add(1);
                    let f = OperatorFrame {
                        counter: self.counter,
                        flags,
                        demand,
                    };
                    self.c
                        .on_frame(&operator_frame(CONTROLLER_NODE, &f), self.now.into());
                }
                self.cycle()
            })
            .collect()
    }

    fn load(&self) -> [f64; 3] {
        let x = self.c.feedforward().inner.integrator.state();
        [x[0], x[1], x[2]]
    }
}

/// Every set point of `cycles` (from rest) within the 3D lab drives' speed and
/// acceleration limits, and the controller ready throughout.
fn assert_within_limits(cycles: &[Cycle<3>]) {
    let mut last = [0i32; 3];
    for (n, c) in cycles.iter().enumerate() {
        for (i, l) in limits().iter().enumerate() {
            let v = c.setpoints[i].units();
            assert!(
                f64::from(v.abs()) <= l.max_velocity * UNITS_PER_M_PER_S,
                "cycle {n}, axis {i}: {v}"
            );
            let dv = f64::from(v - last[i]);
            assert!(
                dv.abs() <= l.max_acceleration * 0.01 * UNITS_PER_M_PER_S + 1.0,
                "cycle {n}, axis {i}: jumps by {dv}"
            );
            last[i] = v;
        }
        assert_eq!(c.mode, Mode::Ready, "cycle {n}");
    }
}

/// Cycles with the stick centred until every set point was zero for 30 cycles in a row
/// (at most 3,000): whether it got there.
fn until_rest(rig: &mut Manual, cycles: &mut Vec<Cycle<3>>) -> bool {
    for _ in 0..1000 {
        cycles.extend(rig.hold(3, HELD, [0; 3]));
        if cycles
            .iter()
            .rev()
            .take(30)
            .all(|c| c.setpoints == [Setpoint::ZERO; 3])
        {
            return true;
        }
    }
    false
}

/// The hand-over on the 3D crane (issue 28, "an automatic move interrupted at 10 / 50 /
/// 90 %"): a 3D move (bridge, trolley and hoist at once) taken over by a diagonal stick
/// in the cycle that reads its frame — manual mode at once, EMCY 0xFF22 with detail 0 —
/// the bridge and the trolley then going the ways the stick points once the move's stop
/// is over; released, at rest; every set point within the drives' limits throughout, no
/// fault.
#[test]
fn a_diagonal_stick_takes_a_3d_move_over_in_the_same_cycle() {
    for share in [0.1, 0.5, 0.9] {
        let mut rig = Manual::new();
        let mut cycles = rig.hold(9, HELD, [0; 3]);
        let off = Flags {
            manual: false,
            ..HELD
        };
        cycles.extend(rig.hold(6, off, [0; 3]));
        assert!(
            !rig.c.feedforward().path().in_manual(),
            "{share}: automatic"
        );
        let request = Request::Move3d {
            id: 1,
            target: [17.0, 5.0, 7.0],
            duration: Some(6.0),
        };
        rig.c.on_frame(&request_frame(&request), rig.now.into());
        // Centred with the request: the take-over is armed, the move runs on.
        cycles.extend(rig.hold(9, HELD, [0; 3]));
        assert_eq!(rig.c.last_answer().1, Answer::Accepted, "{share}");
        let (start, end) = rig
            .c
            .feedforward()
            .plan()
            .active()
            .map(|a| a.span())
            .unwrap();
        while f64::from(rig.now) / 1000.0 < start + share * (end - start) {
            cycles.extend(rig.hold(3, HELD, [0; 3]));
        }
        assert!(
            !rig.c.feedforward().path().in_manual(),
            "{share}: the move runs"
        );
        let stick = [FULL_SCALE / 4, -FULL_SCALE / 4, 0];
        let taken = rig.hold(1, HELD, stick);
        let emcy: Vec<_> = common::emcy_frames(&taken, Some(emcy::MOVE_TAKEN_OVER));
        assert_eq!(emcy.len(), 1, "{share}: EMCY 0xFF22 once");
        assert_eq!(emcy[0][5], emcy::TAKEN_OVER_AT_ONCE, "{share}: at once");
        assert!(
            rig.c.feedforward().path().in_manual(),
            "{share}: manual at once"
        );
        cycles.extend(taken);
        cycles.extend(rig.hold(900, HELD, stick));
        let before = rig.load();
        cycles.extend(rig.hold(50, HELD, stick));
        let after = rig.load();
        assert!(
            after[0] - before[0] > 0.05 && after[1] - before[1] < -0.05,
            "{share}: the stick drives bridge and trolley ({before:?} → {after:?})"
        );
        assert!(until_rest(&mut rig, &mut cycles), "{share}: at rest");
        assert_within_limits(&cycles);
    }
}

/// A diagonal full stick (bridge and trolley) for 4 s, then released: both horizontal
/// axes travel, every set point within the 3D lab drives' limits, exactly zero after the
/// stop; withdrawn, manual mode is left at rest.
#[test]
fn a_diagonal_full_stick_step_and_release_ends_at_rest_within_limits() {
    let mut rig = Manual::new();
    let mut cycles = rig.hold(9, HELD, [0; 3]);
    assert_eq!(rig.c.status().bytes()[3], MANUAL_MODE_CODE);
    let start = rig.load();
    cycles.extend(rig.hold(400, HELD, [FULL_SCALE, FULL_SCALE, 0]));
    assert_eq!(rig.c.counters().frames_ignored, 0, "y is the 3D crane's");
    assert!(
        until_rest(&mut rig, &mut cycles),
        "at rest after the release"
    );
    let end = rig.load();
    let moved = [end[0] - start[0], end[1] - start[1]];
    assert!(moved[0] > 1.0 && moved[1] > 0.5, "travelled {moved:?} m");
    let tail = rig.hold(300, HELD, [0; 3]);
    assert!(tail.iter().all(|c| c.setpoints == [Setpoint::ZERO; 3]));
    cycles.extend(tail);
    assert_within_limits(&cycles);
    let off = Flags {
        manual: false,
        ..HELD
    };
    rig.hold(6, off, [0; 3]);
    assert_eq!(rig.c.status().bytes()[3], 1, "left at rest");
    assert!(!rig.c.feedforward().path().in_manual());
    println!("3D: travelled {moved:?} m (bridge, trolley) on a diagonal full stick");
}

/// The generator and the 3D crane's inverse model in step (review finding 2): after
/// every cycle in manual mode, the entry cycle included, the generator's current piece
/// starts one cycle (10 ms) before the model's time.
#[test]
fn the_3d_generator_is_advanced_on_every_cycle_the_model_steps() {
    use controller::{Feedforward, Replan};
    let mut rig = Manual::new();
    let mut checked = 0;
    for n in 0..600 {
        let demand = if (9..300).contains(&n) {
            [FULL_SCALE, FULL_SCALE / 2, 0]
        } else {
            [0; 3]
        };
        rig.hold(1, HELD, demand);
        let ff = rig.c.feedforward_mut();
        let model = ff.time();
        if let Some(path) = ff.path_mut().manual_mut() {
            let generator = path.time();
            assert!(
                (model - generator - 0.01).abs() < 1e-9,
                "cycle {n}: {generator} s, model {model} s"
            );
            checked += 1;
        }
    }
    assert!(checked > 500, "{checked} cycles in manual mode");
}
