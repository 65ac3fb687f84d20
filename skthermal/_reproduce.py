"""The papers' Machine B study, replicated on the simulator: ``skthermal reproduce``.

Abdulshahed et al. (000; 001 §5.3) selected 5 of the 77 temperature sensors of
Machine B with grey influence coefficients and fuzzy c-means, trained two ANFIS
models on Test IV -- one rule per fuzzy c-means cluster (3 rules) and a grid
partition (3 membership functions per input, 243 rules) -- and tested them on
Tests I, II, III, V and VI (001 Tables 5-7 and 5-8, Figs. 5-11 to 5-15). This
module repeats that study on Tests I-VI simulated with the ``"vmc-b"`` preset,
adds the grey models (GNNMCI, Grey-PSO) and the thesis' neural network baseline
(10 hidden neurons, 001 §6.3), and writes a report folder.

It also holds what the command line shares with the study: the named models
(:data:`MODELS`, :func:`make_model`), the named sensor selectors
(:func:`make_selector`), :class:`RunStartRegressor` (models on changes since
the start of each run) and :func:`score_runs` (the papers' metrics per run).
"""

import json
import platform
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, RegressorMixin, clone
from sklearn.utils.validation import check_is_fitted

TARGET = "disp_y_um"
TRAIN_TEST = "IV"
TEST_RUNS = ("I", "II", "III", "V", "VI")
DEFAULT_SAMPLE_PERIOD_S = 60.0
QUICK_SAMPLE_PERIOD_S = 120.0
N_SENSORS = 5

# 001 Tables 5-7 and 5-8 (also 000 Tables 6-7): R, RMSE (µm), NSE, residual
# band (±µm) of the models trained on Test IV, per test.
PAPER = {
    ("I", "anfis-grid"): (0.96, 1.53, 0.92, 3.0),
    ("I", "anfis-fcm"): (0.99, 1.23, 0.94, 2.0),
    ("II", "anfis-grid"): (0.99, 2.72, 0.96, 4.0),
    ("II", "anfis-fcm"): (0.99, 0.57, 0.99, 2.0),
    ("III", "anfis-grid"): (0.98, 2.78, 0.95, 5.0),
    ("III", "anfis-fcm"): (0.99, 1.06, 0.98, 2.0),
    ("V", "anfis-grid"): (0.97, 3.98, 0.95, 8.0),
    ("V", "anfis-fcm"): (0.99, 2.78, 0.97, 4.0),
    ("VI", "anfis-grid"): (0.98, 3.88, 0.95, 7.0),
    ("VI", "anfis-fcm"): (0.99, 2.78, 0.97, 5.0),
}
PAPER_RULES = {"anfis-fcm": 3, "anfis-grid": 243}
PAPER_SENSORS = ("T18_C", "T55_C", "T63_C", "T68_C", "T71_C")

METRIC_COLUMNS = ("R", "RMSE_um", "NSE", "residual_um", "improvement_pct")


# --------------------------------------------------------------------------
# Models on changes since the start of each run
# --------------------------------------------------------------------------


def _run_labels(X, groups):
    """Run label of every row: ``groups``, a ``run`` column or index level."""
    if groups is not None:
        return np.asarray(groups)
    if isinstance(X, pd.DataFrame):
        if "run" in X.columns:
            return X["run"].to_numpy()
        if "run" in X.index.names:
            return X.index.get_level_values("run").to_numpy()
    return None


def _first_rows(labels, n):
    """Position of the first row of the run of every row."""
    if labels is None:
        return np.zeros(n, dtype=int)
    codes, _ = pd.factorize(labels)
    _, first = np.unique(codes, return_index=True)
    return first[codes]


