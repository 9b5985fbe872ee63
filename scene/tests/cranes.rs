//! What every registered crane must be, checked on each through the registry
//! (`scene::cranes::visit_crane`), so that a new crane is covered without an edit here:
//! its reasons are ranked by the planner, its stock inclinometer reads as many slopes as
//! its swing has, and the virtual bus carries it on its own plant with its drives where
//! they stand for the load at rest.
#![allow(clippy::unwrap_used)]

use controller::commissioning::InclinometerSetup;
use controller::planner::ORDER;
use scene::cranes::{visit_crane, CraneVisitor, FirmwareCrane, FirmwareModel};
use sim::simulated::CranePlant;

/// Runs `check` on each registered crane once (the first formulation of each).
fn each_crane<V: CraneVisitor<Output = ()> + Copy>(check: V) -> usize {
    let mut seen = Vec::new();
    for model in FirmwareModel::every() {
        if !seen.contains(&model.crane_name()) {
            seen.push(model.crane_name());
            visit_crane(model, check);
        }
    }
    seen.len()
}

/// Every reason a crane names is one the planner ranks: a reason outside `ORDER` would
/// have no bit, and its violation would pass unseen.
#[test]
fn every_crane_reason_is_ranked() {
    #[derive(Clone, Copy)]
    struct Ranked;
    impl CraneVisitor for Ranked {
        type Output = ();
        fn visit<K: FirmwareCrane<A>, const A: usize>(self, _model: K::Model) {
            for r in K::REASONS {
                for reason in [r.workspace, r.velocity, r.acceleration] {
                    assert!(ORDER.contains(&reason), "{}: {reason:?}", K::NAME);
                }
            }
        }
    }
    assert_eq!(each_crane(Ranked), 3);
}

/// The stock inclinometer of each crane reads as many slopes as its swing has: the
/// one-axis sensor at node 3 for a swing in one plane, the two-axis one at node 5 for a
/// swing in both (what the virtual bus simulates for it).
#[test]
fn each_crane_has_the_stock_inclinometer_of_its_swing() {
    #[derive(Clone, Copy)]
    struct Stock;
    impl CraneVisitor for Stock {
        type Output = ();
        fn visit<K: FirmwareCrane<A>, const A: usize>(self, _model: K::Model) {
            let i = InclinometerSetup::stock(K::SWING_AXES);
            let axes = 1 + u8::from(i.lateral.is_some());
            let node = if K::SWING_AXES == 1 { 3 } else { 5 };
            assert_eq!((axes, i.node), (K::SWING_AXES, node), "{}", K::NAME);
        }
    }
    assert_eq!(each_crane(Stock), 3);
}

/// The virtual bus carries each crane on its own plant, with its drives where they stand
/// for the load at rest (the hook-and-load crane's rope a sling shorter than the load is
/// deep) and the load where the crane says it rests.
#[test]
fn the_virtual_bus_carries_each_crane_on_its_own_plant() {
    #[derive(Clone, Copy)]
    struct OnItsPlant;
    impl CraneVisitor for OnItsPlant {
        type Output = ();
        fn visit<K: FirmwareCrane<A>, const A: usize>(self, _model: K::Model) {
            let crane = K::default();
            // A third of the way into each drive's range.
            let drives = crane.ranges().map(|(lo, hi)| lo + (hi - lo) / 3.0);
            let load = crane.load_at_rest(drives);
            // A plant that is the model: no mismatch to move the load off its rest.
            let model = sim::Scenario {
                plant: Some(sim::plant::Mismatch::NONE),
                ..sim::CLOSED_LOOP
            };
            let bus = sim::VirtualBus::for_crane(model, &crane, drives);
            let state = bus.plant().unwrap().true_state();
            // The operator frame's slots: the horizontal drives first, the hoist in z.
            let slot = |i: usize| {
                if i < usize::from(K::HORIZONTAL_AXES) {
                    i
                } else {
                    2
                }
            };
            for i in 0..A {
                let (want_drive, want_load) = (drives[i], load[i]);
                let (drive, at) = (state.drives[slot(i)], state.load[slot(i)]);
                assert!((drive - want_drive).abs() < 1e-12, "{}: drive {i}", K::NAME);
                assert!((at - want_load).abs() < 1e-12, "{}: load {i}", K::NAME);
            }
        }
    }
    assert_eq!(each_crane(OnItsPlant), 3);
}
