//! The object dictionary, declared once (CiA 301, CiA 402, CiA 410): every object the
//! controller's SDO server answers ([`CONTROLLER`], the objects
//! `can/crane-controller.eds` describes for a PLC's configuration tool; a host test holds
//! the two against each other), and every object of a drive or an inclinometer that the
//! commissioning reads or writes or a PDO maps, each with its index, sub-index, data type,
//! access and name. The SDO server ([`crate::node`]), the commissioning
//! ([`crate::commissioning`]) and the PDO mappings ([`crate::cia402::pdo`],
//! [`crate::cia410`]) read them from here.

use crate::canopen::sdo::Object;

/// The CiA 301 data types (Tab. 44) of the objects here, by their codes (the EDS's
/// `DataType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u16)]
pub enum DataType {
    /// INTEGER8.
    Integer8 = 0x0002,
    /// INTEGER16.
    Integer16 = 0x0003,
    /// INTEGER32.
    Integer32 = 0x0004,
    /// UNSIGNED8.
    Unsigned8 = 0x0005,
    /// UNSIGNED16.
    Unsigned16 = 0x0006,
    /// UNSIGNED32.
    Unsigned32 = 0x0007,
}

impl DataType {
    /// The CiA 301 data type code (the EDS's `DataType`).
    #[must_use]
    pub const fn code(self) -> u16 {
        self as u16
    }

    /// Its size, bytes.
    #[must_use]
    pub const fn size(self) -> u8 {
        match self {
            Self::Integer8 | Self::Unsigned8 => 1,
            Self::Integer16 | Self::Unsigned16 => 2,
            Self::Integer32 | Self::Unsigned32 => 4,
        }
    }
}

/// Who may read and write an object (CiA 306's `AccessType`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Access {
    /// Read only, and never changes (a record's highest sub-index).
    Const,
    /// Read only.
    ReadOnly,
    /// Read and write.
    ReadWrite,
    /// Write only.
    WriteOnly,
}

impl Access {
    /// The EDS's `AccessType` for it.
    #[must_use]
    pub const fn eds(self) -> &'static str {
        match self {
            Self::Const => "const",
            Self::ReadOnly => "ro",
            Self::ReadWrite => "rw",
            Self::WriteOnly => "wo",
        }
    }

    /// Whether an SDO upload may read it.
    #[must_use]
    pub const fn readable(self) -> bool {
        !matches!(self, Self::WriteOnly)
    }

    /// Whether an SDO download may write it.
    #[must_use]
    pub const fn writable(self) -> bool {
        matches!(self, Self::ReadWrite | Self::WriteOnly)
    }
}

/// One object of a dictionary: where it is, its type, its access, its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    /// Index and sub-index.
    pub object: Object,
    /// Data type.
    pub data_type: DataType,
    /// Access.
    pub access: Access,
    /// Name (the EDS's `ParameterName` for the controller's own objects).
    pub name: &'static str,
}

impl Entry {
    /// The object `index:sub`.
    #[must_use]
    pub const fn new(
        index: u16,
        sub: u8,
        data_type: DataType,
        access: Access,
        name: &'static str,
    ) -> Self {
        Self {
            object: Object::new(index, sub),
            data_type,
            access,
            name,
        }
    }

    /// Its size, bytes.
    #[must_use]
    pub const fn size(&self) -> u8 {
        self.data_type.size()
    }

    /// The entry that maps it into a PDO (CiA 301 0x1600/0x1A00 sub n): index, sub-index,
    /// length in bits.
    #[must_use]
    pub const fn mapping(&self) -> u32 {
        let bits = self.size() as u32 * 8;
        ((self.object.index as u32) << 16) | ((self.object.sub as u32) << 8) | bits
    }
}

use Access::{Const, ReadOnly as Ro, ReadWrite as Rw, WriteOnly as Wo};
use DataType::{
    Integer16 as I16, Integer32 as I32, Integer8 as I8, Unsigned16 as U16, Unsigned32 as U32,
    Unsigned8 as U8,
};

// CiA 301 communication objects, on every device.

