//! A model's parameters as a scene's `[model]` gives them: solver-core's own types
//! (`CraneParams`, `Crane3dParams`, `DoublePendulumParams`, `MassOnCarParams`), read by
//! their own derives (solver-core's feature `serde`), not copied field by field.
//!
//! The file's keys are laid over the model's default at every depth before the type reads
//! them. A type's own default cannot do that for a nested table: the hook-and-load crane's
//! `[model.crane]` would take `CraneParams`'s default — the paper crane, whose shortest
//! rope is 3 m — for every crane key it leaves out, where the hook-and-load crane's is
//! 1.5 m (`DoublePendulumParams::EXAMPLE`).

use std::ops::Deref;

use serde::de::{self, DeserializeOwned, Deserializer};
use serde::{Deserialize, Serialize};

/// The parameters `P` of a scene's model: the keys the file sets, every other one
/// `P::default()`'s (the paper's or the example's, as each type says).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params<P>(pub P);

impl<P: Copy> Params<P> {
    /// The solver-core parameters.
    #[must_use]
    pub fn params(&self) -> P {
        self.0
    }
}

impl<P> Deref for Params<P> {
    type Target = P;
    fn deref(&self) -> &P {
        &self.0
    }
}

impl<'de, P: Default + Serialize + DeserializeOwned> Deserialize<'de> for Params<P> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        let keys = toml::Table::deserialize(deserializer)?;
        let mut table = toml::Table::try_from(P::default()).map_err(de::Error::custom)?;
        lay_over(&mut table, keys);
        // `P`'s derive refuses an unknown key (`deny_unknown_fields`) and a wrong type,
        // with serde's message, which names the key but not the tables it is in: the
        // path is tracked on the way down and put in front.
        serde_path_to_error::deserialize(toml::Value::Table(table))
            .map(Params)
            .map_err(|e| {
                let key = match e.path().to_string() {
                    // The table itself (no key below it).
                    path if path == "." => SECTION.to_string(),
                    path => format!("{SECTION}.{path}"),
                };
                de::Error::custom(format!("`{key}`: {}", e.inner().message()))
            })
    }
}

/// The scene's table the parameters are read from: a refusal names a key by its whole
/// path from the file's top, e.g. `model.workspace.l_mx`, in its reason. The refusal's
/// field stays `model`: the parser places an error by its position in the text, and
/// `[model]` is read whole before its `kind` picks the parameters' type, so the keys
/// reach this type without their positions.
const SECTION: &str = "model";

/// `keys` written into `base`: a table into the table of the same name, key by key; any
/// other value in place of what `base` has.
fn lay_over(base: &mut toml::Table, keys: toml::Table) {
    for (key, value) in keys {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(inner)), toml::Value::Table(value)) => lay_over(inner, value),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use solver_core::models::crane::CraneParams;
    use solver_core::models::double_pendulum_crane::DoublePendulumParams;
    use solver_core::models::mass_on_car::MassOnCarParams;

    use super::*;

    fn read<P: Default + Serialize + DeserializeOwned>(text: &str) -> Result<P, String> {
        toml::from_str::<Params<P>>(text)
            .map(|p| p.0)
            .map_err(|e| e.message().to_string())
    }

    /// A key left out is the model's default, also in a nested table: the hook-and-load
    /// crane's rope keeps its 1.5 m when the file sets its crane's mass or its longest rope.
    #[test]
    fn a_key_left_out_is_the_models_default_at_every_depth() {
        let example = DoublePendulumParams::EXAMPLE;
        assert_eq!(read::<DoublePendulumParams>(""), Ok(example));
        let p = read::<DoublePendulumParams>("[crane]\nm = 20.0\n[crane.workspace]\nl_max = 8.5")
            .unwrap();
        assert_eq!((p.crane.m, p.crane.workspace.l_max), (20.0, 8.5));
        assert_eq!(p.crane.workspace.l_min, 1.5);
        assert_eq!((p.hook_mass, p.sling), (example.hook_mass, example.sling));
        let p = read::<CraneParams>("tau1 = 0.04\n[workspace]\nx_min = 5.0").unwrap();
        let paper = CraneParams::PAPER;
        assert_eq!((p.tau1, p.workspace.x_min), (0.04, 5.0));
        assert_eq!(
            (p.tau2, p.workspace.x_max),
            (paper.tau2, paper.workspace.x_max)
        );
    }

    /// An unknown key, also in a nested table, and a wrong type are refused with serde's
    /// message after the key's whole path; the mass-on-car's angle is read in degrees.
    #[test]
    fn a_bad_key_or_value_is_refused_by_its_path_and_the_angle_is_in_degrees() {
        let e = read::<CraneParams>("[workspace]\nl_mx = 10.0").unwrap_err();
        assert!(
            e.starts_with("`model.workspace.l_mx`: unknown field `l_mx`, expected one of `x_min`"),
            "{e}"
        );
        let e = read::<DoublePendulumParams>("[crane.workspace]\nx_mni = 1.0").unwrap_err();
        assert!(
            e.starts_with("`model.crane.workspace.x_mni`: unknown field `x_mni`"),
            "{e}"
        );
        let e = read::<CraneParams>("x_min = 5.0").unwrap_err();
        assert!(e.starts_with("`model.x_min`: unknown field `x_min`"), "{e}");
        let e = read::<CraneParams>("m = \"x\"").unwrap_err();
        assert_eq!(e, "`model.m`: invalid type: string \"x\", expected f64");
        let e = read::<DoublePendulumParams>("[crane]\ntau1 = true").unwrap_err();
        assert_eq!(
            e,
            "`model.crane.tau1`: invalid type: boolean `true`, expected f64"
        );
        let p = read::<MassOnCarParams>("alpha_deg = 30.0").unwrap();
        assert_eq!(p.alpha, 30f64.to_radians());
    }
}
