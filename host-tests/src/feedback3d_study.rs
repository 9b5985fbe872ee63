//! The closed loop of Fig. 1 for the crane in three dimensions, on a plant that is not
//! the model ([`crate::plant3d`]): feedforward only against feedforward + the state
//! feedback per vertical plane ([`controller::feedback3d`]), Monte Carlo over the
//! mismatch and disturbance ranges of the planar study ([`crate::feedback_study`]), in
//! both planes, on the diagonal move and on random moves (hoisting while travelling,
//! short and long ropes); a gust at rest from any direction.

use controller::commissioning::Swing;
use controller::correction::Measured;
use controller::feedback::{clamp_to_limits, Config, Gains, Mode, Reference};
use controller::feedback3d::SpatialFeedback;
use controller::setpoint::{AxisLimits, DriveLimits};
use controller::InverseModel;
use scene::cranes::spatial::Spatial;
use solver_core::models::crane3d::{subs, Crane3dParams, Crane3dSubs};
use solver_core::trajectory::{PointToPoint, Trajectory};
use solver_core::{Driven, Error, JacobianMode, SolverSettings};

use crate::feedback_study::{period, quantile, Calibration};
use crate::plant::{Gust, Rng};
use crate::plant3d::{Mismatch3d, Plant3d};
use controller::rope::{InclinometerLag, Learnt};

/// The 3D inverse model's solution over a whole run: what the controller has every cycle.
#[derive(Debug, Clone)]
pub struct ReferenceRun3 {
    /// Time of the first sample, s.
    pub t0: f64,
    /// Period, s.
    pub h: f64,
    /// Feedforward `u_d` per cycle (bridge, trolley, hoist), m/s.
    pub u: Vec<[f64; 3]>,
    /// Reference state per cycle, per plane (x–z, y–z).
    pub r: Vec<[Reference; 2]>,
    /// Desired load position per cycle.
    pub z: Vec<[f64; 3]>,
    /// Start and end of the move, s.
    pub span: (f64, f64),
    /// The target `[x_C, y_C, z_C]`.
    pub target: [f64; 3],
}

/// Runs the 3D inverse model (*subs*, BDF4, exact Jacobian, h = 10 ms: the 3D firmware
/// scene's solver) along `z` from rest at `t0` for `steps` cycles.
pub fn reference_run(
    params: Crane3dParams,
    z: PointToPoint<f64, 3>,
    t0: f64,
    steps: usize,
) -> Result<ReferenceRun3, Error> {
    let settings = SolverSettings::paper(JacobianMode::Exact);
    let model = Crane3dSubs::<f64, _>::new(params, z)?;
    type Move = PointToPoint<f64, 3>;
    let integrator = subs::Bdf::<f64, Move>::new(&model, &settings, 4, t0)?;
    let mut inv: InverseModel<Spatial, _, _, f64, { subs::N }> =
        InverseModel::new(model, integrator);
    let mut run = ReferenceRun3 {
        t0,
        h: settings.h,
        u: Vec::with_capacity(steps + 1),
        r: Vec::with_capacity(steps + 1),
        z: Vec::with_capacity(steps + 1),
        span: (z.t_start(), z.t_start() + z.duration()),
        target: z.end().into(),
    };
    for k in 0..=steps {
        if k > 0 {
            inv.integrator.step(&inv.model)?;
        }
        // y = [x, y, l, ẋ, ẏ, l̇, λ, u1, u2, u3]; each plane's reference as the planar
        // crane's in that plane (the 3D crane's controller::feedforward::CraneReference).
        let y: [f64; subs::N] = inv.integrator.state().into();
        let t = inv.integrator.time();
        let [p, v] = inv.model.trajectory().derivatives::<2>(t);
        let [xc, yc, zc]: [f64; 3] = p.into();
        let [vxc, vyc, vzc]: [f64; 3] = v.into();
        let [x, yy, l, vx, vy, vl, _, u1, u2, u3] = y;
        run.r.push([
            Reference::from_subs([x, l, vx, vl], [xc, zc], [vxc, vzc]),
            Reference::from_subs([yy, l, vy, vl], [yc, zc], [vyc, vzc]),
        ]);
        run.u.push([u1, u2, u3]);
        run.z.push([xc, yc, zc]);
    }
    Ok(run)
}

