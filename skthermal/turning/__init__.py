"""Turning errors: decomposition of the diametral error of turned parts from
on-machine and post-process measurements, and synthetic turning tests."""

from skthermal.turning._decomposition import (
    TURNING_TEST_CONDITIONS,
    decompose_turning_error,
    fit_error_lines,
    make_turning_errors,
)

__all__ = [
    "TURNING_TEST_CONDITIONS",
    "decompose_turning_error",
    "fit_error_lines",
    "make_turning_errors",
]
