"""Issue 33 over the bus: the documented rope calibration (docs/COMMISSIONING.md, "Rope
calibration") against a python-canopen inclinometer that is late, filtered and noisy as
a real CiA 410 sensor is, on a crane whose drum does not measure the true rope.

The plant (load.py, in the drives' process) hangs the load on the *true* rope,
`(1 + S) · drum + O` (`drives.py --true-rope`), where the commissioning file's scaling
says `drum`: a drum-scale error `S` and a hook block `O` longer than commissioned. The
inclinometer reports its sample `delay` SYNCs late, through a first-order filter, with
0.05° of Gaussian noise (seeded: a run is reproducible; `load.SensorLag`). Each case runs
the procedure as a commissioning engineer does, over the bus only:

1. the inclinometer's timing commissioned (`[inclinometer] delay_cycles`, `filter_ms`),
   the paper's move (12, 8) → (20, 4) m in 8 s and back three times as the first moves
   after power-up, with the state feedback (scenes/paper-crane-feedback.toml);
2. 0x2004:1..6 read over SDO by python-canopen (typed by can/crane-controller.eds):
   offered (sub 4 = 2) — then the learnt rope must be within the uncertainty the
   controller states (sub 5) of the true one over the whole rope range 3–9 m — or
   refused with its named reason (4 too uncertain: its uncertainty beyond 20 mm, the
   moves repeated as the procedure says, up to twice; 5 the delay not as
   commissioned), and then not saved (the test fails, naming it: with the timing
   commissioned the study offers 999 of 1000);
3. an offered estimate saved as step 3 says (the winch's `position_scale` × (1 + s),
   `position_offset` × (1 + s) + o, and the drive's velocity factor by the same
   1 + s), the crane powered again with it, and the paper's move made: 5 s after its end
   the load (the plant's own, not the controller's estimate) within ±20 mm of the target
   vertically, ±50 mm horizontally, swinging < 0.1°.

Before the calibration the same crane sets the load 90–180 mm off vertically (checked
after the first calibration move: the test can fail). An inclinometer two cycles late
where the file says 0 is refused with reason 5 and its delay measured (sub 6). Every
frame of every run decodes with cantools against can/crane.dbc.
"""

import math
import os
import re
import time
import tomllib

import pytest

from rig import ACCEPTED, MODE, ROOT
from test_black_box import wait_rest
from test_feedback import HEARTBEAT3, TPDO3, distance
from test_interop import WINCH, assert_setpoints_within_limits, rigs  # noqa: F401

SCENE = "scenes/paper-crane-feedback.toml"
COMMISSIONING = "scenes/commissioning.toml"
NOISE_DEG = 0.05  # 1σ, the largest
DRUM, HOOK = 1e-6, 0.0  # the winch's position_scale and position_offset, as commissioned
START, TARGET, DURATION = (12.0, 8.0), (20.0, 4.0), 8.0  # the paper's move
ROUND_TRIPS = 3  # docs/COMMISSIONING.md, step 1
EXTRA_ROUND_TRIPS = 2  # at most, while the estimate is refused as too uncertain (step 2)
# 0x2004:4
NOTHING, OFFSET, BOTH, CLAMPED, UNCERTAIN, DELAY_MISMATCH = range(6)
MAX_UNCERTAINTY_UM = 20_000  # what the controller offers at most (controller/src/rope.rs)
ROPE_RANGE = (3.0, 9.0)  # m, over which 0x2004:5 bounds the length

# id: (delay cycles, filter ms — the sensor's and as commissioned; drum-scale error S,
# rope offset O m — the plant's truth; noise seed)
CASES = {
    "delay-0": (0, 0.0, +0.010, +0.05, 1),
    "delay-2-filter-10ms": (2, 10.0, -0.015, -0.08, 2),
    "delay-5": (5, 0.0, +0.020, +0.10, 3),
}


# --- helpers -----------------------------------------------------------------------------
def crane_files(directory, delay, filter_ms, winch=(DRUM, HOOK)):
    """The feedback scene in `directory` with its commissioning file: the stock one with
    the inclinometer's timing commissioned and the winch's scaling `winch` (m per
    increment, m at increment 0). Returns the scene's path."""
    os.makedirs(directory, exist_ok=True)
    with open(os.path.join(ROOT, SCENE)) as f:
        scene = f.read()
    with open(os.path.join(ROOT, COMMISSIONING)) as f:
        head, trolley, winch_row = f.read().split("[[drive]]")
    assert 'axis = "winch"' in winch_row
    scale, offset = winch
    winch_row = re.sub(r"position_scale = \S+", f"position_scale = {scale!r}", winch_row, count=1)
    winch_row = re.sub(r"position_offset = \S+", f"position_offset = {offset!r}", winch_row, count=1)
    text = "[[drive]]".join((head, trolley, winch_row))
    text += f"\n[inclinometer]\nnode = 3\ndelay_cycles = {delay}\nfilter_ms = {float(filter_ms)!r}\n"
    with open(os.path.join(directory, "commissioning.toml"), "w") as f:
        f.write(text)
    row = [r for r in tomllib.loads(text)["drive"] if r["axis"] == "winch"][0]
    assert (row["position_scale"], row["position_offset"]) == (scale, offset), row
    path = os.path.join(directory, "paper-crane-feedback.toml")
    with open(path, "w") as f:
        f.write(scene)
    return path


