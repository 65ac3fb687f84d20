"""Gaussian and generalised-bell membership functions and their derivatives.

METHODS §6, layer 1 of ANFIS. Parameters follow MATLAB's Fuzzy Logic Toolbox
(and Jang 1993): ``gaussmf`` takes ``(sigma, c)``, ``gbellmf`` takes
``(a, b, c)``; the centre ``c`` is always the last parameter.

Besides the memberships themselves, ANFIS needs their *logarithms* (firing
strengths are products of memberships, which underflow to zero far from the
training data; sums of logarithms do not) and the derivatives of the
log-memberships with respect to the parameters (the premise gradient). All
functions broadcast over numpy arrays.
"""

import numpy as np
from scipy.special import expit

#: Number of parameters of each membership function, in storage order.
MF_PARAMS = {"gaussian": ("sigma", "c"), "gbell": ("a", "b", "c")}


def gaussian_mf(x, sigma, c):
    """Gaussian membership ``exp(-(x - c)^2 / (2 sigma^2))``.

    Parameters
    ----------
    x : array-like
        Input values.
    sigma : float or array-like
        Width, > 0.
    c : float or array-like
        Centre.

    Returns
    -------
    ndarray
        Memberships in [0, 1], broadcast over the arguments.

    Examples
    --------
    >>> from skthermal.fuzzy import gaussian_mf
    >>> gaussian_mf([0.0, 1.0], 1.0, 0.0).round(4).tolist()
    [1.0, 0.6065]
    """
    return np.exp(log_gaussian_mf(x, sigma, c))


def log_gaussian_mf(x, sigma, c):
    """Natural logarithm of :func:`gaussian_mf`, ``-(x - c)^2 / (2 sigma^2)``."""
    z = (np.asarray(x, dtype=float) - c) / sigma
    with np.errstate(over="ignore"):  # -inf far away is handled by the caller
        return -0.5 * z * z


def gbell_mf(x, a, b, c):
    """Generalised bell membership ``1 / (1 + |(x - c) / a|^(2b))``.

    Parameters
    ----------
    x : array-like
        Input values.
    a : float or array-like
        Half width: the membership is 0.5 at ``x = c +- a``; > 0.
    b : float or array-like
        Slope parameter, > 0 (the slope at the crossover points is
        ``-b / (2a)``).
    c : float or array-like
        Centre.

    Returns
    -------
    ndarray
        Memberships in [0, 1], broadcast over the arguments.

    Examples
    --------
    >>> from skthermal.fuzzy import gbell_mf
    >>> gbell_mf([0.0, 1.0, 3.0], 1.0, 2.0, 0.0).round(4).tolist()
    [1.0, 0.5, 0.0122]
    """
    return np.exp(log_gbell_mf(x, a, b, c))


def _log_abs_z(x, a, c):
    z = (np.asarray(x, dtype=float) - c) / a
    with np.errstate(divide="ignore"):
        return z, np.log(np.abs(z))


def log_gbell_mf(x, a, b, c):
    """Natural logarithm of :func:`gbell_mf`, ``-log(1 + |z|^(2b))``.

    Computed as ``-softplus(2b log|z|)`` so that it stays finite (and accurate)
    for inputs arbitrarily far from the centre, where ``|z|^(2b)`` would
    overflow.
    """
    _, log_abs = _log_abs_z(x, a, c)
    return -np.logaddexp(0.0, 2.0 * b * log_abs)


def log_gaussian_mf_grad(x, sigma, c):
    """Derivatives of :func:`log_gaussian_mf` with respect to ``(sigma, c)``.

    ``d/dsigma = (x - c)^2 / sigma^3`` and ``d/dc = (x - c) / sigma^2``.

    Returns
    -------
    ndarray
        Shape ``broadcast(x, sigma, c).shape + (2,)``, last axis ``(sigma, c)``.

    Examples
    --------
    >>> from skthermal.fuzzy._membership import log_gaussian_mf_grad
    >>> log_gaussian_mf_grad(2.0, 1.0, 0.0).tolist()
    [4.0, 2.0]
    """
    d = np.asarray(x, dtype=float) - c
    inv = 1.0 / (sigma * sigma)
    d_c = d * inv
    d_sigma = d * d_c / sigma
    return np.stack(np.broadcast_arrays(d_sigma, d_c), axis=-1)


def log_gbell_mf_grad(x, a, b, c):
    """Derivatives of :func:`log_gbell_mf` with respect to ``(a, b, c)``.

    With ``z = (x - c) / a``, ``q = |z|^(2b)`` and ``t = q / (1 + q)``:
    ``d/da = 2b t / a``, ``d/db = -2 t log|z|`` and ``d/dc = 2b t / (a z)``
    (Jang 1993, eq. for the bell function, divided by the membership). At the
    centre (``z = 0``) all three are zero (their limits for ``b > 1/2``).

    Returns
    -------
    ndarray
        Shape ``broadcast(x, a, b, c).shape + (3,)``, last axis ``(a, b, c)``.

    Examples
    --------
    >>> from skthermal.fuzzy._membership import log_gbell_mf_grad
    >>> log_gbell_mf_grad(1.0, 1.0, 2.0, 0.0).tolist()
    [2.0, -0.0, 2.0]
    """
    z, log_abs = _log_abs_z(x, a, c)
    t = expit(2.0 * b * log_abs)
    at_centre = z == 0.0
    safe_z = np.where(at_centre, 1.0, z)
    d_a = 2.0 * b * t / a
    d_b = np.where(at_centre, 0.0, -2.0 * t * np.where(at_centre, 0.0, log_abs))
    d_c = np.where(at_centre, 0.0, 2.0 * b * t / (a * safe_z))
    return np.stack(np.broadcast_arrays(d_a, d_b, d_c), axis=-1)


def membership(x, params, mf):
    """Membership of ``x`` given a parameter array whose last axis is the MF's.

    Parameters
    ----------
    x : array-like
        Input values, broadcast against ``params[..., 0]``.
    params : array-like of shape (..., n_params)
        ``(sigma, c)`` for ``"gaussian"``, ``(a, b, c)`` for ``"gbell"``.
    mf : {"gaussian", "gbell"}

    Returns
    -------
    ndarray
    """
    return np.exp(log_membership(x, params, mf))


def log_membership(x, params, mf):
    """Logarithm of :func:`membership`."""
    params = np.asarray(params, dtype=float)
    if mf == "gaussian":
        return log_gaussian_mf(x, params[..., 0], params[..., 1])
    if mf == "gbell":
        return log_gbell_mf(x, params[..., 0], params[..., 1], params[..., 2])
    raise ValueError(f"mf must be 'gaussian' or 'gbell', got {mf!r}.")


def log_membership_grad(x, params, mf):
    """Derivatives of :func:`log_membership` w.r.t. the parameters (last axis)."""
    params = np.asarray(params, dtype=float)
    if mf == "gaussian":
        return log_gaussian_mf_grad(x, params[..., 0], params[..., 1])
    if mf == "gbell":
        return log_gbell_mf_grad(x, params[..., 0], params[..., 1], params[..., 2])
    raise ValueError(f"mf must be 'gaussian' or 'gbell', got {mf!r}.")
