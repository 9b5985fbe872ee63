//! The one place where a scene's crane, model and scheme become types.
//!
//! Every tool that runs a scene comes through here, so they cannot drift apart:
//! - the studies, the sweep and the paper's figures, through [`model`], which builds the
//!   scene's model on its move in the study's scalar and hands it to a
//!   [`ModelVisitor`] (which steps it with any [`Scheme`] it likes), and [`Exact`], the
//!   exact inputs Eq. 29 measures against;
//! - the firmware's build script, the host's run of the firmware, the virtual ECU and the
//!   fuzzer's build script, through [`firmware`], which hands the scene's setup to a
//!   [`FirmwareCraneVisitor`] as its crane's type (the cranes registered in
//!   [`crate::cranes`], one file each); [`FirmwareScheme`] is the integrator the firmware
//!   links for the scene, as the Rust type the build scripts write
//!   ([`FirmwareScheme::rust`]) and as the same type built on the host
//!   ([`FirmwareScene::inverse_model`]);
//! - the panic proof's build script, through [`FirmwareScheme::every`] and a module per
//!   registered crane ([`visit_crane`]).
//!
//! No model is named here: [`model`], [`Exact`] and [`accuracy_threshold`] follow from
//! the scene's list of models (`model_specs!` in `lib.rs`) and each model's
//! `family::ModelFamily`, and the firmware's side from its crane's list of formulations
//! (`crane_models!` in its file under `scene/src/cranes/`; docs/MODELS.md).

use controller::commissioning::NodeSetup;
use controller::crane::command_plan;
use controller::feedback::Config as FeedbackConfig;
use controller::planner::Planner;
use controller::Config;
use solver_core::plan::Plan;
use solver_core::schemes::bdf::CORRECT_BELOW_H;
use solver_core::trajectory::{PointToPoint, Trajectory};
use solver_core::{DaeModel, Error, Real, Scheme, SolverSettings};

use crate::commissioning::CommissioningFile;
pub use crate::cranes::{
    qemu_scenes, visit_crane, CraneModel, CraneVisitor, FirmwareCrane, FirmwareError,
    FirmwareIntegrator, FirmwareModel, FirmwareVisitor, StepsVisitor, Structure,
};
use crate::family::ExactInputs;
use crate::{
    trajectory, JacobianSpec, ModelSpec, NewtonSpec, ScalarSpec, Scene, SceneError, SchemeSpec,
};

pub use crate::family::ModelVisitor;

/// Builds the scene's model on its move in `T` and hands it to `visitor`; a model its
/// parameters or move make impossible (rope slack, workspace, smoothness) is refused.
/// Each model's type and sizes are its row in the scene's list of models
/// (`model_specs!` in `lib.rs`).
pub fn model<T: Real, V: ModelVisitor<T>>(
    scene: &Scene,
    visitor: V,
) -> Result<V::Output, SceneError> {
    scene.build_model(visitor)
}

/// The e_max above which a run of `model` counts as inaccurate: 1 mm/s for the cranes'
/// velocity set points, 0.01 N for the mass-on-car's force (each model's
/// `ModelFamily::ACCURACY_THRESHOLD`).
#[must_use]
pub fn accuracy_threshold(model: &ModelSpec) -> f64 {
    model.accuracy_threshold()
}

/// The visitor that only builds the model: what [`Scene::validate`] asks of it.
#[derive(Debug, Clone, Copy)]
pub struct Built;

impl<T: Real> ModelVisitor<T> for Built {
    type Output = ();
    fn visit<M: DaeModel<T, N, NU>, const N: usize, const NU: usize, const S: usize>(self, _: M) {}
}

/// The scheme a scene names, as a value (the studies choose the integrator at run time).
#[must_use]
pub fn scheme(scene: &Scene) -> Scheme {
    match scene.solver.scheme {
        SchemeSpec::Bdf => Scheme::Bdf(scene.solver.k),
        SchemeSpec::Radau => Scheme::Radau,
    }
}

/// The exact inputs of a scene's move, sample by sample, in f64: what Eq. 29 measures
/// a run against — its model's `ModelFamily::exact` (the cranes' flat inverse, whatever
/// the formulation; the mass-on-car's internal dynamics integrated along, Eqs. 37–38).
#[derive(Debug)]
pub struct Exact(Box<dyn ExactInputs>);

impl Exact {
    /// The reference of `scene`'s model and move.
    pub fn new(scene: &Scene) -> Result<Self, SceneError> {
        scene.exact_inputs().map(Exact)
    }

    /// The exact inputs at `t` into `out` (`t` never decreases between calls).
    pub fn at(&mut self, t: f64, out: &mut Vec<f64>) -> Result<(), Error> {
        out.clear();
        self.0.at(t, out)
    }
}

