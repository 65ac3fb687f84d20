"""The machine description: a validated data model apart from the solvers.

A :class:`MachineSpec` says what a machine *is* (nodes, links, convection,
heat sources, sensors, thermo-elastic map and every number with its unit);
:class:`~skthermal.simulate.ThermalMachine` says what is done with it
(responses, simulation, calibration). A spec is checked once, when it is
built, and every error names the offending entry. It converts to and from a
plain dict and a TOML file (:meth:`MachineSpec.from_toml`,
:meth:`MachineSpec.to_toml`), whose layout is documented in
:meth:`MachineSpec.from_dict`.
"""

import math
import numbers
import tomllib
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from skthermal._naming import (
    TARGET_PATTERN,
    TEMPERATURE_PATTERN,
    renamed,
    shown,
    suggest,
)
from skthermal.simulate._drivers import _check_number
from skthermal.simulate._effects import (
    ANY,
    EFFECTS,
    NOT_NEGATIVE,
    POSITIVE,
    ParameterRange,
)

ROOM = "room"
# The ball screw's growth, a displacement coefficient of the feed axis
# ("k.<axis>.screw"), not a node: no node may be named so.
SCREW = "screw"
SENSOR_KINDS = ("surface", "embedded", "air")

# Heat sources of the file layout: table -> {field: (parameter, unit)}.
HEAT_FIELDS = {
    "bearing": {
        "W_at_1000_rpm": ("q.bearing_W", "W"),
        "alpha": ("q.alpha", "1"),
    },
    "drive": {
        "idle_W": ("q.motor_idle_W", "W"),
        "W_per_1000_rpm": ("q.motor_W_per_krpm", "W per 1000 rpm"),
    },
    "belt": {"W_per_1000_rpm": ("q.belt_W_per_krpm", "W per 1000 rpm")},
    "cutting": {"W": ("q.cutting_W", "W")},
}
HEAT_ROLES = {
    "bearing": "bearing",
    "drive": "motor",
    "belt": "belt",
    "cutting": "cutting",
}
# Custom heat sources: field -> unit (parameter q.<source>.<field>).
CUSTOM_HEAT_FIELDS = {
    "W_constant": "W, always",
    "W": "W while the spindle turns",
    "W_at_1000_rpm": "W at 1000 rpm, times (n/1000)^alpha",
    "alpha": "1",
    "W_per_1000_rpm": "W per 1000 rpm",
    "W_per_m_min": "W per m/min of feed",
}
SENSOR_FIELDS = {
    "noise_C": "sensor.noise_C",
    "quantization_C": "sensor.quantization_C",
    "offset_C": "sensor.offset_C",
}
NODE_FIELDS = ("capacity_J_per_K", "convection_W_per_K")
# Numbers a description may leave out: an absent heat source gives no heat,
# absent sensor and displacement noise is zero.
NUMBER_DEFAULTS = {
    "q.bearing_W": 0.0,
    "q.alpha": 1.5,
    "q.motor_idle_W": 0.0,
    "q.motor_W_per_krpm": 0.0,
    "q.belt_W_per_krpm": 0.0,
    "q.cutting_W": 0.0,
    "sensor.noise_C": 0.0,
    "sensor.quantization_C": 0.0,
    "sensor.offset_C": 0.0,
    "disp.noise_um": 0.0,
}
# Roles a file may leave out when a node carries the role's name.
REQUIRED_ROLES = {
    "enclosure": "the air node around the machine",
    "tool": "the tool or test bar",
}
# Largest sensor noise, quantisation step or offset (°C) and displacement
# noise (µm) a machine file may give: beyond them a figure is a slip (a
# noise of 20 °C meant 0.02), which the simulated readings would carry.
_SENSOR_C = 5.0
_DISP_UM = 100.0
# A sensor's weights must sum to 1 within this tolerance.
WEIGHT_SUM_TOLERANCE = 1e-6


def _unknown(where, name, choices, what="node"):
    return ValueError(
        f"{where}: unknown {what} {name!r}{suggest(name, choices)}; "
        f"known: {sorted(map(str, choices))}."
    )


def _check_fields(where, table, allowed, hint=""):
    if not isinstance(table, dict):
        raise ValueError(f"{where} must be a table (dict), got {type(table).__name__}.")
    for key in table:
        if key not in allowed:
            raise ValueError(
                f"{where}: unknown field {key!r}{suggest(key, allowed)}; "
                f"fields: {list(allowed)}{hint.format(key=key)}."
            )


def _check_axis(a):
    """A ValueError unless ``a`` names a displacement channel (the
    ``<axis>`` of its column ``disp_<axis>_um``)."""
    if isinstance(a, str) and "_" not in a and TARGET_PATTERN.fullmatch(f"disp_{a}_um"):
        return
    column = isinstance(a, str) and TARGET_PATTERN.fullmatch(a) is not None
    hint = f"; {a!r} is a column: give {a[5:-3]!r}" if column else ""
    raise ValueError(
        f"axis {a!r}: a displacement channel name is letters and digits "
        f"(column disp_<axis>_um, e.g. 'z' or 'ch1'){hint}."
    )


def _check_names(where, value):
    """A list of names (strings) in a machine file, each once, as a tuple."""
    if isinstance(value, str) or not isinstance(value, list | tuple):
        raise ValueError(
            f"{where} must be a list of names, got {type(value).__name__} {value!r}."
        )
    for item in value:
        if not isinstance(item, str):
            raise ValueError(f"{where}: {item!r} is not a name (a string).")
    twice = [item for i, item in enumerate(value) if item in value[:i]]
    if twice:
        raise ValueError(f"{where} lists {twice[0]!r} twice.")
    return tuple(value)


def _number(where, value, *, positive=False, nonnegative=False):
    # A file's number must be a number (any real: int, float, a numpy
    # scalar), not a string that parses as one, nor a bool.
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{where} must be a number, got {value!r}.")
    return _check_number(value, where, positive=positive, nonnegative=nonnegative)


def _same_number(a, b):
    """Whether ``a`` and ``b`` are the same number (False for a non-number)."""
    try:
        return bool(a == b)
    except (TypeError, ValueError):
        return False


def _node(where, value, nodes):
    """A reference to a node (a name in ``nodes``), with a clear error."""
    if not isinstance(value, str):
        raise ValueError(f"{where} must be a node name, got {value!r}.")
    if value not in nodes:
        raise _unknown(where, value, list(nodes))
    return value


