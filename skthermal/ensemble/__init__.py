"""Combinations of thermal-error models: modular models superposed from
single-source tests."""

from skthermal.ensemble._modular import ModularRegressor

__all__ = ["ModularRegressor"]
