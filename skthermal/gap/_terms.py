"""Discrepancy terms: the effects of the vocabulary as corrections that can be
added to any simulation's output.

When the simulation is not a :class:`~skthermal.simulate.ThermalMachine` but
a run table from another tool, an unmodelled effect cannot be switched on
inside it. Each effect is then written as a *discrepancy term*: a signal
built from the simulated channels and the drivers (a first-order lag of the
simulated temperatures, a filtered |feed|, a post-stop response, ...) with a
few nonlinear parameters (time constants, searched in bounded ranges) and one
linear gain per channel (least squares). Every model also has the *base*: a
gain per channel on the simulated channel itself, so that a scale error of
the simulation is not mistaken for a missing effect (offsets are removed by
comparing changes since the start of each run).

All signals are computed at the run's own sample rate and then compared at
the run's ``rows`` as changes since the start (the mean of the first
``START_SAMPLES`` compared samples), like the measurements.
"""

import itertools
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar

from skthermal.gap._evidence import ridge_heldout
from skthermal.gap._problem import START_SAMPLES
from skthermal.preprocessing._lags import lowpass_steps, run_steps


@dataclass
class RunSignals:
    """One run of the two tables, aligned.

    Attributes
    ----------
    name : label
    time_s, spindle_rpm, ambient_C, feed_mm_min : ndarray of shape (n,)
        Drivers at the full sample rate (time from 0).
    sim : ndarray of shape (n, c)
        Simulated channels (absolute values).
    rows : ndarray of int
        Samples compared.
    y : ndarray of shape (len(rows), c)
        Measured channels at ``rows``, change since start.
    origin : object, optional
        For a block of a longer run (``block_hours``): a key shared by the
        blocks of that run, whose signals are all its first rows up to the
        block's end, so a term's signals of the longest block hold every
        other block's. None: a run of its own.
    period : float, optional
        The sampling period against which a step is a gap (the whole run's
        for a block); default: the median step.
    driver_initial : {"rest", "steady"}, default="rest"
        The drivers' heat before the run's first row, for the filters of
        the drivers (:meth:`driver_lowpass`): none (the run starts soaked,
        as a simulation started from rest assumes) or what the first row's
        drivers give in steady state.
    """

    name: object
    time_s: np.ndarray
    spindle_rpm: np.ndarray
    ambient_C: np.ndarray
    feed_mm_min: np.ndarray
    sim: np.ndarray
    rows: np.ndarray
    y: np.ndarray
    origin: object = None
    period: float = None
    driver_initial: str = "rest"

    def __post_init__(self):
        # The run's steps (sampling period, uneven steps and gaps), worked
        # out once: the terms filter each run many times.
        self.plan = run_steps(self.time_s, self.period)

    def driver_lowpass(self, x, tau):
        """:func:`lowpass` of a signal of the drivers (a heat input: |feed|,
        the speed), started as ``driver_initial`` says. A filter started in
        steady state at the first row reads a run that starts cutting as one
        that has been cutting for ever: its change since the start would
        fall while the heat builds up."""
        return lowpass(x, tau, self, rest=self.driver_initial == "rest")

    def compared(self, X):
        """``X`` (full rate, ``(n, ...)``) at ``rows``, change since start."""
        x = np.asarray(X, dtype=float)[self.rows]
        return x - x[:START_SAMPLES].mean(axis=0)


@dataclass
class Signals:
    """All runs, which channels are temperatures, and the channel weights
    (``sqrt(weight) / scale``) with which squared errors are summed;
    ``channels``: their names (for messages), when known."""

    runs: list
    is_temp: np.ndarray
    w: np.ndarray
    channels: tuple = ()

    @property
    def n_channels(self):
        return self.is_temp.size


def lowpass(x, tau, run, rest=False):
    """First-order low-pass of ``x`` (time along axis 0, at ``run``'s
    samples), started in steady state at the first row, or from zero with
    ``rest=True``. Each step is filtered with its own length
    (``run.time_s``), so uneven sampling and logging gaps (rows left out)
    are filtered exactly. ``tau`` 0 returns ``x``."""
    x = np.asarray(x, dtype=float)
    if tau <= 0:
        return x
    u = x.reshape(x.shape[0], -1)
    z0 = np.zeros(u.shape[1]) if rest else None
    z = lowpass_steps(u, float(tau), *run.plan, z0=z0)
    return z.reshape(x.shape)


