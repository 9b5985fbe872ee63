//! Commissioning a CiA 402 drive over SDO, CiA 302 style: whenever the drive boots (or
//! is first found), check what it is, write its configuration from the commissioning
//! table and read every value back, confirm the mode of operation, and only then start
//! it (NMT, addressed to that node). A drive that fails any step stays disabled: it is
//! never sent a set point.
//!
//! The sequence, one SDO exchange per cycle (docs/COMMISSIONING.md lists it with values):
//! 1. NMT *enter pre-operational* to the node (manager role): a drive found stopped
//!    answers no SDO, and only pre-operational accepts PDO mapping;
//! 2. read 0x1000 *device type*: the low word must be 402 (0x0192);
//! 3. read 0x1018:1..=4 *identity* (vendor, product, revision, serial; logged);
//! 4. write, then read back: 0x6060 *modes of operation*, 0x60C2 *interpolation time
//!    period*, RPDO1 (0x1400/0x1600: controlword 0x6040, target velocity 0x60FF), TPDO1
//!    (0x1800/0x1A00: statusword 0x6041, velocity actual 0x606C), TPDO2 (0x1801/0x1A01:
//!    position actual 0x6064, mode display 0x6061), all synchronous on every SYNC;
//!    heartbeat producer 0x1017 and consumer 0x1016 (the drive watches the controller),
//!    quick-stop option 0x605A and deceleration 0x6085, max motor speed 0x6080, and
//!    optionally the velocity unit 0x60A9 and the profile ramps 0x6083/0x6084 (pv only);
//! 5. read 0x6061 *modes of operation display* until it shows the mode (a few tries);
//! 6. NMT *start remote node* to that node (manager role).

use heapless::Vec;

use crate::canopen::cob;
use crate::canopen::nmt::{self, NmtCommand};
use crate::canopen::od::{self, device, Entry};
use crate::canopen::sdo::{abort, Event, Object, SdoClient, SdoError};
use crate::cia402::pdo as cia402_pdo;
use crate::cia410;
use crate::drive::Drive;
use crate::frame::CanFrame;
use crate::motion::MotionWindows;

/// CiA 402 mode of operation (0x6060) the drive runs in. With feature `serde`, a
/// commissioning file's `mode = "csv"` or `"pv"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Deserialize))]
#[repr(i8)]
pub enum OperationMode {
    /// Cyclic synchronous velocity (9): the drive follows 0x60FF every SYNC without
    /// ramps of its own — the mode for set points the master computes every cycle.
    #[cfg_attr(feature = "serde", serde(rename = "csv"))]
    CyclicSynchronousVelocity = 9,
    /// Profile velocity (3), only for drives without CSV: every target passes the
    /// drive's own ramp 0x6083/0x6084, which must then be steeper than anything the
    /// inverse model asks (docs/COMMISSIONING.md).
    #[cfg_attr(feature = "serde", serde(rename = "pv"))]
    ProfileVelocity = 3,
}

impl OperationMode {
    /// The value of 0x6060 / 0x6061.
    #[must_use]
    pub const fn code(self) -> i8 {
        self as i8
    }
}

/// What the controller writes into one drive: a row of the commissioning file.
///
/// With feature `serde`, a `[[drive]]` row's keys that are fields of this type in its
/// own units: `node` (required), `mode`, `heartbeat_ms`, `controller_timeout_ms`,
/// `quick_stop_option`, `abort_connection_option`, `position_scale`, `position_offset`
/// ([`DriveSetup::stock`]'s value for a key left out). The row gives the drive's
/// deceleration, its max velocity and its profile ramp in m/s and m/s², the velocity
/// unit by name, and checks them against the crane's set-point limits, which a row does
/// not know (`max_velocity` left out is 1.1 times the crane's limit): those four fields
/// are skipped here, zero or none until the file's reader sets them; the motion windows
/// are read beside the row into `motion` ([`MotionWindows`], the stock ones until then).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Deserialize),
    serde(deny_unknown_fields)
)]
pub struct DriveSetup {
    /// CANopen node id (1..=127).
    pub node: u8,
    /// Mode of operation.
    #[cfg_attr(feature = "serde", serde(default = "stock_row::mode"))]
    pub mode: OperationMode,
    /// The drive's heartbeat producer time 0x1017, ms.
    #[cfg_attr(feature = "serde", serde(default = "stock_row::heartbeat_ms"))]
    pub heartbeat_ms: u16,
    /// The drive's consumer heartbeat time for the controller (0x1016:1), ms: the drive
    /// stops by itself if the controller falls silent this long.
    #[cfg_attr(feature = "serde", serde(default = "stock_row::controller_timeout_ms"))]
    pub controller_timeout_ms: u16,
    /// Quick-stop option code 0x605A (6: brake on the quick-stop ramp and stay in
    /// *quick stop active*, where the controller holds a halted crane).
    #[cfg_attr(feature = "serde", serde(default = "stock_row::quick_stop_option"))]
    pub quick_stop_option: i16,
    /// Abort connection option code 0x6007: what the drive does when it loses the
    /// controller (its heartbeat consumer trips, bus-off) or is switched out of
    /// *operational* — 3: quick stop, which the controller's enable sequence leaves again
    /// by itself; a drive's default is often 1 (fault), which a network stop and start at
    /// rest would then turn into a fault needing a reset.
    #[cfg_attr(
        feature = "serde",
        serde(default = "stock_row::abort_connection_option")
    )]
    pub abort_connection_option: i16,
    /// Quick-stop deceleration 0x6085, drive acceleration units.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub quick_stop_deceleration: u32,
    /// Max motor speed 0x6080, drive velocity units: the drive's own last limit.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub max_velocity: u32,
    /// SI unit of velocity 0x60A9, written when given (µm/s is `0xFA01_0300`).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub velocity_unit: Option<u32>,
    /// Profile acceleration and deceleration 0x6083/0x6084 (profile velocity mode only).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub profile_ramp: Option<u32>,
    /// Metres per increment of position actual 0x6064 (the winch: the drum's scaling).
    #[cfg_attr(feature = "serde", serde(default = "stock_row::position_scale"))]
    pub position_scale: f64,
    /// Metres at position actual 0 (trolley position; rope length for the winch).
    #[cfg_attr(feature = "serde", serde(default = "stock_row::position_offset"))]
    pub position_offset: f64,
    /// How far the drive may be from what the controller commanded (nothing is written
    /// into the drive: the controller supervises its motion, [`crate::motion`]).
    #[cfg_attr(feature = "serde", serde(skip, default = "stock_row::motion"))]
    pub motion: MotionWindows,
}

