//! Picks the board's memory map and turns the scene chosen at build time into Rust.
//!
//! `SCENE=path/to/scene.toml` (default: `scene::firmware::DEFAULT_SCENE`) names one model,
//! its parameters, the trajectory and the solver settings. The generated `scene.rs`
//! declares exactly that model and integrator type, so the firmware links only the
//! model its scene needs. A scene the firmware cannot run (not a crane, invalid) stops
//! the build with the scene checker's message.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};

use scene::commissioning::CommissioningFile;
use scene::dispatch::{firmware, FirmwareCrane, FirmwareCraneVisitor};
use scene::firmware::FirmwareScene;
use scene::rust_source::{module, Code, Item, ToRust, TypedF64};
use scene::{JacobianSpec, Scene};

fn main() {
    let manifest =
        PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    let root = manifest
        .parent()
        .expect("firmware/ lives in the repository")
        .to_path_buf();

    // Board: memory map, interrupt table, linker scripts.
    let qemu = env::var_os("CARGO_FEATURE_QEMU").is_some();
    let stm32 = env::var_os("CARGO_FEATURE_STM32H743").is_some();
    if qemu == stm32 {
        panic!("choose exactly one board: --features qemu or --features stm32h743");
    }
    let memory = if qemu {
        manifest.join("qemu/memory.x")
    } else {
        root.join("memory.x")
    };
    copy(&memory, &out.join("memory.x"));
    if qemu {
        copy(&manifest.join("qemu/device.x"), &out.join("device.x"));
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    println!("cargo:rustc-link-arg-bins=--nmagic");

    // Scene.
    println!("cargo:rerun-if-env-changed=SCENE");
    let scene_path = env::var("SCENE")
        .map(PathBuf::from)
        .unwrap_or_else(|_| root.join(scene::firmware::DEFAULT_SCENE));
    let scene_path = if scene_path.is_absolute() {
        scene_path
    } else {
        root.join(scene_path)
    };
    println!("cargo:rerun-if-changed={}", scene_path.display());
    let scene =
        Scene::load(&scene_path).unwrap_or_else(|e| panic!("scene {}: {e}", scene_path.display()));
    let commissioning = scene_path.with_file_name(scene::commissioning::FILE_NAME);
    println!("cargo:rerun-if-changed={}", commissioning.display());
    let commissioning = CommissioningFile::for_scene(&scene_path)
        .unwrap_or_else(|e| panic!("{}: {e}", commissioning.display()));
    let code = generate(&scene, &commissioning)
        .unwrap_or_else(|e| panic!("scene {}: {e}", scene_path.display()));
    fs::write(out.join("scene.rs"), code).expect("OUT_DIR is writable");
}

fn copy(from: &Path, to: &Path) {
    fs::copy(from, to).unwrap_or_else(|e| panic!("{}: {e}", from.display()));
    println!("cargo:rerun-if-changed={}", from.display());
}

/// The Rust for one scene.
fn generate(scene: &Scene, commissioning: &CommissioningFile) -> Result<String, String> {
    // The checks and the setup the host's run of the firmware loop shares, as the
    // scene's crane's type (`scene::dispatch::firmware`, the one place a scene's crane
    // becomes a type).
    firmware(scene, commissioning, Generate { scene })?
}

/// Writes the scene module for the scene's crane.
struct Generate<'a> {
    scene: &'a Scene,
}

impl FirmwareCraneVisitor for Generate<'_> {
    type Output = Result<String, String>;

    fn visit<K: FirmwareCrane<A>, const A: usize>(
        self,
        setup: FirmwareScene<K, A>,
    ) -> Self::Output {
        crane_module(self.scene, &setup)
    }
}

