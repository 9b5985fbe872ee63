//! A virtual CAN bus: two simulated CiA 402 drives that answer the controller, plus a
//! scenario of timed actions (supervisor requests, garbage, a drive fault, a silenced
//! drive, an injected solver failure). Compiled into the QEMU build and replayed
//! identically by the host reference, so both see the same bus.
//!
//! The drives ([`DriveSim`]) behave like stock CiA 402 drives as far as the controller
//! can tell: they boot pre-operational in another mode, are commissioned over SDO and
//! started by NMT, walk the CiA 402 state machine on the controlwords they receive, take
//! the target velocity as actual velocity, integrate it into their position, and answer
//! every SYNC with their TPDOs. Quirks make one of them misbehave the ways real drives do.

#[cfg(feature = "plant")]
mod inclinometer;
#[cfg(feature = "plant")]
pub use inclinometer::InclinometerSim;

use heapless::{Deque, LinearMap};

use crate::scenario::{Action, Quirk, Scenario, Stick, STICK_PERIOD_MS};
#[cfg(feature = "plant")]
use crate::simulated::CranePlant;
use crate::simulated::Simulated;
use crate::traffic::Traffic;
use controller::board::{self, CanPort};
use controller::canopen::od::{self, device, Entry};
use controller::canopen::sdo::{self, abort, Object, ObjectDictionary, Value};
use controller::canopen::{self, cob, NmtCommand, NmtState, CONTROLLER_NODE};
use controller::cia402::{controlword, pdo, DriveState};
use controller::commands::request_frame;
use controller::commissioning::OperationMode;
use controller::controller::{Controller, Cycle};
use controller::correction::AxesCorrection;
use controller::drive::{self, Drive};
use controller::feedforward::{Feedforward, Injectable, Replan};
use controller::frame::CanFrame;
use controller::operator::{operator_frame, OperatorFrame};
use core::marker::PhantomData;

/// One simulated CiA 402 drive: NMT slave (boot-up message, pre-operational until
/// started), SDO server of a small object dictionary (the objects commissioning writes,
/// read back as written), the CiA 402 state machine on its controlword, TPDO1
/// (statusword, velocity actual) and TPDO2 (position actual, mode display) on every
/// SYNC while operational, a heartbeat once 0x1017 is set. It boots in profile
/// position mode (0x6060 = 1), as a drive left configured for another machine.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveSim {
    node: u8,
    powered: bool,
    nmt: NmtState,
    boot_up_due: bool,
    od: SimDictionary,
    state: DriveState,
    velocity: i32,
    /// Position, nm (position actual is in µm).
    position_nm: i64,
    /// Velocity actual when a plant moves it (else it is the set point followed).
    actual_velocity: Option<i32>,
    silent: bool,
    quirk: Option<Quirk>,
    /// Statuswords of the last SYNCs, newest first (for a lagging TPDO).
    history: [u16; 4],
    next_heartbeat_ms: u32,
}

/// The objects a simulated drive holds: (index, sub) → (value, size).
#[derive(Debug, Clone, PartialEq)]
struct SimDictionary {
    entries: LinearMap<(u16, u8), (u32, u8), 48>,
    refuses_csv: bool,
    reports_mode: Option<i8>,
    node: u8,
}

impl SimDictionary {
    fn new(node: u8) -> Self {
        let mut entries = LinearMap::new();
        // Profile position, left from another machine; heartbeat off (CiA 301 default);
        // abort connection option 1, fault (a common factory setting).
        for (entry, value) in [
            (device::MODES_OF_OPERATION, 1),
            (device::PRODUCER_HEARTBEAT, 0),
            (device::ABORT_CONNECTION_OPTION, 1),
        ] {
            let _ = entries.insert(key(entry.object), (value, entry.size()));
        }
        Self {
            entries,
            refuses_csv: false,
            reports_mode: None,
            node,
        }
    }

    fn get(&self, entry: Entry) -> u32 {
        get(&self.entries, entry.object)
    }

    fn mode_display(&self) -> i8 {
        self.reports_mode
            .unwrap_or(self.get(device::MODES_OF_OPERATION) as u8 as i8)
    }

    /// Whether the drive accepts writes to `object`: the parameters commissioning writes
    /// and its PDOs' communication and mapping parameters.
    fn writable(object: Object) -> bool {
        const PARAMETERS: [Entry; 12] = [
            device::MODES_OF_OPERATION,
            device::PRODUCER_HEARTBEAT,
            device::QUICK_STOP_OPTION,
            device::ABORT_CONNECTION_OPTION,
            device::QUICK_STOP_DECELERATION,
            device::MAX_MOTOR_SPEED,
            device::VELOCITY_UNIT,
            device::PROFILE_ACCELERATION,
            device::PROFILE_DECELERATION,
            device::INTERPOLATION_PERIOD,
            device::INTERPOLATION_INDEX,
            device::CONSUMER_HEARTBEAT,
        ];
        PARAMETERS.iter().any(|e| e.object == object)
            || pdo_parameter(
                object,
                &[
                    od::RPDO1_COMMUNICATION,
                    od::RPDO2_COMMUNICATION,
                    od::TPDO1_COMMUNICATION,
                    od::TPDO2_COMMUNICATION,
                ],
                &[
                    od::RPDO1_MAPPING,
                    od::RPDO2_MAPPING,
                    od::TPDO1_MAPPING,
                    od::TPDO2_MAPPING,
                ],
            )
    }
}

