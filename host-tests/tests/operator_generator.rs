//! Operator mode's generator (`solver_core::operator`, issue 28) on both lab cranes: the
//! inverse models driven by it, its smoothness, the drives' limits and the workspace
//! after the exact flat inverse over 10,000 random stick sequences per crane, the
//! stopping bound, the exact rest, limits, stops, bad demands, and the load in nonlinear
//! plants (the model's and one whose pendulum is 10 % longer or shorter). The hand-over
//! from a running move: `tests/operator_takeover.rs`.
//!
//! `cargo test -p host-tests --release --test operator_generator -- --nocapture` prints
//! the numbers it checks.

use std::f64::consts::PI;

use host_tests::operator::{
    drive, flat_set_points, random_sequences, simulate_plant, Crane, Extremes, Gen, Hold, Pendulum,
    RandomStick, RandomSummary, Record,
};
use host_tests::operator_study::study_depth;
use sim::plant::Rng;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::{subs, Crane3dParams, Crane3dSubs};
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::operator::{
    brake, stopping_bound, Demand, Generator, Generator3d, PlanarGenerator, Settings,
    LAB_HOIST_RING, LAB_RING, SMOOTHNESS,
};
use solver_core::reference::{flat_crane, flat_crane3d};
use solver_core::{DaeModel, Driven, Error, JacobianMode, SolverSettings};

const H: f64 = 0.01;

/// The rope lengths (load depths) studied: the lab range `[3, 9]` m, the deepest within
/// the generator's depth range (the rope's slope under full acceleration).
const DEPTHS: [f64; 5] = [3.0, 4.5, 6.0, 7.5, 8.95];

fn records(
    crane: &Crane,
    robust: bool,
    start: [f64; 3],
    cycles: usize,
    stick: impl FnMut(usize) -> [f64; 3],
) -> (Gen, Vec<Record>) {
    let mut g = crane.start(robust, start).unwrap();
    let mut out = Vec::with_capacity(cycles);
    drive(crane, &mut g, cycles, stick, |r| out.push(*r));
    (g, out)
}

/// A start in the middle of each crane's hall at `depth`.
fn start(crane: &Crane, depth: f64) -> [f64; 3] {
    match crane {
        Crane::Planar(_) => [12.0, 0.0, depth],
        Crane::Spatial(_) => [12.0, 2.0, depth],
    }
}

/// The model's `MIN_SMOOTHNESS` and one more: what the generator promises.
#[test]
fn smooth_enough_for_the_models_and_continuous_to_the_fifth_derivative() {
    let planar = <CraneSubs<f64, PlanarGenerator> as DaeModel<f64, 7, 2>>::MIN_SMOOTHNESS;
    let spatial = <Crane3dSubs<f64, Generator3d> as DaeModel<f64, 10, 3>>::MIN_SMOOTHNESS;
    assert_eq!(SMOOTHNESS, planar.max(spatial) + 1);
    // Across every cycle boundary of a busy 3D run (reversals, hoisting), derivatives
    // 0..=5 from the cycle before equal those from the cycle after, to rounding.
    let crane = Crane::SPATIAL;
    let mut g = crane.start(false, [12.0, 2.0, 6.0]).unwrap();
    let mut rng = RandomStick::new(5, false);
    let mut worst = [0.0_f64; 6];
    let mut sixth = 0.0_f64;
    for n in 0..3000 {
        let end: Option<[[f64; 3]; 7]> = (n > 0).then(|| g.load::<7>(g.time() + H));
        let _ = g.advance(rng.at(n));
        let Some(end) = end else { continue };
        let begin = g.load::<7>(g.time());
        for j in 0..6 {
            for i in 0..3 {
                let scale = 1.0 + end[j][i].abs();
                worst[j] = worst[j].max((end[j][i] - begin[j][i]).abs() / scale);
            }
        }
        for i in 0..3 {
            sixth = sixth.max((end[6][i] - begin[6][i]).abs());
        }
    }
    println!(
        "largest relative jump at a cycle boundary, orders 0..=5: {:?}; the sixth derivative jumps by up to {sixth:.2}",
        worst.map(|w| format!("{w:.1e}"))
    );
    for (j, w) in worst.iter().enumerate() {
        assert!(*w < 1e-8, "order {j} jumps by {w}");
    }
    assert!(
        sixth > 1e-3,
        "the sixth derivative is the one allowed to jump"
    );
}