/// The Rust of the scene module for crane `K` with `A` driven axes.
fn crane_module<K: FirmwareCrane<A>, const A: usize>(
    scene: &Scene,
    setup: &FirmwareScene<K, A>,
) -> Result<String, String> {
    // The model, the scheme and the Newton strategy are types, so the firmware links
    // only the ones its scene names (`scene::dispatch::FirmwareScheme`, which the host's
    // run of the firmware builds too).
    let types = setup.rust();
    let s = &scene.solver;
    let transformed = s.newton == scene::NewtonSpec::Transformed;
    let jacobian_label = match (s.jacobian, s.reinit_every) {
        _ if transformed => "RADAU5".to_string(),
        (JacobianSpec::Fd, _) => "J".to_string(),
        (JacobianSpec::Exact, _) => "exact".to_string(),
        (JacobianSpec::Broyden, None) => "J~".to_string(),
        (JacobianSpec::Broyden, Some(m)) => format!("J~{m}"),
    };
    let tr = &scene.trajectory;
    let solver = format!("{} {jacobian_label} h = {} s", types.scheme, s.h);
    let config = scene::firmware::config_source(&setup.config)?;
    let stub = env::var_os("CARGO_FEATURE_STUB_INVERSE_MODEL").is_some();
    let inverse_model = format!(
        "controller::InverseModel<Crane, Model, Integrator, f64, {{ {} }}>",
        types.unknowns
    );
    let mut items = vec![
        Item::constant("Scene name.", "NAME", "&str", &scene.name.as_str()),
        Item::constant(
            "Scheme and Jacobian, for logs.",
            "SOLVER",
            "&str",
            &solver.as_str(),
        ),
        Item::constant(
            "Cycles the scene's move takes (to its `t_end`).",
            "CYCLES",
            "u32",
            &setup.cycles,
        ),
        Item::constant(
            "Cycle time, ms.",
            "PERIOD_MS",
            "u32",
            &setup.config.period_ms,
        ),
        Item::constant(
            "The controller's configuration: the scene's cycle and the commissioning file.",
            "CONFIG",
            "controller::Config",
            &Code(&config),
        ),
        Item::constant("The crane's driven axes.", "AXES", "usize", &A),
        Item::type_alias("The crane.", "Crane", K::TYPE),
        Item::type_alias(
            "The crane model, driven by a plan that changes on command.",
            "Model",
            &types.model,
        ),
        Item::type_alias("The integrator.", "Integrator", &types.integrator),
        if stub {
            Item::type_alias(
                "The inverse model stubbed out (feature `stub-inverse-model`).",
                "Feedforward",
                "Stub",
            )
        } else {
            Item::type_alias("Model and integrator.", "Feedforward", &inverse_model)
        },
    ];
    // The state feedback is linked only when the scene closes the loop.
    let correction = "correction() -> Result<Correction, controller::feedback::DesignError>";
    match &setup.feedback {
        Some(config) => items.extend([
            Item::type_alias(
                "Between the inverse model and the drives: the state feedback (Fig. 1).",
                "Correction",
                K::FEEDBACK_TYPE,
            ),
            Item::constant(
                "Its configuration: the scene's `[feedback]`.",
                "FEEDBACK",
                "controller::feedback::Config",
                config,
            ),
            Item::function(
                "The feedback, its gains designed from the scene's weights.",
                correction,
                K::FEEDBACK_NEW,
            ),
        ]),
        None => items.extend([
            Item::type_alias(
                "Between the inverse model and the drives: nothing (feedforward only).",
                "Correction",
                "controller::feedback::NoFeedback",
            ),
            Item::function(
                "No feedback to design.",
                correction,
                "Ok(controller::feedback::NoFeedback)",
            ),
        ]),
    }
    let planner = format!(
        "controller::planner::Planner::with_axes(PARAMS, {})",
        setup.planner.limits().to_rust()
    );
    items.extend([
        Item::constant("Crane parameters.", "PARAMS", "Crane", &setup.params),
        Item::constant(
            "The planner of moves on command: this crane, its drives' set-point limits (the\n\
             commissioning file's; the set-point gate enforces them too).",
            "PLANNER",
            "controller::planner::Planner<Crane, AXES>",
            &Code(&planner),
        ),
    ]);
    // Manual mode's generator is linked only when the scene has `[operator]`.
    if let Some(operator) = &setup.operator {
        items.extend([
            Item::type_alias(
                "Manual mode (the scene's `[operator]`): the path the model follows, the plan or\n\
                 the operator's generator.",
                "Steered",
                K::STEERED_TYPE,
            ),
            Item::constant(
                "The generator's settings.",
                "OPERATOR",
                K::OPERATOR_TYPE,
                operator,
            ),
        ]);
    }
    let (start, end): ([f64; A], [f64; A]) = (
        setup.first_move.start().into(),
        setup.first_move.end().into(),
    );
    let build = if stub {
        "Ok(Stub { plan, t: 0.0 })".to_string()
    } else {
        let path = if setup.operator.is_some() {
            "Steered::new(plan, OPERATOR)"
        } else {
            "plan"
        };
        format!(
            "let model = Model::new(PARAMS.0, {path})?;\n\
             let integrator = {}?;\n\
             Ok(controller::InverseModel::new(model, integrator))",
            types.new
        )
    };
    let body = format!(
        "let mut plan = controller::crane::command_plan::<Crane, AXES>(START, {})?;\n\
         if first_move {{\n    \
         plan.push(solver_core::trajectory::PointToPoint::new(START.into(), {}.into(), {}, {}, {})?)?;\n\
         }}\n\
         {build}",
        tr.smoothness.to_rust(),
        end.map(TypedF64).to_rust(),
        TypedF64(tr.t_start).to_rust(),
        TypedF64(tr.duration).to_rust(),
        tr.smoothness.to_rust(),
    );
    items.extend([
        Item::constant(
            "Solver settings.",
            "SETTINGS",
            "solver_core::SolverSettings",
            &scene.settings(),
        ),
        Item::constant(
            "Where the scene's move starts: the crane rests there at power-up (the virtual bus's drives,\n\
             so only the QEMU build reads it).",
            "START",
            "[f64; AXES]",
            &start.map(TypedF64),
        )
        .with_attribute("cfg_attr(not(feature = \"qemu\"), allow(dead_code))"),
        Item::function(
            "Builds the scene's inverse model at rest at t = 0, its move planned if\n\
             `first_move` (checked against the planner's rules when the firmware was built).",
            "inverse_model(first_move: bool) -> Result<Feedforward, solver_core::Error>",
            &body,
        ),
    ]);
    Ok(module(
        &format!(
            "Generated by build.rs from scene `{}`. Do not edit.",
            scene.name
        ),
        &items,
    ))
}
