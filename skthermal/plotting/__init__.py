"""Plots of thermal-error models: scikit-learn-style Display objects.

Every display has ``from_*`` class methods that compute and draw, and a
``plot(ax=...)`` method that draws again; the drawn artists are stored as
attributes ending in ``_`` (``ax_``, ``figure_``, lines, spans). matplotlib
is needed only when drawing: ``pip install "skthermal[plot]"``.
"""

from skthermal.plotting._gap import GapOverlayDisplay, GapTimelineDisplay
from skthermal.plotting._membership import MembershipFunctionDisplay
from skthermal.plotting._prediction import PredictionDisplay
from skthermal.plotting._selection import SensorScoreDisplay

__all__ = [
    "GapOverlayDisplay",
    "GapTimelineDisplay",
    "MembershipFunctionDisplay",
    "PredictionDisplay",
    "SensorScoreDisplay",
]
