//! A scene's `[operator]` (manual mode, issue 28): the shipped manual scenes give the
//! lab's generator settings, every key out of range is refused by name, and a model that
//! cannot run manual mode is refused naming the model.

use scene::cranes::planar::Planar;
use scene::cranes::spatial::Spatial;
use std::path::PathBuf;

use scene::commissioning::CommissioningFile;
use scene::firmware::firmware_scene;
use scene::Scene;
use solver_core::models::crane::CraneParams;
use solver_core::models::crane3d::Crane3dParams;
use solver_core::operator::Settings;

fn scenes_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes")
}

const MANUAL: &str = include_str!("../../scenes/paper-crane-manual.toml");
const MANUAL_3D: &str = include_str!("../../scenes/crane3d/crane3d-manual.toml");

/// The planar manual scene with one line replaced.
fn with(old: &str, new: &str) -> String {
    assert!(MANUAL.contains(old), "{old}");
    MANUAL.replacen(old, new, 1)
}

fn refused(text: &str) -> (String, String) {
    let e = Scene::parse(text).unwrap_err();
    (e.field, e.reason)
}

/// The shipped manual scenes spell out the lab's settings: the firmware's setup holds
/// exactly `Settings::lab` / `Settings::lab_3d` of the scene's crane; their base scenes
/// (no `[operator]`) hold none.
#[test]
fn the_manual_scenes_give_the_lab_settings_and_their_bases_none() {
    let planar = scenes_dir().join("paper-crane-manual.toml");
    let scene = Scene::load(&planar).unwrap();
    let c = CommissioningFile::for_scene(&planar).unwrap();
    let f = firmware_scene::<Planar, 2>(&scene, &c).unwrap();
    assert_eq!(f.operator, Some(Settings::lab(&CraneParams::PAPER)));
    assert!(f
        .rust()
        .model
        .contains("Steered<solver_core::operator::PlanarGenerator, 2>"));

    let spatial = scenes_dir().join("crane3d/crane3d-manual.toml");
    let scene = Scene::load(&spatial).unwrap();
    let c = CommissioningFile::for_scene(&spatial).unwrap();
    let f = firmware_scene::<Spatial, 3>(&scene, &c).unwrap();
    assert_eq!(f.operator, Some(Settings::lab_3d(&Crane3dParams::EXAMPLE)));
    assert!(f
        .rust()
        .model
        .contains("Steered<solver_core::operator::Generator3d, 3>"));

    // An empty section is the lab's settings too.
    let start = MANUAL.find("\n# Manual mode").unwrap();
    let empty = format!("{}\n[operator]\n", &MANUAL[..start]);
    let scene = Scene::parse(&empty).unwrap();
    let f = firmware_scene::<Planar, 2>(&scene, &CommissioningFile::default()).unwrap();
    assert_eq!(f.operator, Some(Settings::lab(&CraneParams::PAPER)));

    for base in ["paper-crane.toml", "crane3d/crane3d.toml"] {
        let path = scenes_dir().join(base);
        let scene = Scene::load(&path).unwrap();
        assert_eq!(scene.operator, None, "{base}");
    }
    let scene = Scene::load(&scenes_dir().join("paper-crane.toml")).unwrap();
    let f = firmware_scene::<Planar, 2>(&scene, &CommissioningFile::default()).unwrap();
    assert_eq!(f.operator, None);
    assert!(f.rust().model.contains("Plan<f64, 2>"));
}

/// A key changed in the file reaches the generator's settings.
#[test]
fn the_keys_reach_the_generators_settings() {
    let text = with("speed = [1.0, 0.5]", "speed = [0.8, 0.3]")
        .replacen("robust = false", "robust = true", 1)
        .replacen("deadband = 0.05", "deadband = 0.1", 1);
    let scene = Scene::parse(&text).unwrap();
    let f = firmware_scene::<Planar, 2>(&scene, &CommissioningFile::default()).unwrap();
    let s = f.operator.unwrap();
    assert_eq!((s.horizontal[0].speed, s.hoist.speed), (0.8, 0.3));
    assert!(s.robust);
    assert_eq!(s.deadband, 0.1);
}

