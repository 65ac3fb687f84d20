"""
Guarding a compensation model against broken sensors
=====================================================

A compensation model moves a machine axis by what it predicts, so a broken
thermocouple must not become an absurd correction. ``GuardedRegressor``
wraps the model, remembers the range of every sensor and of the
displacement in training, and checks every prediction: a reading far outside
the training range, a sensor that jumps or stops changing, a prediction
outside the plausible band. By default it only warns; ``mode="hold"`` holds
the last good compensation while a sensor is faulty and says so per row.

Tests I, II, III and V of the simulated Machine B train a ridge model on four
sensors chosen by grey relational analysis; test IV is then "measured" with
three faults on the chosen sensors: a spike to 1e6 (a broken thermocouple),
a reading stuck for 90 minutes and a slow drift (a loose sensor). The drift
pulls the prediction out of its plausible band about 1.5 hours before the
sensor itself leaves its training range: the output band is the last line
of defence.

Run: ``python examples/plot_sensor_guard.py`` (the plot needs the ``plot``
extra: ``pip install "skthermal[plot]"``).
"""

# %%
# Train the model and wrap it. ``inputs`` names the sensors the model reads:
# a fault on one of the 73 others must not hold the compensation.
import warnings

import numpy as np
from sklearn.linear_model import Ridge
from sklearn.pipeline import make_pipeline

from skthermal.compose import GuardedRegressor, GuardWarning
from skthermal.datasets import make_machine_b_tests, split_runs
from skthermal.selection import GRASelector

runs = make_machine_b_tests(random_state=0)
X, y, groups = split_runs(runs, targets="disp_y_um")
train = groups != "IV"
model = make_pipeline(GRASelector(n_features_to_select=4), Ridge())
used = list(model.fit(X[train], y[train])[:-1].get_feature_names_out())
print("sensors read by the model:", used)

guard = GuardedRegressor(model, inputs=used, mode="hold").fit(X[train], y[train])

# %%
# Test IV as measured, and with three faults (30 s samples; run time in h).
X_iv, y_iv = X[~train], y[~train]
hours = X_iv.index.get_level_values("time_s").to_numpy() / 3600.0
broken = X_iv.copy()
spike, stuck, drift = used[0], used[1], used[2]
broken.loc[(hours > 2.0) & (hours < 2.1), spike] = 1e6
frozen = np.flatnonzero((hours >= 3.0) & (hours < 4.5))
broken.iloc[frozen, broken.columns.get_loc(stuck)] = broken[stuck].iloc[frozen[0]]
broken[drift] += np.clip(hours - 5.0, 0.0, None) * 4.0  # 4 °C per hour

with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always", GuardWarning)
    checked = guard.predict_checked(broken)
for w in caught:
    print(f"{w.category.__name__}: {w.message}\n")

# %%
# What the controller reads: per row the value to apply, ok, action, reason.
print(checked[~checked["ok"]].head(8))
print(checked.groupby(["action", "reason"]).size().to_string())

# %%
# Without the guard the spike alone would ask for a correction of this size:
unguarded = guard.estimator_.predict(broken)
print(f"largest unguarded prediction: {np.abs(unguarded).max():.3g} µm")
print(f"largest guarded prediction:   {checked['prediction'].abs().max():.3g} µm")
print(f"largest measured displacement: {np.abs(y_iv).max():.3g} µm")

# %%
# Measured error, the guarded compensation and where it was held.
try:
    import matplotlib.pyplot as plt
except ImportError:
    print('matplotlib is not installed: pip install "skthermal[plot]"')
else:
    fig, ax = plt.subplots(figsize=(10, 4))
    ax.plot(hours, y_iv.to_numpy(), color="0.6", label="measured (test IV)")
    ax.plot(hours, guard.estimator_.predict(X_iv), label="model, healthy sensors")
    ax.plot(hours, checked["prediction"], label="guarded, faulty sensors")
    held = checked["action"].to_numpy() == "held"
    ax.fill_between(
        hours,
        0,
        1,
        where=held,
        transform=ax.get_xaxis_transform(),
        color="tab:red",
        alpha=0.15,
        label="held",
    )
    ax.set_xlabel("time (h)")
    ax.set_ylabel("Y displacement (µm)")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    plt.show()
