//! The calibration set's cases one by one (issue 33), worst vertical first: what the
//! crane was, what its calibration learnt and where its move ended. A diagnostic for
//! `feedback_study --calibration-only`'s tables.
//! `cargo run --release -p host-tests --example calibration_cases -- [CASES] [SHOWN]`.
use controller::feedback::{Config, Gains};
use host_tests::feedback_study::calibration_study;

fn main() {
    let mut args = std::env::args().skip(1).map(|a| a.parse::<usize>().ok());
    let n = args.next().flatten().unwrap_or(100);
    let shown = args.next().flatten().unwrap_or(10);
    let gains = Gains::design(&Config::PAPER).expect("the study's gains");
    let set = calibration_study(33, n, &gains);
    // The error against the uncertainty stated, by the inclinometer's noise.
    for bin in 0..5 {
        let (lo, hi) = (0.01 * bin as f64, 0.01 * (bin + 1) as f64);
        let mut r: Vec<(f64, f64, f64)> = set
            .iter()
            .filter(|c| {
                let d = c.case.angle_noise.0.to_degrees();
                d >= lo && d < hi
            })
            .map(|c| {
                let e = c.length_error[0].abs().max(c.length_error[1].abs());
                (
                    e / c.calibration.uncertainty,
                    e * 1e3,
                    c.calibration.uncertainty * 1e3,
                )
            })
            .collect();
        r.sort_by(|a, b| a.0.total_cmp(&b.0));
        let rms = (r.iter().map(|v| v.1 * v.1).sum::<f64>() / r.len().max(1) as f64).sqrt();
        let med_u = r.get(r.len() / 2).map_or(0.0, |v| v.2);
        println!(
            "noise {lo:.2}-{hi:.2}°: {} cases, error rms {rms:.1} mm, max {:.1} mm, uncertainty median {med_u:.1} mm, ratio max {:.2}",
            r.len(),
            r.iter().map(|v| v.1).fold(0.0, f64::max),
            r.last().map_or(0.0, |v| v.0)
        );
    }
    let score =
        |r: &host_tests::feedback_study::CaseResult| (r.distance / 0.05).max(r.swing_deg / 0.1);
    for (name, by) in [
        (
            "vertical",
            &(|c: &host_tests::feedback_study::CalibrationCase| c.run.vertical)
                as &dyn Fn(&host_tests::feedback_study::CalibrationCase) -> f64,
        ),
        (
            "horizontal and swing",
            &|c: &host_tests::feedback_study::CalibrationCase| score(&c.run),
        ),
    ] {
        println!("worst {name}:");
        let mut order: Vec<usize> = (0..set.len()).collect();
        order.sort_by(|&a, &b| by(&set[b]).total_cmp(&by(&set[a])));
        for &i in order.iter().take(shown) {
            let c = &set[i];
            let k = &c.case;
            println!(
            "case {i}: drum {:+.2} %, offset {:+.0} mm, mass {:+.2}, delay {}, filter {:.0} ms, noise {:.3}°, gust {:.1} N at {:.1} s, swing0 {:.1}° | learnt {:+.2} % {:+.0} mm {:?} unc {:.1} mm delay {:.1} ms, error {:.1}/{:.1} mm | vertical {:.1} mm, distance {:.1} mm, swing {:.3}°, mode {:?}",
            k.drum_scale * 100.0,
            k.rope_offset * 1e3,
            k.load_mass,
            k.inclinometer.delay,
            k.inclinometer.filter * 1e3,
            k.angle_noise.0.to_degrees(),
            k.gust.amplitude,
            k.gust.start,
            k.swing0.to_degrees(),
            c.calibration.estimate.0 * 100.0,
            c.calibration.estimate.1 * 1e3,
            c.calibration.learnt,
            c.calibration.uncertainty * 1e3,
            c.calibration.delay * 1e3,
            c.length_error[0] * 1e3,
            c.length_error[1] * 1e3,
            c.run.vertical * 1e3,
            c.run.distance * 1e3,
            c.run.swing_deg,
            c.run.mode,
        );
        }
    }
}
