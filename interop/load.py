"""The load and its sensor for the drives' process (drives.py): a pendulum hanging from
the trolley, moved by the two simulated drives, and a CiA 410 inclinometer on the hook
block (python-canopen LocalNode, cia410-inclinometer.eds) that measures its swing.

The pendulum is the crane of Eqs. 21-22 (the rope massless and straight, the load a
point): `φ̈ = −(g sin φ + cos φ · ẍ + 2 l̇ φ̇) / l`, the rope length `l` and the trolley
position `x` those of the drives (position actual through the commissioning file's
scaling, as the controller reads them). The drives in CSV hold their velocity from one
SYNC to the next (drives.py), so the trolley's acceleration is a velocity step at each
SYNC: it changes φ̇ by `−cos φ · Δẋ / l` there, and between SYNCs the pendulum swings
with the trolley at constant speed and the rope at constant rate (RK4, 1 ms steps). The
drives have no lag and there is no friction, noise or wind: a plant that is not the
controller's model (its drives have lags of 30 and 20 ms), but the simplest one that the
test can reason about — a swing left alone keeps its amplitude.

The angle φ is the controller's (sim/src/plant.rs, the virtual bus's
inclinometer): positive with the load displaced towards +x, the load at `x + l sin φ`.
The inclinometer reports *slope long16* (0x6010) as the controller converts it back
(`InclinometerSetup::angle`): `slope · resolution = φ / sign + offset` in degrees, the
resolution 0x6000 in 0.001° as commissioned, the sign and offset of the commissioning
file's `[inclinometer]`.
"""

import collections
import math
import os
import random
import struct
import threading

from node import SimulatedNode

EDS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "cia410-inclinometer.eds")
# The 3D crane's two-axis inclinometer (load3d.py): slope lateral16 (0x6020) as well.
EDS_TWO_AXES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "cia410-inclinometer-2axis.eds")
G = 9.81  # m/s², Tab. 3
SUBSTEPS = 10  # RK4 steps per SYNC period


class Load:
    """The pendulum under the trolley; `trolley` and `winch` are drives.py's `Drive`s,
    `axes` maps each to (scale m per increment, offset m) from the commissioning file."""

    def __init__(self, trolley, winch, axes, cycle_s, rope=None):
        self.trolley, self.winch = trolley, winch
        self.axes = axes
        # The rope's true scaling (m per increment of the winch, m at increment 0), where
        # it is not what the commissioning file says: a drum-scale error or a hook block
        # of another length (issue 33's rope calibration). None: the file's.
        self.true_rope = rope
        self.cycle_s = cycle_s
        self.lock = threading.RLock()
        self.phi = 0.0  # rad
        self.rate = 0.0  # φ̇, rad/s
        self.syncs = 0
        with self.lock:
            self.vx, self.vl = self._velocities()
            self.l = self.rope()

    def _metres(self, drive, value):
        scale, offset = self.axes[drive.id]
        return offset + scale * value

    def trolley_x(self):
        return self._metres(self.trolley, self.trolley.position)

    def rope(self):
        if self.true_rope is not None:
            scale, offset = self.true_rope
            return offset + scale * self.winch.position
        return self._metres(self.winch, self.winch.position)

    def _velocities(self):
        rope_scale = self.axes[self.winch.id][0] if self.true_rope is None else self.true_rope[0]
        return (
            self.axes[self.trolley.id][0] * self.trolley.velocity * self.trolley.velocity_factor,
            rope_scale * self.winch.velocity * self.winch.velocity_factor,
        )

    def _accelerations(self, t, phi, rate, l0):
        l = max(l0 + self.vl * t, 0.1)
        return rate, -(G * math.sin(phi) + 2.0 * self.vl * rate) / l

    def on_sync(self):
        """After the drives took this SYNC: the swing over the period that ended (the
        trolley and the rope at the speeds they held), then the trolley's velocity step."""
        with self.lock:
            self.syncs += 1
            h = self.cycle_s / SUBSTEPS
            l0, phi, rate = self.l, self.phi, self.rate
            self.path = []
            for i in range(SUBSTEPS):
                t = i * h
                k1 = self._accelerations(t, phi, rate, l0)
                k2 = self._accelerations(t + h / 2, phi + h / 2 * k1[0], rate + h / 2 * k1[1], l0)
                k3 = self._accelerations(t + h / 2, phi + h / 2 * k2[0], rate + h / 2 * k2[1], l0)
                k4 = self._accelerations(t + h, phi + h * k3[0], rate + h * k3[1], l0)
                phi += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
                rate += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
                self.path.append(phi)
            self.l = max(self.rope(), 0.1)
            vx, vl = self._velocities()
            rate -= math.cos(phi) * (vx - self.vx) / self.l
            self.phi, self.rate, self.vx, self.vl = phi, rate, vx, vl
            return phi

    def amplitude(self, still=False):
        """The swing's amplitude, rad: the angle at which its energy would turn it (the
        rope held at its length). With `still`, as if the trolley stopped now: the
        load's own motion, that a moving trolley's velocity step would leave to it."""
        rate = self.rate + (math.cos(self.phi) * self.vx / self.l if still else 0.0)
        c = math.cos(self.phi) - self.l * rate**2 / (2 * G)
        return math.acos(max(-1.0, min(1.0, c)))

    def swing(self, degrees):
        """The swing's amplitude is `degrees` now, the load at a turning point (φ̇ = 0):
        as a load already swinging when the controller first looks at it."""
        with self.lock:
            self.phi, self.rate = math.radians(degrees), 0.0
            return self.state()

    def kick(self, degrees):
        """The swing's amplitude is `degrees` now, by a blow to the load: the angle stays,
        its rate changes (in the direction it had, + if none). A swing at rest starts so
        (a gust, a knock): the angle itself never jumps, so a controller watching it
        sees a swing, not an implausible reading."""
        with self.lock:
            a = math.radians(degrees)
            if abs(self.phi) > a:
                raise ValueError(f"the load is at {math.degrees(self.phi):.3f}° already")
            speed = math.sqrt(max(0.0, 2 * G / self.l * (math.cos(self.phi) - math.cos(a))))
            self.rate = -speed if self.rate < 0 else speed
            return self.state()

    def state(self):
        """What the test judges: the swing and where the load is (m, °)."""
        with self.lock:
            x, l = self.trolley_x(), self.l
            return {
                "syncs": self.syncs,
                "phi_deg": math.degrees(self.phi),
                "rate_deg_s": math.degrees(self.rate),
                "amplitude_deg": math.degrees(self.amplitude()),
                "still_amplitude_deg": math.degrees(self.amplitude(still=True)),
                "trolley_m_s": self.vx,
                "trolley_m": x,
                "rope_m": l,
                "load_x_m": x + l * math.sin(self.phi),
                "load_z_m": l * math.cos(self.phi),
            }


