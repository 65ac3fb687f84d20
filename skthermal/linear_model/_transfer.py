"""Transfer-function thermal-error model: first- or second-order lags of
temperature changes and of spindle speed, summed with linear gains.

The industrial baseline of Mareš, Horejš and Havlík (Precision Engineering 66,
2020), the kind of model that runs inside a CNC: every input drives the thermal
error through its own discrete low-order transfer function. Time constants are
identified by variable projection (for fixed time constants the error is linear
in the gains, which a least-squares solve gives exactly).
"""

from numbers import Integral, Real

import numpy as np
from scipy import linalg
from scipy.optimize import least_squares
from sklearn.base import BaseEstimator, RegressorMixin, _fit_context
from sklearn.utils._param_validation import Interval
from sklearn.utils.validation import check_is_fitted, validate_data

from skthermal.preprocessing import exponential_filter
from skthermal.utils._runs import (
    PAUSE_BRIDGE,
    changes_since_start,
    check_positive_numbers,
    continued_runs,
    continued_steps,
    continued_values,
    extract_runs,
    fitted_sample_periods,
    gap_periods,
    row_times,
    run_memory,
    run_sample_periods,
    run_slices,
    run_times,
    warn_no_time,
    warn_pauses,
    warn_unlabelled_runs,
)
from skthermal.utils._threads import single_threaded_blas

# Relative spread of the sampling interval tolerated within one run: the exact
# discretisation below assumes a constant step.
_DT_RTOL = 0.01
# Least ratio of the two time constants of an input with order=2. Two lags
# of nearly equal time constants are nearly the same column: their
# difference, with huge opposite gains, approximates the derivative of a
# lag with respect to its time constant (a second lag in series), which a
# fit free to merge them drifts to. Kept apart, the pair stays a sum of two
# distinct lags with gains of the size of the error; a series connection of
# two lags is such a sum (partial fractions), and one of two nearly equal
# lags is matched closely by a pair this far apart.
MIN_TAU_RATIO = 2.0


def _pair_log_tau(x, lo, hi, order):
    """Log time constants from the coordinates of the refinement.

    Order 1: the coordinates are the log time constants. Order 2, per input
    ``(u, v)``: ``log tau_1 = u`` in ``[lo, hi - log r]`` and ``log tau_2``
    the fraction ``v`` in ``[0, 1]`` of the way from ``u + log r`` to
    ``hi`` (``r = MIN_TAU_RATIO``), so that box bounds keep every pair
    ordered and at least ``r`` apart within ``[lo, hi]``.
    """
    if order == 1:
        return x
    u, v = x.reshape(-1, 2).T
    gap = np.log(MIN_TAU_RATIO)
    return np.column_stack([u, u + gap + v * (hi - u - gap)]).reshape(-1)


def _pair_coordinates(log_tau, lo, hi, order):
    """The inverse of :func:`_pair_log_tau` (pairs ordered and at least
    ``MIN_TAU_RATIO`` apart), and the coordinates' bounds."""
    if order == 1:
        n = log_tau.size
        return log_tau, (np.full(n, lo), np.full(n, hi))
    a, b = log_tau.reshape(-1, 2).T
    gap = np.log(MIN_TAU_RATIO)
    room = hi - a - gap
    v = np.divide(b - a - gap, room, out=np.zeros_like(room), where=room > 0)
    x = np.column_stack([a, np.clip(v, 0.0, 1.0)]).reshape(-1)
    n = a.size
    low = np.column_stack([np.full(n, lo), np.zeros(n)]).reshape(-1)
    high = np.column_stack([np.full(n, hi - gap), np.ones(n)]).reshape(-1)
    return x, (low, high)