/// 0x1000 *device type*: the device profile in the low word.
pub const DEVICE_TYPE: u16 = 0x1000;
/// 0x1001 *error register*.
pub const ERROR_REGISTER: u16 = 0x1001;
/// 0x1005 *COB-ID SYNC*.
pub const COB_ID_SYNC: u16 = 0x1005;
/// 0x1006 *communication cycle period*, µs.
pub const CYCLE_PERIOD: u16 = 0x1006;
/// 0x1016 *consumer heartbeat time*: sub n watches one node.
pub const CONSUMER_HEARTBEAT: u16 = 0x1016;
/// 0x1017 *producer heartbeat time*, ms.
pub const PRODUCER_HEARTBEAT: u16 = 0x1017;
/// 0x1018 *identity*: vendor id (sub 1), product code, revision, serial number (sub 4).
pub const IDENTITY: u16 = 0x1018;
/// 0x1400 RPDO1's communication parameter.
pub const RPDO1_COMMUNICATION: u16 = 0x1400;
/// 0x1401 RPDO2's communication parameter.
pub const RPDO2_COMMUNICATION: u16 = 0x1401;
/// 0x1402 RPDO3's communication parameter.
pub const RPDO3_COMMUNICATION: u16 = 0x1402;
/// 0x1600 RPDO1's mapping parameter.
pub const RPDO1_MAPPING: u16 = 0x1600;
/// 0x1601 RPDO2's mapping parameter.
pub const RPDO2_MAPPING: u16 = 0x1601;
/// 0x1602 RPDO3's mapping parameter.
pub const RPDO3_MAPPING: u16 = 0x1602;
/// 0x1800 TPDO1's communication parameter.
pub const TPDO1_COMMUNICATION: u16 = 0x1800;
/// 0x1801 TPDO2's communication parameter.
pub const TPDO2_COMMUNICATION: u16 = 0x1801;
/// 0x1A00 TPDO1's mapping parameter.
pub const TPDO1_MAPPING: u16 = 0x1A00;
/// 0x1A01 TPDO2's mapping parameter.
pub const TPDO2_MAPPING: u16 = 0x1A01;

/// A PDO communication parameter's sub-index 1: the COB-ID (bit 31: not valid).
pub const fn pdo_cob_id(communication: u16) -> Entry {
    Entry::new(communication, 1, U32, Rw, "COB-ID")
}

/// A PDO communication parameter's sub-index 2: the transmission type (1: synchronous,
/// every SYNC; 0xFE: event-driven, manufacturer specific).
pub const fn pdo_transmission_type(communication: u16) -> Entry {
    Entry::new(communication, 2, U8, Rw, "Transmission type")
}

/// A PDO mapping parameter's sub-index 0: how many objects it maps.
pub const fn pdo_mapped_count(mapping: u16) -> Entry {
    Entry::new(mapping, 0, U8, Rw, "Number of mapped objects")
}

/// A PDO mapping parameter's sub-index `n` (1…): the `n`th object mapped
/// ([`Entry::mapping`]).
pub const fn pdo_mapped(mapping: u16, n: u8) -> Entry {
    Entry::new(mapping, n, U32, Rw, "Mapped object")
}

/// The objects of a device the controller commissions (a CiA 402 drive, a CiA 410
/// inclinometer), with the access their profiles give them.
pub mod device {
    use super::*;

    /// 0x1000 *device type*: the device profile in the low word (402, 410).
    pub const DEVICE_TYPE: Entry = Entry::new(super::DEVICE_TYPE, 0, U32, Ro, "Device type");
    /// 0x1016:1 *consumer heartbeat time*: node << 16 | ms, the node it watches.
    pub const CONSUMER_HEARTBEAT: Entry = Entry::new(
        super::CONSUMER_HEARTBEAT,
        1,
        U32,
        Rw,
        "Consumer heartbeat time 1",
    );
    /// 0x1017 *producer heartbeat time*, ms.
    pub const PRODUCER_HEARTBEAT: Entry = Entry::new(
        super::PRODUCER_HEARTBEAT,
        0,
        U16,
        Rw,
        "Producer heartbeat time",
    );

    /// 0x1018:`sub` of *identity*: 1 vendor id, 2 product code, 3 revision, 4 serial.
    pub const fn identity(sub: u8) -> Entry {
        Entry::new(super::IDENTITY, sub, U32, Ro, "Identity")
    }

