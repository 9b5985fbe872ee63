//! What the controller knows of each node it commissions and supervises — a list built
//! from the commissioning file (`Config::nodes`): a CiA 402 drive per axis of the model's
//! inputs and, for a scene with the state feedback, the CiA 410 inclinometer. A crane
//! with another drive (a bridge) or sensor adds a row, not a field.

use heapless::Vec;

use crate::canopen::NmtState;
use crate::cia402::{statusword, DriveState};
use crate::commissioning::{
    Commissioning, InclinometerSetup, NodeSetup, OperationMode, Phase, Swing, MAX_NODES,
};
use crate::config::Config;
use crate::drive::{Drive, Order};
use crate::fault::Implausibility;
use crate::frame::CanFrame;
use crate::motion::{Actual, MotionWatch};
use crate::node::Role;

/// One node on the bus.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Link {
    /// A drive and the axis it drives.
    Drive(Drive, DriveLink),
    /// The inclinometer.
    Inclinometer(SensorLink),
}

/// The nodes, in the commissioning file's order, with where each of the crane's `A`
/// drives and the inclinometer are in the list.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Links<const A: usize = 2> {
    list: Vec<Link, MAX_NODES>,
    /// The crane's drives, in the model's input order: the order of `axes`.
    drives: Order<A>,
    /// Where each drive is in `list`.
    axes: [Option<usize>; A],
    sensor: Option<usize>,
}

impl<const A: usize> Links<A> {
    /// Links for the nodes of `config`, each commissioned by the controller it
    /// configures: the first drive of each of the crane's `drives` (a row for a drive
    /// the crane lacks is not linked), the inclinometer only if `sensors` (a controller
    /// with the state feedback).
    ///
    /// Always inlined: `sensors` is the controller's `C::ENABLED`, a constant, so that a
    /// firmware without the feedback links none of the inclinometer's commissioning.
    #[inline(always)]
    pub(crate) fn new(config: &Config, drives: [Drive; A], sensors: bool) -> Self {
        let controller = config.node;
        let period_ms = u8::try_from(config.period_ms).unwrap_or(u8::MAX);
        let manager = config.role == Role::Manager;
        let (sdo_timeout_ms, boot_time_ms) = (config.sdo_timeout_ms, config.boot_time_ms);
        let drives = Order::new(drives);
        let mut links = Self {
            list: Vec::new(),
            drives,
            axes: [None; A],
            sensor: None,
        };
        for node in config.nodes.iter().flatten() {
            let at = Some(links.list.len());
            let link = match *node {
                NodeSetup::Drive(axis, setup) => {
                    let Some(slot) = drives.of_mut(axis, &mut links.axes) else {
                        continue;
                    };
                    if slot.is_some() {
                        continue;
                    }
                    *slot = at;
                    Link::Drive(
                        axis,
                        DriveLink::new(
                            Commissioning::new(
                                setup,
                                controller,
                                period_ms,
                                manager,
                                sdo_timeout_ms,
                            )
                            .with_boot_time(boot_time_ms),
                        ),
                    )
                }
                NodeSetup::Inclinometer(setup) if sensors && links.sensor.is_none() => {
                    links.sensor = at;
                    Link::Inclinometer(SensorLink {
                        commissioning: Commissioning::new(
                            setup,
                            controller,
                            period_ms,
                            manager,
                            sdo_timeout_ms,
                        )
                        .with_boot_time(boot_time_ms),
                        nmt: None,
                        last_heartbeat_ms: None,
                        swing: None,
                        fresh: false,
                        outbox: None,
                        seen_operational: false,
                    })
                }
                NodeSetup::Inclinometer(_) => continue,
            };
            // `nodes` has MAX_NODES entries at most: it always fits.
            let _ = links.list.push(link);
        }
        links
    }

    /// How many nodes.
    pub(crate) fn len(&self) -> usize {
        self.list.len()
    }

    /// Node `i` of the list.
    pub(crate) fn get_mut(&mut self, i: usize) -> Option<&mut Link> {
        self.list.get_mut(i)
    }

