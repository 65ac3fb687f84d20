"""Causal lag features for dynamic thermal-error compensation.

The thermal error of a machine tool lags its temperatures: the structure heats
and cools with its own time constants. A static regression on the current
temperatures cannot represent that lag; first-order low-pass filters of the
temperature changes (and of the spindle speed, the heat source) can.
"""

import warnings
from numbers import Real

import numpy as np
from scipy.signal import lfilter
from sklearn.base import BaseEstimator, TransformerMixin, _fit_context
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import (
    check_is_fitted,
    validate_data,
)

from skthermal.utils._runs import (
    GAP_BRIDGE,
    GAP_STEPS,
    PAUSE_BRIDGE,
    ForgetRunsMixin,
    changes_since_start,
    check_positive_numbers,
    continued_runs,
    continued_steps,
    continued_values,
    driver_positions,
    extend_memory,
    extract_runs,
    fitted_sample_periods,
    gap_periods,
    refuse_clock_values,
    row_times,
    run_feature_names_in,
    run_frame_index,
    run_memory,
    run_sample_periods,
    run_slices,
    run_times,
    warn_centred_drivers,
    warn_dt_against_times,
    warn_gaps,
    warn_misnamed_time,
    warn_no_time,
    warn_pauses,
    warn_slow_periods,
    warn_target_columns,
    warn_time_unit,
    warn_unlabelled_runs,
    warn_unnamed_drivers,
    within_run_steps,
)


