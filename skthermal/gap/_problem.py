"""The numerical core of the gap diagnosis: measured runs, predictions and
calibration.

Gaps are measured on changes since the start of each run (offsets of sensors
and of the displacement zero are not physics; the start is the mean of the
first few compared samples), channel by channel, each
divided by the spread of its group's measurements (displacements in µm,
temperatures in °C). Displacement channels and temperature channels weigh
half each. The noise floor of every channel is
estimated from second differences of its measurement.
"""

import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from skthermal._naming import TEMPERATURE_PATTERN, closest, shown, suggest
from skthermal.datasets._runtable import check_column_names, warn_implausible
from skthermal.simulate import EFFECTS
from skthermal.utils._faults import flat_columns, repair_spikes
from skthermal.utils._noise import pooled_noise
from skthermal.utils._runs import (
    ABSOLUTE_ZERO_C,
    MAX_MAGNITUDE,
    check_labels,
    check_unique_columns,
    driver_lookalike_hint,
    is_clock_dtype,
    warn_short_runs,
)
from skthermal.utils._warnings import user_stacklevel


# Base calibration. The network's time scales are set by three multipliers
# (all capacities, all convection coefficients, the enclosure air's exchange
# with the workshop), fitted by nonlinear least squares.
# Every channel's response is split into its parts driven by the air, the
# spindle bearings, the spindle drive and the feed (the model is linear in
# its inputs), and each part gets its own gain per channel, solved in closed
# form (variable projection) under a hierarchical prior (see fit_gains): that
# absorbs the amplitude offsets of heat inputs, thermo-elastic coefficients
# and sensor couplings, but not the shapes that unmodelled effects leave.
def base_groups(machine):
    """The base calibration's multipliers, ``{name: which parameters}`` (a
    predicate on the keys of ``machine.params``): every capacity, every
    convection, and on top the enclosure air's exchange with the workshop.

    With the conductances fixed, the first two set the network's time
    scales relative to its conduction; the heat-driven amplitude is left to
    the parts' gains (capacities, convections and conductances scaled alike
    change no time constant and only scale the response to the heat, so a
    third family multiplier would only trade places with the gains). How
    fast the air around a machine follows the workshop's (doors,
    ventilation, the enclosure's size) varies between machines more than
    any one part of the network, and the air's response has no gain to take
    it up: with it fixed, a base built differently takes an effect that
    brings the workshop air to the structure faster for what it lacks."""
    exchange = f"hA.{machine.spec.enclosure}"
    return {
        "scale.C": lambda key: key.startswith("C."),
        "scale.hA": lambda key: key.startswith("hA."),
        "scale.enclosure": lambda key: key == exchange,
    }


# "Change since the start of the run" is taken relative to the mean of the
# first few compared samples, on both sides: relative to one sample, that
# sample's noise would offset the whole run.
START_SAMPLES = 5
# What a glitch's repair is for, in its warning.
USED_FOR = "the diagnosis (its gap and noise floor)"
# The fewest samples a run (or block) needs in both modes: the start
# reference and a few changes after it.
MIN_SAMPLES = START_SAMPLES + 3

# The parameter each candidate effect brings to the calibration (None: the
# effect is a structural switch without a free parameter), and the effects
# modelled on the residual instead of simulated: both owned by the effects.
EFFECT_PARAMETER = {name: e.diagnosis_parameter for name, e in EFFECTS.items()}
# How far the calibration may move a candidate's parameter: between these
# multiples of the machine's value (the base's multipliers move less, see
# calibrate).
EFFECT_RANGE = (0.05, 20.0)
RESIDUAL_EFFECTS = tuple(name for name, e in EFFECTS.items() if e.residual)


def floor_squared(problem):
    """Squared gap a perfect model would leave: the measurement noise of
    every channel, weighted, plus the noise of the run-start reference
    (changes since start are taken against the mean of ``START_SAMPLES``
    noisy samples, which offsets a whole run by noise / sqrt(START_SAMPLES))."""
    white = float(np.sum(problem.weight * (problem.noise / problem.scale) ** 2))
    return white * (1.0 + 1.0 / START_SAMPLES)


@dataclass
class MeasuredRun:
    """One measured run prepared for the diagnosis."""

    name: object
    time_s: np.ndarray
    spindle_rpm: np.ndarray
    ambient_C: np.ndarray
    feed_mm_min: np.ndarray
    rows: np.ndarray  # samples kept for the comparison
    y: np.ndarray  # measured channels at ``rows``, change since start
    # The first readings of the machine's sensors (simulated name -> the
    # run's first samples, ThermalMachine.first_readings, °C), with
    # initial="measured".
    start: dict = None
    # The run's initial node temperatures: "ambient" or an array (°C, in the
    # order of ``spec.nodes``), as ThermalMachine.response takes.
    initial: object = "ambient"


@dataclass
class Problem:
    """Measured runs, the channels compared, their scales and weights."""

    runs: list
    channels: list  # measured column names
    sim_channels: list  # the simulated column each is compared with
    is_disp: np.ndarray
    scale: np.ndarray
    weight: np.ndarray
    noise: np.ndarray
    meta: dict = field(default_factory=dict)

    @property
    def names(self):
        return [r.name for r in self.runs]


# The drivers of a run table, and the measured columns that are channels.
DRIVER_COLUMNS = ("time_s", "spindle_rpm", "ambient_C", "feed_mm_min")
NOT_CHANNELS = ("run", *DRIVER_COLUMNS)


def is_channel(column):
    """Whether a run-table column is a channel (a temperature ``*_C`` other
    than ``ambient_C``, or a displacement ``disp_*_um``)."""
    column = str(column)
    return (column.endswith("_C") and column != "ambient_C") or (
        column.startswith("disp_") and column.endswith("_um")
    )


def _where(run, table):
    return f"run {run!r}" + (f" of the {table} table" if table else "")


def driver_values(frame, col, run, table=""):
    """The driver ``col`` of one run as floats, checked.

    Raises a ValueError naming the run (and ``table``), the row within the
    run and the value when a value is missing or not finite, or when
    ``spindle_rpm`` is negative.
    """
    if is_clock_dtype(frame[col].dtype):
        raise ValueError(
            f"{col} in {_where(run, table)} holds {frame[col].dtype} values; it must "
            "hold numbers (time_s: the seconds since the start of the run)."
        )
    values = pd.to_numeric(frame[col], errors="coerce").to_numpy(float)
    absurd = np.abs(values) > MAX_MAGNITUDE
    bad = ~np.isfinite(values) | absurd
    if col == "spindle_rpm":
        bad |= np.isfinite(values) & (values < 0)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        given = frame[col].iloc[k]
        if isinstance(given, str) and given.strip():
            clock = (
                " (a clock time or date? time_s is the seconds since the start "
                "of the run: convert it first)"
                if col == "time_s"
                else ""
            )
            raise ValueError(
                f"{col} is text ({shown(given)}) in {_where(run, table)} at row "
                f"{k} of the run: it must hold numbers{clock}."
            )
        if not np.isfinite(values[k]):
            what = f"is missing or not finite ({shown(given)})"
        elif absurd[k]:
            what = f"is absurd ({values[k]:g}, beyond {MAX_MAGNITUDE:g} in magnitude)"
        else:
            what = f"is negative ({values[k]:g})"
        raise ValueError(
            f"{col} {what} in {_where(run, table)} at row {k} of the run: the "
            "drivers must "
            "be finite"
            + (" and spindle_rpm not negative." if col == "spindle_rpm" else ".")
        )
    return values


