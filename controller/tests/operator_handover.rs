//! Manual mode against automatic moves and the supervisor (issue 28): the stick taking a
//! running move over (in the same cycle, or — without headroom — at its on-path stop's
//! rest), a request for manual mode that waits or is refused (and said so),
//! and a supervisor's stop that holds until the load rests whatever the stick does.

mod common;

use common::manual::{moving, send_request, until_rest, Manual, HELD};
use common::*;
use controller::canopen::emcy;
use controller::commands::{Answer, Reject, Request};
use controller::operator::{Flags, Refusal, FULL_SCALE, MANUAL_MODE_CODE};
use controller::setpoint::Setpoint;
use controller::{Cycle, Mode, Replan};
use sim::HEALTHY;
use solver_core::models::crane::CraneParams;
use solver_core::operator::Settings;
use solver_core::plan::Segment;

/// The automatic move of these tests: 6 m of travel and 2 m of hoisting in 6 s, from
/// [`HOME`].
const TARGET: [f64; 2] = [18.0, 6.0];
const DURATION: f64 = 6.0;

/// The controller's EMCYs with `code` among `cycles`' frames.
fn emcys(cycles: &[Cycle], code: u16) -> Vec<[u8; 8]> {
    common::emcy_frames(cycles, Some(code))
}

/// The manual-mode refusals (EMCY 0xFF21) among `cycles`' frames: their detail bytes.
fn refusals(cycles: &[Cycle]) -> Vec<u8> {
    common::emcy_frames(cycles, Some(emcy::MANUAL_REFUSED))
        .into_iter()
        .map(|d| {
            assert_eq!(d[2] & 0x01, 0, "a warning: no generic error bit");
            assert_eq!(d[3], emcy::MANUAL_REFUSED_BYTE);
            d[5]
        })
        .collect()
}

/// The automatic move of these tests sent to `rig` with `id`.
fn send_move(rig: &mut Manual, id: u8) {
    send_move_to(rig, id, TARGET);
}

/// A move to `target` in [`DURATION`] sent to `rig` with `id`.
fn send_move_to(rig: &mut Manual, id: u8, target: [f64; 2]) {
    send_request(
        rig,
        Request::Move {
            id,
            target,
            duration: Some(DURATION),
        },
    );
}

/// The automatic move sent to `rig` and accepted, the operator asking for manual mode
/// with the stick centred meanwhile (the interlock lifted, as a deflection needs):
/// the move is not taken over by a centred stick.
fn automatic_move(rig: &mut Manual) -> Vec<Cycle> {
    automatic_move_to(rig, TARGET)
}

/// [`automatic_move`] to `target`.
fn automatic_move_to(rig: &mut Manual, target: [f64; 2]) -> Vec<Cycle> {
    send_move_to(rig, 1, target);
    let cycles = rig.hold(9, HELD, [0; 3]);
    assert_eq!(rig.c.last_answer().1, Answer::Accepted);
    assert_eq!(rig.mode_byte(), 1, "a centred stick takes nothing over");
    assert!(!rig.c.feedforward().path().in_manual());
    cycles
}

/// The automatic move of [`automatic_move`] with a move queued behind it, run to `share`
/// of its span with the stick centred; then the stick deflected to `stick` and the cycle
/// that reads that frame. All cycles, the last that one.
fn deflect_at(rig: &mut Manual, share: f64, stick: i16) -> Vec<Cycle> {
    deflect(rig, TARGET, share, [stick, 0, 0])
}

