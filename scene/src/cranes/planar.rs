//! The paper's planar crane (trolley and winch; Eqs. 24–28, Tab. 3), everything it is in
//! one file: what the controller knows of it ([`Crane`]: drives, limits, reference,
//! flat inverse) and the reference of each of its inverse models, the plant the virtual
//! bus runs for it ([`Simulated`]), and — on the host — its formulations and its
//! [`FirmwareCrane`](super::FirmwareCrane) registration.

use controller::crane::{AxisReasons, Crane, Flat};
use controller::drive::{self, Drive};
use controller::feedback::Reference;
use controller::feedforward::CraneReference;
use controller::operator::path::Steered;
use controller::setpoint::{AxisLimits, DriveLimits};
#[cfg(feature = "sim")]
use sim::mismatch::Mismatch;
#[cfg(feature = "sim")]
use sim::plant::Plant;
#[cfg(feature = "sim")]
use sim::simulated::Simulated;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_ext::CraneExt;
use solver_core::models::crane_proj::CraneProj;
use solver_core::models::crane_subs::CraneSubs;
use solver_core::operator::PlanarGenerator;
use solver_core::plan::Plan;
use solver_core::reference::flat_crane;
use solver_core::trajectory::Trajectory;
use solver_core::{Driven, Real};

#[cfg(feature = "host")]
pub use host::*;

crane_type! {
    /// The planar crane with its parameters: the type the controller, the virtual bus and the
    /// registry know it by.
    Planar(CraneParams), 2
}

impl Planar {
    /// The paper's lab crane (Tab. 3).
    pub const PAPER: Self = Self(CraneParams::PAPER);
}

impl Crane<2> for Planar {
    const NAME: &'static str = "planar crane";
    const DRIVES: [Drive; 2] = drive::PLANAR;
    const REASONS: [AxisReasons; 2] = [AxisReasons::TROLLEY, AxisReasons::WINCH];
    const LAB_LIMITS: [AxisLimits; 2] = DriveLimits::LAB.axes();
    const SWING_AXES: u8 = 1;
    const HORIZONTAL_AXES: u8 = 1;
    /// The inputs contain `z⁗` (Eqs. 27–28), so the drives' accelerations `u̇` contain
    /// `z⁽⁵⁾`. With the paper's n = 4 the fifth derivative jumps at a move's ends: BDF4
    /// overshoots the planned peak acceleration by 9.7 %, BDF6 by a factor of up to
    /// 3.3. With n ≥ 5 the accelerations are continuous and the computed ones stay
    /// within 0.5 % of the exact ones (`cargo test -p controller --test smoothness`).
    const MIN_COMMAND_SMOOTHNESS: usize = 5;
    type Reference = Reference;
    fn drive_states(r: &Reference) -> [(f64, f64); 2] {
        [(r.x, r.vx), (r.l, r.vl)]
    }
    fn g(&self) -> f64 {
        self.0.g
    }
    fn ranges(&self) -> [(f64, f64); 2] {
        let w = &self.0.workspace;
        [(w.x_min, w.x_max), (w.l_min, w.l_max)]
    }
    fn target(x: f64, y: Option<f64>, z: f64, _end: [f64; 2]) -> Option<[f64; 2]> {
        y.is_none().then_some([x, z])
    }
    fn flat<Z: Trajectory<f64, 2>>(&self, z: &Z, t: f64) -> Flat<2> {
        let f = flat_crane::flat_inverse(&self.0, z, t);
        Flat {
            position: [f.x, f.l],
            u: f.u,
            u_dot: f.u_dot,
        }
    }
    fn drives_at_rest(&self, load: [f64; 2]) -> [f64; 2] {
        load
    }
    fn load_at_rest(&self, drives: [f64; 2]) -> [f64; 2] {
        drives
    }
    fn lags(&self) -> [f64; 2] {
        [self.0.tau1, self.0.tau2]
    }
}

/// The reference from *subs*' first unknowns `y = [x, l, ẋ, l̇, …]` and the load's
/// desired `path`: the angle and its rate from the desired load position and velocity
/// (Eqs. 27–28).
fn from_subs_unknowns<Z: Trajectory<f64, 2>>(y: &[f64], path: &Z, t: f64) -> Reference {
    let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
    let [p, v] = path.derivatives::<2>(t);
    Reference::from_subs([at(0), at(1), at(2), at(3)], p.into(), v.into())
}

