"""Evidence for model-structure selection: likelihood-ratio tests, information
criteria, residual whiteness and the explainable part of a gap.

Grey-box thermal identification (CTSM-R; the forward selection of Leprince,
Madsen et al., Energy & Buildings 2021) grows a model one extension at a
time: the extension with the largest likelihood gain is kept when the
likelihood-ratio test against the smaller model gives p < 0.05, and the
residuals of the final model should be white, judged by their cumulated
periodogram. These functions give the same figures for any pair of nested
models fitted by least squares with Gaussian residuals.

Residuals of thermal models sampled every few seconds are strongly
autocorrelated, and a test that counts every sample as independent finds
every extension "significant". :func:`effective_samples` shortens the sample
count by the residual's correlation time; pass it as ``n`` to
:func:`likelihood_ratio`.
"""

import logging
from dataclasses import dataclass

import numpy as np
from scipy import stats

from skthermal.gap._scores import excess_shrink, gap_of

logger = logging.getLogger("skthermal.gap")


def _as_series(residual):
    """A list of 1-D float arrays (one per run) from an array or a list."""
    if isinstance(residual, list | tuple):
        series = [np.asarray(r, dtype=float) for r in residual]
    else:
        series = [np.asarray(residual, dtype=float)]
    out = []
    for r in series:
        if r.ndim == 2:
            r = r.sum(axis=1)
        if r.ndim != 1:
            raise ValueError(
                f"A residual must be 1-D (samples) or 2-D (samples, channels); "
                f"got shape {r.shape}."
            )
        if not np.all(np.isfinite(r)):
            raise ValueError("The residual has missing or infinite values.")
        out.append(r)
    return out


def lag1_correlation(residual):
    """Lag-1 autocorrelation of a residual, pooled over runs.

    Parameters
    ----------
    residual : array-like of shape (n,) or (n, n_channels), or list of them
        One series per run; with channels, their sum is used.

    Returns
    -------
    float
        In [-1, 1]; 0 for a constant series.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.gap._evidence import lag1_correlation
    >>> round(lag1_correlation(np.sin(np.linspace(0, 3, 200))), 2)
    0.98
    """
    num = den = 0.0
    for r in _as_series(residual):
        r = r - r.mean()
        num += float(r[1:] @ r[:-1])
        den += float(r @ r)
    return float(np.clip(num / den, -1.0, 1.0)) if den > 0 else 0.0


def effective_samples(residual, *, per_channel=False):
    """Number of independent samples in an autocorrelated residual.

    ``n (1 - rho) / (1 + rho)`` for an AR(1) residual of lag-1 correlation
    ``rho`` (clipped to [0, 0.99]), summed over runs; at least 1.

    Parameters
    ----------
    residual : array-like of shape (n,) or (n, n_channels), or list of them
    per_channel : bool, default=False
        With channels: one figure per channel (default: of their sum).

    Returns
    -------
    float, or ndarray of shape (n_channels,) with ``per_channel``

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.gap._evidence import effective_samples
    >>> rng = np.random.default_rng(0)
    >>> white = rng.standard_normal(1000)
    >>> 850 < effective_samples(white) < 1150
    True
    >>> from scipy.signal import lfilter
    >>> slow = lfilter([1.0], [1.0, -0.9], white)
    >>> effective_samples(slow) < 100
    True
    >>> effective_samples(np.column_stack([white, slow]), per_channel=True) < 200
    array([False,  True])
    """
    if per_channel:
        runs = residual if isinstance(residual, list | tuple) else [residual]
        runs = [np.atleast_2d(np.asarray(r, dtype=float).T).T for r in runs]
        return np.array(
            [
                effective_samples([r[:, j] for r in runs])
                for j in range(runs[0].shape[1])
            ]
        )
    series = _as_series(residual)
    rho = float(np.clip(lag1_correlation(series), 0.0, 0.99))
    n = sum(r.size for r in series)
    return max(float(n) * (1.0 - rho) / (1.0 + rho), 1.0)