/// serde's value of a key a commissioning file's `[[drive]]` row leaves out: the stock
/// drive's ([`DriveSetup::stock`]), so that the defaults are written once.
#[cfg(feature = "serde")]
mod stock_row {
    use super::{DriveSetup, MotionWindows, OperationMode};

    /// The stock drive; its node and max velocity are the row's.
    const STOCK: DriveSetup = DriveSetup::stock(0, 0);

    pub(super) fn mode() -> OperationMode {
        STOCK.mode
    }
    pub(super) fn heartbeat_ms() -> u16 {
        STOCK.heartbeat_ms
    }
    pub(super) fn controller_timeout_ms() -> u16 {
        STOCK.controller_timeout_ms
    }
    pub(super) fn quick_stop_option() -> i16 {
        STOCK.quick_stop_option
    }
    pub(super) fn abort_connection_option() -> i16 {
        STOCK.abort_connection_option
    }
    pub(super) fn position_scale() -> f64 {
        STOCK.position_scale
    }
    pub(super) fn position_offset() -> f64 {
        STOCK.position_offset
    }
    pub(super) fn motion() -> MotionWindows {
        STOCK.motion
    }
}

impl DriveSetup {
    /// A stock CiA 402 drive at `node` in CSV, units of 1 µm and 1 µm/s, heartbeat every
    /// 100 ms, stopping by itself 300 ms after the controller's heartbeat stops, quick
    /// stop at 6 m/s², at most `max_velocity` m/s.
    #[must_use]
    pub const fn stock(node: u8, max_velocity: u32) -> Self {
        Self {
            node,
            mode: OperationMode::CyclicSynchronousVelocity,
            heartbeat_ms: 100,
            controller_timeout_ms: 300,
            quick_stop_option: 6,
            abort_connection_option: 3,
            quick_stop_deceleration: 6_000_000,
            max_velocity,
            velocity_unit: None,
            profile_ramp: None,
            position_scale: 1e-6,
            position_offset: 0.0,
            motion: MotionWindows::STOCK,
        }
    }

    /// Metres of position actual 0x6064 `increments`, through the commissioned scaling:
    /// the trolley's position, the winch's rope length. (The one place the scaling is
    /// applied: the plausibility check, the measured crane, the supervision and the
    /// reset all read a drive's position through it.)
    #[must_use]
    pub fn metres(&self, increments: i32) -> f64 {
        self.position_offset + self.position_scale * f64::from(increments)
    }

    /// The default trolley drive: node 1, 3.3 m/s.
    pub const TROLLEY: Self = Self::stock(1, 3_300_000);
    /// The default winch drive: node 2, 2.2 m/s.
    pub const WINCH: Self = Self::stock(2, 2_200_000);
}

/// The most nodes the controller commissions: the 3D crane's three drives and its
/// inclinometer (the planar crane uses three of the four places). Each place costs the
/// controller about 0.75 KiB of RAM (a node's commissioning table and state).
pub const MAX_NODES: usize = 4;

/// A node the controller commissions and supervises: a row of the commissioning file.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NodeSetup {
    /// A CiA 402 drive and the axis (the model's input) it drives.
    Drive(Drive, DriveSetup),
    /// The CiA 410 inclinometer on the hook block, for the state feedback.
    Inclinometer(InclinometerSetup),
}

impl NodeSetup {
    /// Its node id.
    #[must_use]
    pub const fn node(&self) -> u8 {
        match self {
            Self::Drive(_, d) => d.node,
            Self::Inclinometer(i) => i.node,
        }
    }
}

/// CiA 402 device profile number, the low word of 0x1000.
pub const CIA402_PROFILE: u32 = 402;
/// CiA 410 (inclinometer) device profile number, the low word of 0x1000.
pub const CIA410_PROFILE: u32 = 410;

/// A device the controller commissions: a CiA 402 drive ([`DriveSetup`]) or the CiA 410
/// inclinometer ([`InclinometerSetup`]). The sequence is the same; what is checked and
/// written differs.
pub trait Device {
    /// The device profile the low word of 0x1000 must name.
    const PROFILE: u32;
    /// Its node id.
    fn node(&self) -> u8;
    /// Everything written into it, in order, for a controller at node `controller`
    /// cycling every `period_ms`.
    fn configuration(&self, controller: u8, period_ms: u8) -> Vec<Write, MAX_WRITES>;
    /// The mode of operation 0x6061 must confirm before the device is started (drives).
    fn confirmed_mode(&self) -> Option<i8>;
    /// Its heartbeat producer time 0x1017, ms.
    fn heartbeat_ms(&self) -> u16;
}

