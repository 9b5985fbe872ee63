//! The one place where a scene's crane, model and scheme become types.
//!
//! Every tool that runs a scene comes through here, so they cannot drift apart:
//! - the studies, the sweep and the paper's figures, through [`model`], which builds the
//!   scene's model on its move in the study's scalar and hands it to a
//!   [`ModelVisitor`] (which steps it with any [`Scheme`] it likes), and [`Exact`], the
//!   exact inputs Eq. 29 measures against;
//! - the firmware's build script, the host's run of the firmware, the virtual ECU and the
//!   fuzzer's build script, through [`firmware`], which hands the scene's setup to a
//!   [`FirmwareCraneVisitor`] as its crane's type ([`FirmwareCrane`], one registration per
//!   crane); [`FirmwareScheme`] is the integrator the firmware links for the scene, as
//!   the Rust type the build scripts write ([`FirmwareScheme::rust`]) and as the same
//!   type built on the host ([`FirmwareCrane::inverse_model`]);
//! - the panic proof's build script, through [`FirmwareScheme::every`].
//!
//! A new model is one arm in [`model`] and [`Exact::new`], and if the firmware drives it
//! a [`FirmwareModel`] and its crane's [`FirmwareCrane`] (docs/MODELS.md).

use controller::commissioning::NodeSetup;
use controller::correction::AxesCorrection;
use controller::crane::command_plan;
use controller::feedback::{Config as FeedbackConfig, NoFeedback, StateFeedback};
use controller::feedback3d::SpatialFeedback;
use controller::feedforward::{CraneReference, Feedforward, InverseModel, Replan};
use controller::planner::Crane;
use controller::planner::Planner;
use controller::Config;
use sim::simulated::Simulated;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::{Crane3dExt, Crane3dParams, Crane3dSubs};
use solver_core::models::crane_ext::{self, CraneExt};
use solver_core::models::crane_proj::{self, CraneProj};
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::models::mass_on_car::MassOnCar;
use solver_core::models::mass_on_car_ext::MassOnCarExt;
use solver_core::plan::Plan;
use solver_core::reference::dopri5::Dopri5Settings;
use solver_core::reference::flat_crane::flat_inverse;
use solver_core::reference::flat_crane3d;
use solver_core::reference::mass_on_car::MassOnCarReference;
use solver_core::schemes::bdf::CORRECT_BELOW_H;
use solver_core::trajectory::{PointToPoint, Trajectory};
use solver_core::{DaeModel, Driven, Error, Integrator, Real, Scheme, SolverSettings};

use crate::commissioning::CommissioningFile;
use crate::feedback::FeedbackSpec;
use crate::{
    trajectory, JacobianSpec, ModelSpec, NewtonSpec, ScalarSpec, Scene, SceneError, SchemeSpec,
};

/// What is done with a scene's model, whatever model it is (the studies).
pub trait ModelVisitor<T: Real> {
    /// What it gives.
    type Output;
    /// Does it with `model` (`N` unknowns, `NU` inputs, `S = 3N` for Radau's stage
    /// system), driven by the scene's move in `T`.
    fn visit<M: DaeModel<T, N, NU>, const N: usize, const NU: usize, const S: usize>(
        self,
        model: M,
    ) -> Self::Output;
}

/// Builds the scene's model on its move in `T` and hands it to `visitor`; a model its
/// parameters or move make impossible (rope slack, workspace, smoothness) is refused.
pub fn model<T: Real, V: ModelVisitor<T>>(
    scene: &Scene,
    visitor: V,
) -> Result<V::Output, SceneError> {
    let err = |e: Error| scene.field_of(e);
    Ok(match &scene.model {
        ModelSpec::CraneSubs(c) => visitor
            .visit::<_, { crane_subs::N }, { crane_subs::NU }, { crane_subs::S }>(
                CraneSubs::new(c.params(), trajectory::<T, 2>(scene)?).map_err(err)?,
            ),
        ModelSpec::CraneProj(c) => visitor
            .visit::<_, { crane_proj::N }, { crane_proj::NU }, { crane_proj::S }>(
                CraneProj::new(c.params(), trajectory::<T, 2>(scene)?).map_err(err)?,
            ),
        ModelSpec::MassOnCar(m) => {
            use solver_core::models::mass_on_car::{N, NU, S};
            visitor.visit::<_, N, NU, S>(
                MassOnCar::new(m.params(), trajectory::<T, 1>(scene)?).map_err(err)?,
            )
        }
        ModelSpec::Crane3dSubs(c) => {
            use solver_core::models::crane3d::subs::{N, NU, S};
            visitor.visit::<_, N, NU, S>(
                Crane3dSubs::new(c.params(), trajectory::<T, 3>(scene)?).map_err(err)?,
            )
        }
        ModelSpec::CraneExt(c) => visitor
            .visit::<_, { crane_ext::N }, { crane_ext::NU }, { crane_ext::S }>(
                CraneExt::new(c.params(), trajectory::<T, 2>(scene)?).map_err(err)?,
            ),
        ModelSpec::MassOnCarExt(m) => {
            use solver_core::models::mass_on_car_ext::{N, NU, S};
            visitor.visit::<_, N, NU, S>(
                MassOnCarExt::new(m.params(), trajectory::<T, 1>(scene)?).map_err(err)?,
            )
        }
        ModelSpec::Crane3dExt(c) => {
            use solver_core::models::crane3d::ext::{N, NU, S};
            visitor.visit::<_, N, NU, S>(
                Crane3dExt::new(c.params(), trajectory::<T, 3>(scene)?).map_err(err)?,
            )
        }
    })
}

