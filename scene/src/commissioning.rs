//! The commissioning file: what the controller writes into each drive, and its own
//! CANopen settings. It lives next to the scene (`commissioning.toml` in the scene's
//! folder); without one, the stock defaults apply (drives at nodes 1 and 2 in CSV).
//! A bad field is refused like a scene's: named, with the reason.
//!
//! ```toml
//! [controller]
//! node = 16                      # 0x10
//! role = "manager"               # manager | slave (a PLC is NMT master)
//! heartbeat_ms = 100             # 0x1017 of the controller
//! heartbeat_timeout_ms = 300     # a drive whose heartbeat is older is lost
//! tpdo_timeout_ms = 50           # … whose TPDOs are older
//! sdo_timeout_ms = 100           # an SDO transfer that takes longer fails
//!
//! [[drive]]
//! axis = "trolley"               # trolley | winch | bridge: each drive of the crane once
//! node = 1
//! mode = "csv"                   # csv | pv (pv only for drives without CSV)
//! heartbeat_ms = 100             # written to the drive's 0x1017
//! controller_timeout_ms = 300    # 0x1016:1: the drive stops if the controller falls silent
//! quick_stop_option = 6          # 0x605A
//! abort_connection_option = 3    # 0x6007
//! quick_stop_deceleration = 6.0  # m/s², 0x6085
//! max_velocity = 3.3             # m/s, 0x6080: at least the set-point limit
//! velocity_unit = "um/s"         # optional: write 0x60A9 (the only unit the gate speaks)
//! profile_acceleration = 30.0    # m/s², pv only (0x6083/0x6084): required there
//! position_scale = 1e-6          # m per increment of 0x6064
//! position_offset = 0.0          # m at increment 0
//! velocity_limit = 3.0           # optional: the set points' limit, m/s (the crane's lab drive's)
//! acceleration_limit = 3.0       # optional: m/s² (planner and set-point gate)
//! standstill_window = 0.02       # m: at rest, how far position actual may move (fault 20)
//! standstill_delay_ms = 500      # set points zero this long: at rest, its position kept
//! following_window = 0.2         # m: moving, position actual against the set points sent (fault 21)
//! following_drift = 0.05         # … plus this share of the distance commanded since rest
//! velocity_window = 0.3          # m/s: moving, velocity actual against them (plus the drift) …
//! following_time_ms = 50         # … for at most this long
//! in_place_window = 0.05         # m: before a move at rest, position actual against the model's (reason 15)
//!
//! [inclinometer]                 # CiA 410, for a scene with [feedback]
//! node = 3
//! resolution_mdeg = 10           # 0x6000: 0.01° per unit of slope long16 (0x6010)
//! heartbeat_ms = 100             # written to its 0x1017
//! sign = 1.0                     # +1 or -1: slope +1° is φ = sign · 1°
//! offset_deg = 0.0               # the slope with the load hanging still
//! axes = 1                       # 2: slope lateral16 (0x6020) too, mapped second in TPDO1
//! lateral_sign = 1.0             # as sign, for the swing across (the 3D crane's y–z plane)
//! lateral_offset_deg = 0.0       # as offset_deg, for the lateral slope
//! delay_cycles = 0               # its sample is this many cycles older than the drives' (0–5)
//! filter_ms = 0.0                # its own first-order filter's time constant (0: none)
//! ```

use std::collections::BTreeSet;
use std::path::Path;

use controller::commissioning::{
    DriveSetup, InclinometerSetup, LateralAxis, NodeSetup, OperationMode, MAX_NODES,
};
use controller::drive::{self, Drive, PLANAR};
use controller::motion::MotionWindows;
use controller::node::Role;
use controller::rope::{InclinometerLag, MAX_DELAY_CYCLES};
use controller::setpoint::{AxisLimits, DriveLimits, MAX_VELOCITY_LIMIT, UNITS_PER_M_PER_S};
use controller::Config;
use serde::Deserialize;
use toml::de::{DeTable, DeValue};

use crate::{side_by_side, SceneError};

/// The file's name, in the scene's folder.
pub const FILE_NAME: &str = "commissioning.toml";

/// SI unit velocity (0x60A9) for µm/s: prefix 10^-6, metre, per second (CiA 402-2).
pub const MICROMETRE_PER_SECOND: u32 = 0xFA01_0300;

/// The commissioning file as read.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommissioningFile {
    /// The controller's own settings.
    #[serde(default)]
    pub controller: ControllerSpec,
    /// One row per drive.
    #[serde(default = "stock_drives", rename = "drive")]
    pub drives: Vec<DriveRow>,
    /// The inclinometer, used by scenes with a state feedback.
    #[serde(default)]
    pub inclinometer: InclinometerRow,
}

impl Default for CommissioningFile {
    fn default() -> Self {
        Self {
            controller: ControllerSpec::default(),
            drives: stock_drives(),
            inclinometer: InclinometerRow::default(),
        }
    }
}

/// The `[inclinometer]` section (CiA 410). Its long axis's keys are read into the
/// controller's [`InclinometerSetup`] (`setup`), its `lateral_*` keys into the
/// controller's [`LateralAxis`] (`lateral`), both beside this row's own keys
/// ([`CommissioningFile::parse`]). Its own keys are what the section says that is no
/// field of those types: `axes`, whether the lateral axis is the setup's
/// (`InclinometerSetup::lateral` is `Some` only for two), and the sensor's timing, which
/// the rope calibration takes as `controller::rope::InclinometerLag` (its filter in
/// seconds, the file's in ms: [`CommissioningFile::lag`]).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InclinometerRow {
    /// The long axis's keys (`lateral` always `None` here: see `axes`).
    #[serde(skip)]
    pub setup: InclinometerSetup,
    /// The lateral axis's keys, kept where `axes` is 2.
    #[serde(skip)]
    pub lateral: LateralAxis,
    /// 1: slope long16 only; 2: slope lateral16 too (the 3D crane's swing across the
    /// bridge).
    pub axes: u8,
    /// Whole cycles the sample it sends is older than the drives' positions of the
    /// same SYNC (docs/COMMISSIONING.md, "The inclinometer's timing"): 0–5.
    pub delay_cycles: u8,
    /// The time constant of its own first-order filter, ms (0: none).
    pub filter_ms: f64,
}

