//! Manual mode as a property of the scene (issue 28): the host's run of the firmware's
//! loop on the scenes with `[operator]` (the QEMU runs are compared with it frame by
//! frame), the master switch played by the virtual bus (`sim::MANUAL_PROFILE`,
//! `sim::MANUAL_DEADMAN`, `sim::MANUAL_TAKEOVER`): manual mode entered at rest or by
//! taking over the scene's move, the load moved by the stick,
//! every set point exactly 0.0 after a release's stop, manual mode left at rest. The
//! same scenario on a scene without `[operator]` never enters manual mode.

use std::path::{Path, PathBuf};

use controller::canopen::{cob, emcy, CONTROLLER_NODE};
use controller::commands::Request;
use controller::commands::STATUS_ID;
use controller::controller::MODEL_REST_CYCLES;
use controller::operator::MANUAL_MODE_CODE;
use controller::setpoint::UNITS_PER_M_PER_S;
use controller::Mode;
use host_tests::firmware::{controller_reference, ReferenceCycle};
use scene::commissioning::CommissioningFile;
use scene::Scene;
use sim::scenario::{
    Action, Event, MANUAL_HANDOVER_REFUSED, MANUAL_TAKEOVER_3D, MANUAL_TAKEOVER_STOP_3D,
};
use sim::{
    Scenario, MANUAL_DEADMAN, MANUAL_PROFILE, MANUAL_PROFILE_3D, MANUAL_TAKEOVER, STICK_PERIOD_MS,
};

fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(name)
}

/// The host's run of the firmware on `scene` with `scenario`.
fn run(scene: &str, scenario: &Scenario) -> Vec<ReferenceCycle> {
    let path = scene_path(scene);
    let s = Scene::load(&path).unwrap();
    let c = CommissioningFile::for_scene(&path).unwrap();
    controller_reference(&s, &c, scenario).unwrap()
}

/// The status frames' mode byte (byte 3) in each cycle that sent one, with its time.
fn modes(run: &[ReferenceCycle]) -> Vec<(u32, u8)> {
    run.iter()
        .flat_map(|c| {
            c.frames
                .iter()
                .filter(|f| f.id() == STATUS_ID)
                .map(move |f| (c.now_ms, f.data()[3]))
        })
        .collect()
}

/// Whether any set point is not exactly zero in the cycles `from..to` ms.
fn moving(run: &[ReferenceCycle], from: u32, to: u32) -> bool {
    run.iter()
        .filter(|c| (from..to).contains(&c.now_ms))
        .any(|c| c.setpoints.iter().any(|s| s.units() != 0))
}

/// The first time from `from` ms on after which every set point is exactly zero to
/// `to` ms.
fn rests_from(run: &[ReferenceCycle], from: u32, to: u32) -> Option<u32> {
    let window: Vec<&ReferenceCycle> = run
        .iter()
        .filter(|c| (from..to).contains(&c.now_ms))
        .collect();
    let last_moving = window
        .iter()
        .rposition(|c| c.setpoints.iter().any(|s| s.units() != 0))?;
    window.get(last_moving + 1).map(|c| c.now_ms)
}

/// The profile on `scene`: manual mode (mode 5) from the request at 10 s, the load
/// moved by each full stick, at rest — every set point exactly 0.0 — a bounded time
/// after each release, manual mode left (mode 1) after the request is withdrawn at
/// 31 s, ready at the end.
fn profile(scene: &str, scenario: &Scenario) {
    let run = run(scene, scenario);
    assert_eq!(
        run.len(),
        scenario.cycles as usize,
        "{scene}: ran to the end"
    );
    let modes = modes(&run);
    let first_manual = modes
        .iter()
        .find(|(_, m)| *m == MANUAL_MODE_CODE)
        .map(|(t, _)| *t)
        .unwrap_or_else(|| panic!("{scene}: manual mode never entered"));
    assert!(
        (10_000..10_200).contains(&first_manual),
        "{scene}: entered at {first_manual} ms"
    );
    // No motion between the scene's move and the first full stick.
    assert!(
        !moving(&run, 9_500, 10_500),
        "{scene}: moved before the stick"
    );
    // Full stick moves the crane; released, it rests again within 5.5 s: the rate
    // limiter's stop (2 s from 1 m/s at 0.5 m/s²), then the filters' window (0.2 + 0.2 s
    // and the generator pendulum's half period, 2.3 s at 4 m deep with the 1 m lowering
    // allowance).
    assert!(
        moving(&run, 10_500, 13_500),
        "{scene}: the stick moved nothing"
    );
    let rest = rests_from(&run, 13_500, 19_000).expect("moving until the next stick");
    assert!(rest < 13_500 + 5_500, "{scene}: at rest from {rest} ms");
    assert!(
        moving(&run, 19_000, 24_000),
        "{scene}: the reversal moved nothing"
    );
    let rest = rests_from(&run, 24_000, 31_000).expect("moving until the request's end");
    assert!(rest < 24_000 + 7_000, "{scene}: at rest from {rest} ms");
    // In manual mode throughout, left after the withdrawal.
    assert!(
        modes
            .iter()
            .filter(|(t, _)| (10_200..31_000).contains(t))
            .all(|(_, m)| *m == MANUAL_MODE_CODE),
        "{scene}: {modes:?}"
    );
    let last = modes.last().unwrap();
    assert_eq!(last.1, 1, "{scene}: manual mode left at rest ({last:?})");
    assert_eq!(run.last().unwrap().mode, Mode::Ready);
    assert!(
        !moving(&run, 31_000, 33_000),
        "{scene}: moved after leaving"
    );
}