/// The e_max above which a run of `model` counts as inaccurate: 1 mm/s for the cranes'
/// velocity set points, 0.01 N for the mass-on-car's force.
#[must_use]
pub fn accuracy_threshold(model: &ModelSpec) -> f64 {
    match model {
        ModelSpec::MassOnCar(_) | ModelSpec::MassOnCarExt(_) => 1e-2,
        ModelSpec::CraneSubs(_)
        | ModelSpec::CraneProj(_)
        | ModelSpec::CraneExt(_)
        | ModelSpec::Crane3dSubs(_)
        | ModelSpec::Crane3dExt(_) => 1e-3,
    }
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
/// a run against.
#[derive(Debug, Clone)]
pub enum Exact {
    /// The crane's flat inverse (any formulation).
    Crane(CraneParams, PointToPoint<f64, 2>),
    /// The mass-on-car's internal dynamics integrated along (Eqs. 37–38).
    MassOnCar(MassOnCarReference<PointToPoint<f64, 1>>),
    /// The 3D crane's flat inverse.
    Crane3d(Crane3dParams, PointToPoint<f64, 3>),
}

impl Exact {
    /// The reference of `scene`'s model and move.
    pub fn new(scene: &Scene) -> Result<Self, SceneError> {
        Ok(match &scene.model {
            ModelSpec::CraneSubs(c) | ModelSpec::CraneProj(c) | ModelSpec::CraneExt(c) => {
                Exact::Crane(c.params(), trajectory::<f64, 2>(scene)?)
            }
            ModelSpec::MassOnCar(m) | ModelSpec::MassOnCarExt(m) => Exact::MassOnCar(
                MassOnCarReference::new(
                    m.params(),
                    trajectory::<f64, 1>(scene)?,
                    0.0,
                    Dopri5Settings::default(),
                )
                .map_err(|e| scene.field_of(e))?,
            ),
            ModelSpec::Crane3dSubs(c) | ModelSpec::Crane3dExt(c) => {
                Exact::Crane3d(c.params(), trajectory::<f64, 3>(scene)?)
            }
        })
    }

    /// The exact inputs at `t` into `out` (`t` never decreases between calls).
    pub fn at(&mut self, t: f64, out: &mut Vec<f64>) -> Result<(), Error> {
        out.clear();
        match self {
            Exact::Crane(p, z) => out.extend(flat_inverse(p, z, t).u),
            Exact::MassOnCar(r) => out.push(r.advance_to(t)?.f),
            Exact::Crane3d(p, z) => out.extend(flat_crane3d::flat_inverse(p, z, t).u),
        }
        Ok(())
    }
}

/// What is done with the firmware's inverse model for a crane with `A` driven axes (the
/// host's run of the firmware, the virtual ECU), whatever its types.
pub trait FirmwareVisitor<K: Crane<A>, const A: usize> {
    /// What it gives.
    type Output;
    /// Does it with `feedforward`: the scene's model on the firmware's plan, advanced by
    /// the integrator the firmware links.
    fn visit<F: Feedforward<A, Reference = K::Reference> + Replan<A>>(
        self,
        feedforward: F,
    ) -> Self::Output;
}

/// A model the firmware can drive: a crane, in f64.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FirmwareModel {
    /// The planar crane, *subs* (Eqs. 24–28).
    CraneSubs,
    /// The planar crane, *proj* (Eqs. 21–22, 27–28).
    CraneProj,
    /// The crane in three dimensions, *subs*.
    Crane3dSubs,
    /// The planar crane, *ext* (*subs* minimally extended to index 1).
    CraneExt,
    /// The crane in three dimensions, *ext*.
    Crane3dExt,
}

impl FirmwareModel {
    /// The model's module under `solver_core::models` and its type's name.
    const fn path(self) -> (&'static str, &'static str) {
        match self {
            Self::CraneSubs => ("crane_subs", "CraneSubs"),
            Self::CraneProj => ("crane_proj", "CraneProj"),
            Self::Crane3dSubs => ("crane3d::subs", "Crane3dSubs"),
            Self::CraneExt => ("crane_ext", "CraneExt"),
            Self::Crane3dExt => ("crane3d::ext", "Crane3dExt"),
        }
    }

    /// Its driven axes.
    #[must_use]
    pub const fn axes(self) -> usize {
        match self {
            Self::CraneSubs | Self::CraneProj | Self::CraneExt => 2,
            Self::Crane3dSubs | Self::Crane3dExt => 3,
        }
    }

    /// Whether it has a structured elimination (`StructuredJacobian`) and a
    /// closed-form step.
    #[must_use]
    pub const fn structured(self) -> bool {
        matches!(
            self,
            Self::CraneSubs | Self::Crane3dSubs | Self::CraneExt | Self::Crane3dExt
        )
    }

