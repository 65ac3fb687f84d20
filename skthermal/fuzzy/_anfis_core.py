"""ANFIS core: rule bases, forward pass, least squares, gradients, training.

METHODS §6 (000 §2, 001 §3.3, 003 §5; Jang 1993): plain functions on arrays,
wrapped by :class:`skthermal.fuzzy.ANFISRegressor`.

Storage layout used throughout:

- ``mf_params`` : ``(n_features, n_mfs, n_params)``; the membership functions
  of every input, parameters ``(sigma, c)`` (Gaussian) or ``(a, b, c)``
  (generalised bell), as MATLAB's ``gaussmf`` / ``gbellmf``.
- ``rules`` : ``(n_rules, n_features)`` integers; ``rules[r, j]`` is the index of
  the membership function of input ``j`` used by rule ``r``.
- ``consequents`` : ``(n_rules, n_features + 1, n_outputs)``; rule ``r`` says
  ``f_r = consequents[r, :-1] . x + consequents[r, -1]``.
"""

import itertools
import sys

import numpy as np
from scipy.linalg import blas

from skthermal.fuzzy._anfis_lsq import (
    NormalEquations,
    cholesky_ridge,
    solve_consequents,
)
from skthermal.fuzzy._cmeans import fuzzy_cmeans
from skthermal.fuzzy._membership import (
    log_membership,
    log_membership_grad,
)
from skthermal.grey._ago import iago

# sqrt(2 ln 2): a Gaussian of width sigma is 0.5 at sigma * _HALF, so that
# Gaussian and bell functions of the same "half width" cross at 0.5 alike.
_HALF = np.sqrt(2.0 * np.log(2.0))
# Floors that keep widths and bell slopes positive during gradient steps,
# widths relative to each input's spread.
_WIDTH_FLOOR = 1e-6
_SLOPE_FLOOR = 1e-3
# Normalised memberships and firing strengths below this are 0 in training
# (see :func:`_flush_tiny`).
_TINY = 1e-100


# --------------------------------------------------------------------------
# Rule bases
# --------------------------------------------------------------------------


def grid_rules(n_mfs, n_features):
    """Rules of a grid partition: every combination of the inputs' MFs.

    Product order with the first input varying slowest, as Jang (1993) and
    MATLAB's ``genfis1``.

    Returns
    -------
    ndarray of shape (n_mfs ** n_features, n_features), dtype intp
    """
    return np.array(
        list(itertools.product(range(n_mfs), repeat=n_features)), dtype=np.intp
    ).reshape(-1, n_features)


def _input_scale(X):
    """A positive length scale per input (its range, else 1)."""
    span = np.ptp(X, axis=0) if X.shape[0] else np.zeros(X.shape[1])
    return np.where(span > 0, span, 1.0)


def grid_mf_params(X, n_mfs, mf):
    """Evenly spaced membership functions over each input's range.

    Jang's initialisation: centres evenly spaced from the minimum to the maximum
    of each input; adjacent functions cross at membership 0.5, i.e. bell
    ``a = range / (2 (n_mfs - 1))``, ``b = 2``, Gaussian
    ``sigma = a / sqrt(2 ln 2)``. With ``n_mfs = 1`` the single function is
    centred on the range with half width ``range / 2``.

    Returns
    -------
    ndarray of shape (n_features, n_mfs, n_params)
    """
    lo, hi = X.min(axis=0), X.max(axis=0)
    span = hi - lo
    if n_mfs == 1:
        centres = ((lo + hi) / 2.0)[:, None]
        half = span / 2.0
    else:
        centres = lo[:, None] + span[:, None] * np.linspace(0.0, 1.0, n_mfs)[None]
        half = span / (2.0 * (n_mfs - 1))
    half = np.where(half > 0, half, 0.5 * _input_scale(X))
    half = np.broadcast_to(half[:, None], centres.shape)
    if mf == "gaussian":
        return np.stack([half / _HALF, centres], axis=-1)
    return np.stack([half, np.full_like(centres, 2.0), centres], axis=-1)


