"""Estimators that wrap other estimators, such as the deployment guard, and
prediction on a stream of blocks of rows."""

from skthermal.compose._guard import (
    GuardedRegressor,
    GuardWarning,
    PredictionRangeWarning,
    RunStartWarning,
    SensorFaultWarning,
    SensorRangeWarning,
)
from skthermal.compose._stream import RunStream

__all__ = [
    "GuardWarning",
    "GuardedRegressor",
    "PredictionRangeWarning",
    "RunStartWarning",
    "RunStream",
    "SensorFaultWarning",
    "SensorRangeWarning",
]
