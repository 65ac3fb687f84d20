"""Fuzzy building blocks: fuzzy c-means clustering."""

from skthermal.fuzzy._cmeans import (
    FuzzyCMeansResult,
    fuzzy_cmeans,
    fuzzy_memberships,
)

__all__ = ["FuzzyCMeansResult", "fuzzy_cmeans", "fuzzy_memberships"]
