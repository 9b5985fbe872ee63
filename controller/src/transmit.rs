//! The transmit path: a bounded queue in front of the CAN controller's transmit
//! buffers that keeps the cycle's order and accounts for every frame.
//!
//! A cycle hands over up to [`BURST`] (16) frames at once — SDO requests and answers,
//! RPDO trolley (0x201), RPDO winch (0x202), EMCYs (0x090), SYNC (0x080), and every
//! 100 ms the heartbeat (0x710) and the status (0x190) — and a synchronous RPDO counts only if it is on the bus before
//! the SYNC that applies it. The STM32H743's FDCAN, as the `fdcan` 0.2 driver sets it
//! up, has 3 transmit buffers in *queue* mode: the bus takes the pending frame with the
//! lowest identifier first, and a transmit into a full queue displaces a pending frame
//! of higher identifier or is refused. That path sends the SYNC before the winch RPDO,
//! cannot take the heartbeat, and loses frames other than the one it reports
//! (`controller/tests/transmit.rs` shows all three on a model of the driver).
//!
//! The path here instead:
//!
//! * the hardware runs as a FIFO ([`TxFifo`]: the FDCAN's Tx FIFO mode, or
//!   [`FifoModel`] on the virtual bus): frames leave in the order they were handed
//!   over, whatever their identifiers, and nothing in it is ever displaced;
//! * [`TxQueue`] holds what does not fit yet, in submission order, and
//!   [`TxQueue::feed`] moves frames into the hardware as its buffers free (the board
//!   calls it on submission and on its transmit-complete interrupt);
//! * **every frame leaves or is reported lost, exactly once, as itself** ([`Lost`]):
//!   * *queue full* — submitted while the queue is full: the new frame is refused and
//!     returned to the caller at once. What is queued is never overwritten or
//!     reordered, so the refusal is the newest frame, the one in hand to report.
//!     With a queue as long as a cycle's burst ([`BURST`]) this cannot happen, because of:
//!   * *expired* — a frame of an earlier cycle that has not left when a new cycle
//!     begins ([`TxQueue::expire`]): bus-off, or a bus too slow or too busy for the
//!     burst. Its set point or SYNC is stale, so it is taken back (out of the queue, and
//!     cancelled in the hardware) rather than sent late ahead of the fresh cycle;
//!   * *bus-off* — the bus refused it (the virtual bus while it is off).
//!
//! Each lost frame goes to [`Controller::transmit_failed`](crate::Controller::transmit_failed)
//! before the next tick: a lost RPDO counts towards the delivery fault, a lost EMCY is
//! sent again, in the order it was first sent among the EMCYs lost with it.

use heapless::Deque;

use crate::frame::CanFrame;

/// Frames a cycle hands over at most (the capacity of [`Cycle::frames`](crate::Cycle)).
pub const BURST: usize = crate::controller::MAX_FRAMES;

/// A frame on its way out, with the time of the cycle that submitted it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Queued {
    /// The frame.
    pub frame: CanFrame,
    /// The submitting cycle's time, ms.
    pub cycle_ms: u64,
}

/// Why a frame will never leave.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Loss {
    /// Submitted while the queue was full: refused, never queued.
    QueueFull,
    /// Still waiting (queued, or pending in the hardware) when a later cycle began.
    Expired,
    /// Refused by the bus (the virtual bus while it is off).
    BusOff,
}

/// A frame that will never leave, and why: report `queued.frame`, no other.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Lost {
    /// The frame lost, with its cycle.
    pub queued: Queued,
    /// Why.
    pub loss: Loss,
}

/// The CAN controller's transmit buffers run as a FIFO: frames leave in the order
/// they were pushed, and a pushed frame is never displaced by a later one.
pub trait TxFifo {
    /// Whether one more frame fits now.
    fn has_room(&mut self) -> bool;

    /// Appends `queued` behind the frames the hardware holds; called only after
    /// [`TxFifo::has_room`]. `Err` gives the frame back (not taken, nothing sent).
    fn push(&mut self, queued: Queued) -> Result<(), Queued>;