/// *subs*: `y = [x, l, ẋ, l̇, λ, u1, u2]`.
impl<T: Real> CraneReference<Planar, 2> for CraneSubs<T, Plan<f64, 2>> {
    fn reference(&self, y: &[f64], t: f64) -> Reference {
        from_subs_unknowns(y, self.trajectory(), t)
    }
}

/// *subs* driven by the plan or, in manual mode, the operator's generator
/// ([`Steered`]): the same reference from the path it follows.
impl<T: Real> CraneReference<Planar, 2> for CraneSubs<T, Steered<PlanarGenerator, 2>> {
    fn reference(&self, y: &[f64], t: f64) -> Reference {
        from_subs_unknowns(y, self.trajectory(), t)
    }
}

/// *proj*: `y = [x, l, φ, ẋ, l̇, φ̇, u1, u2]` holds the reference as it is.
impl<T: Real> CraneReference<Planar, 2> for CraneProj<T, Plan<f64, 2>> {
    fn reference(&self, y: &[f64], _t: f64) -> Reference {
        let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
        Reference {
            x: at(0),
            l: at(1),
            phi: at(2),
            vx: at(3),
            vl: at(4),
            vphi: at(5),
        }
    }
}

/// *ext* (*subs* minimally extended to index 1): its first unknowns are *subs*'
/// `[x, l, ẋ, l̇, …]` in *subs*' order, so the reference is *subs*'.
impl<T: Real> CraneReference<Planar, 2> for CraneExt<T, Plan<f64, 2>> {
    fn reference(&self, y: &[f64], t: f64) -> Reference {
        from_subs_unknowns(y, self.trajectory(), t)
    }
}

/// The planar crane: its plant with the one-axis inclinometer.
#[cfg(feature = "sim")]
impl Simulated<2> for Planar {
    type Plant = Plant;
    fn plant(&self, mismatch: Mismatch, [x, l]: [f64; 2]) -> Plant {
        let p = &self.0;
        Plant::at_rest(x, l, 0.0, [p.tau1, p.tau2], p.g, p.m, mismatch)
    }
}

/// Its formulations and its registration: the host's (the build scripts, the studies,
/// the virtual ECU).
#[cfg(feature = "host")]
mod host {
    use controller::crane::Crane;
    use controller::feedback::{Config as FeedbackConfig, DesignError, NoFeedback, StateFeedback};
    use controller::operator::path::Steered;
    use solver_core::models::crane::{CraneParams, Workspace};
    use solver_core::operator::{PlanarGenerator, Settings};
    use solver_core::plan::Plan;
    use solver_core::reference::flat_crane::flat_inverse;
    use solver_core::trajectory::PointToPoint;
    use solver_core::{Error, SolverSettings};

    use super::Planar;
    use crate::cranes::{
        crane_models, integrators, visit, CraneModel, FirmwareCrane, FirmwareError,
        FirmwareIntegrator, FirmwareVisitor,
    };
    use crate::family::{ExactInputs, Flat, ModelFamily};
    use crate::operator::only_subs;
    use crate::rust_source::struct_to_rust;
    use crate::{ModelSpec, OperatorSpec, SceneError};

    /// The default scene, relative to the workspace root: what the firmware (its build
    /// script, when `SCENE` is not set), the virtual ECU (`ecu` without `--scene`), the
    /// interop rig, `cargo xtask run`, the QEMU scenarios, the soak and the panic proof run
    /// when none is named. The planar crane on the minimally extended formulation (*ext*,
    /// index 1) with structured BDF4 at 10 ms, the configuration docs/RESULTS.md picks for it
    /// ("Which configuration to pick"): the flat inverse to rounding where *subs* (index 3)
    /// has a rounding floor. The paper's own scene (`scenes/paper-crane.toml`, *subs*) stays
    /// what the paper's reproductions, the accuracy tests and the studies run.
    pub const DEFAULT_SCENE: &str = "scenes/paper-crane-ext.toml";

    crane_models! {
        /// The planar crane's formulations the firmware can drive.
        PlanarModel for Planar, 2 {
            /// *subs*: redundant coordinates, the servo-constraints substituted (Eqs. 24–28).
            Subs => crane_subs, CraneSubs, Structured;
            /// *proj*: minimal coordinates projected after Blajer (Eqs. 21–22, 27–28).
            Proj => crane_proj, CraneProj, Dense;
            /// *ext*: *subs* minimally extended to index 1.
            Ext => crane_ext, CraneExt, StructuredOnly;
        }
    }

