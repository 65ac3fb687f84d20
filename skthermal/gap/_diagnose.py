"""Where the simulation and the measurement disagree, which unmodelled effect
explains it, and how far the gap shrinks once that effect is added."""

import logging
from dataclasses import dataclass
from numbers import Integral

import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from scipy import stats
from sklearn.utils._param_validation import Interval, StrOptions, validate_params

from skthermal.gap._evidence import (
    explainable_summary,
    residual_lr_test,
    share_of_explainable,
    whiteness_columns,
)
from skthermal.gap._problem import (
    EFFECT_PARAMETER,
    EFFECT_RANGE,
    RESIDUAL_EFFECTS,
    apply_gains,
    build_problem,
    calibrate,
    drift_mask,
    drift_table,
    effect_parameters,
    floor_squared,
    initial_table,
    measured_initial,
    predict_run,
    refine,
    residuals,
    sensor_columns,
    too_few_runs,
)
from skthermal.gap._regimes import label_regimes
from skthermal.gap._report import GapReport, with_recorded_warnings
from skthermal.gap._scores import (
    DIAGNOSIS_PARAMS,
    applicable,
    beyond_noise,
    block_test,
    candidate_list,
    excess_shrink,
    gap_of,
    heldout_folds,
    on_bound,
    order_candidates,
    rank_key,
    regime_gaps,
    ruled_out,
)
from skthermal.gap._terms import RunSignals, Signals, flexible_heldout
from skthermal.simulate import EFFECTS, ThermalMachine
from skthermal.utils._threads import with_single_threaded_blas

logger = logging.getLogger("skthermal.gap")


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
            # Runs shorter than the lag add nothing (x[: size - lag] would
            # wrap around to a negative stop).
            used = [(r, x) for r, x in pairs if x.size > lag]
            if not used:
                continue
            rs = np.concatenate([r[lag:] for r, _ in used])
            xs = np.concatenate([x[: x.size - lag] for _, x in used])
            if rs.size > 3 and np.std(xs) > 0 and np.std(rs) > 0:
                best = max(best, abs(float(np.corrcoef(rs, xs)[0, 1])))
    return best


def _regimes_of(problem):
    out = []
    for run in problem.runs:
        lab = label_regimes(run.time_s, run.spindle_rpm, run.ambient_C, run.feed_mm_min)
        out.append(lab.iloc[run.rows].reset_index(drop=True))
    return out


class _Context:
    """Everything the candidate evaluations share (pickled to workers)."""

    def __init__(self, problem, machine, reference, folds, max_nfev):
        self.problem = problem
        self.machine = machine
        self.reference = reference
        self.folds = folds
        self.max_nfev = max_nfev

    def fold(self, k, effects, start=None, fine=False, fit=None):
        """Calibrate fold ``k`` with ``effects`` added (or take ``fit``, a
        calibration of that fold done before) and, with ``fine``, refine it;
        returns the held-out residuals of its test runs and the fit."""
        problem = self.problem
        train, test = self.folds[k]
        if fit is None:
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
        return residuals(problem, preds, fit.gain, test, rates=fit.drift_rates), fit

    def predictions(self, fit):
        """Parts of the prediction of every run with ``fit``
        (:func:`predict_run` with ``parts``), by run index."""
        problem = self.problem
        return {
            i: predict_run(fit.machine, problem, run, parts=True)
            for i, run in enumerate(problem.runs)
        }

    def in_sample(self, effects, fits, preds):
        """Residuals of every fold's training runs with its own fit
        (``preds``: :meth:`predictions` of each fit), one list per fold."""
        drift = drift_mask(self.problem, effects, self.machine)
        return [
            residuals(self.problem, p, f.gain, train, drift)
            for (train, _), f, p in zip(self.folds, fits, preds, strict=True)
        ]

    def assemble(self, effects, results):
        """Held-out residuals of every run from the folds' ``results``."""
        out = [None] * len(self.problem.runs)
        for (_, test), (Rs, _) in zip(self.folds, results, strict=True):
            for i, R in zip(test, Rs, strict=True):
                out[i] = R
        return out, [fit for _, fit in results]

    def heldout(self, effects, starts=None, n_jobs=None):
        """Held-out residuals of every run with ``effects`` added, and fits
        (the folds in parallel with ``n_jobs``)."""
        results = Parallel(n_jobs=n_jobs)(
            delayed(self.fold)(k, effects, None if starts is None else starts[k])
            for k in range(len(self.folds))
        )
        return self.assemble(effects, results)


