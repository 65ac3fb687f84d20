"""GMC(1,N) calibration by particle swarm: vectorised swarm vs per-particle loop.

The issue's target: 90 particles x 100 epochs on 26 inputs x 5,000 samples in
under a second on 2 cores. The script calibrates GMC(1,N) on such data twice,
with the same swarm (same ``random_state``, so the same positions are visited):

- ``vectorised``: skthermal's objective, one call per epoch for the whole swarm
  (blocked first-order recursion, see ``skthermal.grey._gmc``);
- ``per-particle``: a straightforward implementation of the same objective, a
  Python loop over the particles, each filtered with ``scipy.signal.lfilter``.

It prints the wall time of both (best of ``--repeats``), their ratio, the
difference of the two optima, the time of the complete swarm calibration
``GreyPSORegressor(calibration="pso", alpha=0.0).fit`` (variable projection
for the start and the search box, then the swarm) and that of the exact
calibration by variable projection, whose loss no swarm may beat. With
``--pure`` it also times one epoch of a per-particle loop that runs the
recursion itself in Python and extrapolates it to 100 epochs.

Run:  python benchmarks/bench_pso.py
Exit status 1 when the two optima differ, when a swarm ends below the
variable-projection loss or, with --check, when the vectorised calibration
takes 1 s or more.
"""

import argparse
import sys
import time

import numpy as np
from scipy.signal import lfilter
from threadpoolctl import threadpool_limits

from skthermal.grey._gmc import _GMCObjective, _model_runs, _tien_ls
from skthermal.grey._regressors import GreyPSORegressor
from skthermal.optimize import particle_swarm


