"""Exact output-error calibration of the grey models: variable projection.

METHODS §7-8. For a fixed development coefficient ``b1`` the restored series of
GMC(1,N) is linear in the driving coefficients and ``u``: it is
``Phi(b1) @ (b, u)``, the columns of ``Phi`` being the restored responses to
each AGO input alone and to ``u = 1``. The papers' particle-swarm objective
(the sum of squared errors of the restored series) is then a linear
least-squares problem inside a 1-D search over ``b1`` -- variable projection --
whose global minimum a grid over ``b1`` (solved in one batch) and a bounded
scalar refinement find. The same machinery gives the ridge-regularised
solution for many collinear inputs and chooses the ridge term by blocked,
run-aware cross-validation; GNNMCI(1,N), whose restored series is linear in
its weights, is the case with no ``b1`` at all.
"""

import numpy as np

from skthermal.grey._gmc import (
    _block_layout,
    _check_delay,
    _convolution_blocked,
    _gmc_penalty_weights,
    _model_runs,
    _penalty_scale,
    _run_scales,
    _scale_runs,
    _unscale_coef,
)
from skthermal.grey._models import check_alpha, check_grey_data


def _gmc_responses(runs, b1s):
    """Restored responses ``Phi(b1)`` of shape (n_b1, n_samples, n_inputs + 1).

    Column j < n_inputs: the restored series for ``b_j = 1`` (others 0,
    ``u = 0``); last column: for ``u = 1``. Rows stack the runs in order. All
    ``b1`` values are filtered in one blocked convolution.
    """
    b1s = np.atleast_1d(np.asarray(b1s, dtype=float))
    G = b1s.shape[0]
    out = []
    with np.errstate(over="ignore", invalid="ignore"):
        for X1, _ in runs:
            n, m = X1.shape
            L, nb, order, _, back = _block_layout(n)
            cols = np.column_stack([X1, np.ones(n)])[order.ravel()]
            F = np.broadcast_to(cols[:, None, :], (L * nb, G, m + 1))
            F = np.ascontiguousarray(F).reshape(L, nb, G * (m + 1))
            Ib = _convolution_blocked(F, np.repeat(b1s, m + 1))
            Ib = Ib.reshape(L * nb, G, m + 1)[back]
            R = np.empty_like(Ib)
            R[0] = Ib[0]
            np.subtract(Ib[1:], Ib[:-1], out=R[1:])
            out.append(R)
    return np.concatenate(out, axis=0).transpose(1, 0, 2)


def _ridge_path(gram, rhs, w, alphas, free_last):
    """Ridge solutions for every ``alpha`` from the normal equations.

    Solves ``min ||y - Phi c||^2 + alpha sum_j (w_j c_j)^2`` for stacks of
    problems given as ``gram = Phi^T Phi`` (..., p, p) and ``rhs = Phi^T y``
    (..., p); ``w`` (..., q) weights the penalised coefficients, which are all
    of them (``q = p``) or all but the last (``free_last``: an unpenalised
    constant, eliminated first by its Schur complement). One eigendecomposition
    per problem serves every ``alpha``; for ``alpha = 0`` directions with
    eigenvalues below round-off are dropped (minimum-norm solution).

    Returns
    -------
    ndarray of shape (..., n_alphas, p)
    """
    alphas = np.asarray(alphas, dtype=float)
    if free_last:
        guu = gram[..., -1, -1]
        gbu = gram[..., :-1, -1]
        ru = rhs[..., -1]
        inv = np.where(guu > 0, 1.0 / np.where(guu > 0, guu, 1.0), 0.0)
        gb = (
            gram[..., :-1, :-1]
            - gbu[..., :, None] * gbu[..., None, :] * inv[..., None, None]
        )
        rb = rhs[..., :-1] - gbu * (ru * inv)[..., None]
    else:
        gb, rb = gram, rhs
    ws = np.where(w > 0, w, 1.0)
    gs = gb / ws[..., :, None] / ws[..., None, :]
    lam, V = np.linalg.eigh(gs)
    lam = np.clip(lam, 0.0, None)
    proj = np.einsum("...ji,...j->...i", V, rb / ws)
    tol = lam[..., -1:] * 1e-12 * lam.shape[-1]
    denom = lam[..., None, :] + alphas[:, None]
    keep = denom > tol[..., None, :]
    f = np.where(keep, 1.0 / np.where(keep, denom, 1.0), 0.0)
    cb = np.einsum("...ij,...aj->...ai", V, f * proj[..., None, :]) / ws[..., None, :]
    if not free_last:
        return cb
    cu = (ru[..., None] - np.einsum("...i,...ai->...a", gbu, cb)) * inv[..., None]
    return np.concatenate([cb, cu[..., None]], axis=-1)


