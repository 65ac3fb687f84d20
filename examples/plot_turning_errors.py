"""
Turning errors: decomposition and an ANFIS on cutting forces
============================================================

Li et al. (003) split the diametral error of a turned part with on-machine
measurements warm (``D_omw``) and cold (``D_omc``) and a post-process CMM
measurement (``D_pp``); the cold on-machine measurement alone gives the
aggregate of the thermal, force-induced and other errors,
``d_agg = D_omc - D_des``. An ANFIS on the spindle torque ``F_t D / 2`` and
the radial and axial forces predicts the line ``d_agg = a L + b`` along the
part. Here on synthetic parts from the stated model of
:func:`skthermal.turning.make_turning_errors`: 20 training parts drawn from the
cutting-condition levels of 003 §6, and the six test cases of 003 Table 1.

Run: ``python examples/plot_turning_errors.py`` (the plot needs the ``plot``
extra: ``pip install "skthermal[plot]"``).
"""

# %%
# Data, and the decomposition of the first test part.
import pandas as pd
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from skthermal import ANFISRegressor
from skthermal.turning import (
    TURNING_TEST_CONDITIONS,
    decompose_turning_error,
    make_turning_errors,
)

train, _ = make_turning_errors(20, random_state=0)
test, profiles = make_turning_errors(conditions=TURNING_TEST_CONDITIONS, random_state=1)
part = profiles[profiles["case"] == 1]
parts = decompose_turning_error(
    part["D_des_mm"],
    D_omw=part["D_omw_mm"],
    D_omc=part["D_omc_mm"],
    D_pp=part["D_pp_mm"],
)
print(parts.assign(L_mm=part["L_mm"].to_numpy()).round(2).to_string(index=False))

# %%
# ANFIS (3 fuzzy c-means rules, 3 inputs, outputs a and b) against a linear
# model on the same inputs.
inputs = ["torque_Nm", "F_r_N", "F_a_N"]
outputs = ["a_um_per_mm", "b_um"]
models = {
    "ANFIS": make_pipeline(
        StandardScaler(), ANFISRegressor(n_clusters=3, epochs=100, random_state=0)
    ),
    "linear": LinearRegression(),
}
measured = 1000 * (profiles["D_omc_mm"] - profiles["D_des_mm"])
predicted = {}
for name, model in models.items():
    ab = (
        pd.DataFrame(
            model.fit(train[inputs], train[outputs]).predict(test[inputs]),
            index=test.index,
        )
        .loc[profiles["case"]]
        .to_numpy()
    )
    predicted[name] = ab[:, 0] * profiles["L_mm"].to_numpy() + ab[:, 1]
    err = (predicted[name] - measured).abs().groupby(profiles["case"])
    print(f"{name}: |error| of d_agg over 10 positions per test case (µm)")
    print(err.agg(["max", "min", "mean"]).T.round(2))
print("003 Table 2 (ANFIS, real parts): mean 1.49 3.45 3.13 2.78 1.22 1.49 µm")

# %%
# Measured and predicted d_agg along the six test parts (003 Fig. 7).
try:
    import matplotlib.pyplot as plt
except ImportError:
    print('matplotlib is not installed: pip install "skthermal[plot]"')
else:
    fig, axes = plt.subplots(1, 6, figsize=(14, 3), sharey=True)
    for ax, (case, rows) in zip(axes, profiles.groupby("case"), strict=True):
        ax.plot(rows["L_mm"], measured[rows.index], "k*", label="measured")
        ax.plot(
            rows["L_mm"], predicted["ANFIS"][rows.index], "o", mfc="none", label="ANFIS"
        )
        ax.set_title(f"test {case}")
        ax.set_xlabel("L (mm)")
    axes[0].set_ylabel("d_agg (µm)")
    axes[0].legend()
    fig.tight_layout()
    plt.show()
