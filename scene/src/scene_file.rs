//! The scene file's own types: the model, trajectory and solver sections as a scene
//! reads them, and the scene (feature `host`).

use std::fmt;

use controller::feedback::Config;
use nalgebra::SVector;
use serde::Deserialize;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::Crane3dParams;
use solver_core::models::double_pendulum_crane::DoublePendulumParams;
use solver_core::models::mass_on_car::MassOnCarParams;
use solver_core::scalar::c;
use solver_core::trajectory::PointToPoint;
use solver_core::{Error, JacobianMode, NewtonSettings, Real, SolverSettings};

pub use crate::params::Params;

/// Why a scene was refused: the field (dotted path) and the reason.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneError {
    /// The offending field, e.g. `solver.h` (empty when the file as a whole is unreadable).
    pub field: String,
    /// What is wrong with it.
    pub reason: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.field.is_empty() {
            write!(f, "{}", self.reason)
        } else {
            write!(f, "field `{}`: {}", self.field, self.reason)
        }
    }
}

impl std::error::Error for SceneError {}

pub(crate) fn refuse(field: &str, reason: impl Into<String>) -> SceneError {
    SceneError {
        field: field.to_string(),
        reason: reason.into(),
    }
}

/// A scene as read from its file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Short name (used for file names of results).
    pub name: String,
    /// What the scene is for.
    #[serde(default)]
    pub description: String,
    /// The model and its parameters.
    pub model: ModelSpec,
    /// The desired output trajectory.
    pub trajectory: TrajectorySpec,
    /// How to solve.
    pub solver: SolverSpec,
    /// The state feedback around the inverse model (Fig. 1), if the scene closes the
    /// loop: the `[feedback]` section read into the controller's own configuration (its
    /// weights and thresholds; the crane's and the cycle's fields are
    /// [`Config::PAPER`]'s until `feedback::config` sets them). [`Scene::parse`] reads
    /// the section (`feedback::section`: its keys are two types' side by side), so serde
    /// skips it here.
    #[serde(skip)]
    pub feedback: Option<Config>,
    /// Manual mode (issue 28): with the section the scene's model follows the plan or
    /// the operator's generator (`controller::operator::path::Steered`) and a PLC's
    /// 0x410 frames drive the crane; without it, plans only (checked and turned into
    /// the generator's settings in `operator.rs`).
    #[serde(default)]
    pub operator: Option<OperatorSpec>,
}

/// `[operator]` as read: every key optional, its default the crane's lab setting
/// (`solver_core::operator::Settings::lab` / `lab_3d`); the keys, units and checks are
/// described in the `operator` module.
///
/// A partial setting, not `Settings` itself: its default depends on the crane (`lab` or
/// `lab_3d`, each from the crane's parameters, the hoist's range from the rope's), which a
/// type's default cannot know, and its shape is not the file's — `speed` and
/// `acceleration` are one list over every axis where `Settings` keeps the horizontal axes
/// apart from the hoist, and `h`, `g` and the ranges are the scene's, not keys of the
/// section. [`OperatorSpec::settings`] lays the keys given over the crane's lab setting.
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
#[allow(missing_docs)]
pub struct OperatorSpec {
    pub speed: Option<Vec<f64>>,
    pub acceleration: Option<Vec<f64>>,
    pub boxes: Option<[f64; 2]>,
    pub hoist_boxes: Option<[f64; 4]>,
    pub robust: Option<bool>,
    pub deadband: Option<f64>,
    pub lowering_allowance: Option<f64>,
    pub entry_blend: Option<f64>,
}

