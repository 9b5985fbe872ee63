#![allow(clippy::unwrap_used, clippy::indexing_slicing)]
use super::*;
use crate::rope::InclinometerLag;
use crate::zero;

fn at_rest(x: f64, l: f64) -> Reference {
    Reference {
        x,
        l,
        ..Reference::default()
    }
}

#[test]
fn zero_when_measurement_equals_reference() {
    // A reference a pendulum can follow (a free swing of 0.3° under a trolley at
    // constant speed, the rope shortening slowly), the feedback started on it in
    // the middle of its motion: the zero's estimate, started on the reference's
    // motion, sees no offset beyond its dead band. (The paper's move:
    // host-tests/tests/feedback.rs.)
    let mut fb = StateFeedback::new(Config::PAPER).unwrap();
    let mut last = [0.1, -0.05];
    let mut prev: Option<Reference> = None;
    let w = libm::sqrt(9.81 / 6.0);
    for k in 0..600 {
        let t = f64::from(k) * 0.01;
        let r = Reference {
            x: 12.0 + 0.1 * t,
            l: 6.0 - 0.05 * t,
            phi: 0.005 * libm::sin(w * t + 1.0),
            vx: 0.1,
            vl: -0.05,
            vphi: 0.005 * w * libm::cos(w * t + 1.0),
        };
        let ud = [0.1, -0.05];
        let m = prev.map(|p| Measurement {
            x: p.x,
            l: p.l,
            phi: Some(p.phi),
        });
        let out = fb.cycle(&r, ud, m, last, &DriveLimits::LAB);
        if k < 5 {
            eprintln!(
                "{k} off {:.4} corr {:?}",
                out.offset.to_degrees(),
                out.correction
            );
        }
        assert_eq!(out.correction, [0.0, 0.0]);
        assert_eq!(out.mode, Mode::Closed);
        last = out.u;
        prev = Some(r);
    }
}

#[test]
fn degraded_rule_table() {
    let c = Config::PAPER;
    let n = c.max_bad_angle_cycles;
    use AngleCheck::*;
    use Mode::*;
    assert_eq!(degraded_rule(&c, Closed, Good, 0, true), Closed);
    assert_eq!(degraded_rule(&c, Closed, Missing, n, true), Closed);
    assert_eq!(
        degraded_rule(&c, Closed, Missing, n + 1, true),
        SwingEstimated(Degraded::AngleLost)
    );
    assert_eq!(
        degraded_rule(&c, Closed, Implausible, n + 1, true),
        SwingEstimated(Degraded::AngleImplausible)
    );
    assert_eq!(
        degraded_rule(&c, Closed, Frozen, 1, true),
        SwingEstimated(Degraded::AngleFrozen)
    );
    // A reading held back as a step not yet confirmed is bridged and never counts.
    assert_eq!(degraded_rule(&c, Closed, HeldBack, n + 1, true), Closed);
    assert_eq!(
        degraded_rule(&c, Closed, Offset, 1, true),
        SwingEstimated(Degraded::AngleOffset)
    );
    // The reason bytes of EMCY 0xFF20 (docs/COMMANDS.md, can/crane.dbc).
    assert_eq!(
        [
            Degraded::AngleLost,
            Degraded::AngleImplausible,
            Degraded::PositionsInvalid,
            Degraded::AngleFrozen,
            Degraded::AngleOffset
        ]
        .map(Degraded::code),
        [1, 2, 3, 4, 5]
    );
    assert_eq!(
        degraded_rule(&c, Closed, Good, 0, false),
        FeedforwardOnly(Degraded::PositionsInvalid)
    );
    // Latched; positions lost while estimating end in feedforward only.
    let estimated = SwingEstimated(Degraded::AngleLost);
    assert_eq!(degraded_rule(&c, estimated, Good, 0, true), estimated);
    assert_eq!(
        degraded_rule(&c, estimated, Missing, 9, false),
        FeedforwardOnly(Degraded::PositionsInvalid)
    );
    let off = FeedforwardOnly(Degraded::PositionsInvalid);
    assert_eq!(degraded_rule(&c, off, Good, 0, true), off);
    assert_eq!(check_angle(&c, None, 0.0), Missing);
    assert_eq!(check_angle(&c, Some(f64::NAN), 0.0), Implausible);
    assert_eq!(check_angle(&c, Some(0.5), 0.5), Implausible);
    assert_eq!(check_angle(&c, Some(0.1), 0.0), Implausible);
    assert_eq!(check_angle(&c, Some(0.01), 0.0), Good);
}

