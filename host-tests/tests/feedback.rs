//! The state feedback of Fig. 1 (`controller::feedback`) on the plant of
//! `host_tests::plant`: stability of the scheduled linear closed loop over the rope
//! range and the mismatch range, the Monte Carlo targets on a fixed-seed subset, the
//! gust at rest, anti-windup, and zero correction on a perfect measurement.

use controller::drive::Drive;
use controller::feedback::{discretise, Config, Degraded, Gains, Measurement, Mode, StateFeedback};
use controller::setpoint::{DriveLimits, SetpointGate};
use host_tests::feedback_study::{fault_study, gust_at_rest, monte_carlo, paper_reference, FAULTS};
use nalgebra::SMatrix;
use solver_core::models::crane::CraneParams;

fn rho13(m: &SMatrix<f64, 13, 13>) -> f64 {
    m.complex_eigenvalues()
        .iter()
        .map(|z| z.re.hypot(z.im))
        .fold(0.0, f64::max)
}

fn rho6(m: &SMatrix<f64, 6, 6>) -> f64 {
    m.complex_eigenvalues()
        .iter()
        .map(|z| z.re.hypot(z.im))
        .fold(0.0, f64::max)
}

/// The sampled closed loop with the one-cycle-late measurement and the predictor
/// observer, state `[p_k, p_{k−1}, ê_{k−1|k−2}]`, for a plant whose lags and pendulum
/// length differ from the model's; the gains are those scheduled at the reference `l`,
/// the move's and the rest's (`GainPoint::k_rest`). The trolley's observer has a fifth
/// state, the drive's velocity offset, which enters as the set point does and is not
/// fed back.
#[test]
fn scheduled_closed_loop_is_stable_over_rope_and_mismatch_range() {
    let cfg = Config::PAPER;
    let gains = Gains::design(&cfg).unwrap();
    let mut worst: f64 = 0.0;
    let c4 = SMatrix::<f64, 2, 4>::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0);
    let c5 = SMatrix::<f64, 2, 5>::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0);
    let c2 = SMatrix::<f64, 1, 2>::new(1.0, 0.0);
    for i in 0..=24 {
        let l = 3.0 + 0.25 * f64::from(i);
        let gp = gains.at(l);
        for d1 in [-0.3, 0.0, 0.3] {
            for d2 in [-0.3, 0.0, 0.3] {
                for rope in [-0.02, 0.0, 0.02] {
                    let p = discretise(
                        cfg.g,
                        cfg.tau1 * (1.0 + d1),
                        cfg.tau2 * (1.0 + d2),
                        l * (1.0 + rope),
                        cfg.h,
                    );
                    // The observer's model: the drive's offset enters as the set point.
                    let ma = SMatrix::<f64, 5, 5>::from_fn(|i, j| match (i, j) {
                        (4, 4) => 1.0,
                        (i, 4) => gp.model.b[i],
                        (i, j) if i < 4 && j < 4 => gp.model.a[(i, j)],
                        _ => 0.0,
                    });
                    let mb = SMatrix::<f64, 5, 1>::from_fn(
                        |i, _| if i < 4 { gp.model.b[i] } else { 0.0 },
                    );
                    for (gains, k) in [("moving", &gp.k), ("at rest", &gp.k_rest)] {
                        let k5 =
                            SMatrix::<f64, 1, 5>::from_fn(|_, j| if j < 4 { k[j] } else { 0.0 });
                        let m: SMatrix<f64, 13, 13> =
                            closed_loop_observed(&p.a, &p.b, &ma, &mb, &k5, &gp.obs, &c4, &c5);
                        let r = rho13(&m);
                        assert!(
                            r < 0.9995,
                            "trolley loop unstable ({gains}): l = {l}, τ1 {d1:+}, rope {rope:+}: ρ = {r}"
                        );
                        worst = worst.max(r);
                    }
                    let m: SMatrix<f64, 6, 6> = closed_loop(
                        &p.aw,
                        &p.bw,
                        &gp.model.aw,
                        &gp.model.bw,
                        &gp.kw,
                        &gp.obs_w,
                        &c2,
                    );
                    let r = rho6(&m);
                    assert!(
                        r < 0.9995,
                        "winch loop unstable: l = {l}, τ2 {d2:+}: ρ = {r}"
                    );
                }
            }
        }
    }
    println!("largest closed-loop eigenvalue modulus over the grid: {worst:.5}");
}

