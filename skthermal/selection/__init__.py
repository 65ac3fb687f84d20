"""Sensor selection: grey influence ranking, grey relational analysis and fuzzy
c-means grouping of temperature sensors, stable temperature-sensitive points."""

from skthermal.selection._base import RunAwareSelector, ScoreSelector
from skthermal.selection._fcm import FCMClusterPicker
from skthermal.selection._grey import GRASelector, GreyInfluenceSelector
from skthermal.selection._stable import FuzzyEquivalenceSelector, StableTSPSelector

__all__ = [
    "FCMClusterPicker",
    "FuzzyEquivalenceSelector",
    "GRASelector",
    "GreyInfluenceSelector",
    "RunAwareSelector",
    "ScoreSelector",
    "StableTSPSelector",
]
