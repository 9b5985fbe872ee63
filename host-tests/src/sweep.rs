//! Sweeps: a scene varied along axes (`--vary h=0.02|0.01,rho=2|3,scalar=f32|f64`),
//! the cross product run, one CSV row per configuration.

use scene::{JacobianSpec, NewtonSpec, ScalarSpec, Scene, SchemeSpec};

use crate::study::{jacobian_label, scheme_label, RunResult};

/// One axis of a sweep: a key and its values.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Axis {
    /// `h`, `rho`, `k`, `scheme`, `jacobian`, `formulation` or `scalar`.
    pub key: String,
    /// The values, as written.
    pub values: Vec<String>,
}

/// The keys a sweep can vary.
pub const KEYS: [&str; 7] = [
    "h",
    "rho",
    "k",
    "scheme",
    "jacobian",
    "formulation",
    "scalar",
];

/// Parses `key=v1|v2|…,key=…` (several `--vary` options may be given; [`cross`]
/// checks the axes together).
pub fn parse_vary(spec: &str) -> Result<Vec<Axis>, String> {
    spec.split(',')
        .filter(|part| !part.trim().is_empty())
        .map(|part| {
            let (key, values) = part
                .split_once('=')
                .ok_or_else(|| format!("`{part}`: expected key=value|value…"))?;
            let key = key.trim().to_string();
            if !KEYS.contains(&key.as_str()) {
                return Err(format!(
                    "`{key}` cannot be varied (one of {})",
                    KEYS.join(", ")
                ));
            }
            let values: Vec<String> = values
                .split('|')
                .map(|v| v.trim().to_string())
                .filter(|v| !v.is_empty())
                .collect();
            if values.is_empty() {
                return Err(format!("`{key}` has no values"));
            }
            Ok(Axis { key, values })
        })
        .collect()
}

/// The scene with one setting changed (not yet validated).
pub fn apply(scene: &Scene, key: &str, value: &str) -> Result<Scene, String> {
    let mut s = scene.clone();
    let bad = |what: &str| format!("{key}={value}: {what}");
    // The labels the CSV writes (`BDF4`, `Radau`, `J`, `Jt10`) are accepted as written.
    let lower = value.to_ascii_lowercase();
    let value = lower.as_str();
    match key {
        "h" => s.solver.h = value.parse().map_err(|_| bad("not a number"))?,
        "rho" => s.solver.rho_power = value.parse().map_err(|_| bad("not 0, 1, 2 or 3"))?,
        "k" => {
            s.solver.k = value.parse().map_err(|_| bad("not an integer"))?;
            s.solver.scheme = SchemeSpec::Bdf;
        }
        "scheme" => {
            s.solver.scheme = match value {
                "radau" => SchemeSpec::Radau,
                "bdf" => SchemeSpec::Bdf,
                v => match v.strip_prefix("bdf").and_then(|k| k.parse().ok()) {
                    Some(k) => {
                        s.solver.k = k;
                        SchemeSpec::Bdf
                    }
                    None => return Err(bad("expected radau, bdf or bdfK")),
                },
            }
        }
        "jacobian" => {
            // `transformed` is RADAU5's simplified Newton on the transformed stage
            // system (the scene's `jacobian = "exact"`, `newton = "transformed"`);
            // every other value is one of the paper's modes on the whole stage system,
            // so it resets `newton` (a radau5 scene varied to `jt10` must not keep it).
            let (mode, reinit, newton) = match value {
                "j" | "fd" => (JacobianSpec::Fd, None, NewtonSpec::Full),
                "exact" => (JacobianSpec::Exact, None, NewtonSpec::Full),
                "transformed" | "radau5" => (JacobianSpec::Exact, None, NewtonSpec::Transformed),
                "jt" | "broyden" => (JacobianSpec::Broyden, None, NewtonSpec::Full),
                v => match v.strip_prefix("jt").and_then(|n| n.parse::<u32>().ok()) {
                    Some(n) => (JacobianSpec::Broyden, Some(n), NewtonSpec::Full),
                    None => return Err(bad("expected j, exact, transformed, jt or jtN")),
                },
            };
            s.solver.jacobian = mode;
            s.solver.reinit_every = reinit;
            s.solver.newton = newton;
        }
        "formulation" => {
            // The same model's formulation by its name on this axis or its label, as
            // the scene's list of models registers them (the planar crane's subs, proj
            // and ext, the 3D and the hook-and-load crane's subs and ext, the
            // mass-on-car's direct one, Eqs. 31–34, and ext).
            s.model = s
                .model
                .with_formulation(value)
                .map_err(|e| bad(&e.to_string()))?;
        }
        "scalar" => {
            s.solver.scalar = match value {
                "f64" => ScalarSpec::F64,
                "f32" => ScalarSpec::F32,
                _ => return Err(bad("expected f32 or f64")),
            }
        }
        _ => return Err(format!("`{key}` cannot be varied")),
    }
    Ok(s)
}

