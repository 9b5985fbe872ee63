//! Which crane the log is of, and who is who on its bus: the scene says the crane (planar:
//! trolley and winch; 3D: bridge, trolley, hoist) and the cycle, its commissioning file
//! the node ids, the position scaling, the drives' limits and the inclinometer — the same
//! files the controller is built from.
//!
//! A frame's COB-ID is read by CiA 301's predefined connection set (function code and
//! node id). The DBC (`can/crane.dbc`) names the stock nodes' frames; a node the
//! commissioning file moves elsewhere is decoded by its stock node's message
//! ([`Crane::dbc_id`]), since the layout is the function's, not the node's.

use std::path::{Path, PathBuf};

use controller::drive::Drive;
use controller::setpoint::AxisLimits;
use scene::commissioning::CommissioningFile;
use scene::dispatch::{visit_crane, CraneVisitor, FirmwareCrane, FirmwareModel};
use scene::Scene;

/// The stock node ids the DBC's messages are written for (docs/COMMISSIONING.md).
const STOCK_CONTROLLER: u8 = 0x10;
const STOCK_INCLINOMETER: u8 = 3;
const STOCK_INCLINOMETER_2AXES: u8 = 5;

/// One drive of the crane, in the model's input order.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveInfo {
    /// Its axis' name: trolley, winch (hoist), bridge.
    pub name: &'static str,
    /// CANopen node id.
    pub node: u8,
    /// Metres per increment of position actual 0x6064.
    pub scale: f64,
    /// Metres at position actual 0.
    pub offset: f64,
    /// The set points' velocity limit, m/s.
    pub velocity_limit: f64,
    /// The set points' acceleration limit, m/s².
    pub acceleration_limit: f64,
    /// The stock node of its axis (the DBC's).
    stock: u8,
}

/// The inclinometer of the commissioning file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InclinometerInfo {
    /// CANopen node id.
    pub node: u8,
    /// 1 or 2 (slope lateral16 too).
    pub axes: u8,
    /// Degrees per unit of slope long16 / lateral16 (0x6000, 0.001° units).
    pub resolution_deg: f64,
    /// Swing = sign · (slope − offset), per axis.
    pub sign: [f64; 2],
    /// The slope at no swing, degrees, per axis.
    pub offset_deg: [f64; 2],
}

/// The crane of the log.
#[derive(Debug, Clone, PartialEq)]
pub struct Crane {
    /// The scene file.
    pub scene: PathBuf,
    /// The crane's name (`controller::crane::Crane::NAME`: "planar crane", "3D crane").
    pub kind: &'static str,
    /// Its swing planes, as many as the slopes its feedback reads (1 planar, 2 for the
    /// 3D crane).
    pub planes: usize,
    /// The controller's node id.
    pub controller: u8,
    /// The drives, in the model's input order.
    pub drives: Vec<DriveInfo>,
    /// The inclinometer's row (whether or not the scene reads it).
    pub inclinometer: InclinometerInfo,
    /// Whether the scene closes the loop with the inclinometer (a `[feedback]` section).
    pub feedback: bool,
    /// The cycle (SYNC period), s.
    pub period: f64,
    /// The controller's heartbeat period, s.
    pub heartbeat: f64,
    /// A drive whose heartbeat is older is lost, s.
    pub heartbeat_timeout: f64,
    /// A started drive whose TPDOs are older is lost, s.
    pub tpdo_timeout: f64,
}

/// What a node is on this crane's bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Role {
    /// The crane controller.
    Controller,
    /// Drive `i` of [`Crane::drives`].
    Drive(usize),
    /// The inclinometer.
    Inclinometer,
    /// A node the commissioning file does not name (a PLC, a tool, a stranger).
    Other,
}

/// A frame's meaning by CiA 301's predefined connection set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cob {
    /// 0x000.
    Nmt,
    /// 0x080.
    Sync,
    /// 0x080 + node.
    Emcy(u8),
    /// TPDO n (1..=4) of the node: 0x180, 0x280, 0x380, 0x480 + node.
    Tpdo(u8, u8),
    /// RPDO n (1..=4) of the node: 0x200, 0x300, 0x400, 0x500 + node.
    Rpdo(u8, u8),
    /// SDO server → client, 0x580 + node.
    SdoResponse(u8),
    /// SDO client → server, 0x600 + node.
    SdoRequest(u8),
    /// NMT error control (heartbeat, boot-up), 0x700 + node.
    Heartbeat(u8),
    /// Anything else (0x100 TIME, LSS, extended ids, …).
    Other,
}

