//! The scene's manual mode, `[operator]` (issue 28): with the section the scene's model
//! follows the plan *or* the operator's generator (`controller::operator::path::Steered`)
//! and a PLC's speed-demand frames (RPDO3 0x410, object 0x2010) drive the crane; without
//! it the model follows plans only and the firmware links no generator (model only what
//! a scene requires). Every key is optional; its default is the crane's lab setting
//! (`solver_core::operator::Settings::lab`, `Settings::lab_3d`, docs/OPERATOR.md):
//!
//! ```toml
//! [operator]
//! speed = [1.0, 0.5]          # m/s per axis at full stick, the model's output order:
//!                             # planar [trolley, hoist], 3D [bridge, trolley, hoist]
//! acceleration = [0.5, 0.5]   # m/s² per axis, the same order
//! boxes = [0.2, 0.2]          # s, the horizontal filter's two moving averages
//! hoist_boxes = [0.2, 0.2, 0.2, 0.2]  # s, the hoist filter's four
//! robust = false              # one more zero-vibration pair against a ±10 % rope error
//! deadband = 0.05             # share of full stick read as zero
//! lowering_allowance = 1.0    # m the hoist may lower below its stop while travelling
//! entry_blend = 8.0           # s, the longest stop a hand-over from a running move may take
//! ```
//!
//! The cycle `h` is the scene's `solver.h`, gravity the model's `g`; each axis's range is
//! the crane's workspace (the hoist's the load depths its rope range allows,
//! `Settings::depth_range`). The settings are checked at scene load
//! (`Settings::validate`) and must fit the firmware's generator, whose rings hold
//! [`LAB_RING`] and [`LAB_HOIST_RING`] cycles; only the formulations whose reference
//! the controller computes from the generator's path (*subs*, planar and 3D) run manual
//! mode, and each crane's file says which (`FirmwareCrane::operator_settings`); the
//! scene's check asks it (`Scene::check`).

use solver_core::operator::{Settings, LAB_HOIST_RING, LAB_RING};
use solver_core::Error;

pub use crate::OperatorSpec;
use crate::{refuse, SceneError};

impl OperatorSpec {
    /// The generator's settings: `lab` (the crane's lab setting, its ranges from the
    /// crane's workspace) with the section's keys over it, for the scene's cycle `h` and
    /// the rope's range `rope` = `(l_min, l_max)`; or the first key that cannot work,
    /// named with the reason. `axes` names the model's outputs, for the messages.
    pub fn settings<const NH: usize>(
        &self,
        lab: Settings<NH>,
        h: f64,
        rope: (f64, f64),
        axes: &[&str],
    ) -> Result<Settings<NH>, SceneError> {
        let mut s = Settings { h, ..lab };
        let per_axis =
            |key: &str, values: &Option<Vec<f64>>| -> Result<Option<Vec<f64>>, SceneError> {
                let Some(v) = values else { return Ok(None) };
                if v.len() != NH + 1 {
                    return Err(refuse(
                        &format!("operator.{key}"),
                        format!(
                            "one value per axis, [{}] (got {})",
                            axes.join(", "),
                            v.len()
                        ),
                    ));
                }
                for (value, axis) in v.iter().zip(axes) {
                    if !(value.is_finite() && *value > 0.0) {
                        return Err(refuse(
                            &format!("operator.{key}"),
                            format!("the {axis}'s must be finite and > 0 (got {value})"),
                        ));
                    }
                }
                Ok(Some(v.clone()))
            };
        if let Some(v) = per_axis("speed", &self.speed)? {
            for (axis, value) in s.horizontal.iter_mut().zip(&v) {
                axis.speed = *value;
            }
            s.hoist.speed = v[NH];
        }
        if let Some(v) = per_axis("acceleration", &self.acceleration)? {
            for (axis, value) in s.horizontal.iter_mut().zip(&v) {
                axis.acceleration = *value;
            }
            s.hoist.acceleration = v[NH];
        }
        if let Some(b) = self.boxes {
            s.boxes = b;
        }
        if let Some(b) = self.hoist_boxes {
            s.hoist_boxes = b;
        }
        if let Some(r) = self.robust {
            s.robust = r;
        }
        if let Some(d) = self.deadband {
            s.deadband = d;
        }
        if let Some(l) = self.lowering_allowance {
            s.lowering_allowance = l;
        }
        if let Some(e) = self.entry_blend {
            s.entry_blend = e;
        }
        // The hoist's depth range follows from the horizontal accelerations (the rope's
        // slope while the load accelerates).
        s.hoist.range = s.depth_range(rope);
        s.validate().map_err(field_of)?;
        let (ring, hoist_ring) = s.ring_lengths().map_err(field_of)?;
        if ring > LAB_RING {
            return Err(refuse(
                "operator",
                format!(
                    "the horizontal filter needs {ring} cycles of history, the firmware's generator holds {LAB_RING} \
                     (shorten `boxes`, drop `robust`, or shorten the rope's l_max)"
                ),
            ));
        }
        if hoist_ring > LAB_HOIST_RING {
            return Err(refuse(
                "operator.hoist_boxes",
                format!(
                    "the hoist's filter needs {hoist_ring} cycles of history, the firmware's generator holds {LAB_HOIST_RING}"
                ),
            ));
        }
        Ok(s)
    }
}

/// The refusal of `[operator]` for a formulation of `crane` other than its *subs*
/// (`kind`): only *subs* has the controller's reference on the generator's path.
pub(crate) fn only_subs(crane: &str, kind: &str, model: impl core::fmt::Debug) -> SceneError {
    refuse(
        "operator",
        format!("manual mode runs on the {crane}'s *subs* (kind = \"{kind}\"); this scene's model is {model:?}"),
    )
}

/// The key of `[operator]` (or the scene's field) a generator's settings error comes
/// from (`Settings::validate`'s names).
fn field_of(e: Error) -> SceneError {
    let name = match e {
        Error::InvalidSetting { name, .. }
        | Error::NonFiniteParameter { name, .. }
        | Error::ParameterOutOfRange { name, .. } => name,
        _ => "",
    };
    let field = match name {
        "h" => "solver.h",
        "g" => "model.g",
        "speed" => "operator.speed",
        "acceleration" | "hoist acceleration" => "operator.acceleration",
        "box" => "operator.boxes",
        "hoist box" => "operator.hoist_boxes",
        "lowering_allowance" => "operator.lowering_allowance",
        "deadband" => "operator.deadband",
        "entry_blend" => "operator.entry_blend",
        // The shortest generator pendulum, for the shallowest load: too short for the
        // cycle.
        "omega_g h" => "model.workspace.l_min",
        "range min" | "range max" | "hoist range min" => "model",
        _ => "operator",
    };
    refuse(field, e.to_string())
}
