"""
Selecting a few temperature sensors from many
=============================================

Generated heating tests with three independent heat sources, each seen by ten
collinear sensors, plus ten sensors that only pick up unrelated temperature
wander. Grey influence, grey relational analysis and the fuzzy c-means picker
rank the sensors, and a compensation model built on the picked sensors is
scored on held-out runs.

Run: ``python examples/plot_sensor_selection.py`` (the plot needs the ``plot``
extra: ``pip install "skthermal[plot]"``).
"""

# %%
# Data: four runs, 40 sensors, one displacement.
import pandas as pd
from sklearn.linear_model import LinearRegression
from sklearn.model_selection import GroupKFold, cross_validate
from sklearn.pipeline import make_pipeline

from skthermal import FCMClusterPicker, GRASelector, GreyInfluenceSelector
from skthermal.datasets import make_sensor_groups, split_runs
from skthermal.metrics import thermal_scorers

runs, truth = make_sensor_groups(n_groups=3, n_runs=4, random_state=0)
X, y, groups = split_runs(runs)
print(X.shape, "run labels:", sorted(set(groups)))

# %%
# Rankings. The run boundaries come from X's (run, time_s) index.
ranking = pd.DataFrame(
    {
        "true group": truth,
        "GM(1,N) influence": GreyInfluenceSelector().fit(X, y).scores_,
        "similitude degree": GRASelector().fit(X, y).scores_,
    }
)
print(ranking.sort_values("GM(1,N) influence", ascending=False).head(10))

# %%
# One sensor per fuzzy group.
picker = FCMClusterPicker(n_clusters=3, random_state=0).fit(X, y)
picked = picker.get_feature_names_out()
print("picked:", list(picked), "true groups:", truth[picked].tolist())

# %%
# The papers' workflow as one Pipeline, scored on held-out runs.
model = make_pipeline(
    FCMClusterPicker(n_clusters=3, random_state=0), LinearRegression()
)
scores = cross_validate(
    model, X, y, groups=groups, cv=GroupKFold(n_splits=4), scoring=thermal_scorers()
)
print(pd.DataFrame(scores).filter(like="test_").mean().round(3))

# %%
# Memberships of every sensor in the three groups.
try:
    import matplotlib.pyplot as plt
except ImportError:
    print('matplotlib is not installed: pip install "skthermal[plot]"')
else:
    fig, ax = plt.subplots(figsize=(9, 3))
    ax.imshow(picker.memberships_.T, aspect="auto", cmap="viridis")
    ax.set_xticks(range(len(X.columns)), X.columns, rotation=90, fontsize=6)
    ax.set_ylabel("group")
    ax.set_title("Fuzzy memberships of the sensors (picked ones marked)")
    for j in picker.representatives_:
        ax.axvline(j, color="w", lw=0.8)
    fig.tight_layout()
    plt.show()
