"""`cargo xtask report` on logs python-can recorded from the virtual ECU, in both formats
(candump -L and Vector ASC): a healthy move, a stop, a drive fault, a lost heartbeat,
a swinging start with the feedback, the 3D crane. Both formats must give the same
report, and its numbers must be the rig's own — what the ECU logged that it sent, what
the supervisor sent and was answered, what the drives and the load simulated.
About 80 s.
"""

import math
import os
import time

import canopen
import pytest

from record import record, recorded, report, write
from rig import ACCEPTED, HERE
from test_interop import rigs  # noqa: F401 (the fixture)

TROLLEY, WINCH, BRIDGE = 1, 2, 4


def same(a, b, path="summary"):
    """Both formats' summaries are the same, number for number: record.py stamps the
    frames on the microsecond grid both writers print, and the report reads the stamps
    exactly, so ASC's time since the first frame and candump's since the epoch give the
    same intervals (only what was read — lines, bytes, other lines — differs)."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for k in a:
            if k not in ("log", "format", "read"):
                same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert len(a) == len(b), (path, len(a), len(b))
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{path}[{i}]")
    else:
        assert a == b, (path, a, b)


def reports(rig, tmp_path, name, scene=None):
    """Closes the rig, writes its recording in both formats, reports both: the summary
    (after checking both agree), the ECU's own log and the page."""
    log = rig.close()
    log.assert_decodes()
    paths = write(rig, str(tmp_path / name))
    summaries = [report(p, str(tmp_path / f"{name}-{p[-3:]}"), scene) for p in paths]
    same(summaries[0], summaries[1])
    assert summaries[0]["format"] == "candump -L" and summaries[1]["format"] == "Vector ASC"
    assert summaries[0]["read"]["frames"] == summaries[1]["read"]["frames"]
    for s in summaries:
        assert s["read"]["unreadable"] == 0 and not s["decoding"]["unknown_ids"], s["decoding"]
        assert not s["decoding"]["undecodable"] and not s["two_controllers"]
        assert s["controller_heard"]
    with open(tmp_path / f"{name}-log" / "index.html") as f:
        page = f.read()
    return summaries[0], log, page


def drive(summary, node):
    return next(d for d in summary["drives"] if d["node"] == node)


def assert_setpoints_are_the_ecus(summary, log, nodes):
    """Largest set point per drive as the ECU logged it sending them, to the µm/s; as
    many set points, less those after the recording stopped."""
    for node in nodes:
        sent = log.setpoints(node)
        d = drive(summary, node)
        assert math.isclose(d["max_setpoint"], max(abs(u) for u in sent) / 1e6, abs_tol=1e-9), node
        assert 0 <= len(sent) - d["setpoints"] <= 20, (node, len(sent), d["setpoints"])
        assert d["over_velocity"] == 0 and d["over_acceleration"] == 0


def assert_emcys_are_the_ecus(summary, log):
    """Every EMCY of the recording, in order, is one the ECU's log has (any sender)."""
    logged = [(i - 0x80, int.from_bytes(d[:2], "little")) for (_, _, i, d, _) in log.frames if 0x81 <= i <= 0xFF]
    reported = [(e["node"], e["code"]) for e in summary["emcys"]["items"]]
    assert reported == logged[: len(reported)] and len(logged) - len(reported) <= 1, (reported, logged)
    return reported


def moving(rigs, duration=4.0, **rig):
    """A rig recording, ready, the move (13, 7.5) in `duration` s accepted as request 1."""
    r = rigs(**rig)
    record(r)
    r.wait_mode("ready")
    r.move(1, 13.0, 7.5, duration)
    assert r.answer(1) == (ACCEPTED, 0)
    return r


def answers(summary):
    return [(r["id"], [a[1] for a in r["answers"]]) for r in summary["requests"]["items"]]