def check_times(t, run, table=""):
    """Raise a ValueError naming the run, the row and both times where
    ``t`` (the run's ``time_s`` as given) does not increase strictly."""
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        # Going back in time (rather than standing still) is most often a
        # table out of order.
        fix = (
            " Rows out of order? Sort the table: "
            "df.sort_values(['run', 'time_s'], kind='stable')."
            if t[k] < t[k - 1]
            else " A repeated time: drop the duplicated row."
        )
        raise ValueError(
            f"time_s is not strictly increasing in {_where(run, table)} at row "
            f"{k} of the run (time_s {t[k]:g} after {t[k - 1]:g}).{fix}"
        )


def check_length(n, run, table=""):
    """Raise a ValueError naming the run when it has fewer than
    ``MIN_SAMPLES`` samples."""
    if n < MIN_SAMPLES:
        raise ValueError(
            f"R{_where(run, table)[1:]} has {n} samples; at least "
            f"{MIN_SAMPLES} are needed (its change since the start is taken "
            f"against the mean of the first {START_SAMPLES})."
        )


def without_attrs(frame):
    """``frame`` (a shallow copy) without ``attrs``: pandas deep-copies them
    into every column and slice taken, and a table joined from many
    simulated runs carries one metadata record per run."""
    frame = frame.copy(deep=False)
    frame.attrs = {}
    return frame


def channel_values(frame, columns, t, run, table=""):
    """The channels ``columns`` of one run as floats, ``(n, len(columns))``.

    Raises a ValueError naming the column, the run, the row and its time
    where a value is text (not a number), missing, not finite or beyond
    ``MAX_MAGNITUDE`` (:func:`check_finite_channels`).
    """
    out = np.empty((len(frame), len(columns)))
    for c, col in enumerate(columns):
        raw = frame[col]
        values = pd.to_numeric(raw, errors="coerce")
        text = values.isna().to_numpy() & raw.notna().to_numpy()
        if text.any():
            r = int(np.flatnonzero(text)[0])
            raise ValueError(
                f"{col} holds {raw.iloc[r]!r}, not a number, in "
                f"{_where(run, table)} at row {r} of the run (time_s {t[r]:g}): the "
                "channels must hold numbers."
            )
        out[:, c] = values.to_numpy(float)
    check_finite_channels(out, columns, t, run, table)
    return out


def check_one_to_one(channels, simulated):
    """Raise a ValueError when two measured ``channels`` are compared with
    the same ``simulated`` column (a mapping onto a name the measured table
    also holds)."""
    seen = {}
    for measured, sim in zip(channels, simulated, strict=True):
        if sim in seen:
            raise ValueError(
                f"The measured columns {seen[sim]!r} and {measured!r} would both "
                f"be compared with the simulated {sim!r}: compare one of them "
                "(channels=, or map only one)."
            )
        seen[sim] = measured


def check_channel_names(channels):
    """Raise a ValueError naming the channels given more than once."""
    seen, twice = set(), []
    for c in channels:
        if c in seen and c not in twice:
            twice.append(c)
        seen.add(c)
    if twice:
        raise ValueError(
            f"Channel(s) {twice} are given more than once in channels=; give "
            "each compared channel once."
        )


def measured_varying(Ys, channels, explicit, stacklevel=5):
    """Mask of the channels whose measurement changes on some run (``Ys``:
    every run's measured channels). A channel whose measurement is constant
    on every run (a dead or unplugged probe) has nothing to diagnose: an
    error when chosen explicitly or when no channel is left, else left out
    with a warning naming it."""
    flat = np.all([flat_columns(Y) for Y in Ys], axis=0)
    dead = [c for c, f in zip(channels, flat, strict=True) if f]
    if dead and (explicit or len(dead) == len(channels)):
        raise ValueError(
            f"The measured channel(s) {dead} are constant on every run (a dead "
            "or unplugged probe?): there is nothing to diagnose on them; "
            + (
                "leave them out of channels=."
                if explicit
                else "no channel is left to compare."
            )
        )
    if dead:
        warnings.warn(
            f"The measured channel(s) {dead} are constant on every run (a dead "
            "or unplugged probe?) and are left out: there is nothing to "
            "diagnose on them.",
            UserWarning,
            stacklevel=stacklevel,
        )
    return ~flat


def check_finite_channels(Y, columns, t, run, table=""):
    """Raise a ValueError naming the column, the run, the first row and its
    time where the channels ``Y`` (``(n, len(columns))``) are missing, not
    finite or beyond ``MAX_MAGNITUDE`` in magnitude (no sensor reads that:
    the squares of the least squares would overflow), or where a temperature
    channel is at or below absolute zero (as validate_runs: a logger's -999
    for no reading ran through the diagnosis and spoilt it)."""
    temperature = np.array(
        [bool(TEMPERATURE_PATTERN.fullmatch(str(c))) for c in columns]
    )
    with np.errstate(invalid="ignore"):
        checks = (
            (~np.isfinite(Y), None),
            (
                np.abs(Y) > MAX_MAGNITUDE,
                lambda n: (
                    f": no sensor reads beyond {MAX_MAGNITUDE:g} in "
                    "magnitude, a broken sensor or a corrupt file."
                ),
            ),
            (
                (Y <= ABSOLUTE_ZERO_C) & temperature[None, :],
                lambda n: (
                    f", and {n} such row(s) in all: a temperature in °C "
                    f"lies above {ABSOLUTE_ZERO_C:g} (a logger's code for no "
                    "reading, such as -999?). Drop or fill those rows."
                ),
            ),
        )
    for found, why in checks:
        if not found.any():
            continue
        r, c = map(int, np.argwhere(found)[0])
        at = f"{_where(run, table)} at row {r} of the run (time_s {t[r]:g})"
        if why is None:
            raise ValueError(f"{columns[c]} is missing or not finite in {at}.")
        raise ValueError(
            f"{columns[c]} holds {Y[r, c]:g} in {at}{why(int(found[:, c].sum()))}"
        )


def _listing(names, limit=12):
    names = [str(n) for n in names]
    if len(names) <= limit:
        return str(names)
    return f"{names[:limit]}... ({len(names)} in all)"


