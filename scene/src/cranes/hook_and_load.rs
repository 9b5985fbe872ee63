//! The hook-and-load crane (trolley and winch; a hook block at the rope's end and the
//! load on a sling below it, a double pendulum) as the firmware drives it: its
//! formulations and its [`FirmwareCrane`] registration.
//!
//! It has no state feedback (`controller::crane::double_pendulum`): a scene with
//! `[feedback]` is refused for it, and it runs feedforward only.

use controller::crane::Crane;
use controller::feedback::{Config as FeedbackConfig, DesignError, NoFeedback};
use solver_core::models::double_pendulum_crane::DoublePendulumParams;
use solver_core::plan::Plan;
use solver_core::reference::double_pendulum::flat_inverse;
use solver_core::trajectory::PointToPoint;
use solver_core::{Error, SolverSettings};

use super::{
    crane_models, CraneModel, FirmwareCrane, FirmwareError, FirmwareIntegrator, FirmwareVisitor,
};
use crate::family::{ExactInputs, Flat, ModelFamily};
use crate::rust_source::struct_to_rust;
use crate::{refuse, ModelSpec, OperatorSpec, SceneError};

crane_models! {
    /// The hook-and-load crane's formulations the firmware can drive.
    HookAndLoadModel for DoublePendulumParams, 2 {
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
    } = <DoublePendulumParams as FirmwareCrane<2>>::TYPE
);

impl FirmwareCrane<2> for DoublePendulumParams {
    const TYPE: &'static str = "solver_core::models::double_pendulum_crane::DoublePendulumParams";
    const QEMU_SCENES: &'static [&'static str] =
        &["scenes/hook-and-load.toml", "scenes/hook-and-load-ext.toml"];
    type Model = HookAndLoadModel;
    type Feedback = NoFeedback;
    const FEEDBACK_TYPE: &'static str = "controller::feedback::NoFeedback";
    const FEEDBACK_NEW: &'static str = "NoFeedback";
    type FeedforwardOnly = NoFeedback;
    fn of(model: &ModelSpec) -> Option<(Self, HookAndLoadModel)> {
        match model {
            ModelSpec::DoublePendulumSubs(c) => Some((c.params(), HookAndLoadModel::Subs)),
            ModelSpec::DoublePendulumExt(c) => Some((c.params(), HookAndLoadModel::Ext)),
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
