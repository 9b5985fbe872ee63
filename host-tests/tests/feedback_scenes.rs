//! The scenes with the state feedback as the firmware runs them (the host's run of its
//! loop, which each QEMU run must equal frame by frame): the scene's own move, planned
//! at boot as the main job's command, starts at the scene's `t_start`. Until then the
//! feedback only observes — every set point exactly 0.0, with the drives enabled and
//! the inclinometer read — and the move starts in the cycles after (5a6c933: up to
//! 3f6faa8 the loop closed at boot and acted on the young estimate's noise, the 3D
//! crane's bridge at up to 0.131 m/s before its move, the planar trolley at 0.063 m/s).
//!
//! Planar and 3D, on every scenario QEMU runs each with (`sim::FEEDBACK_SCENARIOS`,
//! `sim::CRANE3D_FEEDBACK_SCENARIOS`: plants that are not the model, a gust, the
//! inclinometer lost or stuck), and the scenes with manual mode and the feedback on the
//! mismatched plant (`sim::CLOSED_LOOP`). The controller's own tests check the same
//! rule on the planar crane built by hand (`controller/tests/closed_loop.rs`).

use std::path::Path;

use controller::Mode;
use host_tests::firmware::{controller_reference, ReferenceCycle};
use scene::commissioning::CommissioningFile;
use scene::Scene;
use sim::{Scenario, CLOSED_LOOP, CRANE3D_FEEDBACK_SCENARIOS, FEEDBACK_SCENARIOS};

/// Whether any set point of the cycle is not exactly zero.
fn moves(cycle: &ReferenceCycle) -> bool {
    cycle.setpoints.iter().any(|s| s.units() != 0)
}

/// The firmware's run of `scene` (a path from the repository's root) with each of
/// `scenarios`: nothing moves before the scene's move starts, and it starts within
/// 0.1 s of its `t_start`.
fn still_until_the_scene_s_move(scene: &str, scenarios: &[Scenario]) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(scene);
    let s = Scene::load(&path).unwrap();
    let commissioning = CommissioningFile::for_scene(&path).unwrap();
    assert!(s.feedback.is_some(), "{scene} closes the loop");
    let start_ms = (s.trajectory.t_start * 1000.0).round() as u32;
    for scenario in scenarios {
        let run = controller_reference(&s, &commissioning, scenario).unwrap();
        let what = format!("{scene}, {}", scenario.name);
        let before: Vec<&ReferenceCycle> = run.iter().filter(|c| c.now_ms < start_ms).collect();
        let ready = before.iter().filter(|c| c.mode == Mode::Ready).count();
        assert!(
            ready > 20,
            "{what}: ready {ready} cycles before the move's start"
        );
        if let Some(c) = before.iter().find(|c| moves(c)) {
            panic!(
                "{what}: a set point before the move's start at {} ms: {:?}",
                c.now_ms, c.setpoints
            );
        }
        assert!(
            run.iter()
                .filter(|c| (start_ms..start_ms + 100).contains(&c.now_ms))
                .any(moves),
            "{what}: the move starts"
        );
    }
}

#[test]
fn the_planar_feedback_scene_stands_still_until_its_move_starts() {
    still_until_the_scene_s_move("scenes/paper-crane-feedback.toml", &FEEDBACK_SCENARIOS);
}

#[test]
fn the_3d_feedback_scene_stands_still_until_its_move_starts() {
    still_until_the_scene_s_move(
        "scenes/crane3d/crane3d-feedback.toml",
        &CRANE3D_FEEDBACK_SCENARIOS,
    );
}

#[test]
fn the_manual_scenes_with_the_feedback_stand_still_until_their_move_starts() {
    for scene in [
        "scenes/paper-crane-manual-feedback.toml",
        "scenes/crane3d/crane3d-manual-feedback.toml",
    ] {
        still_until_the_scene_s_move(scene, &[CLOSED_LOOP]);
    }
}