#[test]
fn the_planar_manual_scene_follows_the_operator_profile() {
    profile("paper-crane-manual.toml", &MANUAL_PROFILE);
}

#[test]
fn the_3d_manual_scene_follows_the_operator_profile() {
    profile("crane3d/crane3d-manual.toml", &MANUAL_PROFILE_3D);
}

/// The master switch falls silent at 12.5 s mid-travel: the dead-man's loss, the
/// sway-free stop (set points exactly 0.0 from a bounded time on), manual mode left
/// at rest (status mode 1), ready.
fn deadman(scene: &str) {
    let run = run(scene, &MANUAL_DEADMAN);
    assert!(
        moving(&run, 12_000, 12_500),
        "{scene}: travelling at the drop"
    );
    let rest = rests_from(&run, 12_500, 20_000).expect("at rest before the end");
    assert!(rest < 12_500 + 6_000, "{scene}: at rest from {rest} ms");
    // Left at rest, judged cycle by cycle (the status frames come every 100 ms): not
    // before every set point has been zero in drive units for `MODEL_REST_CYCLES` cycles
    // (the model's reach it a few cycles after the generator's path rests, BDF4's
    // history), and in the cycle they have.
    let left = run
        .iter()
        .find(|c| c.now_ms > 12_500 && c.status_mode != MANUAL_MODE_CODE)
        .unwrap_or_else(|| panic!("{scene}: manual mode never left"));
    assert_eq!(left.status_mode, 1, "{scene}: left to {}", left.status_mode);
    let (rest_cycles, period) = (u32::from(MODEL_REST_CYCLES), run[1].now_ms - run[0].now_ms);
    assert!(
        (rest + period * (rest_cycles - 1)..=rest + period * rest_cycles).contains(&left.now_ms),
        "{scene}: left at {} ms, at rest from {rest} ms",
        left.now_ms
    );
    // The status frames say it at their next period.
    let said = modes(&run)
        .into_iter()
        .find(|(t, m)| *t > 12_500 && *m != MANUAL_MODE_CODE)
        .unwrap_or_else(|| panic!("{scene}: no status frame says manual mode left"));
    assert!(
        (left.now_ms..left.now_ms + 100).contains(&said.0),
        "{scene}: said at {} ms, left at {} ms",
        said.0,
        left.now_ms
    );
    assert_eq!(run.last().unwrap().mode, Mode::Ready);
}

#[test]
fn a_dead_man_drop_on_the_planar_manual_scene_stops_and_leaves_manual_mode() {
    deadman("paper-crane-manual.toml");
}

#[test]
fn a_dead_man_drop_on_the_3d_manual_scene_stops_and_leaves_manual_mode() {
    deadman("crane3d/crane3d-manual.toml");
}

/// Manual mode is the scene's: the same master switch on the base scene (no
/// `[operator]`) is refused — no mode 5, and no motion after the scene's move.
#[test]
fn a_scene_without_operator_refuses_manual_mode() {
    let run = run("paper-crane.toml", &MANUAL_PROFILE);
    assert!(modes(&run).iter().all(|(_, m)| *m != MANUAL_MODE_CODE));
    assert!(!moving(&run, 10_000, 33_000));
    assert_eq!(run.last().unwrap().mode, Mode::Ready);
}

/// The hoist lowers while the trolley travels in the profile's reversal: the winch's set
/// point is positive (paying out) for a while.
#[test]
fn the_profile_lowers_the_hoist_while_travelling() {
    let run = run("paper-crane-manual.toml", &MANUAL_PROFILE);
    let both = run
        .iter()
        .filter(|c| (21_000..24_000).contains(&c.now_ms))
        .filter(|c| c.setpoints[0].units() != 0 && c.setpoints[1].units() > 10_000)
        .count();
    assert!(both > 100, "{both} cycles travelling and lowering");
}