def check_mapping(mapping, measured_columns, simulated_columns, what):
    """Raise a ValueError naming every ``mapping`` key that is not a measured
    column and every value that is not among ``simulated_columns`` (``what``
    says why, e.g. "are not columns of the simulated table")."""
    measured_columns = list(measured_columns)
    simulated_columns = list(simulated_columns)
    keys = [k for k in mapping if k not in measured_columns]
    if keys:
        raise ValueError(
            f"mapping key(s) {keys} are not columns of the measured runs"
            f"{suggest(keys[0], measured_columns)}; the keys are measured "
            "columns (its channels: "
            f"{_listing([c for c in measured_columns if is_channel(c)])})."
        )
    values = [v for v in mapping.values() if v not in simulated_columns]
    if values:
        raise ValueError(
            f"mapping value(s) {values} {what}"
            f"{suggest(values[0], simulated_columns)}; the values are simulated "
            "channels: "
            f"{_listing([c for c in simulated_columns if c not in NOT_CHANNELS])}."
        )


def check_measured_names(columns, mapping, channels, table):
    """The run-table naming rule on a measured table's ``columns`` (as
    :func:`skthermal.datasets.read_runs` applies it), but for the columns
    the caller took explicitly: ``mapping``'s keys and ``channels``; the
    error says so (a table that ran with a mapping failed once its columns
    were renamed to "clean up", and the message said only to rename)."""
    try:
        check_column_names(columns, table=table, exempt={*mapping, *(channels or ())})
    except ValueError as exc:
        raise ValueError(
            f"{exc} (Or compare them as they are named: channels=[...] or "
            "mapping={'measured': 'simulated'} takes a column explicitly.)"
        ) from None


def warn_uncompared(measured_columns, channels, why, candidates=()):
    """Warn (UserWarning) about the measured channel columns left out of the
    comparison ``channels`` (when they were not chosen explicitly), naming
    the closest of ``candidates`` (the other side's unused columns) to each:
    a unit or spelling typo there drops a channel otherwise."""
    left = [c for c in measured_columns if is_channel(c) and c not in channels]
    unused = [c for c in candidates if c not in channels and c not in NOT_CHANNELS]
    close = "".join(
        f"; for {c!r} the simulated table has {near!r} (a unit or spelling typo?)"
        for c in left
        if (near := closest(c, unused)) is not None
    )
    if left:
        warnings.warn(
            f"Measured channel(s) {_listing(left)} are not compared: {why} "
            f"them{close}. Map them with mapping={{'measured': 'simulated'}}, or pass "
            "channels= to choose the compared channels (and silence this).",
            UserWarning,
            stacklevel=user_stacklevel(),
        )


def build_problem(
    machine,
    runs,
    *,
    channels=None,
    mapping=None,
    max_samples=600,
    block_hours=None,
    first_readings=False,
):
    """Prepare measured runs: drivers, compared channels, scales, weights.

    With ``block_hours``, every run longer than that is cut into consecutive
    blocks that count as runs for the held-out scoring. A block is simulated
    from the start of its run (so its initial warm state is right) but
    compared only over its own time span, re-zeroed at the block's start.
    With ``first_readings``, every run keeps the first readings of the
    machine's sensors it holds (:attr:`MeasuredRun.start`; compared or not,
    under their measured names through ``mapping``).
    """
    check_unique_columns(runs, "The measured run table")
    for col in ("run", "time_s", "spindle_rpm", "ambient_C"):
        if col not in runs.columns:
            raise ValueError(
                f"The measured runs have no {col!r} column; the diagnosis "
                "simulates each run from its drivers (time_s, spindle_rpm, "
                "ambient_C and, if present, feed_mm_min)"
                + driver_lookalike_hint(runs.columns, [col])
                + "."
            )
    if runs.shape[0] == 0:
        raise ValueError(
            "The measured run table is empty (no rows): the diagnosis needs at "
            "least 2 runs with their drivers and measured channels."
        )
    # Rows without a run label would be dropped by the grouping.
    check_labels(runs["run"].to_numpy())
    runs = without_attrs(runs)
    frames = list(runs.groupby("run", sort=False))
    for name, frame in frames:
        for col in DRIVER_COLUMNS:
            if col in frame.columns:
                driver_values(frame, col, name)
    mapping = dict(mapping or {})
    check_measured_names(runs.columns, mapping, channels, "The measured runs'")
    predicted = list(machine.targets) + list(machine.sensors)
    check_mapping(
        mapping,
        runs.columns,
        predicted,
        "are not channels the simulation predicts",
    )
    explicit = channels is not None
    if channels is None:
        channels = [c for c in runs.columns if mapping.get(c, c) in predicted]
    channels = list(channels)
    check_channel_names(channels)
    bad = [c for c in channels if c not in runs.columns]
    if bad:
        raise ValueError(f"Channel(s) {bad} are not columns of the measured runs.")
    bad = [c for c in channels if mapping.get(c, c) not in predicted]
    if bad:
        raise ValueError(
            f"The simulation does not predict {bad}; map measured columns to "
            "simulated ones with mapping={'measured': 'simulated'}."
        )
    if not channels:
        raise ValueError(
            "No measured column matches a channel the simulation predicts "
            f"({machine.targets} and its {len(machine.sensors)} temperature "
            "sensors); pass mapping= or channels=."
        )
    if not explicit:
        warn_uncompared(runs.columns, channels, "the simulation does not predict")
    still = [c for c in channels if mapping.get(c, c) in machine.unmoved_targets]
    if still:
        # Its whole measured change would count as gap (a planted effect
        # named at 58% fell to 6% beside such a channel).
        warnings.warn(
            f"The machine moves {still} by nothing (no thermo-elastic "
            "coefficient of the axis: [displacement.<axis>] is missing or all "
            "zero), so all their measured change would count as gap"
            + (
                ": they are compared as you chose (channels=)."
                if explicit
                else ": they are left out. Give the axis its coefficients, or "
                "name them in channels= to compare them."
            ),
            UserWarning,
            stacklevel=user_stacklevel(),
        )
        if not explicit:
            channels = [c for c in channels if c not in still]
        if not channels:
            raise ValueError(
                f"Nothing to compare: the machine moves {still} by nothing, and "
                "no other channel of the runs is simulated."
            )
    read = []
    for name, frame in frames:
        t = frame["time_s"].to_numpy(float)
        check_length(t.size, name)
        check_times(t, name)
        y = read_y = channel_values(frame, channels, t, name)
        y = repair_spikes(
            y,
            channels,
            t,
            name,
            "",
            USED_FOR,
            **{
                col: driver_values(frame, col, name)
                for col in ("spindle_rpm", "feed_mm_min", "ambient_C")
                if col in frame
            },
        )
        if y is not read_y:
            # Repaired: the first readings (initial states) read it too.
            frame = frame.assign(**dict(zip(channels, y.T, strict=True)))
        read.append((name, frame, t, y))
    frames = [(name, frame) for name, frame, *_ in read]
    warn_implausible(runs, readings=True)
    warn_short_runs("diagnose", {name: t[-1] - t[0] for name, _, t, _ in read}, 5)
    keep = measured_varying([y for *_, y in read], channels, explicit)
    dead = [c for c, k in zip(channels, keep, strict=True) if not k]
    channels = [c for c, k in zip(channels, keep, strict=True) if k]
    sim_channels = [mapping.get(c, c) for c in channels]
    check_one_to_one(channels, sim_channels)
    is_disp = np.array([c in machine.targets for c in sim_channels])
    starts = {}
    if first_readings:
        starts = _first_readings(machine, frames, mapping, dead)
    prepared = []
    for name, frame, t, y_all in read:
        y_all = y_all[:, keep]
        feed = (
            frame["feed_mm_min"].to_numpy(float)
            if "feed_mm_min" in frame
            else np.zeros_like(t)
        )
        rpm = frame["spindle_rpm"].to_numpy(float)
        air = frame["ambient_C"].to_numpy(float)
        for a, b, label in block_spans(t, name, block_hours):
            check_length(b - a, label)
            step = max(1, int(np.ceil((b - a) / max_samples)))
            rows = np.arange(a, b, step)
            y = y_all[rows]
            y = y - y[:START_SAMPLES].mean(axis=0)
            prepared.append(
                MeasuredRun(
                    name=label,
                    time_s=t[:b] - t[0],
                    spindle_rpm=rpm[:b],
                    ambient_C=air[:b],
                    feed_mm_min=feed[:b],
                    rows=rows,
                    y=y,
                    start=starts.get(name),
                )
            )
    Y = np.vstack([r.y for r in prepared])
    noise = pooled_noise([y[:, keep] for *_, y in read])
    scale, weight = group_scales(Y, is_disp)
    return Problem(prepared, channels, sim_channels, is_disp, scale, weight, noise)


