//! The registry's machinery (host only): what the firmware's setup asks of a crane
//! ([`FirmwareCrane`]), a crane's formulations (`crane_models!`), the integrators a
//! scheme names (`integrators!`) and the one list of cranes (`registry!`), from which
//! [`FirmwareModel`] and [`visit_crane`] follow.

use core::fmt;

use controller::commands::Reject;
use controller::correction::AxesCorrection;
use controller::feedback::{Config as FeedbackConfig, DesignError};
use controller::feedforward::{CraneReference, Feedforward, InverseModel, Replan};
use controller::operator::path::Planned;
use controller::planner::Crane;
use sim::simulated::Simulated;
use solver_core::plan::Plan;
use solver_core::trajectory::Trajectory;
use solver_core::{DaeModel, Driven, Error, Integrator, SolverSettings};

use crate::rust_source::ToRust;
use crate::{ModelSpec, OperatorSpec, SceneError};

/// What is done with the firmware's inverse model for a crane with `A` driven axes (the
/// host's run of the firmware, the virtual ECU), whatever its types.
pub trait FirmwareVisitor<K: Crane<A>, const A: usize> {
    /// What it gives.
    type Output;
    /// Does it with `feedforward`: the scene's model on the firmware's plan, advanced by
    /// the integrator the firmware links.
    fn visit<F: Feedforward<A, Reference = K::Reference> + Replan<A> + 'static>(
        self,
        feedforward: F,
    ) -> Self::Output;
}

/// What is done with the integrator the firmware links for a scene and the model it
/// steps, whatever the trajectory type that drives it (the cost measurements of `cargo
/// xtask instructions`, `host-tests/src/bin/steps.rs`).
pub trait StepsVisitor {
    /// What it gives.
    type Output;
    /// Does it with `model` and `integrator`, at rest at t = 0.
    fn visit<
        M: DaeModel<f64, N, NU>,
        I: Integrator<f64, M, N, NU>,
        const N: usize,
        const NU: usize,
    >(
        self,
        model: M,
        integrator: I,
    ) -> Self::Output;
}

/// The scheme and Newton strategy the firmware links, one of each model's scheme
/// aliases (`schemes_of!` in solver-core's `models`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FirmwareIntegrator {
    /// BDF k, the structured elimination (h below 5 ms: with the closed form's
    /// correction).
    StructuredBdf(usize),
    /// BDF k, the structured elimination, h from 5 ms on: the same steps, the correction
    /// not linked.
    StructuredBdfUncorrected(usize),
    /// BDF k, the run-time Jacobian modes on a dense LU.
    Bdf(usize),
    /// RADAU5, both stage systems by the structured elimination.
    StructuredRadau5,
    /// RADAU5 on dense LUs.
    Radau5,
    /// Radau IIA with the paper's modes on the 3N×3N system.
    RadauFull,
}

impl FirmwareIntegrator {
    /// The alias's name and BDF's k.
    pub(crate) const fn alias(self) -> (&'static str, Option<usize>) {
        match self {
            Self::StructuredBdf(k) => ("StructuredBdf", Some(k)),
            Self::StructuredBdfUncorrected(k) => ("StructuredBdfUncorrected", Some(k)),
            Self::Bdf(k) => ("Bdf", Some(k)),
            Self::StructuredRadau5 => ("StructuredRadau5", None),
            Self::Radau5 => ("Radau5", None),
            Self::RadauFull => ("RadauFull", None),
        }
    }
}

/// How a formulation's Newton systems can be solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Structure {
    /// Dense LUs only (no `StructuredJacobian`).
    Dense,
    /// A structured elimination and a closed-form step, or dense LUs.
    Structured,
    /// The structured elimination only: the extended cranes' closed-form step is their
    /// exact solution at every h, and a dense Newton on 13 or 18 unknowns (39 or 54 in
    /// Radau's stage system) would cost more flash and time for the same bits.
    StructuredOnly,
}