/// [`deflect_at`] with the move to `target` and the stick deflected to `stick`
/// (`[x, y, hoist]`).
fn deflect(rig: &mut Manual, target: [f64; 2], share: f64, stick: [i16; 3]) -> Vec<Cycle> {
    let mut cycles = automatic_move_to(rig, target);
    send_request(
        rig,
        Request::Move {
            id: 2,
            target: HOME,
            duration: None,
        },
    );
    let span = rig
        .c
        .feedforward()
        .plan()
        .active()
        .map(|a| a.span())
        .unwrap();
    let at = span.0 + share * (span.1 - span.0);
    while f64::from(rig.now) / 1000.0 < at {
        cycles.extend(rig.hold(3, HELD, [0; 3]));
    }
    assert_eq!(rig.c.last_answer().1, Answer::Queued, "id 2 queued");
    rig.send(HELD, stick);
    cycles.push(rig.cycle());
    cycles
}

/// The move-taken-over EMCY (0xFF22) of `cycle`, exactly one: its detail byte.
fn taken_over(cycle: &Cycle) -> u8 {
    let emcy = emcys(std::slice::from_ref(cycle), emcy::MOVE_TAKEN_OVER);
    assert_eq!(
        emcy.len(),
        1,
        "the supervisor hears its move was taken over"
    );
    assert_eq!(emcy[0][3], emcy::MOVE_TAKEN_OVER_BYTE);
    emcy[0][5]
}

/// The hand-over refused for want of headroom: the cycle that read the stick (the last
/// of `cycles`) says the move is taken over at its stop's rest (EMCY 0xFF22, detail 1),
/// and the move ends with its on-path stop.
fn ends_on_its_path(rig: &Manual, cycles: &[Cycle], case: &str) {
    assert_eq!(
        taken_over(cycles.last().unwrap()),
        emcy::TAKEN_OVER_AT_REST,
        "{case}"
    );
    assert!(
        matches!(rig.c.feedforward().plan().active(), Some(Segment::Stop(_))),
        "{case}: the move ends with its on-path stop"
    );
}

/// Frames with `stick` every third cycle (centred: the release; deflected: a stop that
/// holds whatever the stick does) until the load rests; then every set point of
/// `cycles` and those within the drives' limits, and the controller ready throughout.
/// All the cycles.
fn rests_within_limits(
    rig: &mut Manual,
    mut cycles: Vec<Cycle>,
    stick: [i16; 3],
    case: &str,
) -> Vec<Cycle> {
    let (rest, rested) = until_rest(rig, 3000, |r, n| {
        if n % 3 == 0 {
            r.send(HELD, stick);
        }
    });
    assert!(rested, "{case}: at rest");
    cycles.extend(rest);
    let mut last = [0; 2];
    assert_within_limits(&cycles, &mut last);
    assert_eq!(
        cycles.iter().map(|c| c.mode).find(|m| *m != Mode::Ready),
        None,
        "{case}: no fault"
    );
    cycles
}

/// After a hand-over: the stick held at `stick` for 9 s (longer than any hand-over's
/// stop, the lab's `Settings::entry_blend` of 8 s, whose own motion adds to the
/// operator's while it lasts), the load then moving the way it points at its share of
/// the manual speed of the generator's `settings` beyond its deadband (the sticks of these tests keep the load clear of the
/// workspace's ends, whose braking curve would slow it); released, at rest, every set point within the drives'
/// limits throughout, no fault, nothing refused, and then every set point exactly zero.
fn drives_then_rests(
    rig: &mut Manual,
    mut cycles: Vec<Cycle>,
    stick: i16,
    settings: &Settings<1>,
    case: &str,
) {
    cycles.extend(rig.hold(900, HELD, [stick, 0, 0]));
    let before = rig.load()[0];
    cycles.extend(rig.hold(50, HELD, [stick, 0, 0]));
    let v = (rig.load()[0] - before) / 0.5;
    // The demand beyond the deadband, scaled so that full stick is full speed.
    let (share, band) = (f64::from(stick) / f64::from(FULL_SCALE), settings.deadband);
    let speed = settings.horizontal[0].speed;
    let want = speed * share.signum() * (share.abs() - band) / (1.0 - band);
    assert!(
        (v - want).abs() < 0.01 * speed,
        "{case}: the stick drives the load at {v} m/s, not {want}"
    );
    let cycles = rests_within_limits(rig, cycles, [0; 3], case);
    let tail = rig.hold(100, HELD, [0; 3]);
    assert!(tail.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]));
    assert!(refusals(&cycles).is_empty(), "{case}: nothing refused");
}

