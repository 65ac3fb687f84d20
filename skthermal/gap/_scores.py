"""Shared scoring vocabulary of the gap diagnosis (both modes and the
report): frequency bands, held-out folds over runs, the gap of a set of
runs, its shrink above the noise floor, the paired block test, the gap per
regime."""

import re
from numbers import Integral, Real

import numpy as np
import pandas as pd
from scipy import stats
from sklearn.model_selection import GroupKFold, LeaveOneGroupOut, check_cv
from sklearn.utils._param_validation import Interval

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


# A sensor's drift beyond this many °C per hour (the root mean square of
# the fitted rates over the temperature channels; 2.4 °C a day) is not a
# sensor's drift: thermocouples and resistance thermometers drift by
# fractions of a degree over months. A trend that fast is a heat load the
# simulation lacks (or its own slow error), so `sensor_drift` is not named
# for it. The rule reads the spread over the sensors, as the simulator's
# rate_C_per_h: a rule on the fastest sensor would rule out the spread of
# the simulator's own drift (its fastest of 77 sensors 2.4 times the root
# mean square); one drifting sensor among n quiet ones is ruled out from
# 0.1 * sqrt(n) °C/h.
MAX_DRIFT_C_PER_H = 0.1


# A sensor's own lag (its bead, cement or contact resistance) beyond this
# many seconds is not a sensor's lag: a time constant of hours is the
# structure's, which a lag term fitted that slow stands in for.
MAX_SENSOR_LAG_S = 3600.0


# A fitted parameter within this relative distance (on a log scale) of an
# end of its search range sits on that end.
ON_BOUND_LOG = 0.02


def on_bound(values, bounds, open_ends=None):
    """``"tau_s = 1200 (the lower end of 1200-28800)"`` for the parameters of
    ``values`` (name -> fitted value) that sit on an end of their ``bounds``
    (name -> (low, high), both positive), joined by "; "; ``""`` for none.
    A parameter on its bound was stopped by the range, not by the data: the
    term may stand in for something else. ``open_ends`` (name -> "lower"
    or "upper"): ends left out, which physics reaches (a term's own value
    may lie there).

    Examples
    --------
    >>> from skthermal.gap._scores import on_bound
    >>> on_bound({"tau_s": 1200.0, "exponent": 0.8},
    ...          {"tau_s": (1200.0, 28800.0), "exponent": (0.5, 1.5)})
    'tau_s = 1200 (the lower end of 1200-28800)'
    """
    said = []
    for name, value in values.items():
        low, high = bounds.get(name, (None, None))
        if low is None or not (np.isfinite(value) and value > 0):
            continue
        for end, which in ((low, "lower"), (high, "upper")):
            if (open_ends or {}).get(name) == which:
                continue
            if abs(np.log(value / end)) <= ON_BOUND_LOG:
                span = f"{low:g}-{high:g}"
                said.append(f"{name} = {value:.4g} (the {which} end of {span})")
    return "; ".join(said)


def ruled_out(effect, fitted, rates=None):
    """Why the fitted value rules ``effect`` out as the explanation (``""``
    when it does not): a ``sensor_drift`` faster than
    :data:`MAX_DRIFT_C_PER_H`, a ``sensor_lag`` slower than
    :data:`MAX_SENSOR_LAG_S`. ``fitted`` is the ranking's value (a float,
    or the run-table mode's dict of parameters); ``rates``: the drift's
    fitted rate of every temperature sensor (``{name: °C/h}``), for the
    message (the fastest is named)."""
    key, limit = {
        "sensor_drift": ("rate_C_per_h", MAX_DRIFT_C_PER_H),
        "sensor_lag": ("tau_s", MAX_SENSOR_LAG_S),
    }.get(effect, (None, None))
    if key is None:
        return ""
    value = fitted.get(key) if isinstance(fitted, dict) else fitted
    if value is None or not np.isfinite(value) or value <= limit:
        return ""
    if effect == "sensor_lag":
        return (
            f"a lag of {value:.0f} s is beyond a sensor's own (at most "
            f"{limit:.0f} s): the structure's slower response is likelier"
        )
    fastest = ""
    if rates:
        sensor, rate = max(rates.items(), key=lambda item: abs(item[1]))
        fastest = f"; the fastest, {sensor!r}, {rate:+.2g} °C/h"
    n = f" {len(rates)}" if rates else ""
    return (
        f"drift rates of {value:.3g} °C/h (root mean square over the{n} "
        f"temperature sensors{fastest}) are beyond a sensor's drift (at most "
        f"{limit:g} °C/h): a heat load the simulation lacks (or a faulty "
        "sensor) is likelier"
    )


