"""The bus recorded as a commissioning engineer records it, by python-can (a writer
independent of the project): every frame the supervisor's python-can connection
received from the virtual ECU and the drives, with python-can's receive time stamps, and
every frame the supervisor sent (as a SocketCAN adapter shows its own frames), written
by python-can's loggers in both formats — candump `-L` (`.log`, `CanutilsLogWriter`)
and Vector ASC (`.asc`, `ASCWriter`).

`record(rig)` starts recording the supervisor's own frames (the received ones the rig's
`Recorder` keeps from its start, boot-ups included); `write(rig, stem)` writes
`stem.log` and `stem.asc`. `report(log, out, scene)` runs `cargo xtask report` on one
(`REPORT_BIN`, set by `cargo xtask interop`) and returns its `summary.json`.

By hand, the committed example (docs/report-example/healthy.log, a swinging start on the
feedback scene): `python interop/record.py example docs/report-example` with `ECU_BIN`
and `REPORT_BIN` set as `cargo xtask interop` sets them.
"""

import json
import os
import subprocess
import sys
import time

import can

from rig import ROOT

REPORT = os.environ.get("REPORT_BIN", os.path.join(ROOT, "target", "debug", "xtask"))


def record(rig):
    """From now on, the supervisor's own frames are kept with the time they were sent."""
    rig.sent = []
    send = rig.network.send_message

    def sending(can_id, data, remote=False):
        rig.sent.append((time.time(), can_id, bytes(data)))
        return send(can_id, data, remote)

    rig.network.send_message = sending


def recorded(rig):
    """Every frame of the run so far as the logs have them: (time, id, data, received),
    in order. Stamps on the microsecond grid: both writers print six decimals, candump
    since the epoch and ASC since the first frame, and a stamp between two microseconds
    would round to other intervals in the two files."""
    received = [(round(t, 6), i, d, True) for (t, i, d) in list(rig.recorder.frames)]
    sent = [(round(t, 6), i, d, False) for (t, i, d) in getattr(rig, "sent", [])]
    return sorted(received + sent, key=lambda f: f[0])


def write(rig, stem):
    """Writes every frame of the run so far through python-can's loggers: `stem.log`
    (candump -L) and `stem.asc` (Vector ASC); returns both paths."""
    paths = [stem + ".log", stem + ".asc"]
    for path in paths:
        writer = can.Logger(path)
        try:
            for t, can_id, data, rx in recorded(rig):
                writer.on_message_received(
                    can.Message(timestamp=t, arbitration_id=can_id, data=data, is_extended_id=False, is_rx=rx, channel="can0")
                )
        finally:
            writer.stop()
    return paths


def report(log, out, scene=None):
    """`cargo xtask report LOG --out OUT [--scene SCENE]`; its summary.json."""
    command = [REPORT, "report", log, "--out", out] + (["--scene", scene] if scene else [])
    run = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, f"{command}: {run.stderr}"
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f)


def example(directory):
    """The committed example: on the feedback scene, the load swinging 5° when the
    paper's move (12, 8) → (20, 4) in 8 s is commanded, recorded until one swing period
    after the 5 s the verdict waits for."""
    from rig import Rig

    scene = "scenes/paper-crane-feedback.toml"
    tmp = os.path.join(ROOT, "target", "report-example-run")
    rig = Rig(tmp, scene=scene, drive_args=["--inclinometer"], seconds=40)
    try:
        record(rig)
        rig.wait_mode("ready")
        rig.drive("swing 5")
        time.sleep(0.5)
        rig.move(1, 20.0, 4.0, 8.0)
        assert rig.answer(1) == (1, 0)
        time.sleep(8.0 + 5.0 + 4.5)
        stem = os.path.join(directory, "healthy")
        write(rig, stem)
    finally:
        rig.close(check=False)
    os.remove(stem + ".asc")  # the example keeps one format; the suite checks both
    print(stem + ".log")


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] != "example":
        sys.exit("usage: python interop/record.py example DIRECTORY")
    example(sys.argv[2])