@dataclass(frozen=True)
class LikelihoodRatio:
    """Likelihood-ratio test of a model against a smaller one nested in it.

    Attributes
    ----------
    statistic : float
        ``n log(rss0 / rss1)``: twice the gain of the Gaussian log-likelihood.
    p_value : float
        Chi-squared survival function of ``statistic`` with ``df`` degrees of
        freedom.
    df : int
        Extra parameters of the larger model.
    delta_aic, delta_bic : float
        Change of the information criteria (negative: the larger model is
        preferred).
    n : float
        Samples the likelihood counts (effective samples).
    """

    statistic: float
    p_value: float
    df: int
    delta_aic: float
    delta_bic: float
    n: float


def likelihood_ratio(rss0, rss1, n, extra_params):
    """Likelihood-ratio test and information criteria of two nested fits.

    For least-squares fits with Gaussian residuals of unknown variance, the
    maximised log-likelihood is ``-n/2 log(rss/n) + const``, so the test
    statistic is ``n log(rss0 / rss1)``, chi-squared with ``extra_params``
    degrees of freedom under the smaller model (Wilks), and ``AIC = n
    log(rss/n) + 2k``, ``BIC = n log(rss/n) + k log n``. With several
    channels, each of its own noise variance, the log-likelihoods add up:
    pass arrays (one entry per channel) and the statistic is
    ``sum_c n_c log(rss0_c / rss1_c)``.

    Parameters
    ----------
    rss0, rss1 : float or array-like of shape (n_channels,)
        Residual sums of squares of the smaller and the larger model (on the
        same data).
    n : float or array-like of shape (n_channels,)
        Number of samples; with autocorrelated residuals, the effective
        number (:func:`effective_samples` of the smaller model's residual).
    extra_params : int
        Parameters the larger model adds in all (>= 1).

    Returns
    -------
    LikelihoodRatio

    Examples
    --------
    >>> from skthermal.gap._evidence import likelihood_ratio
    >>> lr = likelihood_ratio(10.0, 8.0, n=100, extra_params=1)
    >>> round(lr.statistic, 2), lr.p_value < 0.001, lr.delta_aic < 0
    (22.31, True, True)
    >>> likelihood_ratio(10.0, 9.99, n=100, extra_params=3).p_value > 0.5
    True
    >>> likelihood_ratio([10.0, 5.0], [8.0, 5.0], n=[100, 100],
    ...                  extra_params=2).df
    2
    """
    rss0, rss1, n = np.broadcast_arrays(
        np.asarray(rss0, dtype=float),
        np.asarray(rss1, dtype=float),
        np.asarray(n, dtype=float),
    )
    if not (
        np.all(rss0 > 0)
        and np.all(rss1 > 0)
        and np.all(np.isfinite(rss0))
        and np.all(np.isfinite(rss1))
    ):
        raise ValueError(
            f"The residual sums of squares must be positive and finite; got "
            f"rss0={rss0!r}, rss1={rss1!r}."
        )
    if not np.all(n >= 1):
        raise ValueError(f"n must be at least 1, got {n!r}.")
    k = int(extra_params)
    if k < 1:
        raise ValueError(f"extra_params must be at least 1, got {extra_params!r}.")
    ll = float(np.sum(n * np.log(rss1 / rss0)))
    stat = max(-ll, 0.0)
    n_total = float(np.sum(n))
    return LikelihoodRatio(
        statistic=float(stat),
        p_value=float(stats.chi2.sf(stat, k)),
        df=k,
        delta_aic=float(ll + 2 * k),
        delta_bic=float(ll + k * np.log(n_total)),
        n=n_total,
    )