/// The inverse models driven by the generator through its `Trajectory`: BDF4 (the
/// firmware's structured closed-form step, evaluated at `t_{n+1}`) and RADAU5 (three
/// stage times inside each cycle) on both cranes, the stick changing every few cycles.
/// Their set points follow the exact flat inverse of the generated path within the
/// scheme's error (Eq. 29) at every cycle.
#[test]
fn inverse_models_are_driven_by_the_generator_at_every_stage_time() {
    let s = SolverSettings::paper(JacobianMode::Exact);
    let transformed = SolverSettings::paper(JacobianMode::Transformed);
    let stick = |n: usize| -> [f64; 3] {
        let k = (n / 70) % 5;
        [
            [1.0, 0.4, -0.7, 0.0, 1.0][k],
            [0.5, -1.0, 0.0, 0.8, 0.0][k],
            [0.0, 0.6, -0.6, 0.3, 0.0][k],
        ]
    };
    let cycles = 1500;
    // Planar.
    let p = CraneParams::PAPER;
    let g = PlanarGenerator::at_rest(Settings::lab(&p), 0.0, [12.0], 6.0).unwrap();
    let mut model = CraneSubs::new(p, g).unwrap();
    let mut bdf = crane_subs::StructuredBdf::new(&model, &s, 4, 0.0).unwrap();
    let mut radau_model = model;
    let mut radau = crane_subs::StructuredRadau5::new(&radau_model, &transformed, 0.0).unwrap();
    let (mut e_bdf, mut e_radau) = (0.0_f64, 0.0_f64);
    for n in 0..cycles {
        let [x, _, z] = stick(n);
        let d = Demand {
            horizontal: [x],
            hoist: z,
        };
        let _ = model.trajectory_mut().advance(&d);
        let _ = radau_model.trajectory_mut().advance(&d);
        let a = bdf.step(&model).unwrap();
        let b = radau.step(&radau_model).unwrap();
        let exact = flat_crane::flat_inverse(&p, model.trajectory(), a.t).u;
        for (i, want) in exact.iter().enumerate() {
            e_bdf = e_bdf.max((a.u[i] - want).abs());
            e_radau = e_radau.max((b.u[i] - want).abs());
        }
    }
    println!("planar: largest |u − u_flat|: BDF4 {e_bdf:.2e} m/s, RADAU5 {e_radau:.2e} m/s");
    assert!(e_bdf < 5e-3 && e_radau < 5e-3);
    // 3D.
    let p = Crane3dParams::EXAMPLE;
    let g = Generator3d::at_rest(Settings::lab_3d(&p), 0.0, [12.0, 2.0], 6.0).unwrap();
    let mut model = Crane3dSubs::new(p, g).unwrap();
    let mut bdf = subs::StructuredBdf::new(&model, &s, 4, 0.0).unwrap();
    let mut radau_model = model;
    let mut radau = subs::StructuredRadau5::new(&radau_model, &transformed, 0.0).unwrap();
    let (mut e_bdf, mut e_radau) = (0.0_f64, 0.0_f64);
    for n in 0..cycles {
        let [x, y, z] = stick(n);
        let d = Demand {
            horizontal: [x, y],
            hoist: z,
        };
        let _ = model.trajectory_mut().advance(&d);
        let _ = radau_model.trajectory_mut().advance(&d);
        let a = bdf.step(&model).unwrap();
        let b = radau.step(&radau_model).unwrap();
        let exact = flat_crane3d::flat_inverse(&p, model.trajectory(), a.t).u;
        for (i, want) in exact.iter().enumerate() {
            e_bdf = e_bdf.max((a.u[i] - want).abs());
            e_radau = e_radau.max((b.u[i] - want).abs());
        }
    }
    println!("3D: largest |u − u_flat|: BDF4 {e_bdf:.2e} m/s, RADAU5 {e_radau:.2e} m/s");
    assert!(e_bdf < 5e-3 && e_radau < 5e-3);
}

