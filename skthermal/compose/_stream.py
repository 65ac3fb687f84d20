"""Prediction on a stream: a controller's blocks of rows, one run at a time.

A compensation model on a machine tool receives each new block of readings
once (a row every sampling period, or a few rows at a time), while the
sequence models of skthermal read a run from its start: their filters and
changes since the start carry the run's past. :class:`RunStream` keeps that
past between calls, so that predicting block by block gives what predicting
the whole run at once gives.
"""

import warnings
from copy import deepcopy

import numpy as np
import pandas as pd
from sklearn.utils.validation import check_is_fitted

from skthermal.utils._runs import extract_runs, run_slices


class RunStream:
    """Predict runs block by block, continuing each run from the last block.

    Give every block of rows as it comes, with its run label and ``time_s``
    (a run table: ``run`` and ``time_s`` columns or index levels, as
    :func:`skthermal.datasets.read_runs` and
    :func:`skthermal.datasets.split_runs` give them; or ``groups``). The
    rows of a run whose label an earlier block had continue that run: the
    predictions equal those of the whole run given at once (up to
    rounding). A label the stream has not seen starts a new run (a run seen
    in the model's ``fit`` continues that one, as in the model's own
    ``predict``).

    Two ways, chosen from the model:

    - a model with a ``remember_runs`` method
      (:class:`~skthermal.preprocessing.LagRidgeCV`, what
      :func:`~skthermal.preprocessing.make_lag_pipeline` returns,
      :class:`~skthermal.preprocessing.LagFeatures` and
      :class:`~skthermal.linear_model.TransferFunctionRegressor`) keeps
      each run's end state: every block costs the same, however long the
      run;
    - any other model (a Pipeline, a
      :class:`~skthermal.compose.GuardedRegressor`, a static model) is
      given each run's rows so far with the new ones and its predictions of
      the new rows are returned: exact for every model, at a cost that
      grows with the run (see the deployment docs' limits). A warning the
      model raised for an earlier block is not raised again.

    Parameters
    ----------
    model : fitted estimator
        The compensation model. The stream works on a copy (``copy=True``),
        so the model given is left as it was.
    copy : bool, default=True
        Whether to work on a deep copy of ``model``.

    Attributes
    ----------
    model_ : estimator
        The model the stream predicts with (with its remembered runs).
    runs_ : list
        Labels of the runs the stream has seen, in order of appearance.
    incremental_ : bool
        Whether the model keeps each run's end state (constant cost per
        block) rather than being given the run's rows so far.

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
        self.incremental_ = callable(getattr(self.model_, "remember_runs", None))
        self.runs_ = []
        self._history = {}
        self._said = set()

    def predict(self, X, *, groups=None):
        """Predict a block of rows, continuing the runs of earlier blocks.

        Parameters
        ----------
        X : DataFrame or array-like of shape (n_samples, n_features)
            The new rows, in time order within each run, with their run
            labels (a ``run`` column or index level, or ``groups``).
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
        """
        labels = _labels(X, groups)
        self.runs_ += [lab for lab in pd.unique(labels) if lab not in self.runs_]
        kwargs = {} if groups is None else {"groups": groups}
        if self.incremental_:
            y = self.model_.predict(X, **kwargs)
            self.model_.remember_runs(X, **kwargs)
            return y
        return self._predict_with_history(X, groups, labels)

    def _predict_with_history(self, X, groups, labels):
        """The run's rows so far and the new ones given to the model; the
        predictions of the new rows, and the warnings not said before."""
        parts, new_rows, offset = [], [], 0
        for lab in pd.unique(labels):
            mine = np.flatnonzero(labels == lab)
            block = _rows(X, mine)
            past = self._history.get(lab)
            whole = block if past is None else _stack(past, block)
            parts.append((lab, whole))
            done = 0 if past is None else len(past)
            new_rows.append((mine, offset + done + np.arange(mine.size)))
            offset += len(whole)
        stacked = _stack(*[w for _, w in parts]) if len(parts) > 1 else parts[0][1]
        kwargs = {}
        if groups is not None:
            kwargs["groups"] = np.concatenate(
                [np.full(len(w), lab, dtype=object) for lab, w in parts]
            )
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            y_all = np.asarray(self.model_.predict(stacked, **kwargs))
        for w in caught:
            key = (w.category, str(w.message))
            if key not in self._said:
                self._said.add(key)
                warnings.warn_explicit(
                    w.message, w.category, w.filename, w.lineno, source=w.source
                )
        y = np.empty((len(labels),) + y_all.shape[1:], dtype=y_all.dtype)
        for mine, rows in new_rows:
            y[mine] = y_all[rows]
        for lab, whole in parts:
            self._history[lab] = whole
        return y


def _labels(X, groups):
    """Every row's run label, or a ValueError saying how to give them."""
    _, labels = extract_runs(X, groups, finite=False)
    if labels is None:
        raise ValueError(
            "RunStream needs every row's run label, to continue each run from "
            "its last block: give X as a run table (a 'run' column or index "
            "level, with 'time_s') or pass groups=."
        )
    labels = np.asarray(labels, dtype=object)
    run_slices(labels, labels.size)  # a run's rows together, or an error
    return labels


def _rows(X, positions):
    if isinstance(X, (pd.DataFrame, pd.Series)):
        return X.iloc[positions]
    return np.asarray(X)[positions]


def _stack(*blocks):
    if isinstance(blocks[0], (pd.DataFrame, pd.Series)):
        return pd.concat(blocks)
    return np.concatenate(blocks)
