"""Change since the first row of each run, for runs in any row order.

Estimators get runs as contiguous blocks and use
:func:`skthermal.utils.changes_since_start` on their slices directly. Tables
and sensor records may interleave their runs; this gathers the rows of every
run (keeping their order), applies that same function, and puts the rows back.
"""

import numpy as np
import pandas as pd

from skthermal.utils._runs import changes_since_start, run_slices


def changes_since_first_row(values, groups, *, what="groups"):
    """``values`` minus the first row of its run, runs in any order.

    Parameters
    ----------
    values : array-like of shape (n_samples,) or (n_samples, n_columns)
    groups : array-like of shape (n_samples,) or None
        Run label of every row; None: all rows are one run.
    what : str, default="groups"
        How the labels are named in error messages.

    Returns
    -------
    ndarray of float of the shape of ``values``, zero on the first row of
    every run (NaN on every row of a run whose first value is NaN).

    Raises
    ------
    ValueError
        If ``groups`` does not hold one label per row, or a label is missing.
    """
    values = np.asarray(values, dtype=float)
    n = values.shape[0]
    if groups is None:
        return changes_since_start(values, [slice(0, n)] if n else [])
    groups = np.asarray(groups)
    if groups.shape != (n,):
        raise ValueError(
            f"{what} must hold one run label per row ({n}), got shape {groups.shape}."
        )
    codes, _ = pd.factorize(groups)
    if np.any(codes < 0):
        raise ValueError(f"{what} has missing run labels; every row needs one.")
    order = np.argsort(codes, kind="stable")
    slices, _ = run_slices(codes[order])
    out = np.empty_like(values)
    out[order] = changes_since_start(values[order], slices)
    return out
