"""One interop run: the virtual ECU (the real controller in real time, SLCAN over TCP)
built for a scene (the default scene unless `scene` is given), the scene's simulated
drives in their own process (drives.py, one per row of the commissioning file, standing
where the crane holds them while the load rests at the scene's move's start, as the ECU
says (`drives_at_rest`); for the planar crane with the load they swing, and with
`--inclinometer` the CiA 410 inclinometer that measures it, load.py), and a supervisor —
a python-canopen network with the controller as a RemoteNode (can/crane-controller.eds)
that reads its object dictionary over SDO and sends commands on 0x210 (the 3D crane's
moves on 0x310, encoded by cantools from can/crane.dbc).

Every frame of the run is in the ECU's log (both directions, with timestamps); at the
end every one of them must decode with cantools against can/crane.dbc.
"""

import json
import os
import struct
import subprocess
import sys
import threading
import time

import can
import canopen
import cantools

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DBC = os.path.join(ROOT, "can", "crane.dbc")
CONTROLLER_EDS = os.path.join(ROOT, "can", "crane-controller.eds")
ECU = os.environ.get("ECU_BIN", os.path.join(ROOT, "target", "debug", "ecu"))
DEFAULT_SCENE = "scenes/paper-crane-ext.toml"  # the ECU's without --scene (host_tests::DEFAULT_SCENE)

CONTROLLER = 0x10
STATUS, EMCY_CONTROLLER, COMMAND, MOVE3D = 0x190, 0x090, 0x210, 0x310
MODE = {"enabling": 0, "ready": 1, "stopping": 2, "quick stop": 3, "halted": 4}
MOVE, STOP, RESET, SUBMIT3D = 1, 2, 3, 4  # 4: 0x2000:2 only (the 3D move in 0x2000)
ACCEPTED, QUEUED, REJECTED = 1, 2, 3


def realtime():
    """In the child before it runs: the ECU, the drives and a PLC's cyclic task (plc.py)
    keep time (the controller drops a drive whose TPDOs are 50 ms late, and takes an
    operator's frames 90 ms apart for the switch let go), the test's supervisor need
    not. Where that is allowed (root), they get a real-time priority (SCHED_FIFO; each
    sleeps between cycles, and the kernel's RT throttling bounds them anyway), else at
    least nice -10, so that a loaded host does not starve them; elsewhere they run as
    they are."""
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))
        return
    except (OSError, AttributeError):
        pass
    try:
        os.nice(-10)
    except OSError:
        pass


class Recorder(can.Listener):
    """Every frame the supervisor receives, with python-can's timestamp."""

    def __init__(self):
        self.frames = []
        self.lock = threading.Lock()

    def on_message_received(self, msg):
        with self.lock:
            self.frames.append((msg.timestamp, msg.arbitration_id, bytes(msg.data)))

    def with_id(self, can_id):
        with self.lock:
            return [(t, d) for (t, i, d) in self.frames if i == can_id]


