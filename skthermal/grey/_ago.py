"""Accumulated generating operation (AGO), its inverse and background values.

METHODS §1 (001 §3.4.1). All three work within runs: pass ``groups`` (one run
label per row, each run one contiguous block) and the accumulation restarts at
every run boundary.
"""

import numpy as np

from skthermal.utils._runs import run_first_rows, run_slices


def _starts(groups, n):
    """Mask of the rows that start a run."""
    return run_first_rows(groups, n) == np.arange(n)


def ago(x, groups=None):
    """First-order accumulated generating operation, ``x1(k) = sum_{j<=k} x0(j)``.

    Parameters
    ----------
    x : array-like of shape (n_samples,) or (n_samples, n_series)
        Original series ``x0``, time along axis 0.
    groups : array-like of shape (n_samples,), optional
        Run label of every row; the sum restarts at every run.

    Returns
    -------
    x1 : ndarray of the same shape

    Examples
    --------
    >>> from skthermal.grey import ago
    >>> ago([1.0, 2.0, 3.0]).tolist()
    [1.0, 3.0, 6.0]
    >>> ago([1.0, 2.0, 3.0, 4.0], groups=["a", "a", "b", "b"]).tolist()
    [1.0, 3.0, 3.0, 7.0]
    """
    x = np.asarray(x, dtype=float)
    out = np.cumsum(x, axis=0)
    if groups is None:
        return out
    slices, _ = run_slices(groups, x.shape[0])
    # Subtract what was accumulated before each run started (vectorised over
    # runs: one offset per row, taken from the row before its run's start).
    before = np.zeros_like(out)
    for sl in slices[1:]:
        before[sl] = out[sl.start - 1]
    return out - before


def iago(x1, groups=None):
    """Inverse AGO: ``x0(1) = x1(1)``, ``x0(k) = x1(k) - x1(k-1)`` within each run.

    Examples
    --------
    >>> from skthermal.grey import iago
    >>> iago([1.0, 3.0, 6.0]).tolist()
    [1.0, 2.0, 3.0]
    """
    x1 = np.asarray(x1, dtype=float)
    n = x1.shape[0]
    out = np.empty_like(x1)
    if n == 0:
        return out
    out[0] = x1[0]
    out[1:] = x1[1:] - x1[:-1]
    if groups is not None:
        starts = _starts(groups, n)
        out[starts] = x1[starts]
    return out


def background(x1, groups=None):
    """Background (mean) values ``z1(k) = 0.5 x1(k-1) + 0.5 x1(k)``, k >= 2.

    Returns only the rows that have a predecessor in the same run, so a run of
    ``n`` samples contributes ``n - 1`` rows.

    Returns
    -------
    z1 : ndarray of shape (n_samples - n_runs, ...)
    mask : ndarray of bool, shape (n_samples,)
        Rows of ``x1`` (the "k") each value of ``z1`` belongs to.
    """
    x1 = np.asarray(x1, dtype=float)
    n = x1.shape[0]
    if groups is None:
        mask = np.ones(n, dtype=bool)
        if n:
            mask[0] = False
    else:
        starts = _starts(groups, n)
        mask = ~starts
    prev = np.empty_like(x1)
    if n:
        prev[1:] = x1[:-1]
        prev[0] = x1[0]
    z = 0.5 * (prev + x1)
    return z[mask], mask
