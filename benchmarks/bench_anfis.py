"""ANFIS on Jang's Mackey-Glass example: accuracy against the paper, and speed.

Three parts, all on Jang's (1993) example 4 (500 training rows ``ex4.trn``,
500 checking rows ``ex4.chk``, 4 inputs, 2 bell MFs per input, 16 rules):

1. Jang's published trained model (his Table VI and consequent matrix) set into
   ``ANFISRegressor.from_parameters``: RMSE on both sets against the paper's
   0.00148 / 0.00163.
2. Training from scratch from Jang's initial MFs with hybrid learning for
   ``--epochs`` epochs: final training and checking RMSE (the epoch of least
   training error kept, no peeking at the checking set), and the best checking
   RMSE with the checking set given (MATLAB's checking FIS); epochs per second.
3. Side by side with a straightforward per-sample-loop implementation of the
   very same algorithm (same initial MFs, same least-squares solve, same
   step-size rule), written below: both must end with the same parameters
   after ``--loop-epochs`` epochs; the script prints the time per epoch of each
   and their ratio. (No other Python ANFIS is usable here: the ``anfis`` package
   on PyPI is Python 2 code, ``xanfis`` needs PyTorch.)

Run:  python benchmarks/bench_anfis.py [--data ../shared/data] [--epochs 500]
Exit status 1 when Jang's model is not reproduced within 1e-4 or the two
implementations disagree.
"""

import argparse
import itertools
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from skthermal.fuzzy import ANFISRegressor
from skthermal.fuzzy._anfis_core import StepSizeRule, solve_consequents

DEFAULT_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
PEERS = ("torchanfis", "anfis-toolbox")
PEER_SCRIPT = Path(__file__).resolve().parent / "peers" / "run_anfis_peer.py"

JANG_MFS = np.array(
    [
        (0.1790, 2.0456, 0.4798),
        (0.1584, 2.0103, 1.4975),
        (0.2410, 1.9533, 0.2960),
        (0.2923, 1.9178, 1.7824),
        (0.3798, 2.1490, 0.6599),
        (0.4884, 1.8967, 1.6465),
        (0.2815, 2.0170, 0.3341),
        (0.1616, 2.0165, 1.4727),
    ]
).reshape(4, 2, 3)
JANG_INITIAL = np.array([[[0.444045, 2.0, 0.425606], [0.444045, 2.0, 1.313696]]] * 4)


def rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


# --------------------------------------------------------------------------
# A straightforward per-sample implementation of hybrid learning (bell MFs),
# the way ANFIS is usually written out from Jang's paper: loops over samples,
# rules, inputs and parameters, plain products of memberships.
# --------------------------------------------------------------------------


def _bell(x, a, b, c):
    return 1.0 / (1.0 + abs((x - c) / a) ** (2 * b))


def _bell_derivs(x, a, b, c):
    """d mu / d(a, b, c) (Jang 1993)."""
    mu = _bell(x, a, b, c)
    s = mu * (1.0 - mu)
    z = (x - c) / a
    d_a = 2 * b * s / a
    d_b = -2 * math.log(abs(z)) * s if z != 0 else 0.0
    d_c = 2 * b * s / (x - c) if x != c else 0.0
    return (d_a, d_b, d_c)


def loop_train(X, y, mf_params, epochs, step_size, ridge=1e-8):
    n, d = X.shape
    n_mfs = mf_params.shape[1]
    params = [[list(mf_params[j, m]) for m in range(n_mfs)] for j in range(d)]
    rules = list(itertools.product(range(n_mfs), repeat=d))
    rule = StepSizeRule(step_size, 1.2, 0.9)
    errors = []
    for epoch in range(epochs):
        # Forward pass, one sample at a time.
        rows, mus, ws = [], [], []
        for i in range(n):
            mu = [
                [_bell(X[i, j], *params[j][m]) for m in range(n_mfs)] for j in range(d)
            ]
            w = []
            for r in rules:
                prod = 1.0
                for j in range(d):
                    prod *= mu[j][r[j]]
                w.append(prod)
            total = sum(w)
            row = []
            for wr in w:
                row.extend([wr / total * X[i, j] for j in range(d)] + [wr / total])
            rows.append(row)
            mus.append(mu)
            ws.append(w)
        theta = solve_consequents(np.array(rows), y[:, None], ridge)[:, 0]
        cons = [theta[k * (d + 1) : (k + 1) * (d + 1)] for k in range(len(rules))]
        # Error and backward pass, one sample at a time.
        grad = [[[0.0, 0.0, 0.0] for _ in range(n_mfs)] for _ in range(d)]
        sse = 0.0
        for i in range(n):
            w, mu, total = ws[i], mus[i], sum(ws[i])
            f = [sum(c[j] * X[i, j] for j in range(d)) + c[d] for c in cons]
            out = sum(w[k] * f[k] for k in range(len(rules))) / total
            e = out - y[i]
            sse += e * e
            for k, r in enumerate(rules):
                dE_dw = e * (f[k] - out) / total
                for j in range(d):
                    others = 1.0
                    for jj in range(d):
                        if jj != j:
                            others *= mu[jj][r[jj]]
                    derivs = _bell_derivs(X[i, j], *params[j][r[j]])
                    for p in range(3):
                        grad[j][r[j]][p] += dE_dw * others * derivs[p]
        errors.append(math.sqrt(sse / n))
        if errors[-1] == min(errors):  # keep the least-training-error epoch
            best = (np.array(params), np.array(cons))
        if epoch == epochs - 1:
            break
        step = rule.update(errors)
        norm = math.sqrt(sum(g * g for gj in grad for gm in gj for g in gm))
        for j in range(d):
            for m in range(n_mfs):
                for p in range(3):
                    params[j][m][p] -= step / norm * grad[j][m][p]
    return best[0], best[1], np.array(errors)