/// The integrator the firmware links for a scene: the model, the scheme and the Newton
/// strategy, a type, so the firmware links only the one its scene names. For the crane
/// *subs* models (planar and 3D) BDF with the exact Jacobian and RADAU5's transformed
/// Newton (its real and complex systems) take the structured elimination; everything
/// else dense LUs. BDF's closed-form start is corrected below `CORRECT_BELOW_H` (5 ms)
/// only: from there on the firmware does not link the correction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FirmwareScheme {
    /// The model.
    pub model: FirmwareModel,
    /// Its integrator.
    pub integrator: FirmwareIntegrator,
}

impl FirmwareScheme {
    /// The firmware's integrator for `scene`, or why the firmware cannot run it (the
    /// firmware drives a crane, in f64).
    pub fn of(scene: &Scene) -> Result<Self, FirmwareError> {
        if scene.solver.scalar != ScalarSpec::F64 {
            return Err(FirmwareError::F32Scene);
        }
        let model = FirmwareModel::of(&scene.model)?;
        let structured = model.structure() != Structure::Dense;
        let structured_only = model.structure() == Structure::StructuredOnly;
        let s = &scene.solver;
        let transformed = s.newton == NewtonSpec::Transformed;
        let integrator = match s.scheme {
            SchemeSpec::Bdf if structured && s.jacobian == JacobianSpec::Exact && !transformed => {
                // The extended cranes have no differential unknown: BDF never corrects
                // their closed form (`bdf::Structured`), at any h.
                if s.h >= CORRECT_BELOW_H || structured_only {
                    FirmwareIntegrator::StructuredBdfUncorrected(s.k)
                } else {
                    FirmwareIntegrator::StructuredBdf(s.k)
                }
            }
            SchemeSpec::Bdf => FirmwareIntegrator::Bdf(s.k),
            SchemeSpec::Radau if transformed && structured => FirmwareIntegrator::StructuredRadau5,
            SchemeSpec::Radau if transformed => FirmwareIntegrator::Radau5,
            SchemeSpec::Radau => FirmwareIntegrator::RadauFull,
        };
        let scheme = Self { model, integrator };
        if structured_only && !scheme.structured() {
            return Err(FirmwareError::StructuredOnly {
                model: scene.model.label(),
            });
        }
        Ok(scheme)
    }

    /// Every integrator the firmware can link, formulation by formulation of every
    /// registered crane (BDF with k = 4; the proofs hold k opaque): what the link-time
    /// panic proof proves (`panic-proof/`'s build script writes one arm per entry).
    /// [`FirmwareScheme::of`] names nothing else.
    #[must_use]
    pub fn every() -> Vec<FirmwareScheme> {
        use FirmwareIntegrator as I;
        FirmwareModel::every()
            .flat_map(|model| {
                let integrators: &[FirmwareIntegrator] = match model.structure() {
                    Structure::StructuredOnly => {
                        &[I::StructuredBdfUncorrected(4), I::StructuredRadau5]
                    }
                    Structure::Structured => &[
                        I::StructuredBdf(4),
                        I::StructuredBdfUncorrected(4),
                        I::Bdf(4),
                        I::StructuredRadau5,
                        I::RadauFull,
                    ],
                    Structure::Dense => &[I::Bdf(4), I::Radau5, I::RadauFull],
                };
                integrators
                    .iter()
                    .map(move |&integrator| FirmwareScheme { model, integrator })
            })
            .collect()
    }

    /// The crane's parameter type ([`FirmwareCrane::TYPE`]) and its driven axes.
    #[must_use]
    pub fn crane(self) -> (&'static str, usize) {
        self.model.crane()
    }

    /// Whether the Newton systems are solved by the model's structured elimination.
    #[must_use]
    pub fn structured(self) -> bool {
        matches!(
            self.integrator,
            FirmwareIntegrator::StructuredBdf(_)
                | FirmwareIntegrator::StructuredBdfUncorrected(_)
                | FirmwareIntegrator::StructuredRadau5
        )
    }

    /// The model's type and the integrator's type on the firmware's plan, and the
    /// expression that builds the integrator (`model` and `SETTINGS` in scope): what the
    /// firmware's build script writes.
    #[must_use]
    pub fn rust(self) -> FirmwareTypes {
        self.rust_on(&format!("solver_core::plan::Plan<f64, {}>", self.crane().1))
    }

    /// [`FirmwareScheme::rust`] with the model on the crane's `Steered` path (manual
    /// mode), if the model runs manual mode ([`FirmwareModel::steered_type`]).
    #[must_use]
    pub fn steered(self) -> Option<FirmwareTypes> {
        self.model.steered_type().map(|path| self.rust_on(path))
    }

