"""The 3D crane's state feedback per vertical plane through the virtual ECU
(scenes/crane3d/crane3d-feedback.toml) against three python-canopen CiA 402 drives —
bridge (node 4), trolley (1), hoist (2) — and a python-canopen two-axis CiA 410
inclinometer (node 5, cia410-inclinometer-2axis.eds), which measures the rope's slopes
of a spherical pendulum the drives move (load3d.py, in the drives' process: `tan α =
(x_C − x)/z_C` in the x–z plane, slope long16; `tan β = (y_C − y)/z_C` in the y–z
plane, slope lateral16).

* The two-axis inclinometer is commissioned as the commissioning file says: resolution
  0x6000 = 10, TPDO1 = slope long16 and slope lateral16 (0x1A00 count 2, 4 bytes on
  0x185) on every SYNC, heartbeat 0x1017 = 100, each written and read back, NMT start —
  what was written read from the python node's own dictionary, every request and answer
  decoded with cantools; its TPDO1 frames are 4 bytes and decode as
  `TPDO1_Inclinometer2`. A healthy 3D move, (12, 3, 8) → (13, 3.5, 7) in 4 s, ends on
  target with the feedback on (no EMCY), its corrections in the set points (up to
  0.19 m/s off the host's feedforward-only computation for the bridge, 0.055 m/s for
  the trolley), let go at rest within 20 mm and 0.1° (5 mm, 0.02° seen).
* A swinging start: the rope at slopes 3° (x–z) and 2° (y–z), at a turning point (a
  3.6° swing in the vertical plane 34° off the runway), when the same move is commanded;
  5 s after the move each plane swings less than 0.1° and the load is within ±50 mm of
  the target horizontally (seen: (0.048°, 0.031°), 12 mm; the feedback let it go 3 s
  after the move, below its 0.06° rest hold). The same run on the feedforward-only
  scene (scenes/crane3d/crane3d.toml) ends swinging (3.4°, 2.2°), ±0.49 m — the test
  can fail.
* The inclinometer lost 1.5 s into the move (its TPDO1 stops, the node still beats):
  EMCY 0xFF20 naming node 5 with reason 1, four cycles after the last reading (3–6
  allowed, as the planar test), the move runs to its end (set points until 546 cycles
  after the answer seen, the feedback damping on the swing estimated from the drives'
  motion), ready, no fault, the drives on the target (bridge +2.9 mm, trolley −1.9 mm,
  hoist 0 seen; 50 mm and 2 mm allowed), the load swinging less than 1° (0.47° seen,
  where feedforward alone ends the same move within 2 mm and 0.014° on this lag-free
  plant: the estimate assumes the model's drive lags; interop/README.md).
* In every run every set point is within `DriveLimits::LAB_3D` (the feedback's
  corrections reach the bridge's 3 m/s² and the trolley's 2 m/s² exactly) and every
  frame decodes against can/crane.dbc.

The load's state (each plane's swing, where it hangs) is the pendulum's own, read from
the drives' process: the judge is the plant, not the controller's estimate.
"""

import math
import subprocess
import time

from rig import ACCEPTED, ECU, MODE, ROOT, dbc
from test_black_box import cycles_between, wait_rest
from test_crane3d import HOIST, LIMITS, NODES, rpdo_cycles, setpoint_rows
from test_feedback import ANGLE_LOST, FEEDBACK_OFF, commissioning_of, feedback_off
from test_interop import assert_setpoints_within_limits, moving_part, rigs  # noqa: F401

FEEDBACK_SCENE = "scenes/crane3d/crane3d-feedback.toml"
FEEDFORWARD_SCENE = "scenes/crane3d/crane3d.toml"
INCLINOMETER = 5  # scenes/crane3d/commissioning.toml [inclinometer]
HEARTBEAT5, TPDO5 = 0x700 + INCLINOMETER, 0x180 + INCLINOMETER
MOVE = (13.0, 3.5, 7.0)  # test_crane3d.py's move from the scene's rest (12, 3, 8), m
DURATION = 4  # s
UM = 1e6


# --- helpers -----------------------------------------------------------------------------
def feedback_rig(rigs, **kwargs):
    """A rig on the 3D feedback scene with the two-axis inclinometer, ready, the
    inclinometer operational: its heartbeat says so and its TPDO1 comes."""
    rig = rigs(scene=FEEDBACK_SCENE, drive_args=["--inclinometer"], **kwargs)
    rig.wait_mode("ready")
    rig.wait(
        lambda: any(d == b"\x05" for (_, d) in rig.recorder.with_id(HEARTBEAT5)) and rig.recorder.with_id(TPDO5),
        3,
        "the inclinometer operational",
    )
    return rig


