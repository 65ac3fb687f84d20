"""Ridge on lag features, with settings chosen by time-ordered CV."""

from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.linear_model import Ridge
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted, validate_data

from ..utils._runs import extract_runs, run_slices
from ._lags import LagFeatures

DEFAULT_TIME_CONSTANT_SETS = (
    (),
    (900.0, 3600.0, 14400.0),
    (600.0, 1800.0, 5400.0, 16200.0),
)


def _forward_folds(n, n_splits, first_fraction):
    """Expanding-window folds: train on rows before a cut, score the next block."""
    edges = np.linspace(int(first_fraction * n), n, n_splits + 1).astype(int)
    return [
        (np.arange(0, edges[i]), np.arange(edges[i], edges[i + 1]))
        for i in range(n_splits)
        if edges[i] > 1 and edges[i + 1] > edges[i]
    ]


def _group_folds(slices, n_splits):
    """Leave-runs-out folds (runs dealt round-robin into n_splits groups)."""
    k = min(n_splits, len(slices))
    parts = [[] for _ in range(k)]
    for r, sl in enumerate(slices):
        parts[r % k].append(np.arange(sl.start, sl.stop))
    n = slices[-1].stop
    folds = []
    for p in parts:
        va = np.concatenate(p)
        mask = np.ones(n, bool)
        mask[va] = False
        folds.append((np.flatnonzero(mask), va))
    return folds


def _ridge_path_sse(F, y, folds, alphas):
    """Total squared validation error for every alpha (one SVD per fold)."""
    sse = np.zeros(alphas.size)
    for tr, va in folds:
        A, B = F[tr], F[va]
        mu, sd = A.mean(0), A.std(0)
        sd[sd == 0] = 1.0
        A = (A - mu) / sd
        B = (B - mu) / sd
        ym = y[tr].mean()
        U, s, Vt = np.linalg.svd(A, full_matrices=False)
        uty = U.T @ (y[tr] - ym)
        d = s / (s**2 + alphas[:, None])  # (n_alpha, r)
        pred = (B @ Vt.T) @ (d * uty).T + ym  # (n_val, n_alpha)
        sse += ((pred - y[va][:, None]) ** 2).sum(0)
    return sse


