"""Regime segments of a run, derived from its drivers.

A gap that appears only after the spindle stops, or only while the air
changes, points at different physics than one present throughout. Every sample
gets a primary regime (heating, after stop, dwell) and the secondary labels
that apply to it (speed level, ambient event, feed motion).
"""

import numpy as np
import pandas as pd


def label_regimes(
    time_s,
    spindle_rpm,
    ambient_C=None,
    feed_mm_min=None,
    *,
    after_stop_min=60.0,
    ambient_event_C=1.0,
    ambient_window_min=120.0,
):
    """Regime labels of every sample of one run.

    Parameters
    ----------
    time_s, spindle_rpm : array-like of shape (n,)
    ambient_C, feed_mm_min : array-like of shape (n,), optional
    after_stop_min : float, default=60.0
        How long after the spindle stops the machine counts as "after stop"
        (cooling, tool growth); later still samples are "dwell".
    ambient_event_C : float, default=1.0
        The air deviating from its running median by more than this marks an
        "ambient event" (an opened door, a draught).
    ambient_window_min : float, default=120.0
        Window of that running median.

    Returns
    -------
    DataFrame
        Columns ``regime`` ("heating", "after stop", "dwell"), ``speed``
        ("0 rpm", "4000 rpm", ...), ``ambient_event`` (bool) and
        ``feed_motion`` (bool).

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.gap import label_regimes
    >>> t = np.arange(0, 4 * 3600, 600.0)
    >>> rpm = np.where(t < 3600, 4000.0, 0.0)
    >>> label_regimes(t, rpm)["regime"].value_counts().to_dict()
    {'dwell': 11, 'after stop': 7, 'heating': 6}
    """
    t = np.asarray(time_s, dtype=float)
    rpm = np.asarray(spindle_rpm, dtype=float)
    on = rpm > 0
    # Time of the most recent stop (on -> off transition) for every sample.
    stops = np.flatnonzero(on[:-1] & ~on[1:]) + 1
    last_stop = np.full(t.shape, -np.inf)
    if stops.size:
        idx = np.searchsorted(stops, np.arange(t.size), side="right") - 1
        valid = idx >= 0
        last_stop[valid] = t[stops[idx[valid]]]
    since_stop = (t - last_stop) / 60.0
    regime = np.where(
        on, "heating", np.where(since_stop <= after_stop_min, "after stop", "dwell")
    )
    speed = pd.Series(np.round(rpm).astype(int)).astype(str) + " rpm"
    event = np.zeros(t.shape, dtype=bool)
    if ambient_C is not None:
        air = pd.Series(np.asarray(ambient_C, dtype=float))
        dt = float(np.median(np.diff(t))) if t.size > 1 else 60.0
        window = max(3, int(round(ambient_window_min * 60.0 / dt)) | 1)
        baseline = air.rolling(window, center=True, min_periods=1).median()
        event = (air - baseline).abs().to_numpy() > ambient_event_C
    feed = (
        np.zeros(t.shape, dtype=bool)
        if feed_mm_min is None
        else np.abs(np.asarray(feed_mm_min, dtype=float)) > 0
    )
    return pd.DataFrame(
        {
            "regime": regime,
            "speed": speed.to_numpy(),
            "ambient_event": event,
            "feed_motion": feed,
        }
    )