/// The models a scene names, listed once: the one registration of a model. A group is
/// one parameter type `P` (the model's [`crate::family::ModelFamily`], its `NZ` outputs), a
/// row one formulation of it: its scene `kind`, its `label` in results, its
/// `formulation` on the sweep's axis (`subs`, `ext`, `direct`), and its type under
/// `solver_core::models` (`module`, `model`: built by `model::new(P, move)`, its sizes
/// the module's `N`, `NU`, `S`). Makes [`ModelSpec`] (one variant a row),
/// [`ModelSpec::KINDS`], one accessor per parameter type (the parameters whatever the
/// formulation, `None` for another model), [`ModelSpec::label`],
/// [`ModelSpec::outputs`], [`ModelSpec::accuracy_threshold`],
/// [`ModelSpec::with_formulation`], and the scene's model built on its move for the
/// studies and its exact reference (`Scene::build_model`, `Scene::exact_inputs`, which
/// `dispatch` hands on). A row missing a part, or a parameter type without its
/// `ModelFamily`, does not compile. A new model is one row here and its files elsewhere;
/// a new crane, one group (docs/MODELS.md).
macro_rules! model_specs {
    (
        $(
            $(#[$group_doc:meta])*
            $accessor:ident($params:ty, $outputs:literal) {
                $(
                    $(#[$doc:meta])*
                    $variant:ident {
                        kind: $kind:literal,
                        label: $label:literal,
                        formulation: $formulation:literal,
                        module: $module:ident $(:: $sub:ident)*,
                        model: $model:ident $(,)?
                    }
                )+
            }
        )+
    ) => {
        /// Which model, with optional parameters (the model's defaults: the crate's doc).
        #[derive(Debug, Clone, PartialEq, Deserialize)]
        #[serde(tag = "kind")]
        pub enum ModelSpec {
            $( $( $(#[$doc])* #[serde(rename = $kind)] $variant(Params<$params>), )+ )+
        }

        impl ModelSpec {
            /// Every `kind` a scene can name, in the order registered.
            pub const KINDS: &'static [&'static str] = &[$( $( $kind, )+ )+];

            $(
                $(#[$group_doc])*
                #[must_use]
                pub fn $accessor(&self) -> Option<Params<$params>> {
                    match self {
                        $( ModelSpec::$variant(p) )|+ => Some(*p),
                        #[allow(unreachable_patterns)]
                        _ => None,
                    }
                }
            )+

            /// The parameter groups whose accessor gives this model its parameters, each
            /// as its accessor's name and its number of outputs: exactly one, with the
            /// model's [`ModelSpec::outputs`] (`scene/tests/scenes.rs` checks every kind).
            #[must_use]
            pub fn parameter_groups(&self) -> Vec<(&'static str, usize)> {
                let mut groups = Vec::new();
                $(
                    if self.$accessor().is_some() {
                        groups.push((stringify!($accessor), $outputs));
                    }
                )+
                groups
            }

            /// The model's short name in results (the table's label for its kind).
            #[must_use]
            pub fn label(&self) -> &'static str {
                match self {
                    $( $( ModelSpec::$variant(_) => $label, )+ )+
                }
            }

            /// Number of output axes the model needs (the move's).
            #[must_use]
            pub fn outputs(&self) -> usize {
                match self {
                    $( $( ModelSpec::$variant(_) )|+ => $outputs, )+
                }
            }

            /// The e_max above which a run of the model counts as inaccurate (its
            /// family's [`crate::family::ModelFamily::ACCURACY_THRESHOLD`]).
            #[must_use]
            pub fn accuracy_threshold(&self) -> f64 {
                match self {
                    $( $( ModelSpec::$variant(_) )|+ =>
                        <$params as crate::family::ModelFamily<$outputs>>::ACCURACY_THRESHOLD, )+
                }
            }

            /// The table a scene writes the model's crane keys in
            /// ([`crate::family::ModelFamily::CRANE_KEYS_UNDER`]).
            fn crane_keys_under(&self) -> &'static str {
                match self {
                    $( $( ModelSpec::$variant(_) )|+ =>
                        <$params as crate::family::ModelFamily<$outputs>>::CRANE_KEYS_UNDER, )+
                }
            }

            /// The same model's formulation `name` (its `formulation` or its `label`)
            /// with the same parameters: the sweep's formulation axis.
            pub fn with_formulation(&self, name: &str) -> Result<ModelSpec, FormulationError> {
                match self {
                    $(
                        $( ModelSpec::$variant(p) )|+ => {
                            let p = *p;
                            $(
                                if name == $formulation || name == $label {
                                    return Ok(ModelSpec::$variant(p));
                                }
                            )+
                            Err(FormulationError {
                                model: <$params as crate::family::ModelFamily<$outputs>>::NAME,
                                formulations: &[$( $formulation ),+],
                            })
                        }
                    )+
                }
            }
        }

        impl Scene {
            /// The scene's model built on its move in `T`, handed to `visitor`; a model
            /// its parameters or move make impossible (rope slack, workspace,
            /// smoothness) is refused (`dispatch::model`).
            pub(crate) fn build_model<T: Real, V: crate::family::ModelVisitor<T>>(
                &self,
                visitor: V,
            ) -> Result<V::Output, SceneError> {
                let err = |e: Error| self.field_of(e);
                Ok(match &self.model {
                    $( $(
                        ModelSpec::$variant(p) => {
                            use solver_core::models::$module $(:: $sub)* as m;
                            visitor.visit::<_, { m::N }, { m::NU }, { m::S }>(
                                m::$model::new(p.params(), trajectory::<T, $outputs>(self)?)
                                    .map_err(err)?,
                            )
                        }
                    )+ )+
                })
            }

            /// The exact inputs of the scene's model along its move
            /// ([`crate::family::ModelFamily::exact`]: `dispatch::Exact`).
            pub(crate) fn exact_inputs(
                &self,
            ) -> Result<Box<dyn crate::family::ExactInputs>, SceneError> {
                match &self.model {
                    $(
                        $( ModelSpec::$variant(p) )|+ => {
                            let z = trajectory::<f64, $outputs>(self)?;
                            let exact =
                                <$params as crate::family::ModelFamily<$outputs>>::exact(p.params(), z)
                                    .map_err(|e| self.field_of(e))?;
                            Ok(Box::new(exact))
                        }
                    )+
                }
            }
        }
    };
}

model_specs! {
    /// The planar crane's parameters, whatever the formulation (`None` for another model).
    crane(CraneParams, 2) {
        /// Crane, redundant coordinates with the servo-constraints substituted.
        CraneSubs {
            kind: "crane-subs", label: "subs", formulation: "subs",
            module: crane_subs, model: CraneSubs,
        }
        /// Crane, minimal coordinates projected after Blajer.
        CraneProj {
            kind: "crane-proj", label: "proj", formulation: "proj",
            module: crane_proj, model: CraneProj,
        }
        /// Crane, *subs* minimally extended to index 1 (the hidden constraints appended).
        CraneExt {
            kind: "crane-ext", label: "ext", formulation: "ext",
            module: crane_ext, model: CraneExt,
        }
    }
    /// The mass-on-car's scene parameters, whatever the formulation.
    mass_on_car_spec(MassOnCarParams, 1) {
        /// Mass-on-car with internal dynamics.
        MassOnCar {
            kind: "mass-on-car", label: "mass-on-car", formulation: "direct",
            module: mass_on_car, model: MassOnCar,
        }
        /// Mass-on-car, minimally extended to index 1.
        MassOnCarExt {
            kind: "mass-on-car-ext", label: "mass-on-car-ext", formulation: "ext",
            module: mass_on_car_ext, model: MassOnCarExt,
        }
    }
    /// The 3D crane's parameters, whatever the formulation (`None` for another model).
    crane3d(Crane3dParams, 3) {
        /// The crane in three dimensions (bridge, trolley, hoist), redundant coordinates
        /// with the servo-constraints substituted.
        Crane3dSubs {
            kind: "crane3d-subs", label: "3d-subs", formulation: "subs",
            module: crane3d::subs, model: Crane3dSubs,
        }
        /// The crane in three dimensions, *subs* minimally extended to index 1.
        Crane3dExt {
            kind: "crane3d-ext", label: "3d-ext", formulation: "ext",
            module: crane3d::ext, model: Crane3dExt,
        }
    }
    /// The hook-and-load crane's parameters, whatever the formulation (`None` for another
    /// model).
    double_pendulum(DoublePendulumParams, 2) {
        /// The hook-and-load crane (a double pendulum), redundant coordinates with the
        /// servo-constraints substituted.
        DoublePendulumSubs {
            kind: "double-pendulum-subs", label: "dp-subs", formulation: "subs",
            module: double_pendulum, model: DoublePendulumSubs,
        }
        /// The hook-and-load crane, *subs* minimally extended to index 1.
        DoublePendulumExt {
            kind: "double-pendulum-ext", label: "dp-ext", formulation: "ext",
            module: double_pendulum_ext, model: DoublePendulumExt,
        }
    }
}

impl ModelSpec {
    /// The mass-on-car's parameters, whatever the formulation (`None` for a crane).
    #[must_use]
    pub fn mass_on_car(&self) -> Option<MassOnCarParams> {
        self.mass_on_car_spec().map(|m| m.params())
    }
}

/// A formulation the scene's model does not have (the sweep's formulation axis): the
/// model and the formulations it has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FormulationError {
    /// The model ([`crate::family::ModelFamily::NAME`]).
    pub model: &'static str,
    /// Its formulations' names, in the order registered.
    pub formulations: &'static [&'static str],
}

impl fmt::Display for FormulationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}'s are ", self.model)?;
        let last = self.formulations.len().saturating_sub(1);
        for (i, name) in self.formulations.iter().enumerate() {
            let sep = match i {
                0 => "",
                i if i == last => " and ",
                _ => ", ",
            };
            write!(f, "{sep}{name}")?;
        }
        Ok(())
    }
}

