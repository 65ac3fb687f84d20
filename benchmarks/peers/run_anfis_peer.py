"""Time one other Python ANFIS package on the data of a ``.npz`` file.

Runs inside the separate environment made by ``make_anfis_peers.sh`` (never
with skthermal's own); called by part 4 of ``benchmarks/bench_anfis.py``:

    /tmp/anfis-peers/bin/python run_anfis_peer.py PEER DATA.npz EPOCHS REPEATS

``PEER`` is ``torchanfis`` or ``anfis-toolbox``. Both are set up like the
skthermal run: a grid of 2 Gaussian MFs per input (16 rules on 4 inputs),
hybrid learning (least-squares consequents, gradient premises), ``EPOCHS``
epochs. Prints one JSON line: the best and all fit times (s) and the training
RMSE.
"""

import json
import sys
import time

import numpy as np


def make(peer, epochs):
    if peer == "torchanfis":
        from torchanfis import ANFISRegressor

        return ANFISRegressor(
            n_mfs=2, n_rules=16, mf_type="gaussian", training="hybrid", epochs=epochs
        )
    if peer == "anfis-toolbox":
        from anfis_toolbox import ANFISRegressor

        return ANFISRegressor(
            n_mfs=2, mf_type="gaussian", init="grid", optimizer="hybrid", epochs=epochs
        )
    raise SystemExit(f"unknown peer {peer!r}")


def main():
    peer, path, epochs, repeats = (
        sys.argv[1],
        sys.argv[2],
        int(sys.argv[3]),
        int(sys.argv[4]),
    )
    data = np.load(path)
    X, y = data["X"], data["y"]
    times = []
    for _ in range(repeats):
        model = make(peer, epochs)
        t0 = time.perf_counter()
        model.fit(X, y)
        times.append(time.perf_counter() - t0)
    pred = np.asarray(model.predict(X), dtype=float).ravel()
    rmse = float(np.sqrt(np.mean((pred - y) ** 2)))
    print(
        json.dumps({"peer": peer, "best_s": min(times), "times_s": times, "rmse": rmse})
    )


if __name__ == "__main__":
    main()
