"""Adaptive compensation with update regression, and a simulated batch campaign.

004 §4.3.1 validates update regression on a long record: a model built on the
first batch compensates the following 19 batches (76 h, changing machining
states); whenever the measured residual exceeds 7 µm the machine measures a
few new samples, the model is updated, and compensation goes on. The paper
reports 10 updates, 184 minutes of measuring (4 % of the time) and residuals
within 10 µm. :func:`adaptive_compensation` replays such a record sample by
sample; :func:`skthermal.datasets.make_batch_campaign` (also importable from
here) simulates one with the Machine-B-like preset of :mod:`skthermal.simulate`.
"""

import copy
import warnings
from dataclasses import dataclass
from numbers import Integral, Real

import numpy as np
import pandas as pd
from sklearn.utils._param_validation import (
    HasMethods,
    Interval,
    StrOptions,
    validate_params,
)
from sklearn.utils.validation import check_is_fitted

from skthermal.datasets import make_batch_campaign
from skthermal.linear_model._update import first_stable_update
from skthermal.utils._runs import (
    RUN_COLUMN,
    TIME_COLUMN,
    changes_since_start,
    check_numeric_columns,
    check_table_times,
    check_time_order,
    extract_runs,
    frame_run_labels,
    row_times,
    run_slices,
)
from skthermal.utils._warnings import user_stacklevel

__all__ = ["AdaptiveCompensationResult", "adaptive_compensation", "make_batch_campaign"]

_NONNEGATIVE = Interval(Real, 0, np.inf, closed="left")


@dataclass(frozen=True)
class AdaptiveCompensationResult:
    """What :func:`adaptive_compensation` reports.

    Attributes
    ----------
    residual : Series
        Measured minus predicted error at every sample, with the model in
        force at that sample (the old model while an update is measured).
    prediction : Series
        The compensation applied at every sample.
    measuring : Series of bool
        Samples measured for an update (machine not cutting).
    updates : DataFrame
        One row per update: ``row`` (position of the triggering sample),
        ``run``, ``time_s``, ``residual_um`` (the triggering residual),
        ``n_samples`` (new samples used), ``stable`` (whether the stability
        rule was met; always True with a fixed number of samples), then the
        coefficients after the update (``intercept`` and one per sensor).
    model : estimator
        The model at the end of the stream (a copy; the input is unchanged).
    sample_period_s : float or None
        Time between samples, from the ``time_s`` of the runs.
    measure_time_s : float or None
        Machine time spent on one update sample.
    """

    residual: pd.Series
    prediction: pd.Series
    measuring: pd.Series
    updates: pd.DataFrame
    model: object
    sample_period_s: float | None
    measure_time_s: float | None

    @property
    def n_updates(self):
        """Number of model updates."""
        return len(self.updates)

    @property
    def samples_used(self):
        """New samples measured for the updates, in all."""
        return int(self.measuring.sum())

    @property
    def downtime_s(self):
        """Machine time spent measuring for updates (s), or None."""
        if self.measure_time_s is None:
            return None
        return self.samples_used * self.measure_time_s

    @property
    def total_time_s(self):
        """Length of the stream (samples times the sample period), or None."""
        if self.sample_period_s is None:
            return None
        return len(self.residual) * self.sample_period_s

    @property
    def downtime_fraction(self):
        """Measuring time over the length of the stream (samples over samples
        when the runs carry no time)."""
        if self.downtime_s is None or self.total_time_s is None:
            return self.samples_used / len(self.residual)
        return self.downtime_s / self.total_time_s

    @property
    def max_residual_um(self):
        """Largest |residual| over the compensated (non-measuring) samples."""
        r = self.residual.to_numpy()[~self.measuring.to_numpy()]
        return float(np.max(np.abs(r))) if r.size else 0.0

    @property
    def max_residual_all_um(self):
        """Largest |residual| over all samples, measuring ones included."""
        return float(np.max(np.abs(self.residual.to_numpy())))

    @property
    def rmse_um(self):
        """Root mean squared residual over all samples."""
        return float(np.sqrt(np.mean(np.square(self.residual.to_numpy()))))

    def summary(self):
        """The headline numbers as a dict."""
        return {
            "n_samples": len(self.residual),
            "n_updates": self.n_updates,
            "samples_used": self.samples_used,
            "downtime_s": self.downtime_s,
            "downtime_fraction": self.downtime_fraction,
            "max_residual_um": self.max_residual_um,
            "max_residual_all_um": self.max_residual_all_um,
            "rmse_um": self.rmse_um,
        }