/// Whether `object` is a parameter of one of a device's PDOs: sub 1 (COB-ID) or 2
/// (transmission type) of one of its `communication` parameters, or sub 0 to 8 (the
/// count and the mapped objects) of one of its `mapping` parameters.
fn pdo_parameter(object: Object, communication: &[u16], mapping: &[u16]) -> bool {
    let Object { index, sub } = object;
    (communication.contains(&index)
        && [od::pdo_cob_id(index), od::pdo_transmission_type(index)]
            .iter()
            .any(|e| e.object.sub == sub))
        || (mapping.contains(&index) && sub <= MAPPED_AT_MOST)
}

/// The objects a simulated device's PDO maps at most: its objects are whole bytes, so
/// eight bytes of data hold eight at most (CiA 301 allows 64, bit by bit).
const MAPPED_AT_MOST: u8 = 8;

/// The key of `object` in a device's stored objects.
fn key(object: Object) -> (u16, u8) {
    (object.index, object.sub)
}

/// The value of `object` as written (0 if it never was).
fn get<const N: usize>(entries: &Objects<N>, object: Object) -> u32 {
    entries.get(&key(object)).map_or(0, |(v, _)| *v)
}

/// The identity object 0x1018 of a simulated device: highest sub-index 4, then vendor
/// id, product code, revision and serial number.
fn identity_value(object: Object, [vendor, product, revision, serial]: [u32; 4]) -> Option<Value> {
    if object.index != od::IDENTITY {
        return None;
    }
    let value = match object.sub {
        0 => sdo_word(4, 1),
        1 => sdo_word(vendor, 4),
        2 => sdo_word(product, 4),
        3 => sdo_word(revision, 4),
        4 => sdo_word(serial, 4),
        _ => return None,
    };
    Some(value)
}

/// A simulated device's stored objects: (index, sub) → (value, size in bytes).
type Objects<const N: usize> = LinearMap<(u16, u8), (u32, u8), N>;

/// `v` as an SDO value of `size` bytes, little endian.
fn sdo_word(v: u32, size: usize) -> Value {
    let bytes = v.to_le_bytes();
    sdo::value(bytes.get(..size).unwrap_or(&bytes))
}

/// A stored object as written (0 in 4 bytes if it never was).
fn stored<const N: usize>(entries: &Objects<N>, object: Object) -> Value {
    let (v, size) = entries.get(&key(object)).copied().unwrap_or((0, 4));
    sdo_word(v, usize::from(size))
}

/// The value `data` carries, little endian, at most 4 bytes.
fn written_value(data: &[u8]) -> u32 {
    let mut word = [0u8; 4];
    for (w, d) in word.iter_mut().zip(data) {
        *w = *d;
    }
    u32::from_le_bytes(word)
}

/// Stores a write the device accepted.
fn store<const N: usize>(entries: &mut Objects<N>, object: Object, data: &[u8]) -> Result<(), u32> {
    entries
        .insert(key(object), (written_value(data), data.len().min(4) as u8))
        .map(|_| ())
        .map_err(|_| abort::OUT_OF_MEMORY)
}

/// The abort answering a write to an object that is not writable: *read only* if it
/// exists, else why it cannot be read.
fn refuse_write(read: Result<Value, u32>) -> u32 {
    match read {
        Ok(_) => abort::READ_ONLY,
        Err(code) => code,
    }
}

impl ObjectDictionary for SimDictionary {
    fn read(&self, object: Object) -> Result<Value, u32> {
        let node = u32::from(self.node);
        let ids = [0x0000_0A1B, 0x0402_0000 | node, 0x0001_0003, 1000 + node];
        if let Some(value) = identity_value(object, ids) {
            return Ok(value);
        }
        if object == device::DEVICE_TYPE.object {
            // CiA 402, servo drive (additional information 0x0002).
            Ok(sdo_word(0x0002_0192, 4))
        } else if object == device::MODES_DISPLAY.object {
            Ok(sdo_word(u32::from(self.mode_display() as u8), 1))
        } else if SimDictionary::writable(object) {
            Ok(stored(&self.entries, object))
        } else {
            Err(abort::NO_OBJECT)
        }
    }

    fn write(&mut self, object: Object, data: &[u8]) -> Result<(), u32> {
        if !SimDictionary::writable(object) {
            return Err(refuse_write(self.read(object)));
        }
        if object == device::MODES_OF_OPERATION.object
            && self.refuses_csv
            && written_value(data) == OperationMode::CyclicSynchronousVelocity as u32
        {
            return Err(abort::INVALID_VALUE);
        }
        store(&mut self.entries, object, data)
    }
}

