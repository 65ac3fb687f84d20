"""Prediction on a stream: a controller's blocks of rows, one run at a time.

A compensation model on a machine tool receives each new block of readings
once (a row every sampling period, or a few rows at a time), while the
sequence models of skthermal read a run from its start: their filters and
changes since the start carry the run's past. :class:`RunStream` keeps that
past between calls, so that predicting block by block gives what predicting
the whole run at once gives.
"""

import re
import warnings
from copy import deepcopy

import numpy as np
import pandas as pd
from sklearn.utils.validation import check_is_fitted

from skthermal._naming import TEMPERATURE_PATTERN
from skthermal.compose._guard import GuardWarning, RunStartWarning
from skthermal.utils._runs import (
    LATE_START_WARNING,
    extract_runs,
    row_times,
    rows_by_run,
    sequence_models,
)
from skthermal.utils._warnings import without_figures


class RunStream:
    """Predict runs block by block, continuing each run from the last block.

    Give every block of rows once, as it comes, with each row's run label
    and ``time_s`` (a run table: ``run`` and ``time_s`` columns or index
    levels, as :func:`skthermal.datasets.read_runs` and
    :func:`skthermal.datasets.split_runs` give them). The rows of a run that
    an earlier block had continue it: the predictions equal those of the
    whole run given at once (up to rounding). A label the stream has not
    seen starts a new run (a run seen in the model's ``fit`` continues that
    one, as in the model's own ``predict``); a block that starts a known
    label again at its first ``time_s`` (or at 0) starts that run anew. A
    block that starts at or before the last ``time_s`` the stream has of its
    run otherwise (given twice, out of order) is an error naming the run
    and both times, before the model sees it. Rows of several runs may be
    interleaved in a block; each run's rows must be in time order.

    Three ways, chosen from the model:

    - a model with a ``remember_runs`` method
      (:class:`~skthermal.preprocessing.LagRidgeCV`, what
      :func:`~skthermal.preprocessing.make_lag_pipeline` returns,
      :class:`~skthermal.preprocessing.LagFeatures`,
      :class:`~skthermal.linear_model.TransferFunctionRegressor`, and a
      :class:`~skthermal.compose.GuardedRegressor`, which keeps the last
      rows its checks read around a static model, each run so far around
      a sequence model) keeps each run's end state: every block costs the
      same, however long the run (around a guarded sequence model, in
      proportion to the run so far);
    - a static model (no sequence model inside, not a guard) is given the
      new rows alone;
    - any other model (a Pipeline with a sequence step or a guard, a grey
      regressor) is given each run's rows so far with the new ones, and its
      predictions of the new rows are returned: exact for every model, at a
      cost that grows with the run; :meth:`forget` frees a finished run.

    A warning the model raised for an earlier block (or, after a run's
    first block, about the run's start) is not raised again; a guard's
    finding that goes on from one block to the next is said when it
    begins, and the same finding (its kind, sensors and run) again once
    :data:`REPEAT_S` seconds of ``time_s`` after it was last said (the
    stream's time: how far its runs went on, whatever labels they reuse):
    one more fault of a sensor within those ten minutes is flagged in its
    rows (``ok``) but not said again.

    Differences from the whole run remain, by design: a guard in
    ``mode="hold"`` replaces a reading that is faulty from a run's first
    row by the sensor's next good reading when the call holds one; block by
    block the next reading is not there yet, so the stream's first blocks
    clip it instead (or raise, for a sensor that has read nothing yet). A
    run's first reading is the odd one out (a glitch) only when its second
    and third readings show it; given in blocks of one or two rows, the
    glitch passes and the second reading is flagged as a jump instead.

    Parameters
    ----------
    model : fitted estimator
        The compensation model.
    copy : bool, default=True
        Whether to work on a deep copy of ``model``. With ``False`` a model
        that keeps run end states remembers the streamed runs itself: its
        own ``predict`` then continues them, and a file it is saved to
        holds them.

    Attributes
    ----------
    model_ : estimator
        The model the stream predicts with (with its remembered runs).
    runs_ : list
        Labels of the runs the stream holds, in order of appearance.
    mode_ : {"incremental", "static", "history"}
        Which of the three ways above the stream takes.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from skthermal.compose import RunStream
    >>> from skthermal.preprocessing import LagRidgeCV
    >>> t = np.arange(0.0, 6 * 3600, 60.0)
    >>> rpm = np.where(t < 3 * 3600, 3000.0, 0.0)
    >>> temp = 20 + 5 * (1 - np.exp(-t / 1800)) * (rpm > 0)
    >>> table = pd.DataFrame(
    ...     {"run": "a", "time_s": t, "T1_C": temp, "spindle_rpm": rpm}
    ... )
    >>> y = 2.0 * (temp - 20)
    >>> model = LagRidgeCV(time_constant_sets=[(600.0,)]).fit(table, y)
    >>> new = table.assign(run="b")
    >>> stream = RunStream(model)
    >>> blocks = [stream.predict(new.iloc[i : i + 10]) for i in range(0, len(new), 10)]
    >>> bool(np.allclose(np.concatenate(blocks), model.predict(new)))
    True
    """

    def __init__(self, model, *, copy=True):
        check_is_fitted(model)
        self.model_ = deepcopy(model) if copy else model
        if callable(getattr(self.model_, "remember_runs", None)):
            self.mode_ = "incremental"
        elif sequence_models(self.model_) or _holds_guard(self.model_):
            self.mode_ = "history"
        else:
            self.mode_ = "static"
        self._spans = {}  # label -> [first time_s, last time_s]
        self._history = {}
        self._said = {}  # warning key -> the block's last time_s when said
        self._texts = {}  # warning key -> its text in the last block
        self._ends = {}  # label -> (its first readings, its last readings)
        self._clock = 0.0  # s of time_s streamed, over all runs (_advance)

    def __setstate__(self, state):
        # A stream pickled by an earlier version kept no readings, and said
        # its findings at the blocks' time_s.
        state.setdefault("_ends", {})
        state.setdefault("_clock", max(state.get("_said", {}).values(), default=0.0))
        self.__dict__.update(state)

    def _advance(self, runs, times):
        """The stream's clock after the block (``runs``: its runs' rows,
        ``times``: their time_s): it goes on by the most any run of the
        block went on since its last block (a new run: since its first
        row). Findings are said again :data:`REPEAT_S` after on it, not on
        the blocks' time_s, which a run label given again from 0, or runs
        started at other times, took back (a fault of the new run was never
        said)."""
        step = 0.0
        for lab, a, b in runs:
            span = self._spans.get(lab)
            start = times[a] if span is None or times[a] <= span[1] else span[1]
            step = max(step, float(times[b - 1] - start))
        self._clock += step
        return self._clock

    @property
    def runs_(self):
        """Labels of the runs the stream holds, in order of appearance."""
        return list(self._spans)

    def predict(self, X, *, groups=None):
        """Predict a block of rows, continuing the runs of earlier blocks.

        Parameters
        ----------
        X : DataFrame of shape (n_samples, n_features)
            The new rows, with ``time_s`` and run labels (a ``run`` column or
            index level, or ``groups``); each run's rows in time order.
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
        """
        return self._call("predict", X, groups)

    def predict_checked(self, X, *, groups=None):
        """The guard's checked predictions of a block (a
        :class:`~skthermal.compose.GuardedRegressor`'s
        :meth:`~skthermal.compose.GuardedRegressor.predict_checked`: the
        prediction and ``ok``, ``action``, ``reason`` per row), continuing
        the runs of earlier blocks. Indexed like ``X``."""
        if not hasattr(self.model_, "predict_checked"):
            raise AttributeError(
                f"{type(self.model_).__name__} has no predict_checked: wrap the "
                "model in skthermal.compose.GuardedRegressor for checked "
                "predictions."
            )
        return self._call("predict_checked", X, groups)

    def forget(self, run=None):
        """Forget a finished run (its label), or every run: what the stream
        (and its model) holds of it is freed, and a later block of that
        label starts a new run. Returns self."""
        labels = list(self.runs_) if run is None else [run]
        for lab in labels:
            if lab not in self._spans:
                raise KeyError(
                    f"The stream holds no run {lab!r}; it holds {self.runs_}."
                )
            self._drop(lab)
        return self

    def _keeps_states(self):
        """Whether the model continues each run from an end state it keeps
        (a sequence model's: a record logged twice is a block given twice),
        not from rows kept by a guard around a static model."""
        return self.mode_ == "incremental" and not hasattr(
            self.model_, "predict_checked"
        )

    def _refuses_equal_time(self):
        """Whether a block starting at the last time the stream has of its
        run is refused: by every stream except those of a static model or
        a guard around one (a record logged twice): a sequence model reads
        the run's times in increasing order."""
        return (
            self._keeps_states()
            or self.mode_ == "history"
            or bool(sequence_models(self.model_))
        )

    def _drop(self, lab):
        del self._spans[lab]
        self._ends.pop(lab, None)
        self._history.pop(lab, None)
        if self.mode_ == "incremental" and hasattr(self.model_, "forget_runs"):
            self.model_.forget_runs([lab])

    def _call(self, method, X, groups):
        labels, times = _labels_and_times(X, groups)
        if not labels.size:
            raise ValueError(
                "The block given to RunStream holds no rows: give each block "
                "when it has rows."
            )
        # Each run's rows together, in the order the runs first appear; the
        # block's runs as (label, first row, end row) of the reordered rows.
        uniques, rows = rows_by_run(labels)
        order = np.concatenate(rows)
        ends = np.cumsum([r.size for r in rows])
        runs = [
            (lab, int(e - r.size), int(e)) for lab, r, e in zip(uniques, rows, ends)
        ]
        reordered = bool(np.any(order != np.arange(order.size)))
        if reordered:
            X = X.iloc[order]
            labels, times = labels[order], times[order]
            groups = None if groups is None else np.asarray(groups)[order]
        # The temperatures of each run's first and last row of the block
        # (a clock reset is told by them), by row.
        ends = sorted({a for _, a, _ in runs} | {b - 1 for _, _, b in runs})
        readings = dict(zip(ends, _readings(X.iloc[ends]), strict=True))
        new = self._check_order(runs, times, readings)
        now = self._advance(runs, times)  # for when a finding is said again
        kwargs = {} if groups is None else {"groups": groups}
        if self.mode_ == "history":
            out = self._with_history(method, X, groups, runs, new, now)
        elif self.mode_ == "incremental":
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                out = getattr(self.model_, method)(X, **kwargs)
            self._say_new(caught, not new, now)
            self.model_.remember_runs(X, **kwargs)
        else:
            out = getattr(self.model_, method)(X, **kwargs)
        for lab, a, b in runs:
            self._spans.setdefault(lab, [times[a], None])[1] = times[b - 1]
            first = self._ends.get(lab, (readings[a],))[0]
            self._ends[lab] = (first, readings[b - 1])
        if reordered:
            back = np.empty_like(order)
            back[order] = np.arange(order.size)
            out = out.iloc[back] if hasattr(out, "iloc") else np.asarray(out)[back]
        return out

    def _check_order(self, runs, times, readings):
        """The labels of the block's runs new to the stream. A known run
        given again from its start restarts (said, and whether its readings,
        ``readings`` of its first row, go on from the earlier run's last
        ones: a clock reset mid-run); one
        that does not start after the stream's last time of it is an
        error."""
        new = set()
        held = {}  # the held runs by their labels' text
        for k in self._spans:
            held.setdefault(_as_text(k), k)
        for lab, a, _ in runs:
            t0 = times[a]
            span = self._spans.get(lab)
            if span is None:
                like = [held[_as_text(lab)]] if _as_text(lab) in held else []
                if like:
                    warnings.warn(
                        f"Run {lab!r} ({type(lab).__name__}) is new to the "
                        f"stream, which holds run {like[0]!r} "
                        f"({type(like[0]).__name__}): labels of another type are "
                        "another run, which starts at this block's first row. "
                        "Give the labels of every block one type.",
                        UserWarning,
                        stacklevel=4,
                    )
                new.add(lab)
            elif t0 < span[1] or (t0 == span[1] and self._refuses_equal_time()):
                # A record logged twice (at the last one's time) is no block
                # given twice for a static model or a guard around one; a
                # sequence model given the run so far refused it itself,
                # naming a row of the run so far the caller never gave.
                if t0 in (0.0, span[0]):  # the run again from its start
                    self._say_restart(lab, t0, span, readings[a])
                    self._drop(lab)
                    new.add(lab)
                    continue
                raise ValueError(
                    f"Run {lab!r}: the block starts at time_s={t0:g}, not after "
                    f"the last row the stream has of that run (time_s="
                    f"{span[1]:g}; the run from {span[0]:g}): a block given "
                    "twice or out of order? Give each block once, in time "
                    "order; a new run under the same label starts again at its "
                    "first time_s (or forget(run) the old one)."
                )
        return new

    def _say_restart(self, lab, t0, span, first):
        """Warn that run ``lab`` starts again at ``t0`` (its first readings
        ``first``); with a sequence model inside, when those readings go on
        from the earlier run's last ones rather than from its first (a
        controller whose clock was reset mid-run, the machine warm), as a
        :class:`~skthermal.compose.RunStartWarning`, saying what the model
        makes of it."""
        text = (
            f"Run {lab!r} starts again at time_s={t0:g}: taken as a new run "
            "under the same label; the stream's rows of the earlier one (to "
            f"time_s={span[1]:g}) are dropped."
        )
        sequence = bool(sequence_models(self.model_))
        category = UserWarning
        if sequence or _holds_guard(self.model_):
            category = RunStartWarning
            ends = self._ends.get(lab)
            # Only a sequence model takes a warm machine for a cold one.
            if ends is not None and sequence and _goes_on(*ends, first):
                text += (
                    " Its first readings go on from the earlier run's last "
                    "ones, not from where that run began: if the controller's "
                    "clock was reset mid-run, the model now takes the warm "
                    "machine for one at the start of a run, and its "
                    "compensation is off from here. Give time_s going on from "
                    f"{span[1]:g} to continue the run, or a new run label for "
                    "a new run."
                )
        warnings.warn(text, category, stacklevel=5)

    def _say_new(self, caught, started, now, history=False):
        """Say the warnings of ``caught`` not said for an earlier block
        (:func:`_said_key`), a guard's finding again when it was last said
        :data:`REPEAT_S` seconds before on the stream's clock (``now``,
        :meth:`_advance`) or more and it goes on; with ``started`` (every run of the
        block continues one of the stream's), none about the runs' start.
        With ``history`` (the model was given each run so far), a finding
        goes on when its text changed since the last block (more rows): an
        unchanged one ended before this block, and is not said again."""
        for w in caught:
            key = _said_key(w)
            late = started and (
                issubclass(w.category, RunStartWarning)
                or re.search(LATE_START_WARNING, str(w.message)) is not None
            )
            if late:
                continue
            text = str(w.message)
            grew = not history or self._texts.get(key) != text
            self._texts[key] = text
            last = self._said.get(key)
            again = issubclass(w.category, GuardWarning) and (
                last is not None and now - last >= REPEAT_S and grew
            )
            if last is None or again:
                self._said[key] = now
                warnings.warn_explicit(
                    w.message, w.category, w.filename, w.lineno, source=w.source
                )

    def _with_history(self, method, X, groups, runs, new, now):
        """The runs' rows so far and the new ones given to the model; its
        output for the new rows, and the warnings not said before."""
        parts, rows = [], []
        offset = 0
        for lab, a, b in runs:
            mine = np.arange(a, b)
            block = X.iloc[mine]
            past = self._history.get(lab)
            whole = block if past is None else pd.concat([past, block])
            done = 0 if past is None else len(past)
            parts.append((lab, whole))
            rows.append(offset + done + np.arange(mine.size))
            offset += len(whole)
        stacked = pd.concat([w for _, w in parts]) if len(parts) > 1 else parts[0][1]
        kwargs = {}
        if groups is not None:
            kwargs["groups"] = np.concatenate(
                [np.full(len(w), lab, dtype=object) for lab, w in parts]
            )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            out = getattr(self.model_, method)(stacked, **kwargs)
        self._say_new(caught, not new, now, history=True)
        for lab, whole in parts:
            self._history[lab] = whole
        rows = np.concatenate(rows)
        if hasattr(out, "iloc"):
            return out.iloc[rows].set_axis(X.index, axis=0)
        return np.asarray(out)[rows]