def fcm_mf_params(X, n_clusters, mf, *, m=2.0, random_state=None):
    """One rule per fuzzy c-means cluster of the inputs (``genfis3`` style).

    The inputs are standardised for the clustering only (so that the units of
    the sensors do not decide the partition; MATLAB's ``genfis3`` clusters the
    raw inputs together with the output). Every rule gets, on every input, a
    membership function centred on its cluster centre with width equal to the
    membership-weighted spread of the input around it,
    ``sigma_ij = sqrt(sum_n u_ni^m (x_nj - c_ij)^2 / sum_n u_ni^m)`` (bell:
    half width ``a = sigma sqrt(2 ln 2)``, ``b = 2``), floored at 1e-3 of the
    input's range.

    Returns
    -------
    mf_params : ndarray of shape (n_features, n_clusters, n_params)
    rules : ndarray of shape (n_clusters, n_features)
    """
    mean = X.mean(axis=0)
    std = X.std(axis=0)
    std = np.where(std > 0, std, 1.0)
    res = fuzzy_cmeans((X - mean) / std, n_clusters, m=m, random_state=random_state)
    centres = res.centers * std + mean  # (c, d)
    um = res.memberships**m  # (n, c)
    weight = um.sum(axis=0)
    d2 = (X[:, None, :] - centres[None, :, :]) ** 2  # (n, c, d)
    spread = np.sqrt(np.einsum("nc,ncd->cd", um, d2) / weight[:, None])
    spread = np.maximum(spread, 1e-3 * _input_scale(X)[None, :])
    centres, spread = centres.T, spread.T  # (d, c)
    if mf == "gaussian":
        params = np.stack([spread, centres], axis=-1)
    else:
        params = np.stack(
            [spread * _HALF, np.full_like(centres, 2.0), centres], axis=-1
        )
    rules = np.tile(np.arange(n_clusters, dtype=np.intp)[:, None], (1, X.shape[1]))
    return params, rules


def _rule_selectors(rules, n_mfs):
    """One-hot ``S[j, r, m] = rules[r, j] == m``, shape (d, R, M)."""
    n_rules, d = rules.shape
    S = np.zeros((d, n_rules, n_mfs))
    S[np.arange(d)[None, :], np.arange(n_rules)[:, None], rules] = 1.0
    return S


# --------------------------------------------------------------------------
# Forward pass
# --------------------------------------------------------------------------


def _forward_log(XT, mf_params, mf):
    """Log-memberships ``(d, M, n)`` of inputs given as ``X.T`` (d, n).

    Samples run along the last, contiguous axis (the "rules x samples" layout
    of the training loop: reductions over rules and products with short rows
    of parameters then stream over long rows). For Gaussians also returns
    ``z = (x - c) / sigma`` (d, M, n), reused by the gradient.
    """
    if mf != "gaussian":
        return log_membership(XT[:, None, :], mf_params[:, :, None, :], mf), None
    z = XT[:, None, :] - mf_params[:, :, 1, None]
    z /= mf_params[:, :, 0, None]
    with np.errstate(over="ignore"):  # -inf far away: floored by the caller
        return -0.5 * z * z, z


def _rule_matrix(rules, n_mfs):
    """One-hot ``(d M, R)`` matrix: column r picks ``rules[r, j]`` of each input.

    With log-memberships flattened to ``(d M, n)``, one matrix product sums
    every rule's log-memberships: ``log w = rule_matrix.T @ logmu``.
    """
    n_rules, d = rules.shape
    E = np.zeros((d * n_mfs, n_rules))
    E[np.arange(d)[None, :] * n_mfs + rules, np.arange(n_rules)[:, None]] = 1.0
    return E


def _log_floor(d):
    """Floor of one log-membership: ``d`` of them still sum to a finite number.

    A sample infinitely far from some MF then costs a huge but finite log
    firing strength, never ``0 * -inf = NaN`` in the product of
    :func:`_firing_from_log`.
    """
    return -np.finfo(float).max / (4.0 * max(d, 1))


def _is_grid(rules, n_mfs):
    """Whether ``rules`` is the full grid of :func:`grid_rules`, in its order."""
    n_rules, d = rules.shape
    return n_rules == n_mfs**d and np.array_equal(rules, grid_rules(n_mfs, d))


def _firing_from_log(logmu, E, grid=False):
    """Normalised firing strengths ``wbar`` (R, n) from log-memberships (d, M, n).

    ``log w_r = sum_j log mu_{j, rules[r, j]}(x_j)`` and
    ``wbar = exp(log w - logsumexp(log w))``: however far an input lies from
    every membership function, the largest ``wbar`` is of order one, so the
    output stays finite (METHODS §6).

    ``grid=True`` (the rules are :func:`grid_rules`) uses the product
    structure instead (:func:`_grid_memberships`, :func:`_grid_firing`):
    ``d M`` exponentials instead of ``M^d``. ``logmu`` is overwritten.
    """
    if grid:
        return _grid_firing(_grid_memberships(logmu))
    d, n_mfs, n = logmu.shape
    # Squared distances of ~1e155 and beyond overflow to -inf; the floor
    # keeps the normalisation well defined.
    np.maximum(logmu, _log_floor(d), out=logmu)
    logw = E.T @ logmu.reshape(d * n_mfs, n)
    # Softmax with the largest log weight subtracted (log-sum-exp): the
    # largest weight is exp(0) = 1 before normalisation, so the sum never
    # underflows.
    logw -= logw.max(axis=0)
    w = np.exp(logw, out=logw)
    w /= w.sum(axis=0)
    return w


