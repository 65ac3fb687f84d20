"""Proof of the diagnosis on data whose effect is withheld.

"Measured" runs come from a perturbed machine with one effect switched on; the
diagnosis sees the unperturbed simulation without that effect and must name
it, say "none" when nothing was added, and refuse to blame a wrong effect when
the true one is not among its candidates.
"""

import dataclasses
import logging
import zlib
from dataclasses import dataclass, field
from numbers import Real

import numpy as np
import pandas as pd
from joblib import Parallel, delayed
from sklearn.utils import check_random_state

from skthermal.gap._problem import is_channel
from skthermal.simulate import (
    EFFECTS,
    AmbientProfile,
    DoorEvent,
    DutyCycle,
    ThermalMachine,
)
from skthermal.utils._threads import with_single_threaded_blas

logger = logging.getLogger("skthermal.gap")

# Effect parameter scaled by the strength of a validation case; drift gets a
# visible default (the simulator's 0.01 °C/h is below the sensor noise).
_STRENGTH = {
    "sensor_lag": {"sensor_lag.tau_s": 480.0},
    "speed_convection": {"speed_convection.gain": 0.2},
    "tool_growth": {"tool_growth.hA_rotating": 2.5},
    "feed_heating": {"feed_heating.W_per_m_min": 6.0},
    "sensor_drift": {
        "sensor_drift.rate_C_per_h": 0.06,
        "sensor_drift.walk_C_per_sqrt_h": 0.02,
    },
    "ambient_transient": {},
}


@dataclass
class GapCase:
    """A validation case: the simulation, the hidden truth and its runs."""

    simulation: ThermalMachine
    truth: ThermalMachine
    runs: pd.DataFrame
    effect: str | None
    strength: float


def _perturbed(machine, rng, low, high):
    new = {}
    for key, value in machine.params.items():
        kind = key.split(".")[0]
        if kind in ("C", "G", "hA", "q", "k") and key != "q.alpha" and value != 0:
            new[key] = value * (1 + rng.choice([-1, 1]) * rng.uniform(low, high))
    return machine.with_params(new)


def _random_duty(rng, hours, with_feed, sample_period_s):
    """Alternating random speed steps and rests of 0.5-1.75 h, each
    starting on a sample (the logged speeds are the speeds in force, so the
    simulation's only mismatch is the one drawn)."""
    steps, t = [], 0.0
    on = bool(rng.randint(2))
    while t < hours - 1e-9:
        length = min(rng.uniform(0.5, 1.75), hours - t)
        rpm = float(rng.choice([2000, 3000, 4000, 6000, 8000, 9000])) if on else 0.0
        feed = (
            float(rng.choice([1000, 2500, 4000]))
            if with_feed and rng.rand() < 0.6
            else 0.0
        )
        steps.append((length, rpm, feed))
        t += length
        on = not on
    ends = np.cumsum([length for length, _, _ in steps]) * 3600.0 / sample_period_s
    ends = np.ceil(ends - 1e-9) * sample_period_s
    lengths = np.diff(ends, prepend=0.0)
    # (A last step shorter than a sample ends on the run's last sample.)
    return DutyCycle(
        [
            (d, rpm, feed)
            for d, (_, rpm, feed) in zip(lengths, steps, strict=True)
            if d > 0
        ]
    )


