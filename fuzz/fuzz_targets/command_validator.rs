//! The command validator on arbitrary targets and durations (NaN, infinities, huge
//! and tiny values), from rest and from the middle of the paper's move: no panic;
//! an accepted duration is in range and its path passes every check; a stop found
//! during the move passes every check too.
#![no_main]

use controller::planner::{MoveSearch, DURATION_RANGE, SAMPLES_PER_CYCLE};
use controller::Replan;
use crane_fuzz::{feedforward, PLANNER};
use libfuzzer_sys::fuzz_target;
use nalgebra::SVector;
use solver_core::trajectory::{PointToPoint, Trajectory};

fuzz_target!(|input: (u64, u64, Option<u64>, bool, u16)| {
    let (x, z, d, moving, at) = input;
    let target = [f64::from_bits(x), f64::from_bits(z)];
    let duration = d.map(f64::from_bits);
    let ff = feedforward(moving);
    let plan = *ff.plan();
    let Ok(mut search) = MoveSearch::new(&plan, target, duration) else {
        return;
    };
    let mut cycles = 0;
    let result = loop {
        let mut budget = SAMPLES_PER_CYCLE;
        if let Some(r) = search.advance(&PLANNER, &mut budget) {
            break r;
        }
        cycles += 1;
        assert!(cycles < 100, "the search ends");
    };
    if let Ok(d) = result {
        assert!((DURATION_RANGE.0..=DURATION_RANGE.1).contains(&d), "{d}");
        let n = plan.planned_smoothness();
        let path = PointToPoint::new(plan.final_position(), SVector::from(target), 0.0, d, n)
            .expect("a checked path builds");
        assert_eq!(PLANNER.check(&path, 0.0, d), Ok(()));
    }
    if moving {
        let t = 1.0 + 8.0 * f64::from(at) / f64::from(u16::MAX);
        if let Some(stop) = PLANNER.plan_stop(&plan, t) {
            let (t0, t1) = stop.active_span();
            assert_eq!(PLANNER.check(&stop, t0, t1), Ok(()));
            // On the stopped move's path, at or before its target.
            assert!(stop.stays_on_path() && stop.fraction() <= 1.0);
        }
    }
});
