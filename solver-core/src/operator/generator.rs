//! The generator: the stick's demand in, once per cycle; the load path out, as a
//! [`Trajectory`] the inverse models are driven by.

use nalgebra::SVector;

use crate::error::{Error, Result};
use crate::operator::ends::SwingMap;
use crate::operator::entry::{
    check_inside, plan_stop, AxisStop, Blend, Ends, Handover, Headroom, Stop,
};
use crate::operator::filter::{i64_to_f64, u64_to_f64, Factor, Taps};
use crate::operator::group::Group;
use crate::operator::limiter::{brake, ceil_i, floor_i, truncate, Axis};
use crate::operator::settings::{cycles, zv_cycles, Quanta, Rounding, Settings};
use crate::scalar::{c, to_f64, Real};
use crate::trajectory::Trajectory;

/// The load path's smoothness: derivatives 1..=5 are continuous — the crane models'
/// `MIN_SMOOTHNESS` (4: continuous set points) and one more (continuous drive
/// accelerations), what the controller plans its moves with.
pub const SMOOTHNESS: usize = 5;

/// One cycle's stick: per axis a demand in `[−1, 1]` of full stick (outside it: clamped;
/// not finite: refused and taken as zero).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Demand<const NH: usize> {
    /// The horizontal axes, in the model's output order (planar: x; 3D: x, y). A vector:
    /// the load moves along the direction it points.
    pub horizontal: [f64; NH],
    /// The hoist: positive lowers the load (the depth `z_C` grows).
    pub hoist: f64,
}

impl<const NH: usize> Demand<NH> {
    /// The stick at zero.
    pub const ZERO: Self = Self {
        horizontal: [0.0; NH],
        hoist: 0.0,
    };
}

/// What a cycle did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[must_use]
pub struct Cycle {
    /// A demand was not finite and was taken as zero (the axis stops sway-free).
    pub refused_demand: bool,
    /// The path is at rest on this cycle: every derivative exactly 0.0.
    pub at_rest: bool,
}

/// How the horizontal filter is tuned for the current horizontal motion (chosen when it
/// starts from rest).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tuning {
    /// The virtual pendulum's length `l_g`, m: `g (m_g h/π)²`, never shorter than the
    /// load's effective pendulum while the horizontal axes move.
    pub pendulum: f64,
    /// Its half period in cycles, `m_g`: the zero-vibration pair's delay.
    pub half_period: usize,
    /// The robust pair's delay in cycles, tuned to the rope when the motion started.
    pub robust_half_period: Option<usize>,
    /// The horizontal path's mean lag behind the rate limiter, `τ̄ = (m_g + m_r + m_1 +
    /// m_2) h/2`, s: the stopping distance's second term per m/s.
    pub lag: f64,
    /// The hoist path's mean lag, `(Σ m_z,i) h/2`, s.
    pub hoist_lag: f64,
    /// The deepest the load may go while the horizontal axes move, m.
    pub depth_cap: f64,
    /// The same in the hoist's position units.
    cap_units: i64,
}

/// The horizontal axes' and the hoist's ranges in position units, narrowed by a
/// hand-over's stop.
type Narrowed<const NH: usize> = ([(i64, i64); NH], (i64, i64));

/// The distance a load moving at `speed` needs to stop once the stick is released (or a
/// stop is commanded), m: the rate limiter's full-deceleration stop, at most
/// `v²/(2A) + v h/2`, and the filters' lag, at most `v τ̄`, plus `v h/2` for the
/// vector stop's rounding to whole cycles — `v²/(2A) + v (τ̄ + h)`, with `v` the largest
/// speed of the rate limiter within the last `τ̄`-window (in steady motion the load's
/// speed). For a vector `v` along a direction: per axis
/// `|v_i| (max_j |v_j|/A_j / 2 + τ̄ + h)`.
#[must_use]
pub fn stopping_bound(speed: f64, acceleration: f64, lag: f64, h: f64) -> f64 {
    let v = libm::fabs(speed);
    v * v / (2.0 * acceleration) + v * (lag + h)
}

/// The operator-mode generator for a crane with `NH` horizontal axes and a hoist, its
/// horizontal ring `RH` cycles long and the hoist's `RV`
/// ([`Settings::ring_lengths`] gives the least lengths for a crane's settings).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Generator<const NH: usize, const RH: usize, const RV: usize> {
    settings: Settings<NH>,
    inv_h: f64,
    /// Time of the first cycle, s.
    t0: f64,
    /// Cycles since `t0`: the current piece starts at `t0 + cycles h`.
    cycles: u64,
    /// Whether the current piece came from a cycle (the next one then starts at its end).
    built: bool,
    /// A stop is latched: every demand is taken as zero.
    stopping: bool,
    horizontal: Group<NH, RH>,
    hoist: Group<1, RV>,
    tuning: Tuning,
    /// The hoist's deepest rate-limiter position since it last rested, in its units: no
    /// load depth of the filtered path lies below it.
    reach: i64,
    /// The horizontal windows in cycles.
    boxes: [usize; 2],
    /// A hand-over's blend, while it lasts (and on its last cycle, [`Blend::lasts`]
    /// false).
    blend: Option<Blend<NH>>,
    /// The horizontal filter's virtual pendulum: the swing's end from its start, worked
    /// out when the filter is installed.
    swing: SwingMap,
    /// A stick's share beyond the deadband to velocity quanta per horizontal axis,
    /// `V_i/(δv_i (1 − deadband))`.
    full_stick: [f64; NH],
    /// The same for the hoist.
    full_hoist: f64,
    /// The lowering allowance in the hoist's position units, `⌊allowance/δp_z⌋`: fixed by
    /// the settings, worked out at [`Generator::reset`] instead of at every start (a
    /// double divide and a `floor`).
    allowance: i64,
    /// The horizontal filter for a start from the hoist's present state, worked out
    /// while the horizontal axes rest ([`Generator::retune`]).
    staged: Staged,
}

/// What a motion's start tunes the horizontal filter to, worked out ahead: at the end of
/// every cycle in which the horizontal axes rest (and no hand-over's blend lasts), for
/// the hoist's state at that cycle's end — what the next cycle's start reads — and only
/// when that state changed the tuning's inputs (the depth cap in units; with the robust
/// pair also the rope). The filter itself is installed in the horizontal group then (a
/// resting group's filter is read by nothing until a start, which installs it anyway),
/// and not again while the half periods stay the same. A start checks the keys, forgets
/// the ring and writes [`Tuning`]: the same operations on the same operands as a start
/// that works it all out, bit for bit, without the double divides (seven on the 3D
/// crane's plain path; the allowance's eighth is [`Generator::reset`]'s now), `sqrt` and
/// the taps' merging in the start's cycle, the generator's most expensive (`cargo xtask
/// cycles`, docs/OPERATOR.md "## Cost"). Their cost moves to the resting cycles in which
/// the depth cap changes: the cycle the horizontal axes come to rest after hoisting, and
/// each cycle of hoisting while they rest. A hand-over's entry stages the filter for its
/// blend (whose extent lengthens the pendulum, the same for the whole blend): a start
/// during the blend takes it, as long as the blend lasts and the keys are the same.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Staged {
    /// The depth cap in the hoist's units the filter was tuned for.
    cap_units: i64,
    /// The rope the robust pair was tuned to (its depth `z_C`), m.
    depth: f64,
    /// The virtual pendulum `g/ω_g²`, m.
    pendulum: f64,
    /// `m_g`; 0: nothing staged (a half period is at least one cycle), also for one
    /// beyond `u16` (a ring that long is not built; such a start works it all out).
    half_period: u16,
    /// `m_r` with the robust setting, else 0.
    robust_half_period: u16,
    /// Whether it was tuned for the hand-over's blend that lasts (its extent).
    blend: bool,
}

