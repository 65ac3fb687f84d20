"""Input-range and sensor-fault guard for a deployed compensation model.

A compensation model's output moves a machine axis, so a broken sensor must
not turn into an absurd correction. :class:`GuardedRegressor` wraps any
regressor, records during ``fit`` the range each input and the output took in
training, how far each sensor moved from one sample to the next and how long
it stayed unchanged, and checks every later prediction against them: readings
outside the (widened) training range, sensors that jump or flat-line, and
predictions outside a plausible band are reported with the sensor, the run and
the time, and in a safe mode clipped or held.
"""

import warnings
from numbers import Integral, Real

import numpy as np
import pandas as pd
from sklearn.base import (
    BaseEstimator,
    MetaEstimatorMixin,
    RegressorMixin,
    _fit_context,
    clone,
)
from sklearn.utils._param_validation import HasMethods, Interval, StrOptions
from sklearn.utils.metaestimators import available_if
from sklearn.utils.validation import check_is_fitted, validate_data

from skthermal._naming import plain
from skthermal.datasets._runtable import physical_lows
from skthermal.utils._runs import (
    LATE_START_WARNING,
    MAX_MAGNITUDE,
    RUN_COLUMN,
    TARGET_COLUMNS_WARNING,
    TIME_COLUMN,
    check_time_order,
    describe_unreadable,
    extract_runs,
    has_time_index,
    is_commanded,
    pass_runs,
    routed_runs,
    row_times,
    rows_by_run,
    run_first_rows,
    run_slices,
    sequence_models,
    target_names,
    unreadable,
)
from skthermal.utils._wrappers import wrapped_tags, wrapper_router


class GuardWarning(UserWarning):
    """Base class of the warnings of :class:`GuardedRegressor`.

    ``warnings.simplefilter("error", GuardWarning)`` turns all of them into
    errors.
    """


class SensorRangeWarning(GuardWarning):
    """An input is outside the range it took in training (widened by ``span``)."""


class SensorFaultWarning(GuardWarning):
    """A sensor jumps, flat-lines or (``mode="hold"``) reads NaN or infinity."""


class PredictionRangeWarning(GuardWarning):
    """A prediction is outside the plausible band of the training output."""


class RunStartWarning(GuardWarning):
    """A run given to a sequence model starts after its beginning and
    continues no run the model knows: the model takes it as a run that
    starts there."""


# Fault kinds, in the order they are reported.
_KINDS = ("missing", "range", "jump", "flat")
# The jump limit after faulty readings grows with the samples in between up
# to this many: after a long dropout a sensor that comes back far off (an
# offset of 8 °C after 20 missing samples in an independent check) is still
# a jump; a real drift over the dropout costs one held sample.
_MAX_SPAN = 4
_MIN_FLAT = 10  # samples: the shortest flat-line "auto" reports
# Good rows in a row from which remember_runs keeps a run's tail: the step
# checks (a jump, an odd first reading) read up to three rows.
_KEEP_GOOD = 3
# A run whose median step is below this share of training's period is
# logged faster (its flat-line window scaled); above, it only jitters.
_FASTER = 0.9
# The most rows remember_runs keeps of a run: the first reading after a
# longer silence of a sensor is judged as a run's first (no jump check).
_MAX_KEPT = 3600


def _steps(A, first, bad=None, periods=None):
    """Change of every column since its last earlier reading in the same run
    that is not ``bad`` (missing or out of range; None: since the previous
    row), and over how many rows (0 and 1 where the run has no such reading
    yet).

    A step measured from a faulty reading says nothing of the reading after
    it: the row after an out-of-range spike, or after a run's faulty first
    reading, is judged against the last good one (a controller passing the
    run so far knows it then).

    With ``periods`` (every row's time since the run's previous row, in
    sampling periods of training, per row or per row and input;
    :meth:`GuardedRegressor._input_periods`), the span is at most
    :data:`_MAX_SPAN` rows plus the time the rows leave out
    (:func:`_gap_span`): what a sensor may move grows with a logging gap."""
    n = A.shape[0]
    rows = np.arange(n)
    if periods is not None:
        periods = np.broadcast_to(periods.reshape(n, -1), A.shape)
    if bad is None or not bad.any():
        d = np.zeros_like(A)
        d[1:] = A[1:] - A[:-1]
        d[first] = 0.0
        span = np.ones(A.shape)
        if periods is not None:
            span = np.where(first[:, None], 1.0, _gap_span(1.0, periods))
        return d, span
    start = np.maximum.accumulate(np.where(first, rows, 0))
    last = _last_good(bad, start)
    prev = np.full_like(last, -1)
    prev[1:] = last[:-1]
    prev[first] = -1
    cols = np.arange(A.shape[1])
    known = prev >= 0
    d = np.where(known, A - A[np.maximum(prev, 0), cols], 0.0)
    count = np.where(known, rows[:, None] - prev, 1)
    span = np.minimum(count, _MAX_SPAN).astype(float)
    if periods is not None:
        # Time since the last good reading, in periods, beyond its rows.
        elapsed = np.cumsum(np.where(first[:, None], 0.0, periods), axis=0)
        since = elapsed - elapsed[np.maximum(prev, 0), cols]
        span = np.where(known, _gap_span(span, since - count + 1.0), span)
    return d, span


def _gap_span(rows, periods):
    """The span of a step over ``rows`` rows (at most :data:`_MAX_SPAN`)
    that took ``periods`` sampling periods of training: beyond the rows,
    the time a logging gap leaves out counts in full, as a sensor drifts
    over it (grown by its square root, a clean reading after a 1 h pause in
    a daily swing of the air was held as a jump; a spike in the first
    reading after a long pause is left to the range check)."""
    return rows + np.maximum(periods - 1.0, 0.0)


def _faster(periods, first):
    """Per row, how many times faster than in training its run is logged
    (the run's median time step in this call; 1 unless it is below
    :data:`_FASTER` periods)."""
    run = np.cumsum(first) - 1
    # Records logged twice (a step of 0) are no faster logging.
    mine = ~first & (periods > 0)
    median = pd.Series(periods[mine]).groupby(run[mine]).median()
    runs, median = median.index.to_numpy(), median.to_numpy()
    # A logger's jitter (its median step a few percent off) is no faster
    # logging either: the window would move by a sample with the rows a
    # call holds (a stream's block and the whole run disagreed).
    factor = np.where(median < _FASTER, 1.0 / np.maximum(median, 1e-9), 1.0)
    per_run = np.ones(int(run.max()) + 1 if run.size else 0)
    per_run[runs] = factor
    return per_run[run] if run.size else np.ones(periods.shape)


def _median_period(times, first):
    """The median time step within runs (s), NaN without times."""
    if times is None or times.size < 2:
        return np.nan
    dt = np.diff(times)[~first[1:]]
    dt = dt[np.isfinite(dt) & (dt > 0)]
    return float(np.median(dt)) if dt.size else np.nan


def _periods(times, first, period):
    """Every row's time since its run's previous row in sampling periods of
    training (``period`` s; 1 at a run's first row), or None without times
    or a period."""
    if times is None or not np.isfinite(period) or period <= 0:
        return None
    out = np.ones(times.shape)
    out[1:] = np.diff(times) / period
    out[first] = 1.0
    return out


def _odd_first_readings(jump, step, first):
    """Runs' first readings (n, p) that are the odd one out: the step to the
    run's second reading is a jump, the step from the second to the third is
    not. The first reading is the run's reference for changes since the
    start, so a glitch there would offset every later compensation while the
    rows after it looked good; only the step back would be flagged."""
    odd = np.zeros_like(jump)
    n = jump.shape[0]
    starts = np.flatnonzero(first)
    starts = starts[starts + 2 < n]
    starts = starts[~first[starts + 1] & ~first[starts + 2]]
    calm = np.isfinite(step[starts + 2]) & ~jump[starts + 2]
    odd[starts] = jump[starts + 1] & calm
    return odd


