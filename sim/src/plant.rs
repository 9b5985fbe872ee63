//! A crane plant that is *not* the controller's model, for the closed-loop study.
//!
//! The trolley, the winch and the load as one mechanical system (Lagrange's equations in
//! `x`, the drum's rope `l` and the swing `φ`: the rope's force acts back on both drives),
//! each drive a mass under a PI velocity loop, with what the inverse model leaves out:
//!
//! * the velocity loops: proportional gain for a time constant `τ (1 + δ)` on the axis'
//!   mass with the load's share, `|δ| ≤ 30 %` (the model's τ of Tab. 3 are identified
//!   values), integral time 10 `τ` (so the loop settles like a first-order lag, and a
//!   constant load — the rope's pull, the load's weight on the winch — is held without
//!   a lasting error);
//! * friction in both axes, Coulomb (`c · tanh(v / 1 mm/s)`) plus viscous (`b · v`), as
//!   the forces that would make a proportional loop droop by `c` and `b v`: the integral
//!   removes the droop over time, but a small correction meets them as a dead band;
//! * the masses, which the paper does not give: trolley [`TROLLEY_MASS`], winch (drum
//!   and motor reflected to the rope) [`WINCH_MASS`], the load Tab. 3's;
//! * the rope is not what the drum's measurement says: its scaling is off by up to ±2 %
//!   (rope diameter, layering) and it is longer by an offset of up to ±2 % of the initial
//!   length (hook block, rope stretch): the pendulum has length `(1 + s) l + Δl`;
//! * a wind gust: a horizontal force `F(t)` on the load (a sin² pulse);
//! * a load heavier or lighter than the model's ([`Mismatch::load_mass`]). The inverse
//!   model has no mass in it (its drives are the lags of Eq. 22, its load a pendulum);
//!   the plant's drives feel it. It enters through the hoist's inertia (the
//!   load hangs rigidly along the rope: `m k²` reflected to the drum) and the weight the
//!   hoist holds, and through the rope's pull on the trolley (`m g φ`, and the load's
//!   inertia while the swing changes). By default the loops are tuned for the plant's
//!   own load, so each axis keeps the model's τ; with [`Mismatch::loops_for_model_load`]
//!   they keep the gains commissioned for the model's load, as a real drive does when
//!   a heavier load is picked up: the hoist then answers slower by `(M_W + m' k²) /
//!   (M_W + m k²)`;
//! * velocity loops without integral action ([`Mismatch::proportional_only`], per axis):
//!   a P loop droops by the force it must deliver over its gain — friction, the rope's
//!   pull — and a hoist's holds only the weight it was commissioned for (its integral
//!   frozen at that hold, the torque feedforward such a drive has), so a heavier load
//!   sinks at `Δm g k / k_p`;
//! * measurements sampled every cycle with noise and quantisation, delivered one
//!   cycle (10 ms) late; the inclinometer's angle through its own first-order filter and
//!   a delay of its own beyond that ([`crate::angle_sensor`]), as a real one reports it.
//!
//! Integrated with classical RK4 at 1 ms under the zero-order-held 10 ms set points.
//!
//! `no_std` and `libm` only: the QEMU firmware's virtual bus runs the same plant as the
//! host (feature `sim`), so that QEMU and host compute the same frames.

use crate::angle_sensor::AngleSensor;
pub use crate::angle_sensor::SensorLag;
pub use crate::mismatch::{Gust, Mismatch, Rng, Travel3d};
use crate::simulated::{CranePlant, Sensed, TrueState};

/// The trolley's mass, kg (assumed: the paper gives the load's only).
pub const TROLLEY_MASS: f64 = 30.0;
/// The winch's mass, drum and motor reflected to the rope, kg (assumed).
pub const WINCH_MASS: f64 = 10.0;
/// The velocity loops' integral time, in time constants.
const INTEGRAL_TIME: f64 = 10.0;

