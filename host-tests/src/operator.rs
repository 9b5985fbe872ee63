//! Operator mode's generator ([`solver_core::operator`]) driven by scripted and random
//! sticks on both cranes: the drives' motion from the exact flat inverse of the path, the
//! inverse model driven by the generator, nonlinear forward simulations of the plants —
//! what the generator's tests (`tests/operator_generator.rs`) and its study
//! (`operator_study`) share.
//!
//! Axes are kept in three slots everywhere, `[x, y, z]`: the 3D crane's bridge, trolley
//! and hoist; the planar crane uses `x` and `z` (its trolley and winch) and leaves `y` at
//! zero.

use controller::setpoint::{AxisLimits, DriveLimits};
use nalgebra::SVector;
use sim::plant::Rng;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::{subs, Crane3dParams, Crane3dSubs};
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::operator::{Cycle, Demand, Generator3d, PlanarGenerator, Settings};
use solver_core::reference::dopri5::{Dopri5, Dopri5Settings};
use solver_core::reference::plant::{crane_rhs, simulate, SampledInput};
use solver_core::reference::{flat_crane, flat_crane3d};
use solver_core::trajectory::Trajectory;
use solver_core::{Driven, Error, JacobianMode, SolverSettings};

/// Which crane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Crane {
    /// The paper's planar crane: trolley and winch.
    Planar(CraneParams),
    /// The 3D crane: bridge, trolley, hoist.
    Spatial(Crane3dParams),
}

impl Crane {
    /// The lab cranes.
    pub const PLANAR: Self = Self::Planar(CraneParams::PAPER);
    /// The 3D lab crane.
    pub const SPATIAL: Self = Self::Spatial(Crane3dParams::EXAMPLE);

    /// Its name in tables.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::Planar(_) => "planar",
            Self::Spatial(_) => "3D",
        }
    }

    /// The drives' limits in the slots `[x, y, z]` (the planar crane's y: none).
    #[must_use]
    pub fn limits(&self) -> [AxisLimits; 3] {
        match self {
            Self::Planar(_) => {
                let l = DriveLimits::LAB;
                let none = AxisLimits {
                    max_velocity: f64::INFINITY,
                    max_acceleration: f64::INFINITY,
                };
                [l.trolley, none, l.winch]
            }
            Self::Spatial(_) => DriveLimits::LAB_3D,
        }
    }

    /// The drives' ranges `[x, y, l]` (the planar crane's y: unbounded).
    #[must_use]
    pub fn ranges(&self) -> [(f64, f64); 3] {
        match self {
            Self::Planar(p) => {
                let w = p.workspace;
                [
                    (w.x_min, w.x_max),
                    (f64::NEG_INFINITY, f64::INFINITY),
                    (w.l_min, w.l_max),
                ]
            }
            Self::Spatial(p) => {
                let w = p.workspace;
                [(w.x_min, w.x_max), (w.y_min, w.y_max), (w.l_min, w.l_max)]
            }
        }
    }

    /// Gravity and the rope-slack limit of the load's downward acceleration.
    #[must_use]
    pub fn slack_limit(&self) -> f64 {
        match self {
            Self::Planar(p) => p.g * (1.0 - p.min_tension_fraction),
            Self::Spatial(p) => p.g * (1.0 - p.min_tension_fraction),
        }
    }

    /// The drive time constants `[τ_x, τ_y, τ_z]`.
    #[must_use]
    pub fn taus(&self) -> [f64; 3] {
        match self {
            Self::Planar(p) => [p.tau1, 0.0, p.tau2],
            Self::Spatial(p) => [p.tau1, p.tau2, p.tau3],
        }
    }

    /// Gravity.
    #[must_use]
    pub fn g(&self) -> f64 {
        match self {
            Self::Planar(p) => p.g,
            Self::Spatial(p) => p.g,
        }
    }

    /// A generator with the lab manual-mode settings (robust or not), at rest with the
    /// load at `at` (`[x, y, depth]`) at t = 0.
    pub fn start(&self, robust: bool, at: [f64; 3]) -> Result<Gen, Error> {
        match self {
            Self::Planar(p) => {
                let mut s = Settings::lab(p);
                s.robust = robust;
                Ok(Gen::Planar(PlanarGenerator::at_rest(
                    s,
                    0.0,
                    [at[0]],
                    at[2],
                )?))
            }
            Self::Spatial(p) => {
                let mut s = Settings::lab_3d(p);
                s.robust = robust;
                Ok(Gen::Spatial(Generator3d::at_rest(
                    s,
                    0.0,
                    [at[0], at[1]],
                    at[2],
                )?))
            }
        }
    }
}

