//! Values as Rust source: what the firmware's build script writes into its generated
//! scene module (`firmware/build.rs`, and the fuzzer's `fuzz/build.rs`). One trait,
//! [`ToRust`], implemented once per type the scripts write; a struct is written field by
//! field from its own definition (`struct_to_rust!` destructures it without `..`, so a
//! field added to the controller's or solver-core's type does not compile until it is
//! written here too), never by a format string that lists the fields by hand. A crane's
//! parameter types are written by a `struct_to_rust!` row in the crane's own file
//! (`crate::cranes`); the types every crane shares, here.
//!
//! An `f64` is written with `{:?}`, Rust's shortest representation that reads back to
//! the same bits (`1.0`, `1e-300`, `0.1`): the firmware's constants are the host's,
//! exactly.

use controller::commissioning::{
    DriveSetup, InclinometerSetup, LateralAxis, NodeSetup, OperationMode,
};
use controller::drive::Drive;
use controller::feedback::{Config as FeedbackConfig, Weights};
use controller::motion::MotionWindows;
use controller::node::Role;
use controller::rope::InclinometerLag;
use controller::setpoint::AxisLimits;
use solver_core::operator::{AxisSettings, Settings};
use solver_core::{JacobianMode, NewtonSettings, SolverSettings};

/// A value as a Rust constant expression.
pub trait ToRust {
    /// The expression, e.g. `1.5`, `[1.0, 2.0]`, `controller::rope::InclinometerLag { delay: 0, filter: 0.0 }`.
    fn to_rust(&self) -> String;
}

impl ToRust for f64 {
    /// `{:?}`: the shortest decimal that reads back to the same `f64`, always with a `.`
    /// or an exponent (`1.0`, never `1`), so it is a float literal. Not finite (the
    /// scene checks refuse such values before anything is written, but the writer is
    /// total): `f64`'s constants, as `{:?}`'s `NaN` and `inf` are no Rust.
    fn to_rust(&self) -> String {
        if self.is_nan() {
            "f64::NAN".to_string()
        } else if self.is_infinite() {
            if *self > 0.0 {
                "f64::INFINITY"
            } else {
                "f64::NEG_INFINITY"
            }
            .to_string()
        } else {
            format!("{self:?}")
        }
    }
}

/// An `f64` written with its type suffix (`12.0_f64`), for an expression whose type the
/// generated code does not otherwise pin (`[START].into()`, a generic constructor's
/// arguments). Finite values only (a scene's trajectory is checked finite).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TypedF64(pub f64);

impl ToRust for TypedF64 {
    fn to_rust(&self) -> String {
        format!("{}_f64", self.0.to_rust())
    }
}

/// Integers and `bool` as their literal.
macro_rules! display_to_rust {
    ($($t:ty),+) => {
        $(impl ToRust for $t {
            fn to_rust(&self) -> String {
                self.to_string()
            }
        })+
    };
}
display_to_rust!(u8, u16, u32, i16, usize, bool);

impl ToRust for () {
    /// A crane without manual mode has `()` as its generator's settings.
    fn to_rust(&self) -> String {
        "()".to_string()
    }
}

impl<T: ToRust> ToRust for Option<T> {
    fn to_rust(&self) -> String {
        match self {
            None => "None".to_string(),
            Some(v) => format!("Some({})", v.to_rust()),
        }
    }
}

impl<T: ToRust, const N: usize> ToRust for [T; N] {
    fn to_rust(&self) -> String {
        format!("[{}]", list(self.iter().map(ToRust::to_rust)))
    }
}

impl<T: ToRust, U: ToRust> ToRust for (T, U) {
    fn to_rust(&self) -> String {
        format!("({}, {})", self.0.to_rust(), self.1.to_rust())
    }
}

fn list(items: impl Iterator<Item = String>) -> String {
    items.collect::<Vec<_>>().join(", ")
}

