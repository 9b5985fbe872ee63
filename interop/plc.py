"""A PLC's master switch in a process of its own (issue 28's operator, test_operator.py),
on its own SLCAN connection to the virtual ECU:

* by default the speed demand `Operator_Controller` (RPDO3 0x410) encoded by cantools
  from can/crane.dbc every `--period` s, its alive counter changing every frame;
* with `--sdo`, a PLC without PDOs: the same fields through 0x2010 with python-canopen's
  SDO client — the flags (enable, manual request) and centred demands written once,
  then the alive counter (sub 1, which submits the fields as one frame) every
  `--period` s.

Why a process, with the ECU's and the drives' priority (rig.realtime): a PLC's cyclic
task keeps its period whatever else runs, and the controller treats a gap longer than
its dead-man deadline (90 ms) as the switch let go. As a thread of the test's own
process the frames shared one interpreter with the test's polling and the supervisor's
listener, and on a loaded machine a gap of that length stopped the crane in the middle
of a stick the test held (CI, test_the_3d_crane_follows_a_diagonal_stick_straight…:
0.59 m travelled where 1 m was due).

Commands on stdin, one JSON object a line, each answered with one JSON line on stdout
(`{"ok": false, "error": …}` where it could not be done):

* `{"set": {field: value, …}}` — the DBC's fields from the next frame on (refused, and
  the frame unchanged, if cantools cannot encode them, and with `--sdo`, whose frame is
  what `download` wrote);
* `{"download": [sub, "hex"]}` (`--sdo`) — one SDO download into 0x2010, between two
  submissions;
* `{"silence": true}` — no frame more (a dead-man drop); the answer carries every
  frame sent (`sent`, hex) and the number of SDO submissions (`submitted`), and the
  process ends.

`--fields` (JSON) sets fields before the first frame. The first line on stdout
(`{"ready": true}`) comes once the first frame is on the bus. A failed send stops the
cyclic task with the reason on stderr; the next command is answered with it and the
process ends with exit status 1 (stdin's end ends it too).

With `--sdo` the PLC's SDO client shares node 0x10's server with the test's supervisor
(`rig.Rig.controller`), and every client of the virtual ECU receives every frame: a
supervisor's SDO transfer while this one runs could take the other's answer for its own
(python-canopen checks an expedited download's answer by its command byte alone), so a
test does none while an `SdoOperator` runs.
"""

import argparse
import json
import struct
import sys
import threading
import time

import can
import canopen

from rig import CONTROLLER, CONTROLLER_EDS, dbc

OPERATOR_DEMAND = 0x2010  # the controller's object the SDO path writes


class Switch:
    """The cyclic task: one frame (or one SDO submission) every `period`."""

    def __init__(self, network, period, sdo, fields):
        self.network = network
        self.period = period
        self.lock = threading.Lock()
        self.counter = 0
        self.sent = []  # the bytes of every RPDO3 frame sent
        self.submitted = 0
        self.running = True
        self.message = dbc().get_message_by_name("Operator_Controller")
        self.fields = {
            "enable": 1,
            "manual_request": 1,
            "micro_speed": 0,
            "demand_x": 0.0,
            "demand_y": 0.0,
            "demand_z": 0.0,
        }
        self.fields.update(fields)
        self.message.encode({"alive_counter": 0, **self.fields})  # fails here, not in a tick
        self.sdo = None
        if sdo:
            controller = canopen.RemoteNode(CONTROLLER, CONTROLLER_EDS)
            controller.sdo.RESPONSE_TIMEOUT = 1.0
            network.add_node(controller)
            self.sdo = controller.sdo
            for sub, value in ((2, struct.pack("<B", 0b011)), (3, b"\0\0"), (4, b"\0\0"), (5, b"\0\0")):
                self.sdo.download(OPERATOR_DEMAND, sub, value)

    def tick(self):
        with self.lock:
            self.counter = (self.counter + 1) % 256
            if self.sdo is not None:
                self.sdo.download(OPERATOR_DEMAND, 1, struct.pack("<B", self.counter))
                self.submitted += 1
            else:
                data = bytes(self.message.encode({"alive_counter": self.counter, **self.fields}))
                self.network.send_message(self.message.frame_id, data)
                self.sent.append(data)

    def run(self):
        """The ticks after the first (`main` sends it before saying ready)."""
        due = time.monotonic()
        while True:
            due += self.period
            time.sleep(max(0.0, due - time.monotonic()))
            if not self.running:
                return
            self.tick()

    def command(self, request):
        if "set" in request:
            if self.sdo is not None:  # the SDO path sends what `download` wrote, not fields
                return {"ok": False, "error": "set with --sdo: download the sub instead"}
            unknown = set(request["set"]) - set(self.fields)
            if unknown:
                return {"ok": False, "error": f"no such field {sorted(unknown)}"}
            with self.lock:
                fields = {**self.fields, **request["set"]}
                self.message.encode({"alive_counter": self.counter, **fields})
                self.fields = fields
            return {"ok": True}
        if "download" in request:
            if self.sdo is None:
                return {"ok": False, "error": "download without --sdo"}
            sub, value = request["download"]
            with self.lock:
                self.sdo.download(OPERATOR_DEMAND, sub, bytes.fromhex(value))
            return {"ok": True}
        if request.get("silence"):
            self.running = False
            return {"ok": True}
        return {"ok": False, "error": f"unknown command {request}"}


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--port", type=int, required=True, help="the virtual ECU's SLCAN port")
    p.add_argument("--period", type=float, default=0.02, help="s between frames (submissions)")
    p.add_argument("--sdo", action="store_true", help="0x2010 over SDO instead of RPDO3")
    p.add_argument("--fields", type=json.loads, default={}, help="JSON: fields of the first frame on")
    args = p.parse_args()
    if args.sdo and args.fields:
        p.error("--fields is the RPDO3 frame's: with --sdo the fields are downloaded")
    bus = can.ThreadSafeBus(interface="slcan", channel=f"socket://127.0.0.1:{args.port}", sleep_after_open=0)
    network = canopen.Network(bus)
    network.connect()  # its notifier reads what the ECU sends to every client
    switch = Switch(network, args.period, args.sdo, args.fields)
    failure = []

    def cyclic():
        try:
            switch.run()
        except Exception as e:  # the bus gone: said on stderr and in the next answer
            failure.append(e)
            print(f"plc: the cyclic task failed: {type(e).__name__}: {e}", file=sys.stderr, flush=True)
            switch.running = False

    switch.tick()
    print(json.dumps({"ready": True}), flush=True)
    thread = threading.Thread(target=cyclic, daemon=True)
    thread.start()
    for line in sys.stdin:
        try:
            answer = switch.command(json.loads(line))
        except Exception as e:  # a bad line, an SDO abort or timeout: the test is told
            answer = {"ok": False, "error": f"{type(e).__name__}: {e}"}
        if not switch.running:  # silenced (or failed): the answer once the last frame is out
            thread.join()
            answer.update(sent=[d.hex() for d in switch.sent], submitted=switch.submitted)
        if failure:
            answer = {"ok": False, "error": f"the cyclic task failed: {failure[0]}"}
        print(json.dumps(answer), flush=True)
        if not switch.running:
            break
    switch.running = False
    thread.join()
    try:
        network.disconnect()
    except Exception as e:  # the ECU already gone at the run's end
        print(f"plc: disconnect: {type(e).__name__}: {e}", file=sys.stderr, flush=True)
    sys.exit(1 if failure else 0)


if __name__ == "__main__":
    main()
