//! The rope-following robust pair (`host_tests::rope_pair`), a design not yet in the
//! generator, on the open-loop study's profiles: `cargo run --release -p host-tests --bin
//! rope_pair_study -- [--depths 3,6] [--half-period-now]`.
//!
//! Per crane and rope length, over every scripted stick shape of `operator_study` with the
//! hoist lowering and raising during the travel (and, as a check of the design, with the
//! hoist idle, where it is the generator's robust path but for the pair's delay rounded
//! to whole cycles): the swing after the path's rest in a plant whose pendulum is 10 %
//! off at every instant (the drum's scaling, and rigging of 10 % of the shortest rope),
//! set beside the generator's robust setting on the same runs; and the largest share of
//! a drive limit the path uses (the exact flat inverse), beside the plain generator's.

use clap::Parser;
use host_tests::operator::{
    flat_set_points, residual, simulate_plant, Crane, Extremes, Flat, Hold, Record,
};
use host_tests::operator_study::{
    start, study_profile, PendulumError, Profile, Shape, DEPTHS, HOISTS,
};
use host_tests::plant::Rng;
use host_tests::rope_pair::{rests, DelayRule, RopePair};

#[derive(Parser)]
struct Args {
    /// Rope lengths (load depths at rest), m.
    #[arg(long, value_delimiter = ',', default_values_t = DEPTHS)]
    depths: Vec<f64>,
    /// The delay the half period at the load's depth now, not the mean of both ends'.
    #[arg(long)]
    half_period_now: bool,
}

/// The cycle, s.
const H: f64 = 0.01;

/// The flat inverse of the rope-following path at `t`.
fn flat(crane: &Crane, pair: &RopePair, t: f64) -> Flat {
    match crane {
        Crane::Planar(p) => Flat::planar(p, pair, t),
        Crane::Spatial(p) => Flat::spatial(p, pair, t),
    }
}

/// One profile with the rope-following pair.
struct Outcome {
    /// The largest swing after the rest, deg, per [`PendulumError`] (drum, rigging of the
    /// shortest rope).
    swing: [f64; 2],
    /// The largest share of a drive limit.
    share: f64,
    /// Whether any value was not a number.
    non_finite: bool,
}

fn run(
    crane: &Crane,
    at: [f64; 3],
    p: &Profile,
    seed: u64,
    rule: DelayRule,
) -> Result<Outcome, String> {
    let mut gen = crane.start(false, at).map_err(|e| e.to_string())?;
    let mut pair = RopePair::new(crane, rule);
    let mut rng = Rng::new(seed);
    // The delayed copy rests up to D (at most 3.1 s at 9.5 m) after the plain path.
    let cycles = p.cycles() + 320;
    let mut records = Vec::with_capacity(cycles);
    for n in 0..cycles {
        let stick = p.at(n, &mut rng);
        let cycle = gen.advance(stick);
        if cycle.refused_demand {
            return Err(format!("cycle {n}: the generator refused the demand"));
        }
        pair.push(&gen);
        let t = gen.time();
        let path = pair.path(t);
        records.push(Record {
            n,
            t,
            stick,
            load: [path[0], path[1], path[2]],
            flat: [flat(crane, &pair, t), flat(crane, &pair, t + 0.5 * H)],
            limiter: [0.0; 3],
            at_rest: rests(&path),
            refused: false,
        });
    }
    let mut extremes = Extremes::default();
    for r in &records {
        extremes.add(crane, r);
    }
    let release = p.shape.release();
    let rest = records
        .iter()
        .rposition(|r| !r.at_rest)
        .map_or(0, |n| n + 1)
        .max(release);
    let rest_point = records
        .get(rest)
        .ok_or("the path did not rest within the run")?
        .load[0];
    let shortest = records
        .iter()
        .map(|r| r.load[0][2])
        .fold(f64::INFINITY, f64::min);
    let u = flat_set_points(&records);
    let mut swing = [0.0_f64; 2];
    for (form, worst) in [PendulumError::Drum, PendulumError::RiggingOfShortest]
        .iter()
        .zip(&mut swing)
    {
        for pendulum in form.pendulums(at[2], shortest) {
            let motion =
                simulate_plant(crane, at, pendulum, &u, Hold::Cubic).map_err(|e| e.to_string())?;
            let (_, s) = residual(&motion, rest, rest_point);
            *worst = worst.max(s[0].max(s[1]).to_degrees());
        }
    }
    Ok(Outcome {
        swing,
        share: extremes.share(crane),
        non_finite: extremes.non_finite,
    })
}

/// "median / worst".
fn median_worst(mut v: Vec<f64>) -> String {
    v.sort_by(f64::total_cmp);
    let median = v.get(v.len() / 2).copied().unwrap_or(f64::NAN);
    let worst = v.last().copied().unwrap_or(f64::NAN);
    format!("{median:.4} / {worst:.4}")
}

fn main() -> Result<(), String> {
    let args = Args::parse();
    let rule = if args.half_period_now {
        DelayRule::HalfPeriodNow
    } else {
        DelayRule::MeanOfBothEnds
    };
    println!("The delay: {rule:?}\n");
    println!(
        "| crane | rope, m | hoist | runs | robust now, drum ±10 %, swing, °, median / worst | rope-following, drum ±10 % | rope-following, rigging ±10 % of the shortest rope | runs over 0.1°, robust now (drum) / rope-following, drum / rigging | drive limit used, plain / rope-following, worst |\n|---|---:|---|---:|---:|---:|---:|---:|---:|"
    );
    for crane in [Crane::PLANAR, Crane::SPATIAL] {
        for depth in &args.depths {
            for (lever, hoists) in [("idle", &HOISTS[..1]), ("moving", &HOISTS[1..])] {
                let mut now = Vec::new();
                let mut following = [Vec::new(), Vec::new()];
                let mut share = [0.0_f64; 2];
                for (k, shape) in Shape::all(&crane).into_iter().enumerate() {
                    for &hoist in hoists {
                        let p = Profile { shape, hoist };
                        let at = start(&crane, *depth);
                        let seed = 28 + k as u64;
                        let what = || format!("{} {depth} {} {hoist}", crane.name(), shape.name());
                        let o = study_profile(&crane, at, &p, seed)
                            .map_err(|e| format!("{}: {e}", what()))?;
                        let r = run(&crane, at, &p, seed, rule)
                            .map_err(|e| format!("{}: {e}", what()))?;
                        if r.non_finite {
                            return Err(format!("{}: a value not a number", what()));
                        }
                        now.push(o.mismatch[1][0]);
                        following[0].push(r.swing[0]);
                        following[1].push(r.swing[1]);
                        share[0] = share[0].max(o.share);
                        share[1] = share[1].max(r.share);
                    }
                }
                let over = |v: &[f64]| v.iter().filter(|s| **s > 0.1).count();
                println!(
                    "| {} | {depth} | {lever} | {} | {} | {} | {} | {} / {} / {} | {:.3} / {:.3} |",
                    crane.name(),
                    now.len(),
                    median_worst(now.clone()),
                    median_worst(following[0].clone()),
                    median_worst(following[1].clone()),
                    over(&now),
                    over(&following[0]),
                    over(&following[1]),
                    share[0],
                    share[1],
                );
            }
        }
    }
    Ok(())
}
