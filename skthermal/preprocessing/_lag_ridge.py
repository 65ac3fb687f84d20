"""Ridge on lag features, with settings chosen by time-ordered CV."""

import time
import warnings
from numbers import Integral, Real

import numpy as np
from scipy.stats import rankdata
from sklearn.base import BaseEstimator, RegressorMixin, _fit_context
from sklearn.linear_model import Ridge
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted, validate_data

from skthermal.preprocessing._lags import LagFeatures, runs_start_driven
from skthermal.utils._folds import run_folds
from skthermal.utils._runs import (
    EARLIER_PART_WARNING,
    GAP_BRIDGE,
    LATE_START_WARNING,
    PAUSE_BRIDGE,
    REUSED_LABEL_WARNING,
    TIME_UNIT_WARNING,
    check_one_target,
    check_positive_numbers,
    check_time_order,
    continued_runs,
    driver_positions,
    extract_runs,
    has_time_index,
    run_slices,
    run_times,
    warn_centred_drivers,
    warn_dt_against_times,
    warn_gaps,
    warn_no_time,
    warn_pauses,
    warn_time_unit,
    warn_unlabelled_runs,
    warn_unnamed_drivers,
)
from skthermal.utils._threads import single_threaded_blas
from skthermal.utils._warnings import user_stacklevel

DEFAULT_TIME_CONSTANT_SETS = (
    (),
    (900.0, 3600.0, 14400.0),
    (600.0, 1800.0, 5400.0, 16200.0),
)


def _ridge_path_sse(F, y, folds, alphas, per_fold=False):
    """Squared validation error for every alpha (one eigendecomposition of
    the standardised Gram matrix per fold).

    The total over the folds, shape (n_alphas,), or with ``per_fold`` one row
    per fold, shape (n_folds, n_alphas).
    """
    sse = np.zeros((len(folds), alphas.size))
    for k, (tr, va) in enumerate(folds):
        # One fold at a time: its copies of the rows are gone before the
        # next fold's are made.
        sse[k] = _fold_path_sse(F, y, tr, va, alphas)
    return sse if per_fold else sse.sum(0)


def _fold_path_sse(F, y, tr, va, alphas):
    """:func:`_ridge_path_sse` of one fold (training rows ``tr``, validation
    rows ``va``)."""
    A, B = F[tr], F[va]  # copies: standardised in place below
    mu = A.mean(0)
    A -= mu
    # The standard deviation from the centred copy: A.std(0) would make
    # another copy of A, the largest array of the fit.
    sd = np.sqrt(np.einsum("ij,ij->j", A, A) / A.shape[0])
    sd[sd == 0] = 1.0
    A /= sd
    B -= mu
    B /= sd
    ym = y[tr].mean()
    # The ridge path from A^T A = V diag(w) V^T (p x p, a fraction of the
    # cost of an SVD of the n x p A): the coefficients are
    # V diag(1 / (w + alpha)) V^T A^T y. The penalties (>= 1e-2 on
    # standardised columns) keep the small eigenvalues' rounding harmless.
    w, V = np.linalg.eigh(A.T @ A)
    if alphas.min() >= 1e-10 * max(float(w.max()), 1.0):
        c = V.T @ (A.T @ (y[tr] - ym))
        d = c / (np.maximum(w, 0.0) + alphas[:, None])  # (n_alpha, p)
        pred = (B @ V) @ d.T + ym  # (n_val, n_alpha)
    else:  # penalties too small for the Gram's rounding: the SVD
        U, sv, Vt = np.linalg.svd(A, full_matrices=False)
        d = sv / (sv**2 + alphas[:, None]) * (U.T @ (y[tr] - ym))
        pred = (B @ Vt.T) @ d.T + ym
    return ((pred - y[va][:, None]) ** 2).sum(0)


# What the inner LagFeatures (its candidates in fit, the chosen one in
# predict) would say that LagRidgeCV has already said in its own name:
# gaps, rows without run labels, driver names, groups against X's runs.
_SAID_BY_LAG_RIDGE = (
    r"LagFeatures: .* gap\(s\)",
    r"LagFeatures\.fit got",
    r"LagFeatures\.fit: drivers=",
    r"LagFeatures\.fit: the driver ",
    r"groups cut the rows into",
    r"LagFeatures: dt=.* is given, but the time_s steps",
    TIME_UNIT_WARNING,
)