def _check_sensor_name(name):
    """A sensor's name must be a temperature column of the run table."""
    where = f"sensor {name!r}"
    if isinstance(name, str) and TEMPERATURE_PATTERN.fullmatch(name):
        return
    rule = (
        "a temperature sensor is a run-table column named T<name>_C (letters "
        "and digits, inner '_'), e.g. 'T05_C' or 'Tcarrier3_C'"
    )
    if isinstance(name, str) and TARGET_PATTERN.fullmatch(name):
        raise ValueError(
            f"{where}: {rule}; {name!r} is a displacement column, and "
            "displacements are the axes (axes = [...] and [displacement.<axis>])."
        )
    hint = ""
    if isinstance(name, str):
        guess = renamed(name, "a temperature sensor")
        if guess is None:
            guess = name if name.startswith("T") else f"T{name}"
            guess = guess if guess.endswith("_C") else f"{guess}_C"
        if TEMPERATURE_PATTERN.fullmatch(guess):
            hint = f" (did you mean {guess!r}?)"
    raise ValueError(f"{where}: {rule}{hint}.")


def parameter_entry(key):
    """Where the parameter ``key`` lives in a machine file, in words.

    Parameters
    ----------
    key : str
        Parameter name, e.g. ``"q.alpha"``.

    Returns
    -------
    str
        E.g. ``"heat source 'bearing', field 'alpha'"``.
    """
    family, _, rest = key.partition(".")
    if family == "C":
        return f"node {rest!r}, field 'capacity_J_per_K'"
    if family == "hA":
        return f"node {rest!r}, field 'convection_W_per_K'"
    if family == "G":
        return f"link {rest!r}, field 'conductance_W_per_K'"
    for source, fields in HEAT_FIELDS.items():
        for f, (name, _) in fields.items():
            if name == key:
                return f"heat source {source!r}, field {f!r}"
    for f, name in SENSOR_FIELDS.items():
        if name == key:
            return f"sensor_noise, field {f!r}"
    if key == "disp.noise_um":
        return "displacement, field 'noise_um'"
    if family == "q" and "." in rest:
        source, _, f = rest.partition(".")
        return f"heat source {source!r}, field {f!r}"
    if family == "k" and "." in rest:
        axis, _, node = rest.partition(".")
        return f"displacement {axis!r}, field {node!r}"
    if family in EFFECTS:
        return f"effect {family!r}, field {rest!r}"
    return f"params, field {key!r}"


def check_parameter_names(spec, names):
    """Raise unless every name in ``names`` is a parameter of ``spec``.

    The one check of parameter names: of a machine file (its ``[params]``),
    of ``ThermalMachine.from_spec(params=...)``, ``with_params`` and
    ``calibrate``. The error suggests the closest name.

    Parameters
    ----------
    spec : MachineSpec
    names : iterable of str
    """
    known = spec.known_parameters()
    unknown = [k for k in names if k not in known]
    if not unknown:
        return
    hints = []
    for key in unknown:
        axis, _, node = str(key).removeprefix("k.").partition(".")
        if str(key).startswith("k.") and node == "screw" and axis in spec.axes:
            where = (
                f"only on the feed axis {spec.feed_axis!r} ('k.{spec.feed_axis}.screw')"
                if spec.screw_nodes
                else "only on a machine with a ball screw ([heat.feed] screw = "
                "[...]), which this machine has not"
            )
            hints.append(f"{key!r} (the ball screw's growth counts {where})")
        else:
            hints.append(f"{key!r}{suggest(key, known)}")
    raise ValueError(
        f"Unknown parameter(s) {', '.join(hints)} for machine {spec.name!r}; "
        "see ThermalMachine.parameter_table()."
    )


def check_connected(spec, params):
    """Raise a ValueError naming the nodes of ``spec`` that the parameters
    ``params`` leave without a path to the air (no positive conductance or
    convection): their temperature would be undefined."""
    p = params
    enclosure = spec.enclosure
    reach = {enclosure}
    adjacent = {n: set() for n in spec.nodes}
    for a, b in spec.edges:
        if p[f"G.{a}-{b}"] > 0:
            adjacent[a].add(b)
            adjacent[b].add(a)
    for n in spec.nodes:
        if p.get(f"hA.{n}", 0.0) > 0:
            adjacent[n].add(enclosure)
            adjacent[enclosure].add(n)
    if p.get(f"hA.{enclosure}", 0.0) <= 0:
        raise ValueError(
            f"node {enclosure!r} (the enclosure air) needs a positive "
            f"convection to the workshop air (hA.{enclosure}, W/K)."
        )
    todo = [enclosure]
    while todo:
        for m in adjacent[todo.pop()] - reach:
            reach.add(m)
            todo.append(m)
    cut = [n for n in spec.nodes if n not in reach]
    if cut:
        raise ValueError(
            f"node(s) {cut} are not connected to the air: give them a link "
            "with a positive conductance or a positive convection."
        )


def parameter_range(key):
    """The valid range of the parameter ``key``, by the rules of
    :func:`check_parameters` (which checks every value against it).

    Capacities ``C.*`` are positive; conductances ``G.*`` and ``hA.*``, heat
    inputs ``q.*``, noise figures ``sensor.*`` and ``disp.*`` not negative;
    loss exponents ``q.*alpha`` lie in [0.5, 3]; displacement coefficients
    ``k.*`` are any finite number; effects' parameters follow their effect
    (:attr:`Effect.ranges`: ``sensor_lag.tau_s`` in (0, 1 day], the
    ``feed_heating`` fractions in [0, 1], each other parameter from 0 to a
    bound far above its physical values, which catches a unit slip such as
    milliseconds for seconds). ``calibrate`` keeps its bounds inside.

    Parameters
    ----------
    key : str
        Parameter name, e.g. ``"q.alpha"``.

    Returns
    -------
    ParameterRange
        ``low``, ``high``, ``low_open`` (``low`` itself excluded) and the
        rule in words; ``value in parameter_range(key)`` tests a value.

    Examples
    --------
    >>> from skthermal.simulate._spec import parameter_range
    >>> str(parameter_range("q.alpha")), str(parameter_range("C.spindle"))
    ('[0.5, 3]', '(0, inf)')
    >>> 1.2 in parameter_range("feed_heating.measure_at")
    False
    """
    family = str(key).partition(".")[0]
    if family == "C":
        return POSITIVE._replace(rule="is a heat capacity and must be positive")
    if family in ("G", "hA"):
        return NOT_NEGATIVE._replace(rule="is a conductance and must not be negative")
    if family == "q" and key.endswith("alpha"):
        return ParameterRange(
            0.5,
            3.0,
            False,
            "(loss ~ speed^alpha) must lie in [0.5, 3]",
            "; Palmgren-type friction gives 1 to 1.7",
        )
    if family == "q":
        return NOT_NEGATIVE._replace(rule="is a heat input and must not be negative")
    if family == "sensor":
        return ParameterRange(
            0.0,
            _SENSOR_C,
            False,
            f"must lie in [0, {_SENSOR_C:g}] °C",
            "; temperature sensors read to 0.01-0.5 °C, so more is a slip of "
            "unit or decimal point",
        )
    if family == "disp":
        return ParameterRange(
            0.0,
            _DISP_UM,
            False,
            f"must lie in [0, {_DISP_UM:g}] µm",
            "; displacement probes read to 0.01-1 µm, so more is a slip of "
            "unit (mm?) or decimal point",
        )
    if family in EFFECTS:
        return EFFECTS[family].parameter_range(key.partition(".")[2])
    return ANY


