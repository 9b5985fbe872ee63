//! Operator mode's generator: a master switch's speed demand turned into a smooth load
//! path that the inverse models follow (issue 28).
//!
//! The field shapes the *trolley's* speed reference with input shapers tuned to one
//! pendulum length, approximate while hoisting. Here the stick becomes a path of the
//! *load*, and the inverse model (exact for any history of the rope's length) gives the
//! drives' set points. The generator is a [`Trajectory`](crate::trajectory::Trajectory)
//! like a [`Plan`](crate::plan::Plan): `CraneSubs<f64, PlanarGenerator>` and
//! `Crane3dSubs<f64, Generator3d>` are driven by it, one [`Generator::advance`] per cycle
//! before the step, and it is evaluated anywhere inside the cycle (BDF's `t_{n+1}`,
//! Radau IIA's three stage times) with as many derivatives as asked.
//!
//! ## The chain, per horizontal axis
//!
//! ```text
//! stick → rate limiter p₀ (|v₀| ≤ V, |a₀| ≤ A, braking curve)      limiter.rs
//!       → two moving averages B(T₁) B(T₂), a zero-vibration pair      filter.rs
//!         ½(δ₀ + δ_{T_g/2}) [and the robust pair ½(δ₀ + δ_{T_r/2})]
//!         = the virtual trolley r
//!       → the virtual pendulum ẍ_L = ω_g² (r − x_L) = the load path    piece.rs
//! ```
//!
//! The pair at the virtual pendulum's half period cancels its swing exactly: the pair
//! followed by the pendulum is the *half-sine* kernel `½ ω_g sin(ω_g t)` on
//! `[0, T_g/2]`, non-negative with unit area. So the load path is the rate limiter's
//! path averaged over a finite window with non-negative weights,
//! `x_L = K ∗ p₀`, `K = halfsine ∗ B(T₁) ∗ B(T₂) [∗ pair_r]`, and comes to rest
//! exactly `T_K = T_g/2 + T₁ + T₂ [+ T_r/2]` after the rate limiter does.
//!
//! **Smoothness.** `p₀` is C¹ (its acceleration jumps per cycle); each window adds one
//! order, the half-sine two: the load path is C⁵ ([`SMOOTHNESS`]) — the crane models'
//! `MIN_SMOOTHNESS` (4: `u` contains `z⁗`, so the set points are continuous) plus one
//! (continuous drive accelerations). The hoist's path has four windows and no
//! pendulum: C⁵ too. Why the hoist needs C⁵ and not C³: when the load accelerates
//! horizontally, the trolley `x = x_C − ẍ_C z_C/(z̈_C − g)` has `ẍ ∋ z_C⁽⁴⁾`, so the
//! trolley's set point contains the hoist's fourth derivative, its rate the fifth.
//!
//! ## The drives after the inverse model: the bound relied on
//!
//! The flat inverse puts the trolley at `x = x_L + ẍ_L/ω²` with `ω² = (g − z̈_C)/z_C`
//! (the load's effective pendulum). With `ẍ_L = ω_g²(r − x_L)`:
//!
//! ```text
//! x = (1 − β) x_L + β r,     β = ω_g²/ω² = z_C g / (l_g (g − z̈_C)).
//! ```
//!
//! **The bound: `l_g` is never below the load's effective pendulum, `β ≤ 1`.** Then the
//! trolley is at every instant a convex combination of the load path and the virtual
//! trolley, both non-negative averages of `p₀`: it never leaves the range of `p₀`, so
//! the braking curve on `p₀` keeps load *and* drive inside the workspace. With the rope
//! length constant, `ẋ`, `ẍ`, `x⃛` are the same combinations: `|ẋ| ≤ V`, `|ẍ| ≤ A`,
//! `|x⃛| ≤ 2A/max(T₁, T₂)`, so the drive's set point `u = τẍ + ẋ` keeps
//! `|u| ≤ V + τA` and `|u̇| ≤ A(1 + 2τ/max(T₁, T₂))`. Hoisting during travel makes β
//! vary and adds `β̇ (r − x_L)` to the speed and `2β̇(ṙ − ẋ_L) + β̈(r − x_L)` to the
//! acceleration (`|r − x_L| ≤ A l_g/g`): small for smooth hoisting, and checked with the
//! exact flat inverse over each scene's rope range (`host-tests/tests/operator_generator.rs`).
//! The generator keeps `β ≤ 1` by construction: when a horizontal motion starts it
//! tunes `l_g = z_cap g/(g − A_z)` for the deepest load `z_cap` the hoist may reach
//! during it (where it would stop now, or its deepest since it last rested, plus
//! [`Settings::lowering_allowance`]), and holds the hoist above `z_cap` (a braking
//! curve) until the horizontal axes rest again.
//!
//! ## Stopping
//!
//! Releasing the stick (or [`Generator::stop`]) brings the rate limiter to rest at full
//! deceleration along its current direction; the load follows within the window. The
//! load's stopping distance from speed `v` is at most [`stopping_bound`]:
//! `v²/(2A) + v (τ̄ + h)`, `τ̄ = T_g/4 [+ T_r/4] + (T₁ + T₂)/2` the filters' mean lag
//! ([`Tuning::lag`]). After the stop the path is exactly at rest: the filters' history
//! is integers and their state is set to zero when the window has passed, so every
//! derivative is 0.0 and the position constant (no creep).
//!
//! ## Cost
//!
//! Per cycle a few taps into a ring of the last seconds' accelerations (one byte per
//! axis and cycle), a few running sums, and per axis the filter states at the cycle's
//! end from those at its start (a few multiply-adds through maps folded when the filter
//! is tuned, `ends.rs`). The evaluation at the cycle's end — BDF's one per step — reads
//! the end states; anywhere else the cycle's polynomial of degree 11 is built for the
//! call and evaluated by synthetic division (one multiply-add per coefficient,
//! derivative and axis). Nothing depends on how long the generator has run.

