"""Prediction on a stream: RunStream against passing the run so far.

A controller gives the compensation model one new row per sampling period.
For a sequence model, the exact ways are to pass the run so far on every call
(cost growing with the run) or ``skthermal.compose.RunStream``, which keeps
each run's end state (``remember_runs``) for ``LagRidgeCV`` and
``TransferFunctionRegressor``. Both models are fitted on two synthetic runs
(16 sensors, a speed step); then, after ``--hours`` of a new run sampled every
``--period`` seconds, the time of one more row is measured both ways, side by
side (one BLAS thread), with the largest difference of their predictions.

Run:  python benchmarks/bench_stream.py [--hours 10] [--period 1]
"""

import argparse
import time
import warnings

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from skthermal.compose import RunStream
from skthermal.linear_model import TransferFunctionRegressor
from skthermal.preprocessing import make_lag_pipeline


def make_run(label, hours, period, seed, n_sensors=16):
    """One run: a spindle step and its rest, sensors lagging the heat."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, hours * 3600, period)
    rpm = np.where((t > 600) & (t < hours * 1800), 2000.0 + 1000 * seed, 0.0)
    heat = np.cumsum(rpm) * period / 3e6
    table = {"run": label, "time_s": t, "spindle_rpm": rpm}
    disp = 0.001 * rpm
    for k in range(n_sensors):
        tau = 3000.0 + 700.0 * k
        temp = 20 + heat * np.exp(-t / tau) + 0.01 * rng.standard_normal(t.size)
        table[f"T{k + 1}_C"] = temp
        disp = disp + (temp - 20) / (k + 1)
    return pd.DataFrame(table), disp


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, default=10.0)
    parser.add_argument("--period", type=float, default=1.0)
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args(argv)
    runs = [make_run(lab, 6.0, 60.0, seed) for seed, lab in enumerate("ab")]
    X = pd.concat([r for r, _ in runs], ignore_index=True)
    y = np.concatenate([d for _, d in runs])
    new, _ = make_run("c", args.hours, args.period, 2)
    n = len(new)
    print(
        f"One more row after {args.hours:g} h sampled every {args.period:g} s "
        f"({n} rows, 16 sensors), one BLAS thread:"
    )
    print(
        f"{'model':28s} {'run so far':>11s} {'RunStream':>10s} {'ratio':>7s}  max diff"
    )
    with threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, model in [
            ("make_lag_pipeline()", make_lag_pipeline()),
            ("TransferFunctionRegressor", TransferFunctionRegressor()),
        ]:
            model.fit(X, y)
            stream = RunStream(model)
            stream.predict(new.iloc[: n - args.repeats])
            t0 = time.perf_counter()
            last = [
                stream.predict(new.iloc[i : i + 1])[0]
                for i in range(n - args.repeats, n)
            ]
            streamed = (time.perf_counter() - t0) / args.repeats
            t0 = time.perf_counter()
            for _ in range(3):
                whole = model.predict(new)
            so_far = (time.perf_counter() - t0) / 3
            diff = float(np.max(np.abs(np.array(last) - whole[-args.repeats :])))
            print(
                f"{name:28s} {1e3 * so_far:8.1f} ms {1e3 * streamed:7.1f} ms "
                f"{so_far / streamed:6.1f}x  {diff:.1e}"
            )


if __name__ == "__main__":
    main()
