"""Manual mode over the bus (issue 28): a PLC drives the virtual ECU running the scenes
with `[operator]` (scenes/paper-crane-manual.toml, scenes/crane3d/crane3d-manual.toml)
through the operator's speed demand, as an independent stack sends it:

* RPDO3 0x410 built by cantools from can/crane.dbc's `Operator_Controller` every 20 ms
  (the DBC asks for 30 ms or faster; 20 ms leaves a loaded machine two frames of
  margin within the controller's 90 ms dead-man deadline), its alive counter changing
  every frame, by a PLC process of its own (plc.py, `Operator`: a cyclic task with the
  ECU's priority, not a thread the test's own work could hold up past the deadline);
* the same fields written into 0x2010 *Operator demand* with python-canopen's SDO
  client, by the same kind of process (`SdoOperator`: flags and demands once, the alive
  counter, which submits them, every 30 ms);
* the EDS's objects 0x1402/0x1602 (RPDO3's communication and mapping) and 0x2010 as
  python-canopen's od import reads them, checked against the DBC's layout of the frame
  and read back from the running controller over SDO.

Judged by the simulated crane itself (load.py's pendulum, load3d.py's spherical one) and
the controller's own frames: the status frame's mode 5 (*Manual*) once manual mode is
requested at rest, the load travelling with the stick, after the release the drives at
standstill with the load swinging less than 0.1° and every set point exactly 0.0, and
the status frame back to 1 (*ready*) when the request is withdrawn; the master switch
falling silent mid-travel (a dead-man drop) stops the crane the same way and leaves
manual mode with no frame more. A scene without `[operator]` refuses manual mode and
says why (EMCY 0xFF21, decoded by cantools from the DBC); a running move taken over by
the stick is announced by EMCY 0xFF22. About 75 s.
"""

import json
import math
import os
import struct
import sys
import time

import canopen

from rig import ACCEPTED, CONTROLLER_EDS, HERE, STATUS, dbc
from test_black_box import wait_rest
from test_interop import rigs  # noqa: F401

PLANAR = "scenes/paper-crane-manual.toml"
SPATIAL = "scenes/crane3d/crane3d-manual.toml"
MANUAL, READY = 5, 1  # the status frame's mode byte (docs/COMMANDS.md)
FULL_SCALE = 32767  # raw demand of full stick
OPERATOR_ID = 0x410
PERIOD = 0.02  # s between the PLC's frames


class Plc:
    """A PLC on the bus in a process of its own (plc.py, with the ECU's and the drives'
    priority: a cyclic task that keeps its period whatever the test does); stopped with
    the rig if the test ends first."""

    def __init__(self, rig, *args):
        self.proc = rig.spawn([sys.executable, os.path.join(HERE, "plc.py"), "--port", str(rig.port), *args])
        ready = self.proc.stdout.readline()
        assert json.loads(ready or "{}").get("ready"), f"the PLC did not start: {ready!r}"

    def ask(self, **request):
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        answer = json.loads(self.proc.stdout.readline() or "{}")
        assert answer.get("ok"), answer
        return answer

    def silence(self):
        """The switch falls silent: no frame more. Returns what plc.py sent."""
        answer = self.ask(silence=True)
        assert self.proc.wait(timeout=5) == 0
        return answer


class Operator(Plc):
    """A PLC's master switch on the bus: `Operator_Controller` encoded by cantools every
    `PERIOD`, its alive counter changing, until `silence` (a dead-man drop)."""

    def __init__(self, rig, **fields):
        super().__init__(rig, "--period", str(PERIOD), "--fields", json.dumps(fields))
        self.sent = []  # the bytes of every frame sent, once silenced

    def set(self, **fields):
        self.ask(set=fields)

    def silence(self):
        self.sent = [bytes.fromhex(d) for d in super().silence()["sent"]]


class SdoOperator(Plc):
    """A PLC without PDOs: the flags (enable, manual request) and centred demands
    written into 0x2010 once, then the alive counter (sub 1, which submits the fields as
    one frame) every 30 ms (plc.py --sdo); `set` writes a field between two
    submissions. No test reads or writes the controller over the supervisor's SDO
    client while one runs (two clients of one server: plc.py says why)."""

    def __init__(self, rig):
        super().__init__(rig, "--sdo", "--period", "0.03")
        self.submitted = 0  # submissions, once silenced

    def set(self, sub, value):
        self.ask(download=[sub, value.hex()])

    def silence(self):
        self.submitted = super().silence()["submitted"]


def wait_manual(rig, mode, timeout=3.0):
    """The status frame's mode `mode` (5 manual, 1 ready) from a frame sent from now on."""
    since = time.time()
    rig.wait(
        lambda: any(t > since and s[3] == mode for (t, s) in rig.statuses()),
        timeout,
        f"status mode {mode}",
    )