# --------------------------------------------------------------------------


def load(data):
    folder = Path(data) / "mackey_glass"
    trn = np.loadtxt(folder / "ex4.trn")
    chk = np.loadtxt(folder / "ex4.chk")
    cons = np.loadtxt(folder / "jang_consequents.csv", delimiter=",", skiprows=1)
    return trn, chk, cons


def peer_data(seed=0, n=2000):
    """The data of part 4: 2000 x 4 inputs, a smooth target plus noise 0.1."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, size=(n, 4))
    y = (
        np.sin(2 * X[:, 0])
        + X[:, 1] ** 2
        - 0.5 * X[:, 2] * X[:, 3]
        + 0.1 * rng.standard_normal(n)
    )
    return X, y


def compare_peers(python, epochs, repeats, threads):
    """Part 4: skthermal against other packages, fitted on the same data."""
    from threadpoolctl import threadpool_limits

    X, y = peer_data()
    times = []
    # The same number of BLAS threads as the peers get.
    with threadpool_limits(limits=threads or None, user_api="blas"):
        for _ in range(max(repeats, 3)):
            model = ANFISRegressor(init="grid", n_mfs=2, epochs=epochs)
            t0 = time.perf_counter()
            model.fit(X, y)
            times.append(time.perf_counter() - t0)
    ours, ours_rmse = min(times), rmse(model.predict(X), y)
    print(
        f"   skthermal      {ours:8.3f} s  RMSE {ours_rmse:.4f}  (fits: "
        + ", ".join(f"{t:.3f}" for t in times)
        + ")"
    )
    env = dict(os.environ)
    if threads:
        env.update({"OMP_NUM_THREADS": str(threads), "MKL_NUM_THREADS": str(threads)})
        env["OPENBLAS_NUM_THREADS"] = str(threads)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "data.npz"
        np.savez(path, X=X, y=y)
        for peer in PEERS:
            cmd = [python, str(PEER_SCRIPT), peer, str(path), str(epochs)]
            cmd.append(str(repeats))
            done = subprocess.run(cmd, capture_output=True, text=True, env=env)
            if done.returncode != 0:
                last = (done.stderr.strip().splitlines() or ["no output"])[-1]
                print(f"   {peer:14s} failed: {last}")
                continue
            res = json.loads(done.stdout.strip().splitlines()[-1])
            print(
                f"   {peer:14s} {res['best_s']:8.3f} s  RMSE {res['rmse']:.4f}  "
                f"ratio to skthermal {res['best_s'] / ours:6.1f}x  (fits: "
                + ", ".join(f"{t:.3f}" for t in res["times_s"])
                + ")"
            )
    return ours_rmse <= 0.111


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=str(DEFAULT_DATA), help="shared data")
    parser.add_argument("--epochs", type=int, default=500)
    parser.add_argument("--step-size", type=float, default=0.1)
    parser.add_argument("--loop-epochs", type=int, default=3)
    parser.add_argument(
        "--peers",
        default="/tmp/anfis-peers/bin/python",
        help="Python of the peer environment (benchmarks/peers/make_anfis_peers.sh)",
    )
    parser.add_argument("--peer-epochs", type=int, default=50)
    parser.add_argument("--peer-repeats", type=int, default=2)
    parser.add_argument("--peer-threads", type=int, default=1)
    parser.add_argument("--peers-only", action="store_true", help="part 4 alone")
    args = parser.parse_args(argv)
    if args.peers_only:
        return run_peers(args)
    try:
        trn, chk, cons = load(args.data)
    except OSError as exc:
        print(f"Mackey-Glass data not found under {args.data}: {exc}")
        return 2
    Xt, yt, Xc, yc = trn[:, :4], trn[:, 4], chk[:, :4], chk[:, 4]
    ok = True

    print("1. Jang's published model (paper: 0.00148 training, 0.00163 checking)")
    jang = ANFISRegressor.from_parameters(
        mf="gbell", mf_params=JANG_MFS, consequents=cons
    )
    r_trn, r_chk = rmse(jang.predict(Xt), yt), rmse(jang.predict(Xc), yc)
    print(f"   RMSE training {r_trn:.5f}  checking {r_chk:.5f}")
    ok &= abs(r_trn - 0.00148) < 1e-4 and abs(r_chk - 0.00163) < 1e-4

    print(
        f"\n2. Hybrid learning from Jang's initial MFs, {args.epochs} epochs, "
        f"step size {args.step_size}"
    )
    model = ANFISRegressor(
        init=JANG_INITIAL, mf="gbell", epochs=args.epochs, step_size=args.step_size
    )
    t0 = time.perf_counter()
    model.fit(Xt, yt)
    elapsed = time.perf_counter() - t0
    print(
        f"   least training error at epoch {model.best_epoch_}: RMSE training "
        f"{rmse(model.predict(Xt), yt):.5f}  checking {rmse(model.predict(Xc), yc):.5f}"
    )
    print(
        f"   {model.n_iter_ / elapsed:.0f} epochs/s ({elapsed:.2f} s), "
        f"final step size {model.history_['step_size'][-1]:.4g}"
    )
    checked = ANFISRegressor(
        init=JANG_INITIAL, mf="gbell", epochs=args.epochs, step_size=args.step_size
    )
    t0 = time.perf_counter()
    checked.fit(Xt, yt, X_val=Xc, y_val=yc)
    elapsed = time.perf_counter() - t0
    print(
        f"   with the checking set (MATLAB checking FIS): least checking RMSE "
        f"{checked.history_['val_rmse'].min():.5f} at epoch {checked.best_epoch_}, "
        f"{checked.n_iter_ / elapsed:.0f} epochs/s"
    )

    n = args.loop_epochs
    print(f"\n3. Same algorithm, per-sample loops, {n} epochs")
    t0 = time.perf_counter()
    loop_params, loop_cons, loop_err = loop_train(
        Xt, yt, JANG_INITIAL, n, args.step_size
    )
    t_loop = (time.perf_counter() - t0) / n
    vec = ANFISRegressor(
        init=JANG_INITIAL, mf="gbell", epochs=n, step_size=args.step_size
    )
    reps = max(1, int(200 / n))
    t0 = time.perf_counter()
    for _ in range(reps):
        vec.fit(Xt, yt)
    t_vec = (time.perf_counter() - t0) / (reps * n)
    # The consequent least squares is ill conditioned (cond(A) ~ 1e5), so the
    # two agree to rounding amplified by it, not to the last digit.
    d_err = np.abs(vec.history_["train_rmse"] / loop_err - 1).max()
    d_mf = np.abs(vec.mf_params_ - loop_params).max()
    d_cons = np.abs(vec.consequents_ - loop_cons).max() / np.abs(loop_cons).max()
    same = d_err < 1e-5 and d_mf < 1e-7 and d_cons < 1e-5
    print(
        f"   largest differences: training RMSE (relative) {d_err:.1e}, MF "
        f"parameters {d_mf:.1e}, consequents (relative to the largest) {d_cons:.1e}"
    )
    print(f"   same training errors and parameters: {same}")
    print(
        f"   per epoch: loops {t_loop * 1e3:.1f} ms, skthermal {t_vec * 1e3:.2f} ms, "
        f"ratio {t_loop / t_vec:.0f}x"
    )
    ok &= same
    return run_peers(args) if ok else 1


def run_peers(args):
    print(
        f"\n4. Other Python ANFIS packages: 2000 x 4, 16 rules, "
        f"{args.peer_epochs} epochs, hybrid learning"
    )
    if not Path(args.peers).exists():
        print(
            f"   skipped: no peer environment at {args.peers} (make it with "
            "bash benchmarks/peers/make_anfis_peers.sh)"
        )
        return 0
    ok = compare_peers(
        args.peers, args.peer_epochs, args.peer_repeats, args.peer_threads
    )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
