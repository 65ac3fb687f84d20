"""The named vocabulary of switchable physical effects.

Each effect is a component a simulation may include or leave out, with its own
parameters and a short physical explanation. The sim-to-real gap diagnosis
adds them one at a time to explain where a simulation and a measurement
disagree, so the names and meanings are part of the public API.
"""

import functools
import math
import zlib
from typing import NamedTuple

import numpy as np
import pandas as pd

from skthermal._naming import suggest
from skthermal.simulate._solver import first_order_lag


class ParameterRange(NamedTuple):
    """The valid values of one parameter: ``low`` to ``high``.

    ``low_open`` excludes ``low`` itself (a heat capacity is positive, not
    zero); ``high`` is always included. ``rule`` says it in words, as the
    error messages do.
    """

    low: float
    high: float
    low_open: bool
    rule: str
    hint: str = ""

    def __contains__(self, value):
        above = value > self.low if self.low_open else value >= self.low
        return bool(above and value <= self.high)

    def __str__(self):
        left = "(" if self.low_open else "["
        right = "]" if math.isfinite(self.high) else ")"
        return f"{left}{self.low:g}, {self.high:g}{right}"


ANY = ParameterRange(-math.inf, math.inf, False, "must be a finite number")
NOT_NEGATIVE = ParameterRange(0.0, math.inf, False, "must not be negative")
POSITIVE = ParameterRange(0.0, math.inf, True, "must be positive")
FRACTION = ParameterRange(0.0, 1.0, False, "must lie in [0, 1]")


class Effect:
    """One switchable physical effect: its parameters and its physics.

    An effect owns everything about itself: default parameters and units,
    their valid ranges, the parameter the gap diagnosis frees when it tests
    the effect, and its change to the machine, through hooks the simulator
    calls while the effect is on.
    Adding an effect to the vocabulary is one new subclass registered in
    ``EFFECTS``.

    Attributes
    ----------
    name : str
        Identifier used in ``ThermalMachine(effects=...)`` and in metadata.
    summary : str
        The physics in a few sentences.
    params : dict
        Default parameter values, stored in the machine as ``"<name>.<param>"``.
    units : dict
        Unit of each parameter.
    ranges : dict
        Valid range (:class:`ParameterRange`) of each parameter that is not
        simply "not negative" (the default).
    diagnosis_parameter : str or None
        The parameter (full name) the gap diagnosis calibrates when it adds
        this effect; None for a switch without a free parameter.
    residual : bool
        True for an effect the diagnosis models on the residual instead of
        simulating it (a random process such as sensor drift).
    default_on : bool
        Whether a machine has the effect on when neither its description nor
        the caller says otherwise (see :func:`default_effects`).
    shares : tuple of str
        Parameters (short names) that are fractions of one whole: their sum
        must not exceed 1 (:meth:`check_joint`); ``calibrate`` keeps a joint
        fit of them inside that limit.
    """

    name = ""
    summary = ""
    params = {}
    units = {}
    ranges = {}
    diagnosis_parameter = None
    residual = False
    default_on = True
    shares = ()

    def __repr__(self):
        return f"Effect({self.name!r})"

    def parameter_range(self, key):
        """The valid range of this effect's parameter ``key`` (short name)."""
        return self.ranges.get(key, NOT_NEGATIVE)

    def check(self, params):
        """Validate this effect's parameters in the machine's ``params``:
        each in its range (:meth:`parameter_range`), then the joint rules
        of the effect, if any (:meth:`check_joint`)."""
        for key in self.params:
            full = f"{self.name}.{key}"
            value = params[full]
            valid = self.parameter_range(key)
            if value not in valid:
                raise ValueError(
                    f"Parameter {full!r} {valid.rule}, got {value}{valid.hint}."
                )
        self.check_joint(params)

    def check_joint(self, params):
        """Rules that tie several of the effect's parameters: the
        :attr:`shares` sum to at most 1."""
        if not self.shares:
            return
        names = [f"{self.name}.{k}" for k in self.shares]
        total = sum(params[k] for k in names)
        if total > 1:
            terms = " + ".join(f"{k} ({params[k]:g})" for k in names)
            raise ValueError(
                f"{terms} = {total:g} must not exceed 1 (they are fractions "
                "of one heat flow)."
            )

    def missing(self, spec):
        """What the machine description ``spec`` (a ``MachineSpec``) lacks
        for this effect to act on it, in words; None when nothing is
        missing. The gap diagnosis lists such an effect as not applicable,
        with this reason."""
        return None

    # Hooks; ``machine`` is the ThermalMachine, ``p`` its parameters.

    def convection(self, machine, p, rpm, h):
        """Change the convection conductances ``h`` (W/K) at speed ``rpm``."""
        return h

    def exposed_nodes(self, machine):
        """Nodes that convect to the workshop air instead of the enclosure."""
        return ()

    def heat(self, machine, p, rpm, feed, cols, sources):
        """Add heat inputs (W) to ``cols`` (node -> array), in place."""

    def displacement(self, machine, p, M):
        """Change the thermo-elastic map ``M`` (axes x nodes), in place."""

    def read(self, machine, p, x, lagged, dt):
        """Change noise-free sensor readings ``x`` (n x sensors)."""
        return x

    def noise(self, machine, p, x, t, dt, rng):
        """Change noisy sensor readings ``x``."""
        return x