def _stream_inputs(model, runs, target, sensors, relative):
    if not isinstance(runs, pd.DataFrame):
        raise TypeError(
            "runs must be a run table (pandas DataFrame with sensor and target "
            f"columns), got {type(runs).__name__}."
        )
    if not isinstance(target, str):
        raise TypeError(f"target must be one column name, got {target!r}.")
    if sensors is None:
        names = getattr(model, "feature_names_in_", None)
        if names is None:
            raise ValueError(
                "The model was fitted without feature names; pass sensors=[...] "
                "naming the run-table columns it uses, in order."
            )
        sensors = list(names)
    sensors = list(sensors)
    missing = [c for c in [*sensors, target] if c not in runs.columns]
    if missing:
        raise ValueError(f"Column(s) {missing} not in the run table.")
    n_in = getattr(model, "n_features_in_", len(sensors))
    if n_in != len(sensors):
        raise ValueError(
            f"The model expects {n_in} inputs but {len(sensors)} sensors were given."
        )
    labels = [RUN_COLUMN] if RUN_COLUMN in runs.columns else []
    check_numeric_columns(runs[[*sensors, target]], frame_run_labels(runs))
    features, groups = extract_runs(runs[[*sensors, *labels]], finite=False)
    slices, _ = run_slices(groups, len(runs))
    X = features.to_numpy(dtype=float)
    y = runs[target].to_numpy(dtype=float)
    if len(runs) == 0:
        raise ValueError("The run table is empty.")
    for name, A in (("sensor", X), ("target", y[:, None])):
        bad = ~np.isfinite(A)
        if bad.any():
            row, col = np.argwhere(bad)[0]
            what = sensors[col] if name == "sensor" else target
            raise ValueError(
                f"Column {what!r} has NaN or infinite values (first at row {row})."
            )
    if relative:
        X = changes_since_start(X, slices)
        y = changes_since_start(y, slices)
    if TIME_COLUMN in runs.columns:
        check_table_times(runs, groups)
        t = runs[TIME_COLUMN].to_numpy(dtype=float)
    else:
        check_time_order(features, groups)
        t = row_times(features)
    period = None
    if t is not None:
        steps = np.concatenate([np.diff(t[sl]) for sl in slices])
        steps = steps[steps > 0]
        period = float(np.median(steps)) if steps.size else None
    return X, y, groups, t, sensors, period


# A target spanning less than 1/_UNIT_FACTOR of the threshold, or more than
# 10 * _UNIT_FACTOR times it, is in another unit than µm (mm, nm).
_UNIT_FACTOR = 100.0


