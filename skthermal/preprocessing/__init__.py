"""Preprocessing for dynamic thermal-error models: causal lag features."""

from skthermal.preprocessing._lag_ridge import LagRidgeCV, make_lag_pipeline
from skthermal.preprocessing._lags import LagFeatures, exponential_filter

__all__ = ["LagFeatures", "LagRidgeCV", "exponential_filter", "make_lag_pipeline"]
