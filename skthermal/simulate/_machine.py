"""The thermal machine: a lumped-parameter network, heat sources, sensors and a
thermo-elastic map from temperatures to displacements.

``C_i dT_i/dt = sum_j G_ij (T_j - T_i) + hA_i (T_air,i - T_i) + Q_i(t)``

Every number lives in one flat dictionary of named parameters (``"C.boss"``,
``"G.boss-carrier1"``, ``"k.y.carrier3"``, ``"speed_convection.gain"`` ...), so
any of them can be changed with :meth:`ThermalMachine.with_params` or fitted to
measurements with :meth:`ThermalMachine.calibrate`.
"""

import zlib
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from sklearn.utils import check_random_state

from skthermal.simulate._drivers import AmbientProfile, DutyCycle, _check_number
from skthermal.simulate._effects import EFFECTS, check_effects
from skthermal.simulate._solver import ModalSystem, first_order_lag
from skthermal.utils._threads import single_threaded_blas

ROOM = "room"
SENSOR_KINDS = ("surface", "embedded", "air")


@dataclass(frozen=True)
class SensorSpec:
    """A temperature sensor: which temperatures it reads, and how.

    Attributes
    ----------
    name : str
        Run-table column, ``T<name>_C``.
    weights : dict
        Node name (or ``"room"``, the workshop air) -> weight; the sensor reads
        the weighted mean, e.g. a point between two carrier segments.
    kind : {"surface", "embedded", "air"}
        Surface sensors lag when the ``sensor_lag`` effect is on.
    location : str
        Where it sits, in words.
    """

    name: str
    weights: dict
    kind: str = "surface"
    location: str = ""


@dataclass(frozen=True)
class MachineSpec:
    """The structure of a machine: nodes, couplings, roles and sensors."""

    name: str
    description: str
    nodes: tuple
    edges: tuple
    sensors: tuple
    head_nodes: tuple = ()
    exposed_nodes: tuple = ()
    enclosure: str = "enclosure"
    tool: str = "tool"
    bearing: str = "bearings"
    motor: str = "motor"
    belt: str = "carrier2"
    cutting: str = "tool"
    screw_nodes: tuple = ()
    nut: str | None = None
    axis_motor: str | None = None
    feed_axis: str = "y"
    axes: tuple = ("x", "y", "z")
    groups: dict = field(default_factory=dict)


@dataclass
class CalibrationResult:
    """What :meth:`ThermalMachine.calibrate` found.

    Attributes
    ----------
    params : Series
        Calibrated values of the fitted parameters.
    initial : Series
        Their values before calibration.
    std_error : Series
        Approximate standard errors from the Jacobian at the solution.
    rmse_before, rmse_after : Series
        RMSE per fitted channel before and after.
    cost : float
        Final half sum of squared residuals.
    nfev : int
        Simulations run.
    success : bool
    message : str
    """

    params: pd.Series
    initial: pd.Series
    std_error: pd.Series
    rmse_before: pd.Series
    rmse_after: pd.Series
    cost: float
    nfev: int
    success: bool
    message: str


def _weights_matrix(spec, names_index, items):
    W = np.zeros((len(items), len(names_index)))
    for i, weights in enumerate(items):
        for node, w in weights.items():
            W[i, names_index[node]] += w
    return W


