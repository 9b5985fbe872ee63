//! The scene's state feedback, `[feedback]`: with the section the firmware links the
//! state feedback of Fig. 1 (`controller::feedback`) and commissions the inclinometer
//! of the commissioning file; without it, the inverse model alone (model only what a
//! scene requires). Every field has the study's value as default
//! (`controller::feedback::Config::PAPER`, docs/RESULTS.md):
//!
//! ```toml
//! [feedback]
//! # LQR weights, Bryson's rule: the acceptable value of each quantity.
//! load_position = 0.02        # m, horizontal load position x + l φ
//! trolley_position = 0.5      # m
//! swing_velocity = 0.05       # m/s, l φ̇
//! trolley_correction = 0.15   # m/s, δu1
//! rope_position = 0.005       # m
//! winch_correction = 0.05     # m/s, δu2
//! # Kalman observer: what disturbs and how well it is measured (1σ).
//! drive_disturbance = 0.5     # m/s², friction and lag errors
//! swing_disturbance = 0.1     # rad/s², wind
//! drive_offset = 0.3          # m/s per √s: how fast the drive's velocity offset wanders
//! position_noise = 5e-4       # m
//! angle_noise = 5e-4          # rad
//! # At rest (the reference still) the trolley's gains are designed from these: the
//! # swing damped fast, weighing the load's velocity over the rail ẋ + l φ̇ too.
//! rest_load_position = 0.03   # m
//! rest_trolley_position = 0.1 # m
//! rest_swing_velocity = 0.1   # m/s, l φ̇
//! rest_load_velocity = 0.03   # m/s, ẋ + l φ̇
//! rest_angle_noise = 3e-3     # rad, the angle's noise the observer at rest is designed for
//! # The degraded-mode rule (docs/COMMANDS.md).
//! max_angle = 0.35            # rad: beyond, the angle is implausible
//! max_innovation = 0.035      # rad: further from the prediction, implausible
//! bridged_cycles = 3          # bad angles bridged before the angle is no longer read
//! frozen_cycles = 3           # the same value this long …
//! frozen_motion = 0.00175     # … while the crane's motion moved it this much (rad): stuck
//! held_allowance = 0.02       # m/s: how much harder an unchanged reading may push
//! # At rest on the target the feedback lets go (set points zero) …
//! rest_position = 0.02        # m: load within this of its target (x and rope) …
//! rest_swing = 0.00105        # rad: … and swinging less (0.06°) for 0.1 s …
//! rest_hysteresis = 1.65      # … and takes hold again at this times either (0.0995°)
//! # The inclinometer's offset check (controller::zero).
//! offset_dead_band = 0.00175  # rad: an offset within this is left in the reading
//! offset_step = 0.0044        # rad: a reading this far from the prediction is a step of the zero
//! max_offset = 0.0087         # rad: an offset beyond this …
//! offset_cycles = 500         # … for this many cycles is announced (EMCY 0xFF20 reason 5)
//! ```
//!
//! The gains are designed from the weights at start-up (`Gains::design`), for the
//! scene's crane (g, τ1, τ2 of Tab. 3) and cycle h; the scene check designs them once
//! on the host, so a set of weights whose Riccati iteration does not converge is refused
//! here, not on the crane.

use controller::feedback::{Config, Gains, Weights};
use controller::rope::InclinometerLag;
use solver_core::models::crane::CraneParams;
use toml::de::DeValue;
use toml::Spanned;

use crate::{key_at, refuse, side_by_side, SceneError};

/// The `[feedback]` table (`section`, spans into the scene's `text`) read into the
/// controller's own [`Config`]: its keys are [`Weights`]' and [`Config`]'s side by side
/// (Config's g, τ1, τ2, h and the inclinometer's lag are not the file's), each read by
/// its own type ([`crate::side_by_side`]).
pub(crate) fn section<'i>(text: &str, section: Spanned<DeValue<'i>>) -> Result<Config, SceneError> {
    let span = section.span();
    let table = match section.into_inner() {
        DeValue::Table(table) => table,
        other => {
            return Err(refuse(
                &key_at(text, span.start),
                format!("invalid type: {}, expected a table", other.type_str()),
            ))
        }
    };
    let (weights, config) = side_by_side::split::<Weights, Config>(text, table)?;
    let weights: Weights = side_by_side::read(text, span.clone(), weights)?;
    let config: Config = side_by_side::read(text, span, config)?;
    Ok(Config { weights, ..config })
}

