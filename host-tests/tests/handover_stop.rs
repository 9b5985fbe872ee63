//! How far a hand-over's stop carries the load (issue 28, "a stick deflection during an
//! automatic move ends that move with the on-path stop"), against the planner's
//! on-path stop (a stop request on 0x210) taken at the same instant: on the planar and
//! the 3D lab crane, moves with the hoist still, raising and lowering, interrupted at
//! 10, 30, 50, 70 and 90 % of their time.
//!
//! Both stops are what the controller does: the hand-over is
//! `controller::operator::path::Source::take_over` (the generator's own stop within what
//! the drives leave beside the operator, `controller::operator::path::room`) on the move
//! the planner planned, the stick centred afterwards so that the load path is that stop
//! alone; the planner's is `Planner::plan_stop` on the same plan at the same instant
//! (`None`: no stop beats the move, which then runs on to its target).
//!
//! What the code guarantees, and what is asserted here: the hand-over's stop continues
//! the move on its straight path, never turns back, and rests at or before its target
//! (its end is a share in [0, 1] of the way left, `solver_core::operator`'s `entry`),
//! within [`Settings::entry_blend`]; the planner's rests on the path at or before the
//! target too, no later than the move would have (`Stop::stays_on_path`). So along every
//! axis the hand-over's stop is never longer than the planner's longest stop, the move
//! itself. Nothing orders it against the planner's *shortest* stop: the planner may use
//! 95 % of each drive's limits and bisects its durations to 5 %, the hand-over's stop
//! only what the operator leaves of 95 % (`room`), on a grid of durations a fifth apart,
//! and it takes the trolley's smoothest end before the nearest. The table says how the
//! two compare, and — its last columns — how far the load travels when a stop is
//! commanded 0.1 s after the take-over (`Source::stop`, which shortens the hand-over's
//! stop where the room allows): never farther or later than the hand-over's own.
//!
//! `cargo test -p host-tests --test handover_stop -- --nocapture` prints the table.

use controller::crane::{command_plan, Crane};
use controller::operator::path::Source;
use controller::planner::Planner;
use controller::setpoint::{AxisLimits, DriveLimits};
use nalgebra::SVector;
use scene::cranes::planar::Planar;
use scene::cranes::spatial::Spatial;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::Crane3dParams;
use solver_core::operator::{Generator3d, PlanarGenerator, Settings};
use solver_core::plan::Plan;
use solver_core::trajectory::{PointToPoint, Trajectory};
use solver_core::Error;

/// The controller's cycle, s.
const H: f64 = 0.01;

/// Where in its time a move is interrupted.
const SHARES: [f64; 5] = [0.1, 0.3, 0.5, 0.7, 0.9];

/// A move of one crane: what the hoist does, from, to (the model's outputs, depth last),
/// duration.
struct Move<const A: usize> {
    hoist: &'static str,
    from: [f64; A],
    to: [f64; A],
    duration: f64,
}

/// The planar moves: level, the manual scene's move (raising), and back down.
const PLANAR: [Move<2>; 3] = [
    Move {
        hoist: "still",
        from: [12.0, 6.0],
        to: [18.0, 6.0],
        duration: 6.0,
    },
    Move {
        hoist: "raising",
        from: [12.0, 8.0],
        to: [20.0, 4.0],
        duration: 8.0,
    },
    Move {
        hoist: "lowering",
        from: [20.0, 4.0],
        to: [13.0, 7.0],
        duration: 8.0,
    },
];

/// The 3D moves: level and diagonal, the 3D manual scene's move (raising), and one that
/// lowers (`takeover_limits`'s).
const SPATIAL: [Move<3>; 3] = [
    Move {
        hoist: "still",
        from: [12.0, 3.0, 6.0],
        to: [18.0, 5.0, 6.0],
        duration: 8.0,
    },
    Move {
        hoist: "raising",
        from: [12.0, 3.0, 8.0],
        to: [20.0, 6.0, 4.0],
        duration: 8.0,
    },
    Move {
        hoist: "lowering",
        from: [19.0, 6.0, 4.0],
        to: [13.0, 2.0, 7.0],
        duration: 10.0,
    },
];