impl Default for InclinometerRow {
    fn default() -> Self {
        Self {
            setup: InclinometerSetup::STOCK,
            lateral: LateralAxis::STOCK,
            axes: 1,
            delay_cycles: 0,
            filter_ms: 0.0,
        }
    }
}

/// The controller's CANopen settings. Its role is the controller's own type
/// (`controller::node::Role`, with feature `serde`). The section stays a type of its own
/// while `cargo xtask report` reads its `heartbeat_ms` (xtask/src/report/bus.rs):
/// `controller::Config` names it `heartbeat_period_ms`.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
#[allow(missing_docs)]
pub struct ControllerSpec {
    pub node: u8,
    pub role: Role,
    pub heartbeat_ms: u16,
    pub heartbeat_timeout_ms: u32,
    pub tpdo_timeout_ms: u32,
    pub sdo_timeout_ms: u32,
}

impl Default for ControllerSpec {
    fn default() -> Self {
        let c = Config::DEFAULT;
        Self {
            node: c.node,
            role: c.role,
            heartbeat_ms: c.heartbeat_period_ms,
            heartbeat_timeout_ms: c.heartbeat_timeout_ms,
            tpdo_timeout_ms: c.tpdo_timeout_ms,
            sdo_timeout_ms: c.sdo_timeout_ms,
        }
    }
}

/// One `[[drive]]` row. The drive's keys in its own units are read into the
/// controller's [`DriveSetup`] (`setup`), the motion windows into its `motion`, both
/// beside this row's own keys ([`CommissioningFile::parse`]). Its own keys are what the
/// row says that is no field of `DriveSetup` as it stands: the axis (the controller's
/// `NodeSetup::Drive` holds it beside the setup), the values the file gives in m/s,
/// m/s² or by name, checked against the crane's set-point limits that a row does not
/// know (`max_velocity` left out is 1.1 times the crane's limit) and refused with the
/// row's index, and the set points' own limits (`controller::setpoint::AxisLimits`).
/// [`CommissioningFile::config_for`] writes the checked values into the setup.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriveRow {
    /// The axis it drives.
    pub axis: Drive,
    /// The drive's own keys. Its deceleration, max velocity, velocity unit and profile
    /// ramp are not read into it: `config_for` sets them from the row's keys below.
    #[serde(skip, default = "unset_setup")]
    pub setup: DriveSetup,
    /// Quick-stop deceleration, m/s² (0x6085).
    #[serde(default = "stock_deceleration")]
    pub quick_stop_deceleration: f64,
    /// Max motor speed, m/s (0x6080); 1.1 times the set points' limit when absent.
    pub max_velocity: Option<f64>,
    /// The SI unit of velocity 0x60A9 by name (only "um/s").
    pub velocity_unit: Option<String>,
    /// The profile ramp 0x6083/0x6084, m/s² (pv only).
    pub profile_acceleration: Option<f64>,
    /// The set points' velocity limit for this drive, m/s (the planner's and the
    /// gate's); the crane's lab drive's when absent.
    pub velocity_limit: Option<f64>,
    /// The set points' acceleration limit, m/s²; the crane's lab drive's when absent.
    pub acceleration_limit: Option<f64>,
}

/// A row's setup until `parse` reads it beside the row (serde skips it in the row).
fn unset_setup() -> DriveSetup {
    DriveSetup::stock(0, 0)
}

/// The stock drive's quick-stop deceleration in the file's unit, m/s².
fn stock_deceleration() -> f64 {
    f64::from(DriveSetup::stock(0, 0).quick_stop_deceleration) / UNITS_PER_M_PER_S
}

fn stock_drives() -> Vec<DriveRow> {
    [(Drive::Trolley, 1), (Drive::Winch, 2)]
        .into_iter()
        .map(|(axis, node)| DriveRow {
            axis,
            setup: DriveSetup::stock(node, 0),
            quick_stop_deceleration: stock_deceleration(),
            max_velocity: None,
            velocity_unit: None,
            profile_acceleration: None,
            velocity_limit: None,
            acceleration_limit: None,
        })
        .collect()
}

/// A drive row's motion supervision windows, or the field that cannot work and why: each
/// window positive (the standstill window at least ten increments of position actual,
/// or the drive's quantisation trips it), the drift a share below one, the times at least
/// a cycle (what the controller sees of a drive comes once a cycle).
fn motion_windows(d: &DriveSetup, period_ms: u32) -> Result<MotionWindows, (&'static str, String)> {
    let positive = |name: &'static str, v: f64, unit: &str| {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err((name, format!("a positive number, {unit}")))
        }
    };
    let standstill = positive("standstill_window", d.motion.standstill, "m")?;
    if standstill < 10.0 * d.position_scale.abs() {
        return Err((
            "standstill_window",
            format!(
                "at least ten increments of position actual ({} m): a drive's quantisation would trip it",
                10.0 * d.position_scale.abs()
            ),
        ));
    }
    let following = positive("following_window", d.motion.following, "m")?;
    let velocity = positive("velocity_window", d.motion.velocity, "m/s")?;
    let in_place = positive("in_place_window", d.motion.in_place, "m")?;
    if !(0.0..1.0).contains(&d.motion.following_drift) {
        return Err((
            "following_drift",
            "a share of the distance commanded, 0 to below 1".into(),
        ));
    }
    let cycle = |name: &'static str, ms: u16| {
        if u32::from(ms) >= period_ms {
            Ok(ms)
        } else {
            Err((
                name,
                format!("at least a cycle ({period_ms} ms): a drive reports once a cycle"),
            ))
        }
    };
    Ok(MotionWindows {
        standstill,
        standstill_delay_ms: cycle("standstill_delay_ms", d.motion.standstill_delay_ms)?,
        following,
        following_drift: d.motion.following_drift,
        velocity,
        following_time_ms: cycle("following_time_ms", d.motion.following_time_ms)?,
        in_place,
    })
}