def _quiet_inner_lag_features():
    """Inside ``warnings.catch_warnings()``: silence :data:`_SAID_BY_LAG_RIDGE`."""
    for message in _SAID_BY_LAG_RIDGE:
        warnings.filterwarnings("ignore", message=message)


def _flat_results(results, alphas, n_scored):
    """``cv_results_`` with one entry per (candidate, penalty), from the
    candidates' lists and their ``sse`` rows over ``alphas``."""
    n_alphas = alphas.size
    sse = np.asarray(results["sse"], dtype=float).reshape(-1)
    flat = {
        key: [v for v in results[key] for _ in range(n_alphas)]
        for key in ("time_constants", "use_drivers", "relative", "driver_initial")
    }
    flat["alpha"] = np.tile(alphas, len(results["time_constants"]))
    flat["sse"] = sse
    flat["mse"] = sse / n_scored if n_scored else np.full(sse.size, np.nan)
    # Ties share the best rank, as scikit-learn's search results rank them.
    flat["rank_sse"] = rankdata(sse, method="min").astype(int)
    return flat


class LagRidgeCV(RegressorMixin, BaseEstimator):
    """Standardised ridge regression on :class:`LagFeatures`, tuned by time CV.

    ``fit`` chooses the set of time constants, whether the drivers are used,
    and the ridge penalty by cross-validation that respects time: with one run,
    expanding-window (forward-chaining) folds; with several runs, folds that
    leave whole runs out. Total squared validation error decides. Features are
    causal and restart at every run, so they are computed once over the
    training data and sliced per fold (exact for these folds). The chosen
    model is then refitted on all the training rows.

    In ``predict`` a run label seen in ``fit`` continues that run (see
    :class:`LagFeatures`): the later rows of a training run, given alone,
    are predicted as they would be inside the whole run.

    Parameters
    ----------
    time_constant_sets : sequence of sequences of float, default=None
        Candidate sets of filter time constants (seconds; in a set finite,
        > 0 and distinct). ``None`` means ``((), (900, 3600, 14400), (600,
        1800, 5400, 16200))``.
    drivers : "auto", None or sequence of str or int, default="auto"
        Driver columns, see :class:`LagFeatures`.
    try_without_drivers : bool, default=True
        Also try every candidate without the drivers (their columns left
        out).
    relative : bool or "auto", default="auto"
        Temperatures as changes since each run's start (True) or as read
        (False). ``"auto"``: with several runs, chosen by the CV; with one
        run, changes (both fit a single run alike, as they differ by a
        constant; changes keep a new run that starts warmer or colder from
        an offset), unless its ``time_s`` starts after 0: a part cut from a
        longer record starts at no particular state, so its readings are
        taken as they are.
    driver_initial : {"auto", "steady", "rest"}, default="auto"
        State of the drivers' filters before each run, see
        :class:`LagFeatures`. ``"auto"``: chosen by the CV when a training
        run starts with a driver on (its filters as driven for ever before,
        or from rest: runs logged from a cold start with the spindle
        turning are the one, runs cut from a longer duty the other; on
        independent records with such runs "steady" alone left held-out
        errors 1.5 and 2.2 times linear regression's where the CV's choice
        gave 0.19 and 1.26), else ``"steady"`` (both are then the same).
    alphas : array-like of float, default=None
        Candidate ridge penalties, finite and > 0; ``None`` means
        ``np.logspace(-2, 5, 15)``.
    cv : {"auto", "forward", "blocks", "runs"}, default="auto"
        Folds: expanding-window (``"forward"``), contiguous blocks left out
        (``"blocks"``) or whole runs left out (``"runs"``; the runs are
        dealt into the folds in the order of their labels, so the chosen
        model does not depend on the order of the runs in the table).
        ``"auto"``: ``"runs"`` with several runs, else ``"forward"``
        (as ``"runs"`` on one run, with a warning). A fold that leaves
        runs out and keeps fewer than ``first_fraction`` of the rows for
        training (short runs alone) is skipped.
    selection : {"min", "1se"}, default="min"
        The least total validation error, or the one-standard-error rule
        (the largest penalty, then the fewest features, within one standard
        error of the least).
    n_splits : int, default=4
        Number of folds.
    first_fraction : float, default=0.4
        Forward folds: the first cut, as a fraction of the training rows.
    dt : float or None, default=None
        Seconds per row when ``X`` has no times (no ``time_s`` column or
        index level). None: one second per row, with a warning, since the
        time constants are in seconds.
    verbose : int, default=0
        1 prints a line per candidate setting (its validation error and the
        seconds so far) and one for the refit: a fit on a long campaign
        logged every second takes minutes.

    Attributes
    ----------
    time_constants_ : tuple of float
        Chosen time constants.
    use_drivers_ : bool
        Whether the chosen model uses the drivers' filters. Without them the
        driver columns are left out (never taken as temperatures); with
        them but no time constants, the drivers enter unfiltered (their
        powers, as :class:`LagFeatures` makes them).
    alpha_ : float
        Chosen ridge penalty.
    cv_results_ : dict of lists and ndarrays
        One entry per setting tried (every candidate with every penalty, the
        candidates in order, the penalties of each in the order of
        ``alphas``), so that ``pandas.DataFrame(cv_results_)`` is a table:
        ``"time_constants"`` (tuple), ``"use_drivers"``, ``"relative"``,
        ``"driver_initial"``, ``"alpha"``, ``"sse"`` (total squared
        validation error over the folds), ``"mse"`` (``sse`` over the
        validation rows) and
        ``"rank_sse"`` (1 for the least).
    best_index_ : int
        Row of ``cv_results_`` of the chosen settings (with
        ``selection="1se"`` not always the least ``sse``).
    best_score_ : float
        Mean squared validation error of the chosen settings.
    lag_features_ : LagFeatures
        The fitted features, drivers included; the model reads the first
        ``n_lag_features_`` of them.
    n_lag_features_ : int
        Number of features the ridge reads.
    scaler_ : StandardScaler
    ridge_ : Ridge
    relative_ : bool
        Whether the chosen features are changes since each run's start.
    driver_initial_ : {"steady", "rest"}
        The chosen state of the drivers' filters before each run.
    n_fitted_runs_ : int or None
        Labelled runs seen in ``fit`` (None when ``fit`` got no run labels);
        ``predict`` then warns when given rows without run labels.
    n_features_in_ : int

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.preprocessing import LagRidgeCV
    >>> t = np.arange(400) * 60.0
    >>> T = 20 + 5 * (1 - np.exp(-t / 3600))
    >>> y = 10 * (1 - np.exp(-t / 7200))
    >>> run = np.zeros(400)  # the rows are one run
    >>> model = LagRidgeCV(dt=60.0).fit(T[:, None], y, groups=run)
    >>> model.predict(T[:, None], groups=run).shape
    (400,)
    """

    _parameter_constraints = {
        "time_constant_sets": [None, list, tuple],
        "drivers": [StrOptions({"auto"}), None, "array-like"],
        "try_without_drivers": ["boolean"],
        "relative": ["boolean", StrOptions({"auto"})],
        "driver_initial": [StrOptions({"auto", "steady", "rest"})],
        "alphas": [None, "array-like"],
        "cv": [StrOptions({"auto", "forward", "blocks", "runs"})],
        "selection": [StrOptions({"min", "1se"})],
        "n_splits": [Interval(Integral, 2, None, closed="left")],
        "first_fraction": [Interval(Real, 0, 1, closed="neither")],
        "dt": [None, Interval(Real, 0, None, closed="neither")],
        "verbose": ["verbose"],
    }

    def __init__(
        self,
        time_constant_sets=None,
        *,
        drivers="auto",
        try_without_drivers=True,
        relative="auto",
        driver_initial="auto",
        alphas=None,
        cv="auto",
        selection="min",
        n_splits=4,
        first_fraction=0.4,
        dt=None,
        verbose=0,
    ):
        self.cv = cv
        self.selection = selection
        self.time_constant_sets = time_constant_sets
        self.drivers = drivers
        self.try_without_drivers = try_without_drivers
        self.relative = relative
        self.driver_initial = driver_initial
        self.alphas = alphas
        self.n_splits = n_splits
        self.first_fraction = first_fraction
        self.dt = dt
        self.verbose = verbose

    def _features(self, taus, relative, dt=None, initial="steady"):
        # Arrays inside, whatever scikit-learn's global transform_output.
        return LagFeatures(
            time_constants=tuple(taus),
            relative=relative,
            drivers=self.drivers,
            driver_initial=initial,
            dt=dt,
        ).set_output(transform="default")

    def _select(self, fold_sse, folds, n_feat, alphas):
        """Candidate and alpha chosen from the per-fold errors.

        ``fold_sse`` has shape (n_candidates, n_folds, n_alphas). ``"min"``:
        least total error. ``"1se"``: the one-standard-error rule (Hastie,
        Tibshirani and Friedman, The Elements of Statistical Learning, 7.10):
        among settings whose mean fold error is within one standard error of
        the least, the largest penalty, then the fewest features.
        """
        total = fold_sse.sum(axis=1)
        c, j = np.unravel_index(int(np.argmin(total)), total.shape)
        k = fold_sse.shape[1]
        if self.selection == "min" or k < 2:
            return int(c), int(j)
        sizes = np.array([va.size for _, va in folds], dtype=float)
        mse = fold_sse / sizes[None, :, None]
        mean = mse.mean(axis=1)
        se = mse[c, :, j].std(ddof=1) / np.sqrt(k)
        ok = np.argwhere(mean <= mean[c, j] + se)
        # The largest alpha, then the fewest features.
        order = np.lexsort((n_feat[ok[:, 0]], -alphas[ok[:, 1]]))
        c, j = ok[order[0]]
        return int(c), int(j)

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, *, groups=None):
        """Choose the settings by time-ordered CV, then refit on all rows.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
        y : array-like of shape (n_samples,)
        groups : array-like of shape (n_samples,), optional
            Run label of every row (else a ``run`` column or index level).

        Returns
        -------
        self : LagRidgeCV
        """
        sets, alphas = self._check_grids()
        X_raw, groups = extract_runs(X, groups, y=y)
        check_one_target(type(self).__name__, y, "make_lag_pipeline()")
        X_arr, y = validate_data(self, X_raw, y, dtype=np.float64, y_numeric=True)
        name = type(self).__name__
        warn_unlabelled_runs(name, None, groups, len(y), X=X_raw, stacklevel=None)
        names = getattr(self, "feature_names_in_", None)
        warn_unnamed_drivers(name, self.drivers, names, groups)
        drivers = driver_positions(self.drivers, names, X_arr.shape[1])
        warn_centred_drivers(name, X_arr, drivers, names)
        # Without times, warn once here (not once per candidate), then give
        # the candidates one second per row explicitly.
        warn_no_time(
            type(self).__name__,
            X_raw,
            self.dt,
            sorted({float(t) for taus in sets for t in taus}),
        )
        # The candidates read the times themselves (and keep their sampling
        # period for predict); without times, one second per row.
        dt = self.dt
        if dt is None and not has_time_index(X_raw):
            dt = 1.0
        y = np.asarray(y, dtype=float)
        n = y.shape[0]
        slices, labels = run_slices(groups, n)
        self.n_fitted_runs_ = None if groups is None else len(slices)
        check_time_order(X_raw, groups)
        if self.dt is not None:
            warn_dt_against_times(
                name, X_raw, slices, labels, float(self.dt), overrides=False
            )
        warn_time_unit(X_raw, groups)
        # Once here, not once per candidate (silenced below); without any
        # filter (the tuned static ridge) a gap changes nothing.
        if any(sets):
            warn_gaps(type(self).__name__, X_raw, slices, labels, GAP_BRIDGE)
        # Both initial states of the drivers' filters only where a run starts
        # driven (elsewhere they are the same).
        initials = (self.driver_initial,)
        if self.driver_initial == "auto":
            driven = runs_start_driven(X_arr, slices, drivers)
            initials = ("steady", "rest") if driven else ("steady",)
        # One BLAS thread: the CV is a loop of small ridge solves, which on
        # cores shared with other jobs ran 20-50 times slower with BLAS
        # threads waiting for each other (0.5 s against 8-19 s on
        # FL_THERMAL's 6,669 training rows).
        with warnings.catch_warnings(), single_threaded_blas():
            _quiet_inner_lag_features()
            return self._fit(
                X_raw, y, groups, slices, labels, sets, alphas, dt, initials
            )

    def _check_grids(self):
        """The candidate time-constant sets (tuples of float) and penalties
        (an array), checked: every entry a finite number > 0."""
        name = type(self).__name__
        sets = (
            DEFAULT_TIME_CONSTANT_SETS
            if self.time_constant_sets is None
            else self.time_constant_sets
        )
        flat = [s for s in sets if isinstance(s, Real) or isinstance(s, str)]
        if flat:
            raise ValueError(
                "time_constant_sets is a list of candidate sets, each a sequence "
                f"of time constants (s), got {self.time_constant_sets!r}; for one "
                f"set write [{tuple(sets)!r}], for one candidate each "
                f"{[(s,) for s in sets]!r}."
            )
        if len(sets) == 0:
            raise ValueError(
                f"The 'time_constant_sets' parameter of {name} must hold at "
                "least one candidate set (() for none of the filters). Got "
                f"{self.time_constant_sets!r} instead."
            )
        sets = [
            tuple(
                check_positive_numbers(
                    taus,
                    f"time_constant_sets[{i}]",
                    name,
                    distinct=True,
                    why="time constants in seconds, each a filter of its own",
                ).tolist()
            )
            for i, taus in enumerate(sets)
        ]
        alphas = (
            np.logspace(-2, 5, 15)
            if self.alphas is None
            else check_positive_numbers(
                self.alphas, "alphas", name, empty=False, why="ridge penalties"
            )
        )
        return sets, alphas

    def _fit(self, X_raw, y, groups, slices, labels, sets, alphas, dt, initials):
        """The CV over the candidate settings and the refit of ``fit``."""
        n = y.shape[0]
        folds = run_folds(
            self.cv,
            slices,
            labels,
            n,
            self.n_splits,
            self.first_fraction,
            type(self).__name__,
        )
        if not folds:
            warnings.warn(
                f"{type(self).__name__}: {n} training row(s) leave no "
                "cross-validation fold, so nothing is chosen by validation: the "
                "first candidate and penalty are taken. Give more rows.",
                UserWarning,
                stacklevel=3,
            )
        if self.relative == "auto":
            # Within one run both give the same fit (they differ by a
            # constant); only between runs can the data tell them apart.
            # With one run, changes: a new run starting warmer or colder is
            # then not predicted with an offset. But a run whose rows start
            # after its time_s = 0 (cut from a longer record) starts at no
            # particular state: its changes mean nothing elsewhere, and the
            # readings as they are carry over.
            times = run_times(X_raw, slices)
            cut = times is not None and float(times[0, 0]) > 0
            relatives = (True, False) if len(slices) > 1 else ((not cut),)
        else:
            relatives = (bool(self.relative),)
        cands = []
        for taus in sets:
            for rel in relatives:
                cands += [(taus, True, rel, initial) for initial in initials]
                if self.try_without_drivers and self.drivers is not None:
                    cands.append((taus, False, rel, initials[0]))
        results = {
            "time_constants": [],
            "use_drivers": [],
            "relative": [],
            "driver_initial": [],
            "sse": [],
        }
        fold_sse, n_feat, kept = [], [], []
        clock = time.perf_counter()
        for k, (taus, use, rel, initial) in enumerate(cands, 1):
            # The previous candidate's features go before these are made.
            F = None
            try:
                lf = self._features(taus, rel, dt, initial)
                F = np.asarray(lf.fit_transform(X_raw, groups=groups))
            except ValueError as exc:
                # A candidate without features (no filters, every column a
                # driver) is skipped; anything else is the input's fault.
                if "would produce no features" not in str(exc):
                    raise
                continue
            # A candidate without the drivers keeps the temperatures'
            # features only (the driver columns left out, not temperatures).
            n_temp = lf.n_temperature_features_
            if (
                use
                and F.shape[1] == n_temp
                and (taus, False, rel, initials[0]) in cands
            ):
                continue  # no driver features: the same model as without
            if not use:
                if n_temp == 0:
                    continue  # every column a driver: nothing left
                F = F[:, :n_temp]
            per = (
                _ridge_path_sse(F, y, folds, alphas, per_fold=True)
                if folds
                else np.zeros((1, alphas.size))
            )
            results["time_constants"].append(taus)
            results["use_drivers"].append(F.shape[1] > n_temp)
            results["relative"].append(rel)
            results["driver_initial"].append(initial)
            results["sse"].append(per.sum(0))
            fold_sse.append(per)
            n_feat.append(F.shape[1])
            kept.append((taus, use, rel, initial))
            if self.verbose:
                best = per.sum(0).min() / max(sum(va.size for _, va in folds), 1)
                print(
                    f"[{type(self).__name__}] candidate {k}/{len(cands)}: time "
                    f"constants {tuple(float(t) for t in taus)} s, drivers "
                    f"{'yes' if F.shape[1] > n_temp else 'no'}, "
                    f"{'changes' if rel else 'readings'}: validation MSE "
                    f"{best:.4g} ({time.perf_counter() - clock:.1f} s)",
                    flush=True,
                )
        F = None
        if not kept:
            raise ValueError("No candidate setting produced any feature.")
        c, j = self._select(np.asarray(fold_sse), folds, np.asarray(n_feat), alphas)
        n_scored = sum(va.size for _, va in folds)
        self.cv_results_ = _flat_results(results, alphas, n_scored)
        self.best_index_ = int(c * alphas.size + j)
        score = self.cv_results_["sse"][self.best_index_]
        self.best_score_ = float(score / n_scored) if n_scored else float("nan")
        (taus, use, rel, initial), self.alpha_ = kept[c], float(alphas[j])
        self.time_constants_ = taus
        self.relative_ = rel
        self.driver_initial_ = initial
        self.lag_features_ = self._features(taus, rel, dt, initial)
        self.lag_features_.fit(X_raw, groups=groups)
        if not taus:
            self._warn_slow_candidates(sets, slices, run_times(X_raw, slices))
        F = np.asarray(self.lag_features_.transform(X_raw, groups=groups))
        n_temp = self.lag_features_.n_temperature_features_
        self.n_lag_features_ = F.shape[1] if use else n_temp
        self.use_drivers_ = self.n_lag_features_ > n_temp
        F = F[:, : self.n_lag_features_]
        self.scaler_ = StandardScaler().set_output(transform="default").fit(F)
        F = self.scaler_.transform(F)  # the unscaled features go
        self.ridge_ = Ridge(alpha=self.alpha_).fit(F, y)
        if self.verbose:
            print(
                f"[{type(self).__name__}] refit on {n} rows: time constants "
                f"{tuple(float(t) for t in taus)} s, alpha {self.alpha_:g} "
                f"({time.perf_counter() - clock:.1f} s)",
                flush=True,
            )
        return self

    def _warn_slow_candidates(self, sets, slices, times):
        """Warn when the CV chose no time constant and every candidate's is
        slow for the training runs (the longest shorter than ten times the
        shortest candidate time constant; ``times``: the runs' first and
        last ``time_s``, or None): the model is then the static one by
        default, not because the process has no lag."""
        shortest = min((min(taus) for taus in sets if taus), default=None)
        period = getattr(self.lag_features_, "sample_period_s_", np.nan)
        if shortest is None or not np.isfinite(period):
            return
        if times is not None:
            longest = float(np.max(times[:, 1] - times[:, 0]))
        else:
            longest = max(sl.stop - sl.start - 1 for sl in slices) * period
        if longest >= 10 * shortest:
            return
        taus = sorted({t for ts in sets for t in ts})
        warnings.warn(
            f"{type(self).__name__} chose no time constant (a static model "
            f"of the readings): the candidates ({taus[0]:g}-{taus[-1]:g} s) "
            f"are slow for training runs of at most {longest:g} s (sampled "
            f"every {period:g} s). Give time_constant_sets on the process's "
            "own time scale (e.g. a few sampling periods to a fraction of a "
            "run).",
            UserWarning,
            stacklevel=user_stacklevel(),
        )

    def predict(self, X, *, groups=None):
        """Predict, restarting the lag features at every run.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
        groups : array-like of shape (n_samples,), optional

        Returns
        -------
        y_pred : ndarray of shape (n_samples,)
        """
        check_is_fitted(self, "ridge_")
        X_raw, groups = extract_runs(X, groups)
        X_arr = validate_data(self, X_raw, dtype=np.float64, reset=False)
        warn_unlabelled_runs(
            type(self).__name__, self.n_fitted_runs_, groups, X_arr.shape[0]
        )
        slices, labels = run_slices(groups, X_arr.shape[0])
        check_time_order(X_raw, groups)
        # The runs that continue training runs, as lag_features_ takes them:
        # the errors and warnings then name the estimator the user called.
        memory = self.lag_features_.run_states_
        cont = continued_runs(
            type(self).__name__,
            X_arr,
            slices,
            labels,
            run_times(X_raw, slices),
            memory,
        )
        warn_pauses(type(self).__name__, X_raw, slices, cont, memory, PAUSE_BRIDGE, 3)
        with warnings.catch_warnings():
            # LagFeatures names itself; the user called LagRidgeCV, and was
            # just warned about rows without run labels, a late start or a
            # pause.
            _quiet_inner_lag_features()
            warnings.filterwarnings("ignore", message=r"LagFeatures: run .* continues")
            warnings.filterwarnings("ignore", message=r"LagFeatures was fitted on")
            warnings.filterwarnings("ignore", message=LATE_START_WARNING)
            warnings.filterwarnings("ignore", message=REUSED_LABEL_WARNING)
            warnings.filterwarnings("ignore", message=EARLIER_PART_WARNING)
            F = np.asarray(self.lag_features_.transform(X_raw, groups=groups))
        if self.time_constants_:
            warn_gaps(type(self).__name__, X_raw, slices, labels, GAP_BRIDGE, 3)
        F = F[:, : self.n_lag_features_]
        return self.ridge_.predict(self.scaler_.transform(F))

    def remember_runs(self, X, *, groups=None):
        """Remember where the runs of ``X`` end, so the next call continues them.

        For prediction on a stream: after :meth:`predict` of a block of rows,
        call this with the same rows; the next block of a run (its label,
        later ``time_s``) is then predicted as the whole run given at once
        would be, at a cost that does not grow with the run's length. See
        :meth:`LagFeatures.remember_runs` and
        :class:`skthermal.compose.RunStream`, which does both calls.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
        groups : array-like of shape (n_samples,), optional

        Returns
        -------
        self : LagRidgeCV
        """
        check_is_fitted(self, "ridge_")
        self.lag_features_.remember_runs(X, groups=groups)
        return self

    def forget_runs(self, labels):
        """Forget the runs of ``labels`` (see
        :meth:`LagFeatures.forget_runs`). Returns self."""
        check_is_fitted(self, "ridge_")
        self.lag_features_.forget_runs(labels)
        return self


def make_lag_pipeline(
    time_constant_sets=None,
    *,
    drivers="auto",
    alphas=None,
    n_splits=4,
    dt=None,
    relative="auto",
    driver_initial="auto",
    verbose=0,
):
    """The recommended dynamic compensation model, unfitted.

    Lag features (temperature changes since the run start, their exponential
    filters, the filtered spindle speed) followed by standardised ridge
    regression, with time constants, drivers and penalty chosen by
    time-ordered CV in ``fit`` (see :class:`LagRidgeCV`).

    Parameters
    ----------
    time_constant_sets, drivers, alphas, n_splits, dt, relative, driver_initial, \
verbose
        See :class:`LagRidgeCV`.

    Returns
    -------
    LagRidgeCV

    Examples
    --------
    >>> from skthermal.preprocessing import make_lag_pipeline
    >>> make_lag_pipeline().n_splits
    4
    """
    return LagRidgeCV(
        time_constant_sets=time_constant_sets,
        drivers=drivers,
        alphas=alphas,
        n_splits=n_splits,
        dt=dt,
        relative=relative,
        driver_initial=driver_initial,
        verbose=verbose,
    )
