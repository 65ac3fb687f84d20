"""Grey regressors: GMC(1,N) calibrated by a particle swarm, and GNNMCI(1,N).

METHODS §7-9 (001 §3.6 and Appendix A, 002). Thin scikit-learn wrappers around
the array functions of :mod:`skthermal.grey._gmc` and
:func:`skthermal.optimize.particle_swarm`; what is specific to them is that the
rows are time-ordered samples of runs, so everything that uses time restarts at
every run boundary.
"""

import warnings
from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, _fit_context
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import _num_samples, check_is_fitted, validate_data

from skthermal.grey._ago import iago
from skthermal.grey._gmc import (
    _coef_shift,
    _GMCObjective,
    _gnnmci_sse,
    _model_runs,
    _run_scales,
    _scale_runs,
    _tien_ls,
    _unscale_coef,
    gmc_time_response,
    gnnmci_time_response,
)
from skthermal.grey._varpro import _gmc_varpro, _gnnmci_ridge
from skthermal.optimize._pso import particle_swarm
from skthermal.utils._runs import (
    check_one_target,
    check_run_lengths,
    check_time_order,
    continued_runs,
    extract_runs,
    run_memory,
    run_slices,
    run_times,
    warn_absolute_target,
    warn_row_gaps,
    warn_short_runs,
    warn_unlabelled_runs,
)
from skthermal.utils._threads import single_threaded_blas
from skthermal.utils._warnings import user_stacklevel


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
        "inertia": [Interval(Real, 0, None, closed="left"), tuple, list],
        "velocity_clamp": [
            None,
            Interval(Real, 0, None, closed="neither"),
            "array-like",
        ],
        "bounds": [StrOptions({"auto"}), "array-like"],
        "random_state": ["random_state"],
    }

    def _runs_for_fit(self, X, y, groups):
        check_one_target(type(self).__name__, y, f"{type(self).__name__}()")
        X, groups = extract_runs(X, groups, y=y)
        check_time_order(X, groups)
        slices, labels = run_slices(groups, _num_samples(X))
        warn_row_gaps(type(self).__name__, X, slices, labels, stacklevel=6)
        frame = X
        X, y = validate_data(self, X, y, y_numeric=True, dtype=np.float64)
        y = np.asarray(y, dtype=float)
        check_run_lengths(slices, labels, type(self).__name__)
        spans = run_times(frame, slices)
        if spans is not None:
            warn_short_runs(
                type(self).__name__,
                dict(zip(labels, spans[:, 1] - spans[:, 0], strict=True)),
                stacklevel=user_stacklevel(),
            )
        warn_unlabelled_runs(
            type(self).__name__, None, groups, X.shape[0], X=frame, stacklevel=5
        )
        warn_absolute_target(type(self).__name__, y, slices)
        return X, y, slices, labels, run_memory(X, slices, labels, frame)

    def _runs_for_predict(self, X, groups):
        """Validated inputs, the runs and, per run, the state it continues."""
        check_is_fitted(self)
        X, groups = extract_runs(X, groups)
        check_time_order(X, groups)
        n = _num_samples(X)
        slices, labels = run_slices(groups, n)
        times = run_times(X, slices)
        frame = X
        X = validate_data(self, X, reset=False, dtype=np.float64)
        name = type(self).__name__
        warn_unlabelled_runs(name, len(self.run_states_) or None, groups, n)
        cont = continued_runs(name, X, slices, labels, times, self.run_states_)
        warn_row_gaps(name, frame, slices, labels, cont, self.run_states_)
        states = [None if lab is None else self.run_states_[lab] for lab in cont]
        return X, slices, states

    @staticmethod
    def _scaled_runs(runs):
        """``runs`` scaled to magnitude ~1, their binary exponents ``(ey, ex)``.

        The calibration runs on the target divided by ``2^ey`` and input j by
        ``2^ex_j`` (see :func:`skthermal.grey._gmc._scale_runs`), so that it
        neither overflows nor loses an input on data in any units; the fitted
        coefficients are scaled back by :meth:`_unscale`.
        """
        ey, ex = _run_scales(runs)
        return _scale_runs(runs, ey, ex), (ey, ex)

    def _unscale(self, theta, scales):
        """Coefficients of the scaled data in the units of the data."""
        names = getattr(self, "feature_names_in_", None)
        return _unscale_coef(theta, *scales, type(self).__name__, names)

    @staticmethod
    def _unscale_loss(loss, scales):
        """A sum of squares of the scaled target in the target's units squared."""
        with np.errstate(over="ignore", under="ignore"):
            return np.ldexp(loss, 2 * scales[0])

    def _warn_short_swarm(self, objective, found, exact, start):
        """ConvergenceWarning when the swarm ended more than 1% above the
        loss of the exact optimum ``exact`` (computed anyway, the default
        start ``start``): a random or least-squares start with the default
        budget ended at 80-760 times its loss, no better than a constant."""
        got, best = (
            float(objective(np.asarray(v)[None, :])[0]) for v in (found, exact)
        )
        if got > 1.01 * best + 1e-300:
            advice = (
                "Your bounds may leave the optimum out: widen them, or leave "
                "bounds='auto'."
                if self.init == start and not isinstance(self.bounds, str)
                else f"Start it there (init={start!r}, the default), or give it "
                "more particles and epochs."
            )
            warnings.warn(
                f"{type(self).__name__}: the swarm ended at a training loss "
                f"{got / best:.3g} times that of the exact optimum (init="
                f"{self.init!r}, {self.n_particles} particles, {self.epochs} "
                f"epochs). {advice}",
                ConvergenceWarning,
                stacklevel=4,
            )

    def _swarm(self, objective, box, init, rng, shift):
        """The particle swarm on the scaled coefficients (``box`` is scaled).

        A ``velocity_clamp`` is in the units of the coefficients: it is scaled
        with them, so the swarm takes the same steps as on unscaled data.
        """
        clamp = self.velocity_clamp
        if clamp is not None:
            try:
                v = np.asarray(clamp, dtype=float)
            except (TypeError, ValueError):
                v = None  # particle_swarm says what is wrong with it
            if (
                v is not None
                and v.ndim <= 1
                and v.size in (1, shift.size)
                and np.all(np.isfinite(v))
                and np.all(v > 0)
            ):
                v = np.broadcast_to(v.ravel(), shift.shape)
                with np.errstate(over="ignore", under="ignore"):
                    v = np.ldexp(v, shift)
                tiny, big = np.finfo(float).tiny, np.finfo(float).max
                clamp = np.clip(v, tiny, big)
        return particle_swarm(
            objective,
            box,
            n_particles=self.n_particles,
            epochs=self.epochs,
            c1=self.c1,
            c2=self.c2,
            inertia=self.inertia,
            velocity_clamp=clamp,
            init=init,
            random_state=rng,
        )

    @staticmethod
    def _scaled_box(box, shift):
        """A user's search box ``(low, high)`` per coefficient, scaled."""
        with np.errstate(over="ignore", under="ignore"):
            out = np.ldexp(box, shift[:, None])
        if not np.all(np.isfinite(out)):
            raise ValueError(
                "bounds are beyond the float range once the data are brought to "
                "magnitude ~1 (bounds of some 1e300 on data of very different "
                "scales): give bounds closer to the expected coefficients."
            )
        return out

    def _finite_prediction(self, out):
        """``out``, or a ValueError where the prediction left the float range."""
        bad = ~np.isfinite(out)
        if bad.any():
            raise ValueError(
                f"{type(self).__name__}.predict: the prediction is beyond the "
                f"float range at {int(bad.sum())} row(s) (first: row "
                f"{int(np.flatnonzero(bad)[0])}): the inputs there are far outside "
                "the range the model was fitted on. Check their units."
            )
        return out

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # A time-series model: on rows drawn independently (as in the generic
        # checks) there is no dynamics to learn, so no R^2 can be promised.
        tags.regressor_tags.poor_score = True
        return tags

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, *, groups=None):
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
        X, y, slices, labels, memory = self._runs_for_fit(X, y, groups)
        # The runs in the order of their labels, not of their rows: the same
        # runs stacked in another order (files read in another glob order)
        # give the same cross-validation folds of alpha="auto", so the same
        # model (0.24 µm apart before).
        order = np.argsort([str(label) for label in labels], kind="stable")
        # The matrix products of training are small (n_samples x n_features,
        # times n_particles per epoch): a multi-threaded BLAS only adds
        # synchronisation, several times their cost on a busy machine. As
        # scikit-learn's KMeans does, keep BLAS on one thread meanwhile.
        with single_threaded_blas():
            self._fit(X, y, [slices[r] for r in order])
        self.run_states_ = self._end_states(X, slices, memory)
        return self