/// A generator of either crane.
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub enum Gen {
    /// Planar.
    Planar(PlanarGenerator),
    /// 3D.
    Spatial(Generator3d),
}

/// Where the drives are and how they move when the load follows the path exactly (the
/// flat inverse), in the slots `[x, y, z]`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Flat {
    /// Drive positions `[x, y, l]`, m.
    pub drives: [f64; 3],
    /// Set points u, m/s.
    pub u: [f64; 3],
    /// Their rates u̇, m/s².
    pub u_dot: [f64; 3],
    /// The rope's force per unit mass λ (negative: tension), 1/s².
    pub lambda: f64,
}

impl Flat {
    /// The planar crane's exact flat inverse of the path `z` at `t`.
    #[must_use]
    pub fn planar(p: &CraneParams, z: &impl Trajectory<f64, 2>, t: f64) -> Self {
        let f = flat_crane::flat_inverse(p, z, t);
        Self {
            drives: [f.x, 0.0, f.l],
            u: [f.u[0], 0.0, f.u[1]],
            u_dot: [f.u_dot[0], 0.0, f.u_dot[1]],
            lambda: f.lambda,
        }
    }

    /// The 3D crane's exact flat inverse of the path `z` at `t`.
    #[must_use]
    pub fn spatial(p: &Crane3dParams, z: &impl Trajectory<f64, 3>, t: f64) -> Self {
        let f = flat_crane3d::flat_inverse(p, z, t);
        Self {
            drives: [f.x, f.y, f.l],
            u: f.u,
            u_dot: f.u_dot,
            lambda: f.lambda,
        }
    }
}

impl Gen {
    /// One cycle with the stick `[x, y, z]` (the planar crane ignores y).
    pub fn advance(&mut self, stick: [f64; 3]) -> Cycle {
        let [x, y, z] = stick;
        match self {
            Self::Planar(g) => g.advance(&Demand {
                horizontal: [x],
                hoist: z,
            }),
            Self::Spatial(g) => g.advance(&Demand {
                horizontal: [x, y],
                hoist: z,
            }),
        }
    }

    /// Start of the current cycle.
    #[must_use]
    pub fn time(&self) -> f64 {
        match self {
            Self::Planar(g) => g.time(),
            Self::Spatial(g) => g.time(),
        }
    }

    /// The load path's derivatives 0..D−1 at `t`, slots `[x, y, z]`.
    #[must_use]
    pub fn load<const D: usize>(&self, t: f64) -> [[f64; 3]; D] {
        match self {
            Self::Planar(g) => {
                let d: [SVector<f64, 2>; D] = g.derivatives(t);
                d.map(|v| [v[0], 0.0, v[1]])
            }
            Self::Spatial(g) => {
                let d: [SVector<f64, 3>; D] = g.derivatives(t);
                d.map(|v| [v[0], v[1], v[2]])
            }
        }
    }

    /// The flat inverse at `t`.
    #[must_use]
    pub fn flat(&self, crane: &Crane, t: f64) -> Flat {
        match (self, crane) {
            (Self::Planar(g), Crane::Planar(p)) => Flat::planar(p, g, t),
            (Self::Spatial(g), Crane::Spatial(p)) => Flat::spatial(p, g, t),
            _ => Flat::default(),
        }
    }

    /// Whether the path is at rest on the current cycle.
    #[must_use]
    pub fn is_at_rest(&self) -> bool {
        match self {
            Self::Planar(g) => g.is_at_rest(),
            Self::Spatial(g) => g.is_at_rest(),
        }
    }

