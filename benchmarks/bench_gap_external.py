"""Gap diagnosis of an external simulation's run table against a structurally
different truth machine.

For each case (each effect of the diagnosis's vocabulary, a null case and an
out-of-vocabulary coolant load) and each seed, a random campaign of 4 runs
(duty cycles and room air as ``benchmarks/truth/campaign.py`` draws them) is
simulated twice:

- *measured*: the truth machine of ``benchmarks/truth`` with the case's
  effect (noise, quantisation, offsets);
- *simulated*: an imperfect external model: another machine of the same
  kind without the effect, its capacities, conductances, convection and heat
  inputs drawn anew (each within 15% of nominal, so 0-30% away from the
  truth's), its bearing-loss exponent drawn anew, and every
  displacement coefficient of every node perturbed by up to 20%; noise-free,
  fed the measured drivers.

``diagnose_runs(simulated, measured)`` is then run with its default
candidates. Prints the confusion table (truth x named), the four target
rates (withheld effect ranked first >= 90%, null called none >= 90%,
out-of-vocabulary never blamed on a wrong effect, mean held-out shrink of the
withheld effect >= 70%) and the time taken.

Run:  python benchmarks/bench_gap_external.py [--seeds 5] [--effects a,b]
      [--n-jobs 2] [--prehistory 12] [--out results.csv]
"""

import sys
import time
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _gap_targets import (  # noqa: E402
    add_prehistory,
    parse_args,
    print_results,
    run_cases,
)
from truth import (  # noqa: E402
    CASES,
    EFFECTS,
    TruthMachine,
    random_blocks,
    random_room,
    warm_run_table,
)

from skthermal.gap import diagnose_runs  # noqa: E402

DRIVERS = ("spindle_rpm", "feed_mm_min", "ambient_C")


def make_pair(
    case, seed, n_runs=4, hours=(5.0, 7.0), sample_period_s=60.0, prehistory=0.0
):
    """Measured runs of the truth with ``case``, and the run table of an
    imperfect simulation of the same runs without it. With ``prehistory``
    (hours), the truth runs random duty before each run and the simulation
    does not know it: it starts every run soaked, as a simulation of the
    test alone does."""
    rng = np.random.default_rng([seed, CASES.index(case), 17])
    effects = [] if case == "null" else [EFFECTS[case](rng.integers(2**32))]
    truth = TruthMachine(effects, random_state=rng.integers(2**32))
    model = TruthMachine([], random_state=rng.integers(2**32))
    model.D = model.D * (1 + rng.uniform(-0.2, 0.2, size=model.D.shape))
    doors = rng.poisson(0.8, n_runs)
    if doors.sum() == 0:
        doors[0] = 1
    # Its own stream (spawning leaves ``rng``'s draws as they were).
    pre_rng = rng.spawn(1)[0] if prehistory > 0 else None
    measured, simulated = [], []
    for i in range(n_runs):
        h = np.round(rng.uniform(*hours) * 60) / 60
        blocks = random_blocks(rng, h, sample_period_s)
        room = random_room(rng, doors[i])
        name = f"run{i + 1}"
        pre = (
            random_blocks(pre_rng, prehistory, sample_period_s)
            if pre_rng is not None
            else []
        )
        m = warm_run_table(
            truth,
            pre,
            blocks,
            room,
            sample_period_s=sample_period_s,
            run=name,
            random_state=rng.integers(2**32),
        )
        s = model.run_table(
            blocks, room, sample_period_s=sample_period_s, run=name, noise=False
        )
        # The external tool was fed the logged drivers.
        s[list(DRIVERS)] = m[list(DRIVERS)].to_numpy()
        measured.append(m)
        simulated.append(s)
    return (
        pd.concat(simulated, ignore_index=True),
        pd.concat(measured, ignore_index=True),
        truth,
    )


def one_case(case, seed, n_runs, prehistory=0.0):
    """Diagnose one pair of tables; a dict of the figures of interest."""
    t0 = time.perf_counter()
    simulated, measured, truth = make_pair(case, seed, n_runs, prehistory=prehistory)
    report = diagnose_runs(simulated, measured)
    ranking = report.ranking.reset_index(drop=True)
    top = ranking.iloc[0]
    row = {
        "case": case,
        "seed": seed,
        "strength": repr(truth.effects[0]) if truth.effects else "",
        "named": report.best_effect or "none",
        "ranked_first": top["effect"],
        "top_shrink": float(top["shrink"]),
        "top_p": float(top["p_value"]),
        "top_lr_p": float(top["lr_p_value"]),
        "base_gap": float(top["gap_before"]),
        "explainable": float(report.explainable["share"]),
        "noise_floor": float(report.noise_floor),
        "true_rank": np.nan,
        "true_shrink": np.nan,
        "true_share": np.nan,
        "true_p": np.nan,
    }
    hit = ranking.index[ranking["effect"] == case]
    if len(hit):
        true = ranking.loc[hit[0]]
        row["true_rank"] = int(hit[0]) + 1
        row["true_shrink"] = float(true["shrink"])
        row["true_share"] = float(true["share_of_explainable"])
        row["true_p"] = float(true["p_value"])
    row["seconds"] = time.perf_counter() - t0
    return row


def main(argv=None):
    args, jobs = parse_args(__doc__.splitlines()[0], argv, add_prehistory)
    df, elapsed = run_cases(
        partial(one_case, n_runs=args.n_runs, prehistory=args.prehistory),
        jobs,
        args.n_jobs,
    )
    if args.out:
        df.to_csv(args.out, index=False)
    print_results(
        df,
        [
            "case",
            "seed",
            "ranked_first",
            "named",
            "true_rank",
            "true_shrink",
            "true_share",
            "true_p",
            "top_shrink",
            "top_p",
            "top_lr_p",
            "base_gap",
            "explainable",
            "noise_floor",
            "seconds",
        ],
    )
    print(
        f"\n{len(jobs)} external-mode diagnoses against the truth machine in "
        f"{elapsed / 60:.1f} min (n_jobs={args.n_jobs})"
    )


if __name__ == "__main__":
    main()
