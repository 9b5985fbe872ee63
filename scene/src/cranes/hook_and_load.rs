//! The hook-and-load crane (trolley and winch; a hook block at the rope's end and the
//! load on a sling below it, a double pendulum: `solver_core::models::double_pendulum`),
//! everything it is in one file: what the controller knows of it ([`Crane`]: drives,
//! limits, its own reference state [`HookReference`], flat inverse) and the reference of
//! each of its inverse models (*subs*, *ext*), the plant the virtual bus runs for it
//! ([`Simulated`]), and — on the host — its formulations and its
//! [`FirmwareCrane`](super::FirmwareCrane) registration.
//!
//! It has no state feedback yet: which sensor a loop would read (the rope's angle at
//! the hook block, the sling's, or both) is open, so its only correction is
//! `controller::feedback::NoFeedback`, the planar loop — keyed on the planar
//! `controller::feedback::Reference` — is refused for it at compile time, and a scene
//! with `[feedback]` is refused for it.

use controller::commands::Reject;
use controller::crane::{AxisReasons, Crane, Flat};
use controller::drive::{self, Drive};
use controller::feedforward::CraneReference;
use controller::setpoint::{AxisLimits, DriveLimits};
#[cfg(feature = "sim")]
use sim::mismatch::Mismatch;
#[cfg(feature = "sim")]
use sim::plant_dp::PlantDp;
#[cfg(feature = "sim")]
use sim::simulated::Simulated;
use solver_core::models::double_pendulum::DoublePendulumSubs;
use solver_core::models::double_pendulum_crane::DoublePendulumParams;
use solver_core::models::double_pendulum_ext::DoublePendulumExt;
use solver_core::plan::Plan;
use solver_core::reference::double_pendulum::{self, FlatDoublePendulum};
use solver_core::trajectory::Trajectory;
use solver_core::Real;

#[cfg(feature = "host")]
pub use host::*;

crane_type! {
    /// The hook-and-load crane with its parameters: the type the controller, the virtual bus
    /// and the registry know it by.
    HookAndLoad(DoublePendulumParams), 2
}

impl HookAndLoad {
    /// Tab. 3's crane with a hook block of 30 % of the load's mass on a 1 m sling
    /// (`DoublePendulumParams::EXAMPLE`).
    pub const EXAMPLE: Self = Self(DoublePendulumParams::EXAMPLE);
}

/// The hook-and-load crane's reference state: the drives and the hook block, with their
/// rates (the load follows its path; the hook is where the flat inverse puts it).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct HookReference {
    /// Trolley position x, m.
    pub x: f64,
    /// Rope length l (rail to hook block), m.
    pub l: f64,
    /// The hook block `[x_H, z_H]`, m.
    pub hook: [f64; 2],
    /// Trolley velocity, m/s.
    pub vx: f64,
    /// Rope rate, m/s.
    pub vl: f64,
    /// The hook block's velocity, m/s.
    pub v_hook: [f64; 2],
}

impl HookReference {
    /// From the first unknowns of *subs* (and *ext*, which keeps *subs*' order):
    /// `[x, l, x_H, z_H, v_x, v_l, v_xH, v_zH, …]`.
    fn from_subs_unknowns(y: &[f64]) -> Self {
        let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
        Self {
            x: at(0),
            l: at(1),
            hook: [at(2), at(3)],
            vx: at(4),
            vl: at(5),
            v_hook: [at(6), at(7)],
        }
    }
}

