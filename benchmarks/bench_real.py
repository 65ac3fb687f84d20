"""Every skthermal regressor, alone and behind every sensor selector, against
linear baselines on a real spindle test (FL_THERMAL).

Data: ``fl_thermal_spindle.csv.gz`` (GitHub CAIVIAC/FL_THERMAL), one 46.3 h run
sampled every 15 s: 16 temperatures ``T1_C`` .. ``T16_C``, ``spindle_rpm`` and
five displacement channels ``disp_ch1_um`` .. ``disp_ch5_um``. Each channel is
a separate target; every model is fitted per channel.

Inputs. The 16 temperatures (absolute readings; models that need changes since
the run start make them themselves). ``TransferFunctionRegressor`` and the lag
pipeline also get ``spindle_rpm``, their driver.

Splits.

* ``chrono``: the first 60% of the rows train, the last 40% are scored. Every
  model predicts the whole record as one run (so sequence models see the true
  run start) and is scored on the last 40%.
* ``lobo`` (leave one duty block out): the record alternates 4 h speed steps
  and 4 h rest. A block starts where the spindle starts after a rest
  (``spindle_rpm`` goes from 0 to > 0; the first block starts at row 0), so
  the blocks are 1250 rpm + rest, 2500 + rest, 3750 + rest, 5000 + rest,
  3500 + rest, and the final mixed block (500, 1500, 2500, 4500 rpm, rest).
  Each block in turn is held out; the rest trains, the part before the block
  and the part after it as two runs (restarting there: the only honest choice
  for a model that cannot see the held-out rows). The whole record is then
  predicted as one run and the held-out block scored. The RMSE printed is
  pooled over all held-out rows, i.e. over the whole record.

Model choice. Hyper-parameters come from a small grid scored by time-ordered
cross-validation on the training rows only: two expanding-window folds (fit on
the first 50% / 75% of the training rows, predict from the start through the
next 25%, score those 25%), keeping run labels; ``--cv-folds 4`` uses
four (fit on 40/55/70/85%, score the next 15%) to show how much a verdict
hangs on that choice. ANFIS (behind a
StandardScaler, slopes-only ridge as the ridge baseline) gets the same joint
grid search over its rule count (1, 2, 3) and the ridge baseline's alphas
(``ANFISRidge``): one rule is exactly that baseline. Behind a selector the
number of sensors (4 or 8) is chosen the same way, with the regressor at its
benchmark settings (``BASE`` below). LASSO selection (Tanaka et al., IJAT
2025) is ``SelectFromModel(LassoCV)`` on standardised temperatures, LassoCV
with ``TimeSeriesSplit(5)``; the script prints how many sensors it keeps.

Baselines: ``LinearRegression`` on the 16 temperatures (the reference of every
ratio), ridge with its penalty chosen by the same CV, and persistence (the
last training value before the scored rows; for the first LOBO block, the
first one after it). The recommended lag pipeline
``skthermal.preprocessing.make_lag_pipeline()`` runs with its own settings
when the module exists.

Run:  python benchmarks/bench_real.py [--data ../shared/data] [--quick]
      [--split chrono|lobo|both] [--models NAME,NAME] [--cv-folds 2|4]
``--quick`` runs the chronological split only, on a subset of models (the
baselines, UpdateRegressor, ANFISRegressor, TransferFunctionRegressor and the
LASSO selector), with the same grids (under 3 minutes). ``--models`` keeps
the rows whose name contains one of the given words (case-insensitive). A
model that fails prints its error in its row.
"""

import argparse
import itertools
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.feature_selection import SelectFromModel
from sklearn.linear_model import LassoCV, LinearRegression, Ridge
from sklearn.model_selection import TimeSeriesSplit
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from skthermal import (
    ANFISRegressor,
    FCMClusterPicker,
    GNNMCIRegressor,
    GRASelector,
    GreyInfluenceSelector,
    GreyPSORegressor,
    ModularRegressor,
    UpdateRegressor,
)
from skthermal.datasets import load_fl_thermal
from skthermal.linear_model import TransferFunctionRegressor
from skthermal.metrics import rmse