impl DriveSim {
    /// A drive at `node`, powered and about to send its boot-up message, at `position` m.
    #[must_use]
    pub fn new(node: u8, position: f64) -> Self {
        Self {
            node,
            powered: true,
            nmt: NmtState::PreOperational,
            boot_up_due: true,
            od: SimDictionary::new(node),
            state: DriveState::SwitchOnDisabled,
            velocity: 0,
            position_nm: libm::round(position * 1e9) as i64,
            actual_velocity: None,
            silent: false,
            quirk: None,
            history: [0x0250; 4],
            next_heartbeat_ms: 0,
        }
    }

    /// Its CiA 402 state.
    #[must_use]
    pub fn state(&self) -> DriveState {
        self.state
    }

    /// Its NMT state.
    #[must_use]
    pub fn nmt(&self) -> NmtState {
        self.nmt
    }

    /// Its mode of operation (0x6060).
    #[must_use]
    pub fn mode(&self) -> i8 {
        self.od.get(device::MODES_OF_OPERATION) as u8 as i8
    }

    /// Position actual, m.
    #[must_use]
    pub fn position(&self) -> f64 {
        self.position_nm as f64 * 1e-9
    }

    /// Velocity actual, drive units.
    #[must_use]
    pub fn velocity(&self) -> i32 {
        self.velocity
    }

    /// A value of its object dictionary, as written.
    #[must_use]
    pub fn object(&self, index: u16, sub: u8) -> u32 {
        get(&self.od.entries, Object::new(index, sub))
    }

    /// How fast its axis moves, drive units: as it drives it, plus a creep.
    fn moving(&self) -> i32 {
        match self.quirk {
            Some(Quirk::Creeps(creep)) => self.velocity.saturating_add(creep),
            _ => self.velocity,
        }
    }

    fn statusword(&self) -> u16 {
        let csv = self.od.mode_display() == 9;
        match self.state {
            DriveState::ReadyToSwitchOn => 0x0231,
            DriveState::SwitchedOn => 0x0233,
            DriveState::OperationEnabled if csv => 0x1237,
            DriveState::OperationEnabled => 0x0237,
            DriveState::QuickStopActive => 0x0217,
            DriveState::FaultReactionActive | DriveState::Fault => 0x0218,
            _ => 0x0250,
        }
    }

    fn reported_statusword(&self) -> u16 {
        let lag = match self.quirk {
            Some(Quirk::StatusLag(n)) => usize::from(n),
            _ => 0,
        };
        if lag == 0 {
            self.statusword()
        } else {
            self.history
                .get(lag.min(self.history.len()) - 1)
                .copied()
                .unwrap_or(0x0250)
        }
    }

    fn quirk(&mut self, quirk: Quirk) {
        self.quirk = Some(quirk);
        match quirk {
            Quirk::RefusesCsv => self.od.refuses_csv = true,
            Quirk::ReportsMode(m) => self.od.reports_mode = Some(m),
            Quirk::StatusLag(_)
            | Quirk::SdoMute
            | Quirk::ReportsVelocity(_)
            | Quirk::Creeps(_)
            | Quirk::IgnoresSetpoint => {}
        }
    }

    /// Power-on or NMT reset: everything back to its boot values, boot-up message due.
    fn reboot(&mut self) {
        let quirk = self.quirk;
        *self = Self {
            position_nm: self.position_nm,
            powered: true,
            ..Self::new(self.node, 0.0)
        };
        if let Some(q) = quirk {
            self.quirk(q);
        }
    }

    fn on_nmt(&mut self, command: NmtCommand) {
        self.nmt = match command {
            NmtCommand::Start => NmtState::Operational,
            NmtCommand::Stop => NmtState::Stopped,
            NmtCommand::PreOperational => NmtState::PreOperational,
            NmtCommand::ResetNode | NmtCommand::ResetCommunication => {
                self.reboot();
                NmtState::PreOperational
            }
        };
        if self.nmt != NmtState::Operational && self.state == DriveState::OperationEnabled {
            // A drive that leaves operational loses its RPDOs: it reacts as its abort
            // connection option 0x6007 says (CiA 402): 1 fault, 2 disable voltage,
            // 3 quick stop, 0 nothing.
            self.state = match self.od.get(device::ABORT_CONNECTION_OPTION) as u16 as i16 {
                1 => DriveState::Fault,
                2 => DriveState::SwitchOnDisabled,
                3 => DriveState::QuickStopActive,
                _ => self.state,
            };
        }
    }