def _run_stats(design, y):
    """One run's least-squares statistics per channel: the Gram matrix of
    its design ``(n, c, k)`` (shape ``(c, k, k)``), the design's products
    with the targets ``y`` ``(n, c)`` (``(c, k)``) and the targets' sums of
    squares (``(c,)``)."""
    D = np.ascontiguousarray(design.transpose(1, 2, 0))  # (c, k, n)
    G = D @ D.transpose(0, 2, 1)
    b = (D @ y.T[:, :, None])[..., 0]
    return G, b, np.einsum("nc,nc->c", y, y)


def _solve_gains(G, b, sign=None):
    """Per-channel least-squares gains from the summed Gram matrices ``G``
    ``(c, k, k)`` and products ``b`` ``(c, k)`` of the runs fitted; a tiny
    ridge keeps channels on which a feature is zero well posed. Returns
    (c, k).

    ``sign`` (shape (c,), entries -1, 0 or +1) constrains the sign of the
    last feature's gain per channel: where the unconstrained gain has the
    wrong sign, the constrained optimum of this convex problem has that gain
    at zero, so those channels are solved again without the feature."""
    diag = np.einsum("ckk->ck", G)
    k = G.shape[-1]
    A = G + (1e-8 * diag + 1e-12)[:, :, None] * np.eye(k)
    gains = np.linalg.solve(A, b[..., None])[..., 0]
    if sign is not None and k > 1:
        wrong = sign * gains[:, -1] < 0
        if wrong.any():
            gains[wrong, -1] = 0.0
            gains[wrong, :-1] = np.linalg.solve(
                A[wrong][:, :-1, :-1], b[wrong][:, :-1, None]
            )[..., 0]
    return gains


def _predict(design, gains):
    return np.einsum("nck,ck->nc", design, gains)