impl Device for DriveSetup {
    const PROFILE: u32 = CIA402_PROFILE;
    fn node(&self) -> u8 {
        self.node
    }
    fn configuration(&self, controller: u8, period_ms: u8) -> Vec<Write, MAX_WRITES> {
        configuration(self, controller, period_ms)
    }
    fn confirmed_mode(&self) -> Option<i8> {
        Some(self.mode.code())
    }
    fn heartbeat_ms(&self) -> u16 {
        self.heartbeat_ms
    }
}

/// The inclinometer on the hook block (CiA 410): a row of the commissioning file.
///
/// With feature `serde`, the `[inclinometer]` section's keys of its long axis (a key
/// left out: [`InclinometerSetup::STOCK`]'s value); the section's second axis is read
/// beside it ([`LateralAxis`]) and kept where the section's `axes = 2`, so `lateral` is
/// skipped here.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Deserialize),
    serde(deny_unknown_fields, default = "stock_inclinometer")
)]
pub struct InclinometerSetup {
    /// CANopen node id (1..=127).
    pub node: u8,
    /// Resolution 0x6000 of *slope long16* (0x6010), 0.001°: 10 is 0.01° (CiA 410's
    /// usual choice; ±327° fit the 16 bits). The file's `resolution_mdeg`, its unit.
    #[cfg_attr(feature = "serde", serde(rename = "resolution_mdeg"))]
    pub resolution: u16,
    /// Its heartbeat producer time 0x1017, ms.
    pub heartbeat_ms: u16,
    /// Radians of swing angle per degree of slope, with the sign: +1° of slope is
    /// `sign · 1°` of the angle φ of Eq. 20 (how the sensor is mounted).
    pub sign: f64,
    /// The slope at φ = 0 (the load hanging still), degrees: the mounting offset.
    pub offset_deg: f64,
    /// The second axis, *slope lateral16* (0x6020), of a two-axis inclinometer: the 3D
    /// crane's swing across the bridge (the rope's slope in the y–z plane). `None`: one
    /// axis (the planar crane's).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub lateral: Option<LateralAxis>,
}

/// serde's value of a key the `[inclinometer]` section leaves out: the stock one's.
#[cfg(feature = "serde")]
fn stock_inclinometer() -> InclinometerSetup {
    InclinometerSetup::STOCK
}

/// How *slope lateral16* becomes the swing in the y–z plane: its sign and mounting
/// offset, as for the long axis.
///
/// With feature `serde`, the `[inclinometer]` section's `lateral_sign` and
/// `lateral_offset_deg` (a key left out: [`InclinometerSetup::STOCK_TWO_AXES`]' value).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Deserialize),
    serde(deny_unknown_fields, default = "stock_lateral")
)]
pub struct LateralAxis {
    /// +1° of slope is `sign · 1°` of the swing.
    #[cfg_attr(feature = "serde", serde(rename = "lateral_sign"))]
    pub sign: f64,
    /// The slope with the load hanging still, degrees.
    #[cfg_attr(feature = "serde", serde(rename = "lateral_offset_deg"))]
    pub offset_deg: f64,
}

/// serde's value of a lateral key the `[inclinometer]` section leaves out: the stock
/// two-axis inclinometer's.
#[cfg(feature = "serde")]
fn stock_lateral() -> LateralAxis {
    LateralAxis::STOCK
}

impl LateralAxis {
    /// The stock two-axis inclinometer's lateral axis: its slope is the swing.
    pub const STOCK: Self = Self {
        sign: 1.0,
        offset_deg: 0.0,
    };
}

/// The swing angles an inclinometer measured, rad: in the plane of the long axis (the
/// planar crane's φ of Eq. 20; the 3D crane's x–z plane), and across it (the 3D
/// crane's y–z plane) where the inclinometer has two axes.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Swing {
    /// From *slope long16*.
    pub long: f64,
    /// From *slope lateral16*.
    pub lateral: Option<f64>,
}

impl InclinometerSetup {
    /// A stock one-axis CiA 410 inclinometer at node 3: 0.01°, heartbeat every 100 ms,
    /// mounted so that its slope is φ.
    pub const STOCK: Self = Self {
        node: 3,
        resolution: 10,
        heartbeat_ms: 100,
        sign: 1.0,
        offset_deg: 0.0,
        lateral: None,
    };

    /// A stock two-axis CiA 410 inclinometer (the 3D crane's) at node 5: as
    /// [`InclinometerSetup::STOCK`], its lateral slope the swing across the bridge. A node
    /// of its own, so that its 4-byte TPDO1 (0x185) and the one-axis sensor's 2-byte one
    /// (0x183) are each one message of `can/crane.dbc`.
    pub const STOCK_TWO_AXES: Self = Self {
        node: 5,
        lateral: Some(LateralAxis::STOCK),
        ..Self::STOCK
    };

    /// The stock inclinometer with `axes` slopes: [`InclinometerSetup::STOCK`] for one,
    /// [`InclinometerSetup::STOCK_TWO_AXES`] for two (a crane's
    /// [`crate::crane::Crane::SWING_AXES`]).
    #[must_use]
    pub const fn stock(axes: u8) -> Self {
        if axes >= 2 {
            Self::STOCK_TWO_AXES
        } else {
            Self::STOCK
        }
    }

    /// The swing angle φ, rad, from a *slope long16* value.
    #[must_use]
    pub fn angle(&self, slope: i16) -> f64 {
        self.degrees_to_angle(slope, self.sign, self.offset_deg)
    }

    /// The swing angles from a TPDO1's slopes ([`cia410::Slopes`]): the lateral one
    /// where both the setup and the frame have it.
    #[must_use]
    pub fn swing(&self, slopes: cia410::Slopes) -> Swing {
        Swing {
            long: self.angle(slopes.long),
            lateral: match (self.lateral, slopes.lateral) {
                (Some(axis), Some(slope)) => {
                    Some(self.degrees_to_angle(slope, axis.sign, axis.offset_deg))
                }
                _ => None,
            },
        }
    }