mod ends;
mod entry;
mod filter;
mod generator;
mod group;
mod limiter;
mod piece;
mod settings;

pub use entry::{Handover, Headroom, Room};
pub use generator::{stopping_bound, Cycle, Demand, Generator, Tuning, SMOOTHNESS};
pub use limiter::{brake, MAX_STEP};
pub use settings::{AxisSettings, Quanta, Settings, MAX_HOIST_ACCELERATION, MAX_OMEGA_H};

/// Ring lengths that hold every setting of [`Settings::lab`] and [`Settings::lab_3d`]
/// (ropes up to 9 m at 10 ms, robust included): the horizontal ring's cycles.
pub const LAB_RING: usize = 656;

/// The hoist ring's cycles for the same settings.
pub const LAB_HOIST_RING: usize = 84;

/// The planar crane's generator (trolley and hoist) with the lab's ring lengths.
pub type PlanarGenerator = Generator<1, LAB_RING, LAB_HOIST_RING>;

/// The 3D crane's generator (bridge, trolley and hoist) with the lab's ring lengths.
pub type Generator3d = Generator<2, LAB_RING, LAB_HOIST_RING>;

#[cfg(test)]
mod tests {
    use super::*;

    /// The issue's RAM target, ≤ 3 KiB of static RAM for the generator, holds for both
    /// lab types (measured: 2,024 and 3,056 bytes; `docs/OPERATOR.md`), so a change that
    /// grows the generator past it fails here rather than on the MCU.
    #[test]
    fn the_lab_generators_fit_in_three_kibibytes() {
        assert!(core::mem::size_of::<PlanarGenerator>() <= 3 * 1024);
        assert!(core::mem::size_of::<Generator3d>() <= 3 * 1024);
    }

    /// A generator reset in place after a motion (its rings full of an old history, its
    /// filter tuned for it) is the generator built at rest there: the same path, bit for
    /// bit, over a motion with a start, hoisting, a reversal and a release, and the same
    /// refusal — with `self` left as it was — of a position outside the ranges.
    #[test]
    fn a_generator_reset_in_place_is_the_one_built_at_rest() {
        #![allow(clippy::unwrap_used)]
        let settings = Settings::lab_3d(&crate::models::crane3d::Crane3dParams::EXAMPLE);
        let (lo, hi) = (settings.horizontal[0].range, settings.hoist.range);
        let start = (
            [
                lo.0 + 0.3 * (lo.1 - lo.0),
                settings.horizontal[1].range.0 + 0.5,
            ],
            hi.0 + 0.4 * (hi.1 - hi.0),
        );
        let stick = |n: usize| Demand {
            horizontal: match n {
                0..=149 => [1.0, 0.4],
                150..=249 => [-0.7, 0.0],
                _ => [0.0, 0.0],
            },
            hoist: if (20..120).contains(&n) { 0.8 } else { 0.0 },
        };
        let mut used = Generator3d::parked(settings);
        used.reset(settings, 0.0, start.0, start.1).unwrap();
        for n in 0..200 {
            let _ = used.advance(&stick(n));
        }
        assert!(!used.is_at_rest(), "reset while moving");
        let before = used;
        let outside = [lo.1 + 1.0, start.0[1]];
        let refused = used.reset(settings, 2.0, outside, start.1);
        assert!(refused.is_err());
        assert_eq!(used, before, "a refused reset changes nothing");
        assert_eq!(
            Generator3d::at_rest(settings, 2.0, outside, start.1).err(),
            refused.err()
        );
        used.reset(settings, 2.0, start.0, start.1).unwrap();
        let mut fresh = Generator3d::at_rest(settings, 2.0, start.0, start.1).unwrap();
        assert_eq!(used.tuning(), fresh.tuning());
        let mut moved = false;
        for n in 0..700 {
            let (a, b) = (used.advance(&stick(n)), fresh.advance(&stick(n)));
            assert_eq!(a, b, "cycle {n}");
            moved |= !a.at_rest;
            for theta in [0.0, 0.5, 1.0] {
                let t = used.time() + theta * settings.h;
                assert_eq!(used.evaluate::<6>(t), fresh.evaluate::<6>(t), "cycle {n}");
            }
        }
        assert!(
            moved && used.is_at_rest(),
            "the motion ran and came to rest"
        );
    }
}