/// What one run of a case measured.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CaseResult3 {
    /// Largest horizontal load tracking error during the move, m.
    pub tracking: f64,
    /// Largest distance from the target per direction (x, y, z) from 5 s after the move
    /// over one swing period, m.
    pub distance: [f64; 3],
    /// Largest swing per plane (x–z, y–z) then, degrees.
    pub swing_deg: [f64; 2],
    /// Largest |u| per drive sent, m/s.
    pub max_u: [f64; 3],
    /// Largest |Δu|/h per drive sent, m/s².
    pub max_du: [f64; 3],
    /// Largest |u| sent from 5 s after the move to the end, m/s (zero: the drives hold).
    pub at_rest_u: f64,
    /// The rope's scaling error and offset the x–z plane's feedback learnt (zero without
    /// feedback).
    pub rope: (f64, f64),
    /// The feedback's mode at the end (`None` without feedback).
    pub mode: Option<Mode>,
}

impl CaseResult3 {
    /// Within ±50 mm horizontally (x and y) and the swing below 0.1° in both planes 5 s
    /// after the move.
    pub fn meets_target(&self) -> bool {
        let [dx, dy, _] = self.distance;
        dx <= 0.05 && dy <= 0.05 && self.swing_deg.iter().all(|s| *s < 0.1)
    }

    /// [`Self::meets_target`] and within ±50 mm vertically too.
    pub fn meets_target_in_all_directions(&self) -> bool {
        self.meets_target() && self.distance[2] <= 0.05
    }

    /// Whether the set points were exactly zero as the drives receive them (whole µm/s)
    /// from 5 s after the move.
    pub fn at_rest_zero(&self) -> bool {
        self.at_rest_u * controller::setpoint::UNITS_PER_M_PER_S < 0.5
    }
}

/// The 3D crane's state-feedback configuration: the planar study's weights and
/// thresholds with the x–z plane's lags (bridge, hoist).
pub fn config(params: &Crane3dParams, h: f64) -> Config {
    Config {
        g: params.g,
        tau1: params.tau1,
        tau2: params.tau3,
        h,
        ..Config::PAPER
    }
}

/// The two planes' gains for `params` ([`SpatialFeedback::design`]).
pub fn design(params: &Crane3dParams) -> Result<[Gains; 2], String> {
    SpatialFeedback::design(&config(params, 0.01), params.tau2).map_err(|e| format!("{e:?}"))
}

/// What goes wrong with the two-axis inclinometer from a time on (s). Both slopes come
/// in one TPDO: a lost inclinometer loses both; one axis alone fails by freezing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SlopeFault {
    /// The inclinometer falls silent: both planes lose their angle.
    Lost(f64),
    /// Slope lateral16 (the y–z plane's) freezes at its last value.
    LateralFrozen(f64),
    /// Slope long16 (the x–z plane's) freezes at its last value.
    LongFrozen(f64),
}

/// The plant of `case` at rest where `reference` starts (bridge, trolley, rope).
fn plant_at_start(params: &Crane3dParams, reference: &ReferenceRun3, case: &Mismatch3d) -> Plant3d {
    let [r_xz, r_yz] = reference.r.first().copied().unwrap_or_default();
    Plant3d::at_rest(
        r_xz.x,
        r_yz.x,
        r_xz.l,
        reference.t0,
        [params.tau1, params.tau2, params.tau3],
        params.g,
        params.m,
        *case,
    )
}

/// Runs `case` along `reference`, with the feedback when `gains` is given (and the
/// inclinometer's lateral slope failing as `fault` says).
pub fn simulate(
    params: &Crane3dParams,
    reference: &ReferenceRun3,
    case: &Mismatch3d,
    gains: Option<&[Gains; 2]>,
    fault: Option<SlopeFault>,
) -> CaseResult3 {
    let fb =
        gains.map(|g| SpatialFeedback::with_gains(config(params, reference.h), params.tau2, *g));
    run(params, reference, case, fb, fault).0
}

