"""Grey regressors: GMC(1,N) calibrated by a particle swarm, and GNNMCI(1,N).

METHODS §7-9 (001 §3.6 and Appendix A, 002). Thin scikit-learn wrappers around
the array functions of :mod:`skthermal.grey._gmc` and
:func:`skthermal.optimize.particle_swarm`; what is specific to them is that the
rows are time-ordered samples of runs, so everything that uses time restarts at
every run boundary.
"""

from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted, validate_data

from skthermal.grey._ago import iago
from skthermal.grey._gmc import (
    _GMCObjective,
    _gnnmci_sse,
    _model_runs,
    _tien_ls,
    gmc_time_response,
    gnnmci_time_response,
)
from skthermal.optimize._pso import particle_swarm
from skthermal.utils._runs import check_run_lengths, extract_runs, run_slices
from skthermal.utils._threads import single_threaded_blas


def _rms(A):
    return np.sqrt(np.mean(np.square(A), axis=0))


def _run_stats(runs):
    """Mean run length, rms target change and rms input change per input."""
    y0 = np.concatenate([r[1] for r in runs])
    dX = np.concatenate([np.diff(r[0], axis=0, prepend=0.0) for r in runs])
    n_mean = y0.shape[0] / len(runs)
    return n_mean, float(_rms(y0)), _rms(dX)


def _user_box(bounds, n_dims, what):
    box = np.asarray(bounds, dtype=float)
    if box.shape != (n_dims, 2):
        raise ValueError(
            f"bounds must have shape ({n_dims}, 2), one (low, high) pair for "
            f"{what}; got shape {box.shape}."
        )
    if not np.all(np.isfinite(box)) or np.any(box[:, 0] > box[:, 1]):
        raise ValueError("bounds must be finite (low, high) pairs with low <= high.")
    if box[0, 0] < 0:
        raise ValueError(
            f"The lower bound of the first coefficient must be >= 0, got "
            f"{box[0, 0]}: a negative development coefficient makes the model "
            "grow exponentially (unstable)."
        )
    return box


class _GreyRunRegressor(RegressorMixin, BaseEstimator):
    """Shared run handling and validation of the grey regressors."""

    _parameter_constraints: dict = {
        "n_particles": [Interval(Integral, 1, None, closed="left")],
        "epochs": [Interval(Integral, 0, None, closed="left")],
        "c1": [Interval(Real, 0, None, closed="left")],
        "c2": [Interval(Real, 0, None, closed="left")],
        "inertia": [Interval(Real, 0, None, closed="left"), tuple],
        "velocity_clamp": [
            None,
            Interval(Real, 0, None, closed="neither"),
            "array-like",
        ],
        "bounds": [StrOptions({"auto"}), "array-like"],
        "random_state": ["random_state"],
    }

    def _runs_for_fit(self, X, y, groups):
        X, groups = extract_runs(X, groups)
        X, y = validate_data(self, X, y, y_numeric=True, dtype=np.float64)
        y = np.asarray(y, dtype=float)
        slices, labels = run_slices(groups, X.shape[0])
        check_run_lengths(slices, labels, type(self).__name__)
        return X, y, slices

    def _runs_for_predict(self, X, groups):
        check_is_fitted(self)
        X, groups = extract_runs(X, groups)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        slices, _ = run_slices(groups, X.shape[0])
        return X, slices

    def _swarm(self, objective, box, init, rng):
        return particle_swarm(
            objective,
            box,
            n_particles=self.n_particles,
            epochs=self.epochs,
            c1=self.c1,
            c2=self.c2,
            inertia=self.inertia,
            velocity_clamp=self.velocity_clamp,
            init=init,
            random_state=rng,
        )

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # A time-series model: on rows drawn independently (as in the generic
        # checks) there is no dynamics to learn, so no R^2 can be promised.
        tags.regressor_tags.poor_score = True
        return tags

    def fit(self, X, y, groups=None):
        """Calibrate the model on one or more training runs.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Input series (e.g. temperatures), time-ordered within each run; a
            DataFrame may carry the run labels in a ``run`` column or index
            level.
        y : array-like of shape (n_samples,)
            Target series (e.g. a thermal displacement).
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        self : object
            The fitted estimator.
        """
        self._validate_params()
        X, y, slices = self._runs_for_fit(X, y, groups)
        # The matrix products of training are small (n_samples x n_features,
        # times n_particles per epoch): a multi-threaded BLAS only adds
        # synchronisation, several times their cost on a busy machine. As
        # scikit-learn's KMeans does, keep BLAS on one thread meanwhile.
        with single_threaded_blas():
            return self._fit(X, y, slices)