impl Crane<2> for HookAndLoad {
    const NAME: &'static str = "hook-and-load crane";
    const DRIVES: [Drive; 2] = drive::PLANAR;
    const REASONS: [AxisReasons; 2] = [AxisReasons::TROLLEY, AxisReasons::WINCH];
    const LAB_LIMITS: [AxisLimits; 2] = DriveLimits::LAB.axes();
    /// Provisional: no feedback reads it yet; the stock one-axis inclinometer (on the
    /// hook block it would read the rope's angle; the sling's is not measured).
    const SWING_AXES: u8 = 1;
    const HORIZONTAL_AXES: u8 = 1;
    /// The inputs contain `z⁽⁶⁾` (the sling's constraints differentiated four times give
    /// `u`, five times `u̇`: index 5, `solver_core::models::double_pendulum`), so the
    /// drives' accelerations `u̇` contain `z⁽⁷⁾`: moves are planned with n ≥ 7, as the
    /// planar crane's with n ≥ 5 for its `z⁗`.
    const MIN_COMMAND_SMOOTHNESS: usize = 7;
    /// Two: its stops have n = 9, the path's 10th derivative jumps where one takes over.
    /// With one (n = 8, the 9th jumping) BDF4's set points answered the takeover with a
    /// transient alternating cycle to cycle, up to 9.0e-3 m/s from the exact inverse's in
    /// a stop's first 15 cycles (3.6e-3 with two; 7.4e-4 and 7.1e-4 after them: `cargo
    /// test -p controller --test double_pendulum_crane stop_takeover -- --ignored
    /// --nocapture`, stops every 0.1 s of (12, 8) → (16, 6) in 8 s), and the stop sent
    /// 0.4 s into that move — 0.58 s long — sent a trolley set point 3.66 m/s² from the
    /// last where the exact inverse's acceleration was 1.6–1.9 m/s²: fault 2. With two
    /// every stop of the sweep every 0.1 s rests ready, its set points within 0.950 of the
    /// acceleration limits (`cargo test -p controller --test double_pendulum_crane a_stop
    /// -- --nocapture`; three: 0.948).
    const STOP_SMOOTHNESS_ABOVE_MOVES: usize = 2;
    type Reference = HookReference;
    fn drive_states(r: &HookReference) -> [(f64, f64); 2] {
        [(r.x, r.vx), (r.l, r.vl)]
    }
    fn g(&self) -> f64 {
        self.0.crane.g
    }
    fn ranges(&self) -> [(f64, f64); 2] {
        let w = &self.0.crane.workspace;
        [(w.x_min, w.x_max), (w.l_min, w.l_max)]
    }
    fn target(x: f64, y: Option<f64>, z: f64, _end: [f64; 2]) -> Option<[f64; 2]> {
        y.is_none().then_some([x, z])
    }
    /// The exact flat inverse; where it has none (a rope or the sling slack, the hook at
    /// the rail) every value is NaN, which the planner refuses as a violation.
    fn flat<Z: Trajectory<f64, 2>>(&self, z: &Z, t: f64) -> Flat<2> {
        double_pendulum::flat_inverse(&self.0, z, t).map_or(Flat::UNDEFINED, |f| drives(&f))
    }
    /// The hook hangs a sling above the load: the rope is that much shorter.
    fn drives_at_rest(&self, [x, z]: [f64; 2]) -> [f64; 2] {
        [x, z - self.0.sling]
    }
    fn load_at_rest(&self, [x, l]: [f64; 2]) -> [f64; 2] {
        [x, l + self.0.sling]
    }
    /// The rope carries hook and load: it stays taut while their mean downward
    /// acceleration `(z̈_C + μ z̈_H)/(1 + μ)` (μ = m_h/m) stays below g, and keeps the
    /// planner's margin below `max_down_acceleration`; the sling is the load's own rope,
    /// which the planner checks for every crane. Where the flat inverse refuses a slack
    /// rope or sling, slack; where it refuses the hook at the rail
    /// (`solver_core::Error::OutsideWorkspace` naming `z_H`), [`Reject::HookAtRail`];
    /// anything else it refuses (a non-finite path), the undefined flat, whose NaN the
    /// planner refuses as each axis's violation. One flat inverse serves both the rope
    /// check and the drives' checks.
    fn taut_flat<Z: Trajectory<f64, 2>>(
        &self,
        z: &Z,
        t: f64,
        load_down_acceleration: f64,
        max_down_acceleration: f64,
    ) -> Result<Flat<2>, Reject> {
        match double_pendulum::flat_inverse(&self.0, z, t) {
            Ok(f) => {
                let [_, a_hook] = f.a_hook;
                let mu = self.0.hook_mass / self.0.crane.m;
                let mean = (load_down_acceleration + mu * a_hook) / (1.0 + mu);
                if mean.is_nan() || mean > max_down_acceleration {
                    Err(Reject::SlackRope)
                } else {
                    Ok(drives(&f))
                }
            }
            Err(solver_core::Error::RopeSlack { .. }) => Err(Reject::SlackRope),
            Err(solver_core::Error::OutsideWorkspace {
                coordinate: "z_H", ..
            }) => Err(Reject::HookAtRail),
            Err(_) => Ok(Flat::UNDEFINED),
        }
    }
    fn lags(&self) -> [f64; 2] {
        [self.0.crane.tau1, self.0.crane.tau2]
    }
}