/// The property: 10,000 random stick sequences of 12 s per crane (levels held 0.05–3 s,
/// full stick, zero, anything between, noise at the deadband; every axis at once;
/// random start anywhere in the hall at any rope length, a tenth of them next to a
/// limit), the drives' motion from the exact flat inverse of the path at the start and
/// middle of every cycle: every set point within 95 % of the drive's velocity and
/// acceleration limits (the planner's margin, left for the scheme's error), the set
/// point's change per cycle too (what the gate checks), no drive and no rope outside
/// the workspace, the rope always in tension.
#[test]
fn random_sticks_keep_every_drive_within_its_limits_and_the_workspace() {
    for (crane, seed) in [(Crane::PLANAR, 2801), (Crane::SPATIAL, 2802)] {
        let RandomSummary {
            sequences,
            worst,
            share,
        } = random_sequences(&crane, seed, 10_000);
        println!(
            "{}: {sequences} sequences: largest |u| {:.3?} m/s, |u̇| {:.3?} m/s², |Δu|/h {:.3?} m/s²; \
             largest share of a limit {:.3} (sequence {}); nearest approach to a range's end {:.2e} m \
             (positive: outside); largest downward load acceleration {:.3} m/s²; largest λ {:.3} 1/s²",
            crane.name(),
            worst.u,
            worst.u_dot,
            worst.du,
            share.0,
            share.1,
            worst.outside,
            worst.down,
            worst.lambda
        );
        assert!(!worst.non_finite);
        assert!(share.0 <= 0.95, "a drive limit's share {}", share.0);
        assert!(
            worst.outside <= 1e-9,
            "outside the workspace by {} m",
            worst.outside
        );
        assert!(worst.down < crane.slack_limit() && worst.lambda < 0.0);
    }
}

/// The bound the generator relies on, without hoisting: the trolley (bridge) is at every
/// instant a convex combination of the load path and the virtual trolley, so its set
/// point keeps `|u| ≤ V + τA` and `|u̇| ≤ A (1 + 2τ/max(T₁, T₂))` exactly — checked with
/// the flat inverse over 1,000 random horizontal stick sequences per crane at random
/// rope lengths. (Hoisting during travel adds the terms of `β̇`, which the 10,000
/// sequences above measure.)
#[test]
fn without_hoisting_the_drives_keep_the_stated_bound() {
    for crane in [Crane::PLANAR, Crane::SPATIAL] {
        let planar = matches!(crane, Crane::Planar(_));
        let mut rng = Rng::new(28);
        let taus = crane.taus();
        let mut worst = [0.0_f64; 2];
        for _ in 0..1000 {
            let depth = rng.uniform(3.0, 8.95);
            let mut g = crane.start(false, start(&crane, depth)).unwrap();
            let (acc, speed) = g.limits();
            let box_max = 0.2;
            let mut stick = RandomStick::new(rng.next_u64(), planar);
            drive(
                &crane,
                &mut g,
                1000,
                |n| {
                    let mut s = stick.at(n);
                    s[2] = 0.0;
                    s
                },
                |r| {
                    for f in &r.flat {
                        for i in 0..2 {
                            if acc[i] == 0.0 {
                                continue;
                            }
                            let u_bound = speed[i] + taus[i] * acc[i];
                            let a_bound = acc[i] * (1.0 + 2.0 * taus[i] / box_max);
                            worst[0] = worst[0].max(f.u[i].abs() / u_bound);
                            worst[1] = worst[1].max(f.u_dot[i].abs() / a_bound);
                        }
                    }
                },
            );
        }
        println!(
            "{}: without hoisting, largest |u|/(V + τA) {:.4}, |u̇|/(A(1 + 2τ/T)) {:.4}",
            crane.name(),
            worst[0],
            worst[1]
        );
        assert!(
            worst[0] <= 1.0 + 1e-9 && worst[1] <= 1.0 + 1e-9,
            "{worst:?}"
        );
    }
}

