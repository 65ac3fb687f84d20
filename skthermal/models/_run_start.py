"""A regressor fitted and applied on changes since the start of each run."""

import warnings

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, RegressorMixin, _fit_context, clone
from sklearn.utils import get_tags
from sklearn.utils._param_validation import HasMethods, StrOptions
from sklearn.utils.validation import check_is_fitted, validate_data

from skthermal.utils._runs import (
    LATE_START_WARNING,
    REUSED_LABEL_WARNING,
    RUN_COLUMN,
    TARGET_COLUMNS_WARNING,
    TIME_COLUMN,
    changes_since_start,
    check_one_target,
    check_time_order,
    continued_runs,
    continued_values,
    driver_positions,
    extract_runs,
    has_time_index,
    run_memory,
    run_slices,
    run_times,
    warn_absolute_target,
    warn_unlabelled_runs,
)
from skthermal.utils._wrappers import routed_params, wrapped_tags, wrapper_router


class RunStartRegressor(RegressorMixin, BaseEstimator):
    """Fit and predict a regressor on changes since the start of each run.

    The papers model "temperature change" against "thermal drift": inputs and
    target are taken relative to the first sample of their run, and the
    prediction is the change of the error since the run started -- what a
    compensation applies (zero on the first sample of every run).

    Run labels come from ``groups``, a ``run`` column or a ``run`` index level
    (as returned by :func:`skthermal.datasets.split_runs`); without any, all
    rows are one run. The inner estimator sees a DataFrame indexed by run
    (and by ``time_s`` when ``X`` has times: a ``time_s`` column or index
    level), so run-aware estimators (grey models, ANFIS checking sets, lag
    features) keep the run boundaries and the times.

    *Runs across fit and predict*, as the grey regressors: a run label seen
    in ``fit`` continues that run, so its later rows given alone are
    predicted as the change since the run's first *training* row (what
    predicting the whole run gives on them); a labelled run that starts
    inside its training span is an error; a run not seen in ``fit`` starts
    at its first row, with a warning if its ``time_s`` does not start at 0.

    Parameters
    ----------
    estimator : regressor
        The model, cloned by ``fit``.
    drivers : "auto", sequence of str or int, default=None
        Columns passed through as they are, not as changes: drivers such as
        the spindle speed are set-points, not readings offset from their run
        start (``1250 rpm`` at the first row is heat, not zero). Names of
        DataFrame columns, or positions; ``"auto"``: the run table's drivers
        ``spindle_rpm`` and ``feed_mm_min`` among the columns of ``X``.

    Attributes
    ----------
    estimator_ : regressor
        The fitted clone.
    run_states_ : dict
        Per run label seen in ``fit``: its length, first row, first and last
        ``time_s`` and the inner model's prediction at its first row. Empty
        when ``fit`` got no run labels.
    n_features_in_ : int
        Number of features seen during ``fit``.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Names of the features seen during ``fit`` (string column names only).

    See Also
    --------
    skthermal.ensemble.ModularRegressor : a sum of regressors; with
        ``relative=True`` it also works on changes since the run start, but
        hands its modules plain arrays.
    skthermal.models.make_model : the named models, each wrapped in this
        class.

    Notes
    -----
    001 §5.3 trains and scores its models on temperature and displacement
    changes since the start of each test. Scores of this regressor
    (:meth:`score`) compare changes with absolute targets; score changes with
    :func:`skthermal.study.score_runs` instead.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from skthermal.models import RunStartRegressor
    >>> t = np.linspace(0.0, 1.0, 20)
    >>> X = np.r_[20.0 + 3.0 * t, 25.0 + 3.0 * t][:, None]  # two runs
    >>> y = np.r_[5.0 + 2.0 * t, -4.0 + 2.0 * t]
    >>> runs = np.repeat(["a", "b"], 20)
    >>> model = RunStartRegressor(LinearRegression()).fit(X, y, groups=runs)
    >>> model.predict(X, groups=runs)[[0, 19, 20, 39]].round(6)
    array([0., 2., 0., 2.])
    """

    _parameter_constraints: dict = {
        "estimator": [HasMethods(["fit", "predict"])],
        "drivers": [None, StrOptions({"auto"}), "array-like"],
    }

    def __init__(self, estimator, *, drivers=None):
        self.estimator = estimator
        self.drivers = drivers

    def _changes(self, A, groups, X, bases=None):
        """``A`` minus the first row of its run (drivers kept as they are),
        as a DataFrame indexed by run (and time, when ``X`` has times).
        ``bases``: per run, the first row to subtract instead (None: the
        run's own)."""
        slices, _ = run_slices(groups, A.shape[0])
        levels, names = [], []
        if groups is not None:
            levels.append(np.asarray(groups))
            names.append(RUN_COLUMN)
        if has_time_index(X):
            levels.append(np.asarray(X.index.get_level_values(TIME_COLUMN)))
            names.append(TIME_COLUMN)
        index = pd.MultiIndex.from_arrays(levels, names=names) if levels else None
        changes = changes_since_start(A, slices, bases)
        columns = getattr(self, "feature_names_in_", None)
        keep = driver_positions(self.drivers, columns, A.shape[1])
        changes[:, keep] = A[:, keep]
        # Integer column labels when unnamed: the inner model records no names.
        return pd.DataFrame(changes, index=index, columns=columns)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        if hasattr(self.estimator, "fit"):  # else refused by fit's validation
            wrapped_tags(tags, self.estimator)
        return tags

    def get_metadata_routing(self):
        """The metadata routing of this wrapper and its model.

        With ``sklearn.set_config(enable_metadata_routing=True)``, what the
        model requests for ``fit`` (``set_fit_request(sample_weight=True)``)
        is passed on by a Pipeline, a search or ``cross_validate``.

        Returns
        -------
        routing : MetadataRouter
        """
        return wrapper_router(self, ["fit"])

    @_fit_context(prefer_skip_nested_validation=False)
    def fit(self, X, y, *, groups=None, **fit_params):
        """Fit the estimator on changes since the start of each run.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
            Inputs; a ``run`` column or index level holds run labels.
        y : array-like of shape (n_samples,) or (n_samples, n_targets)
            Target; several targets when the wrapped model takes them.
        groups : array-like of shape (n_samples,), optional
            Run labels (runs contiguous); override a ``run`` column.
        **fit_params : dict
            Further arguments of the model's ``fit`` (``sample_weight``,
            one per row); under metadata routing, what the model requested.

        Returns
        -------
        self : RunStartRegressor
        """
        X, groups = extract_runs(X, groups, y=y)
        check_time_order(X, groups)
        multi = get_tags(self).target_tags.multi_output
        if not multi:
            check_one_target(type(self).__name__, y, f"{type(self).__name__}(...)")
        A, y = validate_data(
            self, X, y, y_numeric=True, multi_output=multi, dtype=np.float64
        )
        # Changes since the start of the run need the runs.
        warn_unlabelled_runs(
            type(self).__name__, None, groups, A.shape[0], X=X, stacklevel=4
        )
        slices, labels = run_slices(groups, A.shape[0])
        warn_absolute_target(type(self).__name__, y, slices)
        dy = changes_since_start(np.asarray(y, dtype=float), slices)
        changes = self._changes(A, groups, X)
        # The runs reach the model in the index of the changes.
        fit_params = routed_params(self, "fit", fit_params)
        with warnings.catch_warnings():
            # Said above, for X as given.
            warnings.filterwarnings("ignore", message=TARGET_COLUMNS_WARNING)
            self.estimator_ = clone(self.estimator).fit(changes, dy, **fit_params)
        # Runs labelled in fit: predict warns when it gets rows without labels.
        self._fit_runs = None if groups is None else len(slices)
        # What continuing a labelled run in predict needs: its first row and
        # times, and the inner model's prediction there (the zero of the
        # run's predicted change).
        memory = run_memory(A, slices, labels, X)
        if memory:
            first = np.asarray(self.estimator_.predict(changes), dtype=float)
            for sl, lab in zip(slices, labels, strict=True):
                if lab in memory:
                    memory[lab]["pred_first"] = first[sl.start].copy()
        self.run_states_ = memory
        return self

    def predict(self, X, *, groups=None):
        """Predict the change of the target since the start of each run.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
            Inputs; a ``run`` column or index level holds run labels.
        groups : array-like of shape (n_samples,), optional
            Run labels (runs contiguous); override a ``run`` column.

        Returns
        -------
        ndarray of shape (n_samples,) or (n_samples, n_targets)
            Zero on the first row of every run.
        """
        check_is_fitted(self, "estimator_")
        X, groups = extract_runs(X, groups)
        check_time_order(X, groups)
        A = validate_data(self, X, reset=False, dtype=np.float64)
        warn_unlabelled_runs(
            type(self).__name__, getattr(self, "_fit_runs", None), groups, A.shape[0]
        )
        slices, labels = run_slices(groups, A.shape[0])
        memory = getattr(self, "run_states_", {})
        cont = continued_runs(
            type(self).__name__, A, slices, labels, run_times(X, slices), memory
        )
        bases = continued_values(cont, memory, "x_first")
        with warnings.catch_warnings():
            # This model has just named the runs' late starts and missing
            # labels; the wrapped one would say it again in its own name.
            warnings.filterwarnings("ignore", message=LATE_START_WARNING)
            warnings.filterwarnings("ignore", message=REUSED_LABEL_WARNING)
            warnings.filterwarnings("ignore", message=r".* carry no run labels")
            pred = self.estimator_.predict(self._changes(A, groups, X, bases))
        return changes_since_start(
            np.asarray(pred, dtype=float),
            slices,
            continued_values(cont, memory, "pred_first"),
        )
