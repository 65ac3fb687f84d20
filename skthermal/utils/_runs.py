"""Run-aware helpers: where each run starts and ends inside a stacked array.

Rows of a run table are time-ordered samples of one or more *runs* (tests).
Everything that uses time -- AGO, grey models, "change since the start of the
run" -- must restart at every run boundary. These helpers turn run labels into
contiguous slices and find the labels a user supplied, whichever way they came:
explicitly as ``groups``, as a ``run`` column of a DataFrame, or as a ``run``
level of a DataFrame's index.
"""

import numpy as np

RUN_COLUMN = "run"


def run_slices(groups, n_samples=None):
    """Contiguous slices, one per run, in order of appearance.

    Parameters
    ----------
    groups : array-like of shape (n_samples,) or None
        Run label of every row. ``None`` means all rows form one run.
    n_samples : int, optional
        Number of rows; required when ``groups`` is None.

    Returns
    -------
    slices : list of slice
        ``slices[r]`` selects the rows of the r-th run.
    labels : list
        The run label of each slice.

    Raises
    ------
    ValueError
        If the rows of a run are not contiguous, or if ``groups`` does not have
        one label per row.
    """
    if groups is None:
        if n_samples is None:
            raise ValueError("n_samples is required when groups is None.")
        return [slice(0, int(n_samples))], [None]
    groups = np.asarray(groups)
    if groups.ndim != 1:
        raise ValueError(
            f"Run labels (groups) must be one-dimensional, got shape {groups.shape}."
        )
    if n_samples is not None and groups.shape[0] != n_samples:
        raise ValueError(
            f"Got {groups.shape[0]} run labels (groups) for {n_samples} rows; "
            "every row needs exactly one run label."
        )
    if groups.shape[0] == 0:
        return [], []
    change = np.flatnonzero(groups[1:] != groups[:-1]) + 1
    starts = np.concatenate(([0], change))
    stops = np.concatenate((change, [groups.shape[0]]))
    labels = groups[starts]
    # A label that starts more than one block means the run is split up.
    uniq, counts = np.unique(labels, return_counts=True)
    if np.any(counts > 1):
        bad = uniq[counts > 1][0].item()
        blocks = [
            f"rows {a}-{b - 1}"
            for a, b, lab in zip(starts, stops, labels.tolist(), strict=True)
            if lab == bad
        ]
        raise ValueError(
            f"The rows of run {bad!r} are not contiguous ({', '.join(blocks[:3])}); "
            "sort the table by run and time so that each run is one block."
        )
    slices = [slice(int(a), int(b)) for a, b in zip(starts, stops, strict=True)]
    return slices, labels.tolist()


def extract_runs(X, groups=None):
    """Separate run labels from the features of ``X``.

    The labels are taken, in this order, from ``groups``, from a ``run`` column
    of a DataFrame (which is then removed from the features), or from a ``run``
    level of a DataFrame's index. Without any of them, all rows are one run.

    Returns
    -------
    X : array-like
        ``X`` without a ``run`` column.
    groups : ndarray of shape (n_samples,) or None
    """
    columns = getattr(X, "columns", None)
    has_column = columns is not None and RUN_COLUMN in list(columns)
    if has_column:
        run_col = X[RUN_COLUMN]
        X = X.drop(columns=RUN_COLUMN)
        if groups is None:
            groups = run_col.to_numpy()
    if groups is None:
        index = getattr(X, "index", None)
        names = getattr(index, "names", None)
        if names is not None and RUN_COLUMN in names:
            groups = index.get_level_values(RUN_COLUMN).to_numpy()
    if groups is not None:
        groups = np.asarray(groups)
    return X, groups


def changes_since_start(X, slices):
    """Subtract the first sample of each run from every sample of that run.

    Parameters
    ----------
    X : ndarray of shape (n_samples,) or (n_samples, n_features)
    slices : list of slice
        Runs as returned by :func:`run_slices`.

    Returns
    -------
    ndarray of the same shape, zero on the first row of every run.
    """
    X = np.asarray(X, dtype=float)
    out = np.empty_like(X)
    for sl in slices:
        out[sl] = X[sl] - X[sl.start]
    return out


TIME_COLUMN = "time_s"


def check_time_order(X, groups):
    """Check that a ``time_s`` index level increases strictly within each run.

    Does nothing when ``X`` has no such index level (plain arrays carry no
    time; rows are then taken to be in time order).

    Raises
    ------
    ValueError
        Naming the run, the row and the two times.
    """
    index = getattr(X, "index", None)
    names = getattr(index, "names", None)
    if names is None or TIME_COLUMN not in names:
        return
    t = np.asarray(index.get_level_values(TIME_COLUMN), dtype=float)
    slices, labels = run_slices(groups, t.shape[0])
    for sl, lab in zip(slices, labels, strict=True):
        bad = np.flatnonzero(np.diff(t[sl]) <= 0)
        if bad.size:
            row = sl.start + int(bad[0]) + 1
            where = "" if lab is None else f" in run {lab!r}"
            raise ValueError(
                f"time_s must increase strictly within a run, but{where} row {row} "
                f"has time_s={t[row]:g} after {t[row - 1]:g}."
            )


def check_run_lengths(slices, labels, what, min_samples=2):
    """Raise a ValueError naming the first run shorter than ``min_samples``.

    ``what`` names the method that needs the samples, e.g. ``"GM(1,N)"``.
    """
    for sl, lab in zip(slices, labels, strict=True):
        n = sl.stop - sl.start
        if n < min_samples:
            run = "A run" if lab is None else f"Run {lab!r}"
            got = f"{n} sample" + ("" if n == 1 else "s")
            raise ValueError(
                f"{run} has only {got} (rows {sl.start}-{sl.stop - 1}); {what} "
                f"needs at least {min_samples} samples per run."
            )