class Rig:
    """Starts the ECU, the drives and the supervisor; `close` stops them and checks the log."""

    def __init__(self, tmp, role="manager", drive_args=(), seconds=40, scene=None):
        self.tmp = str(tmp)
        os.makedirs(self.tmp, exist_ok=True)
        self.log_path = os.path.join(self.tmp, "frames.log")
        self.procs = []
        self.ecu_err = open(os.path.join(self.tmp, "ecu.stderr"), "w")
        self.ecu = self.spawn(
            [ECU, "--port", "0", "--role", role, "--seconds", str(seconds), "--log", self.log_path]
            + (["--scene", scene] if scene else []),
            stdin=False,
            stderr=self.ecu_err,
            cwd=ROOT,
        )
        line = self.ecu.stdout.readline()
        if not line.startswith("listening on 127.0.0.1:"):
            self.close(check=False)
            raise RuntimeError(f"the ECU did not start: {line!r}")
        self.port = int(line.rsplit(":", 1)[1])
        self.t0 = time.time()
        # The supervisor first, so that it sees the drives' boot-up.
        self.recorder = Recorder()
        bus = can.ThreadSafeBus(
            interface="slcan", channel=f"socket://127.0.0.1:{self.port}", sleep_after_open=0
        )
        self.network = canopen.Network(bus)
        self.network.listeners.append(self.recorder)
        self.network.connect()
        self.controller = canopen.RemoteNode(CONTROLLER, CONTROLLER_EDS)
        self.controller.sdo.RESPONSE_TIMEOUT = 1.0
        self.network.add_node(self.controller)
        self.drives_err = open(os.path.join(self.tmp, "drives.stderr"), "w")
        # The commissioning file next to the scene: the drives (nodes, order, scaling), the
        # inclinometer; the drives stand where the scene's crane holds them while the load
        # rests at the move's start, until a command.
        self.scene = scene or DEFAULT_SCENE
        commissioning = os.path.join(ROOT, os.path.dirname(self.scene), "commissioning.toml")
        start = ",".join(repr(v) for v in drives_at_rest(self.scene))
        self.drives = self.spawn(
            [sys.executable, os.path.join(HERE, "drives.py"), "--port", str(self.port)]
            + ["--commissioning", commissioning, "--start", start, *drive_args],
            stderr=self.drives_err,
        )
        ready = self.drives.stdout.readline()
        if not ready.strip():
            self.close(check=False)
            raise RuntimeError("the drives did not start (see drives.stderr)")

    def spawn(self, command, stdin=True, stderr=None, cwd=None):
        """A process of the run (the ECU, the drives, a PLC): its stdout a pipe (and its
        stdin, unless `stdin` is false), with the real-time priority (`realtime`), stopped
        by `close`."""
        p = subprocess.Popen(
            command,
            cwd=cwd,
            stdin=subprocess.PIPE if stdin else None,
            stdout=subprocess.PIPE,
            stderr=stderr,
            text=True,
            preexec_fn=realtime,
        )
        self.procs.append(p)
        return p

    # --- the drives --------------------------------------------------------------------
    def drive(self, command):
        """A command to the drives' process (`power 1`, `reboot 2`, `fault 2`, `dump`, …)."""
        self.drives.stdin.write(command + "\n")
        self.drives.stdin.flush()
        answer = json.loads(self.drives.stdout.readline())
        assert answer.get("ok"), answer
        return answer

    def dump(self):
        """Each drive's state and object dictionary (what was written into it)."""
        return {d["node"]: d for d in self.drive("dump")["drives"]}

    def load(self):
        """The load under the trolley (load.py; the 3D crane's load3d.py): swing angle,
        amplitude (the 3D crane's per plane), position."""
        return self.drive("dump")["load"]

    def inclinometer(self):
        """The inclinometer's state and object dictionary (`--inclinometer` only)."""
        return self.drive("dump")["inclinometer"]

    # --- the supervisor ----------------------------------------------------------------
    def command(self, request_id, command, x=0.0, z=0.0, duration=0.0):
        data = struct.pack(
            "<BBHHH", request_id, command, round(x * 1000), round(z * 1000), round(duration * 100)
        )
        self.network.send_message(COMMAND, data)

    def move(self, request_id, x, z, duration):
        self.command(request_id, MOVE, x, z, duration)

    def move3d(self, request_id, x, y, z, duration):
        """The 3D move frame (0x310), encoded by cantools from the DBC's Move3d_Controller
        (x, y, z in m to the mm, the duration in whole seconds); returns its bytes."""
        message = dbc().get_message_by_name("Move3d_Controller")
        fields = {"request_id": request_id, "target_x": x, "target_y": y, "target_z": z, "duration": duration}
        data = message.encode(fields)
        self.network.send_message(message.frame_id, data)
        return data

    def request3d_sdo(self, request_id, x, y, z, duration):
        """A 3D move written into the controller's 0x2000 over SDO, as a PLC without PDOs
        does (docs/COMMANDS.md): 1 id, 3 x, 6 y, 4 z (mm), 7 seconds; `submit_sdo` sends it."""
        sdo = self.controller.sdo
        sdo.download(0x2000, 1, struct.pack("<B", request_id))
        sdo.download(0x2000, 3, struct.pack("<H", round(x * 1000)))
        sdo.download(0x2000, 6, struct.pack("<H", round(y * 1000)))
        sdo.download(0x2000, 4, struct.pack("<H", round(z * 1000)))
        sdo.download(0x2000, 7, struct.pack("<B", duration))

    def submit_sdo(self, command=SUBMIT3D):
        """Command `command` into 0x2000:2: the request written into 0x2000 is made (4: a
        3D move; 1 a move, 2 stop, 3 reset as on the command frame)."""
        self.controller.sdo.download(0x2000, 2, struct.pack("<B", command))

    def reset(self, first_id, timeout=2.0):
        """Resets the crane: a reset is refused (reason 2) until every drive's position
        actual is fresh and shows standstill, e.g. for the first SYNC after a drive is
        started again; retried with a new request id each 100 ms. Returns the id accepted."""
        end = time.time() + timeout
        request_id = first_id
        while True:
            self.command(request_id, RESET)
            answer = self.answer(request_id)
            if answer == (ACCEPTED, 0):
                return request_id
            assert answer == (REJECTED, 2), answer
            assert time.time() < end, f"resets refused for {timeout} s"
            time.sleep(0.1)
            request_id += 1

    def statuses(self):
        """Status frames received: (time, [id, answer, reason, mode, fault, ignored, misses, tx])."""
        return [(t, list(d)) for (t, d) in self.recorder.with_id(STATUS)]

    def status(self):
        s = self.statuses()
        return s[-1][1] if s else None

    def answer(self, request_id, timeout=3.0):
        """The (answer, reason) given to `request_id`."""
        found = self.wait(
            lambda: next((s for (_, s) in self.statuses() if s[0] == request_id and s[1] != 0), None),
            timeout,
            f"an answer to request {request_id}",
        )
        return found[1], found[2]

    def wait_mode(self, mode, timeout=10.0):
        return self.wait(
            lambda: (s := self.status()) is not None and s[3] == MODE[mode] and s,
            timeout,
            f"mode {mode}",
        )

    def emcys(self, node=CONTROLLER):
        return [d for (_, d) in self.recorder.with_id(0x80 + node)]

    def sdo(self, index, sub=0):
        return self.controller.sdo.upload(index, sub)

    def sdo_u(self, index, sub=0):
        return int.from_bytes(self.sdo(index, sub), "little")

    def wait(self, predicate, timeout, what):
        end = time.time() + timeout
        while time.time() < end:
            value = predicate()
            if value:
                return value
            time.sleep(0.05)
        raise AssertionError(f"no {what} within {timeout} s (last status {self.status()})")

    # --- the end ---------------------------------------------------------------------
    def close(self, check=True):
        """Stops everything, the ECU first (the log ends where the test ended); returns
        the log, every frame decoded against the DBC."""
        network = getattr(self, "network", None)
        if network is not None and network.notifier is not None:
            network.notifier.stop()
        # The ECU and the test's other senders (a PLC, plc.py) first; the drives are
        # asked to quit.
        for p in self.procs:
            if p is not getattr(self, "drives", None) and p.poll() is None:
                p.terminate()
        if self.drives_running():
            try:
                self.drives.stdin.write("quit\n")
                self.drives.stdin.flush()
                self.drives.wait(timeout=5)
            except (OSError, subprocess.TimeoutExpired):
                pass
        if network is not None and network.bus is not None:
            try:
                network.bus.shutdown()  # its "C" may find the ECU gone
            except Exception:
                pass
        for p in self.procs:
            if p.poll() is None:
                p.terminate()
            try:
                p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        self.ecu_err.close()
        if hasattr(self, "drives_err"):
            self.drives_err.close()
        return Log(self.log_path) if check else None

    def drives_running(self):
        return getattr(self, "drives", None) is not None and self.drives.poll() is None