/// Stick released (after every hold, short ones before the speed is reached, at several
/// speeds) and the latched stop: the load comes to rest within
/// `v²/(2A) + v (τ̄ + h)` of where it was at the release, `v` the rate limiter's largest
/// speed in the filters' window before it, and then rests exactly.
#[test]
fn a_release_stops_within_the_published_bound() {
    let mut worst = f64::NEG_INFINITY;
    let mut cases = 0;
    for crane in [Crane::PLANAR, Crane::SPATIAL] {
        for depth in DEPTHS {
            for robust in [false, true] {
                for level in [0.3, 0.6, 1.0] {
                    for hold in [0.1, 0.3, 0.8, 2.0, 5.0] {
                        let hold_cycles = (hold / H) as usize;
                        let dir = match crane {
                            Crane::Planar(_) => [level, 0.0, 0.0],
                            Crane::Spatial(_) => [level, -0.6 * level, 0.0],
                        };
                        let (g, r) = records(
                            &crane,
                            robust,
                            start(&crane, depth),
                            hold_cycles + 1500,
                            |n| if n < hold_cycles { dir } else { [0.0; 3] },
                        );
                        let (lag, _) = g.lags();
                        let (acc, _) = g.limits();
                        let window = (lag * 2.0 / H) as usize + 400;
                        let release = &r[hold_cycles];
                        // The largest limiter speed in the window before the release.
                        let v_max = |i: usize| {
                            r[hold_cycles.saturating_sub(window)..=hold_cycles]
                                .iter()
                                .map(|x| x.limiter[i].abs())
                                .fold(0.0, f64::max)
                        };
                        let rest = r
                            .iter()
                            .skip(hold_cycles)
                            .find(|x| x.at_rest)
                            .expect("comes to rest");
                        let v = [release.limiter[0], release.limiter[1]];
                        let t_brake = (0..2)
                            .filter(|i| acc[*i] > 0.0)
                            .map(|i| v[i].abs() / acc[i])
                            .fold(0.0, f64::max);
                        for i in 0..2 {
                            if acc[i] == 0.0 {
                                continue;
                            }
                            let travelled = (rest.load[0][i] - release.load[0][i]).abs();
                            let bound = v[i].abs() * (t_brake / 2.0 + H) + v_max(i) * lag;
                            // Single axis: the published formula itself.
                            if dir[1] == 0.0 {
                                let published = stopping_bound(v_max(i), acc[i], lag, H);
                                assert!(bound <= published + 1e-12);
                            }
                            assert!(travelled <= bound + 1e-9, "{} depth {depth} robust {robust} level {level} hold {hold} axis {i}: {travelled} > {bound}", crane.name());
                            worst = worst.max(travelled - bound);
                            cases += 1;
                        }
                        // Exactly at rest afterwards.
                        let later = r.last().unwrap();
                        assert!(later.at_rest);
                        assert_eq!(later.load[0], rest.load[0]);
                        assert_eq!((later.load[1], later.load[2]), ([0.0; 3], [0.0; 3]));
                    }
                }
            }
        }
    }
    println!(
        "{cases} releases: the load stopped at most {:.3} m inside the bound (closest)",
        -worst
    );
}

/// At rest every derivative is exactly 0.0 and the position constant: after a stop, at
/// any time, for as long as no demand comes; the set points from the flat inverse are
/// exactly zero. The step from the motion's last cycle to the rest is at rounding level.
#[test]
fn after_the_stop_the_path_is_exactly_at_rest() {
    for crane in [Crane::PLANAR, Crane::SPATIAL] {
        let (g, r) = records(&crane, true, start(&crane, 7.0), 2500, |n| {
            if n < 300 {
                [1.0, 1.0, 0.7]
            } else if n < 500 {
                [-0.4, 0.2, -1.0]
            } else {
                [0.0; 3]
            }
        });
        let first = r.iter().position(|x| x.at_rest && x.n > 500).unwrap();
        let before = &r[first - 1];
        let at = &r[first];
        let end_of_motion = {
            // The last moving cycle's path at its end, from the records' cycle start and
            // the same piece: compare positions to rounding.
            before.load[0]
        };
        let jump = (0..3)
            .map(|i| (at.load[0][i] - end_of_motion[i]).abs())
            .fold(0.0, f64::max);
        assert!(jump < 0.01, "rest is where the motion ends");
        for x in &r[first..] {
            assert!(x.at_rest);
            assert_eq!(x.load[0], at.load[0]);
            assert_eq!(x.load[1], [0.0; 3]);
            assert_eq!(x.load[2], [0.0; 3]);
            for f in &x.flat {
                assert_eq!(f.u, [0.0; 3], "{}: set points exactly zero", crane.name());
            }
        }
        // Anywhere in time.
        for t in [g.time() - 5.0, g.time() + 0.37, g.time() + 100.0] {
            let d = g.load::<6>(t);
            assert_eq!(d[0], at.load[0]);
            assert!(d.iter().skip(1).all(|v| *v == [0.0; 3]));
        }
        // The step into rest, measured on the generator alone: the path at the end of
        // the last moving cycle against the rest position.
        let mut g = crane.start(true, start(&crane, 7.0)).unwrap();
        let mut last_end = [0.0; 3];
        let mut step = f64::NAN;
        for n in 0..2500 {
            let stick = if n < 300 { [1.0, 1.0, 0.7] } else { [0.0; 3] };
            let c = g.advance(stick);
            if c.at_rest {
                let now = g.load::<1>(g.time())[0];
                step = (0..3)
                    .map(|i| (now[i] - last_end[i]).abs())
                    .fold(0.0, f64::max);
                break;
            }
            last_end = g.load::<1>(g.time() + H)[0];
        }
        println!("{}: step into rest {step:.1e} m", crane.name());
        assert!(step < 1e-12, "{step}");
    }
}