    impl ModelFamily<2> for CraneParams {
        const NAME: &'static str = "the planar crane";
        /// 1 mm/s: its inputs are the drives' velocity set points.
        const ACCURACY_THRESHOLD: f64 = 1e-3;
        type Exact = Flat<Self, 2>;
        /// Its flat inverse, whatever the formulation.
        fn exact(self, z: PointToPoint<f64, 2>) -> Result<Flat<Self, 2>, Error> {
            Ok(Flat { params: self, z })
        }
    }

    impl ExactInputs for Flat<CraneParams, 2> {
        fn at(&mut self, t: f64, out: &mut Vec<f64>) -> Result<(), Error> {
            out.extend(flat_inverse(&self.params, &self.z, t).u);
            Ok(())
        }
    }

    // Its parameters as the build scripts write them (`crate::rust_source`).
    struct_to_rust!(
        CraneParams {
            m,
            g,
            tau1,
            tau2,
            workspace,
            min_tension_fraction,
        } = "solver_core::models::crane::CraneParams"
    );
    struct_to_rust!(
        Workspace {
            x_min,
            x_max,
            l_min,
            l_max
        } = "solver_core::models::crane::Workspace"
    );

    impl FirmwareCrane<2> for Planar {
        const TYPE: &'static str = Planar::PATH;
        /// The default scene first (every scenario of the virtual bus runs on it).
        const QEMU_SCENES: &'static [&'static str] = &[
            DEFAULT_SCENE,
            "scenes/paper-crane.toml",
            "scenes/paper-crane-radau5.toml",
        ];
        type Model = PlanarModel;
        type Feedback = StateFeedback;
        const FEEDBACK_TYPE: &'static str = "controller::feedback::StateFeedback";
        const FEEDBACK_NEW: &'static str = "Correction::new(FEEDBACK)";
        type FeedforwardOnly = NoFeedback;
        fn of(model: &ModelSpec) -> Option<(Self, PlanarModel)> {
            match model {
                ModelSpec::CraneSubs(c) => Some((Planar(c.params()), PlanarModel::Subs)),
                ModelSpec::CraneProj(c) => Some((Planar(c.params()), PlanarModel::Proj)),
                ModelSpec::CraneExt(c) => Some((Planar(c.params()), PlanarModel::Ext)),
                // Another crane's or rig's model.
                _ => None,
            }
        }
        fn feedback_config(
            spec: &FeedbackConfig,
            crane: &Self,
            h: f64,
        ) -> Result<FeedbackConfig, SceneError> {
            crate::feedback::config(spec, &crane.0, h)
        }
        fn feedback(&self, config: FeedbackConfig) -> Result<StateFeedback, DesignError> {
            StateFeedback::new(config)
        }
        type Operator = Settings<1>;
        const OPERATOR_TYPE: &'static str = "solver_core::operator::Settings<1>";
        const STEERED_TYPE: &'static str =
            "controller::operator::path::Steered<solver_core::operator::PlanarGenerator, 2>";
        /// *subs* only: only it has the controller's reference on the generator's path
        /// (its `CraneReference` on `Steered`, above).
        fn manual_mode(model: PlanarModel) -> bool {
            model == PlanarModel::Subs
        }
        /// The lab's settings with the scene's keys: the trolley ranges over the
        /// workspace, the hoist over the depths the rope's range allows.
        fn operator_settings(
            spec: &OperatorSpec,
            crane: &Self,
            model: PlanarModel,
            h: f64,
        ) -> Result<Settings<1>, SceneError> {
            if !Self::manual_mode(model) {
                return Err(only_subs("planar crane", "crane-subs", model));
            }
            let w = crane.0.workspace;
            spec.settings(
                Settings::lab(&crane.0),
                h,
                (w.l_min, w.l_max),
                &["trolley", "hoist"],
            )
        }
        fn steered_inverse_model<V: FirmwareVisitor<Self, 2>>(
            self,
            model: PlanarModel,
            integrator: FirmwareIntegrator,
            plan: Plan<f64, 2>,
            operator: Settings<1>,
            settings: &SolverSettings,
            visitor: V,
        ) -> Result<V::Output, FirmwareError> {
            type P = Steered<PlanarGenerator, 2>;
            if model != PlanarModel::Subs {
                return Err(FirmwareError::NoManualMode {
                    crane: <Self as Crane<2>>::NAME,
                    model: model.path().1,
                });
            }
            Ok(integrators!(
                Structured,
                visit,
                solver_core::models::crane_subs,
                integrator,
                solver_core::models::crane_subs::CraneSubs::new(self.0, P::new(plan, operator))?,
                settings,
                visitor,
                P
            ))
        }
    }
}
