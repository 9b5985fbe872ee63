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
    last_sync_ns: Option<i64>,
    /// The nominal cycle, ns.
    #[serde(skip)]
    period_ns: i64,
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
            last_sync_ns: None,
            period_ns: ((crane.period * 1e9).round() as i64).max(1),
            rpdos: vec![0; n],
            sending: vec![false; n],
            tpdo_timeout: crane.tpdo_timeout,
        }
    }

    /// One frame, `drive` the index of the drive it is of.
    pub fn frame(&mut self, s: &Seen, drive: Option<usize>) {
        match (s.cob, drive) {
            (Cob::Sync, _) => self.sync(s.t, s.ns),
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

    /// A SYNC at `t` s (`ns` exactly). The interval is judged in whole nanoseconds:
    /// a recorder's stamps are whole microseconds, so an interval of exactly 1.5 cycles
    /// or on a bin's edge is common, and f64 seconds would put it on either side.
    fn sync(&mut self, t: f64, ns: i64) {
        self.syncs += 1;
        if let Some(last) = self.last_sync_ns {
            let dt_ns = ns - last;
            let dt = dt_ns as f64 / 1e9;
            self.interval.add(dt);
            self.intervals.push(t, dt * 1e3);
            let period = self.period_ns;
            let (bin_ns, span_ns) = ((BIN_MS * 1e6) as i64, (SPAN_MS * 1e6) as i64);
            let bin = (dt_ns - period + span_ns).div_euclid(bin_ns);
            self.histogram[bin.clamp(0, BINS as i64 - 1) as usize] += 1;
            if 2 * dt_ns > 3 * period {
                // A gap of n cycles (rounded) misses n − 1.
                let cycles = (dt_ns + period / 2) / period;
                self.missed_cycles += u64::try_from(cycles - 1).unwrap_or(0);
                self.gaps.push((t, dt));
            }
            if 2 * dt_ns < period {
                self.doubled_syncs += 1;
            }
        }
        self.last_sync = Some(t);
        self.last_sync_ns = Some(ns);
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
