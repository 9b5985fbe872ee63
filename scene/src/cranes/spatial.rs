//! The crane in three dimensions (bridge, trolley and hoist), everything it is in one
//! file: what the controller knows of it ([`Crane`]: drives, limits, reference per
//! vertical plane, flat inverse) and the reference of each of its inverse models, the
//! plant the virtual bus runs for it ([`Simulated`]), and — on the host — its
//! formulations and its [`FirmwareCrane`](super::FirmwareCrane) registration, with its
//! state feedback per vertical plane (`controller::feedback3d::SpatialFeedback`) on a
//! two-axis inclinometer.

use controller::crane::{AxisReasons, Crane, Flat};
use controller::drive::{self, Drive};
use controller::feedback::Reference;
use controller::feedforward::CraneReference;
use controller::operator::path::Steered;
use controller::setpoint::{AxisLimits, DriveLimits};
#[cfg(feature = "sim")]
use sim::mismatch::Mismatch;
#[cfg(feature = "sim")]
use sim::plant3d::Mismatch3d;
#[cfg(feature = "sim")]
use sim::plant3d::Plant3d;
#[cfg(feature = "sim")]
use sim::simulated::Simulated;
use solver_core::models::crane3d::{Crane3dExt, Crane3dParams, Crane3dSubs};
use solver_core::operator::Generator3d;
use solver_core::plan::Plan;
use solver_core::reference::flat_crane3d;
use solver_core::trajectory::Trajectory;
use solver_core::{Driven, Real};

#[cfg(feature = "host")]
pub use host::*;

crane_type! {
    /// The 3D crane with its parameters: the type the controller, the virtual bus and the
    /// registry know it by.
    Spatial(Crane3dParams), 3
}

impl Spatial {
    /// The assumed EOT crane of the 3D scenes (`Crane3dParams::EXAMPLE`).
    pub const EXAMPLE: Self = Self(Crane3dParams::EXAMPLE);
}

impl Crane<3> for Spatial {
    const NAME: &'static str = "3D crane";
    const DRIVES: [Drive; 3] = drive::SPATIAL;
    const REASONS: [AxisReasons; 3] = [
        AxisReasons::BRIDGE,
        AxisReasons::TROLLEY,
        AxisReasons::WINCH,
    ];
    const LAB_LIMITS: [AxisLimits; 3] = DriveLimits::LAB_3D;
    const SWING_AXES: u8 = 2;
    const HORIZONTAL_AXES: u8 = 2;
    /// As the planar crane's: its inputs contain the load path's fourth derivatives
    /// (the flat inverse, `solver_core::reference::flat_crane3d`), its accelerations the
    /// fifth.
    const MIN_COMMAND_SMOOTHNESS: usize = 5;
    /// The reference of each vertical plane, x–z then y–z, as the planar crane's in
    /// that plane.
    type Reference = [Reference; 2];
    /// The bridge from the x–z plane, the trolley from the y–z plane (each plane's `x` is
    /// its horizontal drive), the rope from either (the x–z plane's).
    fn drive_states([xz, yz]: &[Reference; 2]) -> [(f64, f64); 3] {
        [(xz.x, xz.vx), (yz.x, yz.vx), (xz.l, xz.vl)]
    }
    fn g(&self) -> f64 {
        self.0.g
    }
    fn ranges(&self) -> [(f64, f64); 3] {
        let w = &self.0.workspace;
        [(w.x_min, w.x_max), (w.y_min, w.y_max), (w.l_min, w.l_max)]
    }
    /// A planar command moves the load in the x–z plane it hangs in: y stays.
    fn target(x: f64, y: Option<f64>, z: f64, [_, y_end, _]: [f64; 3]) -> Option<[f64; 3]> {
        Some([x, y.unwrap_or(y_end), z])
    }
    fn flat<Z: Trajectory<f64, 3>>(&self, z: &Z, t: f64) -> Flat<3> {
        let f = flat_crane3d::flat_inverse(&self.0, z, t);
        Flat {
            position: [f.x, f.y, f.l],
            u: f.u,
            u_dot: f.u_dot,
        }
    }
    fn drives_at_rest(&self, load: [f64; 3]) -> [f64; 3] {
        load
    }
    fn load_at_rest(&self, drives: [f64; 3]) -> [f64; 3] {
        drives
    }
    fn lags(&self) -> [f64; 3] {
        [self.0.tau1, self.0.tau2, self.0.tau3]
    }
}

/// The reference of each vertical plane from the 3D *subs* unknowns
/// `y = [x, y, l, ẋ, ẏ, l̇, …]` and the load's desired path: the drive's position, the
/// rope, the rope's slope in the plane (what a two-axis inclinometer reports,
/// `solver_core::reference::flat_crane3d::FlatState3d::slope`) and the rates.
fn planes<Z: Trajectory<f64, 3>>(y: &[f64], path: &Z, t: f64) -> [Reference; 2] {
    let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
    let [p, v] = path.derivatives::<2>(t);
    let [xc, yc, zc]: [f64; 3] = p.into();
    let [vxc, vyc, vzc]: [f64; 3] = v.into();
    let (l, vl) = (at(2), at(5));
    [
        Reference::from_subs([at(0), l, at(3), vl], [xc, zc], [vxc, vzc]),
        Reference::from_subs([at(1), l, at(4), vl], [yc, zc], [vyc, vzc]),
    ]
}

