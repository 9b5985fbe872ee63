//! Operator mode's generator studied on both lab cranes (issue 28): scripted stick
//! profiles at every rope length — steps and releases at several speeds and hold times,
//! reversals, pulsing, pendant levels, diagonal and circular sticks, noise at the
//! deadband, each with the hoist idle, lowering and raising — measured for the drives'
//! limits, the stopping distance against its bound, the load in the model's nonlinear
//! plant driven by the inverse model, and in a plant whose pendulum is 10 % longer or
//! shorter; the time to speed; the random sequences of the property test; the
//! generator's RAM. `cargo run --release -p host-tests --bin operator_study` prints the
//! tables of `docs/OPERATOR.md` and draws its figure.

use std::path::Path;

use solver_core::operator::{stopping_bound, Generator3d, PlanarGenerator};

use crate::feedback_study::quantile;
use crate::operator::{
    drive, flat_set_points, inverse_model_run, residual, simulate_plant, Crane, Extremes, Gen,
    Hold, Pendulum, Record,
};
use crate::plant::Rng;
use crate::plot::{figure, Chart, Legend, Scale, Series};

/// The cycle, s.
const H: f64 = 0.01;

/// The rope lengths (load depths at rest) studied, m: the lab range, the deepest within
/// the generator's depth range.
pub const DEPTHS: [f64; 5] = [3.0, 4.5, 6.0, 7.5, 8.95];

/// What the horizontal stick does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// `level` of full stick for `hold` s, then released.
    Step {
        /// Share of full stick.
        level: f64,
        /// Seconds held.
        hold: f64,
    },
    /// Full stick one way for `hold` s, the other way as long, released.
    Reversal {
        /// Seconds each way.
        hold: f64,
    },
    /// Full stick on and off at `hz` for 6 s, released.
    Pulse {
        /// Frequency, Hz.
        hz: f64,
    },
    /// A pendant's levels: a quarter, half, three quarters, full, 1.5 s each, released.
    Pendant,
    /// Both horizontal axes at full stick for 4 s, released (3D).
    Diagonal,
    /// The stick around a circle once in 10 s, released (3D).
    Circle,
    /// Noise within ±0.1 of full stick (the deadband is 0.05) for 8 s.
    Noise,
}

impl Shape {
    /// Every shape the crane's stick has (diagonal and circle only in 3D).
    #[must_use]
    pub fn all(crane: &Crane) -> Vec<Shape> {
        let mut out = Vec::new();
        for level in [0.3, 0.6, 1.0] {
            for hold in [0.2, 0.5, 1.0, 2.0, 5.0] {
                out.push(Shape::Step { level, hold });
            }
        }
        out.extend([
            Shape::Reversal { hold: 1.0 },
            Shape::Reversal { hold: 3.0 },
            Shape::Pulse { hz: 0.5 },
            Shape::Pulse { hz: 1.0 },
            Shape::Pulse { hz: 2.0 },
            Shape::Pendant,
            Shape::Noise,
        ]);
        if matches!(crane, Crane::Spatial(_)) {
            out.extend([Shape::Diagonal, Shape::Circle]);
        }
        out
    }

    /// Cycles until the stick is released for good.
    #[must_use]
    pub fn release(&self) -> usize {
        let s = match *self {
            Shape::Step { hold, .. } => hold,
            Shape::Reversal { hold } => 2.0 * hold,
            Shape::Pulse { .. } => 6.0,
            Shape::Pendant => 6.0,
            Shape::Diagonal => 4.0,
            Shape::Circle => 10.0,
            Shape::Noise => 8.0,
        };
        (s / H).round() as usize
    }