    /// Applies an RPDO addressed to this drive: the CiA 402 transitions (numbers of
    /// CiA 402 Fig. 3) for the controlwords the controller sends, anything else ignored.
    /// In *quick stop active* the drive brakes on its own quick-stop ramp (0x6085) on
    /// every SYNC.
    fn command(&mut self, cw: u16, target: i32) {
        use controlword::*;
        use DriveState::*;
        self.state = match (self.state, cw) {
            (Fault, FAULT_RESET) => SwitchOnDisabled, // 15
            (Fault, _) => Fault,
            (OperationEnabled, QUICK_STOP) => QuickStopActive, // 11
            (QuickStopActive, QUICK_STOP) => QuickStopActive,
            (_, DISABLE_VOLTAGE | QUICK_STOP) => SwitchOnDisabled, // 7, 9, 10, 12
            (QuickStopActive, _) => QuickStopActive,
            (SwitchOnDisabled | SwitchedOn | OperationEnabled, SHUTDOWN) => ReadyToSwitchOn, // 2, 6, 8
            (ReadyToSwitchOn, SWITCH_ON) => SwitchedOn,                                      // 3
            (OperationEnabled, SWITCH_ON) => SwitchedOn,                                     // 5
            (SwitchedOn | OperationEnabled, ENABLE_OPERATION) => OperationEnabled,           // 4
            (state, _) => state,
        };
        self.apply_target(target);
    }

    fn apply_target(&mut self, target: i32) {
        use DriveState::*;
        // In any mode but CSV or pv the target velocity means nothing (profile position
        // waits for a target position): the drive stands.
        let follows =
            matches!(self.od.mode_display(), 9 | 3) && self.quirk != Some(Quirk::IgnoresSetpoint);
        self.velocity = match self.state {
            OperationEnabled if follows => target,
            // Braking on its own ramp, SYNC by SYNC (see on_sync).
            QuickStopActive => self.velocity,
            _ => 0,
        };
    }

    /// SYNC: integrate the position over the interpolation period (0x60C2, ms) and
    /// remember the statusword.
    fn on_sync(&mut self) {
        if self.state == DriveState::QuickStopActive {
            // The quick-stop deceleration 0x6085 (units/s) over one interpolation period
            // 0x60C2 (ms), both as commissioned — whatever its NMT state: the drive's
            // motion control does not wait for PDOs to brake.
            let per_cycle = u64::from(self.od.get(device::QUICK_STOP_DECELERATION))
                * u64::from(self.od.get(device::INTERPOLATION_PERIOD).max(1))
                / 1000;
            let step = i32::try_from(per_cycle).unwrap_or(i32::MAX).max(1);
            self.velocity -= self.velocity.clamp(-step, step);
        }
        let period_ms = i64::from(self.od.get(device::INTERPOLATION_PERIOD).max(1));
        // µm/s × ms = nm.
        self.position_nm += i64::from(self.moving()) * period_ms;
        let [a, b, c, _] = self.history;
        self.history = [self.statusword(), a, b, c];
    }
}

/// The bus of crane `K` with `A` driven axes: a drive for each axis, a scenario, and
/// what is waiting to be received; in scenarios with a plant (feature `plant`), the
/// crane's plant ([`Simulated`]) and its inclinometer.
#[derive(Debug, Clone)]
pub struct VirtualBus<K: Simulated<A>, const A: usize> {
    /// The crane's drives, in the model's input order: the order of `drives`.
    order: [Drive; A],
    drives: [DriveSim; A],
    #[cfg(feature = "plant")]
    plant: Option<K::Plant>,
    crane: PhantomData<fn() -> K>,
    #[cfg(feature = "plant")]
    inclinometer: Option<InclinometerSim>,
    scenario: Scenario,
    next_event: usize,
    inbox: Deque<CanFrame, 32>,
    /// Frames due this cycle, in bus order, for [`CanPort::receive`].
    rx: Deque<CanFrame, 32>,
    /// End of the last receive window, ms.
    rx_until: Option<u32>,
    /// Frames that did not fit the receive window (must stay 0; a loss would also show
    /// as a missing frame in the QEMU/host comparison).
    rx_overflow: u32,
    injected: Deque<CanFrame, 32>,
    traffic: Option<Traffic>,
    solver_failure: bool,
    hang: bool,
    hangs: bool,
    bus_off_cycles: u8,
    noise: u32,
    /// The operator's master switch: what it sends, while it sends.
    stick: Option<Stick>,
    /// Its last alive counter.
    stick_counter: u8,
    /// When it sends next, ms.
    next_stick_ms: u32,
}

/// A frame the virtual bus refused (bus-off).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BusOff;

impl<K: Simulated<A> + Default, const A: usize> VirtualBus<K, A> {
    /// A freshly powered drive for each of the drives of crane `K` with its default
    /// parameters (the planar crane's: the paper's lab crane, Tab. 3), the crane resting
    /// with the drives at `start`, and the scenario (with its plant and inclinometer, if
    /// it has one): [`VirtualBus::for_crane`].
    #[must_use]
    pub fn new(scenario: Scenario, start: [f64; A]) -> Self {
        VirtualBus::for_crane(scenario, &K::default(), start)
    }
}