/// [`simulate`] with the feedback `fb` as given (`None`: feedforward only); the feedback
/// as it ends the run, for what its rope estimator learnt.
fn run(
    params: &Crane3dParams,
    reference: &ReferenceRun3,
    case: &Mismatch3d,
    mut fb: Option<SpatialFeedback>,
    fault: Option<SlopeFault>,
) -> (CaseResult3, Option<SpatialFeedback>) {
    let limits: [AxisLimits; 3] = DriveLimits::LAB_3D;
    let h = reference.h;
    let r_xz = reference
        .r
        .first()
        .map_or_else(Reference::default, |r| r[0]);
    let mut plant = plant_at_start(params, reference, case);
    let (ts, te) = reference.span;
    let l_end = reference.r.last().map_or(r_xz.l, |r| r[0].l);
    let window = (te + 5.0, te + 5.0 + period(params.g, case.rope(l_end)));
    let mut res = CaseResult3::default();
    let mut last = [0.0; 3];
    let mut measured: Option<Measured<3>> = None;
    // The slopes read last before a freeze.
    let mut held = [0.0; 2];
    for (k, (r, ud)) in reference.r.iter().zip(&reference.u).enumerate() {
        let t = reference.t0 + k as f64 * h;
        let u = match fb.as_mut() {
            Some(fb) => {
                let (u, outputs) = fb.cycle(r, *ud, measured, last, &limits);
                res.mode = Some(controller::feedback3d::worse(
                    outputs[0].mode,
                    outputs[1].mode,
                ));
                u
            }
            None => {
                let mut u = [0.0; 3];
                for (((u, d), l), lim) in u.iter_mut().zip(ud).zip(last).zip(limits) {
                    *u = clamp_to_limits(*d, l, lim, h);
                }
                u
            }
        };
        // Measured now, delivered in the next cycle.
        let load = plant.load();
        let [mx, my, ml, long, lateral] = plant.sense();
        let swing = match fault {
            Some(SlopeFault::Lost(at)) if t >= at => None,
            Some(SlopeFault::LateralFrozen(at)) if t >= at => Some(Swing {
                long,
                lateral: Some(held[1]),
            }),
            Some(SlopeFault::LongFrozen(at)) if t >= at => Some(Swing {
                long: held[0],
                lateral: Some(lateral),
            }),
            _ => {
                held = [long, lateral];
                Some(Swing {
                    long,
                    lateral: Some(lateral),
                })
            }
        };
        measured = Some(Measured {
            position: [mx, my, ml],
            swing,
        });
        let zd = reference.z.get(k).copied().unwrap_or(reference.target);
        if t >= ts && t <= te {
            let e = ((load[0] - zd[0]).powi(2) + (load[1] - zd[1]).powi(2)).sqrt();
            res.tracking = res.tracking.max(e);
        }
        if t >= window.0 && t <= window.1 {
            for (d, (l, target)) in res
                .distance
                .iter_mut()
                .zip(load.iter().zip(reference.target))
            {
                *d = d.max((l - target).abs());
            }
            for (s, slope) in res.swing_deg.iter_mut().zip(plant.slopes()) {
                *s = s.max(slope.abs().to_degrees());
            }
        }
        if t >= window.0 {
            res.at_rest_u = u.iter().fold(res.at_rest_u, |m, v| m.max(v.abs()));
        }
        for i in 0..3 {
            res.max_u[i] = res.max_u[i].max(u[i].abs());
            res.max_du[i] = res.max_du[i].max((u[i] - last[i]).abs() / h);
        }
        last = u;
        plant.advance(u, h);
    }
    res.rope = fb
        .as_ref()
        .map_or((0.0, 0.0), |fb| fb.planes()[0].rope().estimate());
    (res, fb)
}

/// The diagonal move of the firmware's 3D scene (`scenes/crane3d/crane3d.toml`): the
/// load from (12, 3, 8) to (20, 6, 4) in 8 s from 1 s, smoothness 4.
pub fn diagonal() -> PointToPoint<f64, 3> {
    // The scene's own numbers; scene/tests load the file itself.
    PointToPoint::new(
        [12.0, 3.0, 8.0].into(),
        [20.0, 6.0, 4.0].into(),
        1.0,
        8.0,
        4,
    )
    .expect("the 3D scene's move is valid")
}

/// Cycles a run needs: until one swing period after "5 s after the move".
fn steps_for(span: (f64, f64), t0: f64, l_end: f64, h: f64) -> usize {
    ((span.1 + 5.0 + period(9.81, l_end * 1.02) + 0.1 - t0) / h).ceil() as usize
}

/// The diagonal move, run long enough for the measures.
pub fn diagonal_reference(params: &Crane3dParams) -> ReferenceRun3 {
    let z = diagonal();
    let steps = steps_for((1.0, 9.0), 0.0, 4.0, 0.01);
    reference_run(*params, z, 0.0, steps).expect("the diagonal move runs")
}