class SensorLag(Effect):
    name = "sensor_lag"
    summary = (
        "Surface-mounted sensors read the skin of a part through a contact "
        "resistance and their own mass, so they lag the structure they sit "
        "on: heating and cooling trace different loops in a "
        "temperature-displacement plot (hysteresis)."
    )
    params = {"tau_s": 480.0}
    units = {"tau_s": "s"}
    ranges = {
        "tau_s": ParameterRange(
            0.0,
            86400.0,
            True,
            "must lie in (0, 86400] s (up to a day)",
            "; a sensor lags its part by seconds to minutes",
        )
    }
    diagnosis_parameter = "sensor_lag.tau_s"

    def missing(self, spec):
        if not any(s.kind == "surface" for s in spec.sensors):
            return (
                "the machine has no surface-mounted sensor to lag (a sensor's "
                'kind = "surface")'
            )
        return None

    def read(self, machine, p, x, lagged, dt):
        if lagged.any():
            x[:, lagged] = first_order_lag(x[:, lagged], p["sensor_lag.tau_s"], dt)
        return x


class SpeedConvection(Effect):
    name = "speed_convection"
    summary = (
        "A turning spindle stirs the air around the head: the convection of "
        "the spindle, boss, carrier and motor grows with speed, roughly as "
        "(n / 1000 rpm)^0.8 (forced convection), so the machine runs cooler "
        "at speed than still-air convection predicts."
    )
    params = {"gain": 0.2, "exponent": 0.8}
    units = {"gain": "1", "exponent": "1"}
    ranges = {
        "gain": ParameterRange(
            0.0,
            20.0,
            False,
            "must lie in [0, 20]",
            "; the convection grows by gain * (n / 1000 rpm)^exponent, "
            "typically 0.1 to 1",
        ),
        "exponent": ParameterRange(
            0.0,
            2.0,
            False,
            "must lie in [0, 2]",
            "; forced convection grows as the air speed^0.5 to ^0.8",
        ),
    }
    diagnosis_parameter = "speed_convection.gain"

    def missing(self, spec):
        if not spec.head_nodes:
            return (
                "the machine has no head nodes whose convection grows with "
                "speed ([roles] head = [...]); tool_growth, which also cools "
                "with speed, can stand in for it"
            )
        return None

    def convection(self, machine, p, rpm, h):
        if rpm > 0:
            gain = (
                p["speed_convection.gain"]
                * (rpm / 1000.0) ** p["speed_convection.exponent"]
            )
            index = machine.node_index
            for n in machine.spec.head_nodes:
                h[index[n]] *= 1.0 + gain
        return h