# A guard's finding (its kind, sensors and run) said again by a stream when
# it was last said this long before (s of time_s): a sensor hovering at the
# edge of its range came back 247 times in 100 minutes, each said.
REPEAT_S = 600.0


def _holds_guard(model):
    """Whether ``model`` is a guard or holds one (a pipeline's step), whose
    checks read a run's rows before the new ones."""
    if hasattr(model, "predict_checked"):
        return True
    params = model.get_params(deep=True) if hasattr(model, "get_params") else {}
    return any(hasattr(v, "predict_checked") for v in params.values())


def _said_key(w):
    """What makes warning ``w`` (of a model given the run so far) one said
    before: its text without its figures outside quotes (a guard's
    finding by its kind, sensors and run, not its time, values or row
    counts; an inner model's gap count growing with the run so far)."""
    text = without_figures(str(w.message))
    # "1 row" and "2 rows" are one finding growing.
    text = re.sub(r"\b(row|sample|stretch)(?:e?s)\b", r"\1", text)
    return w.category, text


def _readings(X):
    """The temperature readings (``T<name>_C`` columns) of the rows of
    ``X``, one array row per row."""
    columns = [
        c for c in X.columns if isinstance(c, str) and TEMPERATURE_PATTERN.fullmatch(c)
    ]
    try:
        return X[columns].to_numpy(dtype=float, na_value=np.nan)
    except (TypeError, ValueError):  # text among them: the model says so
        values = X[columns].apply(pd.to_numeric, errors="coerce")
        return values.to_numpy(dtype=float, na_value=np.nan)