def cumulated_periodogram(residual):
    """Cumulated periodogram of a residual, pooled over runs.

    Each run's periodogram (Fourier frequencies above zero) is divided by its
    mean, so runs of different amplitude count alike; the ordinates of all
    runs are sorted by frequency (as a fraction of the Nyquist frequency) and
    cumulated. For white noise the curve follows the diagonal.

    Parameters
    ----------
    residual : array-like of shape (n,) or (n, n_channels), or list of them

    Returns
    -------
    frequency : ndarray of shape (m,)
        Fractions of the Nyquist frequency, in (0, 1].
    cumulated : ndarray of shape (m,)
        Cumulated normalised periodogram, ending at 1.

    Examples
    --------
    >>> import numpy as np
    >>> from skthermal.gap._evidence import cumulated_periodogram
    >>> f, c = cumulated_periodogram(np.random.default_rng(0).standard_normal(64))
    >>> f.shape, round(float(c[-1]), 6)
    ((32,), 1.0)
    """
    freqs, powers = [], []
    for r in _as_series(residual):
        if r.size < 4:
            continue
        p = np.abs(np.fft.rfft(r - r.mean()))[1:] ** 2
        f = np.fft.rfftfreq(r.size)[1:] / 0.5
        if p.sum() <= 0:
            continue
        freqs.append(f)
        powers.append(p / p.mean())
    if not freqs:
        raise ValueError(
            "The cumulated periodogram needs a non-constant residual of at least "
            "4 samples."
        )
    f = np.concatenate(freqs)
    p = np.concatenate(powers)
    order = np.argsort(f, kind="stable")
    c = np.cumsum(p[order])
    return f[order], c / c[-1]


def whiteness(residual):
    """How white a residual is: its cumulated periodogram against the
    Kolmogorov-Smirnov band.

    Parameters
    ----------
    residual : array-like of shape (n,) or (n, n_channels), or list of them

    Returns
    -------
    dict
        ``max_deviation`` (largest distance of the cumulated periodogram
        from the diagonal), ``band`` (half-width of the 95% Kolmogorov-Smirnov
        band, ``1.358 / (sqrt(m - 1) + 0.12 + 0.11 / sqrt(m - 1))`` for ``m``
        ordinates), ``white`` (the curve stays inside the band), ``lag1``
        (lag-1 autocorrelation) and ``effective_samples``.

    Notes
    -----
    The test of the cumulated periodogram is that of Box, Jenkins and Reinsel
    (Time Series Analysis, 4th ed., section 8.2.6), as R's ``cpgram``; grey-box
    thermal modelling (CTSM-R) uses it to accept a model structure.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.signal import lfilter
    >>> from skthermal.gap._evidence import whiteness
    >>> e = np.random.default_rng(0).standard_normal(500)
    >>> whiteness(e)["white"], whiteness(lfilter([1.0], [1.0, -0.8], e))["white"]
    (True, False)
    """
    f, c = cumulated_periodogram(residual)
    m = f.size
    # The uniform line: the share of ordinates up to each one.
    uniform = np.arange(1, m + 1) / m
    dev = float(np.max(np.abs(c - uniform)))
    root = np.sqrt(max(m - 1, 1))
    band = float(1.358 / (root + 0.12 + 0.11 / root))
    return {
        "max_deviation": dev,
        "band": band,
        "white": bool(dev <= band),
        "lag1": lag1_correlation(residual),
        "effective_samples": effective_samples(residual),
    }


# The least share of a feature's norm over all runs that scales it in a
# fold (see ridge_heldout).
EXCITATION = 0.1


def _well_posed(Gs, free):
    """The standardised Gram matrices ``Gs`` (c, k, k) with a unit diagonal
    where an unpenalised feature (``free``) is zero on the training runs
    (a constant simulated channel): its weight is then 0 instead of the
    system being singular. Features that are not zero are left untouched."""
    zero = free & (np.einsum("ckk->ck", Gs) <= 1e-12)
    if not zero.any():
        return Gs
    return Gs + zero[:, :, None] * np.eye(Gs.shape[-1])