/// One crane's formulations the firmware can drive (made by `crane_models!`).
pub trait CraneModel: Copy + Eq + fmt::Debug + 'static {
    /// Every one, in the order listed.
    const ALL: &'static [Self];
    /// The model's module under `solver_core::models` and its type's name.
    fn path(self) -> (&'static str, &'static str);
    /// How its Newton systems can be solved.
    fn structure(self) -> Structure;
}

/// Builds crane `K`'s formulations with the integrator a scheme names (made by
/// `crane_models!`, one arm list per crane).
pub trait Formulation<K: Crane<A>, const A: usize>: CraneModel {
    /// The firmware's inverse model: this formulation of `crane` on `plan` advanced by
    /// `integrator`, at rest at t = 0, handed to `visitor`.
    fn inverse_model<V: FirmwareVisitor<K, A>>(
        self,
        crane: K,
        integrator: FirmwareIntegrator,
        plan: Plan<f64, A>,
        settings: &SolverSettings,
        visitor: V,
    ) -> Result<V::Output, FirmwareError>;
    /// This formulation of `crane` on `z` with `integrator`, handed to `visitor`.
    fn steps<Z: Trajectory<f64, A>, V: StepsVisitor>(
        self,
        crane: K,
        z: Z,
        integrator: FirmwareIntegrator,
        settings: &SolverSettings,
        visitor: V,
    ) -> Result<V::Output, FirmwareError>;
}

/// Why the firmware cannot run a scene: the registry's one error type (the firmware's
/// build script, the host's run of the firmware and the virtual ECU print it).
#[derive(Debug, Clone, PartialEq)]
pub enum FirmwareError {
    /// The scene computes in f32; the firmware plans moves in f64.
    F32Scene,
    /// The scene's model is no registered crane's (`model`: its label).
    NotACrane {
        /// The model's label.
        model: &'static str,
    },
    /// The scene's model belongs to another crane than the one asked for.
    NotThisCrane {
        /// The model's label.
        model: &'static str,
        /// The crane asked for (`Crane::NAME`).
        crane: &'static str,
    },
    /// A formulation the firmware runs with its structured Newton only, with a scheme
    /// that is not.
    StructuredOnly {
        /// The model's label.
        model: &'static str,
    },
    /// A structured integrator named for a model without a structured elimination
    /// (`FirmwareScheme::of` never names one; refused rather than built as a dense one).
    NotStructured {
        /// The model's type, its name only ([`type_name`]): as [`Self::NoManualMode`]
        /// names it.
        model: &'static str,
    },
    /// Manual mode asked of a formulation that does not run it.
    NoManualMode {
        /// The crane (`Crane::NAME`).
        crane: &'static str,
        /// The formulation's type.
        model: &'static str,
    },
    /// The scene refused for this crane: its move, its `[feedback]` or its `[operator]`.
    Scene(SceneError),
    /// The commissioning file refused for this crane.
    Commissioning(SceneError),
    /// The scene's move breaks one of the planner's rules (docs/COMMANDS.md): it must
    /// pass the checks every commanded move passes.
    PlannerRule(Reject),
    /// The cycle is not a whole number of ms (the firmware's timer counts ms).
    CycleNotWholeMs {
        /// The scene's step, s.
        h: f64,
    },
    /// The cycle is not shorter than the watchdog's period.
    CycleNotUnderWatchdog {
        /// The scene's step, s.
        h: f64,
        /// The watchdog's period, ms.
        watchdog_ms: u32,
    },
    /// The step does not divide the run's length.
    RunNotWholeCycles {
        /// The scene's step, s.
        h: f64,
        /// The run's length, s.
        t_end: f64,
    },
    /// The move starts before the drives can be commissioned and enabled.
    StartsBeforeReady {
        /// The move's start, s.
        t_start: f64,
        /// When the drives are ready, s.
        ready: f64,
        /// The scene's step, s.
        h: f64,
    },
    /// A configuration whose fault thresholds are not `Config::DEFAULT`'s: the
    /// firmware's generated configuration takes them from there
    /// (`crate::firmware::config_source`).
    ThresholdsNotDefault,
    /// The move, the plan, the model or its integrator could not be built.
    Solver(Error),
}