def sensor_columns(machine, columns, mapping=None):
    """The measured column of each of the machine's sensors the run table
    holds, ``{sensor: column}``: named through ``mapping`` (measured ->
    simulated), else by the sensor's own name."""
    named = {}
    for measured, simulated in dict(mapping or {}).items():
        if simulated in machine.sensors:
            named.setdefault(simulated, measured)
    columns = set(columns)
    return {s: named.get(s, s) for s in machine.sensors if named.get(s, s) in columns}


def _first_readings(machine, frames, mapping, dead=()):
    """The first readings of the machine's sensors in every run, ``{run:
    {sensor: samples}}`` (:meth:`ThermalMachine.first_readings`, the columns
    by :func:`sensor_columns`). A column constant on every run (a dead or
    unplugged probe) tells nothing of the machine's state and is left out,
    with a warning unless it is among ``dead``, the compared channels already
    left out for it."""
    columns = sensor_columns(machine, frames[0][1].columns, mapping)
    values = [
        frame[list(columns.values())].apply(pd.to_numeric, errors="coerce")
        for _, frame in frames
    ]
    flat = np.all([flat_columns(v.to_numpy(float)) for v in values], axis=0)
    stuck = [c for c, f in zip(columns.values(), flat, strict=True) if f]
    unsaid = [c for c in stuck if c not in dead]
    if unsaid:
        warnings.warn(
            f"The sensor column(s) {unsaid} are constant on every run (a dead "
            "or unplugged probe?) and are left out of the runs' initial "
            "states.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
    columns = {s: c for s, c in columns.items() if c not in stuck}
    return {
        name: machine.first_readings(frame, columns=columns, run=name)
        for name, frame in frames
    }


def block_spans(t, name, block_hours):
    """Consecutive blocks of a run (times ``t``) of about ``block_hours``
    each, as ``(first row, end row, label)``; one block, labelled ``name``,
    when ``block_hours`` is None or the run is shorter than 1.5 blocks.

    Labels give each block's span since the run's start in hours, from its
    first sample to the next block's first sample (the run's last one for
    the last block), with as many decimals as the boundaries need to stay
    in increasing order and within a tenth of ``block_hours`` of the times
    (``r1[0-0.5 h]``, ``r1[0.5-1 h]``), else in seconds.
    """
    if block_hours is None or t[-1] - t[0] <= 1.5 * block_hours * 3600.0:
        return [(0, t.size, name)]
    n_blocks = int(round((t[-1] - t[0]) / (block_hours * 3600.0)))
    if t.size < MIN_SAMPLES * n_blocks:
        period = float(np.median(np.diff(t)))
        # Blocks that hold MIN_SAMPLES however the span's division rounds
        # (from 10 samples on), rounded up to 3 digits.
        hours = (MIN_SAMPLES + 4) * period / 3600.0
        digits = 2 - int(np.floor(np.log10(hours)))
        need = np.ceil(hours * 10.0**digits) / 10.0**digits
        raise ValueError(
            f"block_hours={block_hours:g} ({block_hours * 3600.0:g} s) cuts run "
            f"{name!r} ({t.size} samples, every {period:g} s) into {n_blocks} "
            f"blocks; a block needs at least {MIN_SAMPLES} samples: give "
            f"block_hours of at least {need:.3g}."
        )
    edges = np.linspace(0, t.size, n_blocks + 1).astype(int)
    pairs = list(zip(edges[:-1], edges[1:], strict=True))
    bounds = [t[a] - t[0] for a, _ in pairs] + [t[-1] - t[0]]
    unit = "h"
    for decimals in range(4):
        shown = [_hours(b, decimals) for b in bounds]
        close = all(
            abs(float(x) - b / 3600.0) <= 0.1 * block_hours
            for x, b in zip(shown, bounds)
        )
        if close and all(float(x) < float(y) for x, y in zip(shown, shown[1:])):
            break
    else:
        shown, unit = [f"{b:.12g}" for b in bounds], "s"
    labels = [f"{name}[{shown[k]}-{shown[k + 1]} {unit}]" for k in range(len(pairs))]
    if len(set(labels)) != len(labels):
        raise AssertionError(f"Duplicate block labels: {labels}")
    return [(a, b, label) for (a, b), label in zip(pairs, labels, strict=True)]


def too_few_runs(n, longest_s, block_hours):
    """The ValueError for fewer than 2 runs (or blocks) to hold out, with a
    hint at ``block_hours`` (``longest_s``: the longest run's span)."""
    hours = longest_s / 3600.0
    if block_hours is None:
        hint = (
            "; to hold one long record out in blocks, pass block_hours= (e.g. "
            f"block_hours={max(hours / 3, 1e-3):.2g} for 3 blocks of its "
            f"{hours:.3g} h)"
        )
    else:
        hint = (
            f": block_hours={block_hours:g} cuts only runs longer than 1.5 x "
            f"{block_hours:g} h into blocks, and the longest run lasts "
            f"{hours:.3g} h; give block_hours below {hours / 1.5:.3g} h for at "
            "least 2 blocks"
        )
    return ValueError(
        "The diagnosis scores effects on held-out runs: give at least 2 runs "
        f"(got {n}){hint}."
    )


def _hours(seconds, decimals):
    """``seconds`` in hours with ``decimals`` decimals, trailing zeros
    dropped (``0.5``, ``2``)."""
    text = f"{seconds / 3600.0:.{decimals}f}"
    return text.rstrip("0").rstrip(".") if "." in text else text


def group_scales(Y, is_disp):
    """Scale and weight of every channel for the normalised gap.

    One scale per group (µm for displacements, °C for temperatures): errors
    in the same unit count alike, so a nearly flat, noisy channel (a small
    X error) does not weigh as much as the axis that actually moves. Each
    group present weighs alike, shared by its channels.
    """
    scale = np.empty(Y.shape[1])
    weight = np.empty(Y.shape[1])
    groups = [g for g in (is_disp, ~is_disp) if g.any()]
    for g in groups:
        scale[g] = max(float(np.sqrt(np.mean(Y[:, g].var(axis=0)))), 1e-9)
        weight[g] = 1.0 / len(groups) / g.sum()
    return scale, weight


def with_scales(machine, reference, values):
    """``machine`` with group scales and effect parameters applied.

    ``values`` maps names to multipliers: those of :func:`base_groups`
    multiply a family of ``reference`` parameters (several on one parameter
    compound, as the enclosure's exchange and the convections); an effect
    parameter name multiplies that parameter's reference value.
    """
    new = {}
    groups = base_groups(machine)
    for name, factor in values.items():
        if name in groups:
            match = groups[name]
            for key, value in reference.items():
                if match(key):
                    new[key] = new.get(key, value) * factor
        else:
            new[name] = reference[name] * factor
    return machine.with_params(new)


def _channels_of(problem, run, values):
    """Compared channels (change since start, at ``run.rows``) from the
    machine's noise-free readings ``values`` of ``problem.sim_channels``."""
    r = values[run.rows]
    return r - r[:START_SAMPLES].mean(axis=0)


PARTS = ("air", "bearing", "drive", "feed")


def predict_run(machine, problem, run, parts=False, same_start=False):
    """Simulated channels of one run (change since start, at ``run.rows``).

    The network and the sensors (with their lag) run at the measurement's own
    sample rate; the comparison keeps every ``rows`` sample. The model is
    linear in its inputs, so with ``parts`` the prediction is returned as its
    parts driven by the air, the spindle bearings, the spindle drive (motor,
    belt and cutting) and the feed (shape ``(4, n, n_channels)``; their sum
    is the prediction). With ``same_start``, the machine starts from the
    run's own initial state (:attr:`MeasuredRun.initial`) whatever its
    effects, not from its own estimate (:func:`run_initial`): what an
    effect changes in the run itself. Uses only the machine's public
    response API (:meth:`ThermalMachine.response` and
    :meth:`ThermalMachine.read`).
    """
    dt = float(run.time_s[1] - run.time_s[0])
    air = run.ambient_C
    drivers = (run.time_s, run.spindle_rpm, air, run.feed_mm_min)
    initial = run.initial if same_start else run_initial(problem, run, machine)

    def read(T, ambient):
        values = machine.read(T, ambient, problem.sim_channels, sample_period_s=dt)
        return _channels_of(problem, run, values)

    if not parts:
        return read(machine.response(*drivers, initial=initial, run=run.name), air)
    out = np.zeros((len(PARTS), run.rows.size, len(problem.channels)))
    by_source = machine.response(
        *drivers, initial=initial, by_source=True, run=run.name
    )
    zero_air = np.zeros_like(air)
    for k, source in enumerate(PARTS):
        if source in by_source:
            out[k] = read(by_source[source], air if source == "air" else zero_air)
    return out


def measured_initial(machine, problem, p_soaked=0.0):
    """``problem`` with every run's initial node temperatures estimated from
    its first temperature readings (:attr:`MeasuredRun.start`) by
    :meth:`ThermalMachine.initial_from_readings`, with ``machine`` as given
    (:attr:`MeasuredRun.initial`). A machine with other effects (a
    candidate) starts from its own estimate, with ``machine``'s parameters
    and its effects (:func:`run_initial`): an effect changes the states the
    machine passes through, so the temperatures of the nodes no sensor
    reads. Only the first readings enter the estimates, and nothing an
    effect does later in a run. ``p_soaked``: the prior probability of a
    soaked start (:meth:`ThermalMachine.initial_from_readings`)."""
    meta = dict(problem.meta)
    meta["initial_from"] = machine
    # The prior of the initial states spans the runs' own speeds and feeds.
    meta["initial_ranges"] = {
        "max_rpm": max(float(np.max(np.abs(r.spindle_rpm))) for r in problem.runs),
        "max_feed_mm_min": max(
            float(np.max(np.abs(r.feed_mm_min))) for r in problem.runs
        ),
    }
    meta["initial_cache"] = {}
    # Whether each run starts warm is judged once, with the machine as
    # given: every candidate starts the run alike (each from its own warm
    # state).
    judge = machine.warm_probability
    meta["warm"] = (
        {
            run.name: _reading_call(judge, meta, run, p_soaked=p_soaked)
            for run in problem.runs
        }
        if p_soaked > 0
        else {}
    )
    problem = replace(problem, meta=meta)
    runs = [
        replace(run, initial=_estimate(problem, run, machine)) for run in problem.runs
    ]
    return replace(problem, runs=runs)


def _estimate(problem, run, machine):
    """``machine``'s initial node temperatures of ``run`` from its first
    readings."""
    meta = problem.meta
    return _reading_call(
        machine.initial_from_readings, meta, run, warm=meta["warm"].get(run.name)
    )


def _reading_call(method, meta, run, **kwargs):
    """``method`` (of a machine: ``initial_from_readings``,
    ``warm_probability``) on ``run``'s first readings and drivers."""
    k = len(next(iter(run.start.values())))
    return method(
        run.start,
        run.ambient_C[:k],
        time_s=run.time_s[:k],
        spindle_rpm=run.spindle_rpm[:k],
        feed_mm_min=run.feed_mm_min[:k],
        **meta["initial_ranges"],
        run=run.name,
        **kwargs,
    )


def run_initial(problem, run, machine):
    """The initial state ``machine`` simulates ``run`` from: the run's own
    (:attr:`MeasuredRun.initial`), or with first readings
    (:func:`measured_initial`), the estimate of the machine as given with
    ``machine``'s effects, computed once per run and set of effects (the
    same whatever parameters a calibration tries, and in whatever order
    the candidates come)."""
    if run.start is None or "initial_from" not in problem.meta:
        return run.initial
    given = problem.meta["initial_from"]
    effects = frozenset(machine.effects)
    if effects == frozenset(given.effects):
        return run.initial
    cache = problem.meta["initial_cache"]
    key = (run.name, effects)
    if key not in cache:
        cache[key] = _estimate(problem, run, given.with_effects(sorted(effects)))
    return cache[key]


def initial_table(machine, problem):
    """The runs' initial node temperatures above their first air reading
    (K; rows: runs, columns: nodes), as :attr:`GapReport.initial_states`."""
    rows = {}
    for run in problem.runs:
        air0 = run.ambient_C[0]
        if isinstance(run.initial, str):  # "ambient": soaked at the air
            rows[run.name] = np.zeros(len(machine.spec.nodes))
        else:
            rows[run.name] = np.asarray(run.initial, dtype=float) - air0
    table = pd.DataFrame.from_dict(rows, orient="index", columns=machine.spec.nodes)
    return table.rename_axis(index="run", columns="node")


def _run_clock(run):
    """Time since the run's start reference (hours), at the compared rows."""
    t = (run.time_s[run.rows] - run.time_s[run.rows[0]]) / 3600.0
    return t - t[:START_SAMPLES].mean()


def drift_rates(xs, runs, mask):
    """Drift rate of every channel in ``mask`` shared by ``runs``: the
    least-squares slope (per hour since the start reference, through it:
    changes since start are zero there) of the stacked ``xs``
    (``(..., n, n_channels)`` per run); 0 outside ``mask``.

    A drifting sensor drifts at its own rate in every run (ageing,
    connector thermo-EMF are properties of the sensor), so the rate is fitted
    on training runs and carried to held-out runs like any other parameter.
    """
    clocks = [_run_clock(run) for run in runs]
    num = sum(np.einsum("n,...nc->...c", t, x) for t, x in zip(clocks, xs, strict=True))
    den = max(sum(float(t @ t) for t in clocks), 1e-300)
    return np.where(mask, num / den, 0.0)


def without_drift(x, run, rate):
    """``x`` (``(..., n, n_channels)``) minus the drift ``rate`` (per channel,
    per hour; :func:`drift_rates`) since the run's start reference."""
    return np.asarray(x, dtype=float) - _run_clock(run)[:, None] * rate[..., None, :]


# Hyper-prior of the groups' mean gains: loose, a heat input may be off by
# a factor of several.
HYPER_SPREAD = 3.0


def fit_gains(problem, predictions, runs_idx, spread=0.3, drift=None):
    """Closed-form gains of the parts of every channel, with a shared prior.

    A hierarchical Bayesian ridge: minimises ``||y - sum_a g_a P_a||^2 / s^2
    + sum_a (g_a - m_a)^2 / spread^2`` over ``runs_idx``, ``s`` the channel's
    noise, where ``m_a`` is the part's mean gain over the channels of the
    same group (displacements, temperatures), itself fitted (with a loose
    prior of one). A part whose signal stands well above the noise moves its
    gain freely (absorbing a calibration offset of the heat inputs, the
    thermo-elastic coefficients or a sensor's coupling); a part buried in the
    noise, or nearly collinear with another part, takes the amplitude the
    other channels found for it (a heat input that is twice the model's
    raises every channel) instead of fitting the noise.
    ``predictions[i]`` has shape (n_parts, n, n_channels); returns gains of
    shape (n_parts, n_channels).

    With ``drift`` (a channel mask), those channels may carry a linear drift
    at a rate of their own, the same in every run (:func:`drift_rates`): it
    is partialled out of both sides, so a drifting sensor does not bend the
    gains.
    """
    data = [(predictions[i], problem.runs[i].y) for i in runs_idx]
    if drift is not None:
        runs = [problem.runs[i] for i in runs_idx]
        rate_P = drift_rates([P for P, _ in data], runs, drift)
        rate_y = drift_rates([y for _, y in data], runs, drift)
        data = [
            (without_drift(P, run, rate_P), without_drift(y, run, rate_y))
            for (P, y), run in zip(data, runs, strict=True)
        ]
    G = sum(np.einsum("anc,bnc->cab", P, P) for P, _ in data)
    b = sum(np.einsum("anc,nc->ca", P, y) for P, y in data)
    noise = np.maximum(problem.noise, 1e-3 * problem.scale)
    gain = _hierarchical_gains(problem, G, b, (noise / spread) ** 2, spread)
    # The data term above treats every sample as independent; slow
    # model-error residuals are not. Second pass: weigh the data by their
    # effective number of independent samples (the residual's variance times
    # its AR(1) correlation time in samples), per channel.
    r = [y - np.einsum("anc,ca->nc", P, gain) for P, y in data]
    ss = sum(np.sum(x * x, axis=0) for x in r)
    lag1 = sum(np.sum(x[1:] * x[:-1], axis=0) for x in r)
    var = np.maximum(ss / sum(x.shape[0] for x in r), noise**2)
    lam = var * _correlation_time(ss, lag1) / spread**2
    return _hierarchical_gains(problem, G, b, lam, spread).T


def _correlation_time(ss, lag1):
    """Samples per independent sample of an AR(1) residual, ``(1 + rho) /
    (1 - rho)``, from its sum of squares and lag-1 sum of products
    (``rho`` clipped to [0, 0.99])."""
    rho = np.clip(lag1 / np.maximum(ss, 1e-300), 0.0, 0.99)
    return (1 + rho) / (1 - rho)


def _hierarchical_gains(problem, G, b, lam, spread):
    n_ch, n_parts = b.shape
    eye = np.eye(n_parts)
    A_inv = np.linalg.inv(G + lam[:, None, None] * eye)
    # gains = u + V @ mean: linear in the prior mean of the channel's group.
    u = np.einsum("cab,cb->ca", A_inv, b)
    V = lam[:, None, None] * A_inv
    gain = np.empty((n_ch, n_parts))
    for group in (problem.is_disp, ~problem.is_disp):
        if not group.any():
            continue
        # The group's prior mean is the mean of its gains (empirical Bayes),
        # held near one by a loose hyper-prior (spread HYPER_SPREAD).
        eps = (spread / HYPER_SPREAD) ** 2 / group.sum()
        mean = np.linalg.solve(
            (1 + eps) * eye - V[group].mean(axis=0), u[group].mean(axis=0) + eps
        )
        gain[group] = u[group] + V[group] @ mean
    return gain


def apply_gains(prediction, gain):
    """Parts ``(n_parts, n, n_channels)`` combined with gains
    ``(n_parts, n_channels)``."""
    return np.einsum("anc,ac->nc", prediction, gain)


def residuals(problem, predictions, gain, runs_idx, drift=None, rates=None):
    """Normalised, weighted residuals of the given runs (list of arrays).

    ``predictions[i]`` is either a plain prediction (gain None) or the
    heat/air parts combined with ``gain``. With ``drift`` (a channel mask),
    the drift rates those channels share over the runs (:func:`drift_rates`)
    are fitted and removed (for calibration); with ``rates`` (a
    :attr:`Fit.drift_rates`, per channel), those rates are removed (for
    held-out runs).
    """
    w = np.sqrt(problem.weight) / problem.scale
    runs = [problem.runs[i] for i in runs_idx]
    out = []
    for i, run in zip(runs_idx, runs, strict=True):
        p = predictions[i] if gain is None else apply_gains(predictions[i], gain)
        out.append((p - run.y) * w)
    if drift is not None:
        rates = drift_rates(out, runs, drift)
    if rates is not None:
        out = [without_drift(r, run, rates) for r, run in zip(out, runs, strict=True)]
    return out


def drift_table(problem, rates):
    """``GapReport.drift_rates`` from per-fold drift ``rates`` of the
    temperature channels (``(n_folds, n_temperatures)``, °C/h): ``{channel:
    median over the folds}``."""
    names = [c for c, d in zip(problem.channels, problem.is_disp, strict=True) if not d]
    median = np.median(rates, axis=0)
    return {c: float(r) for c, r in zip(names, median, strict=True)}


def drift_mask(problem, effects, machine=None):
    """Channels whose readings may drift under ``effects`` or the effects
    ``machine`` has on (None if none)."""
    on = set(effects) | set(machine.effects if machine is not None else ())
    if "sensor_drift" in on and (~problem.is_disp).any():
        return ~problem.is_disp
    return None


@dataclass
class Fit:
    """A calibrated model: its parameters, displacement gains and machine."""

    effects: tuple
    values: dict
    gain: np.ndarray
    machine: object
    cost: float
    nfev: int
    fine: dict = field(default_factory=dict)
    # Normalised drift rate of every channel, per hour, fitted on the
    # training runs when ``sensor_drift`` is among the effects (else None);
    # held-out runs are read with it removed.
    drift_rates: np.ndarray = None


def training_drift(problem, predictions, gain, train_idx, drift):
    """:attr:`Fit.drift_rates` of a calibration (None without ``drift``)."""
    if drift is None:
        return None
    raw = residuals(problem, predictions, gain, train_idx)
    return drift_rates(raw, [problem.runs[i] for i in train_idx], drift)


def calibrate(
    problem, machine, reference, effects, train_idx, *, start=None, max_nfev=40
):
    """Fit base scales (and the candidate effects' parameters) on training runs."""
    groups = base_groups(machine)
    names = list(groups)
    for e in effects:
        p = EFFECT_PARAMETER.get(e)
        if p is not None:
            names.append(p)
    start = dict(start or {})
    x0 = np.log([start.get(n, 1.0) for n in names])
    lo = np.array(
        [np.log(0.25) if n in groups else np.log(EFFECT_RANGE[0]) for n in names]
    )
    hi = -lo
    x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)
    sim_effects = [e for e in effects if e not in RESIDUAL_EFFECTS]
    base = machine.with_effects(add=sim_effects)
    drift = drift_mask(problem, effects, machine)

    def model(x):
        return with_scales(base, reference, dict(zip(names, np.exp(x), strict=True)))

    def vector(x):
        m = model(x)
        preds = {
            i: predict_run(m, problem, problem.runs[i], parts=True) for i in train_idx
        }
        gain = fit_gains(problem, preds, train_idx, drift=drift)
        return np.concatenate(
            [r.ravel() for r in residuals(problem, preds, gain, train_idx, drift)]
        )

    jac = BroydenJacobian(vector, (lo, hi))
    res = least_squares(
        jac.reduced_fun,
        x0,
        jac=jac.reduced_jac,
        bounds=(lo, hi),
        max_nfev=max_nfev,
        x_scale=1.0,
    )
    m = model(res.x)
    preds = {i: predict_run(m, problem, problem.runs[i], parts=True) for i in train_idx}
    gain = fit_gains(problem, preds, train_idx, drift=drift)
    return Fit(
        tuple(effects),
        dict(zip(names, np.exp(res.x), strict=True)),
        gain,
        m,
        float(res.cost),
        int(res.nfev),
        drift_rates=training_drift(problem, preds, gain, train_idx, drift),
    )