def expected_inclinometer_writes():
    """What the controller writes into the two-axis inclinometer (controller/src/
    commissioning.rs, `InclinometerSetup::configuration` with `axes = 2`): resolution
    0.01°, TPDO1 = slope long16 then slope lateral16 on every SYNC, heartbeat 100 ms."""
    cob = 0x180 + INCLINOMETER
    return [
        (0x6000, 0, 10),
        (0x1800, 1, 0x8000_0000 | cob),
        (0x1A00, 0, 0),
        (0x1A00, 1, 0x6010_0010),
        (0x1A00, 2, 0x6020_0010),
        (0x1A00, 0, 2),
        (0x1800, 2, 1),
        (0x1800, 1, cob),
        (0x1017, 0, 100),
    ]


def distance(load, target):
    """How far from `target` (x, y) the load gets horizontally, m, swinging as it swings
    with the bridge and the trolley still: their offset plus the swing's reach."""
    offset = math.hypot(load["bridge_m"] - target[0], load["trolley_m"] - target[1])
    return offset + load["rope_m"] * math.sin(math.radians(load["still_amplitude_deg"]))


def swings(load):
    """Each plane's swing (x–z, y–z) with the drives still, °, and the whole swing's."""
    return (
        round(load["xz_still_amplitude_deg"], 3),
        round(load["yz_still_amplitude_deg"], 3),
        round(load["still_amplitude_deg"], 3),
    )


def accepted_at(log, request_id=1):
    return next(t for (t, d) in log.sent(0x190) if d[0] == request_id and d[1] == ACCEPTED)


def slopes_sent(log):
    """The inclinometer's TPDO1s as cantools decodes them: (time, long °, lateral °)."""
    return [(t, m["slope_long16"], m["slope_lateral16"]) for (t, m) in log.decoded(TPDO5)]


