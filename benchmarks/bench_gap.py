"""Gap diagnosis: speed of a full diagnosis, and the validation campaign.

1. A full diagnosis of 6 measured runs (6 h each, vmc-b, 77 temperatures and
   3 displacements) with all 6 candidate effects, in parallel over candidates
   (n_jobs=2) and, side by side in the same run, serially (n_jobs=1); prints
   both times and the speed-up. Target: at most 60 s on 2 cores.
2. With ``--validate N``: the validation of METHODS-style targets over N seeds
   per effect (plus null and out-of-vocabulary cases), the confusion table and
   whether each target is met (same as ``skthermal gap-check --seeds N``).

Run:  python benchmarks/bench_gap.py [--validate 5] [--check]
"""

import argparse
import sys
import time

from skthermal.gap import diagnose, make_gap_campaign, validate


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--validate", type=int, default=0, metavar="SEEDS")
    parser.add_argument(
        "--check",
        action="store_true",
        help="exit 1 if the diagnosis takes more than 60 s",
    )
    args = parser.parse_args(argv)

    case = make_gap_campaign("tool_growth", n_runs=6, hours=6.0, random_state=0)
    times = {}
    for n_jobs in (2, 1):
        t0 = time.perf_counter()
        report = diagnose(case.simulation, case.runs, n_jobs=n_jobs)
        times[n_jobs] = time.perf_counter() - t0
    print(
        f"6 runs x 6 h, {len(report.ranking)} candidates, vmc-b, "
        f"{len(report.settings['channels'])} channels"
    )
    print(f"  diagnosis, n_jobs=2 : {times[2]:6.1f} s")
    print(f"  diagnosis, n_jobs=1 : {times[1]:6.1f} s")
    print(f"  speed-up            : {times[1] / times[2]:6.2f} x")
    print(f"  verdict: {report.verdict()}")
    failed = args.check and times[2] > 60
    if args.validate:
        t0 = time.perf_counter()
        val = validate(seeds=args.validate, n_jobs=2, random_state=0)
        print(
            f"\nvalidation, {args.validate} seeds per case: "
            f"{time.perf_counter() - t0:.0f} s"
        )
        print(val.confusion.to_string())
        for k, v in val.rates.items():
            print(f"  {k}: {v:.2f}")
        for k, v in val.targets.items():
            print(f"  target {k}: {'met' if v else 'NOT met'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
