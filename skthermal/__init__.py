"""skthermal: predict and compensate the thermal errors of CNC machine tools.

Scikit-learn compatible sensor selectors and regressors from the thermal-error
literature (grey models, fuzzy c-means, ANFIS), with run-aware handling of
time-ordered test runs.
"""

import importlib

__version__ = "0.1.0.dev0"

# The estimators are imported on first use (PEP 562), so that importing the
# package -- and starting the ``skthermal`` command -- does not pay for
# scikit-learn, scipy and every estimator module up front.
_LAZY = {
    "ANFISRegressor": "skthermal.fuzzy",
    "FCMClusterPicker": "skthermal.selection",
    "FuzzyEquivalenceSelector": "skthermal.selection",
    "GNNMCIRegressor": "skthermal.grey",
    "GRASelector": "skthermal.selection",
    "GreyInfluenceSelector": "skthermal.selection",
    "GreyPSORegressor": "skthermal.grey",
    "GuardedRegressor": "skthermal.compose",
    "LagFeatures": "skthermal.preprocessing",
    "LagRidgeCV": "skthermal.preprocessing",
    "ModularRegressor": "skthermal.ensemble",
    "StableTSPSelector": "skthermal.selection",
    "TransferFunctionRegressor": "skthermal.linear_model",
    "UpdateRegressor": "skthermal.linear_model",
}

__all__ = [
    "ANFISRegressor",
    "FCMClusterPicker",
    "FuzzyEquivalenceSelector",
    "GNNMCIRegressor",
    "GRASelector",
    "GreyInfluenceSelector",
    "GreyPSORegressor",
    "GuardedRegressor",
    "LagFeatures",
    "LagRidgeCV",
    "ModularRegressor",
    "StableTSPSelector",
    "TransferFunctionRegressor",
    "UpdateRegressor",
    "__version__",
]


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'skthermal' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