def sensor_args(delay, filter_ms, seed, true_rope):
    return [
        "--inclinometer",
        "--inclinometer-delay",
        str(delay),
        "--inclinometer-filter-ms",
        repr(filter_ms),
        "--inclinometer-noise",
        repr(NOISE_DEG),
        "--inclinometer-seed",
        str(seed),
        "--true-rope",
        f"{true_rope[0]!r},{true_rope[1]!r}",
    ]


def open_rig(rigs, scene, drive_args, seconds):
    """A rig on `scene`, ready, the inclinometer operational (its heartbeat and TPDO)."""
    rig = rigs(scene=scene, drive_args=drive_args, seconds=seconds)
    rig.wait_mode("ready")
    rig.wait(
        lambda: any(d == b"\x05" for (_, d) in rig.recorder.with_id(HEARTBEAT3)) and rig.recorder.with_id(TPDO3),
        3,
        "the inclinometer operational",
    )
    return rig


def move(rig, request_id, target):
    """The paper's move (8 s) to `target`, accepted at rest; returns the load once the
    drives rest after it."""
    rig.move(request_id, *target, DURATION)
    assert rig.answer(request_id) == (ACCEPTED, 0)
    time.sleep(DURATION)
    wait_rest(rig, 8)
    return rig.load()


def calibration(rig):
    """0x2004:1..6 as python-canopen reads them (typed by the EDS)."""
    record = rig.controller.sdo[0x2004]
    names = ("scale_ppm", "offset_um", "samples", "learnt", "uncertainty_um", "delay_us")
    return {name: record[sub].raw for sub, name in enumerate(names, start=1)}


def rope_error_mm(learnt, truth):
    """The largest distance, mm, between the rope the estimate gives and the true one over
    the rope range (both are straight lines in the drum's reading: the ends)."""
    s, o = learnt["scale_ppm"] * 1e-6, learnt["offset_um"] * 1e-6
    true_s, true_o = truth
    return max(abs(((1 + s) * l + o) - ((1 + true_s) * l + true_o)) * 1e3 for l in ROPE_RANGE)


def vertical_mm(load, target_z):
    return (load["load_z_m"] - target_z) * 1e3


def reading_noise_deg(log, after):
    """The noise of the inclinometer's readings on the bus after `after` (the load nearly
    still), as cantools decodes its TPDO1 (*slope long16*, °): the spread of the
    differences of successive readings over √2 — a swing below 0.1° changes the reading
    by < 0.002° a cycle, the noise (white) by √2 σ."""
    slopes = [m["slope_long16"] for (t, m) in log.decoded(TPDO3) if t > after]
    steps = [b - a for a, b in zip(slopes, slopes[1:])]
    assert len(steps) > 200, len(steps)
    mean = sum(steps) / len(steps)
    return math.sqrt(sum((d - mean) ** 2 for d in steps) / len(steps) / 2)


def check_log(log):
    """Every frame decoded, no EMCY (the feedback stayed on), set points within limits."""
    log.assert_decodes()
    assert not log.sent(0x090), [d.hex() for (_, d) in log.sent(0x090)]
    assert_setpoints_within_limits(log)