    /// Takes back every frame still pending from a cycle before `now_ms` (cancels its
    /// transmission) and hands each to `lost`, oldest first. A frame that completes
    /// on the bus while being cancelled has left and is not handed over.
    fn cancel_before(&mut self, now_ms: u64, lost: &mut dyn FnMut(Queued));
}

/// What went through the queue since boot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TxStats {
    /// Frames accepted into the queue.
    pub queued: u32,
    /// Frames handed to the hardware.
    pub handed: u32,
    /// Frames refused because the queue was full.
    pub refused: u32,
    /// Frames expired (from the queue or cancelled in the hardware).
    pub expired: u32,
}

/// A bounded FIFO of `N` frames in front of the hardware: order kept, nothing
/// overwritten, every loss returned as the frame lost. No allocation.
#[derive(Debug, Clone)]
pub struct TxQueue<const N: usize> {
    waiting: Deque<Queued, N>,
    stats: TxStats,
}

impl<const N: usize> Default for TxQueue<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> TxQueue<N> {
    /// An empty queue.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            waiting: Deque::new(),
            stats: TxStats {
                queued: 0,
                handed: 0,
                refused: 0,
                expired: 0,
            },
        }
    }

    /// Queues `frame` of the cycle at `now_ms` behind everything queued before it.
    /// A full queue refuses it: `Err` returns this frame, which is the one lost.
    pub fn submit(&mut self, frame: CanFrame, now_ms: u64) -> Result<(), Lost> {
        let queued = Queued {
            frame,
            cycle_ms: now_ms,
        };
        match self.waiting.push_back(queued) {
            Ok(()) => {
                self.stats.queued = self.stats.queued.wrapping_add(1);
                Ok(())
            }
            Err(queued) => {
                self.stats.refused = self.stats.refused.wrapping_add(1);
                Err(Lost {
                    queued,
                    loss: Loss::QueueFull,
                })
            }
        }
    }

    /// Moves frames, oldest first, into the hardware while it has room; returns how
    /// many. Call it after submitting and whenever the hardware frees a buffer.
    pub fn feed(&mut self, hw: &mut impl TxFifo) -> usize {
        let mut handed = 0;
        while hw.has_room() {
            let Some(next) = self.waiting.pop_front() else {
                break;
            };
            if let Err(back) = hw.push(next) {
                // Not taken: it stays first in line (the slot just popped is free).
                let _ = self.waiting.push_front(back);
                break;
            }
            handed += 1;
        }
        self.stats.handed = self.stats.handed.wrapping_add(handed as u32);
        handed
    }

    /// At the start of the cycle at `now_ms`: every frame of an earlier cycle that has
    /// not left is taken back — first those pending in the hardware (they are older),
    /// then those queued — and handed to `lost`, oldest first, each exactly once.
    pub fn expire(&mut self, hw: &mut impl TxFifo, now_ms: u64, mut lost: impl FnMut(Lost)) {
        let mut expired = 0u32;
        hw.cancel_before(now_ms, &mut |queued| {
            expired += 1;
            lost(Lost {
                queued,
                loss: Loss::Expired,
            });
        });
        while let Some(front) = self.waiting.front() {
            if front.cycle_ms >= now_ms {
                break;
            }
            if let Some(queued) = self.waiting.pop_front() {
                expired += 1;
                lost(Lost {
                    queued,
                    loss: Loss::Expired,
                });
            }
        }
        self.stats.expired = self.stats.expired.wrapping_add(expired);
    }

    /// Frames waiting for the hardware.
    #[must_use]
    pub fn len(&self) -> usize {
        self.waiting.len()
    }

    /// Whether nothing waits.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.waiting.is_empty()
    }

    /// Totals since boot.
    #[must_use]
    pub fn stats(&self) -> TxStats {
        self.stats
    }
}

/// A transmit FIFO of `SLOTS` buffers, as the FDCAN's Tx FIFO mode documents it
/// (RM0433, "Tx FIFO": frames leave in the order of the get index, regardless of their
/// identifiers; no element is displaced): the virtual bus's transmit buffers, and the
/// model the host tests run the real controller's bursts through.
#[derive(Debug, Clone, Default)]
pub struct FifoModel<const SLOTS: usize> {
    pending: Deque<Queued, SLOTS>,
}