# A sensor that warmed (or cooled) this much over a run counts in telling a
# clock reset from a new run (K): one that moved a quantum step does not.
_MOVED_K = 0.5


def _goes_on(first, last, new):
    """Whether the temperatures ``new`` go on from ``last`` (an earlier
    run's last row) rather than from ``first`` (its first row): nearer the
    end than half their distance to the start for most of the sensors that
    moved over :data:`_MOVED_K` in that run."""
    if not first.shape == last.shape == new.shape:
        return False  # the blocks held other columns
    moved = np.abs(last - first)
    use = np.isfinite(moved) & np.isfinite(new) & (moved > _MOVED_K)
    if not use.any():
        return False
    near_end = np.abs(new - last)[use] < 0.5 * np.abs(new - first)[use]
    return bool(np.mean(near_end) > 0.5)


def _as_text(label):
    """A run label as a table would write it (``1.0`` as ``1``)."""
    if isinstance(label, float | np.floating) and float(label).is_integer():
        return str(int(label))
    return str(label)


def _labels_and_times(X, groups):
    """Every row's run label and ``time_s``, or a ValueError saying how to
    give them."""
    if not isinstance(X, pd.DataFrame):
        raise ValueError(
            "RunStream needs the blocks as run tables (a DataFrame with 'run' "
            "and 'time_s' columns or index levels): without each row's time_s, "
            "a block given twice or out of order cannot be told from the next "
            f"one. Got {type(X).__name__}."
        )
    X_raw, labels = extract_runs(X, groups, finite=False)
    if labels is None:
        raise ValueError(
            "RunStream needs every row's run label, to continue each run from "
            "its last block: a 'run' column or index level, or groups=."
        )
    times = row_times(X_raw)
    if times is None:
        raise ValueError(
            "RunStream needs every row's time_s (a 'time_s' column or index "
            "level): without it, a block given twice or out of order cannot "
            "be told from the next one."
        )
    return np.asarray(labels, dtype=object), np.asarray(times, dtype=float)
