"""The papers' metrics per run, on changes since the start of each run."""

import numpy as np
import pandas as pd
from sklearn.utils._param_validation import validate_params

from skthermal.utils._runs import rows_by_run

METRIC_COLUMNS = ("R", "RMSE_um", "NSE", "residual_um", "improvement_pct")


def run_metrics(z, p):
    """The papers' metrics of one run (changes since its start); NaN if not finite."""
    from skthermal.metrics import (
        improvement,
        nash_sutcliffe,
        pearson_r,
        residual_band,
        rmse,
    )

    z = np.asarray(z, dtype=float)
    p = np.asarray(p, dtype=float)
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(z))):
        return dict.fromkeys(METRIC_COLUMNS, np.nan)
    return {
        "R": pearson_r(z, p),
        "RMSE_um": rmse(z, p),
        "NSE": nash_sutcliffe(z, p),
        "residual_um": residual_band(z, p),
        "improvement_pct": 100.0 * improvement(z, p),
    }


@validate_params(
    {
        "measured": ["array-like"],
        "predicted": ["array-like"],
        "groups": ["array-like"],
    },
    prefer_skip_nested_validation=True,
)
def score_runs(measured, predicted, groups):
    """Metrics per run, both series taken as changes since the run start.

    R, RMSE, NSE, residual band max|error| and improvement
    1 - max|error| / max|measured| (001 §3.8), computed on each run's
    measured and predicted values minus their first value, as a compensation
    applies them.

    Parameters
    ----------
    measured, predicted : array-like of shape (n_samples,)
        Measured and predicted displacement.
    groups : array-like of shape (n_samples,)
        Run label of every row; the first row of a run is its start.

    Returns
    -------
    DataFrame
        One row per run, in order of appearance: ``run``, ``n_samples`` and
        the columns of ``METRIC_COLUMNS`` (NaN for a run with non-finite
        values).

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.study import score_runs
    >>> z = np.array([10.0, 11.0, 12.0, 0.0, 2.0, 4.0])
    >>> p = np.array([5.0, 6.0, 7.5, 1.0, 3.0, 5.0])
    >>> score_runs(z, p, ["a"] * 3 + ["b"] * 3)[["run", "RMSE_um"]].round(3)
      run  RMSE_um
    0   a    0.289
    1   b    0.000
    """
    z = np.asarray(measured, dtype=float).ravel()
    p = np.asarray(predicted, dtype=float).ravel()
    groups = np.asarray(groups)
    if not (z.shape[0] == p.shape[0] == groups.shape[0]):
        raise ValueError(
            f"measured, predicted and groups must have one value per row; got "
            f"{z.shape[0]}, {p.shape[0]} and {groups.shape[0]}."
        )
    rows = []
    for label, mine in zip(*rows_by_run(groups), strict=True):
        zr, pr = z[mine], p[mine]
        rows.append(
            {
                "run": label,
                "n_samples": int(mine.size),
                **run_metrics(zr - zr[0], pr - pr[0]),
            }
        )
    return pd.DataFrame(rows)