def test_a_healthy_move_reported_as_the_rig_ran_it(rigs, tmp_path):
    rig = moving(rigs)
    time.sleep(4.0 + 5.0 + 5.8)  # the move, 5 s, a swing period at 7.5 m
    drives = rig.dump()
    s, log, page = reports(rig, tmp_path, "healthy")
    assert answers(s) == [(1, ["Accepted"])]
    assert_setpoints_are_the_ecus(s, log, (TROLLEY, WINCH))
    assert assert_emcys_are_the_ecus(s, log) == []
    for node in (TROLLEY, WINCH):
        last = drive(s, node)["positions"][1]
        assert abs(last - drives[node]["position"] * 1e-6) < 1e-6, (node, last, drives[node]["position"])
    move = s["moves"]["items"][0]
    assert move["verdict"].startswith("pass where measured"), move  # no inclinometer: swing not measured
    assert move["horizontal"] < 0.002 and move["moving_cycles"] == 0, move
    assert any("no inclinometer on the bus" in c for c in s["cannot_answer"])
    # The boot, as the drives were commissioned: boot-ups, NMT, the SDO transcripts.
    for node in (TROLLEY, WINCH):
        assert len(s["nodes"][str(node)]["boot_ups"]["items"]) == 1
        assert s["sdo"][str(node)][1] == 0, "no abort"
    assert "write 0x6060:0 Modes of operation = 0x09 (9) → done" in page
    starts = [c for c in s["nmt"]["items"] if c["command"] == "Start"]
    assert sorted(c["node"] for c in starts) == [TROLLEY, WINCH]
    # Timing: every SYNC the ECU sent while recording, at 10 ms.
    syncs = len(log.sent(0x080))
    assert 0 <= syncs - s["timing"]["syncs"] <= 20, (syncs, s["timing"]["syncs"])
    assert abs(s["timing"]["interval"]["mean"] - 0.01) < 5e-4
    assert all(order[1] == 0 and order[2] == 0 for order in s["timing"]["rpdo_order"])
    assert s["last_counters"] == [0, 0, 0]


def test_a_stop_reported_short_of_the_target(rigs, tmp_path):
    rig = moving(rigs, 8.0)
    time.sleep(2.5)
    rig.command(2, 2)
    assert rig.answer(2) == (ACCEPTED, 0)
    time.sleep(6.0)
    s, log, _ = reports(rig, tmp_path, "stop")
    assert answers(s) == [(1, ["Accepted"]), (2, ["Accepted"])]
    assert [r["kind"] for r in s["requests"]["items"]][1] == "Stop"
    move = s["moves"]["items"][0]
    assert move["ended_by"].startswith("stopped at"), move
    assert_setpoints_are_the_ecus(s, log, (TROLLEY, WINCH))
    trolley = drive(s, TROLLEY)["positions"][1]
    assert 12.0 < trolley < 13.0, trolley  # short of the target, on the way


def test_a_drive_fault_reported_with_its_reaction(rigs, tmp_path):
    rig = moving(rigs)
    time.sleep(1.0)
    rig.drive("fault 2")
    rig.wait_mode("halted")
    time.sleep(0.5)
    s, log, _ = reports(rig, tmp_path, "fault")
    emcys = assert_emcys_are_the_ecus(s, log)
    assert (WINCH, 0x2310) in emcys and (0x10, 0xFF02) in emcys, emcys
    controller = next(e for e in s["emcys"]["items"] if e["node"] == 0x10)
    assert controller["fault"] == "DriveFault" and "winch drive (node 2)" in controller["meaning"]
    assert controller["documented"].startswith("quick stop"), controller
    assert "QuickStop" in controller["taken"] and "Halted" in controller["taken"], controller
    assert s["modes"]["items"][-1][1:] == ["Halted", "DriveFault"]
    assert s["moves"]["items"][0]["ended_by"].startswith("fault DriveFault")
    states = [st[1] for st in drive(s, WINCH)["states"]["items"]]
    assert "fault" in states