#[test]
fn a_lost_angle_then_lost_positions_end_in_feedforward_only() {
    let mut fb = StateFeedback::new(Config::PAPER).unwrap();
    let r = at_rest(15.0, 5.0);
    let mut last = [0.0; 2];
    for k in 0..10 {
        let m = Measurement {
            x: 15.01,
            l: 5.0,
            phi: if k < 3 { Some(0.0) } else { None },
        };
        let out = fb.cycle(&r, [0.0; 2], Some(m), last, &DriveLimits::LAB);
        last = out.u;
        if k >= 3 + 4 {
            assert_eq!(out.mode, Mode::SwingEstimated(Degraded::AngleLost));
            assert!(out.u[0] < 0.0, "still correcting the 10 mm");
        }
    }
    let lost = Measurement {
        x: f64::NAN,
        l: 5.0,
        phi: None,
    };
    let out = fb.cycle(&r, [0.0; 2], Some(lost), last, &DriveLimits::LAB);
    assert_eq!(out.mode, Mode::FeedforwardOnly(Degraded::PositionsInvalid));
    last = out.u;
    // The correction is ramped out within the acceleration limit, then zero.
    for _ in 0..100 {
        let out = fb.cycle(&r, [0.0; 2], None, last, &DriveLimits::LAB);
        assert!((out.u[0] - last[0]).abs() <= 3.0 * 0.01 + 1e-12);
        last = out.u;
    }
    assert_eq!(last, [0.0, 0.0]);
    fb.reset();
    assert_eq!(fb.mode(), Mode::Closed);
}

/// [`StateFeedback::reset`] starts every field as [`StateFeedback::with_gains`]
/// does, the rope's calibration kept (review finding C1 made it field by field).
#[test]
fn a_reset_is_a_new_feedback_that_keeps_the_rope() {
    let mut fb = StateFeedback::new(Config::PAPER).unwrap();
    let mut last = [0.0; 2];
    // Past the rope filters' warm-up on a moving crane (6/ω, 4.3 s at 5 m).
    for k in 0..800 {
        let t = f64::from(k) * 0.01;
        let r = Reference {
            x: 15.0 + 0.2 * t,
            l: 5.0,
            vx: 0.2,
            ..Reference::default()
        };
        let m = Measurement {
            x: r.x + 0.01,
            l: 5.0,
            phi: (k % 50 != 7).then_some(0.01 * libm::sin(1.4 * t)),
        };
        last = fb.cycle(&r, [0.2, 0.0], Some(m), last, &DriveLimits::LAB).u;
    }
    assert!(fb.rope().samples() > 0);
    let rope = fb.rope;
    fb.reset();
    let mut fresh = StateFeedback::with_gains(Config::PAPER, fb.gains);
    assert_ne!(fresh, fb);
    fresh.rope = rope;
    assert_eq!(fresh, fb);
}

/// The linear trolley–swing crane of the model at rest at `(15 m, l)`, started
/// with a swing `phi0` and a trolley error `x0`, under the feedback; the angle read
/// through `read` (cycle, true angle) → reading. Returns per cycle the true state
/// `[x, ẋ, φ, φ̇]` (relative to the rest) and the feedback's output.
fn linear_run(
    l: f64,
    x0: f64,
    phi0: f64,
    cycles: usize,
    read: impl Fn(usize, f64) -> Option<f64>,
) -> Vec<(Vector4<f64>, Output)> {
    linear_run_with(Config::PAPER, l, x0, phi0, cycles, read)
}

/// [`linear_run`] with the feedback configured by `cfg`.
fn linear_run_with(
    cfg: Config,
    l: f64,
    x0: f64,
    phi0: f64,
    cycles: usize,
    read: impl Fn(usize, f64) -> Option<f64>,
) -> Vec<(Vector4<f64>, Output)> {
    let truth = Vector4::new(x0, 0.0, phi0, 0.0);
    let still = |_| (at_rest(15.0, l), [0.0; 2]);
    run_linear_crane(cfg, l, truth, cycles, still, read, |_, _| {})
}