def _grid_memberships(logmu):
    """Memberships normalised over every input's functions, ``nu`` (d, M, n).

    ``nu_jm = mu_jm / sum_m' mu_jm'``, from the log-memberships (overwritten)
    with every input's largest subtracted first, so that the largest ``nu``
    of an input is at least ``1 / M`` however far the input lies. For a grid
    rule base the normalised firing strengths are the products
    ``wbar_r = prod_j nu_{j, rules[r, j]}`` (the sum over the grid of the rule
    weights is the product over inputs of their sums), so no sum over rules
    is needed.
    """
    d, n_mfs, n = logmu.shape
    np.maximum(logmu, _log_floor(d), out=logmu)
    if n_mfs == 2:
        return _two_memberships(logmu[:, 1] - logmu[:, 0])
    # Loops over the few functions of an input: numpy reduces a short middle
    # axis far slower than it combines long rows.
    top = logmu[:, 0].copy()
    for m in range(1, n_mfs):
        np.maximum(top, logmu[:, m], out=top)
    logmu -= top[:, None, :]
    nu = np.exp(logmu, out=logmu)
    total = nu[:, 0].copy()
    for m in range(1, n_mfs):
        total += nu[:, m]
    nu /= total[:, None, :]
    return nu


def _two_memberships(diff):
    """:func:`_grid_memberships` of two functions per input, from
    ``diff = log mu_1 - log mu_0`` (d, n) (overwritten).

    One exponential per input and sample (exp is the costly part): with
    ``e = exp(-|diff|)`` the larger membership is ``1 / (1 + e)`` and the
    smaller ``e / (1 + e)``, each accurate however small.
    """
    first = diff <= 0
    np.abs(diff, out=diff)
    np.negative(diff, out=diff)
    e = np.exp(diff, out=diff)
    large = e + 1.0
    np.reciprocal(large, out=large)
    e *= large
    nu = np.empty((diff.shape[0], 2, diff.shape[1]))
    nu[:, 0] = np.where(first, large, e)
    nu[:, 1] = np.where(first, e, large)
    return nu


def _flush_tiny(a):
    """``a`` (normalised memberships or firing strengths, in [0, 1]) with
    values below :data:`_TINY` set to 0, in place. Products of such values
    in the normal equations would otherwise be subnormal numbers, on which
    the Cholesky factorisation runs tens of times slower (many inputs, each
    rule far from most samples); their share of any output is below 1e-100.
    """
    a[a < _TINY] = 0.0
    return a


def _forward(XT, mf_params, mf, E, grid):
    """Forward pass of training: ``z``, ``nu`` and ``wbar`` (R, n).

    ``z`` as in :func:`_forward_log` (None for bells), ``nu`` the normalised
    memberships of a grid rule base (:func:`_grid_memberships`, else None).
    Two Gaussians per input on a grid go straight from the squared distances
    to ``nu``, the same numbers without forming the log-memberships.
    """
    d, n_mfs = mf_params.shape[:2]
    if grid and mf == "gaussian" and n_mfs == 2:
        z = XT[:, None, :] - mf_params[:, :, 1, None]
        z /= mf_params[:, :, 0, None]
        with np.errstate(over="ignore"):  # inf far away: capped below
            sq = z * z
        # The floor of the log-memberships, -0.5 sq >= _log_floor(d).
        np.minimum(sq, -2.0 * _log_floor(d), out=sq)
        diff = sq[:, 0] - sq[:, 1]
        diff *= 0.5
        nu = _flush_tiny(_two_memberships(diff))
        return z, nu, _flush_tiny(_grid_firing(nu))
    logmu, z = _forward_log(XT, mf_params, mf)
    if grid:
        nu = _flush_tiny(_grid_memberships(logmu))
        return z, nu, _flush_tiny(_grid_firing(nu))
    return z, None, _flush_tiny(_firing_from_log(logmu, E))