    /// [`FirmwareScheme::rust`] with the model following `plan`, a path type's Rust (the
    /// firmware's `Plan`, or with manual mode the crane's `Steered`,
    /// `FirmwareCrane::STEERED_TYPE`).
    #[must_use]
    pub fn rust_on(self, plan: &str) -> FirmwareTypes {
        let (module, model) = self.model.path();
        let (alias, k) = self.integrator.alias();
        let path = format!("solver_core::models::{module}");
        FirmwareTypes {
            model: format!("{path}::{model}<f64, {plan}>"),
            integrator: format!("{path}::{alias}<f64, {plan}>"),
            unknowns: format!("{path}::N"),
            new: match k {
                Some(k) => format!("Integrator::new(&model, &SETTINGS, {k}, 0.0)"),
                None => "Integrator::new(&model, &SETTINGS, 0.0)".into(),
            },
            multistep: k.is_some(),
            scheme: match k {
                Some(k) => format!("BDF{k}"),
                None => "Radau IIA".into(),
            },
        }
    }
}

/// The firmware's watchdog period, ms: a cycle must be shorter.
pub const WATCHDOG_MS: u32 = 100;

/// How long commissioning both drives takes, s, at `period_ms` per cycle: one SDO
/// exchange per cycle for every write and its read-back and the reads around them, the
/// drives' first heartbeat after their start, and the CiA 402 enable sequence. A scene's
/// move that starts earlier would ask for motion from drives not yet enabled.
#[must_use]
pub fn commissioning_time(config: &Config) -> f64 {
    let drives = || {
        config.nodes.iter().flatten().filter_map(|n| match n {
            NodeSetup::Drive(_, d) => Some(d),
            NodeSetup::Inclinometer(_) => None,
        })
    };
    let writes = drives()
        .map(|d| controller::commissioning::configuration(d, config.node, 10).len())
        .max()
        .unwrap_or(0);
    let exchanges = 2 * writes + 10;
    let heartbeat = drives()
        .map(|d| f64::from(d.heartbeat_ms))
        .fold(0.0, f64::max);
    (exchanges as f64 * f64::from(config.period_ms) + heartbeat) / 1000.0
}

/// The firmware's setup of a crane scene: crane `K` with `A` driven axes.
#[derive(Debug, Clone, Copy)]
pub struct FirmwareScene<K: FirmwareCrane<A>, const A: usize> {
    /// Crane parameters.
    pub params: K,
    /// The scene's formulation of it.
    pub model: K::Model,
    /// The scene's move.
    pub first_move: PointToPoint<f64, A>,
    /// The plan at t = 0: at rest at the move's start, the move planned. Moves on
    /// command have the smoothness `max(n, K::MIN_COMMAND_SMOOTHNESS)`
    /// (`controller::crane::command_plan`).
    pub plan: Plan<f64, A>,
    /// The planner of moves on command, with each drive's set-point limits (the
    /// commissioning file's, [`controller::crane::Crane::LAB_LIMITS`] where it names none).
    pub planner: Planner<K, A>,
    /// Timing and the nodes of the controller.
    pub config: Config,
    /// Cycles the scene runs (to its `t_end`).
    pub cycles: u32,
    /// The state feedback, if the scene closes the loop (its inclinometer is then in
    /// `config`).
    pub feedback: Option<controller::feedback::Config>,
    /// The integrator the firmware links.
    pub scheme: FirmwareScheme,
    /// Manual mode's generator settings, if the scene has `[operator]`: the model then
    /// follows the plan or the generator (`FirmwareCrane::STEERED_TYPE`).
    pub operator: Option<K::Operator>,
}

impl<K: FirmwareCrane<A>, const A: usize> FirmwareScene<K, A> {
    /// Where the load rests at power-up: where the scene's move starts (`[x_C, z_C]`,
    /// the 3D crane's `[x_C, y_C, z_C]`). The drives stand where the crane's
    /// `drives_at_rest` puts them (the planar and 3D crane's there too, the
    /// hook-and-load crane's rope a sling shorter).
    #[must_use]
    pub fn start(&self) -> [f64; A] {
        self.first_move.start().into()
    }

    /// The firmware's inverse model on `plan`, at rest at t = 0: the scene's formulation
    /// advanced by the integrator the firmware links, handed to `visitor` — the types
    /// [`FirmwareScheme::rust`] names.
    pub fn inverse_model<V: FirmwareVisitor<K, A>>(
        &self,
        plan: Plan<f64, A>,
        settings: &SolverSettings,
        visitor: V,
    ) -> Result<V::Output, FirmwareError> {
        match self.operator {
            Some(operator) => self.params.steered_inverse_model(
                self.model,
                self.scheme.integrator,
                plan,
                operator,
                settings,
                visitor,
            ),
            None => self.params.inverse_model(
                self.model,
                self.scheme.integrator,
                plan,
                settings,
                visitor,
            ),
        }
    }