impl Staged {
    /// Nothing staged: the next start works the tuning out.
    const NONE: Self = Self {
        cap_units: 0,
        depth: 0.0,
        pendulum: 0.0,
        half_period: 0,
        robust_half_period: 0,
        blend: false,
    };
}

/// The stick's demand through the deadband: zero inside it, the rest scaled by `full`
/// (`1/(1 − deadband)` times full speed) so that full stick stays full; `None` for a value
/// that is not finite.
fn shaped(d: f64, deadband: f64, full: f64) -> Option<f64> {
    if !d.is_finite() {
        return None;
    }
    let a = libm::fabs(d).min(1.0);
    if a <= deadband {
        return Some(0.0);
    }
    let s = (a - deadband) * full;
    Some(if d < 0.0 { -s } else { s })
}

/// `[min, max]` in position units from `origin`, rounded inwards. Rounded and converted by
/// [`ceil_i`] and [`floor_i`] (`libm::ceil(…) as i64`, in one hardware conversion where
/// the value fits 32 bits): a hand-over's blend widens the ranges again in its last
/// cycle, and there `libm`'s `ceil` and `floor` and the soft `__aeabi_d2lz` for `as i64`
/// made `unit_bounds` 579 point cycles (`cargo xtask cycles --scenario
/// manual-takeover-3d`).
fn unit_bounds((lo, hi): (f64, f64), origin: f64, q: &Quanta) -> (i64, i64) {
    (
        ceil_i((lo - origin) / q.position),
        floor_i((hi - origin) / q.position),
    )
}

/// The horizontal axes' names in errors.
const HORIZONTAL: [&str; 2] = ["x", "y"];

impl<const NH: usize, const RH: usize, const RV: usize> Generator<NH, RH, RV> {
    /// At rest at time `t0` with the load at `horizontal` and depth `depth` (its rest
    /// position, exactly: the path starts there). Refuses invalid settings, rings shorter
    /// than the settings need and a position outside the settings' ranges.
    pub fn at_rest(
        settings: Settings<NH>,
        t0: f64,
        horizontal: [f64; NH],
        depth: f64,
    ) -> Result<Self> {
        let mut g = Self::parked(settings);
        g.reset(settings, t0, horizontal, depth)?;
        Ok(g)
    }

    /// Storage for a generator that has not started: at rest at the origin at time 0,
    /// deaf to the stick (every demand scales to zero speed), until [`Generator::reset`]
    /// starts it. What a controller keeps its manual mode's generator in while it runs
    /// automatic moves, so that entering manual mode writes the generator in place
    /// instead of building one on the control task's stack (`Generator3d` is ~3 KB,
    /// and a value built and then moved is two of them on the stack). Always inlined, so
    /// that the controller's construction writes it in place too.
    #[must_use]
    #[inline(always)]
    pub fn parked(settings: Settings<NH>) -> Self {
        Self {
            settings,
            inv_h: 0.0,
            t0: 0.0,
            cycles: 0,
            built: false,
            stopping: false,
            horizontal: Group::parked(),
            hoist: Group::parked(),
            tuning: Tuning {
                pendulum: 0.0,
                half_period: 0,
                robust_half_period: None,
                lag: 0.0,
                hoist_lag: 0.0,
                depth_cap: 0.0,
                cap_units: 0,
            },
            reach: 0,
            boxes: [0; 2],
            blend: None,
            swing: SwingMap::NONE,
            full_stick: [0.0; NH],
            full_hoist: 0.0,
            allowance: 0,
            staged: Staged::NONE,
        }
    }

    /// [`Generator::at_rest`] in place: the same generator, written field by field into
    /// `self` (the rings forgotten, not rebuilt), whatever `self` held — parked, moving
    /// or at rest. Every check comes first: on an error `self` is unchanged.
    pub fn reset(
        &mut self,
        settings: Settings<NH>,
        t0: f64,
        horizontal: [f64; NH],
        depth: f64,
    ) -> Result<()> {
        settings.validate()?;
        let (need_h, need_v) = settings.ring_lengths()?;
        if need_h > RH || need_v > RV {
            return Err(Error::InvalidSetting {
                name: if need_h > RH {
                    "horizontal ring length"
                } else {
                    "hoist ring length"
                },
                value: need_h.max(need_v) as f64,
            });
        }
        if !t0.is_finite() {
            return Err(Error::NonFiniteParameter {
                name: "t0",
                value: t0,
            });
        }
        for ((x, a), name) in horizontal
            .iter()
            .zip(settings.horizontal.iter())
            .zip(HORIZONTAL)
        {
            check_inside(name, *x, a.range, t0)?;
        }
        check_inside("z_C", depth, settings.hoist.range, t0)?;
        let h = settings.h;
        let quanta = settings.horizontal.map(|a| Quanta::new(a.acceleration, h));
        let mut bounds = [(0, 0); NH];
        for ((b, (a, q)), x) in bounds
            .iter_mut()
            .zip(settings.horizontal.iter().zip(quanta.iter()))
            .zip(horizontal)
        {
            *b = unit_bounds(a.range, x, q);
        }
        let zq = Quanta::new(settings.hoist.acceleration, h);
        let mut hoist_windows = [Factor::Window(1); 4];
        let mut hoist_cycles = 0;
        for (f, b) in hoist_windows.iter_mut().zip(settings.hoist_boxes) {
            let m = cycles("hoist box", b, h)?;
            hoist_cycles += m;
            *f = Factor::Window(m);
        }
        let boxes = [
            cycles("box", settings.boxes[0], h)?,
            cycles("box", settings.boxes[1], h)?,
        ];
        // Checked: from here on every field is written.
        self.hoist.reset(
            [depth],
            [settings.hoist.acceleration],
            h,
            [unit_bounds(settings.hoist.range, depth, &zq)],
            Taps::new(&hoist_windows),
        );
        self.horizontal.reset(
            horizontal,
            settings.horizontal.map(|a| a.acceleration),
            h,
            bounds,
            Taps::new(&[Factor::Window(boxes[0]), Factor::Window(boxes[1])]),
        );
        self.settings = settings;
        self.inv_h = 1.0 / h;
        self.t0 = t0;
        self.cycles = 0;
        self.built = false;
        self.stopping = false;
        self.tuning = Tuning {
            pendulum: 0.0,
            half_period: 0,
            robust_half_period: None,
            lag: 0.0,
            hoist_lag: hoist_cycles as f64 * h * 0.5,
            depth_cap: depth,
            cap_units: 0,
        };
        self.reach = 0;
        self.boxes = boxes;
        self.blend = None;
        self.swing = SwingMap::NONE;
        self.full_stick = settings
            .horizontal
            .map(|a| a.speed / Quanta::new(a.acceleration, h).velocity / (1.0 - settings.deadband));
        self.full_hoist = settings.hoist.speed / zq.velocity / (1.0 - settings.deadband);
        self.allowance = truncate(libm::floor(settings.lowering_allowance / zq.position));
        self.staged = Staged::NONE;
        self.retune();
        Ok(())
    }

