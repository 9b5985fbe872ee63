//! CiA 301 emergency error codes (Tab. 21) the controller sends or classifies, by name.
//! Codes 0xFF00..=0xFFFF are device specific; their meaning is in docs/COMMANDS.md.

/// Error reset or no error: a fault has been cleared.
pub const NO_ERROR: u16 = 0x0000;
/// Software reset (the watchdog restarted the controller).
pub const SOFTWARE_RESET: u16 = 0x6010;
/// Internal software: the inverse model failed.
pub const INTERNAL_SOFTWARE: u16 = 0x6100;
/// Communication, generic: set points could not be delivered.
pub const COMMUNICATION: u16 = 0x8100;
/// Life guard or heartbeat error: a drive's heartbeat stopped or reported a state other
/// than operational.
pub const HEARTBEAT: u16 = 0x8130;
/// Recovered from bus off (CiA 301) — not sent by this controller; named so that it is
/// not used for anything else.
pub const RECOVERED_FROM_BUS_OFF: u16 = 0x8140;
/// CAN-ID collision: another node sends with the controller's own node id, or produces
/// what the controller produces (SYNC, its drives' RPDOs).
pub const CAN_ID_COLLISION: u16 = 0x8150;
/// Position controller (CiA 402): a drive at rest left its standstill window.
pub const STANDSTILL: u16 = 0x8500;
/// Following error (CiA 402): a moving drive left its following window.
pub const FOLLOWING_ERROR: u16 = 0x8611;
/// RPDO timeout: a drive's TPDO (the controller's receive PDO) stopped arriving.
pub const RPDO_TIMEOUT: u16 = 0x8250;
/// Device specific: a second deadline miss.
pub const DEADLINE: u16 = 0xFF01;
/// Device specific: a drive reported a fault.
pub const DRIVE_FAULT: u16 = 0xFF02;
/// Device specific: the set-point choke point refused the model's value.
pub const SETPOINT_REFUSED: u16 = 0xFF03;
/// Device specific: the model asked for motion of a drive that is not enabled.
pub const DRIVE_NOT_READY: u16 = 0xFF04;
/// Device specific: a drive reports a position or velocity it cannot have (outside the
/// workspace, beyond its limits, a jump it cannot make in a cycle).
pub const DRIVE_IMPLAUSIBLE: u16 = 0xFF05;
/// Device specific: commissioning a drive failed (drive, object and reason in the
/// manufacturer bytes).
pub const COMMISSIONING: u16 = 0xFF10;
/// Device specific: the SDO abort code of the commissioning failure announced by the
/// [`COMMISSIONING`] EMCY just before it — drive, object and abort code do not fit one
/// EMCY's five manufacturer bytes (manufacturer bytes: [`ABORT_CODE_FOLLOWS`], the abort
/// code as u32 little-endian; 0 when the failure was no SDO abort, e.g. a wrong device
/// type: the reason is in 0x2002:5).
///
/// Fault codes never take the values of the manufacturer bytes' other meanings: 15 (the
/// feedback warning, [`FEEDBACK_OFF`]), 16 ([`ABORT_CODE_FOLLOWS`]), 22 (a refused
/// manual mode, [`MANUAL_REFUSED_BYTE`]) and 23 (a move the stick ended,
/// [`MOVE_TAKEN_OVER_BYTE`]).
pub const COMMISSIONING_ABORT: u16 = 0xFF12;
/// The first manufacturer byte of [`COMMISSIONING_ABORT`] (where other EMCYs of the
/// controller have their fault code): 16, not a fault of its own.
pub const ABORT_CODE_FOLLOWS: u8 = 16;
/// Device specific: a drive reports a mode of operation (0x6061) other than the
/// commissioned one.
pub const DRIVE_MODE: u16 = 0xFF11;
/// Device specific: the state feedback fell back to feedforward only — a warning
/// (manufacturer bytes: 15, inclinometer node, reason; docs/COMMANDS.md).
pub const FEEDBACK_OFF: u16 = 0xFF20;
/// Device specific: an operator's request for manual mode was refused — a warning
/// (manufacturer bytes: [`MANUAL_REFUSED_BYTE`], 0, the reason,
/// `controller::operator::Refusal`; docs/COMMANDS.md, "Manual mode").
pub const MANUAL_REFUSED: u16 = 0xFF21;
/// The first manufacturer byte of [`MANUAL_REFUSED`] (where a fault has its code): 22,
/// after the faults' 1–21, no fault of its own.
pub const MANUAL_REFUSED_BYTE: u8 = 22;
/// Device specific: the operator's stick ended the running automatic move — a warning, so
/// that the supervisor hears its move will not reach its target (manufacturer bytes:
/// [`MOVE_TAKEN_OVER_BYTE`], 0, how — [`TAKEN_OVER_AT_ONCE`] or [`TAKEN_OVER_AT_REST`] —
/// and zeros; docs/COMMANDS.md, "Manual mode").
pub const MOVE_TAKEN_OVER: u16 = 0xFF22;
/// The first manufacturer byte of [`MOVE_TAKEN_OVER`]: 23, no fault of its own.
pub const MOVE_TAKEN_OVER_BYTE: u8 = 23;
/// [`MOVE_TAKEN_OVER`]'s detail: the stick drives from this cycle on (the operator's
/// generator ended the move with a stop of its own).
pub const TAKEN_OVER_AT_ONCE: u8 = 0;
/// [`MOVE_TAKEN_OVER`]'s detail: the generator refused the hand-over (no stop of its own
/// fitted the drives' headroom, or it would leave the workspace or need a longer virtual
/// pendulum); the move ends with its on-path stop and the stick drives from its rest.
pub const TAKEN_OVER_AT_REST: u8 = 1;

