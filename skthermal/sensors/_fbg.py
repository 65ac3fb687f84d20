"""Fibre Bragg grating (FBG) strain sensors: temperature correction and
strain channels simulated from node temperatures.

An FBG bonded to the structure reports the strain of the surface under it,
but its Bragg wavelength also shifts with its own temperature, which reads as
an *apparent* strain of 8.64 µm/m per °C (001 §4.2.2.3, §4.6). 001 corrected
it with the low-cost temperature sensor next to each grating instead of a
second, unconstrained grating; :func:`correct_fbg_strain` does that
correction. :func:`add_strain_channels` adds raw grating readings
``S<name>_ue`` to a simulated run table from the simulator's node
temperatures (a stated thermo-elastic model, see :class:`FBGGauge`), so that
fusion of temperatures and strains (001 §5.4) can be tried on simulated runs.
"""

import warnings
from dataclasses import dataclass, field
from numbers import Real

import numpy as np
import pandas as pd
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, validate_params

from skthermal._naming import STRAIN_PATTERN, TEMPERATURE_PATTERN
from skthermal._run_changes import changes_since_first_row
from skthermal.utils._aligned import common_index
from skthermal.utils._runs import (
    check_finite_columns,
    check_frame,
    check_numeric_columns,
    check_table_times,
    frame_run_labels,
)

FBG_SENSITIVITY_UE_PER_C = 8.64
"""Apparent strain of a grating per °C of its own temperature (µε/°C, 001
§4.2.2.3)."""


def _number(value, name):
    if isinstance(value, bool) or not isinstance(value, Real) or not np.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}.")
    return float(value)


def correct_fbg_strain(
    raw_ue,
    temperature_C,
    *,
    reference_C=None,
    sensitivity_ue_per_C=FBG_SENSITIVITY_UE_PER_C,
    groups=None,
):
    """Remove a grating's own temperature sensitivity from its strain reading.

    ``strain = raw - k (T - T_ref)``: the reading of a grating whose
    temperature changed by ``T - T_ref`` contains ``k (T - T_ref)`` of
    apparent strain, ``k`` = 8.64 µε/°C (001 §4.2.2.3), which a co-located
    temperature sensor measures and this function subtracts. What is left is
    the strain of the structure under the grating (its thermal expansion and
    its deformation).

    Parameters
    ----------
    raw_ue : array-like of shape (n_samples,) or (n_samples, n_gratings)
        Raw grating readings (µε), zeroed at the reference temperature.
    temperature_C : array-like, broadcastable to ``raw_ue``, first axis n_samples
        Temperature (°C) of the co-located sensor of every grating: one
        column per grating, or one series for all.
    reference_C : float, array-like of shape (n_gratings,) or None, default=None
        Grating temperature at which the readings are zero. None: the
        temperature at the first sample of every run.
    sensitivity_ue_per_C : float, default=8.64
        Apparent strain per °C of grating temperature (of any sign: an
        athermal package can bring it near zero or below).
    groups : array-like of shape (n_samples,), optional
        Run labels; with ``reference_C=None`` every run is referred to its own
        first sample. With a ``reference_C`` they are not needed (a warning
        says so): every run is referred to that temperature.

    Returns
    -------
    ndarray of the shape of ``raw_ue``
        Temperature-corrected strain (µε).

    Examples
    --------
    >>> from skthermal.sensors import correct_fbg_strain
    >>> correct_fbg_strain([0.0, 30.0, 52.0], [20.0, 22.0, 24.0]).round(2).tolist()
    [0.0, 12.72, 17.44]
    """
    k = _number(sensitivity_ue_per_C, "sensitivity_ue_per_C")
    common_index(
        {"raw_ue": raw_ue, "temperature_C": temperature_C, "groups": groups},
        item="samples",
    )
    try:
        raw = np.asarray(raw_ue, dtype=float)
        temp = np.asarray(temperature_C, dtype=float)
    except (TypeError, ValueError):
        raise ValueError("raw_ue and temperature_C must be numeric arrays.") from None
    if raw.ndim not in (1, 2) or raw.shape[0] == 0:
        raise ValueError(
            f"raw_ue must have shape (n_samples,) or (n_samples, n_gratings), got "
            f"{raw.shape}."
        )
    if temp.ndim == 0 or temp.shape[0] != raw.shape[0]:
        raise ValueError(
            f"temperature_C of shape {temp.shape} does not match raw_ue of shape "
            f"{raw.shape}: give one co-located temperature per sample (and per "
            "grating); a constant temperature corrects nothing."
        )
    if temp.ndim == 1 and raw.ndim == 2:
        temp = temp[:, None]
    try:
        temp = np.broadcast_to(temp, raw.shape)
    except ValueError:
        raise ValueError(
            f"temperature_C of shape {np.shape(temperature_C)} does not match "
            f"raw_ue of shape {raw.shape}: give one co-located temperature per "
            "sample (and per grating)."
        ) from None
    for name, a in (("raw_ue", raw), ("temperature_C", temp)):
        bad = ~np.isfinite(a)
        if bad.any():
            row = int(np.argwhere(bad)[0][0])
            raise ValueError(f"{name} is NaN or infinite at sample {row}.")
    if reference_C is None:
        return raw - k * changes_since_first_row(temp, groups)
    if groups is not None:
        warnings.warn(
            "correct_fbg_strain: groups are not used with a reference_C: every "
            "run is referred to that temperature. Give reference_C=None to "
            "refer each run to its own first sample.",
            UserWarning,
            stacklevel=2,
        )
    ref = np.asarray(reference_C, dtype=float)
    if not np.all(np.isfinite(ref)):
        raise ValueError("reference_C must be finite.")
    try:
        ref = np.broadcast_to(ref, raw.shape[1:])
    except ValueError:
        raise ValueError(
            f"reference_C of shape {ref.shape} does not match the "
            f"{raw.shape[1:]} gratings."
        ) from None
    return raw - k * (temp - ref)


