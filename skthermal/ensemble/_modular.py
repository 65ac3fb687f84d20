"""Modular thermal-error models: modules trained on single-source tests,
superposed to predict tests in which the sources act together.

001 §5.4.1.3: a model of the ram's Z error trained on a Z-axis heating test
and one trained on a C-axis heating test were superposed to predict a
combined (helical) test, "so the thermal model could be built up in a modular
form and so is extensible to the remainder of the structure". Heat conduction
is linear, so the temperature changes caused by separate sources add up, and
so do the displacements they cause; each module learns one source from the
sensors that see it.
"""

import warnings
from numbers import Integral, Real

import numpy as np
import pandas as pd
from sklearn.base import RegressorMixin, _fit_context, clone
from sklearn.exceptions import ConvergenceWarning
from sklearn.linear_model import LinearRegression
from sklearn.utils import Bunch, _safe_indexing, get_tags
from sklearn.utils._param_validation import Interval
from sklearn.utils.metaestimators import _BaseComposition
from sklearn.utils.validation import check_is_fitted, validate_data

from skthermal.datasets._runtable import (
    driver_columns,
    sensor_columns,
    target_columns,
)
from skthermal.utils._runs import (
    RUN_COLUMN,
    TIME_COLUMN,
    UNLABELLED_WARNING,
    changes_since_start,
    check_one_target,
    check_time_order,
    continued_runs,
    continued_values,
    extract_runs,
    row_times,
    run_memory,
    run_slices,
    run_table_index,
    run_times,
    warn_absolute_target,
    warn_unlabelled_runs,
)
from skthermal.utils._warnings import user_stacklevel
from skthermal.utils._wrappers import routed_by_name, wrapper_router