    /// CiA 402 0x6007 *abort connection option code*: what the drive does when it loses
    /// the controller.
    pub const ABORT_CONNECTION_OPTION: Entry =
        Entry::new(0x6007, 0, I16, Rw, "Abort connection option code");
    /// CiA 402 0x6040 *controlword*.
    pub const CONTROLWORD: Entry = Entry::new(0x6040, 0, U16, Rw, "Controlword");
    /// CiA 402 0x6041 *statusword*.
    pub const STATUSWORD: Entry = Entry::new(0x6041, 0, U16, Ro, "Statusword");
    /// CiA 402 0x605A *quick stop option code*.
    pub const QUICK_STOP_OPTION: Entry = Entry::new(0x605A, 0, I16, Rw, "Quick stop option code");
    /// CiA 402 0x6060 *modes of operation* ([`crate::commissioning::OperationMode`]).
    pub const MODES_OF_OPERATION: Entry = Entry::new(0x6060, 0, I8, Rw, "Modes of operation");
    /// CiA 402 0x6061 *modes of operation display*.
    pub const MODES_DISPLAY: Entry = Entry::new(0x6061, 0, I8, Ro, "Modes of operation display");
    /// CiA 402 0x6064 *position actual value*.
    pub const POSITION_ACTUAL: Entry = Entry::new(0x6064, 0, I32, Ro, "Position actual value");
    /// CiA 402 0x606C *velocity actual value*.
    pub const VELOCITY_ACTUAL: Entry = Entry::new(0x606C, 0, I32, Ro, "Velocity actual value");
    /// CiA 402 0x6080 *max motor speed*.
    pub const MAX_MOTOR_SPEED: Entry = Entry::new(0x6080, 0, U32, Rw, "Max motor speed");
    /// CiA 402 0x6083 *profile acceleration*.
    pub const PROFILE_ACCELERATION: Entry = Entry::new(0x6083, 0, U32, Rw, "Profile acceleration");
    /// CiA 402 0x6084 *profile deceleration*.
    pub const PROFILE_DECELERATION: Entry = Entry::new(0x6084, 0, U32, Rw, "Profile deceleration");
    /// CiA 402 0x6085 *quick stop deceleration*.
    pub const QUICK_STOP_DECELERATION: Entry =
        Entry::new(0x6085, 0, U32, Rw, "Quick stop deceleration");
    /// CiA 402 0x60A9 *SI unit velocity*.
    pub const VELOCITY_UNIT: Entry = Entry::new(0x60A9, 0, U32, Rw, "SI unit velocity");
    /// CiA 402 0x60C2:1 *interpolation time period value*.
    pub const INTERPOLATION_PERIOD: Entry =
        Entry::new(0x60C2, 1, U8, Rw, "Interpolation time period value");
    /// CiA 402 0x60C2:2 *interpolation time index*: the power of ten of the value's
    /// unit, s.
    pub const INTERPOLATION_INDEX: Entry =
        Entry::new(0x60C2, 2, I8, Rw, "Interpolation time index");
    /// CiA 402 0x60FF *target velocity*.
    pub const TARGET_VELOCITY: Entry = Entry::new(0x60FF, 0, I32, Rw, "Target velocity");

    /// CiA 410 0x6000 *resolution* of the 16-bit slopes, 0.001°.
    pub const RESOLUTION: Entry = Entry::new(0x6000, 0, U16, Rw, "Resolution");
    /// CiA 410 0x6010 *slope long16*: the angle about the lateral axis, in resolution
    /// units.
    pub const SLOPE_LONG16: Entry = Entry::new(0x6010, 0, I16, Ro, "Slope long16");
    /// CiA 410 0x6020 *slope lateral16*: the angle about the longitudinal axis.
    pub const SLOPE_LATERAL16: Entry = Entry::new(0x6020, 0, I16, Ro, "Slope lateral16");
}

// The controller's own objects (manufacturer specific, 0x2000…; docs/COMMANDS.md).