impl From<Error> for FirmwareError {
    fn from(e: Error) -> Self {
        Self::Solver(e)
    }
}

impl fmt::Display for FirmwareError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::F32Scene => write!(f, "the firmware plans moves in f64; this scene computes in f32"),
            Self::NotACrane { model } => {
                write!(f, "the firmware drives a crane; this scene is the {model}")
            }
            Self::NotThisCrane { model, crane } => {
                write!(f, "the scene's model ({model}) is not the {crane}'s")
            }
            Self::StructuredOnly { model } => write!(
                f,
                "the firmware runs the extended formulation ({model}) with its structured Newton only: \
                 BDF with jacobian = \"exact\", or Radau with newton = \"transformed\""
            ),
            Self::NotStructured { model } => write!(
                f,
                "a structured integrator for {model}, which has no structured elimination"
            ),
            Self::NoManualMode { crane, model } => {
                write!(f, "the {crane}'s {model} has no manual mode")
            }
            Self::Scene(e) => write!(f, "{e}"),
            Self::Commissioning(e) => write!(f, "commissioning file: {e}"),
            Self::PlannerRule(r) => write!(
                f,
                "the scene's move breaks the planner's rule {r:?} (docs/COMMANDS.md)"
            ),
            Self::CycleNotWholeMs { h } => {
                write!(f, "the firmware's cycle is a whole number of ms; h = {h} s")
            }
            Self::CycleNotUnderWatchdog { h, watchdog_ms } => write!(
                f,
                "h = {h} s is not shorter than the watchdog's {watchdog_ms} ms: every cycle would reset the controller"
            ),
            Self::RunNotWholeCycles { h, t_end } => write!(
                f,
                "h = {h} s does not divide t_end = {t_end} s: the run would stop short"
            ),
            // `ready` as it is (whole ms), not to two decimals: 1.234 printed "1.23", and
            // a move starting at 1.232 s read as refused for starting after it.
            Self::StartsBeforeReady { t_start, ready, h } => write!(
                f,
                "the move starts at {t_start} s, before the drives can be commissioned and enabled ({ready} s at h = {h} s)"
            ),
            Self::ThresholdsNotDefault => write!(
                f,
                "the firmware takes its fault thresholds from Config::DEFAULT"
            ),
            Self::Solver(e) => write!(f, "{e}"),
        }
    }
}