/// The travel of the drive `axis` (the set points' order: planar trolley, winch; 3D
/// bridge, trolley, hoist) over `run` from its set points, m (what a drive that follows
/// them travels).
fn travel(run: &[ReferenceCycle], axis: usize) -> f64 {
    run.iter()
        .map(|c| f64::from(c.setpoints[axis].units()) / UNITS_PER_M_PER_S * 0.01)
        .sum()
}

/// The move-taken-over EMCY (0xFF22) of `run`, exactly once: when, and its detail byte
/// (0 at once, 1 at the on-path stop's rest).
fn taken_over(run: &[ReferenceCycle]) -> (u32, u8) {
    let emcy = cob::EMCY + u16::from(CONTROLLER_NODE);
    let taken: Vec<(u32, u8)> = run
        .iter()
        .flat_map(|c| {
            c.frames
                .iter()
                .filter(|f| f.id() == emcy && f.data()[..2] == emcy::MOVE_TAKEN_OVER.to_le_bytes())
                .map(move |f| (c.now_ms, f.data()[5]))
        })
        .collect();
    assert_eq!(taken.len(), 1, "EMCY 0xFF22 once: {taken:?}");
    taken[0]
}

/// The operator takes over the scene's automatic move at 4 s (`sim::MANUAL_TAKEOVER`):
/// EMCY 0xFF22 *move taken over* once, detail 0 (at once), manual mode from that very
/// cycle (the status's mode byte as the cycle leaves it), the stick live (the load goes
/// on forward at half stick without a second centring), at rest after the release,
/// manual mode left at rest, ready. That the stick drives is judged against the same
/// take-over with the stick centred again 30 ms after it (the move's own stop alone):
/// the half stick's 5 s carry the trolley more than a metre farther.
#[test]
fn the_operator_takes_over_the_scene_s_move() {
    let scene = "paper-crane-manual.toml";
    let run = taken_over_at_once(scene, &MANUAL_TAKEOVER, 4_000);
    // The same take-over, the stick centred again at the next frame.
    let pulsed = self::run(scene, &pulsed(&MANUAL_TAKEOVER));
    let (held, stopped) = (travel(&run, 0), travel(&pulsed, 0));
    assert!(
        held - stopped > 1.0,
        "the stick carried the trolley {held:.3} m, its stop alone {stopped:.3} m"
    );
    println!(
        "take-over: the trolley {held:.3} m with the stick, {stopped:.3} m with its stop alone"
    );
    left_at_rest(&run);
}

/// `scenario` run on `scene`: to its end, the automatic move taken over in the cycle that
/// reads the deflection at `at_ms` (within the stick's frame period) — EMCY 0xFF22 once,
/// detail 0 (at once) — and manual mode from that very cycle (the status's mode byte as
/// the cycle leaves it).
fn taken_over_at_once(scene: &str, scenario: &Scenario, at_ms: u32) -> Vec<ReferenceCycle> {
    let run = run(scene, scenario);
    assert_eq!(run.len(), scenario.cycles as usize, "ran to the end");
    let (taken, how) = taken_over(&run);
    assert!(
        (at_ms..at_ms + 100).contains(&taken),
        "taken over at {taken} ms"
    );
    assert_eq!(how, emcy::TAKEN_OVER_AT_ONCE, "at once");
    let manual = run
        .iter()
        .find(|c| c.status_mode == MANUAL_MODE_CODE)
        .map(|c| c.now_ms)
        .expect("manual mode entered");
    assert_eq!(manual, taken, "manual mode in the take-over's cycle");
    run
}

/// After a take-over's release at 9 s: at rest before the request is withdrawn at 15 s,
/// manual mode left at rest, ready.
fn left_at_rest(run: &[ReferenceCycle]) {
    let rest = rests_from(run, 9_000, 15_000).expect("at rest before the withdrawal");
    assert!(rest < 15_000, "at rest from {rest} ms");
    let last = *modes(run).last().unwrap();
    assert_eq!(last.1, 1, "manual mode left at rest ({last:?})");
    assert_eq!(run.last().unwrap().mode, Mode::Ready);
}