class SensorLag:
    """What a real CiA 410 inclinometer does to the angle before it reports it (issue 33,
    as sim/src/angle_sensor.rs does it for the study's plant): a first-order low-pass of
    time constant `filter_s` that follows the angle at the pendulum's integration steps,
    a sample taken at every SYNC with Gaussian noise of `noise_deg` (1σ; drawn from its
    own `random.Random(seed)`, so a run is reproducible), and that sample reported
    `delay_cycles` SYNCs later (0–5; before the first ones, the angle it started on). The
    defaults are an ideal sensor: the angle of this SYNC as it is."""

    MAX_DELAY = 5

    def __init__(self, delay_cycles=0, filter_s=0.0, noise_deg=0.0, seed=0, cycle_s=0.01):
        if not 0 <= delay_cycles <= self.MAX_DELAY:
            raise ValueError(f"delay {delay_cycles} cycles: 0 to {self.MAX_DELAY}")
        if filter_s < 0 or noise_deg < 0:
            raise ValueError("the filter's time constant and the noise are not negative")
        self.delay_cycles, self.filter_s, self.noise_deg = delay_cycles, filter_s, noise_deg
        self.cycle_s = cycle_s
        self.random = random.Random(seed)
        self.filtered = None  # rad, the filter's output
        self.line = collections.deque(maxlen=delay_cycles + 1)  # samples, newest last

    def active(self):
        return self.delay_cycles > 0 or self.filter_s > 0 or self.noise_deg > 0

    def reading(self, phi, path=None):
        """The angle (rad) the sensor reports at this SYNC, the true one being `phi`."""
        if not self.active():
            return phi
        if self.filtered is None:  # at rest so long that the filter followed it
            self.filtered = phi
            self.line.extend([phi] * self.delay_cycles)
        steps = path if path else [phi]
        dt = self.cycle_s / len(steps)
        follow = 1.0 - math.exp(-dt / self.filter_s) if self.filter_s > 0 else 1.0
        for angle in steps:  # exact for the angle held over each step
            self.filtered += follow * (angle - self.filtered)
        noise = math.radians(self.random.gauss(0.0, self.noise_deg)) if self.noise_deg > 0 else 0.0
        self.line.append(self.filtered + noise)
        return self.line[0]


