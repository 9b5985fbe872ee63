//! The planar crane's controller with manual mode (the operator's generator drives its
//! inverse model) on the virtual bus, and the operator's frames to it: what the manual
//! mode tests share.

use controller::canopen::CONTROLLER_NODE;
use controller::feedback::NoFeedback;
use controller::operator::path::Steered;
use controller::operator::{operator_frame, Flags, OperatorFrame, FULL_SCALE, MANUAL_MODE_CODE};
use controller::setpoint::Setpoint;
use controller::{Config, Controller, Cycle, Injectable, InverseModel, Mode};
use scene::cranes::planar::Planar;
use sim::{run_cycle, VirtualBus, HEALTHY};
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::operator::{PlanarGenerator, Settings};

use super::{planner, settings, HOME};

/// A live operator asking for manual mode (enable, manual request).
pub const HELD: Flags = Flags {
    enable: true,
    manual: true,
    micro: false,
};

/// What the model follows: the plan, or the operator's generator.
pub type Path = Steered<PlanarGenerator, 2>;
/// The inverse model with manual mode, as the controller steps it.
pub type ManualFf = Injectable<
    InverseModel<Planar, CraneSubs<f64, Path>, crane_subs::Bdf<f64, Path>, f64, { crane_subs::N }>,
>;

/// The controller with manual mode on the paper's crane at rest at [`HOME`], the bus,
/// the clock, and the operator's next alive counter.
pub struct Manual {
    pub c: Controller<ManualFf, NoFeedback, Planar, 2>,
    pub bus: VirtualBus<Planar, 2>,
    pub now: u32,
    pub counter: u8,
}

impl Manual {
    /// Ready at rest at [`HOME`], manual mode with the lab's settings.
    pub fn new() -> Self {
        Self::with(Settings::lab(&CraneParams::PAPER))
    }

    /// Ready at rest at [`HOME`], manual mode with the `generator`'s settings.
    pub fn with(generator: Settings<1>) -> Self {
        let plan = controller::crane::command_plan::<Planar, 2>(HOME, 4).unwrap();
        let path = Steered::new(plan, generator);
        let model = CraneSubs::new(CraneParams::PAPER, path).unwrap();
        let integrator = crane_subs::Bdf::new(&model, &settings(), 4, 0.0).unwrap();
        let ff = Injectable::new(InverseModel::new(model, integrator));
        let mut rig = Self {
            c: Controller::new(ff, planner(), Config::DEFAULT),
            bus: VirtualBus::new(HEALTHY, HOME),
            now: 0,
            counter: 0,
        };
        for _ in 0..120 {
            if rig.cycle().mode == Mode::Ready {
                return rig;
            }
        }
        panic!("not ready");
    }

    /// One controller cycle on the bus, 10 ms.
    pub fn cycle(&mut self) -> Cycle {
        let out = run_cycle(&mut self.c, &mut self.bus, self.now).unwrap();
        self.now += 10;
        out
    }

    /// The operator's frame now: the next counter, `flags`, `demand`.
    pub fn send(&mut self, flags: Flags, demand: [i16; 3]) {
        self.counter = self.counter.wrapping_add(1);
        let f = operator_frame(
            CONTROLLER_NODE,
            &OperatorFrame {
                counter: self.counter,
                flags,
                demand,
            },
        );
        self.c.on_frame(&f, self.now.into());
    }

    /// `cycles` cycles with a frame every third (30 ms) carrying `flags` and `demand`.
    pub fn hold(&mut self, cycles: usize, flags: Flags, demand: [i16; 3]) -> Vec<Cycle> {
        (0..cycles)
            .map(|n| {
                if n % 3 == 0 {
                    self.send(flags, demand);
                }
                self.cycle()
            })
            .collect()
    }

    /// The status frame's mode byte.
    pub fn mode_byte(&self) -> u8 {
        self.c.status().bytes()[3]
    }

    /// The load's position in the model, m.
    pub fn load(&self) -> [f64; 2] {
        let x = self.c.feedforward().inner.integrator.state();
        [x[0], x[1]]
    }
}

/// Enters manual mode and lifts the interlock (the stick centred), then holds full
/// stick for `cycles`: the load is moving at the end.
pub fn moving(cycles: usize) -> Manual {
    let mut rig = Manual::new();
    rig.hold(9, HELD, [0; 3]);
    assert_eq!(rig.mode_byte(), MANUAL_MODE_CODE);
    rig.hold(cycles, HELD, [FULL_SCALE, 0, 0]);
    rig
}

/// Cycles until every set point was zero for 30 cycles in a row (at most `max`); all
/// outputs, and whether it got there.
pub fn until_rest(
    rig: &mut Manual,
    max: usize,
    mut each: impl FnMut(&mut Manual, usize),
) -> (Vec<Cycle>, bool) {
    let mut out: Vec<Cycle> = Vec::new();
    for n in 0..max {
        each(rig, n);
        out.push(rig.cycle());
        if out.len() > 30
            && out
                .iter()
                .rev()
                .take(30)
                .all(|c| c.setpoints == [Setpoint::ZERO; 2])
        {
            return (out, true);
        }
    }
    (out, false)
}

/// A supervisor's request frame to the controller now.
pub fn send_request(rig: &mut Manual, request: controller::commands::Request) {
    rig.c.on_frame(
        &controller::commands::request_frame(&request),
        rig.now.into(),
    );
}