/// The hand-over (issue 28, "Safety and hand-over"): a stick deflected during an
/// automatic move, at 10, 50 and 90 % of it and either way, takes the crane over in the
/// cycle that reads the frame — manual mode from that cycle (the status's mode byte),
/// EMCY 0xFF22 with detail 0 (at once), the move queued behind refused (reason 2) — and
/// the stick drives the load at its share of the manual speed; every set point within
/// the drives' speed and acceleration limits throughout (the set points go on smoothly
/// from the move's), no fault, and after the release every set point exactly zero.
#[test]
fn a_stick_deflected_during_an_automatic_move_takes_it_over_in_the_same_cycle() {
    let settings = Settings::lab(&CraneParams::PAPER);
    for share in [0.1, 0.5, 0.9] {
        for stick in [FULL_SCALE / 4, -FULL_SCALE / 4] {
            let case = format!("{share} of the move, stick {stick}");
            let mut rig = Manual::new();
            let cycles = deflect_at(&mut rig, share, stick);
            let ended = cycles.last().unwrap();
            assert_eq!(taken_over(ended), emcy::TAKEN_OVER_AT_ONCE, "{case}");
            assert!(rig.c.feedforward().path().in_manual(), "{case}: at once");
            assert_eq!(rig.mode_byte(), MANUAL_MODE_CODE, "{case}");
            assert_eq!(
                rig.c.last_answer(),
                (2, Answer::Rejected, Some(Reject::NotReady)),
                "{case}: the queued move refused"
            );
            drives_then_rests(&mut rig, cycles, stick, &settings, &case);
        }
    }
}

/// The hand-over at full stick, with the move and against it, at 10, 50 and 90 % of the
/// move: the move's stop and the operator's full speed added (the hardest case for the
/// headroom), held for 9 s — into the workspace's ends, where the generator's braking
/// curve takes over — then released: every set point within the drives' limits, no
/// fault, at rest, nothing refused.
#[test]
fn a_full_stick_hand_over_keeps_every_set_point_within_the_limits() {
    for share in [0.1, 0.5, 0.9] {
        for stick in [FULL_SCALE, -FULL_SCALE] {
            let case = format!("{share} of the move, stick {stick}");
            let mut rig = Manual::new();
            let mut cycles = deflect_at(&mut rig, share, stick);
            assert_eq!(
                taken_over(cycles.last().unwrap()),
                emcy::TAKEN_OVER_AT_ONCE,
                "{case}"
            );
            cycles.extend(rig.hold(900, HELD, [stick, 0, 0]));
            let cycles = rests_within_limits(&mut rig, cycles, [0; 3], &case);
            assert!(refusals(&cycles).is_empty(), "{case}: nothing refused");
        }
    }
}

/// A stop request (0x210) while a hand-over's stop still runs, full stick forward 50 %
/// into the move: the generator's stop is latched in that very cycle (the stick's share
/// stops at once, whatever the stick does), the taken-over move's own stop goes on —
/// shortened where the drives' room allows (`Generator::stop_within`; how far:
/// host-tests' `handover_stop`) — and the load rests within the drives' limits, no
/// fault, the set points then exactly zero.
#[test]
fn a_stop_request_during_a_hand_over_s_stop_latches_the_operator_s_stop_at_once() {
    let mut rig = Manual::new();
    let mut cycles = deflect_at(&mut rig, 0.5, FULL_SCALE);
    cycles.extend(rig.hold(60, HELD, [FULL_SCALE, 0, 0]));
    send_request(&mut rig, Request::Stop { id: 5 });
    cycles.push(rig.cycle());
    let path = rig.c.feedforward_mut().path_mut().manual_mut().unwrap();
    assert!(path.is_stopping(), "the operator's stop latched at once");
    rests_within_limits(&mut rig, cycles, [FULL_SCALE, 0, 0], "stopped");
    let tail = rig.hold(100, HELD, [FULL_SCALE, 0, 0]);
    assert!(
        tail.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]),
        "held at rest: the stick interlocked after the stop"
    );
}