/// A stick held into a limit ends in a sway-free rest at the limit — the load and the
/// drive inside it all the way — and the opposite stick moves it away at once.
#[test]
fn held_into_a_limit_it_stops_there_and_drives_away() {
    for crane in [Crane::PLANAR, Crane::SPATIAL] {
        for depth in [3.0, 8.95] {
            let ranges = crane.ranges();
            let (x_hi, z_hi) = (ranges[0].1, depth);
            let mut g = crane.start(false, [x_hi - 3.0, 1.0, depth]).unwrap();
            let mut e = Extremes::default();
            let mut last = None;
            drive(
                &crane,
                &mut g,
                2500,
                |_| [1.0, 0.0, 0.0],
                |r| {
                    e.add(&crane, r);
                    last = Some(*r);
                },
            );
            let r = last.unwrap();
            assert!(r.at_rest, "at rest at the limit");
            let gap = x_hi - r.load[0][0];
            println!("{} depth {depth}: stopped {gap:.2e} m before x_max, drives at most {:.2e} m outside", crane.name(), e.outside);
            assert!((0.0..1e-4).contains(&gap), "{gap}");
            assert!(e.outside <= 1e-9);
            // Away from it: the first cycle already moves back.
            let _ = g.advance([-1.0, 0.0, 0.0]);
            assert!(g.limiter()[0] < 0.0);
            let _ = z_hi;
        }
    }
}

/// The hoist: lowering into the depth limit ends at rest above it; while the horizontal
/// axes move, the hoist stays above the depth the virtual pendulum was tuned for (so the
/// pendulum is never shorter than the rope).
#[test]
fn the_hoist_stays_above_what_the_pendulum_was_tuned_for() {
    for crane in [Crane::PLANAR, Crane::SPATIAL] {
        let (g, r) = records(&crane, false, start(&crane, 4.0), 3000, |n| {
            if n < 1500 {
                [if (n / 300) % 2 == 0 { 1.0 } else { -1.0 }, 0.0, 1.0]
            } else {
                [0.0, 0.0, 1.0]
            }
        });
        let l_g = g.pendulum();
        let mut deepest_moving = 0.0_f64;
        for x in &r {
            let z = x.load[0][2];
            let moving = x.load[1][0] != 0.0;
            if moving {
                deepest_moving =
                    deepest_moving.max(z * crane.g() / (crane.g() - x.load[2][2].max(0.0)));
            }
        }
        let last = r.last().unwrap();
        println!(
            "{}: travelling and lowering from 4 m: longest effective pendulum while travelling {deepest_moving:.3} m, l_g {l_g:.3} m; after travel the hoist went on to {:.3} m",
            crane.name(),
            last.load[0][2]
        );
        assert!(deepest_moving <= l_g);
        assert!(
            last.load[0][2] > 5.0 + 1.0,
            "lowering continues once the travel has ended"
        );
    }
}