    /// The horizontal stick `[x, y]` at cycle `n`.
    #[must_use]
    pub fn at(&self, n: usize, rng: &mut Rng) -> [f64; 2] {
        if n >= self.release() {
            return [0.0; 2];
        }
        let t = n as f64 * H;
        match *self {
            Shape::Step { level, .. } => [level, 0.0],
            Shape::Reversal { hold } => [if t < hold { 1.0 } else { -1.0 }, 0.0],
            Shape::Pulse { hz } => [if (t * hz).fract() < 0.5 { 1.0 } else { 0.0 }, 0.0],
            Shape::Pendant => [(1.0 + (t / 1.5).floor()) * 0.25, 0.0],
            Shape::Diagonal => [1.0, 1.0],
            Shape::Circle => {
                let a = core::f64::consts::TAU * t / 10.0;
                [a.cos(), a.sin()]
            }
            Shape::Noise => [rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1)],
        }
    }

    /// Its name in tables.
    #[must_use]
    pub fn name(&self) -> String {
        match *self {
            Shape::Step { level, hold } => format!("step {level} for {hold} s"),
            Shape::Reversal { hold } => format!("reversal after {hold} s"),
            Shape::Pulse { hz } => format!("pulsing at {hz} Hz"),
            Shape::Pendant => "pendant levels".into(),
            Shape::Diagonal => "diagonal".into(),
            Shape::Circle => "circle".into(),
            Shape::Noise => "noise at the deadband".into(),
        }
    }
}

/// A profile: a horizontal shape and the hoist's stick while it lasts (0 idle, + lowering,
/// − raising), from 0.5 s on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Profile {
    /// The horizontal stick.
    pub shape: Shape,
    /// The hoist's stick.
    pub hoist: f64,
}

impl Profile {
    /// The stick `[x, y, z]` at cycle `n`, noise drawn from `rng`.
    pub fn at(&self, n: usize, rng: &mut Rng) -> [f64; 3] {
        let [x, y] = self.shape.at(n, rng);
        let z = if (50..self.shape.release()).contains(&n) {
            self.hoist
        } else {
            0.0
        };
        [x, y, z]
    }

    /// Cycles run: the stick's time and 12 s to come to rest.
    #[must_use]
    pub fn cycles(&self) -> usize {
        self.shape.release() + 1200
    }
}

/// The hoist's sticks studied: idle, lowering, raising.
pub const HOISTS: [f64; 3] = [0.0, 0.6, -0.6];

/// One profile's measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome {
    /// The largest share of a drive limit (plain setting).
    pub share: f64,
    /// The release's stopping distance minus its bound, m, per setting (plain, robust):
    /// negative inside the bound (−∞ when no axis moved).
    pub stop_margin: [f64; 2],
    /// The release's stopping distance of the x axis and its bound (plain), m.
    pub stop: (f64, f64),
    /// Model = plant: the load's largest distance from its rest point after the
    /// generator's rest, m, and its largest swing, deg.
    pub exact: (f64, f64),
    /// The pendulum's length off the model's: the largest swing after the rest, deg, per
    /// setting (plain, robust) and per [`PendulumError::ALL`].
    pub mismatch: [[f64; 3]; 2],
    /// [`PendulumError::RiggingOfStart`]'s largest share of the model's rope: 0.1 where
    /// the rope never got shorter than at the start.
    pub rigging_share: f64,
}

impl Outcome {
    /// The largest swing after the rest with the pendulum 10 % off at every instant
    /// (the drum's scaling, or rigging of 10 % of the shortest rope), deg, for the
    /// setting (0 plain, 1 robust).
    #[must_use]
    pub fn ten_percent(&self, setting: usize) -> f64 {
        self.mismatch[setting][0].max(self.mismatch[setting][1])
    }
}

/// How the study puts the plant's pendulum 10 % off the model's rope, each way
/// ([`Pendulum`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PendulumError {
    /// The drum's scaling ±10 %: the pendulum 10 % off at every rope length.
    Drum,
    /// Rigging of ±10 % of the shortest rope the run reaches: at most 10 % off at
    /// every instant, less where the rope is longer.
    RiggingOfShortest,
    /// Rigging of ±10 % of the rope at the start (the study's only form before
    /// 2026-11-30): more than 10 % of the pendulum once the hoist has raised the load.
    RiggingOfStart,
}