impl<K: Simulated<A>, const A: usize> VirtualBus<K, A> {
    /// A freshly powered drive for each of `crane`'s drives (at its stock node, about to
    /// send its boot-up message), the crane resting with the drives at `start` (each
    /// drive's position, same order: `Crane::drives_at_rest` of where the load rests),
    /// and the scenario's events. A scenario with a plant
    /// (feature `plant`) runs on `crane`'s plant with its parameters, and its
    /// inclinometer at the stock node.
    #[must_use]
    pub fn for_crane(scenario: Scenario, crane: &K, start: [f64; A]) -> Self {
        let drives = K::DRIVES;
        #[cfg(feature = "plant")]
        let (plant, inclinometer) = match scenario.plant {
            Some(mismatch) => (
                Some(crane.plant(mismatch, start)),
                Some(InclinometerSim::new(
                    controller::commissioning::InclinometerSetup::stock(K::SWING_AXES).node,
                )),
            ),
            None => (None, None),
        };
        #[cfg(not(feature = "plant"))]
        let _ = crane;
        let mut at = start.into_iter();
        Self {
            order: drives,
            drives: drives.map(|d| DriveSim::new(d.node(), at.next().unwrap_or(0.0))),
            #[cfg(feature = "plant")]
            plant,
            crane: PhantomData,
            #[cfg(feature = "plant")]
            inclinometer,
            traffic: scenario.random.map(Traffic::new),
            scenario,
            next_event: 0,
            inbox: Deque::new(),
            rx: Deque::new(),
            rx_until: None,
            rx_overflow: 0,
            injected: Deque::new(),
            solver_failure: false,
            hang: false,
            hangs: true,
            bus_off_cycles: 0,
            noise: 0x9E37_79B9,
            stick: None,
            stick_counter: 0,
            next_stick_ms: 0,
        }
    }

    /// The scenario.
    #[must_use]
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// Whether the bus simulates what the scenario asks for: a scenario with a plant
    /// needs the feature `plant`.
    #[must_use]
    pub fn simulates_scenario(&self) -> bool {
        #[cfg(feature = "plant")]
        let plant = self.plant.is_some();
        #[cfg(not(feature = "plant"))]
        let plant = false;
        self.scenario.plant.is_none() || plant
    }

    /// A simulated drive (`None`: the crane has no such drive).
    #[must_use]
    pub fn drive(&self, drive: Drive) -> Option<&DriveSim> {
        drive::of(&self.order, drive, &self.drives)
    }

    fn drive_mut(&mut self, drive: Drive) -> Option<&mut DriveSim> {
        drive::of_mut(&self.order, drive, &mut self.drives)
    }

    /// Does `act` to `drive`'s simulation; an event for a drive the bus does not
    /// simulate (the bridge on the planar crane) does nothing.
    fn on_drive(&mut self, drive: Drive, act: impl FnOnce(&mut DriveSim)) {
        if let Some(d) = self.drive_mut(drive) {
            act(d);
        }
    }

    /// The plant, in scenarios with one.
    #[cfg(feature = "plant")]
    #[must_use]
    pub fn plant(&self) -> Option<&K::Plant> {
        self.plant.as_ref()
    }

    /// The inclinometer, in scenarios with a plant.
    #[cfg(feature = "plant")]
    #[must_use]
    pub fn inclinometer(&self) -> Option<&InclinometerSim> {
        self.inclinometer.as_ref()
    }

    /// The same bus after the watchdog restarted the firmware: the scenario's hang is
    /// not repeated.
    #[must_use]
    pub fn without_hangs(mut self) -> Self {
        self.hangs = false;
        self
    }

    /// Whether the scenario makes the firmware hang now (asked once).
    pub fn take_hang(&mut self) -> bool {
        core::mem::take(&mut self.hang)
    }

    /// Whether the scenario asked for the next solver step to fail (asked once).
    pub fn take_solver_failure(&mut self) -> bool {
        core::mem::take(&mut self.solver_failure)
    }

    fn deliver(&mut self, frame: CanFrame) {
        // 32 frames per cycle are far more than any scenario sends; a loss would show as a
        // missing frame in the QEMU/host comparison.
        let _ = self.inbox.push_back(frame);
    }

    /// The controller transmits `frame`: the drives react (NMT, SDO, RPDO) and answer a
    /// SYNC with their TPDOs. While the bus is off nothing is delivered; the SYNC, always
    /// among a cycle's last frames, counts the bus-off cycles down.
    pub fn transmit(&mut self, frame: &CanFrame) -> Result<(), BusOff> {
        let id = frame.id();
        if self.bus_off_cycles > 0 {
            if id == cob::SYNC {
                self.bus_off_cycles -= 1;
            }
            return Err(BusOff);
        }
        self.on_bus(frame);
        Ok(())
    }

