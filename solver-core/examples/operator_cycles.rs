//! Operator mode's generator, one cycle as the firmware will run it, for a host
//! instruction count under callgrind (issue 28): the 3D crane's generator (three axes:
//! bridge, trolley, hoist; the robust setting, the longest ring), every axis moving all
//! the time (reversals, hoisting during travel), evaluated as the inverse model asks for
//! it — `derivatives::<3>` at one time per cycle (BDF's `t_{n+1}`) or at three (Radau IIA's
//! stage times).
//!
//! ```sh
//! cargo build --release -p solver-core --example operator_cycles
//! valgrind --tool=callgrind --toggle-collect='*measured_cycle*' \
//!     target/release/examples/operator_cycles radau moving
//! ```
//!
//! Instructions per cycle = callgrind's `Collected` / the cycles printed. Arguments: the
//! scheme, `bdf` (default) or `radau`; what is counted: `moving` (default: every cycle of
//! a run in which all three axes move), `hand-over` (cycles during a hand-over's blend:
//! a hand-over from a running move every 400 cycles, each blend lasting 4 s), `hoisting`
//! (the hoist alone moving, reversing every 530 cycles, the horizontal axes at rest: the
//! filter for their next start staged as the depth cap changes) or `start` (the cycle in
//! which a motion starts from rest: the filter is tuned and its ring cleared).

use nalgebra::SVector;
use solver_core::models::crane3d::Crane3dParams;
use solver_core::operator::{Demand, Generator3d, Handover, Headroom, Room, Settings};
use solver_core::trajectory::{PointToPoint, Trajectory};

/// The cycles counted.
const CYCLES: usize = 20_000;

/// The room the 3D lab crane's drives (`controller::setpoint::DriveLimits::LAB_3D`: 3, 2
/// and 2 m/s, 3, 2 and 3 m/s²) leave a hand-over's stop beside the operator: 95 % of
/// each limit less the manual speed and 1.5 times the manual acceleration (the table of
/// `cargo run --release -p host-tests --example takeover_limits`).
const ROOM: Headroom<2> = Headroom {
    horizontal: [
        Room {
            speed: 1.85,
            acceleration: 2.1,
        },
        Room {
            speed: 1.1,
            acceleration: 1.15,
        },
    ],
    hoist: Room {
        speed: 1.4,
        acceleration: 2.1,
    },
};

/// One cycle: the generator's advance and the evaluations at `stages` fractions of it.
#[inline(never)]
fn measured_cycle(g: &mut Generator3d, d: &Demand<2>, stages: &[f64]) -> f64 {
    let _ = g.advance(d);
    let t = g.time();
    let mut sum = 0.0;
    for c in stages {
        let z: [SVector<f64, 3>; 3] = g.derivatives(t + c * 0.01);
        sum += z[2][0] + z[1][1] + z[0][2];
    }
    sum
}

/// The stick at cycle `n`: every axis moving, never at rest.
fn busy(n: usize) -> Demand<2> {
    Demand {
        horizontal: [
            [1.0, 0.4, -1.0, -0.6][(n / 400) % 4],
            [0.3, -0.8, 0.5, 1.0][(n / 270) % 4],
        ],
        hoist: [0.6, -0.6][(n / 530) % 2],
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let stages: &[f64] = match args.next().as_deref() {
        None | Some("bdf") => &[1.0],
        // Radau IIA's nodes (4 ∓ √6)/10 and 1.
        Some("radau") => &[0.155_051_025_721_682_2, 0.644_948_974_278_317_8, 1.0],
        Some(other) => return Err(format!("`{other}`: expected bdf or radau").into()),
    };
    let p = Crane3dParams::EXAMPLE;
    let mut s = Settings::lab_3d(&p);
    s.robust = true;
    let at_rest = || Generator3d::at_rest(s, 0.0, [12.0, 3.0], 6.0);
    let mut sum = 0.0;
    match args.next().as_deref() {
        None | Some("moving") => {
            let mut g = at_rest()?;
            for n in 0..CYCLES {
                sum += measured_cycle(std::hint::black_box(&mut g), &busy(n), stages);
            }
        }
        Some("hand-over") => {
            let mv = PointToPoint::new(
                SVector::from([12.0, 3.0, 8.0]),
                SVector::from([20.0, 6.0, 4.0]),
                0.0,
                10.0,
                5,
            )?;
            let blend = (s.entry_blend / 0.01).round() as usize;
            let mut g = at_rest()?;
            for n in 0..CYCLES {
                if n % blend == 0 {
                    let t = 1.0 + 0.01 * (n / blend % 5) as f64;
                    g = Generator3d::take_over(s, t, &Handover::<2>::of(&mv, t), &ROOM)?;
                }
                sum += measured_cycle(std::hint::black_box(&mut g), &busy(n), stages);
            }
        }
        Some("hoisting") => {
            let mut g = at_rest()?;
            for n in 0..CYCLES {
                let d = Demand {
                    horizontal: [0.0; 2],
                    hoist: busy(n).hoist,
                };
                sum += measured_cycle(std::hint::black_box(&mut g), &d, stages);
            }
        }
        Some("start") => {
            for n in 0..CYCLES {
                let mut g = at_rest()?;
                sum += measured_cycle(std::hint::black_box(&mut g), &busy(n), stages);
            }
        }
        Some(other) => {
            return Err(format!("`{other}`: expected moving, hand-over, hoisting or start").into())
        }
    }
    println!("{CYCLES} cycles, checksum {sum}");
    Ok(())
}