impl std::error::Error for FormulationError {}

/// A point-to-point move.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct TrajectorySpec {
    pub start: Vec<f64>,
    pub end: Vec<f64>,
    pub t_start: f64,
    pub duration: f64,
    pub smoothness: usize,
    pub t_end: f64,
}

/// Integrator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SchemeSpec {
    /// BDF with `k` steps.
    Bdf,
    /// 3-stage Radau IIA.
    Radau,
}

/// Jacobian mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JacobianSpec {
    /// Finite differences every iteration (J).
    Fd,
    /// Broyden (J̃, J̃_N with `reinit_every = N`).
    Broyden,
    /// Exact partials.
    Exact,
}

/// How Newton treats Radau's stage system.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NewtonSpec {
    /// Newton on the whole stage system with the chosen Jacobian (the paper's modes).
    #[default]
    Full,
    /// RADAU5's simplified Newton on the transformed stage system, exact partials kept
    /// across steps (`JacobianMode::Transformed`); Radau with `jacobian = "exact"` only.
    Transformed,
}

/// Scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ScalarSpec {
    /// Double precision (default).
    F64,
    /// Single precision.
    F32,
}

/// Solver settings.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(missing_docs)]
pub struct SolverSpec {
    pub scheme: SchemeSpec,
    #[serde(default = "default_k")]
    pub k: usize,
    pub h: f64,
    pub jacobian: JacobianSpec,
    #[serde(default)]
    pub reinit_every: Option<u32>,
    #[serde(default)]
    pub newton: NewtonSpec,
    #[serde(default = "default_rho")]
    pub rho_power: u32,
    #[serde(default = "default_iterations")]
    pub max_iterations: u32,
    #[serde(default = "default_scalar")]
    pub scalar: ScalarSpec,
}

