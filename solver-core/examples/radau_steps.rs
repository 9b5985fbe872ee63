//! The paper's crane move (`scenes/paper-crane.toml`: *subs*, 12 m → 20 m, 8 m → 4 m,
//! t = 1 … 9 s, C4 polynomial, 10 s) stepped with Radau IIA, nothing recorded: a small
//! release binary for a host instruction count under callgrind.
//!
//! ```sh
//! cargo build --release -p solver-core --example radau_steps
//! valgrind --tool=callgrind --toggle-collect='*Radau*::step' \
//!     target/release/examples/radau_steps transformed 0.01
//! ```
//!
//! Instructions per step = callgrind's `Collected` / the steps printed.

use nalgebra::SVector;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::trajectory::PointToPoint;
use solver_core::{JacobianMode, SolverSettings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let mode = match args.next().as_deref() {
        Some("exact") => JacobianMode::Exact,
        Some("jt10") => JacobianMode::Broyden {
            reinit_every: Some(10),
        },
        _ => JacobianMode::Transformed,
    };
    let h: f64 = args.next().map_or(Ok(0.01), |s| s.parse())?;
    let z = PointToPoint::new(
        SVector::from([12.0, 8.0]),
        SVector::from([20.0, 4.0]),
        1.0,
        8.0,
        4,
    )?;
    let model = CraneSubs::new(CraneParams::PAPER, z)?;
    let settings = SolverSettings {
        h,
        ..SolverSettings::paper(mode)
    };
    let mut radau = crane_subs::Radau::<f64, _>::new(&model, &settings, 0.0)?;
    let steps = (10.0 / h).round() as usize;
    let mut iterations = 0u64;
    for _ in 0..steps {
        iterations += u64::from(std::hint::black_box(radau.step(&model))?.stats.iterations);
    }
    println!("{mode:?} h = {h}: {steps} steps, {iterations} Newton iterations");
    Ok(())
}
