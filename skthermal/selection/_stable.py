"""Stable temperature-sensitive-point selection and its fuzzy-clustering baseline.

Liu et al. (2022, 004 §3.1) rank temperature sensors by an
*uncertainty-correlation coefficient* ``rho^U = rho / (1 + U_rho)``: the
Pearson correlation of a sensor with the thermal error, discounted by the
uncertainty of that correlation, obtained by propagating the displacement
sensor's uncertainty and the temperature's (three times the RMSE of a
regression of the temperature on the error) through the derivatives of
Pearson's r. The baseline it replaces (004 §2.1) groups the sensors by
fuzzy-equivalence clustering of their correlation matrix and keeps the sensor
most correlated with the error in every group.
"""

import warnings
from numbers import Integral, Real

import numpy as np
from sklearn.utils._param_validation import Interval, StrOptions

from skthermal.selection._base import RunAwareSelector, ScoreSelector
from skthermal.utils._runs import changes_since_start, run_slices
from skthermal.utils._warnings import user_stacklevel


def _centred(A):
    return A - A.mean(axis=0)


def pearson_gradients(x, e):
    """Pearson's r of every sensor with the error, and its derivatives.

    With centred ``x~ = x - mean(x)``, ``e~ = e - mean(e)``, ``Sxx = sum
    x~^2``, ``See = sum e~^2`` and ``r = sum x~ e~ / sqrt(Sxx See)``::

        d r / d x_k = e~_k / sqrt(Sxx See) - r x~_k / Sxx
        d r / d e_k = x~_k / sqrt(Sxx See) - r e~_k / See

    (the terms from the means vanish because centred values sum to zero).
    These are 004 eq. 7-8 written without the ``1 - 1/N`` factors of the
    extracted text, which cancel in the same way.

    Parameters
    ----------
    x : ndarray of shape (n_samples, n_sensors)
        Temperatures.
    e : ndarray of shape (n_samples,)
        Thermal error.

    Returns
    -------
    r : ndarray of shape (n_sensors,)
    dr_dx : ndarray of shape (n_samples, n_sensors)
        ``dr_dx[k, i] = d r_i / d x_{k,i}``.
    dr_de : ndarray of shape (n_samples, n_sensors)
        ``dr_de[k, i] = d r_i / d e_k``.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.selection._stable import pearson_gradients
    >>> x = np.array([[0.0], [1.0], [3.0]])
    >>> r, dx, de = pearson_gradients(x, np.array([0.0, 2.0, 2.0]))
    >>> round(float(r[0]), 4), dx[:, 0].round(4).tolist()
    (0.7559, [-0.162, 0.243, -0.081])
    """
    x = np.asarray(x, dtype=float)
    e = np.asarray(e, dtype=float).reshape(-1)
    xc, ec = _centred(x), _centred(e)
    sxx = np.einsum("ki,ki->i", xc, xc)
    see = float(ec @ ec)
    norm = np.sqrt(sxx) * np.sqrt(see)  # not sqrt(sxx * see): it overflows
    r = (ec @ xc) / norm
    dr_dx = ec[:, None] / norm - r * xc / sxx
    dr_de = xc / norm - r * ec[:, None] / see
    return r, dr_dx, dr_de