impl<const SLOTS: usize> FifoModel<SLOTS> {
    /// Empty buffers.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            pending: Deque::new(),
        }
    }

    /// The bus takes the next frame (the FIFO's head): it completes (or is refused
    /// by the bus) and its buffer is free again.
    pub fn take_next(&mut self) -> Option<Queued> {
        self.pending.pop_front()
    }

    /// Frames pending.
    #[must_use]
    pub fn len(&self) -> usize {
        self.pending.len()
    }

    /// Whether no frame is pending.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.pending.is_empty()
    }
}

impl<const SLOTS: usize> TxFifo for FifoModel<SLOTS> {
    fn has_room(&mut self) -> bool {
        !self.pending.is_full()
    }

    fn push(&mut self, queued: Queued) -> Result<(), Queued> {
        self.pending.push_back(queued)
    }

    fn cancel_before(&mut self, now_ms: u64, lost: &mut dyn FnMut(Queued)) {
        // Pending frames are in submission order: the older ones are in front.
        while let Some(front) = self.pending.front() {
            if front.cycle_ms >= now_ms {
                break;
            }
            if let Some(q) = self.pending.pop_front() {
                lost(q);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;

    fn f(id: u16) -> CanFrame {
        CanFrame::new(id, &[]).unwrap()
    }

    #[test]
    fn keeps_order_and_feeds_as_slots_free() {
        let mut q = TxQueue::<8>::new();
        let mut hw = FifoModel::<3>::new();
        for id in [0x201, 0x202, 0x090, 0x080, 0x710, 0x190] {
            q.submit(f(id), 0).unwrap();
            q.feed(&mut hw);
        }
        assert_eq!((hw.len(), q.len()), (3, 3));
        let mut sent = Vec::new();
        while let Some(next) = hw.take_next() {
            sent.push(next.frame.id());
            q.feed(&mut hw);
        }
        assert_eq!(sent, [0x201, 0x202, 0x090, 0x080, 0x710, 0x190]);
        assert_eq!(
            q.stats(),
            TxStats {
                queued: 6,
                handed: 6,
                refused: 0,
                expired: 0
            }
        );
    }

    #[test]
    fn a_full_queue_refuses_the_new_frame_and_keeps_the_rest() {
        let mut q = TxQueue::<2>::new();
        q.submit(f(0x201), 0).unwrap();
        q.submit(f(0x202), 0).unwrap();
        let lost = q.submit(f(0x080), 0).unwrap_err();
        assert_eq!(lost.queued.frame.id(), 0x080);
        assert_eq!(lost.loss, Loss::QueueFull);
        let mut hw = FifoModel::<3>::new();
        q.feed(&mut hw);
        assert_eq!(hw.take_next().unwrap().frame.id(), 0x201);
        assert_eq!(hw.take_next().unwrap().frame.id(), 0x202);
    }

    #[test]
    fn expiry_takes_back_older_cycles_only_hardware_first() {
        let mut q = TxQueue::<8>::new();
        let mut hw = FifoModel::<3>::new();
        for id in [0x201, 0x202, 0x080, 0x710, 0x190] {
            q.submit(f(id), 100).unwrap();
        }
        q.feed(&mut hw);
        let mut lost = Vec::new();
        q.expire(&mut hw, 100, |l| lost.push(l));
        assert!(lost.is_empty(), "the cycle's own frames do not expire");
        q.expire(&mut hw, 110, |l| lost.push(l));
        let ids: Vec<u16> = lost.iter().map(|l| l.queued.frame.id()).collect();
        assert_eq!(ids, [0x201, 0x202, 0x080, 0x710, 0x190]);
        assert!(lost.iter().all(|l| l.loss == Loss::Expired));
        assert!(hw.is_empty() && q.is_empty());
        assert_eq!(q.stats().expired, 5);
    }
}
