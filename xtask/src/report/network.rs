//! The network: the nodes seen, their boot-ups, NMT commands and states, heartbeats and
//! their ages, and each node's SDO transcript (commissioning) by object name.

use std::collections::BTreeMap;

use controller::canopen::nmt::NmtState;
use serde::Serialize;

use super::bus::{Cob, Crane};
use super::sdo::{Channel, Eds};
use super::series::{Capped, Stats};
use super::Seen;

/// One node as the log shows it. Its lists keep their first entries and count the
/// rest, so that a node rebooting every second for hours costs no more memory.
#[derive(Debug, Clone, Serialize)]
pub struct Node {
    /// Frames the node sent (EMCY, TPDO, SDO answers, heartbeats).
    pub frames: u64,
    /// First and last frame it sent, s.
    pub first: f64,
    /// Last frame it sent, s.
    pub last: f64,
    /// Boot-up messages (heartbeat state 0), s.
    pub boot_ups: Capped<f64>,
    /// Heartbeats seen (boot-up messages not counted).
    pub heartbeats: u64,
    /// Intervals between its heartbeats, s (none across a boot-up).
    pub heartbeat_interval: Stats,
    /// Heartbeat gaps longer than the controller's timeout: (when the next heartbeat or
    /// boot-up came, gap s).
    pub heartbeat_gaps: Capped<(f64, f64)>,
    /// Its last heartbeat since its last boot-up, s (its age at the log's end is the
    /// end less this).
    pub last_heartbeat: Option<f64>,
    /// NMT states its heartbeat reported, in order, when they changed: (s, state).
    pub states: Capped<(f64, String)>,
    /// The state its last heartbeat reported.
    #[serde(skip)]
    state_now: Option<String>,
}

impl Node {
    fn new() -> Self {
        Self {
            frames: 0,
            first: 0.0,
            last: 0.0,
            boot_ups: Capped::new(BOOT_UPS),
            heartbeats: 0,
            heartbeat_interval: Stats::default(),
            heartbeat_gaps: Capped::new(GAPS),
            last_heartbeat: None,
            states: Capped::new(STATES),
            state_now: None,
        }
    }
}

/// An NMT command seen on the bus.
#[derive(Debug, Clone, Serialize)]
pub struct NmtCommand {
    /// When, s.
    pub t: f64,
    /// Its name (the DBC's value table).
    pub command: String,
    /// The node addressed (0: all).
    pub node: u8,
}

/// What the network section reports.
#[derive(Debug)]
pub struct Network {
    /// Nodes by id.
    pub nodes: BTreeMap<u8, Node>,
    /// NMT commands.
    pub nmt: Capped<NmtCommand>,
    /// SDO channels by server node.
    pub sdo: BTreeMap<u8, Channel>,
    /// Heartbeats of the controller's node id less than half its period apart: two
    /// nodes beating with one id.
    pub early_controller_heartbeats: u64,
    eds: BTreeMap<u8, Eds>,
    timeout: f64,
    controller: u8,
    controller_period: f64,
}

/// Most boot-ups kept per node.
const BOOT_UPS: usize = 50;
/// Most heartbeat gaps kept per node.
const GAPS: usize = 50;
/// Most NMT state changes kept per node.
const STATES: usize = 100;

impl Network {
    /// For `crane`, with the object names of `eds` per node.
    pub fn new(crane: &Crane, eds: BTreeMap<u8, Eds>) -> Self {
        Self {
            nodes: BTreeMap::new(),
            nmt: Capped::new(200),
            sdo: BTreeMap::new(),
            early_controller_heartbeats: 0,
            eds,
            timeout: crane.heartbeat_timeout,
            controller: crane.controller,
            controller_period: crane.heartbeat,
        }
    }

    /// The EDS used for `node`, if any.
    pub fn eds_of(&self, node: u8) -> Option<&Eds> {
        self.eds.get(&node)
    }

    /// One frame.
    pub fn frame(&mut self, s: &Seen) {
        let data = s.frame.bytes();
        if let Some(node) = s.cob.node().filter(|_| s.cob.sent_by_node()) {
            let n = self.nodes.entry(node).or_insert_with(Node::new);
            if n.frames == 0 {
                n.first = s.t;
            }
            n.frames += 1;
            n.last = s.t;
        }
        match s.cob {
            Cob::Nmt => {
                let command = s
                    .label("command")
                    .unwrap_or_else(|| format!("0x{:02X}", data.first().copied().unwrap_or(0)));
                self.nmt.push(NmtCommand {
                    t: s.t,
                    command,
                    node: data.get(1).copied().unwrap_or(0),
                });
            }
            Cob::Heartbeat(node) => self.heartbeat(s, node),
            Cob::SdoRequest(node) => {
                let eds = self.eds.get(&node);
                self.sdo.entry(node).or_default().request(s.t, data, eds);
            }
            Cob::SdoResponse(node) => {
                let eds = self.eds.get(&node);
                self.sdo.entry(node).or_default().response(s.t, data, eds);
            }
            _ => {}
        }
    }