impl Cob {
    /// The meaning of identifier `id` (extended ids are no CANopen frame here).
    pub fn of(id: u32, extended: bool) -> Cob {
        if extended || id > 0x7FF {
            return Cob::Other;
        }
        let node = (id & 0x7F) as u8;
        let function = id & 0x780;
        match (function, node) {
            (0x000, 0) => Cob::Nmt,
            (0x080, 0) => Cob::Sync,
            (0x080, n) => Cob::Emcy(n),
            (0x180 | 0x280 | 0x380 | 0x480, n) if n > 0 => {
                Cob::Tpdo(((function - 0x180) / 0x100 + 1) as u8, n)
            }
            (0x200 | 0x300 | 0x400 | 0x500, n) if n > 0 => {
                Cob::Rpdo(((function - 0x200) / 0x100 + 1) as u8, n)
            }
            (0x580, n) if n > 0 => Cob::SdoResponse(n),
            (0x600, n) if n > 0 => Cob::SdoRequest(n),
            (0x700, n) if n > 0 => Cob::Heartbeat(n),
            _ => Cob::Other,
        }
    }

    /// The node the frame is of (`None` for NMT, SYNC and others).
    pub fn node(self) -> Option<u8> {
        match self {
            Cob::Emcy(n)
            | Cob::Tpdo(_, n)
            | Cob::Rpdo(_, n)
            | Cob::SdoResponse(n)
            | Cob::SdoRequest(n)
            | Cob::Heartbeat(n) => Some(n),
            Cob::Nmt | Cob::Sync | Cob::Other => None,
        }
    }

    /// Whether the node itself sent it (EMCY, TPDO, SDO response, heartbeat), as opposed
    /// to a frame addressed to it.
    pub fn sent_by_node(self) -> bool {
        matches!(
            self,
            Cob::Emcy(_) | Cob::Tpdo(..) | Cob::SdoResponse(_) | Cob::Heartbeat(_)
        )
    }
}

/// What the report reads of a registered crane: its name, its drives in the model's
/// input order, its lab drives' limits, and the slopes its feedback reads.
struct Facts;

impl CraneVisitor for Facts {
    type Output = (&'static str, Vec<Drive>, Vec<AxisLimits>, u8);
    fn visit<K: FirmwareCrane<A>, const A: usize>(self, _: K::Model) -> Self::Output {
        (
            K::NAME,
            K::DRIVES.to_vec(),
            K::LAB_LIMITS.to_vec(),
            K::SWING_AXES,
        )
    }
}

impl Crane {
    /// The crane of `scene` with the commissioning file beside it (the stock one when
    /// there is none), as the controller's build reads them.
    pub fn load(scene_path: &Path) -> Result<Crane, String> {
        let scene =
            Scene::load(scene_path).map_err(|e| format!("{}: {e}", scene_path.display()))?;
        let file = CommissioningFile::for_scene(scene_path)
            .map_err(|e| format!("{}: commissioning file: {e}", scene_path.display()))?;
        let model = FirmwareModel::of(&scene.model).map_err(|_| {
            format!(
                "{}: a {} scene has no crane on a bus; give a crane's scene",
                scene_path.display(),
                scene.model.label()
            )
        })?;
        let (kind, drives, limits, planes) = visit_crane(model, Facts);
        let drives = drives
            .into_iter()
            .zip(limits)
            .map(|(axis, limit)| {
                let row = file.drives.iter().find(|d| d.axis == axis);
                let stock = axis.node();
                DriveInfo {
                    name: axis.name(),
                    node: row.map_or(stock, |r| r.setup.node),
                    scale: row.map_or(1e-6, |r| r.setup.position_scale),
                    offset: row.map_or(0.0, |r| r.setup.position_offset),
                    velocity_limit: row
                        .and_then(|r| r.velocity_limit)
                        .unwrap_or(limit.max_velocity),
                    acceleration_limit: row
                        .and_then(|r| r.acceleration_limit)
                        .unwrap_or(limit.max_acceleration),
                    stock,
                }
            })
            .collect();
        let i = file.inclinometer;
        let c = file.controller;
        Ok(Crane {
            scene: scene_path.to_path_buf(),
            kind,
            planes: usize::from(planes),
            controller: c.node,
            drives,
            inclinometer: InclinometerInfo {
                node: i.setup.node,
                axes: i.axes,
                resolution_deg: f64::from(i.setup.resolution) / 1000.0,
                sign: [i.setup.sign, i.lateral.sign],
                offset_deg: [i.setup.offset_deg, i.lateral.offset_deg],
            },
            feedback: scene.feedback.is_some(),
            period: scene.solver.h,
            heartbeat: f64::from(c.heartbeat_ms) / 1000.0,
            heartbeat_timeout: f64::from(c.heartbeat_timeout_ms) / 1000.0,
            tpdo_timeout: f64::from(c.tpdo_timeout_ms) / 1000.0,
        })
    }

