//! The crane in three dimensions as a plant that is *not* the model, for the 3D
//! closed-loop study: [`plant`](crate::plant)'s planar plant with the bridge added.
//!
//! The bridge (carrying the trolley), the trolley, the hoist drum and the load are one
//! mechanical system, so the rope's force acts back on all three drives and the bridge
//! moves the trolley's mass as well. What the inverse model leaves out is what the
//! planar plant adds, per axis: a PI velocity loop (or a P loop without integral
//! action) tuned to the model's time constant off by up to ±30 %, for the plant's load or
//! the model's, Coulomb and viscous friction, brakes on an axis whose drive is
//! not enabled; the rope's scaling error and offset; a load mass off by up to ±20 %; a
//! wind gust from any horizontal direction; noisy, quantised sensors read one cycle
//! late. Integrated with classical RK4 at 1 ms ([`PLANT_STEP`]) under the
//! zero-order-held 10 ms set points.
//!
//! ## Coordinates
//!
//! `q = [x, y, l, α, β]`: bridge `x`, trolley `y` (on the bridge), the drum's rope `l`
//! and the rope's two *slopes*, `α` in the x–z plane and `β` in the y–z plane, as the
//! flat reference defines them (`solver_core::reference::flat_crane3d::FlatState3d::slope`)
//! and as the two-axis CiA 410 inclinometer on the hook block reports them:
//!
//! ```text
//! tan α = (x_C − x) / z_C,    tan β = (y_C − y) / z_C.
//! ```
//!
//! Why the slopes. (i) They are regular wherever the rope points downwards
//! (`|α|, |β| < 90°`): the map below is smooth and its two tangent vectors `e_α`, `e_β`
//! are independent there (the cosine of the angle between them is `−sin α sin β`, −0.12
//! at 20° in both planes), whereas spherical angles (inclination and its azimuth) are singular exactly at the
//! hanging rest, where the plant spends most of its time. (ii) They are what the
//! sensor reads, so [`Plant3d::sense`] reports a coordinate and no conversion can
//! disagree with the controller's definition. (iii) With `β ≡ 0` the slope `α` is the
//! planar plant's swing `φ` itself (`tan α/√(1 + tan²α) = sin α`), so the planar
//! special case is the same ODE in the same coordinates, not merely the same motion.
//! Cardan angles would share (i) but not (ii) and (iii).
//!
//! With `u = tan α`, `v = tan β`, `D = √(1 + u² + v²)` the rope's unit vector (from the
//! trolley down to the load) is `e = (u, v, 1)/D`, the pendulum's length
//! `L = (1 + s) l + Δl` ([`Mismatch3d::rope`]) and the load is at
//!
//! ```text
//! r_C = (x, y, 0) + L e,      z down from the rope's exit at the trolley.
//! ```
//!
//! ## Lagrange's equations
//!
//! Kinetic and potential energy (bridge mass `M_B`, trolley `M_T`, winch reflected to
//! the rope `M_W`, load `m`; gravity `+g` along `z`):
//!
//! ```text
//! T = ½ (M_B + M_T) ẋ² + ½ M_T ẏ² + ½ M_W l̇² + ½ m |ṙ_C|²,     V = −m g z_C.
//! ```
//!
//! With the Jacobian `J = ∂r_C/∂q` (columns `(1, 0, 0)`, `(0, 1, 0)`, `(1 + s) e`,
//! `L e_α`, `L e_β`) and `r̈_C = J q̈ + h(q, q̇)`, Lagrange's equations
//! `d/dt ∂T/∂q̇ − ∂T/∂q = Q` read
//!
//! ```text
//! (diag(M_B + M_T, M_T, M_W, 0, 0) + m JᵀJ) q̈ = (f_x, f_y, f_l, 0, 0) + Jᵀ (F_w − m h),
//! F_w = (F(t) cos θ, F(t) sin θ, m g),
//! ```
//!
//! `f_i` the drives' forces (loop less friction), `F(t)` the gust from the direction
//! `θ`. The bridge's row carries the load's whole horizontal inertia `m r̈_C,x` (the
//! rope's pull on the trolley, passed on to the bridge), the trolley's the lateral one,
//! the winch's the rope tension. The mass matrix is symmetric positive definite for
//! `L > 0`. Written out, with `S_a = 1 + u²`, `S_b = 1 + v²`, `u̇ = S_a α̇`,
//! `v̇ = S_b β̇`, `L̇ = (1 + s) l̇`:
//!
//! ```text
//! e_u  = (1 + v², −u v, −u) / D³                      e_α = S_a e_u
//! e_v  = (−u v, 1 + u², −v) / D³                      e_β = S_b e_v
//! e_uu = (−3u(1 + v²), v(2u² − 1 − v²), 2u² − 1 − v²) / D⁵
//! e_uv = (v(2u² − 1 − v²), u(2v² − 1 − u²), 3 u v) / D⁵
//! e_vv = (u(2v² − 1 − u²), −3v(1 + u²), 2v² − 1 − u²) / D⁵
//! h = 2 L̇ (e_u u̇ + e_v v̇) + 2 L (u S_a α̇² e_u + v S_b β̇² e_v)
//!       + L (e_uu u̇² + 2 e_uv u̇ v̇ + e_vv v̇²)
//! ```
//!
//! (the middle term of `h` is `ü`'s part without `α̈`: `ü = S_a α̈ + 2 u S_a α̇²`). The
//! five equations are solved by Gaussian elimination; a braked axis' row and column
//! are replaced by `q̈_i = 0` (the brake takes whatever the rope pulls).
//!
//! ## The planar special case
//!
//! With `y` held, `β = β̇ = 0` and no lateral force, every coupling to the trolley and to
//! `β` vanishes exactly (`u v = 0`, `e · e_v = 0`, `e_u · e_v = 0` at `v = 0`) and the
//! x-row is the planar trolley's with its mass `M_B + M_T`: the planar [`Plant`] with
//! `TROLLEY_MASS = M_B + M_T`, `WINCH_MASS = M_W`. The bridge's loop gain is then the
//! planar trolley's, `(M_B + M_T + m)/τ`.
//!
//! `no_std` and `libm` only, deterministic for a seed, as the planar plant.
//!
//! [`Plant`]: crate::plant::Plant

use crate::angle_sensor::{AngleSensor, SensorLag};
use crate::mismatch;
use crate::plant::{Gust, Mismatch, Rng, PLANT_STEP, TROLLEY_MASS, WINCH_MASS};
use crate::simulated::{CranePlant, Sensed, TrueState};

/// The bridge's own mass, kg (assumed: a light EOT girder pair with end carriages, four
/// times the trolley; the bridge is the heaviest axis).
pub const BRIDGE_MASS: f64 = 120.0;

/// The velocity loops' integral time, in time constants (the planar plant's).
const INTEGRAL_TIME: f64 = 10.0;

/// The drives' masses, which the inverse model (per unit load mass) does not know.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Masses3d {
    /// The bridge's own mass, kg (it carries the trolley's as well).
    pub bridge: f64,
    /// The trolley's mass (with the hoist on it), kg.
    pub trolley: f64,
    /// The winch, drum and motor reflected to the rope, kg.
    pub winch: f64,
}

impl Masses3d {
    /// The assumed crane: [`BRIDGE_MASS`], the planar plant's trolley
    /// ([`TROLLEY_MASS`]) and winch ([`WINCH_MASS`]).
    pub const EXAMPLE: Self = Self {
        bridge: BRIDGE_MASS,
        trolley: TROLLEY_MASS,
        winch: WINCH_MASS,
    };