/// The latched stop: demands are ignored from the next cycle until `resume`, the load
/// stops as it does on release; a demand that is not finite is refused and taken as
/// zero.
#[test]
fn stop_latch_and_refused_demands() {
    let p = CraneParams::PAPER;
    let mut g = PlanarGenerator::at_rest(Settings::lab(&p), 0.0, [12.0], 5.0).unwrap();
    for _ in 0..200 {
        let _ = g.advance(&Demand {
            horizontal: [1.0],
            hoist: 0.5,
        });
    }
    g.stop();
    assert!(g.is_stopping());
    let mut rest = 0;
    for n in 0..2000 {
        let c = g.advance(&Demand {
            horizontal: [1.0],
            hoist: 0.5,
        });
        if c.at_rest {
            rest = n;
            break;
        }
    }
    assert!(
        rest > 0 && g.is_at_rest(),
        "stopped and at rest despite the stick"
    );
    let _ = g.advance(&Demand {
        horizontal: [1.0],
        hoist: 0.0,
    });
    assert!(g.is_at_rest(), "still latched");
    g.resume();
    let _ = g.advance(&Demand {
        horizontal: [1.0],
        hoist: 0.0,
    });
    assert!(!g.is_at_rest());
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let mut g = PlanarGenerator::at_rest(Settings::lab(&p), 0.0, [12.0], 5.0).unwrap();
        let c = g.advance(&Demand {
            horizontal: [bad],
            hoist: 0.0,
        });
        assert!(
            c.refused_demand && c.at_rest,
            "{bad}: refused, taken as zero"
        );
        let c = g.advance(&Demand {
            horizontal: [0.0],
            hoist: bad,
        });
        assert!(c.refused_demand && c.at_rest);
    }
    // Beyond full stick: clamped to full.
    let mut a = PlanarGenerator::at_rest(Settings::lab(&p), 0.0, [12.0], 5.0).unwrap();
    let mut b = a;
    for _ in 0..300 {
        let _ = a.advance(&Demand {
            horizontal: [7.0],
            hoist: -3.0,
        });
        let _ = b.advance(&Demand {
            horizontal: [1.0],
            hoist: -1.0,
        });
    }
    assert_eq!(a.demanded_speeds(), b.demanded_speeds());
    // Inside the deadband: no motion at all.
    let mut c = PlanarGenerator::at_rest(Settings::lab(&p), 0.0, [12.0], 5.0).unwrap();
    for n in 0..500 {
        let noise = 0.05 * ((n as f64) * 1.7).sin();
        assert!(
            c.advance(&Demand {
                horizontal: [noise],
                hoist: -noise
            })
            .at_rest
        );
    }
}

/// Settings the generator cannot keep its promises with are refused, each by name.
#[test]
fn bad_settings_and_starts_are_refused() {
    let p = CraneParams::PAPER;
    let good = Settings::lab(&p);
    type Spoil = fn(&mut Settings<1>);
    let cases: [(&str, Spoil); 7] = [
        ("h", |s| s.h = 0.0),
        ("box", |s| s.boxes[0] = 0.015),
        ("hoist box", |s| s.hoist_boxes[2] = -0.2),
        ("deadband", |s| s.deadband = 0.9),
        ("speed", |s| s.horizontal[0].speed = f64::NAN),
        ("hoist acceleration", |s| s.hoist.acceleration = 6.0),
        ("entry_blend", |s| s.entry_blend = 0.0),
    ];
    for (name, spoil) in cases {
        let mut s = good;
        spoil(&mut s);
        let e = PlanarGenerator::at_rest(s, 0.0, [12.0], 5.0).unwrap_err();
        let named = match e {
            Error::InvalidSetting { name: n, .. }
            | Error::NonFiniteParameter { name: n, .. }
            | Error::ParameterOutOfRange { name: n, .. } => n,
            other => panic!("{name}: {other:?}"),
        };
        assert_eq!(named, name);
    }
    // Rings too short for the settings.
    let e = Generator::<1, 100, LAB_HOIST_RING>::at_rest(good, 0.0, [12.0], 5.0).unwrap_err();
    assert!(
        matches!(
            e,
            Error::InvalidSetting {
                name: "horizontal ring length",
                ..
            }
        ),
        "{e:?}"
    );
    let mut robust = good;
    robust.robust = true;
    let (need, hoist) = robust.ring_lengths().unwrap();
    println!("lab settings, robust: rings of {need} and {hoist} cycles (the lab type has {LAB_RING} and {LAB_HOIST_RING})");
    assert!(need <= LAB_RING && hoist <= LAB_HOIST_RING);
    // A start outside the ranges.
    let e = PlanarGenerator::at_rest(good, 0.0, [9.0], 5.0).unwrap_err();
    assert!(matches!(
        e,
        Error::OutsideWorkspace {
            coordinate: "x",
            ..
        }
    ));
    let e = PlanarGenerator::at_rest(good, 0.0, [12.0], 9.5).unwrap_err();
    assert!(matches!(
        e,
        Error::OutsideWorkspace {
            coordinate: "z_C",
            ..
        }
    ));
}

