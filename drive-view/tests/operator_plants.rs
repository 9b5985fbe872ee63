//! The closed loop in manual mode on plants that are not the model, each error alone and
//! combined (issue 28, "Closed loop"): a subset of the study
//! `cargo run -p drive-view --example operator_plants [-- --more]` (its `study.rs` says
//! what is measured), held to the targets — the load within 50 mm of the model's
//! load and the swing below 0.1° over the second swing period after rest, the feedback's
//! correction travel within 50 mm.
//!
//! The subset, the plain generator (the scenes' setting) unless said: the 4 s full-stick
//! step, the hoist still, lowering and raising; pulsing and the pendant's levels at 8 m; a
//! P-only hoist and the errors on the 3D crane's trolley; with the robust generator, the
//! pendulum 10 % off. Met: the load and the swing on every plant of the first study after
//! the 4 s step, both cranes; every target on the planar crane with each error alone after
//! the step, with the load, the lags, the P-only travel drive or friction off after
//! pulsing and the pendant's levels (both cranes), with a P-only hoist and with the errors
//! on the 3D trolley; with the robust generator every target with the pendulum 10 % off
//! (the rope alone, and the view's plant) on both cranes after the step, the reversal,
//! pulsing at 0.5 Hz and the pendant's levels. A P-only hoist tuned for the model's load
//! cannot hold a 20 % heavier one: the controller's standstill supervision faults before
//! manual mode is entered. Missed (docs/OPERATOR.md), ignored until they hold: the
//! correction travel with every error at once (a P-only drive with friction droops, and
//! the feedback makes the droop up, whichever generator) and, with the plain generator,
//! with the rope 10 % off (`the_correction_travel_target_on_every_plant_plain`). The swing
//! after pulsing at 0.5 Hz on an 8 m rope with the pendulum about 10 % longer than the
//! model's, missed with the plain generator up to 785a611, is met
//! (`the_swing_target_after_pulsing_at_half_a_hertz_with_the_pendulum_long_plain`).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

#[allow(dead_code)] // The example's tables are not printed here.
#[path = "../examples/operator_plants/study.rs"]
mod study;

use study::{
    case, CraneCase, Generator, Hoist, Measured, Outcome, PlantCase, Profile, CRANES, FULL_STEP,
    MORE_PLANTS, MORE_PROFILES, PLANTS, TARGET_DEG, TARGET_M,
};

/// The plants with one error each (the study's first seven).
const ALONE: usize = 7;

/// The study's plant named `name`.
fn plant(name: &str) -> &'static PlantCase {
    PLANTS
        .iter()
        .chain(&MORE_PLANTS)
        .find(|p| p.name == name)
        .unwrap_or_else(|| panic!("no plant {name}"))
}

/// The cranes `plant` is studied on.
fn cranes_of(plant: &PlantCase) -> impl Iterator<Item = &'static CraneCase> + '_ {
    CRANES
        .iter()
        .filter(move |c| !plant.only_3d || c.axes.len() == 2)
}

/// Asserts every target on each case of `plants` (on the cranes each is studied on) ×
/// `profiles` × `ropes` × every hoist lever, the plain generator.
fn every_target_met(plants: &[&PlantCase], profiles: &[Profile], ropes: &[f64]) {
    every_target_met_on(&CRANES, plants, profiles, ropes, Generator::Plain);
}

/// [`every_target_met`] on `cranes` only, with `generator`; at least one case must run.
fn every_target_met_on(
    cranes: &[CraneCase],
    plants: &[&PlantCase],
    profiles: &[Profile],
    ropes: &[f64],
    generator: Generator,
) {
    let mut ran = 0;
    for plant in plants {
        for crane in cranes_of(plant).filter(|c| cranes.iter().any(|k| k.name == c.name)) {
            for &profile in profiles {
                for &rope in ropes {
                    for hoist in Hoist::ALL {
                        let o = case(crane, plant, profile, rope, hoist, generator);
                        let m = measured(&o);
                        println!("{}: {m:?}", label(&o));
                        assert!(m.meets_targets(), "{}: {m:?}", label(&o));
                        ran += 1;
                    }
                }
            }
        }
    }
    let names: Vec<&str> = plants.iter().map(|p| p.name).collect();
    assert!(
        ran > 0,
        "no case: none of {names:?} is studied on these cranes"
    );
}

fn measured(o: &Outcome) -> Measured {
    match &o.result {
        Ok(m) => *m,
        Err(e) => panic!(
            "{} on {}, rope {} m, hoist {:?}: {e}",
            o.crane, o.plant, o.rope, o.hoist
        ),
    }
}

fn label(o: &Outcome) -> String {
    format!(
        "{} on {}, {}, rope {} m, hoist {}",
        o.crane,
        o.plant,
        o.profile.name(),
        o.rope,
        o.hoist.name()
    )
}

#[test]
fn each_error_alone_on_the_planar_crane_meets_every_target() {
    for plant in &PLANTS[..ALONE] {
        for rope in [3.5, 8.0] {
            for hoist in Hoist::ALL {
                let o = case(&CRANES[0], plant, FULL_STEP, rope, hoist, Generator::Plain);
                let m = measured(&o);
                println!("{}: {m:?}", label(&o));
                assert!(m.meets_targets(), "{}: {m:?}", label(&o));
            }
        }
    }
}