    /// The drives, with their axes.
    pub(crate) fn drives(&self) -> impl Iterator<Item = (Drive, &DriveLink)> {
        self.list.iter().filter_map(|l| match l {
            Link::Drive(a, link) => Some((*a, link)),
            Link::Inclinometer(_) => None,
        })
    }

    /// The drive of `axis`, if the commissioning file has one.
    pub(crate) fn drive(&self, axis: Drive) -> Option<&DriveLink> {
        match self.list.get((*self.drives.of(axis, &self.axes)?)?)? {
            Link::Drive(_, link) => Some(link),
            Link::Inclinometer(_) => None,
        }
    }

    /// The drive of `axis`, to change.
    pub(crate) fn drive_mut(&mut self, axis: Drive) -> Option<&mut DriveLink> {
        match self.list.get_mut((*self.drives.of(axis, &self.axes)?)?)? {
            Link::Drive(_, link) => Some(link),
            Link::Inclinometer(_) => None,
        }
    }

    /// The axis whose drive is at CANopen node `node`.
    pub(crate) fn axis_at(&self, node: u8) -> Option<Drive> {
        self.drives()
            .find(|(_, link)| link.commissioning.setup().node == node)
            .map(|(axis, _)| axis)
    }

    /// The inclinometer, if the controller has one.
    pub(crate) fn sensor(&self) -> Option<&SensorLink> {
        match self.list.get(self.sensor?)? {
            Link::Inclinometer(link) => Some(link),
            Link::Drive(..) => None,
        }
    }

    /// The inclinometer, to change.
    pub(crate) fn sensor_mut(&mut self) -> Option<&mut SensorLink> {
        match self.list.get_mut(self.sensor?)? {
            Link::Inclinometer(link) => Some(link),
            Link::Drive(..) => None,
        }
    }
}

/// What the controller knows of one drive.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct DriveLink {
    pub(crate) commissioning: Commissioning,
    /// NMT state from its last heartbeat or boot-up message.
    pub(crate) nmt: Option<NmtState>,
    pub(crate) last_heartbeat_ms: Option<u64>,
    pub(crate) statusword: u16,
    pub(crate) state: DriveState,
    pub(crate) velocity: i32,
    pub(crate) position: Option<i32>,
    pub(crate) mode_display: Option<i8>,
    /// Last TPDO1; the clock starts when the drive is first seen operational.
    pub(crate) last_tpdo_ms: Option<u64>,
    pub(crate) last_position_ms: Option<u64>,
    /// The next commissioning frame, answered to a response received between cycles.
    pub(crate) outbox: Option<CanFrame>,
    pub(crate) not_following: u8,
    /// What was implausible about its last position actual, if anything (a reset is
    /// refused meanwhile).
    pub(crate) implausible: Option<Implausibility>,
    /// What the set points sent should have done, and where it came to rest: kept when
    /// it reboots (a drive moved meanwhile is caught when it reports again).
    pub(crate) motion: MotionWatch,
}

impl DriveLink {
    /// Its TPDOs are due from `now_ms` on (it is operational again, or SYNC resumed);
    /// the position it reported before is no baseline for the next (it may have been
    /// moved meanwhile) — until that one comes, its position is unknown.
    pub(crate) fn restart_clocks(&mut self, now_ms: u64) {
        self.last_tpdo_ms = Some(now_ms);
        self.last_position_ms = Some(now_ms);
        self.position = None;
    }

    pub(crate) fn new(commissioning: Commissioning) -> Self {
        Self {
            commissioning,
            nmt: None,
            last_heartbeat_ms: None,
            statusword: 0,
            state: DriveState::Unknown,
            velocity: 0,
            position: None,
            mode_display: None,
            last_tpdo_ms: None,
            last_position_ms: None,
            outbox: None,
            not_following: 0,
            implausible: None,
            motion: MotionWatch::default(),
        }
    }

    /// Commissioned and started: it may be sent PDOs and is supervised.
    pub(crate) fn linked(&self) -> bool {
        self.commissioning.phase() == Phase::Done
    }

    /// Linked, operational and enabled under remote control: it may be asked to move.
    pub(crate) fn ready(&self) -> bool {
        self.linked()
            && self.nmt == Some(NmtState::Operational)
            && self.last_tpdo_ms.is_some()
            && self.state == DriveState::OperationEnabled
            && self.statusword & statusword::REMOTE != 0
    }