def _in_range(value, key, where):
    """``value`` of parameter ``key``, or an error naming ``where`` when it
    lies outside :func:`parameter_range`."""
    valid = parameter_range(key)
    if value not in valid:
        raise ValueError(f"{where} {valid.rule}, got {value}{valid.hint}.")
    return value


def check_parameters(spec, params, *, strict=False, base=None):
    """Check the names and values of a machine's parameters.

    The one home of the parameter rules: names belong to the structure
    (:func:`check_parameter_names`), every value lies in its range
    (:func:`parameter_range`: capacities positive, conductances, heat
    inputs and noise figures not negative, loss exponents ``alpha`` in
    [0.5, 3] ...), and each effect checks its joint rules
    (:meth:`Effect.check`). Errors name the file entry of the parameter
    (:func:`parameter_entry`).

    Parameters
    ----------
    spec : MachineSpec
    params : dict
        Name -> value.
    strict : bool, default=False
        Values must be real numbers (not strings that parse as numbers), as
        in a machine file. Without it, numeric 0-d arrays are taken too, but
        never text or a bool (``True`` is no heat input).
    base : dict, optional
        Parameters already checked (a machine's), which ``params`` change:
        only the values of ``params`` are checked, the effects' joint rules
        on the whole set.

    Returns
    -------
    dict
        The parameters as floats (with ``base``: the whole set).
    """
    check_parameter_names(spec, params)
    out = {}
    for key, value in params.items():
        if type(value) is not float or not math.isfinite(value):
            where = f"{parameter_entry(key)}: parameter {key!r}"
            if strict or isinstance(value, str | bytes | bool | np.bool_):
                value = _number(where, value)
            else:
                value = _check_number(value, where)
        out[key] = _in_range(value, key, f"{parameter_entry(key)}: parameter {key!r}")
    if base is None:
        full = {
            f"{e.name}.{k}": v for e in EFFECTS.values() for k, v in e.params.items()
        }
    else:
        full = dict(base)
    full.update(out)
    for effect in EFFECTS.values():
        try:
            effect.check(full)
        except ValueError as exc:
            raise ValueError(f"effect {effect.name!r}: {exc}") from None
    return out if base is None else full


@dataclass(frozen=True)
class SensorSpec:
    """A temperature sensor: which temperatures it reads, and how.

    Attributes
    ----------
    name : str
        Run-table column ``T<name>_C``, e.g. ``"T01_C"``.
    weights : dict
        Node name (or ``"room"``, the workshop air) -> weight (1); the sensor
        reads the weighted mean, e.g. a point between two carrier segments.
        Weights are not negative and sum to 1.
    kind : {"surface", "embedded", "air"}
        Surface sensors lag when the ``sensor_lag`` effect is on.
    location : str
        Where it sits, in words.
    noise_C, quantization_C, offset_C : float or None
        This sensor's noise (°C, standard deviation), quantisation step (°C)
        and calibration offset (°C, standard deviation of the offset drawn
        once per sensor); None (default) takes the machine's
        ``sensor.noise_C``, ``sensor.quantization_C`` and ``sensor.offset_C``,
        shared by all sensors without their own.
    """

    name: str
    weights: dict
    kind: str = "surface"
    location: str = ""
    noise_C: float | None = None
    quantization_C: float | None = None
    offset_C: float | None = None