/// The drives' part of the exact double-pendulum state: trolley and rope, their inputs
/// and the inputs' rates.
fn drives(f: &FlatDoublePendulum) -> Flat<2> {
    Flat {
        position: [f.x, f.l],
        u: f.u,
        u_dot: f.u_dot,
    }
}

/// *subs*: `y = [x, l, x_H, z_H, v_x, v_l, v_xH, v_zH, λ1, λ2, u1, u2]`.
impl<T: Real> CraneReference<HookAndLoad, 2> for DoublePendulumSubs<T, Plan<f64, 2>> {
    fn reference(&self, y: &[f64], _t: f64) -> HookReference {
        HookReference::from_subs_unknowns(y)
    }
}

/// *ext*: its first unknowns are *subs*' in *subs*' order.
impl<T: Real> CraneReference<HookAndLoad, 2> for DoublePendulumExt<T, Plan<f64, 2>> {
    fn reference(&self, y: &[f64], _t: f64) -> HookReference {
        HookReference::from_subs_unknowns(y)
    }
}

// The hook-and-load crane without feedback: the inverse model's set points as they are.
controller::feedforward_only!(2, HookReference);

/// The hook-and-load crane: its double pendulum with the one-axis inclinometer on the
/// hook block. `start` is where the drives stand: at rest the rope is the sling's length
/// shorter than the load is deep.
#[cfg(feature = "sim")]
impl Simulated<2> for HookAndLoad {
    type Plant = PlantDp;
    fn plant(&self, mismatch: Mismatch, start: [f64; 2]) -> PlantDp {
        PlantDp::at_rest(self.0, start, mismatch)
    }
}

/// Its formulations and its registration: the host's (the build scripts, the studies,
/// the virtual ECU).
#[cfg(feature = "host")]
mod host {
    use controller::crane::Crane;
    use controller::feedback::{Config as FeedbackConfig, DesignError, NoFeedback};
    use solver_core::models::double_pendulum_crane::DoublePendulumParams;
    use solver_core::plan::Plan;
    use solver_core::reference::double_pendulum::flat_inverse;
    use solver_core::trajectory::PointToPoint;
    use solver_core::{Error, SolverSettings};

    use super::HookAndLoad;
    use crate::cranes::{
        crane_models, CraneModel, FirmwareCrane, FirmwareError, FirmwareIntegrator, FirmwareVisitor,
    };
    use crate::family::{ExactInputs, Flat, ModelFamily};
    use crate::rust_source::struct_to_rust;
    use crate::{refuse, ModelSpec, OperatorSpec, SceneError};

    crane_models! {
        /// The hook-and-load crane's formulations the firmware can drive.
        HookAndLoadModel for HookAndLoad, 2 {
            /// *subs*: redundant coordinates, the servo-constraints substituted (index 5).
            Subs => double_pendulum, DoublePendulumSubs, Structured;
            /// *ext*: *subs* minimally extended to index 1 (30 unknowns: its structured
            /// Newton only).
            Ext => double_pendulum_ext, DoublePendulumExt, StructuredOnly;
        }
    }

