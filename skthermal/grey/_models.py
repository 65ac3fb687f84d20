"""GM(1,1), GM(0,N) and GM(1,N) grey models as plain array functions.

METHODS §2-3 (000 eq. 10-13, 001 §3.7). The N-variable models estimate how
strongly each input series drives the target and are the basis of the grey
influence ranking of temperature sensors.
"""

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from skthermal.grey._ago import ago, background
from skthermal.utils._runs import changes_since_start, check_run_lengths, run_slices


def check_alpha(alpha, auto=False):
    """A ridge ``alpha`` as a finite float >= 0 (or ``"auto"`` when allowed);
    a named error otherwise."""
    if auto and isinstance(alpha, str) and alpha == "auto":
        return alpha
    ok = not isinstance(alpha, (bool, str)) and np.isscalar(alpha)
    if ok:
        ok = bool(np.isfinite(alpha) and alpha >= 0)
    if not ok:
        extra = ' or "auto"' if auto else ""
        raise ValueError(f"alpha must be a finite number >= 0{extra}, got {alpha!r}.")
    return float(alpha)


def _solve(B, Y, alpha):
    """Least squares ``min ||B theta - Y||``, optionally ridge-regularised.

    ``alpha == 0`` uses LAPACK's SVD-based ``gelsd``: rank revealing, and the
    minimum-norm solution when ``B`` is rank deficient (many collinear sensors).
    ``alpha > 0`` solves a ridge problem on columns scaled to unit norm (so the
    penalty does not depend on units or on the length of the series) and
    scales the solution back: it spreads weight evenly across collinear columns.
    """
    alpha = check_alpha(alpha)
    if alpha == 0:
        theta, *_ = linalg.lstsq(B, Y, lapack_driver="gelsd")
        return theta
    scale = np.linalg.norm(B, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    Bs = B / scale
    G = Bs.T @ Bs
    G[np.diag_indices_from(G)] += alpha
    return linalg.solve(G, Bs.T @ Y, assume_a="pos") / scale


def check_grey_data(y, X, groups, min_equations, model):
    """Validate a target, its input series and their runs for a grey model.

    Returns ``y`` (1-D float), ``X`` (2-D float) and the run slices. The
    errors name the model and say what is missing: a 1-D target with one value
    per input row, finite values, at least 2 samples per run, and at least
    ``min_equations`` equations (one per sample after the first of each run).
    """
    y = np.asarray(y, dtype=float)
    X = np.asarray(X, dtype=float)
    if X.ndim == 1:
        X = X[:, None]
    if y.ndim != 1 or X.shape[0] != y.shape[0]:
        raise ValueError(
            f"{model}: need a 1-D target with one value per row of the inputs; "
            f"got shapes {y.shape} and {X.shape}."
        )
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(X))):
        raise ValueError(f"{model}: the data contain NaN or infinite values.")
    slices, labels = run_slices(groups, y.shape[0])
    check_run_lengths(slices, labels, model)
    n_eq = y.shape[0] - len(slices)
    if n_eq < min_equations:
        raise ValueError(
            f"{model}: too few samples: {X.shape[1]} input series need at least "
            f"{min_equations + len(slices)} samples ({min_equations} equations, one "
            f"per sample after the first of each run), got {y.shape[0]} samples in "
            f"{len(slices)} run(s)."
        )
    return y, X, slices


def _prepare(y, X, groups, relative, min_rows, model):
    y, X, slices = check_grey_data(y, X, groups, min_rows, model)
    if relative:
        y = changes_since_start(y, slices)
        X = changes_since_start(X, slices)
    return y, X, groups


def gm0n(y, X, *, groups=None, relative=True, alpha=0.0):
    """GM(0,N) static grey model; returns the influence coefficients ``theta``.

    Solves ``z_1^(1)(k) = sum_j theta_j x_j^(1)(k)``, k = 2..n, by least squares
    with ``Y = z_1^(1)`` and ``B = [x_2^(1) .. x_N^(1)]`` (METHODS §2).

    Parameters
    ----------
    y : array-like of shape (n_samples,)
        Target series ``x_1^(0)`` (e.g. a thermal displacement).
    X : array-like of shape (n_samples, n_inputs)
        Input series ``x_2^(0) .. x_N^(0)`` (e.g. temperatures).
    groups : array-like of shape (n_samples,), optional
        Run labels; the AGO restarts at every run and the equations of all runs
        are solved together.
    relative : bool, default=True
        Use changes since the first sample of each run (the papers'
        "temperature change"), not absolute readings.
    alpha : float, default=0.0
        0 gives the SVD-based minimum-norm least-squares solution (rank
        revealing, so collinear sensors do not break it); > 0 a ridge penalty
        on unit-norm columns of ``B`` (scale free), which spreads the weight of
        collinear sensors evenly instead of arbitrarily.

    Returns
    -------
    theta : ndarray of shape (n_inputs,)
        Influence coefficients; ``|theta_j|`` ranks the inputs.
    """
    y, X, groups = _prepare(y, X, groups, relative, np.shape(X)[-1], "GM(0,N)")
    z1, mask = background(ago(y, groups), groups)
    B = ago(X, groups)[mask]
    return _solve(B, z1, alpha)