    /// The rate limiter's speeds `[x, y, z]` at the end of the current cycle.
    #[must_use]
    pub fn limiter(&self) -> [f64; 3] {
        match self {
            Self::Planar(g) => {
                let ([x], z) = g.demanded_speeds();
                [x, 0.0, z]
            }
            Self::Spatial(g) => {
                let ([x, y], z) = g.demanded_speeds();
                [x, y, z]
            }
        }
    }

    /// The horizontal filter's mean lag τ̄ and the hoist's, s.
    #[must_use]
    pub fn lags(&self) -> (f64, f64) {
        let t = match self {
            Self::Planar(g) => g.tuning(),
            Self::Spatial(g) => g.tuning(),
        };
        (t.lag, t.hoist_lag)
    }

    /// The generator pendulum's length `l_g`, m.
    #[must_use]
    pub fn pendulum(&self) -> f64 {
        match self {
            Self::Planar(g) => g.tuning().pendulum,
            Self::Spatial(g) => g.tuning().pendulum,
        }
    }

    /// The settings' accelerations `[A_x, A_y, A_z]` and speeds (planar y: 0).
    #[must_use]
    pub fn limits(&self) -> ([f64; 3], [f64; 3]) {
        match self {
            Self::Planar(g) => {
                let s = g.settings();
                (
                    [s.horizontal[0].acceleration, 0.0, s.hoist.acceleration],
                    [s.horizontal[0].speed, 0.0, s.hoist.speed],
                )
            }
            Self::Spatial(g) => {
                let s = g.settings();
                (
                    [
                        s.horizontal[0].acceleration,
                        s.horizontal[1].acceleration,
                        s.hoist.acceleration,
                    ],
                    [s.horizontal[0].speed, s.horizontal[1].speed, s.hoist.speed],
                )
            }
        }
    }
}

/// One cycle of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Record {
    /// Cycle index.
    pub n: usize,
    /// Start of the cycle, s.
    pub t: f64,
    /// The stick.
    pub stick: [f64; 3],
    /// The load path's position, speed, acceleration at the cycle's start.
    pub load: [[f64; 3]; 3],
    /// The flat inverse at the cycle's start and at its middle.
    pub flat: [Flat; 2],
    /// The rate limiter's speeds at the cycle's start (before its step).
    pub limiter: [f64; 3],
    /// The path is at rest on this cycle.
    pub at_rest: bool,
    /// A demand was refused.
    pub refused: bool,
}

/// Drives `gen` for `cycles` cycles with `stick(n)`, calling `each` with every cycle.
pub fn drive(
    crane: &Crane,
    gen: &mut Gen,
    cycles: usize,
    mut stick: impl FnMut(usize) -> [f64; 3],
    mut each: impl FnMut(&Record),
) {
    for n in 0..cycles {
        let s = stick(n);
        let limiter = gen.limiter();
        let c = gen.advance(s);
        let t = gen.time();
        let h = 0.01;
        each(&Record {
            n,
            t,
            stick: s,
            load: gen.load::<3>(t),
            flat: [gen.flat(crane, t), gen.flat(crane, t + 0.5 * h)],
            limiter,
            at_rest: c.at_rest,
            refused: c.refused_demand,
        });
    }
}

/// The worst of a run against the crane's limits: per slot the largest `|u|`, `|u̇|` and
/// set-point change per cycle over h (what the gate checks), the farthest a drive went
/// outside its range (m, ≤ 0 when inside), the least rope tension margin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extremes {
    /// Largest |u| per slot, m/s.
    pub u: [f64; 3],
    /// Largest |u̇| per slot (start and middle of each cycle), m/s².
    pub u_dot: [f64; 3],
    /// Largest `|u_{n+1} − u_n|/h` per slot, m/s².
    pub du: [f64; 3],
    /// Largest excursion beyond a drive range (negative: the nearest approach), m.
    pub outside: f64,
    /// Largest downward load acceleration, m/s².
    pub down: f64,
    /// Largest λ (must stay negative: the rope in tension), 1/s².
    pub lambda: f64,
    /// Whether any value was not a number.
    pub non_finite: bool,
    last_u: Option<[f64; 3]>,
}

