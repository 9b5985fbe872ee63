//! Per drive: the set point sent (RPDO1 target velocity 0x60FF) against the velocity
//! (TPDO1 0x606C) and position (TPDO2 0x6064) the drive reports, the following error,
//! the set points checked against the drive's limits, the CiA 402 state from the
//! statusword and the controlwords sent.
//!
//! A synchronous RPDO takes effect at the next SYNC, so the set point a TPDO answers is
//! the last one sent before the SYNC that TPDO follows: the following error is that set
//! point less the velocity actual.

use controller::cia402::DriveState;
use serde::Serialize;

use super::bus::{Cob, Crane, DriveInfo};
use super::series::{Capped, Series, Stats};
use super::Seen;

/// The CiA 402 state a statusword shows (Tab. 30 of CiA 402-2), decoded as the
/// controller decodes it.
pub fn cia402_state(statusword: u16) -> &'static str {
    match DriveState::from_statusword(statusword) {
        DriveState::NotReadyToSwitchOn => "not ready to switch on",
        DriveState::SwitchOnDisabled => "switch on disabled",
        DriveState::ReadyToSwitchOn => "ready to switch on",
        DriveState::SwitchedOn => "switched on",
        DriveState::OperationEnabled => "operation enabled",
        DriveState::QuickStopActive => "quick stop active",
        DriveState::FaultReactionActive => "fault reaction active",
        DriveState::Fault => "fault",
        DriveState::Unknown => "(no CiA 402 state)",
    }
}

/// One drive's record.
#[derive(Debug, Clone, Serialize)]
pub struct DriveRecord {
    /// Its axis.
    pub name: &'static str,
    /// Its node.
    pub node: u8,
    /// Velocity limit, m/s.
    pub velocity_limit: f64,
    /// Acceleration limit, m/s².
    pub acceleration_limit: f64,
    /// Set points sent.
    pub setpoints: u64,
    /// Largest |set point|, m/s (`None`: no set point in the log).
    pub max_setpoint: Option<f64>,
    /// Largest |step| between consecutive set points over the period, m/s² (`None`:
    /// fewer than two).
    pub max_acceleration: Option<f64>,
    /// Set points above the velocity limit.
    pub over_velocity: u64,
    /// Steps above the acceleration limit.
    pub over_acceleration: u64,
    /// Velocity actuals (TPDO1) received.
    pub velocity_actuals: u64,
    /// Largest |velocity actual|, m/s (`None`: no TPDO1 in the log).
    pub max_velocity: Option<f64>,
    /// |following error|: the applied set point less the velocity actual, m/s.
    pub following_error: Stats,
    /// Position actual at the first and the last TPDO2, m.
    pub positions: Option<(f64, f64)>,
    /// Range of position actual, m.
    pub position_range: Option<(f64, f64)>,
    /// CiA 402 states in order when they change: (s, state, statusword).
    pub states: Capped<(f64, String, u16)>,
    /// Controlwords sent when they change: (s, name).
    pub controlwords: Capped<(f64, String)>,
    /// Modes of operation display when it changes: (s, mode).
    pub modes: Capped<(f64, String)>,
    #[serde(skip)]
    pub(crate) setpoint: Series,
    #[serde(skip)]
    pub(crate) velocity: Series,
    #[serde(skip)]
    pub(crate) position: Series,
    #[serde(skip)]
    pub(crate) error: Series,
    #[serde(skip)]
    info: DriveInfo,
    #[serde(skip)]
    last_sent: Option<f64>,
    #[serde(skip)]
    applied: Option<f64>,
    #[serde(skip)]
    last_cw: Option<u16>,
    #[serde(skip)]
    last_state: Option<&'static str>,
    #[serde(skip)]
    last_mode: Option<i64>,
    #[serde(skip)]
    period: f64,
    /// The last position actual, m (for the load).
    #[serde(skip)]
    pub(crate) position_now: Option<f64>,
}

/// Every drive's record.
#[derive(Debug)]
pub struct Drives {
    /// In the model's input order.
    pub drives: Vec<DriveRecord>,
}

