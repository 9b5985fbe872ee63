//! One case of the calibration set (issue 33) run on the crane as it is (its rope not
//! calibrated), with the feedback, its trace printed: a diagnostic.
//! `cargo run --release -p host-tests --example calibration_case -- INDEX [EVERY] [DELAY]`
//! (DELAY: the inclinometer's delay in cycles instead of the drawn one, commissioned as
//! such: the same case with another sensor).
use controller::feedback::{Config, Gains};
use host_tests::feedback_study::{draw_calibration_case, print_case_trace};
use host_tests::plant::Rng;
use solver_core::models::crane::CraneParams;

fn main() {
    let mut args = std::env::args().skip(1).map(|a| a.parse::<usize>().ok());
    let index = args.next().flatten().unwrap_or(0);
    let every = args.next().flatten().unwrap_or(50);
    let delay = args.next().flatten();
    let params = CraneParams::PAPER;
    let gains = Gains::design(&Config::PAPER).expect("the study's gains");
    // As `calibration_study` draws its cases.
    let mut rng = Rng::new(33);
    let mut drawn = None;
    for _ in 0..=index {
        drawn = Some(draw_calibration_case(&mut rng, &params));
    }
    let Some((reference, mut case)) = drawn else {
        return;
    };
    if let Some(d) = delay {
        case.inclinometer.delay = u8::try_from(d).unwrap_or(u8::MAX);
    }
    print_case_trace(&params, &reference, &case, &gains, f64::NEG_INFINITY, every);
}
