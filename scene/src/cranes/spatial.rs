//! The crane in three dimensions (bridge, trolley and hoist) as the firmware drives it:
//! its formulations and its [`FirmwareCrane`] registration, with its state feedback per
//! vertical plane ([`SpatialFeedback`]) on a two-axis inclinometer.

use controller::crane::Crane;
use controller::feedback::{Config as FeedbackConfig, DesignError, NoFeedback};
use controller::feedback3d::SpatialFeedback;
use controller::operator::path::Steered;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::{Crane3dParams, Workspace3d};
use solver_core::operator::{Generator3d, Settings};
use solver_core::plan::Plan;
use solver_core::reference::flat_crane3d::flat_inverse;
use solver_core::trajectory::PointToPoint;
use solver_core::{Error, SolverSettings};

use super::{
    crane_models, integrators, visit, CraneModel, FirmwareCrane, FirmwareError, FirmwareIntegrator,
    FirmwareVisitor,
};
use crate::family::{ExactInputs, Flat, ModelFamily};
use crate::operator::only_subs;
use crate::rust_source::struct_to_rust;
use crate::{ModelSpec, OperatorSpec, SceneError};

crane_models! {
    /// The 3D crane's formulations the firmware can drive.
    SpatialModel for Crane3dParams, 3 {
        /// *subs*: redundant coordinates, the servo-constraints substituted.
        Subs => crane3d::subs, Crane3dSubs, Structured;
        /// *ext*: *subs* minimally extended to index 1.
        Ext => crane3d::ext, Crane3dExt, StructuredOnly;
    }
}

impl ModelFamily<3> for Crane3dParams {
    const NAME: &'static str = "the 3D crane";
    /// 1 mm/s: its inputs are the drives' velocity set points.
    const ACCURACY_THRESHOLD: f64 = 1e-3;
    type Exact = Flat<Self, 3>;
    /// Its flat inverse, whatever the formulation.
    fn exact(self, z: PointToPoint<f64, 3>) -> Result<Flat<Self, 3>, Error> {
        Ok(Flat { params: self, z })
    }
}

impl ExactInputs for Flat<Crane3dParams, 3> {
    fn at(&mut self, t: f64, out: &mut Vec<f64>) -> Result<(), Error> {
        out.extend(flat_inverse(&self.params, &self.z, t).u);
        Ok(())
    }
}

// Its parameters as the build scripts write them (`crate::rust_source`).
struct_to_rust!(
    Crane3dParams {
        m,
        g,
        tau1,
        tau2,
        tau3,
        workspace,
        min_tension_fraction,
    } = <Crane3dParams as FirmwareCrane<3>>::TYPE
);
struct_to_rust!(
    Workspace3d {
        x_min,
        x_max,
        y_min,
        y_max,
        l_min,
        l_max,
    } = "solver_core::models::crane3d::Workspace3d"
);

impl FirmwareCrane<3> for Crane3dParams {
    const TYPE: &'static str = "solver_core::models::crane3d::Crane3dParams";
    const QEMU_SCENES: &'static [&'static str] = &[
        "scenes/crane3d/crane3d.toml",
        "scenes/crane3d/crane3d-radau5.toml",
        "scenes/crane3d/crane3d-ext.toml",
    ];
    type Model = SpatialModel;
    type Feedback = SpatialFeedback;
    const FEEDBACK_TYPE: &'static str = "controller::feedback3d::SpatialFeedback";
    const FEEDBACK_NEW: &'static str = "Correction::new(FEEDBACK, PARAMS.tau2)";
    type FeedforwardOnly = NoFeedback;
    fn of(model: &ModelSpec) -> Option<(Self, SpatialModel)> {
        match model {
            ModelSpec::Crane3dSubs(c) => Some((c.params(), SpatialModel::Subs)),
            ModelSpec::Crane3dExt(c) => Some((c.params(), SpatialModel::Ext)),
            // Another crane's or rig's model.
            _ => None,
        }
    }
    /// The x–z plane's configuration (bridge and hoist: τ1, τ3) from the scene's
    /// `[feedback]`; the y–z plane's is the same with the trolley's τ2
    /// ([`SpatialFeedback::new`]).
    fn feedback_config(
        spec: &FeedbackConfig,
        crane: &Self,
        h: f64,
    ) -> Result<FeedbackConfig, SceneError> {
        let w = crane.workspace;
        let plane = CraneParams {
            m: crane.m,
            g: crane.g,
            tau1: crane.tau1,
            tau2: crane.tau3,
            workspace: solver_core::models::crane::Workspace {
                x_min: w.x_min,
                x_max: w.x_max,
                l_min: w.l_min,
                l_max: w.l_max,
            },
            min_tension_fraction: crane.min_tension_fraction,
        };
        crate::feedback::config(spec, &plane, h)
    }
    fn feedback(&self, config: FeedbackConfig) -> Result<SpatialFeedback, DesignError> {
        SpatialFeedback::new(config, self.tau2)
    }
    type Operator = Settings<2>;
    const OPERATOR_TYPE: &'static str = "solver_core::operator::Settings<2>";
    const STEERED_TYPE: &'static str =
        "controller::operator::path::Steered<solver_core::operator::Generator3d, 3>";
    /// Only *subs* has the controller's reference on the generator's path
    /// (`controller::crane::spatial`); bridge and trolley range over the workspace box,
    /// the hoist over the depths the rope's range allows.
    /// *subs* only: only it has the controller's reference on the generator's path.
    fn manual_mode(model: SpatialModel) -> bool {
        model == SpatialModel::Subs
    }
    fn operator_settings(
        spec: &OperatorSpec,
        crane: &Self,
        model: SpatialModel,
        h: f64,
    ) -> Result<Settings<2>, SceneError> {
        if !Self::manual_mode(model) {
            return Err(only_subs("3D crane", "crane3d-subs", model));
        }
        let w = crane.workspace;
        spec.settings(
            Settings::lab_3d(crane),
            h,
            (w.l_min, w.l_max),
            &["bridge", "trolley", "hoist"],
        )
    }
    fn steered_inverse_model<V: FirmwareVisitor<Self, 3>>(
        self,
        model: SpatialModel,
        integrator: FirmwareIntegrator,
        plan: Plan<f64, 3>,
        operator: Settings<2>,
        settings: &SolverSettings,
        visitor: V,
    ) -> Result<V::Output, FirmwareError> {
        type P = Steered<Generator3d, 3>;
        if model != SpatialModel::Subs {
            return Err(FirmwareError::NoManualMode {
                crane: <Self as Crane<3>>::NAME,
                model: model.path().1,
            });
        }
        Ok(integrators!(
            Structured,
            visit,
            solver_core::models::crane3d::subs,
            integrator,
            solver_core::models::crane3d::Crane3dSubs::new(self, P::new(plan, operator))?,
            settings,
            visitor,
            P
        ))
    }
}