/// A type's own name from its full path (`core::any::type_name`): the path and the
/// generic arguments dropped — `CraneProj` of `solver_core::models::crane::CraneProj<f64,
/// …>` — so that an error names a formulation as a scene's reader knows it.
pub fn type_name(full: &'static str) -> &'static str {
    let base = full.split('<').next().unwrap_or(full);
    base.rsplit("::").next().unwrap_or(base)
}

impl std::error::Error for FirmwareError {}

impl From<FirmwareError> for String {
    fn from(e: FirmwareError) -> Self {
        e.to_string()
    }
}

/// A crane the firmware drives, registered once: how a scene names it, the lab drives'
/// limits, its parameters as the build script writes them, its formulations and its
/// state feedback.
///
/// Everything a scene builds owns its data (`'static`), so a host program may keep the
/// controller it builds (the keyboard view steps it between key presses). Its `Default`
/// is the parameters a scene that sets none gets (the panic proof's example).
pub trait FirmwareCrane<const A: usize>:
    Crane<A> + Simulated<A> + ToRust + Copy + Default + fmt::Debug + 'static
{
    /// The parameters' type, as the build script writes it.
    const TYPE: &'static str;
    /// Its shipped scenes (paths from the repository's root) whose firmware `cargo xtask
    /// qemu` runs on the healthy bus, each checked against its golden log, the host's run
    /// and its baseline (`firmware/expected/`, `firmware/baselines/`, named by the file's
    /// stem). Each is one of this crane's (`scene/tests/scenes.rs` checks).
    const QEMU_SCENES: &'static [&'static str];
    /// Its formulations (`crane_models!`).
    type Model: Formulation<Self, A>;
    /// The correction a scene's `[feedback]` links.
    type Feedback: AxesCorrection<A, Self::Reference> + 'static;
    /// [`FirmwareCrane::Feedback`]'s type, as the build script writes it.
    const FEEDBACK_TYPE: &'static str;
    /// The expression that builds it from `FEEDBACK` (and `PARAMS`), as the build script
    /// writes it ([`FirmwareCrane::feedback`] builds the same).
    const FEEDBACK_NEW: &'static str;
    /// The correction of a scene without `[feedback]`: none (`NoFeedback`, which is
    /// each crane's `AxesCorrection` on its own).
    type FeedforwardOnly: AxesCorrection<A, Self::Reference> + Default + 'static;
    /// This crane's parameters and formulation, if `model` is one of its models.
    fn of(model: &ModelSpec) -> Option<(Self, Self::Model)>;
    /// The scene's `[feedback]` as the controller's, for this crane and step `h`; or why
    /// this crane cannot honour it.
    fn feedback_config(
        spec: &FeedbackConfig,
        crane: &Self,
        h: f64,
    ) -> Result<FeedbackConfig, SceneError>;
    /// The state feedback of this crane for `config` ([`FirmwareCrane::feedback_config`]'s),
    /// or why its gains cannot be designed.
    fn feedback(&self, config: FeedbackConfig) -> Result<Self::Feedback, DesignError>;
    /// Manual mode's generator settings for this crane
    /// (`solver_core::operator::Settings` of its horizontal axes; `()` for a crane
    /// without manual mode).
    type Operator: Copy + fmt::Debug + PartialEq + ToRust;
    /// [`FirmwareCrane::Operator`]'s type, as the build script writes it.
    const OPERATOR_TYPE: &'static str;
    /// The path a model in manual mode follows, as the build script writes it: the plan
    /// or the crane's generator (`controller::operator::path::Steered`).
    const STEERED_TYPE: &'static str;
    /// Whether formulation `model` runs manual mode (the generator's path has what its
    /// reference needs): what [`FirmwareCrane::operator_settings`] accepts, and what the
    /// panic proof links with the crane's `Steered` path.
    fn manual_mode(_model: Self::Model) -> bool {
        false
    }
    /// The scene's `[operator]` as the generator's settings for this crane's formulation
    /// `model` at the cycle `h`; or why it cannot run manual mode (a formulation without
    /// `CraneReference` on the generator's path, a key out of range).
    fn operator_settings(
        spec: &OperatorSpec,
        crane: &Self,
        model: Self::Model,
        h: f64,
    ) -> Result<Self::Operator, SceneError>;
    /// The firmware's inverse model with manual mode: formulation `model` on `plan` or,
    /// in manual mode, the generator with `operator` ([`FirmwareCrane::STEERED_TYPE`]),
    /// advanced by `integrator`, at rest at t = 0, handed to `visitor`. A formulation
    /// [`FirmwareCrane::operator_settings`] refuses is refused here too.
    fn steered_inverse_model<V: FirmwareVisitor<Self, A>>(
        self,
        model: Self::Model,
        integrator: FirmwareIntegrator,
        plan: Plan<f64, A>,
        operator: Self::Operator,
        settings: &SolverSettings,
        visitor: V,
    ) -> Result<V::Output, FirmwareError>;
    /// The firmware's inverse model: formulation `model` on `plan` advanced by
    /// `integrator`, at rest at t = 0, handed to `visitor` — the types
    /// `FirmwareScheme::rust` names.
    fn inverse_model<V: FirmwareVisitor<Self, A>>(
        self,
        model: Self::Model,
        integrator: FirmwareIntegrator,
        plan: Plan<f64, A>,
        settings: &SolverSettings,
        visitor: V,
    ) -> Result<V::Output, FirmwareError> {
        model.inverse_model(self, integrator, plan, settings, visitor)
    }
    /// Formulation `model` on `z` with `integrator`, handed to `visitor` (the cost
    /// measurements).
    fn steps<Z: Trajectory<f64, A>, V: StepsVisitor>(
        self,
        model: Self::Model,
        z: Z,
        integrator: FirmwareIntegrator,
        settings: &SolverSettings,
        visitor: V,
    ) -> Result<V::Output, FirmwareError> {
        model.steps(self, z, integrator, settings, visitor)
    }
}