@dataclass
class Evaluation:
    """One candidate added on top of ``effects``, scored on held-out runs."""

    row: dict  # the ranking row
    regime_shrink: pd.Series  # shrink per regime
    residuals: list  # held-out residuals of every run, with the candidate
    fits: list  # the folds' calibrations
    preds: list  # per fold, ctx.predictions of its calibration
    # per fold, {run: what the candidate adds to its prediction (n, c, 1)}
    signature: list = None

    @property
    def effect(self):
        return self.row["effect"]

    @property
    def rank_key(self):
        """Sort key, best first with ``reverse=True``."""
        return rank_key(self.row)


def _evaluate(
    ctx,
    before_effects,
    before_R,
    before_fits,
    before_preds,
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
    preds = [ctx.predictions(f) for f in fits]
    row.update(
        _lr_evidence(
            ctx,
            ctx.in_sample(before_effects, before_fits, before_preds),
            ctx.in_sample(effects, fits, preds),
            candidate,
        )
    )
    _log_row("Which", row)
    regime_shrink = (1.0 - ra / rb.reindex(ra.index)).rename(candidate)
    param = EFFECT_PARAMETER.get(candidate)
    per_sensor = None
    row["on_bound"] = ""
    if param is not None:
        ref = ctx.reference[param]
        row["fitted"] = float(np.median([f.values[param] for f in fits]) * ref)
        row["on_bound"] = on_bound(
            {param: row["fitted"]}, {param: tuple(ref * b for b in EFFECT_RANGE)}
        )
    elif candidate in RESIDUAL_EFFECTS:
        # The drift rates' spread over the temperature channels in °C/h, as
        # the simulator's rate_C_per_h: the root mean square of the rates
        # of report.drift_rates (each the median over the folds).
        per_fold = drift_rates_C_per_h(ctx.problem, fits)
        rates = np.median(per_fold, axis=0)
        row["fitted"] = float(np.sqrt(np.mean(rates**2)))
        per_sensor = drift_table(ctx.problem, per_fold)
    else:
        row["fitted"] = np.nan
    # The ThermalMachine mode's range (0.05 to 20 times the machine's value)
    # has no end physics reaches: on either, the range stopped the fit.
    row["stopped"] = row["on_bound"]
    row["ruled_out"] = ruled_out(candidate, row["fitted"], per_sensor)
    row["explains"] = row["explains"] and not row["ruled_out"] and not row["stopped"]
    signature = None
    if candidate not in RESIDUAL_EFFECTS:
        # What the candidate adds to the prediction of every run, per fold:
        # a feature of the flexible model (which then contains every
        # candidate).
        signature = [
            {
                i: (apply_gains(p[i], f.gain) - apply_gains(b[i], bf.gain))[:, :, None]
                for i in p
            }
            for p, f, b, bf in zip(preds, fits, before_preds, before_fits, strict=True)
        ]
    return Evaluation(row, regime_shrink, after_R, fits, preds, signature)


def drift_rates_C_per_h(problem, fits):
    """The drift rates of the temperature channels fitted on every fold, in
    °C per hour of the measured readings, ``(n_folds, n_temperatures)``
    (:attr:`Fit.drift_rates` are those of the normalised residual,
    simulated minus measured)."""
    w = np.sqrt(problem.weight) / problem.scale
    temp = ~problem.is_disp
    return np.array([-(f.drift_rates / w)[temp] for f in fits])


def _drift_table(problem, screen):
    """:attr:`GapReport.drift_rates`: the drift rate of every compared
    temperature channel (°C/h, median over the folds) of the calibrations
    that model drift: the machine's own base when it has ``sensor_drift``
    on, else the ``sensor_drift`` candidate's; empty when none does."""
    if screen.base_fits and screen.base_fits[0].drift_rates is not None:
        fits = screen.base_fits
    elif "sensor_drift" in screen.evaluations:
        fits = screen.evaluations["sensor_drift"].fits
    else:
        return {}
    return drift_table(problem, drift_rates_C_per_h(problem, fits))


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
    b, a = before_R, after_R
    gap_b, ms_b = gap_of(b)
    gap_a, ms_a = gap_of(a)
    shrink = excess_shrink(gap_b, gap_a, floor2)
    d = ms_b - ms_a  # per held-out run
    p = block_test(b, a)
    rb = regime_gaps(b, regimes)
    ra = regime_gaps(a, regimes)
    row = {
        "effect": candidate,
        "gap_before": gap_b,
        "gap_after": gap_a,
        "shrink": shrink,
        "shrink_raw": 1.0 - gap_a / gap_b if gap_b > 0 else 0.0,
        "p_value": p,
        "runs_improved": int(np.sum(d > 0)),
        "n_runs": int(d.size),
        "extra_params": _free_parameters(ctx, candidate),
        "xcorr_before": _xcorr(ctx.problem, b),
        "xcorr_after": _xcorr(ctx.problem, a),
    }
    row.update(whiteness_columns(b, a))
    row["explains"] = bool(
        shrink >= min_shrink and p < alpha and beyond_noise(gap_b, floor2)
    )
    return row, (rb, ra)


def _lr_evidence(ctx, before_in, after_in, candidate):
    """Likelihood-ratio test and information criteria of adding
    ``candidate``, in sample on every fold's training runs (``before_in``,
    ``after_in``: their residuals, one list per fold), averaged over the
    folds.

    Each fold's statistic (per channel, effective samples corrected for the
    residual's autocorrelation, :func:`likelihood_ratio`) is chi-squared
    under the model without the candidate; their mean has the same mean and
    less spread, so its p-value from the same distribution is conservative.
    The degrees of freedom (``lr_df``, also ``extra_params``) are the
    candidate's free parameters (:func:`_free_parameters`); a candidate
    without any gets no test (NaN p-value and criteria)."""
    df = _free_parameters(ctx, candidate)
    tests = [
        residual_lr_test(rb, ra, max(df, 1))
        for rb, ra in zip(before_in, after_in, strict=True)
    ]
    statistic = float(np.mean([t.statistic for t in tests]))
    if df == 0:
        # A structural switch without a free parameter: not a nested model
        # with more parameters, so no likelihood-ratio test nor criteria.
        return {
            "lr_df": 0,
            "lr_statistic": statistic,
            "lr_p_value": np.nan,
            "delta_aic": np.nan,
            "delta_bic": np.nan,
        }
    return {
        "lr_df": df,
        "lr_statistic": statistic,
        "lr_p_value": float(stats.chi2.sf(statistic, df)),
        "delta_aic": float(np.mean([t.delta_aic for t in tests])),
        "delta_bic": float(np.mean([t.delta_bic for t in tests])),
    }


def _free_parameters(ctx, candidate):
    """Free parameters ``candidate`` adds to a calibration (the ranking's
    ``extra_params`` and ``lr_df``): its effect parameter, or one drift rate
    per temperature channel for ``sensor_drift``; 0 for a structural switch
    without a parameter."""
    if candidate in RESIDUAL_EFFECTS:
        return int((~ctx.problem.is_disp).sum())
    return effect_parameters([candidate])


def _run_signals(problem, fold_preds):
    """The runs as :class:`Signals` of a fixed simulation (``fold_preds``:
    the prediction of every run, change since start at the compared
    rows), for the flexible discrepancy model."""
    runs = []
    for i, run in enumerate(problem.runs):
        rows = run.rows
        runs.append(
            RunSignals(
                run.name,
                run.time_s[rows] - run.time_s[rows[0]],
                run.spindle_rpm[rows],
                run.ambient_C[rows],
                run.feed_mm_min[rows],
                fold_preds[i],
                np.arange(rows.size),
                run.y,
            )
        )
    return Signals(runs, ~problem.is_disp, np.sqrt(problem.weight) / problem.scale)


def _explainable(ctx, screen, floor2):
    """The flexible discrepancy model on the base calibrated on each
    fold's training runs, with every candidate's signature among its
    features: its held-out gap and the share of the base's held-out gap
    above the noise floor it removes (what any added term could close)."""
    folds = ctx.folds
    fold_signals = []
    for fit, parts in zip(screen.base_fits, screen.base_preds, strict=True):
        fold_signals.append(
            _run_signals(
                ctx.problem, {i: apply_gains(p, fit.gain) for i, p in parts.items()}
            )
        )
    signatures = [
        ev.signature for ev in screen.evaluations.values() if ev.signature is not None
    ]
    extra = [
        [[sig[k][i] for sig in signatures] for i in range(len(ctx.problem.runs))]
        for k in range(len(folds))
    ]
    flex_R = flexible_heldout(fold_signals, folds, extra)
    return explainable_summary(screen.base_R, flex_R, floor2)


@validate_params(
    {
        "machine": [ThermalMachine],
        "runs": [pd.DataFrame],
        **DIAGNOSIS_PARAMS,
        "max_nfev": [Interval(Integral, 1, None, closed="left")],
        "fine": ["boolean"],
        "initial": [StrOptions({"auto", "ambient", "measured"})],
    },
    prefer_skip_nested_validation=True,
)
@with_single_threaded_blas
@with_recorded_warnings
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
    initial="auto",
    n_jobs=None,
):
    """Diagnose the gap between a simulated machine and measured runs.

    1. **Where**: the gap of the simulation as given and after calibrating its
       base parameters, per run, regime, channel and frequency band, with each
       regime's share of the squared error against its share of time, and the
       times where the gap jumps.
    2. **Which** (screening): the base parameters (one multiplier for all
       heat capacities, one for all convection coefficients, one for the
       enclosure air's exchange with the workshop, and per-channel
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
       conductance of the spindle head's nodes and the bearings' loss
       exponent (held near the simulation's values by a prior). This
       comparison decides: the top candidate *explains* the gap when,
       finely calibrated, it removes at least ``min_shrink`` of the
       held-out gap above the noise floor and the improvement is
       significant; otherwise no candidate explains it.
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
        machine does not already have. A candidate that cannot change any
        compared channel on these runs (e.g. ``feed_heating`` on a machine
        without a feed axis, or on runs without feed) is not scored: it is
        listed in ``report.not_applicable`` and in the verdict.
    cv : int, splitter or iterable of (train, test), optional
        Held-out scheme over runs (every run held out exactly once, by a
        fold that does not train on it): default leave-one-run-out for up to 3
        runs, else 3-fold GroupKFold; an int is a number of GroupKFold
        folds (at most the number of runs); a splitter splits the runs
        (one group each); (train, test) pairs are run indices, the runs
        numbered in their order in the table (blocks of ``block_hours``
        counting as runs).
    channels : sequence of str, optional
        Measured columns to compare (default: every one the simulation
        predicts, with a warning naming the measured channels it does not
        predict).
    mapping : dict, optional
        ``{measured column: simulated column}`` when the names differ (e.g.
        ``{"disp_ch1_um": "disp_z_um"}``); a key that is not a measured
        column or a value the simulation does not predict is an error.
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
    initial : {"auto", "ambient", "measured"}, default="auto"
        The machine's state at the start of every run. ``"ambient"``: soaked
        at the run's first air reading. ``"measured"``: estimated from the
        run's first temperature readings
        (:meth:`~skthermal.simulate.ThermalMachine.initial_from_readings`,
        every sensor of the machine the runs hold, compared or not), for
        runs that start warm from earlier work; it needs a sensor on the
        structure. Only the first readings enter the estimate, and each
        candidate starts from its own (made with the effect added).
        ``"auto"``: ``"measured"`` when the runs hold any of the machine's
        sensors that read its structure
        (:attr:`~skthermal.simulate.ThermalMachine.structure_sensors`, not
        the air alone), else ``"ambient"`` (``report.settings["initial"]``
        says which). On the independent truth machine
        (``benchmarks/bench_gap_truth.py``) "measured" halved the base's
        held-out gap on runs that start warm (the withheld effect first in
        47% of the cases, 43% from the air) and changed nothing that
        counts on soaked runs (60% either way, measured with the
        two-multiplier base of earlier versions); see "Runs that start
        warm" in docs/gap.md.
    n_jobs : int, optional
        Candidates (and the folds of the fine calibration) evaluated in
        parallel (joblib).

    Returns
    -------
    GapReport

    Examples
    --------
    >>> from skthermal.gap import diagnose, make_gap_campaign
    >>> case = make_gap_campaign("tool_growth", n_runs=4, hours=4, random_state=0)
    >>> report = diagnose(case.simulation, case.runs,
    ...                   candidates=["tool_growth", "speed_convection"],
    ...                   greedy=False, max_samples=150)
    >>> report.best_effect
    'tool_growth'
    """
    base_effects = tuple(machine.effects)
    candidates = candidate_list(candidates, EFFECTS, base_effects)
    # "auto": from the first readings when a sensor reads the structure (an
    # air sensor alone cannot tell a warm machine), a run whose readings a
    # soaked machine explains as well starting at the air.
    p_soaked = ThermalMachine.SOAKED_PRIOR if initial == "auto" else 0.0
    if initial == "auto":
        held = sensor_columns(machine, runs.columns, mapping)
        structure = set(machine.structure_sensors)
        initial = "measured" if structure.intersection(held) else "ambient"
    problem = build_problem(
        machine,
        runs,
        channels=channels,
        mapping=mapping,
        max_samples=max_samples,
        block_hours=block_hours,
        first_readings=initial == "measured",
    )
    if len(problem.runs) < 2:
        longest = runs.groupby("run", sort=False)["time_s"].agg(np.ptp).max()
        raise too_few_runs(len(problem.runs), float(longest), block_hours)
    folds = heldout_folds(len(problem.runs), cv, [r.name for r in problem.runs])
    if initial == "measured":
        problem = measured_initial(machine, problem, p_soaked=p_soaked)
    # The simulation as given: what the candidates are checked against, and
    # the first residuals of the "where" step.
    simulated = [predict_run(machine, problem, r) for r in problem.runs]
    not_applicable = _not_applicable(problem, machine, candidates, simulated)
    candidates = applicable(candidates, not_applicable)
    logger.info(
        "Prepared %d run(s) and %d channel(s); %d candidate(s): %s.",
        len(problem.runs),
        len(problem.channels),
        len(candidates),
        ", ".join(candidates),
    )
    reference = machine.params
    ctx = _Context(problem, machine, reference, folds, max_nfev)
    rules = (_regimes_of(problem), floor_squared(problem), min_shrink, alpha)
    where = _where(ctx, simulated)
    screen = _screen(ctx, candidates, rules, n_jobs)
    explainable = _explainable(ctx, screen, rules[1]) if len(candidates) else {}
    if explainable:
        screen.ranking["share_of_explainable"] = [
            share_of_explainable(v, explainable["share"])
            for v in screen.ranking["shrink"]
        ]
    how_far = _how_far(ctx, screen, rules, fine, n_jobs)
    if how_far is not None:
        how_far.row["share_of_explainable"] = share_of_explainable(
            how_far.row["shrink"], explainable["share"]
        )
    best = how_far.effect if how_far is not None and how_far.explains else None
    added, steps = _greedy(ctx, screen, how_far, candidates, rules, greedy, n_jobs)
    logger.info(
        "Verdict: %s.",
        f"{' + '.join(added)} explain(s) the gap" if best else "no effect explains",
    )
    machines = {"base calibrated": where.base.machine}
    if best is not None:
        with_best = calibrate(
            problem,
            machine,
            reference,
            tuple(added),
            np.arange(len(problem.runs)),
            start=where.base.values,
            max_nfev=max_nfev,
        )
        machines["+ " + " + ".join(added)] = with_best.machine
    report = GapReport._build(
        problem=problem,
        machine=machine,
        candidates=candidates,
        ranking=screen.ranking,
        regime_shrink=screen.regime_shrink,
        best_effect=best,
        steps=steps,
        base_R=screen.base_R,
        best_R=screen.evaluations[best].residuals if best is not None else None,
        fine_row=None if how_far is None else how_far.row,
        fine_regimes=None if how_far is None else how_far.regimes,
        fine_before_R=None if how_far is None else how_far.before_R,
        fine_after_R=None if how_far is None else how_far.after_R,
        as_given=where.as_given,
        calibrated=where.calibrated,
        regimes=rules[0],
        floor2=rules[1],
        settings={
            "min_shrink": min_shrink,
            "alpha": alpha,
            "folds": len(folds),
            "fine": bool(fine),
            "base_effects": list(base_effects),
            "initial": initial,
            "p_soaked": p_soaked if initial == "measured" else None,
        },
    )
    report.machines = machines
    report.not_applicable = not_applicable
    report.explainable = explainable
    report.drift_rates = _drift_table(problem, screen)
    report.initial_states = initial_table(machine, problem)
    return report