class _GaussianRuleForms:
    """Log firing strengths and premise gradient of Gaussian rules that are
    not a grid (fuzzy c-means rule bases), as quadratic forms of the inputs.

    ``log w_r = -0.5 sum_j (x_j - c_jr)^2 / sigma_jr^2`` (``c_jr``,
    ``sigma_jr`` of the function rule ``r`` uses on input ``j``) expands to
    ``-0.5 (a_r . x^2 - 2 (a_r c_r) . x + a_r . c_r^2)`` with ``a = 1 /
    sigma^2``: two matrix products of the ``(R, d)`` coefficients with the
    training inputs and their squares, instead of every log-membership
    ``(d, M, n)`` and its sum over each rule's functions. The premise
    gradient likewise needs only ``g @ x`` and ``g @ x^2`` (``g = dE / dlog
    w``, ``(R, n)``). The inputs are centred on their training mean first,
    so the expanded terms stay of the order of the distances themselves.
    For the training inputs only: far outside them the squares could
    overflow, where the log-memberships of :func:`_forward_log` are floored.
    """

    def __init__(self, XT, rules):
        self.mean = XT.mean(axis=1)
        self.Xc = XT - self.mean[:, None]
        self.Xc2 = self.Xc * self.Xc
        self.rules = rules
        self.inputs = np.broadcast_to(np.arange(XT.shape[0]), rules.shape)

    def _coefficients(self, mf_params):
        """``sigma`` and centred ``c`` of every rule's functions, (R, d)."""
        sigma = mf_params[self.inputs, self.rules, 0]
        centre = mf_params[self.inputs, self.rules, 1] - self.mean
        return sigma, centre

    def firing(self, mf_params):
        """Normalised firing strengths ``wbar`` (R, n)."""
        sigma, centre = self._coefficients(mf_params)
        a = 1.0 / (sigma * sigma)
        logw = (-0.5 * a) @ self.Xc2
        logw += (a * centre) @ self.Xc
        logw -= 0.5 * np.sum(a * centre * centre, axis=1)[:, None]
        logw -= logw.max(axis=0)
        w = np.exp(logw, out=logw)
        w /= w.sum(axis=0)
        return _flush_tiny(w)

    def gradient(self, g, mf_params):
        """Premise gradient ``(d, M, 2)`` from ``g = dE / dlog w`` (R, n):
        ``sum_n g (x - c) / sigma^2`` for the centres and ``sum_n g (x -
        c)^2 / sigma^3`` for the widths, summed over the rules sharing a
        function."""
        sigma, centre = self._coefficients(mf_params)
        g0 = g.sum(axis=1)[:, None]
        g1 = g @ self.Xc.T
        g2 = g @ self.Xc2.T
        d_centre = (g1 - centre * g0) / (sigma * sigma)
        d_sigma = (g2 - 2.0 * centre * g1 + centre * centre * g0) / sigma**3
        grad = np.zeros_like(mf_params)
        np.add.at(grad[..., 0], (self.inputs, self.rules), d_sigma)
        np.add.at(grad[..., 1], (self.inputs, self.rules), d_centre)
        return grad


def _grid_firing(nu):
    """Normalised firing strengths (R, n) of the grid rules, first input slowest."""
    w = nu[0]
    for j in range(1, nu.shape[0]):  # a loop over inputs, not samples
        w = (w[:, None, :] * nu[j][None, :, :]).reshape(-1, nu.shape[2])
    return w


def _normalised_firing(X, mf_params, rules, mf):
    """Normalised firing strengths ``wbar`` (n, R), computed in log space."""
    logmu, _ = _forward_log(np.ascontiguousarray(X.T), mf_params, mf)
    n_mfs = mf_params.shape[1]
    grid = _is_grid(rules, n_mfs)
    return _firing_from_log(logmu, _rule_matrix(rules, n_mfs), grid).T


def _rule_outputs(X1, consequents):
    """Rule outputs ``f`` (n, R, o) for inputs with a trailing ones column."""
    n_rules, p, n_out = consequents.shape
    C = consequents.transpose(1, 0, 2).reshape(p, n_rules * n_out)
    return (X1 @ C).reshape(X1.shape[0], n_rules, n_out)


def _with_ones(X):
    return np.hstack([X, np.ones((X.shape[0], 1))])


def anfis_predict(X, mf_params, rules, consequents, mf):
    """Output of a first-order Takagi-Sugeno system, ``sum_r wbar_r f_r``.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
    mf_params : ndarray of shape (n_features, n_mfs, n_params)
    rules : ndarray of shape (n_rules, n_features)
    consequents : ndarray of shape (n_rules, n_features + 1, n_outputs)
    mf : {"gaussian", "gbell"}

    Returns
    -------
    ndarray of shape (n_samples, n_outputs)
    """
    wbar = _normalised_firing(X, mf_params, rules, mf)
    f = _rule_outputs(_with_ones(X), consequents)
    return np.einsum("nr,nro->no", wbar, f)


# --------------------------------------------------------------------------
# Least squares and gradients
# --------------------------------------------------------------------------


def _design(wbar, X1):
    """Consequent design matrix ``[wbar_r x, wbar_r]`` over rules, (n, R(d+1))."""
    return (wbar[:, :, None] * X1[:, None, :]).reshape(X1.shape[0], -1)


def _solve_transposed(AT, YT, ridge, free=None):
    """:func:`solve_consequents` for ``A.T`` (columns, n) and ``Y.T`` (o, n).

    Forms the normal equations straight from the transposed design matrix
    (``A^T A`` by BLAS ``syrk``, no copy), the usual case of more samples than
    columns; otherwise defers to :func:`solve_consequents`.
    """
    p, n = AT.shape
    if ridge > 0 and p <= n:
        # AT.T is a Fortran-ordered (n, p) view: syrk(trans=1) gives A^T A.
        G = blas.dsyrk(1.0, AT.T, trans=1, lower=0)
        theta = cholesky_ridge(G, AT @ YT.T, ridge, p, free)
        if theta is not None:
            return theta
    return solve_consequents(AT.T, YT.T, ridge, free)


