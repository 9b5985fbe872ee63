"""The 3D crane's load for the drives' process (drives.py): a spherical pendulum hanging
from the trolley, moved by the three simulated drives — bridge (x along the runway),
trolley (y along the bridge), hoist (the rope) — and measured by the two-axis CiA 410
inclinometer on the hook block (load.py's `Inclinometer` with its lateral axis).

The load is a point on a massless straight rope of the hoist's length `l`, hanging from
the rope's exit at the trolley, `s = (x, y, 0)` with z down. Its place relative to it,
`p = r_C − s` with `|p| = l`, is integrated in Cartesian coordinates (no angle is
singular at the hanging rest, where the load spends its time):

    p̈ = g ẑ − s̈ − λ p,    λ = (g p_z + |ṗ|² − l̇² − p·s̈) / l²

(`λ l` the rope's pull per kg of load) from the constraint `|p|² = l²` differentiated
twice with `l̈ = 0`. As in load.py (the planar crane), the drives in CSV hold their
velocity from one SYNC to the next, so between SYNCs `s̈ = 0` and `l̇` is constant (RK4,
1 ms steps), and at a SYNC the drives' velocity steps are impulses: the load keeps its
velocity across the rope, the rope takes up the difference along it (`ṗ` loses the step
of `ṡ`, then its component along the rope is the new `l̇`). After each period the load
is put back on the rope's length (the integration keeps it there to rounding: 4e-15 m
seen). No lag, friction, noise or wind: a swing left alone keeps its energy. With the
trolley still and the load in the x–z plane it is load.py's planar pendulum: under the
same bridge and rope motion `α` was its `φ` to 1e-15 rad.

The slopes are the controller's (`solver_core::reference::flat_crane3d`, sim/src/plant3d.rs):

    tan α = (x_C − x) / z_C,    tan β = (y_C − y) / z_C,

`α` in the x–z plane (slope long16), `β` in the y–z plane (slope lateral16), each
reported as `slope · resolution = angle / sign + offset` with its axis' sign and offset
from the commissioning file (load.py's `Inclinometer.sample`).
"""

import math
import threading

from load import G, SUBSTEPS


def _add(a, b, k=1.0):
    return [u + k * v for u, v in zip(a, b)]


def _dot(a, b):
    return sum(u * v for u, v in zip(a, b))