class DiscrepancyTerm:
    """A correction added to the simulation (the base: none).

    Subclasses set ``name``, ``bounds`` (nonlinear parameters and their
    search ranges, searched on a log grid and refined), ``channels``
    (``"all"``, ``"temperature"`` or ``"displacement"``) and implement
    ``_signal(run, theta)`` returning the term's signals at the full rate,
    shape ``(n, c, k)`` or ``(n, k)`` (shared by all channels).

    Attributes (after ``fit``)
    --------------------------
    theta_ : dict
        Fitted nonlinear parameters.
    gains_ : ndarray of shape (n_channels, n_features)
        Gains of the base and of every term of the model, per channel.
    """

    name = "base"
    bounds = {}
    # Ends of ``bounds`` that physics reaches ("lower" or "upper" per
    # parameter): a fit there may be the term's own value. A fit on any
    # other end was stopped by the range, not by the runs, and the term is
    # then not named (it stands in for something else).
    open_ends = {}
    channels = "all"
    n_signals = 0
    grid = 9
    # The sign physics gives the term's gain on temperature sensors (+1: the
    # effect can only warm them, -1: only cool them, 0: either).
    temperature_sign = 0

    def __init__(self, with_terms=()):
        self.with_terms = tuple(with_terms)

    # --- signals ---------------------------------------------------------------

    def _signal(self, run, theta):
        return np.zeros((run.time_s.size, 0))

    def _mask(self, signals):
        if self.channels == "temperature":
            return signals.is_temp
        if self.channels == "displacement":
            return ~signals.is_temp
        return np.ones(signals.n_channels, dtype=bool)

    def _full(self, signals, run, theta):
        """The term's signals at the full rate, ``(n, c, k)``."""
        s = self._signal(run, theta)
        c = signals.n_channels
        if s.ndim == 2:
            s = np.broadcast_to(s[:, None, :], (s.shape[0], c, s.shape[1]))
        return s

    def features(self, signals, run, theta, full=None):
        """The term's features at the compared rows, ``(n_rows, c, k)``,
        zero on channels the term does not act on. ``full``: the term's
        signals at the full rate (:meth:`_full`) of ``run`` or of a longer
        block of the same run, when already at hand."""
        if full is None:
            full = self._full(signals, run, theta)
        return run.compared(full) * self._mask(signals)[None, :, None]

    def _signs(self, signals):
        """Sign constraint of the term's gain per channel (None: free)."""
        if not self.n_signals or not self.temperature_sign:
            return None
        return np.where(signals.is_temp, float(self.temperature_sign), 0.0)

    def n_params(self, signals):
        """Free parameters the term adds to the base: its nonlinear
        parameters and one gain per signal and channel it acts on."""
        return len(self.bounds) + self.n_signals * int(self._mask(signals).sum())

    def inert(self, signals):
        """Why the term cannot change any compared channel of ``signals``
        (None when it can).

        It cannot when it acts on no compared channel (a temperature term
        with only displacements compared), or when its signal is zero on
        every run at the bounds and the middle of every parameter's range
        (a feed term on runs without feed, a lag of a constant simulation).

        Returns
        -------
        str or None
        """
        if not self.n_signals:
            return None
        if not self._mask(signals).any():
            return f"it acts on {self.channels} channels and none is compared"
        axes = [
            (lo, float(np.sqrt(lo * hi)) if lo > 0 else 0.5 * (lo + hi), hi)
            for lo, hi in self.bounds.values()
        ]
        for combo in itertools.product(*axes):
            theta = dict(zip(self.bounds, combo, strict=True))
            if not self._valid(theta):
                continue
            for run in signals.runs:
                x = self.features(signals, run, theta)
                tol = 1e-9 * max(1.0, float(np.max(np.abs(run.sim), initial=0.0)))
                if np.max(np.abs(x), initial=0.0) > tol:
                    return None
        return "its signal is zero on every run, nothing in the runs drives it"

    # --- fit and apply ---------------------------------------------------------

    def features_of(self, signals, idx, theta):
        """``{i: features of run i}`` (:meth:`features`) for the runs
        ``idx``. The blocks of one run (the same ``origin``) share the
        signals of the longest of them: they are all first rows of that run,
        and the signals are causal."""
        longest = {}
        for i in idx:
            origin = signals.runs[i].origin
            if origin is not None:
                size = signals.runs[i].time_s.size
                if size > longest.get(origin, (-1, 0))[1]:
                    longest[origin] = (i, size)
        full = {
            origin: self._full(signals, signals.runs[i], theta)
            for origin, (i, _) in longest.items()
        }
        return {
            i: self.features(
                signals, signals.runs[i], theta, full.get(signals.runs[i].origin)
            )
            for i in idx
        }

    def _fixed(self, signals, idx):
        """``{i: the base and the earlier terms' features of run i}`` for
        the runs ``idx``."""
        earlier = [
            term.features_of(signals, idx, term.theta_) for term in self.with_terms
        ]
        out = {}
        for i in idx:
            run = signals.runs[i]
            parts = [run.compared(run.sim)[:, :, None], *(f[i] for f in earlier)]
            out[i] = np.concatenate(parts, axis=2)
        return out

    def _designs(self, signals, idx, theta, fixed=None):
        """``{i: design of run i}``: the fixed features (``fixed``, else
        worked out) and the term's own at ``theta``."""
        fixed = self._fixed(signals, idx) if fixed is None else fixed
        if not self.n_signals:
            return {i: fixed[i] for i in idx}
        own = self.features_of(signals, idx, theta)
        return {i: np.concatenate([fixed[i], own[i]], axis=2) for i in idx}

    def _cost(self, signals, idx, theta, fixed=None, cache=None):
        """Weighted sum of squared errors on runs ``idx`` and the gains,
        from the runs' least-squares statistics (:func:`_run_stats`), taken
        from ``cache`` where it holds them (the folds of a screening search
        the same grid on overlapping runs)."""
        key = None
        if cache is not None:
            earlier = tuple((t.name, *t.theta_.values()) for t in self.with_terms)
            key = (self.name, earlier, *theta.values())
        stats = {} if key is None else {i: cache.get((i, *key)) for i in idx}
        missing = [i for i in idx if stats.get(i) is None]
        if missing:
            designs = self._designs(signals, missing, theta, fixed)
            for i in missing:
                stats[i] = _run_stats(designs[i], signals.runs[i].y)
                if key is not None:
                    cache[(i, *key)] = stats[i]
        stats = [stats[i] for i in idx]
        G = sum(st[0] for st in stats)
        b = sum(st[1] for st in stats)
        yy = sum(st[2] for st in stats)
        gains = _solve_gains(G, b, self._signs(signals))
        sse = (
            yy
            - 2.0 * np.einsum("ck,ck->c", gains, b)
            + np.einsum("ck,ckl,cl->c", gains, G, gains)
        )
        return float(np.sum(np.maximum(sse, 0.0) * signals.w**2)), gains

    def fit(self, signals, idx, cache=None):
        """Search the nonlinear parameters and solve the gains on runs
        ``idx`` (the terms in ``with_terms`` keep their fitted parameters).

        ``cache`` (a dict) keeps every run's least-squares statistics at the
        grid's points, for the fits of the same term on other folds of the
        same runs; it holds one term's entries at a time best (memory)."""
        idx = list(idx)
        names = list(self.bounds)
        fixed = self._fixed(signals, idx)
        if not names:
            self.theta_ = {}
            self.cost_, self.gains_ = self._cost(signals, idx, {}, fixed)
            return self
        axes = [
            np.geomspace(*self.bounds[n], self.grid)
            if self.bounds[n][0] > 0
            else np.linspace(*self.bounds[n], self.grid)
            for n in names
        ]
        best = None
        for combo in itertools.product(*axes):
            theta = dict(zip(names, combo, strict=True))
            if not self._valid(theta):
                continue
            cost, _ = self._cost(signals, idx, theta, fixed, cache)
            if best is None or cost < best[0]:
                best = (cost, theta)
        cost, theta = best
        # Refine every parameter between its grid neighbours, one at a time
        # (log scale for time constants), the others held.
        for _ in range(min(len(names), 2)):
            for name, ax in zip(names, axes, strict=True):
                log = self.bounds[name][0] > 0
                grid = np.log(ax) if log else ax
                x0 = np.log(theta[name]) if log else theta[name]
                k = int(np.argmin(np.abs(grid - x0)))
                lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
                if not hi > lo:
                    continue

                def f(x, name=name, log=log):
                    trial = dict(theta, **{name: float(np.exp(x) if log else x)})
                    if not self._valid(trial):
                        return 2.0 * cost + 1.0  # outside: worse than any
                    return self._cost(signals, idx, trial, fixed)[0]

                res = minimize_scalar(
                    f, bounds=(lo, hi), method="bounded", options={"xatol": 0.02}
                )
                if res.fun < cost:
                    cost = float(res.fun)
                    theta = dict(
                        theta, **{name: float(np.exp(res.x) if log else res.x)}
                    )
        self.theta_ = {k: float(v) for k, v in theta.items()}
        self.cost_, self.gains_ = self._cost(signals, idx, self.theta_, fixed)
        return self

    def _valid(self, theta):
        return True

    def apply(self, signals, idx):
        """Predictions (change since start, ``(n_rows, c)``) of runs ``idx``."""
        designs = self._designs(signals, idx, self.theta_)
        return [_predict(designs[i], self.gains_) for i in idx]

    def __repr__(self):
        theta = getattr(self, "theta_", None)
        inner = "" if not theta else ", ".join(f"{k}={v:.3g}" for k, v in theta.items())
        return f"{type(self).__name__}({inner})"


