//! A scene read and checked whole: TOML into [`Scene`], the fields one by one, then its
//! model built from them (`dispatch::model`). The check that builds the model is the one
//! that needs the dispatch, so it sits here, above both, and the scene's types below it
//! (`lib.rs`) import nothing from the dispatch.

use std::path::Path;

use serde::Deserialize;

use crate::cranes::{visit_crane, CraneVisitor, FirmwareCrane, FirmwareModel};
use crate::dispatch::{self, Built};
use crate::{
    key_at, refuse, JacobianSpec, NewtonSpec, OperatorSpec, ScalarSpec, Scene, SceneError,
    SchemeSpec,
};

impl Scene {
    /// Reads and checks a scene file.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| refuse("", format!("cannot read {}: {e}", path.display())))?;
        Self::parse(&text)
    }

    /// Parses and checks a scene from TOML text.
    pub fn parse(text: &str) -> Result<Self, SceneError> {
        // toml names the key path in its message; keep its first line as the reason.
        let toml_error = |e: toml::de::Error| {
            let message = e.message().to_string();
            let field = e.span().map(|s| key_at(text, s.start)).unwrap_or_default();
            refuse(&field, message)
        };
        let mut file = toml::de::DeTable::parse(text).map_err(toml_error)?;
        // `[feedback]` is the controller's own configuration, read on its own
        // (`feedback::section`); the rest is the scene's types'.
        let feedback = file.get_mut().remove("feedback");
        let mut scene =
            Scene::deserialize(toml::de::Deserializer::from(file)).map_err(toml_error)?;
        scene.feedback = feedback
            .map(|section| crate::feedback::section(text, section))
            .transpose()?;
        scene.validate()?;
        Ok(scene)
    }

    /// Every check that does not need a run: types, ranges, and the model built
    /// from its parameters and trajectory (rope slack, workspace, smoothness).
    /// Call it again after changing a scene's fields.
    pub fn validate(&self) -> Result<(), SceneError> {
        let t = &self.trajectory;
        if !(t.t_end.is_finite() && t.t_end > 0.0) {
            return Err(refuse(
                "trajectory.t_end",
                format!("must be finite and > 0 (got {})", t.t_end),
            ));
        }
        if t.t_start < 0.0 {
            return Err(refuse(
                "trajectory.t_start",
                "must be ≥ 0: the run starts at rest at t = 0",
            ));
        }
        let s = &self.solver;
        if s.scheme == SchemeSpec::Bdf && !(1..=6).contains(&s.k) {
            return Err(refuse(
                "solver.k",
                format!("BDF needs k in 1..=6 (got {})", s.k),
            ));
        }
        if s.reinit_every.is_some() && s.jacobian != JacobianSpec::Broyden {
            return Err(refuse(
                "solver.reinit_every",
                "only applies to jacobian = \"broyden\"",
            ));
        }
        if s.newton == NewtonSpec::Transformed
            && (s.scheme != SchemeSpec::Radau || s.jacobian != JacobianSpec::Exact)
        {
            return Err(refuse(
                "solver.newton",
                "\"transformed\" needs scheme = \"radau\" and jacobian = \"exact\"",
            ));
        }
        if s.reinit_every == Some(0) {
            return Err(refuse(
                "solver.reinit_every",
                "must be ≥ 1 (omit it for continuous updating)",
            ));
        }
        self.settings().validate().map_err(|e| self.field_of(e))?;
        if self.steps() == 0 {
            return Err(refuse(
                "solver.h",
                "longer than the whole run (trajectory.t_end)",
            ));
        }
        dispatch::model::<f64, _>(self, Built)?;
        check_operator(self)
    }
}

/// Checks the scene's `[operator]`, if it has one: a crane the firmware drives, in f64,
/// whose formulation runs manual mode, and keys the generator can work with
/// (`FirmwareCrane::operator_settings`).
fn check_operator(scene: &Scene) -> Result<(), SceneError> {
    /// The crane's own check, as its type.
    struct Check<'a>(&'a Scene, &'a OperatorSpec);
    impl CraneVisitor for Check<'_> {
        type Output = Result<(), SceneError>;
        fn visit<K: FirmwareCrane<A>, const A: usize>(self, model: K::Model) -> Self::Output {
            let Check(scene, spec) = self;
            let (crane, _) = K::of(&scene.model)
                .ok_or_else(|| refuse("operator", "the scene's model is not its crane's"))?;
            K::operator_settings(spec, &crane, model, scene.solver.h).map(|_| ())
        }
    }
    let Some(spec) = &scene.operator else {
        return Ok(());
    };
    let model = FirmwareModel::of(&scene.model).map_err(|_| {
        refuse(
            "operator",
            format!(
                "manual mode drives a crane the firmware drives; this scene is the {}",
                scene.model.label()
            ),
        )
    })?;
    if scene.solver.scalar != ScalarSpec::F64 {
        return Err(refuse(
            "operator",
            "manual mode runs in the firmware's f64; this scene computes in f32",
        ));
    }
    visit_crane(model, Check(scene, spec))
}
