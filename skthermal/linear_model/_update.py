"""Ridge and update regression of thermal errors (METHODS §11, 004 §2.2, §3.2).

A thermal-error model ``E = beta_0 + beta_1 T_1 + ... + beta_S T_S`` is fitted
by ridge regression, ``beta = (A^T A + p I)^-1 A^T E`` with ``A = [1, T]``.
When the machining state changes and the model drifts, *update regression*
merges the old coefficients with a handful of new samples,
``beta = (eta A^T A + (1 - eta) I)^-1 (eta A^T E + (1 - eta) beta_old)``, the
minimiser of ``eta ||E - A beta||^2 + (1 - eta) ||beta - beta_old||^2``.
With ``beta_old = 0`` it is ridge regression again. The update is taken as
stable once the coefficients from N, N + 1 and N + 2 new samples agree within
10 %.

The array functions work on ``(n_samples, n_features)`` inputs and
``(n_samples, n_targets)`` targets and return coefficient arrays whose first
row is the intercept; :class:`UpdateRegressor` wraps them.
"""

import warnings
from numbers import Real

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, _fit_context
from sklearn.utils import check_X_y
from sklearn.utils._param_validation import Interval, validate_params
from sklearn.utils.validation import _num_samples, check_is_fitted, validate_data

from skthermal.utils._runs import extract_runs, run_slices, target_names
from skthermal.utils._warnings import user_stacklevel


def _design(X):
    """``A = [1, T_1 .. T_S]``."""
    return np.hstack([np.ones((X.shape[0], 1)), X])


def _penalty(n_coef, scale, penalize_intercept):
    d = np.full(n_coef, float(scale))
    if not penalize_intercept:
        d[0] = 0.0
    return d


def _solve(M, rhs):
    # lstsq (SVD) rather than solve: with eta = 1, alpha = 0 or an unpenalised
    # intercept, M can be singular when there are fewer samples than
    # coefficients; lstsq then gives the minimum-norm coefficients.
    return np.linalg.lstsq(M, rhs, rcond=None)[0]


def _as_2d_target(y):
    y = np.asarray(y, dtype=float)
    return y[:, None] if y.ndim == 1 else y


def _samples(X, y):
    """``X`` (2-D) and ``y`` (2-D), checked as scikit-learn checks them: one
    target row per sample, finite numbers."""
    X, y = check_X_y(X, y, multi_output=True, y_numeric=True, dtype=float)
    return X, _as_2d_target(y)


# The parameters of update_coef and update_path.
_UPDATE_PARAMS = {
    "X": ["array-like"],
    "y": ["array-like"],
    "coef_old": ["array-like"],
    "eta": [Interval(Real, 0, 1, closed="right")],
    "penalize_intercept": ["boolean"],
}
_TOLERANCE = [Interval(Real, 0, None, closed="left")]


@validate_params(
    {
        "X": ["array-like"],
        "y": ["array-like"],
        "alpha": [Interval(Real, 0, None, closed="left")],
        "penalize_intercept": ["boolean"],
    },
    prefer_skip_nested_validation=True,
)
def ridge_coef(X, y, *, alpha=25.0, penalize_intercept=True):
    """Ridge coefficients ``(A^T A + p I)^-1 A^T E`` with ``A = [1, X]``.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
        Temperatures (the temperature-sensitive points): changes since the
        run start in °C, for which 004's ``alpha`` is set (the penalty is
        absolute: in millidegrees it regularises a million times less, and
        a penalised intercept on absolute readings bends the slopes; see
        *Units* in :class:`UpdateRegressor`, which warns of both).
    y : ndarray of shape (n_samples,) or (n_samples, n_targets)
        Thermal error(s).
    alpha : float, default=25.0
        Ridge parameter ``p``; 0 is ordinary multiple regression.
    penalize_intercept : bool, default=True
        Penalise ``beta_0`` like the slopes, as the identity matrix of 004
        eq. 4 does. ``False`` leaves the intercept free (the usual ridge of
        centred data).

    Returns
    -------
    coef : ndarray of shape (n_features + 1,) or (n_features + 1, n_targets)
        ``beta_0`` (intercept) first.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.linear_model import ridge_coef
    >>> X = np.array([[0.0], [1.0], [2.0]])
    >>> ridge_coef(X, 1 + 2 * X[:, 0], alpha=0.0).round(6).tolist()
    [1.0, 2.0]
    >>> ridge_coef(X, 1 + 2 * X[:, 0], alpha=25.0).round(3).tolist()
    [0.278, 0.406]
    """
    X, E = _samples(X, y)
    A = _design(X)
    P = np.diag(_penalty(A.shape[1], alpha, penalize_intercept))
    coef = _solve(A.T @ A + P, A.T @ E)
    return coef[:, 0] if np.ndim(y) == 1 else coef