DEFAULT_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
TEMPS = [f"T{i}_C" for i in range(1, 17)]
SPEED = "spindle_rpm"
CHANNELS = [f"disp_ch{i}_um" for i in range(1, 6)]
RUN = "fl_thermal"
# Expanding-window folds (fit on the first a, score a..b of the training
# rows). ``--cv-folds 4`` checks how much the verdicts hang on this choice.
CV_PROTOCOLS = {
    2: ((0.5, 0.75), (0.75, 1.0)),
    4: ((0.4, 0.55), (0.55, 0.7), (0.7, 0.85), (0.85, 1.0)),
}
CV_FOLDS = CV_PROTOCOLS[2]

# --------------------------------------------------------------------------
# Models: a factory of a fresh estimator from grid parameters, the grid, and
# whether the estimator also reads the spindle speed.


RIDGE_ALPHAS = [float(a) for a in np.logspace(-2, 4, 7)]


def _ridge(alpha=1.0):
    return make_pipeline(StandardScaler(), Ridge(alpha=alpha))


class ANFISRidge(RegressorMixin, BaseEstimator):
    """ANFIS-FCM behind a StandardScaler, its consequents' ridge given as the
    ``alpha`` of scikit-learn's ``Ridge`` (slopes shrunk, constants free).

    ``ANFISRegressor``'s ridge is relative to the mean diagonal of the normal
    equations, which for one rule on standardised inputs is the number of
    rows: ``ridge = alpha / n_rows`` makes one rule exactly the ridge
    baseline ``_ridge(alpha)``, at every training size, so a grid over
    ``n_clusters`` (with 1) and the ridge baseline's alphas holds that
    baseline. ``alpha="auto"``: ANFIS's own ``ridge="auto"`` (its checking
    folds inside the training rows; pandas output keeps the run index they
    read).
    """

    def __init__(self, n_clusters=3, alpha="auto", epochs=50):
        self.n_clusters = n_clusters
        self.alpha = alpha
        self.epochs = epochs

    def fit(self, X, y):
        auto = isinstance(self.alpha, str) and self.alpha == "auto"
        self.pipeline_ = make_pipeline(
            StandardScaler(),
            ANFISRegressor(
                n_clusters=self.n_clusters,
                epochs=self.epochs,
                ridge="auto" if auto else self.alpha / len(X),
                penalize_intercepts=False,
                random_state=0,
            ),
        ).set_output(transform="pandas")
        self.pipeline_.fit(X, y)
        return self

    def predict(self, X):
        return self.pipeline_.predict(X)


def _tf(alpha=10.0):
    # A coarser search than the defaults, to keep the benchmark short.
    return TransferFunctionRegressor(
        speed_column=SPEED, alpha=alpha, n_grid=8, max_iter=10
    )


REGRESSORS = {
    # name: (factory, grid, reads speed)
    "LinearRegression": (LinearRegression, [{}], False),
    "Ridge (CV)": (_ridge, [{"alpha": a} for a in RIDGE_ALPHAS], False),
    "UpdateRegressor": (
        UpdateRegressor,
        [{"alpha": a} for a in (0.1, 25.0, 1e3, 1e4)],
        False,
    ),
    # The ridge baseline's grid (one rule) and 2 or 3 rules, same alphas.
    "ANFISRegressor": (
        ANFISRidge,
        [{"n_clusters": c, "alpha": a} for c in (1, 2, 3) for a in RIDGE_ALPHAS],
        False,
    ),
    "GreyPSORegressor": (
        lambda **p: GreyPSORegressor(random_state=0, **p),
        [{}],
        False,
    ),
    "GNNMCIRegressor": (lambda **p: GNNMCIRegressor(random_state=0, **p), [{}], False),
    "ModularRegressor": (
        ModularRegressor,
        [{"relative": r} for r in (True, False)],
        False,
    ),
    "TransferFunctionRegressor": (
        _tf,
        [{"alpha": a} for a in (1.0, 10.0, 100.0, 1000.0)],
        True,
    ),
}
# Settings of a regressor behind a selector (the selector's size is tuned).
BASE = {
    "LinearRegression": {},
    "Ridge (CV)": {"alpha": 1.0},
    "UpdateRegressor": {"alpha": 25.0},
    "ANFISRegressor": {"n_clusters": 3, "alpha": "auto"},
    "GreyPSORegressor": {},
    "GNNMCIRegressor": {},
    "ModularRegressor": {"relative": True},
    "TransferFunctionRegressor": {"alpha": 10.0},
}


