//! How far `Generator::take_over` (the hand-over from a running automatic move) puts the
//! planar crane's drives past their limits, by where in the move it happens and the
//! blend's length (issue 28): the largest share of a drive limit (`Extremes::share`, the
//! exact flat inverse) over the 25 s after the hand-over, the stick held 3 s either way or
//! centred, then released.
//!
//! `cargo run --release -p host-tests --example takeover_limits [ENTRY_BLEND_S]`
//!
//! The controller does not use it: a deflected stick ends the move with its on-path stop
//! and manual mode starts at the stop's rest (docs/COMMANDS.md, "Manual mode").

use host_tests::operator::{drive, Crane, Extremes, Gen};
use nalgebra::SVector;
use solver_core::models::crane::CraneParams;
use solver_core::operator::{Handover, PlanarGenerator, Settings};
use solver_core::trajectory::{PointToPoint, Trajectory};

fn main() -> Result<(), String> {
    let p = CraneParams::PAPER;
    let mut settings = Settings::lab(&p);
    if let Some(blend) = std::env::args().nth(1) {
        settings.entry_blend = blend.parse().map_err(|e| format!("{blend}: {e}"))?;
    }
    println!(
        "entry_blend {} s; largest share of a drive limit after the hand-over, stick -1 / 0 / +1",
        settings.entry_blend
    );
    println!("| move | at | load speed, m/s | acceleration, m/s² | stick −1 | 0 | +1 |");
    println!("|---|---:|---:|---:|---:|---:|---:|");
    for (duration, to) in [(6.0, [18.0, 6.0]), (8.0, [20.0, 4.0]), (16.0, [20.0, 4.0])] {
        let mv = PointToPoint::new(
            SVector::from([12.0, 8.0]),
            SVector::from(to),
            0.0,
            duration,
            5,
        )
        .map_err(|e| e.to_string())?;
        for share in [0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9] {
            let t = (share * duration / 0.01_f64).round() * 0.01;
            let d: [SVector<f64, 2>; 3] = mv.derivatives(t);
            let mut row = format!(
                "| {duration} s to {to:?} | {share} | {:.2} | {:.2} |",
                d[1][0], d[2][0]
            );
            for stick in [-1.0, 0.0, 1.0] {
                match PlanarGenerator::take_over(settings, t, &Handover::<1>::of(&mv, t)) {
                    Ok(g) => {
                        let crane = Crane::PLANAR;
                        let mut g = Gen::Planar(g);
                        let mut e = Extremes::default();
                        let hold = |n| if n < 300 { [stick, 0.0, 0.0] } else { [0.0; 3] };
                        drive(&crane, &mut g, 2500, hold, |r| e.add(&crane, r));
                        row += &format!(" {:.2} |", e.share(&crane));
                    }
                    Err(_) => row += " refused |",
                }
            }
            println!("{row}");
        }
    }
    Ok(())
}
