"""Where the simulation and the measurement disagree, which unmodelled effect
explains it, and how far the gap shrinks once that effect is added."""

import logging
from numbers import Integral, Real

import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from scipy import stats
from sklearn.model_selection import GroupKFold, LeaveOneGroupOut
from sklearn.utils._param_validation import Interval, validate_params

from skthermal.gap._problem import (
    EFFECT_PARAMETER,
    RESIDUAL_EFFECTS,
    build_problem,
    calibrate,
    effect_parameters,
    floor_squared,
    predict_run,
    refine,
    residuals,
)
from skthermal.gap._regimes import label_regimes
from skthermal.gap._report import GapReport
from skthermal.gap._scores import excess_shrink
from skthermal.simulate import EFFECTS, ThermalMachine

logger = logging.getLogger("skthermal.gap")


def _folds(n_runs, cv):
    groups = np.arange(n_runs)
    if cv is None:
        cv = LeaveOneGroupOut() if n_runs <= 3 else GroupKFold(n_splits=3)
    elif isinstance(cv, int):
        cv = GroupKFold(n_splits=cv)
    X = np.zeros((n_runs, 1))
    return [(tr, te) for tr, te in cv.split(X, groups=groups)]


def _run_ms(R):
    """Mean over samples of the weighted squared normalised residual."""
    return float(np.mean(np.sum(R * R, axis=1))) if R.size else 0.0


def _gap(Rs):
    n = np.array([R.shape[0] for R in Rs], dtype=float)
    ms = np.array([_run_ms(R) for R in Rs])
    return float(np.sqrt(np.sum(n * ms) / n.sum())), ms