_DBC = []


def dbc():
    """can/crane.dbc, loaded by cantools once per process."""
    if not _DBC:
        _DBC.append(cantools.database.load_file(DBC))
    return _DBC[0]


def drives_at_rest(scene, load=None):
    """Where the scene's crane's drives stand while its load rests at `load` (m, the
    model's outputs; the scene's start if None), in the model's input order, m — asked of
    the ECU (`ecu --drives-at-rest`, the controller's own `Crane::drives_at_rest`), so
    that no crane's geometry is written here a second time: the planar and 3D crane's
    drives stand where the load hangs, the hook-and-load crane's rope is a sling shorter."""
    command = [ECU, "--scene", scene, "--drives-at-rest"]
    if load is not None:
        command.append(",".join(repr(float(v)) for v in load))
    out = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, check=True)
    return [float(v) for v in out.stdout.split()]


class Log:
    """The ECU's frame log, each frame decoded with cantools against can/crane.dbc."""

    def __init__(self, path):
        self.db = dbc()
        self.frames = []  # (time, sender, id, data, decoded)
        self.undecodable = []
        with open(path) as f:
            for line in f:
                stamp, sender, frame = line.split()
                can_id, data = frame.split("#")
                can_id, data = int(can_id, 16), bytes.fromhex(data)
                t = float(stamp.strip("()"))
                try:
                    message = self.db.get_message_by_frame_id(can_id)
                    if len(data) != message.length:
                        raise ValueError(f"{len(data)} bytes, the DBC says {message.length}")
                    decoded = message.decode(data, decode_choices=False)
                except Exception as e:  # every kind of failure is a finding
                    self.undecodable.append(f"{line.strip()}: {type(e).__name__}: {e}")
                    decoded = None
                self.frames.append((t, sender, can_id, data, decoded))
        with open(path + ".decoded", "w") as out:
            for t, sender, can_id, data, decoded in self.frames:
                name = self.db.get_message_by_frame_id(can_id).name if decoded is not None else "?"
                out.write(f"{t:10.6f} {sender:5} {can_id:03X}#{data.hex().upper():16} {name} {decoded}\n")

    def assert_decodes(self):
        assert not self.undecodable, "frames the DBC does not decode:\n" + "\n".join(self.undecodable[:20])

    def sent(self, can_id):
        """Frames the controller sent with this id: (time, data)."""
        return [(t, d) for (t, s, i, d, _) in self.frames if i == can_id and s == "ecu"]

    def by_others(self, can_id):
        return [(t, d) for (t, s, i, d, _) in self.frames if i == can_id and s != "ecu"]

    def nmt_starts(self, after=float("-inf")):
        """The NMT *start* commands the controller sent after `after`, by node: {node: [time]}.
        Asserts that no two went to one node within one of its heartbeat periods (0x1017,
        100 ms; at least 8 SYNCs strictly between them, as a start goes out in the cycle
        that takes the heartbeat asking for it or the next): a heartbeat the node sent
        before a start reached it asks for nothing (the controller's `Commissioning::start`);
        one a period later that still says stopped or pre-operational asks again (the start
        was lost), as CiA 301/302 let a manager do. How many starts that makes depends on
        the host's timing, so callers assert the nodes started, not the count."""
        starts = {}
        for t, d in self.sent(0x000):
            if t > after and d[0] == 0x01:
                starts.setdefault(d[1], []).append(t)
        syncs = [t for (t, _) in self.sent(0x080)]
        for node, times in starts.items():
            for a, b in zip(times, times[1:]):
                between = sum(1 for t in syncs if a < t < b)
                assert between >= 8, f"node {node} started twice within {between} SYNCs: {times}"
        return starts

    def decoded(self, can_id):
        return [(t, m) for (t, _, i, _, m) in self.frames if i == can_id]

    def setpoint_pairs(self):
        """(trolley, winch) target velocities of each cycle (the RPDOs before each SYNC;
        0 for a drive not sent one), µm/s."""
        return self.setpoint_rows((1, 2))

    def setpoint_rows(self, nodes):
        """The target velocities of each cycle to `nodes`, in that order (the RPDOs
        before each SYNC; 0 for a drive not sent one), µm/s."""
        cobs = [0x200 + n for n in nodes]
        rows, cycle = [], {}
        for _, sender, can_id, data, _ in self.frames:
            if sender != "ecu":
                continue
            if can_id in cobs:
                cycle[can_id] = struct.unpack_from("<Hi", data)[1]
            elif can_id == 0x080:
                rows.append(tuple(cycle.get(c, 0) for c in cobs))
                cycle = {}
        return rows

    def setpoints(self, node):
        """Target velocities sent to a drive, µm/s, in order."""
        return [struct.unpack_from("<Hi", d)[1] for (_, d) in self.sent(0x200 + node)]