/// A random 3D move inside the workspace, from rest to rest, smoothness 5 (the
/// controller's commands), with a duration all three drives can follow (90 % of their
/// velocity and acceleration limits); refused ones are drawn again. Ropes from 3.5 to
/// 8.5 m, hoisting or lowering while the bridge and trolley travel.
pub fn random_move(
    rng: &mut Rng,
    params: &Crane3dParams,
    t0: f64,
) -> (PointToPoint<f64, 3>, ReferenceRun3) {
    let limits = DriveLimits::LAB_3D;
    loop {
        let point = |rng: &mut Rng| {
            [
                rng.uniform(11.0, 22.0),
                rng.uniform(0.5, 7.5),
                rng.uniform(3.5, 8.5),
            ]
        };
        let (a, b) = (point(rng), point(rng));
        let dist: f64 = a.iter().zip(&b).map(|(p, q)| (q - p).abs()).sum();
        let duration = 3.0 + 0.4 * dist * rng.uniform(1.0, 1.5);
        let Ok(z) = PointToPoint::new(a.into(), b.into(), t0 + 1.0, duration, 5) else {
            continue;
        };
        let steps = steps_for((t0 + 1.0, t0 + 1.0 + duration), t0, b[2], 0.01);
        if let Ok(run) = reference_run(*params, z, t0, steps) {
            let fits = run.u.windows(2).all(|w| {
                limits.iter().enumerate().all(|(i, lim)| {
                    w[1][i].abs() < 0.9 * lim.max_velocity
                        && (w[1][i] - w[0][i]).abs() / 0.01 < 0.9 * lim.max_acceleration
                })
            });
            if fits {
                return (z, run);
            }
        }
    }
}

/// The rope calibration, a commissioning step (`controller::rope`): the diagonal move on
/// `case`'s crane in calm air with the load at rest, the feedback on; the scaling error
/// and offset the x–z plane learnt from the swing.
pub fn calibrate_rope(
    params: &Crane3dParams,
    diagonal: &ReferenceRun3,
    case: &Mismatch3d,
    gains: &[Gains; 2],
) -> (f64, f64) {
    let calm = Mismatch3d {
        gust: Gust::NONE,
        swing0: [0.0; 2],
        ..*case
    };
    simulate(params, diagonal, &calm, Some(gains), None).rope
}

/// One Monte Carlo set: per case, feedforward only, with feedback, with feedback after
/// the rope calibration.
#[derive(Debug, Clone, Default)]
pub struct MonteCarlo3 {
    /// Per case: (mismatch, feedforward only, feedback, feedback with the rope calibrated).
    pub cases: Vec<(Mismatch3d, CaseResult3, CaseResult3, CaseResult3)>,
}

/// Runs `n` random cases on the diagonal move (`random_moves == false`) or on random
/// moves.
pub fn monte_carlo(seed: u64, n: usize, random_moves: bool, gains: &[Gains; 2]) -> MonteCarlo3 {
    let params = Crane3dParams::EXAMPLE;
    let mut rng = Rng::new(seed);
    let diagonal = diagonal_reference(&params);
    let mut mc = MonteCarlo3::default();
    for _ in 0..n {
        let own;
        let reference = if random_moves {
            own = random_move(&mut rng, &params, 0.0).1;
            &own
        } else {
            &diagonal
        };
        let l0 = reference.r.first().map_or(6.0, |r| r[0].l);
        let case = Mismatch3d::random(&mut rng, l0, reference.span);
        let ff = simulate(&params, reference, &case, None, None);
        let fb = simulate(&params, reference, &case, Some(gains), None);
        let calibrated = case.calibrated(calibrate_rope(&params, &diagonal, &case, gains));
        let cal = simulate(&params, reference, &calibrated, Some(gains), None);
        mc.cases.push((case, ff, fb, cal));
    }
    mc
}

