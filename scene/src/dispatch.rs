//! The one place where a scene's model and scheme become types.
//!
//! Every tool that runs a scene comes through here, so they cannot drift apart:
//! - the studies, the sweep and the paper's figures, through [`model`], which builds the
//!   scene's model on its move in the study's scalar and hands it to a
//!   [`ModelVisitor`] (which steps it with any [`Scheme`] it likes), and [`Exact`], the
//!   exact inputs Eq. 29 measures against;
//! - the firmware's build script, the host's run of the firmware and the virtual ECU,
//!   through [`FirmwareScheme`]: the integrator the firmware links for the scene, as the
//!   Rust type the build script writes ([`FirmwareScheme::rust`]) and as the same type
//!   built on the host ([`FirmwareScheme::visit`]).
//!
//! A new model is one arm in [`model`] and [`Exact::new`], and its firmware rows in
//! [`FirmwareScheme`] if the firmware can drive it (docs/MODELS.md).

use controller::feedforward::{CraneReference, Feedforward, InverseModel, Replan};
use nalgebra::SVector;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::{Crane3dParams, Crane3dSubs};
use solver_core::models::crane_proj::{self, CraneProj};
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::models::mass_on_car::MassOnCar;
use solver_core::plan::Plan;
use solver_core::reference::dopri5::Dopri5Settings;
use solver_core::reference::flat_crane::flat_inverse;
use solver_core::reference::flat_crane3d;
use solver_core::reference::mass_on_car::MassOnCarReference;
use solver_core::scalar::c;
use solver_core::schemes::bdf::CORRECT_BELOW_H;
use solver_core::trajectory::PointToPoint;
use solver_core::{DaeModel, Driven, Error, Integrator, Real, Scheme, SolverSettings};

use crate::{JacobianSpec, ModelSpec, NewtonSpec, ScalarSpec, Scene, SceneError, SchemeSpec};

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
    })
}

