//! The controller's NMT slave (CiA 301 §7.3.2): its state machine ([`Node`], which obeys
//! NMT commands) and the messages it produces itself, the boot-up message after power-on
//! or a reset, and the heartbeat on its producer time 0x1017.

use crate::canopen::{self, NmtCommand, NmtState};
use crate::frame::CanFrame;
use crate::node::{Node, Role};

use super::Clock;

/// The NMT slave: its node and which of its own messages are due.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct NmtSlave {
    /// The node: its NMT state and the parameters a master may change.
    pub node: Node,
    /// A boot-up message is due (power-on, or a reset of the node or its communication).
    boot_up_due: bool,
    /// No cycle has begun yet.
    starting: bool,
    /// The cycle under way is the first: it carries the boot-up message, no heartbeat.
    first_cycle: bool,
}

impl NmtSlave {
    /// A node just powered on: its boot-up message is due in the first cycle.
    pub fn new(node: Node) -> Self {
        Self {
            node,
            boot_up_due: true,
            starting: true,
            first_cycle: true,
        }
    }

    /// Obeys an NMT command addressed to it ([`Node::on_nmt`]); after a reset a boot-up
    /// message is due (the producer time back to `boot_heartbeat_ms`).
    pub fn on_command(&mut self, command: NmtCommand, boot_heartbeat_ms: u16) {
        if self.node.on_nmt(command, boot_heartbeat_ms) {
            self.boot_up_due = true;
        }
    }

    /// The beginning of a cycle: the boot-up message, if due. A manager starts itself
    /// after its boot-up (CiA 302); a slave waits for its master's *start*.
    pub fn begin_cycle(&mut self) -> Option<CanFrame> {
        self.first_cycle = core::mem::take(&mut self.starting);
        if !core::mem::take(&mut self.boot_up_due) {
            return None;
        }
        if self.node.role == Role::Manager {
            self.node.state = NmtState::Operational;
        }
        Some(canopen::heartbeat(self.node.id, NmtState::BootUp))
    }

    /// The clock of cycle number `cycle` of a `period_ms` cycle (the first since
    /// power-on, or not).
    pub fn clock(&self, cycle: u32, period_ms: u32) -> Clock {
        Clock {
            cycle,
            period_ms,
            first: self.first_cycle,
        }
    }

    /// The heartbeat (its NMT state), if due at `clock`: every producer time 0x1017
    /// (0: none).
    pub fn heartbeat(&self, clock: Clock) -> Option<CanFrame> {
        clock
            .due(u32::from(self.node.heartbeat_ms))
            .then(|| canopen::heartbeat(self.node.id, self.node.state))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::StagedRequest;

    fn slave(role: Role) -> NmtSlave {
        NmtSlave::new(Node {
            id: 5,
            role,
            state: NmtState::PreOperational,
            heartbeat_ms: 100,
            supervisor: 0,
            cycle_us: 10_000,
            request: StagedRequest::default(),
            operator: Default::default(),
            drives_consumer_ms: 0,
            listed: [0; crate::commissioning::MAX_NODES],
        })
    }

    /// The data byte of a heartbeat frame (its NMT state).
    fn state_byte(frame: &CanFrame) -> (u16, u8) {
        (frame.id(), frame.data().first().copied().unwrap_or(0xEE))
    }

    #[test]
    fn the_boot_up_message_comes_first_and_once() {
        let mut nmt = slave(Role::Slave);
        let boot = nmt.begin_cycle().map(|f| state_byte(&f));
        assert_eq!(boot, Some((0x705, 0x00)));
        assert!(nmt.clock(0, 10).first);
        assert_eq!(
            nmt.heartbeat(nmt.clock(0, 10)),
            None,
            "no heartbeat beside the boot-up"
        );
        assert_eq!(nmt.begin_cycle(), None);
        assert!(!nmt.clock(1, 10).first);
        // A slave waits for its master's start.
        assert_eq!(nmt.node.state, NmtState::PreOperational);
    }

    #[test]
    fn a_manager_starts_itself_after_its_boot_up() {
        let mut nmt = slave(Role::Manager);
        assert!(nmt.begin_cycle().is_some());
        assert_eq!(nmt.node.state, NmtState::Operational);
    }

    #[test]
    fn the_heartbeat_says_the_state_every_producer_time() {
        let mut nmt = slave(Role::Slave);
        let _ = nmt.begin_cycle();
        let _ = nmt.begin_cycle();
        let beats: heapless::Vec<u32, 4> = (1..35)
            .filter(|&c| nmt.heartbeat(nmt.clock(c, 10)).is_some())
            .collect();
        assert_eq!(beats.as_slice(), &[10, 20, 30]);
        assert_eq!(
            nmt.heartbeat(nmt.clock(10, 10)).map(|f| state_byte(&f)),
            Some((0x705, 0x7F))
        );
        nmt.on_command(NmtCommand::Start, 100);
        assert_eq!(
            nmt.heartbeat(nmt.clock(10, 10)).map(|f| state_byte(&f)),
            Some((0x705, 0x05))
        );
        nmt.on_command(NmtCommand::Stop, 100);
        assert_eq!(
            nmt.heartbeat(nmt.clock(10, 10)).map(|f| state_byte(&f)),
            Some((0x705, 0x04))
        );
        // 0x1017 = 0: no heartbeat.
        nmt.node.heartbeat_ms = 0;
        assert!((0..100).all(|c| nmt.heartbeat(nmt.clock(c, 10)).is_none()));
    }

    #[test]
    fn a_reset_makes_the_boot_up_due_again_and_restores_the_producer_time() {
        let mut nmt = slave(Role::Manager);
        let _ = nmt.begin_cycle();
        nmt.node.heartbeat_ms = 500;
        nmt.on_command(NmtCommand::ResetCommunication, 100);
        assert_eq!(nmt.node.heartbeat_ms, 100);
        assert_eq!(nmt.node.state, NmtState::PreOperational);
        assert_eq!(
            nmt.begin_cycle().map(|f| state_byte(&f)),
            Some((0x705, 0x00))
        );
        // Not the first cycle: the heartbeat goes on beside a later boot-up.
        assert!(nmt.heartbeat(nmt.clock(10, 10)).is_some());
        assert_eq!(nmt.node.state, NmtState::Operational);
        // Start, stop and pre-operational are no resets.
        nmt.on_command(NmtCommand::Stop, 100);
        nmt.on_command(NmtCommand::PreOperational, 100);
        assert_eq!(nmt.begin_cycle(), None);
    }
}
