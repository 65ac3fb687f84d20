"""skthermal: predict and compensate the thermal errors of CNC machine tools.

Scikit-learn compatible sensor selectors and regressors from the thermal-error
literature (grey models, fuzzy c-means, ANFIS), with run-aware handling of
time-ordered test runs.
"""

__version__ = "0.1.0.dev0"

from skthermal.fuzzy import ANFISRegressor  # noqa: E402
from skthermal.grey import GNNMCIRegressor, GreyPSORegressor  # noqa: E402
from skthermal.selection import (  # noqa: E402
    FCMClusterPicker,
    GRASelector,
    GreyInfluenceSelector,
)

__all__ = [
    "ANFISRegressor",
    "FCMClusterPicker",
    "GNNMCIRegressor",
    "GRASelector",
    "GreyPSORegressor",
    "GreyInfluenceSelector",
    "__version__",
]