class Base(DiscrepancyTerm):
    """The base: one gain per channel on the simulated channel.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.gap._terms import Base, RunSignals, Signals
    >>> t = np.arange(0, 7200, 60.0)
    >>> sim = (1 - np.exp(-t / 1800))[:, None]
    >>> run = RunSignals("a", t, np.full(t.size, 3000.0), np.full(t.size, 20.0),
    ...                  np.zeros(t.size), sim, np.arange(t.size),
    ...                  2 * (sim - sim[:5].mean(axis=0)))
    >>> base = Base().fit(Signals([run], np.array([True]), np.ones(1)), [0])
    >>> round(float(base.gains_[0, 0]), 3)
    2.0
    """


class SensorLag(DiscrepancyTerm):
    """``sensor_lag``: temperature sensors read a first-order lag of the
    simulated temperature, ``T + g (lag(T, tau) - T)`` per sensor (``g`` 1 for
    a fully lagged sensor, 0 for one without lag)."""

    name = "sensor_lag"
    bounds = {"tau_s": (30.0, 7200.0)}
    channels = "temperature"
    n_signals = 1
    temperature_sign = 1  # a sensor can lag, not lead

    def _full(self, signals, run, theta):
        lagged = lowpass(run.sim, theta["tau_s"], run)
        return (lagged - run.sim)[:, :, None]