/// `scenario` with the stick centred again one frame after each deflection: the
/// take-over with the move's own stop alone.
fn pulsed(scenario: &Scenario) -> Scenario {
    let mut events = Vec::new();
    for (i, e) in scenario.events.iter().enumerate() {
        events.push(*e);
        let next = scenario.events.get(i + 1);
        if matches!(e.action, Action::Stick(s) if s.demand != [0; 3]) {
            if let Some(n) = next {
                events.push(Event {
                    at_ms: e.at_ms + STICK_PERIOD_MS,
                    action: n.action,
                });
            }
        }
    }
    Scenario {
        events: Box::leak(events.into_boxed_slice()),
        ..*scenario
    }
}

/// The operator takes over the 3D scene's move halfway (`MANUAL_TAKEOVER_3D`): EMCY
/// 0xFF22 once, at 5 s, detail 0 (at once), manual mode from that very cycle, the
/// diagonal half stick live at once — against the same take-over with the stick centred
/// again 30 ms after it (the move's own stop alone), its 4 s carry the bridge more than
/// a metre farther forward and the trolley more than a metre farther back —, at rest
/// after the release, manual mode left at rest, ready.
#[test]
fn the_operator_takes_over_the_3d_scene_s_move() {
    let scene = "crane3d/crane3d-manual.toml";
    let run = taken_over_at_once(scene, &MANUAL_TAKEOVER_3D, 5_000);
    let stopped = self::run(scene, &pulsed(&MANUAL_TAKEOVER_3D));
    let (bridge, trolley) = (
        travel(&run, 0) - travel(&stopped, 0),
        travel(&run, 1) - travel(&stopped, 1),
    );
    println!("3D take-over: the stick carried the bridge {bridge:.3} m and the trolley {trolley:.3} m beyond the move's stop alone");
    assert!(bridge > 1.0, "the bridge {bridge:.3} m farther forward");
    assert!(trolley < -1.0, "the trolley {trolley:.3} m farther back");
    left_at_rest(&run);
}

/// A stop request 100 ms after the 3D take-over (`MANUAL_TAKEOVER_STOP_3D`, the QEMU
/// scenario of that cycle): taken over at once at 5 s; the stop answered (accepted) in
/// the cycle that reads it, and every status after it with that answer; the hand-over's stop, planned again from
/// where it is, ends the bridge and the trolley nearer than the same take-over with its
/// own stop alone (the stick centred again 30 ms after the deflection, no stop
/// request): by more than 0.1 m each, and sooner; the stick, still deflected after the
/// stop, moves nothing (every set point 0.0 from the stop's rest to the end); manual
/// mode left at rest.
#[test]
fn a_stop_after_the_3d_take_over_shortens_the_hand_over_s_stop() {
    let scene = "crane3d/crane3d-manual.toml";
    let run = taken_over_at_once(scene, &MANUAL_TAKEOVER_STOP_3D, 5_000);
    let answers: Vec<(u32, [u8; 8])> = run
        .iter()
        .flat_map(|c| {
            c.frames
                .iter()
                .filter(|f| f.id() == STATUS_ID && f.data()[0] == 1 && f.data()[1] != 0)
                .map(move |f| (c.now_ms, f.data().try_into().unwrap()))
        })
        .collect();
    assert!(!answers.is_empty(), "the stop answered");
    assert!(
        answers.iter().all(|(_, a)| a[1] == 1),
        "accepted: {answers:?}"
    );
    assert!(
        (5_100..5_110).contains(&answers[0].0),
        "answered at {} ms",
        answers[0].0
    );
    let alone = self::run(scene, &pulsed(&MANUAL_TAKEOVER_3D));
    let (bridge, trolley) = (
        travel(&alone, 0) - travel(&run, 0),
        travel(&alone, 1) - travel(&run, 1),
    );
    let rest = rests_from(&run, 5_100, 9_000).expect("at rest before the release");
    let rest_alone = rests_from(&alone, 5_100, 15_000).expect("the stop alone rests");
    println!(
        "stop during the hand-over's stop: the bridge {bridge:.3} m and the trolley \
         {trolley:.3} m nearer, at rest at {rest} ms (its stop alone: {rest_alone} ms)"
    );
    assert!(
        bridge > 0.1 && trolley > 0.1,
        "{bridge:.3} / {trolley:.3} m"
    );
    assert!(
        rest < rest_alone,
        "at rest at {rest} ms, alone at {rest_alone} ms"
    );
    // The stick held after the stop and released at 9 s: nothing moves again.
    assert!(!moving(&run, rest, u32::MAX), "moved after the stop's rest");
    let last = *modes(&run).last().unwrap();
    assert_eq!(last.1, 1, "manual mode left at rest ({last:?})");
    assert_eq!(run.last().unwrap().mode, Mode::Ready);
}