class LassoSensorSelector:
    """LASSO sensor selection: sensors with a nonzero LASSO coefficient."""

    def fit(self, X, y):
        lasso = LassoCV(cv=TimeSeriesSplit(5), alphas=30, max_iter=5000)
        pipe = make_pipeline(StandardScaler(), SelectFromModel(lasso))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            pipe.fit(X.to_numpy(), np.asarray(y))
        self.support_ = pipe[-1].get_support()
        if not self.support_.any():
            raise ValueError("LASSO kept no sensor")
        return self

    def get_support(self):
        return self.support_


SELECTORS = {
    # name: (factory, grid)
    "GreyInfluence": (
        lambda k: GreyInfluenceSelector(n_features_to_select=k),
        [{"k": 4}, {"k": 8}],
    ),
    "GRA": (lambda k: GRASelector(n_features_to_select=k), [{"k": 4}, {"k": 8}]),
    "FCMClusterPicker": (
        lambda k: FCMClusterPicker(n_clusters=k, random_state=0),
        [{"k": 4}, {"k": 8}],
    ),
    "LASSO": (lambda: LassoSensorSelector(), [{}]),
}


class Candidate:
    """An estimator on named columns, optionally behind a sensor selector."""

    def __init__(self, regressor, params, selector=None, sel_params=None):
        self.regressor, self.params = regressor, params
        self.selector, self.sel_params = selector, sel_params or {}

    def fit(self, X, y):
        factory, _, speed = REGRESSORS[self.regressor]
        temps = TEMPS
        if self.selector is not None:
            sel = SELECTORS[self.selector][0](**self.sel_params).fit(X[TEMPS], y)
            temps = list(np.asarray(TEMPS)[sel.get_support()])
        self.n_sensors_ = len(temps)
        self.columns_ = temps + ([SPEED] if speed else [])
        self.est_ = factory(**self.params).fit(X[self.columns_], y)
        return self

    def predict(self, X):
        return np.asarray(self.est_.predict(X[self.columns_]), dtype=float)


class LagPipeline:
    """The library's recommended lag pipeline, with its own settings."""

    def fit(self, X, y):
        from skthermal.preprocessing import make_lag_pipeline

        self.est_ = make_lag_pipeline().fit(X, y)
        self.n_sensors_ = len(TEMPS)
        return self

    def predict(self, X):
        return np.asarray(self.est_.predict(X), dtype=float)


def lag_pipeline_available():
    try:
        from skthermal.preprocessing import make_lag_pipeline  # noqa: F401
    except ImportError:
        return False
    return True


# --------------------------------------------------------------------------
# Data, splits and scoring


def frame(data, rows, labels):
    """Rows of the record as a run-indexed DataFrame (labels per row)."""
    part = data.iloc[rows]
    index = pd.MultiIndex.from_arrays(
        [np.asarray(labels, dtype=object), part["time_s"].to_numpy()],
        names=["run", "time_s"],
    )
    return part[TEMPS + [SPEED]].set_axis(index, axis=0)


def duty_blocks(rpm):
    """Block number of every row: a block starts where the spindle starts
    after a rest (the first block at row 0)."""
    rpm = np.asarray(rpm)
    starts = np.flatnonzero((rpm[1:] > 0) & (rpm[:-1] == 0)) + 1
    starts = starts[starts > np.flatnonzero(rpm > 0)[0]]
    return np.searchsorted(starts, np.arange(rpm.size), side="right")