def _softmax_gradient(wT, F, yhat, err):
    """``dE / dlog w_r = wbar_r (f_r - yhat) . err`` (R, n), E = 0.5 sum err^2.

    In the rules x samples layout: ``wT`` (R, n), rule outputs ``F``
    (R, o, n), ``yhat`` and ``err`` (o, n).
    """
    if F.shape[1] == 1:
        return wT * ((F[:, 0] - yhat) * err)
    return wT * np.einsum("ron,on->rn", F - yhat, err)


def _grid_log_mf_gradient(WF, yhat, err, nu, E):
    """``dE / dlog mu_jm`` (d M, n) of a grid rule base, without ``dE / dlog w``.

    Summed over the rules using function m of input j, ``wbar_r (f_r - yhat)
    . err`` is ``err . sum_r wbar_r f_r - (yhat . err) nu_jm``: in a grid the
    normalised firing strengths of those rules add up to ``nu_jm`` (see
    :func:`_grid_memberships`). ``WF`` are the rules' shares ``wbar_r f_r``
    (R, o, n), ``yhat`` and ``err`` (o, n), ``nu`` (d, M, n), ``E`` the rule
    matrix of :func:`_rule_matrix`.
    """
    n_rules, n_out, n = WF.shape
    nu = nu.reshape(-1, n)
    if n_out == 1:
        per_mf = E @ WF[:, 0]
        per_mf *= err
        per_mf -= nu * (yhat * err)
        return per_mf
    per_mf = np.einsum(
        "kon,on->kn", (E @ WF.reshape(n_rules, -1)).reshape(-1, n_out, n), err
    )
    per_mf -= nu * np.einsum("on,on->n", yhat, err)
    return per_mf


def _premise_gradient_from(g, XT, mf_params, mf, E, z=None):
    """Premise gradient from ``g = dE / dlog w`` (R, n).

    ``E`` is the rule matrix of :func:`_rule_matrix`; ``z`` as in
    :func:`_mf_gradient`.
    """
    return _mf_gradient(E @ g, XT, mf_params, mf, z)


def _mf_gradient(per_mf, XT, mf_params, mf, z=None):
    """Premise gradient from ``dE / dlog mu`` (d M, n) (overwritten).

    ``z`` are the standardised distances ``(x - c) / sigma`` (d, M, n) of the
    forward pass (Gaussian MFs), which give the log-membership derivatives
    without recomputing them.
    """
    d, n = XT.shape
    n_mfs = mf_params.shape[1]
    per_mf = per_mf.reshape(d, n_mfs, n)  # dE / dlog mu_jm
    if mf == "gaussian":
        if z is None:
            z = (XT[:, None, :] - mf_params[:, :, 1, None]) / mf_params[:, :, 0, None]
        per_mf *= z
        grad = np.empty_like(mf_params)
        # d log mu / d sigma = z^2 / sigma, d log mu / d c = z / sigma
        grad[..., 0] = np.einsum("jmn,jmn->jm", per_mf, z)
        grad[..., 1] = per_mf.sum(axis=-1)
        grad /= mf_params[..., :1]
        return grad
    dlog = log_membership_grad(XT[:, None, :], mf_params[:, :, None, :], mf)
    return np.einsum("jmn,jmnk->jmk", per_mf, dlog)


def _premise_gradient(X, mf_params, mf, S, wbar, f, yhat, err):
    """Gradient of ``0.5 * sum(err^2)`` w.r.t. ``mf_params`` (analytic).

    ``d yhat / d log w_r = wbar_r (f_r - yhat)`` (softmax), the log firing
    strength is a sum of log-memberships, and the log-membership derivatives
    come from :mod:`skthermal.fuzzy._membership`; everything is vectorised over
    samples, rules and inputs. ``S`` is the one-hot ``(d, R, M)`` selector of
    :func:`_rule_selectors`; ``wbar`` (n, R), ``f`` (n, R, o), ``yhat`` and
    ``err`` (n, o).
    """
    d, n_rules, n_mfs = S.shape
    E = S.transpose(0, 2, 1).reshape(d * n_mfs, n_rules)
    g = _softmax_gradient(wbar.T, f.transpose(1, 2, 0), yhat.T, err.T)
    return _premise_gradient_from(g, np.ascontiguousarray(X.T), mf_params, mf, E)


