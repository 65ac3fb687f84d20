"""Cross-validation folds over time-ordered runs.

The folds the estimators that choose their own settings (``LagRidgeCV``,
``TransferFunctionRegressor(alpha="auto")``) validate on: rows of a run are
never shuffled, so a model is always scored on a stretch of time it was not
fitted on, starting from the run's start.
"""

import warnings

import numpy as np

from skthermal.utils._runs import run_key
from skthermal.utils._warnings import user_stacklevel


def forward_folds(n, n_splits, first_fraction):
    """Expanding-window folds: train on rows before a cut, score the next block."""
    edges = np.linspace(int(first_fraction * n), n, n_splits + 1).astype(int)
    return [
        (np.arange(0, edges[i]), np.arange(edges[i], edges[i + 1]))
        for i in range(n_splits)
        if edges[i] > 1 and edges[i + 1] > edges[i]
    ]


def block_folds(n, n_splits):
    """Contiguous-block folds: leave each of n_splits equal blocks out."""
    edges = np.linspace(0, n, n_splits + 1).astype(int)
    rows = np.arange(n)
    return [
        (np.r_[rows[: edges[i]], rows[edges[i + 1] :]], rows[edges[i] : edges[i + 1]])
        for i in range(n_splits)
        if edges[i + 1] > edges[i]
    ]


def run_order(labels):
    """Positions of the runs ``labels`` in a fixed order that does not depend
    on the order of the runs in the table: by label, or, when the labels do
    not sort (mixed kinds, unorderable objects), by the ``repr`` of their
    :func:`~skthermal.utils._runs.run_key`."""
    positions = range(len(labels))
    try:
        return sorted(positions, key=lambda r: labels[r])
    except TypeError:
        return sorted(positions, key=lambda r: repr(run_key(labels[r])))


def group_folds(slices, n_splits, labels=None):
    """Leave-runs-out folds: the runs, in the order of their labels (else of
    ``slices``), dealt round-robin into n_splits groups, so that the folds do
    not depend on the order the runs were stacked in."""
    k = min(n_splits, len(slices))
    order = range(len(slices)) if labels is None else run_order(labels)
    parts = [[] for _ in range(k)]
    for i, r in enumerate(order):
        sl = slices[r]
        parts[i % k].append(np.arange(sl.start, sl.stop))
    n = max(sl.stop for sl in slices)
    folds = []
    for p in parts:
        va = np.sort(np.concatenate(p))
        mask = np.ones(n, bool)
        mask[va] = False
        folds.append((np.flatnonzero(mask), va))
    return folds


def run_folds(cv, slices, labels, n, n_splits, first_fraction, name):
    """The folds of ``cv`` (``"auto"``, ``"forward"``, ``"blocks"`` or
    ``"runs"``) over ``n`` rows in the runs ``slices``, each with training
    and validation rows: ``"auto"`` leaves whole runs out when there are
    several, else takes expanding windows in time order (as ``"runs"`` on
    one run, with a warning naming the estimator ``name``). A fold that
    leaves out runs and keeps fewer than ``first_fraction`` of the rows for
    training (the short runs alone, a long one left out) is skipped, as
    expanding windows start at that share: fitted on a few rows and scored
    on the rest, it decided the choice alone (a run of 2 rows beside one of
    720 made a transfer-function model choose the largest penalty, 12.5
    where the least-squares fit erred by 0.0)."""
    if cv == "auto":
        cv = "runs" if len(slices) > 1 else "forward"
    if cv == "runs" and len(slices) == 1:
        warnings.warn(
            f"{name}: cv='runs' leaves whole runs out, and the training rows "
            "are one run: expanding-window folds in time order are used "
            "instead (cv='forward').",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
    if cv == "runs" and len(slices) > 1:
        folds = [
            (tr, va)
            for tr, va in group_folds(slices, n_splits, labels)
            if tr.size >= first_fraction * n
        ]
    elif cv == "blocks":
        folds = block_folds(n, n_splits)
    else:
        folds = forward_folds(n, n_splits, first_fraction)
    return [(tr, va) for tr, va in folds if tr.size and va.size]