def make_gap_campaign(
    effect,
    *,
    preset="vmc-b",
    n_runs=4,
    hours=6.0,
    strength=1.0,
    perturbation=(0.1, 0.2),
    sample_period_s=60.0,
    random_state=None,
):
    """Measured-like runs of a perturbed machine with one effect switched on.

    Parameters
    ----------
    effect : str or None
        The effect the "real" machine has and the simulation lacks (None for
        the null case).
    preset : {"vmc-b", "vmc-a", "spindle-rig"}, default="vmc-b"
        The machine; an effect it cannot have (``feed_heating`` on a machine
        without a feed axis) is an error.
    n_runs : int >= 2, default=4
    hours : float >= 2, default=6.0
        Length of every run: random spindle speeds with stops, feed motion in
        some segments, day/night air and (in at least one run) a door event.
    strength : float > 0, default=1.0
        Multiplier of the effect's parameter (for ``ambient_transient``, of
        the door-event drop). The null case is ``effect=None``.
    perturbation : (float, float) with 0 <= low <= high < 1, default=(0.1, 0.2)
        Every capacity, conductance, convection, heat input and
        displacement coefficient of the truth differs from the simulation by
        a random factor ``1 ± U(low, high)``.
    sample_period_s : float, default=60.0
    random_state : int, RandomState instance or None

    Returns
    -------
    GapCase
        ``simulation`` (the unperturbed preset without effects), ``truth``
        and the noisy measured ``runs``.

    Examples
    --------
    >>> from skthermal.gap import make_gap_campaign
    >>> case = make_gap_campaign("tool_growth", n_runs=2, hours=3, random_state=0)
    >>> case.truth.effects, case.simulation.effects, case.runs["run"].nunique()
    (('tool_growth',), (), 2)
    """
    rng = check_random_state(random_state)
    if effect is not None and effect not in EFFECTS:
        raise ValueError(
            f"Unknown effect {effect!r}; the vocabulary is {list(EFFECTS)}."
        )
    if isinstance(n_runs, bool) or not float(n_runs).is_integer() or n_runs < 2:
        raise ValueError(
            f"n_runs must be an integer >= 2 (the diagnosis holds runs out), got "
            f"{n_runs!r}."
        )
    if not (np.isfinite(hours) and hours >= 2.0):
        raise ValueError(
            f"hours must be at least 2 (a run has a door event between 0.5 h "
            f"and 1.5 h before its end), got {hours!r}."
        )
    if effect is not None and not (
        isinstance(strength, Real) and np.isfinite(strength) and strength > 0
    ):
        raise ValueError(
            f"strength must be a finite number > 0 for an effect case, got "
            f"{strength!r}; the case without the effect is effect=None."
        )
    low, high = (float(v) for v in perturbation)
    if not (0.0 <= low <= high < 1.0):
        raise ValueError(
            "perturbation must be (low, high) with 0 <= low <= high < 1 (factors "
            f"1 ± U(low, high) keep every parameter positive), got {perturbation!r}."
        )
    n_runs = int(n_runs)
    simulation = ThermalMachine.from_preset(preset, effects=[])
    truth = _perturbed(simulation, rng, *perturbation)
    # Each campaign's truth is another machine of the preset: its own name
    # gives its sensors their own calibration offsets and drift rates (the
    # simulator draws them from the machine's and the sensor's names).
    serial = zlib.crc32(repr(sorted(truth.params.items())).encode())
    truth = ThermalMachine.from_spec(
        dataclasses.replace(truth.spec, name=f"{preset} truth {serial:08x}"),
        effects=[],
        params=truth.params,
    )
    if effect is not None:
        truth = truth.with_effects([effect]).with_params(
            {k: v * strength for k, v in _STRENGTH[effect].items()}
        )
    door_drop = 8.0 * (strength if effect == "ambient_transient" else 1.0)
    with_feed = True
    frames = []
    door_run = rng.randint(n_runs)
    first = None  # the first run's drivers, to check that the effect acts
    for r in range(n_runs):
        events = []
        if r == door_run or rng.rand() < 0.4:
            events.append(
                DoorEvent(
                    start_h=rng.uniform(0.5, hours - 1.5),
                    drop_C=door_drop * rng.uniform(0.7, 1.1),
                )
            )
        air = AmbientProfile(
            mean_C=rng.uniform(18, 23),
            trend_C_per_h=rng.uniform(-0.3, 0.3),
            day_amplitude_C=rng.uniform(0, 2.5),
            start_hour=rng.uniform(0, 24),
            door_events=events,
            noise_C=0.05,
        )
        duty = _random_duty(rng, hours, with_feed, sample_period_s)
        first = first or (duty, air)
        frames.append(
            truth.simulate(
                duty,
                air,
                sample_period_s=sample_period_s,
                run=f"r{r + 1}",
                random_state=rng,
            )
        )
    if effect is not None:
        _check_acts(truth, effect, preset, *first, sample_period_s)
    for f in frames:
        f.attrs.clear()
    runs = pd.concat(frames, ignore_index=True)
    return GapCase(simulation, truth, runs, effect, float(strength))


