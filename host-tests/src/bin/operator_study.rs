//! Operator mode's generator study (issue 28):
//! `cargo run --release -p host-tests --bin operator_study -- [--depths 3,6] [--sequences N] [--figures DIR]`.
//!
//! Prints the tables of `docs/OPERATOR.md`: the generator's RAM and ring lengths; per
//! crane and rope length the full-stick step (time to 10 % / 90 % of full speed, the
//! stopping distance from full speed and its bound, plain and robust); every scripted
//! profile with the hoist idle, lowering and raising (median and worst of the drive
//! limit used, the release's stopping distance against its bound, the load in the
//! model's nonlinear plant driven by the inverse model, the residual swing in a plant
//! whose pendulum is 10 % longer or shorter); the random sequences of the property test.
//! Draws `operator-stopping.svg`: every release's stopping distance against its bound.

use std::path::PathBuf;

use clap::Parser;
use host_tests::operator::{random_sequences, Crane};
use host_tests::operator_study::{
    hoisting_row, plot_stops, profile_row, ram, step_row, study_depth, Shape, DEPTHS,
    HOISTING_HEADER, PROFILE_HEADER, STEP_HEADER,
};
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::Crane3dParams;
use solver_core::operator::{Settings, LAB_HOIST_RING, LAB_RING};

#[derive(Parser)]
struct Args {
    /// Rope lengths (load depths at rest), m.
    #[arg(long, value_delimiter = ',', default_values_t = DEPTHS)]
    depths: Vec<f64>,
    /// Random stick sequences per crane (the property test's).
    #[arg(long, default_value_t = 10_000)]
    sequences: usize,
    /// Where the SVG figure goes.
    #[arg(long, default_value = "docs/figures")]
    figures: PathBuf,
}

fn main() -> Result<(), String> {
    let args = Args::parse();
    let cranes = [Crane::PLANAR, Crane::SPATIAL];

    println!("## RAM\n");
    for (name, bytes) in ram() {
        println!("- {name}: {bytes} bytes");
    }
    let mut planar = Settings::lab(&CraneParams::PAPER);
    let mut spatial = Settings::lab_3d(&Crane3dParams::EXAMPLE);
    for robust in [false, true] {
        planar.robust = robust;
        spatial.robust = robust;
        let (a, b) = planar.ring_lengths().map_err(|e| e.to_string())?;
        let (c, d) = spatial.ring_lengths().map_err(|e| e.to_string())?;
        println!(
            "- rings needed{}: planar {a} + {b} cycles, 3D {c} + {d} cycles (the lab types hold {LAB_RING} + {LAB_HOIST_RING})",
            if robust { ", robust" } else { "" }
        );
    }

    println!("\n## Full-stick step\n\n{STEP_HEADER}");
    for crane in &cranes {
        for depth in &args.depths {
            println!("{}", step_row(crane, *depth)?);
        }
    }

    println!("\n## Scripted profiles\n");
    for crane in &cranes {
        println!(
            "{}: {} stick shapes × hoist idle / lowering / raising: {}",
            crane.name(),
            Shape::all(crane).len(),
            Shape::all(crane)
                .iter()
                .map(Shape::name)
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    println!("\n{PROFILE_HEADER}");
    let mut stops = Vec::new();
    let mut hoisting = Vec::new();
    // Per stick shape and hoist lever: robust hoisting runs over 0.1° (drum ±10 %), runs.
    let mut misses = std::collections::BTreeMap::new();
    for crane in &cranes {
        for depth in &args.depths {
            let runs = study_depth(crane, *depth)?;
            println!("{}", profile_row(crane, *depth, &runs));
            hoisting.push(hoisting_row(crane, *depth, &runs));
            for (p, o) in runs.iter().filter(|(p, _)| p.hoist != 0.0) {
                let lever = if p.hoist > 0.0 { "lowering" } else { "raising" };
                let count = misses.entry((p.shape.name(), lever)).or_insert((0, 0));
                count.0 += usize::from(o.mismatch[1][0] > 0.1);
                count.1 += 1;
            }
            let points: Vec<(f64, f64)> = runs
                .iter()
                .filter(|(p, _)| matches!(p.shape, Shape::Step { .. }) && p.hoist == 0.0)
                .map(|(_, o)| (o.stop.1, o.stop.0))
                .collect();
            // Three rope lengths per crane: the plot's eight colours.
            if [3.0, 6.0, 8.95].contains(depth) {
                stops.push((format!("{}, rope {depth} m", crane.name()), points));
            }
        }
    }

    println!(
        "\n## The robust setting with the hoist moving during the travel, per form of the pendulum's error\n\n{HOISTING_HEADER}"
    );
    for row in hoisting {
        println!("{row}");
    }
    println!("\nRuns over 0.1° with the drum ±10 %, per stick shape and hoist lever (both cranes, every rope):\n");
    for ((shape, lever), (over, runs)) in &misses {
        if *over > 0 {
            println!("- {shape}, hoist {lever}: {over} of {runs}");
        }
    }

    println!("\n## Random stick sequences\n");
    for (crane, seed) in [(Crane::PLANAR, 2801), (Crane::SPATIAL, 2802)] {
        let r = random_sequences(&crane, seed, args.sequences);
        let w = r.worst;
        println!(
            "- {}: {} sequences of 12 s: largest |u| {:.3?} m/s, |u̇| {:.3?} m/s², |Δu|/h {:.3?} m/s² \
             (slots x, y, hoist); largest share of a drive limit {:.3}; nearest approach to a \
             range's end {:.2e} m (negative: inside); largest λ {:.3} 1/s² (negative: tension)",
            crane.name(),
            r.sequences,
            w.u,
            w.u_dot,
            w.du,
            r.share.0,
            w.outside,
            w.lambda
        );
    }

    let path = args.figures.join("operator-stopping.svg");
    plot_stops(&path, &stops)?;
    println!("\nfigure: {}", path.display());
    Ok(())
}
