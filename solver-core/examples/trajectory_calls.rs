//! One trajectory evaluation as the models ask for it (`derivatives::<3>`: `z_d`,
//! `ż_d`, `z̈_d`) on the paper's crane move, 1,000 times across the move: a host
//! instruction count per call under callgrind, for the bare move and for the firmware's
//! plan holding it (issue 20).
//!
//! ```sh
//! cargo build --release -p solver-core --example trajectory_calls
//! valgrind --tool=callgrind --toggle-collect='*measured_call*' \
//!     target/release/examples/trajectory_calls 4 move
//! ```
//!
//! Instructions per call = callgrind's `Collected` / 1,000. Arguments: the smoothness
//! n (default 4, the paper's) and `move` or `plan`.

use nalgebra::SVector;
use solver_core::plan::Plan;
use solver_core::trajectory::{PointToPoint, Trajectory};

/// The unit callgrind collects.
#[inline(never)]
fn measured_call<Z: Trajectory<f64, 2>>(z: &Z, t: f64) -> [SVector<f64, 2>; 3] {
    z.derivatives::<3>(t)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().map_or(Ok(4), |s| s.parse())?;
    let plan = match args.next().as_deref() {
        None | Some("move") => false,
        Some("plan") => true,
        Some(other) => return Err(format!("`{other}`: expected move or plan").into()),
    };
    let m = PointToPoint::new(
        SVector::from([12.0, 8.0]),
        SVector::from([20.0, 4.0]),
        1.0,
        8.0,
        n,
    )?;
    let times = (0..1000).map(|i| 1.0 + 8.0 * (f64::from(i) + 0.5) / 1000.0);
    let mut sum = 0.0;
    if plan {
        let mut p = Plan::at_rest(m.start(), n)?;
        p.push(m)?;
        for t in times {
            sum += measured_call(std::hint::black_box(&p), t)[2][0];
        }
    } else {
        for t in times {
            sum += measured_call(std::hint::black_box(&m), t)[2][0];
        }
    }
    println!("{} calls, checksum {sum}", 1000);
    Ok(())
}