/// The hand-over refused on the planar scene (`MANUAL_HANDOVER_REFUSED`): the stick
/// deflected at 10.3 s during a move as fast as the limits allow, whose trolley no stop
/// of the generator's keeps within the room the operator leaves. EMCY 0xFF22 once, in
/// the cycle that reads the frame, detail 1; manual mode not entered then (mode 1) but
/// at the on-path stop's rest; the set points up to that rest exactly those of a stop
/// request (0x210) in the same cycle instead of the deflection; the load rests on the
/// move's path (trolley and winch the same share of their way, 5 m back and 1 m down)
/// short of its target; the stick live from the entry (the trolley goes forward at once,
/// no re-centring), at rest after the release, manual mode left at rest, ready.
#[test]
fn a_refused_hand_over_ends_the_move_with_the_planner_s_stop() {
    let scene = "paper-crane-manual.toml";
    let scenario = MANUAL_HANDOVER_REFUSED;
    let run = run(scene, &scenario);
    assert_eq!(run.len(), scenario.cycles as usize, "ran to the end");
    let (taken, how) = taken_over(&run);
    assert!(
        (10_300..10_400).contains(&taken),
        "taken over at {taken} ms"
    );
    assert_eq!(how, emcy::TAKEN_OVER_AT_REST, "at the on-path stop's rest");
    let entered = run
        .iter()
        .find(|c| c.status_mode == MANUAL_MODE_CODE)
        .map(|c| c.now_ms)
        .expect("manual mode entered");
    let rest = rests_from(&run, 9_600, entered).expect("the move ran");
    assert!(
        entered > taken && entered >= rest,
        "entered at {entered} ms, the stop at rest from {rest} ms"
    );
    // The same run with a stop request in the deflection's stead.
    let stop_events: Vec<Event> = scenario
        .events
        .iter()
        .map(|e| match e.action {
            Action::Stick(s) if s.demand != [0; 3] && e.at_ms == 10_300 => Event {
                at_ms: e.at_ms,
                action: Action::Request(Request::Stop { id: 3 }),
            },
            _ => *e,
        })
        .collect();
    let stopped = self::run(
        scene,
        &Scenario {
            events: Box::leak(stop_events.into_boxed_slice()),
            ..scenario
        },
    );
    let until = |r: &[ReferenceCycle]| -> Vec<Vec<i32>> {
        r.iter()
            .filter(|c| c.now_ms < entered)
            .map(|c| c.setpoints.iter().map(|s| s.units()).collect())
            .collect()
    };
    assert_eq!(
        until(&run),
        until(&stopped),
        "the planner's stop, to the unit"
    );
    let moved = |r: &[ReferenceCycle], axis: usize| {
        let part: Vec<ReferenceCycle> = r
            .iter()
            .filter(|c| (9_000..entered).contains(&c.now_ms))
            .cloned()
            .collect();
        travel(&part, axis)
    };
    let (trolley, winch) = (moved(&run, 0), moved(&run, 1));
    let fastest = run
        .iter()
        .filter(|c| c.now_ms < taken)
        .map(|c| c.setpoints[0].units().unsigned_abs())
        .max()
        .unwrap();
    let before: Vec<i32> = run
        .iter()
        .filter(|c| c.now_ms <= taken)
        .map(|c| c.setpoints[0].units())
        .collect();
    let steepest = before
        .windows(2)
        .map(|w| (w[1] - w[0]).unsigned_abs())
        .max()
        .unwrap();
    println!(
        "refused hand-over: the trolley at up to {:.3} m/s and {:.2} m/s² before it; the stop \
         rested after {trolley:.3} m of the trolley's -5 m and {winch:.3} m of the winch's 1 m; \
         manual mode from {entered} ms",
        f64::from(fastest) / UNITS_PER_M_PER_S,
        f64::from(steepest) / UNITS_PER_M_PER_S / 0.01
    );
    assert!(
        (-4.5..0.0).contains(&trolley),
        "short of the target: {trolley:.3} m"
    );
    assert!(
        (trolley / -5.0 - winch / 1.0).abs() < 1e-3,
        "on the path: {trolley:.4} m and {winch:.4} m"
    );
    let after = run
        .iter()
        .filter(|c| (entered..entered + 500).contains(&c.now_ms))
        .filter(|c| c.setpoints[0].units() > 0)
        .count();
    assert!(
        after > 10,
        "the stick drives at once: {after} cycles forward"
    );
    let rest = rests_from(&run, 17_000, 23_000).expect("at rest before the withdrawal");
    assert!(rest < 23_000, "at rest from {rest} ms");
    let last = *modes(&run).last().unwrap();
    assert_eq!(last.1, 1, "manual mode left at rest ({last:?})");
    assert_eq!(run.last().unwrap().mode, Mode::Ready);
}
