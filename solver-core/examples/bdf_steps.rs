//! The paper's crane move (`scenes/paper-crane.toml`: *subs*, 12 m → 20 m, 8 m → 4 m,
//! t = 1 … 9 s, C4 polynomial, 10 s) stepped with BDF4 and the exact Jacobian, nothing
//! recorded: the BDF twin of `radau_steps.rs`, for a host instruction count under
//! callgrind.
//!
//! ```sh
//! cargo build --release -p solver-core --example bdf_steps
//! valgrind --tool=callgrind --toggle-collect='*Bdf*::step' \
//!     target/release/examples/bdf_steps dense 0.01
//! ```
//!
//! Instructions per step = callgrind's `Collected` / the steps printed. `dense` is the
//! general path (run-time Jacobian mode, dense LU), `structured` the model's
//! structured elimination that the firmware's default scene links.

use nalgebra::SVector;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane_subs::{self, CraneSubs};
use solver_core::trajectory::PointToPoint;
use solver_core::{JacobianMode, SolverSettings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().unwrap_or_else(|| "dense".into());
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
        ..SolverSettings::paper(JacobianMode::Exact)
    };
    let steps = (10.0 / h).round() as usize;
    let mut iterations = 0u64;
    match path.as_str() {
        "dense" => {
            let mut bdf = crane_subs::Bdf::<f64, _>::new(&model, &settings, 4, 0.0)?;
            for _ in 0..steps {
                iterations += u64::from(std::hint::black_box(bdf.step(&model))?.stats.iterations);
            }
        }
        "structured" => {
            let mut bdf = crane_subs::StructuredBdf::<f64, _>::new(&model, &settings, 4, 0.0)?;
            for _ in 0..steps {
                iterations += u64::from(std::hint::black_box(bdf.step(&model))?.stats.iterations);
            }
        }
        other => return Err(format!("unknown path {other:?} (dense, structured)").into()),
    }
    println!("BDF4 {path} h = {h}: {steps} steps, {iterations} Newton iterations");
    Ok(())
}
