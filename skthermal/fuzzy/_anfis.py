"""ANFISRegressor: the scikit-learn estimator around the ANFIS core.

METHODS §6 (000 §2, 001 §3.3, 003 §5; Jang 1993); the array-level algorithm
lives in :mod:`skthermal.fuzzy._anfis_core`.
"""

import numbers
import warnings

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin, _fit_context
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_array, check_is_fitted, validate_data

from skthermal._naming import shown
from skthermal.fuzzy._anfis_core import (
    _HALF,
    _CheckingSet,
    _rmse,
    anfis_predict,
    anfis_train,
    fcm_mf_params,
    grid_mf_params,
    grid_rules,
)
from skthermal.fuzzy._membership import MF_PARAMS, membership
from skthermal.grey._ago import ago, iago
from skthermal.utils._runs import (
    check_time_order,
    continued_runs,
    extract_runs,
    is_commanded,
    run_memory,
    run_slices,
    run_times,
    warn_row_gaps,
    warn_unlabelled_runs,
)
from skthermal.utils._threads import single_threaded_blas
from skthermal.utils._warnings import user_stacklevel

# --------------------------------------------------------------------------
# The estimator
# --------------------------------------------------------------------------


def _ago_by_run(X, groups):
    """AGO restarting at every run, each run accumulated on its own.

    Accumulating run by run (rather than over the stacked table, then
    subtracting offsets) makes a run's series bit-for-bit independent of the
    rows around it.
    """
    slices, _ = run_slices(groups, X.shape[0])
    out = np.empty_like(X)
    for sl in slices:
        out[sl] = ago(X[sl])
    return out


def _tail_split(slices, n, fraction):
    """Boolean mask of the last ``fraction`` of the rows of every run."""
    val = np.zeros(n, dtype=bool)
    for sl in slices:
        length = sl.stop - sl.start
        k = min(int(round(fraction * length)), length - 1)
        if k > 0:
            val[sl.stop - k : sl.stop] = True
    if not val.any():
        raise ValueError(
            f"validation_fraction={fraction} holds out no rows of {n} samples; "
            "use a larger fraction or pass X_val and y_val."
        )
    return val


class _EpochHook:
    """Stand-in for the checking set that calls ``epoch_callback`` every epoch.

    ``anfis_train`` scores its checking set exactly once per epoch, after the
    training error and before the early-stopping logic, so wrapping the
    checking set gives a per-epoch hook without touching the training loop.
    It returns the monitored error unchanged (the checking RMSE, or the
    training RMSE when there is no checking set), or NaN once the callback
    asks to stop, which ends the loop. Because that epoch is then not a
    candidate for the kept parameters inside ``anfis_train``, the hook keeps
    its own record of the best epoch.
    """

    def __init__(self, callback, checking, X_train, Y_train):
        self.callback = callback
        self.checking = checking
        self.X = X_train
        self.Y = Y_train
        self.monitored = []
        self.best = None
        self.stopped = False

    def rmse(self, mf_params, rules, consequents, mf):
        epoch = len(self.monitored) + 1
        pred = anfis_predict(self.X, mf_params, rules, consequents, mf)
        train = float(_rmse(pred - self.Y))
        check = None
        if self.checking is not None:
            check = float(self.checking.rmse(mf_params, rules, consequents, mf))
        monitored = train if check is None else check
        self.monitored.append(monitored)
        if np.isfinite(monitored) and (self.best is None or monitored < self.best[0]):
            self.best = (monitored, mf_params.copy(), consequents.copy(), epoch)
        if self.callback(epoch, train, check):
            self.stopped = True
            return np.nan
        return monitored

    def fix_result(self, result):
        """Undo the traces of the hook in the result of ``anfis_train``."""
        history = result["history"]
        if self.checking is None:
            history.pop("val_rmse", None)
        elif self.stopped:
            history["val_rmse"][-1] = self.monitored[-1]
        if self.stopped and self.best is not None:
            _, result["mf_params"], result["consequents"], result["best_epoch"] = (
                self.best
            )
        return result


# Elements (8 bytes each) of the least-squares problem of one epoch above
# which fit warns: the design matrix and the normal equations (or their
# dual) of the consequents.
_LARGE_PROBLEM = 5e7


def _warn_large_problem(n_rules, n_features, n_samples):
    """Warn when the consequents' least squares take gigabytes every epoch."""
    columns = n_rules * (n_features + 1)
    elements = n_samples * columns + min(n_samples, columns) ** 2
    if elements <= _LARGE_PROBLEM:
        return
    warnings.warn(
        f"ANFISRegressor: {n_rules} rules x {n_features + 1} consequents = "
        f"{columns} unknowns on {n_samples} rows: every epoch's least squares "
        f"handles about {8 * elements / 1e9:.1f} GB and takes long. Use "
        "init='fcm' (a few rules), fewer inputs or membership functions.",
        UserWarning,
        stacklevel=4,
    )


# Below this ridge (relative, as ``ridge`` is) consequents with more
# unknowns than training rows are left to the rounding: fit warns.
_UNDERDETERMINED_RIDGE = 1e-3


def _warn_underdetermined(n_rules, n_features, n_samples, ridge, chosen=False):
    """Warn when the consequents have more unknowns than training rows and
    no ridge worth the name fixes them (``chosen``: the ridge is the one
    ``ridge="auto"`` picked)."""
    columns = n_rules * (n_features + 1)
    if columns <= n_samples or ridge >= _UNDERDETERMINED_RIDGE:
        return
    if chosen:
        fix = (
            f"ridge='auto' picked {ridge:g} from ridge_grid on a checking set "
            "that cannot tell such fits apart: give a ridge_grid from "
            f"{_UNDERDETERMINED_RIDGE:g}, or a ridge of "
            f"{_UNDERDETERMINED_RIDGE:g} .. 1."
        )
    else:
        fix = f"or a ridge of {_UNDERDETERMINED_RIDGE:g} .. 1 (or ridge='auto')."
    warnings.warn(
        f"ANFISRegressor: {n_rules} rules x {n_features + 1} consequents = "
        f"{columns} unknowns on {n_samples} training rows: more unknowns than "
        "rows, so the data do not fix the consequents (the fit then depends "
        "on the rows' order and on rounding, and extrapolates far). Use fewer "
        "membership functions (n_mfs) or inputs, init='fcm' with a few rules, "
        f"{fix}",
        UserWarning,
        stacklevel=4,
    )


# A premise step longer than this many times an input's span moves its
# membership functions far outside the data (train R^2 0.99 -> 0.79 on
# temperatures given in units 1e5 times too large); one shorter than the
# span divided by this ratio squared barely moves them (inputs given 1e6
# times too large: 30 epochs end where the first did).
_STEP_SPAN_RATIO = 1000.0


# Inputs whose spans differ by more than this factor are trained unevenly:
# the premise step and the consequents' ridge are in the inputs' units.
_MIXED_SCALES = 100.0


# With grey=True, inputs centred on zero (mean within this share of their
# standard deviation) accumulate into running sums that turn back.
_CENTRED_SHARE = 0.1


