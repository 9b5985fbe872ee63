//! Manual mode with the state feedback, as the firmware of a scene with `[operator]` and
//! `[feedback]` runs it, on the plant that is not the model (issue 28, "Closed loop"):
//! the planar crane and the 3D crane with its feedback per vertical plane, at several
//! rope lengths, travelling with the hoist still and while hoisting. Each case: the hoist
//! brought to the rope length with its lever, full stick for 4 s (the 3D crane: bridge
//! and trolley at once, a diagonal) started 2, 2.5 or 3 s after the hoist rests, the
//! release; from the cycle every set point is exactly 0.0 on, over one period of the
//! plant's pendulum, the plant's load's largest distance from where it rests and its
//! largest swing, the worst of the three starts. The targets: ±50 mm and 0.1°
//! within one swing period of rest.
//!
//! The plant is `drive_view::engine::PLANT` (`sim::MISMATCHED`'s drive lags, friction and
//! noisy quantised sensors, the pendulum about 10 % longer than the model's rope).
//! `cargo test --release -p drive-view --test closed_loop -- --nocapture` prints the
//! table (docs/OPERATOR.md, "Closed loop in manual mode").

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

use std::path::PathBuf;

use drive_view::engine::{Engine, Snapshot};
use drive_view::switch::{Action, Axis, MasterSwitch, NOTCHES};

const G: f64 = 9.81;

fn engine(scene: &str) -> (Engine, MasterSwitch) {
    engine_on(scene, drive_view::engine::PLANT)
}

/// [`engine`] on another plant that is not the model.
fn engine_on(scene: &str, plant: sim::plant::Mismatch) -> (Engine, MasterSwitch) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(scene);
    let e = Engine::for_scene_with(&path, plant).unwrap();
    let s = MasterSwitch::new(e.has_y());
    (e, s)
}

/// `seconds` of cycles, every one without a fault and with finite set points.
fn run(e: &mut Engine, s: &mut MasterSwitch, seconds: f64) -> Vec<Snapshot> {
    e.run_for(s, seconds).unwrap()
}

/// Runs until every set point is exactly 0.0 (at most `seconds`), checking every cycle.
fn until_rest(e: &mut Engine, s: &mut MasterSwitch, seconds: f64) {
    let n = (seconds * 1000.0 / f64::from(e.period_ms())).round() as usize;
    for _ in 0..n {
        if e.checked_cycle(s).unwrap().setpoints == [0.0; 3] {
            return;
        }
    }
    panic!("no rest within {seconds} s");
}

/// One case's outcome.
struct Case {
    rope: f64,
    hoisting: bool,
    /// The load's largest distance from where it rests, m, over the pendulum's period.
    within: f64,
    /// Its largest swing, degrees, over the same.
    swing: f64,
    /// The plant's pendulum, m.
    pendulum: f64,
}

/// Manual mode entered, the hoist driven to about `rope` m, `wait` s after its set
/// points rest full stick along `axes` for 4 s (with the hoist lowering at half stick if
/// `hoisting`), released, and the load judged over the plant's pendulum period after
/// the set points rest.
fn case(scene: &str, rope: f64, axes: &[Axis], hoisting: bool, wait: f64) -> Case {
    let (mut e, mut s) = engine(scene);
    run(&mut e, &mut s, 3.0);
    s.apply(Action::ToggleManual);
    run(&mut e, &mut s, 0.3);
    // The hoist to the rope length (the lever at full: 0.5 m/s), then still.
    let depth = |snaps: &[Snapshot]| snaps.last().unwrap().plant.drives[2];
    let now = depth(&run(&mut e, &mut s, 0.01));
    let step = if rope > now { 1 } else { -1 };
    for _ in 0..NOTCHES {
        s.apply(Action::Notch(Axis::Z, step));
    }
    let mut l = now;
    while (rope - l) * f64::from(step) > 0.3 {
        l = depth(&run(&mut e, &mut s, 0.1));
    }
    s.apply(Action::Centre);
    until_rest(&mut e, &mut s, 20.0);
    run(&mut e, &mut s, wait);
    // The travel.
    for axis in axes {
        for _ in 0..NOTCHES {
            s.apply(Action::Notch(*axis, 1));
        }
    }
    if hoisting {
        for _ in 0..NOTCHES / 2 {
            s.apply(Action::Notch(Axis::Z, 1));
        }
    }
    run(&mut e, &mut s, 4.0);
    s.apply(Action::Centre);
    until_rest(&mut e, &mut s, 30.0);
    let rest = run(&mut e, &mut s, 0.01);
    let plant = rest.last().unwrap().plant;
    let pendulum = plant.load[2];
    let period = 2.0 * std::f64::consts::PI * (pendulum / G).sqrt();
    let after = run(&mut e, &mut s, period);
    let at = after.last().unwrap().plant.load;
    let within = after
        .iter()
        .map(|c| {
            let d: f64 = (0..3).map(|i| (c.plant.load[i] - at[i]).powi(2)).sum();
            d.sqrt()
        })
        .fold(0.0, f64::max);
    let swing = after
        .iter()
        .flat_map(|c| c.swing_deg())
        .fold(0.0_f64, |m, a| m.max(a.abs()));
    assert!(after.last().unwrap().manual(), "still in manual mode");
    Case {
        rope: plant.drives[2],
        hoisting,
        within,
        swing,
        pendulum,
    }
}

