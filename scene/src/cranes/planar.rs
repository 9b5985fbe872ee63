//! The paper's planar crane (trolley and winch; Eqs. 24–28, Tab. 3) as the firmware
//! drives it: its formulations and its [`FirmwareCrane`] registration.

use controller::feedback::{Config as FeedbackConfig, DesignError, NoFeedback, StateFeedback};
use solver_core::models::crane::CraneParams;

use super::{crane_models, FirmwareCrane};
use crate::feedback::FeedbackSpec;
use crate::{ModelSpec, SceneError};

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

impl FirmwareCrane<2> for CraneParams {
    const TYPE: &'static str = "solver_core::models::crane::CraneParams";
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
    fn source(&self) -> String {
        let w = self.workspace;
        format!(
            "solver_core::models::crane::CraneParams {{ m: {:?}, g: {:?}, tau1: {:?}, tau2: {:?}, workspace: solver_core::models::crane::Workspace {{ x_min: {:?}, x_max: {:?}, l_min: {:?}, l_max: {:?} }}, min_tension_fraction: {:?} }}",
            self.m, self.g, self.tau1, self.tau2, w.x_min, w.x_max, w.l_min, w.l_max, self.min_tension_fraction
        )
    }
    fn feedback_config(
        spec: &FeedbackSpec,
        crane: &Self,
        h: f64,
    ) -> Result<FeedbackConfig, SceneError> {
        spec.config(crane, h)
    }
    fn feedback(&self, config: FeedbackConfig) -> Result<StateFeedback, DesignError> {
        StateFeedback::new(config)
    }
}
