"""What every simulated CANopen slave in the drives' process shares (drives.py's CiA 402
drives, load.py's CiA 410 inclinometer): a python-canopen LocalNode with the CiA 301
duties python-canopen leaves to the application — no SDO while unpowered or *stopped*,
NMT commands only when powered and addressed, a reset node or communication as a boot,
the boot-up message and the heartbeat on power-on.

A subclass provides `_reset_application()` (its state after power-on or reset node),
`_forget_communication()` (what a reset communication clears besides 0x1000-0x1FFF),
`_after_nmt(command, was_operational)` (what a state change means to it), and may
refuse SDO with `_sdo_refused()`.
"""

import threading

import canopen


class SimulatedNode:
    """A LocalNode `node_id` from `eds` on `network`, with the glue above."""

    def __init__(self, network, node_id, eds):
        self.network = network
        self.id = node_id
        self.node = canopen.LocalNode(node_id, eds)
        self.lock = threading.RLock()
        self.powered = False
        self.node.add_read_callback(self._read)
        self.node.add_write_callback(self._write)
        network.add_node(self.node)
        # SDO and NMT through the glue: off when unpowered, no SDO in stopped.
        network.unsubscribe(self.node.sdo.rx_cobid, self.node.sdo.on_request)
        network.subscribe(self.node.sdo.rx_cobid, self._on_sdo)
        network.unsubscribe(0, self.node.nmt.on_command)
        network.subscribe(0, self._on_nmt)

    def _sdo_refused(self):
        return False

    def _on_sdo(self, can_id, data, timestamp):
        with self.lock:
            if not self.powered or self._sdo_refused() or self.node.nmt.state == "STOPPED":
                return
            self.node.sdo.on_request(can_id, data, timestamp)

    def _on_nmt(self, can_id, data, timestamp):
        with self.lock:
            if not self.powered or len(data) != 2 or data[1] not in (0, self.id):
                return
            command = data[0]
            if command in (0x81, 0x82):  # reset node / communication
                self.boot(reset_application=command == 0x81)
                return
            was_operational = self.node.nmt.state == "OPERATIONAL"
            self.node.nmt.on_command(can_id, data, timestamp)
            self._after_nmt(command, was_operational)

    def boot(self, reset_application=True):
        """Power-on (or an NMT reset): boot-up message, pre-operational, heartbeat 0x1017."""
        with self.lock:
            self.node.nmt.stop_heartbeat()
            if reset_application:
                self._reset_application()
            else:
                for index in [i for i in self.node.data_store if 0x1000 <= i < 0x2000]:
                    del self.node.data_store[index]
                self._forget_communication()
            self.powered = True
            self.node.nmt.state = "INITIALISING"  # sends the boot-up message
            self.node.nmt.state = "PRE-OPERATIONAL"  # starts the heartbeat (0x1017)

    def power_off(self):
        with self.lock:
            self.powered = False
            self.node.nmt.stop_heartbeat()

    def dictionary(self):
        """What was written into the node: `{"IIII:s": hex}` from its data store."""
        with self.lock:
            od = {}
            for index, subs in sorted(self.node.data_store.items()):
                for subindex, raw in sorted(subs.items()):
                    od[f"{index:04X}:{subindex}"] = raw.hex()
            return od