@dataclass(frozen=True)
class FBGGauge:
    """Where a grating is bonded and how its member deforms with temperature.

    The raw reading of the grating, change since the start of the run:

    ``S = alpha dT_m + beta (dT_a - dT_b) + k dT_m + noise``

    ``dT_m`` is the temperature rise of the member under the grating (the
    weighted mean of ``nodes``), ``alpha`` its free thermal expansion
    (``expansion_ue_per_C``; the grating is bonded, so it follows the
    surface), ``beta (dT_a - dT_b)`` the bending strain at the surface from a
    temperature difference across the member (``gradient = (a, b)``,
    ``bending_ue_per_C``), and ``k dT_m`` the grating's own apparent strain
    (8.64 µε/°C). Node temperatures are the simulator's, without sensor lag:
    the strain of a member follows its bulk temperature at once, one reason
    why 001 §4.6.1 found less hysteresis in FBG signals than in surface
    temperatures.

    Attributes
    ----------
    nodes : dict
        Node name -> weight (weights sum to one) of the member under the
        grating, e.g. ``{"carrier2": 0.5, "carrier3": 0.5}``.
    expansion_ue_per_C : float, default=11.0
        Thermal expansion of the member (µε/°C; steel ~11.5, cast iron ~10.5).
    gradient : (str, str) or None, default=None
        Nodes ``(a, b)`` whose difference bends the member.
    bending_ue_per_C : float, default=0.0
        Surface strain per °C of ``T_a - T_b``.
    sensor : str or None, default=None
        The co-located temperature column (``T<name>_C``) used for the
        correction by :func:`correct_strain_channels`.
    location : str, default=""
        Where it sits, in words.
    """

    nodes: dict = field(default_factory=dict)
    expansion_ue_per_C: float = 11.0
    gradient: tuple | None = None
    bending_ue_per_C: float = 0.0
    sensor: str | None = None
    location: str = ""


