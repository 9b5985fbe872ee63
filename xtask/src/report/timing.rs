//! Bus timing: the SYNC period and its jitter (a histogram of the deviation from the
//! cycle), missed cycles (a gap of more than 1.5 periods) and doubled SYNCs (less than
//! half a period: two producers), each drive's RPDO before the SYNC that applies it
//! (docs/COMMANDS.md, "Transmit path"), the TPDOs' ages (the gap between two, against
//! the controller's 50 ms timeout) and their delay after SYNC.
//!
//! The time stamps are the recorder's, not the bus's: a host recording over USB or TCP
//! adds its own jitter, which the histogram includes.

use serde::Serialize;

use super::bus::{Cob, Crane};
use super::series::{Capped, Series, Stats};
use super::Seen;

/// The histogram's bins: deviation of a SYNC interval from the period, ms, in bins of
/// [`BIN_MS`] from −[`SPAN_MS`] to +[`SPAN_MS`] (the outer bins take the rest).
pub const BIN_MS: f64 = 0.5;
/// Half the histogram's span, ms.
pub const SPAN_MS: f64 = 5.0;
const BINS: usize = (2.0 * SPAN_MS / BIN_MS) as usize;

/// One drive's TPDO timing.
#[derive(Debug, Clone, Default, Serialize)]
pub struct TpdoTiming {
    /// Gap between consecutive TPDO1s, s.
    pub tpdo1_gap: Stats,
    /// Gap between consecutive TPDO2s, s.
    pub tpdo2_gap: Stats,
    /// Gaps over the controller's TPDO timeout.
    pub over_timeout: u64,
    /// TPDO1's delay after the SYNC it follows, s.
    pub after_sync: Stats,
    #[serde(skip)]
    last: [Option<f64>; 2],
}

/// What the timing section reports.
#[derive(Debug, Serialize)]
pub struct Timing {
    /// The nominal cycle, s.
    pub period: f64,
    /// SYNCs seen.
    pub syncs: u64,
    /// Intervals between SYNCs, s.
    pub interval: Stats,
    /// Histogram of (interval − period) in [`BIN_MS`] bins from −[`SPAN_MS`] ms.
    pub histogram: Vec<u64>,
    /// Cycles missed: a gap of n periods misses n − 1.
    pub missed_cycles: u64,
    /// The gaps (more than 1.5 cycles between two SYNCs), the first 50 and the rest
    /// counted: (when the SYNC came, gap s).
    pub gaps: Capped<(f64, f64)>,
    /// SYNCs less than half a period after the one before.
    pub doubled_syncs: u64,
    /// Per drive (model order): cycles with its RPDO before the SYNC, without, with two.
    pub rpdo_order: Vec<[u64; 3]>,
    /// Per drive (model order).
    pub tpdo: Vec<TpdoTiming>,
    #[serde(skip)]
    pub(crate) intervals: Series,
    #[serde(skip)]
    last_sync: Option<f64>,
    #[serde(skip)]
    rpdos: Vec<u32>,
    #[serde(skip)]
    sending: Vec<bool>,
    #[serde(skip)]
    tpdo_timeout: f64,
}

impl Timing {
    /// For `crane`.
    pub fn new(crane: &Crane) -> Self {
        let n = crane.drives.len();
        Self {
            period: crane.period,
            syncs: 0,
            interval: Stats::default(),
            histogram: vec![0; BINS],
            missed_cycles: 0,
            gaps: Capped::new(50),
            doubled_syncs: 0,
            rpdo_order: vec![[0; 3]; n],
            tpdo: vec![TpdoTiming::default(); n],
            intervals: Series::new(),
            last_sync: None,
            rpdos: vec![0; n],
            sending: vec![false; n],
            tpdo_timeout: crane.tpdo_timeout,
        }
    }

    /// One frame, `drive` the index of the drive it is of.
    pub fn frame(&mut self, s: &Seen, drive: Option<usize>) {
        match (s.cob, drive) {
            (Cob::Sync, _) => self.sync(s.t),
            (Cob::Rpdo(1, _), Some(i)) => {
                self.rpdos[i] += 1;
                self.sending[i] = true;
            }
            (Cob::Tpdo(n @ (1 | 2), _), Some(i)) => {
                let k = usize::from(n - 1);
                let (timeout, sync) = (self.tpdo_timeout, self.last_sync);
                let tp = &mut self.tpdo[i];
                if let Some(last) = tp.last[k] {
                    let gap = s.t - last;
                    if k == 0 {
                        &mut tp.tpdo1_gap
                    } else {
                        &mut tp.tpdo2_gap
                    }
                    .add(gap);
                    if gap > timeout {
                        tp.over_timeout += 1;
                    }
                }
                tp.last[k] = Some(s.t);
                if let (0, Some(sync)) = (k, sync) {
                    tp.after_sync.add(s.t - sync);
                }
            }
            _ => {}
        }
    }

    fn sync(&mut self, t: f64) {
        self.syncs += 1;
        if let Some(last) = self.last_sync {
            let dt = t - last;
            self.interval.add(dt);
            self.intervals.push(t, dt * 1e3);
            let deviation_ms = (dt - self.period) * 1e3;
            let bin = ((deviation_ms + SPAN_MS) / BIN_MS)
                .floor()
                .clamp(0.0, (BINS - 1) as f64);
            self.histogram[bin as usize] += 1;
            if dt > 1.5 * self.period {
                self.missed_cycles += ((dt / self.period).round() as u64).saturating_sub(1);
                self.gaps.push((t, dt));
            }
            if dt < 0.5 * self.period {
                self.doubled_syncs += 1;
            }
        }
        self.last_sync = Some(t);
        for (i, count) in self.rpdos.iter_mut().enumerate() {
            if self.sending[i] {
                let slot = match *count {
                    1 => 0,
                    0 => 1,
                    _ => 2,
                };
                self.rpdo_order[i][slot] += 1;
            }
            *count = 0;
        }
    }
}
