//! The load: its swing from the inclinometer (CiA 410 slope long16 0x6010, the 3D
//! crane's slope lateral16 0x6020 too, turned into the swing by the commissioning file's
//! sign and offset), its position from the drives' positions and the swing, and per move
//! a verdict against docs/COMMANDS.md's targets: within ±50 mm of the target
//! horizontally and swinging less than 0.1° 5 s after the move, the set points exactly
//! zero once it rests.
//!
//! The load hangs at the rope's end below the rope's exit: with the rope's slopes α (x–z
//! plane) and β (y–z), tan α = (x_C − x)/z_C and tan β = (y_C − y)/z_C (the controller's
//! definition, docs/COMMISSIONING.md), and l² = (x_C − x)² + (y_C − y)² + z_C², so
//! z_C = l / √(1 + tan²α + tan²β). The planar crane is β = 0 (x_C = x + l sin φ,
//! z_C = l cos φ, Eq. 20).
//!
//! A move ends at its planned end (accepted, or the end of the move it was queued
//! behind, plus its duration); a move asked as fast as the limits allow, a stopped move
//! and one ended by a fault end when every set point has been zero for 0.1 s. It is
//! judged over one swing period (2π √(l/g)) from 5 s after its end, by the largest
//! distance and swing in that window: a swinging load passes through its rest position.

use serde::Serialize;

use super::bus::Crane;
use super::series::{Capped, Series};

/// Docs/COMMANDS.md and README.md: the load within ±50 mm of its target horizontally …
pub const POSITION_TARGET: f64 = 0.05;
/// … and swinging less than 0.1° 5 s after the move.
pub const SWING_TARGET_DEG: f64 = 0.1;
/// How long after the move it is judged, s.
pub const AFTER: f64 = 5.0;
/// Set points zero this long: at rest, s.
const REST: f64 = 0.1;
/// A reading older than this is not the swing now, s.
const STALE: f64 = 0.1;
const G: f64 = 9.81;

/// One move's verdict.
#[derive(Debug, Clone, Serialize)]
pub struct Verdict {
    /// Request id.
    pub id: u8,
    /// Target, m (x, z; the 3D crane's x, y, z).
    pub target: Vec<f64>,
    /// When it was accepted, s.
    pub accepted: f64,
    /// When it started, s.
    pub start: Option<f64>,
    /// When it ended, s.
    pub end: Option<f64>,
    /// How its end was found.
    pub ended_by: String,
    /// Largest horizontal distance of the load from the target in the window, m.
    pub horizontal: Option<f64>,
    /// Largest vertical distance, m (shown, not judged: the rope's calibration).
    pub vertical: Option<f64>,
    /// Largest swing in the window per plane, degrees (`None`: not measured).
    pub swing: Vec<Option<f64>>,
    /// Cycles in the window with a set point not zero.
    pub moving_cycles: u64,
    /// Cycles in the window with a fresh inclinometer reading.
    pub swing_cycles: u64,
    /// Cycles in the window.
    pub cycles: u64,
    /// Pass, fail, or why it cannot be judged.
    pub verdict: String,
}

#[derive(Debug, Clone)]
struct Track {
    v: Verdict,
    duration: Option<f64>,
    queued: bool,
    stopped: bool,
    faulted: bool,
    rest_since: Option<f64>,
    window: Option<(f64, f64)>,
}

/// What the load section reports.
#[derive(Debug)]
pub struct Load {
    /// Swing per plane, degrees.
    pub(crate) swing: [Series; 2],
    /// Load position x_C (and y_C), z_C, m.
    pub(crate) position: [Series; 3],
    /// Inclinometer frames read.
    pub readings: u64,
    /// SYNCs after the first reading with none fresher than 0.1 s.
    pub stale_cycles: u64,
    /// Largest swing seen per plane, degrees (`None`: not read).
    pub max_swing: [Option<f64>; 2],
    /// The moves judged.
    pub verdicts: Capped<Verdict>,
    /// Accepted moves not yet judged (the log may end first).
    tracks: Vec<Track>,
    angle: [Option<f64>; 2],
    angle_t: Option<f64>,
    crane: Crane,
    planes: usize,
    fault_now: bool,
}

