//! A scripted CAN bus: timed frames the drives "send", compiled into the QEMU build
//! and replayed identically by the host reference, so received traffic is exercised
//! in QEMU and both sides see the same bus.

use crate::canopen::{cob, Drive, NmtState};
use crate::frame::CanFrame;

/// A frame as `const` data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawFrame {
    /// 11-bit identifier.
    pub id: u16,
    /// Number of data bytes.
    pub len: u8,
    /// Data.
    pub data: [u8; 8],
}

impl RawFrame {
    /// The frame (id masked to 11 bits, length capped at 8).
    #[must_use]
    pub fn frame(&self) -> CanFrame {
        CanFrame::fixed(
            self.id,
            self.data.get(..usize::from(self.len.min(8))).unwrap_or(&[]),
        )
    }
}

/// When a scripted frame appears.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Event {
    /// Once, at `at_ms`.
    Once {
        /// Time, ms.
        at_ms: u32,
        /// The frame.
        frame: RawFrame,
    },
    /// At `from_ms`, `from_ms + period_ms`, … while before `until_ms`.
    Every {
        /// First time, ms.
        from_ms: u32,
        /// Period, ms.
        period_ms: u32,
        /// End (exclusive), ms.
        until_ms: u32,
        /// The frame.
        frame: RawFrame,
    },
}

impl Event {
    /// How often the event occurs in `(after_ms, up_to_ms]`.
    fn occurrences(&self, after_ms: u32, up_to_ms: u32) -> usize {
        match *self {
            Event::Once { at_ms, .. } => usize::from(at_ms > after_ms && at_ms <= up_to_ms),
            Event::Every {
                from_ms,
                period_ms,
                until_ms,
                ..
            } => {
                let period = u64::from(period_ms.max(1));
                let last = u64::from(up_to_ms.min(until_ms.saturating_sub(1)));
                let (from, after) = (u64::from(from_ms), u64::from(after_ms));
                // Occurrences from_ms + j·period with after < t ≤ last.
                let up_to = |t: u64| if t < from { 0 } else { (t - from) / period + 1 };
                up_to(last).saturating_sub(up_to(after)) as usize
            }
        }
    }

    fn frame(&self) -> RawFrame {
        match *self {
            Event::Once { frame, .. } | Event::Every { frame, .. } => frame,
        }
    }
}

/// A scripted bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Script {
    /// Name, for logs.
    pub name: &'static str,
    /// The events, delivered in this order within a window.
    pub events: &'static [Event],
}

impl Script {
    /// The frames that appear in `(after_ms, up_to_ms]`, in script order.
    pub fn due(&self, after_ms: u32, up_to_ms: u32) -> impl Iterator<Item = CanFrame> + '_ {
        self.events.iter().flat_map(move |e| {
            core::iter::repeat_n(e.frame().frame(), e.occurrences(after_ms, up_to_ms))
        })
    }
}

const fn raw(id: u16, len: u8, data: [u8; 8]) -> RawFrame {
    RawFrame { id, len, data }
}

const fn heartbeat(drive: Drive) -> RawFrame {
    raw(
        cob::HEARTBEAT + drive.node() as u16,
        1,
        [NmtState::Operational as u8, 0, 0, 0, 0, 0, 0, 0],
    )
}

const fn status(drive: Drive, statusword: u16) -> RawFrame {
    let [s0, s1] = statusword.to_le_bytes();
    raw(
        cob::TPDO1 + drive.node() as u16,
        6,
        [s0, s1, 0, 0, 0, 0, 0, 0],
    )
}

/// Forever, for a script's periodic events.
pub const FOREVER: u32 = u32::MAX;

/// Two healthy drives: heartbeats every 100 ms, and a TPDO after every SYNC walking
/// the CiA 402 enable sequence (switch on disabled → ready → switched on → enabled).
pub const HEALTHY: Script = Script {
    name: "healthy",
    events: &[
        Event::Every {
            from_ms: 5,
            period_ms: 100,
            until_ms: FOREVER,
            frame: heartbeat(Drive::Trolley),
        },
        Event::Every {
            from_ms: 5,
            period_ms: 100,
            until_ms: FOREVER,
            frame: heartbeat(Drive::Winch),
        },
        Event::Once {
            at_ms: 5,
            frame: status(Drive::Trolley, 0x0250),
        },
        Event::Once {
            at_ms: 5,
            frame: status(Drive::Winch, 0x0250),
        },
        Event::Once {
            at_ms: 15,
            frame: status(Drive::Trolley, 0x0231),
        },
        Event::Once {
            at_ms: 15,
            frame: status(Drive::Winch, 0x0231),
        },
        Event::Once {
            at_ms: 25,
            frame: status(Drive::Trolley, 0x0233),
        },
        Event::Once {
            at_ms: 25,
            frame: status(Drive::Winch, 0x0233),
        },
        Event::Every {
            from_ms: 35,
            period_ms: 10,
            until_ms: FOREVER,
            frame: status(Drive::Trolley, 0x0237),
        },
        Event::Every {
            from_ms: 35,
            period_ms: 10,
            until_ms: FOREVER,
            frame: status(Drive::Winch, 0x0237),
        },
    ],
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn periodic_and_single_events_fall_in_their_windows() {
        let count = |a, b| HEALTHY.due(a, b).count();
        assert_eq!(
            count(0, 10),
            4,
            "both heartbeats and both first statuswords at 5 ms"
        );
        assert_eq!(count(10, 20), 2);
        assert_eq!(count(30, 40), 2, "first enabled statuswords at 35 ms");
        assert_eq!(count(100, 110), 4, "heartbeats at 105 ms and two TPDOs");
        assert_eq!(count(0, 1000), 20 + 6 + 2 * 97);
    }
}
