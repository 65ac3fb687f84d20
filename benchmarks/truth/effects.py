"""Effects of the truth machine, implemented apart from skthermal's simulator.

One class per name of the gap diagnosis's vocabulary, plus effects outside
it. Each draws its own strength from ``rng`` in ranges chosen for this truth
(not the simulator's defaults) and acts through the truth machine's hooks:

- ``network(truth, block, net)``: change convection, heat inputs, links or
  baths of one operating state;
- ``drivers(truth, blocks, t, room)``: extra temperature series (baths);
- ``sensors(truth, t, readings, rng)``: change the sensor readings.
"""

import numpy as np
from scipy.signal import lfilter


class TruthEffect:
    """An effect of the truth machine (no change by default)."""

    name = "none"
    in_vocabulary = True

    def __init__(self, rng=None):
        self.rng = np.random.default_rng(rng)
        self.values = {}

    def network(self, truth, block, net):
        pass

    def drivers(self, truth, blocks, t, room):
        return {}

    def sensors(self, truth, t, readings, rng):
        return readings

    def __repr__(self):
        vals = ", ".join(f"{k}={v:.3g}" for k, v in self.values.items())
        return f"{type(self).__name__}({vals})"


class SensorLag(TruthEffect):
    """Contact sensors lag through a contact resistance and two masses.

    Each contact (surface or embedded) sensor gets its own time constant,
    log-normal around a median drawn in 500-1100 s; the reading passes two
    first-order stages (the thermocouple bead, 70%, and its cement, 30%).
    """

    name = "sensor_lag"

    def __init__(self, rng=None):
        super().__init__(rng)
        self.values = {"median_tau_s": self.rng.uniform(500, 1100)}

    def sensors(self, truth, t, readings, rng):
        contact = np.isin(truth.sensor_kinds, ("surface", "embedded"))
        tau = self.values["median_tau_s"] * np.exp(
            0.3 * self.rng.standard_normal(readings.shape[1])
        )
        dt = t[1] - t[0]
        out = readings.copy()
        for j in np.flatnonzero(contact):
            x = readings[:, j]
            for share in (0.7, 0.3):
                a = np.exp(-dt / (share * tau[j]))
                x = lfilter([1 - a], [1.0, -a], x, zi=[a * x[0]])[0]
            out[:, j] = x
        return out


class SpeedConvection(TruthEffect):
    """The turning spindle stirs the air around the head and carrier front.

    Convection of the housings, the motor and the carrier grows as ``1 + g
    w (n / 1000 rpm)^e``, with ``w`` falling off along the carrier as
    ``exp(-u / 0.3)``; ``g`` in 0.12-0.4 and ``e`` in 0.5-1.0.
    """

    name = "speed_convection"

    def __init__(self, rng=None):
        super().__init__(rng)
        self.values = {
            "gain": self.rng.uniform(0.12, 0.4),
            "exponent": self.rng.uniform(0.5, 1.0),
        }

    def network(self, truth, block, net):
        if block.spindle_rpm <= 0:
            return
        boost = (
            self.values["gain"] * (block.spindle_rpm / 1000) ** self.values["exponent"]
        )
        idx = truth.index
        for name in ("housing_front", "housing_rear", "motor", "bearing_front"):
            net.hA[idx[name]] *= 1 + boost
        n = len(truth.carrier["a"])
        u = np.arange(n) / (n - 1)
        for s in "ab":
            cells = [idx[c] for c in truth.carrier[s]]
            net.hA[cells] *= 1 + boost * np.exp(-u / 0.3)


class ToolGrowth(TruthEffect):
    """The turning test bar is cooled by the air it churns.

    While turning, the bar's convection rises by ``h (n / 1000 rpm)^e`` W/K
    (``h`` in 0.6-1.6, ``e`` in 0.5-0.8); at a stop it falls back to still
    air, and heat from the shaft keeps growing the bar.
    """

    name = "tool_growth"

    def __init__(self, rng=None):
        super().__init__(rng)
        self.values = {
            "hA_at_1000": self.rng.uniform(0.6, 1.6),
            "exponent": self.rng.uniform(0.5, 0.8),
        }

    def network(self, truth, block, net):
        if block.spindle_rpm > 0:
            net.hA[truth.index["tool"]] += (
                self.values["hA_at_1000"]
                * (block.spindle_rpm / 1000) ** self.values["exponent"]
            )


class AmbientTransient(TruthEffect):
    """Exposed surfaces see the room air directly, not only the enclosure.

    A share ``s`` (0.35-0.75) of the convection of every exposed node goes
    straight to the room air, so door events reach the structure at once.
    """

    name = "ambient_transient"

    def __init__(self, rng=None):
        super().__init__(rng)
        self.values = {"room_share": self.rng.uniform(0.35, 0.75)}

    def network(self, truth, block, net):
        net.room_share[truth.exposed] = self.values["room_share"]


