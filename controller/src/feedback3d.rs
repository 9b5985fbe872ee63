//! The state feedback of the crane in three dimensions (Fig. 1 with bridge, trolley and
//! hoist): the planar feedback ([`StateFeedback`]) once per vertical plane, coupled
//! through the rope only.
//!
//! **Why per plane.** Linearised about the hanging rest, the spherical pendulum on a
//! bridge and a trolley splits into two planar pendulums of the same length `l`: the
//! swing in the x–z plane is driven by the bridge's acceleration alone, the swing in the
//! y–z plane by the trolley's, and the two couple only at second order in the angles
//! (the rope's direction `e = (tan α, tan β, 1)/D` gives cross terms `α β`, `α̇ β̇`:
//! relative to the first-order terms they are of the size of the other angle in
//! radians, 0.035 for a 2° swing). Each plane is then Eqs. 21–22 with its own drive lag
//! (bridge τ1 or trolley τ2) and the hoist's τ3, and the planar design — LQR at hanging
//! rest, scheduled on `l`, a Kalman observer, its degraded modes, anti-windup, the rest
//! hold — applies unchanged. The rope is one: the hoist's set point is the x–z plane's
//! (its feedback holds the rope on its reference exactly as the y–z plane's would), and
//! the y–z plane's rope-error observer learns that correction, the one sent, not its
//! own — so its estimate of the rope's error, which its rest test reads, follows the
//! rope as it is. The y–z plane's own hoist correction is computed and discarded (two
//! multiplications a cycle).
//!
//! **Degraded modes.** Each plane judges its own angle (the inclinometer's slope long16
//! for x–z, slope lateral16 for y–z): a lost, implausible or frozen lateral slope puts
//! the y–z plane on the swing estimated from the trolley's motion and leaves the x–z
//! plane closed, and the reverse. The mode announced is the worse plane's.

use crate::commissioning::Swing;
use crate::correction::{AxesCorrection, Measured};
use crate::feedback::{
    Config, Correction, DesignError, Gains, Measurement, Mode, Output, Reference, StateFeedback,
};
use crate::rope::RopeLength;
use crate::setpoint::{AxisLimits, DriveLimits};

/// The 3D crane's state feedback: the x–z plane's (bridge and hoist) and the y–z plane's
/// (trolley and hoist).
#[derive(Debug, Clone)]
pub struct SpatialFeedback {
    /// The x–z plane: bridge x, rope l, the slope long16.
    xz: StateFeedback,
    /// The y–z plane: trolley y, rope l, the slope lateral16.
    yz: StateFeedback,
}

impl SpatialFeedback {
    /// The feedback for `config` as the x–z plane's (its `tau1` the bridge's lag, `tau2`
    /// the hoist's), the y–z plane's the same with the trolley's lag `tau_trolley`.
    pub fn new(config: Config, tau_trolley: f64) -> Result<Self, DesignError> {
        let yz = Config {
            tau1: tau_trolley,
            ..config
        };
        Ok(Self {
            xz: StateFeedback::new(config)?,
            yz: StateFeedback::new(yz)?,
        })
    }

    /// [`SpatialFeedback::new`] with the gains already designed, x–z then y–z (a study
    /// runs many cases on one design).
    #[must_use]
    pub fn with_gains(config: Config, tau_trolley: f64, gains: [Gains; 2]) -> Self {
        let [xz, yz] = gains;
        Self {
            xz: StateFeedback::with_gains(config, xz),
            yz: StateFeedback::with_gains(
                Config {
                    tau1: tau_trolley,
                    ..config
                },
                yz,
            ),
        }
    }

    /// The gains of the two planes' designs for `config` and the trolley's lag.
    pub fn design(config: &Config, tau_trolley: f64) -> Result<[Gains; 2], DesignError> {
        Ok([
            Gains::design(config)?,
            Gains::design(&Config {
                tau1: tau_trolley,
                ..*config
            })?,
        ])
    }

    /// The planes' feedbacks, x–z then y–z.
    #[must_use]
    pub fn planes(&self) -> [&StateFeedback; 2] {
        [&self.xz, &self.yz]
    }