def ridge_heldout(targets, features, folds, *, alphas=None, penalize=None):
    """Held-out residuals of a per-channel ridge regression over runs.

    For every fold, each channel's target is regressed on its features over
    the training runs (the penalty chosen by leave-one-run-out over the
    training runs among ``alphas``), and the held-out runs are predicted.
    The features are standardised on the training runs, each scaled by its
    norm there but by at least ``EXCITATION`` (a tenth) of its norm over all
    the runs given, held-out ones included (features, never targets): a
    feature the training runs barely excite (a speed change that happens
    only in a held-out run) then gets a weight near zero instead of one
    scaled up to the training runs' tiny variation, which on the held-out
    run would blow up.

    Parameters
    ----------
    targets : list of array of shape (n_i, c)
        One array per run.
    features : list of array of shape (n_i, c, k)
        Features of every channel (the same ``k`` for all channels).
    folds : list of (train, test)
        Run indices.
    alphas : array-like, optional
        Candidate penalties (relative to the standardised Gram matrix
        diagonal); default ``np.logspace(-4, 2, 7)``.
    penalize : array-like of bool of shape (k,), optional
        Features the penalty applies to (default: all).

    Returns
    -------
    list of array of shape (n_i, c)
        Held-out residuals (target minus prediction) of every run.
    """
    alphas = np.logspace(-4, 2, 7) if alphas is None else np.asarray(alphas, float)
    n_runs = len(targets)
    k = features[0].shape[2]
    pen = np.ones(k) if penalize is None else np.asarray(penalize, float)
    gram = [np.einsum("nck,ncl->ckl", F, F) for F in features]
    cross = [np.einsum("nck,nc->ck", F, y) for F, y in zip(features, targets)]
    out = [None] * n_runs
    free = pen == 0
    # A feature's scale is its norm on the training runs, but at least a
    # tenth of its norm over all the runs.
    floor = EXCITATION * np.sqrt(np.einsum("ckk->ck", sum(gram)))
    for train, test in folds:
        train = list(train)
        G = sum(gram[i] for i in train)
        d = np.sqrt(np.maximum(np.einsum("ckk->ck", G), 1e-300))
        d = np.maximum(d, floor)
        scale = d[:, :, None] * d[:, None, :]
        Gs = G / scale
        best_alpha = np.full(G.shape[0], alphas[0])
        if len(train) > 1:
            b = sum(cross[i] for i in train)
            sse = np.zeros((alphas.size, G.shape[0]))
            for i in train:
                Gi = _well_posed((G - gram[i]) / scale, free)
                bi = (b - cross[i]) / d
                for a, alpha in enumerate(alphas):
                    A = Gi + alpha * np.eye(k) * pen
                    w = np.linalg.solve(A, bi[..., None])[..., 0] / d
                    r = targets[i] - np.einsum("nck,ck->nc", features[i], w)
                    sse[a] += np.sum(r * r, axis=0)
            # One penalty for all channels: the choice of a penalty per
            # channel from a few training runs is itself noisy.
            best_alpha = np.full(G.shape[0], alphas[np.argmin(sse.sum(axis=1))])
        b = sum(cross[i] for i in train) / d
        A = _well_posed(Gs, free) + best_alpha[:, None, None] * np.eye(k) * pen
        w = np.linalg.solve(A, b[..., None])[..., 0] / d
        for i in test:
            out[i] = targets[i] - np.einsum("nck,ck->nc", features[i], w)
    return out


def explainable_gap(gap_before, gap_flexible, floor2):
    """Share of a held-out gap above the noise floor that a flexible
    discrepancy model removes: the part any added term could close.

    Parameters
    ----------
    gap_before : float
        Held-out gap of the base model (RMS).
    gap_flexible : float
        Held-out gap with the flexible discrepancy model of the drivers added
        (fitted on training runs, e.g. with :func:`ridge_heldout`).
    floor2 : float
        Squared gap that noise alone would leave.

    Returns
    -------
    float
        At most 1; negative when the flexible model makes the held-out gap
        worse (it is regularised and fitted on training runs, so it is an
        estimate of what a term could close, not a strict bound).

    Examples
    --------
    >>> from skthermal.gap._evidence import explainable_gap
    >>> round(explainable_gap(1.0, 0.6, 0.0), 2)
    0.4
    >>> round(explainable_gap(1.0, 1.2, 0.0), 2)
    -0.2
    """
    return excess_shrink(gap_before, gap_flexible, floor2)