class SpeedConvection(DiscrepancyTerm):
    """``speed_convection``: convection grows with spindle speed, so every
    channel loses a share of its simulated rise that grows with speed:
    ``g lag((n / 1000 rpm)^e * rise, tau)``, rise the simulated change since
    the run's start.

    The convection changes on the spindle head's large masses, so ``tau`` is
    a structure's time constant, 20 min to 8 h. :class:`ToolGrowth` has the
    same form with a tool's time constant (up to 20 min): the ranges do not
    overlap, so neither term can stand in for the other, and a term acting
    on every channel cannot win the tool's signature through the base
    mismatch it also absorbs on the temperature sensors.
    """

    name = "speed_convection"
    bounds = {"tau_s": (1200.0, 28800.0), "exponent": (0.5, 1.5)}
    open_ends = {"exponent": "lower"}  # laminar convection: h ~ v^0.5
    channels = "all"
    n_signals = 1
    temperature_sign = -1  # more convection only cools
    grid = 7

    def _full(self, signals, run, theta):
        speed = (run.spindle_rpm / 1000.0) ** theta["exponent"]
        rise = run.sim - run.sim[:1]
        return lowpass(speed[:, None] * rise, theta["tau_s"], run)[:, :, None]


class ToolGrowth(DiscrepancyTerm):
    """``tool_growth``: the turning tool is cooled by the air it churns and
    grows back after every stop. Only the displacements see it (the tool
    carries no sensor): ``g lag((n / 1000 rpm)^e * rise, tau)`` with a short
    time constant (a tool's: a test bar or tool of a few kilograms on the
    spindle nose, 1 to 20 min), rise the simulated displacement change since
    the start; after each stop the term relaxes exponentially with ``tau``.
    """

    name = "tool_growth"
    bounds = {"tau_s": (60.0, 1200.0), "exponent": (0.5, 1.0)}
    open_ends = {"exponent": "lower"}  # laminar convection: h ~ v^0.5
    channels = "displacement"
    n_signals = 1
    grid = 7

    def _full(self, signals, run, theta):
        speed = (np.clip(run.spindle_rpm, 0.0, None) / 1000.0) ** theta["exponent"]
        rise = run.sim - run.sim[:1]
        return lowpass(speed[:, None] * rise, theta["tau_s"], run)[:, :, None]


class AmbientTransient(DiscrepancyTerm):
    """``ambient_transient``: exposed surfaces follow the air faster than the
    simulation lets them: a band-pass of the air temperature,
    ``g (lag(T_air, tau_fast) - lag(T_air, tau_slow))``."""

    name = "ambient_transient"
    bounds = {"tau_fast_s": (60.0, 14400.0), "tau_slow_s": (600.0, 28800.0)}
    channels = "all"
    n_signals = 1
    temperature_sign = 1  # surfaces follow the air more closely, not less
    grid = 6

    def _valid(self, theta):
        return theta["tau_slow_s"] > 1.5 * theta["tau_fast_s"]

    def _signal(self, run, theta):
        a = run.ambient_C
        x = lowpass(a, theta["tau_fast_s"], run) - lowpass(a, theta["tau_slow_s"], run)
        return x[:, None]


class FeedHeating(DiscrepancyTerm):
    """``feed_heating``: friction heat of the feed axis, ``g lag(|feed| /
    1000 mm/min, tau)``."""

    name = "feed_heating"
    bounds = {"tau_s": (60.0, 14400.0)}
    channels = "all"
    n_signals = 1
    temperature_sign = 1  # friction heat only warms

    def _signal(self, run, theta):
        return run.driver_lowpass(np.abs(run.feed_mm_min) / 1000.0, theta["tau_s"])[
            :, None
        ]