def _old_coefficients(coef_old, X, E):
    """``coef_old`` as a ``(n_features + 1, n_targets)`` array, checked."""
    old = np.asarray(coef_old, dtype=float)
    p, n_targets = X.shape[1] + 1, E.shape[1]
    want = (p,) if n_targets == 1 else (p, n_targets)
    if old.shape not in {want, (p, n_targets)}:
        raise ValueError(
            f"coef_old must have shape {want}: the intercept first, then one "
            f"weight per input ({X.shape[1]} inputs)"
            + ("" if n_targets == 1 else f", one column per target ({n_targets})")
            + f"; got shape {old.shape}."
        )
    if not np.all(np.isfinite(old)):
        raise ValueError("coef_old contains NaN or infinite values.")
    return old.reshape(p, n_targets)


@validate_params(_UPDATE_PARAMS, prefer_skip_nested_validation=True)
def update_coef(X, y, coef_old, *, eta=0.1, penalize_intercept=True):
    """Update-regression coefficients from an old model and new samples.

    ``beta = (eta A^T A + (1 - eta) I)^-1 (eta A^T E + (1 - eta) beta_old)``
    (004 eq. 14-15), ``A = [1, X]`` of the new samples.

    Parameters
    ----------
    X : ndarray of shape (n_new, n_features)
        New temperature samples, in the units of the old model's (changes
        since the run start in °C for 004's ``eta``; see *Units* in
        :class:`UpdateRegressor`).
    y : ndarray of shape (n_new,) or (n_new, n_targets)
        New thermal-error samples.
    coef_old : ndarray of shape (n_features + 1,) or (n_features + 1, n_targets)
        Old coefficients, intercept first.
    eta : float in (0, 1], default=0.1
        Weight of the new samples; ``1 - eta`` pulls towards ``coef_old``.
    penalize_intercept : bool, default=True
        Pull the intercept towards the old one too (004). ``False`` lets the
        new samples set it freely.

    Returns
    -------
    coef : ndarray of the shape of ``coef_old``

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.linear_model import update_coef
    >>> X, y = np.array([[1.0], [2.0]]), np.array([3.0, 5.0])
    >>> update_coef(X, y, np.zeros(2), eta=0.5).round(4).tolist()
    [1.0, 1.6667]
    """
    X, E = _samples(X, y)
    old = _old_coefficients(coef_old, X, E)
    A = _design(X)
    d = _penalty(A.shape[1], 1.0 - eta, penalize_intercept)
    coef = _solve(eta * (A.T @ A) + np.diag(d), eta * (A.T @ E) + d[:, None] * old)
    return coef.reshape(np.shape(coef_old))