def _unchanged(A, first, before=None):
    """How many earlier readings of the same run equal each reading, in a
    row; ``before`` (n, p): per row, how many equal the run's first row
    given here before it (a continued run's count at its kept rows, see
    :meth:`GuardedRegressor.remember_runs`), added while the reading has
    not changed since."""
    same = np.zeros(A.shape, dtype=bool)
    same[1:] = A[1:] == A[:-1]
    same[first] = False
    count = np.cumsum(same, axis=0)
    out = count - np.maximum.accumulate(np.where(same, 0, count), axis=0)
    if before is not None:
        rows = np.arange(A.shape[0])
        start = np.maximum.accumulate(np.where(first, rows, 0))
        # Still the run's first reading: no change since its first row.
        changes = np.cumsum(~same & ~first[:, None], axis=0)
        out = out + np.where(changes == changes[start], before, 0)
    return out


def _last_good(bad, start):
    """Row of the last good entry at or before each row in its run, or -1.

    ``bad`` is (n,) or (n, p); ``start`` the first row of every row's run.
    """
    rows = np.arange(bad.shape[0]).reshape(-1, *([1] * (bad.ndim - 1)))
    last = np.maximum.accumulate(np.where(bad, -1, rows), axis=0)
    start = start.reshape(rows.shape)
    return np.where(last >= start, last, -1)


def _next_good(bad, start):
    """Row of the next good entry at or after each row in its run, or -1
    (``bad`` of shape (n, p), ``start`` as in :func:`_last_good`)."""
    n = bad.shape[0]
    firsts = np.flatnonzero(start == np.arange(n))
    ends = np.r_[firsts[1:], n] - 1
    end = ends[np.searchsorted(firsts, np.arange(n), side="right") - 1]
    rev = _last_good(bad[::-1], (n - 1 - end)[::-1])[::-1]
    return np.where(rev >= 0, n - 1 - rev, -1)


def _limits(low, high, margin):
    """``[low, high]`` widened by ``margin`` times its width (or its size if 0)."""
    width = high - low
    scale = np.where(width > 0, width, np.maximum(np.abs(high), 1.0))
    return low - margin * scale, high + margin * scale


def _continues(memory, label, t0):
    """Whether a run ``label`` that starts at ``t0`` is one the model knows:
    the run seen in fit again from its start, or its rows after the training
    ones (as :func:`skthermal.utils._runs.continued_runs` takes them)."""
    state = None if label is None else memory.get(label)
    if state is None:
        return False
    t_first, t_last = state["t_first"], state["t_last"]
    return not np.isfinite(t_first) or t0 == t_first or t0 > t_last


