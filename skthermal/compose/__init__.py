"""Estimators that wrap other estimators, such as the deployment guard."""

from skthermal.compose._guard import (
    GuardedRegressor,
    GuardWarning,
    PredictionRangeWarning,
    RunStartWarning,
    SensorFaultWarning,
    SensorRangeWarning,
)

__all__ = [
    "GuardWarning",
    "GuardedRegressor",
    "PredictionRangeWarning",
    "RunStartWarning",
    "SensorFaultWarning",
    "SensorRangeWarning",
]