/// `path { field: value, … }`, then `..rest` if given (struct update syntax).
#[must_use]
pub fn struct_literal(path: &str, fields: &[(&str, &dyn ToRust)], rest: Option<&str>) -> String {
    let mut items: Vec<String> = fields
        .iter()
        .map(|(name, value)| format!("{name}: {}", value.to_rust()))
        .collect();
    if let Some(rest) = rest {
        items.push(format!("..{rest}"));
    }
    format!("{path} {{ {} }}", items.join(", "))
}

/// `impl ToRust` for a struct from all of its fields, in declaration order (destructured
/// without `..`: a field left out does not compile), written as the struct's path in the
/// generated code (`= path`, any `&str` expression: a crane's file names its
/// `FirmwareCrane::TYPE`). A crane's parameter types have their row in the crane's own
/// file (`crate::cranes`), the types every crane shares theirs here.
macro_rules! struct_to_rust {
    (impl<const $n:ident: usize> $ty:ty { $($field:ident),+ $(,)? } = $path:expr) => {
        impl<const $n: usize> $crate::rust_source::ToRust for $ty {
            fn to_rust(&self) -> String {
                let Self { $($field),+ } = self;
                $crate::rust_source::struct_literal(
                    $path,
                    &[$((stringify!($field), $field as &dyn $crate::rust_source::ToRust)),+],
                    None,
                )
            }
        }
    };
    ($ty:ty { $($field:ident),+ $(,)? } = $path:expr) => {
        impl $crate::rust_source::ToRust for $ty {
            fn to_rust(&self) -> String {
                let Self { $($field),+ } = self;
                $crate::rust_source::struct_literal(
                    $path,
                    &[$((stringify!($field), $field as &dyn $crate::rust_source::ToRust)),+],
                    None,
                )
            }
        }
    };
}
pub(crate) use struct_to_rust;

// The state feedback (`controller::feedback`).
struct_to_rust!(
    FeedbackConfig {
        weights,
        g,
        tau1,
        tau2,
        h,
        max_angle,
        max_innovation,
        max_bad_angle_cycles,
        max_frozen_cycles,
        frozen_motion,
        held_allowance,
        rest_position,
        rest_swing,
        rest_hysteresis,
        offset_dead_band,
        offset_step,
        max_offset,
        offset_cycles,
        inclinometer,
    } = "controller::feedback::Config"
);
struct_to_rust!(
    Weights {
        load_position,
        trolley_position,
        swing_velocity,
        trolley_correction,
        rope_position,
        winch_correction,
        drive_disturbance,
        swing_disturbance,
        drive_offset,
        position_noise,
        angle_noise,
        rest_load_position,
        rest_trolley_position,
        rest_swing_velocity,
        rest_load_velocity,
        rest_angle_noise,
    } = "controller::feedback::Weights"
);
struct_to_rust!(InclinometerLag { delay, filter } = "controller::rope::InclinometerLag");

// The commissioning (`controller::commissioning`, `controller::motion`).
struct_to_rust!(
    DriveSetup {
        node,
        mode,
        heartbeat_ms,
        controller_timeout_ms,
        quick_stop_option,
        abort_connection_option,
        quick_stop_deceleration,
        max_velocity,
        velocity_unit,
        profile_ramp,
        position_scale,
        position_offset,
        motion,
    } = "controller::commissioning::DriveSetup"
);
struct_to_rust!(
    MotionWindows {
        standstill,
        standstill_delay_ms,
        following,
        following_drift,
        velocity,
        following_time_ms,
        in_place,
    } = "controller::motion::MotionWindows"
);
struct_to_rust!(
    AxisLimits {
        max_velocity,
        max_acceleration
    } = "controller::setpoint::AxisLimits"
);
struct_to_rust!(
    InclinometerSetup {
        node,
        resolution,
        heartbeat_ms,
        sign,
        offset_deg,
        lateral,
    } = "controller::commissioning::InclinometerSetup"
);
struct_to_rust!(LateralAxis { sign, offset_deg } = "controller::commissioning::LateralAxis");