def _check_acts(truth, effect, preset, duty, air, sample_period_s):
    """Raise a ValueError when ``effect`` changes nothing the truth measures
    (noise-free, on the first run's drivers): a campaign whose "withheld"
    effect is absent is a null case in disguise."""
    if EFFECTS[effect].residual:  # a random process on the sensors' readings
        if not truth.spec.sensors:
            raise ValueError(
                f"The {preset!r} preset has no temperature sensor: {effect!r} "
                "cannot act on it."
            )
        return
    # The same draws of the air for both (its noise is part of the drivers).
    kwargs = {"sample_period_s": sample_period_s, "noise": False, "random_state": 0}
    with_effect = truth.simulate(duty, air, **kwargs)
    without = truth.with_effects([]).simulate(duty, air, **kwargs)
    cols = [c for c in with_effect.columns if is_channel(c)]
    diff = np.max(np.abs(with_effect[cols].to_numpy() - without[cols].to_numpy()))
    if not diff > 1e-9:
        raise ValueError(
            f"The effect {effect!r} changes nothing on the {preset!r} preset "
            f"(largest change of a channel {diff:.2g}): "
            + (
                "it has no feed axis. "
                if effect == "feed_heating" and not truth.spec.screw_nodes
                else ""
            )
            + "Choose another preset or effect."
        )


@dataclass
class ValidationReport:
    """Result of :func:`validate`: every case and the summary rates."""

    cases: pd.DataFrame
    confusion: pd.DataFrame
    rates: dict
    targets: dict = field(default_factory=dict)

    def meets_targets(self):
        """True when every target of the validation is met."""
        return all(self.targets.values())

    def to_markdown(self):
        from skthermal.gap._report import gap_table

        lines = ["# Gap diagnosis validation", ""]
        for k, v in self.rates.items():
            lines.append(f"- {k}: {v:.3f}" if isinstance(v, float) else f"- {k}: {v}")
        lines += ["", "## Targets", ""]
        lines += [
            f"- {k}: {'met' if v else 'NOT met'}" for k, v in self.targets.items()
        ]
        lines += [
            "",
            "## Confusion (rows: truth, columns: diagnosis)",
            "",
            gap_table(self.confusion.reset_index()),
            "",
            "## Cases",
            "",
            gap_table(self.cases),
        ]
        return "\n".join(lines) + "\n"


def _one_case(kind, effect, seed, strength, preset, n_runs, hours, candidates, kwargs):
    case = make_gap_campaign(
        effect,
        preset=preset,
        n_runs=n_runs,
        hours=hours,
        strength=strength,
        random_state=seed,
    )
    from skthermal.gap._diagnose import diagnose

    report = diagnose(
        case.simulation, case.runs, candidates=candidates, greedy=False, **kwargs
    )
    ranking = report.ranking.set_index("effect")
    true_row = ranking.loc[effect] if effect in ranking.index else None
    fine = report.how_far_evidence
    if true_row is None:
        how_far = np.nan
    elif fine.get("effect") == effect:
        how_far = float(fine["shrink"])
    else:
        # The how-far step ran for another candidate: the withheld effect's
        # screening figure stands in.
        how_far = float(true_row["shrink"])
    return {
        "case": kind,
        "truth": effect or "none",
        "seed": seed,
        "strength": strength,
        "diagnosis": report.best_effect or "none",
        "top_candidate": report.ranking.iloc[0]["effect"],
        "top_shrink": float(report.ranking.iloc[0]["shrink"]),
        "true_effect_shrink": float(true_row["shrink"])
        if true_row is not None
        else np.nan,
        "true_effect_how_far": how_far,
        "how_far_effect": fine.get("effect"),
        "how_far_shrink": float(fine["shrink"]) if fine else np.nan,
        "how_far_p": float(fine["p_value"]) if fine else np.nan,
        "how_far_share": float(fine.get("share_of_explainable", np.nan))
        if fine
        else np.nan,
        "explainable_share": float(report.explainable.get("share", np.nan))
        if report.explainable
        else np.nan,
        "true_effect_rank": (
            int(list(ranking.index).index(effect)) + 1
            if true_row is not None
            else np.nan
        ),
    }


