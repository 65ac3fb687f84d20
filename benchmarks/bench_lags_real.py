"""Dynamic compensation with lag features on real and simulated data.

Run from the repository root::

    python benchmarks/bench_lags_real.py [--data ../shared/data]

Prints held-out RMSE of ``make_lag_pipeline()`` next to a linear baseline on
FL_THERMAL (chronological 60/40, all five channels), the gas-furnace series
(co2 from input_gas_rate, chronological 60/40) and simulated Machine B tests
(leave-one-test-out).
"""

import argparse
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import GroupKFold

from skthermal.preprocessing import make_lag_pipeline

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


def fl_thermal(data=DATA):
    path = data / "fl_thermal_spindle.csv.gz"
    if not path.exists():
        print(f"FL_THERMAL: skipped ({path} not found; pass --data)")
        return
    df = pd.read_csv(path)
    temps = [f"T{i}_C" for i in range(1, 17)]
    n = len(df)
    cut = int(0.6 * n)
    index = pd.MultiIndex.from_arrays(
        [np.zeros(n, int), df["time_s"].to_numpy()], names=["run", "time_s"]
    )
    X = df[temps + ["spindle_rpm"]].set_axis(index, axis=0)
    print(f"FL_THERMAL chronological 60/40 ({cut} train / {n - cut} test rows)")
    print(f"{'channel':8s} {'LR':>7s} {'lag':>7s} {'ratio':>6s}  chosen")
    for ch in range(1, 6):
        y = df[f"disp_ch{ch}_um"].to_numpy()
        t0 = time.perf_counter()
        lr = LinearRegression().fit(df[temps].iloc[:cut], y[:cut])
        base = rmse(lr.predict(df[temps].iloc[cut:]), y[cut:])
        model = make_lag_pipeline().fit(X.iloc[:cut], y[:cut])
        pred = model.predict(X)[cut:]
        r = rmse(pred, y[cut:])
        print(
            f"ch{ch:<6d} {base:7.3f} {r:7.3f} {r / base:6.2f}  "
            f"taus={model.time_constants_} drivers={model.use_drivers_} "
            f"alpha={model.alpha_:.3g} ({time.perf_counter() - t0:.1f} s)"
        )


def gas_furnace(data=DATA):
    path = data / "gas_furnace" / "gas_furnace.csv"
    if not path.exists():
        print(f"gas furnace: skipped ({path} not found; pass --data)")
        return
    df = pd.read_csv(path)
    n = len(df)
    # One run, one sample per step: times (and time constants) in samples;
    # the gas rate is the process's input (no spindle or feed drivers).
    index = pd.MultiIndex.from_arrays(
        [["furnace"] * n, np.arange(n, dtype=float)], names=["run", "time_s"]
    )
    u = df[["input_gas_rate"]].set_axis(index)
    y = df["co2"].to_numpy()
    cut = int(0.6 * n)
    base = rmse(
        LinearRegression().fit(u.iloc[:cut], y[:cut]).predict(u.iloc[cut:]), y[cut:]
    )
    model = make_lag_pipeline(
        time_constant_sets=[(), (1.0, 3.0, 9.0), (2.0, 6.0, 18.0, 54.0)],
        drivers=None,
    )
    with warnings.catch_warnings():
        # Times in samples on purpose, not the seconds of a thermal test.
        warnings.filterwarnings("ignore", message="time_s is read as seconds")
        model.fit(u.iloc[:cut], y[:cut])
    r = rmse(model.predict(u)[cut:], y[cut:])
    print(
        f"gas furnace 60/40: LR {base:.3f}  lag {r:.3f}  ratio {r / base:.2f}  "
        f"taus={model.time_constants_} alpha={model.alpha_:.3g}"
    )


def machine_b():
    from skthermal.datasets import make_machine_b_tests

    data = make_machine_b_tests(random_state=0)
    temps = [c for c in data.columns if c.startswith("T") and c.endswith("_C")]
    X = data.set_index(["run", "time_s"])[temps + ["spindle_rpm"]]
    runs = data["run"].to_numpy()
    print("Machine B (simulated), leave-one-test-out (GroupKFold over 6 tests)")
    for target in ["disp_x_um", "disp_y_um", "disp_z_um"]:
        y = data[target].to_numpy()
        base, lag = [], []
        for tr, te in GroupKFold(n_splits=6).split(X, y, runs):
            lr = LinearRegression().fit(X[temps].iloc[tr], y[tr])
            base.append((lr.predict(X[temps].iloc[te]) - y[te]) ** 2)
            model = make_lag_pipeline().fit(X.iloc[tr], y[tr])
            lag.append((model.predict(X.iloc[te]) - y[te]) ** 2)
        b = float(np.sqrt(np.mean(np.concatenate(base))))
        r = float(np.sqrt(np.mean(np.concatenate(lag))))
        print(f"  {target}: LR {b:.3f}  lag {r:.3f}  ratio {r / b:.2f}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--data",
        default=str(DATA),
        help="folder of the shared real data (default: ../shared/data next to "
        "the repository)",
    )
    args = parser.parse_args(argv)
    fl_thermal(Path(args.data))
    gas_furnace(Path(args.data))
    machine_b()


if __name__ == "__main__":
    main()
