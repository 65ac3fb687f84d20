"""Shared scoring vocabulary of the gap diagnosis: frequency bands and the
shrink of the gap above the noise floor (used by the diagnosis and its
report)."""

import numpy as np

# Frequency bands of the "where" analysis: (label, shortest, longest period
# in hours).
BANDS_H = [
    ("> 6 h", 6.0, np.inf),
    ("1-6 h", 1.0, 6.0),
    ("10 min-1 h", 1 / 6, 1.0),
    ("< 10 min", 0.0, 1 / 6),
]

# The unit of every gap figure of the diagnosis: the weighted RMS residual,
# each channel divided by the spread of its group's measurements (µm for
# displacements, °C for temperatures), so a gap of 1 is as large as the
# measured signal itself.
GAP_UNIT = "normalised (1 = spread of the measured signal)"


def excess_shrink(gap_b, gap_a, floor2):
    """Share of the gap above the noise floor removed: ``1 - excess after /
    excess before``, the excess being ``sqrt(gap^2 - floor^2)``."""
    ex_b = np.sqrt(max(gap_b**2 - floor2, 0.0))
    ex_a = np.sqrt(max(gap_a**2 - floor2, 0.0))
    return float(1.0 - ex_a / ex_b) if ex_b > 0 else 0.0
