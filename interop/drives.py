"""The crane's CiA 402 drives simulated with python-canopen's LocalNode on one SLCAN
connection to the virtual ECU, in their own process: one per `[[drive]]` row of the
commissioning file, with its node id (the planar crane's node 1 trolley and node 2 winch,
the stock ones without a file; the 3D crane's node 4 bridge, 1 trolley, 2 hoist).

python-canopen provides the object dictionary (cia402-drive.eds), the SDO server, the
NMT slave with its heartbeat producer (0x1017), EMCY and the PDO maps; the glue here is
the rest of a drive: the boot-up message on power-on, PDOs configured from what was
written into 0x1400/0x1600/0x1800/0x1A00 (+1) when the node is started, synchronous
RPDOs applied and TPDOs sent on SYNC, the CiA 402 state machine on the controlword,
velocity actual = target velocity in CSV (the quick-stop ramp 0x6085 in quick stop),
position integrated over the interpolation period 0x60C2, mode display = 0x6060, the
heartbeat consumer 0x1016 (the drive faults if the controller falls silent), and SDO
and PDOs only where CiA 301 allows them (no SDO in *stopped*, PDOs only in
*operational*).

The same process simulates the load, stepped on every SYNC after the drives: for the
planar crane a pendulum under the trolley whose rope is the winch's position (load.py),
for the 3D crane (a `bridge` row) a spherical pendulum under bridge and trolley
(load3d.py); with `--inclinometer` the CiA 410 inclinometer on the hook block that
measures its swing (node, sign and offset from the commissioning file's
`[inclinometer]`; with `axes = 2` the two-axis one, its lateral sign and offset too:
the 3D crane's, node 5 unless the file says otherwise). The one-axis inclinometer can be
late, filtered and noisy as a real one (`--inclinometer-delay`, `--inclinometer-filter-ms`,
`--inclinometer-noise`, `--inclinometer-seed`; load.SensorLag), and the planar crane's
rope need not be what the commissioning file's scaling says (`--true-rope`): issue 33's
rope calibration (test_rope_calibration.py).

Each drive powers on where `--start` puts its axis (metres, in the model's input order:
trolley, winch; the 3D crane's bridge, trolley, winch: where the crane's drives stand
while the load rests at the scene's start, `rig.drives_at_rest`), through the
commissioning file's scaling; `--trolley`, `--winch`, `--bridge` (increments) override.

Run as `python drives.py --port N [options]`; it takes commands on stdin, one a line,
and answers each with one JSON line on stdout (see `Drives.command`).
"""

import argparse
import json
import os
import struct
import sys
import tomllib

import can
import canopen
from canopen.sdo import SdoAbortedError

from load import Inclinometer, Load, SensorLag
from load3d import SpatialLoad
from node import SimulatedNode

HERE = os.path.dirname(os.path.abspath(__file__))
EDS = os.path.join(HERE, "cia402-drive.eds")
COMMISSIONING = os.path.join(os.path.dirname(HERE), "scenes", "commissioning.toml")
# Without a commissioning file: the stock nodes, and where the default scene's crane rests.
STOCK_NODES = {"bridge": 4, "trolley": 1, "winch": 2}
STOCK_POSITION = {"bridge": 12e6, "trolley": 12e6, "winch": 8e6}  # increments (µm)
PLANAR, SPATIAL = ("trolley", "winch"), ("bridge", "trolley", "winch")

# Statusword bits (CiA 402).
RTSO, SO, OE, FAULT, VOLTAGE, QS, SOD, WARNING = 0x1, 0x2, 0x4, 0x8, 0x10, 0x20, 0x40, 0x80
REMOTE, FOLLOWING = 0x200, 0x1000
STATES = {
    "not ready": 0x00,
    "switch on disabled": SOD,
    "ready to switch on": QS | RTSO,
    "switched on": QS | SO | RTSO,
    "operation enabled": QS | OE | SO | RTSO,
    "quick stop active": OE | SO | RTSO,
    "fault": FAULT,
}
CSV = 9
INVALID_VALUE = 0x06090030  # SDO abort: invalid value for parameter