fn refuse(field: String, reason: impl Into<String>) -> SceneError {
    SceneError {
        field,
        reason: reason.into(),
    }
}

impl CommissioningFile {
    /// The commissioning file next to the scene at `scene_path`, or the defaults if there
    /// is none.
    pub fn for_scene(scene_path: &Path) -> Result<Self, SceneError> {
        let path = scene_path
            .parent()
            .unwrap_or_else(|| Path::new("."))
            .join(FILE_NAME);
        if !path.exists() {
            return Ok(Self::default());
        }
        let text = std::fs::read_to_string(&path).map_err(|e| {
            refuse(
                String::new(),
                format!("cannot read {}: {e}", path.display()),
            )
        })?;
        Self::parse(&text)
    }

    /// Parses the file's text (not yet checked against a scene: see [`Self::config`]).
    pub fn parse(text: &str) -> Result<Self, SceneError> {
        let toml_error = |e: toml::de::Error| {
            let field = e
                .span()
                .map(|s| crate::key_at(text, s.start))
                .unwrap_or_default();
            refuse(field, e.message().to_string())
        };
        let mut file = DeTable::parse(text).map_err(toml_error)?;
        // Each `[[drive]]` row holds its own keys, the drive's and its motion windows'
        // side by side (`side_by_side`): the drive's are taken out and read as the
        // controller's `DriveSetup`, the windows' as its `MotionWindows`, the rest as the
        // row.
        let mut setups = Vec::new();
        if let Some(DeValue::Array(rows)) = file.get_mut().get_mut("drive").map(|d| d.get_mut()) {
            for row in rows.iter_mut() {
                let span = row.span();
                if let DeValue::Table(table) = row.get_mut() {
                    let (own, setup, motion) = side_by_side::split3::<
                        DriveRow,
                        DriveSetup,
                        MotionWindows,
                    >(text, std::mem::take(table))?;
                    *table = own;
                    let mut setup = side_by_side::read::<DriveSetup>(text, span.clone(), setup)?;
                    setup.motion = side_by_side::read::<MotionWindows>(text, span, motion)?;
                    setups.push(setup);
                }
            }
        }
        // `[inclinometer]` likewise: the long axis's keys as the controller's
        // `InclinometerSetup`, the lateral's as its `LateralAxis`, the rest as the row.
        let mut sensor = None;
        if let Some(section) = file.get_mut().get_mut("inclinometer") {
            let span = section.span();
            if let DeValue::Table(table) = section.get_mut() {
                let (setup, lateral, own) = side_by_side::split3::<
                    InclinometerSetup,
                    LateralAxis,
                    InclinometerRow,
                >(text, std::mem::take(table))?;
                *table = own;
                sensor = Some((
                    side_by_side::read::<InclinometerSetup>(text, span.clone(), setup)?,
                    side_by_side::read::<LateralAxis>(text, span, lateral)?,
                ));
            }
        }
        let mut file = Self::deserialize(toml::de::Deserializer::from(file)).map_err(toml_error)?;
        // The rows deserialized, so each was a table: one setup per row.
        for (drive, setup) in file.drives.iter_mut().zip(setups) {
            drive.setup = setup;
        }
        if let Some((setup, lateral)) = sensor {
            file.inclinometer.setup = setup;
            file.inclinometer.lateral = lateral;
        }
        Ok(file)
    }

    /// `config` with the inclinometer of this file (for a scene with a state feedback),
    /// or the first of its fields that cannot work.
    pub fn with_inclinometer(&self, config: Config) -> Result<Config, SceneError> {
        self.with_inclinometer_of(config, 1)
    }

    /// The inclinometer's timing (`delay_cycles`, `filter_ms`) as the rope calibration
    /// takes it (`controller::rope`), or the field that cannot be.
    pub fn lag(&self) -> Result<InclinometerLag, SceneError> {
        let i = &self.inclinometer;
        if i.delay_cycles > MAX_DELAY_CYCLES {
            return Err(refuse(
                "inclinometer.delay_cycles".into(),
                format!("0 to {MAX_DELAY_CYCLES} cycles (got {})", i.delay_cycles),
            ));
        }
        if !(i.filter_ms.is_finite() && (0.0..=1000.0).contains(&i.filter_ms)) {
            return Err(refuse(
                "inclinometer.filter_ms".into(),
                format!("a time constant from 0 to 1000 ms (got {})", i.filter_ms),
            ));
        }
        Ok(InclinometerLag {
            delay: i.delay_cycles,
            filter: i.filter_ms * 1e-3,
        })
    }