def make_splits(data, which):
    """Folds as (name, train_rows, train_labels, scored_rows, anchor_row)."""
    n = len(data)
    folds = []
    if which == "chrono":
        cut = int(round(0.6 * n))
        train = np.arange(cut)
        folds.append(
            ("60/40", train, np.full(cut, RUN, object), np.arange(cut, n), cut - 1)
        )
    else:
        blocks = duty_blocks(data[SPEED])
        for b in np.unique(blocks):
            held = np.flatnonzero(blocks == b)
            train = np.flatnonzero(blocks != b)
            labels = np.where(train < held[0], "before", "after").astype(object)
            anchor = held[0] - 1 if held[0] > 0 else held[-1] + 1
            folds.append((f"block {b}", train, labels, held, anchor))
    return folds


def fit_predict(make, data, y, train, labels, pred_rows, pred_labels):
    model = make()
    model.fit(frame(data, train, labels), y[train])
    return model, model.predict(frame(data, pred_rows, pred_labels))


def cv_choose(make_from, grid, data, y, train, labels):
    """The grid point of least mean RMSE over the expanding-window folds."""
    if len(grid) == 1:
        return grid[0]
    n = train.size
    scores = []
    for params in grid:
        errs = []
        for a, b in CV_FOLDS:
            ia, ib = int(a * n), int(b * n)
            rows = train[:ib]
            _, pred = fit_predict(
                lambda p=params: make_from(p),
                data,
                y,
                train[:ia],
                labels[:ia],
                rows,
                labels[:ib],
            )
            errs.append(rmse(y[train[ia:ib]], pred[ia:]))
        scores.append(np.mean(errs))
    return grid[int(np.argmin(scores))]


def evaluate(row, data, Y, folds):
    """Held-out predictions (pooled over folds) of one row of the table."""
    kind, spec = row
    preds = np.full((len(data), len(CHANNELS)), np.nan)
    fit_s = cv_s = 0.0
    chosen, sensors = [], []
    for _, train, labels, scored, anchor in folds:
        whole = np.arange(len(data))
        whole_labels = np.full(len(data), RUN, object)
        for c, ch in enumerate(CHANNELS):
            y = Y[ch].to_numpy()
            if kind == "persistence":
                preds[scored, c] = y[anchor]
                continue
            if kind == "lag":
                t0 = time.perf_counter()
                model, pred = fit_predict(
                    LagPipeline, data, y, train, labels, whole, whole_labels
                )
                fit_s += time.perf_counter() - t0
                preds[scored, c] = pred[scored]
                continue
            reg, sel = spec
            if sel is None:
                grid = REGRESSORS[reg][1]

                def make_from(p, reg=reg):
                    return Candidate(reg, p)
            else:
                grid = SELECTORS[sel][1]

                def make_from(p, reg=reg, sel=sel):
                    return Candidate(reg, BASE[reg], sel, p)

            t0 = time.perf_counter()
            params = cv_choose(make_from, grid, data, y, train, labels)
            t1 = time.perf_counter()
            model, pred = fit_predict(
                lambda p=params: make_from(p),
                data,
                y,
                train,
                labels,
                whole,
                whole_labels,
            )
            t2 = time.perf_counter()
            cv_s += t1 - t0
            fit_s += t2 - t1
            preds[scored, c] = pred[scored]
            chosen.append(params)
            sensors.append(model.n_sensors_)
    return preds, fit_s, cv_s, chosen, sensors


def table_rows(models_filter, quick, lag_ok):
    rows = [
        ("LinearRegression", ("model", ("LinearRegression", None))),
        ("Ridge (CV)", ("model", ("Ridge (CV)", None))),
        ("persistence", ("persistence", None)),
    ]
    if lag_ok:
        rows.append(("make_lag_pipeline()", ("lag", None)))
    regs = [r for r in REGRESSORS if r not in ("LinearRegression", "Ridge (CV)")]
    sels = list(SELECTORS)
    if quick:
        regs = ["UpdateRegressor", "ANFISRegressor", "TransferFunctionRegressor"]
        sels = ["LASSO"]
    rows += [(r, ("model", (r, None))) for r in regs]
    for sel, reg in itertools.product(sels, ["LinearRegression", *regs]):
        rows.append((f"{sel} + {reg}", ("model", (reg, sel))))
    if models_filter:
        words = [w.strip().lower() for w in models_filter.split(",") if w.strip()]
        rows = [
            r
            for r in rows
            if r[0] == "LinearRegression" or any(w in r[0].lower() for w in words)
        ]
    return rows