def controlword_command(state, cw, previous_cw):
    """The CiA 402 state after controlword `cw` (Tab. 28/29), from `state`."""
    if state == "fault":
        # Fault reset acts on the rising edge of bit 7.
        return "switch on disabled" if cw & 0x80 and not previous_cw & 0x80 else state
    if cw & 0x80:
        return state
    if cw & 0x02 == 0:  # disable voltage
        return "switch on disabled"
    if state == "quick stop active":
        # Left by disable voltage (transition 12); a quick stop repeated every cycle keeps
        # it braking on its ramp (quick stop option 6 stays in quick stop active).
        return state
    if cw & 0x04 == 0:  # quick stop
        return "quick stop active" if state == "operation enabled" else "switch on disabled"
    if cw & 0x0F == 0x06:  # shutdown
        return "ready to switch on" if state != "not ready" else state
    if cw & 0x0F == 0x07:  # switch on / disable operation
        return "switched on" if state in ("ready to switch on", "switched on", "operation enabled") else state
    if cw & 0x0F == 0x0F:  # enable operation (3+4 from ready to switch on)
        return "operation enabled" if state in ("ready to switch on", "switched on", "operation enabled") else state
    return state


class Drive(SimulatedNode):
    """One CiA 402 drive on `network`."""

    def __init__(self, network, node_id, position, refuse_csv=False, sdo_mute=False, status_lag=0):
        self.refuse_csv = refuse_csv
        self.sdo_mute = sdo_mute
        self.status_lag = status_lag
        # Physical: a reboot does not move the axis (an absolute encoder).
        self.position = position
        # Misbehaviour the test asks for (`creep`, `ignore`): the axis moving faster than
        # the drive drives it (a slipping brake), the drive standing whatever its target.
        self.creep = 0
        self.ignoring = False
        # Increments its axis moves per unit of target velocity (0x60FF, µm/s): 1 for a
        # drive whose own velocity scaling matches the commissioning file's 1 µm per
        # increment; a winch whose drum scaling was corrected by the rope calibration has
        # its velocity factor corrected too (docs/COMMISSIONING.md, step 3).
        self.velocity_factor = 1.0
        super().__init__(network, node_id, EDS)
        network.subscribe(0x080, self._on_sync)
        network.subscribe(0x200 + node_id, self._on_rpdo)
        network.subscribe(0x700 + 0x10, self._on_controller_heartbeat)
        self._reset_application()

    # --- process data -----------------------------------------------------------------
    def _reset_application(self):
        self.node.data_store.clear()
        self.state = "switch on disabled"  # "not ready" passes by itself at power-on
        self.controlword = 0
        self.pending = {}
        self.target = 0
        self.velocity = 0
        self.statuswords = []
        self.warning = False
        self.rpdo_mapping = []
        self.tpdos = []
        self.controller_seen = None
        self.syncs = 0
        self.started_log = []
        self.pdo_changed = False

    def mode(self):
        return struct.unpack("<b", self.node.get_data(0x6060, 0))[0]

    def statusword(self):
        sw = STATES[self.state] | REMOTE
        if self.state != "not ready":
            sw |= VOLTAGE
        if self.warning:
            sw |= WARNING
        if self.state == "operation enabled" and self.mode() == CSV:
            sw |= FOLLOWING
        return sw

    def _read(self, index, subindex, od):
        """Values the drive computes (the rest comes from the data store or the EDS)."""
        if index == 0x6041:
            return self.reported_statusword()
        if index == 0x6061:
            return self.mode()
        if index == 0x6064:
            return int(round(self.position))
        if index == 0x606C:
            return self.velocity + self.creep
        if index == 0x6040:
            return self.controlword
        return None

    def _write(self, index, subindex, od, data):
        if 0x1400 <= index < 0x1C00:
            self.pdo_changed = True  # takes effect once stored (at the next SYNC)
        if index == 0x6060 and self.refuse_csv and struct.unpack("<b", data)[0] == CSV:
            raise SdoAbortedError(INVALID_VALUE)  # a drive without CSV
        if index == 0x6040:
            cw = struct.unpack("<H", data)[0]
            self.state = controlword_command(self.state, cw, self.controlword)
            self.controlword = cw

    def reported_statusword(self):
        """The statusword as the TPDO reports it: `status_lag` SYNCs late if asked."""
        if not self.statuswords:
            return self.statusword()
        return self.statuswords[0]

    # --- CiA 301 services ------------------------------------------------------------
    def _sdo_refused(self):
        return self.sdo_mute

    def _after_nmt(self, command, was_operational):
        if command == 0x01:
            self._configure_pdos()
        elif was_operational and self.state == "operation enabled":
            self._connection_lost()

    def _forget_communication(self):
        self.tpdos, self.rpdo_mapping, self.pending = [], [], {}

    def _connection_lost(self):
        """Out of *operational* while enabled: the abort connection option 0x6007."""
        option = struct.unpack("<h", self.node.get_data(0x6007, 0))[0]
        if option == 1:
            self.state = "fault"
        elif option == 2:
            self.state = "switch on disabled"
        elif option == 3:
            self.state = "quick stop active"

    def _on_controller_heartbeat(self, can_id, data, timestamp):
        with self.lock:
            self.controller_seen = timestamp

    def _configure_pdos(self):
        """PDOs as the master wrote them (python-canopen reads 0x14xx/0x16xx/0x18xx/0x1Axx
        from this node's own dictionary)."""
        self.pdo_changed = False
        self.node.rpdo.read()
        self.node.tpdo.read()
        self.tpdos = [m for m in self.node.tpdo.map.values() if m.enabled and 1 <= m.trans_type <= 240]
        rpdo = self.node.rpdo.map[1]
        self.rpdo_mapping = [(v.index, v.subindex, len(v.od) // 8) for v in rpdo] if rpdo.enabled else []
        self.rpdo_sync = 0 <= rpdo.trans_type <= 240
        self.started_log.append(
            {
                "rpdo": [hex(rpdo.cob_id), rpdo.trans_type],
                "tpdo": [[hex(m.cob_id), m.trans_type, len(m.map)] for m in self.tpdos],
            }
        )

    def _on_rpdo(self, can_id, data, timestamp):
        with self.lock:
            if not self.powered or self.node.nmt.state != "OPERATIONAL" or not self.rpdo_mapping:
                return
            offset = 0
            values = {}
            for index, subindex, size in self.rpdo_mapping:
                values[(index, subindex)] = bytes(data[offset : offset + size])
                offset += size
            if self.rpdo_sync:
                self.pending = values  # applied at the next SYNC
            else:
                self._apply(values)

    def _apply(self, values):
        for (index, subindex), raw in values.items():
            self.node.set_data(index, subindex, raw)
            if index == 0x60FF:
                self.target = struct.unpack("<i", raw)[0]

    def period_s(self):
        value = self.node.get_data(0x60C2, 1)[0]
        exponent = struct.unpack("<b", self.node.get_data(0x60C2, 2))[0]
        return value * 10.0**exponent

    def _on_sync(self, can_id, data, timestamp):
        with self.lock:
            if not self.powered:
                return
            self.syncs += 1
            operational = self.node.nmt.state == "OPERATIONAL"
            if operational and self.pdo_changed:
                self._configure_pdos()  # remapped while operational
            if operational and self.pending:
                values, self.pending = self.pending, {}
                self._apply(values)
            self._watch_controller(timestamp)
            dt = self.period_s()
            self.position += (self.velocity * self.velocity_factor + self.creep) * dt
            if self.state == "operation enabled" and self.mode() == CSV:
                self.velocity = 0 if self.ignoring else self.target
            elif self.state == "quick stop active":
                step = struct.unpack("<I", self.node.get_data(0x6085, 0))[0] * dt
                self.velocity = 0 if abs(self.velocity) <= step else self.velocity - step * (1 if self.velocity > 0 else -1)
                self.velocity = int(round(self.velocity))
            else:
                self.velocity = 0
            self.statuswords.append(self.statusword())
            del self.statuswords[: max(0, len(self.statuswords) - 1 - self.status_lag)]
            if operational:
                for tpdo in self.tpdos:
                    if self.syncs % tpdo.trans_type:
                        continue
                    for var in tpdo:
                        var.set_data(self.node.get_data(var.index, var.subindex)[: len(var.od) // 8])
                    tpdo.transmit()

    def _watch_controller(self, now):
        consumer = struct.unpack("<I", self.node.get_data(0x1016, 1))[0]
        timeout_s = (consumer & 0xFFFF) / 1000.0
        if not consumer & 0xFFFF or (consumer >> 16) & 0x7F != 0x10 or self.controller_seen is None:
            return
        if now - self.controller_seen > timeout_s and self.state != "fault":
            self.fault(0x8130, 0x11)  # heartbeat error: the drive stops by itself
            self.controller_seen = None

    # --- what the test does to a drive -------------------------------------------------
    def fault(self, code=0x2310, register=0x03):
        """A fault: the power stage is off, statusword bit 3, an EMCY (generic bit set)."""
        with self.lock:
            self.state = "fault"
            self.target = 0
            self.node.emcy.send(code, register)

    def warn(self):
        """A temperature warning: EMCY with the error register's generic bit clear."""
        with self.lock:
            self.node.emcy.send(0x4210, 0x08)

    def dump(self):
        with self.lock:
            od = self.dictionary()
            return {
                "node": self.id,
                "nmt": self.node.nmt.state,
                "state": self.state,
                "statusword": self.statusword(),
                "mode": self.mode(),
                "position": self.position,
                "velocity": self.velocity,
                "syncs": self.syncs,
                "od": od,
                "started": self.started_log,
            }


class Drives:
    def __init__(self, args):
        bus = can.ThreadSafeBus(
            interface="slcan", channel=f"socket://127.0.0.1:{args.port}", sleep_after_open=0
        )
        self.network = canopen.Network(bus)
        self.network.connect()
        commissioning = {}  # without a file, the stock defaults (as the ECU reads it)
        if os.path.exists(args.commissioning):
            with open(args.commissioning, "rb") as f:
                commissioning = tomllib.load(f)
        rows = {row["axis"]: row for row in commissioning.get("drive", [])}
        # The file's rows in its order (the order the controller commissions them).
        order = [row["axis"] for row in commissioning.get("drive", [])] or list(PLANAR)
        model = SPATIAL if "bridge" in order else PLANAR
        scaling = {
            axis: (rows.get(axis, {}).get("position_scale", 1e-6), rows.get(axis, {}).get("position_offset", 0.0))
            for axis in order
        }
        if args.start and len(args.start) != len(model):
            raise SystemExit(f"drives.py: --start needs {len(model)} coordinates for {', '.join(model)}")
        start = dict(zip(model, args.start)) if args.start else {}
        self.drives = {}
        for axis in order:
            node_id = rows.get(axis, {}).get("node", STOCK_NODES[axis])
            position = getattr(args, axis)
            if position is None and axis in start:
                scale, offset = scaling[axis]
                position = float(round((start[axis] - offset) / scale))  # a whole increment
            if position is None:
                position = STOCK_POSITION[axis]
            self.drives[node_id] = Drive(
                self.network,
                node_id,
                position,
                refuse_csv=node_id in args.refuse_csv,
                sdo_mute=node_id in args.sdo_mute,
                status_lag=args.status_lag if node_id in args.lagging else 0,
            )
        self.axes = {axis: rows.get(axis, {}).get("node", STOCK_NODES[axis]) for axis in order}
        self.inclinometer = None
        axes = {node: scaling[axis] for axis, node in self.axes.items()}
        moved = [self.drives[self.axes[axis]] for axis in model]
        if args.velocity_factor:
            node, factor = args.velocity_factor
            self.drives[int(node)].velocity_factor = factor
        if model == PLANAR:
            self.load = Load(*moved, axes, args.cycle_ms / 1000.0, rope=args.true_rope)
        else:
            if args.true_rope:
                raise SystemExit("drives.py: --true-rope is the planar crane's")
            self.load = SpatialLoad(*moved, axes, args.cycle_ms / 1000.0)
        if args.inclinometer:
            row = commissioning.get("inclinometer", {})
            two_axes = row.get("axes", 1) == 2
            self.inclinometer = Inclinometer(
                self.network,
                row.get("node", 5 if two_axes else 3),
                row.get("sign", 1.0),
                row.get("offset_deg", 0.0),
                lateral=(row.get("lateral_sign", 1.0), row.get("lateral_offset_deg", 0.0)) if two_axes else None,
                lag=SensorLag(
                    args.inclinometer_delay,
                    args.inclinometer_filter_ms / 1000.0,
                    args.inclinometer_noise,
                    args.inclinometer_seed,
                    args.cycle_ms / 1000.0,
                ),
            )
        # After the drives' own: the load swings with the motion they have just taken.
        self.network.subscribe(0x080, self._on_sync)
        for node_id in self.drives:
            if node_id not in args.unpowered:
                self.drives[node_id].boot()
        if self.inclinometer is not None:
            self.inclinometer.boot()

    def _on_sync(self, can_id, data, timestamp):
        with self.load.lock:  # a command sees the load and the reading of one SYNC
            slopes = self.load.on_sync()  # φ, or the 3D crane's (α, β)
            if self.inclinometer is not None:
                if isinstance(slopes, tuple):
                    self.inclinometer.sample(*slopes)
                else:  # the planar pendulum: its path over the period for the sensor's filter
                    self.inclinometer.sample(slopes, path=self.load.path)

    def command(self, line):
        """`power N`, `off N`, `reboot N`, `fault N`, `warn N`, `dump`; `creep N UM_PER_S`
        (the axis moves that much faster than the drive drives it, in every state while
        powered: a slipping brake; 0 ends it), `ignore N` / `obey N` (the drive stands
        whatever its target while its statusword says it follows, and back); for the load
        `swing DEG` (the 3D crane's `swing ALPHA BETA`, the rope's slopes in degrees),
        `kick DEG` (the planar crane), and for the inclinometer `freeze`, `lose`, `heal`:
        one JSON answer (those of the load and the inclinometer with the load's state at
        that moment, `load`)."""
        words = line.split()
        if not words:
            return {"ok": False}
        verb = words[0]
        if verb == "kick" and not hasattr(self.load, "kick"):
            return {"ok": False, "error": "no kick for this crane's load"}
        if verb in ("swing", "kick"):
            state = getattr(self.load, verb)(*(float(w) for w in words[1:]))
            return {"ok": True, "load": state}
        if verb in ("freeze", "lose", "heal"):
            if self.inclinometer is None:
                return {"ok": False, "error": "no inclinometer (--inclinometer)"}
            with self.load.lock:  # between two SYNCs: the state is the frozen reading's
                self.inclinometer.fail({"freeze": "frozen", "lose": "lost", "heal": None}[verb])
                return {"ok": True, "load": self.load.state()}
        if verb == "creep":
            drive = self.drives[int(words[1])]
            with drive.lock:
                drive.creep = int(words[2])
            return {"ok": True}
        nodes = [int(w) for w in words[1:]]
        for n in nodes:
            drive = self.drives[n]
            if verb == "power":
                drive.boot()
            elif verb == "off":
                drive.power_off()
            elif verb == "reboot":
                drive.power_off()
                drive.boot()
            elif verb == "fault":
                drive.fault()
            elif verb == "warn":
                drive.warn()
            elif verb in ("ignore", "obey"):
                with drive.lock:
                    drive.ignoring = verb == "ignore"
            else:
                return {"ok": False, "error": f"unknown command {verb}"}
        if verb == "dump":
            return {
                "ok": True,
                "drives": [d.dump() for d in self.drives.values()],
                "load": self.load.state(),
                "inclinometer": self.inclinometer.dump() if self.inclinometer is not None else None,
            }
        return {"ok": True}

    def close(self):
        for d in self.drives.values():
            d.power_off()
        if self.inclinometer is not None:
            self.inclinometer.power_off()
        self.network.notifier.stop()
        try:
            self.network.bus.shutdown()  # the ECU may be gone already
        except Exception:
            pass


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--port", type=int, required=True)
    p.add_argument(
        "--start",
        type=lambda v: [float(x) for x in v.split(",")],
        help="where each drive stands at power-on, m, in the model's input order (rig.drives_at_rest)",
    )
    p.add_argument("--trolley", type=float, help="trolley position at power-on, increments (12e6)")
    p.add_argument("--winch", type=float, help="winch position at power-on, increments (8e6)")
    p.add_argument("--bridge", type=float, help="bridge position at power-on, increments (12e6)")
    p.add_argument("--unpowered", type=int, nargs="*", default=[], help="nodes not powered at start")
    p.add_argument("--refuse-csv", type=int, nargs="*", default=[], help="nodes that abort 0x6060 = 9")
    p.add_argument("--sdo-mute", type=int, nargs="*", default=[], help="nodes that never answer SDO")
    p.add_argument("--lagging", type=int, nargs="*", default=[], help="nodes whose statusword lags")
    p.add_argument("--status-lag", type=int, default=1, help="SYNCs the statusword lags")
    p.add_argument("--inclinometer", action="store_true", help="the CiA 410 inclinometer on the hook block")
    p.add_argument("--inclinometer-delay", type=int, default=0, help="SYNCs its reading is late (0-5)")
    p.add_argument("--inclinometer-filter-ms", type=float, default=0.0, help="its first-order filter, ms (0: none)")
    p.add_argument("--inclinometer-noise", type=float, default=0.0, help="its noise, degrees (1 sigma)")
    p.add_argument("--inclinometer-seed", type=int, default=0, help="the seed of its noise")
    p.add_argument(
        "--true-rope",
        type=lambda v: tuple(float(x) for x in v.split(",")),
        help="SCALE,OFFSET: the rope's true m per winch increment and m at increment 0, where the "
        "commissioning file's scaling is wrong (the planar crane)",
    )
    p.add_argument(
        "--velocity-factor",
        type=lambda v: (int(v.split(":")[0]), float(v.split(":")[1])),
        help="NODE:F: that drive moves F increments per unit of its target velocity (1)",
    )
    p.add_argument("--commissioning", default=COMMISSIONING, help="the scene's commissioning.toml: scaling, inclinometer")
    p.add_argument("--cycle-ms", type=float, default=10.0, help="the SYNC period the load is stepped by")
    args = p.parse_args()
    drives = Drives(args)
    print(json.dumps({"ok": True, "ready": True}), flush=True)
    try:
        for line in sys.stdin:
            if line.strip() == "quit":
                break
            try:
                answer = drives.command(line)
            except Exception as e:  # an answer, never a silent death
                answer = {"ok": False, "error": repr(e)}
            print(json.dumps(answer), flush=True)
            if "load" in answer and line.split()[0] != "dump":  # the story, for the run's stderr
                print(line.strip(), json.dumps(answer["load"]), file=sys.stderr, flush=True)
    finally:
        drives.close()


if __name__ == "__main__":
    main()