class ThermalMachine:
    """A simulated machine tool: thermal network, heat sources, sensors, errors.

    Build one from a preset with :meth:`from_preset` (``"vmc-b"``,
    ``"vmc-a"``) and simulate a test with :meth:`simulate`. The output is a
    run table (see DATA_FORMAT) whose metadata records the machine and the
    effects that were on.

    Parameters
    ----------
    spec : MachineSpec
        The structure.
    params : dict
        Every physical number, by name (see :meth:`parameter_table`).
    effects : sequence of str
        Effects switched on, from :func:`skthermal.simulate.describe_effects`.

    Notes
    -----
    Node temperatures are advanced with the exact matrix exponential of the
    network at each operating point (spindle speed), cached per speed; heat is
    held constant over a sample and the air varies linearly between samples,
    both integrated exactly (see :mod:`skthermal.simulate._solver`).

    Examples
    --------
    >>> from skthermal.simulate import ThermalMachine, DutyCycle
    >>> machine = ThermalMachine.from_preset("vmc-b")
    >>> run = machine.simulate(DutyCycle.heat_cool(4000, heat_h=1, cool_h=1),
    ...                        run="I", random_state=0)
    >>> run.shape  # run, time, 3 drivers, 77 temperatures, X/Y/Z displacement
    (241, 85)
    >>> machine.effect_status()["sensor_drift"], len(machine.effects)
    (False, 5)
    """

    def __init__(self, spec, params, effects=()):
        self.spec = spec
        self._effects = check_effects(effects)
        full = {
            f"{e.name}.{k}": v for e in EFFECTS.values() for k, v in e.params.items()
        }
        full.update(params)
        self._params = self._validate_params(full)
        self._index = {n: i for i, n in enumerate(spec.nodes)}
        self._cache = {}

    # --- construction -------------------------------------------------------

    @classmethod
    def from_preset(cls, name, *, effects=None, params=None):
        """A preset machine.

        Parameters
        ----------
        name : {"vmc-b", "vmc-a"}
            ``"vmc-b"``: a small vertical milling centre like Machine B of the
            papers, 77 temperature sensors (001 Table 4-4). ``"vmc-a"``: like
            Machine A, 26 sensors (001 Table 6-1).
        effects : sequence of str, optional
            Default: every effect except ``sensor_drift``.
        params : dict, optional
            Parameter overrides.
        """
        from skthermal.simulate._presets import PRESETS

        if name not in PRESETS:
            raise ValueError(
                f"Unknown preset {name!r}; choose one of {sorted(PRESETS)}."
            )
        spec, defaults = PRESETS[name]()
        if effects is None:
            effects = [e for e in EFFECTS if e != "sensor_drift"]
        merged = dict(defaults)
        if params:
            unknown = [
                k for k in params if k not in merged and k.split(".")[0] not in EFFECTS
            ]
            if unknown:
                raise ValueError(f"Unknown parameter(s) {unknown} for preset {name!r}.")
            merged.update(params)
        return cls(spec, merged, effects)

    def _validate_params(self, params):
        out = {}
        for key, value in params.items():
            value = _check_number(value, f"Parameter {key!r}")
            kind = key.split(".")[0]
            if kind == "C" and value <= 0:
                raise ValueError(
                    f"Parameter {key!r} is a heat capacity and must be positive, "
                    f"got {value}."
                )
            if kind in ("G", "hA", "q") and value < 0 and key != "q.alpha":
                raise ValueError(
                    f"Parameter {key!r} (a conductance or heat input) must not be "
                    f"negative, got {value}."
                )
            out[key] = value
        alpha = out.get("q.alpha", 1.5)
        if not 0.5 <= alpha <= 3.0:
            raise ValueError(
                f"Parameter 'q.alpha' (bearing loss ~ speed^alpha) must lie in "
                f"[0.5, 3], got {alpha}; Palmgren-type friction gives 1 to 1.7."
            )
        for key in ("sensor_lag.tau_s",):
            if out[key] <= 0:
                raise ValueError(f"Parameter {key!r} must be positive, got {out[key]}.")
        for key in (
            "feed_heating.stroke",
            "feed_heating.measure_at",
            "feed_heating.nut_share",
            "feed_heating.motor_share",
        ):
            if not 0 <= out[key] <= 1:
                raise ValueError(
                    f"Parameter {key!r} must lie in [0, 1], got {out[key]}."
                )
        if out["feed_heating.nut_share"] + out["feed_heating.motor_share"] > 1:
            raise ValueError("feed_heating.nut_share + motor_share must not exceed 1.")
        for key, value in out.items():
            if (
                key.split(".")[0]
                in (
                    "sensor",
                    "disp",
                    "sensor_drift",
                    "speed_convection",
                    "tool_growth",
                    "feed_heating",
                )
                and value < 0
            ):
                raise ValueError(
                    f"Parameter {key!r} must not be negative, got {value}."
                )
        return out

    @property
    def name(self):
        """Preset or machine name."""
        return self.spec.name

    @property
    def effects(self):
        """Effects switched on, in vocabulary order."""
        return self._effects

    def effect_status(self):
        """Every effect of the vocabulary -> whether it is on."""
        return {e: e in self._effects for e in EFFECTS}

    @property
    def params(self):
        """A copy of all parameters."""
        return dict(self._params)

    @property
    def sensors(self):
        """Names of the temperature columns the machine produces."""
        return [s.name for s in self.spec.sensors]

    @property
    def targets(self):
        """Names of the displacement columns the machine produces."""
        return [f"disp_{a}_um" for a in self.spec.axes]

    def with_effects(self, effects=None, *, add=(), remove=()):
        """A copy with other effects: ``effects`` replaces, ``add``/``remove`` edit."""
        current = list(self._effects if effects is None else check_effects(effects))
        current += [e for e in check_effects(add) if e not in current]
        drop = set(check_effects(remove))
        return ThermalMachine(
            self.spec, self._params, [e for e in current if e not in drop]
        )

    def with_params(self, params=None, **kwargs):
        """A copy with some parameters changed (validated)."""
        new = dict(self._params)
        changes = dict(params or {}, **kwargs)
        unknown = [k for k in changes if k not in new]
        if unknown:
            raise ValueError(
                f"Unknown parameter(s) {unknown}; see ThermalMachine.parameter_table()."
            )
        new.update(changes)
        return ThermalMachine(self.spec, new, self._effects)

    def parameter_table(self):
        """All parameters as a Series (name -> value), sorted by name."""
        return pd.Series(self._params, name="value").sort_index()

    def __repr__(self):
        return (
            f"ThermalMachine({self.name!r}, nodes={len(self.spec.nodes)}, "
            f"sensors={len(self.spec.sensors)}, effects={list(self._effects)})"
        )

    # --- network ------------------------------------------------------------

    def _on(self, effect):
        return effect in self._effects

    def _convection(self, rpm):
        p, spec = self._params, self.spec
        h = np.array([p.get(f"hA.{n}", 0.0) for n in spec.nodes])
        if rpm > 0 and self._on("speed_convection"):
            gain = (
                p["speed_convection.gain"]
                * (rpm / 1000.0) ** p["speed_convection.exponent"]
            )
            for n in spec.head_nodes:
                h[self._index[n]] *= 1.0 + gain
        if rpm > 0 and self._on("tool_growth") and spec.tool in self._index:
            h[self._index[spec.tool]] += (
                p["tool_growth.hA_rotating"] * (rpm / 1000.0) ** 0.8
            )
        return h

    def _network(self, rpm):
        """Conductance matrix ``L + H`` and convection to the workshop air."""
        n = len(self.spec.nodes)
        K = np.zeros((n, n))
        p, idx = self._params, self._index
        for a, b in self.spec.edges:
            g = p[f"G.{a}-{b}"]
            i, j = idx[a], idx[b]
            K[i, j] -= g
            K[j, i] -= g
            K[i, i] += g
            K[j, j] += g
        h = self._convection(rpm)
        to_room = np.zeros(n)
        enc = idx[self.spec.enclosure]
        exposed = (
            set(self.spec.exposed_nodes) if self._on("ambient_transient") else set()
        )
        for name, i in idx.items():
            if i == enc:
                to_room[i] = h[i]
            elif name in exposed:
                to_room[i] = h[i]
            elif h[i] > 0:
                K[i, enc] -= h[i]
                K[enc, i] -= h[i]
                K[enc, enc] += h[i]
                K[i, i] += h[i]
        K[np.diag_indices(n)] += to_room
        return K, to_room

    def _modal(self, rpm):
        key = float(rpm)
        if key not in self._cache:
            K, to_room = self._network(key)
            C = np.array([self._params[f"C.{n}"] for n in self.spec.nodes])
            self._cache[key] = (ModalSystem.from_network(C, K), to_room)
        return self._cache[key]

    def node_time_constants(self, spindle_rpm=0.0):
        """Local time constant ``C_i / (sum of its conductances)`` of every node (s).

        How fast a node alone settles when its surroundings are held fixed:
        minutes for the spindle bearings, tens of minutes for the carrier,
        hours for the column core.
        """
        K, _ = self._network(float(spindle_rpm))
        C = np.array([self._params[f"C.{n}"] for n in self.spec.nodes])
        return pd.Series(C / np.diag(K), index=list(self.spec.nodes), name="tau_s")

    def response_times(self, spindle_rpm=4000.0, *, hours=72.0, fraction=0.632):
        """How long each node takes to reach ``fraction`` of its steady rise.

        Starts the spindle at ``spindle_rpm`` on a cold machine in constant
        air and records when each node has covered ``fraction`` (63.2%: one
        "time constant") of its rise after ``hours``. Useful for planning a
        test: how long to heat before the machine settles.

        Returns
        -------
        Series
            Minutes per node.
        """
        _, states = self.with_effects(remove=["sensor_drift"]).simulate(
            DutyCycle([(hours * 3600.0, spindle_rpm)]),
            20.0,
            sample_period_s=60.0,
            noise=False,
            return_states=True,
        )
        rise = (states - states.iloc[0]).to_numpy()
        final = rise[-1]
        reached = np.abs(rise) >= fraction * np.abs(final)
        minutes = np.where(np.abs(final) > 0, reached.argmax(axis=0), 0).astype(float)
        return pd.Series(minutes, index=list(self.spec.nodes), name="minutes")

    def time_constants(self, spindle_rpm=0.0):
        """Time constants of the network's modes (s), fastest first."""
        return np.sort(self._modal(float(spindle_rpm))[0].time_constants)

    # --- heat and displacement ----------------------------------------------

    def _heat(self, rpm, feed, sources=("spindle", "feed")):
        """Heat inputs (W), shape (n_steps, n_heated), and the heated nodes.

        ``sources`` selects the spindle losses (``"spindle"``: bearings,
        motor, belt, cutting; or ``"bearing"`` and ``"drive"`` (motor and
        belt) separately) and/or the feed losses (``"feed"``: ball screw,
        nut, axis motor).
        """
        p, spec = self._params, self.spec
        krpm = np.asarray(rpm, dtype=float) / 1000.0
        running = (krpm > 0).astype(float)
        cols = {}
        if "spindle" in sources or "bearing" in sources:
            cols[spec.bearing] = p["q.bearing_W"] * krpm ** p["q.alpha"]
        if "spindle" in sources or "drive" in sources:
            cols[spec.motor] = cols.get(spec.motor, 0.0) + (
                p["q.motor_idle_W"] * running + p["q.motor_W_per_krpm"] * krpm
            )
            cols[spec.belt] = cols.get(spec.belt, 0.0) + p["q.belt_W_per_krpm"] * krpm
        if "spindle" in sources:
            if p.get("q.cutting_W", 0.0):
                cols[spec.cutting] = (
                    cols.get(spec.cutting, 0.0) + p["q.cutting_W"] * running
                )
        if "feed" in sources and self._on("feed_heating") and spec.screw_nodes:
            power = (
                p["feed_heating.W_per_m_min"] * np.abs(np.asarray(feed, float)) / 1000.0
            )
            nut_share = p["feed_heating.nut_share"] if spec.nut else 0.0
            motor_share = p["feed_heating.motor_share"] if spec.axis_motor else 0.0
            screw_power = power * (1.0 - nut_share - motor_share)
            m = len(spec.screw_nodes)
            cover = np.clip(p["feed_heating.stroke"] * m - np.arange(m), 0.0, 1.0)
            cover = cover / cover.sum() if cover.sum() > 0 else np.full(m, 1.0 / m)
            for node, share in zip(spec.screw_nodes, cover, strict=True):
                cols[node] = cols.get(node, 0.0) + screw_power * share
            if spec.nut:
                cols[spec.nut] = cols.get(spec.nut, 0.0) + power * nut_share
            if spec.axis_motor:
                cols[spec.axis_motor] = (
                    cols.get(spec.axis_motor, 0.0) + power * motor_share
                )
        nodes = list(cols)
        n = np.shape(rpm)[0]
        if not nodes:
            return np.zeros((n, 0)), []
        Q = np.column_stack([np.broadcast_to(cols[k], (n,)) for k in nodes])
        return Q, [self._index[k] for k in nodes]

    def displacement_matrix(self):
        """Thermo-elastic map, DataFrame (axes x nodes) of µm per K of node rise.

        Growth of bodies in series and bending from gradients appear as
        coefficients on node temperatures. The ball screw's growth counts up to
        the measuring position (``feed_heating.measure_at``), the
        position-dependent term. The tool's growth counts only with the
        ``tool_growth`` effect.
        """
        return pd.DataFrame(
            self._displacement_array().copy(),
            index=list(self.spec.axes),
            columns=list(self.spec.nodes),
        )

    def _displacement_array(self):
        """The thermo-elastic map as an array (axes x nodes), cached."""
        if "displacement" in self._cache:
            return self._cache["displacement"]
        p, spec = self._params, self.spec
        axis_index = {a: i for i, a in enumerate(spec.axes)}
        M = np.zeros((len(spec.axes), len(spec.nodes)))
        for key, value in p.items():
            if value and key.startswith("k."):
                parts = key.split(".")
                if (
                    len(parts) == 3
                    and parts[2] in self._index
                    and parts[1] in axis_index
                ):
                    M[axis_index[parts[1]], self._index[parts[2]]] = value
        screw_total = p.get(f"k.{spec.feed_axis}.screw", 0.0)
        if spec.screw_nodes and screw_total:
            m = len(spec.screw_nodes)
            reach = np.clip(p["feed_heating.measure_at"] * m - np.arange(m), 0.0, 1.0)
            cols = [self._index[n] for n in spec.screw_nodes]
            M[axis_index[spec.feed_axis], cols] += screw_total / m * reach
        if not self._on("tool_growth"):
            M[:, self._index[spec.tool]] = 0.0
        self._cache["displacement"] = M
        return M

    def calibrate(
        self,
        runs,
        params,
        bounds=None,
        *,
        channels=None,
        initial="ambient",
        **least_squares_kw,
    ):
        """Fit chosen physical parameters to measured runs.

        Each run is simulated from its own drivers (``time_s``, ``spindle_rpm``,
        ``ambient_C`` and, if present, ``feed_mm_min``) without noise, and
        ``scipy.optimize.least_squares`` adjusts the named parameters to minimise
        the squared differences with the measured channels (each channel scaled by
        its standard deviation). Displacements are compared as change since the
        start of each run.

        Parameters
        ----------
        runs : DataFrame
            Measured run table(s).
        params : str or sequence of str
            Names from :meth:`parameter_table`, e.g. ``["q.bearing_W",
            "k.y.carrier3"]``.
        bounds : dict or sequence of (low, high), optional
            Default: a tenth to ten times each current value.
        channels : sequence of str, optional
            Columns to fit; default every displacement the machine predicts. Any
            of the machine's temperature columns may be added.
        initial : as in :meth:`simulate_drivers`, default="ambient"
        **least_squares_kw
            Passed to ``scipy.optimize.least_squares`` (e.g. ``max_nfev``).

        Returns
        -------
        machine : ThermalMachine
            A calibrated copy (this machine is unchanged).
        result : CalibrationResult
            Fitted values, approximate standard errors, RMSE per channel before
            and after, cost and convergence information.

        Examples
        --------
        >>> from skthermal.simulate import ThermalMachine, DutyCycle
        >>> truth = ThermalMachine.from_preset("vmc-b", params={"q.bearing_W": 14.0})
        >>> runs = truth.simulate(DutyCycle.heat_cool(4000, heat_h=1, cool_h=1),
        ...                       noise=False)
        >>> model = ThermalMachine.from_preset("vmc-b")
        >>> fitted, result = model.calibrate(runs, ["q.bearing_W"])
        >>> round(float(result.params["q.bearing_W"]), 3)
        14.0
        """
        return _calibrate(
            self, runs, params, bounds, channels, initial, least_squares_kw
        )

    # --- simulation ---------------------------------------------------------

    def _initial_state(self, initial, rpm0, feed0, air0):
        n = len(self.spec.nodes)
        if initial is None or (isinstance(initial, str) and initial == "ambient"):
            return np.full(n, air0)
        if isinstance(initial, str) and initial == "steady":
            K, to_room = self._network(float(rpm0))
            Q, cols = self._heat(np.array([rpm0]), np.array([feed0]))
            rhs = to_room * air0
            np.add.at(rhs, cols, Q[0])
            return np.linalg.solve(K, rhs)
        if isinstance(initial, dict):
            T0 = np.full(n, air0)
            for node, value in initial.items():
                if node not in self._index:
                    raise ValueError(
                        f"initial: unknown node {node!r}; nodes: "
                        f"{list(self.spec.nodes)}."
                    )
                T0[self._index[node]] = _check_number(value, f"initial[{node!r}]")
            return T0
        if np.ndim(initial) == 0:
            return np.full(n, _check_number(initial, "initial"))
        T0 = np.asarray(initial, dtype=float)
        if T0.shape != (n,) or not np.all(np.isfinite(T0)):
            raise ValueError(f"initial must be {n} finite node temperatures.")
        return T0

    def simulate_drivers(
        self,
        time_s,
        spindle_rpm,
        ambient_C,
        feed_mm_min=None,
        *,
        run="run1",
        initial="ambient",
        noise=True,
        random_state=None,
        return_states=False,
        strain_gauges=None,
    ):
        """Simulate given driver series (the drivers of a run table).

        Parameters
        ----------
        time_s : array-like of shape (n,)
            Regular, strictly increasing sample times (s).
        spindle_rpm : array-like of shape (n,)
            Speed in force from each sample to the next (held).
        ambient_C : array-like of shape (n,)
            Workshop air temperature at each sample (linear in between).
        feed_mm_min : array-like of shape (n,), optional
            Axis feed, held like the speed; absent means 0.
        run : label, default="run1"
        initial : {"ambient", "steady"}, float, dict or array, default="ambient"
            Node temperatures at the start: all at the first ambient value, the
            steady state of the first sample's drivers, one value, a
            ``{node: °C}`` dict (others at ambient), or one value per node.
        noise : bool, default=True
            Add sensor noise, quantisation, offsets (and drift, with the
            ``sensor_drift`` effect) and displacement noise. ``False`` gives
            the noiseless model response, as used by :meth:`calibrate`.
        random_state : int, RandomState instance or None
        return_states : bool, default=False
            Also return the node temperatures (DataFrame, one column a node).
        strain_gauges : dict, optional
            ``{name: skthermal.sensors.FBGGauge}``: add raw FBG strain
            channels ``S<name>_ue`` (grating strain including its own
            temperature sensitivity, with 0.5 µε noise when ``noise``), see
            :func:`skthermal.sensors.add_strain_channels`.

        Returns
        -------
        runs : DataFrame
            A run table; ``runs.attrs["metadata"]`` is a list with one record
            (dict) describing the run, ready for
            ``skthermal.datasets.write_runs(runs, path, metadata=...)``.
        states : DataFrame
            Only with ``return_states=True``.
        """
        t = np.asarray(time_s, dtype=float)
        rpm = np.asarray(spindle_rpm, dtype=float)
        air = np.asarray(ambient_C, dtype=float)
        feed = (
            np.zeros_like(t) if feed_mm_min is None else np.asarray(feed_mm_min, float)
        )
        self._check_drivers(t, rpm, air, feed, run)
        rng = check_random_state(random_state)
        dt = float(t[1] - t[0])
        with single_threaded_blas():
            T = self._integrate(
                rpm,
                feed,
                air,
                dt,
                self._initial_state(initial, rpm[0], feed[0], air[0]),
            )
            readings = self._read_sensors(T, air, t, dt, noise, rng)
            disp = (T - T[0]) @ self._displacement_array().T
        p = self._params
        if noise:
            disp = disp + rng.normal(0.0, p["disp.noise_um"], disp.shape)
            air_meas = air + rng.normal(0.0, p["sensor.noise_C"], air.shape)
            air_meas = self._quantise(air_meas)
        else:
            air_meas = air
        data = {
            "run": np.full(t.shape, run, dtype=object),
            "time_s": t - t[0],
            "spindle_rpm": rpm,
            "feed_mm_min": feed,
            "ambient_C": air_meas,
        }
        data.update(zip(self.sensors, readings.T, strict=True))
        data.update(zip(self.targets, disp.T, strict=True))
        frame = pd.DataFrame(data)
        states = pd.DataFrame(T, columns=list(self.spec.nodes))
        if strain_gauges:
            from skthermal.sensors import add_strain_channels

            frame = add_strain_channels(
                frame,
                states,
                strain_gauges,
                noise_ue=0.5 if noise else 0.0,
                random_state=rng,
            )
        frame.attrs["metadata"] = [self.run_metadata(run)]
        if return_states:
            return frame, states
        return frame

    def simulate(
        self,
        duty,
        ambient=None,
        *,
        sample_period_s=30.0,
        run="run1",
        initial="ambient",
        noise=True,
        random_state=None,
        return_states=False,
        strain_gauges=None,
    ):
        """Simulate a test programme.

        Parameters
        ----------
        duty : DutyCycle or sequence of (duration_s, spindle_rpm[, feed_mm_min])
        ambient : AmbientProfile, float or None
            Workshop air; a float is a constant; None is 20 °C.
        sample_period_s : float, default=30.0
        run, initial, noise, random_state, return_states, strain_gauges
            As in :meth:`simulate_drivers`.

        Returns
        -------
        DataFrame (and the node states with ``return_states=True``)
        """
        duty = duty if isinstance(duty, DutyCycle) else DutyCycle(duty)
        if ambient is None:
            ambient = AmbientProfile()
        elif not isinstance(ambient, AmbientProfile):
            ambient = AmbientProfile(mean_C=_check_number(ambient, "ambient"))
        dt = _check_number(sample_period_s, "sample_period_s", positive=True)
        n = int(round(duty.duration_s / dt))
        if n < 1:
            raise ValueError(
                f"The duty cycle ({duty.duration_s:g} s) is shorter than one sample "
                f"period ({dt:g} s)."
            )
        rng = check_random_state(random_state)
        t = np.arange(n + 1) * dt
        rpm, feed = duty.sample(t)
        air = ambient.sample(t, random_state=rng)
        return self.simulate_drivers(
            t,
            rpm,
            air,
            feed,
            run=run,
            initial=initial,
            noise=noise,
            random_state=rng,
            return_states=return_states,
            strain_gauges=strain_gauges,
        )

    def run_metadata(self, run):
        """Metadata row of a simulated run: machine, effects, description."""
        return {
            "run": run,
            "machine": self.name,
            "simulated": True,
            "effects": ",".join(self._effects),
            **{f"effect_{e}": on for e, on in self.effect_status().items()},
        }

    @staticmethod
    def _check_drivers(t, rpm, air, feed, run):
        n = t.shape[0]
        for name, a in (
            ("spindle_rpm", rpm),
            ("ambient_C", air),
            ("feed_mm_min", feed),
        ):
            if a.shape != (n,):
                raise ValueError(
                    f"{name} has {a.shape[0] if a.ndim else 0} values for {n} "
                    f"times (run {run!r})."
                )
        if n < 2:
            raise ValueError(
                f"Run {run!r} needs at least 2 samples to simulate, got {n}."
            )
        for name, a in (
            ("time_s", t),
            ("spindle_rpm", rpm),
            ("ambient_C", air),
            ("feed_mm_min", feed),
        ):
            bad = np.flatnonzero(~np.isfinite(a))
            if bad.size:
                raise ValueError(
                    f"{name} is NaN or infinite in run {run!r} at row {bad[0]}."
                )
        bad = np.flatnonzero(rpm < 0)
        if bad.size:
            raise ValueError(
                f"spindle_rpm must not be negative: {rpm[bad[0]]:g} in run {run!r} "
                f"at row {bad[0]}."
            )
        steps = np.diff(t)
        bad = np.flatnonzero(steps <= 0)
        if bad.size:
            raise ValueError(
                f"time_s must increase strictly: run {run!r}, row {bad[0] + 1} "
                f"(time_s {t[bad[0] + 1]:g} after {t[bad[0]]:g})."
            )
        if np.ptp(steps) > 1e-6 * steps.mean():
            raise ValueError(
                f"Run {run!r} is not regularly sampled (steps from {steps.min():g} to "
                f"{steps.max():g} s); resample it to a constant period first."
            )

    def _integrate(self, rpm, feed, air, dt, T0, sources=("spindle", "feed")):
        n_steps = rpm.shape[0] - 1
        Q, cols = self._heat(rpm[:-1], feed[:-1], sources)
        T = np.empty((n_steps + 1, len(self.spec.nodes)))
        T[0] = T0
        change = np.flatnonzero(np.diff(rpm[:-1]) != 0) + 1
        bounds = np.concatenate(([0], change, [n_steps]))
        for a, b in zip(bounds[:-1], bounds[1:], strict=True):
            modal, to_room = self._modal(rpm[a])
            T[a : b + 1] = modal.step(T[a], Q[a:b], to_room, air[a : b + 1], dt, cols)
        return T

    def _quantise(self, x):
        q = self._params["sensor.quantization_C"]
        return np.round(x / q) * q if q > 0 else x

    def _read_sensors(self, T, air, t, dt, noise, rng):
        spec, p = self.spec, self._params
        index = dict(self._index)
        index[ROOM] = len(spec.nodes)
        W = _weights_matrix(spec, index, [s.weights for s in spec.sensors])
        x = T @ W[:, :-1].T + np.outer(air, W[:, -1])
        if self._on("sensor_lag"):
            lagged = np.array([s.kind == "surface" for s in spec.sensors])
            if lagged.any():
                x[:, lagged] = first_order_lag(x[:, lagged], p["sensor_lag.tau_s"], dt)
        if not noise:
            return x
        # Calibration offsets belong to the sensor, not the run: the same
        # sensor reads the same offset in every run of the machine.
        offsets = np.array(
            [
                np.random.RandomState(
                    zlib.crc32(f"{self.name}/{s.name}".encode())
                ).normal(0.0, p["sensor.offset_C"])
                for s in spec.sensors
            ]
        )
        x = x + offsets
        if self._on("sensor_drift"):
            hours = (t - t[0]) / 3600.0
            rate = rng.normal(0.0, p["sensor_drift.rate_C_per_h"], x.shape[1])
            steps = rng.normal(
                0.0,
                p["sensor_drift.walk_C_per_sqrt_h"] * np.sqrt(dt / 3600.0),
                (x.shape[0] - 1, x.shape[1]),
            )
            walk = np.vstack([np.zeros(x.shape[1]), np.cumsum(steps, axis=0)])
            x = x + np.outer(hours, rate) + walk
        x = x + rng.normal(0.0, p["sensor.noise_C"], x.shape)
        return self._quantise(x)