# Parameter constraints both diagnoses share (candidates, held-out scheme,
# channels, decision rule, sampling, parallelism), for validate_params.
DIAGNOSIS_PARAMS = {
    "candidates": [None, str, list, tuple],
    "cv": [None, Interval(Integral, 2, None, closed="left"), "cv_object"],
    "channels": [None, list, tuple],
    "mapping": [None, dict],
    "min_shrink": [Interval(Real, 0, 1, closed="right")],
    "alpha": [Interval(Real, 0, 1, closed="neither")],
    "greedy": ["boolean"],
    "max_samples": [Interval(Integral, 10, None, closed="left")],
    # joblib's meaning: 1 or more processes, or -1 all cores, -2 all but one..
    "n_jobs": [
        None,
        Interval(Integral, None, -1, closed="right"),
        Interval(Integral, 1, None, closed="left"),
    ],
    "block_hours": [None, Interval(Real, 0, None, closed="neither")],
}


# The order of the candidates, best first: those that explain the gap,
# then by held-out shrink. The candidates are alternatives, not nested
# models: each adds its own term or effect to the same base, and how many
# parameters it adds mostly counts the channels it acts on. Parsimony is
# already in each candidate's own tests against the base (the likelihood
# ratio's degrees of freedom; the held-out score, which an over-fitted
# candidate does not win), so there is no second rule that prefers the
# candidate with fewer parameters.
RANK_BY = ("explains", "shrink")


def rank_key(row):
    """Sort key of one ranking row (a mapping), best first with
    ``reverse=True``."""
    return tuple(row[k] for k in RANK_BY)


def order_candidates(ranking):
    """The ranking table sorted best first (:data:`RANK_BY`, stable)."""
    return ranking.sort_values(
        list(RANK_BY), ascending=False, kind="stable"
    ).reset_index(drop=True)


# Least excess of a gap over the noise floor (RMS, as a share of the
# floor) that an effect may be named for: a base within this of the noise
# (gap < 1.25 x floor) matches the measurement as far as the data tell, and
# the share of an excess that small that a term removes says nothing (on
# null data, a noise-level term "removed 100% of the gap above noise" while
# the gap fell by 2%, at p = 0.04). The floor is itself estimated: on
# simulations plus white noise the base's held-out gap came out 1.01-1.17
# times it.
MIN_EXCESS = 0.75


def beyond_noise(gap_b, floor2):
    """Whether the gap ``gap_b`` exceeds the noise floor (``floor2``, its
    square) by at least :data:`MIN_EXCESS` of it, so that an effect can
    explain something."""
    return bool(gap_b**2 - floor2 >= MIN_EXCESS**2 * floor2)


def excess_shrink(gap_b, gap_a, floor2):
    """Share of the gap above the noise floor removed: ``1 - excess after /
    excess before``, the excess being ``sqrt(gap^2 - floor^2)``."""
    ex_b = np.sqrt(max(gap_b**2 - floor2, 0.0))
    ex_a = np.sqrt(max(gap_a**2 - floor2, 0.0))
    return float(1.0 - ex_a / ex_b) if ex_b > 0 else 0.0


def candidate_list(candidates, vocabulary, present=()):
    """The candidate effects to test, checked, in the vocabulary's order.

    Parameters
    ----------
    candidates : str, sequence of str or None
        None: every effect of ``vocabulary`` not in ``present``.
    vocabulary : sequence of str
        The effects the diagnosis can test.
    present : sequence of str, default=()
        Effects the simulation already has on (they cannot be candidates).

    Returns
    -------
    list of str

    Raises
    ------
    ValueError
        For an unknown effect, an effect already on, or no candidate at all
        (saying so when every effect of the vocabulary is already on).
    """
    vocabulary = list(vocabulary)
    if candidates is None:
        candidates = [e for e in vocabulary if e not in present]
        if not candidates:
            raise ValueError(
                "Give at least one candidate effect: the simulation already has "
                f"every effect of the vocabulary on ({list(present)}), so none is "
                "left to test."
            )
    candidates = [candidates] if isinstance(candidates, str) else list(candidates)
    unknown = [c for c in candidates if c not in vocabulary]
    if unknown:
        raise ValueError(
            f"Unknown effect(s) {unknown}; the vocabulary is {vocabulary}."
        )
    if not candidates:
        raise ValueError("Give at least one candidate effect.")
    already = [c for c in candidates if c in present]
    if already:
        raise ValueError(
            f"The simulation already has {already}; they cannot be candidates."
        )
    return [e for e in vocabulary if e in candidates]


