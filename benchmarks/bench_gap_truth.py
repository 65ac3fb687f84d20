"""Gap diagnosis against a structurally different truth machine.

For each case (each effect of the diagnosis's vocabulary, a null case and an
out-of-vocabulary coolant load) and each seed, a random campaign of 4 runs
is made on the truth machine of ``benchmarks/truth`` (a finite-difference
network with its own heat inputs, displacement map and effect
implementations, independent of ``skthermal.simulate``), and
``diagnose(ThermalMachine.from_preset("vmc-b", effects=[]), runs)`` is run
with its default candidates. Recorded per case: the effect ranked first, the
effect named (or none), the held-out shrink above noise and p-value of the
withheld effect (from the how-far step when it ran for that effect, else
the screening ranking) and its share of the explainable gap (what a
flexible model of the drivers, holding every candidate, removes held out),
and of the top candidate (with its in-sample likelihood-ratio p-value).

Prints the confusion table (truth x named), the four target rates
(withheld effect ranked first >= 90%, null called none >= 90%,
out-of-vocabulary never blamed on a wrong effect, mean held-out shrink of the
withheld effect >= 70%), the median share of the explainable gap and the
time taken.

Run:  python benchmarks/bench_gap_truth.py [--seeds 5] [--effects a,b]
      [--n-jobs 2] [--prehistory 12] [--initial ambient] [--out results.csv]
"""

import sys
import time
from functools import partial
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _gap_targets import (  # noqa: E402
    add_prehistory,
    parse_args,
    print_results,
    run_cases,
)
from truth import CASES, make_truth_campaign  # noqa: E402

from skthermal.gap import diagnose  # noqa: E402
from skthermal.simulate import ThermalMachine  # noqa: E402


def one_case(case, seed, n_runs, diagnose_jobs, prehistory=0.0, initial="auto"):
    """Diagnose one truth campaign; a dict of the figures of interest."""
    t0 = time.perf_counter()
    runs, truth = make_truth_campaign(
        case,
        n_runs=n_runs,
        prehistory_hours=prehistory,
        random_state=[seed, CASES.index(case)],
    )
    machine = ThermalMachine.from_preset("vmc-b", effects=[])
    report = diagnose(machine, runs, n_jobs=diagnose_jobs, initial=initial)
    ranking = report.ranking.reset_index(drop=True)
    top = ranking.iloc[0]
    fine = report.how_far_evidence or {}
    row = {
        "case": case,
        "seed": seed,
        "strength": repr(truth.effects[0]) if truth.effects else "",
        "named": report.best_effect or "none",
        "ranked_first": top["effect"],
        "top_shrink": float(top["shrink"]),
        "top_p": float(top["p_value"]),
        "how_far_effect": fine.get("effect"),
        "how_far_shrink": float(fine["shrink"]) if "shrink" in fine else np.nan,
        "how_far_p": float(fine["p_value"]) if "p_value" in fine else np.nan,
        "top_lr_p": float(top["lr_p_value"]),
        "base_gap": float(top["gap_before"]),
        "explainable": float(report.explainable["share"]),
        "noise_floor": float(report.noise_floor),
        "true_rank": np.nan,
        "true_shrink": np.nan,
        "true_share": np.nan,
        "true_p": np.nan,
        "true_shrink_from": "",
    }
    hit = ranking.index[ranking["effect"] == case]
    if len(hit):
        true = ranking.loc[hit[0]]
        row["true_rank"] = int(hit[0]) + 1
        if fine.get("effect") == case:
            row["true_shrink"] = row["how_far_shrink"]
            row["true_share"] = float(fine["share_of_explainable"])
            row["true_p"] = row["how_far_p"]
            row["true_shrink_from"] = "how-far (fine)"
        else:
            row["true_shrink"] = float(true["shrink"])
            row["true_share"] = float(true["share_of_explainable"])
            row["true_p"] = float(true["p_value"])
            row["true_shrink_from"] = "screening"
    row["seconds"] = time.perf_counter() - t0
    return row


def main(argv=None):
    def add_arguments(parser):
        add_prehistory(parser)
        parser.add_argument(
            "--initial",
            default="auto",
            choices=["auto", "ambient", "measured"],
            help="the runs' initial state in the diagnosis (diagnose's initial=)",
        )

    args, jobs = parse_args(__doc__.splitlines()[0], argv, add_arguments)
    # Parallel over cases; each diagnosis then runs its candidates serially.
    df, elapsed = run_cases(
        partial(
            one_case,
            n_runs=args.n_runs,
            diagnose_jobs=1,
            prehistory=args.prehistory,
            initial=args.initial,
        ),
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
            "true_shrink_from",
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
        f"\n{len(jobs)} diagnoses on vmc-b against the truth machine in "
        f"{elapsed / 60:.1f} min (n_jobs={args.n_jobs})"
    )


if __name__ == "__main__":
    main()
