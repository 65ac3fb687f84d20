"""
ANFIS on Jang's Mackey-Glass example
====================================

Jang's 1993 ANFIS paper predicts the chaotic Mackey-Glass series six steps
ahead, ``x(t+6)`` from ``x(t-18), x(t-12), x(t-6), x(t)``, with two bell
membership functions per input (16 rules, 104 parameters), trained by his
hybrid rule on 500 rows and checked on 500 others. This example

1. sets Jang's published trained model into :class:`~skthermal.fuzzy.ANFISRegressor`
   and reproduces the paper's RMSE (0.00148 training, 0.00163 checking);
2. trains the same structure from Jang's initial membership functions;
3. shows the learning curves, the membership functions before and after
   training, the rules as text, and the checking-set prediction.

The data are not shipped with skthermal: the script reads ``ex4.trn``,
``ex4.chk`` and ``jang_consequents.csv`` from the folder given as its first
argument (default: ``../shared/data/mackey_glass`` beside the repository).

Run: ``python examples/plot_anfis_mackey_glass.py [folder]`` (the plots need
the ``plot`` extra: ``pip install "skthermal[plot]"``).
"""

# %%
# The data: four lagged values of the series and the value six steps ahead,
# as DataFrames so that the rules read with the inputs' names.
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from skthermal.fuzzy import ANFISRegressor

try:
    HERE = Path(__file__).resolve().parent
except NameError:  # run inside a notebook
    HERE = Path.cwd()
FOLDER = Path(
    sys.argv[1]
    if len(sys.argv) > 1 and not sys.argv[1].startswith("-")
    else HERE.parents[1] / "shared" / "data" / "mackey_glass"
)
if not (FOLDER / "ex4.trn").exists():
    sys.exit(f"Mackey-Glass data not found in {FOLDER}; pass the folder.")
trn = np.loadtxt(FOLDER / "ex4.trn")
chk = np.loadtxt(FOLDER / "ex4.chk")
names = ["x(t-18)", "x(t-12)", "x(t-6)", "x(t)"]
X_trn, y_trn = pd.DataFrame(trn[:, :4], columns=names), trn[:, 4]
X_chk, y_chk = pd.DataFrame(chk[:, :4], columns=names), chk[:, 4]


def rmse(pred, y):
    return float(np.sqrt(np.mean((pred - y) ** 2)))


# %%
# Jang's trained model. Bell membership functions ``1 / (1 + |(x - c)/a|^(2b))``
# are stored as ``(a, b, c)``, two per input in column order; the 16 rules
# combine them with the first input varying slowest, and each rule's
# consequent is ``p1..p4`` then the constant.
jang_mfs = np.array(
    [
        [(0.1790, 2.0456, 0.4798), (0.1584, 2.0103, 1.4975)],
        [(0.2410, 1.9533, 0.2960), (0.2923, 1.9178, 1.7824)],
        [(0.3798, 2.1490, 0.6599), (0.4884, 1.8967, 1.6465)],
        [(0.2815, 2.0170, 0.3341), (0.1616, 2.0165, 1.4727)],
    ]
)
consequents = np.loadtxt(FOLDER / "jang_consequents.csv", delimiter=",", skiprows=1)
jang = ANFISRegressor.from_parameters(
    mf="gbell", mf_params=jang_mfs, consequents=consequents, feature_names=names
)
print(
    f"Jang's model: RMSE training {rmse(jang.predict(X_trn), y_trn):.5f} "
    f"(paper 0.00148), checking {rmse(jang.predict(X_chk), y_chk):.5f} "
    "(paper 0.00163)"
)

# %%
# Training from scratch. Jang's initial functions are evenly spaced over the
# range of the data (``init="grid"`` computes them from the training rows; here
# they are given exactly, from the paper). The step size is in the units of
# the inputs, which span less than one unit here, so it starts at 0.1 rather
# than the default 0.5. The checking rows pick the epoch to keep.
initial = np.array([[[0.444045, 2.0, 0.425606], [0.444045, 2.0, 1.313696]]] * 4)
model = ANFISRegressor(init=initial, mf="gbell", epochs=300, step_size=0.1)
model.fit(X_trn, y_trn, X_val=X_chk, y_val=y_chk)
print(
    f"Trained: best epoch {model.best_epoch_}, RMSE training "
    f"{rmse(model.predict(X_trn), y_trn):.5f}, checking "
    f"{rmse(model.predict(X_chk), y_chk):.5f}"
)

# %%
# The first rules, as text.
print("\n".join(model.describe_rules(precision=3).splitlines()[:3]))

# %%
# Learning curves and step size, membership functions before (dashed) and
# after (solid) training, and the checking-set prediction.
try:
    import matplotlib.pyplot as plt
except ImportError:  # the plot extra is not installed
    plt = None

if plt is not None:
    hist = model.history_
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.2))
    ax1.semilogy(hist["epoch"], hist["train_rmse"], label="training")
    ax1.semilogy(hist["epoch"], hist["val_rmse"], label="checking")
    ax1.axvline(model.best_epoch_, color="grey", lw=0.8)
    ax1.set_xlabel("epoch")
    ax1.set_ylabel("RMSE")
    ax1.legend()
    ax2.semilogy(hist["epoch"], hist["step_size"])
    ax2.set_xlabel("epoch")
    ax2.set_ylabel("step size")
    fig.tight_layout()

    model.plot_membership_functions(which="both")
    plt.gcf().tight_layout()

    fig, ax = plt.subplots(figsize=(9, 3))
    ax.plot(y_chk, color="black", lw=1, label="Mackey-Glass x(t+6)")
    ax.plot(model.predict(X_chk), lw=1, ls="--", label="ANFIS")
    ax.plot(100 * (model.predict(X_chk) - y_chk), lw=0.8, label="error x 100")
    ax.set_xlabel("checking sample")
    ax.legend(fontsize="small")
    fig.tight_layout()
    plt.show()
