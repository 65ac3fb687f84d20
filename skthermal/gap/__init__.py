"""Sim-to-real gap diagnosis: where a simulation and measurements disagree,
which unmodelled effect explains it, and how far the gap shrinks once added."""

from skthermal.gap._diagnose import diagnose
from skthermal.gap._downstream import downstream_error
from skthermal.gap._external import ExternalGapReport, diagnose_runs
from skthermal.gap._regimes import label_regimes
from skthermal.gap._report import GapReport
from skthermal.gap._validate import (
    GapCase,
    ValidationReport,
    make_gap_campaign,
    validate,
)

__all__ = [
    "ExternalGapReport",
    "GapCase",
    "GapReport",
    "ValidationReport",
    "diagnose",
    "diagnose_runs",
    "downstream_error",
    "label_regimes",
    "make_gap_campaign",
    "validate",
]