    fn degrees_to_angle(&self, slope: i16, sign: f64, offset_deg: f64) -> f64 {
        let degrees = f64::from(slope) * f64::from(self.resolution) * 1e-3;
        (sign * (degrees - offset_deg)).to_radians()
    }

    /// Whether TPDO1 maps both slopes.
    #[must_use]
    pub fn two_axes(&self) -> bool {
        self.lateral.is_some()
    }
}

impl Device for InclinometerSetup {
    const PROFILE: u32 = CIA410_PROFILE;
    fn node(&self) -> u8 {
        self.node
    }
    /// 0x6000 *resolution*, TPDO1 (0x1800/0x1A00: *slope long16* 0x6010, and *slope
    /// lateral16* 0x6020 for two axes) synchronous on every SYNC, heartbeat producer
    /// 0x1017.
    fn configuration(&self, _controller: u8, _period_ms: u8) -> Vec<Write, MAX_WRITES> {
        let mut writes = Vec::new();
        let _ = writes.push(w(device::RESOLUTION, u32::from(self.resolution)));
        let mapping: &[u32] = if self.two_axes() {
            &cia410::TPDO1_MAPPING_TWO_AXES
        } else {
            &cia410::TPDO1_MAPPING
        };
        pdo(
            &mut writes,
            od::TPDO1_COMMUNICATION,
            od::TPDO1_MAPPING,
            u32::from(cob::TPDO1) + u32::from(self.node),
            mapping,
        );
        let _ = writes.push(w(device::PRODUCER_HEARTBEAT, u32::from(self.heartbeat_ms)));
        writes
    }
    fn confirmed_mode(&self) -> Option<i8> {
        None
    }
    fn heartbeat_ms(&self) -> u16 {
        self.heartbeat_ms
    }
}

/// One value to write (and read back): object, value, size in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Write {
    /// Where.
    pub object: Object,
    /// The value, little endian in `size` bytes.
    pub value: u32,
    /// 1, 2 or 4.
    pub size: u8,
}

/// `value` into `entry`, in its data type's size.
const fn w(entry: Entry, value: u32) -> Write {
    Write {
        object: entry.object,
        value,
        size: entry.size(),
    }
}

/// The most writes a drive's configuration takes.
pub const MAX_WRITES: usize = 40;

/// A PDO's communication (0x1400/0x1800 + n) and mapping (0x1600/0x1A00 + n) writes, in
/// the order CiA 301 requires: disable (COB-ID bit 31), clear the mapping, map, set the
/// count, the transmission type (1: synchronous, every SYNC), enable.
fn pdo(writes: &mut Vec<Write, MAX_WRITES>, comm: u16, map: u16, cob: u32, entries: &[u32]) {
    let mut push = |x| {
        // The configuration is built from a fixed list that fits MAX_WRITES.
        let _ = writes.push(x);
    };
    push(w(od::pdo_cob_id(comm), COB_ID_NOT_VALID | cob));
    push(w(od::pdo_mapped_count(map), 0));
    for (sub, entry) in (1u8..).zip(entries) {
        push(w(od::pdo_mapped(map, sub), *entry));
    }
    push(w(od::pdo_mapped_count(map), entries.len() as u32));
    push(w(od::pdo_transmission_type(comm), SYNCHRONOUS));
    push(w(od::pdo_cob_id(comm), cob));
}

/// A PDO's COB-ID with bit 31 set: the PDO is not valid (CiA 301), so that it may be
/// mapped.
const COB_ID_NOT_VALID: u32 = 0x8000_0000;

/// The transmission type of a synchronous PDO sent on every SYNC (CiA 301).
const SYNCHRONOUS: u32 = 1;

/// The interpolation time index 0x60C2:2 for a period in ms: 10^-3 s.
const MILLISECONDS: i8 = -3;

/// Everything written into a drive, in order, for a controller at node `controller`
/// cycling every `period_ms`.
#[must_use]
pub fn configuration(setup: &DriveSetup, controller: u8, period_ms: u8) -> Vec<Write, MAX_WRITES> {
    let n = u32::from(setup.node);
    let mut writes = Vec::new();
    let mode = setup.mode.code() as u8;
    let fixed = [
        w(device::MODES_OF_OPERATION, u32::from(mode)),
        w(device::INTERPOLATION_PERIOD, u32::from(period_ms)),
        w(device::INTERPOLATION_INDEX, u32::from(MILLISECONDS as u8)),
    ];
    for x in fixed {
        let _ = writes.push(x);
    }
    // RPDO1: controlword (0x6040, 16 bit), target velocity (0x60FF, 32 bit).
    pdo(
        &mut writes,
        od::RPDO1_COMMUNICATION,
        od::RPDO1_MAPPING,
        u32::from(cob::RPDO1) + n,
        &cia402_pdo::RPDO1_MAPPING,
    );
    // TPDO1: statusword (0x6041), velocity actual (0x606C).
    pdo(
        &mut writes,
        od::TPDO1_COMMUNICATION,
        od::TPDO1_MAPPING,
        u32::from(cob::TPDO1) + n,
        &cia402_pdo::TPDO1_MAPPING,
    );
    // TPDO2: position actual (0x6064), modes of operation display (0x6061, 8 bit).
    pdo(
        &mut writes,
        od::TPDO2_COMMUNICATION,
        od::TPDO2_MAPPING,
        u32::from(cob::TPDO2) + n,
        &cia402_pdo::TPDO2_MAPPING,
    );
    let rest = [
        w(device::PRODUCER_HEARTBEAT, u32::from(setup.heartbeat_ms)),
        w(
            device::CONSUMER_HEARTBEAT,
            (u32::from(controller) << 16) | u32::from(setup.controller_timeout_ms),
        ),
        w(
            device::QUICK_STOP_OPTION,
            u32::from(setup.quick_stop_option as u16),
        ),
        w(
            device::ABORT_CONNECTION_OPTION,
            u32::from(setup.abort_connection_option as u16),
        ),
        w(
            device::QUICK_STOP_DECELERATION,
            setup.quick_stop_deceleration,
        ),
        w(device::MAX_MOTOR_SPEED, setup.max_velocity),
    ];
    for x in rest {
        let _ = writes.push(x);
    }
    if let Some(unit) = setup.velocity_unit {
        let _ = writes.push(w(device::VELOCITY_UNIT, unit));
    }
    if let (OperationMode::ProfileVelocity, Some(ramp)) = (setup.mode, setup.profile_ramp) {
        let _ = writes.push(w(device::PROFILE_ACCELERATION, ramp));
        let _ = writes.push(w(device::PROFILE_DECELERATION, ramp));
    }
    writes
}