def _warn_target_scale(y, target, threshold_um):
    """Warn when the target's span is out of all proportion to
    ``threshold_um`` (µm): in mm no update can ever trigger; in nm nearly
    every sample would."""
    span = float(np.ptp(y)) if np.size(y) else 0.0
    if span <= 0 or not np.isfinite(span) or threshold_um <= 0:
        return
    if span < threshold_um / _UNIT_FACTOR:
        unit, effect = "millimetres", "no update can trigger"
    elif span > threshold_um * _UNIT_FACTOR * 10:
        unit, effect = "nanometres", "nearly every sample triggers an update"
    else:
        return
    warnings.warn(
        f"The target {target!r} spans {span:.3g} over the runs against "
        f"threshold_um={threshold_um:g} µm: {effect}. Is it in {unit}? Columns "
        "*_um are read as µm.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


@validate_params(
    {
        "model": [HasMethods(["predict", "partial_fit"])],
        "runs": "no_validation",  # checked with a run-table message
        "target": "no_validation",
        "sensors": ["array-like", None],
        "threshold_um": [_NONNEGATIVE],
        "n_update": [Interval(Integral, 1, None, closed="left"), StrOptions({"auto"})],
        "max_update": [Interval(Integral, 3, None, closed="left")],
        "rtol": [_NONNEGATIVE],
        "atol": [_NONNEGATIVE],
        "relative": ["boolean"],
        "measure_time_s": [_NONNEGATIVE, None],
        "update": ["boolean"],
    },
    prefer_skip_nested_validation=True,
)
def adaptive_compensation(
    model,
    runs,
    *,
    target="disp_y_um",
    sensors=None,
    threshold_um=7.0,
    n_update=6,
    max_update=12,
    rtol=0.1,
    atol=0.0,
    relative=True,
    measure_time_s=None,
    update=True,
):
    """Compensate a stream of samples, updating the model when it drifts.

    The rows of ``runs`` are taken in order. Each sample is compensated with
    the current model; when the measured residual ``|E - E_hat|`` exceeds
    ``threshold_um``, the next samples are *measured* (the machine stops
    cutting to probe the error), the model is updated with them by
    ``partial_fit`` (update regression), and compensation resumes with the
    updated model after the last measured sample. Between updates the model
    is fixed, so whole stretches are predicted at once.

    Parameters
    ----------
    model : fitted estimator with ``predict`` and ``partial_fit``
        Typically a fitted :class:`UpdateRegressor`. It is copied, not
        changed.
    runs : DataFrame
        Run table (rows time-ordered within each run, runs one after
        another) with the sensor columns, the ``target`` column and, ideally,
        ``run`` and ``time_s`` columns (or index levels).
    target : str, default="disp_y_um"
        Column of the thermal error.
    sensors : list of str, optional
        Columns fed to the model, in order. Default: the model's
        ``feature_names_in_``.
    threshold_um : float, default=7.0
        Update when the absolute residual exceeds this (004: 7 µm for a
        10 µm goal).
    n_update : int or "auto", default=6
        New samples per update (004: about six). ``"auto"`` measures until
        the coefficients from N, N + 1 and N + 2 samples agree within
        ``rtol`` (:func:`update_is_stable`) and updates with the N + 2
        samples, at most ``max_update``; it needs the model's
        ``update_path``.
    max_update : int, default=12
        Most samples of one ``"auto"`` update.
    rtol, atol : float, default=0.1, 0.0
        Tolerances of the stability rule (``"auto"`` only).
    relative : bool, default=True
        Use changes since the start of each run for sensors and error, as
        004 and skthermal's models do; ``False`` uses the columns as given.
    measure_time_s : float, optional
        Machine time one update sample costs; default one sample period
        (from ``time_s``).
    update : bool, default=True
        ``False`` compensates with the initial model throughout: the
        baseline without updates.

    Returns
    -------
    result : AdaptiveCompensationResult
        Residual series, updates, and the summary numbers (``n_updates``,
        ``samples_used``, ``downtime_fraction``, ``max_residual_um``, ...).

    See Also
    --------
    UpdateRegressor, make_batch_campaign

    Notes
    -----
    004 §4.3.1. The residual of a sample is known in the replay because the
    record holds the measured error at every sample; on a machine it comes
    from the routine probing that 004 does every cycle, whose time is not
    counted as downtime here. Samples measured for an update are compensated
    with the old model; ``max_residual_um`` leaves them out (the machine is
    not cutting then), ``max_residual_all_um`` includes them.

    Examples
    --------
    >>> from skthermal.linear_model import (
    ...     UpdateRegressor, adaptive_compensation, make_batch_campaign)
    >>> from skthermal.datasets import changes_since_start
    >>> runs = make_batch_campaign(n_batches=4, random_state=0)
    >>> first = changes_since_start(runs[runs["run"] == "B1"])
    >>> model = UpdateRegressor().fit(first[["T09_C", "T35_C"]], first["disp_y_um"])
    >>> rest = runs[runs["run"] != "B1"]
    >>> result = adaptive_compensation(model, rest, threshold_um=7.0, n_update=6)
    >>> result.n_updates, result.samples_used, round(result.max_residual_um, 1)
    (3, 18, 7.5)
    >>> round(adaptive_compensation(model, rest, update=False).max_residual_um, 1)
    12.4
    """
    check_is_fitted(model)
    if n_update == "auto" and not hasattr(model, "update_path"):
        raise TypeError(
            "n_update='auto' needs a model with update_path (UpdateRegressor)."
        )

    X, y, groups, t, sensors, period = _stream_inputs(
        model, runs, target, sensors, relative
    )
    _warn_target_scale(y, target, threshold_um)
    named = getattr(model, "feature_names_in_", None) is not None
    first = X[:1] if not named else pd.DataFrame(X[:1], columns=sensors)
    outputs = np.shape(np.asarray(model.predict(first)))
    if len(outputs) == 2 and outputs[1] > 1:
        raise ValueError(
            f"The model predicts {outputs[1]} outputs; "
            "adaptive_compensation replays one axis (target="
            f"{target!r}) against its own threshold: fit one model per axis "
            "(e.g. UpdateRegressor().fit(X, Y[target])) and replay each."
        )

    def frame(rows):
        return pd.DataFrame(X[rows], columns=sensors) if named else X[rows]

    model = copy.deepcopy(model)
    n = X.shape[0]
    pred = np.empty(n)
    measuring = np.zeros(n, dtype=bool)
    records = []
    k = 0
    while k < n:
        p = np.asarray(model.predict(frame(slice(k, n))), dtype=float).reshape(-1)
        over = np.abs(y[k:] - p) > threshold_um
        if not update or not over.any():
            pred[k:] = p
            break
        j = k + int(np.argmax(over))
        stop = min(n, j + 1 + (max_update if n_update == "auto" else n_update))
        if stop == j + 1:  # triggered on the last sample: nothing left to measure
            pred[k:] = p
            break
        stable = True
        if n_update == "auto":
            path = model.update_path(frame(slice(j + 1, stop)), y[j + 1 : stop])
            n_stable = first_stable_update(path, rtol=rtol, atol=atol)
            if n_stable is None:
                stable = False
            else:
                stop = min(stop, j + 1 + n_stable + 2)
        new = slice(j + 1, stop)
        pred[k:stop] = p[: stop - k]
        measuring[new] = True
        model.partial_fit(frame(new), y[new])
        coef = np.r_[np.ravel(model.intercept_)[:1], np.ravel(model.coef_)]
        records.append(
            {
                "row": j,
                "run": None if groups is None else groups[j],
                "time_s": np.nan if t is None else t[j],
                "residual_um": float(y[j] - p[j - k]),
                "n_samples": stop - j - 1,
                "stable": stable,
                **dict(zip(["intercept", *sensors], coef.tolist(), strict=False)),
            }
        )
        k = stop
    columns = ["row", "run", "time_s", "residual_um", "n_samples", "stable"]
    updates = pd.DataFrame(records, columns=[*columns, "intercept", *sensors])
    index = runs.index
    return AdaptiveCompensationResult(
        residual=pd.Series(y - pred, index=index, name="residual_um"),
        prediction=pd.Series(pred, index=index, name="prediction_um"),
        measuring=pd.Series(measuring, index=index, name="measuring"),
        updates=updates,
        model=model,
        sample_period_s=period,
        measure_time_s=period if measure_time_s is None else float(measure_time_s),
    )