/// One stop: per axis the distance the load travels from the take-over to its rest
/// (signed, m), and how long it takes, s.
#[derive(Debug, Clone, Copy)]
struct Travel<const A: usize> {
    distance: [f64; A],
    duration: f64,
}

impl<const A: usize> Travel<A> {
    /// Along the path, m.
    fn length(&self) -> f64 {
        self.distance.iter().map(|d| d * d).sum::<f64>().sqrt()
    }
}

/// One case measured.
struct Case<const A: usize> {
    /// The load's speed at the take-over, m/s.
    speed: f64,
    /// The way left to the target per axis, m (signed).
    left: [f64; A],
    /// The time the move has left, s.
    rest_in: f64,
    /// The hand-over's stop; `None`: refused (no stop fits the room), the controller
    /// then ends the move with the planner's stop.
    handover: Option<Travel<A>>,
    /// The planner's stop; `None`: no stop beats the move, which runs to its target.
    planner: Option<Travel<A>>,
    /// The hand-over's stop with a stop commanded [`STOP_AFTER`] cycles after the
    /// take-over (`Source::stop`: shortened within the same room), from the take-over.
    stopped: Option<(Travel<A>, f64)>,
}

/// Cycles after the take-over at which [`Case::stopped`]'s stop is commanded (0.1 s).
const STOP_AFTER: usize = 10;

/// `a − b`.
fn minus<const A: usize>(a: [f64; A], b: [f64; A]) -> [f64; A] {
    let mut out = a;
    for (o, b) in out.iter_mut().zip(b) {
        *o -= b;
    }
    out
}

/// `a · b`.
fn dot<const A: usize>(a: [f64; A], b: [f64; A]) -> f64 {
    a.iter().zip(b).map(|(a, b)| a * b).sum()
}

/// The move planned by `planner` from rest, interrupted at `share` of its time: the
/// hand-over's stop (generator `G` with `settings`, the stick centred after it) and
/// the planner's stop at the same instant. Asserts, cycle by cycle, that the hand-over's
/// stop keeps to the move's straight path, never turns back, and rests at or before the
/// target within the settings' `entry_blend`.
fn measure<K: Crane<A>, G: Source<A> + Copy, const A: usize>(
    planner: &Planner<K, A>,
    settings: G::Settings,
    entry_blend: f64,
    mv: &Move<A>,
    share: f64,
    case: &str,
) -> Case<A> {
    let mut plan: Plan<f64, A> = command_plan::<K, A>(mv.from, 4).unwrap();
    let m: PointToPoint<f64, A> = planner
        .plan_move(&plan, mv.to, Some(mv.duration), 0.0)
        .unwrap_or_else(|r| panic!("{case}: the move refused: {r:?}"));
    plan.push(m).unwrap();
    let (t0, t1) = (m.t_start(), m.t_start() + m.duration());
    let t = ((t0 + share * (t1 - t0)) / H).round() * H;
    let [at, v]: [SVector<f64, A>; 2] = plan.derivatives(t);
    let at: [f64; A] = at.into();
    let left = minus(mv.to, at);
    let way = minus(mv.to, mv.from);
    let way2 = dot(way, way);
    // σ: the share of the move's way at `p`; and how far `p` lies off the line.
    let sigma = |p: [f64; A]| dot(minus(p, mv.from), way) / way2;
    let off = |p: [f64; A]| {
        let s = sigma(p);
        let mut d = minus(p, mv.from);
        for (d, w) in d.iter_mut().zip(way) {
            *d -= s * w;
        }
        dot(d, d).sqrt()
    };

    let planner_stop = planner.plan_stop(&plan, t).map(|stop| {
        assert!(stop.stays_on_path(), "{case}: the planner's stop");
        let end: [f64; A] = stop.end().into();
        Travel {
            distance: minus(end, at),
            duration: stop.t_end() - t,
        }
    });

    let mut g = G::parked(settings);
    let limits: [AxisLimits; A] = planner.limits();
    let taken = g.take_over(settings, t, &m, &limits);
    let stopped = taken
        .is_ok()
        .then(|| stopped_after(g, t, at, &limits, case));
    let handover = match taken {
        Ok(()) => {
            let start: [SVector<f64, A>; 1] = g.derivatives(t);
            let start: [f64; A] = start[0].into();
            assert!(
                dot(minus(start, at), minus(start, at)).sqrt() < 1e-9,
                "{case}: the path continues the move"
            );
            let mut last = sigma(at);
            let mut rest = None;
            for _ in 0..3000 {
                let cycle = g.advance([0.0; 2], 0.0);
                let [p]: [SVector<f64, A>; 1] = g.derivatives(g.time());
                let p: [f64; A] = p.into();
                let s = sigma(p);
                assert!(off(p) < 1e-9, "{case}: {} m off the move's path", off(p));
                assert!(
                    s >= last - 1e-12,
                    "{case}: turns back at {} s: σ {s} after {last}",
                    g.time()
                );
                assert!(s <= 1.0 + 1e-12, "{case}: past the target: σ {s}");
                last = s;
                if cycle.at_rest {
                    rest = Some((g.time(), p));
                    break;
                }
            }
            let (when, end) = rest.unwrap_or_else(|| panic!("{case}: never at rest"));
            let duration = when - t;
            assert!(
                duration <= entry_blend + 1e-9,
                "{case}: the stop took {duration} s, longer than entry_blend {entry_blend} s"
            );
            Some(Travel {
                distance: minus(end, at),
                duration,
            })
        }
        Err(Error::NoHandoverStop { .. }) => None,
        Err(e) => panic!("{case}: refused for another reason: {e}"),
    };
    Case {
        speed: v.norm(),
        left,
        rest_in: t1 - t,
        handover,
        planner: planner_stop,
        stopped,
    }
}

