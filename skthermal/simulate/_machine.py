"""The thermal machine: a lumped-parameter network, heat sources, sensors and a
thermo-elastic map from temperatures to displacements.

``C_i dT_i/dt = sum_j G_ij (T_j - T_i) + hA_i (T_air,i - T_i) + Q_i(t)``

Every number lives in one flat dictionary of named parameters (``"C.boss"``,
``"G.boss-carrier1"``, ``"k.y.carrier3"``, ``"speed_convection.gain"`` ...), so
any of them can be changed with :meth:`ThermalMachine.with_params` or fitted to
measurements with :meth:`ThermalMachine.calibrate`.
"""

import copy
import dataclasses
import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.special import expit
from sklearn.utils import check_random_state

from skthermal._naming import plain, shown, suggest
from skthermal.simulate._drivers import (
    AmbientProfile,
    DutyCycle,
    _check_number,
    _float_array,
)
from skthermal.simulate._effects import (
    EFFECTS,
    Effect,
    check_effects,
    default_effects,
    sensor_draws,
)
from skthermal.simulate._presets import PRESETS
from skthermal.simulate._solver import ModalSystem
from skthermal.simulate._spec import (
    HEAT_FIELDS,
    NUMBER_DEFAULTS,
    ROOM,
    MachineSpec,
    check_connected,
    check_parameter_names,
    check_parameters,
    parameter_entry,
    parameter_range,
)
from skthermal.utils._faults import flat_columns, repair_spikes
from skthermal.utils._runs import (
    ABSOLUTE_ZERO_C,
    check_finite_columns,
    check_labels,
    check_numeric_columns,
    check_run_label,
    check_unique_columns,
    is_clock_dtype,
    warn_air_unit,
    warn_short_runs,
)
from skthermal.utils._threads import (
    single_threaded_blas,
    with_single_threaded_blas,
)
from skthermal.utils._warnings import user_stacklevel


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
        Approximate standard errors from the Jacobian at the solution; inf
        for a parameter with no influence on the fitted channels (it is not
        determined by them, and ``calibrate`` warns).
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


# A rise below this (K) is rounding noise, not heating (response_times).
RISE_TOLERANCE_K = 1e-9
# The prior of :meth:`ThermalMachine.initial_from_readings`: the states of
# PRIOR_HOURS of random duty, scaled to PRIOR_RISE_K (rms per node), plus the
# whole machine away from the air by PRIOR_AIR_K (rms); a reading is never
# taken as surer than READING_FLOOR_C.
PRIOR_HOURS = 48.0
PRIOR_RISE_K = 5.0
PRIOR_AIR_K = 2.0
READING_FLOOR_C = 0.01
# Longest stretch of steps integrated in one recursion (longer ones go in
# pieces: the arrays of a piece stay in the cache).
SEGMENT_STEPS = 512
# A first reading this far from the air is in other units (kelvin,
# fahrenheit), not a warm machine.
READING_SPAN_K = 100.0
# First readings a median this far above the air, or one this far below it,
# seldom are a machine's: a warning (readings in fahrenheit, say).
READING_ABOVE_K = 30.0
READING_BELOW_K = 20.0
# Samples of a run's first readings (calibrate's initial="measured").
FIRST_READINGS = 5

# The largest ratio of the fastest to the slowest decay rate of the network
# that floating point resolves: an eigenvalue carries a rounding error of
# about 1e-16 times the fastest rate, so beyond this the slow modes (hours
# of a machine's warm-up) are off by more than ~1e-4 of themselves. Machine
# tools span some 1e3 to 1e5 (seconds to a day).
STIFFNESS_LIMIT = 1e12
# Driver values beyond any machine tool's: a spindle above 1e5 rpm, a feed
# above 2e5 mm/min is a typo or a unit slip (the simulator would write
# millions of degrees). Simulating such drivers warns, naming the value, and
# an error that such a speed may cause names it; the command line refuses
# them.
PLAUSIBLE_RPM = 1e5
PLAUSIBLE_FEED_MM_MIN = 2e5
# Samples of one simulated run (a year at 15 s, 23 days at 1 s): more is a
# duration in the wrong unit, and would not fit in memory.
MAX_SAMPLES = 2_000_000
# A duty cycle longer than this (60 days, as the run tables' milliseconds
# check) is most likely given in milliseconds.
LONGEST_TEST_S = 60 * 86400.0


class ImplausibleDriverWarning(UserWarning):
    """A driver of a simulation lies beyond any machine tool's range."""


class _StiffNetwork(ValueError):
    """The network at one speed is too stiff for floating point."""


def _weights_matrix(spec, names_index, items):
    W = np.zeros((len(items), len(names_index)))
    for i, weights in enumerate(items):
        for node, w in weights.items():
            W[i, names_index[node]] += w
    return W


def _unmoved_axes(spec, params):
    """The axes no node's rise moves (every thermo-elastic coefficient zero,
    the ball screw's too): their channels are sensor noise alone."""
    return [
        a
        for a in spec.axes
        if not any(params.get(f"k.{a}.{n}", 0.0) for n in (*spec.nodes, "screw"))
    ]


def _warn_idle_parts(spec, params):
    """Warn when the description has a displacement axis without any
    thermo-elastic coefficient (its channel would be noise alone) or no heat
    source at all (nothing the drivers do would warm the machine)."""
    flat = _unmoved_axes(spec, params)
    powers = [
        name
        for table in HEAT_FIELDS.values()
        for name, unit in table.values()
        if unit != "1"
    ]
    custom = [
        k
        for k in params
        if k.startswith("q.") and k.count(".") == 2 and not k.endswith(".alpha")
    ]
    problems = []
    if flat:
        problems.append(
            f"axis {flat[0]!r} has no thermo-elastic coefficient (no "
            f"[displacement.{flat[0]}] table, or all zero): its channel "
            f"disp_{flat[0]}_um would be sensor noise alone"
            + (f" (so has {flat[1:]})" if len(flat) > 1 else "")
        )
    if not any(params.get(k, 0.0) for k in [*powers, *custom]):
        problems.append(
            "no heat source has any power ([heat] is missing or all zero): "
            "only the air moves the temperatures"
        )
    fast = _fast_nodes(spec, params)
    if fast:
        node, tau, capacity, conductance = fast[0]
        problems.append(
            f"node {node!r} takes up heat in {tau:.2g} s (capacity "
            f"{capacity:g} J/K against {conductance:g} W/K of links and "
            "convection), where a lumped body of a machine tool takes minutes: "
            "check the units of capacity_J_per_K (J/K, not kJ/K) and of its "
            "conductances (W/K)"
            + (f" (so does {[f[0] for f in fast[1:]]})" if len(fast) > 1 else "")
        )
    if problems:
        warnings.warn(
            f"Machine {spec.name!r}: " + "; ".join(problems) + ".",
            UserWarning,
            stacklevel=user_stacklevel(),
        )


# A node whose capacity fills through its links and convection faster than
# this (seconds) is taken for a unit slip (the presets' fastest: 61 s).
FAST_NODE_S = 10.0


def _fast_nodes(spec, params):
    """``(node, time constant s, capacity, conductance)`` of the nodes
    (not the enclosure air) whose capacity over the sum of their links' and
    convection's conductances is below :data:`FAST_NODE_S`, fastest first."""
    out = []
    for node in spec.nodes:
        if node == spec.enclosure:
            continue
        conductance = float(params.get(f"hA.{node}", 0.0)) + sum(
            float(params.get(f"G.{a}-{b}", 0.0))
            for a, b in spec.edges
            if node in (a, b)
        )
        capacity = float(params.get(f"C.{node}", np.inf))
        if conductance > 0 and capacity / conductance < FAST_NODE_S:
            out.append((node, capacity / conductance, capacity, conductance))
    return sorted(out, key=lambda f: f[1])


def _warn_inactive(spec, effects):
    """Warn, naming each, when effects switched on cannot act on ``spec``."""
    chosen = set(effects)
    lacking = {e: EFFECTS[e].missing(spec) for e in EFFECTS if e in chosen}
    lacking = {e: why for e, why in lacking.items() if why is not None}
    if lacking:
        warnings.warn(
            f"Machine {spec.name!r}: "
            + "; ".join(
                f"effect {e!r} is switched on but does nothing: {why}"
                for e, why in lacking.items()
            )
            + ".",
            UserWarning,
            stacklevel=user_stacklevel(),
        )