    /// Takes over a moving load at time `t` (a hand-over from a running move): the move
    /// ends with a stop of its own on its path, at or before its target, and the
    /// generator starts at rest at that stop's end with the stick live; the load path is
    /// the two added ([`crate::operator`]'s `entry`). The path continues `state` with its
    /// derivatives 0..=5 exactly.
    ///
    /// Why not the move's steady state, blended over a fixed time (the first design):
    /// its blend's fourth derivative reaches the trolley through the pendulum
    /// (`ẍ ∋ x_L⁗ z_C/g`) and put it at up to 2.58 times its acceleration limit 0.4–0.6 s
    /// after a take-over 20 % into a 6 s move (`cargo run --release -p host-tests
    /// --example takeover_limits`, before this change; `entry`'s documentation has the
    /// numbers). The stop here is the shortest (then the nearest) whose added drive
    /// motion stays within `room`, at most [`Settings::entry_blend`] long.
    ///
    /// Refuses invalid settings, a state or room that is not finite, a state for which no
    /// stop keeps within `room` ([`Error::NoHandoverStop`]), and one
    /// whose stop leaves a range, or whose rope is longer than the virtual pendulum may
    /// be ([`Error::OutsideWorkspace`] naming the coordinate).
    pub fn take_over(
        settings: Settings<NH>,
        t: f64,
        state: &Handover<NH>,
        room: &Headroom<NH>,
    ) -> Result<Self> {
        let mut g = Self::parked(settings);
        g.reset_taking_over(settings, t, state, room)?;
        Ok(g)
    }

    /// [`Generator::take_over`] in place, as [`Generator::reset`] is [`Generator::at_rest`]
    /// in place: what a controller calls on the generator it keeps, so that a hand-over
    /// builds no ~3 KB generator on the control task's stack. Every check of the state,
    /// the room and the settings comes first; if the hand-over is refused after the
    /// generator was reset (its stop leaves a range, [`Error::OutsideWorkspace`]),
    /// `self` is a generator at rest at the stop's end, which the caller does not use.
    pub fn reset_taking_over(
        &mut self,
        settings: Settings<NH>,
        t: f64,
        state: &Handover<NH>,
        room: &Headroom<NH>,
    ) -> Result<()> {
        let all = state.horizontal.iter().flatten().chain(state.hoist.iter());
        let ends = state
            .target
            .iter()
            .chain([&state.hoist_target, &state.rest_in]);
        let rooms = room
            .horizontal
            .iter()
            .chain([&room.hoist])
            .flat_map(|r| [r.speed, r.acceleration]);
        if let Some(bad) = all
            .chain(ends)
            .copied()
            .chain(rooms)
            .find(|v| !v.is_finite())
        {
            return Err(Error::NonFiniteParameter {
                name: "hand-over state",
                value: bad,
            });
        }
        settings.validate()?;
        let deepest = state.hoist[0].max(state.hoist_target);
        let c = settings.pendulum_for(deepest) / settings.g;
        // Its own error, not "hand-over stop = 8 outside [0, 8]": no duration was refused
        // for being out of range, none up to the longest kept within the headroom.
        let stop = plan_stop(
            state,
            room,
            c,
            settings.h,
            settings.entry_blend,
            Ends::Smoothest,
        )
        .ok_or(Error::NoHandoverStop {
            longest: settings.entry_blend,
        })?;
        let mut ends = [0.0; NH];
        for ((end, d), axis) in ends.iter_mut().zip(&state.horizontal).zip(&stop.horizontal) {
            *end = d[0] - axis.e[0];
        }
        let depth = state.hoist[0] - stop.hoist.e[0];
        self.reset(settings, t, ends, depth)?;
        self.enter(&stop)
    }

    /// The stop of a hand-over added to the generator at rest at its end (see
    /// [`Generator::take_over`]): the ranges narrowed by the stop's excursion while it
    /// lasts, the pendulum tuned for its deepest load, the blend.
    fn enter(&mut self, stop: &Stop<NH>) -> Result<()> {
        let s = self.settings;
        let (horizontal, hoist) = self.narrowed(stop, &self.horizontal.origin)?;
        self.horizontal.bounds = horizontal;
        self.hoist.bounds = [hoist];
        // The path before the first cycle is the rest at the stop's end and the blend's
        // first share, which starts there: at θ = 0 the state itself.
        self.blend = Some(stop.blend(s.h));
        // The horizontal filter for the stop's deepest load, braked downwards (`retune`).
        self.retune();
        let need = self.pendulum_needed(stop);
        if need.is_nan() || need > self.tuning.pendulum {
            return Err(Error::OutsideWorkspace {
                t: self.t0,
                coordinate: "l",
                value: need,
                min: 0.0,
                max: self.tuning.pendulum,
            });
        }
        Ok(())
    }