def _apply_floors(mf_params, mf, width_floor):
    np.maximum(mf_params[..., 0], width_floor[:, None], out=mf_params[..., 0])
    if mf == "gbell":
        np.maximum(mf_params[..., 1], _SLOPE_FLOOR, out=mf_params[..., 1])


class StepSizeRule:
    """Jang's (1993) heuristic step-size rule for the premise gradient step.

    The step size ``kappa`` is the length of each gradient step in parameter
    space (``eta = kappa / ||grad||``). After every epoch's training error:

    - four consecutive decreases (five errors, each below the previous)
      multiply ``kappa`` by ``increase``;
    - two consecutive combinations of one increase and one decrease (five
      errors alternating up/down/up/down or down/up/down/up) multiply it by
      ``decrease``.

    As in Jang's reference implementation (MATLAB ``anfis``), each rule waits
    at least four epochs after it last fired before it can fire again.
    """

    def __init__(self, step, increase, decrease):
        self.step = float(step)
        self.increase = float(increase)
        self.decrease = float(decrease)
        self._last_inc = 0
        self._last_dec = 0

    def update(self, errors):
        """Update the step from the error history; returns the new step."""
        i = len(errors) - 1
        if i < 4:
            return self.step
        # Signs of the last four moves, oldest first (plain floats: this runs
        # every epoch, on five numbers).
        e = [float(v) for v in errors[-5:]]
        d = [(b > a) - (b < a) for a, b in zip(e[:-1], e[1:], strict=True)]
        alternating = all(d) and all(u == -v for u, v in zip(d[:-1], d[1:]))
        if i - self._last_dec >= 4 and alternating:
            self.step *= self.decrease
            self._last_dec = i
        elif i - self._last_inc >= 4 and all(v < 0 for v in d):
            self.step *= self.increase
            self._last_inc = i
        return self.step


# --------------------------------------------------------------------------
# Training loop
# --------------------------------------------------------------------------


def _rmse(residual):
    if not residual.size:
        return 0.0
    residual = residual.ravel()
    return float(np.sqrt(residual @ residual / residual.size))


class _CheckingSet:
    """Held-out data scored every epoch, in the space of the final output.

    ``X`` is in model space (AGO space for grey ANFIS); the predictions are
    turned back with IAGO over ``groups`` when ``grey`` and compared with the
    original targets ``y`` on the rows of ``mask``.
    """

    def __init__(self, X, y, mask=None, groups=None, grey=False):
        self.X = X
        self.y = y
        self.mask = np.ones(X.shape[0], dtype=bool) if mask is None else mask
        self.groups = groups
        self.grey = grey

    def rmse(self, mf_params, rules, consequents, mf):
        pred = anfis_predict(self.X, mf_params, rules, consequents, mf)
        if self.grey:
            pred = iago(pred, self.groups)
        return _rmse(pred[self.mask] - self.y[self.mask])


def _spread(A):
    """Every column's standard deviation, 1 where it is zero or not finite
    (a constant column, no rows): a scale to divide by."""
    if not A.shape[0]:
        return np.ones(A.shape[1])
    s = np.sqrt(np.mean((A - A.mean(axis=0)) ** 2, axis=0))
    return np.where(np.isfinite(s) & (s > 0), s, 1.0)


def _shift_constants(consequents, centre, sign):
    """The same rules for inputs centred on ``centre`` (``sign`` +1) or back
    (-1): ``f = p x + q`` is ``f = p (x - m) + q'`` with ``q' = q + p m``.
    ``consequents`` (n_rules, n_features + 1, n_outputs); a new array."""
    out = np.array(consequents, dtype=float)
    out[:, -1] += sign * np.einsum("a,rao->ro", centre, out[:, :-1])
    return out