def applicable(candidates, not_applicable):
    """``candidates`` without those in ``not_applicable`` (``{effect:
    reason}``); a ValueError with every reason when none is left."""
    left = [c for c in candidates if c not in not_applicable]
    if not left:
        raise ValueError(
            "None of the candidate effects can act on these runs: "
            + "; ".join(f"{e}: {why}" for e, why in not_applicable.items())
            + "."
        )
    return left


def _natural_key(label):
    """Sort key of a run label with its numbers compared as numbers: run 2
    before run 10, and the blocks of a record (``r1[8-16 h]``,
    ``r1[16-24 h]``) in time order."""
    parts = re.split(r"(\d+(?:\.\d+)?)", str(label))
    return [(0, float(p), "") if k % 2 else (1, 0.0, p) for k, p in enumerate(parts)]


def heldout_folds(n_runs, cv, labels=None):
    """(train, test) run indices: leave-one-run-out for up to 3 runs, else
    3-fold GroupKFold; an int is a number of GroupKFold splits; a splitter
    splits the runs (each run one group); an iterable of (train, test)
    index arrays gives the folds over the runs (in their order in the
    table, blocks of ``block_hours`` counting as runs).

    With the runs' ``labels``, the default and an int's GroupKFold group
    the runs by their labels in sorted order, so the folds hold the same
    runs whatever their order in the table."""
    groups = np.arange(n_runs)
    if labels is not None and (cv is None or isinstance(cv, Integral)):
        order = sorted(range(n_runs), key=lambda i: _natural_key(labels[i]))
        groups = np.empty(n_runs, dtype=int)
        groups[order] = np.arange(n_runs)
    if cv is None:
        cv = LeaveOneGroupOut() if n_runs <= 3 else GroupKFold(n_splits=3)
    elif isinstance(cv, Integral) and not isinstance(cv, bool):
        if cv > n_runs:
            raise ValueError(
                f"cv={cv} holds out the runs in {cv} folds, but there are only "
                f"{n_runs} runs; give cv <= {n_runs}."
            )
        cv = GroupKFold(n_splits=int(cv))
    else:
        cv = check_cv(cv)
    X = np.zeros((n_runs, 1))
    try:
        folds = [
            (np.asarray(tr).ravel(), np.asarray(te).ravel())
            for tr, te in cv.split(X, groups=groups)
        ]
    except (ValueError, TypeError) as exc:
        raise ValueError(
            f"The held-out scheme cv={cv!r} cannot split the {n_runs} runs (each "
            f"run is one sample and one group here): "
            f"{str(exc).replace('n_samples', 'runs')}"
        ) from exc
    if not folds:
        raise ValueError(f"The held-out scheme cv={cv!r} gave no fold.")
    for k, (tr, te) in enumerate(folds):
        for what, idx in (("training", tr), ("held-out", te)):
            ok = (
                idx.size > 0
                and np.issubdtype(idx.dtype, np.integer)
                and idx.min() >= 0
                and idx.max() < n_runs
            )
            if not ok:
                raise ValueError(
                    f"Fold {k} of cv has {what} runs {idx.tolist()}: every fold "
                    f"needs at least one training and one held-out run, given as "
                    f"run indices 0-{n_runs - 1} (runs in their order in the table)."
                )
        both = np.intersect1d(tr, te)
        if both.size:
            raise ValueError(
                f"Fold {k} of cv trains on its held-out run(s) {both.tolist()}: "
                "a held-out run must not be a training run of the same fold."
            )
    # Every run is held out exactly once: the held-out gap is scored on all
    # of them, each predicted by one model that did not see it.
    held = np.concatenate([te for _, te in folds])
    counts = np.bincount(held, minlength=n_runs)
    if np.any(counts != 1):
        never = np.flatnonzero(counts == 0).tolist()
        twice = np.flatnonzero(counts > 1).tolist()
        what = []
        if never:
            what.append(f"run(s) {never} are never held out")
        if twice:
            what.append(f"run(s) {twice} are held out more than once")
        raise ValueError(
            f"The held-out scheme cv={cv!r}: {' and '.join(what)}; the folds "
            f"must hold out each of the {n_runs} runs exactly once (as "
            "GroupKFold or LeaveOneGroupOut do)."
        )
    return folds