/// The scene's move in the scalar `T`, with its `NZ` output axes.
pub(crate) fn trajectory<T: Real, const NZ: usize>(
    scene: &Scene,
) -> Result<PointToPoint<T, NZ>, SceneError> {
    let t = &scene.trajectory;
    for (field, v) in [("trajectory.start", &t.start), ("trajectory.end", &t.end)] {
        if v.len() != NZ {
            return Err(crate::refuse(
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
    /// The crane's flat inverse (either formulation).
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
            ModelSpec::CraneSubs(c) | ModelSpec::CraneProj(c) => {
                Exact::Crane(c.params(), trajectory::<f64, 2>(scene)?)
            }
            ModelSpec::MassOnCar(m) => Exact::MassOnCar(
                MassOnCarReference::new(
                    m.params(),
                    trajectory::<f64, 1>(scene)?,
                    0.0,
                    Dopri5Settings::default(),
                )
                .map_err(|e| scene.field_of(e))?,
            ),
            ModelSpec::Crane3dSubs(c) => Exact::Crane3d(c.params(), trajectory::<f64, 3>(scene)?),
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

/// What is done with the firmware's inverse model for a scene (the host's run of the
/// firmware, the virtual ECU), whatever its types.
pub trait FirmwareVisitor {
    /// What it gives.
    type Output;
    /// Does it with `feedforward`: the scene's model on the firmware's plan, advanced by
    /// the integrator the firmware links.
    fn visit<F: Feedforward + Replan>(self, feedforward: F) -> Self::Output;
}

/// The integrator the firmware links for a scene: the model, the scheme and the Newton
/// strategy, a type, so the firmware links only the one its scene names. For the crane
/// *subs* model BDF with the exact Jacobian and RADAU5's transformed Newton (its real and
/// complex systems) take the structured elimination; everything else dense LUs. BDF's
/// closed-form start is corrected below `CORRECT_BELOW_H` (5 ms) only: from there on
/// the firmware does not link the correction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FirmwareScheme {
    /// *subs*, BDF k, the structured elimination (h below 5 ms: with the closed form's
    /// correction).
    SubsStructuredBdf(usize),
    /// *subs*, BDF k, the structured elimination, h from 5 ms on: the same steps, the
    /// correction not linked.
    SubsStructuredBdfUncorrected(usize),
    /// *subs*, BDF k, the run-time modes on a dense LU.
    SubsBdf(usize),
    /// *subs*, RADAU5, both stage systems by the structured elimination.
    SubsStructuredRadau5,
    /// *subs*, Radau IIA with the paper's modes on the 3N×3N system.
    SubsRadauFull,
    /// *proj*, BDF k, dense LU.
    ProjBdf(usize),
    /// *proj*, RADAU5 on dense LUs.
    ProjRadau5,
    /// *proj*, Radau IIA with the paper's modes on the 3N×3N system.
    ProjRadauFull,
}

impl FirmwareScheme {
    /// The firmware's integrator for `scene`, or why the firmware cannot run it (the
    /// firmware drives a crane, in f64).
    pub fn of(scene: &Scene) -> Result<Self, String> {
        if scene.solver.scalar != ScalarSpec::F64 {
            return Err("the firmware plans moves in f64; this scene computes in f32".into());
        }
        let s = &scene.solver;
        let transformed = s.newton == NewtonSpec::Transformed;
        Ok(match (&scene.model, s.scheme) {
            (ModelSpec::CraneSubs(_), SchemeSpec::Bdf)
                if s.jacobian == JacobianSpec::Exact && !transformed =>
            {
                if s.h >= CORRECT_BELOW_H {
                    Self::SubsStructuredBdfUncorrected(s.k)
                } else {
                    Self::SubsStructuredBdf(s.k)
                }
            }
            (ModelSpec::CraneSubs(_), SchemeSpec::Bdf) => Self::SubsBdf(s.k),
            (ModelSpec::CraneSubs(_), SchemeSpec::Radau) if transformed => {
                Self::SubsStructuredRadau5
            }
            (ModelSpec::CraneSubs(_), SchemeSpec::Radau) => Self::SubsRadauFull,
            (ModelSpec::CraneProj(_), SchemeSpec::Bdf) => Self::ProjBdf(s.k),
            (ModelSpec::CraneProj(_), SchemeSpec::Radau) if transformed => Self::ProjRadau5,
            (ModelSpec::CraneProj(_), SchemeSpec::Radau) => Self::ProjRadauFull,
            (ModelSpec::MassOnCar(_), _) => {
                return Err("the firmware drives a crane; this scene is the mass-on-car".into())
            }
            (ModelSpec::Crane3dSubs(_), _) => {
                return Err(
                    "the firmware drives the planar crane; its controller for three axes is not built yet (issue 19)".into(),
                )
            }
        })
    }

    /// Whether the Newton systems are solved by the model's structured elimination.
    #[must_use]
    pub fn structured(self) -> bool {
        matches!(
            self,
            Self::SubsStructuredBdf(_)
                | Self::SubsStructuredBdfUncorrected(_)
                | Self::SubsStructuredRadau5
        )
    }

    /// The model's type and the integrator's type on the firmware's plan, and the
    /// expression that builds the integrator (`model` and `SETTINGS` in scope): what the
    /// firmware's build script writes.
    #[must_use]
    pub fn rust(self) -> FirmwareTypes {
        const PLAN: &str = "solver_core::plan::Plan<f64, 2>";
        let (module, model, alias, k) = match self {
            Self::SubsStructuredBdf(k) => ("crane_subs", "CraneSubs", "StructuredBdf", Some(k)),
            Self::SubsStructuredBdfUncorrected(k) => (
                "crane_subs",
                "CraneSubs",
                "StructuredBdfUncorrected",
                Some(k),
            ),
            Self::SubsBdf(k) => ("crane_subs", "CraneSubs", "Bdf", Some(k)),
            Self::SubsStructuredRadau5 => ("crane_subs", "CraneSubs", "StructuredRadau5", None),
            Self::SubsRadauFull => ("crane_subs", "CraneSubs", "RadauFull", None),
            Self::ProjBdf(k) => ("crane_proj", "CraneProj", "Bdf", Some(k)),
            Self::ProjRadau5 => ("crane_proj", "CraneProj", "Radau5", None),
            Self::ProjRadauFull => ("crane_proj", "CraneProj", "RadauFull", None),
        };
        let path = format!("solver_core::models::{module}");
        FirmwareTypes {
            model: format!("{path}::{model}<f64, {PLAN}>"),
            integrator: format!("{path}::{alias}<f64, {PLAN}>"),
            unknowns: format!("{path}::N"),
            new: match k {
                Some(k) => format!("Integrator::new(&model, &SETTINGS, {k}, 0.0)"),
                None => "Integrator::new(&model, &SETTINGS, 0.0)".into(),
            },
            scheme: match k {
                Some(k) => format!("BDF{k}"),
                None => "Radau IIA".into(),
            },
        }
    }

    /// The firmware's inverse model for a crane with `params` on `plan`, at rest at
    /// t = 0, handed to `visitor`: the same types [`FirmwareScheme::rust`] names.
    pub fn visit<V: FirmwareVisitor>(
        self,
        params: CraneParams,
        plan: Plan<f64, 2>,
        settings: &SolverSettings,
        visitor: V,
    ) -> Result<V::Output, Error> {
        type P = Plan<f64, 2>;
        Ok(match self {
            Self::SubsStructuredBdf(k) => {
                let model = CraneSubs::new(params, plan)?;
                let i = crane_subs::StructuredBdf::<f64, P>::new(&model, settings, k, 0.0)?;
                visit(visitor, model, i)
            }
            Self::SubsStructuredBdfUncorrected(k) => {
                let model = CraneSubs::new(params, plan)?;
                let i =
                    crane_subs::StructuredBdfUncorrected::<f64, P>::new(&model, settings, k, 0.0)?;
                visit(visitor, model, i)
            }
            Self::SubsBdf(k) => {
                let model = CraneSubs::new(params, plan)?;
                let i = crane_subs::Bdf::<f64, P>::new(&model, settings, k, 0.0)?;
                visit(visitor, model, i)
            }
            Self::SubsStructuredRadau5 => {
                let model = CraneSubs::new(params, plan)?;
                let i = crane_subs::StructuredRadau5::<f64, P>::new(&model, settings, 0.0)?;
                visit(visitor, model, i)
            }
            Self::SubsRadauFull => {
                let model = CraneSubs::new(params, plan)?;
                let i = crane_subs::RadauFull::<f64, P>::new(&model, settings, 0.0)?;
                visit(visitor, model, i)
            }
            Self::ProjBdf(k) => {
                let model = CraneProj::new(params, plan)?;
                let i = crane_proj::Bdf::<f64, P>::new(&model, settings, k, 0.0)?;
                visit(visitor, model, i)
            }
            Self::ProjRadau5 => {
                let model = CraneProj::new(params, plan)?;
                let i = crane_proj::Radau5::<f64, P>::new(&model, settings, 0.0)?;
                visit(visitor, model, i)
            }
            Self::ProjRadauFull => {
                let model = CraneProj::new(params, plan)?;
                let i = crane_proj::RadauFull::<f64, P>::new(&model, settings, 0.0)?;
                visit(visitor, model, i)
            }
        })
    }
}

/// `model` and `integrator` as the controller's inverse model, to `visitor`.
fn visit<V, M, I, const N: usize>(visitor: V, model: M, integrator: I) -> V::Output
where
    V: FirmwareVisitor,
    M: CraneReference + DaeModel<f64, N, 2> + Driven<Trajectory = Plan<f64, 2>>,
    I: Integrator<f64, M, N, 2>,
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
            "mass-on-car" => ("[0.0]", "[1.0]"),
            "crane3d-subs" => ("[12.0, 3.0, 8.0]", "[20.0, 6.0, 4.0]"),
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
        ] {
            let (ty, unknowns) = model::<f64, _>(&scene(kind, "scheme = \"bdf\""), Name).unwrap();
            assert!(ty.contains(name), "{ty}");
            assert_eq!(unknowns, n, "{kind}");
        }
    }

    #[test]
    fn the_firmware_names_the_types_it_builds() {
        for (kind, solver, expected) in [
            (
                "crane-subs",
                "scheme = \"bdf\"\njacobian = \"exact\"",
                FirmwareScheme::SubsStructuredBdfUncorrected(4),
            ),
            (
                "crane-subs",
                "scheme = \"bdf\"\njacobian = \"fd\"",
                FirmwareScheme::SubsBdf(4),
            ),
            (
                "crane-subs",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                FirmwareScheme::SubsStructuredRadau5,
            ),
            (
                "crane-subs",
                "scheme = \"radau\"\njacobian = \"exact\"",
                FirmwareScheme::SubsRadauFull,
            ),
            (
                "crane-proj",
                "scheme = \"bdf\"\njacobian = \"exact\"",
                FirmwareScheme::ProjBdf(4),
            ),
            (
                "crane-proj",
                "scheme = \"radau\"\njacobian = \"exact\"\nnewton = \"transformed\"",
                FirmwareScheme::ProjRadau5,
            ),
            (
                "crane-proj",
                "scheme = \"radau\"\njacobian = \"fd\"",
                FirmwareScheme::ProjRadauFull,
            ),
        ] {
            let s = scene(kind, solver);
            let f = FirmwareScheme::of(&s).unwrap();
            assert_eq!(f, expected, "{kind} {solver}");
            let rust = f.rust();
            assert_eq!(rust.integrator.contains("Structured"), f.structured());
            assert!(rust.model.contains(if kind == "crane-subs" {
                "CraneSubs"
            } else {
                "CraneProj"
            }));
        }
        // Below 5 ms BDF's closed form is corrected, and the firmware links the correction.
        for (h, expected) in [
            (0.002, FirmwareScheme::SubsStructuredBdf(4)),
            (0.005, FirmwareScheme::SubsStructuredBdfUncorrected(4)),
        ] {
            let mut s = scene("crane-subs", "scheme = \"bdf\"");
            s.solver.h = h;
            assert_eq!(FirmwareScheme::of(&s).unwrap(), expected, "h = {h}");
        }
        assert!(FirmwareScheme::of(&scene("mass-on-car", "scheme = \"bdf\"")).is_err());
        assert!(FirmwareScheme::of(&scene("crane3d-subs", "scheme = \"bdf\"")).is_err());
    }
}
