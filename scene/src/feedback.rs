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

/// `[feedback]` as read lives with the scene's other sections (`lib.rs`, so that the
/// scene's types import nothing above them); this module checks it and designs from it.
pub use crate::FeedbackSpec;
use crate::{refuse, SceneError};

impl FeedbackSpec {
    /// The feedback's configuration for the crane `params` cycling every `h` s, or the
    /// first field that cannot work, named with the reason.
    pub fn config(&self, params: &CraneParams, h: f64) -> Result<Config, SceneError> {
        let positive = [
            ("load_position", self.load_position),
            ("trolley_position", self.trolley_position),
            ("swing_velocity", self.swing_velocity),
            ("trolley_correction", self.trolley_correction),
            ("rope_position", self.rope_position),
            ("winch_correction", self.winch_correction),
            ("drive_disturbance", self.drive_disturbance),
            ("swing_disturbance", self.swing_disturbance),
            ("drive_offset", self.drive_offset),
            ("position_noise", self.position_noise),
            ("angle_noise", self.angle_noise),
            ("rest_load_position", self.rest_load_position),
            ("rest_trolley_position", self.rest_trolley_position),
            ("rest_swing_velocity", self.rest_swing_velocity),
            ("rest_load_velocity", self.rest_load_velocity),
            ("rest_angle_noise", self.rest_angle_noise),
            ("max_angle", self.max_angle),
            ("max_innovation", self.max_innovation),
            ("frozen_motion", self.frozen_motion),
            ("held_allowance", self.held_allowance),
            ("rest_position", self.rest_position),
            ("rest_swing", self.rest_swing),
            ("rest_hysteresis", self.rest_hysteresis),
            ("offset_dead_band", self.offset_dead_band),
            ("offset_step", self.offset_step),
            ("max_offset", self.max_offset),
        ];
        for (name, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(refuse(
                    &format!("feedback.{name}"),
                    format!("must be finite and > 0 (got {v})"),
                ));
            }
        }
        if self.max_angle >= std::f64::consts::FRAC_PI_2 {
            return Err(refuse(
                "feedback.max_angle",
                "below π/2: the load hangs below the trolley",
            ));
        }
        if self.bridged_cycles > 10 {
            return Err(refuse(
                "feedback.bridged_cycles",
                "at most 10 (0.1 s at 100 Hz): longer, the observer runs blind",
            ));
        }
        if self.frozen_cycles < 2 {
            return Err(refuse(
                "feedback.frozen_cycles",
                "at least 2: one repeated value is not a stuck sensor",
            ));
        }
        if self.rest_hysteresis < 1.0 {
            return Err(refuse(
                "feedback.rest_hysteresis",
                "at least 1: below, a crane let go would be held again at once (it chatters)",
            ));
        }
        if self.rest_swing * self.rest_hysteresis >= self.max_innovation {
            return Err(refuse(
                "feedback.rest_swing",
                "rest_swing × rest_hysteresis must be below max_innovation: a swing the feedback lets go must be one it can still read",
            ));
        }
        if self.offset_step >= self.max_innovation {
            return Err(refuse(
                "feedback.offset_step",
                "must be below max_innovation: a larger miss is implausible, never a step of the zero",
            ));
        }
        if self.offset_dead_band >= self.max_offset {
            return Err(refuse(
                "feedback.offset_dead_band",
                "must be below max_offset: an offset left in the reading cannot be one that is announced",
            ));
        }
        if self.max_offset >= self.max_angle {
            return Err(refuse(
                "feedback.max_offset",
                "must be below max_angle: the offset is judged on plausible angles",
            ));
        }
        if self.offset_cycles == 0 {
            return Err(refuse(
                "feedback.offset_cycles",
                "at least 1 (longer than the site's gusts: a gust's push is no offset)",
            ));
        }
        let config = Config {
            weights: Weights {
                load_position: self.load_position,
                trolley_position: self.trolley_position,
                swing_velocity: self.swing_velocity,
                trolley_correction: self.trolley_correction,
                rope_position: self.rope_position,
                winch_correction: self.winch_correction,
                drive_disturbance: self.drive_disturbance,
                swing_disturbance: self.swing_disturbance,
                drive_offset: self.drive_offset,
                position_noise: self.position_noise,
                angle_noise: self.angle_noise,
                rest_load_position: self.rest_load_position,
                rest_trolley_position: self.rest_trolley_position,
                rest_swing_velocity: self.rest_swing_velocity,
                rest_load_velocity: self.rest_load_velocity,
                rest_angle_noise: self.rest_angle_noise,
            },
            g: params.g,
            tau1: params.tau1,
            tau2: params.tau2,
            h,
            max_angle: self.max_angle,
            max_innovation: self.max_innovation,
            max_bad_angle_cycles: self.bridged_cycles,
            max_frozen_cycles: self.frozen_cycles,
            frozen_motion: self.frozen_motion,
            held_allowance: self.held_allowance,
            rest_position: self.rest_position,
            rest_swing: self.rest_swing,
            rest_hysteresis: self.rest_hysteresis,
            offset_dead_band: self.offset_dead_band,
            offset_step: self.offset_step,
            max_offset: self.max_offset,
            offset_cycles: self.offset_cycles,
            // The sensor's, from the commissioning file (`CommissioningFile::lag`).
            inclinometer: InclinometerLag::NONE,
        };
        Gains::design(&config).map_err(|e| {
            refuse(
                "feedback",
                format!("no gains can be designed from these weights: {e:?}"),
            )
        })?;
        Ok(config)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::commissioning::CommissioningFile;
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
        let f = firmware_scene::<CraneParams, 2>(&s, &CommissioningFile::default()).unwrap();
        assert_eq!(f.feedback, Some(Config::PAPER));
        assert!(f.config.inclinometer().is_some());
        // Without the section: no feedback, no inclinometer.
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/paper-crane.toml");
        let plain = Scene::load(&path).unwrap();
        let f = firmware_scene::<CraneParams, 2>(&plain, &CommissioningFile::default()).unwrap();
        assert_eq!((f.feedback, f.config.inclinometer()), (None, None));
    }

    #[test]
    fn a_bad_field_is_named() {
        let check = |text: &str| {
            let s = scene(text)?;
            s.feedback.unwrap().config(&CraneParams::PAPER, 0.01)
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
}