/// The rest before the travel, s, after the hoist's set points rest: each row of
/// [`table`] is the worst over these.
const START_WAITS: [f64; 3] = [2.0, 2.5, 3.0];

fn table(crane: &str, scene: &str, axes: &[Axis]) {
    let mut worst = (0.0_f64, 0.0_f64);
    let mut rows = String::from(
        "| crane | rope at rest, m | hoist in the travel | plant's pendulum, m | load within, mm | swing below, ° |\n\
         |---|---:|---|---:|---:|---:|\n",
    );
    for rope in [3.5, 5.0, 6.5, 8.0] {
        for hoisting in [false, true] {
            // The worst of three start instants: one run's result depends on where in
            // the sensors' noise and the load's residual motion the travel starts (on
            // 4a7f83f, starting 0.5 s later moved single rows from 3.8 to 14.1 mm).
            let c = START_WAITS
                .iter()
                .map(|&wait| case(scene, rope, axes, hoisting, wait))
                .reduce(|a, b| Case {
                    within: a.within.max(b.within),
                    swing: a.swing.max(b.swing),
                    ..a
                })
                .unwrap();
            rows += &format!(
                "| {crane} | {:.2} | {} | {:.2} | {:.1} | {:.3} |\n",
                c.rope,
                if c.hoisting { "lowering" } else { "still" },
                c.pendulum,
                c.within * 1000.0,
                c.swing
            );
            worst = (worst.0.max(c.within), worst.1.max(c.swing));
        }
    }
    println!("{rows}");
    let (within, swing) = worst;
    assert!(
        within <= 0.05,
        "{crane}: the load moved {within} m after rest"
    );
    assert!(swing <= 0.1, "{crane}: swing {swing}° after rest");
}

#[test]
fn the_planar_crane_in_manual_mode_with_feedback_rests_within_the_targets() {
    table("planar", "paper-crane-manual-feedback.toml", &[Axis::X]);
}

#[test]
fn the_3d_crane_in_manual_mode_with_feedback_per_plane_rests_within_the_targets() {
    table(
        "3D",
        "crane3d/crane3d-manual-feedback.toml",
        &[Axis::X, Axis::Y],
    );
}

/// Manual mode asked for at rest with the stick centred, on the plant's noisy, quantised
/// sensors: for 5 s every set point is exactly 0.0 and no drive of the plant moves — on
/// both cranes (the feedback observes from the entry and holds its correction until the
/// stick's first demand; acting from the entry, up to 785a611, it moved the trolley on
/// the noise: 4.3 mm on `cargo run --release -p drive-view --example
/// manual_entry_at_rest`'s plant).
#[test]
fn manual_mode_entered_at_rest_moves_nothing_on_either_crane() {
    for scene in [
        "paper-crane-manual-feedback.toml",
        "crane3d/crane3d-manual-feedback.toml",
    ] {
        let (mut e, mut s) = engine(scene);
        let before = run(&mut e, &mut s, 3.0);
        let stood = before.last().unwrap().plant.drives;
        s.apply(Action::ToggleManual);
        let after = run(&mut e, &mut s, 5.0);
        assert!(after.iter().any(Snapshot::manual), "{scene}: manual mode");
        assert!(
            after.iter().all(|c| c.setpoints == [0.0; 3]),
            "{scene}: a set point other than 0.0 without a command"
        );
        assert!(
            after.iter().all(|c| c.plant.drives == stood),
            "{scene}: a drive moved"
        );
    }
}