@dataclass(frozen=True)
class MachineSpec:
    """The description of a machine: network, heat sources, sensors, map.

    Building a spec checks it: names exist (with a suggestion for a typo),
    every parameter belongs to the structure and lies in its range
    (:func:`check_parameters`: capacities positive, conductances,
    convection and heat inputs not negative ...), sensors are named
    ``T<name>_C`` and read a weighted mean (weights not negative, summing to
    1), and every node reaches the air through links or convection. Errors
    name the offending entry.

    Attributes
    ----------
    name : str
        Machine name (recorded in the metadata of simulated runs).
    description : str
        The machine in words.
    nodes : tuple of str
        Lumped bodies. Each has a heat capacity ``C.<node>`` (J/K, > 0) and
        a convection conductance to the air ``hA.<node>`` (W/K, >= 0).
    edges : tuple of (str, str)
        Links between nodes; each has a conductance ``G.<a>-<b>`` (W/K).
    sensors : tuple of SensorSpec
        Temperature sensors.
    head_nodes : tuple of str
        Nodes whose convection grows with spindle speed (``speed_convection``).
    exposed_nodes : tuple of str
        Nodes washed by the workshop air itself with ``ambient_transient``.
    enclosure : str
        The air node around the machine: every other node convects to it,
        and it convects to the workshop air (``"room"``).
    tool : str
        The tool or test bar (``tool_growth``).
    bearing : str
        Node heated by the spindle bearings, ``q.bearing_W * (n/1000)^q.alpha``
        (W, n in rpm).
    motor : str
        Node heated by the spindle drive, ``q.motor_idle_W`` while turning
        plus ``q.motor_W_per_krpm * n/1000`` (W).
    belt : str
        Node heated by a loss linear in speed, ``q.belt_W_per_krpm * n/1000``
        (W): a belt, or a second bearing.
    cutting : str
        Node heated by cutting while the spindle turns, ``q.cutting_W`` (W).
    custom_heat : dict
        Further heat sources, name -> heated node (a coolant pump, a
        hydraulic unit, a second motor). Source ``s`` gives
        ``q.s.W_constant + q.s.W * on + q.s.W_at_1000_rpm * (n/1000)^q.s.alpha
        + q.s.W_per_1000_rpm * n/1000 + q.s.W_per_m_min * |feed|/1000`` (W;
        ``on``: the spindle turns; absent numbers are zero, ``alpha`` 1.5);
        its |feed| term belongs to the ``"feed"`` part of
        :meth:`ThermalMachine.response`, the rest to the ``"drive"`` part.
    screw_nodes : tuple of str
        Ball-screw segments from the fixed bearing on (``feed_heating``).
    nut, axis_motor : str or None
        Ball nut and feed-axis motor nodes (``feed_heating``).
    feed_axis : str
        Displacement channel moved by the ball screw's growth
        (``k.<feed_axis>.screw``, µm/K for the whole screw).
    axes : tuple of str
        Displacement channels: run-table columns ``disp_<axis>_um``; each has
        a coefficient ``k.<axis>.<node>`` (µm/K of node rise) per node.
    groups : dict
        Group name -> sensor names (for reports).
    params : dict
        Default value of every number, by parameter name (see the attributes
        above; ``disp.noise_um`` is the displacement noise in µm, and
        ``<effect>.<param>`` the parameters of an effect). May be empty for a
        structure without numbers; :class:`ThermalMachine` then needs them.
        :meth:`known_parameters` lists the names a structure has.
    effects : dict
        The effect switches the description records: effect name -> on
        (bool). :meth:`ThermalMachine.from_spec` switches on the effects
        recorded on, and for those not recorded their default (every effect
        except ``sensor_drift``); empty (default): every effect takes its
        default. :meth:`ThermalMachine.to_spec` records every switch.
    """

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
    custom_heat: dict = field(default_factory=dict)
    screw_nodes: tuple = ()
    nut: str | None = None
    axis_motor: str | None = None
    feed_axis: str = "y"
    axes: tuple = ("x", "y", "z")
    groups: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)
    effects: dict = field(default_factory=dict)

    # A spec holds dicts (params, groups ...): it compares by value but
    # has no hash (say so, rather than fail inside the generated __hash__).
    __hash__ = None

    def __post_init__(self):
        self.validate()

    def known_parameters(self):
        """Every parameter a machine of this structure has, with its default.

        Returns
        -------
        dict
            Name -> default value; None for the numbers without a default
            (heat capacities ``C.<node>`` and conductances ``G.<a>-<b>``).

        Examples
        --------
        >>> from skthermal.simulate import ThermalMachine
        >>> spec = ThermalMachine.from_preset("spindle-rig").spec
        >>> names = spec.known_parameters()
        >>> names["q.alpha"], names["C.spindle"], "q.bearng_W" in names
        (1.5, None, False)
        """
        out = {f"C.{n}": None for n in self.nodes}
        out.update({f"hA.{n}": 0.0 for n in self.nodes})
        out.update({f"G.{a}-{b}": None for a, b in self.edges})
        out.update(NUMBER_DEFAULTS)
        for source in self.custom_heat:
            out.update(
                {
                    f"q.{source}.{f}": 1.5 if f == "alpha" else 0.0
                    for f in CUSTOM_HEAT_FIELDS
                }
            )
        for axis in self.axes:
            out.update({f"k.{axis}.{n}": 0.0 for n in self.nodes})
        if self.screw_nodes:
            out[f"k.{self.feed_axis}.screw"] = 0.0
        for e in EFFECTS.values():
            out.update({f"{e.name}.{k}": v for k, v in e.params.items()})
        return out

    # --- checks -------------------------------------------------------------

    def _check_enclosure_roles(self):
        """The enclosure is the air around the machine: no role of a solid
        body sits on it. A tool, bearing, motor or ball screw there would
        give the air the body's physics (its heat, its convection to the
        enclosure, that is to itself), and the simulation would run without
        a word. A custom heat source may heat the enclosure air (a cabinet
        or a hydraulic unit inside it)."""
        enc = self.enclosure
        solid = {
            "tool": "the tool or test bar",
            "bearing": "the node the spindle bearings heat",
            "motor": "the node the spindle drive heats",
            "belt": "the node the belt loss heats",
            "cutting": "the node cutting heats",
            "nut": "the ball nut",
            "axis_motor": "the feed-axis motor",
        }
        for role, meaning in solid.items():
            if getattr(self, role) == enc:
                raise ValueError(
                    f"role {role!r} ({meaning}) is the enclosure {enc!r}, the "
                    "air node around the machine; give it a solid node."
                )
        lists = {
            "head_nodes": "roles: head (nodes whose convection grows with speed)",
            "exposed_nodes": "roles: exposed (nodes washed by the workshop air "
            "instead of the enclosure air)",
            "screw_nodes": "heat source 'feed': screw (the ball-screw segments)",
        }
        for role, where in lists.items():
            if enc in getattr(self, role):
                raise ValueError(
                    f"{where} lists the enclosure {enc!r}, the air node around "
                    "the machine, which convects to the workshop air itself; "
                    "list solid nodes only."
                )

    def validate(self):
        """Check the description; raises ValueError naming the bad entry."""
        for f in ("name", "description"):
            if not isinstance(getattr(self, f), str):
                raise ValueError(
                    f"machine spec: {f} must be a string (text), got "
                    f"{type(getattr(self, f)).__name__} {getattr(self, f)!r}."
                )
        nodes = list(self.nodes)
        seen = set()
        for n in nodes:
            if not isinstance(n, str) or not n or n == ROOM or "." in n:
                raise ValueError(
                    f"node {n!r}: a node name is a non-empty string without '.', "
                    f"and {ROOM!r} is reserved for the workshop air."
                )
            if n == SCREW:
                # A node of that name had its displacement coefficient
                # counted twice on a machine with a ball screw, silently.
                raise ValueError(
                    f"node {n!r}: the name is reserved for the ball screw's "
                    f"growth (the displacement coefficient 'k.<axis>.{SCREW}' of "
                    "the feed axis); name the node otherwise, e.g. 'screw_shaft'."
                )
            if n in seen:
                raise ValueError(f"node {n!r} is listed twice.")
            seen.add(n)
        known = set(nodes)
        links = set()
        keys = {}
        for edge in self.edges:
            if not isinstance(edge, list | tuple) or len(edge) != 2:
                raise ValueError(f"link {edge!r}: a link joins two nodes.")
            a, b = edge
            strings = isinstance(a, str) and isinstance(b, str)
            label = f"link '{a}-{b}'" if strings else f"link {list(edge)!r}"
            for x in (a, b):
                if x == ROOM and ROOM not in known:
                    raise ValueError(
                        f"{label}: 'room' (the workshop air) is not a node, so "
                        "links cannot reach it; every node convects to the "
                        f"enclosure air ({self.enclosure!r}, through "
                        "hA.<node>), which convects to the room. A body outside "
                        "the enclosure (a tank, a chiller) is then modelled as "
                        "seeing the enclosure air; to let the workshop air wash "
                        "it directly, list it under roles: exposed (the "
                        "ambient_transient effect)."
                    )
                _node(label, x, nodes)
            if a == b:
                raise ValueError(f"{label}: joins a node to itself.")
            if (a, b) in links or (b, a) in links:
                raise ValueError(f"{label} is listed twice.")
            links.add((a, b))
            # The conductance's name joins the nodes with '-', which node
            # names may contain: two links must not share one name.
            key = f"G.{a}-{b}"
            if key in keys:
                raise ValueError(
                    f"links {list(keys[key])} and {[a, b]} would share the "
                    f"conductance parameter {key!r} (a '-' in a node name makes "
                    "the name ambiguous); rename a node (e.g. '_' for '-')."
                )
            keys[key] = (a, b)
        for role in ("enclosure", "tool", "bearing", "motor", "belt", "cutting"):
            _node(f"role {role!r}", getattr(self, role), nodes)
        for role in ("nut", "axis_motor"):
            value = getattr(self, role)
            if value is not None:
                _node(f"role {role!r}", value, nodes)
                if not self.screw_nodes:
                    raise ValueError(
                        f"role {role!r}: feed heating needs the ball screw "
                        "([heat.feed] screw = [...], screw_nodes); without it "
                        f"the {role} gets no heat."
                    )
        for source, node in self.custom_heat.items():
            if not isinstance(source, str) or not source or "." in source:
                raise ValueError(
                    f"heat source {source!r}: a source name is a non-empty string "
                    "without '.'."
                )
            if source in HEAT_FIELDS or source == "feed":
                raise ValueError(
                    f"heat source {source!r}: the name is taken by a built-in "
                    "source; name the custom source differently."
                )
            _node(f"heat source {source!r}", node, nodes)
        for role in ("head_nodes", "exposed_nodes", "screw_nodes"):
            for value in getattr(self, role):
                _node(role, value, nodes)
        self._check_enclosure_roles()
        axes = list(self.axes)
        if not axes:
            raise ValueError("axes: give at least one displacement channel.")
        for a in axes:
            _check_axis(a)
        if len(set(axes)) != len(axes):
            raise ValueError(f"axes {axes} lists a channel twice.")
        if self.screw_nodes and self.feed_axis not in axes:
            raise _unknown("feed_axis", self.feed_axis, axes, "axis")
        names = set()
        for s in self.sensors:
            if not isinstance(s, SensorSpec):
                raise ValueError(f"sensor {s!r} is not a SensorSpec.")
            where = f"sensor {s.name!r}"
            _check_sensor_name(s.name)
            if s.name in names:
                raise ValueError(f"{where} is listed twice.")
            names.add(s.name)
            if not isinstance(s.location, str):
                raise ValueError(
                    f"{where}: location must be a string (where it sits, in "
                    f"words), got {type(s.location).__name__} {s.location!r}."
                )
            if s.kind not in SENSOR_KINDS:
                raise ValueError(
                    f"{where}: kind {s.kind!r}{suggest(s.kind, SENSOR_KINDS)} is "
                    f"not one of {list(SENSOR_KINDS)}."
                )
            if not isinstance(s.weights, dict):
                raise ValueError(
                    f"{where}: weights must be a table of node weights "
                    f"(node or 'room' = weight), got {s.weights!r}."
                )
            if not s.weights:
                raise ValueError(f"{where} reads no node (weights is empty).")
            for f, key in SENSOR_FIELDS.items():
                if getattr(s, f) is not None:
                    value = _number(f"{where}: {f}", getattr(s, f), nonnegative=True)
                    _in_range(value, key, f"{where}: {f}")
            total = 0.0
            for node, w in s.weights.items():
                if node != ROOM and node not in known:
                    raise _unknown(where, node, [*nodes, ROOM])
                total += _number(f"{where}: weight of {node!r}", w, nonnegative=True)
            if abs(total - 1.0) > WEIGHT_SUM_TOLERANCE:
                terms = " + ".join(f"{w:g}" for w in s.weights.values())
                terms = f"{terms} = {total:g}" if len(s.weights) > 1 else terms
                raise ValueError(
                    f"{where}: the weights must sum to 1 (the sensor reads a "
                    f"weighted mean of nodes), got {terms}."
                )
        for group, members in self.groups.items():
            for m in members:
                if m not in names:
                    raise _unknown(f"group {group!r}", m, names, "sensor")
        if not isinstance(self.effects, dict):
            raise ValueError(
                "effects must be a dict of switches (effect name -> on), got "
                f"{type(self.effects).__name__}."
            )
        for e, on in self.effects.items():
            if e not in EFFECTS:
                raise _unknown("effects", e, list(EFFECTS), "effect")
            if not isinstance(on, bool):
                raise ValueError(f"effect {e!r}: on must be true or false, got {on!r}.")
        if self.params:
            self._validate_numbers()

    def _validate_numbers(self):
        p = self.params
        for n in self.nodes:
            if f"C.{n}" not in p:
                raise ValueError(f"node {n!r}: no heat capacity (C.{n}, J/K).")
        for a, b in self.edges:
            if f"G.{a}-{b}" not in p:
                raise ValueError(f"link '{a}-{b}': no conductance (G.{a}-{b}, W/K).")
        p = check_parameters(self, p, strict=True)
        check_connected(self, p)

    # --- dict and TOML -------------------------------------------------------

    def to_dict(self):
        """The spec as a plain dict in the file layout of :meth:`from_dict`."""
        p = dict(self.params)
        out = {"name": self.name, "description": self.description}
        out["axes"] = list(self.axes)
        roles = {
            "enclosure": self.enclosure,
            "tool": self.tool,
            "head": list(self.head_nodes),
            "exposed": list(self.exposed_nodes),
        }
        out["roles"] = roles
        out["nodes"] = {}
        for n in self.nodes:
            entry = {}
            if f"C.{n}" in p:
                entry["capacity_J_per_K"] = p.pop(f"C.{n}")
            if f"hA.{n}" in p:
                entry["convection_W_per_K"] = p.pop(f"hA.{n}")
            out["nodes"][n] = entry
        out["links"] = []
        for a, b in self.edges:
            link = {"between": [a, b]}
            if f"G.{a}-{b}" in p:
                link["conductance_W_per_K"] = p.pop(f"G.{a}-{b}")
            out["links"].append(link)
        heat = {}
        for source, fields in HEAT_FIELDS.items():
            entry = {"node": getattr(self, HEAT_ROLES[source])}
            for f, (key, _) in fields.items():
                if key in p:
                    entry[f] = p.pop(key)
            heat[source] = entry
        if self.screw_nodes:
            feed = {"screw": list(self.screw_nodes), "axis": self.feed_axis}
            if self.nut is not None:
                feed["nut"] = self.nut
            if self.axis_motor is not None:
                feed["axis_motor"] = self.axis_motor
            heat["feed"] = feed
        if self.custom_heat:
            custom = {}
            for source, node in self.custom_heat.items():
                entry = {"node": node}
                for f in CUSTOM_HEAT_FIELDS:
                    if f"q.{source}.{f}" in p:
                        entry[f] = p.pop(f"q.{source}.{f}")
                custom[source] = entry
            heat["custom"] = custom
        out["heat"] = heat
        noise = {f: p.pop(k) for f, k in SENSOR_FIELDS.items() if k in p}
        out["sensor_noise"] = noise
        out["sensors"] = {
            s.name: {
                "weights": dict(s.weights),
                "kind": s.kind,
                "location": s.location,
                **{
                    f: getattr(s, f) for f in SENSOR_FIELDS if getattr(s, f) is not None
                },
            }
            for s in self.sensors
        }
        disp = {}
        if "disp.noise_um" in p:
            disp["noise_um"] = p.pop("disp.noise_um")
        for axis in self.axes:
            disp[axis] = {}
            for key in [k for k in p if k.startswith(f"k.{axis}.")]:
                value = p.pop(key)
                if value != 0:  # absent coefficients are zero
                    disp[axis][key.split(".", 2)[2]] = value
        out["displacement"] = disp
        effects = {e: {"on": self.effects[e]} for e in EFFECTS if e in self.effects}
        for key in [k for k in p if k.split(".")[0] in EFFECTS]:
            e, _, name = key.partition(".")
            effects.setdefault(e, {})[name] = p.pop(key)
        if effects:
            out["effects"] = effects
        if self.groups:
            out["groups"] = {g: list(m) for g, m in self.groups.items()}
        if p:
            out["params"] = p
        return out

    @classmethod
    def from_dict(cls, data):
        """Build a spec from a dict (the layout of a machine file).

        Layout (units in the field names)::

            name = "my-rig"
            description = "..."
            axes = ["x", "y", "z"]          # disp_<axis>_um columns (default:
                                            # the [displacement.<axis>] tables)

            [roles]
            enclosure = "air"                # air node around the machine
            tool = "spindle_nose"
            head = ["spindle"]               # convection grows with speed
            exposed = ["housing"]            # washed by workshop air

            [nodes.spindle]
            capacity_J_per_K = 2000.0
            convection_W_per_K = 0.5

            [[links]]
            between = ["spindle", "housing"]
            conductance_W_per_K = 10.0

            [heat.bearing]                   # W_at_1000_rpm * (n/1000)^alpha
            node = "front_bearing"
            W_at_1000_rpm = 8.0
            alpha = 1.5
            [heat.drive]                     # idle_W + W_per_1000_rpm * n/1000
            node = "motor"
            [heat.belt]                      # W_per_1000_rpm * n/1000
            node = "rear_bearing"
            [heat.cutting]                   # W while turning
            node = "spindle_nose"
            [heat.feed]                      # optional ball screw
            screw = ["screw1", "screw2"]
            nut = "nut"
            axis_motor = "axis_motor"
            axis = "y"

            [sensor_noise]
            noise_C = 0.03
            quantization_C = 0.125
            offset_C = 0.15

            [sensors.T1_C]
            weights = { front_housing = 0.8, air = 0.2 }   # or "room"
            kind = "surface"                 # surface, embedded or air
            location = "front housing"

            [sensors.T2_C]
            node = "motor"                   # one node: weights = { motor = 1 }

            [displacement]
            noise_um = 0.3
            [displacement.z]                 # µm per K of node rise
            spindle = 1.2
            screw = 4.0                      # the whole ball screw

            [effects.sensor_lag]             # optional: switch and parameters
            on = true
            tau_s = 300.0
            [effects.sensor_drift]
            on = false

            [groups]
            spindle = ["T1_C"]

            [params]                         # any parameter by its name,
            "q.cutting_W" = 5.0              # quoted (the name holds dots)

        Missing numbers take the defaults of an empty machine (no heat, no
        displacement); a misspelt field or name is an error naming the entry.
        An effect without ``on`` takes its default (every effect but
        ``sensor_drift`` is on), as in files written before the switches were
        recorded. Sensors are run-table columns ``T<name>_C``; their weights
        are not negative and sum to 1. The roles ``enclosure`` and ``tool``
        are required unless a node carries that name. ``[params]`` sets any
        parameter by name (:meth:`known_parameters`); where it sets a number
        an entry gives too (``"C.spindle"`` and ``[nodes.spindle]
        capacity_J_per_K``) with another value, the ``[params]`` value is
        used and a warning names both places.
        """
        if not isinstance(data, dict):
            raise ValueError(f"A machine spec is a dict, got {type(data).__name__}.")
        top = (
            "name",
            "description",
            "axes",
            "roles",
            "nodes",
            "links",
            "heat",
            "sensor_noise",
            "sensors",
            "displacement",
            "effects",
            "groups",
            "params",
        )
        _check_fields("machine spec", data, top)
        for key in ("name", "nodes"):
            if key not in data:
                raise ValueError(f"machine spec: the field {key!r} is required.")
        p = {}
        nodes = data["nodes"]
        if not isinstance(nodes, dict) or not nodes:
            raise ValueError(
                "nodes must be a table with one entry per node "
                "([nodes.<name>] capacity_J_per_K = ...), "
                f"got {type(nodes).__name__} {nodes!r}."
            )
        for n, entry in nodes.items():
            _check_fields(f"node {n!r}", entry, NODE_FIELDS)
            if "capacity_J_per_K" not in entry:
                raise ValueError(f"node {n!r}: capacity_J_per_K is required.")
            p[f"C.{n}"] = _number(
                f"node {n!r}: capacity_J_per_K",
                entry["capacity_J_per_K"],
                positive=True,
            )
            p[f"hA.{n}"] = _number(
                f"node {n!r}: convection_W_per_K",
                entry.get("convection_W_per_K", 0),
                nonnegative=True,
            )
        edges = []
        links = data.get("links", [])
        if not isinstance(links, list | tuple):
            raise ValueError(
                "links must be a list of tables ([[links]] between = [...]), "
                f"got {type(links).__name__}."
            )
        for i, link in enumerate(links):
            pair = link.get("between") if isinstance(link, dict) else None
            well_formed = (
                isinstance(pair, list | tuple)
                and len(pair) == 2
                and all(isinstance(x, str) for x in pair)
            )
            # Named by its nodes when it has them; else by its position
            # among the [[links]] tables, counted from 1 as in the file.
            label = f"link '{pair[0]}-{pair[1]}'" if well_formed else f"link {i + 1}"
            _check_fields(label, link, ("between", "conductance_W_per_K"))
            if not well_formed:
                raise ValueError(
                    f"{label}: 'between' must list two node names, got {pair!r}."
                )
            a, b = pair
            if "conductance_W_per_K" not in link:
                raise ValueError(f"{label}: conductance_W_per_K is required.")
            edges.append((a, b))
            p[f"G.{a}-{b}"] = _number(
                f"{label}: conductance_W_per_K",
                link["conductance_W_per_K"],
                nonnegative=True,
            )
        roles = data.get("roles", {})
        _check_fields("roles", roles, ("enclosure", "tool", "head", "exposed"))
        for role, meaning in REQUIRED_ROLES.items():
            if role not in roles and role not in nodes:
                raise ValueError(
                    f"roles: {role} is required ({meaning}; [roles] {role} = "
                    f'"<node>") unless a node is named {role!r}; nodes: '
                    f"{list(map(str, nodes))}."
                )
        for role in REQUIRED_ROLES:
            if role in roles:
                _node(f"role {role!r}", roles[role], nodes)
        kw = {
            "enclosure": roles.get("enclosure", "enclosure"),
            "tool": roles.get("tool", "tool"),
            "head_nodes": _check_names("roles: head", roles.get("head", ())),
            "exposed_nodes": _check_names("roles: exposed", roles.get("exposed", ())),
        }
        for role in ("head", "exposed"):
            for value in kw[f"{role}_nodes"]:
                _node(f"roles: {role}", value, nodes)
        heat = data.get("heat", {})
        _check_fields(
            "heat",
            heat,
            (*HEAT_FIELDS, "feed", "custom"),
            hint=(
                ". Another heat source (a pump, a hydraulic unit) is "
                "[heat.custom.{key}], with its node and power"
            ),
        )
        for source, fields in HEAT_FIELDS.items():
            entry = heat.get(source, {})
            _check_fields(f"heat source {source!r}", entry, ("node", *fields))
            if source in heat and "node" not in entry:
                # Left out, the source would heat a stand-in node (the tool).
                raise ValueError(
                    f"heat source {source!r}: node is required (the node it "
                    f"heats); a machine without it leaves [heat.{source}] out."
                )
            if "node" in entry:
                kw[HEAT_ROLES[source]] = _node(
                    f"heat source {source!r}", entry["node"], nodes
                )
            for f, (key, _) in fields.items():
                if f in entry:
                    p[key] = _number(f"heat source {source!r}: {f}", entry[f])
        feed = heat.get("feed")
        if feed is not None:
            _check_fields(
                "heat source 'feed'",
                feed,
                ("screw", "nut", "axis_motor", "axis"),
                hint=(
                    ". The feed's friction loss is the feed_heating effect's: "
                    "[effects.feed_heating] W_per_m_min = ..."
                ),
            )
            if not feed.get("screw"):
                raise ValueError(
                    "heat source 'feed': [heat.feed] needs screw = [...] (the "
                    "ball-screw nodes, from the fixed bearing on); a machine "
                    "without a ball screw leaves [heat.feed] out."
                )
            kw["screw_nodes"] = _check_names(
                "heat source 'feed': screw", feed.get("screw", ())
            )
            for value in kw["screw_nodes"]:
                _node("heat source 'feed': screw", value, nodes)
            for role in ("nut", "axis_motor"):
                if feed.get(role) is not None:
                    _node(f"heat source 'feed': {role}", feed[role], nodes)
            kw["nut"] = feed.get("nut")
            kw["axis_motor"] = feed.get("axis_motor")
            if "axis" in feed:
                kw["feed_axis"] = feed["axis"]
        custom = heat.get("custom", {})
        _check_fields("heat.custom", custom, list(custom or ()))
        kw["custom_heat"] = {}
        for source, entry in custom.items():
            where = f"heat source {source!r}"
            _check_fields(where, entry, ("node", *CUSTOM_HEAT_FIELDS))
            if "node" not in entry:
                raise ValueError(f"{where}: node is required.")
            kw["custom_heat"][source] = _node(where, entry["node"], nodes)
            for f in CUSTOM_HEAT_FIELDS:
                if f in entry:
                    p[f"q.{source}.{f}"] = _number(
                        f"{where}: {f}", entry[f], nonnegative=f != "alpha"
                    )
        for source in ("bearing", "drive", "belt", "cutting"):
            if HEAT_ROLES[source] not in kw:
                # No such source: heat a node that exists, with zero power.
                kw[HEAT_ROLES[source]] = (
                    kw["tool"] if kw["tool"] in nodes else next(iter(nodes), "")
                )
        # The numbers the entries give (not the defaults): [params] may
        # override them, but not silently.
        given = set(p)
        for key, value in NUMBER_DEFAULTS.items():
            p.setdefault(key, value)
        noise = data.get("sensor_noise", {})
        _check_fields("sensor_noise", noise, SENSOR_FIELDS)
        for f, key in SENSOR_FIELDS.items():
            if f in noise:
                p[key] = _number(f"sensor_noise: {f}", noise[f], nonnegative=True)
                given.add(key)
        sensors = []
        sensor_table = data.get("sensors", {})
        _check_fields("sensors", sensor_table, list(sensor_table or ()))
        for name, entry in sensor_table.items():
            _check_fields(
                f"sensor {name!r}",
                entry,
                ("weights", "node", "kind", "location", *SENSOR_FIELDS),
            )
            if "node" in entry:
                # Shorthand for a sensor on one node: node = "housing".
                if "weights" in entry:
                    raise ValueError(
                        f"sensor {name!r}: give either node (one node) or "
                        "weights (a mix of nodes), not both."
                    )
                if not isinstance(entry["node"], str):
                    raise ValueError(
                        f"sensor {name!r}: node must be a node name, got "
                        f"{entry['node']!r}."
                    )
                entry = {**entry, "weights": {entry["node"]: 1.0}}
            if "weights" not in entry:
                raise ValueError(f"sensor {name!r}: weights (or node) is required.")
            if not isinstance(entry["weights"], dict):
                raise ValueError(
                    f"sensor {name!r}: weights must be a table of node weights "
                    f"(node or 'room' = weight), got {entry['weights']!r}."
                )
            sensors.append(
                SensorSpec(
                    name,
                    {
                        node: _number(f"sensor {name!r}: weight of {node!r}", w)
                        for node, w in entry["weights"].items()
                    },
                    entry.get("kind", "surface"),
                    entry.get("location", ""),
                    **{
                        f: _number(f"sensor {name!r}: {f}", entry[f], nonnegative=True)
                        for f in SENSOR_FIELDS
                        if f in entry
                    },
                )
            )
        disp = data.get("displacement", {})
        if "axes" in data:
            axes = _check_names("axes", data["axes"])
        else:
            # The axes of the [displacement.<axis>] tables, as written.
            tables = [
                k
                for k, v in (disp.items() if isinstance(disp, dict) else ())
                if k != "noise_um" and isinstance(v, dict)
            ]
            axes = _check_names("axes", tables or ("x", "y", "z"))
        for a in axes:
            _check_axis(a)
        if feed is not None and "axis" in feed and feed["axis"] not in axes:
            raise _unknown("heat source 'feed': axis", feed["axis"], axes, "axis")
        if isinstance(disp, dict):
            for key, value in disp.items():
                if key not in axes and key != "noise_um" and isinstance(value, dict):
                    raise ValueError(
                        f"displacement: the table {key!r} names no axis of the "
                        f"machine (axes = {list(axes)}); add it to axes or "
                        "rename it."
                    )
        _check_fields("displacement", disp, ("noise_um", *axes))
        if "noise_um" in disp:
            p["disp.noise_um"] = _number(
                "displacement: noise_um", disp["noise_um"], nonnegative=True
            )
            given.add("disp.noise_um")
        for axis in axes:
            p.update({f"k.{axis}.{n}": 0.0 for n in nodes})
            coefficients = disp.get(axis, {})
            # Keys are nodes (and the ball screw on a machine with one): a
            # misspelt one is an unknown node.
            known = [*nodes, *(["screw"] if feed is not None else [])]
            if not isinstance(coefficients, dict):
                _check_fields(f"displacement {axis!r}", coefficients, known)
            for node in coefficients:
                if node == "noise_um":
                    raise ValueError(
                        f"displacement {axis!r}: noise_um is a field of "
                        "[displacement] itself (the noise of every displacement "
                        "channel, µm), not of an axis; write it beside the "
                        "axes' tables."
                    )
                if node == "screw" and feed is None:
                    raise ValueError(
                        f"displacement {axis!r}: screw: the ball screw's growth "
                        "counts only on a machine with a ball screw ([heat.feed] "
                        "screw = [...]), which this machine has not."
                    )
                if node not in known:
                    raise _unknown(f"displacement {axis!r}", node, known)
            for node, value in coefficients.items():
                p[f"k.{axis}.{node}"] = _number(f"displacement {axis!r}: {node}", value)
                given.add(f"k.{axis}.{node}")
        effects = data.get("effects", {})
        _check_fields("effects", effects, EFFECTS)
        switches = {}
        for e, values in effects.items():
            _check_fields(f"effect {e!r}", values, ("on", *EFFECTS[e].params))
            for k, v in values.items():
                if k == "on":
                    switches[e] = v  # checked by validate
                else:
                    p[f"{e}.{k}"] = _number(f"effect {e!r}: {k}", v)
                    given.add(f"{e}.{k}")
        extra = data.get("params", {})
        _check_fields("params", extra, list(extra or ()))
        for key, value in extra.items():
            if isinstance(value, dict):
                # TOML reads an unquoted dotted key (q.bearing_W = 6.0) as
                # nested tables {"q": {"bearing_W": 6.0}}.
                path, inner = [key], value
                while isinstance(inner, dict) and len(inner) == 1:
                    (k, inner), *_ = inner.items()
                    path.append(k)
                name = ".".join(map(str, path))
                raise ValueError(
                    f"params: {key!r} is a table, not a number; a parameter "
                    "name holds dots, which TOML reads as nested tables unless "
                    f'the name is quoted: write "{name}" = ... (with the quotes).'
                )
        # [params] comes last and wins; a number its own entry gives too is
        # an override, said out loud (once the spec is valid).
        overridden = [
            (key, p[key], value)
            for key, value in extra.items()
            if key in given and not _same_number(p[key], value)
        ]
        p.update(extra)
        group_table = data.get("groups", {})
        _check_fields("groups", group_table, list(group_table or ()))
        groups = {
            g: list(_check_names(f"group {g!r}", m)) for g, m in group_table.items()
        }
        spec = cls(
            name=data["name"],
            description=data.get("description", ""),
            nodes=tuple(nodes),
            edges=tuple(edges),
            sensors=tuple(sensors),
            axes=axes,
            groups=groups,
            params=p,
            effects=switches,
            **kw,
        )
        for key, entry_value, value in overridden:
            warnings.warn(
                f"params: {key!r} = {shown(value)} overrides "
                f"{parameter_entry(key)} = {shown(entry_value)} (one "
                "parameter, given twice); the [params] value is used. Give "
                "each number in one place.",
                UserWarning,
                stacklevel=2,
            )
        return spec

    @classmethod
    def from_toml(cls, path):
        """Read a machine file (TOML, layout of :meth:`from_dict`)."""
        path = Path(path)
        try:
            with path.open("rb") as f:
                data = tomllib.load(f)
        except FileNotFoundError:
            raise FileNotFoundError(f"No machine file {str(path)!r}.") from None
        except IsADirectoryError:
            raise IsADirectoryError(
                f"{path}: a directory, not a machine file (TOML)."
            ) from None
        except UnicodeDecodeError as exc:
            raise ValueError(
                f"{path}: not a UTF-8 text file (byte {exc.start}: {exc.reason}); "
                "a machine file is TOML, which is UTF-8."
            ) from None
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: not a valid TOML file ({exc}).") from None
        except OSError as exc:
            raise OSError(
                f"{path}: cannot read the machine file ({exc.strerror or exc})."
            ) from None
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                spec = cls.from_dict(data)
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None
        for w in caught:
            # The file's warnings name the file, as its errors do.
            warnings.warn(f"{path}: {w.message}", w.category, stacklevel=2)
        return spec

    def to_toml(self, path=None):
        """The spec as TOML text; written to ``path`` if given."""
        text = dumps_toml(self.to_dict())
        if path is not None:
            Path(path).write_text(text, encoding="utf-8")
        return text


