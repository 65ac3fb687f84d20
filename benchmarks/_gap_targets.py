"""The truth-machine protocol shared by ``bench_gap_truth.py``
(ThermalMachine mode) and ``bench_gap_external.py`` (run-table mode): the
cases run in parallel, the per-case table, the confusion table and the
target rates."""

import argparse
import time

import pandas as pd
from joblib import Parallel, delayed
from truth import CASES

NOT_IN_VOCABULARY = ("null", "coolant")


def summarise(df):
    """Confusion table (truth x named) and target rates of a results table.

    ``df`` has one row per case and seed with ``case``, ``named``,
    ``ranked_first``, ``true_shrink`` and, when the mode reports it,
    ``true_share`` (share of the explainable gap).
    """
    vocabulary = [c for c in CASES if c not in NOT_IN_VOCABULARY]
    confusion = pd.crosstab(df["case"], df["named"]).reindex(
        index=[c for c in CASES if c in set(df["case"])],
        columns=[*vocabulary, "none"],
        fill_value=0,
    )
    eff = df[~df["case"].isin(NOT_IN_VOCABULARY)]
    null = df[df["case"] == "null"]
    oov = df[df["case"] == "coolant"]
    rates = {}
    if len(eff):
        rates["withheld effect ranked first (>= 90%)"] = (
            eff["ranked_first"] == eff["case"]
        ).mean()
        rates["withheld effect named"] = (eff["named"] == eff["case"]).mean()
        rates["mean held-out shrink of the withheld effect (>= 0.70)"] = eff[
            "true_shrink"
        ].mean()
        if "true_share" in eff:
            # Unclipped shares: above 1 where the effect's term removes more
            # than the flexible model held out, NaN where that removes
            # nothing; the median reads them better than the mean.
            share = eff["true_share"]
            rates["median share of the explainable gap, withheld effect"] = (
                share.median()
            )
            rates["  cases with a share / share above 1"] = (
                f"{int(share.notna().sum())} / {int((share > 1).sum())}"
            )
    if len(null):
        rates["null called none (>= 90%)"] = (null["named"] == "none").mean()
    if len(oov):
        rates["out-of-vocabulary not blamed on an effect (100%)"] = (
            oov["named"] == "none"
        ).mean()
    return confusion, rates


def run_cases(one_case, jobs, n_jobs):
    """Run ``one_case(case, seed)`` for every ``(case, seed)`` of ``jobs`` in
    parallel, printing each as it ends; the results table in (seed, case)
    order and the seconds taken."""
    t0 = time.perf_counter()
    rows = []
    for row in Parallel(n_jobs=n_jobs, return_as="generator_unordered")(
        delayed(one_case)(c, s) for c, s in jobs
    ):
        rows.append(row)
        print(
            f"[{len(rows)}/{len(jobs)}] {row['case']} seed {row['seed']}: "
            f"first {row['ranked_first']}, named {row['named']} "
            f"({row['seconds']:.0f} s)",
            flush=True,
        )
    rows.sort(key=lambda r: (r["seed"], CASES.index(r["case"])))
    return pd.DataFrame(rows), time.perf_counter() - t0


def print_results(df, columns):
    """The per-case table (``columns``), the confusion table and the
    target rates."""
    with pd.option_context("display.width", 220, "display.max_columns", 30):
        print("Per case:")
        print(df[columns].to_string(index=False, float_format=lambda v: f"{v:.3g}"))
        confusion, rates = summarise(df)
        print("\nConfusion (rows: truth; columns: named):")
        print(confusion.to_string())
        print("\nTargets:")
        for k, v in rates.items():
            print(f"  {k}: {v:.2f}" if not isinstance(v, str) else f"  {k}: {v}")


def add_prehistory(parser):
    """``--prehistory HOURS``: random duty on the truth before each run."""
    parser.add_argument(
        "--prehistory",
        type=float,
        default=0.0,
        help="hours of random duty on the truth before each run (default 0: "
        "every run starts soaked at its first air reading)",
    )


def parse_args(description, argv=None, add_arguments=None):
    """The protocol's command line: ``--seeds``, ``--effects`` (cases),
    ``--n-runs``, ``--n-jobs``, ``--out`` and what ``add_arguments(parser)``
    adds; returns the arguments and the list of (case, seed) jobs."""
    parser = argparse.ArgumentParser(description=description)
    if add_arguments is not None:
        add_arguments(parser)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument(
        "--effects",
        default=",".join(CASES),
        help=f"comma-separated cases among {', '.join(CASES)}",
    )
    parser.add_argument("--n-runs", type=int, default=4)
    parser.add_argument("--n-jobs", type=int, default=1, help="cases in parallel")
    parser.add_argument("--out", help="write the per-case results to this CSV")
    args = parser.parse_args(argv)
    cases = [c.strip() for c in args.effects.split(",") if c.strip()]
    unknown = sorted(set(cases) - set(CASES))
    if unknown:
        parser.error(f"unknown case(s) {unknown}; choose among {list(CASES)}")
    return args, [(c, s) for s in range(args.seeds) for c in cases]