/// The linear trolley–pendulum at rope length `l` from the true state `truth`
/// (`[x, ẋ, φ, φ̇]`, the trolley relative to 15 m) under the feedback configured by
/// `cfg`: each cycle the reference and the model's set points `plan(k)` (the hoist
/// following its reference exactly), the angle read through `read` (cycle, true
/// angle), and `before(k, fb)` run ahead of the cycle. Returns per cycle the true
/// state and the feedback's output.
fn run_linear_crane(
    cfg: Config,
    l: f64,
    mut truth: Vector4<f64>,
    cycles: usize,
    plan: impl Fn(usize) -> (Reference, [f64; 2]),
    read: impl Fn(usize, f64) -> Option<f64>,
    mut before: impl FnMut(usize, &mut StateFeedback),
) -> Vec<(Vector4<f64>, Output)> {
    let mut fb = StateFeedback::new(cfg).unwrap();
    let model = discretise(cfg.g, cfg.tau1, cfg.tau2, l, cfg.h);
    let mut sample: Option<Measurement> = None;
    let mut last = [0.0; 2];
    let mut out = Vec::new();
    for k in 0..cycles {
        let (r, u_d) = plan(k);
        before(k, &mut fb);
        let o = fb.cycle(&r, u_d, sample, last, &DriveLimits::LAB);
        sample = Some(Measurement {
            x: 15.0 + truth.x,
            l: r.l,
            phi: read(k, truth.z),
        });
        truth = model.a * truth + model.b * o.u[0];
        last = o.u;
        out.push((truth, o));
    }
    out
}

fn amplitude(s: &Vector4<f64>, l: f64) -> f64 {
    libm::sqrt(s.z * s.z + s.w * s.w * l / 9.81)
}

#[test]
fn a_load_already_swinging_keeps_the_feedback_and_is_damped() {
    // 5° of swing when the feedback starts: the observer starts from the measured
    // angle, so the swing is no innovation, and the feedback damps it.
    let l = 6.0;
    let period = 2.0 * core::f64::consts::PI * libm::sqrt(l / 9.81);
    let two_periods = (2.0 * period / 0.01) as usize;
    let run = linear_run(l, 0.0, 5f64.to_radians(), two_periods + 1, |_, p| Some(p));
    assert!(run.iter().all(|(_, o)| o.mode == Mode::Closed));
    let (end, _) = run.last().unwrap();
    assert!(
        amplitude(end, l) < 0.1 * 5f64.to_radians(),
        "swing after two periods {:.3}°",
        amplitude(end, l).to_degrees()
    );
}

/// A sensor 0–5 cycles late behind a 20 ms filter, commissioned: the observer's
/// sensor states ([`SensorStates`]) read it as the sensor reports the load, so the
/// swing is damped as with a fresh reading.
#[test]
fn a_late_filtered_reading_as_commissioned_is_damped_as_a_fresh_one() {
    let l = 6.0;
    let period = 2.0 * core::f64::consts::PI * libm::sqrt(l / 9.81);
    let cycles = (2.0 * period / 0.01) as usize + 1;
    let fresh = linear_run(l, 0.0, 3f64.to_radians(), cycles, |_, p| Some(p));
    let fresh = amplitude(&fresh.last().unwrap().0, l);
    for delay in [0u8, 1, 3, 5] {
        let lag = InclinometerLag {
            delay,
            filter: 0.02,
        };
        let (a, b0, b1) = crate::rope::first_order_hold(lag.filter, 0.01);
        // The sensor: the filter on the true angle, then the delay line.
        let sensor = core::cell::RefCell::new((None::<(f64, f64)>, [0.0; 6]));
        let read = |_, p: f64| {
            let mut s = sensor.borrow_mut();
            let y = match s.0 {
                None => p,
                Some((y, before)) => a * y + b0 * p + b1 * before,
            };
            if s.0.is_none() {
                s.1 = [p; 6];
            }
            s.0 = Some((y, p));
            s.1.rotate_right(1);
            s.1[0] = y;
            Some(s.1[usize::from(delay)])
        };
        let cfg = Config {
            inclinometer: lag,
            ..Config::PAPER
        };
        let run = linear_run_with(cfg, l, 0.0, 3f64.to_radians(), cycles, read);
        assert!(run.iter().all(|(_, o)| o.mode == Mode::Closed));
        let left = amplitude(&run.last().unwrap().0, l);
        assert!(
            left < 0.1 * 3f64.to_radians() && left < 2.0 * fresh + 1e-4,
            "{delay} cycles: {:.4}° left after two periods, {:.4}° with a fresh reading",
            left.to_degrees(),
            fresh.to_degrees()
        );
    }
}