/// 0x2000 the command frames' fields, written over SDO (writing the command submits).
pub const REQUEST: u16 = 0x2000;
/// 0x2001 the status frame's fields.
pub const STATUS: u16 = 0x2001;
/// 0x2002 the last commissioning failure.
pub const COMMISSIONING_FAILURE: u16 = 0x2002;
/// 0x2003 the network: NMT role, drives commissioned.
pub const NETWORK: u16 = 0x2003;
/// 0x2004 the rope calibration learnt from the swing.
pub const ROPE_CALIBRATION: u16 = 0x2004;
/// 0x2010 the operator's speed demand, written over SDO (writing the counter submits).
pub const OPERATOR: u16 = 0x2010;

/// 0x2000:1..=7, the request's fields: the command frame's as RPDO1 maps them
/// (request id, command, x, z, duration in 10 ms), then the 3D move's y and duration in
/// s (RPDO2 maps request id, x, y, z and that duration).
pub const REQUEST_FIELDS: [Entry; 7] = [
    Entry::new(REQUEST, 1, U8, Wo, "Request id"),
    Entry::new(REQUEST, 2, U8, Wo, "Command"),
    Entry::new(REQUEST, 3, U16, Wo, "Target x_C mm"),
    Entry::new(REQUEST, 4, U16, Wo, "Target z_C mm"),
    Entry::new(REQUEST, 5, U16, Wo, "Duration 10 ms"),
    Entry::new(REQUEST, 6, U16, Wo, "Target y_C mm"),
    Entry::new(REQUEST, 7, U8, Wo, "Duration s"),
];

/// 0x2010:1..=5, the operator frame's fields as RPDO3 maps them (`crate::operator::frame`):
/// alive counter, flags, demand x, y, z in 1/32767 of the manual speed.
pub const OPERATOR_FIELDS: [Entry; 5] = [
    Entry::new(OPERATOR, 1, U8, Wo, "Alive counter"),
    Entry::new(OPERATOR, 2, U8, Wo, "Flags"),
    Entry::new(OPERATOR, 3, I16, Wo, "Demand x"),
    Entry::new(OPERATOR, 4, I16, Wo, "Demand y"),
    Entry::new(OPERATOR, 5, I16, Wo, "Demand z"),
];

/// 0x2001:1..=8, the status frame's fields, as TPDO1 maps them (docs/COMMANDS.md).
pub const STATUS_FIELDS: [Entry; 8] = [
    Entry::new(STATUS, 1, U8, Ro, "Last request id"),
    Entry::new(
        STATUS,
        2,
        U8,
        Ro,
        "Answer (0 none 1 accepted 2 queued 3 rejected 4 overload)",
    ),
    Entry::new(
        STATUS,
        3,
        U8,
        Ro,
        "Reason (answer 4: how many requests it answers)",
    ),
    Entry::new(STATUS, 4, U8, Ro, "Mode"),
    Entry::new(STATUS, 5, U8, Ro, "Fault"),
    Entry::new(STATUS, 6, U8, Ro, "Frames ignored (modulo 256)"),
    Entry::new(STATUS, 7, U8, Ro, "Deadline misses (modulo 256)"),
    Entry::new(STATUS, 8, U8, Ro, "Transmit failures (modulo 256)"),
];