class GuardedRegressor(MetaEstimatorMixin, RegressorMixin, BaseEstimator):
    """Regressor that checks its inputs and outputs against the training data.

    The way to ship a compensation model: wrap the fitted pipeline (or any
    regressor) so that a broken or drifting sensor is reported, with the
    sensor, the run and the time, before its reading becomes an absurd
    correction. ``fit`` fits a clone of ``estimator`` and records, for every
    input (by feature name) and every output, its training range; for every
    input also the largest change from one sample to the next and the
    longest stretch of unchanged readings within a run. ``predict`` then
    flags

    - *out of range*: a reading beyond the training range by more than
      ``span`` times its width (:class:`SensorRangeWarning`);
    - *jump*: a change from the previous sample of the run larger than
      ``jump`` times the largest change seen in training
      (:class:`SensorFaultWarning`);
    - *flat-line*: a sensor that moved in training but gives the same reading
      for ``flat`` samples in a row (:class:`SensorFaultWarning`); not a
      commanded driver (``spindle_rpm``, ``feed_mm_min``), which holds a
      level by command;
    - *prediction out of band*: a prediction beyond the training output range
      by more than ``output_span`` times its width
      (:class:`PredictionRangeWarning`);
    - *late run start*, for a sequence model (one that reads a run from its
      start: grey models, lag filters, changes since the run start): the
      rows of a run that starts after ``time_s`` 0 and continues no run the
      model knows (:class:`RunStartWarning`). The model takes them as a run
      that starts there, so a window of recent rows would give the
      compensation of a run that just began. Those rows are not ok; their
      predictions are the model's (in the safe modes clipped to the band:
      the run has no good row to hold).

    With ``mode="warn"`` (the default) predictions are those of the wrapped
    model, unchanged. The safe modes bound them: ``"clip"`` clips the inputs
    to their allowed range and the predictions to the band; ``"hold"``
    replaces a faulty reading by the last good reading of that sensor in the
    run and, on every row with a fault, repeats the last good prediction of
    the run. :meth:`predict_checked` returns the predictions with, per row,
    whether it was ``ok``, the ``action`` taken and the ``reason``.

    Parameters
    ----------
    estimator : regressor
        The model to guard (cloned by ``fit``), for example a pipeline of a
        sensor selector and a skthermal regressor. Run-aware sequence models
        get the input as given (a DataFrame keeps its ``(run, time_s)``
        index) and ``groups`` when their ``fit``/``predict`` take it.
    span : float, default=0.25
        Allowed margin beyond the training range of every input, as a
        fraction of that range: with training range ``[lo, hi]`` the allowed
        range is ``[lo - span * (hi - lo), hi + span * (hi - lo)]`` (for an
        input constant in training, ``span`` times its absolute value, at
        least ``span``).
    jump : float or None, default=4.0
        A reading whose change since the previous sample of its run exceeds
        ``jump`` times the largest change of that input in training is a
        jump. After readings that are missing, or out of range by a jump
        (a spike), the change is taken from the last good one (the limit
        times the samples in between, at most 4). With times (``time_s``)
        the limit grows with the time a logging gap leaves out, in sampling
        periods of training; a run logged faster is judged per sample (a
        stricter limit). None: no jump check.
    flat : int, "auto" or None, default="auto"
        Samples of unchanged reading (at the sampling period of training: a
        run logged faster takes as much time, in more samples) after which
        a sensor that moved in training counts as flat-lined. ``"auto"``:
        per input, three times the longest stretch of unchanged readings in
        a training run, at least 10.
        None: no flat-line check.
    output_span : float, default=0.25
        Width of the plausible prediction band beyond the training output
        range, as a fraction of that range (as ``span``).
    inputs : list of str or int, optional
        The inputs to check, by name (``X`` a DataFrame) or position: those
        the model reads, when it selects sensors itself (a fault on a sensor
        it ignores must not hold the compensation). The other inputs are
        passed on unchecked, except that a NaN or infinite value is always
        a fault. None: every input.
    mode : {"warn", "clip", "hold"}, default="warn"
        What to do about the findings. ``"warn"``: warn, predictions
        unchanged; NaN or infinite inputs are an error. ``"clip"``: also clip
        the inputs to their allowed range and the predictions to the band;
        jumps and flat-lines inside the range are only reported; NaN is an
        error. ``"hold"``: also replace faulty readings (out of range, jump,
        flat-line, NaN or infinite) by the last good reading of the sensor
        in the run, and on a row with any fault predict the last good
        prediction of the run (the clipped prediction when the run has no
        good row yet); predictions are clipped to the band. A checked
        sensor that reads NaN or infinity in every row of a run given to
        the call is an error: there is no reading of it to hold.

    Attributes
    ----------
    estimator_ : regressor
        The fitted clone of ``estimator``.
    input_min_ : ndarray of shape (n_features_in_,)
        Smallest training value of every input.
    input_max_ : ndarray of shape (n_features_in_,)
        Largest training value of every input.
    input_max_step_ : ndarray of shape (n_features_in_,)
        Largest change of every input from one sample to the next within a
        training run, per ``sample_period_`` (a step over a logging gap, or
        in a run logged more slowly, divided by the periods it spans).
    sample_period_ : float
        The median time step of the training runs (s), from their
        ``time_s``; NaN without times (steps are then per row).
    input_max_unchanged_ : ndarray of shape (n_features_in_,)
        Longest stretch of identical consecutive readings within a training
        run, in samples (1 when every reading differed from the last).
    stream_runs_ : dict
        After :meth:`remember_runs`: per run label, what continuing the run
        needs: around a static model its last rows and what ``mode="hold"``
        holds (not saved in ``.skops`` files), around a sequence model the
        run so far (``skthermal.io.save`` refuses the guard then).
    output_min_ : ndarray of shape (n_outputs,)
        Smallest training target, per output.
    output_max_ : ndarray of shape (n_outputs,)
        Largest training target, per output.
    checked_inputs_ : ndarray of shape (n_features_in_,) of bool
        Which inputs are checked (all unless ``inputs`` is given).
    n_features_in_ : int
        Number of inputs seen in ``fit``.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Names of the inputs seen in ``fit``, when ``X`` had string column
        names; the warnings name the sensors by them.

    See Also
    --------
    skthermal.io.save : Save the guarded model to a file that loads without
        running code.

    Notes
    -----
    All checks compare one batch of rows with the training statistics; no
    state is kept between calls unless :meth:`remember_runs` keeps it
    (:class:`~skthermal.compose.RunStream` calls it after every block). A
    jump and a flat-line show only between consecutive rows of one call, so
    on the machine's controller stream the blocks through a ``RunStream``,
    or give ``predict`` the rows of the current run so far and use the last
    row. A
    window of recent rows will do for a static model only: a sequence model
    needs the run from its start, or the rows after those of a run it saw in
    ``fit`` or ``partial_fit`` (same run label), which it continues; other
    rows that start after ``time_s`` 0 are flagged (late run start). After a
    one-sample spike both the spike and the next sample (the step back) are
    flagged as jumps. A run's first reading is flagged instead of the step
    to the second when that step is a jump and the next one is not: the
    first reading is the reference of changes since the run start, and
    ``"hold"`` replaces it by the run's second reading. Run boundaries come
    from ``groups``, a ``run`` column or a ``run`` index level; steps and
    stretches never cross them. Times
    in the messages come from a ``time_s`` index level (as produced by
    :func:`skthermal.datasets.split_runs`), else rows are numbered from 0.

    Examples
    --------
    >>> import warnings
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from skthermal.compose import GuardedRegressor, SensorRangeWarning
    >>> X = np.linspace(20.0, 30.0, 50).reshape(-1, 1)
    >>> y = 2.0 * (X[:, 0] - 20.0)
    >>> guard = GuardedRegressor(LinearRegression(), mode="hold").fit(X, y)
    >>> X_new = np.array([[25.0], [25.2], [1e6], [25.4]])
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     checked = guard.predict_checked(X_new)
    >>> checked["prediction"].round(3).tolist()
    [10.0, 10.4, 10.4, 10.8]
    >>> checked["ok"].tolist(), checked["action"].tolist()
    ([True, True, False, True], ['', '', 'held', ''])
    >>> checked.loc[2, "reason"]
    'out of range: x0; jump: x0'

    The reading after the spike is judged from the one before it (25.2):
    not a jump, and predicted again.
    >>> any(issubclass(w.category, SensorRangeWarning) for w in caught)
    True
    """

    _parameter_constraints: dict = {
        "estimator": [HasMethods(["fit", "predict"])],
        "span": [Interval(Real, 0, None, closed="left")],
        "jump": [Interval(Real, 0, None, closed="neither"), None],
        "flat": [
            Interval(Integral, 2, None, closed="left"),
            StrOptions({"auto"}),
            None,
        ],
        "output_span": [Interval(Real, 0, None, closed="left")],
        "inputs": ["array-like", None],
        "mode": [StrOptions({"warn", "clip", "hold"})],
    }

    def __init__(
        self,
        estimator,
        *,
        span=0.25,
        jump=4.0,
        flat="auto",
        output_span=0.25,
        inputs=None,
        mode="warn",
    ):
        self.estimator = estimator
        self.span = span
        self.jump = jump
        self.flat = flat
        self.output_span = output_span
        self.inputs = inputs
        self.mode = mode

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        inner = wrapped_tags(tags, self.estimator)
        if tags.regressor_tags is not None and inner.regressor_tags is not None:
            tags.regressor_tags.poor_score = inner.regressor_tags.poor_score
        return tags

    # --- fit ----------------------------------------------------------------

    def get_metadata_routing(self):
        """The metadata routing of the guard and its wrapped model.

        With ``sklearn.set_config(enable_metadata_routing=True)``, what the
        wrapped model requests (``set_fit_request(sample_weight=True)``) is
        passed on to its ``fit`` and ``partial_fit`` by a Pipeline, a search
        or ``cross_validate``.

        Returns
        -------
        routing : MetadataRouter
        """
        methods = ["fit"]
        if hasattr(self.estimator, "partial_fit"):
            methods.append("partial_fit")
        return wrapper_router(self, methods)

    @_fit_context(prefer_skip_nested_validation=False)
    def fit(self, X, y, *, groups=None, **fit_params):
        """Fit the wrapped regressor and record the training ranges.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
            Training inputs. A ``run`` column or index level holds run labels
            and is not an input; the wrapped model gets ``X`` as given.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Training targets.
        groups : array-like of shape (n_samples,), optional
            Run labels; passed on to the wrapped model's ``fit`` when it
            takes ``groups``.
        **fit_params : dict
            Further arguments of the wrapped model's ``fit``.

        Returns
        -------
        self : GuardedRegressor
        """
        # A refit forgets the runs streamed through the model before.
        self.__dict__.pop("stream_runs_", None)
        # Training data must be complete: named errors (column, run, time).
        features, runs = extract_runs(X, groups, y=y)
        check_time_order(features, runs, strict=False)
        A, Y = validate_data(
            self, features, y, multi_output=True, y_numeric=True, dtype=np.float64
        )
        self.checked_inputs_ = self._resolve_inputs()
        self.estimator_ = clone(self.estimator)
        X_inner, fit_params = routed_runs(
            self, "fit", self.estimator_.fit, X, groups, fit_params
        )
        with warnings.catch_warnings():
            # Said above, for X as given.
            warnings.filterwarnings("ignore", message=TARGET_COLUMNS_WARNING)
            self.estimator_.fit(X_inner, y, **fit_params)
        self._fit_ranges(
            A,
            np.asarray(Y, dtype=float).reshape(A.shape[0], -1),
            runs,
            row_times(features),
        )
        self._output_names = target_names(y)
        self._y_1d = np.asarray(y).ndim == 1
        return self

    def _resolve_inputs(self):
        p = self.n_features_in_
        mask = np.zeros(p, dtype=bool)
        if self.inputs is None:
            mask[:] = True
            return mask
        items = list(np.asarray(self.inputs, dtype=object).ravel())
        names = list(getattr(self, "feature_names_in_", []))
        for item in items:
            if isinstance(item, str):
                if item not in names:
                    where = f"X has {names}" if names else "X has no column names"
                    raise ValueError(
                        f"inputs names {item!r}, which is not an input; {where}."
                    )
                mask[names.index(item)] = True
            elif isinstance(item, Integral) and not isinstance(item, bool):
                if not -p <= item < p:
                    raise ValueError(
                        f"inputs holds position {item}, out of range for X with "
                        f"{p} column(s)."
                    )
                mask[item] = True
            else:
                raise ValueError(
                    f"inputs must hold column names or positions, got {item!r}."
                )
        if not mask.any():
            raise ValueError("inputs is empty: name at least one input to check.")
        return mask

    def _fit_ranges(self, A, Y, runs, times=None, update=False):
        """The training ranges; with ``update``, widened to hold new samples
        too (a range only grows: the model has now seen those conditions).

        With ``times``, the steps are per sampling period of training (the
        median time step; set in ``fit``): a step over a logging gap, or in a
        run logged more slowly, is divided by the periods it spans, so it
        does not widen the jump limit."""
        start = run_first_rows(runs, A.shape[0])
        first = start == np.arange(A.shape[0])
        if not update:
            self.sample_period_ = _median_period(times, first)
        step, span = _steps(A, first, periods=self._input_periods(times, first))
        found = {
            "input_min_": A.min(axis=0),
            "input_max_": A.max(axis=0),
            "input_max_step_": (np.abs(step) / span).max(axis=0),
            "input_max_unchanged_": _unchanged(A, first).max(axis=0) + 1,
            "output_min_": Y.min(axis=0),
            "output_max_": Y.max(axis=0),
        }
        for name, value in found.items():
            if update:
                combine = np.minimum if name.endswith("min_") else np.maximum
                value = combine(getattr(self, name), value)
            setattr(self, name, value)

    def _estimator_has_partial_fit(self):
        return hasattr(self.estimator, "partial_fit")

    @available_if(_estimator_has_partial_fit)
    @_fit_context(prefer_skip_nested_validation=False)
    def partial_fit(self, X, y, *, groups=None):
        """Update the wrapped model with new samples (its ``partial_fit``) and
        widen the checked ranges to hold them.

        Only when the wrapped estimator has ``partial_fit`` (e.g.
        :class:`~skthermal.linear_model.UpdateRegressor`, whose update
        regression re-tunes a model to a changed machine from a few
        samples). The new samples must be complete (no missing reading).

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_new, n_features)
            New inputs, with the columns of ``fit``.
        y : array-like of shape (n_new,) or (n_new, n_outputs)
            Their measured targets.
        groups : array-like of shape (n_new,), optional
            Run labels; passed on when the wrapped ``partial_fit`` takes them.

        Returns
        -------
        self : GuardedRegressor
        """
        first = not hasattr(self, "estimator_")
        features, runs = extract_runs(X, groups, y=y)
        check_time_order(features, runs, strict=False)
        times = row_times(features)
        A, Y = validate_data(
            self,
            features,
            y,
            multi_output=True,
            y_numeric=True,
            dtype=np.float64,
            reset=first,
        )
        if first:  # partial_fit from scratch, as the wrapped model allows
            self.checked_inputs_ = self._resolve_inputs()
            self.estimator_ = clone(self.estimator)
            self._output_names = target_names(y)
        else:
            self._refuse_faulty_update(A, features, runs, times)
        X_inner, kwargs = routed_runs(
            self, "partial_fit", self.estimator_.partial_fit, X, groups, {}
        )
        self.estimator_.partial_fit(X_inner, y, **kwargs)
        Y = np.asarray(Y, dtype=float).reshape(A.shape[0], -1)
        if not first and Y.shape[1] != self.output_min_.size:
            raise ValueError(
                f"y has {Y.shape[1]} output(s); the guard was fitted on "
                f"{self.output_min_.size}."
            )
        self._fit_ranges(A, Y, runs, times, update=not first)
        return self

    def _refuse_faulty_update(self, A, features, runs, times=None):
        """Raise when new samples hold a spike: a step over ``jump`` times
        both the largest step in training and the new samples' own typical
        (median) step. An update must not learn from a faulty sensor, nor
        widen the guard's ranges to it; readings beyond the training range
        and larger steps throughout are what an update is for (a changed
        machine, another batch)."""
        if self.jump is None:
            return
        n = A.shape[0]
        first = run_first_rows(runs, n) == np.arange(n)
        with np.errstate(invalid="ignore"):
            # Per sampling period of training: update samples taken every
            # 10 minutes, or across a pause, are no spike.
            step, span = _steps(A, first, periods=self._input_periods(times, first))
            step = np.abs(step) / span
            typical = (
                np.nanmedian(step, axis=0)
                if np.isfinite(step).any()
                else np.zeros(A.shape[1])
            )
        typical = np.where(np.isfinite(typical), typical, 0.0)
        limit = self.jump * np.maximum(self.input_max_step_, typical)
        spikes = np.isfinite(step) & (step > limit) & (limit > 0)
        spikes &= self.checked_inputs_
        if not spikes.any():
            return
        where = _Where(features, runs, self._sensor_names())
        msg = where.describe(
            spikes,
            A,
            lambda j: (
                f"a step over jump={self.jump:g} times the largest in "
                f"training ({self.input_max_step_[j]:.4g}) and the new samples' "
                f"median ({typical[j]:.4g})"
            ),
        )
        raise ValueError(
            f"partial_fit: the new samples hold a sensor spike ({msg}). An "
            "update must not learn from a faulty sensor, nor widen the checked "
            "ranges to it: drop or correct those rows."
        )

    # --- predict ------------------------------------------------------------

    def predict(self, X, *, groups=None):
        """Predict with the wrapped model, checked (and in a safe mode, bounded).

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
            Inputs, with the same columns as in ``fit``.
        groups : array-like of shape (n_samples,), optional
            Run labels; passed on to the wrapped model's ``predict`` when it
            takes ``groups``.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            With ``mode="warn"`` exactly the wrapped model's prediction.

        Warns
        -----
        SensorRangeWarning, SensorFaultWarning, PredictionRangeWarning
            Naming the sensors, the run and the time of the first finding.
        RunStartWarning
            Naming the first run given to a sequence model from after its
            start.
        """
        X, groups, take, carry = self._continued(X, groups)
        pred = self._guard(X, groups, fresh=_fresh(take, X), carry=carry)
        return pred["prediction"] if take is None else pred["prediction"][take]

    def predict_checked(self, X, *, groups=None):
        """Predictions with, per row, whether the guard found a problem.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
            Inputs, with the same columns as in ``fit``.
        groups : array-like of shape (n_samples,), optional
            Run labels (as in :meth:`predict`).

        Returns
        -------
        checked : DataFrame
            Indexed like ``X`` (a plain array: by row number), with columns

            - ``prediction`` (``prediction_<name>`` per output for several
              outputs): the value to apply, as returned by :meth:`predict`;
            - ``ok``: True when no input of the row is out of range, jumps,
              flat-lines or is missing, the prediction is in its band, and
              (for a sequence model) the row's run starts at its beginning
              or continues a run the model knows;
            - ``action``: ``""`` (prediction of the model), ``"clipped"``
              (inputs or prediction clipped) or ``"held"`` (last good
              prediction of the run repeated);
            - ``reason``: what was found, e.g. ``"out of range: T03_C;
              jump: T03_C"`` or ``"run starts at time_s=4920, not at its
              start: a sequence model needs the whole run or a continued
              run"``, empty when ``ok``.

        Warns
        -----
        SensorRangeWarning, SensorFaultWarning, PredictionRangeWarning
            As :meth:`predict`.
        """
        index = X.index if isinstance(X, pd.DataFrame) else None
        X, groups, take, carry = self._continued(X, groups)
        result = self._guard(
            X, groups, unavailable=True, fresh=_fresh(take, X), carry=carry
        )
        if take is not None:
            result = {key: value[take] for key, value in result.items()}
        pred = np.asarray(result["prediction"], dtype=float)
        if pred.ndim == 1:
            columns = {"prediction": pred}
        else:
            names = getattr(self, "_output_names", None) or [
                str(k) for k in range(pred.shape[1])
            ]
            columns = {f"prediction_{n}": pred[:, k] for k, n in enumerate(names)}
        columns.update(
            ok=~result["bad"], action=result["action"], reason=result["reason"]
        )
        return pd.DataFrame(columns, index=index)

    def _remembers(self):
        """Whether runs can be continued from kept rows: the guard is
        fitted (a static model needs a tail of each run, a sequence model
        the whole run, see :meth:`remember_runs`)."""
        return hasattr(self, "estimator_")

    @available_if(_remembers)
    def remember_runs(self, X, *, groups=None):
        """Keep what continuing the runs of ``X`` (given to :meth:`predict`
        just before) needs: the last rows of each labelled run that the
        checks of later rows read. A later :meth:`predict` of rows of such a
        run continues it: a jump is judged from its last reading, a
        flat-line counts its unchanged readings, ``mode="hold"`` holds its
        last good value, as if the run so far were given again.

        Around a static model what is kept is bounded: the last three rows,
        back to each sensor's last reading a step is taken from, at most
        3,600 rows; what ``mode="hold"`` holds (the last good prediction,
        each sensor's last good reading), the flat-line counts and which
        sensors have read anything are carried apart.
        :class:`~skthermal.compose.RunStream` calls it after every block, so
        each block costs the same however long the run. The checked
        predictions equal those of the run so far given again, except where
        the run's logging period changes (the flat-line window is scaled by
        the median period of the rows a call holds) and for a sensor's first
        reading after a silence of over 3,600 rows (not checked for a jump).
        Around a sequence model (which reads every run from its start) the
        whole run is kept and given again with the new rows, so a block
        costs in proportion to the run so far; the checked predictions equal
        those of the run so far given again. Either way, the warnings of a
        later :meth:`predict` speak of its own rows: a finding among the kept
        rows was said when it began.

        Parameters
        ----------
        X : DataFrame of shape (n_samples, n_features)
            The rows just predicted, with run labels (a ``run`` column or
            index level, or ``groups``) and ``time_s``.
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        self : GuardedRegressor
        """
        stacked, stacked_groups, take, carry = self._continued(X, groups)
        if not isinstance(stacked, pd.DataFrame):
            return self
        features, runs = extract_runs(stacked, stacked_groups, finite=False)
        if runs is None:
            return self
        if sequence_models(self.estimator_):
            self.stream_runs_ = self._whole_runs(stacked, features, runs)
            return self
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # said by predict
            checked = self._guard(
                stacked,
                stacked_groups,
                unavailable=True,
                fresh=_fresh(take, stacked),
                carry=carry,
            )
        A = validate_data(
            self, features, reset=False, dtype=np.float64, ensure_all_finite=False
        )
        P = np.asarray(checked["prediction"], dtype=float).reshape(A.shape[0], -1)
        times = row_times(features)
        states = dict(getattr(self, "stream_runs_", {}))
        slices, labels = run_slices(runs, A.shape[0])
        for sl, label in zip(slices, labels, strict=True):
            if label is None:
                continue
            keep = self._tail_start(checked["reference"][sl], checked["jump"][sl])
            state = states.get(label) or {
                "inputs": np.full(A.shape[1], np.nan),
                "prediction": np.full(P.shape[1], np.nan),
                "read": np.zeros(A.shape[1], dtype=bool),
            }
            # What hold mode holds after the kept rows: the last good
            # prediction and each input's last good reading so far.
            good = np.flatnonzero(~checked["bad"][sl])
            prediction = P[sl][good[-1]] if good.size else state["prediction"]
            ok = ~checked["fault"][sl]
            last = np.where(ok, np.arange(ok.shape[0])[:, None], -1).max(axis=0)
            inputs = np.where(
                last >= 0,
                A[sl][np.maximum(last, 0), np.arange(A.shape[1])],
                state["inputs"],
            )
            first = np.zeros(sl.stop - sl.start, dtype=bool)
            first[0] = True
            before = None if carry is None else carry["unchanged"][sl]
            unchanged = _unchanged(A[sl], first, before)[keep]
            states[label] = {
                "rows": stacked.iloc[sl.start + keep : sl.stop],
                "t_last": -np.inf if times is None else float(times[sl][-1]),
                "inputs": inputs,
                "prediction": np.array(prediction, dtype=float),
                "unchanged": unchanged,
                "read": state["read"] | np.isfinite(A[sl]).any(axis=0),
            }
        self.stream_runs_ = states
        return self

    def _whole_runs(self, stacked, features, runs):
        """:attr:`stream_runs_` for a sequence model: each labelled run of
        ``stacked`` (the runs so far with the new rows) kept whole, with
        nothing held from before its first row, so that replaying it gives
        what the whole run gives (holding the run's latest good readings
        over its faulty first rows instead moved a transfer function's
        start by up to 8 µm for the rest of the run, in an independent
        check). No check is run again: the rows are only kept."""
        p, n_out = self.n_features_in_, self.output_min_.size
        times = row_times(features)
        states = dict(getattr(self, "stream_runs_", {}))
        slices, labels = run_slices(runs, len(stacked))
        for sl, label in zip(slices, labels, strict=True):
            if label is None:
                continue
            states[label] = {
                "rows": stacked.iloc[sl],
                "t_last": -np.inf if times is None else float(times[sl][-1]),
                "inputs": np.full(p, np.nan),
                "prediction": np.full(n_out, np.nan),
                "unchanged": np.zeros(p, dtype=int),
                "read": np.zeros(p, dtype=bool),
            }
        return states

    @available_if(_remembers)
    def forget_runs(self, labels):
        """Forget the kept rows of the runs ``labels`` (see
        :meth:`remember_runs`); a later block of such a label starts a new
        run. Returns self."""
        tails = dict(getattr(self, "stream_runs_", {}))
        for label in labels:
            tails.pop(label, None)
        self.stream_runs_ = tails
        return self

    def _tail_start(self, reference, jump):
        """The first of a run's rows that continuing it needs
        (:meth:`remember_runs`), from the guard's findings on them (per row
        and input: the readings later steps are taken from, ``reference``,
        and the jumps): the last :data:`_KEEP_GOOD` rows (the step checks
        read that far back), the row before each input's last reading a
        step is taken from (a kept run's first row is judged as a run's
        first: out of range, it would be a spike), but at most
        :data:`_MAX_KEPT` rows, and no jump just after the first kept row
        (an odd first reading). What hold mode holds, the flat-line counts
        and which sensors have read anything are kept apart
        (:meth:`remember_runs`)."""
        n = reference.shape[0]
        start = n - _KEEP_GOOD

        def last(mask):
            """Per column, the last row of ``mask`` (n, p), where there is one."""
            rows = np.where(mask, np.arange(n)[:, None], -1).max(axis=0)
            return rows[rows >= 0]

        if self.jump is not None:
            start = min([start, *(last(reference) - 1)])
        # A sensor silent for long (dead for good in hold mode) would keep
        # its last reading's rows without end: kept at most _MAX_KEPT rows.
        start = max(start, n - _MAX_KEPT)
        while start > 0 and jump[start + 1].any():
            start -= 1
        return max(start, 0)

    def _continued(self, X, groups):
        """``X`` (and ``groups``) with the kept rows of the remembered runs
        it continues put before their rows (each run's rows together),
        where ``X``'s own rows are in it, and per row what was before the
        kept rows: what hold mode holds (``"inputs"``, ``"prediction"``, NaN
        where nothing), how many readings equal to the first kept one
        (``"unchanged"``, for the flat-line check) and which sensors have
        read anything (``"read"``); the last two None when no run
        continues. Rows without ``time_s`` continue nothing."""
        states = getattr(self, "stream_runs_", None)
        if not states or not isinstance(X, pd.DataFrame):
            return X, groups, None, None
        features, runs = extract_runs(X, groups, finite=False)
        times = row_times(features)
        if runs is None or times is None:
            return X, groups, None, None
        # Here, where the rows are the caller's: stacked behind the kept
        # ones, a row out of order was named by its place among those.
        check_time_order(features, runs, strict=False)
        order, rows_of = rows_by_run(runs)
        # A kept run goes on with rows after its kept ones (at the same
        # time: a record logged twice); others are predicted as given.
        going = [
            label in states and times[mine[0]] >= states[label]["t_last"]
            for label, mine in zip(order, rows_of, strict=True)
        ]
        if not any(going):
            return X, groups, None, None
        n_out, p = self.output_min_.size, self.n_features_in_
        parts, labels, carried = [], [], []
        take = np.empty(len(runs), dtype=int)  # X's rows in the stacked rows
        # X's rows run by run, taken once (a take per run was quadratic).
        grouped = X.iloc[np.concatenate(rows_of)]
        offset = done = 0
        for label, mine, on in zip(order, rows_of, going, strict=True):
            state = states[label] if on else None
            size = mine.size
            if state is not None:
                parts.append(state["rows"])
                offset += len(state["rows"])
                size += len(state["rows"])
            parts.append(grouped.iloc[done : done + mine.size])
            done += mine.size
            labels.append(np.full(size, label, dtype=object))
            take[mine] = offset + np.arange(mine.size)
            offset += mine.size
            carried.append((size, state))
        stacked = pd.concat(parts)
        stacked_groups = None if groups is None else np.concatenate(labels)

        def column(key, empty):
            """``key`` of each run's state on all its stacked rows."""
            return np.vstack(
                [
                    np.broadcast_to(empty if st is None else st[key], (n, empty.size))
                    for n, st in carried
                ]
            )

        carry = {
            "inputs": column("inputs", np.full(p, np.nan)),
            "prediction": column("prediction", np.full(n_out, np.nan)),
            "unchanged": column("unchanged", np.zeros(p, dtype=int)),
            "read": column("read", np.zeros(p, dtype=bool)),
        }
        return stacked, stacked_groups, take, carry

    def _guard(self, X, groups, unavailable=False, fresh=None, carry=None):
        """The checked predictions of ``X``. With ``unavailable`` (hold mode,
        :meth:`predict_checked`), the runs in which a checked sensor reads
        nothing get no prediction (NaN, action ``"unavailable"``) instead of
        an error for the whole call; the other runs are predicted alone."""
        check_is_fitted(self)
        features, runs = extract_runs(X, groups, finite=False)
        check_time_order(features, runs, strict=False)
        A = validate_data(
            self, features, reset=False, dtype=np.float64, ensure_all_finite=False
        )
        n = A.shape[0]
        start = run_first_rows(runs, n)
        first = start == np.arange(n)
        times = row_times(features)
        where = _Where(features, runs, self._sensor_names(), fresh)
        if self.mode == "hold":
            dead = self._unreadable(A, start, None if carry is None else carry["read"])
            if dead is not None and unavailable:
                return self._without_dead_runs(
                    X, groups, dead, start, where, fresh, carry
                )
            if dead is not None:
                self._refuse_unreadable(dead, start, where)
        flags, reference = self._input_flags(
            A, first, where, times, None if carry is None else carry["unchanged"]
        )
        fault = np.logical_or.reduce(list(flags.values()))
        late = self._late_starts(runs, where, n)

        inputs_changed = np.zeros(n, dtype=bool)
        X_inner = X
        lo, hi = self._input_limits()
        if self.mode == "clip":
            B = np.where(self.checked_inputs_, np.clip(A, lo, hi), A)
            inputs_changed = (B != A).any(axis=1)
            X_inner = _with_values(X, B)
        elif self.mode == "hold" and fault.any():
            last = _last_good(fault, start)
            # Before the first good reading of a run (a dropout at its start)
            # the next good one stands in: the run's first row is its
            # reference for changes since the start, so a made-up value there
            # would offset the whole run.
            nxt = _next_good(fault, start)
            cols = np.arange(A.shape[1])
            ahead = A[np.maximum(nxt, 0), cols]
            fallback = np.where(
                nxt >= 0,
                ahead,
                np.where(np.isnan(A), (lo + hi) / 2, np.clip(A, lo, hi)),
            )
            if carry is not None:
                # A continued run's last good reading before the kept rows.
                known = np.isfinite(carry["inputs"])
                fallback = np.where(known, carry["inputs"], fallback)
            held = A[np.maximum(last, 0), cols]
            B = np.where(fault, np.where(last >= 0, held, fallback), A)
            inputs_changed = fault.any(axis=1)
            X_inner = _with_values(X, B)

        X_inner, kwargs = pass_runs(self.estimator_.predict, X_inner, groups, {})
        with warnings.catch_warnings():
            if (late != "").any():
                # Said once, as a RunStartWarning naming the rows; the wrapped
                # sequence model would say it again in its own words.
                warnings.filterwarnings("ignore", message=LATE_START_WARNING)
            raw = np.asarray(self.estimator_.predict(X_inner, **kwargs), dtype=float)
        P = raw.reshape(n, -1)
        olo, ohi = _limits(self.output_min_, self.output_max_, self.output_span)
        out_band = ~((P >= olo) & (P <= ohi))
        self._warn_output(P, out_band, olo, ohi, where)

        bad = fault.any(axis=1) | out_band.any(axis=1) | (late != "")
        action = np.full(n, "", dtype=object)
        if self.mode == "warn":
            final = P
        else:
            final = np.clip(P, olo, ohi)
            clipped = inputs_changed | (final != P).any(axis=1)
            action[clipped] = "clipped"
            if self.mode == "hold":
                last = _last_good(bad, start)
                hold = bad & (last >= 0)
                final = np.where(hold[:, None], final[np.maximum(last, 0)], final)
                if carry is not None:
                    # A continued run's last good prediction before the kept
                    # rows.
                    known = np.isfinite(carry["prediction"]).all(axis=1)
                    before = bad & (last < 0) & known
                    final = np.where(before[:, None], carry["prediction"], final)
                    hold |= before
                action[hold] = "held"
            lost = ~np.isfinite(final).all(axis=1)
            if lost.any():
                row = int(np.flatnonzero(lost)[0])
                raise ValueError(
                    f"The wrapped model predicted {P[row].tolist()} {where.at(row)}"
                    f" ({int(lost.sum())} row(s) without a finite prediction"
                    + (
                        " and no earlier good one in the run to hold"
                        if self.mode == "hold"
                        else ""
                    )
                    + "); no safe compensation can be given there."
                )
        reason = _reasons(flags, out_band, self._sensor_names(), n, late)
        return {
            "prediction": final.reshape(raw.shape),
            "bad": bad,
            "action": action,
            "reason": reason,
            # Per row and input, for remember_runs: a finding, and whether
            # later steps are taken from the reading.
            "fault": fault,
            "reference": reference,
            "jump": flags.get("jump", np.zeros_like(fault)),
        }

    def _unreadable(self, A, start, read_before=None):
        """Rows x inputs: a checked sensor that reads no finite value in all
        the rows of the row's run that this call holds (``start``: every
        row's run's first row), or None when there is none. There is no
        reading of it to hold, and any value put in its place would be made
        up. (An unchecked input, one the model ignores, gets a value inside
        its range.) ``read_before`` (n, p): per row, whether the sensor read
        a finite value before the rows of a continued run that the call
        holds (:meth:`remember_runs`)."""
        finite = np.isfinite(A)
        if finite.all():  # the usual call: nothing to look for
            return None
        read = np.zeros_like(finite)
        np.logical_or.at(read, start, finite)
        read = read[start]
        if read_before is not None:
            read |= read_before
        dead = ~read & self.checked_inputs_
        return dead if dead.any() else None

    def _dead_text(self, dead, start, where):
        """``sensor 'T3_C' reads no finite value in run ... (n row(s); k more
        sensor(s) alike)``, for the first sensor of ``dead`` (rows x inputs)
        in its first run (``start``: every row's run's first row)."""
        j = int(np.flatnonzero(dead.any(axis=0))[0])
        row = int(np.flatnonzero(dead[:, j])[0])
        others = int(dead.any(axis=0).sum()) - 1
        in_run = int(np.sum(dead[:, j] & (start == start[row])))
        return (
            f"sensor {self._sensor_names()[j]!r} reads no finite value "
            f"{where.at(row)}, nor in any other row of that run given to this "
            f"call ({in_run} row(s)"
            + (f"; {others} more sensor(s) alike" if others else "")
            + ")"
        )

    def _refuse_unreadable(self, dead, start, where):
        """Raise for the dead sensors of :meth:`_unreadable`, before any
        warning: none says that a value was held."""
        raise ValueError(
            f"mode='hold': {self._dead_text(dead, start, where)}: there is no reading "
            "of it to hold, and a compensation computed without it would rest "
            "on a made-up value. Repair the sensor, or use a model fitted "
            "without it; on the controller, give predict the run's rows from "
            "its start, so that a sensor that read earlier is held; in a batch "
            "of runs, leave that run out (predict_checked marks its rows "
            "'unavailable' and predicts the others)."
        )

    def _without_dead_runs(self, X, groups, dead, start, where, fresh=None, carry=None):
        """:meth:`_guard` of the runs without a dead sensor; the rows of the
        others get no prediction (NaN, not ok, action ``"unavailable"``),
        with a :class:`SensorFaultWarning` naming the first (not again for
        a run continued from kept rows, said when it began); ``fresh`` and
        ``carry`` as in :meth:`_guard`."""
        lost = dead.any(axis=1)
        names = self._sensor_names()
        n_runs, n_lost = np.unique(start).size, np.unique(start[lost]).size
        rest = (
            "no run of the call can be predicted"
            if n_lost == n_runs
            else f"the other {n_runs - n_lost} run(s) are predicted"
        )
        new = lost.copy()
        if fresh is not None:
            # A run whose first rows here are kept ones goes on.
            new &= fresh[start]
        if new.any():
            warnings.warn(
                f"mode='hold': {self._dead_text(dead & new[:, None], start, where)}"
                f": no compensation can be given for the {int(lost.sum())} row(s) "
                f"of the {n_lost} run(s) with such a sensor (prediction NaN, "
                f"action 'unavailable'); {rest}.",
                SensorFaultWarning,
                stacklevel=4,
            )
        reason = np.array(
            [
                "no reading: " + ", ".join(names[j] for j in np.flatnonzero(row))
                for row in dead
            ],
            dtype=object,
        )
        out = {
            "bad": lost.copy(),
            "action": np.where(lost, "unavailable", "").astype(object),
            "reason": np.where(lost, reason, "").astype(object),
            "fault": np.ones(dead.shape, dtype=bool),
            "reference": np.zeros(dead.shape, dtype=bool),
            "jump": np.zeros(dead.shape, dtype=bool),
        }
        n_out = self.output_min_.size
        out["prediction"] = np.full((lost.size, n_out), np.nan)
        keep = np.flatnonzero(~lost)
        if keep.size:
            rows = X.iloc[keep] if hasattr(X, "iloc") else np.asarray(X)[keep]
            labels = None if groups is None else np.asarray(groups)[keep]
            part = self._guard(
                rows,
                labels,
                fresh=None if fresh is None else fresh[keep],
                carry=None
                if carry is None
                else {key: value[keep] for key, value in carry.items()},
            )
            out["prediction"][keep] = np.reshape(part["prediction"], (keep.size, -1))
            for key in ("bad", "action", "reason", "fault", "reference", "jump"):
                out[key][keep] = part[key]
        # As the wrapped model predicts: a target given as one column (a
        # one-column frame) keeps its column ("prediction_<name>" in
        # predict_checked; it became "prediction" when a sensor died).
        if n_out == 1 and getattr(self, "_y_1d", True):
            out["prediction"] = out["prediction"][:, 0]
        return out

    def _input_limits(self):
        """The inputs' allowed ranges: the training ranges widened by
        ``span``, not below what an input can physically read (0 rpm, say)."""
        lo, hi = _limits(self.input_min_, self.input_max_, self.span)
        floor = physical_lows(self._sensor_names())
        # Only for inputs whose training values respect it: a speed given as
        # its change since the run start may be negative.
        floor = np.where(self.input_min_ >= floor, floor, -np.inf)
        return np.maximum(lo, floor), hi

    def _sensor_names(self):
        names = getattr(self, "feature_names_in_", None)
        if names is None:
            return [f"x{j}" for j in range(self.n_features_in_)]
        return [str(c) for c in names]

    def _input_periods(self, times, first):
        """Per row and input, the sampling periods of training since the
        run's row before (1 at a run's first row, and for a commanded
        driver, which steps in one row whatever the period), or None
        without times: the spans of :func:`_steps`, by which a step is a
        rate, the same whether a run is logged slowly or has a gap."""
        periods = _periods(times, first, self._period())
        if periods is None:
            return None
        return np.where(self._commanded(), 1.0, periods[:, None])

    def _commanded(self):
        """Per input, whether it is a commanded driver (a spindle speed in
        rpm, a feed in mm/min), which steps in one sample whatever the
        logging period: its steps are per row, not per sampling period."""
        names = getattr(self, "feature_names_in_", None)
        if names is None:
            return np.zeros(self.n_features_in_, dtype=bool)
        return np.array([is_commanded(n) for n in names])

    def _period(self):
        """The sampling period of training (s), NaN when unknown."""
        return getattr(self, "sample_period_", np.nan)

    def _flat_window(self):
        """Per input, the unchanged samples (of training's period) from
        which a sensor that moved in training has flat-lined."""
        if self.flat == "auto":
            return np.maximum(3 * self.input_max_unchanged_, _MIN_FLAT)
        return np.full(self.n_features_in_, self.flat)

    def _input_flags(self, A, first, where, times=None, unchanged=None):
        """Boolean (n, p) matrices per fault kind, warned about as found,
        and the readings later steps are taken from (:meth:`_jumps`)."""
        finite = np.isfinite(A)
        # A reading beyond MAX_MAGNITUDE is as wrong as NaN or inf: the wrapped
        # model's arithmetic would overflow on it. mode="hold" holds it as a
        # reading out of range.
        bad = unreadable(A)
        if bad.any() and self.mode != "hold":
            row, col = np.argwhere(bad)[0]
            value = A[row, col]
            what = (
                f"{value} (NaN or inf)"
                if not np.isfinite(value)
                else describe_unreadable(value)
            )
            raise ValueError(
                f"Input {where.sensors[col]!r} reads {what} {where.at(row)}; "
                f"inputs must be finite and within {MAX_MAGNITUDE:g} in magnitude. "
                "A sensor can drop out on the machine: mode='hold' holds the "
                "last good compensation instead of failing."
            )
        lo, hi = self._input_limits()
        with np.errstate(invalid="ignore", over="ignore"):
            flags = {"missing": ~finite, "range": finite & ((A < lo) | (A > hi))}
            reference = finite
            if self.jump is not None:
                flags["jump"], step, reference = self._jumps(
                    A,
                    first,
                    flags["missing"],
                    flags["range"] & self.checked_inputs_,
                    self._input_periods(times, first),
                )
                # An odd first reading is the fault, not the step from it.
                odd = _odd_first_readings(flags["jump"], step, first)
                flags["jump"][1:] &= ~odd[:-1]
                flags["jump"] |= odd
            if self.flat is not None:
                window = self._flat_window()
                # A commanded driver holds a level by command (a spindle at
                # one speed, or at rest, for hours): no flat-line (an
                # independent check: 1,971 of 5,041 rows of an 84 h run
                # flagged, the compensation held, 21 -> 52 µm).
                moved = (self.input_max_ > self.input_min_) & ~self._commanded()
                # The window is in samples of training: a run logged faster
                # takes as long to flat-line, in more samples.
                periods = _periods(times, first, self._period())
                faster = (
                    np.ones(A.shape[0]) if periods is None else _faster(periods, first)
                )
                flags["flat"] = moved & (
                    _unchanged(A, first, unchanged) + 1 >= window * faster[:, None]
                )
        for kind in ("range", "jump", "flat"):
            if kind in flags:
                flags[kind] &= self.checked_inputs_
        action = {
            "warn": "",
            "clip": " Those readings were clipped to the allowed range.",
            "hold": " The compensation was held at its last good value there (clipped "
            "where the run had no good row yet).",
        }[self.mode]
        said = {kind: where.new_findings(F) for kind, F in flags.items()}
        if said["range"].any():
            msg = where.describe(
                said["range"],
                A,
                lambda j: f"allowed {lo[j]:.4g} to {hi[j]:.4g}",
            )
            warnings.warn(
                f"Input outside its training range widened by span={self.span:g}: "
                f"{msg}. The model extrapolates there.{action}"
                + _HINT.get(self.mode, ""),
                SensorRangeWarning,
                stacklevel=4,
            )
        held = (
            " The compensation was held at its last good value there (clipped "
            "where the run had no good row yet)."
        )
        if said["missing"].any():
            msg = where.describe(said["missing"], A, lambda j: "NaN or inf")
            warnings.warn(
                f"Sensor reading missing: {msg}.{held}",
                SensorFaultWarning,
                stacklevel=4,
            )
        if "jump" in said and said["jump"].any():
            msg = where.describe(
                said["jump"],
                A,
                lambda j: f"largest training step {self.input_max_step_[j]:.4g}",
            )
            warnings.warn(
                f"Sensor jump (a step over jump={self.jump:g} times the largest "
                f"step in training): {msg}."
                + (held if self.mode == "hold" else _HINT.get(self.mode, "")),
                SensorFaultWarning,
                stacklevel=4,
            )
        if "flat" in said and said["flat"].any():
            msg = where.describe(
                said["flat"],
                A,
                lambda j: f"unchanged for {int(window[j])} samples or more",
            )
            warnings.warn(
                f"Sensor flat-lined (no change although it moved in training): "
                f"{msg}." + (held if self.mode == "hold" else _HINT.get(self.mode, "")),
                SensorFaultWarning,
                stacklevel=4,
            )
        return flags, reference

    def _jumps(self, A, first, missing, out, periods=None):
        """Jump flags (n, p), the steps they were judged on, and which
        readings later steps are taken from (neither missing nor a spike).

        A step is taken from the sensor's last reading in the run that is
        neither missing nor a spike: out of range (``out``) and reached by a
        jump, or at the run's first row. The reading after such a spike is
        then judged against the reading before it, so it is not a jump too;
        readings that drift out of the range stay references, so a slow
        drift is not cut into jumps."""
        base = np.where(
            self.input_max_step_ > 0, self.jump * self.input_max_step_, np.inf
        )

        def judge(bad):
            step, span = _steps(A, first, bad, periods)
            step = np.abs(step)
            return np.isfinite(step) & (step > base * span), step

        jump, step = judge(missing)
        spike = out & (jump | first[:, None])
        if spike.any():
            jump, step = judge(missing | spike)
        return jump, step, ~(missing | spike)

    def _late_starts(self, runs, where, n):
        """Per row, why its run cannot be predicted by the wrapped sequence
        model (``""`` when it can): the run starts after time_s 0 and
        continues no run the model knows, so the model would take it as a
        run that starts there. Warns (:class:`RunStartWarning`)."""
        reason = np.full(n, "", dtype=object)
        if where.times is None or n == 0:
            return reason
        models = sequence_models(self.estimator_)
        if not models:
            return reason  # a static model: any rows will do
        slices, labels = run_slices(runs, n)
        late = []
        for sl, label in zip(slices, labels, strict=True):
            t0 = float(where.times[sl.start])
            if t0 == 0 or all(_continues(memory, label, t0) for _, memory in models):
                continue
            reason[sl] = (
                f"run starts at time_s={t0:g}, not at its start: a sequence "
                "model needs the whole run or a continued run"
            )
            late.append(sl)
        if late:
            sl = late[0]
            more = f" ({len(late) - 1} more run(s) like it)" if len(late) > 1 else ""
            warnings.warn(
                f"The rows {where.at(sl.start)} to time_s="
                f"{where.times[sl.stop - 1]:g} do not start at the beginning of "
                f"their run, which continues no run seen in fit{more}. "
                f"{models[0][0]} reads a run from its start, so it takes them "
                "as a run that starts there: its predictions are not those of "
                "the run, and the rows are marked not ok. Give the rows of the "
                "run from its start (the run so far), or continue a run seen "
                "in fit or partial_fit (its run label, rows after its training "
                "rows); a window of recent rows suits only static models.",
                RunStartWarning,
                stacklevel=4,
            )
        return reason

    def _warn_output(self, P, out_band, olo, ohi, where):
        out_band = where.new_findings(out_band)
        if not out_band.any():
            return
        names = getattr(self, "_output_names", None) or [
            f"output {k}" for k in range(P.shape[1])
        ]
        msg = _Where(where.X, where.runs, names).describe(
            out_band, P, lambda k: f"band {olo[k]:.4g} to {ohi[k]:.4g}"
        )
        then = {
            "warn": " The predictions were returned unchanged." + _HINT["warn"],
            "clip": " The predictions were clipped to the band.",
            "hold": " The last good prediction of the run was held.",
        }[self.mode]
        warnings.warn(
            "Prediction outside the training output range widened by "
            f"output_span={self.output_span:g}: {msg}.{then}",
            PredictionRangeWarning,
            stacklevel=4,
        )


