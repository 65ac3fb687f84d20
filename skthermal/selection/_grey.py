"""Grey-system sensor selectors: GM(0,N)/GM(1,N) influence and grey relational
analysis."""

from numbers import Real

import numpy as np
from sklearn.utils._param_validation import Interval, StrOptions

from skthermal.grey._models import gm0n, gm1n
from skthermal.grey._relational import grey_relational_grade
from skthermal.selection._base import ScoreSelector


class GreyInfluenceSelector(ScoreSelector):
    """Rank sensors by their grey-model influence on the thermal error.

    Fits a GM(1,N) (or GM(0,N)) grey model of the displacement driven by all
    sensors and ranks every sensor by the magnitude of its driving coefficient
    ``|b_j|`` (``|theta_j|`` for GM(0,N)), as in Abdulshahed et al. (2015):
    the bigger the coefficient, the bigger the sensor's influence.

    Sensors and displacement are taken as changes since the start of each run
    and accumulated (AGO) within each run only; the grey equations of all runs
    are solved together.

    A coefficient is in units of the displacement per unit of its sensor, as
    in the papers: give every sensor in the same unit (°C). A sensor in other
    units (e.g. thousandths) is ranked by a coefficient scaled by that
    factor; :class:`GRASelector` normalises the series and has no such
    dependence.

    Parameters
    ----------
    method : {"gm1n", "gm0n"}, default="gm1n"
        Grey model used for the ranking.
    n_features_to_select : int, float or None, default=None
        Number of sensors to keep (an int), or a fraction of them (a float in
        (0, 1]). With neither this nor ``threshold`` set, half of the sensors
        are kept.
    threshold : float, {"mean", "median"} or None, default=None
        Keep sensors whose score is at least this value (combined with
        ``n_features_to_select`` when both are given).
    alpha : float, default=0.0
        0 solves the grey equations with SVD-based least squares (rank
        revealing; the minimum-norm solution when sensors are collinear);
        > 0 adds a ridge penalty on unit-norm columns.

    Attributes
    ----------
    scores_ : ndarray of shape (n_features_in_,)
        Influence of every sensor. With several targets, the mean over
        targets of the scores scaled to a maximum of one per target.
    ranking_ : ndarray of shape (n_features_in_,)
        Rank of every sensor, 1 = most influential.
    coef_ : ndarray of shape (n_targets, n_features_in_)
        Signed driving coefficients ``b_j`` (GM(1,N)) or ``theta_j`` (GM(0,N)).
    development_coef_ : ndarray of shape (n_targets,)
        GM(1,N) development coefficient ``a`` (NaN for GM(0,N)).
    support_ : ndarray of bool of shape (n_features_in_,)
        Mask of the kept sensors.
    n_features_in_ : int
        Number of sensors seen in ``fit``.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Sensor names, when ``X`` was a DataFrame.

    See Also
    --------
    GRASelector : ranking by grey relational analysis.
    FCMClusterPicker : one representative sensor per fuzzy cluster.
    skthermal.grey.gm1n : the GM(1,N) model as an array function.

    Notes
    -----
    GM(1,N): ``x_1^(0)(k) + a z_1^(1)(k) = sum_j b_j x_j^(1)(k)`` (METHODS §3;
    Abdulshahed et al. 2015, eq. 10-13). GM(0,N): ``z_1^(1)(k) = sum_j theta_j
    x_j^(1)(k)`` (METHODS §2). GM(1,N) needs more samples than sensors: with
    ``n`` sensors and ``r`` runs at least ``n + 1 + r`` rows.

    Run labels come from ``groups`` (or metadata routing of ``groups``), a
    ``run`` column, or a ``run`` index level; see
    :class:`~skthermal.selection.RunAwareSelector`.

    Examples
    --------
    >>> from skthermal import GreyInfluenceSelector
    >>> from skthermal.datasets import make_sensor_groups
    >>> runs, truth = make_sensor_groups(random_state=0)
    >>> X, y = runs[truth.index], runs["disp_y_um"]
    >>> sel = GreyInfluenceSelector(n_features_to_select=5)
    >>> sel.fit(X, y, groups=runs["run"]).transform(X).shape
    (720, 5)
    """

    _PER_SENSOR = {"scores_": (-1,), "coef_": (-1,)}

    _parameter_constraints: dict = {
        **ScoreSelector._parameter_constraints,
        "method": [StrOptions({"gm1n", "gm0n"})],
        "alpha": [Interval(Real, 0, None, closed="left")],
    }

    def _counts_rows(self):
        return True

    def __init__(
        self, method="gm1n", *, n_features_to_select=None, threshold=None, alpha=0.0
    ):
        self.method = method
        self.n_features_to_select = n_features_to_select
        self.threshold = threshold
        self.alpha = alpha

    def _scores_per_target(self, X, Y, groups):
        coef, dev = [], []
        for k in range(Y.shape[1]):
            if self.method == "gm1n":
                a, b = gm1n(Y[:, k], X, groups=groups, alpha=self.alpha)
            else:
                a, b = np.nan, gm0n(Y[:, k], X, groups=groups, alpha=self.alpha)
            coef.append(b)
            dev.append(a)
        self.coef_ = np.array(coef)
        self.development_coef_ = np.array(dev)
        return np.abs(self.coef_)