class ToolGrowth(Effect):
    name = "tool_growth"
    summary = (
        "The test bar (tool) is cooled by the air it churns while it turns. "
        "When the spindle stops, that cooling stops while heat from the hot "
        "spindle nose keeps flowing in, so the tool keeps growing after the "
        "stop (001 §4.4). Without this effect the tool still expands, but "
        "only still air cools it, turning or not."
    )
    params = {"hA_rotating": 2.5}
    units = {"hA_rotating": "W/K at 1000 rpm"}
    ranges = {
        "hA_rotating": ParameterRange(
            0.0,
            1000.0,
            False,
            "must lie in [0, 1000] W/K",
            "; a turning tool sheds a few W/K at 1000 rpm",
        )
    }
    diagnosis_parameter = "tool_growth.hA_rotating"

    def convection(self, machine, p, rpm, h):
        if rpm > 0:
            h[machine.node_index[machine.spec.tool]] += (
                p["tool_growth.hA_rotating"] * (rpm / 1000.0) ** 0.8
            )
        return h


class AmbientTransient(Effect):
    name = "ambient_transient"
    summary = (
        "Exposed surfaces (column skin, carrier, head, tool, base) are "
        "washed by the workshop air itself, so fast air events such as an "
        "opened door reach the structure within minutes. Without this "
        "effect the structure only sees the air inside the enclosure, which "
        "smooths the workshop air over about an hour."
    )

    def missing(self, spec):
        if not spec.exposed_nodes:
            return (
                "the machine has no nodes washed by the workshop air "
                "([roles] exposed = [...])"
            )
        return None

    def exposed_nodes(self, machine):
        return machine.spec.exposed_nodes


class FeedHeating(Effect):
    name = "feed_heating"
    summary = (
        "Friction in the ball screw and nut heats the screw in proportion "
        "to |feed|, along the stretch the nut travels; the screw's growth "
        "between its fixed bearing and the nut moves the axis, so the error "
        "depends on position. Part of the heat goes to the nut and the axis "
        "motor."
    )
    params = {
        "W_per_m_min": 4.0,
        "stroke": 1.0,
        "measure_at": 0.5,
        "nut_share": 0.25,
        "motor_share": 0.25,
    }
    units = {
        "W_per_m_min": "W per m/min",
        "stroke": "fraction of travel",
        "measure_at": "fraction of travel",
        "nut_share": "1",
        "motor_share": "1",
    }
    ranges = {
        "W_per_m_min": ParameterRange(
            0.0,
            1000.0,
            False,
            "must lie in [0, 1000] W per m/min",
            "; a ball screw and nut lose a few W per m/min of feed",
        ),
        "stroke": FRACTION,
        "measure_at": FRACTION,
        "nut_share": FRACTION,
        "motor_share": FRACTION,
    }
    # The diagnosis gives the feed-driven part its own gain per channel,
    # which sets the screw heating's amplitude; a power parameter on top
    # would only be degenerate with those gains.
    diagnosis_parameter = None
    # The nut and the axis motor take these fractions of the feed heat, the
    # screw the rest.
    shares = ("nut_share", "motor_share")

    def missing(self, spec):
        if not spec.screw_nodes:
            return "the machine has no ball screw ([heat.feed] screw = [...])"
        return None

    def heat(self, machine, p, rpm, feed, cols, sources):
        spec = machine.spec
        if "feed" not in sources or not spec.screw_nodes:
            return
        power = p["feed_heating.W_per_m_min"] * np.abs(np.asarray(feed, float)) / 1000.0
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
            cols[spec.axis_motor] = cols.get(spec.axis_motor, 0.0) + power * motor_share


def sensor_draws(machine, what):
    """One standard normal number per sensor of ``machine``, fixed by the
    machine's and the sensor's names and ``what`` (a property of the sensor
    such as its calibration offset: the same in every run)."""
    names = tuple(s.name for s in machine.spec.sensors)
    return np.array(_draws(machine.name, names, what))


@functools.lru_cache(maxsize=256)
def _draws(machine, sensors, what):
    # Seeding a generator per sensor costs more than simulating a short run:
    # the draws of a machine are made once.
    return tuple(
        np.random.RandomState(
            zlib.crc32(f"{machine}/{s}{what}".encode())
        ).standard_normal()
        for s in sensors
    )


