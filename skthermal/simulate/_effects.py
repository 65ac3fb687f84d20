"""The named vocabulary of switchable physical effects.

Each effect is a component a simulation may include or leave out, with its own
parameters and a short physical explanation. The sim-to-real gap diagnosis
adds them one at a time to explain where a simulation and a measurement
disagree, so the names and meanings are part of the public API.
"""

from dataclasses import dataclass, field

import pandas as pd


@dataclass(frozen=True)
class Effect:
    """One switchable physical effect.

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
    """

    name: str
    summary: str
    params: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)


EFFECTS = {
    e.name: e
    for e in [
        Effect(
            "sensor_lag",
            "Surface-mounted sensors read the skin of a part through a contact "
            "resistance and their own mass, so they lag the structure they sit "
            "on: heating and cooling trace different loops in a "
            "temperature-displacement plot (hysteresis).",
            {"tau_s": 480.0},
            {"tau_s": "s"},
        ),
        Effect(
            "speed_convection",
            "A turning spindle stirs the air around the head: the convection of "
            "the spindle, boss, carrier and motor grows with speed, roughly as "
            "(n / 1000 rpm)^0.8 (forced convection), so the machine runs cooler "
            "at speed than still-air convection predicts.",
            {"gain": 0.2, "exponent": 0.8},
            {"gain": "1", "exponent": "1"},
        ),
        Effect(
            "tool_growth",
            "The test bar (tool) is cooled by the air it churns while it turns. "
            "When the spindle stops, that cooling stops while heat from the hot "
            "spindle nose keeps flowing in, so the tool keeps growing after the "
            "stop (001 §4.4). Without this effect the tool is taken as rigid.",
            {"hA_rotating": 2.5},
            {"hA_rotating": "W/K at 1000 rpm"},
        ),
        Effect(
            "ambient_transient",
            "Exposed surfaces (column skin, carrier, head, tool, base) are "
            "washed by the workshop air itself, so fast air events such as an "
            "opened door reach the structure within minutes. Without this "
            "effect the structure only sees the air inside the enclosure, which "
            "smooths the workshop air over about an hour.",
            {},
            {},
        ),
        Effect(
            "feed_heating",
            "Friction in the ball screw and nut heats the screw in proportion "
            "to |feed|, along the stretch the nut travels; the screw's growth "
            "between its fixed bearing and the nut moves the axis, so the error "
            "depends on position. Part of the heat goes to the nut and the axis "
            "motor.",
            {
                "W_per_m_min": 4.0,
                "stroke": 1.0,
                "measure_at": 0.5,
                "nut_share": 0.25,
                "motor_share": 0.25,
            },
            {
                "W_per_m_min": "W per m/min",
                "stroke": "fraction of travel",
                "measure_at": "fraction of travel",
                "nut_share": "1",
                "motor_share": "1",
            },
        ),
        Effect(
            "sensor_drift",
            "Temperature sensors drift slowly (ageing, connector thermo-EMF): "
            "each reading gains an offset that grows linearly at a random rate "
            "plus a slow random walk.",
            {"rate_C_per_h": 0.01, "walk_C_per_sqrt_h": 0.01},
            {"rate_C_per_h": "°C/h (std over sensors)", "walk_C_per_sqrt_h": "°C/√h"},
        ),
    ]
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


def check_effects(effects):
    """Validate effect names; returns them as a tuple in vocabulary order."""
    if isinstance(effects, str):
        effects = [effects]
    effects = list(effects)
    unknown = [e for e in effects if e not in EFFECTS]
    if unknown:
        raise ValueError(
            f"Unknown effect(s) {unknown}; the vocabulary is {list(EFFECTS)}."
        )
    return tuple(e for e in EFFECTS if e in effects)