class GreyPSORegressor(_GreyRunRegressor):
    """Grey model with convolution integral GMC(1,N), calibrated by PSO or LS.

    The model (METHODS §7, 001 §3.6, 002 eq. 1-2) is the grey differential
    equation ``dx_1^(1)/dt + b1 x_1^(1) = sum_j b_j x_j^(1) + u`` on the 1-AGO of
    the target ``x_1`` and of the inputs ``x_2..x_N``; its time response is a
    convolution integral, evaluated exactly on the integer time grid by a
    recursion, and the prediction is the IAGO of that response.

    Parameters
    ----------
    calibration : {"pso", "ls"}, default="pso"
        "pso" minimises the sum of squared errors of the restored series (after
        IAGO) over all training runs with a particle swarm; "ls" is Tien's
        least squares on the discretised equation (see :func:`gmc1n`).
    n_particles : int, default=90
        Swarm size (001 used 90).
    epochs : int, default=100
        Swarm updates.
    c1, c2 : float, default=2.0
        Self- and swarm-confidence factors.
    inertia : float or (float, float), default=(0.9, 0.4)
        Inertia weight, constant or decreasing linearly over the epochs.
    velocity_clamp : float or array-like of shape (n_features + 2,), default=None
        Largest velocity per coefficient; None: the width of the search box.
    delay : int, default=0
        The target at sample k is driven by the inputs at sample ``k - delay``
        (the delay r of 001 eq. 3.13). Inputs before a run's first sample are
        taken equal to it (the machine at rest before the run).
    bounds : "auto" or array-like of shape (n_features + 2, 2), default="auto"
        Search box of ``(b1, b_2..b_N, u)``. "auto" centres it on the
        least-squares solution: ``b1`` in ``[0, max(4 b1_LS, 10 / n)]``, each
        ``b_j`` in ``b_j,LS ± (2 |b_j,LS| + (b1_max + 1/n) s_y / s_j)``, ``u`` in
        ``u_LS ± (2 |u_LS| + s_y)``, with ``n`` the mean run length and ``s_y``,
        ``s_j`` the root-mean-square changes (since the run start) of the target
        and of input j. ``(b1 + 1/n) s_y / s_j`` is the size of a coefficient
        that moves the restored series by the target's own scale, both for a
        slow model (``b1 n << 1``, the response integrates ``f``) and a fast
        one (``b1 n >> 1``, the response follows ``f / b1``). The lower bound of
        ``b1`` must be ``>= 0`` (stable models only). Ignored when
        ``calibration="ls"``.
    init : {"ls", "random"}, default="ls"
        "ls" starts one particle at the least-squares solution (so the swarm's
        training loss is never worse than that of least squares); "random"
        starts every particle uniformly in the box.
    random_state : int, RandomState instance or None, default=None
        Seeds the swarm; the same seed gives the same coefficients.

    Attributes
    ----------
    coef_ : ndarray of shape (n_features + 2,)
        ``(b1, b_2, ..., b_N, u)``: the development coefficient, one driving
        coefficient per input, the grey control parameter.
    loss_ : float
        Sum of squared errors of the restored series on the training runs.
    history_ : ndarray
        Best loss after the initial swarm and after every epoch (one entry for
        ``calibration="ls"``).
    n_iter_ : int
        Epochs run (0 for least squares).
    n_features_in_ : int
        Number of input series seen in ``fit``.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Names of the input series, when ``X`` has string column names.

    See Also
    --------
    GNNMCIRegressor : The grey neural network GNNMCI(1,N).
    skthermal.grey.gmc1n : Least-squares calibration as a plain function.
    skthermal.optimize.particle_swarm : The optimiser.

    Notes
    -----
    Rows are time-ordered samples of one or more *runs* (tests). Run labels come
    from the ``groups`` argument of ``fit``/``predict``, else from a ``run``
    column of a DataFrame (removed from the features), else from a ``run`` level
    of its index; without any, all rows form one run (so a plain array is one
    run). The rows of a run must be contiguous. AGO and the model's time
    response restart at every run and never cross a boundary; the training
    objective sums over the training runs.

    Inputs and target are taken as changes since the first sample of their run
    (METHODS §1). The first displacement of a run is not known at prediction
    time, so ``predict`` returns the predicted *change of the target since the
    first sample of each run*: zero on that sample. A run's prediction depends
    only on that run's rows, so it is the same whether the run is predicted
    alone or inside a table of several runs, and ``cross_validate`` with
    ``GroupKFold`` over runs is correct when the runs travel with the rows (a
    ``run`` column or index level: ``groups`` passed to ``cross_validate`` reach
    the splitter, not ``predict``).

    Tien's least squares fits the trapezoidal (Tustin) discretisation of the
    equation, one step at a time (an equation error), while the prediction
    integrates it with ``e^{-b1}`` over the whole run (an output error). With
    noise on the target, or fast dynamics, the two optima differ and the swarm,
    which fits the prediction itself, is the better calibration (001 Table 6-4:
    RMSE 3.16 versus 7.26 µm). The objective is evaluated for the whole swarm
    in one call, vectorised over the particles.

    References: A. M. Abdulshahed, PhD thesis (2015), §3.6 and Table 6-4;
    Abdulshahed et al., GNNMCI(1,N) for environmental thermal error (2015).

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.grey import GreyPSORegressor
    >>> t = np.arange(300.0)
    >>> X = np.c_[20 + 6 * (1 - np.exp(-t / 60)), 21 + 3 * (1 - np.exp(-t / 150))]
    >>> y = 4.0 * (X[:, 0] - 20) + 2.5 * (X[:, 1] - 21)
    >>> model = GreyPSORegressor(n_particles=30, epochs=40, random_state=0)
    >>> model.fit(X[:100], y[:100]).coef_.shape
    (4,)
    >>> pred = model.predict(X)  # change since the run's first sample
    >>> bool(np.sqrt(np.mean((pred - y) ** 2)) < 0.05 * np.ptp(y))
    True
    """

    _parameter_constraints: dict = {
        **_GreyRunRegressor._parameter_constraints,
        "calibration": [StrOptions({"pso", "ls"})],
        "delay": [Interval(Integral, 0, None, closed="left")],
        "init": [StrOptions({"ls", "random"})],
    }

    def __init__(
        self,
        *,
        calibration="pso",
        n_particles=90,
        epochs=100,
        c1=2.0,
        c2=2.0,
        inertia=(0.9, 0.4),
        velocity_clamp=None,
        delay=0,
        bounds="auto",
        init="ls",
        random_state=None,
    ):
        self.calibration = calibration
        self.n_particles = n_particles
        self.epochs = epochs
        self.c1 = c1
        self.c2 = c2
        self.inertia = inertia
        self.velocity_clamp = velocity_clamp
        self.delay = delay
        self.bounds = bounds
        self.init = init
        self.random_state = random_state

    def _fit(self, X, y, slices):
        runs = _model_runs(y, X, slices, delay=self.delay)
        n_coef = X.shape[1] + 2
        n_eq = X.shape[0] - len(slices)
        if self.calibration == "ls" and n_eq < n_coef:
            raise ValueError(
                f"Too few samples for {X.shape[1]} input series: least squares has "
                f"{n_coef} unknowns but only {n_eq} equations (one per sample after "
                f"the first of each run; {X.shape[0]} samples in {len(slices)} "
                "run(s)). Use more samples, fewer inputs or calibration='pso'."
            )
        theta_ls = _tien_ls(runs)
        objective = _GMCObjective(runs)
        if self.calibration == "ls":
            theta = theta_ls
            self.n_iter_ = 0
            self.history_ = objective(theta[None, :])
        else:
            box = (
                self._auto_box(theta_ls, runs)
                if isinstance(self.bounds, str)
                else _user_box(self.bounds, n_coef, "(b1, b_2..b_N, u)")
            )
            init = theta_ls if self.init == "ls" else None
            rng = check_random_state(self.random_state)
            res = self._swarm(objective, box, init, rng)
            theta = res.x
            self.n_iter_ = res.nit
            self.history_ = res.history
        self.coef_ = np.asarray(theta, dtype=float)
        self.loss_ = float(objective(self.coef_[None, :])[0])
        return self

    @staticmethod
    def _auto_box(theta_ls, runs):
        n_mean, s_y, s_x = _run_stats(runs)
        b1_max = max(4.0 * theta_ls[0], 10.0 / n_mean)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(s_x > 0, (b1_max + 1.0 / n_mean) * s_y / s_x, 1.0)
        half = np.r_[2 * np.abs(theta_ls[1:-1]) + scale, 2 * abs(theta_ls[-1]) + s_y]
        centre = theta_ls[1:]
        return np.vstack([[0.0, b1_max], np.c_[centre - half, centre + half]])

    def predict(self, X, groups=None):
        """Predicted change of the target since the first sample of each run.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Input series of one or more runs (run labels as in ``fit``).
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,)
            Zero on the first sample of every run.
        """
        X, slices = self._runs_for_predict(X, groups)
        b1, b, u = self.coef_[0], self.coef_[1:-1], self.coef_[-1]
        out = np.empty(X.shape[0])
        for (X1, _), sl in zip(
            _model_runs(None, X, slices, delay=self.delay), slices, strict=True
        ):
            out[sl] = iago(gmc_time_response(X1, b1, b, u))
        return out