/// After a jog and its release on the plant's noisy, quantised sensors, once the feedback
/// lets go (every set point exactly 0.0) nothing moves again without a command: for the
/// following 60 s every set point stays 0.0 — after jogs of 0.3, 1 and 4 s, both cranes
/// (it let go 6.4–8.8 s after the release).
#[test]
fn once_let_go_after_a_jog_nothing_moves_again_without_a_command() {
    for scene in [
        "paper-crane-manual-feedback.toml",
        "crane3d/crane3d-manual-feedback.toml",
    ] {
        for jog in [0.3, 1.0, 4.0] {
            let (mut e, mut s) = engine(scene);
            run(&mut e, &mut s, 3.0);
            s.apply(Action::ToggleManual);
            run(&mut e, &mut s, 0.3);
            for _ in 0..NOTCHES {
                s.apply(Action::Notch(Axis::X, 1));
            }
            run(&mut e, &mut s, jog);
            s.apply(Action::Centre);
            until_rest(&mut e, &mut s, 15.0);
            let after = run(&mut e, &mut s, 60.0);
            assert!(
                after.iter().all(|c| c.setpoints == [0.0; 3]),
                "{scene}, jog {jog} s: a set point other than 0.0 after the feedback let go"
            );
        }
    }
}

/// Manual mode entered at rest and only the hoist's lever at full for 3 s, lowering and
/// raising, on the plant's noisy, quantised sensors: bridge and trolley have no path and
/// are judged at rest — let go when the hoist's lever closes the loop, and the load
/// within the hold thresholds while the hoist moves —, so
/// every bridge and trolley set point is exactly 0.0 and those drives of the plant stay
/// where they stood, until 5 s after the hoist rests, on both cranes. Acting on the
/// young observer's estimate, the travel's feedback moved the trolley on the angle's
/// noise (7.0 mm at up to 0.139 m/s on `operator_feedback`'s plant, 4a7f83f).
#[test]
fn the_hoist_alone_moves_no_travel_drive_on_either_crane() {
    for scene in [
        "paper-crane-manual-feedback.toml",
        "crane3d/crane3d-manual-feedback.toml",
    ] {
        for step in [1, -1] {
            let (mut e, mut s) = engine(scene);
            run(&mut e, &mut s, 3.0);
            s.apply(Action::ToggleManual);
            let stood = run(&mut e, &mut s, 0.3).last().unwrap().plant.drives;
            for _ in 0..NOTCHES {
                s.apply(Action::Notch(Axis::Z, step));
            }
            let mut cycles = run(&mut e, &mut s, 3.0);
            s.apply(Action::Centre);
            cycles.extend(run(&mut e, &mut s, 5.0));
            let hoisted = (cycles.last().unwrap().plant.drives[2] - stood[2]).abs();
            assert!(hoisted > 0.5, "{scene}: the hoist moved {hoisted} m");
            assert!(
                cycles.iter().all(|c| c.setpoints[..2] == [0.0; 2]),
                "{scene}, {step}: a travel set point other than 0.0"
            );
            assert!(
                cycles.iter().all(|c| c.plant.drives[..2] == stood[..2]),
                "{scene}, {step}: a travel drive moved"
            );
        }
    }
}

/// The largest swing in either plane over `seconds`, degrees.
fn largest_swing(e: &mut Engine, s: &mut MasterSwitch, seconds: f64) -> f64 {
    run(e, s, seconds)
        .iter()
        .flat_map(|c| c.swing_deg())
        .fold(0.0_f64, |m, a| m.max(a.abs()))
}