#[test]
fn a_stuck_angle_is_caught_at_rest_before_it_moves_the_trolley() {
    // The load swings 6° after a gust; the reading sticks at 2.2 s (after the
    // zero's estimate has settled, crate::zero), the load still swinging 2.5°. What
    // the trolley's own motion makes the angle do betrays it within a few cycles,
    // and meanwhile the unchanged reading may not push harder than before. (At
    // 3 s, where this test stuck it before the rest's gains, the swing is down to
    // 0.5° and the feedback holds the load within 0.1° of the stuck reading for
    // 2.5 s: a reading that right is not caught, and does no harm.)
    let l = 6.0;
    let stuck_at = 220;
    let stuck = core::cell::Cell::new(None);
    let run = linear_run(l, 0.0, 6f64.to_radians(), 1200, |k, p| {
        if k == stuck_at {
            stuck.set(Some(p));
        }
        if k >= stuck_at {
            stuck.get()
        } else {
            Some(p)
        }
    });
    let caught = run
        .iter()
        .position(|(_, o)| o.mode == Mode::SwingEstimated(Degraded::AngleFrozen))
        .unwrap();
    assert!(
        caught < stuck_at + 15,
        "caught {} cycles after",
        caught - stuck_at
    );
    // Before it was caught, no correction grew beyond its value at the last change
    // plus the allowance.
    let base = run[stuck_at].1.correction[0].abs();
    for (_, o) in &run[stuck_at + 2..caught] {
        assert!(o.correction[0].abs() <= base + Config::PAPER.held_allowance + 1e-12);
    }
    // From then on the swing is estimated from the trolley's motion: it is damped
    // as with the angle, and the crane is let go at rest on its target.
    let (end, last) = run.last().unwrap();
    let at_stuck = amplitude(&run[stuck_at].0, l);
    assert!(
        amplitude(end, l) < 0.1 * at_stuck,
        "swing {:.3}° at the end, {:.3}° when the reading stuck",
        amplitude(end, l).to_degrees(),
        at_stuck.to_degrees()
    );
    let load = end.x + l * end.z;
    assert!(load.abs() < 0.01, "load {:.1} mm off", load * 1e3);
    assert!(last.resting && last.u == [0.0; 2]);
}

#[test]
fn a_reading_stuck_since_the_start_is_no_swing_to_damp() {
    // The load hangs still, the inclinometer reads a stuck 1.5° from the first
    // sample (after a restart the observer starts from it). A still load under a
    // still trolley cannot tell a stuck reading from an offset one: it is an offset
    // (a pendulum holds no 1.5° without a force), never taken for a swing, and
    // announced once the crane is at rest; the feedback must not "damp" a swing it
    // only ever assumed.
    let l = 6.0;
    let stuck = 1.5f64.to_radians();
    let run = linear_run(l, 0.0, 0.0, 1500, |_, _| Some(stuck));
    let (end, last) = run.last().unwrap();
    assert_eq!(last.mode, Mode::SwingEstimated(Degraded::AngleOffset));
    let moved = run.iter().map(|(t, _)| t.x.abs()).fold(0.0, f64::max);
    assert!(moved < 0.015, "the trolley moved {:.1} mm", moved * 1e3);
    assert!(
        amplitude(end, l) < 0.1f64.to_radians(),
        "swing {:.3}°",
        amplitude(end, l).to_degrees()
    );
    assert_eq!(last.u, [0.0; 2]);
}

#[test]
fn a_steady_offset_from_power_up_is_no_swing_and_is_announced_at_rest() {
    // The inclinometer reads 5° more than the angle from the first sample; the
    // load swings 2° and the trolley is 30 mm off. The offset is taken for neither
    // a swing nor a displaced load (read as one, the feedback drove the trolley
    // about `0.7 l b`, 370 mm, off): the crane moves as with a true reading, and
    // once it rests the offset is announced and the angle no longer read.
    let l = 6.0;
    let b = 5f64.to_radians();
    let run = linear_run(l, 0.03, 2f64.to_radians(), 2000, |_, p| Some(p + b));
    let healthy = linear_run(l, 0.03, 2f64.to_radians(), 2000, |_, p| Some(p));
    let apart = run
        .iter()
        .zip(&healthy)
        .map(|((t, _), (h, _))| (t.x - h.x).abs())
        .fold(0.0, f64::max);
    // The trolley goes where it goes with a true reading (damping the swing moves
    // it by 127 mm), within a few millimetres.
    assert!(
        apart < 0.005,
        "{:.1} mm from the true reading's",
        apart * 1e3
    );
    let (end, last) = run.last().unwrap();
    assert!(
        amplitude(end, l) < 0.1f64.to_radians(),
        "swing {:.3}°",
        amplitude(end, l).to_degrees()
    );
    let load = end.x + l * end.z;
    assert!(load.abs() < 0.02, "load {:.1} mm off", load * 1e3);
    assert!((last.offset - b).abs() < 0.1f64.to_radians());
    assert_eq!(last.mode, Mode::SwingEstimated(Degraded::AngleOffset));
    assert!(last.resting && last.u == [0.0; 2]);
    // Announced only at rest, the crane let go: the swing was damped on the angle.
    let announced = run
        .iter()
        .position(|(_, o)| o.mode != Mode::Closed)
        .unwrap();
    assert!(run[announced - 1].1.resting);
}