/// Why commissioning a drive failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CommissioningError {
    /// A transfer failed (abort by the drive, timeout, protocol).
    Sdo(SdoError),
    /// 0x1000 does not name the device's profile (CiA 402, CiA 410).
    DeviceType {
        /// What it says.
        found: u32,
    },
    /// A value read back differs from the one written.
    ReadBack {
        /// Where.
        object: Object,
        /// Written.
        wrote: u32,
        /// Read.
        read: u32,
    },
    /// 0x6061 did not show the commissioned mode.
    Mode {
        /// What it showed.
        found: i8,
    },
    /// The device never answered within the boot time (CiA 302's 0x1F89): not
    /// connected, not powered, or at another node id.
    NeverAppeared {
        /// How long it was looked for, ms.
        waited_ms: u32,
    },
}

impl CommissioningError {
    /// The object concerned.
    #[must_use]
    pub fn object(&self) -> Object {
        match *self {
            Self::Sdo(e) => e.object(),
            Self::DeviceType { .. } => device::DEVICE_TYPE.object,
            Self::ReadBack { object, .. } => object,
            Self::Mode { .. } => device::MODES_DISPLAY.object,
            // What the presence check reads.
            Self::NeverAppeared { .. } => device::DEVICE_TYPE.object,
        }
    }

    /// The EMCY's reason byte (docs/COMMANDS.md): 1 aborted by the drive, 2 timeout,
    /// 3 protocol error, 4 wrong device type, 5 read-back differs, 6 mode not confirmed,
    /// 7 never appeared within the boot time.
    #[must_use]
    pub fn reason(&self) -> u8 {
        match self {
            Self::Sdo(SdoError::Aborted { .. }) => 1,
            Self::Sdo(SdoError::Timeout { .. }) => 2,
            Self::Sdo(SdoError::Protocol { .. }) => 3,
            Self::DeviceType { .. } => 4,
            Self::ReadBack { .. } => 5,
            Self::Mode { .. } => 6,
            Self::NeverAppeared { .. } => 7,
        }
    }

    /// The SDO abort code, if the failure was an SDO transfer's (0 otherwise).
    #[must_use]
    pub fn abort_code(&self) -> u32 {
        match self {
            Self::Sdo(e) => e.code(),
            // Its presence checks timed out, as CiA 301 has a client say it.
            Self::NeverAppeared { .. } => abort::TIMEOUT,
            _ => 0,
        }
    }
}

/// Where commissioning stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Phase {
    /// Not heard of: the presence check (reading 0x1000) is retried now and then.
    Absent,
    /// Running step `step`.
    Running,
    /// Configured, confirmed and started: the drive may be enabled.
    Done,
    /// Failed: the drive stays disabled until it boots again or a reset.
    Failed(CommissioningError),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    DeviceType,
    PreOperational,
    Identity(u8),
    Write(usize),
    ReadBack(usize),
    Mode(u8),
    Start,
}

/// What a commissioning step asks of the controller.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Progress {
    /// Transmit this frame.
    Send(CanFrame),
    /// The drive is commissioned and (manager role) started.
    Done,
    /// Commissioning failed; transmit `abort` if given. The drive stays disabled.
    Failed {
        /// Why.
        error: CommissioningError,
        /// An SDO abort to send.
        abort: Option<CanFrame>,
    },
}

/// Tries of reading 0x6061 before the mode counts as not confirmed (a drive may take a
/// few milliseconds to switch).
const MODE_TRIES: u8 = 5;

/// The commissioning of one device (a drive unless said otherwise).
#[derive(Debug, Clone, PartialEq)]
pub struct Commissioning<D = DriveSetup> {
    setup: D,
    writes: Vec<Write, MAX_WRITES>,
    /// Whether the controller is NMT manager (it switches and starts the drive).
    manager: bool,
    sdo: SdoClient,
    phase: Phase,
    step: Step,
    /// An NMT step is taken on the next poll (it has no answer to wait for).
    nmt_due: bool,
    identity: [u32; 4],
    absent_since_ms: Option<u64>,
    /// When the controller began to look for a device never heard of, ms.
    looking_since_ms: Option<u64>,
    /// The device has answered or spoken since the controller started.
    heard: bool,
    /// A device not heard of within this is a failure, ms ([`Commissioning::with_boot_time`]).
    boot_time_ms: u32,
    /// When the controller last sent it NMT *start*, ms ([`Commissioning::start`]).
    started_ms: Option<u64>,
}

/// How often an absent drive is looked for, ms.
pub const PRESENCE_RETRY_MS: u64 = 1_000;