def _not_applicable(problem, machine, candidates, simulated):
    """Candidates that cannot change the compared channels on these runs,
    with the reason: ``{effect: reason}``.

    An effect whose part the machine lacks (:meth:`Effect.missing`: no
    head nodes for ``speed_convection``, no ball screw for
    ``feed_heating`` ...) says so. Otherwise a simulated effect is added to
    the machine at its reference parameters
    (the calibration only scales them) and every run simulated from its
    initial state: when no compared channel changes on any run from
    ``simulated`` (the machine's predictions, one per run), the effect has
    nothing to act on (e.g. no feed axis, no feed, no lagging sensor
    compared). An effect modelled on
    the residual (sensor drift) needs a compared temperature channel.
    """
    out = {}
    for c in candidates:
        if c in RESIDUAL_EFFECTS and drift_mask(problem, (c,)) is None:
            out[c] = "it acts on temperature sensors and none is compared"
    for c in candidates:
        if c in RESIDUAL_EFFECTS:
            continue
        lacks = EFFECTS[c].missing(machine.spec)
        if lacks is not None:
            out[c] = lacks
            continue
        with_c = machine.with_effects(add=[c])
        # From the same start: with first readings, an effect on the
        # sensors alone (a lag) changes the start estimated from them, and
        # so every channel a little, whatever is compared.
        if not any(
            np.max(np.abs(predict_run(with_c, problem, run, same_start=True) - b))
            > 1e-9 * max(float(np.max(np.abs(b))), 1e-9)
            for run, b in zip(problem.runs, simulated, strict=True)
        ):
            out[c] = (
                "adding it leaves every compared channel of the simulation "
                "unchanged on every run, it has nothing to act on in the machine "
                "or the runs"
            )
    return out