    /// [`Self::with_inclinometer`] for a feedback that reads `axes` slopes (the 3D
    /// crane's: 2, the swing in both vertical planes): an inclinometer with fewer is
    /// refused.
    pub fn with_inclinometer_of(&self, config: Config, axes: u8) -> Result<Config, SceneError> {
        let i = &self.inclinometer;
        if !(1..=2).contains(&i.axes) {
            return Err(refuse(
                "inclinometer.axes".into(),
                "1 (slope long16) or 2 (and slope lateral16)",
            ));
        }
        if i.axes < axes {
            return Err(refuse(
                "inclinometer.axes".into(),
                format!("this crane's feedback reads the swing in {axes} planes: a two-axis inclinometer, axes = 2"),
            ));
        }
        let (s, lateral) = (i.setup, i.lateral);
        if lateral.sign != 1.0 && lateral.sign != -1.0 {
            return Err(refuse("inclinometer.lateral_sign".into(), "+1 or -1"));
        }
        if !(lateral.offset_deg.is_finite() && lateral.offset_deg.abs() < 90.0) {
            return Err(refuse(
                "inclinometer.lateral_offset_deg".into(),
                "finite, within ±90°",
            ));
        }
        let taken =
            config.node == s.node || config.nodes.iter().flatten().any(|n| n.node() == s.node);
        if !(1..=127).contains(&s.node) || taken {
            return Err(refuse(
                "inclinometer.node".into(),
                format!("{} is not a free node id in 1..=127", s.node),
            ));
        }
        if s.resolution == 0 || s.resolution > 100 {
            return Err(refuse(
                "inclinometer.resolution_mdeg".into(),
                "1..=100 (0.001° to 0.1°): coarser hides the swing the feedback damps",
            ));
        }
        if s.heartbeat_ms == 0 || u32::from(s.heartbeat_ms) * 3 > config.heartbeat_timeout_ms {
            return Err(refuse(
                "inclinometer.heartbeat_ms".into(),
                format!(
                    "positive and at most a third of the controller's heartbeat timeout ({} ms)",
                    config.heartbeat_timeout_ms
                ),
            ));
        }
        if s.sign != 1.0 && s.sign != -1.0 {
            return Err(refuse("inclinometer.sign".into(), "+1 or -1"));
        }
        if !(s.offset_deg.is_finite() && s.offset_deg.abs() < 90.0) {
            return Err(refuse(
                "inclinometer.offset_deg".into(),
                "finite, within ±90°",
            ));
        }
        let mut config = config;
        if !config.add_node(NodeSetup::Inclinometer(InclinometerSetup {
            lateral: (i.axes == 2).then_some(lateral),
            ..s
        })) {
            return Err(refuse(
                "inclinometer".into(),
                format!("more than {MAX_NODES} nodes"),
            ));
        }
        Ok(config)
    }

    fn drive(&self, axis: Drive) -> Option<(usize, &DriveRow)> {
        self.drives.iter().enumerate().find(|(_, d)| d.axis == axis)
    }

    /// The set-point limits of a crane with `drives` (the model's input order): each
    /// drive's row's `velocity_limit` and `acceleration_limit`, `defaults`' (the crane's
    /// lab drives', same order) where the row names none; a limit that is not a positive
    /// number is refused with its field named. A drive without a row keeps the default
    /// ([`Self::config_for`] refuses the file for it).
    pub fn limits_for<const A: usize>(
        &self,
        drives: [Drive; A],
        defaults: [AxisLimits; A],
    ) -> Result<[AxisLimits; A], SceneError> {
        let mut limits = defaults;
        for (limit, axis) in limits.iter_mut().zip(drives) {
            let Some((i, d)) = self.drive(axis) else {
                continue;
            };
            for (name, value, slot) in [
                ("velocity_limit", d.velocity_limit, &mut limit.max_velocity),
                (
                    "acceleration_limit",
                    d.acceleration_limit,
                    &mut limit.max_acceleration,
                ),
            ] {
                if let Some(v) = value {
                    if !(v.is_finite() && v > 0.0) {
                        return Err(refuse(
                            format!("drive[{i}].{name}"),
                            "a positive number (m/s or m/s²)",
                        ));
                    }
                    if name == "velocity_limit" && v > MAX_VELOCITY_LIMIT {
                        return Err(refuse(
                            format!("drive[{i}].{name}"),
                            format!("at most {MAX_VELOCITY_LIMIT} m/s"),
                        ));
                    }
                    *slot = v;
                }
            }
        }
        Ok(limits)
    }

    /// The controller's configuration for the planar crane's drives with `limits` cycling
    /// every `period_ms`, or the first field that cannot work, named with the reason.
    pub fn config(&self, limits: DriveLimits, period_ms: u32) -> Result<Config, SceneError> {
        self.config_for(PLANAR, limits.axes(), period_ms)
    }