/// A hand-over with the stick centred again at once (one frame deflected back, against
/// the move, so that the operator's own motion cannot carry the load forward): the
/// move's own stop, which the generator ends it with, brings the load to rest at or
/// before the move's target — never past it — at 10, 50 and 90 % of the move.
#[test]
fn a_taken_over_move_rests_at_or_before_its_target() {
    for share in [0.1, 0.5, 0.9] {
        let mut rig = Manual::new();
        let cycles = deflect_at(&mut rig, share, -FULL_SCALE);
        assert_eq!(taken_over(cycles.last().unwrap()), emcy::TAKEN_OVER_AT_ONCE);
        let mut farthest = f64::NEG_INFINITY;
        let (_, rested) = until_rest(&mut rig, 3000, |r, n| {
            if n % 3 == 0 {
                r.send(HELD, [0; 3]);
            }
            farthest = farthest.max(r.load()[0]);
        });
        assert!(rested, "{share}: at rest");
        assert!(
            farthest <= TARGET[0] + 1e-9,
            "{share}: the load reached {farthest} m, past the target {}",
            TARGET[0]
        );
        assert!(
            rig.c.feedforward().path().in_manual(),
            "{share}: still manual"
        );
    }
}

/// When no stop of the generator's fits what the drives leave beside the operator
/// (here a manual acceleration of 1.95 m/s² leaves the trolley's 3 m/s² no room:
/// 0.95 · 3 − 1.5 · 1.95 < 0, [`controller::operator::path::room`]), the move ends
/// with its on-path stop instead (EMCY 0xFF22, detail 1): the load rests on the move's
/// path short of its target, manual mode is entered at that rest with the stick live —
/// no re-centring — and the stick then drives the load.
#[test]
fn a_hand_over_without_headroom_ends_the_move_on_its_path_and_takes_over_at_its_rest() {
    let mut settings = Settings::lab(&CraneParams::PAPER);
    settings.horizontal[0].acceleration = 1.95;
    for stick in [FULL_SCALE / 4, -FULL_SCALE / 4] {
        let case = format!("stick {stick}");
        let mut rig = Manual::with(settings);
        let mut cycles = deflect_at(&mut rig, 0.5, stick);
        ends_on_its_path(&rig, &cycles, &case);
        let mut entered = None;
        for _ in 0..200 {
            cycles.extend(rig.hold(3, HELD, [stick, 0, 0]));
            if rig.c.feedforward().path().in_manual() {
                entered = Some(rig.load());
                break;
            }
        }
        let entered = entered.unwrap_or_else(|| panic!("{case}: entered at the rest"));
        assert!(
            entered[0] <= TARGET[0] - 1e-3,
            "{case}: rested at {} m, short of the target {}",
            entered[0],
            TARGET[0]
        );
        drives_then_rests(&mut rig, cycles, stick, &settings, &case);
    }
}

