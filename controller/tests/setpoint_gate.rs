//! The choke point every set point passes: finite, within speed, within acceleration.

use controller::drive::Drive;
use controller::setpoint::{
    AxisLimits, DriveLimits, Setpoint, SetpointError, SetpointGate, UNITS_PER_M_PER_S,
};
use proptest::prelude::*;

const LIMITS: DriveLimits = DriveLimits::LAB;

#[test]
fn non_finite_and_over_speed_are_refused_and_change_nothing() {
    let mut gate = SetpointGate::new(LIMITS, 0.01);
    gate.admit(Drive::Trolley, 0.02).unwrap();
    for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert_eq!(
            gate.admit(Drive::Trolley, v),
            Err(SetpointError::NonFinite {
                drive: Drive::Trolley
            })
        );
    }
    assert!(
        matches!(gate.admit(Drive::Winch, 2.5), Err(SetpointError::OverSpeed { limit, .. }) if limit == 2.0)
    );
    assert_eq!(gate.last(Drive::Trolley).units(), 20_000);
    assert_eq!(gate.last(Drive::Winch), Setpoint::ZERO);
}

#[test]
fn a_jump_beyond_the_acceleration_limit_is_refused() {
    let mut gate = SetpointGate::new(LIMITS, 0.01);
    // 3 m/s² · 10 ms = 0.03 m/s per cycle.
    assert!(gate.admit(Drive::Trolley, 0.03).is_ok());
    assert!(matches!(
        gate.admit(Drive::Trolley, 0.0700001),
        Err(SetpointError::OverAcceleration { .. })
    ));
}

proptest! {
    /// Whatever is asked, what comes out is finite, within the limits, and never jumps.
    #[test]
    fn admitted_setpoints_are_always_within_limits(asks in prop::collection::vec(prop_oneof![-4.0..4.0f64, Just(f64::NAN), Just(f64::INFINITY)], 1..200)) {
        let mut gate = SetpointGate::new(LIMITS, 0.01);
        let mut last = 0i32;
        for v in asks {
            let out = match gate.admit(Drive::Trolley, v) { Ok(s) => s, Err(_) => gate.ramp_to_zero(Drive::Trolley) };
            let mps = out.metres_per_second();
            prop_assert!(mps.abs() <= 3.0);
            prop_assert!((f64::from(out.units() - last) / UNITS_PER_M_PER_S).abs() <= 0.03 + 1e-6);
            last = out.units();
        }
    }

    /// The ramp reaches standstill within ceil(v/(a·h)) cycles and never overshoots.
    #[test]
    fn ramp_reaches_zero_monotonically(v in -3.0..3.0f64) {
        let limits = DriveLimits { trolley: AxisLimits { max_velocity: 3.0, max_acceleration: 1e6 }, ..LIMITS };
        let mut gate = SetpointGate::new(limits, 0.01);
        gate.admit(Drive::Trolley, v).unwrap();
        let mut gate = { let mut g = SetpointGate::new(LIMITS, 0.01); let mut cur = 0.0; while (cur - v).abs() > 0.03 { cur += 0.03f64.copysign(v - cur); g.admit(Drive::Trolley, cur).unwrap(); } g.admit(Drive::Trolley, v).unwrap(); g };
        let mut previous = gate.last(Drive::Trolley).units().abs();
        let mut n = 0;
        while gate.last(Drive::Trolley) != Setpoint::ZERO {
            let s = gate.ramp_to_zero(Drive::Trolley).units().abs();
            prop_assert!(s < previous);
            previous = s;
            n += 1;
        }
        prop_assert!(n <= (v.abs() / 0.03).ceil() as usize + 1);
        prop_assert!(gate.at_standstill() || gate.last(Drive::Winch) != Setpoint::ZERO);
    }
}