#[test]
fn a_step_of_the_zero_at_rest_is_taken_out_and_announced() {
    // The crane rests on its target, let go; at 10 s the reading steps by 1.5° (a
    // knock on the sensor). No pendulum jumps: the step is the zero's, so the
    // trolley is not moved (read as a swing, it drove the trolley 50–90 mm off) and
    // the set points stay zero; 5 s later the offset is announced.
    let l = 5.0;
    let step_at = 1000;
    let b = 1.5f64.to_radians();
    let run = linear_run(l, 0.04, 0.5f64.to_radians(), 1800, |k, p| {
        Some(if k >= step_at { p + b } else { p })
    });
    assert!(run[step_at - 1].1.resting, "let go before the step");
    let x0 = run[step_at].0.x;
    for (k, (t, o)) in run.iter().enumerate().skip(step_at) {
        assert!((t.x - x0).abs() < 1e-3, "cycle {k}: trolley moved");
        assert!(o.resting && o.u == [0.0; 2], "cycle {k}: {o:?}");
    }
    let announced = run
        .iter()
        .position(|(_, o)| o.mode == Mode::SwingEstimated(Degraded::AngleOffset))
        .unwrap();
    let after = announced - step_at;
    assert!(
        (zero::OFFSET_CYCLES as usize..zero::OFFSET_CYCLES as usize + 10).contains(&after),
        "announced {after} cycles after the step"
    );
    let last = run.last().unwrap().1;
    assert!((last.offset - b).abs() < 0.05f64.to_radians());
}

#[test]
fn a_knock_among_lost_frames_is_a_step_and_keeps_the_loop_closed() {
    // Two frames lost, the knock (1.5°), one more lost, the knock confirmed: 3
    // missing readings, bridged. The two held back as a step not yet confirmed are
    // not counted (counted, the fourth bad cycle left the angle unread for good).
    let l = 5.0;
    let b = 1.5f64.to_radians();
    let read = |k: usize, p: f64| match k {
        998 | 999 | 1001 => None,
        k if k >= 1000 => Some(p + b),
        _ => Some(p),
    };
    let run = linear_run(l, 0.04, 0.5f64.to_radians(), 1400, read);
    assert!(run[997].1.resting, "let go before the knock");
    let x0 = run[997].0.x;
    for (k, (t, o)) in run.iter().enumerate().skip(990) {
        assert_eq!(o.mode, Mode::Closed, "cycle {k}");
        assert!((t.x - x0).abs() < 1e-3, "cycle {k}: the trolley moved");
    }
    let last = run.last().unwrap().1;
    assert!(
        (last.offset - b).abs() < 0.05f64.to_radians(),
        "offset {:.3}°",
        last.offset.to_degrees()
    );
}

#[test]
fn a_noise_outlier_is_no_step_of_the_zero() {
    // Issue 33 (interop `delay-2-filter-10ms`): one reading 0.27° off the
    // prediction (a 5 σ outlier of a 0.05° noise), the next 0.03° off the same way,
    // while the load swings 1°. Taken for a step at once — and not stepped back, the
    // next miss being 0.24°, inside the threshold — it stayed as a 0.27° offset: the
    // feedback held the load where the reading less the offset put it, the trolley
    // 22 mm off, never let go (with STEP_CYCLES = 1 this test fails so). A step
    // must persist (zero::STEP_CYCLES).
    let l = 5.0;
    let spike = 0.27f64.to_radians();
    let back = 0.03f64.to_radians();
    let read = |k: usize, p: f64| {
        Some(match k {
            600 => p + spike,
            601 => p + back,
            _ => p,
        })
    };
    let run = linear_run(l, 0.04, 1f64.to_radians(), 2500, read);
    let (end, last) = run.last().unwrap();
    assert_eq!(last.mode, Mode::Closed);
    assert!(
        end.x.abs() < 0.005,
        "the trolley held {:.1} mm off",
        end.x * 1e3
    );
    assert!(last.resting && last.u == [0.0; 2], "{last:?}");
}

