//! The set points around a request for manual mode with the load at rest and the stick
//! centred: `cargo run --release -p drive-view --example manual_entry_at_rest -- [WAIT_S]
//! [quiet]`.
//!
//! The planar scene with `[operator]` and `[feedback]` on the study's plant with the load
//! 20 % heavier (`operator_plants`' "load +20 %"), its sensors noisy and quantised as the
//! study's (`quiet`: exact sensors). Manual mode is asked for after `WAIT_S` seconds (3 by
//! default); for 0.3 s after it every cycle whose trolley set point is not 0.0 is printed,
//! then the largest trolley set point and the trolley's largest distance from where it
//! stood over the second after the request. Up to 785a611 the feedback started at the
//! entry and, on the sensors' noise, moved the trolley at rest: this printed 0.0947 m/s
//! and 4.3 mm. It now observes from the entry and holds its correction until the stick's
//! first demand, and this prints 0.0000 m/s and 0.0 mm (asserted by `cargo test --release -p drive-view --test closed_loop
//! manual_mode_entered`).

use std::path::PathBuf;

use drive_view::engine::Engine;
use drive_view::switch::{Action, MasterSwitch};
use sim::plant::Mismatch;

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let wait: f64 = match args.next() {
        Some(a) => a.parse().map_err(|e| format!("WAIT_S: {e}"))?,
        None => 3.0,
    };
    let quiet = match args.next().as_deref() {
        None => false,
        Some("quiet") => true,
        Some(other) => return Err(format!("unknown argument {other}")),
    };
    let sensors = if quiet {
        Mismatch::NONE
    } else {
        Mismatch {
            position_noise: Mismatch::SENSORS.0,
            angle_noise: Mismatch::SENSORS.1,
            noise_seed: 7,
            ..Mismatch::NONE
        }
    };
    let plant = Mismatch {
        load_mass: 0.2,
        ..sensors
    };
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes/paper-crane-manual-feedback.toml");
    let mut engine = Engine::for_scene_with(&path, plant)?;
    let mut switch = MasterSwitch::new(engine.has_y());
    let cycles_before = (wait * 100.0).round() as usize;
    engine.run_for(&mut switch, cycles_before as f64 / 100.0)?;
    let stood = engine.checked_cycle(&mut switch)?.plant.drives[0];
    switch.apply(Action::ToggleManual);
    println!("manual mode asked for at {wait} s, the trolley at {stood:.4} m");
    let (mut largest, mut farthest) = (0.0_f64, 0.0_f64);
    for _ in 0..100 {
        let s = engine.checked_cycle(&mut switch)?;
        let u = s.setpoints[0];
        if u != 0.0 && s.t < wait + 0.3 {
            println!(
                "t {:.2} s, manual {}: trolley set point {u:+.4} m/s (model's {:+.4}), trolley {:.4} m, swing {:+.4}°",
                s.t,
                s.manual(),
                s.feedforward[0],
                s.plant.drives[0],
                s.plant.swing[0].to_degrees()
            );
        }
        largest = largest.max(u.abs());
        farthest = farthest.max((s.plant.drives[0] - stood).abs());
    }
    println!(
        "over the second after the request: largest trolley set point {largest:.4} m/s, the trolley at most {:.1} mm from where it stood",
        farthest * 1000.0
    );
    Ok(())
}