def centred():
    """The stick held centred for 0.2 s after the entry (several frames): the
    zero-position interlock lifts after two centred frames in manual mode, and a stick
    deflected before that is held (docs/COMMANDS.md) — as a PLC must do it."""
    time.sleep(0.2)


def rest_without_swing(rig, swing_keys=("amplitude_deg",), timeout=15.0):
    """The drives at standstill, then the load as load.py / load3d.py has it: swinging
    less than 0.1° (every key of `swing_keys`)."""
    wait_rest(rig, timeout)
    load = rig.load()
    for key in swing_keys:
        assert load[key] < 0.1, load
    return load


def modes_so_far(rig):
    """The status frames' mode byte as the supervisor received them so far, each change
    with its time: [(t, mode), …] — in a failed travel's message, it tells a dead-man
    drop (5 → 1 mid-stick) from a short travel."""
    changes = []
    for t, s in rig.statuses():
        if not changes or changes[-1][1] != s[3]:
            changes.append((round(t - rig.t0, 2), s[3]))
    return changes


def mode_changes(log):
    """The status frames' mode byte as the controller sent them, each change with its
    time in the log: [(t, mode), …]."""
    changes = []
    for t, d in log.sent(STATUS):
        if not changes or changes[-1][1] != d[3]:
            changes.append((t, d[3]))
    return changes


def zero_from(log, t0, t1, nodes):
    """Every set point to `nodes` in the cycles sent in (t0, t1] exactly 0: the number of
    those cycles (and at least one)."""
    rows = [
        struct.unpack_from("<Hi", d)[1]
        for n in nodes
        for (t, d) in log.sent(0x200 + n)
        if t0 < t <= t1
    ]
    assert rows and all(v == 0 for v in rows), rows[:20]
    return len(rows)


def test_the_eds_maps_rpdo3_as_the_dbc_and_the_controller_answers_it():
    """0x1402 (COB-ID 0x410), 0x1602 (five mapped sub-objects of 0x2010, 8 + 8 + 16 +
    16 + 16 bits) and 0x2010's subs (write-only: counter and flags u8, demands i16), as
    python-canopen's od import reads the EDS, laid out as the DBC's Operator_Controller
    (a signal at each mapped object's bit offset, its size; the flags' three bits in
    the second byte)."""
    od = canopen.import_od(CONTROLLER_EDS, 0x10)
    assert od[0x1402][1].default == OPERATOR_ID
    mapped = [od[0x1602][i].default for i in range(1, od[0x1602][0].default + 1)]
    assert mapped == [0x2010_0108, 0x2010_0208, 0x2010_0310, 0x2010_0410, 0x2010_0510]
    demand = od[0x2010]
    assert demand.name == "Operator demand"
    assert [(demand[i].data_type, demand[i].access_type) for i in range(1, 6)] == [
        (canopen.objectdictionary.UNSIGNED8, "wo"),
        (canopen.objectdictionary.UNSIGNED8, "wo"),
        (canopen.objectdictionary.INTEGER16, "wo"),
        (canopen.objectdictionary.INTEGER16, "wo"),
        (canopen.objectdictionary.INTEGER16, "wo"),
    ]
    message = dbc().get_message_by_name("Operator_Controller")
    assert message.frame_id == OPERATOR_ID and message.length == 8
    signals = {s.name: (s.start, s.length, s.is_signed) for s in message.signals}
    offset = 0
    for entry, name in zip(mapped, ["alive_counter", None, "demand_x", "demand_y", "demand_z"]):
        bits = entry & 0xFF
        if name is not None:
            assert signals[name] == (offset, bits, name.startswith("demand")), name
        else:
            # The flags' byte: enable, manual request, micro-speed in its bits 0-2.
            assert [signals[f][:2] for f in ("enable", "manual_request", "micro_speed")] == [
                (offset, 1),
                (offset + 1, 1),
                (offset + 2, 1),
            ]
        offset += bits
    assert offset == 64
    # A stick's full scale is the DBC's ±1.
    assert message.decode(message.encode({
        "alive_counter": 1, "enable": 1, "manual_request": 1, "micro_speed": 0,
        "demand_x": 1.0, "demand_y": -1.0, "demand_z": 0.0,
    }), scaling=False)["demand_x"] == FULL_SCALE