impl PendulumError {
    /// Every form, in the order of [`Outcome::mismatch`].
    pub const ALL: [Self; 3] = [Self::Drum, Self::RiggingOfShortest, Self::RiggingOfStart];

    /// The plant's two pendulums, 10 % shorter and longer, for a run starting at
    /// `start` m whose rope is never shorter than `shortest` m.
    #[must_use]
    pub fn pendulums(self, start: f64, shortest: f64) -> [Pendulum; 2] {
        match self {
            Self::Drum => [Pendulum::scaled(0.9), Pendulum::scaled(1.1)],
            Self::RiggingOfShortest => [
                Pendulum::longer_by(-0.1 * shortest),
                Pendulum::longer_by(0.1 * shortest),
            ],
            Self::RiggingOfStart => [
                Pendulum::longer_by(-0.1 * start),
                Pendulum::longer_by(0.1 * start),
            ],
        }
    }
}

/// The generator run with the profile's stick: its records.
fn records(
    crane: &Crane,
    robust: bool,
    at: [f64; 3],
    p: &Profile,
    seed: u64,
) -> Result<(Gen, Vec<Record>), String> {
    let mut g = crane.start(robust, at).map_err(|e| e.to_string())?;
    let mut rng = Rng::new(seed);
    let mut out = Vec::with_capacity(p.cycles());
    drive(
        crane,
        &mut g,
        p.cycles(),
        |n| p.at(n, &mut rng),
        |r| out.push(*r),
    );
    Ok((g, out))
}

/// The stopping distance after the profile's release against its bound, per horizontal
/// axis the worst margin, and the x axis's (distance, bound).
fn stopping(gen: &Gen, r: &[Record], release: usize) -> (f64, (f64, f64)) {
    let (lag, _) = gen.lags();
    let (acc, _) = gen.limits();
    let Some(rel) = r.get(release) else {
        return (f64::NAN, (f64::NAN, f64::NAN));
    };
    let Some(rest) = r.iter().skip(release).find(|x| x.at_rest) else {
        return (f64::NAN, (f64::NAN, f64::NAN));
    };
    let window = ((2.0 * lag / H) as usize + 400).min(release);
    let v_max = |i: usize| {
        r[release - window..=release]
            .iter()
            .map(|x| x.limiter[i].abs())
            .fold(0.0, f64::max)
    };
    let t_brake = (0..2)
        .filter(|i| acc[*i] > 0.0)
        .map(|i| rel.limiter[i].abs() / acc[i])
        .fold(0.0, f64::max);
    let mut margin = f64::NEG_INFINITY;
    let mut x = (0.0, 0.0);
    // The axes that moved in the window before the release.
    for i in (0..2).filter(|i| acc[*i] > 0.0 && v_max(*i) > 0.0) {
        let travelled = (rest.load[0][i] - rel.load[0][i]).abs();
        let bound = rel.limiter[i].abs() * (t_brake / 2.0 + H) + v_max(i) * lag;
        margin = margin.max(travelled - bound);
        if i == 0 {
            x = (travelled, bound);
        }
    }
    (margin, x)
}

