"""Gap diagnosis between two run tables: an external simulation and
measurements of the same runs.

The simulation may come from any tool (finite elements, a lumped model of
another package): only its exported run table is needed, with the same runs
and drivers as the measured one (at the measured times, or at its own time
step, then interpolated onto them). Each effect of the vocabulary is then
tested as a discrepancy term added to the simulated channels
(:mod:`skthermal.gap._terms`), calibrated on training runs and scored on
held-out runs, beside the evidence grey-box identification uses to select a
model structure (:mod:`skthermal.gap._evidence`).
"""

import logging
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from sklearn.utils._param_validation import StrOptions, validate_params

from skthermal._naming import TEMPERATURE_PATTERN, percent
from skthermal.datasets._runtable import meant_for, warn_implausible
from skthermal.gap._evidence import (
    explainable_summary,
    residual_lr_test,
    share_of_explainable,
    whiteness_columns,
)
from skthermal.gap._problem import (
    START_SAMPLES,
    USED_FOR,
    MeasuredRun,
    Problem,
    block_spans,
    channel_values,
    check_channel_names,
    check_length,
    check_mapping,
    check_measured_names,
    check_one_to_one,
    check_times,
    drift_table,
    driver_values,
    floor_squared,
    group_scales,
    is_channel,
    measured_varying,
    too_few_runs,
    warn_uncompared,
    without_attrs,
)
from skthermal.gap._regimes import label_regimes
from skthermal.gap._report import GapReport, with_recorded_warnings
from skthermal.gap._scores import (
    DIAGNOSIS_PARAMS,
    applicable,
    beyond_noise,
    block_test,
    candidate_list,
    excess_shrink,
    gap_of,
    heldout_folds,
    on_bound,
    order_candidates,
    rank_key,
    regime_gaps,
    ruled_out,
)
from skthermal.gap._terms import (
    TERMS,
    Base,
    RunSignals,
    Signals,
    flexible_heldout,
)
from skthermal.utils._faults import flat_columns, repair_spikes
from skthermal.utils._noise import noise_floor, pooled_noise
from skthermal.utils._runs import (
    check_labels,
    check_unique_columns,
    driver_lookalike_hint,
    warn_short_runs,
)
from skthermal.utils._threads import with_single_threaded_blas
from skthermal.utils._warnings import user_stacklevel

logger = logging.getLogger("skthermal.gap")

DRIVERS = ("time_s", "spindle_rpm", "ambient_C")


def _check_table(df, label):
    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"The {label} runs must be a DataFrame, got {type(df)}.")
    if df.shape[0] == 0:
        raise ValueError(f"The {label} run table is empty (no rows).")
    check_unique_columns(df, f"The {label} run table")
    missing = [c for c in ("run", *DRIVERS) if c not in df.columns]
    if missing:
        meant = [
            f"{c!r} for {name!r}"
            for name in ("run", "time_s")
            if name in missing
            for c in meant_for(df.columns, name)
        ]
        hint = f" (columns that may be meant: {', '.join(meant)})" if meant else ""
        raise ValueError(
            f"The {label} run table has no {missing} column(s){hint}; both tables "
            "need run, time_s, spindle_rpm and ambient_C (and feed_mm_min if the "
            "axis moved)" + driver_lookalike_hint(df.columns, missing) + "."
        )


