"""Accuracy measures of thermal-error models and their scorers (METHODS §12).

Metric functions take ``(y_true, y_pred, *, multioutput=...)`` like
:mod:`sklearn.metrics`; the scorers plug them into ``cross_validate``.
"""

from skthermal.metrics._levels import RMSELevels, cross_batch_rmse, rmse_levels
from skthermal.metrics._regression import (
    improvement,
    nash_sutcliffe,
    pearson_r,
    residual_band,
    rmse,
)
from skthermal.metrics._scorers import get_scorer, get_scorer_names, thermal_scorers

__all__ = [
    "RMSELevels",
    "cross_batch_rmse",
    "get_scorer",
    "get_scorer_names",
    "improvement",
    "nash_sutcliffe",
    "pearson_r",
    "residual_band",
    "rmse",
    "rmse_levels",
    "thermal_scorers",
]