/// What is done with a registered crane's type and one of its formulations.
pub trait CraneVisitor {
    /// What it gives.
    type Output;
    /// Does it with crane `K` (`A` driven axes) and its formulation `model`.
    fn visit<K: FirmwareCrane<A>, const A: usize>(self, model: K::Model) -> Self::Output;
}

/// Builds the integrator of the model module `$m` (a `schemes_of!` alias) that
/// `$integrator` names on `$model` (driven by a `$plan`) and hands both to `$visit`
/// (`$visitor`, model, integrator): one arm per [`FirmwareIntegrator`], the same types
/// `FirmwareScheme::rust` names. A `Dense` model's firmware integrators are the dense
/// ones (`FirmwareScheme::of` never names a structured one for it; one named is refused).
macro_rules! integrators {
    (Dense, $visit:ident, $m:path, $integrator:expr, $model:expr, $settings:expr, $visitor:expr, $plan:ty) => {{
        use $m as m;
        let model = $model;
        match $integrator {
            FirmwareIntegrator::Bdf(k) => {
                let i = m::Bdf::<f64, $plan>::new(&model, $settings, k, 0.0)?;
                $visit($visitor, model, i)
            }
            FirmwareIntegrator::Radau5 => {
                let i = m::Radau5::<f64, $plan>::new(&model, $settings, 0.0)?;
                $visit($visitor, model, i)
            }
            // No structured elimination: never named for it (`FirmwareScheme::of`), and
            // refused rather than built as something else.
            FirmwareIntegrator::StructuredBdf(_)
            | FirmwareIntegrator::StructuredBdfUncorrected(_)
            | FirmwareIntegrator::StructuredRadau5 => {
                return Err($crate::cranes::FirmwareError::NotStructured {
                    model: $crate::cranes::type_name(core::any::type_name_of_val(&model)),
                })
            }
            FirmwareIntegrator::RadauFull => {
                let i = m::RadauFull::<f64, $plan>::new(&model, $settings, 0.0)?;
                $visit($visitor, model, i)
            }
        }
    }};
    ($structure:ident, $visit:ident, $m:path, $integrator:expr, $model:expr, $settings:expr, $visitor:expr, $plan:ty) => {{
        use $m as m;
        let model = $model;
        match $integrator {
            FirmwareIntegrator::StructuredBdf(k) => {
                let i = m::StructuredBdf::<f64, $plan>::new(&model, $settings, k, 0.0)?;
                $visit($visitor, model, i)
            }
            FirmwareIntegrator::StructuredBdfUncorrected(k) => {
                let i = m::StructuredBdfUncorrected::<f64, $plan>::new(&model, $settings, k, 0.0)?;
                $visit($visitor, model, i)
            }
            FirmwareIntegrator::Bdf(k) => {
                let i = m::Bdf::<f64, $plan>::new(&model, $settings, k, 0.0)?;
                $visit($visitor, model, i)
            }
            FirmwareIntegrator::StructuredRadau5 => {
                let i = m::StructuredRadau5::<f64, $plan>::new(&model, $settings, 0.0)?;
                $visit($visitor, model, i)
            }
            FirmwareIntegrator::Radau5 => {
                let i = m::Radau5::<f64, $plan>::new(&model, $settings, 0.0)?;
                $visit($visitor, model, i)
            }
            FirmwareIntegrator::RadauFull => {
                let i = m::RadauFull::<f64, $plan>::new(&model, $settings, 0.0)?;
                $visit($visitor, model, i)
            }
        }
    }};
}

