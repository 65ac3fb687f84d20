"""Faults of measured channels: glitches and dead probes.

A data logger's glitch (a bad conversion, a loose plug for a sample or two,
a corrupt line of a file) puts one or two samples far from the samples
around them. Thermal signals do not jump away and back within a sample or
two, so such samples are told from the signal by the samples around them.
Left in, one glitch blows up what a comparison takes as the noise of the
channel, or pulls a calibration towards it; the readers that compare samples
(the gap diagnosis, ``ThermalMachine.calibrate``) take it on a straight line
between the samples around it and say so.
"""

import warnings

import numpy as np

from skthermal.utils._warnings import user_stacklevel

# A glitch stands further than this from the samples around it, in units of
# the channel's usual step from one sample to the next (or of its quantum,
# the larger). Gaussian noise alone
# does not get there (about 11 standard deviations of the noise on both
# sides at once).
SPIKE_FACTOR = 10.0
# The usual step: the root mean square of the smallest 90% of a channel's
# absolute first differences (a glitch makes two large ones).
_STEP_SHARE = 0.9
# The samples around a glitch agree with each other: they differ by at most
# this share of the glitch's height (a step followed by a fast rise, a
# change of slope, is no glitch).
_AGREE = 0.5
# A fault is rare: more glitches than this in a channel (2, or 1% of its
# samples) are its own behaviour, e.g. a periodic excursion.
_RARE_COUNT, _RARE_SHARE = 2, 0.01
# Next to a change of a driver, a glitch lies outside the rest of the run
# by more than this many times the rest's span (a short real event there,
# a door opened or a spindle burst within a sampling period, stays within
# it in 2.95 M samples of an independent check).
_WILD = 2.0
# The longest glitch, in samples.
_WIDTHS = (1, 2)


