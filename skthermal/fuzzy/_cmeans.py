"""Fuzzy c-means clustering (Bezdek), vectorised over samples and clusters.

METHODS §5 (000 eq. 7-9, 001 §3.3.2.1). Used to group sensors (one
representative per group) and to build the rule base of ANFIS.
"""

from dataclasses import dataclass

import numpy as np
from sklearn.cluster import kmeans_plusplus
from sklearn.utils import check_random_state

from skthermal.utils._threads import single_threaded_blas


@dataclass(frozen=True)
class FuzzyCMeansResult:
    """Result of :func:`fuzzy_cmeans`.

    Attributes
    ----------
    centers : ndarray of shape (n_clusters, n_features)
    memberships : ndarray of shape (n_samples, n_clusters)
        Rows sum to one.
    objective : float
        ``J = sum_i sum_j w_j u_ij^m d_ij^2`` at the returned partition.
    n_iter : int
        Iterations of the best initialisation.
    objective_history : ndarray
        ``J`` after each iteration of the best initialisation.
    """

    centers: np.ndarray
    memberships: np.ndarray
    objective: float
    n_iter: int
    objective_history: np.ndarray

    @property
    def labels(self):
        """Hard partition: the cluster of largest membership for every sample."""
        return self.memberships.argmax(axis=1)


# Internally everything is laid out clusters x samples: reductions over the
# (few) clusters then run along axis 0, which numpy vectorises over the long
# sample axis -- about 20x faster than reducing a short trailing axis.


def _sq_distances(X, centers, x_sq):
    """Squared distances, shape (n_clusters, n_samples)."""
    d2 = centers @ X.T
    d2 *= -2.0
    d2 += x_sq[None, :]
    d2 += np.einsum("ij,ij->i", centers, centers)[:, None]
    np.maximum(d2, 0.0, out=d2)
    return d2


def _memberships(d2, m):
    """Memberships from squared distances, both (n_clusters, n_samples)."""
    dmin = d2.min(axis=0, keepdims=True)
    on_centre = dmin[0] <= 0.0
    if on_centre.any():
        d2 = d2.copy()
        sub = d2[:, on_centre]
        d2[:, on_centre] = np.where(sub <= 0.0, 1.0, np.inf)
        dmin = np.where(on_centre[None, :], 1.0, dmin)
    # Dividing by the smallest distance keeps every ratio in [0, 1], so neither
    # tiny nor huge distances overflow.
    u = np.divide(dmin, d2)
    if m != 2.0:
        np.power(u, 1.0 / (m - 1.0), out=u)
    u /= u.sum(axis=0, keepdims=True)
    return u


def memberships_from_distances(d2, m):
    """Fuzzy memberships from squared distances, ``u_ij ∝ d_ij^(-2/(m-1))``.

    A sample that sits on a centre (d = 0) gets membership 1 there (shared
    equally if it sits on several).

    Parameters
    ----------
    d2 : ndarray of shape (n_samples, n_clusters)
        Squared distances to the centres.
    m : float > 1
        Fuzzifier.

    Returns
    -------
    ndarray of shape (n_samples, n_clusters), rows summing to one.
    """
    return _memberships(np.asarray(d2, dtype=float).T, m).T


def fuzzy_memberships(X, centers, m=2.0):
    """Memberships of new samples in fixed cluster centres.

    Returns
    -------
    ndarray of shape (n_samples, n_clusters), rows summing to one.
    """
    X = np.asarray(X, dtype=float)
    centers = np.asarray(centers, dtype=float)
    if X.ndim != 2 or centers.ndim != 2 or X.shape[1] != centers.shape[1]:
        raise ValueError(
            f"X (shape {X.shape}) and centers (shape {centers.shape}) must be 2-D "
            "with the same number of features (columns)."
        )
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(centers))):
        raise ValueError("X and centers must be finite (no NaN or infinite value).")
    if not m > 1:
        raise ValueError(f"The fuzzifier m must be greater than 1, got {m}.")
    # Distances from data and centres shifted together: exact, and no loss
    # of precision when they share a large offset.
    shift = centers.mean(axis=0)
    X, centers = X - shift, centers - shift
    d2 = _sq_distances(X, centers, np.einsum("ij,ij->i", X, X))
    return _memberships(d2, m).T