def first_order_lags(
    U, time_constants, dt, slices, state=None, times=None, previous=None, periods=None
):
    """Discrete first-order lags of the columns of ``U``, restarting per run.

    ``z[k] = a z[k-1] + (1 - a) u[k]`` with ``a = exp(-dt / tau)`` and
    ``z[-1] = 0`` at the start of every run (the machine at rest, in thermal
    equilibrium): the step response of ``1 / (tau s + 1)`` sampled every
    ``dt``.

    Parameters
    ----------
    U : ndarray of shape (n_samples, n_columns)
        Inputs, zero at rest.
    time_constants : ndarray of shape (n_columns,)
        One time constant per column, in the unit of ``dt``.
    dt : ndarray of shape (n_runs,)
        Sampling interval of each run.
    slices : list of slice
        Runs, as returned by :func:`skthermal.utils.run_slices`.
    state : sequence, optional
        Per run, the lag outputs before its first row, to continue it, or
        None (from rest); see :func:`skthermal.preprocessing.exponential_filter`.
    times : ndarray of shape (n_samples,), optional
        Time of every row; ``dt`` is then the step before each run's first
        row (see :func:`skthermal.preprocessing.exponential_filter`).
    previous : sequence, optional
        Per run, the input row before its first row, or None (see
        :func:`skthermal.preprocessing.exponential_filter`).
    periods : array-like of shape (n_runs,), optional
        Per run, the sampling period against which a step is a gap (see
        :func:`skthermal.preprocessing.exponential_filter`).

    Returns
    -------
    Z : ndarray of shape (n_samples, n_columns)

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.linear_model._transfer import first_order_lags
    >>> z = first_order_lags(np.ones((4, 1)), np.array([1.0]), np.array([1.0]),
    ...                      [slice(0, 4)])
    >>> z.ravel().round(3)
    array([0.632, 0.865, 0.95 , 0.982])
    """
    return exponential_filter(
        np.asarray(U, dtype=float),
        time_constants,
        dt,
        slices,
        initial="rest",
        state=state,
        times=times,
        previous=previous,
        periods=periods,
    )


def _solve_normal(gram, b):
    """``gram^-1 b`` for the normal equations of a ridge (symmetric, positive
    definite when the penalty is positive) by Cholesky, else (singular) the
    minimum-norm least-squares solution. This runs for every trial of the
    time constants: an SVD there cost ten times more."""
    try:
        return linalg.cho_solve(linalg.cho_factor(gram, check_finite=False), b)
    except linalg.LinAlgError:
        return np.linalg.lstsq(gram, b, rcond=1e-12)[0]


def _ridge_with_intercept(Phi, y, alpha):
    """Gains and intercept of ``y ~ Phi``, ridge on standardised columns."""
    mean = Phi.mean(axis=0)
    scale = Phi.std(axis=0)
    scale[scale < 1e-12] = 1.0
    A = (Phi - mean) / scale
    y_mean = y.mean()
    yc = y - y_mean
    # The normal equations of the (small) standardised problem: a few times
    # faster than a least-squares solve of the tall matrix, and this runs for
    # every trial of the time constants.
    gram = A.T @ A
    gram[np.diag_indices_from(gram)] += alpha
    w = _solve_normal(gram, A.T @ yc)
    resid = yc - A @ w
    coef = w / scale
    intercept = y_mean - mean @ coef
    return coef, intercept, np.concatenate([resid, np.sqrt(alpha) * w])