impl<D: Device> Commissioning<D> {
    /// The commissioning of the device `setup` for a controller at `controller` cycling
    /// every `period_ms` ms; `manager`: the controller is NMT manager.
    #[must_use]
    pub fn new(
        setup: D,
        controller: u8,
        period_ms: u8,
        manager: bool,
        sdo_timeout_ms: u32,
    ) -> Self {
        Self {
            writes: setup.configuration(controller, period_ms),
            sdo: SdoClient::new(setup.node(), sdo_timeout_ms),
            setup,
            manager,
            phase: Phase::Absent,
            step: Step::DeviceType,
            nmt_due: false,
            identity: [0; 4],
            absent_since_ms: None,
            looking_since_ms: None,
            heard: false,
            boot_time_ms: u32::MAX,
            started_ms: None,
        }
    }

    /// With a boot time: a device not heard of `ms` after the controller began to look
    /// for it fails with [`CommissioningError::NeverAppeared`] (CiA 302's 0x1F89).
    #[must_use]
    pub fn with_boot_time(mut self, ms: u32) -> Self {
        self.boot_time_ms = ms;
        self
    }

    /// The table row.
    #[must_use]
    pub fn setup(&self) -> &D {
        &self.setup
    }

    /// Where it stands.
    #[must_use]
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Vendor, product, revision and serial number as read from 0x1018.
    #[must_use]
    pub fn identity(&self) -> [u32; 4] {
        self.identity
    }

    /// The COB-ID of the drive's SDO responses.
    #[must_use]
    pub fn response_id(&self) -> u16 {
        self.sdo.response_id()
    }

    /// Starts from the beginning (the drive booted, was found, or a reset): the first
    /// frame. A manager first switches the drive to pre-operational — a drive found
    /// *stopped* answers no SDO, and only pre-operational accepts PDO mapping.
    pub fn begin(&mut self, now_ms: u64) -> CanFrame {
        self.heard = true;
        self.phase = Phase::Running;
        self.absent_since_ms = None;
        self.sdo.cancel();
        if self.manager {
            self.step = Step::PreOperational;
            self.nmt_due = true;
            nmt::command(NmtCommand::PreOperational, self.setup.node())
        } else {
            self.step = Step::DeviceType;
            self.nmt_due = false;
            self.sdo.read(device::DEVICE_TYPE.object, now_ms)
        }
    }

    /// The device was heard (a heartbeat): it is there, whatever it answers — the boot
    /// time no longer applies (a stopped node answers no presence check).
    pub fn heard_of(&mut self) {
        self.heard = true;
    }

    /// NMT *start* for the commissioned device whose heartbeat says it is stopped or
    /// pre-operational (a manager's duty: a start that was lost, or a node stopped by
    /// NMT), unless the controller started it less than one of its heartbeat periods
    /// (0x1017) ago: a heartbeat the device sent before the start reached it says
    /// nothing of the start, and answering it would start the device twice. A start that
    /// was lost is sent again on the first heartbeat a period after it.
    pub fn start(&mut self, now_ms: u64) -> Option<CanFrame> {
        let period_ms = u64::from(self.setup.heartbeat_ms());
        if self
            .started_ms
            .is_some_and(|t| now_ms.saturating_sub(t) < period_ms)
        {
            return None;
        }
        self.started_ms = Some(now_ms);
        Some(nmt::command(NmtCommand::Start, self.setup.node()))
    }

    /// Puts a commissioning that is running aside while the controller may not use SDO
    /// or start nodes (its own NMT state): the transfer in flight is forgotten — its
    /// timeout would otherwise fail the drive for a silence the controller caused — and
    /// the device counts as absent, found again by its heartbeat or the presence check.
    /// Whether it was running. (A device never heard of starts its boot time afresh.)
    pub fn suspend(&mut self) -> bool {
        // The boot time counts the time the controller looks, not the time it may not.
        self.looking_since_ms = None;
        if self.phase != Phase::Running {
            return false;
        }
        self.sdo.cancel();
        self.phase = Phase::Absent;
        self.step = Step::DeviceType;
        self.nmt_due = false;
        self.absent_since_ms = None;
        true
    }

    /// Once per cycle: a due NMT step, a timeout, or the presence check of an absent drive.
    pub fn poll(&mut self, now_ms: u64) -> Option<Progress> {
        match self.phase {
            Phase::Absent => {
                let looking = now_ms.saturating_sub(*self.looking_since_ms.get_or_insert(now_ms));
                if !self.heard && looking >= u64::from(self.boot_time_ms) {
                    self.sdo.cancel();
                    let waited_ms = u32::try_from(looking).unwrap_or(u32::MAX);
                    return Some(self.fail(CommissioningError::NeverAppeared { waited_ms }, None));
                }
                let since = *self.absent_since_ms.get_or_insert(now_ms);
                if !self.sdo.busy() && now_ms >= since {
                    self.absent_since_ms = Some(now_ms.saturating_add(PRESENCE_RETRY_MS));
                    return Some(Progress::Send(
                        self.sdo.read(device::DEVICE_TYPE.object, now_ms),
                    ));
                }
                // A presence check that times out only means "not there yet": nobody
                // listens for its abort.
                let _ = self.sdo.poll(now_ms);
                None
            }
            Phase::Running if self.nmt_due => {
                self.nmt_due = false;
                Some(self.advance(now_ms))
            }
            Phase::Running => self.sdo.poll(now_ms).map(|e| self.on_event(e, now_ms)),
            Phase::Done | Phase::Failed(_) => None,
        }
    }

    /// Takes an SDO response of this drive. `None`: not an answer to anything running.
    pub fn on_response(&mut self, data: &[u8], now_ms: u64) -> Option<Progress> {
        let event = self.sdo.on_response(data, now_ms)?;
        if self.phase == Phase::Absent {
            // The presence check was answered: the drive is there; commission it.
            return Some(Progress::Send(self.begin(now_ms)));
        }
        Some(self.on_event(event, now_ms))
    }