def uncertainty_correlation(x, e, *, displacement_uncertainty=1.0, temperature=None):
    """Uncertainty-correlation coefficients ``rho / (1 + U_rho)`` (004 eq. 6-10).

    Parameters
    ----------
    x : ndarray of shape (n_samples, n_sensors)
        Temperatures (changes since the start of the run).
    e : ndarray of shape (n_samples,)
        Thermal error.
    displacement_uncertainty : float, default=1.0
        ``U_E``, uncertainty of the displacement measurement (units of ``e``).
    temperature : ndarray of shape (n_sensors,) or float, optional
        ``U_Ti``; default ``3 * RMSE`` of the least-squares line of ``T_i`` on
        ``E``, ``RMSE = sqrt(sum residual^2 / (N - 1))`` (004 eq. 9).

    Returns
    -------
    rho : ndarray of shape (n_sensors,)
        Pearson correlations.
    u_rho : ndarray of shape (n_sensors,)
        ``U_rho = sqrt(U_E^2 sum_k (dr/de_k)^2 + U_Ti^2 sum_k (dr/dt_ik)^2)``.
    u_t : ndarray of shape (n_sensors,)
        ``U_Ti``.
    rho_u : ndarray of shape (n_sensors,)
        ``rho / (1 + U_rho)``, signed like ``rho``.
    """
    x = np.asarray(x, dtype=float)
    e = np.asarray(e, dtype=float).reshape(-1)
    n = x.shape[0]
    rho, dr_dx, dr_de = pearson_gradients(x, e)
    if temperature is None:
        # Residual of the line T_i = a + b E: sum = Sxx (1 - r^2), computed
        # directly to avoid cancellation when r is close to 1.
        xc, ec = _centred(x), _centred(e)
        slope = (ec @ xc) / (ec @ ec)
        resid = xc - np.outer(ec, slope)
        u_t = 3.0 * np.sqrt(np.einsum("ki,ki->i", resid, resid) / (n - 1))
    else:
        u_t = np.broadcast_to(np.asarray(temperature, dtype=float), rho.shape)
    u_rho = np.sqrt(
        displacement_uncertainty**2 * np.einsum("ki,ki->i", dr_de, dr_de)
        + u_t**2 * np.einsum("ki,ki->i", dr_dx, dr_dx)
    )
    return rho, u_rho, u_t, rho / (1.0 + u_rho)