def _detrend_first_half(R, is_temp):
    """Residual minus a per-channel linear trend fitted on the run's first half
    and extrapolated (the sensor-drift model); temperature channels only."""
    n = R.shape[0]
    half = max(2, n // 2)
    t = np.arange(n, dtype=float)
    A = np.column_stack([np.ones(half), t[:half]])
    coef, *_ = np.linalg.lstsq(A, R[:half][:, is_temp], rcond=None)
    out = R.copy()
    out[:, is_temp] -= np.column_stack([np.ones(n), t]) @ coef
    return out


def _second_half(R):
    return R[R.shape[0] // 2 :]


def _block_test(before, after, n_blocks=3):
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
                d.append(_run_ms(Rb[lo:hi]) - _run_ms(Ra[lo:hi]))
    d = np.asarray(d)
    if d.size < 2 or np.std(d) == 0:
        return 0.0 if d.size and np.all(d > 0) else 1.0
    return float(stats.ttest_1samp(d, 0.0, alternative="greater").pvalue)


def _xcorr(problem, Rs, max_lag=10):
    """Largest |correlation| between the combined residual and a driver.

    Drivers: spindle speed, air temperature change rate, feed, and time since
    the last spindle stop, at lags 0..max_lag samples (residual after driver).
    """
    best = 0.0
    drivers = {}
    for run, R in zip(problem.runs, Rs, strict=True):
        r = R.sum(axis=1)
        rows = run.rows[run.rows.size - R.shape[0] :]  # residuals may be a tail
        air = run.ambient_C[rows]
        d = {
            "spindle_rpm": run.spindle_rpm[rows],
            "ambient_rate": np.gradient(air) if air.size > 1 else air * 0,
            "feed": np.abs(run.feed_mm_min[rows]),
        }
        on = run.spindle_rpm[rows] > 0
        since = np.zeros(rows.size)
        for k in range(1, rows.size):  # cheap: rows are at most a few hundred
            since[k] = 0.0 if on[k] else since[k - 1] + 1.0
        d["since_stop"] = np.where(on, 0.0, np.exp(-since / 20.0))
        for name, x in d.items():
            drivers.setdefault(name, []).append((r, x))
    for pairs in drivers.values():
        for lag in range(max_lag + 1):
            rs = np.concatenate([r[lag:] for r, _ in pairs])
            xs = np.concatenate([x[: x.size - lag] for _, x in pairs])
            if rs.size > 3 and np.std(xs) > 0 and np.std(rs) > 0:
                best = max(best, abs(float(np.corrcoef(rs, xs)[0, 1])))
    return best


def _regimes_of(problem):
    out = []
    for run in problem.runs:
        lab = label_regimes(run.time_s, run.spindle_rpm, run.ambient_C, run.feed_mm_min)
        out.append(lab.iloc[run.rows].reset_index(drop=True))
    return out


def _regime_gaps(Rs, regimes):
    """Gap per regime label (primary regime, ambient event, feed motion)."""
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
        for speed, idx in lab.groupby("speed").groups.items():
            if speed != "0 rpm":
                rows.append(pd.DataFrame({"regime": f"at {speed}", "e": e[idx]}))
    frame = pd.concat(rows, ignore_index=True)
    return frame.groupby("regime", sort=False)["e"].mean().pow(0.5)


class _Context:
    """Everything the candidate evaluations share (pickled to workers)."""

    def __init__(self, problem, machine, reference, folds, max_nfev):
        self.problem = problem
        self.machine = machine
        self.reference = reference
        self.folds = folds
        self.max_nfev = max_nfev

    def fold(self, k, effects, start=None, fine=False):
        """Calibrate fold ``k`` with ``effects`` added (and, with ``fine``,
        refine it); returns the held-out residuals of its test runs and the
        fit."""
        problem = self.problem
        train, test = self.folds[k]
        fit = calibrate(
            problem,
            self.machine,
            self.reference,
            tuple(effects),
            train,
            start=start,
            max_nfev=self.max_nfev,
        )
        if fine:
            fit = refine(problem, fit, train)
        preds = {
            i: predict_run(fit.machine, problem, problem.runs[i], parts=True)
            for i in test
        }
        return residuals(problem, preds, fit.gain, test), fit

    def assemble(self, effects, results):
        """Held-out residuals of every run from the folds' ``results``."""
        out = [None] * len(self.problem.runs)
        for (_, test), (Rs, _) in zip(self.folds, results, strict=True):
            for i, R in zip(test, Rs, strict=True):
                out[i] = R
        if any(e in RESIDUAL_EFFECTS for e in effects):
            is_temp = ~self.problem.is_disp
            out = [_detrend_first_half(R, is_temp) for R in out]
        return out, [fit for _, fit in results]

    def heldout(self, effects, starts=None):
        """Held-out residuals of every run with ``effects`` added, and fits."""
        results = [
            self.fold(k, effects, None if starts is None else starts[k])
            for k in range(len(self.folds))
        ]
        return self.assemble(effects, results)


def _evaluate(
    ctx,
    before_effects,
    before_R,
    before_fits,
    candidate,
    regimes,
    floor2,
    min_shrink,
    alpha,
):
    effects = tuple(before_effects) + (candidate,)
    logger.info("Which: calibrating with %s on every fold.", " + ".join(effects))
    starts = [f.values for f in before_fits]
    after_R, fits = ctx.heldout(effects, starts)
    row, (rb, ra) = _score(
        ctx, before_R, after_R, candidate, regimes, floor2, min_shrink, alpha
    )
    _log_row("Which", row)
    regime_shrink = (1.0 - ra / rb.reindex(ra.index)).rename(candidate)
    param = EFFECT_PARAMETER.get(candidate)
    if param is not None:
        row["fitted"] = float(
            np.median([f.values[param] for f in fits]) * ctx.reference[param]
        )
    else:
        row["fitted"] = np.nan
    return row, regime_shrink, after_R, fits


def _log_row(step, row):
    logger.info(
        "%s: %s: held-out gap %.3g -> %.3g, shrink %.0f%% above noise, p = %.2g%s.",
        step,
        row["effect"],
        row["gap_before"],
        row["gap_after"],
        100 * row["shrink"],
        row["p_value"],
        " (explains)" if row["explains"] else "",
    )


def _score(ctx, before_R, after_R, candidate, regimes, floor2, min_shrink, alpha):
    """Evidence that adding ``candidate`` turned ``before_R`` into ``after_R``
    (held-out residuals): the ranking row, and the gap per regime before and
    after."""
    if candidate in RESIDUAL_EFFECTS:
        # The drift model is judged on the second half of every run, where its
        # trend, fitted on the first half, is a genuine prediction.
        b = [_second_half(R) for R in before_R]
        a = [_second_half(R) for R in after_R]
        regimes = [r.iloc[r.shape[0] // 2 :].reset_index(drop=True) for r in regimes]
    else:
        b, a = before_R, after_R
    gap_b, ms_b = _gap(b)
    gap_a, ms_a = _gap(a)
    shrink = excess_shrink(gap_b, gap_a, floor2)
    d = ms_b - ms_a  # per held-out run
    p = _block_test(b, a)
    rb = _regime_gaps(b, regimes)
    ra = _regime_gaps(a, regimes)
    row = {
        "effect": candidate,
        "gap_before": gap_b,
        "gap_after": gap_a,
        "shrink": shrink,
        "shrink_raw": 1.0 - gap_a / gap_b if gap_b > 0 else 0.0,
        "p_value": p,
        "runs_improved": int(np.sum(d > 0)),
        "n_runs": int(d.size),
        "extra_params": effect_parameters([candidate]),
        "xcorr_before": _xcorr(ctx.problem, b),
        "xcorr_after": _xcorr(ctx.problem, a),
    }
    row["explains"] = bool(shrink >= min_shrink and p < alpha)
    return row, (rb, ra)


@validate_params(
    {
        "machine": [ThermalMachine],
        "runs": [pd.DataFrame],
        "candidates": [None, str, list, tuple],
        "cv": [None, Interval(Integral, 2, None, closed="left"), "cv_object"],
        "channels": [None, list, tuple],
        "mapping": [None, dict],
        "min_shrink": [Interval(Real, 0, 1, closed="right")],
        "alpha": [Interval(Real, 0, 1, closed="neither")],
        "greedy": ["boolean"],
        "max_samples": [Interval(Integral, 10, None, closed="left")],
        "max_nfev": [Interval(Integral, 1, None, closed="left")],
        "block_hours": [None, Interval(Real, 0, None, closed="neither")],
        "fine": ["boolean"],
        "n_jobs": [None, Integral],
    },
    prefer_skip_nested_validation=True,
)
def diagnose(
    machine,
    runs,
    candidates=None,
    cv=None,
    *,
    channels=None,
    mapping=None,
    min_shrink=0.5,
    alpha=0.05,
    greedy=True,
    max_samples=600,
    max_nfev=30,
    block_hours=None,
    fine=True,
    n_jobs=None,
):
    """Diagnose the gap between a simulated machine and measured runs.

    1. **Where**: the gap of the simulation as given and after calibrating its
       base parameters, per run, regime, channel and frequency band, with each
       regime's share of the squared error against its share of time, and the
       times where the gap jumps.
    2. **Which** (screening): the base parameters (one multiplier for all
       heat capacities, one for all convection coefficients, and per-channel
       gains of the parts driven by the air, the bearings, the drive and the
       feed) are calibrated on training runs so that an offset is not
       mistaken for missing physics. Then every candidate effect is added,
       its parameter calibrated with them, and the gap scored on held-out
       runs. Candidates are ranked by the share of the held-out gap above
       the noise floor they remove (column ``explains``: at least
       ``min_shrink``, and significant in a one-sided paired t-test over
       blocks of the held-out runs at ``alpha``).
    3. **How far**: the top candidate against the base, both with a fine
       calibration that also frees every capacity, convection and
       conductance of the spindle head's nodes (held near the simulation's
       values by a prior). This comparison decides: the top candidate
       *explains* the gap when, finely calibrated, it removes at least
       ``min_shrink`` of the held-out gap above the noise floor and the
       improvement is significant; otherwise no candidate explains it.
       Then greedily the next effect on top while one still explains what
       remains (screening calibration).

    Parameters
    ----------
    machine : ThermalMachine
        The simulation. Its effects that are on stay on; candidates are added.
    runs : DataFrame
        Measured run table(s) with ``time_s``, ``spindle_rpm``, ``ambient_C``
        (and ``feed_mm_min`` if the axis moved), and channels the simulation
        predicts (displacements ``disp_*_um`` and/or its sensors).
    candidates : sequence of str, optional
        Effects to test; default: every effect of the vocabulary that the
        machine does not already have.
    cv : int or splitter, optional
        Held-out scheme over runs: default leave-one-run-out for up to 3
        runs, else 3-fold GroupKFold.
    channels : sequence of str, optional
        Measured columns to compare (default: every one the simulation
        predicts).
    mapping : dict, optional
        ``{measured column: simulated column}`` when the names differ (e.g.
        ``{"disp_ch1_um": "disp_z_um"}``).
    min_shrink : float, default=0.5
        Share of the excess held-out gap an effect must remove to explain it.
    alpha : float, default=0.05
        Significance level of the improvement across held-out runs.
    greedy : bool, default=True
        After the best effect, add further effects while they explain more.
    max_samples : int, default=600
        Samples per run compared (runs are simulated at their own rate).
    max_nfev : int, default=30
        Model evaluations per calibration.
    block_hours : float, optional
        Cut runs longer than this into consecutive blocks that are held out
        one by one (for one long record, e.g. a multi-day test). Each block is
        simulated from the start of its run, so its warm start is right.
    fine : bool, default=True
        Run the fine calibration of the "how far" step (``False``: the
        screening comparison decides, two to three times faster).
    n_jobs : int, optional
        Candidates (and the folds of the fine calibration) evaluated in
        parallel (joblib).

    Returns
    -------
    GapReport

    Examples
    --------
    >>> from skthermal.gap import diagnose, make_gap_campaign
    >>> case = make_gap_campaign("tool_growth", n_runs=3, hours=4, random_state=0)
    >>> report = diagnose(case.simulation, case.runs,
    ...                   candidates=["tool_growth", "speed_convection"],
    ...                   greedy=False, fine=False, max_samples=150)
    >>> report.best_effect
    'tool_growth'
    """
    base_effects = tuple(machine.effects)
    if candidates is None:
        candidates = [e for e in EFFECTS if e not in base_effects]
    candidates = [candidates] if isinstance(candidates, str) else list(candidates)
    unknown = [c for c in candidates if c not in EFFECTS]
    if unknown:
        raise ValueError(
            f"Unknown effect(s) {unknown}; the vocabulary is {list(EFFECTS)}."
        )
    candidates = [e for e in EFFECTS if e in candidates]
    already = [c for c in candidates if c in base_effects]
    if already:
        raise ValueError(
            f"The simulation already has {already}; they cannot be candidates."
        )
    problem = build_problem(
        machine,
        runs,
        channels=channels,
        mapping=mapping,
        max_samples=max_samples,
        block_hours=block_hours,
    )
    if len(problem.runs) < 2:
        raise ValueError(
            "The diagnosis scores effects on held-out runs: give at least 2 runs "
            f"(got {len(problem.runs)})."
        )
    logger.info(
        "Prepared %d run(s) and %d channel(s); %d candidate(s): %s.",
        len(problem.runs),
        len(problem.channels),
        len(candidates),
        ", ".join(candidates),
    )
    reference = machine.params
    folds = _folds(len(problem.runs), cv)
    ctx = _Context(problem, machine, reference, folds, max_nfev)
    regimes = _regimes_of(problem)
    floor2 = floor_squared(problem)

    # Where: as given, and with the base calibrated on all runs (in sample).
    logger.info("Where: simulating the runs and calibrating the base.")
    as_given = residuals(
        problem,
        {i: predict_run(machine, problem, r) for i, r in enumerate(problem.runs)},
        None,
        range(len(problem.runs)),
    )
    all_idx = np.arange(len(problem.runs))
    base_all = calibrate(problem, machine, reference, (), all_idx, max_nfev=max_nfev)
    calibrated = residuals(
        problem,
        {
            i: predict_run(base_all.machine, problem, r, parts=True)
            for i, r in enumerate(problem.runs)
        },
        base_all.gain,
        all_idx,
    )

    # Which: held-out gap of the base, then of every candidate.
    logger.info("Which: calibrating the base on %d fold(s).", len(folds))
    base_R, base_fits = ctx.heldout(())
    jobs = Parallel(n_jobs=n_jobs)(
        delayed(_evaluate)(
            ctx, (), base_R, base_fits, c, regimes, floor2, min_shrink, alpha
        )
        for c in candidates
    )
    rows = [j[0] for j in jobs]
    if n_jobs not in (None, 1):  # workers' log records stay in the workers
        for row in rows:
            _log_row("Which", row)
    ranking = pd.DataFrame(rows)
    ranking = ranking.sort_values(
        ["explains", "shrink"], ascending=False, kind="stable"
    )
    ranking = ranking.reset_index(drop=True)
    regime_shrink = pd.concat([j[1] for j in jobs], axis=1)
    after_R = {j[0]["effect"]: j[2] for j in jobs}
    after_fits = {j[0]["effect"]: j[3] for j in jobs}

    # How far, finely: the top candidate against the base, both with the
    # spindle head's nodes freed. This comparison decides whether the top
    # candidate explains the gap (the screening only ranks).
    focus = ranking.iloc[0]["effect"] if len(ranking) else None
    fine_row = fine_regimes = fine_before_R = fine_after_R = None
    if focus is not None:
        n_folds = len(folds)
        logger.info(
            "How far: %s against the base, %s calibration.",
            focus,
            "fine" if fine else "screening",
        )
        if fine:
            results = Parallel(n_jobs=n_jobs)(
                delayed(ctx.fold)(k, effects, start, True)
                for effects, starts in (
                    ((), [None] * n_folds),
                    ((focus,), [f.values for f in base_fits]),
                )
                for k, start in enumerate(starts)
            )
            fine_before_R, _ = ctx.assemble((), results[:n_folds])
            fine_after_R, _ = ctx.assemble((focus,), results[n_folds:])
        else:
            fine_before_R, fine_after_R = base_R, after_R[focus]
        fine_row, fine_regimes = _score(
            ctx,
            fine_before_R,
            fine_after_R,
            focus,
            regimes,
            floor2,
            min_shrink,
            alpha,
        )
        fine_row["calibration"] = "fine" if fine else "screening"
        _log_row("How far", fine_row)
    best = focus if fine_row is not None and fine_row["explains"] else None

    # How far: the best effect, then greedily more.
    steps = []
    if best is not None:
        added = [best]
        current_R, current_fits = after_R[best], after_fits[best]
        steps.append(
            {
                "added": best,
                "gap": fine_row["gap_after"],
                "shrink": fine_row["shrink"],
                "calibration": fine_row["calibration"],
            }
        )
        remaining = [c for c in candidates if c != best]
        while greedy and remaining:
            more = Parallel(n_jobs=n_jobs)(
                delayed(_evaluate)(
                    ctx,
                    tuple(added),
                    current_R,
                    current_fits,
                    c,
                    regimes,
                    floor2,
                    min_shrink,
                    alpha,
                )
                for c in remaining
            )
            more.sort(key=lambda j: (j[0]["explains"], j[0]["shrink"]), reverse=True)
            top = more[0]
            if not top[0]["explains"]:
                break
            added.append(top[0]["effect"])
            current_R, current_fits = top[2], top[3]
            steps.append(
                {
                    "added": top[0]["effect"],
                    "gap": _gap(current_R)[0],
                    "shrink": top[0]["shrink"],
                    "calibration": "screening",
                }
            )
            remaining.remove(top[0]["effect"])
    machines = {"base calibrated": base_all.machine}
    logger.info(
        "Verdict: %s.",
        f"{' + '.join(added)} explain(s) the gap" if best else "no effect explains",
    )
    if best is not None:
        with_best = calibrate(
            problem,
            machine,
            reference,
            tuple(added),
            all_idx,
            start=base_all.values,
            max_nfev=max_nfev,
        )
        machines["+ " + " + ".join(added)] = with_best.machine
    report = GapReport._build(
        problem=problem,
        machine=machine,
        candidates=candidates,
        ranking=ranking,
        regime_shrink=regime_shrink,
        best_effect=best,
        steps=steps,
        base_R=base_R,
        best_R=after_R.get(best) if best is not None else None,
        fine_row=fine_row,
        fine_regimes=fine_regimes,
        fine_before_R=fine_before_R,
        fine_after_R=fine_after_R,
        as_given=as_given,
        calibrated=calibrated,
        regimes=regimes,
        floor2=floor2,
        settings={
            "min_shrink": min_shrink,
            "alpha": alpha,
            "folds": len(folds),
            "fine": bool(fine),
            "base_effects": list(base_effects),
        },
    )
    report.machines = machines
    return report
