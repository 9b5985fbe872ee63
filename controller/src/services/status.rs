//! The status producer: the controller's status frame (0x180 + node; docs/COMMANDS.md,
//! "Status") once for every answer to a request, [`STATUS_PER_CYCLE`] a cycle at most,
//! and on its period with the last answer when no answer went out in the cycle — so a
//! supervisor sees every answer, and the controller's state at least every period.

use crate::commands::{status_frame, Status};
use crate::frame::CanFrame;
use crate::requests::{AnswerRecord, STATUS_PER_CYCLE};

use super::Clock;

/// The status producer and what it sent in the cycle under way.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct StatusProducer {
    /// The period, ms: the commissioned one, whatever the heartbeat's 0x1017 is set to
    /// (a supervisor reads the status, drives watch the heartbeat).
    period_ms: u16,
    /// Answers sent in the cycle under way ([`StatusProducer::end_cycle`] closes every
    /// cycle in which [`StatusProducer::answer`] was asked).
    sent: usize,
}

impl StatusProducer {
    /// A producer of a status frame every `period_ms` (0: answers only).
    pub fn new(period_ms: u16) -> Self {
        Self { period_ms, sent: 0 }
    }

    /// The status frame of node `node` carrying the next answer not yet sent
    /// (`next_unsent` takes it), while the cycle may send one more; `status` is the
    /// controller's status, whose answer fields are the answer's.
    pub fn answer(
        &mut self,
        node: u8,
        status: &Status,
        next_unsent: impl FnOnce() -> Option<AnswerRecord>,
    ) -> Option<CanFrame> {
        if self.sent >= STATUS_PER_CYCLE {
            return None;
        }
        let answer = next_unsent()?;
        self.sent += 1;
        Some(status_frame(
            node,
            &Status {
                last_id: answer.id,
                answer: answer.answer,
                reason: answer.reason,
                overload: answer.overload,
                ..*status
            },
        ))
    }

    /// The end of the cycle at `clock`: the periodic status frame (`status`, with the
    /// last answer) if due and no answer went out in this cycle.
    pub fn end_cycle(&mut self, node: u8, status: &Status, clock: Clock) -> Option<CanFrame> {
        let answered = core::mem::take(&mut self.sent) != 0;
        (clock.due(u32::from(self.period_ms)) && !answered).then(|| status_frame(node, status))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::{Answer, Reject};

    const NODE: u8 = 1;

    fn status() -> Status {
        Status {
            last_id: 7,
            answer: Answer::Accepted,
            reason: None,
            overload: 0,
            mode: 1,
            fault: 0,
            ignored: 3,
            deadline_misses: 0,
            tx_failures: 0,
        }
    }

    fn clock(cycle: u32) -> Clock {
        Clock {
            cycle,
            period_ms: 10,
            first: false,
        }
    }

    #[test]
    fn each_answer_goes_out_in_its_own_frame_with_the_controllers_state() {
        let mut producer = StatusProducer::new(100);
        let rejected = AnswerRecord::of(9, Err(Reject::Busy));
        let frame = producer.answer(NODE, &status(), || Some(rejected));
        let expected = Status {
            last_id: 9,
            answer: Answer::Rejected,
            reason: Some(Reject::Busy),
            ..status()
        };
        assert_eq!(frame, Some(status_frame(NODE, &expected)));
        // An answer went out: no periodic frame on the period's cycle.
        assert_eq!(producer.end_cycle(NODE, &status(), clock(10)), None);
        // The next period has it again.
        assert_eq!(
            producer.end_cycle(NODE, &status(), clock(20)),
            Some(status_frame(NODE, &status()))
        );
    }

    #[test]
    fn at_most_status_per_cycle_answers_go_out_a_cycle_the_rest_wait() {
        let mut producer = StatusProducer::new(100);
        let mut waiting = 0..20u8;
        let mut sent = 0;
        while producer
            .answer(NODE, &status(), || {
                waiting
                    .next()
                    .map(|id| AnswerRecord::of(id, Ok(Answer::Queued)))
            })
            .is_some()
        {
            sent += 1;
        }
        assert_eq!(sent, STATUS_PER_CYCLE);
        assert_eq!(
            waiting.next(),
            Some(STATUS_PER_CYCLE as u8),
            "none taken unsent"
        );
        let _ = producer.end_cycle(NODE, &status(), clock(11));
        assert!(producer
            .answer(NODE, &status(), || Some(AnswerRecord::of(
                30,
                Ok(Answer::Queued)
            )))
            .is_some());
    }

    #[test]
    fn the_periodic_frame_follows_its_own_period_not_the_heartbeats() {
        let mut producer = StatusProducer::new(50);
        let due: heapless::Vec<u32, 8> = (1..21)
            .filter(|&c| producer.end_cycle(NODE, &status(), clock(c)).is_some())
            .collect();
        assert_eq!(due.as_slice(), &[5, 10, 15, 20]);
        let mut silent = StatusProducer::new(0);
        assert!((1..100).all(|c| silent.end_cycle(NODE, &status(), clock(c)).is_none()));
    }
}