def _check_gauges(gauges, nodes):
    if isinstance(gauges, dict):
        items = list(gauges.items())
    else:
        raise ValueError(
            "gauges must be a dict {name: FBGGauge or dict of FBGGauge fields}."
        )
    if not items:
        raise ValueError("gauges is empty: give at least one grating.")
    out = {}
    for name, g in items:
        column = name if STRAIN_PATTERN.fullmatch(str(name)) else f"S{name}_ue"
        if not STRAIN_PATTERN.fullmatch(column):
            raise ValueError(
                f"Gauge name {name!r} does not make a strain column S<name>_ue "
                "(letters, digits, inner underscores)."
            )
        if isinstance(g, dict):
            try:
                g = FBGGauge(**g)
            except TypeError as exc:
                raise ValueError(f"Gauge {name!r}: {exc}") from None
        if not isinstance(g, FBGGauge):
            raise ValueError(f"Gauge {name!r} must be an FBGGauge or a dict.")
        if not isinstance(g.nodes, dict):
            raise ValueError(
                f"Gauge {name!r}: nodes must be a dict {{node: weight}} (weights "
                f"summing to 1), got {type(g.nodes).__name__} {g.nodes!r}."
            )
        if not g.nodes:
            raise ValueError(f"Gauge {name!r} names no node (nodes={{...}}).")
        used = list(g.nodes) + list(g.gradient or ())
        unknown = [n for n in used if n not in nodes]
        if unknown:
            raise ValueError(
                f"Gauge {name!r}: unknown node(s) {unknown}; the states have "
                f"{list(nodes)}."
            )
        if g.gradient is not None and len(g.gradient) != 2:
            raise ValueError(f"Gauge {name!r}: gradient must be two node names.")
        total = sum(_number(w, f"Gauge {name!r} weight") for w in g.nodes.values())
        if not np.isclose(total, 1.0):
            raise ValueError(
                f"Gauge {name!r}: node weights sum to {total:g}, not 1 (the member "
                "temperature is their weighted mean)."
            )
        _number(g.expansion_ue_per_C, f"Gauge {name!r} expansion_ue_per_C")
        _number(g.bending_ue_per_C, f"Gauge {name!r} bending_ue_per_C")
        if g.sensor is not None and not TEMPERATURE_PATTERN.fullmatch(str(g.sensor)):
            raise ValueError(
                f"Gauge {name!r}: sensor {g.sensor!r} is not a temperature column "
                "T<name>_C."
            )
        if column in out:
            raise ValueError(f"Two gauges make the column {column!r}.")
        out[column] = g
    return out