class SensorDrift(DiscrepancyTerm):
    """``sensor_drift``: every temperature sensor drifts linearly at its own
    rate (°C per hour since the run's start)."""

    name = "sensor_drift"
    bounds = {}
    channels = "temperature"
    n_signals = 1

    def _signal(self, run, theta):
        return (run.time_s / 3600.0)[:, None]


TERMS = {
    cls.name: cls
    for cls in (
        SensorLag,
        SpeedConvection,
        ToolGrowth,
        AmbientTransient,
        FeedHeating,
        SensorDrift,
    )
}


@dataclass
class FlexibleFeatures:
    """Lag features of the drivers (and of every simulated channel) for the
    flexible discrepancy model that bounds what any added term could
    explain."""

    time_constants_s: tuple = (300.0, 1200.0, 4800.0, 14400.0)
    extra: list = field(default_factory=list)

    def features(self, signals, run):
        """``(n_rows, c, k)``: the simulated channel, and low-passes of the
        speed, the spindle state, |feed|, the air change, the speed times
        the simulated rise and of the simulated channel, and the time."""
        speed = run.spindle_rpm / 1000.0
        shared = np.column_stack(
            [
                speed,
                (run.spindle_rpm > 0).astype(float),
                np.abs(run.feed_mm_min) / 1000.0,
                run.ambient_C - run.ambient_C[0],
            ]
        )
        rise = run.sim - run.sim[:1]
        parts = [run.compared(run.sim)[:, :, None]]
        c = signals.n_channels
        for tau in self.time_constants_s:
            z = run.compared(run.driver_lowpass(shared, tau))
            parts.append(np.broadcast_to(z[:, None, :], (z.shape[0], c, z.shape[1])))
            # The channel's own lag (as a difference, so that a small lag is
            # a small coefficient) and its speed-weighted rise.
            lag = lowpass(run.sim, tau, run) - run.sim
            parts.append(run.compared(lag)[:, :, None])
            parts.append(
                run.compared(lowpass(speed[:, None] * rise, tau, run))[..., None]
            )
        clock = run.compared(run.time_s / 3600.0)
        parts.append(np.broadcast_to(clock[:, None, None], (clock.size, c, 1)))
        return np.concatenate(parts, axis=2)


def flexible_heldout(fold_signals, folds, extra=None):
    """Held-out residuals (prediction minus measurement, weighted) of the
    flexible discrepancy model: what any added term could explain.

    Per fold and channel, a ridge regression (penalty chosen by
    leave-one-run-out on the training runs, :func:`ridge_heldout`) of the
    measurement on the simulated channel (not penalised) and the
    :class:`FlexibleFeatures` of the drivers and of that channel, plus any
    ``extra`` features, fitted on the fold's training runs and applied to
    its held-out runs.

    Parameters
    ----------
    fold_signals : list of Signals
        One per fold: the simulation the flexible model corrects in that
        fold (the same object for every fold when the simulation is fixed,
        e.g. an external run table; the base calibrated on the fold's
        training runs for a simulator).
    folds : list of (train, test)
        Run indices.
    extra : list of list of list of ndarray, optional
        ``extra[k][i]``: further features ``(n_rows, c, m)`` of run ``i`` in
        fold ``k`` (e.g. the candidates' signals fitted on that fold).

    Returns
    -------
    list of ndarray of shape (n_rows, c)
        One per run, from the fold that holds it out.
    """
    flex = FlexibleFeatures()
    generic = {}
    out = [None] * len(fold_signals[0].runs)
    for k, (train, test) in enumerate(folds):
        signals = fold_signals[k]
        if id(signals) not in generic:
            generic[id(signals)] = [flex.features(signals, r) for r in signals.runs]
        w = signals.w[None, :, None]
        targets = [r.y * signals.w for r in signals.runs]
        feats = []
        for i, base in enumerate(generic[id(signals)]):
            parts = [base, *(() if extra is None else extra[k][i])]
            feats.append(np.concatenate(parts, axis=2) * w)
        pen = np.ones(feats[0].shape[2], dtype=bool)
        pen[0] = False  # the simulated channel's gain is not penalised
        R = ridge_heldout(targets, feats, [(train, test)], penalize=pen)
        for i in test:
            out[i] = -R[i]
    return out
