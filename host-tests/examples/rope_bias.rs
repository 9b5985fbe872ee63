//! The rope calibration's bias against the inclinometer's delay and noise (issue 33): the
//! paper's case (the drum's scale 1.0 % short, no offset) calibrated with the paper's
//! move in calm air, as the study does, for the sensor delays and noises the issue names:
//! with the inclinometer's timing commissioned, and with none commissioned (what the
//! estimate then measures, and refuses).
//! `cargo run --release -p host-tests --example rope_bias`.
use controller::feedback::{Config, Gains};
use host_tests::feedback_study::{calibrate_rope, calibration_reference};
use host_tests::plant::{Mismatch, SensorLag};
use solver_core::models::crane::CraneParams;

fn main() {
    let params = CraneParams::PAPER;
    let gains = Gains::design(&Config::PAPER).expect("the study's gains");
    let paper = calibration_reference(&params);
    println!("| delay, cycles | noise, ° | timing commissioned | scale learnt | offset learnt, mm | length off at 4 m, mm | at 8 m, mm | uncertainty, mm | delay measured, ms | 0x2004:4 |");
    println!("|---:|---:|---|---:|---:|---:|---:|---:|---:|---|");
    for (delay, noise) in [
        (0u8, 0.0f64),
        (0, 0.02),
        (1, 0.0),
        (1, 0.02),
        (2, 0.02),
        (5, 0.02),
        (0, 0.05),
    ] {
        let case = Mismatch {
            drum_scale: 0.01,
            position_noise: Mismatch::SENSORS.0,
            angle_noise: (noise.to_radians(), Mismatch::SENSORS.1 .1),
            noise_seed: 5,
            inclinometer: SensorLag { delay, filter: 0.0 },
            ..Mismatch::NONE
        };
        for told in [true, false] {
            // Not commissioned: the study's feedback is told the plant's timing, so the
            // plant's delay is taken away from what it is told by running the
            // calibration on a case whose sensor the feedback believes ideal.
            let cal = match told {
                true => calibrate_rope(&params, &paper, &case, &gains),
                false => host_tests::feedback_study::calibrate_rope_told(
                    &params,
                    &paper,
                    &case,
                    &gains,
                    controller::rope::InclinometerLag::NONE,
                ),
            };
            let (s, o) = cal.estimate;
            let off = |l: f64| ((1.0 + s) * l + o - case.rope(l)) * 1e3;
            println!(
                "| {delay} | {noise:.2} | {} | {:+.2} % | {:+.1} | {:+.1} | {:+.1} | {:.1} | {:.1} | {:?} |",
                if told { "yes" } else { "no" },
                s * 100.0,
                o * 1e3,
                off(4.0),
                off(8.0),
                cal.uncertainty * 1e3,
                cal.delay * 1e3,
                cal.learnt
            );
        }
    }
}
