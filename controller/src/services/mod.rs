//! The controller's own CANopen services, each an object with its state and its unit
//! tests, as CANopenNode has them: the NMT slave with its boot-up and heartbeat
//! ([`nmt::NmtSlave`]), the status producer ([`status::StatusProducer`]) and what the EMCY
//! producer announces for a fault ([`emcy::announcement`]; its queue is
//! [`crate::canopen::emcy::Producer`]). The controller owns them and sequences them in
//! its cycle ([`crate::controller::Controller::tick`]); none of them knows the
//! controller.

pub(crate) mod emcy;
pub(crate) mod nmt;
pub(crate) mod status;

/// Where a cycle stands in the schedule of the periodic messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Clock {
    /// The cycle's number since power-on.
    pub cycle: u32,
    /// The cycle, ms.
    pub period_ms: u32,
    /// The cycle is the first since power-on (it carries the boot-up message).
    pub first: bool,
}

impl Clock {
    /// Whether a message produced every `ms` (0: never) is due: every ⌊ms / period⌋
    /// cycles, from the second cycle on; a period shorter than the cycle, never (the
    /// dictionary refuses such a heartbeat producer time 0x1017, and one that is not a
    /// whole number of cycles: `Node::heartbeat_producer_time`).
    pub fn due(&self, ms: u32) -> bool {
        let cycles = ms.checked_div(self.period_ms).unwrap_or(0);
        !self.first && cycles != 0 && self.cycle.is_multiple_of(cycles)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clock(cycle: u32, period_ms: u32) -> Clock {
        Clock {
            cycle,
            period_ms,
            first: cycle == 0,
        }
    }

    #[test]
    fn a_period_is_due_on_its_multiples_of_the_cycle_from_the_second_cycle_on() {
        let due: heapless::Vec<u32, 8> = (0..25).filter(|&c| clock(c, 10).due(100)).collect();
        assert_eq!(due.as_slice(), &[10, 20]);
        // The first cycle carries the boot-up message, not the heartbeat.
        let first = Clock {
            cycle: 0,
            period_ms: 10,
            first: true,
        };
        assert!(!first.due(100));
        assert!(Clock {
            first: false,
            ..first
        }
        .due(100));
    }

    #[test]
    fn a_period_of_zero_or_below_the_cycle_is_never_due() {
        assert!((1..100).all(|c| !clock(c, 10).due(0)));
        assert!((1..100).all(|c| !clock(c, 10).due(5)));
        assert!((1..100).all(|c| !clock(c, 0).due(100)));
    }
}
