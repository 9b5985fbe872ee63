"""The crane in three dimensions (scenes/crane3d/crane3d.toml, feedforward only) against
the independent CANopen stack of `rig.py`: three python-canopen CiA 402 drives — bridge
(node 4, x along the runway, u1), trolley (node 1, y along the bridge, u2), hoist (node 2,
rope length, u3), the rows of scenes/crane3d/commissioning.toml in its order — and a
supervisor that sends the 3D move frame (0x310, encoded by cantools from the DBC's
Move3d_Controller) or writes the same request into 0x2000 over SDO.

* Commissioning: each drive gets the planar test's writes (CSV, interpolation period,
  the three PDO mappings, heartbeat producer and consumer, quick stop, 0x6080 from its
  row), each read back, then NMT start, nodes in the file's order; every cycle then
  carries one RPDO1 to each drive, bridge, trolley, hoist, before the SYNC.
* A 3D move (13, 3.5, 7) in 4 s from where the scene rests (12, 3, 8): answered once,
  accepted; the set points, decoded by cantools, equal the host's `ecu --scene …
  --reference 13,3.5,7,4` cycle by cycle within 2 µm/s (the planar test's tolerance),
  aligned as the planar test aligns them (from the first cycle with a set point not
  zero to the last; 407 cycles). Seen: 0, or 1 µm/s in one set point of 1,221 (the
  trolley's in the move's cycle 278), depending on the cycle of the controller's clock
  the move is accepted in (1 at cycles 152, 156, 160, 173, 181; 0 at 145, 147, 153, 163,
  167, 175, 176, 182) — in all 13 runs exactly where (t − t_start)/T in f64, t = cycle ·
  0.01 s, differs in its last bit from the exact time of the move, so a set point on a
  rounding edge of its µm/s flips. The drives end on the target within 1 mm (0.15 µm
  seen); the way back through 0x2000 (command 4) ends on the start; the same move again
  as fast as the limits allow (duration 0) equals `--reference 13,3.5,7,0` (396 cycles,
  0 µm/s apart seen); a move too fast for the bridge is rejected with the 3D crane's own
  reason (12, bridge velocity).
* A stop mid-move: at rest on the move's straight path, short of the target in every
  axis and never past it on the way.
* A bridge fault mid-move: quick stop (EMCY 0xFF02 naming node 4, the other drives
  braking on their quick-stop ramps), halted, a reset makes the crane ready.
* The planar crane answers a 3D move, by frame or through 0x2000, rejected, reason 3.

Every set point of every run is within `controller::setpoint::DriveLimits::LAB_3D`, and
every frame decodes against can/crane.dbc.
"""

import struct
import time

from rig import ACCEPTED, MODE, REJECTED, STOP, dbc
from test_black_box import (
    answers,
    cycles_between,
    last_motion,
    off_beat,
    off_beat_statuses,
    positions,
    wait_rest,
)
from test_interop import (
    assert_commissioned_after_close,
    assert_setpoints_equal_the_hosts,
    assert_setpoints_within_limits,
    emcy,
    moving_part,
    rigs,  # noqa: F401
)

SCENE = "scenes/crane3d/crane3d.toml"
BRIDGE, TROLLEY, HOIST = 4, 1, 2
NODES = (BRIDGE, TROLLEY, HOIST)  # the model's inputs u1, u2, u3 and the file's rows
START = (12.0, 3.0, 8.0)  # the scene's start: where the crane rests until a command, m
# 0x6080 from the commissioning file's max_velocity (3.3, 2.2, 2.2 m/s), µm/s.
MAX_SPEED = {BRIDGE: 3_300_000, TROLLEY: 2_200_000, HOIST: 2_200_000}
# controller::setpoint::DriveLimits::LAB_3D: (m/s, m/s²).
LIMITS = {BRIDGE: (3.0, 3.0), TROLLEY: (2.0, 2.0), HOIST: (2.0, 3.0)}
BRIDGE_VELOCITY, INVALID = 12, 3  # rejection reasons (docs/COMMANDS.md)
UM = 1e6  # µm per m
MM = 1e3  # µm per mm
H = 0.01  # s


# --- helpers -----------------------------------------------------------------------------
def rpdo_cycles(log, nodes=NODES):
    """Each cycle's RPDO1s as cantools decodes them from the log: (the SYNC's time,
    [(node, controlword, target velocity µm/s), …] in the order sent)."""
    by_cob = {0x200 + n: n for n in nodes}
    cycles, cycle = [], []
    for t, sender, can_id, _, decoded in log.frames:
        if sender != "ecu":
            continue
        if can_id in by_cob:
            cycle.append((by_cob[can_id], decoded["controlword"], round(decoded["target_velocity"] * UM)))
        elif can_id == 0x080:
            cycles.append((t, cycle))
            cycle = []
    return cycles


