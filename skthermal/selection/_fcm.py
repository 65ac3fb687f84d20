"""Fuzzy c-means grouping of sensors with one representative per group."""

import warnings
from numbers import Integral, Real

import numpy as np
from sklearn.base import clone
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import HasMethods, Interval, StrOptions

from skthermal.fuzzy._cmeans import fuzzy_cmeans
from skthermal.selection._base import RunAwareSelector
from skthermal.selection._grey import GRASelector, GreyInfluenceSelector
from skthermal.utils._runs import accepts_groups, changes_since_start
from skthermal.utils._warnings import user_stacklevel


def _pearson_scores(X, Y, slices):
    Xc = changes_since_start(X, slices)
    Yc = changes_since_start(Y, slices)
    Xc = Xc - Xc.mean(axis=0)
    Yc = Yc - Yc.mean(axis=0)
    num = Yc.T @ Xc
    den = np.outer(np.linalg.norm(Yc, axis=0), np.linalg.norm(Xc, axis=0))
    r = np.divide(num, den, out=np.zeros_like(num), where=den > 0)
    return np.abs(r).mean(axis=0)


def _fitted_scores(est):
    for attr in ("scores_", "feature_importances_"):
        if hasattr(est, attr):
            return np.asarray(getattr(est, attr), dtype=float)
    if hasattr(est, "coef_"):
        coef = np.abs(np.asarray(est.coef_, dtype=float))
        return coef if coef.ndim == 1 else coef.mean(axis=0)
    raise ValueError(
        f"The scorer {type(est).__name__} has no scores_, feature_importances_ or "
        "coef_ after fitting; pass a selector such as GRASelector()."
    )