def _quad_loss(c, gram, rhs, yy):
    """``||y - Phi c||^2`` from the normal-equation statistics, c (..., A, p)."""
    lin = np.einsum("...ap,...p->...a", c, rhs)
    quad = np.einsum("...ap,...pq,...aq->...a", c, gram, c)
    return np.maximum(yy[..., None] - 2.0 * lin + quad, 0.0)


def _fold_blocks(lengths, n_folds):
    """Contiguous validation blocks: whole runs, or blocks of runs.

    With at least ``n_folds`` runs the folds are whole runs (consecutive runs
    grouped into ``n_folds`` folds): run-aware cross-validation. With one run
    they are ``n_folds`` contiguous blocks of it (blocked time-series CV).
    With more than one run but fewer than ``n_folds``, every run is cut into
    ``ceil(n_folds / n_runs)`` contiguous blocks: two or three folds give no
    usable standard error for the one-standard-error rule of
    :func:`_cv_alpha` (with two runs it took the largest penalty, a model
    predicting almost no change, on a third of the held-out blocks of the
    FL_THERMAL record).
    Returns a list of row-index arrays into the stacked runs.
    """
    starts = np.concatenate([[0], np.cumsum(lengths)])
    if len(lengths) < n_folds:
        per = int(np.ceil(n_folds / len(lengths)))
        blocks = []
        for start, n in zip(starts[:-1], lengths, strict=True):
            edges = np.unique(np.linspace(0, n, per + 1).round().astype(int))
            blocks += [
                start + np.arange(a, b)
                for a, b in zip(edges[:-1], edges[1:], strict=True)
            ]
        return blocks
    k = n_folds
    fold_of_run = np.arange(len(lengths)) * k // len(lengths)
    return [
        np.concatenate(
            [
                np.arange(starts[r], starts[r + 1])
                for r in np.flatnonzero(fold_of_run == f)
            ]
        )
        for f in range(k)
    ]


def _block_stats(Phi, y, blocks):
    """Normal-equation statistics of each row block of ``Phi`` (G, n, p).

    Returns ``gram`` (n_blocks, G, p, p), ``rhs`` (n_blocks, G, p) and ``yy``
    (n_blocks,).
    """
    gram = np.stack([np.einsum("gnp,gnq->gpq", Phi[:, b], Phi[:, b]) for b in blocks])
    rhs = np.stack([np.einsum("gnp,n->gp", Phi[:, b], y[b]) for b in blocks])
    yy = np.array([y[b] @ y[b] for b in blocks])
    return gram, rhs, yy


