"""Particle swarm optimisation, vectorised over the swarm.

METHODS §9 (001 eq. 3.15-3.17). One call of the objective evaluates every
particle at once, so an objective written with numpy over a leading "particle"
axis costs one Python call per epoch, not one per particle.
"""

import numbers

import numpy as np
from scipy.optimize import OptimizeResult
from sklearn.utils import check_random_state
from sklearn.utils._param_validation import Interval, validate_params

_NONNEGATIVE = Interval(numbers.Real, 0, np.inf, closed="left")


def _as_bounds(bounds):
    """Lower and upper bounds as two float arrays of shape (n_dims,)."""
    if hasattr(bounds, "lb") and hasattr(bounds, "ub"):  # scipy.optimize.Bounds
        lo = np.atleast_1d(np.asarray(bounds.lb, dtype=float))
        hi = np.atleast_1d(np.asarray(bounds.ub, dtype=float))
        lo, hi = np.broadcast_arrays(lo, hi)
    else:
        try:
            b = np.asarray(bounds, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                "bounds must be a sequence of (low, high) pairs, one per dimension."
            ) from exc
        if b.ndim != 2 or b.shape[1] != 2 or b.shape[0] == 0:
            raise ValueError(
                "bounds must be a sequence of (low, high) pairs, one per dimension, "
                f"i.e. of shape (n_dims, 2); got shape {b.shape}."
            )
        lo, hi = b[:, 0], b[:, 1]
    if lo.size == 0:
        raise ValueError("bounds must describe at least one dimension.")
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise ValueError("bounds must be finite: the swarm is drawn inside them.")
    if np.any(lo > hi):
        d = int(np.flatnonzero(lo > hi)[0])
        raise ValueError(
            f"bounds of dimension {d} have low > high: ({lo[d]}, {hi[d]})."
        )
    with np.errstate(over="ignore"):
        wide = ~(np.abs(hi - lo) <= _WIDEST_BOX)
    if np.any(wide):
        d = int(np.flatnonzero(wide)[0])
        raise ValueError(
            f"bounds of dimension {d} ({lo[d]:g}, {hi[d]:g}) are wider than "
            f"{_WIDEST_BOX:g}: the swarm's steps would overflow. Search a "
            "rescaled parameter (or its logarithm) instead."
        )
    return lo.copy(), hi.copy()


# The widest box :func:`particle_swarm` searches in any dimension: its
# velocities (up to a few times the width) stay far from overflow.
_WIDEST_BOX = 1e300


def _inertia_schedule(inertia, epochs):
    if isinstance(inertia, numbers.Real):
        w0 = w1 = float(inertia)
    else:
        try:
            w0, w1 = (float(w) for w in inertia)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                "inertia must be a float or a (start, end) pair for a linear "
                f"decrease, got {inertia!r}."
            ) from exc
    if not (np.isfinite(w0) and np.isfinite(w1)):
        raise ValueError(f"inertia must be finite, got {inertia!r}.")
    if isinstance(inertia, numbers.Real):
        return np.full(max(epochs, 1), w0)
    if epochs <= 1:
        return np.array([w0])
    return np.linspace(w0, w1, epochs)


def _evaluate(fun, P, n_particles):
    costs = np.asarray(fun(P.copy()))
    if np.iscomplexobj(costs):
        raise ValueError(
            "fun returned complex costs: a cost must be a real number (a "
            "square root or power of a negative value, or an FFT, left "
            "unreduced?)."
        )
    # Numbers only: numpy would read text ("1.0") as a number, and None as
    # NaN, which the swarm takes for a failed evaluation.
    odd = None
    if costs.dtype.kind == "O":
        # Numbers of any kind (numpy bools and 0-d arrays, Decimal), not
        # text, None or complex numbers.
        odd = next(
            (
                type(c).__name__
                for c in costs.ravel()
                if c is None
                or isinstance(c, str | bytes | complex | np.complexfloating)
                or (isinstance(c, np.ndarray) and c.dtype.kind not in "biuf")
            ),
            None,
        )
    elif costs.dtype.kind in "US":
        odd = f"text ({costs.dtype} values)"
    elif costs.dtype.kind not in "biuf":
        odd = f"{costs.dtype} values"
    if odd is not None:
        raise ValueError(
            f"fun must return real numbers, one cost per particle; got {odd}."
        )
    try:
        costs = costs.astype(float)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"fun must return real numbers, one cost per particle; got {exc}."
        ) from None
    if costs.shape != (n_particles,):
        raise ValueError(
            "fun must return one cost per particle, an array of shape "
            f"({n_particles},); got shape {costs.shape}."
        )
    if np.any(np.isneginf(costs)):
        raise ValueError(
            "fun returned -inf: the objective is unbounded below at "
            f"{P[np.isneginf(costs)][0]!r}."
        )
    # NaN means "could not evaluate" (e.g. an overflowing model): never a best.
    return np.where(np.isnan(costs), np.inf, costs)