    /// Takes its TPDO1 (statusword 0x6041, velocity actual 0x606C) at `now_ms`; `asked`:
    /// it was last sent a set point other than standstill. What the statusword tells is
    /// the controller's to act on.
    pub(crate) fn on_status(
        &mut self,
        sw: u16,
        velocity: i32,
        now_ms: u64,
        asked: bool,
        not_following_limit: u8,
    ) -> StatusReport {
        let limit_before = self.statusword & statusword::INTERNAL_LIMIT;
        let warning_before = self.statusword & statusword::WARNING;
        let csv = self.commissioning.setup().mode == OperationMode::CyclicSynchronousVelocity;
        self.statusword = sw;
        self.state = DriveState::from_statusword(sw);
        self.velocity = velocity;
        self.last_tpdo_ms = Some(now_ms);
        // CSV: bit 12 set while the drive follows the target velocity.
        let ignoring = csv
            && self.state == DriveState::OperationEnabled
            && sw & statusword::FOLLOWING == 0
            && asked;
        self.not_following = if ignoring {
            self.not_following.saturating_add(1)
        } else {
            0
        };
        StatusReport {
            warning: (sw & statusword::INTERNAL_LIMIT != 0 && limit_before == 0)
                || (sw & statusword::WARNING != 0 && warning_before == 0),
            fault: sw & statusword::FAULT != 0,
            not_following: self.not_following >= not_following_limit,
            remote_lost: sw & statusword::REMOTE == 0,
        }
    }

    /// Whether a linked drive fell silent by `now_ms` (CiA 301 heartbeat consumer): no
    /// heartbeat within `heartbeat_timeout_ms`, or — while the controller produces SYNC
    /// (`syncing`) and the drive is operational, so that its TPDOs are due — no TPDO
    /// within `tpdo_timeout_ms`.
    pub(crate) fn silent(
        &self,
        now_ms: u64,
        syncing: bool,
        heartbeat_timeout_ms: u32,
        tpdo_timeout_ms: u32,
    ) -> Option<Silent> {
        if !self.linked() {
            return None;
        }
        let late = |t: Option<u64>, limit: u32| {
            t.is_some_and(|t| now_ms.saturating_sub(t) > u64::from(limit))
        };
        let tpdos_due = syncing && self.nmt == Some(NmtState::Operational);
        if late(self.last_heartbeat_ms, heartbeat_timeout_ms) {
            Some(Silent::Heartbeat)
        } else if tpdos_due
            && (late(self.last_tpdo_ms, tpdo_timeout_ms)
                || late(self.last_position_ms, tpdo_timeout_ms))
        {
            Some(Silent::Tpdo)
        } else {
            None
        }
    }

    /// What it reported at the last SYNC (position actual through the commissioned
    /// scaling, velocity actual in m/s), if both arrived within `fresh_ms` of `now_ms`
    /// and the position was plausible.
    pub(crate) fn actual(&self, now_ms: u64, fresh_ms: u32) -> Option<Actual> {
        let fresh =
            |t: Option<u64>| t.is_some_and(|t| now_ms.saturating_sub(t) <= u64::from(fresh_ms));
        if !(fresh(self.last_position_ms) && fresh(self.last_tpdo_ms)) || self.implausible.is_some()
        {
            return None;
        }
        let setup = self.commissioning.setup();
        Some(Actual {
            position: setup.metres(self.position?),
            velocity: f64::from(self.velocity) / crate::setpoint::UNITS_PER_M_PER_S,
        })
    }

    /// Forgets what the drive reported (it rebooted): the TPDO values are stale.
    pub(crate) fn forget_process_data(&mut self) {
        self.state = DriveState::Unknown;
        self.statusword = 0;
        self.position = None;
        self.velocity = 0;
        self.last_tpdo_ms = None;
        self.last_position_ms = None;
        self.mode_display = None;
        self.not_following = 0;
        self.implausible = None;
    }
}