/// [`closed_loop`] with an observer of `O` states, `R = 2N + O`: the plant measured
/// through `c`, the observer's model through `co`.
#[allow(clippy::too_many_arguments)]
fn closed_loop_observed<const N: usize, const O: usize, const M: usize, const R: usize>(
    pa: &SMatrix<f64, N, N>,
    pb: &SMatrix<f64, N, 1>,
    ma: &SMatrix<f64, O, O>,
    mb: &SMatrix<f64, O, 1>,
    k: &SMatrix<f64, 1, O>,
    obs: &SMatrix<f64, O, M>,
    c: &SMatrix<f64, M, N>,
    co: &SMatrix<f64, M, O>,
) -> SMatrix<f64, R, R> {
    assert_eq!(R, 2 * N + O);
    let id = SMatrix::<f64, O, O>::identity();
    // ê_{k|k−1} = ma (I − L co) ê_{k−1|k−2} + ma L c p_{k−1} − mb K ê_{k−1|k−2}
    let e_e = ma * (id - obs * co) - mb * k;
    let e_p1 = ma * obs * c;
    // δu_k = −K ê_{k|k−1};  p_{k+1} = pa p_k + pb δu_k
    let p_p1 = -(pb * k * e_p1);
    let p_e = -(pb * k * e_e);
    SMatrix::from_fn(|i, j| {
        let block = |x: usize| {
            if x < N {
                (0, x)
            } else if x < 2 * N {
                (1, x - N)
            } else {
                (2, x - 2 * N)
            }
        };
        let ((bi, ii), (bj, jj)) = (block(i), block(j));
        match (bi, bj) {
            (0, 0) => pa[(ii, jj)],
            (0, 1) => p_p1[(ii, jj)],
            (0, 2) => p_e[(ii, jj)],
            (1, 0) if ii == jj => 1.0,
            (2, 1) => e_p1[(ii, jj)],
            (2, 2) => e_e[(ii, jj)],
            _ => 0.0,
        }
    })
}

/// `z_{k+1} = M z_k` with `z_k = [p_k, p_{k−1}, ê_{k−1|k−2}]` (R = 3N).
fn closed_loop<const N: usize, const M: usize, const R: usize>(
    pa: &SMatrix<f64, N, N>,
    pb: &SMatrix<f64, N, 1>,
    ma: &SMatrix<f64, N, N>,
    mb: &SMatrix<f64, N, 1>,
    k: &SMatrix<f64, 1, N>,
    obs: &SMatrix<f64, N, M>,
    c: &SMatrix<f64, M, N>,
) -> SMatrix<f64, R, R> {
    assert_eq!(R, 3 * N);
    let id = SMatrix::<f64, N, N>::identity();
    // ê_{k|k−1} = ma (I − L C) ê_{k−1|k−2} + ma L C p_{k−1} + mb δu_{k−1},  δu_{k−1} = −K ê_{k−1|k−2}
    let e_e = ma * (id - obs * c) - mb * k;
    let e_p1 = ma * obs * c;
    // δu_k = −K ê_{k|k−1};  p_{k+1} = pa p_k + pb δu_k
    let p_p1 = -(pb * k * e_p1);
    let p_e = -(pb * k * e_e);
    SMatrix::from_fn(|i, j| {
        let (bi, ii, bj, jj) = (i / N, i % N, j / N, j % N);
        match (bi, bj) {
            (0, 0) => pa[(ii, jj)],
            (0, 1) => p_p1[(ii, jj)],
            (0, 2) => p_e[(ii, jj)],
            (1, 0) => id[(ii, jj)],
            (2, 1) => e_p1[(ii, jj)],
            (2, 2) => e_e[(ii, jj)],
            _ => 0.0,
        }
    })
}