impl Default for Extremes {
    fn default() -> Self {
        Self {
            u: [0.0; 3],
            u_dot: [0.0; 3],
            du: [0.0; 3],
            outside: f64::NEG_INFINITY,
            down: f64::NEG_INFINITY,
            lambda: f64::NEG_INFINITY,
            non_finite: false,
            last_u: None,
        }
    }
}

impl Extremes {
    /// Takes one cycle into account.
    pub fn add(&mut self, crane: &Crane, r: &Record) {
        let ranges = crane.ranges();
        for f in &r.flat {
            for (i, (lo, hi)) in ranges.iter().enumerate() {
                self.u[i] = self.u[i].max(f.u[i].abs());
                self.u_dot[i] = self.u_dot[i].max(f.u_dot[i].abs());
                self.outside = self.outside.max(lo - f.drives[i]).max(f.drives[i] - hi);
                self.non_finite |= !f.u[i].is_finite() || !f.u_dot[i].is_finite();
            }
            self.lambda = self.lambda.max(f.lambda);
        }
        self.down = self.down.max(r.load[2][2]);
        let u = r.flat[0].u;
        if let Some(last) = self.last_u {
            for i in 0..3 {
                self.du[i] = self.du[i].max((u[i] - last[i]).abs() / 0.01);
            }
        }
        self.last_u = Some(u);
    }

    /// Takes another run's extremes into account.
    pub fn merge(&mut self, o: &Self) {
        for i in 0..3 {
            self.u[i] = self.u[i].max(o.u[i]);
            self.u_dot[i] = self.u_dot[i].max(o.u_dot[i]);
            self.du[i] = self.du[i].max(o.du[i]);
        }
        self.outside = self.outside.max(o.outside);
        self.down = self.down.max(o.down);
        self.lambda = self.lambda.max(o.lambda);
        self.non_finite |= o.non_finite;
    }

    /// The largest share of a drive limit used: `max(|u|/V, |u̇|/A, |Δu|/(A h))` over the
    /// slots.
    #[must_use]
    pub fn share(&self, crane: &Crane) -> f64 {
        let l = crane.limits();
        (0..3)
            .map(|i| {
                let v = self.u[i] / l[i].max_velocity;
                let a = self.u_dot[i].max(self.du[i]) / l[i].max_acceleration;
                v.max(a)
            })
            .fold(0.0, f64::max)
    }
}

/// A random stick: per axis a level held for a random time (0.05–3 s), levels full stick,
/// zero, anything between, or noise near the deadband; the planar crane's y stays zero.
#[derive(Debug, Clone)]
pub struct RandomStick {
    rng: Rng,
    level: [f64; 3],
    until: [usize; 3],
    noise: [bool; 3],
    planar: bool,
}

impl RandomStick {
    /// A sequence from `seed`.
    #[must_use]
    pub fn new(seed: u64, planar: bool) -> Self {
        Self {
            rng: Rng::new(seed),
            level: [0.0; 3],
            until: [0; 3],
            noise: [false; 3],
            planar,
        }
    }

    /// The stick at cycle `n` (cycles of 10 ms).
    pub fn at(&mut self, n: usize) -> [f64; 3] {
        for i in 0..3 {
            if self.planar && i == 1 {
                continue;
            }
            if n >= self.until[i] {
                let r = self.rng.unit();
                self.level[i] = if r < 0.3 {
                    if self.rng.unit() < 0.5 {
                        1.0
                    } else {
                        -1.0
                    }
                } else if r < 0.5 {
                    0.0
                } else {
                    self.rng.uniform(-1.0, 1.0)
                };
                self.noise[i] = self.rng.unit() < 0.1;
                self.until[i] = n + (self.rng.uniform(0.05, 3.0) / 0.01) as usize;
            }
        }
        let mut s = self.level;
        for (si, noisy) in s.iter_mut().zip(self.noise) {
            if noisy {
                *si = self.rng.uniform(-0.1, 0.1);
            }
        }
        s
    }
}