def commissioning_cycles(log, nodes=NODES):
    """The drives each cycle's commissioning frames (SDO requests, addressed NMT) went
    to, in the order sent: (the SYNC's time, [node, …]) for the cycles that had any."""
    out, cycle = [], []
    for t, sender, can_id, data, _ in log.frames:
        if sender != "ecu":
            continue
        if can_id - 0x600 in nodes:
            cycle.append(can_id - 0x600)
        elif can_id == 0x000 and data[1] in nodes:
            cycle.append(data[1])
        elif can_id == 0x080:
            if cycle:
                out.append((t, cycle))
            cycle = []
    return out


def setpoint_rows(cycles, start=0.0, end=float("inf")):
    """The set points of the cycles whose SYNC is in [start, end), in NODES order (0 for a
    drive not sent one)."""
    rows = []
    for t, cycle in cycles:
        if start <= t < end:
            got = {n: v for (n, _, v) in cycle}
            rows.append(tuple(got.get(n, 0) for n in NODES))
    return rows


def arrival(log, can_id, data):
    """When the ECU received the frame (its last occurrence)."""
    times = [t for (t, d) in log.by_others(can_id) if d == data]
    assert times, f"{can_id:03X}#{data.hex()} not in the log"
    return times[-1]


def assert_answered_once(log, request_id, received, answer, within=0.06):
    """`request_id`, received at `received`, got exactly one answer, `answer`: the first
    status frame naming it, within `within` s, gives it; no other status frame in a cycle
    without a heartbeat names it (the periodic status goes with the heartbeat and repeats
    the last answer: an answer in a cycle with a heartbeat is that cycle's status frame, so
    only off-beat frames can be counted — the requests are sent between two beats); and it
    is the only change of the status's (id, answer, reason) naming it."""
    naming = [(t, list(d[:3])) for (t, d) in log.sent(0x190) if t > received and d[0] == request_id]
    assert naming and naming[0][1] == [request_id, *answer], naming[:2]
    assert naming[0][0] - received < within, naming[0][0] - received
    own = [t for (t, s) in off_beat_statuses(log, received, float("inf")) if s[0] == request_id]
    assert own in ([], [naming[0][0]]), f"answered again at {own}"
    given = [k for (_, k) in answers(log) if k[0] == request_id]
    assert given == [(request_id, *answer)], given


def at(dump, point, tol_um):
    """Every drive at standstill within `tol_um` of `point` (bridge, trolley, hoist; m)."""
    return all(
        dump[n]["velocity"] == 0 and abs(dump[n]["position"] - p * UM) < tol_um for n, p in zip(NODES, point)
    )


def where(dump):
    return tuple(dump[n]["position"] for n in NODES)