/// A hoist whose manual acceleration leaves its drive no room beside the operator
/// (1.95 m/s² of 3: 0.95 · 3 − 1.5 · 1.95 < 0, [`controller::operator::path::room`]
/// zero): a move that does not hoist (3 m of travel at the depth it starts from), whose
/// stop adds nothing to the hoist, is taken over at once (EMCY 0xFF22, detail 0) — by a
/// horizontal stick and by a hoist stick alike, the hoist then moving by the operator's
/// motion only — every set point within the drives' limits to rest, no fault; a move
/// that hoists (2 m in its 6 s) still ends on its path and is taken over at its rest
/// (detail 1), whichever stick: its stop would add hoist motion the hoist has no room for.
/// (A negative room refused every take-over: detail 1 for the move that does not hoist.)
#[test]
fn a_hoist_without_room_takes_over_a_move_that_does_not_hoist_at_once() {
    let mut settings = Settings::lab(&CraneParams::PAPER);
    settings.hoist.acceleration = 1.95;
    let w = CraneParams::PAPER.workspace;
    settings.hoist.range = settings.depth_range((w.l_min, w.l_max));
    // 3 m: halfway through 6 m at this depth the trolley's own stop finds no room, with
    // the lab's settings too (EMCY detail 1 whatever the hoist).
    let level = [HOME[0] + 3.0, HOME[1]];
    let sticks = [[FULL_SCALE / 4, 0, 0], [0, 0, FULL_SCALE / 4]];
    for stick in sticks {
        let case = format!("level move, stick {stick:?}");
        let mut rig = Manual::with(settings);
        let mut cycles = deflect(&mut rig, level, 0.5, stick);
        assert_eq!(
            taken_over(cycles.last().unwrap()),
            emcy::TAKEN_OVER_AT_ONCE,
            "{case}"
        );
        assert!(rig.c.feedforward().path().in_manual(), "{case}: at once");
        cycles.extend(rig.hold(300, HELD, stick));
        let cycles = rests_within_limits(&mut rig, cycles, [0; 3], &case);
        assert!(refusals(&cycles).is_empty(), "{case}: nothing refused");
    }
    for stick in sticks {
        let case = format!("hoisting move, stick {stick:?}");
        let mut rig = Manual::with(settings);
        let cycles = deflect(&mut rig, TARGET, 0.5, stick);
        ends_on_its_path(&rig, &cycles, &case);
    }
}

/// A request for manual mode during an automatic move with the stick centred waits: the
/// move ends at its target as planned, and manual mode is entered at its rest, the stick
/// interlocked (a deflection then moves nothing until it is centred twice).
#[test]
fn a_request_for_manual_mode_during_a_move_waits_for_its_rest() {
    let mut rig = Manual::new();
    let mut waited = automatic_move(&mut rig);
    let (_, end) = rig.c.feedforward().plan().active().unwrap().span();
    let mut entered_at = None;
    for _ in 0..300 {
        waited.extend(rig.hold(3, HELD, [0; 3]));
        if rig.c.feedforward().path().in_manual() {
            entered_at = Some(rig.now);
            break;
        }
    }
    let entered_at = entered_at.expect("entered at rest");
    assert!(refusals(&waited).is_empty(), "waiting is no refusal");
    assert!(f64::from(entered_at) / 1000.0 >= end, "after the move");
    let [x, z] = rig.load();
    assert!((x - TARGET[0]).abs() < 1e-6 && (z - TARGET[1]).abs() < 1e-6);
    let held = rig.hold(60, HELD, [FULL_SCALE, 0, 0]);
    assert!(
        held.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]),
        "interlocked on entry"
    );
}

/// A stick already deflected when the request for manual mode comes (never centred with
/// it) takes nothing over (the zero-position interlock): the move ends at its target.
#[test]
fn a_stick_deflected_with_the_request_takes_no_move_over() {
    let mut rig = Manual::new();
    let off = Flags {
        manual: false,
        ..HELD
    };
    rig.hold(9, off, [0; 3]);
    send_move(&mut rig, 1);
    rig.hold(150, HELD, [FULL_SCALE, 0, 0]);
    assert!(!rig.c.feedforward().path().in_manual(), "the move goes on");
    for _ in 0..300 {
        rig.hold(3, HELD, [FULL_SCALE, 0, 0]);
        if rig.c.feedforward().path().in_manual() {
            break;
        }
    }
    let [x, z] = rig.load();
    assert!((x - TARGET[0]).abs() < 1e-6 && (z - TARGET[1]).abs() < 1e-6);
}