    /// The controller's configuration for a crane with `drives` (the model's input
    /// order) and their `limits` (same order), cycling every `period_ms`: each of its
    /// drives exactly once, no row for a drive it does not have; or the first field that
    /// cannot work, named with the reason.
    pub fn config_for<const A: usize>(
        &self,
        drives: [Drive; A],
        limits: [AxisLimits; A],
        period_ms: u32,
    ) -> Result<Config, SceneError> {
        let c = &self.controller;
        if !(1..=127).contains(&c.node) {
            return Err(refuse("controller.node".into(), "a node id is 1..=127"));
        }
        if c.heartbeat_ms == 0 || u32::from(c.heartbeat_ms) % period_ms != 0 {
            return Err(refuse(
                "controller.heartbeat_ms".into(),
                format!("a positive multiple of the cycle ({period_ms} ms)"),
            ));
        }
        if c.tpdo_timeout_ms < 3 * period_ms {
            return Err(refuse(
                "controller.tpdo_timeout_ms".into(),
                format!(
                    "at least three cycles ({} ms): TPDOs come once a cycle",
                    3 * period_ms
                ),
            ));
        }
        if c.sdo_timeout_ms < 2 * period_ms {
            return Err(refuse(
                "controller.sdo_timeout_ms".into(),
                format!(
                    "at least two cycles ({} ms): one exchange per cycle",
                    2 * period_ms
                ),
            ));
        }
        let mut nodes = BTreeSet::from([c.node]);
        // Each place is overwritten from its row below (or the file is refused).
        let mut setups = drives.map(|d| DriveSetup::stock(d.node(), 0));
        for ((slot, axis), limit) in setups.iter_mut().zip(drives).zip(limits) {
            let name = axis.name();
            let Some((i, d)) = self.drive(axis) else {
                return Err(refuse("drive".into(), format!("no drive moves the {name}")));
            };
            let field = |f: &str| format!("drive[{i}].{f}");
            if self.drives.iter().filter(|d| d.axis == axis).count() > 1 {
                return Err(refuse(field("axis"), format!("the {name} has two drives")));
            }
            let s = &d.setup;
            if !(1..=127).contains(&s.node) || !nodes.insert(s.node) {
                return Err(refuse(
                    field("node"),
                    format!("{} is not a free node id in 1..=127", s.node),
                ));
            }
            let units = |v: f64| (v * UNITS_PER_M_PER_S).round();
            let max_velocity = d.max_velocity.unwrap_or(limit.max_velocity * 1.1);
            if max_velocity.is_nan()
                || max_velocity < limit.max_velocity
                || units(max_velocity) > f64::from(u32::MAX)
            {
                return Err(refuse(
                    field("max_velocity"),
                    format!(
                        "{max_velocity} m/s is below the set-point limit {} m/s: the drive would clip what the model asks",
                        limit.max_velocity
                    ),
                ));
            }
            if d.quick_stop_deceleration.is_nan()
                || d.quick_stop_deceleration <= 0.0
                || units(d.quick_stop_deceleration) > f64::from(u32::MAX)
            {
                return Err(refuse(
                    field("quick_stop_deceleration"),
                    "a positive deceleration, m/s²",
                ));
            }
            if s.heartbeat_ms == 0 || u32::from(s.heartbeat_ms) * 3 > c.heartbeat_timeout_ms {
                return Err(refuse(
                    field("heartbeat_ms"),
                    format!(
                        "positive and at most a third of the controller's heartbeat timeout ({} ms)",
                        c.heartbeat_timeout_ms
                    ),
                ));
            }
            if u32::from(s.controller_timeout_ms) < 2 * u32::from(c.heartbeat_ms) {
                return Err(refuse(
                    field("controller_timeout_ms"),
                    format!(
                        "at least twice the controller's heartbeat ({} ms), or the drive trips on a healthy controller",
                        c.heartbeat_ms
                    ),
                ));
            }
            if !(s.position_scale.is_finite()
                && s.position_scale != 0.0
                && s.position_offset.is_finite())
            {
                return Err(refuse(
                    field("position_scale"),
                    "finite and non-zero, m per increment",
                ));
            }
            if !(1..=3).contains(&s.abort_connection_option) {
                return Err(refuse(
                    field("abort_connection_option"),
                    format!(
                        "{}: 1 (fault), 2 (disable voltage) or 3 (quick stop) — with 0 a drive that loses the controller keeps its last set point",
                        s.abort_connection_option
                    ),
                ));
            }
            let velocity_unit = match d.velocity_unit.as_deref() {
                None => None,
                Some("um/s") => Some(MICROMETRE_PER_SECOND),
                Some(other) => {
                    return Err(refuse(
                        field("velocity_unit"),
                        format!("{other:?}: the set points are in µm/s (\"um/s\")"),
                    ))
                }
            };
            let profile_ramp = match (s.mode, d.profile_acceleration) {
                (OperationMode::CyclicSynchronousVelocity, None) => None,
                (OperationMode::CyclicSynchronousVelocity, Some(_)) => {
                    return Err(refuse(field("profile_acceleration"), "only for mode = \"pv\""))
                }
                (OperationMode::ProfileVelocity, Some(a)) if a >= limit.max_acceleration * 10.0 => {
                    Some(units(a) as u32)
                }
                (OperationMode::ProfileVelocity, _) => {
                    return Err(refuse(
                        field("profile_acceleration"),
                        format!(
                            "profile velocity passes every set point through the drive's ramp 0x6083/0x6084: it must be given and at least ten times the acceleration limit ({} m/s²) not to reshape them",
                            limit.max_acceleration
                        ),
                    ))
                }
            };
            let motion =
                motion_windows(s, period_ms).map_err(|(f, reason)| refuse(field(f), reason))?;
            *slot = DriveSetup {
                quick_stop_deceleration: units(d.quick_stop_deceleration) as u32,
                max_velocity: units(max_velocity) as u32,
                velocity_unit,
                profile_ramp,
                motion,
                ..*s
            };
        }
        let names = || drives.map(Drive::name).join(", ");
        if let Some((i, extra)) = self
            .drives
            .iter()
            .enumerate()
            .find(|(_, d)| !drives.contains(&d.axis))
        {
            return Err(refuse(
                format!("drive[{i}].axis"),
                format!(
                    "this crane has no {}: its drives are {}",
                    extra.axis.name(),
                    names()
                ),
            ));
        }
        // The nodes in the file's order (the stock file: trolley, then winch).
        let mut list = [None; MAX_NODES];
        for (slot, d) in list.iter_mut().zip(&self.drives) {
            let axis = d.axis;
            *slot = drive::of(&drives, axis, &setups).map(|s| NodeSetup::Drive(axis, *s));
        }
        Ok(Config {
            period_ms,
            node: c.node,
            role: c.role,
            heartbeat_period_ms: c.heartbeat_ms,
            heartbeat_timeout_ms: c.heartbeat_timeout_ms,
            tpdo_timeout_ms: c.tpdo_timeout_ms,
            sdo_timeout_ms: c.sdo_timeout_ms,
            nodes: list,
            ..Config::DEFAULT
        })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    fn config(text: &str) -> Result<Config, SceneError> {
        CommissioningFile::parse(text)?.config(DriveLimits::LAB, 10)
    }

    #[test]
    fn the_inclinometer_is_checked_like_a_drive() {
        let stock = CommissioningFile::parse("").unwrap();
        let c = stock.with_inclinometer(Config::DEFAULT).unwrap();
        assert_eq!(c.inclinometer(), Some(&InclinometerSetup::STOCK));
        for (text, field) in [
            ("[inclinometer]\nnode = 1", "inclinometer.node"),
            ("[inclinometer]\nnode = 16", "inclinometer.node"),
            (
                "[inclinometer]\nresolution_mdeg = 1000",
                "inclinometer.resolution_mdeg",
            ),
            (
                "[inclinometer]\nheartbeat_ms = 200",
                "inclinometer.heartbeat_ms",
            ),
            ("[inclinometer]\nsign = 0.5", "inclinometer.sign"),
            (
                "[inclinometer]\noffset_deg = nan",
                "inclinometer.offset_deg",
            ),
        ] {
            let file = CommissioningFile::parse(text).unwrap();
            let e = file.with_inclinometer(Config::DEFAULT).unwrap_err();
            assert_eq!(e.field, field, "{text}: {e}");
        }
        let e = CommissioningFile::parse("[inclinometer]\nnod = 3").unwrap_err();
        assert!(e.to_string().contains("nod"), "{e}");
    }

    /// A feedback that reads the swing in both vertical planes (the 3D crane's) needs a
    /// two-axis inclinometer; the lateral axis's fields are checked as the long one's.
    #[test]
    fn a_two_plane_feedback_needs_a_two_axis_inclinometer() {
        let stock = CommissioningFile::parse("").unwrap();
        let e = stock.with_inclinometer_of(Config::DEFAULT, 2).unwrap_err();
        assert_eq!(e.field, "inclinometer.axes", "{e}");
        let two = CommissioningFile::parse("[inclinometer]\naxes = 2\nlateral_offset_deg = 0.25")
            .unwrap();
        let c = two.with_inclinometer_of(Config::DEFAULT, 2).unwrap();
        let lateral = c.inclinometer().unwrap().lateral.unwrap();
        assert_eq!((lateral.sign, lateral.offset_deg), (1.0, 0.25));
        // The planar feedback takes a two-axis inclinometer and reads its long axis.
        assert!(two.with_inclinometer(Config::DEFAULT).is_ok());
        for (text, field) in [
            ("[inclinometer]\naxes = 3", "inclinometer.axes"),
            (
                "[inclinometer]\naxes = 2\nlateral_sign = 2.0",
                "inclinometer.lateral_sign",
            ),
            (
                "[inclinometer]\naxes = 2\nlateral_offset_deg = 91.0",
                "inclinometer.lateral_offset_deg",
            ),
        ] {
            let file = CommissioningFile::parse(text).unwrap();
            let e = file.with_inclinometer_of(Config::DEFAULT, 2).unwrap_err();
            assert_eq!(e.field, field, "{text}: {e}");
        }
    }

    #[test]
    fn the_defaults_are_the_stock_drives() {
        let c = config("").unwrap();
        assert_eq!(c.nodes, Config::DEFAULT.nodes);
        assert_eq!(c, Config::DEFAULT);
    }

    /// A row that names only its axis and node reads, through the defaults of the
    /// controller's `DriveSetup` and `MotionWindows`, to the stock drive; an
    /// `[inclinometer]` without keys to the stock inclinometer, and one with `axes = 2`
    /// to the stock lateral axis.
    #[test]
    fn rows_left_empty_are_the_controllers_stock_setups() {
        let rows =
            "[[drive]]\naxis = \"trolley\"\nnode = 1\n[[drive]]\naxis = \"winch\"\nnode = 2\n";
        assert_eq!(config(rows).unwrap(), Config::DEFAULT);
        let file = CommissioningFile::parse(&format!("{rows}[inclinometer]\n")).unwrap();
        let c = file.with_inclinometer(config(rows).unwrap()).unwrap();
        assert_eq!(c.inclinometer(), Some(&InclinometerSetup::STOCK));
        let two = CommissioningFile::parse("[inclinometer]\naxes = 2\nnode = 5").unwrap();
        let c = two.with_inclinometer_of(Config::DEFAULT, 2).unwrap();
        assert_eq!(c.inclinometer(), Some(&InclinometerSetup::STOCK_TWO_AXES));
        // A drive's key missing where it has no default is named by serde.
        let e = CommissioningFile::parse("[[drive]]\naxis = \"trolley\"\n").unwrap_err();
        assert_eq!(
            (e.field.as_str(), e.reason.as_str()),
            ("[drive]", "missing field `node`")
        );
    }

    #[test]
    fn a_file_sets_nodes_role_and_the_drum() {
        let c = config(
            "[controller]\nrole = \"slave\"\nnode = 32\n\n[[drive]]\naxis = \"winch\"\nnode = 5\nposition_scale = 2e-6\nposition_offset = 1.5\nvelocity_unit = \"um/s\"\n\n[[drive]]\naxis = \"trolley\"\nnode = 4\n",
        )
        .unwrap();
        assert_eq!(c.role, Role::Slave);
        assert_eq!(c.node, 32);
        let (trolley, winch) = (
            c.drive(Drive::Trolley).unwrap(),
            c.drive(Drive::Winch).unwrap(),
        );
        assert_eq!((trolley.node, winch.node), (4, 5));
        // The nodes in the file's order: the winch first.
        assert!(matches!(
            c.nodes,
            [
                Some(NodeSetup::Drive(Drive::Winch, _)),
                Some(NodeSetup::Drive(Drive::Trolley, _)),
                None,
                None
            ]
        ));
        assert_eq!(winch.position_scale, 2e-6);
        assert_eq!(winch.velocity_unit, Some(MICROMETRE_PER_SECOND));
    }

    #[test]
    fn bad_fields_are_named_with_their_reason() {
        let cases = [
            ("[controller]\nnode = 0\n", "controller.node"),
            ("[controller]\nheartbeat_ms = 15\n", "controller.heartbeat_ms"),
            ("[controller]\nrole = \"master\"\n", "controller.role"),
            ("[controller]\ntpdo_timeout_ms = 10\n", "controller.tpdo_timeout_ms"),
            ("[[drive]]\naxis = \"trolley\"\nnode = 1\n", "drive"),
            ("[[drive]]\naxis = \"trolley\"\nnode = 1\n[[drive]]\naxis = \"winch\"\nnode = 1\n", "drive[1].node"),
            ("[[drive]]\naxis = \"trolley\"\nnode = 16\n[[drive]]\naxis = \"winch\"\nnode = 2\n", "drive[0].node"),
            ("[[drive]]\naxis = \"trolley\"\nnode = 1\nmax_velocity = 2.0\n[[drive]]\naxis = \"winch\"\nnode = 2\n", "drive[0].max_velocity"),
            ("[[drive]]\naxis = \"trolley\"\nnode = 1\nmode = \"pv\"\n[[drive]]\naxis = \"winch\"\nnode = 2\n", "drive[0].profile_acceleration"),
            ("[[drive]]\naxis = \"trolley\"\nnode = 1\nvelocity_unit = \"mm/s\"\n[[drive]]\naxis = \"winch\"\nnode = 2\n", "drive[0].velocity_unit"),
            ("[[drive]]\naxis = \"trolley\"\nnode = 1\ncontroller_timeout_ms = 150\n[[drive]]\naxis = \"winch\"\nnode = 2\n", "drive[0].controller_timeout_ms"),
            ("[[drive]]\naxis = \"trolley\"\nnode = 1\n[[drive]]\naxis = \"winch\"\nnode = 2\nabort_connection_option = 0\n", "drive[1].abort_connection_option"),
            ("[[drive]]\naxis = \"trolley\"\nnode = 1\nbrake = true\n", "drive.brake"),
        ];
        for (text, field) in cases {
            let e = config(text).unwrap_err();
            assert!(
                e.field.starts_with(field) || e.field.ends_with(field.trim_start_matches("drive.")),
                "{text:?}: {e}"
            );
            assert!(!e.reason.is_empty());
        }
        // pv with a steep enough ramp is accepted.
        let c = config("[[drive]]\naxis = \"trolley\"\nnode = 1\nmode = \"pv\"\nprofile_acceleration = 30.0\n[[drive]]\naxis = \"winch\"\nnode = 2\n").unwrap();
        let trolley = c.drive(Drive::Trolley).unwrap();
        assert_eq!(trolley.mode, OperationMode::ProfileVelocity);
        assert_eq!(trolley.profile_ramp, Some(30_000_000));
    }

    /// Each `[controller]` key reaches its field of the controller's configuration (the
    /// role read as the controller's own `Role`), the cycle, the nodes and the thresholds
    /// stay the controller's, and a key the file cannot set (the controller's own names
    /// among them) is refused by name.
    #[test]
    fn each_controller_key_reaches_the_config() {
        let c = config("[controller]\nnode = 20\nrole = \"slave\"\nheartbeat_ms = 50\nheartbeat_timeout_ms = 400\ntpdo_timeout_ms = 60\nsdo_timeout_ms = 120\n").unwrap();
        assert_eq!(
            c,
            Config {
                node: 20,
                role: Role::Slave,
                heartbeat_period_ms: 50,
                heartbeat_timeout_ms: 400,
                tpdo_timeout_ms: 60,
                sdo_timeout_ms: 120,
                ..Config::DEFAULT
            }
        );
        for key in ["period_ms = 20", "heartbeat_period_ms = 100", "nodes = 2"] {
            let e = CommissioningFile::parse(&format!("[controller]\n{key}\n")).unwrap_err();
            let name = key.split(' ').next().unwrap();
            assert_eq!(
                (e.field.as_str(), e.reason.as_str()),
                (
                    format!("controller.{name}").as_str(),
                    format!("unknown field `{name}`, expected one of `node`, `role`, `heartbeat_ms`, `heartbeat_timeout_ms`, `tpdo_timeout_ms`, `sdo_timeout_ms`").as_str()
                )
            );
        }
    }

    /// The motion supervision windows are a drive row's (`controller::motion`): read as
    /// written, the stock ones where absent, and a window that cannot work is refused by
    /// name.
    #[test]
    fn a_drives_motion_windows_are_its_row() {
        let c = config("[[drive]]\naxis = \"trolley\"\nnode = 1\nstandstill_window = 0.01\nfollowing_window = 0.3\nfollowing_time_ms = 100\nin_place_window = 0.02\n[[drive]]\naxis = \"winch\"\nnode = 2\n").unwrap();
        let trolley = c.drive(Drive::Trolley).unwrap().motion;
        assert_eq!(
            (
                trolley.standstill,
                trolley.following,
                trolley.following_time_ms,
                trolley.in_place
            ),
            (0.01, 0.3, 100, 0.02)
        );
        assert_eq!(c.drive(Drive::Winch).unwrap().motion, MotionWindows::STOCK);
        let row = |field: &str| {
            format!("[[drive]]\naxis = \"trolley\"\nnode = 1\n{field}\n[[drive]]\naxis = \"winch\"\nnode = 2\n")
        };
        for (field, name) in [
            ("standstill_window = 0.0", "standstill_window"),
            // Ten increments of 1 µm: 10 µm; a window of 5 µm is the drive's noise.
            ("standstill_window = 5e-6", "standstill_window"),
            ("following_window = -0.1", "following_window"),
            ("velocity_window = nan", "velocity_window"),
            ("in_place_window = 0.0", "in_place_window"),
            ("following_drift = 1.0", "following_drift"),
            ("following_time_ms = 5", "following_time_ms"),
            ("standstill_delay_ms = 0", "standstill_delay_ms"),
        ] {
            let e = config(&row(field)).unwrap_err();
            assert_eq!(e.field, format!("drive[0].{name}"), "{field}: {e}");
        }
        // Every window's key reaches the controller's field of that meaning (the
        // windows are read into `MotionWindows` beside the row), in the second row too.
        let c = config("[[drive]]\naxis = \"trolley\"\nnode = 1\n[[drive]]\naxis = \"winch\"\nnode = 2\nstandstill_window = 0.011\nstandstill_delay_ms = 400\nfollowing_window = 0.21\nfollowing_drift = 0.06\nvelocity_window = 0.31\nfollowing_time_ms = 60\nin_place_window = 0.051\n").unwrap();
        assert_eq!(
            c.drive(Drive::Winch).unwrap().motion,
            MotionWindows {
                standstill: 0.011,
                standstill_delay_ms: 400,
                following: 0.21,
                following_drift: 0.06,
                velocity: 0.31,
                following_time_ms: 60,
                in_place: 0.051,
            }
        );
        assert_eq!(
            c.drive(Drive::Trolley).unwrap().motion,
            MotionWindows::STOCK
        );
        // A typo or the controller's own name is refused at its key, with the row's keys,
        // the drive's (`DriveSetup`'s) and the windows' listed; a bad value at its key.
        for (field, key, reason) in [
            ("standstil_window = 0.02", "standstil_window", "unknown field `standstil_window`, expected one of `axis`, `quick_stop_deceleration`, `max_velocity`, `velocity_unit`, `profile_acceleration`, `velocity_limit`, `acceleration_limit`, `node`, `mode`, `heartbeat_ms`, `controller_timeout_ms`, `quick_stop_option`, `abort_connection_option`, `position_scale`, `position_offset`, `standstill_window`, `standstill_delay_ms`, `following_window`, `following_drift`, `velocity_window`, `following_time_ms`, `in_place_window`"),
            ("in_place = 0.02", "in_place", "unknown field `in_place`, expected one of `axis`, `quick_stop_deceleration`, `max_velocity`, `velocity_unit`, `profile_acceleration`, `velocity_limit`, `acceleration_limit`, `node`, `mode`, `heartbeat_ms`, `controller_timeout_ms`, `quick_stop_option`, `abort_connection_option`, `position_scale`, `position_offset`, `standstill_window`, `standstill_delay_ms`, `following_window`, `following_drift`, `velocity_window`, `following_time_ms`, `in_place_window`"),
            ("following_window = \"x\"", "following_window", "invalid type: string \"x\", expected f64"),
            ("following_time_ms = 1.5", "following_time_ms", "invalid type: floating point `1.5`, expected u16"),
        ] {
            let e = CommissioningFile::parse(&row(field)).unwrap_err();
            assert_eq!(
                (e.field.as_str(), e.reason.as_str()),
                (format!("[drive].{key}").as_str(), reason),
                "{field}"
            );
        }
    }

    /// The 3D crane's file: a row per drive of the crane, in any order, each checked
    /// against its own limits; a row for a drive the crane lacks, or none for one it
    /// has, is refused with the row named.
    #[test]
    fn each_crane_takes_a_row_for_each_of_its_drives_and_no_other() {
        use controller::drive::SPATIAL;
        let lab = DriveLimits::LAB;
        let limits = [lab.trolley, lab.trolley, lab.winch];
        let spatial = "[[drive]]\naxis = \"trolley\"\nnode = 1\n\
                       [[drive]]\naxis = \"winch\"\nnode = 2\n\
                       [[drive]]\naxis = \"bridge\"\nnode = 4\nposition_offset = 1.5\n";
        let file = CommissioningFile::parse(spatial).unwrap();
        let c = file.config_for(SPATIAL, limits, 10).unwrap();
        let bridge = c.drive(Drive::Bridge).unwrap();
        assert_eq!((bridge.node, bridge.position_offset), (4, 1.5));
        assert_eq!(c.drive(Drive::Winch).unwrap().node, 2);
        // The file's order is the commissioning order.
        let order: Vec<u8> = c.nodes.iter().flatten().map(NodeSetup::node).collect();
        assert_eq!(order, [1, 2, 4]);
        // The planar crane has no bridge.
        let e = file.config(lab, 10).unwrap_err();
        assert_eq!(e.field, "drive[2].axis", "{e}");
        assert!(e.reason.contains("no bridge"), "{e}");
        // The 3D crane without its bridge: nothing would move x.
        let e = config_3d(
            "[[drive]]\naxis = \"trolley\"\nnode = 1\n[[drive]]\naxis = \"winch\"\nnode = 2\n",
        );
        assert!(e.reason.contains("bridge"), "{e}");
        // The bridge's own limit: a drive slower than its set points is refused.
        let e = config_3d(&format!("{spatial}max_velocity = 2.0\n"));
        assert_eq!(e.field, "drive[2].max_velocity", "{e}");

        fn config_3d(text: &str) -> SceneError {
            let lab = DriveLimits::LAB;
            CommissioningFile::parse(text)
                .unwrap()
                .config_for(SPATIAL, [lab.trolley, lab.trolley, lab.winch], 10)
                .unwrap_err()
        }
    }
}