/// The taken-over generator `g` (taken over at `t` where the load was `at`), the stick
/// centred, a stop commanded [`STOP_AFTER`] cycles later: never turning back on any
/// axis (the hoist keeps the end its stop had; the travel's shortened), at rest within
/// 30 s; its travel from the take-over, and the largest step back on any axis, m.
fn stopped_after<G: Source<A>, const A: usize>(
    mut g: G,
    t: f64,
    at: [f64; A],
    limits: &[AxisLimits; A],
    case: &str,
) -> (Travel<A>, f64) {
    let mut last = at;
    let mut direction = [0.0; A];
    let mut back = 0.0_f64;
    for n in 0..3000 {
        if n == STOP_AFTER {
            g.stop(limits);
        }
        let cycle = g.advance([0.0; 2], 0.0);
        let [p]: [SVector<f64, A>; 1] = g.derivatives(g.time());
        let p: [f64; A] = p.into();
        for (k, ((d, p), l)) in direction.iter_mut().zip(p).zip(last).enumerate() {
            let step = p - l;
            if *d == 0.0 && step.abs() > 1e-9 {
                *d = step.signum();
            }
            // A few nanometres back near the rest: the nearest end brakes as hard as the
            // room allows, and the stop is checked for turning back at 17 points.
            assert!(
                step * *d >= -1e-6,
                "{case}: axis {k} turns back at cycle {n}: {step} m, at {p} m"
            );
            back = back.max(-step * *d);
        }
        last = p;
        if cycle.at_rest {
            return (
                Travel {
                    distance: minus(p, at),
                    duration: g.time() - t,
                },
                back,
            );
        }
    }
    panic!("{case}: never at rest after the stop");
}

/// `[x, y, z]` of a planar (`x, z`) or 3D distance, for the table.
fn slots<const A: usize>(d: [f64; A]) -> [Option<f64>; 3] {
    match d.as_slice() {
        [x, z] => [Some(*x), None, Some(*z)],
        [x, y, z] => [Some(*x), Some(*y), Some(*z)],
        _ => [None; 3],
    }
}