def run_ms(R):
    """Mean over samples of the weighted squared normalised residual."""
    return float(np.mean(np.sum(R * R, axis=1))) if R.size else 0.0


def gap_of(Rs):
    """Gap of a set of runs (pooled weighted RMS residual) and each run's
    mean squared residual."""
    n = np.array([R.shape[0] for R in Rs], dtype=float)
    ms = np.array([run_ms(R) for R in Rs])
    return float(np.sqrt(np.sum(n * ms) / n.sum())), ms


def block_test(before, after, n_blocks=3):
    """One-sided paired t-test of the squared-error reduction over time blocks.

    Each held-out run is cut into ``n_blocks`` contiguous blocks (hours long,
    so nearly independent); the test asks whether the candidate lowers the
    mean squared residual across blocks more than block-to-block noise would.
    """
    d = []
    for Rb, Ra in zip(before, after, strict=True):
        edges = np.linspace(0, Rb.shape[0], n_blocks + 1).astype(int)
        for lo, hi in zip(edges[:-1], edges[1:], strict=True):
            if hi > lo:
                d.append(run_ms(Rb[lo:hi]) - run_ms(Ra[lo:hi]))
    d = np.asarray(d)
    if d.size < 2 or np.std(d) == 0:
        return 0.0 if d.size and np.all(d > 0) else 1.0
    return float(stats.ttest_1samp(d, 0.0, alternative="greater").pvalue)


# More speed levels than this over the runs (random duty cycles) are
# grouped into bands of round width in the regime tables.
MAX_SPEED_LEVELS = 8


def speed_bands(regimes):
    """``{speed label: its regime label}`` over all runs' regimes, slowest
    first: ``"at 4000 rpm"`` per speed, or, for more than
    :data:`MAX_SPEED_LEVELS` speeds, one per band of a round width (100,
    200, 250, 500, 1000, ... rpm) giving at most that many bands, labelled
    by the slowest and fastest speed run in it (``"at 3000-3500 rpm"``, or
    ``"at 6000 rpm"`` for one speed). Standstill (``"0 rpm"``) has none."""
    labels = sorted(
        {s for lab in regimes for s in lab["speed"].unique() if s != "0 rpm"},
        key=lambda s: int(s.split()[0]),
    )
    if len(labels) <= MAX_SPEED_LEVELS:
        return {s: f"at {s}" for s in labels}
    rpm = np.array([int(s.split()[0]) for s in labels])
    for w in [m * 10.0**e for e in range(2, 7) for m in (1, 2, 2.5, 5)]:
        first, last = np.floor(rpm[[0, -1]] / w)
        if last - first + 1 <= MAX_SPEED_LEVELS:
            band = np.floor(rpm / w)
            out = {}
            for s, b in zip(labels, band, strict=True):
                lo, hi = rpm[band == b].min(), rpm[band == b].max()
                out[s] = f"at {lo:d} rpm" if lo == hi else f"at {lo:d}-{hi:d} rpm"
            return out
    return dict.fromkeys(labels, "at speed")


def regime_gaps(Rs, regimes):
    """Gap per regime label (primary regime, ambient event, feed motion,
    speed level or band, see :func:`speed_bands`)."""
    bands = speed_bands(regimes)
    rows = []
    for R, lab in zip(Rs, regimes, strict=True):
        e = np.sum(R * R, axis=1)
        keys = lab["regime"].to_numpy().astype(object)
        rows.append(pd.DataFrame({"regime": keys, "e": e}))
        if lab["ambient_event"].any():
            rows.append(
                pd.DataFrame(
                    {"regime": "ambient event", "e": e[lab["ambient_event"].to_numpy()]}
                )
            )
        if lab["feed_motion"].any():
            rows.append(
                pd.DataFrame(
                    {"regime": "feed motion", "e": e[lab["feed_motion"].to_numpy()]}
                )
            )
        groups = lab.groupby("speed").groups
        for speed, band in bands.items():  # slowest first
            if speed in groups:
                rows.append(pd.DataFrame({"regime": band, "e": e[groups[speed]]}))
    frame = pd.concat(rows, ignore_index=True)
    gaps = frame.groupby("regime", sort=False)["e"].mean().pow(0.5)
    # The speeds slowest first, after the other regimes (a band first met in
    # a later run came last).
    speeds = list(dict.fromkeys(b for b in bands.values() if b in gaps.index))
    return gaps.reindex([r for r in gaps.index if r not in speeds] + speeds)