/// A load already swinging 1° when manual mode is entered at rest (on the 3D crane
/// towards 45°: 0.71° in each vertical plane, `scene::cranes::spatial`'s plant), and
/// only the hoist's lever at half for 3 s, lowering and raising, on both cranes: the
/// travel, let go as the hoist's lever closes the loop, takes hold as the load's motion
/// shows the swing and damps it while the hoist moves — over the hoist's last second
/// less than 0.6 of the swing at the entry — and less than 0.1° is left over the 3 s
/// that follow 3 s of rest after the hoist. The 3D crane's case of `operator_feedback`'s
/// `a_swinging_load_is_damped_while_only_the_hoist_moves` (review s24 found none; each
/// plane runs the planar feedback). Printed: the swing grows by a quarter in the
/// hoist's first 2 s (1.23°, 0.88°) before it is damped, as in the planar test.
#[test]
fn a_swinging_load_is_damped_while_only_the_hoist_moves_on_either_crane() {
    let swinging = sim::plant::Mismatch {
        swing0: 1f64.to_radians(),
        ..drive_view::engine::PLANT
    };
    for scene in [
        "paper-crane-manual-feedback.toml",
        "crane3d/crane3d-manual-feedback.toml",
    ] {
        for step in [1, -1] {
            let (mut e, mut s) = engine_on(scene, swinging);
            let before = largest_swing(&mut e, &mut s, 2.0);
            s.apply(Action::ToggleManual);
            run(&mut e, &mut s, 0.09);
            for _ in 0..NOTCHES / 2 {
                s.apply(Action::Notch(Axis::Z, step));
            }
            let hoisting = largest_swing(&mut e, &mut s, 2.0);
            let hoist_end = largest_swing(&mut e, &mut s, 1.0);
            s.apply(Action::Centre);
            let rest = largest_swing(&mut e, &mut s, 3.0);
            let after = largest_swing(&mut e, &mut s, 3.0);
            println!(
                "{scene}, hoist {step}: swing at the entry {before:.3}°, in the hoist's \
                 first 2 s {hoisting:.3}°, its last second {hoist_end:.3}°, in the 3 s \
                 after {rest:.3}°, in the next 3 s {after:.3}°"
            );
            assert!(
                before > 0.7,
                "{scene}: {before}°: the load swings at the entry"
            );
            assert!(
                hoist_end < 0.6 * before,
                "{scene}, hoist {step}: {hoist_end}° in the hoist's last second"
            );
            assert!(after < 0.1, "{scene}, hoist {step}: {after}° left");
        }
    }
}

/// The 3D crane entered at rest and one travel axis alone at full stick for 2 s, then
/// released, on the plant's noisy, quantised sensors: the other vertical plane has no
/// path and no swing to damp (the load travels within the driven plane), so its travel
/// drive is let go when the stick closes the loop and judged at rest while the other
/// moves — every one of its set points exactly 0.0 and the plant's drive where it
/// stood, until 5 s after the release. Bridge alone and trolley alone, both directions
/// (review s24, "3D: one axis after the entry" — each plane runs the planar feedback).
/// With `StateFeedback::let_go_at_rest` made to return at once, the other plane acted on
/// its young estimate's noise: its set point reached 0.077 m/s (on b18d9e7).
#[test]
fn one_travel_axis_alone_moves_not_the_other_on_the_3d_crane() {
    for (driven, other) in [(Axis::X, 1), (Axis::Y, 0)] {
        for step in [1, -1] {
            let (mut e, mut s) = engine("crane3d/crane3d-manual-feedback.toml");
            run(&mut e, &mut s, 3.0);
            s.apply(Action::ToggleManual);
            let stood = run(&mut e, &mut s, 0.3).last().unwrap().plant.drives;
            for _ in 0..NOTCHES {
                s.apply(Action::Notch(driven, step));
            }
            let mut cycles = run(&mut e, &mut s, 2.0);
            s.apply(Action::Centre);
            cycles.extend(run(&mut e, &mut s, 5.0));
            let i = 1 - other;
            let travelled = (cycles.last().unwrap().plant.drives[i] - stood[i]).abs();
            assert!(travelled > 0.3, "{driven:?}: it travelled {travelled} m");
            let worst = cycles
                .iter()
                .map(|c| c.setpoints[other].abs())
                .fold(0.0_f64, f64::max);
            assert!(
                worst == 0.0,
                "{driven:?}, {step}: the other travel's set point reached {worst} m/s"
            );
            assert!(
                cycles.iter().all(|c| c.plant.drives[other] == stood[other]),
                "{driven:?}, {step}: the other travel drive moved"
            );
        }
    }
}