/// `| Δx | Δy | Δz | T |` of a stop, `—` where the crane has no such axis, `note` after T.
fn travel_cells<const A: usize>(t: &Travel<A>, note: &str) -> String {
    let mut out = String::new();
    for d in slots(t.distance) {
        out += &d.map_or(" — |".to_string(), |d| format!(" {:.3} |", d.abs()));
    }
    out + &format!(" {:.2}{note} |", t.duration)
}

/// The cases of one crane: asserted, each a row of the table.
fn crane<K: Crane<A>, G: Source<A> + Copy, const A: usize>(
    name: &str,
    planner: &Planner<K, A>,
    settings: G::Settings,
    entry_blend: f64,
    moves: &[Move<A>],
    rows: &mut Vec<String>,
    counts: &mut Counts,
) {
    for mv in moves {
        for share in SHARES {
            let label = format!(
                "{name} {} s {:?} → {:?} (hoist {}) at {:.0} %",
                mv.duration,
                mv.from,
                mv.to,
                mv.hoist,
                share * 100.0
            );
            let c = measure::<K, G, A>(planner, settings, entry_blend, mv, share, &label);
            // The planner's longest stop is the move itself: its target.
            let longest = Travel {
                distance: c.left,
                duration: c.rest_in,
            };
            let planner_stop = c.planner.unwrap_or(longest);
            for (k, (h, l)) in c
                .handover
                .iter()
                .flat_map(|h| h.distance.iter().zip(c.left))
                .enumerate()
            {
                assert!(
                    h * l >= 0.0 && h.abs() <= l.abs() + 1e-9,
                    "{label}: axis {k}: the hand-over's stop travels {h} m of the {l} m left"
                );
            }
            for (k, (p, l)) in planner_stop.distance.iter().zip(c.left).enumerate() {
                assert!(
                    p * l >= -1e-12 && p.abs() <= l.abs() + 1e-9,
                    "{label}: axis {k}: the planner's stop travels {p} m of the {l} m left"
                );
            }
            assert!(
                planner_stop.duration <= c.rest_in + 1e-9,
                "{label}: the planner's stop rests after the move would have"
            );
            counts.longest_planner = counts.longest_planner.max(planner_stop.duration);
            let planner_cells = match c.planner {
                Some(p) => travel_cells(&p, ""),
                None => travel_cells(&longest, " (the move)"),
            };
            if let (Some(h), Some((s, back))) = (c.handover, c.stopped) {
                counts.stop_back = counts.stop_back.max(back);
                for (k, (s, h)) in s.distance.iter().zip(h.distance).enumerate() {
                    assert!(
                        s.abs() <= h.abs() + 1e-9,
                        "{label}: axis {k}: with the stop {s} m, the hand-over's own {h} m"
                    );
                }
                assert!(
                    s.duration <= h.duration + 1e-9,
                    "{label}: the stop rests later"
                );
                if s.length() < h.length() - 1e-3 {
                    counts.stop_shortened += 1;
                }
                counts.stop_least = counts.stop_least.min(s.length() / h.length());
            }
            let stopped_cells = c.stopped.map_or(" — | — |".to_string(), |(s, _)| {
                format!(" {:.3} | {:.2} |", s.length(), s.duration)
            });
            let (handover_cells, ratio) = match c.handover {
                Some(h) => {
                    counts.taken += 1;
                    counts.longest_handover = counts.longest_handover.max(h.duration);
                    let ratio = h.length() / planner_stop.length();
                    if h.length() < planner_stop.length() - 1e-9 {
                        counts.shorter += 1;
                    }
                    counts.largest = counts.largest.max(ratio);
                    counts.least = counts.least.min(ratio);
                    (travel_cells(&h, ""), format!(" {ratio:.2} |"))
                }
                None => {
                    counts.refused += 1;
                    (
                        " refused: the planner's stop | | | |".to_string(),
                        " 1 |".to_string(),
                    )
                }
            };
            rows.push(format!(
                "| {name} | {} s, hoist {} | {:.0} % | {:.2} | {:.3} |{handover_cells}{planner_cells}{ratio}{stopped_cells}",
                mv.duration,
                mv.hoist,
                share * 100.0,
                c.speed,
                longest.length(),
            ));
        }
    }
}