    /// One cycle, both planes: the set points `[bridge, trolley, hoist]` and each
    /// plane's output (x–z, y–z).
    pub fn cycle(
        &mut self,
        reference: &[Reference; 2],
        u_d: [f64; 3],
        measured: Option<Measured<3>>,
        last: [f64; 3],
        limits: &[AxisLimits; 3],
    ) -> ([f64; 3], [Output; 2]) {
        let [r_xz, r_yz] = reference;
        let [ud_x, ud_y, ud_l] = u_d;
        let [last_x, last_y, last_l] = last;
        let [lim_x, lim_y, lim_l] = *limits;
        let plane = |position: usize, angle: fn(Swing) -> Option<f64>| {
            move |m: Measured<3>| {
                let [x, y, l] = m.position;
                Measurement {
                    x: if position == 0 { x } else { y },
                    l,
                    phi: m.swing.and_then(angle),
                }
            }
        };
        let xz = self.xz.cycle(
            r_xz,
            [ud_x, ud_l],
            measured.map(plane(0, |s| Some(s.long))),
            [last_x, last_l],
            &DriveLimits {
                trolley: lim_x,
                winch: lim_l,
            },
        );
        let yz = self.yz.cycle(
            r_yz,
            [ud_y, ud_l],
            measured.map(plane(1, |s| s.lateral)),
            [last_y, last_l],
            &DriveLimits {
                trolley: lim_y,
                winch: lim_l,
            },
        );
        let [u_x, u_l] = xz.u;
        let [u_y, _] = yz.u;
        self.yz.sent([yz.correction[0], xz.correction[1]]);
        ([u_x, u_y, u_l], [xz, yz])
    }
}

/// The worse of two planes' modes: feedforward only before the swing estimated from
/// the drives, before closed loop (the first plane's reason on a tie).
#[must_use]
pub fn worse(a: Mode, b: Mode) -> Mode {
    let rank = |m: Mode| match m {
        Mode::Closed => 0,
        Mode::SwingEstimated(_) => 1,
        Mode::FeedforwardOnly(_) => 2,
    };
    if rank(b) > rank(a) {
        b
    } else {
        a
    }
}

