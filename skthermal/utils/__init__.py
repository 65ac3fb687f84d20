"""Internal utilities shared across skthermal (run handling, lazy imports)."""

from skthermal.utils._runs import (
    changes_since_start,
    check_numeric_columns,
    check_time_order,
    continued_runs,
    extract_runs,
    run_memory,
    run_slices,
    run_times,
    warn_unlabelled_runs,
)

__all__ = [
    "changes_since_start",
    "check_numeric_columns",
    "check_time_order",
    "continued_runs",
    "extract_runs",
    "run_memory",
    "run_slices",
    "run_times",
    "warn_unlabelled_runs",
]