impl ToRust for OperationMode {
    fn to_rust(&self) -> String {
        let variant = match self {
            OperationMode::CyclicSynchronousVelocity => "CyclicSynchronousVelocity",
            OperationMode::ProfileVelocity => "ProfileVelocity",
        };
        format!("controller::commissioning::OperationMode::{variant}")
    }
}

impl ToRust for Drive {
    fn to_rust(&self) -> String {
        let variant = match self {
            Drive::Trolley => "Trolley",
            Drive::Winch => "Winch",
            Drive::Bridge => "Bridge",
        };
        format!("controller::drive::Drive::{variant}")
    }
}

impl ToRust for Role {
    fn to_rust(&self) -> String {
        let variant = match self {
            Role::Manager => "Manager",
            Role::Slave => "Slave",
        };
        format!("controller::node::Role::{variant}")
    }
}

impl ToRust for NodeSetup {
    fn to_rust(&self) -> String {
        match self {
            NodeSetup::Drive(axis, d) => format!(
                "controller::commissioning::NodeSetup::Drive({}, {})",
                axis.to_rust(),
                d.to_rust()
            ),
            NodeSetup::Inclinometer(i) => format!(
                "controller::commissioning::NodeSetup::Inclinometer({})",
                i.to_rust()
            ),
        }
    }
}

// Manual mode's generator (`solver_core::operator`).
struct_to_rust!(impl<const NH: usize> Settings<NH> {
    h, g, horizontal, hoist, boxes, hoist_boxes, lowering_allowance, robust, deadband,
    entry_blend,
} = "solver_core::operator::Settings");
struct_to_rust!(
    AxisSettings {
        speed,
        acceleration,
        range
    } = "solver_core::operator::AxisSettings"
);

// The solver's settings.
struct_to_rust!(
    SolverSettings {
        h,
        jacobian,
        scaling_power,
        newton,
    } = "solver_core::SolverSettings"
);
struct_to_rust!(
    NewtonSettings {
        max_iterations,
        rtol,
        atol,
        stall_ratio,
        stall_limit,
        accept_unconverged,
        broyden_refresh,
    } = "solver_core::NewtonSettings"
);

impl ToRust for JacobianMode {
    fn to_rust(&self) -> String {
        match self {
            JacobianMode::FiniteDifference => "solver_core::JacobianMode::FiniteDifference".into(),
            JacobianMode::Exact => "solver_core::JacobianMode::Exact".into(),
            JacobianMode::Transformed => "solver_core::JacobianMode::Transformed".into(),
            JacobianMode::Broyden { reinit_every } => struct_literal(
                "solver_core::JacobianMode::Broyden",
                &[("reinit_every", reinit_every)],
                None,
            ),
        }
    }
}

/// A string as its Rust literal (`{:?}`: quoted, escaped as Rust reads it back).
impl ToRust for &str {
    fn to_rust(&self) -> String {
        format!("{self:?}")
    }
}

/// Rust source already written, used as it is: an expression or a type the crane's
/// registry or another writer spells (`FirmwareCrane::FEEDBACK_NEW`,
/// `firmware::config_source`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Code<'a>(pub &'a str);

impl ToRust for Code<'_> {
    fn to_rust(&self) -> String {
        self.0.to_string()
    }
}

/// One item of a generated module — a constant, a type alias or a function — with its
/// doc comment (a `///` line per line of `doc`) and its attributes: the build scripts'
/// modules are lists of these ([`Item::source`]), not format strings that spell the
/// item's syntax each time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Item<'a> {
    doc: &'a str,
    attributes: Vec<&'a str>,
    declaration: String,
}

impl<'a> Item<'a> {
    /// `pub const NAME: TY = value;`
    #[must_use]
    pub fn constant(doc: &'a str, name: &str, ty: &str, value: &dyn ToRust) -> Self {
        Self::new(
            doc,
            format!("pub const {name}: {ty} = {};", value.to_rust()),
        )
    }