@validate_params(
    {
        "runs": "no_validation",  # checked with the states, naming both
        "states": "no_validation",
        "gauges": "no_validation",
        "sensitivity_ue_per_C": "no_validation",  # as in correct_fbg_strain
        "noise_ue": [Interval(Real, 0, np.inf, closed="left")],
        "random_state": ["random_state"],
    },
    prefer_skip_nested_validation=True,
)
def add_strain_channels(
    runs,
    states,
    gauges,
    *,
    sensitivity_ue_per_C=FBG_SENSITIVITY_UE_PER_C,
    noise_ue=0.5,
    random_state=None,
):
    """Add raw FBG readings ``S<name>_ue`` computed from node temperatures.

    Every gauge follows the model of :class:`FBGGauge` on the node
    temperatures of the run (change since the start of each run), plus
    Gaussian reading noise. The readings are *raw*: they include the
    grating's own temperature sensitivity, which
    :func:`correct_strain_channels` (or :func:`correct_fbg_strain`) removes
    with a co-located temperature sensor.

    Parameters
    ----------
    runs : DataFrame
        A run table (a ``run`` column separates runs).
    states : DataFrame
        Node temperatures, one row per row of ``runs`` in the same order, as
        returned by ``ThermalMachine.simulate(..., return_states=True)``
        (concatenate them in the order of the runs for several runs).
    gauges : dict
        ``{name: FBGGauge}`` (or a dict of its fields); column ``S<name>_ue``
        (a name already of that form is kept).
    sensitivity_ue_per_C : float, default=8.64
        The grating's apparent strain per °C.
    noise_ue : float, default=0.5
        Standard deviation of the reading noise (µε).
    random_state : int, RandomState instance or None

    Returns
    -------
    DataFrame
        A copy of ``runs`` with one column per gauge appended; its
        ``attrs["fbg_gauges"]`` records the gauges (with those recorded by
        earlier calls).

    Examples
    --------
    >>> from skthermal.simulate import DutyCycle, ThermalMachine
    >>> from skthermal.sensors import FBGGauge, add_strain_channels
    >>> machine = ThermalMachine.from_preset("vmc-b")
    >>> runs, states = machine.simulate(DutyCycle.heat_cool(8000, heat_h=1, cool_h=1),
    ...                                 random_state=0, return_states=True)
    >>> gauges = {"carrier": FBGGauge({"carrier2": 0.5, "carrier3": 0.5},
    ...                               sensor="T15_C")}
    >>> runs = add_strain_channels(runs, states, gauges, random_state=0)
    >>> member = states[["carrier2", "carrier3"]].mean(axis=1)
    >>> rise = member - member.iloc[0]
    >>> bool(abs(runs["Scarrier_ue"].iloc[120] - 19.64 * rise.iloc[120]) < 2.0)
    True
    """
    if not isinstance(runs, pd.DataFrame) or not isinstance(states, pd.DataFrame):
        raise ValueError("runs and states must be pandas DataFrames.")
    if len(runs) != len(states):
        raise ValueError(
            f"states has {len(states)} rows for {len(runs)} rows of runs; give the "
            "node temperatures of every row, in the same order."
        )
    if len(runs) == 0:
        raise ValueError("runs is empty.")
    k = _number(sensitivity_ue_per_C, "sensitivity_ue_per_C")
    noise = float(noise_ue)
    _check_unique(states, "states")
    check_numeric_columns(states)
    checked = _check_gauges(gauges, states.columns)
    clash = [c for c in checked if c in runs.columns]
    if clash:
        raise ValueError(f"runs already has the strain column(s) {clash}.")
    T = states.to_numpy(dtype=float)
    if not np.all(np.isfinite(T)):
        row = int(np.argwhere(~np.isfinite(T))[0][0])
        raise ValueError(f"states is NaN or infinite at row {row}.")
    groups = frame_run_labels(runs)
    check_table_times(runs, groups)
    dT = changes_since_first_row(T, groups)
    index = {n: i for i, n in enumerate(states.columns)}
    # Gauges are linear in the node rises: one matrix product for all of them.
    G = np.zeros((len(index), len(checked)))
    for j, g in enumerate(checked.values()):
        for node, w in g.nodes.items():
            G[index[node], j] += w * (g.expansion_ue_per_C + k)
        if g.gradient is not None:
            a, b = g.gradient
            G[index[a], j] += g.bending_ue_per_C
            G[index[b], j] -= g.bending_ue_per_C
    rng = check_random_state(random_state)
    S = dT @ G + rng.normal(0.0, noise, (len(runs), len(checked)))
    out = runs.copy()
    for j, column in enumerate(checked):
        out[column] = S[:, j]
    # Gauges added by an earlier call stay recorded (and uncorrected).
    out.attrs["fbg_gauges"] = {**runs.attrs.get("fbg_gauges", {}), **checked}
    return out


def _check_unique(frame, name):
    duplicated = frame.columns[frame.columns.duplicated()].unique().tolist()
    if duplicated:
        raise ValueError(
            f"{name} has duplicate column(s) {duplicated}; every column name must "
            "be unique."
        )