class ModularRegressor(RegressorMixin, _BaseComposition):
    """Sum of regressors ("modules"), each on its own inputs.

    ``predict(X) = sum_k module_k.predict(X[:, columns_k])``. Each module
    stands for one heat source (the spindle, a feed axis, the environment)
    and reads the sensors that see it. Modules are trained either on their
    own single-source tests (``fit(X, y, source=...)`` or
    :meth:`fit_modules`), as in 001 §5.4.1.3, or together on one data set by
    backfitting (``fit(X, y)``), which fits every module in turn to what the
    others leave unexplained.

    Given a run table (a DataFrame with ``run`` and ``time_s`` columns, or
    the ``(run, time_s)`` index of :func:`skthermal.datasets.split_runs`) or
    ``groups``, every module gets its columns as a sub-table that keeps their
    names and the ``(run, time_s)`` index, in ``fit`` and ``predict``: a
    sequence module (lag features, a transfer function, a grey model) sees
    the runs, times and drivers it would see fitted alone.

    Parameters
    ----------
    modules : list of (str, estimator, columns) tuples or None, default=None
        The modules: a name, a regressor (cloned) and the columns of ``X`` it
        reads: column names (``X`` a DataFrame), integer positions, or
        ``None`` / ``"all"`` for every column. None: one ``LinearRegression``
        on every column. A module gets its columns as a DataFrame (their
        names; the ``(run, time_s)`` index when runs or times are known) when
        ``X`` has column names, runs or times, else as a numpy array.
    relative : bool, default=True
        Work on changes since the start of each run (inputs and targets in
        ``fit``, inputs in ``predict``), the papers' "temperature change" and
        "thermal drift": the prediction is then the displacement *change*
        since the start of the run (at a run's first row, where every input
        change is zero, what the modules give for zero: their intercepts,
        not forced to zero). Runs come from ``groups``, a ``run``
        column or a ``run`` index level (:func:`skthermal.datasets.split_runs`);
        without them all rows are one run (``fit`` warns when the rows carry
        no ``time_s`` either: a plain array, as a scikit-learn step that
        outputs numpy makes of a run table). A run label seen in ``fit``
        continues that run in ``predict`` (changes since its first training
        row, so its later rows given alone are predicted as inside the whole
        run); a labelled run starting inside its training span is an error;
        a run not seen in ``fit`` whose ``time_s`` does not start at 0 warns.
    max_iter : int, default=20
        Backfitting sweeps when training without ``source``.
    tol : float, default=1e-6
        Backfitting stops when no module's fitted values change by more than
        ``tol`` times the standard deviation of the target.

    Attributes
    ----------
    estimators_ : list of estimator
        The fitted modules, in order.
    run_states_ : dict
        With ``relative=True``, per run label seen in ``fit``: its length,
        first row and first and last ``time_s`` (to continue it). Empty
        otherwise.
    named_estimators_ : Bunch
        The fitted modules by name.
    module_columns_ : list of ndarray of int
        Positions of the columns each module reads.
    n_iter_ : int
        Backfitting sweeps run (0 when trained by ``source``).
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (n_features_in_,)

    See Also
    --------
    skthermal.fuzzy.ANFISRegressor : a module for nonlinear sources.

    Notes
    -----
    001 §5.4.1.3 (Z-axis and C-axis heating tests superposed to predict the
    helical test, ±9 µm of 95 µm). Superposition holds as long as the
    network is linear: a source that changes the heat transfer (a faster
    spindle stirring the air) breaks it a little. A module trained on a test
    of its own source only has seen its sensors move and the others stay
    still; its coefficients on sensors that did not move are undetermined,
    which is why each module should read only the sensors of its source.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn.linear_model import LinearRegression
    >>> from skthermal.ensemble import ModularRegressor
    >>> heat = np.linspace(0, 5, 50)
    >>> quiet = np.zeros(50)
    >>> X = np.r_[np.c_[heat, quiet], np.c_[quiet, heat]]   # two tests
    >>> y = np.r_[2.0 * heat, -1.0 * heat]
    >>> source = np.repeat(["spindle", "axis"], 50)
    >>> model = ModularRegressor([("spindle", LinearRegression(), [0]),
    ...                           ("axis", LinearRegression(), [1])],
    ...                          relative=False)
    >>> model.fit(X, y, source=source).predict([[1.0, 1.0], [2.0, 4.0]]).round(6)
    array([1., 0.])
    """

    _parameter_constraints: dict = {
        "modules": [list, None],
        "relative": ["boolean"],
        "max_iter": [Interval(Integral, 1, None, closed="left")],
        "tol": [Interval(Real, 0, None, closed="left")],
    }

    def __init__(self, modules=None, *, relative=True, max_iter=20, tol=1e-6):
        self.modules = modules
        self.relative = relative
        self.max_iter = max_iter
        self.tol = tol

    # --- nested parameters (``spindle__alpha``), as ColumnTransformer ------

    @property
    def _modules(self):
        try:
            return [(name, est) for name, est, _ in self.modules or []]
        except (TypeError, ValueError):
            return []

    @_modules.setter
    def _modules(self, value):
        self.modules = [
            (name, est, cols)
            for (name, est), (_, _, cols) in zip(value, self.modules, strict=True)
        ]

    def get_params(self, deep=True):
        """Parameters, with those of the modules as ``<name>__<param>``."""
        return self._get_params("_modules", deep=deep)

    def set_params(self, **params):
        """Set parameters, also of modules (``<name>__<param>``) or whole
        modules by name."""
        self._set_params("_modules", **params)
        return self

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # Several targets when every module takes them (the default linear
        # module does).
        inner = [
            module[1]
            for module in (self.modules or ())
            if isinstance(module, tuple) and len(module) > 1
        ]
        tags.target_tags.multi_output = all(
            get_tags(est).target_tags.multi_output
            for est in inner
            if hasattr(est, "fit")
        )
        tags.target_tags.single_output = True
        return tags

    def get_metadata_routing(self):
        """The metadata routing of the composition and its modules.

        With ``sklearn.set_config(enable_metadata_routing=True)``, what a
        module requests for ``fit`` (``set_fit_request(sample_weight=True)``)
        is passed on to it by a Pipeline, a search or ``cross_validate``; with
        ``source``, each module gets the rows of its own tests.

        Returns
        -------
        routing : MetadataRouter
        """
        children = {
            item[0]: item[1]
            for item in self._given_modules()
            if isinstance(item, tuple | list)
            and len(item) == 3
            and isinstance(item[0], str)
            and hasattr(item[1], "fit")
        }
        return wrapper_router(self, ["fit"], children)

    # --- validation ---------------------------------------------------------

    def _given_modules(self):
        """``modules``, or the default: one linear module on every column."""
        if self.modules is None:
            return [("linear", LinearRegression(), None)]
        return self.modules

    def _resolve_modules(self):
        modules = self._given_modules()
        if not modules:
            raise ValueError("modules is empty: give at least one module.")
        out, names = [], []
        for i, item in enumerate(modules):
            if not isinstance(item, tuple | list) or len(item) != 3:
                raise ValueError(
                    f"Module {i} must be a (name, estimator, columns) tuple, got "
                    f"{item!r}."
                )
            name, est, cols = item
            if not isinstance(name, str) or not name or "__" in name:
                raise ValueError(
                    f"Module {i} needs a non-empty string name without '__', got "
                    f"{name!r}."
                )
            if name in names:
                raise ValueError(f"Two modules are named {name!r}.")
            if name in ("modules", "relative", "max_iter", "tol"):
                raise ValueError(f"Module name {name!r} clashes with a parameter.")
            if not (hasattr(est, "fit") and hasattr(est, "predict")):
                raise ValueError(
                    f"Module {name!r}: {est!r} is not a regressor (no fit/predict)."
                )
            names.append(name)
            out.append((name, est, self._columns(name, cols)))
        return out

    def _columns(self, name, cols):
        n = self.n_features_in_
        if cols is None or (isinstance(cols, str) and cols == "all"):
            return np.arange(n)
        if isinstance(cols, str | Integral):
            cols = [cols]
        cols = list(cols)
        if not cols:
            raise ValueError(f"Module {name!r} reads no column.")
        if all(isinstance(c, str) for c in cols):
            names = getattr(self, "feature_names_in_", None)
            if names is None:
                raise ValueError(
                    f"Module {name!r} names its columns, but X has no column "
                    "names; pass a DataFrame or give integer positions."
                )
            where = {c: i for i, c in enumerate(names)}
            missing = [c for c in cols if c not in where]
            if missing:
                raise ValueError(
                    f"Module {name!r}: column(s) {missing} are not in X; it has "
                    f"{list(names)}."
                )
            idx = np.array([where[c] for c in cols])
        elif all(isinstance(c, Integral) and not isinstance(c, bool) for c in cols):
            idx = np.asarray(cols, dtype=int)
            bad = idx[(idx < -n) | (idx >= n)]
            if bad.size:
                raise ValueError(
                    f"Module {name!r}: column position {int(bad[0])} is out of range "
                    f"for X with {n} column(s)."
                )
            idx = idx % n
        else:
            raise ValueError(
                f"Module {name!r}: columns must be names, integer positions, None "
                f"or 'all', got {cols!r}."
            )
        if len(set(idx.tolist())) != idx.size:
            raise ValueError(f"Module {name!r} lists a column twice.")
        return idx

    def _relative(self, A, groups, bases=None):
        """``A`` as changes since each run's first row (``bases``: per run,
        the first row to use instead, or None), with ``relative``."""
        if not self.relative:
            return A
        slices, _ = run_slices(groups, A.shape[0])
        return changes_since_start(A, slices, bases)

    def _frame_index(self, X_raw, groups, n_samples):
        """The index of the modules' sub-tables: ``(run, time_s)`` when the
        runs or times are known (``groups`` winning over ``X``'s own), the
        index of a DataFrame ``X`` fitted with column names; None (plain
        arrays, as given) otherwise."""
        times = row_times(X_raw)
        if groups is not None or times is not None:
            return run_table_index(groups, times)
        if getattr(self, "feature_names_in_", None) is None:
            return None
        index = getattr(X_raw, "index", None)
        return pd.RangeIndex(n_samples) if index is None else index

    def _module_input(self, A, cols, index):
        """The input of the module reading ``cols``: those columns of ``A``,
        as a sub-table on ``index`` with their names, or a plain array when
        ``index`` is None."""
        if index is None:
            return A[:, cols]
        names = getattr(self, "feature_names_in_", None)
        return pd.DataFrame(
            A[:, cols], index=index, columns=cols if names is None else names[cols]
        )

    # --- fit / predict ------------------------------------------------------

    @_fit_context(prefer_skip_nested_validation=False)
    def fit(self, X, y, *, source=None, groups=None, **fit_params):
        """Train the modules.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
            Sensor readings of every module (a ``run`` column or index level
            holds run labels, a ``time_s`` column or index level the times;
            neither is a feature).
        y : array-like of shape (n_samples,) or (n_samples, n_targets)
            Displacement(s).
        source : array-like of shape (n_samples,), optional
            The module whose single-source test every row comes from: each
            module is trained on its rows only. None: all modules are trained
            on all rows together by backfitting.
        groups : array-like of shape (n_samples,), optional
            Run labels (for ``relative=True``); override a ``run`` column.
        **fit_params : dict
            Further arguments of the modules' ``fit`` (``sample_weight``):
            given to every module, or under scikit-learn's metadata routing
            to the modules that request them. Those with one value per row
            are cut to each module's rows with ``source``.

        Returns
        -------
        self : ModularRegressor
        """
        X_raw, groups = extract_runs(X, groups, y=y)
        if not get_tags(self).target_tags.multi_output:
            check_one_target(type(self).__name__, y, f"{type(self).__name__}(...)")
        X, y = validate_data(
            self,
            X_raw,
            y,
            multi_output=get_tags(self).target_tags.multi_output,
            y_numeric=True,
            dtype=np.float64,
        )
        modules = self._resolve_modules()
        params = routed_by_name(self, "fit", fit_params, [m[0] for m in modules])
        if self.relative:
            check_time_order(X_raw, groups)
            # Changes since the start of the run need the runs.
            warn_unlabelled_runs(
                type(self).__name__, None, groups, X.shape[0], X=X_raw, stacklevel=4
            )
        slices, labels = run_slices(groups, X.shape[0])
        if self.relative:
            warn_absolute_target(type(self).__name__, y, slices)
        # Runs labelled in fit: predict warns when it gets rows without labels.
        self._fit_runs = len(slices) if self.relative and groups is not None else None
        # With relative=True, a labelled run continues in predict from its
        # first training row.
        self.run_states_ = run_memory(X, slices, labels, X_raw) if self.relative else {}
        index = self._frame_index(X_raw, groups, X.shape[0])
        X = self._relative(X, groups)
        y = self._relative(np.asarray(y, dtype=float), groups)
        with warnings.catch_warnings():
            if self.relative and groups is None:
                # Said once above, not again by every module.
                warnings.filterwarnings("ignore", message=UNLABELLED_WARNING)
            self._fit(X, y, modules, source, index, params)
        return self

    def _fit(self, X, y, modules, source, index=None, params=None):
        """Fit the modules on ``X`` (validated, relative as asked); ``index``:
        that of their sub-tables (see :meth:`_frame_index`); ``params``: per
        module name, the further arguments of its ``fit``."""
        params = params or {}
        names = [m[0] for m in modules]
        fitted = [clone(est) for _, est, _ in modules]
        self.module_columns_ = [cols for _, _, cols in modules]
        if source is not None:
            source = np.asarray(source)
            if source.shape != (X.shape[0],):
                raise ValueError(
                    f"source must hold one module name per row ({X.shape[0]}), got "
                    f"shape {source.shape}."
                )
            unknown = sorted(set(source.tolist()) - set(names), key=str)
            if unknown:
                raise ValueError(
                    f"source names {unknown!r}, which are not modules; modules: "
                    f"{names}."
                )
            for name, est, cols in zip(
                names, fitted, self.module_columns_, strict=True
            ):
                rows = source == name
                if not rows.any():
                    raise ValueError(f"Module {name!r} has no training rows in source.")
                part = None if index is None else index[rows]
                kwargs = {
                    key: _rows_of(value, rows)
                    for key, value in params.get(name, {}).items()
                }
                est.fit(self._module_input(X[rows], cols, part), y[rows], **kwargs)
            self.n_iter_ = 0
        else:
            parts = np.zeros((len(fitted), *y.shape))
            scale = float(np.std(y)) or 1.0
            inputs = [
                self._module_input(X, cols, index) for cols in self.module_columns_
            ]
            for it in range(1, self.max_iter + 1):
                change = 0.0
                for k, (name, est, X_k) in enumerate(
                    zip(names, fitted, inputs, strict=True)
                ):
                    rest = y - (parts.sum(axis=0) - parts[k])
                    with warnings.catch_warnings():
                        if it > 1:  # a module says it in the first sweep
                            warnings.filterwarnings(
                                "ignore", message=UNLABELLED_WARNING
                            )
                        est.fit(X_k, rest, **params.get(name, {}))
                    new = np.asarray(est.predict(X_k), dtype=float)
                    new = new.reshape(y.shape)
                    change = max(change, float(np.max(np.abs(new - parts[k]))))
                    parts[k] = new
                if len(fitted) == 1 or change <= self.tol * scale:
                    break
            else:
                warnings.warn(
                    f"ModularRegressor: backfitting did not converge in "
                    f"max_iter={self.max_iter} sweeps (the modules' fitted values "
                    f"still moved by {change / scale:.2g} target standard "
                    f"deviations in the last, tol={self.tol:g}); raise max_iter "
                    "or tol.",
                    ConvergenceWarning,
                    stacklevel=user_stacklevel(),
                )
            self.n_iter_ = it
        self.estimators_ = fitted
        self.named_estimators_ = Bunch(**dict(zip(names, fitted, strict=True)))
        self._y_shape = y.shape[1:]
        return self

    def fit_modules(self, data, *, target=None):
        """Train every module on its own test(s).

        Parameters
        ----------
        data : dict
            ``{module name: run table}`` (DataFrames with ``run``, ``time_s``,
            sensors and targets) or ``{module name: (X, y)}``. Every module
            needs an entry; all entries need the same feature columns. The
            modules get the tests' runs and, when every test has them, times.
        target : str or list of str, optional
            Target column(s) of run tables; default: their only
            ``disp_<axis>_um`` column.

        Returns
        -------
        self : ModularRegressor
        """
        if not isinstance(data, dict) or not data:
            raise ValueError("data must be a non-empty dict {module name: data}.")
        Xs, ys, src, grp, times = [], [], [], [], []
        for name, item in data.items():
            if isinstance(item, pd.DataFrame):
                targets = target_columns(item) if target is None else target
                if isinstance(targets, list) and len(targets) == 1:
                    targets = targets[0]
                if isinstance(targets, list) and not targets:
                    raise ValueError(f"The run table of {name!r} has no target.")
                if target is None and isinstance(targets, list):
                    raise ValueError(
                        f"The run table of {name!r} has several targets "
                        f"{targets}; choose with target=."
                    )
                missing = [
                    t
                    for t in ([targets] if isinstance(targets, str) else targets)
                    if t not in item.columns
                ]
                if missing:
                    raise ValueError(f"The run table of {name!r} has no {missing}.")
                # In the table's order: the rows to predict are tables too.
                inputs = set(sensor_columns(item) + driver_columns(item))
                features = [c for c in item.columns if c in inputs]
                labels = [c for c in (RUN_COLUMN, TIME_COLUMN) if c in item.columns]
                X_i, y_i = item[features + labels], item[targets]
            else:
                try:
                    X_i, y_i = item
                except (TypeError, ValueError):
                    raise ValueError(
                        f"data[{name!r}] must be a run table or an (X, y) pair."
                    ) from None
            X_i, g_i = extract_runs(X_i)
            g_i = np.zeros(len(X_i), dtype=int) if g_i is None else g_i
            g = np.array([f"{name}/{r}" for r in np.asarray(g_i).tolist()])
            Xs.append(X_i)
            times.append(row_times(X_i))
            ys.append(np.asarray(y_i, dtype=float))
            src.append(np.full(len(g), name, dtype=object))
            grp.append(g)
        if all(isinstance(x, pd.DataFrame) for x in Xs):
            columns = list(Xs[0].columns)
            for name, x in zip(data, Xs, strict=True):
                if list(x.columns) != columns:
                    raise ValueError(
                        f"The features of {name!r} differ from those of "
                        f"{next(iter(data))!r}; every test needs the same columns."
                    )
            X = pd.concat([x.reset_index(drop=True) for x in Xs], ignore_index=True)
            if all(t is not None for t in times):
                # The tests' times, for the modules that read them.
                X = X.set_axis(run_table_index(None, np.concatenate(times)))
        else:
            X = np.concatenate([np.asarray(x, dtype=float) for x in Xs])
        ndims = {y_.ndim for y_ in ys}
        if len(ndims) != 1:
            raise ValueError("Every module's target must have the same shape.")
        y = np.concatenate(ys)
        return self.fit(X, y, source=np.concatenate(src), groups=np.concatenate(grp))

    def _module_outputs(self, X, groups):
        check_is_fitted(self)
        X_raw, groups = extract_runs(X, groups)
        X = validate_data(self, X_raw, reset=False, dtype=np.float64)
        fit_runs = getattr(self, "_fit_runs", None)
        warn_unlabelled_runs(type(self).__name__, fit_runs, groups, X.shape[0])
        bases = None
        if self.relative:
            check_time_order(X_raw, groups)
            slices, labels = run_slices(groups, X.shape[0])
            memory = getattr(self, "run_states_", {})
            cont = continued_runs(
                type(self).__name__, X, slices, labels, run_times(X_raw, slices), memory
            )
            bases = continued_values(cont, memory, "x_first")
        index = self._frame_index(X_raw, groups, X.shape[0])
        X = self._relative(X, groups, bases)
        with warnings.catch_warnings():
            if fit_runs is not None and groups is None:
                # Said once above, not again by every module.
                warnings.filterwarnings("ignore", message=UNLABELLED_WARNING)
            outputs = [
                np.asarray(
                    est.predict(self._module_input(X, cols, index)), dtype=float
                ).reshape(X.shape[0], *self._y_shape)
                for est, cols in zip(
                    self.estimators_, self.module_columns_, strict=True
                )
            ]
        return np.stack(outputs, axis=1)

    def predict_modules(self, X, *, groups=None):
        """Contribution of every module.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
        groups : array-like of shape (n_samples,), optional

        Returns
        -------
        ndarray of shape (n_samples, n_modules) or (n_samples, n_modules, n_targets)
            Their sum over axis 1 is :meth:`predict`.
        """
        return self._module_outputs(X, groups)

    def predict(self, X, *, groups=None):
        """Sum of the module predictions.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
        groups : array-like of shape (n_samples,), optional
            Run labels (for ``relative=True``); override a ``run`` column.

        Returns
        -------
        ndarray of shape (n_samples,) or (n_samples, n_targets)
            With ``relative=True``, the displacement change since the start of
            each run.
        """
        return self._module_outputs(X, groups).sum(axis=1)


def _rows_of(value, rows):
    """``value`` at the rows ``rows`` (a boolean mask) when it holds one value
    per row (``sample_weight``), else as it is."""
    if isinstance(value, str) or not hasattr(value, "__len__"):
        return value
    if len(value) != rows.shape[0]:
        return value
    return _safe_indexing(value, rows)