class LagRidgeCV(RegressorMixin, BaseEstimator):
    """Standardised ridge regression on :class:`LagFeatures`, tuned by time CV.

    ``fit`` chooses the set of time constants, whether the drivers are used,
    and the ridge penalty by cross-validation that respects time: with one run,
    expanding-window (forward-chaining) folds; with several runs, folds that
    leave whole runs out. Total squared validation error decides. Features are
    causal and restart at every run, so they are computed once over the
    training data and sliced per fold (exact for these folds). The chosen
    model is then refitted on all the training rows.

    Parameters
    ----------
    time_constant_sets : sequence of sequences of float, default=None
        Candidate sets of filter time constants (seconds). ``None`` means
        ``((), (900, 3600, 14400), (600, 1800, 5400, 16200))``.
    drivers : "auto", None or sequence of str or int, default="auto"
        Driver columns, see :class:`LagFeatures`.
    try_without_drivers : bool, default=True
        Also try every candidate without the drivers.
    alphas : array-like of float, default=None
        Candidate ridge penalties; ``None`` means ``np.logspace(-2, 5, 15)``.
    n_splits : int, default=4
        Number of folds.
    first_fraction : float, default=0.4
        Forward folds: the first cut, as a fraction of the training rows.
    dt : float, default=1.0
        Seconds per row when there is no ``time_s`` index level.

    Attributes
    ----------
    time_constants_ : tuple of float
        Chosen time constants.
    use_drivers_ : bool
        Whether the chosen model uses the drivers.
    alpha_ : float
        Chosen ridge penalty.
    cv_results_ : dict
        ``"time_constants"``, ``"use_drivers"`` (one per candidate) and
        ``"sse"`` of shape (n_candidates, n_alphas).
    best_score_ : float
        Mean squared validation error of the chosen settings.
    lag_features_ : LagFeatures
    scaler_ : StandardScaler
    ridge_ : Ridge
    n_features_in_ : int

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.preprocessing import LagRidgeCV
    >>> t = np.arange(400) * 60.0
    >>> T = 20 + 5 * (1 - np.exp(-t / 3600))
    >>> y = 10 * (1 - np.exp(-t / 7200))
    >>> model = LagRidgeCV(dt=60.0).fit(T[:, None], y)
    >>> model.predict(T[:, None]).shape
    (400,)
    """

    _parameter_constraints = {
        "time_constant_sets": [None, list, tuple],
        "drivers": [StrOptions({"auto"}), None, "array-like"],
        "try_without_drivers": ["boolean"],
        "alphas": [None, "array-like"],
        "n_splits": [Interval(Integral, 2, None, closed="left")],
        "first_fraction": [Interval(Real, 0, 1, closed="neither")],
        "dt": [Interval(Real, 0, None, closed="neither")],
    }

    def __init__(
        self,
        time_constant_sets=None,
        *,
        drivers="auto",
        try_without_drivers=True,
        alphas=None,
        n_splits=4,
        first_fraction=0.4,
        dt=1.0,
    ):
        self.time_constant_sets = time_constant_sets
        self.drivers = drivers
        self.try_without_drivers = try_without_drivers
        self.alphas = alphas
        self.n_splits = n_splits
        self.first_fraction = first_fraction
        self.dt = dt

    def _features(self, taus, use_drivers):
        return LagFeatures(
            time_constants=tuple(taus),
            drivers=self.drivers if use_drivers else None,
            dt=self.dt,
        )

    def fit(self, X, y, groups=None):
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
        self._validate_params()
        X_raw, groups = extract_runs(X, groups)
        _, y = validate_data(self, X_raw, y, dtype=np.float64, y_numeric=True)
        y = np.asarray(y, dtype=float)
        n = y.shape[0]
        slices, _ = run_slices(groups, n)
        sets = (
            DEFAULT_TIME_CONSTANT_SETS
            if self.time_constant_sets is None
            else self.time_constant_sets
        )
        alphas = (
            np.logspace(-2, 5, 15)
            if self.alphas is None
            else np.asarray(self.alphas, dtype=float).ravel()
        )
        if len(sets) == 0 or alphas.size == 0 or np.any(alphas <= 0):
            raise ValueError(
                "time_constant_sets and alphas must be non-empty, alphas > 0."
            )
        if len(slices) > 1:
            folds = _group_folds(slices, self.n_splits)
        else:
            folds = _forward_folds(n, self.n_splits, self.first_fraction)
        cands = []
        for taus in sets:
            cands.append((tuple(float(t) for t in taus), True))
            if self.try_without_drivers and self.drivers is not None:
                cands.append((tuple(float(t) for t in taus), False))
        results = {"time_constants": [], "use_drivers": [], "sse": []}
        best = (np.inf, None, None)
        for taus, use in cands:
            try:
                lf = self._features(taus, use).fit(X_raw, groups=groups)
            except ValueError:
                continue  # e.g. no features (no changes, no filters)
            if use and self.drivers is not None and lf.driver_indices_.size == 0:
                if (taus, False) in cands:
                    continue  # same model as without drivers
            F = lf.transform(X_raw, groups=groups)
            sse = (
                _ridge_path_sse(F, y, folds, alphas) if folds else np.zeros(alphas.size)
            )
            results["time_constants"].append(taus)
            results["use_drivers"].append(use and lf.driver_indices_.size > 0)
            results["sse"].append(sse)
            j = int(np.argmin(sse))
            if sse[j] < best[0]:
                best = (sse[j], (taus, use), alphas[j])
        if best[1] is None:
            raise ValueError("No candidate setting produced any feature.")
        results["sse"] = np.asarray(results["sse"])
        self.cv_results_ = results
        n_scored = sum(va.size for _, va in folds)
        self.best_score_ = float(best[0] / n_scored) if n_scored else float("nan")
        (taus, use), self.alpha_ = best[1], float(best[2])
        self.time_constants_ = taus
        self.lag_features_ = self._features(taus, use).fit(X_raw, groups=groups)
        self.use_drivers_ = bool(self.lag_features_.driver_indices_.size)
        F = self.lag_features_.transform(X_raw, groups=groups)
        self.scaler_ = StandardScaler().fit(F)
        self.ridge_ = Ridge(alpha=self.alpha_).fit(self.scaler_.transform(F), y)
        return self

    def predict(self, X, groups=None):
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
        validate_data(self, X_raw, dtype=np.float64, reset=False)
        F = self.lag_features_.transform(X_raw, groups=groups)
        return self.ridge_.predict(self.scaler_.transform(F))


def make_lag_pipeline(
    time_constant_sets=None, *, drivers="auto", alphas=None, n_splits=4, dt=1.0
):
    """The recommended dynamic compensation model, unfitted.

    Lag features (temperature changes since the run start, their exponential
    filters, the filtered spindle speed) followed by standardised ridge
    regression, with time constants, drivers and penalty chosen by
    time-ordered CV in ``fit`` (see :class:`LagRidgeCV`).

    Parameters
    ----------
    time_constant_sets, drivers, alphas, n_splits, dt
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
    )