def test_the_planar_crane_follows_the_stick_over_rpdo3_and_rests_sway_free(rigs):
    """Manual mode requested at rest (status mode 5), full stick along x for 3 s: the
    load travels more than 1.5 m with it; released: the drives at standstill, the load
    swinging < 0.1°, every set point 0.0 until the request is withdrawn (status mode
    1); the controller's RPDO3 and 0x1602 read back over SDO as the EDS has them."""
    rig = rigs(scene=PLANAR, seconds=60)
    rig.wait_mode("ready", timeout=15)
    assert rig.sdo_u(0x1402, 1) == OPERATOR_ID
    assert [rig.sdo_u(0x1602, i) for i in range(1, 6)] == [
        0x2010_0108, 0x2010_0208, 0x2010_0310, 0x2010_0410, 0x2010_0510,
    ]
    start = rig.load()
    op = Operator(rig)
    wait_manual(rig, MANUAL)
    centred()
    op.set(demand_x=1.0)
    time.sleep(3.0)
    op.set(demand_x=0.0)
    end = rest_without_swing(rig)
    travelled = end["load_x_m"] - start["load_x_m"]
    assert travelled > 1.5, (start, end, modes_so_far(rig))
    assert abs(end["rope_m"] - start["rope_m"]) < 0.001, (start, end)
    time.sleep(1.0)
    assert rig.status()[3] == MANUAL
    op.set(manual_request=0)
    wait_manual(rig, READY)
    op.silence()
    log = rig.close()
    log.assert_decodes()
    # Every frame the PLC sent is in the ECU's log, as cantools encoded it.
    received = [d for (_, d) in log.by_others(OPERATOR_ID)]
    assert received == op.sent[: len(received)] and len(received) >= len(op.sent) - 2
    # Ready, manual from the request, ready again at the withdrawal: the set points
    # moved in manual mode and were exactly 0.0 for the last second of it.
    changes = mode_changes(log)
    assert [m for (_, m) in changes][-3:] == [READY, MANUAL, READY], changes
    (t_manual, _), (t_ready, _) = changes[-2:]
    assert any(
        struct.unpack_from("<Hi", d)[1] != 0 for (t, d) in log.sent(0x201) if t_manual < t < t_ready
    )
    assert zero_from(log, t_ready - 1.0, t_ready, (1, 2)) >= 2 * 90


