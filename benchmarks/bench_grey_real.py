"""Grey regressors on a real spindle test: held-out RMSE against linear regression.

FL_THERMAL (one 46 h run, see ``../shared/data/README.md``): the first 60% of
the record trains, all 16 temperatures are the inputs, each displacement
channel is a separate target. The whole record is predicted as one run (the
sequence models see the true run start) and scored on the last 40%. The grey
regressors predict the change since the run start; the first training
displacement is added back. Every setting (the ridge term ``alpha``, the
development coefficient) is chosen on the training part only, by blocked
cross-validation inside ``fit`` (``alpha="auto"``, the default).

A second table shows the other way to use a chronological split: the model
is fitted on the first 60% of the labelled run table (``split_runs``) and
``predict`` gets only the last 40%; the run label seen in ``fit`` makes it
continue the run, so the scores equal those of the whole-record protocol.
Given the tail as a plain array instead, the model restarts the run at the
tail's first row (with a warning), offset here by the last training
displacement: what the library did before it continued runs.

Run: ``python benchmarks/bench_grey_real.py [path/to/data]``.
"""

import sys
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn.linear_model import LinearRegression

from skthermal.datasets import load_fl_thermal, split_runs
from skthermal.grey import GNNMCIRegressor, GreyPSORegressor

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def grey_ratios(df, models, channels=range(1, 6), train_fraction=0.6):
    """Held-out RMSE of each model and its ratio to linear regression, per channel."""
    T = df[[f"T{i}_C" for i in range(1, 17)]].to_numpy()
    n_train = int(train_fraction * len(T))
    rows = []
    for ch in channels:
        y = df[f"disp_ch{ch}_um"].to_numpy()
        lr = LinearRegression().fit(T[:n_train], y[:n_train])
        base = rmse(lr.predict(T[n_train:]), y[n_train:])
        for name, model in models.items():
            t0 = time.perf_counter()
            # The record is one run: say so (plain arrays carry no labels).
            model.fit(T[:n_train], y[:n_train], groups=np.zeros(n_train))
            pred = model.predict(T, groups=np.zeros(len(T))) + y[0]
            err = rmse(pred[n_train:], y[n_train:])
            rows.append(
                (
                    ch,
                    name,
                    base,
                    err,
                    err / base,
                    model.alpha_,
                    time.perf_counter() - t0,
                )
            )
    return rows


def tail_protocol(df, models, channels=range(1, 6), train_fraction=0.6):
    """Fit on the labelled head, predict the tail alone: continued vs restarted."""
    sensors = [f"T{i}_C" for i in range(1, 17)]
    rows = []
    for ch in channels:
        X, Y, _ = split_runs(df, sensors=sensors, targets=[f"disp_ch{ch}_um"])
        y = Y.iloc[:, 0].to_numpy()
        k = int(train_fraction * len(y))
        for name, model in models.items():
            model.fit(X.iloc[:k], y[:k])
            whole = model.predict(X) + y[0]
            tail = model.predict(X.iloc[k:]) + y[0]  # continues the run
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the warning is the point
                restarted = model.predict(X.iloc[k:].to_numpy()) + y[k - 1]
            rows.append(
                (
                    ch,
                    name,
                    rmse(whole[k:], y[k:]),
                    rmse(tail, y[k:]),
                    rmse(restarted, y[k:]),
                )
            )
    return rows


def main(path=DATA):
    df = load_fl_thermal(path)
    models = {
        "GreyPSORegressor (varpro, alpha=auto)": GreyPSORegressor(),
        "GreyPSORegressor (pso, alpha=auto)": GreyPSORegressor(
            calibration="pso", random_state=0
        ),
        "GreyPSORegressor (varpro, alpha=0)": GreyPSORegressor(alpha=0.0),
        "GNNMCIRegressor (alpha=auto)": GNNMCIRegressor(random_state=0),
        "GNNMCIRegressor (alpha=0)": GNNMCIRegressor(alpha=0.0, random_state=0),
    }
    print(
        f"{'ch':>2}  {'model':<40} {'LR µm':>7} {'RMSE µm':>8} {'ratio':>6} "
        f"{'alpha':>8} {'fit s':>6}"
    )
    for ch, name, base, err, ratio, alpha, sec in grey_ratios(df, models):
        print(
            f"{ch:>2}  {name:<40} {base:7.2f} {err:8.2f} {ratio:6.2f} "
            f"{alpha:8.2g} {sec:6.1f}"
        )
    print()
    print("Tail alone, held-out RMSE (µm): whole record / tail with its run label /")
    print("tail as a plain array (restarted at its first row)")
    defaults = {
        "GreyPSORegressor()": GreyPSORegressor(),
        "GNNMCIRegressor()": GNNMCIRegressor(random_state=0),
    }
    for ch, name, whole, tail, restarted in tail_protocol(df, defaults):
        print(f"{ch:>2}  {name:<22} {whole:8.2f} {tail:8.2f} {restarted:8.2f}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else DATA)