def _run_drivers(frame, run):
    """Driver arrays of one run of a run table, with clear errors."""
    for col in ("time_s", "spindle_rpm", "ambient_C"):
        if col not in frame.columns:
            raise ValueError(
                f"Run {run!r} has no {col!r} column; simulating a measured run "
                "needs time_s, spindle_rpm and ambient_C."
            )
    feed = frame["feed_mm_min"].to_numpy(float) if "feed_mm_min" in frame else None
    return (
        frame["time_s"].to_numpy(float),
        frame["spindle_rpm"].to_numpy(float),
        frame["ambient_C"].to_numpy(float),
        feed,
    )


def _calibrate(machine, runs, params, bounds, channels, initial, least_squares_kw):
    from scipy.optimize import least_squares

    if isinstance(params, str):
        params = [params]
    params = list(params)
    if not params:
        raise ValueError("Name at least one parameter to calibrate.")
    current = machine.params
    unknown = [k for k in params if k not in current]
    if unknown:
        raise ValueError(
            f"Unknown parameter(s) {unknown}; see ThermalMachine.parameter_table()."
        )
    x0 = np.array([current[k] for k in params])
    if bounds is None:
        if np.any(x0 == 0):
            zero = [k for k, v in zip(params, x0, strict=True) if v == 0]
            raise ValueError(
                f"Parameter(s) {zero} are 0: give bounds=, the default range "
                "(a tenth to ten times the current value) needs a non-zero value."
            )
        lo, hi = np.minimum(x0 / 10, x0 * 10), np.maximum(x0 / 10, x0 * 10)
    else:
        if isinstance(bounds, dict):
            missing = [k for k in params if k not in bounds]
            if missing:
                raise ValueError(f"bounds has no entry for {missing}.")
            pairs = [bounds[k] for k in params]
        else:
            pairs = list(bounds)
        if len(pairs) != len(params):
            raise ValueError(
                f"Give one (low, high) pair per parameter ({len(params)})."
            )
        lo = np.array([float(a) for a, _ in pairs])
        hi = np.array([float(b) for _, b in pairs])
        if np.any(lo >= hi):
            raise ValueError("Every bound needs low < high.")
        x0 = np.clip(x0, lo, hi)

    if "run" not in runs.columns:
        raise ValueError("The run table has no 'run' column.")
    channels = machine.targets if channels is None else list(channels)
    channels = [c for c in channels if c in runs.columns]
    if not channels:
        raise ValueError(
            f"The runs have none of the channels to fit; the machine predicts "
            f"{machine.targets + machine.sensors}."
        )
    for c in channels:
        if c not in machine.targets and c not in machine.sensors:
            raise ValueError(f"The machine does not predict {c!r}.")
    groups = [(run, frame) for run, frame in runs.groupby("run", sort=False)]
    measured = []
    for run, frame in groups:
        y = frame[channels].to_numpy(float, copy=True)
        if not np.all(np.isfinite(y)):
            raise ValueError(f"Run {run!r} has missing values in {channels}.")
        # Displacements are compared as change since the start of the run,
        # the way the simulation starts them.
        disp = [i for i, c in enumerate(channels) if c in machine.targets]
        y[:, disp] -= y[0, disp]
        measured.append(y)
    scale = np.concatenate(measured).std(axis=0)
    scale = np.where(scale > 0, scale, 1.0)

    def simulate_all(values):
        m = machine.with_params(dict(zip(params, values, strict=True)))
        out = []
        for run, frame in groups:
            t, rpm, air, feed = _run_drivers(frame, run)
            sim = m.simulate_drivers(
                t, rpm, air, feed, run=run, initial=initial, noise=False
            )
            out.append(sim[channels].to_numpy(float))
        return out

    def residuals(values):
        sims = simulate_all(values)
        return np.concatenate(
            [((s - y) / scale).ravel() for s, y in zip(sims, measured, strict=True)]
        )

    def rmse(values):
        sims = simulate_all(values)
        err = np.concatenate([s - y for s, y in zip(sims, measured, strict=True)])
        return pd.Series(np.sqrt(np.mean(err**2, axis=0)), index=channels)

    before = rmse(x0)
    kw = {"x_scale": "jac", "max_nfev": 50 * len(params)}
    kw.update(least_squares_kw)
    res = least_squares(residuals, x0, bounds=(lo, hi), **kw)
    try:
        J = res.jac
        cov = np.linalg.pinv(J.T @ J) * (2 * res.cost / max(J.shape[0] - J.shape[1], 1))
        std = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:  # pragma: no cover - pinv rarely fails
        std = np.full(len(params), np.nan)
    result = CalibrationResult(
        params=pd.Series(res.x, index=params),
        initial=pd.Series(x0, index=params),
        std_error=pd.Series(std, index=params),
        rmse_before=before,
        rmse_after=rmse(res.x),
        cost=float(res.cost),
        nfev=int(res.nfev),
        success=bool(res.success),
        message=str(res.message),
    )
    return machine.with_params(dict(zip(params, res.x, strict=True))), result