def test_a_lost_heartbeat_reported_with_its_gap(rigs, tmp_path):
    rig = moving(rigs)
    time.sleep(1.0)
    # The winch's heartbeat producer switched off (0x1017 = 0) over SDO: its TPDOs go
    # on, its heartbeat stops.
    winch = canopen.RemoteNode(WINCH, os.path.join(HERE, "cia402-drive.eds"))
    rig.network.add_node(winch)
    winch.sdo.download(0x1017, 0, b"\x00\x00")
    rig.wait_mode("halted")
    time.sleep(0.5)
    s, log, page = reports(rig, tmp_path, "heartbeat")
    emcys = assert_emcys_are_the_ecus(s, log)
    assert (0x10, 0x8130) in emcys, emcys
    controller = next(e for e in s["emcys"]["items"] if e["node"] == 0x10)
    assert controller["fault"] == "HeartbeatLost", controller
    winch_node = s["nodes"][str(WINCH)]
    age = s["duration"] - winch_node["last_heartbeat"]
    assert age > 0.8, age  # silent from the write to the end
    assert "write 0x1017:0 Producer heartbeat time = 0x0000 (0) → done" in page


def test_a_swinging_start_with_the_feedback_reported_as_the_load_swung(rigs, tmp_path):
    scene = "scenes/paper-crane-feedback.toml"
    rig = rigs(scene=scene, drive_args=["--inclinometer"])
    record(rig)
    rig.wait_mode("ready")
    start = rig.drive("swing 5")["load"]
    time.sleep(0.5)
    rig.move(1, 20.0, 4.0, 8.0)
    assert rig.answer(1) == (ACCEPTED, 0)
    time.sleep(8.0 + 5.0 + 4.3)  # the move, 5 s, a swing period at 4 m
    end = rig.load()
    s, log, _ = reports(rig, tmp_path, "swing", scene)
    # The 5° the load swung at the start was read (the move swings it further before
    # the feedback has damped it).
    assert s["max_swing"][0] >= start["amplitude_deg"] - 0.01, (s["max_swing"], start)
    move = s["moves"]["items"][0]
    if move["swing_cycles"] == move["cycles"]:
        assert move["verdict"] == "pass", move
    else:  # the recorder stalled in the window: the verdict says what it did not read
        assert move["verdict"].startswith("pass where measured; not measured: the swing in "), move
    # The verdict's numbers against the simulated load at the window's end.
    assert move["swing"][0] < 0.1 and end["amplitude_deg"] < 0.1
    assert abs(end["load_x_m"] - 20.0) <= move["horizontal"] + 0.002, (end, move)
    assert move["horizontal"] < 0.05
    assert_setpoints_are_the_ecus(s, log, (TROLLEY, WINCH))
    # The SYNCs without a reading fresher than 0.1 s, counted here from the recorded
    # frames themselves: a loaded host's recorder can stall past 0.1 s (1 of about 1,900
    # cycles seen at a load average of 10), and the report must count what the log has.
    frames = recorded(rig)
    readings = [t for (t, i, _, _) in frames if i == 0x183]
    last, stale = None, 0
    for t, i, _, _ in frames:
        if i == 0x183:
            last = t
        elif i == 0x080 and last is not None and t - last > 0.1 + 1e-7:
            stale += 1
    assert s["inclinometer_readings"] == len(readings) > 1000, (s["inclinometer_readings"], len(readings))
    assert s["stale_inclinometer_cycles"] == stale, (s["stale_inclinometer_cycles"], stale)


def test_the_3d_crane_reported_with_its_three_drives(rigs, tmp_path):
    scene = "scenes/crane3d/crane3d.toml"
    rig = rigs(scene=scene)
    record(rig)
    rig.wait_mode("ready")
    rig.move3d(1, 13.0, 3.5, 7.0, 4)
    assert rig.answer(1) == (ACCEPTED, 0)
    time.sleep(4.0 + 5.0 + 5.4)
    drives = rig.dump()
    s, log, _ = reports(rig, tmp_path, "crane3d", scene)
    assert s["crane"] == "3D crane"
    assert [d["name"] for d in s["drives"]] == ["bridge", "trolley", "winch"]
    assert_setpoints_are_the_ecus(s, log, (BRIDGE, TROLLEY, WINCH))
    move = s["moves"]["items"][0]
    assert move["target"] == [13.0, 3.5, 7.0] and move["horizontal"] < 0.002, move
    for node in (BRIDGE, TROLLEY, WINCH):
        last = drive(s, node)["positions"][1]
        assert abs(last - drives[node]["position"] * 1e-6) < 1e-6, node
    assert all(order[1] == 0 for order in s["timing"]["rpdo_order"])