class Inclinometer(SimulatedNode):
    """A one-axis CiA 410 inclinometer on the hook block, on `network`; with `lateral`
    (its sign and offset, °) a two-axis one (cia410-inclinometer-2axis.eds: *slope
    lateral16* 0x6020 as well, the 3D crane's swing in the y–z plane; load3d.py).

    python-canopen gives the object dictionary (cia410-inclinometer.eds), the SDO server,
    the NMT slave and the heartbeat producer (0x1017); the glue here is the rest, as for
    the drives: the boot-up message on power-on, TPDO1 configured from 0x1800/0x1A00 when
    started, sampled and sent on SYNC while operational, no SDO in *stopped*. Its faults:
    `frozen` (the reading sticks — TPDO1 repeats its last value, heartbeat and SDO go on,
    as a sensor whose measuring cell hangs) and `lost` (TPDO1 stops; the node still
    answers and beats). `lag` (`SensorLag`, one axis only): its filter, delay and noise;
    without it, an ideal sensor."""

    def __init__(self, network, node_id, sign=1.0, offset_deg=0.0, lateral=None, lag=None):
        self.sign, self.offset_deg = sign, offset_deg
        self.lateral = lateral  # (sign, offset_deg) of slope lateral16, or None: one axis
        self.lag = lag or SensorLag()
        if lateral is not None and self.lag.active():
            raise ValueError("a delayed, filtered or noisy inclinometer has one axis here")
        self.fault = None
        super().__init__(network, node_id, EDS if lateral is None else EDS_TWO_AXES)
        self._reset_application()

    def _reset_application(self):
        self.node.data_store.clear()
        self.slope = 0
        self.lateral_slope = 0
        self.tpdo = None
        self.syncs = 0
        self.sent = 0
        self.started_log = []
        self.pdo_changed = False

    def _read(self, index, subindex, od):
        if index == 0x6010:
            return self.slope
        if index == 0x6020 and self.lateral is not None:
            return self.lateral_slope
        return None

    def _write(self, index, subindex, od, data):
        if index in (0x1800, 0x1A00):
            self.pdo_changed = True

    def resolution_deg(self):
        return struct.unpack("<H", self.node.get_data(0x6000, 0))[0] * 1e-3

    def _after_nmt(self, command, was_operational):
        if command == 0x01:
            self._configure_tpdo()

    def _forget_communication(self):
        self.tpdo = None

    def _configure_tpdo(self):
        self.pdo_changed = False
        self.node.tpdo.read()
        m = self.node.tpdo.map[1]
        self.tpdo = m if m.enabled and 1 <= m.trans_type <= 240 else None
        self.started_log.append([hex(m.cob_id), m.trans_type, [hex(v.index) for v in m]])

    def _slope(self, angle, sign, offset_deg):
        """The reading of `angle` (rad) at the commissioned resolution, as the controller
        converts it back: `slope · resolution = angle / sign + offset`."""
        degrees = math.degrees(angle) / sign + offset_deg
        return max(-32768, min(32767, round(degrees / self.resolution_deg())))

    def sample(self, phi, lateral=None, path=None):
        """SYNC: measure `phi` (rad; the two-axis sensor's x–z slope, `lateral` its y–z
        one) at the commissioned resolution, and send TPDO1. `path`: the angle over the
        period that ended at this SYNC (one value per integration step, the last `phi`),
        which the sensor's filter follows (`SensorLag`); without one, `phi` held."""
        with self.lock:
            if not self.powered:
                return
            phi = self.lag.reading(phi, path)  # what the sensor reports now (its lag)
            self.syncs += 1
            operational = self.node.nmt.state == "OPERATIONAL"
            if operational and self.pdo_changed:
                self._configure_tpdo()
            if self.fault != "frozen":
                self.slope = self._slope(phi, self.sign, self.offset_deg)
                if self.lateral is not None and lateral is not None:
                    self.lateral_slope = self._slope(lateral, *self.lateral)
            if not operational or self.tpdo is None or self.fault == "lost":
                return
            if self.syncs % self.tpdo.trans_type:
                return
            for var in self.tpdo:
                var.set_data(self.node.get_data(var.index, var.subindex)[: len(var.od) // 8])
            self.tpdo.transmit()
            self.sent += 1

    def fail(self, fault):
        """`frozen`, `lost`, or None (healthy again)."""
        with self.lock:
            self.fault = fault

    def dump(self):
        with self.lock:
            od = self.dictionary()
            return {
                "node": self.id,
                "nmt": self.node.nmt.state,
                "fault": self.fault,
                "slope": self.slope,
                "lateral_slope": self.lateral_slope if self.lateral is not None else None,
                "resolution_deg": self.resolution_deg(),
                "syncs": self.syncs,
                "sent": self.sent,
                "od": od,
                "started": self.started_log,
            }