def _changes(X, groups):
    """``X`` minus the first row of its run, as a DataFrame indexed by run."""
    labels = _run_labels(X, groups)
    if isinstance(X, pd.DataFrame):
        frame = X.drop(columns="run") if "run" in X.columns else X
        if labels is not None and "run" not in frame.index.names:
            frame = frame.set_axis(pd.Index(labels, name="run"), axis=0)
    else:
        values = np.asarray(X, dtype=float)
        if values.ndim == 1:
            values = values[:, None]
        index = None if labels is None else pd.Index(labels, name="run")
        # Integer column labels: the inner model records no feature names.
        frame = pd.DataFrame(values, index=index)
    values = frame.to_numpy(dtype=float)
    first = _first_rows(labels, values.shape[0])
    changes = pd.DataFrame(
        values - values[first], index=frame.index, columns=frame.columns
    )
    return changes, first


class RunStartRegressor(RegressorMixin, BaseEstimator):
    """Fit and predict a regressor on changes since the start of each run.

    The papers model "temperature change" against "thermal drift": inputs and
    target are taken relative to the first sample of their run, and the
    prediction is the change of the error since the run started -- what a
    compensation applies (zero on the first sample of every run). Run labels
    come from ``groups``, a ``run`` column or a ``run`` index level (as
    returned by :func:`skthermal.datasets.split_runs`); without any, all rows
    are one run. The inner estimator sees a DataFrame indexed by run, so
    run-aware estimators (grey models, ANFIS checking sets) keep the run
    boundaries.

    Parameters
    ----------
    estimator : regressor
        The model, cloned by ``fit``.

    Attributes
    ----------
    estimator_ : regressor
        The fitted clone.
    """

    def __init__(self, estimator):
        self.estimator = estimator

    def fit(self, X, y, groups=None):
        Xc, first = _changes(X, groups)
        yv = np.asarray(y, dtype=float)
        self.estimator_ = clone(self.estimator).fit(Xc, yv - yv[first])
        return self

    def predict(self, X, groups=None):
        check_is_fitted(self, "estimator_")
        Xc, first = _changes(X, groups)
        pred = np.asarray(self.estimator_.predict(Xc), dtype=float)
        return pred - pred[first]


# --------------------------------------------------------------------------
# Named models and selectors
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelSpec:
    """A named model of the study and of ``skthermal fit``."""

    label: str
    description: str


MODELS = {
    "anfis-fcm": ModelSpec(
        "ANFIS-FCM", "ANFIS, one rule per fuzzy c-means cluster (3 rules)"
    ),
    "anfis-grid": ModelSpec(
        "ANFIS-Grid", "ANFIS, grid partition, 3 MFs per input (243 rules on 5)"
    ),
    "gnnmci": ModelSpec("GNNMCI", "grey neural network GNNMCI(1,N), PSO-trained"),
    "grey-pso": ModelSpec("Grey-PSO", "grey model GMC(1,N) calibrated by PSO"),
    "mlp": ModelSpec("MLP", "neural network, 10 hidden neurons (001 §6.3)"),
}


def _anfis(init, quick, random_state):
    from skthermal.fuzzy import ANFISRegressor

    # Gaussian MFs and a checking set cut from Test IV, as in 000 §4.3: the
    # epoch of least checking error is kept, and training stops when it has
    # not improved for 20 epochs ("until the errors converge").
    common = {"mf": "gaussian", "validation_fraction": 0.2, "n_iter_no_change": 20}
    if init == "fcm":
        return ANFISRegressor(
            init="fcm",
            n_clusters=3,
            epochs=20 if quick else 100,
            random_state=random_state,
            **common,
        )
    return ANFISRegressor(
        init="grid",
        n_mfs=3,
        epochs=10 if quick else 100,
        random_state=random_state,
        **common,
    )


def _mlp(quick, random_state):
    from sklearn.compose import TransformedTargetRegressor
    from sklearn.neural_network import MLPRegressor
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    # MATLAB's fitnet of the thesis: tanh hidden layer, scaled inputs and
    # target, a batch second-order trainer (L-BFGS here for Levenberg-Marquardt).
    net = MLPRegressor(
        hidden_layer_sizes=(10,),
        activation="tanh",
        solver="lbfgs",
        max_iter=200 if quick else 1000,
        random_state=random_state,
    )
    return make_pipeline(
        StandardScaler(),
        TransformedTargetRegressor(regressor=net, transformer=StandardScaler()),
    )