# --- 1 and 2: commissioning, a 3D move by frame and one through 0x2000 ---------------------
def test_three_drives_commissioned_and_a_3d_move_equal_to_the_hosts_by_frame_and_by_sdo(rigs):
    target, duration = (13.0, 3.5, 7.0), 4
    rig = rigs(scene=SCENE)
    rig.wait_mode("ready")
    assert rig.sdo_u(0x2003, 2) == 0b111, "three drives commissioned"
    before = rig.dump()
    assert sorted(before) == sorted(NODES)
    assert where(before) == tuple(p * UM for p in START), where(before)
    # A 3D crane's own rejection: 10 m along the runway in 6 s is beyond the bridge's
    # 3 m/s (the planner ranks bridge reasons before the trolley's).
    rig.move3d(9, 22.0, 3.0, 7.0, 6)
    assert rig.answer(9) == (REJECTED, BRIDGE_VELOCITY)
    off_beat(rig)
    frame = rig.move3d(1, *target, duration)
    assert rig.answer(1) == (ACCEPTED, 0)
    rig.wait(lambda: any(d["velocity"] for d in rig.dump().values()), 1, "motion")
    rig.wait(lambda: at(rig.dump(), target, 5 * MM), duration + 3, "the end of the move")
    end = wait_rest(rig, 2)
    # Back to the start through the dictionary (a PLC without PDOs): the fields first,
    # then command 4 into 0x2000:2 submits them.
    rig.request3d_sdo(2, *START, duration)
    off_beat(rig)
    rig.submit_sdo()
    assert rig.answer(2) == (ACCEPTED, 0)
    rig.wait(lambda: any(d["velocity"] for d in rig.dump().values()), 1, "motion")
    rig.wait(lambda: at(rig.dump(), START, 5 * MM), duration + 3, "the end of the move back")
    back = wait_rest(rig, 2)
    # Again, as fast as the limits allow (duration 0).
    off_beat(rig)
    fastest = rig.move3d(3, *target, 0)
    assert rig.answer(3) == (ACCEPTED, 0)
    rig.wait(lambda: any(d["velocity"] for d in rig.dump().values()), 1, "motion")
    rig.wait(lambda: at(rig.dump(), target, 5 * MM), duration + 3, "the end of the fastest move")
    again = wait_rest(rig, 2)
    status = rig.status()
    log = rig.close()
    log.assert_decodes()
    # What the controller wrote into each drive, read back from the drive's own dictionary,
    # and the sequence of requests that did it.
    assert_commissioned_after_close(end, log, max_speed=MAX_SPEED)
    nmt = [d for (_, d) in log.sent(0x000)]
    assert sorted(nmt) == sorted(bytes([c, n]) for c in (0x80, 0x01) for n in NODES), nmt
    # One commissioning frame per drive and cycle, in the file's order (in parallel: a
    # drive a cycle ahead may be started first).
    for t, nodes in commissioning_cycles(log):
        assert nodes == sorted(nodes, key=NODES.index) and len(set(nodes)) == len(nodes), (t, nodes)
    assert status[3:6] == [MODE["ready"], 0, 0], "ready, no fault, nothing ignored"
    assert not log.sent(0x090), "no EMCY"
    # The move frame as cantools reads it, and each request answered once.
    assert [m for (_, m) in log.decoded(0x310) if m["request_id"] == 1] == [
        {"request_id": 1, "target_x": 13.0, "target_y": 3.5, "target_z": 7.0, "duration": 4}
    ]
    assert_answered_once(log, 1, arrival(log, 0x310, frame), (ACCEPTED, 0))
    submit = [t for (t, d) in log.by_others(0x610) if d[:5] == bytes([0x2F, 0x00, 0x20, 0x02, 4])]
    assert len(submit) == 1, "one submission"
    assert_answered_once(log, 2, submit[0], (ACCEPTED, 0))
    t_fastest = arrival(log, 0x310, fastest)
    assert_answered_once(log, 3, t_fastest, (ACCEPTED, 0), within=0.16)  # a search of up to 15 cycles
    # Every cycle since the drives were linked: one RPDO1 to each, in the file's order.
    cycles = rpdo_cycles(log)
    linked = next(i for i, (_, c) in enumerate(cycles) if len(c) == len(NODES))
    odd = [(round(t, 3), c) for (t, c) in cycles[linked:] if [n for (n, _, _) in c] != list(NODES)]
    assert not odd, odd[:5]
    assert all(cw == 0x0F for (_, c) in cycles[linked + 10 :] for (_, cw, _) in c), "enable operation"
    # The first move's set points are the host's, cycle by cycle.
    rows = setpoint_rows(cycles, end=submit[0])
    worst = assert_setpoints_equal_the_hosts(log, *target, duration, scene=SCENE, nodes=NODES, rows=rows)
    cycle = int(next(t for (t, k) in answers(log) if k == (1, ACCEPTED, 0)) * 100)  # the ECU's clock
    print(f"set points: {len(moving_part(rows))} cycles from cycle {cycle}, "
          f"largest difference from the host's {worst} um/s")
    # The fastest move: the duration the controller chose is the host's too (the moves
    # are equally long), and so are its set points.
    fast = setpoint_rows(cycles, start=t_fastest)
    worst = assert_setpoints_equal_the_hosts(log, *target, 0, scene=SCENE, nodes=NODES, rows=fast)
    print(f"as fast as the limits allow: {len(moving_part(fast))} cycles, {worst} um/s from the host's")
    assert len(moving_part(fast)) < len(moving_part(rows)), "faster than 4 s"
    # The drives integrate them (position actual), and end on the target, then the start.
    for i, n in enumerate(NODES):
        integrated = START[i] * UM + sum(r[i] for r in rows) * H
        assert abs(end[n]["position"] - integrated) < 1, (n, end[n]["position"], integrated)
        assert abs(end[n]["position"] - target[i] * UM) < 1 * MM, (n, end[n]["position"])
        assert abs(back[n]["position"] - START[i] * UM) < 1 * MM, (n, back[n]["position"])
        assert abs(again[n]["position"] - target[i] * UM) < 1 * MM, (n, again[n]["position"])
        print(f"node {n}: {end[n]['position'] - target[i] * UM:+.3f} um from the target, "
              f"{back[n]['position'] - START[i] * UM:+.3f} um from the start after the way back")
    assert_setpoints_within_limits(log, LIMITS)