/// The fault set: `n` random cases of the diagonal move on the crane as commissioned
/// (its rope calibrated), each with the feedback and the inclinometer failing at a
/// random instant of the move as each of [`FAULTS3`] says, against feedforward only on
/// the same case; with whether the case's gust still blew when it failed.
pub fn fault_study(
    seed: u64,
    n: usize,
    gains: &[Gains; 2],
) -> Vec<([(CaseResult3, CaseResult3); 3], bool)> {
    let params = Crane3dParams::EXAMPLE;
    let mut rng = Rng::new(seed);
    let reference = diagonal_reference(&params);
    let (ts, te) = reference.span;
    let l0 = reference.r.first().map_or(6.0, |r| r[0].l);
    (0..n)
        .map(|_| {
            let case = Mismatch3d::random(&mut rng, l0, reference.span);
            let at = rng.uniform(ts, te);
            let case = case.calibrated(calibrate_rope(&params, &reference, &case, gains));
            let ff = simulate(&params, &reference, &case, None, None);
            let run = |f| simulate(&params, &reference, &case, Some(gains), Some(f));
            let g = &case.gust;
            let blowing = g.amplitude != 0.0 && g.start + g.duration > at;
            (
                [
                    (run(SlopeFault::Lost(at)), ff),
                    (run(SlopeFault::LateralFrozen(at)), ff),
                    (run(SlopeFault::LongFrozen(at)), ff),
                ],
                blowing,
            )
        })
        .collect()
}

/// The names of the fault study's faults, in its order.
pub const FAULTS3: [&str; 3] = [
    "lost mid-move (both slopes)",
    "slope lateral16 frozen mid-move",
    "slope long16 frozen mid-move",
];

/// A gust at rest (10 N for 1 s) from the direction `theta` (rad from the x axis) at
/// rope length `l`: the swing amplitude (the rope's angle from the vertical) two swing
/// periods after its peak, relative to the peak — `(with feedback, feedforward only)`.
pub fn gust_at_rest(l: f64, theta: f64, gains: &[Gains; 2]) -> (f64, f64) {
    let params = Crane3dParams::EXAMPLE;
    let h = 0.01;
    let t_end = 1.5 + 4.0 * period(params.g, l);
    let steps = (t_end / h).ceil() as usize;
    let at = |x: f64| Reference {
        x,
        l,
        ..Reference::default()
    };
    let reference = ReferenceRun3 {
        t0: 0.0,
        h,
        u: vec![[0.0; 3]; steps],
        r: vec![[at(15.0), at(4.0)]; steps],
        z: vec![[15.0, 4.0, l]; steps],
        span: (0.0, 0.0),
        target: [15.0, 4.0, l],
    };
    let case = Mismatch3d {
        gust: Gust {
            start: 0.5,
            duration: 1.0,
            amplitude: 10.0,
        },
        gust_direction: theta,
        position_noise: crate::plant::Mismatch::SENSORS.0,
        angle_noise: crate::plant::Mismatch::SENSORS.1,
        noise_seed: 7,
        ..Mismatch3d::NONE
    };
    let ratio =
        |g: Option<&[Gains; 2]>| {
            let swings = swing_series(&params, &reference, &case, g);
            let until = case.gust.start + case.gust.duration + period(params.g, l);
            let (tp, peak) = swings.iter().filter(|(t, _)| *t <= until).fold(
                (0.0, 0.0_f64),
                |(bt, b), (t, s)| if *s > b { (*t, *s) } else { (bt, b) },
            );
            let t2 = tp + 2.0 * period(params.g, l);
            let later = swings
                .iter()
                .filter(|(t, _)| *t >= t2 && *t <= t2 + period(params.g, l))
                .fold(0.0_f64, |m, (_, s)| m.max(*s));
            later / peak
        };
    (ratio(Some(gains)), ratio(None))
}

/// The rope's angle from the vertical over a run, `(t, rad)`.
fn swing_series(
    params: &Crane3dParams,
    reference: &ReferenceRun3,
    case: &Mismatch3d,
    gains: Option<&[Gains; 2]>,
) -> Vec<(f64, f64)> {
    let limits = DriveLimits::LAB_3D;
    let h = reference.h;
    let mut fb = gains.map(|g| SpatialFeedback::with_gains(config(params, h), params.tau2, *g));
    let mut plant = plant_at_start(params, reference, case);
    let mut last = [0.0; 3];
    let mut measured = None;
    let mut out = Vec::with_capacity(reference.r.len());
    for (k, (r, ud)) in reference.r.iter().zip(&reference.u).enumerate() {
        let u = match fb.as_mut() {
            Some(fb) => fb.cycle(r, *ud, measured, last, &limits).0,
            None => *ud,
        };
        let [mx, my, ml, long, lateral] = plant.sense();
        measured = Some(Measured {
            position: [mx, my, ml],
            swing: Some(Swing {
                long,
                lateral: Some(lateral),
            }),
        });
        let [a, b] = plant.slopes();
        // The rope's angle from the vertical: tan² = tan²α + tan²β.
        let swing = (a.tan().powi(2) + b.tan().powi(2)).sqrt().atan();
        out.push((k as f64 * h, swing));
        last = u;
        plant.advance(u, h);
    }
    out
}