/// The plant's true state, `[x, l_drum, φ, ẋ, l̇, φ̇]` (the pendulum length is
/// [`Mismatch::rope`]), and the velocity loops' integrals.
#[derive(Debug, Clone)]
pub struct Plant {
    /// State.
    pub y: [f64; 6],
    /// The trolley's and the winch's velocity-loop integral `∫(u − v) dt`, m.
    pub integral: [f64; 2],
    /// Time, s.
    pub t: f64,
    /// Proportional gains, N s/m.
    kp: [f64; 2],
    /// Integral gains, N/m.
    ki: [f64; 2],
    g: f64,
    m: f64,
    mismatch: Mismatch,
    noise: Rng,
    /// The inclinometer's filter and delay line.
    sensor: AngleSensor<1>,
}

/// Integration step of the plant, s.
pub const PLANT_STEP: f64 = 1e-3;

/// The state and the integrals as one vector for RK4.
type Full = [f64; 8];

impl Plant {
    /// At rest at trolley `x`, drum rope length `l`, time `t`; model time constants `tau`.
    pub fn at_rest(x: f64, l: f64, t: f64, tau: [f64; 2], g: f64, m: f64, mm: Mismatch) -> Self {
        let [tau1, tau2] = tau;
        let (t1, t2) = (tau1 * (1.0 + mm.tau1), tau2 * (1.0 + mm.tau2));
        let k = 1.0 + mm.drum_scale;
        let model_m = m;
        let m = m * (1.0 + mm.load_mass);
        let tuned = if mm.loops_for_model_load { model_m } else { m };
        let kp = [
            (TROLLEY_MASS + tuned) / t1,
            (WINCH_MASS + tuned * k * k) / t2,
        ];
        let ki = [kp[0] / (INTEGRAL_TIME * t1), kp[1] / (INTEGRAL_TIME * t2)];
        let phi = mm.swing0;
        // The winch's integral holds the load's weight from the start (the trolley's the
        // rope's pull at the initial swing: none at its turning point, the load at rest);
        // a P-only winch's holds the commissioned load's, for good.
        let held = if mm.proportional_only[1] { tuned } else { m };
        let hold = -held * g * k * libm::cos(phi) / ki[1];
        Self {
            y: [x, l, phi, 0.0, 0.0, 0.0],
            integral: [0.0, hold],
            t,
            kp,
            ki,
            g,
            m,
            mismatch: mm,
            noise: Rng::new(mm.noise_seed),
            sensor: AngleSensor::new(mm.inclinometer, [phi]),
        }
    }

    /// Lagrange's equations of trolley, rope and load (`M q̈ = f` in `q = [x, l, φ]`,
    /// the load at `(x + L sin φ, L cos φ)`, `L = (1 + s) l + Δl`) with the drives' forces.
    fn rhs(&self, t: f64, y: &Full, u: [f64; 2], braked: [bool; 2]) -> Full {
        let [_, l, phi, vx, vl, vphi, i1, i2] = *y;
        let mm = &self.mismatch;
        let [c1, c2] = mm.coulomb;
        let [b1, b2] = mm.viscous;
        let [u1, u2] = u;
        let [kp1, kp2] = self.kp;
        let [ki1, ki2] = self.ki;
        let friction = |kp: f64, c: f64, b: f64, v: f64| kp * (c * libm::tanh(v / 1e-3) + b * v);
        let f_trolley = kp1 * (u1 - vx) + ki1 * i1 - friction(kp1, c1, b1, vx);
        let f_winch = kp2 * (u2 - vl) + ki2 * i2 - friction(kp2, c2, b2, vl);
        let m = self.m;
        let k = 1.0 + mm.drum_scale;
        let len = mm.rope(l);
        let vlen = k * vl;
        let (s, c) = (libm::sin(phi), libm::cos(phi));
        let gust = mm.gust.force(t);
        // Mass matrix (symmetric; M23 = 0).
        let m11 = TROLLEY_MASS + m;
        let m12 = m * k * s;
        let m13 = m * len * c;
        let m22 = WINCH_MASS + m * k * k;
        let m33 = m * len * len;
        // Generalised forces less the velocity terms.
        let f1 = f_trolley + gust - 2.0 * m * vlen * vphi * c + m * len * vphi * vphi * s;
        let f2 = f_winch + gust * k * s + m * k * len * vphi * vphi + m * self.g * k * c;
        let f3 = gust * len * c - 2.0 * m * len * vlen * vphi - m * self.g * len * s;
        // Rows 2 and 3 give l̈ and φ̈ from ẍ; row 1 then ẍ. A braked axis does not
        // accelerate (its row is the brake's reaction), and its loop does not integrate.
        let [trolley_braked, winch_braked] = braked;
        let (m12, f2) = if winch_braked { (0.0, 0.0) } else { (m12, f2) };
        let ax = if trolley_braked {
            0.0
        } else {
            (f1 - m12 * f2 / m22 - m13 * f3 / m33) / (m11 - m12 * m12 / m22 - m13 * m13 / m33)
        };
        let al = if winch_braked {
            0.0
        } else {
            (f2 - m12 * ax) / m22
        };
        let aphi = (f3 - m13 * ax) / m33;
        let [p1, p2] = mm.proportional_only;
        let di1 = if trolley_braked || p1 { 0.0 } else { u1 - vx };
        let di2 = if winch_braked || p2 { 0.0 } else { u2 - vl };
        [vx, vl, vphi, ax, al, aphi, di1, di2]
    }