impl AxesCorrection<3, [Reference; 2]> for SpatialFeedback {
    const ENABLED: bool = true;
    fn correct(
        &mut self,
        reference: &[Reference; 2],
        u_d: [f64; 3],
        measured: Option<Measured<3>>,
        last: [f64; 3],
        limits: &[AxisLimits; 3],
    ) -> ([f64; 3], Mode) {
        let (u, [xz, yz]) = self.cycle(reference, u_d, measured, last, limits);
        (u, worse(xz.mode, yz.mode))
    }
    /// Each plane learns its horizontal drive's correction and the hoist's.
    fn sent(&mut self, [ud_x, ud_y, ud_l]: [f64; 3], [u_x, u_y, u_l]: [f64; 3]) {
        self.xz.sent([u_x - ud_x, u_l - ud_l]);
        self.yz.sent([u_y - ud_y, u_l - ud_l]);
    }
    fn restart(&mut self) {
        Correction::restart(&mut self.xz);
        Correction::restart(&mut self.yz);
    }
    fn let_go_at_rest(&mut self) {
        self.xz.let_go_at_rest();
        self.yz.let_go_at_rest();
    }
    fn mode(&self) -> Option<Mode> {
        Some(worse(self.xz.mode(), self.yz.mode()))
    }
    /// The x–z plane's: its swing is the one the hoist's set points follow.
    fn rope(&self) -> Option<&RopeLength> {
        Some(self.xz.rope())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use crate::feedback::{Degraded, Reference};
    use crate::setpoint::DriveLimits;

    fn at_rest(x: f64, l: f64) -> Reference {
        Reference {
            x,
            l,
            ..Reference::default()
        }
    }

    fn config() -> Config {
        Config {
            tau1: 0.05,
            tau2: 0.02,
            ..Config::PAPER
        }
    }

    /// A swing in one plane is corrected by that plane's drive only; the hoist's set
    /// point is the x–z plane's; with no swing and the load on its reference nothing is
    /// added.
    #[test]
    fn each_plane_drives_its_own_axis() {
        let reference = [at_rest(12.0, 6.0), at_rest(3.0, 6.0)];
        let limits = DriveLimits::LAB_3D;
        let mut fb = SpatialFeedback::new(config(), 0.03).unwrap();
        let still = Measured {
            position: [12.0, 3.0, 6.0],
            swing: Some(Swing {
                long: 0.0,
                lateral: Some(0.0),
            }),
        };
        let mut last = [0.0; 3];
        for _ in 0..20 {
            let (u, mode) = fb.correct(&reference, [0.0; 3], Some(still), last, &limits);
            assert_eq!(mode, Mode::Closed);
            assert!(u.iter().all(|v| v.abs() < 1e-12), "{u:?}");
            last = u;
        }
        // A swing across the bridge (y–z) only, a pendulum's at l = 6 m: the trolley
        // moves, the bridge does not.
        let mut fb = SpatialFeedback::new(config(), 0.03).unwrap();
        let omega = (9.81_f64 / 6.0).sqrt();
        let mut last = [0.0; 3];
        let mut moved = [0.0_f64; 3];
        for k in 0..300 {
            let lateral = Measured {
                swing: Some(Swing {
                    long: 0.0,
                    lateral: Some(0.03 * (omega * f64::from(k) * 0.01).cos()),
                }),
                ..still
            };
            let (u, outputs) = fb.cycle(&reference, [0.0; 3], Some(lateral), last, &limits);
            assert_eq!(u[2], outputs[0].u[1], "the hoist is the x–z plane's");
            for (m, v) in moved.iter_mut().zip(u) {
                *m = m.max(v.abs());
            }
            last = u;
        }
        assert!(moved[1] > 1e-3, "trolley {moved:?}");
        assert!(moved[0] < 1e-9, "bridge {moved:?}");
    }

    /// The rope is one: the y–z plane's rope-error estimate is the x–z plane's, also
    /// while only the y–z plane rests (its own hoist correction zero, the one sent not).
    #[test]
    fn both_planes_estimate_the_rope_the_hoist_was_sent() {
        let reference = [at_rest(12.0, 6.0), at_rest(3.0, 6.0)];
        let limits = DriveLimits::LAB_3D;
        let mut fb = SpatialFeedback::new(config(), 0.03).unwrap();
        let omega = (9.81_f64 / 6.0).sqrt();
        let mut last = [0.0; 3];
        let mut only_yz_rested = 0;
        for k in 0..400 {
            // A swing along the runway, none across, the rope 8 mm long.
            let m = Measured {
                position: [12.0, 3.0, 6.008],
                swing: Some(Swing {
                    long: 0.03 * (omega * f64::from(k) * 0.01).cos(),
                    lateral: Some(0.0),
                }),
            };
            let (u, [xz, yz]) = fb.cycle(&reference, [0.0; 3], Some(m), last, &limits);
            if yz.resting && !xz.resting {
                only_yz_rested += 1;
            }
            if !matches!(xz.mode, Mode::FeedforwardOnly(_)) {
                assert_eq!(xz.error[4..], yz.error[4..], "cycle {k}");
            }
            last = u;
        }
        assert!(only_yz_rested > 100, "{only_yz_rested} cycles");
    }

    /// A lost lateral slope degrades the y–z plane only; the announced mode is the
    /// worse plane's, and both come back on restart.
    #[test]
    fn a_lost_lateral_slope_degrades_its_plane_only() {
        let reference = [at_rest(12.0, 6.0), at_rest(3.0, 6.0)];
        let limits = DriveLimits::LAB_3D;
        let mut fb = SpatialFeedback::new(config(), 0.03).unwrap();
        let both = Measured {
            position: [12.0, 3.0, 6.0],
            swing: Some(Swing {
                long: 0.0,
                lateral: Some(0.0),
            }),
        };
        let long_only = Measured {
            swing: Some(Swing {
                long: 0.0,
                lateral: None,
            }),
            ..both
        };
        let mut last = [0.0; 3];
        let mut mode = Mode::Closed;
        for k in 0..60 {
            // Both slopes read for a while (the angles trusted), then the lateral lost.
            let m = if k < 50 { both } else { long_only };
            let (u, m) = fb.correct(&reference, [0.0; 3], Some(m), last, &limits);
            mode = m;
            last = u;
        }
        assert_eq!(mode, Mode::SwingEstimated(Degraded::AngleLost));
        let [xz, yz] = fb.planes();
        assert_eq!(xz.mode(), Mode::Closed);
        assert_eq!(yz.mode(), Mode::SwingEstimated(Degraded::AngleLost));
        AxesCorrection::restart(&mut fb);
        assert_eq!(AxesCorrection::mode(&fb), Some(Mode::Closed));
    }

    #[test]
    fn the_worse_mode_wins() {
        let lost = Mode::SwingEstimated(Degraded::AngleLost);
        let off = Mode::FeedforwardOnly(Degraded::PositionsInvalid);
        assert_eq!(worse(Mode::Closed, lost), lost);
        assert_eq!(worse(lost, Mode::Closed), lost);
        assert_eq!(worse(lost, off), off);
        assert_eq!(worse(off, lost), off);
        assert_eq!(
            worse(lost, Mode::SwingEstimated(Degraded::AngleFrozen)),
            lost
        );
    }
}