def gm1n(y, X, *, groups=None, relative=True, alpha=0.0):
    """GM(1,N) grey model; returns the development and driving coefficients.

    Solves ``x_1^(0)(k) + a z_1^(1)(k) = sum_j b_j x_j^(1)(k)``, k = 2..n, by
    least squares with ``Y = x_1^(0)(2..n)`` and rows of ``B`` equal to
    ``[-z_1^(1)(k), x_2^(1)(k) .. x_N^(1)(k)]`` (METHODS §3; the seeds print the
    first column without its minus sign).

    Parameters
    ----------
    y, X, groups, relative, alpha
        As in :func:`gm0n`.

    Returns
    -------
    a : float
        Development coefficient.
    b : ndarray of shape (n_inputs,)
        Driving coefficients; ``|b_j|`` ranks the inputs.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.grey import gm1n
    >>> t = np.arange(30.0)
    >>> X = np.c_[1 - np.exp(-t / 5), 1 - np.exp(-t / 12)]
    >>> a, b = gm1n(3 * X[:, 0] + 0.2 * X[:, 1], X)
    >>> bool(abs(b[0]) > abs(b[1]))
    True
    """
    y, X, groups = _prepare(y, X, groups, relative, np.shape(X)[-1] + 1, "GM(1,N)")
    z1, mask = background(ago(y, groups), groups)
    B = np.column_stack([-z1, ago(X, groups)[mask]])
    theta = _solve(B, y[mask], alpha)
    return float(theta[0]), theta[1:]


@dataclass(frozen=True)
class GM11:
    """A fitted GM(1,1) model, ``x0(k) + a z1(k) = b``.

    Attributes
    ----------
    a : float
        Development coefficient.
    b : float
        Grey input.
    x0_1 : float
        First value of the original series, the model's initial condition.
    n_samples : int
        Length of the series it was fitted on.
    """

    a: float
    b: float
    x0_1: float
    n_samples: int

    def predict(self, n_samples=None):
        """Restored series ``x0hat(1..n_samples)`` (default: the fitted length).

        Values past the fitted length are forecasts.
        """
        n = self.n_samples if n_samples is None else int(n_samples)
        k = np.arange(n, dtype=float)
        # x1 = x0_1 e^{-ak} + (b / a)(1 - e^{-ak}), written with expm1 so that
        # a development coefficient near 0 (a nearly constant series) does
        # not cancel catastrophically; (1 - e^{-ak}) / a -> k as a -> 0.
        if self.a == 0:
            growth = k
        else:
            growth = -np.expm1(-self.a * k) / self.a
        x1 = self.x0_1 * np.exp(-self.a * k) + self.b * growth
        out = np.empty(n)
        out[:1] = x1[:1]
        out[1:] = np.diff(x1)
        return out

    def forecast(self, steps=1):
        """The ``steps`` values after the fitted series."""
        return self.predict(self.n_samples + int(steps))[self.n_samples :]


def gm11(x0):
    """Fit the single-series grey model GM(1,1).

    Parameters
    ----------
    x0 : array-like of shape (n_samples,)
        A short positive series, at least 3 samples.

    Returns
    -------
    GM11
        With ``a``, ``b`` and ``predict`` / ``forecast``.

    Examples
    --------
    >>> from skthermal.grey import gm11
    >>> model = gm11([2.874, 3.278, 3.337, 3.390, 3.679])
    >>> round(model.a, 7), round(model.b, 7)
    (-0.0372044, 3.0653633)
    >>> round(float(model.forecast(1)[0]), 5)
    3.75066
    """
    x0 = np.asarray(x0, dtype=float)
    if x0.ndim != 1:
        raise ValueError(f"GM(1,1) takes a 1-D series, got shape {x0.shape}.")
    if x0.shape[0] < 3:
        raise ValueError(
            f"GM(1,1) needs at least 3 samples to estimate a and b, got {x0.shape[0]}."
        )
    if not np.all(np.isfinite(x0)):
        raise ValueError("GM(1,1): the series contains NaN or infinite values.")
    z1, mask = background(ago(x0))
    B = np.column_stack([-z1, np.ones_like(z1)])
    a, b = _solve(B, x0[mask], 0.0)
    return GM11(a=float(a), b=float(b), x0_1=float(x0[0]), n_samples=x0.shape[0])