class GreyPSORegressor(_GreyRunRegressor):
    """Grey model with convolution integral GMC(1,N), calibrated on its output.

    The model (METHODS §7, 001 §3.6, 002 eq. 1-2) is the grey differential
    equation ``dx_1^(1)/dt + b1 x_1^(1) = sum_j b_j x_j^(1) + u`` on the 1-AGO of
    the target ``x_1`` and of the inputs ``x_2..x_N``; its time response is a
    convolution integral, evaluated exactly on the integer time grid by a
    recursion, and the prediction is the IAGO of that response.

    Parameters
    ----------
    calibration : {"varpro", "pso", "ls"}, default="varpro"
        How the coefficients are found. "varpro" and "pso" minimise the papers'
        objective, the sum of squared errors of the restored series (after
        IAGO) over all training runs, plus the ridge term of ``alpha``.
        "varpro" (variable projection) finds its global minimum: for a fixed
        ``b1`` the restored series is linear in ``(b_2..b_N, u)``, so a grid of
        ``b1`` values, each with a linear least-squares solve (all in one
        batch), followed by a bounded scalar refinement of ``b1``, leaves
        nothing for a swarm to improve. "pso" runs the papers' particle swarm
        on the same objective, one particle starting from the variable
        projection solution by default (see ``init``). "ls" is Tien's least
        squares on the discretised equation (see :func:`gmc1n`). The papers'
        own set-up is ``calibration="pso", alpha=0.0``.
    alpha : float >= 0 or "auto", default="auto"
        Ridge term ``alpha sum_j (g(b1) ||dx_j|| b_j)^2`` on the driving
        coefficients, ``dx_j`` being the changes of input j since the run start
        and ``g(b1) = 0.5 (1 + e^{-b1}) / (1 - e^{-b1} + 1/n)`` the response's
        static gain: it shrinks what each input contributes to the prediction,
        as a ridge on unit-norm columns, whatever the time constant (so it
        does not favour slow, integrating models). Many collinear sensors
        (temperatures that all follow the same heat) otherwise receive large
        opposite coefficients that cancel on the training runs and not beyond.
        "auto" chooses it on the training data only, from 0 and 1e-6..1e2, by
        cross-validation of the restored series: leave-runs-out with several
        training runs, forward chaining over 5 contiguous blocks with one run,
        with the one-standard-error rule (see Notes). With
        ``calibration="ls"`` a float is the ridge of :func:`gmc1n` and "auto"
        means Tien's plain least squares (0).
    n_particles : int, default=90
        Swarm size (001 used 90).
    epochs : int, default=100
        Swarm updates.
    c1, c2 : float, default=2.0
        Self- and swarm-confidence factors.
    inertia : float or (float, float), default=(0.9, 0.4)
        Inertia weight, constant or decreasing linearly over the epochs (a
        pair as a tuple or a list, as configuration files give it).
    velocity_clamp : float or array-like of shape (n_features + 2,), default=None
        Largest velocity per coefficient; None: the width of the search box.
    delay : int, default=0
        The target at sample k is driven by the inputs at sample ``k - delay``
        (the delay r of 001 eq. 3.13). Inputs before a run's first sample are
        taken equal to it (the machine at rest before the run).
    bounds : "auto" or array-like of shape (n_features + 2, 2), default="auto"
        Search box of ``(b1, b_2..b_N, u)``. "auto" centres it on the
        variable-projection solution ``(b1*, b*, u*)``: ``b1`` in
        ``[0, max(4 b1*, 10 / n)]``, each ``b_j`` in
        ``b*_j ± (2 |b*_j| + (b1_max + 1/n) s_y / s_j)``, ``u`` in
        ``u* ± (2 |u*| + s_y)``, with ``n`` the mean run length and ``s_y``,
        ``s_j`` the root-mean-square changes (since the run start) of the target
        and of input j. ``(b1 + 1/n) s_y / s_j`` is the size of a coefficient
        that moves the restored series by the target's own scale, both for a
        slow model (``b1 n << 1``, the response integrates ``f``) and a fast
        one (``b1 n >> 1``, the response follows ``f / b1``). The lower bound of
        ``b1`` must be ``>= 0`` (stable models only). With
        ``calibration="varpro"`` only the range of ``b1`` is used (the search
        grid spans it); ignored when ``calibration="ls"``.
    init : {"varpro", "ls", "random"}, default="varpro"
        Start of the swarm (``calibration="pso"``): one particle at the
        variable-projection solution (the swarm's loss is then that of
        "varpro", which it cannot improve), or at Tien's least-squares
        solution, or every particle uniformly in the box ("random").
    random_state : int, RandomState instance or None, default=None
        Seeds the swarm; the same seed gives the same coefficients.

    Attributes
    ----------
    coef_ : ndarray of shape (n_features,)
        ``(b_2, ..., b_N)``: one driving coefficient per input, in the order
        of the columns of ``X`` (scikit-learn's layout, so ``RFE`` and
        ``SelectFromModel`` read one weight per feature).
    development_coef_ : float
        ``b1``, the development coefficient.
    control_ : float
        ``u``, the grey control parameter.
    alpha_ : float
        The ridge term used (chosen by cross-validation for ``alpha="auto"``).
    loss_ : float
        Sum of squared errors of the restored series on the training runs
        (without the ridge term).
    history_ : ndarray
        Best objective (with the ridge term) after the initial swarm and after
        every epoch (one entry for "varpro" and "ls").
    n_iter_ : int
        Epochs run (0 for "varpro" and "ls").
    run_states_ : dict
        Per run label seen in ``fit``: what continuing that run in ``predict``
        needs (its length, first inputs, first and last ``time_s``, the
        accumulated inputs and the convolution integral at its last row, its
        last ``delay`` inputs). Empty when ``fit`` got no run labels.
    n_features_in_ : int
        Number of input series seen in ``fit``.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Names of the input series, when ``X`` has string column names.

    See Also
    --------
    GNNMCIRegressor : The grey neural network GNNMCI(1,N).
    skthermal.grey.gmc1n : Least-squares calibration as a plain function.
    skthermal.grey.gmc1n_varpro : Variable projection as a plain function.
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

    *Runs across fit and predict.* A run label seen in ``fit`` continues that
    run in ``predict``: after a chronological split of a labelled table (e.g.
    from :func:`skthermal.datasets.split_runs`), ``predict`` on the later rows
    gives what predicting the whole run would give on them, from the state
    kept in ``run_states_`` (the change since the run's first *training*
    sample). A labelled run whose first row is the run's first training row
    (same first ``time_s``; without a time index, same first inputs) is
    predicted again from its start, so training rows can be re-predicted; one
    whose first ``time_s`` is inside the span seen in ``fit`` is an error, and
    one that starts before it (``fit`` had a later part of the run) is
    predicted from its own first row, as the run's start. Without a time
    index, rows of a seen run that do not start with its first training row
    are taken to follow its last one. A run not seen in
    ``fit`` starts at its first row, with a warning if its ``time_s`` does not
    start at 0. Rows without run labels given to a model fitted on labelled
    runs are taken as one new run, with a warning. ``fit`` on rows with
    neither run labels nor ``time_s`` (a plain array, as a scikit-learn step
    that outputs numpy makes of a run table) takes them as one run, with a
    warning (rows with a ``time_s``, or with ``groups``, say where runs
    start). ``time_s`` must increase strictly within a run, in ``fit`` and in
    ``predict``.

    Tien's least squares fits the trapezoidal (Tustin) discretisation of the
    equation, one step at a time (an equation error), while the prediction
    integrates it with ``e^{-b1}`` over the whole run (an output error). With
    noise on the target, or fast dynamics, the two optima differ and the swarm,
    which fits the prediction itself, is the better calibration (001 Table 6-4:
    RMSE 3.16 versus 7.26 µm). Variable projection minimises that same
    objective exactly; the swarm remains to reproduce the papers, and its
    objective is evaluated for the whole swarm in one call, vectorised over
    the particles.

    With ``alpha="auto"`` the cross-validation simulates the model through the
    held-out rows from the inputs alone (an output-error model uses no target
    value there) and scores it on them; with one training run each of its
    later blocks is predicted by a model fitted on the blocks before it, as a
    chronological split asks. With five runs or more the folds hold out whole
    runs; with two to four, blocks of runs (each run cut so that there are at
    least five folds). Among the ``alpha`` values whose mean held-out error
    is within one standard error of the best, the largest is taken.

    *Units.* The calibration runs on the target and on each input divided by a
    power of two near its largest change (exact in floating point), and the
    coefficients are scaled back: the fit neither overflows on a target of
    1e80 nor loses an input of 1e-80 beside the constant ``u``, and a target
    in other units (``y * c``) gives ``c`` times the predictions. ``alpha`` is
    relative (to the squared error) and ``bounds`` and ``velocity_clamp`` are
    in the units of the coefficients, so they keep their meaning. A
    coefficient that no float can hold (a target some 1e300 times larger than
    an input's changes) is a ``ValueError``, as is a prediction beyond the
    float range.

    References: A. M. Abdulshahed, PhD thesis (2015), §3.6 and Table 6-4;
    Abdulshahed et al., GNNMCI(1,N) for environmental thermal error (2015).

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.grey import GreyPSORegressor
    >>> t = np.arange(300.0)
    >>> X = np.c_[20 + 6 * (1 - np.exp(-t / 60)), 21 + 3 * (1 - np.exp(-t / 150))]
    >>> y = 4.0 * (X[:, 0] - 20) + 2.5 * (X[:, 1] - 21)
    >>> run = np.full(300, "test-1")  # the rows are one test run
    >>> model = GreyPSORegressor().fit(X[:100], y[:100], groups=run[:100])
    >>> model.coef_.shape  # one driving coefficient per input
    (2,)
    >>> pred = model.predict(X, groups=run)  # change since the run's start
    >>> bool(np.sqrt(np.mean((pred - y) ** 2)) < 0.05 * np.ptp(y))
    True

    A run label seen in ``fit`` continues that run in ``predict``:

    >>> tail = model.predict(X[100:], groups=run[100:])
    >>> bool(np.allclose(tail, pred[100:]))
    True
    """

    _parameter_constraints: dict = {
        **_GreyRunRegressor._parameter_constraints,
        "calibration": [StrOptions({"varpro", "pso", "ls"})],
        "alpha": [Interval(Real, 0, None, closed="left"), StrOptions({"auto"})],
        "delay": [Interval(Integral, 0, None, closed="left")],
        "init": [StrOptions({"varpro", "ls", "random"})],
    }

    def __init__(
        self,
        *,
        calibration="varpro",
        alpha="auto",
        n_particles=90,
        epochs=100,
        c1=2.0,
        c2=2.0,
        inertia=(0.9, 0.4),
        velocity_clamp=None,
        delay=0,
        bounds="auto",
        init="varpro",
        random_state=None,
    ):
        self.calibration = calibration
        self.alpha = alpha
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
        longest = max(sl.stop - sl.start for sl in slices)
        if self.delay >= longest - 1:
            raise ValueError(
                f"delay={self.delay} samples leaves no input change inside any "
                f"run: the longest run has {longest} samples, so every target "
                "would be driven by the inputs held at the run's start. Give a "
                f"delay below {longest - 1} (samples, not seconds)."
            )
        runs, scales = self._scaled_runs(_model_runs(y, X, slices, delay=self.delay))
        shift = _coef_shift(*scales)
        n_coef = X.shape[1] + 2
        n_eq = X.shape[0] - len(slices)
        if self.calibration == "ls" and n_eq < n_coef:
            raise ValueError(
                f"Too few samples for {X.shape[1]} input series: least squares has "
                f"{n_coef} unknowns but only {n_eq} equations (one per sample after "
                f"the first of each run; {X.shape[0]} samples in {len(slices)} "
                "run(s)). Use more samples, fewer inputs or calibration='varpro'."
            )
        user_box = (
            None
            if isinstance(self.bounds, str)
            else self._scaled_box(
                _user_box(self.bounds, n_coef, "(b1, b_2..b_N, u)"), shift
            )
        )
        if self.calibration == "ls":
            alpha = 0.0 if isinstance(self.alpha, str) else float(self.alpha)
            theta = _tien_ls(runs, alpha)
            self.alpha_ = alpha
            objective = _GMCObjective(runs)
            self.n_iter_ = 0
            self.history_ = objective(theta[None, :])
        else:
            b1_bounds = None if user_box is None else user_box[0]
            theta_vp, self.alpha_, scale = _gmc_varpro(
                runs, self.alpha, b1_bounds=b1_bounds
            )
            objective = _GMCObjective(runs, alpha=self.alpha_, scale=scale)
            if self.calibration == "varpro":
                theta = theta_vp
                self.n_iter_ = 0
                self.history_ = objective(theta[None, :])
            else:
                seed = {"varpro": theta_vp, "ls": _tien_ls(runs), "random": None}[
                    self.init
                ]
                box = self._auto_box(theta_vp, runs) if user_box is None else user_box
                rng = check_random_state(self.random_state)
                res = self._swarm(objective, box, seed, rng, shift)
                theta = res.x
                self._warn_short_swarm(objective, theta, theta_vp, "varpro")
                self.n_iter_ = res.nit
                self.history_ = res.history
        theta = np.asarray(theta, dtype=float)
        loss = float(_GMCObjective(runs)(theta[None, :])[0])
        theta = self._unscale(theta, scales)
        self.development_coef_ = float(theta[0])
        self.coef_ = np.array(theta[1:-1], dtype=float)
        self.control_ = float(theta[-1])
        self.loss_ = float(self._unscale_loss(loss, scales))
        self.history_ = self._unscale_loss(self.history_, scales)
        if self.calibration == "ls":
            # Tien's least squares fit the grey equation, not the restored
            # series: on (nearly) collinear inputs the series can explode.
            n_rows = sum(r[1].shape[0] for r in runs)
            rmse = np.sqrt(loss / max(n_rows, 1))
            spread = _run_stats(runs)[1]
            if not rmse <= 10.0 * max(spread, np.finfo(float).tiny):
                # In the target's units for the message.
                rmse, spread = (np.ldexp(v, scales[0]) for v in (rmse, spread))
                warnings.warn(
                    f"GreyPSORegressor: calibration='ls' fits the training "
                    f"rows with an RMSE of {rmse:.3g}, {rmse / spread:.3g} "
                    f"times their change ({spread:.3g}; "
                    f"b1={self.development_coef_:.3g}): "
                    "least squares fit the grey equation, not the prediction, "
                    "and failed here (collinear inputs). Use "
                    "calibration='varpro'.",
                    ConvergenceWarning,
                    stacklevel=3,
                )
        return self

    @staticmethod
    def _auto_box(theta, runs):
        n_mean, s_y, s_x = _run_stats(runs)
        b1_max = max(4.0 * theta[0], 10.0 / n_mean)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(s_x > 0, (b1_max + 1.0 / n_mean) * s_y / s_x, 1.0)
        half = np.r_[2 * np.abs(theta[1:-1]) + scale, 2 * abs(theta[-1]) + s_y]
        centre = theta[1:]
        return np.vstack([[0.0, b1_max], np.c_[centre - half, centre + half]])

    def _end_states(self, X, slices, memory):
        """Per labelled run: what continuing it needs (see :meth:`predict`)."""
        b1, b, u = self.development_coef_, self.coef_, self.control_
        d = self.delay
        for sl, state in zip(slices, memory.values(), strict=False):
            Xr = X[sl]
            ((X1, _),) = _model_runs(None, Xr, [slice(0, Xr.shape[0])], delay=d)
            ind = gmc_time_response(X1, b1, b, u)
            idx = np.maximum(np.arange(Xr.shape[0] - d, Xr.shape[0]), 0)
            state.update(
                X1_end=X1[-1],
                I_end=float(ind[-1]),
                f_end=float(X1[-1] @ b + u),
                tail=Xr[idx],
            )
        return memory

    def _continue(self, X, state):
        """Restored series of rows that follow the training rows of a run."""
        b1, b, u = self.development_coef_, self.coef_, self.control_
        d = self.delay
        Xd = np.vstack([state["tail"], X])[: X.shape[0]] if d else X
        X1 = state["X1_end"] + np.cumsum(Xd - state["x_first"], axis=0)
        J = gmc_time_response(X1, b1, b, u)  # convolution from zero at row 1
        a = np.exp(-b1)
        i1 = a * state["I_end"] + 0.5 * (a * state["f_end"] + X1[0] @ b + u)
        with np.errstate(under="ignore"):
            ind = J + i1 * a ** np.arange(X.shape[0], dtype=float)
        return np.diff(ind, prepend=state["I_end"])

    def predict(self, X, *, groups=None):
        """Predicted change of the target since the first sample of each run.

        A run whose label was seen in ``fit`` *continues* that run: rows that
        come after its training rows are predicted from the state at the end of
        them (change since the first training sample), so the later part of a
        run can be predicted alone. See Notes for the rules.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Input series of one or more runs (run labels as in ``fit``).
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,)
            Zero on the first sample of every run predicted from its start.
        """
        X, slices, states = self._runs_for_predict(X, groups)
        b1, b, u = self.development_coef_, self.coef_, self.control_
        out = np.empty(X.shape[0])
        with np.errstate(over="ignore", invalid="ignore"):
            for sl, state in zip(slices, states, strict=True):
                if state is None:
                    ((X1, _),) = _model_runs(
                        None, X[sl], [slice(0, sl.stop - sl.start)], delay=self.delay
                    )
                    out[sl] = iago(gmc_time_response(X1, b1, b, u))
                else:
                    out[sl] = self._continue(X[sl], state)
        return self._finite_prediction(out)


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
        Inertia weight, constant or decreasing linearly (001: 0.9 to 0.4); a
        pair as a tuple or a list.
    velocity_clamp : float or array-like of shape (n_features + 2,), default=1.5
        Largest velocity per weight (002: ±1.5), in the weights' units (target
        units per input unit: 1.5 suits µm and °C); None: the width of the
        box, which scales with the data.
    bounds : "auto" or array-like of shape (n_features + 2, 2), default="auto"
        Search box of ``(w11, w2_2..w2_{N-1}, w2N)``. "auto": ``w11`` in
        ``[0, 1]``, each input weight in ``±3 s_y / s_j`` and ``w2N`` in
        ``±2 s_y``, with ``s_y``, ``s_j`` the root-mean-square changes (since
        the run start) of the target and of input j; ``s_y / s_j`` is the weight
        with which input j alone would reproduce the target's scale. Collinear
        inputs can need larger weights: if a weight ends on the wall of the
        box, pass wider bounds; the box always holds the ridge solution (see
        ``init``). The lower bound of ``w11`` must be ``>= 0``.
    alpha : float >= 0 or "auto", default="auto"
        Ridge term ``alpha sum_j (||dx_j|| w2j)^2`` added to the swarm's
        objective, ``dx_j`` being the changes of input j since the run start
        (a ridge on unit-norm columns): it keeps collinear sensors from
        receiving large opposite weights. "auto" chooses it on the training
        data only by cross-validation, as :class:`GreyPSORegressor` does.
        ``alpha=0.0`` is the papers' objective.
    init : {"ridge", "random"}, default="ridge"
        Start of the swarm: one particle at the exact minimiser of the
        objective (a ridge regression, see Notes), the others uniformly in the
        box; or every particle uniformly in the box ("random", as the papers).
    random_state : int, RandomState instance or None, default=None
        Seeds the swarm; the same seed gives the same weights.

    Attributes
    ----------
    weights_ : ndarray of shape (n_features + 2,)
        ``(w11, w2_2, ..., w2_{N-1}, w2N)``: the development weight, one weight
        per input, the constant weight.
    alpha_ : float
        The ridge term used (chosen by cross-validation for ``alpha="auto"``).
    loss_ : float
        Sum of squared errors of the restored series on the training runs
        (without the ridge term).
    history_ : ndarray of shape (n_iter_ + 1,)
        Best objective (with the ridge term) after the initial swarm and after
        every epoch.
    n_iter_ : int
        Epochs run.
    run_states_ : dict
        Per run label seen in ``fit``: what continuing that run in ``predict``
        needs (its length, first inputs, first and last ``time_s``). Empty
        when ``fit`` got no run labels.
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
    ``cross_validate`` reach the splitter, not ``predict``). A run label seen in
    ``fit`` continues that run in ``predict``, with the rules and warnings
    described in the Notes of :class:`GreyPSORegressor`; the training runs
    on scaled data as described there (*Units*), the default
    ``velocity_clamp=1.5`` being in the weights' units.

    With the target taken as its change since the run start,
    ``x_1^(1)(1) = 0``: the ``e^{-w11 k}`` term vanishes, ``w11`` no longer
    affects the predictions, and after IAGO the network is the linear model
    ``xhat_1^(0)(k) = sum_j w2j (x_j(k) - x_j(1))`` for k >= 2 (``w2N`` only
    sets the first sample, where the target is 0). The swarm still trains
    ``w11`` as in the papers. The objective, with the ridge term, is then a
    ridge regression without intercept whose exact solution (``w2N = 0``)
    seeds the swarm by default, so the swarm cannot end worse than it. The
    seeds print the bias ``theta`` with
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
    >>> run = np.full(300, "test-1")  # the rows are one test run
    >>> model = GNNMCIRegressor(n_particles=30, epochs=60, random_state=0)
    >>> model.fit(X[:100], y[:100], groups=run[:100]).weights_.shape
    (4,)
    >>> pred = model.predict(X, groups=run)
    >>> bool(np.sqrt(np.mean((pred - y) ** 2)) < 0.05 * np.ptp(y))
    True
    """

    _parameter_constraints: dict = {
        **_GreyRunRegressor._parameter_constraints,
        "alpha": [Interval(Real, 0, None, closed="left"), StrOptions({"auto"})],
        "init": [StrOptions({"ridge", "random"})],
    }

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
        alpha="auto",
        init="ridge",
        random_state=None,
    ):
        self.alpha = alpha
        self.init = init
        self.n_particles = n_particles
        self.epochs = epochs
        self.c1 = c1
        self.c2 = c2
        self.inertia = inertia
        self.velocity_clamp = velocity_clamp
        self.bounds = bounds
        self.random_state = random_state

    def _fit(self, X, y, slices):
        runs, scales = self._scaled_runs(_model_runs(y, X, slices))
        shift = _coef_shift(*scales)
        n_w = X.shape[1] + 2
        seed, self.alpha_, xnorm = _gnnmci_ridge(runs, self.alpha)
        if isinstance(self.bounds, str):
            _, s_y, s_x = _run_stats(runs)
            with np.errstate(divide="ignore", invalid="ignore"):
                half = np.where(s_x > 0, 3.0 * s_y / s_x, 1.0)
            # Collinear inputs can need larger weights than one input alone:
            # the box always holds the ridge solution with room around it.
            half = np.maximum(half, 2.0 * np.abs(seed[1:-1]))
            box = np.vstack(
                [[0.0, 1.0], np.column_stack([-half, half]), [-2 * s_y, 2 * s_y]]
            )
            seed[0] = 0.5
        else:
            box = self._scaled_box(
                _user_box(self.bounds, n_w, "(w11, w2_2..w2_{N-1}, w2N)"), shift
            )
        alpha = self.alpha_

        def objective(W):
            loss = _gnnmci_sse(W, runs)
            if alpha > 0:
                loss += alpha * np.sum((W[:, 1:-1] * xnorm) ** 2, axis=1)
            return loss

        rng = check_random_state(self.random_state)
        init = seed if self.init == "ridge" else None
        res = self._swarm(objective, box, init, rng, shift)
        self._warn_short_swarm(objective, res.x, seed, "ridge")
        self.weights_ = self._unscale(res.x, scales)
        loss = _gnnmci_sse(res.x[None, :], runs)[0]
        self.loss_ = float(self._unscale_loss(loss, scales))
        self.history_ = self._unscale_loss(res.history, scales)
        self.n_iter_ = res.nit
        return self

    def _end_states(self, X, slices, memory):
        # The restored series of a continued run needs only its first row.
        return memory

    def predict(self, X, *, groups=None):
        """Predicted change of the target since the first sample of each run.

        A run whose label was seen in ``fit`` *continues* that run (see the
        Notes of :class:`GreyPSORegressor` for the rules).

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
        X, slices, states = self._runs_for_predict(X, groups)
        out = np.empty(X.shape[0])
        with np.errstate(over="ignore", invalid="ignore"):
            for sl, state in zip(slices, states, strict=True):
                if state is None:
                    ((X1, _),) = _model_runs(
                        None, X[sl], [slice(0, sl.stop - sl.start)]
                    )
                    out[sl] = iago(gnnmci_time_response(X1, self.weights_))
                else:
                    out[sl] = (X[sl] - state["x_first"]) @ self.weights_[1:-1]
        return self._finite_prediction(out)