class GRASelector(ScoreSelector):
    """Rank sensors by grey relational analysis with the thermal error.

    Compares the zero-initial image (change since the start of each run) of
    every sensor with that of the displacement and keeps the sensors whose
    curves are most alike: by the similitude degree of the thesis (001 §3.7.3),
    Liu's absolute degree, or Deng's relational grade.

    Parameters
    ----------
    method : {"similitude", "absolute", "deng"}, default="similitude"
        Relational degree (see :func:`skthermal.grey.grey_relational_grade`).
    normalize : {"range", "std"} or None, default="range"
        Each zero-initial image is divided by its range (or standard deviation)
        over the training rows before comparison, so sensors in °C and
        displacements in µm are comparable. ``None`` compares raw units, which
        makes the similitude and absolute degrees depend on the units.
    rho : float in (0, 1], default=0.5
        Distinguishing coefficient of Deng's grade.
    n_features_to_select : int, float or None, default=None
        Number of sensors to keep (an int), or a fraction of them (a float in
        (0, 1]). With neither this nor ``threshold`` set, half of the sensors
        are kept.
    threshold : float, {"mean", "median"} or None, default=None
        Keep sensors whose degree is at least this value.

    Attributes
    ----------
    scores_ : ndarray of shape (n_features_in_,)
        Relational degree of every sensor. With several targets, the mean
        over targets of the degrees scaled to a maximum of one per target.
    ranking_ : ndarray of shape (n_features_in_,)
        Rank of every sensor, 1 = most related.
    support_ : ndarray of bool of shape (n_features_in_,)
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (n_features_in_,)

    See Also
    --------
    GreyInfluenceSelector : ranking by grey-model influence coefficients.

    Notes
    -----
    METHODS §4. Degrees are computed per run and averaged, weighted by the
    runs' lengths. Run labels as in :class:`GreyInfluenceSelector`.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal import GRASelector
    >>> t = np.linspace(0, 1, 60)
    >>> X = np.c_[np.sin(7 * t), t ** 2, 1 - np.exp(-3 * t)]
    >>> y = 4 * (1 - np.exp(-3 * t))
    >>> sel = GRASelector(n_features_to_select=1).fit(X, y, groups=np.zeros(60))
    >>> sel.get_support().tolist()
    [False, False, True]
    """

    _parameter_constraints: dict = {
        **ScoreSelector._parameter_constraints,
        "method": [StrOptions({"similitude", "absolute", "deng"})],
        "normalize": [StrOptions({"range", "std"}), None],
        "rho": [Interval(Real, 0, 1, closed="right")],
    }

    def __init__(
        self,
        method="similitude",
        *,
        normalize="range",
        rho=0.5,
        n_features_to_select=None,
        threshold=None,
    ):
        self.method = method
        self.normalize = normalize
        self.rho = rho
        self.n_features_to_select = n_features_to_select
        self.threshold = threshold

    def _scores_per_target(self, X, Y, groups):
        return np.array(
            [
                grey_relational_grade(
                    Y[:, k],
                    X,
                    method=self.method,
                    rho=self.rho,
                    normalize=self.normalize,
                    groups=groups,
                )
                for k in range(Y.shape[1])
            ]
        )
