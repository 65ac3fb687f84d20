"""Sensor selection: grey influence ranking, grey relational analysis and fuzzy
c-means grouping of temperature sensors."""

from skthermal.selection._base import RunAwareSelector, ScoreSelector
from skthermal.selection._fcm import FCMClusterPicker
from skthermal.selection._grey import GRASelector, GreyInfluenceSelector

__all__ = [
    "FCMClusterPicker",
    "GRASelector",
    "GreyInfluenceSelector",
    "RunAwareSelector",
    "ScoreSelector",
]
