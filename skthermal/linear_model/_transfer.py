"""Transfer-function thermal-error model: first- or second-order lags of
temperature changes and of spindle speed, summed with linear gains.

The industrial baseline of Mareš, Horejš and Havlík (Precision Engineering 66,
2020), the kind of model that runs inside a CNC: every input drives the thermal
error through its own discrete low-order transfer function. Time constants are
identified by variable projection (for fixed time constants the error is linear
in the gains, which a least-squares solve gives exactly).
"""

import warnings
from numbers import Integral, Real

import numpy as np
from scipy import linalg
from scipy.optimize import least_squares
from scipy.signal import lfilter
from sklearn.base import BaseEstimator, RegressorMixin, _fit_context
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted, validate_data

from skthermal.preprocessing import exponential_filter
from skthermal.utils._folds import run_folds
from skthermal.utils._runs import (
    GAP_BRIDGE,
    PAUSE_BRIDGE,
    ForgetRunsMixin,
    changes_since_start,
    check_positive_numbers,
    continued_runs,
    continued_steps,
    continued_values,
    extend_memory,
    extract_runs,
    fitted_sample_periods,
    gap_periods,
    has_time_index,
    row_times,
    run_memory,
    run_sample_periods,
    run_slices,
    run_times,
    target_names,
    warn_centred_drivers,
    warn_dt_against_times,
    warn_gaps,
    warn_misnamed_time,
    warn_no_time,
    warn_pauses,
    warn_short_runs,
    warn_slow_periods,
    warn_start_offsets,
    warn_time_unit,
    warn_unlabelled_runs,
)
from skthermal.utils._threads import single_threaded_blas
from skthermal.utils._warnings import user_stacklevel

# Relative spread of the sampling interval tolerated within one run: the exact
# discretisation below assumes a constant step (the median one), and a
# logger's clock jitters by a few percent.
_DT_RTOL = 0.05
# Least ratio of the two time constants of an input with order=2. Two lags
# of nearly equal time constants are nearly the same column: their
# difference, with huge opposite gains, approximates the derivative of a
# lag with respect to its time constant (a second lag in series), which a
# fit free to merge them drifts to. Kept apart, the pair stays a sum of two
# distinct lags with gains of the size of the error; a series connection of
# two lags is such a sum (partial fractions), and one of two nearly equal
# lags is matched closely by a pair this far apart.
MIN_TAU_RATIO = 2.0
# Least reach of a lag at the upper bound of tau_bounds that fit warns
# about, as a share of the output's range over the training rows (reach:
# the gain times the range of the lag's input, where a slow lag ends if its
# input holds): below it, a slow lag with a gain near zero (the superfluous
# second lag of order=2 often ends there) changes nothing.
_BOUND_SHARE = 0.05
# Values held at once by the grid search's lags (a block of rows of all of
# them, see _grid_moments): 32 MB.
_GRID_BLOCK = 2**22
# Candidate penalties of alpha="auto": the least-squares fit of the original
# method and one penalty per decade, on the standardised lags (the range of
# the ridge grids of benchmarks/bench_real.py, which chose 1 to 1000 on the
# real FL_THERMAL record).
AUTO_ALPHAS = (0.0, 0.1, 1.0, 10.0, 100.0, 1000.0, 10000.0)
# Folds of alpha="auto", as LagRidgeCV's defaults (n_splits, first_fraction).
_CV_SPLITS = 4
_CV_FIRST = 0.4
# Rows per block of the blocked QR factorisation of the Jacobian (see
# _triangular_factor): small enough to stay in cache, large enough that the
# stacked factors are few.
_QR_BLOCK = 2048


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


def _fit_lags(Ut, tau, inputs, dts, slices, out=None):
    """The lags of :func:`first_order_lags` as ``fit`` needs them: one row
    per lag.

    From rest with a constant step per run: the filter calls of
    :func:`skthermal.preprocessing.exponential_filter`, but every lag its
    own (in the refinement no two lags share a time constant) and a
    contiguous row, which spares the copies in and out of the columns of a
    design and the inputs repeated per lag.

    Parameters
    ----------
    Ut : ndarray of shape (n_inputs, n_samples)
        Inputs, one row per input.
    tau : ndarray of shape (n_lags,)
        Time constant of every lag.
    inputs : ndarray of int of shape (n_lags,)
        Input (row of ``Ut``) of every lag.
    dts : ndarray of shape (n_runs,)
        Sampling interval of every run.
    slices : list of slice
        Runs.
    out : ndarray of shape (n_lags, n_samples), optional
        Where to put the lags.

    Returns
    -------
    Z : ndarray of shape (n_lags, n_samples)
    """
    Z = np.empty((tau.size, Ut.shape[1])) if out is None else out
    for sl, dt in zip(slices, dts, strict=True):
        if sl.stop <= sl.start:
            continue
        a = np.exp(-dt / tau)
        for j, (aj, i) in enumerate(zip(a, inputs, strict=True)):
            Z[j, sl] = lfilter([1.0 - aj], [1.0, -aj], Ut[i, sl])
    return Z


def _stretches(rows, slices, dts):
    """The runs ``slices`` (sampled every ``dts``) restricted to ``rows`` (sorted
    positions), as slices of ``rows`` and their intervals: the training or
    validation stretches of a fold, each from a run's start."""
    bounds = np.searchsorted(rows, [(sl.start, sl.stop) for sl in slices])
    keep = bounds[:, 1] > bounds[:, 0]
    return [slice(int(a), int(b)) for a, b in bounds[keep]], np.asarray(dts)[keep]