/// The 3D crane's plant with ideal first-order drive lags and an exact spherical
/// pendulum whose length is the rope's plus `offset` (rigging). State
/// `[x, y, l, ẋ, ẏ, l̇, e, ė]`, `e` the rope's unit vector from the trolley down to the
/// load (z down): the load is at `(x, y, 0) + (l + offset) e`, and with
/// `f = g e_z − s̈` (s̈ the trolley's acceleration) the load's equation perpendicular to
/// the rope gives `ë = ((f − (f·e) e) − 2 L̇ ė)/L − |ė|² e` (the planar crane's
/// `φ̈ = (−g sin φ − 2 l̇ φ̇ − ẍ cos φ)/l` in its plane).
#[must_use]
pub fn rhs3d(
    p: &Crane3dParams,
    offset: f64,
    y: &SVector<f64, 12>,
    u: &SVector<f64, 3>,
) -> SVector<f64, 12> {
    let v = |i: usize| y[i];
    let (ax, ay, al) = (
        (u[0] - v(3)) / p.tau1,
        (u[1] - v(4)) / p.tau2,
        (u[2] - v(5)) / p.tau3,
    );
    let e = [v(6), v(7), v(8)];
    let w = [v(9), v(10), v(11)];
    let length = v(2) + offset;
    let f = [-ax, -ay, p.g];
    let fe = f[0] * e[0] + f[1] * e[1] + f[2] * e[2];
    let ww = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    let mut out = SVector::<f64, 12>::zeros();
    out[0] = v(3);
    out[1] = v(4);
    out[2] = v(5);
    out[3] = ax;
    out[4] = ay;
    out[5] = al;
    for i in 0..3 {
        out[6 + i] = w[i];
        out[9 + i] = (f[i] - fe * e[i] - 2.0 * v(5) * w[i]) / length - ww * e[i];
    }
    out
}

/// The 3D plant's load position and slopes `[atan2(e_x, e_z), atan2(e_y, e_z)]`.
#[must_use]
pub fn load3d(offset: f64, y: &SVector<f64, 12>) -> ([f64; 3], [f64; 2]) {
    let length = y[2] + offset;
    (
        [y[0] + length * y[6], y[1] + length * y[7], length * y[8]],
        [y[6].atan2(y[8]), y[7].atan2(y[8])],
    )
}

/// A forward simulation's samples: per cycle the load position `[x, y, z]` and the
/// swing angles `[x–z, y–z]`, rad.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    /// Load positions.
    pub load: Vec<[f64; 3]>,
    /// Swing angles.
    pub swing: Vec<[f64; 2]>,
}

/// How the set points reach the plant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hold {
    /// Joined by piecewise-cubic interpolation (the paper's check, `reference::plant`).
    Cubic,
    /// Each held for its cycle (a drive that does not interpolate).
    Zero,
}

/// How the plant's pendulum differs from the model's rope: it is `scale · rope + offset`
/// long. An offset is rigging (hook block, sling) the model leaves out: the same length
/// whatever the rope, so its share of the pendulum grows as the hoist raises. A scale is
/// the drum's calibration off: the rope pays out `scale` times what the model counts,
/// so the error is the same share at every rope length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pendulum {
    /// The plant's rope per model rope.
    pub scale: f64,
    /// Added to the plant's pendulum, m.
    pub offset: f64,
}

impl Pendulum {
    /// The model's own pendulum.
    pub const MODEL: Self = Self {
        scale: 1.0,
        offset: 0.0,
    };

    /// The pendulum `offset` longer than the rope (rigging).
    #[must_use]
    pub const fn longer_by(offset: f64) -> Self {
        Self { scale: 1.0, offset }
    }

    /// The pendulum `scale` times the rope (the drum's scaling).
    #[must_use]
    pub const fn scaled(scale: f64) -> Self {
        Self { scale, offset: 0.0 }
    }
}

