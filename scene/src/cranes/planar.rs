//! The paper's planar crane (trolley and winch; Eqs. 24–28, Tab. 3) as the firmware
//! drives it: its formulations and its [`FirmwareCrane`] registration.

use controller::crane::Crane;
use controller::feedback::{Config as FeedbackConfig, DesignError, NoFeedback, StateFeedback};
use controller::operator::path::Steered;
use solver_core::models::crane::{CraneParams, Workspace};
use solver_core::operator::{PlanarGenerator, Settings};
use solver_core::plan::Plan;
use solver_core::reference::flat_crane::flat_inverse;
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
    PlanarModel for CraneParams, 2 {
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
    } = <CraneParams as FirmwareCrane<2>>::TYPE
);
struct_to_rust!(
    Workspace {
        x_min,
        x_max,
        l_min,
        l_max
    } = "solver_core::models::crane::Workspace"
);

impl FirmwareCrane<2> for CraneParams {
    const TYPE: &'static str = "solver_core::models::crane::CraneParams";
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
            ModelSpec::CraneSubs(c) => Some((c.params(), PlanarModel::Subs)),
            ModelSpec::CraneProj(c) => Some((c.params(), PlanarModel::Proj)),
            ModelSpec::CraneExt(c) => Some((c.params(), PlanarModel::Ext)),
            // Another crane's or rig's model.
            _ => None,
        }
    }
    fn feedback_config(
        spec: &FeedbackConfig,
        crane: &Self,
        h: f64,
    ) -> Result<FeedbackConfig, SceneError> {
        crate::feedback::config(spec, crane, h)
    }
    fn feedback(&self, config: FeedbackConfig) -> Result<StateFeedback, DesignError> {
        StateFeedback::new(config)
    }
    type Operator = Settings<1>;
    const OPERATOR_TYPE: &'static str = "solver_core::operator::Settings<1>";
    const STEERED_TYPE: &'static str =
        "controller::operator::path::Steered<solver_core::operator::PlanarGenerator, 2>";
    /// Only *subs* has the controller's reference on the generator's path
    /// (`controller::crane::planar`); the trolley's range is the workspace's, the hoist's
    /// the depths the rope's range allows.
    /// *subs* only: only it has the controller's reference on the generator's path.
    fn manual_mode(model: PlanarModel) -> bool {
        model == PlanarModel::Subs
    }
    fn operator_settings(
        spec: &OperatorSpec,
        crane: &Self,
        model: PlanarModel,
        h: f64,
    ) -> Result<Settings<1>, SceneError> {
        if !Self::manual_mode(model) {
            return Err(only_subs("planar crane", "crane-subs", model));
        }
        let w = crane.workspace;
        spec.settings(
            Settings::lab(crane),
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
            solver_core::models::crane_subs::CraneSubs::new(self, P::new(plan, operator))?,
            settings,
            visitor,
            P
        ))
    }
}