    /// `pub type NAME = TY;`
    #[must_use]
    pub fn type_alias(doc: &'a str, name: &str, ty: &str) -> Self {
        Self::new(doc, format!("pub type {name} = {ty};"))
    }

    /// `pub fn SIGNATURE { body }`, each line of `body` indented by four spaces.
    #[must_use]
    pub fn function(doc: &'a str, signature: &str, body: &str) -> Self {
        let body: Vec<String> = body.lines().map(|l| format!("    {l}")).collect();
        Self::new(
            doc,
            format!("pub fn {signature} {{\n{}\n}}", body.join("\n")),
        )
    }

    /// The item with the attribute `#[attribute]` (after those it has).
    #[must_use]
    pub fn with_attribute(mut self, attribute: &'a str) -> Self {
        self.attributes.push(attribute);
        self
    }

    fn new(doc: &'a str, declaration: String) -> Self {
        Self {
            doc,
            attributes: Vec::new(),
            declaration,
        }
    }

    /// The item's source: its doc comment, its attributes and its declaration, each on
    /// its own line, the last line ended.
    #[must_use]
    pub fn source(&self) -> String {
        let mut lines: Vec<String> = self.doc.lines().map(|l| format!("/// {l}")).collect();
        lines.extend(self.attributes.iter().map(|a| format!("#[{a}]")));
        lines.push(self.declaration.clone());
        lines.join("\n") + "\n"
    }
}