def _initial_memberships(X, n_clusters, init, m, rng, x_sq):
    n = X.shape[0]
    if isinstance(init, np.ndarray):
        u = np.array(init, dtype=float)
        if u.shape != (n, n_clusters):
            raise ValueError(
                f"init memberships must have shape {(n, n_clusters)}, got {u.shape}."
            )
        if np.any(u < 0) or not np.all(np.isfinite(u)):
            raise ValueError("init memberships must be finite and non-negative.")
        empty = np.flatnonzero(u.sum(axis=1) <= 0)
        if empty.size:
            raise ValueError(
                f"init memberships of sample {int(empty[0])} are all zero; every "
                "sample needs a positive membership somewhere."
            )
        u = np.ascontiguousarray(u.T)
        return u / u.sum(axis=0, keepdims=True)
    if init == "random":
        u = rng.random_sample((n_clusters, n))
        return u / u.sum(axis=0, keepdims=True)
    if init == "k-means++":
        centers, _ = kmeans_plusplus(
            X, n_clusters, random_state=rng, x_squared_norms=x_sq
        )
        return _memberships(_sq_distances(X, centers, x_sq), m)
    raise ValueError(
        f"init must be 'k-means++', 'random' or an array of memberships, got {init!r}."
    )


# Memberships (in [0, 1]) whose largest change is below this and no longer
# shrinks change by rounding only: a fixed point. With tol=0 their last bits
# cycled (at 1e-16 to 1e-13, by data set), and every one of max_iter
# iterations ran.
_ROUNDING = 1e-10


def _fcm_single(X, u, m, tol, max_iter, w, x_sq, gram):
    """One fuzzy c-means run from memberships ``u`` (n_clusters, n_samples).

    Every centre is a weighted mean of the samples, ``c = A X`` with
    ``A = u^m / sum u^m``. With ``gram = X X^T`` given (worth it when there are
    more features than samples, e.g. sensors clustered on long time series)
    the distances come from ``||x_j||^2 - 2 (A K)_ij + (A K A^T)_ii`` at
    O(c n^2) per iteration instead of O(c n d), and ``X`` is touched once, at
    the end, to form the centres.
    """
    history = []
    n_iter = 0
    last = np.inf
    tiny = np.finfo(float).tiny
    for n_iter in range(1, max_iter + 1):
        um = u * u if m == 2.0 else u**m
        if w is not None:
            um *= w[None, :]
        A = um / np.maximum(um.sum(axis=1), tiny)[:, None]
        if gram is None:
            d2 = _sq_distances(X, A @ X, x_sq)
        else:
            AK = A @ gram
            c_sq = np.einsum("ij,ij->i", AK, A)
            d2 = AK
            d2 *= -2.0
            d2 += x_sq[None, :]
            d2 += c_sq[:, None]
            np.maximum(d2, 0.0, out=d2)
        history.append(float(np.vdot(um, d2)))
        u_new = _memberships(d2, m)
        u -= u_new
        shift = max(u.max(), -u.min())
        u = u_new
        if shift <= tol or (shift < _ROUNDING and shift >= last):
            break
        last = shift
    return A @ X, u, np.asarray(history), n_iter