class SensorDrift(Effect):
    name = "sensor_drift"
    summary = (
        "Temperature sensors drift slowly (ageing, connector thermo-EMF): "
        "each reading gains an offset that grows linearly at the sensor's "
        "own random rate (the same in every run) plus a slow random walk."
    )
    params = {"rate_C_per_h": 0.01, "walk_C_per_sqrt_h": 0.01}
    units = {"rate_C_per_h": "°C/h (std over sensors)", "walk_C_per_sqrt_h": "°C/√h"}
    ranges = {
        "rate_C_per_h": ParameterRange(
            0.0,
            10.0,
            False,
            "must lie in [0, 10] °C/h",
            "; sensors drift by hundredths of a degree per hour",
        ),
        "walk_C_per_sqrt_h": ParameterRange(
            0.0,
            10.0,
            False,
            "must lie in [0, 10] °C/√h",
            "; sensors wander by hundredths of a degree per √h",
        ),
    }
    residual = True
    default_on = False

    def noise(self, machine, p, x, t, dt, rng):
        hours = (t - t[0]) / 3600.0
        # The rate belongs to the sensor (its ageing), not to the run: the
        # same sensor drifts at the same rate in every run of the machine.
        # The random walk is new in every run.
        rate = p["sensor_drift.rate_C_per_h"] * sensor_draws(machine, "drift_rate")
        steps = rng.normal(
            0.0,
            p["sensor_drift.walk_C_per_sqrt_h"] * np.sqrt(dt / 3600.0),
            (x.shape[0] - 1, x.shape[1]),
        )
        walk = np.vstack([np.zeros(x.shape[1]), np.cumsum(steps, axis=0)])
        return x + np.outer(hours, rate) + walk


EFFECTS = {
    e.name: e
    for e in (
        SensorLag(),
        SpeedConvection(),
        ToolGrowth(),
        AmbientTransient(),
        FeedHeating(),
        SensorDrift(),
    )
}


def describe_effects():
    """The effect vocabulary as a table.

    Returns
    -------
    DataFrame
        One row per effect: ``effect``, ``summary`` and its default
        ``parameters``.

    Examples
    --------
    >>> from skthermal.simulate import describe_effects
    >>> describe_effects()["effect"].tolist()  # doctest: +NORMALIZE_WHITESPACE
    ['sensor_lag', 'speed_convection', 'tool_growth', 'ambient_transient',
     'feed_heating', 'sensor_drift']
    """
    return pd.DataFrame(
        [
            {
                "effect": e.name,
                "summary": e.summary,
                "parameters": ", ".join(
                    f"{k}={v:g} {e.units.get(k, '')}".rstrip()
                    for k, v in e.params.items()
                ),
            }
            for e in EFFECTS.values()
        ]
    )


def default_effects(switches=None):
    """The effects a machine has on unless told otherwise.

    Parameters
    ----------
    switches : dict, optional
        Effect name -> on (bool), e.g. the switches a machine description
        records (:attr:`MachineSpec.effects`); effects it leaves out take their
        default (every effect except ``sensor_drift``).

    Returns
    -------
    tuple of str
        The effects switched on, in vocabulary order.

    Examples
    --------
    >>> from skthermal.simulate._effects import default_effects
    >>> "sensor_drift" in default_effects()
    False
    >>> default_effects({"sensor_drift": True, "sensor_lag": False})[-1]
    'sensor_drift'
    """
    switches = switches or {}
    return tuple(
        name for name, e in EFFECTS.items() if switches.get(name, e.default_on)
    )


def check_effects(effects):
    """Validate effect names; returns them as a tuple in vocabulary order."""
    if isinstance(effects, str):
        effects = [effects]
    effects = list(effects)
    unknown = [e for e in effects if e not in EFFECTS]
    if unknown:
        raise ValueError(
            f"Unknown effect(s) {unknown}{suggest(unknown[0], EFFECTS)}; the "
            f"vocabulary is {list(EFFECTS)}."
        )
    return tuple(e for e in EFFECTS if e in effects)