    /// The mass each drive moves itself, `[M_B + M_T, M_T, M_W]`, kg.
    pub fn driven(&self) -> [f64; 3] {
        [self.bridge + self.trolley, self.trolley, self.winch]
    }
}

/// Everything in which the 3D plant differs from the model, and the sensors. Axes in the
/// inverse model's drive order: bridge, trolley, hoist.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mismatch3d {
    /// Relative errors of the drives' time constants (plant τ_i = model τ_i (1 + this)).
    pub tau: [f64; 3],
    /// Relative error of the load's mass (plant m = model m (1 + this)).
    pub load_mass: f64,
    /// Rope longer than measured by this, m.
    pub rope_offset: f64,
    /// The drum's scaling error: the rope is `(1 + this)` times what the drum measures.
    pub drum_scale: f64,
    /// Coulomb droop of each velocity loop, m/s.
    pub coulomb: [f64; 3],
    /// Viscous droop of each axis, relative.
    pub viscous: [f64; 3],
    /// The wind gust's time course and signed peak force, N.
    pub gust: Gust,
    /// The gust's horizontal direction, rad from +x towards +y.
    pub gust_direction: f64,
    /// Position noise (1σ) and quantum, m (bridge, trolley, drum).
    pub position_noise: (f64, f64),
    /// Slope noise (1σ) and quantum, rad (both slopes).
    pub angle_noise: (f64, f64),
    /// Seed of the sensor noise.
    pub noise_seed: u64,
    /// The slopes `[α, β]` the load has when the run starts, rad (a gust before the
    /// command), at rest in the swing's turning point.
    pub swing0: [f64; 2],
    /// The inclinometer's filter and its delay beyond the positions' (both slopes).
    pub inclinometer: SensorLag,
    /// The velocity loops of these axes (bridge, trolley, hoist) have no integral
    /// action, as [`Mismatch::proportional_only`] has it for the planar plant.
    pub proportional_only: [bool; 3],
    /// The loops tuned for the model's load mass, as
    /// [`Mismatch::loops_for_model_load`] has it.
    pub loops_for_model_load: bool,
}

impl Mismatch3d {
    /// The plant equal to the model: no friction, no offset, no gust, exact sensors.
    pub const NONE: Self = Self {
        tau: [0.0; 3],
        load_mass: 0.0,
        rope_offset: 0.0,
        drum_scale: 0.0,
        coulomb: [0.0; 3],
        viscous: [0.0; 3],
        gust: Gust::NONE,
        gust_direction: 0.0,
        position_noise: (0.0, 0.0),
        angle_noise: (0.0, 0.0),
        noise_seed: 0,
        swing0: [0.0; 2],
        inclinometer: SensorLag::NONE,
        proportional_only: [false; 3],
        loops_for_model_load: false,
    };

    /// A random case with the planar study's ranges: τ within ±30 %, load mass within
    /// ±20 %, rope offset within ±2 % of `l0`, drum scaling within ±2 %, Coulomb
    /// friction up to a droop of 10 mm/s on bridge and trolley and 5 mm/s on the hoist,
    /// viscous up to 3 %, a gust of up to ±10 N along a horizontal line at any angle
    /// (the sign picks the way along it, so every direction is as likely) lasting
    /// 0.5–3 s starting in `gust_window`, a load already swinging by up to 5° in any
    /// direction when the run starts; the planar study's sensors on every channel.
    pub fn random(rng: &mut Rng, l0: f64, gust_window: (f64, f64)) -> Self {
        let duration = rng.uniform(0.5, 3.0);
        let (a, b) = gust_window;
        let start = rng.uniform(a, (b - duration).max(a));
        let tau = [
            rng.uniform(-0.3, 0.3),
            rng.uniform(-0.3, 0.3),
            rng.uniform(-0.3, 0.3),
        ];
        let load_mass = rng.uniform(-0.2, 0.2);
        let rope_offset = rng.uniform(-0.02, 0.02) * l0;
        let drum_scale = rng.uniform(-0.02, 0.02);
        let coulomb = [
            rng.uniform(0.0, 0.01),
            rng.uniform(0.0, 0.01),
            rng.uniform(0.0, 0.005),
        ];
        let viscous = [
            rng.uniform(0.0, 0.03),
            rng.uniform(0.0, 0.03),
            rng.uniform(0.0, 0.03),
        ];
        let gust = Gust {
            start,
            duration,
            amplitude: rng.uniform(-10.0, 10.0),
        };
        let gust_direction = rng.uniform(0.0, core::f64::consts::PI);
        let noise_seed = rng.next_u64();
        // The rope inclined by `swing` from the vertical towards the azimuth `towards`.
        let swing = rng.uniform(0.0, 5.0).to_radians();
        let towards = rng.uniform(-core::f64::consts::PI, core::f64::consts::PI);
        let (s, c) = (libm::sin(swing), libm::cos(swing));
        let swing0 = [
            libm::atan2(s * libm::cos(towards), c),
            libm::atan2(s * libm::sin(towards), c),
        ];
        let (position_noise, angle_noise) = Mismatch::SENSORS;
        Self {
            tau,
            load_mass,
            rope_offset,
            drum_scale,
            coulomb,
            viscous,
            gust,
            gust_direction,
            position_noise,
            angle_noise,
            noise_seed,
            swing0,
            inclinometer: SensorLag::NONE,
            proportional_only: [false; 3],
            loops_for_model_load: false,
        }
    }

    /// The planar case `planar` on the 3D crane: its winch becomes the hoist, its
    /// trolley's errors go to the travel drives [`Mismatch::travel_3d`] names (by default
    /// the bridge, the trolley exact and frictionless), the gust blows along x and the
    /// load swings in the x–z plane (what the planar special case compares).
    pub fn from_planar(planar: &Mismatch) -> Self {
        let [c1, c2] = planar.coulomb;
        let [b1, b2] = planar.viscous;
        let [p1, p2] = planar.proportional_only;
        let [bridge, trolley] = planar.travel_3d.drives();
        let travel = |on: bool, v: f64| if on { v } else { 0.0 };
        Self {
            tau: [
                travel(bridge, planar.tau1),
                travel(trolley, planar.tau1),
                planar.tau2,
            ],
            load_mass: planar.load_mass,
            rope_offset: planar.rope_offset,
            drum_scale: planar.drum_scale,
            coulomb: [travel(bridge, c1), travel(trolley, c1), c2],
            viscous: [travel(bridge, b1), travel(trolley, b1), b2],
            gust: planar.gust,
            gust_direction: 0.0,
            position_noise: planar.position_noise,
            angle_noise: planar.angle_noise,
            noise_seed: planar.noise_seed,
            swing0: [planar.swing0, 0.0],
            inclinometer: planar.inclinometer,
            proportional_only: [p1 && bridge, p1 && trolley, p2],
            loops_for_model_load: planar.loops_for_model_load,
        }
    }

    /// The pendulum's length when the drum measures `l`, m ([`mismatch::rope`]).
    pub fn rope(&self, l: f64) -> f64 {
        mismatch::rope(self.drum_scale, self.rope_offset, l)
    }