/// What a drive's statusword reports (CiA 402 Tab. 30), for the controller to act on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct StatusReport {
    /// *Internal limit active* (bit 11) or *warning* (bit 7) rose.
    pub(crate) warning: bool,
    /// *Fault* (bit 3).
    pub(crate) fault: bool,
    /// In CSV, the target velocity ignored (bit 12 clear while enabled and asked to
    /// move) for as many TPDOs in a row as the limit.
    pub(crate) not_following: bool,
    /// *Remote* (bit 9) clear: the drive is under local control.
    pub(crate) remote_lost: bool,
}

/// Which of a drive's messages stopped coming.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Silent {
    /// Its heartbeat.
    Heartbeat,
    /// Its TPDOs, while due.
    Tpdo,
}

/// What the controller knows of the inclinometer.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SensorLink {
    pub(crate) commissioning: Commissioning<InclinometerSetup>,
    pub(crate) nmt: Option<NmtState>,
    pub(crate) last_heartbeat_ms: Option<u64>,
    /// The swing angles of its last TPDO, rad, and whether it arrived since the last
    /// cycle.
    pub(crate) swing: Option<Swing>,
    pub(crate) fresh: bool,
    pub(crate) outbox: Option<CanFrame>,
    /// Seen operational since it was commissioned: a later pre-operational or stopped
    /// heartbeat means it lost its configuration (before, a lost NMT start).
    pub(crate) seen_operational: bool,
}

impl SensorLink {
    /// Commissioned, operational, heard within `timeout_ms`: its angles count.
    pub(crate) fn healthy(&self, now_ms: u64, timeout_ms: u32) -> bool {
        self.commissioning.phase() == Phase::Done
            && self.nmt == Some(NmtState::Operational)
            && self
                .last_heartbeat_ms
                .is_some_and(|t| now_ms.saturating_sub(t) <= u64::from(timeout_ms))
    }
}

/// What a node's heartbeat (or boot-up message) asks of the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Heartbeat {
    /// Nothing to do.
    Nothing,
    /// Commission it from the start: it booted (its configuration is gone), came back
    /// pre-operational after it was operational (someone may have written to its
    /// dictionary), or was not known yet.
    Commission,
    /// Send it NMT *start* (manager): commissioned, but stopped or pre-operational —
    /// a start that was lost, or a node stopped by NMT, which keeps its configuration
    /// (no SDO reaches a stopped node). At most once per heartbeat period of the node
    /// ([`Commissioning::start`]).
    Start,
    /// It is operational again after it was not: its TPDO clocks start now.
    Resumed,
}

/// The controller's answer to a node's NMT state `state` (CiA 301 heartbeat), given its
/// commissioning `phase`, whether it was operational since (`was_operational`), and
/// whether the controller is NMT manager. Also whether the node *left operational*
/// (commissioned, was operational or booted again, is operational no more) — a fault
/// during a move.
///
/// | reported | commissioned, was operational | commissioned, not yet | not known (absent) |
/// |---|---|---|---|
/// | boot-up | commission (left) | commission | commission |
/// | pre-operational | commission (left) | start (manager) | commission |
/// | stopped | start (manager; left) | start (manager) | commission (manager: begins with NMT pre-operational); a slave waits |
/// | operational | — | resumed | commission |
pub(crate) fn on_heartbeat(
    state: NmtState,
    phase: Phase,
    was_operational: bool,
    manager: bool,
) -> (Heartbeat, bool) {
    let done = phase == Phase::Done;
    let left =
        done && (was_operational || state == NmtState::BootUp) && state != NmtState::Operational;
    let start = if manager {
        Heartbeat::Start
    } else {
        Heartbeat::Nothing
    };
    let action = match (state, phase) {
        (NmtState::BootUp, _) => Heartbeat::Commission,
        (NmtState::PreOperational, Phase::Done) if was_operational => Heartbeat::Commission,
        (NmtState::PreOperational | NmtState::Stopped, Phase::Done) => start,
        (NmtState::Stopped, Phase::Absent) if !manager => Heartbeat::Nothing,
        (NmtState::PreOperational | NmtState::Stopped | NmtState::Operational, Phase::Absent) => {
            Heartbeat::Commission
        }
        (NmtState::Operational, Phase::Done) if !was_operational => Heartbeat::Resumed,
        _ => Heartbeat::Nothing,
    };
    (action, left)
}