/// The source of a module of `items`, after its `header` line (a `//` comment).
#[must_use]
pub fn module(header: &str, items: &[Item<'_>]) -> String {
    let mut source = format!("// {header}\n");
    for item in items {
        source.push_str(&item.source());
    }
    source
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn an_f64_reads_back_to_the_same_bits() {
        let awkward = [
            0.1,
            0.1 + 0.2,
            1.0 / 3.0,
            -0.0,
            1.0,
            1e16,
            1e-300,
            f64::MIN_POSITIVE,
            f64::MIN_POSITIVE / 3.0, // subnormal
            f64::from_bits(1),       // the smallest subnormal
            f64::MAX,
            f64::MIN,
            f64::EPSILON,
            core::f64::consts::PI,
            9.81,
            123_456_789.123_456_79,
            0.00175,
        ];
        for x in awkward {
            let text = x.to_rust();
            // A float literal: a `.` or an exponent, never an integer's digits alone.
            assert!(text.contains('.') || text.contains('e'), "{text}");
            let back: f64 = text.parse().unwrap();
            assert_eq!(back.to_bits(), x.to_bits(), "{x:e} written as {text}");
        }
        assert_eq!(
            [f64::NAN, f64::INFINITY, f64::NEG_INFINITY].to_rust(),
            "[f64::NAN, f64::INFINITY, f64::NEG_INFINITY]"
        );
    }

    #[test]
    fn compound_values_are_written_as_rust() {
        assert_eq!(3u32.to_rust(), "3");
        assert_eq!((-6i16).to_rust(), "-6");
        assert_eq!(true.to_rust(), "true");
        assert_eq!(Some(5u32).to_rust(), "Some(5)");
        assert_eq!(None::<u32>.to_rust(), "None");
        assert_eq!([1.0, 2.5].to_rust(), "[1.0, 2.5]");
        assert_eq!((0.5, 9.0).to_rust(), "(0.5, 9.0)");
        assert_eq!(
            [TypedF64(12.0), TypedF64(0.1)].to_rust(),
            "[12.0_f64, 0.1_f64]"
        );
        assert_eq!(
            JacobianMode::Broyden {
                reinit_every: Some(10)
            }
            .to_rust(),
            "solver_core::JacobianMode::Broyden { reinit_every: Some(10) }"
        );
        assert_eq!(
            InclinometerLag {
                delay: 2,
                filter: 0.05
            }
            .to_rust(),
            "controller::rope::InclinometerLag { delay: 2, filter: 0.05 }"
        );
        assert_eq!(
            struct_literal("a::B", &[("x", &1u8), ("y", &0.5)], Some("a::B::DEFAULT")),
            "a::B { x: 1, y: 0.5, ..a::B::DEFAULT }"
        );
        assert_eq!(
            Some(NodeSetup::Inclinometer(InclinometerSetup {
                lateral: Some(LateralAxis {
                    sign: -1.0,
                    offset_deg: 0.25
                }),
                ..InclinometerSetup::STOCK
            }))
            .to_rust(),
            format!(
                "Some(controller::commissioning::NodeSetup::Inclinometer(controller::commissioning::InclinometerSetup {{ node: {}, resolution: {}, heartbeat_ms: {}, sign: {:?}, offset_deg: {:?}, lateral: Some(controller::commissioning::LateralAxis {{ sign: -1.0, offset_deg: 0.25 }}) }}))",
                InclinometerSetup::STOCK.node,
                InclinometerSetup::STOCK.resolution,
                InclinometerSetup::STOCK.heartbeat_ms,
                InclinometerSetup::STOCK.sign,
                InclinometerSetup::STOCK.offset_deg
            )
        );
    }

    /// A module is its header and its items, each with its doc lines and attributes; a
    /// function's body is indented, a string written as its literal.
    #[test]
    fn a_module_is_its_items() {
        let items = [
            Item::constant("Its name.", "NAME", "&str", &"a \"b\""),
            Item::constant("Two lines\nof doc.", "X", "[f64; 2]", &[1.0, 0.5])
                .with_attribute("allow(dead_code)"),
            Item::type_alias("The model.", "Model", "a::B<C>"),
            Item::function("Builds it.", "f() -> u8", "let x = 1;\nx + 1"),
            Item::constant("Verbatim.", "Y", "u8", &Code("X as u8")),
        ];
        assert_eq!(
            module("Generated. Do not edit.", &items),
            "// Generated. Do not edit.\n\
             /// Its name.\npub const NAME: &str = \"a \\\"b\\\"\";\n\
             /// Two lines\n/// of doc.\n#[allow(dead_code)]\npub const X: [f64; 2] = [1.0, 0.5];\n\
             /// The model.\npub type Model = a::B<C>;\n\
             /// Builds it.\npub fn f() -> u8 {\n    let x = 1;\n    x + 1\n}\n\
             /// Verbatim.\npub const Y: u8 = X as u8;\n"
        );
    }

    /// Every field of the feedback's configuration is written once, by its name, with
    /// its value: the names the controller's type has (a field added there does not
    /// compile here until it is written), each value read back exactly.
    #[test]
    fn the_feedback_configuration_is_written_field_by_field() {
        let text = FeedbackConfig::PAPER.to_rust();
        let w = Weights::DEFAULT;
        for (name, value) in [
            ("load_position", w.load_position),
            ("rest_angle_noise", w.rest_angle_noise),
            ("g", 9.81),
            ("h", 0.01),
            ("rest_swing", FeedbackConfig::PAPER.rest_swing),
            ("offset_dead_band", FeedbackConfig::PAPER.offset_dead_band),
        ] {
            let written = format!(" {name}: {}", value.to_rust());
            assert_eq!(text.matches(&written).count(), 1, "{written} in {text}");
        }
        assert!(text.starts_with("controller::feedback::Config { weights: controller::feedback::Weights { load_position: "));
        assert!(text.ends_with(
            ", inclinometer: controller::rope::InclinometerLag { delay: 0, filter: 0.0 } }"
        ));
        // The configuration's 19 fields (the weights and the lag among them), the
        // weights' 16, the lag's 2.
        assert_eq!(text.matches(": ").count(), 19 + 16 + 2, "{text}");
    }
}