    /// The Rust the firmware's build script writes for the scene's model and
    /// integrator: on the plan, or with manual mode on the crane's `Steered`.
    #[must_use]
    pub fn rust(&self) -> FirmwareTypes {
        match self.operator {
            Some(_) => self.scheme.rust_on(K::STEERED_TYPE),
            None => self.scheme.rust(),
        }
    }
}

/// The firmware's setup of `scene` for crane `K` with the drives of `commissioning`, or
/// why the firmware cannot run it: not this crane, not f64 ([`FirmwareScheme::of`]), a
/// cycle the watchdog or the ms timer cannot keep, a run that is not a whole number of
/// cycles, a bad commissioning file (a drive of the crane missing, a drive it does not
/// have), a `[feedback]` the crane cannot honour, a move that starts before the drives
/// can be enabled, or one that breaks the planner's rules (docs/COMMANDS.md) — a scene's
/// move must pass the checks every commanded move passes. [`crate::dispatch::firmware`]
/// picks `K` from the scene.
pub fn firmware_scene<K: FirmwareCrane<A>, const A: usize>(
    scene: &Scene,
    commissioning: &CommissioningFile,
) -> Result<FirmwareScene<K, A>, FirmwareError> {
    let scheme = FirmwareScheme::of(scene)?;
    let (params, model) = K::of(&scene.model).ok_or(FirmwareError::NotThisCrane {
        model: scene.model.label(),
        crane: K::NAME,
    })?;
    let first_move = trajectory::<f64, A>(scene).map_err(FirmwareError::Scene)?;
    let mut plan = command_plan::<K, A>(first_move.start().into(), scene.trajectory.smoothness)?;
    plan.push(first_move)?;
    // Each drive's set-point limits: its commissioning row's, the crane's lab drive's
    // where the row names none — the planner's and the gate's.
    let limits = commissioning
        .limits_for(K::DRIVES, K::LAB_LIMITS)
        .map_err(FirmwareError::Commissioning)?;
    let planner = Planner::with_axes(params, limits);
    let (t0, t1) = first_move.active_span();
    planner
        .check(&first_move, t0, t1)
        .map_err(FirmwareError::PlannerRule)?;
    let h = scene.solver.h;
    let period_ms = (h * 1000.0).round() as u32;
    if (f64::from(period_ms) / 1000.0 - h).abs() > 1e-12 {
        return Err(FirmwareError::CycleNotWholeMs { h });
    }
    if period_ms >= WATCHDOG_MS {
        return Err(FirmwareError::CycleNotUnderWatchdog {
            h,
            watchdog_ms: WATCHDOG_MS,
        });
    }
    let t_end = scene.trajectory.t_end;
    let cycles = t_end / h;
    if (cycles - cycles.round()).abs() > 1e-9 * cycles.max(1.0) {
        return Err(FirmwareError::RunNotWholeCycles { h, t_end });
    }
    let config = commissioning
        .config_for(K::DRIVES, limits, period_ms)
        .map_err(FirmwareError::Commissioning)?;
    let feedback = scene
        .feedback
        .map(|f| K::feedback_config(&f, &params, h))
        .transpose()
        .map_err(FirmwareError::Scene)?
        .map(|f| {
            commissioning
                .lag()
                .map(|inclinometer| FeedbackConfig { inclinometer, ..f })
                .map_err(FirmwareError::Commissioning)
        })
        .transpose()?;
    let config = if feedback.is_some() {
        commissioning
            .with_inclinometer_of(config, K::SWING_AXES)
            .map_err(FirmwareError::Commissioning)?
    } else {
        config
    };
    let operator = scene
        .operator
        .as_ref()
        .map(|o| K::operator_settings(o, &params, model, h))
        .transpose()
        .map_err(FirmwareError::Scene)?;
    let ready = commissioning_time(&config);
    let t_start = scene.trajectory.t_start;
    if t_start < ready {
        return Err(FirmwareError::StartsBeforeReady { t_start, ready, h });
    }
    Ok(FirmwareScene {
        params,
        model,
        first_move,
        plan,
        planner,
        config,
        cycles: scene.steps() as u32,
        feedback,
        scheme,
        operator,
    })
}

/// What is done with the firmware's setup of a scene, whatever its crane.
pub trait FirmwareCraneVisitor {
    /// What it gives.
    type Output;
    /// Does it with the setup of a crane `K` with `A` driven axes.
    fn visit<K: FirmwareCrane<A>, const A: usize>(self, f: FirmwareScene<K, A>) -> Self::Output;
}