def share_of_explainable(shrink, explainable):
    """A shrink (above noise) as a share of the explainable part
    (:func:`explainable_gap`), not clipped: above 1 when a term removes
    more of the held-out gap than the flexible model (regularised, it may
    fall short of a term it contains); NaN when the flexible model removes
    nothing (there is no share of nothing).

    Examples
    --------
    >>> from skthermal.gap._evidence import share_of_explainable
    >>> share_of_explainable(0.3, 0.6), share_of_explainable(0.3, -0.1)
    (0.5, nan)
    """
    return float(shrink / explainable) if explainable > 0 else float("nan")


def explainable_summary(base_R, flexible_R, floor2):
    """What the flexible discrepancy model makes of the base's held-out gap.

    Parameters
    ----------
    base_R, flexible_R : list of ndarray
        Held-out residuals of every run, of the base and with the flexible
        model.
    floor2 : float
        Squared gap that noise alone would leave.

    Returns
    -------
    dict
        ``gap_before`` and ``gap_after`` (held out), ``share`` (of the gap
        above noise it removes, :func:`explainable_gap`) and the whiteness of
        its residual (``whiteness_after``, ``white_band``, ``white_after``):
        the ``explainable`` of a gap report.
    """
    gap_base = gap_of(base_R)[0]
    gap_flex = gap_of(flexible_R)[0]
    share = explainable_gap(gap_base, gap_flex, floor2)
    white = _whiteness_or_none(flexible_R)
    logger.info(
        "Base held-out gap %.3g; a flexible model of the drivers reaches %.3g "
        "(%.0f%% of the excess above noise).",
        gap_base,
        gap_flex,
        100 * share,
    )
    return {
        "gap_before": gap_base,
        "gap_after": gap_flex,
        "share": share,
        "whiteness_after": white["max_deviation"],
        "white_band": white["band"],
        "white_after": white["white"],
    }


def residual_lr_test(before, after, extra_params):
    """:func:`likelihood_ratio` of two fits from their in-sample residuals.

    Per channel (each with its own noise variance), with the samples counted
    by their effective number (:func:`effective_samples` of ``before``);
    ``after`` is taken as no worse than ``before`` channel by channel (a
    nested fit cannot be).

    Parameters
    ----------
    before, after : list of ndarray of shape (n_i, n_channels)
        Residuals of every run of the smaller and the larger fit.
    extra_params : int
        Parameters the larger fit adds (at least 1 is counted).

    Returns
    -------
    LikelihoodRatio
    """
    rss0 = np.maximum(sum(np.sum(R * R, axis=0) for R in before), 1e-300)
    rss1 = np.maximum(sum(np.sum(R * R, axis=0) for R in after), 1e-300)
    return likelihood_ratio(
        rss0,
        np.minimum(rss1, rss0),
        effective_samples(list(before), per_channel=True),
        max(int(extra_params), 1),
    )


def _whiteness_or_none(residual):
    """:func:`whiteness` of ``residual``, or NaN figures (``white`` None)
    when it has no periodogram (every run shorter than 4 compared samples,
    or constant)."""
    try:
        return whiteness(residual)
    except ValueError:
        return {"max_deviation": np.nan, "band": np.nan, "white": None}


def whiteness_columns(before, after):
    """The whiteness columns of a ranking row: the largest deviation of the
    cumulated periodogram of the held-out residuals ``before`` and ``after``
    a candidate, the 95% band and whether ``after`` is white
    (:func:`whiteness`; NaN and None when a residual has no periodogram)."""
    white_b, white_a = _whiteness_or_none(before), _whiteness_or_none(after)
    return {
        "whiteness_before": white_b["max_deviation"],
        "whiteness_after": white_a["max_deviation"],
        "white_band": white_a["band"],
        "white_after": white_a["white"],
    }