def describe_choice(chosen, sensors, n_folds):
    """Chosen grid points (with counts) and the number of sensors used."""
    parts = []
    if chosen and any(chosen):
        counts = pd.Series([str(c) for c in chosen]).value_counts()
        parts.append(", ".join(f"{k} x{v}" for k, v in counts.items()))
    if sensors and (min(sensors) != max(sensors) or sensors[0] != len(TEMPS)):
        if n_folds == 1:
            parts.append("sensors per channel " + "/".join(map(str, sensors)))
        else:
            parts.append(f"sensors {min(sensors)}-{max(sensors)}")
    return "; ".join(parts)


def run_split(name, data, Y, rows, quick):
    folds = make_splits(data, name)
    scored = np.concatenate([f[3] for f in folds])
    print(f"\n## Split: {name} ({len(folds)} fold(s), {scored.size} scored rows)\n")
    if name == "lobo":
        sizes = ", ".join(f"{f[0]}: {f[3].size}" for f in folds)
        print(f"Held-out blocks (rows): {sizes}\n")
    header = (
        "| model | "
        + " | ".join(f"ch{i}" for i in range(1, 6))
        + " | fit s | CV s | choices |"
    )
    print(header)
    print("|" + "---|" * 9)
    ref = None
    for label, row in rows:
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                preds, fit_s, cv_s, chosen, sensors = evaluate(row, data, Y, folds)
            errs = np.array(
                [
                    rmse(Y[ch].to_numpy()[scored], preds[scored, c])
                    for c, ch in enumerate(CHANNELS)
                ]
            )
        except Exception as exc:  # a failing model must not stop the table
            msg = f"{type(exc).__name__}: {exc}".replace("|", "/").replace("\n", " ")
            print(
                f"| {label} | ERROR: {msg[:200]} | | | | | | "
                f"{time.perf_counter() - t0:.1f} | |",
                flush=True,
            )
            continue
        if ref is None:
            ref = errs
        cells = [f"{e:.2f} ({e / r:.2f})" for e, r in zip(errs, ref, strict=True)]
        print(
            f"| {label} | "
            + " | ".join(cells)
            + f" | {fit_s:.1f} | {cv_s:.1f} | "
            + describe_choice(chosen, sensors, len(folds))
            + " |",
            flush=True,
        )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--split", choices=("chrono", "lobo", "both"), default=None)
    parser.add_argument(
        "--models",
        default=None,
        help="comma list of words: the rows whose name contains any of them "
        "(case-insensitive), e.g. 'lasso,transfer'",
    )
    parser.add_argument("--cv-folds", type=int, choices=sorted(CV_PROTOCOLS), default=2)
    args = parser.parse_args(argv)
    split = args.split or ("chrono" if args.quick else "both")
    global CV_FOLDS
    CV_FOLDS = CV_PROTOCOLS[args.cv_folds]

    df = load_fl_thermal(args.data)
    data = df.reset_index(drop=True)
    Y = data[CHANNELS]
    lag_ok = lag_pipeline_available()
    print("# FL_THERMAL real-data benchmark")
    print(
        f"rows {len(data)}, dt 15 s, {len(TEMPS)} temperatures; "
        f"RMSE in um on held-out rows (ratio to LinearRegression)"
    )
    print("make_lag_pipeline: " + ("available" if lag_ok else "unavailable"))
    print(f"CV folds (fit on the first a, score a..b of the training rows): {CV_FOLDS}")
    rows = table_rows(args.models, args.quick, lag_ok)
    t0 = time.perf_counter()
    for name in ("chrono", "lobo") if split == "both" else (split,):
        run_split(name, data, Y, rows, args.quick)
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
