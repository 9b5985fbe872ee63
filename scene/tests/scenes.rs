//! The shipped scenes load; broken ones are refused naming the field and the reason.

use scene::cranes::planar::Planar;
use scene::cranes::spatial::Spatial;
use std::path::PathBuf;

use controller::setpoint::DriveLimits;
use scene::commissioning::{CommissioningFile, FILE_NAME};
use scene::firmware::firmware_scene;
use scene::Scene;

fn scenes_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes")
}

const PAPER: &str = include_str!("../../scenes/paper-crane.toml");

/// Every shipped scene, in `scenes/` and its folders (a crane's own folder holds its
/// scenes and its commissioning file), and each folder's commissioning file.
#[test]
fn every_shipped_scene_loads() {
    fn walk(dir: &std::path::Path, scenes: &mut usize, files: &mut usize) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, scenes, files);
                continue;
            }
            let commissioning = path.file_name().is_some_and(|n| n == FILE_NAME);
            if commissioning {
                let text = std::fs::read_to_string(&path).unwrap();
                CommissioningFile::parse(&text)
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                *files += 1;
            } else if path.extension().is_some_and(|e| e == "toml") {
                Scene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                *scenes += 1;
            }
        }
    }
    let (mut scenes, mut files) = (0, 0);
    walk(&scenes_dir(), &mut scenes, &mut files);
    assert!(
        scenes >= 8 && files >= 2,
        "{scenes} scenes, {files} commissioning files"
    );
}

/// The paper scene with one line replaced.
fn with(old: &str, new: &str) -> String {
    assert!(PAPER.contains(old), "{old}");
    PAPER.replacen(old, new, 1)
}

fn refused(text: &str) -> (String, String) {
    let e = Scene::parse(text).unwrap_err();
    (e.field, e.reason)
}

#[test]
fn broken_scenes_name_the_field() {
    let cases = [
        (with("h = 0.01", "h = -0.01"), "solver.h", "step size"),
        (with("h = 0.01", "h = \"fast\""), "solver.h", "invalid type"),
        (with("k = 4", "k = 9"), "solver.k", "1..=6"),
        (
            with("rho_power = 2", "rho_power = 5"),
            "solver.rho_power",
            "not supported",
        ),
        (
            with("jacobian = \"exact\"", "jacobian = \"magic\""),
            "solver.jacobian",
            "unknown variant",
        ),
        (
            with("max_iterations = 20", "max_iterations = 0"),
            "solver.max_iterations",
            "not supported",
        ),
        (
            with("duration = 8.0", "duration = 0.0"),
            "trajectory.duration",
            "outside",
        ),
        (
            with("smoothness = 4", "smoothness = 3"),
            "trajectory.smoothness",
            "needs n >= 4",
        ),
        (
            with("start = [12.0, 8.0]", "start = [12.0]"),
            "trajectory.start",
            "needs 2 values",
        ),
        (
            with("start = [12.0, 8.0]", "start = [12.0, 10.0]"),
            "trajectory",
            "outside the workspace",
        ),
        (
            with("start = [12.0, 8.0]", "start = [15.0, 3.0]")
                .replace("end = [20.0, 4.0]", "end = [15.0, 9.0]")
                .replace("duration = 8.0", "duration = 1.2"),
            "trajectory",
            "slack",
        ),
        (
            with("kind = \"crane-subs\"", "kind = \"crane-subs\"\ntau1 = 0.0"),
            "model.tau1",
            "outside",
        ),
        (
            with("kind = \"crane-subs\"", "kind = \"crane-subs\"\nmass = 3.0"),
            "model",
            "`model.mass`: unknown field",
        ),
        (
            with("t_end = 10.0", "t_end = nan"),
            "trajectory.t_end",
            "finite",
        ),
        // The workspace is a table of its own: a bad bound is named there, a bound
        // written beside the crane's keys is an unknown key of `[model]`. A key the
        // model's type does not know is refused in `model` (the parser reads the model's
        // keys after its kind, away from their place in the text), its reason naming the
        // key's whole path.
        (
            with(
                "kind = \"crane-subs\"",
                "kind = \"crane-subs\"\n\n[model.workspace]\nl_min = 0.0",
            ),
            "model.workspace.l_min",
            "outside",
        ),
        (
            with(
                "kind = \"crane-subs\"",
                "kind = \"crane-subs\"\nl_min = 2.0",
            ),
            "model",
            "`model.l_min`: unknown field `l_min`",
        ),
        (
            with(
                "kind = \"crane-subs\"",
                "kind = \"crane-subs\"\n\n[model.workspace]\nl_mx = 10.0",
            ),
            "model",
            "`model.workspace.l_mx`: unknown field `l_mx`, expected one of `x_min`, `x_max`, `l_min`, `l_max`",
        ),
        (
            with(
                "kind = \"crane-subs\"",
                "kind = \"double-pendulum-subs\"\n\n[model.crane.workspace]\nx_mni = 1.0",
            ),
            "model",
            "`model.crane.workspace.x_mni`: unknown field `x_mni`",
        ),
        // The hook-and-load crane's crane keys are in `[model.crane]`.
        (
            with(
                "kind = \"crane-subs\"",
                "kind = \"double-pendulum-subs\"\n\n[model.crane]\ntau1 = -0.1",
            )
            .replace("smoothness = 4", "smoothness = 7"),
            "model.crane.tau1",
            "outside",
        ),
        (
            with(
                "kind = \"crane-subs\"",
                "kind = \"double-pendulum-subs\"\n\n[model.crane.workspace]\nx_min = 30.0",
            )
            .replace("smoothness = 4", "smoothness = 7"),
            "model.crane.workspace.x_min",
            "outside",
        ),
    ];
    for (text, field, reason) in cases {
        let (f, r) = refused(&text);
        assert_eq!(f, field, "reason: {r}");
        assert!(r.contains(reason), "{field}: `{r}` does not say `{reason}`");
    }
}