#[test]
fn monte_carlo_targets_hold_on_a_fixed_seed_subset() {
    let gains = Gains::design(&Config::PAPER).unwrap();
    for (seed, random) in [(11, false), (12, true)] {
        let mc = monte_carlo(seed, 25, random, &gains);
        for (case, ff, fb, calibrated) in &mc.cases {
            assert!(
                fb.meets_target(),
                "feedback misses the target: {fb:?} for {case:?} (feedforward only: {ff:?})"
            );
            // The rope calibrated (a commissioning step), in all three directions.
            assert!(
                calibrated.meets_target_in_all_directions(),
                "calibrated: {calibrated:?} for {case:?}"
            );
            assert!(fb.max_u[0] <= 3.0 && fb.max_u[1] <= 2.0);
            assert!(fb.max_du[0] <= 3.0 + 1e-9 && fb.max_du[1] <= 3.0 + 1e-9);
        }
        // Loads already swinging up to 5° at the start are among the cases.
        assert!(mc
            .cases
            .iter()
            .any(|c| c.0.swing0.abs() > 4f64.to_radians()));
        // Feedforward alone does not get there on this plant.
        let ff_ok = mc.cases.iter().filter(|c| c.1.meets_target()).count();
        assert!(
            ff_ok < mc.cases.len() / 2,
            "{ff_ok} feedforward-only cases meet the target"
        );
    }
}

/// A frozen inclinometer is caught by the crane's own motion within a few cycles of a
/// lost one being noticed: on the same case it leaves the load close to where a lost
/// one does (within 50 mm and 0.25°: the few cycles of watching, mid-swing), mid-move
/// and at rest — where the old rule (a frozen value while the reference angle moves by
/// 0.5°) never caught it, and mid-move took 56 cycles. That either leaves the load no worse than
/// feedforward alone is *not* asserted: `feedback_study` shows it does not hold in every
/// case yet (docs/RESULTS.md).
#[test]
fn a_frozen_inclinometer_is_caught_as_soon_as_a_lost_one() {
    let gains = Gains::design(&Config::PAPER).unwrap();
    assert_eq!(FAULTS[0], "frozen mid-move");
    assert_eq!(FAULTS[2], "frozen at rest");
    for f in fault_study(5, 20, &gains) {
        let [frozen_mid, lost_mid, frozen_rest, lost_rest, ..] = f.runs;
        for ((_, frozen), (_, lost)) in [(frozen_mid, lost_mid), (frozen_rest, lost_rest)] {
            assert!(
                frozen.distance <= lost.distance + 0.05
                    && frozen.swing_deg <= lost.swing_deg + 0.25,
                "frozen {frozen:?}, lost {lost:?}, case {:?}",
                f.case
            );
        }
    }
}

#[test]
fn a_failed_inclinometer_leaves_what_it_saw_better_than_feedforward_alone() {
    // After a fall-back the swing is estimated from the trolley's motion: what the
    // sensor saw before it failed goes on being damped. At rest (a gust over before
    // the failure) the load is never worse off than with feedforward alone on the same
    // case; mid-move, where the gust was over when it failed, it is far better in
    // the median. A gust blowing after the failure no sensor sees, and feedforward
    // alone, blind to it as well, is sometimes the luckier of the two; stopped when
    // the sensor fails (what the failure costs on what the sensor saw), the fall-back
    // is worse than feedforward alone only by the positions-only estimate's error over
    // the rest of the move: at most 16.5 mm and 0.197° in the study's 1000 cases
    // (`feedback_study`), asserted within 20 mm and 0.2° here.
    let gains = Gains::design(&Config::PAPER).unwrap();
    let faults = fault_study(11, 40, &gains);
    let mut mid = Vec::new();
    for f in &faults {
        for (ff, fb) in f.calm {
            assert!(
                fb.distance <= ff.distance + 0.02 && fb.swing_deg <= ff.swing_deg + 0.2,
                "the gust stopped at the failure: {fb:?}, feedforward only {ff:?}, case {:?}",
                f.case
            );
        }
        let [frozen_mid, lost_mid, frozen_rest, lost_rest, ..] = f.runs;
        for (name, (ff, fb)) in [("frozen", frozen_rest), ("lost", lost_rest)] {
            assert!(
                !fb.worse_than(&ff),
                "{name} at rest: {fb:?}, feedforward only {ff:?}, case {:?}",
                f.case
            );
        }
        if !f.gust_after_failure() {
            mid.extend([frozen_mid, lost_mid]);
        }
    }
    assert!(
        mid.len() >= 20,
        "{} mid-move cases without a late gust",
        mid.len()
    );
    let mut ratio: Vec<f64> = mid
        .iter()
        .map(|(ff, fb)| fb.distance / ff.distance)
        .collect();
    ratio.sort_by(f64::total_cmp);
    let median = ratio[ratio.len() / 2];
    assert!(
        median < 0.3,
        "median distance with a failed sensor / feedforward: {median:.2}"
    );
}