def fuzzy_cmeans(
    X,
    n_clusters,
    *,
    m=2.0,
    tol=1e-5,
    max_iter=300,
    n_init=1,
    init="k-means++",
    sample_weight=None,
    random_state=None,
):
    """Fuzzy c-means clustering.

    Alternates ``c_i = sum_j w_j u_ij^m x_j / sum_j w_j u_ij^m`` and
    ``u_ij = 1 / sum_k (d_ij / d_kj)^(2/(m-1))`` (METHODS §5) until no
    membership moves by more than ``tol``. Each iteration is a handful of
    matrix products over all samples and clusters at once.

    Parameters
    ----------
    X : array-like of shape (n_samples, n_features)
    n_clusters : int
        Number of clusters, ``1 <= n_clusters <= n_samples``.
    m : float > 1, default=2.0
        Fuzzifier; m -> 1 approaches k-means, larger m gives softer partitions.
    tol : float, default=1e-5
        Stop when the largest change of any membership is at most ``tol``
        (``0``: at a fixed point, changes of rounding aside).
    max_iter : int, default=300
    n_init : int, default=1
        Number of initialisations; the partition with the least objective wins.
    init : {"k-means++", "random"} or ndarray of shape (n_samples, n_clusters)
        ``"k-means++"`` seeds centres with k-means++; ``"random"`` draws random
        memberships (as scikit-fuzzy and MATLAB's ``fcm`` do); an array gives the
        initial memberships (then ``n_init`` should be 1).
    sample_weight : array-like of shape (n_samples,), optional
        Non-negative weight of every sample in the objective and the centres.
    random_state : int, RandomState instance or None

    Returns
    -------
    FuzzyCMeansResult

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.fuzzy import fuzzy_cmeans
    >>> X = np.r_[np.zeros((5, 2)), np.ones((5, 2)) * 10]
    >>> res = fuzzy_cmeans(X, 2, random_state=0)
    >>> sorted(res.centers[:, 0].round(6).tolist())
    [0.0, 10.0]
    """
    X = np.asarray(X, dtype=float)
    if X.ndim != 2:
        raise ValueError(f"X must be 2-D (samples x features), got shape {X.shape}.")
    if not np.all(np.isfinite(X)):
        raise ValueError("X contains NaN or infinite values.")
    n = X.shape[0]
    if not 1 <= int(n_clusters) <= n:
        raise ValueError(
            f"n_clusters must be between 1 and the number of samples ({n}), "
            f"got {n_clusters}."
        )
    if not m > 1:
        raise ValueError(f"The fuzzifier m must be greater than 1, got {m}.")
    for name, value in (("max_iter", max_iter), ("n_init", n_init)):
        if isinstance(value, bool) or not float(value).is_integer() or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}.")
    if not tol >= 0:
        raise ValueError(f"tol must be >= 0, got {tol!r}.")
    w = None
    if sample_weight is not None:
        w = np.asarray(sample_weight, dtype=float)
        if w.shape != (n,) or np.any(w < 0) or not np.all(np.isfinite(w)):
            raise ValueError(f"sample_weight must be {n} finite non-negative values.")
        if not w.sum() > 0:
            raise ValueError("sample_weight is zero everywhere: no sample counts.")
    rng = check_random_state(random_state)
    # Centred: the squared distances (|x|^2 - 2 x.c + |c|^2) keep their
    # precision when the data share a large offset; the centres are shifted
    # back at the end.
    shift = X.mean(axis=0)
    X = X - shift
    x_sq = np.einsum("ij,ij->i", X, X)
    best = None
    with single_threaded_blas():
        gram = X @ X.T if X.shape[1] > X.shape[0] else None
        for _ in range(int(n_init)):
            u0 = _initial_memberships(X, int(n_clusters), init, m, rng, x_sq)
            centers, u, history, n_iter = _fcm_single(
                X, u0, m, tol, max_iter, w, x_sq, gram
            )
            um = u**m if w is None else u**m * w[None, :]
            J = float(np.vdot(um, _sq_distances(X, centers, x_sq)))
            if best is None or J < best.objective:
                best = FuzzyCMeansResult(centers + shift, u.T, J, n_iter, history)
    return best