def make_model(name, *, random_state=None, quick=False):
    """A named model, wrapped in :class:`RunStartRegressor`.

    Parameters
    ----------
    name : {"anfis-fcm", "anfis-grid", "gnnmci", "grey-pso", "mlp"}
    random_state : int or None
    quick : bool, default=False
        A small training budget (for tests and smoke runs).

    Returns
    -------
    RunStartRegressor
        Parameters of the inner model are reachable as ``estimator__<name>``
        (``estimator__epochs``, ...).
    """
    from skthermal.grey import GNNMCIRegressor, GreyPSORegressor

    if name not in MODELS:
        raise ValueError(f"Unknown model {name!r}; choose one of {', '.join(MODELS)}.")
    if name == "anfis-fcm":
        inner = _anfis("fcm", quick, random_state)
    elif name == "anfis-grid":
        inner = _anfis("grid", quick, random_state)
    elif name == "gnnmci":
        inner = GNNMCIRegressor(random_state=random_state)
    elif name == "grey-pso":
        inner = GreyPSORegressor(random_state=random_state)
    else:
        inner = _mlp(quick, random_state)
    return RunStartRegressor(inner)


SELECTORS = {
    "fcm": "grey influence GM(1,N) + fuzzy c-means, one sensor per group",
    "grey": "top sensors by grey influence GM(1,N)",
    "gra": "top sensors by grey relational (similitude) degree",
}


def make_selector(name, n_sensors=N_SENSORS, *, random_state=None):
    """A named sensor selector keeping ``n_sensors`` sensors."""
    from skthermal.selection import (
        FCMClusterPicker,
        GRASelector,
        GreyInfluenceSelector,
    )

    if name not in SELECTORS:
        raise ValueError(
            f"Unknown selector {name!r}; choose one of {', '.join(SELECTORS)}."
        )
    if name == "fcm":
        return FCMClusterPicker(n_clusters=n_sensors, random_state=random_state)
    if name == "grey":
        return GreyInfluenceSelector(n_features_to_select=n_sensors)
    return GRASelector(n_features_to_select=n_sensors)


def n_rules(model):
    """Rules of a fitted (wrapped) ANFIS model, else None."""
    inner = getattr(model, "estimator_", model)
    value = getattr(inner, "n_rules_", None)
    return None if value is None else int(value)


# --------------------------------------------------------------------------
# Metrics per run
# --------------------------------------------------------------------------


def run_metrics(z, p):
    """The papers' metrics of one run (changes since its start)."""
    from skthermal.metrics import (
        improvement,
        nash_sutcliffe,
        pearson_r,
        residual_band,
        rmse,
    )

    z = np.asarray(z, dtype=float)
    p = np.asarray(p, dtype=float)
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(z))):
        return dict.fromkeys(METRIC_COLUMNS, np.nan)
    return {
        "R": pearson_r(z, p),
        "RMSE_um": rmse(z, p),
        "NSE": nash_sutcliffe(z, p),
        "residual_um": residual_band(z, p),
        "improvement_pct": 100.0 * improvement(z, p),
    }


def score_runs(measured, predicted, groups):
    """Metrics per run, both series taken as changes since the run start.

    Parameters
    ----------
    measured, predicted : array-like of shape (n_samples,)
    groups : array-like of shape (n_samples,)
        Run label of every row (runs contiguous).

    Returns
    -------
    DataFrame
        One row per run: ``run``, ``n_samples`` and :data:`METRIC_COLUMNS`.
    """
    z = np.asarray(measured, dtype=float)
    p = np.asarray(predicted, dtype=float)
    groups = np.asarray(groups)
    rows = []
    for label in pd.unique(groups):
        mask = groups == label
        zr, pr = z[mask], p[mask]
        rows.append(
            {
                "run": label,
                "n_samples": int(mask.sum()),
                **run_metrics(zr - zr[0], pr - pr[0]),
            }
        )
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------
# Formatting
# --------------------------------------------------------------------------


def _fmt(value, spec=".2f", prefix=""):
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "—"
    if isinstance(value, int | np.integer):
        return f"{prefix}{value}"
    return f"{prefix}{value:{spec}}"