#[test]
fn a_bad_key_is_refused_by_name() {
    let cases = [
        (
            with("speed = [1.0, 0.5]", "speed = [1.0]"),
            "operator.speed",
            "one value per axis, [trolley, hoist]",
        ),
        (
            with("speed = [1.0, 0.5]", "speed = [1.0, -0.5]"),
            "operator.speed",
            "hoist",
        ),
        (
            with("acceleration = [0.5, 0.5]", "acceleration = [0.0, 0.5]"),
            "operator.acceleration",
            "trolley",
        ),
        (
            // More than half of g: the rope's tension.
            with("acceleration = [0.5, 0.5]", "acceleration = [0.5, 6.0]"),
            "operator.acceleration",
            "hoist acceleration",
        ),
        (
            with("boxes = [0.2, 0.2]", "boxes = [0.2, 0.205]"),
            "operator.boxes",
            "box",
        ),
        (
            with(
                "hoist_boxes = [0.2, 0.2, 0.2, 0.2]",
                "hoist_boxes = [0.2, 0.2, 0.2, -0.2]",
            ),
            "operator.hoist_boxes",
            "hoist box",
        ),
        (
            // Longer than the firmware's hoist ring.
            with(
                "hoist_boxes = [0.2, 0.2, 0.2, 0.2]",
                "hoist_boxes = [0.5, 0.2, 0.2, 0.2]",
            ),
            "operator.hoist_boxes",
            "holds 84",
        ),
        (
            // Longer than the firmware's horizontal ring.
            with("boxes = [0.2, 0.2]", "boxes = [3.0, 3.0]"),
            "operator",
            "holds 656",
        ),
        (
            with("deadband = 0.05", "deadband = 0.6"),
            "operator.deadband",
            "deadband",
        ),
        (
            with("lowering_allowance = 1.0", "lowering_allowance = -1.0"),
            "operator.lowering_allowance",
            "lowering_allowance",
        ),
        (
            with("entry_blend = 8.0", "entry_blend = 8.005"),
            "operator.entry_blend",
            "entry_blend",
        ),
        (
            // A rope so short that the generator's pendulum swings more than a tenth of
            // a radian per cycle at the shallowest load: named by its key.
            with(
                "kind = \"crane-subs\"",
                "kind = \"crane-subs\"\n\n[model.workspace]\nl_min = 0.05",
            ),
            "model.workspace.l_min",
            "omega_g h",
        ),
        (
            with("robust = false", "robust = \"yes\""),
            "operator.robust",
            "invalid type",
        ),
        (
            with("robust = false", "robust = false\nstick = 1.0"),
            "operator.stick",
            "unknown field `stick`",
        ),
    ];
    for (text, field, reason) in cases {
        let (f, r) = refused(&text);
        assert_eq!(f, field, "{r}");
        assert!(r.contains(reason), "{field}: {r}");
    }
    // The 3D crane's arrays have three values.
    let (f, r) = refused(&MANUAL_3D.replacen("speed = [1.0, 0.8, 0.5]", "speed = [1.0, 0.5]", 1));
    assert_eq!(f, "operator.speed");
    assert!(r.contains("[bridge, trolley, hoist]"), "{r}");
}

/// Only *subs* of the planar and the 3D crane run manual mode: every other model is
/// refused with an error naming it.
#[test]
fn a_model_without_manual_mode_is_refused_naming_it() {
    let planar = |kind: &str| with("kind = \"crane-subs\"", &format!("kind = \"{kind}\""));
    let spatial = MANUAL_3D.replacen("kind = \"crane3d-subs\"", "kind = \"crane3d-ext\"", 1);
    let cases = [
        (planar("crane-proj"), "Proj"),
        (planar("crane-ext"), "Ext"),
        (spatial, "Ext"),
    ];
    for (text, model) in cases {
        let (f, r) = refused(&text);
        assert_eq!(f, "operator", "{r}");
        assert!(r.contains("*subs*") && r.contains(model), "{r}");
    }
    // The hook-and-load crane has no generator.
    let dp = planar("double-pendulum-subs").replacen("smoothness = 4", "smoothness = 7", 1);
    let (f, r) = refused(&dp);
    assert_eq!(f, "operator", "{r}");
    assert!(r.contains("hook-and-load"), "{r}");
    // No crane at all.
    let car = with("kind = \"crane-subs\"", "kind = \"mass-on-car\"")
        .replacen("start = [12.0, 8.0]", "start = [0.0]", 1)
        .replacen("end = [20.0, 4.0]", "end = [1.0]", 1);
    let (f, r) = refused(&car);
    assert_eq!(f, "operator", "{r}");
    assert!(r.contains("mass-on-car"), "{r}");
    // f32.
    let f32 = with(
        "max_iterations = 20",
        "max_iterations = 20\nscalar = \"f32\"",
    );
    let (f, r) = refused(&f32);
    assert_eq!(f, "operator", "{r}");
    assert!(r.contains("f32"), "{r}");
}