    /// The ranges, in position units from `origin` (horizontal) and the hoist's origin,
    /// narrowed by `stop`'s excursion about its end there — refused if the stop leaves a
    /// range ([`Error::OutsideWorkspace`]).
    fn narrowed(&self, stop: &Stop<NH>, origin: &[f64; NH]) -> Result<Narrowed<NH>> {
        let s = self.settings;
        let t = self.t0;
        let narrowed = |name: &'static str, end: f64, axis: &AxisStop, (lo, hi): (f64, f64)| {
            check_inside(name, end + axis.low, (lo, hi), t)?;
            check_inside(name, end + axis.high, (lo, hi), t)?;
            Ok((lo - axis.low, hi - axis.high))
        };
        let zq = self.hoist.quanta()[0];
        let z_end = self.hoist.origin[0];
        let z_range = narrowed("z_C", z_end, &stop.hoist, s.hoist.range)?;
        let mut bounds = self.horizontal.bounds;
        for (i, ((axis, a), name)) in stop
            .horizontal
            .iter()
            .zip(s.horizontal.iter())
            .zip(HORIZONTAL)
            .enumerate()
        {
            let (Some(q), Some(end)) = (
                self.horizontal.quanta().get(i).copied(),
                origin.get(i).copied(),
            ) else {
                continue;
            };
            let range = narrowed(name, end, axis, a.range)?;
            if let Some(b) = bounds.get_mut(i) {
                *b = unit_bounds(range, end, &q);
            }
        }
        Ok((bounds, unit_bounds(z_range, z_end, &zq)))
    }

    /// The virtual pendulum `stop` needs: the deepest load it reaches, braked downwards
    /// by the hoist's acceleration and the stop's own, m (infinite if no length does).
    fn pendulum_needed(&self, stop: &Stop<NH>) -> f64 {
        let s = self.settings;
        let rest = s.g - s.hoist.acceleration - stop.hoist.down.max(0.0);
        if rest > 0.0 {
            (self.hoist.origin[0] + stop.hoist.high) * s.g / rest
        } else {
            f64::INFINITY
        }
    }

    /// A stop commanded while a hand-over's stop lasts: that stop planned again from
    /// where it is now, within `room` beside the operator's motion (the caller's, as for
    /// [`Generator::take_over`]), its shortest duration and then its nearest end ([`Ends::Nearest`]: the travel's nearest
    /// share of the way left, the hoist to the end it was stopping at). The generator's
    /// own path moves with the new end (its horizontal origin; its units, the
    /// operator's motion, stay), so that the load path goes on with every derivative.
    /// Kept as it is when no such stop is shorter, or when the new stop or the
    /// generator's own braking would leave the narrowed ranges, or the stop would need a
    /// longer pendulum than the filter was tuned for.
    // Out of line: its search (`plan_stop`, inlined here) is on the control task's stack
    // only in the cycle that latches the stop during a hand-over's stop, not in
    // `steer_manual`'s frame every cycle.
    #[inline(never)]
    fn shorten_handover_stop(&mut self, room: &Headroom<NH>) {
        let Some(blend) = self.blend.filter(Blend::lasts) else {
            return;
        };
        let s = self.settings;
        let left = blend.cycles_left();
        let now = blend.now(s.h);
        // `c` for the deepest the load may be while the stop lasts, as the take-over
        // takes the move's: the load now (the operator's hoist and the share), the stop's
        // end (the hoist's origin, where the share is 0), and where the operator's hoist,
        // stopped too, comes to rest with the share added (the stick may have lowered
        // since the take-over).
        let axis = self.hoist.axes[0];
        let braked = self.depth_at(axis.n_p.saturating_add(brake(axis.n_v)));
        let deepest = self
            .rope_now()
            .max(self.hoist.origin[0])
            .max(braked + now.hoist[0].max(0.0));
        let c = s.pendulum_for(deepest) / s.g;
        let Some(stop) = plan_stop(&now, room, c, s.h, u64_to_f64(left) * s.h, Ends::Nearest)
        else {
            return;
        };
        // The new end from the old, per horizontal axis: where the generator's own path
        // moves (the hoist's stays, [`Ends::Nearest`]).
        let mut origin = self.horizontal.origin;
        let mut nearer = false;
        for ((o, d), axis) in origin.iter_mut().zip(&now.horizontal).zip(&stop.horizontal) {
            let moved = d[0] - axis.e[0];
            nearer |= moved != 0.0;
            *o += moved;
        }
        if !(nearer || stop.cycles < left) {
            return;
        }
        let Ok((horizontal, hoist)) = self.narrowed(&stop, &origin) else {
            return;
        };
        let fits = self
            .horizontal
            .axes
            .iter()
            .zip(horizontal)
            .chain(self.hoist.axes.iter().zip([hoist]))
            .all(|(a, b)| Axis::stops_inside(a.n_v, a.n_p, b));
        // The pendulum the filter was tuned with must do for the new stop's deepest load
        // braked downwards, as the hand-over's entry checks it.
        let need = self.pendulum_needed(&stop);
        if !fits || need.is_nan() || need > self.tuning.pendulum {
            return;
        }
        self.horizontal.origin = origin;
        self.horizontal.bounds = horizontal;
        self.hoist.bounds = [hoist];
        self.blend = Some(stop.blend(s.h));
        // A filter staged for the old blend's extent is not this one's.
        self.staged = Staged::NONE;
    }

    /// The ranges back to the settings' once a hand-over's stop has passed.
    fn widen(&mut self) {
        let s = self.settings;
        let quanta = self.horizontal.quanta();
        for (((b, a), q), o) in self
            .horizontal
            .bounds
            .iter_mut()
            .zip(s.horizontal.iter())
            .zip(quanta)
            .zip(self.horizontal.origin)
        {
            *b = unit_bounds(a.range, o, &q);
        }
        let zq = self.hoist.quanta()[0];
        self.hoist.bounds = [unit_bounds(s.hoist.range, self.hoist.origin[0], &zq)];
    }

    /// Chooses the horizontal filter for a motion starting now (the horizontal axes at
    /// rest): the virtual pendulum long enough for the deepest load the hoist may reach
    /// while it lasts — where it would stop now, or its deepest since it last rested,
    /// and the lowering allowance below that, within its range — and the robust pair at
    /// the rope's current length. Taken from [`Staged`] when it was worked out for this
    /// state (a start from rest without a blend: always, [`Generator::advance`] stages it
    /// at the end of every resting cycle), else worked out now.
    fn retune(&mut self) {
        let cap_units = self.cap_units();
        let depth_cap = self.depth_at(cap_units);
        let (pendulum, m_g, robust) = if self.is_staged(cap_units) {
            // Installed while the group rested; its history since then all zero steps.
            self.horizontal.forget();
            let st = &self.staged;
            let m_r = usize::from(st.robust_half_period);
            (
                st.pendulum,
                usize::from(st.half_period),
                (m_r != 0).then_some(m_r),
            )
        } else {
            self.stage(cap_units, depth_cap)
        };
        let [b1, b2] = self.boxes;
        self.tuning = Tuning {
            pendulum,
            half_period: m_g,
            robust_half_period: robust,
            lag: (m_g + robust.unwrap_or(0) + b1 + b2) as f64 * self.settings.h * 0.5,
            depth_cap,
            cap_units,
            ..self.tuning
        };
    }

    /// The deepest the load may go while a motion starting now lasts, in the hoist's
    /// units: where the hoist would stop now, or its deepest since it last rested, and
    /// the lowering allowance below that, within its range.
    fn cap_units(&self) -> i64 {
        let axis = self.hoist.axes[0];
        let reach = self.reach.max(axis.n_p + brake(axis.n_v));
        reach
            .saturating_add(self.allowance)
            .min(self.hoist.bounds[0].1)
    }

    /// The depth `cap_units` from the hoist's origin, m.
    fn depth_at(&self, cap_units: i64) -> f64 {
        // Converted in 32 bits where it fits (`i64_to_f64`): the same value without the
        // soft `__aeabi_l2d`.
        self.hoist.origin[0] + i64_to_f64(cap_units) * self.hoist.quanta()[0].position
    }

    /// The rope now: the load's depth at this cycle's start (it hangs straight at
    /// horizontal rest), a hand-over's share included, within the range the ring is
    /// sized for.
    fn rope_now(&self) -> f64 {
        let path = self.hoist.start_position(0);
        // The share on its last cycle too: the path still holds it.
        let depth = match &self.blend {
            Some(b) => path + b.hoist_at_start(),
            None => path,
        };
        depth.min(self.settings.hoist.range.1)
    }

    /// Whether a hand-over's blend lasts beyond the current cycle.
    fn blending(&self) -> bool {
        self.blend.as_ref().is_some_and(Blend::lasts)
    }

    /// Whether [`Staged`] holds the filter for a start with this depth cap: tuned with
    /// the blend that lasts or with none as now, the same cap, the same rope if the
    /// robust pair is tuned to it.
    fn is_staged(&self, cap_units: i64) -> bool {
        let st = &self.staged;
        st.blend == self.blending()
            && st.half_period != 0
            && st.cap_units == cap_units
            && (!self.settings.robust || st.depth.to_bits() == self.rope_now().to_bits())
    }

    /// Works the filter out for a start with this depth cap (`cap_units`, `depth_cap` m)
    /// and the rope now, and installs it in the horizontal group (which forgets its
    /// ring); kept in [`Staged`] (with whether a blend lasts: its extent moves the
    /// pendulum) unless a half period is beyond `u16`. Returns the pendulum `g/ω_g²`, `m_g` and the robust
    /// pair's `m_r`.
    fn stage(&mut self, cap_units: i64, depth_cap: f64) -> (f64, usize, Option<usize>) {
        let s = &self.settings;
        let h = s.h;
        // While a hand-over's stop lasts, its load may be deeper by its excursion and
        // braked downwards: the pendulum is never shorter than that load's effective one
        // (`z g/(g − z̈)`), nor longer than the ring holds.
        let mut pendulum = s.pendulum_for(depth_cap);
        if let Some([high, down]) = self
            .blend
            .as_ref()
            .filter(|b| b.lasts())
            .map(|b| b.hoist_extent)
        {
            let rest = s.g - s.hoist.acceleration - down;
            let braked = if rest > 0.0 {
                (depth_cap + high) * s.g / rest
            } else {
                f64::INFINITY
            };
            pendulum = pendulum.max(braked).min(s.pendulum_for(s.hoist.range.1));
        }
        let m_g = zv_cycles(pendulum, s.g, h, Rounding::Up);
        let depth_now = self.rope_now();
        let robust = s
            .robust
            .then(|| zv_cycles(depth_now, s.g, h, Rounding::Nearest));
        let st = self.staged;
        let pendulum = if st.half_period != 0
            && usize::from(st.half_period) == m_g
            && usize::from(st.robust_half_period) == robust.unwrap_or(0)
        {
            // The filter staged last, installed since (every other filter clears the
            // stage): taps, `ω_g h` and the pendulum are functions of the half periods
            // alone. Its history forgotten, as installing it again would.
            self.horizontal.forget();
            st.pendulum
        } else {
            let omega_g = core::f64::consts::PI / (m_g as f64 * h);
            // The windows' taps as `reset` merged them (they never change), not merged
            // anew.
            let windows = self.horizontal.taps().without_pairs();
            let taps = match robust {
                Some(m_r) => windows.with_pairs(&[m_g, m_r]),
                None => windows.with_pairs(&[m_g]),
            };
            self.horizontal.set_filter(taps);
            self.swing = SwingMap::new(omega_g * h, h);
            s.g / (omega_g * omega_g)
        };
        self.staged = match (u16::try_from(m_g), u16::try_from(robust.unwrap_or(0))) {
            (Ok(half_period), Ok(robust_half_period)) => Staged {
                cap_units,
                depth: depth_now,
                pendulum,
                half_period,
                robust_half_period,
                blend: self.blending(),
            },
            _ => Staged::NONE,
        };
        (pendulum, m_g, robust)
    }

    /// Stages the filter for a start in the next cycle ([`Staged`]), if the horizontal
    /// axes rest and no blend lasts; nothing if it is staged for this state already (a
    /// resting hoist: the check is integers, and the rope with the robust pair).
    fn stage_next_start(&mut self) {
        if !self.horizontal.is_at_rest() || self.blending() {
            return;
        }
        let cap_units = self.cap_units();
        if !self.is_staged(cap_units) {
            self.stage(cap_units, self.depth_at(cap_units));
        }
    }

    /// One cycle: moves on past the current piece (if any) and builds the next one,
    /// `[t, t + h]`, from the stick's `demand`. Call it once per cycle before the inverse
    /// model steps over that interval. Never inlined: `cargo xtask cycles` measures the
    /// generator's cost per cycle from a call of this (and of [`Generator::evaluate`]) to
    /// its return.
    #[inline(never)]
    pub fn advance(&mut self, demand: &Demand<NH>) -> Cycle {
        if self.built {
            self.cycles += 1;
        }
        self.built = true;
        if self.blend.as_ref().is_some_and(|b| !b.lasts()) {
            // Its last share was on the cycle before.
            self.blend = None;
        }
        let s = self.settings;
        let mut refused = false;
        let mut shape = |d: f64, full: f64| {
            shaped(d, s.deadband, full).unwrap_or_else(|| {
                refused = true;
                0.0
            })
        };
        let mut targets = [0.0; NH];
        for ((t, d), full) in targets
            .iter_mut()
            .zip(demand.horizontal)
            .zip(self.full_stick)
        {
            *t = shape(d, full);
        }
        let mut hoist_target = shape(demand.hoist, self.full_hoist);
        if self.stopping {
            targets = [0.0; NH];
            hoist_target = 0.0;
        }
        let starts = self.horizontal.is_at_rest() && targets.iter().any(|t| *t != 0.0);
        if starts {
            self.retune();
        }
        // While the horizontal axes move, the hoist stays above the depth the pendulum
        // was tuned for.
        let mut hoist_bounds = self.hoist.bounds;
        if starts || !self.horizontal.is_at_rest() {
            hoist_bounds[0].1 = hoist_bounds[0].1.min(self.tuning.cap_units);
        }
        self.hoist
            .cycle([hoist_target], hoist_bounds, s.h, self.inv_h, None);
        let n_p = self.hoist.axes[0].n_p;
        // A hand-over's stop keeps its deepest load in `reach` while it lasts.
        self.reach = if self.hoist.is_at_rest() && !self.blending() {
            n_p
        } else {
            self.reach.max(n_p)
        };
        let bounds = self.horizontal.bounds;
        self.horizontal
            .cycle(targets, bounds, s.h, self.inv_h, Some(&self.swing));
        if self.blend.as_mut().is_some_and(|b| !b.advance()) {
            // Its last share is on this cycle: the ranges are the settings' from the next.
            self.widen();
        }
        // Last: what the next cycle's start reads is final now.
        self.stage_next_start();
        Cycle {
            refused_demand: refused,
            at_rest: self.is_at_rest(),
        }
    }

    /// Latches a stop: from the next cycle on every demand is taken as zero, so the load
    /// comes to a sway-free rest along its current direction, within
    /// [`stopping_bound`]. Kept until [`Generator::resume`].
    /// A hand-over's stop that lasts goes on to its end: [`Generator::stop_within`]
    /// shortens it too.
    pub fn stop(&mut self) {
        self.stopping = true;
    }

    /// [`Generator::stop`], and while a hand-over's stop lasts, that stop shortened to
    /// its shortest, then nearest, end that keeps within `room` (the drives' room beside
    /// the operator, as the hand-over was given): the taken-over move stops as soon as
    /// it can too, not only the operator's share. Its cost is the hand-over's search
    /// again (at most a refused one's), in the cycle the stop is latched. Call
    /// [`Generator::advance`] before evaluating the path again: the new stop starts at the
    /// next cycle.
    pub fn stop_within(&mut self, room: &Headroom<NH>) {
        if !self.stopping {
            self.shorten_handover_stop(room);
        }
        self.stopping = true;
    }

    /// Lifts a latched stop: demands count again (the caller's interlock decides when).
    pub fn resume(&mut self) {
        self.stopping = false;
    }

    /// Whether a stop is latched.
    #[must_use]
    pub fn is_stopping(&self) -> bool {
        self.stopping
    }

    /// Whether the path is at rest on the current cycle: every derivative exactly 0.0,
    /// the position constant, until a demand moves it again.
    #[must_use]
    pub fn is_at_rest(&self) -> bool {
        !self.blending() && self.horizontal.is_at_rest() && self.hoist.is_at_rest()
    }

    /// Start of the current cycle, s.
    #[must_use]
    pub fn time(&self) -> f64 {
        // `cycles` as f64 through the split conversion (the same value): `as f64` on a
        // u64 is the soft `__aeabi_ul2d` on the Cortex-M7, and every evaluation asks.
        self.t0 + i64_to_f64(self.cycles as i64) * self.settings.h
    }

    /// The settings.
    #[must_use]
    pub fn settings(&self) -> &Settings<NH> {
        &self.settings
    }

    /// The current tuning of the horizontal filter.
    #[must_use]
    pub fn tuning(&self) -> &Tuning {
        &self.tuning
    }

    /// The rate limiter's speeds at the current cycle's end (the next one's start), m/s:
    /// horizontal axes, hoist.
    #[must_use]
    pub fn demanded_speeds(&self) -> ([f64; NH], f64) {
        (self.horizontal.speeds(), self.hoist.speeds()[0])
    }

    /// The path and its first `D − 1` derivatives at `t` (inside the current cycle; beyond
    /// it the cycle's polynomial is continued): per horizontal axis, and the hoist's. At
    /// the cycle's end (BDF's `t_{n+1}`) with `D ≤ 3` from the end states, elsewhere
    /// from the cycle's polynomial ([`crate::operator`]'s `ends`). Never inlined, as
    /// [`Generator::advance`].
    #[must_use]
    #[inline(never)]
    pub fn evaluate<const D: usize>(&self, t: f64) -> ([[f64; D]; NH], [f64; D]) {
        let theta = (t - self.time()) * self.inv_h;
        let (h, inv_h) = (self.settings.h, self.inv_h);
        let mut out = [[0.0; D]; NH];
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.horizontal.eval(i, theta, h, inv_h, Some(&self.swing));
        }
        let mut hoist = self.hoist.eval(0, theta, h, inv_h, None);
        if let Some(b) = &self.blend {
            b.add_to(&mut out, &mut hoist, theta, inv_h);
        }
        (out, hoist)
    }

    /// `(t_n, t_n + h)` while the path moves, `(t_n, t_n)` at rest: the trajectory is
    /// known one cycle ahead.
    fn span(&self) -> (f64, f64) {
        let t = self.time();
        if self.is_at_rest() {
            (t, t)
        } else {
            (t, t + self.settings.h)
        }
    }
}