    /// Integrates over `dt` (a multiple of [`PLANT_STEP`]) with `u` held.
    pub fn advance(&mut self, u: [f64; 2], dt: f64) {
        self.advance_braked(u, dt, [false; 2]);
    }

    /// [`Self::advance`] with the axes whose drive is not powered (not enabled, in
    /// fault, switched off) held by their brakes: they stand still whatever the rope
    /// pulls, the load swinging under them.
    pub fn advance_braked(&mut self, u: [f64; 2], dt: f64, braked: [bool; 2]) {
        if braked[0] {
            self.y[3] = 0.0;
        }
        if braked[1] {
            self.y[4] = 0.0;
        }
        let n = libm::round(dt / PLANT_STEP).max(1.0) as usize;
        let h = dt / n as f64;
        for _ in 0..n {
            let [y0, y1, y2, y3, y4, y5] = self.y;
            let [i1, i2] = self.integral;
            let y: Full = [y0, y1, y2, y3, y4, y5, i1, i2];
            let t = self.t;
            let add = |a: &Full, k: &Full, s: f64| -> Full {
                core::array::from_fn(|i| a.get(i).zip(k.get(i)).map_or(0.0, |(a, k)| a + s * k))
            };
            let k1 = self.rhs(t, &y, u, braked);
            let k2 = self.rhs(t + h / 2.0, &add(&y, &k1, h / 2.0), u, braked);
            let k3 = self.rhs(t + h / 2.0, &add(&y, &k2, h / 2.0), u, braked);
            let k4 = self.rhs(t + h, &add(&y, &k3, h), u, braked);
            let next: Full = core::array::from_fn(|i| {
                let at = |v: &Full| v.get(i).copied().unwrap_or(0.0);
                at(&y) + h / 6.0 * (at(&k1) + 2.0 * at(&k2) + 2.0 * at(&k3) + at(&k4))
            });
            let [n0, n1, n2, n3, n4, n5, n6, n7] = next;
            self.y = [n0, n1, n2, n3, n4, n5];
            self.integral = [n6, n7];
            self.t += h;
            self.sensor.track([n2], h);
        }
    }

    /// The load position `[x_C, z_C]` (Eq. 27 with the true rope length).
    pub fn load(&self) -> [f64; 2] {
        let [x, l, phi, ..] = self.y;
        let len = self.mismatch.rope(l);
        [x + len * libm::sin(phi), len * libm::cos(phi)]
    }

    /// What the sensors read now: `[x, l_drum, φ]` with noise and quantisation, the
    /// angle as the inclinometer reports it: filtered, and sampled
    /// [`SensorLag::delay`] cycles before the positions ([`crate::angle_sensor`]).
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