impl Load {
    /// For `crane`.
    pub fn new(crane: &Crane) -> Self {
        Self {
            swing: [Series::new(), Series::new()],
            position: [Series::new(), Series::new(), Series::new()],
            readings: 0,
            stale_cycles: 0,
            max_swing: [None; 2],
            verdicts: Capped::new(500),
            tracks: Vec::new(),
            angle: [None; 2],
            angle_t: None,
            crane: crane.clone(),
            planes: crane.planes,
            fault_now: false,
        }
    }

    /// How many swing planes this crane has (1 planar, 2 for the 3D crane).
    pub fn planes(&self) -> usize {
        self.planes
    }

    /// An inclinometer frame: slope long16 (and lateral16), degrees as the DBC reads them
    /// (0.01° per unit, the stock resolution).
    pub fn inclinometer(&mut self, t: f64, long: Option<f64>, lateral: Option<f64>) {
        let i = self.crane.inclinometer;
        let rescale = i.resolution_deg / 0.01;
        for (plane, slope) in [long, lateral].into_iter().enumerate() {
            if let Some(slope) = slope {
                let swing = i.sign[plane] * (slope * rescale - i.offset_deg[plane]);
                self.angle[plane] = Some(swing);
                if plane < self.planes {
                    let max = &mut self.max_swing[plane];
                    *max = Some(max.map_or(swing.abs(), |m| m.max(swing.abs())));
                    self.swing[plane].push(t, swing);
                }
            }
        }
        self.readings += 1;
        self.angle_t = Some(t);
    }

    /// A move accepted (or queued).
    pub fn accepted(
        &mut self,
        t: f64,
        id: u8,
        target: Vec<f64>,
        duration: Option<f64>,
        queued: bool,
    ) {
        self.tracks.push(Track {
            v: Verdict {
                id,
                target,
                accepted: t,
                start: (!queued).then_some(t),
                end: None,
                ended_by: String::new(),
                horizontal: None,
                vertical: None,
                swing: vec![None; self.planes],
                moving_cycles: 0,
                swing_cycles: 0,
                cycles: 0,
                verdict: String::new(),
            },
            duration,
            queued,
            stopped: false,
            faulted: false,
            rest_since: None,
            window: None,
        });
    }

    /// A stop accepted: the running move and a queued one end at rest.
    pub fn stop(&mut self, t: f64) {
        for track in self.tracks.iter_mut().filter(|k| k.v.end.is_none()) {
            track.stopped = true;
            if track.queued && track.v.start.is_none() {
                track.v.start = Some(t);
            }
            track.v.ended_by = format!("stopped at {t:.2} s; at rest (set points zero for 0.1 s)");
        }
    }

    /// The controller's fault as the status shows it (`None` for none).
    pub fn fault(&mut self, t: f64, fault: Option<&str>) {
        self.fault_now = fault.is_some();
        if let Some(fault) = fault {
            for track in self
                .tracks
                .iter_mut()
                .filter(|k| k.v.end.is_none() && !k.faulted)
            {
                track.faulted = true;
                if track.v.start.is_none() {
                    track.v.start = Some(t);
                }
                track.v.ended_by =
                    format!("fault {fault} at {t:.2} s; at rest (set points zero for 0.1 s)");
            }
        }
    }

