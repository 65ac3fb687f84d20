"""skthermal: predict and compensate the thermal errors of CNC machine tools.

Scikit-learn compatible sensor selectors and regressors from the thermal-error
literature (grey models, fuzzy c-means, ANFIS), with run-aware handling of
time-ordered test runs.
"""

__version__ = "0.1.0.dev0"

from skthermal.ensemble import ModularRegressor  # noqa: E402
from skthermal.fuzzy import ANFISRegressor  # noqa: E402
from skthermal.grey import GNNMCIRegressor, GreyPSORegressor  # noqa: E402
from skthermal.linear_model import UpdateRegressor  # noqa: E402
from skthermal.selection import (  # noqa: E402
    FCMClusterPicker,
    FuzzyEquivalenceSelector,
    GRASelector,
    GreyInfluenceSelector,
    StableTSPSelector,
)

__all__ = [
    "ANFISRegressor",
    "FCMClusterPicker",
    "FuzzyEquivalenceSelector",
    "GNNMCIRegressor",
    "GRASelector",
    "GreyPSORegressor",
    "ModularRegressor",
    "StableTSPSelector",
    "UpdateRegressor",
    "GreyInfluenceSelector",
    "__version__",
]
