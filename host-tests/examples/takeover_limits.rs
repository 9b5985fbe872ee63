//! How far `Generator::take_over` (the hand-over from a running automatic move) takes the
//! drives towards their limits, by where in the move it happens (issue 28): the largest
//! share of a drive limit (`Extremes::share`, the exact flat inverse) over the 25 s after
//! the hand-over, the stick held 3 s either way or centred, then released — on the
//! planar crane (moves of 6, 8 and 16 s that also raise the load) and on the 3D crane (a
//! diagonal move that raises it, and one that lowers it). The drives' headroom for the
//! move's stop is their limit's 95 % less what the operator's generator may use beside
//! it (`headroom`). Each cell also names where the largest share is: the slot (x, y, l),
//! what (v: |u|, a: |u̇| or |Δu|/h) and the time after the hand-over.
//!
//! `cargo run --release -p host-tests --example takeover_limits [ENTRY_BLEND_S]`
//! (`ENTRY_BLEND_S`: the longest stop, `Settings::entry_blend`).

use controller::setpoint::AxisLimits;
use host_tests::operator::{drive, Crane, Extremes, Gen};
use nalgebra::SVector;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::Crane3dParams;
use solver_core::operator::{Generator3d, Handover, Headroom, PlanarGenerator, Room, Settings};
use solver_core::trajectory::{PointToPoint, Trajectory};

/// The room a drive with limits `l` leaves a hand-over's stop beside an operator moving
/// at up to `speed` and `acceleration` (the manual settings): 95 % of the limit less the
/// operator's speed, and less 1.5 times its acceleration (the generator's drive
/// acceleration stays within it, its rate adds `τ x⃛`).
fn room(l: &AxisLimits, speed: f64, acceleration: f64) -> Room {
    Room {
        speed: 0.95 * l.max_velocity - speed,
        acceleration: 0.95 * l.max_acceleration - 1.5 * acceleration,
    }
}

fn main() -> Result<(), String> {
    let blend = match std::env::args().nth(1) {
        Some(b) => Some(b.parse::<f64>().map_err(|e| format!("{b}: {e}"))?),
        None => None,
    };
    let mut planar = Settings::lab(&CraneParams::PAPER);
    let mut spatial = Settings::lab_3d(&Crane3dParams::EXAMPLE);
    if let Some(b) = blend {
        planar.entry_blend = b;
        spatial.entry_blend = b;
    }
    println!(
        "longest stop (entry_blend) {} s; largest share of a drive limit after the hand-over \
         (slot, v|a, s after), stick -1 / 0 / +1",
        planar.entry_blend
    );
    println!("| crane | move | at | load speed, m/s | stick −1 | 0 | +1 |");
    println!("|---|---|---:|---:|---:|---:|---:|");
    let mut worst = 0.0_f64;
    let mut refused = 0;
    let planar_moves: [(f64, [f64; 2]); 3] =
        [(6.0, [18.0, 6.0]), (8.0, [20.0, 4.0]), (16.0, [20.0, 4.0])];
    let spatial_moves: [(f64, [f64; 3], [f64; 3]); 2] = [
        (8.0, [12.0, 3.0, 8.0], [20.0, 6.0, 4.0]),
        (10.0, [19.0, 6.0, 4.0], [13.0, 2.0, 7.0]),
    ];
    let shares = [0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9];
    for (duration, to) in planar_moves {
        let from = [12.0, 8.0];
        let mv = PointToPoint::new(SVector::from(from), SVector::from(to), 0.0, duration, 5)
            .map_err(|e| e.to_string())?;
        let crane = Crane::PLANAR;
        let [x, _, l] = crane.limits();
        let headroom = Headroom {
            horizontal: [room(&x, 1.0, 0.5)],
            hoist: room(&l, 0.5, 0.5),
        };
        for share in shares {
            let t = (share * duration / 0.01_f64).round() * 0.01;
            let d: [SVector<f64, 2>; 2] = mv.derivatives(t);
            let mut row = format!(
                "| planar | {duration} s {from:?} → {to:?} | {share} | {:.2} |",
                d[1].norm()
            );
            for stick in [-1.0, 0.0, 1.0] {
                let g =
                    PlanarGenerator::take_over(planar, t, &Handover::<1>::of(&mv, t), &headroom)
                        .map(Gen::Planar);
                row += &cell(&crane, g, t, [stick, 0.0, 0.0], &mut worst, &mut refused);
            }
            println!("{row}");
        }
    }
    for (duration, from, to) in spatial_moves {
        let mv = PointToPoint::new(SVector::from(from), SVector::from(to), 0.0, duration, 5)
            .map_err(|e| e.to_string())?;
        let crane = Crane::SPATIAL;
        let [x, y, l] = crane.limits();
        let headroom = Headroom {
            horizontal: [room(&x, 1.0, 0.5), room(&y, 0.8, 0.5)],
            hoist: room(&l, 0.5, 0.5),
        };
        for share in shares {
            let t = (share * duration / 0.01_f64).round() * 0.01;
            let d: [SVector<f64, 3>; 2] = mv.derivatives(t);
            let mut row = format!(
                "| 3D | {duration} s {from:?} → {to:?} | {share} | {:.2} |",
                d[1].norm()
            );
            for stick in [-1.0, 0.0, 1.0] {
                let g = Generator3d::take_over(spatial, t, &Handover::<2>::of(&mv, t), &headroom)
                    .map(Gen::Spatial);
                row += &cell(
                    &crane,
                    g,
                    t,
                    [stick, 0.5 * stick, 0.0],
                    &mut worst,
                    &mut refused,
                );
            }
            println!("{row}");
        }
    }
    println!("largest share {worst:.3}; {refused} hand-overs refused");
    Ok(())
}

/// One hand-over driven for 25 s with `stick` held for its first 3 s: its largest share
/// of a drive limit and where it was, or why it was refused.
fn cell(
    crane: &Crane,
    g: Result<Gen, solver_core::Error>,
    t: f64,
    stick: [f64; 3],
    worst: &mut f64,
    refused: &mut usize,
) -> String {
    let mut g = match g {
        Ok(g) => g,
        Err(e) => {
            *refused += 1;
            let reason = match e {
                solver_core::Error::OutsideWorkspace { coordinate, .. } => coordinate,
                _ => "room",
            };
            return format!(" refused ({reason}) |");
        }
    };
    let mut e = Extremes::default();
    let mut at = (0.0, 0.0, 0, "");
    let limits = crane.limits();
    let hold = |n| if n < 300 { stick } else { [0.0; 3] };
    drive(crane, &mut g, 2500, hold, |r| {
        e.add(crane, r);
        for (i, f) in r.flat.iter().flat_map(|f| (0..3).map(move |i| (i, f))) {
            let v = f.u[i].abs() / limits[i].max_velocity;
            let a = f.u_dot[i].abs() / limits[i].max_acceleration;
            for (s, what) in [(v, "v"), (a, "a")] {
                if s > at.0 {
                    at = (s, r.t - t, i, what);
                }
            }
        }
    });
    let share = e.share(crane);
    *worst = worst.max(share);
    format!(
        " {share:.2} ({} {} {:.1}) |",
        ["x", "y", "l"][at.2],
        at.3,
        at.1
    )
}
