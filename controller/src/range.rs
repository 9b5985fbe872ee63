//! Each drive kept inside its range, whatever asks it to move: a software limit with a
//! braking curve on the drive's *measured* position, as a stock drive's software
//! position limits (CiA 402 0x607D) guard its own travel.
//!
//! The planner keeps every move's target inside the ranges and the operator generator
//! brakes the *model's* drives at the ranges' ends. The drive itself may still run past
//! an end: a drive whose lag, droop or scaling differs from the model's goes further than
//! the model's, and the state feedback's corrections, which damp a swing the model does
//! not have, move the drive beyond where the model's rests. In `drive-view`'s random
//! lever test (the plant not the model, the feedback on, levers held into the ends)
//! the drives ran up to 32 mm past an end before this guard, 1.8 mm with it
//! (`cargo test -p drive-view --test random_levers -- --nocapture`). So the last word
//! on each set point, before the gate, is the room the drive has left.
//!
//! The room is a braking curve on the distance `d` left to the end:
//!
//! ```text
//! v_max(d) = a (√(T² + 2d/a) − T),   T = 4 (τ + h),   0 at and beyond the end,
//! ```
//!
//! `a` the drive's acceleration limit, `τ` its lag (Eq. 22), `h` the cycle (the position
//! is a cycle old). Far from the end it is the braking parabola `√(2ad)` less the lag;
//! near it the law is linear, `v ≈ d/T`: a drive with lag `τ` whose set point is
//! `d/T` approaches the end as `τ ẍ + ẋ + x/T = 0`, critically damped or slower when
//! `T ≥ 4τ` — it creeps up to the end and never passes it (a steeper law overshoots
//! by the lag: `a τ²` for the bare parabola). The cycle's delay counts as lag.
//!
//! What is limited is what is *added* to the model's set point `u_d`: the model's own
//! drive stays inside the ranges by construction (the planner's targets, the generator's
//! braking curve), and a move to a range's end must arrive there exactly, so `u_d`
//! passes while the drive is inside its range; a correction towards an end only as far
//! as the room allows. At an end or beyond it nothing moves the drive further out, the
//! model's set point neither: a drive that runs ahead of the model is held at the end.
//! A set point within the bounds is left exactly as it is (nothing changes for moves
//! that keep clear of the ends); one beyond them is brought there no faster than the
//! gate's acceleration limit allows, so the gate never has to refuse it; away from an
//! end the drive may always move.
//!
//! Once the guard has held a drive back, its set point returns to the asked one no faster
//! than the gate allows ([`toward`], the controller's `within_ranges`), also when the
//! drive comes back inside by a hair or its position is late.
//!
//! Not yet: the feedback is not told. Its observer learns the correction it asked for,
//! not the one sent, for as long as the guard bites, and its drive-offset state may take
//! up the difference (an independent review's finding; stop 43's note).

use crate::setpoint::AxisLimits;

/// The law's time constant `T = 4(τ + h)`, s ([module docs](self)).
fn time_constant(lag: f64, h: f64) -> f64 {
    4.0 * (lag + h)
}

/// The largest speed towards an end `d` m away: `v_max(d)`, 0 at the end and beyond.
fn v_max(d: f64, a: f64, t: f64) -> f64 {
    if d > 0.0 && a > 0.0 {
        a * (libm::sqrt(t * t + 2.0 * d / a) - t)
    } else {
        0.0
    }
}

/// The velocities, m/s, `(lowest, highest)`, that leave a drive at `position` room to
/// stop inside `(lo, hi)` ([module docs](self)): `lag` the drive's τ, `h` the cycle.
#[must_use]
pub fn room(position: f64, (lo, hi): (f64, f64), a: f64, lag: f64, h: f64) -> (f64, f64) {
    let t = time_constant(lag, h);
    (-v_max(position - lo, a, t), v_max(hi - position, a, t))
}