def flat_columns(Y):
    """Columns of ``Y`` (``(n, k)``) that do not change (to rounding) but for
    a rare glitch (at most 2 samples, a quarter of them in short runs, each
    more than 1% of the reading's level away from it): a dead or unplugged
    probe when it holds for every run. (On a reading that never changes, a
    glitch cannot be told by its size: the usual step is the glitch's own. A
    quantised reading's flicker is a change.)"""
    Y = np.asarray(Y, dtype=float)
    level = np.median(Y, axis=0)
    size = np.maximum(1.0, np.abs(level))
    off = np.abs(Y - level) > 1e-12 * size
    glitch = np.abs(Y - level) > 0.01 * size
    rare = off.sum(axis=0) <= min(_RARE_COUNT, (Y.shape[0] - 1) // 4)
    return ~off.any(axis=0) | (rare & ~np.any(off & ~glitch, axis=0))


def _scales(y):
    """Each column's usual step (the root mean square of the smallest 90% of
    its absolute first differences, leaving out at least the two of one
    glitch) and its quantum (its smallest nonzero step; 0 for none)."""
    a = np.sort(np.abs(np.diff(y, axis=0)), axis=0)
    m = a.shape[0]
    keep = max(1, min(int(np.floor(_STEP_SHARE * m)), m - 2))
    quantum = np.where(a > 0, a, np.inf).min(axis=0)
    return (
        np.sqrt(np.mean(a[:keep] ** 2, axis=0)),
        np.where(np.isfinite(quantum), quantum, 0.0),
    )


def _driver_changes(drivers, air, n):
    """Samples next to a change of a driver: any step of the speed or feed
    (``drivers``), a jump of the workshop air (``air``) beyond
    :data:`SPIKE_FACTOR` times its usual step and its quantum (a door
    opened, not the flicker of a quantised reading)."""
    near = np.zeros(n, dtype=bool)
    moved = np.zeros(n - 1, dtype=bool)
    if drivers is not None:
        D = np.asarray(drivers, dtype=float).reshape(n, -1)
        moved |= np.any(np.diff(D, axis=0) != 0, axis=1)
    if air is not None:
        A = np.asarray(air, dtype=float).reshape(n, -1)
        floor = np.maximum(*_scales(A))
        moved |= np.any(np.abs(np.diff(A, axis=0)) > SPIKE_FACTOR * floor, axis=1)
    near[:-1] |= moved
    near[1:] |= moved
    return near


def find_spikes(y, drivers=None, running=None, air=None):
    """Samples of ``y`` (``(n,)`` or ``(n, k)``, one column per channel)
    that are glitches of one or two samples, as a boolean array of ``y``'s
    shape.

    A glitch stands away from the samples around it by more than
    :data:`SPIKE_FACTOR` times the larger of the channel's usual step from
    one sample to the next (the root mean square of the smallest 90% of its
    absolute first differences) and its quantum (its smallest nonzero step),
    while those samples agree with each other (for the first and the last
    sample, the two after or before it). Next to a change of a driver, where
    a short event can be real, it must also lie outside the rest of the run
    by more than twice the rest's span (so must a first sample where the run
    starts running; a last sample there is not judged). A step that stays, a
    change of slope, a fast rise and a quantised reading's flicker are no
    glitches. Faults are rare: more than 2 such samples (or 1% of them) in a
    channel are its own behaviour (a periodic excursion), and none is taken.
    (A glitch on a reading that never changes is not found: its quantum is
    the glitch's own step; :func:`flat_columns` takes such a channel as a
    dead probe.)

    Parameters
    ----------
    y : array-like of shape (n,) or (n, k)
        One run of the channels.
    drivers : array-like of shape (n,) or (n, j), optional
        The run's step-like drivers (speed, feed): a sample next to a change
        of one (a short spindle burst within a sampling period) may be a
        real event, and is a glitch only when it lies far outside the rest
        of the run (a reading stored as 0, a dropped line).
    running : array-like of bool of shape (n,), optional
        Whether a heat source (the spindle, a feed axis) runs at each
        sample: a run that starts running rises fastest at its first
        sample, which is then judged as next to a driver's change.
    air : array-like of shape (n,), optional
        The workshop air: a jump of it (a door opened for a sampling
        period, beyond its usual step and quantum) counts as a change of a
        driver.
    """
    y = np.asarray(y, dtype=float)
    flat = y.ndim == 1
    y2 = y[:, None] if flat else y
    n = y2.shape[0]
    mask = np.zeros(y2.shape, dtype=bool)
    if n < 3:
        return mask[:, 0] if flat else mask
    step, quantum = _scales(y2)
    moving = _driver_changes(drivers, air, n)
    # How far every candidate stands out, where, and whether no driver
    # changes there: (rows, height, calm) per kind.
    tests = []
    for width in _WIDTHS:
        if n < width + 2:
            break
        before, after = y2[: n - width - 1], y2[width + 1 :]
        block = np.stack([y2[1 + j : n - width + j] for j in range(width)])
        low = np.min(np.minimum(np.abs(block - before), np.abs(block - after)), 0)
        low = np.where(np.abs(after - before) <= _AGREE * low, low, 0.0)
        calm = ~np.any([moving[1 + j : n - width + j] for j in range(width)], 0)
        for j in range(width):
            tests.append((slice(1 + j, n - width + j), low, calm[:, None]))
    # The first and the last sample, against the two samples after (before)
    # them, which agree.
    for row, one, two in ((0, 1, 2), (n - 1, n - 2, n - 3)):
        height = np.abs(y2[row] - y2[one])
        height = np.where(np.abs(y2[one] - y2[two]) <= _AGREE * height, height, 0.0)
        calm = not (moving[row] or moving[one])
        if row == 0 and running is not None and np.asarray(running)[0]:
            calm = False
        if row == n - 1 and not calm:
            # The last sample at a driver's change may be the first of a new
            # regime, with nothing after it: not judged.
            height = np.zeros_like(height)
        tests.append((slice(row, row + 1), height[None], np.array([[calm]])))
    floor = SPIKE_FACTOR * np.maximum(step, quantum)
    # Next to a driver's change, only a sample outside the rest of the run
    # (its two highest and lowest samples left out) by more than _WILD
    # times the rest's span: a reading stored as 0, a line of 1e6.
    ranked = np.sort(y2, axis=0)
    lo, hi = (ranked[2], ranked[-3]) if n >= 6 else (ranked[0], ranked[-1])
    wild = np.maximum(lo - y2, y2 - hi) > _WILD * np.maximum(hi - lo, floor)
    for rows, height, calm in tests:
        mask[rows] |= (height > floor) & (calm | wild[rows])
    # Many: a behaviour of the channel (a periodic excursion), not a fault.
    mask[:, mask.sum(axis=0) > max(_RARE_COUNT, _RARE_SHARE * n)] = False
    return mask[:, 0] if flat else mask


def repair_spikes(
    y,
    columns,
    time_s,
    run,
    table="",
    used_for="the comparison",
    *,
    spindle_rpm=None,
    feed_mm_min=None,
    ambient_C=None,
):
    """``y`` (``(n, len(columns))``, one run) with every glitch
    (:func:`find_spikes`, with the run's drivers as given: the speed and feed
    step, the spindle or a feed axis runs where they are not 0) replaced by
    a straight line between the samples around it (through the two nearest
    at a run's end), and a warning naming the column, the run, the time and
    the value of each (the first few). ``y`` itself is not changed; it is
    returned as it is when there is none."""
    steps = [d for d in (spindle_rpm, feed_mm_min) if d is not None]
    drivers = running = None
    if steps:
        drivers = np.column_stack(steps)
        running = np.any(drivers != 0, axis=1)
    mask = find_spikes(y, drivers, running, ambient_C)
    if not mask.any():
        return y
    out = np.array(y, dtype=float, copy=True)
    rows = np.arange(out.shape[0])
    for c in np.flatnonzero(mask.any(axis=0)):
        bad = mask[:, c]
        good = rows[~bad]
        out[bad, c] = np.interp(rows[bad], good, out[good, c])
        # At a run's ends, on the line through the two nearest good samples.
        for ends, pair in (
            (rows[bad] < good[0], good[:2]),
            (rows[bad] > good[-1], good[-2:]),
        ):
            if ends.any() and pair.size == 2:
                slope = (out[pair[1], c] - out[pair[0], c]) / (pair[1] - pair[0])
                at = rows[bad][ends]
                out[at, c] = out[pair[0], c] + slope * (at - pair[0])
    where = f"run {run!r}" + (f" of the {table} table" if table else "")
    found, cols = np.nonzero(mask)
    listed = [
        f"{columns[c]} = {y[r, c]:g} at time_s {time_s[r]:g} "
        f"({y[r, c] - out[r, c]:+.3g} from the samples around it)"
        for r, c in zip(found[:5], cols[:5], strict=True)
    ]
    more = f" and {found.size - 5} more" if found.size > 5 else ""
    warnings.warn(
        f"{found.size} sample(s) of {where} stand far from the samples "
        f"around them, which agree (over {SPIKE_FACTOR:g} times the channel's "
        f"usual step from one sample to the next): "
        f"{'; '.join(listed)}{more}. Glitches? Each is taken on a straight "
        f"line between the samples around it for {used_for}.",
        UserWarning,
        stacklevel=user_stacklevel(),
    )
    return out