def _data(n=5000, m=26, seed=0):
    """26 temperatures driven by 4 heat sources, displacement from GMC(1,N)."""
    rng = np.random.default_rng(seed)
    period = 400
    on = rng.random((n // period + 1, 4)) > 0.4
    power = on.repeat(period, axis=0)[:n] * rng.uniform(2, 8, 4)
    src = np.zeros((n, 4))
    a = np.exp(-1.0 / rng.uniform(100, 600, 4))
    for t in range(1, n):
        src[t] = a * src[t - 1] + (1 - a) * power[t - 1]
    X = 20 + src @ rng.uniform(0, 1, (4, m)) + rng.normal(0, 0.02, (n, m))
    b = rng.normal(0, 1e-3, m)
    X1 = np.cumsum(X - X[0], axis=0)
    f = X1 @ b + 1e-3
    x1 = lfilter([0.5, 0.5 * np.exp(-0.01)], [1.0, -np.exp(-0.01)], f)
    x1 -= x1[0] * np.exp(-0.01 * np.arange(n))  # I(1) = 0
    y = np.diff(x1, prepend=0.0) + rng.normal(0, 0.05, n)
    return X, y


def _per_particle_objective(runs):
    """The same SSE, one particle at a time (what the swarm replaces)."""

    def objective(theta):
        out = np.empty(theta.shape[0])
        for p, (b1, *b, u) in enumerate(theta):
            a = np.exp(-b1)
            sse = 0.0
            for X1, y0 in runs:
                f = X1 @ np.asarray(b) + u
                g = np.empty_like(f)
                g[0] = 0.0
                g[1:] = 0.5 * (a * f[:-1] + f[1:])
                x1 = lfilter([1.0], [1.0, -a], g)
                r = np.diff(x1, prepend=0.0) - y0
                sse += r @ r
            out[p] = sse
        return out

    return objective


def _pure_python_epoch(runs, theta):
    out = np.empty(theta.shape[0])
    for p, (b1, *b, u) in enumerate(theta):
        a = float(np.exp(-b1))
        sse = 0.0
        for X1, y0 in runs:
            f = (X1 @ np.asarray(b) + u).tolist()
            acc, prev = 0.0, 0.0
            for t in range(1, len(f)):
                acc = a * acc + 0.5 * (a * f[t - 1] + f[t])
                sse += (acc - prev - y0[t]) ** 2
                prev = acc
        out[p] = sse
    return out


def _best_time(fun, repeats):
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fun()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=5000)
    parser.add_argument("--inputs", type=int, default=26)
    parser.add_argument("--particles", type=int, default=90)
    parser.add_argument("--epochs", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--pure", action="store_true")
    parser.add_argument("--check", action="store_true")
    args = parser.parse_args(argv)

    X, y = _data(args.samples, args.inputs)
    runs = _model_runs(y, X, [slice(0, len(y))])
    theta_ls = _tien_ls(runs)
    box = GreyPSORegressor._auto_box(theta_ls, runs)
    kw = {
        "n_particles": args.particles,
        "epochs": args.epochs,
        "init": theta_ls,
        "random_state": 0,
    }
    print(
        f"GMC(1,N) PSO calibration: {args.inputs} inputs x {args.samples} samples, "
        f"{args.particles} particles x {args.epochs} epochs"
    )
    # Both objectives run with BLAS on one thread, as GreyPSORegressor.fit
    # does: their matrix products are too small to gain from threads.
    with threadpool_limits(limits=1, user_api="blas"):
        t_vec, res_vec = _best_time(
            lambda: particle_swarm(_GMCObjective(runs), box, **kw), args.repeats
        )
        t_loop, res_loop = _best_time(
            lambda: particle_swarm(_per_particle_objective(runs), box, **kw),
            max(1, args.repeats - 1),
        )
    one_run = np.zeros(len(X))  # the rows are one run
    t_fit, model = _best_time(
        lambda: GreyPSORegressor(
            calibration="pso",
            alpha=0.0,
            n_particles=args.particles,
            epochs=args.epochs,
            random_state=0,
        ).fit(X, y, groups=one_run),
        args.repeats,
    )
    t_vp, exact = _best_time(
        lambda: GreyPSORegressor(calibration="varpro", alpha=0.0).fit(
            X, y, groups=one_run
        ),
        args.repeats,
    )
    rel = abs(res_vec.fun - res_loop.fun) / res_loop.fun
    print(f"  vectorised swarm objective : {t_vec:8.3f} s")
    print(f"  per-particle loop (lfilter): {t_loop:8.3f} s")
    print(f"  ratio                      : {t_loop / t_vec:8.1f} x")
    print(f"  GreyPSORegressor.fit (pso) : {t_fit:8.3f} s (varpro + box + swarm)")
    print(f"  GreyPSORegressor.fit       : {t_vp:8.3f} s (varpro, exact)")
    print(
        f"  best SSE {res_vec.fun:.6g} (vectorised) vs {res_loop.fun:.6g} "
        f"(loop), relative difference {rel:.1e}; LS SSE "
        f"{_GMCObjective(runs)(theta_ls[None])[0]:.6g}; variable projection SSE "
        f"{exact.loss_:.6g}, swarm from it {model.loss_:.6g}"
    )
    if args.pure:
        theta = res_vec.x + np.zeros((args.particles, 1))
        with threadpool_limits(limits=1, user_api="blas"):
            t_pure, _ = _best_time(lambda: _pure_python_epoch(runs, theta), 1)
        print(
            f"  pure-Python recursion      : {t_pure:8.3f} s per epoch, "
            f"~{t_pure * (args.epochs + 1):.0f} s for the run "
            f"({t_pure * (args.epochs + 1) / t_vec:.0f} x)"
        )
    status = 0
    if rel > 1e-6:
        print("FAIL: the two implementations reach different optima")
        status = 1
    if min(res_vec.fun, res_loop.fun, model.loss_) < exact.loss_ * (1 - 1e-9):
        print("FAIL: a swarm beat the variable-projection optimum")
        status = 1
    if args.check and t_vec >= 1.0:
        print("FAIL: vectorised calibration takes 1 s or more")
        status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())
