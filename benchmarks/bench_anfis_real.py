"""ANFIS on a real spindle record against ridge regression, channel by channel.

FL_THERMAL (``../shared/data/fl_thermal_spindle.csv.gz``, one 46 h record):
inputs are the changes of all 16 temperatures since the record's first row,
targets the changes of each displacement channel ``disp_ch1_um`` ..
``disp_ch5_um`` separately; chronological split, the first 60 % for training
and the last 40 % held out. Both models see the same standardised inputs and
shrink slopes only (free intercept), and every setting is chosen on the
training part only, by the same time-ordered cross-validation
(``GridSearchCV`` over two expanding-window folds, as ``bench_real.py``: fit
on the first 50 % / 75 % of the training rows, score the next 25 %; least
mean RMSE, ties to the first grid point), then refitted on the whole
training part:

- ridge: ``StandardScaler`` + scikit-learn's ``Ridge``, ``alpha`` in
  1e-2 .. 1e4 (one per decade);
- ANFIS-FCM: ``StandardScaler`` + ``ANFISRegressor(penalize_intercepts=False,
  epochs=50)``, fuzzy c-means rules, ``n_clusters`` in 1, 2, 3 times the same
  alphas. The consequents' ridge is given as ``Ridge``'s alpha
  (``ridge = alpha / n_rows``: ANFIS's ridge is relative to the mean diagonal
  of the normal equations, the number of rows for one rule on standardised
  inputs), so one rule is exactly the ridge above and the ANFIS grid holds the
  ridge grid.

``LinearRegression`` is printed for reference. Prints the held-out RMSE (µm)
of each, the choices, and the ratio ANFIS / ridge per channel; exit status 1
when ANFIS is worse than ridge on any channel (by more than a relative 1e-6,
the rounding between the two solvers of the same model).

Run:  python benchmarks/bench_anfis_real.py [--data ../shared/data]

(Exit status 1 today: ANFIS is worse than ridge on channels 1 and 2.)
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.exceptions import ConvergenceWarning
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.model_selection import GridSearchCV
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from skthermal.datasets import load_fl_thermal
from skthermal.fuzzy import ANFISRegressor

DEFAULT_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
ALPHAS = [float(a) for a in np.logspace(-2, 4, 7)]
CV_FOLDS = ((0.5, 0.75), (0.75, 1.0))


def rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - np.asarray(b)) ** 2)))


class ANFISRidge(RegressorMixin, BaseEstimator):
    """ANFIS-FCM behind a StandardScaler with the ridge given as ``Ridge``'s
    alpha (slopes shrunk, constants free): one rule is ``Ridge(alpha)``."""

    def __init__(self, n_clusters=3, alpha=1.0, epochs=50):
        self.n_clusters = n_clusters
        self.alpha = alpha
        self.epochs = epochs

    def fit(self, X, y):
        self.pipeline_ = make_pipeline(
            StandardScaler(),
            ANFISRegressor(
                n_clusters=self.n_clusters,
                ridge=self.alpha / len(X),
                penalize_intercepts=False,
                epochs=self.epochs,
                random_state=0,
            ),
        ).fit(X, y)
        return self

    def predict(self, X):
        return self.pipeline_.predict(X)


def time_ordered_folds(n):
    """Expanding-window folds over ``n`` training rows (fit, score)."""
    return [
        (np.arange(int(a * n)), np.arange(int(a * n), int(b * n))) for a, b in CV_FOLDS
    ]


def search(estimator, grid, n):
    return GridSearchCV(
        estimator,
        grid,
        cv=time_ordered_folds(n),
        scoring="neg_root_mean_squared_error",
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=str(DEFAULT_DATA), help="shared data")
    parser.add_argument("--train-fraction", type=float, default=0.6)
    parser.add_argument(
        "--clusters", default="1,2,3", help="rule counts searched (comma list)"
    )
    parser.add_argument("--epochs", type=int, default=50)
    args = parser.parse_args(argv)
    try:
        table = load_fl_thermal(args.data)
    except (OSError, FileNotFoundError) as exc:
        print(f"FL_THERMAL not found under {args.data}: {exc}")
        return 2
    clusters = [int(c) for c in args.clusters.split(",") if c.strip()]
    temps = table[[f"T{i}_C" for i in range(1, 17)]].to_numpy(dtype=float)
    X = temps - temps[0]
    k = int(round(args.train_fraction * X.shape[0]))
    print(
        f"FL_THERMAL: {X.shape[0]} rows, 16 temperature changes; training rows "
        f"0-{k - 1}, held out {k}-{X.shape[0] - 1}; choices by time-ordered CV "
        f"on the training rows (fit first 50%/75%, score next 25%)\n"
    )
    print(
        "channel  LinReg   ridge (alpha)      ANFIS-FCM (rules, alpha)   "
        "ANFIS/ridge  ridge/LinReg  ANFIS/LinReg  time"
    )
    worse = []
    collapsed = 0
    for ch in range(1, 6):
        y = table[f"disp_ch{ch}_um"].to_numpy(dtype=float)
        y = y - y[0]
        linear = LinearRegression().fit(X[:k], y[:k])
        r_lin = rmse(linear.predict(X[k:]), y[k:])
        ridge = search(
            make_pipeline(StandardScaler(), Ridge()), {"ridge__alpha": ALPHAS}, k
        ).fit(X[:k], y[:k])
        r_ridge = rmse(ridge.predict(X[k:]), y[k:])
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            # Counted below, not printed one by one around the table.
            warnings.simplefilter("always", ConvergenceWarning)
            anfis = search(
                ANFISRidge(epochs=args.epochs),
                {"n_clusters": clusters, "alpha": ALPHAS},
                k,
            ).fit(X[:k], y[:k])
        elapsed = time.perf_counter() - t0
        collapsed += sum(issubclass(w.category, ConvergenceWarning) for w in caught)
        for w in caught:
            if not issubclass(w.category, ConvergenceWarning):
                warnings.showwarning(w.message, w.category, w.filename, w.lineno)
        r_anfis = rmse(anfis.predict(X[k:]), y[k:])
        ratio = r_anfis / r_ridge
        if r_anfis > r_ridge * (1 + 1e-6):
            worse.append(ch)
        best = anfis.best_params_
        alpha = ridge.best_params_["ridge__alpha"]
        print(
            f"ch{ch}      {r_lin:6.2f}   {r_ridge:6.2f} ({alpha:7.3g})"
            f"   {r_anfis:6.2f} ({best['n_clusters']}, {best['alpha']:7.3g})"
            f"          {ratio:6.2f}       {r_ridge / r_lin:6.2f}        "
            f"{r_anfis / r_lin:6.2f}  {elapsed:5.1f} s",
            flush=True,
        )
    print(
        f"\n{collapsed} ANFIS fits (of the CV's and the refits) warned that a "
        "premise step collapsed a membership function (Jang's step-size rule; "
        "the best epoch's parameters are kept)."
    )
    print(
        "ANFIS-FCM not worse than ridge on every channel: "
        + ("yes" if not worse else f"no (worse on ch{worse})")
    )
    return 1 if worse else 0


if __name__ == "__main__":
    sys.exit(main())
