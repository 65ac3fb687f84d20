"""Noise levels of measured series: the white-noise part of a reading."""

import numpy as np
from scipy import stats


def noise_floor(y):
    """White-noise standard deviation of each column, from second differences.

    Smooth thermal signals have tiny second differences; white noise of
    standard deviation s gives second differences of standard deviation
    ``sqrt(6) s``. The largest 2% are trimmed so that steps and events do not
    count as noise, and the trimmed mean square is divided by the variance a
    Gaussian keeps under the same trimming (0.87), so that Gaussian noise is
    estimated without bias. (A median would read zero on quantised readings,
    whose second differences are mostly exactly zero.)
    """
    d2 = np.diff(y, n=2, axis=0)
    if d2.shape[0] == 0:
        return np.zeros(y.shape[1])
    a = np.sort(np.abs(d2), axis=0)
    keep = max(1, int(np.ceil(0.98 * a.shape[0])))
    return np.sqrt(
        np.mean(a[:keep] ** 2, axis=0) / 6.0 / _kept_variance(keep / a.shape[0])
    )


def _kept_variance(fraction):
    """Variance of a standard normal variable trimmed to its central
    ``fraction`` (the ``1 - fraction`` largest absolute values dropped)."""
    if fraction >= 1.0:
        return 1.0
    q = stats.norm.ppf(0.5 + fraction / 2.0)
    return 1.0 - 2.0 * q * stats.norm.pdf(q) / fraction


def pooled_noise(runs):
    """White-noise level of every channel, pooled over the runs' full-rate
    measurements (``runs``: one ``(n, channels)`` array per run, glitches
    repaired)."""
    return np.sqrt(np.mean([noise_floor(y) ** 2 for y in runs], axis=0))
