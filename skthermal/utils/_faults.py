"""Faults of measured channels: single-sample glitches and dead probes.

A data logger's glitch (a bad conversion, a loose plug for one sample, a
corrupt line of a file) puts one sample far from its neighbours. Thermal
signals do not jump away and back within one sample, so such a sample is
told from the signal by its two neighbours. Left in, one glitch blows up
what a comparison takes as the noise of the channel, or pulls a calibration
towards it; the readers that compare samples (the gap diagnosis,
``ThermalMachine.calibrate``) take it as the mean of its neighbours and say
so.
"""

import warnings

import numpy as np

from skthermal.utils._warnings import user_stacklevel

# A glitch stands further than this from both neighbours, in units of the
# channel's usual step from one sample to the next. Gaussian noise alone
# does not get there (about 11 standard deviations of the noise on both
# sides at once).
SPIKE_FACTOR = 10.0
# The usual step: the root mean square of the smallest 90% of a channel's
# absolute first differences (a glitch makes two large ones).
_STEP_SHARE = 0.9


def flat_columns(Y):
    """Columns of ``Y`` (``(n, k)``) that do not change (to rounding): a dead
    or unplugged probe when it holds for every run."""
    return np.ptp(Y, axis=0) <= 1e-12 * np.maximum(1.0, np.max(np.abs(Y), axis=0))


def find_spikes(y):
    """Samples of ``y`` (``(n,)`` or ``(n, k)``, one column per channel)
    that are single-sample glitches, as a boolean array of ``y``'s shape.

    A sample is a glitch when it stands away from both its neighbours, on the
    same side, by more than :data:`SPIKE_FACTOR` times the channel's usual
    step from one sample to the next: the root mean square of the smallest
    90% of its absolute first differences, and no less than the smallest
    nonzero one (the quantum of readings that mostly do not change). A step
    that stays, a change of slope and a fast rise are not glitches; nor is
    the first or the last sample, which has one neighbour.
    """
    y = np.asarray(y, dtype=float)
    flat = y.ndim == 1
    y2 = y[:, None] if flat else y
    mask = np.zeros(y2.shape, dtype=bool)
    m = y2.shape[0] - 1
    if m < 2:
        return mask[:, 0] if flat else mask
    d = np.diff(y2, axis=0)
    a = np.sort(np.abs(d), axis=0)
    # At least the two steps of one glitch are left out of the usual step.
    keep = max(1, min(int(np.floor(_STEP_SHARE * m)), m - 2))
    step = np.sqrt(np.mean(a[:keep] ** 2, axis=0))
    quantum = np.where(a > 0, a, np.inf).min(axis=0)
    step = np.maximum(step, np.where(np.isfinite(quantum), quantum, 0.0))
    left, right = d[:-1], -d[1:]
    mask[1:-1] = (np.sign(left) == np.sign(right)) & (
        np.minimum(np.abs(left), np.abs(right)) > SPIKE_FACTOR * step
    )
    return mask[:, 0] if flat else mask


def repair_spikes(y, columns, time_s, run, table="", used_for="the comparison"):
    """``y`` (``(n, len(columns))``, one run) with every single-sample
    glitch (:func:`find_spikes`) replaced by the mean of its neighbours,
    and a warning naming the column, the run, the time and the value of
    each (the first few). ``y`` itself is not changed; it is returned as
    it is when there is none."""
    mask = find_spikes(y)
    if not mask.any():
        return y
    out = np.array(y, dtype=float, copy=True)
    rows, cols = np.nonzero(mask)
    out[rows, cols] = 0.5 * (out[rows - 1, cols] + out[rows + 1, cols])
    where = f"run {run!r}" + (f" of the {table} table" if table else "")
    listed = [
        f"{columns[c]} = {y[r, c]:g} at time_s {time_s[r]:g} "
        f"({y[r, c] - out[r, c]:+.3g} from its neighbours' mean)"
        for r, c in zip(rows[:5], cols[:5], strict=True)
    ]
    more = f" and {rows.size - 5} more" if rows.size > 5 else ""
    warnings.warn(
        f"{rows.size} sample(s) of {where} stand far from both neighbouring "
        f"samples (over {SPIKE_FACTOR:g} times the channel's usual step from "
        f"one sample to the next): {'; '.join(listed)}{more}. Glitches? "
        f"Each is taken as the mean of its neighbours for {used_for}; "
        "clean or drop them in the table to silence this.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )
    return out