def markdown_table(frame):
    """A DataFrame as a GitHub Markdown table (cells as already formatted)."""
    header = "| " + " | ".join(map(str, frame.columns)) + " |"
    rule = "|" + "|".join("---" for _ in frame.columns) + "|"
    body = [
        "| " + " | ".join(str(v) for v in row) + " |"
        for row in frame.itertuples(index=False, name=None)
    ]
    return "\n".join([header, rule, *body])


def format_results(results):
    """The long result table in the form of 001 Tables 5-7/5-8 (strings)."""
    rows = []
    for r in results.to_dict("records"):
        rows.append(
            {
                "Test": r["test"],
                "Model": r["label"],
                "Rules": _fmt(r["rules"] if pd.notna(r["rules"]) else None),
                "R": _fmt(r["R"]),
                "RMSE µm": _fmt(r["RMSE_um"]),
                "NSE": _fmt(r["NSE"]),
                "Residual": _fmt(r["residual_um"], ".1f", "±"),
                "Improv. %": _fmt(r["improvement_pct"], ".0f"),
                "Paper R": _fmt(r["paper_R"]),
                "Paper RMSE": _fmt(r["paper_RMSE_um"]),
                "Paper NSE": _fmt(r["paper_NSE"]),
                "Paper resid.": _fmt(r["paper_residual_um"], ".0f", "±"),
            }
        )
    return pd.DataFrame(rows)


def format_summary(summary):
    rows = []
    for r in summary.to_dict("records"):
        rows.append(
            {
                "Model": r["label"],
                "Rules": _fmt(r["rules"] if pd.notna(r["rules"]) else None),
                "Train RMSE (IV) µm": _fmt(r["train_RMSE_um"]),
                "Mean RMSE µm": _fmt(r["RMSE_um"]),
                "Paper mean RMSE": _fmt(r["paper_RMSE_um"]),
                "Max residual µm": _fmt(r["residual_um"], ".1f", "±"),
                "Mean R": _fmt(r["R"]),
                "Mean NSE": _fmt(r["NSE"]),
                "Fit s": _fmt(r["fit_s"], ".1f"),
            }
        )
    return pd.DataFrame(rows)


def text_table(frame):
    """Left-aligned first columns, right-aligned numbers, for the terminal."""
    cols = list(frame.columns)
    widths = [max(len(str(c)), *(len(str(v)) for v in frame[c])) for c in cols]
    left = {"Test", "Model", "Sensor", "Location", "Description"}

    def line(values):
        cells = []
        for c, w, v in zip(cols, widths, values, strict=True):
            cells.append(str(v).ljust(w) if c in left else str(v).rjust(w))
        return "  ".join(cells).rstrip()

    out = [line(cols)]
    out += [line(row) for row in frame.itertuples(index=False, name=None)]
    return "\n".join(out)


# --------------------------------------------------------------------------
# The study
# --------------------------------------------------------------------------


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


def _versions():
    import importlib.metadata as md

    out = {"python": platform.python_version(), "platform": platform.platform()}
    for dist in ("skthermal", "scikit-learn", "numpy", "scipy", "pandas", "matplotlib"):
        try:
            out[dist] = md.version(dist)
        except md.PackageNotFoundError:
            out[dist] = None
    return out


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    if value is None or isinstance(value, str | int | float | bool):
        return value
    return repr(value)


