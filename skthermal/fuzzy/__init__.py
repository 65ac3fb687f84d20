"""Fuzzy building blocks and ANFIS: membership functions, fuzzy c-means and
the adaptive neuro-fuzzy inference system."""

from skthermal.fuzzy._anfis import ANFISRegressor
from skthermal.fuzzy._cmeans import (
    FuzzyCMeansResult,
    fuzzy_cmeans,
    fuzzy_memberships,
)
from skthermal.fuzzy._membership import gaussian_mf, gbell_mf

__all__ = [
    "ANFISRegressor",
    "FuzzyCMeansResult",
    "fuzzy_cmeans",
    "fuzzy_memberships",
    "gaussian_mf",
    "gbell_mf",
]
