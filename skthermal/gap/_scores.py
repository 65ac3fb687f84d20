"""Shared scoring vocabulary of the gap diagnosis (both modes and the
report): frequency bands, held-out folds over runs, the gap of a set of
runs, its shrink above the noise floor, the paired block test, the gap per
regime."""

from numbers import Integral, Real

import numpy as np
import pandas as pd
from scipy import stats
from sklearn.model_selection import GroupKFold, LeaveOneGroupOut
from sklearn.utils._param_validation import Interval

# Frequency bands of the "where" analysis: (label, shortest, longest period
# in hours).
BANDS_H = [
    ("> 6 h", 6.0, np.inf),
    ("1-6 h", 1.0, 6.0),
    ("10 min-1 h", 1 / 6, 1.0),
    ("< 10 min", 0.0, 1 / 6),
]

# The unit of every gap figure of the diagnosis: the weighted RMS residual,
# each channel divided by the spread of its group's measurements (µm for
# displacements, °C for temperatures), so a gap of 1 is as large as the
# measured signal itself.
GAP_UNIT = "normalised (1 = spread of the measured signal)"


# Parameter constraints both diagnoses share (candidates, held-out scheme,
# channels, decision rule, sampling, parallelism), for validate_params.
DIAGNOSIS_PARAMS = {
    "candidates": [None, str, list, tuple],
    "cv": [None, Interval(Integral, 2, None, closed="left"), "cv_object"],
    "channels": [None, list, tuple],
    "mapping": [None, dict],
    "min_shrink": [Interval(Real, 0, 1, closed="right")],
    "alpha": [Interval(Real, 0, 1, closed="neither")],
    "greedy": ["boolean"],
    "max_samples": [Interval(Integral, 10, None, closed="left")],
    "n_jobs": [None, Integral],
}


def excess_shrink(gap_b, gap_a, floor2):
    """Share of the gap above the noise floor removed: ``1 - excess after /
    excess before``, the excess being ``sqrt(gap^2 - floor^2)``."""
    ex_b = np.sqrt(max(gap_b**2 - floor2, 0.0))
    ex_a = np.sqrt(max(gap_a**2 - floor2, 0.0))
    return float(1.0 - ex_a / ex_b) if ex_b > 0 else 0.0


def heldout_folds(n_runs, cv):
    """(train, test) run indices: leave-one-run-out for up to 3 runs, else
    3-fold GroupKFold; an int is a number of GroupKFold splits."""
    groups = np.arange(n_runs)
    if cv is None:
        cv = LeaveOneGroupOut() if n_runs <= 3 else GroupKFold(n_splits=3)
    elif isinstance(cv, int):
        cv = GroupKFold(n_splits=cv)
    X = np.zeros((n_runs, 1))
    return [(tr, te) for tr, te in cv.split(X, groups=groups)]


def run_ms(R):
    """Mean over samples of the weighted squared normalised residual."""
    return float(np.mean(np.sum(R * R, axis=1))) if R.size else 0.0


def gap_of(Rs):
    """Gap of a set of runs (pooled weighted RMS residual) and each run's
    mean squared residual."""
    n = np.array([R.shape[0] for R in Rs], dtype=float)
    ms = np.array([run_ms(R) for R in Rs])
    return float(np.sqrt(np.sum(n * ms) / n.sum())), ms


def block_test(before, after, n_blocks=3):
    """One-sided paired t-test of the squared-error reduction over time blocks.

    Each held-out run is cut into ``n_blocks`` contiguous blocks (hours long,
    so nearly independent); the test asks whether the candidate lowers the
    mean squared residual across blocks more than block-to-block noise would.
    """
    d = []
    for Rb, Ra in zip(before, after, strict=True):
        edges = np.linspace(0, Rb.shape[0], n_blocks + 1).astype(int)
        for lo, hi in zip(edges[:-1], edges[1:], strict=True):
            if hi > lo:
                d.append(run_ms(Rb[lo:hi]) - run_ms(Ra[lo:hi]))
    d = np.asarray(d)
    if d.size < 2 or np.std(d) == 0:
        return 0.0 if d.size and np.all(d > 0) else 1.0
    return float(stats.ttest_1samp(d, 0.0, alternative="greater").pvalue)


def regime_gaps(Rs, regimes):
    """Gap per regime label (primary regime, ambient event, feed motion)."""
    rows = []
    for R, lab in zip(Rs, regimes, strict=True):
        e = np.sum(R * R, axis=1)
        keys = lab["regime"].to_numpy().astype(object)
        rows.append(pd.DataFrame({"regime": keys, "e": e}))
        if lab["ambient_event"].any():
            rows.append(
                pd.DataFrame(
                    {"regime": "ambient event", "e": e[lab["ambient_event"].to_numpy()]}
                )
            )
        if lab["feed_motion"].any():
            rows.append(
                pd.DataFrame(
                    {"regime": "feed motion", "e": e[lab["feed_motion"].to_numpy()]}
                )
            )
        for speed, idx in lab.groupby("speed").groups.items():
            if speed != "0 rpm":
                rows.append(pd.DataFrame({"regime": f"at {speed}", "e": e[idx]}))
    frame = pd.concat(rows, ignore_index=True)
    return frame.groupby("regime", sort=False)["e"].mean().pow(0.5)