    fn fail(&mut self, error: CommissioningError, abort: Option<CanFrame>) -> Progress {
        self.phase = Phase::Failed(error);
        Progress::Failed { error, abort }
    }

    fn on_event(&mut self, event: Event, now_ms: u64) -> Progress {
        let value = match event {
            Event::Send(frame) => return Progress::Send(frame),
            Event::Failed { error, abort } => {
                return self.fail(CommissioningError::Sdo(error), abort);
            }
            Event::Complete(value) => value,
        };
        let mut word = [0u8; 4];
        for (w, v) in word.iter_mut().zip(&value) {
            *w = *v;
        }
        let read = u32::from_le_bytes(word);
        match self.step {
            Step::DeviceType if read & 0xFFFF != D::PROFILE => {
                return self.fail(CommissioningError::DeviceType { found: read }, None);
            }
            Step::Identity(sub) => {
                if let Some(slot) = self.identity.get_mut(usize::from(sub).saturating_sub(1)) {
                    *slot = read;
                }
            }
            Step::ReadBack(i) => {
                if let Some(x) = self.writes.get(i) {
                    let mask = match x.size {
                        1 => 0xFF,
                        2 => 0xFFFF,
                        _ => u32::MAX,
                    };
                    if read & mask != x.value & mask {
                        let error = CommissioningError::ReadBack {
                            object: x.object,
                            wrote: x.value,
                            read: read & mask,
                        };
                        return self.fail(error, None);
                    }
                }
            }
            Step::Mode(tries) => {
                let found = read as u8 as i8;
                if Some(found) != self.setup.confirmed_mode() {
                    if tries + 1 >= MODE_TRIES {
                        return self.fail(CommissioningError::Mode { found }, None);
                    }
                    self.step = Step::Mode(tries + 1);
                    return Progress::Send(self.sdo.read(device::MODES_DISPLAY.object, now_ms));
                }
            }
            _ => {}
        }
        self.advance(now_ms)
    }