/// *subs*, `y = [x, y, l, ẋ, ẏ, l̇, λ, u1, u2, u3]`.
impl<T: Real> CraneReference<Spatial, 3> for Crane3dSubs<T, Plan<f64, 3>> {
    fn reference(&self, y: &[f64], t: f64) -> [Reference; 2] {
        planes(y, self.trajectory(), t)
    }
}

/// *subs* driven by the plan or, in manual mode, the operator's generator
/// ([`Steered`]): the same reference from the path it follows.
impl<T: Real> CraneReference<Spatial, 3> for Crane3dSubs<T, Steered<Generator3d, 3>> {
    fn reference(&self, y: &[f64], t: f64) -> [Reference; 2] {
        planes(y, self.trajectory(), t)
    }
}

/// *ext*: its first ten unknowns are the 3D *subs*' in its order, so the reference of
/// each vertical plane is *subs*'.
impl<T: Real> CraneReference<Spatial, 3> for Crane3dExt<T, Plan<f64, 3>> {
    fn reference(&self, y: &[f64], t: f64) -> [Reference; 2] {
        planes(y, self.trajectory(), t)
    }
}

/// The 3D crane with the two-axis inclinometer. The planar scenario's mismatch on bridge
/// and hoist, its gust and its swinging start at 45°, so that both vertical planes
/// swing.
#[cfg(feature = "sim")]
impl Simulated<3> for Spatial {
    type Plant = Plant3d;
    fn plant(&self, mismatch: Mismatch, [x, y, l]: [f64; 3]) -> Plant3d {
        let p = &self.0;
        let planar = Mismatch3d::from_planar(&mismatch);
        let [s, _] = planar.swing0;
        let diagonal = Mismatch3d {
            gust_direction: core::f64::consts::FRAC_PI_4,
            swing0: [s, s].map(|a| libm::atan(libm::tan(a) * core::f64::consts::FRAC_1_SQRT_2)),
            ..planar
        };
        Plant3d::at_rest(x, y, l, 0.0, [p.tau1, p.tau2, p.tau3], p.g, p.m, diagonal)
    }
}

/// Its formulations and its registration: the host's (the build scripts, the studies,
/// the virtual ECU).
#[cfg(feature = "host")]
mod host {
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

    use super::Spatial;
    use crate::cranes::{
        crane_models, integrators, visit, CraneModel, FirmwareCrane, FirmwareError,
        FirmwareIntegrator, FirmwareVisitor,
    };
    use crate::family::{ExactInputs, Flat, ModelFamily};
    use crate::operator::only_subs;
    use crate::rust_source::struct_to_rust;
    use crate::{ModelSpec, OperatorSpec, SceneError};

    crane_models! {
        /// The 3D crane's formulations the firmware can drive.
        SpatialModel for Spatial, 3 {
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
        } = "solver_core::models::crane3d::Crane3dParams"
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

    impl FirmwareCrane<3> for Spatial {
        const TYPE: &'static str = Spatial::PATH;
        const QEMU_SCENES: &'static [&'static str] = &[
            "scenes/crane3d/crane3d.toml",
            "scenes/crane3d/crane3d-radau5.toml",
            "scenes/crane3d/crane3d-ext.toml",
        ];
        type Model = SpatialModel;
        type Feedback = SpatialFeedback;
        const FEEDBACK_TYPE: &'static str = "controller::feedback3d::SpatialFeedback";
        const FEEDBACK_NEW: &'static str = "Correction::new(FEEDBACK, PARAMS.0.tau2)";
        type FeedforwardOnly = NoFeedback;
        fn of(model: &ModelSpec) -> Option<(Self, SpatialModel)> {
            match model {
                ModelSpec::Crane3dSubs(c) => Some((Spatial(c.params()), SpatialModel::Subs)),
                ModelSpec::Crane3dExt(c) => Some((Spatial(c.params()), SpatialModel::Ext)),
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
            let crane = &crane.0;
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
            SpatialFeedback::new(config, self.0.tau2)
        }
        type Operator = Settings<2>;
        const OPERATOR_TYPE: &'static str = "solver_core::operator::Settings<2>";
        const STEERED_TYPE: &'static str =
            "controller::operator::path::Steered<solver_core::operator::Generator3d, 3>";
        /// *subs* only: only it has the controller's reference on the generator's path
        /// (its `CraneReference` on `Steered`, above).
        fn manual_mode(model: SpatialModel) -> bool {
            model == SpatialModel::Subs
        }
        /// The lab's settings with the scene's keys: bridge and trolley range over the
        /// workspace box, the hoist over the depths the rope's range allows.
        fn operator_settings(
            spec: &OperatorSpec,
            crane: &Self,
            model: SpatialModel,
            h: f64,
        ) -> Result<Settings<2>, SceneError> {
            if !Self::manual_mode(model) {
                return Err(only_subs("3D crane", "crane3d-subs", model));
            }
            let w = crane.0.workspace;
            spec.settings(
                Settings::lab_3d(&crane.0),
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
                solver_core::models::crane3d::Crane3dSubs::new(self.0, P::new(plan, operator))?,
                settings,
                visitor,
                P
            ))
        }
    }
}
