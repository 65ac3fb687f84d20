"""The papers' Machine B study, replicated on the simulator: ``skthermal reproduce``.

Abdulshahed et al. (000; 001 §5.3) selected 5 of the 77 temperature sensors of
Machine B with grey influence coefficients and fuzzy c-means, trained two ANFIS
models on Test IV -- one rule per fuzzy c-means cluster (3 rules) and a grid
partition (3 membership functions per input, 243 rules) -- and tested them on
Tests I, II, III, V and VI (001 Tables 5-7 and 5-8, Figs. 5-11 to 5-15). This
module repeats that study on Tests I-VI simulated with the ``"vmc-b"`` preset,
adds the grey models (GNNMCI, Grey-PSO) and the thesis' neural network baseline
(10 hidden neurons, 001 §6.3). The report (tables, Markdown, figures) is written
by :mod:`skthermal.study._report`.
"""

import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from skthermal._versions import package_versions
from skthermal.models import MODELS, make_model, make_selector, n_rules
from skthermal.models._registry import N_SENSORS
from skthermal.study._constants import (
    DEFAULT_SAMPLE_PERIOD_S,
    PAPER,
    PAPER_SENSORS,
    QUICK_SAMPLE_PERIOD_S,
    TARGET,
    TEST_RUNS,
    TRAIN_TEST,
)
from skthermal.study._report import _draw_figures, _jsonable, _write_tables
from skthermal.study._scoring import run_metrics
from skthermal.utils._runs import changes_since_start, run_slices


class Progress:
    """Progress lines with the elapsed seconds, on stderr."""

    def __init__(self, stream=None, enabled=True):
        self.stream = sys.stderr if stream is None else stream
        self.enabled = enabled
        self.start = time.perf_counter()

    def elapsed(self):
        return time.perf_counter() - self.start

    def __call__(self, message):
        if self.enabled:
            print(f"[{self.elapsed():6.1f} s] {message}", file=self.stream, flush=True)


def _model_params(model):
    inner = model.estimator
    params = inner.get_params(deep=True)
    return {k: _jsonable(v) for k, v in params.items() if not hasattr(v, "fit")}


def _fitted_choices(model):
    """What training chose: for ANFIS the ridge, its checking scores and the
    epoch; for the lag-feature baselines the time constants, drivers and
    penalty."""
    inner = getattr(model, "estimator_", None)
    if hasattr(inner, "lag_features_"):
        return {
            "time_constants_s": [float(t) for t in inner.time_constants_],
            "use_drivers": bool(inner.use_drivers_),
            "alpha": float(inner.alpha_),
        }
    if not hasattr(inner, "ridge_scores_"):
        return None
    return {
        "ridge": inner.ridge_,
        "ridge_checking_rmse": {
            f"{k:g}": _jsonable(v) for k, v in inner.ridge_scores_.items()
        },
        "best_epoch": inner.best_epoch_,
    }


def _sensor_table(picker, names, machine, selected):
    location = {s.name: s.location for s in machine.spec.sensors}
    table = pd.DataFrame(
        {
            "sensor": names,
            "location": [location.get(n, "") for n in names],
            "group": picker.labels_,
            "gm1n_influence": picker.scores_,
            "selected": [n in selected for n in names],
        }
    )
    return table


@dataclass
class StudyResult:
    """Everything ``reproduce`` computed; also written to the report folder."""

    results: pd.DataFrame
    summary: pd.DataFrame
    sensors: pd.DataFrame
    campaign: pd.DataFrame
    predictions: pd.DataFrame
    runs: pd.DataFrame
    settings: dict
    files: list
    finding: str