    impl ModelFamily<2> for DoublePendulumParams {
        const NAME: &'static str = "the hook-and-load crane";
        /// 1 mm/s: its inputs are the drives' velocity set points.
        const ACCURACY_THRESHOLD: f64 = 1e-3;
        /// A scene nests the planar crane's keys in `[model.crane]`.
        const CRANE_KEYS_UNDER: &'static str = "model.crane";
        type Exact = Flat<Self, 2>;
        /// Its flat inverse (the load's path is a flat output), whatever the formulation.
        fn exact(self, z: PointToPoint<f64, 2>) -> Result<Flat<Self, 2>, Error> {
            Ok(Flat { params: self, z })
        }
    }

    impl ExactInputs for Flat<DoublePendulumParams, 2> {
        fn at(&mut self, t: f64, out: &mut Vec<f64>) -> Result<(), Error> {
            out.extend(flat_inverse(&self.params, &self.z, t)?.u);
            Ok(())
        }
    }

    // Its parameters as the build scripts write them (`crate::rust_source`).
    struct_to_rust!(
        DoublePendulumParams {
            crane,
            hook_mass,
            sling,
        } = "solver_core::models::double_pendulum_crane::DoublePendulumParams"
    );

    impl FirmwareCrane<2> for HookAndLoad {
        const TYPE: &'static str = HookAndLoad::PATH;
        const QEMU_SCENES: &'static [&'static str] =
            &["scenes/hook-and-load.toml", "scenes/hook-and-load-ext.toml"];
        type Model = HookAndLoadModel;
        type Feedback = NoFeedback;
        const FEEDBACK_TYPE: &'static str = "controller::feedback::NoFeedback";
        const FEEDBACK_NEW: &'static str = "NoFeedback";
        type FeedforwardOnly = NoFeedback;
        fn of(model: &ModelSpec) -> Option<(Self, HookAndLoadModel)> {
            match model {
                ModelSpec::DoublePendulumSubs(c) => {
                    Some((HookAndLoad(c.params()), HookAndLoadModel::Subs))
                }
                ModelSpec::DoublePendulumExt(c) => {
                    Some((HookAndLoad(c.params()), HookAndLoadModel::Ext))
                }
                // Another crane's or rig's model.
                _ => None,
            }
        }
        /// No loop for it yet: which angle it would measure (the rope's at the hook block,
        /// the sling's, or both) is open.
        fn feedback_config(
            _spec: &FeedbackConfig,
            _crane: &Self,
            _h: f64,
        ) -> Result<FeedbackConfig, SceneError> {
            Err(refuse(
                "feedback",
                "the hook-and-load crane has no state feedback yet; remove [feedback] (it runs feedforward only)",
            ))
        }
        fn feedback(&self, _config: FeedbackConfig) -> Result<NoFeedback, DesignError> {
            Ok(NoFeedback)
        }
        type Operator = ();
        const OPERATOR_TYPE: &'static str = "()";
        const STEERED_TYPE: &'static str = "";
        /// No generator for it yet: its load path would need the sling's swing in the
        /// generator's pendulum, and its model has no `CraneReference` on such a path.
        fn operator_settings(
            _spec: &OperatorSpec,
            _crane: &Self,
            model: HookAndLoadModel,
            _h: f64,
        ) -> Result<(), SceneError> {
            Err(refuse(
                "operator",
                format!(
                    "the hook-and-load crane ({model:?}) has no manual mode yet; remove [operator]"
                ),
            ))
        }
        fn steered_inverse_model<V: FirmwareVisitor<Self, 2>>(
            self,
            model: HookAndLoadModel,
            _integrator: FirmwareIntegrator,
            _plan: Plan<f64, 2>,
            _operator: (),
            _settings: &SolverSettings,
            _visitor: V,
        ) -> Result<V::Output, FirmwareError> {
            Err(FirmwareError::NoManualMode {
                crane: <Self as Crane<2>>::NAME,
                model: model.path().1,
            })
        }
    }
}