/// Every object the controller's SDO server answers, in index order, as
/// `can/crane-controller.eds` describes it. A record's sub-index 0 (its highest
/// sub-index) is the largest sub-index the table holds for it.
pub const CONTROLLER: [Entry; 90] = [
    Entry::new(DEVICE_TYPE, 0, U32, Ro, "Device type"),
    Entry::new(ERROR_REGISTER, 0, U8, Ro, "Error register"),
    Entry::new(COB_ID_SYNC, 0, U32, Ro, "COB-ID SYNC"),
    Entry::new(CYCLE_PERIOD, 0, U32, Ro, "Communication cycle period"),
    Entry::new(
        CONSUMER_HEARTBEAT,
        0,
        U8,
        Const,
        "Highest sub-index supported",
    ),
    Entry::new(CONSUMER_HEARTBEAT, 1, U32, Rw, "Consumer heartbeat time 1"),
    Entry::new(PRODUCER_HEARTBEAT, 0, U16, Rw, "Producer heartbeat time"),
    Entry::new(IDENTITY, 0, U8, Const, "Highest sub-index supported"),
    Entry::new(IDENTITY, 1, U32, Ro, "Vendor-ID"),
    Entry::new(IDENTITY, 2, U32, Ro, "Product code"),
    Entry::new(IDENTITY, 3, U32, Ro, "Revision number"),
    Entry::new(IDENTITY, 4, U32, Ro, "Serial number"),
    Entry::new(
        RPDO1_COMMUNICATION,
        0,
        U8,
        Const,
        "Highest sub-index supported",
    ),
    Entry::new(RPDO1_COMMUNICATION, 1, U32, Ro, "COB-ID used by RPDO"),
    Entry::new(RPDO1_COMMUNICATION, 2, U8, Ro, "Transmission type"),
    Entry::new(
        RPDO2_COMMUNICATION,
        0,
        U8,
        Const,
        "Highest sub-index supported",
    ),
    Entry::new(RPDO2_COMMUNICATION, 1, U32, Ro, "COB-ID used by RPDO"),
    Entry::new(RPDO2_COMMUNICATION, 2, U8, Ro, "Transmission type"),
    Entry::new(
        RPDO3_COMMUNICATION,
        0,
        U8,
        Const,
        "Highest sub-index supported",
    ),
    Entry::new(RPDO3_COMMUNICATION, 1, U32, Ro, "COB-ID used by RPDO"),
    Entry::new(RPDO3_COMMUNICATION, 2, U8, Ro, "Transmission type"),
    Entry::new(RPDO1_MAPPING, 0, U8, Const, "Highest sub-index supported"),
    Entry::new(RPDO1_MAPPING, 1, U32, Ro, "Mapped object 1"),
    Entry::new(RPDO1_MAPPING, 2, U32, Ro, "Mapped object 2"),
    Entry::new(RPDO1_MAPPING, 3, U32, Ro, "Mapped object 3"),
    Entry::new(RPDO1_MAPPING, 4, U32, Ro, "Mapped object 4"),
    Entry::new(RPDO1_MAPPING, 5, U32, Ro, "Mapped object 5"),
    Entry::new(RPDO2_MAPPING, 0, U8, Const, "Highest sub-index supported"),
    Entry::new(RPDO2_MAPPING, 1, U32, Ro, "Mapped object 1"),
    Entry::new(RPDO2_MAPPING, 2, U32, Ro, "Mapped object 2"),
    Entry::new(RPDO2_MAPPING, 3, U32, Ro, "Mapped object 3"),
    Entry::new(RPDO2_MAPPING, 4, U32, Ro, "Mapped object 4"),
    Entry::new(RPDO2_MAPPING, 5, U32, Ro, "Mapped object 5"),
    Entry::new(RPDO3_MAPPING, 0, U8, Const, "Highest sub-index supported"),
    Entry::new(RPDO3_MAPPING, 1, U32, Ro, "Mapped object 1"),
    Entry::new(RPDO3_MAPPING, 2, U32, Ro, "Mapped object 2"),
    Entry::new(RPDO3_MAPPING, 3, U32, Ro, "Mapped object 3"),
    Entry::new(RPDO3_MAPPING, 4, U32, Ro, "Mapped object 4"),
    Entry::new(RPDO3_MAPPING, 5, U32, Ro, "Mapped object 5"),
    Entry::new(
        TPDO1_COMMUNICATION,
        0,
        U8,
        Const,
        "Highest sub-index supported",
    ),
    Entry::new(TPDO1_COMMUNICATION, 1, U32, Ro, "COB-ID used by TPDO"),
    Entry::new(TPDO1_COMMUNICATION, 2, U8, Ro, "Transmission type"),
    Entry::new(TPDO1_MAPPING, 0, U8, Const, "Highest sub-index supported"),
    Entry::new(TPDO1_MAPPING, 1, U32, Ro, "Mapped object 1"),
    Entry::new(TPDO1_MAPPING, 2, U32, Ro, "Mapped object 2"),
    Entry::new(TPDO1_MAPPING, 3, U32, Ro, "Mapped object 3"),
    Entry::new(TPDO1_MAPPING, 4, U32, Ro, "Mapped object 4"),
    Entry::new(TPDO1_MAPPING, 5, U32, Ro, "Mapped object 5"),
    Entry::new(TPDO1_MAPPING, 6, U32, Ro, "Mapped object 6"),
    Entry::new(TPDO1_MAPPING, 7, U32, Ro, "Mapped object 7"),
    Entry::new(TPDO1_MAPPING, 8, U32, Ro, "Mapped object 8"),
    Entry::new(REQUEST, 0, U8, Const, "Highest sub-index supported"),
    REQUEST_FIELDS[0],
    REQUEST_FIELDS[1],
    REQUEST_FIELDS[2],
    REQUEST_FIELDS[3],
    REQUEST_FIELDS[4],
    REQUEST_FIELDS[5],
    REQUEST_FIELDS[6],
    Entry::new(STATUS, 0, U8, Const, "Highest sub-index supported"),
    STATUS_FIELDS[0],
    STATUS_FIELDS[1],
    STATUS_FIELDS[2],
    STATUS_FIELDS[3],
    STATUS_FIELDS[4],
    STATUS_FIELDS[5],
    STATUS_FIELDS[6],
    STATUS_FIELDS[7],
    Entry::new(
        COMMISSIONING_FAILURE,
        0,
        U8,
        Const,
        "Highest sub-index supported",
    ),
    Entry::new(COMMISSIONING_FAILURE, 1, U8, Ro, "Node"),
    Entry::new(COMMISSIONING_FAILURE, 2, U16, Ro, "Index"),
    Entry::new(COMMISSIONING_FAILURE, 3, U8, Ro, "Sub-index"),
    Entry::new(COMMISSIONING_FAILURE, 4, U32, Ro, "SDO abort code"),
    Entry::new(COMMISSIONING_FAILURE, 5, U8, Ro, "Reason"),
    Entry::new(NETWORK, 0, U8, Const, "Highest sub-index supported"),
    Entry::new(NETWORK, 1, U8, Ro, "NMT role"),
    Entry::new(NETWORK, 2, U8, Ro, "Drives commissioned"),
    Entry::new(
        ROPE_CALIBRATION,
        0,
        U8,
        Const,
        "Highest sub-index supported",
    ),
    Entry::new(ROPE_CALIBRATION, 1, I32, Ro, "Drum scaling error, ppm"),
    Entry::new(ROPE_CALIBRATION, 2, I32, Ro, "Rope offset, um"),
    Entry::new(ROPE_CALIBRATION, 3, U32, Ro, "Samples"),
    Entry::new(ROPE_CALIBRATION, 4, U8, Ro, "Learnt"),
    Entry::new(ROPE_CALIBRATION, 5, U32, Ro, "Length uncertainty, um"),
    Entry::new(
        ROPE_CALIBRATION,
        6,
        I32,
        Ro,
        "Angle delay beyond commissioned, us",
    ),
    Entry::new(OPERATOR, 0, U8, Const, "Highest sub-index supported"),
    OPERATOR_FIELDS[0],
    OPERATOR_FIELDS[1],
    OPERATOR_FIELDS[2],
    OPERATOR_FIELDS[3],
    OPERATOR_FIELDS[4],
];

/// The controller's entry `object`, or the CiA 301 abort code why there is none: no
/// such object, or no such sub-index of one.
pub fn controller_entry(object: Object) -> Result<&'static Entry, u32> {
    use crate::canopen::sdo::abort;
    let mut known_index = false;
    for entry in &CONTROLLER {
        if entry.object == object {
            return Ok(entry);
        }
        known_index |= entry.object.index == object.index;
    }
    Err(if known_index {
        abort::NO_SUB
    } else {
        abort::NO_OBJECT
    })
}

/// The highest sub-index of the controller's record `index` (its sub-index 0), or
/// `None` when `index` is a plain variable or none of the controller's.
#[must_use]
pub fn highest_sub(index: u16) -> Option<u8> {
    CONTROLLER
        .iter()
        .filter(|e| e.object.index == index)
        .map(|e| e.object.sub)
        .max()
        .filter(|sub| *sub > 0)
}
