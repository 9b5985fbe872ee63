"""The 3D crane's move frame (RPDO2 of the controller, 0x310), read independently of the
project's own code: cantools against can/crane.dbc, and python-canopen against the
controller's EDS (its RPDO2 communication and mapping parameters, 0x1401/0x1601). The
bytes are those the controller's unit test pins for request_frame(Move3d { id 1,
target (1, 2, 3) m, duration 0.2 s -> 1 s }) (controller/src/commands.rs)."""

import struct

import cantools
from canopen import objectdictionary

from rig import CONTROLLER_EDS, DBC

FRAME = bytes([1, 0xE8, 0x03, 0xD0, 0x07, 0xB8, 0x0B, 1])


def test_cantools_encodes_and_decodes_the_3d_move_as_the_controller_does():
    db = cantools.database.load_file(DBC)
    msg = db.get_message_by_frame_id(0x310)
    assert msg.name == "Move3d_Controller"
    fields = {"request_id": 1, "target_x": 1.0, "target_y": 2.0, "target_z": 3.0, "duration": 1}
    assert msg.encode(fields) == FRAME
    decoded = msg.decode(FRAME)
    assert decoded["target_y"] == 2.0 and decoded["duration"] == 1


def test_the_eds_maps_rpdo2_to_the_same_fields():
    od = objectdictionary.import_od(CONTROLLER_EDS, node_id=0x10)
    assert od[0x1401][1].default == 0x310
    mapping = [od[0x1601][k].default for k in range(1, od[0x1601][0].default + 1)]
    fields = [(m >> 16, (m >> 8) & 0xFF, m & 0xFF) for m in mapping]
    names = [od[index][sub].name for (index, sub, _) in fields]
    assert names == ["Request id", "Target x_C mm", "Target y_C mm", "Target z_C mm", "Duration s"]
    # Unpacked by the mapping's bit lengths: 1 → id, (1, 2, 3) m in mm, 1 s.
    fmt = "<" + "".join({8: "B", 16: "H"}[bits] for (_, _, bits) in fields)
    assert struct.unpack(fmt, FRAME) == (1, 1000, 2000, 3000, 1)