def _jittered_period(t):
    """The period of a clock that only jitters: the coarsest rounding of
    the median step (to a decimal digit) that makes the times, rounded to
    its multiples, evenly spaced, each time near its slot; None when none
    does (the run has gaps or another period in places)."""
    median = float(np.median(np.diff(t)))
    if not median > 0:
        return None
    top = int(np.floor(np.log10(median)))
    for digits in range(-top, 10):
        period = round(median, digits)
        if period <= 0:
            continue
        k = np.round(t / period)
        # Evenly spaced, and every time within a tenth of a period of its
        # slot either way: jitter, not a gap or a drifting clock.
        if np.all(np.diff(k) == 1) and np.ptp(t - k * period) <= 0.2 * period:
            return period
    return None


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

    #: Prior probability of a soaked start that ``initial="auto"`` gives
    #: :meth:`initial_from_readings` (in :meth:`calibrate` and
    #: ``skthermal.gap.diagnose``): test runs start soaked as often as warm.
    SOAKED_PRIOR = 0.5

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
    def from_spec(cls, spec, *, effects=None, params=None):
        """A machine from a description: a spec, a dict or a TOML file.

        Parameters
        ----------
        spec : MachineSpec, dict or path
            The machine; a dict or a file in the layout of
            :meth:`MachineSpec.from_dict`.
        effects : sequence of str, optional
            Effects switched on. Default: the switches the description
            records (:attr:`MachineSpec.effects`, written by
            :meth:`to_spec`); an effect it does not record takes its default
            (every effect except ``sensor_drift`` is on, unless the machine
            lacks what it acts on, e.g. ``feed_heating`` without a ball
            screw). Given, it replaces the recorded switches. Switching on an
            effect that cannot act on the machine warns, with the reason.
        params : dict, optional
            Parameter overrides (names as in :meth:`parameter_table`).

        Examples
        --------
        >>> from skthermal.simulate import ThermalMachine
        >>> spec = ThermalMachine.from_preset("spindle-rig").spec
        >>> machine = ThermalMachine.from_spec(spec.to_dict())
        >>> machine.targets[:2]
        ['disp_ch1_um', 'disp_ch2_um']
        """
        if isinstance(spec, dict):
            spec = MachineSpec.from_dict(spec)
        elif isinstance(spec, str | Path):
            spec = MachineSpec.from_toml(spec)
        elif not isinstance(spec, MachineSpec):
            raise TypeError(
                "spec must be a MachineSpec, a dict or the path of a TOML file, "
                f"got {type(spec).__name__}."
            )
        if not spec.params:
            raise ValueError(
                f"Machine spec {spec.name!r} has no numbers (params is empty): "
                "give capacities, conductances and the other parameters."
            )
        if effects is None:
            # Effects on by default that cannot act on this machine (no ball
            # screw for feed_heating, say) stay off; those the description
            # switches on itself are kept, with a warning.
            recorded = {e for e, on in (spec.effects or {}).items() if on}
            effects = tuple(
                e
                for e in default_effects(spec.effects)
                if e in recorded or EFFECTS[e].missing(spec) is None
            )
            _warn_inactive(spec, recorded)
        else:
            _warn_inactive(spec, check_effects(effects))
        merged = dict(NUMBER_DEFAULTS)
        merged.update(
            {f"k.{axis}.{node}": 0.0 for axis in spec.axes for node in spec.nodes}
        )
        merged.update(spec.params)
        if params:
            merged.update(params)
        _warn_idle_parts(spec, merged)
        return cls(spec, merged, effects)

    def to_spec(self):
        """The machine's description: its current parameters and effects.

        The spec records every parameter (effect parameters included) and
        every effect switch (:attr:`MachineSpec.effects`), so
        ``from_spec(machine.to_spec())`` and a round trip through
        ``to_toml(path)`` and ``from_spec(path)`` give the same machine.

        Examples
        --------
        >>> from skthermal.simulate import ThermalMachine
        >>> m = ThermalMachine.from_preset("spindle-rig", effects=[]).with_params(
        ...     {"q.bearing_W": 5.0})
        >>> again = ThermalMachine.from_spec(m.to_spec().to_dict())
        >>> again.params["q.bearing_W"], again.effects
        (5.0, ())
        """
        return dataclasses.replace(
            self.spec,
            params=dict(self._params),
            effects={e: e in self._effects for e in EFFECTS},
        )

    @classmethod
    def from_preset(cls, name, *, effects=None, params=None):
        """A preset machine.

        Parameters
        ----------
        name : {"vmc-b", "vmc-a", "spindle-rig"}
            ``"vmc-b"``: a small vertical milling centre like Machine B of the
            papers, 77 temperature sensors (001 Table 4-4). ``"vmc-a"``: like
            Machine A, 26 sensors (001 Table 6-1). ``"spindle-rig"``: a
            spindle test rig (front and rear bearings and housings, motor,
            base, air), 16 sensors and 5 displacement channels of the
            spindle nose, laid out like the FL_THERMAL record.
        effects : sequence of str, optional
            Default: every effect except ``sensor_drift``, and on
            ``"spindle-rig"`` except ``feed_heating`` (no ball screw).
        params : dict, optional
            Parameter overrides (names as in :meth:`parameter_table`).
        """
        if name not in PRESETS:
            raise ValueError(
                f"Unknown preset {name!r}; choose one of {sorted(PRESETS)}."
            )
        return cls.from_spec(PRESETS[name](), effects=effects, params=params)

    def _validate_params(self, params):
        params = check_parameters(self.spec, params)
        check_connected(self.spec, params)
        return params

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

    @property
    def unmoved_targets(self):
        """Names of the displacement columns that no part of the machine
        moves (every thermo-elastic coefficient of the axis zero): the
        simulation holds them at zero."""
        return [f"disp_{a}_um" for a in _unmoved_axes(self.spec, self.params)]

    @property
    def structure_sensors(self):
        """Names of the sensors that read the structure: a weight on a node
        other than the enclosure (not the air alone). The first readings of
        these tell a warm machine (:meth:`initial_from_readings`)."""
        enc = self.spec.enclosure
        return [
            s.name
            for s in self.spec.sensors
            if any(w > 0 and n not in (enc, ROOM) for n, w in s.weights.items())
        ]

    def first_readings(self, run_table, *, columns=None, run=None):
        """A run's first readings, for :meth:`initial_from_readings`.

        Parameters
        ----------
        run_table : DataFrame
            A run table (its rows in time order within each run), or one
            run of it.
        columns : dict, optional
            Sensor -> column of ``run_table``, where the names differ;
            default every sensor of the machine the table holds.
        run : label, optional
            The run whose first readings to take, from a table with a
            ``run`` column; needed when it holds more than one run.

        Returns
        -------
        dict
            Sensor -> its first :data:`FIRST_READINGS` samples, of every
            sensor whose first samples are finite numbers (one missing there
            is left out).

        Examples
        --------
        >>> from skthermal.simulate import ThermalMachine, DutyCycle
        >>> rig = ThermalMachine.from_preset("spindle-rig")
        >>> runs = rig.simulate(DutyCycle.heat_cool(3000, heat_h=1, cool_h=1),
        ...                     noise=False, run="R1")
        >>> first = rig.first_readings(runs, run="R1")
        >>> list(first)[:2], first["T1_C"].shape
        (['T1_C', 'T2_C'], (5,))
        """
        if not isinstance(run_table, pd.DataFrame):
            raise TypeError(
                "run_table must be a run table (a pandas DataFrame), got "
                f"{type(run_table).__name__}."
            )
        frame = run_table
        if "run" in frame.columns:
            labels = [plain(x) for x in pd.unique(frame["run"])]
            if run is not None:
                if run not in labels:
                    raise ValueError(
                        f"run {run!r} is not in the table; its runs: "
                        f"{labels[:6]}{' ...' if len(labels) > 6 else ''}."
                    )
                frame = frame[(frame["run"] == run).to_numpy()]
            elif len(labels) > 1:
                raise ValueError(
                    f"The table holds {len(labels)} runs ({labels[:3]} ...): "
                    "give run= to say whose first readings to take."
                )
        where = "" if run is None else f"Run {run!r}: "
        if frame.empty:
            raise ValueError(f"{where}the table has no rows to read.")
        if columns is None:
            columns = {c: c for c in self.sensors if c in frame.columns}
        else:
            columns = dict(columns)
            self._check_sensor_names(columns, "columns")
            absent = {s: c for s, c in columns.items() if c not in frame.columns}
            if absent:
                s, c = next(iter(absent.items()))
                raise ValueError(
                    f"columns: sensor {s!r} is mapped to column {c!r}, which the "
                    f"table lacks{suggest(str(c), [str(x) for x in frame.columns])}."
                )
        head = frame.iloc[:FIRST_READINGS]
        out = {}
        for sensor, column in columns.items():
            values = pd.to_numeric(head[column], errors="coerce").to_numpy(float)
            if np.all(np.isfinite(values)):
                out[sensor] = values
        structure = self.structure_sensors
        if not any(sensor in structure for sensor in out):
            read = [c for c in columns if c in structure]
            pool = read or structure
            listed = f"{pool[:4]}{' ...' if len(pool) > 4 else ''}"
            what = (
                f"none of the sensors that read the machine's structure ({listed}) "
                f"holds numbers in its first {FIRST_READINGS} samples"
                if read
                else "the table holds none of the sensors that read the "
                f"machine's structure ({listed})"
            )
            air = f" (the air alone, {sorted(out)}, cannot tell a warm machine)"
            raise ValueError(
                f"{where}{what}{air if out else ''}: initial='measured' "
                "estimates the run's initial state from them; give "
                "initial='ambient' (soaked at the first air reading) for such "
                "runs."
            )
        return out

    def _check_sensor_names(self, names, what):
        """A ValueError naming the entries of ``names`` that are not sensors
        of the machine (``what``: where they come from)."""
        unknown = [c for c in names if c not in self.sensors]
        if unknown:
            raise ValueError(
                f"{what}: {unknown} are not sensors of the machine"
                f"{suggest(unknown[0], self.sensors)}; its sensors: "
                f"{self.sensors[:6]}{' ...' if len(self.sensors) > 6 else ''}."
            )

    def with_effects(self, effects=None, *, add=(), remove=()):
        """A copy with other effects: ``effects`` replaces, ``add``/``remove`` edit."""
        current = list(self._effects if effects is None else check_effects(effects))
        added = [e for e in check_effects(add) if e not in current]
        _warn_inactive(
            self.spec, [e for e in current + added if e not in self._effects]
        )
        current += added
        drop = set(check_effects(remove))
        return ThermalMachine(
            self.spec, self._params, [e for e in current if e not in drop]
        )

    def with_params(self, params=None, **kwargs):
        """A copy with some parameters changed (validated)."""
        changes = dict(params or {}, **kwargs)
        # Only the changed values need their checks (the rest were checked
        # when this machine was built), and the joint ones.
        new = check_parameters(self.spec, changes, base=self._params)
        check_connected(self.spec, new)
        machine = copy.copy(self)
        machine._params = new
        # The sensors' weights and the read plans depend on the structure only.
        machine._cache = {
            k: v
            for k, v in self._cache.items()
            if isinstance(k, tuple) and k[0] in ("sensors", "read")
        }
        return machine

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

    @property
    def node_index(self):
        """Node name -> column of the node temperatures (``spec.nodes`` order)."""
        return dict(self._index)

    def _active(self):
        return [EFFECTS[e] for e in self._effects]

    def _convection(self, rpm):
        p, spec = self._params, self.spec
        h = np.array([p.get(f"hA.{n}", 0.0) for n in spec.nodes])
        for effect in self._active():
            h = effect.convection(self, p, rpm, h)
        return h

    def _conductances(self, rpm):
        """Every conductance of the network at ``rpm``, as ``(parameter, i,
        j, W/K)``: the links, and each node's convection, to the enclosure
        node ``j`` or (``j`` None: the enclosure's own, and that of the nodes
        an effect exposes) straight to the workshop air."""
        p, idx = self._params, self._index
        for a, b in self.spec.edges:
            yield f"G.{a}-{b}", idx[a], idx[b], p[f"G.{a}-{b}"]
        h = self._convection(rpm)
        enc = idx[self.spec.enclosure]
        exposed = set()
        for effect in self._active():
            exposed |= set(effect.exposed_nodes(self))
        for name, i in idx.items():
            if i == enc or name in exposed:
                yield f"hA.{name}", i, None, h[i]
            elif h[i] > 0:
                yield f"hA.{name}", i, enc, h[i]

    def _network(self, rpm):
        """Conductance matrix ``L + H`` and convection to the workshop air."""
        n = len(self.spec.nodes)
        K = np.zeros((n, n))
        to_room = np.zeros(n)
        for _, i, j, g in self._conductances(rpm):
            if j is None:
                to_room[i] = g
                continue
            K[i, j] -= g
            K[j, i] -= g
            K[i, i] += g
            K[j, j] += g
        K[np.diag_indices(n)] += to_room
        return K, to_room

    def _modal(self, rpm):
        """The modal system and convection to the workshop air at ``rpm``,
        cached per speed, or once for every speed when the network does
        not follow the speed."""
        # Without an effect whose convection follows the speed, one
        # network serves every speed.
        key = float(rpm) if self._speed_dependent() else "any speed"
        if key not in self._cache:
            K, to_room = self._network(float(rpm))
            C = np.array([self._params[f"C.{n}"] for n in self.spec.nodes])
            try:
                with np.errstate(over="ignore", invalid="ignore"):
                    modal = ModalSystem.from_network(C, K)
            except (ValueError, np.linalg.LinAlgError):
                # check_connected gives every node a path to the air, so a
                # zero decay rate (or an overflow) is rounding: too stiff.
                modal = None
            if modal is None or not modal.rates[-1] <= (
                STIFFNESS_LIMIT * modal.rates[0]
            ):
                raise _StiffNetwork(self._stiff_message(np.array([float(rpm)])))
            self._cache[key] = (modal, to_room)
        return self._cache[key]

    def _speed_dependent(self):
        """Whether an active effect makes the convection follow the speed
        (overrides :meth:`Effect.convection`)."""
        return any(
            type(effect).convection is not Effect.convection
            for effect in self._active()
        )

    def _resolvable(self, rpm):
        """Whether floating point resolves the network at ``rpm`` (its
        :meth:`_modal` system, kept for the simulation)."""
        try:
            self._modal(rpm)
        except _StiffNetwork:
            return False
        return True

    def network(self, spindle_rpm=0.0):
        """The linear network at one spindle speed.

        ``C dT/dt = -K T + h_room T_room + Q``: every node's convection to
        the enclosure air is part of ``K``; ``h_room`` is the convection of
        the enclosure (and, with ``ambient_transient``, of the exposed nodes)
        to the workshop air.

        Returns
        -------
        C : ndarray of shape (n_nodes,)
            Heat capacities (J/K).
        K : ndarray of shape (n_nodes, n_nodes)
            Conductance matrix (W/K).
        h_room : ndarray of shape (n_nodes,)
            Convection to the workshop air (W/K).
        """
        K, to_room = self._network(_check_number(spindle_rpm, "spindle_rpm"))
        C = np.array([self._params[f"C.{n}"] for n in self.spec.nodes])
        return C, K, to_room

    def heat_inputs(self, spindle_rpm, feed_mm_min=None):
        """Heat input (W) of every heated node, one row per sample.

        Returns
        -------
        DataFrame
            Columns: the heated nodes.
        """
        rpm = np.atleast_1d(np.asarray(spindle_rpm, dtype=float))
        feed = (
            np.zeros_like(rpm)
            if feed_mm_min is None
            else np.atleast_1d(np.asarray(feed_mm_min, dtype=float))
        )
        Q, cols = self._heat(rpm, feed)
        return pd.DataFrame(Q, columns=[self.spec.nodes[i] for i in cols])

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
            Minutes per node; NaN for a node that does not heat (its rise
            after ``hours`` is below 1e-9 K, e.g. at 0 rpm without heat).
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
        # A node that does not heat (no heat at this speed: its rise is
        # rounding noise) has no response time: NaN.
        heats = np.abs(final) > RISE_TOLERANCE_K
        minutes = np.where(heats, reached.argmax(axis=0), np.nan).astype(float)
        return pd.Series(minutes, index=list(self.spec.nodes), name="minutes")

    def time_constants(self, spindle_rpm=0.0):
        """Time constants of the network's modes (s), fastest first."""
        return np.sort(self._modal(float(spindle_rpm))[0].time_constants)

    # --- responses (noise-free) ----------------------------------------------

    #: Heat-source groups of :meth:`response` with ``by_source=True``.
    SOURCES = ("air", "bearing", "drive", "feed")

    def response(
        self,
        time_s,
        spindle_rpm,
        ambient_C,
        feed_mm_min=None,
        *,
        initial="ambient",
        by_source=False,
        run="run1",
    ):
        """Node temperatures for given drivers, without noise.

        The noise-free state of the network; read channels from it with
        :meth:`read`. :meth:`simulate_drivers` is this followed by
        :meth:`read` and the sensors' noise.

        Parameters
        ----------
        time_s, spindle_rpm, ambient_C, feed_mm_min
            Drivers, as in :meth:`simulate_drivers`.
        initial : as in :meth:`simulate_drivers`, default="ambient"
        by_source : bool, default=False
            Split the response by what drives it (the network is linear):
            ``"air"`` (the air, from ``initial``, without heat), and the
            heat of the ``"bearing"`` (spindle bearings), the ``"drive"``
            (motor, belt, cutting, and the custom sources but for their
            |feed| terms) and the ``"feed"`` (ball screw with
            ``feed_heating``, and the custom sources' |feed| terms; only
            with a non-zero feed), each from zero with the air at zero. The
            parts sum to the response.
        run : label, default="run1"
            Named in error messages.

        Returns
        -------
        ndarray of shape (n, n_nodes) or dict of them
            Node temperatures (°C; a heat part is a rise in K), columns in
            the order of ``spec.nodes``.

        Examples
        --------
        >>> import numpy as np
        >>> from skthermal.simulate import ThermalMachine
        >>> m = ThermalMachine.from_preset("spindle-rig")
        >>> t = np.arange(121) * 30.0
        >>> parts = m.response(t, np.full(121, 3000.0), np.full(121, 20.0),
        ...                    by_source=True)
        >>> sorted(parts)
        ['air', 'bearing', 'drive']
        >>> total = m.response(t, np.full(121, 3000.0), np.full(121, 20.0))
        >>> bool(np.allclose(sum(parts.values()), total))
        True
        """
        t, rpm, air, feed = self._drivers(time_s, spindle_rpm, ambient_C, feed_mm_min)
        self._check_drivers(t, rpm, air, feed, run)
        dt = float(t[1] - t[0])
        T0 = self._initial_state(initial, rpm[0], feed[0], air[0], run)
        with single_threaded_blas():
            if not by_source:
                return self._integrate(rpm, feed, air, dt, T0, run=run)
            zero_air = np.zeros_like(air)
            zero_T = np.zeros_like(T0)
            parts = {"air": ((), air, T0)}
            for source in self.SOURCES[1:]:
                if source == "feed" and not (self._feed_heated() and np.any(feed != 0)):
                    continue
                parts[source] = ((source,), zero_air, zero_T)
            T = self._integrate_parts(rpm, feed, dt, list(parts.values()), run)
        return {source: T[:, j] for j, source in enumerate(parts)}

    def read(
        self, node_T, ambient_C, channels=None, *, sample_period_s, reference=None
    ):
        """Channels read from node temperatures, without noise.

        Parameters
        ----------
        node_T : array-like of shape (n, n_nodes) or DataFrame
            Node temperatures, e.g. from :meth:`response` (columns in the
            order of ``spec.nodes``); a DataFrame (e.g. the states of
            :meth:`simulate` with ``return_states=True``) is read by column
            name, and must hold every node.
        ambient_C : array-like of shape (n,)
            Workshop air (sensors with a ``"room"`` weight read it; pass zeros
            for a heat part of :meth:`response`).
        channels : str or sequence of str, optional
            Sensor and displacement columns; default all sensors, then all
            displacements.
        sample_period_s : float
            Sample period (s), for the sensors' lag (``sensor_lag``).
        reference : array-like of shape (n_nodes,), optional
            Node temperatures at which displacements are zero; default the
            first row of ``node_T``.

        Returns
        -------
        ndarray of shape (n, n_channels)
            Temperatures (°C) and displacements (µm).
        """
        n_nodes = len(self.spec.nodes)
        if isinstance(node_T, pd.DataFrame):
            missing = [n for n in self.spec.nodes if n not in node_T.columns]
            if missing:
                raise ValueError(
                    f"node_T (a DataFrame, read by column name) has no column "
                    f"for node(s) {missing}; the nodes are {list(self.spec.nodes)}."
                )
            node_T = node_T[list(self.spec.nodes)]
        T = np.asarray(node_T, dtype=float)
        if T.ndim != 2 or T.shape[1] != n_nodes or T.shape[0] == 0:
            raise ValueError(
                f"node_T must have shape (n, {n_nodes}) with n >= 1 (one column "
                f"per node), got {T.shape}."
            )
        air = np.asarray(ambient_C, dtype=float)
        if air.shape != (T.shape[0],):
            raise ValueError(
                f"ambient_C has shape {air.shape}, expected ({T.shape[0]},)."
            )
        for what, values in (("node_T", T), ("ambient_C", air)):
            bad = ~np.isfinite(values.reshape(len(values), -1)).all(axis=1)
            if bad.any():
                row = int(np.flatnonzero(bad)[0])
                raise ValueError(
                    f"{what} holds a value that is not finite (NaN or inf) in "
                    f"row {row}; read needs finite temperatures."
                )
        _check_number(sample_period_s, "sample_period_s", positive=True)
        if channels is None:
            channels = self.sensors + self.targets
        else:
            channels = [channels] if isinstance(channels, str) else list(channels)
        temp, names, disp, rows = self._read_plan(channels)
        out = np.empty((T.shape[0], len(channels)))
        if names:
            out[:, temp] = self._sensor_values(T, air, float(sample_period_s), names)
        if rows:
            M = self._displacement_array()
            ref = T[0] if reference is None else np.asarray(reference, dtype=float)
            if ref.shape != (n_nodes,):
                raise ValueError(
                    f"reference must be {n_nodes} node temperatures (one per "
                    f"node), got shape {ref.shape}."
                )
            out[:, disp] = (T - ref) @ M[rows].T
        return out

    def _read_plan(self, channels):
        """Where :meth:`read` puts each of ``channels``: the columns and
        names of the sensors, the columns of the displacements and their
        rows of the thermo-elastic map; cached per channel list."""
        key = ("read", tuple(channels))
        if key not in self._cache:
            sensors, targets = set(self.sensors), list(self.targets)
            bad = [c for c in channels if c not in sensors and c not in targets]
            if bad:
                raise ValueError(
                    f"The machine does not predict {bad}; its channels are its "
                    f"sensors ({len(sensors)}) and {targets}."
                )
            temp = [i for i, c in enumerate(channels) if c in sensors]
            disp = [i for i, c in enumerate(channels) if c in targets]
            self._cache[key] = (
                _as_slice(temp),
                [channels[i] for i in temp],
                _as_slice(disp),
                [targets.index(channels[i]) for i in disp],
            )
        return self._cache[key]

    @staticmethod
    def _drivers(time_s, spindle_rpm, ambient_C, feed_mm_min):
        t = _float_array(time_s, "time_s")
        feed = (
            np.zeros_like(t)
            if feed_mm_min is None
            else _float_array(feed_mm_min, "feed_mm_min")
        )
        return (
            t,
            _float_array(spindle_rpm, "spindle_rpm"),
            _float_array(ambient_C, "ambient_C"),
            feed,
        )

    # --- heat and displacement ----------------------------------------------

    def _heat(self, rpm, feed, sources=("spindle", "feed")):
        """Heat inputs (W), shape (n_steps, n_heated), and the heated nodes.

        ``sources`` selects the spindle losses (``"spindle"``: bearings,
        motor, belt, cutting; or ``"bearing"`` and ``"drive"`` (motor, belt
        and cutting) separately) and/or the feed losses (``"feed"``: ball screw,
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
        if "spindle" in sources or "drive" in sources:
            if p.get("q.cutting_W", 0.0):
                cols[spec.cutting] = (
                    cols.get(spec.cutting, 0.0) + p["q.cutting_W"] * running
                )
        for source, node in spec.custom_heat.items():
            spindle, by_feed = self._custom_power(source, krpm, running, feed)
            if "spindle" in sources or "drive" in sources:
                cols[node] = cols.get(node, 0.0) + spindle
            if "feed" in sources and by_feed is not None:
                cols[node] = cols.get(node, 0.0) + by_feed
        for effect in self._active():
            effect.heat(self, p, rpm, feed, cols, sources)
        nodes = list(cols)
        n = np.shape(rpm)[0]
        if not nodes:
            return np.zeros((n, 0)), []
        Q = np.column_stack([np.broadcast_to(cols[k], (n,)) for k in nodes])
        return Q, [self._index[k] for k in nodes]

    def _custom_power(self, source, krpm, running, feed):
        """Heat (W) of the custom source ``source`` (see ``MachineSpec``):
        the part that follows the spindle (and the constant part), and the
        part that follows |feed| (None without a ``W_per_m_min``)."""
        p = self._params

        def q(f, default=0.0):
            return p.get(f"q.{source}.{f}", default)

        power = q("W_constant") + q("W") * running
        if q("W_at_1000_rpm"):
            power = power + q("W_at_1000_rpm") * krpm ** q("alpha", 1.5)
        power = power + q("W_per_1000_rpm") * krpm
        by_feed = None
        if q("W_per_m_min"):
            by_feed = q("W_per_m_min") * np.abs(np.asarray(feed, float)) / 1e3
        return power, by_feed

    def _feed_heated(self):
        """Whether any heat follows the feed: the ball screw of
        ``feed_heating``, or a custom source with a ``W_per_m_min``."""
        if self._on("feed_heating") and self.spec.screw_nodes:
            return True
        return any(
            self._params.get(f"q.{source}.W_per_m_min", 0.0)
            for source in self.spec.custom_heat
        )

    def displacement_matrix(self):
        """Thermo-elastic map, DataFrame (axes x nodes) of µm per K of node rise.

        Growth of bodies in series and bending from gradients appear as
        coefficients on node temperatures. The ball screw's growth counts up to
        the measuring position (``feed_heating.measure_at``), the
        position-dependent term. The tool's growth is the tool node's
        coefficients (``k.<axis>.<tool>``), on or off the ``tool_growth``
        effect: that effect changes how the tool is cooled (its convection
        while turning), not this map.
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
        for name, effect in EFFECTS.items():
            if self._on(name):
                effect.displacement(self, p, M)
        self._cache["displacement"] = M
        return M

    @with_single_threaded_blas
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
        the squared differences with the measured channels, each scaled by
        its standard deviation, but by no less than a quarter of the root
        mean square standard deviation of its kind (displacements,
        temperatures): a channel that barely moves weighs by its error in µm
        (or °C), not as much as one carrying the signal. Every channel is
        compared as its change since the start of each run (a temperature
        sensor's calibration offset does not bend the fit).

        Parameters
        ----------
        runs : DataFrame
            Measured run table(s).
        params : str or sequence of str
            Names from :meth:`parameter_table`, e.g. ``["q.bearing_W",
            "k.y.carrier3"]``.
        bounds : dict or sequence of (low, high), optional
            Default: a tenth to ten times each current value, within the
            parameter's valid range (a fraction in [0, 1], ``alpha`` in
            [0.5, 3] ...; see :func:`~skthermal.simulate._spec.parameter_range`).
            Given bounds must lie inside the valid range (an error names
            the parameter).
        channels : sequence of str, optional
            Columns to fit, each once; default every displacement the machine
            predicts that the runs hold (with a warning naming those they
            lack). Any of the machine's temperature columns may be added.
        initial : as in :meth:`simulate_drivers`, "measured" or "auto", \
                default="ambient"
            The machine's state at the start of every run. ``"ambient"``:
            soaked at the run's first air reading. ``"measured"`` estimates
            each run's from its own first readings (its first
            :data:`FIRST_READINGS` samples of every sensor of the machine
            the runs hold; :meth:`initial_from_readings`, again for every
            trial machine of the fit), for runs that start warm; it needs a
            sensor on the structure (:attr:`structure_sensors`). ``"auto"``:
            ``"measured"`` when the runs hold such a sensor, else
            ``"ambient"`` (the default of ``skthermal.gap.diagnose``), and a
            run whose first readings a soaked machine explains as well (within
            the sensors' offsets and noise of the air) starts soaked
            (:meth:`initial_from_readings` with ``p_soaked`` of
            :attr:`SOAKED_PRIOR`). Runs that start warm, calibrated from the
            air, take their warm start's decay as physics: pass ``"auto"`` or
            ``"measured"`` for them. On soaked runs ``"measured"`` costs: the
            sensors' calibration offsets are read partly as temperatures.
        **least_squares_kw
            Passed to ``scipy.optimize.least_squares`` (e.g. ``max_nfev``); a
            keyword it does not take is a TypeError naming it.

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

    def initial_from_readings(
        self,
        readings,
        ambient_C,
        *,
        time_s=None,
        spindle_rpm=None,
        feed_mm_min=None,
        max_rpm=6000.0,
        max_feed_mm_min=0.0,
        p_soaked=0.0,
        warm=None,
        run="run1",
    ):
        """Node temperatures that match the first readings of a run.

        A run that starts warm from earlier work (or while the machine still
        follows a change of the air) does not start in equilibrium with its
        first air reading. Its initial node temperatures are estimated from
        the temperature sensors at the start, as the most probable state
        given the readings: a Gaussian prior over the states the machine
        itself passes through (the node temperatures above the air during
        two days of random duty, spindle blocks up to ``max_rpm`` and feed
        up to ``max_feed_mm_min`` alternating with rests, scaled to
        :data:`PRIOR_RISE_K` per node, plus the whole machine away from the
        air by :data:`PRIOR_AIR_K`), and readings uncertain by the sensors'
        calibration offset, noise and quantisation (``sensor.*``). Nodes no
        sensor reads take the temperatures such states give them beside the
        ones read; a sensor's calibration offset is taken as partly a
        temperature.

        Parameters
        ----------
        readings : mapping or DataFrame
            Sensor column -> temperature (°C) at the start of the run, or
            the run's first few samples of it (a sequence, or a DataFrame of
            the first rows), for any of :attr:`sensors` (at least one).
            Samples are read at the first one's time from a straight line
            through them, which averages their noise and follows the
            machine's drift over them.
        ambient_C : float or sequence
            The workshop air at the start (°C), or its first samples.
        time_s : sequence, optional
            Times of the samples (default: evenly spaced).
        spindle_rpm, feed_mm_min : sequence, optional
            The drivers over the samples (with ``time_s``): what the machine
            warms by during them (simulated from soaked at the air's
            samples) is taken out before the line is drawn, so that a
            spindle started at the first sample does not tilt it (a bearing
            sensor warms fast).
        max_rpm, max_feed_mm_min : float, default=6000.0 and 0.0
            The fastest spindle speed and feed of the machine's duty (its
            range, not this run's: they set the shapes of the warm states of
            the prior, not their size; with neither, only the air moves it).
        p_soaked : float in [0, 1), default=0.0
            Prior probability that the machine is soaked at the start (every
            node at the air), beside the warm states: the estimate is then
            the posterior mean of that mixture, so readings that a soaked
            machine explains as well as a warm one (within the sensors'
            offsets and noise of the air) leave it at the air instead of
            reading the sensors' calibration offsets as warmth. Test runs
            often start soaked; ``calibrate(initial="auto")`` and
            ``skthermal.gap.diagnose(initial="auto")`` take
            :attr:`SOAKED_PRIOR`.
        warm : float in [0, 1], optional
            The probability that the run starts warm, when already worked
            out (:meth:`warm_probability`, e.g. with the machine as given,
            so that every variant of it starts the run alike): used in
            place of the one ``p_soaked`` gives.
        run : label, default="run1"
            Named in error messages and warnings.

        Returns
        -------
        ndarray of shape (n_nodes,)
            Node temperatures (°C) in the order of ``spec.nodes``: an
            ``initial=`` of :meth:`response` and :meth:`simulate_drivers`.
            ``calibrate(initial="measured")`` and
            ``skthermal.gap.diagnose(initial="measured")`` take each run's
            from its own first readings, with the runs' fastest speed and
            feed.

        Examples
        --------
        >>> from skthermal.simulate import ThermalMachine
        >>> rig = ThermalMachine.from_preset("spindle-rig")
        >>> T0 = rig.initial_from_readings({"T1_C": 24.0, "T2_C": 23.5}, 20.0)
        >>> T0.shape, bool(T0.max() > 20.0)
        ((9,), True)
        """
        p_soaked = _check_p_soaked(p_soaked)
        if warm is not None and not 0.0 <= warm <= 1.0:
            raise ValueError(f"warm must be in [0, 1], got {warm!r}.")
        air0, z, S, sigma2, P, W = self._reading_model(
            readings,
            ambient_C,
            time_s,
            spindle_rpm,
            feed_mm_min,
            max_rpm,
            max_feed_mm_min,
            run,
        )
        d = P @ W.T @ np.linalg.solve(S, z)
        if warm is None and p_soaked > 0:
            warm = _warm_probability(z, S, sigma2, p_soaked)
        return air0 + d * (1.0 if warm is None else warm)

    def warm_probability(
        self,
        readings,
        ambient_C,
        *,
        time_s=None,
        spindle_rpm=None,
        feed_mm_min=None,
        max_rpm=6000.0,
        max_feed_mm_min=0.0,
        p_soaked=None,
        run="run1",
    ):
        """Posterior probability that a run starts warm rather than soaked.

        The readings' likelihood under the warm states of
        :meth:`initial_from_readings`'s prior against a soaked machine (every
        node at the air, the readings off by the sensors' offsets and
        noise), with prior probability ``p_soaked`` (default
        :attr:`SOAKED_PRIOR`) of a soaked start. The arguments are those of
        :meth:`initial_from_readings`.

        Examples
        --------
        >>> from skthermal.simulate import ThermalMachine
        >>> rig = ThermalMachine.from_preset("spindle-rig")
        >>> warm = rig.warm_probability({"T1_C": 24.0, "T2_C": 23.5}, 20.0)
        >>> soaked = rig.warm_probability({"T1_C": 20.05, "T2_C": 19.98}, 20.0)
        >>> bool(warm > 0.99), bool(soaked < 0.5)
        (True, True)
        """
        p_soaked = self.SOAKED_PRIOR if p_soaked is None else p_soaked
        p_soaked = _check_p_soaked(p_soaked)
        if p_soaked == 0:
            return 1.0
        _, z, S, sigma2, _, _ = self._reading_model(
            readings,
            ambient_C,
            time_s,
            spindle_rpm,
            feed_mm_min,
            max_rpm,
            max_feed_mm_min,
            run,
        )
        return _warm_probability(z, S, sigma2, p_soaked)

    def _reading_model(
        self,
        readings,
        ambient_C,
        time_s,
        spindle_rpm,
        feed_mm_min,
        max_rpm,
        max_feed_mm_min,
        run,
    ):
        """The first readings and their Gaussian model: the air at the
        start, the readings above what a soaked machine reads ``z``, their
        covariance under the warm states ``S``, the sensors' own variances
        ``sigma2``, the state prior ``P`` and the reading matrix ``W``."""
        where = f"Run {run!r}: "
        if isinstance(readings, pd.DataFrame):
            readings = {c: readings[c].to_numpy() for c in readings.columns}
        readings = dict(readings.items() if hasattr(readings, "items") else readings)
        if not readings:
            raise ValueError(
                f"{where}readings is empty: give the first reading of at least "
                f"one of the machine's sensors ({len(self.sensors)}, e.g. "
                f"{self.sensors[:3]})."
            )
        self._check_sensor_names(readings, f"{where}readings")
        max_rpm = _check_number(max_rpm, "max_rpm", nonnegative=True)
        max_feed = _check_number(max_feed_mm_min, "max_feed_mm_min", nonnegative=True)
        for name, value, limit, unit in (
            ("max_rpm", max_rpm, PLAUSIBLE_RPM, "rpm"),
            ("max_feed_mm_min", max_feed, PLAUSIBLE_FEED_MM_MIN, "mm/min"),
        ):
            if value > limit:
                warnings.warn(
                    f"{name} is {value:g} {unit}, beyond any machine tool's "
                    f"({limit:g} {unit}): check the value and its unit. The "
                    "estimate goes on.",
                    ImplausibleDriverWarning,
                    stacklevel=2,
                )
        names = list(readings)
        t = None if time_s is None else _sample_times(time_s, run)
        air0 = _at_start(ambient_C, t, "ambient_C", run)
        samples = {c: _numbers(readings[c], f"readings[{c!r}]", run) for c in names}
        raw = np.array(
            [_at_start(samples[c], t, f"readings[{c!r}]", run) for c in names]
        )
        _check_span(raw - air0, names, air0, where)
        _warn_unlikely(raw - air0, names, air0, where)
        heating = {}
        if spindle_rpm is not None:
            heating = self._heating(names, ambient_C, t, spindle_rpm, feed_mm_min, run)
        m = np.array(
            [
                _at_start(samples[c] - heating[c], t, f"readings[{c!r}]", run)
                if c in heating
                else raw[i]
                for i, c in enumerate(names)
            ]
        )
        _check_span(
            m - air0,
            names,
            air0,
            where,
            " after taking out what spindle_rpm and feed_mm_min warm the "
            "machine by over the samples: check their values and units",
        )
        n = len(self.spec.nodes)
        # The readings are affine in the node temperatures: one node at a
        # time (single rows: a sensor's lag does not act on one sample).
        r = self.read(np.full((1, n), air0), [air0], names, sample_period_s=1.0)[0]
        W = np.column_stack(
            [
                self.read(np.eye(n)[[j]], [0.0], names, sample_period_s=1.0)[0]
                for j in range(n)
            ]
        )
        P = self._state_prior(max_rpm, max_feed)
        # Every sensor's own figures (else the machine's).
        own = {s.name: k for k, s in enumerate(self.spec.sensors)}
        pick = [own[c] for c in names]
        sigma2 = np.maximum(
            self._sensor_numbers("offset_C")[pick] ** 2
            + self._sensor_numbers("noise_C")[pick] ** 2
            + self._sensor_numbers("quantization_C")[pick] ** 2 / 12.0,
            READING_FLOOR_C**2,
        )
        z = m - r
        S = W @ P @ W.T + np.diag(sigma2)
        return air0, z, S, sigma2, P, W

    def _heating(self, names, ambient_C, time_s, spindle_rpm, feed_mm_min, run):
        """How much the sensors ``names`` warm over the samples of
        :meth:`initial_from_readings` from the drivers, started soaked:
        ``{sensor: change since the first sample}``."""
        rpm = _float_array(spindle_rpm, "spindle_rpm")
        if rpm.size < 2:
            return {}
        if time_s is None:
            raise ValueError(
                f"Run {run!r}: spindle_rpm needs time_s: the times of the "
                "samples, to simulate what the drivers warm the machine by "
                "over them."
            )
        t = time_s
        air = _float_array(ambient_C, "ambient_C")
        if air.ndim == 0:
            air = np.full(t.shape, float(air))
        feed = None if feed_mm_min is None else _float_array(feed_mm_min, "feed_mm_min")
        T = self.response(t, rpm, air, feed, run=run)
        values = self.read(T, air, names, sample_period_s=float(np.median(np.diff(t))))
        return dict(zip(names, (values - values[0]).T, strict=True))

    def _state_prior(self, max_rpm, max_feed):
        """Second moments (K^2) of the node temperatures above the air
        (:meth:`initial_from_readings`), cached per speed and feed."""
        key = ("state_prior", max_rpm, max_feed)
        if key in self._cache:
            return self._cache[key]
        rng = np.random.default_rng(0)
        dt = 60.0
        steps = int(PRIOR_HOURS * 3600 / dt)
        rpm, feed = np.zeros(steps), np.zeros(steps)
        i, on = 0, True
        while i < steps:
            k = int(rng.uniform(25, 100) if on else rng.uniform(15, 70))
            if on:
                rpm[i : i + k] = rng.uniform(0.1, 1.0) * max_rpm
                if rng.random() < 0.5:
                    feed[i : i + k] = rng.uniform(0.2, 1.0) * max_feed
            i, on = i + k, not on
        t = np.arange(steps) * dt
        with warnings.catch_warnings():
            # initial_from_readings has warned of an implausible max_rpm.
            warnings.simplefilter("ignore", ImplausibleDriverWarning)
            rise = self.response(t, rpm, np.zeros(steps), feed, initial=0.0)[::10]
        P = rise.T @ rise / rise.shape[0]
        mean_var = float(np.trace(P)) / P.shape[0]
        if mean_var > 0:
            P *= PRIOR_RISE_K**2 / mean_var
        P = P + PRIOR_AIR_K**2 * np.ones_like(P)
        self._cache[key] = P
        return P

    def _initial_state(self, initial, rpm0, feed0, air0, run=None):
        n = len(self.spec.nodes)
        if initial is None or (isinstance(initial, str) and initial == "ambient"):
            return np.full(n, air0)
        if isinstance(initial, str) and initial == "steady":
            return self._steady_state(rpm0, feed0, air0, run)
        if isinstance(initial, str):
            raise ValueError(
                f"initial={initial!r}: give 'ambient', 'steady', a temperature, "
                "a dict node -> °C or one temperature per node"
                + (
                    f" (initial={initial!r} is an option of calibrate and of "
                    "skthermal.gap.diagnose, which read each run's first "
                    "readings; here give initial=initial_from_readings(...))."
                    if initial in ("measured", "auto")
                    else "."
                )
            )
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
        T0 = _float_array(initial, "initial")
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
        check_run_label(run)
        t, rpm, air, feed = self._drivers(time_s, spindle_rpm, ambient_C, feed_mm_min)
        self._check_drivers(t, rpm, air, feed, run)
        return self._sampled_run(
            t,
            rpm,
            air,
            feed,
            None,
            run=run,
            initial=initial,
            noise=noise,
            random_state=random_state,
            return_states=return_states,
            strain_gauges=strain_gauges,
        )

    def _sampled_run(
        self,
        t,
        rpm,
        air,
        feed,
        fine,
        *,
        run,
        initial,
        noise,
        random_state,
        return_states,
        strain_gauges,
    ):
        """The run table of checked drivers sampled at ``t``. ``fine``:
        None (the speed and feed held over every sample), or ``(times, rpm,
        feed)``: integration times that hold the samples' (and where the
        drivers change between samples), with the speed and feed in force
        from each (the air linear between the samples); the network is
        then read at the samples."""
        rng = check_random_state(random_state)
        dt = float(t[1] - t[0])
        T0 = self._initial_state(initial, rpm[0], feed[0], air[0], run)
        with single_threaded_blas():
            if fine is None:
                T = self._integrate(rpm, feed, air, dt, T0, run=run)
            else:
                times, rpm_f, feed_f = fine
                air_f = np.interp(times, t, air)
                # Whole sample periods exactly dt (one stretch, one set of
                # gains), not differences of times rounded apart.
                steps = np.diff(times)
                steps[np.abs(steps - dt) <= 1e-9 * dt] = dt
                T = self._integrate(rpm_f, feed_f, air_f, steps, T0, run=run)
                T = T[np.searchsorted(times, t)]
            _warn_hot(T, air, self.spec.nodes, run)
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
            Period of the table's samples. The heat follows the duty cycle's
            segments exactly, whatever their lengths: a segment that starts
            between two samples starts there (the network is integrated to
            that time, then on), and the network is read at the samples.
            The table's ``spindle_rpm`` and ``feed_mm_min`` are the values in
            force at each sample time, as a logger records them.
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
        n = int(round(duty.duration_s / dt)) if duty.duration_s / dt < 1e18 else 0
        if not 0 < n <= MAX_SAMPLES and duty.duration_s >= dt:
            raise ValueError(
                f"The duty cycle lasts {duty.duration_s:g} s "
                f"({duty.duration_s / 86400:.4g} days): sampled every {dt:g} s "
                f"that is {duty.duration_s / dt:.4g} samples, more than skthermal "
                f"simulates in one run ({MAX_SAMPLES:,}, for memory). Durations "
                "are in seconds: check their unit, or sample less often "
                "(sample_period_s; --sample-period on the command line)."
            )
        if duty.duration_s > LONGEST_TEST_S:
            warnings.warn(
                f"The duty cycle lasts {duty.duration_s / 86400:.4g} days: thermal "
                "tests last hours to weeks. Durations are in seconds: are they in "
                "milliseconds? The simulation goes on.",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
        if n < 1:
            raise ValueError(
                f"The duty cycle ({duty.duration_s:g} s) is shorter than one sample "
                f"period ({dt:g} s)."
            )
        rng = check_random_state(random_state)
        t = np.arange(n + 1) * dt
        rpm, feed = duty.sample(t)
        air = ambient.sample(t, random_state=rng)
        check_run_label(run)
        self._check_drivers(t, rpm, air, feed, run)
        fine = None
        between = _starts_between(duty, dt, n)
        if between.size:
            # Integrate from every sample and every segment start between
            # two; each step's speed and feed are those in force at its
            # middle.
            times = np.union1d(t, between)
            rpm_f, feed_f = duty.sample(times + 0.5 * np.diff(times, append=times[-1]))
            fine = (times, rpm_f, feed_f)
        return self._sampled_run(
            t,
            rpm,
            air,
            feed,
            fine,
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
                    f"{name} must be a flat sequence of one value per time, "
                    f"shape ({n},), for the {n} times of run {run!r}; got "
                    f"shape {a.shape}."
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
        bad = np.flatnonzero(air <= ABSOLUTE_ZERO_C)
        if bad.size:
            raise ValueError(
                f"ambient_C must be a temperature in °C, above {ABSOLUTE_ZERO_C:g}: "
                f"{air[bad[0]]:g} in run {run!r} at row {bad[0]}."
            )
        for name, a, limit, unit in (
            ("spindle_rpm", rpm, PLAUSIBLE_RPM, "rpm"),
            ("feed_mm_min", np.abs(feed), PLAUSIBLE_FEED_MM_MIN, "mm/min"),
        ):
            bad = np.flatnonzero(a > limit)
            if bad.size:
                warnings.warn(
                    f"{name} is {a[bad[0]]:g} {unit} in run {run!r} at row "
                    f"{bad[0]} ({bad.size} such row(s)), beyond any machine "
                    f"tool's ({limit:g} {unit}): check the value and its unit. "
                    "The simulation goes on.",
                    ImplausibleDriverWarning,
                    stacklevel=3,
                )
        steps = np.diff(t)
        bad = np.flatnonzero(steps <= 0)
        if bad.size:
            raise ValueError(
                f"time_s must increase strictly: run {run!r}, row {bad[0] + 1} "
                f"(time_s {t[bad[0] + 1]:g} after {t[bad[0]]:g})."
            )
        if np.ptp(steps) > 1e-6 * steps.mean():
            period = _jittered_period(t)
            fix = (
                "Resample it to a constant period first."
                if period is None
                else "Resample it to a constant period first, or, where the "
                "logger's clock only jitters, round time_s to its period "
                f"(time_s = round(time_s / {period:.6g}) * {period:.6g}, "
                "which makes this run regular)."
            )
            raise ValueError(
                f"Run {run!r} is not regularly sampled (steps from "
                f"{steps.min():.9g} to {steps.max():.9g} s); the simulation "
                f"runs at one period. {fix}"
            )

    def _integrate(self, rpm, feed, air, dt, T0, sources=("spindle", "feed"), run=None):
        return self._integrate_parts(rpm, feed, dt, [(sources, air, T0)], run)[:, 0]

    def _integrate_parts(self, rpm, feed, dt, parts, run=None):
        """Node temperatures of several responses of the network at once,
        shape (n, k, n_nodes): ``parts`` holds ``(sources, air, T0)`` of each
        (the heat sources of :meth:`_heat`, the driving air and the initial
        state); they advance together, one recursion per stretch of
        :meth:`_segments`. ``dt``: the step length, or one per step."""
        n_steps = rpm.shape[0] - 1
        steps = np.broadcast_to(np.asarray(dt, dtype=float), (n_steps,))
        heats = [
            self._checked_heat(rpm[:-1], feed[:-1], sources, run)
            for sources, _, _ in parts
        ]
        nodes = sorted({c for _, cols in heats for c in cols})
        pos = {c: i for i, c in enumerate(nodes)}
        Q = np.zeros((len(parts), n_steps, len(nodes)))
        for j, (q, cols) in enumerate(heats):
            Q[j][:, [pos[c] for c in cols]] = q
        air = np.stack([a for _, a, _ in parts])
        T = np.empty((n_steps + 1, len(parts), len(self.spec.nodes)))
        T[0] = np.stack([T0 for _, _, T0 in parts])
        try:
            with np.errstate(over="raise", invalid="raise"):
                for a, b, (modal, to_room) in self._segments(rpm[:-1], steps):
                    T[a : b + 1] = modal.step(
                        T[a], Q[:, a:b], to_room, air[:, a : b + 1], steps[a], nodes
                    )
        except (FloatingPointError, _StiffNetwork):
            T[:] = np.nan
        if not np.all(np.isfinite(T)):
            raise ValueError(self._stiff_message(rpm[:-1], run))
        return T

    def _segments(self, rpm, steps):
        """``(start, stop, modal system)`` of the stretches of steps over
        which the network stays the same (it changes with the speed only
        when an effect makes the convection follow it) and the steps
        (``steps``, their lengths) are equal, none longer than
        ``SEGMENT_STEPS``."""
        if rpm.shape[0] == 0:
            return []
        change = np.flatnonzero((np.diff(rpm) != 0) | (np.diff(steps) != 0)) + 1
        starts = np.concatenate(([0], change))
        systems = [self._modal(rpm[a]) for a in starts]
        keep = [0] + [
            k
            for k in range(1, len(starts))
            if systems[k] is not systems[k - 1]
            or steps[starts[k]] != steps[starts[k - 1]]
        ]
        stops = [*starts[keep[1:]], rpm.shape[0]]
        # Long stretches go in pieces that stay in the processor's cache
        # (each piece starts from the state the previous one ends in).
        return [
            (a, min(a + SEGMENT_STEPS, int(b)), systems[k])
            for k, b in zip(keep, stops, strict=True)
            for a in range(int(starts[k]), int(b), SEGMENT_STEPS)
        ]

    def _checked_heat(self, rpm, feed, sources=("spindle", "feed"), run=None):
        """:meth:`_heat`, with an error naming the drivers where it overflows."""
        with np.errstate(over="ignore", invalid="ignore"):
            Q, cols = self._heat(rpm, feed, sources)
        bad = np.flatnonzero(~np.all(np.isfinite(Q), axis=1))
        if bad.size:
            where = f"row {bad[0]}" if run is None else f"run {run!r}, row {bad[0]}"
            raise ValueError(
                f"The heat input is not finite (it overflows) at {where} "
                f"(spindle_rpm {rpm[bad[0]]:g}, feed_mm_min {feed[bad[0]]:g}): "
                "the drivers lie far outside any plausible range (a spindle "
                "turns at up to some 10^5 rpm)."
            )
        return Q, cols

    def _steady_state(self, rpm0, feed0, air0, run=None):
        """Node temperatures in equilibrium with constant drivers
        (``initial="steady"``): ``K T = h_room T_air + Q``."""
        Q, cols = self._checked_heat(np.array([rpm0]), np.array([feed0]), run=run)
        T0 = None
        if self._resolvable(rpm0):
            K, to_room = self._network(float(rpm0))
            rhs = to_room * air0
            np.add.at(rhs, cols, Q[0])
            try:
                with np.errstate(over="raise", invalid="raise", divide="raise"):
                    T0 = np.linalg.solve(K, rhs)
            except (np.linalg.LinAlgError, FloatingPointError):
                T0 = None
        if T0 is None or not np.all(np.isfinite(T0)):
            message = self._stiff_message(np.array([rpm0]), run)
            raise ValueError(
                "initial='steady': the steady state of the first sample's "
                f"drivers (spindle_rpm {rpm0:g}, feed_mm_min {feed0:g}) cannot "
                f"be computed. {message}"
            )
        return T0

    def _stiff_message(self, rpm, run=None):
        """Why the node temperatures are not finite, naming the suspects:
        the spindle speed when the network is sound at rest and the speed
        beyond any spindle's, else the parameters."""
        p, spec = self._params, self.spec
        row = int(np.argmax(rpm))
        fastest = float(rpm[row])
        if fastest > PLAUSIBLE_RPM and self._resolvable(0.0):
            where = f"run {run!r}, row {row}" if run is not None else f"row {row}"
            grow = [e for e in ("speed_convection", "tool_growth") if self._on(e)]
            why = (
                f"the convection that grows with speed ({', '.join(grow)}) and "
                "the speed-driven heat make the network too stiff or too hot "
                "for floating point"
                if grow
                else "the speed-driven heat is too large for floating point"
            )
            return (
                f"The node temperatures are not finite: the spindle speed "
                f"{fastest:g} rpm (spindle_rpm, {where}) lies far outside any "
                f"plausible range (a spindle turns at up to some "
                f"{PLAUSIBLE_RPM:.0e} rpm); {why}, while the machine at rest "
                "computes. Check the speed's value and unit (rpm)."
            )
        C = {f"C.{n}": p[f"C.{n}"] for n in spec.nodes}
        G = {f"G.{a}-{b}": p[f"G.{a}-{b}"] for a, b in spec.edges}
        G.update({f"hA.{n}": p.get(f"hA.{n}", 0.0) for n in spec.nodes})
        small = min(C, key=C.get)
        big = max(C, key=C.get)
        large = max(G, key=G.get)
        # The extremes of the network need not be the cause (a 40 W/K
        # enclosure is the largest conductance beside a 1 mJ/K bead on
        # 1 W/K): name the nodes of the fastest and slowest local time
        # constants, with the capacity and conductances that set them.
        with np.errstate(all="ignore"):
            tau = self.node_time_constants(fastest).to_numpy()
        order = np.where(np.isnan(tau), np.inf, tau)
        quick, slow = int(np.argmin(order)), int(np.argmax(order))

        def node(i, which):
            name = spec.nodes[i]
            cap = f"C.{name}"
            kind = {small: "smallest capacity", big: "largest capacity"}
            parts = [
                f"{'largest conductance ' if k == large else ''}{k} = {v:g} W/K"
                for k, v in self._node_conductances(i, fastest)
            ]
            if len(parts) > 3:
                parts = [*parts[:3], f"{len(parts) - 3} more"]
            over = " + ".join(parts) if parts else "no conductance"
            return (
                f"{which} node {name!r}: time constant {tau[i]:.3g} s = "
                f"{kind.get(cap, 'capacity')} {cap} = {C[cap]:g} J/K over "
                f"{over}"
            )

        return (
            "The node temperatures are not finite, or rounding would dominate "
            "them: the network is too stiff or too large for floating point "
            f"(at the fastest speed {fastest:g} rpm, its time constants span "
            f"more than {STIFFNESS_LIMIT:.0e} to 1; {node(quick, 'fastest')}; "
            f"{node(slow, 'slowest')}). Bring the parameters and drivers to "
            "physical values: a larger capacity or smaller conductances of the "
            "fastest node, a smaller capacity or larger conductances of the "
            "slowest."
        )

    def _node_conductances(self, i, rpm):
        """``(parameter, W/K)`` of the conductances of node ``i`` (its
        diagonal of :meth:`network` at ``rpm``, the sum its local time
        constant divides by), largest first: its links, its convection and,
        for the enclosure, the convection of the nodes inside it."""
        with np.errstate(all="ignore"):
            items = [
                (name, float(g))
                for name, a, b, g in self._conductances(float(rpm))
                if i in (a, b) and g > 0
            ]
        return sorted(items, key=lambda kv: -kv[1])

    def _quantise(self, x, step=None):
        """Round to the quantisation step (per column when ``step`` is given)."""
        q = self._params["sensor.quantization_C"] if step is None else step
        q = np.asarray(q, dtype=float)
        safe = np.where(q > 0, q, 1.0)
        # A multiple of a decimal step such as 0.01 is written as the
        # logger writes it (20.08, not 20.080000000000002): rounded to the
        # decimals the step itself has, which changes no binary step (0.125).
        decimals = _step_decimals(safe)
        steps = np.round(x / safe) * safe
        if decimals.ndim == 0:
            if decimals >= 0:
                steps = np.round(steps, int(decimals))
        else:
            for d in np.unique(decimals[decimals >= 0]):
                cols = decimals == d
                steps[..., cols] = np.round(steps[..., cols], int(d))
        return np.where(q > 0, steps, x)

    def _sensor_numbers(self, field):
        """Per-sensor noise figure ``field``: its own, or the machine's."""
        shared = self._params[f"sensor.{field}"]
        return np.array(
            [
                shared if getattr(s, field) is None else getattr(s, field)
                for s in self.spec.sensors
            ]
        )

    def _sensor_matrix(self, names):
        """Weights (sensors x nodes + room) and the lagged mask, cached."""
        key = ("sensors", tuple(names))
        if key not in self._cache:
            index = dict(self._index)
            index[ROOM] = len(self.spec.nodes)
            by_name = {s.name: s for s in self.spec.sensors}
            sensors = [by_name[n] for n in names]
            W = _weights_matrix(self.spec, index, [s.weights for s in sensors])
            lagged = np.array([s.kind == "surface" for s in sensors], dtype=bool)
            self._cache[key] = (W, lagged)
        return self._cache[key]

    def _sensor_values(self, T, air, dt, names):
        W, lagged = self._sensor_matrix(names)
        x = T @ W[:, :-1].T + np.outer(air, W[:, -1])
        for effect in self._active():
            x = effect.read(self, self._params, x, lagged, dt)
        return x

    def _read_sensors(self, T, air, t, dt, noise, rng):
        p = self._params
        x = self._sensor_values(T, air, dt, self.sensors)
        if not noise:
            return x
        # Calibration offsets belong to the sensor, not the run: the same
        # sensor reads the same offset in every run of the machine.
        x = x + sensor_draws(self, "") * self._sensor_numbers("offset_C")
        for effect in self._active():
            x = effect.noise(self, p, x, t, dt, rng)
        x = x + rng.normal(0.0, 1.0, x.shape) * self._sensor_numbers("noise_C")
        return self._quantise(x, self._sensor_numbers("quantization_C"))


def _step_decimals(step):
    """The decimals of each positive ``step`` (0.01 -> 2, 0.125 -> 3, 5 -> 0),
    -1 where it has more than 12 (1/3)."""
    step = np.asarray(step, dtype=float)
    out = np.full(step.shape, -1)
    for d in range(12, -1, -1):
        exact = np.abs(np.round(step, d) - step) <= 1e-9 * step
        out = np.where(exact, d, out)
    return out


# calibrate scales a channel by no less than this share of the root mean
# square spread of the channels of its kind.
CHANNEL_SCALE_FLOOR = 0.25


def _starts_between(duty, dt, n):
    """Times (s) at which a segment of ``duty`` starts between two of the
    ``n + 1`` samples ``0, dt, ...`` (a start within 1e-9 of a sample's
    time is on it)."""
    starts = np.cumsum([seg.duration_s for seg in duty.segments])[:-1]
    off = np.abs(starts / dt - np.round(starts / dt)) > 1e-9
    return starts[off & (starts > 0) & (starts < n * dt)]


def _as_slice(index):
    """``index`` (a list of column numbers) as a slice when they follow
    one another (a cheaper view), else as it is."""
    if index and index == list(range(index[0], index[-1] + 1)):
        return slice(index[0], index[-1] + 1)
    return index


def _finite(column):
    """Whether a run-table column holds a finite number on every row."""
    values = pd.to_numeric(column, errors="coerce").to_numpy(float)
    return bool(np.all(np.isfinite(values)))


def _run_drivers(frame, run):
    """Driver arrays of one run of a run table, with clear errors."""
    for col in ("time_s", "spindle_rpm", "ambient_C"):
        if col not in frame.columns:
            raise ValueError(
                f"Run {run!r} has no {col!r} column; simulating a measured run "
                "needs time_s, spindle_rpm and ambient_C."
            )
        if is_clock_dtype(frame[col].dtype):
            raise ValueError(
                f"{col} of run {run!r} holds {frame[col].dtype} values; it must "
                "hold numbers (time_s: the seconds since the start of the run)."
            )
    feed = frame["feed_mm_min"].to_numpy(float) if "feed_mm_min" in frame else None
    return (
        frame["time_s"].to_numpy(float),
        frame["spindle_rpm"].to_numpy(float),
        frame["ambient_C"].to_numpy(float),
        feed,
    )


def _check_bounds(bounds, params):
    """Low and high bounds (arrays) of ``calibrate``'s ``bounds=``, checked:
    pairs of numbers, low below high, inside each parameter's valid range
    (:func:`~skthermal.simulate._spec.parameter_range`)."""
    if isinstance(bounds, dict):
        # A mistyped key first: it is also why an entry is missing.
        extra = [k for k in bounds if k not in params]
        if extra:
            raise ValueError(
                f"bounds names {extra}, not among the parameters to calibrate "
                f"{params}{suggest(str(extra[0]), params)}."
            )
        missing = [k for k in params if k not in bounds]
        if missing:
            raise ValueError(f"bounds has no entry for {missing}.")
        pairs = [bounds[k] for k in params]
    elif not isinstance(bounds, list | tuple | np.ndarray):
        raise ValueError(
            "bounds must be a dict {parameter: (low, high)} or a list of "
            f"(low, high) pairs, got {type(bounds).__name__}."
        )
    else:
        pairs = list(bounds)
    if len(pairs) != len(params):
        raise ValueError(
            f"Give one (low, high) pair per parameter ({len(params)}: {params}), "
            f"got {len(pairs)}."
        )
    lo, hi = np.empty(len(params)), np.empty(len(params))
    for i, (k, pair) in enumerate(zip(params, pairs, strict=True)):
        where = f"bounds of {k!r}"
        if not isinstance(pair, list | tuple | np.ndarray) or len(pair) != 2:
            raise ValueError(f"{where} must be a (low, high) pair, got {pair!r}.")
        for j, (side, value) in enumerate((("low", pair[0]), ("high", pair[1]))):
            try:
                value = float(value)
            except OverflowError:
                raise ValueError(
                    f"{where}: {side} must be a finite number (a float reaches "
                    f"about 1.8e308), got {shown(pair[j])}."
                ) from None
            except (TypeError, ValueError):
                value = np.nan
            if np.isnan(value):
                raise ValueError(f"{where}: {side} must be a number, got {pair[j]!r}.")
            (lo, hi)[j][i] = value
        if lo[i] >= hi[i]:
            raise ValueError(
                f"{where}: low must be below high, got ({lo[i]:g}, {hi[i]:g})."
            )
        valid = parameter_range(k)
        if lo[i] not in valid or hi[i] not in valid:
            raise ValueError(
                f"{where}: ({lo[i]:g}, {hi[i]:g}) reach outside its valid "
                f"range {valid} ({parameter_entry(k)}: {k!r} {valid.rule}); "
                "keep the bounds inside it."
            )
    return lo, hi


def _default_bounds(x0, params):
    """``calibrate``'s default bounds: a tenth to ten times each current
    value, within the parameter's valid range."""
    zero = [k for k, v in zip(params, x0, strict=True) if v == 0]
    if zero:
        raise ValueError(
            f"Parameter(s) {zero} are 0: give bounds=, the default range "
            "(a tenth to ten times the current value) needs a non-zero value."
        )
    lo, hi = np.minimum(x0 / 10, x0 * 10), np.maximum(x0 / 10, x0 * 10)
    for i, k in enumerate(params):
        valid = parameter_range(k)
        lo[i], hi[i] = max(lo[i], valid.low), min(hi[i], valid.high)
    return lo, hi


class _Shares:
    """The variables ``least_squares`` moves in ``calibrate``, keeping the
    shares of every effect (:attr:`Effect.shares`, e.g. ``feed_heating``'s
    ``nut_share`` and ``motor_share``) summing to at most 1.

    Bounds are a box and a sum limit is not. A single freed share gets its
    high bound cut to the room the fixed shares leave it. Of two freed
    shares, the first is fitted as it is and the second as its place ``t``
    in [0, 1] between its low bound and the room the first leaves it,
    ``min(high, room - first)``: every point of that box is a valid machine
    inside the bounds, and every valid machine inside the bounds is a point
    of the box. Without shares the variables are the parameters.
    """

    def __init__(self, machine, params, lo, hi):
        self.lo, self.hi = lo.copy(), hi.copy()
        self.groups = []
        current = machine.params
        for effect in EFFECTS.values():
            names = [f"{effect.name}.{k}" for k in effect.shares]
            free = [k for k in names if k in params]
            if not free:
                continue
            if len(free) > 2:  # pragma: no cover - no effect has three shares
                raise NotImplementedError("calibrate fits at most two shares.")
            fixed = {k: current[k] for k in names if k not in params}
            room = 1.0 - sum(fixed.values())
            idx = [params.index(k) for k in free]
            low = float(sum(lo[idx]))
            if low >= room:
                held = " + ".join(f"{k} ({v:g})" for k, v in fixed.items())
                held = f" (1 minus the fixed {held})" if fixed else ""
                start = (
                    f"bounds of {free}: effect {effect.name!r} needs "
                    f"{' + '.join(names)} <= 1, so the fitted ones may sum to "
                    f"at most {room:g}{held}"
                )
                if math.isclose(low, room, rel_tol=1e-12, abs_tol=1e-15):
                    # least_squares needs every low bound below its high one.
                    used = (
                        f"its low bound ({low:g}) already uses all of it: the "
                        "only valid point is the low bound itself"
                        if len(free) == 1
                        else f"their low bounds (sum {low:g}) already use all "
                        "of it: the only valid point is the low bounds "
                        "themselves"
                    )
                    raise ValueError(
                        f"{start}, and {used}, which leaves nothing to fit. "
                        "Lower a low bound."
                    )
                raise ValueError(
                    f"{start}, but their low bounds sum to {low:g}; lower them."
                )
            i = idx[0]
            j = idx[1] if len(idx) == 2 else None
            self.hi[i] = min(self.hi[i], room - (lo[j] if j is not None else 0.0))
            pair = None if j is None else (i, j, room, lo[j], hi[j])
            if j is not None:
                self.lo[j], self.hi[j] = 0.0, 1.0
            self.groups.append((names, dict(zip(free, idx)), fixed, pair))

    def to_params(self, v):
        """Parameter values of the variables ``v``."""
        x = np.array(v, dtype=float)
        for names, free, fixed, pair in self.groups:
            if pair is not None:
                i, j, room, lo_j, hi_j = pair
                x[j] = lo_j + v[j] * (min(hi_j, room - x[i]) - lo_j)
            # The effect's own check sums the shares in this order: keep the
            # last one a rounding below the limit where it lands on it.
            last = list(free.values())[-1]
            while sum(x[free[k]] if k in free else fixed[k] for k in names) > 1:
                x[last] = np.nextafter(x[last], -np.inf)
        return x

    def to_variables(self, x):
        """The variables of the parameter values ``x`` (inside the bounds)."""
        v = np.clip(np.array(x, dtype=float), self.lo, self.hi)
        for *_, pair in self.groups:
            if pair is not None:
                i, j, room, lo_j, hi_j = pair
                span = min(hi_j, room - v[i]) - lo_j
                v[j] = np.clip((x[j] - lo_j) / span, 0.0, 1.0) if span > 0 else 0.0
        return v

    def jacobian(self, v):
        """The derivatives of the parameters by the variables at ``v``."""
        A = np.eye(len(v))
        for *_, pair in self.groups:
            if pair is not None:
                i, j, room, lo_j, hi_j = pair
                A[j, j] = min(hi_j, room - v[i]) - lo_j
                A[j, i] = -v[j] if room - v[i] < hi_j else 0.0
        return A


def _least_squares_keywords(least_squares_kw):
    """Raise a TypeError naming a keyword ``least_squares`` does not take."""
    import inspect

    from scipy.optimize import least_squares

    taken = set(inspect.signature(least_squares).parameters) - {
        "fun",
        "x0",
        "bounds",
        "args",
        "kwargs",
    }
    for key in least_squares_kw:
        if key not in taken:
            raise TypeError(
                f"calibrate() got an unexpected keyword argument {key!r}"
                f"{suggest(key, sorted(taken))}; keywords beyond calibrate's "
                "own go to scipy.optimize.least_squares, which takes "
                f"{sorted(taken)}."
            )


def _numbers(samples, name, run):
    """``samples`` (a number or a sequence of them) as floats; booleans and
    text are refused (``True`` is not 1 °C)."""
    a = np.asarray(samples)
    numeric = a.dtype.kind in "iuf" or (
        a.dtype.kind == "O"
        and not any(isinstance(v, (bool, np.bool_, str, bytes)) for v in a.ravel())
    )
    if not numeric:
        raise ValueError(
            f"Run {run!r}: {name} must be numbers (°C), got {shown(samples)} "
            f"(dtype {a.dtype})."
        )
    return _float_array(a, name)


def _sample_times(time_s, run):
    """The times of a run's first samples as floats: finite, increasing."""
    t = _float_array(time_s, "time_s")
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise ValueError(f"Run {run!r}: time_s is NaN or infinite at sample {bad[0]}.")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        raise ValueError(
            f"Run {run!r}: time_s must increase strictly, got {t[bad[0] + 1]:g} "
            f"after {t[bad[0]]:g} (samples {bad[0]} and {bad[0] + 1})."
        )
    return t


def _at_start(samples, t, name, run):
    """A reading at the time of its first sample: the number itself, or the
    value at ``t[0]`` of the least-squares line through the samples (``t``:
    checked times, :func:`_sample_times`, or None for evenly spaced)."""
    x = _numbers(samples, name, run)
    if x.ndim == 0:
        return _check_number(x, name)
    if x.size == 0 or not np.all(np.isfinite(x)):
        raise ValueError(
            f"Run {run!r}: {name} must be finite numbers (°C), got {shown(samples)}."
        )
    if t is None:
        t = np.arange(x.size, dtype=float)
    if t.shape != x.shape:
        raise ValueError(
            f"Run {run!r}: {name} has {x.size} samples and time_s {t.size}: "
            "give one time per sample."
        )
    if x.size == 1:
        return float(x[0])
    # The least-squares line through the samples, at the first one's time.
    dt = t - t.mean()
    slope = float(dt @ (x - x.mean())) / float(dt @ dt)
    return float(x.mean() - slope * (t.mean() - t[0]))


def _check_p_soaked(p_soaked):
    if not 0.0 <= p_soaked < 1.0:
        raise ValueError(f"p_soaked must be in [0, 1), got {p_soaked!r}.")
    return float(p_soaked)


def _warm_probability(z, S, sigma2, p_soaked):
    """Posterior probability that readings ``z`` (above what a soaked machine
    reads) come from a warm state, readings ~ N(0, S), rather than from a
    soaked machine, readings ~ N(0, diag(sigma2)), with prior probability
    ``p_soaked`` of the latter."""
    _, logdet = np.linalg.slogdet(S)
    warm = -0.5 * (z @ np.linalg.solve(S, z) + logdet)
    soaked = -0.5 * (np.sum(z * z / sigma2) + np.sum(np.log(sigma2)))
    return float(expit(warm - soaked + np.log((1.0 - p_soaked) / p_soaked)))


def _check_span(rise, names, air0, where, after=None):
    """Refuse first readings (``rise``: K above the air ``air0``) that no
    machine tool gives; ``after``: what was taken out of them (the drivers'
    heating), else they are taken to be in other units."""
    far = np.abs(rise)
    i = int(np.argmax(far))
    if far[i] <= READING_SPAN_K:
        return
    if after is not None:
        raise ValueError(
            f"{where}readings[{names[i]!r}] is {far[i]:g} K from the air "
            f"({air0:g} °C){after}."
        )
    raise ValueError(
        f"{where}readings[{names[i]!r}] is {air0 + rise[i]:g}, {far[i]:g} K "
        f"from the air ({air0:g} °C): give temperatures in °C, as the air "
        f"(a machine tool runs within some {READING_SPAN_K:g} K of it)."
    )


def _warn_unlikely(rise, names, air0, where):
    """Warn of first readings (``rise``: K above the air ``air0``) that a
    machine's structure seldom gives: a unit slip (fahrenheit, say)."""
    if np.median(rise) <= READING_ABOVE_K and rise.min() >= -READING_BELOW_K:
        return
    j = int(np.argmin(rise)) if rise.min() < -READING_BELOW_K else int(np.argmax(rise))
    warnings.warn(
        f"{where}readings[{names[j]!r}] is {rise[j]:+.3g} K from the air "
        f"({air0:g} °C), the readings a median {np.median(rise):+.3g} K: "
        f"a machine tool's structure seldom starts more than "
        f"{READING_ABOVE_K:g} K above the air or {READING_BELOW_K:g} K below "
        "it. Check that the readings and the air are in the same unit "
        "(°C); the estimate goes on.",
        UserWarning,
        stacklevel=3,
    )


def _calibrate(machine, runs, params, bounds, channels, initial, least_squares_kw):
    from scipy.optimize import least_squares

    if not isinstance(runs, pd.DataFrame):
        raise TypeError(
            "runs must be a run table (a pandas DataFrame with run, time_s, "
            f"spindle_rpm, ambient_C and the channels), got {type(runs).__name__}."
        )
    _least_squares_keywords(least_squares_kw)
    if isinstance(params, str):
        params = [params]
    params = list(params)
    if not params:
        raise ValueError("Name at least one parameter to calibrate.")
    twice = sorted({k for k in params if params.count(k) > 1})
    if twice:
        raise ValueError(f"params names {twice} more than once.")
    check_parameter_names(machine.spec, params)
    for k in params:
        effect = k.split(".")[0]
        if effect in EFFECTS and effect not in machine.effects:
            raise ValueError(
                f"Cannot calibrate {k!r}: effect {effect!r} is off, so the "
                "parameter has no influence; switch it on first "
                f"(machine.with_effects(add=[{effect!r}]))."
            )
    current = machine.params
    known = machine.spec.known_parameters()
    x0 = np.array([current.get(k, known[k]) for k in params], dtype=float)
    # Bounds inside each parameter's valid range: least_squares keeps its
    # steps (finite differences included) within them, so every simulation
    # of the fit is of a valid machine.
    lo, hi = (
        _default_bounds(x0, params) if bounds is None else _check_bounds(bounds, params)
    )
    # Shares of one whole (feed_heating's nut_share and motor_share) stay
    # within their sum's limit too: the fit moves variables that keep them.
    shares = _Shares(machine, params, lo, hi)
    v0 = shares.to_variables(np.clip(x0, lo, hi))
    x0 = shares.to_params(v0)

    check_unique_columns(runs)
    if "run" not in runs.columns:
        levels = [n for n in runs.index.names if n in ("run", "time_s")]
        raise ValueError(
            "The run table has no 'run' column"
            + (
                f"; {levels} are levels of its index: runs.reset_index()."
                if "run" in levels
                else "."
            )
        )
    if len(runs) == 0:
        raise ValueError("The run table is empty (no rows).")
    # A row without a label would be left out of every run (groupby drops
    # it) without a word.
    check_labels(runs["run"].to_numpy())
    if channels is None:
        channels = [c for c in machine.targets if c in runs.columns]
        if not channels:
            raise ValueError(
                f"The runs have none of the channels to fit; the machine predicts "
                f"{machine.targets + machine.sensors}."
            )
        absent = [c for c in machine.targets if c not in runs.columns]
        if absent:
            warnings.warn(
                f"calibrate: the runs have no column {absent}, which the machine "
                f"predicts; fitting {channels} only (name channels= to choose).",
                UserWarning,
                stacklevel=4,
            )
    else:
        channels = [channels] if isinstance(channels, str) else list(channels)
        missing = [c for c in channels if c not in runs.columns]
        if missing:
            raise ValueError(
                f"channels {missing} are not columns of the runs"
                f"{suggest(missing[0], runs.columns)}."
            )
        if not channels:
            raise ValueError("channels is empty: name the channels to fit.")
        twice = sorted({c for c in channels if channels.count(c) > 1})
        if twice:
            raise ValueError(f"channels names {twice} more than once.")
    for c in channels:
        if c not in machine.targets and c not in machine.sensors:
            raise ValueError(f"The machine does not predict {c!r}.")
    structure = [c for c in machine.structure_sensors if c in runs.columns]
    p_soaked = 0.0
    if isinstance(initial, str) and initial == "auto":
        initial = "measured" if structure else "ambient"
        p_soaked = machine.SOAKED_PRIOR
    from_readings = isinstance(initial, str) and initial == "measured"
    # A text, a missing or an infinite value in a fitted channel or a driver
    # is named by its column, run, row and time.
    read = [
        c
        for c in ("time_s", "spindle_rpm", "ambient_C", "feed_mm_min", *channels)
        # Clock times are named per run by _run_drivers.
        if c in runs.columns and not is_clock_dtype(runs[c].dtype)
    ]
    check_numeric_columns(runs[read], runs["run"])
    check_finite_columns(
        runs[read].astype(float),
        runs["run"],
        what="the runs",
        hint="The calibration compares every sample: impute or drop those "
        "rows first, or leave the channel out (channels=).",
    )
    groups = [(run, frame) for run, frame in runs.groupby("run", sort=False)]
    if "time_s" in runs.columns and not is_clock_dtype(runs["time_s"].dtype):
        warn_short_runs(
            "calibrate",
            {run: np.ptp(f["time_s"].to_numpy(float)) for run, f in groups},
            4,
        )
    drivers = {run: _run_drivers(frame, run) for run, frame in groups}
    warn_air_unit(
        np.concatenate([d[2] for d in drivers.values()]), "simulation, calibration"
    )
    # A glitch of a sample or two would pull the fit towards it, or a run's
    # initial state from its first readings: the fitted channels and, when
    # the first readings set the initial state, the (finite) sensors they
    # read are repaired (others are not read: no word about them).
    readers = [
        s
        for s in machine.sensors
        if from_readings and s in runs.columns and s not in channels
    ]
    repaired = []
    for run, frame in groups:
        t, rpm, air, feed = drivers[run]
        columns = [
            *channels,
            *(c for c in readers if _finite(frame[c])),
        ]
        y = repair_spikes(
            frame[columns].to_numpy(float, copy=True),
            columns,
            t,
            run,
            used_for="the calibration",
            spindle_rpm=rpm,
            feed_mm_min=feed,
            ambient_C=air,
        )
        repaired.append((run, frame.assign(**dict(zip(columns, y.T, strict=True)))))
    groups = repaired
    # The first readings of every run (initial="measured").
    first = (
        {run: machine.first_readings(frame, run=run) for run, frame in groups}
        if from_readings
        else {}
    )
    measured = []
    for run, frame in groups:
        y = frame[channels].to_numpy(float)
        # Every channel is compared as its change since the start of the
        # run: displacements start at zero in the simulation, and a sensor's
        # calibration offset is not physics (compared as read, it would bend
        # the fitted parameters).
        measured.append(y - y[0])
    flat = np.all([flat_columns(y) for y in measured], axis=0)
    dead = [c for c, f in zip(channels, flat, strict=True) if f]
    if dead:
        warnings.warn(
            f"calibrate: the channel(s) {dead} are constant on every run (a "
            "dead or unplugged probe?): the fit takes them as a machine that "
            "does not move there, a glitch or two on them left out; leave them "
            "out (channels=).",
            UserWarning,
            stacklevel=4,
        )
        for y in measured:  # constant: no change since the start
            y[:, flat] = 0.0
    # Each channel scaled by its own spread, so that every channel carrying
    # a signal has its say, but by no less than a quarter of the root mean
    # square spread of its kind (displacements, temperatures): scaled by its
    # own spread, a channel that barely moves (noise around zero) would weigh
    # as much as one carrying the signal, and the fit would chase its noise.
    spread = np.concatenate(measured).std(axis=0)
    is_temp = np.array([c not in machine.targets for c in channels])
    scale = spread.copy()
    for kind in (is_temp, ~is_temp):
        if kind.any():
            floor = CHANNEL_SCALE_FLOOR * np.sqrt(np.mean(spread[kind] ** 2))
            scale[kind] = np.maximum(spread[kind], floor)
    scale = np.where(scale > 0, scale, 1.0)

    # The prior of the initial states spans the runs' own speeds and feeds.
    prior_range = {}
    warm = {}
    if from_readings:
        prior_range = {
            "max_rpm": max(float(np.max(np.abs(d[1]))) for d in drivers.values()),
            "max_feed_mm_min": max(
                float(np.max(np.abs(d[3]))) if d[3] is not None else 0.0
                for d in drivers.values()
            ),
        }
        # With "auto", whether each run starts warm is judged once, with the
        # machine as given: every trial machine starts the run alike.
        if p_soaked > 0:
            k = FIRST_READINGS
            warm = {
                run: machine.warm_probability(
                    first[run],
                    air[:k],
                    time_s=t[:k],
                    spindle_rpm=rpm[:k],
                    feed_mm_min=None if feed is None else feed[:k],
                    **prior_range,
                    p_soaked=p_soaked,
                    run=run,
                )
                for run, (t, rpm, air, feed) in drivers.items()
            }

    # The prior of the initial states (initial="measured") depends on the
    # parameters of the network and its heat, not on the thermo-elastic
    # coefficients: one per set of the others (a finite-difference step of a
    # coefficient reuses it).
    priors = {}

    def simulate_all(values):
        m = machine.with_params(dict(zip(params, values, strict=True)))
        thermal = tuple(
            v for k, v in zip(params, values, strict=True) if not k.startswith("k.")
        )
        if thermal in priors:
            m._cache.update(priors[thermal])
        out = []
        for run, (t, rpm, air, feed) in drivers.items():
            k = FIRST_READINGS
            start = (
                m.initial_from_readings(
                    first[run],
                    air[:k],
                    time_s=t[:k],
                    spindle_rpm=rpm[:k],
                    feed_mm_min=None if feed is None else feed[:k],
                    **prior_range,
                    warm=warm.get(run),
                    run=run,
                )
                if from_readings
                else initial
            )
            sim = m.simulate_drivers(
                t, rpm, air, feed, run=run, initial=start, noise=False
            )
            values = sim[channels].to_numpy(float)
            out.append(values - values[0])
        if from_readings and thermal not in priors:
            priors[thermal] = {
                key: value
                for key, value in m._cache.items()
                if isinstance(key, tuple) and key[0] == "state_prior"
            }
        return out

    def residuals(variables):
        sims = simulate_all(shares.to_params(variables))
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
    res = least_squares(residuals, v0, bounds=(shares.lo, shares.hi), **kw)
    x = shares.to_params(res.x)
    J = res.jac.toarray() if hasattr(res.jac, "toarray") else np.asarray(res.jac)
    # A parameter that does not move the fitted channels (a zero Jacobian
    # column: the simulations do not change) is not determined by them; its
    # standard error is infinite.
    dead = ~np.any(J != 0, axis=0)
    std = np.full(len(params), np.inf)
    corr = np.full((len(params), len(params)), np.nan)
    live = ~dead
    if live.any():
        try:
            Jl = J[:, live]
            cov = np.linalg.pinv(Jl.T @ Jl) * (
                2 * res.cost / max(J.shape[0] - J.shape[1], 1)
            )
            # From the variables of the fit to the parameters (the identity
            # unless shares were fitted).
            A = shares.jacobian(res.x)[:, live]
            cov = A @ cov @ A.T
            std[live] = np.sqrt(np.clip(np.diag(cov)[live], 0, None))
            scale = np.sqrt(np.clip(np.diag(cov), 0, None))
            with np.errstate(invalid="ignore", divide="ignore"):
                corr = cov / np.outer(scale, scale)
        except np.linalg.LinAlgError:  # pragma: no cover - pinv rarely fails
            std[live] = np.nan
    if dead.any():
        names = [k for k, d in zip(params, dead, strict=True) if d]
        warnings.warn(
            f"calibrate: parameter(s) {names} have no influence on the fitted "
            f"channels {channels}; they are not determined by them (std_error "
            "inf). Fit channels they move, or leave them out.",
            UserWarning,
            stacklevel=4,
        )
    # A parameter the fit left on its bound wanted to go further: often a
    # unit slip (speed in krpm, displacements in mm) or a structure that
    # does not fit the runs, seldom a value just beyond the default range.
    tol = 1e-6 * np.maximum(np.abs(hi - lo), 1e-300)
    at_low = ~dead & (x - lo <= tol)
    on_bound = at_low | (~dead & (hi - x <= tol))
    ends = [
        f"{params[i]} = {x[i]:.4g} ({'low' if at_low[i] else 'high'} bound)"
        for i in np.flatnonzero(on_bound)
    ]
    if ends:
        alike = _alike_text(params, on_bound, corr)
        check = (
            "check the units of the runs (speed in rpm, displacements in µm, "
            "temperatures in °C) and the sketch's structure; if the value is "
            "plausible, widen bounds=."
        )
        warnings.warn(
            f"calibrate: {', '.join(ends)} ended on the bound of its range: the "
            "fit wanted it further. "
            + (f"{alike} {check}" if alike else check[0].upper() + check[1:]),
            UserWarning,
            stacklevel=4,
        )
    result = CalibrationResult(
        params=pd.Series(x, index=params),
        initial=pd.Series(x0, index=params),
        std_error=pd.Series(std, index=params),
        rmse_before=before,
        rmse_after=rmse(x),
        cost=float(res.cost),
        nfev=int(res.nfev),
        success=bool(res.success),
        message=str(res.message),
    )
    return machine.with_params(dict(zip(params, x, strict=True))), result


# Parameters whose estimates correlate this strongly move the fitted
# channels alike: the runs hardly tell them apart.
ALIKE_CORRELATION = 0.95


def _alike_text(params, on_bound, corr):
    """For the parameters a calibration left on a bound (``on_bound``), the
    others whose estimates correlate with theirs (``corr``) beyond
    :data:`ALIKE_CORRELATION`, as a sentence ("" when none): collinear
    coefficients push each other to the bounds, which looks like a unit slip
    and is not one."""
    pairs = []
    for i in np.flatnonzero(on_bound):
        r = np.where(np.arange(len(params)) == i, np.nan, corr[i])
        if not np.isfinite(r).any():
            continue
        j = int(np.nanargmax(np.abs(r)))
        if abs(r[j]) >= ALIKE_CORRELATION:
            pairs.append(f"{params[i]} with {params[j]} (r = {r[j]:+.2f})")
    if not pairs:
        return ""
    return (
        f"Its estimate moves with another's ({'; '.join(pairs)}): they shape the "
        "fitted channels alike, so the runs hardly tell them apart and the pair "
        "can run to the bounds. Fix one of them, or fit fewer parameters; else"
    )


# A part of a machine tool this much warmer than the air (K) is no machine's:
# spindle bearings run at 20-40 K above it. A simulation that gets there has
# a slip in its file (a heat input in kW written as W, a capacity in kJ/K).
# Set above what the presets reach in the gap check's random campaigns
# (vmc-b's bearings up to about 120 K at 9000 rpm with doubled effects).
_HOT_RISE_K = 150.0


def _warn_hot(T, air, nodes, run):
    """Warn naming the node of a simulated run that rises more than
    :data:`_HOT_RISE_K` above the air (``T``: node temperatures at the
    samples, ``air``: the air at the samples)."""
    rise = T - np.asarray(air, dtype=float)[:, None]
    if not np.nanmax(rise, initial=-np.inf) > _HOT_RISE_K:
        return
    k, j = np.unravel_index(int(np.nanargmax(rise)), rise.shape)
    warnings.warn(
        f"ThermalMachine: in run {run!r} node {nodes[j]!r} rises "
        f"{rise[k, j]:.0f} K above the air (to {T[k, j]:.0f} °C): no part "
        "of a machine tool runs that hot. Check the machine's heat inputs "
        "(W, not kW), capacities (J/K) and conductances (W/K), and the "
        "drivers (a speed beyond what the machine is built for).",
        UserWarning,
        stacklevel=user_stacklevel(),
    )