/// A biased inclinometer (review finding 12): 3–10° of either sign from power-up on
/// the mid-move cases, a step of 1–2° at rest 2.5 s after the move (a gust at rest
/// before it). The offset is never taken for a swing or a displaced load: 5 s after the
/// move the trolley is within the ±50 mm tolerance of its reference, the load within
/// it of the target and no worse off than with feedforward alone on the same case; the
/// offset is announced (EMCY 0xFF20 reason 5: the swing then estimated from the
/// positions) once the crane rests, and no other fall-back is taken. Before the fix the
/// feedback read a steady offset as a swing and a displaced load and drove the trolley
/// 146–485 mm off (50–90 mm for the step at rest).
#[test]
fn a_biased_inclinometer_never_displaces_the_trolley_and_is_announced() {
    let gains = Gains::design(&Config::PAPER).unwrap();
    assert_eq!(
        &FAULTS[4..],
        ["offset from power-up", "offset step at rest"]
    );
    let faults = fault_study(7, 20, &gains);
    let mut announced = 0;
    for f in &faults {
        for (name, (ff, fb)) in FAULTS.iter().zip(&f.runs).skip(4) {
            let case = (name, f.offsets, &f.case);
            assert!(fb.trolley <= 0.05, "{case:?}: trolley {fb:?}");
            assert!(fb.distance <= 0.05, "{case:?}: load {fb:?}");
            assert!(
                !fb.worse_than(ff),
                "{case:?}: {fb:?}, feedforward only {ff:?}"
            );
            match fb.mode {
                Some(Mode::SwingEstimated(Degraded::AngleOffset)) => announced += 1,
                Some(Mode::Closed) => {}
                other => panic!("{case:?}: {other:?}"),
            }
        }
    }
    // Announced once the crane rests: all but the few cases still settling when the
    // run ends.
    assert!(
        announced * 10 >= 9 * 2 * faults.len(),
        "{announced} of {} announced",
        2 * faults.len()
    );
}

#[test]
fn gust_at_rest_is_damped_below_ten_percent_in_two_periods() {
    let gains = Gains::design(&Config::PAPER).unwrap();
    for l in [3.0, 6.0, 9.0] {
        let (fb, ff) = gust_at_rest(l, &gains);
        assert!(fb < 0.1, "l = {l}: {fb}");
        assert!(ff > 0.5, "without feedback the swing stays: l = {l}: {ff}");
    }
}

/// Measurements 1 m and 10° off and a feedforward at the limits: every set point passes
/// the gate, i.e. the clamp keeps within the velocity and acceleration limits.
#[test]
fn anti_windup_keeps_set_points_within_the_gate() {
    let params = CraneParams::PAPER;
    let reference = paper_reference(&params);
    let limits = DriveLimits::LAB;
    let mut fb = StateFeedback::new(Config::PAPER).unwrap();
    let mut gate = SetpointGate::new(limits, 0.01);
    let mut last = [0.0; 2];
    for (k, (r, ud)) in reference.r.iter().zip(&reference.u).enumerate() {
        let sign = if (k / 150) % 2 == 0 { 1.0 } else { -1.0 };
        let m = Measurement {
            x: r.x + sign,
            l: r.l - sign * 0.5,
            phi: Some(r.phi + sign * 0.17),
        };
        let ud = [ud[0] * 2.0, ud[1] * 2.0];
        let out = fb.cycle(r, ud, Some(m), last, &limits);
        let a = gate.admit(Drive::Trolley, out.u[0]);
        let b = gate.admit(Drive::Winch, out.u[1]);
        assert!(
            a.is_ok() && b.is_ok(),
            "cycle {k}: {out:?} refused: {a:?} {b:?}"
        );
        last = [
            gate.last(Drive::Trolley).metres_per_second(),
            gate.last(Drive::Winch).metres_per_second(),
        ];
    }
}