# Fine calibration (the "how far" step). The screening calibration above
# moves whole families of the network together; the shapes of a machine's
# responses are set node by node, and most by the nodes around the spindle,
# its main heat source. The fine calibration gives every capacity, convection
# and conductance of those nodes its own multiplier, and the bearings' loss
# exponent too, held near one by a prior (log spread FINE_SPREAD), fitted
# jointly with the effect and the gains.
FINE_SPREAD = 0.4
FINE_NFEV = 8


# The bearings' loss exponent (``q.alpha``) the fine calibration may take,
# at least this range around the machine's own: machines' speed laws differ
# (1.2-1.4 on an independent truth against vmc-b's 1.5), and a base that
# cannot follow lets a speed-dependent candidate stand in for it.
ALPHA_RANGE = (1.0, 2.0)


def fine_keys(machine):
    """Parameters the fine calibration frees: capacity, convection and
    conductances of the spindle head's nodes and the tool (without declared
    head nodes: the spindle's heated nodes and their neighbours), and the
    bearings' loss exponent ``q.alpha`` when the bearings are heated."""
    spec = machine.spec
    region = set(spec.head_nodes)
    if region:
        region.add(spec.tool)
    else:
        heated = {spec.bearing, spec.motor, spec.belt, spec.cutting}
        region = set(heated)
        for a, b in spec.edges:
            if a in heated or b in heated:
                region |= {a, b}
    p = machine.params
    keys = [
        f"{fam}.{n}"
        for n in spec.nodes
        if n in region
        for fam in ("C", "hA")
        if p.get(f"{fam}.{n}", 0.0) > 0
    ]
    keys += [
        f"G.{a}-{b}"
        for a, b in spec.edges
        if (a in region or b in region) and p.get(f"G.{a}-{b}", 0.0) > 0
    ]
    if p.get("q.alpha", 0.0) > 0 and p.get("q.bearing_W", 0.0) > 0:
        keys.append("q.alpha")
    return keys