fn default_k() -> usize {
    4
}
fn default_rho() -> u32 {
    2
}
fn default_iterations() -> u32 {
    20
}
fn default_scalar() -> ScalarSpec {
    ScalarSpec::F64
}

impl Scene {
    /// Number of output axes the model needs.
    pub fn outputs(&self) -> usize {
        self.model.outputs()
    }

    /// The interior of the move, `[t_start + T/8, t_start + 7T/8]`: away from its
    /// ends, where the trajectory's (n+1)-th derivative jumps and limits every scheme.
    pub fn interior(&self) -> (f64, f64) {
        let t = &self.trajectory;
        (
            t.t_start + t.duration / 8.0,
            t.t_start + 7.0 * t.duration / 8.0,
        )
    }

    /// Number of steps of the run.
    pub fn steps(&self) -> usize {
        ((self.trajectory.t_end) / self.solver.h).round() as usize
    }

    /// The solver-core settings.
    pub fn settings(&self) -> SolverSettings {
        let s = &self.solver;
        let jacobian = match s.jacobian {
            JacobianSpec::Fd => JacobianMode::FiniteDifference,
            JacobianSpec::Exact if s.newton == NewtonSpec::Transformed => JacobianMode::Transformed,
            JacobianSpec::Exact => JacobianMode::Exact,
            JacobianSpec::Broyden => JacobianMode::Broyden {
                reinit_every: s.reinit_every,
            },
        };
        let newton = match s.scalar {
            ScalarSpec::F64 => NewtonSettings::for_scalar::<f64>(),
            ScalarSpec::F32 => NewtonSettings::for_scalar::<f32>(),
        };
        SolverSettings {
            h: s.h,
            jacobian,
            scaling_power: s.rho_power,
            newton: NewtonSettings {
                max_iterations: s.max_iterations,
                ..newton
            },
        }
    }

    /// The crane trajectory (two axes).
    pub fn trajectory2(&self) -> Result<PointToPoint<f64, 2>, SceneError> {
        self.trajectory_n::<2>()
    }

    /// The 3D crane's trajectory (three axes).
    pub fn trajectory3(&self) -> Result<PointToPoint<f64, 3>, SceneError> {
        self.trajectory_n::<3>()
    }

