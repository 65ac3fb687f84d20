"""
Stable sensor selection and update regression over a 20-batch campaign
======================================================================

The workflow of Liu et al. (2022): temperature-sensitive points chosen by
their uncertainty-correlation coefficient, a ridge model per batch, the
three-level RMSE of eq. 16, and a model that updates itself from six new
samples whenever the compensated residual exceeds 7 µm over a long run of
changing machining states (their §4.3.1: 10 updates in 76 h, residual within
10 µm).

The campaign is simulated: 20 four-hour batches of the Machine-B-like preset,
each at its own spindle speed, feed and cutting share, separated by rests of
random length, so a batch may start on a warm machine at any hour of the
workshop's day.

Run: ``python examples/plot_update_regression.py`` (the plot needs the
``plot`` extra: ``pip install "skthermal[plot]"``).
"""

# %%
# The campaign: 20 batches, one sample per 4-minute cycle.
from collections import Counter

import pandas as pd
from sklearn.pipeline import make_pipeline

from skthermal.datasets import changes_since_start
from skthermal.linear_model import (
    UpdateRegressor,
    adaptive_compensation,
    make_batch_campaign,
)
from skthermal.metrics import cross_batch_rmse
from skthermal.selection import FuzzyEquivalenceSelector, StableTSPSelector

runs = make_batch_campaign(n_batches=20, random_state=0)
meta = pd.DataFrame(runs.attrs["metadata"]).set_index("run")
print(meta[["spindle_rpm", "feed_mm_min", "cut_fraction", "rest_before_h"]].head())

sensors = [c for c in runs if c.startswith("T")]
target = "disp_y_um"
changes = changes_since_start(runs)  # 004 subtracts the first measurement
X, y, batches = changes[sensors], changes[target], changes["run"]

# %%
# Temperature-sensitive points chosen on each batch separately: how often does
# the chosen pair change? (004 Table 2: the stable selection varies less.)
stable, clustered = Counter(), Counter()
for _, rows in changes.groupby("run", sort=False):
    one_run = {"groups": rows["run"]}  # the batch is one run
    s = StableTSPSelector(n_features_to_select=2).fit(
        rows[sensors], rows[target], **one_run
    )
    f = FuzzyEquivalenceSelector(n_groups=2).fit(rows[sensors], rows[target], **one_run)
    stable[tuple(s.get_feature_names_out())] += 1
    clustered[tuple(f.get_feature_names_out())] += 1
print("distinct pairs, stable selection:", len(stable), stable.most_common(3))
print("distinct pairs, fuzzy clustering:", len(clustered), clustered.most_common(3))

# %%
# Three-level RMSE (004 eq. 16): model Mi fitted on batch i predicts every
# batch j; mean over batches per model; mean over models per method.
methods = {
    "stable + ridge": make_pipeline(StableTSPSelector(), UpdateRegressor()),
    "clustering + ridge": make_pipeline(
        FuzzyEquivalenceSelector(n_groups=2), UpdateRegressor()
    ),
    "stable + OLS": make_pipeline(StableTSPSelector(), UpdateRegressor(alpha=0.0)),
    "clustering + OLS": make_pipeline(
        FuzzyEquivalenceSelector(n_groups=2), UpdateRegressor(alpha=0.0)
    ),
}
levels = cross_batch_rmse(methods, X, y, batches)
print(levels.per_method.round(2))
# The same on absolute readings instead of changes since each batch's start:
absolute = cross_batch_rmse(
    {"stable + ridge": methods["stable + ridge"]},
    runs[sensors],
    runs[target],
    runs["run"],
)
print("stable + ridge on absolute readings:", absolute.per_method.iloc[0, 0].round(2))

# %%
# Adaptive compensation: the model of B1 compensates B2..B20 (76 h). When the
# residual exceeds 7 µm, six new samples are measured and the model updated.
first = changes[changes["run"] == "B1"]
tsp = list(
    StableTSPSelector()
    .fit(first[sensors], first[target], groups=first["run"])
    .get_feature_names_out()
)
model = UpdateRegressor(alpha=25.0, eta=0.1).fit(first[tsp], first[target])
rest = runs[runs["run"] != "B1"]
adaptive = adaptive_compensation(model, rest, target=target, threshold_um=7.0)
fixed = adaptive_compensation(model, rest, target=target, update=False)
auto = adaptive_compensation(model, rest, target=target, n_update="auto")
print("TSPs:", tsp)
print(
    pd.DataFrame(
        {
            "no update": fixed.summary(),
            "update, 6 samples": adaptive.summary(),
            "update, stability rule": auto.summary(),
        }
    ).round(3)
)
print(adaptive.updates[["run", "time_s", "residual_um", "n_samples"]])

# %%
# Error and residual along the campaign.
try:
    import matplotlib.pyplot as plt
except ImportError:
    print('matplotlib is not installed: pip install "skthermal[plot]"')
else:
    hours = (pd.RangeIndex(len(rest)) * adaptive.sample_period_s) / 3600.0
    measured = changes_since_start(rest)[target].to_numpy()
    fig, ax = plt.subplots(figsize=(10, 4))
    ax.plot(hours, measured, color="0.7", label="thermal error (change in batch)")
    ax.plot(hours, fixed.residual.to_numpy(), label="residual, no update")
    ax.plot(hours, adaptive.residual.to_numpy(), label="residual, update regression")
    ax.plot(
        hours[adaptive.updates["row"].to_numpy()],
        adaptive.updates["residual_um"],
        "kv",
        label="update",
    )
    for bound in (-10, 10):
        ax.axhline(bound, color="k", lw=0.5, ls="--")
    ax.set_xlabel("campaign time without rests (h)")
    ax.set_ylabel("µm")
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    plt.show()