def _ridge_column_changes(Phi, y, alpha, groups, new):
    """Changes of the residual vector of :func:`_ridge_with_intercept` when
    groups of columns of ``Phi`` are replaced, one group at a time.

    The finite-difference Jacobian replaces the one or two lag columns of
    one time constant at a time. A full solve for each costs a Gram matrix
    and a Cholesky factorisation of all the lags, so the Jacobian grew with
    the cube of the number of lags; and it is only as accurate as the
    normal equations, off by several per cent with hundreds of nearly
    dependent lags. Here one QR factorisation of the design (augmented for
    the ridge) serves all the replacements: products with all the new
    columns at once, then per group a few vectors of the length of a row of
    the design and a solve of the group's size.

    Parameters
    ----------
    Phi : ndarray of shape (n_samples, n_columns)
        Design.
    y : ndarray of shape (n_samples,)
        Target.
    alpha : float
        Ridge penalty, as in :func:`_ridge_with_intercept`.
    groups : list of ndarray of int
        The columns that each change replaces.
    new : ndarray of shape (n_samples, n_new)
        Their new columns, group after group.

    Returns
    -------
    changes : ndarray of shape (n_samples + n_columns, len(groups)) or None
        Per group, the residual vector of :func:`_ridge_with_intercept` with
        the group's columns replaced, less that of ``Phi``. NaN where the
        new design is (nearly) singular, and None when ``Phi``'s is: there
        the normal equations of a direct solve fall back to a least-norm
        solution, which is left to them.
    """
    mean = Phi.mean(axis=0)
    scale = Phi.std(axis=0)
    scale[scale < 1e-12] = 1.0
    A = (Phi - mean) / scale
    yc = y - y.mean()
    n, p = A.shape
    if alpha > 0:  # the ridge as least squares with sqrt(alpha) I below
        A = np.vstack([A, np.sqrt(alpha) * np.eye(p)])
        yc = np.concatenate([yc, np.zeros(p)])
    Q, R = np.linalg.qr(A)
    # The squares of R's diagonal are the pivots of a Cholesky factorisation
    # of the Gram matrix R'R: below the rounding of the largest, it fails.
    tiny = 1e-16 * np.max(np.diag(R) ** 2)
    if not np.min(np.diag(R) ** 2) > tiny:
        return None
    z = Q.T @ yc
    base = yc - Q @ z
    R_inv = linalg.solve_triangular(R, np.eye(p), check_finite=False)
    mean = new.mean(axis=0)
    scale = new.std(axis=0)
    scale[scale < 1e-12] = 1.0
    cols = np.concatenate(groups)
    delta = np.zeros((A.shape[0], new.shape[1]))
    delta[:n] = (new - mean) / scale - A[:n, cols]
    # The new columns within Q's span (coordinates t) and orthogonal to it
    # (o), projected twice: once loses digits to nearly dependent columns.
    inside = Q.T @ delta
    outside = delta - Q @ inside
    again = Q.T @ outside
    outside -= Q @ again
    t = R[:, cols] + inside + again
    o_base = outside.T @ base
    # In Q's coordinates the kept columns span the orthogonal complement of
    # N, a basis of the replaced columns' rows of R^-1 (each orthogonal to
    # R's other columns). Off the kept columns, y is Q N N'z + base and the
    # new columns Q N N't + o, whose least squares give their gains beta
    # and the new residual Q N (N'z - N't beta) + base - o beta.
    within = np.zeros((p, len(groups)))
    changes = np.zeros((A.shape[0], len(groups)))
    bad = np.zeros(len(groups), dtype=bool)
    end = 0
    for g, group in enumerate(groups):
        k = group.size
        block = slice(end, end + k)
        end += k
        if k == 0:
            continue
        # An orthonormal basis N by Gram-Schmidt, twice (of one or two
        # columns: a fraction of a QR call's overhead).
        N = R_inv[group].T
        for i in range(k):
            for _ in range(2):
                N[:, i] -= N[:, :i] @ (N[:, :i].T @ N[:, i])
            N[:, i] /= np.linalg.norm(N[:, i])
        Nz = N.T @ z
        Nt = N.T @ t[:, block]
        o = outside[:, block]
        # The new columns' Gram off the kept ones: the last pivots of a
        # Cholesky factorisation with them last.
        gram = Nt.T @ Nt + o.T @ o
        if not np.linalg.eigvalsh(gram)[0] > tiny:
            bad[g] = True
            continue
        beta = np.linalg.solve(gram, Nt.T @ Nz + o_base[block])
        within[:, g] = N @ (Nz - Nt @ beta)
        changes[:, g] = -(o @ beta)
    changes += Q @ within
    # The augmented rows hold -sqrt(alpha) w, the residual vector +.
    tail = -changes[n:] if alpha > 0 else np.zeros((p, len(groups)))
    changes = np.vstack([changes[:n], tail])
    changes[:, bad] = np.nan
    return changes


