"""The downstream view of the gap: how well a compensation model trained on
simulated runs does on the measured ones, simulation by simulation."""

import numpy as np
import pandas as pd
from sklearn.base import clone

from skthermal.utils._runs import check_labels
from skthermal.utils._threads import single_threaded_blas


def downstream_error(
    estimator, machines, runs, *, features=None, target=None, random_state=0
):
    """Error on measured runs of an estimator trained on simulated runs.

    For every simulation in ``machines``, each measured run's drivers are
    simulated (with sensor noise), ``estimator`` is trained on the simulated
    runs and scored on the measured runs. A simulation that lacks an effect
    the machine has trains a worse compensation model; adding the effect
    can lower the error, but need not: ``report.machines`` hold the
    calibrated parameters without the diagnosis's per-channel gains, so
    another misfit of theirs can outweigh the effect (an independent check
    found the error higher with a correctly named ``sensor_lag`` in 2 of 3
    seeds). Read it as a check, not a proof.

    Parameters
    ----------
    estimator : regressor
        Cloned for every simulation; trained on changes since the start of
        each run (inputs and target), as a compensation would be applied.
    machines : dict
        Name -> ThermalMachine, e.g. ``report.machines`` of a
        :class:`GapReport` (the base-calibrated simulation and the one with
        the identified effect).
    runs : DataFrame
        Measured run tables with the drivers, the ``features`` and the
        ``target``.
    features : list of str, optional
        Temperature columns used as inputs; default every column that the
        measured runs and all simulations share.
    target : str, optional
        Displacement column; default the first ``disp_*_um`` column the
        simulations predict.
    random_state : int, default=0
        Seeds the simulated sensor noise.

    Returns
    -------
    DataFrame
        One row per simulation and run: ``simulation``, ``run``, ``rmse``,
        ``max_abs`` (µm), plus an ``overall`` row per simulation.
    """
    names = list(machines)
    if not names:
        raise ValueError("Give at least one simulation in machines.")
    if features is None:
        shared = set(runs.columns)
        for m in machines.values():
            shared &= set(m.sensors)
        features = [c for c in runs.columns if c in shared]
    if not features:
        raise ValueError(
            "The measured runs and the simulations share no sensor column."
        )
    if target is None:
        predicted = set(next(iter(machines.values())).targets)
        candidates = [c for c in runs.columns if c in predicted]
        if not candidates:
            raise ValueError(
                "The measured runs have no displacement the simulations predict."
            )
        target = candidates[0]
    for name in names:
        if target not in machines[name].targets:
            raise ValueError(
                f"target {target!r} is not predicted by simulation {name!r} "
                f"(its displacements: {machines[name].targets})."
            )
    missing = [c for c in ["run", *features, target] if c not in runs.columns]
    if missing:
        raise ValueError(f"The measured runs have no column(s) {missing}.")
    check_labels(runs["run"].to_numpy())
    groups = list(runs.groupby("run", sort=False))

    def rel(frame, cols):
        values = frame[cols].to_numpy(float)
        return values - values[:5].mean(axis=0)

    rows = []
    for name in names:
        machine = machines[name]
        sim_X, sim_y = [], []
        with single_threaded_blas():
            for k, (run, frame) in enumerate(groups):
                feed = frame["feed_mm_min"] if "feed_mm_min" in frame else None
                sim = machine.simulate_drivers(
                    frame["time_s"],
                    frame["spindle_rpm"],
                    frame["ambient_C"],
                    feed,
                    run=run,
                    random_state=random_state + k,
                )
                sim_X.append(rel(sim, features))
                sim_y.append(rel(sim, [target])[:, 0])
        model = clone(estimator).fit(np.vstack(sim_X), np.concatenate(sim_y))
        errors = []
        for run, frame in groups:
            err = model.predict(rel(frame, features)) - rel(frame, [target])[:, 0]
            errors.append(err)
            rows.append(
                {
                    "simulation": name,
                    "run": run,
                    "rmse": float(np.sqrt(np.mean(err**2))),
                    "max_abs": float(np.max(np.abs(err))),
                }
            )
        allerr = np.concatenate(errors)
        rows.append(
            {
                "simulation": name,
                "run": "overall",
                "rmse": float(np.sqrt(np.mean(allerr**2))),
                "max_abs": float(np.max(np.abs(allerr))),
            }
        )
    return pd.DataFrame(rows)
