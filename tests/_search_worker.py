"""One worker of a distributed search, run as its own process by the tests.

    python tests/_search_worker.py STORAGE STUDY [--n-trials N] [--sleep S]
        [--marker PATH] [--heartbeat H] [--grace G] [--random-state R]
        [--start-at PATH]

``STORAGE`` is anything :func:`skthermal.model_selection.make_storage`
takes (a ``.db`` or ``.log`` path, a ``postgresql://`` URL). Every worker
searches a small ANFIS space on the same tiny synthetic runs, so the workers'
trials belong to one study. ``--sleep`` makes each trial sleep after drawing
its parameters (and after writing ``--marker``), so a test can kill the
worker in the middle of a trial. ``--start-at`` makes the worker write
``PATH.<pid>`` once it is ready, then wait for ``PATH`` before it joins the
study, so that several workers join at the same moment.
"""

import argparse
import time
from pathlib import Path

from skthermal.datasets import make_sensor_groups, split_runs
from skthermal.fuzzy import ANFISRegressor
from skthermal.model_selection import run_search, search_space


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("storage")
    parser.add_argument("study")
    parser.add_argument("--n-trials", type=int, default=3)
    parser.add_argument("--sleep", type=float, default=0.0)
    parser.add_argument("--marker", default=None)
    parser.add_argument("--heartbeat", default="auto", help="seconds, or none")
    parser.add_argument("--grace", type=int, default=None)
    parser.add_argument("--random-state", type=int, default=None)
    parser.add_argument("--start-at", default=None)
    args = parser.parse_args(argv)
    import optuna  # here, so that collecting this file never needs optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    heartbeat = args.heartbeat
    if heartbeat not in ("auto", "none"):
        heartbeat = int(heartbeat)
    elif heartbeat == "none":
        heartbeat = None

    runs, _ = make_sensor_groups(
        n_groups=2, sensors_per_group=2, n_noise=1, n_runs=3, n_samples=50,
        random_state=0,
    )  # fmt: skip
    X, y, groups = split_runs(runs)
    base = search_space("anfis", init="fcm", n_clusters=(2, 3), epochs=(2, 4))

    def space(trial):
        params = base(trial)
        if args.marker:
            Path(args.marker).write_text(str(trial.number))
        if args.sleep:
            time.sleep(args.sleep)
        return params

    if args.start_at:
        import os

        Path(f"{args.start_at}.{os.getpid()}").write_text("ready")
        while not Path(args.start_at).exists():
            time.sleep(0.01)
    run_search(
        ANFISRegressor(random_state=0),
        X,
        y,
        groups=groups,
        space=space,
        n_trials=args.n_trials,
        storage=args.storage,
        study_name=args.study,
        heartbeat_interval=heartbeat,
        grace_period=args.grace,
        random_state=args.random_state,
        refit=False,
    )


if __name__ == "__main__":
    main()