@validate_params(
    {
        "fun": [callable],
        "bounds": "no_validation",  # pairs or scipy Bounds, checked with the shape
        "n_particles": [Interval(numbers.Integral, 1, None, closed="left")],
        "epochs": [Interval(numbers.Integral, 0, None, closed="left")],
        "c1": [_NONNEGATIVE],
        "c2": [_NONNEGATIVE],
        "inertia": [numbers.Real, "array-like"],
        "velocity_clamp": [
            Interval(numbers.Real, 0, None, closed="neither"),
            "array-like",
            None,
        ],
        "init": ["array-like", None],
        "random_state": ["random_state"],
        "tol": [_NONNEGATIVE, None],
        "patience": [Interval(numbers.Integral, 1, None, closed="left")],
    },
    prefer_skip_nested_validation=True,
)
def particle_swarm(
    fun,
    bounds,
    *,
    n_particles=90,
    epochs=100,
    c1=2.0,
    c2=2.0,
    inertia=(0.9, 0.4),
    velocity_clamp=None,
    init=None,
    random_state=None,
    tol=None,
    patience=10,
):
    """Minimise ``fun`` over a box with a global-best particle swarm.

    Every epoch updates the velocity and position of each particle (METHODS §9,
    001 eq. 3.15-3.16),

    ``V <- w V + c1 R1 (Pbest - B) + c2 R2 (Gbest - B)``,  ``B <- B + V``,

    with ``R1, R2 ~ U(0, 1)`` drawn per particle and per component, then
    evaluates the whole swarm with a single call ``fun(B)``.

    Parameters
    ----------
    fun : callable
        ``fun(P) -> costs``: ``P`` has shape (n_particles, n_dims), one particle
        per row, and ``costs`` shape (n_particles,). ``P`` is a copy, so ``fun``
        may modify it. NaN and ``+inf`` costs mark positions that cannot be
        evaluated: they never become a best position. ``-inf`` is an error.
    bounds : sequence of (low, high) pairs or scipy.optimize.Bounds
        The search box, one finite pair per dimension (``low == high`` fixes a
        dimension). Initial positions are uniform in the box.
    n_particles : int, default=90
        Swarm size (001 and 002 used 90).
    epochs : int, default=100
        Number of velocity/position updates. ``fun`` is called ``epochs + 1``
        times: once for the initial swarm, then once per epoch.
    c1, c2 : float, default=2.0
        Self-confidence (towards the particle's own best) and swarm-confidence
        (towards the global best) factors.
    inertia : float or (float, float), default=(0.9, 0.4)
        Inertia weight ``w``. A pair decreases linearly from the first value
        at the first epoch to the second at the last; a float is constant.
    velocity_clamp : float or array-like of shape (n_dims,), optional
        Largest absolute velocity per component (002 used 1.5). Default: the
        width of the box in each dimension, so no particle crosses the box in
        less than one step. Initial velocities are uniform in ``±clamp``.
    init : array-like of shape (n_dims,) or (n_init, n_dims), optional
        Starting positions for the first ``n_init <= n_particles`` particles
        (clipped into the box), e.g. a least-squares solution to start from;
        the other particles start uniformly in the box. The returned cost is
        then never worse than the best of these starting points.
    random_state : int, RandomState instance or None, default=None
        Seeds the initial swarm and the ``R1, R2`` draws: the same seed gives
        the same result.
    tol : float, optional
        Stop early when the best cost has improved by no more than
        ``tol * |best cost|`` over the last ``patience`` epochs. Default: run
        all epochs.
    patience : int, default=10
        Window, in epochs, of the ``tol`` test.

    Returns
    -------
    OptimizeResult
        With ``x`` (best position, shape (n_dims,)), ``fun`` (its cost),
        ``history`` (best cost after the initial evaluation and after each
        epoch, shape (nit + 1,), non-increasing), ``nit`` (epochs run), ``nfev``
        (particle evaluations, ``n_particles * (nit + 1)``), ``success`` and
        ``message``.

    Raises
    ------
    ValueError
        For malformed or infinite bounds, a ``fun`` that returns the wrong
        shape or ``-inf``, or when no evaluated position had a finite cost.

    Notes
    -----
    Positions that leave the box are put back on its wall and the velocity
    component that took them out is set to zero (an "absorbing" wall): the
    particle keeps searching along the wall, where bounded optima often lie,
    and is pulled back inside by its attractors at the next epoch. Particles
    are compared with ``<``, and the global best is the first particle of
    lowest cost, so ties resolve deterministically.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.optimize import particle_swarm
    >>> def sphere(P):
    ...     return np.sum((P - 1.0) ** 2, axis=1)
    >>> res = particle_swarm(sphere, [(-5, 5)] * 3, n_particles=30, epochs=100,
    ...                      random_state=0)
    >>> np.round(res.x, 3).tolist()
    [1.0, 1.0, 1.0]
    >>> len(res.history), res.nfev
    (101, 3030)
    """
    lo, hi = _as_bounds(bounds)
    d = lo.shape[0]
    n, epochs, patience = int(n_particles), int(epochs), int(patience)
    weights = _inertia_schedule(inertia, epochs)
    span = hi - lo
    if velocity_clamp is None:
        vmax = span.copy()
    else:
        vmax = np.asarray(velocity_clamp, dtype=float)
        if vmax.ndim > 1 or vmax.size not in (1, d):
            raise ValueError(
                f"velocity_clamp must be a number or hold one value per dimension "
                f"of the search ({d}), got {vmax.size} value(s)."
            )
        vmax = np.broadcast_to(vmax.ravel(), (d,)).copy()
        if not np.all(vmax > 0) or not np.all(np.isfinite(vmax)):
            raise ValueError(
                f"velocity_clamp must be positive and finite, got {velocity_clamp!r}."
            )

    rng = check_random_state(random_state)
    B = lo + rng.uniform(size=(n, d)) * span
    if init is not None:
        start = np.atleast_2d(np.asarray(init, dtype=float))
        if start.ndim != 2 or start.shape[1] != d or start.shape[0] > n:
            raise ValueError(
                f"init must have shape ({d},) or (n_init, {d}) with n_init <= "
                f"n_particles = {n}; got shape {np.shape(init)}."
            )
        if not np.all(np.isfinite(start)):
            raise ValueError("init positions must be finite.")
        B[: start.shape[0]] = np.clip(start, lo, hi)
    V = rng.uniform(-1.0, 1.0, size=(n, d)) * vmax

    cost = _evaluate(fun, B, n)
    pbest, pcost = B.copy(), cost.copy()
    g = int(np.argmin(pcost))
    history = [pcost[g]]
    nit = 0
    message = f"Maximum number of epochs ({epochs}) reached."
    for nit in range(1, epochs + 1):
        r1 = rng.uniform(size=(n, d))
        r2 = rng.uniform(size=(n, d))
        V *= weights[nit - 1]
        V += c1 * r1 * (pbest - B)
        V += c2 * r2 * (pbest[g] - B)
        np.clip(V, -vmax, vmax, out=V)
        B += V
        outside = (B < lo) | (B > hi)
        np.clip(B, lo, hi, out=B)
        V[outside] = 0.0
        cost = _evaluate(fun, B, n)
        better = cost < pcost
        pbest[better] = B[better]
        pcost[better] = cost[better]
        g = int(np.argmin(pcost))
        history.append(pcost[g])
        if tol is not None and nit >= patience:
            old, new = history[-patience - 1], history[-1]
            if np.isfinite(old) and old - new <= tol * abs(old):
                message = (
                    f"Best cost improved by no more than tol={tol} (relative) "
                    f"over {patience} epochs."
                )
                break
    if not np.isfinite(pcost[g]):
        raise ValueError(
            "Every position the swarm evaluated had a non-finite cost (NaN or inf); "
            "narrow the bounds or check the objective."
        )
    return OptimizeResult(
        x=pbest[g].copy(),
        fun=float(pcost[g]),
        history=np.asarray(history, dtype=float),
        nit=nit,
        nfev=n * (nit + 1),
        success=True,
        message=message,
    )