def _align(
    simulated,
    measured,
    channels,
    mapping,
    max_samples,
    block_hours=None,
    driver_initial="rest",
):
    """Runs of both tables, checked against each other, as RunSignals."""
    _check_table(simulated, "simulated")
    _check_table(measured, "measured")
    simulated, measured = without_attrs(simulated), without_attrs(measured)
    mapping = dict(mapping or {})
    # The measured table is a run table; the simulated one may be another
    # tool's export, its columns matched by name or through the mapping.
    check_measured_names(measured.columns, mapping, channels, "The measured table's")
    check_mapping(
        mapping,
        measured.columns,
        simulated.columns,
        "are not columns of the simulated table",
    )
    explicit = channels is not None
    if channels is None:
        # Channels by name, and every measured column the mapping names.
        channels = [
            c
            for c in measured.columns
            if (is_channel(c) or c in mapping)
            and mapping.get(c, c) in simulated.columns
        ]
    channels = list(channels)
    check_channel_names(channels)
    bad = [c for c in channels if c not in measured.columns]
    if bad:
        raise ValueError(f"Channel(s) {bad} are not columns of the measured table.")
    bad = [mapping.get(c, c) for c in channels if mapping.get(c, c) not in simulated]
    if bad:
        raise ValueError(
            f"Column(s) {bad} are not in the simulated table; map measured "
            "columns to simulated ones with mapping={'measured': 'simulated'}."
        )
    if not channels:
        raise ValueError(
            "No measured channel (T*_C sensors or disp_*_um displacements) has a "
            "column of the same name in the simulated table; pass channels= or "
            "mapping=."
        )
    if not explicit:
        warn_uncompared(
            measured.columns,
            channels,
            "the simulated table has no column for",
            simulated.columns,
        )
    sim_cols = [mapping.get(c, c) for c in channels]
    check_one_to_one(channels, sim_cols)
    for table, label in ((simulated, "simulated"), (measured, "measured")):
        try:
            check_labels(table["run"].to_numpy())
        except ValueError as exc:
            raise ValueError(f"The {label} run table: {exc}") from None
    sim_runs = dict(tuple(simulated.groupby("run", sort=False)))
    meas_runs = list(measured.groupby("run", sort=False))
    missing = [name for name, _ in meas_runs if name not in sim_runs]
    if missing:
        as_text = {str(name) for name in sim_runs}
        hint = (
            "; the labels differ only in type (numbers in one table, text in "
            "the other): give both tables' run columns one type, e.g. "
            "measured['run'] = measured['run'].astype(str)"
            if all(str(name) in as_text for name in missing)
            else ""
        )
        raise ValueError(
            f"Run(s) {missing} of the measured table are missing from the "
            f"simulated table (it has {list(sim_runs)}){hint}."
        )
    extra = [name for name in sim_runs if name not in dict(meas_runs)]
    if extra:
        warnings.warn(
            f"Run(s) {extra} of the simulated table are not in the measured "
            "table and are not compared.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
    out = []
    for name, meas in meas_runs:
        sim = sim_runs[name]
        check_length(len(meas), name, "measured")
        t = driver_values(meas, "time_s", name, "measured")
        ts = driver_values(sim, "time_s", name, "simulated")
        check_times(t, name, "measured")
        check_times(ts, name, "simulated")
        tol = 1e-6 * max(1.0, float(np.max(np.abs(t))))
        span = (float(ts[0]), float(ts[-1]))
        _check_time_scales(t, ts, name)
        # Simulated rows before the measured start (a logger started late):
        # not compared, but the terms' filters run through them from the
        # simulation's start, with the simulation's drivers.
        before = _before_measured(sim, ts, t[0] - tol, sim_cols, name)
        # Simulated rows beyond the measured span, but for one on either
        # side to interpolate from, are neither compared nor checked.
        first = max(int(np.searchsorted(ts, t[0] + tol, side="right")) - 1, 0)
        last = min(int(np.searchsorted(ts, t[-1] - tol, side="left")), ts.size - 1)
        sim, ts = sim.iloc[first : last + 1], ts[first : last + 1]
        # The simulation at the measured times, or (another tool's export
        # at its own time step) interpolated linearly onto them.
        same = ts.size == t.size and not np.any(np.abs(t - ts) > tol)
        if not same:
            # A logger's jitter may put the first or last sample up to half
            # a sampling period beyond the simulated span: held there.
            slack = tol + (0.5 * float(np.median(np.diff(t))) if t.size > 1 else 0.0)
            if ts.size < 2 or ts[0] > t[0] + slack or ts[-1] < t[-1] - slack:
                raise ValueError(
                    f"Run {name!r}: the simulated table covers time_s "
                    f"{span[0]:.10g}-{span[1]:.10g} s, the measured one "
                    f"{t[0]:.10g}-{t[-1]:.10g} s. A simulation at other times "
                    "than the measurement's is interpolated onto them, so it "
                    "must cover the measured span (both in seconds)."
                    + (
                        " The measured times start after the simulation ends: "
                        "a clock's time? Give both tables the time since the "
                        "run's start."
                        if t[0] > span[1]
                        else ""
                    )
                )
        # Where the simulation was computed: its rows, and the measured
        # driver in force at each (zero-order hold).
        at = (
            np.arange(t.size)
            if same
            else np.clip(np.searchsorted(t, ts, side="right") - 1, 0, t.size - 1)
        )
        inside = (ts >= t[0] - tol) & (ts <= t[-1] + tol)
        if not same and t.size > 1:
            # Inside a logging gap of the measurement (a step longer than 1.5
            # sampling periods: rows missing) its drivers are not known: the
            # last logged value is only carried across it, and a driver that
            # changed in the gap (even at its first missing row) differs.
            step_after = np.r_[np.diff(t), 0.0][at]
            in_gap = step_after > 1.5 * float(np.median(np.diff(t))) + tol
            inside &= ~(in_gap & (ts > t[at] + tol))
        drivers, sim_drivers = {}, {}
        for col in ("spindle_rpm", "ambient_C", "feed_mm_min"):
            in_m, in_s = col in meas.columns, col in sim.columns
            m = driver_values(meas, col, name, "measured") if in_m else np.zeros(t.size)
            sim_d = (
                driver_values(sim, col, name, "simulated")
                if in_s
                else np.zeros(ts.size)
            )
            sim_drivers[col] = sim_d
            tol_d = 1e-3 * max(1.0, float(np.max(np.abs(m))))
            # The feed enters the terms as |feed|: a direction of travel
            # logged in one table only is no other driver.
            m_c, sim_c = (
                (np.abs(m), np.abs(sim_d)) if col == "feed_mm_min" else (m, sim_d)
            )
            if col == "ambient_C":
                tol_d = max(tol_d, 0.05)  # the air as logged, quantised
                if not same:  # between samples the logged air moves on
                    tol_d = max(tol_d, float(np.max(np.abs(np.diff(m)), initial=0)))
            # Only where both tables have the run: simulated rows before the
            # first or after the last measured sample (a simulation covering
            # more than the measurement) are not compared.
            wrong = np.abs(m_c[at] - sim_c) > tol_d
            if not same and t.size > 1:
                # A logger's clock jitters: a step of a driver may fall on
                # either side of a simulated row within half a sampling
                # period. The value of the measured sample that close (the
                # one before or after) is as good.
                half = 0.5 * float(np.median(np.diff(t)))
                for near in (np.maximum(at - 1, 0), np.minimum(at + 1, t.size - 1)):
                    close = np.abs(t[near] - ts) <= half
                    wrong &= ~(close & (np.abs(m_c[near] - sim_c) <= tol_d))
            off = np.flatnonzero(wrong & inside)
            if off.size:
                k = int(off[0])
                where = ""
                if not (in_m and in_s):
                    lacking = sim if in_m else meas
                    where = " (absent from one table: 0)" + driver_lookalike_hint(
                        lacking.columns, [col]
                    )
                row = f"row {k} of the run" if same else f"simulated row {k} of the run"
                small = abs(m[at[k]] - sim_d[k]) < 1.0
                if col == "ambient_C" and in_m and in_s:
                    where += _air_hint(m[at][inside], sim_d[inside], small)
                raise ValueError(
                    f"The drivers differ: {col} in run {name!r} at {row} "
                    f"(time {ts[k]:g} s) is {m[at[k]]:g} measured and {sim_d[k]:g} "
                    f"simulated{where}; simulate the measured drivers."
                )
            drivers[col] = m
        y_meas = repair_spikes(
            channel_values(meas, channels, t, name, "measured"),
            channels,
            t,
            name,
            "measured",
            USED_FOR,
            **drivers,
        )
        y_sim = repair_spikes(
            channel_values(sim, sim_cols, ts, name, "simulated"),
            sim_cols,
            ts,
            name,
            "simulated",
            USED_FOR,
            **sim_drivers,
        )
        if not same:
            y_sim = np.column_stack(
                [np.interp(t, ts, y_sim[:, c]) for c in range(y_sim.shape[1])]
            )
        out.append((name, t, drivers, y_meas, y_sim, before))
    # Measured runs that start after 0 are no clock's time when the
    # simulation starts before them (a logger started late).
    warn_implausible(measured, late_start=not any(row[5] is not None for row in out))
    # The same warnings of the simulated table, which has the same columns:
    # said of which table.
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        warn_implausible(simulated, late_start=False)
    for w in said:
        warnings.warn(
            f"The simulated table: {w.message}",
            w.category,
            stacklevel=user_stacklevel(),
        )
    warn_short_runs("diagnose_runs", {name: t[-1] - t[0] for name, t, *_ in out}, 5)
    _warn_warm_starts(out, channels)
    aligned = [row[:5] for row in out]
    blocks = [block_spans(t, name, block_hours) for name, t, *_ in out]
    if sum(len(b) for b in blocks) < 2:
        longest = max(float(t[-1] - t[0]) for _, t, *_ in out)
        raise too_few_runs(len(out), longest, block_hours)
    keep = _varying_channels(aligned, channels, sim_cols, explicit)
    channels = [c for c, k in zip(channels, keep, strict=True) if k]
    sim_cols = [c for c, k in zip(sim_cols, keep, strict=True) if k]
    runs = []
    for (name, t, drivers, y_meas, y_sim, before), spans in zip(
        out, blocks, strict=True
    ):
        # A block (block_hours) keeps its run's signals from the start (the
        # terms' filters start there, gaps judged against the whole run's
        # sampling period), compared over its own span only; so does a run
        # whose simulation starts before its measurement (``before``: the
        # simulated rows ahead of it).
        period = float(np.median(np.diff(t))) if t.size > 1 else None
        ahead = 0 if before is None else before["time_s"].size
        t0 = t[0] if before is None else before["time_s"][0]

        for a, b, label in spans:
            check_length(b - a, label)
            step = max(1, int(np.ceil((b - a) / max_samples)))
            rows = np.arange(a, b, step)
            y = y_meas[rows][:, keep]
            runs.append(
                RunSignals(
                    label,
                    _ahead(before, "time_s", t[:b]) - t0,
                    _ahead(before, "spindle_rpm", drivers["spindle_rpm"][:b]),
                    _ahead(before, "ambient_C", drivers["ambient_C"][:b]),
                    _ahead(before, "feed_mm_min", drivers["feed_mm_min"][:b]),
                    _ahead(before, "sim", y_sim[:b][:, keep], keep),
                    rows + ahead,
                    y - y[:START_SAMPLES].mean(axis=0),
                    origin=None if len(spans) == 1 else name,
                    period=None if len(spans) == 1 and not ahead else period,
                    driver_initial=driver_initial,
                )
            )
    noise = pooled_noise([row[3][:, keep] for row in out])
    return runs, channels, sim_cols, noise


# Least simulated time steps per measured run's span: fewer, and the run is
# compared with a few straight lines between simulated rows.
_MIN_SIMULATED_STEPS = 3
# The simulated rows this many times (or more) further apart than the
# measured ones, too few of them in a run: a simulation whose time_s is in
# milliseconds (a thousand times) rather than an export at a coarse step.
_MS_RATIO = (300.0, 3000.0)


def _check_time_scales(t, ts, name):
    """Check the simulated run's median time step ``ts`` against the span of
    the measured run ``t``: when fewer than :data:`_MIN_SIMULATED_STEPS`
    such steps fit in it, the measurement is compared with straight lines
    between a few simulated rows. Raise when the steps are some thousand
    times the measured ones (:data:`_MS_RATIO`: a simulation's ``time_s`` in
    milliseconds read as seconds, which an independent check's diagnosis
    took silently for "no candidate explains the gap"), else warn naming
    the run (a short run beside a coarse export)."""
    if t.size < 2 or ts.size < 2:
        return
    length = float(t[-1] - t[0])
    step = float(np.median(np.diff(ts)))
    if step * _MIN_SIMULATED_STEPS <= length:
        return
    ratio = step / float(np.median(np.diff(t)))
    text = (
        f"Run {name!r}: the simulated rows are {step:g} s apart (median step of "
        f"time_s), the measured run lasts {length:g} s: fewer than "
        f"{_MIN_SIMULATED_STEPS} simulated steps fall in it, and the measurement "
        "is compared with straight lines between them."
    )
    if _MS_RATIO[0] <= ratio <= _MS_RATIO[1]:
        raise ValueError(
            f"{text} The simulated rows are some {ratio:.0f} times further apart "
            "than the measured ones: a simulation's time_s in milliseconds? Give "
            "both tables time_s in seconds since the run's start."
        )
    warnings.warn(
        f"{text} Export the simulation at a finer step for such runs, or leave "
        "them out.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def _before_measured(sim, ts, start, sim_cols, name):
    """The simulated rows of a run before its measured start (``start``):
    their times, drivers (a driver the simulated table lacks is 0) and
    simulated channels, or None when the simulation starts with the
    measurement."""
    ahead = ts < start
    if not ahead.any():
        return None
    rows = sim[ahead]
    out = {"time_s": ts[ahead]}
    for col in ("spindle_rpm", "ambient_C", "feed_mm_min"):
        out[col] = (
            driver_values(rows, col, name, "simulated")
            if col in rows.columns
            else np.zeros(out["time_s"].size)
        )
    out["sim"] = channel_values(rows, sim_cols, out["time_s"], name, "simulated")
    return out


def _ahead(before, key, values, keep=None):
    """``values`` of a run's signals with the simulated rows ahead of its
    measurement (``before``, :func:`_before_measured`) in front."""
    if before is None:
        return values
    pre = before[key] if keep is None else before[key][:, keep]
    return np.concatenate([pre, values])


def _varying_channels(aligned, channels, sim_cols, explicit):
    """Mask of the channels kept. A channel constant in both tables on every
    run has nothing to diagnose: an error when chosen explicitly, else left
    out with a warning. So is a channel whose measurement alone is constant
    on every run (:func:`measured_varying`). A channel constant only in the
    simulation (one it does not model) is left out with a warning, or, when
    chosen explicitly, kept (the base gain is then 0) with a warning."""
    flat_m = np.all([flat_columns(y) for _, _, _, y, _ in aligned], axis=0)
    flat_s = np.all([flat_columns(y) for _, _, _, _, y in aligned], axis=0)
    both = [c for c, f in zip(channels, flat_m & flat_s, strict=True) if f]
    if both and (explicit or len(both) == len(channels)):
        raise ValueError(
            f"Channel(s) {both} are constant in both tables on every run: "
            "there is nothing to diagnose on them; "
            + (
                "leave them out of channels=."
                if explicit
                else "no channel is left to compare."
            )
        )
    if both:
        warnings.warn(
            f"Channel(s) {both} are constant in both tables on every run and "
            "are left out: there is nothing to diagnose on them.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
    # A measured channel constant on every run (a dead probe) whatever the
    # simulation does: the same rule as above, on the channels left.
    left = ~(flat_m & flat_s)
    keep = left.copy()
    keep[left] = measured_varying(
        [y[:, left] for _, _, _, y, _ in aligned],
        [c for c, k in zip(channels, left, strict=True) if k],
        explicit,
        stacklevel=6,
    )
    unmodelled = flat_s & ~flat_m & keep
    only_sim = [c for c, f in zip(sim_cols, unmodelled, strict=True) if f]
    if only_sim and explicit:
        warnings.warn(
            f"The simulated channel(s) {only_sim} are constant on every run: the "
            "simulation predicts no change there, so the base gain is 0 and the "
            "whole measured change of those channels counts as gap.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
    elif only_sim:
        # The simulation does not model them: any term built from the drivers
        # alone would take up their whole measured change, and be named for
        # it whatever the missing physics.
        if not (keep & ~unmodelled).any():
            raise ValueError(
                f"The simulated channel(s) {only_sim} are constant on every run: "
                "the simulation predicts no change on any compared channel, so "
                "no effect can be judged against it."
            )
        warnings.warn(
            f"The simulated channel(s) {only_sim} are constant on every run: the "
            "simulation does not model them, so no missing effect can be "
            "judged there, and they are left out (name them in channels= to "
            "compare them anyway; their whole measured change then counts as "
            "gap).",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
        keep = keep & ~unmodelled
    return keep


# A base gain this far from one (either way) that does most of the
# calibration's work is a unit slip or a simulation off by that factor.
_SCALE_SLIP = 10.0


def _warn_scale_slips(channels, gain, as_given, calibrated):
    """Warn naming the channels whose simulation fits the measurement only
    after the base gain (calibrated on all runs) scales it by
    :data:`_SCALE_SLIP` or more, or flips its sign, while that gain removes
    most of the gap: the base takes the factor up, and the verdict would
    then say nothing of it (nm under a ``_um`` header read as "the
    simulation matches")."""

    def rms(residuals):
        return np.sqrt(
            sum(np.sum(r * r, axis=0) for r in residuals)
            / max(sum(r.shape[0] for r in residuals), 1)
        )

    before, after = rms(as_given), rms(calibrated)
    scaled = (np.abs(gain) >= _SCALE_SLIP) | (np.abs(gain) <= 1 / _SCALE_SLIP)
    slip = (scaled | (gain < 0)) & (after < 0.5 * before)
    if not slip.any():
        return
    text = ", ".join(f"{channels[c]!r} by {gain[c]:.3g}" for c in np.flatnonzero(slip))
    warnings.warn(
        f"The simulation fits the measurement only scaled ({text}: the base "
        "gain of the channel, calibrated on all runs, which removes most of "
        "its gap): a unit slip (nm or mm under a *_um header, K or mK in a "
        "*_C column), a sign convention of the axis, or a simulation off by "
        "that factor? The diagnosis takes the factor as part of the base and "
        "judges the effects on what is left.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def _kinds(channels, sim_cols):
    """Which compared channels are displacements: by the measured column's
    name (the run-table contract), else the simulated one's; a channel named
    neither way is an error (displacements and temperatures are scaled and
    corrected apart)."""
    out = []
    for measured, simulated in zip(channels, sim_cols, strict=True):
        for name in (measured, simulated):
            if is_channel(name):
                out.append(str(name).startswith("disp_"))
                break
        else:
            raise ValueError(
                f"Cannot tell whether channel {measured!r} (simulated "
                f"{simulated!r}) is a temperature or a displacement: name the "
                "measured column T<name>_C or disp_<name>_um."
            )
    return np.array(out, dtype=bool)


def _problem(runs, channels, sim_cols, noise):
    """The measured side as a :class:`Problem` (scales, weights, noise)."""
    is_disp = _kinds(channels, sim_cols)
    scale, weight = group_scales(np.vstack([r.y for r in runs]), is_disp)
    measured = [
        MeasuredRun(
            name=r.name,
            time_s=r.time_s,
            spindle_rpm=r.spindle_rpm,
            ambient_C=r.ambient_C,
            feed_mm_min=r.feed_mm_min,
            rows=r.rows,
            y=r.y,
        )
        for r in runs
    ]
    return Problem(measured, channels, sim_cols, is_disp, scale, weight, noise)


def _residuals(signals, preds, idx):
    """Normalised, weighted residuals (prediction minus measurement)."""
    return [(p - signals.runs[i].y) * signals.w for p, i in zip(preds, idx)]


def _heldout(signals, folds, make, cache=None):
    """Held-out residuals of every run and the fold models: ``make()``
    returns an unfitted model (term with its ``with_terms``); ``cache`` is
    shared by the folds' fits (see ``DiscrepancyTerm.fit``)."""
    out = [None] * len(signals.runs)
    models = []
    for train, test in folds:
        model = make(train).fit(signals, train, cache)
        models.append(model)
        for i, R in zip(test, _residuals(signals, model.apply(signals, test), test)):
            out[i] = R
    return out, models


def _evaluate(signals, folds, with_terms, before_R, before_in, name, ctx):
    """Held-out score and in-sample evidence of adding term ``name``."""
    regimes, floor2, min_shrink, alpha, all_idx, before_regimes = ctx
    # The folds and the fit on all runs search the same grid on
    # overlapping runs: each run's statistics at a grid point are worked out
    # once.
    cache = {}
    after_R, models = _heldout(
        signals,
        folds,
        lambda train: TERMS[name]([t[train_key(train)] for t in with_terms]),
        cache,
    )
    gap_b, ms_b = gap_of(before_R)
    gap_a, ms_a = gap_of(after_R)
    shrink = excess_shrink(gap_b, gap_a, floor2)
    p = block_test(before_R, after_R)
    full = TERMS[name]([t["all"] for t in with_terms]).fit(signals, all_idx, cache)
    after_in = _residuals(signals, full.apply(signals, all_idx), all_idx)
    # Per channel (each with its own noise), effective samples corrected for
    # the residual's autocorrelation.
    lr = residual_lr_test(before_in, after_in, full.n_params(signals))
    thetas = [m.theta_ for m in models]
    row = {
        "effect": name,
        "gap_before": gap_b,
        "gap_after": gap_a,
        "shrink": shrink,
        "shrink_raw": 1.0 - gap_a / gap_b if gap_b > 0 else 0.0,
        "p_value": p,
        "runs_improved": int(np.sum(ms_b - ms_a > 0)),
        "n_runs": int(ms_b.size),
        "extra_params": full.n_params(signals),
        "lr_df": lr.df,
        "lr_statistic": lr.statistic,
        "lr_p_value": lr.p_value,
        "delta_aic": lr.delta_aic,
        "delta_bic": lr.delta_bic,
        **whiteness_columns(before_R, after_R),
        "fitted": {k: float(np.median([t[k] for t in thetas])) for k in full.theta_},
    }
    per_sensor = None
    if not full.theta_ and name == "sensor_drift":
        # No nonlinear parameter: the root mean square over the temperature
        # channels of the drift rates of report.drift_rates (each the median
        # over the folds) in °C/h, as the ThermalMachine mode and the
        # simulator's ``rate_C_per_h``.
        rates = np.array([m.gains_[signals.is_temp, -1] for m in models])
        if rates.size:
            rates = np.median(rates, axis=0)
            row["fitted"] = {"rate_C_per_h": float(np.sqrt(np.mean(rates**2)))}
            names = np.asarray(signals.channels, dtype=object)
            names = names[signals.is_temp] if names.size else range(rates.size)
            per_sensor = dict(zip(names, rates, strict=True))
    row["ruled_out"] = ruled_out(name, row["fitted"], per_sensor)
    term = TERMS[name]
    row["on_bound"] = on_bound(row["fitted"], term.bounds)
    row["stopped"] = on_bound(row["fitted"], term.bounds, term.open_ends)
    row["explains"] = (
        bool(shrink >= min_shrink and p < alpha)
        and beyond_noise(gap_b, floor2)
        and not row["ruled_out"]
        and not row["stopped"]
    )
    rb = regime_gaps(before_R, regimes) if before_regimes is None else before_regimes
    ra = regime_gaps(after_R, regimes)
    return row, (rb, ra), after_R, {"folds": models, "all": full}


def _drift_table(problem, evaluation):
    """``GapReport.drift_rates``: the ``sensor_drift`` term's gain of every
    compared temperature channel on its signal (hours since the run's
    start): the drift rate in °C/h of the readings, median over the folds
    (empty without the candidate)."""
    if evaluation is None:
        return {}
    temp = ~problem.is_disp
    return drift_table(problem, [m.gains_[temp, -1] for m in evaluation[3]["folds"]])


def _flexible_heldout(signals, folds, fitted):
    """Held-out residuals of the flexible discrepancy model
    (:func:`flexible_heldout`) on the external simulation, with the signals
    of every candidate term fitted on the fold's training runs (``fitted``:
    per candidate, ``{"folds": [...]}``) among its features."""
    every = range(len(signals.runs))
    extra = []
    for k in range(len(folds)):
        terms = [fit["folds"][k] for fit in fitted if fit["folds"][k].n_signals]
        feats = [term.features_of(signals, every, term.theta_) for term in terms]
        extra.append([[f[i] for f in feats] for i in every])
    return flexible_heldout([signals] * len(folds), folds, extra)


def train_key(train):
    """Key of a fold's fitted terms: its training runs."""
    return tuple(int(i) for i in train)


@dataclass(repr=False)
class ExternalGapReport(GapReport):
    """Result of :func:`skthermal.gap.diagnose_runs`.

    As :class:`GapReport`, with the simulation given as a run table; the
    ranking also holds, per candidate discrepancy term, the likelihood-ratio
    test of the model with the term against the base (in sample, Gaussian
    residuals, effective samples corrected for autocorrelation:
    ``lr_statistic``, ``lr_p_value``, ``extra_params``, ``delta_aic``,
    ``delta_bic``), the whiteness of the held-out residual before and after
    (largest deviation of the cumulated periodogram from the diagonal, the
    95% Kolmogorov-Smirnov ``white_band``, ``white_after``) and
    ``share_of_explainable``.

    ``explainable`` is as in :class:`GapReport`; here the flexible model
    corrects the external simulation itself.
    """

    # The user's own simulation: the where answer is about it as given.
    where_model = "as given"

    def _verdict(self):
        row = self.how_far_evidence
        if not row:
            return "No candidate effect was tested."
        flexible = self._flexible_text(row)
        as_given = _as_given_text(row.get("gap_as_given", np.nan), row["gap_before"])
        evidence = (
            f"held-out gap {row['gap_before']:.3g}{as_given} -> "
            f"{row['gap_after']:.3g}, "
            f"{row['runs_improved']}/{row['n_runs']} held-out runs better, "
            f"p = {row['p_value']:.2g}; in-sample likelihood ratio p = "
            f"{row['lr_p_value']:.2g}{flexible}"
        )
        if self.best_effect is None:
            return (
                f"{self._none_opening(row)} ({self._best_candidate_text(row)}: "
                f"{evidence})." + self._unnamed_tail(row)
            )
        text = (
            f"{self.best_effect!r} explains the gap: adding it removes "
            f"{percent(row['shrink'])} of the held-out gap above the noise floor "
            f"({evidence})."
        )
        return text + self._bound_text(row) + self._named_tail()

    def __repr__(self):
        return f"ExternalGapReport(best_effect={self.best_effect!r}): {self.verdict()}"


@validate_params(
    {
        "simulated": [pd.DataFrame],
        "measured": [pd.DataFrame],
        **DIAGNOSIS_PARAMS,
        "driver_initial": [StrOptions({"rest", "steady"})],
    },
    prefer_skip_nested_validation=True,
)
@with_single_threaded_blas
@with_recorded_warnings
def diagnose_runs(
    simulated,
    measured,
    candidates=None,
    cv=None,
    *,
    channels=None,
    mapping=None,
    min_shrink=0.5,
    alpha=0.05,
    greedy=True,
    max_samples=600,
    block_hours=None,
    driver_initial="rest",
    n_jobs=None,
):
    """Diagnose the gap between a simulation's run table and measured runs.

    The simulation can come from any tool: its run table has the same runs
    and drivers as the measured one, and the channels it predicts. At the
    measured times, or at its own time step covering each measured run: it
    is then interpolated linearly onto the measured times (its drivers are
    checked against the measured ones in force at its own rows).

    1. **Where**: the gap of the simulation as given and with the base
       calibrated (one gain per channel, on all runs), per run, regime,
       channel and frequency band.
    2. **Which**: every candidate effect, written as a discrepancy term added
       to the simulated channels (a lag of the simulated temperatures for
       ``sensor_lag``, a speed-weighted filtered rise for
       ``speed_convection``, a response that relaxes after each spindle stop
       for ``tool_growth``, a band-pass of the air for
       ``ambient_transient``, a filtered |feed| for ``feed_heating``, a trend
       per sensor for ``sensor_drift``), is calibrated with the base on
       training runs (its time constants by a bounded search, its gains by
       least squares per channel) and scored on held-out runs. An effect
       explains the gap when it removes at least ``min_shrink`` of the
       held-out gap above the noise floor and the improvement is significant
       (one-sided paired t-test over blocks of the held-out runs at
       ``alpha``). Beside it: the likelihood-ratio test against the base (in
       sample, effective samples corrected for autocorrelation), the change
       of AIC and BIC, and the whiteness of the held-out residual before and
       after. A flexible discrepancy model of the drivers (ridge regression
       on their lag features, fitted on training runs) estimates how much of
       the held-out gap any added term could close (held out it is not a
       strict bound: a term may remove more, and it may make the gap worse);
       every effect's shrink is also given as a share of that, unclipped.
       A candidate whose term is zero on every run and compared channel
       (``feed_heating`` without feed, a temperature term with only
       displacements compared) is not scored: it is listed in
       ``report.not_applicable`` and in the verdict.
    3. **How far**: the held-out gap before and after the best effect (or
       the best candidate), per regime; then, with ``greedy``, further
       effects while one still explains what remains.

    Parameters
    ----------
    simulated, measured : DataFrame
        Run tables (``run``, ``time_s``, ``spindle_rpm``, ``ambient_C``,
        optional ``feed_mm_min``; channels ``T*_C`` and ``disp_*_um``) with
        the same runs and drivers; the simulated times may differ (see
        above).
    candidates : sequence of str, optional
        Effects to test (default: every discrepancy term).
    cv : int, splitter or iterable of (train, test), optional
        Held-out scheme over runs (every run held out exactly once, by a
        fold that does not train on it): default leave-one-run-out for up to 3
        runs, else 3-fold GroupKFold; an int is a number of GroupKFold
        folds (at most the number of runs); a splitter splits the runs
        (one group each); (train, test) pairs are run indices, the runs
        numbered in their order in the table.
    channels : sequence of str, optional
        Measured columns compared (default: every measured channel with a
        simulated column of the same name, with a warning naming the
        measured channels left out; a channel constant in both tables is
        then left out with a warning, while named here it is an error).
    mapping : dict, optional
        ``{measured column: simulated column}`` when the names differ; a key
        that is not a measured column or a value that is not a simulated
        column is an error.
    min_shrink : float, default=0.5
        Share of the excess held-out gap an effect must remove to explain it.
    alpha : float, default=0.05
        Significance level of the held-out improvement.
    greedy : bool, default=True
        After the best effect, add further effects while they explain more.
    max_samples : int, default=600
        Samples per run compared (the terms are computed at the full rate).
    block_hours : float, optional
        Cut runs longer than 1.5 ``block_hours`` into consecutive blocks of
        about that length, held out one by one (for one long record, e.g. a
        multi-day test), as :func:`skthermal.gap.diagnose` does. The terms
        of a block are computed from the start of its run (so their filters
        are warm), and compared over the block's own span, re-zeroed at its
        start; blocks are labelled with their span, e.g. ``r1[0-2 h]``.
    driver_initial : {"rest", "steady"}, default="rest"
        The drivers' heat before each run, for the terms and features that
        filter the drivers (``feed_heating``'s |feed|, the flexible model's
        speed and |feed|): ``"rest"``, none (the runs start soaked, as a
        simulation started from rest assumes: heat from a run that starts
        cutting builds up from its first row); ``"steady"``, what the first
        row's drivers give in steady state (runs that start where the
        machine had been working as it does at their first row).
    n_jobs : int, optional
        Candidates evaluated in parallel (joblib). Worth it only when a
        diagnosis takes tens of seconds (long or many runs): starting the
        workers costs seconds, and a diagnosis of 5 runs of 8 h at 60 s took
        0.5 s serially and 3.6 s with ``n_jobs=2``.

    Returns
    -------
    ExternalGapReport

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from scipy.signal import lfilter
    >>> from skthermal.gap import diagnose_runs
    >>> rng = np.random.default_rng(0)
    >>> frames_s, frames_m = [], []
    >>> for r in range(4):
    ...     t = np.arange(0, 6 * 3600, 60.0)
    ...     rpm = np.where((t // 3600) % 2 == r % 2, 4000.0, 0.0)
    ...     heat = lfilter([0.02], [1, -0.98], rpm / 1000)
    ...     sim = 20 + np.column_stack([heat, 0.5 * heat])
    ...     a = np.exp(-60 / 900)
    ...     lag = lfilter([1 - a], [1, -a], sim - 20, axis=0) + 20
    ...     meas = lag + 0.01 * rng.standard_normal(sim.shape)
    ...     base = {"run": r, "time_s": t, "spindle_rpm": rpm, "ambient_C": 20.0}
    ...     frames_s.append(pd.DataFrame({**base, "T1_C": sim[:, 0],
    ...                                   "T2_C": sim[:, 1]}))
    ...     frames_m.append(pd.DataFrame({**base, "T1_C": meas[:, 0],
    ...                                   "T2_C": meas[:, 1]}))
    >>> report = diagnose_runs(pd.concat(frames_s), pd.concat(frames_m),
    ...                        candidates=["sensor_lag", "feed_heating"])
    >>> report.best_effect
    'sensor_lag'
    """
    candidates = candidate_list(candidates, TERMS)
    runs, channels, sim_cols, noise = _align(
        simulated, measured, channels, mapping, max_samples, block_hours, driver_initial
    )
    problem = _problem(runs, channels, sim_cols, noise)
    problem.meta["source"] = "run table"
    w = np.sqrt(problem.weight) / problem.scale
    signals = Signals(runs, ~problem.is_disp, w, tuple(problem.channels))
    n = len(runs)
    all_idx = list(range(n))
    folds = [
        (list(tr), list(te)) for tr, te in heldout_folds(n, cv, [r.name for r in runs])
    ]
    # Terms with nothing to act on (no feed, no compared channel of their
    # kind) are not scored: a zero term would only add noise to the ranking.
    not_applicable = {
        c: why for c in candidates if (why := TERMS[c]().inert(signals)) is not None
    }
    candidates = applicable(candidates, not_applicable)
    floor2 = floor_squared(problem)
    regimes = [
        label_regimes(r.time_s, r.spindle_rpm, r.ambient_C, r.feed_mm_min)
        .iloc[r.rows]
        .reset_index(drop=True)
        for r in runs
    ]
    logger.info(
        "Prepared %d run(s), %d channel(s); %d candidate(s): %s.",
        n,
        len(channels),
        len(candidates),
        ", ".join(candidates),
    )

    # Where: as given, and with the base calibrated on all runs.
    as_given = [
        (r.compared(r.sim) - r.y) * w for r in runs
    ]  # prediction minus measurement
    base_all = Base().fit(signals, all_idx)
    calibrated = _residuals(signals, base_all.apply(signals, all_idx), all_idx)
    _warn_scale_slips(channels, base_all.gains_[:, 0], as_given, calibrated)

    # Which: the base held out, then every candidate.
    base_R, _ = _heldout(signals, folds, lambda train: Base())
    ctx = (regimes, floor2, min_shrink, alpha, all_idx, regime_gaps(base_R, regimes))
    jobs = Parallel(n_jobs=n_jobs)(
        delayed(_evaluate)(signals, folds, (), base_R, calibrated, c, ctx)
        for c in candidates
    )
    # How much any added term could close: the flexible model.
    flex_R = _flexible_heldout(signals, folds, [j[3] for j in jobs])
    explainable = explainable_summary(base_R, flex_R, floor2)
    rows = [j[0] for j in jobs]
    for row in rows:
        row["share_of_explainable"] = share_of_explainable(
            row["shrink"], explainable["share"]
        )
        logger.info(
            "Which: %s: held-out gap %.3g -> %.3g, shrink %.0f%% above noise "
            "(%.0f%% of the explainable), p = %.2g, in-sample likelihood ratio "
            "p = %.2g%s.",
            row["effect"],
            row["gap_before"],
            row["gap_after"],
            100 * row["shrink"],
            100 * row["share_of_explainable"],
            row["p_value"],
            row["lr_p_value"],
            " (explains)" if row["explains"] else "",
        )
    by_name = {j[0]["effect"]: j for j in jobs}
    ranking = order_candidates(pd.DataFrame(rows))
    regime_shrink = pd.concat(
        [
            (1.0 - ra / rb.reindex(ra.index)).rename(row["effect"])
            for row, (rb, ra), _, _ in jobs
        ],
        axis=1,
    )
    focus = ranking.iloc[0]["effect"]
    focus_row, (rb, ra), focus_R, _ = by_name[focus]
    best = focus if focus_row["explains"] else None

    # How far: the best effect, then greedily more.
    steps = []
    if best is not None:
        added = [by_name[best][3]]
        steps.append(
            {
                "added": best,
                "gap": focus_row["gap_after"],
                "shrink": focus_row["shrink"],
                "calibration": "discrepancy term",
            }
        )
        current_R = focus_R
        current_in = _residuals(
            signals, added[0]["all"].apply(signals, all_idx), all_idx
        )
        remaining = [c for c in candidates if c != best]
        while greedy and remaining:
            ctx = (*ctx[:-1], regime_gaps(current_R, regimes))
            more = Parallel(n_jobs=n_jobs)(
                delayed(_evaluate_more)(
                    signals, folds, added, current_R, current_in, c, ctx
                )
                for c in remaining
            )
            more.sort(key=lambda j: rank_key(j[0]), reverse=True)
            top = more[0]
            if not top[0]["explains"]:
                break
            added.append(top[3])
            current_R = top[2]
            current_in = _residuals(
                signals, top[3]["all"].apply(signals, all_idx), all_idx
            )
            steps.append(
                {
                    "added": top[0]["effect"],
                    "gap": top[0]["gap_after"],
                    "shrink": top[0]["shrink"],
                    "calibration": "discrepancy term",
                }
            )
            remaining.remove(top[0]["effect"])
    # The simulation as given on the same rows: a base whose per-channel
    # gains do not carry from run to run can be worse held out.
    fine_row = dict(
        focus_row, calibration="discrepancy term", gap_as_given=gap_of(as_given)[0]
    )
    report = ExternalGapReport._build(
        problem=problem,
        machine=_Named("external simulation (run table)"),
        candidates=candidates,
        ranking=ranking,
        regime_shrink=regime_shrink,
        best_effect=best,
        steps=steps,
        base_R=base_R,
        best_R=focus_R if best is not None else None,
        fine_row=fine_row,
        fine_regimes=(rb, ra),
        fine_before_R=base_R,
        fine_after_R=focus_R,
        as_given=as_given,
        calibrated=calibrated,
        regimes=regimes,
        floor2=floor2,
        settings={
            "min_shrink": min_shrink,
            "alpha": alpha,
            "folds": len(folds),
            "mode": "external",
            "block_hours": block_hours,
        },
    )
    report.explainable = explainable
    report.drift_rates = _drift_table(problem, by_name.get("sensor_drift"))
    report.machines = {"base calibrated": base_all}
    report.not_applicable = not_applicable
    logger.info("Verdict: %s", report.verdict())
    return report


def _evaluate_more(signals, folds, added, before_R, before_in, name, ctx):
    """:func:`_evaluate` on top of already added terms (``added``: their
    fold and all-run fits)."""
    with_terms = [
        {**{train_key(tr): m for (tr, _), m in zip(folds, a["folds"])}, "all": a["all"]}
        for a in added
    ]
    # Each earlier term carries its own earlier terms: only the last is
    # needed as the chain, but the features of all of them are used.
    return _evaluate(signals, folds, with_terms, before_R, before_in, name, ctx)


@dataclass
class _Named:
    name: str


def _air_hint(measured, simulated, small):
    """Why the simulated air (``simulated``, at the simulated rows) differs
    from the measured one (``measured``, at the same rows), for the error:
    another unit, a constant offset, noise on one side; empty when none
    fits (a simulation driven by another air series altogether)."""
    if np.allclose(simulated, measured * 1.8 + 32.0, atol=1.0):
        return " (the simulated air in °F? ambient_C is in °C: (F - 32) / 1.8)"
    if np.allclose(simulated, measured + 273.15, atol=1.0):
        return " (the simulated air in kelvin? ambient_C is in °C: K - 273.15)"
    diff = simulated - measured
    if np.std(diff) <= 0.25 * abs(np.mean(diff)):
        return (
            f" (the simulated air is the measured one offset by "
            f"{np.mean(diff):+.2g} K throughout: another air probe, or one "
            "calibrated otherwise? Drive the simulation with the logged air)"
        )
    if not small:
        return ""
    # Off by a little and not by a constant: noise on one side.
    rough_m, rough_s = (
        float(noise_floor(np.asarray(v, float)[:, None])[0])
        for v in (measured, simulated)
    )
    if rough_s < 0.5 * rough_m:
        return (
            " (the simulated air is smooth and the measured one noisy: the "
            "simulation was driven by another air series than the one logged; "
            "drive it with the measured ambient_C, e.g. ThermalMachine."
            "simulate_drivers(time_s, spindle_rpm, ambient_C, noise=False))"
        )
    return (
        " (a simulation exported with its sensors' noise on the air reading? "
        "Export the air without noise; with skthermal's simulator standing in "
        "for the other tool: skthermal simulate --no-noise, or noise=False)"
    )


def _as_given_text(given, before):
    """The verdict's remark when the simulation as given has a smaller
    held-out gap than the base calibrated on the other runs: by what the
    printed figures show (a 0.02% difference read "0.145, less than ...
    0.145")."""
    if not (np.isfinite(given) and float(f"{given:.3g}") < float(f"{before:.3g}")):
        return ""
    return (
        f" (the simulation as given: {given:.3g}, less than the base "
        "calibrated on the other runs)"
    )


# How far (K) a run's temperature sensors may read above its air at its
# first row, on average, before the run counts as starting warm: beyond
# what sensor offsets (a K or two) make of a machine soaked at the air.
_WARM_START_K = 3.0


def _warn_warm_starts(out, channels):
    """Warn when measured runs start warm (their temperature sensors well
    above the air at the first row) and the simulation of them does not:
    a simulation started from the air misses the warmth, and the cooling
    from it shows as a gap, taken for a lag or a gain (an independent
    check: the only warning blamed a unit slip, and a planted lag was
    lost). ``out``: the aligned runs ``(name, t, drivers, y_meas, y_sim,
    before)``."""
    temps = [j for j, c in enumerate(channels) if TEMPERATURE_PATTERN.fullmatch(str(c))]
    if not temps:
        return
    warm = []
    for name, _, drivers, y_meas, y_sim, _ in out:
        air = float(drivers["ambient_C"][0])
        above_m = float(np.mean(y_meas[0, temps])) - air
        above_s = float(np.mean(y_sim[0, temps])) - air
        if above_m > _WARM_START_K and above_s < 0.25 * above_m:
            warm.append((name, above_m, above_s))
    if not warm:
        return
    name, above_m, above_s = warm[0]
    more = f" (and {len(warm) - 1} more run(s) alike)" if len(warm) > 1 else ""
    warnings.warn(
        f"Measured run {name!r}{more} starts warm: its temperature sensors "
        f"read {above_m:.1f} K above the air at its first row on average, the "
        f"simulation {above_s:.1f} K. A simulation started from the air misses "
        "that warmth, and the cooling from it shows as part of the gap (often "
        "taken for a lag or a gain). Start the simulation from the measured "
        "state, or earlier (a simulation may start before the measured run).",
        UserWarning,
        stacklevel=user_stacklevel(),
    )