/// One row of the table (markdown) for one mode of a set.
pub fn table_row(name: &str, results: &[CaseResult3]) -> String {
    let n = results.len().max(1) as f64;
    let col = |f: &dyn Fn(&CaseResult3) -> f64| results.iter().map(f).collect::<Vec<_>>();
    let mut tr = col(&|r| r.tracking * 1e3);
    let mut dh = col(&|r| r.distance[0].max(r.distance[1]) * 1e3);
    let mut dv = col(&|r| r.distance[2] * 1e3);
    let mut s = col(&|r| r.swing_deg[0].max(r.swing_deg[1]));
    let max = |i: usize, f: &dyn Fn(&CaseResult3) -> [f64; 3]| {
        results.iter().map(|r| f(r)[i]).fold(0.0, f64::max)
    };
    let ok = results.iter().filter(|r| r.meets_target()).count();
    let all = results
        .iter()
        .filter(|r| r.meets_target_in_all_directions())
        .count();
    let zero = results.iter().filter(|r| r.at_rest_zero()).count();
    let rest = col(&|r| r.at_rest_u * 1e3).into_iter().fold(0.0, f64::max);
    format!(
        "| {name} | {:.1} / {:.1} | {:.1} / {:.1} / {:.1} | {:.3} / {:.3} / {:.3} | {:.1} / {:.1} / {:.1} | {ok}/{} ({:.1} %) | {all} ({:.1} %) | {:.2}, {:.2}, {:.2} | {:.2}, {:.2}, {:.2} | {zero} ({:.1} %) | {rest:.3} |",
        quantile(&mut tr, 0.5),
        quantile(&mut tr, 1.0),
        quantile(&mut dh, 0.5),
        quantile(&mut dh, 0.99),
        quantile(&mut dh, 1.0),
        quantile(&mut s, 0.5),
        quantile(&mut s, 0.99),
        quantile(&mut s, 1.0),
        quantile(&mut dv, 0.5),
        quantile(&mut dv, 0.99),
        quantile(&mut dv, 1.0),
        results.len(),
        100.0 * ok as f64 / n,
        100.0 * all as f64 / n,
        max(0, &|r| r.max_u),
        max(1, &|r| r.max_u),
        max(2, &|r| r.max_u),
        max(0, &|r| r.max_du),
        max(1, &|r| r.max_du),
        max(2, &|r| r.max_du),
        100.0 * zero as f64 / n,
    )
}

/// The table's header.
pub const TABLE_HEADER: &str = "| set, mode | horizontal tracking during the move, mm (median / max) | horizontal distance 5 s after (worse of x, y), mm (median / p99 / max) | swing 5 s after (worse plane), ° (median / p99 / max) | vertical 5 s after, mm (median / p99 / max) | within ±50 mm in x and y and < 0.1° in both planes | and within ±50 mm vertically | worst |u| bridge, trolley, hoist m/s | worst |Δu|/h bridge, trolley, hoist m/s² | set points zero (as the drives receive them) from 5 s after the move | largest set point then, mm/s |\n|---|---|---|---|---|---|---|---|---|---|---:|";

/// The 3D crane's feedback for `case` with its inclinometer's timing commissioned
/// (docs/COMMISSIONING.md, "The inclinometer's timing"): the gains designed for it, as
/// the controller designs them from its configuration.
fn commissioned_feedback(params: &Crane3dParams, h: f64, case: &Mismatch3d) -> SpatialFeedback {
    let cfg = Config {
        inclinometer: InclinometerLag {
            delay: case.inclinometer.delay,
            filter: case.inclinometer.filter,
        },
        ..config(params, h)
    };
    SpatialFeedback::new(cfg, params.tau2).expect("the 3D crane's gains")
}

