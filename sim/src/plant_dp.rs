//! The hook-and-load crane's plant for the virtual bus: the double pendulum in minimal
//! coordinates (`solver_core::reference::double_pendulum::plant_rhs`: trolley `x` and rope
//! `l` through first-order drives, the rope's angle `φ1` and the sling's `φ2`), with the
//! drives' lags as the plant has them, the load's mass as it is, brakes, and noisy
//! position sensors and a one-axis inclinometer on the hook block (it reads `φ1`, late
//! and filtered as [`crate::angle_sensor`] has it).
//!
//! Of [`Mismatch`] it honours the drives' lag errors (`tau1`, `tau2`), the load's mass
//! (`load_mass`: the hook's ratio to it), the initial swing (`swing0`, both angles), the
//! sensors (`position_noise`, `angle_noise`, `noise_seed`, `inclinometer`). The planar
//! plant's rope offset, drum scaling, friction, gust, P-only loops and loop tuning
//! (`proportional_only`, `loops_for_model_load`) are not modelled here (its
//! drives are the first-order lags of Eq. 24, not force-driven velocity loops): a
//! scenario that needs them runs on the planar crane.

use solver_core::models::double_pendulum_crane::DoublePendulumParams;
use solver_core::reference::double_pendulum::{plant_output, plant_rhs};

use crate::angle_sensor::AngleSensor;
use crate::plant::{Mismatch, Rng, PLANT_STEP};
use crate::simulated::{CranePlant, Sensed, TrueState};

/// The hook-and-load crane's true state `[x, l, φ1, φ2, ẋ, l̇, φ̇1, φ̇2]`.
#[derive(Debug, Clone)]
pub struct PlantDp {
    /// State.
    pub y: [f64; 8],
    /// Time, s.
    pub t: f64,
    /// The plant's parameters: the model's with the mismatch's lags and load mass.
    params: DoublePendulumParams,
    mismatch: Mismatch,
    noise: Rng,
    /// The inclinometer's filter and delay line (the rope's angle).
    sensor: AngleSensor<1>,
}

impl PlantDp {
    /// At rest with the trolley at `x` and the rope `l` long (rail to hook block), the
    /// model's parameters `model` and the plant's `mismatch`.
    #[must_use]
    pub fn at_rest(model: DoublePendulumParams, [x, l]: [f64; 2], mismatch: Mismatch) -> Self {
        let mut params = model;
        params.crane.tau1 *= 1.0 + mismatch.tau1;
        params.crane.tau2 *= 1.0 + mismatch.tau2;
        params.crane.m *= 1.0 + mismatch.load_mass;
        let phi = mismatch.swing0;
        Self {
            y: [x, l, phi, phi, 0.0, 0.0, 0.0, 0.0],
            t: 0.0,
            params,
            mismatch,
            noise: Rng::new(mismatch.noise_seed),
            sensor: AngleSensor::new(mismatch.inclinometer, [phi]),
        }
    }

    /// The state's rate with the drives commanded `u` and those in `braked` held: a
    /// braked drive neither moves nor accelerates, the pendulum swinging under it.
    fn rhs(&self, y: &[f64; 8], u: [f64; 2], braked: [bool; 2]) -> [f64; 8] {
        let mut d: [f64; 8] = plant_rhs(&self.params, &(*y).into(), &u.into()).into();
        for (axis, held) in braked.into_iter().enumerate() {
            if held {
                if let Some(v) = d.get_mut(axis) {
                    *v = 0.0;
                }
                if let Some(a) = d.get_mut(axis + 4) {
                    *a = 0.0;
                }
            }
        }
        d
    }

    /// Integrates over `dt` (RK4 in steps of [`PLANT_STEP`]) with `u` held, the drives
    /// in `braked` held by their brakes.
    pub fn advance_braked(&mut self, u: [f64; 2], dt: f64, braked: [bool; 2]) {
        for (axis, held) in braked.into_iter().enumerate() {
            if held {
                if let Some(v) = self.y.get_mut(axis + 4) {
                    *v = 0.0;
                }
            }
        }
        let n = libm::round(dt / PLANT_STEP).max(1.0) as usize;
        let h = dt / n as f64;
        let add = |a: &[f64; 8], k: &[f64; 8], s: f64| -> [f64; 8] {
            core::array::from_fn(|i| a.get(i).zip(k.get(i)).map_or(0.0, |(a, k)| a + s * k))
        };
        for _ in 0..n {
            let y = self.y;
            let k1 = self.rhs(&y, u, braked);
            let k2 = self.rhs(&add(&y, &k1, h / 2.0), u, braked);
            let k3 = self.rhs(&add(&y, &k2, h / 2.0), u, braked);
            let k4 = self.rhs(&add(&y, &k3, h), u, braked);
            self.y = core::array::from_fn(|i| {
                let at = |v: &[f64; 8]| v.get(i).copied().unwrap_or(0.0);
                at(&y) + h / 6.0 * (at(&k1) + 2.0 * at(&k2) + 2.0 * at(&k3) + at(&k4))
            });
            self.t += h;
            let [_, _, phi1, ..] = self.y;
            self.sensor.track([phi1], h);
        }
    }