def exponential_filter(
    U,
    time_constant,
    dt,
    slices=None,
    *,
    initial="steady",
    state=None,
    times=None,
    previous=None,
    periods=None,
):
    """First-order exponential (low-pass) filter, restarting at every run.

    ``z[k] = a z[k-1] + (1 - a) u[k]`` with ``a = exp(-dt / time_constant)``:
    the step-invariant discretisation of ``1 / (tau s + 1)``. Each run's filter
    starts either in steady state at the run's first value (``z[-1] = u[0]``,
    so a constant input gives a constant output) or at rest (``z[-1] = 0``).

    Parameters
    ----------
    U : array-like of shape (n_samples,) or (n_samples, n_features)
        Input signals, rows in time order.
    time_constant : float or array-like of shape (n_features,)
        Time constant in the unit of ``dt`` (seconds), > 0; one for all
        columns or one per column.
    dt : float or array-like of shape (n_runs,)
        Sampling period of every run (one value for all runs, or one per run).
    slices : list of slice, optional
        Runs as returned by :func:`skthermal.utils._runs.run_slices`
        (default: all rows are one run).
    initial : {"steady", "rest"}, default="steady"
        State before each run's first row: steady state at its first value,
        or zero.
    state : sequence, optional
        Per run, the filter output before its first row (``z[-1]``, shape
        ``(n_features,)``), e.g. the last output of the same run's earlier
        rows, to continue it; None (or non-finite values) starts that run as
        ``initial`` says. An array of shape (n_runs, n_features) works too.
    times : array-like of shape (n_samples,), optional
        Time of every row (seconds). Each row's step is then the time since
        the row before (``a`` varies from row to row), so uneven sampling is
        filtered exactly; a step longer than 1.5 times the run's median step
        is a gap (missing samples), across which the input is taken to
        change linearly (the filter's exact response to that ramp). ``dt``
        is then only the step before each run's first row (which matters
        for ``initial="rest"`` and for a ``state``: the time since the
        state's sample). Runs whose steps all equal ``dt`` are filtered
        as without ``times``.
    previous : sequence, optional
        Per run, the input row before its first row (``u[-1]``, with
        ``state``: the last input of the same run's earlier rows), or None.
        With ``times``, when the step before the run's first row (``dt``) is
        a gap the input is taken to change linearly from it over that step,
        as within a run, so a run continued after a pause is filtered as the
        whole run would be.
    periods : array-like of shape (n_runs,), optional
        With ``times``, every run's sampling period, against which a step is
        a gap (longer than 1.5 periods); default: the median step of the
        rows given (which a block of one or two rows cannot tell).

    Returns
    -------
    Z : ndarray of the same shape as ``U``

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.preprocessing import exponential_filter
    >>> z = exponential_filter(np.r_[0.0, 1.0, 1.0, 1.0], 1.0, 1.0)
    >>> np.round(z, 3).tolist()
    [0.0, 0.632, 0.865, 0.95]
    >>> z = exponential_filter(np.ones(3), 1.0, 1.0, initial="rest")
    >>> np.round(z, 3).tolist()
    [0.632, 0.865, 0.95]

    Uneven steps, and a gap over which the input ramps from 1 to 3:

    >>> z = exponential_filter(np.r_[0.0, 1.0, 1.0, 3.0], 1.0, 1.0,
    ...                        times=[0, 1, 1.5, 4.5])
    >>> np.round(z, 3).tolist()
    [0.0, 0.632, 0.777, 2.355]
    """
    U = np.asarray(U, dtype=float)
    if initial not in ("steady", "rest"):
        raise ValueError(f"initial must be 'steady' or 'rest', got {initial!r}.")
    if U.ndim == 0:
        raise ValueError("U must hold one row per sample, got a single number.")
    if U.shape[0] == 0:
        return U.copy()
    if not np.all(np.isfinite(U)):
        row = int(np.flatnonzero(~np.isfinite(U.reshape(U.shape[0], -1)).any(1))[0])
        raise ValueError(
            f"U holds a missing or infinite value at row {row}: the filter would "
            "carry it through the rest of the run. Impute or drop those rows "
            "first."
        )
    U2 = U.reshape(U.shape[0], -1)
    taus = np.asarray(time_constant, dtype=float)
    if taus.ndim > 1 or (taus.ndim == 1 and taus.size != U2.shape[1]):
        raise ValueError(
            f"time_constant must be a number or one per column of U, got shape "
            f"{taus.shape} for U of shape {U.shape}."
        )
    if not (np.all(np.isfinite(taus)) and np.all(taus > 0)):
        raise ValueError(
            f"time_constant must be finite and > 0, got {time_constant!r}."
        )
    if slices is None:
        slices = [slice(0, U.shape[0])]
    slices = list(slices)
    if not all(
        isinstance(sl, slice)
        and sl.step in (None, 1)
        and sl.start is not None
        and sl.stop is not None
        and 0 <= sl.start <= sl.stop <= U.shape[0]
        for sl in slices
    ):
        raise ValueError(
            f"slices must be slice(start, stop) objects within the {U.shape[0]} "
            "rows of U, as run_slices gives them."
        )
    covered = np.zeros(U.shape[0], dtype=int)
    for sl in slices:
        covered[sl] += 1
    if np.any(covered != 1):
        raise ValueError(
            f"slices must cover every row of U ({U.shape[0]}) exactly once, as "
            "run_slices gives them."
        )
    refuse_clock_values(dt, "dt")
    dts = np.asarray(dt, dtype=float)
    if dts.ndim > 1 or (dts.ndim == 1 and dts.size != len(slices)):
        raise ValueError(
            f"dt must be a number or one per run ({len(slices)}), got shape "
            f"{dts.shape}."
        )
    if not (np.all(np.isfinite(dts)) and np.all(dts > 0)):
        raise ValueError(f"dt must be finite and > 0, got {dt!r}.")
    dts = np.broadcast_to(dts, (len(slices),))
    if state is None:
        state = [None] * len(slices)
    if isinstance(state, np.ndarray) and state.ndim > 0:
        state = list(state)
    # Not np.ndim(state): a list mixing None (a run from its start) and
    # arrays (a continued run) is no array.
    if not isinstance(state, list | tuple):
        raise ValueError(
            f"state must be a list with one entry per run ({len(slices)}), each "
            f"None or one value per column of U, got {type(state).__name__}."
        )
    if len(state) != len(slices):
        raise ValueError(
            f"state must hold one entry per run ({len(slices)}), got {len(state)}."
        )
    if any(st is not None and np.size(st) != U2.shape[1] for st in state):
        raise ValueError(
            f"Every state must hold one value per column of U ({U2.shape[1]})."
        )
    state = [
        None if st is None else np.asarray(st, dtype=float).reshape(U2.shape[1])
        for st in state
    ]
    previous = [None] * len(slices) if previous is None else list(previous)
    if len(previous) != len(slices):
        raise ValueError(
            f"previous must hold one entry per run ({len(slices)}), got "
            f"{len(previous)}."
        )
    # One lfilter call per run and distinct time constant: the columns that
    # share it are filtered together along the time axis.
    uniq, which = np.unique(np.broadcast_to(taus, (U2.shape[1],)), return_inverse=True)
    if times is not None:
        refuse_clock_values(times, "times")
        times = np.asarray(times, dtype=float).ravel()
        if times.shape[0] != U2.shape[0]:
            raise ValueError(
                f"times must hold one time per row ({U2.shape[0]}), got "
                f"{times.shape[0]}."
            )
        if not np.all(np.isfinite(times)):
            raise ValueError("times must be finite (no NaN or infinite time).")
        steps, run, _, _ = within_run_steps(times, slices, medians=False)
        bad = np.flatnonzero(steps <= 0)
        if bad.size:
            sl = slices[run[bad[0]]]
            raise ValueError(
                "times must increase strictly within each run (slice "
                f"{sl.start}:{sl.stop})."
            )
    if periods is not None:
        periods = np.asarray(periods, dtype=float).ravel()
        if periods.size != len(slices) or np.any(periods <= 0):
            raise ValueError(
                f"periods must hold one sampling period > 0 per run "
                f"({len(slices)}), got {periods.tolist()}."
            )
    if _all_regular(dts, None if times is None else steps, periods, previous):
        return _regular_lowpass(
            U2, slices, dts[0], uniq, which, state, initial
        ).reshape(U.shape)
    Z = np.empty_like(U2)
    for r, (sl, step) in enumerate(zip(slices, dts, strict=True)):
        if sl.stop <= sl.start:
            continue
        # Steps before every row (None: all ``step``, one lfilter call) and
        # the gaps among them.
        steps = gap = None
        u_prev = None
        if times is not None:
            # A gap is a step longer than GAP_STEPS sampling periods: the
            # run's own period when given (a few rows of a longer run, even
            # one, are judged as in the whole run), else its median step.
            # The step from the row before the run (a continued run's last
            # training row) is a gap as a step within the run would be.
            _, steps, gap = run_steps(
                times[sl],
                None if periods is None else float(periods[r]),
                step=step,
                continued=previous[r] is not None,
            )
            if gap is not None and gap[0]:
                u_prev = np.asarray(previous[r], dtype=float).reshape(-1)
        for j, tau in enumerate(uniq):
            cols = np.flatnonzero(which == j)
            z0 = U2[sl.start, cols] if initial == "steady" else np.zeros(cols.size)
            if state[r] is not None and np.all(np.isfinite(state[r][cols])):
                z0 = state[r][cols]
            for piece in _column_chunks(np.arange(cols.size), sl.stop - sl.start):
                c = cols[piece]
                u = U2[sl, c] if c.size < U2.shape[1] else U2[sl]
                prev_u = None if u_prev is None else u_prev[c]
                Z[sl, c] = lowpass_steps(u, tau, step, steps, gap, z0[piece], prev_u)
    return Z.reshape(U.shape)