def test_the_sdo_path_drives_the_planar_crane_as_the_frame_does(rigs):
    """The same fields through 0x2010 over python-canopen's SDO client, as a PLC
    without PDOs writes them (`SdoOperator`): manual mode (status 5), a half stick
    along x for 3 s moves the load, centred it rests sway-free, and with the request
    withdrawn manual mode is left at rest (status 1)."""
    rig = rigs(scene=PLANAR, seconds=60)
    rig.wait_mode("ready", timeout=15)
    start = rig.load()
    op = SdoOperator(rig)
    wait_manual(rig, MANUAL)
    centred()
    op.set(3, struct.pack("<h", FULL_SCALE // 2))
    time.sleep(3.0)
    op.set(3, struct.pack("<h", 0))
    end = rest_without_swing(rig)
    travelled = end["load_x_m"] - start["load_x_m"]
    assert travelled > 0.7, (start, end, modes_so_far(rig))
    assert rig.status()[3] == MANUAL
    op.set(2, struct.pack("<B", 0b001))  # the request withdrawn, the switch held
    wait_manual(rig, READY)
    op.silence()
    assert op.submitted > 100
    rig.close().assert_decodes()


def test_the_3d_crane_follows_a_diagonal_stick_straight_and_a_dead_man_drop_stops_it(rigs):
    """The 3D crane: manual mode, a diagonal full stick (bridge and trolley) for 2.5 s:
    the load moves along x and y on a straight path (within 5 cm of the line from its
    start to its rest); released, at rest swinging < 0.1° in either plane. Then full
    stick along x again and the switch falls silent after 2 s (no frame more): the
    dead-man stops the crane, the load at rest swinging < 0.1°, manual mode left
    (status mode 1) without another frame, every set point 0.0 after."""
    rig = rigs(scene=SPATIAL, seconds=70)
    rig.wait_mode("ready", timeout=15)
    start = rig.load()
    op = Operator(rig)
    wait_manual(rig, MANUAL)
    centred()
    op.set(demand_x=1.0, demand_y=1.0)
    path = []
    end_time = time.time() + 2.5
    while time.time() < end_time:
        path.append(rig.load())
        time.sleep(0.1)
    op.set(demand_x=0.0, demand_y=0.0)
    keys = ("xz_amplitude_deg", "yz_amplitude_deg")
    end = rest_without_swing(rig, keys)
    dx, dy = end["load_x_m"] - start["load_x_m"], end["load_y_m"] - start["load_y_m"]
    assert dx > 1.0 and dy > 0.7, (start, end, modes_so_far(rig))
    length = math.hypot(dx, dy)
    for p in path:
        px, py = p["load_x_m"] - start["load_x_m"], p["load_y_m"] - start["load_y_m"]
        assert abs(px * dy - py * dx) / length < 0.05, (p, start, end)
    # The dead-man drop.
    before = end
    op.set(demand_x=-1.0)
    time.sleep(2.0)
    op.silence()
    wait_manual(rig, READY, timeout=15)
    end = rest_without_swing(rig, keys)
    assert end["load_x_m"] < before["load_x_m"] - 0.5, (before, end, modes_so_far(rig))
    time.sleep(1.0)
    log = rig.close()
    log.assert_decodes()
    # After the last frame the switch sent: manual mode left (mode 1) with no frame
    # more, and the set points exactly 0.0 for the run's last second.
    dropped = max(t for (t, _) in log.by_others(OPERATOR_ID))
    changes = mode_changes(log)
    assert changes[-1][1] == READY and changes[-2][1] == MANUAL, changes
    assert changes[-1][0] > dropped, (changes, dropped)
    last = max(t for (t, _) in log.sent(0x080))
    assert zero_from(log, last - 1.0, last, (4, 1, 2)) >= 3 * 90


def controller_emcys(log, code):
    """The controller's EMCYs (0x090) with `code`, as cantools decoded them from the DBC
    (`EMCY_Controller`): [(time, signals), …]."""
    return [(t, m) for (t, m) in log.decoded(0x090) if m is not None and m["error_code"] == code]


def test_the_stick_takes_over_a_running_move_and_the_emcy_says_so(rigs):
    """A PLC's move (0x210) runs; the operator asks for manual mode with the stick
    centred, then pushes it: the stick takes the crane over in the cycle that reads its
    frame — the controller says so by EMCY 0xFF22 *MoveTakenOver* (fault byte 23, detail
    0: at once, decoded by cantools from the DBC) and its next status frame says manual
    (5), the move ending with the generator's own stop — the load goes
    on the pushed way without a second centring (at the stick's share of the manual
    speed once the move's stop is over), and after the release it rests sway-free; the
    request withdrawn, ready (status 1)."""
    rig = rigs(scene=PLANAR, seconds=60)
    rig.wait_mode("ready", timeout=15)
    start = rig.load()
    rig.move(1, start["load_x_m"] + 6.0, 8.0, 8.0)
    assert rig.answer(1) == (ACCEPTED, 0)
    time.sleep(2.0)
    op = Operator(rig)
    time.sleep(0.3)
    op.set(demand_x=0.25)
    wait_manual(rig, MANUAL, timeout=10.0)
    # Past the move's own stop (at most the lab's entry_blend, 8 s), the load moves at
    # the quarter stick's share of the manual speed beyond the deadband:
    # 1 m/s * (0.25 - 0.05) / 0.95 = 0.21 m/s (the move's stop alone would rest).
    time.sleep(8.5)
    a = rig.load()
    time.sleep(1.0)
    b = rig.load()
    speed = b["load_x_m"] - a["load_x_m"]
    assert 0.15 < speed < 0.27, (a, b, modes_so_far(rig))
    op.set(demand_x=0.0)
    rest_without_swing(rig)
    op.set(manual_request=0)
    wait_manual(rig, READY)
    op.silence()
    log = rig.close()
    log.assert_decodes()
    emcys = controller_emcys(log, 0xFF22)
    assert len(emcys) == 1, emcys
    t_taken, signals = emcys[0]
    assert signals["fault"] == 23, signals
    assert signals["detail"] == 0, signals
    changes = mode_changes(log)
    t_manual = next(t for (t, m) in changes if m == MANUAL)
    # Manual mode from the take-over's cycle: the next status frame (every 100 ms) says
    # so; the EMCY's detail 0 said it at once.
    assert 0 <= t_manual - t_taken <= 0.15, (t_taken, changes)


def test_a_scene_without_operator_refuses_manual_mode_and_says_why(rigs):
    """The scene without `[operator]` (scenes/paper-crane.toml): the PLC's request for
    manual mode is refused once, by EMCY 0xFF21 *ManualRefused* with fault byte 22 and
    reason 1 (the controller follows plans only) in its detail byte, decoded by cantools
    from the DBC; the status frame never says manual."""
    rig = rigs(scene="scenes/paper-crane.toml", seconds=30)
    rig.wait_mode("ready", timeout=15)
    op = Operator(rig)
    time.sleep(1.0)
    op.silence()
    time.sleep(0.3)
    log = rig.close()
    log.assert_decodes()
    emcys = controller_emcys(log, 0xFF21)
    assert len(emcys) == 1, emcys
    _, signals = emcys[0]
    assert (signals["fault"], signals["detail"]) == (22, 1), signals
    assert all(m != MANUAL for (_, m) in mode_changes(log))
