//! The paper's planar crane (Eq. 24): trolley x and rope length l, its load swinging in
//! the x–z plane. Everything the controller knows of it: the [`Crane`] impl and the
//! reference state of each of its inverse models (*subs*, *proj*, *ext*).

use solver_core::models::crane::CraneParams;
use solver_core::models::crane_ext::CraneExt;
use solver_core::models::crane_proj::CraneProj;
use solver_core::models::crane_subs::CraneSubs;
use solver_core::operator::PlanarGenerator;
use solver_core::plan::Plan;
use solver_core::reference::flat_crane;
use solver_core::trajectory::Trajectory;
use solver_core::{Driven, Real};

use super::{AxisReasons, Crane, Flat};
use crate::drive::{self, Drive};
use crate::feedback::Reference;
use crate::feedforward::CraneReference;
use crate::operator::path::Steered;
use crate::setpoint::{AxisLimits, DriveLimits};

impl Crane<2> for CraneParams {
    const NAME: &'static str = "planar crane";
    const DRIVES: [Drive; 2] = drive::PLANAR;
    const REASONS: [AxisReasons; 2] = [AxisReasons::TROLLEY, AxisReasons::WINCH];
    const LAB_LIMITS: [AxisLimits; 2] = DriveLimits::LAB.axes();
    const SWING_AXES: u8 = 1;
    /// The inputs contain `z⁗` (Eqs. 27–28), so the drives' accelerations `u̇` contain
    /// `z⁽⁵⁾`. With the paper's n = 4 the fifth derivative jumps at a move's ends: BDF4
    /// overshoots the planned peak acceleration by 9.7 %, BDF6 by a factor of up to
    /// 3.3. With n ≥ 5 the accelerations are continuous and the computed ones stay
    /// within 0.5 % of the exact ones (`cargo test -p controller --test smoothness`).
    const MIN_COMMAND_SMOOTHNESS: usize = 5;
    type Reference = Reference;
    fn drive_states(r: &Reference) -> [(f64, f64); 2] {
        [(r.x, r.vx), (r.l, r.vl)]
    }
    fn g(&self) -> f64 {
        self.g
    }
    fn ranges(&self) -> [(f64, f64); 2] {
        let w = &self.workspace;
        [(w.x_min, w.x_max), (w.l_min, w.l_max)]
    }
    fn target(x: f64, y: Option<f64>, z: f64, _end: [f64; 2]) -> Option<[f64; 2]> {
        y.is_none().then_some([x, z])
    }
    fn flat<Z: Trajectory<f64, 2>>(&self, z: &Z, t: f64) -> Flat<2> {
        let f = flat_crane::flat_inverse(self, z, t);
        Flat {
            position: [f.x, f.l],
            u: f.u,
            u_dot: f.u_dot,
        }
    }
    fn drives_at_rest(&self, load: [f64; 2]) -> [f64; 2] {
        load
    }
    fn load_at_rest(&self, drives: [f64; 2]) -> [f64; 2] {
        drives
    }
    fn lags(&self) -> [f64; 2] {
        [self.tau1, self.tau2]
    }
}

/// The reference from *subs*' first unknowns `y = [x, l, ẋ, l̇, …]` and the load's
/// desired `path`: the angle and its rate from the desired load position and velocity
/// (Eqs. 27–28).
fn from_subs_unknowns<Z: Trajectory<f64, 2>>(y: &[f64], path: &Z, t: f64) -> Reference {
    let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
    let [p, v] = path.derivatives::<2>(t);
    Reference::from_subs([at(0), at(1), at(2), at(3)], p.into(), v.into())
}

/// *subs*: `y = [x, l, ẋ, l̇, λ, u1, u2]`.
impl<T: Real> CraneReference for CraneSubs<T, Plan<f64, 2>> {
    type Reference = Reference;
    fn reference(&self, y: &[f64], t: f64) -> Reference {
        from_subs_unknowns(y, self.trajectory(), t)
    }
}

/// *subs* driven by the plan or, in manual mode, the operator's generator
/// ([`Steered`]): the same reference from the path it follows.
impl<T: Real> CraneReference for CraneSubs<T, Steered<PlanarGenerator, 2>> {
    type Reference = Reference;
    fn reference(&self, y: &[f64], t: f64) -> Reference {
        from_subs_unknowns(y, self.trajectory(), t)
    }
}

/// *proj*: `y = [x, l, φ, ẋ, l̇, φ̇, u1, u2]` holds the reference as it is.
impl<T: Real> CraneReference for CraneProj<T, Plan<f64, 2>> {
    type Reference = Reference;
    fn reference(&self, y: &[f64], _t: f64) -> Reference {
        let at = |i: usize| y.get(i).copied().unwrap_or(0.0);
        Reference {
            x: at(0),
            l: at(1),
            phi: at(2),
            vx: at(3),
            vl: at(4),
            vphi: at(5),
        }
    }
}

/// *ext* (*subs* minimally extended to index 1): its first unknowns are *subs*'
/// `[x, l, ẋ, l̇, …]` in *subs*' order, so the reference is *subs*'.
impl<T: Real> CraneReference for CraneExt<T, Plan<f64, 2>> {
    type Reference = Reference;
    fn reference(&self, y: &[f64], t: f64) -> Reference {
        from_subs_unknowns(y, self.trajectory(), t)
    }
}