# --- 1. commissioned, and a healthy 3D move with the feedback on ---------------------------
def test_the_two_axis_inclinometer_is_commissioned_and_a_healthy_3d_move_keeps_the_feedback_on(rigs):
    rig = feedback_rig(rigs)
    # The python node's own dictionary holds what was written: 0x6000, TPDO1 with both
    # slopes (count 2), synchronous, its COB-ID valid, 0x1017; operational.
    sensor = rig.inclinometer()
    od = {k: int.from_bytes(bytes.fromhex(v), "little") for k, v in sensor["od"].items()}
    final = {(index, sub): value for index, sub, value in expected_inclinometer_writes()}
    for (index, sub), value in final.items():
        assert od.get(f"{index:04X}:{sub}") == value, (hex(index), sub, od)
    assert od["1A00:0"] == 2 and (od["1A00:1"], od["1A00:2"]) == (0x6010_0010, 0x6020_0010)
    assert sensor["nmt"] == "OPERATIONAL" and sensor["started"] == [["0x185", 1, ["0x6010", "0x6020"]]]
    rig.move3d(1, *MOVE, DURATION)
    assert rig.answer(1) == (ACCEPTED, 0)
    time.sleep(DURATION)
    end = wait_rest(rig, 6)
    load = rig.load()
    status = rig.status()
    log = rig.close()
    log.assert_decodes()
    # Commissioned as the commissioning file says: pre-operational, identity, each value
    # written and read back, started — every request and answer decoded by cantools.
    want = [("nmt", 0x80, INCLINOMETER), ("r", 0x1000, 0)] + [("r", 0x1018, s) for s in (1, 2, 3, 4)]
    for index, sub, value in expected_inclinometer_writes():
        want += [("w", index, sub, value), ("r", index, sub)]
    want.append(("nmt", 0x01, INCLINOMETER))
    got = commissioning_of(log, INCLINOMETER)
    assert got == want, got
    answers = [m for (_, m) in log.decoded(0x580 + INCLINOMETER)]
    assert len(answers) == len(want) - 2 and not [a for a in answers if a["command"] == 0x80], "each answered"
    assert answers[0]["index"] == 0x1000 and answers[0]["data"] & 0xFFFF == 410, "a CiA 410 device"
    requests = [w for w in want if w[0] != "nmt"]
    for i, (request, a) in enumerate(zip(requests, answers)):
        assert (a["index"], a["subindex"]) == request[1:3], (request, a)
        if request[0] == "w":
            assert a["command"] == 0x60, (request, a)
        elif requests[i - 1][0] == "w":
            size = 4 - ((a["command"] >> 2) & 3)
            assert a["data"] & ((1 << (8 * size)) - 1) == requests[i - 1][3], ("read back", request, a)
    # Its TPDO1: 4 bytes, the DBC's TPDO1_Inclinometer2, both slopes in degrees; the
    # move swings the load by degrees in both planes (4.7° and 2.3° seen).
    tpdos = log.by_others(TPDO5)
    assert tpdos and all(len(d) == 4 for (_, d) in tpdos), {len(d) for (_, d) in tpdos}
    assert dbc().get_message_by_frame_id(TPDO5).name == "TPDO1_Inclinometer2"
    slopes = slopes_sent(log)
    assert len(slopes) == len(tpdos)
    longest = max(abs(a) for (_, a, _) in slopes)
    lateral = max(abs(b) for (_, _, b) in slopes)
    print(f"the move swung the load up to {longest:.2f}° (x–z) and {lateral:.2f}° (y–z)")
    assert 1.0 < longest < 15.0 and 1.0 < lateral < 15.0, (longest, lateral)
    beats = [m["nmt_state"] for (_, m) in log.decoded(HEARTBEAT5)]
    assert beats[0] == 0 and beats[-1] == 5, "boot-up, then operational"
    # The feedback on: no EMCY, nothing ignored, its corrections in the set points (off
    # the host's feedforward-only computation of the same move).
    assert not log.sent(0x090), [d.hex() for (_, d) in log.sent(0x090)]
    assert status[3:6] == [MODE["ready"], 0, 0], status
    out = subprocess.run(
        [ECU, "--scene", FEEDFORWARD_SCENE, "--reference", ",".join(str(v) for v in (*MOVE, DURATION))],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    host = moving_part([tuple(int(v) for v in line.split()) for line in out.stdout.splitlines()])
    bus = moving_part(setpoint_rows(rpdo_cycles(log)))
    worst = [max(abs(p[i] - q[i]) for p, q in zip(bus, host)) for i in range(3)]
    print(f"set points off the feedforward's by up to {worst} um/s (bridge, trolley, hoist)")
    assert worst[0] > 1_000 and worst[1] > 1_000, f"the set points are the feedforward's to {worst} um/s"
    assert_setpoints_within_limits(log, LIMITS)
    # On target, at rest, let go: within the 20 mm the feedback lets go at, swinging less
    # than 0.1° (5 mm, 0.02° seen).
    print(f"at rest: {distance(load, MOVE) * 1e3:.2f} mm from the target, swing {swings(load)}°")
    assert distance(load, MOVE) < 0.020 and load["still_amplitude_deg"] < 0.1, load
    assert abs(load["rope_m"] - MOVE[2]) < 0.002, load
    assert setpoint_rows(rpdo_cycles(log))[-1] == (0, 0, 0)
    for i, n in enumerate(NODES):
        assert abs(end[n]["position"] - MOVE[i] * UM) < 20e3, (n, end[n]["position"])


# --- 2. a swinging start --------------------------------------------------------------------
SWING = (3.0, 2.0)  # the rope's slopes at the command, ° (x–z, y–z): 3.6° towards 33.7°
SETTLE = 5.0  # s after the move's end


def swinging_start(rig):
    """The load swinging (at a turning point, slopes `SWING`) when the 3D move is
    commanded. Returns the load at the move's end and `SETTLE` s later."""
    rig.drive(f"swing {SWING[0]} {SWING[1]}")
    rig.move3d(1, *MOVE, DURATION)
    assert rig.answer(1) == (ACCEPTED, 0)
    accepted = time.time()
    time.sleep(max(0.0, accepted + DURATION - time.time()))
    at_end = rig.load()
    samples = []
    for k in range(int(SETTLE * 2)):
        time.sleep(max(0.0, accepted + DURATION + (k + 1) * 0.5 - time.time()))
        samples.append(rig.load())
    return at_end, samples


def test_a_load_swinging_in_both_planes_when_a_3d_move_is_commanded_ends_on_target(rigs):
    rig = feedback_rig(rigs)
    at_end, samples = swinging_start(rig)
    end = samples[-1]
    status = rig.status()
    log = rig.close()
    log.assert_decodes()
    for k, s in enumerate(samples):
        print(f"{(k + 1) * 0.5:.1f} s after: {distance(s, MOVE) * 1e3:.1f} mm, swing {swings(s)}°")
    print(f"at the move's end {distance(at_end, MOVE) * 1e3:.1f} mm, swing {swings(at_end)}°")
    # SETTLE s after the move: each plane swings less than 0.1° (the acceptance the
    # feedback's 0.06° rest hold is set below), the load within ±50 mm of the target
    # horizontally (offset plus reach) and on the rope's length, let go.
    assert end["xz_still_amplitude_deg"] < 0.1 and end["yz_still_amplitude_deg"] < 0.1, swings(end)
    assert end["still_amplitude_deg"] < 0.1, swings(end)
    assert distance(end, MOVE) < 0.050, end
    assert abs(end["rope_m"] - MOVE[2]) < 0.002, end
    assert setpoint_rows(rpdo_cycles(log))[-1] == (0, 0, 0), "let go at rest"
    # The slopes the controller had when it accepted the move (the first reading after
    # its answer): the load swinging in both planes, long16 the x–z slope, lateral16 the
    # y–z one; the feedback on throughout.
    t_accept = accepted_at(log)
    _, long16, lateral16 = next(s for s in slopes_sent(log) if s[0] > t_accept)
    assert abs(long16 - SWING[0]) < 0.2 and abs(lateral16 - SWING[1]) < 0.2, (long16, lateral16)
    assert not log.sent(0x090), f"the feedback stayed on: {[d.hex() for (_, d) in log.sent(0x090)]}"
    assert status[3:6] == [MODE["ready"], 0, 0], status
    assert_setpoints_within_limits(log, LIMITS)


def test_the_same_swinging_start_with_feedforward_alone_ends_swinging(rigs):
    """The 3D crane's feedforward on the same plant: the swing it was not told about stays
    in both planes — what the test above must tell apart."""
    rig = rigs(scene=FEEDFORWARD_SCENE)
    rig.wait_mode("ready")
    at_end, samples = swinging_start(rig)
    end = samples[-1]
    log = rig.close()
    log.assert_decodes()
    assert not log.sent(0x600 + INCLINOMETER), "no inclinometer commissioned"
    assert_setpoints_within_limits(log, LIMITS)
    print(f"feedforward alone, {SETTLE} s after: {distance(end, MOVE) * 1e3:.1f} mm, swing {swings(end)}°")
    assert end["xz_still_amplitude_deg"] > 1.0 and end["yz_still_amplitude_deg"] > 1.0, swings(end)
    assert distance(end, MOVE) > 0.2, end


# --- 3. the inclinometer lost mid-move -----------------------------------------------------
def test_the_inclinometer_lost_mid_move_falls_back_and_the_move_completes(rigs):
    rig = feedback_rig(rigs)
    rig.move3d(1, *MOVE, DURATION)
    assert rig.answer(1) == (ACCEPTED, 0)
    time.sleep(1.5)
    rig.drive("lose")
    rig.wait(lambda: rig.emcys(), 1, "an EMCY")
    time.sleep(DURATION - 1.5)
    end = wait_rest(rig, 6)
    load = rig.load()
    status = rig.status()
    log = rig.close()
    log.assert_decodes()
    # One EMCY: 0xFF20, error register 0x80, fault 15 (feedback off), node 5, reason 1.
    sent = [d for (_, d) in log.sent(0x090)]
    assert sent == [bytes([0x20, 0xFF, 0x80, 15, INCLINOMETER, ANGLE_LOST, 0, 0])], [d.hex() for d in sent]
    decoded = [m for (_, m) in log.decoded(0x090)][0]
    assert (decoded["error_code"], decoded["fault"], decoded["node"], decoded["detail"]) == (
        FEEDBACK_OFF,
        15,
        INCLINOMETER,
        ANGLE_LOST,
    ), decoded
    # Three cycles bridged, the fourth without an angle switches (a cycle of slack for
    # the real time, as the planar test allows); the node still beats.
    t_last = log.by_others(TPDO5)[-1][0]
    t_off = feedback_off(log)[0][0]
    print(f"EMCY {cycles_between(log, t_last, t_off)} cycles after the last reading")
    assert 3 <= cycles_between(log, t_last, t_off) <= 6, cycles_between(log, t_last, t_off)
    assert [t for (t, _) in log.by_others(HEARTBEAT5) if t > t_off], "the node still beats"
    # The move ran to its end on the swing estimated from the drives' motion (both planes
    # lost), the feedback damping until the crane rests, then letting go: ready, no
    # fault, set points at least until the move's planned end (407 cycles of the host's
    # computation) and zero within 10 s after it, the drives on the target.
    assert status[3:6] == [MODE["ready"], 0, 0], status
    t_accept = accepted_at(log)
    cycles = rpdo_cycles(log)
    rows = setpoint_rows(cycles)
    moving = [t for ((t, _), r) in zip(cycles, rows) if t > t_accept and any(r)]
    n = cycles_between(log, t_accept, max(moving))
    print(f"set points until {n} cycles after the answer; at rest: swing {swings(load)}°")
    assert 400 <= n <= 1400, n
    assert rows[-1] == (0, 0, 0)
    for i, node in enumerate(NODES):
        off = end[node]["position"] - MOVE[i] * UM
        print(f"node {node}: {off / 1e3:+.2f} mm from the target")
        assert abs(off) < (2e3 if node == HOIST else 50e3), (node, off)
    assert load["still_amplitude_deg"] < 1.0, load
    assert_setpoints_within_limits(log, LIMITS)
