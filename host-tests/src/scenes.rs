//! The reference scenes of the tests (the study reads the same from `scenes/*.toml`).

use nalgebra::SVector;
use solver_core::trajectory::PointToPoint;

/// The paper's crane move: the load from (12 m, 8 m deep) to (20 m, 4 m deep)
/// between t = 1 s and t = 9 s, simulated over 10 s (Sec. 3.1, Fig. 3).
pub const CRANE_START: [f64; 2] = [12.0, 8.0];
/// End of the paper's crane move.
pub const CRANE_END: [f64; 2] = [20.0, 4.0];
/// Start time of the move, s.
pub const CRANE_T_START: f64 = 1.0;
/// Duration of the move, s.
pub const CRANE_DURATION: f64 = 8.0;
/// Total simulated time, s.
pub const CRANE_T_END: f64 = 10.0;

/// The paper's crane trajectory with smoothness `n` (4 is the paper's C4 polynomial).
pub fn crane_trajectory(n: usize) -> PointToPoint<f64, 2> {
    PointToPoint::new(
        SVector::from(CRANE_START),
        SVector::from(CRANE_END),
        CRANE_T_START,
        CRANE_DURATION,
        n,
    )
    .expect("the paper's crane trajectory is valid")
}

/// The mass-on-car move of Fig. 11: z from 0 to 1 m between t = 3 s and t = 6 s
/// ("the end of the transition at time t = 6 s"), 20 s in all. Three seconds are
/// about four periods of the internal oscillation (ω ≈ 8.6 rad/s at α = 15°), so the
/// move leaves it ringing visibly, as in Fig. 11(b).
pub fn mass_on_car_trajectory(n: usize) -> PointToPoint<f64, 1> {
    PointToPoint::new(SVector::from([0.0]), SVector::from([1.0]), 3.0, 3.0, n)
        .expect("the mass-on-car trajectory is valid")
}

/// Total simulated time of the mass-on-car scene, s.
pub const MASS_ON_CAR_T_END: f64 = 20.0;