def anfis_train(
    X,
    Y,
    mf_params,
    rules,
    mf,
    *,
    epochs=100,
    learning="hybrid",
    step_size=0.5,
    step_increase=1.2,
    step_decrease=0.9,
    ridge=1e-8,
    penalize_intercepts=True,
    checking=None,
    tol=0.0,
    n_iter_no_change=None,
    consequents=None,
    verbose=0,
):
    """Train a first-order Takagi-Sugeno system (Jang's hybrid rule or backprop).

    Hybrid learning, every epoch (Jang 1993, §IV): forward pass; full-batch
    least squares for all consequents at once (they enter the output
    linearly); training error; gradient step of length ``step_size`` on the
    premise parameters; :class:`StepSizeRule` adapts the step. Backprop
    learning takes the same normalised gradient step on premise and
    consequent parameters together.

    The parameters of the epoch with the least checking error (least training
    error without a checking set) are returned, as MATLAB's ``anfis`` does.

    Parameters
    ----------
    X : ndarray of shape (n_samples, n_features)
    Y : ndarray of shape (n_samples, n_outputs)
    mf_params : ndarray of shape (n_features, n_mfs, n_params)
        Initial premise parameters (copied).
    rules : ndarray of shape (n_rules, n_features)
    mf : {"gaussian", "gbell"}
    epochs, learning, step_size, step_increase, step_decrease, ridge, \
penalize_intercepts, tol, n_iter_no_change, verbose
        See :class:`ANFISRegressor`.
    checking : _CheckingSet, optional
    consequents : ndarray of shape (n_rules, n_features + 1, n_outputs), optional
        Initial consequents for backprop learning (default: constant rules
        equal to the target mean).

    Returns
    -------
    dict
        ``mf_params``, ``consequents``, ``history`` (dict of arrays) and
        ``best_epoch`` (1-based).
    """
    n, d = X.shape
    n_out = Y.shape[1]
    n_rules = rules.shape[0]
    mf_params = np.array(mf_params, dtype=float)
    # Rules x samples layout: every per-sample array has samples along its
    # last, contiguous axis; consequent columns are ordered (input, rule).
    XT = np.ascontiguousarray(X.T)
    X1T = np.vstack([XT, np.ones((1, n))])
    # With free constant terms the least squares see the inputs centred on
    # their mean: each rule's f = p (x - m) + q' is f = p x + q with
    # q = q' - p m (converted after every solve), the same model, but the
    # stabilising ridge of q' acts at the data, not at x = 0, so inputs far
    # from zero (kelvin, large offsets) are not biased by it. With shrunk
    # constant terms the prior is "no error where the inputs are zero" (the
    # papers' changes since the run start): the inputs are taken as given.
    # Backprop takes every step on the consequents too, so it always sees the
    # inputs centred: a normalised step then weighs slopes and constant terms
    # alike whatever the inputs' offset (on readings around 20 °C the slopes'
    # gradient is 20 times the constant terms', and every step overshoots).
    centre = (
        X.mean(axis=0)
        if n and (not penalize_intercepts or learning == "backprop")
        else np.zeros(d)
    )
    if n:
        # An input constant in training (a stuck sensor) is centred in any
        # case: taken as given it is a second constant term, and the least
        # squares split the level between the two, leaving it a slope the
        # data never set (a stuck sensor reading 1 K more moved a grid
        # ANFIS by 34 um). Centred, it is zero, and its slopes are the
        # ridge's: zero.
        constant = np.ptp(X, axis=0) == 0
        centre = np.where(constant, X[0], centre)
    centred = bool(centre.any())
    X1cT = np.vstack([XT - centre[:, None], X1T[-1:]]) if centred else X1T
    YT = np.ascontiguousarray(Y.T)
    n_mfs = mf_params.shape[1]
    E = _rule_matrix(rules, n_mfs)
    grid = _is_grid(rules, n_mfs)
    # Columns (input, rule): the rules' constant terms are the last n_rules.
    free = None
    if not penalize_intercepts:
        free = np.zeros((d + 1) * n_rules, dtype=bool)
        free[d * n_rules :] = True
    normal = None
    if learning == "hybrid":
        normal = NormalEquations.plan(X1cT, YT, rules, n_mfs, grid, ridge)
    AT3 = None  # the transposed design matrix, only when it is needed
    # Gaussian rules that are not a grid: quadratic forms of the inputs.
    forms = _GaussianRuleForms(XT, rules) if mf == "gaussian" and not grid else None
    width_floor = _WIDTH_FLOOR * _input_scale(X)
    if learning == "backprop":
        if consequents is None:
            consequents = np.zeros((n_rules, d + 1, n_out))
            consequents[:, -1, :] = Y.mean(axis=0)
        # Internally f = p (x - m) + q', converted back to f = p x + q for
        # every parameter set returned, and on standardised scales: a slope
        # in units of the target's spread per input's spread, a constant in
        # units of the target's spread. The normalised step then moves the
        # consequents as far whatever the units of the inputs and targets
        # (in the target's units, a target spread over 1000 learned almost
        # nothing; in the inputs' units, inputs spread over 100, such as
        # grey=True's accumulated ones, overshot).
        x_scale, y_scale = _spread(X), _spread(Y)
        # (input or constant, output): what one unit of a scaled consequent is
        unit = np.vstack([y_scale[None, :] / x_scale[:, None], y_scale[None, :]])
        consequents_c = _shift_constants(consequents, centre, 1.0) / unit
    rule = StepSizeRule(step_size, step_increase, step_decrease)
    stalled = None  # the epoch after which the premise gradient vanished
    collapsed = None  # the epoch whose premise step put a width on its floor
    stepped = False  # whether a premise step was taken

    history = {"epoch": [], "train_rmse": [], "step_size": []}
    if checking is not None:
        history["val_rmse"] = []
    best = (np.inf, None, None, 0)
    stop_best = np.inf
    no_improvement = 0
    report_every = max(1, epochs // 10) if verbose == 1 else 1

    for epoch in range(1, epochs + 1):
        if forms is None:
            z, nu, wT = _forward(XT, mf_params, mf, E, grid)
        else:
            z, nu, wT = None, None, forms.firing(mf_params)
        if learning == "hybrid":
            theta = None if normal is None else normal.solve(wT, nu, ridge, free)
            if theta is None:
                if AT3 is None:
                    AT3 = np.empty((d + 1, n_rules, n))
                np.multiply(wT[None], X1cT[:, None, :], out=AT3)
                theta = _solve_transposed(AT3.reshape(-1, n), YT, ridge, free)
            # theta: rows (input, rule), columns outputs; back to f = p x + q.
            consequents = theta.reshape(d + 1, n_rules, n_out).transpose(1, 0, 2)
            if centred:
                consequents = _shift_constants(consequents, centre, -1.0)
            C = consequents.transpose(1, 0, 2).reshape(d + 1, -1)
            F = (C.T @ X1T).reshape(n_rules, n_out, n)  # rule outputs
        else:
            unscaled = unit * consequents_c
            consequents = _shift_constants(unscaled, centre, -1.0)
            C = unscaled.transpose(1, 0, 2).reshape(d + 1, -1)
            F = (C.T @ X1cT).reshape(n_rules, n_out, n)
        WF = wT[:, None, :] * F  # the rules' shares of the output
        yhat = WF.sum(axis=0)
        err = yhat - YT
        train = _rmse(err)
        history["epoch"].append(epoch)
        history["train_rmse"].append(train)
        history["step_size"].append(rule.step)
        monitored = train
        if checking is not None:
            monitored = checking.rmse(mf_params, rules, consequents, mf)
            history["val_rmse"].append(monitored)
        if not np.isfinite(monitored):
            break
        if monitored < best[0]:
            best = (monitored, mf_params.copy(), consequents.copy(), epoch)
        if verbose and (epoch % report_every == 0 or epoch == epochs):
            msg = f"Epoch {epoch}/{epochs}: train RMSE {train:.6g}"
            if checking is not None:
                msg += f", checking RMSE {monitored:.6g}"
            print(f"{msg}, step size {rule.step:.4g}", file=sys.stdout)
        if n_iter_no_change is not None:
            if monitored > stop_best - tol:
                no_improvement += 1
            else:
                no_improvement = 0
            stop_best = min(stop_best, monitored)
            if no_improvement >= n_iter_no_change:
                if verbose:
                    print(
                        f"Stopped after epoch {epoch}: no improvement of more "
                        f"than tol={tol} in {n_iter_no_change} epochs.",
                        file=sys.stdout,
                    )
                break
        if epoch == epochs:
            break
        step = rule.update(history["train_rmse"])
        if forms is not None:
            grad = forms.gradient(_softmax_gradient(wT, F, yhat, err), mf_params)
        else:
            if grid:
                per_mf = _grid_log_mf_gradient(WF, yhat, err, nu, E)
            else:
                per_mf = E @ _softmax_gradient(wT, F, yhat, err)
            grad = _mf_gradient(per_mf, XT, mf_params, mf, z)
        if learning == "hybrid":
            norm = np.sqrt(np.vdot(grad, grad))
            if norm > 0 and np.isfinite(norm):
                mf_params -= (step / norm) * grad
                stepped = True
            elif stepped and stalled is None:
                # The gradient vanished after steps were taken (one rule has
                # none from the start): a step collapsed a membership function
                # (its width onto the floor, zero on every sample), and the
                # later epochs repeat this one. Recorded for the estimator.
                stalled = epoch
        else:
            # dE / d consequent (a, r) = sum_n x~_a wbar_r err (x~ centred),
            # times the unit of the scaled consequents
            XE = (X1cT[:, None, :] * err[None]).reshape(-1, n)
            grad_c = (XE @ wT.T).reshape(d + 1, n_out, n_rules).transpose(2, 0, 1)
            grad_c *= unit
            norm = np.sqrt(np.vdot(grad, grad) + np.vdot(grad_c, grad_c))
            if norm > 0 and np.isfinite(norm):
                mf_params -= (step / norm) * grad
                consequents_c = consequents_c - (step / norm) * grad_c
        _apply_floors(mf_params, mf, width_floor)
        if collapsed is None and np.any(mf_params[..., 0] <= width_floor[:, None]):
            collapsed = epoch

    if best[1] is None:  # not a single finite epoch: keep the last parameters
        best = (np.inf, mf_params.copy(), consequents.copy(), len(history["epoch"]))
    return {
        "mf_params": best[1],
        "consequents": best[2],
        "history": {k: np.asarray(v) for k, v in history.items()},
        "best_epoch": best[3],
        "stalled_epoch": stalled,
        "collapsed_epoch": collapsed,
    }
