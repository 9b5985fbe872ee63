//! Throwaway probe (not committed): after a short jog and its release, does the feedback
//! move the crane again long after the rest?
use drive_view::engine::Engine;
use drive_view::switch::{Action, Axis, MasterSwitch};
use std::path::PathBuf;
fn main() -> Result<(), String> {
    for scene in [
        "paper-crane-manual-feedback.toml",
        "crane3d/crane3d-manual-feedback.toml",
    ] {
        for jog in [0.3, 1.0, 4.0] {
            let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../scenes")
                .join(scene);
            let mut e = Engine::for_scene(&path)?;
            let mut s = MasterSwitch::new(e.has_y());
            e.run_for(&mut s, 3.0)?;
            s.apply(Action::ToggleManual);
            e.run_for(&mut s, 0.3)?;
            for _ in 0..drive_view::switch::NOTCHES {
                s.apply(Action::Notch(Axis::X, 1));
            }
            e.run_for(&mut s, jog)?;
            s.apply(Action::Centre);
            let snaps = e.run_for(&mut s, 90.0)?;
            let moving: Vec<f64> = snaps
                .iter()
                .filter(|c| c.setpoints != [0.0; 3])
                .map(|c| c.t)
                .collect();
            let last = moving.last().copied().unwrap_or(0.0);
            let after20 = moving.iter().filter(|t| **t > snaps[0].t + 20.0).count();
            let first_zero = snaps
                .iter()
                .position(|c| c.setpoints == [0.0; 3])
                .map(|i| snaps[i].t);
            println!("{scene} jog {jog}: first all-zero at {first_zero:?}, last non-zero at {last:.2} s (release at {:.2}), non-zero cycles later than 20 s: {after20}", snaps[0].t);
        }
    }
    Ok(())
}
