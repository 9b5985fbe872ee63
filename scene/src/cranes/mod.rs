//! The cranes the firmware drives, one file each, and their one registration.
//!
//! A crane's file ([`planar`], [`spatial`], [`hook_and_load`]) is everything that crane
//! is: its type (its parameters in a newtype), what the controller knows of it
//! (`controller::crane::Crane`: drives, limits, reference state, command smoothness,
//! flat inverse) and the reference of each of its inverse models
//! (`controller::feedforward::CraneReference`), the plant the virtual bus runs for it
//! (`sim::simulated::Simulated`), and — on the host (feature `host`) — its
//! [`FirmwareCrane`] registration (how a scene names it, its parameters as the build
//! script writes them, its state feedback, its manual mode) with the list of its
//! formulations, made once with `crane_models!`. From that list follow the crane's
//! entries in `FirmwareScheme::every()` (what the panic proof proves), the model type
//! each names for the build scripts, whether it has a structured elimination, and the
//! code that builds it with the integrator a scheme names, on the host as on the
//! firmware. The `registry!` list (`registry.rs`) names the cranes: [`FirmwareModel`]
//! (which crane, which of its formulations) and the dispatch to a crane's type
//! ([`visit_crane`]) follow from it. Adding a crane is its file here and one line there
//! (with its model's `model_specs!` rows: docs/MODELS.md, section 4); a formulation, one
//! line in its crane's list.
//!
//! Without the feature `host` (the firmware, the panic proof) only the crane types and
//! their `no_std` impls are built: what the firmware links of its crane.

/// A crane's type, `Name(Params)` with `A` driven axes: a newtype over its models'
/// parameters, which exists only to carry the impls of other crates' traits (the orphan
/// rule forbids them on solver-core's parameter type). Its `.0` is what its models are
/// built from (`Model::new(crane.0, path)`): the registry's `crane_models!` and the
/// firmware's, the fuzzer's and the panic proof's generated code rely on it, so every
/// crane type is made here. `PATH` is the type's path as generated code names it (what
/// its [`FirmwareCrane::TYPE`] is); on the host the build scripts write a value as
/// `Name(Params { … })` (the parameters' own `ToRust`).
macro_rules! crane_type {
    ($(#[$doc:meta])* $name:ident($params:ty), $axes:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, Default, PartialEq)]
        pub struct $name(pub $params);

        impl $name {
            /// The type's path from outside the crate, as generated code names it.
            pub const PATH: &'static str = concat!("::", module_path!(), "::", stringify!($name));
        }

        #[cfg(feature = "host")]
        impl $crate::rust_source::ToRust for $name {
            fn to_rust(&self) -> String {
                format!(
                    "{}({})",
                    <$name as $crate::cranes::FirmwareCrane<$axes>>::TYPE,
                    self.0.to_rust()
                )
            }
        }
    };
}

pub mod hook_and_load;
pub mod planar;
pub mod spatial;

#[cfg(feature = "host")]
mod registry;
#[cfg(feature = "host")]
pub use registry::*;
#[cfg(feature = "host")]
pub(crate) use registry::{crane_models, integrators};