#[test]
fn mass_on_car_angle_is_checked_in_degrees() {
    let text = std::fs::read_to_string(scenes_dir().join("mass-on-car.toml")).unwrap();
    let (f, r) = refused(&text.replace("alpha_deg = 15.0", "alpha_deg = 90.0"));
    assert_eq!(f, "model.alpha_deg", "{r}");
}

#[test]
fn garbage_is_refused_not_a_panic() {
    for text in ["", "name = 3", "[[[", "name = \"x\"\n[model]\nkind = 1"] {
        assert!(Scene::parse(text).is_err());
    }
}

#[test]
fn the_shipped_commissioning_file_is_the_stock_setup_and_the_firmware_scenes_pass() {
    let paper = scenes_dir().join("paper-crane.toml");
    let commissioning = CommissioningFile::for_scene(&paper).unwrap();
    assert_eq!(
        commissioning.config(DriveLimits::LAB, 10).unwrap(),
        controller::Config::DEFAULT
    );
    for name in [
        "paper-crane",
        "paper-crane-radau",
        "paper-crane-radau-exact",
    ] {
        let scene = Scene::load(&scenes_dir().join(format!("{name}.toml"))).unwrap();
        firmware_scene::<Planar, 2>(&scene, &commissioning)
            .unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

#[test]
fn scenes_the_firmware_cannot_run_are_refused_with_a_message() {
    let c = CommissioningFile::default();
    use scene::dispatch::FirmwareError;
    let refused =
        |text: String| firmware_scene::<Planar, 2>(&Scene::parse(&text).unwrap(), &c).unwrap_err();
    let e = refused(with("h = 0.01", "h = 0.1"));
    assert!(
        matches!(e, FirmwareError::CycleNotUnderWatchdog { h: 0.1, .. }),
        "{e:?}"
    );
    assert!(e.to_string().contains("watchdog"), "{e}");
    let e = refused(with("t_end = 10.0", "t_end = 10.005"));
    assert!(
        matches!(e, FirmwareError::RunNotWholeCycles { .. }),
        "{e:?}"
    );
    assert!(e.to_string().contains("does not divide"), "{e}");
    let e = refused(with("t_start = 1.0", "t_start = 0.5"));
    assert!(
        matches!(e, FirmwareError::StartsBeforeReady { t_start: 0.5, .. }),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .contains("before the drives can be commissioned"),
        "{e}"
    );
    let bad = CommissioningFile::parse("[controller]\nnode = 200\n").unwrap();
    let e = firmware_scene::<Planar, 2>(&Scene::parse(PAPER).unwrap(), &bad).unwrap_err();
    assert!(
        matches!(&e, FirmwareError::Commissioning(c) if c.field == "controller.node"),
        "{e:?}"
    );
    // Another crane's scene, named as such (not a NaN setting).
    let crane3d = Scene::load(&scenes_dir().join("crane3d/crane3d.toml")).unwrap();
    let e = firmware_scene::<Planar, 2>(&crane3d, &c).unwrap_err();
    assert_eq!(
        e,
        FirmwareError::NotThisCrane {
            model: crane3d.model.label(),
            crane: "planar crane"
        }
    );
    assert_eq!(
        e.to_string(),
        "the scene's model (3d-subs) is not the planar crane's"
    );
}

/// The 3D crane's scene with one line replaced.
fn crane3d_with(old: &str, new: &str) -> String {
    let text = include_str!("../../scenes/crane3d-diagonal.toml");
    assert!(text.contains(old), "{old}");
    text.replacen(old, new, 1)
}

#[test]
fn a_3d_scene_is_checked_as_a_planar_one_is() {
    let (field, reason) = refused(&crane3d_with(
        "end = [20.0, 6.0, 4.0]",
        "end = [20.0, 9.0, 4.0]",
    ));
    assert_eq!(field, "trajectory");
    assert!(
        reason.contains("y = ") && reason.contains("workspace"),
        "{reason}"
    );
    let (field, reason) = refused(&crane3d_with(
        "start = [12.0, 3.0, 8.0]",
        "start = [12.0, 8.0]",
    ));
    assert_eq!(field, "trajectory.start");
    assert!(reason.contains("needs 3 values"), "{reason}");
    let (field, _) = refused(&crane3d_with(
        "kind = \"crane3d-subs\"",
        "kind = \"crane3d-subs\"\ntau3 = -1.0",
    ));
    assert_eq!(field, "model.tau3");
}

/// The 3D crane's scenes in their folder pass the firmware's checks with the folder's
/// commissioning file (three drives, the two-axis inclinometer for the feedback), as
/// the 3D crane; with the planar crane's file they are refused, naming the bridge.
#[test]
fn the_3d_scenes_pass_with_their_own_commissioning_file() {
    use scene::dispatch::{firmware, FirmwareCrane, FirmwareCraneVisitor};
    use scene::firmware::FirmwareScene;
    struct Axes3;
    impl FirmwareCraneVisitor for Axes3 {
        type Output = (usize, bool);
        fn visit<K: FirmwareCrane<A>, const A: usize>(
            self,
            f: FirmwareScene<K, A>,
        ) -> Self::Output {
            (A, f.config.inclinometer().is_some_and(|i| i.two_axes()))
        }
    }
    let dir = scenes_dir().join("crane3d");
    for (name, feedback) in [
        ("crane3d", false),
        ("crane3d-radau5", false),
        ("crane3d-feedback", true),
    ] {
        let path = dir.join(format!("{name}.toml"));
        let scene = Scene::load(&path).unwrap();
        let own = CommissioningFile::for_scene(&path).unwrap();
        assert_eq!(
            firmware(&scene, &own, Axes3).unwrap(),
            (3, feedback),
            "{name}"
        );
        let planar = CommissioningFile::for_scene(&scenes_dir().join("paper-crane.toml")).unwrap();
        let e = firmware(&scene, &planar, Axes3).unwrap_err();
        assert!(e.to_string().contains("bridge"), "{name}: {e}");
    }
}

/// Each drive's set-point limits come from its commissioning row where it names them
/// (the planner's and the gate's), the crane's lab drive's otherwise: a slower bridge
/// refuses the 3D scene's move by the bridge's rule; a bad limit is refused by name.
#[test]
fn a_drives_limits_are_its_commissioning_rows() {
    use controller::setpoint::DriveLimits;
    use scene::firmware::firmware_scene;
    let path = scenes_dir().join("crane3d/crane3d.toml");
    let scene = Scene::load(&path).unwrap();
    let own = std::fs::read_to_string(scenes_dir().join("crane3d/commissioning.toml")).unwrap();
    // The hoist's row with its own acceleration limit.
    let hoist_row = own.replacen(
        "axis = \"winch\"",
        "axis = \"winch\"\nacceleration_limit = 2.5",
        1,
    );
    let file = CommissioningFile::parse(&hoist_row).unwrap();
    let f = firmware_scene::<Spatial, 3>(&scene, &file).unwrap();
    let [bridge, trolley, hoist] = f.planner.limits();
    let lab = DriveLimits::LAB_3D;
    assert_eq!((bridge, trolley), (lab[0], lab[1]));
    assert_eq!(hoist.max_acceleration, 2.5);
    assert_eq!(hoist.max_velocity, lab[2].max_velocity);
    // The bridge limited to 1.5 m/s: the diagonal move needs about 2 m/s.
    let slow = own.replacen(
        "axis = \"bridge\"",
        "axis = \"bridge\"\nvelocity_limit = 1.5",
        1,
    );
    let e = firmware_scene::<Spatial, 3>(&scene, &CommissioningFile::parse(&slow).unwrap())
        .unwrap_err();
    assert!(
        matches!(e, scene::dispatch::FirmwareError::PlannerRule(_)),
        "{e:?}"
    );
    assert!(e.to_string().contains("BridgeVelocity"), "{e}");
    let bad = own.replacen(
        "axis = \"trolley\"",
        "axis = \"trolley\"\nvelocity_limit = -1.0",
        1,
    );
    let e =
        firmware_scene::<Spatial, 3>(&scene, &CommissioningFile::parse(&bad).unwrap()).unwrap_err();
    assert!(e.to_string().contains("drive[1].velocity_limit"), "{e}");
    // Beyond what 0x60FF's i32 of µm/s can carry with room to spare: refused.
    let absurd = own.replacen(
        "axis = \"trolley\"",
        "axis = \"trolley\"\nvelocity_limit = 2500.0",
        1,
    );
    let e = firmware_scene::<Spatial, 3>(&scene, &CommissioningFile::parse(&absurd).unwrap())
        .unwrap_err();
    assert!(
        e.to_string().contains("drive[1].velocity_limit") && e.to_string().contains("at most"),
        "{e}"
    );
}

/// The extended formulations' scenes are checked as their direct ones are: a bad
/// parameter, a move outside the workspace or too rough for the model, each refused
/// naming the field; the firmware takes the planar one as its crane's.
#[test]
fn the_extended_scenes_are_checked_as_the_direct_ones() {
    let read = |name: &str| std::fs::read_to_string(scenes_dir().join(name)).unwrap();
    let (planar, spatial, car) = (
        read("paper-crane-ext.toml"),
        read("crane3d-diagonal-ext.toml"),
        read("mass-on-car-ext.toml"),
    );
    let cases = [
        (
            planar.replacen(
                "kind = \"crane-ext\"",
                "kind = \"crane-ext\"\ntau2 = -1.0",
                1,
            ),
            "model.tau2",
        ),
        (
            planar.replacen("start = [12.0, 8.0]", "start = [12.0, 10.0]", 1),
            "trajectory",
        ),
        (
            planar.replacen("smoothness = 4", "smoothness = 3", 1),
            "trajectory.smoothness",
        ),
        (
            spatial.replacen("end = [20.0, 6.0, 4.0]", "end = [20.0, 9.0, 4.0]", 1),
            "trajectory",
        ),
        (
            car.replacen("alpha_deg = 15.0", "alpha_deg = 90.0", 1),
            "model.alpha_deg",
        ),
    ];
    for (text, field) in cases {
        assert_ne!(Scene::parse(&text).map(|_| ()), Ok(()), "{field}");
        assert_eq!(refused(&text).0, field);
    }
    // The firmware links the extended cranes as it links subs.
    let f = firmware_scene::<Planar, 2>(
        &Scene::parse(&planar).unwrap(),
        &CommissioningFile::default(),
    )
    .unwrap();
    assert_eq!(
        f.scheme.model,
        scene::dispatch::FirmwareModel::Planar(scene::cranes::planar::PlanarModel::Ext)
    );
}

/// The hook-and-load crane's scene passes the firmware's checks as its own crane (two
/// drives, its own parameters and model); a `[feedback]` on it is refused by name (it has
/// no loop yet), not run as the planar crane's.
#[test]
fn the_hook_and_load_scene_is_its_own_crane() {
    use scene::dispatch::{firmware, FirmwareCrane, FirmwareCraneVisitor};
    use scene::firmware::FirmwareScene;
    struct Crane;
    impl FirmwareCraneVisitor for Crane {
        type Output = (usize, &'static str, &'static str);
        fn visit<K: FirmwareCrane<A>, const A: usize>(
            self,
            f: FirmwareScene<K, A>,
        ) -> Self::Output {
            (A, K::TYPE, f.scheme.model.path().1)
        }
    }
    let path = scenes_dir().join("hook-and-load.toml");
    let scene = Scene::load(&path).unwrap();
    let commissioning = CommissioningFile::for_scene(&path).unwrap();
    let (axes, ty, model) = firmware(&scene, &commissioning, Crane).unwrap();
    assert_eq!(axes, 2);
    assert!(ty.ends_with("::HookAndLoad"), "{ty}");
    assert_eq!(model, "DoublePendulumSubs");
    let text = std::fs::read_to_string(&path).unwrap() + "\n[feedback]\n";
    let with_feedback = Scene::parse(&text).unwrap();
    let e = firmware(&with_feedback, &commissioning, Crane).unwrap_err();
    assert!(
        e.to_string()
            .contains("hook-and-load crane has no state feedback"),
        "{e}"
    );
}

/// Every registered crane's QEMU scenes (`FirmwareCrane::QEMU_SCENES`, what `cargo xtask
/// qemu` runs on the healthy bus) pass the firmware's checks as that crane, the default
/// scene first (every scenario of the virtual bus runs on it), none listed twice.
#[test]
fn every_crane_s_qemu_scenes_are_its_own() {
    use scene::dispatch::{
        firmware, qemu_scenes, visit_crane, CraneVisitor, FirmwareCrane, FirmwareCraneVisitor,
        FirmwareModel,
    };
    use scene::firmware::FirmwareScene;
    struct Type;
    impl FirmwareCraneVisitor for Type {
        type Output = &'static str;
        fn visit<K: FirmwareCrane<A>, const A: usize>(
            self,
            _: FirmwareScene<K, A>,
        ) -> &'static str {
            K::TYPE
        }
    }
    struct Scenes;
    impl CraneVisitor for Scenes {
        type Output = usize;
        fn visit<K: FirmwareCrane<A>, const A: usize>(self, _: K::Model) -> usize {
            assert!(!K::QEMU_SCENES.is_empty(), "{}: no QEMU scene", K::TYPE);
            for file in K::QEMU_SCENES {
                let path = scenes_dir().parent().unwrap().join(file);
                let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
                let commissioning = CommissioningFile::for_scene(&path).unwrap();
                let ty = firmware(&scene, &commissioning, Type)
                    .unwrap_or_else(|e| panic!("{file}: {e}"));
                assert_eq!(ty, K::TYPE, "{file} is another crane's");
            }
            K::QEMU_SCENES.len()
        }
    }
    let mut cranes = Vec::new();
    let mut listed = 0;
    for model in FirmwareModel::every() {
        if !cranes.contains(&model.crane()) {
            cranes.push(model.crane());
            listed += visit_crane(model, Scenes);
        }
    }
    let all = qemu_scenes();
    assert_eq!(all.len(), listed);
    assert_eq!(all.first(), Some(&scene::firmware::DEFAULT_SCENE));
    let mut unique = all.clone();
    unique.sort_unstable();
    unique.dedup();
    assert_eq!(unique.len(), all.len(), "a scene listed twice: {all:?}");
}

/// Every model a scene can name (`ModelSpec::KINDS`, the one registration: `model_specs!`
/// in lib.rs): its `kind` reads back into it, its label in results is its own, and its
/// parameters come through exactly one accessor, of a type with as many outputs as the
/// model says. A model added to the registration is checked here without a line more.
#[test]
fn every_model_kind_has_its_label_and_one_kind_of_parameters() {
    use scene::ModelSpec;
    let mut labels = std::collections::BTreeSet::new();
    for kind in ModelSpec::KINDS {
        let model: ModelSpec =
            toml::from_str(&format!("kind = \"{kind}\"")).unwrap_or_else(|e| panic!("{kind}: {e}"));
        assert!(
            labels.insert(model.label()),
            "{kind}: label {} twice",
            model.label()
        );
        let groups = model.parameter_groups();
        assert_eq!(groups.len(), 1, "{kind}: {groups:?}");
        assert_eq!(groups[0].1, model.outputs(), "{kind}: {groups:?}");
    }
    // The labels the published results carry (docs/figures' CSVs) stay as they are.
    for (kind, label) in [
        ("crane-subs", "subs"),
        ("crane-proj", "proj"),
        ("crane-ext", "ext"),
        ("mass-on-car", "mass-on-car"),
        ("mass-on-car-ext", "mass-on-car-ext"),
        ("crane3d-subs", "3d-subs"),
        ("crane3d-ext", "3d-ext"),
        ("double-pendulum-subs", "dp-subs"),
        ("double-pendulum-ext", "dp-ext"),
    ] {
        let model: ModelSpec = toml::from_str(&format!("kind = \"{kind}\"")).unwrap();
        assert_eq!(model.label(), label, "{kind}");
    }
    assert!(toml::from_str::<ModelSpec>("kind = \"crane\"").is_err());
}

/// The sweep's formulation axis (`ModelSpec::with_formulation`): each model's formulations
/// by name or label, with the same parameters; another model's refused with the list of
/// its own.
#[test]
fn a_formulation_is_one_of_the_same_models() {
    use scene::ModelSpec;
    for kind in ModelSpec::KINDS {
        let model: ModelSpec = toml::from_str(&format!("kind = \"{kind}\"")).unwrap();
        assert_eq!(
            model.with_formulation(model.label()).unwrap(),
            model,
            "{kind}"
        );
        let e = model.with_formulation("bogus").unwrap_err();
        for name in e.formulations {
            let other = model.with_formulation(name).unwrap();
            assert_eq!(other.outputs(), model.outputs(), "{kind} {name}");
            assert_eq!(
                model.with_formulation(other.label()).unwrap(),
                other,
                "{kind} {name}"
            );
        }
    }
    let crane: ModelSpec = toml::from_str("kind = \"crane-subs\"\nm = 2000.0").unwrap();
    let proj = crane.with_formulation("proj").unwrap();
    assert_eq!(proj.label(), "proj");
    assert_eq!(proj.crane(), crane.crane());
    for (kind, message) in [
        ("crane-subs", "the planar crane's are subs, proj and ext"),
        ("crane3d-ext", "the 3D crane's are subs and ext"),
        (
            "double-pendulum-subs",
            "the hook-and-load crane's are subs and ext",
        ),
        ("mass-on-car", "the mass-on-car's are direct and ext"),
    ] {
        let model: ModelSpec = toml::from_str(&format!("kind = \"{kind}\"")).unwrap();
        let e = model.with_formulation("3d-subs-typo").unwrap_err();
        assert_eq!(e.to_string(), message);
    }
    // Another model's label is not this one's formulation.
    let car: ModelSpec = toml::from_str("kind = \"mass-on-car\"").unwrap();
    assert!(car.with_formulation("subs").is_err());
    assert!(car.with_formulation("dp-ext").is_err());
}