def run_steps(times, period=None, *, step=None, continued=False):
    """One run's time steps, worked out once for repeated filtering with
    :func:`lowpass_steps` (as :func:`exponential_filter` does for a run
    given ``times``).

    Parameters
    ----------
    times : ndarray of shape (n_samples,)
        Strictly increasing times of the run's rows (seconds).
    period : float, optional
        The run's sampling period, against which a step is a gap (longer
        than ``GAP_STEPS`` periods); default: the median step.
    step : float, optional
        The step before the first row; default: ``period``.
    continued : bool, default=False
        The run continues earlier rows: a ``step`` before its first row
        longer than ``GAP_STEPS`` periods is a gap too.

    Returns
    -------
    step : float
        The step before the first row.
    steps, gap : ndarray of shape (n_samples,) or None
        Every row's step and whether it is a gap; None when every step
        equals ``step`` and none is a gap (the filter is then one
        ``lfilter`` call).
    """
    d = np.diff(np.asarray(times, dtype=float))
    if period is None:
        period = float(np.median(d)) if d.size else np.inf
    if step is None:
        step = period if np.isfinite(period) else 1.0
    inner = d > GAP_STEPS * period
    first_gap = continued and bool(step > GAP_STEPS * period)
    if not (first_gap or inner.any() or np.any(np.abs(d - step) > 1e-9 * step)):
        return step, None, None
    return step, np.concatenate(([step], d)), np.concatenate(([first_gap], inner))


def _all_regular(dts, steps, periods, previous):
    """Whether every run is sampled at one common step (``steps``: the time
    steps within runs, None without times), without gaps, and none continues
    earlier rows: :func:`exponential_filter` then filters the runs of one
    length together (:func:`_regular_lowpass`) instead of one by one."""
    if any(p is not None for p in previous):
        return False
    step = float(dts[0])
    if np.any(dts != step):  # each run is filtered with its own step
        return False
    if periods is not None and np.any(step > GAP_STEPS * periods):
        return False
    if steps is None:
        return True
    return not np.any(np.abs(steps - step) > 1e-9 * step)


def _regular_lowpass(U, slices, step, taus, which, state, initial):
    """The filters of :func:`exponential_filter` for runs at one common step
    (:func:`_all_regular`): the runs of one length are filtered together,
    as the columns of one ``lfilter`` call per time constant, with the same
    arithmetic as one call per run. With many short runs, one call per run
    and time constant was the cost."""
    Z = np.empty_like(U)
    lengths = np.array([sl.stop - sl.start for sl in slices], dtype=int)
    for length in np.unique(lengths[lengths > 0]):
        runs = np.flatnonzero(lengths == length)
        starts = np.array([slices[r].start for r in runs], dtype=int)
        rows = starts[:, None] + np.arange(length)  # (n_runs, length)
        for j, tau in enumerate(taus):
            cols = np.flatnonzero(which == j)
            # A run's state is taken when finite in every column of the
            # time constant, else its initial rule.
            if initial == "steady":
                z0 = U[starts[:, None], cols]
            else:
                z0 = np.zeros((runs.size, cols.size))
            for i, r in enumerate(runs):
                if state[r] is not None and np.all(np.isfinite(state[r][cols])):
                    z0[i] = state[r][cols]
            a = float(np.exp(-step / tau))
            for piece in _column_chunks(np.arange(cols.size), rows.size):
                c = cols[piece]
                columns = U[rows.T[:, :, None], c].reshape(length, -1)
                out = lfilter(
                    [1.0 - a],
                    [1.0, -a],
                    columns,
                    axis=0,
                    zi=a * z0[:, piece].reshape(1, -1),
                )[0]
                Z[rows.T[:, :, None], c] = out.reshape(length, runs.size, -1)
    return Z