class FeedHeating(TruthEffect):
    """Ball screw and nut friction in proportion to |feed|.

    ``w`` W per m/min (1.5-5) is shared between the screw cells under the
    block's stroke, the nut (15-35%) and the axis motor (10-30%).
    """

    name = "feed_heating"

    def __init__(self, rng=None):
        super().__init__(rng)
        self.values = {
            "W_per_m_min": self.rng.uniform(1.5, 5.0),
            "nut_share": self.rng.uniform(0.15, 0.35),
            "motor_share": self.rng.uniform(0.1, 0.3),
        }

    def network(self, truth, block, net):
        if block.feed_mm_min == 0:
            return
        v = self.values
        total = v["W_per_m_min"] * abs(block.feed_mm_min) / 1000
        n = len(truth.screw)
        x = (np.arange(n) + 0.5) / n
        centre, half = block.stroke
        # Averaged over many strokes, the moving nut heats its travel with a
        # taper towards the ends, smoothed over the nut's own length.
        w = np.clip(1 - np.abs(x - centre) / max(half, 1.5 / n), 0, None) ** 0.5
        w /= w.sum()
        cells = [truth.index[c] for c in truth.screw]
        net.q[cells] += total * (1 - v["nut_share"] - v["motor_share"]) * w
        net.q[truth.index["nut"]] += total * v["nut_share"]
        net.q[truth.index["axis_motor"]] += total * v["motor_share"]


class SensorDrift(TruthEffect):
    """A share of the thermocouples drift: a linear trend plus a slow wander.

    40-90% of the sensors drift, at rates normal with a spread drawn in
    0.015-0.04 °C/h, plus an Ornstein-Uhlenbeck wander of 0.01-0.03 °C with
    a 2 h correlation time.
    """

    name = "sensor_drift"

    def __init__(self, rng=None):
        super().__init__(rng)
        self.values = {
            "share": self.rng.uniform(0.4, 0.9),
            "rate_C_per_h": self.rng.uniform(0.015, 0.04),
            "wander_C": self.rng.uniform(0.01, 0.03),
        }
        self._rates = None

    def sensors(self, truth, t, readings, rng):
        n = readings.shape[1]
        if self._rates is None:
            on = self.rng.random(n) < self.values["share"]
            self._rates = on * self.values["rate_C_per_h"] * self.rng.standard_normal(n)
            self._on = on
        dt = t[1] - t[0]
        a = np.exp(-dt / 7200.0)
        e = (
            rng.standard_normal(readings.shape)
            * self.values["wander_C"]
            * np.sqrt(1 - a**2)
        )
        wander = lfilter([1.0], [1.0, -a], e, axis=0)
        wander -= wander[0]
        return readings + (t[:, None] / 3600.0) * self._rates + wander * self._on


class Coolant(TruthEffect):
    """Out of vocabulary: flood coolant from a tank that warms while it runs.

    During blocks with coolant on (hidden: not in the run table), the table,
    the test bar and the front housing exchange heat with coolant at the
    tank's temperature. The tank warms towards the room + 2.5-5 K with a 1.5 h
    time constant while the pump runs and cools back with 3 h.
    """

    name = "coolant"
    in_vocabulary = False

    def __init__(self, rng=None):
        super().__init__(rng)
        self.values = {
            "strength": self.rng.uniform(0.6, 1.4),
            "tank_rise_K": self.rng.uniform(2.5, 5.0),
        }

    def network(self, truth, block, net):
        if not block.coolant:
            return
        g = np.zeros(truth.n)
        s = self.values["strength"]
        g[truth.index["table"]] = 12.0 * s
        g[truth.index["tool"]] = 2.5 * s
        g[truth.index["housing_front"]] = 2.0 * s
        net.baths["coolant"] = g

    def drivers(self, truth, blocks, t, room):
        rise = np.zeros(t.size)
        level, start = 0.0, 0.0
        for block in blocks:
            sel = (t >= start) & (t <= start + block.duration_s)
            target, tau = (
                (self.values["tank_rise_K"], 5400.0)
                if block.coolant
                else (0.0, 10800.0)
            )
            rise[sel] = target + (level - target) * np.exp(-(t[sel] - start) / tau)
            level = target + (level - target) * np.exp(-block.duration_s / tau)
            start += block.duration_s
        return {"coolant": room + rise}


EFFECTS = {
    cls.name: cls
    for cls in (
        SensorLag,
        SpeedConvection,
        ToolGrowth,
        AmbientTransient,
        FeedHeating,
        SensorDrift,
        Coolant,
    )
}
