//! One construction of the firmware's controller on the host (`host_tests::firmware::
//! with_controller`), used by the host's run of the firmware — which every QEMU run is
//! compared with frame for frame — and by the virtual ECU: for every crane scene it
//! links the Newton strategy the firmware links and the state feedback exactly when the
//! scene has `[feedback]` (issue 18: the ECU had run the feedback scene feedforward only).

use std::path::{Path, PathBuf};

use controller::correction::AxesCorrection;
use controller::{Controller, Feedforward, Injectable, Replan};
use host_tests::firmware::{with_controller, WithController};
use scene::commissioning::CommissioningFile;
use scene::dispatch::{firmware, FirmwareCrane, FirmwareCraneVisitor};
use scene::firmware::FirmwareScene;
use scene::Scene;

/// What a controller was built with: a feedback, its inverse model's type, its drives.
struct Probe;

impl WithController for Probe {
    type Output = (bool, String, usize);

    fn with<F, C, K, const A: usize>(
        self,
        controller: Controller<Injectable<F>, C, K, A>,
        _: &FirmwareScene<K, A>,
    ) -> Self::Output
    where
        F: Feedforward<A, Reference = K::Reference> + Replan<A>,
        C: AxesCorrection<A, K::Reference>,
        K: FirmwareCrane<A>,
    {
        (
            controller.feedback_mode().is_some(),
            std::any::type_name::<F>().to_string(),
            controller.drives().len(),
        )
    }
}

/// The scene's controller, built as the host's run of the firmware builds it; and
/// whether the firmware's scheme for it is structured.
struct Build<'a>(&'a Scene);

impl FirmwareCraneVisitor for Build<'_> {
    type Output = Result<((bool, String, usize), bool), String>;

    fn visit<K: FirmwareCrane<A>, const A: usize>(self, f: FirmwareScene<K, A>) -> Self::Output {
        let built = with_controller(self.0, &f, f.plan, f.config, Probe)?;
        Ok((built, f.scheme.structured()))
    }
}

/// The scene files under `dir` and its folders (a crane's own folder holds its scenes
/// and its commissioning file).
fn scene_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(scene_files(&path));
        } else if path.extension().is_some_and(|e| e == "toml")
            && !path.ends_with("commissioning.toml")
        {
            out.push(path);
        }
    }
    out
}

#[test]
fn every_crane_scene_gets_the_firmwares_controller() {
    let mut checked = 0;
    let mut spatial = 0;
    let mut hook_and_load = 0;
    for path in scene_files(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes")) {
        let scene = Scene::load(&path).unwrap();
        let commissioning = CommissioningFile::for_scene(&path).unwrap();
        // A scene the firmware cannot run (another model, a move its planner refuses, a
        // commissioning file without the crane's drives) is refused with the reason,
        // never run as something else.
        let Ok(((feedback, model, drives), structured)) =
            firmware(&scene, &commissioning, Build(&scene))
                .map_err(|e| e.to_string())
                .and_then(|built| built)
        else {
            continue;
        };
        hook_and_load += usize::from(model.contains("DoublePendulum"));
        assert_eq!(feedback, scene.feedback.is_some(), "{}", path.display());
        assert_eq!(
            model.contains("Structured"),
            structured,
            "{}: {model}",
            path.display()
        );
        assert_eq!(drives, scene.trajectory.start.len(), "{}", path.display());
        spatial += usize::from(drives == 3);
        checked += 1;
    }
    assert!(
        checked >= 7 && spatial >= 1 && hook_and_load >= 1,
        "{checked} scenes, {spatial} in 3D, {hook_and_load} hook-and-load"
    );
}
