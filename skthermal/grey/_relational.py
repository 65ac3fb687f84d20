"""Grey relational analysis: similitude degree, absolute degree, Deng's grade.

METHODS §4 (001 §3.7.3, §4.5.2). All three compare each input series with the
target on their zero-initial images (the change since the first sample of each
run); a bigger degree means a series follows the target more closely.
"""

import numpy as np

from skthermal.utils._runs import changes_since_start, check_run_lengths, run_slices

_METHODS = ("similitude", "absolute", "deng")
_NORMALIZE = ("range", "std", None)


def _scale(A, normalize):
    if normalize is None:
        return A
    if normalize == "range":
        s = np.ptp(A, axis=0)
    else:
        s = np.std(A, axis=0)
    s = np.where(s > 0, s, 1.0)
    return A / s


def _trapezoid_sum(A):
    # s = sum_{k=2..n-1} x(k) + 0.5 x(n) on a zero-initial image (x(1) = 0).
    return A[1:-1].sum(axis=0) + 0.5 * A[-1]


def grey_relational_grade(
    y, X, *, method="similitude", rho=0.5, normalize="range", groups=None
):
    """Grey relational degree of every input series with the target.

    Parameters
    ----------
    y : array-like of shape (n_samples,)
        Reference (target) series.
    X : array-like of shape (n_samples, n_inputs)
        Comparison series.
    method : {"similitude", "absolute", "deng"}, default="similitude"
        ``"similitude"``: ``1 / (1 + |s_0 - s_i|)``; ``"absolute"``: Liu's
        absolute degree ``(1 + |s_0| + |s_i|) / (1 + |s_0| + |s_i| + |s_i - s_0|)``;
        ``"deng"``: Deng's grade, the mean over samples of
        ``(dmin + rho dmax) / (d_i(k) + rho dmax)`` (METHODS §4).
    rho : float in (0, 1], default=0.5
        Distinguishing coefficient of Deng's grade.
    normalize : {"range", "std"} or None, default="range"
        Each zero-initial image is divided by its range (or standard deviation)
        over all rows, so that series in different units (µm, °C) can be
        compared. ``None`` keeps the raw units: the similitude and absolute
        degrees then depend on the units chosen.
    groups : array-like of shape (n_samples,), optional
        Run labels. Zero-initial images restart at every run; the degree is
        computed per run and averaged, weighted by the run's length. Deng's
        ``dmin`` and ``dmax`` are taken over all runs' rows together (one
        scale for every run, as for one series), so his grade over several
        runs is not the mean of each run's own grade.

    Returns
    -------
    degree : ndarray of shape (n_inputs,)
        In (0, 1]; bigger means more closely related.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.grey import grey_relational_grade
    >>> t = np.linspace(0, 1, 50)
    >>> X = np.c_[t, t ** 3, np.sin(9 * t)]
    >>> grey_relational_grade(t, X).argmax()
    np.int64(0)
    """
    if method not in _METHODS:
        raise ValueError(f"method must be one of {_METHODS}, got {method!r}.")
    if normalize not in _NORMALIZE:
        raise ValueError(f"normalize must be one of {_NORMALIZE}, got {normalize!r}.")
    if not 0 < rho <= 1:
        raise ValueError(f"rho must be in (0, 1], got {rho}.")
    y = np.asarray(y, dtype=float)
    X = np.asarray(X, dtype=float)
    if X.ndim == 1:
        X = X[:, None]
    if y.ndim != 1 or y.shape[0] != X.shape[0]:
        raise ValueError(
            f"Target of shape {y.shape} does not match inputs of shape {X.shape}."
        )
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(X))):
        where = "y" if not np.all(np.isfinite(y)) else "X"
        row = int(np.flatnonzero(~np.isfinite(np.column_stack([y, X])).all(axis=1))[0])
        raise ValueError(
            f"The data contain NaN or infinite values ({where}, first at row "
            f"{row}); grey relational analysis needs every value."
        )
    slices, labels = run_slices(groups, y.shape[0])
    check_run_lengths(slices, labels, "grey relational analysis")
    A = changes_since_start(np.column_stack([y, X]), slices)
    A = _scale(A, normalize)
    a0, Ai = A[:, :1], A[:, 1:]

    if method == "deng":
        d = np.abs(Ai - a0)
        dmax, dmin = d.max(), d.min()
        if dmax == 0:
            return np.ones(X.shape[1])
        xi = (dmin + rho * dmax) / (d + rho * dmax)
        per_run = np.array([xi[sl].mean(axis=0) for sl in slices])
    else:
        s0 = np.array([_trapezoid_sum(a0[sl])[0] for sl in slices])[:, None]
        si = np.array([_trapezoid_sum(Ai[sl]) for sl in slices])
        if method == "similitude":
            per_run = 1.0 / (1.0 + np.abs(s0 - si))
        else:
            num = 1.0 + np.abs(s0) + np.abs(si)
            per_run = num / (num + np.abs(si - s0))
    weights = np.array([sl.stop - sl.start for sl in slices], dtype=float)
    return np.average(per_run, axis=0, weights=weights)
