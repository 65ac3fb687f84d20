"""Estimators that wrap other estimators, such as the deployment guard."""

from skthermal.compose._guard import (
    GuardedRegressor,
    GuardWarning,
    PredictionRangeWarning,
    SensorFaultWarning,
    SensorRangeWarning,
)

__all__ = [
    "GuardWarning",
    "GuardedRegressor",
    "PredictionRangeWarning",
    "SensorFaultWarning",
    "SensorRangeWarning",
]