def reproduce(
    out="skthermal-report",
    *,
    seed=0,
    quick=False,
    sample_period_s=None,
    figures=True,
    models=None,
    progress=None,
    command=None,
):
    """Run the Machine B study and write the report folder.

    Parameters
    ----------
    out : path-like or None
        Report folder (created); None writes nothing.
    seed : int
        Seeds the simulation, the sensor clustering and every model.
    quick : bool
        A tiny budget: coarser sampling and few epochs (for tests).
    sample_period_s : float, optional
        Sampling of the simulated tests; default 10 s, as the thesis (120 s
        with ``quick``).
    figures : bool
        Draw PNG figures (needs matplotlib; skipped with a note without it).
    models : sequence of str, optional
        Subset of :data:`MODELS` (default the papers' models, in that order;
        the baselines ``"ridge"`` and ``"lag-ridge"`` on request).
    progress : callable, optional
        Called with progress messages (default: lines on stderr).
    command : str, optional
        The command line, recorded in ``settings.json``.

    Returns
    -------
    StudyResult
    """
    from skthermal.datasets import make_machine_b_tests, split_runs, write_runs
    from skthermal.simulate import ThermalMachine

    progress = Progress() if progress is None else progress
    models = (
        [n for n, spec in MODELS.items() if spec.paper]
        if models is None
        else list(models)
    )
    if sample_period_s is None:
        sample_period_s = QUICK_SAMPLE_PERIOD_S if quick else DEFAULT_SAMPLE_PERIOD_S
    timings = {}
    t0 = time.perf_counter()

    progress(f"simulating Machine B Tests I-VI ({sample_period_s:g} s sampling)")
    machine = ThermalMachine.from_preset("vmc-b")
    runs = make_machine_b_tests(
        machine=machine, sample_period_s=sample_period_s, random_state=seed
    )
    meta = pd.DataFrame(runs.attrs["metadata"])
    X, y, groups = split_runs(runs, targets=TARGET)
    timings["simulate_s"] = time.perf_counter() - t0

    t = time.perf_counter()
    train = groups == TRAIN_TEST
    progress(
        f"selecting {N_SENSORS} of {X.shape[1]} sensors on Test {TRAIN_TEST} "
        "(GM(1,N) influence + fuzzy c-means)"
    )
    picker = make_selector("fcm", N_SENSORS, random_state=seed)
    picker.fit(X[train], y[train])
    selected = list(picker.get_feature_names_out())
    sensors = _sensor_table(picker, list(X.columns), machine, selected)
    timings["select_s"] = time.perf_counter() - t
    progress(f"selected {', '.join(selected)}")

    fitted, fit_s, train_rmse, preds = {}, {}, {}, {}
    # The selected sensors, and the drivers the models read (spindle speed).
    drivers = sorted({d for name in models for d in MODELS[name].drivers})
    Xd, _, _ = split_runs(runs, sensors=selected + drivers, targets=TARGET)
    for name in models:
        model = make_model(name, random_state=seed, quick=quick)
        Xs = Xd[selected + list(MODELS[name].drivers)]
        label = MODELS[name].label
        progress(f"training {label} on Test {TRAIN_TEST}")
        t = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            # The MLP's "did not converge" is expected with a fixed budget.
            warnings.filterwarnings("ignore", message=".*(converge|Maximum).*")
            model.fit(Xs[train], y[train])
        fit_s[name] = time.perf_counter() - t
        rules = n_rules(model)
        progress(
            f"trained {label}"
            + (f" ({rules} rules)" if rules is not None else "")
            + f" in {fit_s[name]:.1f} s"
        )
        for w in caught:
            text = str(w.message)
            if "premise training stopped" in text:
                # Expected of the study's ANFIS-FCM (docs/replication.md):
                # said as a note of the study, not as a warning to fix.
                progress(f"{label}: {text.split(': ', 1)[1]}")
            else:
                warnings.warn_explicit(
                    w.message, w.category, w.filename, w.lineno, source=w.source
                )
        fitted[name] = model
        p = model.predict(Xs)
        preds[name] = p
        ztr = y[train].to_numpy()
        train_rmse[name] = run_metrics(ztr - ztr[0], p[train])["RMSE_um"]

    progress("scoring Tests " + ", ".join(TEST_RUNS))
    rows = []
    zall = y.to_numpy()
    for test in TEST_RUNS:
        mask = groups == test
        z = zall[mask] - zall[mask][0]
        for name in models:
            p = preds[name][mask]
            paper = PAPER.get((test, name), (np.nan,) * 4)
            rows.append(
                {
                    "test": test,
                    "model": name,
                    "label": MODELS[name].label,
                    "rules": n_rules(fitted[name]),
                    **run_metrics(z, p),
                    "paper_R": paper[0],
                    "paper_RMSE_um": paper[1],
                    "paper_NSE": paper[2],
                    "paper_residual_um": paper[3],
                }
            )
    results = pd.DataFrame(rows)
    # How far from the paper: the RMSE as a multiple of the paper's (NaN
    # where the paper has no figure).
    results["RMSE_vs_paper"] = results["RMSE_um"] / results["paper_RMSE_um"]
    results["rules"] = results["rules"].astype("Int64")
    summary = (
        results.groupby("model", sort=False)
        .agg(
            label=("label", "first"),
            rules=("rules", "first"),
            RMSE_um=("RMSE_um", "mean"),
            paper_RMSE_um=("paper_RMSE_um", "mean"),
            residual_um=("residual_um", "max"),
            R=("R", "mean"),
            NSE=("NSE", "mean"),
        )
        .reset_index()
    )
    summary.insert(3, "train_RMSE_um", summary["model"].map(train_rmse))
    summary["fit_s"] = summary["model"].map(fit_s)
    finding = _finding(results, summary)

    campaign = _campaign_table(runs, meta, selected)
    predictions = runs[["run", "time_s", "spindle_rpm", "ambient_C"]].copy()
    predictions[TARGET] = changes_since_start(zall, run_slices(groups)[0])
    for name in models:
        predictions[f"pred_{name}"] = preds[name]

    settings = {
        "command": command,
        "study": "Machine B Tests I-VI (001 §5.3), simulated with preset vmc-b",
        "seed": seed,
        "quick": quick,
        "sample_period_s": sample_period_s,
        "target": TARGET,
        "train_test": TRAIN_TEST,
        "test_tests": list(TEST_RUNS),
        "comparison": (
            "measured and predicted Y displacement as change since the start "
            "of each test; model inputs are temperature changes since the start"
        ),
        "selector": {
            "class": type(picker).__name__,
            "params": _jsonable(picker.get_params()),
            "fitted_on": TRAIN_TEST,
            "selected": selected,
            "paper_selected": list(PAPER_SENSORS),
        },
        "models": {
            name: {
                "label": MODELS[name].label,
                "class": type(fitted[name].estimator).__name__,
                "params": _model_params(fitted[name]),
                "rules": n_rules(fitted[name]),
                "fitted": _fitted_choices(fitted[name]),
                "fit_s": round(fit_s[name], 3),
            }
            for name in models
        },
        "machine_effects": machine.run_metadata("x")["effects"],
        "versions": package_versions(
            ("skthermal", "scikit-learn", "numpy", "scipy", "pandas", "matplotlib"),
            with_platform=True,
        ),
        "timings_s": {k: round(v, 3) for k, v in timings.items()},
    }
    result = StudyResult(
        results=results,
        summary=summary,
        sensors=sensors,
        campaign=campaign,
        predictions=predictions,
        runs=runs,
        settings=settings,
        files=[],
        finding=finding,
    )
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        progress(f"writing the report to {out}/")
        t = time.perf_counter()
        write_runs(runs, out / "runs.csv.gz", metadata=runs.attrs["metadata"])
        result.files += ["runs.csv.gz", "runs.csv.gz.json"]
        figure_files, figure_note = [], None
        if figures:
            try:
                figure_files = _draw_figures(out, result, models)
            except ImportError:
                figure_note = "matplotlib is not installed: figures were skipped"
                progress(figure_note + " (pip install 'skthermal[plot]')")
        else:
            figure_note = "figures were not requested (--no-figures)"
        timings["report_s"] = time.perf_counter() - t
        timings["total_s"] = time.perf_counter() - t0
        settings["timings_s"] = {k: round(v, 3) for k, v in timings.items()}
        settings["figures"] = figure_files
        if figure_note:
            settings["figures_note"] = figure_note
        result.files += _write_tables(out, result, figure_files, figure_note)
        result.files += figure_files
    else:
        timings["total_s"] = time.perf_counter() - t0
        settings["timings_s"] = {k: round(v, 3) for k, v in timings.items()}
    progress(f"done in {time.perf_counter() - t0:.1f} s")
    return result


