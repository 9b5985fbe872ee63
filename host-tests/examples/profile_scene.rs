//! Runs one scene's controller loop (the firmware's cycle) for profiling:
//! `valgrind --tool=callgrind target/release/examples/profile_scene scenes/paper-crane.toml`.
use controller::virtual_bus::HEALTHY;
use host_tests::firmware::controller_reference;
use scene::Scene;

fn main() {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "scenes/paper-crane.toml".into());
    let scene = Scene::load(std::path::Path::new(&path)).expect("scene");
    let cycles = controller_reference(&scene, &HEALTHY).expect("runs");
    println!(
        "{} cycles, last mode {:?}",
        cycles.len(),
        cycles.last().map(|c| c.mode)
    );
}