@validate_params(_UPDATE_PARAMS, prefer_skip_nested_validation=True)
def update_path(X, y, coef_old, *, eta=0.1, penalize_intercept=True):
    """Update-regression coefficients after each of the first 1..n new samples.

    All ``n`` updates are solved at once (cumulative Gram matrices and one
    batched solve), so the stability rule can be checked for every ``N``.

    Parameters
    ----------
    X, y, coef_old, eta, penalize_intercept
        As in :func:`update_coef`.

    Returns
    -------
    path : ndarray of shape (n_new, n_features + 1) or (n_new, n_features + 1,
        n_targets)
        ``path[N - 1]`` is ``update_coef(X[:N], y[:N], coef_old, ...)``.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.linear_model import update_coef, update_path
    >>> rng = np.random.default_rng(0)
    >>> X, y = rng.normal(size=(5, 2)), rng.normal(size=5)
    >>> path = update_path(X, y, np.ones(3))
    >>> bool(np.allclose(path[2], update_coef(X[:3], y[:3], np.ones(3))))
    True
    """
    X, E = _samples(X, y)
    old = _old_coefficients(coef_old, X, E)
    A = _design(X)
    G = np.cumsum(A[:, :, None] * A[:, None, :], axis=0)
    B = np.cumsum(A[:, :, None] * E[:, None, :], axis=0)
    d = _penalty(A.shape[1], 1.0 - eta, penalize_intercept)
    M = eta * G + np.diag(d)
    rhs = eta * B + (d[:, None] * old)[None]
    path = np.linalg.pinv(M) @ rhs
    return path.reshape((X.shape[0], *np.shape(coef_old)))


@validate_params(
    {"coefs": ["array-like"], "rtol": _TOLERANCE, "atol": _TOLERANCE},
    prefer_skip_nested_validation=True,
)
def update_is_stable(coefs, *, rtol=0.1, atol=0.0):
    """The stability rule of update regression (004 §3.2).

    An update is stable when the coefficients obtained with ``N``, ``N + 1``
    and ``N + 2`` new samples differ by less than 10 %. Here: for every
    coefficient, the spread (max - min) over the given coefficient vectors
    is at most ``rtol`` times its largest magnitude, plus ``atol``.

    Parameters
    ----------
    coefs : array-like of shape (n_models, n_coef) or (n_models, ...)
        Coefficient vectors (or arrays) of ``n_models >= 2`` successive
        updates, typically three rows of :func:`update_path`.
    rtol : float, default=0.1
        Relative tolerance (the paper's 10 %).
    atol : float, default=0.0
        Absolute tolerance, for coefficients close to zero (an intercept
        near zero would otherwise never be "stable").

    Returns
    -------
    bool

    Examples
    --------
    >>> from skthermal.linear_model import update_is_stable
    >>> update_is_stable([[1.0, 5.0], [1.05, 5.2], [0.98, 5.1]])
    True
    >>> update_is_stable([[1.0, 5.0], [1.3, 5.2], [0.98, 5.1]])
    False
    """
    c = np.asarray(coefs, dtype=float)
    if c.ndim < 2 or c.shape[0] < 2:
        raise ValueError(
            "coefs must hold at least two coefficient vectors (one per row), got "
            f"shape {c.shape}."
        )
    if not np.all(np.isfinite(c)):
        raise ValueError("coefs contains NaN or infinite values.")
    spread = c.max(axis=0) - c.min(axis=0)
    scale = np.abs(c).max(axis=0)
    return bool(np.all(spread <= rtol * scale + atol))


@validate_params(
    {"path": ["array-like"], "rtol": _TOLERANCE, "atol": _TOLERANCE},
    prefer_skip_nested_validation=True,
)
def first_stable_update(path, *, rtol=0.1, atol=0.0):
    """Smallest ``N`` whose updates with N, N + 1, N + 2 samples agree.

    Parameters
    ----------
    path : ndarray of shape (n_new, ...)
        Output of :func:`update_path`.
    rtol, atol : float
        As in :func:`update_is_stable`.

    Returns
    -------
    n : int or None
        ``N`` (1-based number of new samples), or None when no window of
        three successive updates is stable.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.linear_model import first_stable_update
    >>> path = np.array([[0.0, 1.0], [1.0, 2.0], [1.9, 4.0], [2.0, 4.1],
    ...                  [2.05, 4.2], [2.0, 4.1]])
    >>> first_stable_update(path)
    3
    """
    p = np.asarray(path, dtype=float)
    if p.ndim < 2 or p.shape[0] == 0 or p[0].size == 0:
        raise ValueError(
            "path must hold one coefficient vector per number of new samples "
            f"(the output of update_path), got shape {p.shape}."
        )
    if not np.all(np.isfinite(p)):
        raise ValueError("path contains NaN or infinite values.")
    p = p.reshape(p.shape[0], -1)
    if p.shape[0] < 3:
        return None
    w = np.stack([p[:-2], p[1:-1], p[2:]])
    spread = w.max(axis=0) - w.min(axis=0)
    scale = np.abs(w).max(axis=0)
    ok = np.all(spread <= rtol * scale + atol, axis=1)
    return int(np.argmax(ok)) + 1 if ok.any() else None