/// Runs one profile on one crane from `at`: every measure of [`Outcome`].
pub fn study_profile(
    crane: &Crane,
    at: [f64; 3],
    p: &Profile,
    seed: u64,
) -> Result<Outcome, String> {
    let (plain_gen, plain) = records(crane, false, at, p, seed)?;
    let (robust_gen, robust) = records(crane, true, at, p, seed)?;
    let mut e = Extremes::default();
    for r in &plain {
        e.add(crane, r);
    }
    let release = p.shape.release();
    let (m_plain, stop) = stopping(&plain_gen, &plain, release);
    let (m_robust, _) = stopping(&robust_gen, &robust, release);
    // Model = plant: the inverse model driven by the generator, the plant by its set points.
    let mut rng = Rng::new(seed);
    let g = crane.start(false, at).map_err(|e| e.to_string())?;
    let (u, rest) = inverse_model_run(crane, g, p.cycles(), |n| p.at(n, &mut rng))
        .map_err(|e| e.to_string())?;
    let rest = rest.ok_or("the inverse model's run did not come to rest")?;
    let rest_point = plain.get(rest).map(|r| r.load[0]).ok_or("no rest record")?;
    let motion =
        simulate_plant(crane, at, Pendulum::MODEL, &u, Hold::Cubic).map_err(|e| e.to_string())?;
    let (dist, swing) = residual(&motion, rest + 1, rest_point);
    let exact = (
        dist.iter().fold(0.0_f64, |a, b| a.max(*b)),
        swing[0].max(swing[1]).to_degrees(),
    );
    // ±10 %: the flat inverse's set points into a plant with the pendulum off.
    let mut mismatch = [[0.0_f64; 3]; 2];
    let mut largest_share = 0.0_f64;
    for (m, r) in mismatch.iter_mut().zip([&plain, &robust]) {
        let rest = r
            .iter()
            .position(|x| x.at_rest && x.n >= release)
            .ok_or("no rest")?;
        let u = flat_set_points(r);
        let shortest = r.iter().map(|x| x.load[0][2]).fold(f64::INFINITY, f64::min);
        largest_share = largest_share.max(0.1 * at[2] / shortest);
        for (form, worst) in PendulumError::ALL.iter().zip(m.iter_mut()) {
            for pendulum in form.pendulums(at[2], shortest) {
                let motion = simulate_plant(crane, at, pendulum, &u, Hold::Cubic)
                    .map_err(|e| e.to_string())?;
                let (_, swing) = residual(&motion, rest, r[rest].load[0]);
                *worst = worst.max(swing[0].max(swing[1]).to_degrees());
            }
        }
    }
    Ok(Outcome {
        share: e.share(crane),
        stop_margin: [m_plain, m_robust],
        stop,
        exact,
        mismatch,
        rigging_share: largest_share,
    })
}

/// Where each crane's runs start: the middle of its hall, back enough for a 6 m travel.
#[must_use]
pub fn start(crane: &Crane, depth: f64) -> [f64; 3] {
    match crane {
        Crane::Planar(_) => [12.0, 0.0, depth],
        Crane::Spatial(_) => [12.0, 3.0, depth],
    }
}

/// Every profile at one depth.
pub fn study_depth(crane: &Crane, depth: f64) -> Result<Vec<(Profile, Outcome)>, String> {
    let mut out = Vec::new();
    for (k, shape) in Shape::all(crane).into_iter().enumerate() {
        for hoist in HOISTS {
            let p = Profile { shape, hoist };
            let o = study_profile(crane, start(crane, depth), &p, 28 + k as u64).map_err(|e| {
                format!(
                    "{} depth {depth} {} hoist {hoist}: {e}",
                    crane.name(),
                    shape.name()
                )
            })?;
            out.push((p, o));
        }
    }
    Ok(out)
}

/// The markdown header of the profiles table.
pub const PROFILE_HEADER: &str = "| crane | rope, m | runs | drive limit used, median / worst | release: distance − bound, m, worst plain / robust | model = plant after rest: load from its rest point, mm, median / worst | swing, °, median / worst | ±10 % pendulum, swing, °: plain median / worst | robust, hoist idle, median / worst | robust, hoisting, median / worst |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|";

/// The median and the largest of some values.
fn median_worst(mut v: Vec<f64>) -> (f64, f64) {
    let median = quantile(&mut v, 0.5);
    (median, v.last().copied().unwrap_or(f64::NAN))
}

