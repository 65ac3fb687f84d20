"""Run-aware base class of the sensor selectors.

The selectors score sensors on how they *change* during a run, and grey models
accumulate series over time; both must restart at every run boundary. The base
class finds the run labels, validates the data with errors that name the
offending sensor or run, and leaves the scoring to subclasses.
"""

import warnings
from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator, _fit_context
from sklearn.feature_selection import SelectorMixin
from sklearn.utils._param_validation import Interval, RealNotInt, StrOptions
from sklearn.utils.validation import _num_samples, check_is_fitted, validate_data

from skthermal._naming import listed
from skthermal.utils._runs import (
    POWER_DRIVERS,
    changes_since_start,
    check_finite_target,
    check_run_lengths,
    check_time_order,
    describe_row,
    describe_unreadable,
    extract_runs,
    run_feature_names_in,
    run_frame_index,
    run_slices,
    target_names,
    unreadable,
    warn_row_gaps,
    warn_target_columns,
    warn_unlabelled_runs,
)
from skthermal.utils._warnings import user_stacklevel

# A column whose changes within its runs are all at most this share of its
# largest magnitude does not change: what is left is the rounding of the
# readings (5 + 1e-13 passed as a varying target, and the selectors ranked
# the sensors on it).
_ROUNDING_SHARE = 1e-12


def _rounding_share(A):
    """Relative rounding of the values of ``A`` as given, before conversion
    to float64, per column of a DataFrame (else one figure):
    :data:`_ROUNDING_SHARE`, or a few steps of the machine precision of a
    lower-precision float type (float32 rounds at 6e-8 relative, so float32
    readings constant up to rounding vary by ~1e-7)."""
    if hasattr(A, "columns"):  # a DataFrame: one figure per column
        return np.array([_dtype_share(d) for d in A.dtypes])
    return _dtype_share(getattr(A, "dtype", None))


def _dtype_share(dtype):
    """:func:`_rounding_share` of one dtype (None: float64's)."""
    try:  # pandas' nullable dtypes carry their numpy dtype
        d = np.dtype(getattr(dtype, "numpy_dtype", dtype))
    except TypeError:
        return _ROUNDING_SHARE
    if dtype is None or d.kind != "f":
        return _ROUNDING_SHARE
    return max(_ROUNDING_SHARE, 8.0 * float(np.finfo(d).eps))


def _unchanging(A, slices, share=_ROUNDING_SHARE):
    """Whether each column of ``A`` is constant within every run, up to the
    rounding of its values (``share`` of their largest magnitude,
    :func:`_rounding_share`: one figure, or one per column)."""
    share = np.asarray(share, dtype=float)
    if share.ndim and share.size != A.shape[1]:  # columns left out since
        share = share.max()
    change = np.abs(changes_since_start(A, slices)).max(axis=0)
    return change <= share * np.abs(A).max(axis=0)


def _feature_label(estimator, j):
    names = getattr(estimator, "feature_names_in_", None)
    return f"sensor {names[j]!r}" if names is not None else f"feature {j}"


def _warn_drivers_as_sensors(selector):
    """Warn when ``selector`` is fitted on the operating drivers (spindle
    speed, feed) among the sensors: it ranks them as temperatures, and a
    lag model behind it loses its heat input when they are not kept (its
    errors rose from 0.29 to 0.4-1.7 µm in cross-validation, silently)."""
    names = getattr(selector, "feature_names_in_", None)
    found = [] if names is None else [str(c) for c in names if c in POWER_DRIVERS]
    if found:
        warnings.warn(
            f"{type(selector).__name__}: X holds the drivers {found}, which it "
            "ranks as temperature sensors; a model behind it that reads them as "
            "heat (LagRidgeCV, LagFeatures) loses them when they are not kept. "
            "Select among the sensors and pass the drivers by, under their "
            "names: ColumnTransformer([('sensors', selector, sensor_columns)], "
            "remainder='passthrough', verbose_feature_names_out=False) with "
            "set_output(transform='pandas').",
            UserWarning,
            stacklevel=user_stacklevel(),
        )