def _warn_grey_signs(X, names):
    """Warn when ``grey=True`` gets centred (standardised) inputs: half of
    them or more with a mean near zero and values of both signs. Grey models
    accumulate non-negative series; a centred input's running sum turns
    back, so one accumulated value stands for several states of the run, and
    the restored (differenced) predictions amplify the fit's errors
    (training R^2 1.0 on changes since the run start, -215 on the same
    readings standardised). One signed input among others (a feed's
    direction, a sensor cooling below its start) is no cause: an independent
    check found such inputs fitted well."""
    if X.shape[0] < 2:
        return
    mean, std = X.mean(axis=0), X.std(axis=0)
    centred = (
        (std > 0)
        & (np.abs(mean) < _CENTRED_SHARE * std)
        & (X.min(axis=0) < 0)
        & (X.max(axis=0) > 0)
    )
    if not centred.any() or 2 * centred.sum() < X.shape[1]:
        return
    j = int(np.flatnonzero(centred)[0])
    more = f" (and {centred.sum() - 1} more)" if centred.sum() > 1 else ""
    warnings.warn(
        f"ANFISRegressor(grey=True): input {names[j]!r}{more} is centred on zero "
        f"(mean {mean[j]:.3g}, standard deviation {std[j]:.3g}), as standardised "
        "readings are. grey=True accumulates every input over its run, and a "
        "centred input's running sum turns back, so the model and the "
        "restored predictions can be far off. Give readings or changes since "
        "the run start, scaled without centring "
        "(StandardScaler(with_mean=False) or MaxAbsScaler).",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def _warn_grey_offsets(X, groups, names):
    """Warn when ``grey=True`` gets readings with an offset: half of the
    inputs or more start their runs further from zero than they move within
    a run (absolute °C, kelvin). Accumulated, the offset becomes a ramp in
    time that outweighs the thermal changes, the fit is made on the running
    sums, and the restored (differenced) predictions can be far worse than
    on changes since the run start (an independent check: 54-77 µm held out
    on absolute readings with free intercepts, 3 µm on changes, 16 µm for
    predicting zero). The grey regressors take changes since the run start
    for this reason."""
    slices, _ = run_slices(groups, X.shape[0])
    if X.shape[0] < 2 or not slices:
        return
    first = np.abs(np.stack([X[sl.start] for sl in slices]))
    span = np.stack([np.ptp(X[sl], axis=0) for sl in slices])
    offset = np.median(first, axis=0)
    moves = np.median(span, axis=0)
    # A speed or feed is a heat input whose running sum the grey model is
    # meant to integrate: its level is no offset.
    readings = ~np.array([is_commanded(n) for n in names])
    far = (offset > np.maximum(moves, 1e-12)) & readings
    if not far.any() or 2 * far.sum() < readings.sum():
        return
    j = int(np.flatnonzero(far)[np.argmax((offset / np.maximum(moves, 1e-300))[far])])
    more = f" (and {far.sum() - 1} more)" if far.sum() > 1 else ""
    warnings.warn(
        f"ANFISRegressor(grey=True): input {names[j]!r}{more} starts its runs at "
        f"{offset[j]:.3g} (median over the runs) and moves {moves[j]:.3g} within "
        "a run: readings with an offset (absolute °C, kelvin). grey=True "
        "accumulates every input over its run, so the offset becomes a ramp in "
        "time that outweighs the thermal changes, and the restored predictions "
        "can be far off (most with penalize_intercepts=False). Give changes "
        "since the run start (skthermal.datasets.changes_since_start), as the "
        "grey regressors take them.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def _warn_input_scales(step_size, X, names, grey=False):
    """Warn when the premise step (in the inputs' units) dwarfs an input's
    span (the gradient steps throw its functions off the data) or is far
    too short for the inputs' spans (they barely move), and when the
    inputs' spans differ by more than :data:`_MIXED_SCALES` (spindle speed
    in rpm beside temperatures in °C). ``grey``: ``X`` are the accumulated
    inputs of ``grey=True``, which a scaler in front must not centre."""
    if grey:
        scale = standardise = (
            "Scale the inputs without centring them (StandardScaler(with_mean="
            "False) or MaxAbsScaler in front; grey=True accumulates them, and "
            "centred readings accumulate into drifting sums)"
        )
    else:
        scale = "Scale the inputs (a StandardScaler in front)"
        standardise = "Standardise the inputs (a StandardScaler in front)"
    span = np.ptp(X, axis=0) if X.shape[0] else np.zeros(X.shape[1])
    moving = np.flatnonzero(span > 0)
    if not moving.size:
        return
    j = moving[np.argmin(span[moving])]
    if 0 < step_size < span[j] / _STEP_SPAN_RATIO**2:
        warnings.warn(
            f"ANFISRegressor: step_size={step_size:g} is the length of each "
            f"premise step in the inputs' units, and the inputs span "
            f"{span[j]:.3g} or more: the membership functions will barely move "
            f"in training. {scale} or give a step_size of about "
            f"{0.01 * span[j]:.2g}.",
            UserWarning,
            stacklevel=4,
        )
    elif step_size > _STEP_SPAN_RATIO * span[j]:
        warnings.warn(
            f"ANFISRegressor: step_size={step_size:g} is the length of each "
            f"premise step in the inputs' units, and input {names[j]!r} spans "
            f"only {span[j]:.3g}: the membership functions would jump far "
            f"beyond the data. {scale} or give a step_size of about "
            f"{0.01 * span[j]:.2g}.",
            UserWarning,
            stacklevel=4,
        )
    hi = moving[np.argmax(span[moving])]
    if span[hi] > _MIXED_SCALES * span[j]:
        warnings.warn(
            f"ANFISRegressor: the inputs' spans differ by a factor of "
            f"{span[hi] / span[j]:.3g} ({names[hi]!r} spans {span[hi]:.3g}, "
            f"{names[j]!r} {span[j]:.3g}). The premise step and the consequents' "
            "ridge act in the inputs' units, so such inputs are trained and "
            "shrunk unevenly (a speed in rpm instead of krpm changes the "
            f"model). {standardise}.",
            UserWarning,
            stacklevel=4,
        )


class ANFISRegressor(RegressorMixin, BaseEstimator):
    """Adaptive neuro-fuzzy inference system (first-order Takagi-Sugeno).

    Rules ``IF x_1 is A_1r AND ... AND x_d is A_dr THEN f_r = p_r . x + q_r``;
    the output is the firing-strength-weighted mean of the rule outputs
    (METHODS §6). The rule base comes from fuzzy c-means (one rule per cluster,
    few rules, as in 000) or from a grid partition of the inputs (Jang 1993);
    training is Jang's hybrid rule: least squares for the consequents and a
    gradient step with an adaptive step size for the membership functions.

    Parameters
    ----------
    init : {"fcm", "grid"} or array-like of shape (n_features, n_mfs, n_params), \
default="fcm"
        Rule base. ``"fcm"``: one rule per fuzzy c-means cluster of the
        (standardised) inputs, each with its own membership function on every
        input, centred on the cluster centre, width from the membership-
        weighted spread. ``"grid"``: ``n_mfs`` functions per input evenly over
        the training range (Jang's initialisation) and one rule per
        combination, ``n_mfs ** n_features`` rules, first input slowest. An
        array gives the initial grid membership functions directly (parameters
        as ``mf``), e.g. the initial functions of a paper.
    n_clusters : int, default=3
        Number of rules with ``init="fcm"``.
    n_mfs : int, default=2
        Membership functions per input with ``init="grid"``.
    mf : {"gaussian", "gbell"}, default="gaussian"
        Membership function: Gaussian ``exp(-(x - c)^2 / (2 sigma^2))``,
        parameters ``(sigma, c)``, or generalised bell
        ``1 / (1 + |(x - c) / a|^(2b))``, parameters ``(a, b, c)``.
    epochs : int, default=100
        Maximum number of training epochs (full passes over the data).
    learning : {"hybrid", "backprop"}, default="hybrid"
        ``"hybrid"``: every epoch a least-squares solve of all consequents and
        a gradient step on the premise parameters (Jang). ``"backprop"``:
        gradient descent on all parameters, consequents starting as constant
        rules equal to the target mean; their steps are taken with the
        inputs centred on their training mean (``f = p (x - m) + q'``,
        stored as ``p x + q``), so an offset of the inputs (readings around
        20 °C, kelvin) changes nothing; they are stepped on standardised
        scales (a slope in units of the target's spread per the input's
        spread), so the units of a target (µm or nm) and of the inputs change
        their steps nothing. A backprop fit that never improves on
        its initial model warns (``ConvergenceWarning``).
    step_size : float, default=0.5
        Initial step size: the length of the gradient step in parameter space
        (the gradient is rescaled to this length, Jang 1993). It is in the
        units of the inputs: scale the inputs (e.g. ``StandardScaler``) or pick
        a smaller step (MATLAB's default is 0.01) for inputs spanning a
        narrow range.
    step_increase : float, default=1.2
        Factor applied to the step after four consecutive decreases of the
        training error.
    step_decrease : float, default=0.9
        Factor applied to the step after two consecutive up/down oscillations
        of the training error. As in MATLAB's ``anfis``, each of the two
        rules waits at least four epochs after it last changed the step
        before it can change it again.
    ridge : float or "auto", default=1e-8
        Ridge regularisation of the consequents' least-squares solve,
        relative to the mean diagonal of the normal equations: the same for
        any unit of the target, but not for the inputs' units (a column of
        large readings weighs in that mean; an input in rpm beside others in
        °C is shrunk unlike them, and fit warns): standardise the inputs
        for the ridge to act evenly. 0 uses the SVD-based minimum-norm
        least-squares solution. With
        ``penalize_intercepts=True`` it shrinks the consequents towards zero
        at inputs of zero: inputs far from zero (kelvin, absolute readings)
        then need centring or standardising first (a ``StandardScaler``), or
        ``penalize_intercepts=False`` (not with ``grey=True``, which needs
        changes since the run start), where the inputs are centred on their
        training mean for the solve (each rule's ``f = p (x - m) + q'`` is
        stored as ``p x + q``) and an offset changes only the constant
        terms. Many
        collinear inputs (e.g. neighbouring temperature sensors) make the
        consequents overfit; a larger ridge (1e-3 .. 1) shrinks them.
        ``"auto"`` picks it from ``ridge_grid``: by the checking set when
        there is one (``X_val``/``y_val`` or ``validation_fraction``), else by
        time-ordered cross-validation on the training rows (train on the
        first half of every run and check on its third quarter; train on the
        first three quarters and check on the last; mean checking RMSE); the
        model is then refitted on all training rows with the chosen value,
        stored in ``ridge_``.
    ridge_grid : array-like of float, default=(1e-8, 1e-6, 1e-4, 1e-3, 1e-2, \
0.1, 1.0)
        Candidate values for ``ridge="auto"``.
    penalize_intercepts : bool, default=True
        Whether the ridge also shrinks every rule's constant term. True
        shrinks all consequents towards zero: the prior of the papers'
        set-up, where inputs and target are changes since the run start and
        the error is zero where the temperature changes are. False shrinks
        the slopes only and leaves the constant terms free (with a
        stabilising ridge of 1e-8), as scikit-learn's ``Ridge`` leaves its
        intercept: use it with absolute readings, or any target that is far
        from zero where the inputs are, best on standardised inputs (a
        ``StandardScaler`` in front), where one rule then is exactly a
        ridge regression.
    validation_fraction : float in (0, 1) or None, default=None
        Hold out the last ``validation_fraction`` of the rows of every run
        (of all rows without runs) as checking data. The split is deterministic
        and keeps time order, as suits time series; shuffle beforehand, or
        pass ``X_val``/``y_val`` to ``fit``, for unordered data.
    tol : float, default=0.0
        Minimum decrease of the monitored error (checking RMSE if there is a
        checking set, else training RMSE) that counts as an improvement for
        ``n_iter_no_change``.
    n_iter_no_change : int or None, default=None
        Stop when the monitored error has not improved by more than ``tol`` for
        this many epochs; None trains all ``epochs``.
    grey : bool, default=False
        Grey-ANFIS (001 §6.2.2): train on the accumulated (AGO) series of the
        inputs and the target and return predictions through the inverse AGO.
        Accumulation restarts at every run (``groups``, a ``run`` column or a
        ``run`` index level). Give inputs as changes since the run start (as
        the grey regressors take them): an offset (absolute °C, kelvin)
        accumulates into a ramp in time, and ``fit`` warns. Every run is
        predicted from its own start, so a run's prediction does not depend
        on the other rows passed with it. A run label seen in ``fit``
        continues that run (its later rows given
        alone are predicted as inside the whole run), with the grey
        regressors' rules.
        A model fitted with run labels warns when ``predict`` gets rows
        without them (they would be taken as one run). Whenever the rows of a
        run are read in order (``grey``, ``validation_fraction``,
        ``ridge="auto"``), a ``time_s`` index level that does not increase
        within a run is an error.
    max_rules : int, default=4096
        Largest rule base a grid partition may create; a larger one raises a
        ValueError before anything is allocated. A rule base whose
        consequents' least squares take more than about 0.4 GB per epoch
        (rules x (inputs + 1) unknowns on the training rows) warns.
    random_state : int, RandomState instance or None, default=None
        Seeds the fuzzy c-means initialisation.
    verbose : int, default=0
        1 prints progress ten times during training, 2 every epoch.
    epoch_callback : callable or None, default=None
        Called after every epoch as ``epoch_callback(epoch, train_rmse,
        check_rmse)`` (``epoch`` 1-based; ``check_rmse`` None without a
        checking set); returning True stops training after that epoch,
        keeping the parameters of the best epoch so far. Used for pruning
        hyperparameter searches (:func:`skthermal.model_selection.run_search`).
        It is a training-time hook: a fitted estimator is pickled and saved
        without it (``epoch_callback=None`` after loading); one not yet
        fitted keeps it, so the copies trained in worker processes
        (``n_jobs > 1`` in scikit-learn's ``cross_validate`` or searches)
        call it there, and it must then pickle. Setting it costs one extra
        pass over the training data per epoch.

    Attributes
    ----------
    mf_params_ : ndarray of shape (n_features_in_, n_mfs, n_params)
        Trained membership functions: ``mf_params_[j, m]`` is ``(sigma, c)``
        or ``(a, b, c)`` of the m-th function of input j.
    initial_mf_params_ : ndarray of the same shape
        Membership functions before training.
    rules_ : ndarray of shape (n_rules_, n_features_in_)
        ``rules_[r, j]`` is the index of the membership function of input j
        in rule r.
    consequents_ : ndarray of shape (n_rules_, n_features_in_ + 1) or \
(n_rules_, n_features_in_ + 1, n_outputs_)
        Linear coefficients of every rule, then its constant.
    n_rules_ : int
        Number of rules.
    n_outputs_ : int
        Number of targets.
    history_ : dict of ndarray
        Per epoch: ``"epoch"`` (1-based), ``"train_rmse"`` (in AGO space when
        ``grey``), ``"step_size"`` (the step after that epoch's error was
        judged, i.e. the one the next epoch's gradient step takes) and, with
        a checking set, ``"val_rmse"`` (in the original space).
        ``pandas.DataFrame(history_)`` tabulates it.
    ridge_ : float
        Ridge used for the consequents (the chosen one with ``ridge="auto"``).
    ridge_scores_ : dict of float to float
        With ``ridge="auto"``: the checking RMSE of every candidate ridge.
    run_states_ : dict
        With ``grey=True``, per run label seen in ``fit``: what continuing
        that run in ``predict`` needs (its first row and times, the
        accumulated inputs and prediction at its last row). Empty otherwise.
    best_epoch_ : int
        Epoch whose parameters were kept: least checking RMSE, or least
        training RMSE without a checking set.
    n_iter_ : int
        Epochs run.
    n_features_in_ : int
        Number of features seen during fit (a ``run`` column is not one).
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Names of the features seen during fit, when X has string column names.

    See Also
    --------
    skthermal.fuzzy.fuzzy_cmeans : The clustering behind ``init="fcm"``.
    skthermal.grey.ago : The accumulated generating operation of ``grey=True``.

    Notes
    -----
    Jang, J.-S. R. (1993), "ANFIS: adaptive-network-based fuzzy inference
    system", IEEE Trans. SMC 23(3): layers eq. (1)-(5) of METHODS §6, hybrid
    learning §IV, step-size rule §III (also 003 §5). The firing strengths are
    normalised in log space (log-sum-exp of summed log-memberships), so inputs
    far outside the training range still give a finite output: that of the
    rule whose membership functions decay slowest there. That output is the
    rules' linear consequents evaluated at the input, so it grows linearly
    with an input far outside the training range (a sensor reading 1e6 gives
    a prediction of the order of 1e6 times a consequent slope); it is not
    clipped: wrap a deployed model in
    :class:`skthermal.compose.GuardedRegressor`. Abdulshahed et al.
    (000) found 3 FCM rules to beat a 243-rule grid for thermal error.

    Training runs its linear algebra on one BLAS thread, as scikit-learn's
    ``KMeans`` does for its iterations: an epoch is a chain of products too
    small to share well between threads, and on cores shared with other jobs
    waiting threads made a 1458-consequent grid three times slower (5.7 s
    against 1.9 s for 30 epochs on 2 busy cores). Parallelise over fits
    instead (``n_jobs`` of a search or of ``cross_validate``).

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.fuzzy import ANFISRegressor
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(-1, 1, size=(200, 2))
    >>> y = np.sin(2 * X[:, 0]) + X[:, 1] ** 2
    >>> model = ANFISRegressor(n_clusters=4, epochs=30, random_state=0).fit(X, y)
    >>> model.n_rules_
    4
    >>> bool(model.score(X, y) > 0.95)
    True
    """

    _parameter_constraints: dict = {
        "init": [StrOptions({"fcm", "grid"}), "array-like"],
        "n_clusters": [Interval(numbers.Integral, 1, None, closed="left")],
        "n_mfs": [Interval(numbers.Integral, 1, None, closed="left")],
        "mf": [StrOptions({"gaussian", "gbell"})],
        "epochs": [Interval(numbers.Integral, 1, None, closed="left")],
        "learning": [StrOptions({"hybrid", "backprop"})],
        "step_size": [Interval(numbers.Real, 0, None, closed="neither")],
        "step_increase": [Interval(numbers.Real, 1, None, closed="left")],
        "step_decrease": [Interval(numbers.Real, 0, 1, closed="right")],
        "ridge": [Interval(numbers.Real, 0, None, closed="left"), StrOptions({"auto"})],
        "ridge_grid": ["array-like"],
        "penalize_intercepts": ["boolean"],
        "validation_fraction": [
            Interval(numbers.Real, 0, 1, closed="neither"),
            None,
        ],
        "tol": [Interval(numbers.Real, 0, None, closed="left")],
        "n_iter_no_change": [Interval(numbers.Integral, 1, None, closed="left"), None],
        "grey": ["boolean"],
        "max_rules": [Interval(numbers.Integral, 1, None, closed="left")],
        "random_state": ["random_state"],
        "verbose": ["verbose"],
        "epoch_callback": [callable, None],
    }

    def __init__(
        self,
        *,
        init="fcm",
        n_clusters=3,
        n_mfs=2,
        mf="gaussian",
        epochs=100,
        learning="hybrid",
        step_size=0.5,
        step_increase=1.2,
        step_decrease=0.9,
        ridge=1e-8,
        ridge_grid=(1e-8, 1e-6, 1e-4, 1e-3, 1e-2, 0.1, 1.0),
        penalize_intercepts=True,
        validation_fraction=None,
        tol=0.0,
        n_iter_no_change=None,
        grey=False,
        max_rules=4096,
        random_state=None,
        verbose=0,
        epoch_callback=None,
    ):
        self.init = init
        self.n_clusters = n_clusters
        self.n_mfs = n_mfs
        self.mf = mf
        self.epochs = epochs
        self.learning = learning
        self.step_size = step_size
        self.step_increase = step_increase
        self.step_decrease = step_decrease
        self.ridge = ridge
        self.ridge_grid = ridge_grid
        self.penalize_intercepts = penalize_intercepts
        self.validation_fraction = validation_fraction
        self.tol = tol
        self.n_iter_no_change = n_iter_no_change
        self.grey = grey
        self.max_rules = max_rules
        self.random_state = random_state
        self.verbose = verbose
        self.epoch_callback = epoch_callback

    def __getstate__(self):
        # The callback is a training-time hook that usually closes over live
        # objects (an Optuna trial, a database connection): a fitted model
        # is saved without it. A model still to be trained keeps it, so that
        # the copies scikit-learn sends to worker processes (n_jobs > 1 in
        # cross_validate or a search) train as the model given would.
        state = super().__getstate__()
        if state.get("epoch_callback") is not None and "mf_params_" in state:
            state = {**state, "epoch_callback": None}
        return state

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        return tags

    # ---------------------------------------------------------------- fit

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, *, groups=None, X_val=None, y_val=None, groups_val=None):
        """Build the rule base and train it.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Inputs. A ``run`` column (or index level) holds run labels and is
            not a feature.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Targets. Several outputs share one rule base (the membership
            functions are trained on their summed squared error) and one
            ``ridge_``, each with its own consequents: an output then differs
            from one fitted alone, and may be worse (an independent check:
            0.149 against 0.103 µm); fit one model per target (e.g.
            ``sklearn.multioutput.MultiOutputRegressor``) for the best of each.
        groups : array-like of shape (n_samples,), optional
            Run labels (each run one contiguous block of rows); used by
            ``grey=True`` and by ``validation_fraction``. Overrides a ``run``
            column.
        X_val, y_val : array-like, optional
            Checking data: the parameters of the epoch with the least checking
            RMSE are kept. Cannot be combined with ``validation_fraction``.
        groups_val : array-like of shape (n_val_samples,), optional
            Run labels of ``X_val`` (for ``grey=True``).

        Returns
        -------
        self : ANFISRegressor
            The fitted estimator.
        """
        X, groups = extract_runs(X, groups, y=y)
        frame = X
        X, y = validate_data(
            self, X, y, multi_output=True, y_numeric=True, dtype=np.float64
        )
        Y = y.reshape(y.shape[0], -1)
        n, d = X.shape
        rng = check_random_state(self.random_state)
        if groups is not None:
            groups = np.asarray(groups)
            if groups.shape != (n,):
                raise ValueError(
                    f"groups must hold one run label per row ({n}), got shape "
                    f"{groups.shape}."
                )
        if self._uses_runs():
            check_time_order(frame, groups)
        if self.grey:
            warn_row_gaps(type(self).__name__, frame, *run_slices(groups, n))

        has_val = X_val is not None or y_val is not None
        if has_val and (X_val is None or y_val is None):
            raise ValueError("Pass both X_val and y_val, or neither.")
        if has_val and self.validation_fraction is not None:
            raise ValueError(
                "Give either validation_fraction or X_val/y_val, not both."
            )

        X_model, Y_model = X, Y
        if self.grey:
            _warn_grey_signs(X, self._feature_names())
            _warn_grey_offsets(X, groups, self._feature_names())
            X_model, Y_model = _ago_by_run(X, groups), _ago_by_run(Y, groups)

        checking = None
        train_rows = slice(None)
        if has_val:
            checking = self._explicit_checking(X_val, y_val, groups_val, Y.shape[1])
        elif self.validation_fraction is not None:
            slices, _ = run_slices(groups, n)
            val = _tail_split(slices, n, self.validation_fraction)
            train_rows = ~val
            checking = self._tail_checking(X_model, Y, groups, slices, val)

        X_train, Y_train = X_model[train_rows], Y_model[train_rows]
        mf_params, rules = self._initial_rule_base(X_train, rng)
        _warn_large_problem(rules.shape[0], X_train.shape[1], X_train.shape[0])
        if self.ridge != "auto":
            _warn_underdetermined(
                rules.shape[0], X_train.shape[1], X_train.shape[0], self.ridge
            )
        _warn_input_scales(
            self.step_size, X_train, self._feature_names(), grey=self.grey
        )

        ridge, result = self.ridge, None
        self.ridge_scores_ = {}
        if ridge == "auto":
            ridge, result = self._choose_ridge(
                X_model,
                Y_model,
                Y,
                groups,
                X_train,
                Y_train,
                mf_params,
                rules,
                checking,
                rng,
            )
            _warn_underdetermined(
                rules.shape[0], X_train.shape[1], X_train.shape[0], ridge, True
            )

        if result is None or self.epoch_callback is not None:
            hook = None
            if self.epoch_callback is not None:
                hook = _EpochHook(self.epoch_callback, checking, X_train, Y_train)
                checking = hook
            result = self._train(
                X_train, Y_train, mf_params, rules, ridge, checking, self.verbose
            )
            if hook is not None:
                result = hook.fix_result(result)
        self.ridge_ = float(ridge)
        self._n_fitted_runs = None
        if groups is not None:
            self._n_fitted_runs = len(run_slices(groups, n)[0])
        self.initial_mf_params_ = mf_params
        self.mf_params_ = result["mf_params"]
        self.rules_ = rules
        self._set_consequents(result["consequents"], y.ndim == 1)
        self.history_ = result["history"]
        self.best_epoch_ = int(result["best_epoch"])
        self.n_iter_ = len(self.history_["epoch"])
        stalled = result.get("stalled_epoch")
        collapsed = result.get("collapsed_epoch")
        what = None
        if stalled is not None and stalled < self.n_iter_:
            what = (
                f"premise training stopped after epoch {stalled} of "
                f"{self.n_iter_}: a gradient step collapsed a membership function "
                "(its width onto the floor, so it is zero on every sample) and "
                "the premise gradient vanished; the later epochs repeat that "
                f"error. The parameters of the best epoch ({self.best_epoch_}) "
                "are kept."
            )
        elif collapsed is not None:
            # One function gone, the others go on: the rules it takes part
            # in fire nowhere from then on, with no word (half of the
            # collapses of 290 fits of real and simulated records).
            kept = (
                "the parameters kept (best epoch "
                f"{self.best_epoch_}) are from before it"
                if self.best_epoch_ <= collapsed
                else f"the model kept (best epoch {self.best_epoch_}) has "
                "fewer working rules than it was given"
            )
            what = (
                f"the premise step of epoch {collapsed} collapsed a membership "
                "function (its width onto the floor, so it is zero on every "
                "sample): the rules it takes part in fire nowhere from then on, "
                f"and {kept}."
            )
        if what is not None:
            warnings.warn(
                f"ANFISRegressor: {what} A smaller step_size (now "
                f"{self.step_size:g}, in the units of the inputs) makes a "
                "collapse less likely, and training slower.",
                ConvergenceWarning,
                stacklevel=user_stacklevel(),
            )
        if self.learning == "backprop" and self.best_epoch_ == 1 and self.n_iter_ > 1:
            # The first epoch is the initial model (constant rules at the
            # target mean): gradient descent never improved on it.
            warnings.warn(
                f"ANFISRegressor: backprop learning never improved on its "
                f"initial model in {self.n_iter_} epochs (training RMSE "
                f"{self.history_['train_rmse'][0]:.4g} at epoch 1, "
                f"{self.history_['train_rmse'][-1]:.4g} at the last): the model "
                "kept is the initial one. The step is in the units of the "
                f"inputs (step_size={self.step_size:g}): standardise the "
                "inputs (StandardScaler) or lower step_size.",
                ConvergenceWarning,
                stacklevel=3,
            )
        self._input_range = np.c_[X_train.min(axis=0), X_train.max(axis=0)]
        # Grey-ANFIS is a sequence model: what continuing a labelled run in
        # predict needs (its first row and times, the accumulated inputs and
        # the accumulated prediction at its last row).
        self.run_states_ = {}
        if self.grey:
            slices, labels = run_slices(groups, n)
            memory = run_memory(X, slices, labels, frame)
            for sl, lab in zip(slices, labels, strict=True):
                if lab in memory:
                    last = X_model[sl.stop - 1 : sl.stop]
                    memory[lab]["ago_last"] = last[0].copy()
                    memory[lab]["pred_ago_last"] = anfis_predict(
                        last, self.mf_params_, self.rules_, self._consequents, self.mf
                    )[0]
            self.run_states_ = memory
        return self

    def _uses_runs(self):
        """Whether fitting reads the rows of a run in time order."""
        return self.grey or self.validation_fraction is not None or self.ridge == "auto"

    def _train(self, X, Y, mf_params, rules, ridge, checking, verbose):
        # One BLAS thread: an epoch is a chain of matrix products too small
        # to share well, and on cores shared with other jobs OpenBLAS threads
        # wait for each other (a 1458-consequent grid, 30 epochs on 2 busy
        # cores: 5.7 s with two threads, 1.9 s with one).
        with single_threaded_blas():
            return anfis_train(
                X,
                Y,
                mf_params,
                rules,
                self.mf,
                epochs=self.epochs,
                learning=self.learning,
                step_size=self.step_size,
                step_increase=self.step_increase,
                step_decrease=self.step_decrease,
                ridge=ridge,
                penalize_intercepts=self.penalize_intercepts,
                checking=checking,
                tol=self.tol,
                n_iter_no_change=self.n_iter_no_change,
                verbose=verbose,
            )

    def _choose_ridge(
        self,
        X_model,
        Y_model,
        Y,
        groups,
        X_train,
        Y_train,
        mf_params,
        rules,
        checking,
        rng,
    ):
        """``ridge="auto"``: the candidate with the least checking RMSE.

        Uses the checking set when there is one (and then returns the fit of
        the chosen candidate, which is final), else the mean checking RMSE of
        the forward folds of :meth:`_forward_folds` (returns no fit: the
        caller refits on all rows).
        """
        grid = np.asarray(self.ridge_grid, dtype=float).ravel()
        if grid.size == 0 or not np.all(np.isfinite(grid)) or np.any(grid < 0):
            raise ValueError(
                "ridge_grid must hold at least one finite, non-negative value, "
                f"got {self.ridge_grid!r}."
            )
        if checking is None:
            folds = self._forward_folds(X_model, Y_model, Y, groups, rng)
            final = False
        else:
            folds = [(X_train, Y_train, mf_params, rules, checking)]
            final = True
        best = (np.inf, None, None)
        for value in grid:
            scores, res = [], None
            for X_sel, Y_sel, mfp, rls, check in folds:
                res = self._train(X_sel, Y_sel, mfp, rls, value, check, 0)
                val = np.asarray(res["history"]["val_rmse"], dtype=float)
                scores.append(np.nanmin(val) if np.any(np.isfinite(val)) else np.inf)
            score = float(np.mean(scores))
            self.ridge_scores_[float(value)] = score
            if score < best[0] or best[1] is None:
                best = (score, float(value), res)
        return best[1], (best[2] if final else None)

    def _forward_folds(self, X_model, Y_model, Y, groups, rng):
        """Two time-ordered folds over the last half of every run.

        Fold 1 trains on the first half of every run and checks on its third
        quarter; fold 2 trains on the first three quarters and checks on the
        last quarter (forward chaining: never trained on later rows than it
        is checked on). Each fold gets its own initial rule base.
        """
        n = X_model.shape[0]
        slices, _ = run_slices(groups, n)
        labels = None if groups is None else np.asarray(groups)
        folds = []
        for end in (0.75, 1.0):
            keep = np.zeros(n, dtype=bool)
            for sl in slices:
                length = sl.stop - sl.start
                keep[sl.start : sl.start + int(round(end * length))] = True
            Xk, Yk, Yo = X_model[keep], Y_model[keep], Y[keep]
            gk = None if labels is None else labels[keep]
            sk, _ = run_slices(gk, Xk.shape[0])
            try:
                val = _tail_split(sk, Xk.shape[0], 0.25 / end)
            except ValueError:
                raise ValueError(
                    f"ridge='auto' checks candidates on the third and last "
                    f"quarters of every run, but {n} samples leave none; pass "
                    "X_val and y_val, or a number for ridge."
                ) from None
            if int(np.sum(~val)) < max(2, getattr(self, "n_clusters", 1)):
                raise ValueError(
                    f"ridge='auto' trains its checking folds on the first half "
                    f"and three quarters of every run, but {n} samples leave "
                    f"only {int(np.sum(~val))} there; pass X_val and y_val, or a "
                    "number for ridge."
                )
            check = self._tail_checking(Xk, Yo, gk, sk, val)
            mfp, rls = self._initial_rule_base(Xk[~val], rng)
            folds.append((Xk[~val], Yk[~val], mfp, rls, check))
        return folds

    def _set_consequents(self, consequents, single_output):
        self._consequents = np.asarray(consequents, dtype=float)
        self.n_outputs_ = self._consequents.shape[2]
        self.n_rules_ = self._consequents.shape[0]
        self._single_output = bool(single_output)
        self.consequents_ = (
            self._consequents[:, :, 0] if single_output else self._consequents
        )

    def _initial_rule_base(self, X, rng):
        n, d = X.shape
        k = len(MF_PARAMS[self.mf])
        if isinstance(self.init, str) and self.init == "fcm":
            if self.n_clusters > n:
                raise ValueError(
                    f"init='fcm' with n_clusters={self.n_clusters} needs at least "
                    f"{self.n_clusters} training samples, got {n} sample"
                    f"{'' if n == 1 else 's'}."
                )
            return fcm_mf_params(X, self.n_clusters, self.mf, random_state=rng)
        if isinstance(self.init, str):  # "grid"
            n_mfs = self.n_mfs
            self._check_grid_size(n_mfs, d)
            if n == 0:
                raise ValueError("Cannot build a grid rule base from 0 samples.")
            params = grid_mf_params(X, n_mfs, self.mf)
        else:
            params = np.array(self.init, dtype=float)
            if params.ndim != 3 or params.shape[0] != d or params.shape[2] != k:
                raise ValueError(
                    f"An init array must have shape (n_features, n_mfs, {k}) = "
                    f"({d}, n_mfs, {k}) for mf={self.mf!r} "
                    f"(parameters {MF_PARAMS[self.mf]}), got {params.shape}."
                )
            if not np.all(np.isfinite(params)) or np.any(params[..., :-1] <= 0):
                raise ValueError(
                    "An init array must be finite with positive widths (and "
                    "bell slopes)."
                )
            n_mfs = params.shape[1]
            self._check_grid_size(n_mfs, d)
        return params, grid_rules(n_mfs, d)

    def _check_grid_size(self, n_mfs, d):
        n_rules = int(n_mfs) ** int(d)
        if n_rules > self.max_rules:
            raise ValueError(
                f"A grid partition with n_mfs={n_mfs} membership functions on each "
                f"of {d} inputs has {n_mfs}**{d} = {n_rules} rules, more than "
                f"max_rules={self.max_rules}. Use init='fcm', fewer inputs or "
                "membership functions, or raise max_rules."
            )

    def _explicit_checking(self, X_val, y_val, groups_val, n_out):
        X_val, groups_val = extract_runs(X_val, groups_val)
        X_val = validate_data(self, X_val, reset=False, dtype=np.float64)
        y_val = check_array(
            y_val, ensure_2d=False, dtype=np.float64, input_name="y_val"
        )
        Y_val = y_val.reshape(y_val.shape[0], -1)
        if Y_val.shape != (X_val.shape[0], n_out):
            raise ValueError(
                f"y_val must have {X_val.shape[0]} rows and {n_out} output(s) like "
                f"y, got shape {y_val.shape}."
            )
        if not self.grey:
            return _CheckingSet(X_val, Y_val)
        run_slices(groups_val, X_val.shape[0])  # validates the labels
        labels = (
            np.zeros(X_val.shape[0], dtype=np.intp)
            if groups_val is None
            else np.asarray(groups_val)
        )
        return _CheckingSet(
            _ago_by_run(X_val, groups_val), Y_val, groups=labels, grey=True
        )

    def _tail_checking(self, X_model, Y, groups, slices, val):
        if not self.grey:
            return _CheckingSet(X_model[val], Y[val])
        # IAGO of a tail needs the prediction of the row just before it: score
        # the tail plus that row, which the inverse AGO treats as the start.
        rows, labels, mask = [], [], []
        for r, sl in enumerate(slices):
            tail = np.flatnonzero(val[sl]) + sl.start
            if tail.size == 0:
                continue
            block = np.r_[tail[0] - 1, tail]
            rows.append(block)
            labels.append(np.full(block.size, r))
            mask.append(np.r_[False, np.ones(tail.size, dtype=bool)])
        rows = np.concatenate(rows)
        return _CheckingSet(
            X_model[rows],
            Y[rows],
            mask=np.concatenate(mask),
            groups=np.concatenate(labels),
            grey=True,
        )

    # ------------------------------------------------------------ predict

    def predict(self, X, *, groups=None):
        """Predict the targets.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Inputs; a ``run`` column or index level holds run labels.
        groups : array-like of shape (n_samples,), optional
            Run labels, for ``grey=True`` (every run is accumulated, predicted
            and restored from its own start).

        Returns
        -------
        ndarray of shape (n_samples,) or (n_samples, n_outputs)
        """
        check_is_fitted(self)
        X, groups = extract_runs(X, groups)
        frame = X
        if self.grey:
            check_time_order(X, groups)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        cont = []
        if self.grey:
            warn_unlabelled_runs(
                type(self).__name__,
                getattr(self, "_n_fitted_runs", None),
                groups,
                X.shape[0],
            )
            slices, labels = run_slices(groups, X.shape[0])
            memory = getattr(self, "run_states_", {})
            cont = continued_runs(
                type(self).__name__, X, slices, labels, run_times(frame, slices), memory
            )
            warn_row_gaps(type(self).__name__, frame, slices, labels, cont, memory)
            A = _ago_by_run(X, groups)
            for sl, lab in zip(slices, cont, strict=True):
                if lab is not None:  # accumulate on from the training rows
                    A[sl] += memory[lab]["ago_last"]
            X = A
        pred = anfis_predict(
            X, self.mf_params_, self.rules_, self._consequents, self.mf
        )
        if self.grey:
            first = pred.copy()
            pred = iago(pred, groups)
            for sl, lab in zip(slices, cont, strict=True):
                if lab is not None:
                    pred[sl.start] = first[sl.start] - memory[lab]["pred_ago_last"]
        return pred[:, 0] if self._single_output else pred

    # ------------------------------------------------- parameters and text

    @classmethod
    def from_parameters(
        cls,
        *,
        mf,
        mf_params,
        consequents,
        rules=None,
        feature_names=None,
        **params,
    ):
        """A fitted estimator from given parameters (e.g. a published model).

        Parameters
        ----------
        mf : {"gaussian", "gbell"}
        mf_params : array-like of shape (n_features, n_mfs, n_params)
            ``mf_params[j, m]`` is ``(sigma, c)`` or ``(a, b, c)`` of the m-th
            membership function of input j (MATLAB's ``gaussmf`` /
            ``gbellmf`` order).
        consequents : array-like of shape (n_rules, n_features + 1) or \
(n_rules, n_features + 1, n_outputs)
            Per rule the coefficients ``p_1 .. p_d`` then the constant.
        rules : array-like of shape (n_rules, n_features), optional
            Index of the membership function of every input in every rule.
            Default: the grid product ``n_mfs ** n_features`` rules with the
            first input varying slowest (Jang 1993, MATLAB ``genfis1``); or,
            when ``n_rules == n_mfs`` and that is not a grid, rule r uses the
            r-th function of every input (an FCM rule base).
        feature_names : sequence of str, optional
            Sets ``feature_names_in_``.
        **params
            Other constructor parameters (e.g. ``grey=True``).

        Returns
        -------
        ANFISRegressor
            Fitted: ``predict``, ``describe_rules`` and the plots work.

        Examples
        --------
        >>> from skthermal.fuzzy import ANFISRegressor
        >>> model = ANFISRegressor.from_parameters(
        ...     mf="gaussian",
        ...     mf_params=[[[1.0, 0.0], [1.0, 2.0]]],
        ...     consequents=[[0.0, -1.0], [0.0, 1.0]],
        ... )
        >>> model.predict([[-5.0], [1.0], [7.0]]).round(3).tolist()
        [-1.0, 0.0, 1.0]
        """
        est = cls(mf=mf, **params)
        est._validate_params()  # as fit would: bad settings named now
        k = len(MF_PARAMS[mf]) if mf in MF_PARAMS else None
        if k is None:
            raise ValueError(f"mf must be 'gaussian' or 'gbell', got {mf!r}.")
        mf_params = np.array(mf_params, dtype=float)
        if mf_params.ndim != 3 or mf_params.shape[2] != k:
            raise ValueError(
                f"mf_params must have shape (n_features, n_mfs, {k}) for "
                f"mf={mf!r}, got {mf_params.shape}."
            )
        d, n_mfs = mf_params.shape[:2]
        if not np.all(np.isfinite(mf_params)) or np.any(mf_params[..., :-1] <= 0):
            raise ValueError("mf_params must be finite with positive widths.")
        cons = np.array(consequents, dtype=float)
        if not np.all(np.isfinite(cons)):
            raise ValueError("consequents must be finite (no NaN or infinite value).")
        single = cons.ndim == 2
        cons = cons[:, :, None] if single else cons
        if cons.ndim != 3 or cons.shape[1] != d + 1:
            raise ValueError(
                f"consequents must have shape (n_rules, {d + 1}[, n_outputs]) for "
                f"{d} inputs, got {np.shape(consequents)}."
            )
        n_rules = cons.shape[0]
        if rules is None:
            if n_mfs**d == n_rules:
                rules = grid_rules(n_mfs, d)
            elif n_mfs == n_rules:
                rules = np.tile(np.arange(n_rules)[:, None], (1, d))
            else:
                raise ValueError(
                    f"{n_rules} rules match neither a grid of {n_mfs}**{d} rules "
                    f"nor one rule per membership function; pass rules."
                )
        given = np.asarray(rules)
        if given.shape != (n_rules, d):
            raise ValueError(
                f"rules must have shape ({n_rules}, {d}), one row of membership "
                f"function indices per rule; got shape {given.shape}."
            )
        try:
            numeric = given.astype(float)
        except (TypeError, ValueError):
            numeric = np.full(given.shape, np.nan)
        bad = ~np.isfinite(numeric) | (numeric != np.round(numeric))
        bad |= (numeric < 0) | (numeric >= n_mfs)
        if bad.any():
            r, j = (int(k) for k in np.argwhere(bad)[0])
            raise ValueError(
                f"rules[{r}, {j}] is {shown(given[r, j])}: every entry must be the "
                f"index of one of the {n_mfs} membership functions of its "
                f"input, an integer in [0, {n_mfs})."
            )
        rules = numeric.astype(np.intp)
        est.n_features_in_ = d
        if feature_names is not None:
            names = np.asarray(list(feature_names), dtype=object)
            if names.shape != (d,):
                raise ValueError(f"feature_names must hold {d} names.")
            est.feature_names_in_ = names
        est.initial_mf_params_ = mf_params.copy()
        est.mf_params_ = mf_params
        est.rules_ = rules
        est._set_consequents(cons, single)
        est.history_ = {
            "epoch": np.array([], dtype=int),
            "train_rmse": np.array([]),
            "step_size": np.array([]),
        }
        est.best_epoch_ = 0
        est.n_iter_ = 0
        est.ridge_ = 0.0 if est.ridge == "auto" else float(est.ridge)
        est.ridge_scores_ = {}
        est.run_states_ = {}
        est._n_fitted_runs = None
        spread = mf_params[..., 0] * (1.0 if mf == "gbell" else _HALF)
        centres = mf_params[..., -1]
        est._input_range = np.c_[
            (centres - 2 * spread).min(axis=1), (centres + 2 * spread).max(axis=1)
        ]
        return est

    def _feature_names(self):
        names = getattr(self, "feature_names_in_", None)
        if names is not None:
            return [str(s) for s in names]
        return [f"x{j + 1}" for j in range(self.n_features_in_)]

    def describe_rules(self, precision=4):
        """The rules as readable linguistic text (001 Table 5-6).

        Membership function m of input j is called ``in{j}mf{m}`` (1-based, as
        MATLAB), followed by its parameters; the inputs are named by
        ``feature_names_in_`` when the model was fitted on a DataFrame.

        Parameters
        ----------
        precision : int, default=4
            Significant digits of the numbers.

        Returns
        -------
        str
            One line per rule.

        Examples
        --------
        >>> from skthermal.fuzzy import ANFISRegressor
        >>> model = ANFISRegressor.from_parameters(
        ...     mf="gaussian",
        ...     mf_params=[[[1.0, 0.0], [1.0, 2.0]]],
        ...     consequents=[[0.5, -1.0], [0.0, 1.0]],
        ...     feature_names=["T18"],
        ... )
        >>> print(model.describe_rules())
        Rule 1: IF T18 is in1mf1 (sigma=1, c=0) THEN y = 0.5*T18 - 1
        Rule 2: IF T18 is in1mf2 (sigma=1, c=2) THEN y = 0*T18 + 1
        """
        check_is_fitted(self)
        names = self._feature_names()
        pnames = MF_PARAMS[self.mf]

        def num(v):
            return f"{v:.{precision}g}"

        lines = []
        C = self._consequents
        outs = (
            ["y"] if self.n_outputs_ == 1 else [f"y{o + 1}" for o in range(C.shape[2])]
        )
        for r, rule in enumerate(self.rules_):
            premises = []
            for j, m in enumerate(rule):
                pars = ", ".join(
                    f"{p}={num(v)}"
                    for p, v in zip(pnames, self.mf_params_[j, m], strict=True)
                )
                premises.append(f"{names[j]} is in{j + 1}mf{m + 1} ({pars})")
            thens = []
            for o, out in enumerate(outs):
                terms = [f"{num(C[r, j, o])}*{names[j]}" for j in range(len(names))]
                const = C[r, -1, o]
                expr = " + ".join(terms)
                expr += f" - {num(-const)}" if const < 0 else f" + {num(const)}"
                thens.append(f"{out} = {expr.replace('+ -', '- ')}")
            lines.append(
                f"Rule {r + 1}: IF {' AND '.join(premises)} THEN {', '.join(thens)}"
            )
        return "\n".join(lines)

    def get_input_range(self):
        """Range of every input as the membership functions see it.

        The smallest and largest training value of every input (with
        ``grey=True``, of the accumulated inputs); for a model made by
        :meth:`from_parameters`, the span of its membership functions (the
        centres +- two half widths). Used to choose the x-axis of
        :meth:`plot_membership_functions`.

        Returns
        -------
        ndarray of shape (n_features_in_, 2)
            ``(min, max)`` of every input.

        Examples
        --------
        >>> from skthermal.fuzzy import ANFISRegressor
        >>> X = [[0.0], [1.0], [2.0], [4.0]]
        >>> model = ANFISRegressor(n_clusters=2, epochs=2, random_state=0)
        >>> model.fit(X, [0.0, 1.0, 2.0, 4.0]).get_input_range().tolist()
        [[0.0, 4.0]]
        """
        check_is_fitted(self, "mf_params_")
        return np.array(self._input_range, dtype=float)

    def membership_degrees(self, X, *, which="trained"):
        """Membership of every input value in every membership function.

        Layer 1 of ANFIS: ``out[i, j, m]`` is the degree to which ``X[i, j]``
        belongs to the m-th membership function of input j (``in{j+1}mf{m+1}``
        of :meth:`describe_rules`).

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features_in_)
            Input values as the membership functions see them (with
            ``grey=True``, accumulated inputs).
        which : {"trained", "initial"}, default="trained"
            The trained functions (``mf_params_``) or those before training
            (``initial_mf_params_``).

        Returns
        -------
        ndarray of shape (n_samples, n_features_in_, n_mfs)
            Membership degrees in [0, 1].

        Examples
        --------
        >>> from skthermal.fuzzy import ANFISRegressor
        >>> model = ANFISRegressor.from_parameters(
        ...     mf="gaussian",
        ...     mf_params=[[[1.0, 0.0], [1.0, 2.0]]],
        ...     consequents=[[0.0, -1.0], [0.0, 1.0]],
        ... )
        >>> model.membership_degrees([[0.0], [1.0]]).round(4).tolist()
        [[[1.0, 0.1353]], [[0.6065, 0.6065]]]
        """
        check_is_fitted(self, "mf_params_")
        if which not in ("trained", "initial"):
            raise ValueError(f"which must be 'trained' or 'initial', got {which!r}.")
        params = self.mf_params_ if which == "trained" else self.initial_mf_params_
        X = check_array(X, dtype=np.float64)
        if X.shape[1] != params.shape[0]:
            raise ValueError(
                f"X has {X.shape[1]} features, but {type(self).__name__} has "
                f"{params.shape[0]} inputs."
            )
        return membership(X[:, :, None], params, self.mf)

    def plot_membership_functions(self, ax=None, which="trained", n_points=201):
        """Plot the membership functions of every input (001 Fig. 6-6).

        A shortcut for
        :meth:`skthermal.plotting.MembershipFunctionDisplay.from_estimator`.

        Parameters
        ----------
        ax : matplotlib Axes or sequence of Axes, optional
            One Axes per input; by default a new figure with one panel per
            input.
        which : {"trained", "initial", "both"}, default="trained"
            Trained functions (solid), initial ones (dashed), or both.
        n_points : int, default=201
            Points per curve.

        Returns
        -------
        ndarray of matplotlib Axes
            One panel per input.

        See Also
        --------
        skthermal.plotting.MembershipFunctionDisplay : The display drawn, with
            the curves and artists as attributes.
        """
        check_is_fitted(self)
        # Imported here: plotting is optional, and it reads this model only
        # through its public attributes and methods (no import of fuzzy).
        from skthermal.plotting import MembershipFunctionDisplay

        display = MembershipFunctionDisplay.from_estimator(
            self, which=which, n_points=n_points, ax=ax
        )
        return display.axes_