# The inputs' root-mean-square magnitude (uncentred, over all entries) for
# which the absolute penalties of the defaults were set: temperature changes
# in °C are ~0.1-20 (the simulated campaign: 2.5-6 per batch; absolute
# readings in °C ~25). Two decades beyond, the penalty is 1e4 times weaker or
# stronger than intended relative to the data term.
_DESIGN_SCALE = (0.01, 100.0)


# Inputs whose mean lies this many standard deviations from zero, in most
# columns, and that seldom come within one standard deviation of zero, are
# readings with an offset (absolute °C), not changes (which are zero at
# every run's start, however far a long batch's mean lies from it).
_OFFSET_SPREADS = 3.0


def _warn_offset_inputs(X, columns=None):
    """Warn when most columns of ``X`` sit far from zero (absolute readings)
    while the intercept is penalised: 004's prior is for changes since the
    run start, zero where the error is; on readings around 20 °C the penalty
    pulls the intercept to zero and bends the slopes to reach the offset (an
    independent check: 5.6 times the held-out error of the same model on
    changes)."""
    if X.shape[0] < 2:
        return
    mean, std = X.mean(axis=0), X.std(axis=0)
    far = np.abs(mean) > _OFFSET_SPREADS * np.maximum(std, 1e-12)
    # Changes since the run start: zero at every run's first row and near it
    # at the next (two rows in a row within a spread of zero), however short
    # the warm-up; a logger's drop-out row of zeros among readings is not.
    near = np.abs(X) <= std
    far &= ~np.any(near[1:] & near[:-1], axis=0)
    # A warm-up of one sample (a fast sensor at a slow logging period, its
    # next row already beyond a spread of zero on a long plateau): a row of
    # zeros in every column followed by one still well short of the column's
    # mean is a run's start too; a drop-out row of zeros is followed by a
    # reading near the mean.
    zeros = np.flatnonzero(np.all(X[:-1] == 0.0, axis=1))
    far &= ~np.any(np.abs(X[zeros + 1]) <= 0.5 * np.abs(mean), axis=0)
    if 2 * far.sum() <= X.shape[1]:
        return
    names = columns if columns is not None else [f"x{j}" for j in range(X.shape[1])]
    j = int(np.flatnonzero(far)[0])
    warnings.warn(
        f"UpdateRegressor: X's columns sit far from zero ({names[j]!r}: mean "
        f"{mean[j]:.3g}, standard deviation {std[j]:.3g}; {far.sum()} of "
        f"{X.shape[1]} columns alike), as absolute readings do, while the "
        "intercept is penalised (penalize_intercept=True, 004's prior for "
        "changes since the run start): the penalty pulls the intercept to zero "
        "and bends the slopes to reach the offset. Give changes since the run "
        "start (skthermal.datasets.changes_since_start), or set "
        "penalize_intercept=False.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def _warn_input_scale(X, name, value, stacklevel, columns=None):
    """Warn when ``X`` is far from the °C magnitudes a default penalty assumes.

    ``name=value`` is the default penalty in use: ``alpha`` of ``fit``, or
    ``eta`` of a ``partial_fit`` from scratch (ridge with ``(1 - eta) / eta``).
    ``columns``: X's column names, to name the columns beyond the range
    (a driver such as ``spindle_rpm`` among temperatures in °C).
    """
    if X.size == 0:
        return
    scale = float(np.sqrt(np.mean(np.square(X))))
    lo, hi = _DESIGN_SCALE
    if not (scale > hi or 0.0 < scale < lo):
        return
    effect = (
        "regularises far less than intended (the model over-fits)"
        if scale > hi
        else "regularises far more than intended (coefficients shrunk to ~0)"
    )
    what = "alpha" if name == "alpha" else "(1 - eta) / eta"
    each = np.sqrt(np.mean(np.square(X), axis=0))
    beyond = (each > hi) if scale > hi else (each < lo)
    where = ""
    if 0 < beyond.sum() < X.shape[1]:
        names = columns if columns is not None else [f"x{j}" for j in range(X.shape[1])]
        listed = ", ".join(
            f"{names[j]!r} ({each[j]:.3g})" for j in np.flatnonzero(beyond)[:5]
        )
        more = f" and {beyond.sum() - 5} more" if beyond.sum() > 5 else ""
        where = f" (from the column(s) {listed}{more})"
    warnings.warn(
        f"UpdateRegressor: X has a root-mean-square of {scale:.3g}{where}, far from "
        f"the temperature changes in °C (about {lo:g} to {hi:g}) for which the "
        f"default {name}={value!r} (004's) was set; as an absolute penalty it "
        f"{effect} here. Give X in °C (e.g. millidegrees / 1000) or "
        f"standardise it, or set {name} for these units: {what} scales with "
        "the square of the unit of X (times 1e6 for millidegrees; exactly so with "
        "penalize_intercept=False). The units of y do not matter.",
        UserWarning,
        stacklevel=stacklevel,
    )


def _features(X, groups=None, y=None):
    """``X`` without the run table's ``run`` and ``time_s`` columns: the
    model is static, but takes a run table as stored (the labels are
    checked, then not used; a given target must be finite)."""
    X, groups = extract_runs(X, groups, y=y)
    if groups is not None:
        run_slices(groups, _num_samples(X))
    return X


class UpdateRegressor(RegressorMixin, BaseEstimator):
    """Ridge thermal-error model that updates itself from a few new samples.

    ``fit`` is ridge regression, ``beta = (A^T A + alpha I)^-1 A^T E`` with
    ``A = [1, T_1 .. T_S]``; ``partial_fit`` is *update regression*: it merges
    the current coefficients with new samples,
    ``beta = (eta A^T A + (1 - eta) I)^-1 (eta A^T E + (1 - eta) beta_old)``,
    so that about six new samples re-tune a model to a changed machining
    state without the over-fitting of a model built from six samples alone
    (Liu et al., 2022).

    Parameters
    ----------
    alpha : float, default=25.0
        Ridge parameter ``p`` of ``fit`` (004 uses 25, suitable between 10
        and 30 for temperatures in °C and errors in µm). 0 gives ordinary
        multiple regression. An absolute penalty, in the units of ``A^T A``
        (the inputs' units squared, summed over samples): the default suits
        inputs that are temperature changes in °C (see Notes, *Units*).
    eta : float in (0, 1], default=0.1
        Weight of the new samples in ``partial_fit``; the old coefficients
        get ``1 - eta``. Small values (004: 0.1) keep the update close to the
        old model. Absolute as ``alpha`` is: the default suits °C.
    penalize_intercept : bool, default=True
        As in 004, the identity matrix covers the intercept too: ``fit``
        shrinks ``beta_0`` towards zero and ``partial_fit`` pulls it towards
        the old one. This suits inputs and errors taken as changes since the
        start of a run (both zero at the start). ``False`` leaves the
        intercept free in both.

    Attributes
    ----------
    coef_ : ndarray of shape (n_features_in_,) or (n_targets, n_features_in_)
        Slopes ``beta_1 .. beta_S``.
    intercept_ : float or ndarray of shape (n_targets,)
        ``beta_0``.
    n_updates_ : int
        Number of ``partial_fit`` calls since the last ``fit``.
    n_features_in_ : int
        Number of temperatures seen in ``fit``.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Their names, when ``X`` was a DataFrame.

    See Also
    --------
    skthermal.linear_model.adaptive_compensation : compensate a stream of
        samples, updating the model when the residual grows.
    skthermal.selection.StableTSPSelector : the temperature-sensitive points.
    sklearn.linear_model.Ridge : ridge with an unpenalised intercept.

    Notes
    -----
    004 eq. 3-4 (ridge) and eq. 13-15 (update regression); METHODS §11.
    ``partial_fit`` on an unfitted model starts from ``beta_old = 0``, which
    is ridge regression with ``p = (1 - eta) / eta``. Multi-output ``y`` (one
    column per displacement axis) fits one coefficient vector per axis.
    :meth:`update_path` gives the coefficients after each of the first N new
    samples, and :func:`update_is_stable` the paper's stopping rule.

    *Units.* The penalties are those of 004, absolute: ``alpha ||beta||^2``
    against ``||E - A beta||^2`` (and ``1 - eta`` against ``eta``). The units
    of ``y`` do not matter (the coefficients scale with it), but those of
    ``X`` do: with inputs ``c`` times larger (millidegrees: ``c = 1000``) the
    same ``alpha`` regularises the slopes ``c^2`` times less. ``alpha * c^2``
    gives the °C model back when the intercept is free
    (``penalize_intercept=False``; a penalised intercept is then pinned
    ``c^2`` times harder), as ``(1 - eta) / eta`` times ``c^2`` does for
    ``eta``; the simplest remedy is to give ``X`` in °C, or to standardise
    it. The defaults are kept as published, so that results in °C are
    004's; ``fit`` with the default ``alpha`` (and ``partial_fit`` on an
    unfitted model with the default ``eta``) warns when the root-mean-square
    of ``X`` is outside 0.01-100, far from temperature changes in °C (e.g.
    millidegrees, kelvin times 1000, absolute kelvin), and says what to set.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.linear_model import UpdateRegressor
    >>> rng = np.random.default_rng(0)
    >>> T = rng.uniform(0, 5, size=(60, 2))
    >>> E = 4 * T[:, 0] + 2 * T[:, 1]
    >>> model = UpdateRegressor().fit(T, E)
    >>> model.coef_.round(1).tolist()  # shrunk by the ridge penalty
    [3.6, 2.0]
    >>> T_new = rng.uniform(0, 5, size=(6, 2))
    >>> model.partial_fit(T_new, 5 * T_new[:, 0] + 2 * T_new[:, 1]).n_updates_
    1
    >>> model.coef_.round(1).tolist()
    [4.5, 2.2]
    """

    _parameter_constraints: dict = {
        "alpha": [Interval(Real, 0, None, closed="left")],
        "eta": [Interval(Real, 0, 1, closed="right")],
        "penalize_intercept": ["boolean"],
    }

    def __init__(self, alpha=25.0, *, eta=0.1, penalize_intercept=True):
        self.alpha = alpha
        self.eta = eta
        self.penalize_intercept = penalize_intercept

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        return tags

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, *, groups=None):
        """Fit the model by ridge regression.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
            Temperatures, usually changes since the start of each run.
        y : array-like of shape (n_samples,) or (n_samples, n_targets)
            Thermal error(s).
        groups : array-like of shape (n_samples,), optional
            Run labels. The model is static (rows are independent), so they
            are only checked; accepted so that every skthermal regressor
            takes the same call.

        Returns
        -------
        self : object
        """
        names = target_names(y)
        X, y = validate_data(
            self,
            _features(X, groups, y),
            y,
            multi_output=True,
            y_numeric=True,
            dtype=np.float64,
        )
        self._target_names = names
        if self.alpha == 25.0:
            _warn_input_scale(
                X, "alpha", self.alpha, 4, getattr(self, "feature_names_in_", None)
            )
        if self.penalize_intercept and self.alpha > 0:
            _warn_offset_inputs(X, getattr(self, "feature_names_in_", None))
        coef = ridge_coef(
            X,
            _as_2d_target(y),
            alpha=self.alpha,
            penalize_intercept=self.penalize_intercept,
        )
        self._set_coef(coef, y.ndim)
        self.n_updates_ = 0
        return self

    @_fit_context(prefer_skip_nested_validation=True)
    def partial_fit(self, X, y, *, groups=None):
        """Update the coefficients with new samples (update regression).

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_new, n_features)
            New temperature samples.
        y : array-like of shape (n_new,) or (n_new, n_targets)
            New thermal-error samples; named targets (a Series or DataFrame)
            must be those of ``fit``, in the same order.
        groups : array-like of shape (n_new,), optional
            Run labels, only checked (as in ``fit``).

        Returns
        -------
        self : object
        """
        first = not hasattr(self, "coef_")
        X, y, E, old = self._new_samples(
            X,
            y,
            first=first,
            hint="; partial_fit needs the same targets as fit",
            groups=groups,
        )
        if first and self.eta == 0.1:
            # From scratch the update is ridge with p = (1 - eta) / eta.
            _warn_input_scale(
                X, "eta", self.eta, 4, getattr(self, "feature_names_in_", None)
            )
        coef = update_coef(
            X, E, old, eta=self.eta, penalize_intercept=self.penalize_intercept
        )
        self._set_coef(coef, y.ndim if first else self._y_ndim)
        self.n_updates_ = 1 if first else self.n_updates_ + 1
        return self

    def update_path(self, X, y):
        """Coefficients the update would give with the first 1..n new samples.

        The model is not changed. ``path[N - 1]`` is what ``partial_fit(X[:N],
        y[:N])`` would set; pass three successive rows to
        :func:`update_is_stable` for the paper's stopping rule.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_new, n_features)
        y : array-like of shape (n_new,) or (n_new, n_targets)

        Returns
        -------
        path : ndarray of shape (n_new, n_features + 1) or (n_new, n_targets,
            n_features + 1)
            Intercept first in the last axis, as ``[intercept_, *coef_]``.
        """
        check_is_fitted(self)
        X, y, E, old = self._new_samples(X, y, first=False)
        path = update_path(
            X, E, old, eta=self.eta, penalize_intercept=self.penalize_intercept
        )
        path = np.swapaxes(path, 1, 2)
        return path[:, 0, :] if self._y_ndim == 1 else path

    def predict(self, X, *, groups=None):
        """Predicted thermal error.

        Parameters
        ----------
        X : {array-like, DataFrame} of shape (n_samples, n_features)
        groups : array-like of shape (n_samples,), optional
            Run labels, only checked (see :meth:`fit`).

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_targets)
        """
        check_is_fitted(self)
        X = validate_data(self, _features(X, groups), reset=False, dtype=np.float64)
        return X @ self.coef_.T + self.intercept_

    def _new_samples(self, X, y, *, first, hint="", groups=None):
        """Validated new samples, their 2-D targets and the coefficients so far
        (zeros for the first ``partial_fit``)."""
        names = target_names(y)
        known = getattr(self, "_target_names", None)
        if first:
            self._target_names = names
        elif names is not None and known is not None and names != known:
            raise ValueError(
                f"y holds the target(s) {names}, but the model was fitted on "
                f"{known}{hint} (the same names, in the same order)."
            )
        X, y = validate_data(
            self,
            _features(X, groups, y),
            y,
            multi_output=True,
            y_numeric=True,
            dtype=np.float64,
            reset=first,
        )
        E = _as_2d_target(y)
        old = np.zeros((X.shape[1] + 1, E.shape[1])) if first else self._coef_matrix()
        if old.shape[1] != E.shape[1]:
            raise ValueError(
                f"y has {E.shape[1]} target(s) but the model was fitted on "
                f"{old.shape[1]}{hint}."
            )
        return X, y, E, old

    def _coef_matrix(self):
        coef = np.atleast_2d(self.coef_)
        return np.vstack([np.atleast_1d(self.intercept_)[None, :], coef.T])

    def _set_coef(self, coef, y_ndim):
        self._y_ndim = y_ndim
        if y_ndim == 1:
            self.intercept_ = float(coef[0, 0])
            self.coef_ = coef[1:, 0].copy()
        else:
            self.intercept_ = coef[0].copy()
            self.coef_ = coef[1:].T.copy()