    /// The same crane with the hoist's scaling corrected by the rope calibration
    /// `(s, o)` ([`mismatch::calibrated`]), as [`Mismatch::calibrated`] does it for the
    /// planar winch.
    pub fn calibrated(&self, calibration: (f64, f64)) -> Self {
        let (drum_scale, rope_offset) =
            mismatch::calibrated((self.drum_scale, self.rope_offset), calibration);
        Self {
            drum_scale,
            rope_offset,
            ..*self
        }
    }
}

/// The state and the integrals as one vector for RK4: `q`, `q̇`, the loops' integrals.
type Full = [f64; 13];

/// A 3-vector.
type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    let [a0, a1, a2] = a;
    let [b0, b1, b2] = b;
    a0 * b0 + a1 * b1 + a2 * b2
}

fn scale(s: f64, a: V3) -> V3 {
    a.map(|x| s * x)
}

fn add(a: V3, b: V3) -> V3 {
    let [a0, a1, a2] = a;
    let [b0, b1, b2] = b;
    [a0 + b0, a1 + b1, a2 + b2]
}

/// The load's kinematics at one configuration: the Jacobian's columns and the
/// velocity-product term of its acceleration.
struct Kinematics {
    /// The load, `r_C`, m.
    r: V3,
    /// `∂r_C/∂q_i`, one column per coordinate.
    cols: [V3; 5],
    /// `h(q, q̇)`: `r̈_C = J q̈ + h`, m/s².
    h: V3,
}

/// The load's position, Jacobian and `h` at `q = [x, y, l, α, β]`, `q̇`, for the rope
/// of the drum's scaling `k` and the true length `len`.
fn kinematics(q: [f64; 5], qd: [f64; 5], k: f64, len: f64) -> Kinematics {
    let [x, y, _, a, b] = q;
    let [_, _, vl, va, vb] = qd;
    let (u, v) = (libm::tan(a), libm::tan(b));
    let (sa, sb) = (1.0 + u * u, 1.0 + v * v);
    let (ud, vd) = (sa * va, sb * vb);
    let d2 = 1.0 + u * u + v * v;
    let d = libm::sqrt(d2);
    let d3 = d2 * d;
    let d5 = d3 * d2;
    let e = [u / d, v / d, 1.0 / d];
    let eu = [(1.0 + v * v) / d3, -u * v / d3, -u / d3];
    let ev = [-u * v / d3, (1.0 + u * u) / d3, -v / d3];
    let cu = 2.0 * u * u - 1.0 - v * v;
    let cv = 2.0 * v * v - 1.0 - u * u;
    let euu = [-3.0 * u * (1.0 + v * v) / d5, v * cu / d5, cu / d5];
    let euv = [v * cu / d5, u * cv / d5, 3.0 * u * v / d5];
    let evv = [u * cv / d5, -3.0 * v * (1.0 + u * u) / d5, cv / d5];
    let vlen = k * vl;
    let h = add(
        add(
            scale(2.0 * vlen, add(scale(ud, eu), scale(vd, ev))),
            scale(
                2.0 * len,
                add(scale(u * sa * va * va, eu), scale(v * sb * vb * vb, ev)),
            ),
        ),
        scale(
            len,
            add(
                add(scale(ud * ud, euu), scale(2.0 * ud * vd, euv)),
                scale(vd * vd, evv),
            ),
        ),
    );
    Kinematics {
        r: add([x, y, 0.0], scale(len, e)),
        cols: [
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            scale(k, e),
            scale(len * sa, eu),
            scale(len * sb, ev),
        ],
        h,
    }
}

/// `A z = b` for the symmetric positive definite 5×5 mass matrix, by Gaussian
/// elimination without pivoting (stable for such a matrix; its pivots are masses and
/// moments of inertia, all positive).
fn solve(mut a: [[f64; 5]; 5], mut b: [f64; 5]) -> [f64; 5] {
    for k in 0..5 {
        let (Some(&pivot_row), Some(&pivot_b)) = (a.get(k), b.get(k)) else {
            continue;
        };
        let pivot = pivot_row.get(k).copied().unwrap_or(1.0);
        for (row, bi) in a.iter_mut().zip(b.iter_mut()).skip(k + 1) {
            let f = row.get(k).copied().unwrap_or(0.0) / pivot;
            for (x, p) in row.iter_mut().zip(pivot_row.iter()) {
                *x -= f * p;
            }
            *bi -= f * pivot_b;
        }
    }
    let mut z = [0.0; 5];
    for k in (0..5).rev() {
        let (Some(row), Some(&bk)) = (a.get(k), b.get(k)) else {
            continue;
        };
        let s = row
            .iter()
            .zip(z.iter())
            .skip(k + 1)
            .fold(bk, |s, (a, z)| s - a * z);
        let pivot = row.get(k).copied().unwrap_or(1.0);
        if let Some(slot) = z.get_mut(k) {
            *slot = s / pivot;
        }
    }
    z
}

/// The 3D crane plant: true state, the velocity loops and the sensors.
#[derive(Debug, Clone)]
pub struct Plant3d {
    /// State `[x, y, l_drum, α, β, ẋ, ẏ, l̇, α̇, β̇]` (the pendulum length is
    /// [`Mismatch3d::rope`] of `l_drum`; `α`, `β` the slopes, rad).
    pub q: [f64; 10],
    /// The bridge's, trolley's and hoist's velocity-loop integral `∫(u − v) dt`, m.
    pub integral: [f64; 3],
    /// Time, s.
    pub t: f64,
    /// Proportional gains, N s/m.
    kp: [f64; 3],
    /// Integral gains, N/m.
    ki: [f64; 3],
    /// The plant's time constants, s (the model's with the mismatch).
    tau: [f64; 3],
    g: f64,
    /// The plant's load mass, kg (the model's with the mismatch).
    m: f64,
    /// The model's load mass, kg (what [`Mismatch3d::loops_for_model_load`] tunes for).
    model_m: f64,
    masses: Masses3d,
    mismatch: Mismatch3d,
    noise: Rng,
    /// The inclinometer's filter and delay line (slopes long and lateral).
    sensor: AngleSensor<2>,
    /// The previous cycle's sample, for [`Self::sense_late`].
    late: Option<[f64; 5]>,
}

impl Plant3d {
    /// At rest (the load at its turning point `mismatch.swing0`) with the bridge at `x`,
    /// the trolley at `y`, the drum's rope `l`, time `t`; the model's time constants
    /// `tau` (bridge, trolley, hoist), gravity `g` and load mass `m`; the assumed
    /// [`Masses3d::EXAMPLE`] (another crane: [`Self::with_masses`]).
    #[allow(clippy::too_many_arguments)] // The planar `at_rest`'s seven and the trolley's `y`.
    pub fn at_rest(
        x: f64,
        y: f64,
        l: f64,
        t: f64,
        tau: [f64; 3],
        g: f64,
        m: f64,
        mismatch: Mismatch3d,
    ) -> Self {
        let [a, b] = mismatch.swing0;
        let ([t1, t2, t3], [d1, d2, d3]) = (tau, mismatch.tau);
        let mut plant = Self {
            q: [x, y, l, a, b, 0.0, 0.0, 0.0, 0.0, 0.0],
            integral: [0.0; 3],
            t,
            kp: [0.0; 3],
            ki: [0.0; 3],
            tau: [t1 * (1.0 + d1), t2 * (1.0 + d2), t3 * (1.0 + d3)],
            g,
            m: m * (1.0 + mismatch.load_mass),
            model_m: m,
            masses: Masses3d::EXAMPLE,
            mismatch,
            noise: Rng::new(mismatch.noise_seed),
            sensor: AngleSensor::new(mismatch.inclinometer, [a, b]),
            late: None,
        };
        plant.tune();
        plant
    }