_HINT = {
    "warn": " predict_checked lists the rows. A faulty sensor (stuck, jumping "
    "or cut): mode='clip' or 'hold' bounds the compensation there. The machine "
    "or room truly beyond its training range (a colder room, a faster "
    "spindle): clipping or holding errs too; refit on runs that cover it.",
    "clip": "",
}


def _fresh(take, X):
    """The rows of the stacked ``X`` given now (``take``: where they are in
    it; None: every row)."""
    if take is None:
        return None
    fresh = np.zeros(len(X), dtype=bool)
    fresh[take] = True
    return fresh


def _with_values(X, B):
    """``X`` with its input values replaced by ``B`` (index, run column kept)."""
    if not isinstance(X, pd.DataFrame):
        return B
    # The run table's run and time columns are not inputs: kept as they are,
    # in their places.
    kept = sorted(
        (c for c in (RUN_COLUMN, TIME_COLUMN) if c in X.columns),
        key=X.columns.get_loc,
    )
    features = [c for c in X.columns if c not in kept]
    out = pd.DataFrame(B, index=X.index, columns=features)
    for c in kept:
        out.insert(X.columns.get_loc(c), c, X[c])
    return out


def _reasons(flags, out_band, sensors, n, late=None):
    """Per row, e.g. ``"out of range: T03_C, T04_C; jump: T03_C"``; first
    ``late`` (per row, why the run cannot be predicted, or ``""``)."""
    labels = {
        "missing": "missing",
        "range": "out of range",
        "jump": "jump",
        "flat": "flat-line",
    }
    reason = np.full(n, "", dtype=object)
    # Text is built for the rows with a finding only.
    found = out_band.any(axis=1)
    if late is not None:
        found |= late != ""
    for F in flags.values():
        found |= F.any(axis=1)
    rows = np.flatnonzero(found)
    if not rows.size:
        return reason
    parts = [] if late is None else [late[rows]]
    for kind in _KINDS:
        F = flags.get(kind)
        if F is None:
            continue
        F = F[rows]
        if not F.any():
            continue
        names = np.full(rows.size, "", dtype=object)
        for j in np.flatnonzero(F.any(axis=0)):
            sep = np.where(names == "", "", ", ")
            names = np.where(F[:, j], names + sep + sensors[j], names)
        parts.append(np.where(names == "", "", labels[kind] + ": " + names))
    band = out_band[rows].any(axis=1)
    if band.any():
        parts.append(np.where(band, "prediction out of band", ""))
    text = np.full(rows.size, "", dtype=object)
    for part in parts:
        sep = np.where((text == "") | (part == ""), "", "; ")
        text = text + sep + part
    reason[rows] = text
    return reason


