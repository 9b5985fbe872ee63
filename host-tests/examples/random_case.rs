//! One case of the feedback study's random set (`feedback_study`, seed 410) run with the
//! feedback on the crane as it is (rope not calibrated), its trace printed from 1 s
//! before the move's end: a diagnostic of a case not at rest 5 s after its move.
//! `cargo run --release -p host-tests --example random_case -- INDEX [EVERY]`
use controller::feedback::{Config, Gains};
use host_tests::feedback_study::{print_case_trace, random_move};
use host_tests::plant::{Mismatch, Rng};
use solver_core::models::crane::CraneParams;

fn main() {
    let mut args = std::env::args().skip(1).map(|a| a.parse::<usize>().ok());
    let index = args.next().flatten().unwrap_or(0);
    let every = args.next().flatten().unwrap_or(10);
    let params = CraneParams::PAPER;
    let gains = Gains::design(&Config::PAPER).expect("the study's gains");
    // As `monte_carlo` draws its random set.
    let mut rng = Rng::new(410);
    let mut drawn = None;
    for _ in 0..=index {
        let (_, reference) = random_move(&mut rng, &params, 0.0);
        let l0 = reference.r.first().map_or(6.0, |r| r.l);
        let case = Mismatch::random(&mut rng, l0, reference.span);
        drawn = Some((reference, case));
    }
    let Some((reference, case)) = drawn else {
        return;
    };
    print_case_trace(
        &params,
        &reference,
        &case,
        &gains,
        reference.span.1 - 1.0,
        every,
    );
}
