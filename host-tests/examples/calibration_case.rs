//! One case of the calibration set (issue 33) run on the crane as it is (its rope not
//! calibrated), with the feedback, its trace printed: a diagnostic.
//! `cargo run --release -p host-tests --example calibration_case -- INDEX [EVERY] [DELAY]`
//! (DELAY: the inclinometer's delay in cycles instead of the drawn one, commissioned as
//! such: the same case with another sensor).
use controller::feedback::{Config, Gains};
use controller::setpoint::DriveLimits;
use host_tests::feedback_study::{random_move_in, simulate};
use host_tests::plant::{Mismatch, Rng, SensorLag};
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
        let (_, reference) = random_move_in(&mut rng, &params, 0.0, (3.0, 9.0));
        let l0 = reference.r.first().map_or(6.0, |r| r.l);
        let base = Mismatch::random(&mut rng, l0, reference.span);
        let case = Mismatch {
            rope_offset: rng.uniform(-0.1, 0.1),
            load_mass: rng.uniform(-0.5, 1.0),
            angle_noise: (rng.uniform(0.0, 0.05).to_radians(), Mismatch::SENSORS.1 .1),
            inclinometer: SensorLag {
                delay: (rng.unit() * 6.0).floor().min(5.0) as u8,
                filter: rng.uniform(0.0, 0.02),
            },
            ..base
        };
        drawn = Some((reference, case));
    }
    let Some((reference, mut case)) = drawn else {
        return;
    };
    if let Some(d) = delay {
        case.inclinometer.delay = u8::try_from(d).unwrap_or(u8::MAX);
    }
    println!("{case:?}");
    println!(
        "move {:?} -> {:?}, span {:?}",
        reference.z.first(),
        reference.target,
        reference.span
    );
    let (r, s) = simulate(
        &params,
        &reference,
        &case,
        Some(&gains),
        &DriveLimits::LAB,
        true,
    );
    println!("{r:?}");
    for (i, t) in s.t.iter().enumerate().step_by(every) {
        println!(
            "t {t:6.2}  load {:8.3} {:7.3}  phi {:8.3}°  u {:7.3} {:7.3}",
            s.load[i][0], s.load[i][1], s.phi_deg[i], s.u[i][0], s.u[i][1]
        );
    }
}