/// The firmware's setup of `scene` with the drives of `commissioning`, as its own crane's
/// type, handed to `visitor`; or why the firmware cannot run the scene
/// ([`firmware_scene`]). The one place where a scene's crane becomes a type.
pub fn firmware<V: FirmwareCraneVisitor>(
    scene: &Scene,
    commissioning: &CommissioningFile,
    visitor: V,
) -> Result<V::Output, FirmwareError> {
    /// The registered crane, as its type.
    struct Setup<'a, V> {
        scene: &'a Scene,
        commissioning: &'a CommissioningFile,
        visitor: V,
    }
    impl<V: FirmwareCraneVisitor> CraneVisitor for Setup<'_, V> {
        type Output = Result<V::Output, FirmwareError>;
        fn visit<K: FirmwareCrane<A>, const A: usize>(self, _: K::Model) -> Self::Output {
            let setup = firmware_scene::<K, A>(self.scene, self.commissioning)?;
            Ok(self.visitor.visit(setup))
        }
    }
    let model = FirmwareScheme::of(scene)?.model;
    visit_crane(
        model,
        Setup {
            scene,
            commissioning,
            visitor,
        },
    )
}

/// The trajectory type a cost measurement drives the model by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DrivenBy {
    /// The scene's move as a `PointToPoint` (the studies' and the paper's).
    PointToPoint,
    /// The same move pushed onto a `Plan` at rest at its start: the firmware's type.
    Plan,
}

/// The scene's model on its move (`driven`: bare, or on the firmware's `Plan` as the
/// firmware builds it) and the integrator the firmware links for the scene
/// ([`FirmwareScheme::of`]), handed to `visitor`.
pub fn firmware_steps<V: StepsVisitor>(
    scene: &Scene,
    driven: DrivenBy,
    visitor: V,
) -> Result<V::Output, FirmwareError> {
    /// The registered crane, as its type: its formulation on the move, bare or planned.
    struct Steps<'a, V> {
        scene: &'a Scene,
        integrator: FirmwareIntegrator,
        driven: DrivenBy,
        visitor: V,
    }
    impl<V: StepsVisitor> CraneVisitor for Steps<'_, V> {
        type Output = Result<V::Output, FirmwareError>;
        fn visit<K: FirmwareCrane<A>, const A: usize>(self, model: K::Model) -> Self::Output {
            let Steps {
                scene,
                integrator,
                driven,
                visitor,
            } = self;
            let settings = &scene.settings();
            let (crane, _) = K::of(&scene.model).ok_or(FirmwareError::NotThisCrane {
                model: scene.model.label(),
                crane: K::NAME,
            })?;
            let z = trajectory::<f64, A>(scene).map_err(FirmwareError::Scene)?;
            match driven {
                DrivenBy::PointToPoint => crane.steps(model, z, integrator, settings, visitor),
                DrivenBy::Plan => {
                    // The move as the firmware plans it: at rest at its start, the move
                    // pushed.
                    let mut plan =
                        command_plan::<K, A>(z.start().into(), scene.trajectory.smoothness)?;
                    plan.push(z)?;
                    crane.steps(model, plan, integrator, settings, visitor)
                }
            }
        }
    }
    let scheme = FirmwareScheme::of(scene)?;
    visit_crane(
        scheme.model,
        Steps {
            scene,
            integrator: scheme.integrator,
            driven,
            visitor,
        },
    )
}