def _model_params(model):
    inner = model.estimator
    params = inner.get_params(deep=True)
    return {k: _jsonable(v) for k, v in params.items() if not hasattr(v, "fit")}


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
        Sampling of the simulated tests; default 60 s (120 s with ``quick``).
    figures : bool
        Draw PNG figures (needs matplotlib; skipped with a note without it).
    models : sequence of str, optional
        Subset of :data:`MODELS` (default all, in that order).
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
    models = list(MODELS) if models is None else list(models)
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

    Xs = X[selected]
    fitted, fit_s, train_rmse, preds = {}, {}, {}, {}
    for name in models:
        model = make_model(name, random_state=seed, quick=quick)
        label = MODELS[name].label
        progress(f"training {label} on Test {TRAIN_TEST}")
        t = time.perf_counter()
        with warnings.catch_warnings():
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
    predictions[TARGET] = zall - zall[_first_rows(groups, len(groups))]
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
                "fit_s": round(fit_s[name], 3),
            }
            for name in models
        },
        "machine_effects": machine.run_metadata("x")["effects"],
        "versions": _versions(),
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
    verdict = "holds" if holds else "does NOT hold"
    return (
        f"The paper's finding (ANFIS-FCM, 3 rules, beats ANFIS-Grid, 243 rules) "
        f"{verdict} here: mean RMSE {fcm:.2f} vs {grid:.2f} µm (paper "
        f"{paper_fcm:.2f} vs {paper_grid:.2f}); ANFIS-FCM is better on {wins} of "
        f"{len(by_test)} tests."
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


def _write_tables(out, result, figure_files, figure_note):
    files = []
    result.results.to_csv(out / "results.csv", index=False)
    result.summary.to_csv(out / "summary.csv", index=False)
    result.sensors.to_csv(out / "sensors.csv", index=False)
    result.campaign.to_csv(out / "campaign.csv", index=False)
    result.predictions.to_csv(out / "predictions.csv.gz", index=False)
    files += [
        "results.csv",
        "summary.csv",
        "sensors.csv",
        "campaign.csv",
        "predictions.csv.gz",
    ]
    with open(out / "settings.json", "w", encoding="utf-8") as fh:
        json.dump(_jsonable(result.settings), fh, indent=2, ensure_ascii=False)
        fh.write("\n")
    files.append("settings.json")
    (out / "report.md").write_text(
        report_markdown(result, figure_files, figure_note), encoding="utf-8"
    )
    files.append("report.md")
    return files


def report_markdown(result, figure_files=(), figure_note=None):
    """The report as Markdown: tables beside the papers' figures, figures."""
    s = result.settings
    sel = result.sensors[result.sensors["selected"]]
    sensors = pd.DataFrame(
        {
            "Sensor": sel["sensor"],
            "Location": sel["location"],
            "Group": sel["group"],
            "GM(1,N) influence": [f"{v:.3g}" for v in sel["gm1n_influence"]],
        }
    )
    camp = result.campaign
    campaign = pd.DataFrame(
        {
            "Test": camp["test"],
            "Role": camp["role"],
            "Description": camp["description"],
            "Samples": camp["samples"],
            "Sim. max ΔY µm": [f"{v:.1f}" for v in camp["sim_max_dY_um"]],
            "Paper max Y µm": [_fmt(v, ".0f") for v in camp["paper_max_Y_um"]],
        }
    )
    lines = [
        "# Machine B study, replicated on the simulator",
        "",
        "Tests I-VI of Machine B (001 §5.3; 000) simulated with the `vmc-b` "
        f"preset, {s['sample_period_s']:g} s sampling, seed {s['seed']}"
        + (" (quick budget)" if s["quick"] else "")
        + ". Sensors selected and models trained on Test IV; scored on "
        "Tests I, II, III, V and VI. Measured and predicted Y displacement are "
        "compared as change since the start of each test, as a compensation "
        "applies them. Paper columns: 001 Tables 5-7 and 5-8 (ANFIS models "
        "only; — where the paper has no figure).",
        "",
        f"**{result.finding}**" if result.finding else "",
        "",
        "## Results per test (001 Tables 5-7, 5-8)",
        "",
        markdown_table(format_results(result.results)),
        "",
        "## Mean over the five tests",
        "",
        markdown_table(format_summary(result.summary)),
        "",
        "## Selected sensors (paper: " + ", ".join(PAPER_SENSORS) + ")",
        "",
        markdown_table(sensors),
        "",
        "## The simulated campaign",
        "",
        markdown_table(campaign),
        "",
        "## Figures (001 Figs. 5-11 to 5-15)",
        "",
    ]
    if figure_files:
        lines += [f"![{f}]({f})" for f in figure_files]
    else:
        lines.append(figure_note or "No figures.")
    lines += [
        "",
        "## Files",
        "",
        "`results.csv` (per test and model), `summary.csv` (means), "
        "`sensors.csv` (all 77 sensors: group, influence, selected), "
        "`campaign.csv`, `predictions.csv.gz` (changes since the start of each "
        "test, every model), `runs.csv.gz` (the simulated run table, metadata "
        "sidecar `runs.csv.gz.json`), `settings.json` (settings, versions, "
        "timings).",
        "",
    ]
    return "\n".join(lines)


# --------------------------------------------------------------------------
# Figures (plain matplotlib, no pyplot state)
# --------------------------------------------------------------------------


def _draw_figures(out, result, models):
    from matplotlib.figure import Figure

    folder = out / "figures"
    folder.mkdir(exist_ok=True)
    files = []
    pred = result.predictions
    # Paper layout: (a) ANFIS-Grid, (b) ANFIS-FCM; otherwise every model.
    panels = [m for m in ("anfis-grid", "anfis-fcm") if m in models] or models[:2]
    figure_no = {"I": "5-11", "II": "5-12", "III": "5-13", "V": "5-14", "VI": "5-15"}
    table = result.results.set_index(["test", "model"])
    for test in TEST_RUNS:
        part = pred[pred["run"] == test]
        hours = part["time_s"].to_numpy() / 3600.0
        z = part[TARGET].to_numpy()
        fig = Figure(figsize=(5.2 * len(panels), 5.2), layout="constrained")
        axes = fig.subplots(
            2, len(panels), sharex=True, squeeze=False, height_ratios=[2.2, 1]
        )
        for j, name in enumerate(panels):
            p = part[f"pred_{name}"].to_numpy()
            top, bottom = axes[0, j], axes[1, j]
            top.plot(hours, z, color="black", lw=1.6, label="measured")
            top.plot(hours, p, color="tab:red", lw=1.2, ls="--", label="predicted")
            row = table.loc[(test, name)]
            top.set_title(
                f"({chr(97 + j)}) {MODELS[name].label}: RMSE {row['RMSE_um']:.2f} µm",
                fontsize=10,
            )
            top.set_ylabel("Y change (µm)")
            top.legend(loc="best", fontsize=8)
            top.grid(alpha=0.3)
            bottom.plot(hours, z - p, color="tab:blue", lw=1.0)
            bottom.axhline(0.0, color="gray", lw=0.8)
            bottom.set_ylabel("residual (µm)")
            bottom.set_xlabel("time (h)")
            bottom.grid(alpha=0.3)
        fig.suptitle(
            f"Test {test} (cf. 001 Fig. {figure_no[test]}), trained on Test IV",
            fontsize=11,
        )
        name = f"figures/test_{test}.png"
        fig.savefig(out / name, dpi=110)
        files.append(name)

    fig = Figure(figsize=(8, 4.2), layout="constrained")
    ax = fig.subplots()
    width = 0.8 / max(len(models), 1)
    x = np.arange(len(TEST_RUNS))
    for k, name in enumerate(models):
        vals = [table.loc[(t, name), "RMSE_um"] for t in TEST_RUNS]
        ax.bar(
            x + (k - (len(models) - 1) / 2) * width,
            vals,
            width,
            label=MODELS[name].label,
        )
    for name, marker in (("anfis-fcm", "o"), ("anfis-grid", "s")):
        if name in models:
            k = models.index(name)
            paper = [PAPER[(t, name)][1] for t in TEST_RUNS]
            ax.plot(
                x + (k - (len(models) - 1) / 2) * width,
                paper,
                marker,
                color="black",
                mfc="white",
                label=f"paper {MODELS[name].label}",
            )
    ax.set_xticks(x, [f"Test {t}" for t in TEST_RUNS])
    ax.set_yscale("log")
    ax.set_ylabel("RMSE (µm, log scale)")
    ax.set_title("RMSE per test, models trained on Test IV")
    ax.grid(alpha=0.3, axis="y", which="both")
    ax.legend(fontsize=8, ncols=2)
    name = "figures/rmse_by_test.png"
    fig.savefig(out / name, dpi=110)
    files.append(name)
    return files
