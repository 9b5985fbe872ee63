//! What the keyboard view needs of a crane beyond what the firmware's setup of a scene
//! gives: the operator generator its inverse model is driven by in manual mode, that
//! model built on a [`Steered`] path, and what its simulated plant shows on the screen.
//! The planar and the 3D crane, each with its *subs* formulation (the two formulations
//! whose manual mode the controller's tests prove, `controller/tests/operator*.rs`).

use controller::operator::path::{Source, Steered};
use controller::{Feedforward, InverseModel, Replan};
use scene::dispatch::FirmwareCrane;
use sim::plant::Plant;
use sim::plant3d::Plant3d;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::{subs as crane3d, Crane3dParams, Crane3dSubs};
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::operator::{Generator3d, PlanarGenerator, Settings};
use solver_core::schemes::Scheme;
use solver_core::{Error, SolverSettings};

/// The plant's true state as drawn, in the slots `[x, y, z]` of the operator frame (the
/// planar crane's y is 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantState {
    /// Where the drives stand: bridge (planar: trolley) x, trolley y, the drum's rope
    /// length, m.
    pub drives: [f64; 3],
    /// The load `[x_C, y_C, z_C]`, m, `z_C` its depth below the rope's exit.
    pub load: [f64; 3],
    /// The rope's slopes in the x–z and y–z planes, rad (the swing).
    pub swing: [f64; 2],
}

/// A crane the keyboard view can drive by hand: `A` driven axes, as the firmware's setup
/// of a scene makes it a type ([`FirmwareCrane`]).
pub trait ManualCrane<const A: usize>: FirmwareCrane<A> + 'static
where
    Self::Feedback: 'static,
    Self::FeedforwardOnly: 'static,
{
    /// The operator generator that turns its stick into a load path.
    type Generator: Source<A>;
    /// The inverse model on the plan-or-generator path.
    type Feedforward: Feedforward<A, Reference = Self::Reference> + Replan<A> + 'static;
    /// The generator's settings derived from the crane's parameters: the lab's
    /// (`Settings::lab`, `Settings::lab_3d`, docs/OPERATOR.md) with the robust setting
    /// on, since the view's plant is not the model and its pendulum is about 10 % off
    /// (the robust pair keeps the swing after a stop below 0.1° without feedback).
    fn generator_settings(&self) -> <Self::Generator as Source<A>>::Settings;
    /// Its *subs* formulation on `path`, advanced by `scheme`, at rest at t = 0.
    fn feedforward(
        &self,
        path: Steered<Self::Generator, A>,
        scheme: Scheme,
        settings: &SolverSettings,
    ) -> Result<Self::Feedforward, Error>;
    /// What its plant shows.
    fn observe(plant: &Self::Plant) -> PlantState;
}

type PlanarPath = Steered<PlanarGenerator, 2>;
type SpatialPath = Steered<Generator3d, 3>;

impl ManualCrane<2> for CraneParams {
    type Generator = PlanarGenerator;
    type Feedforward = InverseModel<
        CraneSubs<f64, PlanarPath>,
        crane_subs::Chosen<f64, PlanarPath>,
        f64,
        { crane_subs::N },
    >;
    fn generator_settings(&self) -> Settings<1> {
        Settings {
            robust: true,
            ..Settings::lab(self)
        }
    }
    fn feedforward(
        &self,
        path: PlanarPath,
        scheme: Scheme,
        settings: &SolverSettings,
    ) -> Result<Self::Feedforward, Error> {
        let model = CraneSubs::new(*self, path)?;
        let integrator = crane_subs::Chosen::new(&model, scheme, settings, 0.0)?;
        Ok(InverseModel::new(model, integrator))
    }
    fn observe(plant: &Plant) -> PlantState {
        let [x, l, phi, ..] = plant.y;
        let [x_c, z_c] = plant.load();
        PlantState {
            drives: [x, 0.0, l],
            load: [x_c, 0.0, z_c],
            swing: [phi, 0.0],
        }
    }
}

impl ManualCrane<3> for Crane3dParams {
    type Generator = Generator3d;
    type Feedforward = InverseModel<
        Crane3dSubs<f64, SpatialPath>,
        crane3d::Chosen<f64, SpatialPath>,
        f64,
        { crane3d::N },
    >;
    fn generator_settings(&self) -> Settings<2> {
        Settings {
            robust: true,
            ..Settings::lab_3d(self)
        }
    }
    fn feedforward(
        &self,
        path: SpatialPath,
        scheme: Scheme,
        settings: &SolverSettings,
    ) -> Result<Self::Feedforward, Error> {
        let model = Crane3dSubs::new(*self, path)?;
        let integrator = crane3d::Chosen::new(&model, scheme, settings, 0.0)?;
        Ok(InverseModel::new(model, integrator))
    }
    fn observe(plant: &Plant3d) -> PlantState {
        let [x, y, l, ..] = plant.q;
        PlantState {
            drives: [x, y, l],
            load: plant.load(),
            swing: plant.slopes(),
        }
    }
}