# --- a small TOML writer (the standard library only reads TOML) ------------


BARE_KEY_CHARACTERS = frozenset(
    "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-"
)
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n"}
_ESCAPES.update({"\f": "\\f", "\r": "\\r"})


def _key(k):
    # TOML's bare keys are ASCII letters, digits, '_' and '-' only; any
    # other key (non-ASCII, dotted, spaced) is written quoted.
    k = str(k)
    if k and all(c in BARE_KEY_CHARACTERS for c in k):
        return k
    return _string(k)


def _string(s):
    # A basic string: escape the quote, the backslash, every control
    # character (< 0x20) and DEL (0x7F), which TOML forbids raw.
    out = []
    for c in s:
        if c in _ESCAPES:
            out.append(_ESCAPES[c])
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            out.append(f"\\u{ord(c):04X}")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def _value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        return repr(float(v))
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"Cannot write {type(v).__name__} to TOML.")


INLINE_TABLES = ("weights",)


def dumps_toml(data, prefix=()):
    """TOML text of a nested dict of numbers, strings, lists and dicts.

    Sub-dicts become tables, lists of dicts arrays of tables; floats are
    written with ``repr`` so they read back to the same value.
    """
    lines, tables = [], []
    for k, v in data.items():
        if isinstance(v, dict) and k not in INLINE_TABLES:
            tables.append((k, v))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            tables.append((k, v))
        else:
            lines.append(f"{_key(k)} = {_value(v)}")
    out = "\n".join(lines)
    for k, v in tables:
        path = (*prefix, k)
        header = ".".join(_key(x) for x in path)
        if isinstance(v, list):
            for item in v:
                body = dumps_toml(item, path)
                out += f"\n\n[[{header}]]\n{body}".rstrip()
        else:
            body = dumps_toml(v, path)
            out += f"\n\n[{header}]\n{body}".rstrip()
    return out.strip() + ("\n" if not prefix else "")