#[test]
fn every_plant_on_both_cranes_keeps_the_load_and_the_swing_within_the_targets() {
    for crane in &CRANES {
        for plant in &PLANTS {
            for hoist in Hoist::ALL {
                let o = case(crane, plant, FULL_STEP, 8.0, hoist, Generator::Plain);
                let m = measured(&o);
                println!("{}: {m:?}", label(&o));
                assert!(m.load_error <= TARGET_M, "{}: {m:?}", label(&o));
                assert!(m.swing <= TARGET_DEG, "{}: {m:?}", label(&o));
            }
        }
    }
}

#[test]
fn pulsing_and_pendant_levels_meet_every_target_with_the_load_the_lags_p_only_travel_or_friction_off(
) {
    let plants = [
        "load +20 %",
        "load -20 %",
        "lags x1.5",
        "P only (travel)",
        "friction",
    ]
    .map(plant);
    every_target_met(&plants, &MORE_PROFILES, &[8.0]);
}

#[test]
fn a_p_only_hoist_and_the_errors_on_the_3d_trolley_meet_every_target() {
    let plants = [
        "P only (hoist)",
        "lags x1.5, trolley too",
        "P only (bridge and trolley)",
        "friction, trolley too",
    ]
    .map(plant);
    let profiles = [FULL_STEP, Profile::Pulse(0.5), Profile::Pendant];
    every_target_met(&plants, &profiles, &[8.0]);
}

#[test]
fn a_p_only_hoist_tuned_for_the_model_s_load_lets_a_heavier_one_sink_out_of_its_standstill_window()
{
    // 25.7 mm/s (sim's a_winch_without_integral_action_holds_only_the_load_it_was_tuned_for)
    // leaves the 20 mm standstill window (scenes' commissioning.toml) while the crane
    // waits for manual mode: the controller faults instead of driving it.
    let heavier = plant("P only (hoist), load +20 %");
    for crane in &CRANES {
        let o = case(
            crane,
            heavier,
            FULL_STEP,
            8.0,
            Hoist::Still,
            Generator::Plain,
        );
        println!("{}: {:?}", label(&o), o.result);
        let Err(e) = &o.result else {
            panic!("{}: no fault: {:?}", label(&o), o.result);
        };
        assert!(e.ends_with("Standstill(Winch)"), "{}: {e}", label(&o));
    }
}

/// The plants whose pendulum is 10 % off the model's: the rope alone, and the view's plant
/// with the drives' errors too.
const PENDULUM_OFF: [&str; 3] = ["rope +10 %", "rope -10 %", "view's plant"];

/// Every profile on which the plain generator misses a target with the pendulum off
/// (docs/OPERATOR.md, "Closed loop in manual mode"): the 4 s step, the reversal, pulsing
/// at 0.5 Hz, the pendant's levels.
const MISSED_PLAIN: [Profile; 4] = [
    FULL_STEP,
    Profile::Reversal,
    Profile::Pulse(0.5),
    Profile::Pendant,
];

// The robust generator's second pair, tuned to the load's depth at each start, leaves the
// feedback little swing to take out where the pendulum is 10 % off: every target met where
// the plain generator misses the correction travel (up to 67.9 mm on c72dad3; before it
// also, after pulsing at 0.5 Hz, the swing, up to 0.126°). At 3.5 and 8 m, every hoist
// lever (the study:
// `cargo run --release -p drive-view --example operator_plants -- --robust [--more]`).

#[test]
fn with_the_robust_generator_the_pendulum_10_percent_off_meets_every_target_planar() {
    every_target_met_on(
        &CRANES[..1],
        &PENDULUM_OFF.map(plant),
        &MISSED_PLAIN,
        &[3.5, 8.0],
        Generator::Robust,
    );
}

#[test]
fn with_the_robust_generator_the_pendulum_10_percent_off_meets_every_target_3d() {
    every_target_met_on(
        &CRANES[1..],
        &PENDULUM_OFF.map(plant),
        &MISSED_PLAIN,
        &[3.5, 8.0],
        Generator::Robust,
    );
}

/// Missed up to 785a611 (0.101–0.126° a swing period after rest) and ignored; met since
/// the feedback observes from the manual entry and acts from the stick's first demand
/// (c72dad3: at most 0.078° in the study's runs, docs/OPERATOR.md).
#[test]
fn the_swing_target_after_pulsing_at_half_a_hertz_with_the_pendulum_long_plain() {
    let mut missed = Vec::new();
    for plant in ["rope +10 %", "view's plant"].map(plant) {
        for hoist in Hoist::ALL {
            let o = case(
                &CRANES[0],
                plant,
                Profile::Pulse(0.5),
                8.0,
                hoist,
                Generator::Plain,
            );
            let m = measured(&o);
            if m.swing > TARGET_DEG {
                missed.push(format!("{}: {:.3}°", label(&o), m.swing));
            }
        }
    }
    assert!(missed.is_empty(), "{missed:#?}");
}

#[test]
#[ignore = "target missed: every error at once (P-only drives with friction: the feedback \
            makes their droop up, with either generator) and, with the plain generator, the \
            rope 10 % off (3D: the step, the hoist raising, the pendant's levels) need more \
            than 50 mm of correction (docs/OPERATOR.md, \"Closed loop in manual mode\")"]
fn the_correction_travel_target_on_every_plant_plain() {
    let mut missed = Vec::new();
    for crane in &CRANES {
        for plant in &PLANTS {
            for profile in [FULL_STEP, Profile::Pendant] {
                for hoist in Hoist::ALL {
                    let o = case(crane, plant, profile, 8.0, hoist, Generator::Plain);
                    let m = measured(&o);
                    if m.correction > TARGET_M {
                        missed.push(format!("{}: {:.1} mm", label(&o), m.correction * 1000.0));
                    }
                }
            }
        }
    }
    assert!(missed.is_empty(), "{missed:#?}");
}