#[test]
fn correction_is_zero_when_measurement_equals_reference() {
    let reference = paper_reference(&CraneParams::PAPER);
    let mut fb = StateFeedback::new(Config::PAPER).unwrap();
    let mut measured = None;
    let mut last = [0.0; 2];
    for (r, ud) in reference.r.iter().zip(&reference.u) {
        let out = fb.cycle(r, *ud, measured, last, &DriveLimits::LAB);
        assert_eq!(out.correction, [0.0; 2]);
        last = out.u;
        measured = Some(Measurement {
            x: r.x,
            l: r.l,
            phi: Some(r.phi),
        });
    }
}

/// The rope calibration (the paper's move and back, three times, in calm air, the first
/// moves after power-up: `calibration_reference`)
/// on an inclinometer offset from power-up learns the rope a true reading teaches: the
/// offset enters the pendulum's equation as a constant (`−g b`), which the regression's
/// constant term takes up (`controller::rope`). Without it, in the closed loop, whose
/// swing accelerations are small beside `g b`, 0.3° put the rope 86–228 mm off, and 3°
/// at a bound.
#[test]
fn a_biased_inclinometer_does_not_bias_the_learnt_rope() {
    use host_tests::feedback_study::{simulate_with_fault, SensorFault};
    use host_tests::plant::{Gust, Mismatch};
    let params = CraneParams::PAPER;
    let gains = Gains::design(&Config::PAPER).unwrap();
    let paper = host_tests::feedback_study::calibration_reference(&params);
    let case = Mismatch {
        drum_scale: 0.015,
        rope_offset: 0.08,
        gust: Gust::NONE,
        position_noise: Mismatch::SENSORS.0,
        angle_noise: Mismatch::SENSORS.1,
        noise_seed: 5,
        ..Mismatch::NONE
    };
    let learn = |bias: f64| {
        let fault = (bias != 0.0).then_some(SensorFault::Offset {
            at: f64::NEG_INFINITY,
            by: bias,
        });
        let (r, _) = simulate_with_fault(
            &params,
            &paper,
            &case,
            Some(&gains),
            fault,
            &DriveLimits::LAB,
            false,
        );
        let (s, o) = r.rope;
        (1.0 + s) * 4.0 + o
    };
    let truth = case.rope(4.0);
    let healthy = learn(0.0);
    println!(
        "true reading: rope learnt {:.1} mm off",
        (healthy - truth) * 1e3
    );
    assert!((healthy - truth).abs() < 0.02);
    for deg in [-3.0, -0.3, 0.3, 1.0, 3.0, 6.0] {
        let biased = learn(f64::to_radians(deg));
        println!("{deg}°: rope learnt {:.1} mm off", (biased - truth) * 1e3);
        // The offset is a regressor of its own, exact in the swing (`controller::rope`):
        // on the calibration moves -3° to 6° learn the rope within 2.4 mm of a true
        // reading's, 6° within 4.7 mm (issue 33; with a constant regressor and the
        // calibration moves, -3° was 11.5 mm off it).
        let tolerance = if f64::abs(deg) <= 3.0 { 0.01 } else { 0.016 };
        assert!(
            (biased - healthy).abs() < tolerance,
            "{deg}°: {:.1} mm from a true reading's",
            (biased - healthy) * 1e3
        );
    }
}

