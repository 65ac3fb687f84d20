"""GMC(1,N) and GNNMCI(1,N): grey models with a convolution integral.

METHODS §7-8 (001 §3.6 and Appendix A, 002 eq. 1-2). Plain array functions:
the time responses (vectorised over many coefficient sets at once, which is
what makes a particle swarm over them cheap), Tien's least-squares calibration
of GMC(1,N), and the four-layer forward pass of the grey neural network
GNNMCI(1,N) beside its closed form.

Conventions shared by every function here: ``X1`` is the 1-AGO of the input
series of *one* run, shape (n_samples, n_inputs); time runs along axis 0 and is
counted k = 1..n within the run. A model's output at the AGO level is
``xhat_1^(1)``; the restored series (the prediction of the target) is its IAGO.
"""

import numpy as np

from skthermal.grey._ago import iago
from skthermal.grey._models import _solve, check_grey_data
from skthermal.utils._runs import run_slices


def _block_layout(n):
    """Cut n samples into ``nb`` blocks of ``L ~ sqrt(n)`` consecutive samples.

    Returns ``L``, ``nb``, ``order`` of shape (L, nb) with ``order[j, k]`` the
    sample at position j of block k (the last block padded with the last
    sample), ``valid`` (False on the padding) and ``back``, the position of
    every sample in the flattened (L, nb) layout.
    """
    L = max(1, int(np.ceil(np.sqrt(n))))
    nb = -(-n // L)
    t = np.arange(nb * L).reshape(nb, L).T
    valid = t < n
    t_all = np.arange(n)
    back = (t_all % L) * nb + t_all // L
    return L, nb, np.minimum(t, n - 1), valid, back


def _convolution_blocked(F, b1, out=None, tmp=None):
    """Trapezoidal convolution integral of GMC(1,N) in the blocked time layout.

    ``I(t) = e^{-b1} I(t-1) + 0.5 (e^{-b1} f(t-1) + f(t))``, ``I(1) = 0``.

    Parameters
    ----------
    F : ndarray of shape (L, nb, n_sets)
        ``f(t)`` in the layout of :func:`_block_layout`.
    b1 : ndarray of shape (n_sets,)
    out : ndarray of shape (L, nb, n_sets), optional
        Where to write the result (a swarm objective reuses its buffers: fresh
        multi-megabyte arrays cost page faults on every call).
    tmp : ndarray of shape (nb, n_sets), optional
        Scratch space.

    Returns
    -------
    ndarray of shape (L, nb, n_sets)

    Notes
    -----
    ``scipy.signal.lfilter`` takes one filter per call, so filtering the swarm,
    where every particle has its own ``b1``, would need a Python loop over the
    particles; numpy's ``cumsum`` along a leading axis is slow, and the closed
    form ``e^{-b1 t} cumsum(e^{b1 s} g(s))`` overflows on long runs. Instead
    the series is cut into ``nb`` blocks of ``L ~ sqrt(n)`` samples laid out
    position-major, so the recursion runs as a loop over the ``L`` positions,
    each step one vectorised operation on all blocks and all coefficient sets;
    a second short loop over the ``nb`` blocks chains the value at each block's
    end into the next (``I = I_local + e^{-b1 (j+1)} carry``). That is
    ``O(sqrt(n))`` Python steps in all, no exponent larger than ``b1 L``, and
    nothing that can overflow for ``b1 >= 0``.
    """
    L, nb, p = F.shape
    a = np.exp(-b1)
    G = np.empty_like(F) if out is None else out
    tmp = np.empty((nb, p)) if tmp is None else tmp
    np.multiply(F[:-1], a, out=G[1:])
    np.add(G[1:], F[1:], out=G[1:])
    np.multiply(F[-1, :-1], a, out=G[0, 1:])
    np.add(G[0, 1:], F[0, 1:], out=G[0, 1:])
    G[0, 0] = 0.0
    np.multiply(G, 0.5, out=G)
    for j in range(1, L):
        np.multiply(G[j - 1], a, out=tmp)
        np.add(G[j], tmp, out=G[j])
    if nb > 1:
        pw = np.exp(-np.arange(1, L + 1, dtype=float)[:, None] * b1[None, :])
        carry = np.empty((nb, p))
        carry[0] = 0.0
        c = G[-1, 0].copy()
        for k in range(1, nb):
            carry[k] = c
            np.multiply(c, pw[-1], out=c)
            np.add(c, G[-1, k], out=c)
        for j in range(L):
            np.multiply(carry, pw[j], out=tmp)
            np.add(G[j], tmp, out=G[j])
    return G


def _as_sets(b1, b, u, n_inputs):
    """Coefficients as (n_sets,), (n_sets, n_inputs), (n_sets,) and a 'single' flag."""
    single = np.ndim(b1) == 0
    b1 = np.atleast_1d(np.asarray(b1, dtype=float))
    b = np.asarray(b, dtype=float).reshape(b1.shape[0], n_inputs)
    u = np.broadcast_to(np.asarray(u, dtype=float), b1.shape)
    return b1, b, u, single


def gmc_time_response(X1, b1, b, u, x1_first=0.0):
    """Time response ``xhat_1^(1)(t)`` of GMC(1,N) over one run (METHODS §7).

    ``xhat_1^(1)(t) = x_1^(1)(1) e^{-b1 (t-1)} + I(t)`` with the convolution
    integral on the integer grid (trapezoidal rule)
    ``I(t) = e^{-b1} I(t-1) + 0.5 (e^{-b1} f(t-1) + f(t))``, ``I(1) = 0``, and
    ``f(t) = sum_j b_j x_j^(1)(t) + u``.

    Parameters
    ----------
    X1 : array-like of shape (n_samples, n_inputs)
        1-AGO of the input series of one run.
    b1 : float or array-like of shape (n_sets,)
        Development coefficient(s).
    b : array-like of shape (n_inputs,) or (n_sets, n_inputs)
        Driving coefficients ``b_2 .. b_N``.
    u : float or array-like of shape (n_sets,)
        Grey control parameter.
    x1_first : float, default=0.0
        Initial value ``x_1^(1)(1) = x_1^(0)(1)``; zero when the target is taken
        as its change since the start of the run.

    Returns
    -------
    ndarray of shape (n_samples,) for one coefficient set, else
    (n_samples, n_sets).

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.grey import gmc_time_response
    >>> X1 = np.cumsum(np.ones((4, 1)), axis=0)
    >>> np.round(gmc_time_response(X1, 0.0, [1.0], 0.0), 3).tolist()
    [0.0, 1.5, 4.0, 7.5]
    """
    X1 = np.asarray(X1, dtype=float)
    if X1.ndim == 1:
        X1 = X1[:, None]
    b1, b, u, single = _as_sets(b1, b, u, X1.shape[1])
    n = X1.shape[0]
    L, nb, order, _, back = _block_layout(n)
    F = X1[order.ravel()] @ b.T
    F += u
    out = _convolution_blocked(F.reshape(L, nb, -1), b1).reshape(L * nb, -1)[back]
    if x1_first != 0.0:
        t = np.arange(n, dtype=float)[:, None]
        with np.errstate(over="ignore"):
            out += x1_first * np.exp(-b1[None, :] * t)
    return out[:, 0] if single else out


def _delay_inputs(X, delay):
    """Row t takes the inputs of row ``t - delay``; rows before the start repeat it."""
    if delay == 0:
        return X
    idx = np.maximum(np.arange(X.shape[0]) - delay, 0)
    return X[idx]


def _model_runs(y, X, slices, *, relative=True, delay=0):
    """Per run: (X1, target series x_1^(0)) with delay, changes and AGO applied."""
    runs = []
    for sl in slices:
        Xr = _delay_inputs(X[sl], delay)
        yr = None if y is None else y[sl]
        if relative:
            Xr = Xr - Xr[0]
            if yr is not None:
                yr = yr - yr[0]
        runs.append((np.cumsum(Xr, axis=0), yr))
    return runs


def _run_scales(runs):
    """Binary exponents ``ey`` and ``ex`` (one per input) of the data's magnitude.

    ``2^ey`` and ``2^ex_j`` are the powers of two just above the largest
    ``|x_1^(0)|`` and ``|x_j^(0)|`` of ``runs`` (changes since the run start
    for :func:`_model_runs` with ``relative=True``); 0 for a series that is 0
    throughout. Found from the exponents of the largest values, without
    squaring anything.
    """
    ymax = max(
        (float(np.max(np.abs(y0), initial=0.0)) for _, y0 in runs if y0 is not None),
        default=0.0,
    )
    xmax = np.max(
        [
            np.max(np.abs(np.diff(X1, axis=0, prepend=0.0)), axis=0, initial=0.0)
            for X1, _ in runs
        ],
        axis=0,
    )
    return int(np.frexp(ymax)[1]), np.frexp(xmax)[1].astype(int)


def _scale_runs(runs, ey, ex):
    """``runs`` with the target divided by ``2^ey`` and input j by ``2^ex_j``.

    The calibrations then work on series of magnitude ~1 whatever the units of
    the data: sums of squares of a 1e80 target do not overflow, and an input
    of 1e-80 is not lost beside the constant ``u`` (a rank decision). Scaling
    by a power of two is exact in floating point and commutes with the AGO,
    so on normal-scale data the calibration does the same arithmetic as on
    the unscaled data up to rounding inside the least-squares solvers (column
    pivoting, SVD), and ``y * c`` gives coefficients ``b * c`` (see
    :func:`_coef_shift`).
    """
    return [
        (np.ldexp(X1, -ex), None if y0 is None else np.ldexp(y0, -ey))
        for X1, y0 in runs
    ]


def _coef_shift(ey, ex):
    """Binary shift of ``(b1, b_2..b_N, u)`` between original and scaled data.

    With the target divided by ``2^ey`` and input j by ``2^ex_j``, the same
    model has ``b1`` unchanged, ``b_j`` multiplied by ``2^(ex_j - ey)`` and
    ``u`` by ``2^-ey`` (the same for the GNNMCI weights ``(w11, w2j, w2N)``):
    ``scaled = np.ldexp(original, shift)``.
    """
    return np.r_[0, np.asarray(ex, dtype=int) - ey, -ey].astype(int)


def _decades(e):
    """``2^e`` as a power of ten for messages (``1e+80``), never overflowing."""
    return f"1e{round(float(e) * np.log10(2.0)):+d}"


def _unscale_coef(theta, ey, ex, model, names=None):
    """Coefficients fitted on :func:`_scale_runs` data, in the data's units.

    A ``ValueError`` names the input whose coefficient does not fit in a float
    (a target some 1e300 times larger than the changes of an input).
    """
    shift = _coef_shift(ey, ex)
    with np.errstate(over="ignore"):
        out = np.ldexp(np.asarray(theta, dtype=float), -shift)
    bad = ~np.isfinite(out[1:-1])
    if bad.any():
        j = int(np.flatnonzero(bad)[0])
        name = f"input {j}" if names is None else f"input {str(names[j])!r}"
        raise ValueError(
            f"{model}: the coefficient of {name} is beyond the float range: the "
            f"target changes by up to ~{_decades(ey)} while that input changes by "
            f"up to ~{_decades(ex[j])} only. Express the target or that input in "
            "other units."
        )
    if not np.isfinite(out[-1]):
        raise ValueError(
            f"{model}: the constant term is beyond the float range (the target "
            f"changes by up to ~{_decades(ey)}). Express the target in other units."
        )
    return out


def _tien_ls(runs, alpha=0.0):
    """Tien's least squares ``x_1^(0)(k) = -b1 z_1^(1)(k) + sum b_j z_j^(1)(k) + u``.

    Constrained to ``b1 >= 0``: when the unconstrained solution has ``b1 < 0`` the
    problem is a convex quadratic with one active bound, so the constrained
    optimum has ``b1 = 0`` and the other coefficients are re-solved.
    """
    rows, target = [], []
    for X1, y0 in runs:
        x1 = np.cumsum(y0)
        z1 = 0.5 * (x1[1:] + x1[:-1])
        zX = 0.5 * (X1[1:] + X1[:-1])
        rows.append(np.column_stack([-z1, zX, np.ones_like(z1)]))
        target.append(y0[1:])
    B = np.concatenate(rows)
    Y = np.concatenate(target)
    theta = _solve(B.copy(), Y, alpha)
    if not theta[0] >= 0:
        theta = np.concatenate([[0.0], _solve(B[:, 1:].copy(), Y, alpha)])
    return theta


class _GMCObjective:
    """Swarm objective of GMC(1,N): SSE of the restored series over all runs.

    Called with ``theta`` of shape (n_sets, n_inputs + 2), rows
    ``(b1, b_2..b_N, u)``, it returns one sum of squared errors per row, with
    no Python loop over the rows. ``runs`` is a list of ``(X1, y0)`` with
    ``y0[0] == 0`` (changes since the start, so ``x_1^(1)(1) = 0``); with
    ``alpha > 0`` the ridge term of variable projection is added; the inputs
    are re-laid out once here in the blocked time order of
    :func:`_convolution_blocked`, so every call runs entirely in that layout.
    """

    def __init__(self, runs, alpha=0.0, scale=None):
        # Ridge term alpha sum_j (w_j(b1) b_j)^2 of variable projection; scale is its
        # (input norms, mean run length).
        self.alpha = float(alpha)
        self.scale = scale
        self.runs = []
        for X1, y0 in runs:
            L, nb, order, valid, _ = _block_layout(X1.shape[0])
            y0b = np.where(valid, y0[order], 0.0)
            self.runs.append(
                (L, nb, np.ascontiguousarray(X1[order.ravel()]), y0b, ~valid)
            )
        self._work = {}

    def _buffers(self, i, p):
        key = (i, p)
        if key not in self._work:
            L, nb = self.runs[i][:2]
            self._work[key] = (
                np.empty((L * nb, p)),
                np.empty((L, nb, p)),
                np.empty((nb, p)),
            )
        return self._work[key]

    def __call__(self, theta):
        theta = np.asarray(theta, dtype=float)
        b1, b, u = theta[:, 0], theta[:, 1:-1], theta[:, -1]
        bT = np.ascontiguousarray(b.T)
        p = theta.shape[0]
        sse = np.zeros(p)
        with np.errstate(over="ignore", invalid="ignore"):
            for i, (L, nb, X1b, y0b, pad) in enumerate(self.runs):
                F, Ib, tmp = self._buffers(i, p)
                np.matmul(X1b, bT, out=F)
                F = F.reshape(L, nb, p)
                np.add(F, u, out=F)
                _convolution_blocked(F, b1, out=Ib, tmp=tmp)
                # Restored series xhat0(t) = I(t) - I(t-1), minus the target,
                # written over F (no longer needed).
                R = F
                np.subtract(Ib[1:], Ib[:-1], out=R[1:])
                np.subtract(Ib[0, 1:], Ib[-1, :-1], out=R[0, 1:])
                R[0, 0] = Ib[0, 0]
                np.subtract(R, y0b[:, :, None], out=R)
                R[pad] = 0.0
                R = R.reshape(L * nb, p)
                sse += np.einsum("ij,ij->j", R, R)
            if self.alpha > 0:
                w = _gmc_penalty_weights(b1, *self.scale)
                sse += self.alpha * np.einsum("ij,ij->i", w * b, w * b)
        return sse


def gmc1n(y, X, *, groups=None, relative=True, delay=0, alpha=0.0):
    """Calibrate GMC(1,N) by Tien's least squares (METHODS §7).

    Solves ``x_1^(0)(k) = -b1 z_1^(1)(k) + sum_j b_j z_j^(1)(k) + u`` over the
    samples k = 2..n of every run, ``z`` being background values of the AGO
    series, with the stability constraint ``b1 >= 0`` (see Notes).

    Parameters
    ----------
    y : array-like of shape (n_samples,)
        Target series ``x_1^(0)`` (e.g. a thermal displacement).
    X : array-like of shape (n_samples, n_inputs)
        Input series ``x_2^(0) .. x_N^(0)`` (e.g. temperatures).
    groups : array-like of shape (n_samples,), optional
        Run labels; AGO restarts at every run, the equations of all runs are
        solved together.
    relative : bool, default=True
        Use changes since the first sample of each run.
    delay : int, default=0
        The target at sample k is driven by the inputs at sample ``k - delay``;
        inputs before a run's first sample are taken equal to it.
    alpha : float, default=0.0
        0: SVD-based minimum-norm least squares; > 0: scale-free ridge (as
        :func:`gm0n`).

    Returns
    -------
    b1 : float
        Development coefficient, ``>= 0``.
    b : ndarray of shape (n_inputs,)
        Driving coefficients.
    u : float
        Grey control parameter.

    Notes
    -----
    A negative ``b1`` makes the time response grow like ``e^{|b1| t}``: not a
    thermal error, and it overflows on long runs. The least-squares problem is a
    convex quadratic, so when its unconstrained minimiser has ``b1 < 0`` the
    minimiser under ``b1 >= 0`` lies on ``b1 = 0``; the other coefficients are
    then re-solved with ``b1 = 0``. When the unconstrained ``b1 >= 0`` the
    result is exactly Tien's least squares.

    Tien's equation is the trapezoidal (Tustin) discretisation of the grey
    differential equation, whereas the time response of
    :func:`gmc_time_response` integrates it with ``e^{-b1}``: the two agree to
    first order in ``b1`` only, one reason why calibrating the time response
    directly (by a particle swarm) can beat least squares (001 Table 6-4).

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.grey import gmc1n
    >>> rng = np.random.default_rng(0)
    >>> X = np.cumsum(rng.normal(size=(40, 2)), axis=0)
    >>> X1 = np.cumsum(X - X[0], axis=0)
    >>> x1 = np.zeros(40)  # Tien's equation, b1 = 0.2, b = (0.5, -0.3), u = 0.1
    >>> for k in range(1, 40):
    ...     f = 0.5 * (X1[k] + X1[k - 1]) @ [0.5, -0.3] + 0.1
    ...     x1[k] = ((1 - 0.1) * x1[k - 1] + f) / (1 + 0.1)
    >>> b1, b, u = gmc1n(np.diff(x1, prepend=0.0), X)
    >>> round(b1, 6), np.round(b, 6).tolist(), round(u, 6)
    (0.2, [0.5, -0.3], 0.1)
    """
    n_inputs = 1 if np.ndim(X) == 1 else np.shape(X)[1]
    y, X, slices = check_grey_data(y, X, groups, n_inputs + 2, "GMC(1,N)")
    runs = _model_runs(y, X, slices, relative=relative, delay=_check_delay(delay))
    ey, ex = _run_scales(runs)
    theta = _tien_ls(_scale_runs(runs, ey, ex), alpha)
    theta = _unscale_coef(theta, ey, ex, "GMC(1,N)")
    return float(theta[0]), theta[1:-1], float(theta[-1])


def _per_run(value, n_runs, name):
    value = np.asarray(value, dtype=float)
    if value.ndim == 0:
        return np.full(n_runs, float(value))
    if value.shape != (n_runs,):
        raise ValueError(f"{name} must be a float or one value per run ({n_runs}).")
    return value


def gmc1n_predict(X, b1, b, u, *, groups=None, relative=True, delay=0, x1_first=0.0):
    """Restored series ``xhat_1^(0)`` of a calibrated GMC(1,N), run by run.

    Parameters
    ----------
    X : array-like of shape (n_samples, n_inputs)
        Input series.
    b1, b, u : float, array-like of shape (n_inputs,), float
        Coefficients, e.g. from :func:`gmc1n`.
    groups, relative, delay
        As in :func:`gmc1n`.
    x1_first : float or array-like of shape (n_runs,), default=0.0
        First target value of each run (zero for changes since the start).

    Returns
    -------
    ndarray of shape (n_samples,)
        IAGO of :func:`gmc_time_response`, restarted at every run.
    """
    X = np.asarray(X, dtype=float)
    if X.ndim == 1:
        X = X[:, None]
    b = np.atleast_1d(np.asarray(b, dtype=float))
    if b.ndim != 1 or b.size != X.shape[1]:
        raise ValueError(
            f"b must hold one driving coefficient per input ({X.shape[1]}), got "
            f"shape {b.shape}."
        )
    if not (np.isfinite(b1) and b1 >= 0 and np.all(np.isfinite(b)) and np.isfinite(u)):
        raise ValueError(
            f"b1 must be finite and >= 0 (a negative development coefficient "
            f"grows exponentially), and b and u finite; got b1={b1!r}."
        )
    delay = _check_delay(delay)
    slices, _ = run_slices(groups, X.shape[0])
    first = _per_run(x1_first, len(slices), "x1_first")
    out = np.empty(X.shape[0])
    for (X1, _), sl, x0 in zip(
        _model_runs(None, X, slices, relative=relative, delay=delay),
        slices,
        first,
        strict=True,
    ):
        out[sl] = iago(gmc_time_response(X1, b1, b, u, x0))
    return out


def _check_delay(delay):
    """``delay`` as an int >= 0 (a named error otherwise)."""
    if (
        isinstance(delay, bool)
        or not np.isscalar(delay)
        or not float(delay).is_integer()
        or delay < 0
    ):
        raise ValueError(f"delay must be an integer >= 0 (samples), got {delay!r}.")
    return int(delay)


def gnnmci_time_response(X1, weights, x1_first=0.0):
    """Closed form of GNNMCI(1,N) (METHODS §8), at the AGO level, for one run.

    ``xhat_1^(1)(k) = x_1^(1)(1) e^{-w11 k} + sum_j w2j x_j^(1)(k) + w2N``,
    k = 1..n.

    Parameters
    ----------
    X1 : array-like of shape (n_samples, n_inputs)
        1-AGO of the input series of one run.
    weights : array-like of shape (n_inputs + 2,) or (n_sets, n_inputs + 2)
        ``(w11, w2_2 .. w2_{N-1}, w2N)``: the development weight, one weight per
        input and the constant.
    x1_first : float, default=0.0
        ``x_1^(1)(1)``, the target's first value.

    Returns
    -------
    ndarray of shape (n_samples,) or (n_samples, n_sets)

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.grey import gnnmci_layers, gnnmci_time_response
    >>> X1 = np.cumsum(np.arange(8.0).reshape(4, 2), axis=0)
    >>> w = [0.3, 0.5, -0.2, 1.0]
    >>> bool(np.allclose(gnnmci_time_response(X1, w, 2.0),
    ...                  gnnmci_layers(X1, w, 2.0)))
    True
    """
    X1 = np.asarray(X1, dtype=float)
    if X1.ndim == 1:
        X1 = X1[:, None]
    W = np.asarray(weights, dtype=float)
    single = W.ndim == 1
    W = np.atleast_2d(W)
    out = X1 @ W[:, 1:-1].T
    out += W[:, -1]
    if x1_first != 0.0:
        k = np.arange(1, X1.shape[0] + 1, dtype=float)[:, None]
        with np.errstate(over="ignore"):
            out += x1_first * np.exp(-W[:, 0] * k)
    return out[:, 0] if single else out


def gnnmci_layers(X1, weights, x1_first=0.0, *, return_layers=False):
    """Four-layer forward pass of the grey neural network GNNMCI(1,N).

    Layers exactly as METHODS §8 (001 Appendix A, 002 §2), for k = 1..n:

    - A: ``a = w11 k``
    - B: ``b = sigmoid(a)``
    - C: ``c_1 = b w21``, ``c_j = x_j^(1)(k) b w2j``, ``c_N = b w2N``
    - D: ``d = sum_j w3j c_j - theta``

    with ``w21 = -x_1^(1)(1)``, ``w3j = 1 + e^{-w11 k}`` and
    ``theta = -x_1^(1)(1) (1 + e^{-w11 k})``. Since ``b (1 + e^{-a}) = 1`` the
    output equals :func:`gnnmci_time_response`. This pass is the papers'
    network; it overflows once ``w11 k < -709`` (``e^{-a}`` in ``w3j``), which
    the closed form avoids, so estimators train and predict with the closed form.

    Parameters
    ----------
    X1, weights, x1_first
        As in :func:`gnnmci_time_response` (a single weight vector).
    return_layers : bool, default=False
        Also return the layer outputs.

    Returns
    -------
    d : ndarray of shape (n_samples,)
        ``xhat_1^(1)(k)``.
    layers : dict, only if ``return_layers``
        ``"A"``, ``"B"`` of shape (n_samples,), ``"C"`` of shape
        (n_samples, n_inputs + 2).
    """
    X1 = np.asarray(X1, dtype=float)
    if X1.ndim == 1:
        X1 = X1[:, None]
    w = np.asarray(weights, dtype=float)
    if w.shape != (X1.shape[1] + 2,):
        raise ValueError(
            f"weights must have shape ({X1.shape[1] + 2},) for {X1.shape[1]} "
            f"inputs, got {w.shape}."
        )
    w11, w2 = w[0], w[1:]
    k = np.arange(1, X1.shape[0] + 1, dtype=float)
    layer_a = w11 * k
    with np.errstate(over="ignore"):
        e = np.exp(-layer_a)
        layer_b = 1.0 / (1.0 + e)
        w21 = -x1_first
        layer_c = np.column_stack(
            [layer_b * w21, X1 * layer_b[:, None] * w2[:-1], layer_b * w2[-1]]
        )
        w3 = 1.0 + e
        theta = -x1_first * (1.0 + e)
        d = (w3[:, None] * layer_c).sum(axis=1) - theta
    if return_layers:
        return d, {"A": layer_a, "B": layer_b, "C": layer_c}
    return d


def _gnnmci_sse(W, runs):
    """Swarm objective of GNNMCI: SSE of the restored series, one per weight set."""
    sse = np.zeros(W.shape[0])
    with np.errstate(over="ignore", invalid="ignore"):
        for X1, y0 in runs:
            xhat1 = gnnmci_time_response(X1, W, float(y0[0]))
            R = np.empty_like(xhat1)
            R[0] = xhat1[0] - y0[0]
            np.subtract(xhat1[1:], xhat1[:-1], out=R[1:])
            R[1:] -= y0[1:, None]
            sse += np.einsum("ij,ij->j", R, R)
    return sse


def gnnmci_predict(X, weights, *, groups=None, relative=True, x1_first=0.0):
    """Restored series ``xhat_1^(0)`` of GNNMCI(1,N), run by run (closed form).

    Parameters
    ----------
    X : array-like of shape (n_samples, n_inputs)
    weights : array-like of shape (n_inputs + 2,)
        ``(w11, w2_2 .. w2_{N-1}, w2N)``.
    groups, relative
        As in :func:`gmc1n`.
    x1_first : float or array-like of shape (n_runs,), default=0.0
        First target value of each run (zero for changes since the start).

    Returns
    -------
    ndarray of shape (n_samples,)
    """
    X = np.asarray(X, dtype=float)
    if X.ndim == 1:
        X = X[:, None]
    w = np.asarray(weights, dtype=float)
    if w.ndim != 1 or w.size != X.shape[1] + 2 or not np.all(np.isfinite(w)):
        raise ValueError(
            f"weights must hold {X.shape[1] + 2} finite values (w11, one per "
            f"input, w2N) for {X.shape[1]} input(s), got shape {w.shape}."
        )
    slices, _ = run_slices(groups, X.shape[0])
    first = _per_run(x1_first, len(slices), "x1_first")
    out = np.empty(X.shape[0])
    for (X1, _), sl, x0 in zip(
        _model_runs(None, X, slices, relative=relative), slices, first, strict=True
    ):
        out[sl] = iago(gnnmci_time_response(X1, weights, x0))
    return out


# ------------------------------------------------------------------------------
# The ridge term of the output-error calibration, shared by the swarm objective
# above and by variable projection (skthermal.grey._varpro).


def _static_gain(b1, n_mean):
    """Gain from a sustained input change to the restored series, per ``b1``.

    ``0.5 (1 + a) / (1 - a)`` with ``a = e^{-b1}`` is the steady-state gain of
    the discrete response; ``1 / n_mean`` in the denominator caps it at the run
    length for a near-integrator (``b1 n << 1``), which never settles in a run.
    """
    a = np.exp(-np.asarray(b1, dtype=float))
    return 0.5 * (1.0 + a) / (1.0 - a + 1.0 / n_mean)


def _penalty_scale(runs):
    """Norm of each input's change since the run start and the mean run length."""
    dX = np.concatenate([np.diff(X1, axis=0, prepend=0.0) for X1, _ in runs])
    return np.linalg.norm(dX, axis=0), dX.shape[0] / len(runs)


def _gmc_penalty_weights(b1, xnorm, n_mean):
    """Ridge weights ``w_j(b1) = g(b1) ||dx_j||`` of shape (len(b1), n_inputs).

    The penalty ``alpha sum_j (w_j b_j)^2`` is that of a ridge on unit-norm
    columns (as :func:`gm0n`) for the *static* response ``g(b1) dx_j b_j``:
    it shrinks what each input contributes to the prediction, in the target's
    units, whatever ``b1`` is, so it does not favour slow (integrating) models.
    """
    return _static_gain(np.atleast_1d(b1), n_mean)[:, None] * xnorm[None, :]