class SpatialLoad:
    """The spherical pendulum under the 3D crane's trolley; `bridge`, `trolley` and
    `winch` are drives.py's `Drive`s, `axes` maps each one's node to (scale m per
    increment, offset m) from the commissioning file."""

    def __init__(self, bridge, trolley, winch, axes, cycle_s):
        self.bridge, self.trolley, self.winch = bridge, trolley, winch
        self.axes = axes
        self.cycle_s = cycle_s
        self.lock = threading.RLock()
        self.syncs = 0
        with self.lock:
            self.vx, self.vy, self.vl = self._velocities()
            self.l = max(self.rope(), 0.1)
            self.p = [0.0, 0.0, self.l]  # the load from the rope's exit, m (z down)
            self.v = [0.0, 0.0, self.vl]  # its velocity relative to the trolley, m/s

    def _metres(self, drive, value):
        scale, offset = self.axes[drive.id]
        return offset + scale * value

    def bridge_x(self):
        return self._metres(self.bridge, self.bridge.position)

    def trolley_y(self):
        return self._metres(self.trolley, self.trolley.position)

    def rope(self):
        return self._metres(self.winch, self.winch.position)

    def _velocities(self):
        return tuple(self.axes[d.id][0] * d.velocity for d in (self.bridge, self.trolley, self.winch))

    def _derivative(self, p, v):
        """(ṗ, p̈) between SYNCs: the support at constant speed, the rope at constant rate."""
        pull = (G * p[2] + _dot(v, v) - self.vl**2) / _dot(p, p)
        return v, [-pull * p[0], -pull * p[1], G - pull * p[2]]

    def on_sync(self):
        """After the drives took this SYNC: the swing over the period that ended (the
        bridge, the trolley and the rope at the speeds they held), then the velocity steps.
        Returns the slopes (α, β), rad."""
        with self.lock:
            self.syncs += 1
            h = self.cycle_s / SUBSTEPS
            p, v = self.p, self.v
            for _ in range(SUBSTEPS):
                k1 = self._derivative(p, v)
                k2 = self._derivative(_add(p, k1[0], h / 2), _add(v, k1[1], h / 2))
                k3 = self._derivative(_add(p, k2[0], h / 2), _add(v, k2[1], h / 2))
                k4 = self._derivative(_add(p, k3[0], h), _add(v, k3[1], h))
                p = [p[i] + h / 6 * (k1[0][i] + 2 * k2[0][i] + 2 * k3[0][i] + k4[0][i]) for i in range(3)]
                v = [v[i] + h / 6 * (k1[1][i] + 2 * k2[1][i] + 2 * k3[1][i] + k4[1][i]) for i in range(3)]
            # Back on the rope's length (the drives' positions), then the velocity steps:
            # the support's taken from the load's relative velocity, the rope's along it.
            self.l = max(self.rope(), 0.1)
            p = [c * self.l / math.sqrt(_dot(p, p)) for c in p]
            vx, vy, vl = self._velocities()
            v = _add(v, [vx - self.vx, vy - self.vy, 0.0], -1.0)
            e = [c / self.l for c in p]
            v = _add(v, e, vl - _dot(v, e))
            self.p, self.v, self.vx, self.vy, self.vl = p, v, vx, vy, vl
            return self.slopes()

    def slopes(self):
        """(α, β), rad: the rope's slopes in the x–z and the y–z plane."""
        p = self.p
        return math.atan2(p[0], p[2]), math.atan2(p[1], p[2])

    def _swing_velocity(self, still):
        """The load's velocity across the rope, m/s: relative to the trolley, or with
        `still` its own (absolute) — what it keeps if the bridge and the trolley stop now."""
        v = _add(self.v, [self.vx, self.vy, 0.0]) if still else list(self.v)
        e = [c / self.l for c in self.p]
        return _add(v, e, -_dot(v, e))

    def amplitude(self, still=False):
        """The swing's amplitude, rad: the angle from the vertical at which its energy
        would turn it (the rope held at its length); `still` as in `_swing_velocity`."""
        w = self._swing_velocity(still)
        c = self.p[2] / self.l - _dot(w, w) / (2 * G * self.l)
        return math.acos(max(-1.0, min(1.0, c)))

    def plane_amplitudes(self, still=False):
        """Each plane's swing amplitude, rad, x–z then y–z: `√(α² + α̇² l/g)` of its slope
        and slope rate (the planes' linearised pendulums, exact to second order in the
        angles); `still` as in `_swing_velocity`."""
        w = self._swing_velocity(still)
        p = self.p
        out = []
        for i in (0, 1):
            angle = math.atan2(p[i], p[2])
            rate = (p[2] * w[i] - p[i] * w[2]) / (p[i] ** 2 + p[2] ** 2)
            out.append(math.sqrt(angle**2 + rate**2 * self.l / G))
        return out

    def swing(self, alpha_deg, beta_deg=0.0):
        """The rope at the slopes `alpha_deg`, `beta_deg` now, the load at a turning point
        (at rest relative to the trolley but for the rope's rate): a swing in the vertical
        plane through that direction, as a load already swinging when the controller
        first looks at it."""
        with self.lock:
            u, v = math.tan(math.radians(alpha_deg)), math.tan(math.radians(beta_deg))
            d = math.sqrt(1 + u * u + v * v)
            e = [u / d, v / d, 1 / d]
            self.p = [c * self.l for c in e]
            self.v = [c * self.vl for c in e]
            return self.state()

    def state(self):
        """What the test judges: the swing and where the load is (m, °)."""
        with self.lock:
            x, y, l = self.bridge_x(), self.trolley_y(), self.l
            alpha, beta = self.slopes()
            planes = self.plane_amplitudes()
            still = self.plane_amplitudes(still=True)
            return {
                "syncs": self.syncs,
                "alpha_deg": math.degrees(alpha),
                "beta_deg": math.degrees(beta),
                "amplitude_deg": math.degrees(self.amplitude()),
                "still_amplitude_deg": math.degrees(self.amplitude(still=True)),
                "xz_amplitude_deg": math.degrees(planes[0]),
                "yz_amplitude_deg": math.degrees(planes[1]),
                "xz_still_amplitude_deg": math.degrees(still[0]),
                "yz_still_amplitude_deg": math.degrees(still[1]),
                "bridge_m_s": self.vx,
                "trolley_m_s": self.vy,
                "bridge_m": x,
                "trolley_m": y,
                "rope_m": l,
                "load_x_m": x + self.p[0],
                "load_y_m": y + self.p[1],
                "load_z_m": self.p[2],
            }