# The largest number of values :func:`exponential_filter` filters in one
# call (8 MB): more columns are filtered a piece at a time.
_CHUNK_ELEMENTS = 1 << 20


def _column_chunks(cols, n_rows):
    """``cols`` in pieces of at most :data:`_CHUNK_ELEMENTS` values over
    ``n_rows`` rows (at least one column each): the filters work column by
    column, so filtering a piece at a time changes no value, and the
    temporaries of a call stay a piece's size, not the input's."""
    width = max(1, _CHUNK_ELEMENTS // max(int(n_rows), 1))
    return [cols[i : i + width] for i in range(0, cols.size, width)]


def lowpass_steps(u, time_constant, step, steps=None, gap=None, z0=None, u_prev=None):
    """The first-order filter of one run's rows, without input checks (the
    kernel of :func:`exponential_filter`, for callers that filter the same
    checked run many times).

    Parameters
    ----------
    u : ndarray of shape (n_samples, n_features)
        Finite inputs, rows in time order.
    time_constant : float
        > 0, in the unit of the steps.
    step : float
        The step before every row when ``steps`` is None.
    steps, gap : ndarray of shape (n_samples,), optional
        Every row's step and whether it is a gap (the input then changes
        linearly over it), as :func:`run_steps` gives them.
    z0 : ndarray of shape (n_features,), optional
        The output before the first row; default: steady state at ``u[0]``.
    u_prev : ndarray of shape (n_features,), optional
        The input before the first row, for a gap before it.

    Returns
    -------
    ndarray of shape (n_samples, n_features)
    """
    if z0 is None:
        z0 = u[0]
    if steps is not None:
        return _varying_lowpass(u, steps / time_constant, z0, gap, u_prev)
    a = float(np.exp(-step / time_constant))
    zi = a * np.asarray(z0, dtype=float)[None, :]
    return lfilter([1.0 - a], [1.0, -a], u, axis=0, zi=zi)[0]


# Largest decay (step / time constant) of one step, and of one block of
# _varying_lowpass: exp(-40) is below the rounding of float64, and exp(80)
# is far from overflow.
_MAX_DECAY = 40.0


def _varying_lowpass(u, decay, z0, gap, u_prev=None):
    """``z[k] = a[k] z[k-1] + c[k]``, ``a = exp(-decay)``, ``z[-1] = z0``.

    On a sampled step ``c[k] = (1 - a[k]) u[k]`` (the input held over the
    step, as with a constant step); across a gap (``gap[k]``) the input
    changes linearly from ``u[k-1]`` to ``u[k]``, the exact response of the
    filter to that ramp: ``c = (1 - a) u[k-1] + (u[k] - u[k-1]) (1 - (1 - a)
    / decay)``; ``u_prev`` is ``u[-1]``, for a gap before the first row.
    Evaluated in closed form, with ``S`` the cumulated decay,
    ``z[k] = exp(-S[k]) (z0 + sum_j exp(S[j]) c[j])``, in blocks of at most
    ``_MAX_DECAY`` of decay so that the exponentials stay in range.
    """
    d = np.minimum(decay, _MAX_DECAY)
    gain = -np.expm1(-d)  # 1 - a
    c = gain[:, None] * u
    if gap.any():
        k = np.flatnonzero(gap)
        ramp = 1.0 - gain[k] / np.maximum(decay[k], 1e-300)
        before = u[k - 1]
        if k[0] == 0:
            before[0] = u[0] if u_prev is None else u_prev
        du = u[k] - before
        c[k] = gain[k, None] * before + ramp[:, None] * du
    S = np.cumsum(d)
    block = np.floor(S / _MAX_DECAY).astype(int)
    edges = np.flatnonzero(np.diff(block)) + 1
    starts = np.concatenate(([0], edges))
    stops = np.concatenate((edges, [u.shape[0]]))
    z = np.empty_like(u)
    prev = np.asarray(z0, dtype=float)
    for a, b in zip(starts, stops, strict=True):
        ref = S[a] - d[a]  # cumulated decay before the block's first row
        E = np.exp(S[a:b] - ref)[:, None]
        z[a:b] = (prev + np.cumsum(E * c[a:b], axis=0)) / E
        prev = z[b - 1]
    return z


def _distinct_labels(values):
    """``values`` printed short (``%g``), with more digits where that would
    print two different values alike (100000 and 100000.4)."""
    values = [float(v) for v in values]
    for digits in range(6, 18):
        labels = [f"{v:.{digits}g}" for v in values]
        if len(set(labels)) == len(set(values)):
            return labels
    return [repr(v) for v in values]


def runs_start_driven(X, slices, drivers):
    """Whether a run (``slices`` of the rows of ``X``) starts with a driver
    (the columns ``drivers``) on: where the drivers' initial state, steady
    or at rest, makes a difference."""
    return bool(np.any(X[[sl.start for sl in slices]][:, drivers] != 0))


class LagFeatures(ForgetRunsMixin, TransformerMixin, BaseEstimator):
    """Causal lag features: temperatures and their low-pass filters.

    For every run (restarting at each run start) the transformer returns the
    temperatures, as changes since the run start ``dT`` (``relative=True``) or
    as absolute readings ``T``, the same through first-order exponential
    filters with the given time constants (each starting in steady state),
    these filters applied to the drivers (e.g. spindle speed) as
    ``|u / driver_scale| ** p`` for every power ``p``, and, last, those
    driver terms unfiltered (an error that follows the speed at once, such
    as the centrifugal growth of a spindle). Columns in that order:
    temperatures, their filters, the drivers' filters, the drivers.

    Within one run both choices give the same model up to a constant (the
    filters are linear and start in steady state), so they differ only
    between runs: changes suit runs that each start from rest with the error
    measured from the run start; absolute readings suit runs that start warm
    or cut from a longer record.

    Run labels are taken from ``groups``, a ``run`` column or a ``run`` index
    level; with times (a ``time_s`` column or index level, as in a run table)
    the sampling period of each run is the median spacing of its times,
    otherwise ``dt``.

    *Runs across fit and transform.* A run label seen in ``fit`` continues
    that run: after a chronological split of a labelled table, transforming
    the later rows alone gives what transforming the whole run gives on
    them (changes since the run's first training row, filters continued
    from their last training outputs, kept in ``run_states_``). A labelled
    run that starts where its training rows started is transformed again
    from its start; one that starts inside the training span is an error.
    A run not seen in ``fit`` starts at its first row, with a warning if its
    ``time_s`` does not start at 0. The same rules as the grey regressors.

    Parameters
    ----------
    time_constants : sequence of float, default=(900.0, 3600.0, 14400.0)
        Filter time constants in seconds, finite, > 0 and distinct. May be
        empty.
    include_changes : bool, default=True
        Include the unfiltered temperatures (``dT`` or ``T``) and driver
        terms themselves.
    relative : bool, default=True
        Temperatures as changes since the run start (True) or as absolute
        readings (False).
    drivers : "auto", None or sequence of str or int, default="auto"
        Driver columns (names or positions), filtered but not differenced.
        ``"auto"`` uses the run table's drivers ``spindle_rpm`` and
        ``feed_mm_min`` when present. All other columns are temperatures,
        the run table's air temperature ``ambient_C`` included.
    driver_powers : sequence of float, default=(1.0, 1.5)
        Powers applied to the magnitude of the scaled drivers (a spindle
        turning either way, an axis travelling either way, heats alike):
        at least one, each finite, > 0 and distinct.
    driver_scale : float, default=1000.0
        Drivers are divided by this before the power.
    driver_initial : {"steady", "rest"}, default="steady"
        State of the driver filters before each run: steady state at the
        run's first value, or zero (the heat source off before the run).
    dt : float or None, default=None
        Seconds per row when ``X`` has no times (no ``time_s`` column or
        index level), or when no run has two rows (then an error if None).
        None: in ``fit``, one second per row, with a warning, since the time
        constants are in seconds; in ``transform``, the sampling period
        found in ``fit``.

    Attributes
    ----------
    sample_period_s_ : float
        Sampling period (s) in ``fit``: the median over the runs of two
        rows or more of the median spacing of their times (a run of one row
        is filtered with it), or ``dt`` (1 when None) without times.
        ``transform`` uses it for rows without times.
    n_features_in_ : int
    feature_names_in_ : ndarray of str
        Only when fitted on a DataFrame with string column names.
    driver_indices_ : ndarray of int
        Positions of the driver columns.
    n_temperature_features_ : int
        How many features come from the temperatures (the first ones; the
        drivers' terms follow them).
    runs_start_driven_ : bool
        Whether a training run starts with a driver on (a spindle turning);
        :meth:`transform` warns of runs that do when none did and
        ``driver_initial="steady"``.
    n_fitted_runs_ : int or None
        Labelled runs seen in ``fit`` (None when ``fit`` got no run labels);
        ``transform`` then warns when given rows without run labels.
    run_states_ : dict
        Per run label seen in ``fit``: what continuing that run needs (its
        length, first row, first and last ``time_s`` and the filters' last
        outputs). Empty when ``fit`` got no run labels.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.preprocessing import LagFeatures
    >>> X = np.c_[np.linspace(20, 25, 6), np.linspace(21, 22, 6)]
    >>> run = np.zeros(6)  # the rows are one run
    >>> LagFeatures(time_constants=[60.0], dt=30.0).fit_transform(X, groups=run).shape
    (6, 4)
    """

    _parameter_constraints = {
        "time_constants": ["array-like"],
        "include_changes": ["boolean"],
        "relative": ["boolean"],
        "drivers": [StrOptions({"auto"}), None, "array-like"],
        "driver_powers": ["array-like"],
        "driver_scale": [Interval(Real, 0, None, closed="neither")],
        "driver_initial": [StrOptions({"steady", "rest"})],
        "dt": [None, Interval(Real, 0, None, closed="neither")],
    }

    def __init__(
        self,
        time_constants=(900.0, 3600.0, 14400.0),
        *,
        include_changes=True,
        relative=True,
        drivers="auto",
        driver_powers=(1.0, 1.5),
        driver_scale=1000.0,
        driver_initial="steady",
        dt=None,
    ):
        self.time_constants = time_constants
        self.include_changes = include_changes
        self.relative = relative
        self.driver_initial = driver_initial
        self.drivers = drivers
        self.driver_powers = driver_powers
        self.driver_scale = driver_scale
        self.dt = dt

    def _taus(self):
        return check_positive_numbers(
            self.time_constants,
            "time_constants",
            type(self).__name__,
            distinct=True,
            why="in seconds; each a filter of its own",
        )

    def _powers(self):
        return check_positive_numbers(
            self.driver_powers,
            "driver_powers",
            type(self).__name__,
            empty=False,
            distinct=True,
            why="0 would make a constant feature and a negative power an "
            "infinite one for a driver at rest; drivers=None leaves the "
            "drivers out",
        )

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y=None, *, groups=None):
        """Check the input and find the driver columns.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
        y : ignored
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        self : LagFeatures
        """
        self._fit(X, groups, y)
        return self

    def _fit(self, X, groups, y=None):
        """:meth:`fit`; returns the training rows' features when it has
        computed them (to keep every labelled run's end state, else None),
        with ``X`` as :func:`extract_runs` returns it and the run labels."""
        taus, powers = self._taus(), self._powers()
        X_raw, groups = extract_runs(X, groups)
        warn_target_columns(X_raw, y)
        warn_time_unit(X_raw, groups)
        X_arr = validate_data(self, X_raw, dtype=np.float64)
        slices, labels = run_slices(groups, X_arr.shape[0])
        self.n_fitted_runs_ = None if groups is None else len(slices)
        name = type(self).__name__
        warn_unlabelled_runs(
            name, None, groups, X_arr.shape[0], X=X_raw, stacklevel=None
        )
        names = getattr(self, "feature_names_in_", None)
        warn_unnamed_drivers(name, self.drivers, names, groups)
        warn_no_time(type(self).__name__, X_raw, self.dt, taus)
        if self.dt is not None:
            warn_dt_against_times(
                name, X_raw, slices, labels, float(self.dt), overrides=False
            )
        # From the times (runs of one row take the others' period), else dt
        # (one second when None): not a period kept from an earlier fit.
        dts, self.sample_period_s_ = fitted_sample_periods(
            X_raw, groups, slices, self.dt, type(self).__name__
        )
        warn_gaps(type(self).__name__, X_raw, slices, labels, GAP_BRIDGE)
        self.driver_indices_ = driver_positions(
            self.drivers, getattr(self, "feature_names_in_", None), X_arr.shape[1]
        )
        warn_centred_drivers(name, X_arr, self.driver_indices_, names)
        self.runs_start_driven_ = runs_start_driven(X_arr, slices, self.driver_indices_)
        n_temp = X_arr.shape[1] - self.driver_indices_.size
        self.n_temperature_features_ = n_temp * (int(self.include_changes) + taus.size)
        n_out = self.n_temperature_features_
        n_out += (
            self.driver_indices_.size
            * powers.size
            * (taus.size + int(self.include_changes))
        )
        if n_out == 0:
            raise ValueError(
                "LagFeatures would produce no features: set include_changes=True "
                "or give time_constants (and drivers) to filter."
            )
        # What continuing each labelled run in transform needs: its first
        # row (the base of the changes) and times, and the filters' last
        # outputs.
        memory = run_memory(X_arr, slices, labels, X_raw)
        F = None
        if memory:
            F = self._compute(X_arr, slices, dts, times=row_times(X_raw))
            skip, end = self._state_columns(F.shape[1])
            for sl, lab in zip(slices, labels, strict=True):
                if lab in memory:
                    memory[lab]["state"] = F[sl.stop - 1, skip:end].copy()
        self.run_states_ = memory
        return F, X_raw, groups

    def _compute(
        self,
        X_arr,
        slices,
        dts,
        bases=None,
        states=None,
        times=None,
        lasts=None,
        periods=None,
    ):
        """The features. Per run, ``bases``: the first row of the training
        run it continues (None: its own first row); ``states``: the filters'
        outputs before it (None: a fresh start); ``lasts``: the last row of
        inputs before it (None: none); ``dts``: the step before its first
        row. ``times``: every row's time (missing samples and uneven steps
        are then filtered exactly), or None."""
        taus = self._taus()
        temp = np.setdiff1d(np.arange(X_arr.shape[1]), self.driver_indices_)
        n_runs = len(slices)
        bases = [None] * n_runs if bases is None else bases
        lasts = [None] * n_runs if lasts is None else lasts
        T = X_arr[:, temp]
        T_last = [None if x is None else x[temp] for x in lasts]
        if self.relative:
            own = [None if b is None else b[temp] for b in bases]
            T = changes_since_start(T, slices, own)
            # A continued run has the first row of its training run as base.
            T_last = [
                None if x is None or b is None else x - b
                for x, b in zip(T_last, own, strict=True)
            ]
        blocks = [T] if self.include_changes else []
        filtered = [(T, T_last, tau, "steady") for tau in taus]
        instant = []  # the drivers as they are: the last columns
        if self.driver_indices_.size:
            D = X_arr[:, self.driver_indices_] / self.driver_scale
            D_last = [
                None if x is None else x[self.driver_indices_] / self.driver_scale
                for x in lasts
            ]
            for p in self._powers():
                Dp = np.abs(D) ** p
                Dp_last = [None if x is None else np.abs(x) ** p for x in D_last]
                if self.include_changes:
                    instant.append(Dp)
                filtered += [(Dp, Dp_last, tau, self.driver_initial) for tau in taus]
        states = [None] * n_runs if states is None else states
        widths = [b.shape[1] for b in blocks + instant]
        widths += [U.shape[1] for U, _, _, _ in filtered]
        if not sum(widths):
            return np.hstack(blocks + instant)  # no features: numpy says so
        # Every block written into its place in one array (not stacked at
        # the end, which held every block twice at the peak).
        F = np.empty((X_arr.shape[0], sum(widths)))
        col = 0
        for block in blocks:
            F[:, col : col + block.shape[1]] = block
            col += block.shape[1]
        start = 0
        for U, U_last, tau, initial in filtered:
            width = U.shape[1]
            state = [None if st is None else st[start : start + width] for st in states]
            F[:, col : col + width] = exponential_filter(
                U,
                tau,
                dts,
                slices,
                initial=initial,
                state=state,
                times=times,
                previous=U_last,
                periods=periods,
            )
            start += width
            col += width
        for block in instant:
            F[:, col : col + block.shape[1]] = block
            col += block.shape[1]
        return F

    def transform(self, X, *, groups=None):
        """Compute the lag features, restarting at every run.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        F : ndarray or DataFrame of shape (n_samples, n_features_out)
            A DataFrame indexed by ``run`` (and ``time_s``) when ``X`` is a
            run table (a ``run`` or ``time_s`` column, or such index levels),
            as the selectors return: a sequence model after this step in a
            Pipeline then still sees where every run starts and each row's
            time. Otherwise an array (or what ``set_output`` asks for).
        """
        check_is_fitted(self, "driver_indices_")
        F, X_raw, groups, _ = self._continued(X, groups)
        index = run_frame_index(X, X_raw, groups)
        if index is None:
            return F
        import pandas as pd

        return pd.DataFrame(
            F, index=index, columns=self.get_feature_names_out(), copy=False
        )

    def _continued(self, X, groups):
        """The features of ``X``, continuing the runs this model remembers;
        with ``X`` and ``groups`` as :func:`extract_runs` returns them and
        what :meth:`remember_runs` needs: ``(X_arr, slices, labels, cont)``."""
        X_raw, groups = extract_runs(X, groups)
        X_arr = validate_data(self, X_raw, dtype=np.float64, reset=False)
        warn_unlabelled_runs(
            type(self).__name__,
            getattr(self, "n_fitted_runs_", None),
            groups,
            X_arr.shape[0],
        )
        slices, labels = run_slices(groups, X_arr.shape[0])
        # From the times (checked to increase), else the fitted period.
        dts = run_sample_periods(X_raw, groups, slices, self.sample_period_s_)
        # Level 5: the caller of transform, which scikit-learn's set_output
        # wraps.
        warn_gaps(type(self).__name__, X_raw, slices, labels, GAP_BRIDGE, 5)
        warn_slow_periods(
            type(self).__name__, X_raw, slices, labels, self.sample_period_s_, 5
        )
        if self.dt is None:
            warn_misnamed_time(type(self).__name__, X_raw, self.sample_period_s_, 5)
        memory = getattr(self, "run_states_", {})
        spans = run_times(X_raw, slices)
        cont = continued_runs(
            type(self).__name__,
            X_arr,
            slices,
            labels,
            spans,
            memory,
            # A step that a pipeline may call: the class alone, not a method.
            method=None,
            stacklevel=5,
        )
        warn_pauses(type(self).__name__, X_raw, slices, cont, memory, PAUSE_BRIDGE, 5)
        self._warn_driven_starts(X_arr, slices, labels, cont, spans)
        bases = continued_values(cont, memory, "x_first")
        states = continued_values(cont, memory, "state")
        lasts = continued_values(cont, memory, "x_last")
        times = row_times(X_raw)
        periods = gap_periods(dts, cont, self.sample_period_s_, memory)
        dts = continued_steps(dts, slices, times, cont, memory)
        F = self._compute(X_arr, slices, dts, bases, states, times, lasts, periods)
        return F, X_raw, groups, (X_arr, slices, labels, cont)

    def _warn_driven_starts(self, X_arr, slices, labels, cont, spans):
        """Warn of runs given from their start (``time_s`` 0) that start
        with a driver on when no training run did, and
        ``driver_initial="steady"`` takes them as driven for ever before
        their first row: a run that starts cold with the
        spindle turning then carries the heat of a steady state at once
        (46 µm off against 0.89 with ``"rest"`` in an independent check)."""
        if self.driver_initial != "steady" or getattr(self, "runs_start_driven_", True):
            return
        # A run given from its start (time_s 0): one cut from a longer
        # record (a later time_s) was driven before, as steady takes it.
        driven = [
            "unlabelled" if label is None else label
            for r, (sl, label, c) in enumerate(zip(slices, labels, cont, strict=True))
            if c is None
            and (spans is None or spans[r, 0] == 0)
            and np.any(X_arr[sl.start, self.driver_indices_] != 0)
        ]
        if not driven:
            return
        names = getattr(self, "feature_names_in_", None)
        drivers = [
            f"column {j}" if names is None else str(names[j])
            for j in self.driver_indices_
        ]
        more = f" and {len(driven) - 3} more" if len(driven) > 3 else ""
        warnings.warn(
            f"{type(self).__name__}: run(s) {driven[:3]}{more} start with "
            f"{' or '.join(drivers)} on, which no training run did: "
            "driver_initial='steady' takes them as driven for ever before "
            "their first row. A run that starts cold with the spindle "
            "turning is then predicted far off: give driver_initial='rest' "
            "when runs start cold, or train on runs that start so.",
            UserWarning,
            stacklevel=5,
        )

    def remember_runs(self, X, *, groups=None):
        """Remember where the runs of ``X`` end, so the next call continues them.

        For prediction on a stream (a controller that passes each new block
        of rows once): after transforming (or predicting) a block, call this
        with the same rows. The next block of a run, under its label and
        with later ``time_s``, then continues the filters from this block's
        last row, as if the whole run had been given at once, at a cost
        that does not grow with the run's length. A run not remembered
        (a new label) starts at its first row, as in :meth:`transform`.
        :class:`skthermal.compose.RunStream` does both calls.

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
            Rows of one or more runs, with their run labels (a ``run``
            column or index level, or ``groups``); rows without labels are
            not remembered.
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        self : LagFeatures
        """
        check_is_fitted(self, "driver_indices_")
        with warnings.catch_warnings():
            # Said by the transform or predict call of the same rows.
            warnings.simplefilter("ignore", UserWarning)
            F, X_raw, _, (X_arr, slices, labels, cont) = self._continued(X, groups)
        memory = self.run_states_
        skip, end = self._state_columns(F.shape[1])
        extend_memory(memory, X_arr, slices, labels, X_raw, cont)
        for sl, lab in zip(slices, labels, strict=True):
            if lab is not None:
                memory[lab]["state"] = F[sl.stop - 1, skip:end].copy()
        return self

    def _state_columns(self, n_columns):
        """Where the filters' outputs are among ``n_columns`` features: after
        the unfiltered temperatures, before the unfiltered drivers."""
        n_temp = self.n_features_in_ - self.driver_indices_.size
        skip = n_temp if self.include_changes else 0
        end = n_columns - (
            self.driver_indices_.size * self._powers().size
            if self.include_changes
            else 0
        )
        return skip, end

    def fit_transform(self, X, y=None, *, groups=None):
        """Fit, then transform the same rows (with the same run labels).

        Parameters
        ----------
        X : array-like or DataFrame of shape (n_samples, n_features)
        y : ignored
        groups : array-like of shape (n_samples,), optional
            Run label of every row.

        Returns
        -------
        F : ndarray or DataFrame of shape (n_samples, n_features_out)
            As :meth:`transform` returns.
        """
        F, X_raw, groups = self._fit(X, groups, y)
        if F is None:  # no labelled run: fit computed nothing
            return self.transform(X, groups=groups)
        # The training rows are every run from its start: the features fit
        # computed are what transform would compute again.
        index = run_frame_index(X, X_raw, groups)
        if index is None:
            return F
        import pandas as pd

        return pd.DataFrame(
            F, index=index, columns=self.get_feature_names_out(), copy=False
        )

    def get_feature_names_out(self, input_features=None):
        """Names of the output features.

        Parameters
        ----------
        input_features : array-like of str, optional

        Returns
        -------
        ndarray of str
        """
        check_is_fitted(self, "driver_indices_")
        # scikit-learn's rule: None gives the names seen in fit (or x0, x1,
        # ...); names given must match those, or their number.
        input_features = run_feature_names_in(self, input_features)
        temp = np.setdiff1d(np.arange(self.n_features_in_), self.driver_indices_)
        tnames = [str(c) for c in input_features[temp]]
        if self.relative:
            tnames = [f"d_{c}" for c in tnames]
        out = list(tnames) if self.include_changes else []
        taus = _distinct_labels(self._taus())
        powers = _distinct_labels(self._powers())
        for tau in taus:
            out += [f"{c}_lp{tau}" for c in tnames]
        for p in powers:
            for tau in taus:
                out += [
                    f"{input_features[i]}_pow{p}_lp{tau}" for i in self.driver_indices_
                ]
        if self.include_changes:
            for p in powers:
                out += [f"{input_features[i]}_pow{p}" for i in self.driver_indices_]
        return np.asarray(out, dtype=object)
