//! The cranes the virtual bus can simulate, keyed on the crane type as the controller is
//! ([`controller::crane::Crane`]): which plant a scenario with a plant runs on, built
//! from the crane's own parameters, and how the plant's sensed state reaches the drives'
//! position actual and the inclinometer. The bus never decides by its drive list which
//! crane it carries.

use controller::crane::Crane;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::Crane3dParams;
use solver_core::models::double_pendulum_crane::DoublePendulumParams;

use crate::plant::{Mismatch, Plant};
use crate::plant3d::{Mismatch3d, Plant3d};
use crate::plant_dp::PlantDp;

/// What a plant's sensors read at the end of a cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensed<const A: usize> {
    /// Each drive's position and velocity, m and m/s, in the model's input order: its
    /// drive's position and velocity actual.
    pub motion: [(f64, f64); A],
    /// The inclinometer's slopes, degrees: long (x–z plane) and lateral (y–z plane; 0
    /// for a one-axis inclinometer).
    pub slope_deg: [f64; 2],
}

/// A plant's true state, without its sensors' noise, filter or delay: what a view draws
/// and a test judges the crane by. Each in the slots `[x, y, z]` of the operator frame
/// (a planar crane's y is 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrueState {
    /// Where the drives stand: bridge (planar: trolley) x, trolley y, the drum's rope
    /// length, m.
    pub drives: [f64; 3],
    /// The load `[x_C, y_C, z_C]`, m, `z_C` its depth below the rope's exit.
    pub load: [f64; 3],
    /// The rope's slopes in the x–z and y–z planes, rad (the swing; the hook-and-load
    /// crane's: the hoist rope's, where its inclinometer sits).
    pub swing: [f64; 2],
}

/// A simulated crane that the drives move.
pub trait CranePlant<const A: usize> {
    /// Advances `dt` with each drive's velocity command `u` (m/s), the drives in
    /// `braked` held by their brakes.
    fn advance_braked(&mut self, u: [f64; A], dt: f64, braked: [bool; A]);
    /// What its sensors read now, with their noise, filter and delay.
    fn sense(&mut self) -> Sensed<A>;
    /// Its true state now.
    fn true_state(&self) -> TrueState;
}

/// A crane the virtual bus simulates in scenarios with a plant.
pub trait Simulated<const A: usize>: Crane<A> + Copy + core::fmt::Debug {
    /// Its plant.
    type Plant: CranePlant<A> + Clone + core::fmt::Debug;
    /// The plant of this crane with the scenario's `mismatch`, at rest with the drives
    /// at `start` (model input order).
    fn plant(&self, mismatch: Mismatch, start: [f64; A]) -> Self::Plant;
}

impl CranePlant<2> for Plant {
    fn advance_braked(&mut self, u: [f64; 2], dt: f64, braked: [bool; 2]) {
        Plant::advance_braked(self, u, dt, braked);
    }
    fn sense(&mut self) -> Sensed<2> {
        let [x, l, phi] = Plant::sense(self);
        let [_, _, _, vx, vl, _] = self.y;
        Sensed {
            motion: [(x, vx), (l, vl)],
            slope_deg: [phi.to_degrees(), 0.0],
        }
    }
    fn true_state(&self) -> TrueState {
        let [x, l, phi, ..] = self.y;
        let [x_c, z_c] = self.load();
        TrueState {
            drives: [x, 0.0, l],
            load: [x_c, 0.0, z_c],
            swing: [phi, 0.0],
        }
    }
}

/// The planar crane: its plant with the one-axis inclinometer.
impl Simulated<2> for CraneParams {
    type Plant = Plant;
    fn plant(&self, mismatch: Mismatch, [x, l]: [f64; 2]) -> Plant {
        Plant::at_rest(x, l, 0.0, [self.tau1, self.tau2], self.g, self.m, mismatch)
    }
}

impl CranePlant<3> for Plant3d {
    fn advance_braked(&mut self, u: [f64; 3], dt: f64, braked: [bool; 3]) {
        Plant3d::advance_braked(self, u, dt, braked);
    }
    fn sense(&mut self) -> Sensed<3> {
        let [x, y, l, long, lateral] = Plant3d::sense(self);
        let [_, _, _, _, _, vx, vy, vl, _, _] = self.q;
        Sensed {
            motion: [(x, vx), (y, vy), (l, vl)],
            slope_deg: [long.to_degrees(), lateral.to_degrees()],
        }
    }
    fn true_state(&self) -> TrueState {
        let [x, y, l, ..] = self.q;
        TrueState {
            drives: [x, y, l],
            load: self.load(),
            swing: self.slopes(),
        }
    }
}

/// The 3D crane with the two-axis inclinometer. The planar scenario's mismatch on bridge
/// and hoist, its gust and its swinging start at 45°, so that both vertical planes
/// swing.
impl Simulated<3> for Crane3dParams {
    type Plant = Plant3d;
    fn plant(&self, mismatch: Mismatch, [x, y, l]: [f64; 3]) -> Plant3d {
        let planar = Mismatch3d::from_planar(&mismatch);
        let [s, _] = planar.swing0;
        let diagonal = Mismatch3d {
            gust_direction: core::f64::consts::FRAC_PI_4,
            swing0: [s, s].map(|a| libm::atan(libm::tan(a) * core::f64::consts::FRAC_1_SQRT_2)),
            ..planar
        };
        Plant3d::at_rest(
            x,
            y,
            l,
            0.0,
            [self.tau1, self.tau2, self.tau3],
            self.g,
            self.m,
            diagonal,
        )
    }
}

impl CranePlant<2> for PlantDp {
    fn advance_braked(&mut self, u: [f64; 2], dt: f64, braked: [bool; 2]) {
        PlantDp::advance_braked(self, u, dt, braked);
    }
    fn sense(&mut self) -> Sensed<2> {
        let [x, l, phi1] = PlantDp::sense(self);
        let [_, _, _, _, vx, vl, _, _] = self.y;
        Sensed {
            motion: [(x, vx), (l, vl)],
            slope_deg: [phi1.to_degrees(), 0.0],
        }
    }
    fn true_state(&self) -> TrueState {
        let [x, l, phi1, ..] = self.y;
        let [x_c, z_c] = self.load();
        TrueState {
            drives: [x, 0.0, l],
            load: [x_c, 0.0, z_c],
            swing: [phi1, 0.0],
        }
    }
}

/// The hook-and-load crane: its double pendulum with the one-axis inclinometer on the
/// hook block. `start` is where the drives stand: at rest the rope is the sling's length
/// shorter than the load is deep.
impl Simulated<2> for DoublePendulumParams {
    type Plant = PlantDp;
    fn plant(&self, mismatch: Mismatch, start: [f64; 2]) -> PlantDp {
        PlantDp::at_rest(*self, start, mismatch)
    }
}