/// A request for manual mode that cannot be granted is said so once (review finding 6):
/// a controller whose model follows plans only announces EMCY 0xFF21, detail 1
/// (unsupported), once however long the request stands, and again when it is asked
/// anew; a halted controller with manual mode answers detail 2 (not ready).
#[test]
fn a_refused_request_for_manual_mode_is_announced_once() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    let mut counter = 0u8;
    let mut ask = |rig: &mut Rig, flags: Flags, cycles: usize| -> Vec<Cycle> {
        (0..cycles)
            .map(|n| {
                if n % 3 == 0 {
                    counter = counter.wrapping_add(1);
                    let f = controller::operator::operator_frame(
                        controller::canopen::CONTROLLER_NODE,
                        &controller::operator::OperatorFrame {
                            counter,
                            flags,
                            demand: [0; 3],
                        },
                    );
                    rig.c.on_frame(&f, rig.now.into());
                }
                rig.cycle()
            })
            .collect()
    };
    let off = Flags {
        manual: false,
        ..HELD
    };
    let first = ask(&mut rig, HELD, 300);
    assert_eq!(refusals(&first), [Refusal::Unsupported.code()]);
    ask(&mut rig, off, 9);
    let again = ask(&mut rig, HELD, 30);
    assert_eq!(
        refusals(&again),
        [Refusal::Unsupported.code()],
        "asked anew"
    );
    assert!(first.iter().chain(&again).all(|c| c.mode == Mode::Ready));

    let mut rig = Manual::new();
    rig.c.feedforward_mut().fail_next_step();
    let mut halted = Vec::new();
    for _ in 0..300 {
        let out = rig.hold(
            1,
            Flags {
                manual: false,
                ..HELD
            },
            [0; 3],
        );
        let done = matches!(out[0].mode, Mode::Halted(_));
        halted.extend(out);
        if done {
            break;
        }
    }
    assert!(matches!(halted.last().unwrap().mode, Mode::Halted(_)));
    let refused = rig.hold(60, HELD, [0; 3]);
    assert_eq!(refusals(&refused), [Refusal::NotReady.code()]);
}

/// A supervisor's stop request in manual mode holds until the load rests (review
/// finding 7): the operator centring the stick for two frames mid-stop and pushing it
/// again changes nothing — the set points are those of the same stop with the stick held
/// throughout, to the unit — and once at rest a stick centred twice moves the load again.
#[test]
fn a_stop_request_holds_until_rest_whatever_the_stick_does() {
    let stop = |recentre: bool| {
        let mut rig = moving(300);
        send_request(&mut rig, Request::Stop { id: 5 });
        let first = rig.cycle();
        assert!(
            first.setpoints[0].units() > 100_000,
            "travelling when stopped"
        );
        let stick = if recentre { [0; 3] } else { [FULL_SCALE, 0, 0] };
        let mut stopping = vec![first];
        stopping.extend(rig.hold(6, HELD, stick));
        let (rest, rested) = until_rest(&mut rig, 2000, |r, n| {
            if n % 3 == 0 {
                r.send(HELD, [FULL_SCALE, 0, 0]);
            }
        });
        assert!(rested, "at rest (re-centred mid-stop: {recentre})");
        stopping.extend(rest);
        (rig, stopping)
    };
    let (_, held) = stop(false);
    let (mut rig, recentred) = stop(true);
    let units = |c: &[Cycle]| -> Vec<[i32; 2]> {
        c.iter()
            .map(|c| [c.setpoints[0].units(), c.setpoints[1].units()])
            .collect()
    };
    assert_eq!(units(&recentred), units(&held));
    let mut last = units(&recentred[..1])[0];
    assert_within_limits(&recentred[1..], &mut last);
    rig.hold(6, HELD, [0; 3]);
    let live = rig.hold(150, HELD, [FULL_SCALE, 0, 0]);
    assert!(
        live.iter().any(|c| c.setpoints[0].units() > 0),
        "at rest, centred twice: live"
    );
}