/// The 3D rope calibration's moves: the diagonal move and back
/// [`CALIBRATION_ROUNDS`](crate::feedback_study::CALIBRATION_ROUNDS) times, each leg from
/// rest 1 s after the last one's end, the load left 3 s after it (as the planar
/// [`calibration_reference`](crate::feedback_study::calibration_reference)).
pub fn calibration_reference3(params: &Crane3dParams) -> ReferenceRun3 {
    let (a, b) = ([12.0, 3.0, 8.0], [20.0, 6.0, 4.0]);
    let (h, duration): (f64, f64) = (0.01, 8.0);
    let steps = ((duration + 4.0) / h).round() as usize;
    let mut all: Option<ReferenceRun3> = None;
    for k in 0..2 * crate::feedback_study::CALIBRATION_ROUNDS {
        let t0 = k as f64 * steps as f64 * h;
        let (from, to) = if k % 2 == 0 { (a, b) } else { (b, a) };
        let z = PointToPoint::new(from.into(), to.into(), t0 + 1.0, duration, 4)
            .expect("the diagonal move is valid");
        let leg = reference_run(*params, z, t0, steps).expect("the diagonal move runs");
        match all.as_mut() {
            None => all = Some(leg),
            Some(all) => {
                // Each leg starts where the last one ended, at rest.
                all.r.extend(leg.r.iter().skip(1));
                all.u.extend(leg.u.iter().skip(1));
                all.z.extend(leg.z.iter().skip(1));
                all.span.1 = leg.span.1;
                all.target = leg.target;
            }
        }
    }
    all.expect("at least one leg")
}

/// One case of the 3D calibration set (issue 33).
#[derive(Debug, Clone, Copy)]
pub struct CalibrationCase3 {
    /// The crane and its inclinometer.
    pub case: Mismatch3d,
    /// What the x–z plane's rope calibration learnt on [`calibration_reference3`].
    pub calibration: Calibration,
    /// The learnt length's error at the rope range's ends (3.5 m, 8.5 m), m.
    pub length_error: [f64; 2],
    /// The case's random move with the feedback, the rope calibrated if offered.
    pub run: CaseResult3,
}

/// The issue-33 set for the 3D crane: the planar set's ranges (drum ±2 %, rope offset
/// ±0.1 m, load 0.5–2×, inclinometer 0–5 cycles late, filter up to 20 ms, noise up to
/// 0.05° on both slopes) on [`Mismatch3d::random`]'s drives and gusts; calibrated on
/// [`calibration_reference3`] in calm air with the timing commissioned, then a random 3D
/// move (ropes 3.5–8.5 m) on the crane as commissioned.
pub fn calibration_study3(seed: u64, n: usize) -> Vec<CalibrationCase3> {
    let params = Crane3dParams::EXAMPLE;
    let mut rng = Rng::new(seed);
    let moves = calibration_reference3(&params);
    (0..n)
        .map(|_| {
            let (_, reference) = random_move(&mut rng, &params, 0.0);
            let l0 = reference.r.first().map_or(6.0, |r| r[0].l);
            let base = Mismatch3d::random(&mut rng, l0, reference.span);
            let case = Mismatch3d {
                rope_offset: rng.uniform(-0.1, 0.1),
                load_mass: rng.uniform(-0.5, 1.0),
                angle_noise: (rng.uniform(0.0, 0.05).to_radians(), base.angle_noise.1),
                inclinometer: crate::plant::SensorLag {
                    delay: (rng.unit() * 6.0).floor().min(5.0) as u8,
                    filter: rng.uniform(0.0, 0.02),
                },
                ..base
            };
            let calm = Mismatch3d {
                gust: Gust::NONE,
                swing0: [0.0; 2],
                ..case
            };
            let fb = commissioned_feedback(&params, moves.h, &case);
            let (cal, fb) = run(&params, &moves, &calm, Some(fb), None);
            let calibration = fb.map_or(
                Calibration {
                    estimate: (0.0, 0.0),
                    learnt: Learnt::Nothing,
                    uncertainty: f64::INFINITY,
                    delay: 0.0,
                },
                |fb| {
                    let rope = fb.planes()[0].rope();
                    Calibration {
                        estimate: cal.rope,
                        learnt: rope.learnt(),
                        uncertainty: rope.uncertainty(),
                        delay: rope.delay(),
                    }
                },
            );
            let (s, o) = calibration.estimate;
            let length_error = [3.5, 8.5].map(|l| (1.0 + s) * l + o - case.rope(l));
            let crane = match calibration.learnt {
                Learnt::Both => case.calibrated(calibration.estimate),
                _ => case,
            };
            let fb = commissioned_feedback(&params, reference.h, &crane);
            let (run, _) = run(&params, &reference, &crane, Some(fb), None);
            CalibrationCase3 {
                case,
                calibration,
                length_error,
                run,
            }
        })
        .collect()
}