/// The vector: a diagonal stick moves the load along a straight line (to within the
/// speed quanta, `δv/2` per axis times the time), the circle stays a smooth curve with
/// every limit kept.
#[test]
fn a_diagonal_stick_gives_a_straight_load_path() {
    let crane = Crane::SPATIAL;
    let from = [12.0, 1.5, 6.0];
    let (_, r) = records(&crane, false, from, 1500, |n| {
        if n < 600 {
            [1.0, 0.75, 0.0]
        } else {
            [0.0; 3]
        }
    });
    let end = r.last().unwrap().load[0];
    let (dx, dy) = (end[0] - from[0], end[1] - from[1]);
    let norm = (dx * dx + dy * dy).sqrt();
    let across = r
        .iter()
        .map(|x| ((x.load[0][0] - from[0]) * dy - (x.load[0][1] - from[1]) * dx).abs() / norm)
        .fold(0.0, f64::max);
    println!("diagonal: {norm:.3} m travelled, at most {across:.2e} m off the straight line");
    assert!(across < 1e-4, "{across}");
    // The stick through the 5 % deadband, times the axes' manual speeds (1 and 0.8 m/s).
    let want = (0.75 - 0.05) / 0.95 * 0.8 / 1.0;
    assert!(
        (dy / dx - want).abs() < 1e-4,
        "along the stick's direction: {} against {want}",
        dy / dx
    );
}

/// Every scripted profile of the study (`operator_study`: steps and releases at three
/// speeds and five hold times, reversals, pulsing at 0.5–2 Hz, pendant levels, noise at
/// the deadband, and on the 3D crane diagonal and circular sticks — each with the hoist
/// idle, lowering and raising) at every rope length on both cranes:
/// - every drive within 95 % of its limits (the exact flat inverse);
/// - the release within its stopping bound;
/// - model = plant: the inverse model (the firmware's structured BDF4 at 10 ms) driven by
///   the generator, its set points into the crane's nonlinear plant (Eqs. 21–22; the 3D
///   crane's spherical pendulum) joined as the paper's check joins them — from the
///   generator's rest on the load stays within ±10 mm of its rest point and swings at
///   most 0.1° in every plane, while hoisting too;
/// - open loop against a plant whose pendulum is 10 % longer or shorter at every instant
///   (the drum's scaling, or rigging of 10 % of the shortest rope the run reaches:
///   `PendulumError`), driven by the exact flat inverse of the path at the model's
///   length: the robust
///   setting leaves at most 0.1° of swing after the rest when the rope keeps its length
///   during the travel, and less than the plain setting. (Hoisting during the travel
///   moves the rope away from the length the robust pair was tuned for: the study
///   reports that residual.)
#[test]
fn every_scripted_profile_at_every_rope_length() {
    let mut runs = 0;
    let mut worst = [0.0_f64; 5];
    for crane in [Crane::PLANAR, Crane::SPATIAL] {
        for depth in DEPTHS {
            for (p, o) in study_depth(&crane, depth).unwrap() {
                let what = format!(
                    "{} rope {depth} {} hoist {}",
                    crane.name(),
                    p.shape.name(),
                    p.hoist
                );
                assert!(o.share <= 0.95, "{what}: share {}", o.share);
                assert!(
                    o.stop_margin[0] <= 1e-9 && o.stop_margin[1] <= 1e-9,
                    "{what}: {:?}",
                    o.stop_margin
                );
                assert!(
                    o.exact.0 <= 0.010 && o.exact.1 <= 0.1,
                    "{what}: {:?}",
                    o.exact
                );
                let robust = o.ten_percent(1);
                if p.hoist == 0.0 {
                    assert!(robust <= 0.1, "{what}: robust {:?}", o.mismatch);
                    assert!(robust <= o.ten_percent(0), "{what}: {:?}", o.mismatch);
                    worst[3] = worst[3].max(robust);
                } else {
                    worst[4] = worst[4].max(robust);
                }
                worst[0] = worst[0].max(o.share);
                worst[1] = worst[1].max(o.exact.0);
                worst[2] = worst[2].max(o.exact.1);
                runs += 1;
            }
        }
    }
    println!(
        "{runs} profile runs: drive limit share at most {:.3}; model = plant: {:.2e} m, {:.2e}°; \
         ±10 %, robust: hoist idle at most {:.4}°, hoisting at most {:.4}°",
        worst[0], worst[1], worst[2], worst[3], worst[4]
    );
}

