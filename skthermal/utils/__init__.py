"""Internal utilities shared across skthermal (run handling, lazy imports)."""

from skthermal.utils._runs import (
    changes_since_start,
    check_time_order,
    extract_runs,
    run_slices,
)

__all__ = ["changes_since_start", "check_time_order", "extract_runs", "run_slices"]