/// Error register (0x1001) bit 0: generic error. CiA 301 requires it whenever any error
/// is present, so an EMCY without it is a warning (see [`is_fault`]).
pub const REGISTER_GENERIC: u8 = 0x01;
/// Error register bit 4: communication error.
pub const REGISTER_COMMUNICATION: u8 = 0x10;
/// Error register bit 7: manufacturer specific.
pub const REGISTER_MANUFACTURER: u8 = 0x80;

/// The rule by which a drive's EMCY is classified: a **fault** when its error code is not
/// *error reset* and its error register has the generic bit set (CiA 301 7.5.2.2: the
/// bit is set while any error is present); otherwise a **warning** (logged and counted,
/// no reaction). A drive's own fault is in any case seen in its statusword (bit 3).
#[must_use]
pub fn is_fault(code: u16, register: u8) -> bool {
    code != NO_ERROR && register & REGISTER_GENERIC != 0
}

/// The EMCY producer's queue (CiA 301 §7.2.7; CANopenNode's `CO_Emergency`): what is to
/// be sent, oldest first, and what the last cycle handed to the board, so that a frame
/// the board reports lost goes out again in its original order.
#[derive(Debug, Clone)]
pub struct Producer<const Q: usize> {
    /// EMCYs to send, oldest first. A full queue keeps the oldest: the first fault is
    /// the cause, and the two frames of a commissioning failure stay together.
    queue: heapless::Deque<crate::frame::CanFrame, Q>,
    /// The EMCYs handed out by the last cycle, each with whether the board reported it
    /// lost; the lost ones go back to the front of `queue` in their original order.
    in_flight: heapless::Vec<(crate::frame::CanFrame, bool), Q>,
}

impl<const Q: usize> Default for Producer<Q> {
    fn default() -> Self {
        Self {
            queue: heapless::Deque::new(),
            in_flight: heapless::Vec::new(),
        }
    }
}

impl<const Q: usize> Producer<Q> {
    /// Queues `frame`; `false` when the queue is full (the frame is dropped, the oldest
    /// kept).
    pub fn send(&mut self, frame: crate::frame::CanFrame) -> bool {
        self.queue.push_back(frame).is_ok()
    }

    /// Puts the frames of the last cycle that the board reported lost back at the front
    /// of the queue, in their original order, and forgets the rest; the number of queued
    /// frames dropped from the back to make room.
    pub fn requeue_lost(&mut self) -> u32 {
        let mut dropped = 0_u32;
        for (frame, lost) in self.in_flight.iter().rev() {
            if !*lost {
                continue;
            }
            if self.queue.is_full() {
                let _ = self.queue.pop_back();
                dropped = dropped.saturating_add(1);
            }
            let _ = self.queue.push_front(*frame);
        }
        self.in_flight.clear();
        dropped
    }

    /// The next frame to send this cycle, remembered as in flight.
    pub fn hand_out(&mut self) -> Option<crate::frame::CanFrame> {
        let frame = self.queue.pop_front()?;
        // Room for it: both hold Q, and `requeue_lost` cleared it.
        let _ = self.in_flight.push((frame, false));
        Some(frame)
    }

    /// The board could not send `frame`: `false` when it was not one handed out by the
    /// last cycle (or was reported already).
    pub fn lost(&mut self, frame: &crate::frame::CanFrame) -> bool {
        match self
            .in_flight
            .iter_mut()
            .find(|(sent, lost)| !*lost && sent == frame)
        {
            Some((_, lost)) => {
                *lost = true;
                true
            }
            None => false,
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::canopen::emcy as frame;

    fn emcy(code: u16) -> crate::frame::CanFrame {
        frame(5, code, 0x81, [0; 5])
    }

    #[test]
    fn a_lost_frame_goes_out_again_first_in_its_order() {
        let mut p = Producer::<4>::default();
        for code in [DEADLINE, DRIVE_FAULT, SETPOINT_REFUSED] {
            assert!(p.send(emcy(code)));
        }
        let sent = [p.hand_out().unwrap(), p.hand_out().unwrap()];
        assert!(p.lost(&sent[1]) && p.lost(&sent[0]));
        assert!(!p.lost(&sent[0]), "reported once");
        assert!(!p.lost(&emcy(HEARTBEAT)), "never handed out");
        assert_eq!(p.requeue_lost(), 0);
        let again: [_; 3] = core::array::from_fn(|_| p.hand_out().unwrap());
        assert_eq!(again, [sent[0], sent[1], emcy(SETPOINT_REFUSED)]);
        assert!(p.hand_out().is_none());
    }

    #[test]
    fn a_full_queue_keeps_the_oldest_and_counts_what_a_requeue_drops() {
        let mut p = Producer::<2>::default();
        assert!(p.send(emcy(DEADLINE)));
        let sent = p.hand_out().unwrap();
        assert!(p.send(emcy(DRIVE_FAULT)) && p.send(emcy(HEARTBEAT)));
        assert!(!p.send(emcy(RPDO_TIMEOUT)), "full: the new one is dropped");
        assert!(p.lost(&sent));
        assert_eq!(p.requeue_lost(), 1, "the newest queued frame made room");
        assert_eq!(p.hand_out(), Some(sent));
        assert_eq!(p.hand_out(), Some(emcy(DRIVE_FAULT)));
        assert_eq!(p.hand_out(), None);
    }
}
