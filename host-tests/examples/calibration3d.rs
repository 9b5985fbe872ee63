//! The 3D crane's calibration set (issue 33): its x–z plane's rope calibration against
//! a two-axis inclinometer 0–5 cycles late, filtered and noisy, and where the load ends
//! 5 s after a random move on the crane as then commissioned.
//! `cargo run --release -p host-tests --example calibration3d -- [CASES]`.
use controller::rope::Learnt;
use host_tests::feedback3d_study::calibration_study3;

fn main() {
    let n = std::env::args()
        .nth(1)
        .and_then(|a| a.parse::<usize>().ok())
        .unwrap_or(200);
    let set = calibration_study3(33, n);
    let count = |f: &dyn Fn(&host_tests::feedback3d_study::CalibrationCase3) -> bool| {
        set.iter().filter(|c| f(c)).count()
    };
    println!("3D calibration set, {} cases (seed 33)", set.len());
    for learnt in [
        Learnt::Both,
        Learnt::Nothing,
        Learnt::Clamped,
        Learnt::Uncertain,
        Learnt::DelayMismatch,
    ] {
        println!(
            "  learnt {learnt:?}: {}",
            count(&|c| c.calibration.learnt == learnt)
        );
    }
    let offered: Vec<_> = set
        .iter()
        .filter(|c| c.calibration.learnt == Learnt::Both)
        .collect();
    let error = |c: &host_tests::feedback3d_study::CalibrationCase3| {
        c.length_error[0].abs().max(c.length_error[1].abs())
    };
    println!(
        "  offered: length error (3.5 / 8.5 m) max {:.1} mm, uncertainty max {:.1} mm, error within the uncertainty {}/{}",
        offered.iter().map(|c| error(c) * 1e3).fold(0.0, f64::max),
        offered
            .iter()
            .map(|c| c.calibration.uncertainty * 1e3)
            .fold(0.0, f64::max),
        offered
            .iter()
            .filter(|c| error(c) <= c.calibration.uncertainty)
            .count(),
        offered.len()
    );
    println!(
        "  vertical within +-20 mm 5 s after the move: {}/{} (max {:.1} mm)",
        count(&|c| c.run.distance[2] <= 0.02),
        set.len(),
        set.iter()
            .map(|c| c.run.distance[2] * 1e3)
            .fold(0.0, f64::max)
    );
    println!(
        "  horizontal within +-50 mm and < 0.1 deg in both planes: {}/{}",
        count(&|c| c.run.meets_target()),
        set.len()
    );
    for delay in 0..=5u8 {
        let of =
            |c: &host_tests::feedback3d_study::CalibrationCase3| c.case.inclinometer.delay == delay;
        println!(
            "    delay {delay} cycles: {}/{} horizontal, {}/{} vertical",
            count(&|c| of(c) && c.run.meets_target()),
            count(&of),
            count(&|c| of(c) && c.run.distance[2] <= 0.02),
            count(&of),
        );
    }
}
