//! One construction of the firmware's controller on the host (`host_tests::firmware::
//! with_controller`), used by the host's run of the firmware — which every QEMU run is
//! compared with frame for frame — and by the virtual ECU: for every crane scene it
//! links the Newton strategy the firmware links and the state feedback exactly when the
//! scene has `[feedback]` (issue 18: the ECU had run the feedback scene feedforward only).

use std::path::Path;

use controller::feedback::Correction;
use controller::{Controller, Feedforward, Injectable, Replan};
use host_tests::firmware::{with_controller, WithController};
use scene::commissioning::CommissioningFile;
use scene::firmware::firmware_scene;
use scene::{ModelSpec, Scene};

/// What a controller was built with: a feedback, its inverse model's type.
struct Probe;

impl WithController for Probe {
    type Output = (bool, String);

    fn with<F: Feedforward + Replan, C: Correction>(
        self,
        controller: Controller<Injectable<F>, C>,
    ) -> Self::Output {
        (
            controller.feedback_mode().is_some(),
            std::any::type_name::<F>().to_string(),
        )
    }
}

#[test]
fn every_crane_scene_gets_the_firmwares_controller() {
    let mut checked = 0;
    for entry in std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes")).unwrap()
    {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") || path.ends_with("commissioning.toml") {
            continue;
        }
        let scene = Scene::load(&path).unwrap();
        let commissioning = CommissioningFile::for_scene(&path).unwrap();
        // A scene the firmware cannot run (another model, a move its planner refuses) is
        // refused with the reason, never run as something else.
        let Ok(f) = firmware_scene(&scene, &commissioning) else {
            continue;
        };
        let plan = f.plan;
        let built = with_controller(&scene, &f, plan, f.config, Probe);
        if let ModelSpec::MassOnCar(_) = scene.model {
            assert!(built.is_err(), "{}: refused, not dropped", path.display());
            continue;
        }
        let (feedback, model) = built.unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(feedback, scene.feedback.is_some(), "{}", path.display());
        assert_eq!(
            model.contains("Structured"),
            f.scheme.structured(),
            "{}: {model}",
            path.display()
        );
        checked += 1;
    }
    assert!(checked >= 5, "{checked} scenes");
}