    /// The same plant at rest on a crane with the drives' masses `masses` (loops tuned
    /// again for them, the integrals reset to the rest hold): call it on a plant fresh
    /// from [`Self::at_rest`].
    #[must_use]
    pub fn with_masses(mut self, masses: Masses3d) -> Self {
        self.masses = masses;
        self.tune();
        self
    }

    /// Tunes the loops as the planar plant does — proportional gain for the plant's time
    /// constant on the axis' mass with the load's share (the whole load for the
    /// horizontal axes, `m (1 + s)²` reflected to the drum; the plant's load, or the
    /// model's with [`Mismatch3d::loops_for_model_load`]), integral time 10 τ — and
    /// sets the hoist's integral to hold the load's weight from the start (a P-only
    /// hoist's: the load's it is tuned for, for good). The bridge's and the trolley's
    /// start at zero, as the planar trolley's: the rope's mean horizontal pull over a
    /// swing is none.
    fn tune(&mut self) {
        let k = 1.0 + self.mismatch.drum_scale;
        let [mx, my, ml] = self.masses.driven();
        let [t1, t2, t3] = self.tau;
        let tuned = if self.mismatch.loops_for_model_load {
            self.model_m
        } else {
            self.m
        };
        let kp = [
            (mx + tuned) / t1,
            (my + tuned) / t2,
            (ml + tuned * k * k) / t3,
        ];
        let [kp1, kp2, kp3] = kp;
        self.kp = kp;
        self.ki = [
            kp1 / (INTEGRAL_TIME * t1),
            kp2 / (INTEGRAL_TIME * t2),
            kp3 / (INTEGRAL_TIME * t3),
        ];
        let [_, _, ki3] = self.ki;
        // The weight's pull along the rope, reflected to the drum: m g k e_z.
        let [_, _, _, a, b, ..] = self.q;
        let (u, v) = (libm::tan(a), libm::tan(b));
        let ez = 1.0 / libm::sqrt(1.0 + u * u + v * v);
        let [_, _, p3] = self.mismatch.proportional_only;
        let held = if p3 { tuned } else { self.m };
        self.integral = [0.0, 0.0, -held * self.g * k * ez / ki3];
    }

    /// The kinematics at the full state `s`.
    fn kinematics_of(&self, s: &[f64; 10]) -> Kinematics {
        let [x, y, l, a, b, vx, vy, vl, va, vb] = *s;
        let k = 1.0 + self.mismatch.drum_scale;
        kinematics(
            [x, y, l, a, b],
            [vx, vy, vl, va, vb],
            k,
            self.mismatch.rope(l),
        )
    }

    /// Lagrange's equations (module documentation) with the drives' forces: `ṡ`.
    fn rhs(&self, t: f64, s: &Full, u: [f64; 3], braked: [bool; 3]) -> Full {
        let [x, y, l, a, b, vx, vy, vl, va, vb, i1, i2, i3] = *s;
        let mm = &self.mismatch;
        let kin = self.kinematics_of(&[x, y, l, a, b, vx, vy, vl, va, vb]);
        let friction = |kp: f64, c: f64, b: f64, v: f64| kp * (c * libm::tanh(v / 1e-3) + b * v);
        let v = [vx, vy, vl];
        let integral = [i1, i2, i3];
        // The drives' forces: loop less friction; a braked axis' loop does not integrate.
        let force: [f64; 3] = core::array::from_fn(|i| {
            let at = |a: &[f64; 3]| a.get(i).copied().unwrap_or(0.0);
            let (kp, ki) = (at(&self.kp), at(&self.ki));
            kp * (at(&u) - at(&v)) + ki * at(&integral)
                - friction(kp, at(&mm.coulomb), at(&mm.viscous), at(&v))
        });
        let [f1, f2, f3] = force;
        let gust = mm.gust.force(t);
        let fw = [
            gust * libm::cos(mm.gust_direction),
            gust * libm::sin(mm.gust_direction),
            self.m * self.g,
        ];
        // What acts on the load besides the rope, less its share of velocity terms.
        let load = add(fw, scale(-self.m, kin.h));
        let q_drives = [f1, f2, f3, 0.0, 0.0];
        let [mx, my, ml] = self.masses.driven();
        let m_drives = [mx, my, ml, 0.0, 0.0];
        let is_braked = |i: usize| braked.get(i).copied().unwrap_or(false);
        let col = |i: usize| kin.cols.get(i).copied().unwrap_or([0.0; 3]);
        // A braked axis: q̈_i = 0, its row and column the identity's.
        let mass: [[f64; 5]; 5] = core::array::from_fn(|i| {
            core::array::from_fn(|j| {
                if is_braked(i) || is_braked(j) {
                    if i == j {
                        1.0
                    } else {
                        0.0
                    }
                } else {
                    let own = if i == j {
                        m_drives.get(i).copied().unwrap_or(0.0)
                    } else {
                        0.0
                    };
                    own + self.m * dot(col(i), col(j))
                }
            })
        });
        let rhs: [f64; 5] = core::array::from_fn(|i| {
            if is_braked(i) {
                0.0
            } else {
                q_drives.get(i).copied().unwrap_or(0.0) + dot(col(i), load)
            }
        });
        let [ax, ay, al, aa, ab] = solve(mass, rhs);
        let proportional = |i: usize| mm.proportional_only.get(i).copied().unwrap_or(false);
        let di: [f64; 3] = core::array::from_fn(|i| {
            if is_braked(i) || proportional(i) {
                0.0
            } else {
                u.get(i).copied().unwrap_or(0.0) - v.get(i).copied().unwrap_or(0.0)
            }
        });
        let [di1, di2, di3] = di;
        [vx, vy, vl, va, vb, ax, ay, al, aa, ab, di1, di2, di3]
    }

    /// Integrates over `dt` (a multiple of [`PLANT_STEP`]) with `u` (bridge, trolley,
    /// hoist velocity set points, m/s) held.
    pub fn advance(&mut self, u: [f64; 3], dt: f64) {
        self.advance_braked(u, dt, [false; 3]);
    }

    /// [`Self::advance`] with the axes whose drive is not powered (not enabled, in
    /// fault, switched off) held by their brakes: they stand still whatever the rope
    /// pulls, the load swinging under them.
    pub fn advance_braked(&mut self, u: [f64; 3], dt: f64, braked: [bool; 3]) {
        for (v, &b) in self.q.iter_mut().skip(5).zip(braked.iter()) {
            if b {
                *v = 0.0;
            }
        }
        let n = libm::round(dt / PLANT_STEP).max(1.0) as usize;
        let h = dt / n as f64;
        for _ in 0..n {
            let s: Full = core::array::from_fn(|i| {
                if i < 10 {
                    self.q.get(i).copied().unwrap_or(0.0)
                } else {
                    self.integral.get(i - 10).copied().unwrap_or(0.0)
                }
            });
            let t = self.t;
            let add = |a: &Full, k: &Full, c: f64| -> Full {
                core::array::from_fn(|i| a.get(i).zip(k.get(i)).map_or(0.0, |(a, k)| a + c * k))
            };
            let k1 = self.rhs(t, &s, u, braked);
            let k2 = self.rhs(t + h / 2.0, &add(&s, &k1, h / 2.0), u, braked);
            let k3 = self.rhs(t + h / 2.0, &add(&s, &k2, h / 2.0), u, braked);
            let k4 = self.rhs(t + h, &add(&s, &k3, h), u, braked);
            let next: Full = core::array::from_fn(|i| {
                let at = |v: &Full| v.get(i).copied().unwrap_or(0.0);
                at(&s) + h / 6.0 * (at(&k1) + 2.0 * at(&k2) + 2.0 * at(&k3) + at(&k4))
            });
            let (q, integral) = next.split_at(10);
            for (dst, src) in self.q.iter_mut().zip(q) {
                *dst = *src;
            }
            for (dst, src) in self.integral.iter_mut().zip(integral) {
                *dst = *src;
            }
            self.t += h;
            let slopes = self.slopes();
            self.sensor.track(slopes, h);
        }
    }