    /// What node `node` is on this bus.
    pub fn role(&self, node: u8) -> Role {
        if node == self.controller {
            Role::Controller
        } else if let Some(i) = self.drives.iter().position(|d| d.node == node) {
            Role::Drive(i)
        } else if node == self.inclinometer.node {
            Role::Inclinometer
        } else {
            Role::Other
        }
    }

    /// A node's name in the report: "controller", "trolley drive", "inclinometer", …
    pub fn node_name(&self, node: u8) -> String {
        match self.role(node) {
            Role::Controller => format!("controller (node {node})"),
            Role::Drive(i) => format!("{} drive (node {node})", self.drives[i].name),
            Role::Inclinometer => format!("inclinometer (node {node})"),
            Role::Other => format!("node {node} (not in the commissioning file)"),
        }
    }

    /// The DBC identifier that describes frame `id` on this bus: a node of the
    /// commissioning file at another id than the stock one is decoded by its stock
    /// node's message.
    pub fn dbc_id(&self, id: u32) -> u32 {
        let cob = Cob::of(id, false);
        let Some(node) = cob.node() else {
            return id;
        };
        let stock = match self.role(node) {
            Role::Controller => STOCK_CONTROLLER,
            Role::Drive(i) => self.drives[i].stock,
            Role::Inclinometer if self.inclinometer.axes == 2 => STOCK_INCLINOMETER_2AXES,
            Role::Inclinometer => STOCK_INCLINOMETER,
            Role::Other => node,
        };
        (id & !0x7F) | u32::from(stock)
    }

    /// Drive index of `node`, if it is one of the crane's drives.
    pub fn drive_of(&self, node: u8) -> Option<usize> {
        match self.role(node) {
            Role::Drive(i) => Some(i),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::firmware::root;

    #[test]
    fn the_planar_and_the_3d_crane_from_their_scenes() {
        let planar = Crane::load(&root().join("scenes/paper-crane.toml")).unwrap();
        assert_eq!(planar.kind, "planar crane");
        let nodes: Vec<_> = planar.drives.iter().map(|d| (d.name, d.node)).collect();
        assert_eq!(nodes, [("trolley", 1), ("winch", 2)]);
        assert_eq!((planar.controller, planar.period), (0x10, 0.01));
        assert_eq!(planar.drives[0].velocity_limit, 3.0);
        let spatial = Crane::load(&root().join("scenes/crane3d/crane3d.toml")).unwrap();
        let nodes: Vec<_> = spatial.drives.iter().map(|d| (d.name, d.node)).collect();
        assert_eq!(nodes, [("bridge", 4), ("trolley", 1), ("winch", 2)]);
        assert_eq!(spatial.inclinometer.axes, 2);
        assert!(Crane::load(&root().join("scenes/mass-on-car.toml")).is_err());
    }

    #[test]
    fn cob_ids_by_the_predefined_connection_set() {
        assert_eq!(Cob::of(0x000, false), Cob::Nmt);
        assert_eq!(Cob::of(0x080, false), Cob::Sync);
        assert_eq!(Cob::of(0x090, false), Cob::Emcy(0x10));
        assert_eq!(Cob::of(0x190, false), Cob::Tpdo(1, 0x10));
        assert_eq!(Cob::of(0x282, false), Cob::Tpdo(2, 2));
        assert_eq!(Cob::of(0x310, false), Cob::Rpdo(2, 0x10));
        assert_eq!(Cob::of(0x410, false), Cob::Rpdo(3, 0x10));
        assert_eq!(Cob::of(0x5A0, false), Cob::SdoResponse(0x20));
        assert_eq!(Cob::of(0x701, false), Cob::Heartbeat(1));
        assert_eq!(Cob::of(0x701, true), Cob::Other);
    }

    #[test]
    fn a_drive_at_another_node_is_decoded_by_its_stock_message() {
        let mut crane = Crane::load(&root().join("scenes/paper-crane.toml")).unwrap();
        crane.drives[0].node = 7;
        assert_eq!(crane.dbc_id(0x187), 0x181);
        assert_eq!(crane.dbc_id(0x207), 0x201);
        assert_eq!(crane.dbc_id(0x182), 0x182);
        assert_eq!(crane.dbc_id(0x080), 0x080);
        assert_eq!(crane.dbc_id(0x190), 0x190);
    }
}
