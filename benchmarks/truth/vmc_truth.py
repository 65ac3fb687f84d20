"""An independent truth machine: a vertical milling centre built differently.

The machine is of the same kind as skthermal's ``vmc-b`` preset (a spindle
carrier on a column, a belt-less motor beside the carrier, a ball-screw Y
axis, 77 thermocouples, a test bar measured in X, Y and Z) and writes run
tables with exactly that preset's column names, but it shares none of the
simulator's code or network:

- the carrier is a finite-difference grid of two strips of ``N_CARRIER``
  cells each (the strip the first sensor row sits on, and the strip that
  carries the motor), coupled cell by cell;
- the column is two finite-difference chains (front and back skin) of
  ``N_COLUMN`` cells, coupled through the web;
- the spindle head has separate front and rear bearings, the shaft, and a
  front and a rear housing;
- the ball screw is a chain of ``N_SCREW`` cells between a fixed and a
  floating bearing;
- the enclosure air is a node of its own that exchanges with the room air.

Heat inputs: each bearing ``a (n / 1000 rpm)^alpha`` with ``alpha`` near
1.3, a motor with idle, linear and quadratic losses, an axis motor in
proportion to |feed|. Displacements come from integrated thermal strain
along the carrier, the column and the screw, the spindle's axial growth, and
tilt terms from the temperature difference across the column (Y) and across
the two carrier strips (X).

The network is linear for a given operating state (speed, feed, hidden
coolant and stroke), so each block of constant state is solved exactly in
the modal coordinates of its symmetrised conductance matrix (zero-order hold
on the inputs at the sample period). Only numpy and scipy are used.
"""

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy.linalg import eigh
from scipy.signal import lfilter
from threadpoolctl import threadpool_limits

ALPHA_UM = 11.5  # thermal expansion of steel and cast iron, µm per m per K

N_CARRIER = 20
N_COLUMN = 12
N_SCREW = 16
CARRIER_LENGTH_M = 0.6
COLUMN_HEIGHT_M = 1.2
COLUMN_DEPTH_M = 0.5
STRIP_SPACING_M = 0.3
SCREW_LENGTH_M = 0.8

CONTACT_KINDS = ("surface", "embedded")


class _Network:
    """Named nodes with heat capacities, links and convection."""

    def __init__(self):
        self.names, self.C, self.hA = [], [], []
        self.links = []
        self.index = {}

    def node(self, name, capacity, hA=0.0):
        self.index[name] = len(self.names)
        self.names.append(name)
        self.C.append(capacity)
        self.hA.append(hA)

    def link(self, a, b, G):
        self.links.append((self.index[a], self.index[b], G))

    def arrays(self):
        i, j, g = (np.array(v) for v in zip(*self.links, strict=True))
        return np.array(self.C), np.array(self.hA), i.astype(int), j.astype(int), g