def correct_strain_channels(
    runs, colocated=None, *, sensitivity_ue_per_C=FBG_SENSITIVITY_UE_PER_C
):
    """Temperature-correct strain columns of a run table, run by run.

    Parameters
    ----------
    runs : DataFrame
        A run table with raw strain columns ``S<name>_ue``.
    colocated : dict or None, default=None
        ``{strain column: temperature column}``, the co-located sensor of
        every grating to correct. None: the ``sensor`` of every gauge recorded
        in ``runs.attrs["fbg_gauges"]`` by :func:`add_strain_channels`.
    sensitivity_ue_per_C : float, default=8.64

    Returns
    -------
    DataFrame
        A copy with the listed strain columns corrected (same names), each
        referred to the co-located temperature at the start of its run; its
        ``attrs["fbg_corrected"]`` lists the corrected columns, which a
        second call refuses to correct again.

    Examples
    --------
    >>> import pandas as pd
    >>> from skthermal.sensors import correct_strain_channels
    >>> runs = pd.DataFrame({"run": ["a", "a", "b", "b"],
    ...                      "time_s": [0.0, 60.0, 0.0, 60.0],
    ...                      "T1_C": [20.0, 21.0, 25.0, 27.0],
    ...                      "Sram_ue": [0.0, 20.0, 0.0, 40.0]})
    >>> correct_strain_channels(runs, {"Sram_ue": "T1_C"})["Sram_ue"].round(2).tolist()
    [0.0, 11.36, 0.0, 22.72]
    """
    check_frame(runs, "runs (a run table)")
    done = list(runs.attrs.get("fbg_corrected", []))
    if colocated is None:
        recorded = runs.attrs.get("fbg_gauges", {})
        colocated = {
            c: g.sensor
            for c, g in recorded.items()
            if g.sensor is not None and c not in done
        }
        if not colocated:
            raise ValueError(
                "Give colocated={strain column: temperature column}; the table "
                "records no uncorrected gauge with a co-located sensor"
                + (f" (already corrected: {done})." if done else ".")
            )
    if not isinstance(colocated, dict) or not colocated:
        raise ValueError("colocated must be a non-empty dict {strain: temperature}.")
    again = [c for c in colocated if c in done]
    if again:
        raise ValueError(
            f"The strain column(s) {again} are already temperature-corrected (by "
            "an earlier correct_strain_channels on this table); correcting again "
            "would subtract the grating's sensitivity twice."
        )
    _check_unique(runs, "runs")
    for s, t in colocated.items():
        for col, pattern, what in (
            (s, STRAIN_PATTERN, "strain"),
            (t, TEMPERATURE_PATTERN, "temperature"),
        ):
            if col not in runs.columns:
                raise ValueError(f"The {what} column {col!r} is not in the table.")
            if not pattern.fullmatch(str(col)):
                raise ValueError(f"{col!r} is not a {what} column name.")
    if len(runs) == 0:
        raise ValueError("runs is empty: no rows to correct.")
    strain = list(colocated)
    groups = frame_run_labels(runs)
    used = runs[list(dict.fromkeys([*strain, *colocated.values()]))]
    check_numeric_columns(used, groups)
    check_finite_columns(
        used.astype(float),
        groups,
        what="runs",
        hint="Every reading of a corrected grating and of its co-located "
        "sensor is needed: impute or drop those rows first.",
    )
    check_table_times(runs, groups)
    corrected = correct_fbg_strain(
        runs[strain].to_numpy(dtype=float),
        runs[[colocated[s] for s in strain]].to_numpy(dtype=float),
        sensitivity_ue_per_C=sensitivity_ue_per_C,
        groups=groups,
    )
    out = runs.copy()
    out[strain] = corrected
    out.attrs["fbg_corrected"] = [*done, *strain]
    return out
