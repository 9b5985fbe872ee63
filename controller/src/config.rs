//! The controller's configuration: timing, the nodes it commissions and supervises, and
//! the thresholds of its fault reactions (docs/COMMISSIONING.md). The drives' limits are
//! the planner's ([`crate::planner::Planner::limits`]): one source for the moves it
//! accepts and the set points the gate admits.

use crate::commissioning::{DriveSetup, InclinometerSetup, NodeSetup, MAX_NODES};
use crate::drive::Drive;
use crate::node::Role;

/// Timing, the drives' commissioning table and the thresholds of the fault reactions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// Cycle time, ms (the solver's h): the one owner of the cycle period.
    pub period_ms: u32,
    /// Core clock, Hz: a cycle's budget is one period of it ([`Config::cycle_budget`]).
    pub core_hz: u64,
    /// The controller's node id.
    pub node: u8,
    /// NMT manager or slave.
    pub role: Role,
    /// Period of the controller's heartbeat and status, ms.
    pub heartbeat_period_ms: u16,
    /// A drive whose heartbeat is older than this is lost, ms.
    pub heartbeat_timeout_ms: u32,
    /// A started drive whose TPDOs are older than this is lost, ms.
    pub tpdo_timeout_ms: u32,
    /// An SDO server that has not answered within this fails the transfer, ms.
    pub sdo_timeout_ms: u32,
    /// The nodes commissioned and supervised, in order — a drive per axis, the
    /// inclinometer for a scene with the state feedback (the commissioning file). A
    /// second row for an axis is not used; an axis without one is never ready, so
    /// nothing moves.
    pub nodes: [Option<NodeSetup>; MAX_NODES],
    /// A reset is refused while a drive reports a speed above this, drive units (µm/s).
    pub standstill_units: i32,
    /// How far outside the workspace a drive's position actual may lie before it is
    /// implausible (end stops beyond the planned box, feedback near its edge), m.
    pub position_tolerance_m: f64,
    /// A drive reporting a velocity beyond this multiple of its limit, or moving faster
    /// between two position actuals, reports something implausible.
    pub overspeed: f64,
    /// A node of the list that has not answered this long after the controller began to
    /// look for it is a commissioning failure (CiA 302's boot time, 0x1F89), ms.
    pub boot_time_ms: u32,
    /// A second deadline miss within this many cycles stops the crane.
    pub deadline_window: u32,
    /// This many cycles in a row with a failed RPDO: set points cannot be delivered.
    pub undeliverable_cycles: u32,
    /// Cycles after a reset during which a drive in fault is sent the fault-reset
    /// sequence (not yet a new fault): enough for a statusword that lags a few SYNCs.
    pub fault_reset_cycles: u8,
    /// This many TPDOs in a row of an enabled drive in CSV that does not follow the set
    /// point (statusword bit 12 clear) while it is asked to move: a fault.
    pub not_following_tpdos: u8,
}

impl Config {
    /// 100 Hz on a 400 MHz Cortex-M7, manager of the stock drives at nodes 1 and 2,
    /// heartbeats every 100 ms, drives lost after 300 ms (TPDOs after 50 ms).
    pub const DEFAULT: Self = Self {
        period_ms: 10,
        core_hz: 400_000_000,
        node: 0x10,
        role: Role::Manager,
        heartbeat_period_ms: 100,
        heartbeat_timeout_ms: 300,
        tpdo_timeout_ms: 50,
        sdo_timeout_ms: 100,
        nodes: [
            Some(NodeSetup::Drive(Drive::Trolley, DriveSetup::TROLLEY)),
            Some(NodeSetup::Drive(Drive::Winch, DriveSetup::WINCH)),
            None,
            None,
        ],
        standstill_units: 1_000,
        position_tolerance_m: 0.5,
        overspeed: 1.2,
        boot_time_ms: 10_000,
        deadline_window: 100,
        undeliverable_cycles: 3,
        fault_reset_cycles: 20,
        not_following_tpdos: 3,
    };

    /// A cycle costing more than this (core cycles; QEMU instructions) missed its
    /// deadline: one period of the core clock.
    #[must_use]
    pub fn cycle_budget(&self) -> u64 {
        self.core_hz / 1000 * u64::from(self.period_ms)
    }

    pub(crate) fn period_s(&self) -> f64 {
        f64::from(self.period_ms) / 1000.0
    }

    /// The drive of `axis`, if the nodes have one.
    #[must_use]
    pub fn drive(&self, axis: Drive) -> Option<&DriveSetup> {
        self.nodes.iter().flatten().find_map(|n| match n {
            NodeSetup::Drive(a, d) if *a == axis => Some(d),
            _ => None,
        })
    }

    /// The inclinometer, if the nodes have one.
    #[must_use]
    pub fn inclinometer(&self) -> Option<&InclinometerSetup> {
        self.nodes.iter().flatten().find_map(|n| match n {
            NodeSetup::Inclinometer(i) => Some(i),
            NodeSetup::Drive(..) => None,
        })
    }

    /// These settings with `node` added to the list (see [`Config::add_node`]).
    #[must_use]
    pub fn with_node(mut self, node: NodeSetup) -> Self {
        self.add_node(node);
        self
    }

    /// Adds `node` in the first free place of the list (none left: unchanged, and
    /// `false`).
    pub fn add_node(&mut self, node: NodeSetup) -> bool {
        match self.nodes.iter_mut().find(|n| n.is_none()) {
            Some(slot) => {
                *slot = Some(node);
                true
            }
            None => false,
        }
    }
}
