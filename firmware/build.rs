//! Picks the board's memory map and turns the scene chosen at build time into Rust.
//!
//! `SCENE=path/to/scene.toml` (default: `scenes/paper-crane.toml`) names one model,
//! its parameters, the trajectory and the solver settings. The generated `scene.rs`
//! declares exactly that model and integrator type, so the firmware links only the
//! model its scene needs. A scene the firmware cannot run (not a crane, invalid) stops
//! the build with the scene checker's message.

use std::env;
use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

use scene::commissioning::CommissioningFile;
use scene::dispatch::{firmware, Axes, FirmwareCrane, FirmwareCraneVisitor, ReferenceOf};
use scene::firmware::FirmwareScene;
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
        .unwrap_or_else(|_| root.join("scenes/paper-crane.toml"));
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

    fn visit<K: FirmwareCrane<A>, const A: usize>(self, setup: FirmwareScene<K, A>) -> Self::Output
    where
        Axes<A>: ReferenceOf,
    {
        crane_module(self.scene, &setup)
    }
}

/// The Rust of the scene module for crane `K` with `A` driven axes.
fn crane_module<K: FirmwareCrane<A>, const A: usize>(
    scene: &Scene,
    setup: &FirmwareScene<K, A>,
) -> Result<String, String>
where
    Axes<A>: ReferenceOf,
{
    // The model, the scheme and the Newton strategy are types, so the firmware links
    // only the ones its scene names (`scene::dispatch::FirmwareScheme`, which the host's
    // run of the firmware builds too).
    let types = setup.scheme.rust();
    let s = &scene.solver;
    let settings = scene.settings();
    let transformed = s.newton == scene::NewtonSpec::Transformed;
    let jacobian = match (s.jacobian, s.reinit_every) {
        _ if transformed => "solver_core::JacobianMode::Transformed".to_string(),
        (JacobianSpec::Fd, _) => "solver_core::JacobianMode::FiniteDifference".to_string(),
        (JacobianSpec::Exact, _) => "solver_core::JacobianMode::Exact".to_string(),
        (JacobianSpec::Broyden, r) => {
            format!("solver_core::JacobianMode::Broyden {{ reinit_every: {r:?} }}")
        }
    };
    let jacobian_label = match (s.jacobian, s.reinit_every) {
        _ if transformed => "RADAU5".to_string(),
        (JacobianSpec::Fd, _) => "J".to_string(),
        (JacobianSpec::Exact, _) => "exact".to_string(),
        (JacobianSpec::Broyden, None) => "J~".to_string(),
        (JacobianSpec::Broyden, Some(m)) => format!("J~{m}"),
    };
    let tr = &scene.trajectory;
    let nw = settings.newton;
    let mut c = String::new();
    let _ = writeln!(
        c,
        "// Generated by build.rs from scene `{}`. Do not edit.",
        scene.name
    );
    let _ = writeln!(
        c,
        "/// Scene name.\npub const NAME: &str = {:?};",
        scene.name
    );
    let _ = writeln!(c, "/// Scheme and Jacobian, for logs.\npub const SOLVER: &str = \"{} {jacobian_label} h = {} s\";", types.scheme, s.h);
    let _ = writeln!(
        c,
        "/// Cycles the scene's move takes (to its `t_end`).\npub const CYCLES: u32 = {};",
        setup.cycles
    );
    let _ = writeln!(
        c,
        "/// Cycle time, ms.\npub const PERIOD_MS: u32 = {};",
        setup.config.period_ms
    );
    let _ = writeln!(
        c,
        "/// The controller's configuration: the scene's cycle and the commissioning file.\npub const CONFIG: controller::Config = {};",
        scene::firmware::config_source(&setup.config)?
    );
    let _ = writeln!(
        c,
        "/// The crane's driven axes.\npub const AXES: usize = {A};\n/// The crane.\npub type Crane = {};",
        K::TYPE
    );
    let _ = writeln!(
        c,
        "/// The crane model, driven by a plan that changes on command.\npub type Model = {};",
        types.model
    );
    let _ = writeln!(
        c,
        "/// The integrator.\npub type Integrator = {};",
        types.integrator
    );
    let stub = env::var_os("CARGO_FEATURE_STUB_INVERSE_MODEL").is_some();
    if stub {
        let _ = writeln!(c, "/// The inverse model stubbed out (feature `stub-inverse-model`).\npub type Feedforward = Stub;");
    } else {
        let _ = writeln!(c, "/// Model and integrator.\npub type Feedforward = controller::InverseModel<Model, Integrator, f64, {{ {} }}>;", types.unknowns);
    }
    // The state feedback is linked only when the scene closes the loop.
    match &setup.feedback {
        Some(config) => {
            let _ = writeln!(
                c,
                "/// Between the inverse model and the drives: the state feedback (Fig. 1).\npub type Correction = {};\n/// Its configuration: the scene's `[feedback]`.\npub const FEEDBACK: controller::feedback::Config = {};\n/// The feedback, its gains designed from the scene's weights.\npub fn correction() -> Result<Correction, controller::feedback::DesignError> {{\n    {}\n}}",
                K::FEEDBACK_TYPE,
                scene::feedback::FeedbackSpec::source(config),
                K::FEEDBACK_NEW
            );
        }
        None => {
            let _ = writeln!(
                c,
                "/// Between the inverse model and the drives: nothing (feedforward only).\npub type Correction = controller::feedback::NoFeedback;\n/// No feedback to design.\npub fn correction() -> Result<Correction, controller::feedback::DesignError> {{\n    Ok(controller::feedback::NoFeedback)\n}}"
            );
        }
    }
    let _ = writeln!(
        c,
        "/// Crane parameters.\npub const PARAMS: Crane = {};",
        setup.params.source()
    );
    let limits = K::LIMITS
        .map(|l| {
            format!(
                "controller::setpoint::AxisLimits {{ max_velocity: {:?}, max_acceleration: {:?} }}",
                l.max_velocity, l.max_acceleration
            )
        })
        .join(", ");
    let _ = writeln!(
        c,
        "/// The planner of moves on command: this crane, its lab drives' limits (which the\n/// set-point gate enforces too).\npub const PLANNER: controller::planner::Planner<Crane, AXES> = controller::planner::Planner::with_axes(PARAMS, [{limits}]);"
    );
    let _ = writeln!(
        c,
        "/// Solver settings.\npub const SETTINGS: solver_core::SolverSettings = solver_core::SolverSettings {{ h: {:?}, jacobian: {jacobian}, scaling_power: {}, newton: solver_core::NewtonSettings {{ max_iterations: {}, rtol: {:?}, atol: {:?}, stall_ratio: {:?}, stall_limit: {:?}, accept_unconverged: false, broyden_refresh: true }} }};",
        settings.h, settings.scaling_power, nw.max_iterations, nw.rtol, nw.atol, nw.stall_ratio, nw.stall_limit
    );
    let v = |x: [f64; A]| {
        let items = x.map(|a| format!("{a:?}_f64")).join(", ");
        format!("[{items}]")
    };
    let (start, end): ([f64; A], [f64; A]) = (
        setup.first_move.start().into(),
        setup.first_move.end().into(),
    );
    let _ = writeln!(
        c,
        "/// Where the scene's move starts: the crane rests there at power-up (the virtual bus's drives,\n/// so only the QEMU build reads it).\n#[cfg_attr(not(feature = \"qemu\"), allow(dead_code))]\npub const START: [f64; AXES] = {};",
        v(start)
    );
    let _ = writeln!(
        c,
        "/// Builds the scene's inverse model at rest at t = 0, its move planned if\n/// `first_move` (checked against the planner's rules when the firmware was built).\npub fn inverse_model(first_move: bool) -> Result<Feedforward, solver_core::Error> {{\n    let mut plan = controller::feedforward::command_plan(START, {})?;\n    if first_move {{\n        plan.push(solver_core::trajectory::PointToPoint::new(START.into(), {}.into(), {:?}_f64, {:?}_f64, {})?)?;\n    }}\n    {}\n}}",
        tr.smoothness,
        v(end),
        tr.t_start,
        tr.duration,
        tr.smoothness,
        if stub {
            "Ok(Stub { plan, t: 0.0 })".to_string()
        } else {
            format!("let model = Model::new(PARAMS, plan)?;\n    let integrator = {}?;\n    Ok(controller::InverseModel::new(model, integrator))", types.new)
        }
    );
    Ok(c)
}