def _grid_moments(Ut, Y, dts, slices, grid):
    """Centred Gram matrix of the lags of every input at every grid time
    constant, and their products with the centred targets.

    The lags are formed and reduced a block of rows at a time (each block's
    filters continued from the last row of the one before): the Gram matrix
    is small, but all the lags at once held ``n_samples * n_inputs *
    n_grid`` values (1 GB at 1e5 rows, 80 inputs and 15 grid points, and as
    much again while stacking them). The column means, needed before the
    first block, come in closed form: from rest, the lag of time constant
    ``tau`` summed over a run of ``N`` rows is ``sum_i u[i] (1 - a^(N - i))``
    with ``a = exp(-dt / tau)``.

    Parameters
    ----------
    Ut : ndarray of shape (n_inputs, n_samples)
        Inputs, one row per input.
    Y : ndarray of shape (n_samples, n_outputs)
        Targets.
    dts, slices
        Sampling interval and rows of every run.
    grid : ndarray of shape (n_grid,)
        Time constants.

    Returns
    -------
    gram : ndarray of shape (n_inputs * n_grid, n_inputs * n_grid)
        Columns ordered (input, grid point): column ``i * n_grid + g``.
    cross : ndarray of shape (n_inputs * n_grid, n_outputs)
    """
    n_in, n = Ut.shape
    n_lags = n_in * grid.size
    sums = np.zeros((n_in, grid.size))
    for sl, dt in zip(slices, dts, strict=True):
        left = np.arange(sl.stop - sl.start, 0, -1)[:, None]  # N - i
        sums -= Ut[:, sl] @ np.expm1(-left * dt / grid)
    mean = sums.reshape(n_lags) / n
    Yc = Y - Y.mean(axis=0)
    rows = max(1, min(n, _GRID_BLOCK // n_lags))
    block = np.empty((n_in, grid.size, rows))

    def blocks():
        # Fill the block with the lags of consecutive rows, run after run.
        fill, pieces = 0, []
        state = np.empty((n_in, grid.size))
        for sl, dt in zip(slices, dts, strict=True):
            a = np.exp(-dt / grid)
            state[:] = 0.0
            start = sl.start
            while start < sl.stop:
                take = min(sl.stop - start, rows - fill)
                u = Ut[:, start : start + take]
                for g, ag in enumerate(a):
                    z = lfilter(
                        [1.0 - ag], [1.0, -ag], u, axis=1, zi=ag * state[:, g, None]
                    )[0]
                    block[:, g, fill : fill + take] = z
                    state[:, g] = z[:, -1]
                pieces.append(slice(start, start + take))
                fill += take
                start += take
                if fill == rows:
                    yield fill, pieces
                    fill, pieces = 0, []
        if fill:
            yield fill, pieces

    gram = np.zeros((n_lags, n_lags))
    cross = np.zeros((n_lags, Y.shape[1]))
    for fill, pieces in blocks():
        lags = block.reshape(n_lags, rows)[:, :fill]
        lags -= mean[:, None]
        gram += lags @ lags.T
        cross += lags @ np.concatenate([Yc[sl] for sl in pieces])
    return gram, cross


def _standardise(Z):
    """Centre the rows of ``Z`` and scale them to a mean square of one (a
    constant row left at zero), in place; return the means and scales."""
    mean = Z.mean(axis=1)
    Z -= mean[:, None]
    scale = np.sqrt(np.einsum("ij,ij->i", Z, Z) / Z.shape[1])
    scale[scale < 1e-12] = 1.0
    Z /= scale[:, None]
    return mean, scale


def _ridge_residual(A, yc, alpha):
    """Normal equations, gains and residual vector of the ridge of ``yc``
    (centred target) on the standardised lags ``A`` (one row each).

    The normal equations of the (small) standardised problem: a few times
    faster than a least-squares solve of the tall matrix, and this runs for
    every trial of the time constants. Returns the Gram matrix with the
    penalty on its diagonal, the gains ``w`` and the residual vector ``[yc -
    A'w, sqrt(alpha) w]`` whose sum of squares the refinement minimises.
    """
    gram = A @ A.T
    gram[np.diag_indices_from(gram)] += alpha
    w = _solve_normal(gram, A @ yc)
    return gram, w, np.concatenate([yc - w @ A, np.sqrt(alpha) * w])


def _orthonormal_basis(A, alpha, gram, out=None):
    """QR factorisation ``[A'; sqrt(alpha) I] = Q R`` of the ridge's design.

    Cholesky QR twice (``R1`` the Cholesky factor of the Gram matrix, ``Q1 =
    [A'; sqrt(alpha) I] R1^-1``, and again on ``Q1``): products and
    triangular solves of the tall matrix, which run at the speed of a
    matrix product, where Householder QR (and the forming of its ``Q``)
    took ten times longer. The first pass loses orthogonality as the square
    of the design's condition number; the second restores it to rounding
    when the first left ``Q1' Q1`` near the identity (a condition number up
    to some 1e7). Else, and when the Gram matrix is singular to rounding,
    Householder QR. ``out``, of the shape of ``A``, takes ``Qn``.

    Returns
    -------
    Qn : ndarray of shape (n_lags, n_samples)
        The rows of ``Q`` for the samples, transposed.
    Qp : ndarray of shape (n_lags, n_lags)
        Those for the penalty, transposed.
    R : ndarray of shape (n_lags, n_lags)
    """
    p, n = A.shape
    try:
        R1 = linalg.cholesky(gram, check_finite=False)
        # Qn' <- Qn' R1^-1, in place through the transposes' Fortran order.
        Qn = np.empty_like(A) if out is None else out
        Qn[:] = A
        _solve_right(Qn, R1)
        Qp = np.sqrt(alpha) * linalg.solve_triangular(
            R1, np.eye(p), trans="T", check_finite=False
        )
        G2 = Qn @ Qn.T + Qp @ Qp.T
        if not np.max(np.abs(G2 - np.eye(p))) < 0.1:
            raise linalg.LinAlgError("the first pass lost orthogonality")
        R2 = linalg.cholesky(G2, check_finite=False)
        _solve_right(Qn, R2)
        Qp = linalg.solve_triangular(R2, Qp, trans="T", check_finite=False)
        return Qn, Qp, R2 @ R1
    except linalg.LinAlgError:
        Q, R = np.linalg.qr(np.vstack([A.T, np.sqrt(alpha) * np.eye(p)]))
        return np.ascontiguousarray(Q[:n].T), np.ascontiguousarray(Q[n:].T), R


def _solve_right(C, R):
    """``C <- R^-T C`` in place (``R`` upper-triangular, ``C`` wide and
    C-ordered), through the transpose's Fortran order: ``C' <- C' R^-1``."""
    out = linalg.blas.dtrsm(1.0, R, C.T, side=1, overwrite_b=True)
    if not np.shares_memory(out, C):  # BLAS wrote to a copy
        C[...] = out.T


def _accumulate(C, A, B, alpha=1.0):
    """``C += alpha A @ B`` in place, ``B`` and ``C`` wide and C-ordered:
    through the transposes' Fortran order, without a temporary of ``C``'s
    size."""
    out = linalg.blas.dgemm(alpha, B.T, A.T, beta=1.0, c=C.T, overwrite_c=True)
    if not np.shares_memory(out, C):  # BLAS wrote to a copy
        C[...] = out.T


def _ridge_column_changes(A, yc, alpha, gram, groups, new, out=None, basis=None):
    """Changes of the residual vector of :func:`_ridge_residual` when groups
    of lags are replaced, one group at a time.

    The finite-difference Jacobian replaces the one or two lags of one time
    constant at a time. A full solve for each costs a Gram matrix and a
    Cholesky factorisation of all the lags, so the Jacobian grew with the
    cube of the number of lags; and it is only as accurate as the normal
    equations, off by several per cent with hundreds of nearly dependent
    lags. Here one QR factorisation of the design (augmented for the ridge,
    :func:`_orthonormal_basis`) serves all the replacements: products with
    all the new lags at once, then per group a few vectors of the length of
    a lag and a solve of the group's size.

    Parameters
    ----------
    A : ndarray of shape (n_lags, n_samples)
        Standardised lags (:func:`_standardise`), one row each.
    yc : ndarray of shape (n_samples,)
        Centred target.
    alpha : float
        Ridge penalty, as in :func:`_ridge_residual`.
    gram : ndarray of shape (n_lags, n_lags)
        ``A A' + alpha I``.
    groups : list of ndarray of int
        The lags that each change replaces.
    new : ndarray of shape (n_new, n_samples)
        Their new standardised lags, group after group; overwritten.
    out : tuple of ndarray, optional
        Where to put the changes (C-ordered), as returned.
    basis : ndarray of the shape of ``A``, optional
        Work space (see :func:`_orthonormal_basis`).

    Returns
    -------
    changes : tuple of ndarray or None
        Per group, the residual vector of :func:`_ridge_residual` with the
        group's lags replaced, less that of ``A``: its entries for the
        samples, of shape (len(groups), n_samples), and for the penalty, of
        shape (len(groups), n_lags). NaN where the new design is (nearly)
        singular, and None when ``A``'s is: there the normal equations of a
        direct solve fall back to a least-norm solution, which is left to
        them (:func:`_direct_changes`).
    """
    p, n = A.shape
    Qn, Qp, R = _orthonormal_basis(A, alpha, gram, basis)
    # The squares of R's diagonal are the pivots of a Cholesky factorisation
    # of the Gram matrix R'R: below the rounding of the largest, it fails.
    tiny = 1e-16 * np.max(np.diag(R) ** 2)
    if not np.min(np.diag(R) ** 2) > tiny:
        return None
    z = Qn @ yc
    base_n, base_p = yc - z @ Qn, -(z @ Qp)
    R_inv = linalg.solve_triangular(R, np.eye(p), check_finite=False)
    cols = np.concatenate(groups)
    for row, col in enumerate(cols):  # the changes of the lags, in place
        new[row] -= A[col]
    # The new lags within Q's span (coordinates t) and orthogonal to it
    # (outside), projected twice: once loses digits to nearly dependent
    # lags. (The changes are zero in the penalty's rows.)
    inside = Qn @ new.T
    out_n, out_p = new, -(inside.T @ Qp)
    _accumulate(out_n, inside.T, Qn, -1.0)
    again = Qn @ out_n.T + Qp @ out_p.T
    _accumulate(out_n, again.T, Qn, -1.0)
    out_p -= again.T @ Qp
    t = R[:, cols] + inside + again
    o_base = out_n @ base_n + out_p @ base_p
    # In Q's coordinates the kept lags span the orthogonal complement of N,
    # a basis of the replaced lags' rows of R^-1 (each orthogonal to R's
    # other columns). Off the kept lags, y is Q N N'z + base and the new
    # lags Q N N't + o, whose least squares give their gains beta and the
    # new residual Q N (N'z - N't beta) + base - o beta.
    within = np.zeros((p, len(groups)))
    if out is None:
        out = np.empty((len(groups), n)), np.empty((len(groups), p))
    changes_n, changes_p = out
    changes_n[:] = 0.0
    changes_p[:] = 0.0
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
        o_n, o_p = out_n[block], out_p[block]
        # The new lags' Gram off the kept ones: the last pivots of a
        # Cholesky factorisation with them last.
        gram_g = Nt.T @ Nt + o_n @ o_n.T + o_p @ o_p.T
        if not np.linalg.eigvalsh(gram_g)[0] > tiny:
            bad[g] = True
            continue
        beta = np.linalg.solve(gram_g, Nt.T @ Nz + o_base[block])
        within[:, g] = N @ (Nz - Nt @ beta)
        changes_n[g] = -(beta @ o_n)
        changes_p[g] = -(beta @ o_p)
    _accumulate(changes_n, within.T, Qn)
    changes_p += within.T @ Qp
    # The augmented rows hold -sqrt(alpha) w, the residual vector +.
    changes_p *= -1.0 if alpha > 0 else 0.0
    changes_n[bad] = np.nan
    changes_p[bad] = np.nan
    return changes_n, changes_p


def _direct_changes(A, yc, alpha, gram, w, groups, new):
    """What :func:`_ridge_column_changes` gives, by the normal equations of
    each new design (a least-norm solution where singular), as
    :func:`_ridge_residual` solves them (``gram`` and ``w`` its Gram matrix
    and gains for ``A``): the Gram matrix with the group's rows and columns
    replaced, products with all the new lags at once. The changes of the
    residual are formed from those of the gains, so a replacement that
    changes nothing (an input at rest) changes it by exactly zero, as
    refitting from scratch did."""
    p, n = A.shape
    cross = A @ new.T
    b, b_new = A @ yc, new @ yc
    dW = np.empty((len(groups), p))
    end = 0
    for g, group in enumerate(groups):
        block = slice(end, end + group.size)
        end += group.size
        G = gram.copy()
        G[group] = cross[:, block].T
        G[:, group] = cross[:, block]
        G[np.ix_(group, group)] = new[block] @ new[block].T
        G[group, group] += alpha
        rhs = b.copy()
        rhs[group] = b_new[block]
        dW[g] = _solve_normal(G, rhs) - w
    changes_n = -(dW @ A)
    end = 0
    for g, group in enumerate(groups):
        block = slice(end, end + group.size)
        end += group.size
        changes_n[g] -= (w[group] + dW[g, group]) @ (new[block] - A[group])
    return changes_n, np.sqrt(alpha) * dW


def _triangular_factor(Kn, Kp):
    """Upper-triangular ``R`` with ``R'R = Kn Kn' + Kp Kp'`` and a
    nonnegative diagonal: the ``R`` of the QR factorisation of ``[Kn';
    Kp']``.

    The Cholesky factor of the Gram matrix, one product of the tall matrix
    with itself, a fifth of the time of Householder QR: backward stable, so
    ``R'R`` is the Gram matrix to rounding, which keeps the directions of
    the rows down to ``1e-8`` of the strongest (those of a finite-difference
    Jacobian are exact to ``1e-3``). When the Gram matrix is singular to
    rounding (a row of zeros: a step that moves no lag), Householder QR by
    blocks of ``_QR_BLOCK`` columns of ``Kn`` whose factors are then
    factorised together (the blocks stay in cache).
    """
    k = Kn.shape[0]
    try:
        return linalg.cholesky(Kn @ Kn.T + Kp @ Kp.T, check_finite=False)
    except linalg.LinAlgError:
        pass
    geqrf = linalg.lapack.dgeqrf
    parts = [Kp.T]
    for start in range(0, Kn.shape[1], _QR_BLOCK):
        parts.append(np.triu(geqrf(Kn[:, start : start + _QR_BLOCK].T)[0][:k]))
    top = np.triu(geqrf(np.vstack(parts))[0][:k])
    R = np.zeros((k, k))
    R[: top.shape[0]] = top
    return R * np.where(np.diag(R) < 0, -1.0, 1.0)[:, None]


class TransferFunctionRegressor(ForgetRunsMixin, RegressorMixin, BaseEstimator):
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
    alpha : float or "auto", default="auto"
        Ridge penalty on the gains of the standardised lag features (each of
        sum of squares ``n_samples``, as ``Ridge`` after ``StandardScaler``);
        it steadies the gains of many collinear temperatures. 0 is the
        least-squares fit of the original method. ``"auto"``: chosen per
        output among ``alphas`` by time-ordered cross-validation on the
        training rows, the folds of ``LagRidgeCV``'s ``cv="auto"`` (whole runs
        left out when there are several, else expanding windows: fit on the
        first 40, 55, 70, 85% of the rows, score the next 15%), each
        validation stretch predicted from its run's start with the time
        constants and gains identified on the fold's training rows (within
        the whole fit's ``tau_bounds``; a fold that keeps fewer than 40% of
        the rows for training is skipped). With
        many collinear temperatures the least-squares gains cancel one
        another: on a 48 h spindle record with 13 temperatures the held-out
        error was 52 times linear regression's at ``alpha=0`` and 2.2 times
        with the chosen penalty; on the real FL_THERMAL record the chosen
        penalties took channels 1 and 2 from 1.74 and 1.61 times linear
        regression to 0.25 and 0.37. Where least squares does not blow up,
        the choice is about as good on average (0.47 to 2.55 times its
        error in an independent check's 35 cases, 1.03 in the geometric
        mean). The fit takes some 20 times longer.
    alphas : array-like of float or None, default=None
        Candidate penalties of ``alpha="auto"``, finite and >= 0 (ignored
        otherwise). None: ``AUTO_ALPHAS``, 0 and 0.1 to 10^4 one per
        decade.
    dt : float or None, default=None
        Sampling interval. None: read from the ``time_s`` index level of
        ``X`` (:func:`skthermal.datasets.split_runs`), one interval per run
        (a run of one row takes that of the others; an error when no run has
        two rows), or 1 (time constants in samples) when ``X`` has no such
        level. A number overrides the index. ``fit`` needs each run sampled
        at a constant interval; ``predict`` follows the times, across gaps
        too (with a warning; the inputs taken to change linearly over a
        gap).
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
    lag_coef_ : ndarray of shape (n_inputs, order) or (n_outputs, n_inputs, order)
        Gain of every lag (error per unit of temperature change, or per unit
        of heat power, in steady state), beside ``time_constants_``.
    coef_ : ndarray of shape (n_inputs,) or (n_outputs, n_inputs)
        Steady-state gain of every input: the sum of its lags' gains (what
        the error changes per unit of a held input change once every lag has
        settled). scikit-learn's layout, one weight per column of ``X``, so
        ``RFE`` and ``SelectFromModel`` read it.
    intercept_ : float or ndarray of shape (n_outputs,)
    alpha_ : float or ndarray of shape (n_outputs,)
        The penalty used: ``alpha``, or the one the cross-validation chose
        for every output.
    cv_results_ : dict
        With ``alpha="auto"``: ``"alpha"``, the candidates, and ``"rmse"``,
        the validation root mean square error of each (shape (n_alphas,) or
        (n_alphas, n_outputs), as ``y``), over all folds' validation rows
        (NaN when no fold could be formed). Of candidates whose errors tie,
        the largest penalty is chosen.
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
        "alpha": [Interval(Real, 0, None, closed="left"), StrOptions({"auto"})],
        "alphas": [None, "array-like"],
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
        alpha="auto",
        alphas=None,
        dt=None,
        tau_bounds=None,
        n_grid=15,
        max_iter=30,
    ):
        self.speed_column = speed_column
        self.speed_exponent = speed_exponent
        self.order = order
        self.alpha = alpha
        self.alphas = alphas
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
        row taking that of the others (:func:`fitted_sample_periods`), each
        run sampled at a constant interval (the identification filters at
        one step per run); in ``predict``, the median step of each run (the
        filters then follow the times, gaps included), a run without times
        taking the fitted ``period``."""
        name = type(self).__name__
        if self.dt is not None:
            if period is None:
                warn_dt_against_times(name, X_raw, slices, labels, float(self.dt))
            return np.full(len(slices), float(self.dt)), float(self.dt)
        if period is None:
            kwargs = {"labels": labels, "regular": name, "rtol": _DT_RTOL}
            return fitted_sample_periods(X_raw, groups, slices, None, name, **kwargs)
        return run_sample_periods(X_raw, groups, slices, period), period

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

    def _grid_search(self, Ut, Y, grid, alpha, moments):
        """Time constants on the log grid, for every output, from shared lags.

        Every input is filtered once per grid time constant; the centred Gram
        matrix of all these lags then gives the ridge cost of any choice of
        one grid time constant per lag from a small solve, without filtering
        again: a common time constant (pair, for ``order=2``), then sweeps of
        1-D searches over each lag's own time constant until none improves.
        ``moments``: :func:`_grid_moments` of ``Ut`` and ``Y`` (copied here).
        """
        n_in, n = Ut.shape
        n_grid = grid.size
        # Columns ordered (input, grid point): column i * n_grid + g.
        gram, cross = (m.copy() for m in moments)
        scale = np.sqrt(np.diag(gram) / n)
        scale[scale < 1e-12] = 1.0
        gram /= np.outer(scale, scale)
        cross /= scale[:, None]
        yy = np.sum((Y - Y.mean(axis=0)) ** 2, axis=0)
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

        eye = alpha * np.eye(base.size)

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
            diag = gram[cand, cand] + alpha
            G = gram[np.ix_(rest, rest)]
            G[np.diag_indices_from(G)] += alpha
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

    def _identify(self, Ut, Y, dts, slices, bounds, grid, alphas, moments=None):
        """Time constants, gains, intercept, evaluations and last lag
        outputs of every output, each with its own penalty ``alphas[k]``: the
        grid search (shared by the outputs of one penalty), then the
        refinement of each. ``moments``: :func:`_grid_moments` of ``Ut`` and
        ``Y``, which no penalty changes (computed when None)."""
        if moments is None:
            moments = _grid_moments(Ut, Y, dts, slices, grid)
        gram, cross = moments
        starts = [None] * Y.shape[1]
        for alpha in np.unique(alphas):
            cols = np.flatnonzero(alphas == alpha)
            found = self._grid_search(
                Ut, Y[:, cols], grid, alpha, (gram, cross[:, cols])
            )
            for k, start in zip(cols, found, strict=True):
                starts[k] = start
        return [
            self._fit_one(Ut, Y[:, k], dts, slices, bounds, np.log(start), alphas[k])
            for k, start in enumerate(starts)
        ]

    def _choose_alphas(self, Ut, Y, dts, slices, labels, bounds, grid):
        """The penalty of every output by time-ordered cross-validation (see
        ``alpha``), and the validation errors of all candidates."""
        name = type(self).__name__
        candidates = (
            np.array(AUTO_ALPHAS)
            if self.alphas is None
            else check_positive_numbers(
                self.alphas,
                "alphas",
                name,
                empty=False,
                allow_zero=True,
                why="ridge penalties",
            )
        )
        n, n_out = Y.shape
        folds = run_folds("auto", slices, labels, n, _CV_SPLITS, _CV_FIRST, name)
        sse = np.zeros((candidates.size, n_out))
        if not folds:
            warnings.warn(
                f"{name}: {n} training row(s) leave no cross-validation fold, so "
                f"alpha='auto' cannot choose a penalty: the first candidate, "
                f"{candidates[0]:g}, is taken. Give more rows or set alpha.",
                UserWarning,
                stacklevel=user_stacklevel(),
            )
        inputs = np.arange(Ut.shape[0] * self.order) // self.order
        for tr, va in folds:
            tr_slices, tr_dts = _stretches(tr, slices, dts)
            # Every validation stretch from its run's start, scored on its own
            # rows: the lags start at rest there, as in predict.
            upto = np.concatenate(
                [
                    np.arange(sl.start, va[(va >= sl.start) & (va < sl.stop)].max() + 1)
                    for sl in slices
                    if np.any((va >= sl.start) & (va < sl.stop))
                ]
            )
            va_slices, va_dts = _stretches(upto, slices, dts)
            scored = np.isin(upto, va)
            Ut_tr, Y_tr, Ut_va, Y_va = Ut[:, tr], Y[tr], Ut[:, upto], Y[upto[scored]]
            # The lags' moments on the fold's rows, for every candidate.
            moments = _grid_moments(Ut_tr, Y_tr, tr_dts, tr_slices, grid)
            for i, alpha in enumerate(candidates):
                fits = self._identify(
                    Ut_tr,
                    Y_tr,
                    tr_dts,
                    tr_slices,
                    bounds,
                    grid,
                    np.full(n_out, alpha),
                    moments,
                )
                for k, (tau, coef, intercept, *_) in enumerate(fits):
                    Z = _fit_lags(Ut_va, tau.ravel(), inputs, va_dts, va_slices)
                    pred = intercept + coef.ravel() @ Z[:, scored]
                    sse[i, k] += np.sum((pred - Y_va[:, k]) ** 2)
        scored_rows = sum(va.size for _, va in folds)
        rmse = np.sqrt(sse / scored_rows) if scored_rows else np.full_like(sse, np.nan)
        # The least error; of candidates that tie with it (to rounding: a
        # constant output, say), the largest penalty, the steadiest gains.
        if folds:
            ties = sse <= sse.min(axis=0) * (1 + 1e-9) + 1e-300
            chosen = candidates[[int(np.flatnonzero(t)[-1]) for t in ties.T]]
        else:
            chosen = np.full(n_out, candidates[0])
        return chosen, {"alpha": candidates, "rmse": rmse}

    def _fit_one(self, Ut, y, dts, slices, bounds, log_tau, alpha):
        """Refine the time constants of one output from the grid search's;
        return them, the gains, the intercept, the evaluations and every
        run's last lag outputs."""
        lo, hi = np.log(bounds)
        n_lags, n = log_tau.size, Ut.shape[1]
        inputs = np.arange(n_lags) // self.order
        yc = y - y.mean()
        # The refinement sees the output in units of its standard deviation:
        # its stopping rules (a gradient below 1e-8) are absolute, and the
        # same displacements in metres stopped it at the start (the time
        # constants then depended on the unit of y). The ridge solution is
        # linear in y, so the optimum is the same; the gains below are
        # solved from y itself.
        spread = float(np.std(yc))
        y_refine = yc / spread if spread > 0 else yc
        # Work space of the refinement, allocated once: arrays of the size
        # of the design, which every evaluation faulted in afresh (a tenth
        # of a second each at 1e5 rows and 80 lags). The lags; the basis of
        # their span; the moved lags of all the steps (one lag per step, or
        # per input two and one); and the residual and its changes.
        buffer = np.empty((n_lags, n))
        if self.max_iter > 0:
            basis = np.empty((n_lags, n))
            moved_lags = np.empty((n_lags + (self.order - 1) * Ut.shape[0], n))
            Kn, Kp = np.empty((n_lags + 1, n)), np.empty((n_lags + 1, n_lags))

        def to_log_tau(x):
            return _pair_log_tau(x, lo, hi, self.order)

        last = {}

        def evaluate(x):
            # Standardised lags, Gram matrix, gains and residual vector. The
            # Jacobian is taken where the residual was just evaluated:
            # filter the lags once for both.
            key = x.tobytes()
            if key not in last:
                last.clear()
                tau = np.exp(to_log_tau(x))
                A = _fit_lags(Ut, tau, inputs, dts, slices, buffer)
                _standardise(A)
                last[key] = (A, *_ridge_residual(A, y_refine, alpha))
            return last[key]

        # The refinement sees only sums of squares and products of the
        # residual vector and of the Jacobian's columns (its trust region
        # comes from an SVD of the Jacobian and the residual's coordinates
        # on its singular vectors), which are the same in any orthonormal
        # coordinates of their span. In coordinates whose first axis is the
        # residual, that is (norm, 0, ..., 0), and the Jacobian the
        # triangular factor of the QR factorisation of [residual, J]: rows
        # of the number of time constants plus one, where vectors of
        # n_samples rows cost it an SVD of the tall Jacobian per step, as
        # much as all the rest. (Its rank test, singular values against
        # 2.2e-16 times the number of rows, is then stricter: a Jacobian
        # whose weakest direction is 1e-14 to 1e-11 of its strongest, at
        # the rounding of the differences, counts as of full rank.)
        def residual(x):
            rho = evaluate(x)[-1]
            out = np.zeros(x.size + 1)
            out[0] = np.sqrt(rho @ rho)
            return out

        def jacobian(x, *args):
            # Forward differences, refiltering only the lags whose time
            # constants move (the other rows of the design are unchanged)
            # and solving with them replaced from one factorisation of the
            # whole design (see _ridge_column_changes).
            A, gram, w, rho = evaluate(x)
            log_tau = to_log_tau(x)
            steps, moved = np.empty(x.size), []
            for j, xj in enumerate(x):
                h = 1e-3 * max(1.0, abs(xj))
                steps[j] = h if xj + h <= x_high[j] else -h
                step = x.copy()
                step[j] += steps[j]
                moved.append(to_log_tau(step))
            lags = [np.flatnonzero(m != log_tau) for m in moved]
            cols = np.concatenate(lags)
            tau = np.exp(
                np.concatenate([m[c] for m, c in zip(moved, lags, strict=True)])
            )

            def new_lags():
                # The moved lags of all the steps, standardised.
                Z = moved_lags[: cols.size]
                _fit_lags(Ut, tau, inputs[cols], dts, slices, Z)
                _standardise(Z)
                return Z

            # Rows: the residual, then the changes of every step.
            Kn[0], Kp[0] = rho[:n], rho[n:]
            changes = _ridge_column_changes(
                A,
                y_refine,
                alpha,
                gram,
                lags,
                new_lags(),
                (Kn[1:], Kp[1:]),
                basis,
            )
            if changes is None:
                bad = np.ones(x.size, dtype=bool)
            else:
                bad = np.isnan(Kn[1:]).any(axis=1)
            if bad.any():
                # (Nearly) singular: the direct solve, as before.
                ends = np.cumsum([c.size for c in lags])
                pick = np.flatnonzero(bad)
                rows = np.concatenate(
                    [np.arange(ends[j] - lags[j].size, ends[j]) for j in pick]
                )
                direct = _direct_changes(
                    A,
                    y_refine,
                    alpha,
                    gram,
                    w,
                    [lags[j] for j in pick],
                    new_lags()[rows],
                )
                Kn[1 + pick], Kp[1 + pick] = direct
            Kn[1:] /= steps[:, None]
            Kp[1:] /= steps[:, None]
            return _triangular_factor(Kn, Kp)[:, 1:]

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
        last.clear()
        log_tau = to_log_tau(x)
        Z = _fit_lags(Ut, np.exp(log_tau), inputs, dts, slices, buffer)
        states = Z[:, [sl.stop - 1 for sl in slices]].T
        mean, scale = _standardise(Z)
        w = _ridge_residual(Z, yc, alpha)[1]
        coef = w / scale
        intercept = y.mean() - mean @ coef
        shape = (Ut.shape[0], self.order)
        return (
            np.exp(log_tau).reshape(shape),
            coef.reshape(shape),
            intercept,
            n_iter,
            states,
        )

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
        warn_time_unit(X_raw, groups)
        names = target_names(y)
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
        warn_centred_drivers(
            type(self).__name__,
            X,
            self.speed_columns_,
            getattr(self, "feature_names_in_", None),
        )
        warn_no_time(type(self).__name__, X_raw, self.dt)
        dts, self.sample_period_s_ = self._intervals(X_raw, groups, slices, labels)
        warn_start_offsets(type(self).__name__, y, slices, names, labels)
        if self.dt is not None or has_time_index(X_raw):
            spans = [(sl.stop - sl.start - 1) * d for sl, d in zip(slices, dts)]
            warn_short_runs(
                type(self).__name__,
                dict(zip(labels, spans, strict=True)),
                stacklevel=user_stacklevel(),
            )
        if bounds is None:
            longest = max((sl.stop - sl.start) * d for sl, d in zip(slices, dts))
            # A lag much slower than the longest run cannot be told from a
            # ramp by the data, and extrapolates like one.
            bounds = (0.1 * float(dts.min()), float(longest))
        # One row per input: every lag a contiguous series (see _fit_lags).
        Ut = np.ascontiguousarray(self._inputs(X, slices).T)
        Y = y.reshape(X.shape[0], -1)
        grid = np.exp(np.linspace(*np.log(bounds), self.n_grid))
        # One BLAS thread: the search is a loop of small ridge solves and
        # trust-region SVDs, which threads only slow down on shared cores.
        with single_threaded_blas():
            if self.alpha == "auto":
                alphas, results = self._choose_alphas(
                    Ut, Y, dts, slices, labels, bounds, grid
                )
                if y.ndim == 1:  # shaped as alpha_
                    results["rmse"] = results["rmse"][:, 0]
                self.cv_results_ = results
            else:
                alphas = np.full(Y.shape[1], float(self.alpha))
                # Not a stale choice of an earlier fit with alpha="auto".
                self.__dict__.pop("cv_results_", None)
            fits = self._identify(Ut, Y, dts, slices, bounds, grid, alphas)
        taus, coefs, intercepts, n_iter, states = (
            np.array(part) for part in zip(*fits, strict=True)
        )
        self.n_iter_ = int(n_iter.max())
        self.alpha_ = float(alphas[0]) if y.ndim == 1 else alphas
        self._warn_at_bounds(
            taus, coefs, Ut, Y, bounds, tau_bounds_given=self.tau_bounds is not None
        )
        if y.ndim == 1:
            taus, coefs, intercepts = taus[0], coefs[0], float(intercepts[0])
        self.time_constants_ = taus
        self.lag_coef_ = coefs
        self.coef_ = coefs.sum(axis=-1)
        self.intercept_ = intercepts
        # What continuing a labelled run in predict needs: its first row and
        # times, and every lag's last output.
        memory = run_memory(X, slices, labels, X_raw)
        for r, lab in enumerate(labels):
            if lab in memory:
                memory[lab]["state"] = states[:, r]
        self.run_states_ = memory
        return self

    def _warn_at_bounds(self, taus, coefs, Ut, Y, bounds, tau_bounds_given):
        """Warn naming the inputs whose time constant ends at the upper bound
        of ``tau_bounds`` (within 1%) with a lag that matters: the data did
        not fix it there, and its gain extrapolates (an independent check
        found slow sensors at the upper bound, the training span, with gains
        of -21 and -130 µm/K and a held-out error growing through the test
        part). A lag matters when its reach, its gain times the range of its
        input over the training rows (where the lag ends if the input
        holds), is at least :data:`_BOUND_SHARE` of the output's range: with
        ``order=2`` a superfluous second lag often ends at the bound with a
        gain near zero, and says nothing. A lag at the lower bound is an
        input that acts at once: nothing to say."""
        hi = bounds[1]
        taus = taus.reshape(Y.shape[1], -1)
        coefs = coefs.reshape(Y.shape[1], -1)
        inputs = np.arange(taus.shape[1]) // self.order
        reach = np.abs(coefs) * np.ptp(Ut, axis=1)[inputs]
        matters = reach > _BOUND_SHARE * np.ptp(Y, axis=0)[:, None]
        at_hi = np.zeros(Ut.shape[0], dtype=bool)
        at_hi[inputs[((taus >= hi / 1.01) & matters).any(axis=0)]] = True
        if not at_hi.any():
            return
        names = getattr(self, "feature_names_in_", None)
        shown = [
            repr(str(names[i])) if names is not None else f"input {i}"
            for i in np.flatnonzero(at_hi)
        ]
        where = "given" if tau_bounds_given else "the longest training run"
        warnings.warn(
            f"TransferFunctionRegressor: the time constant of {', '.join(shown)} "
            f"ends at the upper bound of tau_bounds ({hi:g} s, {where}): the "
            "training data do not fix it, and a lag that slow fits a drift "
            "with a large gain, which extrapolates. Leave such an input out, "
            "give longer or more runs, or a larger alpha.",
            UserWarning,
            stacklevel=user_stacklevel(),
        )

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
        lags, _ = self._continued(X, groups)
        # One row of lag coefficients per output.
        lag_coef = self.lag_coef_
        coefs = lag_coef.reshape(-1, int(np.prod(lag_coef.shape[-2:])))
        out = np.column_stack(
            [F @ coef for F, coef in zip(lags, coefs, strict=True)]
        ) + np.atleast_1d(self.intercept_)
        return out[:, 0] if np.ndim(lag_coef) == 2 else out

    def _continued(self, X, groups):
        """The lag features of every output (a list) for ``X``, continuing
        the runs this model remembers, and what :meth:`remember_runs` needs:
        ``(X_raw, X, slices, labels, cont)``."""
        X_raw, groups = extract_runs(X, groups)
        X = validate_data(self, X_raw, reset=False, dtype=np.float64)
        warn_unlabelled_runs(
            type(self).__name__, self.n_fitted_runs_, groups, X.shape[0]
        )
        slices, labels = run_slices(groups, X.shape[0])
        dts, _ = self._intervals(X_raw, groups, slices, labels, self.sample_period_s_)
        memory = getattr(self, "run_states_", {})
        cont = continued_runs(
            type(self).__name__,
            X,
            slices,
            labels,
            run_times(X_raw, slices),
            memory,
            stacklevel=4,
        )
        if self.dt is None:  # a given dt overrides the times, pauses too
            warn_pauses(
                type(self).__name__, X_raw, slices, cont, memory, PAUSE_BRIDGE, 4
            )
            warn_slow_periods(
                type(self).__name__, X_raw, slices, labels, self.sample_period_s_, 4
            )
            warn_gaps(type(self).__name__, X_raw, slices, labels, GAP_BRIDGE, 4)
            warn_misnamed_time(type(self).__name__, X_raw, self.sample_period_s_, 4)
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
        periods = gap_periods(dts, cont, self.sample_period_s_, memory)
        dts = continued_steps(dts, slices, times, cont, memory)
        lags = self._lag_states(U, dts, slices, states, times, previous, periods)
        return lags, (X_raw, X, slices, labels, cont)

    def remember_runs(self, X, *, groups=None):
        """Remember where the runs of ``X`` end, so the next call continues them.

        For prediction on a stream: after :meth:`predict` of a block of rows,
        call this with the same rows; the next block of a run (its label,
        later ``time_s``) is then predicted as the whole run given at once
        would be, at a cost that does not grow with the run's length.
        :class:`skthermal.compose.RunStream` does both calls.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Rows of runs with their labels; rows without labels are not
            remembered.
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        self : TransferFunctionRegressor
        """
        check_is_fitted(self)
        with warnings.catch_warnings():
            # Said by the predict call of the same rows.
            warnings.simplefilter("ignore", UserWarning)
            lags, (X_raw, X, slices, labels, cont) = self._continued(X, groups)
        memory = self.run_states_
        extend_memory(memory, X, slices, labels, X_raw, cont)
        for sl, lab in zip(slices, labels, strict=True):
            if lab is not None:
                memory[lab]["state"] = np.array([F[sl.stop - 1] for F in lags])
        return self
