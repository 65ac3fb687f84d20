"""A stand-in for the air temperature of a record that did not measure it."""

from numbers import Real

import numpy as np
import pandas as pd
from scipy.signal import lfilter
from sklearn.utils._param_validation import Interval, validate_params

from skthermal._naming import plain
from skthermal.datasets._runtable import (
    RUN,
    _check_numeric,
    _report_nonfinite,
    sensor_columns,
)
from skthermal.utils._runs import check_unique_columns, run_slices


@validate_params(
    {
        "runs": [pd.DataFrame],
        "time_constant_s": [Interval(Real, 0, None, closed="neither")],
        "alpha": [Interval(Real, 0, None, closed="neither")],
        "return_scores": ["boolean"],
    },
    prefer_skip_nested_validation=True,
)
def ambient_proxy(runs, *, time_constant_s=7200.0, alpha=1.5, return_scores=False):
    """The temperature sensor that best stands in for the workshop air.

    Many spindle tests record temperatures on the machine but not the air
    around it, which a simulation needs as a driver. The sensor least
    coupled to the spindle follows the workshop, not the spindle: the one
    whose change since the start of its run correlates least with the
    spindle's losses ``(n/1000)^alpha``, low-passed with ``time_constant_s``
    (the slow warming of the structure), restarting at every run.

    Parameters
    ----------
    runs : DataFrame
        Run table with ``time_s``, ``spindle_rpm`` and temperature sensors
        ``T*_C`` (and ``run`` when it holds several runs).
    time_constant_s : float, default=7200.0
        Time constant of the low-pass of the spindle losses (s).
    alpha : float, default=1.5
        Exponent of the loss in speed (bearing friction: 1 to 1.7).
    return_scores : bool, default=False
        Also return every sensor's score.

    Returns
    -------
    name : str
        The sensor column.
    scores : Series
        Only with ``return_scores=True``: each temperature sensor's absolute
        correlation with the low-passed losses (lowest: the proxy).

    Raises
    ------
    ValueError
        Naming what is missing: no ``spindle_rpm`` or ``time_s`` column, no
        sensor, a missing or non-numeric reading (column and row named),
        ``time_s`` not strictly increasing within a run, or a spindle that
        never turns (nothing to correlate with).

    Examples
    --------
    >>> import numpy as np
    >>> import pandas as pd
    >>> from skthermal.datasets import ambient_proxy
    >>> t = np.arange(0, 8 * 3600, 60.0)
    >>> rpm = np.where(t % 7200 < 3600, 4000.0, 0.0)
    >>> warm = np.cumsum(rpm) / 4e5
    >>> runs = pd.DataFrame({"time_s": t, "spindle_rpm": rpm,
    ...                      "T1_C": 20 + warm,
    ...                      "T2_C": 20 + 0.3 * np.sin(t / 20000)})
    >>> ambient_proxy(runs)
    'T2_C'
    """
    scores = _proxy_scores(runs, time_constant_s, alpha)
    name = scores.idxmin()
    return (name, scores) if return_scores else name


def _proxy_scores(runs, time_constant_s, alpha):
    check_unique_columns(runs)
    for col in ("time_s", "spindle_rpm"):
        if col not in runs.columns:
            raise ValueError(
                f"ambient_proxy needs a {col!r} column; the run table has "
                f"{list(runs.columns)[:8]}."
            )
    sensors = sensor_columns(runs)
    temps = [c for c in sensors if c.endswith("_C")]
    if not temps:
        raise ValueError(
            "ambient_proxy needs temperature sensors (columns T*_C); the run "
            "table has none."
        )
    groups = runs[RUN].to_numpy() if RUN in runs.columns else None
    slices, _ = run_slices(groups, len(runs))
    columns = ["time_s", "spindle_rpm", *temps]
    try:
        _check_numeric(runs, columns)
        table = runs[columns].to_numpy(dtype=float, na_value=np.nan)
        # DATA_FORMAT: a missing reading is an error, not a sensor to skip.
        _report_nonfinite(
            runs,
            columns,
            ~np.isfinite(table),
            "missing or infinite",
            "; ambient_proxy needs every reading (drop or impute those rows)",
        )
    except ValueError as exc:
        raise ValueError(f"ambient_proxy: {exc}") from None
    t, rpm = table[:, 0], table[:, 1]
    for sl in slices:
        bad = np.flatnonzero(~(np.diff(t[sl]) > 0))
        if bad.size:
            i = sl.start + int(bad[0]) + 1
            where = "" if groups is None else f"in run {plain(groups[i])!r}, "
            raise ValueError(
                "ambient_proxy: time_s must be strictly increasing within a run: "
                f"{where}row {i} has time_s {t[i]:g} after time_s {t[i - 1]:g} "
                f"(row {i - 1}); sort the table, e.g. "
                "df.sort_values(['run', 'time_s'], kind='stable')."
            )
    if not np.any(rpm > 0):
        raise ValueError(
            "ambient_proxy: the spindle never turns (spindle_rpm is 0 "
            "throughout), so no sensor can be told apart from the air."
        )
    loss = (np.clip(rpm, 0.0, None) / 1000.0) ** alpha
    heating = np.empty_like(loss)
    change = np.empty((len(runs), len(temps)))
    values = table[:, 2:]
    for sl in slices:
        dt = float(np.median(np.diff(t[sl]))) if sl.stop - sl.start > 1 else 1.0
        a = np.exp(-dt / time_constant_s)
        heating[sl] = lfilter([1 - a], [1, -a], loss[sl])
        change[sl] = values[sl] - values[sl][0]
    h = heating - heating.mean()
    c = change - change.mean(axis=0)
    denom = np.sqrt((c**2).sum(axis=0) * (h**2).sum())
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.abs(h @ c) / denom
    # A sensor that never changes carries no information either way: last.
    corr = np.where(np.isfinite(corr), corr, np.inf)
    return pd.Series(corr, index=temps, name="abs_correlation")