/// A configuration of a sweep: the settings applied, and the scene they made.
pub type Configuration = (Vec<(String, String)>, Scene);

/// Every combination of the axes' values, with the settings that made it. Refuses
/// an axis given twice (the second would silently override the first) and `k`
/// beside `scheme` (`k` makes a scheme BDF: `scheme=radau` rows would run BDF).
pub fn cross(scene: &Scene, axes: &[Axis]) -> Result<Vec<Configuration>, String> {
    for (i, axis) in axes.iter().enumerate() {
        if axes[..i].iter().any(|a| a.key == axis.key) {
            return Err(format!(
                "`{}` is varied twice; give all its values in one axis (`{}=a|b|…`)",
                axis.key, axis.key
            ));
        }
    }
    if axes.iter().any(|a| a.key == "k") && axes.iter().any(|a| a.key == "scheme") {
        return Err(
            "`k` and `scheme` cannot both be varied (k only exists for BDF); write the schemes as `scheme=radau|bdf1|bdf4`"
                .into(),
        );
    }
    let mut out = vec![(Vec::new(), scene.clone())];
    for axis in axes {
        let mut next = Vec::with_capacity(out.len() * axis.values.len());
        for (settings, s) in &out {
            for v in &axis.values {
                let mut settings = settings.clone();
                settings.push((axis.key.clone(), v.clone()));
                next.push((settings, apply(s, &axis.key, v)?));
            }
        }
        out = next;
    }
    Ok(out)
}

/// The CSV columns of a sweep (documented in docs/RESULTS.md; a test pins them).
pub const CSV_HEADER: &str = "scene,formulation,scheme,jacobian,h,rho,scalar,steps,e_max,e_max_interior,iterations_mean,iterations_max,residual_evals_per_step,jacobian_evals,floor_steps,ns_per_step,outcome,failure";

/// One configuration's CSV row.
pub fn csv_row(scene: &Scene, r: &RunResult) -> String {
    let s = &scene.solver;
    let scalar = match s.scalar {
        ScalarSpec::F64 => "f64",
        ScalarSpec::F32 => "f32",
    };
    let failure = r.failure_text().replace(['"', ','], ";");
    format!(
        "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},\"{}\"",
        scene.name,
        scene.model.label(),
        scheme_label(scene),
        jacobian_label(scene),
        s.h,
        s.rho_power,
        scalar,
        r.steps,
        cell(r.e_global, |v| format!("{v:.4e}")),
        cell(r.e_interior, |v| format!("{v:.4e}")),
        cell(r.iterations_mean, |v| format!("{v:.3}")),
        r.iterations_max,
        cell(r.residual_evals_per_step, |v| format!("{v:.2}")),
        r.jacobian_evals,
        r.floor_steps,
        cell(r.ns_per_step, |v| format!("{v:.1}")),
        r.outcome.as_str(),
        failure
    )
}