class _Where:
    """Names rows by run and time (or row number) for the messages."""

    def __init__(self, X, runs, sensors, fresh=None):
        self.X = X
        self.runs = runs
        self.sensors = sensors
        self.times = (
            np.asarray(X.index.get_level_values(TIME_COLUMN))
            if has_time_index(X)
            else None
        )
        # The rows given now, behind kept rows of their runs (remember_runs);
        # None: every row.
        self.fresh = fresh

    def new_findings(self, F):
        """``F`` (n,) or (n, p) on the rows given now only, without the
        findings that go on from the kept rows before them: said when they
        began, not again at every block."""
        if self.fresh is None:
            return F
        F = np.asarray(F, dtype=bool).reshape(len(self.fresh), -1)
        out = F & self.fresh[:, None]
        # A finding flagged on the last kept row goes on until its first
        # row without it.
        n = len(self.fresh)
        starts = np.flatnonzero(self.fresh[1:] & ~self.fresh[:-1]) + 1
        ends = np.r_[np.flatnonzero(~self.fresh[1:] & self.fresh[:-1]) + 1, n]
        for r, end in zip(
            starts, ends[np.searchsorted(ends, starts, "right")], strict=True
        ):
            block = F[r:end]
            first_off = np.where(block, end - r, np.arange(end - r)[:, None]).min(
                axis=0
            )
            going = F[r - 1] & (np.arange(end - r)[:, None] < first_off)
            out[r:end] &= ~going
        return out

    def at(self, row):
        run = "" if self.runs is None else f"in run {plain(self.runs[row])!r} "
        if self.times is not None:
            return f"{run}at time_s={self.times[row]:g}"
        return f"{run}at row {row}"

    def describe(self, F, values, detail, limit=5):
        """The first occurrence of every flagged column, at most ``limit``,
        with the rows it holds for and, when they are apart, in how many
        stretches of consecutive rows."""
        cols = np.flatnonzero(F.any(axis=0))
        rows = F.argmax(axis=0)
        counts = F.sum(axis=0)
        stretches = F[0] + (F[1:] & ~F[:-1]).sum(axis=0)
        items = [
            f"{self.sensors[j]!r} {self.at(rows[j])} (value "
            f"{values[rows[j], j]:.4g}, {detail(j)}; {counts[j]} row"
            f"{'' if counts[j] == 1 else 's'}"
            f"{f' in {stretches[j]} stretches' if stretches[j] > 1 else ''})"
            for j in cols[:limit]
        ]
        more = f" and {cols.size - limit} more" if cols.size > limit else ""
        head = f"{cols.size} of {F.shape[1]}: " if F.shape[1] > 1 else ""
        return head + "; ".join(items) + more