/// The set point `u` (m/s) of a drive at `position`, the model's being `u_d`, kept
/// within its [`room`] or `u_d`: `u` itself when inside (or not finite: the gate refuses
/// that as before); otherwise the bound, reached from the last set point `last` no
/// faster than `limits`' acceleration over the cycle `h` allows.
///
/// Every cycle of every drive passes here, so the common case is cheap (the MCU has no
/// double-precision square root in hardware): a set point away from the end, or the
/// model's own inside the range, passes at once; one towards an end passes when its own
/// stopping distance `u²/(2a) + uT` fits in the room, the same test as `u ≤ v_max(d)`
/// without the root; only a set point that does not is bounded.
#[must_use]
#[allow(clippy::too_many_arguments)]
pub fn guard(
    u: f64,
    u_d: f64,
    last: f64,
    position: f64,
    (lo, hi): (f64, f64),
    limits: AxisLimits,
    lag: f64,
    h: f64,
) -> f64 {
    let a = limits.max_acceleration;
    let t = time_constant(lag, h);
    // Towards the end ahead (`sign` +1: hi, −1: lo), `room` m away.
    let (sign, room) = if u > 0.0 {
        (1.0, hi - position)
    } else {
        (-1.0, position - lo)
    };
    let speed = u * sign;
    if !u.is_finite() || u == 0.0 {
        return u;
    }
    let bound = if room <= 0.0 {
        // At an end or beyond it nothing moves the drive further out.
        0.0
    } else if speed <= u_d * sign || (a > 0.0 && speed * speed / (2.0 * a) + speed * t <= room) {
        // The model's own set point inside the range, or room enough.
        return u;
    } else {
        // The model's own set point passes while the drive is inside the range.
        sign * v_max(room, a, t).max(u_d * sign)
    };
    toward(bound, last, a, h)
}

