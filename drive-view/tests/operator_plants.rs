//! The closed loop in manual mode on plants that are not the model, each error alone and
//! combined (issue 28, "Closed loop"): a subset of the study
//! `cargo run -p drive-view --example operator_plants` (its `study.rs` says what is
//! measured), held to the targets — the load within 50 mm of the model's load and
//! the swing below 0.1° over the second swing period after rest, the feedback's
//! correction travel within 50 mm.
//!
//! The subset is the 4 s full-stick step. Met: the load and the swing on every plant of
//! the study, both cranes; the correction travel on the planar crane with each error
//! alone. Missed (docs/OPERATOR.md): the correction travel with every error at once (a
//! P-only drive with friction droops, and the feedback makes the droop up) and on the 3D
//! crane with the rope 10 % off: `the_correction_travel_target_on_every_plant` asserts it
//! at 8 m and is ignored until it holds. The study's other profiles miss it in more cases
//! (the reversal with the rope 10 % long, planar too): docs/OPERATOR.md lists them.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing)]

#[allow(dead_code)] // The example's tables are not printed here.
#[path = "../examples/operator_plants/study.rs"]
mod study;

use study::{case, Hoist, Measured, Outcome, CRANES, FULL_STEP, PLANTS, TARGET_DEG, TARGET_M};

/// The plants with one error each (the study's first seven).
const ALONE: usize = 7;

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
            for hoist in [Hoist::Still, Hoist::Lowering] {
                let o = case(&CRANES[0], plant, FULL_STEP, rope, hoist);
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
            for hoist in [Hoist::Still, Hoist::Lowering] {
                let o = case(crane, plant, FULL_STEP, 8.0, hoist);
                let m = measured(&o);
                println!("{}: {m:?}", label(&o));
                assert!(m.load_error <= TARGET_M, "{}: {m:?}", label(&o));
                assert!(m.swing <= TARGET_DEG, "{}: {m:?}", label(&o));
            }
        }
    }
}

#[test]
#[ignore = "target missed: every error at once (P-only drives with friction) and the 3D \
            crane with the rope 10 % off need more than 50 mm of correction \
            (docs/OPERATOR.md, \"Closed loop in manual mode\")"]
fn the_correction_travel_target_on_every_plant() {
    let mut missed = Vec::new();
    for crane in &CRANES {
        for plant in &PLANTS {
            for hoist in [Hoist::Still, Hoist::Lowering] {
                let o = case(crane, plant, FULL_STEP, 8.0, hoist);
                let m = measured(&o);
                if m.correction > TARGET_M {
                    missed.push(format!("{}: {:.1} mm", label(&o), m.correction * 1000.0));
                }
            }
        }
    }
    assert!(missed.is_empty(), "{missed:#?}");
}