# --- 3: a stop mid-move ---------------------------------------------------------------------
def test_a_stop_mid_move_rests_on_the_path_short_of_the_target_never_past_it(rigs):
    """(12, 3, 8) → (14, 4.5, 6.5) in 8 s, stopped 2.5 s in: at rest about halfway (0.44-0.56
    of the way seen; stopped 2.0-3.5 s in, 0.27-0.78). A stop the limits cannot fit into
    what is left of the move lets the move run on to its target (docs/COMMANDS.md): so
    does a stop 2.5 s into the same move in 5 s, which leaves no room to brake (the
    interop README has the instants tried)."""
    target, duration, stop_after = (14.0, 4.5, 6.5), 8, 2.5
    rig = rigs(scene=SCENE)
    rig.wait_mode("ready")
    rig.move3d(1, *target, duration)
    assert rig.answer(1) == (ACCEPTED, 0)
    t_accept = next(t for (t, s) in rig.statuses() if s[:2] == [1, ACCEPTED])
    rest, log = stop_mid_move(rig, t_accept + stop_after, duration)
    t_accept = next(t for (t, k) in answers(log) if k == (1, ACCEPTED, 0))
    t_end = last_motion(log, t_accept, nodes=NODES)
    assert cycles_between(log, t_accept, t_end) <= duration * 100, "never later than the move"
    fractions = stopped_short(log, rest, START, target, t_accept, t_end)
    # On the move's straight path (the load hangs still under the trolley at rest): the
    # same fraction of the way in every axis, and well short of the target.
    assert max(fractions) - min(fractions) < 0.01, f"off the straight path: {fractions}"
    print(f"at rest {fractions[0]:.4f} of the way, {cycles_between(log, t_accept, t_end)} cycles after the answer")
    assert 0.2 < fractions[0] < 0.9, f"stopped {fractions[0]:.3f} of the way"
    assert_setpoints_within_limits(log, LIMITS)


def stop_mid_move(rig, at, duration):
    """Stop request 2 (0x210) sent at `at` (the supervisor's clock), off the SYNC's beat:
    accepted, the drives at rest within `duration` s (`wait_rest`), no fault and no EMCY,
    every frame decoded, the stop answered exactly once. Returns the rest (as `wait_rest`
    read it) and the closed rig's log."""
    time.sleep(max(0.0, at - time.time()))
    off_beat(rig, delay=0.02)
    rig.command(2, STOP)
    assert rig.answer(2) == (ACCEPTED, 0)
    rest = wait_rest(rig, duration)
    status = rig.status()
    log = rig.close()
    log.assert_decodes()
    assert status[3:6] == [MODE["ready"], 0, 0], "a stop is no fault"
    assert not log.sent(0x090)
    stop = bytes([2, STOP, 0, 0, 0, 0, 0, 0])
    assert_answered_once(log, 2, arrival(log, 0x210, stop), (ACCEPTED, 0))
    return rest, log


def stopped_short(log, rest, start, target, t_accept, t_end, nodes=NODES):
    """Each drive of `nodes`, stopped on its way from `start` to where it stands for
    `target` (m, in the nodes' order): never past that, at rest (`rest`, as `wait_rest`
    read it) nor on the way (position actual, every SYNC from `t_accept` to half a
    second after `t_end`), within the planar black-box test's 5 mm. Returns the fraction
    of its way each drive rests at."""
    tol = 5 * MM
    fractions = []
    for i, n in enumerate(nodes):
        x0, x1, x = start[i] * UM, target[i] * UM, rest[n]["position"]
        sign = 1 if x1 > x0 else -1
        assert sign * (x - x1) <= tol, f"node {n} rests at {x / UM:.4f} m, for the target {target[i]}"
        way = positions(log, n, t_accept, t_end + 0.5)
        assert max(sign * (v - x1) for v in way) <= tol, f"node {n} passed where it stands for the target"
        fractions.append((x - x0) / (x1 - x0))
    return fractions


