"""Accuracy measures of thermal-error models (METHODS §12, 001 §3.8).

The thesis and papers report a model with four numbers: the root mean squared
error, the Nash-Sutcliffe efficiency, Pearson's correlation coefficient and the
residual band ``max |z - p|`` (the "±4 µm" of a compensated test), plus the
improvement ``1 - max|z - p| / max|z|`` (the "94%" of error removed). All take
``y_true`` (measured error ``z``) and ``y_pred`` (predicted ``p``) of shape
``(n_samples,)`` or ``(n_samples, n_outputs)``.
"""

import warnings

import numpy as np
from sklearn.exceptions import UndefinedMetricWarning

_MULTIOUTPUT = ("raw_values", "uniform_average")


def _as_2d(y, name):
    try:
        y = np.asarray(y, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric: {exc}") from exc
    if y.ndim == 1:
        y = y[:, None]
    if y.ndim != 2:
        raise ValueError(f"{name} must be 1-D or 2-D, got shape {y.shape}.")
    return y


def _check_targets(y_true, y_pred, multioutput):
    """Validated 2-D float arrays of equal shape and the output weights."""
    y_true = _as_2d(y_true, "y_true")
    y_pred = _as_2d(y_pred, "y_pred")
    if y_true.shape[0] != y_pred.shape[0]:
        raise ValueError(
            f"y_true has {y_true.shape[0]} samples but y_pred has "
            f"{y_pred.shape[0]}; they must have the same length."
        )
    if y_true.shape[1] != y_pred.shape[1]:
        raise ValueError(
            f"y_true has {y_true.shape[1]} outputs but y_pred has {y_pred.shape[1]}."
        )
    if y_true.shape[0] == 0:
        raise ValueError("y_true and y_pred are empty; need at least one sample.")
    for name, y in (("y_true", y_true), ("y_pred", y_pred)):
        bad = ~np.isfinite(y)
        if bad.any():
            row, col = np.argwhere(bad)[0]
            where = f"row {row}" if y.shape[1] == 1 else f"row {row}, output {col}"
            raise ValueError(
                f"{name} has {int(bad.sum())} NaN or infinite value(s), the first "
                f"at {where} ({y[row, col]})."
            )
    if isinstance(multioutput, str):
        if multioutput not in _MULTIOUTPUT:
            raise ValueError(
                f"multioutput must be one of {list(_MULTIOUTPUT)} or an array of "
                f"output weights, got {multioutput!r}."
            )
        weights = multioutput
    else:
        try:
            weights = np.asarray(multioutput, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(
                f"multioutput weights must be numbers, got {multioutput!r}."
            ) from exc
        if weights.shape != (y_true.shape[1],):
            raise ValueError(
                f"multioutput weights have shape {weights.shape}, expected "
                f"({y_true.shape[1]},): one weight per output."
            )
        if not np.all(np.isfinite(weights)) or np.any(weights < 0):
            raise ValueError(
                "multioutput weights must be finite and 0 or more, got "
                f"{weights.tolist()}."
            )
        if not weights.sum() > 0:
            raise ValueError(
                "multioutput weights are all 0; give at least one output a "
                "positive weight."
            )
    return y_true, y_pred, weights


def _sample_weights(sample_weight, n):
    """Validated sample weights of ``n`` samples (None: all equal): 1-D,
    finite, 0 or more, not all 0."""
    if sample_weight is None:
        return None
    try:
        w = np.asarray(sample_weight, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"sample_weight must be numbers: {exc}") from exc
    if w.ndim == 0:
        w = np.full(n, float(w))
    if w.shape != (n,):
        raise ValueError(
            f"sample_weight has shape {w.shape}, expected ({n},): one weight "
            "per sample."
        )
    bad = ~np.isfinite(w) | (w < 0)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"sample_weight must be finite and 0 or more; row {row} has {w[row]}."
        )
    if not w.sum() > 0:
        raise ValueError(
            "sample_weight is 0 for every sample; give at least one sample a "
            "positive weight."
        )
    return w


def _weighted_mean(a, w, axis=0):
    """Mean over ``axis`` (weights ``w`` or None)."""
    return np.average(a, axis=axis, weights=w)


def _kept(y_true, y_pred, w):
    """The samples of positive weight (all without weights): a largest
    residual is not weighted, only left out at weight 0."""
    if w is None:
        return y_true, y_pred
    keep = w > 0
    return y_true[keep], y_pred[keep]


def _aggregate(values, weights):
    if isinstance(weights, str):
        if weights == "raw_values":
            return values
        weights = None
    return float(np.average(values, weights=weights))


def _ratio_score(num, den, force_finite):
    """``1 - num / den`` per output, with the constant-target convention.

    Where ``den == 0``: 1.0 when ``num == 0`` (perfect prediction) and 0.0
    otherwise if ``force_finite``; NaN and -inf otherwise.
    """
    zero = den == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        score = 1.0 - num / np.where(zero, 1.0, den)
    if zero.any():
        perfect = num == 0
        if force_finite:
            fill = np.where(perfect, 1.0, 0.0)
        else:
            fill = np.where(perfect, np.nan, -np.inf)
        score = np.where(zero, fill, score)
    return score


def rmse(y_true, y_pred, *, sample_weight=None, multioutput="uniform_average"):
    """Root mean squared error, ``sqrt(mean((z - p)^2))``.

    Parameters
    ----------
    y_true : array-like of shape (n_samples,) or (n_samples, n_outputs)
        Measured values.
    y_pred : array-like of shape (n_samples,) or (n_samples, n_outputs)
        Predicted values.
    sample_weight : array-like of shape (n_samples,), default=None
        Weight of every sample (e.g. to count runs of other lengths
        alike); None weighs them equally.
    multioutput : {"raw_values", "uniform_average"} or array-like of shape \
(n_outputs,), default="uniform_average"
        ``"raw_values"`` returns one value per output; otherwise the (weighted)
        mean over outputs.

    Returns
    -------
    float or ndarray of shape (n_outputs,)

    Raises
    ------
    ValueError
        If the shapes differ or a value is NaN or infinite.

    Examples
    --------
    >>> from skthermal.metrics import rmse
    >>> rmse([1.0, 2.0, 3.0], [1.0, 2.0, 5.0])
    1.1547005383792515
    >>> rmse([[1.0, 0.0], [3.0, 0.0]], [[2.0, 0.0], [4.0, 3.0]],
    ...      multioutput="raw_values")
    array([1.        , 2.12132034])
    """
    y_true, y_pred, weights = _check_targets(y_true, y_pred, multioutput)
    w = _sample_weights(sample_weight, y_true.shape[0])
    e, scale = _unit_columns(y_true - y_pred)
    values = scale * np.sqrt(_weighted_mean(e**2, w))
    return _aggregate(values, weights)


def _unit_columns(a, scale=None):
    """``a`` divided by each column's largest magnitude (or ``scale``), and
    that scale: squares of errors of 1e160 or 1e-170 neither overflow nor
    underflow, and the sums of squares keep their ratios."""
    if scale is None:
        scale = np.max(np.abs(a), axis=0, initial=0.0)
        scale = np.where(scale > 0, scale, 1.0)
    return a / scale, scale


def nash_sutcliffe(
    y_true,
    y_pred,
    *,
    sample_weight=None,
    multioutput="uniform_average",
    force_finite=True,
):
    """Nash-Sutcliffe efficiency, ``1 - sum (z - p)^2 / sum (z - mean z)^2``.

    1 is a perfect model, 0 a model no better than the mean of the measured
    values, negative values worse than that. It equals the coefficient of
    determination R² of :func:`sklearn.metrics.r2_score`.

    Parameters
    ----------
    y_true, y_pred, sample_weight, multioutput
        As in :func:`rmse` (with weights, the sums and the mean of ``z``
        are weighted, as in ``r2_score``).
    force_finite : bool, default=True
        What to return for an output whose measured values are constant
        (``sum (z - mean z)^2 = 0``): with ``True``, 1.0 if the prediction is
        exact and 0.0 otherwise (as ``r2_score``); with ``False``, NaN and
        -inf.

    Returns
    -------
    float or ndarray of shape (n_outputs,)

    Examples
    --------
    >>> from skthermal.metrics import nash_sutcliffe
    >>> nash_sutcliffe([1.0, 2.0, 3.0], [1.0, 2.0, 5.0])
    -1.0
    """
    y_true, y_pred, weights = _check_targets(y_true, y_pred, multioutput)
    w = _sample_weights(sample_weight, y_true.shape[0])
    e = y_true - y_pred
    d = y_true - _weighted_mean(y_true, w)
    # Each sum of squares on its own scale, and the ratio of the scales
    # squared apart: with one scale for both, errors of 1e300 left the
    # spread of the measured values underflowing to 0, a score of 0.
    e, e_scale = _unit_columns(e)
    d, d_scale = _unit_columns(d)
    sse = _weighted_mean(e**2, w)
    sst = _weighted_mean(d**2, w)
    with np.errstate(over="ignore", invalid="ignore"):
        # inf beyond float range (a score of -inf); no error is no error,
        # however small the spread.
        sse = np.where(sse > 0, sse * (e_scale / d_scale) ** 2, 0.0)
    return _aggregate(_ratio_score(sse, sst, force_finite), weights)


def pearson_r(y_true, y_pred, *, sample_weight=None, multioutput="uniform_average"):
    """Pearson's correlation coefficient R between measured and predicted values.

    Parameters
    ----------
    y_true, y_pred, sample_weight, multioutput
        As in :func:`rmse` (with weights, the weighted correlation: weighted
        means, covariance and variances).

    Returns
    -------
    float or ndarray of shape (n_outputs,)
        R in [-1, 1] per output (or their mean). R is undefined, and NaN is
        returned for that output with an ``UndefinedMetricWarning``, when
        ``y_true`` or ``y_pred`` is constant in it (or has a single sample);
        the mean over the outputs is then NaN too (pass
        ``multioutput="raw_values"`` for the others). As a scorer, a model
        that predicts a constant scores NaN, which a search ranks as
        undefined rather than as bad.

    Examples
    --------
    >>> from skthermal.metrics import pearson_r
    >>> pearson_r([1.0, 2.0, 3.0], [2.0, 4.0, 6.0])
    1.0
    >>> pearson_r([1.0, 2.0, 3.0], [1.0, 3.0, 2.0])
    0.5
    """
    y_true, y_pred, weights = _check_targets(y_true, y_pred, multioutput)
    w = _sample_weights(sample_weight, y_true.shape[0])
    if w is not None:  # samples of weight 0 count for nothing
        keep = w > 0
        y_true, y_pred, w = y_true[keep], y_pred[keep], w[keep]
    # Deviations in units of their largest: R does not depend on the scale,
    # and products of 1e-170s or 1e160s neither underflow nor overflow.
    dt = _unit_columns(y_true - _weighted_mean(y_true, w))[0]
    dp = _unit_columns(y_pred - _weighted_mean(y_pred, w))[0]
    den = np.sqrt(_weighted_mean(dt**2, w) * _weighted_mean(dp**2, w))
    # Constant by its values, not by the rounding of its mean (0.1 three
    # times leaves deviations of 1e-17, a correlation of 0 or 1e-16).
    constant = (np.ptp(y_true, axis=0) == 0) | (np.ptp(y_pred, axis=0) == 0)
    if constant.any():
        sides = [
            name
            for name, values in (("y_true", y_true), ("y_pred", y_pred))
            if (np.ptp(values, axis=0) == 0).any()
        ]
        which = " or ".join(sides)
        warnings.warn(
            f"Pearson's R is undefined where {which} is constant (or a single "
            f"sample): NaN for {int(constant.sum())} of {constant.size} output(s).",
            UndefinedMetricWarning,
            stacklevel=2,
        )
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where((den > 0) & ~constant, _weighted_mean(dt * dp, w) / den, np.nan)
    return _aggregate(np.clip(r, -1.0, 1.0), weights)


def residual_band(y_true, y_pred, *, sample_weight=None, multioutput="uniform_average"):
    """Largest absolute residual, ``max |z - p|``.

    A compensated test whose residual stays within ±4 µm has a residual band
    of 4 µm.

    Parameters
    ----------
    y_true, y_pred, sample_weight, multioutput
        As in :func:`rmse`; a largest residual is not weighted: samples of
        weight 0 are left out, the others count alike.

    Returns
    -------
    float or ndarray of shape (n_outputs,)

    Examples
    --------
    >>> from skthermal.metrics import residual_band
    >>> residual_band([10.0, 20.0, 30.0], [12.0, 17.0, 31.0])
    3.0
    """
    y_true, y_pred, weights = _check_targets(y_true, y_pred, multioutput)
    w = _sample_weights(sample_weight, y_true.shape[0])
    y_true, y_pred = _kept(y_true, y_pred, w)
    return _aggregate(np.max(np.abs(y_true - y_pred), axis=0), weights)


def improvement(
    y_true,
    y_pred,
    *,
    sample_weight=None,
    multioutput="uniform_average",
    force_finite=True,
):
    """Share of the peak error removed by compensation, ``1 - max|z - p| / max|z|``.

    ``y_true`` is the error before compensation (typically the displacement
    since the start of the run) and ``y_true - y_pred`` the residual after
    it: 0.94 means the peak error fell by 94%.

    Parameters
    ----------
    y_true, y_pred, sample_weight, multioutput
        As in :func:`residual_band` (samples of weight 0 left out).
    force_finite : bool, default=True
        What to return for an output whose measured values are all zero: with
        ``True``, 1.0 if the prediction is exact and 0.0 otherwise; with
        ``False``, NaN and -inf.

    Returns
    -------
    float or ndarray of shape (n_outputs,)

    Examples
    --------
    >>> from skthermal.metrics import improvement
    >>> improvement([10.0, 20.0, 40.0], [12.0, 17.0, 38.0])
    0.925
    """
    y_true, y_pred, weights = _check_targets(y_true, y_pred, multioutput)
    w = _sample_weights(sample_weight, y_true.shape[0])
    y_true, y_pred = _kept(y_true, y_pred, w)
    band = np.max(np.abs(y_true - y_pred), axis=0)
    peak = np.max(np.abs(y_true), axis=0)
    return _aggregate(_ratio_score(band, peak, force_finite), weights)
