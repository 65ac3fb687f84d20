"""ANFIS on a real spindle record against ridge regression, channel by channel.

FL_THERMAL (``../shared/data/fl_thermal_spindle.csv.gz``, one 46 h record):
inputs are the changes of all 16 temperatures since the record's first row,
targets the changes of each displacement channel ``disp_ch1_um`` ..
``disp_ch5_um`` separately; chronological split, the first 60 % for training
and the last 40 % held out. Both models see the same standardised inputs, and
every setting is chosen on the training part only:

- ``RidgeCV``: scikit-learn's ridge, alpha chosen from 1e-3 .. 1e4 by its
  efficient leave-one-out cross-validation on the training part;
- ``ANFISRegressor`` with fuzzy c-means rules (3 rules) and ``ridge="auto"``:
  the consequents' ridge chosen by the checking RMSE on the last quarter of
  the training part, then refitted on the whole training part.

Prints the held-out RMSE (µm) of each and the ratio ANFIS / RidgeCV per
channel; exit status 1 when ANFIS is worse than RidgeCV on any channel.

Run:  python benchmarks/bench_anfis_real.py [--data ../shared/data]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from sklearn.linear_model import RidgeCV
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from skthermal.datasets import load_fl_thermal
from skthermal.fuzzy import ANFISRegressor

DEFAULT_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=str(DEFAULT_DATA), help="shared data")
    parser.add_argument("--train-fraction", type=float, default=0.6)
    parser.add_argument("--n-clusters", type=int, default=3)
    parser.add_argument("--epochs", type=int, default=100)
    args = parser.parse_args(argv)
    try:
        table = load_fl_thermal(args.data)
    except (OSError, FileNotFoundError) as exc:
        print(f"FL_THERMAL not found under {args.data}: {exc}")
        return 2
    temps = table[[f"T{i}_C" for i in range(1, 17)]].to_numpy(dtype=float)
    X = temps - temps[0]
    k = int(round(args.train_fraction * X.shape[0]))
    print(
        f"FL_THERMAL: {X.shape[0]} rows, 16 temperature changes; training rows "
        f"0-{k - 1}, held out {k}-{X.shape[0] - 1}\n"
    )
    print("channel  RidgeCV (alpha)     ANFIS-FCM (ridge)     ANFIS/RidgeCV  time")
    worse = []
    for ch in range(1, 6):
        y = table[f"disp_ch{ch}_um"].to_numpy(dtype=float)
        y = y - y[0]
        ridge = make_pipeline(StandardScaler(), RidgeCV(alphas=np.logspace(-3, 4, 15)))
        ridge.fit(X[:k], y[:k])
        r_ridge = rmse(ridge.predict(X[k:]), y[k:])
        anfis = make_pipeline(
            StandardScaler(),
            ANFISRegressor(
                n_clusters=args.n_clusters,
                ridge="auto",
                epochs=args.epochs,
                random_state=0,
            ),
        )
        t0 = time.perf_counter()
        anfis.fit(X[:k], y[:k])
        elapsed = time.perf_counter() - t0
        r_anfis = rmse(anfis.predict(X[k:]), y[k:])
        ratio = r_anfis / r_ridge
        if ratio > 1:
            worse.append(ch)
        print(
            f"ch{ch}      {r_ridge:6.2f} ({ridge[-1].alpha_:8.3g})   "
            f"{r_anfis:6.2f} ({anfis[-1].ridge_:8.3g})     {ratio:6.2f}       "
            f"{elapsed:5.1f} s"
        )
    print(
        "\nANFIS-FCM not worse than RidgeCV on every channel: "
        + ("yes" if not worse else f"no (worse on ch{worse})")
    )
    return 1 if worse else 0


if __name__ == "__main__":
    sys.exit(main())