/// A number's cell, empty when there is no number (not run, not finished, not timed):
/// a spreadsheet must not read `NaN` or a made-up `0` as a measurement.
fn cell(v: f64, format: impl Fn(f64) -> String) -> String {
    if v.is_finite() {
        format(v)
    } else {
        String::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vary_specs_parse() {
        let axes = parse_vary("h=0.02|0.01,rho=2|3,scalar=f32|f64").unwrap();
        assert_eq!(axes.len(), 3);
        assert_eq!(axes[0].values, vec!["0.02", "0.01"]);
        assert!(parse_vary("speed=3").is_err());
        assert!(parse_vary("h=").is_err());
        assert!(parse_vary("h").is_err());
    }

    fn paper_crane() -> Scene {
        Scene::load(&crate::paper::root().join("scenes/paper-crane.toml")).unwrap()
    }

    #[test]
    fn an_axis_given_twice_is_refused() {
        let axes = [parse_vary("h=0.01").unwrap(), parse_vary("h=0.02").unwrap()].concat();
        let e = cross(&paper_crane(), &axes).unwrap_err();
        assert!(e.contains("twice"), "{e}");
    }

    #[test]
    fn k_beside_scheme_is_refused() {
        let axes = parse_vary("scheme=radau|bdf,k=1|9").unwrap();
        let e = cross(&paper_crane(), &axes).unwrap_err();
        assert!(e.contains("`k` and `scheme`"), "{e}");
    }

    /// Every model's formulations, by their names and by the labels the CSV writes; a
    /// formulation another model has is refused by name.
    #[test]
    fn each_model_varies_over_its_own_formulations() {
        let load =
            |name: &str| Scene::load(&crate::paper::root().join("scenes").join(name)).unwrap();
        let labels = |scene: &Scene, values: &str| -> Vec<&'static str> {
            cross(
                scene,
                &parse_vary(&format!("formulation={values}")).unwrap(),
            )
            .unwrap()
            .iter()
            .map(|(_, s)| s.model.label())
            .collect()
        };
        let planar = paper_crane();
        assert_eq!(labels(&planar, "subs|proj|ext"), ["subs", "proj", "ext"]);
        let spatial = load("crane3d-diagonal.toml");
        assert_eq!(
            labels(&spatial, "subs|ext|3d-ext"),
            ["3d-subs", "3d-ext", "3d-ext"]
        );
        let car = load("mass-on-car.toml");
        assert_eq!(
            labels(&car, "direct|ext|mass-on-car"),
            ["mass-on-car", "mass-on-car-ext", "mass-on-car"]
        );
        for (scene, value) in [(&spatial, "proj"), (&car, "subs"), (&planar, "direct")] {
            let e = apply(scene, "formulation", value).unwrap_err();
            assert!(e.contains(value), "{e}");
        }
    }

    #[test]
    fn transformed_is_radau5_and_labelled_so() {
        let axes = parse_vary("scheme=radau,jacobian=transformed|exact|Jt10").unwrap();
        let configs = cross(&paper_crane(), &axes).unwrap();
        let labels: Vec<String> = configs.iter().map(|(_, s)| jacobian_label(s)).collect();
        assert_eq!(labels, ["transformed", "exact", "Jt10"]);
        assert_eq!(configs[0].1.solver.newton, NewtonSpec::Transformed);
        assert_eq!(
            configs[0].1.settings().jacobian,
            solver_core::JacobianMode::Transformed
        );
        // Back to a paper mode from a radau5 scene: the transformed Newton is dropped.
        let radau5 =
            Scene::load(&crate::paper::root().join("scenes/paper-crane-radau5.toml")).unwrap();
        let back = apply(&radau5, "jacobian", "exact").unwrap();
        assert_eq!(back.solver.newton, NewtonSpec::Full);
        assert_eq!(jacobian_label(&radau5), "transformed");
    }

    #[test]
    fn the_labels_the_csv_writes_are_accepted() {
        let axes = parse_vary("jacobian=J|Jt10|exact,scheme=BDF4|Radau").unwrap();
        let configs = cross(&paper_crane(), &axes).unwrap();
        let labels: Vec<String> = configs
            .iter()
            .map(|(_, s)| format!("{} {}", scheme_label(s), jacobian_label(s)))
            .collect();
        assert_eq!(
            labels,
            [
                "BDF4 J",
                "Radau J",
                "BDF4 Jt10",
                "Radau Jt10",
                "BDF4 exact",
                "Radau exact"
            ]
        );
    }
}