class TransferFunctionRegressor(RegressorMixin, BaseEstimator):
    """Thermal error as a sum of discrete transfer functions of the inputs.

    Every temperature sensor (as its change since the start of the run) and
    every spindle-speed driver (as a heat power ``|n| ** speed_exponent``)
    drives the thermal error through its own low-order transfer function::

        e[k] = c + sum_j sum_m g_jm z_jm[k],
        z_jm[k] = a_jm z_jm[k-1] + (1 - a_jm) u_j[k],  a_jm = exp(-dt / tau_jm),

    one lag per input (``order=1``) or two in parallel (``order=2``, a
    second-order transfer function with real poles). The lags restart from
    rest at every run boundary. For fixed time constants the model is linear
    in the gains ``g`` and ``c``, solved exactly by (ridge) least squares; the
    time constants are found by variable projection: a search over a common
    time constant on a log grid, sweeps of 1-D grid searches over each lag's
    own time constant (all from lags filtered once per grid point, sharing
    one Gram matrix), then a bounded nonlinear least-squares refinement of
    all of them.

    Parameters
    ----------
    speed_column : str, int, list of str or int, or None, default=None
        Columns of ``X`` that are spindle-speed drivers (names when ``X`` is a
        DataFrame, or positions). They enter as ``|n| ** speed_exponent``,
        zero at rest. Every other column is a temperature and enters as its
        change since the start of the run. None: all columns are
        temperatures.
    speed_exponent : float, default=1.0
        Heat power of a speed driver taken as proportional to speed to this
        power (1: proportional to speed; bearing friction grows faster).
    order : {1, 2}, default=1
        Lags per input: a first-order transfer function, or a second-order
        one with real poles (the sum of two first-order lags). The two time
        constants of an input are kept at least a factor ``MIN_TAU_RATIO``
        (2) apart: closer ones cannot be told apart by the data, and a fit
        free to merge them ends with huge gains of opposite signs.
    alpha : float, default=0.0
        Ridge penalty on the gains of the standardised lag features (each of
        sum of squares ``n_samples``, as ``Ridge`` after ``StandardScaler``);
        it steadies the gains of many collinear temperatures.
    dt : float or None, default=None
        Sampling interval. None: read from the ``time_s`` index level of
        ``X`` (:func:`skthermal.datasets.split_runs`), one interval per run
        (a run of one row takes that of the others; an error when no run has
        two rows), or 1 (time constants in samples) when ``X`` has no such
        level. A number overrides the index.
    tau_bounds : (float, float) or None, default=None
        Bounds ``(low, high)`` of the time constants, in the unit of ``dt``:
        finite, ``0 < low < high`` (with ``order=2``, ``high >= 2 * low``).
        None: from a tenth of the shortest sampling interval to the duration
        of the longest run (a slower lag cannot be identified from the
        data).
    n_grid : int, default=15
        Time constants tried in each grid search (log-spaced over
        ``tau_bounds``).
    max_iter : int, default=30
        Evaluations of the refinement (scipy's ``max_nfev``); 0 keeps the grid
        search's common time constant(s).

    Attributes
    ----------
    time_constants_ : ndarray of shape (n_inputs, order) or (n_outputs, n_inputs, order)
        Identified time constants, in the unit of ``dt``, inputs in column
        order of ``X``.
    coef_ : ndarray of shape (n_inputs, order) or (n_outputs, n_inputs, order)
        Gain of every lag (error per unit of temperature change, or per unit
        of heat power, in steady state).
    intercept_ : float or ndarray of shape (n_outputs,)
    n_iter_ : int
        One for the grid search plus the evaluations of the refinement (the
        most over the outputs).
    sample_period_s_ : float
        Sampling interval in ``fit``: ``dt``, or the median over the runs of
        two rows or more of their intervals. ``predict`` uses it for rows
        without times.
    speed_columns_ : ndarray of int
        Positions of the speed drivers.
    n_fitted_runs_ : int or None
        Labelled runs seen in ``fit`` (None when ``fit`` got no run labels).
    run_states_ : dict
        Per run label seen in ``fit``: what continuing that run in
        ``predict`` needs (its length, first row, first and last ``time_s``
        and every lag's last output). Empty when ``fit`` got no run labels.
    n_features_in_ : int
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Defined only when ``X`` has string column names.

    See Also
    --------
    skthermal.linear_model.UpdateRegressor : static ridge model on
        temperatures.

    Notes
    -----
    Mareš, M., Horejš, O., Havlík, L. (2020). Thermal error compensation of a
    5-axis machine tool using indigenous temperature sensors and CNC
    integrated Python code validated with a machined test piece. Precision
    Engineering 66, 21-30: the thermal error as the sum of discrete
    first-order transfer functions of temperature differences and of spindle
    speed, identified from calibration tests and run inside the CNC. The
    discretisation here is the exact step-invariant one of ``1 / (tau s + 1)``
    with a constant step per run; a run whose ``time_s`` steps vary by more
    than 1% is an error. The variable-projection identification (Golub and
    Pereyra) replaces the system-identification toolbox of the original.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.linear_model._transfer import TransferFunctionRegressor
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(400.0)
    >>> speed = np.where(t < 200, 3000.0, 0.0)
    >>> temp = 20 + 5 * (1 - np.exp(-t / 30.0)) + 0.01 * rng.normal(size=400)
    >>> error = 0.004 * (1 - np.exp(-np.minimum(t, 200) / 60.0))
    >>> error = 3000 * np.where(t < 200, error, error[199] * np.exp(-(t - 199) / 60))
    >>> X = np.c_[temp, speed]
    >>> model = TransferFunctionRegressor(speed_column=1, dt=1.0).fit(X, error)
    >>> round(float(model.time_constants_[1, 0]))
    60
    >>> bool(np.sqrt(np.mean((model.predict(X) - error) ** 2)) < 0.1)
    True
    """

    _parameter_constraints: dict = {
        "speed_column": [None, str, Integral, list],
        "speed_exponent": [Interval(Real, 0, None, closed="neither")],
        "order": [Interval(Integral, 1, 2, closed="both")],
        "alpha": [Interval(Real, 0, None, closed="left")],
        "dt": [None, Interval(Real, 0, None, closed="neither")],
        "tau_bounds": [None, tuple, list],
        "n_grid": [Interval(Integral, 2, None, closed="left")],
        "max_iter": [Interval(Integral, 0, None, closed="left")],
    }

    def __init__(
        self,
        *,
        speed_column=None,
        speed_exponent=1.0,
        order=1,
        alpha=0.0,
        dt=None,
        tau_bounds=None,
        n_grid=15,
        max_iter=30,
    ):
        self.speed_column = speed_column
        self.speed_exponent = speed_exponent
        self.order = order
        self.alpha = alpha
        self.dt = dt
        self.tau_bounds = tau_bounds
        self.n_grid = n_grid
        self.max_iter = max_iter

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        # A time-series model: on rows drawn independently (as in the generic
        # checks) there is no dynamics to learn, so no R^2 can be promised.
        tags.regressor_tags.poor_score = True
        return tags

    def _speed_positions(self):
        cols = self.speed_column
        if cols is None:
            return np.array([], dtype=int)
        cols = cols if isinstance(cols, list) else [cols]
        names = getattr(self, "feature_names_in_", None)
        positions = []
        for col in cols:
            if isinstance(col, str):
                if names is None:
                    raise ValueError(
                        f"speed_column {col!r} is a column name, but X has no "
                        "column names: pass a DataFrame or a column position."
                    )
                hits = np.flatnonzero(names == col)
                if hits.size == 0:
                    raise ValueError(
                        f"speed_column {col!r} is not a column of X; columns are "
                        f"{names.tolist()}."
                    )
                positions.append(int(hits[0]))
            elif isinstance(col, Integral) and not isinstance(col, bool):
                if not -self.n_features_in_ <= col < self.n_features_in_:
                    raise ValueError(
                        f"speed_column {col} is out of range for X with "
                        f"{self.n_features_in_} columns."
                    )
                positions.append(int(col) % self.n_features_in_)
            else:
                raise ValueError(
                    f"speed_column entries must be column names or positions, "
                    f"got {col!r}."
                )
        return np.unique(positions)

    def _intervals(self, X_raw, groups, slices, labels, period=None):
        """Sampling interval of every run, and the model's period: ``dt``
        when given; in ``fit`` (``period`` None) from the times, a run of one
        row taking that of the others (:func:`fitted_sample_periods`); in
        ``predict``, a run without times takes the fitted ``period``."""
        if self.dt is not None:
            return np.full(len(slices), float(self.dt)), float(self.dt)
        name = type(self).__name__
        kwargs = {"labels": labels, "regular": name, "rtol": _DT_RTOL}
        if period is None:
            return fitted_sample_periods(X_raw, groups, slices, None, name, **kwargs)
        return run_sample_periods(X_raw, groups, slices, period, **kwargs), period

    def _check_tau_bounds(self):
        """``tau_bounds`` as (low, high), or None."""
        if self.tau_bounds is None:
            return None
        name = type(self).__name__
        low, high = check_positive_numbers(
            self.tau_bounds,
            "tau_bounds",
            name,
            size=2,
            why="the least and the greatest time constant, in the unit of dt",
        )
        if not low < high:
            raise ValueError(
                f"The 'tau_bounds' parameter of {name} must be (low, high) with "
                f"low < high. Got {self.tau_bounds!r} instead."
            )
        if self.order == 2 and high < MIN_TAU_RATIO * low:
            raise ValueError(
                f"With order=2, the two time constants of an input are kept at "
                f"least a factor {MIN_TAU_RATIO:g} apart, which tau_bounds="
                f"{self.tau_bounds!r} leave no room for: widen tau_bounds, or "
                "use order=1."
            )
        return float(low), float(high)

    def _inputs(self, X, slices, bases=None):
        """Temperature changes since each run's first row (``bases``: per
        run, the first row to use instead, or None) and speed powers."""
        U = changes_since_start(X, slices, bases)
        speed = self.speed_columns_
        U[:, speed] = np.abs(X[:, speed]) ** self.speed_exponent
        return U

    def _features(
        self,
        U,
        log_tau,
        dts,
        slices,
        state=None,
        times=None,
        previous=None,
        periods=None,
    ):
        tau = np.exp(log_tau).reshape(-1)
        if previous is not None:
            previous = [
                None if u is None else np.repeat(u, self.order) for u in previous
            ]
        return first_order_lags(
            np.repeat(U, self.order, axis=1),
            tau,
            dts,
            slices,
            state,
            times,
            previous,
            periods,
        )

    def _lag_states(
        self, U, dts, slices, states=None, times=None, previous=None, periods=None
    ):
        """Lag features of every output (a list), given the lag outputs
        before each run (``states``: per run, None or an array (n_outputs,
        n_lags) of a continued run; ``dts`` is then the step before each
        run's first row when ``times`` are given) and the inputs of the row
        before it (``previous``: per run, None or a row of ``U``)."""
        taus = self.time_constants_.reshape(-1, U.shape[1] * self.order)
        states = [None] * len(slices) if states is None else states
        return [
            self._features(
                U,
                np.log(tau),
                dts,
                slices,
                [None if st is None else st[k] for st in states],
                times,
                previous,
                periods,
            )
            for k, tau in enumerate(taus)
        ]

    def _grid_search(self, U, Y, dts, slices, grid):
        """Time constants on the log grid, for every output, from shared lags.

        Every input is filtered once per grid time constant; the centred Gram
        matrix of all these lags then gives the ridge cost of any choice of
        one grid time constant per lag from a small solve, without filtering
        again: a common time constant (pair, for ``order=2``), then sweeps of
        1-D searches over each lag's own time constant until none improves.
        """
        n, n_in = U.shape
        n_grid = grid.size
        # Columns ordered (input, grid point): column i * n_grid + g.
        lags = np.stack(
            [exponential_filter(U, t, dts, slices, initial="rest") for t in grid],
            axis=2,
        ).reshape(n, n_in * n_grid)
        lags -= lags.mean(axis=0)
        gram = lags.T @ lags
        scale = np.sqrt(np.diag(gram) / n)
        scale[scale < 1e-12] = 1.0
        gram /= np.outer(scale, scale)
        Yc = Y - Y.mean(axis=0)
        cross = (lags.T @ Yc) / scale[:, None]
        yy = np.sum(Yc**2, axis=0)
        base = np.repeat(np.arange(n_in) * n_grid, self.order)
        if self.order == 1:
            starts = [np.full(n_in, g) for g in range(n_grid)]
        else:
            # Pairs ordered and at least MIN_TAU_RATIO apart (see there).
            g1, g2 = np.nonzero(grid[None, :] >= MIN_TAU_RATIO * grid[:, None])
            starts = [np.tile(pair, n_in) for pair in zip(g1, g2, strict=True)]

        def apart(pick):
            if self.order == 1:
                return True
            pairs = grid[pick.reshape(-1, 2)]
            return bool(np.all(pairs[:, 1] >= MIN_TAU_RATIO * pairs[:, 0]))

        eye = self.alpha * np.eye(base.size)

        def cost(pick, k):
            cols = base + pick
            b = cross[cols, k]
            w = _solve_normal(gram[np.ix_(cols, cols)] + eye, b)
            return float(yy[k] - w @ b)

        def costs_at(pick, i, k):
            # The cost of every grid time constant for lag i, the others as
            # in pick: one Cholesky factor of the others' Gram, bordered by
            # each candidate (a Cholesky with lag i last), where a full
            # factorisation per candidate made a sweep grow with the fourth
            # power of the number of lags. NaN where a candidate's pivot
            # vanishes to within rounding, or all when the others' Gram is
            # singular: there a Cholesky factorisation may fail, and the
            # direct solve (falling back to least norm) decides, as it did.
            rest = np.delete(base + pick, i)
            cand = base[i] + np.arange(n_grid)
            diag = gram[cand, cand] + self.alpha
            G = gram[np.ix_(rest, rest)]
            G[np.diag_indices_from(G)] += self.alpha
            rhs = np.column_stack([cross[rest, k], gram[np.ix_(rest, cand)]])
            if rest.size:
                try:
                    L = linalg.cholesky(G, lower=True, check_finite=False)
                except linalg.LinAlgError:
                    return np.full(n_grid, np.nan)
                rhs = linalg.solve_triangular(L, rhs, lower=True, check_finite=False)
            z, border = rhs[:, 0], rhs[:, 1:]
            pivot = diag - np.einsum("ij,ij->j", border, border)
            ok = pivot > 1e-12 * diag
            fit = z @ z + (cross[cand, k] - z @ border) ** 2 / np.where(ok, pivot, 1.0)
            return np.where(ok, yy[k] - fit, np.nan)

        out = []
        for k in range(Y.shape[1]):
            costs = [cost(p, k) for p in starts]
            pick = starts[int(np.argmin(costs))].copy()
            best = min(costs)
            for _ in range(5):
                improved = False
                for i in range(pick.size):
                    # Changing lag i leaves the others, so the costs of its
                    # candidates hold through the scan below.
                    at_i = costs_at(pick, i, k)
                    for g in range(n_grid):
                        if g == pick[i]:
                            continue
                        trial = pick.copy()
                        trial[i] = g
                        if not apart(trial):
                            continue
                        c = float(at_i[g])
                        if np.isnan(c):
                            c = cost(trial, k)
                        if c < best * (1 - 1e-9):
                            best, pick, improved = c, trial, True
                if not improved:
                    break
            out.append(grid[pick])
        return out

    def _fit_one(self, U, y, dts, slices, bounds, log_tau):
        lo, hi = np.log(bounds)

        U_lags = np.repeat(U, self.order, axis=1)

        def to_log_tau(x):
            return _pair_log_tau(x, lo, hi, self.order)

        last = {}

        def features(x):
            # The Jacobian is taken where the residuals were just evaluated:
            # filter the lags once for both.
            key = x.tobytes()
            if key not in last:
                last.clear()
                last[key] = self._features(U, to_log_tau(x), dts, slices)
            return last[key]

        def residual(x):
            return _ridge_with_intercept(features(x), y, self.alpha)[2]

        def jacobian(x):
            # Forward differences, refiltering only the lags whose time
            # constants move (the other columns of the design are unchanged)
            # and solving with them replaced from one factorisation of the
            # whole design (see _ridge_column_changes).
            log_tau = to_log_tau(x)
            Phi = features(x)
            steps, moved = np.empty(x.size), []
            for j, xj in enumerate(x):
                h = 1e-3 * max(1.0, abs(xj))
                steps[j] = h if xj + h <= x_high[j] else -h
                step = x.copy()
                step[j] += steps[j]
                moved.append(to_log_tau(step))
            # The moved lags of all the steps filtered in one call (column by
            # column as one at a time), sparing a call's overhead per step.
            lags = [np.flatnonzero(m != log_tau) for m in moved]
            filtered = exponential_filter(
                U_lags[:, np.concatenate(lags)],
                np.exp(
                    np.concatenate([m[c] for m, c in zip(moved, lags, strict=True)])
                ),
                dts,
                slices,
                initial="rest",
            )
            changes = _ridge_column_changes(Phi, y, self.alpha, lags, filtered)
            if changes is None:
                changes = np.full((Phi.shape[0] + Phi.shape[1], x.size), np.nan)
            J = changes / steps
            r0 = None
            ends = np.cumsum([c.size for c in lags])
            for j in np.flatnonzero(np.isnan(J).any(axis=0)):
                # (Nearly) singular: the direct solve, as before.
                if r0 is None:
                    r0 = _ridge_with_intercept(Phi, y, self.alpha)[2]
                trial = Phi.copy()
                trial[:, lags[j]] = filtered[:, ends[j] - lags[j].size : ends[j]]
                r = _ridge_with_intercept(trial, y, self.alpha)[2]
                J[:, j] = (r - r0) / steps[j]
            return J

        x, (x_low, x_high) = _pair_coordinates(log_tau, lo, hi, self.order)
        n_iter = 1  # the grid search
        if self.max_iter > 0:
            # Keep the start strictly inside the bounds for the trust region.
            x0 = np.clip(x, x_low + 1e-9, x_high - 1e-9)
            sol = least_squares(
                residual,
                x0,
                bounds=(x_low, x_high),
                jac=jacobian,
                max_nfev=self.max_iter,
                x_scale=1.0,
            )
            n_iter += int(sol.nfev)
            if np.sum(sol.fun**2) <= np.sum(residual(x) ** 2):
                x = sol.x
        log_tau = to_log_tau(x)
        Phi = self._features(U, log_tau, dts, slices)
        coef, intercept, _ = _ridge_with_intercept(Phi, y, self.alpha)
        shape = (U.shape[1], self.order)
        return np.exp(log_tau).reshape(shape), coef.reshape(shape), intercept, n_iter

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, *, groups=None):
        """Identify the time constants and gains.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Temperatures (absolute readings, °C) and speed drivers. A ``run``
            column or index level marks the runs; a ``time_s`` index level
            gives the sampling interval.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Thermal error.
        groups : array-like of shape (n_samples,), optional
            Run label of every row; overrides a ``run`` column or index level.

        Returns
        -------
        self : object
            Fitted estimator.
        """
        bounds = self._check_tau_bounds()
        X_raw, groups = extract_runs(X, groups, y=y)
        X, y = validate_data(
            self, X_raw, y, y_numeric=True, multi_output=True, dtype=np.float64
        )
        if X.shape[0] < 2:
            raise ValueError(
                f"TransferFunctionRegressor needs at least 2 samples, got "
                f"n_samples = {X.shape[0]}."
            )
        slices, labels = run_slices(groups, X.shape[0])
        self.n_fitted_runs_ = None if groups is None else len(slices)
        self.speed_columns_ = self._speed_positions()
        warn_no_time(type(self).__name__, X_raw, self.dt)
        dts, self.sample_period_s_ = self._intervals(X_raw, groups, slices, labels)
        if bounds is None:
            longest = max((sl.stop - sl.start) * d for sl, d in zip(slices, dts))
            # A lag much slower than the longest run cannot be told from a
            # ramp by the data, and extrapolates like one.
            bounds = (0.1 * float(dts.min()), float(longest))
        U = self._inputs(X, slices)
        Y = y.reshape(X.shape[0], -1)
        grid = np.exp(np.linspace(*np.log(bounds), self.n_grid))
        # One BLAS thread: the search is a loop of small ridge solves and
        # trust-region SVDs, which threads only slow down on shared cores.
        with single_threaded_blas():
            starts = self._grid_search(U, Y, dts, slices, grid)
            fits = [
                self._fit_one(U, Y[:, k], dts, slices, bounds, np.log(start))
                for k, start in enumerate(starts)
            ]
        taus, coefs, intercepts, n_iter = (
            np.array(part) for part in zip(*fits, strict=True)
        )
        self.n_iter_ = int(n_iter.max())
        if y.ndim == 1:
            taus, coefs, intercepts = taus[0], coefs[0], float(intercepts[0])
        self.time_constants_ = taus
        self.coef_ = coefs
        self.intercept_ = intercepts
        # What continuing a labelled run in predict needs: its first row and
        # times, and every lag's last output.
        memory = run_memory(X, slices, labels, X_raw)
        if memory:
            F = self._lag_states(U, dts, slices)
            for sl, lab in zip(slices, labels, strict=True):
                if lab in memory:
                    memory[lab]["state"] = np.stack([f[sl.stop - 1] for f in F])
        self.run_states_ = memory
        return self

    def predict(self, X, *, groups=None):
        """Predict the thermal error, run by run from rest.

        A run label seen in ``fit`` continues that run (its later rows given
        alone are predicted as inside the whole run); a labelled run that
        starts inside its training span is an error; a run not seen in
        ``fit`` starts from rest at its first row, with a warning if its
        ``time_s`` does not start at 0. The same rules as the grey
        regressors.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Rows of runs: whole runs from their first sample (the lags start
            from rest), or the later rows of training runs.
        groups : array-like of shape (n_samples,), optional
            Run label of every row; overrides a ``run`` column or index level.

        Returns
        -------
        y_pred : ndarray of shape (n_samples,) or (n_samples, n_outputs)
        """
        check_is_fitted(self)
        X_raw, groups = extract_runs(X, groups)
        X = validate_data(self, X_raw, reset=False, dtype=np.float64)
        warn_unlabelled_runs(
            type(self).__name__, self.n_fitted_runs_, groups, X.shape[0]
        )
        slices, labels = run_slices(groups, X.shape[0])
        dts, _ = self._intervals(X_raw, groups, slices, labels, self.sample_period_s_)
        memory = getattr(self, "run_states_", {})
        cont = continued_runs(
            type(self).__name__, X, slices, labels, run_times(X_raw, slices), memory
        )
        if self.dt is None:  # a given dt overrides the times, pauses too
            warn_pauses(
                type(self).__name__, X_raw, slices, cont, memory, PAUSE_BRIDGE, 3
            )
        bases = continued_values(cont, memory, "x_first")
        U = self._inputs(X, slices, bases)
        states = continued_values(cont, memory, "state")
        # The inputs of a continued run's last training row: across a pause
        # they ramp from there, as within a run.
        previous = [
            None if x is None else self._inputs(x[None, :], [slice(0, 1)], [b])[0]
            for x, b in zip(
                continued_values(cont, memory, "x_last"), bases, strict=True
            )
        ]
        # A given dt overrides the index's times, also across pauses.
        times = row_times(X_raw) if self.dt is None else None
        periods = gap_periods(dts, cont, self.sample_period_s_)
        dts = continued_steps(dts, slices, times, cont, memory)
        coefs = self.coef_.reshape(-1, U.shape[1] * self.order)
        out = np.column_stack(
            [
                F @ coef
                for F, coef in zip(
                    self._lag_states(U, dts, slices, states, times, previous, periods),
                    coefs,
                    strict=True,
                )
            ]
        ) + np.atleast_1d(self.intercept_)
        return out[:, 0] if np.ndim(self.coef_) == 2 else out