/// The Rust the firmware's build script writes for a [`FirmwareScheme`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FirmwareTypes {
    /// The model's type on the firmware's plan.
    pub model: String,
    /// The integrator's type.
    pub integrator: String,
    /// The model's number of unknowns (a path to its constant).
    pub unknowns: String,
    /// The expression that builds the integrator.
    pub new: String,
    /// Whether it is BDF (its constructor takes k).
    pub multistep: bool,
    /// The scheme, for logs.
    pub scheme: String,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cranes::planar::Planar;
    use controller::feedforward::{Feedforward, Replan};
    use controller::planner::Crane;

    /// The study's visitor that only names the model's type.
    struct Name;

    impl<T: Real> ModelVisitor<T> for Name {
        type Output = (&'static str, usize);
        fn visit<M: DaeModel<T, N, NU>, const N: usize, const NU: usize, const S: usize>(
            self,
            _: M,
        ) -> Self::Output {
            (std::any::type_name::<M>(), N)
        }
    }

    fn scene(model: &str, solver: &str) -> Scene {
        let jacobian = if solver.contains("jacobian") {
            ""
        } else {
            "jacobian = \"exact\"\n"
        };
        let spec: ModelSpec = toml::from_str(&format!("kind = \"{model}\"")).unwrap();
        let (start, end) = match spec.outputs() {
            1 => ("[0.0]", "[1.0]"),
            3 => ("[12.0, 3.0, 8.0]", "[20.0, 6.0, 4.0]"),
            _ => ("[12.0, 8.0]", "[20.0, 4.0]"),
        };
        // Smooth enough for every model: the hook-and-load crane's inputs contain the
        // path's sixth derivative.
        let n = 7;
        Scene::parse(&format!(
            "name = \"t\"\n[model]\nkind = \"{model}\"\n[trajectory]\nstart = {start}\nend = {end}\nt_start = 1.0\nduration = 7.0\nsmoothness = {n}\nt_end = 10.0\n[solver]\n{solver}\n{jacobian}h = 0.01\n"
        ))
        .unwrap()
    }

    /// A move refused for starting before the drives are ready says when they are, to the
    /// ms: with drive heartbeats of 94 ms that time has a third decimal, and a start
    /// 2 ms before it read as after it with two decimals.
    #[test]
    fn a_move_starting_before_the_drives_are_ready_reads_as_before() {
        let text = include_str!("../../scenes/commissioning.toml")
            .replacen(
                "heartbeat_ms = 100              # drive's 0x1017",
                "heartbeat_ms = 94",
                1,
            )
            .replacen(
                "heartbeat_ms = 100\ncontroller",
                "heartbeat_ms = 94\ncontroller",
                1,
            );
        assert_eq!(text.matches("heartbeat_ms = 94").count(), 2, "both drives'");
        let c = CommissioningFile::parse(&text).unwrap();
        let limits = c.limits_for(Planar::DRIVES, Planar::LAB_LIMITS).unwrap();
        let ready = commissioning_time(&c.config_for(Planar::DRIVES, limits, 10).unwrap());
        let mut s = Scene::parse(include_str!("../../scenes/paper-crane.toml")).unwrap();
        s.trajectory.t_start = ready - 0.002;
        let e = firmware_scene::<Planar, 2>(&s, &c).unwrap_err().to_string();
        let printed: f64 = e
            .split_once("enabled (")
            .and_then(|(_, rest)| rest.split_once(" s at"))
            .map(|(number, _)| number.parse().unwrap())
            .unwrap_or_else(|| panic!("{e}"));
        assert_eq!(printed, ready, "{e}");
        assert!(s.trajectory.t_start < printed, "{e}");
    }

    #[test]
    fn each_model_is_built_with_its_own_size() {
        for (kind, name, n) in [
            ("crane-subs", "CraneSubs", 7),
            ("crane-proj", "CraneProj", 8),
            ("mass-on-car", "MassOnCar", 5),
            ("crane3d-subs", "Crane3dSubs", 10),
            ("crane-ext", "CraneExt", 13),
            ("mass-on-car-ext", "MassOnCarExt", 7),
            ("crane3d-ext", "Crane3dExt", 18),
            ("double-pendulum-subs", "DoublePendulumSubs", 12),
            ("double-pendulum-ext", "DoublePendulumExt", 30),
        ] {
            let (ty, unknowns) = model::<f64, _>(&scene(kind, "scheme = \"bdf\""), Name).unwrap();
            assert!(ty.contains(name), "{ty}");
            assert_eq!(unknowns, n, "{kind}");
        }
    }

    /// Every kind the firmware drives (a registered crane's formulation), from the
    /// registration: a model added there is checked here without a line more.
    fn firmware_kinds() -> Vec<&'static str> {
        ModelSpec::KINDS
            .iter()
            .copied()
            .filter(|kind| FirmwareModel::of(&scene(kind, "scheme = \"bdf\"").model).is_ok())
            .collect()
    }

    /// The label of the model `kind` names.
    fn s_label(kind: &str) -> &'static str {
        scene(kind, "scheme = \"bdf\"").model.label()
    }

    #[test]
    fn the_firmware_names_the_types_it_builds() {
        use crate::cranes::planar::PlanarModel;
        use crate::cranes::spatial::SpatialModel;
        use FirmwareIntegrator as I;
        use FirmwareModel as M;
        for (kind, solver, model, integrator) in [
            (
                "crane-subs",
                "scheme = \"bdf\"\njacobian = \"exact\"",
                M::Planar(PlanarModel::Subs),
                I::StructuredBdfUncorrected(4),
            ),
            (
                "crane-subs",
                "scheme = \"bdf\"\njacobian = \"fd\"",
                M::Planar(PlanarModel::Subs),
                I::Bdf(4),
            ),
            (
                "crane-subs",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                M::Planar(PlanarModel::Subs),
                I::StructuredRadau5,
            ),
            (
                "crane-subs",
                "scheme = \"radau\"\njacobian = \"exact\"",
                M::Planar(PlanarModel::Subs),
                I::RadauFull,
            ),
            (
                "crane-proj",
                "scheme = \"bdf\"\njacobian = \"exact\"",
                M::Planar(PlanarModel::Proj),
                I::Bdf(4),
            ),
            (
                "crane-proj",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                M::Planar(PlanarModel::Proj),
                I::Radau5,
            ),
            (
                "crane-proj",
                "scheme = \"radau\"\njacobian = \"fd\"",
                M::Planar(PlanarModel::Proj),
                I::RadauFull,
            ),
            (
                "crane3d-subs",
                "scheme = \"bdf\"\njacobian = \"exact\"",
                M::Spatial(SpatialModel::Subs),
                I::StructuredBdfUncorrected(4),
            ),
            (
                "crane3d-subs",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                M::Spatial(SpatialModel::Subs),
                I::StructuredRadau5,
            ),
            (
                "crane-ext",
                "scheme = \"bdf\"\njacobian = \"exact\"",
                M::Planar(PlanarModel::Ext),
                I::StructuredBdfUncorrected(4),
            ),
            (
                "crane-ext",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                M::Planar(PlanarModel::Ext),
                I::StructuredRadau5,
            ),
            (
                "crane3d-ext",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                M::Spatial(SpatialModel::Ext),
                I::StructuredRadau5,
            ),
        ] {
            let s = scene(kind, solver);
            let f = FirmwareScheme::of(&s).unwrap();
            assert_eq!(f, FirmwareScheme { model, integrator }, "{kind} {solver}");
            let rust = f.rust();
            assert_eq!(rust.integrator.contains("Structured"), f.structured());
            let (module, name) = model.path();
            assert!(rust.model.contains(name), "{}", rust.model);
            assert!(
                rust.integrator
                    .starts_with(&format!("solver_core::models::{module}::")),
                "{}",
                rust.integrator
            );
            let plan = format!("Plan<f64, {}>", model.crane().1);
            assert!(rust.model.contains(&plan) && rust.integrator.contains(&plan));
        }
        // Below 5 ms BDF's closed form is corrected, and the firmware links the correction.
        for (h, expected) in [
            (0.002, I::StructuredBdf(4)),
            (0.005, I::StructuredBdfUncorrected(4)),
        ] {
            let mut s = Scene::parse(include_str!("../../scenes/paper-crane.toml")).unwrap();
            s.solver.h = h;
            assert_eq!(
                FirmwareScheme::of(&s).unwrap().integrator,
                expected,
                "h = {h}"
            );
        }
        // ext's closed form is never corrected: the firmware links no correction at any h.
        let mut s = scene("crane-ext", "scheme = \"bdf\"");
        s.solver.h = 0.002;
        assert_eq!(
            FirmwareScheme::of(&s).unwrap().integrator,
            I::StructuredBdfUncorrected(4)
        );
        // A model of no registered crane is named in the refusal.
        for (kind, model) in [
            ("mass-on-car", "mass-on-car"),
            ("mass-on-car-ext", "mass-on-car-ext"),
        ] {
            let e = FirmwareScheme::of(&scene(kind, "scheme = \"bdf\"")).unwrap_err();
            assert_eq!(e, FirmwareError::NotACrane { model });
        }
        // The extended cranes run on their structured Newton only.
        for (kind, solver) in [
            ("crane-ext", "scheme = \"radau\"\njacobian = \"fd\""),
            ("crane3d-ext", "scheme = \"bdf\"\njacobian = \"broyden\""),
            ("crane-ext", "scheme = \"radau\"\njacobian = \"exact\""),
        ] {
            let e = FirmwareScheme::of(&scene(kind, solver)).unwrap_err();
            assert_eq!(
                e,
                FirmwareError::StructuredOnly {
                    model: s_label(kind)
                }
            );
            assert!(
                e.to_string().contains("structured Newton only"),
                "{kind} {solver}: {e}"
            );
        }
    }

    /// Whatever the scene's solver settings, the firmware's integrator is one of those
    /// the panic proof proves ([`FirmwareScheme::every`], up to BDF's k).
    #[test]
    fn every_firmware_integrator_is_proven() {
        let every = FirmwareScheme::every();
        let mut seen = 0;
        let kinds = firmware_kinds();
        for kind in &kinds {
            for solver in [
                "scheme = \"bdf\"\njacobian = \"exact\"",
                "scheme = \"bdf\"\njacobian = \"fd\"",
                "scheme = \"bdf\"\njacobian = \"broyden\"",
                "scheme = \"radau\"\njacobian = \"exact\"",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                "scheme = \"radau\"\njacobian = \"fd\"",
            ] {
                for h in [0.002, 0.01] {
                    let mut s = scene(kind, solver);
                    s.solver.h = h;
                    let Ok(mut f) = FirmwareScheme::of(&s) else {
                        // The extended cranes refuse what is not their structured Newton.
                        let model = FirmwareModel::of(&s.model).unwrap();
                        assert_eq!(
                            model.structure(),
                            Structure::StructuredOnly,
                            "{kind} {solver} h = {h}"
                        );
                        continue;
                    };
                    f.integrator = match f.integrator {
                        FirmwareIntegrator::StructuredBdf(_) => {
                            FirmwareIntegrator::StructuredBdf(4)
                        }
                        FirmwareIntegrator::StructuredBdfUncorrected(_) => {
                            FirmwareIntegrator::StructuredBdfUncorrected(4)
                        }
                        FirmwareIntegrator::Bdf(_) => FirmwareIntegrator::Bdf(4),
                        other => other,
                    };
                    assert!(every.contains(&f), "{kind} {solver} h = {h}: {f:?}");
                    seen += 1;
                }
            }
        }
        // Every kind's BDF with the exact Jacobian at both h, at least.
        assert!(seen >= 2 * kinds.len(), "{seen} of {kinds:?}");
        // And each is built for its own crane: the one whose type its model's visit
        // hands over.
        struct Crane;
        impl CraneVisitor for Crane {
            type Output = (&'static str, usize, &'static str);
            fn visit<K: FirmwareCrane<A>, const A: usize>(self, _: K::Model) -> Self::Output {
                (K::TYPE, A, K::NAME)
            }
        }
        for f in every {
            let (crane, axes) = f.crane();
            assert_eq!(
                visit_crane(f.model, Crane),
                (crane, axes, f.model.crane_name()),
                "{f:?}"
            );
        }
    }

    /// Every formulation of every registered crane is built on the host with every
    /// integrator the panic proof proves (the types `rust()` names), at rest with zero
    /// set points, by its own crane: another crane's formulation cannot be named
    /// (`FirmwareCrane::Model`), so it is never built as something else.
    #[test]
    fn every_registered_formulation_is_built_by_its_crane() {
        struct Steps;
        impl<K: Crane<A>, const A: usize> FirmwareVisitor<K, A> for Steps {
            type Output = Vec<f64>;
            fn visit<F: Feedforward<A, Reference = K::Reference> + Replan<A>>(
                self,
                mut f: F,
            ) -> Vec<f64> {
                f.step().unwrap().u.to_vec()
            }
        }
        struct AtRest<'a>(&'a Scene, FirmwareIntegrator);
        impl CraneVisitor for AtRest<'_> {
            type Output = Vec<f64>;
            fn visit<K: FirmwareCrane<A>, const A: usize>(self, model: K::Model) -> Vec<f64> {
                let (crane, own) = K::of(&self.0.model).unwrap();
                assert_eq!(own, model);
                let start = trajectory::<f64, A>(self.0).unwrap().start();
                let plan = command_plan::<K, A>(start.into(), 5).unwrap();
                let mode = match self.1 {
                    FirmwareIntegrator::StructuredRadau5 | FirmwareIntegrator::Radau5 => {
                        solver_core::JacobianMode::Transformed
                    }
                    _ => solver_core::JacobianMode::Exact,
                };
                let settings = SolverSettings::paper(mode);
                crane
                    .inverse_model(model, self.1, plan, &settings, Steps)
                    .unwrap()
            }
        }
        let mut built = 0;
        for kind in firmware_kinds() {
            let s = scene(kind, "scheme = \"bdf\"");
            let model = FirmwareModel::of(&s.model).unwrap();
            for f in FirmwareScheme::every()
                .into_iter()
                .filter(|f| f.model == model)
            {
                let u = visit_crane(model, AtRest(&s, f.integrator));
                assert_eq!(u.len(), f.crane().1, "{f:?}");
                assert!(u.iter().all(|u| *u == 0.0), "{f:?}: {u:?}");
                built += 1;
            }
        }
        assert_eq!(built, FirmwareScheme::every().len());
        // A structured integrator named for a model without a structured elimination is
        // refused, never built as a dense one.
        let plan = Plan::at_rest([12.0, 8.0].into(), 5).unwrap();
        let settings = SolverSettings::paper(solver_core::JacobianMode::Exact);
        let proj = crate::cranes::planar::PlanarModel::Proj;
        for i in [
            FirmwareIntegrator::StructuredBdf(4),
            FirmwareIntegrator::StructuredBdfUncorrected(4),
            FirmwareIntegrator::StructuredRadau5,
        ] {
            let built = Planar::PAPER.inverse_model(proj, i, plan, &settings, Steps);
            let e = built.unwrap_err();
            assert!(
                matches!(e, FirmwareError::NotStructured { model: "CraneProj" }),
                "{i:?}: {e:?}"
            );
        }
        // Manual mode asked of a formulation without it is refused naming both (the
        // scene check refuses it first), not built on the plan.
        let dp = crate::cranes::hook_and_load::HookAndLoad::EXAMPLE;
        let subs = crate::cranes::hook_and_load::HookAndLoadModel::Subs;
        let built = dp.steered_inverse_model(
            subs,
            FirmwareIntegrator::StructuredBdfUncorrected(4),
            plan,
            (),
            &settings,
            Steps,
        );
        assert_eq!(
            built.unwrap_err(),
            FirmwareError::NoManualMode {
                crane: "hook-and-load crane",
                model: "DoublePendulumSubs"
            }
        );
    }
}