def _fine_bounds(keys, params):
    """Bounds of the fine calibration's log multipliers: a factor of 4 each
    way, the loss exponent within :data:`ALPHA_RANGE` (widened to 0.7-1.4
    times the machine's own)."""
    bound = np.log(4.0)
    lo, hi = np.full(len(keys), -bound), np.full(len(keys), bound)
    if "q.alpha" in keys:
        j, alpha = keys.index("q.alpha"), params["q.alpha"]
        low = min(ALPHA_RANGE[0], 0.7 * alpha)
        high = max(ALPHA_RANGE[1], 1.4 * alpha)
        lo[j], hi[j] = np.log(low / alpha), np.log(high / alpha)
    return lo, hi


def _effective_samples(R):
    """Independent samples in weighted residuals ``R`` (list of (n, ch)): the
    sample count, shortened by the AR(1) correlation time of the combined
    residual, times the participation ratio of the channels (channels that
    move together count once)."""
    X = np.vstack(R)
    if X.shape[0] < 3:
        return float(max(X.size, 1))
    lam = np.clip(np.linalg.eigvalsh(np.atleast_2d(np.cov(X, rowvar=False))), 0.0, None)
    ratio = lam.sum() ** 2 / max(float(np.sum(lam**2)), 1e-300)
    s = np.concatenate([r.sum(axis=1) for r in R])
    ss = float(s @ s)
    return max(
        X.shape[0] / float(_correlation_time(ss, s[1:] @ s[:-1])) * max(ratio, 1.0),
        1.0,
    )