/// A healthy inclinometer is never judged stuck. Case 314 of the study's paper's-move
/// set (seed 2026): a 9.2 N gust blows while the load swings 6° near a turning point,
/// and the reading, noisy and quantised, repeats 5.986° for five cycles by chance. The
/// observer's angle is 0.06° off the reading then (the gust is a force its model does
/// not have); the stuck-sensor watch measured the position-only estimate against the
/// reading, counted that gap as motion and fell back to the positions alone mid-move
/// (105 mm and 1.49° 5 s after the move; 245 mm / 3.48° with the rope calibrated,
/// case 310). Measured as the motion of the estimate since the reading began to
/// repeat, the feedback keeps the angle and the load ends on target.
#[test]
fn a_healthy_reading_that_repeats_by_chance_under_a_gust_is_not_stuck() {
    use host_tests::feedback_study::simulate;
    use host_tests::plant::{Gust, Mismatch};
    let params = CraneParams::PAPER;
    let gains = Gains::design(&Config::PAPER).unwrap();
    let paper = paper_reference(&params);
    let case = Mismatch {
        tau1: 0.21696650122936917,
        tau2: -0.11173577207835542,
        rope_offset: -0.06145395888132285,
        drum_scale: 0.00800919178335421,
        coulomb: [0.007021529391728908, 0.0018745654371414905],
        viscous: [0.02846057775523102, 0.016986147616902793],
        gust: Gust {
            start: 6.421163423469926,
            duration: 1.7291133075817293,
            amplitude: 9.208126294155075,
        },
        position_noise: Mismatch::SENSORS.0,
        angle_noise: Mismatch::SENSORS.1,
        noise_seed: 13531939154114236654,
        swing0: 0.0387992074700055,
        ..Mismatch::NONE
    };
    let (fb, _) = simulate(
        &params,
        &paper,
        &case,
        Some(&gains),
        &DriveLimits::LAB,
        false,
    );
    assert_eq!(fb.mode, Some(Mode::Closed), "{fb:?}");
    assert!(fb.meets_target(), "{fb:?}");
}

/// The observer designed for the inclinometer's timing as commissioned (issue 33). Case
/// 781 of the calibration set (`cargo run --release -p host-tests --example
/// calibration_case -- 781`): an inclinometer 2 cycles late behind a 19 ms filter, a
/// load 36 % lighter than the model's, an 8.8 N gust for 2.5 s from 2.3 s of a 4.8 s
/// move. An observer that takes the angle for one as old as the positions swung the load
/// up during the move, fell back on an implausible angle and ended 4.8 m off swinging
/// 55°; told the timing (`feedback::angle_age`), it ends on target.
#[test]
fn a_late_filtered_angle_as_commissioned_leaves_the_load_on_target() {
    use controller::rope::InclinometerLag;
    use host_tests::feedback_study::{reference_run, simulate_told, steps_for};
    use host_tests::plant::{Gust, Mismatch, SensorLag};
    use solver_core::trajectory::PointToPoint;
    let params = CraneParams::PAPER;
    let gains = Gains::design(&Config::PAPER).unwrap();
    let (a, b) = (
        [15.95546780195112, 8.694865016031308],
        [18.291067932480505, 8.427967315320503],
    );
    let duration = 4.763268249105748;
    let z = PointToPoint::new(a.into(), b.into(), 1.0, duration, 5).unwrap();
    let steps = steps_for((1.0, 1.0 + duration), 0.0, b[1], 0.01);
    let reference = reference_run(params, z, 0.0, steps).unwrap();
    let lag = SensorLag {
        delay: 2,
        filter: 0.019450022195595683,
    };
    let case = Mismatch {
        tau1: -0.03924197749328939,
        tau2: 0.06345312159319316,
        rope_offset: -0.06738231119238902,
        drum_scale: -0.0020423734313546535,
        coulomb: [0.0029021988007440157, 0.0018019624190831396],
        viscous: [0.027079849867687772, 0.025646020180944338],
        gust: Gust {
            start: 2.3217191470230087,
            duration: 2.4791607135413036,
            amplitude: 8.807178633504343,
        },
        position_noise: (0.0002, 0.0001),
        angle_noise: (0.0005745869118134879, 0.000175),
        noise_seed: 6559377092695850606,
        swing0: -0.08418366794544549,
        load_mass: -0.3592812131412573,
        inclinometer: lag,
        proportional_only: [false; 2],
        loops_for_model_load: false,
        ..Mismatch::NONE
    };
    let run = |told| simulate_told(&params, &reference, &case, &gains, told, &DriveLimits::LAB);
    let told = run(InclinometerLag {
        delay: lag.delay,
        filter: lag.filter,
    });
    assert!(told.meets_target(), "{told:?}");
    assert_eq!(told.mode, Some(Mode::Closed), "{told:?}");
    let untold = run(InclinometerLag::NONE);
    assert!(untold.swing_deg > 1.0, "{untold:?}");
}