    /// A frame on the bus, the controller's or another node's: the drives (and the
    /// inclinometer) react — NMT, SDO, RPDO — and a SYNC makes them advance and answer.
    fn on_bus(&mut self, frame: &CanFrame) {
        let id = frame.id();
        let data = frame.data();
        if id == cob::SYNC {
            self.sync();
            return;
        }
        #[cfg(feature = "plant")]
        if let Some(sensor) = self.inclinometer.as_mut() {
            let node = sensor.node();
            if id == cob::NMT {
                if let [command, addressee] = *data {
                    if addressee == 0 || addressee == node {
                        if let Some(command) = NmtCommand::from_byte(command) {
                            sensor.on_nmt(command);
                        }
                    }
                }
            } else if id == sdo::REQUEST + u16::from(node) {
                if let Some(answer) = sensor.on_sdo(data) {
                    self.deliver(answer);
                }
            }
        }
        for i in 0..self.drives.len() {
            let Some(d) = self.drives.get_mut(i) else {
                continue;
            };
            let (powered, node, nmt) = (d.powered, d.node, d.nmt);
            if !powered {
                continue;
            }
            if id == cob::NMT {
                if let [command, addressee] = *data {
                    if addressee == 0 || addressee == node {
                        if let Some(command) = NmtCommand::from_byte(command) {
                            d.on_nmt(command);
                        }
                    }
                }
            } else if id == sdo::REQUEST + u16::from(node) {
                if d.nmt != NmtState::Stopped && d.quirk != Some(Quirk::SdoMute) && !d.silent {
                    if let Some(answer) = sdo::serve(&mut d.od, node, data) {
                        self.deliver(answer);
                    }
                }
            } else if id == cob::RPDO1 + u16::from(node) && nmt == NmtState::Operational {
                if let [c0, c1, v0, v1, v2, v3] = *data {
                    d.command(
                        u16::from_le_bytes([c0, c1]),
                        i32::from_le_bytes([v0, v1, v2, v3]),
                    );
                }
            }
        }
    }

    /// SYNC: the drives advance one interpolation period — on their own, or moving the
    /// plant, whose sensed state then is their position and velocity actual and the
    /// inclinometer's slope — and answer with their TPDOs.
    fn sync(&mut self) {
        for d in &mut self.drives {
            if d.powered {
                d.on_sync();
            }
        }
        #[cfg(feature = "plant")]
        let mut slope = None;
        #[cfg(feature = "plant")]
        if let Some(plant) = self.plant.as_mut() {
            let drives = self.drives.each_mut();
            let (u, dt, braked) = plant_inputs(&drives);
            plant.advance_braked(u, dt, braked);
            let sensed = plant.sense();
            report_motion(drives, sensed.motion);
            slope = Some(sensed.slope_deg);
        }
        for i in 0..self.drives.len() {
            let Some(d) = self.drives.get(i) else {
                continue;
            };
            if d.powered && d.nmt == NmtState::Operational && !d.silent {
                let velocity = match d.quirk {
                    Some(Quirk::ReportsVelocity(v)) => v,
                    _ => d.actual_velocity.unwrap_or(d.moving()),
                };
                let node = d.node;
                let status = pdo::tpdo1(node, d.reported_statusword(), velocity);
                let position = pdo::tpdo2(node, (d.position_nm / 1000) as i32, d.od.mode_display());
                self.deliver(status);
                self.deliver(position);
            }
        }
        #[cfg(feature = "plant")]
        if let (Some(sensor), Some(slopes_deg)) = (self.inclinometer.as_mut(), slope) {
            // The planar crane swings in the plane of the long axis only (lateral 0).
            if let Some(frame) = sensor.on_sync(slopes_deg) {
                self.deliver(frame);
            }
        }
    }