/// The plant's pendulum is `scale · rope + offset` whatever the rope does: a trolley
/// nudge starts a swing whose period is that of the pendulum, while the hoist keeps the
/// rope still; the drum's scale 1.21 and the rigging that makes the same pendulum swing
/// alike, 10 % slower than the model's pendulum (both cranes). With the hoist lowering,
/// the depth recorded in the model's measure follows the model's rope for either form.
#[test]
fn the_plant_s_pendulum_is_scaled_rope_plus_rigging() {
    let depth = 4.0;
    // The swing's period from its downward zero crossings (the first plane).
    let period = |m: &host_tests::operator::Motion| {
        let crossings: Vec<f64> = m
            .swing
            .windows(2)
            .enumerate()
            .filter(|(_, w)| w[0][0] > 0.0 && w[1][0] <= 0.0)
            .map(|(n, w)| (n as f64 + w[0][0] / (w[0][0] - w[1][0])) * 0.01)
            .collect();
        let (first, last) = (crossings[0], crossings[crossings.len() - 1]);
        (last - first) / (crossings.len() - 1) as f64
    };
    let nudge: Vec<[f64; 3]> = (0..2000)
        .map(|n| if n < 50 { [0.2, 0.0, 0.0] } else { [0.0; 3] })
        .collect();
    let lowering: Vec<[f64; 3]> = (0..600)
        .map(|n| if n < 300 { [0.0, 0.0, 0.3] } else { [0.0; 3] })
        .collect();
    for (crane, at) in [
        (Crane::PLANAR, [12.0, 0.0, depth]),
        (Crane::SPATIAL, [12.0, 4.0, depth]),
    ] {
        let model = simulate_plant(&crane, at, Pendulum::MODEL, &nudge, Hold::Zero).unwrap();
        let scaled =
            simulate_plant(&crane, at, Pendulum::scaled(1.21), &nudge, Hold::Zero).unwrap();
        let rigged = simulate_plant(
            &crane,
            at,
            Pendulum::longer_by(0.21 * depth),
            &nudge,
            Hold::Zero,
        )
        .unwrap();
        let (t, ts, tr) = (period(&model), period(&scaled), period(&rigged));
        assert!(
            (t - 2.0 * PI * (depth / crane.g()).sqrt()).abs() < 0.02,
            "{t}"
        );
        assert!(
            (ts / t - 1.1).abs() < 2e-3 && (tr / t - 1.1).abs() < 2e-3,
            "{t} {ts} {tr}"
        );
        // The rope pays out 0.3 m/s through the winch's lag for 3 s.
        for pendulum in [Pendulum::scaled(1.1), Pendulum::longer_by(0.4)] {
            let m = simulate_plant(&crane, at, pendulum, &lowering, Hold::Zero).unwrap();
            let end = m.load.last().unwrap()[2];
            assert!((end - (depth + 0.9)).abs() < 1e-6, "{pendulum:?}: {end}");
        }
    }
}

/// The 3D plant with the load in the x–z plane is the planar plant of Eqs. 21–22 (the
/// nonlinear references the profiles are measured in agree).
#[test]
fn the_3d_plant_in_a_plane_is_the_planar_plant() {
    let (planar, spatial) = (
        Crane::PLANAR,
        Crane::Spatial(Crane3dParams::extruded(&CraneParams::PAPER, 0.03, 0.0, 8.0)),
    );
    let (_, r) = records(&planar, false, [12.0, 0.0, 6.0], 1200, |n| {
        if n < 300 {
            [1.0, 0.0, 0.5]
        } else {
            [0.0; 3]
        }
    });
    let u = flat_set_points(&r);
    let rigged = |crane: &Crane, at| {
        simulate_plant(crane, at, Pendulum::longer_by(0.4), &u, Hold::Zero).unwrap()
    };
    let (a, b) = (
        rigged(&planar, [12.0, 0.0, 6.0]),
        rigged(&spatial, [12.0, 4.0, 6.0]),
    );
    let mut worst = 0.0_f64;
    for (p, q) in a.load.iter().zip(&b.load) {
        worst = worst
            .max((p[0] - q[0]).abs())
            .max((p[2] - q[2]).abs())
            .max((q[1] - 4.0).abs());
    }
    for (p, q) in a.swing.iter().zip(&b.swing) {
        worst = worst.max((p[0] - q[0]).abs()).max(q[1].abs());
    }
    println!("3D plant in a plane against the planar plant: largest difference {worst:.1e}");
    assert!(worst < 1e-8, "{worst}");
}

/// The braking distance in quanta is what the docs' formula bounds, for the lab
/// accelerations: `B(n) δp ≤ v²/(2A) + v h/2`.
#[test]
fn braking_units_within_the_formula() {
    for a in [0.3, 0.5, 1.0] {
        let q = solver_core::operator::Quanta::new(a, H);
        for n in (0..40_000).step_by(7) {
            let v = n as f64 * q.velocity;
            assert!(brake(n) as f64 * q.position <= v * v / (2.0 * a) + v * H / 2.0 + 1e-12);
        }
    }
}