@with_single_threaded_blas
def validate(
    effects=None,
    *,
    seeds=5,
    preset="vmc-b",
    n_runs=4,
    hours=6.0,
    strengths=(0.5, 2.0),
    out_of_vocabulary="tool_growth",
    include_null=True,
    n_jobs=None,
    random_state=0,
    **diagnose_kwargs,
):
    """Check the diagnosis on campaigns whose effect is known.

    For every effect and seed, runs of a perturbed machine with that effect
    switched on (strength drawn from ``strengths``) are diagnosed with the
    unperturbed simulation lacking it (candidates: the whole vocabulary). The
    null case adds no effect; the out-of-vocabulary case adds
    ``out_of_vocabulary`` but leaves it out of the candidates.

    Targets: the withheld effect is ranked first in at least 90% of its cases,
    the null case is called "none" in at least 90%, the out-of-vocabulary
    case is never blamed on a wrong effect, and adding the withheld effect
    removes at least 70% of the held-out gap above the noise floor (mean over
    its cases, as the diagnosis's how-far step measures it: with the fine
    calibration; the screening figure of the ranking is reported beside it,
    and stands in when the withheld effect is not the how-far step's
    candidate). The stricter rate at which the withheld effect is also
    *named* (passes the explains test) is reported beside them.

    Returns
    -------
    ValidationReport
    """
    rng = check_random_state(random_state)
    effects = list(EFFECTS) if effects is None else list(effects)
    jobs = []
    for effect in effects:
        for _ in range(seeds):
            jobs.append(
                (
                    "effect",
                    effect,
                    int(rng.randint(2**31 - 1)),
                    float(np.exp(rng.uniform(*np.log(strengths)))),
                    None,
                )
            )
    if include_null:
        for _ in range(seeds):
            jobs.append(("null", None, int(rng.randint(2**31 - 1)), 1.0, None))
    if out_of_vocabulary:
        cands = [e for e in EFFECTS if e != out_of_vocabulary]
        for _ in range(seeds):
            jobs.append(
                (
                    "out of vocabulary",
                    out_of_vocabulary,
                    int(rng.randint(2**31 - 1)),
                    float(np.exp(rng.uniform(*np.log(strengths)))),
                    cands,
                )
            )
    # One line per finished case, from this process: with n_jobs the
    # workers' own step lines do not reach the caller's log.
    rows = []
    results = Parallel(n_jobs=n_jobs, return_as="generator")(
        delayed(_one_case)(
            kind, effect, seed, strength, preset, n_runs, hours, cands, diagnose_kwargs
        )
        for kind, effect, seed, strength, cands in jobs
    )
    for row in results:
        rows.append(row)
        case = "null case" if row["case"] == "null" else f"{row['case']} {row['truth']}"
        logger.info(
            "Case %d of %d (%s, seed %d): named %s, top candidate %s",
            len(rows),
            len(jobs),
            case,
            row["seed"],
            row["diagnosis"],
            row["top_candidate"],
        )
    cases = pd.DataFrame(rows)
    confusion = pd.crosstab(cases["case"] + ": " + cases["truth"], cases["diagnosis"])
    eff = cases[cases["case"] == "effect"]
    null = cases[cases["case"] == "null"]
    oov = cases[cases["case"] == "out of vocabulary"]
    rates = {}
    if len(eff):
        first = eff["true_effect_rank"] == 1
        named = eff["diagnosis"] == eff["truth"]
        rates["withheld effect ranked first"] = float(first.mean())
        rates["withheld effect named (explains the gap)"] = float(named.mean())
        per = eff.assign(first=first, named=named).groupby("truth")
        for k, v in per["first"].mean().items():
            rates[f"ranked first: {k}"] = float(v)
        for k, v in per["named"].mean().items():
            rates[f"named: {k}"] = float(v)
        rates["mean shrink of the withheld effect"] = float(
            eff["true_effect_how_far"].mean()
        )
        rates["median shrink of the withheld effect"] = float(
            eff["true_effect_how_far"].median()
        )
        rates["mean screening shrink of the withheld effect"] = float(
            eff["true_effect_shrink"].mean()
        )
        for k, v in eff.groupby("truth")["true_effect_how_far"].mean().items():
            rates[f"mean shrink: {k}"] = float(v)
    if len(null):
        rates["null called none"] = float((null["diagnosis"] == "none").mean())
    if len(oov):
        rates["out of vocabulary called none"] = float(
            (oov["diagnosis"] == "none").mean()
        )
    targets = {}
    if len(eff):
        targets["withheld effect ranked first >= 90%"] = (
            rates["withheld effect ranked first"] >= 0.9
        )
        targets["mean shrink of the withheld effect >= 70%"] = (
            rates["mean shrink of the withheld effect"] >= 0.7
        )
    if len(null):
        targets["null called none >= 90%"] = rates["null called none"] >= 0.9
    if len(oov):
        targets["out of vocabulary never blamed on a wrong effect"] = (
            rates["out of vocabulary called none"] == 1.0
        )
    return ValidationReport(cases, confusion, rates, targets)
