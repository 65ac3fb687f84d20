"""How much of the held-out gap ``sensor_drift`` can remove at all.

``skthermal gap-check`` plants ``sensor_drift`` as a rate per sensor (the
same in every run) plus a random walk that is new in every run. A term
carried from training runs to held-out runs can at best take out the rates.
For campaigns of the gap-check's kind (vmc-b, 4 runs of 6 h, strength drawn
as gap-check draws it), this diagnoses each campaign twice with the
``sensor_drift`` candidate alone: as measured, and with every sensor's true
rate taken out of the runs (known from the truth machine; the walk stays).
It prints, side by side per campaign, the share of the base's held-out gap
above noise that the fitted rates remove (the diagnosis's how-far shrink)
and the share the true rates remove (the ceiling).

Run:  python benchmarks/bench_drift_ceiling.py [--seeds 5] [--n-jobs 2]
"""

import argparse
import warnings

import numpy as np
import pandas as pd
from joblib import Parallel, delayed

from skthermal.gap import diagnose, make_gap_campaign
from skthermal.gap._scores import excess_shrink
from skthermal.simulate._effects import sensor_draws


def _overall(report):
    table = report.how_far
    return table[table["regime"] == "overall"].iloc[0]


def one_campaign(seed, strength):
    case = make_gap_campaign(
        "sensor_drift", preset="vmc-b", strength=strength, random_state=seed
    )
    truth = case.truth
    rate = truth.params["sensor_drift.rate_C_per_h"] * sensor_draws(truth, "drift_rate")
    runs = case.runs
    without = runs.copy()
    for _, run in runs.groupby("run"):
        hours = (run["time_s"] - run["time_s"].iloc[0]).to_numpy() / 3600.0
        without.loc[run.index, truth.sensors] = run[
            truth.sensors
        ].to_numpy() - np.outer(hours, rate)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        measured = diagnose(
            case.simulation, runs, candidates=["sensor_drift"], greedy=False
        )
        removed = diagnose(
            case.simulation, without, candidates=["sensor_drift"], greedy=False
        )
    a, b = _overall(measured), _overall(removed)
    floor2 = measured.noise_floor**2
    return {
        "seed": seed,
        "strength": round(strength, 3),
        "fitted rates": excess_shrink(a["gap_before"], a["gap_after"], floor2),
        "true rates (ceiling)": excess_shrink(a["gap_before"], b["gap_before"], floor2),
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--n-jobs", type=int, default=2)
    args = parser.parse_args(argv)
    rng = np.random.RandomState(0)
    jobs = [
        (int(rng.randint(2**31 - 1)), float(np.exp(rng.uniform(*np.log([0.5, 2.0])))))
        for _ in range(args.seeds)
    ]
    rows = Parallel(n_jobs=args.n_jobs)(delayed(one_campaign)(*job) for job in jobs)
    table = pd.DataFrame(rows)
    print("Held-out shrink of sensor_drift (share of the gap above noise)")
    print(table.round(3).to_string(index=False))
    fitted, ceiling = table["fitted rates"].mean(), table["true rates (ceiling)"].mean()
    print(
        f"mean: fitted {fitted:.2f}, ceiling {ceiling:.2f}, "
        f"fitted / ceiling {fitted / ceiling:.2f}"
    )


if __name__ == "__main__":
    main()