def _default_params():
    """Physical values of the truth machine (SI units, W, J/K, W/K)."""
    return {
        # capacities
        "C.bearing_front": 600.0,
        "C.bearing_rear": 500.0,
        "C.shaft": 4000.0,
        "C.housing_front": 12000.0,
        "C.housing_rear": 9000.0,
        "C.motor": 9000.0,
        "C.tool": 450.0,
        "C.carrier_cell": 3500.0,
        "C.column_cell": 15000.0,
        "C.base_cell": 250000.0,
        "C.screw_cell": 150.0,
        "C.nut": 800.0,
        "C.table": 90000.0,
        "C.axis_motor": 6000.0,
        "C.air": 120000.0,
        # conductances
        "G.bearing_front-shaft": 3.0,
        "G.bearing_front-housing_front": 6.0,
        "G.bearing_rear-shaft": 2.0,
        "G.bearing_rear-housing_rear": 4.0,
        "G.housing": 5.0,
        "G.housing_front-carrier": 4.0,
        "G.housing_rear-carrier": 3.0,
        "G.shaft-tool": 0.8,
        "G.motor-carrier": 3.0,
        "G.carrier_axial": 16.0,
        "G.carrier_strips": 4.0,
        "G.carrier-column": 8.0,
        "G.column_vertical": 24.0,
        "G.column_web": 6.0,
        "G.column-base": 10.0,
        "G.base": 30.0,
        "G.screw_axial": 0.7,
        "G.screw_fixed": 1.5,
        "G.screw_floating": 0.4,
        "G.screw-axis_motor": 0.5,
        "G.nut-screw": 1.0,
        "G.nut-table": 2.0,
        "G.table-base": 6.0,
        "G.axis_motor-base": 2.0,
        "G.air-room": 40.0,
        # convection to the enclosure air
        "hA.bearing": 0.05,
        "hA.shaft": 0.1,
        "hA.housing_front": 1.0,
        "hA.housing_rear": 0.8,
        "hA.motor": 1.5,
        "hA.tool": 0.15,
        "hA.carrier_cell": 0.25,
        "hA.column_cell": 0.6,
        "hA.base_cell": 3.0,
        "hA.screw_cell": 0.05,
        "hA.nut": 0.15,
        "hA.table": 2.0,
        "hA.axis_motor": 0.8,
        # heat sources
        "q.bearing_front_W_at_1000": 4.5,
        "q.bearing_rear_share": 0.55,
        "q.bearing_alpha": 1.3,
        "q.motor_idle_W": 12.0,
        "q.motor_W_per_krpm": 4.0,
        "q.motor_W_per_krpm2": 0.25,
        "q.axis_motor_W_per_m_min": 4.0,
        # sensors
        "sensor.noise_C": 0.025,
        "sensor.quantization_C": 0.0625,
        "sensor.offset_C": 0.2,
        "sensor.air_pickup": 0.08,
        "disp.noise_um": 0.25,
        "disp.quantization_um": 0.1,
        "disp.offset_um": 5.0,
    }


@dataclass
class Block:
    """One stretch of constant operating state.

    Attributes
    ----------
    duration_s : float
        A multiple of the sample period.
    spindle_rpm, feed_mm_min : float
    coolant : bool
        Flood coolant on (hidden: not a column of the run table).
    stroke : (float, float)
        Centre and half-length of the nut's travel, as fractions of the screw
        (hidden).
    """

    duration_s: float
    spindle_rpm: float
    feed_mm_min: float = 0.0
    coolant: bool = False
    stroke: tuple = (0.5, 0.25)


@dataclass
class BlockNet:
    """The network of one operating state, before assembly.

    Effects edit it: ``hA`` (W/K) and ``room_share`` per node, heat inputs
    ``q`` (W) per node, ``links`` added as ``(i, j, G)``, and ``baths``: a
    conductance per node to an external temperature series named in the
    dictionary (``"coolant"``).
    """

    hA: np.ndarray
    room_share: np.ndarray
    q: np.ndarray
    links: list = field(default_factory=list)
    baths: dict = field(default_factory=dict)


