"""The frames the state feedback adds — the CiA 410 inclinometer's (node 3) and the
controller's EMCY 0xFF20 — decoded by cantools against can/crane.dbc, independently of
the project's own DBC reader. The bytes are those the controller's tests assert it
sends or takes (controller/tests/closed_loop.rs, host-tests/tests/can_frames.rs)."""

import struct

import cantools

from rig import DBC


def db():
    return cantools.database.load_file(DBC)


def test_the_inclinometer_slope_is_degrees_at_the_commissioned_resolution():
    m = db().get_message_by_frame_id(0x183)
    assert m.name == "TPDO1_Inclinometer"
    assert abs(m.decode(struct.pack("<h", -1234))["slope_long16"] - (-12.34)) < 1e-9


def test_the_inclinometer_sdo_heartbeat_and_emcy_decode():
    d = db()
    write = d.decode_message(0x603, bytes([0x2B, 0x00, 0x60, 0, 10, 0, 0, 0]))
    assert (write["index"], write["subindex"], write["data"]) == (0x6000, 0, 10)
    answer = d.decode_message(0x583, bytes([0x43, 0, 0x10, 0, 0x9A, 1, 1, 0]))
    assert (answer["index"], answer["data"] & 0xFFFF) == (0x1000, 410)
    assert str(d.decode_message(0x703, bytes([5]))["nmt_state"]) == "Operational"
    emcy = d.decode_message(0x083, bytes([0, 0x50, 0x01, 0, 0, 0, 0, 0]))
    assert emcy["error_code"] == 0x5000


def test_feedback_off_is_emcy_0xff20_fault_15_naming_the_inclinometer_and_the_reason():
    e = db().decode_message(0x090, bytes([0x20, 0xFF, 0x80, 15, 3, 1, 0, 0]))
    # The DBC names the controller's EMCY codes (VAL_ 144 error_code, issue 32).
    assert (e["error_code"].value, e["error_code"].name) == (0xFF20, "FeedbackOff")
    assert e["error_register"] == 0x80, "a warning: no generic error bit"
    assert str(e["fault"]) == "FeedbackOff"
    assert (e["node"], e["detail"]) == (3, 1), "inclinometer, angle lost"