def _gmc_block_stats(runs, grid, y, blocks, max_elements=2**22):
    """:func:`_block_stats` of the GMC responses, the ``b1`` grid in chunks.

    The responses of a chunk of grid values hold ``max_elements`` numbers at
    most (32 MB), so long records do not need the whole (G, n, p) array.
    """
    n, p = y.shape[0], runs[0][0].shape[1] + 1
    step = max(1, max_elements // (n * p))
    parts = [
        _block_stats(_gmc_responses(runs, grid[i : i + step]), y, blocks)
        for i in range(0, len(grid), step)
    ]
    gram = np.concatenate([part[0] for part in parts], axis=1)
    rhs = np.concatenate([part[1] for part in parts], axis=1)
    return gram, rhs, parts[0][2]


def _cv_alpha(stats, blocks, w, alphas, free_last, forward):
    """Pick ``alpha`` by blocked, run-aware CV on output-error predictions.

    ``stats`` are the :func:`_block_stats` of the validation ``blocks`` (from
    :func:`_fold_blocks`). Several runs (``forward=False``): each fold holds
    out whole runs and trains on the others. One run (``forward=True``): each
    block after the first is predicted by a model trained on the blocks
    before it (forward chaining, as ``TimeSeriesSplit``), which is what a
    chronological split asks of the model: extrapolation to later conditions.
    In each fold the coefficients (and, for GMC, the grid value of ``b1``) are
    fitted on the training rows only, by the penalised loss. The model is
    simulated through the held-out rows from the inputs alone (an output-error
    model uses no target value there), so no target information leaks across
    folds.

    The choice follows the one-standard-error rule: the largest ``alpha`` whose
    mean held-out error is within one standard error (over folds) of the
    smallest; between equally good models, the simpler one extrapolates more
    safely.

    Returns the chosen alpha and the mean held-out squared error per alpha.
    """
    gram_k, rhs_k, yy_k = stats
    alphas = np.asarray(alphas, dtype=float)
    folds = range(1, len(blocks)) if forward else range(len(blocks))
    fold_mse = []
    for k in folds:
        train = np.arange(k) if forward else np.delete(np.arange(len(blocks)), k)
        gt, rt = gram_k[train].sum(0), rhs_k[train].sum(0)
        yt = np.full(gt.shape[0], yy_k[train].sum())
        c = _ridge_path(gt, rt, w, alphas, free_last)  # (G, A, p)
        pen = alphas * np.sum((c[..., : w.shape[-1]] * w[:, None, :]) ** 2, axis=-1)
        j = _quad_loss(c, gt, rt, yt) + pen  # (G, A)
        best = np.argmin(np.where(np.isfinite(j), j, np.inf), axis=0)
        c_best = c[best, np.arange(len(alphas))]  # (A, p)
        sse = _held_out(c_best, gram_k[k][best], rhs_k[k][best], yy_k[k])
        fold_mse.append(sse / len(blocks[k]))
    fold_mse = np.array(fold_mse)
    cv = fold_mse.mean(axis=0)
    i = int(np.argmin(cv))
    se = fold_mse[:, i].std(ddof=1) / np.sqrt(len(fold_mse)) if len(fold_mse) > 1 else 0
    within = np.flatnonzero(cv <= cv[i] + se)
    return float(alphas[within].max()), cv


def _held_out(c, gram, rhs, yy):
    """Held-out SSE for A coefficient vectors c (A, p) with their own stats."""
    lin = np.einsum("ap,ap->a", c, rhs)
    quad = np.einsum("ap,apq,aq->a", c, gram, c)
    return np.maximum(yy - 2.0 * lin + quad, 0.0)


ALPHA_GRID = np.r_[0.0, np.logspace(-6, 2, 17)]


def _b1_grid(n_mean, b1_bounds=None, n_grid=40):
    """Grid of development coefficients: 0 and log-spaced time constants.

    From a time constant of ~100 runs (``b1 = 0.01 / n_mean``, an integrator
    over a run) to ``b1 = 20`` (``e^{-b1} ~ 2e-9``: no lag at all).
    """
    lo, hi = (0.0, 20.0) if b1_bounds is None else map(float, b1_bounds)
    grid = np.r_[0.0, np.geomspace(min(0.01 / n_mean, 1e-3), 20.0, n_grid)]
    grid = grid[(grid >= lo) & (grid <= hi)]
    return np.unique(np.r_[lo, grid, hi])


def _gmc_varpro(runs, alpha=0.0, *, b1_bounds=None, n_grid=40, n_folds=5):
    """Output-error calibration of GMC(1,N) by variable projection.

    Minimises ``sum_k (xhat_1^(0)(k) - x_1^(0)(k))^2 + alpha sum_j (w_j b_j)^2``
    over ``(b1, b, u)`` with ``b1`` in ``b1_bounds``: for fixed ``b1`` it is a
    linear least-squares problem; a grid over ``b1`` (all solved in one batch)
    picks the basin, a bounded scalar minimisation refines ``b1`` between the
    grid neighbours with an exact (SVD) solve inside.

    The ridge weights ``w_j`` are those of :func:`_gmc_penalty_weights`.
    ``runs`` is a list of ``(X1, y0)`` as made by :func:`_model_runs` with
    ``relative=True``. ``alpha="auto"`` chooses it from :data:`ALPHA_GRID` by
    blocked, run-aware cross-validation on the training runs (:func:`_cv_alpha`).

    Returns ``theta = (b1, b_2..b_N, u)``, the alpha used and the penalty
    scale ``(xnorm, n_mean)``.
    """
    from scipy import linalg, optimize

    xnorm, n_mean = _penalty_scale(runs)
    y = np.concatenate([y0 for _, y0 in runs])
    lengths = [y0.shape[0] for _, y0 in runs]
    grid = _b1_grid(n_mean, b1_bounds, n_grid)
    W = _gmc_penalty_weights(grid, xnorm, n_mean)
    auto = isinstance(alpha, str)
    blocks = _fold_blocks(lengths, n_folds) if auto else [np.arange(len(y))]
    stats = _gmc_block_stats(runs, grid, y, blocks)
    if auto:
        alpha, _ = _cv_alpha(stats, blocks, W, ALPHA_GRID, True, len(lengths) == 1)
    alpha = float(alpha)
    gram, rhs, yy = stats[0].sum(0), stats[1].sum(0), stats[2].sum()
    c = _ridge_path(gram, rhs, W, [alpha], True)[:, 0]
    pen = alpha * np.sum((c[:, :-1] * W) ** 2, axis=1)
    J = _quad_loss(c[:, None], gram, rhs, np.full(len(grid), yy))[:, 0] + pen
    g = int(np.argmin(np.where(np.isfinite(J), J, np.inf)))

    def solve(b1):
        P = _gmc_responses(runs, [b1])[0]
        if alpha > 0:
            w = _gmc_penalty_weights([b1], xnorm, n_mean)[0]
            P = np.vstack([P, np.column_stack([np.diag(np.sqrt(alpha) * w), 0 * w])])
            t = np.r_[y, np.zeros(w.shape[0])]
        else:
            t = y
        coef, *_ = linalg.lstsq(P, t, lapack_driver="gelsy")
        r = P @ coef - t
        return float(r @ r), coef

    best_b1 = grid[g]
    best_j, best_c = solve(best_b1)
    lo, hi = grid[max(g - 1, 0)], grid[min(g + 1, len(grid) - 1)]
    if hi > lo:
        res = optimize.minimize_scalar(
            lambda b: solve(b)[0],
            bounds=(lo, hi),
            method="bounded",
            options={"xatol": 1e-10 + 1e-6 * best_b1},
        )
        j, coef = solve(res.x)
        if j < best_j:
            best_b1, best_j, best_c = float(res.x), j, coef
    return np.r_[best_b1, best_c], alpha, (xnorm, n_mean)


def _gnnmci_ridge(runs, alpha=0.0, *, n_folds=5):
    """Exact (ridge) least-squares weights of GNNMCI(1,N) on changes since start.

    With ``x_1^(1)(1) = 0`` the restored series is ``sum_j w2j dx_j(k)`` for
    k >= 2 and ``w2N`` at k = 1 (where the target is 0), so the swarm's
    objective plus ``alpha sum_j (||dx_j|| w2j)^2`` is minimised by a ridge
    regression without intercept and ``w2N = 0``; ``w11`` does not enter.
    ``alpha="auto"`` picks it as :func:`_gmc_varpro` does.

    Returns the weights ``(w11 = 0, w2_2..w2_{N-1}, w2N = 0)``, the alpha used
    and the input norms of the penalty.
    """
    from scipy import linalg

    dX = np.concatenate([np.diff(X1, axis=0, prepend=0.0) for X1, _ in runs])
    y = np.concatenate([y0 for _, y0 in runs])
    xnorm = np.linalg.norm(dX, axis=0)
    if isinstance(alpha, str):
        lengths = [y0.shape[0] for _, y0 in runs]
        blocks = _fold_blocks(lengths, n_folds)
        stats = _block_stats(dX[None], y, blocks)
        forward = len(lengths) == 1
        alpha, _ = _cv_alpha(stats, blocks, xnorm[None], ALPHA_GRID, False, forward)
    alpha = float(alpha)
    if alpha > 0:
        P = np.vstack([dX, np.diag(np.sqrt(alpha) * xnorm)])
        t = np.r_[y, np.zeros(dX.shape[1])]
    else:
        P, t = dX, y
    w, *_ = linalg.lstsq(P, t, lapack_driver="gelsy")
    return np.r_[0.0, w, 0.0], alpha, xnorm


def gmc1n_varpro(y, X, *, groups=None, delay=0, alpha=0.0, b1_bounds=None):
    """Calibrate GMC(1,N) on its restored series by variable projection.

    Minimises the papers' particle-swarm objective (METHODS §7), the sum of
    squared errors of the restored series ``xhat_1^(0)`` over all runs, plus
    an optional ridge term, exactly: for a fixed ``b1`` the restored series is
    linear in ``(b_2..b_N, u)``, so a grid over ``b1`` with a least-squares
    solve for each (all in one batch), then a bounded scalar refinement of
    ``b1``, finds the global minimum. Inputs and target are taken as changes
    since the first sample of each run.

    Parameters
    ----------
    y : array-like of shape (n_samples,)
        Target series ``x_1^(0)``.
    X : array-like of shape (n_samples, n_inputs)
        Input series ``x_2^(0) .. x_N^(0)``.
    groups : array-like of shape (n_samples,), optional
        Run labels; the model restarts at every run.
    delay : int, default=0
        As in :func:`gmc1n`.
    alpha : float >= 0 or "auto", default=0.0
        Ridge term ``alpha sum_j (g(b1) ||dx_j|| b_j)^2``, ``g(b1)`` the static
        gain of the response (see :class:`GreyPSORegressor`); "auto" chooses
        it by cross-validation over the runs (blocks of a single run).
    b1_bounds : (float, float), optional
        Range of ``b1``; default ``[0, 20]`` (``e^{-20}``: no lag at all).

    Returns
    -------
    b1 : float
    b : ndarray of shape (n_inputs,)
    u : float

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.grey import gmc1n_predict, gmc1n_varpro
    >>> t = np.arange(200.0)
    >>> X = np.c_[20 + 5 * (1 - np.exp(-t / 40)), 20 + 2 * np.sin(t / 30)]
    >>> y = gmc1n_predict(X, 0.1, [0.3, -0.2], 0.01)
    >>> b1, b, u = gmc1n_varpro(y, X)
    >>> round(b1, 6), np.round(b, 6).tolist(), round(u, 6)
    (0.1, [0.3, -0.2], 0.01)
    """
    n_inputs = 1 if np.ndim(X) == 1 else np.shape(X)[1]
    alpha = check_alpha(alpha, auto=True)
    if b1_bounds is not None:
        lo_hi = np.asarray(b1_bounds, dtype=float)
        if (
            lo_hi.shape != (2,)
            or not np.all(np.isfinite(lo_hi))
            or lo_hi[0] < 0
            or lo_hi[0] > lo_hi[1]
        ):
            raise ValueError(
                "b1_bounds must be a finite (low, high) pair with 0 <= low <= high "
                f"(a negative b1 grows exponentially), got {b1_bounds!r}."
            )
    y, X, slices = check_grey_data(y, X, groups, 1, "GMC(1,N)")
    runs = _model_runs(y, X, slices, delay=_check_delay(delay))
    # On data of magnitude ~1 (exact powers of two): no overflow, no lost input.
    ey, ex = _run_scales(runs)
    theta, _, _ = _gmc_varpro(_scale_runs(runs, ey, ex), alpha, b1_bounds=b1_bounds)
    theta = _unscale_coef(theta, ey, ex, "GMC(1,N)")
    return float(theta[0]), theta[1 : n_inputs + 1], float(theta[-1])