class FCMClusterPicker(RunAwareSelector):
    """Group sensors by fuzzy c-means and keep the best sensor of each group.

    The thermal-error workflow of Abdulshahed et al. (2015): many temperature
    sensors (76 on their machine) are grouped into ``n_clusters`` fuzzy
    clusters of sensors that behave alike, and the most influential sensor of
    each cluster represents it, so a handful of sensors (5) cover the
    machine's distinct thermal behaviours without redundancy. As a Pipeline
    step it turns any regressor into a sensor-selecting model.

    Parameters
    ----------
    n_clusters : int, default=5
        Number of sensor groups, hence of sensors kept (all of them, with a
        warning, when X has fewer).
    scorer : {"gm1n", "gm0n", "gra", "pearson"} or selector, default="gm1n"
        How a group's representative is chosen: the grey influence
        (:class:`GreyInfluenceSelector` with GM(1,N) or GM(0,N)), the grey
        relational degree (:class:`GRASelector`), the absolute Pearson
        correlation of the changes since the start of each run, or any
        estimator instance that exposes ``scores_``, ``feature_importances_``
        or ``coef_`` after fitting (it is cloned and fitted on the same data,
        with ``groups`` when its ``fit`` accepts them).
    features : {"series", "scores"}, default="series"
        What the sensors are clustered on. ``"series"``: each sensor's change
        since the start of its run, standardised, so sensors whose readings
        move together fall in one group. ``"scores"``: the sensors' scores
        alone (one number per sensor), the literal reading of "the influence
        weightings are clustered" in the papers; it groups sensors of similar
        influence, not of similar behaviour.
    m : float > 1, default=2.0
        Fuzzifier of fuzzy c-means.
    n_init : int, default=10
        Fuzzy c-means initialisations (k-means++ seeded); the least objective
        wins.
    max_iter : int, default=300
        Fuzzy c-means iterations per initialisation.
    tol : float, default=1e-5
        Fuzzy c-means stops when no membership changes by more than ``tol``.
    random_state : int, RandomState instance or None, default=None
        Seeds fuzzy c-means.

    Attributes
    ----------
    scores_ : ndarray of shape (n_features_in_,)
        Score of every sensor under ``scorer``.
    labels_ : ndarray of shape (n_features_in_,)
        Group of every sensor (its largest membership). Groups are numbered by
        decreasing score of their representative.
    memberships_ : ndarray of shape (n_features_in_, n_groups)
        Fuzzy membership of every sensor in every group.
    representatives_ : ndarray of shape (n_groups,)
        Index of the kept sensor of each group, in group order.
    support_ : ndarray of bool of shape (n_features_in_,)
        Mask of the kept sensors.
    n_iter_ : int
        Fuzzy c-means iterations of the best initialisation.
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (n_features_in_,)

    See Also
    --------
    GreyInfluenceSelector, GRASelector, skthermal.fuzzy.fuzzy_cmeans

    Notes
    -----
    METHODS §5 and 000 §4.2 (76 sensors -> T18, T55, T63, T68, T71). Sensor
    series are changes since the start of each run; scores restart at run
    boundaries (run labels from ``groups``, a ``run`` column or a ``run``
    index level, as for every skthermal selector). A group with no sensor of
    largest membership (possible when ``n_clusters`` is close to the number of
    sensors) is dropped with a warning, so fewer sensors are kept.

    Examples
    --------
    >>> from skthermal import FCMClusterPicker
    >>> from skthermal.datasets import make_sensor_groups
    >>> runs, truth = make_sensor_groups(n_groups=3, random_state=0)
    >>> sensors = truth.index
    >>> picker = FCMClusterPicker(n_clusters=3, random_state=0)
    >>> picker.fit(runs[sensors], runs["disp_y_um"], groups=runs["run"])
    FCMClusterPicker(n_clusters=3, random_state=0)
    >>> sorted(truth[picker.get_feature_names_out()].tolist())
    [0, 1, 2]
    """

    _PER_SENSOR = {"scores_": (-1,), "memberships_": (0,)}

    _parameter_constraints: dict = {
        "n_clusters": [Interval(Integral, 1, None, closed="left")],
        "scorer": [
            StrOptions({"gm1n", "gm0n", "gra", "pearson"}),
            HasMethods(["fit"]),
        ],
        "features": [StrOptions({"series", "scores"})],
        "m": [Interval(Real, 1, None, closed="neither")],
        "n_init": [Interval(Integral, 1, None, closed="left")],
        "max_iter": [Interval(Integral, 1, None, closed="left")],
        "tol": [Interval(Real, 0, None, closed="left")],
        "random_state": ["random_state"],
    }

    def _counts_rows(self):
        return isinstance(self.scorer, str) and self.scorer in ("gm1n", "gm0n")

    def __init__(
        self,
        n_clusters=5,
        *,
        scorer="gm1n",
        features="series",
        m=2.0,
        n_init=10,
        max_iter=300,
        tol=1e-5,
        random_state=None,
    ):
        self.n_clusters = n_clusters
        self.scorer = scorer
        self.features = features
        self.m = m
        self.n_init = n_init
        self.max_iter = max_iter
        self.tol = tol
        self.random_state = random_state

    def _score_sensors(self, X, Y, groups, slices):
        if self.scorer == "pearson":
            return _pearson_scores(X, Y, slices)
        if self.scorer in ("gm1n", "gm0n"):
            est = GreyInfluenceSelector(self.scorer)
        elif self.scorer == "gra":
            est = GRASelector()
        else:
            est = clone(self.scorer)
        y = Y[:, 0] if Y.shape[1] == 1 else Y
        try:
            if groups is not None and accepts_groups(est.fit):
                est.fit(X, y, groups=groups)
            else:
                with warnings.catch_warnings():
                    # This picker has just said that the rows are one run.
                    warnings.filterwarnings("ignore", message=r".*carry no run labels")
                    est.fit(X, y)
        except ValueError as exc:
            if "too few samples" not in str(exc) or not isinstance(self.scorer, str):
                raise
            raise ValueError(
                f"{exc} scorer='pearson' (or 'gra') scores the sensors without "
                "that limit, e.g. the many spots of a thermal image."
            ) from exc
        scores = _fitted_scores(est)
        if scores.shape != (X.shape[1],):
            raise ValueError(
                f"The scorer returned {scores.shape} scores for {X.shape[1]} sensors."
            )
        return scores

    def _fit_runs(self, X, Y, groups, slices):
        n_features = X.shape[1]
        n_clusters = self.n_clusters
        if n_clusters > n_features:
            # As the other selectors (and scikit-learn's SelectKBest): all
            # are kept, with a warning.
            warnings.warn(
                f"n_clusters={n_clusters}, but X has only {n_features} "
                "sensor(s): every sensor is a group of its own, and all are "
                "kept.",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
            n_clusters = n_features
        scores = self._score_sensors(X, Y, groups, slices)
        if self.features == "series":
            Z = changes_since_start(X, slices)
            Z -= Z.mean(axis=0)
            # In units of each sensor's largest deviation first, so that the
            # spread of readings of 1e-300 does not underflow to 0 (no zero
            # otherwise: constant sensors were rejected).
            Z /= np.max(np.abs(Z), axis=0)
            Z /= Z.std(axis=0)
            points = Z.T
        else:
            top = np.max(np.abs(scores))
            points = (scores / (top if top > 0 else 1.0))[:, None]
        result = fuzzy_cmeans(
            points,
            n_clusters,
            m=self.m,
            tol=self.tol,
            max_iter=self.max_iter,
            n_init=self.n_init,
            random_state=check_random_state(self.random_state),
        )
        hard = result.labels
        reps, clusters = [], []
        for c in range(n_clusters):
            members = np.flatnonzero(hard == c)
            if members.size:
                reps.append(members[np.argmax(scores[members])])
                clusters.append(c)
        if len(reps) < n_clusters:
            warnings.warn(
                f"{n_clusters - len(reps)} of {n_clusters} sensor groups "
                "ended up empty; keeping one sensor for each of the "
                f"{len(reps)} others. Lower n_clusters.",
                UserWarning,
                stacklevel=3,
            )
        reps = np.asarray(reps)
        order = np.argsort(-scores[reps], kind="stable")
        relabel = np.empty(n_clusters, dtype=int)
        kept = np.asarray(clusters)[order]
        empty = [c for c in range(n_clusters) if c not in clusters]
        relabel[np.r_[kept, empty].astype(int)] = np.arange(n_clusters)
        self.scores_ = scores
        self.n_iter_ = result.n_iter
        self.labels_ = relabel[hard]
        self.memberships_ = result.memberships[:, np.argsort(relabel)]
        self.representatives_ = reps[order]
        support = np.zeros(n_features, dtype=bool)
        support[self.representatives_] = True
        self.support_ = support