    /// The load's mass, kg (the model's with [`Mismatch::load_mass`]).
    pub fn load_mass(&self) -> f64 {
        self.m
    }
}

// How the virtual bus runs this plant (`crate::simulated`): kept beside the plant, so a
// new crane's plant and its registration with the bus are one file.
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

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    const G: f64 = 9.81;
    const M: f64 = 18.9;

    fn plant(mm: Mismatch) -> Plant {
        Plant::at_rest(15.0, 6.0, 0.0, [0.03, 0.02], G, M, mm)
    }

    #[test]
    fn at_rest_without_a_set_point_it_stays_at_rest() {
        // The winch's integral holds the load's weight from the first step.
        let mut p = plant(Mismatch {
            drum_scale: 0.02,
            rope_offset: 0.1,
            ..Mismatch::NONE
        });
        for _ in 0..1000 {
            p.advance([0.0; 2], 0.01);
        }
        assert!((p.y[0] - 15.0).abs() < 1e-9 && (p.y[1] - 6.0).abs() < 1e-9);
        assert!(p.y[2].abs() < 1e-12);
    }

    #[test]
    fn a_velocity_step_is_followed_like_a_lag_of_tau_and_held_without_droop() {
        // 63 % of the step within half of τ either way (the integral adds a little); with
        // Coulomb friction the integral removes the droop a proportional loop keeps.
        let mm = Mismatch {
            coulomb: [0.01, 0.0],
            ..Mismatch::NONE
        };
        let mut p = plant(mm);
        let mut t63 = None;
        for k in 1..=5000 {
            p.advance([0.5, 0.0], PLANT_STEP);
            if t63.is_none() && p.y[3] >= 0.63 * 0.5 {
                t63 = Some(k as f64 * PLANT_STEP);
            }
        }
        let t63 = t63.unwrap();
        assert!((0.015..0.045).contains(&t63), "63 % after {t63} s");
        // The mean speed over a swing period (the swinging load pulls the trolley to
        // and fro): a proportional loop would droop to 0.49 m/s.
        let period = 2.0 * core::f64::consts::PI * libm::sqrt(6.0 / G);
        let x0 = p.y[0];
        let n = libm::round(period / PLANT_STEP) as usize;
        for _ in 0..n {
            p.advance([0.5, 0.0], PLANT_STEP);
        }
        let mean = (p.y[0] - x0) / (n as f64 * PLANT_STEP);
        assert!((mean - 0.5).abs() < 1e-3, "mean speed {mean} m/s");
    }

    #[test]
    fn the_load_swings_with_the_rope_s_true_length() {
        // The trolley held by its loop: the rope pulls it a little, so the period is
        // the pendulum's of the true length within a per cent.
        let mm = Mismatch {
            drum_scale: 0.02,
            rope_offset: 0.1,
            swing0: 0.02,
            ..Mismatch::NONE
        };
        let mut p = plant(mm);
        let mut crossings = Vec::new();
        let mut last = p.y[2];
        for k in 1..=20_000 {
            p.advance([0.0; 2], PLANT_STEP);
            if last > 0.0 && p.y[2] <= 0.0 {
                crossings.push(k as f64 * PLANT_STEP);
            }
            last = p.y[2];
        }
        let period = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
        let expected = 2.0 * core::f64::consts::PI * libm::sqrt(mm.rope(6.0) / G);
        assert!(
            (period / expected - 1.0).abs() < 0.01,
            "period {period:.4} s, pendulum {expected:.4} s"
        );
    }

    /// The mean speed of the trolley over one swing period of the 6 m rope under `u`,
    /// after 5 s to settle: the swinging load pulls the trolley to and fro.
    fn mean_trolley_speed(p: &mut Plant, u: f64) -> f64 {
        for _ in 0..5000 {
            p.advance([u, 0.0], PLANT_STEP);
        }
        let period = 2.0 * core::f64::consts::PI * libm::sqrt(6.0 / G);
        let n = libm::round(period / PLANT_STEP) as usize;
        let x0 = p.y[0];
        for _ in 0..n {
            p.advance([u, 0.0], PLANT_STEP);
        }
        (p.y[0] - x0) / (n as f64 * PLANT_STEP)
    }

    #[test]
    fn a_trolley_without_integral_action_droops_by_its_friction() {
        // P only: the loop's force kp (u − v) meets the friction kp (c + b v), so the
        // trolley runs at (u − c)/(1 + b): 0.4757 m/s for 0.5 with 10 mm/s and 3 %. The
        // PI loop of the same trolley removes the droop.
        let rough = Mismatch {
            coulomb: [0.01, 0.0],
            viscous: [0.03, 0.0],
            ..Mismatch::NONE
        };
        let mut p = plant(Mismatch {
            proportional_only: [true, false],
            ..rough
        });
        let mean = mean_trolley_speed(&mut p, 0.5);
        let droop = (0.5 - 0.01) / 1.03;
        assert!((mean - droop).abs() < 1e-3, "P only: {mean} m/s");
        let mut p = plant(rough);
        let mean = mean_trolley_speed(&mut p, 0.5);
        assert!((mean - 0.5).abs() < 1e-3, "PI: {mean} m/s");
    }

    #[test]
    fn a_winch_without_integral_action_holds_only_the_load_it_was_tuned_for() {
        // The loops tuned for the model's 18.9 kg; the plant's load 20 % heavier. P only,
        // the winch holds the 18.9 kg's weight and the extra 3.78 kg sinks the load at
        // Δm g k / kp = 37.1 N / (28.9 kg / 20 ms) = 25.7 mm/s.
        let heavier = Mismatch {
            load_mass: 0.2,
            loops_for_model_load: true,
            proportional_only: [false, true],
            ..Mismatch::NONE
        };
        let mut p = plant(heavier);
        for _ in 0..200 {
            p.advance([0.0; 2], 0.01);
        }
        let sink = 0.2 * M * G / ((WINCH_MASS + M) / 0.02);
        assert!((p.y[4] / sink - 1.0).abs() < 1e-3, "{} m/s", p.y[4]);
        // With the load it was tuned for, or with its integral, it holds.
        for mm in [
            Mismatch {
                load_mass: 0.0,
                ..heavier
            },
            Mismatch {
                proportional_only: [false; 2],
                ..heavier
            },
        ] {
            let mut p = plant(mm);
            for _ in 0..200 {
                p.advance([0.0; 2], 0.01);
            }
            assert!((p.y[1] - 6.0).abs() < 1e-9, "{mm:?}: l = {}", p.y[1]);
        }
    }

    /// When the winch reaches 63 % of a 0.3 m/s step, s.
    fn winch_t63(mm: Mismatch) -> f64 {
        let mut p = plant(mm);
        for k in 1..=1000 {
            p.advance([0.0, 0.3], PLANT_STEP);
            if p.y[4] >= 0.63 * 0.3 {
                return k as f64 * PLANT_STEP;
            }
        }
        f64::INFINITY
    }

    #[test]
    fn a_heavier_load_slows_a_winch_tuned_for_the_model_s_load() {
        // The load hangs rigidly along the rope: the winch moves W + m k². Tuned for the
        // model's load, a 20 % heavier one makes it (10 + 22.7)/(10 + 18.9) = 1.13 times
        // slower; tuned for the plant's own load it keeps its τ.
        let base = winch_t63(Mismatch::NONE);
        let heavier = Mismatch {
            load_mass: 0.2,
            ..Mismatch::NONE
        };
        let untuned = winch_t63(Mismatch {
            loops_for_model_load: true,
            ..heavier
        });
        let retuned = winch_t63(heavier);
        let ratio = (WINCH_MASS + 1.2 * M) / (WINCH_MASS + M);
        assert!(
            (untuned / base / ratio - 1.0).abs() < 0.05,
            "tuned for the model's load: {untuned} s against {base} s"
        );
        assert!(
            (retuned / base - 1.0).abs() < 0.05,
            "tuned for its own: {retuned} s against {base} s"
        );
    }
}