    /// Everything that appears on the bus in `(after_ms, up_to_ms]`: the scenario's
    /// events, the drives' boot-up messages and heartbeats, then the answers to the
    /// controller's last frames (SDO responses, the TPDOs answering the SYNC).
    pub fn receive_until(
        &mut self,
        after_ms: u32,
        up_to_ms: u32,
    ) -> impl Iterator<Item = CanFrame> + '_ {
        let mut fresh: Deque<CanFrame, 32> = Deque::new();
        while let Some(e) = self.scenario.events.get(self.next_event).copied() {
            if e.at_ms > up_to_ms {
                break;
            }
            self.next_event += 1;
            self.apply(e.action, &mut fresh);
        }
        while let Some(f) = self.injected.pop_front() {
            let _ = fresh.push_back(f);
        }
        // The master switch's frame every `STICK_PERIOD_MS`, its alive counter changing.
        if let Some(stick) = self.stick {
            if up_to_ms >= self.next_stick_ms {
                self.stick_counter = self.stick_counter.wrapping_add(1);
                let frame = OperatorFrame {
                    counter: self.stick_counter,
                    flags: stick.flags,
                    demand: stick.demand,
                };
                let _ = fresh.push_back(operator_frame(CONTROLLER_NODE, &frame));
                self.next_stick_ms = up_to_ms.saturating_add(STICK_PERIOD_MS);
            }
        }
        if let Some(mut traffic) = self.traffic.take() {
            traffic.cycle(up_to_ms, |a| self.apply(a, &mut fresh));
            self.traffic = Some(traffic);
        }
        for d in self.drives.iter_mut() {
            if !d.powered || d.silent {
                continue;
            }
            if core::mem::take(&mut d.boot_up_due) {
                let _ = fresh.push_back(canopen::heartbeat(d.node, NmtState::BootUp));
                d.next_heartbeat_ms = up_to_ms;
            }
            // Heartbeat every 0x1017 ms once it is set.
            let period = d.od.get(device::PRODUCER_HEARTBEAT);
            if period > 0 && up_to_ms >= d.next_heartbeat_ms {
                let beat = canopen::heartbeat(d.node, d.nmt);
                d.next_heartbeat_ms = up_to_ms.saturating_add(period);
                let _ = fresh.push_back(beat);
            }
        }
        #[cfg(feature = "plant")]
        if let Some(sensor) = self.inclinometer.as_mut() {
            if let Some(beat) = sensor.heartbeat(up_to_ms) {
                let _ = fresh.push_back(beat);
            }
        }
        let _ = after_ms;
        while let Some(f) = self.inbox.pop_front() {
            let _ = fresh.push_back(f);
        }
        core::iter::from_fn(move || fresh.pop_front())
    }

    /// Makes `action` happen now (tests and the soak run); frames it puts on the bus
    /// are received in the next cycle, after the scenario's.
    pub fn inject(&mut self, action: Action) {
        let mut frames = Deque::new();
        self.apply(action, &mut frames);
        while let Some(f) = frames.pop_front() {
            let _ = self.injected.push_back(f);
        }
    }

    fn apply(&mut self, action: Action, fresh: &mut Deque<CanFrame, 32>) {
        match action {
            Action::Request(r) => {
                let _ = fresh.push_back(request_frame(&r));
            }
            Action::Frame(raw) => {
                let _ = fresh.push_back(raw.frame());
            }
            Action::Storm { count } => {
                for _ in 0..count {
                    let f = self.garbage();
                    let _ = fresh.push_back(f);
                }
            }
            Action::DriveFault(drive) => {
                if let Some(d) = self.drive_mut(drive) {
                    d.state = DriveState::Fault;
                    let _ = fresh.push_back(canopen::emcy(d.node, 0x2310, 0x03, [0; 5]));
                }
            }
            Action::DriveWarning(drive) => {
                // Temperature warning: error register without the generic bit.
                let _ = fresh.push_back(canopen::emcy(drive.node(), 0x4210, 0x00, [0; 5]));
            }
            Action::Silence(drive) => self.on_drive(drive, |d| d.silent = true),
            Action::DropOut(drive) => {
                self.on_drive(drive, |d| d.state = DriveState::SwitchOnDisabled);
            }
            Action::Revive(drive) => self.on_drive(drive, |d| d.silent = false),
            Action::PowerOff(drive) => self.on_drive(drive, |d| {
                d.powered = false;
                d.boot_up_due = false;
                d.nmt = NmtState::Stopped;
                d.state = DriveState::NotReadyToSwitchOn;
                d.velocity = 0;
            }),
            Action::PowerOn(drive) => self.on_drive(drive, DriveSim::reboot),
            Action::Nmt(drive, command) => self.on_drive(drive, |d| d.on_nmt(command)),
            Action::Quirk(drive, quirk) => self.on_drive(drive, |d| d.quirk(quirk)),
            Action::SolverFailure => self.solver_failure = true,
            Action::Hang => self.hang = self.hangs,
            Action::BusOff { cycles } => self.bus_off_cycles = cycles,
            #[cfg(feature = "plant")]
            Action::Sensor(fault) => {
                if let Some(sensor) = self.inclinometer.as_mut() {
                    sensor.fail(fault);
                }
            }
            #[cfg(not(feature = "plant"))]
            Action::Sensor(_) => {}
            Action::Stick(stick) => {
                // A master switch that was silent sends at once; one that sends keeps
                // its period.
                if self.stick.is_none() {
                    self.next_stick_ms = 0;
                }
                self.stick = Some(stick);
            }
            Action::StickSilent => self.stick = None,
            Action::Foreign(raw) => {
                let frame = raw.frame();
                self.on_bus(&frame);
                let _ = fresh.push_back(frame);
            }
        }
    }

    /// A pseudo-random frame: unknown ids, wrong lengths, malformed commands, foreign TPDOs.
    fn garbage(&mut self) -> CanFrame {
        self.noise ^= self.noise << 13;
        self.noise ^= self.noise >> 17;
        self.noise ^= self.noise << 5;
        let n = self.noise;
        let bytes = n.to_le_bytes();
        let kind = n % 5;
        let data = [
            bytes[0], bytes[1], bytes[2], bytes[3], bytes[1], bytes[0], bytes[3], bytes[2],
        ];
        let len = ((n >> 8) % 9) as usize;
        let id = match kind {
            0 => 0x210,                                 // a command, mostly malformed
            1 => (0x181 + (n >> 12) % 2) as u16,        // a drive TPDO of a wrong length
            2 => 0x555,                                 // unknown
            3 => (0x700 + 0x40 + (n >> 12) % 8) as u16, // a foreign node's heartbeat
            _ => 0x7FF,                                 // unknown
        };
        let len = if kind == 0 && len == 8 {
            7
        } else if kind == 1 && len == 6 {
            5
        } else {
            len
        };
        CanFrame::fixed(id, data.get(..len).unwrap_or(&[]))
    }
}