def refine(
    problem, fit, train_idx, *, spread=FINE_SPREAD, max_nfev=FINE_NFEV, keys=None
):
    """Fine calibration on top of a screening :func:`calibrate` fit.

    Frees the node parameters of :func:`fine_keys` (log multipliers with a
    Gaussian prior of spread ``spread``), fitted with the gains by nonlinear
    least squares on the training runs. The data are weighted by their
    effective number of independent samples, so that slow, correlated model
    errors do not overrule the prior. Returns a new :class:`Fit`.
    """
    base = fit.machine
    keys = fine_keys(base) if keys is None else list(keys)
    if not keys:
        return fit
    ref = base.params
    drift = drift_mask(problem, fit.effects, fit.machine)

    def model(x):
        return base.with_params(
            {k: ref[k] * v for k, v in zip(keys, np.exp(x), strict=True)}
        )

    def data(x):
        m = model(x)
        preds = {
            i: predict_run(m, problem, problem.runs[i], parts=True) for i in train_idx
        }
        gain = fit_gains(problem, preds, train_idx, drift=drift)
        return residuals(problem, preds, gain, train_idx, drift), gain, m, preds

    R0 = data(np.zeros(len(keys)))[0]
    scale = np.sqrt(sum(float(np.sum(r * r)) for r in R0) / _effective_samples(R0))
    scale = max(scale, 1e-12)

    def vector(x):
        R = data(x)[0]
        return np.concatenate(
            [np.concatenate([r.ravel() for r in R]) / scale, x / spread]
        )

    lo, hi = _fine_bounds(keys, ref)
    jac = BroydenJacobian(vector, (lo, hi))
    res = least_squares(
        jac.reduced_fun,
        np.zeros(len(keys)),
        jac=jac.reduced_jac,
        bounds=(lo, hi),
        max_nfev=max_nfev,
    )
    _, gain, m, preds = data(res.x)
    return Fit(
        fit.effects,
        dict(fit.values),
        gain,
        m,
        float(res.cost),
        fit.nfev + int(res.nfev),
        dict(zip(keys, np.exp(res.x), strict=True)),
        training_drift(problem, preds, gain, train_idx, drift),
    )