/// A watched supervisor (0x1016:1: node 0x20, 300 ms) that falls silent in manual mode
/// (stop 41's note: this path had no test of its own): while the stick moves the load it
/// is the fault it is in automatic, a controlled stop announced as fault 14 (0x8130), the
/// set points within the drives' limits down to rest; with manual mode parked at rest it
/// is no fault, as manual mode counts as motion only while its generator moves.
#[test]
fn a_silent_supervisor_stops_manual_travel_and_leaves_a_parked_crane_alone() {
    use controller::canopen::{self, NmtState};
    use controller::Fault;
    let watch = |rig: &mut Manual| {
        // 0x1016:1 = 300 ms for node 0x20, by an SDO expedited download.
        let write =
            controller::CanFrame::new(0x610, &[0x23, 0x16, 0x10, 1, 0x2C, 0x01, 0x20, 0]).unwrap();
        rig.c.on_frame(&write, rig.now.into());
    };
    let beat = |rig: &mut Manual| {
        let frame = canopen::heartbeat(0x20, NmtState::Operational);
        rig.c.on_frame(&frame, rig.now.into());
    };
    for travelling in [true, false] {
        let mut rig = Manual::new();
        watch(&mut rig);
        let mut cycles = Vec::new();
        for n in 0..300 {
            if n % 10 == 0 {
                beat(&mut rig);
            }
            let push = if travelling && n >= 30 { FULL_SCALE } else { 0 };
            cycles.extend(rig.hold(1, HELD, [push, 0, 0]));
        }
        assert!(cycles.iter().all(|c| c.mode == Mode::Ready));
        assert_eq!(rig.mode_byte(), MANUAL_MODE_CODE);
        let mut last = [
            cycles.last().unwrap().setpoints[0].units(),
            cycles.last().unwrap().setpoints[1].units(),
        ];
        let push = if travelling { FULL_SCALE } else { 0 };
        let silent = rig.hold(100, HELD, [push, 0, 0]);
        let fault = silent.iter().map(|c| c.mode).find(|m| *m != Mode::Ready);
        if travelling {
            assert_eq!(fault, Some(Mode::Stopping(Fault::SupervisorLost)));
            let emcy: Vec<_> = silent
                .iter()
                .flat_map(|c| c.frames.iter())
                .filter(|f| f.id() == 0x090)
                .collect();
            assert_eq!(emcy.len(), 1);
            assert_eq!(
                emcy[0].data()[..4],
                [0x30, 0x81, 0x11, 14],
                "0x8130, fault 14"
            );
            let mut halt = silent.clone();
            for _ in 0..300 {
                let out = rig.cycle();
                let halted = matches!(out.mode, Mode::Halted(_));
                halt.push(out);
                if halted {
                    break;
                }
            }
            assert!(matches!(halt.last().unwrap().mode, Mode::Halted(_)));
            assert_within_limits(&halt, &mut last);
        } else {
            assert_eq!(fault, None, "parked: no fault");
            assert!(silent.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]));
        }
    }
}

const OFF: Flags = Flags {
    manual: false,
    ..HELD
};

/// A stick centred in manual mode, manual mode then left (bit 1 cleared), and a request
/// made again later with the stick already deflected (review s10, finding 1): a frame
/// without the request interlocks the stick, so nothing is taken over — the move ends at
/// its target — and only a stick centred with the request moves the load after it.
#[test]
fn a_stick_centred_before_the_request_takes_no_move_over() {
    let mut rig = Manual::new();
    rig.hold(9, HELD, [0; 3]);
    assert_eq!(rig.mode_byte(), MANUAL_MODE_CODE);
    rig.hold(30, OFF, [0; 3]);
    assert_eq!(rig.mode_byte(), 1, "left at rest");
    send_move(&mut rig, 1);
    rig.hold(60, OFF, [0; 3]);
    let mut cycles = Vec::new();
    for _ in 0..300 {
        cycles.extend(rig.hold(3, HELD, [FULL_SCALE, 0, 0]));
        if rig.c.feedforward().path().in_manual() {
            break;
        }
    }
    assert!(
        emcys(&cycles, emcy::MOVE_TAKEN_OVER).is_empty(),
        "nothing taken over"
    );
    let [x, z] = rig.load();
    assert!((x - TARGET[0]).abs() < 1e-6 && (z - TARGET[1]).abs() < 1e-6);
    let held = rig.hold(60, HELD, [FULL_SCALE, 0, 0]);
    assert!(held.iter().all(|c| c.setpoints == [Setpoint::ZERO; 2]));
}