    /// The load's position `[x_C, z_C]`.
    #[must_use]
    pub fn load(&self) -> [f64; 2] {
        plant_output(&self.params, &self.y.into()).into()
    }

    /// What the sensors read now: `[x, l, φ1]` with noise and quantisation, the rope's
    /// angle as the inclinometer on the hook block reports it (filtered and late).
    pub fn sense(&mut self) -> [f64; 3] {
        let [x, l, ..] = self.y;
        let (pn, pq) = self.mismatch.position_noise;
        let (an, aq) = self.mismatch.angle_noise;
        let noise = &mut self.noise;
        let mut q = |v: f64, sigma: f64, quantum: f64| {
            let v = v + sigma * noise.normal();
            if quantum > 0.0 {
                libm::round(v / quantum) * quantum
            } else {
                v
            }
        };
        let (x, l) = (q(x, pn, pq), q(l, pn, pq));
        let [phi] = self.sensor.sample(|phi| q(phi, an, aq));
        [x, l, phi]
    }
}

// How the virtual bus runs this plant (`crate::simulated`): kept beside the plant, so a
// new crane's plant and its registration with the bus are one file.
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

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use solver_core::plan::Plan;
    use solver_core::reference::double_pendulum::flat_inverse;
    use solver_core::trajectory::{PointToPoint, Trajectory};

    const P: DoublePendulumParams = DoublePendulumParams::EXAMPLE;

    /// At rest it stays at rest: the load under the trolley, the sling's length below
    /// the hook block.
    #[test]
    fn at_rest_it_stays_at_rest() {
        let mut plant = PlantDp::at_rest(P, [12.0, 7.0], Mismatch::NONE);
        plant.advance_braked([0.0; 2], 5.0, [false; 2]);
        let [xc, zc] = plant.load();
        assert!(
            (xc - 12.0).abs() < 1e-12 && (zc - 8.0).abs() < 1e-12,
            "{xc} {zc}"
        );
        assert_eq!(plant.sense(), [12.0, 7.0, 0.0]);
    }

    /// Driven by the exact inputs of the flat inverse along a move, the plant carries the
    /// load along the path (the forward check of Sec. 2.3) and the inclinometer reads the
    /// rope's angle.
    #[test]
    fn the_exact_inputs_carry_the_load_along_its_path() {
        let mut plan = Plan::at_rest([12.0, 8.0].into(), 7).unwrap();
        let step = PointToPoint::new([12.0, 8.0].into(), [16.0, 6.0].into(), 1.0, 6.0, 7).unwrap();
        plan.push(step).unwrap();
        let mut plant = PlantDp::at_rest(P, [12.0, 7.0], Mismatch::NONE);
        let dt = 0.001;
        let mut worst: f64 = 0.0;
        for k in 0..8000 {
            let t = f64::from(k) * dt;
            let u = flat_inverse(&P, &plan, t).unwrap().u;
            plant.advance_braked(u, dt, [false; 2]);
            let want = plan.derivatives::<1>(t + dt)[0];
            let [xc, zc] = plant.load();
            worst = worst.max((xc - want[0]).abs().max((zc - want[1]).abs()));
        }
        eprintln!("load off its path at most {worst:.2e} m (inputs held over 1 ms)");
        assert!(worst < 2e-3, "{worst} m");
        let f = flat_inverse(&P, &plan, 8.0).unwrap();
        let [_, _, phi1] = plant.sense();
        assert!((phi1 - f.angle[0]).abs() < 1e-3, "{phi1} {:?}", f.angle);
    }

    /// A braked trolley stands still whatever it is commanded; the winch moves.
    #[test]
    fn a_braked_drive_stands_still() {
        let mut plant = PlantDp::at_rest(P, [12.0, 7.0], Mismatch::NONE);
        plant.advance_braked([0.5, 0.2], 1.0, [true, false]);
        assert_eq!(plant.y[0], 12.0);
        assert!(plant.y[1] > 7.1, "{}", plant.y[1]);
    }
}