class TruthMachine:
    """A vertical milling centre, independent of :mod:`skthermal.simulate`.

    Parameters
    ----------
    effects : sequence of effect objects (see ``benchmarks.truth.effects``)
    variation : float, default=0.15
        Every capacity, conductance, convection and heat input differs from
        its nominal value by a factor drawn in ``[1 - variation, 1 +
        variation]`` (each seed is another machine of the kind).
    random_state : int or None
    """

    def __init__(self, effects=(), *, variation=0.15, random_state=None):
        rng = np.random.default_rng(random_state)
        self.effects = tuple(effects)
        p = _default_params()
        for key in p:
            if key.split(".")[0] in ("C", "G", "hA", "q") and key != "q.bearing_alpha":
                p[key] *= 1 + rng.uniform(-variation, variation)
        p["q.bearing_alpha"] = rng.uniform(1.2, 1.4)
        self.params = p
        self._build()
        self._cache = {}

    # --- structure -----------------------------------------------------------

    def _build(self):
        p, net = self.params, _Network()
        for name in ("bearing_front", "bearing_rear"):
            net.node(name, p[f"C.{name}"], p["hA.bearing"])
        for name in ("shaft", "housing_front", "housing_rear", "motor", "tool"):
            net.node(name, p[f"C.{name}"], p[f"hA.{name}"])
        self.carrier = {s: [f"carrier_{s}{i}" for i in range(N_CARRIER)] for s in "ab"}
        for s in "ab":
            for n in self.carrier[s]:
                net.node(n, p["C.carrier_cell"], p["hA.carrier_cell"])
        self.column = {s: [f"column_{s}{i}" for i in range(N_COLUMN)] for s in "fk"}
        for s in "fk":
            for n in self.column[s]:
                net.node(n, p["C.column_cell"], p["hA.column_cell"])
        self.base = [f"base{i}" for i in range(3)]
        for n in self.base:
            net.node(n, p["C.base_cell"], p["hA.base_cell"])
        self.screw = [f"screw{i}" for i in range(N_SCREW)]
        for n in self.screw:
            net.node(n, p["C.screw_cell"], p["hA.screw_cell"])
        for name in ("nut", "table", "axis_motor"):
            net.node(name, p[f"C.{name}"], p[f"hA.{name}"])
        net.node("air", p["C.air"], 0.0)

        net.link("bearing_front", "shaft", p["G.bearing_front-shaft"])
        net.link("bearing_front", "housing_front", p["G.bearing_front-housing_front"])
        net.link("bearing_rear", "shaft", p["G.bearing_rear-shaft"])
        net.link("bearing_rear", "housing_rear", p["G.bearing_rear-housing_rear"])
        net.link("housing_front", "housing_rear", p["G.housing"])
        net.link("shaft", "tool", p["G.shaft-tool"])
        for s in "ab":
            c = self.carrier[s]
            net.link("housing_front", c[0], p["G.housing_front-carrier"])
            net.link("housing_rear", c[1], p["G.housing_rear-carrier"])
            for a, b in zip(c[:-1], c[1:], strict=True):
                net.link(a, b, p["G.carrier_axial"])
            net.link(c[-1], self.column["f"][-1], p["G.carrier-column"])
        for a, b in zip(self.carrier["a"], self.carrier["b"], strict=True):
            net.link(a, b, p["G.carrier_strips"])
        m = int(round(0.3 * (N_CARRIER - 1)))
        for k in (m - 1, m, m + 1):
            net.link("motor", self.carrier["b"][k], p["G.motor-carrier"] / 3)
        for s in "fk":
            c = self.column[s]
            for a, b in zip(c[:-1], c[1:], strict=True):
                net.link(a, b, p["G.column_vertical"])
            net.link(c[0], self.base[0], p["G.column-base"])
        for a, b in zip(self.column["f"], self.column["k"], strict=True):
            net.link(a, b, p["G.column_web"])
        for a, b in zip(self.base[:-1], self.base[1:], strict=True):
            net.link(a, b, p["G.base"])
        for a, b in zip(self.screw[:-1], self.screw[1:], strict=True):
            net.link(a, b, p["G.screw_axial"])
        net.link(self.screw[0], self.base[1], p["G.screw_fixed"])
        net.link(self.screw[-1], self.base[2], p["G.screw_floating"])
        net.link(self.screw[0], "axis_motor", p["G.screw-axis_motor"])
        nut_cells = self.screw[3:13]
        for n in nut_cells:
            net.link("nut", n, p["G.nut-screw"] / len(nut_cells))
        net.link("nut", "table", p["G.nut-table"])
        net.link("table", self.base[1], p["G.table-base"])
        net.link("axis_motor", self.base[2], p["G.axis_motor-base"])

        self.net = net
        self.names = net.names
        self.index = net.index
        self.C, self.hA0, self.li, self.lj, self.lg = net.arrays()
        self.n = len(self.names)
        self.exposed = [
            self.index[k]
            for k in (
                "housing_front",
                "housing_rear",
                "motor",
                "tool",
                *self.carrier["a"],
                *self.carrier["b"],
                *self.column["f"],
                *self.column["k"],
                *self.base,
                "table",
            )
        ]
        self._build_sensors()
        self._build_displacements()

    def chain_weights(self, chain, u):
        """Node weights of the point at fraction ``u`` along a chain of cells."""
        x = u * (len(chain) - 1)
        i = min(int(np.floor(x)), len(chain) - 2)
        f = x - i
        return {chain[i]: 1 - f, chain[i + 1]: f}

    def _build_sensors(self):
        idx, pick = self.index, self.params["sensor.air_pickup"]
        specs = []

        def add(number, weights, kind):
            specs.append((f"T{number:02d}_C", weights, kind))

        def surface(weights):
            # A thermocouple on a surface also reads a little of the air.
            w = {k: v * (1 - pick) for k, v in weights.items()}
            w["air"] = w.get("air", 0.0) + pick
            return w

        for i, n in enumerate(range(1, 8)):
            add(n, surface(self.chain_weights(self.column["f"], i / 6)), "surface")
        for i, n in enumerate(range(8, 34)):
            add(n, surface(self.chain_weights(self.carrier["a"], i / 25)), "surface")
        for i, n in enumerate(range(34, 63)):
            add(n, surface(self.chain_weights(self.carrier["b"], i / 28)), "surface")
        add(63, surface({"housing_front": 1.0}), "surface")
        add(64, surface({"housing_rear": 1.0}), "surface")
        add(65, surface({"housing_front": 0.6, "housing_rear": 0.4}), "surface")
        add(66, {"air": 0.85, self.base[0]: 0.15}, "air")
        add(67, {"air": 0.8, self.screw[5]: 0.2}, "air")
        add(68, surface({self.base[1]: 0.75, self.screw[0]: 0.25}), "surface")
        add(69, surface({self.base[2]: 0.6, self.screw[10]: 0.4}), "surface")
        add(70, {"room": 0.6, "air": 0.35, self.column["f"][-1]: 0.05}, "air")
        for n, h in ((71, 0.3), (72, 0.7)):
            w = {
                k: 0.5 * v
                for s in "fk"
                for k, v in self.chain_weights(self.column[s], h).items()
            }
            add(n, w, "embedded")
        w = {"air": 0.7}
        w.update(
            {k: 0.3 * v for k, v in self.chain_weights(self.carrier["a"], 0.4).items()}
        )
        add(73, w, "air")
        add(74, surface({"table": 0.85, "nut": 0.15}), "surface")
        add(75, {"air": 0.65, "housing_front": 0.35}, "air")
        add(76, {"room": 0.55, "air": 0.45}, "air")
        add(77, {"air": 0.7, "tool": 0.3}, "air")

        self.sensor_names = [s[0] for s in specs]
        self.sensor_kinds = np.array([s[2] for s in specs])
        W = np.zeros((len(specs), self.n))
        w_room = np.zeros(len(specs))
        for r, (_, weights, _) in enumerate(specs):
            for k, v in weights.items():
                if k == "room":
                    w_room[r] += v
                else:
                    W[r, idx[k]] += v
        self.W_sensors, self.w_room = W, w_room

    def _build_displacements(self):
        """µm per K of each node's rise, for X, Y and Z at the test bar."""
        idx, D = self.index, np.zeros((3, self.n))
        X, Y, Z = 0, 1, 2
        dx = CARRIER_LENGTH_M / N_CARRIER
        u = (np.arange(N_CARRIER) + 0.5) * dx
        for s in "ab":
            for i, name in enumerate(self.carrier[s]):
                # Axial growth of the carrier (integrated strain) moves the
                # spindle in Y; the strips' difference bends it in X.
                D[Y, idx[name]] += 0.5 * ALPHA_UM * dx
                sign = 1.0 if s == "b" else -1.0
                D[X, idx[name]] += (
                    sign * ALPHA_UM / STRIP_SPACING_M * (CARRIER_LENGTH_M - u[i]) * dx
                )
        dh = COLUMN_HEIGHT_M / N_COLUMN
        h = (np.arange(N_COLUMN) + 0.5) * dh
        for s, sign in (("f", 1.0), ("k", -1.0)):
            for j, name in enumerate(self.column[s]):
                # Curvature from the front-back difference tilts the column.
                D[Y, idx[name]] += (
                    sign * ALPHA_UM / COLUMN_DEPTH_M * (COLUMN_HEIGHT_M - h[j]) * dh
                )
                D[Z, idx[name]] += 0.5 * ALPHA_UM * dh
        ds = SCREW_LENGTH_M / N_SCREW
        for name in self.screw[: N_SCREW // 2]:
            D[Y, idx[name]] += ALPHA_UM * ds
        D[Y, idx[self.base[1]]] -= ALPHA_UM * ds * (N_SCREW // 2)
        D[Z, idx["shaft"]] += ALPHA_UM * 0.1
        D[Z, idx["housing_front"]] += ALPHA_UM * 0.15
        D[Z, idx["tool"]] += ALPHA_UM * 0.15
        self.D = D
        self.disp_names = ["disp_x_um", "disp_y_um", "disp_z_um"]

    # --- one operating state ---------------------------------------------------

    def base_block_net(self, block):
        """The network of ``block`` without any effect."""
        p, idx = self.params, self.index
        q = np.zeros(self.n)
        krpm = block.spindle_rpm / 1000.0
        if block.spindle_rpm > 0:
            qf = p["q.bearing_front_W_at_1000"] * krpm ** p["q.bearing_alpha"]
            q[idx["bearing_front"]] = qf
            q[idx["bearing_rear"]] = p["q.bearing_rear_share"] * qf
            q[idx["motor"]] = (
                p["q.motor_idle_W"]
                + p["q.motor_W_per_krpm"] * krpm
                + p["q.motor_W_per_krpm2"] * krpm**2
            )
        q[idx["axis_motor"]] = (
            p["q.axis_motor_W_per_m_min"] * abs(block.feed_mm_min) / 1000.0
        )
        return BlockNet(hA=self.hA0.copy(), room_share=np.zeros(self.n), q=q)

    def block_net(self, block):
        net = self.base_block_net(block)
        for effect in self.effects:
            effect.network(self, block, net)
        return net

    def _assemble(self, net):
        """Conductance matrix K, and input vectors per driver."""
        n, air = self.n, self.index["air"]
        K = np.zeros((n, n))
        li = np.concatenate([self.li] + [[a for a, _, _ in net.links]]).astype(int)
        lj = np.concatenate([self.lj] + [[b for _, b, _ in net.links]]).astype(int)
        lg = np.concatenate([self.lg] + [[g for _, _, g in net.links]])
        # Convection: the share to the enclosure air is a link to the air node.
        to_air = net.hA * (1 - net.room_share)
        to_air[air] = 0.0
        nodes = np.flatnonzero(to_air > 0)
        li = np.concatenate([li, nodes])
        lj = np.concatenate([lj, np.full(nodes.size, air)])
        lg = np.concatenate([lg, to_air[nodes]])
        np.add.at(K, (li, lj), -lg)
        np.add.at(K, (lj, li), -lg)
        np.add.at(K, (li, li), lg)
        np.add.at(K, (lj, lj), lg)
        b = {"room": net.hA * net.room_share}
        b["room"][air] += self.params["G.air-room"]
        for name, g in net.baths.items():
            b[name] = np.asarray(g, dtype=float)
        for g in b.values():
            K[np.diag_indices(n)] += g
        return K, b, net.q

    def _modes(self, block):
        key = (
            block.spindle_rpm,
            block.feed_mm_min,
            block.coolant,
            tuple(block.stroke),
        )
        if key not in self._cache:
            K, b, q = self._assemble(self.block_net(block))
            s = 1.0 / np.sqrt(self.C)
            # A 94-node problem: BLAS threads only add contention.
            with threadpool_limits(1):
                lam, V = eigh(s[:, None] * K * s[None, :])
            self._cache[key] = (lam, V, b, q, s)
        return self._cache[key]

    # --- response --------------------------------------------------------------

    def node_temperatures(self, blocks, t, drivers, T0=None):
        """Node temperatures (°C) at the sample times ``t``.

        Parameters
        ----------
        blocks : sequence of Block
        t : array (n_samples,)
            Regular sample times starting at 0; block boundaries fall on them.
        drivers : dict of array (n_samples,)
            ``"room"`` (°C) and any bath named by an effect (``"coolant"``).
        T0 : array (n_nodes,), optional
            Initial state; default: every node at the room air.
        """
        dt = t[1] - t[0]
        T = np.empty((t.size, self.n))
        T[0] = drivers["room"][0] if T0 is None else T0
        mid = {k: 0.5 * (v[1:] + v[:-1]) for k, v in drivers.items()}
        start = 0
        for block in blocks:
            m = int(round(block.duration_s / dt))
            stop = min(start + m, t.size - 1)
            if stop <= start:
                continue
            lam, V, b, q, s = self._modes(block)
            f = np.tile(q, (stop - start, 1))
            for name, vec in b.items():
                f += mid[name][start:stop, None] * vec[None, :]
            g = (f * s) @ V
            a = np.exp(-lam * dt)
            beta = np.where(
                lam > 1e-12, -np.expm1(-lam * dt) / np.maximum(lam, 1e-300), dt
            )
            z0 = V.T @ (T[start] / s)
            w = g * beta
            Z = np.empty_like(w)
            for k in range(self.n):
                Z[:, k] = lfilter([1.0], [1.0, -a[k]], w[:, k], zi=[a[k] * z0[k]])[0]
            T[start + 1 : stop + 1] = (Z @ V.T) * s
            start = stop
        return T

    def steady_state(self, block, room):
        """Node temperatures at equilibrium for a constant operating state."""
        K, b, q = self._assemble(self.block_net(block))
        # Every bath (room, coolant) held at the same temperature ``room``.
        return np.linalg.solve(K, q + room * sum(b.values()))

    def run_table(
        self,
        blocks,
        room,
        *,
        sample_period_s=60.0,
        run="run1",
        noise=True,
        random_state=None,
    ):
        """Simulate one run and return its run table (vmc-b's columns).

        Parameters
        ----------
        blocks : sequence of Block
        room : callable or float
            Room air (°C) as a function of time (s), or a constant.
        sample_period_s : float, default=60.0
        run : label
        noise : bool, default=True
            Sensor noise, quantisation and offsets.
        random_state : int, Generator or None
        """
        rng = np.random.default_rng(random_state)
        total = sum(b.duration_s for b in blocks)
        t = np.arange(0.0, total + 0.5 * sample_period_s, sample_period_s)
        room_t = np.full(t.size, float(room)) if np.isscalar(room) else room(t)
        drivers = {"room": room_t}
        for effect in self.effects:
            drivers.update(effect.drivers(self, blocks, t, room_t))
        T = self.node_temperatures(blocks, t, drivers)
        sensors = T @ self.W_sensors.T + room_t[:, None] * self.w_room[None, :]
        for effect in self.effects:
            sensors = effect.sensors(self, t, sensors, rng)
        disp = (T - T[0]) @ self.D.T
        edges = np.cumsum([0.0] + [b.duration_s for b in blocks])
        k = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(blocks) - 1)
        rpm = np.array([b.spindle_rpm for b in blocks], dtype=float)[k]
        feed = np.array([b.feed_mm_min for b in blocks], dtype=float)[k]
        ambient = room_t.copy()
        if noise:
            p = self.params
            sensors = sensors + p["sensor.offset_C"] * rng.standard_normal(
                sensors.shape[1]
            )
            sensors = sensors + p["sensor.noise_C"] * rng.standard_normal(sensors.shape)
            qz = p["sensor.quantization_C"]
            sensors = np.round(sensors / qz) * qz
            ambient = (
                np.round(
                    (ambient + p["sensor.noise_C"] * rng.standard_normal(t.size)) / qz
                )
                * qz
            )
            disp = disp + p["disp.offset_um"] * rng.standard_normal(3)
            disp = disp + p["disp.noise_um"] * rng.standard_normal(disp.shape)
            qd = p["disp.quantization_um"]
            disp = np.round(disp / qd) * qd
        cols = {
            "run": run,
            "time_s": t,
            "spindle_rpm": rpm,
            "feed_mm_min": feed,
            "ambient_C": ambient,
        }
        cols.update(dict(zip(self.sensor_names, sensors.T, strict=True)))
        cols.update(dict(zip(self.disp_names, disp.T, strict=True)))
        return pd.DataFrame(cols)