/// Simulates the crane's nonlinear plant, at rest at `start` (load `[x, y, depth]`) with
/// the pendulum `pendulum` off the model's rope, under the set points `u` (one per cycle
/// from t = 0, slots `[x, y, z]`; the hoist's set point scaled as the plant's drum pays
/// out). The load's depth is recorded in the model's measure, `(L cos φ − offset)/scale`.
pub fn simulate_plant(
    crane: &Crane,
    start: [f64; 3],
    pendulum: Pendulum,
    u: &[[f64; 3]],
    hold: Hold,
) -> Result<Motion, Error> {
    let Pendulum { scale, offset } = pendulum;
    let h = 0.01;
    let mut motion = Motion {
        load: Vec::with_capacity(u.len()),
        swing: Vec::with_capacity(u.len()),
    };
    match crane {
        Crane::Planar(p) => {
            let samples: Vec<SVector<f64, 2>> = u
                .iter()
                .map(|v| SVector::from([v[0], v[2] * scale]))
                .collect();
            let y0 = SVector::from([start[0], start[2] * scale + offset, 0.0, 0.0, 0.0, 0.0]);
            let mut record = |y: &SVector<f64, 6>| {
                let [x, l, phi, ..]: [f64; 6] = (*y).into();
                motion
                    .load
                    .push([x + l * phi.sin(), 0.0, (l * phi.cos() - offset) / scale]);
                motion.swing.push([phi, 0.0]);
            };
            match hold {
                Hold::Cubic => {
                    let input = SampledInput::new(0.0, h, &samples);
                    simulate(|y, u| crane_rhs(p, y, u), y0, &input, |_, _, y| record(y))?;
                }
                Hold::Zero => held(y0, &samples, h, |y, u| crane_rhs(p, y, u), &mut record)?,
            }
        }
        Crane::Spatial(p) => {
            let samples: Vec<SVector<f64, 3>> = u
                .iter()
                .map(|v| SVector::from([v[0], v[1], v[2] * scale]))
                .collect();
            let mut y0 = SVector::<f64, 12>::zeros();
            y0[0] = start[0];
            y0[1] = start[1];
            y0[2] = start[2] * scale;
            y0[8] = 1.0;
            let mut record = |y: &SVector<f64, 12>| {
                let (mut load, swing) = load3d(offset, y);
                load[2] = (load[2] - offset) / scale;
                motion.load.push(load);
                motion.swing.push(swing);
            };
            match hold {
                Hold::Cubic => {
                    let input = SampledInput::new(0.0, h, &samples);
                    simulate(
                        |y, u| rhs3d(p, offset, y, u),
                        y0,
                        &input,
                        |_, _, y| record(y),
                    )?;
                }
                Hold::Zero => held(y0, &samples, h, |y, u| rhs3d(p, offset, y, u), &mut record)?,
            }
        }
    }
    Ok(motion)
}

/// Integrates under set points held for each cycle.
fn held<const D: usize, const NU: usize>(
    y0: SVector<f64, D>,
    samples: &[SVector<f64, NU>],
    h: f64,
    rhs: impl Fn(&SVector<f64, D>, &SVector<f64, NU>) -> SVector<f64, D>,
    record: &mut impl FnMut(&SVector<f64, D>),
) -> Result<(), Error> {
    let mut ode = Dopri5::new(
        0.0,
        y0,
        h / 4.0,
        Dopri5Settings {
            rtol: 1e-11,
            atol: 1e-13,
            max_steps: 100_000,
        },
    );
    record(&y0);
    for (n, u) in samples.iter().enumerate().skip(1) {
        // The set point computed for t_n is applied from t_n on.
        let prev = samples.get(n - 1).copied().unwrap_or(*u);
        let y = ode.advance_to(n as f64 * h, &mut |_, y| rhs(y, &prev))?;
        record(&y);
    }
    Ok(())
}

/// The set points of a run: the exact flat inverse of the path at every cycle's start.
#[must_use]
pub fn flat_set_points(records: &[Record]) -> Vec<[f64; 3]> {
    records.iter().map(|r| r.flat[0].u).collect()
}