/// The feedback's configuration for the crane `params` cycling every `h` s from the
/// scene's `[feedback]` (`spec`, as `Scene::parse` read it), or the first field that cannot
/// work, named with the reason.
pub fn config(spec: &Config, params: &CraneParams, h: f64) -> Result<Config, SceneError> {
    let w = &spec.weights;
    let positive = [
        ("load_position", w.load_position),
        ("trolley_position", w.trolley_position),
        ("swing_velocity", w.swing_velocity),
        ("trolley_correction", w.trolley_correction),
        ("rope_position", w.rope_position),
        ("winch_correction", w.winch_correction),
        ("drive_disturbance", w.drive_disturbance),
        ("swing_disturbance", w.swing_disturbance),
        ("drive_offset", w.drive_offset),
        ("position_noise", w.position_noise),
        ("angle_noise", w.angle_noise),
        ("rest_load_position", w.rest_load_position),
        ("rest_trolley_position", w.rest_trolley_position),
        ("rest_swing_velocity", w.rest_swing_velocity),
        ("rest_load_velocity", w.rest_load_velocity),
        ("rest_angle_noise", w.rest_angle_noise),
        ("max_angle", spec.max_angle),
        ("max_innovation", spec.max_innovation),
        ("frozen_motion", spec.frozen_motion),
        ("held_allowance", spec.held_allowance),
        ("rest_position", spec.rest_position),
        ("rest_swing", spec.rest_swing),
        ("rest_hysteresis", spec.rest_hysteresis),
        ("offset_dead_band", spec.offset_dead_band),
        ("offset_step", spec.offset_step),
        ("max_offset", spec.max_offset),
    ];
    for (name, v) in positive {
        if !(v.is_finite() && v > 0.0) {
            return Err(refuse(
                &format!("feedback.{name}"),
                format!("must be finite and > 0 (got {v})"),
            ));
        }
    }
    if spec.max_angle >= std::f64::consts::FRAC_PI_2 {
        return Err(refuse(
            "feedback.max_angle",
            "below π/2: the load hangs below the trolley",
        ));
    }
    if spec.max_bad_angle_cycles > 10 {
        return Err(refuse(
            "feedback.bridged_cycles",
            "at most 10 (0.1 s at 100 Hz): longer, the observer runs blind",
        ));
    }
    if spec.max_frozen_cycles < 2 {
        return Err(refuse(
            "feedback.frozen_cycles",
            "at least 2: one repeated value is not a stuck sensor",
        ));
    }
    if spec.rest_hysteresis < 1.0 {
        return Err(refuse(
            "feedback.rest_hysteresis",
            "at least 1: below, a crane let go would be held again at once (it chatters)",
        ));
    }
    if spec.rest_swing * spec.rest_hysteresis >= spec.max_innovation {
        return Err(refuse(
            "feedback.rest_swing",
            "rest_swing × rest_hysteresis must be below max_innovation: a swing the feedback lets go must be one it can still read",
        ));
    }
    if spec.offset_step >= spec.max_innovation {
        return Err(refuse(
            "feedback.offset_step",
            "must be below max_innovation: a larger miss is implausible, never a step of the zero",
        ));
    }
    if spec.offset_dead_band >= spec.max_offset {
        return Err(refuse(
            "feedback.offset_dead_band",
            "must be below max_offset: an offset left in the reading cannot be one that is announced",
        ));
    }
    if spec.max_offset >= spec.max_angle {
        return Err(refuse(
            "feedback.max_offset",
            "must be below max_angle: the offset is judged on plausible angles",
        ));
    }
    if spec.offset_cycles == 0 {
        return Err(refuse(
            "feedback.offset_cycles",
            "at least 1 (longer than the site's gusts: a gust's push is no offset)",
        ));
    }
    let config = Config {
        g: params.g,
        tau1: params.tau1,
        tau2: params.tau2,
        h,
        // The sensor's, from the commissioning file (`CommissioningFile::lag`).
        inclinometer: InclinometerLag::NONE,
        ..*spec
    };
    Gains::design(&config).map_err(|e| {
        refuse(
            "feedback",
            format!("no gains can be designed from these weights: {e:?}"),
        )
    })?;
    Ok(config)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::commissioning::CommissioningFile;
    use crate::cranes::planar::Planar;
    use crate::firmware::firmware_scene;
    use crate::Scene;

    fn scene(feedback: &str) -> Result<Scene, SceneError> {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../scenes/paper-crane-feedback.toml");
        let text = std::fs::read_to_string(path).unwrap();
        let base = text.split("[feedback]").next().unwrap();
        Scene::parse(&format!("{base}[feedback]\n{feedback}"))
    }

    #[test]
    fn the_defaults_are_the_study_s_and_link_the_inclinometer() {
        let s = scene("").unwrap();
        let f = firmware_scene::<Planar, 2>(&s, &CommissioningFile::default()).unwrap();
        assert_eq!(f.feedback, Some(Config::PAPER));
        assert!(f.config.inclinometer().is_some());
        // Without the section: no feedback, no inclinometer.
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/paper-crane.toml");
        let plain = Scene::load(&path).unwrap();
        let f = firmware_scene::<Planar, 2>(&plain, &CommissioningFile::default()).unwrap();
        assert_eq!((f.feedback, f.config.inclinometer()), (None, None));
    }

    #[test]
    fn a_bad_field_is_named() {
        let check = |text: &str| {
            let s = scene(text)?;
            config(&s.feedback.unwrap(), &CraneParams::PAPER, 0.01)
        };
        for (text, field) in [
            ("load_position = -1.0", "feedback.load_position"),
            ("angle_noise = nan", "feedback.angle_noise"),
            ("rest_load_position = 0.0", "feedback.rest_load_position"),
            (
                "rest_trolley_position = -0.1",
                "feedback.rest_trolley_position",
            ),
            ("rest_swing_velocity = inf", "feedback.rest_swing_velocity"),
            ("rest_load_velocity = nan", "feedback.rest_load_velocity"),
            ("drive_offset = 0.0", "feedback.drive_offset"),
            ("max_angle = 2.0", "feedback.max_angle"),
            ("bridged_cycles = 50", "feedback.bridged_cycles"),
            ("frozen_cycles = 1", "feedback.frozen_cycles"),
            ("rest_swing = 0.0", "feedback.rest_swing"),
            ("rest_hysteresis = 0.9", "feedback.rest_hysteresis"),
            ("rest_swing = 0.03", "feedback.rest_swing"),
            ("offset_dead_band = -0.001", "feedback.offset_dead_band"),
            ("offset_dead_band = 0.01", "feedback.offset_dead_band"),
            ("offset_step = 0.04", "feedback.offset_step"),
            ("max_offset = inf", "feedback.max_offset"),
            ("max_offset = 0.4", "feedback.max_offset"),
            ("offset_cycles = 0", "feedback.offset_cycles"),
            ("load_position = 1e-300", "feedback"),
        ] {
            let e = check(text).unwrap_err();
            assert_eq!(e.field, field, "{text}: {e}");
        }
        let e = scene("load_positon = 0.02").unwrap_err();
        assert!(e.to_string().contains("load_positon"), "{e}");
    }

    /// A typo, a key the file cannot set (the crane's g, the cycle h, the controller's own
    /// names) and a value of the wrong type are refused at their key, the typo with every
    /// key the section has, as serde says it for one struct.
    #[test]
    fn a_bad_key_or_type_is_refused_at_its_key() {
        let keys = "`load_position`, `trolley_position`, `swing_velocity`, `trolley_correction`, \
            `rope_position`, `winch_correction`, `drive_disturbance`, `swing_disturbance`, \
            `drive_offset`, `position_noise`, `angle_noise`, `rest_load_position`, \
            `rest_trolley_position`, `rest_swing_velocity`, `rest_load_velocity`, \
            `rest_angle_noise`, `max_angle`, `max_innovation`, `bridged_cycles`, \
            `frozen_cycles`, `frozen_motion`, `held_allowance`, `rest_position`, \
            `rest_swing`, `rest_hysteresis`, `offset_dead_band`, `offset_step`, \
            `max_offset`, `offset_cycles`";
        for key in ["load_positon", "g", "h", "weights", "max_bad_angle_cycles"] {
            let e = scene(&format!("{key} = 1")).unwrap_err();
            assert_eq!(e.field, format!("feedback.{key}"));
            assert_eq!(
                e.reason,
                format!("unknown field `{key}`, expected one of {keys}")
            );
        }
        for (text, field, reason) in [
            (
                "load_position = \"a\"",
                "feedback.load_position",
                "invalid type: string \"a\", expected f64",
            ),
            (
                "max_angle = true",
                "feedback.max_angle",
                "invalid type: boolean `true`, expected f64",
            ),
            (
                "bridged_cycles = 1.5",
                "feedback.bridged_cycles",
                "invalid type: floating point `1.5`, expected u32",
            ),
            (
                "offset_cycles = -1",
                "feedback.offset_cycles",
                "invalid value: integer `-1`, expected u32",
            ),
        ] {
            let e = scene(text).unwrap_err();
            assert_eq!(
                (e.field.as_str(), e.reason.as_str()),
                (field, reason),
                "{text}"
            );
        }
    }

    /// Each key of `[feedback]` lands in the controller's field of that meaning (the
    /// weights' by name, `bridged_cycles` and `frozen_cycles` in the renamed ones), and a
    /// key left out keeps the study's value.
    #[test]
    fn every_key_reaches_its_field() {
        let s = scene(
            "load_position = 0.021\ntrolley_position = 0.51\nswing_velocity = 0.051\n\
             trolley_correction = 0.151\nrope_position = 0.0051\nwinch_correction = 0.052\n\
             drive_disturbance = 0.52\nswing_disturbance = 0.11\ndrive_offset = 0.31\n\
             position_noise = 5.1e-4\nangle_noise = 5.2e-4\nrest_load_position = 0.031\n\
             rest_trolley_position = 0.11\nrest_swing_velocity = 0.12\nrest_load_velocity = 0.032\n\
             rest_angle_noise = 3.1e-3\nmax_angle = 0.34\nmax_innovation = 0.036\n\
             bridged_cycles = 4\nfrozen_cycles = 5\nfrozen_motion = 0.0018\n\
             held_allowance = 0.021\nrest_position = 0.022\nrest_swing = 0.0011\n\
             rest_hysteresis = 1.7\noffset_dead_band = 0.0018\noffset_step = 0.0045\n\
             max_offset = 0.0088\noffset_cycles = 501",
        )
        .unwrap();
        let c = s.feedback.unwrap();
        assert_eq!(
            c.weights.all(),
            [
                0.021, 0.51, 0.051, 0.151, 0.0051, 0.052, 0.52, 0.11, 0.31, 5.1e-4, 5.2e-4, 0.031,
                0.11, 0.12, 0.032, 3.1e-3
            ]
        );
        assert_eq!(
            [
                c.max_angle,
                c.max_innovation,
                c.frozen_motion,
                c.held_allowance,
                c.rest_position,
                c.rest_swing,
                c.rest_hysteresis,
                c.offset_dead_band,
                c.offset_step,
                c.max_offset,
            ],
            [0.34, 0.036, 0.0018, 0.021, 0.022, 0.0011, 1.7, 0.0018, 0.0045, 0.0088]
        );
        assert_eq!(
            (c.max_bad_angle_cycles, c.max_frozen_cycles, c.offset_cycles),
            (4, 5, 501)
        );
        // What a scene cannot set is the paper's until the crane's and the cycle's are
        // filled in (`config`).
        let p = Config::PAPER;
        assert_eq!(
            (c.g, c.tau1, c.tau2, c.h, c.inclinometer),
            (p.g, p.tau1, p.tau2, p.h, p.inclinometer)
        );
        // One key: the rest are the study's.
        let one = scene("max_angle = 0.3").unwrap().feedback.unwrap();
        assert_eq!(
            one,
            Config {
                max_angle: 0.3,
                ..Config::PAPER
            }
        );
    }
}