/// One row of the profiles table.
#[must_use]
pub fn profile_row(crane: &Crane, depth: f64, runs: &[(Profile, Outcome)]) -> String {
    let col = |hoisting: Option<bool>, f: &dyn Fn(&Outcome) -> f64| {
        runs.iter()
            .filter(|(p, _)| hoisting.is_none_or(|h| (p.hoist != 0.0) == h))
            .map(|(_, o)| f(o))
            .collect::<Vec<_>>()
    };
    let worst = |v: Vec<f64>| v.into_iter().fold(f64::NEG_INFINITY, f64::max);
    let share = median_worst(col(None, &|o| o.share));
    let dist = median_worst(col(None, &|o| o.exact.0 * 1e3));
    let swing = median_worst(col(None, &|o| o.exact.1));
    let plain = median_worst(col(None, &|o| o.ten_percent(0)));
    let robust_idle = median_worst(col(Some(false), &|o| o.ten_percent(1)));
    let robust_hoisting = median_worst(col(Some(true), &|o| o.ten_percent(1)));
    format!(
        "| {} | {depth} | {} | {:.3} / {:.3} | {:+.4} / {:+.4} | {:.4} / {:.4} | {:.1e} / {:.1e} | {:.3} / {:.3} | {:.4} / {:.4} | {:.4} / {:.4} |",
        crane.name(),
        runs.len(),
        share.0,
        share.1,
        worst(col(None, &|o| o.stop_margin[0])),
        worst(col(None, &|o| o.stop_margin[1])),
        dist.0,
        dist.1,
        swing.0,
        swing.1,
        plain.0,
        plain.1,
        robust_idle.0,
        robust_idle.1,
        robust_hoisting.0,
        robust_hoisting.1,
    )
}

/// The markdown header of the table of the robust setting with the hoist moving during
/// the travel, per form of the pendulum's error.
pub const HOISTING_HEADER: &str = "| crane | rope, m | runs | drum ±10 %, swing, °, median / worst | rigging ±10 % of the shortest rope | rigging ±10 % of the rope at the start | that rigging's largest share of the rope | runs over 0.1°, drum / rigging of the shortest |\n|---|---:|---:|---:|---:|---:|---:|---:|";

/// One row of the table of the robust setting with the hoist moving ([`HOISTING_HEADER`]).
#[must_use]
pub fn hoisting_row(crane: &Crane, depth: f64, runs: &[(Profile, Outcome)]) -> String {
    let hoisting: Vec<&Outcome> = runs
        .iter()
        .filter(|(p, _)| p.hoist != 0.0)
        .map(|(_, o)| o)
        .collect();
    let form = |k: usize| median_worst(hoisting.iter().map(|o| o.mismatch[1][k]).collect());
    let [drum, shortest, start] = [form(0), form(1), form(2)];
    let share = hoisting
        .iter()
        .map(|o| o.rigging_share)
        .fold(f64::NEG_INFINITY, f64::max);
    let over = |k: usize| hoisting.iter().filter(|o| o.mismatch[1][k] > 0.1).count();
    format!(
        "| {} | {depth} | {} | {:.4} / {:.4} | {:.4} / {:.4} | {:.4} / {:.4} | {:.1} % | {} / {} |",
        crane.name(),
        hoisting.len(),
        drum.0,
        drum.1,
        shortest.0,
        shortest.1,
        start.0,
        start.1,
        share * 100.0,
        over(0),
        over(1),
    )
}

/// A full-stick step of the x axis from rest: the times for the load to reach 10 % and
/// 90 % of full speed, s, the speed reached at the release after 6 s, the stopping
/// distance from there and its bound, m; and the filter's lag τ̄ and `l_g`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// `l_g`, m.
    pub pendulum: f64,
    /// τ̄, s.
    pub lag: f64,
    /// Time to 10 % of full speed, s.
    pub t10: f64,
    /// Time to 90 %, s.
    pub t90: f64,
    /// Stopping distance from full speed, m.
    pub stop: f64,
    /// Its bound, m.
    pub bound: f64,
}