class GNNMCIRegressor(_GreyRunRegressor):
    """Grey neural network with convolution integral GNNMCI(1,N), PSO-trained.

    The four-layer network of 001 Appendix A and 002 §2 (METHODS §8), trained
    on the weights ``(w11, w2j)`` by a particle swarm that minimises the sum of
    squared errors of the restored series over the training runs. Its output
    reduces exactly to the closed form
    ``xhat_1^(1)(k) = x_1^(1)(1) e^{-w11 k} + sum_j w2j x_j^(1)(k) + w2N``
    (see :func:`skthermal.grey.gnnmci_layers`), which training evaluates for
    the whole swarm at once; the prediction is its IAGO.

    Parameters
    ----------
    n_particles : int, default=90
        Swarm size (001 and 002 used 90).
    epochs : int, default=100
        Swarm updates (001: 100; 002: 10).
    c1 : float, default=1.5
        Self-confidence factor (001).
    c2 : float, default=2.0
        Swarm-confidence factor (001).
    inertia : float or (float, float), default=(0.9, 0.4)
        Inertia weight, constant or decreasing linearly (001: 0.9 to 0.4).
    velocity_clamp : float or array-like of shape (n_features + 2,), default=1.5
        Largest velocity per weight (002: ±1.5); None: the width of the box.
    bounds : "auto" or array-like of shape (n_features + 2, 2), default="auto"
        Search box of ``(w11, w2_2..w2_{N-1}, w2N)``. "auto": ``w11`` in
        ``[0, 1]``, each input weight in ``±3 s_y / s_j`` and ``w2N`` in
        ``±2 s_y``, with ``s_y``, ``s_j`` the root-mean-square changes (since
        the run start) of the target and of input j; ``s_y / s_j`` is the weight
        with which input j alone would reproduce the target's scale. Collinear
        inputs can need larger weights: if a weight ends on the wall of the
        box, pass wider bounds. The lower bound of ``w11`` must be ``>= 0``.
    random_state : int, RandomState instance or None, default=None
        Seeds the swarm; the same seed gives the same weights.

    Attributes
    ----------
    weights_ : ndarray of shape (n_features + 2,)
        ``(w11, w2_2, ..., w2_{N-1}, w2N)``: the development weight, one weight
        per input, the constant weight.
    loss_ : float
        Sum of squared errors of the restored series on the training runs.
    history_ : ndarray of shape (n_iter_ + 1,)
        Best loss after the initial swarm and after every epoch.
    n_iter_ : int
        Epochs run.
    n_features_in_ : int
        Number of input series seen in ``fit``.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Names of the input series, when ``X`` has string column names.

    See Also
    --------
    GreyPSORegressor : GMC(1,N) with the convolution integral.
    skthermal.grey.gnnmci_layers : The layered forward pass.

    Notes
    -----
    Rows are time-ordered samples of one or more *runs* (tests). Run labels come
    from the ``groups`` argument of ``fit``/``predict``, else from a ``run``
    column of a DataFrame (removed from the features), else from a ``run`` level
    of its index; without any, all rows form one run (so a plain array is one
    run). The rows of a run must be contiguous. AGO and the model's time
    response restart at every run and never cross a boundary; the training
    objective sums over the training runs.

    Inputs and target are taken as changes since the first sample of their run
    (METHODS §1). The first displacement of a run is not known at prediction
    time, so ``predict`` returns the predicted *change of the target since the
    first sample of each run* (on that sample, the network's own value
    ``xhat_1^(1)(1) = w2N``, which training drives towards 0). A run's
    prediction depends only on that run's rows, so it is the same whether the
    run is predicted alone or inside a table of several runs, and
    ``cross_validate`` with ``GroupKFold`` over runs is correct when the runs
    travel with the rows (a ``run`` column or index level: ``groups`` passed to
    ``cross_validate`` reach the splitter, not ``predict``).

    With the target taken as its change since the run start,
    ``x_1^(1)(1) = 0``: the ``e^{-w11 k}`` term vanishes, ``w11`` no longer
    affects the predictions, and after IAGO the network is the linear model
    ``xhat_1^(0)(k) = sum_j w2j (x_j(k) - x_j(1))`` for k >= 2 (``w2N`` only
    sets the first sample, where the target is 0). The swarm still trains
    ``w11`` as in the papers. The seeds print the bias ``theta`` with
    ``x_1^(1)(k+1)``, the target itself; METHODS §8 reads it as the initial
    value, which is what is implemented.

    References: A. M. Abdulshahed, PhD thesis (2015), Appendix A;
    Abdulshahed et al., GNNMCI(1,N) for environmental thermal error (2015).

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.grey import GNNMCIRegressor
    >>> t = np.arange(300.0)
    >>> X = np.c_[20 + 6 * (1 - np.exp(-t / 60)), 21 + 3 * (1 - np.exp(-t / 150))]
    >>> y = 4.0 * (X[:, 0] - 20) + 2.5 * (X[:, 1] - 21)
    >>> model = GNNMCIRegressor(n_particles=30, epochs=60, random_state=0)
    >>> model.fit(X[:100], y[:100]).weights_.shape
    (4,)
    >>> pred = model.predict(X)
    >>> bool(np.sqrt(np.mean((pred - y) ** 2)) < 0.05 * np.ptp(y))
    True
    """

    def __init__(
        self,
        *,
        n_particles=90,
        epochs=100,
        c1=1.5,
        c2=2.0,
        inertia=(0.9, 0.4),
        velocity_clamp=1.5,
        bounds="auto",
        random_state=None,
    ):
        self.n_particles = n_particles
        self.epochs = epochs
        self.c1 = c1
        self.c2 = c2
        self.inertia = inertia
        self.velocity_clamp = velocity_clamp
        self.bounds = bounds
        self.random_state = random_state

    def _fit(self, X, y, slices):
        runs = _model_runs(y, X, slices)
        n_w = X.shape[1] + 2
        if isinstance(self.bounds, str):
            _, s_y, s_x = _run_stats(runs)
            with np.errstate(divide="ignore", invalid="ignore"):
                half = np.where(s_x > 0, 3.0 * s_y / s_x, 1.0)
            box = np.vstack(
                [[0.0, 1.0], np.column_stack([-half, half]), [-2 * s_y, 2 * s_y]]
            )
        else:
            box = _user_box(self.bounds, n_w, "(w11, w2_2..w2_{N-1}, w2N)")
        rng = check_random_state(self.random_state)
        res = self._swarm(lambda W: _gnnmci_sse(W, runs), box, None, rng)
        self.weights_ = res.x
        self.loss_ = res.fun
        self.history_ = res.history
        self.n_iter_ = res.nit
        return self

    def predict(self, X, groups=None):
        """Predicted change of the target since the first sample of each run.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Input series of one or more runs (run labels as in ``fit``).
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,)
        """
        X, slices = self._runs_for_predict(X, groups)
        out = np.empty(X.shape[0])
        for (X1, _), sl in zip(_model_runs(None, X, slices), slices, strict=True):
            out[sl] = iago(gnnmci_time_response(X1, self.weights_))
        return out