@dataclass
class Where:
    """Step 1: the simulation's residuals as given and with the base
    calibrated on all runs (in sample)."""

    as_given: list
    calibrated: list
    base: object  # the calibration on all runs (a Fit)


def _where(ctx, simulated):
    """The residuals of the simulation as given (``simulated``: its
    predictions, one per run) and with the base calibrated on all runs."""
    logger.info("Where: simulating the runs and calibrating the base.")
    problem, machine = ctx.problem, ctx.machine
    n = len(problem.runs)
    as_given = residuals(problem, dict(enumerate(simulated)), None, range(n))
    all_idx = np.arange(n)
    base = calibrate(
        problem, machine, ctx.reference, (), all_idx, max_nfev=ctx.max_nfev
    )
    calibrated = residuals(
        problem,
        {
            i: predict_run(base.machine, problem, r, parts=True)
            for i, r in enumerate(problem.runs)
        },
        base.gain,
        all_idx,
        rates=base.drift_rates,
    )
    return Where(as_given, calibrated, base)


@dataclass
class Screen:
    """Step 2: the base and every candidate on held-out runs."""

    base_R: list  # held-out residuals of the base
    base_fits: list
    base_preds: list  # per fold, ctx.predictions of its base calibration
    ranking: pd.DataFrame  # best first
    regime_shrink: pd.DataFrame  # candidates x regimes
    evaluations: dict  # effect name -> Evaluation