#[test]
fn a_lost_angle_mid_swing_is_estimated_from_the_trolley_and_damped() {
    // The load swings 3°; the inclinometer falls silent after 2 s, before the
    // feedback has damped the swing, but after the load's motion has confirmed it
    // as a swing (the zero's estimate shows 0.02° of offset left). Cutting the
    // correction would leave the swing; the model's swing under the trolley's
    // measured motion goes on damping it.
    let l = 6.0;
    let lost_at = 200;
    let run = linear_run(l, 0.0, 3f64.to_radians(), 1500, |k, p| {
        (k < lost_at).then_some(p)
    });
    let degraded_at = run
        .iter()
        .position(|(_, o)| o.mode == Mode::SwingEstimated(Degraded::AngleLost))
        .unwrap();
    assert!(degraded_at <= lost_at + 2 + Config::PAPER.max_bad_angle_cycles as usize);
    let (end, last) = run.last().unwrap();
    let at_loss = amplitude(&run[lost_at].0, l);
    assert!(at_loss > 1f64.to_radians(), "still swinging when lost");
    assert!(
        amplitude(end, l) < 0.05 * at_loss,
        "swing {:.3}° at the end, {:.3}° when lost",
        amplitude(end, l).to_degrees(),
        at_loss.to_degrees()
    );
    assert!(last.resting && last.u == [0.0; 2]);
}

#[test]
fn a_swing_not_yet_confirmed_when_the_angle_is_lost_is_not_acted_on() {
    // The same load, the inclinometer silent after 0.3 s: the zero's estimate
    // still shows 2.8° of the 3° reading as a possible offset (a swing and a biased
    // sensor look alike until the load's motion tells them apart, crate::zero), and
    // the feedback had acted on the rest only. It goes on from that estimate: a
    // biased sensor lost early must not make the trolley "damp" its offset into a
    // real swing, so the unconfirmed part is left as feedforward alone leaves it —
    // never made worse. (Before, a lost angle went on from the raw reading and a
    // stuck one from this estimate: a gust's push read as offset before trust put
    // the two more than 0.25° or 50 mm apart in 35 of 1000 mid-move cases,
    // issue 18.)
    let l = 6.0;
    let lost_at = 30;
    let run = linear_run(l, 0.0, 3f64.to_radians(), 1500, |k, p| {
        (k < lost_at).then_some(p)
    });
    let (end, last) = run.last().unwrap();
    let at_loss = amplitude(&run[lost_at].0, l);
    assert!(
        amplitude(end, l) <= at_loss,
        "swing {:.3}° at the end, {:.3}° when lost",
        amplitude(end, l).to_degrees(),
        at_loss.to_degrees()
    );
    assert_eq!(last.mode, Mode::SwingEstimated(Degraded::AngleLost));
    assert!(last.resting && last.u == [0.0; 2]);
}

#[test]
fn a_quiet_reading_of_a_quiet_crane_is_no_stuck_sensor() {
    // At rest on the target, nothing moves: the same reading for ever is right.
    let run = linear_run(6.0, 0.0, 0.0, 500, |_, _| Some(0.0));
    assert!(run.iter().all(|(_, o)| o.mode == Mode::Closed));
}

#[test]
fn at_rest_on_the_target_the_set_points_are_exactly_zero_until_disturbed() {
    // 40 mm off and 0.5° of swing: the feedback brings the load in, then lets go —
    // the set points exactly zero — and takes hold again when a push swings it.
    let l = 5.0;
    let cfg = Config::PAPER;
    let mut fb = StateFeedback::new(cfg).unwrap();
    let model = discretise(cfg.g, cfg.tau1, cfg.tau2, l, cfg.h);
    let r = at_rest(15.0, l);
    let mut truth = Vector4::new(0.04, 0.0, 0.5f64.to_radians(), 0.0);
    let mut sample = None;
    let mut last = [0.0; 2];
    let mut resting_since = None;
    for k in 0..2000 {
        if k == 1500 {
            truth.w += 0.01; // a push: 0.57°/s of swing rate
        }
        let o = fb.cycle(&r, [0.0; 2], sample, last, &DriveLimits::LAB);
        sample = Some(Measurement {
            x: 15.0 + truth.x,
            l,
            phi: Some(truth.z),
        });
        truth = model.a * truth + model.b * o.u[0];
        last = o.u;
        match (o.resting, resting_since) {
            (true, None) if k < 1500 => resting_since = Some(k),
            (false, Some(_)) if k < 1500 => {
                unreachable!("let go at {resting_since:?}, held again at {k}")
            }
            _ => {}
        }
        if let Some(since) = resting_since {
            if k > since + 5 && k < 1500 {
                assert_eq!(o.u, [0.0, 0.0], "cycle {k}");
            }
        }
        if k == 1499 {
            assert!((truth.x + l * truth.z).abs() < 0.05);
            assert!(amplitude(&truth, l) < 0.1f64.to_radians());
        }
        if k == 1600 {
            // Within a second (a quarter period is 1.1 s): a crane let go is held
            // again on its swing averaged over about a period, so that the
            // estimate's noise does not make it chatter.
            assert!(!o.resting, "the push is answered");
        }
    }
    assert!(resting_since.is_some_and(|k| k < 1400), "{resting_since:?}");
}

