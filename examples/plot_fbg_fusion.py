"""
Fusing temperatures with FBG strain
===================================

001 §4.6 and §5.4 supplemented a few temperature sensors with fibre Bragg
grating (FBG) strain sensors on the structure. A grating also reads its own
temperature as an apparent strain of 8.64 µm/m per °C, corrected with the
temperature sensor next to it. Here three gratings are simulated on the
Machine-B-like simulator (carrier, column, spindle boss), corrected, and a
model on three temperatures is compared with one on the same three
temperatures plus the three strains: trained on test IV, tested on I, III, V.

Run: ``python examples/plot_fbg_fusion.py`` (the plot needs the ``plot``
extra: ``pip install "skthermal[plot]"``).
"""

# %%
# The gratings: where they are bonded (node weights), the member's expansion
# and, for the column, bending from the surface-core difference; each has a
# co-located temperature sensor for the correction.
import pandas as pd
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from skthermal import ANFISRegressor
from skthermal.datasets import changes_since_start
from skthermal.metrics import residual_band, rmse
from skthermal.sensors import FBGGauge, add_strain_channels, correct_strain_channels
from skthermal.simulate import AmbientProfile, DutyCycle, ThermalMachine

machine = ThermalMachine.from_preset("vmc-b")
gauges = {
    "carrier": FBGGauge({"carrier2": 0.5, "carrier3": 0.5}, sensor="T15_C"),
    "column": FBGGauge(
        {"column_surface": 0.5, "column_core": 0.5},
        gradient=("column_surface", "column_core"),
        bending_ue_per_C=3.0,
        sensor="T04_C",
    ),
    "boss": FBGGauge({"boss": 1.0}, sensor="T63_C"),
}


def simulate(duty, ambient, run, seed):
    runs, states = machine.simulate(
        duty,
        ambient,
        sample_period_s=60,
        run=run,
        random_state=seed,
        return_states=True,
    )
    raw = add_strain_channels(runs, states, gauges, random_state=seed)
    return raw, correct_strain_channels(raw)


# %%
# Tests IV (training), I, III and V of Machine B (METHODS §14).
raw_iv, train = simulate(
    DutyCycle.from_hours([(2, 4000), (1, 0), (2, 4000), (3, 0)]),
    AmbientProfile(mean_C=20.0, day_amplitude_C=0.4, start_hour=8.0),
    "IV",
    0,
)
tests = {
    "I": simulate(
        DutyCycle.heat_cool(4000, heat_h=1, cool_h=1),
        AmbientProfile(mean_C=20.5, trend_C_per_h=0.2),
        "I",
        1,
    )[1],
    "III": simulate(
        DutyCycle.heat_cool(4000, heat_h=3, cool_h=2),
        AmbientProfile(mean_C=21.5, trend_C_per_h=0.15),
        "III",
        2,
    )[1],
    "V": simulate(
        DutyCycle.heat_cool(8000, heat_h=1, cool_h=1),
        AmbientProfile(mean_C=20.0, trend_C_per_h=-0.1),
        "V",
        3,
    )[1],
}
strains = ["Scarrier_ue", "Scolumn_ue", "Sboss_ue"]
print("raw vs corrected strain at the end of heating (µε):")
print(
    pd.DataFrame(
        {"raw": raw_iv[strains].iloc[120], "corrected": train[strains].iloc[120]}
    ).round(1)
)

# %%
# Temperatures alone against temperatures + strains, with a linear model and
# an ANFIS (3 fuzzy c-means rules), all on changes since the start of a run.
temps = ["T15_C", "T04_C", "T63_C"]
target = "disp_y_um"
ctrain = changes_since_start(train)
ctests = {k: changes_since_start(v) for k, v in tests.items()}
rows = []
for inputs_name, cols in (
    ("temperatures", temps),
    ("temperatures + strains", temps + strains),
):
    for est in (
        LinearRegression(),
        ANFISRegressor(n_clusters=3, epochs=30, random_state=0),
    ):
        model = make_pipeline(StandardScaler(), est).fit(ctrain[cols], ctrain[target])
        for name, t in ctests.items():
            pred = model.predict(t[cols])
            rows.append(
                {
                    "inputs": inputs_name,
                    "model": type(est).__name__,
                    "test": name,
                    "RMSE": rmse(t[target], pred),
                    "band": residual_band(t[target], pred),
                }
            )
table = pd.DataFrame(rows).pivot_table(
    index=["inputs", "model"], columns="test", values="RMSE"
)
print("RMSE (µm) of the Y displacement on the unseen tests:")
print(table.round(2))

# %%
# Hysteresis (001 Fig. 4-25): displacement against a surface temperature and
# against the carrier strain over test IV.
try:
    import matplotlib.pyplot as plt
except ImportError:
    print('matplotlib is not installed: pip install "skthermal[plot]"')
else:
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.5))
    axes[0].plot(ctrain["T15_C"], ctrain[target])
    axes[0].set_xlabel("T15 change (°C)")
    axes[1].plot(ctrain["Scarrier_ue"], ctrain[target])
    axes[1].set_xlabel("carrier strain, corrected (µε)")
    for ax in axes:
        ax.set_ylabel("Y displacement (µm)")
    fig.suptitle("Test IV: surface temperature lags, strain follows")
    fig.tight_layout()
    plt.show()