def _screen(ctx, candidates, rules, n_jobs):
    logger.info("Which: calibrating the base on %d fold(s).", len(ctx.folds))
    base_R, base_fits = ctx.heldout((), n_jobs=n_jobs)
    base_preds = [ctx.predictions(f) for f in base_fits]
    evaluations = Parallel(n_jobs=n_jobs)(
        delayed(_evaluate)(ctx, (), base_R, base_fits, base_preds, c, *rules)
        for c in candidates
    )
    if n_jobs not in (None, 1):  # workers' log records stay in the workers
        for ev in evaluations:
            _log_row("Which", ev.row)
    ranking = order_candidates(pd.DataFrame([ev.row for ev in evaluations]))
    return Screen(
        base_R,
        base_fits,
        base_preds,
        ranking,
        pd.concat([ev.regime_shrink for ev in evaluations], axis=1),
        {ev.effect: ev for ev in evaluations},
    )


@dataclass
class HowFar:
    """Step 3: the top candidate against the base, the comparison that
    decides whether it explains the gap."""

    row: dict
    regimes: tuple  # gap per regime, before and after
    before_R: list
    after_R: list

    @property
    def effect(self):
        return self.row["effect"]

    @property
    def explains(self):
        return bool(self.row["explains"])


def _how_far(ctx, screen, rules, fine, n_jobs):
    """The top candidate against the base; with ``fine``, both with the
    spindle head's nodes freed (the screening only ranks)."""
    if not len(screen.ranking):
        return None
    focus = screen.ranking.iloc[0]["effect"]
    logger.info(
        "How far: %s against the base, %s calibration.",
        focus,
        "fine" if fine else "screening",
    )
    if fine:
        n_folds = len(ctx.folds)
        # The base's screening calibrations are refined as they are; the
        # top candidate is calibrated from them, then refined.
        results = Parallel(n_jobs=n_jobs)(
            delayed(ctx.fold)(k, effects, start, True, fit)
            for effects, starts, fits in (
                ((), [None] * n_folds, screen.base_fits),
                ((focus,), [f.values for f in screen.base_fits], [None] * n_folds),
            )
            for k, (start, fit) in enumerate(zip(starts, fits, strict=True))
        )
        before_R, _ = ctx.assemble((), results[:n_folds])
        after_R, _ = ctx.assemble((focus,), results[n_folds:])
    else:
        before_R, after_R = screen.base_R, screen.evaluations[focus].residuals
    row, regimes = _score(ctx, before_R, after_R, focus, *rules)
    # The ranking's columns: the held-out ones of this comparison, the
    # in-sample evidence and the fitted parameter of the screening.
    row = {**screen.evaluations[focus].row, **row}
    row["explains"] = row["explains"] and not row["ruled_out"] and not row["stopped"]
    row["calibration"] = "fine" if fine else "screening"
    _log_row("How far", row)
    return HowFar(row, regimes, before_R, after_R)


def _greedy(ctx, screen, how_far, candidates, rules, greedy, n_jobs):
    """Step 4: the explaining effect, then (with ``greedy``) the next one on
    top while one still explains what remains. Returns the effects added
    and one step row each."""
    if how_far is None or not how_far.explains:
        return [], []
    best = how_far.effect
    added = [best]
    current = screen.evaluations[best]
    steps = [
        {
            "added": best,
            "gap": how_far.row["gap_after"],
            "shrink": how_far.row["shrink"],
            "calibration": how_far.row["calibration"],
        }
    ]
    remaining = [c for c in candidates if c != best]
    while greedy and remaining:
        more = Parallel(n_jobs=n_jobs)(
            delayed(_evaluate)(
                ctx,
                tuple(added),
                current.residuals,
                current.fits,
                current.preds,
                c,
                *rules,
            )
            for c in remaining
        )
        top = max(more, key=lambda ev: ev.rank_key)
        if not top.row["explains"]:
            break
        added.append(top.effect)
        current = top
        steps.append(
            {
                "added": top.effect,
                "gap": gap_of(top.residuals)[0],
                "shrink": top.row["shrink"],
                "calibration": "screening",
            }
        )
        remaining.remove(top.effect)
    return added, steps