    /// The load position `[x_C, y_C, z_C]`, m (`z_C` down from the rope's exit).
    pub fn load(&self) -> [f64; 3] {
        self.kinematics_of(&self.q).r
    }

    /// The load's velocity `ṙ_C = J q̇`, m/s.
    pub fn load_velocity(&self) -> [f64; 3] {
        let kin = self.kinematics_of(&self.q);
        let [.., vx, vy, vl, va, vb] = self.q;
        kin.cols
            .iter()
            .zip([vx, vy, vl, va, vb])
            .fold([0.0; 3], |r, (c, v)| add(r, scale(v, *c)))
    }

    /// The true slopes `[α, β]`, rad.
    pub fn slopes(&self) -> [f64; 2] {
        let [_, _, _, a, b, ..] = self.q;
        [a, b]
    }

    /// The pendulum's true length, m.
    pub fn rope(&self) -> f64 {
        let [_, _, l, ..] = self.q;
        self.mismatch.rope(l)
    }

    /// The plant's load mass, kg (the model's with [`Mismatch3d::load_mass`]).
    pub fn load_mass(&self) -> f64 {
        self.m
    }

    /// The drives' masses.
    pub fn masses(&self) -> Masses3d {
        self.masses
    }

    /// How this plant differs from the model.
    pub fn mismatch(&self) -> &Mismatch3d {
        &self.mismatch
    }

    /// The mechanical energy `T + V`, J: the drives' and the load's kinetic energy and
    /// the load's potential energy (zero at the rope's exit; the loops' stored energy
    /// not included). What the swing keeps once the drives stand still.
    pub fn energy(&self) -> f64 {
        let [.., vx, vy, vl, _, _] = self.q;
        let [mx, my, ml] = self.masses.driven();
        let vc = self.load_velocity();
        let [_, _, zc] = self.load();
        0.5 * (mx * vx * vx + my * vy * vy + ml * vl * vl + self.m * dot(vc, vc))
            - self.m * self.g * zc
    }

    /// What the sensors read now: `[x, y, l_drum, α, β]` (bridge, trolley, the drum's
    /// rope as measured, slope long, slope lateral in rad) with noise and quantisation,
    /// the slopes as the inclinometer reports them: filtered, and sampled
    /// [`SensorLag::delay`] cycles before the positions ([`crate::angle_sensor`]).
    /// As for the planar plant, the caller delivers it one cycle later (the sample taken
    /// at the end of a cycle is what the controller has in the next); [`Self::sense_late`]
    /// does that bookkeeping.
    pub fn sense(&mut self) -> [f64; 5] {
        let [x, y, l, ..] = self.q;
        let (pn, pq) = self.mismatch.position_noise;
        let (an, aq) = self.mismatch.angle_noise;
        let noise = &mut self.noise;
        let mut read = |v: f64, sigma: f64, quantum: f64| {
            let v = v + sigma * noise.normal();
            if quantum > 0.0 {
                libm::round(v / quantum) * quantum
            } else {
                v
            }
        };
        let (x, y, l) = (read(x, pn, pq), read(y, pn, pq), read(l, pn, pq));
        let [a, b] = self.sensor.sample(|v| read(v, an, aq));
        [x, y, l, a, b]
    }

    /// Samples the sensors now ([`Self::sense`]) and returns the previous call's sample:
    /// called once a cycle, what the controller has one cycle late (`None` in the first
    /// cycle, before anything has arrived).
    pub fn sense_late(&mut self) -> Option<[f64; 5]> {
        let now = self.sense();
        self.late.replace(now)
    }
}