def _finding(results, summary):
    means = summary.set_index("model")["RMSE_um"]
    if not {"anfis-fcm", "anfis-grid"} <= set(means.index):
        return ""
    fcm, grid = means["anfis-fcm"], means["anfis-grid"]
    by_test = results.pivot(index="test", columns="model", values="RMSE_um")
    wins = int((by_test["anfis-fcm"] < by_test["anfis-grid"]).sum())
    holds = bool(fcm < grid)
    paper_fcm = np.mean([PAPER[(t, "anfis-fcm")][1] for t in TEST_RUNS])
    paper_grid = np.mean([PAPER[(t, "anfis-grid")][1] for t in TEST_RUNS])
    # Judged on the mean over the tests; said "on the mean" when the tests
    # split the other way (better on 2 of 5 read as a contradiction).
    verdict = "holds" if holds else "does NOT hold"
    if holds != (2 * wins > len(by_test)):
        verdict += " on the mean"
    ratio = results.pivot(index="test", columns="model", values="RMSE_vs_paper")
    near = [
        t for t in TEST_RUNS if t in ratio.index and ratio.loc[t, "anfis-grid"] <= 2
    ]
    far = [t for t in TEST_RUNS if t in ratio.index and t not in near]
    return (
        f"The paper's finding (ANFIS-FCM, 3 rules, beats ANFIS-Grid, 243 rules) "
        f"{verdict} here: mean RMSE {fcm:.2f} vs {grid:.2f} µm (paper "
        f"{paper_fcm:.2f} vs {paper_grid:.2f}); ANFIS-FCM is better on {wins} of "
        f"{len(by_test)} tests. ANFIS-Grid is within 2x of the paper's RMSE on "
        f"Tests {', '.join(near) or 'none'}"
        + (f", not on {', '.join(far)}." if far else ".")
    )


def _campaign_table(runs, meta, selected):
    rows = []
    for record in meta.to_dict("records"):
        run = record["run"]
        part = runs[runs["run"] == run]
        y = part[TARGET].to_numpy()
        dy = y - y[0]
        temps = part[selected].to_numpy()
        rows.append(
            {
                "test": run,
                "role": "training" if run == TRAIN_TEST else "test",
                "description": record.get("description", ""),
                "hours": round(float(part["time_s"].iloc[-1]) / 3600.0, 2),
                "samples": len(part),
                "sim_max_dY_um": float(np.max(np.abs(dy))),
                "paper_max_Y_um": record.get("paper_max_disp_y_um", np.nan),
                "sim_max_dT_selected_C": float(np.max(np.abs(temps - temps[0]))),
            }
        )
    return pd.DataFrame(rows)