    /// A SYNC at `t`: the drives' last positions (model order, m) and set points (m/s).
    pub fn cycle(&mut self, t: f64, positions: &[Option<f64>], setpoints: &[Option<f64>]) {
        let fresh = self.angle_t.is_some_and(|a| t - a <= STALE);
        if self.angle_t.is_some() && !fresh {
            self.stale_cycles += 1;
        }
        let angles: Vec<Option<f64>> = (0..self.planes)
            .map(|p| if fresh { self.angle[p] } else { None })
            .collect();
        let load = self.load_position(positions, &angles);
        if let Some(load) = &load {
            for (series, v) in self.position.iter_mut().zip(load.iter()) {
                series.push(t, *v);
            }
        }
        let at_rest = setpoints.iter().all(|s| s.is_none_or(|v| v == 0.0));
        let rope = positions.last().copied().flatten();
        let mut ended = Vec::new();
        for (k, track) in self.tracks.iter_mut().enumerate() {
            advance(track, t, at_rest, rope);
            if let Some((from, to)) = track.window {
                if t >= from && t <= to {
                    track.v.cycles += 1;
                    track.v.moving_cycles += u64::from(!at_rest);
                    track.v.swing_cycles += u64::from(angles.iter().any(Option::is_some));
                    if let Some(load) = &load {
                        let (h, v) = distance(&track.v.target, load);
                        track.v.horizontal = Some(track.v.horizontal.unwrap_or(0.0).max(h));
                        track.v.vertical = Some(track.v.vertical.unwrap_or(0.0).max(v));
                    }
                    for (plane, a) in angles.iter().enumerate() {
                        if let (Some(a), Some(slot)) = (a, track.v.swing.get_mut(plane)) {
                            *slot = Some(slot.unwrap_or(0.0).max(a.abs()));
                        }
                    }
                }
                if t > to {
                    ended.push(k);
                }
            }
        }
        // A queued move starts when the one before it ends.
        for k in 1..self.tracks.len() {
            if self.tracks[k].v.start.is_none() {
                if let Some(end) = self.tracks[k - 1].v.end {
                    self.tracks[k].v.start = Some(end.max(self.tracks[k].v.accepted));
                }
            }
        }
        for k in ended.into_iter().rev() {
            let mut track = self.tracks.remove(k);
            judge(&mut track, None);
            self.verdicts.push(track.v);
        }
    }

    /// The load's position (x_C, y_C, z_C; planar: x_C, 0, z_C) from the drives'
    /// positions and the swing (none measured: hanging still below the trolley).
    fn load_position(&self, positions: &[Option<f64>], angles: &[Option<f64>]) -> Option<[f64; 3]> {
        let (x, y, l) = match positions {
            [Some(x), Some(l)] => (*x, 0.0, *l),
            [Some(x), Some(y), Some(l)] => (*x, *y, *l),
            _ => return None,
        };
        let tan = |p: usize| {
            angles
                .get(p)
                .copied()
                .flatten()
                .unwrap_or(0.0)
                .to_radians()
                .tan()
        };
        let (ta, tb) = (tan(0), tan(1));
        let z = l / (1.0 + ta * ta + tb * tb).sqrt();
        Some([x + z * ta, y + z * tb, z])
    }

    /// The end of the log: the moves still open are judged on what the log has.
    pub fn finish(&mut self, end: f64) {
        for mut track in std::mem::take(&mut self.tracks) {
            judge(&mut track, Some(end));
            self.verdicts.push(track.v);
        }
    }
}

/// Moves a track's end and window on at `t`.
fn advance(track: &mut Track, t: f64, at_rest: bool, rope: Option<f64>) {
    if track.v.end.is_some() {
        return;
    }
    let Some(start) = track.v.start else {
        return;
    };
    track.rest_since = if at_rest {
        track.rest_since.or(Some(t))
    } else {
        None
    };
    let by_rest = track.stopped || track.faulted || track.duration.is_none();
    let end = if by_rest {
        track
            .rest_since
            .filter(|&r| t - r >= REST - 1e-9 && r > start)
    } else {
        track.duration.map(|d| start + d).filter(|&e| t >= e)
    };
    if let Some(end) = end {
        track.v.end = Some(end);
        if track.v.ended_by.is_empty() {
            track.v.ended_by = if by_rest {
                "at rest (set points zero for 0.1 s; the duration was not given)".into()
            } else {
                "its planned end (start + duration)".into()
            };
        }
        let period = rope.map_or(5.0, |l| 2.0 * std::f64::consts::PI * (l.abs() / G).sqrt());
        track.window = Some((end + AFTER, end + AFTER + period));
    }
}