class RunAwareSelector(SelectorMixin, BaseEstimator):
    """Base class: validation, run handling and the ``transform`` of a selector.

    Run labels are taken from the ``groups`` argument of ``fit`` (which can be
    routed by scikit-learn's metadata routing), else from a ``run`` column of a
    DataFrame ``X`` (removed from the features), else from a ``run`` level of
    the DataFrame's index, as produced by :func:`skthermal.datasets.split_runs`;
    otherwise all rows form one run. Subclasses implement ``_fit_runs``.
    """

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.required = True
        # transform only picks columns: float32 readings stay float32.
        tags.transformer_tags.preserves_dtype = ["float64", "float32"]
        return tags

    def _counts_rows(self):
        """Whether the scores count rows, not seconds (a grey model's
        accumulation): ``fit`` then warns of gaps in the runs' times and of
        runs sampled at other periods, which change the scores."""
        return False

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, *, groups=None):
        """Score the sensors and choose the ones to keep.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_sensors)
            Sensor readings, rows time-ordered within each run. A ``run``
            column or index level of a DataFrame gives the run labels.
        y : array-like of shape (n_samples,) or (n_samples, n_targets)
            Thermal displacement(s).
        groups : array-like of shape (n_samples,), default=None
            Run label of every row; overrides a ``run`` column or index level.

        Returns
        -------
        self : object
        """
        X, groups = extract_runs(X, groups, finite=False)
        check_time_order(X, groups)
        if self._counts_rows():
            slices, labels = run_slices(groups, _num_samples(X))
            warn_row_gaps(type(self).__name__, X, slices, labels, stacklevel=4)
        # Rows without run labels are one run: a scaler in front that outputs
        # numpy drops the run index, and every run's changes and
        # accumulations would run on across the boundaries, silently.
        warn_unlabelled_runs(
            type(self).__name__, None, groups, _num_samples(X), X=X, stacklevel=4
        )
        if y is not None:
            check_finite_target(y, X, groups)
            warn_target_columns(X, y)
        rows = X  # its run and time_s, for messages
        names = target_names(y)
        shares = (_rounding_share(X), _rounding_share(y))
        X, y = validate_data(
            self,
            X,
            y,
            multi_output=True,
            y_numeric=True,
            ensure_min_samples=2,
            ensure_all_finite=False,
            dtype=np.float64,
        )
        Y = np.asarray(y, dtype=float).reshape(X.shape[0], -1)
        _warn_drivers_as_sensors(self)
        slices, labels = run_slices(groups, X.shape[0])
        constant = self._check_runs(X, Y, slices, labels, rows, groups, names, shares)
        self._fit_varying(X, Y, groups, slices, constant)
        return self

    def _check_finite(self, name, A, rows, groups, hint, support=None):
        """Raise a ValueError naming the first non-finite or absurdly large
        (:func:`~skthermal.utils._runs.unreadable`) value of ``A`` (``name``
        "X" or "y"): the sensor or target, the row, its run and time
        (:func:`~skthermal.utils._runs.describe_row` of ``rows`` and
        ``groups``, as ``extract_runs`` returns them), and with ``support``
        whether the sensor is selected."""
        bad = unreadable(A)
        if not bad.any():
            return
        row, col = (int(i) for i in np.argwhere(bad)[0])
        value = A[row, col]
        kind = (
            ("NaN" if np.isnan(value) else "inf")
            if not np.isfinite(value)
            else describe_unreadable(value)
        )
        what = _feature_label(self, col) if name == "X" else f"target {col}"
        role = ""
        if support is not None:
            role = " (a selected sensor)" if support[col] else " (not a selected one)"
        raise ValueError(
            f"Input {name} contains {kind}: {what} at "
            f"{describe_row(row, rows, groups)}{role}. {hint}"
        )

    def _check_runs(
        self,
        X,
        Y,
        slices,
        labels,
        rows=None,
        groups=None,
        names=None,
        shares=(_ROUNDING_SHARE, _ROUNDING_SHARE),
    ):
        for name, A in (("X", X), ("y", Y)):
            hint = "Impute or drop the samples before fitting."
            self._check_finite(name, A, rows, groups, hint)
        check_run_lengths(slices, labels, "measuring a change")
        flat = _unchanging(Y, slices, shares[1])
        if flat.any():
            k = int(np.argmax(flat))
            target = f"{names[k]!r}" if names else str(k)
            raise ValueError(
                f"Target {target} does not change within any run: "
                "there is no thermal error to rank the sensors by (a correlation "
                f"with it is undefined). {type(self).__name__} needs a varying "
                "thermal error."
            )
        constant = _unchanging(X, slices, shares[0])
        if constant.all():
            label = _feature_label(self, 0)
            raise ValueError(
                f"Every sensor is constant within every run ({label} and "
                f"{constant.size - 1} more): none carries information about "
                "the thermal error."
            )
        if constant.any():
            # As scikit-learn's selectors do with a constant feature: said,
            # and ranked last. (Refused, a sensor that moved in one run only
            # failed the cross-validation fold that held that run out.)
            found = [_feature_label(self, j) for j in np.flatnonzero(constant)]
            warnings.warn(
                f"{type(self).__name__}: {listed(found)} "
                f"{'is' if len(found) == 1 else 'are'} constant within every "
                "training run and carr"
                f"{'ies' if len(found) == 1 else 'y'} no information about the "
                "thermal error: not selected, ranked last, scored NaN.",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
        return constant

    # Fitted attributes that hold one entry per sensor, and the axes along
    # which they do (filled with NaN for the sensors left out as constant).
    _PER_SENSOR = {"scores_": (-1,)}

    def _fit_varying(self, X, Y, groups, slices, constant):
        """``_fit_runs`` on the sensors that vary, its per-sensor attributes
        widened to every sensor (the constant ones unselected and last)."""
        if not constant.any():
            self._fit_runs(X, Y, groups, slices)
            return
        keep = np.flatnonzero(~constant)
        self._fit_runs(X[:, keep], Y, groups, slices)
        n = X.shape[1]
        for name, axes in self._PER_SENSOR.items():
            if not hasattr(self, name):
                continue
            value = np.asarray(getattr(self, name), dtype=float)
            for axis in axes:
                shape = list(value.shape)
                shape[axis] = n
                full = np.full(shape, np.nan)
                index = [slice(None)] * value.ndim
                index[axis] = keep
                full[tuple(index)] = value
                value = full
            setattr(self, name, value)
        support = np.zeros(n, dtype=bool)
        support[keep] = self.support_
        self.support_ = support
        if hasattr(self, "ranking_"):
            ranking = np.full(n, keep.size + 1, dtype=self.ranking_.dtype)
            ranking[keep] = self.ranking_
            self.ranking_ = ranking
        if hasattr(self, "labels_"):
            labels = np.full(n, -1, dtype=self.labels_.dtype)
            labels[keep] = self.labels_
            self.labels_ = labels
        if hasattr(self, "representatives_"):
            self.representatives_ = keep[self.representatives_]

    def _get_support_mask(self):
        check_is_fitted(self)
        return self.support_

    def transform(self, X):
        """Keep the selected sensors (a ``run`` column is dropped).

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_sensors)

        Returns
        -------
        X_selected : ndarray or DataFrame of shape (n_samples, n_selected)
            A DataFrame indexed by ``run`` (and ``time_s``) when ``X`` is a
            run table (a ``run`` column, or ``run``/``time_s`` index levels):
            a sequence model after the selector in a Pipeline then still
            sees where every run starts and each row's time. Otherwise an
            array (or what ``set_output`` asks for).
        """
        original = X
        X, groups = extract_runs(X, finite=False)
        check_is_fitted(self)
        A = validate_data(self, X, reset=False, ensure_all_finite=False)
        support = self._get_support_mask()
        if unreadable(A).any():
            hint = "Impute or drop those samples first."
            self._check_finite("X", A, X, groups, hint, support)
        kept = A[:, support]
        index = run_frame_index(original, X, groups)
        if index is None:
            return kept
        import pandas as pd

        return pd.DataFrame(kept, index=index, columns=self.get_feature_names_out())

    def get_feature_names_out(self, input_features=None):
        """Names of the kept sensors.

        Parameters
        ----------
        input_features : array-like of str, optional
            The input names: those seen in ``fit``, or the columns of the
            run table fitted on (with its ``run`` and ``time_s`` columns, as
            a ``ColumnTransformer`` passes them). None gives the names seen
            in ``fit`` (``x0``, ``x1``, ... for an array).

        Returns
        -------
        ndarray of str
        """
        check_is_fitted(self)
        return run_feature_names_in(self, input_features)[self.get_support()]


class ScoreSelector(RunAwareSelector):
    """Base class of selectors that keep the best-scoring sensors.

    Subclasses implement ``_scores_per_target(X, Y, groups)`` returning an
    array of shape (n_targets, n_features), bigger = more relevant.
    """

    _parameter_constraints: dict = {
        "n_features_to_select": [
            Interval(Integral, 1, None, closed="left"),
            Interval(RealNotInt, 0, 1, closed="right"),
            None,
        ],
        "threshold": [Real, StrOptions({"mean", "median"}), None],
    }

    def _fit_runs(self, X, Y, groups, slices):
        per_output = self._scores_per_target(X, Y, groups)
        if per_output.shape[0] == 1:
            scores = per_output[0]
        else:
            # Several displacement axes: average the scores after scaling each
            # axis' scores to a maximum of one, so no axis dominates by units.
            top = per_output.max(axis=1, keepdims=True)
            scores = (per_output / np.where(top > 0, top, 1.0)).mean(axis=0)
        self.scores_ = scores
        order = np.argsort(-scores, kind="stable")
        ranking = np.empty_like(order)
        ranking[order] = np.arange(1, order.size + 1)
        self.ranking_ = ranking
        self.support_ = self._support_from_scores(scores, order)

    def _support_from_scores(self, scores, order):
        n = scores.size
        keep = np.ones(n, dtype=bool)
        threshold = self.threshold
        if threshold == "mean":
            threshold = scores.mean()
        elif threshold == "median":
            threshold = np.median(scores)
        if threshold is not None:
            if not np.isfinite(threshold):
                raise ValueError(
                    f"threshold must be a finite score, 'mean' or 'median', got "
                    f"{self.threshold!r}."
                )
            keep &= scores >= threshold
            if not keep.any():
                raise ValueError(
                    f"threshold={self.threshold!r} keeps no sensor: the scores "
                    f"range from {np.min(scores):.4g} to {np.max(scores):.4g} "
                    "(see scores_)."
                )
        k = self.n_features_to_select
        if k is None and threshold is None:
            k = max(1, n // 2)
        if k is not None:
            if isinstance(k, Real) and not isinstance(k, Integral):
                k = max(1, int(round(k * n)))
            elif k > n:
                # As scikit-learn's SelectKBest: all are kept, with a warning.
                warnings.warn(
                    f"n_features_to_select={k}, but X has only {n} sensor(s): "
                    "all are kept.",
                    UserWarning,
                    stacklevel=user_stacklevel(),
                )
            top = np.zeros(n, dtype=bool)
            top[order[: min(int(k), n)]] = True
            keep &= top
        return keep