/// The outputs `[x_C, (y_C,) z_C]` and their derivatives as the models take them.
fn outputs<T: Real, const NH: usize, const NZ: usize, const D: usize>(
    (horizontal, hoist): ([[f64; D]; NH], [f64; D]),
) -> [SVector<T, NZ>; D] {
    let mut out = [SVector::<T, NZ>::zeros(); D];
    for (j, o) in out.iter_mut().enumerate() {
        for (i, slot) in o.iter_mut().enumerate() {
            let v = if i < NH {
                horizontal.get(i).and_then(|a| a.get(j))
            } else {
                hoist.get(j)
            };
            *slot = c(v.copied().unwrap_or(0.0));
        }
    }
    out
}

/// The planar crane's load path `[x_C, z_C]`.
impl<T: Real, const RH: usize, const RV: usize> Trajectory<T, 2> for Generator<1, RH, RV> {
    fn derivatives<const D: usize>(&self, t: T) -> [SVector<T, 2>; D] {
        outputs(self.evaluate::<D>(to_f64(t)))
    }

    fn active_span(&self) -> (T, T) {
        let (a, b) = self.span();
        (c(a), c(b))
    }

    fn smoothness(&self) -> usize {
        SMOOTHNESS
    }
}

/// The 3D crane's load path `[x_C, y_C, z_C]`.
impl<T: Real, const RH: usize, const RV: usize> Trajectory<T, 3> for Generator<2, RH, RV> {
    fn derivatives<const D: usize>(&self, t: T) -> [SVector<T, 3>; D] {
        outputs(self.evaluate::<D>(to_f64(t)))
    }

