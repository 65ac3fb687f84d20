"""
Modular models: superposing single-source tests
===============================================

001 §5.4.1.3 trained one model on a Z-axis heating test and one on a C-axis
heating test and added them up to predict a combined (helical) test. The same
on the Machine-B-like simulator: a spindle-only test (8000 rpm) and a
feed-only test (the Y ball screw at 10 m/min) train two modules, each on the
sensors near its heat source; the combined test (6000 rpm and 8 m/min
together, warmer air) checks their sum.

Run: ``python examples/plot_modular_models.py`` (the plot needs the ``plot``
extra: ``pip install "skthermal[plot]"``).
"""

# %%
# Three simulated tests. The preset's feed heating is raised to 15 W per
# m/min so that the ball screw matters for Y (about 35 µm in its own test).
import pandas as pd
from sklearn.linear_model import LinearRegression

from skthermal.datasets import changes_since_start
from skthermal.ensemble import ModularRegressor
from skthermal.metrics import residual_band, rmse
from skthermal.simulate import DutyCycle, ThermalMachine

machine = ThermalMachine.from_preset("vmc-b", params={"feed_heating.W_per_m_min": 15.0})
spindle = machine.simulate(
    DutyCycle.heat_cool(8000, heat_h=2, cool_h=2),
    20.0,
    sample_period_s=60,
    run="spindle",
    random_state=0,
)
feed = machine.simulate(
    DutyCycle.heat_cool(0, heat_h=2, cool_h=2, feed_mm_min=10000),
    20.0,
    sample_period_s=60,
    run="feed",
    random_state=1,
)
combined = machine.simulate(
    DutyCycle([(3 * 3600, 6000, 8000), (3600, 0, 0)]),
    20.5,
    sample_period_s=60,
    run="combined",
    random_state=2,
)
target = "disp_y_um"
for run in (spindle, feed, combined):
    print(run["run"].iloc[0], f"max |Y| {run[target].abs().max():.1f} µm")

# %%
# Two modules: the spindle module reads the boss and carrier sensors, the axis
# module the Y bed and table sensors. Each is trained on its own test only.
head = ["T63_C", "T12_C", "T40_C", "T25_C"]
axis = ["T68_C", "T69_C", "T74_C"]
model = ModularRegressor(
    [("spindle", LinearRegression(), head), ("axis", LinearRegression(), axis)]
).fit_modules({"spindle": spindle, "axis": feed}, target=target)
truth = changes_since_start(combined, target)[target].to_numpy()
parts = model.predict_modules(combined[["run", *model.feature_names_in_]])
pred = parts.sum(axis=1)

# %%
# Against single models on the same seven sensors: trained on one test, and
# (an easier baseline that needs both tests too) on both tests pooled.
cols = head + axis
rel = {
    k: changes_since_start(v, cols + [target])
    for k, v in (("spindle", spindle), ("feed", feed), ("combined", combined))
}
rows = [("modular (spindle + axis modules)", pred)]
for name, data in (
    ("single model, spindle test", rel["spindle"]),
    ("single model, feed test", rel["feed"]),
    ("single model, both tests pooled", pd.concat([rel["spindle"], rel["feed"]])),
):
    single = LinearRegression().fit(data[cols], data[target])
    rows.append((name, single.predict(rel["combined"][cols])))
print(
    pd.DataFrame(
        [(n, rmse(truth, p), residual_band(truth, p)) for n, p in rows],
        columns=["model", "RMSE (µm)", "band (±µm)"],
    )
    .round(2)
    .to_string(index=False)
)

# %%
# The combined test and the two modules' contributions.
try:
    import matplotlib.pyplot as plt
except ImportError:
    print('matplotlib is not installed: pip install "skthermal[plot]"')
else:
    hours = combined["time_s"] / 3600
    fig, ax = plt.subplots(figsize=(8, 3.5))
    ax.plot(hours, truth, "k", label="simulated Y")
    ax.plot(hours, pred, "--", label="modular prediction")
    ax.plot(hours, parts[:, 0], ":", label="spindle module")
    ax.plot(hours, parts[:, 1], ":", label="axis module")
    ax.set_xlabel("h")
    ax.set_ylabel("µm")
    ax.legend()
    fig.tight_layout()
    plt.show()