class _Memo:
    """``fun`` remembering its last point and value (least_squares asks for
    the Jacobian at the point it has just evaluated)."""

    def __init__(self, fun):
        self.fun = fun
        self.x = self.f = None

    def __call__(self, x):
        if self.x is None or not np.array_equal(x, self.x):
            self.f = self.fun(x)
            self.x = np.array(x, copy=True)
        return self.f


class BroydenJacobian:
    """A Jacobian for ``least_squares`` that simulates little.

    At the first point: forward differences with steps ``rel_step *
    max(1, |x|)``, turned back at a bound (scipy's ``approx_derivative``
    with that ``abs_step``). At every later point (the
    accepted steps): Broyden's rank-one update from the step and the change
    of the residuals, ``J += (df - J dx) dx^T / (dx^T dx)``, which costs no
    simulation. Exact along the steps taken, approximate across them.

    ``least_squares`` takes :meth:`reduced_fun` and :meth:`reduced_jac`: the
    residuals (``m`` of them, tens of thousands) folded into ``n + 1``
    (``n`` parameters). With ``f`` the residuals and ``J`` the Jacobian at a
    point, ``[f J] = Q R`` with ``R`` upper triangular; the reduced
    residuals are ``R[:, 0] = (|f|, 0, ..., 0)`` and their Jacobian
    ``R[:, 1:]``. The cost ``|f|^2 / 2``, the gradient ``J^T f`` and the
    Gauss-Newton model ``|f + J p|^2`` are those of the full problem, so the
    trust-region steps are the same, and each costs an ``(n + 1) x n``
    decomposition instead of an ``m x n`` one.
    """

    def __init__(self, fun, bounds, rel_step=1e-3):
        self.fun = _Memo(fun)
        self.lo, self.hi = (np.asarray(b, dtype=float) for b in bounds)
        self.rel_step = rel_step
        self.x = self.f = None
        # J = J0 + U V^T (the rank-one updates kept apart, so an update costs
        # no m x n matrix) and its Gram matrix J^T J, updated alike.
        self._J0 = self._gram = None
        self._U, self._V = [], []

    def _advance(self, x):
        """Residuals at ``x``, with the Jacobian brought to ``x``."""
        f = self.fun(x)
        if self._J0 is None:
            sign = np.where(x >= 0, 1.0, -1.0)
            h = self.rel_step * sign * np.maximum(1.0, np.abs(x))
            out = (x + h < self.lo) | (x + h > self.hi)
            fits = np.abs(h) <= np.maximum(x - self.lo, self.hi - x)
            h = np.where(out & fits, -h, h)
            h = (x + h) - x
            J = np.empty((f.size, x.size))
            for k in range(x.size):
                step = np.array(x, dtype=float, copy=True)
                step[k] += h[k]
                J[:, k] = (self.fun.fun(step) - f) / h[k]
            self._J0, self._gram = J, J.T @ J
        else:
            dx = x - self.x
            norm = float(dx @ dx)
            if norm > 0:
                u = f - self.f - self._times(dx)
                v = dx / norm
                Ju = self._transposed_times(u)
                self._gram = (
                    self._gram
                    + np.outer(Ju, v)
                    + np.outer(v, Ju)
                    + float(u @ u) * np.outer(v, v)
                )
                self._U.append(u)
                self._V.append(v)
        self.x, self.f = np.array(x, dtype=float, copy=True), f
        return f

    def _times(self, p):
        """``J @ p``."""
        out = self._J0 @ p
        for u, v in zip(self._U, self._V, strict=True):
            out += u * float(v @ p)
        return out

    def _transposed_times(self, w):
        """``J^T @ w``."""
        out = w @ self._J0
        for u, v in zip(self._U, self._V, strict=True):
            out += v * float(u @ w)
        return out

    @property
    def J(self):
        """The Jacobian at the last point (m x n)."""
        J = self._J0.copy()
        for u, v in zip(self._U, self._V, strict=True):
            J += np.outer(u, v)
        return J

    def __call__(self, x):
        self._advance(x)
        return self.J

    def reduced_fun(self, x):
        """``(|f(x)|, 0, ..., 0)``: residuals of the reduced problem."""
        f = self.fun(x)
        out = np.zeros(np.size(x) + 1)
        out[0] = np.sqrt(f @ f)
        return out

    def reduced_jac(self, x):
        """``R[:, 1:]`` of ``[f J] = Q R`` at ``x`` (the class's notes)."""
        f = self._advance(x)
        norm = np.sqrt(f @ f)
        n = np.size(x)
        first = self._transposed_times(f) / norm if norm > 0 else np.zeros(n)
        # The rest of R: any factor of J^T J minus the first row's part
        # (only its Gram matrix enters the model); the eigenvalue square
        # root is exact for a singular J too.
        rest = self._gram - np.outer(first, first)
        w, V = np.linalg.eigh((rest + rest.T) / 2)
        return np.vstack([first, np.sqrt(np.clip(w, 0.0, None))[:, None] * V.T])


def effect_parameters(effects):
    """Number of free parameters an effect set adds."""
    return sum(EFFECT_PARAMETER.get(e) is not None for e in effects)