    /// The mass-on-car trajectory (one axis).
    pub fn trajectory1(&self) -> Result<PointToPoint<f64, 1>, SceneError> {
        self.trajectory_n::<1>()
    }

    fn trajectory_n<const NZ: usize>(&self) -> Result<PointToPoint<f64, NZ>, SceneError> {
        trajectory::<f64, NZ>(self)
    }

    /// Maps a solver-core error to the scene field it comes from.
    pub fn field_of(&self, e: Error) -> SceneError {
        let field = match e {
            Error::InvalidStepSize { .. } => "solver.h".to_string(),
            Error::InvalidSetting { name, .. } => match name {
                "scaling_power" => "solver.rho_power".to_string(),
                "bdf_k" => "solver.k".to_string(),
                "reinit_every" | "max_iterations" => format!("solver.{name}"),
                other => format!("solver.{other}"),
            },
            Error::NonFiniteParameter { name, .. } | Error::ParameterOutOfRange { name, .. } => {
                match name {
                    "alpha" => "model.alpha_deg".to_string(),
                    "smoothness" => "trajectory.smoothness".to_string(),
                    "trajectory start" => "trajectory.start".to_string(),
                    "trajectory end" => "trajectory.end".to_string(),
                    "trajectory t_start" => "trajectory.t_start".to_string(),
                    "trajectory duration" => "trajectory.duration".to_string(),
                    other => self.model_key(other),
                }
            }
            Error::TrajectoryTooRough { .. } => "trajectory.smoothness".to_string(),
            Error::RopeSlack { .. } | Error::OutsideWorkspace { .. } => "trajectory".to_string(),
            _ => String::new(),
        };
        refuse(&field, e.to_string())
    }

    /// The dotted key of the model's parameter `name` (a solver-core error's name): the
    /// workspace's in `[model.workspace]`, the hook-and-load crane's crane keys in
    /// `[model.crane]`.
    fn model_key(&self, name: &str) -> String {
        let workspace = matches!(
            name,
            "x_min" | "x_max" | "y_min" | "y_max" | "l_min" | "l_max"
        );
        let crane =
            workspace || matches!(name, "m" | "g" | "tau1" | "tau2" | "min_tension_fraction");
        let key = if workspace {
            format!("workspace.{name}")
        } else {
            name.to_string()
        };
        if crane {
            format!("{}.{key}", self.model.crane_keys_under())
        } else {
            format!("model.{key}")
        }
    }
}

/// The scene's move in the scalar `T`, with its `NZ` output axes.
pub(crate) fn trajectory<T: Real, const NZ: usize>(
    scene: &Scene,
) -> Result<PointToPoint<T, NZ>, SceneError> {
    let t = &scene.trajectory;
    for (field, v) in [("trajectory.start", &t.start), ("trajectory.end", &t.end)] {
        if v.len() != NZ {
            return Err(refuse(
                field,
                format!("needs {NZ} values (one per output axis), has {}", v.len()),
            ));
        }
    }
    PointToPoint::new(
        SVector::<T, NZ>::from_iterator(t.start.iter().map(|v| c::<T>(*v))),
        SVector::<T, NZ>::from_iterator(t.end.iter().map(|v| c::<T>(*v))),
        c(t.t_start),
        c(t.duration),
        t.smoothness,
    )
    .map_err(|e| scene.field_of(e))
}

/// The dotted key on the line that holds byte `pos` (best effort, for messages):
/// `table.key` for a `key = value` line, `table` for a `[table]` header.
pub(crate) fn key_at(text: &str, pos: usize) -> String {
    let line_start = text
        .get(..pos)
        .and_then(|b| b.rfind('\n'))
        .map_or(0, |i| i + 1);
    let line = text
        .get(line_start..)
        .and_then(|r| r.lines().next())
        .unwrap_or("")
        .trim();
    let header = |l: &str| {
        l.strip_prefix('[')
            .and_then(|r| r.strip_suffix(']'))
            .map(str::to_string)
    };
    if let Some(table) = header(line) {
        return table;
    }
    let table = text
        .get(..line_start)
        .unwrap_or("")
        .lines()
        .rev()
        .find_map(|l| header(l.trim()))
        .unwrap_or_default();
    match line.split_once('=').map(|(k, _)| k.trim()) {
        Some(k) if table.is_empty() => k.to_string(),
        Some(k) => format!("{table}.{k}"),
        None => table,
    }
}
