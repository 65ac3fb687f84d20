"""
Plotting thermal-error models with Display objects
==================================================

:mod:`skthermal.plotting` has scikit-learn-style displays (as
:class:`sklearn.metrics.PredictionErrorDisplay`): a ``from_*`` class method
computes and draws, ``plot(ax=...)`` draws again, and the artists are kept as
attributes (``ax_``, ``figure_``, lines, bars, spans). This example draws all
four on the simulated heating and cooling tests of Machine B:

1. :class:`~skthermal.plotting.SensorScoreDisplay`: grey influence scores of
   the 77 temperature sensors, coloured by fuzzy c-means group;
2. :class:`~skthermal.plotting.PredictionDisplay`: measured and predicted Y
   error of held-out tests, with the residual band (001 Figs. 5-11 to 5-15);
3. :class:`~skthermal.plotting.MembershipFunctionDisplay`: an ANFIS model's
   membership functions before and after training;
4. :class:`~skthermal.plotting.GapTimelineDisplay`: the residual of a test
   shaded by operating regime.

Run: ``python examples/plot_displays.py`` (needs ``pip install
"skthermal[plot]"``).
"""

# %%
# Data: six simulated tests; tests IV (two heating phases) and V (8000 rpm)
# are held out.
import matplotlib.pyplot as plt
import numpy as np
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from skthermal import ANFISRegressor, FCMClusterPicker
from skthermal.datasets import make_machine_b_tests, split_runs
from skthermal.gap import label_regimes
from skthermal.plotting import (
    GapTimelineDisplay,
    MembershipFunctionDisplay,
    PredictionDisplay,
    SensorScoreDisplay,
)

runs = make_machine_b_tests(random_state=0)
X, y, groups = split_runs(runs, targets="disp_y_um")
train = np.isin(groups, ["I", "II", "III", "VI"])
X_train, y_train, X_test, y_test = X[train], y[train], X[~train], y[~train]

# %%
# Sensor scores
# -------------
# Fuzzy c-means groups sensors that behave alike and keeps the most
# influential sensor of each group (outlined bars).
picker = FCMClusterPicker(n_clusters=4, random_state=0).fit(X_train, y_train)
SensorScoreDisplay.from_estimator(picker, sort=True)
plt.tight_layout()

# %%
# Measured vs predicted
# ---------------------
# A linear model on the picked sensors, one column of panels per held-out
# test; ``run="V"`` would draw one test only.
model = make_pipeline(
    FCMClusterPicker(n_clusters=4, random_state=0), LinearRegression()
).fit(X_train, y_train)
display = PredictionDisplay.from_estimator(model, X_test, y_test)
display.figure_.tight_layout()
print(display.metrics_.round(3))

# %%
# Membership functions
# --------------------
# ANFIS with three fuzzy c-means rules on two standardised sensors.
sensors = picker.get_feature_names_out()[:2]
anfis = make_pipeline(
    StandardScaler().set_output(transform="pandas"),
    ANFISRegressor(n_clusters=3, epochs=30, random_state=0),
).fit(X_train[sensors], y_train)
MembershipFunctionDisplay.from_estimator(anfis[-1], which="both")
plt.tight_layout()

# %%
# Residual by regime
# ------------------
# Where does the linear model miss? Label every sample of test IV by what the
# machine was doing (:func:`skthermal.gap.label_regimes`: spindle running, the
# first hour after it stops, then standing) and shade the residual timeline.
test = runs[runs["run"] == "IV"]
residual = test["disp_y_um"].to_numpy() - model.predict(X[groups == "IV"])
time_s = test["time_s"].to_numpy()
regimes = label_regimes(time_s, test["spindle_rpm"])["regime"].to_numpy()
GapTimelineDisplay.from_arrays(time_s, residual, regimes, residual_name="residual (µm)")
plt.tight_layout()
plt.show()
