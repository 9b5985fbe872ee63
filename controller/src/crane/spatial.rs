//! The 3D crane: bridge x, trolley y and rope length l, its load swinging in both
//! vertical planes. Everything the controller knows of it: the [`Crane`] impl and the
//! reference state of each of its inverse models (*subs*, *ext*).

use solver_core::models::crane3d::{Crane3dExt, Crane3dParams, Crane3dSubs};
use solver_core::operator::Generator3d;
use solver_core::plan::Plan;
use solver_core::reference::flat_crane3d;
use solver_core::trajectory::Trajectory;
use solver_core::{Driven, Real};

use super::{AxisReasons, Crane, Flat};
use crate::drive::{self, Drive};
use crate::feedback::Reference;
use crate::feedforward::CraneReference;
use crate::operator::path::Steered;
use crate::setpoint::{AxisLimits, DriveLimits};

impl Crane<3> for Crane3dParams {
    const NAME: &'static str = "3D crane";
    const DRIVES: [Drive; 3] = drive::SPATIAL;
    const REASONS: [AxisReasons; 3] = [
        AxisReasons::BRIDGE,
        AxisReasons::TROLLEY,
        AxisReasons::WINCH,
    ];
    const LAB_LIMITS: [AxisLimits; 3] = DriveLimits::LAB_3D;
    const SWING_AXES: u8 = 2;
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
        self.g
    }
    fn ranges(&self) -> [(f64, f64); 3] {
        let w = &self.workspace;
        [(w.x_min, w.x_max), (w.y_min, w.y_max), (w.l_min, w.l_max)]
    }
    /// A planar command moves the load in the x–z plane it hangs in: y stays.
    fn target(x: f64, y: Option<f64>, z: f64, [_, y_end, _]: [f64; 3]) -> Option<[f64; 3]> {
        Some([x, y.unwrap_or(y_end), z])
    }
    fn flat<Z: Trajectory<f64, 3>>(&self, z: &Z, t: f64) -> Flat<3> {
        let f = flat_crane3d::flat_inverse(self, z, t);
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
        [self.tau1, self.tau2, self.tau3]
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
impl<T: Real> CraneReference for Crane3dSubs<T, Plan<f64, 3>> {
    type Reference = [Reference; 2];
    fn reference(&self, y: &[f64], t: f64) -> [Reference; 2] {
        planes(y, self.trajectory(), t)
    }
}

/// *subs* driven by the plan or, in manual mode, the operator's generator
/// ([`Steered`]): the same reference from the path it follows.
impl<T: Real> CraneReference for Crane3dSubs<T, Steered<Generator3d, 3>> {
    type Reference = [Reference; 2];
    fn reference(&self, y: &[f64], t: f64) -> [Reference; 2] {
        planes(y, self.trajectory(), t)
    }
}

/// *ext*: its first ten unknowns are the 3D *subs*' in its order, so the reference of
/// each vertical plane is *subs*'.
impl<T: Real> CraneReference for Crane3dExt<T, Plan<f64, 3>> {
    type Reference = [Reference; 2];
    fn reference(&self, y: &[f64], t: f64) -> [Reference; 2] {
        planes(y, self.trajectory(), t)
    }
}