/// While the stick has taken an automatic move over (manual mode, the move's stop still
/// running), a move sent is refused (reason 2), not queued (review s10, finding 2); a
/// move sent again with the id of the one the stick ended is a new request, answered and
/// acted on as one once the operator gives the crane back at rest (finding 4).
#[test]
fn while_the_stick_takes_over_nothing_is_accepted_and_a_resent_move_is_new() {
    let mut rig = Manual::new();
    automatic_move(&mut rig);
    rig.hold(30, HELD, [0; 3]);
    rig.send(HELD, [FULL_SCALE, 0, 0]);
    rig.cycle();
    assert!(rig.c.feedforward().path().in_manual());
    send_request(
        &mut rig,
        Request::Move {
            id: 3,
            target: [14.0, 8.0],
            duration: Some(DURATION),
        },
    );
    rig.hold(3, HELD, [FULL_SCALE, 0, 0]);
    assert_eq!(
        rig.c.last_answer(),
        (3, Answer::Rejected, Some(Reject::NotReady))
    );
    // The operator lets go of the request during the stop; manual mode is left at rest,
    // and the PLC sends move 1 again.
    let mut left = false;
    for _ in 0..1500 {
        rig.hold(3, OFF, [0; 3]);
        if !rig.c.feedforward().path().in_manual() {
            left = true;
            break;
        }
    }
    assert!(left, "manual mode left at rest");
    send_move(&mut rig, 1);
    let mut reached = false;
    for _ in 0..1500 {
        rig.hold(3, OFF, [0; 3]);
        let [x, z] = rig.load();
        if (x - TARGET[0]).abs() < 1e-6 && (z - TARGET[1]).abs() < 1e-6 {
            reached = true;
            break;
        }
    }
    assert!(reached, "the move sent again runs to its target");
}

/// A crane whose model follows plans only (no `[operator]` section): operator frames
/// asking for manual mode, centred and then deflected, neither stop its automatic move
/// nor take it over (review s10, finding 3); the request is refused once, at once.
#[test]
fn a_crane_without_manual_mode_lets_no_stick_stop_its_move() {
    let mut rig = Rig::new(HEALTHY, false);
    rig.ready();
    send(
        &mut rig,
        Request::Move {
            id: 1,
            target: TARGET,
            duration: Some(DURATION),
        },
    );
    let mut cycles = rig.run(30);
    let mut counter = 0u8;
    for n in 0..300 {
        if n % 3 == 0 {
            counter = counter.wrapping_add(1);
            let demand = if n < 9 { 0 } else { FULL_SCALE };
            let f = controller::operator::operator_frame(
                controller::canopen::CONTROLLER_NODE,
                &controller::operator::OperatorFrame {
                    counter,
                    flags: HELD,
                    demand: [demand, 0, 0],
                },
            );
            rig.c.on_frame(&f, rig.now.into());
        }
        cycles.push(rig.cycle());
        assert!(
            !matches!(rig.c.feedforward().plan().active(), Some(Segment::Stop(_))),
            "cycle {n}: the move goes on"
        );
    }
    assert_eq!(refusals(&cycles), [Refusal::Unsupported.code()]);
    assert!(emcys(&cycles, emcy::MOVE_TAKEN_OVER).is_empty());
}