/// Horizontal and vertical distance of `load` from `target` (x, z or x, y, z).
fn distance(target: &[f64], load: &[f64; 3]) -> (f64, f64) {
    match target {
        [x, z] => ((load[0] - x).abs(), (load[2] - z).abs()),
        [x, y, z] => ((load[0] - x).hypot(load[1] - y), (load[2] - z).abs()),
        _ => (f64::NAN, f64::NAN),
    }
}

/// The verdict of a track, `log_end` when the log ended before its window did.
fn judge(track: &mut Track, log_end: Option<f64>) {
    let started = track.v.start.is_some();
    let v = &mut track.v;
    let Some(end) = v.end else {
        v.verdict = if !started {
            "not judged: the move had not started when the log ends".into()
        } else {
            "not judged: the move had not ended when the log ends".into()
        };
        return;
    };
    if track.stopped || track.faulted {
        let swing = v.swing.iter().flatten().fold(0.0f64, |a, b| a.max(*b));
        v.verdict = format!(
            "{}: judged as a stop — {} from the target, {}",
            if track.faulted {
                "ended by a fault"
            } else {
                "stopped"
            },
            v.horizontal
                .map_or("position unknown".into(), |h| format!("{:.0} mm", h * 1e3)),
            if v.swing.iter().any(Option::is_some) {
                format!("swinging {swing:.3}°")
            } else {
                "swing not measured".into()
            }
        );
        return;
    }
    if let (Some(log_end), Some((from, _))) = (log_end, track.window) {
        if log_end < from || v.cycles == 0 {
            v.verdict = format!(
                "not judged: the log ends {:.1} s after the move's end, before the {AFTER} s",
                log_end - end
            );
            return;
        }
    }
    let mut failed = Vec::new();
    let mut unknown: Vec<String> = Vec::new();
    match v.horizontal {
        Some(h) if h > POSITION_TARGET => failed.push(format!("{:.0} mm from the target", h * 1e3)),
        Some(_) => {}
        None => unknown.push("the drives' positions".to_string()),
    }
    let swing = v
        .swing
        .iter()
        .flatten()
        .fold(None, |a: Option<f64>, b| Some(a.unwrap_or(0.0).max(*b)));
    // Without a reading the load is taken hanging still below the trolley: its distance
    // is then the trolley's, and the verdict says so.
    match swing {
        Some(s) if s >= SWING_TARGET_DEG => failed.push(format!("swinging {s:.3}°")),
        Some(_) if v.swing_cycles < v.cycles => unknown.push(format!(
            "the swing in {} of {} cycles (the inclinometer silent: the load taken hanging still)",
            v.cycles - v.swing_cycles,
            v.cycles
        )),
        Some(_) => {}
        None => unknown.push(
            "the swing (no inclinometer frames): the load taken hanging still below the trolley"
                .to_string(),
        ),
    }
    if v.moving_cycles > 0 {
        failed.push(format!(
            "set points not zero in {} of {} cycles",
            v.moving_cycles, v.cycles
        ));
    }
    let partial = log_end.is_some_and(|e| track.window.is_some_and(|(_, to)| e < to));
    let cut = if partial {
        " (the log ends within the window)"
    } else {
        ""
    };
    v.verdict = match (failed.is_empty(), unknown.is_empty()) {
        (true, true) => format!("pass{cut}"),
        (true, false) => format!(
            "pass where measured; not measured: {}{cut}",
            unknown.join(", ")
        ),
        (false, _) => format!("FAIL: {}{cut}", failed.join(", ")),
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::firmware::root;

    #[test]
    fn the_load_below_the_trolley_with_the_swing() {
        let crane = Crane::load(&root().join("scenes/paper-crane.toml")).unwrap();
        let load = Load::new(&crane);
        let p = load
            .load_position(&[Some(12.0), Some(8.0)], &[Some(3.0)])
            .unwrap();
        let phi = 3f64.to_radians();
        assert!((p[0] - (12.0 + 8.0 * phi.sin())).abs() < 1e-12);
        assert!((p[2] - 8.0 * phi.cos()).abs() < 1e-12);
        let still = load
            .load_position(&[Some(12.0), Some(8.0)], &[None])
            .unwrap();
        assert_eq!(still, [12.0, 0.0, 8.0]);
    }

    #[test]
    fn a_move_is_judged_five_seconds_after_its_end() {
        let crane = Crane::load(&root().join("scenes/paper-crane.toml")).unwrap();
        let mut load = Load::new(&crane);
        load.accepted(1.0, 7, vec![13.0, 7.5], Some(4.0), false);
        let mut t = 0.0;
        while t < 20.0 {
            let moving = (1.0..5.0).contains(&t);
            load.inclinometer(t, Some(if moving { 1.0 } else { 0.02 }), None);
            let x = if t < 5.0 {
                12.0 + (t - 1.0).max(0.0) / 4.0
            } else {
                13.01
            };
            load.cycle(
                t,
                &[Some(x), Some(7.5)],
                &[Some(if moving { 0.2 } else { 0.0 }), Some(0.0)],
            );
            t += 0.01;
        }
        load.finish(t);
        let v = &load.verdicts.items[0];
        assert_eq!(v.end, Some(5.0));
        assert_eq!(v.verdict, "pass", "{v:?}");
        assert!((v.horizontal.unwrap() - 0.01 - 7.5 * 0.02f64.to_radians().sin()).abs() < 1e-3);
    }

    /// The move of `a_move_is_judged_five_seconds_after_its_end`, the inclinometer read
    /// until `readings_until` s; its verdict.
    fn judged(readings_until: f64) -> Verdict {
        let crane = Crane::load(&root().join("scenes/paper-crane.toml")).unwrap();
        let mut load = Load::new(&crane);
        load.accepted(1.0, 7, vec![13.0, 7.5], Some(4.0), false);
        let mut t = 0.0;
        while t < 20.0 {
            let moving = (1.0..5.0).contains(&t);
            if t < readings_until {
                load.inclinometer(t, Some(0.02), None);
            }
            let x = 12.0 + (t - 1.0).clamp(0.0, 4.0) / 4.0;
            let v = if moving { 0.25 } else { 0.0 };
            load.cycle(t, &[Some(x), Some(7.5)], &[Some(v), Some(0.0)]);
            t += 0.01;
        }
        load.finish(t);
        load.verdicts.items[0].clone()
    }

    #[test]
    fn a_verdict_says_what_it_did_not_measure() {
        // The window is 10 s to 15.5 s (a swing period at 7.5 m).
        let whole = judged(30.0);
        assert_eq!(whole.verdict, "pass");
        let part = judged(12.0);
        // Read from 10 s to 12.1 s (a reading is fresh for 0.1 s) of the window.
        assert!((205..=215).contains(&part.swing_cycles), "{part:?}");
        assert_eq!(
            part.verdict,
            format!(
                "pass where measured; not measured: the swing in {} of {} cycles (the \
                 inclinometer silent: the load taken hanging still)",
                part.cycles - part.swing_cycles,
                part.cycles
            )
        );
        let none = judged(-1.0);
        assert!(
            none.verdict.contains("the swing (no inclinometer frames)")
                && none.verdict.contains("hanging still"),
            "{}",
            none.verdict
        );
    }
}
