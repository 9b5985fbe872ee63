//! Runs one scene's controller loop (the firmware's cycle) for profiling:
//! `valgrind --tool=callgrind target/release/examples/profile_scene scenes/paper-crane.toml`.
use host_tests::firmware::controller_reference;
use scene::commissioning::CommissioningFile;
use scene::Scene;
use sim::HEALTHY;

fn main() {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "scenes/paper-crane.toml".into());
    let path = std::path::Path::new(&path);
    let scene = Scene::load(path).expect("scene");
    let commissioning = CommissioningFile::for_scene(path).expect("commissioning file");
    let cycles = controller_reference(&scene, &commissioning, &HEALTHY).expect("runs");
    println!(
        "{} cycles, last mode {:?}",
        cycles.len(),
        cycles.last().map(|c| c.mode)
    );
}