class StableTSPSelector(ScoreSelector):
    """Keep the sensors with the largest uncertainty-correlation coefficient.

    The *stability TSP selection* of Liu et al. (2022): every temperature
    sensor is scored by its Pearson correlation with the thermal error,
    discounted by the uncertainty of that correlation,
    ``rho^U = rho / (1 + U_rho)``, and the ``n_features_to_select`` best
    sensors are the temperature-sensitive points (TSPs). No grouping: the
    sensors kept may be collinear, which ridge regression
    (:class:`~skthermal.linear_model.UpdateRegressor`) tolerates, but they are
    the most, and most stably, correlated ones.

    Parameters
    ----------
    n_features_to_select : int, float or None, default=2
        Number of TSPs (an int; 004 uses two) or a fraction of the sensors (a
        float in (0, 1]).
    displacement_uncertainty : float, default=1.0
        ``U_E``, the uncertainty of the displacement measurement, in the
        units of ``y`` (µm).
    temperature_uncertainty : "regression" or float, default="regression"
        ``U_Ti``. ``"regression"``: three times the RMSE of the regression of
        each sensor on the thermal error (004 eq. 9), the part of the
        sensor's signal unrelated to the error. A float: one known
        uncertainty for all sensors (units of ``X``).
    threshold : float, {"mean", "median"} or None, default=None
        Keep sensors whose score is at least this (combined with
        ``n_features_to_select`` when both are given).

    Attributes
    ----------
    scores_ : ndarray of shape (n_features_in_,)
        ``|rho^U|`` of every sensor (with several targets, the mean over
        targets of the scores scaled to a maximum of one per target).
    ranking_ : ndarray of shape (n_features_in_,)
        Rank of every sensor, 1 = best.
    correlation_ : ndarray of shape (n_targets, n_features_in_)
        Pearson's ``rho``, signed.
    uncertainty_ : ndarray of shape (n_targets, n_features_in_)
        ``U_rho``.
    temperature_uncertainty_ : ndarray of shape (n_targets, n_features_in_)
        ``U_Ti`` used.
    uncertainty_correlation_ : ndarray of shape (n_targets, n_features_in_)
        ``rho^U``, signed.
    support_ : ndarray of bool of shape (n_features_in_,)
        Mask of the TSPs.
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (n_features_in_,)

    See Also
    --------
    FuzzyEquivalenceSelector : the clustering baseline of 004.
    skthermal.linear_model.UpdateRegressor : the model 004 builds on the TSPs.

    Notes
    -----
    004 eq. 5-10; METHODS §10. Sensors and error are taken as changes since
    the start of each run (as 004 subtracts the first measurement), stacked
    over the runs, and the samples of those changes are the ``t_ik`` and
    ``e_k`` of the error propagation. The derivatives of Pearson's r are
    analytic (:func:`pearson_gradients`); their sums of squares reduce to
    ``(1 - rho^2) / S_TT`` and ``(1 - rho^2) / S_EE``.

    Sign: a negatively correlated sensor is as useful to a linear model as a
    positively correlated one, so sensors are ranked by ``|rho^U|``;
    ``uncertainty_correlation_`` keeps the sign.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.selection import StableTSPSelector
    >>> rng = np.random.default_rng(0)
    >>> t = np.linspace(0, 4, 60)
    >>> E = 20 * (1 - np.exp(-t))
    >>> X = np.c_[E / 5 + rng.normal(0, 0.5, 60), E / 4 + rng.normal(0, 0.05, 60),
    ...           -E / 6 + rng.normal(0, 0.1, 60), rng.normal(0, 1, 60)]
    >>> one_run = np.zeros(60)  # the rows are one run
    >>> sel = StableTSPSelector(n_features_to_select=2).fit(X, E, groups=one_run)
    >>> sel.get_support().tolist()
    [False, True, True, False]
    >>> sel.correlation_.round(2).tolist()
    [[0.93, 1.0, -0.99, -0.05]]
    """

    _PER_SENSOR = {
        "scores_": (-1,),
        "correlation_": (-1,),
        "uncertainty_": (-1,),
        "temperature_uncertainty_": (-1,),
        "uncertainty_correlation_": (-1,),
    }

    _parameter_constraints: dict = {
        **ScoreSelector._parameter_constraints,
        "displacement_uncertainty": [Interval(Real, 0, None, closed="left")],
        "temperature_uncertainty": [
            StrOptions({"regression"}),
            Interval(Real, 0, None, closed="left"),
        ],
    }

    def __init__(
        self,
        n_features_to_select=2,
        *,
        displacement_uncertainty=1.0,
        temperature_uncertainty="regression",
        threshold=None,
    ):
        self.n_features_to_select = n_features_to_select
        self.displacement_uncertainty = displacement_uncertainty
        self.temperature_uncertainty = temperature_uncertainty
        self.threshold = threshold

    def _scores_per_target(self, X, Y, groups):
        slices, _ = run_slices(groups, X.shape[0])
        Xc = changes_since_start(X, slices)
        Yc = changes_since_start(Y, slices)
        spread = np.ptp(Yc, axis=0)
        if np.any(self.displacement_uncertainty > spread):
            k = int(np.argmax(self.displacement_uncertainty > spread))
            warnings.warn(
                f"StableTSPSelector: displacement_uncertainty="
                f"{self.displacement_uncertainty:g} is larger than the whole "
                f"range of the thermal error of target {k} ({spread[k]:.3g}): "
                "every correlation is then within its uncertainty and the "
                "scores do not tell the sensors apart. Give the uncertainty "
                "in the unit of y.",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
        known = self.temperature_uncertainty
        out = [
            uncertainty_correlation(
                Xc,
                Yc[:, k],
                displacement_uncertainty=self.displacement_uncertainty,
                temperature=None if known == "regression" else known,
            )
            for k in range(Y.shape[1])
        ]
        rho, u_rho, u_t, rho_u = (np.array(a) for a in zip(*out, strict=True))
        self.correlation_ = rho
        self.uncertainty_ = u_rho
        self.temperature_uncertainty_ = u_t
        self.uncertainty_correlation_ = rho_u
        return np.abs(rho_u)


def fuzzy_equivalence_closure(R):
    """Max-min transitive closure of a fuzzy similarity matrix (004 eq. 2-4).

    004 squares ``R`` by max-min composition, ``(R o R)_ij = max_k min(R_ik,
    R_kj)``, until it no longer changes; the result is a fuzzy equivalence
    matrix, whose lambda-cuts are equivalence relations. Its entry ``(i, j)``
    is the largest, over all chains of sensors from ``i`` to ``j``, of the
    weakest similarity along the chain: the weakest link on the path between
    ``i`` and ``j`` in a maximum spanning tree of ``R``. It is computed that
    way, exactly (the values are entries of ``R``), in O(n^2) memory and time
    instead of the squarings' O(n^3) memory (1.3 GB for 525 sensors).

    Parameters
    ----------
    R : array-like of shape (n, n)
        Symmetric, values in [0, 1], ones on the diagonal.

    Returns
    -------
    closure : ndarray of shape (n, n)
    merges : ndarray of shape (n - 1,)
        The similarities at which the groups merge, highest first (the
        maximum spanning tree's edges): the lambda-cut at ``lam`` has ``1 +
        sum(merges < lam)`` groups.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.selection._stable import fuzzy_equivalence_closure
    >>> R = np.array([[1.0, 0.8, 0.1], [0.8, 1.0, 0.6], [0.1, 0.6, 1.0]])
    >>> fuzzy_equivalence_closure(R)[0].tolist()
    [[1.0, 0.8, 0.6], [0.8, 1.0, 0.6], [0.6, 0.6, 1.0]]
    """
    from scipy.sparse.csgraph import minimum_spanning_tree

    R = np.asarray(R, dtype=float)
    if R.ndim != 2 or R.shape[0] != R.shape[1]:
        raise ValueError(f"R must be a square matrix, got shape {R.shape}.")
    n = R.shape[0]
    closure = np.eye(n)
    if n < 2:
        return closure, np.zeros(0)
    # A minimum spanning tree of 2 - R (weights in [1, 2]: no zero, which the
    # sparse graph would read as "no edge") is a maximum spanning tree of R.
    cost = 2.0 - np.clip(R, 0.0, 1.0)
    np.fill_diagonal(cost, 0.0)
    tree = minimum_spanning_tree(cost).tocoo()
    i, j = tree.row, tree.col
    w = R[i, j]
    order = np.argsort(-w, kind="stable")
    # Kruskal's merges, strongest first: every pair joined by a merge has
    # that merge's similarity as its weakest link.
    group = np.arange(n)
    members = {k: [k] for k in range(n)}
    for e in order:
        a, b = group[i[e]], group[j[e]]
        A, B = members.pop(a), members.pop(b)
        closure[np.ix_(A, B)] = w[e]
        closure[np.ix_(B, A)] = w[e]
        group[B] = a
        members[a] = A + B
    return closure, w[order]


def _cut_labels(closure, threshold):
    """Groups of the lambda-cut ``closure >= threshold``, numbered by first
    member."""
    cut = closure >= threshold
    # Rows of an equivalence relation are identical within a group.
    _, first, labels = np.unique(cut, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(np.argsort(first))
    return order[labels.reshape(-1)]


class FuzzyEquivalenceSelector(RunAwareSelector):
    """Group sensors by fuzzy-equivalence clustering; keep the best of each.

    The baseline TSP selection of 004 §2.1: the matrix of absolute Pearson
    correlations between sensors is made a fuzzy equivalence matrix by
    repeated max-min squaring (its transitive closure); sensors whose closure
    similarity is at least ``threshold`` (lambda) form a group, and the
    sensor of each group most correlated with the thermal error is kept.

    Parameters
    ----------
    threshold : float in [0, 1], default=0.9
        Lambda: sensors ``i``, ``j`` share a group when their closure
        similarity ``>= threshold``. Higher means more, smaller groups.
    n_groups : int or None, default=None
        If given, lambda is chosen instead as the highest level of the
        closure giving at most ``n_groups`` groups (004 uses two groups);
        ``threshold`` is then ignored.

    Attributes
    ----------
    similarity_ : ndarray of shape (n_features_in_, n_features_in_)
        The fuzzy equivalence matrix (closure of ``|corr|``).
    threshold_ : float
        Lambda used.
    labels_ : ndarray of shape (n_features_in_,)
        Group of every sensor, numbered by first member.
    representatives_ : ndarray of shape (n_groups,)
        Index of the kept sensor of every group, in group order.
    scores_ : ndarray of shape (n_features_in_,)
        ``|rho|`` of every sensor with the error (mean over targets).
    support_ : ndarray of bool of shape (n_features_in_,)
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (n_features_in_,)

    See Also
    --------
    StableTSPSelector : the selection 004 proposes instead.
    FCMClusterPicker : fuzzy c-means grouping of sensors.

    Notes
    -----
    004 eq. 2-5; METHODS §10. Correlations use changes since the start of
    each run, stacked over runs. The paper writes ``F > lambda``; here ``>=``,
    so ``threshold=0`` is one group and ``threshold=1`` groups only
    perfectly (transitively) correlated sensors.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.selection import FuzzyEquivalenceSelector
    >>> t = np.linspace(0, 1, 50)
    >>> X = np.c_[t, t ** 1.1, np.sin(9 * t), np.sin(9 * t) + 0.01 * t]
    >>> one_run = np.zeros(50)  # the rows are one run
    >>> sel = FuzzyEquivalenceSelector(threshold=0.95).fit(X, t, groups=one_run)
    >>> sel.labels_.tolist(), sel.representatives_.tolist()
    ([0, 0, 1, 1], [0, 3])
    """

    _PER_SENSOR = {"scores_": (-1,), "similarity_": (0, 1)}

    _parameter_constraints: dict = {
        "threshold": [Interval(Real, 0, 1, closed="both")],
        "n_groups": [Interval(Integral, 1, None, closed="left"), None],
    }

    def __init__(self, threshold=0.9, *, n_groups=None):
        self.threshold = threshold
        self.n_groups = n_groups

    def _fit_runs(self, X, Y, groups, slices):
        Xc = changes_since_start(X, slices)
        Yc = changes_since_start(Y, slices)
        xc, yc = _centred(Xc), _centred(Yc)
        xn = xc / np.linalg.norm(xc, axis=0)
        yn = yc / np.linalg.norm(yc, axis=0)
        R = np.abs(xn.T @ xn)
        # Exact symmetry, so that every lambda-cut is an equivalence relation.
        R = np.clip((R + R.T) / 2.0, 0.0, 1.0)
        np.fill_diagonal(R, 1.0)
        closure, merges = fuzzy_equivalence_closure(R)
        self.similarity_ = closure
        self.scores_ = np.abs(yn.T @ xn).mean(axis=0)
        if self.n_groups is None:
            lam = float(self.threshold)
        else:
            if self.n_groups >= closure.shape[0]:
                # As the score selectors (and scikit-learn's SelectKBest).
                warnings.warn(
                    f"n_groups={self.n_groups}, but X has only "
                    f"{closure.shape[0]} sensor(s): every sensor is a group of "
                    "its own, and all are kept.",
                    UserWarning,
                    stacklevel=user_stacklevel(),
                )
            # The lambda-cuts at the similarities where groups merge, high to
            # low: a cut at lam has n minus (merges at or above lam) groups;
            # the highest one with at most n_groups.
            levels = np.unique(np.r_[1.0, merges])[::-1]
            done = np.searchsorted(-merges, -levels, side="right")
            counts = closure.shape[0] - done
            ok = np.flatnonzero(counts <= self.n_groups)
            lam = float(levels[ok[0]])
        self.threshold_ = lam
        labels = _cut_labels(closure, lam)
        n_groups = labels.max() + 1
        # Best sensor per group, vectorised: mask other groups' scores out.
        member = labels[None, :] == np.arange(n_groups)[:, None]
        reps = np.argmax(np.where(member, self.scores_[None, :], -np.inf), axis=1)
        self.labels_ = labels
        self.representatives_ = reps
        support = np.zeros(X.shape[1], dtype=bool)
        support[reps] = True
        self.support_ = support