    /// The step after the current one, and what it sends.
    fn advance(&mut self, now_ms: u64) -> Progress {
        let next = match self.step {
            Step::PreOperational => Step::DeviceType,
            Step::DeviceType => Step::Identity(1),
            Step::Identity(sub) if sub < 4 => Step::Identity(sub + 1),
            Step::Identity(_) => Step::Write(0),
            Step::Write(i) => Step::ReadBack(i),
            Step::ReadBack(i) if i + 1 < self.writes.len() => Step::Write(i + 1),
            Step::ReadBack(_) if self.setup.confirmed_mode().is_some() => Step::Mode(0),
            Step::ReadBack(_) | Step::Mode(_) if self.manager => Step::Start,
            Step::ReadBack(_) | Step::Mode(_) | Step::Start => {
                self.phase = Phase::Done;
                return Progress::Done;
            }
        };
        self.step = next;
        let node = self.setup.node();
        match next {
            Step::PreOperational | Step::Start => {
                // No answer to wait for: the next step follows on the next poll.
                self.nmt_due = true;
                let command = if next == Step::Start {
                    self.started_ms = Some(now_ms);
                    NmtCommand::Start
                } else {
                    NmtCommand::PreOperational
                };
                Progress::Send(nmt::command(command, node))
            }
            Step::Identity(sub) => {
                Progress::Send(self.sdo.read(device::identity(sub).object, now_ms))
            }
            Step::Write(i) | Step::ReadBack(i) => {
                let Some(x) = self.writes.get(i).copied() else {
                    self.phase = Phase::Done;
                    return Progress::Done;
                };
                Progress::Send(if matches!(next, Step::Write(_)) {
                    let bytes = x.value.to_le_bytes();
                    self.sdo.write(
                        x.object,
                        bytes.get(..usize::from(x.size)).unwrap_or(&bytes),
                        now_ms,
                    )
                } else {
                    self.sdo.read(x.object, now_ms)
                })
            }
            Step::Mode(_) => Progress::Send(self.sdo.read(device::MODES_DISPLAY.object, now_ms)),
            Step::DeviceType => Progress::Send(self.sdo.read(device::DEVICE_TYPE.object, now_ms)),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
    use super::*;

    /// A write spelled out, independently of the dictionary.
    fn write(index: u16, sub: u8, value: u32, size: u8) -> Write {
        Write {
            object: Object::new(index, sub),
            value,
            size,
        }
    }
    use crate::canopen::sdo::{serve, ObjectDictionary, Value};

    #[test]
    fn the_largest_configuration_fits_and_starts_with_the_mode() {
        let stock = configuration(&DriveSetup::TROLLEY, 0x10, 10);
        assert_eq!(stock.len(), 3 + 3 * 7 + 6);
        assert_eq!(stock[0], write(0x6060, 0, 9, 1));
        let pv = DriveSetup {
            mode: OperationMode::ProfileVelocity,
            velocity_unit: Some(0xFA01_0300),
            profile_ramp: Some(30_000_000),
            ..DriveSetup::WINCH
        };
        let all = configuration(&pv, 0x10, 10);
        assert_eq!(all.len(), 3 + 3 * 7 + 6 + 3);
        assert!(all.len() < MAX_WRITES, "nothing is cut");
        assert_eq!(all[0], write(0x6060, 0, 3, 1));
        // RPDO1 of node 2: disabled first, enabled last.
        assert_eq!(all[3], write(0x1400, 1, 0x8000_0202, 4));
        assert_eq!(all[9], write(0x1400, 1, 0x0000_0202, 4));
    }

    /// A two-axis inclinometer gets both slopes mapped into TPDO1 (long first, as the
    /// controller decodes them); a one-axis one only slope long16. Its slopes become the
    /// swing in both planes with each axis's own sign and offset.
    #[test]
    fn a_two_axis_inclinometer_maps_both_slopes() {
        let one = InclinometerSetup::STOCK.configuration(0x10, 10);
        let two = InclinometerSetup::STOCK_TWO_AXES.configuration(0x10, 10);
        let mapped = |c: &Vec<Write, MAX_WRITES>| -> (u32, std::vec::Vec<u32>) {
            let count = c
                .iter()
                .rev()
                .find(|x| x.object == Object::new(0x1A00, 0))
                .unwrap()
                .value;
            let entries = c
                .iter()
                .filter(|x| x.object.index == 0x1A00 && x.object.sub > 0)
                .map(|x| x.value)
                .collect();
            (count, entries)
        };
        assert_eq!(mapped(&one), (1, vec![0x6010_0010]));
        assert_eq!(mapped(&two), (2, vec![0x6010_0010, 0x6020_0010]));
        let setup = InclinometerSetup {
            lateral: Some(LateralAxis {
                sign: -1.0,
                offset_deg: 0.5,
            }),
            ..InclinometerSetup::STOCK
        };
        let swing = setup.swing(cia410::Slopes {
            long: 150,
            lateral: Some(250),
        });
        assert!((swing.long - 1.5_f64.to_radians()).abs() < 1e-15);
        assert!((swing.lateral.unwrap() - (-2.0_f64).to_radians()).abs() < 1e-15);
        // A one-axis setup reads no lateral swing, whatever the frame.
        let one_axis = InclinometerSetup::STOCK.swing(cia410::Slopes {
            long: 150,
            lateral: Some(250),
        });
        assert_eq!(one_axis.lateral, None);
    }

    /// A drive that answers everything, but lies about one object.
    struct Liar {
        device_type: u32,
        wrong: Option<Object>,
        values: heapless::LinearMap<(u16, u8), u32, 64>,
    }

    impl ObjectDictionary for Liar {
        fn read(&self, o: Object) -> Result<Value, u32> {
            let v = match (o.index, o.sub) {
                (0x1000, 0) => self.device_type,
                (0x6061, 0) => self.values.get(&(0x6060, 0)).copied().unwrap_or(0),
                (i, s) => self.values.get(&(i, s)).copied().unwrap_or(0),
            };
            let v = if Some(o) == self.wrong { v ^ 1 } else { v };
            Ok(crate::canopen::sdo::value(&v.to_le_bytes()))
        }
        fn write(&mut self, o: Object, d: &[u8]) -> Result<(), u32> {
            let mut word = [0u8; 4];
            word[..d.len()].copy_from_slice(d);
            self.values
                .insert((o.index, o.sub), u32::from_le_bytes(word))
                .map(|_| ())
                .map_err(|_| 0x0504_0005)
        }
    }

    /// Runs a commissioning against `drive` to its end.
    fn run(drive: &mut Liar) -> Phase {
        commission(drive).0.phase()
    }

    /// A manager's commissioning of `drive`, run to its end, and when it sent the
    /// drive NMT *start*, ms (if it did).
    fn commission(drive: &mut Liar) -> (Commissioning, Option<u64>) {
        let mut c = Commissioning::new(DriveSetup::TROLLEY, 0x10, 10, true, 100);
        let mut frame = Some(c.begin(0));
        let mut started = None;
        for now in 1..200u64 {
            let progress = match frame.take() {
                Some(f) if f.id() == 0x601 => {
                    let answer = serve(drive, 1, f.data()).unwrap();
                    c.on_response(answer.data(), now)
                }
                // An NMT command: no answer, the next step on the next poll.
                Some(_) | None => c.poll(now),
            };
            match progress {
                Some(Progress::Send(f)) => {
                    if f.id() == 0 && f.data() == [0x01, 1] {
                        started = Some(now);
                    }
                    frame = Some(f);
                }
                Some(Progress::Done | Progress::Failed { .. }) => break,
                None => {}
            }
        }
        (c, started)
    }

    #[test]
    fn a_heartbeat_within_a_period_of_the_start_does_not_start_the_drive_again() {
        let (mut c, started) = commission(&mut drive(0x0002_0192, None));
        assert_eq!(c.phase(), Phase::Done);
        // A manager starts the drive it commissioned.
        let t = started.unwrap();
        let period = u64::from(DriveSetup::TROLLEY.heartbeat_ms);
        // A pre-operational heartbeat sent before the start reached the drive.
        assert_eq!(c.start(t + period - 1), None);
        // One a period later: the start was lost, it is sent again, and once only.
        let again = c.start(t + period);
        assert_eq!(again.map(|f| f.data().to_vec()), Some(vec![0x01, 1]));
        assert_eq!(c.start(t + period + 1), None);
    }

    fn drive(device_type: u32, wrong: Option<Object>) -> Liar {
        Liar {
            device_type,
            wrong,
            values: heapless::LinearMap::new(),
        }
    }

    #[test]
    fn a_truthful_drive_is_commissioned() {
        assert_eq!(run(&mut drive(0x0002_0192, None)), Phase::Done);
    }

    #[test]
    fn another_device_profile_is_refused() {
        assert_eq!(
            run(&mut drive(0x0000_0191, None)),
            Phase::Failed(CommissioningError::DeviceType { found: 0x191 })
        );
    }

    #[test]
    fn a_value_that_reads_back_differently_is_named() {
        let object = Object::new(0x1A01, 2);
        assert_eq!(
            run(&mut drive(0x0002_0192, Some(object))),
            Phase::Failed(CommissioningError::ReadBack {
                object,
                wrote: 0x6061_0008,
                read: 0x6061_0009
            })
        );
    }
}