/// [`Step`] for one crane, depth and setting.
pub fn full_stick_step(crane: &Crane, depth: f64, robust: bool) -> Result<Step, String> {
    let mut g = crane
        .start(robust, start(crane, depth))
        .map_err(|e| e.to_string())?;
    let (acc, speed) = g.limits();
    let hold = 600;
    let mut r = Vec::new();
    drive(
        crane,
        &mut g,
        hold + 1200,
        |n| if n < hold { [1.0, 0.0, 0.0] } else { [0.0; 3] },
        |x| r.push(*x),
    );
    let v = speed[0];
    let first = |share: f64| {
        r.iter()
            .find(|x| x.load[1][0] >= share * v)
            .map_or(f64::NAN, |x| x.t)
    };
    let rel = r.get(hold).ok_or("short run")?;
    let rest = r.iter().skip(hold).find(|x| x.at_rest).ok_or("no rest")?;
    let (lag, _) = g.lags();
    Ok(Step {
        pendulum: g.pendulum(),
        lag,
        t10: first(0.1),
        t90: first(0.9),
        stop: rest.load[0][0] - rel.load[0][0],
        bound: stopping_bound(rel.limiter[0], acc[0], lag, H),
    })
}

/// The markdown header of the step table.
pub const STEP_HEADER: &str = "| crane | rope, m | l_g, m | τ̄, s, plain / robust | 10 % / 90 % of full speed after, s, plain | robust | stopping distance from full speed / bound, m, plain | robust |\n|---|---:|---:|---:|---:|---:|---:|---:|";

/// One row of the step table.
pub fn step_row(crane: &Crane, depth: f64) -> Result<String, String> {
    let p = full_stick_step(crane, depth, false)?;
    let r = full_stick_step(crane, depth, true)?;
    Ok(format!(
        "| {} | {depth} | {:.3} | {:.3} / {:.3} | {:.2} / {:.2} | {:.2} / {:.2} | {:.3} / {:.3} | {:.3} / {:.3} |",
        crane.name(),
        p.pendulum,
        p.lag,
        r.lag,
        p.t10,
        p.t90,
        r.t10,
        r.t90,
        p.stop,
        p.bound,
        r.stop,
        r.bound
    ))
}

/// The generator's static RAM: `size_of` of each crane's generator type, bytes.
#[must_use]
pub fn ram() -> [(&'static str, usize); 2] {
    [
        (
            "planar (PlanarGenerator)",
            core::mem::size_of::<PlanarGenerator>(),
        ),
        ("3D (Generator3d)", core::mem::size_of::<Generator3d>()),
    ]
}

/// The figure: every release's stopping distance against its bound, per crane and rope
/// length, and the bound itself.
pub fn plot_stops(path: &Path, points: &[(String, Vec<(f64, f64)>)]) -> Result<(), String> {
    let mut series: Vec<Series> = points
        .iter()
        .map(|(name, p)| {
            let mut p = p.clone();
            p.sort_by(|a, b| a.0.total_cmp(&b.0));
            Series {
                name: name.clone(),
                points: p,
            }
        })
        .collect();
    let top = points
        .iter()
        .flat_map(|(_, p)| p.iter().map(|q| q.0))
        .fold(0.0, f64::max);
    series.push(Series {
        name: "the bound".into(),
        points: vec![(0.0, 0.0), (top, top)],
    });
    figure(
        path,
        &[(
            Chart {
                title: "Stopping distance after the stick's release against its bound",
                x_label: "bound v²/(2A) + v (τ̄ + h), m",
                y_label: "stopping distance, m",
                x_scale: Scale::Linear,
                y_scale: Scale::Linear,
                legend: Legend::OverData,
            },
            series,
        )],
        false,
    )
}