# --- 4: the bridge drive faults --------------------------------------------------------------
def test_a_bridge_fault_mid_move_quick_stops_halts_and_a_reset_makes_it_ready(rigs):
    rig = rigs(scene=SCENE)
    rig.wait_mode("ready")
    rig.move3d(1, 13.0, 3.5, 7.0, 4)
    assert rig.answer(1) == (ACCEPTED, 0)
    rig.wait(lambda: rig.dump()[BRIDGE]["velocity"] != 0, 1, "motion")
    time.sleep(1.0)
    rig.drive("fault 4")  # statusword bit 3 and EMCY 0x2310 from the bridge
    rig.wait_mode("quick stop", 1)
    rig.wait_mode("halted", 5)
    assert rig.status()[4] == 3, "drive fault"
    rig.wait(lambda: all(d["velocity"] == 0 for d in rig.dump().values()), 3, "standstill")
    halted = rig.dump()
    assert halted[BRIDGE]["state"] == "fault"
    assert all(halted[n]["state"] == "quick stop active" for n in (TROLLEY, HOIST)), halted
    reset_id = rig.reset(2)
    rig.wait_mode("ready", 3)
    end = rig.dump()
    status = rig.status()
    log = rig.close()
    log.assert_decodes()
    assert status[3:5] == [MODE["ready"], 0]
    # The bridge's own EMCY and the controller's, as cantools reads them.
    fault_emcy = log.by_others(0x084)
    assert [d for (_, d) in fault_emcy] == [struct.pack("<HB5x", 0x2310, 0x03)]
    assert [m["error_code"] for (_, m) in log.decoded(0x084)] == [0x2310]
    emcys = log.sent(0x090)
    assert [d for (_, d) in emcys] == [emcy(0xFF02, 0x81, 3, BRIDGE), bytes(8)], [d.hex() for (_, d) in emcys]
    first = log.decoded(0x090)[0][1]
    assert (first["error_code"], first["fault"], first["node"]) == (0xFF02, 3, BRIDGE)
    assert emcys[0][0] - fault_emcy[0][0] < 0.05, "noticed within the next cycles"
    # From the fault to the reset every drive is told to quick stop, and its set point
    # ramps to zero within the limits; the trolley and the hoist brake on their own ramp.
    t_reset = arrival(log, 0x210, bytes([reset_id, 3, 0, 0, 0, 0, 0, 0]))
    quick = [c for (t, c) in rpdo_cycles(log) if emcys[0][0] < t < t_reset]
    assert quick and all(cw == 0x0002 for c in quick for (_, cw, _) in c), "quick stop"
    assert all(v == 0 for (_, _, v) in quick[-1]), "at rest when halted"
    for n in (TROLLEY, HOIST):
        words = [m["statusword"] for (t, m) in log.decoded(0x180 + n) if t > emcys[0][0]]
        assert any(w & 0x6F == 0x07 for w in words), f"node {n} never in quick stop active"
    # The bridge got a fault reset (bit 7) and all three were enabled again, where they stopped.
    assert 0x80 in [cw for (_, c) in rpdo_cycles(log) for (n, cw, _) in c if n == BRIDGE]
    for n in NODES:
        assert end[n]["state"] == "operation enabled" and end[n]["nmt"] == "OPERATIONAL", (n, end[n]["state"])
        assert end[n]["position"] == halted[n]["position"], "no motion after the reset"
    assert_setpoints_within_limits(log, LIMITS)


# --- 5: the planar crane and a 3D move -----------------------------------------------------
def test_the_planar_crane_rejects_a_3d_move_as_invalid_by_frame_and_through_0x2000(rigs):
    rig = rigs()
    rig.wait_mode("ready")
    off_beat(rig)
    frame = rig.move3d(1, 13.0, 3.5, 7.5, 4)
    assert rig.answer(1) == (REJECTED, INVALID)
    rig.request3d_sdo(2, 13.0, 3.5, 7.5, 4)
    off_beat(rig)
    rig.submit_sdo()
    assert rig.answer(2) == (REJECTED, INVALID)
    time.sleep(0.2)
    status = rig.status()
    end = rig.dump()
    log = rig.close()
    log.assert_decodes()
    assert_answered_once(log, 1, arrival(log, 0x310, frame), (REJECTED, INVALID))
    submit = [t for (t, d) in log.by_others(0x610) if d[:5] == bytes([0x2F, 0x00, 0x20, 0x02, 4])]
    assert len(submit) == 1
    assert_answered_once(log, 2, submit[0], (REJECTED, INVALID))
    assert [m["reason"] for (_, m) in log.decoded(0x190) if m["last_id"] == 1][:1] == [INVALID]
    assert status[3:6] == [MODE["ready"], 0, 0], "no fault, and a rejection is not an ignored frame"
    assert not log.sent(0x090)
    assert not any(v for n in (1, 2) for v in log.setpoints(n)), "nothing moved"
    assert (end[1]["position"], end[2]["position"]) == (12e6, 8e6)
    assert dbc().get_message_by_frame_id(0x310).decode(frame)["target_y"] == 3.5