/// The virtual bus is the host's CAN port: frames arrive in windows of one cycle (the
/// scenario's events, the drives' boot-up messages and heartbeats, then the answers to
/// the controller's last frames), and a transmitted frame reaches the drives at once —
/// or, during a bus-off, is refused.
/// What the plant gets from its drives this cycle: each drive's set point (m/s; zero
/// without power), the cycle (0x60C2 of the first drive, s), and which axes are held by
/// their brakes (a drive without power on its motor, or not enabled).
#[cfg(feature = "plant")]
fn plant_inputs<const N: usize>(drives: &[&mut DriveSim; N]) -> ([f64; N], f64, [bool; N]) {
    let period_ms = drives
        .first()
        .map_or(1, |d| d.od.get(device::INTERPOLATION_PERIOD).max(1));
    let u = drives.each_ref().map(|d| {
        if d.powered {
            f64::from(d.moving()) * 1e-6
        } else {
            0.0
        }
    });
    let braked = drives.each_ref().map(|d| {
        !d.powered
            || !matches!(
                d.state,
                DriveState::OperationEnabled | DriveState::QuickStopActive
            )
    });
    (u, f64::from(period_ms) * 1e-3, braked)
}

/// The plant's sensed position and velocity of each axis become its drive's position
/// and velocity actual.
#[cfg(feature = "plant")]
fn report_motion<const N: usize>(drives: [&mut DriveSim; N], motion: [(f64, f64); N]) {
    for (d, (position, velocity)) in drives.into_iter().zip(motion) {
        d.position_nm = libm::round(position * 1e9) as i64;
        d.actual_velocity = Some(libm::round(velocity * 1e6) as i32);
    }
}

impl<K: Simulated<A>, const A: usize> CanPort for VirtualBus<K, A> {
    type TxError = BusOff;

    fn transmit(&mut self, _now_ms: u64, frame: &CanFrame) -> Result<(), BusOff> {
        VirtualBus::<K, A>::transmit(self, frame)
    }

    fn lost(&mut self, _now_ms: u64) -> Option<(CanFrame, BusOff)> {
        None
    }

    /// Times saturate at `u32::MAX` ms (49 days; scenarios are short).
    fn receive(&mut self, now_ms: u64) -> Option<CanFrame> {
        let now_ms = u32::try_from(now_ms).unwrap_or(u32::MAX);
        if self.rx.is_empty() && self.rx_until.is_none_or(|t| t < now_ms) {
            let after = self.rx_until.unwrap_or(0);
            let mut window: Deque<CanFrame, 32> = Deque::new();
            for frame in self.receive_until(after, now_ms) {
                let _ = window.push_back(frame);
            }
            for frame in window {
                if self.rx.push_back(frame).is_err() {
                    self.rx_overflow = self.rx_overflow.saturating_add(1);
                }
            }
            self.rx_until = Some(now_ms);
        }
        self.rx.pop_front()
    }
}

impl<K: Simulated<A>, const A: usize> VirtualBus<K, A> {
    /// Frames that did not fit a cycle's receive window (0 in every scenario).
    #[must_use]
    pub fn rx_overflow(&self) -> u32 {
        self.rx_overflow
    }
}

/// One cycle of the firmware's loop on the virtual bus, on the host: [`board::cycle`]
/// with the scenario's hang and solver failure injected before the tick, as the QEMU
/// board does. `None`: the firmware hangs here, and its watchdog takes over.
pub fn run_cycle<F, C, K, const A: usize>(
    controller: &mut Controller<Injectable<F>, C, K, A>,
    bus: &mut VirtualBus<K, A>,
    now_ms: u32,
) -> Option<Cycle<A>>
where
    F: Feedforward<A, Reference = K::Reference> + Replan<A>,
    C: AxesCorrection<A, K::Reference>,
    K: Simulated<A>,
{
    let now = u64::from(now_ms);
    board::cycle(
        controller,
        bus,
        now,
        |controller, bus| {
            if bus.take_hang() {
                return None;
            }
            if bus.take_solver_failure() {
                controller.feedforward_mut().fail_next_step();
            }
            Some(controller.tick(now))
        },
        |_, _| {},
    )
}
