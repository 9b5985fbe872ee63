//! A simulated stock CiA 410 inclinometer on the hook block: NMT slave (boot-up
//! message, pre-operational until started), SDO server of the objects commissioning
//! touches, *slope long16* (0x6010) in TPDO1 on every SYNC while operational, a
//! heartbeat once 0x1017 is set. Its slope is the plant's swing angle φ (Eq. 20),
//! noisy and quantised as the plant senses it, in the resolution 0x6000 asks.

use heapless::LinearMap;

use controller::canopen::od::{self, device, Entry};
use controller::canopen::sdo::{self, abort, Object, ObjectDictionary, Value};
use controller::canopen::{self, NmtCommand, NmtState};
use controller::cia410;
use controller::frame::CanFrame;

use super::{
    get, identity_value, key, pdo_parameter, refuse_write, sdo_word, store, stored, Objects,
};
use crate::scenario::SensorFault;

/// The objects it holds: (index, sub) → (value, size).
#[derive(Debug, Clone, PartialEq)]
struct Dictionary {
    entries: Objects<16>,
    node: u8,
}

impl Dictionary {
    fn new(node: u8) -> Self {
        let mut entries = LinearMap::new();
        // 0.1° by default (as many sensors ship); heartbeat off.
        for (entry, value) in [(device::RESOLUTION, 100), (device::PRODUCER_HEARTBEAT, 0)] {
            let _ = entries.insert(key(entry.object), (value, entry.size()));
        }
        Self { entries, node }
    }

    fn get(&self, entry: Entry) -> u32 {
        get(&self.entries, entry.object)
    }

    /// Whether it accepts writes to `object`: its resolution, its heartbeat and its
    /// TPDO1's parameters.
    fn writable(object: Object) -> bool {
        [device::RESOLUTION, device::PRODUCER_HEARTBEAT]
            .iter()
            .any(|e| e.object == object)
            || pdo_parameter(object, &[od::TPDO1_COMMUNICATION], &[od::TPDO1_MAPPING])
    }
}

impl ObjectDictionary for Dictionary {
    fn read(&self, object: Object) -> Result<Value, u32> {
        let node = u32::from(self.node);
        let ids = [0x0000_0B2C, 0x0410_0000 | node, 0x0001_0000, 2000 + node];
        if let Some(value) = identity_value(object, ids) {
            return Ok(value);
        }
        if object == device::DEVICE_TYPE.object {
            // CiA 410, one axis, 16 bit (additional information 0x0001).
            Ok(sdo_word(0x0001_019A, 4))
        } else if Dictionary::writable(object) {
            Ok(stored(&self.entries, object))
        } else {
            Err(abort::NO_OBJECT)
        }
    }

    fn write(&mut self, object: Object, data: &[u8]) -> Result<(), u32> {
        if !Dictionary::writable(object) {
            return Err(refuse_write(self.read(object)));
        }
        store(&mut self.entries, object, data)
    }
}

/// The simulated inclinometer.
#[derive(Debug, Clone, PartialEq)]
pub struct InclinometerSim {
    node: u8,
    nmt: NmtState,
    boot_up_due: bool,
    od: Dictionary,
    fault: Option<SensorFault>,
    /// The slopes it reports, long and lateral, resolution units.
    slopes: [i16; 2],
    next_heartbeat_ms: u32,
}

impl InclinometerSim {
    /// Powered, about to send its boot-up message.
    #[must_use]
    pub fn new(node: u8) -> Self {
        Self {
            node,
            nmt: NmtState::PreOperational,
            boot_up_due: true,
            od: Dictionary::new(node),
            fault: None,
            slopes: [0; 2],
            next_heartbeat_ms: 0,
        }
    }

    /// Its node id.
    #[must_use]
    pub fn node(&self) -> u8 {
        self.node
    }

    /// Its NMT state.
    #[must_use]
    pub fn nmt(&self) -> NmtState {
        self.nmt
    }

    /// A value of its object dictionary, as written.
    #[must_use]
    pub fn object(&self, index: u16, sub: u8) -> u32 {
        get(&self.od.entries, Object::new(index, sub))
    }

    /// From now on it has `fault` ([`SensorFault::Back`]: none).
    pub fn fail(&mut self, fault: SensorFault) {
        self.fault = (fault != SensorFault::Back).then_some(fault);
    }

    /// An NMT command addressed to it (or all).
    pub fn on_nmt(&mut self, command: NmtCommand) {
        self.nmt = match command {
            NmtCommand::Start => NmtState::Operational,
            NmtCommand::Stop => NmtState::Stopped,
            NmtCommand::PreOperational => NmtState::PreOperational,
            NmtCommand::ResetNode | NmtCommand::ResetCommunication => {
                *self = Self {
                    fault: self.fault,
                    ..Self::new(self.node)
                };
                NmtState::PreOperational
            }
        };
    }

    /// An SDO request to it: the answer, if it gives one.
    pub fn on_sdo(&mut self, data: &[u8]) -> Option<CanFrame> {
        if self.nmt == NmtState::Stopped || self.fault == Some(SensorFault::Lost) {
            return None;
        }
        sdo::serve(&mut self.od, self.node, data)
    }

    /// SYNC: it samples `slopes_deg` (the plant's sensed swing, °: in the plane of its
    /// long axis, and across it) and sends TPDO1 if operational, with the slopes its
    /// mapping (0x1A00, as the controller commissioned it) names: slope long16, and slope
    /// lateral16 if mapped second. A fault offset tilts both axes alike.
    pub fn on_sync(&mut self, slopes_deg: [f64; 2]) -> Option<CanFrame> {
        let offset_deg = match self.fault {
            Some(SensorFault::Lost) => return None,
            Some(SensorFault::Stuck) => None,
            Some(SensorFault::Offset(centidegrees)) => Some(f64::from(centidegrees) * 0.01),
            None | Some(SensorFault::Back) => Some(0.0),
        };
        if let Some(offset_deg) = offset_deg {
            let resolution = f64::from(self.od.get(device::RESOLUTION).max(1)) * 1e-3;
            for (slope, deg) in self.slopes.iter_mut().zip(slopes_deg) {
                let units = libm::round((deg + offset_deg) / resolution);
                *slope = units.clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16;
            }
        }
        let [long, lateral] = self.slopes;
        let two_axes = self.od.get(od::pdo_mapped_count(od::TPDO1_MAPPING)) >= 2
            && self.od.get(od::pdo_mapped(od::TPDO1_MAPPING, 2))
                == cia410::TPDO1_MAPPING_TWO_AXES[1];
        let slopes = cia410::Slopes {
            long,
            lateral: two_axes.then_some(lateral),
        };
        (self.nmt == NmtState::Operational).then(|| cia410::tpdo1(self.node, slopes))
    }

    /// Its boot-up message and heartbeats due by `now_ms`.
    pub fn heartbeat(&mut self, now_ms: u32) -> Option<CanFrame> {
        if self.fault == Some(SensorFault::Lost) {
            return None;
        }
        if core::mem::take(&mut self.boot_up_due) {
            self.next_heartbeat_ms = now_ms;
            return Some(canopen::heartbeat(self.node, NmtState::BootUp));
        }
        let period = self.od.get(device::PRODUCER_HEARTBEAT);
        if period > 0 && now_ms >= self.next_heartbeat_ms {
            self.next_heartbeat_ms = now_ms.saturating_add(period);
            return Some(canopen::heartbeat(self.node, self.nmt));
        }
        None
    }
}