#[test]
fn against_coulomb_friction_the_crane_is_let_go_for_good_with_less_than_0_1_deg() {
    // The linear crane whose trolley moves `c` slower than asked and not at all
    // below `c` (a Coulomb droop of 5 or 10 mm/s, the study's range), 30 mm off and
    // swinging 0.5–3° at 4–8 m: the feedback cannot damp the last hundredths of a
    // degree smoothly. The old rest hold (the largest angle over the last half
    // period) let go up to 8.5 s in, and in two of these cases let go and took
    // hold again; judged as the swing the load keeps once the trolley stands
    // still, the crane is let go within 8 s, for good, with less than 0.1° left.
    let cfg = Config::PAPER;
    for l in [4.0, 6.0, 8.0] {
        let model = discretise(cfg.g, cfg.tau1, cfg.tau2, l, cfg.h);
        let r = at_rest(15.0, l);
        for c in [0.005, 0.01] {
            for swing in [0.5f64, 1.5, 3.0] {
                let mut fb = StateFeedback::new(cfg).unwrap();
                let mut truth = Vector4::new(0.03, 0.0, swing.to_radians(), 0.0);
                let mut sample = None;
                let mut last = [0.0; 2];
                let mut let_go = None;
                for k in 0..1500 {
                    let o = fb.cycle(&r, [0.0; 2], sample, last, &DriveLimits::LAB);
                    sample = Some(Measurement {
                        x: 15.0 + truth.x,
                        l,
                        phi: Some(truth.z),
                    });
                    let moved = o.u[0].signum() * (o.u[0].abs() - c).max(0.0);
                    truth = model.a * truth + model.b * moved;
                    last = o.u;
                    match (o.resting, let_go) {
                        (true, None) => let_go = Some(k),
                        (false, Some(at)) => {
                            unreachable!("{l} m, {c} m/s, {swing}°: let go at {at}, held at {k}")
                        }
                        _ => {}
                    }
                }
                let at = let_go.unwrap();
                let left = amplitude(&truth, l).to_degrees();
                assert!(at < 800, "{l} m, {c} m/s, {swing}°: let go at cycle {at}");
                assert!(left < 0.1, "{l} m, {c} m/s, {swing}°: {left:.3}° left");
                assert_eq!(last, [0.0; 2]);
            }
        }
    }
}

/// Cycles for a correction acting on the young estimate's noise (a few hundredths
/// of a m/s) to be ramped out within the lab trolley's acceleration limit.
const RAMP_OUT: usize = 3;

/// A reading's noise of ±0.02°, deterministic.
fn noise(k: usize) -> f64 {
    let r = (k.wrapping_mul(7919) % 13) as f64 - 6.0;
    (0.02 * r / 6.0).to_radians()
}

/// [`run_linear_crane`] with the paper's feedback, the trolley `x0` off and the
/// load hanging still, the reading the true angle plus [`noise`].
fn crane_under_feedback(
    l: f64,
    x0: f64,
    cycles: usize,
    plan: impl Fn(usize) -> (Reference, [f64; 2]),
    before: impl FnMut(usize, &mut StateFeedback),
) -> Vec<(Vector4<f64>, Output)> {
    let truth = Vector4::new(x0, 0.0, 0.0, 0.0);
    let read = |k, phi| Some(phi + noise(k));
    run_linear_crane(Config::PAPER, l, truth, cycles, plan, read, before)
}

/// At rest at 15 m and `l`, the hoist raising at 0.2 m/s from cycle `from` on.
fn hoist_from(l: f64, from: usize) -> impl Fn(usize) -> (Reference, [f64; 2]) {
    move |k| {
        let v = if k >= from { -0.2 } else { 0.0 };
        let raised = 0.2 * 0.01 * (k.saturating_sub(from) as f64);
        let r = Reference {
            x: 15.0,
            l: l - raised,
            vl: v,
            ..Reference::default()
        };
        (r, [0.0, v])
    }
}

#[test]
fn before_the_trust_a_hoist_starting_alone_lets_the_trolley_go() {
    // The loop closed at rest, the angle not yet trusted, the estimate acting on
    // the reading's noise: when the hoist starts alone, the trolley is let go —
    // its set point the model's, exactly — and stays so while only the hoist moves.
    let from = 100;
    let run = crane_under_feedback(5.0, 0.0, 300, hoist_from(5.0, from), |_, _| {});
    assert!(!run[from].1.trusted, "the hoist starts before the trust");
    assert!(
        run[..from].iter().any(|(_, o)| o.u[0] != 0.0),
        "before the hoist starts the trolley acts on the young estimate"
    );
    for (k, (_, o)) in run.iter().enumerate().skip(from + RAMP_OUT) {
        assert_eq!(o.u[0], 0.0, "cycle {k}");
        assert!(o.u[1] < 0.0, "cycle {k}: the hoist raises");
    }
}