// How the virtual bus runs this plant (`crate::simulated`): kept beside the plant, so a
// new crane's plant and its registration with the bus are one file.
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

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use crate::plant::{Plant, Travel3d};
    use solver_core::models::crane3d::Crane3dParams;
    use solver_core::reference::flat_crane3d;
    use solver_core::trajectory::{PointToPoint, Trajectory};

    const G: f64 = 9.81;
    const M: f64 = 18.9;
    const TAU: [f64; 3] = [0.05, 0.03, 0.02];
    const PI: f64 = core::f64::consts::PI;

    fn plant(mm: Mismatch3d) -> Plant3d {
        Plant3d::at_rest(15.0, 4.0, 6.0, 0.0, TAU, G, M, mm)
    }

    /// Zero crossings (downwards, linearly interpolated) of a sampled signal.
    fn crossings(samples: &[(f64, f64)]) -> Vec<f64> {
        samples
            .windows(2)
            .filter(|w| w[0].1 > 0.0 && w[1].1 <= 0.0)
            .map(|w| w[0].0 + (w[1].0 - w[0].0) * w[0].1 / (w[0].1 - w[1].1))
            .collect()
    }

    fn mean_period(c: &[f64]) -> f64 {
        (c[c.len() - 1] - c[0]) / (c.len() - 1) as f64
    }

    #[test]
    fn energy_is_conserved_with_the_drives_braked() {
        // A spherical swing of 15° and 10° with the rates of a wide ellipse, the
        // suspension fixed: the brakes do no work, so T + V stays. Measured drift over
        // 20 s: 2.3e-14 of the swing's energy m g L (1 − cos 15°) ≈ 40 J; bound 1e-12.
        let mut p = plant(Mismatch3d {
            drum_scale: 0.02,
            rope_offset: 0.1,
            ..Mismatch3d::NONE
        });
        p.q[3] = 15f64.to_radians();
        p.q[4] = -10f64.to_radians();
        p.q[8] = 0.05;
        p.q[9] = 0.2;
        let e0 = p.energy();
        let scale = M * G * p.rope() * (1.0 - 15f64.to_radians().cos());
        let mut worst: f64 = 0.0;
        for _ in 0..2000 {
            p.advance_braked([0.0; 3], 0.01, [true; 3]);
            worst = worst.max((p.energy() - e0).abs());
        }
        assert!(
            worst < 1e-12 * scale,
            "energy drift {worst:e} J of {scale} J"
        );
        // And it did swing in both planes.
        assert!(p.q[8].abs() + p.q[9].abs() > 0.0);
    }

    #[test]
    fn energy_is_conserved_with_all_drives_free_and_the_loops_springs() {
        // No friction, no gust, no proportional gain, set points zero: each loop is a
        // spring `k_i i`, `i̇ = −q̇`, whose energy ½ k_i i² joins T + V. Everything moves:
        // bridge, trolley, hoist (under the load's weight on its spring) and both
        // swings, so every coupling term of the mass matrix and of `h` does work.
        // Measured drift over 20 s: 4e-10 of the initial kinetic energy (the stiff
        // springs, ω up to 16 rad/s, are RK4's largest error); bound 1e-8.
        let mut p = plant(Mismatch3d {
            drum_scale: 0.02,
            rope_offset: 0.1,
            ..Mismatch3d::NONE
        });
        p.kp = [0.0; 3];
        p.q[3] = 12f64.to_radians();
        p.q[4] = 8f64.to_radians();
        p.q[5] = 0.3;
        p.q[6] = -0.4;
        p.q[7] = 0.2;
        p.q[9] = -0.1;
        let total = |p: &Plant3d| {
            p.energy()
                + p.ki
                    .iter()
                    .zip(p.integral)
                    .map(|(k, i)| 0.5 * k * i * i)
                    .sum::<f64>()
        };
        let e0 = total(&p);
        let kinetic0 = p.energy() + M * G * p.load()[2];
        let mut worst: f64 = 0.0;
        let mut moved = [0.0f64; 3];
        for _ in 0..2000 {
            p.advance([0.0; 3], 0.01);
            worst = worst.max((total(&p) - e0).abs());
            for (m, v) in moved.iter_mut().zip(&p.q[5..8]) {
                *m = m.max(v.abs());
            }
        }
        assert!(
            worst < 1e-8 * kinetic0,
            "energy drift {worst:e} J of kinetic {kinetic0} J"
        );
        assert!(moved.iter().all(|&v| v > 0.05), "drives moved {moved:?}");
    }

    /// Set points for the planar comparison: the bridge out and back, the hoist up and
    /// down, zero-order held over 10 ms.
    fn planar_set_points(t: f64) -> (f64, f64) {
        let bump = |t: f64, t0: f64, d: f64, a: f64| {
            let s = (t - t0) / d;
            if (0.0..=1.0).contains(&s) {
                a * (PI * s).sin().powi(2)
            } else {
                0.0
            }
        };
        (
            bump(t, 0.5, 6.0, 1.2) - bump(t, 9.0, 4.0, 0.8),
            bump(t, 1.0, 4.0, -0.4) + bump(t, 8.0, 5.0, 0.3),
        )
    }

    #[test]
    fn a_move_with_the_trolley_still_is_the_planar_plant() {
        // Derivation (module documentation): with y held, β = β̇ = 0 and no lateral
        // force, the trolley's and β's rows decouple exactly and the bridge's row is the
        // planar trolley's with its mass M_B + M_T; the loop gain (M_B + M_T + m)/τ is the
        // planar trolley's too. So the planar plant (TROLLEY_MASS = 30 kg) is the 3D one
        // with any split of 30 kg between bridge and trolley — here 20 + 10, and 0 + 30
        // to show the split does not matter. The same case throughout: τ errors,
        // friction on both axes, rope scaling and offset, a gust along x, a swinging
        // start, the bridge braked for 2 s. Same ODE in the same coordinates (α = φ),
        // so equal to rounding: measured 3.6e-15 m in x, 0 in l, 1.7e-16 rad in φ, 2.2e-16
        // in the rates; bound 1e-12.
        let planar_case = Mismatch {
            tau1: 0.2,
            tau2: -0.25,
            rope_offset: 0.12,
            drum_scale: 0.015,
            coulomb: [0.008, 0.004],
            viscous: [0.02, 0.01],
            gust: Gust {
                start: 3.0,
                duration: 1.5,
                amplitude: -8.0,
            },
            swing0: 3f64.to_radians(),
            ..Mismatch::NONE
        };
        for (bridge, trolley) in [(20.0, 10.0), (0.0, TROLLEY_MASS)] {
            let masses = Masses3d {
                bridge,
                trolley,
                winch: WINCH_MASS,
            };
            assert_eq!(masses.bridge + masses.trolley, TROLLEY_MASS);
            let mut planar = Plant::at_rest(15.0, 6.0, 0.0, [0.05, 0.02], G, M, planar_case);
            let mut p3 = Plant3d::at_rest(
                15.0,
                4.0,
                6.0,
                0.0,
                [0.05, 0.03, 0.02],
                G,
                M,
                Mismatch3d::from_planar(&planar_case),
            )
            .with_masses(masses);
            let (mut dx, mut dl, mut dphi, mut dv) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
            let mut largest_swing = 0.0f64;
            for k in 0..2000 {
                let t = k as f64 * 0.01;
                let (u1, u2) = planar_set_points(t);
                let braked = (12.0..14.0).contains(&t);
                planar.advance_braked([u1, u2], 0.01, [braked, false]);
                p3.advance_braked([u1, 0.0, u2], 0.01, [braked, false, false]);
                let [x, l, phi, vx, vl, vphi] = planar.y;
                dx = dx.max((p3.q[0] - x).abs());
                dl = dl.max((p3.q[2] - l).abs());
                dphi = dphi.max((p3.q[3] - phi).abs());
                dv = dv
                    .max((p3.q[5] - vx).abs())
                    .max((p3.q[7] - vl).abs())
                    .max((p3.q[8] - vphi).abs());
                largest_swing = largest_swing.max(phi.abs());
                // The trolley and the lateral swing are not touched at all.
                assert_eq!((p3.q[1], p3.q[4], p3.q[6], p3.q[9]), (4.0, 0.0, 0.0, 0.0));
                let ([xc, zc], [xc3, _, zc3]) = (planar.load(), p3.load());
                assert!((xc - xc3).abs() < 1e-12 && (zc - zc3).abs() < 1e-12);
            }
            assert!(
                dx < 1e-12 && dl < 1e-12 && dphi < 1e-12 && dv < 1e-12,
                "{bridge} + {trolley} kg: x {dx:e} m, l {dl:e} m, φ {dphi:e} rad, rates {dv:e}"
            );
            // A move that exercises the swing: several degrees.
            assert!(largest_swing > 3f64.to_radians(), "{largest_swing}");
        }
    }

    /// The slopes sampled every millisecond for `secs`, with the drives braked or under
    /// their loops (set points zero).
    fn swing(p: &mut Plant3d, secs: f64, braked: bool) -> Vec<(f64, [f64; 2])> {
        let n = (secs / PLANT_STEP).round() as usize;
        (0..n)
            .map(|_| {
                p.advance_braked([0.0; 3], PLANT_STEP, [braked; 3]);
                (p.t, p.slopes())
            })
            .collect()
    }

    fn plane(samples: &[(f64, [f64; 2])], k: usize) -> Vec<(f64, f64)> {
        samples.iter().map(|(t, s)| (*t, s[k])).collect()
    }

    /// The largest |slope| over `[a, b)`.
    fn amplitude(samples: &[(f64, f64)], a: f64, b: f64) -> f64 {
        samples
            .iter()
            .filter(|(t, _)| (a..b).contains(t))
            .fold(0.0f64, |m, (_, s)| m.max(s.abs()))
    }

    #[test]
    fn small_swings_have_the_true_rope_s_period_in_both_planes_and_do_not_couple() {
        // The rope as the mismatch makes it: 2 % longer scaling, 0.1 m offset.
        let mm = Mismatch3d {
            drum_scale: 0.02,
            rope_offset: 0.1,
            swing0: [1f64.to_radians(), 0.0],
            ..Mismatch3d::NONE
        };
        let expected = 2.0 * PI * (mm.rope(6.0) / G).sqrt();
        let omega = 2.0 * PI / expected;
        // (a) Suspension braked: an ellipse, 1° in x–z from rest, 0.7° in y–z from the
        // rate. Each plane swings with the pendulum's period: the amplitude lengthens
        // it by θ²/16 ≈ 2e-5, and the ellipse's precession, (3/8) a b ω ≈ 8e-5 of ω,
        // shifts its projections' zero crossings (measured −2.8e-5 in x–z, −8.6e-5 in
        // y–z; bound 2e-4, where a 1 % error in the rope would be 5e-3). Each plane
        // keeps its amplitude within 0.1 % over 20 s (measured 6e-7 and 1.8e-4).
        let mut p = plant(mm);
        p.q[9] = 0.7f64.to_radians() * omega;
        let s = swing(&mut p, 20.0, true);
        for (k, a0) in [(0, 1.0f64), (1, 0.7)] {
            let a0 = a0.to_radians();
            let pl = plane(&s, k);
            let period = mean_period(&crossings(&pl));
            assert!(
                (period / expected - 1.0).abs() < 2e-4,
                "plane {k}: period {period} s, pendulum {expected} s"
            );
            let late = amplitude(&pl, 20.0 - expected, 20.0);
            assert!((late / a0 - 1.0).abs() < 1e-3, "plane {k}: {late} of {a0}");
        }
        // (b) A swing in one plane alone stays there (exactly: β = 0 is invariant), the
        // other plane alone likewise.
        for k in 0..2 {
            let mut swing0 = [0.0; 2];
            swing0[k] = 1f64.to_radians();
            let mut p = plant(Mismatch3d { swing0, ..mm });
            let s = swing(&mut p, 10.0, true);
            assert!(s.iter().all(|(_, a)| a[1 - k] == 0.0));
            assert!(amplitude(&plane(&s, k), 5.0, 10.0) > 0.9f64.to_radians());
        }
        // (c) The drives under their loops (bridge 150 kg, trolley 30 kg): the rope pulls
        // each a little, so each plane's period is the pendulum's within 1 % (as the
        // planar plant's test has it; measured +0.16 % in x–z, +0.24 % in y–z), from a
        // start at rest in both planes.
        let mut p = plant(Mismatch3d {
            swing0: [1f64.to_radians(), -0.5f64.to_radians()],
            ..mm
        });
        let s = swing(&mut p, 20.0, false);
        for k in 0..2 {
            let period = mean_period(&crossings(&plane(&s, k)));
            assert!(
                (period / expected - 1.0).abs() < 0.01,
                "plane {k} under the loops: period {period} s, pendulum {expected} s"
            );
        }
    }

    #[test]
    fn a_gust_from_45_degrees_swings_both_planes_equally() {
        let gusty = Mismatch3d {
            gust: Gust {
                start: 0.5,
                duration: 2.0,
                amplitude: 10.0,
            },
            gust_direction: PI / 4.0,
            ..Mismatch3d::NONE
        };
        // Suspension braked: the crane is symmetric in x and y, so the planes swing alike
        // to rounding (cos 45° and sin 45° differ by an ulp).
        let mut p = plant(gusty);
        let s = swing(&mut p, 15.0, true);
        let worst = s
            .iter()
            .fold(0.0f64, |m, (_, a)| m.max((a[0] - a[1]).abs()));
        let peak = amplitude(&plane(&s, 0), 0.0, 15.0);
        assert!(worst < 1e-12 * peak, "planes differ by {worst:e} of {peak}");
        // ≈ the static deflection 10 N/(√2 m g) ≈ 2.2° per plane, overshooting.
        assert!(peak > 2f64.to_radians(), "{peak}");
        // Under the loops the bridge (150 kg, τ 50 ms) and the trolley (30 kg, 30 ms)
        // give a little differently to the rope's pull: the planes' peaks within 0.5 %
        // (measured 0.07 %, both 2.5°).
        let mut p = plant(gusty);
        let s = swing(&mut p, 15.0, false);
        let (a, b) = (
            amplitude(&plane(&s, 0), 0.0, 15.0),
            amplitude(&plane(&s, 1), 0.0, 15.0),
        );
        assert!((a / b - 1.0).abs() < 5e-3, "peaks {a} and {b} rad");
        assert!(a > 2f64.to_radians());
        // And a gust along x alone leaves the lateral plane still.
        let mut p = plant(Mismatch3d {
            gust_direction: 0.0,
            ..gusty
        });
        let s = swing(&mut p, 15.0, false);
        assert!(s.iter().all(|(_, a)| a[1] == 0.0));
    }

    #[test]
    fn the_sensed_slopes_are_the_flat_reference_s() {
        // Static deflected states of the flat 3D reference along a diagonal move with
        // hoisting: where the reference puts bridge, trolley and rope for the load at
        // z(t), the plant placed there with the reference's slopes has its load at z(t)
        // (to rounding: measured 1.8e-15 m; bound 1e-12 m), and reports those slopes.
        // A wrong definition (an angle from the vertical, Cardan angles, swapped planes)
        // puts the load elsewhere.
        let params = Crane3dParams::EXAMPLE;
        let z = PointToPoint::new(
            [12.0, 3.0, 8.0].into(),
            [20.0, 6.0, 4.0].into(),
            1.0,
            7.0,
            4,
        )
        .unwrap();
        let mm = Mismatch3d {
            drum_scale: 0.02,
            rope_offset: 0.1,
            ..Mismatch3d::NONE
        };
        let mut largest = [0.0f64; 2];
        let mut worst = 0.0f64;
        for t in [1.5, 2.2, 3.0, 4.5, 5.8, 6.5, 7.4] {
            let flat = flat_crane3d::flat_inverse(&params, &z, t);
            let [at] = z.derivatives::<1>(t);
            let zc: [f64; 3] = at.into();
            let l_drum = (flat.l - mm.rope_offset) / (1.0 + mm.drum_scale);
            let mut p = Plant3d::at_rest(
                flat.x,
                flat.y,
                l_drum,
                t,
                TAU,
                G,
                M,
                Mismatch3d {
                    swing0: flat.slope,
                    ..mm
                },
            );
            let load = p.load();
            for (a, b) in load.iter().zip(zc) {
                worst = worst.max((a - b).abs());
            }
            let sensed = p.sense();
            assert_eq!([sensed[3], sensed[4]], flat.slope, "t = {t}");
            // And the other way round: the definition on the plant's own state.
            let [xc, yc, zl] = load;
            let own = [(xc - p.q[0]).atan2(zl), (yc - p.q[1]).atan2(zl)];
            for (a, b) in own.iter().zip(flat.slope) {
                assert!((a - b).abs() < 1e-14, "t = {t}: {own:?} {:?}", flat.slope);
            }
            for (m, s) in largest.iter_mut().zip(flat.slope) {
                *m = m.max(s.abs());
            }
        }
        assert!(worst < 1e-12, "load off by {worst:e} m");
        // The states are deflected in both planes.
        assert!(largest.iter().all(|&s| s > 0.01), "{largest:?}");
    }

    #[test]
    fn same_seed_same_bits() {
        let run = |seed: u64| {
            let mut rng = Rng::new(seed);
            let mm = Mismatch3d::random(&mut rng, 6.0, (1.0, 6.0));
            let mut p = plant(mm);
            let mut bits = Vec::new();
            for k in 0..800 {
                let t = k as f64 * 0.01;
                let u = [
                    0.8 * (0.5 * t).sin(),
                    -0.5 * (0.3 * t).sin(),
                    0.2 * (0.7 * t).sin(),
                ];
                p.advance_braked(u, 0.01, [false, (3.0..3.5).contains(&t), false]);
                if let Some(late) = p.sense_late() {
                    bits.extend(late.map(f64::to_bits));
                }
                bits.extend(p.q.map(f64::to_bits));
                bits.extend(p.load().map(f64::to_bits));
            }
            (mm, bits)
        };
        let (a, bits_a) = run(7);
        let (b, bits_b) = run(7);
        assert_eq!(a, b);
        assert_eq!(bits_a, bits_b);
        let (c, bits_c) = run(8);
        assert_ne!(a, c);
        assert_ne!(bits_a, bits_c);
    }

    #[test]
    fn random_cases_stay_in_the_planar_study_s_ranges() {
        let mut rng = Rng::new(11);
        let mut lateral = false;
        for _ in 0..500 {
            let mm = Mismatch3d::random(&mut rng, 6.0, (1.0, 8.0));
            assert!(mm.tau.iter().all(|d| d.abs() <= 0.3));
            assert!(mm.load_mass.abs() <= 0.2);
            assert!(mm.drum_scale.abs() <= 0.02 && mm.rope_offset.abs() <= 0.12);
            let [c1, c2, c3] = mm.coulomb;
            assert!((0.0..=0.01).contains(&c1) && (0.0..=0.01).contains(&c2));
            assert!((0.0..=0.005).contains(&c3));
            assert!(mm.viscous.iter().all(|b| (0.0..=0.03).contains(b)));
            let g = mm.gust;
            assert!(g.amplitude.abs() <= 10.0 && (0.5..=3.0).contains(&g.duration));
            assert!(g.start >= 1.0 && g.start + g.duration <= 8.0);
            // The initial swing: at most 5° from the vertical, in any direction.
            let [a, b] = mm.swing0.map(f64::tan);
            let from_vertical = (a * a + b * b).sqrt().atan();
            assert!(from_vertical <= 5f64.to_radians() + 1e-12);
            lateral |= b.abs() > 3f64.to_radians().tan();
        }
        assert!(lateral);
    }

    #[test]
    fn at_rest_it_stays_at_rest_and_a_velocity_step_is_a_lag() {
        // The hoist's integral holds the load's weight from the first step.
        let mut p = plant(Mismatch3d {
            drum_scale: 0.02,
            rope_offset: 0.1,
            load_mass: 0.15,
            ..Mismatch3d::NONE
        });
        let start = p.q;
        for _ in 0..500 {
            p.advance([0.0; 3], 0.01);
        }
        for (a, b) in p.q.iter().zip(start) {
            assert!((a - b).abs() < 1e-9, "{:?}", p.q);
        }
        // Each axis follows a step like a lag of its (mismatched) τ: 63 % within half τ
        // either way, as the planar plant's test has it.
        let tau_err = [0.2, -0.2, 0.1];
        for axis in 0..3 {
            let mut p = plant(Mismatch3d {
                tau: tau_err,
                ..Mismatch3d::NONE
            });
            let mut u = [0.0; 3];
            u[axis] = 0.3;
            let tau = TAU[axis] * (1.0 + tau_err[axis]);
            let mut t63 = None;
            for k in 1..=500 {
                p.advance(u, PLANT_STEP);
                if t63.is_none() && p.q[5 + axis] >= 0.63 * 0.3 {
                    t63 = Some(k as f64 * PLANT_STEP);
                }
            }
            let t63 = t63.unwrap();
            assert!(
                (0.5 * tau..1.5 * tau).contains(&t63),
                "axis {axis}: 63 % after {t63} s, τ {tau} s"
            );
        }
    }

    /// The bridge's and the trolley's mean velocity over a swing period (a 6 m rope) of
    /// `p` driven by `u`, after 5 s at it.
    fn mean_travel_velocity(mut p: Plant3d, u: [f64; 3]) -> [f64; 2] {
        for _ in 0..5000 {
            p.advance(u, PLANT_STEP);
        }
        let period = 2.0 * PI * (6.0 / G).sqrt();
        let n = (period / PLANT_STEP).round() as usize;
        let (x0, y0) = (p.q[0], p.q[1]);
        for _ in 0..n {
            p.advance(u, PLANT_STEP);
        }
        let t = n as f64 * PLANT_STEP;
        [(p.q[0] - x0) / t, (p.q[1] - y0) / t]
    }

    #[test]
    fn p_only_loops_droop_and_a_hoist_tuned_for_the_model_s_load_lets_a_heavier_one_sink() {
        // The planar plant's options, per axis: the bridge and the trolley P only with
        // 10 mm/s and 3 % friction run at (u − c)/(1 + b) on average over a swing period;
        // the P-only hoist tuned for the model's load sinks under a 20 % heavier one at
        // Δm g k / kp. From the planar mismatch the bridge and the hoist take them.
        let mm = Mismatch3d {
            coulomb: [0.01, 0.01, 0.0],
            viscous: [0.03, 0.03, 0.0],
            proportional_only: [true; 3],
            load_mass: 0.2,
            loops_for_model_load: true,
            ..Mismatch3d::NONE
        };
        let u = [0.5, 0.3, 0.0];
        let mean = mean_travel_velocity(plant(mm), u);
        for (m, u) in mean.iter().zip(u) {
            assert!((m - (u - 0.01) / 1.03).abs() < 1e-3, "{mean:?}");
        }
        // The sink with the load hanging still (the travel's swing adds its centripetal
        // pull to the rope's tension).
        let mut p = plant(mm);
        p.advance([0.0; 3], 2.0);
        let sink = 0.2 * M * G / ((WINCH_MASS + M) / TAU[2]);
        assert!((p.q[7] / sink - 1.0).abs() < 1e-3, "{} m/s", p.q[7]);
        let planar = Mismatch {
            proportional_only: [true, true],
            loops_for_model_load: true,
            ..Mismatch::NONE
        };
        let from = Mismatch3d::from_planar(&planar);
        assert_eq!(from.proportional_only, [true, false, true]);
        assert!(from.loops_for_model_load);
    }

    #[test]
    fn the_planar_trolley_s_errors_go_to_the_3d_travel_drives_the_mismatch_names() {
        // A P-only travel drive with 10 mm/s and 3 % friction and 1.5 times the model's
        // lag, taken by the bridge, the trolley or both: a drive that takes it runs at
        // (u − c)/(1 + b) on average over a swing period, one that does not at u.
        let planar = Mismatch {
            tau1: 0.5,
            coulomb: [0.01, 0.0],
            viscous: [0.03, 0.0],
            proportional_only: [true, false],
            ..Mismatch::NONE
        };
        let u = [0.5, 0.3, 0.0];
        for (travel, taken) in [
            (Travel3d::Bridge, [true, false]),
            (Travel3d::Trolley, [false, true]),
            (Travel3d::Both, [true, true]),
        ] {
            let mm = Mismatch3d::from_planar(&Mismatch {
                travel_3d: travel,
                ..planar
            });
            let lag = |on: bool| if on { 0.5 } else { 0.0 };
            assert_eq!(mm.tau, [lag(taken[0]), lag(taken[1]), 0.0], "{travel:?}");
            assert_eq!(mm.proportional_only, [taken[0], taken[1], false]);
            let mean = mean_travel_velocity(plant(mm), u);
            for ((m, u), on) in mean.iter().zip(u).zip(taken) {
                let expected = if on { (u - 0.01) / 1.03 } else { u };
                assert!((m - expected).abs() < 1e-3, "{travel:?}: {mean:?}");
            }
        }
    }
}