    /// A frame of the NMT error control channel (0x700 + node): a boot-up message or a
    /// heartbeat. A boot-up is no heartbeat: a node starts producing heartbeats only
    /// once its producer time (0x1017) is set, and CiA 301 has a consumer watch a node
    /// from its first heartbeat on — so the time from a boot-up to the first heartbeat
    /// is no gap, while the silence from the last heartbeat to a reboot is one.
    fn heartbeat(&mut self, s: &Seen, node: u8) {
        let Some(&state) = s.frame.bytes().first() else {
            return;
        };
        let (timeout, controller, period) = (self.timeout, self.controller, self.controller_period);
        let n = self.nodes.entry(node).or_insert_with(Node::new);
        let boot_up = state & 0x7F == 0;
        if let Some(last) = n.last_heartbeat {
            let gap = s.t - last;
            if gap > timeout {
                n.heartbeat_gaps.push((s.t, gap));
            }
            if !boot_up {
                n.heartbeat_interval.add(gap);
                if node == controller && gap < period / 2.0 {
                    self.early_controller_heartbeats += 1;
                }
            }
        }
        if boot_up {
            n.boot_ups.push(s.t);
            n.last_heartbeat = None;
        } else {
            n.heartbeats += 1;
            n.last_heartbeat = Some(s.t);
        }
        // Bit 7 is node guarding's toggle bit (its answers share 0x700 + node).
        let name = match NmtState::from_byte(state & 0x7F) {
            Some(NmtState::BootUp) => "boot-up".to_string(),
            Some(NmtState::Stopped) => "stopped".to_string(),
            Some(NmtState::Operational) => "operational".to_string(),
            Some(NmtState::PreOperational) => "pre-operational".to_string(),
            None => format!("state {} (not CiA 301)", state & 0x7F),
        };
        if n.state_now.as_ref() != Some(&name) {
            n.states.push((s.t, name.clone()));
            n.state_now = Some(name);
        }
    }

    /// The end of the log.
    pub fn finish(&mut self) {
        self.sdo.values_mut().for_each(Channel::finish);
    }

    /// Whether the controller was heard at all.
    pub fn controller_heard(&self) -> bool {
        self.nodes
            .get(&self.controller)
            .is_some_and(|n| n.frames > 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::firmware::root;
    use crate::report::logs::Frame;

    fn beat(network: &mut Network, t: f64, node: u8, state: u8) {
        let ns = (t * 1e9).round() as i64;
        let frame = Frame {
            t: ns,
            id: 0x700 + u32::from(node),
            extended: false,
            remote: false,
            len: 1,
            data: [state, 0, 0, 0, 0, 0, 0, 0],
        };
        network.frame(&Seen {
            t,
            ns,
            frame: &frame,
            cob: Cob::Heartbeat(node),
            decoded: None,
        });
    }

    #[test]
    fn a_boot_up_is_no_heartbeat_and_the_wait_for_the_first_is_no_gap() {
        let crane = Crane::load(&root().join("scenes/paper-crane.toml")).unwrap();
        let mut network = Network::new(&crane, BTreeMap::new());
        // Boot-up; commissioning sets 0x1017 and the first heartbeat comes 0.6 s later.
        beat(&mut network, 0.0, 1, 0);
        for k in 0..5 {
            beat(&mut network, 0.6 + 0.1 * f64::from(k), 1, 0x7F);
        }
        // Silent for a second, then it reboots: that silence is a gap.
        beat(&mut network, 2.0, 1, 0);
        beat(&mut network, 2.7, 1, 0x7F);
        let n = &network.nodes[&1];
        assert_eq!(n.boot_ups.items, [0.0, 2.0]);
        assert_eq!(n.heartbeats, 6);
        assert_eq!(n.heartbeat_interval.count, 4);
        assert!((n.heartbeat_interval.max - 0.1).abs() < 1e-9, "{n:?}");
        assert_eq!(n.heartbeat_gaps.items.len(), 1, "{:?}", n.heartbeat_gaps);
        assert!((n.heartbeat_gaps.items[0].1 - 1.0).abs() < 1e-9);
        assert_eq!(n.last_heartbeat, Some(2.7));
    }

    #[test]
    fn a_node_rebooting_for_hours_costs_bounded_memory_and_every_boot_up_is_counted() {
        let crane = Crane::load(&root().join("scenes/paper-crane.toml")).unwrap();
        let mut network = Network::new(&crane, BTreeMap::new());
        for k in 0..10_000u32 {
            let t = f64::from(k);
            beat(&mut network, t, 1, 0);
            beat(&mut network, t + 0.5, 1, if k % 2 == 0 { 0x7F } else { 5 });
        }
        let n = &network.nodes[&1];
        assert_eq!(n.boot_ups.items.len(), BOOT_UPS);
        assert_eq!(n.boot_ups.items.len() as u64 + n.boot_ups.dropped, 10_000);
        assert_eq!(n.heartbeat_gaps.items.len(), GAPS);
        assert_eq!(
            n.heartbeat_gaps.items.len() as u64 + n.heartbeat_gaps.dropped,
            9_999
        );
        assert_eq!(n.states.items.len(), STATES);
        assert_eq!(n.states.items.len() as u64 + n.states.dropped, 20_000);
    }
}