/// A crane's formulations, listed once: `Variant => module::path, Type, Structure;`
/// (the module under `solver_core::models`, its model type, and how its Newton systems
/// can be solved: [`Structure`]). Makes the enum of them with [`CraneModel`] and
/// [`Formulation`]: one arm per formulation, each building exactly the types
/// `FirmwareScheme::rust` names from the same list. A `Structured` model whose module has no
/// `StructuredBdf` does not compile.
macro_rules! crane_models {
    (
        $(#[$enum_doc:meta])*
        $name:ident for $crane:ty, $axes:literal {
            $(
                $(#[$doc:meta])*
                $variant:ident => $module:ident $(:: $sub:ident)*, $model:ident, $structure:ident;
            )+
        }
    ) => {
        $(#[$enum_doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum $name {
            $( $(#[$doc])* $variant, )+
        }

        impl $crate::cranes::CraneModel for $name {
            const ALL: &'static [Self] = &[$(Self::$variant),+];
            fn path(self) -> (&'static str, &'static str) {
                match self {
                    $(
                        Self::$variant => (
                            concat!(stringify!($module) $(, "::", stringify!($sub))*),
                            stringify!($model),
                        ),
                    )+
                }
            }
            fn structure(self) -> $crate::cranes::Structure {
                match self {
                    $( Self::$variant => $crate::cranes::Structure::$structure, )+
                }
            }
        }

        impl $crate::cranes::Formulation<$crane, $axes> for $name {
        fn inverse_model<V: $crate::cranes::FirmwareVisitor<$crane, $axes>>(
            self,
            crane: $crane,
            integrator: $crate::cranes::FirmwareIntegrator,
            plan: solver_core::plan::Plan<f64, $axes>,
            settings: &solver_core::SolverSettings,
            visitor: V,
        ) -> Result<V::Output, $crate::cranes::FirmwareError> {
            use $crate::cranes::{visit, FirmwareIntegrator};
            type P = solver_core::plan::Plan<f64, $axes>;
            Ok(match self {
                $(
                    $name::$variant => $crate::cranes::integrators!(
                        $structure,
                        visit,
                        solver_core::models::$module $(:: $sub)*,
                        integrator,
                        solver_core::models::$module $(:: $sub)* :: $model::new(crane.0, plan)?,
                        settings,
                        visitor,
                        P
                    ),
                )+
            })
        }

        fn steps<Z, V>(
            self,
            crane: $crane,
            z: Z,
            integrator: $crate::cranes::FirmwareIntegrator,
            settings: &solver_core::SolverSettings,
            visitor: V,
        ) -> Result<V::Output, $crate::cranes::FirmwareError>
        where
            Z: solver_core::trajectory::Trajectory<f64, $axes>,
            V: $crate::cranes::StepsVisitor,
        {
            use $crate::cranes::{step_visit, FirmwareIntegrator};
            Ok(match self {
                $(
                    $name::$variant => $crate::cranes::integrators!(
                        $structure,
                        step_visit,
                        solver_core::models::$module $(:: $sub)*,
                        integrator,
                        solver_core::models::$module $(:: $sub)* :: $model::new(crane.0, z)?,
                        settings,
                        visitor,
                        Z
                    ),
                )+
            })
        }
        }
    };
}
pub(crate) use crane_models;
pub(crate) use integrators;

/// The registered cranes, listed once: `Variant(ModelEnum) for Params, axes;`. Makes
/// [`FirmwareModel`] (which crane, which of its formulations), its list of every
/// formulation, and [`visit_crane`], the one `match` that turns a crane into its type.
macro_rules! registry {
    ( $( $(#[$doc:meta])* $variant:ident($models:ty) for $crane:ty, $axes:literal; )+ ) => {
        /// A formulation the firmware can drive: which crane, which of its models.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub enum FirmwareModel {
            $( $(#[$doc])* $variant($models), )+
        }

        impl FirmwareModel {
            /// Every formulation of every crane, crane by crane in the order registered.
            pub fn every() -> impl Iterator<Item = FirmwareModel> {
                core::iter::empty()
                    $( .chain(<$models as CraneModel>::ALL.iter().map(|m| FirmwareModel::$variant(*m))) )+
            }

            /// The scene's model as a registered crane's formulation.
            pub fn of(model: &ModelSpec) -> Result<Self, FirmwareError> {
                $(
                    if let Some((_, m)) = <$crane as FirmwareCrane<$axes>>::of(model) {
                        return Ok(FirmwareModel::$variant(m));
                    }
                )+
                Err(FirmwareError::NotACrane { model: model.label() })
            }

            /// The model's module under `solver_core::models` and its type's name.
            #[must_use]
            pub fn path(self) -> (&'static str, &'static str) {
                match self { $( Self::$variant(m) => m.path(), )+ }
            }

            /// How its Newton systems can be solved.
            #[must_use]
            pub fn structure(self) -> Structure {
                match self { $( Self::$variant(m) => m.structure(), )+ }
            }

            /// Whether it runs manual mode ([`FirmwareCrane::manual_mode`]): its path then
            /// the crane's [`FirmwareCrane::STEERED_TYPE`].
            #[must_use]
            pub fn steered_type(self) -> Option<&'static str> {
                match self {
                    $( Self::$variant(m) => <$crane as FirmwareCrane<$axes>>::manual_mode(m)
                        .then_some(<$crane as FirmwareCrane<$axes>>::STEERED_TYPE), )+
                }
            }

            /// Its crane's name (`Crane::NAME`: "planar crane", "3D crane", …).
            #[must_use]
            pub fn crane_name(self) -> &'static str {
                match self { $( Self::$variant(_) => <$crane as Crane<$axes>>::NAME, )+ }
            }

            /// Its crane's parameter type ([`FirmwareCrane::TYPE`]) and driven axes.
            #[must_use]
            pub fn crane(self) -> (&'static str, usize) {
                match self { $( Self::$variant(_) => (<$crane as FirmwareCrane<$axes>>::TYPE, $axes), )+ }
            }
        }

        /// Every registered crane's [`FirmwareCrane::QEMU_SCENES`], crane by crane in the
        /// order registered: the scenes `cargo xtask qemu` runs on the healthy bus.
        #[must_use]
        pub fn qemu_scenes() -> Vec<&'static str> {
            [$( <$crane as FirmwareCrane<$axes>>::QEMU_SCENES, )+].concat()
        }

        /// Hands `model`'s crane, as its type, and its formulation to `visitor`.
        pub fn visit_crane<V: CraneVisitor>(model: FirmwareModel, visitor: V) -> V::Output {
            match model { $( FirmwareModel::$variant(m) => visitor.visit::<$crane, $axes>(m), )+ }
        }
    };
}

registry! {
    /// The paper's planar crane: trolley and winch.
    Planar(super::planar::PlanarModel) for super::planar::Planar, 2;
    /// The crane in three dimensions: bridge, trolley and hoist.
    Spatial(super::spatial::SpatialModel) for super::spatial::Spatial, 3;
    /// The hook-and-load crane: trolley and winch, a hook block and the load on a sling.
    HookAndLoad(super::hook_and_load::HookAndLoadModel)
        for super::hook_and_load::HookAndLoad, 2;
}

/// `model` and `integrator` to a [`StepsVisitor`].
pub(crate) fn step_visit<V, M, I, const N: usize, const NU: usize>(
    visitor: V,
    model: M,
    integrator: I,
) -> V::Output
where
    V: StepsVisitor,
    M: DaeModel<f64, N, NU>,
    I: Integrator<f64, M, N, NU>,
{
    visitor.visit(model, integrator)
}

/// `model` and `integrator` as the controller's inverse model, to `visitor`.
pub(crate) fn visit<K, V, M, I, const N: usize, const A: usize>(
    visitor: V,
    model: M,
    integrator: I,
) -> V::Output
where
    K: Crane<A> + 'static,
    V: FirmwareVisitor<K, A>,
    M: CraneReference<K, A> + DaeModel<f64, N, A> + Driven + 'static,
    M::Trajectory: Planned<A>,
    I: Integrator<f64, M, N, A> + 'static,
{
    visitor.visit(InverseModel::<K, M, I, f64, N>::new(model, integrator))
}