# --- the calibration, saved, and a move -------------------------------------------------------
@pytest.mark.parametrize("case", list(CASES))
def test_the_rope_calibration_with_a_late_noisy_inclinometer_sets_the_load_down_on_target(rigs, tmp_path, case):
    delay, filter_ms, true_s, true_o, seed = CASES[case]
    truth = (DRUM * (1 + true_s), HOOK * (1 + true_s) + true_o)  # the plant's rope per increment, at increment 0
    scene = crane_files(tmp_path / "as-built", delay, filter_ms)
    rig = open_rig(rigs, scene, sensor_args(delay, filter_ms, seed, truth), seconds=180)
    # Step 1: the paper's move and back, three times.
    request_id = 1
    before = None
    for _ in range(ROUND_TRIPS):
        at_target = move(rig, request_id, TARGET)
        before = before or at_target
        move(rig, request_id + 1, START)
        request_id += 2
    # Step 2: 0x2004; refused as too uncertain, the moves are repeated (the sums go on),
    # as docs/COMMISSIONING.md says, up to twice.
    learnt = calibration(rig)
    refusals = []
    while learnt["learnt"] == UNCERTAIN and len(refusals) < EXTRA_ROUND_TRIPS:
        assert learnt["uncertainty_um"] > MAX_UNCERTAINTY_UM, learnt  # the reason it names
        refusals.append(learnt)
        move(rig, request_id, TARGET)
        move(rig, request_id + 1, START)
        request_id += 2
        learnt = calibration(rig)
    status = rig.status()
    check_log(rig.close())
    assert status[3:6] == [MODE["ready"], 0, 0], status
    error = rope_error_mm(learnt, (true_s, true_o))
    story = f"{case}: refused first {refusals}, learnt {learnt}, truth S {true_s * 1e6:+.0f} ppm O {true_o * 1e6:+.0f} um, error {error:.1f} mm"
    print(story, f"; uncalibrated the load ended {vertical_mm(before, TARGET[1]):+.1f} mm vertically")
    # The uncalibrated crane misses the target height: what the calibration must correct.
    assert abs(vertical_mm(before, TARGET[1])) > 50, before
    assert learnt["samples"] > 0, story
    assert learnt["learnt"] in (BOTH, UNCERTAIN, DELAY_MISMATCH), story
    if learnt["learnt"] == UNCERTAIN:
        # Refused, with the reason it gives, after every round trip the procedure allows:
        # the issue's other outcome ("within a stated tolerance of the truth ..., or refused
        # with a reason"). Honest only if the truth lies within what it states; not saved
        # (no step 3), the engineer calibrates again. (Seen once with 5 cycles of delay, in
        # seven runs: uncertainty 29.3 mm, error 7.1 mm, 5 round trips.)
        assert learnt["uncertainty_um"] > MAX_UNCERTAINTY_UM, story
        assert error <= learnt["uncertainty_um"] * 1e-3, story
        print(f"refused as uncertain after {ROUND_TRIPS + len(refusals)} round trips: {story}")
        return
    if learnt["learnt"] == DELAY_MISMATCH:
        pytest.fail(f"refused for its delay although the delay is commissioned: {story}")
    # Offered: within the uncertainty the controller states, over 3-9 m of rope.
    assert learnt["uncertainty_um"] <= MAX_UNCERTAINTY_UM, story
    assert error <= learnt["uncertainty_um"] * 1e-3, story
    # Step 3: saved as the winch's scaling (and its velocity factor), powered again.
    s, o = learnt["scale_ppm"] * 1e-6, learnt["offset_um"] * 1e-6
    saved = crane_files(tmp_path / "calibrated", delay, filter_ms, winch=(DRUM * (1 + s), HOOK * (1 + s) + o))
    args = sensor_args(delay, filter_ms, seed + 100, truth) + ["--velocity-factor", f"{WINCH}:{1 / (1 + s)!r}"]
    rig = open_rig(rigs, saved, args, seconds=40)
    rig.move(1, *TARGET, DURATION)
    assert rig.answer(1) == (ACCEPTED, 0)
    time.sleep(DURATION + 5.0)
    end = rig.load()
    status = rig.status()
    log = rig.close()
    check_log(log)
    assert status[3:6] == [MODE["ready"], 0, 0], status
    # The sensor on the bus is as noisy as asked (0.05°, read at 0.01°): after the move.
    t_accept = next(t for (t, d) in log.sent(0x190) if d[0] == 1 and d[1] == ACCEPTED)
    noise = reading_noise_deg(log, t_accept + DURATION + 1.0)
    print(
        f"{case}: calibrated, 5 s after the move the load {vertical_mm(end, TARGET[1]):+.1f} mm vertically, "
        f"{distance(end, TARGET[0]) * 1e3:.1f} mm horizontally, swinging {end['amplitude_deg']:.3f}°; "
        f"the readings' noise on the bus {noise:.4f}°"
    )
    assert 0.04 <= noise <= 0.06, noise
    assert abs(vertical_mm(end, TARGET[1])) <= 20, end
    assert distance(end, TARGET[0]) <= 0.050, end
    assert end["amplitude_deg"] < 0.1, end


# --- a delay not commissioned --------------------------------------------------------------
def test_an_inclinometer_later_than_commissioned_is_measured_and_refused(rigs, tmp_path):
    """The sensor two cycles late, the file saying 0: the estimate refused with reason 5
    and the delay shown in sub 6 — at least a whole cycle beyond the commissioned, and
    no more than the true 20 ms (+ the 4 ms it tolerates). It reads low, 15.7–16.0 ms
    after this one round trip (the study's closed loop: 17.6 ms, docs/RESULTS.md), so
    "the whole cycles of it" may take a second calibration to find
    (docs/COMMISSIONING.md: calibrate again until sub 4 no longer says 5)."""
    delay, seed = 2, 4
    truth = (DRUM * 1.01, HOOK)
    scene = crane_files(tmp_path / "as-built", 0, 0.0)  # the file says 0 cycles
    rig = open_rig(rigs, scene, sensor_args(delay, 0.0, seed, truth), seconds=60)
    move(rig, 1, TARGET)  # one round trip: the refusal needs no uncertainty
    move(rig, 2, START)
    learnt = calibration(rig)
    check_log(rig.close())
    print(f"late by {delay} cycles, commissioned 0: learnt {learnt}")
    assert learnt["learnt"] == DELAY_MISMATCH, learnt
    assert 10_000 <= learnt["delay_us"] <= delay * 10_000 + 4_000, learnt