#[test]
fn before_the_trust_a_hoist_starting_alone_holds_a_trolley_off_its_place() {
    // The same, the trolley 100 mm off (three times the hold threshold, 33 mm): it is
    // brought in while the hoist moves, not let go.
    let (hold_position, _) = Config::PAPER.hold_thresholds();
    assert!(0.1 > 3.0 * hold_position);
    let from = 100;
    let run = crane_under_feedback(5.0, 0.1, 300, hoist_from(5.0, from), |_, _| {});
    assert!(!run[from].1.trusted);
    assert!(run[from + RAMP_OUT..from + 50]
        .iter()
        .all(|(_, o)| o.u[0] < 0.0));
    let (truth, _) = run[299];
    assert!(truth.x < 0.05, "brought in: {:.3} m off", truth.x);
}

#[test]
fn a_hoist_still_moving_as_the_travel_stops_is_no_hoist_starting_alone() {
    // A combined move's tail: the trolley crept 1 mm in 0.1 s while the hoist
    // raised, then the travel stopped and the hoist went on. That is no hoist
    // starting alone: before the trust the young estimate may not yet show the
    // swing the move left, so the trolley goes on acting, not let go. (Judged as a
    // start, `hoist_moving` false from the travel's stop, it was let go at once.)
    const CREEP: f64 = 0.01;
    let l = 5.0;
    let hoist = hoist_from(l, 40);
    let plan = move |k: usize| {
        let (mut r, mut u_d) = hoist(k);
        let v = if (50..60).contains(&k) { CREEP } else { 0.0 };
        r.x += CREEP * 0.01 * (k.clamp(50, 60) - 50) as f64;
        r.vx = v;
        u_d[0] = v;
        (r, u_d)
    };
    let run = crane_under_feedback(l, 0.0, 200, plan, |_, _| {});
    assert!(!run[60].1.trusted);
    let acting = run[60 + RAMP_OUT..200]
        .iter()
        .filter(|(_, o)| o.u[0] != 0.0)
        .count();
    assert!(acting > 100, "the trolley acted in {acting} of 137 cycles");
}

#[test]
fn a_loop_closed_at_rest_lets_the_trolley_go_unless_the_estimate_holds_it() {
    // Manual mode's first demand at rest may move the hoist alone: the controller
    // closes the loop with `let_go_at_rest`. Before the trust, on the reading's
    // noise alone, the trolley is let go at once; off its place it is held.
    let at = 50;
    let still = |_| (at_rest(15.0, 5.0), [0.0; 2]);
    let closing = |k, fb: &mut StateFeedback| {
        if k == at {
            fb.let_go_at_rest();
        }
    };
    let run = crane_under_feedback(5.0, 0.0, 150, still, closing);
    assert!(!run[at].1.trusted);
    assert!(run[..at].iter().any(|(_, o)| o.u[0] != 0.0));
    for (k, (_, o)) in run.iter().enumerate().skip(at + RAMP_OUT) {
        assert_eq!(o.u[0], 0.0, "cycle {k}");
    }
    // Started 100 mm off, the feedback has brought the trolley half way in by the
    // demand, swinging the load 0.5°: the estimate holds both, and so does the
    // trolley.
    let run = crane_under_feedback(5.0, 0.1, 150, still, closing);
    let (truth, _) = run[at];
    // Beyond the hold thresholds (33 mm and 0.099°), the swing three times beyond,
    // so the hold is not decided at its edge.
    let (hold_position, hold_swing) = Config::PAPER.hold_thresholds();
    assert!(
        truth.x > hold_position && truth.z > 3.0 * hold_swing,
        "{truth:?}"
    );
    for (k, (_, o)) in run.iter().enumerate().skip(at) {
        assert_ne!(o.u[0], 0.0, "cycle {k}");
    }
}

#[test]
fn clamp_respects_both_limits() {
    let lim = AxisLimits {
        max_velocity: 3.0,
        max_acceleration: 3.0,
    };
    assert!((clamp_to_limits(10.0, 2.99, lim, 0.01) - (3.0 - 2e-6)).abs() < 1e-12);
    assert!((clamp_to_limits(1.0, 0.0, lim, 0.01) - (0.03 - 2e-6)).abs() < 1e-12);
    assert_eq!(clamp_to_limits(f64::NAN, 0.5, lim, 0.01), 0.5);
    assert_eq!(clamp_to_limits(0.01, 0.0, lim, 0.01), 0.01);
}
