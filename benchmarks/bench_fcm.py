"""Fuzzy c-means: skthermal against scikit-fuzzy's ``cmeans``, side by side.

Both run on the same data from the same initial memberships with the same
fuzzifier and iteration limit; the script prints the partition agreement
(adjusted Rand index), the centre difference, the best-of-N wall time of each
and their ratio, and the time per iteration (the two stop on slightly
different criteria, so the iteration counts can differ).

Run:  pip install -e ".[bench]" && python benchmarks/bench_fcm.py
Exit status 1 when a partition disagrees (ARI < 0.99) or, with --check, when
skthermal is less than 3x faster on any case.
"""

import argparse
import sys
import time

import numpy as np
from sklearn.datasets import make_blobs
from sklearn.metrics import adjusted_rand_score

from skthermal.datasets._generators import make_sensor_groups
from skthermal.fuzzy import fuzzy_cmeans


def _best_time(fun, repeats):
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fun()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _cases():
    X, _ = make_blobs(20_000, n_features=5, centers=6, random_state=0)
    yield "blobs 20000x5, c=6, m=2", X, 6, 2.0
    yield "blobs 20000x5, c=6, m=1.7", X, 6, 1.7
    X, _ = make_blobs(5_000, n_features=20, centers=10, random_state=1)
    yield "blobs 5000x20, c=10, m=2", X, 10, 2.0
    runs, truth = make_sensor_groups(
        n_groups=5,
        sensors_per_group=15,
        n_noise=1,
        n_runs=6,
        n_samples=600,
        random_state=0,
    )
    Z = runs[truth.index].to_numpy()
    Z = (Z - Z.mean(axis=0)) / Z.std(axis=0)
    yield "76 sensors x 3600 samples, c=5, m=2", Z.T.copy(), 5, 2.0


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--check", action="store_true", help="require >= 3x")
    args = parser.parse_args(argv)
    try:
        import skfuzzy
    except ImportError:
        sys.exit('scikit-fuzzy is needed: pip install -e ".[bench]"')

    tol, max_iter = 1e-5, 300
    header = (
        f"{'case':38s} {'ARI':>6s} {'max|dc|':>9s} {'skfuzzy s':>10s} "
        f"{'skthermal s':>11s} {'ratio':>6s} {'iters':>9s} {'ratio/iter':>10s}"
    )
    print(header)
    print("-" * len(header))
    failed = False
    for name, X, c, m in _cases():
        rng = np.random.default_rng(0)
        u0 = rng.random((X.shape[0], c))
        u0 /= u0.sum(axis=1, keepdims=True)
        t_ref, ref = _best_time(
            lambda X=X, c=c, m=m, u0=u0: skfuzzy.cmeans(
                X.T, c, m, error=tol, maxiter=max_iter, init=u0.T
            ),
            args.repeats,
        )
        t_own, own = _best_time(
            lambda X=X, c=c, m=m, u0=u0: fuzzy_cmeans(
                X, c, m=m, tol=tol, max_iter=max_iter, init=u0
            ),
            args.repeats,
        )
        ref_centers, ref_u, n_ref = ref[0], ref[1], ref[5]
        ari = adjusted_rand_score(ref_u.argmax(axis=0), own.labels)
        dc = np.abs(np.sort(own.centers, axis=0) - np.sort(ref_centers, axis=0)).max()
        ratio = t_ref / t_own
        per_iter = (t_ref / n_ref) / (t_own / own.n_iter)
        print(
            f"{name:38s} {ari:6.3f} {dc:9.2e} {t_ref:10.4f} {t_own:11.4f} "
            f"{ratio:5.1f}x {n_ref:4d}/{own.n_iter:<4d} {per_iter:9.1f}x"
        )
        failed |= ari < 0.99 or (args.check and ratio < 3)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