    fn active_span(&self) -> (T, T) {
        let (a, b) = self.span();
        (c(a), c(b))
    }

    fn smoothness(&self) -> usize {
        SMOOTHNESS
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::indexing_slicing, clippy::unwrap_used)]
    extern crate std;
    use std::string::ToString;
    use std::vec;
    use std::vec::Vec;

    use super::*;
    use crate::models::crane::CraneParams;
    use crate::models::crane3d::Crane3dParams;
    use crate::operator::entry::plan_stop;
    use crate::operator::{Generator3d, PlanarGenerator, Room};
    use crate::trajectory::PointToPoint;

    /// A stick that hoists alone, starts the horizontal axes while hoisting, after the
    /// hoist stopped, before and after they came to rest, releases, reverses: piecewise
    /// constant demands of pseudo-random lengths (an LCG, the same every run), half of
    /// them the horizontal axes released for 400–1,999 cycles (their stop and the
    /// filter's window are 300–650), the others 1–300 cycles of any demand; the hoist's
    /// demand a third of the time zero.
    fn sticks<const NH: usize>(cycles: usize) -> Vec<Demand<NH>> {
        let mut seed = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (seed >> 33) as usize
        };
        let mut out = Vec::with_capacity(cycles);
        while out.len() < cycles {
            let rest = next() % 2 == 0;
            let left = if rest {
                400 + next() % 1_600
            } else {
                1 + next() % 300
            };
            let mut demand = Demand::ZERO;
            for d in demand.horizontal.iter_mut() {
                *d = if rest { 0.0 } else { LEVELS[next() % 6] };
            }
            demand.hoist = LEVELS[next() % 6];
            out.extend(core::iter::repeat_n(demand, left));
        }
        out.truncate(cycles);
        out
    }

    /// The first cycle of `sticks` with a horizontal demand.
    const FIRST_MOTION: usize = 1_056;

    /// The stick's levels, zero a third of the time.
    const LEVELS: [f64; 6] = [0.0, 0.0, 1.0, -1.0, 0.6, -0.3];

    /// Runs `staged` and a twin whose staged tuning is dropped before every cycle (so
    /// that each of its starts works the tuning out in the start's cycle, as before
    /// [`Staged`]) on the same stick: the same cycles, tunings, paths, and while the
    /// horizontal axes move the same generator (the staged tuning aside), bit for bit. Returns how many starts changed
    /// `m_g` (the tuning worked out anew after hoisting) and how many starts there were.
    fn twin_run<const NH: usize, const RH: usize, const RV: usize>(
        mut staged: Generator<NH, RH, RV>,
        sticks: &[Demand<NH>],
    ) -> (usize, usize, usize) {
        let mut fresh = staged;
        let (mut changed, mut starts, mut blended) = (0, 0, 0);
        for (n, stick) in sticks.iter().enumerate() {
            fresh.staged = Staged::NONE;
            let before = staged.tuning;
            let resting = staged.horizontal.is_at_rest();
            let (a, b) = (staged.advance(stick), fresh.advance(stick));
            assert_eq!(a, b, "cycle {n}");
            if resting && !staged.horizontal.is_at_rest() {
                starts += 1;
                changed += usize::from(staged.tuning.half_period != before.half_period);
                blended += usize::from(staged.blend.is_some());
            }
            for theta in [0.0, 0.3, 1.0] {
                let t = staged.time() + theta * staged.settings.h;
                assert_eq!(staged.evaluate::<6>(t), fresh.evaluate::<6>(t), "cycle {n}");
            }
            // Moving, from the start on: the whole state (at rest the twin, staging anew
            // every cycle, has forgotten its ring's old cycles sooner).
            if !staged.horizontal.is_at_rest() {
                let mut twin = fresh;
                twin.staged = staged.staged;
                assert_eq!(staged, twin, "cycle {n}");
            }
        }
        (changed, starts, blended)
    }

    /// A start takes the staged tuning, and it is the one the start would work out: planar
    /// and 3D, plain and robust, from rest and from a hand-over (a start during its blend
    /// takes the filter the entry staged when it is plain; robust, the rope has moved with
    /// the blend by then and the start works the filter out).
    #[test]
    fn a_staged_tuning_is_the_one_the_start_works_out() {
        for robust in [false, true] {
            let (g, _) = lab_generators(robust);
            let (changed, starts, _) = twin_run(g, &sticks::<1>(60_000));
            assert!(changed >= 3 && starts >= 15, "{changed} of {starts} starts");

            let (_, g) = lab_generators(robust);
            let s = *g.settings();
            let (changed, starts, _) = twin_run(g, &sticks::<2>(60_000));
            assert!(changed >= 3 && starts >= 15, "{changed} of {starts} starts");

            let (state, room) = hand_over_at(3.0);
            let g = Generator3d::take_over(s, 3.0, &state, &room).unwrap();
            // The stick moved 50 cycles in: during the blend.
            let mut stick = vec![Demand::ZERO; 50];
            stick.extend(sticks::<2>(16_000).split_off(FIRST_MOTION));
            let (_, starts, blended) = twin_run(g, &stick);
            assert!(blended == 1 && starts >= 2, "{blended} of {starts} starts");
        }
    }

    /// At the cycle's end (BDF's `t_{n+1}`, three values) the path comes from the end
    /// states; asked for four, from the cycle's polynomial: the same values to rounding,
    /// every cycle of a long random stick — planar and 3D, plain and robust, from rest
    /// and from a hand-over (its blend added, and before its first cycle the taken-over
    /// state itself).
    #[test]
    fn at_the_cycle_end_the_end_states_are_the_polynomial() {
        fn compare<const NH: usize, const RH: usize, const RV: usize>(
            mut g: Generator<NH, RH, RV>,
            sticks: &[Demand<NH>],
        ) -> usize {
            let mut moving = 0;
            for (n, stick) in sticks.iter().enumerate() {
                let _ = g.advance(stick);
                moving += usize::from(!g.is_at_rest());
                let t = g.time() + g.settings.h;
                let (fast_h, fast_z) = g.evaluate::<3>(t);
                let (slow_h, slow_z) = g.evaluate::<4>(t);
                let close = |a: &[f64; 3], b: &[f64; 4]| {
                    a.iter()
                        .zip(b)
                        .all(|(a, b)| (a - b).abs() <= 1e-12 * (1.0 + b.abs()))
                };
                for (a, b) in fast_h.iter().zip(slow_h.iter()) {
                    assert!(close(a, b), "cycle {n}: {a:?} vs {b:?}");
                }
                assert!(
                    close(&fast_z, &slow_z),
                    "cycle {n}: {fast_z:?} vs {slow_z:?}"
                );
            }
            moving
        }
        for robust in [false, true] {
            let (g, _) = lab_generators(robust);
            assert!(compare(g, &sticks::<1>(20_000)) > 5_000);

            let (_, g) = lab_generators(robust);
            let s = *g.settings();
            assert!(compare(g, &sticks::<2>(20_000)) > 5_000);

            let (state, room) = hand_over_at(3.0);
            let g = Generator3d::take_over(s, 3.0, &state, &room).unwrap();
            // Before its first cycle the path is the taken-over state.
            let (h0, z0) = g.evaluate::<3>(3.0);
            for (got, want) in h0.iter().zip(&state.horizontal) {
                assert!((0..3).all(|j| (got[j] - want[j]).abs() <= 1e-12 * (1.0 + want[j].abs())));
            }
            assert!((0..3)
                .all(|j| (z0[j] - state.hoist[j]).abs() <= 1e-12 * (1.0 + state.hoist[j].abs())));
            let mut stick = vec![Demand::ZERO; 50];
            stick.extend(sticks::<2>(6_000).split_off(FIRST_MOTION));
            assert!(compare(g, &stick) > 500);
        }
    }

    /// The lab generators (planar, 3D) at rest in the middle of their ranges, plain or
    /// robust.
    fn lab_generators(robust: bool) -> (PlanarGenerator, Generator3d) {
        let middle = |(a, b): (f64, f64)| (a + b) / 2.0;
        let mut s = Settings::lab(&CraneParams::PAPER);
        s.robust = robust;
        let (x, z) = (s.horizontal[0].range, s.hoist.range);
        let planar = PlanarGenerator::at_rest(s, 0.0, [middle(x)], middle(z)).unwrap();
        let mut s = Settings::lab_3d(&Crane3dParams::EXAMPLE);
        s.robust = robust;
        let (x, y, z) = (s.horizontal[0].range, s.horizontal[1].range, s.hoist.range);
        let spatial = Generator3d::at_rest(s, 0.0, [middle(x), middle(y)], middle(z)).unwrap();
        (planar, spatial)
    }

    /// The 3D lab move and room of the hand-over tests: a take-over at `t` of the move
    /// (12, 3, 8 m deep) → (20, 6, 4 m deep) in 10 s, the 3D lab drives' room beside the
    /// operator (`examples/operator_cycles.rs`).
    fn hand_over_at(t: f64) -> (Handover<2>, Headroom<2>) {
        let mv = PointToPoint::new(
            nalgebra::SVector::from([12.0, 3.0, 8.0]),
            nalgebra::SVector::from([20.0, 6.0, 4.0]),
            0.0,
            10.0,
            5,
        )
        .unwrap();
        let room = |speed, acceleration| Room {
            speed,
            acceleration,
        };
        let room = Headroom {
            horizontal: [room(1.85, 2.1), room(1.1, 1.15)],
            hoist: room(1.4, 2.1),
        };
        (Handover::<2>::of(&mv, t), room)
    }

    /// A stop commanded during a hand-over's stop shortens it ([`Generator::stop_within`]): the
    /// 3D lab move taken over at 2, 5 and 8 s of its 10, the stick centred, the stop
    /// commanded `k` cycles later. The path goes on with its derivatives through the
    /// cycle the shortened stop begins in; along each axis the load never turns back,
    /// rests no farther than the hand-over's own stop (and at or beyond where it was when
    /// the stop came) and no later; and some rest nearer.
    #[test]
    fn a_stop_during_a_hand_over_s_stop_shortens_it() {
        let s = Settings::lab_3d(&Crane3dParams::EXAMPLE);
        let h = s.h;
        let mut nearer = 0;
        for t in [2.0, 5.0, 8.0] {
            for k in [0_usize, 1, 10, 40] {
                let (state, room) = hand_over_at(t);
                let mut plain = Generator3d::take_over(s, t, &state, &room).unwrap();
                let mut stopped = plain;
                for _ in 0..k {
                    let _ = plain.advance(&Demand::ZERO);
                    let _ = stopped.advance(&Demand::ZERO);
                }
                // The path at the end of the cycle before the stop, and where the load is.
                // Before the first cycle (k = 0) the stop's start is the take-over's instant.
                let boundary = if k == 0 {
                    stopped.time()
                } else {
                    stopped.time() + h
                };
                let (before_h, before_z) = stopped.evaluate::<6>(boundary);
                let was = before_h.map(|d| d[0]);
                stopped.stop_within(&room);
                let _ = stopped.advance(&Demand::ZERO);
                let _ = plain.advance(&Demand::ZERO);
                let (after_h, after_z) = stopped.evaluate::<6>(boundary);
                for (b, a) in before_h
                    .iter()
                    .chain([&before_z])
                    .zip(after_h.iter().chain([&after_z]))
                {
                    for j in 0..6 {
                        assert!(
                            (a[j] - b[j]).abs() <= 1e-7 * (1.0 + b[j].abs()),
                            "{t} s + {k}: derivative {j} {} → {}",
                            b[j],
                            a[j]
                        );
                    }
                }
                let direction: [f64; 2] =
                    core::array::from_fn(|i| (state.target[i] - state.horizontal[i][0]).signum());
                let (mut last, mut rest_stopped, mut rest_plain) = (was, None, None);
                for n in 0..2_000 {
                    let now = stopped.time();
                    let (x, _) = stopped.evaluate::<1>(now);
                    for i in 0..2 {
                        assert!(
                            (x[i][0] - last[i]) * direction[i] >= -1e-9,
                            "{t} s + {k}: axis {i} turns back at cycle {n}"
                        );
                        last[i] = x[i][0];
                    }
                    if stopped.is_at_rest() && rest_stopped.is_none() {
                        rest_stopped = Some(n);
                    }
                    if plain.is_at_rest() && rest_plain.is_none() {
                        rest_plain = Some(n);
                    }
                    if rest_stopped.is_some() && rest_plain.is_some() {
                        break;
                    }
                    let _ = stopped.advance(&Demand::ZERO);
                    let _ = plain.advance(&Demand::ZERO);
                }
                let (a, b) = (rest_stopped.unwrap(), rest_plain.unwrap());
                assert!(
                    a <= b,
                    "{t} s + {k}: rests at cycle {a}, not later than {b}"
                );
                let end_stopped = stopped.evaluate::<1>(stopped.time()).0;
                let end_plain = plain.evaluate::<1>(plain.time()).0;
                let mut shorter = false;
                for i in 0..2 {
                    let (e1, e2) = (end_stopped[i][0], end_plain[i][0]);
                    assert!(
                        (e1 - e2) * direction[i] <= 1e-9,
                        "{t} s + {k}: axis {i} {e1} past {e2}"
                    );
                    assert!(
                        (e1 - was[i]) * direction[i] >= -1e-9,
                        "{t} s + {k}: axis {i} behind"
                    );
                    shorter |= (e2 - e1) * direction[i] > 1e-3;
                }
                nearer += usize::from(shorter);
            }
        }
        // Shortened on the durations' grid (a fifth apart, and the stop's own rest): 10
        // cycles after the take-overs at 2 and 5 s by 0.16 and 0.40 m (13.272 against
        // 13.437 m, 19.023 against 19.424 m along x), 40 cycles after at the same end 0.2 s
        // sooner; the take-over at 8 s has its shortest stop already.
        assert!(nearer >= 2, "{nearer} of 12 shortened by more than 1 mm");
    }

    /// With the robust setting a hand-over tunes the robust pair to the taken-over rope,
    /// the depth the path has there — not to the depth its stop ends at — when it enters
    /// and when the stick starts a motion during its blend.
    #[test]
    fn a_robust_hand_over_tunes_its_pair_to_the_taken_over_rope() {
        let mut s = Settings::lab_3d(&Crane3dParams::EXAMPLE);
        s.robust = true;
        for t in [3.0, 5.0, 7.5] {
            let (state, room) = hand_over_at(t);
            let want = zv_cycles(state.hoist[0], s.g, s.h, Rounding::Nearest);
            let mut g = Generator3d::take_over(s, t, &state, &room).unwrap();
            assert_eq!(g.tuning().robust_half_period, Some(want), "entry at {t} s");
            let stop_end = zv_cycles(g.hoist.origin[0], s.g, s.h, Rounding::Nearest);
            assert_ne!(want, stop_end, "the case tells the ropes apart");
            let _ = g.advance(&Demand {
                horizontal: [1.0, 0.0],
                hoist: 0.0,
            });
            assert!(g.blending() && !g.horizontal.is_at_rest());
            assert_eq!(g.tuning().robust_half_period, Some(want), "start at {t} s");
        }
    }

    /// With the stick at rest the path after a hand-over is the stop's end plus the blend
    /// `E(τ) = Σ_j e_j T_b^j H_j(τ)` worked out here from the Hermite basis: at every
    /// cycle end, and before the first cycle (the taken-over state): the blend's shares
    /// move on one cycle per cycle, none twice, none skipped.
    #[test]
    fn after_a_hand_over_the_path_is_the_stop_and_its_blend() {
        let s = Settings::lab_3d(&Crane3dParams::EXAMPLE);
        let t0 = 5.0;
        let (state, room) = hand_over_at(t0);
        let mut g = Generator3d::take_over(s, t0, &state, &room).unwrap();
        let deepest = state.hoist[0].max(state.hoist_target);
        let c = s.pendulum_for(deepest) / s.g;
        let stop = plan_stop(&state, &room, c, s.h, s.entry_blend, Ends::Smoothest).unwrap();
        let duration = stop.cycles as f64 * s.h;
        let blend = |e: &[f64; 6], tau: f64| -> f64 {
            let mut scale = 1.0;
            let mut sum = 0.0;
            for (ej, basis) in e.iter().zip(crate::operator::entry::HERMITE.iter()) {
                let h_j: f64 = basis
                    .iter()
                    .enumerate()
                    .map(|(k, b)| b * tau.powi(k as i32))
                    .sum();
                sum += ej * scale * h_j;
                scale *= duration;
            }
            sum
        };
        let ends = [
            g.horizontal.origin[0],
            g.horizontal.origin[1],
            g.hoist.origin[0],
        ];
        let es = [stop.horizontal[0].e, stop.horizontal[1].e, stop.hoist.e];
        let check = |g: &Generator3d, n: u64| {
            let tau = n as f64 / stop.cycles as f64;
            let (horizontal, hoist) = g.evaluate::<3>(t0 + n as f64 * s.h);
            let got = [horizontal[0][0], horizontal[1][0], hoist[0]];
            for ((got, end), e) in got.iter().zip(ends).zip(&es) {
                let want = end + blend(e, tau);
                assert!((got - want).abs() < 1e-9, "cycle {n}: {got} vs {want}");
            }
        };
        check(&g, 0);
        for n in 1..=stop.cycles + 20 {
            let _ = g.advance(&Demand::ZERO);
            check(&g, n.min(stop.cycles));
        }
        assert!(g.is_at_rest() && g.blend.is_none());
    }

    /// A start during a hand-over's blend takes the filter its entry staged (plain: the
    /// keys are the cap and the blend, both unchanged): nothing is worked out in the
    /// start's cycle, whose tuning is the entry's.
    #[test]
    fn a_start_during_a_blend_takes_the_entry_s_filter() {
        let s = Settings::lab_3d(&Crane3dParams::EXAMPLE);
        for t in [3.0, 5.0, 7.5] {
            let (state, room) = hand_over_at(t);
            let mut g = Generator3d::take_over(s, t, &state, &room).unwrap();
            let entry = *g.tuning();
            for _ in 0..50 {
                let _ = g.advance(&Demand::ZERO);
            }
            assert!(g.blending() && g.horizontal.is_at_rest());
            assert!(g.is_staged(g.cap_units()), "hand-over at {t} s");
            let _ = g.advance(&Demand {
                horizontal: [0.6, -0.4],
                hoist: 0.0,
            });
            assert!(!g.horizontal.is_at_rest());
            assert_eq!(*g.tuning(), entry, "hand-over at {t} s");
        }
    }

    /// A hand-over no stop fits (here a moving trolley and no room at all) is refused with
    /// what was tried, never a duration that reads as inside its range (it printed
    /// "parameter hand-over stop = 8 outside [0, 8]").
    #[test]
    fn a_hand_over_no_stop_fits_says_which_stops_were_tried() {
        let settings = Settings::lab(&CraneParams::PAPER);
        let moving = Handover {
            horizontal: [[12.0, 0.5, 0.0, 0.0, 0.0, 0.0]],
            hoist: [8.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            target: [18.0],
            hoist_target: 8.0,
            rest_in: 6.0,
        };
        let none = Room {
            speed: 0.0,
            acceleration: 0.0,
        };
        let room = Headroom {
            horizontal: [none],
            hoist: none,
        };
        let e = PlanarGenerator::take_over(settings, 0.0, &moving, &room).unwrap_err();
        assert_eq!(e, Error::NoHandoverStop { longest: 8.0 });
        assert_eq!(
            e.to_string(),
            "no hand-over stop of at most 8 s keeps the drives within the headroom left beside the operator"
        );
    }
}