/// The inverse model (*subs*, the firmware's structured BDF4 at 10 ms) driven by the
/// generator `gen`, one cycle at a time with `stick(n)`: the set points per cycle (the
/// first, at t = 0, at rest) and the cycle at which the generator came to rest for good
/// (`None` if it did not).
pub fn inverse_model_run(
    crane: &Crane,
    gen: Gen,
    cycles: usize,
    mut stick: impl FnMut(usize) -> [f64; 3],
) -> Result<(Vec<[f64; 3]>, Option<usize>), Error> {
    let settings = SolverSettings::paper(JacobianMode::Exact);
    let mut u = Vec::with_capacity(cycles + 1);
    u.push([0.0; 3]);
    let mut rest = None;
    let note = |n: usize, c: Cycle, rest: &mut Option<usize>| {
        if !c.at_rest {
            *rest = None;
        } else if rest.is_none() {
            *rest = Some(n);
        }
    };
    match (crane, gen) {
        (Crane::Planar(p), Gen::Planar(g)) => {
            let mut model = CraneSubs::new(*p, g)?;
            let mut bdf = crane_subs::StructuredBdf::new(&model, &settings, 4, 0.0)?;
            for n in 0..cycles {
                let [x, _, z] = stick(n);
                let c = model.trajectory_mut().advance(&Demand {
                    horizontal: [x],
                    hoist: z,
                });
                note(n, c, &mut rest);
                let r = bdf.step(&model)?;
                u.push([r.u[0], 0.0, r.u[1]]);
            }
        }
        (Crane::Spatial(p), Gen::Spatial(g)) => {
            let mut model = Crane3dSubs::new(*p, g)?;
            let mut bdf = subs::StructuredBdf::new(&model, &settings, 4, 0.0)?;
            for n in 0..cycles {
                let [x, y, z] = stick(n);
                let c = model.trajectory_mut().advance(&Demand {
                    horizontal: [x, y],
                    hoist: z,
                });
                note(n, c, &mut rest);
                let r = bdf.step(&model)?;
                u.push([r.u[0], r.u[1], r.u[2]]);
            }
        }
        _ => {
            return Err(Error::InvalidSetting {
                name: "crane and generator differ",
                value: 0.0,
            })
        }
    }
    Ok((u, rest))
}

/// From cycle `from` on: the largest distance of the plant's load from `rest` in each
/// slot, m, and the largest swing per plane, rad.
#[must_use]
pub fn residual(motion: &Motion, from: usize, rest: [f64; 3]) -> ([f64; 3], [f64; 2]) {
    let mut dist = [0.0_f64; 3];
    let mut swing = [0.0_f64; 2];
    for (l, s) in motion.load.iter().zip(&motion.swing).skip(from) {
        for i in 0..3 {
            dist[i] = dist[i].max((l[i] - rest[i]).abs());
        }
        for i in 0..2 {
            swing[i] = swing[i].max(s[i].abs());
        }
    }
    (dist, swing)
}

/// The property test's random sequences as the study prints them: the worst share of a
/// drive limit, the nearest approach to a range's end (positive: outside), the largest
/// λ (negative: tension).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RandomSummary {
    /// Sequences run.
    pub sequences: usize,
    /// The worst of all.
    pub worst: Extremes,
    /// The largest share of a drive limit and the sequence it came from.
    pub share: (f64, usize),
}

/// `sequences` random stick sequences of 12 s on `crane` from random starts (a tenth next
/// to a limit) at random rope lengths, seeded by `seed`.
#[must_use]
pub fn random_sequences(crane: &Crane, seed: u64, sequences: usize) -> RandomSummary {
    let planar = matches!(crane, Crane::Planar(_));
    let mut rng = Rng::new(seed);
    let ranges = crane.ranges();
    let mut worst = Extremes::default();
    let mut share = (0.0, 0);
    for seq in 0..sequences {
        let depth = rng.uniform(3.0, 8.95);
        let mut at = |i: usize| {
            let (lo, hi) = ranges[i];
            if rng.unit() < 0.1 {
                if rng.unit() < 0.5 {
                    lo + rng.uniform(0.0, 0.3)
                } else {
                    hi - rng.uniform(0.0, 0.3)
                }
            } else {
                rng.uniform(lo, hi)
            }
        };
        let x = at(0);
        let y = if planar { 0.0 } else { at(1) };
        let Ok(mut g) = crane.start(false, [x, y, depth]) else {
            worst.non_finite = true;
            continue;
        };
        let mut stick = RandomStick::new(rng.next_u64(), planar);
        let mut e = Extremes::default();
        drive(crane, &mut g, 1200, |n| stick.at(n), |r| e.add(crane, r));
        let s = e.share(crane);
        if s > share.0 {
            share = (s, seq);
        }
        worst.merge(&e);
    }
    RandomSummary {
        sequences,
        worst,
        share,
    }
}