impl Drives {
    /// The drives of `crane`.
    pub fn new(crane: &Crane) -> Self {
        Self {
            drives: crane
                .drives
                .iter()
                .map(|d| DriveRecord {
                    name: d.name,
                    node: d.node,
                    velocity_limit: d.velocity_limit,
                    acceleration_limit: d.acceleration_limit,
                    setpoints: 0,
                    max_setpoint: None,
                    max_acceleration: None,
                    over_velocity: 0,
                    over_acceleration: 0,
                    velocity_actuals: 0,
                    max_velocity: None,
                    following_error: Stats::default(),
                    positions: None,
                    position_range: None,
                    states: Capped::new(200),
                    controlwords: Capped::new(200),
                    modes: Capped::new(50),
                    setpoint: Series::new(),
                    velocity: Series::new(),
                    position: Series::new(),
                    error: Series::new(),
                    info: d.clone(),
                    last_sent: None,
                    applied: None,
                    last_cw: None,
                    last_state: None,
                    last_mode: None,
                    period: crane.period,
                    position_now: None,
                })
                .collect(),
        }
    }

    /// One frame of drive `i` (or a SYNC for all).
    pub fn frame(&mut self, s: &Seen, i: Option<usize>) {
        if s.cob == Cob::Sync {
            for d in &mut self.drives {
                d.applied = d.last_sent.or(d.applied);
            }
            return;
        }
        let (Some(i), Some(d)) = (i, s.decoded) else {
            return;
        };
        let Some(drive) = self.drives.get_mut(i) else {
            return;
        };
        match s.cob {
            Cob::Rpdo(1, _) => {
                let (Some(v), Some(cw)) = (d.get("target_velocity"), d.get("controlword")) else {
                    return;
                };
                drive.setpoints += 1;
                drive.max_setpoint = Some(drive.max_setpoint.map_or(v.abs(), |m| m.max(v.abs())));
                if v.abs() > drive.velocity_limit * (1.0 + 1e-9) {
                    drive.over_velocity += 1;
                }
                if let Some(last) = drive.last_sent {
                    let a = (v - last).abs() / drive.period;
                    drive.max_acceleration = Some(drive.max_acceleration.map_or(a, |m| m.max(a)));
                    if a > drive.acceleration_limit * (1.0 + 1e-6) {
                        drive.over_acceleration += 1;
                    }
                }
                drive.last_sent = Some(v);
                drive.setpoint.push(s.t, v);
                let cw = cw as u16;
                if drive.last_cw != Some(cw) {
                    let name = s
                        .label("controlword")
                        .unwrap_or_else(|| format!("0x{cw:04X}"));
                    drive.controlwords.push((s.t, name));
                    drive.last_cw = Some(cw);
                }
            }
            Cob::Tpdo(1, _) => {
                let (Some(v), Some(sw)) = (d.get("velocity_actual"), d.get("statusword")) else {
                    return;
                };
                drive.velocity_actuals += 1;
                drive.max_velocity = Some(drive.max_velocity.map_or(v.abs(), |m| m.max(v.abs())));
                drive.velocity.push(s.t, v);
                if let Some(applied) = drive.applied {
                    drive.following_error.add((applied - v).abs());
                    drive.error.push(s.t, applied - v);
                }
                let sw = sw as u16;
                let state = cia402_state(sw);
                if drive.last_state != Some(state) {
                    drive.states.push((s.t, state.to_string(), sw));
                    drive.last_state = Some(state);
                }
            }
            Cob::Tpdo(2, _) => {
                let (Some(p), Some(mode)) = (d.get("position_actual"), d.get("mode_display"))
                else {
                    return;
                };
                // The DBC reads 1 µm per increment; the commissioning file's scaling rules.
                let metres = (p * 1e6).round() * drive.info.scale + drive.info.offset;
                drive.position.push(s.t, metres);
                drive.position_now = Some(metres);
                drive.positions = Some(match drive.positions {
                    Some((first, _)) => (first, metres),
                    None => (metres, metres),
                });
                drive.position_range = Some(match drive.position_range {
                    Some((lo, hi)) => (lo.min(metres), hi.max(metres)),
                    None => (metres, metres),
                });
                let mode = mode as i64;
                if drive.last_mode != Some(mode) {
                    let name = s.label("mode_display").unwrap_or_else(|| mode.to_string());
                    drive.modes.push((s.t, name));
                    drive.last_mode = Some(mode);
                }
            }
            _ => {}
        }
    }

    /// The last set point sent to each drive, m/s (`None` before the first).
    pub fn last_setpoints(&self) -> impl Iterator<Item = Option<f64>> + '_ {
        self.drives.iter().map(|d| d.last_sent)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statusword_states() {
        assert_eq!(cia402_state(0x0237), "operation enabled");
        assert_eq!(cia402_state(0x0217), "quick stop active");
        assert_eq!(cia402_state(0x0008), "fault");
        assert_eq!(cia402_state(0x0250), "switch on disabled");
        assert_eq!(cia402_state(0x0231), "ready to switch on");
    }
}