/// What the table adds up to.
struct Counts {
    taken: usize,
    refused: usize,
    /// Hand-overs whose stop was shorter than the planner's.
    shorter: usize,
    least: f64,
    largest: f64,
    /// The longest hand-over's stop and the longest planner's, s.
    longest_handover: f64,
    longest_planner: f64,
    /// Hand-overs whose stop a stop command 0.1 s later shortened by more than 1 mm
    /// along the path, and the least share of the hand-over's own travel it left.
    stop_shortened: usize,
    stop_least: f64,
    /// The largest step back on any axis after such a stop, m.
    stop_back: f64,
}

/// The hand-over's stop on both lab cranes, three moves each, interrupted at 10 to
/// 90 %: on the move's path, never turning back, at rest at or before the target within
/// `entry_blend`, per axis never farther than the target (the planner's longest stop);
/// the table against the planner's shortest.
#[test]
fn a_hand_over_s_stop_rests_on_the_path_no_farther_than_the_target() {
    let mut rows = Vec::new();
    let mut counts = Counts {
        taken: 0,
        refused: 0,
        shorter: 0,
        least: f64::INFINITY,
        largest: 0.0,
        longest_handover: 0.0,
        longest_planner: 0.0,
        stop_shortened: 0,
        stop_least: f64::INFINITY,
        stop_back: 0.0,
    };
    let planar = Settings::lab(&CraneParams::PAPER);
    crane::<Planar, PlanarGenerator, 2>(
        "planar",
        &Planner::with_axes(Planar::PAPER, DriveLimits::LAB.axes()),
        planar,
        planar.entry_blend,
        &PLANAR,
        &mut rows,
        &mut counts,
    );
    let spatial = Settings::lab_3d(&Crane3dParams::EXAMPLE);
    crane::<Spatial, Generator3d, 3>(
        "3D",
        &Planner::with_axes(Spatial::EXAMPLE, DriveLimits::LAB_3D),
        spatial,
        spatial.entry_blend,
        &SPATIAL,
        &mut rows,
        &mut counts,
    );
    println!(
        "The hand-over's stop against the planner's on-path stop at the same instant: the \
         load's travel from the take-over to its rest per axis (|Δ|, m) and the time to rest \
         (T, s); \"the move\": no stop beats the move, which runs to its target."
    );
    println!(
        "| crane | move | at | load speed, m/s | way left, m | hand-over Δx | Δy | Δz | T | \
         planner Δx | Δy | Δz | T | hand-over / planner | stopped 0.1 s after: travel | T |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &rows {
        println!("{r}");
    }
    println!(
        "{} hand-overs taken, {} refused; the hand-over's stop / the planner's along the \
         path: {:.2} to {:.2}, shorter in {} cases; the longest hand-over's stop {:.2} s \
         (entry_blend {} s), the longest planner's {:.2} s",
        counts.taken,
        counts.refused,
        counts.least,
        counts.largest,
        counts.shorter,
        counts.longest_handover,
        planar.entry_blend,
        counts.longest_planner
    );
    println!(
        "A stop commanded 0.1 s after the take-over shortened {} of the {} hand-overs' \
         stops by more than 1 mm along the path (to {:.2} of their own travel at least), \
         none longer or later; the largest step back on an axis {:.1e} m",
        counts.stop_shortened, counts.taken, counts.stop_least, counts.stop_back
    );
    assert_eq!(counts.taken + counts.refused, 30);
    // A stop that never shortens anything would pass the checks above.
    assert!(
        counts.stop_shortened >= 5,
        "{} shortened",
        counts.stop_shortened
    );
    // Refusing is no way to pass: most hand-overs find a stop.
    assert!(counts.taken >= 25, "{} refused", counts.refused);
}