/// `u` reached from the last set point `last` no faster than the acceleration `a` over
/// the cycle `h` allows (two drive units under the gate's step, for its rounding, as the
/// feedback's clamp): what the gate admits. A non-finite `u` as it is (the gate refuses
/// it). After the guard held a drive back, its set point returns to the asked one this
/// way, never in a jump the gate would refuse.
#[must_use]
pub fn toward(u: f64, last: f64, a: f64, h: f64) -> f64 {
    if !u.is_finite() {
        return u;
    }
    let step = (a * h - 2e-6).max(0.0);
    // Not `f64::clamp`, which panics when its bounds cross.
    u.max(last - step).min(last + step)
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: AxisLimits = AxisLimits {
        max_velocity: 3.0,
        max_acceleration: 3.0,
    };
    const H: f64 = 0.01;
    const LAG: f64 = 0.05;

    /// The room's highest velocity is the braking parabola far from the end and the
    /// linear law `d/T` near it, `T = 4(τ + h)`; zero at the end and beyond, where the
    /// drive may still move back.
    #[test]
    fn the_room_is_a_braking_parabola_ending_in_a_linear_law() {
        let t = 4.0 * (LAG + H);
        for d in [1e-4, 1e-3, 0.01, 0.1, 1.0, 10.0] {
            let (_, v) = room(20.0 - d, (0.0, 20.0), 3.0, LAG, H);
            // v²/(2a) + v T = d, the parabola less the linear law's lag.
            let stop = v * v / (2.0 * 3.0) + v * t;
            assert!((stop - d).abs() < 1e-9 * d.max(1.0), "d = {d}: {stop}");
            let (w, _) = room(d, (0.0, 20.0), 3.0, LAG, H);
            assert!((w + v).abs() < 1e-12, "symmetric at the low end");
        }
        let (_, near) = room(20.0 - 1e-6, (0.0, 20.0), 3.0, LAG, H);
        assert!(
            (near - 1e-6 / t).abs() < 1e-9,
            "linear near the end: {near}"
        );
        assert_eq!(room(20.0, (0.0, 20.0), 3.0, LAG, H).1, 0.0, "at the end");
        assert_eq!(room(20.5, (0.0, 20.0), 3.0, LAG, H).1, 0.0, "beyond it");
        assert!(
            room(20.5, (0.0, 20.0), 3.0, LAG, H).0 < 0.0,
            "may drive back"
        );
    }

    /// Inside the room a set point is sent exactly as it came; a non-finite one too
    /// (the gate refuses it, as without the guard); and the model's own set point
    /// always, to arrive exactly where a move to an end ends.
    #[test]
    fn a_set_point_inside_the_room_is_left_alone() {
        assert_eq!(guard(0.4, 0.4, 0.4, 10.0, (0.0, 20.0), LIMITS, LAG, H), 0.4);
        assert_eq!(
            guard(-0.4, -0.4, -0.4, 10.0, (0.0, 20.0), LIMITS, LAG, H),
            -0.4
        );
        assert!(guard(f64::NAN, 0.0, 0.0, 19.99, (0.0, 20.0), LIMITS, LAG, H).is_nan());
        // At the end, away from it: allowed.
        assert_eq!(
            guard(-0.2, 0.0, 0.0, 20.0, (0.0, 20.0), LIMITS, LAG, H),
            -0.2
        );
        // The model's own set point 0.1 mm before the end, where the room is less.
        let (_, room_left) = room(19.9999, (0.0, 20.0), 3.0, LAG, H);
        assert!(room_left < 0.01);
        assert_eq!(
            guard(0.01, 0.01, 0.01, 19.9999, (0.0, 20.0), LIMITS, LAG, H),
            0.01
        );
        // A correction on top of it towards the end: only the model's.
        assert_eq!(
            guard(0.02, 0.01, 0.01, 19.9999, (0.0, 20.0), LIMITS, LAG, H),
            0.01
        );
    }

    /// The release ramp: from 0.0 the asked 0.3 m/s is reached at the gate's step, and a
    /// non-finite value passes for the gate to refuse.
    #[test]
    fn after_a_hold_the_set_point_returns_at_the_gate_s_step() {
        let step = LIMITS.max_acceleration * H - 2e-6;
        assert!((toward(0.3, 0.0, 3.0, H) - step).abs() < 1e-15);
        assert_eq!(toward(0.01, 0.0, 3.0, H), 0.01);
        assert!(toward(f64::NAN, 0.0, 3.0, H).is_nan());
        // Inside the range by a hair, the model's set point passes the guard whole: the
        // controller ramps it (`within_ranges`).
        assert_eq!(
            guard(0.3, 0.3, 0.0, 19.999_999, (0.0, 20.0), LIMITS, LAG, H),
            0.3
        );
    }

    /// At an end or beyond it nothing moves the drive further out, the model's set
    /// point neither (a drive that runs ahead of the model is held at the end); at the
    /// gate's step from the last set point.
    #[test]
    fn at_an_end_nothing_moves_the_drive_further_out() {
        assert_eq!(
            guard(0.01, 0.01, 0.01, 20.0, (0.0, 20.0), LIMITS, LAG, H),
            0.0
        );
        assert_eq!(
            guard(-0.01, -0.01, -0.01, 0.0, (0.0, 20.0), LIMITS, LAG, H),
            0.0
        );
        let step = LIMITS.max_acceleration * H - 2e-6;
        let u = guard(0.5, 0.5, 0.5, 20.001, (0.0, 20.0), LIMITS, LAG, H);
        assert!((u - (0.5 - step)).abs() < 1e-12, "ramped down: {u}");
    }

    /// Towards an end with too little room: the set point falls to the room's bound, at
    /// most the gate's step per cycle; a drive stepped with the guard on a lagged drive
    /// stops inside the range.
    #[test]
    fn a_drive_pushed_at_an_end_stops_inside_its_range() {
        let (mut x, mut v, mut u) = (19.0, 1.0, 1.0);
        let mut peak = x;
        for _ in 0..500 {
            // A correction that asks for 1 m/s on, the model resting.
            let next = guard(1.0, 0.0, u, x, (0.0, 20.0), LIMITS, LAG, H);
            assert!(
                (next - u).abs() <= LIMITS.max_acceleration * H,
                "the gate's step"
            );
            u = next;
            // The drive's lag over the cycle (fine Euler steps).
            for _ in 0..100 {
                v += (u - v) / LAG * H / 100.0;
                x += v * H / 100.0;
            }
            peak = peak.max(x);
        }
        assert!(peak <= 20.0, "passed the end: {peak}");
        assert!(peak > 19.98, "stopped short: {peak}");
    }
}