    /// Whether the firmware runs it with its structured elimination only: the extended
    /// cranes' closed-form step is their exact solution at every h, and a dense Newton on
    /// 13 or 18 unknowns (39 or 54 in Radau's stage system) would cost more flash and
    /// time for the same bits.
    #[must_use]
    pub const fn structured_only(self) -> bool {
        matches!(self, Self::CraneExt | Self::Crane3dExt)
    }
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
    const fn alias(self) -> (&'static str, Option<usize>) {
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
    pub fn of(scene: &Scene) -> Result<Self, String> {
        if scene.solver.scalar != ScalarSpec::F64 {
            return Err("the firmware plans moves in f64; this scene computes in f32".into());
        }
        let model = match scene.model {
            ModelSpec::CraneSubs(_) => FirmwareModel::CraneSubs,
            ModelSpec::CraneProj(_) => FirmwareModel::CraneProj,
            ModelSpec::Crane3dSubs(_) => FirmwareModel::Crane3dSubs,
            ModelSpec::CraneExt(_) => FirmwareModel::CraneExt,
            ModelSpec::Crane3dExt(_) => FirmwareModel::Crane3dExt,
            ModelSpec::MassOnCar(_) | ModelSpec::MassOnCarExt(_) => {
                return Err("the firmware drives a crane; this scene is the mass-on-car".into())
            }
        };
        let s = &scene.solver;
        let transformed = s.newton == NewtonSpec::Transformed;
        let integrator = match s.scheme {
            SchemeSpec::Bdf
                if model.structured() && s.jacobian == JacobianSpec::Exact && !transformed =>
            {
                // The extended cranes have no differential unknown: BDF never corrects
                // their closed form (`bdf::Structured`), at any h.
                if s.h >= CORRECT_BELOW_H || model.structured_only() {
                    FirmwareIntegrator::StructuredBdfUncorrected(s.k)
                } else {
                    FirmwareIntegrator::StructuredBdf(s.k)
                }
            }
            SchemeSpec::Bdf => FirmwareIntegrator::Bdf(s.k),
            SchemeSpec::Radau if transformed && model.structured() => {
                FirmwareIntegrator::StructuredRadau5
            }
            SchemeSpec::Radau if transformed => FirmwareIntegrator::Radau5,
            SchemeSpec::Radau => FirmwareIntegrator::RadauFull,
        };
        let scheme = Self { model, integrator };
        if model.structured_only() && !scheme.structured() {
            return Err(
                "the firmware runs the extended formulation (ext) with its structured Newton only: \
                 BDF with jacobian = \"exact\", or Radau with newton = \"transformed\""
                    .into(),
            );
        }
        Ok(scheme)
    }

    /// Every integrator the firmware can link, model by model (BDF with k = 4; the
    /// proofs hold k opaque): what the link-time panic proof proves (`panic-proof/`'s
    /// build script writes one arm per entry). [`FirmwareScheme::of`] names nothing else.
    #[must_use]
    pub fn every() -> Vec<FirmwareScheme> {
        use FirmwareIntegrator as I;
        [
            FirmwareModel::CraneSubs,
            FirmwareModel::CraneProj,
            FirmwareModel::Crane3dSubs,
            FirmwareModel::CraneExt,
            FirmwareModel::Crane3dExt,
        ]
        .into_iter()
        .flat_map(|model| {
            let integrators: &[FirmwareIntegrator] = if model.structured_only() {
                &[I::StructuredBdfUncorrected(4), I::StructuredRadau5]
            } else if model.structured() {
                &[
                    I::StructuredBdf(4),
                    I::StructuredBdfUncorrected(4),
                    I::Bdf(4),
                    I::StructuredRadau5,
                    I::RadauFull,
                ]
            } else {
                &[I::Bdf(4), I::Radau5, I::RadauFull]
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
        match self.model {
            FirmwareModel::CraneSubs | FirmwareModel::CraneProj | FirmwareModel::CraneExt => {
                (<CraneParams as FirmwareCrane<2>>::TYPE, 2)
            }
            FirmwareModel::Crane3dSubs | FirmwareModel::Crane3dExt => {
                (<Crane3dParams as FirmwareCrane<3>>::TYPE, 3)
            }
        }
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
        let (module, model) = self.model.path();
        let (alias, k) = self.integrator.alias();
        let plan = format!("solver_core::plan::Plan<f64, {}>", self.model.axes());
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

/// Builds the integrator of the model module `$m` (a `schemes_of!` alias) that
/// `$integrator` names on `$model` (driven by a `$plan`) and hands both to `$visit`
/// (`$visitor`, model, integrator): one arm per [`FirmwareIntegrator`], the same types
/// [`FirmwareScheme::rust`] names.
macro_rules! integrators {
    ($visit:ident, $m:path, $integrator:expr, $model:expr, $settings:expr, $visitor:expr, $plan:ty) => {{
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
    // A model without a structured elimination: its firmware integrators are the dense
    // ones ([`FirmwareScheme::of`] never names a structured one for it).
    ($visit:ident, $m:path, dense, $integrator:expr, $model:expr, $settings:expr, $visitor:expr, $plan:ty) => {{
        use $m as m;
        let model = $model;
        match $integrator {
            FirmwareIntegrator::Bdf(k)
            | FirmwareIntegrator::StructuredBdf(k)
            | FirmwareIntegrator::StructuredBdfUncorrected(k) => {
                let i = m::Bdf::<f64, $plan>::new(&model, $settings, k, 0.0)?;
                $visit($visitor, model, i)
            }
            FirmwareIntegrator::Radau5 | FirmwareIntegrator::StructuredRadau5 => {
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

/// A crane the firmware drives, registered once: how a scene names it, the lab drives'
/// limits, its parameters as the build script writes them, its firmware integrators
/// and its state feedback. The planar crane (`A = 2`) and the 3D crane (`A = 3`).
pub trait FirmwareCrane<const A: usize>: Crane<A> + Simulated<A> + Copy + core::fmt::Debug {
    /// The parameters' type, as the build script writes it.
    const TYPE: &'static str;
    /// The correction a scene's `[feedback]` links.
    type Feedback: AxesCorrection<A, Self::Reference>;
    /// [`FirmwareCrane::Feedback`]'s type, as the build script writes it.
    const FEEDBACK_TYPE: &'static str;
    /// The expression that builds it from `FEEDBACK` (and `PARAMS`), as the build script
    /// writes it ([`FirmwareCrane::feedback`] builds the same).
    const FEEDBACK_NEW: &'static str;
    /// How many slopes its feedback reads (the planar crane's φ: 1; the 3D crane's
    /// swing in both vertical planes: 2): the inclinometer must have as many axes.
    const SWING_AXES: u8;
    /// The correction of a scene without `[feedback]`: none (`NoFeedback`, which is
    /// each crane's `AxesCorrection` on its own).
    type FeedforwardOnly: AxesCorrection<A, Self::Reference> + Default;
    /// This crane's parameters, if `model` is one of its models.
    fn of(model: &ModelSpec) -> Option<Self>;
    /// The parameters as a Rust constant expression.
    fn source(&self) -> String;
    /// The scene's `[feedback]` as the controller's, for this crane and step `h`; or why
    /// this crane cannot honour it.
    fn feedback_config(spec: &FeedbackSpec, crane: &Self, h: f64)
        -> Result<FeedbackConfig, String>;
    /// The state feedback of this crane for `config` ([`FirmwareCrane::feedback_config`]'s).
    fn feedback(&self, config: FeedbackConfig) -> Result<Self::Feedback, String>;
    /// The firmware's inverse model for `scheme` on `plan`, at rest at t = 0, handed to
    /// `visitor`: the types [`FirmwareScheme::rust`] names.
    fn inverse_model<V: FirmwareVisitor<Self, A>>(
        self,
        scheme: FirmwareScheme,
        plan: Plan<f64, A>,
        settings: &SolverSettings,
        visitor: V,
    ) -> Result<V::Output, Error>;
}

/// A scheme for another crane's model (never built: [`FirmwareScheme::of`] names the
/// scene's own model).
const fn other_crane(scheme: FirmwareScheme) -> Error {
    let _ = scheme;
    Error::InvalidSetting {
        name: "model (the firmware scheme names another crane's model)",
        value: f64::NAN,
    }
}

/// The paper's planar crane: trolley and winch (Eqs. 24–28, Tab. 3).
impl FirmwareCrane<2> for CraneParams {
    const TYPE: &'static str = "solver_core::models::crane::CraneParams";
    type Feedback = StateFeedback;
    const FEEDBACK_TYPE: &'static str = "controller::feedback::StateFeedback";
    const FEEDBACK_NEW: &'static str = "Correction::new(FEEDBACK)";
    const SWING_AXES: u8 = 1;
    type FeedforwardOnly = NoFeedback;
    fn of(model: &ModelSpec) -> Option<Self> {
        model.crane().map(|c| c.params())
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
    ) -> Result<FeedbackConfig, String> {
        spec.config(crane, h).map_err(|e| e.to_string())
    }
    fn feedback(&self, config: FeedbackConfig) -> Result<StateFeedback, String> {
        StateFeedback::new(config).map_err(|e| format!("{e:?}"))
    }
    fn inverse_model<V: FirmwareVisitor<Self, 2>>(
        self,
        scheme: FirmwareScheme,
        plan: Plan<f64, 2>,
        settings: &SolverSettings,
        visitor: V,
    ) -> Result<V::Output, Error> {
        type P = Plan<f64, 2>;
        match scheme.model {
            FirmwareModel::CraneSubs => Ok(integrators!(
                visit,
                solver_core::models::crane_subs,
                scheme.integrator,
                CraneSubs::new(self, plan)?,
                settings,
                visitor,
                P
            )),
            FirmwareModel::CraneProj => Ok(integrators!(
                visit,
                solver_core::models::crane_proj,
                dense,
                scheme.integrator,
                CraneProj::new(self, plan)?,
                settings,
                visitor,
                P
            )),
            FirmwareModel::CraneExt => Ok(integrators!(
                visit,
                solver_core::models::crane_ext,
                scheme.integrator,
                CraneExt::new(self, plan)?,
                settings,
                visitor,
                P
            )),
            FirmwareModel::Crane3dSubs | FirmwareModel::Crane3dExt => Err(other_crane(scheme)),
        }
    }
}

/// The crane in three dimensions: bridge, trolley and hoist; its state feedback per
/// vertical plane ([`SpatialFeedback`]) with a two-axis inclinometer.
impl FirmwareCrane<3> for Crane3dParams {
    const TYPE: &'static str = "solver_core::models::crane3d::Crane3dParams";
    type Feedback = SpatialFeedback;
    const FEEDBACK_TYPE: &'static str = "controller::feedback3d::SpatialFeedback";
    const FEEDBACK_NEW: &'static str = "Correction::new(FEEDBACK, PARAMS.tau2)";
    const SWING_AXES: u8 = 2;
    type FeedforwardOnly = NoFeedback;
    fn of(model: &ModelSpec) -> Option<Self> {
        model.crane3d().map(|c| c.params())
    }
    fn source(&self) -> String {
        let w = self.workspace;
        format!(
            "solver_core::models::crane3d::Crane3dParams {{ m: {:?}, g: {:?}, tau1: {:?}, tau2: {:?}, tau3: {:?}, workspace: solver_core::models::crane3d::Workspace3d {{ x_min: {:?}, x_max: {:?}, y_min: {:?}, y_max: {:?}, l_min: {:?}, l_max: {:?} }}, min_tension_fraction: {:?} }}",
            self.m, self.g, self.tau1, self.tau2, self.tau3, w.x_min, w.x_max, w.y_min, w.y_max, w.l_min, w.l_max, self.min_tension_fraction
        )
    }
    /// The x–z plane's configuration (bridge and hoist: τ1, τ3) from the scene's
    /// `[feedback]`; the y–z plane's is the same with the trolley's τ2
    /// ([`SpatialFeedback::new`]).
    fn feedback_config(
        spec: &FeedbackSpec,
        crane: &Self,
        h: f64,
    ) -> Result<FeedbackConfig, String> {
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
        spec.config(&plane, h).map_err(|e| e.to_string())
    }
    fn feedback(&self, config: FeedbackConfig) -> Result<SpatialFeedback, String> {
        SpatialFeedback::new(config, self.tau2).map_err(|e| format!("{e:?}"))
    }
    fn inverse_model<V: FirmwareVisitor<Self, 3>>(
        self,
        scheme: FirmwareScheme,
        plan: Plan<f64, 3>,
        settings: &SolverSettings,
        visitor: V,
    ) -> Result<V::Output, Error> {
        type P = Plan<f64, 3>;
        match scheme.model {
            FirmwareModel::Crane3dSubs => Ok(integrators!(
                visit,
                solver_core::models::crane3d::subs,
                scheme.integrator,
                Crane3dSubs::new(self, plan)?,
                settings,
                visitor,
                P
            )),
            FirmwareModel::Crane3dExt => Ok(integrators!(
                visit,
                solver_core::models::crane3d::ext,
                scheme.integrator,
                Crane3dExt::new(self, plan)?,
                settings,
                visitor,
                P
            )),
            FirmwareModel::CraneSubs | FirmwareModel::CraneProj | FirmwareModel::CraneExt => {
                Err(other_crane(scheme))
            }
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
pub struct FirmwareScene<K, const A: usize> {
    /// Crane parameters.
    pub params: K,
    /// The scene's move.
    pub first_move: PointToPoint<f64, A>,
    /// The plan at t = 0: at rest at the move's start, the move planned. Moves on
    /// command have the smoothness `max(n, K::MIN_COMMAND_SMOOTHNESS)`
    /// (`controller::crane::command_plan`).
    pub plan: Plan<f64, A>,
    /// The planner of moves on command, with each drive's set-point limits (the
    /// commissioning file's, [`Crane::LAB_LIMITS`] where it names none).
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
}

impl<K, const A: usize> FirmwareScene<K, A> {
    /// Where the load rests at power-up: where the scene's move starts (`[x_C, z_C]`,
    /// the 3D crane's `[x_C, y_C, z_C]`). At rest the drives stand there too (trolley
    /// and bridge under the load, the rope as long as the load is deep).
    #[must_use]
    pub fn start(&self) -> [f64; A] {
        self.first_move.start().into()
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
) -> Result<FirmwareScene<K, A>, String> {
    let scheme = FirmwareScheme::of(scene)?;
    let params = K::of(&scene.model).ok_or("the scene's model is not this crane's")?;
    let first_move = trajectory::<f64, A>(scene).map_err(|e| e.to_string())?;
    let mut plan = command_plan::<K, A>(first_move.start().into(), scene.trajectory.smoothness)
        .map_err(|e| e.to_string())?;
    plan.push(first_move).map_err(|e| e.to_string())?;
    // Each drive's set-point limits: its commissioning row's, the crane's lab drive's
    // where the row names none — the planner's and the gate's.
    let limits = commissioning
        .limits_for(K::DRIVES, K::LAB_LIMITS)
        .map_err(|e| format!("commissioning file: {e}"))?;
    let planner = Planner::with_axes(params, limits);
    let (t0, t1) = first_move.active_span();
    planner.check(&first_move, t0, t1).map_err(|r| {
        format!("the scene's move breaks the planner's rule {r:?} (docs/COMMANDS.md)")
    })?;
    let period_ms = (scene.solver.h * 1000.0).round() as u32;
    if (f64::from(period_ms) / 1000.0 - scene.solver.h).abs() > 1e-12 {
        return Err(format!(
            "the firmware's cycle is a whole number of ms; h = {} s",
            scene.solver.h
        ));
    }
    if period_ms >= WATCHDOG_MS {
        return Err(format!(
            "h = {} s is not shorter than the watchdog's {WATCHDOG_MS} ms: every cycle would reset the controller",
            scene.solver.h
        ));
    }
    let cycles = scene.trajectory.t_end / scene.solver.h;
    if (cycles - cycles.round()).abs() > 1e-9 * cycles.max(1.0) {
        return Err(format!(
            "h = {} s does not divide t_end = {} s: the run would stop short",
            scene.solver.h, scene.trajectory.t_end
        ));
    }
    let config = commissioning
        .config_for(K::DRIVES, limits, period_ms)
        .map_err(|e| format!("commissioning file: {e}"))?;
    let feedback = scene
        .feedback
        .map(|f| K::feedback_config(&f, &params, scene.solver.h))
        .transpose()?
        .map(|f| {
            commissioning
                .lag()
                .map(|inclinometer| FeedbackConfig { inclinometer, ..f })
                .map_err(|e| format!("commissioning file: {e}"))
        })
        .transpose()?;
    let config = if feedback.is_some() {
        commissioning
            .with_inclinometer_of(config, K::SWING_AXES)
            .map_err(|e| format!("commissioning file: {e}"))?
    } else {
        config
    };
    let ready = commissioning_time(&config);
    if scene.trajectory.t_start < ready {
        return Err(format!(
            "the move starts at {} s, before the drives can be commissioned and enabled ({ready:.2} s at h = {} s)",
            scene.trajectory.t_start, scene.solver.h
        ));
    }
    Ok(FirmwareScene {
        params,
        first_move,
        plan,
        planner,
        config,
        cycles: scene.steps() as u32,
        feedback,
        scheme,
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
) -> Result<V::Output, String> {
    Ok(match FirmwareScheme::of(scene)?.model {
        FirmwareModel::CraneSubs | FirmwareModel::CraneProj | FirmwareModel::CraneExt => {
            visitor.visit(firmware_scene::<CraneParams, 2>(scene, commissioning)?)
        }
        FirmwareModel::Crane3dSubs | FirmwareModel::Crane3dExt => {
            visitor.visit(firmware_scene::<Crane3dParams, 3>(scene, commissioning)?)
        }
    })
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
) -> Result<V::Output, String> {
    let scheme = FirmwareScheme::of(scene)?;
    let settings = &scene.settings();
    let i = scheme.integrator;
    // The move as the firmware plans it: at rest at its start, the move pushed.
    // `crane` only names the crane whose command smoothness the plan takes.
    fn on_plan<K: Crane<A>, const A: usize>(
        _crane: &K,
        z: PointToPoint<f64, A>,
        n: usize,
    ) -> Result<Plan<f64, A>, Error> {
        let mut plan = command_plan::<K, A>(z.start().into(), n)?;
        plan.push(z)?;
        Ok(plan)
    }
    let n = scene.trajectory.smoothness;
    let planar = || {
        let p = scene.model.crane().map(|c| c.params());
        let p = p.ok_or_else(|| "the scene's model is not the planar crane".to_string())?;
        Ok::<_, String>((p, trajectory::<f64, 2>(scene).map_err(|e| e.to_string())?))
    };
    let done = match (scheme.model, driven) {
        (FirmwareModel::CraneSubs, DrivenBy::PointToPoint) => {
            let (p, z) = planar()?;
            subs_steps(p, z, i, settings, visitor)
        }
        (FirmwareModel::CraneSubs, DrivenBy::Plan) => {
            let (p, z) = planar()?;
            on_plan(&p, z, n).and_then(|plan| subs_steps(p, plan, i, settings, visitor))
        }
        (FirmwareModel::CraneProj, DrivenBy::PointToPoint) => {
            let (p, z) = planar()?;
            proj_steps(p, z, i, settings, visitor)
        }
        (FirmwareModel::CraneProj, DrivenBy::Plan) => {
            let (p, z) = planar()?;
            on_plan(&p, z, n).and_then(|plan| proj_steps(p, plan, i, settings, visitor))
        }
        (FirmwareModel::CraneExt, DrivenBy::PointToPoint) => {
            let (p, z) = planar()?;
            ext_steps(p, z, i, settings, visitor)
        }
        (FirmwareModel::CraneExt, DrivenBy::Plan) => {
            let (p, z) = planar()?;
            on_plan(&p, z, n).and_then(|plan| ext_steps(p, plan, i, settings, visitor))
        }
        (FirmwareModel::Crane3dSubs, driven) => {
            let p = Crane3dParams::of(&scene.model)
                .ok_or_else(|| "the scene's model is not the 3D crane".to_string())?;
            let z = trajectory::<f64, 3>(scene).map_err(|e| e.to_string())?;
            match driven {
                DrivenBy::PointToPoint => crane3d_steps(p, z, i, settings, visitor),
                DrivenBy::Plan => {
                    on_plan(&p, z, n).and_then(|plan| crane3d_steps(p, plan, i, settings, visitor))
                }
            }
        }
        (FirmwareModel::Crane3dExt, driven) => {
            let p = Crane3dParams::of(&scene.model)
                .ok_or_else(|| "the scene's model is not the 3D crane".to_string())?;
            let z = trajectory::<f64, 3>(scene).map_err(|e| e.to_string())?;
            match driven {
                DrivenBy::PointToPoint => crane3d_ext_steps(p, z, i, settings, visitor),
                DrivenBy::Plan => on_plan(&p, z, n)
                    .and_then(|plan| crane3d_ext_steps(p, plan, i, settings, visitor)),
            }
        }
    };
    done.map_err(|e| e.to_string())
}

/// The planar *subs* crane on `z` with the firmware's integrator `i`, to `visitor`.
fn subs_steps<Z: Trajectory<f64, 2>, V: StepsVisitor>(
    p: CraneParams,
    z: Z,
    i: FirmwareIntegrator,
    settings: &SolverSettings,
    visitor: V,
) -> Result<V::Output, Error> {
    Ok(integrators!(
        step_visit,
        solver_core::models::crane_subs,
        i,
        CraneSubs::new(p, z)?,
        settings,
        visitor,
        Z
    ))
}

/// The planar *proj* crane on `z` with the firmware's integrator `i`, to `visitor`.
fn proj_steps<Z: Trajectory<f64, 2>, V: StepsVisitor>(
    p: CraneParams,
    z: Z,
    i: FirmwareIntegrator,
    settings: &SolverSettings,
    visitor: V,
) -> Result<V::Output, Error> {
    Ok(integrators!(
        step_visit,
        solver_core::models::crane_proj,
        dense,
        i,
        CraneProj::new(p, z)?,
        settings,
        visitor,
        Z
    ))
}

/// The 3D crane on `z` with the firmware's integrator `i`, to `visitor`.
fn crane3d_steps<Z: Trajectory<f64, 3>, V: StepsVisitor>(
    p: Crane3dParams,
    z: Z,
    i: FirmwareIntegrator,
    settings: &SolverSettings,
    visitor: V,
) -> Result<V::Output, Error> {
    Ok(integrators!(
        step_visit,
        solver_core::models::crane3d::subs,
        i,
        Crane3dSubs::new(p, z)?,
        settings,
        visitor,
        Z
    ))
}

/// The planar *ext* crane on `z` with the firmware's integrator `i`, to `visitor`.
fn ext_steps<Z: Trajectory<f64, 2>, V: StepsVisitor>(
    p: CraneParams,
    z: Z,
    i: FirmwareIntegrator,
    settings: &SolverSettings,
    visitor: V,
) -> Result<V::Output, Error> {
    Ok(integrators!(
        step_visit,
        solver_core::models::crane_ext,
        i,
        CraneExt::new(p, z)?,
        settings,
        visitor,
        Z
    ))
}

/// The 3D *ext* crane on `z` with the firmware's integrator `i`, to `visitor`.
fn crane3d_ext_steps<Z: Trajectory<f64, 3>, V: StepsVisitor>(
    p: Crane3dParams,
    z: Z,
    i: FirmwareIntegrator,
    settings: &SolverSettings,
    visitor: V,
) -> Result<V::Output, Error> {
    Ok(integrators!(
        step_visit,
        solver_core::models::crane3d::ext,
        i,
        Crane3dExt::new(p, z)?,
        settings,
        visitor,
        Z
    ))
}

/// `model` and `integrator` to a [`StepsVisitor`].
fn step_visit<V, M, I, const N: usize, const NU: usize>(
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
fn visit<K, V, M, I, const N: usize, const A: usize>(
    visitor: V,
    model: M,
    integrator: I,
) -> V::Output
where
    K: Crane<A>,
    V: FirmwareVisitor<K, A>,
    M: CraneReference<Reference = K::Reference>
        + DaeModel<f64, N, A>
        + Driven<Trajectory = Plan<f64, A>>,
    I: Integrator<f64, M, N, A>,
{
    visitor.visit(InverseModel::<M, I, f64, N>::new(model, integrator))
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
        let (start, end) = match model {
            "mass-on-car" | "mass-on-car-ext" => ("[0.0]", "[1.0]"),
            "crane3d-subs" | "crane3d-ext" => ("[12.0, 3.0, 8.0]", "[20.0, 6.0, 4.0]"),
            _ => ("[12.0, 8.0]", "[20.0, 4.0]"),
        };
        Scene::parse(&format!(
            "name = \"t\"\n[model]\nkind = \"{model}\"\n[trajectory]\nstart = {start}\nend = {end}\nt_start = 1.0\nduration = 7.0\nsmoothness = 4\nt_end = 10.0\n[solver]\n{solver}\n{jacobian}h = 0.01\n"
        ))
        .unwrap()
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
        ] {
            let (ty, unknowns) = model::<f64, _>(&scene(kind, "scheme = \"bdf\""), Name).unwrap();
            assert!(ty.contains(name), "{ty}");
            assert_eq!(unknowns, n, "{kind}");
        }
    }

    #[test]
    fn the_firmware_names_the_types_it_builds() {
        use FirmwareIntegrator as I;
        use FirmwareModel as M;
        for (kind, solver, model, integrator) in [
            (
                "crane-subs",
                "scheme = \"bdf\"\njacobian = \"exact\"",
                M::CraneSubs,
                I::StructuredBdfUncorrected(4),
            ),
            (
                "crane-subs",
                "scheme = \"bdf\"\njacobian = \"fd\"",
                M::CraneSubs,
                I::Bdf(4),
            ),
            (
                "crane-subs",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                M::CraneSubs,
                I::StructuredRadau5,
            ),
            (
                "crane-subs",
                "scheme = \"radau\"\njacobian = \"exact\"",
                M::CraneSubs,
                I::RadauFull,
            ),
            (
                "crane-proj",
                "scheme = \"bdf\"\njacobian = \"exact\"",
                M::CraneProj,
                I::Bdf(4),
            ),
            (
                "crane-proj",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                M::CraneProj,
                I::Radau5,
            ),
            (
                "crane-proj",
                "scheme = \"radau\"\njacobian = \"fd\"",
                M::CraneProj,
                I::RadauFull,
            ),
            (
                "crane3d-subs",
                "scheme = \"bdf\"\njacobian = \"exact\"",
                M::Crane3dSubs,
                I::StructuredBdfUncorrected(4),
            ),
            (
                "crane3d-subs",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                M::Crane3dSubs,
                I::StructuredRadau5,
            ),
            (
                "crane-ext",
                "scheme = \"bdf\"\njacobian = \"exact\"",
                M::CraneExt,
                I::StructuredBdfUncorrected(4),
            ),
            (
                "crane-ext",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                M::CraneExt,
                I::StructuredRadau5,
            ),
            (
                "crane3d-ext",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                M::Crane3dExt,
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
            let plan = format!("Plan<f64, {}>", model.axes());
            assert!(rust.model.contains(&plan) && rust.integrator.contains(&plan));
        }
        // Below 5 ms BDF's closed form is corrected, and the firmware links the correction.
        for (h, expected) in [
            (0.002, I::StructuredBdf(4)),
            (0.005, I::StructuredBdfUncorrected(4)),
        ] {
            let mut s = scene("crane-subs", "scheme = \"bdf\"");
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
        assert!(FirmwareScheme::of(&scene("mass-on-car", "scheme = \"bdf\"")).is_err());
        assert!(FirmwareScheme::of(&scene("mass-on-car-ext", "scheme = \"bdf\"")).is_err());
        // The extended cranes run on their structured Newton only.
        for (kind, solver) in [
            ("crane-ext", "scheme = \"radau\"\njacobian = \"fd\""),
            ("crane3d-ext", "scheme = \"bdf\"\njacobian = \"broyden\""),
            ("crane-ext", "scheme = \"radau\"\njacobian = \"exact\""),
        ] {
            let e = FirmwareScheme::of(&scene(kind, solver)).unwrap_err();
            assert!(e.contains("structured Newton only"), "{kind} {solver}: {e}");
        }
    }

    /// Whatever the scene's solver settings, the firmware's integrator is one of those
    /// the panic proof proves ([`FirmwareScheme::every`], up to BDF's k).
    #[test]
    fn every_firmware_integrator_is_proven() {
        let every = FirmwareScheme::every();
        let mut seen = 0;
        for kind in [
            "crane-subs",
            "crane-proj",
            "crane3d-subs",
            "crane-ext",
            "crane3d-ext",
        ] {
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
                        assert!(kind.ends_with("ext"), "{kind} {solver} h = {h}");
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
        assert_eq!(seen, 44);
        // And each is built for its own crane.
        for f in every {
            let (crane, axes) = f.crane();
            assert_eq!(axes, f.model.axes());
            assert!(crane.ends_with(if axes == 3 {
                "Crane3dParams"
            } else {
                "CraneParams"
            }));
        }
    }

    /// Each crane builds the integrators of its own models only: another crane's scheme
    /// is refused, never built as something else.
    #[test]
    fn a_crane_builds_its_own_models_only() {
        struct Steps;
        impl<K: Crane<A>, const A: usize> FirmwareVisitor<K, A> for Steps {
            type Output = [f64; A];
            fn visit<F: Feedforward<A, Reference = K::Reference> + Replan<A>>(
                self,
                mut f: F,
            ) -> [f64; A] {
                f.step().unwrap().u
            }
        }
        let settings = SolverSettings::paper(solver_core::JacobianMode::Exact);
        let planar = FirmwareScheme::of(&scene("crane-subs", "scheme = \"bdf\"")).unwrap();
        let spatial = FirmwareScheme::of(&scene("crane3d-subs", "scheme = \"bdf\"")).unwrap();
        let plan2 = Plan::at_rest([12.0, 8.0].into(), 5).unwrap();
        let plan3 = Plan::at_rest([12.0, 3.0, 8.0].into(), 5).unwrap();
        let p2 = CraneParams::PAPER;
        let p3 = Crane3dParams::EXAMPLE;
        // At rest the inverse model's set points are zero.
        assert_eq!(
            p2.inverse_model(planar, plan2, &settings, Steps).unwrap(),
            [0.0; 2]
        );
        assert_eq!(
            p3.inverse_model(spatial, plan3, &settings, Steps).unwrap(),
            [0.0; 3]
        );
        assert!(p2.inverse_model(spatial, plan2, &settings, Steps).is_err());
        assert!(p3.inverse_model(planar, plan3, &settings, Steps).is_err());
        let planar_ext = FirmwareScheme::of(&scene("crane-ext", "scheme = \"bdf\"")).unwrap();
        let spatial_ext = FirmwareScheme::of(&scene("crane3d-ext", "scheme = \"bdf\"")).unwrap();
        assert_eq!(
            p2.inverse_model(planar_ext, plan2, &settings, Steps)
                .unwrap(),
            [0.0; 2]
        );
        assert_eq!(
            p3.inverse_model(spatial_ext, plan3, &settings, Steps)
                .unwrap(),
            [0.0; 3]
        );
        assert!(p2
            .inverse_model(spatial_ext, plan2, &settings, Steps)
            .is_err());
        assert!(p3
            .inverse_model(planar_ext, plan3, &settings, Steps)
            .is_err());
    }
}
